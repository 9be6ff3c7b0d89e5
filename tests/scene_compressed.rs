//! Quantized and compressed geometry (KHR_mesh_quantization,
//! EXT_meshopt_compression, KHR_draco_mesh_compression): each file must
//! load into the soup of its plain twin, within the precision its encoder
//! kept, and a small synthetic file per feature tests it without the
//! shared folder.

mod common;

use common::scene::{load, shared::khronos, Builder};
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
    let s: Vec<f64> = (0..3).map(|i| node["scale"][i].as_f64().unwrap()).collect();
    assert!(
        (s[0] - s[1]).abs() <= 1e-6 * s[0] && (s[1] - s[2]).abs() <= 1e-6 * s[0],
        "the bounds assume uniform node scales, not {s:?}"
    );
    s[0].max(s[1]).max(s[2])
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

/// For every triangle of `a`, the distance (largest corner distance, over
/// the three rotations of its corners) to the nearest triangle of `b`; the
/// largest such distance. For encoders that reorder triangles and vertices.
fn max_matched_distance(a: &soupray::soup::Soup, b: &soupray::soup::Soup) -> f64 {
    let tri = |s: &soupray::soup::Soup, t: usize| -> [[f64; 3]; 3] {
        std::array::from_fn(|k| s.corner(t, k).map(f64::from))
    };
    let dist = |p: [f64; 3], q: [f64; 3]| -> f64 {
        ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2) + (p[2] - q[2]).powi(2)).sqrt()
    };
    let theirs: Vec<[[f64; 3]; 3]> = (0..b.triangle_count()).map(|t| tri(b, t)).collect();
    let mut worst = 0.0f64;
    for t in 0..a.triangle_count() {
        let mine = tri(a, t);
        let mut best = f64::INFINITY;
        for other in &theirs {
            for r in 0..3 {
                let d = (0..3)
                    .map(|k| dist(mine[k], other[(k + r) % 3]))
                    .fold(0.0, f64::max);
                best = best.min(d);
            }
        }
        worst = worst.max(best);
    }
    worst
}

/// Both directions of [`max_matched_distance`]: every triangle of each soup
/// has a close one in the other.
fn soup_set_distance(a: &soupray::soup::Soup, b: &soupray::soup::Soup, what: &str) -> f64 {
    assert_eq!(
        a.triangle_count(),
        b.triangle_count(),
        "{what}: triangle count"
    );
    max_matched_distance(a, b).max(max_matched_distance(b, a))
}

/// A compressed file's soup against its plain twin's at `frames`, matched
/// as triangle sets (decoders may reorder them), each within `bound`; and
/// frame `moved` against frame 0, which must differ by far more, so the
/// comparison can tell frames apart.
fn assert_skinned_twin(
    compressed: &soupray::scene::Scene,
    plain: &soupray::scene::Scene,
    frames: &[i64],
    moved: i64,
    bound: f64,
    what: &str,
) {
    for &f in frames {
        let t = plain.time_of_frame(f);
        let a = compressed.evaluate(t).unwrap().soup;
        let b = plain.evaluate(t).unwrap().soup;
        let d = soup_set_distance(&a, &b, &format!("frame {f}"));
        eprintln!("{what} frame {f}: max matched distance {d:.3e} (bound {bound:.3e})");
        assert!(
            d <= bound,
            "frame {f}: a triangle is {d} from the plain twin's nearest, more than {bound}"
        );
    }
    let off = soup_set_distance(
        &compressed
            .evaluate(plain.time_of_frame(moved))
            .unwrap()
            .soup,
        &plain.evaluate(plain.time_of_frame(0)).unwrap().soup,
        &format!("frames {moved} and 0"),
    );
    assert!(
        off > 10.0 * bound,
        "the comparison cannot tell frames apart ({off})"
    );
}

#[test]
fn meshopt_cesium_man_matches_its_plain_twin_while_skinned() {
    let (Some(compressed), Some(plain)) = (
        khronos("derived/CesiumMan/glTF-Meshopt-derived/CesiumMan.glb"),
        khronos("CesiumMan/glTF-Binary/CesiumMan.glb"),
    ) else {
        return;
    };
    let compressed_scene = load(&compressed, None);
    let plain_scene = load(&plain, None);
    // The encoder (gltfpack's defaults) keeps 14-bit positions (8e-5 of
    // this 1.5-unit figure per corner), 8-bit skin weights and 12-bit
    // quaternions: a rotation off by up to 2^-12 rad per joint, along
    // chains of up to six joints with the mesh up to 0.5 units from the
    // joint, moves a corner by up to 6 * 0.5 * 2^-12 = 7.3e-4 at the end of
    // a chain; the 8-bit weights add up to 0.5/255 of the distance between
    // two joints' placements of a vertex near a bend (a few centimetres).
    // 3e-3 (0.2% of the figure's height) covers their sum with margin; the
    // largest measured is 1.6e-3. A wrong decode (or a wrong frame, checked
    // last) is off by far more.
    let bound = 3e-3;
    assert_skinned_twin(
        &compressed_scene,
        &plain_scene,
        &[0, 9, 20, 33, 48],
        20,
        bound,
        "meshopt CesiumMan",
    );
}

