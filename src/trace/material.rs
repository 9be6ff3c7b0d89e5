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

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::energy::{ggx_albedo, sheen_albedo};
use super::sampling::{
    cos_sin_turns, luminance, sample_cosine_hemisphere, sample_uniform_hemisphere, INV_PI, PI,
};
use crate::device_struct::{device_consts, device_struct};
use crate::scene::{AlphaMode, Material, MaterialTable};

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
    /// KHR_materials_transmission `transmissionFactor`.
    pub transmission: f32,
    /// KHR_materials_ior `ior`.
    pub ior: f32,
    /// 1 when transmissive with a volume (refraction, attenuation), 0
    /// thin-walled.
    pub volume: f32,
    /// KHR_materials_specular `specularFactor`.
    pub specular: f32,
    /// The volume's attenuation coefficient per unit length,
    /// `-ln(attenuationColor) / attenuationDistance` (rgb, 0).
    pub sigma: [f32; 4],
    /// KHR_materials_specular `specularColorFactor` (rgb, 0).
    pub specular_color: [f32; 4],
    /// Texture binding indices (-1: none) of `transmissionTexture` (R),
    /// `specularTexture` (A) and `specularColorTexture` (RGB, sRGB).
    pub transmission_tex: i32,
    pub specular_tex: i32,
    pub specular_color_tex: i32,
    /// KHR_materials_clearcoat `clearcoatFactor`.
    pub clearcoat: f32,
    /// KHR_materials_clearcoat `clearcoatRoughnessFactor`.
    pub clearcoat_roughness: f32,
    /// KHR_materials_sheen `sheenRoughnessFactor`.
    pub sheen_roughness: f32,
    /// Texture binding indices (-1: none) of `clearcoatTexture` (R) and
    /// `clearcoatRoughnessTexture` (G).
    pub clearcoat_tex: i32,
    pub clearcoat_roughness_tex: i32,
    /// KHR_materials_sheen `sheenColorFactor` (rgb, 0).
    pub sheen_color: [f32; 4],
    /// Texture binding indices (-1: none) of `sheenColorTexture` (RGB,
    /// sRGB), `sheenRoughnessTexture` (A) and `clearcoatNormalTexture`.
    pub sheen_color_tex: i32,
    pub sheen_roughness_tex: i32,
    pub clearcoat_normal_tex: i32,
    /// `clearcoatNormalTexture.scale`.
    pub clearcoat_normal_scale: f32,
    /// KHR_materials_diffuse_transmission `diffuseTransmissionFactor`.
    pub diffuse_transmission: f32,
    /// Texture binding indices (-1: none) of `diffuseTransmissionTexture`
    /// (A) and `diffuseTransmissionColorTexture` (RGB, sRGB).
    pub diffuse_transmission_tex: i32,
    pub diffuse_transmission_color_tex: i32,
    pub pad: f32,
    /// KHR_materials_diffuse_transmission `diffuseTransmissionColorFactor`
    /// (rgb, 0).
    pub diffuse_transmission_color: [f32; 4],
    /// KHR_materials_iridescence `iridescenceFactor`, `iridescenceIor`,
    /// `iridescenceThicknessMinimum` and `iridescenceThicknessMaximum` (nm).
    pub iridescence: f32,
    pub iridescence_ior: f32,
    pub iridescence_thickness_min: f32,
    pub iridescence_thickness_max: f32,
    /// Texture binding indices (-1: none) of `iridescenceTexture` (R) and
    /// `iridescenceThicknessTexture` (G).
    pub iridescence_tex: i32,
    pub iridescence_thickness_tex: i32,
    /// KHR_materials_anisotropy `anisotropyStrength`, and the cosine and
    /// sine of `anisotropyRotation` (counter-clockwise from the tangent),
    /// taken here once rather than at every hit.
    pub anisotropy_strength: f32,
    pub anisotropy_cos: f32,
    pub anisotropy_sin: f32,
    /// Texture binding index (-1: none) of `anisotropyTexture` (RG: the
    /// direction in tangent space, B: the strength).
    pub anisotropy_tex: i32,
    /// KHR_materials_dispersion `dispersion` (20 / Abbe number, 0: none).
    pub dispersion: f32,
    pub pad2: f32,
}
}

const _: () = assert!(std::mem::size_of::<DeviceMaterialExt>() == 192);

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
        DeviceMaterialExt {
            transmission: m.transmission_factor,
            ior: m.ior,
            volume: if m.has_volume() { 1.0 } else { 0.0 },
            specular: m.specular_factor,
            sigma: [sigma(a[0]), sigma(a[1]), sigma(a[2]), 0.0],
            specular_color: [
                m.specular_color[0],
                m.specular_color[1],
                m.specular_color[2],
                0.0,
            ],
            transmission_tex: -1,
            specular_tex: -1,
            specular_color_tex: -1,
            clearcoat: m.clearcoat_factor,
            clearcoat_roughness: m.clearcoat_roughness,
            sheen_roughness: m.sheen_roughness,
            clearcoat_tex: -1,
            clearcoat_roughness_tex: -1,
            sheen_color: [m.sheen_color[0], m.sheen_color[1], m.sheen_color[2], 0.0],
            sheen_color_tex: -1,
            sheen_roughness_tex: -1,
            clearcoat_normal_tex: -1,
            clearcoat_normal_scale: m.clearcoat_normal_scale,
            diffuse_transmission: m.diffuse_transmission,
            diffuse_transmission_tex: -1,
            diffuse_transmission_color_tex: -1,
            pad: 0.0,
            diffuse_transmission_color: [
                m.diffuse_transmission_color[0],
                m.diffuse_transmission_color[1],
                m.diffuse_transmission_color[2],
                0.0,
            ],
            iridescence: m.iridescence,
            iridescence_ior: m.iridescence_ior,
            iridescence_thickness_min: m.iridescence_thickness_min,
            iridescence_thickness_max: m.iridescence_thickness_max,
            iridescence_tex: -1,
            iridescence_thickness_tex: -1,
            anisotropy_strength: m.anisotropy_strength,
            anisotropy_cos: m.anisotropy_rotation.cos(),
            anisotropy_sin: m.anisotropy_rotation.sin(),
            anisotropy_tex: -1,
            dispersion: m.dispersion,
            pad2: 0.0,
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

/// The dielectric extensions at one point (`HAS_TRANSMISSION` only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Normal-incidence reflectance, `((ior - 1) / (ior + 1))^2`.
    pub f0: f32,
    /// The coloured F0 of KHR_materials_specular, `min(f0 * color, 1)`.
    pub f0_color: Vec3,
    /// Share of the diffuse lobe that transmits.
    pub transmission: f32,
    /// Relative index: the far side's over wo's side (1 thin-walled).
    pub eta: f32,
    /// Thin-walled: transmission goes straight through, unbent.
    pub thin: bool,
    /// KHR_materials_diffuse_transmission: the share of the (untransmitted)
    /// diffuse lobe that is transmitted diffusely, 0 without it.
    pub diffuse_transmission: f32,
    /// The diffusely transmitted light's colour (white without it).
    pub diffuse_transmission_color: Vec3,
    /// KHR_materials_iridescence: the thin film's weight (0: none), its
    /// index and its thickness in nanometres.
    pub iridescence: f32,
    pub iridescence_ior: f32,
    pub iridescence_thickness: f32,
}

