//! Texture formats beyond PNG and JPEG: EXT_texture_webp and
//! KHR_texture_basisu (KTX2 with Basis Universal, transcoded at load), each
//! decoded in preference to the texture's fallback image, and
//! EXT_texture_avif (no decoder: the fallback with a warning, or a clear
//! refusal).
//! Third-party files are read in place from the shared folder; the
//! synthetic ones are made here.

mod common;

use common::scene::ktx2::uastc_ktx2;
use common::scene::png;
use common::shared::khronos;
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
    let uri = format!("data:image/webp;base64,{}", common::scene::base64(&bytes));
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

// ---------------------------------------------------------------------------
// KHR_texture_basisu

/// Four distinct colours, with alpha, for 2x2 blocks.
const BLOCK_COLOURS: [[u8; 4]; 4] = [
    [255, 0, 0, 255],
    [0, 200, 0, 128],
    [10, 20, 250, 255],
    [90, 90, 90, 0],
];

/// What `BLOCK_COLOURS` as 2x2 blocks decode to: `w` x `h` texels (at most
/// 8x8), rows top to bottom, upside down if `flipped`.
fn block_texels(w: u32, h: u32, flipped: bool) -> Vec<u8> {
    let mut out = Vec::new();
    for y in 0..h {
        let y = if flipped { h - 1 - y } else { y };
        for x in 0..w {
            out.extend_from_slice(&BLOCK_COLOURS[(y / 4 * 2 + x / 4) as usize]);
        }
    }
    out
}

/// The image a glTF of one texture whose only image is `bytes` (a
/// KHR_texture_basisu source) decodes to.
fn ktx2_texture(dir: &Path, bytes: &[u8], name: &str) -> Arc<DecodedImage> {
    std::fs::write(dir.join(format!("{name}.ktx2")), bytes).unwrap();
    let path = write_gltf(
        dir,
        &format!("{name}.gltf"),
        json!({
            "extensionsUsed": ["KHR_texture_basisu"],
            "extensionsRequired": ["KHR_texture_basisu"],
            "images": [{"uri": format!("{name}.ktx2"), "mimeType": "image/ktx2"}],
            "textures": [{"extensions": {"KHR_texture_basisu": {"source": 0}}}],
        }),
    );
    let scene = load(&path);
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    texture_pixels(&scene, 0)
}

#[test]
fn uastc_ktx2_decodes_exactly_rows_top_to_bottom() {
    let dir = tempfile::tempdir().unwrap();
    for zstd in [false, true] {
        let bytes = uastc_ktx2(8, 8, &BLOCK_COLOURS, zstd, None);
        let img = ktx2_texture(dir.path(), &bytes, if zstd { "zstd" } else { "raw" });
        assert_eq!((img.width, img.height), (8, 8));
        assert_eq!(img.rgba8, block_texels(8, 8, false), "zstd {zstd}");
        assert_eq!(
            texel(&img, 0, 0),
            BLOCK_COLOURS[0],
            "top left is the first block"
        );
        assert_eq!(texel(&img, 7, 7), BLOCK_COLOURS[3]);
    }
    // Sizes that are not whole blocks keep only the texels inside.
    let img = ktx2_texture(
        dir.path(),
        &uastc_ktx2(6, 5, &BLOCK_COLOURS, true, Some("rd")),
        "odd",
    );
    assert_eq!((img.width, img.height), (6, 5));
    assert_eq!(img.rgba8, block_texels(6, 5, false));
}

#[test]
fn ktx2_stored_bottom_up_is_flipped_to_gltf_orientation() {
    let dir = tempfile::tempdir().unwrap();
    let img = ktx2_texture(
        dir.path(),
        &uastc_ktx2(8, 8, &BLOCK_COLOURS, false, Some("ru")),
        "ru",
    );
    assert_eq!(img.rgba8, block_texels(8, 8, true));
}

