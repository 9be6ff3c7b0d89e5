//! Texture formats beyond PNG and JPEG: EXT_texture_webp (decoded),
//! EXT_texture_avif (no decoder: fallback or a clear refusal),
//! KHR_texture_basisu (KTX2 with Basis Universal, transcoded at load) and
//! KHR_materials_pbrSpecularGlossiness (converted to metallic-roughness).
//! Third-party files are read in place from the shared folder; the
//! synthetic ones are made here.

mod scene_support;

use scene_support::shared::khronos;
use serde_json::{json, Value};
use soupray::scene::material::DecodedImage;
use soupray::scene::{LoadOptions, Scene};
use std::path::{Path, PathBuf};
use std::sync::Arc;

fn load(path: &Path) -> Scene {
    Scene::load(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn load_err(path: &Path) -> String {
    match Scene::load(path, &LoadOptions::default()) {
        Ok(_) => panic!("{} loaded, but should have been refused", path.display()),
        Err(e) => e.to_string(),
    }
}

/// The decoded image that texture `texture` samples.
fn texture_pixels(scene: &Scene, texture: usize) -> Arc<DecodedImage> {
    let table = scene.materials();
    let image = table.textures[texture].image;
    table.images[image]
        .decoded(image)
        .unwrap_or_else(|e| panic!("{e}"))
}

/// Per-channel mean and standard deviation of an RGBA8 image, 0-255.
fn stats(img: &DecodedImage) -> ([f64; 4], [f64; 4]) {
    let n = (img.width as usize * img.height as usize) as f64;
    let mut sum = [0f64; 4];
    let mut sq = [0f64; 4];
    for px in img.rgba8.chunks_exact(4) {
        for c in 0..4 {
            sum[c] += px[c] as f64;
            sq[c] += (px[c] as f64).powi(2);
        }
    }
    let mean = sum.map(|s| s / n);
    let mut sd = [0f64; 4];
    for c in 0..4 {
        sd[c] = (sq[c] / n - mean[c] * mean[c]).max(0.0).sqrt();
    }
    (mean, sd)
}

fn texel(img: &DecodedImage, x: u32, y: u32) -> [u8; 4] {
    let i = 4 * (y as usize * img.width as usize + x as usize);
    img.rgba8[i..i + 4].try_into().unwrap()
}

/// A glTF with no meshes, only `root`'s materials, textures and images,
/// written into `dir` as `name`.
fn write_gltf(dir: &Path, name: &str, mut root: Value) -> PathBuf {
    root["asset"] = json!({"version": "2.0"});
    root["scenes"] = json!([{"nodes": []}]);
    root["scene"] = json!(0);
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_string_pretty(&root).unwrap()).unwrap();
    path
}

/// `rgba` (w x h) as a lossless WebP, encoded by the `image` crate.
pub fn webp(w: u32, h: u32, rgba: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    image::codecs::webp::WebPEncoder::new_lossless(&mut out)
        .encode(rgba, w, h, image::ExtendedColorType::Rgba8)
        .unwrap();
    out
}

fn png(w: u32, h: u32, rgba: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    image::RgbaImage::from_raw(w, h, rgba.to_vec())
        .unwrap()
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .unwrap();
    out
}

// ---------------------------------------------------------------------------
// EXT_texture_webp

#[test]
fn webp_box_textured_decodes_to_the_cesium_logo() {
    let Some(path) = khronos("derived/BoxTextured/glTF-WEBP-derived/BoxTextured.glb") else {
        return;
    };
    // The file requires EXT_texture_webp and its texture has no `source`.
    let scene = load(&path);
    let img = texture_pixels(&scene, 0);
    assert_eq!((img.width, img.height), (256, 256));
    // Reference: libwebp 1.2.4's dwebp on the same bytes (the image is lossy
    // VP8, so decoders may differ by their chroma upsampling): means
    // 154.83, 186.49, 176.46, 255; the grey border (220, 220, 220) at (0,
    // 0) and (10, 200), the white centre (255, 255, 253) and the logo's blue
    // (108, 173, 224) at (64, 64). Measured here: `image-webp` gives the
    // same means to 4 decimals and the same texels, so the bounds are tight.
    let (mean, _) = stats(&img);
    let want_mean = [154.83, 186.49, 176.46, 255.0];
    for c in 0..4 {
        assert!(
            (mean[c] - want_mean[c]).abs() < 0.01,
            "channel {c} mean {} vs libwebp's {}",
            mean[c],
            want_mean[c]
        );
    }
    for ((x, y), want) in [
        ((0, 0), [220, 220, 220, 255]),
        ((10, 200), [220, 220, 220, 255]),
        ((128, 128), [255, 255, 253, 255]),
        ((64, 64), [108, 173, 224, 255]),
    ] {
        assert_eq!(texel(&img, x, y), want, "texel ({x}, {y}) vs libwebp's");
    }
}

/// A 4x2 checker of distinct colours, with alpha.
fn checker() -> Vec<u8> {
    (0..8u8)
        .flat_map(|i| [i * 30, 255 - i * 20, i.wrapping_mul(70), 128 + i])
        .collect()
}

#[test]
fn webp_source_is_preferred_over_the_png_fallback() {
    let dir = tempfile::tempdir().unwrap();
    let pixels = checker();
    std::fs::write(dir.path().join("logo.webp"), webp(4, 2, &pixels)).unwrap();
    // The fallback is a different (plain red) image, so the test sees which
    // one was taken.
    std::fs::write(
        dir.path().join("fallback.png"),
        png(1, 1, &[255, 0, 0, 255]),
    )
    .unwrap();
    let path = write_gltf(
        dir.path(),
        "webp.gltf",
        json!({
            "extensionsUsed": ["EXT_texture_webp"],
            "images": [{"uri": "fallback.png"}, {"uri": "logo.webp", "mimeType": "image/webp"}],
            "textures": [{"source": 0, "extensions": {"EXT_texture_webp": {"source": 1}}}],
            "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
        }),
    );
    let scene = load(&path);
    assert_eq!(scene.materials().textures[0].image, 1);
    let img = texture_pixels(&scene, 0);
    assert_eq!((img.width, img.height), (4, 2));
    assert_eq!(img.rgba8, pixels, "lossless WebP decodes bit for bit");
}

#[test]
fn required_webp_embedded_without_fallback_loads() {
    let dir = tempfile::tempdir().unwrap();
    let pixels = checker();
    let bytes = webp(4, 2, &pixels);
    let uri = format!("data:image/webp;base64,{}", scene_support::base64(&bytes));
    let path = write_gltf(
        dir.path(),
        "webp_required.gltf",
        json!({
            "extensionsUsed": ["EXT_texture_webp"],
            "extensionsRequired": ["EXT_texture_webp"],
            "images": [{"uri": uri}],
            "textures": [{"extensions": {"EXT_texture_webp": {"source": 0}}}],
            "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]
        }),
    );
    let scene = load(&path);
    assert_eq!(texture_pixels(&scene, 0).rgba8, pixels);
}

#[test]
fn a_texture_source_extension_out_of_range_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let path = write_gltf(
        dir.path(),
        "bad_webp.gltf",
        json!({
            "images": [{"uri": "x.webp"}],
            "textures": [{"extensions": {"EXT_texture_webp": {"source": 3}}}],
        }),
    );
    let msg = load_err(&path);
    for part in [
        "bad_webp.gltf",
        "texture 0.extensions.EXT_texture_webp.source",
        "image 3",
        "Fix:",
    ] {
        assert!(msg.contains(part), "{part:?} missing from: {msg}");
    }
}
