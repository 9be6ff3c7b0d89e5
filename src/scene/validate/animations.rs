//! Animations: samplers, channel targets, and the output types the spec
//! allows per path (integer rotations and weights must be normalized).

use serde_json::{Map, Value};

use super::{array, as_u32, describe, fail, items, object, Check};
use crate::scene::error::Result;

pub(super) fn check_animations(
    c: &Check,
    root: &Map<String, Value>,
    accessor_types: &[(u64, bool)],
) -> Result<()> {
    let file = c.file;
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
    Ok(())
}
