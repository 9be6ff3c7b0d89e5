//! The device soup (`soupray::soup::device::DeviceSoup`) against the CPU
//! reference `Scene::evaluate`: every frame of every clip of every real
//! asset, and generated scenes for what the assets lack (mirrored skins and
//! rigid mirrors, two influence sets, morphs with skins, meshes without
//! normals or uvs, a mesh instanced skinned and rigid, non-finite geometry).
//! Also the struct layouts, the compiled feature set, buffer reuse, and a
//! BVH built straight from the device soup.

mod common;

use common::scene::{asset, load, skinned_triangle, Builder};
use opencl3::memory::ClMem;
use serde_json::json;
use soupray::bvh::device_builder::DeviceBuilder;
use soupray::bvh::{validate, BuildParams};
use soupray::scene::{LoadOptions, Scene};
use soupray::soup::device::{DeviceSoup, SoupError};
use soupray::soup::Soup;

/// Clips with more frames than this are sampled evenly (ends included).
const MAX_FRAMES: i64 = 120;

/// Every frame of the scene's clip, or an even sample of them.
fn frames(scene: &Scene) -> Vec<i64> {
    let (first, last) = scene.frame_range();
    let span = last - first;
    if span < MAX_FRAMES {
        return (first..=last).collect();
    }
    (0..=MAX_FRAMES)
        .map(|s| first + span * s / MAX_FRAMES)
        .collect()
}

fn diagonal(scene: &Scene) -> f32 {
    let (lo, hi) = scene.clip_bounds().unwrap();
    (hi - lo).length()
}

/// Largest position difference, after checking everything else exactly or
/// to `normal_tol`: same triangle count and attribute presence, equal uvs
/// and material ids, normals within `normal_tol` (unit vectors).
fn compare(device: &Soup, cpu: &Soup, normal_tol: f32, what: &str) -> f32 {
    assert_eq!(
        device.triangle_count(),
        cpu.triangle_count(),
        "{what}: triangle count"
    );
    assert_eq!(device.normals.len(), cpu.normals.len(), "{what}: normals");
    assert_eq!(device.uvs.len(), cpu.uvs.len(), "{what}: uvs");
    assert_eq!(
        device.material_ids, cpu.material_ids,
        "{what}: material ids"
    );
    assert_eq!(device.uvs, cpu.uvs, "{what}: uvs differ");
    for (i, (a, b)) in device.normals.iter().zip(&cpu.normals).enumerate() {
        let e = (0..3).map(|k| (a[k] - b[k]).abs()).fold(0.0, f32::max);
        assert!(
            e <= normal_tol,
            "{what}: normal of corner {i} is {a:?}, CPU {b:?}"
        );
    }
    let mut worst = 0.0f32;
    for (i, (a, b)) in device.positions.iter().zip(&cpu.positions).enumerate() {
        assert_eq!(a[3], 0.0, "{what}: corner {i} w");
        for k in 0..3 {
            let e = (a[k] - b[k]).abs();
            assert!(!e.is_nan(), "{what}: corner {i} is {a:?}, CPU {b:?}");
            worst = worst.max(e);
        }
    }
    worst
}

/// Evaluates every frame of `scene` on the device and on the CPU and holds
/// them to 1e-5 of the scene's diagonal; returns the worst relative error.
fn check_scene(scene: &Scene, what: &str) -> f32 {
    let d = common::device();
    let mut soup = DeviceSoup::new(&d, scene).unwrap_or_else(|e| panic!("{what}: {e}"));
    assert_eq!(soup.triangle_count(), scene.triangle_count());
    let diag = diagonal(scene).max(f32::MIN_POSITIVE);
    let tol = 1e-5 * diag;
    let mut worst = 0.0f32;
    for f in frames(scene) {
        let t = scene.time_of_frame(f);
        let what = format!("{what} frame {f}");
        let info = soup
            .evaluate(scene, t)
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        let cpu = scene.evaluate(t).unwrap();
        let got = soup.read_back().unwrap();
        let err = compare(&got, &cpu.soup, 1e-5, &what);
        assert!(
            err <= tol,
            "{what}: a corner is {err} from the CPU's (tolerance {tol}, diagonal {diag})"
        );
        worst = worst.max(err / diag);
        assert_eq!(info.camera, cpu.camera, "{what}: camera");
        assert_eq!(info.lights, cpu.lights, "{what}: lights");
        assert_eq!(info.warnings, cpu.warnings, "{what}: warnings");
        assert_eq!(info.time, t);
    }
    eprintln!("{what}: worst corner error {worst:.2e} of the diagonal");
    worst
}

