//! What a loader must ignore rather than reject: animation channels with
//! paths soupray does not implement, and attribute names glTF does not
//! define. Both are removed from the document with a warning.

use std::collections::BTreeMap;

use serde_json::{Map, Value};

/// The `node` channel paths soupray animates.
const KNOWN_PATHS: &[&str] = &["translation", "rotation", "scale", "weights"];

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

/// Removes channels with unknown animation paths, with one warning per
/// (animation, path).
pub(super) fn drop_unknown_channels(root: &mut Map<String, Value>) -> Vec<String> {
    let mut warnings = Vec::new();
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
                    Some("pointer") if crate::scene::pointer::channel_pointer(ch).is_some() => None,
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
    warnings
}

/// Attribute names glTF does not define (application-specific ones must
/// start with "_"): soupray reads none of them, so they are dropped with
/// one warning each instead of failing the `gltf` crate's validation.
pub(super) fn drop_unknown_attributes(root: &mut Map<String, Value>) -> Vec<String> {
    let mut warnings = Vec::new();
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
    warnings
}
