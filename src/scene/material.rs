//! The material table the renderer shades with: metallic-roughness factors
//! and textures, normal and occlusion maps, emission (with
//! KHR_materials_emissive_strength), alpha mode, double-sidedness,
//! KHR_texture_transform, and the dielectric extensions
//! KHR_materials_transmission, KHR_materials_ior and KHR_materials_volume
//! and KHR_materials_specular, KHR_materials_clearcoat (with its normal
//! map), KHR_materials_sheen, KHR_materials_diffuse_transmission and
//! KHR_materials_iridescence, KHR_materials_anisotropy and
//! KHR_materials_dispersion, with their textures, and KHR_materials_unlit;
//! KHR_materials_pbrSpecularGlossiness is converted to these on load
//! (`material_load` reads the file). Every other `KHR_materials_*`
//! extension a scene uses is named in one warning. Images are kept as
//! handles and decoded only when asked for, so scenes whose textures nobody
//! samples never pay for them. Every parameter is a row of the tables at
//! the end ([`Slot`], [`FACTORS`]), which the stages after loading read.

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use super::error::{Result, SceneError};

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum AlphaMode {
    Opaque,
    Mask,
    Blend,
}

/// KHR_texture_transform: `uv' = T(offset) * R(rotation) * S(scale) * uv`.
#[derive(Debug, Clone, Copy, PartialEq)]
/// The KHR_texture_transform of a texture use. The device applies it as
/// `trace::texture::transform_matrix` (whose rotation follows the extension's
/// worked example and the sample viewer; its GLSL listing has it transposed).
pub struct TextureTransform {
    pub offset: [f32; 2],
    pub rotation: f32,
    pub scale: [f32; 2],
    /// Overrides the reference's `texCoord` when present.
    pub tex_coord: Option<u32>,
}

