//! EXT_mesh_gpu_instancing: each instance becomes part of the soup every
//! frame, placed at `world_from_node * node_from_instance`, so the
//! instances follow the node's animation; malformed instance data and soups
//! too large to exist are refused before anything is allocated for them.

mod common;

use common::scene::{instanced_triangles, load, shared::khronos, skinned_triangle, Builder};
use serde_json::json;
use soupray::scene::soup_size::{physical_memory_bytes, MAX_SOUP_TRIANGLES};
use soupray::scene::{LoadOptions, Scene};

fn load_err(path: &std::path::Path) -> String {
    match Scene::load(path, &LoadOptions::default()) {
        Ok(_) => panic!("{} loaded", path.display()),
        Err(e) => e.to_string(),
    }
}

#[test]
fn instances_give_the_soup_of_their_flat_twin_at_every_frame() {
    let dir = tempfile::tempdir().unwrap();
    let instanced = load(&instanced_triangles(dir.path(), true), None);
    let flat = load(&instanced_triangles(dir.path(), false), None);
    assert_eq!(instanced.instances().len(), 4);
    assert_eq!(instanced.gpu_instance_count(), 4);
    assert_eq!(flat.gpu_instance_count(), 0);
    assert_eq!(instanced.triangle_count(), 4);
    for t in [0.0, 0.25, 0.5, 1.0] {
        let a = instanced.evaluate(t).unwrap().soup;
        let b = flat.evaluate(t).unwrap().soup;
        assert_eq!(a.triangle_count(), 4);
        for (i, (p, q)) in a.positions.iter().zip(&b.positions).enumerate() {
            for k in 0..3 {
                assert!(
                    (p[k] - q[k]).abs() <= 1e-6 * (1.0 + q[k].abs()),
                    "t = {t}: corner {i} is {p:?}, its flat twin's {q:?}"
                );
            }
        }
        for (p, q) in a.normals.iter().zip(&b.normals) {
            for k in 0..3 {
                assert!(
                    (p[k] - q[k]).abs() <= 1e-6,
                    "t = {t}: normal {p:?} vs {q:?}"
                );
            }
        }
    }
    // The node's animation moves every instance: at t = 1 the node's
    // animated translation is (1, 2, 3) (replacing its rest (0.5, 0, 0)),
    // and the first instance (no rotation or offset) sits there.
    let s = instanced.evaluate(1.0).unwrap().soup;
    assert_eq!(s.positions[0][..3], [1.0, 2.0, 3.0]);
    assert_eq!(s.positions[1][..3], [2.0, 2.0, 3.0]);
    let s = instanced.evaluate(0.0).unwrap().soup;
    assert_eq!(s.positions[1][..3], [1.0, 0.0, 0.0]);
}

#[test]
fn an_instanced_skinned_mesh_moves_about_its_node() {
    // Skinning ignores the node's transform; an instance's transform then
    // offsets the skinned mesh about the node.
    let dir = tempfile::tempdir().unwrap();
    let path = skinned_triangle(
        dir.path(),
        json!({"translation": [0.0, 1.0, 0.0]}),
        [5.0, 0.0, 0.0],
    );
    let mut root: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
    let mut b = Builder::default();
    // Re-embed with one more accessor: the instances' translations.
    let uri = root["buffers"][0]["uri"].as_str().unwrap().to_owned();
    let bin = common::scene::decode_data_uri(&uri);
    b.bin = bin;
    b.views = root["bufferViews"].as_array().unwrap().clone();
    b.accessors = root["accessors"].as_array().unwrap().clone();
    let t = b.floats(&[0.0, 0.0, 0.0, 0.0, 0.0, 10.0], 3);
    root["nodes"][0]["extensions"] =
        json!({"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": t}}});
    let path = b.write(root, dir.path(), "skinned_instanced", true);
    let scene = load(&path, None);
    let soup = scene.evaluate(0.0).unwrap().soup;
    assert_eq!(soup.triangle_count(), 2);
    let corners: Vec<[f32; 3]> = soup.positions.iter().map(|p| [p[0], p[1], p[2]]).collect();
    assert_eq!(
        corners,
        vec![
            [0.0, 1.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 2.0, 0.0],
            [0.0, 1.0, 10.0],
            [1.0, 1.0, 10.0],
            [0.0, 2.0, 10.0]
        ]
    );
}

