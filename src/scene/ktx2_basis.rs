//! KHR_texture_basisu: KTX2 textures with a Basis Universal payload (ETC1S
//! under BasisLZ, or UASTC raw or under Zstandard), transcoded to RGBA8 at
//! load, mip level 0 only.
//!
//! The container is read by the `ktx2` crate and transcoded by `basisu`, a
//! pure-Rust port of Binomial's transcoder (its output matched the C++
//! transcoder byte for byte on every KTX2 texture of Khronos' sample
//! assets). Pure Rust matters here: the bytes come from untrusted files.
//! Even so, everything the transcoder would trust is checked against the
//! file first ([`check`]): the level index, each level's sizes against the
//! dimensions, the BasisLZ global data and its slices, and the decoded size
//! against [`MAX_DECODED_IMAGE_BYTES`], the bound every image format shares.
//! Without these checks a level that lies about its uncompressed length
//! makes the transcoder allocate what it claims (found by fuzzing).
//!
//! Colour: the texels are the stored values, exactly as for PNG: whether they
//! are sRGB-encoded is decided by the material slot that samples them
//! (glTF 2.0, section 3.9, and KHR_texture_basisu, which requires the KTX2
//! transfer function to agree), not by the file's DFD. Orientation: glTF
//! asks for the top-left origin ("rd", rows top to bottom, like PNG); a file
//! whose `KTXorientation` says "ru" is flipped so that it still samples the
//! right way up.

use super::image_decode::MAX_DECODED_IMAGE_BYTES;
use super::material::DecodedImage;

/// DFD colour models of the Basis Universal payloads soupray transcodes.
const MODEL_ETC1S: u8 = 163;
const MODEL_UASTC: u8 = 166;

/// Size of the BasisLZ global data's header and of one image descriptor
/// (KTX 2.0, section 3.12.2).
const BASISLZ_HEADER: usize = 20;
const BASISLZ_IMAGE_DESC: usize = 20;

/// What to do about a texture soupray cannot use, for the messages.
const FIX_DAMAGED: &str =
    "Fix: re-encode the texture (for example with `toktx --t2 --encode uastc` \
                           or `gltf-transform uastc`), or check that the file is complete.";
const FIX_KIND: &str = "Fix: re-encode it as a 2D texture with `toktx --t2 --encode etc1s` or \
                        `--encode uastc` (or `gltf-transform etc1s`), or export it as PNG.";

/// KTX2's file identifier, "«KTX 20»\r\n\x1A\n".
pub(crate) fn is_ktx2(bytes: &[u8]) -> bool {
    bytes.starts_with(&ktx2::MAGIC)
}

/// The Basis payload of a checked file.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Payload {
    Etc1s,
    Uastc,
}

/// A texture's level 0 as RGBA8, rows top to bottom, or why not (completing
/// "image N: ...").
pub(crate) fn decode(bytes: &[u8]) -> Result<DecodedImage, String> {
    let (width, height, flip) = check(bytes)?;
    let transcoded = std::panic::catch_unwind(|| {
        let transcoder = basisu::Transcoder::new(bytes).map_err(transcoder_error)?;
        transcoder
            .transcode(0, basisu::TargetFormat::Rgba32, basisu::DecodeFlags::NONE)
            .map_err(transcoder_error)
    })
    .unwrap_or_else(|_| Err("the transcoder stopped on it".into()))
    .map_err(|e| {
        format!(
            "is a KTX2 file whose Basis Universal data cannot be transcoded ({e}). {FIX_DAMAGED}"
        )
    })?;
    let row = width as usize * 4;
    if transcoded.len() != row * height as usize {
        return Err(format!(
            "is a KTX2 file that transcoded to {} bytes instead of {width}x{height} RGBA texels. \
             {FIX_DAMAGED}",
            transcoded.len()
        ));
    }
    let rgba8 = if flip {
        transcoded.rchunks_exact(row).flatten().copied().collect()
    } else {
        transcoded
    };
    Ok(DecodedImage {
        width,
        height,
        rgba8,
    })
}

