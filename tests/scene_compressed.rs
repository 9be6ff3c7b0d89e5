//! Quantized and compressed geometry (KHR_mesh_quantization,
//! EXT_meshopt_compression, KHR_draco_mesh_compression): each file must
//! load into the soup of its plain twin, within the precision its encoder
//! kept, and a small synthetic file per feature tests it without the
//! shared folder.

mod scene_support;

use scene_support::{load, shared::khronos, Builder};
use serde_json::json;

/// The largest distance between corresponding corners of two soups with
/// the same triangles in the same order.
fn max_corner_distance(a: &soupray::soup::Soup, b: &soupray::soup::Soup, what: &str) -> f64 {
    assert_eq!(
        a.triangle_count(),
        b.triangle_count(),
        "{what}: triangle count"
    );
    let mut worst = 0.0f64;
    for t in 0..a.triangle_count() {
        for k in 0..3 {
            let (p, q) = (a.corner(t, k), b.corner(t, k));
            let d = (0..3)
                .map(|i| (p[i] as f64 - q[i] as f64).powi(2))
                .sum::<f64>()
                .sqrt();
            worst = worst.max(d);
        }
    }
    worst
}

fn scale_of(node: &serde_json::Value) -> f64 {
    let s = &node["scale"];
    assert!(
        s[0] == s[1] && s[1] == s[2],
        "the bound below assumes uniform node scales"
    );
    s[0].as_f64().unwrap()
}

#[test]
fn quantized_animated_morph_cube_matches_its_float_twin() {
    let (Some(quantized), Some(plain)) = (
        khronos("AnimatedMorphCube/glTF-Quantized/AnimatedMorphCube.gltf"),
        khronos("AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb"),
    ) else {
        return;
    };
    let json: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&quantized).unwrap()).unwrap();
    // World length of one integer step of the positions and deltas: the
    // mesh node's dequantization scale times its parent's scale (rotations
    // keep lengths).
    let step = scale_of(&json["nodes"][0]) * scale_of(&json["nodes"][1]);
    // Largest morph delta per target, in steps, from the accessors' min/max.
    let delta_steps: Vec<f64> = json["meshes"][0]["primitives"][0]["targets"]
        .as_array()
        .unwrap()
        .iter()
        .map(|t| {
            let acc = &json["accessors"][t["POSITION"].as_u64().unwrap() as usize];
            (0..3)
                .map(|i| {
                    let m = acc["min"][i]
                        .as_f64()
                        .unwrap()
                        .abs()
                        .max(acc["max"][i].as_f64().unwrap().abs());
                    m * m
                })
                .sum::<f64>()
                .sqrt()
        })
        .collect();
    let quantized_scene = load(&quantized, None);
    let plain_scene = load(&plain, None);
    for f in [0, 17, 30, 61, 88, 101] {
        let t = plain_scene.time_of_frame(f);
        let weights = &quantized_scene.pose(t).morph_weights[0];
        // Rounding to the nearest step moves each component of the base
        // position and of each weighted delta by at most half a step; the
        // weights are normalized UNSIGNED_BYTE, so each is off by at most
        // 0.5/255 times its delta. Plus f32 rounding of the world positions.
        let weight_sum: f64 = weights.iter().map(|&w| w.abs() as f64).sum();
        let bound = step * (3f64.sqrt() / 2.0 * (1.0 + weight_sum))
            + step * delta_steps.iter().map(|d| 0.5 / 255.0 * d).sum::<f64>()
            + 1e-5;
        let a = quantized_scene.evaluate(t).unwrap().soup;
        let b = plain_scene.evaluate(t).unwrap().soup;
        let d = max_corner_distance(&a, &b, &format!("frame {f}"));
        eprintln!("quantized AnimatedMorphCube frame {f}: max corner distance {d:.3e} (bound {bound:.3e}, step {step:.3e})");
        assert!(
            d <= bound,
            "frame {f}: a corner is {d} away from the float twin's, more than the quantization bound {bound}"
        );
    }
}