impl Dielectric {
    /// For a material of index `ior` in air, seen from outside (`front`)
    /// or inside; `volume`: refracting rather than thin-walled.
    pub fn new(ior: f32, transmission: f32, volume: bool, front: bool) -> Dielectric {
        Dielectric::nested(ior, 1.0, transmission, volume, front)
    }

    /// With index `n_other` on the surface's other side (for a thin-walled
    /// surface, the volume it is in; `trace::media`): F0 from the relative
    /// index `ior / n_other`, and for a volume the relative index
    /// `media::relative_eta`. Mirrors `pt_dielectric_params` in
    /// `kernels/trace/pathtrace.cl`.
    pub fn nested(
        ior: f32,
        n_other: f32,
        transmission: f32,
        volume: bool,
        front: bool,
    ) -> Dielectric {
        let eta = if volume {
            super::media::relative_eta(ior, n_other, front)
        } else {
            1.0
        };
        let f0 = super::media::relative_f0(ior, n_other);
        Dielectric {
            f0,
            f0_color: Vec3::splat(f0),
            transmission: transmission.clamp(0.0, 1.0),
            eta,
            thin: !volume,
            diffuse_transmission: 0.0,
            diffuse_transmission_color: Vec3::ONE,
            iridescence: 0.0,
            iridescence_ior: 1.3,
            iridescence_thickness: 400.0,
        }
    }
}

impl Dielectric {
    /// With KHR_materials_specular's `specularColorFactor` (the factor is
    /// `BsdfParams::specular`).
    pub fn with_specular_color(self, color: [f32; 3]) -> Dielectric {
        Dielectric {
            f0_color: (Vec3::splat(self.f0) * Vec3::from(color)).min(Vec3::ONE),
            ..self
        }
    }

    /// With KHR_materials_diffuse_transmission's factor and colour.
    pub fn with_diffuse_transmission(self, factor: f32, color: [f32; 3]) -> Dielectric {
        Dielectric {
            diffuse_transmission: factor.clamp(0.0, 1.0),
            diffuse_transmission_color: Vec3::from(color),
            ..self
        }
    }

    /// With KHR_materials_iridescence's weight, film index and thickness
    /// (nanometres).
    pub fn with_iridescence(self, factor: f32, ior: f32, thickness: f32) -> Dielectric {
        Dielectric {
            iridescence: factor.clamp(0.0, 1.0),
            iridescence_ior: ior,
            iridescence_thickness: thickness,
            ..self
        }
    }

    /// Whether the diffuse transmission lobe can carry light.
    fn transmits_diffusely(&self) -> bool {
        self.diffuse_transmission > 0.0 && self.diffuse_transmission_color.max_element() > 0.0
    }
}

pub fn f0_of_ior(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

/// The BSDF's parameters at one point (`BsdfParams`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfParams {
    pub base: Vec3,
    pub metallic: f32,
    /// GGX alpha (roughness squared, at least `MIN_GGX_ALPHA`): the base's
    /// specular lobe's along the shading frame's y axis.
    pub alpha: f32,
    /// The base's specular lobe's GGX alpha along the shading frame's x
    /// axis, which is KHR_materials_anisotropy's direction (kernels
    /// compiled with `HAS_ANISOTROPY`): `alpha` without anisotropy.
    pub alpha_t: f32,
    /// 1 for glTF materials, 0 for the pure Lambertian of `--clay`.
    pub specular: f32,
    /// The dielectric extensions (kernels compiled with
    /// `HAS_TRANSMISSION`); `None`: the base model exactly as without.
    pub dielectric: Option<Dielectric>,
    /// Turquin's multiple-scattering compensation of the GGX reflection
    /// lobes (kernels compiled with `GGX_ENERGY_COMPENSATION`).
    pub energy_compensation: bool,
    /// The clear coat and sheen layers over the base (kernels compiled
    /// with `HAS_CLEARCOAT` or `HAS_SHEEN`); `None`: the base alone.
    pub layers: Option<Layers>,
}

/// KHR_materials_clearcoat and KHR_materials_sheen at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layers {
    /// `clearcoatFactor` (0: no coat).
    pub clearcoat: f32,
    /// The coat's GGX alpha (`clearcoatRoughnessFactor` squared).
    pub coat_alpha: f32,
    /// `sheenColorFactor` (black: no sheen).
    pub sheen_color: Vec3,
    /// `sheenRoughnessFactor`.
    pub sheen_roughness: f32,
    /// The coat's normal in the base's shading frame (z: the base's
    /// shading normal): the interpolated vertex normal, or
    /// `clearcoatNormalTexture` applied to it, since the extension keeps
    /// the base's normal map off the coat. `Vec3::Z` exactly: the base's.
    pub coat_normal: Vec3,
}

impl Layers {
    pub fn new(
        clearcoat: f32,
        coat_roughness: f32,
        sheen_color: [f32; 3],
        sheen_roughness: f32,
    ) -> Layers {
        Layers {
            clearcoat: clearcoat.clamp(0.0, 1.0),
            coat_alpha: ggx_alpha(coat_roughness),
            sheen_color: Vec3::from(sheen_color).clamp(Vec3::ZERO, Vec3::ONE),
            sheen_roughness: sheen_roughness.clamp(0.0, 1.0),
            coat_normal: Vec3::Z,
        }
    }

    /// With the coat's own normal `n` (unit, in the base's shading frame).
    pub fn with_coat_normal(self, n: Vec3) -> Layers {
        Layers {
            coat_normal: n,
            ..self
        }
    }
}

/// The coat's frame (`coat_frame` in kernels/trace/bsdf.h): tangents around the
/// coat normal, `None` when it is the base's (then vectors are used as
/// they are, so a coat without its own normal is exactly the base frame).
fn coat_frame(l: &Layers) -> Option<(Vec3, Vec3, Vec3)> {
    let n = l.coat_normal;
    if n.x == 0.0 && n.y == 0.0 {
        return None;
    }
    let (t, b) = super::sampling::onb(n);
    Some((t, b, n))
}

/// `v` (base frame) in the coat's frame.
fn to_coat(f: Option<(Vec3, Vec3, Vec3)>, v: Vec3) -> Vec3 {
    match f {
        None => v,
        Some((t, b, n)) => Vec3::new(v.dot(t), v.dot(b), v.dot(n)),
    }
}

/// `v` (coat frame) in the base's frame.
fn from_coat(f: Option<(Vec3, Vec3, Vec3)>, v: Vec3) -> Vec3 {
    match f {
        None => v,
        Some((t, b, n)) => (t * v.x + b * v.y) + n * v.z,
    }
}

pub const MIN_GGX_ALPHA: f32 = 1.0e-3;

/// At or below this alpha the GGX lobes are delta lobes (pbrt-v4's
/// `EffectivelySmooth`): `bsdf_eval` and `bsdf_pdf` leave them out and
/// `bsdf_sample` picks their exact direction. Evaluated as GGX at alpha 1e-3
/// they gave light sampling rare ~1/(pi alpha^2) fireflies.
pub const SMOOTH_GGX_ALPHA: f32 = 1.0e-3;

/// Whether a GGX lobe of this alpha is a delta lobe.
pub fn ggx_smooth(alpha: f32) -> bool {
    alpha <= SMOOTH_GGX_ALPHA
}

impl BsdfParams {
    pub fn new(base: [f32; 3], metallic: f32, roughness: f32) -> BsdfParams {
        BsdfParams {
            base: Vec3::from(base),
            metallic: metallic.clamp(0.0, 1.0),
            alpha: ggx_alpha(roughness),
            alpha_t: ggx_alpha(roughness),
            specular: 1.0,
            dielectric: None,
            energy_compensation: false,
            layers: None,
        }
    }

