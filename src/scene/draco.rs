//! KHR_draco_mesh_compression: primitives whose indices and (some) vertex
//! attributes are stored as one Draco-compressed mesh in a bufferView.
//!
//! As with EXT_meshopt_compression, the `gltf` crate never sees the
//! compression: each Draco primitive is decoded at load into a buffer of its
//! own, and the accessors its `indices` and Draco-listed attributes name are
//! pointed at views of that buffer (the spec says to ignore those
//! accessors' own bufferView and byteOffset), so the accessor reader checks
//! the decoded data as it checks any other. Attributes the extension does
//! not list, and morph targets, are read from their accessors as usual, in
//! the decoded vertex order (the spec requires the accessors to match the
//! decompressed data).
//!
//! Decoding is the pure-Rust `draco-core`. Before it runs, the payload's
//! range and every accessor count are checked against the file, and the
//! decoder is given ceilings derived from those counts, so a payload that
//! claims more points or faces than its accessors is refused at its header
//! instead of being decoded; after it, the decoded counts, component counts
//! and values must match the accessors exactly.

use std::collections::HashMap;

use serde_json::{Map, Value};

use super::error::{Result, SceneError};

pub(crate) const EXTENSION: &str = "KHR_draco_mesh_compression";

/// All Draco primitives of one file together decode to at most this many
/// bytes (1 GiB), the bound compressed buffer views have too.
const MAX_DECODED_BYTES: u64 = super::meshopt_views::MAX_DECODED_BYTES;

/// What a decoded array becomes: one accessor's elements.
#[derive(Debug, Clone)]
struct Fill {
    /// `"indices"` or the attribute's name, for messages.
    what: String,
    /// The Draco attribute's unique id; `None` for the indices.
    draco_id: Option<u32>,
    /// The accessor in the file's JSON.
    accessor: usize,
    /// The accessor this fill is written through in the `gltf` crate's
    /// JSON: `accessor` itself, or a copy when another primitive already
    /// fills `accessor` with other data.
    target: usize,
    count: usize,
    components: usize,
    component_type: u64,
    /// Where the elements start in the primitive's decoded buffer.
    offset: usize,
}

impl Fill {
    fn bytes(&self) -> usize {
        self.count * self.components * component_size(self.component_type)
    }
}

/// One Draco-compressed primitive, checked.
#[derive(Debug, Clone)]
pub(crate) struct DracoPrimitive {
    /// `mesh M "name" primitive P`, for messages.
    label: String,
    mesh: usize,
    primitive: usize,
    /// The bufferView holding the Draco payload.
    view: usize,
    /// The vertex count every Draco attribute's accessor shares.
    points: usize,
    fills: Vec<Fill>,
    decoded_len: usize,
}

/// Whether the file's JSON stores primitive `prim` of mesh `mesh`
/// Draco-compressed.
pub(crate) fn is_draco_primitive(json: &Value, mesh: usize, prim: usize) -> bool {
    json["meshes"][mesh]["primitives"][prim]["extensions"]
        .get(EXTENSION)
        .is_some()
}

fn component_size(component_type: u64) -> usize {
    match component_type {
        5120 | 5121 => 1,
        5122 | 5123 => 2,
        _ => 4,
    }
}

fn component_name(component_type: u64) -> &'static str {
    match component_type {
        5120 => "BYTE",
        5121 => "UNSIGNED_BYTE",
        5122 => "SHORT",
        5123 => "UNSIGNED_SHORT",
        5125 => "UNSIGNED_INT",
        _ => "FLOAT",
    }
}

fn components_of(ty: &str) -> Option<usize> {
    match ty {
        "SCALAR" => Some(1),
        "VEC2" => Some(2),
        "VEC3" => Some(3),
        "VEC4" => Some(4),
        _ => None,
    }
}

const FIX: &str = "Fix: re-encode the asset with a current Draco encoder (for example \
                   gltf-transform draco, or gltf-pipeline -d), or export it without Draco compression";