/// A material's use of a texture.
#[derive(Debug, Clone, PartialEq)]
pub struct TextureRef {
    /// Index into [`MaterialTable::textures`].
    pub texture: usize,
    /// Which TEXCOORD_n set (after any transform override).
    pub tex_coord: u32,
    pub transform: Option<TextureTransform>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: Option<String>,
    pub base_color_factor: [f32; 4],
    pub base_color_texture: Option<TextureRef>,
    pub metallic_factor: f32,
    pub roughness_factor: f32,
    /// Roughness in G, metalness in B.
    pub metallic_roughness_texture: Option<TextureRef>,
    pub normal_texture: Option<TextureRef>,
    pub normal_scale: f32,
    pub occlusion_texture: Option<TextureRef>,
    pub occlusion_strength: f32,
    pub emissive_factor: [f32; 3],
    /// KHR_materials_emissive_strength multiplier (1 without the extension).
    pub emissive_strength: f32,
    pub emissive_texture: Option<TextureRef>,
    pub alpha_mode: AlphaMode,
    pub alpha_cutoff: f32,
    pub double_sided: bool,
    /// KHR_materials_transmission `transmissionFactor` (0 without it): the
    /// share of the dielectric's diffuse lobe replaced by transmission.
    pub transmission_factor: f32,
    /// KHR_materials_ior `ior` (1.5 without it).
    pub ior: f32,
    /// KHR_materials_volume `thicknessFactor` (0 without it: thin-walled).
    /// Only whether it is above 0 matters to a path tracer: the mesh's
    /// own geometry is the volume.
    pub thickness_factor: f32,
    /// KHR_materials_volume `attenuationColor` (white without it).
    pub attenuation_color: [f32; 3],
    /// KHR_materials_volume `attenuationDistance` (infinite without it).
    pub attenuation_distance: f32,
    /// KHR_materials_unlit: the surface shows its base colour, unlit.
    pub unlit: bool,
    /// KHR_materials_specular `specularFactor` (1 without it).
    pub specular_factor: f32,
    /// KHR_materials_specular `specularColorFactor` (white without it).
    pub specular_color: [f32; 3],
    /// KHR_materials_transmission `transmissionTexture` (R scales the factor).
    pub transmission_texture: Option<TextureRef>,
    /// KHR_materials_specular `specularTexture` (A scales the factor).
    pub specular_texture: Option<TextureRef>,
    /// KHR_materials_specular `specularColorTexture` (sRGB RGB scales the colour).
    pub specular_color_texture: Option<TextureRef>,
    /// KHR_materials_clearcoat `clearcoatFactor` (0 without it: no coat).
    pub clearcoat_factor: f32,
    /// KHR_materials_clearcoat `clearcoatRoughnessFactor` (0 without it).
    pub clearcoat_roughness: f32,
    /// KHR_materials_sheen `sheenColorFactor` (black without it: no sheen).
    pub sheen_color: [f32; 3],
    /// KHR_materials_sheen `sheenRoughnessFactor` (0 without it).
    pub sheen_roughness: f32,
    /// KHR_materials_clearcoat `clearcoatTexture` (R scales the factor).
    pub clearcoat_texture: Option<TextureRef>,
    /// KHR_materials_clearcoat `clearcoatRoughnessTexture` (G scales the factor).
    pub clearcoat_roughness_texture: Option<TextureRef>,
    /// KHR_materials_clearcoat `clearcoatNormalTexture`: the coat's own
    /// normal map (without it the coat takes the unmapped normal).
    pub clearcoat_normal_texture: Option<TextureRef>,
    /// `clearcoatNormalTexture.scale` (1 without it).
    pub clearcoat_normal_scale: f32,
    /// KHR_materials_sheen `sheenColorTexture` (sRGB RGB scales the colour).
    pub sheen_color_texture: Option<TextureRef>,
    /// KHR_materials_sheen `sheenRoughnessTexture` (A scales the factor).
    pub sheen_roughness_texture: Option<TextureRef>,
    /// KHR_materials_diffuse_transmission `diffuseTransmissionFactor` (0
    /// without it): the share of the diffuse lobe transmitted diffusely.
    pub diffuse_transmission: f32,
    /// `diffuseTransmissionTexture` (A scales the factor).
    pub diffuse_transmission_texture: Option<TextureRef>,
    /// `diffuseTransmissionColorFactor` (white without it).
    pub diffuse_transmission_color: [f32; 3],
    /// `diffuseTransmissionColorTexture` (sRGB RGB scales the colour).
    pub diffuse_transmission_color_texture: Option<TextureRef>,
    /// KHR_materials_iridescence `iridescenceFactor` (0 without it: no film).
    pub iridescence: f32,
    /// `iridescenceTexture` (R scales the factor).
    pub iridescence_texture: Option<TextureRef>,
    /// `iridescenceIor`: the film's index (1.3 by default).
    pub iridescence_ior: f32,
    /// `iridescenceThicknessMinimum` and `iridescenceThicknessMaximum`, nm
    /// (100 and 400 by default).
    pub iridescence_thickness_min: f32,
    pub iridescence_thickness_max: f32,
    /// `iridescenceThicknessTexture` (G picks the thickness between the
    /// two; without it the film is the maximum thick).
    pub iridescence_thickness_texture: Option<TextureRef>,
    /// KHR_materials_anisotropy `anisotropyStrength` (0 without it).
    pub anisotropy_strength: f32,
    /// `anisotropyRotation`: radians, counter-clockwise from the tangent.
    pub anisotropy_rotation: f32,
    /// `anisotropyTexture` (RG: the direction in tangent space, B scales
    /// the strength).
    pub anisotropy_texture: Option<TextureRef>,
    /// KHR_materials_dispersion `dispersion`: 20 / Abbe number (0: none).
    pub dispersion: f32,
    /// KHR_materials_diffuse_roughness `diffuseRoughnessFactor` (0
    /// without it: Lambert's diffuse lobe).
    pub diffuse_roughness: f32,
    /// `diffuseRoughnessTexture` (R scales the factor).
    pub diffuse_roughness_texture: Option<TextureRef>,
}

impl Default for Material {
    /// The glTF default material: every property at its specification
    /// default (base colour 1, metallic 1, roughness 1, opaque, one-sided).
    fn default() -> Self {
        Material {
            name: None,
            base_color_factor: [1.0; 4],
            base_color_texture: None,
            metallic_factor: 1.0,
            roughness_factor: 1.0,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            emissive_factor: [0.0; 3],
            emissive_strength: 1.0,
            emissive_texture: None,
            alpha_mode: AlphaMode::Opaque,
            alpha_cutoff: 0.5,
            double_sided: false,
            transmission_factor: 0.0,
            ior: 1.5,
            thickness_factor: 0.0,
            attenuation_color: [1.0; 3],
            attenuation_distance: f32::INFINITY,
            unlit: false,
            specular_factor: 1.0,
            specular_color: [1.0; 3],
            transmission_texture: None,
            specular_texture: None,
            specular_color_texture: None,
            clearcoat_factor: 0.0,
            clearcoat_roughness: 0.0,
            sheen_color: [0.0; 3],
            sheen_roughness: 0.0,
            clearcoat_texture: None,
            clearcoat_roughness_texture: None,
            clearcoat_normal_texture: None,
            clearcoat_normal_scale: 1.0,
            sheen_color_texture: None,
            sheen_roughness_texture: None,
            diffuse_transmission: 0.0,
            diffuse_transmission_texture: None,
            diffuse_transmission_color: [1.0; 3],
            diffuse_transmission_color_texture: None,
            iridescence: 0.0,
            iridescence_texture: None,
            iridescence_ior: 1.3,
            iridescence_thickness_min: 100.0,
            iridescence_thickness_max: 400.0,
            iridescence_thickness_texture: None,
            anisotropy_strength: 0.0,
            anisotropy_rotation: 0.0,
            anisotropy_texture: None,
            dispersion: 0.0,
            diffuse_roughness: 0.0,
            diffuse_roughness_texture: None,
        }
    }
}

