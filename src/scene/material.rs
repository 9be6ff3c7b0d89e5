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
//! (`apply_specular_glossiness`). Every other `KHR_materials_*`
//! extension a scene uses is
//! named in one warning (`ignored_material_extensions`). Images are kept as handles and decoded only when
//! asked for, so scenes whose textures nobody samples never pay for them.

use std::path::PathBuf;
use std::sync::{Arc, OnceLock};

use super::error::{Result, SceneError};
use super::source::{decode_base64, resolve_uri, Source};

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

impl Material {
    /// Every texture use of the material, core and extensions alike.
    pub fn texture_refs_mut(&mut self) -> [&mut Option<TextureRef>; 18] {
        [
            &mut self.base_color_texture,
            &mut self.metallic_roughness_texture,
            &mut self.normal_texture,
            &mut self.occlusion_texture,
            &mut self.emissive_texture,
            &mut self.transmission_texture,
            &mut self.specular_texture,
            &mut self.specular_color_texture,
            &mut self.clearcoat_texture,
            &mut self.clearcoat_roughness_texture,
            &mut self.clearcoat_normal_texture,
            &mut self.sheen_color_texture,
            &mut self.sheen_roughness_texture,
            &mut self.diffuse_transmission_texture,
            &mut self.diffuse_transmission_color_texture,
            &mut self.iridescence_texture,
            &mut self.iridescence_thickness_texture,
            &mut self.anisotropy_texture,
        ]
    }
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
        [
            &self.base_color_texture,
            &self.metallic_roughness_texture,
            &self.normal_texture,
            &self.occlusion_texture,
            &self.emissive_texture,
            &self.transmission_texture,
            &self.specular_texture,
            &self.specular_color_texture,
            &self.clearcoat_texture,
            &self.clearcoat_roughness_texture,
            &self.clearcoat_normal_texture,
            &self.sheen_color_texture,
            &self.sheen_roughness_texture,
            &self.diffuse_transmission_texture,
            &self.diffuse_transmission_color_texture,
            &self.iridescence_texture,
            &self.iridescence_thickness_texture,
            &self.anisotropy_texture,
        ]
        .into_iter()
        .flatten()
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

/// KHR_materials_pbrSpecularGlossiness, converted to soupray's
/// metallic-roughness model on load (the extension wins over the
/// material's `pbrMetallicRoughness`, which exporters write as a fallback):
///
/// - `diffuseFactor` / `diffuseTexture` (sRGB RGBA) become the base colour
///   and alpha, with metallic 0: the surface is a dielectric;
/// - `glossinessFactor` and the texture's A become roughness = 1 -
///   glossiness (an image derived from the texture, since a factor alone
///   cannot invert it);
/// - `specularFactor` and the texture's RGB (sRGB) become
///   KHR_materials_specular's specular colour, scaled by 1 / 0.04 so that
///   the dielectric F0 at ior 1.5, `min(0.04 * specularColor, 1)`, is the
///   specular colour itself: the normal reflectance spec-gloss defines.
///
/// This is the mapping KHR_materials_specular describes for spec-gloss
/// content, chosen over `gltf-transform metalrough` (which guesses a
/// metalness from the specular colour and re-bakes the textures) because
/// it keeps F0 and the diffuse colour exactly. It is approximate where the
/// specular colour sits above dielectric F0 (metal-like, coloured
/// specular): the reflection is right at normal incidence, but the diffuse
/// lobe is weighted by the dielectric's Fresnel rather than spec-gloss's
/// `1 - max(specular)`, and grazing reflectance tends to white.
///
/// Returns the texture whose roughness image is still to be derived.
fn apply_specular_glossiness(
    src: &Source,
    material: usize,
    m: &mut Material,
) -> Option<(TextureRef, f32)> {
    let sg = material_extension(src, material, SPECULAR_GLOSSINESS)?;
    let diffuse = sg.get("diffuseFactor").and_then(|a| a.as_array());
    let c = |k: usize| {
        diffuse
            .and_then(|a| a.get(k))
            .and_then(|x| x.as_f64())
            .map_or(1.0, |x| x as f32)
    };
    m.base_color_factor = [c(0), c(1), c(2), c(3)];
    m.base_color_texture = extension_texture(src, material, SPECULAR_GLOSSINESS, "diffuseTexture");
    let glossiness = number(Some(sg), "glossinessFactor", 1.0);
    let specular = rgb(Some(sg), "specularFactor", 1.0);
    m.metallic_factor = 0.0;
    m.metallic_roughness_texture = None;
    m.specular_factor = 1.0;
    m.specular_texture = None;
    m.specular_color = specular.map(|s| s / DIELECTRIC_F0);
    let texture = extension_texture(
        src,
        material,
        SPECULAR_GLOSSINESS,
        "specularGlossinessTexture",
    );
    m.specular_color_texture = texture.clone();
    match texture {
        Some(t) => {
            // The derived texture carries the glossiness factor.
            m.roughness_factor = 1.0;
            Some((t, glossiness))
        }
        None => {
            m.roughness_factor = 1.0 - glossiness;
            None
        }
    }
}

/// The normal reflectance of KHR_materials_specular's dielectric at the
/// default ior 1.5: `((1.5 - 1) / (1.5 + 1))^2`.
const DIELECTRIC_F0: f32 = 0.04;

/// Gives each spec-gloss material with a `specularGlossinessTexture` a
/// metallic-roughness texture derived from it (one per texture and
/// glossiness factor): same sampler, same texture coordinates and
/// transform, its image converted by `roughness_from_glossiness` when
/// decoded.
fn add_roughness_textures(
    materials: &mut [Material],
    textures: &mut Vec<Texture>,
    images: &mut Vec<Image>,
    gloss_textures: &[(usize, (TextureRef, f32))],
) {
    let mut derived: Vec<((usize, u32), usize)> = Vec::new();
    for (material, (reference, glossiness)) in gloss_textures {
        let key = (reference.texture, glossiness.to_bits());
        let texture = match derived.iter().find(|(k, _)| *k == key) {
            Some(&(_, t)) => t,
            None => {
                let Some(source_texture) = textures.get(reference.texture).cloned() else {
                    continue;
                };
                let Some(source_image) = images.get(source_texture.image) else {
                    continue;
                };
                let image = Image {
                    name: Some(format!(
                        "roughness from the glossiness of image {}{}",
                        source_texture.image,
                        source_image
                            .name
                            .as_deref()
                            .map(|n| format!(" \"{n}\""))
                            .unwrap_or_default()
                    )),
                    source: source_image.source.clone(),
                    file: source_image.file.clone(),
                    roughness_from_glossiness: Some(*glossiness),
                    decoded: OnceLock::new(),
                };
                images.push(image);
                textures.push(Texture {
                    image: images.len() - 1,
                    ..source_texture
                });
                derived.push((key, textures.len() - 1));
                textures.len() - 1
            }
        };
        materials[*material].metallic_roughness_texture = Some(TextureRef {
            texture,
            ..reference.clone()
        });
    }
}

/// The `KHR_materials_*` extensions soupray renders (the rest are named in
/// a warning when a scene uses them).
pub const SUPPORTED_MATERIAL_EXTENSIONS: &[&str] = &[
    "KHR_materials_emissive_strength",
    "KHR_materials_transmission",
    "KHR_materials_ior",
    "KHR_materials_volume",
    "KHR_materials_unlit",
    "KHR_materials_specular",
    "KHR_materials_variants",
    "KHR_materials_clearcoat",
    "KHR_materials_sheen",
    "KHR_materials_diffuse_transmission",
    "KHR_materials_iridescence",
    "KHR_materials_anisotropy",
    "KHR_materials_dispersion",
    SPECULAR_GLOSSINESS,
];

/// Every texture the supported material extensions read, as (extension,
/// property): what `validate` checks beside the core material's textures.
pub(crate) const EXTENSION_TEXTURES: &[(&str, &str)] = &[
    ("KHR_materials_transmission", "transmissionTexture"),
    ("KHR_materials_specular", "specularTexture"),
    ("KHR_materials_specular", "specularColorTexture"),
    ("KHR_materials_clearcoat", "clearcoatTexture"),
    ("KHR_materials_clearcoat", "clearcoatRoughnessTexture"),
    ("KHR_materials_clearcoat", "clearcoatNormalTexture"),
    ("KHR_materials_sheen", "sheenColorTexture"),
    ("KHR_materials_sheen", "sheenRoughnessTexture"),
    (DIFFUSE_TRANSMISSION, "diffuseTransmissionTexture"),
    (DIFFUSE_TRANSMISSION, "diffuseTransmissionColorTexture"),
    (IRIDESCENCE, "iridescenceTexture"),
    (IRIDESCENCE, "iridescenceThicknessTexture"),
    (ANISOTROPY, "anisotropyTexture"),
    (SPECULAR_GLOSSINESS, "diffuseTexture"),
    (SPECULAR_GLOSSINESS, "specularGlossinessTexture"),
];

/// One warning per `KHR_materials_*` extension the file uses (on a
/// material, or in `extensionsUsed`) that soupray does not render, naming
/// it and the first material using it.
pub(crate) fn ignored_material_extensions(json: &serde_json::Value) -> Vec<String> {
    // extension -> (first material index, name, count)
    let mut users: std::collections::BTreeMap<String, (Option<usize>, Option<String>, usize)> =
        Default::default();
    let mut warnings = Vec::new();
    let materials = json.get("materials").and_then(|m| m.as_array());
    for (i, m) in materials.into_iter().flatten().enumerate() {
        let Some(exts) = m.get("extensions").and_then(|e| e.as_object()) else {
            continue;
        };
        let name = m.get("name").and_then(|n| n.as_str()).map(str::to_owned);
        for ext in exts.keys() {
            if !ext.starts_with("KHR_materials_") {
                continue;
            }
            // Supported ones are rendered with their textures (except
            // KHR_materials_volume's thicknessTexture, which a path tracer
            // does not need: it measures the distance through the mesh).
            if SUPPORTED_MATERIAL_EXTENSIONS.contains(&ext.as_str()) {
                continue;
            }
            let e = users
                .entry(ext.clone())
                .or_insert((Some(i), name.clone(), 0));
            e.2 += 1;
        }
    }
    let used = json.get("extensionsUsed").and_then(|u| u.as_array());
    for ext in used.into_iter().flatten().filter_map(|e| e.as_str()) {
        if ext.starts_with("KHR_materials_") && !SUPPORTED_MATERIAL_EXTENSIONS.contains(&ext) {
            users.entry(ext.to_owned()).or_insert((None, None, 0));
        }
    }
    for (ext, (first, name, count)) in users {
        let by = match first {
            Some(i) => format!(
                " by material {i}{}{}",
                name.map(|n| format!(" \"{n}\"")).unwrap_or_default(),
                if count > 1 {
                    format!(" and {} more", count - 1)
                } else {
                    String::new()
                }
            ),
            None => " (listed in extensionsUsed)".to_owned(),
        };
        warnings.push(format!(
            "{ext} is used{by} but soupray ignores it; those materials render as plain metallic-roughness"
        ));
    }
    warnings
}

/// The names of the file's KHR_materials_variants (an unnamed one is
/// listed by its index).
pub(crate) fn variant_names(json: &serde_json::Value) -> Vec<String> {
    json.get("extensions")
        .and_then(|e| e.get("KHR_materials_variants"))
        .and_then(|v| v.get("variants"))
        .and_then(|v| v.as_array())
        .map(|a| {
            a.iter()
                .enumerate()
                .map(|(i, v)| {
                    v.get("name")
                        .and_then(|n| n.as_str())
                        .map_or_else(|| i.to_string(), str::to_owned)
                })
                .collect()
        })
        .unwrap_or_default()
}

/// The material that primitive `primitive` of mesh `mesh` takes in variant
/// `variant` (KHR_materials_variants mappings), if one is mapped.
pub(crate) fn variant_material(
    json: &serde_json::Value,
    mesh: usize,
    primitive: usize,
    variant: usize,
) -> Option<usize> {
    let mappings = json
        .get("meshes")?
        .get(mesh)?
        .get("primitives")?
        .get(primitive)?
        .get("extensions")?
        .get("KHR_materials_variants")?
        .get("mappings")?
        .as_array()?;
    mappings.iter().find_map(|m| {
        let listed = m
            .get("variants")?
            .as_array()?
            .iter()
            .any(|v| v.as_u64() == Some(variant as u64));
        if listed {
            m.get("material")?.as_u64().map(|x| x as usize)
        } else {
            None
        }
    })
}

const DIFFUSE_TRANSMISSION: &str = "KHR_materials_diffuse_transmission";
const IRIDESCENCE: &str = "KHR_materials_iridescence";
const ANISOTROPY: &str = "KHR_materials_anisotropy";

/// The material's `extensions.NAME` object in the raw JSON.
fn material_extension<'j>(
    src: &'j Source,
    material: usize,
    name: &str,
) -> Option<&'j serde_json::Value> {
    src.json
        .get("materials")?
        .get(material)?
        .get("extensions")?
        .get(name)
}