/// The transcoder's refusal in words (`basisu` reports a block it cannot
/// decode as a missing feature).
fn transcoder_error(e: basisu::Error) -> String {
    match e {
        basisu::Error::Truncated => "its data ends early".into(),
        basisu::Error::InvalidData => "its header or codebooks are corrupt".into(),
        basisu::Error::UnsupportedFeature(what) => {
            format!("the transcoder says \"{what}\", which is what corrupt blocks read as")
        }
        other => format!("{other:?}"),
    }
}

/// Checks everything the transcoder reads against the file and the size
/// bound; the dimensions of level 0 and whether the rows are stored bottom
/// to top.
fn check(bytes: &[u8]) -> Result<(u32, u32, bool), String> {
    let damaged = |what: String| format!("is a damaged KTX2 file: {what}. {FIX_DAMAGED}");
    let reader = ktx2::Reader::new(bytes).map_err(|e| {
        damaged(format!(
            "{e} (a header, index or level range past its {} bytes)",
            bytes.len()
        ))
    })?;
    let header = reader.header();
    let (width, height) = (header.pixel_width, header.pixel_height);
    let kind = |what: String| {
        format!("is a KTX2 {what}, which soupray cannot use as a glTF texture. {FIX_KIND}")
    };
    if let Some(format) = header.format {
        return Err(kind(format!(
            "texture of vkFormat {} rather than Basis Universal (KHR_texture_basisu textures are \
             ETC1S or UASTC, vkFormat 0)",
            format.value()
        )));
    }
    if height == 0 || header.pixel_depth != 0 {
        return Err(kind(format!(
            "{} texture",
            if height == 0 { "1D" } else { "3D" }
        )));
    }
    if header.face_count != 1 || header.layer_count > 1 {
        return Err(kind(format!(
            "texture of {} faces and {} layers (a glTF texture is one 2D image)",
            header.face_count, header.layer_count
        )));
    }
    let texels = width as u64 * height as u64;
    if texels * 4 > MAX_DECODED_IMAGE_BYTES {
        return Err(format!(
            "is a KTX2 file of {width}x{height} texels, which would decode to {} MiB, more than \
             soupray's {} MiB for one image. Fix: downscale the texture.",
            (texels * 4) >> 20,
            MAX_DECODED_IMAGE_BYTES >> 20
        ));
    }
    let model = reader.basic_dfd().map(|dfd| dfd.color_model);
    let payload = match model.map(|m| m.map_or(0, |m| m.value())) {
        Some(MODEL_ETC1S) => Payload::Etc1s,
        Some(MODEL_UASTC) => Payload::Uastc,
        Some(m) => {
            return Err(kind(format!(
                "texture of DFD colour model {m} (soupray transcodes ETC1S, model {MODEL_ETC1S}, \
                 and UASTC LDR, model {MODEL_UASTC})"
            )))
        }
        None => return Err(damaged("it has no basic data format descriptor".into())),
    };
    let scheme = header
        .supercompression_scheme
        .map(|s| s.value())
        .unwrap_or(0);
    // BasisLZ (1) is ETC1S's own; UASTC is stored raw (0) or under Zstandard (2).
    let scheme_ok = match payload {
        Payload::Etc1s => scheme == 1,
        Payload::Uastc => scheme == 0 || scheme == 2,
    };
    if !scheme_ok {
        return Err(kind(format!(
            "{payload:?} texture under supercompression scheme {scheme} (ETC1S goes with BasisLZ, \
             UASTC with none or Zstandard)"
        )));
    }
    let levels: Vec<_> = reader.levels().collect();
    let max_levels = 32 - width.max(height).leading_zeros();
    if levels.len() as u32 > max_levels {
        return Err(damaged(format!(
            "{} mip levels for {width}x{height} texels, which have at most {max_levels}",
            levels.len()
        )));
    }
    // Bytes of UASTC level `l`: one 16-byte block per 4x4 texels.
    let uastc_bytes = |l: usize| {
        let (w, h) = ((width >> l).max(1) as u64, (height >> l).max(1) as u64);
        w.div_ceil(4) * h.div_ceil(4) * 16
    };
    for (l, level) in levels.iter().enumerate() {
        let stored = level.data.len() as u64;
        let problem = match (payload, scheme) {
            (Payload::Uastc, 0) if stored != uastc_bytes(l) => Some(format!(
                "{stored} bytes where its size needs {}",
                uastc_bytes(l)
            )),
            (Payload::Uastc, _) if level.uncompressed_byte_length != uastc_bytes(l) => {
                Some(format!(
                    "an uncompressed length of {} bytes where its size needs {}",
                    level.uncompressed_byte_length,
                    uastc_bytes(l)
                ))
            }
            _ if stored == 0 => Some("no data".into()),
            _ => None,
        };
        if let Some(problem) = problem {
            return Err(damaged(format!("mip level {l} has {problem}")));
        }
    }
    if payload == Payload::Etc1s {
        check_basislz(reader.supercompression_global_data(), &levels).map_err(damaged)?;
    }
    let flip = reader
        .key_value_data()
        .find(|(key, _)| *key == "KTXorientation")
        .is_some_and(|(_, value)| value.get(1) == Some(&b'u'));
    Ok((width, height, flip))
}

