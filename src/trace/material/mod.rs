//! The materials as the path tracer shades them: the device table
//! (`DeviceMaterial`, `PtMaterial` in the generated `kernels/generated/pt_types.h`) made
//! from the scene's `MaterialTable`, and the plain Rust reference of the
//! glTF metallic-roughness BSDF (`bsdf_eval`, `bsdf_pdf`, `bsdf_sample`)
//! that `kernels/trace/bsdf.h` mirrors operation for operation.
//!
//! The model is the specification's Appendix B: Lambert diffuse and GGX
//! specular with height-correlated Smith masking, the dielectric weighted by
//! a 4 % Schlick Fresnel and blended by `metallic` towards a conductor whose
//! Schlick Fresnel starts at the base colour. `--clay` replaces it with a
//! pure Lambertian of albedo 0.8.
//!
//! With `BsdfParams::dielectric` set (the kernels' `HAS_TRANSMISSION`),
//! KHR_materials_ior sets the dielectric's F0 and KHR_materials_transmission
//! replaces the share `transmission` of the diffuse lobe by a GGX
//! transmission lobe tinted by the base colour: thin-walled (the reflection
//! lobe mirrored to the far side, no bending) or, with KHR_materials_volume,
//! refracting (Walter et al. 2007, as pbrt-v4's `DielectricBxDF`, including
//! its 1/eta^2 radiance scaling). Fresnel stays Schlick's, taken on the
//! optically thinner side and 1 under total internal reflection.
//! KHR_materials_diffuse_transmission (the kernels' `HAS_DIFFUSE_TRANSMISSION`)
//! moves the share `diffuse_transmission` of what stays of the diffuse lobe
//! to a Lambertian transmission lobe of its own colour, weighted by the
//! Fresnel the diffuse reflection would have at the mirror of wi.
//! KHR_materials_iridescence (`HAS_IRIDESCENCE`) mixes every Fresnel of the
//! dielectric layer and of the metal towards a thin film's
//! (`thin_film_fresnel`, Belcour and Barla 2017, as the extension gives it).

// `!(x > 0.0)` is meant: it is also true for NaN, as in the kernels.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

mod bsdf;
mod dielectric;
mod inputs;
mod layering;

pub use inputs::{inputs_fill_code, inputs_struct_code};

pub use bsdf::{
    anisotropic_alpha, bsdf_eval, bsdf_eval_lobes, bsdf_only_delta, bsdf_pdf, bsdf_sample,
    ggx_alpha, ggx_smooth, shadow_straight_through, sheen_lobe, sheen_scaling, smooth_reflectance,
    spec_probability, thin_straight_through, BsdfParams, BsdfSample, Layers, LobeSplit,
    MIN_GGX_ALPHA, SHEEN_MIN_ROUGHNESS, SMOOTH_GGX_ALPHA,
};
pub use dielectric::{
    eon_eval, eon_fon_albedo, f0_of_ior, fresnel_dielectric, fresnel_dielectric3,
    lobe_probabilities, thin_film_fresnel, Dielectric,
};

use bytemuck::{Pod, Zeroable};

use crate::device_struct::ConstDef;
use crate::device_struct::{device_consts, device_struct};
use crate::scene::material::{define_name, device_factors, DEVICE_FACTOR_FLOATS};
use crate::scene::{AlphaMode, Material, MaterialTable};
use crate::trace::texture::Slot;

device_consts! {
    fn material_consts;
    /// Material flags (`PtMaterial.flags`): both faces are shaded.
    pub const MAT_DOUBLE_SIDED: u32 = 1;
    pub const MAT_ALPHA_MASK: u32 = 2;
    pub const MAT_ALPHA_BLEND: u32 = 4;
    pub const MAT_EMISSIVE: u32 = 8;
    /// KHR_materials_unlit (read only by kernels built with `HAS_UNLIT`).
    pub const MAT_UNLIT: u32 = 16;
    /// `--backface-culling`: rays pass through the material's back faces, as a
    /// rasterizer culls them (set on single-sided materials only).
    pub const MAT_CULL_BACK: u32 = 32;
}

device_struct! {
/// One material as the device shades it. Texture
/// slots index the texture bindings, -1 for none.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct DeviceMaterial as "PtMaterial" {
    pub base_color: [f32; 4],
    pub emissive: [f32; 4],
    pub metallic: f32,
    pub roughness: f32,
    pub alpha_cutoff: f32,
    pub normal_scale: f32,
    pub flags: u32,
    pub base_color_tex: i32,
    pub metallic_roughness_tex: i32,
    pub normal_tex: i32,
    pub emissive_tex: i32,
    pub pad: [u32; 3],
}
}

const _: () = assert!(std::mem::size_of::<DeviceMaterial>() == 80);

