//! Through the `soupray` binary, where the exit code and the JSON log are
//! the subject: a frame scaled to nothing, NaN and infinite vertices with
//! and without `--sanitize`.

use super::*;

/// Runs `soupray render` on frames `frames` of `scene` into `out`.
fn soupray(scene: &Path, out: &Path, frames: &str, extra: &[&str]) -> std::process::Output {
    common::soupray_cmd()
        .arg("render")
        .arg(scene)
        .args(["--frames", frames, "--spp", "4", "--quiet"])
        .args([
            "--width",
            &WIDTH.to_string(),
            "--height",
            &HEIGHT.to_string(),
        ])
        .args(["--out", out.to_str().unwrap(), "--name", "f.####.exr"])
        .args(extra)
        .output()
        .unwrap()
}

fn read_log(path: &Path) -> Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

#[test]
fn a_frame_with_everything_scaled_to_zero_renders_the_sky() {
    let dir = tempfile::tempdir().unwrap();
    let spec = base_spec();
    // The meshes hang under their own node, whose scale goes from 1 at
    // t = 0 to 0 at t = 1 (frame 24); camera and light stay put.
    let (mut b, mut root) = gltf(&spec);
    let meshes = spec.parts.len();
    let times = b.floats(&[0.0, 1.0], 1);
    let scales = b.floats(&[1.0, 1.0, 1.0, 0.0, 0.0, 0.0], 3);
    let group = root["nodes"].as_array().unwrap().len();
    root["nodes"]
        .as_array_mut()
        .unwrap()
        .push(json!({"name": "group", "children": (1..=meshes).collect::<Vec<_>>()}));
    let children: Vec<usize> = (meshes + 1..group).chain([group]).collect();
    root["nodes"][ROOT_NODE]["children"] = json!(children);
    root["animations"] = json!([{"samplers": [{"input": times, "output": scales}],
        "channels": [{"sampler": 0, "target": {"node": group, "path": "scale"}}]}]);
    let scene = b.write(root, dir.path(), "vanish", true);
    let out = dir.path().join("out");
    let run = soupray(&scene, &out, "0,24", &["--env-color", "0.2,0.3,0.4"]);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let first = common::read_exr(&out.join("f.0000.exr"));
    assert!(
        coverage(&first).0 > first.rgba.len() / 2,
        "frame 0 shows the scene"
    );
    let empty = common::read_exr(&out.join("f.0024.exr"));
    for (i, p) in empty.rgba.iter().enumerate() {
        assert_eq!(*p, [0.2, 0.3, 0.4, 0.0], "frame 24 pixel {i}");
    }
    let (l0, l24) = (
        read_log(&out.join("f.0000.json")),
        read_log(&out.join("f.0024.json")),
    );
    // The soup keeps its topology (every triangle, collapsed to a point),
    // the tree is valid and its cost a number.
    assert_eq!(l24["triangles"], l0["triangles"]);
    assert!(l24["triangles"].as_u64().unwrap() > 0);
    assert!(l24["build"]["sah_cost"]
        .as_f64()
        .is_some_and(f64::is_finite));
    assert!(l24["build"]["leaves"].as_u64().unwrap() > 0);
    let warnings = l24["warnings"].as_array().unwrap();
    assert!(
        warnings
            .iter()
            .all(|w| !w.as_str().unwrap().contains("NaN")),
        "{warnings:?}"
    );
}

/// A floor and a quad named "Bad" whose vertex 4 is `bad` and is used by
/// its last two triangles (of four); `with_bad: false` leaves those two
/// triangles out.
fn bad_vertex_scene(dir: &Path, name: &str, bad: f32, with_bad: bool) -> (PathBuf, usize) {
    let mut spec = base_spec();
    spec.parts.truncate(1);
    let mut indices = vec![0, 1, 2, 0, 2, 3];
    if with_bad {
        indices.extend([0, 1, 4, 2, 3, 4]);
    }
    spec.parts.push(Part {
        name: "Bad",
        positions: vec![
            [-0.5, 0.2, 0.5],
            [0.5, 0.2, 0.5],
            [0.5, 1.0, -0.5],
            [-0.5, 1.0, -0.5],
            [0.0, bad, 0.0],
        ],
        normals: None,
        indices,
        material: diffuse([0.2, 0.7, 0.3]),
    });
    let (mut b, root) = gltf(&spec);
    // POSITION needs min and max, which the Builder leaves out when a value
    // is infinite: give the finite bounds, so the file is valid glTF but
    // for the value itself.
    b.accessors[3]["min"] = json!([-0.5, 0.0, -0.5]);
    b.accessors[3]["max"] = json!([0.5, 1.0, 0.5]);
    // The accessors are written in order: per part POSITION, (NORMAL),
    // indices; the floor has normals, so "Bad"'s POSITION is accessor 3.
    let accessor = 3;
    assert_eq!(
        root["meshes"][1]["primitives"][0]["attributes"]["POSITION"],
        accessor
    );
    (b.write(root, dir, name, true), accessor)
}

#[test]
fn nan_and_infinite_vertices_are_errors_naming_mesh_and_accessor_unless_sanitized() {
    let dir = tempfile::tempdir().unwrap();
    for (bad, what) in [(f32::NAN, "NaN"), (f32::INFINITY, "inf")] {
        let (scene, accessor) = bad_vertex_scene(dir.path(), what, bad, true);
        let out = dir.path().join(format!("out-{what}"));
        let run = soupray(&scene, &out, "0", &[]);
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert_eq!(run.status.code(), Some(4), "{what}: {stderr}");
        for needle in [
            "mesh 1 \"Bad\"".to_string(),
            format!("accessor {accessor}"),
            "POSITION".into(),
            "element 4".into(),
            "--sanitize".into(),
        ] {
            assert!(
                stderr.contains(&needle),
                "{what}: no {needle:?} in: {stderr}"
            );
        }

        // --sanitize: the frame renders, the log counts the two triangles
        // that use the bad vertex, and the image is that of the scene
        // without them (they can never be hit).
        let run = soupray(&scene, &out, "0", &["--sanitize"]);
        assert!(
            run.status.success(),
            "{what} --sanitize: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        let log = read_log(&out.join("f.0000.json"));
        let warnings: Vec<&str> = log["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w.as_str().unwrap())
            .collect();
        assert!(
            warnings.iter().any(|w| w.contains(" 2 triangle")),
            "{what}: the log's warnings do not count 2 triangles: {warnings:?}"
        );
        let image = common::read_exr(&out.join("f.0000.exr"));
        assert!(image.rgba.iter().flatten().all(|v| v.is_finite()));
        let (clean, _) = bad_vertex_scene(dir.path(), "clean", 0.0, false);
        let clean_out = dir.path().join(format!("clean-{what}"));
        let run = soupray(&clean, &clean_out, "0", &[]);
        assert!(run.status.success());
        let reference = common::read_exr(&clean_out.join("f.0000.exr"));
        assert!(
            image.rgba == reference.rgba,
            "{what} --sanitize: the image differs from the scene without the bad triangles"
        );
    }
}
