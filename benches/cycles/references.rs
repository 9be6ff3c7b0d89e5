//! The converged references, cached under `OUT/refs/` by a key of every
//! setting and the hashes of the scene, the script and the rendering code.

use crate::opts::Opts;
use crate::renderers::{read_exr, Render};
use crate::scenes::{fnv1a, FNV_START};
use serde_json::json;
use soupray::film::Image;
use std::path::{Path, PathBuf};

pub fn mean_rgb(img: &Image) -> f64 {
    let sum: f64 = img
        .rgba
        .iter()
        .map(|p| (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0)
        .sum();
    sum / img.rgba.len().max(1) as f64
}

/// A cached reference: the image and the seconds it took.
pub fn cached_reference(
    o: &Opts,
    dir: &Path,
    render: impl FnOnce(&Path) -> Result<Render, String>,
) -> Result<(Image, f64, bool), String> {
    let exr = dir.join("reference.exr");
    let meta = dir.join("reference.json");
    if !o.fresh_refs && exr.exists() && meta.exists() {
        let time = std::fs::read_to_string(&meta)
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
            .and_then(|v| v["time_s"].as_f64())
            .unwrap_or(f64::NAN);
        return Ok((read_exr(&exr)?, time, true));
    }
    let _ = std::fs::remove_dir_all(dir);
    let work = dir.join("work");
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let r = render(&work)?;
    let produced = std::fs::read_dir(&work)
        .map_err(|e| e.to_string())?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|x| x == "exr"))
        .ok_or("the reference render left no EXR")?;
    std::fs::rename(&produced, &exr).map_err(|e| format!("{}: {e}", exr.display()))?;
    let _ = std::fs::remove_dir_all(&work);
    std::fs::write(
        &meta,
        serde_json::to_string_pretty(&json!({"time_s": r.times.time, "total_s": r.times.total}))
            .expect("json"),
    )
    .map_err(|e| format!("{}: {e}", meta.display()))?;
    Ok((r.image, r.times.time, false))
}

/// A hash of the files at `paths` (files, or directories read recursively),
/// with their names.
pub fn source_hash(paths: &[PathBuf]) -> Result<u64, String> {
    fn walk(p: &Path, files: &mut Vec<PathBuf>) -> Result<(), String> {
        if p.is_dir() {
            let mut entries: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| format!("{}: {e}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .collect();
            entries.sort();
            for e in entries {
                walk(&e, files)?;
            }
        } else if p.is_file() {
            files.push(p.to_owned());
        }
        Ok(())
    }
    let mut files = Vec::new();
    for p in paths {
        walk(p, &mut files)?;
    }
    let mut h = FNV_START;
    for f in files {
        let name = f.strip_prefix(env!("CARGO_MANIFEST_DIR")).unwrap_or(&f);
        h = fnv1a(h, name.to_string_lossy().as_bytes());
        h = fnv1a(
            h,
            &std::fs::read(&f).map_err(|e| format!("{}: {e}", f.display()))?,
        );
    }
    Ok(h)
}
