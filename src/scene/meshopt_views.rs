//! EXT_meshopt_compression: bufferViews whose bytes are stored compressed
//! by meshoptimizer's codecs in another buffer. Each compressed view is
//! decoded at load into a buffer of its own, and the document handed to the
//! `gltf` crate points the view at that buffer (offset 0), so the accessor
//! reader sees plain data and checks it as it checks any other.
//!
//! Decoding is meshoptimizer's own C++ (the `meshopt` crate). That code
//! `assert`s its preconditions instead of returning errors, so every one of
//! them (mode, byteStride, count, filter) is checked here first, and the
//! size each view decodes to is bounded before anything is allocated: by
//! the smallest encoding the codec can produce for it, and by a total.

use serde_json::{Map, Value};

use super::error::{Result, SceneError};

pub(crate) const EXTENSION: &str = "EXT_meshopt_compression";

/// All compressed views of one file together decode to at most this many
/// bytes (1 GiB), far above any real mesh.
pub(crate) const MAX_DECODED_BYTES: u64 = 1 << 30;

/// meshoptimizer's vertex codec spends at least a quarter byte (its version
/// 1 control bits) per byte lane per block of at most 256 vertices, so one
/// encoded byte never decodes to more than 1024.
const MAX_VERTEX_EXPANSION: u64 = 1024;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Mode {
    Attributes,
    Triangles,
    Indices,
}

#[derive(Debug, Clone, Copy, PartialEq)]
enum Filter {
    None,
    Octahedral,
    Quaternion,
    Exponential,
}

/// One compressed bufferView, checked.
#[derive(Debug, Clone)]
pub(crate) struct CompressedView {
    pub view: usize,
    /// Where the compressed bytes are.
    buffer: usize,
    offset: usize,
    length: usize,
    stride: usize,
    count: usize,
    mode: Mode,
    filter: Filter,
}

impl CompressedView {
    /// Size of the decoded data: the view's byteLength.
    pub fn decoded_len(&self) -> usize {
        self.stride * self.count
    }
}

fn invalid(file: &str, view: usize, detail: String) -> SceneError {
    SceneError::Invalid {
        file: file.to_owned(),
        detail: format!(
            "bufferView {view} is compressed with {EXTENSION}, but {detail}. Fix: re-encode the asset \
             (for example with gltfpack or gltf-transform meshopt), or export it without compression."
        ),
    }
}

/// Whether buffer `b` of the JSON is a fallback buffer: one that exists
/// only so compressed views have something to point at, and may hold no
/// data at all.
pub(crate) fn is_fallback_buffer(buffer: &Value) -> bool {
    buffer
        .get("extensions")
        .and_then(|e| e.get(EXTENSION))
        .and_then(|e| e.get("fallback"))
        .and_then(Value::as_bool)
        .unwrap_or(false)
}

/// Finds and checks every compressed view of the (already validated) JSON.
pub(crate) fn compressed_views(file: &str, json: &Value) -> Result<Vec<CompressedView>> {
    let empty = Vec::new();
    let views = json
        .get("bufferViews")
        .and_then(Value::as_array)
        .unwrap_or(&empty);
    let buffers = json
        .get("buffers")
        .and_then(Value::as_array)
        .unwrap_or(&empty);
    let mut out = Vec::new();
    let mut total: u64 = 0;
    for (i, view) in views.iter().enumerate() {
        let Some(ext) = view.get("extensions").and_then(|e| e.get(EXTENSION)) else {
            continue;
        };
        let ext = ext
            .as_object()
            .ok_or_else(|| invalid(file, i, "its extension object is not a JSON object".into()))?;
        let c = check_view(file, i, view, ext, buffers)?;
        total += c.decoded_len() as u64;
        if total > MAX_DECODED_BYTES {
            return Err(invalid(
                file,
                i,
                format!(
                    "the compressed views up to it decode to {total} bytes, more than the \
                     {MAX_DECODED_BYTES} soupray decodes for one file"
                ),
            ));
        }
        out.push(c);
    }
    Ok(out)
}

