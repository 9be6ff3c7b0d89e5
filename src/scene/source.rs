//! Turning a path into a validated glTF document plus the bytes of every
//! buffer: `.gltf` with external or data-URI buffers, and `.glb`. The GLB
//! container is parsed here rather than by the `gltf` crate so that a
//! truncated binary chunk is kept (short) instead of rejected outright: the
//! accessor that reaches past the end then reports itself by name, which
//! tells the user far more than "length mismatch".

use std::path::{Path, PathBuf};

use super::error::{Result, SceneError};
use super::texture_source;

/// Extensions other than the materials' whose semantics soupray
/// implements ([`supported_extensions`] adds those).
const GEOMETRY_SCENE_AND_TEXTURE_EXTENSIONS: &[&str] = &[
    "EXT_mesh_gpu_instancing",
    "EXT_meshopt_compression",
    "KHR_animation_pointer",
    "KHR_draco_mesh_compression",
    "KHR_lights_punctual",
    "KHR_mesh_quantization",
    "KHR_texture_transform",
    "EXT_texture_webp",
    "KHR_texture_basisu",
];

/// Every extension whose semantics soupray implements, sorted; any other
/// name in `extensionsRequired` is refused. (Names in `extensionsUsed`
/// only are optional by definition and are ignored when unknown.)
pub fn supported_extensions() -> Vec<&'static str> {
    let mut names = GEOMETRY_SCENE_AND_TEXTURE_EXTENSIONS.to_vec();
    names.extend(super::material_load::supported_material_extensions());
    names.sort_unstable();
    names
}

/// Supported extensions read from the raw JSON rather than by the `gltf`
/// crate: every material extension (`scene::material`), and these
/// (`scene::mesh` for the geometry ones).
const READ_FROM_RAW_JSON: &[&str] = &[
    "EXT_mesh_gpu_instancing",
    "EXT_meshopt_compression",
    "KHR_animation_pointer",
    "KHR_draco_mesh_compression",
    "KHR_mesh_quantization",
    texture_source::KHR_TEXTURE_BASISU,
    texture_source::EXT_TEXTURE_WEBP,
    texture_source::EXT_TEXTURE_AVIF,
];

const GLB_MAGIC: &[u8; 4] = b"glTF";
const CHUNK_JSON: u32 = 0x4E4F_534A;
const CHUNK_BIN: u32 = 0x004E_4942;

/// A loaded document and its buffers.
pub struct Source {
    /// The path as the user gave it, for messages.
    pub file: String,
    /// Directory that relative URIs resolve against.
    pub dir: PathBuf,
    pub document: gltf::Document,
    /// The same JSON untyped, for the few extension fields the `gltf`
    /// crate drops (KHR_texture_transform on normal and occlusion maps).
    pub json: serde_json::Value,
    pub buffers: Vec<Vec<u8>>,
    /// Per buffer: why it holds fewer bytes than its `byteLength` says, if so.
    pub short_buffers: Vec<Option<String>>,
    /// What was skipped or ignored while reading (unknown animation paths,
    /// buffers longer than their `byteLength`).
    pub warnings: Vec<String>,
}

impl Source {
    /// Whether the file lists `name` in extensionsUsed (or, against the
    /// spec but harmlessly, only in extensionsRequired).
    pub(crate) fn uses_extension(&self, name: &str) -> bool {
        self.json
            .as_object()
            .is_some_and(|root| uses_extension(root, name))
    }
}

pub(crate) fn uses_extension(
    root: &serde_json::Map<String, serde_json::Value>,
    name: &str,
) -> bool {
    ["extensionsUsed", "extensionsRequired"].iter().any(|key| {
        root.get(*key)
            .and_then(|list| list.as_array())
            .is_some_and(|list| list.iter().any(|e| e.as_str() == Some(name)))
    })
}

struct Glb<'a> {
    json: &'a [u8],
    bin: Option<Vec<u8>>,
    /// Set when the file ends before the length its header declares.
    truncation: Option<String>,
}

