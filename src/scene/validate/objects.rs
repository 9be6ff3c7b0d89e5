//! Scenes, images, textures, materials, meshes, nodes, skins, cameras and
//! lights: their references, and the parts each kind needs.

use serde_json::{Map, Value};

use super::{array, as_u32, describe, fail, items, object, uint, Check};
use crate::scene::error::Result;
use crate::scene::material::Slot;
use crate::scene::material_load::SPECULAR_GLOSSINESS_TEXTURES;

pub(super) fn check_scenes(c: &Check, root: &Map<String, Value>) -> Result<()> {
    let file = c.file;
    if let Some(s) = root.get("scene") {
        c.index(s, &|| "scene".into(), "scenes")?;
    }
    for (i, s) in items(file, root, "scenes")?.iter().enumerate() {
        c.index_list(s, "nodes", &|| format!("scene {i}"), "nodes", true)?;
    }
    Ok(())
}

/// Each image has exactly one of a uri and a bufferView (with a mimeType).
pub(super) fn check_images(c: &Check, root: &Map<String, Value>) -> Result<()> {
    let file = c.file;
    for (i, img) in items(file, root, "images")?.iter().enumerate() {
        let at = || format!("image {i}");
        let view = c.opt_index(img, "bufferView", &at, "bufferViews")?;
        match (img.get("uri"), view) {
            (Some(u), None) if u.is_string() => {}
            (Some(_), None) => return Err(fail(file, format!("{}.uri is not a string", at()))),
            (None, Some(_)) => {
                if !img.get("mimeType").is_some_and(Value::is_string) {
                    return Err(fail(
                        file,
                        format!(
                            "{} is stored in a bufferView but has no mimeType; glTF requires one (image/png or image/jpeg)",
                            at()
                        ),
                    ));
                }
            }
            (Some(_), Some(_)) => {
                return Err(fail(
                    file,
                    format!("{} has both a uri and a bufferView; glTF allows one", at()),
                ))
            }
            (None, None) => {
                return Err(fail(
                    file,
                    format!("{} has neither a uri nor a bufferView", at()),
                ))
            }
        }
    }
    Ok(())
}

/// Each texture has an image, from `source` or a texture-source extension.
pub(super) fn check_textures(c: &Check, root: &Map<String, Value>) -> Result<()> {
    let file = c.file;
    for (i, t) in items(file, root, "textures")?.iter().enumerate() {
        let at = || format!("texture {i}");
        c.opt_index(t, "sampler", &at, "samplers")?;
        let fallback = c.opt_index(t, "source", &at, "images")?;
        let mut any_source = fallback.is_some();
        for ext in crate::scene::texture_source::TEXTURE_SOURCE_EXTENSIONS {
            let Some(e) = t.get("extensions").and_then(|e| e.get(*ext)) else {
                continue;
            };
            let at_ext = || format!("{}.extensions.{ext}", at());
            let e = object(file, e, &at_ext)?;
            any_source |= c.opt_index(e, "source", &at_ext, "images")?.is_some();
        }
        if !any_source {
            return Err(fail(
                file,
                format!(
                    "{} has no image: neither source nor a texture-source extension's source",
                    at()
                ),
            ));
        }
    }
    Ok(())
}

/// Materials: every texture reference and its texCoord.
pub(super) fn check_materials(c: &Check, root: &Map<String, Value>) -> Result<()> {
    let file = c.file;
    for (i, m) in items(file, root, "materials")?.iter().enumerate() {
        // Every texture soupray reads, and those spec-gloss converts.
        let at_path = |path: &str| {
            let mut keys = path.split('/');
            let first = m.get(keys.next()?)?;
            keys.try_fold(first, |v, key| v.get(key))
        };
        let slots = Slot::ALL
            .iter()
            .map(|s| s.path())
            .chain(SPECULAR_GLOSSINESS_TEXTURES.iter().copied())
            .map(|path| (path.replace('/', "."), at_path(path)));
        for (slot, info) in slots {
            let Some(info) = info else { continue };
            let at = || format!("material {i} {slot}");
            let info = object(file, info, &at)?;
            c.index(
                info.get("index").unwrap_or(&Value::Null),
                &|| format!("{}.index", at()),
                "textures",
            )?;
            for tc in [
                info.get("texCoord"),
                info.get("extensions")
                    .and_then(|e| e.get("KHR_texture_transform"))
                    .and_then(|t| t.get("texCoord")),
            ]
            .into_iter()
            .flatten()
            {
                if as_u32(tc).is_none() {
                    return Err(fail(
                        file,
                        format!(
                            "{}: texCoord {} is not a valid set index",
                            at(),
                            describe(tc)
                        ),
                    ));
                }
            }
        }
    }

    Ok(())
}

/// Meshes: each has primitives, whose attributes, indices, material and
/// morph targets refer to what exists, with the component types glTF
/// allows.
pub(super) fn check_meshes(
    c: &Check,
    root: &Map<String, Value>,
    accessor_types: &[(u64, bool)],
) -> Result<()> {
    let file = c.file;
    let quantized = crate::scene::source::uses_extension(root, crate::scene::mesh::QUANTIZATION);
    for (i, mesh) in items(file, root, "meshes")?.iter().enumerate() {
        let prims = array(
            file,
            mesh.get("primitives").unwrap_or(&Value::Null),
            &|| format!("mesh {i}.primitives"),
        )?;
        if prims.is_empty() {
            return Err(fail(file, format!("mesh {i} has no primitives")));
        }
        for (p, prim) in prims.iter().enumerate() {
            check_primitive(c, i, p, prim, quantized, accessor_types)?;
        }
    }
    Ok(())
}