fn invalid(file: &str, label: &str, detail: String) -> SceneError {
    SceneError::Invalid {
        file: file.to_owned(),
        detail: format!("{label} is compressed with {EXTENSION}, but {detail}. {FIX}."),
    }
}

/// Finds and checks every Draco primitive of the (already validated)
/// JSON, and lays out the buffer each decodes into.
pub(crate) fn draco_primitives(file: &str, json: &Value) -> Result<Vec<DracoPrimitive>> {
    let empty = Vec::new();
    let list = |key: &str| json.get(key).and_then(Value::as_array).unwrap_or(&empty);
    let (meshes, accessors, views) = (list("meshes"), list("accessors"), list("bufferViews"));
    let mut out = Vec::new();
    let mut total: u64 = 0;
    for (m, mesh) in meshes.iter().enumerate() {
        let prims = mesh
            .get("primitives")
            .and_then(Value::as_array)
            .unwrap_or(&empty);
        for (p, prim) in prims.iter().enumerate() {
            let Some(ext) = prim.get("extensions").and_then(|e| e.get(EXTENSION)) else {
                continue;
            };
            let label = match mesh.get("name").and_then(Value::as_str) {
                Some(n) => format!("mesh {m} \"{n}\" primitive {p}"),
                None => format!("mesh {m} primitive {p}"),
            };
            let mut d = check_primitive(file, &label, prim, ext, accessors, views)?;
            (d.mesh, d.primitive) = (m, p);
            total += d.decoded_len as u64;
            if total > MAX_DECODED_BYTES {
                return Err(invalid(
                    file,
                    &label,
                    format!(
                        "the Draco primitives up to it decode to {total} bytes, more than the \
                         {MAX_DECODED_BYTES} soupray decodes for one file"
                    ),
                ));
            }
            out.push(d);
        }
    }
    Ok(out)
}

fn check_primitive(
    file: &str,
    label: &str,
    prim: &Value,
    ext: &Value,
    accessors: &[Value],
    views: &[Value],
) -> Result<DracoPrimitive> {
    let fail = |detail: String| invalid(file, label, detail);
    let ext = ext
        .as_object()
        .ok_or_else(|| fail("its extension object is not a JSON object".into()))?;
    let view = extension_view(&fail, ext, views)?;
    // bufferViews lie inside their buffers' byteLength (`validate`); the
    // bytes actually present are checked when decoding.
    let mode = prim.get("mode").and_then(Value::as_u64).unwrap_or(4);
    if mode != 4 && mode != 5 {
        return Err(fail(format!(
            "its mode is {mode}; the extension allows only TRIANGLES (4) and TRIANGLE_STRIP (5)"
        )));
    }
    let draco_attributes = ext
        .get("attributes")
        .and_then(Value::as_object)
        .ok_or_else(|| fail("its extension has no attributes object".into()))?;
    let attributes: Map<String, Value> = prim
        .get("attributes")
        .and_then(Value::as_object)
        .cloned()
        .unwrap_or_default();

    let mut fills = Vec::new();
    let mut points: Option<(usize, String)> = None;
    let mut offset = 0usize;
    let mut add = |what: String,
                   draco_id: Option<u32>,
                   accessor: usize,
                   fills: &mut Vec<Fill>|
     -> Result<()> {
        let fill = accessor_fill(&fail, accessors, what, draco_id, accessor, offset)?;
        offset = (offset + fill.bytes()).next_multiple_of(4);
        fills.push(fill);
        Ok(())
    };

    let indices = prim.get("indices").and_then(Value::as_u64).ok_or_else(|| {
        fail(
            "the primitive has no indices accessor; a Draco mesh is indexed, and the extension \
                 fills the primitive's indices accessor with its faces"
                .into(),
        )
    })? as usize;
    add("indices".into(), None, indices, &mut fills)?;
    check_indices_fill(&fail, &fills[0], indices)?;
    let mut ids_seen: HashMap<u64, &str> = HashMap::new();
    for (name, id) in draco_attributes {
        let id = id.as_u64().filter(|&i| i <= u64::from(u32::MAX)).ok_or_else(|| {
            fail(format!(
                "its extension gives attribute {name} the Draco id {id}, not a non-negative 32-bit integer"
            ))
        })?;
        if let Some(other) = ids_seen.insert(id, name) {
            return Err(fail(format!(
                "its extension gives attributes {other} and {name} the same Draco id {id}"
            )));
        }
        // The extension's attributes are a subset of the primitive's; a
        // name the primitive lacks (or whose unknown semantic was dropped
        // with a warning) is not read.
        let Some(accessor) = attributes.get(name).and_then(Value::as_u64) else {
            continue;
        };
        add(name.clone(), Some(id as u32), accessor as usize, &mut fills)?;
        let f = fills.last().expect("just added");
        match &points {
            None => points = Some((f.count, name.clone())),
            Some((n, first)) if *n != f.count => {
                return Err(fail(format!(
                    "its {name} accessor {} has {} elements and its {first} accessor {n}; every attribute \
                     decoded from one Draco mesh has one element per decoded point",
                    f.accessor, f.count
                )))
            }
            _ => {}
        }
    }
    let Some((points, _)) = points else {
        return Err(fail(
            "its extension lists none of the primitive's attributes, so it decodes no vertices"
                .into(),
        ));
    };
    Ok(DracoPrimitive {
        label: label.to_owned(),
        mesh: 0,
        primitive: 0,
        view,
        points,
        fills,
        decoded_len: offset,
    })
}

