//! Third-party files read in place: the Khronos sample corpus, the sample
//! animations and the scanned meshes live in the shared folder beside the
//! checkout (`../shared`, or `SOUPRAY_SHARED`), never in the repository.
//!
//! A test that needs one asks [`shared`] and returns early when it is
//! absent. The skip is written straight to the process's standard error,
//! past libtest's capture, so `cargo test` names every skipped test in its
//! output. Under CI (`CI` set) a missing file is a failure instead: CI has
//! the folder and must run every test.
//!
//! This file has no dependencies so that the benches can include it too
//! (`#[path = "../../tests/common/shared.rs"] mod shared;` in
//! benches/support); the tests reach it as `common::shared`.
#![allow(dead_code)]

use std::io::Write;
use std::path::{Path, PathBuf};

/// The shared folder: `SOUPRAY_SHARED` when set, else `../shared` beside the
/// checkout (or beside `SOUPRAY_TEST_ROOT`, a bundle's stand-in for it).
pub fn shared_root() -> PathBuf {
    if let Some(dir) = std::env::var_os("SOUPRAY_SHARED").filter(|d| !d.is_empty()) {
        return PathBuf::from(dir);
    }
    let repo = std::env::var_os("SOUPRAY_TEST_ROOT")
        .filter(|r| !r.is_empty())
        .map(PathBuf::from)
        .unwrap_or_else(|| Path::new(env!("CARGO_MANIFEST_DIR")).to_path_buf());
    repo.join("../shared")
}

/// `rel` under the shared folder (`"khronos/Fox/glTF-Binary/Fox.glb"`,
/// `"meshes/beast.ply"`), or `None` after saying which test skips and what
/// is missing. Panics under CI, where the folder must be there.
#[track_caller]
pub fn shared(rel: &str) -> Option<PathBuf> {
    let path = shared_root().join(rel);
    if path.exists() {
        return Some(path);
    }
    let test = std::thread::current()
        .name()
        .unwrap_or("a test")
        .to_string();
    if std::env::var_os("CI").is_some() {
        panic!(
            "{test}: {} is missing and CI is set: CI must have the shared folder \
             (set SOUPRAY_SHARED to its path)",
            path.display()
        );
    }
    let _ = writeln!(
        std::io::stderr(),
        "skipped {test}: needs {} (the shared folder of third-party assets; set SOUPRAY_SHARED \
         to its path)",
        path.display()
    );
    None
}

/// Several shared files at once: all of them, or `None` after naming the
/// first one missing.
#[track_caller]
pub fn shared_all<const N: usize>(rels: [&str; N]) -> Option<[PathBuf; N]> {
    let mut out: [PathBuf; N] = std::array::from_fn(|_| PathBuf::new());
    for (slot, rel) in out.iter_mut().zip(rels) {
        *slot = shared(rel)?;
    }
    Some(out)
}

/// A file of the Khronos sample corpus, by its path under `khronos/`.
#[track_caller]
pub fn khronos(rel: &str) -> Option<PathBuf> {
    shared(&format!("khronos/{rel}"))
}

/// A sample model's file by its short name `"Model/file.ext"`, read in place
/// from the shared folder: a `.glb` from `assets/Model/glTF-Binary/`, any
/// other file from `assets/Model/glTF/`.
#[track_caller]
pub fn sample(rel: &str) -> Option<PathBuf> {
    let (model, file) = rel
        .split_once('/')
        .unwrap_or_else(|| panic!("{rel}: not Model/file"));
    let variant = if file.ends_with(".glb") {
        "glTF-Binary"
    } else {
        "glTF"
    };
    shared(&format!("assets/{model}/{variant}/{file}"))
}

/// CesiumMan's binary glTF, the scene the render tests frame and check.
#[track_caller]
pub fn cesium_man() -> Option<PathBuf> {
    sample("CesiumMan/CesiumMan.glb")
}

/// A scanned mesh (`"beast.ply"`) from the shared folder's `meshes/`.
#[track_caller]
pub fn mesh_path(name: &str) -> Option<PathBuf> {
    shared(&format!("meshes/{name}"))
}

/// A copy of sample model `rel`'s folder in a new temporary directory, less
/// the files named in `without`, and the path of `rel`'s file in it: for the
/// tests of what a missing image does (the originals are never changed).
#[track_caller]
pub fn sample_without(rel: &str, without: &[&str]) -> Option<(TempCopy, PathBuf)> {
    let src = sample(rel)?;
    let from = src.parent().unwrap();
    let dir = std::env::temp_dir().join(format!(
        "soupray-sample-{}-{}",
        std::process::id(),
        TEMP_COPIES.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
    ));
    std::fs::create_dir_all(&dir).unwrap();
    for entry in std::fs::read_dir(from).unwrap() {
        let entry = entry.unwrap();
        let name = entry.file_name();
        if entry.file_type().unwrap().is_file() && !without.iter().any(|w| name == **w) {
            std::fs::copy(entry.path(), dir.join(&name)).unwrap();
        }
    }
    let path = dir.join(src.file_name().unwrap());
    Some((TempCopy(dir), path))
}

static TEMP_COPIES: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);

/// A temporary directory, removed when dropped.
pub struct TempCopy(pub PathBuf);

impl Drop for TempCopy {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}
