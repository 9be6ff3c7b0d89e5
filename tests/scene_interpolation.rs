//! Animation sampling checked against values worked out by hand from the
//! keyframes stored in InterpolationTest.glb (read with the tests' own
//! reader), for every interpolation mode, plus small generated files for
//! what the asset lacks: the slerp short-path trap and CUBICSPLINE weights.

mod common;

use common::scene::{asset, instance_triangles, load, Builder, Raw};
use glam::{Quat, Vec3};
use serde_json::json;

const FILE: &str = "InterpolationTest/InterpolationTest.glb";

/// (times, flat values) of the only channel of the named animation.
fn keys(raw: &Raw, anim: &str) -> (Vec<f64>, Vec<Vec<f64>>) {
    let a = &raw.json["animations"][raw.animation_index(anim)];
    let s = &a["samplers"][0];
    let times = raw
        .accessor(s["input"].as_u64().unwrap() as usize)
        .into_iter()
        .map(|v| v[0])
        .collect();
    (times, raw.accessor(s["output"].as_u64().unwrap() as usize))
}

fn node_named(scene: &soupray::scene::Scene, name: &str) -> usize {
    scene
        .nodes()
        .iter()
        .position(|n| n.name.as_deref() == Some(name))
        .unwrap()
}

fn close(a: f32, b: f64, tol: f64, what: &str) {
    assert!((a as f64 - b).abs() <= tol, "{what}: got {a}, expected {b}");
}

/// Same rotation (q and -q are equal rotations).
fn same_rotation(q: Quat, expected: [f64; 4], tol: f64, what: &str) {
    let d = q.x as f64 * expected[0]
        + q.y as f64 * expected[1]
        + q.z as f64 * expected[2]
        + q.w as f64 * expected[3];
    assert!(
        d.abs() >= 1.0 - tol,
        "{what}: got {q:?}, expected ±{expected:?}"
    );
}

#[test]
fn step_holds_the_previous_key_and_clamps() {
    let Some(file) = asset(FILE) else {
        return;
    };
    let raw = Raw::open(&file);
    let (t, v) = keys(&raw, "Step Scale");
    // The file's values: 1, 0.5, 1, 0.5, 1 (uniform scales).
    assert_eq!(
        v.iter().map(|s| s[0]).collect::<Vec<_>>(),
        vec![1.0, 0.5, 1.0, 0.5, 1.0]
    );
    let scene = load(&file, Some("Step Scale"));
    let node = node_named(&scene, "Cube");
    let scale_at = |time: f64| scene.pose(time).local[node].scale;
    // Before the first key (t0 = 1/24): clamped to the first value.
    assert_eq!(scale_at(0.0), Vec3::splat(1.0));
    // Between keys 0 and 1, and just before key 1: still key 0's value.
    assert_eq!(scale_at((t[0] + t[1]) / 2.0), Vec3::splat(1.0));
    assert_eq!(scale_at(t[1] - 1e-4), Vec3::splat(1.0));
    // At key 1 exactly and after it: key 1's value.
    assert_eq!(scale_at(t[1]), Vec3::splat(0.5));
    assert_eq!(scale_at((t[1] + t[2]) / 2.0), Vec3::splat(0.5));
    // After the last key: clamped to the last value.
    assert_eq!(scale_at(100.0), Vec3::splat(1.0));
}

#[test]
fn linear_scale_is_a_straight_blend() {
    let Some(file) = asset(FILE) else {
        return;
    };
    let raw = Raw::open(&file);
    let (t, _) = keys(&raw, "Linear Scale");
    let scene = load(&file, Some("Linear Scale"));
    let node = node_named(&scene, "Cube.001");
    // Key 0 = 1, key 1 = 0.5: a quarter of the way is 0.875, halfway 0.75.
    let s = scene.pose(t[0] + 0.25 * (t[1] - t[0])).local[node].scale;
    close(s.x, 0.875, 1e-5, "quarter");
    let s = scene.pose((t[1] + t[2]) / 2.0).local[node].scale;
    close(s.y, 0.75, 1e-5, "half between key 1 (0.5) and key 2 (1)");
}