/// A triangle stored the way KHR_mesh_quantization allows: SHORT positions
/// dequantized by the node's scale and translation, BYTE normalized normals
/// and morph deltas, UNSIGNED_SHORT unnormalized texture coordinates.
fn quantized_triangle(
    dir: &std::path::Path,
    declare_extension: bool,
    with_uv: bool,
) -> std::path::PathBuf {
    let mut b = Builder::default();
    let pos = b.i16s(&[0, 0, 0, 1000, 0, 0, 0, -2000, 0], 3, false);
    let positions = &mut b.accessors[pos];
    positions["min"] = json!([0, -2000, 0]);
    positions["max"] = json!([1000, 0, 0]);
    let nrm = b.i8s(&[0, 0, 127, 0, 0, 127, 0, -128, 0], 3, true);
    let uv = b.u16s(&[0, 0, 3, 0, 0, 7], 2, false);
    // A normalized BYTE delta of -1 step in z.
    let delta = b.i8s(&[0, 0, 0, 0, 0, 0, 0, 0, -127], 3, true);
    let mut root = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0, "scale": [0.001, 0.001, 0.001], "translation": [1.0, 2.0, 3.0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv},
                                     "targets": [{"POSITION": delta}]}],
                    "weights": [0.5]}]
    });
    if !with_uv {
        let attributes = &mut root["meshes"][0]["primitives"][0]["attributes"];
        attributes.as_object_mut().unwrap().remove("TEXCOORD_0");
    }
    if declare_extension {
        root["extensionsUsed"] = json!(["KHR_mesh_quantization"]);
        root["extensionsRequired"] = json!(["KHR_mesh_quantization"]);
    }
    b.write(root, dir, "quantized", true)
}

#[test]
fn synthetic_quantized_triangle_dequantizes_through_the_node_transform() {
    let dir = tempfile::tempdir().unwrap();
    let scene = load(&quantized_triangle(dir.path(), true, true), None);
    let prim = &scene.meshes()[0].primitives[0];
    // Unnormalized integers are read as their values...
    assert_eq!(prim.positions[1].to_array(), [1000.0, 0.0, 0.0]);
    assert_eq!(prim.positions[2].to_array(), [0.0, -2000.0, 0.0]);
    assert_eq!(prim.uvs.as_ref().unwrap()[2], [0.0, 7.0]);
    // ...normalized ones by max(c / 127, -1): -128 clamps to -1.
    let normals = prim.normals.as_ref().unwrap();
    assert_eq!(normals[0].to_array(), [0.0, 0.0, 1.0]);
    assert_eq!(normals[2].to_array(), [0.0, -1.0, 0.0]);
    assert_eq!(
        prim.targets[0].positions.as_ref().unwrap()[2].to_array(),
        [0.0, 0.0, -1.0]
    );
    // The node transform carries the dequantization: 0.001 per step, then
    // the translation; the morph delta (weight 0.5) moves corner 2 by
    // -0.5 step in z.
    let soup = scene.evaluate(0.0).unwrap().soup;
    let expect = [[1.0, 2.0, 3.0], [2.0, 2.0, 3.0], [1.0, 0.0, 2.9995]];
    for (k, e) in expect.iter().enumerate() {
        let p = soup.corner(0, k);
        for i in 0..3 {
            assert!(
                (p[i] - e[i]).abs() < 1e-6,
                "corner {k} is {p:?}, expected {e:?}"
            );
        }
    }
}

#[test]
fn integer_positions_without_the_quantization_extension_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let refusal = |with_uv: bool| {
        let path = quantized_triangle(dir.path(), false, with_uv);
        match soupray::scene::Scene::load(&path, &Default::default()) {
            Ok(_) => panic!("integer attributes without KHR_mesh_quantization must be refused"),
            Err(e) => e.to_string(),
        }
    };
    let err = refusal(false);
    assert!(err.contains("POSITION"), "{err}");
    assert!(err.contains("SHORT"), "{err}");
    assert!(err.contains("KHR_mesh_quantization"), "{err}");
    assert!(err.contains("extensionsUsed"), "{err}");
    // Unnormalized texture coordinates are refused by the JSON checks
    // first, naming the extension that would allow them.
    let err = refusal(true);
    assert!(err.contains("TEXCOORD_0"), "{err}");
    assert!(err.contains("KHR_mesh_quantization"), "{err}");
}
