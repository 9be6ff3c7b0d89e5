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

mod animations;
mod buffers;
mod ignored;
mod objects;

use serde_json::{Map, Value};

use super::error::{Result, SceneError};

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

/// Validates `json` in place (removing channels soupray must ignore) and
/// returns the warnings to show.
pub(super) fn validate(file: &str, json: &mut Value) -> Result<Vec<String>> {
    let root = json
        .as_object_mut()
        .ok_or_else(|| fail(file, "the JSON document is not an object".into()))?;
    check_asset_version(file, root)?;
    // Removed before anything is checked: what soupray must ignore cannot
    // fail the file.
    let mut warnings = ignored::drop_unknown_channels(root);
    warnings.extend(ignored::drop_unknown_attributes(root));

    let root = &*root;
    let (check, lights) = Check::count_objects(file, root)?;
    let c = &check;
    objects::check_scenes(c, root)?;
    let views = buffers::check_buffers_and_views(c, root)?;
    buffers::check_accessors(c, root, &views)?;
    let accessor_types = buffers::accessor_types(c, root)?;
    objects::check_images(c, root)?;
    objects::check_textures(c, root)?;
    objects::check_materials(c, root)?;
    objects::check_meshes(c, root, &accessor_types)?;
    objects::check_nodes(c, root)?;
    objects::check_skins(c, root)?;
    objects::check_cameras(c, root)?;
    objects::check_lights(c, &lights)?;
    animations::check_animations(c, root, &accessor_types)?;
    Ok(warnings)
}

/// The asset's `version` must be 2.x and its `minVersion` (if any) at most
/// 2.0.
fn check_asset_version(file: &str, root: &Map<String, Value>) -> Result<()> {
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
    Ok(())
}

impl<'r> Check<'r> {
    /// Counts every top-level array (and the KHR_lights_punctual lights,
    /// returned too) so that indices can be checked against them.
    fn count_objects<'j>(
        file: &'r str,
        root: &'j Map<String, Value>,
    ) -> Result<(Self, Vec<&'j Map<String, Value>>)> {
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
        Ok((check, lights))
    }
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