#[test]
fn ktx2_matches_its_png_twin_and_is_preferred_over_it() {
    // The PNG holds the KTX2's texels; the texture names both, and samples
    // the KTX2 (its extension source) rather than the PNG fallback, which
    // is here made different to tell them apart.
    let dir = tempfile::tempdir().unwrap();
    let pixels = block_texels(8, 8, false);
    let twin = dir.path().join("twin.png");
    std::fs::write(&twin, png(8, 8, &pixels)).unwrap();
    std::fs::write(dir.path().join("fallback.png"), png(1, 1, &[1, 2, 3, 4])).unwrap();
    std::fs::write(
        dir.path().join("t.ktx2"),
        uastc_ktx2(8, 8, &BLOCK_COLOURS, true, None),
    )
    .unwrap();
    let path = write_gltf(
        dir.path(),
        "twin.gltf",
        json!({
            "extensionsUsed": ["KHR_texture_basisu"],
            "images": [{"uri": "fallback.png"}, {"uri": "t.ktx2"}, {"uri": "twin.png"}],
            "textures": [
                {"source": 0, "extensions": {"KHR_texture_basisu": {"source": 1}}},
                {"source": 2},
            ],
        }),
    );
    let scene = load(&path);
    assert_eq!(
        texture_pixels(&scene, 0).rgba8,
        texture_pixels(&scene, 1).rgba8
    );
    assert_eq!(texture_pixels(&scene, 0).rgba8, pixels);
}

/// The decoded pixels of the image whose file is `name` in `scene`.
fn image_named(scene: &Scene, name: &str) -> Arc<DecodedImage> {
    let table = scene.materials();
    let index = table
        .images
        .iter()
        .position(|i| match &i.source {
            soupray::scene::material::ImageSource::File(p) => p.ends_with(name),
            _ => false,
        })
        .unwrap_or_else(|| panic!("no image {name}"));
    table.images[index]
        .decoded(index)
        .unwrap_or_else(|e| panic!("{e}"))
}

/// `img` against what Binomial's C++ transcoder (Basis Universal 2.x,
/// through basisu_c_sys 0.9.1) gives for the same file: its per-channel
/// means and four texels. The pure-Rust transcoder soupray uses was
/// byte-identical to it on all 23 KTX2 textures of the two lamps, so the
/// bounds are tight.
fn assert_like_reference(
    img: &DecodedImage,
    size: (u32, u32),
    mean: [f64; 4],
    texels: [[u8; 4]; 4],
) {
    assert_eq!((img.width, img.height), size);
    let (got, _) = stats(img);
    for c in 0..4 {
        assert!(
            (got[c] - mean[c]).abs() < 0.001,
            "channel {c}: mean {} vs {}",
            got[c],
            mean[c]
        );
    }
    let (w, h) = size;
    for ((x, y), want) in [(0, 0), (w / 2, h / 2), (w - 1, h - 1), (w / 4, 3 * h / 4)]
        .into_iter()
        .zip(texels)
    {
        assert_eq!(texel(img, x, y), want, "texel ({x}, {y})");
    }
}

#[test]
fn stained_glass_lamp_requires_basisu_and_transcodes_etc1s_and_uastc() {
    let Some(path) = khronos("StainedGlassLamp/glTF-KTX-BasisU/StainedGlassLamp.gltf") else {
        return;
    };
    let scene = load(&path);
    for w in scene.warnings() {
        assert!(!w.contains("decode") && !w.contains("KTX2"), "{w}");
    }
    scene
        .materials()
        .decode_used_images()
        .unwrap_or_else(|e| panic!("{e}"));
    soupray::trace::texture::HostTextures::new(scene.materials()).unwrap_or_else(|e| panic!("{e}"));
    // ETC1S under BasisLZ, opaque and with alpha, then UASTC under Zstandard.
    assert_like_reference(
        &image_named(&scene, "StainedGlassLamp_base_basecolor.ktx2"),
        (2048, 2048),
        [39.561, 35.641, 30.876, 255.0],
        [[31, 31, 31, 255]; 4],
    );
    assert_like_reference(
        &image_named(&scene, "StainedGlassLamp_grill_basecolor-alpha.ktx2"),
        (1024, 1024),
        [48.076, 39.028, 38.454, 210.233],
        [
            [46, 38, 38, 200],
            [46, 37, 37, 247],
            [46, 37, 37, 255],
            [46, 37, 37, 103],
        ],
    );
    assert_like_reference(
        &image_named(&scene, "StainedGlassLamp_glass_basecolor-alpha.ktx2"),
        (2048, 1024),
        [110.274, 87.177, 72.146, 253.038],
        [
            [64, 64, 64, 255],
            [64, 64, 64, 255],
            [64, 64, 64, 255],
            [255, 197, 190, 255],
        ],
    );
}

