//! Bad input: every broken file gives an error that names the file and the
//! accessor or extension at fault and says how to fix it; none panics.

mod common;

use common::scene::{asset, Builder};
use serde_json::json;
use soupray::scene::{LoadOptions, Scene};

fn load_err(path: &std::path::Path, opts: &LoadOptions) -> String {
    match Scene::load(path, opts) {
        Ok(_) => panic!("{} loaded but should not", path.display()),
        Err(e) => e.to_string(),
    }
}

fn assert_mentions(msg: &str, parts: &[&str]) {
    for p in parts {
        assert!(msg.contains(p), "message lacks {p:?}: {msg}");
    }
}

#[test]
fn truncated_glb_names_file_and_accessor() {
    let dir = tempfile::tempdir().unwrap();
    let Some(rigged_simple_glb) = asset("RiggedSimple/RiggedSimple.glb") else {
        return;
    };
    let bytes = std::fs::read(&rigged_simple_glb).unwrap();
    let path = dir.path().join("cut.glb");
    std::fs::write(&path, &bytes[..bytes.len() * 3 / 4]).unwrap();
    let msg = load_err(&path, &LoadOptions::default());
    assert_mentions(&msg, &["cut.glb", "accessor ", "truncated", "Fix"]);

    // Cut inside the JSON chunk: still an error naming the file.
    std::fs::write(&path, &bytes[..200]).unwrap();
    let msg = load_err(&path, &LoadOptions::default());
    assert_mentions(&msg, &["cut.glb", "truncated", "JSON"]);
}

#[test]
fn missing_bin_names_the_uri() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("SimpleSkin.gltf");
    let Some(simple_skin_gltf) = asset("SimpleSkin/SimpleSkin.gltf") else {
        return;
    };
    std::fs::copy(&simple_skin_gltf, &path).unwrap();
    let msg = load_err(&path, &LoadOptions::default());
    assert_mentions(&msg, &["SimpleSkin.gltf", "skinGeometry.bin", "Fix"]);
}

fn triangle_file(
    dir: &std::path::Path,
    name: &str,
    positions: &[f32],
    indices: &[u32],
    extra: serde_json::Value,
) -> std::path::PathBuf {
    let mut b = Builder::default();
    let pos = b.floats(positions, 3);
    let idx = b.u32s(indices);
    let mut root = json!({
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]}]
    });
    for (k, v) in extra.as_object().unwrap() {
        root[k] = v.clone();
    }
    b.write(root, dir, name, true)
}

#[test]
fn out_of_range_indices_name_the_index_accessor() {
    let dir = tempfile::tempdir().unwrap();
    let path = triangle_file(
        dir.path(),
        "badindex",
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        &[0, 1, 7],
        json!({}),
    );
    let msg = load_err(&path, &LoadOptions::default());
    // Accessor 1 holds the indices (accessor 0 the positions).
    assert_mentions(
        &msg,
        &[
            "badindex.gltf",
            "accessor 1",
            "indices of mesh 0 primitive 0",
            "index 7",
            "3 vertices",
            "Fix",
        ],
    );
}

#[test]
fn nan_positions_error_unless_sanitized() {
    let dir = tempfile::tempdir().unwrap();
    let positions = [
        0.0,
        0.0,
        0.0,
        1.0,
        0.0,
        0.0,
        0.0,
        1.0,
        0.0,
        f32::NAN,
        0.0,
        0.0,
    ];
    let path = triangle_file(
        dir.path(),
        "nan",
        &positions,
        &[0, 1, 2, 0, 3, 2],
        json!({}),
    );
    let msg = load_err(&path, &LoadOptions::default());
    assert_mentions(
        &msg,
        &[
            "nan.gltf",
            "accessor 0",
            "POSITION of mesh 0 primitive 0",
            "element 3",
            "--sanitize",
        ],
    );

    let opts = LoadOptions {
        sanitize: true,
        ..Default::default()
    };
    let scene = Scene::load(&path, &opts).unwrap();
    let frame = scene.evaluate(0.0).unwrap();
    assert_eq!(frame.soup.triangle_count(), 1);
    assert!(
        frame
            .warnings
            .iter()
            .any(|w| w.contains("dropped 1 triangle")),
        "{:?}",
        frame.warnings
    );
}

