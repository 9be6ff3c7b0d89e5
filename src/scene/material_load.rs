//! Reading a glTF file's materials into the `MaterialTable`: the core
//! metallic-roughness material, every supported `KHR_materials_*`
//! extension, KHR_texture_transform, and KHR_materials_pbrSpecularGlossiness
//! converted to metallic-roughness.

use std::sync::OnceLock;

use super::error::{Result, SceneError};
use super::material::*;
use super::source::{decode_base64, resolve_uri, Source};

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
pub(super) fn apply_specular_glossiness(
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
pub(super) fn add_roughness_textures(
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

/// The `KHR_materials_*` extensions the tables read (every one that sets
/// a factor or a texture), each once, in table order.
fn table_extensions() -> Vec<&'static str> {
    let factors = FACTORS.iter().filter_map(|f| f.extension_key());
    let slots = Slot::ALL.into_iter().filter_map(|s| s.extension_key());
    let mut names: Vec<&'static str> = Vec::new();
    for (ext, _) in factors.chain(slots) {
        if !names.contains(&ext) {
            names.push(ext);
        }
    }
    names
}

/// The `KHR_materials_*` extensions soupray renders (the rest are named in
/// a warning when a scene uses them): those whose factors and textures
/// the material tables read, and the three that change the material
/// otherwise.
pub fn supported_material_extensions() -> Vec<&'static str> {
    let mut names = table_extensions();
    names.extend([
        "KHR_materials_unlit",
        "KHR_materials_variants",
        SPECULAR_GLOSSINESS,
    ]);
    names
}

/// The textures of KHR_materials_pbrSpecularGlossiness, below
/// `/materials/N/`: what `validate` checks beside the `Slot`s.
pub(crate) const SPECULAR_GLOSSINESS_TEXTURES: &[&str] = &[
    "extensions/KHR_materials_pbrSpecularGlossiness/diffuseTexture",
    "extensions/KHR_materials_pbrSpecularGlossiness/specularGlossinessTexture",
];

/// One warning per `KHR_materials_*` extension the file uses (on a
/// material, or in `extensionsUsed`) that soupray does not render, naming
/// it and the first material using it.
pub(crate) fn ignored_material_extensions(json: &serde_json::Value) -> Vec<String> {
    let supported = supported_material_extensions();
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
            if supported.contains(&ext.as_str()) {
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
        if ext.starts_with("KHR_materials_") && !supported.contains(&ext) {
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

/// The material's `extensions.NAME` object in the raw JSON.
pub(super) fn material_extension<'j>(
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

/// The JSON value at `path` below material `material`'s object.
fn material_json<'j>(
    src: &'j Source,
    material: usize,
    path: &str,
) -> Option<&'j serde_json::Value> {
    let object = src.json.get("materials")?.get(material)?;
    path.split('/').try_fold(object, |v, key| v.get(key))
}

/// A material extension's texture (`extensions.EXT.KEY`), read from the
/// raw JSON, which `validate` has checked (index in range, texCoord a set
/// index).
pub(super) fn extension_texture(
    src: &Source,
    material: usize,
    ext: &str,
    key: &str,
) -> Option<TextureRef> {
    texture_at(src, material, &format!("extensions/{ext}/{key}"))
}

/// The texture info at `path` below a material.
fn texture_at(src: &Source, material: usize, path: &str) -> Option<TextureRef> {
    let info = material_json(src, material, path)?;
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
pub(super) fn rgb(v: Option<&serde_json::Value>, key: &str, default: f32) -> [f32; 3] {
    let a = v.and_then(|v| v.get(key)).and_then(|a| a.as_array());
    let c = |k: usize| {
        a.and_then(|a| a.get(k))
            .and_then(|x| x.as_f64())
            .map_or(default, |x| x as f32)
    };
    [c(0), c(1), c(2)]
}

pub(super) fn number(v: Option<&serde_json::Value>, key: &str, default: f32) -> f32 {
    v.and_then(|v| v.get(key))
        .and_then(|x| x.as_f64())
        .map_or(default, |x| x as f32)
}

pub(super) fn parse_transform(value: Option<&serde_json::Value>) -> Option<TextureTransform> {
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

pub(super) fn texture_ref(
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
pub(super) fn transform_json<'j>(
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

pub(super) fn info_ref(
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
        materials.push(load_material(src, i, &m));
        if let Some(material) = materials.last_mut() {
            if let Some(gloss) = apply_specular_glossiness(src, i, material) {
                gloss_textures.push((materials.len() - 1, gloss));
            }
        }
    }
    let mut textures = load_textures(doc);
    let mut images = load_images(src)?;
    add_roughness_textures(&mut materials, &mut textures, &mut images, &gloss_textures);

    Ok(MaterialTable {
        materials,
        textures,
        images,
        default_material: None,
    })
}

/// Material `i` (`m`): the core glTF model, then each extension soupray
/// reads (the specular-glossiness workflow is applied by the caller).
fn load_material(src: &Source, i: usize, m: &gltf::Material) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let normal = m.normal_texture();
    let occlusion = m.occlusion_texture();
    let mut material = Material {
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
        unlit: material_extension(src, i, "KHR_materials_unlit").is_some(),
        ..Material::default()
    };
    read_extensions(src, i, &mut material);
    material
}

/// The extensions' factors and textures, each row of the tables in
/// `material` the file sets (the core ones come through `gltf`).
fn read_extensions(src: &Source, i: usize, material: &mut Material) {
    for factor in FACTORS.iter().filter(|f| f.extension_key().is_some()) {
        let Some(value) = material_json(src, i, factor.path) else {
            continue;
        };
        let components = factor.components(material);
        match value.as_array() {
            // A colour's missing components keep their defaults.
            Some(array) if components.len() > 1 => {
                for (c, x) in components.iter_mut().zip(array) {
                    if let Some(x) = x.as_f64() {
                        *c = x as f32;
                    }
                }
            }
            _ if components.len() == 1 => {
                if let Some(x) = value.as_f64() {
                    components[0] = x as f32;
                }
            }
            _ => {}
        }
    }
    for slot in Slot::ALL {
        if slot.extension_key().is_some() {
            *slot.of_mut(material) = texture_at(src, i, slot.path());
        }
    }
}

/// The file's textures with their samplers' wrap modes and filters.
fn load_textures(doc: &gltf::Document) -> Vec<Texture> {
    let wrap = |w: gltf::texture::WrappingMode| match w {
        gltf::texture::WrappingMode::ClampToEdge => Wrap::ClampToEdge,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::MirroredRepeat,
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
    };
    doc.textures()
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
        .collect()
}

/// The file's images, each a file to read or the bytes (a data URI's or a
/// bufferView's) to decode.
fn load_images(src: &Source) -> Result<Vec<Image>> {
    let doc = &src.document;
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
    Ok(images)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_tables_name_every_rendered_material_extension() {
        let mut names = table_extensions();
        names.sort_unstable();
        let want = [
            "KHR_materials_anisotropy",
            "KHR_materials_clearcoat",
            "KHR_materials_diffuse_roughness",
            "KHR_materials_diffuse_transmission",
            "KHR_materials_dispersion",
            "KHR_materials_emissive_strength",
            "KHR_materials_ior",
            "KHR_materials_iridescence",
            "KHR_materials_sheen",
            "KHR_materials_specular",
            "KHR_materials_transmission",
            "KHR_materials_volume",
        ];
        assert_eq!(names, want);
    }
}