/// A material extension's texture (`extensions.EXT.KEY`), read from the
/// raw JSON, which `validate` has checked (index in range, texCoord a set
/// index).
fn extension_texture(src: &Source, material: usize, ext: &str, key: &str) -> Option<TextureRef> {
    let info = material_extension(src, material, ext)?.get(key)?;
    let texture = info.get("index")?.as_u64()? as usize;
    let tex_coord = info.get("texCoord").and_then(|t| t.as_u64()).unwrap_or(0) as u32;
    Some(texture_ref(
        texture,
        tex_coord,
        info.get("extensions")
            .and_then(|e| e.get("KHR_texture_transform")),
    ))
}

/// A colour factor `key` of extension object `v` (three numbers), each
/// component `default` where absent.
fn rgb(v: Option<&serde_json::Value>, key: &str, default: f32) -> [f32; 3] {
    let a = v.and_then(|v| v.get(key)).and_then(|a| a.as_array());
    let c = |k: usize| {
        a.and_then(|a| a.get(k))
            .and_then(|x| x.as_f64())
            .map_or(default, |x| x as f32)
    };
    [c(0), c(1), c(2)]
}

fn number(v: Option<&serde_json::Value>, key: &str, default: f32) -> f32 {
    v.and_then(|v| v.get(key))
        .and_then(|x| x.as_f64())
        .map_or(default, |x| x as f32)
}

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
    file: String,
    /// Set on the image soupray derives from a KHR_materials_pbrSpecularGlossiness
    /// `specularGlossinessTexture`: the glossiness factor, baked with the
    /// image's alpha (glossiness) into a metallic-roughness texture.
    roughness_from_glossiness: Option<f32>,
    decoded: OnceLock<std::result::Result<Arc<DecodedImage>, String>>,
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

