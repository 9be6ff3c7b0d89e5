//! Buffers, bufferViews and accessors: every byte range lies inside what
//! it refers to, aligned as glTF requires.

use serde_json::{Map, Value};

use super::{component_size, describe, fail, items, object, shape, uint, Check};
use crate::scene::error::Result;

/// A bufferView's (byteOffset, byteLength, byteStride).
pub(super) type View = (u64, u64, u64);

/// Checks buffers and bufferViews, returning each view's extent.
pub(super) fn check_buffers_and_views(c: &Check, root: &Map<String, Value>) -> Result<Vec<View>> {
    let file = c.file;
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
    Ok(views)
}

pub(super) fn check_accessors(c: &Check, root: &Map<String, Value>, views: &[View]) -> Result<()> {
    for (i, a) in items(c.file, root, "accessors")?.iter().enumerate() {
        check_accessor(c, i, a, views)?;
    }
    Ok(())
}

/// One accessor: a defined component type and shape, a positive count,
/// and elements that fit, aligned, in its bufferView.
fn check_accessor(c: &Check, i: usize, a: &Map<String, Value>, views: &[View]) -> Result<()> {
    let file = c.file;
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
        let end = u128::from(offset) + u128::from(step) * u128::from(count - 1) + u128::from(elem);
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
        check_sparse(c, &at, sparse, count, elem, views)?;
    }
    Ok(())
}

/// A sparse accessor's count, and its indices and values, each inside its
/// bufferView; `elem` is the byte size of one of the accessor's elements.
fn check_sparse(
    c: &Check,
    at: &dyn Fn() -> String,
    sparse: &Value,
    count: u64,
    elem: u64,
    views: &[View],
) -> Result<()> {
    let file = c.file;
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
                        format!(
                            "{} has componentType {ct}; sparse indices must be unsigned integers",
                            at_p()
                        ),
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
    Ok(())
}

/// Each accessor's (componentType, normalized), for the checks of what
/// reads it.
pub(super) fn accessor_types(c: &Check, root: &Map<String, Value>) -> Result<Vec<(u64, bool)>> {
    Ok(items(c.file, root, "accessors")?
        .iter()
        .map(|a| {
            (
                a.get("componentType").and_then(Value::as_u64).unwrap_or(0),
                a.get("normalized")
                    .and_then(Value::as_bool)
                    .unwrap_or(false),
            )
        })
        .collect())
}