    /// With the clear coat and sheen layers.
    pub fn with_layers(self, l: Layers) -> BsdfParams {
        BsdfParams {
            layers: Some(l),
            ..self
        }
    }

    /// With the dielectric extensions' parameters.
    pub fn with_dielectric(self, d: Dielectric) -> BsdfParams {
        BsdfParams {
            dielectric: Some(d),
            ..self
        }
    }

    /// With KHR_materials_anisotropy's strength (clamped to 0..1; the
    /// extension texture's blue already applied): the alpha along the
    /// anisotropy direction becomes `anisotropic_alpha`.
    pub fn with_anisotropy(self, strength: f32) -> BsdfParams {
        BsdfParams {
            alpha_t: anisotropic_alpha(self.alpha, strength),
            ..self
        }
    }

    /// `--clay`: white Lambertian of albedo 0.8.
    pub fn clay() -> BsdfParams {
        BsdfParams {
            base: Vec3::splat(0.8),
            metallic: 0.0,
            alpha: 1.0,
            alpha_t: 1.0,
            specular: 0.0,
            dielectric: None,
            energy_compensation: false,
            layers: None,
        }
    }
}

/// KHR_materials_anisotropy's `alphaT`: `mix(alpha, 1, strength^2)`
/// along the anisotropy direction (the alpha across it stays `alpha`).
/// Strength 0 returns `alpha` itself, so the lobe stays isotropic bit for
/// bit. Mirrors `anisotropic_alpha` in kernels/trace/bsdf.h.
pub fn anisotropic_alpha(alpha: f32, strength: f32) -> f32 {
    let s = strength.clamp(0.0, 1.0);
    if s > 0.0 {
        alpha + (1.0 - alpha) * (s * s)
    } else {
        alpha
    }
}

pub fn ggx_alpha(roughness: f32) -> f32 {
    let r = roughness.clamp(0.0, 1.0);
    (r * r).max(MIN_GGX_ALPHA)
}

fn ggx_d(a: f32, cos_h: f32) -> f32 {
    let a2 = a * a;
    let c2 = cos_h * cos_h;
    let k = c2 * (a2 - 1.0) + 1.0;
    a2 / ((PI * k) * k)
}

fn ggx_lambda(a: f32, c: f32) -> f32 {
    let c2 = c * c;
    let t2 = (1.0 - c2).max(0.0) / c2;
    ((1.0 + (a * a) * t2).sqrt() - 1.0) * 0.5
}

/// Anisotropic GGX (Heitz 2014, eq. 85): alpha `ax` along x, `ay` along y,
/// at the unit half vector `h`.
fn ggx_d_aniso(ax: f32, ay: f32, h: Vec3) -> f32 {
    let x = h.x / ax;
    let y = h.y / ay;
    let k = (x * x + y * y) + h.z * h.z;
    1.0 / (((PI * ax) * ay) * (k * k))
}

/// Smith's Lambda of anisotropic GGX at the unit direction `w`: the
/// isotropic one with the alpha projected on `w`'s azimuth.
fn ggx_lambda_aniso(ax: f32, ay: f32, w: Vec3) -> f32 {
    let (x, y) = (ax * w.x, ay * w.y);
    let t2 = (x * x + y * y) / (w.z * w.z);
    ((1.0 + t2).sqrt() - 1.0) * 0.5
}

/// The base's specular microfacet lobe: GGX with `alpha_t` along the
/// shading frame's x axis and `alpha` along y. Equal alphas take the
/// isotropic formulas, so a material without anisotropy gives the bits it
/// gave before anisotropy existed. Twins of the `spec_*` in kernels/trace/bsdf.h.
fn spec_isotropic(p: &BsdfParams) -> bool {
    p.alpha_t == p.alpha
}

/// Whether the base's specular lobe is a delta lobe: smooth both ways.
fn spec_smooth(p: &BsdfParams) -> bool {
    ggx_smooth(p.alpha.max(p.alpha_t))
}

fn spec_d(p: &BsdfParams, h: Vec3) -> f32 {
    if spec_isotropic(p) {
        ggx_d(p.alpha, h.z)
    } else {
        ggx_d_aniso(p.alpha_t, p.alpha, h)
    }
}

fn spec_lambda(p: &BsdfParams, w: Vec3) -> f32 {
    if spec_isotropic(p) {
        ggx_lambda(p.alpha, w.z)
    } else {
        ggx_lambda_aniso(p.alpha_t, p.alpha, w)
    }
}

fn spec_vndf_pdf(p: &BsdfParams, wo: Vec3, wi: Vec3) -> f32 {
    if spec_isotropic(p) {
        return ggx_vndf_pdf(p.alpha, wo, wi);
    }
    let hv = wo + wi;
    let hl = hv.length();
    if hl == 0.0 {
        return 0.0;
    }
    let h = hv / hl;
    (spec_d(p, h) / (1.0 + spec_lambda(p, wo))) / (4.0 * wo.z)
}

fn spec_sample_vndf(p: &BsdfParams, wo: Vec3, u1: f32, u2: f32) -> Vec3 {
    ggx_sample_vndf(p.alpha_t, p.alpha, wo, u1, u2)
}

/// The white single-scattering albedo of the base's specular lobe at `wo`
/// (Turquin's compensation); anisotropic: `energy::anisotropic_albedo`.
fn spec_albedo(p: &BsdfParams, wo: Vec3) -> f32 {
    if spec_isotropic(p) {
        return ggx_albedo(p.alpha, wo.z);
    }
    super::energy::anisotropic_albedo(p.alpha_t, p.alpha, wo.to_array())
}

fn schlick_weight(c: f32) -> f32 {
    let m = (1.0 - c).clamp(0.0, 1.0);
    let m2 = m * m;
    (m2 * m2) * m
}

/// Schlick's Fresnel of a dielectric of normal reflectance `f0` and
/// relative index `eta` at cosine `c` on wo's side: taken with the cosine
/// on the optically thinner side, 1 under total internal reflection.
pub fn fresnel_dielectric(f0: f32, eta: f32, c: f32) -> f32 {
    match thinner_side_cos(eta, c) {
        Some(c) => f0 + (1.0 - f0) * schlick_weight(c),
        None => 1.0,
    }
}

/// The cosine on the optically thinner side of an interface of relative
/// index `eta` (the far side's over wo's) for cosine `c` on wo's side:
/// `c` itself when wo's side is the thinner one, else the refracted
/// cosine; `None` under total internal reflection.
fn thinner_side_cos(eta: f32, c: f32) -> Option<f32> {
    if eta < 1.0 {
        let s2t = (1.0 - c * c).max(0.0) / (eta * eta);
        if s2t >= 1.0 {
            return None;
        }
        return Some((1.0 - s2t).sqrt());
    }
    Some(c)
}

/// `fresnel_dielectric` per channel of a coloured F0.
pub fn fresnel_dielectric3(f0: Vec3, eta: f32, c: f32) -> Vec3 {
    match thinner_side_cos(eta, c) {
        Some(c) => f0 + (Vec3::ONE - f0) * schlick_weight(c),
        None => Vec3::ONE,
    }
}

fn max3(v: Vec3) -> f32 {
    v.x.max(v.y).max(v.z)
}