/// The bufferView holding the extension's Draco data.
fn extension_view(
    fail: &dyn Fn(String) -> SceneError,
    ext: &Map<String, Value>,
    views: &[Value],
) -> Result<usize> {
    let view = match ext.get("bufferView") {
        None => return Err(fail("its extension has no bufferView".into())),
        Some(v) => v.as_u64().ok_or_else(|| {
            fail(format!(
                "its extension's bufferView is {v}, not a non-negative integer"
            ))
        })?,
    };
    if view as usize >= views.len() || view > u64::from(u32::MAX) {
        return Err(fail(format!(
            "its extension names bufferView {view}, and the file has {} bufferViews",
            views.len()
        )));
    }
    let view = view as usize;
    Ok(view)
}

/// What accessor `accessor` (the indices, or the attribute `what` with
/// Draco id `draco_id`) takes from the decoded data, placed at byte
/// `offset` of the primitive's decoded buffer; its count, type and
/// component type must be ones the decoder fills.
fn accessor_fill(
    fail: &dyn Fn(String) -> SceneError,
    accessors: &[Value],
    what: String,
    draco_id: Option<u32>,
    accessor: usize,
    offset: usize,
) -> Result<Fill> {
    let acc = &accessors[accessor];
    let count = acc.get("count").and_then(Value::as_u64).unwrap_or(0);
    if count == 0 || count > super::accessor::MAX_ELEMENTS as u64 {
        return Err(fail(format!(
            "its {what} accessor {accessor} has count {count}; soupray reads 1 to {} elements",
            super::accessor::MAX_ELEMENTS
        )));
    }
    let ty = acc.get("type").and_then(Value::as_str).unwrap_or("");
    let components = components_of(ty).ok_or_else(|| {
            fail(format!(
                "its {what} accessor {accessor} is of type {ty}; Draco data fills SCALAR and VEC2 to VEC4 accessors"
            ))
        })?;
    let component_type = acc
        .get("componentType")
        .and_then(Value::as_u64)
        .unwrap_or(0);
    if !matches!(component_type, 5120..=5123 | 5125 | 5126) {
        return Err(fail(format!(
            "its {what} accessor {accessor} has componentType {component_type}"
        )));
    }
    if acc.get("sparse").is_some() {
        return Err(fail(format!(
                "its {what} accessor {accessor} is sparse; the extension fills the accessor from the Draco \
                 data, and such an accessor must have no sparse substitutions"
            )));
    }
    Ok(Fill {
        what,
        draco_id,
        accessor,
        target: accessor,
        count: count as usize,
        components,
        component_type,
        offset,
    })
}