pub fn load(path: &Path) -> Result<Source> {
    let file = path.display().to_string();
    let bytes =
        crate::input::read_regular(path, crate::input::MAX_INPUT_BYTES).map_err(|cause| {
            SceneError::Io {
                file: file.clone(),
                what: "the glTF file".into(),
                cause,
            }
        })?;
    let dir = path
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."));

    let glb = if bytes.starts_with(GLB_MAGIC) {
        Some(parse_glb(&file, &bytes)?)
    } else {
        None
    };
    let json_bytes = glb.as_ref().map_or(&bytes[..], |g| g.json);
    let not_json = |e: &dyn std::fmt::Display| {
        SceneError::Malformed {
        file: file.clone(),
        detail: format!(
            "is not valid glTF JSON: {e}{}. Fix: re-export the file; if it was copied or downloaded, \
             check that the copy is complete.",
            glb.as_ref()
                .and_then(|g| g.truncation.as_deref())
                .map(|t| format!(" ({t})"))
                .unwrap_or_default()
        ),
    }
    };
    let mut json: serde_json::Value =
        serde_json::from_slice(json_bytes).map_err(|e| not_json(&e))?;
    check_required_extensions(&file, &json)?;
    // Every index and range checked before the `gltf` crate sees them.
    let mut warnings = super::validate::validate(&file, &mut json)?;
    let mut for_crate = json_for_crate(&json);
    // The `gltf` crate needs every texture's `source`; it gets the image
    // soupray samples, which a texture-source extension may have chosen.
    let (texture_images, avif_warning) = texture_source::choose_texture_images(&file, &json)?;
    warnings.extend(avif_warning);
    if let Some(textures) = for_crate.get_mut("textures").and_then(|t| t.as_array_mut()) {
        for (texture, image) in textures.iter_mut().zip(&texture_images) {
            if let (Some(t), Some(image)) = (texture.as_object_mut(), image) {
                t.insert("source".into(), (*image).into());
            }
        }
    }
    let compressed = super::meshopt_views::compressed_views(&file, &json)?;
    super::meshopt_views::redirect_views(&mut for_crate, &compressed);
    // Draco primitives decode into buffers appended after those.
    let mut draco = super::draco::draco_primitives(&file, &json)?;
    super::draco::redirect(&mut for_crate, &mut draco);
    let root: gltf::json::Root = serde_json::from_value(for_crate).map_err(|e| not_json(&e))?;

    let document = gltf::Document::from_json(root).map_err(|e| SceneError::Malformed {
        file: file.clone(),
        detail: format!(
            "is not valid glTF 2.0: {e}. Fix: run the file through the Khronos glTF-Validator \
             and re-export it from the authoring tool."
        ),
    })?;

    let file_buffers = document.buffers().len() - compressed.len() - draco.len();
    let (mut buffers, mut short_buffers) = read_file_buffers(
        &file,
        &dir,
        &json,
        &document,
        file_buffers,
        glb,
        &mut warnings,
    )?;
    // Compressed views decode into the buffers `redirect_views` appended.
    for c in &compressed {
        let decoded = super::meshopt_views::decode(&file, c, &buffers, &short_buffers)?;
        buffers.push(decoded);
        short_buffers.push(None);
    }
    for d in &draco {
        let decoded = super::draco::decode(&file, d, &document, &buffers, &short_buffers)?;
        buffers.push(decoded);
        short_buffers.push(None);
    }

    Ok(Source {
        file,
        dir,
        document,
        json,
        buffers,
        short_buffers,
        warnings,
    })
}

/// Every extension the file requires must be one soupray reads.
fn check_required_extensions(file: &str, json: &serde_json::Value) -> Result<()> {
    if let Some(required) = json.get("extensionsRequired").and_then(|r| r.as_array()) {
        let supported = supported_extensions();
        for extension in required {
            let name = extension.as_str().unwrap_or("(not a string)");
            // Required AVIF is honoured where every AVIF texture has a
            // fallback image; `choose_texture_images` refuses the rest.
            if !supported.contains(&name) && name != texture_source::EXT_TEXTURE_AVIF {
                return Err(SceneError::UnsupportedExtension {
                    file: file.to_owned(),
                    extension: name.to_owned(),
                    supported: supported.join(", "),
                });
            }
        }
    }
    Ok(())
}

/// The document handed to the `gltf` crate: without what soupray reads
/// from the raw JSON itself.
fn json_for_crate(json: &serde_json::Value) -> serde_json::Value {
    // The extensions soupray reads from the raw JSON itself are checked
    // above; the `gltf` crate, built without them, would refuse them when
    // required.
    let mut for_crate = json.clone();
    if let Some(required) = for_crate
        .get_mut("extensionsRequired")
        .and_then(|r| r.as_array_mut())
    {
        let materials = super::material_load::supported_material_extensions();
        let read_raw = |name: &str| READ_FROM_RAW_JSON.contains(&name) || materials.contains(&name);
        required.retain(|e| !e.as_str().is_some_and(read_raw));
    }
    // KHR_animation_pointer channels (`scene::pointer`) are read from the
    // raw JSON; the crate knows no "pointer" path.
    if let Some(animations) = for_crate
        .get_mut("animations")
        .and_then(|a| a.as_array_mut())
    {
        for animation in animations {
            if let Some(channels) = animation.get_mut("channels").and_then(|c| c.as_array_mut()) {
                channels.retain(|ch| super::pointer::channel_pointer(ch).is_none());
            }
        }
    }
    for_crate
}

/// Per buffer, why it holds fewer bytes than its byteLength (if it does).
type ShortBuffers = Vec<Option<String>>;