#[test]
fn meshopt_animated_morph_cube_matches_its_plain_twin() {
    let (Some(compressed), Some(plain)) = (
        khronos("derived/AnimatedMorphCube/glTF-Meshopt-derived/AnimatedMorphCube.glb"),
        khronos("AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb"),
    ) else {
        return;
    };
    let json = glb_json(&compressed);
    // Normalized SHORT positions over [-s, s], s the node's (uniform)
    // scale, on the encoder's (gltfpack's default) 14-bit grid: a step of
    // 2s / (2^14 - 1) world units. Rounding moves each component of the
    // base position and of each weighted delta (deltas share the grid) by
    // at most half a step. The weights are floats here; plus f32 rounding.
    let step = 2.0 * scale_of(&json["nodes"][0]) / f64::from((1 << 14) - 1);
    let compressed_scene = load(&compressed, None);
    let plain_scene = load(&plain, None);
    for f in [0, 17, 30, 61, 88, 101] {
        let t = plain_scene.time_of_frame(f);
        let weight_sum: f64 = compressed_scene.pose(t).morph_weights[0]
            .iter()
            .map(|&w| w.abs() as f64)
            .sum();
        let bound = 3f64.sqrt() / 2.0 * step * (1.0 + weight_sum) + 1e-5;
        let a = compressed_scene.evaluate(t).unwrap().soup;
        let b = plain_scene.evaluate(t).unwrap().soup;
        // The encoder reordered the vertices: match triangles as sets.
        let d = soup_set_distance(&a, &b, &format!("frame {f}"));
        eprintln!(
            "meshopt AnimatedMorphCube frame {f}: max matched distance {d:.3e} (bound {bound:.3e})"
        );
        assert!(
            d <= bound,
            "frame {f}: a triangle is {d} from the plain twin's nearest, more than {bound}"
        );
    }
}

/// The JSON chunk of a .glb.
fn glb_json(path: &std::path::Path) -> serde_json::Value {
    let bytes = std::fs::read(path).unwrap();
    let len = u32::from_le_bytes(bytes[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&bytes[20..20 + len]).unwrap()
}

#[test]
fn synthetic_meshopt_quad_decodes_every_codec_and_filter() {
    let dir = tempfile::tempdir().unwrap();
    let (root, bin) = common::scene::meshopt_quad();
    let scene = load(
        &common::scene::write_with_buffer(root, &bin, dir.path(), "meshopt"),
        None,
    );
    let prim = &scene.meshes()[0].primitives[0];
    // EXPONENTIAL with 24-bit mantissas keeps these values exactly.
    assert_eq!(
        prim.positions
            .iter()
            .map(|p| p.to_array())
            .collect::<Vec<_>>(),
        vec![
            [0.0, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0]
        ]
    );
    // OCTAHEDRAL of +z: z stored as 127, read as the normalized BYTE 1.
    for n in prim.normals.as_ref().unwrap() {
        assert_eq!(n.to_array(), [0.0, 0.0, 1.0]);
    }
    // The index codec keeps triangle order and winding but may rotate the
    // corners of a triangle.
    let reference = soupray::soup::Soup::from_triangles(&[
        [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]],
        [[0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]],
    ]);
    let soup = scene.evaluate(0.0).unwrap().soup;
    assert_eq!(soup_set_distance(&soup, &reference, "meshopt quad"), 0.0);
}

