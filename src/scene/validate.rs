//! Checking the untyped JSON of a glTF file before anything indexes into
//! it, the `gltf` crate included.
//!
//! The `gltf` crate reads every index as a `u32` (so `"mesh": 4294967297`
//! silently becomes mesh 1), does not check animation channel targets or
//! image sources, and `unwrap`s its way through references it assumes are
//! valid: a bad file panics it. So every reference in the document is
//! checked here first, against glTF 2.0's own rules: each index is a
//! non-negative integer below 2^32 naming an object that exists; lists the
//! spec requires to be unique are; accessors are aligned to their component
//! size and lie inside their bufferView, bufferViews inside their buffer's
//! `byteLength`; the asset's version is one soupray understands; camera and
//! light objects have the parts their type needs; animation outputs have
//! the component types the spec allows for their path.
//!
//! Channels that target a path soupray does not implement (or a channel
//! without a node, or a `"pointer"` channel without its
//! `KHR_animation_pointer` pointer) are removed from the document with one
//! warning per animation and path: the spec says such channels are to be
//! ignored by a loader that does not know them. `"pointer"` channels stay
//! (`scene::pointer` reads them); the pointer itself is resolved there.

use std::collections::BTreeMap;

use serde_json::{Map, Value};

use super::error::{Result, SceneError};

const KNOWN_PATHS: &[&str] = &["translation", "rotation", "scale", "weights"];

struct Check<'a> {
    file: &'a str,
    counts: BTreeMap<&'static str, usize>,
}

fn fail(file: &str, detail: String) -> SceneError {
    SceneError::Invalid {
        file: file.to_owned(),
        detail: format!(
            "is not valid glTF 2.0: {detail}. Fix: re-export the asset, or run it through the Khronos glTF-Validator to see every problem."
        ),
    }
}

fn describe(v: &Value) -> String {
    let s = v.to_string();
    if s.len() > 40 {
        format!(
            "{}...",
            &s[..s.char_indices().nth(40).map_or(s.len(), |(i, _)| i)]
        )
    } else {
        s
    }
}

/// A non-negative integer that fits in 32 bits.
fn as_u32(v: &Value) -> Option<u64> {
    v.as_u64().filter(|&n| n <= u64::from(u32::MAX))
}

fn uint(file: &str, v: Option<&Value>, at: &dyn Fn() -> String, default: u64) -> Result<u64> {
    match v {
        None => Ok(default),
        Some(v) => v.as_u64().ok_or_else(|| {
            fail(
                file,
                format!("{} is {}, not a non-negative integer", at(), describe(v)),
            )
        }),
    }
}

impl Check<'_> {
    fn count(&self, of: &str) -> usize {
        self.counts.get(of).copied().unwrap_or(0)
    }

    /// `v` must be an index into the top-level array `of`.
    fn index(&self, v: &Value, at: &dyn Fn() -> String, of: &'static str) -> Result<usize> {
        let n = self.count(of);
        match as_u32(v) {
            Some(i) if (i as usize) < n => Ok(i as usize),
            Some(i) => Err(fail(
                self.file,
                format!(
                    "{} refers to {} {i}, but the file has {}",
                    at(),
                    singular(of),
                    if n == 0 {
                        format!("no {of}")
                    } else {
                        format!("{n} {of} (0..{})", n - 1)
                    }
                ),
            )),
            None => Err(fail(
                self.file,
                format!(
                    "{} is {}, which is not a valid index (a non-negative integer below 2^32)",
                    at(),
                    describe(v)
                ),
            )),
        }
    }

    fn opt_index(
        &self,
        obj: &Map<String, Value>,
        key: &str,
        at: &dyn Fn() -> String,
        of: &'static str,
    ) -> Result<Option<usize>> {
        match obj.get(key) {
            None => Ok(None),
            Some(v) => self.index(v, &|| format!("{}.{key}", at()), of).map(Some),
        }
    }

    /// A list of indices into `of`, each at most once.
    fn index_list(
        &self,
        obj: &Map<String, Value>,
        key: &str,
        at: &dyn Fn() -> String,
        of: &'static str,
        unique: bool,
    ) -> Result<Vec<usize>> {
        let Some(v) = obj.get(key) else {
            return Ok(Vec::new());
        };
        let list = array(self.file, v, &|| format!("{}.{key}", at()))?;
        let mut out = Vec::with_capacity(list.len());
        let mut seen = std::collections::HashSet::new();
        for (k, item) in list.iter().enumerate() {
            let i = self.index(item, &|| format!("{}.{key}[{k}]", at()), of)?;
            if unique && !seen.insert(i) {
                return Err(fail(
                    self.file,
                    format!(
                        "{}.{key} lists {} {i} more than once; glTF requires each to appear once",
                        at(),
                        singular(of)
                    ),
                ));
            }
            out.push(i);
        }
        Ok(out)
    }
}