#[test]
fn cubic_spline_scale_with_flat_tangents() {
    let Some(file) = asset(FILE) else {
        return;
    };
    let raw = Raw::open(&file);
    let (t, v) = keys(&raw, "CubicSpline Scale");
    // [in, value, out] per key; the file's tangents are all zero.
    assert_eq!(v.len(), 3 * t.len());
    assert!(v
        .iter()
        .enumerate()
        .all(|(i, e)| i % 3 == 1 || e.iter().all(|x| *x == 0.0)));
    let scene = load(&file, Some("CubicSpline Scale"));
    let node = node_named(&scene, "Cube.002");
    // Hermite with zero tangents: p = h00 * 1 + h01 * 0.5 where at s = 1/4
    // h00 = 2/64 - 3/16 + 1 = 0.84375 and h01 = 0.15625: 0.921875.
    let s = scene.pose(t[0] + 0.25 * (t[1] - t[0])).local[node].scale;
    close(s.z, 0.921875, 1e-5, "s = 1/4");
    let s = scene.pose((t[0] + t[1]) / 2.0).local[node].scale;
    close(s.z, 0.75, 1e-5, "s = 1/2");
}

#[test]
fn cubic_spline_rotation_scales_tangents_by_the_interval_and_normalises() {
    let Some(file) = asset(FILE) else {
        return;
    };
    let raw = Raw::open(&file);
    let (t, v) = keys(&raw, "CubicSpline Rotation");
    let scene = load(&file, Some("CubicSpline Rotation"));
    let node = node_named(&scene, "Cube.004");
    // Between keys 1 and 2 at s = 1/2: h00 = h01 = 1/2, h10 = dt/8,
    // h11 = -dt/8, with v1 = v[4], out-tangent b1 = v[5], in-tangent
    // a2 = v[6], v2 = v[7]; then normalised.
    let dt = t[2] - t[1];
    let p: Vec<f64> = (0..4)
        .map(|i| 0.5 * v[4][i] + dt / 8.0 * v[5][i] + 0.5 * v[7][i] - dt / 8.0 * v[6][i])
        .collect();
    let len = p.iter().map(|x| x * x).sum::<f64>().sqrt();
    let expected = [p[0] / len, p[1] / len, p[2] / len, p[3] / len];
    let q = scene.pose((t[1] + t[2]) / 2.0).local[node].rotation;
    same_rotation(q, expected, 1e-6, "cubic rotation");
    assert!((q.length() - 1.0).abs() < 1e-6);
    // (This asset's tangents barely change the result once normalised;
    // `cubic_spline_weights_use_in_value_out_per_target` is the test that
    // fails if tangents are not scaled by the interval.)
}

#[test]
fn linear_rotation_slerps_at_constant_angular_speed() {
    let Some(file) = asset(FILE) else {
        return;
    };
    let raw = Raw::open(&file);
    let (t, v) = keys(&raw, "Linear Rotation");
    let scene = load(&file, Some("Linear Rotation"));
    let node = node_named(&scene, "Cube.005");
    // Keys 3 and 4 are turns about z by -135 and -180 degrees; halfway is
    // -157.5 degrees: q = (0, 0, -sin 78.75, cos 78.75).
    assert!((v[3][2] + (67.5f64).to_radians().sin()).abs() < 1e-4 && v[4][2] == -1.0);
    let half = 78.75f64.to_radians();
    let q = scene.pose((t[3] + t[4]) / 2.0).local[node].rotation;
    same_rotation(
        q,
        [0.0, 0.0, -half.sin(), half.cos()],
        1e-6,
        "slerp midpoint",
    );
    // A quarter of the way from key 0 (identity) to key 1 (-45 degrees):
    // -11.25 degrees, which plain lerp + normalise would miss slightly.
    let quarter = (11.25f64 / 2.0).to_radians();
    let q = scene.pose(t[0] + 0.25 * (t[1] - t[0])).local[node].rotation;
    same_rotation(
        q,
        [0.0, 0.0, -quarter.sin(), quarter.cos()],
        1e-7,
        "slerp quarter",
    );
}

