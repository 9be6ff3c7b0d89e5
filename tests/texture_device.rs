//! `kernels/trace/texture.h` on the device against the Rust reference in
//! `soupray::trace::texture`: the struct layout; every wrap-mode pair with
//! both filters, sRGB and linear, on small generated images and on the real
//! textures of the test assets, at random uvs (far outside [0, 1] and
//! negative included), exact texel centres and edges, and NaN/infinite uvs;
//! the 256 sRGB bytes; KHR_texture_transform and TEXCOORD selection; a
//! texture's mean over random triangles (which weighs textured emitters);
//! and an untextured scene, which gets no buffers.
//!
//! The device and the reference perform the same float operations with FMA
//! contraction off and decode through the same table, so they agree exactly;
//! the tests allow 1e-6 so that a device with a different (but conforming)
//! rounding of `floor` inputs would still pass, and print the largest gap.

mod common;

use common::scene::asset;
use soupray::scene::material::{Filter, Wrap};
use soupray::scene::{LoadOptions, Scene, TextureTransform};
use soupray::trace::texture::*;

const TOLERANCE: f32 = 1e-6;

/// A spread of uvs for a `w` x `h` texture: random ones in [-3, 4], far ones
/// (up to ±1e6), exact texel centres and edges over three periods, and the
/// special values 0, -0, ±1, 1 ∓ ulp, NaN, ±inf and 1e30.
fn uvs(w: u32, h: u32, rng: &mut common::Rng, random: usize) -> Vec<[f32; 2]> {
    let mut out = Vec::new();
    for _ in 0..random {
        out.push([rng.f32() * 7.0 - 3.0, rng.f32() * 7.0 - 3.0]);
    }
    for _ in 0..random / 8 {
        let far = |r: &mut common::Rng| (r.f32() - 0.5) * 2e6 * r.f32() * r.f32();
        out.push([far(rng), far(rng)]);
    }
    let lines = |n: u32| {
        let n = n as i32;
        (-n..2 * n + 1).flat_map(move |i| {
            let i = i as f32;
            [(i + 0.5) / n as f32, i / n as f32]
        })
    };
    for u in lines(w) {
        out.push([u, rng.f32()]);
    }
    for v in lines(h) {
        out.push([rng.f32(), v]);
    }
    let special = [
        0.0,
        -0.0,
        1.0,
        -1.0,
        1.0 - f32::EPSILON / 2.0,
        1.0 + f32::EPSILON,
        -1e-7,
        1e-7,
        f32::NAN,
        f32::INFINITY,
        f32::NEG_INFINITY,
        1e30,
        -1e30,
    ];
    for a in special {
        for b in [0.0, 0.37, -0.6, f32::NAN] {
            out.push([a, b]);
            out.push([b, a]);
        }
    }
    out
}

/// Samples on the device and with the reference; asserts they agree and
/// returns the largest difference.
fn compare(
    set: &TextureSet,
    host: &HostTextures,
    bindings: &[TextureBinding],
    uv0: &[[f32; 2]],
    uv1: &[[f32; 2]],
    what: &str,
) -> f32 {
    let (dev_uv, dev_rgba) = set.sample_batch(bindings, uv0, uv1).unwrap();
    let mut worst = 0.0f32;
    for i in 0..bindings.len() {
        let uv = texture_uv_ref(&bindings[i], uv0[i], uv1[i]);
        let rgba = sample_texture_ref(host, &bindings[i], uv);
        // Equal values (or both NaN: NaN payloads may differ).
        let same_uv = (0..2).all(|k| {
            let (a, b) = (uv[k], dev_uv[i][k]);
            a.to_bits() == b.to_bits() || (a.is_nan() && b.is_nan())
        });
        assert!(
            same_uv,
            "{what}: sample {i}: uv device {:?}, reference {uv:?}",
            dev_uv[i]
        );
        for k in 0..4 {
            let d = (rgba[k] - dev_rgba[i][k]).abs();
            assert!(
                d <= TOLERANCE && rgba[k].is_finite() && dev_rgba[i][k].is_finite(),
                "{what}: sample {i} ({:?} at uv {:?} -> {uv:?}, binding {:?}): device {:?}, reference {rgba:?}",
                host.info[bindings[i].texture as usize],
                uv0[i],
                bindings[i],
                dev_rgba[i]
            );
            worst = worst.max(d);
        }
    }
    eprintln!(
        "{what}: {} samples, largest difference {worst:e}",
        bindings.len()
    );
    worst
}