fn check_primitive(
    c: &Check,
    i: usize,
    p: usize,
    prim: &Value,
    quantized: bool,
    accessor_types: &[(u64, bool)],
) -> Result<()> {
    let file = c.file;
    let at = || format!("mesh {i} primitive {p}");
    let prim = object(file, prim, &at)?;
    let attrs = object(
        file,
        prim.get("attributes").unwrap_or(&Value::Null),
        &|| format!("{}.attributes", at()),
    )?;
    for (name, v) in attrs {
        let a = c.index(v, &|| format!("{} attribute {name}", at()), "accessors")?;
        // Integer texture coordinates, colours and weights are
        // read as fractions only when normalized (glTF 2.0 3.7.2.1).
        let (ct, normalized) = accessor_types[a];
        let fraction = ["TEXCOORD_", "COLOR_", "WEIGHTS_"]
            .iter()
            .any(|p| name.starts_with(p));
        // KHR_mesh_quantization adds every (un)normalized 8- and
        // 16-bit type for texture coordinates (its table).
        let quantized_uv = quantized && name.starts_with("TEXCOORD_") && matches!(ct, 5120..=5123);
        if fraction && ct != 5126 && !(matches!(ct, 5121 | 5123) && normalized) && !quantized_uv {
            return Err(fail(
                file,
                format!(
                    "{} attribute {name} is accessor {a} of componentType {ct}{}; glTF allows FLOAT \
                     or normalized UNSIGNED_BYTE/UNSIGNED_SHORT there{}",
                    at(),
                    if normalized { " (normalized)" } else { " without normalized: true" },
                    if name.starts_with("TEXCOORD_") && matches!(ct, 5120..=5123) {
                        " (and any 8- or 16-bit integers when the file lists KHR_mesh_quantization \
                         in extensionsUsed)"
                    } else {
                        ""
                    }
                ),
            ));
        }
    }
    c.opt_index(prim, "indices", &at, "accessors")?;
    c.opt_index(prim, "material", &at, "materials")?;
    let mode = uint(file, prim.get("mode"), &|| format!("{}.mode", at()), 4)?;
    if mode > 6 {
        return Err(fail(
            file,
            format!("{} has mode {mode}, which glTF does not define", at()),
        ));
    }
    if let Some(targets) = prim.get("targets") {
        for (t, target) in array(file, targets, &|| format!("{}.targets", at()))?
            .iter()
            .enumerate()
        {
            let target = object(file, target, &|| format!("{} morph target {t}", at()))?;
            for (name, v) in target {
                c.index(
                    v,
                    &|| format!("{} morph target {t} attribute {name}", at()),
                    "accessors",
                )?;
            }
        }
    }
    Ok(())
}

pub(super) fn check_nodes(c: &Check, root: &Map<String, Value>) -> Result<()> {
    for (i, n) in items(c.file, root, "nodes")?.iter().enumerate() {
        let at = || format!("node {i}");
        c.index_list(n, "children", &at, "nodes", true)?;
        c.opt_index(n, "camera", &at, "cameras")?;
        c.opt_index(n, "mesh", &at, "meshes")?;
        c.opt_index(n, "skin", &at, "skins")?;
        if let Some(l) = n
            .get("extensions")
            .and_then(|e| e.get("KHR_lights_punctual"))
            .and_then(|e| e.get("light"))
        {
            c.index(
                l,
                &|| format!("{} KHR_lights_punctual.light", at()),
                "lights",
            )?;
        }
    }
    Ok(())
}

/// Each skin has joints, listed once each.
pub(super) fn check_skins(c: &Check, root: &Map<String, Value>) -> Result<()> {
    let file = c.file;
    for (i, s) in items(file, root, "skins")?.iter().enumerate() {
        let at = || format!("skin {i}");
        c.opt_index(s, "inverseBindMatrices", &at, "accessors")?;
        c.opt_index(s, "skeleton", &at, "nodes")?;
        if c.index_list(s, "joints", &at, "nodes", true)?.is_empty() {
            return Err(fail(file, format!("skin {i} has no joints")));
        }
    }
    Ok(())
}

/// Each camera has the object its type needs.
pub(super) fn check_cameras(c: &Check, root: &Map<String, Value>) -> Result<()> {
    let file = c.file;
    for (i, cam) in items(file, root, "cameras")?.iter().enumerate() {
        let ty = cam.get("type").and_then(Value::as_str).unwrap_or("");
        if !matches!(ty, "perspective" | "orthographic")
            || !cam.get(ty).is_some_and(Value::is_object)
        {
            return Err(fail(
                file,
                format!(
                    "camera {i} has type {} without a matching `perspective` or `orthographic` object",
                    describe(cam.get("type").unwrap_or(&Value::Null))
                ),
            ));
        }
    }
    Ok(())
}

/// Each KHR_lights_punctual light has a known type, and spot lights their
/// `spot` object.
pub(super) fn check_lights(c: &Check, lights: &[&Map<String, Value>]) -> Result<()> {
    let file = c.file;
    for (i, l) in lights.iter().enumerate() {
        let ty = l.get("type").and_then(Value::as_str).unwrap_or("");
        if !matches!(ty, "directional" | "point" | "spot") {
            return Err(fail(
                file,
                format!("KHR_lights_punctual light {i} has type {}, which the extension does not define", describe(l.get("type").unwrap_or(&Value::Null))),
            ));
        }
        if ty == "spot" && !l.get("spot").is_some_and(Value::is_object) {
            return Err(fail(
                file,
                format!("KHR_lights_punctual light {i} is a spot light without a `spot` object"),
            ));
        }
    }

    Ok(())
}