fn check_view(
    file: &str,
    i: usize,
    view: &Value,
    ext: &Map<String, Value>,
    buffers: &[Value],
) -> Result<CompressedView> {
    let uint = |key: &str, default: Option<u64>| -> Result<u64> {
        match ext.get(key) {
            None => default.ok_or_else(|| invalid(file, i, format!("its extension has no {key}"))),
            Some(v) => v.as_u64().ok_or_else(|| {
                invalid(
                    file,
                    i,
                    format!("its extension's {key} is {v}, not a non-negative integer"),
                )
            }),
        }
    };
    let buffer = uint("buffer", None)?;
    let offset = uint("byteOffset", Some(0))?;
    let length = uint("byteLength", None)?;
    let stride = uint("byteStride", None)?;
    let count = uint("count", None)?;
    let mode = view_mode(file, i, ext)?;
    let filter = view_filter(file, i, ext)?;
    check_source(file, i, buffers, buffer, offset, length)?;
    check_decoder_layout(file, i, mode, filter, stride, count)?;
    check_decoded_size(file, i, view, mode, stride, count, length)?;
    Ok(CompressedView {
        view: i,
        buffer: buffer as usize,
        offset: offset as usize,
        length: length as usize,
        stride: stride as usize,
        count: count as usize,
        mode,
        filter,
    })
}

/// The extension's `mode`.
fn view_mode(file: &str, i: usize, ext: &Map<String, Value>) -> Result<Mode> {
    Ok(match ext.get("mode").and_then(Value::as_str) {
        Some("ATTRIBUTES") => Mode::Attributes,
        Some("TRIANGLES") => Mode::Triangles,
        Some("INDICES") => Mode::Indices,
        other => {
            return Err(invalid(
                file,
                i,
                format!(
                    "its mode is {}; the extension defines ATTRIBUTES, TRIANGLES and INDICES",
                    other.map_or("missing".to_owned(), |m| format!("\"{m}\""))
                ),
            ))
        }
    })
}

/// The extension's `filter` (NONE when absent).
fn view_filter(file: &str, i: usize, ext: &Map<String, Value>) -> Result<Filter> {
    Ok(match ext.get("filter").map(|f| f.as_str()) {
        None | Some(Some("NONE")) => Filter::None,
        Some(Some("OCTAHEDRAL")) => Filter::Octahedral,
        Some(Some("QUATERNION")) => Filter::Quaternion,
        Some(Some("EXPONENTIAL")) => Filter::Exponential,
        Some(other) => {
            return Err(invalid(
                file,
                i,
                format!(
                    "its filter is {}; the extension defines NONE, OCTAHEDRAL, QUATERNION and EXPONENTIAL",
                    other.map_or("not a string".to_owned(), |m| format!("\"{m}\""))
                ),
            ))
        }
    })
}

/// The compressed bytes lie inside a buffer that holds data.
fn check_source(
    file: &str,
    i: usize,
    buffers: &[Value],
    buffer: u64,
    offset: u64,
    length: u64,
) -> Result<()> {
    let source = buffers.get(buffer as usize).ok_or_else(|| {
        invalid(
            file,
            i,
            format!(
                "its extension refers to buffer {buffer}, and the file has {} buffers",
                buffers.len()
            ),
        )
    })?;
    if is_fallback_buffer(source) {
        return Err(invalid(
            file,
            i,
            format!(
                "its compressed data is in buffer {buffer}, a fallback buffer (which holds no data)"
            ),
        ));
    }
    let source_len = source
        .get("byteLength")
        .and_then(Value::as_u64)
        .unwrap_or(0);
    let end = u128::from(offset) + u128::from(length);
    if length == 0 || end > u128::from(source_len) {
        return Err(invalid(
            file,
            i,
            format!(
                "its compressed data covers bytes {offset}..{end} of buffer {buffer}, whose byteLength is {source_len}"
            ),
        ));
    }
    Ok(())
}