fn singular(of: &str) -> &str {
    match of {
        "meshes" => "mesh",
        _ => of.strip_suffix('s').unwrap_or(of),
    }
}

fn array<'v>(file: &str, v: &'v Value, at: &dyn Fn() -> String) -> Result<&'v Vec<Value>> {
    v.as_array()
        .ok_or_else(|| fail(file, format!("{} is {}, not an array", at(), describe(v))))
}

fn object<'v>(file: &str, v: &'v Value, at: &dyn Fn() -> String) -> Result<&'v Map<String, Value>> {
    v.as_object()
        .ok_or_else(|| fail(file, format!("{} is {}, not an object", at(), describe(v))))
}

/// The objects of top-level array `key` (empty when absent).
fn items<'v>(
    file: &str,
    root: &'v Map<String, Value>,
    key: &str,
) -> Result<Vec<&'v Map<String, Value>>> {
    let Some(v) = root.get(key) else {
        return Ok(Vec::new());
    };
    array(file, v, &|| key.to_owned())?
        .iter()
        .enumerate()
        .map(|(i, item)| object(file, item, &|| format!("{key}[{i}]")))
        .collect()
}

fn component_size(ty: u64) -> Option<u64> {
    match ty {
        5120 | 5121 => Some(1),
        5122 | 5123 => Some(2),
        5125 | 5126 => Some(4),
        _ => None,
    }
}

/// (columns, rows) of an accessor type.
fn shape(ty: &str) -> Option<(u64, u64)> {
    Some(match ty {
        "SCALAR" => (1, 1),
        "VEC2" => (1, 2),
        "VEC3" => (1, 3),
        "VEC4" => (1, 4),
        "MAT2" => (2, 2),
        "MAT3" => (3, 3),
        "MAT4" => (4, 4),
        _ => return None,
    })
}

/// "major.minor" as the spec's `asset.version` pattern `^[0-9]+\.[0-9]+$`.
fn parse_version(s: &str) -> Option<(u64, u64)> {
    let (a, b) = s.split_once('.')?;
    let num = |t: &str| {
        (!t.is_empty() && t.len() < 10 && t.bytes().all(|c| c.is_ascii_digit()))
            .then(|| t.parse().ok())
            .flatten()
    };
    Some((num(a)?, num(b)?))
}

/// Whether glTF 2.0 defines the attribute name (or it is an
/// application-specific "_NAME").
fn known_semantic(name: &str) -> bool {
    if matches!(name, "POSITION" | "NORMAL" | "TANGENT") || name.starts_with('_') {
        return true;
    }
    ["TEXCOORD_", "COLOR_", "JOINTS_", "WEIGHTS_"]
        .iter()
        .any(|p| {
            name.strip_prefix(p).is_some_and(|n| {
                !n.is_empty() && n.len() < 10 && n.bytes().all(|c| c.is_ascii_digit())
            })
        })
}

