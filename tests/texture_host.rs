//! The host side of the texture stage, without a device: sRGB decoding
//! against the standard formula and the kernel's table, KHR_texture_transform
//! composition against hand-computed values, the reference sampler's wrap
//! and filter rules on tiny hand-made images, how a material table becomes
//! records and bindings (only sampled slots decoded, images shared, sRGB per
//! binding), and the errors for missing, corrupt and unsupported inputs.

mod common;

use common::scene::asset;
use serde_json::{json, Value};
use soupray::kernels::KERNEL_SOURCES;
use soupray::scene::material::{Filter, Wrap};
use soupray::scene::{LoadOptions, MaterialTable, Scene, TextureRef, TextureTransform};
use soupray::trace::texture::*;
use std::f32::consts::FRAC_PI_2;
use std::path::Path;

fn materials_of(path: &Path) -> Scene {
    Scene::load(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

fn table(scene: &Scene) -> &MaterialTable {
    scene.materials()
}

/// Writes `rgba` as a PNG.
fn png(path: &Path, w: u32, h: u32, rgba: &[u8]) {
    image::RgbaImage::from_raw(w, h, rgba.to_vec())
        .unwrap()
        .save(path)
        .unwrap();
}

/// A glTF with no meshes, only `root`'s materials, textures, samplers and
/// images (written into `dir` as `name`).
fn write_gltf(dir: &Path, name: &str, mut root: Value) -> std::path::PathBuf {
    root["asset"] = json!({"version": "2.0"});
    root["scenes"] = json!([{"nodes": []}]);
    root["scene"] = json!(0);
    let path = dir.join(name);
    std::fs::write(&path, serde_json::to_string_pretty(&root).unwrap()).unwrap();
    path
}

// ---------------------------------------------------------------------------
// sRGB

#[test]
fn srgb_decode_matches_the_standard_formula() {
    // IEC 61966-2-1, by hand: 0 -> 0; the linear segment up to 0.04045
    // (c / 12.92 = 0.0031308049...); 0.5 -> ((0.5 + 0.055) / 1.055)^2.4 =
    // 0.2140411404...; 1 -> 1.
    assert_eq!(srgb_to_linear(0.0), 0.0);
    assert!((srgb_to_linear(0.04045) - 0.003_130_805).abs() < 1e-9);
    assert!((srgb_to_linear(0.5) - 0.214_041_14).abs() < 1e-7);
    assert_eq!(srgb_to_linear(1.0), 1.0);
    // The two branches meet at the boundary (continuity to 1e-7).
    let below = srgb_to_linear(0.04045);
    let above = srgb_to_linear(0.040_450_004);
    assert!(above >= below && above - below < 1e-7, "{below} {above}");
    assert_eq!(srgb_to_linear(0.04), 0.04 / 12.92);
}

#[test]
fn decode_table_is_the_formula_at_every_byte() {
    let t = decode_table();
    for i in 0..256 {
        let c = i as f64 / 255.0;
        // Independent f64 evaluation of the standard formula.
        let lin = if c <= 0.04045 {
            c / 12.92
        } else {
            ((c + 0.055) / 1.055).powf(2.4)
        };
        let err = (t[256 + i] as f64 - lin).abs();
        assert!(
            err <= lin * 6e-8 + 1e-12,
            "sRGB byte {i}: {} vs {lin}",
            t[256 + i]
        );
        assert_eq!(t[i], i as f32 / 255.0, "linear byte {i}");
    }
    assert_eq!(t[255], 1.0);
    assert_eq!(t[511], 1.0);
    // Bytes 10 and 11 straddle 0.04045 (10/255 = 0.0392, 11/255 = 0.0431).
    assert_eq!(t[256 + 10], ((10.0f64 / 255.0) / 12.92) as f32);
    assert!(t[256 + 11] > t[256 + 10]);
}

#[test]
fn kernel_decode_table_equals_the_rust_table_bit_for_bit() {
    let header = KERNEL_SOURCES
        .iter()
        .find(|(n, _)| *n == "texture.h")
        .unwrap()
        .1;
    let start = header.find("TEXTURE_DECODE[512] = {").unwrap();
    let body = &header[start..];
    let body = &body[body.find('{').unwrap() + 1..body.find("};").unwrap()];
    let values: Vec<f32> = body
        .lines()
        .map(|l| l.split("//").next().unwrap())
        .flat_map(|l| l.split(','))
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(|s| s.trim_end_matches('f').parse::<f32>().unwrap())
        .collect();
    assert_eq!(values.len(), 512);
    for (i, (k, r)) in values.iter().zip(decode_table()).enumerate() {
        assert_eq!(k.to_bits(), r.to_bits(), "entry {i}: kernel {k}, Rust {r}");
    }
}

// ---------------------------------------------------------------------------
// KHR_texture_transform

fn apply(t: &TextureTransform, uv: [f32; 2]) -> [f32; 2] {
    let b = TextureBinding::new(0, 0, Some(t), false);
    texture_uv_ref(&b, uv, [f32::NAN; 2])
}

fn close(a: [f32; 2], b: [f32; 2]) -> bool {
    (a[0] - b[0]).abs() < 1e-6 && (a[1] - b[1]).abs() < 1e-6
}

fn tt(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> TextureTransform {
    TextureTransform {
        offset,
        rotation,
        scale,
        tex_coord: None,
    }
}

#[test]
fn transform_offset_rotation_scale_by_hand() {
    // Offset alone: a shift, exactly.
    let t = tt([0.25, -0.5], 0.0, [1.0, 1.0]);
    assert_eq!(apply(&t, [0.5, 0.5]), [0.75, 0.0]);
    assert_eq!(transform_matrix(Some(&t)), [1.0, 0.0, 0.25, 0.0, 1.0, -0.5]);
    // Scale alone.
    let t = tt([0.0, 0.0], 0.0, [2.0, 3.0]);
    assert_eq!(apply(&t, [0.5, 0.25]), [1.0, 0.75]);
    // Rotation by +90°: counter-clockwise in uv space, where v points down
    // (u' = cos u + sin v, v' = -sin u + cos v): (1, 0) -> (0, -1),
    // (0, 1) -> (1, 0).
    let t = tt([0.0, 0.0], FRAC_PI_2, [1.0, 1.0]);
    assert!(close(apply(&t, [1.0, 0.0]), [0.0, -1.0]));
    assert!(close(apply(&t, [0.0, 1.0]), [1.0, 0.0]));
    // All three: offset (0.1, 0.2), rotation 0.3, scale (2, 3) at (0.5, 0.25):
    // cos 0.3 = 0.955336489, sin 0.3 = 0.295520207;
    // u' = 0.955336489 * 2 * 0.5 + 0.295520207 * 3 * 0.25 + 0.1 = 1.276976644
    // v' = -0.295520207 * 2 * 0.5 + 0.955336489 * 3 * 0.25 + 0.2 = 0.620982160
    let t = tt([0.1, 0.2], 0.3, [2.0, 3.0]);
    let got = apply(&t, [0.5, 0.25]);
    assert!(close(got, [1.276_976_6, 0.620_982_2]), "{got:?}");
    // No extension: the identity, exactly.
    let b = TextureBinding::new(0, 0, None, false);
    assert_eq!(texture_uv_ref(&b, [0.3, -7.5], [9.0, 9.0]), [0.3, -7.5]);
}

#[test]
fn transform_matches_the_extension_example() {
    // KHR_texture_transform's example: offset (0, 1), rotation pi/2, scale
    // 0.5 "utilizes only the lower left quadrant of the source image, rotated
    // clockwise 90°": the unit square lands on u in [0, 0.5], v in [0.5, 1].
    let t = tt([0.0, 1.0], std::f64::consts::FRAC_PI_2 as f32, [0.5, 0.5]);
    assert!(close(apply(&t, [0.0, 0.0]), [0.0, 1.0]));
    assert!(close(apply(&t, [1.0, 0.0]), [0.0, 0.5]));
    assert!(close(apply(&t, [0.0, 1.0]), [0.5, 1.0]));
    assert!(close(apply(&t, [1.0, 1.0]), [0.5, 0.5]));
    // Its second example flips v: offset (0, 1), scale (1, -1).
    let t = tt([0.0, 1.0], 0.0, [1.0, -1.0]);
    assert_eq!(apply(&t, [0.25, 0.25]), [0.25, 0.75]);
}

#[test]
fn binding_selects_its_texcoord_set() {
    let b = TextureBinding::new(0, 1, None, false);
    assert_eq!(texture_uv_ref(&b, [0.1, 0.2], [0.7, 0.8]), [0.7, 0.8]);
    let b = TextureBinding::new(0, 0, None, false);
    assert_eq!(texture_uv_ref(&b, [0.1, 0.2], [0.7, 0.8]), [0.1, 0.2]);
}

// ---------------------------------------------------------------------------
// The reference sampler on hand-made images

/// A 3x1 texture whose red channel is 0, 90, 180 and alpha 255.
fn strip(wrap: Wrap, filter: Filter) -> (HostTextures, TextureBinding) {
    let mut h = HostTextures::default();
    let px = [0u8, 0, 0, 255, 90, 0, 0, 255, 180, 0, 0, 255];
    let i = h.push_texture(3, 1, &px, wrap, wrap, filter).unwrap();
    (h, TextureBinding::new(i, 0, None, false))
}

fn red(h: &HostTextures, b: &TextureBinding, u: f32) -> f32 {
    sample_texture_ref(h, b, [u, 0.5])[0]
}

#[test]
fn reference_sampler_wraps_and_filters_by_hand() {
    let t = decode_table();
    let (h, b) = strip(Wrap::ClampToEdge, Filter::Linear);
    assert_eq!(red(&h, &b, 0.5 / 3.0), 0.0); // texel centre
    assert_eq!(red(&h, &b, 1.5 / 3.0), t[90]);
    assert_eq!(red(&h, &b, 1.0 / 3.0), t[90] * 0.5); // edge: halfway
    assert_eq!(red(&h, &b, 0.0), 0.0); // clamped to texel 0
    assert_eq!(red(&h, &b, -5.0), 0.0);
    assert_eq!(red(&h, &b, 7.0), t[180]);
    let (h, b) = strip(Wrap::Repeat, Filter::Linear);
    // u = 0 lies between texel 2 (wrapped) and texel 0.
    assert_eq!(red(&h, &b, 0.0), t[180] * 0.5);
    assert_eq!(red(&h, &b, 4.0 + 1.5 / 3.0), t[90]);
    assert_eq!(red(&h, &b, -1.0 + 1.5 / 3.0), t[90]);
    let (h, b) = strip(Wrap::MirroredRepeat, Filter::Linear);
    // Texel -1 mirrors to texel 0; period 2 reverses the second copy.
    assert_eq!(red(&h, &b, 0.0), 0.0);
    assert_eq!(red(&h, &b, 1.0 + 0.5 / 3.0), t[180]);
    assert_eq!(red(&h, &b, -0.5 / 3.0), 0.0);
    assert_eq!(red(&h, &b, 2.0 + 1.5 / 3.0), t[90]);
    let (h, b) = strip(Wrap::Repeat, Filter::Nearest);
    assert_eq!(red(&h, &b, 0.999), t[180]);
    assert_eq!(red(&h, &b, 1.0), 0.0);
    assert_eq!(red(&h, &b, -0.001), t[180]);
    // NaN and infinite uvs read as 0.
    assert_eq!(red(&h, &b, f32::NAN), 0.0);
    assert_eq!(red(&h, &b, f32::INFINITY), 0.0);
    // sRGB decodes RGB before filtering, never alpha.
    let mut b = b;
    b.srgb = 1;
    let s = sample_texture_ref(&h, &b, [1.5 / 3.0, 0.5]);
    assert_eq!(s, [t[256 + 90], 0.0, 0.0, 1.0]);
    // No texture: the factor's identity.
    assert_eq!(
        sample_texture_ref(&h, &TextureBinding::NONE, [0.2, 0.2]),
        [1.0; 4]
    );
}

// ---------------------------------------------------------------------------
// Material tables

/// 3x5 and 2x2 images, two samplers, five textures (image 0 shared by
/// textures 0 and 1; texture 3 unused; texture 4 only as occlusion).
fn two_material_gltf(dir: &Path) -> std::path::PathBuf {
    let a: Vec<u8> = (0..15 * 4).map(|i| (i * 17 % 256) as u8).collect();
    let b: Vec<u8> = (0..4 * 4).map(|i| (255 - i * 13) as u8).collect();
    png(&dir.join("a.png"), 3, 5, &a);
    png(&dir.join("b.png"), 2, 2, &b);
    write_gltf(
        dir,
        "textured.gltf",
        json!({
            "extensionsUsed": ["KHR_texture_transform"],
            "images": [{"uri": "a.png", "name": "A"}, {"uri": "b.png"}],
            "samplers": [
                {"wrapS": 33071, "wrapT": 33648, "magFilter": 9728},
                {}
            ],
            "textures": [
                {"source": 0, "sampler": 0},
                {"source": 0, "sampler": 1},
                {"source": 1, "sampler": 1},
                {"source": 1},
                {"source": 1}
            ],
            "materials": [
                {"name": "first", "pbrMetallicRoughness": {
                    "baseColorTexture": {"index": 0, "texCoord": 0, "extensions": {
                        "KHR_texture_transform": {"offset": [0.25, -0.5], "rotation": 0.3,
                                                   "scale": [2.0, 3.0], "texCoord": 1}}},
                    "metallicRoughnessTexture": {"index": 1}}},
                {"emissiveTexture": {"index": 2, "texCoord": 1},
                 "normalTexture": {"index": 0},
                 "occlusionTexture": {"index": 4}}
            ]
        }),
    )
}

#[test]
fn material_table_becomes_records_and_bindings() {
    let dir = tempfile::tempdir().unwrap();
    let scene = materials_of(&two_material_gltf(dir.path()));
    let h = HostTextures::new(table(&scene)).unwrap();
    // Textures 0, 1, 2 are sampled; 3 is unused and 4 is occlusion only.
    assert_eq!(h.record_of_texture, [0, 1, 2, TEXTURE_NONE, TEXTURE_NONE]);
    assert_eq!(
        h.info,
        [
            TextureInfo {
                offset: 0,
                width: 3,
                height: 5,
                wrap_s: TEXTURE_WRAP_CLAMP_TO_EDGE,
                wrap_t: TEXTURE_WRAP_MIRRORED_REPEAT,
                filter: TEXTURE_FILTER_NEAREST
            },
            // The same image: the same texels.
            TextureInfo {
                offset: 0,
                width: 3,
                height: 5,
                wrap_s: TEXTURE_WRAP_REPEAT,
                wrap_t: TEXTURE_WRAP_REPEAT,
                filter: TEXTURE_FILTER_LINEAR
            },
            TextureInfo {
                offset: 15,
                width: 2,
                height: 2,
                wrap_s: TEXTURE_WRAP_REPEAT,
                wrap_t: TEXTURE_WRAP_REPEAT,
                filter: TEXTURE_FILTER_LINEAR
            },
        ]
    );
    assert_eq!(h.texels.len(), 15 + 4);
    assert_eq!(h.texels[0], u32::from_le_bytes([0, 17, 34, 51]));
    assert_eq!(h.texels[15], u32::from_le_bytes([255, 242, 229, 216]));

    let m = &table(&scene).materials;
    let base = h.binding(m[0].base_color_texture.as_ref().unwrap(), true);
    assert_eq!((base.texture, base.tex_coord, base.srgb), (0, 1, 1)); // texCoord override
    let (s, c) = 0.3f32.sin_cos();
    assert_eq!(
        base.transform,
        [c * 2.0, s * 3.0, 0.25, -s * 2.0, c * 3.0, -0.5]
    );
    let mr = h.binding(m[0].metallic_roughness_texture.as_ref().unwrap(), false);
    assert_eq!((mr.texture, mr.tex_coord, mr.srgb), (1, 0, 0));
    let emissive = h.binding(m[1].emissive_texture.as_ref().unwrap(), true);
    assert_eq!(
        (emissive.texture, emissive.tex_coord, emissive.srgb),
        (2, 1, 1)
    );
    // Texture 0 again, now as a normal map: linear in this binding only.
    let normal = h.binding(m[1].normal_texture.as_ref().unwrap(), false);
    assert_eq!((normal.texture, normal.srgb), (0, 0));
    assert_eq!(normal.transform, [1.0, 0.0, 0.0, 0.0, 1.0, 0.0]);
    // Occlusion was not uploaded: its binding is NONE.
    assert!(h
        .binding(m[1].occlusion_texture.as_ref().unwrap(), false)
        .is_none());
    // Asking for every slot adds texture 4 (sharing image 1's texels).
    let all = HostTextures::with_slots(table(&scene), &Slot::ALL).unwrap();
    assert_eq!(all.info.len(), 4);
    assert_eq!(all.info[3].offset, 15);
    assert_eq!(all.texels.len(), 19);
}

#[test]
fn untextured_tables_give_an_empty_set() {
    for a in [
        "RiggedFigure/RiggedFigure.glb",
        "AnimatedMorphCube/AnimatedMorphCube.glb",
    ] {
        let Some(path) = asset(a) else {
            return;
        };
        let scene = materials_of(&path);
        let h = HostTextures::new(table(&scene)).unwrap();
        assert!(h.is_empty() && h.texels.is_empty(), "{a}");
    }
    let h = HostTextures::new(&MaterialTable::default()).unwrap();
    assert!(h.is_empty());
    let r = TextureRef {
        texture: 0,
        tex_coord: 0,
        transform: None,
    };
    assert!(h.binding(&r, true).is_none());
}

#[test]
fn a_missing_image_names_the_file_and_the_image() {
    // The original in a temporary copy without CesiumMan_img0.jpg.
    let Some((_dir, cesium_man_gltf)) =
        common::shared::sample_without("CesiumMan/CesiumMan.gltf", &["CesiumMan_img0.jpg"])
    else {
        return;
    };
    let scene = materials_of(&cesium_man_gltf);
    let msg = HostTextures::new(table(&scene)).unwrap_err().to_string();
    for part in [
        "CesiumMan.gltf",
        "image 0",
        "CesiumMan_img0.jpg",
        "Fix:",
        "baseColorTexture of material 0",
    ] {
        assert!(msg.contains(part), "{part:?} missing from: {msg}");
    }
}

#[test]
fn only_sampled_slots_are_decoded() {
    // MorphStressTest in a temporary copy without its occlusion map
    // Base_AO.png: the shaded slots load, asking for occlusion names the
    // missing image.
    let Some((_dir, morph_stress_test_gltf)) =
        common::shared::sample_without("MorphStressTest/MorphStressTest.gltf", &["Base_AO.png"])
    else {
        return;
    };
    let scene = materials_of(&morph_stress_test_gltf);
    let h = HostTextures::new(table(&scene)).unwrap();
    assert_eq!(h.info.len(), 2);
    assert_eq!(h.texels.len(), 2 * 64 * 64);
    let msg = HostTextures::with_slots(table(&scene), &Slot::ALL)
        .unwrap_err()
        .to_string();
    for part in [
        "MorphStressTest.gltf",
        "image 0 \"Base_AO\"",
        "Base_AO.png",
        "occlusionTexture of material 0 \"Base\"",
    ] {
        assert!(msg.contains(part), "{part:?} missing from: {msg}");
    }
}

#[test]
fn a_corrupt_image_names_the_file_and_the_image() {
    let dir = tempfile::tempdir().unwrap();
    png(&dir.path().join("good.png"), 1, 1, &[1, 2, 3, 4]);
    std::fs::write(
        dir.path().join("broken.png"),
        b"\x89PNG\r\n\x1a\nnot really",
    )
    .unwrap();
    let path = write_gltf(
        dir.path(),
        "corrupt.gltf",
        json!({
            "images": [{"uri": "good.png"}, {"uri": "broken.png"}],
            "textures": [{"source": 0}, {"source": 1}],
            "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}},
                          {"name": "bad", "emissiveTexture": {"index": 1}}]
        }),
    );
    let scene = materials_of(&path);
    let msg = HostTextures::new(table(&scene)).unwrap_err().to_string();
    for part in [
        "corrupt.gltf",
        "image 1",
        "cannot be decoded",
        "Fix:",
        "emissiveTexture of material 1 \"bad\"",
    ] {
        assert!(msg.contains(part), "{part:?} missing from: {msg}");
    }
}

#[test]
fn a_second_uv_set_other_than_one_is_carried_in_the_second_slot() {
    let dir = tempfile::tempdir().unwrap();
    png(&dir.path().join("t.png"), 1, 1, &[1, 2, 3, 4]);
    let path = write_gltf(
        dir.path(),
        "uv2.gltf",
        json!({
            "images": [{"uri": "t.png"}],
            "textures": [{"source": 0}],
            "materials": [{"name": "m", "normalTexture": {"index": 0, "texCoord": 2},
                           "emissiveTexture": {"index": 0}}]
        }),
    );
    let scene = materials_of(&path);
    // TEXCOORD_2 is the one set besides 0: the soup's slot 1 carries it.
    assert_eq!(scene.second_uv_set(), Some(2));
    let m = &table(&scene).materials[0];
    assert_eq!(m.normal_texture.as_ref().unwrap().tex_coord, 1);
    assert_eq!(m.emissive_texture.as_ref().unwrap().tex_coord, 0);
    HostTextures::new(table(&scene)).unwrap();
}

#[test]
fn two_uv_sets_besides_the_first_keep_the_lowest_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    png(&dir.path().join("t.png"), 1, 1, &[1, 2, 3, 4]);
    let path = write_gltf(
        dir.path(),
        "uv12.gltf",
        json!({
            "images": [{"uri": "t.png"}],
            "textures": [{"source": 0}],
            "materials": [{"name": "m", "normalTexture": {"index": 0, "texCoord": 3},
                           "emissiveTexture": {"index": 0, "texCoord": 1}}]
        }),
    );
    let scene = materials_of(&path);
    assert_eq!(scene.second_uv_set(), Some(1));
    let m = &table(&scene).materials[0];
    assert_eq!(m.emissive_texture.as_ref().unwrap().tex_coord, 1);
    assert_eq!(m.normal_texture.as_ref().unwrap().tex_coord, 0);
    assert!(
        scene
            .warnings()
            .iter()
            .any(|w| w.contains("TEXCOORD_3") && w.contains("read with TEXCOORD_0")),
        "{:?}",
        scene.warnings()
    );
}
