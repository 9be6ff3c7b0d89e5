//! What the benches share: the third-party files they read in place from
//! the shared folder, their render scenes, and rendering one frame.
// Each bench uses only some of it.
#![allow(dead_code)]

use std::path::PathBuf;

#[path = "../../tests/common/shared.rs"]
mod shared;

/// `rel` under the shared folder (`../shared` beside the checkout, or
/// `SOUPRAY_SHARED`; `SOUPRAY_TEST_ROOT` stands in for the checkout), or an
/// error naming the missing file, for the bench to print and skip that row
/// (never a panic, CI or not).
pub fn shared_file(rel: &str) -> Result<PathBuf, String> {
    let path = shared::shared_root().join(rel);
    if path.exists() {
        Ok(path)
    } else {
        Err(format!(
            "{} is missing (the shared folder of third-party assets; set SOUPRAY_SHARED to its \
             path)",
            path.display()
        ))
    }
}

/// A sample model's file by its short name (`"Fox/Fox.glb"`): a `.glb` from
/// `assets/Model/glTF-Binary/`, any other from `assets/Model/glTF/`.
pub fn sample(rel: &str) -> Result<PathBuf, String> {
    let (model, file) = rel.split_once('/').unwrap_or(("", rel));
    let variant = if file.ends_with(".glb") {
        "glTF-Binary"
    } else {
        "glTF"
    };
    shared_file(&format!("assets/{model}/{variant}/{file}"))
}

/// A scanned mesh (`"beast.ply"`) from the shared folder's `meshes/`.
pub fn mesh_path(name: &str) -> Result<PathBuf, String> {
    shared_file(&format!("meshes/{name}"))
}

/// A scanned mesh read as a soup; `Err` names the missing file.
pub fn mesh(name: &str) -> Result<soupray::soup::Soup, String> {
    let path = mesh_path(name)?;
    soupray::ply::read_soup(&path).map_err(|e| format!("{}: {e}", path.display()))
}

/// A bench scene: its file, frame and the flags that light it. `cesium` is
/// frame `cesium_frame` of CesiumMan (read in place from the shared folder)
/// as `soupray render` renders it; `MESH-LIGHTING` a clay scan scene that `cargo bench --bench
/// cycles -- --scenes-only` writes to out/bench-cycles/scenes/ (frame 0,
/// `--clay`, sky radiance 0.1 under the sun, 1 otherwise, as that bench
/// renders it). An error names the missing file and how to write it.
pub fn scene(
    name: &str,
    cesium_frame: &'static str,
) -> Result<(PathBuf, &'static str, Vec<String>), String> {
    if name == "cesium" {
        return Ok((sample("CesiumMan/CesiumMan.glb")?, cesium_frame, vec![]));
    }
    let path = PathBuf::from(format!("out/bench-cycles/scenes/{name}.gltf"));
    if !path.exists() {
        return Err(format!(
            "{name}: no scene file {} (write it with `cargo bench --bench cycles -- \
             --scenes-only`)",
            path.display()
        ));
    }
    // The clay scans under the sky or the sun render clay; the other
    // scenes their materials: the textured emitter and the street of lamps
    // by their own light at night, the rest under the sun and a dim sky.
    let (clay, env) = match name.rsplit_once('-').map_or("", |(_, lighting)| lighting) {
        "sky" => (true, "1"),
        "sun" => (true, "0.1"),
        "emitter" | "lamps" => (false, "0"),
        _ => (false, "0.1"),
    };
    let mut args: Vec<String> = vec!["--env-color".into(), format!("{env},{env},{env}")];
    if clay {
        args.insert(0, "--clay".into());
    }
    Ok((path, "0", args))
}

/// A frame `soupray render` wrote: its RGBA (the denoised beauty of a
/// `--denoise` frame) and its log.
pub struct Frame {
    pub image: soupray::film::Image,
    pub log: soupray::output::FrameLog,
}

/// Renders frame `frame` of `scene` at `size` with `binary` (a soupray
/// build) and `args` into `dir` (emptied first), and reads it back.
pub fn render_frame(
    binary: &str,
    scene: &std::path::Path,
    frame: &str,
    size: (u32, u32),
    args: &[String],
    dir: &std::path::Path,
) -> Result<Frame, String> {
    let _ = std::fs::remove_dir_all(dir);
    let out = std::process::Command::new(binary)
        .arg("render")
        .arg(scene)
        .args(["--frame", frame, "--quiet", "--name", "img.####.exr"])
        .args(["--width", &size.0.to_string()])
        .args(["--height", &size.1.to_string()])
        .args(args)
        .arg("--out")
        .arg(dir)
        .output()
        .map_err(|e| format!("cannot run {binary}: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "soupray render {} {args:?}: {}",
            scene.display(),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let exr = dir.join(format!("img.{frame:0>4}.exr"));
    let log = dir.join(format!("img.{frame:0>4}.json"));
    Ok(Frame {
        image: soupray::output::read_exr_rgba(&exr)
            .map_err(|e| format!("{}: {e}", exr.display()))?,
        log: soupray::output::read_log(&log).map_err(|e| format!("{}: {e}", log.display()))?,
    })
}

/// `--name VALUE` from the command line.
pub fn flag(name: &str) -> Option<String> {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .cloned()
}