/// The step of the quantization grid a Draco encoder put positions on,
/// recovered from the decoded positions themselves: Draco dequantizes
/// component c as min_c + q * range / (2^bits - 1), with one range (the
/// largest extent) for all components, so the smallest `bits` for which
/// every component sits on that grid is the one the encoder used.
fn draco_position_step(positions: &[glam::Vec3]) -> (u32, f64) {
    let lo: Vec<f64> = (0..3)
        .map(|k| {
            positions
                .iter()
                .map(|p| f64::from(p[k]))
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    let range = (0..3)
        .map(|k| {
            positions
                .iter()
                .map(|p| f64::from(p[k]) - lo[k])
                .fold(0.0, f64::max)
        })
        .fold(0.0, f64::max);
    for bits in 1..=20u32 {
        let step = range / f64::from((1u32 << bits) - 1);
        // f32 dequantization is off the grid by a few ulps of the value.
        let slack = 1e-6 * (range + lo.iter().map(|v| v.abs()).fold(0.0, f64::max));
        let on_grid = positions.iter().all(|p| {
            (0..3).all(|k| {
                let q = (f64::from(p[k]) - lo[k]) / step;
                (q - q.round()).abs() * step <= slack
            })
        });
        if on_grid {
            return (bits, step);
        }
    }
    panic!("the decoded positions are on no Draco quantization grid of up to 20 bits");
}

#[test]
fn draco_rigged_simple_matches_its_plain_twin_while_skinned() {
    let (Some(compressed), Some(plain)) = (
        khronos("RiggedSimple/glTF-Draco/RiggedSimple.gltf"),
        khronos("RiggedSimple/glTF-Binary/RiggedSimple.glb"),
    ) else {
        return;
    };
    let compressed_scene = load(&compressed, None);
    let plain_scene = load(&plain, None);
    let prim = &compressed_scene.meshes()[0].primitives[0];
    assert!(prim.draco_compressed);
    assert!(prim.influences.is_some(), "JOINTS_0/WEIGHTS_0 decoded");
    let (bits, step) = draco_position_step(&prim.positions);
    // The payload keeps positions on an 11-bit grid (gltf-pipeline's
    // default) and the skin weights as exact floats; the joints are rigid
    // (their animated scale is 1 to 2e-7), so a corner is off by at most
    // half a step per component, sqrt(3)/2 step in length, plus f32
    // rounding of the world positions.
    assert!(bits <= 16, "{bits}-bit grid");
    let bound = 3f64.sqrt() / 2.0 * step * (1.0 + 1e-6) + 1e-5;
    eprintln!("Draco RiggedSimple: {bits}-bit grid, step {step:.3e}");
    assert_skinned_twin(
        &compressed_scene,
        &plain_scene,
        &[0, 12, 25, 37, 50],
        25,
        bound,
        "Draco RiggedSimple",
    );
}

#[test]
fn synthetic_draco_grid_matches_its_plain_twin_with_every_connectivity_coder() {
    let dir = tempfile::tempdir().unwrap();
    // Sequential, EdgeBreaker and EdgeBreaker valence connectivity.
    for speed in [10, 5, 1] {
        let pair = common::scene::draco_grid(12, speed);
        let (root, bin) = pair.plain.clone();
        let plain_scene = load(
            &common::scene::write_with_buffer(root, &bin, dir.path(), &format!("plain{speed}")),
            None,
        );
        let (root, bin) = pair.draco.clone();
        let draco_path =
            common::scene::write_with_buffer(root, &bin, dir.path(), &format!("draco{speed}"));
        let draco_scene = load(&draco_path, None);
        let prim = &draco_scene.meshes()[0].primitives[0];
        assert!(prim.draco_compressed);
        assert_eq!(prim.positions.len(), pair.points);
        assert_eq!(prim.triangles.len(), pair.faces);
        // Texture coordinates (12 bits over [0, 1]) follow their vertices:
        // uv = (x / 5, y / 2) of the (quantized) position.
        let step = pair.position_step;
        for (p, uv) in prim.positions.iter().zip(prim.uvs.as_ref().unwrap()) {
            let want = [p.x / 5.0, p.y / 2.0];
            for k in 0..2 {
                let slack = 0.5 / 4095.0 + step / 2.0 / [5.0, 2.0][k] + 1e-6;
                assert!(
                    f64::from((uv[k] - want[k]).abs()) <= slack,
                    "speed {speed}: uv {uv:?} at {p:?}"
                );
            }
        }
        // Each position component is off by at most half a step; the
        // skin's joints are rigid and its weights exact, and the morph
        // delta (0.1 x, weight 0.5) adds 0.05 of the x error.
        let bound = 3f64.sqrt() / 2.0 * step + 0.05 * step / 2.0 + 1e-5;
        let a = draco_scene.evaluate(0.0).unwrap().soup;
        let b = plain_scene.evaluate(0.0).unwrap().soup;
        let d = soup_set_distance(&a, &b, &format!("speed {speed}"));
        eprintln!("Draco grid, speed {speed}: max matched distance {d:.3e} (bound {bound:.3e})");
        assert!(d <= bound, "speed {speed}: {d} > {bound}");
        // The skin bends the grid: unskinned, the far corners are off by
        // far more (joint 2 turns them 30 degrees).
        let unbent = soupray::soup::Soup::from_triangles(
            &prim
                .triangles
                .iter()
                .map(|t| t.map(|v| prim.positions[v as usize].to_array()))
                .collect::<Vec<_>>(),
        );
        assert!(soup_set_distance(&a, &unbent, "unskinned") > 100.0 * bound);
    }
}

/// Appends `bytes` to `bin` as a new bufferView of `root`'s buffer 0.
fn append_view(root: &mut serde_json::Value, bin: &mut Vec<u8>, bytes: &[u8]) -> usize {
    while !bin.len().is_multiple_of(4) {
        bin.push(0);
    }
    let views = root["bufferViews"].as_array_mut().unwrap();
    views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": bytes.len()}));
    let view = views.len() - 1;
    bin.extend_from_slice(bytes);
    root["buffers"][0]["byteLength"] = bin.len().into();
    view
}

#[test]
fn optional_draco_is_decoded_in_preference_to_the_fallback_data() {
    let dir = tempfile::tempdir().unwrap();
    let pair = common::scene::draco_grid(12, 5);
    let (root, bin) = pair.plain.clone();
    let plain_scene = load(
        &common::scene::write_with_buffer(root, &bin, dir.path(), "plain"),
        None,
    );
    // Draco listed as used only, and POSITION given a fallback bufferView
    // that is all zeros: the decoded positions must win.
    let (mut root, mut bin) = pair.draco.clone();
    root.as_object_mut().unwrap().remove("extensionsRequired");
    let pos = root["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
        .as_u64()
        .unwrap() as usize;
    let zeros = vec![0u8; pair.points * 12];
    let view = append_view(&mut root, &mut bin, &zeros);
    root["accessors"][pos]["bufferView"] = view.into();
    let scene = load(
        &common::scene::write_with_buffer(root, &bin, dir.path(), "fallback"),
        None,
    );
    let bound = 3f64.sqrt() / 2.0 * pair.position_step + 0.05 * pair.position_step / 2.0 + 1e-5;
    let d = soup_set_distance(
        &scene.evaluate(0.0).unwrap().soup,
        &plain_scene.evaluate(0.0).unwrap().soup,
        "fallback",
    );
    assert!(d <= bound, "{d} > {bound}");
}

#[test]
fn draco_primitives_sharing_accessors_each_read_their_own_payload() {
    let dir = tempfile::tempdir().unwrap();
    // Two primitives naming the same accessors, compressed by different
    // connectivity coders into two payloads; each morph target in its own
    // payload's vertex order.
    let first = common::scene::draco_grid(12, 10);
    let second = common::scene::draco_grid(12, 5);
    let (mut root, mut bin) = first.draco.clone();
    let (root2, bin2) = &second.draco;
    let payload2 = {
        let v = &root2["bufferViews"][second.payload_view];
        let at = v["byteOffset"].as_u64().unwrap() as usize;
        bin2[at..at + v["byteLength"].as_u64().unwrap() as usize].to_vec()
    };
    let target2 = {
        let t = root2["meshes"][0]["primitives"][0]["targets"][0]["POSITION"]
            .as_u64()
            .unwrap() as usize;
        let v =
            &root2["bufferViews"][root2["accessors"][t]["bufferView"].as_u64().unwrap() as usize];
        let at = v["byteOffset"].as_u64().unwrap() as usize;
        (
            root2["accessors"][t].clone(),
            bin2[at..at + v["byteLength"].as_u64().unwrap() as usize].to_vec(),
        )
    };
    let payload_view = append_view(&mut root, &mut bin, &payload2);
    let target_view = append_view(&mut root, &mut bin, &target2.1);
    let mut target_acc = target2.0;
    target_acc["bufferView"] = target_view.into();
    let accessors = root["accessors"].as_array_mut().unwrap();
    accessors.push(target_acc);
    let target = accessors.len() - 1;
    let mut prim = root["meshes"][0]["primitives"][0].clone();
    prim["extensions"]["KHR_draco_mesh_compression"]["bufferView"] = payload_view.into();
    prim["targets"][0]["POSITION"] = target.into();
    root["meshes"][0]["primitives"]
        .as_array_mut()
        .unwrap()
        .push(prim);
    let scene = load(
        &common::scene::write_with_buffer(root, &bin, dir.path(), "shared"),
        None,
    );
    let prims = &scene.meshes()[0].primitives;
    assert_eq!(prims.len(), 2);
    assert!(prims.iter().all(|p| p.draco_compressed));

    let (mut plain, plain_bin) = first.plain.clone();
    let p0 = plain["meshes"][0]["primitives"][0].clone();
    plain["meshes"][0]["primitives"]
        .as_array_mut()
        .unwrap()
        .push(p0);
    let plain_scene = load(
        &common::scene::write_with_buffer(plain, &plain_bin, dir.path(), "plain2"),
        None,
    );
    let step = first.position_step.max(second.position_step);
    let bound = 3f64.sqrt() / 2.0 * step + 0.05 * step / 2.0 + 1e-5;
    let d = soup_set_distance(
        &scene.evaluate(0.0).unwrap().soup,
        &plain_scene.evaluate(0.0).unwrap().soup,
        "shared accessors",
    );
    assert!(d <= bound, "{d} > {bound}");
}