impl Material {
    pub fn texture_refs(&self) -> impl Iterator<Item = &TextureRef> {
        Slot::ALL.into_iter().filter_map(|slot| slot.of(self))
    }

    pub fn is_textured(&self) -> bool {
        self.texture_refs().next().is_some()
    }

    /// Whether the material needs the dielectric extensions' code
    /// (`HAS_TRANSMISSION`): some transmission, or an ior other than the
    /// default 1.5 (the default's 4 % Fresnel is the base model's), or a
    /// specular layer other than the default (a factor, a colour or one of
    /// their textures), or diffuse transmission. A transmission texture
    /// alone changes nothing: it scales a factor of 0.
    pub fn needs_transmission(&self) -> bool {
        self.transmission_factor > 0.0
            || self.has_diffuse_transmission()
            || self.has_iridescence()
            || self.has_anisotropy()
            || self.ior != 1.5
            || self.specular_factor != 1.0
            || self.specular_color != [1.0; 3]
            || self.specular_texture.is_some()
            || self.specular_color_texture.is_some()
    }

    /// Whether the material transmits diffusely
    /// (`HAS_DIFFUSE_TRANSMISSION`): a factor above 0 (its texture only
    /// scales it).
    pub fn has_diffuse_transmission(&self) -> bool {
        self.diffuse_transmission > 0.0
    }

    /// Whether the material has a thin film (`HAS_IRIDESCENCE`): a factor
    /// above 0 (its texture only scales it).
    pub fn has_iridescence(&self) -> bool {
        self.iridescence > 0.0
    }

    /// Whether the material's specular lobes are anisotropic
    /// (`HAS_ANISOTROPY`): a strength above 0 (its texture only scales it).
    pub fn has_anisotropy(&self) -> bool {
        self.anisotropy_strength > 0.0
    }

    /// Whether the material disperses (`HAS_DISPERSION`): a dispersion
    /// above 0 on a refracting volume (the extension builds on
    /// KHR_materials_volume; thin-walled surfaces do not disperse).
    pub fn has_dispersion(&self) -> bool {
        self.dispersion > 0.0 && self.transmission_factor > 0.0 && self.has_volume()
    }

    /// Whether the diffuse lobe is rough (`HAS_DIFFUSE_ROUGHNESS`): a
    /// roughness of 0 is Lambert's lobe.
    pub fn has_diffuse_roughness(&self) -> bool {
        self.diffuse_roughness > 0.0
    }

    /// Whether the material has a clear coat (`HAS_CLEARCOAT`).
    pub fn has_clearcoat(&self) -> bool {
        self.clearcoat_factor > 0.0
    }

    /// Whether the material has a sheen (`HAS_SHEEN`): a sheen colour of
    /// black is no layer at all.
    pub fn has_sheen(&self) -> bool {
        self.sheen_color.iter().any(|&c| c > 0.0)
    }

    /// Transmissive (specularly or diffusely) with a volume: the mesh
    /// bounds a medium (refraction and Beer-Lambert attenuation inside),
    /// rather than being thin-walled.
    pub fn has_volume(&self) -> bool {
        (self.transmission_factor > 0.0 || self.has_diffuse_transmission())
            && self.thickness_factor > 0.0
    }
}