const WRAPS: [Wrap; 3] = [Wrap::Repeat, Wrap::ClampToEdge, Wrap::MirroredRepeat];

#[test]
fn generated_images_every_wrap_pair_and_filter() {
    let d = common::device();
    let mut rng = common::Rng::new(4);
    let mut host = HostTextures::default();
    let mut per_texture = Vec::new();
    for (w, h) in [(1, 1), (3, 5), (16, 16), (2, 7)] {
        let px: Vec<u8> = (0..w * h * 4).map(|_| (rng.f32() * 256.0) as u8).collect();
        for ws in WRAPS {
            for wt in WRAPS {
                for f in [Filter::Linear, Filter::Nearest] {
                    let i = host.push_texture(w, h, &px, ws, wt, f).unwrap();
                    per_texture.push((i, w, h));
                }
            }
        }
    }
    let set = TextureSet::upload(&d, &host).unwrap();
    assert_eq!(set.texture_count(), 4 * 9 * 2);
    let (mut bindings, mut uv0, mut uv1) = (Vec::new(), Vec::new(), Vec::new());
    for &(i, w, h) in &per_texture {
        for (k, uv) in uvs(w, h, &mut rng, 120).into_iter().enumerate() {
            let srgb = k % 2 == 1;
            if k % 3 == 2 {
                // Through a random transform, from TEXCOORD_1 (TEXCOORD_0
                // holds garbage that must not be read).
                let t = TextureTransform {
                    offset: [rng.f32() * 4.0 - 2.0, rng.f32() * 4.0 - 2.0],
                    rotation: rng.f32() * 12.0 - 6.0,
                    scale: [rng.f32() * 6.0 - 3.0, rng.f32() * 6.0 - 3.0],
                    tex_coord: Some(1),
                };
                bindings.push(TextureBinding::new(i, 1, Some(&t), srgb));
                uv0.push([f32::NAN, 1e30]);
                uv1.push(uv);
            } else {
                bindings.push(TextureBinding::new(i, 0, None, srgb));
                uv0.push(uv);
                uv1.push([f32::NAN, -1e30]);
            }
        }
    }
    compare(&set, &host, &bindings, &uv0, &uv1, "generated images");
}

#[test]
fn srgb_bytes_decode_on_the_device_as_the_formula() {
    let d = common::device();
    let mut host = HostTextures::default();
    // 256x1: texel i has R = i, G = 255 - i, B = i / 2, A = i.
    let px: Vec<u8> = (0..256u32)
        .flat_map(|i| [i as u8, 255 - i as u8, (i / 2) as u8, i as u8])
        .collect();
    let t = host
        .push_texture(256, 1, &px, Wrap::Repeat, Wrap::Repeat, Filter::Nearest)
        .unwrap();
    let set = TextureSet::upload(&d, &host).unwrap();
    let centres: Vec<[f32; 2]> = (0..256).map(|i| [(i as f32 + 0.5) / 256.0, 0.5]).collect();
    for srgb in [true, false] {
        let b = vec![TextureBinding::new(t, 0, None, srgb); 256];
        let (_, got) = set.sample_batch(&b, &centres, &centres).unwrap();
        for (i, rgba) in got.iter().enumerate() {
            let c = |byte: usize| {
                let x = byte as f64 / 255.0;
                if !srgb {
                    x
                } else if x <= 0.04045 {
                    x / 12.92
                } else {
                    ((x + 0.055) / 1.055).powf(2.4)
                }
            };
            let want = [c(i), c(255 - i), c(i / 2), i as f64 / 255.0];
            for k in 0..4 {
                assert!(
                    (rgba[k] as f64 - want[k]).abs() <= 1e-7,
                    "byte {i} channel {k} (srgb {srgb}): {} vs {}",
                    rgba[k],
                    want[k]
                );
            }
        }
    }
}