/// The indices accessor's fill `f` is a list of triangles of unsigned
/// integers.
fn check_indices_fill(fail: &dyn Fn(String) -> SceneError, f: &Fill, indices: usize) -> Result<()> {
    if f.components != 1 || !matches!(f.component_type, 5121 | 5123 | 5125) {
        return Err(fail(format!(
                "its indices accessor {indices} is {} of {}; indices are SCALAR UNSIGNED_BYTE, UNSIGNED_SHORT \
                 or UNSIGNED_INT",
                if f.components == 1 { "SCALAR".to_owned() } else { format!("VEC{}", f.components) },
                component_name(f.component_type)
            )));
    }
    if !f.count.is_multiple_of(3) {
        return Err(fail(format!(
                "its indices accessor {indices} has count {}, not a multiple of 3; a Draco mesh is a list of \
                 triangles",
                f.count
            )));
    }
    Ok(())
}

/// Points every accessor the Draco primitives fill at a view of a buffer
/// of its primitive's own (appended after the file's buffers and those
/// already appended, in the order of `prims`), in the `gltf` crate's copy
/// of the JSON. An accessor that two primitives fill from different Draco
/// data is copied for the later one, so each reads its own.
pub(crate) fn redirect(json: &mut Value, prims: &mut [DracoPrimitive]) {
    if prims.is_empty() {
        return;
    }
    let len_of =
        |json: &Value, key: &str| json.get(key).and_then(Value::as_array).map_or(0, Vec::len);
    let first_buffer = len_of(json, "buffers");
    // Which Draco data (bufferView, attribute id) each accessor was given.
    let mut claimed: HashMap<usize, (usize, Option<u32>)> = HashMap::new();
    for (k, d) in prims.iter_mut().enumerate() {
        let (m, p) = (d.mesh, d.primitive);
        let buffer = first_buffer + k;
        ensure_array(json, "buffers").push(serde_json::json!({ "byteLength": d.decoded_len }));
        for fill in &mut d.fills {
            let source = (d.view, fill.draco_id);
            match claimed.get(&fill.accessor) {
                Some(s) if *s == source => continue,
                Some(_) => {
                    // Another primitive fills this accessor from other data.
                    let copy = json["accessors"][fill.accessor].clone();
                    let accessors = ensure_array(json, "accessors");
                    accessors.push(copy);
                    fill.target = accessors.len() - 1;
                    let prim = &mut json["meshes"][m]["primitives"][p];
                    match fill.draco_id {
                        None => prim["indices"] = fill.target.into(),
                        Some(_) => prim["attributes"][&fill.what] = fill.target.into(),
                    }
                }
                None => {
                    claimed.insert(fill.accessor, source);
                }
            }
            let views = ensure_array(json, "bufferViews");
            views.push(serde_json::json!({
                "buffer": buffer,
                "byteOffset": fill.offset,
                "byteLength": fill.bytes(),
            }));
            let view = views.len() - 1;
            if let Some(acc) = json["accessors"][fill.target].as_object_mut() {
                acc.insert("bufferView".into(), view.into());
                acc.insert("byteOffset".into(), 0.into());
                acc.remove("sparse");
            }
        }
        if let Some(ext) = json["meshes"][m]["primitives"][p]
            .get_mut("extensions")
            .and_then(Value::as_object_mut)
        {
            ext.remove(EXTENSION);
        }
    }
}

fn ensure_array<'j>(json: &'j mut Value, key: &str) -> &'j mut Vec<Value> {
    if !json.get(key).is_some_and(Value::is_array) {
        json[key] = Value::Array(Vec::new());
    }
    json[key].as_array_mut().expect("just made an array")
}

