//! Shared helpers for the integration tests: the device, deterministic
//! geometry, and the shipped meshes.
#![allow(dead_code)]

use soupray::device::Device;
use soupray::film::Image;
use soupray::soup::Soup;
use std::path::{Path, PathBuf};

/// The OpenCL device the tests run on (SOUPRAY_DEVICE picks another).
/// Opening is serialised: PoCL's platform discovery is not safe to run from
/// several test threads at once (it then sometimes reports no device).
pub fn device() -> Device {
    static OPEN: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _guard = OPEN.lock().unwrap_or_else(|e| e.into_inner());
    Device::open(None).unwrap_or_else(|e| panic!("the tests need an OpenCL device: {e}"))
}

/// The repository root the tests read assets from: `SOUPRAY_TEST_ROOT`
/// when set (a `scripts/gpu-check.sh` bundle, whose test binaries run far
/// from the checkout they were built in), else the checkout.
pub fn repo() -> PathBuf {
    match std::env::var_os("SOUPRAY_TEST_ROOT").filter(|r| !r.is_empty()) {
        Some(root) => PathBuf::from(root),
        None => PathBuf::from(env!("CARGO_MANIFEST_DIR")),
    }
}

pub fn mesh(name: &str) -> Soup {
    let p = repo().join("tests/assets/meshes").join(name);
    soupray::ply::read_soup(&p).unwrap_or_else(|e| panic!("{e}"))
}

/// A small xorshift generator, so test soups are the same everywhere.
pub struct Rng(pub u64);
impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E3779B97F4A7C15) | 1)
    }
    pub fn f32(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// `n` random triangles of size about `size` in the unit cube.
pub fn random_soup(n: usize, size: f32, seed: u64) -> Soup {
    let mut rng = Rng::new(seed);
    let tris: Vec<[[f32; 3]; 3]> = (0..n)
        .map(|_| {
            let c = [rng.f32(), rng.f32(), rng.f32()];
            std::array::from_fn(|_| std::array::from_fn(|a| c[a] + (rng.f32() - 0.5) * size))
        })
        .collect();
    Soup::from_triangles(&tris)
}

/// `soup` scaled by `s` and moved by `offset`.
pub fn transformed(soup: &Soup, s: f32, offset: f32) -> Soup {
    let mut out = soup.clone();
    for p in &mut out.positions {
        for c in &mut p[..3] {
            *c = *c * s + offset;
        }
    }
    out
}

pub fn exists(p: &Path) -> bool {
    p.exists()
}

/// The RGBA layer of an EXR soupray wrote (the AOVs are not read).
pub fn read_exr(path: &Path) -> Image {
    soupray::output::read_exr_rgba(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}