/// Every clip of a file.
fn check_file(rel: &str) {
    let Some(path) = asset(rel) else {
        return;
    };
    let clips = load(&path, None).clips().len().max(1);
    for c in 0..clips {
        let scene = load(&path, Some(&c.to_string()));
        check_scene(&scene, &format!("{rel} clip {c}"));
    }
}

#[test]
fn skinned_assets_match_cpu_every_frame() {
    check_file("SimpleSkin/SimpleSkin.gltf");
    check_file("RiggedSimple/RiggedSimple.glb");
    check_file("RiggedFigure/RiggedFigure.glb");
    check_file("CesiumMan/CesiumMan.gltf");
}

#[test]
fn fox_matches_cpu_every_frame_of_all_three_clips() {
    let Some(fox_glb) = asset("Fox/Fox.glb") else {
        return;
    };
    assert_eq!(load(&fox_glb, None).clips().len(), 3);
    check_file("Fox/Fox.glb");
}

#[test]
fn morph_assets_match_cpu_every_frame() {
    check_file("SimpleMorph/SimpleMorph.gltf");
    check_file("AnimatedMorphCube/AnimatedMorphCube.glb");
    check_file("MorphStressTest/MorphStressTest.gltf");
}

#[test]
fn rigid_assets_match_cpu_every_frame() {
    check_file("InterpolationTest/InterpolationTest.glb");
    check_file("AnimatedCube/AnimatedCube.gltf");
    check_file("BoxAnimated/BoxAnimated.glb");
}

#[test]
fn mirrored_skin_swaps_corners_like_the_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let path = skinned_triangle(
        dir.path(),
        json!({"scale": [-1.0, 1.0, 1.0]}),
        [100.0, 0.0, 0.0],
    );
    let scene = load(&path, None);
    let d = common::device();
    let mut soup = DeviceSoup::new(&d, &scene).unwrap();
    soup.evaluate(&scene, 0.0).unwrap();
    let got = soup.read_back().unwrap();
    let cpu = scene.evaluate(0.0).unwrap().soup;
    // The swap moved the mirror image of corner 1, (-1, 0, 0), to slot 2.
    assert_eq!(cpu.corner(0, 2), [-1.0, 0.0, 0.0]);
    assert_eq!(got.positions, cpu.positions);
    assert_eq!(compare(&got, &cpu, 0.0, "mirrored skin"), 0.0);
}