/// Decodes one Draco primitive's payload, read through the `gltf` crate's
/// view (which a compressed buffer view may have redirected), into the
/// buffer `redirect` laid out for it. A failure names the file, the mesh,
/// the primitive and what went wrong.
pub(crate) fn decode(
    file: &str,
    d: &DracoPrimitive,
    document: &gltf::Document,
    buffers: &[Vec<u8>],
    short_buffers: &[Option<String>],
) -> Result<Vec<u8>> {
    let fail = |detail: String| invalid(file, &d.label, detail);
    let view = document
        .views()
        .nth(d.view)
        .expect("bufferView indices were validated");
    let buffer = view.buffer().index();
    let data = &buffers[buffer];
    let (start, end) = (view.offset(), view.offset() + view.length());
    if end > data.len() {
        let why = short_buffers[buffer]
            .clone()
            .unwrap_or_else(|| format!("buffer {buffer} is short"));
        return Err(SceneError::Invalid {
            file: file.to_owned(),
            detail: format!(
                "{} is compressed with {EXTENSION} in bytes {start}..{end} of buffer {buffer} (bufferView {}), \
                 which holds only {} bytes ({why}). Fix: re-export the asset or re-copy it completely.",
                d.label,
                d.view,
                data.len()
            ),
        });
    }
    let payload = &data[start..end];
    let faces = d.fills[0].count / 3;
    // The accessors say how much the mesh decodes to; the decoder refuses
    // a header that claims more before reserving anything for it.
    // The decoded bytes bound leaves room for attributes the extension
    // does not list (up to 16 of 4 components of 8 bytes a point).
    let limits = draco_core::DecodeLimits::default()
        .with_max_points(d.points as u64)
        .with_max_faces(faces as u64)
        .with_max_decoded_bytes((d.points as u64 * 512).min(MAX_DECODED_BYTES));
    let mut input = draco_core::DecoderBuffer::new(payload).with_limits(limits);
    let mut mesh = draco_core::Mesh::new();
    draco_core::MeshDecoder::new()
        .decode(&mut input, &mut mesh)
        .map_err(|e| {
            fail(format!(
                "its {}-byte Draco payload (bufferView {}) does not decode to the {} points and {faces} \
                 triangles its accessors describe: {e}",
                payload.len(),
                d.view,
                d.points
            ))
        })?;
    if mesh.num_points() != d.points || mesh.num_faces() != faces {
        return Err(fail(format!(
            "its Draco payload decodes to {} points and {} triangles, while its accessors describe {} points \
             and {faces} triangles",
            mesh.num_points(),
            mesh.num_faces(),
            d.points
        )));
    }
    let mut out = vec![0u8; d.decoded_len];
    for fill in &d.fills {
        let dst = &mut out[fill.offset..fill.offset + fill.bytes()];
        match fill.draco_id {
            None => write_indices(&mesh, fill, dst).map_err(fail)?,
            Some(id) => write_attribute(&mesh, fill, id, dst).map_err(fail)?,
        }
    }
    Ok(out)
}

fn write_indices(
    mesh: &draco_core::Mesh,
    fill: &Fill,
    dst: &mut [u8],
) -> std::result::Result<(), String> {
    let size = component_size(fill.component_type);
    let points = mesh.num_points();
    for (k, corner) in mesh.faces().iter().flatten().enumerate() {
        let v = corner.0;
        if v as usize >= points {
            return Err(format!(
                "its Draco faces use point {v} while it decodes {points} points"
            ));
        }
        if !store(
            fill.component_type,
            f64::from(v),
            &mut dst[k * size..(k + 1) * size],
        ) {
            return Err(format!(
                "its Draco faces use point {v}, which its indices accessor {} of {} cannot hold",
                fill.accessor,
                component_name(fill.component_type)
            ));
        }
    }
    Ok(())
}

