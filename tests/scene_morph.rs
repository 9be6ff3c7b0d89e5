//! Morph targets: SimpleMorph by hand, AnimatedMorphCube and every clip of
//! MorphStressTest against the independent reference, and the precedence
//! of mesh.weights, node.weights and the animation.

mod common;

use common::scene::{assert_soup_matches, asset, load, Builder, Raw};
use serde_json::json;

#[test]
fn simple_morph_by_hand() {
    let Some(simple_morph_gltf) = asset("SimpleMorph/SimpleMorph.gltf") else {
        return;
    };
    let scene = load(&simple_morph_gltf, None);
    assert_eq!(scene.max_morph_targets(), 2);
    // Weight keys at t = 0..4: (0,0), (0,1), (1,1), (1,0), (0,0).
    // At t = 1.5: (0.5, 1). Vertex 2 = (0.5, 0.5, 0) + 0.5 * (-1, 1, 0)
    // + 1 * (1, 1, 0) = (1, 2, 0); vertices 0 and 1 have zero deltas.
    let frame = scene.evaluate(1.5).unwrap();
    assert_eq!(scene.pose(1.5).morph_weights[0], vec![0.5, 1.0]);
    assert_eq!(frame.soup.corner(0, 2), [1.0, 2.0, 0.0]);
    assert_eq!(frame.soup.corner(0, 0), [0.0, 0.0, 0.0]);
    assert_eq!(frame.soup.corner(0, 1), [1.0, 0.0, 0.0]);
    // At t = 3.25: (0.75, 0): (0.5, 0.5) + 0.75 * (-1, 1) = (-0.25, 1.25).
    assert_eq!(
        scene.evaluate(3.25).unwrap().soup.corner(0, 2),
        [-0.25, 1.25, 0.0]
    );
}

#[test]
fn animated_morph_cube_matches_reference() {
    let Some(file) = asset("AnimatedMorphCube/AnimatedMorphCube.glb") else {
        return;
    };
    let scene = load(&file, None);
    let raw = Raw::open(&file);
    for f in [0, 30, 61, 101] {
        let t = scene.time_of_frame(f);
        let frame = scene.evaluate(t).unwrap();
        assert_soup_matches(
            &frame.soup,
            &raw.soup(Some(0), t),
            1e-5,
            &format!("AnimatedMorphCube frame {f}"),
        );
    }
}

#[test]
fn morph_stress_test_matches_reference_in_every_clip() {
    let Some(file) = asset("MorphStressTest/MorphStressTest.gltf") else {
        return;
    };
    let raw = Raw::open(&file);
    for (clip, frames) in [
        ("Individuals", [17, 100, 225]),
        ("TheWave", [5, 24, 48]),
        ("Pulse", [11, 70, 153]),
    ] {
        let scene = load(&file, Some(clip));
        assert_eq!(scene.max_morph_targets(), 8);
        let anim = raw.animation_index(clip);
        for f in frames {
            let t = scene.time_of_frame(f);
            let ours = &scene.pose(t).morph_weights[0];
            let theirs = &raw.sample(anim, t)[0].2;
            for (a, b) in ours.iter().zip(theirs) {
                assert!(
                    (*a as f64 - b).abs() < 1e-6,
                    "{clip} frame {f}: weights {ours:?} vs {theirs:?}"
                );
            }
            let frame = scene.evaluate(t).unwrap();
            assert_soup_matches(
                &frame.soup,
                &raw.soup(Some(anim), t),
                1e-5,
                &format!("{clip} frame {f}"),
            );
        }
    }
}

fn weighted_triangle(
    dir: &std::path::Path,
    node_weights: Option<f32>,
    animated: Option<[f32; 2]>,
) -> soupray::scene::Scene {
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let delta = b.floats(&[0.0, 0.0, 4.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 3);
    let mut node = json!({"mesh": 0});
    if let Some(w) = node_weights {
        node["weights"] = json!([w]);
    }
    let mut root = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [node],
        "meshes": [{"weights": [0.25], "primitives": [{"attributes": {"POSITION": pos}, "targets": [{"POSITION": delta}]}]}],
    });
    if let Some(keys) = animated {
        let times = b.floats(&[0.0, 1.0], 1);
        let values = b.floats(&keys, 1);
        root["animations"] = json!([{"channels": [{"sampler": 0, "target": {"node": 0, "path": "weights"}}],
            "samplers": [{"input": times, "output": values}]}]);
    }
    let path = b.write(root, dir, "weights", true);
    load(&path, None)
}

#[test]
fn weights_default_to_mesh_then_node_and_the_animation_overrides_both() {
    let dir = tempfile::tempdir().unwrap();
    // Only mesh.weights (0.25): z = 4 * 0.25.
    let z = |s: &soupray::scene::Scene, t: f64| s.evaluate(t).unwrap().soup.corner(0, 0)[2];
    assert_eq!(z(&weighted_triangle(dir.path(), None, None), 0.0), 1.0);
    // node.weights (0.5) wins over mesh.weights.
    assert_eq!(z(&weighted_triangle(dir.path(), Some(0.5), None), 0.0), 2.0);
    // The animation (0.75 at t = 0 to 0.25 at t = 1) wins over both.
    let s = weighted_triangle(dir.path(), Some(0.5), Some([0.75, 0.25]));
    assert_eq!(z(&s, 0.0), 3.0);
    assert_eq!(z(&s, 1.0), 1.0);
    assert_eq!(z(&s, 0.25), 2.5);
}