pub(crate) const SPECULAR_GLOSSINESS: &str = "KHR_materials_pbrSpecularGlossiness";

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wrap {
    Repeat,
    ClampToEdge,
    MirroredRepeat,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Filter {
    Nearest,
    Linear,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Texture {
    pub name: Option<String>,
    /// Index into [`MaterialTable::images`].
    pub image: usize,
    pub wrap_s: Wrap,
    pub wrap_t: Wrap,
    pub mag_filter: Filter,
    pub min_filter: Filter,
}

/// Where an image's encoded bytes are.
#[derive(Debug, Clone)]
pub enum ImageSource {
    File(PathBuf),
    Bytes(Arc<[u8]>),
}

/// Decoded pixels, RGBA8, rows top to bottom.
#[derive(Debug, Clone)]
pub struct DecodedImage {
    pub width: u32,
    pub height: u32,
    pub rgba8: Vec<u8>,
}

#[derive(Debug)]
pub struct Image {
    pub name: Option<String>,
    pub source: ImageSource,
    pub(super) file: String,
    /// Set on the image soupray derives from a KHR_materials_pbrSpecularGlossiness
    /// `specularGlossinessTexture`: the glossiness factor, baked with the
    /// image's alpha (glossiness) into a metallic-roughness texture.
    pub(super) roughness_from_glossiness: Option<f32>,
    pub(super) decoded: OnceLock<std::result::Result<Arc<DecodedImage>, String>>,
}

impl Image {
    /// The pixels, decoded on first use and cached.
    pub fn decoded(&self, index: usize) -> Result<Arc<DecodedImage>> {
        self.decoded
            .get_or_init(|| self.decode())
            .clone()
            .map_err(|problem| SceneError::Invalid {
                file: self.file.clone(),
                detail: format!(
                    "image {index}{}: {problem}",
                    self.name
                        .as_deref()
                        .map(|n| format!(" \"{n}\""))
                        .unwrap_or_default()
                ),
            })
    }

    fn decode(&self) -> std::result::Result<Arc<DecodedImage>, String> {
        let bytes: std::borrow::Cow<[u8]> = match &self.source {
            ImageSource::File(path) => {
                crate::input::read_regular(path, crate::input::MAX_INPUT_BYTES)
                    .map_err(|e| {
                        format!(
                            "cannot read {} ({e}). Fix: put the image next to the .gltf file.",
                            path.display()
                        )
                    })?
                    .into()
            }
            ImageSource::Bytes(b) => (&b[..]).into(),
        };
        let mut image = super::image_decode::decode(&bytes)?;
        if let Some(glossiness) = self.roughness_from_glossiness {
            roughness_from_glossiness(&mut image, glossiness);
        }
        Ok(Arc::new(image))
    }
}

/// Rewrites a specular-glossiness texture (RGB specular, A glossiness) as a
/// metallic-roughness one: G = roughness = 1 - glossinessFactor * A, B =
/// metalness = 0 (R and A unused, set to 0 and 1). Glossiness is linear,
/// so no colour-space conversion is involved.
fn roughness_from_glossiness(image: &mut DecodedImage, glossiness_factor: f32) {
    for px in image.rgba8.chunks_exact_mut(4) {
        let gloss = glossiness_factor * px[3] as f32 / 255.0;
        let roughness = (1.0 - gloss).clamp(0.0, 1.0);
        px[0] = 0;
        px[1] = (roughness * 255.0).round() as u8;
        px[2] = 0;
        px[3] = 255;
    }
}

/// Everything a renderer needs to shade: materials indexed by the soup's
/// per-triangle material ids, and the textures and images they use.
#[derive(Debug, Default)]
pub struct MaterialTable {
    pub materials: Vec<Material>,
    pub textures: Vec<Texture>,
    pub images: Vec<Image>,
    /// Index of the appended glTF default material, used by primitives that
    /// name no material (present only when some primitive needs it).
    pub default_material: Option<u32>,
}

impl MaterialTable {
    pub fn has_textured_materials(&self) -> bool {
        self.materials.iter().any(Material::is_textured)
    }

    /// Decodes every image some material uses (and no other), so that
    /// rendering never stops half-way on a bad texture.
    pub fn decode_used_images(&self) -> Result<()> {
        for m in &self.materials {
            for r in m.texture_refs() {
                let image = self.textures[r.texture].image;
                self.images[image].decoded(image)?;
            }
        }
        Ok(())
    }
}

// The material's parameters: every number and texture a glTF material
// sets, one row each, with where it stands in the file, which `Material`
// field holds it and the range the specification allows. The loader, the
// range checks, the animation pointers, validation, `soupray info` and the
// device tables (`PtMaterialExt.factor` and `.tex`, with their generated
// defines) all read these two tables, so a new material parameter is a
// field above and a row below, not an edit in each of them.

/// Declares [`Slot`] from one row per texture use: the variant, the
/// `Material` field, the path below `/materials/N/` in the file, the name
/// messages give it, whether its RGB is sRGB-encoded, and for an
/// extension's texture the kernel define under which it is read.
macro_rules! texture_slots {
    (@feature) => { None };
    (@feature $feature:literal) => { Some($feature) };
    (@scales) => { None };
    (@scales $factor:literal $channel:ident) => { Some(($factor, stringify!($channel))) };
    ($($(#[$doc:meta])* $variant:ident: $field:ident at $path:literal as $name:literal, $srgb:literal
       $(, $feature:literal)? $(, scales $factor:literal . $channel:ident)?;)*) => {
        /// A texture use of a material.
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub enum Slot {
            $($(#[$doc])* $variant,)*
        }

        impl Slot {
            pub const COUNT: usize = [$($name),*].len();
            /// Every slot, core first, in the order of this table.
            pub const ALL: [Slot; Slot::COUNT] = [$(Slot::$variant),*];

            /// The texture info's path below `/materials/N/` (what an
            /// animation pointer names).
            pub fn path(self) -> &'static str {
                match self {
                    $(Slot::$variant => $path,)*
                }
            }

            /// The glTF property name, for messages.
            pub fn name(self) -> &'static str {
                match self {
                    $(Slot::$variant => $name,)*
                }
            }

            /// Whether the glTF specification says the slot's RGB is
            /// sRGB-encoded.
            pub fn is_srgb(self) -> bool {
                match self {
                    $(Slot::$variant => $srgb,)*
                }
            }

            /// The kernel define that compiles the code reading an
            /// extension's texture (`PtMaterialExt.tex`); `None` for the
            /// core textures (`PtMaterial`).
            pub const fn feature(self) -> Option<&'static str> {
                match self {
                    $(Slot::$variant => texture_slots!(@feature $($feature)?),)*
                }
            }

            /// The factor whose value the texture scales, by its key in
            /// the extension's object, and the channel that scales it
            /// (`x`, `y`, `z`, `w` or `xyz`): the kernels' generated
            /// `pt_material_inputs` applies it. `None`: read by hand (the
            /// core textures, normal maps, the film's thickness, the
            /// anisotropy's direction).
            pub const fn scales(self) -> Option<(&'static str, &'static str)> {
                match self {
                    $(Slot::$variant => texture_slots!(@scales $($factor $channel)?),)*
                }
            }

            pub fn of(self, m: &Material) -> Option<&TextureRef> {
                match self {
                    $(Slot::$variant => m.$field.as_ref(),)*
                }
            }

            pub fn of_mut(self, m: &mut Material) -> &mut Option<TextureRef> {
                match self {
                    $(Slot::$variant => &mut m.$field,)*
                }
            }
        }

        impl Material {
            /// Every texture use of the material, core and extensions alike.
            pub fn texture_refs_mut(&mut self) -> [&mut Option<TextureRef>; Slot::COUNT] {
                [$(&mut self.$field),*]
            }
        }
    };
}

texture_slots! {
    BaseColor: base_color_texture
        at "pbrMetallicRoughness/baseColorTexture" as "baseColorTexture", true;
    MetallicRoughness: metallic_roughness_texture
        at "pbrMetallicRoughness/metallicRoughnessTexture" as "metallicRoughnessTexture", false;
    Normal: normal_texture at "normalTexture" as "normalTexture", false;
    Occlusion: occlusion_texture at "occlusionTexture" as "occlusionTexture", false;
    Emissive: emissive_texture at "emissiveTexture" as "emissiveTexture", true;
    Transmission: transmission_texture
        at "extensions/KHR_materials_transmission/transmissionTexture"
        as "KHR_materials_transmission transmissionTexture", false, "HAS_TRANSMISSION",
        scales "transmissionFactor".x;
    Specular: specular_texture
        at "extensions/KHR_materials_specular/specularTexture"
        as "KHR_materials_specular specularTexture", false, "HAS_TRANSMISSION",
        scales "specularFactor".w;
    SpecularColor: specular_color_texture
        at "extensions/KHR_materials_specular/specularColorTexture"
        as "KHR_materials_specular specularColorTexture", true, "HAS_TRANSMISSION",
        scales "specularColorFactor".xyz;
    Clearcoat: clearcoat_texture
        at "extensions/KHR_materials_clearcoat/clearcoatTexture"
        as "KHR_materials_clearcoat clearcoatTexture", false, "HAS_CLEARCOAT",
        scales "clearcoatFactor".x;
    ClearcoatRoughness: clearcoat_roughness_texture
        at "extensions/KHR_materials_clearcoat/clearcoatRoughnessTexture"
        as "KHR_materials_clearcoat clearcoatRoughnessTexture", false, "HAS_CLEARCOAT",
        scales "clearcoatRoughnessFactor".y;
    /// The coat's own normal map.
    ClearcoatNormal: clearcoat_normal_texture
        at "extensions/KHR_materials_clearcoat/clearcoatNormalTexture"
        as "KHR_materials_clearcoat clearcoatNormalTexture", false, "HAS_CLEARCOAT";
    SheenColor: sheen_color_texture
        at "extensions/KHR_materials_sheen/sheenColorTexture"
        as "KHR_materials_sheen sheenColorTexture", true, "HAS_SHEEN",
        scales "sheenColorFactor".xyz;
    SheenRoughness: sheen_roughness_texture
        at "extensions/KHR_materials_sheen/sheenRoughnessTexture"
        as "KHR_materials_sheen sheenRoughnessTexture", false, "HAS_SHEEN",
        scales "sheenRoughnessFactor".w;
    DiffuseTransmission: diffuse_transmission_texture
        at "extensions/KHR_materials_diffuse_transmission/diffuseTransmissionTexture"
        as "KHR_materials_diffuse_transmission diffuseTransmissionTexture", false, "HAS_DIFFUSE_TRANSMISSION",
        scales "diffuseTransmissionFactor".w;
    DiffuseTransmissionColor: diffuse_transmission_color_texture
        at "extensions/KHR_materials_diffuse_transmission/diffuseTransmissionColorTexture"
        as "KHR_materials_diffuse_transmission diffuseTransmissionColorTexture", true, "HAS_DIFFUSE_TRANSMISSION",
        scales "diffuseTransmissionColorFactor".xyz;
    Iridescence: iridescence_texture
        at "extensions/KHR_materials_iridescence/iridescenceTexture"
        as "KHR_materials_iridescence iridescenceTexture", false, "HAS_IRIDESCENCE",
        scales "iridescenceFactor".x;
    /// G picks the film's thickness between its minimum and maximum.
    IridescenceThickness: iridescence_thickness_texture
        at "extensions/KHR_materials_iridescence/iridescenceThicknessTexture"
        as "KHR_materials_iridescence iridescenceThicknessTexture", false, "HAS_IRIDESCENCE";
    /// RG: the direction in tangent space; B scales the strength.
    Anisotropy: anisotropy_texture
        at "extensions/KHR_materials_anisotropy/anisotropyTexture"
        as "KHR_materials_anisotropy anisotropyTexture", false, "HAS_ANISOTROPY";
    DiffuseRoughness: diffuse_roughness_texture
        at "extensions/KHR_materials_diffuse_roughness/diffuseRoughnessTexture"
        as "KHR_materials_diffuse_roughness diffuseRoughnessTexture", false, "HAS_DIFFUSE_ROUGHNESS",
        scales "diffuseRoughnessFactor".x;
}

impl Slot {
    /// The extension whose object holds the texture info, and the info's
    /// key in it; `None` for the core textures.
    pub fn extension_key(self) -> Option<(&'static str, &'static str)> {
        self.path().strip_prefix("extensions/")?.split_once('/')
    }
}

/// Where a factor's value lives in `Material`: the field, to read and to
/// write.
#[derive(Clone, Copy)]
pub enum FactorField {
    Scalar(fn(&Material) -> &f32, fn(&mut Material) -> &mut f32),
    Rgb(
        fn(&Material) -> &[f32; 3],
        fn(&mut Material) -> &mut [f32; 3],
    ),
    Rgba(
        fn(&Material) -> &[f32; 4],
        fn(&mut Material) -> &mut [f32; 4],
    ),
}

/// `FactorField::$kind` of `Material::$field`.
macro_rules! factor_field {
    ($kind:ident, $field:ident) => {
        FactorField::$kind(|m| &m.$field, |m| &mut m.$field)
    };
}

/// A number (or colour) a material sets.
#[derive(Clone, Copy)]
pub struct Factor {
    /// The property's path below `/materials/N/`.
    pub path: &'static str,
    pub field: FactorField,
    /// The range the specification allows, each component clamped into it
    /// with a warning (NaN: the default). `None`: checked by hand in
    /// `ranges`, or unbounded.
    pub range: Option<(f32, f32)>,
    /// Whether the kernels read it as it is, from `PtMaterialExt.factor`
    /// (the core factors are in `PtMaterial`; the rest reach the device
    /// derived, as the volume's attenuation coefficient).
    pub on_device: bool,
}

impl Factor {
    /// Floats in the value.
    pub const fn width(&self) -> usize {
        match self.field {
            FactorField::Scalar(..) => 1,
            FactorField::Rgb(..) => 3,
            FactorField::Rgba(..) => 4,
        }
    }

    /// The value's components in `m`.
    pub fn values<'m>(&self, m: &'m Material) -> &'m [f32] {
        match self.field {
            FactorField::Scalar(f, _) => std::slice::from_ref(f(m)),
            FactorField::Rgb(f, _) => f(m),
            FactorField::Rgba(f, _) => f(m),
        }
    }

    /// The value's components in `m`, to change.
    pub fn components<'m>(&self, m: &'m mut Material) -> &'m mut [f32] {
        match self.field {
            FactorField::Scalar(_, f) => std::slice::from_mut(f(m)),
            FactorField::Rgb(_, f) => f(m),
            FactorField::Rgba(_, f) => f(m),
        }
    }

    /// The extension that sets it, and the key path inside the
    /// extension's object; `None` for core factors.
    pub fn extension_key(&self) -> Option<(&'static str, &'static str)> {
        self.path.strip_prefix("extensions/")?.split_once('/')
    }

    /// The property as messages name it: `KHR_materials_sheen
    /// sheenRoughnessFactor`, `occlusionTexture.strength`.
    pub fn name(&self) -> String {
        match self.extension_key() {
            Some((ext, key)) => format!("{ext} {}", key.replace('/', ".")),
            None => self
                .path
                .trim_start_matches("pbrMetallicRoughness/")
                .replace('/', "."),
        }
    }
}