#[test]
fn translations_and_the_soup_agree() {
    let Some(file) = asset(FILE) else {
        return;
    };
    let raw = Raw::open(&file);
    let (t, v) = keys(&raw, "Linear Translation");
    let scene = load(&file, Some("Linear Translation"));
    let node = node_named(&scene, "Cube.009");
    let time = t[1] + 0.3 * (t[2] - t[1]);
    let expected: Vec<f64> = (0..3)
        .map(|i| v[1][i] + 0.3 * (v[2][i] - v[1][i]))
        .collect();
    let frame = scene.evaluate(time).unwrap();
    // The cube mesh spans [-1, 1]^3 with no rotation or scale on the node,
    // so its soup triangles are centred on the node's translation.
    let tris = instance_triangles(&scene, node);
    let mut lo = [f32::INFINITY; 3];
    let mut hi = [f32::NEG_INFINITY; 3];
    for tri in tris {
        for k in 0..3 {
            let p = frame.soup.corner(tri, k);
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
    }
    for a in 0..3 {
        close((lo[a] + hi[a]) / 2.0, expected[a], 1e-4, "centre");
        close(hi[a] - lo[a], 2.0, 1e-4, "size");
    }

    let (t, v) = keys(&raw, "Step Translation");
    let scene = load(&file, Some("Step Translation"));
    let node = node_named(&scene, "Cube.006");
    let p = scene.pose(t[2] + 0.9 * (t[3] - t[2])).local[node].translation;
    close(p.y, v[2][1], 0.0, "step translation");
}

#[test]
fn clips_are_chosen_by_name_or_index_and_never_blended() {
    let Some(file) = asset(FILE) else {
        return;
    };
    let by_name = load(&file, Some("Linear Scale"));
    let by_index = load(&file, Some("1"));
    assert_eq!(by_name.active_clip().unwrap().index, 1);
    assert_eq!(by_index.active_clip().unwrap().index, 1);
    // With "Step Scale" active, the node animated by "Linear Scale" keeps
    // its rest pose from the file.
    let raw = Raw::open(&file);
    let scene = load(&file, Some("Step Scale"));
    let other = node_named(&scene, "Cube.001");
    let rest = &raw.json["nodes"][other]["translation"];
    let pose = scene.pose(0.5);
    assert_eq!(pose.local[other].scale, Vec3::ONE);
    assert_eq!(
        pose.local[other].translation.x as f64,
        rest[0].as_f64().unwrap()
    );
    // Default is clip 0.
    assert_eq!(load(&file, None).active_clip().unwrap().index, 0);
}

#[test]
fn frame_range_covers_the_clip() {
    let Some(file) = asset(FILE) else {
        return;
    };
    // "Step Rotation" lasts 1.708333 s = 41 frames at 24 fps;
    // "Linear Scale" 1.666667 s = 40 frames.
    let scene = load(&file, Some("Step Rotation"));
    assert_eq!(scene.frame_range(), (0, 41));
    assert_eq!(load(&file, Some("Linear Scale")).frame_range(), (0, 40));
    let opts = soupray::scene::LoadOptions {
        animation: Some("Linear Scale".into()),
        fps: 30.0,
        ..Default::default()
    };
    let scene = soupray::scene::Scene::load(&file, &opts).unwrap();
    // 1.666667 * 30 = 50.00001: still 50 frames, not 51.
    assert_eq!(scene.frame_range(), (0, 50));
    assert_eq!(scene.time_of_frame(15), 0.5);
}

/// One triangle on a node whose rotation is animated from `q0` to `q1`.
fn rotating_triangle(dir: &std::path::Path, q0: [f32; 4], q1: [f32; 4]) -> std::path::PathBuf {
    let mut b = Builder::default();
    let pos = b.floats(&[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0], 3);
    let times = b.floats(&[0.0, 1.0], 1);
    let rots = b.floats(&[q0, q1].concat(), 4);
    b.write(
        json!({
            "scene": 0, "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
            "animations": [{"channels": [{"sampler": 0, "target": {"node": 0, "path": "rotation"}}],
                            "samplers": [{"input": times, "output": rots, "interpolation": "LINEAR"}]}]
        }),
        dir,
        "slerp",
        true,
    )
}

#[test]
fn slerp_between_q_and_nearly_minus_q_takes_the_short_path() {
    let dir = tempfile::tempdir().unwrap();
    // q0: 10 degrees about z. q1: 20 degrees about z, stored negated, so the
    // two are almost opposite 4-vectors though the rotations differ by 10
    // degrees. Halfway must be 15 degrees; the long way round would pass
    // through about 195 degrees.
    let h = |deg: f32| (deg.to_radians() / 2.0).sin_cos();
    let (s10, c10) = h(10.0);
    let (s20, c20) = h(20.0);
    let path = rotating_triangle(dir.path(), [0.0, 0.0, s10, c10], [0.0, 0.0, -s20, -c20]);
    let scene = load(&path, None);
    let frame = scene.evaluate(0.5).unwrap();
    let p = frame.soup.corner(0, 0);
    let a = 15f32.to_radians();
    assert!(
        (p[0] - a.cos()).abs() < 1e-5 && (p[1] - a.sin()).abs() < 1e-5,
        "{p:?}"
    );
    // And a quarter of the way: 12.5 degrees.
    let q = scene.pose(0.25).local[0].rotation;
    let (axis, angle) = q.to_axis_angle();
    assert!(
        (angle.to_degrees() - 12.5).abs() < 1e-3 || (angle.to_degrees() - 347.5).abs() < 1e-3,
        "{axis} {angle}"
    );
}

#[test]
fn cubic_spline_weights_use_in_value_out_per_target() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let d0 = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], 3);
    let d1 = b.floats(&[1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 3);
    let times = b.floats(&[0.0, 2.0], 1);
    // Per key: in-tangents (t0, t1), values (t0, t1), out-tangents (t0, t1).
    let out = b.floats(
        &[
            9.0, 9.0, /* values */ 0.0, 1.0, /* out */ 1.0, 0.0, // key 0
            0.0, -1.0, /* values */ 1.0, 0.0, /* out */ 9.0, 9.0, // key 1
        ],
        1,
    );
    let path = b.write(
        json!({
            "scenes": [{"nodes": [0]}],
            "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "targets": [{"POSITION": d0}, {"POSITION": d1}]}]}],
            "animations": [{"channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}],
                            "samplers": [{"input": times, "output": out, "interpolation": "CUBICSPLINE"}]}]
        }),
        dir.path(),
        "cubic_weights",
        false,
    );
    let scene = load(&path, None);
    // At t = 1 (s = 1/2, dt = 2): h00 = h01 = 1/2, h10 = 2/8, h11 = -2/8.
    // Target 0: 0.5*0 + 0.25*1 + 0.5*1 - 0.25*0 = 0.75.
    // Target 1: 0.5*1 + 0.25*0 + 0.5*0 - 0.25*(-1) = 0.75.
    let w = &scene.pose(1.0).morph_weights[0];
    assert!(
        (w[0] - 0.75).abs() < 1e-6 && (w[1] - 0.75).abs() < 1e-6,
        "{w:?}"
    );
    // Vertex 0 = (0,0,0) + 0.75*(0,0,1) + 0.75*(1,0,0).
    let p = scene.evaluate(1.0).unwrap().soup.corner(0, 0);
    assert!(
        (p[0] - 0.75).abs() < 1e-6 && (p[2] - 0.75).abs() < 1e-6,
        "{p:?}"
    );
}