#[test]
fn transform_and_texcoord_on_the_device_by_hand() {
    let d = common::device();
    let mut host = HostTextures::default();
    host.push_texture(
        1,
        1,
        &[1, 2, 3, 4],
        Wrap::Repeat,
        Wrap::Repeat,
        Filter::Linear,
    )
    .unwrap();
    let set = TextureSet::upload(&d, &host).unwrap();
    let t = |offset, rotation, scale| TextureTransform {
        offset,
        rotation,
        scale,
        tex_coord: None,
    };
    // (transform, texcoord set, uv, expected uv), expected values by hand
    // (see tests/texture_host.rs for the derivations).
    let cases = [
        (t([0.25, -0.5], 0.0, [1.0, 1.0]), 0, [0.5, 0.5], [0.75, 0.0]),
        (t([0.0, 0.0], 0.0, [2.0, 3.0]), 0, [0.5, 0.25], [1.0, 0.75]),
        (
            t([0.0, 1.0], std::f32::consts::FRAC_PI_2, [0.5, 0.5]),
            1,
            [1.0, 0.0],
            [0.0, 0.5],
        ),
        (
            t([0.1, 0.2], 0.3, [2.0, 3.0]),
            1,
            [0.5, 0.25],
            [1.276_976_6, 0.620_982_2],
        ),
    ];
    let bindings: Vec<_> = cases
        .iter()
        .map(|(tr, set, _, _)| TextureBinding::new(0, *set, Some(tr), false))
        .collect();
    // The unused set holds a different uv, so a wrong selection shows.
    let uv0: Vec<_> = cases
        .iter()
        .map(|c| if c.1 == 0 { c.2 } else { [9.0, 9.0] })
        .collect();
    let uv1: Vec<_> = cases
        .iter()
        .map(|c| if c.1 == 1 { c.2 } else { [9.0, 9.0] })
        .collect();
    let (got, rgba) = set.sample_batch(&bindings, &uv0, &uv1).unwrap();
    for (i, c) in cases.iter().enumerate() {
        assert!(
            (got[i][0] - c.3[0]).abs() < 1e-6 && (got[i][1] - c.3[1]).abs() < 1e-6,
            "case {i}: {:?} vs {:?}",
            got[i],
            c.3
        );
        // A 1x1 texture reads its one texel everywhere.
        assert_eq!(
            rgba[i],
            [1.0 / 255.0, 2.0 / 255.0, 3.0 / 255.0, 4.0 / 255.0]
        );
    }
}

/// The textures of `file`'s materials on the host and on the device, and
/// the binding of every shaded slot that has one (after checking it
/// against the host's), for `f`; nothing when the asset is absent.
fn with_asset_textures(
    file: &str,
    f: impl FnOnce(&HostTextures, &TextureSet, Vec<TextureBinding>),
) {
    let Some(path) = asset(file) else {
        return;
    };
    let d = common::device();
    let scene = Scene::load(&path, &LoadOptions::default()).unwrap();
    let table = scene.materials();
    let host = HostTextures::new(table).unwrap();
    let set = TextureSet::new(&d, table).unwrap();
    assert!(!set.is_empty(), "{file}");
    assert_eq!(set.texel_bytes(), host.texels.len() * 4);
    let mut slots = Vec::new();
    for m in &table.materials {
        for slot in Slot::SHADED {
            let b = set.slot_binding(m, slot);
            if !b.is_none() {
                assert_eq!(b, host.binding(slot.of(m).unwrap(), slot.is_srgb()));
                slots.push(b);
            }
        }
    }
    f(&host, &set, slots);
}

