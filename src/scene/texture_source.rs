//! Which image a texture samples. glTF's texture-source extensions
//! (KHR_texture_basisu, EXT_texture_webp, EXT_texture_avif) each name an
//! image in `textures[i].extensions.EXT.source` that a renderer should
//! prefer over `textures[i].source`, which is then an optional fallback in
//! a format every viewer reads (PNG or JPEG). soupray decodes KTX2/Basis
//! Universal and WebP, and has no AVIF decoder, so an AVIF texture falls
//! back to `source` with a warning, and a file that requires AVIF without a
//! fallback is refused with the way out. (The `image` crate's AVIF decoding
//! needs the system dav1d; rav1d 1.1, the Rust port, builds with cargo alone
//! and decodes correctly, but aborts the process on some corrupt files, a
//! panic inside its C API, which untrusted textures must not be able to do.)

use serde_json::Value;

use super::error::{Result, SceneError};

pub(crate) const KHR_TEXTURE_BASISU: &str = "KHR_texture_basisu";
pub(crate) const EXT_TEXTURE_WEBP: &str = "EXT_texture_webp";
pub(crate) const EXT_TEXTURE_AVIF: &str = "EXT_texture_avif";

/// Every texture-source extension `validate` checks the `source` index of.
pub(crate) const TEXTURE_SOURCE_EXTENSIONS: &[&str] =
    &[KHR_TEXTURE_BASISU, EXT_TEXTURE_WEBP, EXT_TEXTURE_AVIF];

/// Those soupray decodes, in the order it prefers them when a texture
/// names several.
const DECODED_SOURCE_EXTENSIONS: &[&str] = &[KHR_TEXTURE_BASISU, EXT_TEXTURE_WEBP];

/// The image index `textures[texture].extensions.EXT.source`, if present
/// (`validate` has checked that it is in range).
fn extension_source(texture: &Value, ext: &str) -> Option<usize> {
    texture
        .get("extensions")?
        .get(ext)?
        .get("source")?
        .as_u64()
        .map(|s| s as usize)
}

/// The image each texture samples, in texture order, and the one warning
/// for the file's AVIF textures if it has any. Errs when a texture has no
/// image soupray can use and the file requires the extension that would
/// have given it one.
pub(crate) fn choose_texture_images(
    file: &str,
    json: &Value,
) -> Result<(Vec<Option<usize>>, Option<String>)> {
    let required = |ext: &str| {
        json.get("extensionsRequired")
            .and_then(Value::as_array)
            .is_some_and(|r| r.iter().any(|e| e.as_str() == Some(ext)))
    };
    let textures = json
        .get("textures")
        .and_then(Value::as_array)
        .map(Vec::as_slice)
        .unwrap_or_default();
    let mut chosen = Vec::with_capacity(textures.len());
    // (texture, AVIF image, fallback image)
    let mut avif: Vec<(usize, usize, Option<usize>)> = Vec::new();
    for (i, t) in textures.iter().enumerate() {
        let fallback = t.get("source").and_then(Value::as_u64).map(|s| s as usize);
        let decoded = DECODED_SOURCE_EXTENSIONS
            .iter()
            .find_map(|ext| extension_source(t, ext));
        let image = match (decoded, extension_source(t, EXT_TEXTURE_AVIF)) {
            (Some(image), _) => Some(image),
            (None, Some(avif_image)) => {
                avif.push((i, avif_image, fallback));
                // Without a fallback the texture keeps its AVIF image, whose
                // decoding then fails with the reason and the fix.
                Some(fallback.unwrap_or(avif_image))
            }
            (None, None) => fallback,
        };
        chosen.push(image);
    }
    if avif.is_empty() {
        return Ok((chosen, None));
    }
    let list = |items: &mut dyn Iterator<Item = String>| {
        let items: Vec<String> = items.collect();
        let shown = items.len().min(4);
        let mut text = items[..shown].join(", ");
        if items.len() > shown {
            text.push_str(&format!(" and {} more", items.len() - shown));
        }
        text
    };
    let without: Vec<_> = avif.iter().filter(|(_, _, f)| f.is_none()).collect();
    if required(EXT_TEXTURE_AVIF) && !without.is_empty() {
        return Err(SceneError::Invalid {
            file: file.to_owned(),
            detail: format!(
                "the file requires EXT_texture_avif and {} has only an AVIF image ({}), which soupray \
                 cannot decode (it reads PNG, JPEG, WebP and KTX2/Basis Universal). Fix: convert the \
                 textures, for example with `gltf-transform webp {file} out.glb` (or `gltf-transform png`), \
                 or re-export them with a PNG or JPEG fallback in textures[].source.",
                if without.len() == 1 { "texture" } else { "textures" },
                list(&mut without
                    .iter()
                    .map(|(t, img, _)| format!("texture {t}: image {img}")))
            ),
        });
    }
    let mut parts = Vec::new();
    let with: Vec<_> = avif.iter().filter(|(_, _, f)| f.is_some()).collect();
    if !with.is_empty() {
        parts.push(format!(
            "uses the fallback image for {}",
            list(&mut with.iter().map(|(t, img, f)| format!(
                "texture {t} (AVIF image {img}, fallback image {})",
                f.unwrap_or_default()
            )))
        ));
    }
    if !without.is_empty() {
        parts.push(format!(
            "cannot texture with {}, which have no fallback, so the materials render with their factors only",
            list(&mut without
                .iter()
                .map(|(t, img, _)| format!("texture {t} (AVIF image {img})")))
        ));
    }
    let warning = format!(
        "{file}: EXT_texture_avif: soupray has no AVIF decoder; it {}. Fix: convert the textures with \
         `gltf-transform webp` or `gltf-transform png`.",
        parts.join("; it ")
    );
    Ok((chosen, Some(warning)))
}