fn write_attribute(
    mesh: &draco_core::Mesh,
    fill: &Fill,
    id: u32,
    dst: &mut [u8],
) -> std::result::Result<(), String> {
    let attr = mesh.attribute_by_unique_id(id).ok_or_else(|| {
        format!(
            "its extension maps {} to Draco attribute {id}, which the Draco mesh does not have",
            fill.what
        )
    })?;
    if attr.num_components() as usize != fill.components {
        return Err(format!(
            "Draco attribute {id} ({}) has {} components while its accessor {} has {}",
            fill.what,
            attr.num_components(),
            fill.accessor,
            fill.components
        ));
    }
    let ty = attr.data_type();
    let width = ty.byte_length();
    let stride = usize::try_from(attr.byte_stride()).unwrap_or(0);
    if width == 0 || stride < width * fill.components {
        return Err(format!(
            "Draco attribute {id} ({}) stores {ty:?} values, which soupray cannot read",
            fill.what
        ));
    }
    let values = attr.buffer().data();
    let size = component_size(fill.component_type);
    let mut at = 0;
    for point in 0..fill.count {
        let value = attr.mapped_index(draco_core::PointIndex(point as u32)).0 as usize;
        let element = (value < attr.size())
            .then(|| value.checked_mul(stride))
            .flatten()
            .and_then(|s| Some(s..s.checked_add(width * fill.components)?))
            .and_then(|range| values.get(range))
            .ok_or_else(|| {
                format!(
                    "Draco attribute {id} ({}) has no value for point {point}",
                    fill.what
                )
            })?;
        for c in element.chunks_exact(width) {
            let v = load(ty, c).unwrap_or(f64::NAN);
            if !store(fill.component_type, v, &mut dst[at..at + size]) {
                return Err(format!(
                    "Draco attribute {id} ({}) holds {v} at point {point}, which its accessor {} of {} cannot hold",
                    fill.what,
                    fill.accessor,
                    component_name(fill.component_type)
                ));
            }
            at += size;
        }
    }
    Ok(())
}

/// One Draco component as a number.
fn load(ty: draco_core::DataType, b: &[u8]) -> Option<f64> {
    use draco_core::DataType as T;
    let arr = |n: usize| -> [u8; 8] {
        let mut a = [0u8; 8];
        a[..n].copy_from_slice(&b[..n]);
        a
    };
    Some(match ty {
        T::Int8 => f64::from(b[0] as i8),
        T::Uint8 | T::Bool => f64::from(b[0]),
        T::Int16 => f64::from(i16::from_le_bytes([b[0], b[1]])),
        T::Uint16 => f64::from(u16::from_le_bytes([b[0], b[1]])),
        T::Int32 => f64::from(i32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        T::Uint32 => f64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        T::Float32 => f64::from(f32::from_le_bytes([b[0], b[1], b[2], b[3]])),
        T::Int64 => i64::from_le_bytes(arr(8)) as f64,
        T::Uint64 => u64::from_le_bytes(arr(8)) as f64,
        T::Float64 => f64::from_le_bytes(arr(8)),
        T::Invalid => return None,
    })
}

/// Writes `v` as one component of the accessor's type: floats as they are,
/// integers only when `v` is one the type holds (the value is cast, as
/// Draco's own glTF decoders do, not renormalized). False when it is not.
fn store(component_type: u64, v: f64, out: &mut [u8]) -> bool {
    if component_type == 5126 {
        out.copy_from_slice(&(v as f32).to_le_bytes());
        return true;
    }
    let (lo, hi) = match component_type {
        5120 => (i8::MIN as f64, i8::MAX as f64),
        5121 => (0.0, u8::MAX as f64),
        5122 => (i16::MIN as f64, i16::MAX as f64),
        5123 => (0.0, u16::MAX as f64),
        _ => (0.0, u32::MAX as f64),
    };
    if !(lo..=hi).contains(&v) || v.fract() != 0.0 {
        return false;
    }
    match component_type {
        5120 => out[0] = v as i8 as u8,
        5121 => out[0] = v as u8,
        5122 => out.copy_from_slice(&(v as i16).to_le_bytes()),
        5123 => out.copy_from_slice(&(v as u16).to_le_bytes()),
        _ => out.copy_from_slice(&(v as u32).to_le_bytes()),
    }
    true
}