/// Every shaded texture of `file`, sampled through its materials' bindings.
fn real_asset(file: &str, random: usize) {
    with_asset_textures(file, |host, set, slots| {
        let mut rng = common::Rng::new(7);
        let (mut bindings, mut uv0) = (Vec::new(), Vec::new());
        for b in slots {
            let info = host.info[b.texture as usize];
            // Linear as well as the slot's own encoding.
            for srgb in [b.srgb, 1 - b.srgb] {
                for uv in uvs(info.width, info.height, &mut rng, random) {
                    bindings.push(TextureBinding { srgb, ..b });
                    uv0.push(uv);
                }
            }
        }
        assert!(!bindings.is_empty(), "{file} samples no texture");
        compare(set, host, &bindings, &uv0, &uv0.clone(), file);
    });
}

/// `texture_triangle_mean` on the device against its Rust reference, for
/// every shaded texture of `file` over `count` random triangles: most
/// within [0, 1]², some a texel or less across, some spanning several
/// periods.
fn triangle_means(file: &str, count: usize) {
    with_asset_textures(file, |host, set, slots| {
        triangle_means_of(file, host, set, &slots, count)
    });
}

fn triangle_means_of(
    file: &str,
    host: &HostTextures,
    set: &TextureSet,
    slots: &[TextureBinding],
    count: usize,
) {
    let mut rng = common::Rng::new(11);
    let (mut bindings, mut triangles) = (Vec::new(), Vec::new());
    for &b in slots {
        for i in 0..count {
            let scale = [1.0f32, 1e-3, 4.0][i % 3];
            let base = [rng.f32(), rng.f32()];
            let mut corner = || std::array::from_fn(|a| base[a] + scale * (rng.f32() - 0.5));
            let tri: ([[f32; 2]; 3], [[f32; 2]; 3]) = (
                [corner(), corner(), corner()],
                [corner(), corner(), corner()],
            );
            bindings.push(b);
            triangles.push(tri);
        }
    }
    assert!(!bindings.is_empty(), "{file} has no texture");
    let device = set.triangle_mean_batch(&bindings, &triangles).unwrap();
    let mut worst = 0.0f32;
    for i in 0..bindings.len() {
        let want = soupray::trace::texture_mean::texture_triangle_mean_ref(
            host,
            &bindings[i],
            &triangles[i],
        );
        for k in 0..4 {
            let diff = (want[k] - device[i][k]).abs();
            assert!(
                diff <= TOLERANCE,
                "{file}: triangle {i} {:?}: device {:?}, reference {want:?}",
                triangles[i],
                device[i]
            );
            worst = worst.max(diff);
        }
    }
    eprintln!(
        "{file}: {} triangle means, largest difference {worst:e}",
        bindings.len()
    );
}

#[test]
fn triangle_means_match_reference_on_real_textures() {
    triangle_means("DamagedHelmet/DamagedHelmet.glb", 600);
    triangle_means("Fox/Fox.glb", 600);
}

#[test]
fn fox_texture_matches_reference() {
    real_asset("Fox/Fox.glb", 3000);
}

#[test]
fn interpolation_test_jpeg_matches_reference() {
    real_asset("InterpolationTest/InterpolationTest.glb", 3000);
}

#[test]
fn morph_stress_test_textures_match_reference() {
    real_asset("MorphStressTest/MorphStressTest.gltf", 3000);
}

#[test]
fn untextured_scene_has_no_texture_buffers() {
    let d = common::device();
    let Some(rigged_figure_glb) = asset("RiggedFigure/RiggedFigure.glb") else {
        return;
    };
    let scene = Scene::load(&rigged_figure_glb, &LoadOptions::default()).unwrap();
    let set = TextureSet::new(&d, scene.materials()).unwrap();
    assert!(set.is_empty());
    assert!(set.info_buffer().is_none() && set.texel_buffer().is_none());
    assert_eq!((set.texture_count(), set.texel_bytes()), (0, 0));
    let m = &scene.materials().materials[0];
    assert!(set.slot_binding(m, Slot::BaseColor).is_none());
    // Sampling NONE gives the factors' identity without touching the device.
    let (_, rgba) = set
        .sample_batch(&[TextureBinding::NONE], &[[0.3, 0.3]], &[[0.0, 0.0]])
        .unwrap();
    assert_eq!(rgba, [[1.0; 4]]);
    assert_eq!(d.take_timings().unwrap().launches, 0);
}