fn parse_transform(value: Option<&serde_json::Value>) -> Option<TextureTransform> {
    let v = value?;
    let pair = |key: &str, default: [f32; 2]| {
        v.get(key)
            .and_then(|a| a.as_array())
            .and_then(|a| Some([a.first()?.as_f64()? as f32, a.get(1)?.as_f64()? as f32]))
            .unwrap_or(default)
    };
    Some(TextureTransform {
        offset: pair("offset", [0.0, 0.0]),
        rotation: v.get("rotation").and_then(|r| r.as_f64()).unwrap_or(0.0) as f32,
        scale: pair("scale", [1.0, 1.0]),
        tex_coord: v.get("texCoord").and_then(|t| t.as_u64()).map(|t| t as u32),
    })
}

fn texture_ref(
    texture: usize,
    tex_coord: u32,
    transform_json: Option<&serde_json::Value>,
) -> TextureRef {
    let transform = parse_transform(transform_json);
    TextureRef {
        texture,
        tex_coord: transform.and_then(|t| t.tex_coord).unwrap_or(tex_coord),
        transform,
    }
}

/// The `KHR_texture_transform` object of a material's texture slot, read
/// from the raw JSON (`slot` is a path such as `["pbrMetallicRoughness",
/// "baseColorTexture"]`).
fn transform_json<'j>(
    src: &'j Source,
    material: usize,
    slot: &[&str],
) -> Option<&'j serde_json::Value> {
    let mut v = src.json.get("materials")?.get(material)?;
    for key in slot {
        v = v.get(key)?;
    }
    v.get("extensions")?.get("KHR_texture_transform")
}

