//! The file's own environment: glTF has no sky, so soupray reads a constant
//! one from the rendered scene's `extras.soupray.environment`.

use serde_json::json;
use soupray::scene::{LoadOptions, Scene};

fn scene_with_extras(extras: serde_json::Value) -> Scene {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sky.gltf");
    let root = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [], "extras": extras}],
    });
    std::fs::write(&path, serde_json::to_string(&root).unwrap()).unwrap();
    Scene::load(&path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn a_scene_extras_environment_is_read() {
    let scene = scene_with_extras(json!({"soupray": {"environment": [0.25, 0.5, 1.0]}}));
    assert_eq!(scene.environment(), Some([0.25, 0.5, 1.0]));
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
}

#[test]
fn a_malformed_extras_environment_is_ignored_with_a_warning() {
    for bad in [json!([1.0, 2.0]), json!([1.0, -1.0, 0.0]), json!("blue")] {
        let scene = scene_with_extras(json!({"soupray": {"environment": bad}}));
        assert_eq!(scene.environment(), None);
        assert!(
            scene
                .warnings()
                .iter()
                .any(|w| w.contains("extras.soupray.environment") && w.contains("ignored")),
            "{bad}: {:?}",
            scene.warnings()
        );
    }
}

#[test]
fn other_extras_are_not_an_environment() {
    let scene = scene_with_extras(json!({"author": "someone"}));
    assert_eq!(scene.environment(), None);
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
}