/// The mode, filter and stride are a combination the decoder accepts.
fn check_decoder_layout(
    file: &str,
    i: usize,
    mode: Mode,
    filter: Filter,
    stride: u64,
    count: u64,
) -> Result<()> {
    // Each check below is one of the decoder's own asserts.
    match mode {
        Mode::Attributes if stride == 0 || stride > 256 || !stride.is_multiple_of(4) => {
            return Err(invalid(
                file,
                i,
                format!("its mode is ATTRIBUTES with byteStride {stride}; that mode needs a multiple of 4 from 4 to 256"),
            ))
        }
        Mode::Triangles | Mode::Indices if stride != 2 && stride != 4 => {
            return Err(invalid(
                file,
                i,
                format!("its mode is {mode:?} with byteStride {stride}; index modes need 2 or 4"),
            ))
        }
        Mode::Triangles if !count.is_multiple_of(3) => {
            return Err(invalid(
                file,
                i,
                format!("its mode is TRIANGLES with count {count}, which is not a multiple of 3"),
            ))
        }
        _ => {}
    }
    if filter != Filter::None && mode != Mode::Attributes {
        return Err(invalid(
            file,
            i,
            format!("it has filter {filter:?}, which only ATTRIBUTES mode allows"),
        ));
    }
    let filter_ok = match filter {
        Filter::None => true,
        Filter::Octahedral => stride == 4 || stride == 8,
        Filter::Quaternion => stride == 8,
        Filter::Exponential => stride.is_multiple_of(4),
    };
    if !filter_ok {
        return Err(invalid(
            file,
            i,
            format!(
                "its filter {filter:?} does not allow byteStride {stride} (OCTAHEDRAL needs 4 or 8, QUATERNION 8)"
            ),
        ));
    }
    Ok(())
}

/// What the view decodes to is plausible for its compressed length, within
/// soupray's limit, and covers the bufferView.
fn check_decoded_size(
    file: &str,
    i: usize,
    view: &Value,
    mode: Mode,
    stride: u64,
    count: u64,
    length: u64,
) -> Result<()> {
    // The data cannot decode to more than the smallest encoding allows: a
    // count that lies about a short payload is refused before allocating.
    let decoded = u128::from(stride) * u128::from(count);
    let plausible = match mode {
        Mode::Attributes => decoded <= u128::from(length) * u128::from(MAX_VERTEX_EXPANSION),
        // A header, a byte per triangle and a 16-byte table at least.
        Mode::Triangles => u128::from(length) >= 17 + u128::from(count / 3),
        // A header, a byte per index and a 4-byte tail at least.
        Mode::Indices => u128::from(length) >= 5 + u128::from(count),
    };
    if count == 0 || !plausible {
        return Err(invalid(
            file,
            i,
            format!(
                "it claims {count} elements of {stride} bytes from {length} compressed bytes, which \
                 cannot hold them"
            ),
        ));
    }
    if decoded > u128::from(MAX_DECODED_BYTES) {
        return Err(invalid(
            file,
            i,
            format!(
                "it decodes to {decoded} bytes, more than the {MAX_DECODED_BYTES} soupray decodes for one file"
            ),
        ));
    }
    let view_len = view.get("byteLength").and_then(Value::as_u64).unwrap_or(0);
    if u128::from(view_len) > decoded {
        return Err(invalid(
            file,
            i,
            format!(
                "its byteLength is {view_len} while its extension decodes only {count} x {stride} = {decoded} bytes"
            ),
        ));
    }
    if let Some(view_stride) = view.get("byteStride").and_then(Value::as_u64) {
        if mode == Mode::Attributes && view_stride != stride {
            return Err(invalid(
                file,
                i,
                format!(
                    "its byteStride is {view_stride} while its extension's is {stride}; the extension \
                     requires them to be equal"
                ),
            ));
        }
    }
    Ok(())
}
/// Points each compressed view of the `gltf` crate's copy of the JSON at
/// a buffer of its own (appended after the file's buffers, in the order of
/// `views`) holding the decoded bytes from offset 0.
pub(crate) fn redirect_views(json: &mut Value, views: &[CompressedView]) {
    if views.is_empty() {
        return;
    }
    let first_new = json
        .get("buffers")
        .and_then(Value::as_array)
        .map_or(0, Vec::len);
    for (k, c) in views.iter().enumerate() {
        if let Some(view) = json
            .get_mut("bufferViews")
            .and_then(|v| v.get_mut(c.view))
            .and_then(Value::as_object_mut)
        {
            view.insert("buffer".into(), Value::from(first_new + k));
            view.insert("byteOffset".into(), Value::from(0));
            if let Some(ext) = view.get_mut("extensions").and_then(Value::as_object_mut) {
                ext.remove(EXTENSION);
            }
        }
        if let Some(buffers) = json.get_mut("buffers").and_then(Value::as_array_mut) {
            buffers.push(serde_json::json!({ "byteLength": c.decoded_len() }));
        }
    }
}