/// One scene that exercises every path at once: a skinned mesh with two
/// blended joints (animated), the same mesh placed again without a skin, a
/// mesh without normals, uvs or material placed plainly and mirrored, and a
/// morphed mesh with animated weights and morphed normals.
fn mixed_scene(dir: &std::path::Path) -> std::path::PathBuf {
    let mut b = Builder::default();
    let quad = b.floats(
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 2.0, 0.0, 0.0, 2.0, 0.0],
        3,
    );
    let quad_n = b.floats(
        &[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.6, 0.8, 0.0, 0.6, 0.8],
        3,
    );
    let quad_uv = b.floats(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0], 2);
    let quad_i = b.u32s(&[0, 1, 2, 0, 2, 3]);
    let quad_j = b.u16s(&[0, 1, 0, 0, 0, 1, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0], 4, false);
    let quad_w = b.floats(
        &[
            1.0, 0.0, 0.0, 0.0, 0.7, 0.3, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0,
        ],
        4,
    );
    let ibm = b.floats(
        &[
            [
                1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
            ],
            [
                1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, -1.0, 0.0, 1.0,
            ],
        ]
        .concat(),
        16,
    );
    let tri = b.floats(&[0.0, 0.0, 0.0, 2.0, 0.0, 0.5, 0.0, 1.5, 0.2], 3);
    let morph = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let morph_n = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], 3);
    let morph_uv = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0], 2);
    let d0 = b.floats(&[0.0, 0.0, 0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 3);
    let d0n = b.floats(&[0.5, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 3);
    let d1 = b.floats(&[0.0, 0.0, 0.0, 0.3, 0.3, 0.0, 0.0, 0.0, -0.4], 3);
    let times = b.floats(&[0.0, 0.5, 1.0], 1);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let rot = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, s, 0.0, s, 0.0, 1.0, 0.0, 0.0], 4);
    let mv = b.floats(&[0.0, 1.0, 0.0, 0.5, 1.5, 0.0, 0.0, 3.0, 1.0], 3);
    let wts = b.floats(&[0.0, 0.0, 1.0, 0.25, 0.5, 1.0], 1);
    b.write(
        json!({
            "scenes": [{"nodes": [0, 1, 3, 4, 5, 6]}],
            "nodes": [
                {"mesh": 0, "skin": 0},
                {"name": "root", "children": [2]},
                {"name": "tip", "translation": [0.0, 1.0, 0.0]},
                {"mesh": 1, "translation": [3.0, 0.0, 0.0]},
                {"mesh": 1, "scale": [-1.0, 1.0, 1.0], "translation": [-3.0, 0.0, 0.0]},
                {"mesh": 2, "translation": [0.0, 0.0, -2.0]},
                {"mesh": 0, "rotation": [0.0, 0.0, s, s], "translation": [0.0, -3.0, 0.0]}
            ],
            "skins": [{"joints": [1, 2], "inverseBindMatrices": ibm}],
            "materials": [{"name": "red"}],
            "meshes": [
                {"primitives": [{"attributes": {"POSITION": quad, "NORMAL": quad_n, "TEXCOORD_0": quad_uv,
                    "JOINTS_0": quad_j, "WEIGHTS_0": quad_w}, "indices": quad_i, "material": 0}]},
                {"primitives": [{"attributes": {"POSITION": tri}}]},
                {"weights": [0.0, 0.0], "primitives": [{"attributes": {"POSITION": morph, "NORMAL": morph_n,
                    "TEXCOORD_0": morph_uv}, "targets": [{"POSITION": d0, "NORMAL": d0n}, {"POSITION": d1}]}]}
            ],
            "animations": [{
                "channels": [
                    {"sampler": 0, "target": {"node": 1, "path": "rotation"}},
                    {"sampler": 1, "target": {"node": 2, "path": "translation"}},
                    {"sampler": 2, "target": {"node": 5, "path": "weights"}}
                ],
                "samplers": [
                    {"input": times, "output": rot},
                    {"input": times, "output": mv},
                    {"input": times, "output": wts}
                ]
            }]
        }),
        dir,
        "mixed",
        false,
    )
}

#[test]
fn mixed_generated_scene_matches_cpu_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&mixed_scene(dir.path()), None);
    assert!(scene.has_skins() && scene.has_normals() && scene.has_uvs());
    assert_eq!(scene.max_morph_targets(), 2);
    assert_eq!(scene.frame_range(), (0, 24));
    check_scene(&scene, "mixed scene");
}