/// Validates `json` in place (removing channels soupray must ignore) and
/// returns the warnings to show.
pub(super) fn validate(file: &str, json: &mut Value) -> Result<Vec<String>> {
    let mut warnings = Vec::new();
    let root = json
        .as_object_mut()
        .ok_or_else(|| fail(file, "the JSON document is not an object".into()))?;

    // The asset's version.
    let asset = root.get("asset").ok_or_else(|| {
        fail(
            file,
            "the file has no `asset` object (with `version`)".into(),
        )
    })?;
    let asset = object(file, asset, &|| "asset".into())?;
    let version = asset
        .get("version")
        .and_then(Value::as_str)
        .ok_or_else(|| fail(file, "asset.version is missing or not a string".into()))?;
    match parse_version(version) {
        Some((2, _)) => {}
        Some(_) | None => {
            return Err(SceneError::Malformed {
                file: file.to_owned(),
                detail: format!(
                    "declares glTF version \"{}\" (asset.version); soupray reads glTF 2.x. \
                     Fix: convert the asset to glTF 2.0.",
                    describe(&Value::String(version.to_owned())).trim_matches('"')
                ),
            })
        }
    }
    if let Some(min) = asset.get("minVersion") {
        let ok = min
            .as_str()
            .and_then(parse_version)
            .is_some_and(|v| v <= (2, 0));
        if !ok {
            return Err(SceneError::Malformed {
                file: file.to_owned(),
                detail: format!(
                    "requires glTF version {} (asset.minVersion); soupray reads glTF 2.0. \
                     Fix: export the asset for glTF 2.0.",
                    describe(min)
                ),
            });
        }
    }

    // Unknown animation paths: removed with one warning per (animation, path).
    if let Some(Value::Array(animations)) = root.get_mut("animations") {
        for (a, anim) in animations.iter_mut().enumerate() {
            let Some(Value::Array(channels)) = anim.get_mut("channels") else {
                continue;
            };
            let mut skipped: BTreeMap<String, usize> = BTreeMap::new();
            channels.retain(|ch| {
                let target = ch.get("target");
                let path = target.and_then(|t| t.get("path")).and_then(Value::as_str);
                let reason = match path {
                    Some("pointer") if super::pointer::channel_pointer(ch).is_some() => None,
                    Some("pointer") => Some(
                        "target path \"pointer\" but no KHR_animation_pointer pointer string"
                            .to_owned(),
                    ),
                    Some(p) if !KNOWN_PATHS.contains(&p) => Some(format!("target path \"{p}\"")),
                    Some(_) if target.and_then(|t| t.get("node")).is_none() => {
                        Some("no target node".to_owned())
                    }
                    _ => None,
                };
                match reason {
                    Some(r) => {
                        *skipped.entry(r).or_default() += 1;
                        false
                    }
                    None => true,
                }
            });
            for (why, n) in skipped {
                warnings.push(format!(
                    "animation {a}: skipped {n} channel(s) with {why}, which soupray does not implement"
                ));
            }
        }
    }

    // Attribute names glTF does not define (application-specific ones must
    // start with "_"): soupray reads none of them, so they are dropped with
    // one warning each instead of failing the `gltf` crate's validation.
    if let Some(Value::Array(meshes)) = root.get_mut("meshes") {
        let mut unknown: BTreeMap<String, usize> = BTreeMap::new();
        for mesh in meshes.iter_mut() {
            let Some(Value::Array(prims)) = mesh.get_mut("primitives") else {
                continue;
            };
            for prim in prims.iter_mut() {
                let mut maps: Vec<&mut Value> = Vec::new();
                let Value::Object(p) = prim else { continue };
                for (key, v) in p.iter_mut() {
                    match (key.as_str(), v) {
                        ("attributes", v @ Value::Object(_)) => maps.push(v),
                        ("targets", Value::Array(targets)) => maps.extend(targets.iter_mut()),
                        _ => {}
                    }
                }
                for map in maps {
                    if let Value::Object(m) = map {
                        m.retain(|name, _| {
                            let known = known_semantic(name);
                            if !known {
                                *unknown.entry(name.clone()).or_default() += 1;
                            }
                            known
                        });
                    }
                }
            }
        }
        for (name, n) in unknown {
            warnings.push(format!(
                "ignored the attribute \"{name}\" of {n} primitive(s) or morph target(s): glTF defines no such \
                 attribute (application-specific names start with \"_\")"
            ));
        }
    }

    let root = &*root;
    let mut check = Check {
        file,
        counts: BTreeMap::new(),
    };
    for key in [
        "accessors",
        "animations",
        "buffers",
        "bufferViews",
        "cameras",
        "images",
        "materials",
        "meshes",
        "nodes",
        "samplers",
        "scenes",
        "skins",
        "textures",
    ] {
        let n = items(file, root, key)?.len();
        check.counts.insert(key, n);
    }
    let lights_ext = root
        .get("extensions")
        .and_then(|e| e.get("KHR_lights_punctual"));
    let lights: Vec<&Map<String, Value>> = match lights_ext.and_then(|l| l.get("lights")) {
        None => Vec::new(),
        Some(v) => array(file, v, &|| "extensions.KHR_lights_punctual.lights".into())?
            .iter()
            .enumerate()
            .map(|(i, l)| object(file, l, &|| format!("KHR_lights_punctual light {i}")))
            .collect::<Result<_>>()?,
    };
    check.counts.insert("lights", lights.len());
    let c = &check;

    if let Some(s) = root.get("scene") {
        c.index(s, &|| "scene".into(), "scenes")?;
    }
    for (i, s) in items(file, root, "scenes")?.iter().enumerate() {
        c.index_list(s, "nodes", &|| format!("scene {i}"), "nodes", true)?;
    }

    // Buffers, views, accessors.
    let mut buffer_len = Vec::new();
    for (i, b) in items(file, root, "buffers")?.iter().enumerate() {
        let at = || format!("buffer {i}");
        let len = uint(
            file,
            b.get("byteLength"),
            &|| format!("{}.byteLength", at()),
            u64::MAX,
        )?;
        if len == u64::MAX || len == 0 {
            return Err(fail(file, format!("{} has no positive byteLength", at())));
        }
        if let Some(u) = b.get("uri") {
            if !u.is_string() {
                return Err(fail(file, format!("{}.uri is not a string", at())));
            }
        }
        buffer_len.push(len);
    }
    // Per view: (byteOffset, byteLength, byteStride).
    let mut views = Vec::new();
    for (i, v) in items(file, root, "bufferViews")?.iter().enumerate() {
        let at = || format!("bufferView {i}");
        let buffer = c.index(
            v.get("buffer").unwrap_or(&Value::Null),
            &|| format!("{}.buffer", at()),
            "buffers",
        )?;
        let offset = uint(
            file,
            v.get("byteOffset"),
            &|| format!("{}.byteOffset", at()),
            0,
        )?;
        let length = uint(
            file,
            v.get("byteLength"),
            &|| format!("{}.byteLength", at()),
            0,
        )?;
        if length == 0 {
            return Err(fail(file, format!("{} has no positive byteLength", at())));
        }
        let stride = uint(
            file,
            v.get("byteStride"),
            &|| format!("{}.byteStride", at()),
            0,
        )?;
        if v.contains_key("byteStride") && !(4..=252).contains(&stride) || stride % 4 != 0 {
            return Err(fail(
                file,
                format!(
                    "{} has byteStride {stride}; glTF requires a multiple of 4 from 4 to 252",
                    at()
                ),
            ));
        }
        let end = u128::from(offset) + u128::from(length);
        if end > u128::from(buffer_len[buffer]) {
            return Err(fail(
                file,
                format!(
                    "{} covers bytes {offset}..{end} of buffer {buffer}, whose byteLength is {}",
                    at(),
                    buffer_len[buffer]
                ),
            ));
        }
        views.push((offset, length, stride));
    }
    for (i, a) in items(file, root, "accessors")?.iter().enumerate() {
        let name = a
            .get("name")
            .and_then(Value::as_str)
            .map(|n| format!(" \"{n}\""))
            .unwrap_or_default();
        let at = || format!("accessor {i}{name}");
        let ct = uint(
            file,
            a.get("componentType"),
            &|| format!("{}.componentType", at()),
            0,
        )?;
        let size = component_size(ct).ok_or_else(|| {
            fail(
                file,
                format!(
                    "{} has componentType {ct}, which glTF does not define",
                    at()
                ),
            )
        })?;
        let ty = a.get("type").and_then(Value::as_str).unwrap_or("");
        let (cols, rows) = shape(ty).ok_or_else(|| {
            fail(
                file,
                format!(
                    "{} has type {}, which glTF does not define",
                    at(),
                    describe(a.get("type").unwrap_or(&Value::Null))
                ),
            )
        })?;
        let count = uint(file, a.get("count"), &|| format!("{}.count", at()), 0)?;
        if count == 0 {
            return Err(fail(file, format!("{} has no positive count", at())));
        }
        let offset = uint(
            file,
            a.get("byteOffset"),
            &|| format!("{}.byteOffset", at()),
            0,
        )?;
        // Matrix columns start on 4-byte boundaries.
        let elem = if cols == 1 {
            rows * size
        } else {
            cols * (rows * size).next_multiple_of(4)
        };
        if let Some(view) = c.opt_index(a, "bufferView", &at, "bufferViews")? {
            let (view_offset, view_len, stride) = views[view];
            if offset % size != 0 || (view_offset + offset) % size != 0 {
                return Err(fail(
                    file,
                    format!(
                        "{} starts at byte {} of its buffer (byteOffset {offset} in bufferView {view}), \
                         which is not a multiple of its {size}-byte component size as glTF requires",
                        at(),
                        u128::from(view_offset) + u128::from(offset)
                    ),
                ));
            }
            if stride != 0 && stride < elem {
                return Err(fail(
                    file,
                    format!(
                        "{} has {elem}-byte elements, longer than bufferView {view}'s byteStride {stride}",
                        at()
                    ),
                ));
            }
            let step = if stride == 0 { elem } else { stride };
            let end =
                u128::from(offset) + u128::from(step) * u128::from(count - 1) + u128::from(elem);
            if end > u128::from(view_len) {
                return Err(fail(
                    file,
                    format!(
                        "{} ({count} x {ty}) needs bytes {offset}..{end} of bufferView {view}, \
                         which is only {view_len} bytes long",
                        at()
                    ),
                ));
            }
        } else if a.contains_key("byteOffset") && offset != 0 {
            return Err(fail(
                file,
                format!("{} has a byteOffset but no bufferView", at()),
            ));
        }
        if let Some(sparse) = a.get("sparse") {
            let sparse = object(file, sparse, &|| format!("{}.sparse", at()))?;
            let n = uint(
                file,
                sparse.get("count"),
                &|| format!("{}.sparse.count", at()),
                0,
            )?;
            if n == 0 || n > count {
                return Err(fail(
                    file,
                    format!(
                        "{} has sparse.count {n}; it must be 1..{count} (the accessor's count)",
                        at()
                    ),
                ));
            }
            for (part, elem_size) in [("indices", None), ("values", Some(elem))] {
                let at_p = || format!("{}.sparse.{part}", at());
                let p = object(file, sparse.get(part).unwrap_or(&Value::Null), &at_p)?;
                let view = c.index(
                    p.get("bufferView").unwrap_or(&Value::Null),
                    &|| format!("{}.bufferView", at_p()),
                    "bufferViews",
                )?;
                let off = uint(
                    file,
                    p.get("byteOffset"),
                    &|| format!("{}.byteOffset", at_p()),
                    0,
                )?;
                let elem_size = match elem_size {
                    Some(e) => e,
                    None => {
                        let ct = uint(
                            file,
                            p.get("componentType"),
                            &|| format!("{}.componentType", at_p()),
                            0,
                        )?;
                        if !matches!(ct, 5121 | 5123 | 5125) {
                            return Err(fail(
                                file,
                                format!("{} has componentType {ct}; sparse indices must be unsigned integers", at_p()),
                            ));
                        }
                        component_size(ct).unwrap_or(1)
                    }
                };
                let end = u128::from(off) + u128::from(elem_size) * u128::from(n);
                if end > u128::from(views[view].1) {
                    return Err(fail(
                        file,
                        format!(
                            "{} needs bytes {off}..{end} of bufferView {view}, which is only {} bytes long",
                            at_p(),
                            views[view].1
                        ),
                    ));
                }
            }
        }
    }
    let accessor_types: Vec<(u64, bool)> = items(file, root, "accessors")?
        .iter()
        .map(|a| {
            (
                a.get("componentType").and_then(Value::as_u64).unwrap_or(0),
                a.get("normalized")
                    .and_then(Value::as_bool)
                    .unwrap_or(false),
            )
        })
        .collect();

    // Images and textures.
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
    // Materials: every texture reference and its texCoord.
    for (i, m) in items(file, root, "materials")?.iter().enumerate() {
        let pbr = m.get("pbrMetallicRoughness").and_then(Value::as_object);
        let mut slots: Vec<(String, Option<&Value>)> = vec![
            (
                "pbrMetallicRoughness.baseColorTexture".to_owned(),
                pbr.and_then(|p| p.get("baseColorTexture")),
            ),
            (
                "pbrMetallicRoughness.metallicRoughnessTexture".to_owned(),
                pbr.and_then(|p| p.get("metallicRoughnessTexture")),
            ),
            ("normalTexture".to_owned(), m.get("normalTexture")),
            ("occlusionTexture".to_owned(), m.get("occlusionTexture")),
            ("emissiveTexture".to_owned(), m.get("emissiveTexture")),
        ];
        slots.extend(
            crate::scene::material_load::EXTENSION_TEXTURES
                .iter()
                .map(|&(ext, key)| {
                    (
                        format!("extensions.{ext}.{key}"),
                        extension_texture_info(m, ext, key),
                    )
                }),
        );
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

    // Meshes.
    let quantized = super::source::uses_extension(root, super::mesh::QUANTIZATION);
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
                let quantized_uv =
                    quantized && name.starts_with("TEXCOORD_") && matches!(ct, 5120..=5123);
                if fraction
                    && ct != 5126
                    && !(matches!(ct, 5121 | 5123) && normalized)
                    && !quantized_uv
                {
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
        }
    }

    // Nodes, skins, cameras, lights.
    for (i, n) in items(file, root, "nodes")?.iter().enumerate() {
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
    for (i, s) in items(file, root, "skins")?.iter().enumerate() {
        let at = || format!("skin {i}");
        c.opt_index(s, "inverseBindMatrices", &at, "accessors")?;
        c.opt_index(s, "skeleton", &at, "nodes")?;
        if c.index_list(s, "joints", &at, "nodes", true)?.is_empty() {
            return Err(fail(file, format!("skin {i} has no joints")));
        }
    }
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

    // Animations: samplers, channel targets, and the output types the spec
    // allows per path (integer rotations and weights must be normalized).
    for (a, anim) in items(file, root, "animations")?.iter().enumerate() {
        let samplers = match anim.get("samplers") {
            Some(v) => array(file, v, &|| format!("animation {a}.samplers"))?.clone(),
            None => Vec::new(),
        };
        let mut outputs = Vec::new();
        for (s, sampler) in samplers.iter().enumerate() {
            let at = || format!("animation {a} sampler {s}");
            let sampler = object(file, sampler, &at)?;
            c.index(
                sampler.get("input").unwrap_or(&Value::Null),
                &|| format!("{}.input", at()),
                "accessors",
            )?;
            outputs.push(c.index(
                sampler.get("output").unwrap_or(&Value::Null),
                &|| format!("{}.output", at()),
                "accessors",
            )?);
        }
        let Some(channels) = anim.get("channels") else {
            continue;
        };
        for (k, ch) in array(file, channels, &|| format!("animation {a}.channels"))?
            .iter()
            .enumerate()
        {
            let at = || format!("animation {a} channel {k}");
            let ch = object(file, ch, &at)?;
            let s = as_u32(ch.get("sampler").unwrap_or(&Value::Null))
                .map(|s| s as usize)
                .filter(|&s| s < samplers.len())
                .ok_or_else(|| {
                    fail(
                        file,
                        format!(
                            "{}.sampler is {}, but the animation has {} sampler(s)",
                            at(),
                            describe(ch.get("sampler").unwrap_or(&Value::Null)),
                            samplers.len()
                        ),
                    )
                })?;
            let target = object(file, ch.get("target").unwrap_or(&Value::Null), &|| {
                format!("{}.target", at())
            })?;
            let path = target.get("path").and_then(Value::as_str).unwrap_or("");
            // A pointer channel names no node (what it animates is its
            // pointer's business).
            if path != "pointer" {
                c.index(
                    target.get("node").unwrap_or(&Value::Null),
                    &|| format!("{}.target.node", at()),
                    "nodes",
                )?;
            }
            let (ct, normalized) = accessor_types[outputs[s]];
            let ok = match path {
                "translation" | "scale" => ct == 5126,
                _ => ct == 5126 || (matches!(ct, 5120..=5123) && normalized),
            };
            if !ok {
                return Err(fail(
                    file,
                    format!(
                        "{} animates {path} from accessor {} of componentType {ct}{}; glTF allows FLOAT{} there",
                        at(),
                        outputs[s],
                        if normalized { " (normalized)" } else { " without normalized: true" },
                        if matches!(path, "translation" | "scale") {
                            ""
                        } else {
                            " or normalized BYTE/UNSIGNED_BYTE/SHORT/UNSIGNED_SHORT"
                        }
                    ),
                ));
            }
        }
    }
    Ok(warnings)
}

/// A material extension's texture info object (`materials[i].extensions.EXT.KEY`).
fn extension_texture_info<'j>(
    material: &'j serde_json::Map<String, Value>,
    ext: &str,
    key: &str,
) -> Option<&'j Value> {
    material.get("extensions")?.get(ext)?.get(key)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn versions() {
        assert_eq!(parse_version("2.0"), Some((2, 0)));
        assert_eq!(parse_version("2.10"), Some((2, 10)));
        assert_eq!(parse_version("banana"), None);
        assert_eq!(parse_version("2."), None);
        assert_eq!(parse_version("-2.0"), None);
    }
}