/// The reflectance of a thin film of index `film_ior` and thickness
/// `thickness` (nm) in air over a base of normal reflectance `f0` (per
/// channel), at cosine `cos1` with the normal in air: the Airy sum of the
/// film's two interfaces with the phase of each round trip, integrated
/// against the sRGB primaries' spectral sensitivities in Fourier space
/// (Belcour and Barla 2017, "A Practical Extension to Microfacet Theory for
/// the Modeling of Varying Iridescence", in the form KHR_materials_iridescence
/// gives: the first two orders, Schlick's Fresnel from the base's F0). Two
/// departures from the extension's listing, both so that a vanishing film
/// leaves exactly the base's Fresnel: the air-film interface takes the exact
/// dielectric Fresnel (Schlick's is not 0 at grazing angles between equal
/// indices), and R12 R23 is not floored at 1e-5 (the floor left interference
/// terms of weight ~sqrt(1e-5) where the film reflects nothing: 0.007 at
/// normal incidence). A film thinner than 0.03 nm fades into the air; the
/// result is clamped to 0..1.
pub fn thin_film_fresnel(film_ior: f32, cos1: f32, thickness: f32, f0: Vec3) -> Vec3 {
    // smoothstep(0, 0.03, thickness)
    let x = (thickness / 0.03).clamp(0.0, 1.0);
    let n2 = 1.0 + (film_ior - 1.0) * ((x * x) * (3.0 - 2.0 * x));
    let sin2_sq = (1.0 / (n2 * n2)) * (1.0 - cos1 * cos1);
    let cos2_sq = 1.0 - sin2_sq;
    if cos2_sq < 0.0 {
        return Vec3::ONE;
    }
    let cos2 = cos2_sq.sqrt();
    // Air to film.
    // The exact Fresnel of the air-film interface (unpolarised).
    let rs_12 = (cos1 - n2 * cos2) / (cos1 + n2 * cos2);
    let rp_12 = (n2 * cos1 - cos2) / (n2 * cos1 + cos2);
    let r12 = 0.5 * (rs_12 * rs_12 + rp_12 * rp_12);
    let t121 = 1.0 - r12;
    let phi12 = if n2 < 1.0 { PI } else { 0.0 };
    let phi21 = PI - phi12;
    // Film to base: the base's index from its F0 (below 1, so finite).
    let sqrt3 = |v: Vec3| Vec3::new(v.x.sqrt(), v.y.sqrt(), v.z.sqrt());
    let sf0 = sqrt3(f0.clamp(Vec3::ZERO, Vec3::splat(0.9999)));
    let base_ior = (Vec3::ONE + sf0) / (Vec3::ONE - sf0);
    let r1 = ((base_ior - Vec3::splat(n2)) / (base_ior + Vec3::splat(n2)))
        * ((base_ior - Vec3::splat(n2)) / (base_ior + Vec3::splat(n2)));
    let r23 = r1 + (Vec3::ONE - r1) * schlick_weight(cos2);
    let phi23 = Vec3::new(
        if base_ior.x < n2 { PI } else { 0.0 },
        if base_ior.y < n2 { PI } else { 0.0 },
        if base_ior.z < n2 { PI } else { 0.0 },
    );
    // Optical path difference of one round trip, and the phase shifts.
    let opd = ((2.0 * n2) * thickness) * cos2;
    let phi = Vec3::splat(phi21) + phi23;
    let r123 = (r12 * r23).clamp(Vec3::ZERO, Vec3::splat(0.9999));
    let r123_sqrt = sqrt3(r123);
    let rs = ((t121 * t121) * r23) / (Vec3::ONE - r123);
    // The incoherent (m = 0) term, then the first two interference orders.
    let mut sum = r12 + rs;
    let mut cm = rs - Vec3::splat(t121);
    for m in 1..=2 {
        cm *= r123_sqrt;
        let sm = film_sensitivity(m as f32 * opd, phi * m as f32) * 2.0;
        sum += cm * sm;
    }
    sum.clamp(Vec3::ZERO, Vec3::ONE)
}

/// The Fourier transform of the sRGB primaries' spectral sensitivities at
/// optical path difference `opd` (nm) with phase shifts `shift`: Gaussian
/// fits of the CIE 1931 matching functions (Belcour and Barla 2017), then
/// XYZ to linear Rec. 709.
fn film_sensitivity(opd: f32, shift: Vec3) -> Vec3 {
    let phase = (2.0 * PI) * opd * 1.0e-9;
    let val = Vec3::new(5.4856e-13, 4.4201e-13, 5.2481e-13);
    let pos = Vec3::new(1.6810e6, 1.7953e6, 2.2084e6);
    let var = Vec3::new(4.3278e9, 9.3046e9, 6.6121e9);
    let gauss = |v: f32, p: f32, s: f32, sh: f32| {
        ((v * ((2.0 * PI) * s).sqrt()) * (p * phase + sh).cos()) * (-(phase * phase) * s).exp()
    };
    let mut xyz = Vec3::new(
        gauss(val.x, pos.x, var.x, shift.x),
        gauss(val.y, pos.y, var.y, shift.y),
        gauss(val.z, pos.z, var.z, shift.z),
    );
    xyz.x += gauss(9.7470e-14, 2.2399e6, 4.5282e9, shift.x);
    xyz /= 1.0685e-7;
    Vec3::new(
        (3.2404542 * xyz.x - 1.5371385 * xyz.y) - 0.4985314 * xyz.z,
        (-0.969266 * xyz.x + 1.8760108 * xyz.y) + 0.0415560 * xyz.z,
        (0.0556434 * xyz.x - 0.2040259 * xyz.y) + 1.0572252 * xyz.z,
    )
}

/// The dielectric layer's Fresnel at cosine `c` on wo's side: the coloured
/// Schlick of `fresnel_dielectric3`, mixed towards the thin film's by the
/// iridescence weight (the film taken at the cosine on the thinner side,
/// 1 under total internal reflection).
fn layer_fresnel(d: &Dielectric, c: f32) -> Vec3 {
    let Some(ct) = thinner_side_cos(d.eta, c) else {
        return Vec3::ONE;
    };
    let f = d.f0_color + (Vec3::ONE - d.f0_color) * schlick_weight(ct);
    if !(d.iridescence > 0.0) {
        return f;
    }
    let film = thin_film_fresnel(d.iridescence_ior, ct, d.iridescence_thickness, d.f0_color);
    f + (film - f) * d.iridescence
}

/// The metal's Fresnel at cosine `c`: Schlick's from the base colour,
/// mixed towards the thin film's over it by the iridescence weight.
fn metal_fresnel(p: &BsdfParams, d: &Dielectric, c: f32) -> Vec3 {
    let f = p.base + (Vec3::ONE - p.base) * schlick_weight(c);
    if !(d.iridescence > 0.0) {
        return f;
    }
    let film = thin_film_fresnel(d.iridescence_ior, c, d.iridescence_thickness, p.base);
    f + (film - f) * d.iridescence
}

/// The probabilities of the specular reflection, the specular
/// transmission and the diffuse transmission lobes (the diffuse reflection
/// lobe has the rest), with the dielectric extensions.
pub fn lobe_probabilities(p: &BsdfParams, d: &Dielectric, cos_o: f32) -> (f32, f32, f32) {
    let fo = p.specular * max3(layer_fresnel(d, cos_o));
    let ws = p.metallic + (1.0 - p.metallic) * fo;
    let wb = ((1.0 - p.metallic) * luminance(p.base)) * (1.0 - fo);
    let wt = wb * d.transmission;
    let wd = (wb * (1.0 - d.transmission)) * (1.0 - d.diffuse_transmission);
    let wdt = (((1.0 - p.metallic) * luminance(d.diffuse_transmission_color)) * (1.0 - fo))
        * ((1.0 - d.transmission) * d.diffuse_transmission);
    let sum = ((ws + wt) + wd) + wdt;
    if sum > 0.0 {
        (ws / sum, wt / sum, wdt / sum)
    } else {
        (0.0, 0.0, 0.0)
    }
}