/// One triangle drawn by `instances` instances, with `triangles` copies of
/// it in the mesh (a u16 index buffer of zeros and ones).
fn many_instances(
    dir: &std::path::Path,
    triangles: usize,
    instances: usize,
    name: &str,
) -> std::path::PathBuf {
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let indices: Vec<u16> = (0..triangles).flat_map(|_| [0u16, 1, 2]).collect();
    let idx = b.u16s(&indices, 1, false);
    let t: Vec<f32> = (0..instances).flat_map(|i| [i as f32, 0.0, 0.0]).collect();
    let t = b.floats(&t, 3);
    b.write(
        json!({
            "extensionsUsed": ["EXT_mesh_gpu_instancing"],
            "scenes": [{"nodes": [0]}],
            "nodes": [{"name": "forest", "mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": {"TRANSLATION": t}}}}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]}]
        }),
        dir,
        name,
        false,
    )
}

#[test]
fn a_soup_past_the_index_limit_is_refused_at_load() {
    let dir = tempfile::tempdir().unwrap();
    // 65536 triangles x 30000 instances: 2.0e9 triangles from a 1.7 MB file.
    let path = many_instances(dir.path(), 65536, 30_000, "huge");
    let msg = load_err(&path);
    assert!(msg.starts_with(&path.display().to_string()), "{msg}");
    assert!(
        msg.contains("30000 mesh instance(s) expand to a soup of 1966080000 triangles")
            && msg.contains(&format!("at most {MAX_SOUP_TRIANGLES} triangles"))
            && msg.contains("Fix:"),
        "{msg}"
    );
}

#[test]
fn a_soup_larger_than_this_machine_is_refused_at_load() {
    let Some(physical) = physical_memory_bytes() else {
        eprintln!("skipped: this system does not report its memory");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    // Just over the machine's memory at the soup's full attribute size,
    // and under the index limit.
    let per_instance = 65536u64 * soupray::scene::soup_size::SOUP_BYTES_PER_TRIANGLE;
    let instances = (physical / per_instance + 1) as usize;
    if instances * 65536 > MAX_SOUP_TRIANGLES {
        eprintln!("skipped: this machine's memory is above what the soup can index");
        return;
    }
    let path = many_instances(dir.path(), 65536, instances, "big");
    let msg = load_err(&path);
    assert!(
        msg.contains(&format!(
            "{instances} mesh instance(s) expand to a soup of {} triangles",
            instances * 65536
        )) && msg.contains("this machine has")
            && msg.contains("Fix:"),
        "{msg}"
    );
}

#[test]
fn malformed_instance_data_is_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let cases = [
        (
            "counts",
            json!({"TRANSLATION": 1, "SCALE": 2}),
            "attributes have different counts (2 and 3)",
        ),
        ("missing", json!({"TRANSLATION": 99}), "names accessor 99"),
        (
            "zero",
            json!({"ROTATION": 3}),
            "element 1 is a zero quaternion",
        ),
        ("type", json!({"TRANSLATION": 3}), "needs VEC3 of FLOAT"),
    ];
    for (name, attributes, expect) in cases {
        let mut b = Builder::default();
        let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
        b.floats(&[0.0; 6], 3);
        b.floats(&[1.0; 9], 3);
        b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0], 4);
        let path = b.write(
            json!({
                "scenes": [{"nodes": [0]}],
                "nodes": [{"name": "row", "mesh": 0, "extensions": {"EXT_mesh_gpu_instancing": {"attributes": attributes}}}],
                "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}]
            }),
            dir.path(),
            name,
            true,
        );
        let msg = load_err(&path);
        assert!(
            msg.contains("node 0 \"row\"") && msg.contains(expect) && msg.contains("Fix:"),
            "{name}: {msg}"
        );
    }
}

#[test]
fn simple_instancing_draws_its_125_cubes() {
    let Some(path) = khronos("SimpleInstancing/glTF-Binary/SimpleInstancing.glb") else {
        return;
    };
    let scene = load(&path, None);
    assert_eq!(scene.gpu_instance_count(), 125);
    assert_eq!(scene.triangle_count(), 1500);
    let soup = scene.evaluate(0.0).unwrap().soup;
    // 125 distinct cube centres.
    let mut centres: Vec<[i64; 3]> = soup
        .positions
        .chunks(36)
        .map(|cube| {
            let c = cube.iter().fold([0.0f64; 3], |a, p| {
                [a[0] + p[0] as f64, a[1] + p[1] as f64, a[2] + p[2] as f64]
            });
            [
                (c[0] / 36.0 * 1e3) as i64,
                (c[1] / 36.0 * 1e3) as i64,
                (c[2] / 36.0 * 1e3) as i64,
            ]
        })
        .collect();
    centres.sort();
    centres.dedup();
    assert_eq!(centres.len(), 125);
}
