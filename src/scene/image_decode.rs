//! Texture images to RGBA8: PNG, JPEG and WebP through the `image` crate
//! (WebP with its pure-Rust `image-webp` decoder), told apart by their
//! bytes rather than by `mimeType`, which exporters get wrong (a `.ktx2`
//! named as an image's `uri` with no mimeType is common). AVIF is
//! recognised only to say that soupray cannot decode it.

use super::material::DecodedImage;

/// The formats soupray decodes, for messages.
pub(crate) const READABLE_FORMATS: &str = "PNG, JPEG and WebP";

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
    let img = image::load_from_memory(bytes).map_err(|e| {
        format!(
            "cannot be decoded ({e}); soupray reads {READABLE_FORMATS}. Fix: re-export the texture \
             as PNG, JPEG or WebP."
        )
    })?;
    let rgba = img.to_rgba8();
    Ok(DecodedImage {
        width: rgba.width(),
        height: rgba.height(),
        rgba8: rgba.into_raw(),
    })
}