/// The diffuse transmission lobe (KHR_materials_diffuse_transmission) for
/// wi below the surface: Lambertian, of the extension's colour, weighted by
/// one minus the Fresnel the diffuse reflection lobe has at the mirror of
/// wi, so that moving the diffuse lobe's share across the surface moves
/// its energy exactly.
fn diffuse_transmission_eval(p: &BsdfParams, d: &Dielectric, wo: Vec3, wi: Vec3) -> Vec3 {
    let weight = ((1.0 - p.metallic) * (1.0 - d.transmission)) * d.diffuse_transmission;
    if !(weight > 0.0) {
        return Vec3::ZERO;
    }
    let hv = wo + Vec3::new(wi.x, wi.y, -wi.z);
    let hl = hv.length();
    if hl == 0.0 {
        return Vec3::ZERO;
    }
    let voh = wo.dot(hv / hl).max(0.0);
    let fd = max3(p.specular * layer_fresnel(d, voh));
    d.diffuse_transmission_color * ((weight * (1.0 - fd)) * INV_PI)
}

/// The half vector of a refraction from wo (z > 0) to wi (z < 0) with
/// relative index eta, and its cosines with wo and wi; `None` when the
/// pair cannot be a refraction through a front-facing microfacet.
fn refraction_half(eta: f32, wo: Vec3, wi: Vec3) -> Option<(Vec3, f32, f32)> {
    let hv = wo + wi * eta;
    let hl = hv.length();
    if !(hl > 0.0) {
        return None;
    }
    let mut h = hv / hl;
    if h.z < 0.0 {
        h = -h;
    }
    let oh = wo.dot(h);
    let ih = wi.dot(h);
    if !(oh > 0.0) || !(ih < 0.0) {
        return None;
    }
    Some((h, oh, ih))
}

fn dielectric_eval(p: &BsdfParams, d: &Dielectric, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.z <= 0.0 || wi.z == 0.0 {
        return Vec3::ZERO;
    }
    if wi.z > 0.0 {
        let hv = wo + wi;
        let hl = hv.length();
        if hl == 0.0 {
            return Vec3::ZERO;
        }
        let h = hv / hl;
        let voh = wo.dot(h).max(0.0);
        let dd = spec_d(p, h);
        let g2 = 1.0 / ((1.0 + spec_lambda(p, wo)) + spec_lambda(p, wi));
        let s = if spec_smooth(p) {
            0.0
        } else {
            (dd * g2) / ((4.0 * wo.z) * wi.z)
        };
        let layer = p.specular * layer_fresnel(d, voh);
        let fd = max3(layer);
        let fm = metal_fresnel(p, d, voh);
        if p.energy_compensation {
            let ms = 1.0 / spec_albedo(p, wo) - 1.0;
            let dielectric = p.base * (diffuse_share(d, fd) * INV_PI)
                + (layer * s) * (Vec3::ONE + d.f0_color * ms);
            let metal = fm * s * (Vec3::ONE + p.base * ms);
            return dielectric * (1.0 - p.metallic) + metal * p.metallic;
        }
        let dielectric = p.base * (diffuse_share(d, fd) * INV_PI) + layer * s;
        let metal = fm * s;
        return dielectric * (1.0 - p.metallic) + metal * p.metallic;
    }
    let diffuse = diffuse_transmission_eval(p, d, wo, wi);
    let weight = (1.0 - p.metallic) * d.transmission;
    if !(weight > 0.0) || spec_smooth(p) {
        return diffuse;
    }
    if d.thin {
        // The reflection lobe mirrored through the surface.
        let r = Vec3::new(wi.x, wi.y, -wi.z);
        let hv = wo + r;
        let hl = hv.length();
        if hl == 0.0 {
            return Vec3::ZERO;
        }
        let h = hv / hl;
        let voh = wo.dot(h).max(0.0);
        let dd = spec_d(p, h);
        let g2 = 1.0 / ((1.0 + spec_lambda(p, wo)) + spec_lambda(p, r));
        let s = (dd * g2) / ((4.0 * wo.z) * r.z);
        // Thin-walled: eta is 1.
        let fd = p.specular * max3(layer_fresnel(d, voh));
        return p.base * ((weight * (1.0 - fd)) * s) + diffuse;
    }
    let Some((h, oh, ih)) = refraction_half(d.eta, wo, wi) else {
        return diffuse;
    };
    let fd = p.specular * max3(layer_fresnel(d, oh));
    let denom = ih + oh / d.eta;
    let g2 = 1.0 / ((1.0 + spec_lambda(p, wo)) + spec_lambda(p, wi));
    let ft = (((spec_d(p, h) * (1.0 - fd)) * g2) * ((ih * oh) / (((denom * denom) * wi.z) * wo.z)))
        .abs()
        / (d.eta * d.eta);
    p.base * (weight * ft) + diffuse
}

/// The diffuse reflection lobe's weight after the specular layer's
/// Fresnel `fd`: what neither transmission takes.
fn diffuse_share(d: &Dielectric, fd: f32) -> f32 {
    ((1.0 - fd) * (1.0 - d.transmission)) * (1.0 - d.diffuse_transmission)
}

fn dielectric_pdf(p: &BsdfParams, d: &Dielectric, wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 || wi.z == 0.0 {
        return 0.0;
    }
    let (ps, pt, pdt) = lobe_probabilities(p, d, wo.z);
    if wi.z > 0.0 {
        let spec = if ps > 0.0 && !spec_smooth(p) {
            spec_vndf_pdf(p, wo, wi)
        } else {
            0.0
        };
        return ps * spec + (((1.0 - ps) - pt) - pdt) * (wi.z * INV_PI);
    }
    let diffuse = pdt * (-wi.z * INV_PI);
    if !(pt > 0.0) || spec_smooth(p) {
        return diffuse;
    }
    if d.thin {
        return pt * spec_vndf_pdf(p, wo, Vec3::new(wi.x, wi.y, -wi.z)) + diffuse;
    }
    let Some((h, oh, ih)) = refraction_half(d.eta, wo, wi) else {
        return diffuse;
    };
    let g1 = 1.0 / (1.0 + spec_lambda(p, wo));
    let pdf_h = ((g1 * spec_d(p, h)) * oh) / wo.z;
    let denom = ih + oh / d.eta;
    pt * (pdf_h * (-ih / (denom * denom))) + diffuse
}