fn info_ref(
    src: &Source,
    material: usize,
    slot: &[&str],
    info: Option<gltf::texture::Info>,
) -> Option<TextureRef> {
    let info = info?;
    Some(texture_ref(
        info.texture().index(),
        info.tex_coord(),
        transform_json(src, material, slot),
    ))
}

pub(crate) fn load_materials(src: &Source) -> Result<MaterialTable> {
    let doc = &src.document;
    let mut materials = Vec::new();
    // (material, its specularGlossinessTexture and glossinessFactor) for
    // the roughness textures derived once the textures are read.
    let mut gloss_textures: Vec<(usize, (TextureRef, f32))> = Vec::new();
    for m in doc.materials() {
        let i = m.index().unwrap_or(0);
        let pbr = m.pbr_metallic_roughness();
        let normal = m.normal_texture();
        let occlusion = m.occlusion_texture();
        materials.push(Material {
            name: m.name().map(str::to_owned),
            base_color_factor: pbr.base_color_factor(),
            base_color_texture: info_ref(
                src,
                i,
                &["pbrMetallicRoughness", "baseColorTexture"],
                pbr.base_color_texture(),
            ),
            metallic_factor: pbr.metallic_factor(),
            roughness_factor: pbr.roughness_factor(),
            metallic_roughness_texture: info_ref(
                src,
                i,
                &["pbrMetallicRoughness", "metallicRoughnessTexture"],
                pbr.metallic_roughness_texture(),
            ),
            normal_scale: normal.as_ref().map_or(1.0, |n| n.scale()),
            normal_texture: normal.as_ref().map(|n| {
                texture_ref(
                    n.texture().index(),
                    n.tex_coord(),
                    transform_json(src, i, &["normalTexture"]),
                )
            }),
            occlusion_strength: occlusion.as_ref().map_or(1.0, |o| o.strength()),
            occlusion_texture: occlusion.as_ref().map(|o| {
                texture_ref(
                    o.texture().index(),
                    o.tex_coord(),
                    transform_json(src, i, &["occlusionTexture"]),
                )
            }),
            emissive_factor: m.emissive_factor(),
            emissive_strength: m.emissive_strength().unwrap_or(1.0),
            emissive_texture: info_ref(src, i, &["emissiveTexture"], m.emissive_texture()),
            alpha_mode: match m.alpha_mode() {
                gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                gltf::material::AlphaMode::Mask => AlphaMode::Mask,
                gltf::material::AlphaMode::Blend => AlphaMode::Blend,
            },
            alpha_cutoff: m.alpha_cutoff().unwrap_or(0.5),
            double_sided: m.double_sided(),
            transmission_factor: number(
                material_extension(src, i, "KHR_materials_transmission"),
                "transmissionFactor",
                0.0,
            ),
            ior: number(material_extension(src, i, "KHR_materials_ior"), "ior", 1.5),
            thickness_factor: number(
                material_extension(src, i, "KHR_materials_volume"),
                "thicknessFactor",
                0.0,
            ),
            attenuation_color: rgb(
                material_extension(src, i, "KHR_materials_volume"),
                "attenuationColor",
                1.0,
            ),
            attenuation_distance: number(
                material_extension(src, i, "KHR_materials_volume"),
                "attenuationDistance",
                f32::INFINITY,
            ),
            unlit: material_extension(src, i, "KHR_materials_unlit").is_some(),
            specular_factor: number(
                material_extension(src, i, "KHR_materials_specular"),
                "specularFactor",
                1.0,
            ),
            specular_color: rgb(
                material_extension(src, i, "KHR_materials_specular"),
                "specularColorFactor",
                1.0,
            ),
            transmission_texture: extension_texture(
                src,
                i,
                "KHR_materials_transmission",
                "transmissionTexture",
            ),
            specular_texture: extension_texture(
                src,
                i,
                "KHR_materials_specular",
                "specularTexture",
            ),
            specular_color_texture: extension_texture(
                src,
                i,
                "KHR_materials_specular",
                "specularColorTexture",
            ),
            clearcoat_factor: number(
                material_extension(src, i, "KHR_materials_clearcoat"),
                "clearcoatFactor",
                0.0,
            ),
            clearcoat_roughness: number(
                material_extension(src, i, "KHR_materials_clearcoat"),
                "clearcoatRoughnessFactor",
                0.0,
            ),
            sheen_color: rgb(
                material_extension(src, i, "KHR_materials_sheen"),
                "sheenColorFactor",
                0.0,
            ),
            sheen_roughness: number(
                material_extension(src, i, "KHR_materials_sheen"),
                "sheenRoughnessFactor",
                0.0,
            ),
            clearcoat_texture: extension_texture(
                src,
                i,
                "KHR_materials_clearcoat",
                "clearcoatTexture",
            ),
            clearcoat_roughness_texture: extension_texture(
                src,
                i,
                "KHR_materials_clearcoat",
                "clearcoatRoughnessTexture",
            ),
            clearcoat_normal_texture: extension_texture(
                src,
                i,
                "KHR_materials_clearcoat",
                "clearcoatNormalTexture",
            ),
            clearcoat_normal_scale: number(
                material_extension(src, i, "KHR_materials_clearcoat")
                    .and_then(|c| c.get("clearcoatNormalTexture")),
                "scale",
                1.0,
            ),
            sheen_color_texture: extension_texture(
                src,
                i,
                "KHR_materials_sheen",
                "sheenColorTexture",
            ),
            sheen_roughness_texture: extension_texture(
                src,
                i,
                "KHR_materials_sheen",
                "sheenRoughnessTexture",
            ),
            diffuse_transmission: number(
                material_extension(src, i, DIFFUSE_TRANSMISSION),
                "diffuseTransmissionFactor",
                0.0,
            ),
            diffuse_transmission_texture: extension_texture(
                src,
                i,
                DIFFUSE_TRANSMISSION,
                "diffuseTransmissionTexture",
            ),
            diffuse_transmission_color: rgb(
                material_extension(src, i, DIFFUSE_TRANSMISSION),
                "diffuseTransmissionColorFactor",
                1.0,
            ),
            diffuse_transmission_color_texture: extension_texture(
                src,
                i,
                DIFFUSE_TRANSMISSION,
                "diffuseTransmissionColorTexture",
            ),
            iridescence: number(
                material_extension(src, i, IRIDESCENCE),
                "iridescenceFactor",
                0.0,
            ),
            iridescence_texture: extension_texture(src, i, IRIDESCENCE, "iridescenceTexture"),
            iridescence_ior: number(
                material_extension(src, i, IRIDESCENCE),
                "iridescenceIor",
                1.3,
            ),
            iridescence_thickness_min: number(
                material_extension(src, i, IRIDESCENCE),
                "iridescenceThicknessMinimum",
                100.0,
            ),
            iridescence_thickness_max: number(
                material_extension(src, i, IRIDESCENCE),
                "iridescenceThicknessMaximum",
                400.0,
            ),
            iridescence_thickness_texture: extension_texture(
                src,
                i,
                IRIDESCENCE,
                "iridescenceThicknessTexture",
            ),
            anisotropy_strength: number(
                material_extension(src, i, ANISOTROPY),
                "anisotropyStrength",
                0.0,
            ),
            anisotropy_rotation: number(
                material_extension(src, i, ANISOTROPY),
                "anisotropyRotation",
                0.0,
            ),
            anisotropy_texture: extension_texture(src, i, ANISOTROPY, "anisotropyTexture"),
            dispersion: number(
                material_extension(src, i, "KHR_materials_dispersion"),
                "dispersion",
                0.0,
            ),
        });
        if let Some(material) = materials.last_mut() {
            if let Some(gloss) = apply_specular_glossiness(src, i, material) {
                gloss_textures.push((materials.len() - 1, gloss));
            }
        }
    }

    let wrap = |w: gltf::texture::WrappingMode| match w {
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
    };
    let mut textures: Vec<Texture> = doc
        .textures()
        .map(|t| {
            let s = t.sampler();
            Texture {
                name: t.name().map(str::to_owned),
                image: t.source().index(),
                wrap_s: wrap(s.wrap_s()),
                wrap_t: wrap(s.wrap_t()),
                mag_filter: match s.mag_filter() {
                    Some(gltf::texture::MagFilter::Nearest) => Filter::Nearest,
                    _ => Filter::Linear,
                },
                min_filter: match s.min_filter() {
                    Some(gltf::texture::MinFilter::Nearest)
                    | Some(gltf::texture::MinFilter::NearestMipmapNearest)
                    | Some(gltf::texture::MinFilter::NearestMipmapLinear) => Filter::Nearest,
                    _ => Filter::Linear,
                },
            }
        })
        .collect();

    let mut images = Vec::new();
    for img in doc.images() {
        let source = match img.source() {
            gltf::image::Source::Uri { uri, .. } => match uri.strip_prefix("data:") {
                Some(rest) => {
                    let payload = rest.split_once(',').map_or("", |(_, p)| p);
                    ImageSource::Bytes(decode_base64(payload).unwrap_or_default().into())
                }
                None => ImageSource::File(resolve_uri(&src.dir, uri)),
            },
            gltf::image::Source::View { view, .. } => {
                let data = &src.buffers[view.buffer().index()];
                let end = view.offset().saturating_add(view.length());
                if end > data.len() {
                    return Err(SceneError::invalid(
                        &src.file,
                        format!(
                            "image {} lies in bufferView {} (bytes {}..{end} of buffer {}), but the buffer holds only {} bytes. \
                             Fix: re-export the asset or re-copy it completely.",
                            img.index(),
                            view.index(),
                            view.offset(),
                            view.buffer().index(),
                            data.len()
                        ),
                    ));
                }
                ImageSource::Bytes(data[view.offset()..end].into())
            }
        };
        images.push(Image {
            name: img.name().map(str::to_owned),
            source,
            file: src.file.clone(),
            roughness_from_glossiness: None,
            decoded: OnceLock::new(),
        });
    }
    add_roughness_textures(&mut materials, &mut textures, &mut images, &gloss_textures);

    Ok(MaterialTable {
        materials,
        textures,
        images,
        default_material: None,
    })
}