const UNIT: Option<(f32, f32)> = Some((0.0, 1.0));
const NON_NEGATIVE: Option<(f32, f32)> = Some((0.0, f32::MAX));

/// Every factor a material sets, core and extensions. The specification's
/// defaults are `Material::default()`'s.
pub const FACTORS: &[Factor] = &[
    Factor {
        path: "pbrMetallicRoughness/baseColorFactor",
        field: factor_field!(Rgba, base_color_factor),
        range: UNIT,
        on_device: false,
    },
    Factor {
        path: "pbrMetallicRoughness/metallicFactor",
        field: factor_field!(Scalar, metallic_factor),
        range: UNIT,
        on_device: false,
    },
    Factor {
        path: "pbrMetallicRoughness/roughnessFactor",
        field: factor_field!(Scalar, roughness_factor),
        range: UNIT,
        on_device: false,
    },
    Factor {
        path: "emissiveFactor",
        field: factor_field!(Rgb, emissive_factor),
        range: UNIT,
        on_device: false,
    },
    Factor {
        path: "alphaCutoff",
        field: factor_field!(Scalar, alpha_cutoff),
        range: NON_NEGATIVE,
        on_device: false,
    },
    // Any finite scale is allowed; `ranges` replaces an infinite one.
    Factor {
        path: "normalTexture/scale",
        field: factor_field!(Scalar, normal_scale),
        range: None,
        on_device: false,
    },
    Factor {
        path: "occlusionTexture/strength",
        field: factor_field!(Scalar, occlusion_strength),
        range: UNIT,
        on_device: false,
    },
    Factor {
        path: "extensions/KHR_materials_emissive_strength/emissiveStrength",
        field: factor_field!(Scalar, emissive_strength),
        range: NON_NEGATIVE,
        on_device: false,
    },
    Factor {
        path: "extensions/KHR_materials_transmission/transmissionFactor",
        field: factor_field!(Scalar, transmission_factor),
        range: UNIT,
        on_device: true,
    },
    // 1 or more, or 0 for an infinite index, which `ranges` maps first.
    Factor {
        path: "extensions/KHR_materials_ior/ior",
        field: factor_field!(Scalar, ior),
        range: Some((1.0, f32::MAX)),
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_volume/thicknessFactor",
        field: factor_field!(Scalar, thickness_factor),
        range: NON_NEGATIVE,
        on_device: false,
    },
    Factor {
        path: "extensions/KHR_materials_volume/attenuationColor",
        field: factor_field!(Rgb, attenuation_color),
        range: UNIT,
        on_device: false,
    },
    // Above 0, or infinite: checked last in `ranges`.
    Factor {
        path: "extensions/KHR_materials_volume/attenuationDistance",
        field: factor_field!(Scalar, attenuation_distance),
        range: None,
        on_device: false,
    },
    Factor {
        path: "extensions/KHR_materials_specular/specularFactor",
        field: factor_field!(Scalar, specular_factor),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_specular/specularColorFactor",
        field: factor_field!(Rgb, specular_color),
        range: NON_NEGATIVE,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_clearcoat/clearcoatFactor",
        field: factor_field!(Scalar, clearcoat_factor),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_clearcoat/clearcoatRoughnessFactor",
        field: factor_field!(Scalar, clearcoat_roughness),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_clearcoat/clearcoatNormalTexture/scale",
        field: factor_field!(Scalar, clearcoat_normal_scale),
        range: None,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_sheen/sheenColorFactor",
        field: factor_field!(Rgb, sheen_color),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_sheen/sheenRoughnessFactor",
        field: factor_field!(Scalar, sheen_roughness),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_diffuse_transmission/diffuseTransmissionFactor",
        field: factor_field!(Scalar, diffuse_transmission),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_diffuse_transmission/diffuseTransmissionColorFactor",
        field: factor_field!(Rgb, diffuse_transmission_color),
        range: UNIT,
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_iridescence/iridescenceFactor",
        field: factor_field!(Scalar, iridescence),
        range: UNIT,
        on_device: true,
    },
    // Real films have indices of 1 to about 4; the bound keeps the film's
    // optical path (index times thickness) finite.
    Factor {
        path: "extensions/KHR_materials_iridescence/iridescenceIor",
        field: factor_field!(Scalar, iridescence_ior),
        range: Some((1.0, 100.0)),
        on_device: true,
    },
    // Films are nanometres thick: anything above 100 µm is a mistake, and
    // the interference terms vanish long before.
    Factor {
        path: "extensions/KHR_materials_iridescence/iridescenceThicknessMinimum",
        field: factor_field!(Scalar, iridescence_thickness_min),
        range: Some((0.0, 1.0e5)),
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_iridescence/iridescenceThicknessMaximum",
        field: factor_field!(Scalar, iridescence_thickness_max),
        range: Some((0.0, 1.0e5)),
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_anisotropy/anisotropyStrength",
        field: factor_field!(Scalar, anisotropy_strength),
        range: UNIT,
        on_device: true,
    },
    // A turn is 2 pi; beyond 1e4 radians an f32 angle is coarser than a
    // thousandth of a radian, and an infinite one has no cosine.
    Factor {
        path: "extensions/KHR_materials_anisotropy/anisotropyRotation",
        field: factor_field!(Scalar, anisotropy_rotation),
        range: Some((-1.0e4, 1.0e4)),
        on_device: false,
    },
    // 1 is an Abbe number of 20, about the lowest of real materials; the
    // extension allows more to exaggerate, and 20 (Abbe number 1) is far
    // beyond any material.
    Factor {
        path: "extensions/KHR_materials_dispersion/dispersion",
        field: factor_field!(Scalar, dispersion),
        range: Some((0.0, 20.0)),
        on_device: true,
    },
    Factor {
        path: "extensions/KHR_materials_diffuse_roughness/diffuseRoughnessFactor",
        field: factor_field!(Scalar, diffuse_roughness),
        range: UNIT,
        on_device: true,
    },
];