#[test]
fn required_unknown_extension_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let path = triangle_file(
        dir.path(),
        "volume_scatter",
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        &[0, 1, 2],
        json!({"extensionsUsed": ["KHR_materials_volume_scatter"], "extensionsRequired": ["KHR_materials_volume_scatter"]}),
    );
    let msg = load_err(&path, &LoadOptions::default());
    assert_mentions(
        &msg,
        &[
            "volume_scatter.gltf",
            "KHR_materials_volume_scatter",
            "does not implement",
            "Fix",
        ],
    );

    // Merely used (optional) unknown extensions are fine.
    let path = triangle_file(
        dir.path(),
        "optional",
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        &[0, 1, 2],
        json!({"extensionsUsed": ["EXT_something_optional"]}),
    );
    let scene = Scene::load(&path, &LoadOptions::default()).unwrap();
    assert_eq!(scene.extensions_used(), ["EXT_something_optional"]);
}

#[test]
fn malformed_and_missing_files_name_the_file() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("broken.gltf");
    std::fs::write(&path, "{\"asset\": {\"version\": \"2.0\"}, \"nodes\": [").unwrap();
    assert_mentions(
        &load_err(&path, &LoadOptions::default()),
        &["broken.gltf", "JSON"],
    );
    let missing = dir.path().join("nothere.glb");
    assert_mentions(
        &load_err(&missing, &LoadOptions::default()),
        &["nothere.glb", "cannot read"],
    );
    // A reference to a node that does not exist.
    std::fs::write(
        &path,
        r#"{"asset": {"version": "2.0"}, "scenes": [{"nodes": [3]}]}"#,
    )
    .unwrap();
    assert_mentions(
        &load_err(&path, &LoadOptions::default()),
        &["broken.gltf", "not valid glTF"],
    );
}

#[test]
fn bad_selections_list_the_choices() {
    let opts = |animation: Option<&str>, scene: Option<usize>, camera: Option<&str>| LoadOptions {
        animation: animation.map(str::to_owned),
        scene,
        camera: camera.map(str::to_owned),
        ..Default::default()
    };
    let Some(fox) = asset("Fox/Fox.glb") else {
        return;
    };
    assert_mentions(
        &load_err(&fox, &opts(Some("Dance"), None, None)),
        &["Fox.glb", "Dance", "\"Survey\"", "\"Walk\"", "\"Run\""],
    );
    assert_mentions(
        &load_err(&fox, &opts(Some("3"), None, None)),
        &["Fox.glb", "--animation 3"],
    );
    assert_mentions(
        &load_err(&fox, &opts(None, Some(2), None)),
        &["Fox.glb", "--scene 2", "1 scene"],
    );
    assert_mentions(
        &load_err(&fox, &opts(None, None, Some("main"))),
        &["Fox.glb", "--camera main", "has none"],
    );
    let bad_fps = LoadOptions {
        fps: 0.0,
        ..Default::default()
    };
    assert_mentions(&load_err(&fox, &bad_fps), &["Fox.glb", "--fps"]);
}

#[test]
fn no_truncation_or_corruption_panics() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("fuzz.glb");
    let Some(rigged_simple_glb) = asset("RiggedSimple/RiggedSimple.glb") else {
        return;
    };
    let bytes = std::fs::read(&rigged_simple_glb).unwrap();
    let mut rng = common::Xorshift32(0x2545_f491);
    let mut next = move || rng.next();
    for i in 0..60 {
        let mut data = bytes.clone();
        if i % 2 == 0 {
            data.truncate(next() as usize % bytes.len());
        } else {
            for _ in 0..4 {
                let at = next() as usize % data.len();
                data[at] = next() as u8;
            }
        }
        std::fs::write(&path, &data).unwrap();
        // Either outcome is fine; a panic fails the test.
        if let Ok(scene) = Scene::load(&path, &LoadOptions::default()) {
            let _ = scene.evaluate(0.5);
        }
    }
}

#[test]
fn bad_extension_texture_index_is_named() {
    // A material extension's texture is checked like the core ones: an
    // index past the texture table is an error naming the file, the
    // material, the extension's property and the table's size.
    let dir = tempfile::tempdir().unwrap();
    let path = triangle_file(
        dir.path(),
        "spec",
        &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0],
        &[0, 1, 2],
        json!({
            "extensionsUsed": ["KHR_materials_specular"],
            "materials": [{"extensions": {"KHR_materials_specular": {"specularColorTexture": {"index": 3}}}}]
        }),
    );
    let msg = load_err(&path, &LoadOptions::default());
    assert_mentions(
        &msg,
        &[
            "spec.gltf",
            "material 0",
            "KHR_materials_specular.specularColorTexture",
            "texture 3",
            "no textures",
        ],
    );
}