impl DeviceMaterial {
    /// A material's factors and flags, with no texture bound (the caller
    /// fills the texture slots when textures are compiled in).
    pub fn from_material(m: &Material) -> DeviceMaterial {
        let e = m.emissive_factor;
        let s = m.emissive_strength;
        let emissive = [e[0] * s, e[1] * s, e[2] * s, 0.0];
        let emits = emissive[..3].iter().any(|&c| c > 0.0 && c.is_finite());
        let mut flags = 0;
        // A volume's inside is seen through its back faces, so a refracting
        // material is two-sided whatever `doubleSided` says.
        if m.double_sided || m.has_volume() {
            flags |= MAT_DOUBLE_SIDED;
        }
        match m.alpha_mode {
            AlphaMode::Opaque => {}
            AlphaMode::Mask => flags |= MAT_ALPHA_MASK,
            AlphaMode::Blend => flags |= MAT_ALPHA_BLEND,
        }
        if emits {
            flags |= MAT_EMISSIVE;
        }
        if m.unlit {
            flags |= MAT_UNLIT;
        }
        DeviceMaterial {
            base_color: m.base_color_factor,
            emissive,
            metallic: m.metallic_factor,
            roughness: m.roughness_factor,
            alpha_cutoff: m.alpha_cutoff,
            normal_scale: m.normal_scale,
            flags,
            base_color_tex: -1,
            metallic_roughness_tex: -1,
            normal_tex: -1,
            emissive_tex: -1,
            pad: [0; 3],
        }
    }

    pub fn emits(&self) -> bool {
        self.flags & MAT_EMISSIVE != 0
    }
}

/// The device table for `table`: one entry per material, then the glTF
/// default material, which out-of-range ids (and soups without material
/// ids) fall back to.
pub fn device_materials(table: &MaterialTable) -> Vec<DeviceMaterial> {
    let mut v: Vec<DeviceMaterial> = table
        .materials
        .iter()
        .map(DeviceMaterial::from_material)
        .collect();
    v.push(DeviceMaterial::from_material(&Material::default()));
    v
}

device_struct! {
/// A material's extension factors (dielectric, coats, sheen, diffuse
/// transmission, iridescence, anisotropy, dispersion), in a table beside
/// the materials that only kernels built with `HAS_MATERIAL_EXT` read.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct DeviceMaterialExt as "PtMaterialExt" {
    /// The factors the kernels read as the file sets them: each row of
    /// `scene::material::FACTORS` marked `on_device`, in the table's
    /// order (a colour takes three floats). The kernels index it with the
    /// generated `F_<KEY>` defines.
    pub factor: [f32; DEVICE_FACTOR_FLOATS],
    /// 1 when transmissive with a volume (refraction, attenuation), 0
    /// thin-walled.
    pub volume: f32,
    /// The volume's attenuation coefficient per unit length,
    /// `-ln(attenuationColor) / attenuationDistance` (rgb, 0).
    pub sigma: [f32; 4],
    /// The cosine and sine of KHR_materials_anisotropy's
    /// `anisotropyRotation` (counter-clockwise from the tangent), taken
    /// here once rather than at every hit.
    pub anisotropy_cos: f32,
    pub anisotropy_sin: f32,
    /// Texture binding indices (-1: none) of the extensions' textures, in
    /// `Slot::EXT` order. The kernels index it with the generated
    /// `TEX_<SLOT>` defines.
    pub tex: [i32; Slot::EXT_COUNT],
}
}

/// `F_<KEY>`: where each factor the kernels read starts in
/// `PtMaterialExt.factor`; `TEX_<SLOT>`: each extension texture's index in
/// `PtMaterialExt.tex`.
pub fn material_ext_consts() -> Vec<ConstDef> {
    let factors = device_factors().map(|(at, name, _)| (name, at));
    let textures = (Slot::EXT.iter().enumerate())
        .map(|(i, slot)| (define_name("TEX", &format!("{slot:?}")), i));
    factors
        .chain(textures)
        .map(|(name, value)| ConstDef {
            name: name.into(),
            value: value as u32,
            doc: Vec::new(),
        })
        .collect()
}

impl DeviceMaterialExt {
    pub fn from_material(m: &Material) -> DeviceMaterialExt {
        let d = m.attenuation_distance;
        let sigma = |c: f32| {
            if !(d > 0.0) || d.is_infinite() || c >= 1.0 {
                0.0
            } else if !(c > 0.0) {
                f32::MAX
            } else {
                -c.ln() / d
            }
        };
        let a = m.attenuation_color;
        let mut factor = [0.0; DEVICE_FACTOR_FLOATS];
        for (at, _, f) in device_factors() {
            let v = f.values(m);
            factor[at..at + v.len()].copy_from_slice(v);
        }
        DeviceMaterialExt {
            factor,
            volume: if m.has_volume() { 1.0 } else { 0.0 },
            sigma: [sigma(a[0]), sigma(a[1]), sigma(a[2]), 0.0],
            anisotropy_cos: m.anisotropy_rotation.cos(),
            anisotropy_sin: m.anisotropy_rotation.sin(),
            tex: [-1; Slot::EXT_COUNT],
        }
    }
}

/// The extension table beside `device_materials` (same order, the default
/// material last).
pub fn device_material_exts(table: &MaterialTable) -> Vec<DeviceMaterialExt> {
    let mut v: Vec<DeviceMaterialExt> = table
        .materials
        .iter()
        .map(DeviceMaterialExt::from_material)
        .collect();
    v.push(DeviceMaterialExt::from_material(&Material::default()));
    v
}