#[test]
fn gpu_instances_match_cpu_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&common::scene::instanced_triangles(dir.path(), true), None);
    check_scene(&scene, "generated EXT_mesh_gpu_instancing row");
    // A skinned mesh drawn by two instances: each gets joint matrices of
    // its own.
    let path = skinned_triangle(
        dir.path(),
        json!({"translation": [0.0, 1.0, 0.0]}),
        [5.0, 0.0, 2.0],
    );
    let mut root: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let mut b = Builder::default();
    let uri = root["buffers"][0]["uri"].as_str().unwrap().to_owned();
    b.bin = common::scene::decode_data_uri(&uri);
    b.views = root["bufferViews"].as_array().unwrap().clone();
    b.accessors = root["accessors"].as_array().unwrap().clone();
    let t = b.floats(&[0.0, 0.0, 0.0, 0.0, 3.0, 10.0], 3);
    root["nodes"][0]["extensions"] =
        json!({"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": t}}});
    let scene = load(&b.write(root, dir.path(), "skinned_instanced", true), None);
    assert_eq!(scene.triangle_count(), 2);
    check_scene(&scene, "instanced skinned triangle");
    if let Some(path) = common::shared::khronos("SimpleInstancing/glTF-Binary/SimpleInstancing.glb")
    {
        check_scene(&load(&path, None), "SimpleInstancing");
    }
}

#[test]
fn second_influence_set_matches_cpu() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let j0 = b.u8s(&[0; 12], 4, false);
    let w0 = b.u8s(&[64, 0, 0, 0, 64, 0, 0, 0, 200, 0, 0, 0], 4, true);
    let j1 = b.u16s(&[1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0], 4, false);
    let w1 = b.u8s(&[64, 0, 0, 0, 128, 0, 0, 0, 10, 0, 0, 0], 4, true);
    let times = b.floats(&[0.0, 1.0], 1);
    let mv = b.floats(&[1.0, 0.0, 4.0, 1.0, 2.0, -1.0], 3);
    let path = b.write(
        json!({
            "scenes": [{"nodes": [0, 1, 2]}],
            "nodes": [{"mesh": 0, "skin": 0}, {"name": "j0"}, {"name": "j1", "translation": [1.0, 0.0, 4.0]}],
            "skins": [{"joints": [1, 2]}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos,
                "JOINTS_0": j0, "WEIGHTS_0": w0, "JOINTS_1": j1, "WEIGHTS_1": w1}}]}],
            "animations": [{"channels": [{"sampler": 0, "target": {"node": 2, "path": "translation"}}],
                            "samplers": [{"input": times, "output": mv}]}]
        }),
        dir.path(),
        "two_sets",
        true,
    );
    let scene = load(&path, None);
    assert_eq!(scene.max_influence_sets(), 2);
    let d = common::device();
    let soup = DeviceSoup::new(&d, &scene).unwrap();
    assert!(soup.build_options().contains("-D INFLUENCE_SETS=2"));
    drop(soup);
    check_scene(&scene, "two influence sets");
}