/// Decodes one view from the file's buffers. A failure names the file, the
/// view and what went wrong.
pub(crate) fn decode(
    file: &str,
    c: &CompressedView,
    buffers: &[Vec<u8>],
    short_buffers: &[Option<String>],
) -> Result<Vec<u8>> {
    let data = &buffers[c.buffer];
    let end = c.offset + c.length;
    if end > data.len() {
        let why = short_buffers[c.buffer]
            .clone()
            .unwrap_or_else(|| format!("buffer {} is short", c.buffer));
        return Err(SceneError::Invalid {
            file: file.to_owned(),
            detail: format!(
                "bufferView {} is compressed with {EXTENSION} in bytes {}..{end} of buffer {}, which holds \
                 only {} bytes ({why}). Fix: re-export the asset or re-copy it completely.",
                c.view,
                c.offset,
                c.buffer,
                data.len()
            ),
        });
    }
    let encoded = &data[c.offset..end];
    // u32 words so the filters, which read 16- and 32-bit lanes in place,
    // get aligned memory.
    let mut words = vec![0u32; c.decoded_len().div_ceil(4)];
    let destination = words.as_mut_ptr().cast::<std::ffi::c_void>();
    // SAFETY: `destination` holds at least count * stride bytes, and every
    // precondition the decoders assert (stride, count % 3) was checked by
    // `check_view`; the decoders read at most `encoded.len()` bytes.
    let status = unsafe {
        match c.mode {
            Mode::Attributes => ::meshopt::ffi::meshopt_decodeVertexBuffer(
                destination,
                c.count,
                c.stride,
                encoded.as_ptr(),
                encoded.len(),
            ),
            Mode::Triangles => ::meshopt::ffi::meshopt_decodeIndexBuffer(
                destination,
                c.count,
                c.stride,
                encoded.as_ptr(),
                encoded.len(),
            ),
            Mode::Indices => ::meshopt::ffi::meshopt_decodeIndexSequence(
                destination,
                c.count,
                c.stride,
                encoded.as_ptr(),
                encoded.len(),
            ),
        }
    };
    if status != 0 {
        let why = match status {
            -1 => "its header names no format version the decoder knows",
            -2 => "its data ends before all elements are decoded",
            -3 => "it has bytes left over after all elements are decoded",
            _ => "the decoder rejected it",
        };
        return Err(SceneError::Invalid {
            file: file.to_owned(),
            detail: format!(
                "bufferView {} cannot be decoded ({EXTENSION}, mode {:?}, {} x {} bytes from {} compressed bytes): \
                 {why} (meshoptimizer error {status}). Fix: re-encode the asset with gltfpack or gltf-transform, \
                 or re-copy it completely if it was truncated.",
                c.view, c.mode, c.count, c.stride, c.length
            ),
        });
    }
    // SAFETY: as above; the filters rewrite `count` elements of `stride`
    // bytes in place, with the strides each one asserts checked.
    unsafe {
        match c.filter {
            Filter::None => {}
            Filter::Octahedral => {
                ::meshopt::ffi::meshopt_decodeFilterOct(destination, c.count, c.stride)
            }
            Filter::Quaternion => {
                ::meshopt::ffi::meshopt_decodeFilterQuat(destination, c.count, c.stride)
            }
            Filter::Exponential => {
                ::meshopt::ffi::meshopt_decodeFilterExp(destination, c.count, c.stride)
            }
        }
    }
    let mut bytes: Vec<u8> = bytemuck::cast_slice(&words).to_vec();
    bytes.truncate(c.decoded_len());
    Ok(bytes)
}