#[test]
fn anisotropy_barn_lamp_textures_are_used() {
    let Some(path) = khronos("AnisotropyBarnLamp/glTF-KTX2-Basisu/AnisotropyBarnLamp.gltf") else {
        return;
    };
    let scene = load(&path);
    for w in scene.warnings() {
        assert!(!w.contains("decode") && !w.contains("KTX2"), "{w}");
    }
    soupray::trace::texture::HostTextures::new(scene.materials()).unwrap_or_else(|e| panic!("{e}"));
    assert_like_reference(
        &image_named(&scene, "AnisotropyBarnLamp_basecolor.ktx2"),
        (2048, 2048),
        [191.055, 148.759, 125.826, 255.0],
        [
            [229, 166, 133, 255],
            [218, 158, 126, 255],
            [65, 63, 59, 255],
            [163, 120, 100, 255],
        ],
    );
}

// ---------------------------------------------------------------------------
// EXT_texture_avif: not decoded (see image_decode), so the fallback image
// is sampled with one warning, and a file that requires AVIF without one
// is refused with the fix.

#[test]
fn avif_required_without_fallback_is_refused_with_the_fix() {
    let Some(path) = khronos("derived/BoxTextured/glTF-AVIF-derived/BoxTextured.glb") else {
        return;
    };
    let msg = load_err(&path);
    for part in [
        "BoxTextured.glb",
        "requires EXT_texture_avif",
        "texture 0: image 0",
        "cannot decode",
        "Fix:",
        "gltf-transform",
    ] {
        assert!(msg.contains(part), "{part:?} missing from: {msg}");
    }
}

/// A glTF of two textures whose AVIF images (made here, see
/// common::scene::avif) have a PNG fallback, and a third without one.
fn avif_with_fallbacks(dir: &Path, required: bool, third: bool) -> PathBuf {
    use common::scene::avif::{bytes, GRADIENT_LOSSLESS};
    std::fs::write(dir.join("logo.avif"), bytes(GRADIENT_LOSSLESS)).unwrap();
    std::fs::write(dir.join("fallback.png"), png(4, 2, &checker())).unwrap();
    let avif = |fallback: Option<u32>| {
        let mut t = json!({"extensions": {"EXT_texture_avif": {"source": 1}}});
        if let Some(f) = fallback {
            t["source"] = f.into();
        }
        t
    };
    let mut textures = vec![avif(Some(0)), avif(Some(0))];
    if third {
        textures.push(avif(None));
    }
    let mut root = json!({
        "extensionsUsed": ["EXT_texture_avif"],
        "images": [{"uri": "fallback.png"}, {"uri": "logo.avif", "mimeType": "image/avif"}],
        "textures": textures,
    });
    if required {
        root["extensionsRequired"] = json!(["EXT_texture_avif"]);
    }
    write_gltf(dir, &format!("avif_{required}_{third}.gltf"), root)
}

#[test]
fn avif_textures_sample_their_fallback_with_one_warning() {
    let dir = tempfile::tempdir().unwrap();
    for required in [false, true] {
        let scene = load(&avif_with_fallbacks(dir.path(), required, false));
        assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
        let w = &scene.warnings()[0];
        for part in [
            "EXT_texture_avif",
            "no AVIF decoder",
            "texture 0 (AVIF image 1, fallback image 0)",
            "texture 1",
            "Fix:",
        ] {
            assert!(w.contains(part), "{part:?} missing from: {w}");
        }
        for t in 0..2 {
            assert_eq!(
                texture_pixels(&scene, t).rgba8,
                checker(),
                "texture {t} samples the PNG"
            );
        }
    }
}

#[test]
fn avif_without_fallback_renders_with_factors_or_is_refused_when_required() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&avif_with_fallbacks(dir.path(), false, true));
    let w = scene.warnings().join("\n");
    assert!(
        w.contains("cannot texture with texture 2 (AVIF image 1)"),
        "{w}"
    );
    let table = scene.materials();
    let e = table.images[1].decoded(1).err().unwrap().to_string();
    assert!(
        e.contains("image 1") && e.contains("is AVIF") && e.contains("Fix:"),
        "{e}"
    );
    let msg = load_err(&avif_with_fallbacks(dir.path(), true, true));
    assert!(
        msg.contains("requires EXT_texture_avif") && msg.contains("texture 2: image 1"),
        "{msg}"
    );
}