#[test]
fn compiled_defines_follow_the_scene_features() {
    let Some(morph_stress_test_gltf) = asset("MorphStressTest/MorphStressTest.gltf") else {
        return;
    };
    let d = common::device();
    // Rigid only: no skinning, no morphing.
    let Some(box_animated_glb) = asset("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    let scene = load(&box_animated_glb, None);
    let soup = DeviceSoup::new(&d, &scene).unwrap();
    let o = soup.build_options();
    assert!(!o.contains("HAS_SKIN"), "{o}");
    assert!(o.contains("-D MORPH_TARGETS=0"), "{o}");
    assert!(o.contains("-D INFLUENCE_SETS=0"), "{o}");
    assert_eq!(o.contains("HAS_NORMALS"), scene.has_normals(), "{o}");
    assert_eq!(o.contains("HAS_UVS"), scene.has_uvs(), "{o}");
    assert!(!o.contains("SANITIZE"), "{o}");

    // Morphs without skins.
    let scene = load(&morph_stress_test_gltf, None);
    let soup = DeviceSoup::new(&d, &scene).unwrap();
    let o = soup.build_options();
    assert!(!o.contains("HAS_SKIN"), "{o}");
    assert!(
        o.contains(&format!("-D MORPH_TARGETS={}", scene.max_morph_targets())),
        "{o}"
    );
    assert_eq!(scene.max_morph_targets(), 8);

    // A skin, one influence set, no morphs; sanitize only when asked.
    let opts = LoadOptions {
        sanitize: true,
        ..Default::default()
    };
    let Some(cesium_man_gltf) = asset("CesiumMan/CesiumMan.gltf") else {
        return;
    };
    let scene = Scene::load(&cesium_man_gltf, &opts).unwrap();
    let soup = DeviceSoup::new(&d, &scene).unwrap();
    let o = soup.build_options();
    assert!(o.contains("-D HAS_SKIN=1"), "{o}");
    assert!(o.contains("-D INFLUENCE_SETS=1"), "{o}");
    assert!(o.contains("-D MORPH_TARGETS=0"), "{o}");
    assert!(
        o.contains("-D HAS_NORMALS=1") && o.contains("-D HAS_UVS=1"),
        "{o}"
    );
    assert!(o.contains("-D SANITIZE=1"), "{o}");
}

#[test]
fn buffers_are_allocated_once_and_reused_every_frame() {
    let d = common::device();
    let Some(cesium_man_gltf) = asset("CesiumMan/CesiumMan.gltf") else {
        return;
    };
    let scene = load(&cesium_man_gltf, None);
    let mut soup = DeviceSoup::new(&d, &scene).unwrap();
    let allocations = soup.allocations();
    assert!(allocations > 0);
    let handles = |s: &DeviceSoup| {
        (
            s.positions().get(),
            s.normals().map(|b| b.get()),
            s.uvs().map(|b| b.get()),
            s.material_ids().get(),
        )
    };
    let before = handles(&soup);
    let mut previous: Option<Soup> = None;
    for f in [0, 10, 20, 30] {
        let info = soup.evaluate(&scene, scene.time_of_frame(f)).unwrap();
        assert!(!info.reused, "frame {f} has a new pose");
        assert_eq!(soup.allocations(), allocations, "frame {f} allocated");
        assert_eq!(handles(&soup), before, "frame {f} replaced a buffer");
        let now = soup.read_back().unwrap();
        if let Some(p) = &previous {
            assert_ne!(p.positions, now.positions, "frame {f} did not move");
        }
        previous = Some(now);
    }
}

#[test]
fn an_unchanged_pose_keeps_the_soup_without_launching() {
    let d = common::device();
    let Some(cesium_man_gltf) = asset("CesiumMan/CesiumMan.gltf") else {
        return;
    };
    let scene = load(&cesium_man_gltf, None);
    let mut soup = DeviceSoup::new(&d, &scene).unwrap();
    d.take_timings().unwrap();
    // Past the end of the clip every sample clamps to the last key.
    let end = scene.duration();
    assert!(!soup.evaluate(&scene, end + 1.0).unwrap().reused);
    let launched = d.take_timings().unwrap().launches;
    assert_eq!(launched, 2, "deform and assemble");
    let info = soup.evaluate(&scene, end + 2.0).unwrap();
    assert!(info.reused);
    assert_eq!(d.take_timings().unwrap().launches, 0);
    let cpu = scene.evaluate(end + 2.0).unwrap();
    let got = soup.read_back().unwrap();
    let err = compare(&got, &cpu.soup, 1e-5, "reused pose");
    assert!(err <= 1e-5 * diagonal(&scene));
    assert_eq!(info.camera, cpu.camera);
}

#[test]
fn bvh_built_from_the_device_soup_validates() {
    let d = common::device();
    let Some(fox_glb) = asset("Fox/Fox.glb") else {
        return;
    };
    let scene = load(&fox_glb, Some("Run"));
    let mut soup = DeviceSoup::new(&d, &scene).unwrap();
    let params = BuildParams::default();
    let mut builder = DeviceBuilder::new(&d, params).unwrap();
    for f in [0, 9, 17] {
        soup.evaluate(&scene, scene.time_of_frame(f)).unwrap();
        let (bvh, _) = builder
            .build_from_device(soup.positions(), soup.triangle_count())
            .unwrap();
        let host = soup.read_back().unwrap();
        let shape = validate(&bvh, &host, params.leaf_size)
            .unwrap_or_else(|e| panic!("Fox Run frame {f}: {e}"));
        let root = bvh.root_bounds();
        let (lo, hi) = host.bounds().unwrap();
        assert_eq!(
            (root.lo, root.hi),
            (lo, hi),
            "frame {f}: root box is the soup's bounds"
        );
        assert!(
            shape.max_depth > 1 && shape.leaves > 1,
            "frame {f}: {shape:?}"
        );
    }
}

/// A triangle whose node scale overflows f32 once applied.
fn overflowing_scene(dir: &std::path::Path) -> std::path::PathBuf {
    let mut b = Builder::default();
    let ok = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let big = b.floats(&[0.0, 0.0, 0.0, 1e30, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    b.write(
        json!({
            "scenes": [{"nodes": [0, 1]}],
            "nodes": [{"mesh": 0}, {"name": "huge", "mesh": 1, "scale": [1e30, 1.0, 1.0]}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": ok}}]},
                       {"name": "blown", "primitives": [{"attributes": {"POSITION": ok}}, {"attributes": {"POSITION": big}}]}]
        }),
        dir,
        "overflow",
        true,
    )
}

#[test]
fn non_finite_corners_fail_with_the_cpu_message_or_collapse_when_sanitized() {
    let dir = tempfile::tempdir().unwrap();
    let path = overflowing_scene(dir.path());
    let d = common::device();
    let scene = load(&path, None);
    let cpu = scene.evaluate(0.0).unwrap_err().to_string();
    let mut soup = DeviceSoup::new(&d, &scene).unwrap();
    let err = soup.evaluate(&scene, 0.0).unwrap_err();
    assert!(matches!(err, SoupError::Scene(_)), "{err}");
    assert_eq!(err.to_string(), cpu);
    assert!(cpu.contains("mesh 1 \"blown\" primitive 1"), "{cpu}");

    let opts = LoadOptions {
        sanitize: true,
        ..Default::default()
    };
    let scene = Scene::load(&path, &opts).unwrap();
    let mut soup = DeviceSoup::new(&d, &scene).unwrap();
    let info = soup.evaluate(&scene, 0.0).unwrap();
    assert_eq!(info.warnings.len(), 1, "{:?}", info.warnings);
    assert!(
        info.warnings[0].contains("collapsed 1 triangle"),
        "{:?}",
        info.warnings
    );
    let got = soup.read_back().unwrap();
    assert_eq!(got.triangle_count(), 3);
    assert!(got
        .positions
        .iter()
        .all(|p| p.iter().all(|c| c.is_finite())));
    // The finite triangles are the CPU's, which dropped the bad one.
    let cpu = scene.evaluate(0.0).unwrap().soup;
    assert_eq!(cpu.triangle_count(), 2);
    assert_eq!(got.positions[..6], cpu.positions[..]);
    // The bad one is a point: zero area, no NaN for the BVH builder.
    assert_eq!(got.positions[6], got.positions[7]);
    assert_eq!(got.positions[7], got.positions[8]);
}

#[test]
fn another_scene_is_refused() {
    let d = common::device();
    let Some(box_animated_glb) = asset("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    let a = load(&box_animated_glb, None);
    let Some(cesium_man_gltf) = asset("CesiumMan/CesiumMan.gltf") else {
        return;
    };
    let b = load(&cesium_man_gltf, None);
    let mut soup = DeviceSoup::new(&d, &a).unwrap();
    let err = soup.evaluate(&b, 0.0).unwrap_err();
    assert!(matches!(err, SoupError::WrongScene { .. }), "{err}");
}
