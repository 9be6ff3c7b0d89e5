//! What the render benches share: their scenes.

use std::path::PathBuf;

/// A bench scene: its file, frame and the flags that light it. `cesium` is
/// frame `cesium_frame` of the shipped animation as `soupray render`
/// renders it; `MESH-LIGHTING` a clay scan scene that `cargo bench --bench
/// cycles -- --scenes-only` writes to out/bench-cycles/scenes/ (frame 0,
/// `--clay`, sky radiance 0.1 under the sun, 1 otherwise, as that bench
/// renders it). An error names the missing file and how to write it.
pub fn scene(
    name: &str,
    cesium_frame: &'static str,
) -> Result<(PathBuf, &'static str, Vec<String>), String> {
    if name == "cesium" {
        return Ok((
            PathBuf::from("animations/CesiumMan/CesiumMan.glb"),
            cesium_frame,
            vec![],
        ));
    }
    let path = PathBuf::from(format!("out/bench-cycles/scenes/{name}.gltf"));
    if !path.exists() {
        return Err(format!(
            "{name}: no scene file {} (write it with `cargo bench --bench cycles -- \
             --scenes-only`)",
            path.display()
        ));
    }
    let env = if name.ends_with("-sun") { "0.1" } else { "1" };
    Ok((
        path,
        "0",
        vec![
            "--clay".into(),
            "--env-color".into(),
            format!("{env},{env},{env}"),
        ],
    ))
}
