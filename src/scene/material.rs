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
//! extension a scene uses is named in one warning. Images are kept as handles and decoded only when
//! asked for, so scenes whose textures nobody samples never pay for them.

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use super::error::{Result, SceneError};
use super::material_params::Slot;

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