fn dielectric_sample(
    p: &BsdfParams,
    d: &Dielectric,
    wo: Vec3,
    lobe_u: f32,
    u1: f32,
    u2: f32,
) -> Option<BsdfSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let (ps, pt, pdt) = lobe_probabilities(p, d, wo.z);
    if spec_smooth(p) && lobe_u < ps + pt {
        let (wi, value, pdf) = if lobe_u < ps {
            (
                Vec3::new(-wo.x, -wo.y, wo.z),
                smooth_reflectance(p, wo.z),
                ps,
            )
        } else {
            let weight = (1.0 - p.metallic) * d.transmission;
            let (wi, value) = if d.thin {
                (-wo, thin_straight_through(p, d, wo.z))
            } else {
                let c = wo.z;
                let s2t = (1.0 - c * c).max(0.0) / (d.eta * d.eta);
                if s2t >= 1.0 {
                    return None;
                }
                let ct = (1.0 - s2t).sqrt();
                let wi = -wo / d.eta + Vec3::Z * (c / d.eta - ct);
                let fd = p.specular * max3(layer_fresnel(d, c));
                (wi, p.base * (weight * ((1.0 - fd) / (d.eta * d.eta))))
            };
            if wi.z >= 0.0 {
                return None;
            }
            (wi, value, pt)
        };
        if !(pdf > 0.0) {
            return None;
        }
        return Some(BsdfSample {
            wi,
            f: value / wi.z.abs(),
            pdf,
            delta: true,
        });
    }
    let wi = if lobe_u < ps {
        let h = spec_sample_vndf(p, wo, u1, u2);
        let wi = h * (2.0 * wo.dot(h)) - wo;
        if wi.z <= 0.0 {
            return None;
        }
        wi
    } else if lobe_u < ps + pt {
        let h = spec_sample_vndf(p, wo, u1, u2);
        let c = wo.dot(h);
        let wi = if d.thin {
            let r = h * (2.0 * c) - wo;
            Vec3::new(r.x, r.y, -r.z)
        } else {
            if !(c > 0.0) {
                return None;
            }
            let s2t = (1.0 - c * c).max(0.0) / (d.eta * d.eta);
            if s2t >= 1.0 {
                return None;
            }
            let ct = (1.0 - s2t).sqrt();
            -wo / d.eta + h * (c / d.eta - ct)
        };
        if wi.z >= 0.0 {
            return None;
        }
        wi
    } else if lobe_u < (ps + pt) + pdt {
        // Diffuse transmission: the cosine hemisphere below.
        let wi = sample_cosine_hemisphere(u1, u2);
        if wi.z <= 0.0 {
            return None;
        }
        Vec3::new(wi.x, wi.y, -wi.z)
    } else {
        let wi = sample_cosine_hemisphere(u1, u2);
        if wi.z <= 0.0 {
            return None;
        }
        wi
    };
    let pdf = dielectric_pdf(p, d, wo, wi);
    if !(pdf > 0.0) {
        return None;
    }
    Some(BsdfSample {
        wi,
        f: dielectric_eval(p, d, wo, wi),
        pdf,
        delta: false,
    })
}

/// The probability of sampling the specular lobe.
pub fn spec_probability(p: &BsdfParams, cos_o: f32) -> f32 {
    let fd = p.specular * (0.04 + 0.96 * schlick_weight(cos_o));
    let ws = p.metallic + (1.0 - p.metallic) * fd;
    let wd = ((1.0 - p.metallic) * luminance(p.base)) * (1.0 - fd);
    let sum = ws + wd;
    if sum > 0.0 {
        ws / sum
    } else {
        0.0
    }
}

/// The base BSDF (without the coat and sheen layers).
fn base_eval(p: &BsdfParams, wo: Vec3, wi: Vec3) -> Vec3 {
    if let Some(d) = &p.dielectric {
        return dielectric_eval(p, d, wo, wi);
    }
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return Vec3::ZERO;
    }
    // Pure Lambert (--clay): the same value as below, without the lobe.
    if p.specular == 0.0 && p.metallic == 0.0 {
        return p.base * INV_PI;
    }
    let hv = wo + wi;
    let hl = hv.length();
    if hl == 0.0 {
        return Vec3::ZERO;
    }
    let h = hv / hl;
    let voh = wo.dot(h).max(0.0);
    let d = spec_d(p, h);
    let g2 = 1.0 / ((1.0 + spec_lambda(p, wo)) + spec_lambda(p, wi));
    let s = if spec_smooth(p) {
        0.0
    } else {
        (d * g2) / ((4.0 * wo.z) * wi.z)
    };
    let w = schlick_weight(voh);
    let fd = p.specular * (0.04 + 0.96 * w);
    let fm = p.base + (Vec3::ONE - p.base) * w;
    if p.energy_compensation {
        let dielectric = p.base * ((1.0 - fd) * INV_PI)
            + Vec3::splat(fd * s) * (1.0 + 0.04 * (1.0 / spec_albedo(p, wo) - 1.0));
        let metal = fm * s * (Vec3::ONE + p.base * (1.0 / spec_albedo(p, wo) - 1.0));
        return dielectric * (1.0 - p.metallic) + metal * p.metallic;
    }
    let dielectric = p.base * ((1.0 - fd) * INV_PI) + Vec3::splat(fd * s);
    let metal = fm * s;
    dielectric * (1.0 - p.metallic) + metal * p.metallic
}

fn ggx_vndf_pdf(a: f32, wo: Vec3, wi: Vec3) -> f32 {
    let hv = wo + wi;
    let hl = hv.length();
    if hl == 0.0 {
        return 0.0;
    }
    let h = hv / hl;
    let g1 = 1.0 / (1.0 + ggx_lambda(a, wo.z));
    (g1 * ggx_d(a, h.z)) / (4.0 * wo.z)
}

/// The pdf of `base_sample`.
fn base_pdf(p: &BsdfParams, wo: Vec3, wi: Vec3) -> f32 {
    if let Some(d) = &p.dielectric {
        return dielectric_pdf(p, d, wo, wi);
    }
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    if p.specular == 0.0 && p.metallic == 0.0 {
        return wi.z * INV_PI;
    }
    let ps = spec_probability(p, wo.z);
    let spec = if ps > 0.0 && !spec_smooth(p) {
        spec_vndf_pdf(p, wo, wi)
    } else {
        0.0
    };
    ps * spec + (1.0 - ps) * (wi.z * INV_PI)
}

/// Heitz's visible-normal sampling, for alpha `ax` along x and `ay` along y.
fn ggx_sample_vndf(ax: f32, ay: f32, wo: Vec3, u1: f32, u2: f32) -> Vec3 {
    let vh = Vec3::new(ax * wo.x, ay * wo.y, wo.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u1.sqrt();
    let (c, s) = cos_sin_turns(u2);
    let p1 = r * c;
    let mut p2 = r * s;
    let s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
    let nh = (t1 * p1 + t2 * p2) + vh * ((1.0 - p1 * p1) - p2 * p2).max(0.0).sqrt();
    Vec3::new(ax * nh.x, ay * nh.y, nh.z.max(0.0)).normalize()
}

/// A sampled direction: wi, the BSDF value and the mixture pdf; from a
/// delta lobe (`delta`), f is the lobe's reflectance over |wi.z| and pdf the
/// lobe's selection probability, so f |wi.z| / pdf is the weight either way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub f: Vec3,
    pub pdf: f32,
    pub delta: bool,
}

/// The reflectance of the smooth (delta) reflection lobe for outgoing
/// cosine c: the GGX reflection terms of `bsdf_eval` with the microfacet
/// lobe integrated to 1 (h = n, so v.h = c).
pub fn smooth_reflectance(p: &BsdfParams, c: f32) -> Vec3 {
    let w = schlick_weight(c);
    let fm = p.base + (Vec3::ONE - p.base) * w;
    if let Some(d) = &p.dielectric {
        let layer = p.specular * layer_fresnel(d, c);
        let fm = metal_fresnel(p, d, c);
        let (dielectric, metal) = if p.energy_compensation {
            let ms = 1.0 / ggx_albedo(p.alpha, c) - 1.0;
            (
                layer * (Vec3::ONE + d.f0_color * ms),
                fm * (Vec3::ONE + p.base * ms),
            )
        } else {
            (layer, fm)
        };
        return dielectric * (1.0 - p.metallic) + metal * p.metallic;
    }
    let fd = p.specular * (0.04 + 0.96 * w);
    let (dielectric, metal) = if p.energy_compensation {
        (
            Vec3::splat(fd) * (1.0 + 0.04 * (1.0 / ggx_albedo(p.alpha, c) - 1.0)),
            fm * (Vec3::ONE + p.base * (1.0 / ggx_albedo(p.alpha, c) - 1.0)),
        )
    } else {
        (Vec3::splat(fd), fm)
    };
    dielectric * (1.0 - p.metallic) + metal * p.metallic
}

