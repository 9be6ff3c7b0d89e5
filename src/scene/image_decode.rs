//! Texture images to RGBA8: PNG, JPEG and WebP through the `image` crate
//! (WebP with its pure-Rust `image-webp` decoder), and KTX2 with Basis
//! Universal through `ktx2_basis`, told apart by their bytes rather than by
//! `mimeType`, which exporters get wrong (a `.ktx2` named as an image's `uri`
//! with no mimeType is common). AVIF is recognised only to say that soupray
//! cannot decode it.

use std::io::Cursor;

use super::ktx2_basis;
use super::material::DecodedImage;

/// The formats soupray decodes, for messages.
pub(crate) const READABLE_FORMATS: &str = "PNG, JPEG, WebP and KTX2 (Basis Universal)";

/// The most one decoded image may take, RGBA8, in any format: the `image`
/// crate's default allocation limit, made explicit so that KTX2 shares it
/// (a header's dimensions are checked against it before anything is
/// allocated or decoded).
pub(crate) const MAX_DECODED_IMAGE_BYTES: u64 = 512 << 20;

/// An ISO-BMFF file (`ftyp` box) of an AVIF brand.
fn is_avif(bytes: &[u8]) -> bool {
    bytes.get(4..8) == Some(b"ftyp") && matches!(bytes.get(8..12), Some(b"avif") | Some(b"avis"))
}

/// The image's pixels, or why they cannot be had (in the words of the
/// message `Image::decoded` completes with the file and image).
pub(crate) fn decode(bytes: &[u8]) -> Result<DecodedImage, String> {
    if is_avif(bytes) {
        return Err(format!(
            "is AVIF, which soupray cannot decode (it reads {READABLE_FORMATS}). Fix: convert the \
             textures, for example with `gltf-transform webp` or `gltf-transform png`, or give the \
             texture a PNG or JPEG fallback in textures[].source."
        ));
    }
    if ktx2_basis::is_ktx2(bytes) {
        return ktx2_basis::decode(bytes);
    }
    let cannot = |e: image::ImageError| {
        format!(
            "cannot be decoded ({e}); soupray reads {READABLE_FORMATS}. Fix: re-export the texture \
             as PNG, JPEG or WebP."
        )
    };
    let mut limits = image::Limits::no_limits();
    limits.max_alloc = Some(MAX_DECODED_IMAGE_BYTES);
    let mut reader = image::ImageReader::new(Cursor::new(bytes))
        .with_guessed_format()
        .map_err(|e| cannot(e.into()))?;
    reader.limits(limits);
    let img = reader.decode().map_err(cannot)?;
    let rgba = img.to_rgba8();
    Ok(DecodedImage {
        width: rgba.width(),
        height: rgba.height(),
        rgba8: rgba.into_raw(),
    })
}