/// Floats in `PtMaterialExt.factor`: the factors the kernels read as
/// they are, in the table's order.
pub const DEVICE_FACTOR_FLOATS: usize = {
    let (mut i, mut n) = (0, 0);
    while i < FACTORS.len() {
        if FACTORS[i].on_device {
            n += FACTORS[i].width();
        }
        i += 1;
    }
    n
};

/// The factors the kernels read, each with its first float's index in
/// `PtMaterialExt.factor` and its define's name (`F_SHEEN_ROUGHNESS` for
/// `sheenRoughnessFactor`).
pub fn device_factors() -> impl Iterator<Item = (usize, String, &'static Factor)> {
    FACTORS.iter().filter(|f| f.on_device).scan(0, |at, f| {
        let first = *at;
        *at += f.width();
        let key = f.extension_key().map_or(f.path, |(_, key)| key);
        let key = key.strip_suffix("Factor").unwrap_or(key);
        Some((first, define_name("F", key), f))
    })
}

/// A kernel define's name for a table entry: `prefix`, then `camel` (a
/// glTF key or a `Slot`'s name) in upper snake case, `/` as `_`:
/// `define_name("F", "sheenRoughness")` is `F_SHEEN_ROUGHNESS`.
pub fn define_name(prefix: &str, camel: &str) -> String {
    let mut name = format!("{prefix}_");
    for (i, c) in camel.chars().enumerate() {
        match c {
            '/' => name.push('_'),
            c if c.is_ascii_uppercase() && i > 0 => {
                name.push('_');
                name.push(c);
            }
            c => name.push(c.to_ascii_uppercase()),
        }
    }
    name
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_slot_names_its_extension_and_key() {
        for slot in Slot::ALL {
            match slot.extension_key() {
                Some((ext, key)) => assert_eq!(slot.name(), format!("{ext} {key}")),
                None => assert!(slot.path().ends_with(slot.name()), "{slot:?}"),
            }
        }
    }

    #[test]
    fn factor_paths_are_unique() {
        for (i, a) in FACTORS.iter().enumerate() {
            assert!(
                FACTORS[i + 1..].iter().all(|b| b.path != a.path),
                "{}",
                a.path
            );
        }
    }

    #[test]
    fn factor_names_match_the_messages() {
        let name = |p: &str| FACTORS.iter().find(|f| f.path == p).unwrap().name();
        assert_eq!(
            name("pbrMetallicRoughness/baseColorFactor"),
            "baseColorFactor"
        );
        assert_eq!(
            name("occlusionTexture/strength"),
            "occlusionTexture.strength"
        );
        assert_eq!(
            name("extensions/KHR_materials_sheen/sheenRoughnessFactor"),
            "KHR_materials_sheen sheenRoughnessFactor"
        );
    }
}