/// The buffers the file itself holds (the first `count` of the document's;
/// decoded ones are appended after them), each cut to its byteLength,
/// with a note for each that is shorter.
fn read_file_buffers(
    file: &str,
    dir: &Path,
    json: &serde_json::Value,
    document: &gltf::Document,
    count: usize,
    glb: Option<Glb>,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Vec<u8>>, ShortBuffers)> {
    let (glb_bin, glb_truncation) = match glb {
        Some(g) => (g.bin, g.truncation),
        None => (None, None),
    };
    let mut glb_bin = glb_bin;
    let mut buffers = Vec::new();
    let mut short_buffers = Vec::new();
    for buffer in document.buffers().take(count) {
        let raw = &json["buffers"][buffer.index()];
        if super::meshopt_views::is_fallback_buffer(raw) {
            // Only compressed views point here, and they read their
            // decoded buffers instead: its uri, if any, is not read.
            buffers.push(Vec::new());
            short_buffers.push(Some(format!(
                "buffer {} is a fallback buffer of {}, which holds no data",
                buffer.index(),
                super::meshopt_views::EXTENSION
            )));
            continue;
        }
        let (data, glb_note) = match buffer.source() {
            gltf::buffer::Source::Bin => match glb_bin.take() {
                Some(bin) => (bin, glb_truncation.clone()),
                None => {
                    return Err(SceneError::Buffer {
                        file: file.to_owned(),
                        buffer: buffer.index(),
                        uri: "(GLB binary chunk)".into(),
                        problem: "is missing: the buffer has no uri and the file has no GLB BIN chunk. \
                                  Fix: re-export the asset as a complete .glb, or give the buffer a uri."
                            .into(),
                    })
                }
            },
            gltf::buffer::Source::Uri(uri) => (
                read_uri(file, dir, buffer.index(), uri, buffer.length(), warnings)?,
                None,
            ),
        };
        let mut data = data;
        // A GLB's BIN chunk may carry up to 3 bytes of padding.
        let slack = if glb_note.is_some() || matches!(buffer.source(), gltf::buffer::Source::Bin) {
            3
        } else {
            0
        };
        if data.len() > buffer.length() + slack {
            warnings.push(format!(
                "buffer {} holds {} bytes but its byteLength is {}; the bytes past byteLength are ignored",
                buffer.index(),
                data.len(),
                buffer.length()
            ));
        }
        data.truncate(buffer.length());
        let note = (data.len() < buffer.length()).then(|| {
            glb_note.unwrap_or_else(|| {
                format!(
                    "buffer {} holds {} bytes but its byteLength is {}: its data is truncated",
                    buffer.index(),
                    data.len(),
                    buffer.length()
                )
            })
        });
        if let Some(n) = &note {
            warnings.push(n.clone());
        }
        buffers.push(data);
        short_buffers.push(note);
    }
    Ok((buffers, short_buffers))
}
fn parse_glb<'a>(file: &str, bytes: &'a [u8]) -> Result<Glb<'a>> {
    let malformed = |detail: String| {
        SceneError::Malformed {
        file: file.to_owned(),
        detail: format!("{detail}. Fix: re-export the .glb; if it was copied or downloaded, check that the copy is complete."),
    }
    };
    let u32_at = |at: usize| -> Option<u32> {
        bytes
            .get(at..at + 4)
            .map(|b| u32::from_le_bytes([b[0], b[1], b[2], b[3]]))
    };
    let version = u32_at(4)
        .ok_or_else(|| malformed("is a truncated GLB: the 12-byte header is incomplete".into()))?;
    if version != 2 {
        return Err(malformed(format!(
            "is a GLB of container version {version}; soupray reads glTF 2.0 (version 2)"
        )));
    }
    let declared = u32_at(8)
        .ok_or_else(|| malformed("is a truncated GLB: the 12-byte header is incomplete".into()))?
        as usize;
    let truncation = (bytes.len() < declared).then(|| {
        format!(
            "the GLB header declares {declared} bytes but the file has only {}: the file is truncated",
            bytes.len()
        )
    });
    if bytes.len() > declared {
        return Err(malformed(format!(
            "is not a valid GLB: its header declares {declared} bytes but the file has {}",
            bytes.len()
        )));
    }
    let end = declared.min(bytes.len());

    let json_len = u32_at(12)
        .ok_or_else(|| malformed("is a truncated GLB: it ends before its JSON chunk".into()))?
        as usize;
    if u32_at(16) != Some(CHUNK_JSON) {
        return Err(malformed(
            "is not a valid GLB: the first chunk is not the JSON chunk".into(),
        ));
    }
    let json_start = 20;
    let json_end = json_start + json_len;
    if json_end > end {
        return Err(malformed(format!(
            "is a truncated GLB: its JSON chunk needs bytes {json_start}..{json_end} but the file ends at {}",
            bytes.len()
        )));
    }
    let json = &bytes[json_start..json_end];

    let bin_header = (json_end + 3) & !3;
    let mut bin = None;
    if let (Some(bin_len), Some(kind)) = (u32_at(bin_header), u32_at(bin_header + 4)) {
        if kind == CHUNK_BIN {
            let start = bin_header + 8;
            let want_end = start + bin_len as usize;
            // Keep whatever part of the chunk exists; accessors that need
            // the missing tail report themselves by name.
            let have_end = want_end.min(end).max(start.min(end));
            bin = Some(bytes[start.min(end)..have_end].to_vec());
        }
    } else if truncation.is_some() && bin_header < declared {
        bin = Some(Vec::new());
    }
    Ok(Glb {
        json,
        bin,
        truncation,
    })
}