/// `bsdf_only_delta` of the base BSDF.
fn base_only_delta(p: &BsdfParams) -> bool {
    if !spec_smooth(p) {
        return false;
    }
    if p.metallic >= 1.0 {
        return true;
    }
    if let Some(d) = &p.dielectric {
        if d.transmission >= 1.0 {
            return true;
        }
        if d.transmits_diffusely() {
            return false;
        }
    }
    !(p.base.x > 0.0 || p.base.y > 0.0 || p.base.z > 0.0)
}

/// The smooth thin-walled transmission lobe's reflectance at outgoing
/// cosine `c` (straight through, unbent): what `base_sample`'s delta lobe
/// carries. A shadow ray crossing such a surface keeps this times the
/// layers' scaling of the base (`layered_straight_through`).
pub fn thin_straight_through(p: &BsdfParams, d: &Dielectric, c: f32) -> Vec3 {
    let weight = (1.0 - p.metallic) * d.transmission;
    let fd = p.specular * max3(layer_fresnel(d, c));
    p.base * (weight * (1.0 - fd))
}

/// Samples the base BSDF.
fn base_sample(p: &BsdfParams, wo: Vec3, lobe_u: f32, u1: f32, u2: f32) -> Option<BsdfSample> {
    if let Some(d) = &p.dielectric {
        return dielectric_sample(p, d, wo, lobe_u, u1, u2);
    }
    if wo.z <= 0.0 {
        return None;
    }
    let ps = spec_probability(p, wo.z);
    // Pure Lambert (--clay) has no specular lobe: ps is 0.
    if lobe_u < ps && spec_smooth(p) {
        return Some(BsdfSample {
            wi: Vec3::new(-wo.x, -wo.y, wo.z),
            f: smooth_reflectance(p, wo.z) / wo.z,
            pdf: ps,
            delta: true,
        });
    }
    let wi = if lobe_u < ps {
        let h = spec_sample_vndf(p, wo, u1, u2);
        h * (2.0 * wo.dot(h)) - wo
    } else {
        sample_cosine_hemisphere(u1, u2)
    };
    if wi.z <= 0.0 {
        return None;
    }
    let pdf = base_pdf(p, wo, wi);
    if !(pdf > 0.0) {
        return None;
    }
    Some(BsdfSample {
        wi,
        f: base_eval(p, wo, wi),
        pdf,
        delta: false,
    })
}

/// The sheen distribution's roughness floor: the Charlie distribution's
/// exponent is 1 / roughness (the glTF sample viewer's floor too).
pub const SHEEN_MIN_ROUGHNESS: f32 = 0.07;

/// The clear coat's Fresnel weight at cosine `c` with the view: Schlick's
/// for ior 1.5 (the extension's `fresnel_coat` uses N.V, not V.H).
fn coat_fresnel(c: f32) -> f32 {
    0.04 + 0.96 * schlick_weight(c)
}

/// The coat's share `clearcoat * Fc(cos_o)` of what leaves towards wo: the
/// weight of the coat lobe and the probability of sampling it.
fn coat_weight(l: &Layers, cos_o: f32) -> f32 {
    (l.clearcoat * coat_fresnel(cos_o)).clamp(0.0, 1.0)
}

/// The coat's white GGX lobe D G2 / (4 |n.l| |n.v|) about the coat's
/// normal (0 when smooth: a delta lobe), energy-compensated to albedo 1
/// (its Fresnel is outside, in the mix: F0 = 1 in Turquin's factor) with
/// `GGX_ENERGY_COMPENSATION`. `wo`, `wi` are in the base's frame; the lobe
/// is scaled by (coat n.l) / (base n.l), so that with the renderer's
/// base-frame cosine it reflects as a lobe about its own normal would (and
/// a tilted coat keeps its albedo but for what falls below the surface).
fn coat_lobe(p: &BsdfParams, l: &Layers, wo: Vec3, wi: Vec3) -> f32 {
    if !(wi.z > 0.0) || ggx_smooth(l.coat_alpha) {
        return 0.0;
    }
    let f = coat_frame(l);
    let (wo, wi_c) = (to_coat(f, wo), to_coat(f, wi));
    if !(wo.z > 0.0) || !(wi_c.z > 0.0) {
        return 0.0;
    }
    let hv = wo + wi_c;
    let hl = hv.length();
    if hl == 0.0 {
        return 0.0;
    }
    let h = hv / hl;
    let a = l.coat_alpha;
    let g2 = 1.0 / ((1.0 + ggx_lambda(a, wo.z)) + ggx_lambda(a, wi_c.z));
    let s = (ggx_d(a, h.z) * g2) / ((4.0 * wo.z) * wi_c.z);
    let s = if p.energy_compensation {
        s / ggx_albedo(a, wo.z)
    } else {
        s
    };
    if f.is_some() {
        s * (wi_c.z / wi.z)
    } else {
        s
    }
}

/// The view's cosine with the coat's normal.
fn coat_cos(l: &Layers, wo: Vec3) -> f32 {
    to_coat(coat_frame(l), wo).z
}

/// The smooth coat's reflectance towards the mirror direction (its lobe
/// integrated to 1, compensated as `coat_lobe`).
fn coat_smooth_reflectance(p: &BsdfParams, l: &Layers, cos_o: f32) -> f32 {
    let w = coat_weight(l, cos_o);
    if p.energy_compensation {
        w / ggx_albedo(l.coat_alpha, cos_o)
    } else {
        w
    }
}

/// The Charlie sheen's Lambda: the extension's fit `l` of Estevez and Kulla.
fn sheen_l(x: f32, a: f32) -> f32 {
    let t = (1.0 - a) * (1.0 - a);
    let mix = |p1: f32, p0: f32| p1 + (p0 - p1) * t;
    mix(21.5473, 25.3245) / (1.0 + mix(3.82987, 3.32435) * x.powf(mix(0.19823, 0.16801)))
        + mix(-1.9776, -1.27393) * x
        + mix(-4.32054, -4.85967)
}

fn sheen_lambda(c: f32, a: f32) -> f32 {
    if c < 0.5 {
        sheen_l(c, a).exp()
    } else {
        (2.0 * sheen_l(0.5, a) - sheen_l(1.0 - c, a)).exp()
    }
}

/// The white Charlie sheen lobe D V of KHR_materials_sheen (Estevez and
/// Kulla 2017: D = (2 + 1/a) sin^(1/a)(h) / (2 pi), a = sheen roughness; V
/// = 1 / ((1 + Lambda(wo) + Lambda(wi)) 4 |n.v| |n.l|)), 0 below.
pub fn sheen_lobe(roughness: f32, wo: Vec3, wi: Vec3) -> f32 {
    if !(wo.z > 0.0) || !(wi.z > 0.0) {
        return 0.0;
    }
    let hv = wo + wi;
    let hl = hv.length();
    if hl == 0.0 {
        return 0.0;
    }
    let ch = hv.z / hl;
    let a = roughness.max(SHEEN_MIN_ROUGHNESS);
    let s2 = (1.0 - ch * ch).max(0.0);
    let d = ((2.0 + 1.0 / a) * s2.powf(0.5 / a)) * (0.5 * INV_PI);
    d / (((1.0 + sheen_lambda(wo.z, a)) + sheen_lambda(wi.z, a)) * ((4.0 * wo.z) * wi.z))
}

