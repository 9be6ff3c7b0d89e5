//! Hostile glTF input: the regression corpus (`tests/fuzz_corpus/`, made by
//! its `make.py`), inputs that are not regular files, and a time-bounded
//! structured mutation fuzz of the test assets with a fixed seed.
//!
//! Every input must either load (and evaluate) or fail with an error that
//! names the file; none may panic, hang, or reach the last-resort catch of a
//! panic inside loading (`soupray::scene::LAST_RESORT`): an input that does
//! is a gap in the validation, and the test lists it.
//!
//! Nothing here writes outside a temporary directory. Paths such as
//! `/dev/zero` appear only as inputs, opened read-only.
//!
//! One module per kind of input; this file holds the check they share
//! (`outcome`).

#[path = "../common/mod.rs"]
mod common;

mod corpus;
mod draco;
mod mutation;
mod textures;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use common::scene::asset;
use common::XorshiftStar;
use serde_json::{json, Value};
use soupray::scene::{LoadOptions, Scene, LAST_RESORT};

fn corpus() -> PathBuf {
    common::fuzz_corpus()
}

/// Loads `path` and evaluates a few frames; `Err` is the error's message.
fn outcome(path: &Path) -> Result<Vec<String>, String> {
    let scene = Scene::load(path, &LoadOptions::default()).map_err(|e| e.to_string())?;
    scene
        .materials()
        .decode_used_images()
        .map_err(|e| e.to_string())?;
    let (first, last) = scene.frame_range();
    for frame in [first, (first + last) / 2, last] {
        scene
            .evaluate(scene.time_of_frame(frame))
            .map_err(|e| e.to_string())?;
    }
    Ok(scene.warnings().to_vec())
}