fn read_uri(
    file: &str,
    dir: &Path,
    buffer: usize,
    uri: &str,
    byte_length: usize,
    warnings: &mut Vec<String>,
) -> Result<Vec<u8>> {
    let err = |problem: String| SceneError::Buffer {
        file: file.to_owned(),
        buffer,
        uri: shorten(uri),
        problem,
    };
    if let Some(rest) = uri.strip_prefix("data:") {
        let (header, payload) = rest.split_once(',').ok_or_else(|| {
            err("is a data URI without a ',' before its payload. Fix: re-export the asset.".into())
        })?;
        if !header.ends_with(";base64") {
            return Err(err("is a data URI that is not base64-encoded; glTF buffers must use base64. Fix: re-export the asset.".into()));
        }
        return decode_base64(payload).ok_or_else(|| {
            err("is a data URI whose base64 payload is corrupt. Fix: re-export the asset.".into())
        });
    }
    let relative = percent_decode(uri);
    let path = dir.join(&relative);
    // Never more than the buffer declares: a huge or endless file cannot
    // make soupray allocate more than byteLength.
    let (bytes, size) = crate::input::read_regular_prefix(&path, byte_length as u64, true)
        .map_err(|e| {
            err(format!(
                "cannot be read as {} ({e}). Fix: put {relative} next to {file} (glTF resolves buffer URIs \
                 relative to the .gltf file), or use the .glb version of the asset.",
                path.display()
            ))
        })?;
    if size > byte_length as u64 {
        warnings.push(format!(
            "buffer {buffer}'s file {} holds {size} bytes but its byteLength is {byte_length}; \
             the bytes past byteLength are ignored",
            path.display()
        ));
    }
    Ok(bytes)
}

pub(crate) fn resolve_uri(dir: &Path, uri: &str) -> PathBuf {
    dir.join(percent_decode(uri))
}

fn shorten(uri: &str) -> String {
    if uri.len() > 60 {
        let cut = (0..=60)
            .rev()
            .find(|&i| uri.is_char_boundary(i))
            .unwrap_or(0);
        format!("{}...", &uri[..cut])
    } else {
        uri.to_owned()
    }
}

/// URIs in glTF are RFC 3986 references, so file names with spaces and the
/// like arrive percent-encoded.
fn percent_decode(uri: &str) -> String {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%' && i + 2 < bytes.len() {
            let hex = std::str::from_utf8(&bytes[i + 1..i + 3]).ok();
            if let Some(v) = hex.and_then(|h| u8::from_str_radix(h, 16).ok()) {
                out.push(v);
                i += 3;
                continue;
            }
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

/// Decodes standard or URL-safe base64, ignoring whitespace and padding.
pub(crate) fn decode_base64(text: &str) -> Option<Vec<u8>> {
    let mut out = Vec::with_capacity(text.len() * 3 / 4);
    let mut acc = 0u32;
    let mut bits = 0;
    for c in text.bytes() {
        let v = match c {
            b'A'..=b'Z' => c - b'A',
            b'a'..=b'z' => c - b'a' + 26,
            b'0'..=b'9' => c - b'0' + 52,
            b'+' | b'-' => 62,
            b'/' | b'_' => 63,
            b'=' | b' ' | b'\n' | b'\r' | b'\t' => continue,
            _ => return None,
        };
        acc = (acc << 6) | u32::from(v);
        bits += 6;
        if bits >= 8 {
            bits -= 8;
            out.push((acc >> bits) as u8);
            acc &= (1 << bits) - 1;
        }
    }
    Some(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trip_of_known_text() {
        assert_eq!(decode_base64("aGVsbG8gd29ybGQ=").unwrap(), b"hello world");
        assert_eq!(decode_base64("AAECAw==").unwrap(), vec![0, 1, 2, 3]);
        assert!(decode_base64("ab$c").is_none());
    }

    #[test]
    fn percent_decoding_of_spaces() {
        assert_eq!(percent_decode("my%20file.bin"), "my file.bin");
        assert_eq!(percent_decode("100%"), "100%");
    }
}