/// The sheen's probability of being sampled: its albedo max(colour) E(cos_o).
fn sheen_probability(l: &Layers, cos_o: f32) -> f32 {
    (max3(l.sheen_color) * sheen_albedo(l.sheen_roughness, cos_o)).clamp(0.0, 1.0)
}

/// The extension's albedo scaling of the base under the sheen,
/// min(1 - max(colour) E(n.v), 1 - max(colour) E(n.l)).
pub fn sheen_scaling(l: &Layers, cos_o: f32, cos_i: f32) -> f32 {
    let m = max3(l.sheen_color);
    (1.0 - m * sheen_albedo(l.sheen_roughness, cos_o))
        .min(1.0 - m * sheen_albedo(l.sheen_roughness, cos_i))
}

fn layered_eval(p: &BsdfParams, l: &Layers, wo: Vec3, wi: Vec3) -> Vec3 {
    if !(wo.z > 0.0) {
        return Vec3::ZERO;
    }
    let base = base_eval(p, wo, wi);
    let under = base * sheen_scaling(l, wo.z, wi.z.abs())
        + l.sheen_color * sheen_lobe(l.sheen_roughness, wo, wi);
    let wc = coat_weight(l, coat_cos(l, wo));
    under * (1.0 - wc) + Vec3::splat(wc * coat_lobe(p, l, wo, wi))
}

fn layered_pdf(p: &BsdfParams, l: &Layers, wo: Vec3, wi: Vec3) -> f32 {
    if !(wo.z > 0.0) {
        return 0.0;
    }
    let f = coat_frame(l);
    let (wo_c, wi_c) = (to_coat(f, wo), to_coat(f, wi));
    let pc = coat_weight(l, wo_c.z);
    let psh = sheen_probability(l, wo.z);
    let sheen = if wi.z > 0.0 { 0.5 * INV_PI } else { 0.0 };
    let coat = if wi.z > 0.0 && wi_c.z > 0.0 && pc > 0.0 && !ggx_smooth(l.coat_alpha) {
        ggx_vndf_pdf(l.coat_alpha, wo_c, wi_c)
    } else {
        0.0
    };
    (1.0 - pc) * (psh * sheen + (1.0 - psh) * base_pdf(p, wo, wi)) + pc * coat
}

fn layered_sample(
    p: &BsdfParams,
    l: &Layers,
    wo: Vec3,
    lobe_u: f32,
    u1: f32,
    u2: f32,
) -> Option<BsdfSample> {
    if !(wo.z > 0.0) {
        return None;
    }
    let f = coat_frame(l);
    let wo_c = to_coat(f, wo);
    let pc = coat_weight(l, wo_c.z);
    let wi = if lobe_u < pc {
        if !(wo_c.z > 0.0) {
            return None;
        }
        if ggx_smooth(l.coat_alpha) {
            let wi = from_coat(f, Vec3::new(-wo_c.x, -wo_c.y, wo_c.z));
            if !(wi.z > 0.0) {
                return None;
            }
            return Some(BsdfSample {
                wi,
                f: Vec3::splat(coat_smooth_reflectance(p, l, wo_c.z) / wi.z),
                pdf: pc,
                delta: true,
            });
        }
        let h = ggx_sample_vndf(l.coat_alpha, l.coat_alpha, wo_c, u1, u2);
        let wi_c = h * (2.0 * wo_c.dot(h)) - wo_c;
        // Below the coat (its pdf there is 0) or below the surface.
        let wi = from_coat(f, wi_c);
        if !(wi_c.z > 0.0) || !(wi.z > 0.0) {
            return None;
        }
        wi
    } else {
        // The rest of lobe_u picks among the sheen and the base's lobes.
        let u = (lobe_u - pc) / (1.0 - pc);
        let psh = sheen_probability(l, wo.z);
        if u < psh {
            sample_uniform_hemisphere(u1, u2)
        } else {
            let s = base_sample(p, wo, (u - psh) / (1.0 - psh), u1, u2)?;
            if s.delta {
                let scale = sheen_scaling(l, wo.z, s.wi.z.abs()) * (1.0 - pc);
                return Some(BsdfSample {
                    wi: s.wi,
                    f: s.f * scale,
                    pdf: s.pdf * ((1.0 - pc) * (1.0 - psh)),
                    delta: true,
                });
            }
            s.wi
        }
    };
    if wi.z == 0.0 {
        return None;
    }
    let pdf = layered_pdf(p, l, wo, wi);
    if !(pdf > 0.0) {
        return None;
    }
    Some(BsdfSample {
        wi,
        f: layered_eval(p, l, wo, wi),
        pdf,
        delta: false,
    })
}

/// What a shadow ray crossing a smooth thin-walled surface keeps
/// (`bsdf_shadow_straight_through` in kernels/trace/bsdf.h): the straight-through
/// lobe as `bsdf_sample` carries it, under the coat and the sheen (for that
/// lobe wi = -wo, so both cosines are `wo.z`; the coat's is taken with its
/// own normal). `wo`: the ray's reverse direction in the shading frame.
pub fn shadow_straight_through(p: &BsdfParams, d: &Dielectric, wo: Vec3) -> Vec3 {
    let c = wo.z;
    let t = thin_straight_through(p, d, c);
    match &p.layers {
        Some(l) => t * ((1.0 - coat_weight(l, coat_cos(l, wo))) * sheen_scaling(l, c, c)),
        None => t,
    }
}

/// The BSDF (without the cosine) for local directions wo, wi (z = normal):
/// the base, under the sheen (albedo-scaled), under the clear coat
/// (`fresnel_coat`: mixed by clearcoat * Fc(n.v)).
pub fn bsdf_eval(p: &BsdfParams, wo: Vec3, wi: Vec3) -> Vec3 {
    match &p.layers {
        Some(l) => layered_eval(p, l, wo, wi),
        None => base_eval(p, wo, wi),
    }
}

/// The solid-angle pdf of `bsdf_sample` producing wi.
pub fn bsdf_pdf(p: &BsdfParams, wo: Vec3, wi: Vec3) -> f32 {
    match &p.layers {
        Some(l) => layered_pdf(p, l, wo, wi),
        None => base_pdf(p, wo, wi),
    }
}

/// Samples wi for wo (`lobe_u` picks the lobe); `None` below the surface.
pub fn bsdf_sample(p: &BsdfParams, wo: Vec3, lobe_u: f32, u1: f32, u2: f32) -> Option<BsdfSample> {
    match &p.layers {
        Some(l) => layered_sample(p, l, wo, lobe_u, u1, u2),
        None => base_sample(p, wo, lobe_u, u1, u2),
    }
}

/// True when every lobe is a delta lobe: `bsdf_eval` is 0 for every pair
/// of directions, and the path tracer skips light sampling there.
pub fn bsdf_only_delta(p: &BsdfParams) -> bool {
    let layers_delta = p.layers.is_none_or(|l| {
        (!(l.clearcoat > 0.0) || ggx_smooth(l.coat_alpha)) && !(max3(l.sheen_color) > 0.0)
    });
    layers_delta && base_only_delta(p)
}