fn u32_at(bytes: &[u8], at: usize) -> u32 {
    u32::from_le_bytes(bytes[at..at + 4].try_into().expect("4 bytes"))
}

/// The BasisLZ global data: its header's lengths add up to its size, and
/// every level's slices lie inside that level.
fn check_basislz(sgd: &[u8], levels: &[ktx2::Level]) -> Result<(), String> {
    let descs = BASISLZ_HEADER + BASISLZ_IMAGE_DESC * levels.len();
    if sgd.len() < descs {
        return Err(format!(
            "its BasisLZ global data is {} bytes, too short for the descriptors of {} mip levels \
             ({descs} bytes)",
            sgd.len(),
            levels.len()
        ));
    }
    let endpoints = u16::from_le_bytes([sgd[0], sgd[1]]);
    let selectors = u16::from_le_bytes([sgd[2], sgd[3]]);
    let lengths: u64 = (4..20).step_by(4).map(|at| u32_at(sgd, at) as u64).sum();
    if endpoints == 0 || selectors == 0 || descs as u64 + lengths != sgd.len() as u64 {
        return Err(format!(
            "its BasisLZ global data ({} bytes) does not add up: {endpoints} endpoints, {selectors} \
             selectors, and codebooks and tables of {lengths} bytes after {descs} bytes of \
             descriptors",
            sgd.len()
        ));
    }
    for (l, level) in levels.iter().enumerate() {
        let desc = BASISLZ_HEADER + BASISLZ_IMAGE_DESC * l;
        let rgb = (u32_at(sgd, desc + 4), u32_at(sgd, desc + 8));
        let alpha = (u32_at(sgd, desc + 12), u32_at(sgd, desc + 16));
        for (name, (offset, length)) in [("colour", rgb), ("alpha", alpha)] {
            let end = offset as u64 + length as u64;
            if (name == "colour" && length == 0) || end > level.data.len() as u64 {
                return Err(format!(
                    "mip level {l}'s {name} slice (bytes {offset}..{end}) is not inside the \
                     level's {} bytes",
                    level.data.len()
                ));
            }
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_the_ktx2_identifier_is_ktx2() {
        assert!(is_ktx2(b"\xabKTX 20\xbb\r\n\x1a\n"));
        assert!(!is_ktx2(b"\x89PNG\r\n\x1a\n"));
        assert!(!is_ktx2(b"\xabKTX 20\xbb\r\n\x1a"));
    }
}
