//! The integration tests' one support module (each test file has
//! `mod common;`): the device, the soupray binary, asset paths, random
//! numbers and generated geometry, and by topic the render scenes
//! (`render`), the glTF builder and reference evaluator (`scene`) and the
//! trace helpers (`trace`).
#![allow(dead_code)]

use soupray::device::Device;
use soupray::film::Image;
use soupray::soup::Soup;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};

pub mod geometry;
pub mod passes;
pub mod render;
pub mod rng;
pub mod scene;
pub mod shared;
pub mod trace;

#[allow(unused_imports)]
pub use rng::{random_dir, random_upper_dir, Rng, Xorshift32, XorshiftStar};

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

/// A file under the repository root (`"animations/walker/walker.glb"`).
pub fn repo_file(rel: &str) -> PathBuf {
    repo().join(rel)
}

/// The hostile-input corpus, `tests/fuzz_corpus/`.
pub fn fuzz_corpus() -> PathBuf {
    repo().join("tests/fuzz_corpus")
}

/// A sample model's file (`"Fox/Fox.glb"`), read in place from the shared
/// folder; `None` (the caller skips) after naming it when it is absent.
#[track_caller]
pub fn asset(rel: &str) -> Option<PathBuf> {
    shared::sample(rel)
}

/// `asset` as a command-line argument.
#[track_caller]
pub fn asset_arg(rel: &str) -> Option<String> {
    asset(rel).map(|p| p.display().to_string())
}

/// A scanned mesh's path (`"beast.ply"`) as a command-line argument.
#[track_caller]
pub fn mesh_arg(name: &str) -> Option<String> {
    shared::mesh_path(name).map(|p| p.display().to_string())
}

/// The soupray binary cargo built for this test run.
pub const SOUPRAY: &str = env!("CARGO_BIN_EXE_soupray");

/// A command running the soupray binary, for the caller's arguments.
pub fn soupray_cmd() -> Command {
    Command::new(SOUPRAY)
}

/// Runs soupray with `args` (standard input closed) and waits for it.
pub fn soupray(args: &[&str]) -> Output {
    soupray_cmd()
        .args(args)
        .stdin(Stdio::null())
        .output()
        .expect("run soupray")
}

/// A scanned mesh from the shared folder (`"beast.ply"`), or `None` (the
/// caller skips) after naming it when it is absent.
#[track_caller]
pub fn mesh(name: &str) -> Option<Soup> {
    let p = shared::mesh_path(name)?;
    Some(soupray::ply::read_soup(&p).unwrap_or_else(|e| panic!("{e}")))
}

/// `n` random triangles of size about `size` in the unit cube.
pub fn random_soup(n: usize, size: f32, seed: u64) -> Soup {
    Soup::from_triangles(&random_triangles(n, size, seed))
}

/// The triangles of `random_soup(n, size, seed)`, to mix with others.
pub fn random_triangles(n: usize, size: f32, seed: u64) -> Vec<[[f32; 3]; 3]> {
    let mut rng = Rng::new(seed);
    (0..n)
        .map(|_| {
            let c = [rng.f32(), rng.f32(), rng.f32()];
            std::array::from_fn(|_| std::array::from_fn(|a| c[a] + (rng.f32() - 0.5) * size))
        })
        .collect()
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

/// Every channel of an EXR soupray wrote, by name, as f32 (AOVs included).
pub fn exr_channels(path: &Path) -> std::collections::BTreeMap<String, Vec<f32>> {
    let image = exr::prelude::read_all_flat_layers_from_file(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    image.layer_data[0]
        .channel_data
        .list
        .iter()
        .map(|c| (c.name.to_string(), c.sample_data.values_as_f32().collect()))
        .collect()
}

/// A generated table against its header in kernels/: with
/// `SOUPRAY_REGENERATE` set, writes `text(fresh)` to `header` first. The
/// table has `len` values, the header text round-trips every value, and
/// `stored` (the table soupray parsed from the header) is what the
/// generator makes now.
pub fn assert_generated_table(
    fresh: &[f32],
    len: usize,
    header: &str,
    text: impl Fn(&[f32]) -> String,
    stored: &[f32],
) {
    let path = repo().join(header);
    if std::env::var_os("SOUPRAY_REGENERATE").is_some() {
        std::fs::write(&path, text(fresh)).unwrap();
    }
    assert_eq!(fresh.len(), len);
    assert_eq!(soupray::trace::energy::parse_header(&text(fresh)), fresh);
    assert_eq!(
        stored, fresh,
        "{header} is stale: rerun with SOUPRAY_REGENERATE=1"
    );
}

/// `v` in a new device buffer.
pub fn upload<T: Copy>(d: &Device, v: &[T]) -> opencl3::memory::Buffer<T> {
    let mut b = d.buffer::<T>(v.len()).unwrap();
    d.write(&mut b, v).unwrap();
    b
}

/// Runs a probe kernel `k(in, out, n)` over `n` cases, one work item each:
/// uploads `input` and reads `out_len` outputs back.
pub fn run_probe<I: Copy, O: Copy + Default>(
    d: &Device,
    k: &opencl3::kernel::Kernel,
    input: &[I],
    n: usize,
    out_len: usize,
) -> Vec<O> {
    use soupray::device::Arg;
    let inb = upload(d, input);
    let outb = upload(d, &vec![O::default(); out_len]);
    let args = [Arg::Buf(&inb), Arg::Buf(&outb), Arg::U32(n as u32)];
    d.launch("probe", k, n.div_ceil(64), 64, &args).unwrap();
    d.finish().unwrap();
    let mut got = vec![O::default(); out_len];
    d.read(&outb, &mut got).unwrap();
    got
}

/// A device value against its Rust twin's, within `rel` (relative) + 1e-6.
pub fn close(a: f32, b: f32, rel: f32, what: &str) {
    assert!(
        (a - b).abs() <= rel * a.abs().max(b.abs()) + 1e-6,
        "{what}: device {a} vs reference {b}"
    );
}

/// What the BSDF probe cases held, for the tests' coverage asserts.
#[derive(Default)]
pub struct BsdfProbeTally {
    pub sampled: usize,
    pub transmitted: usize,
    pub deltas: usize,
    pub only_delta: usize,
}

/// One case of `pt_probe.cl`'s BSDF probes (`o`: eval rgb, pdf, sample
/// flag, wi, f, pdf) against the Rust twin `trace::material` at `p`, `wo`,
/// `wi` and the sample's random numbers `u`, within `rel`.
#[allow(clippy::too_many_arguments)]
pub fn check_bsdf_probe(
    o: &[f32],
    p: &soupray::trace::material::BsdfParams,
    wo: glam::Vec3,
    wi: glam::Vec3,
    u: [f32; 3],
    rel: f32,
    what: &str,
    tally: &mut BsdfProbeTally,
) {
    use glam::Vec3;
    use soupray::trace::material::{bsdf_eval, bsdf_only_delta, bsdf_pdf, bsdf_sample};
    let f = bsdf_eval(p, wo, wi);
    for k in 0..3 {
        close(o[k], f[k], rel, &format!("eval {what}"));
    }
    close(o[3], bsdf_pdf(p, wo, wi), rel, &format!("pdf {what}"));
    match bsdf_sample(p, wo, u[0], u[1], u[2]) {
        Some(s) if s.delta => {
            // A delta lobe: the exact direction, its reflectance over
            // |wi.z| and the lobe's probability (bsdf_pdf is 0 there).
            assert_eq!(o[4], 2.0, "sample {what}: the device's was no delta lobe");
            for k in 0..3 {
                close(o[5 + k], s.wi[k], rel, &format!("delta wi {what}"));
                close(o[8 + k], s.f[k], rel, &format!("delta f {what}"));
            }
            close(o[11], s.pdf, rel, &format!("delta pdf {what}"));
            // Only the non-delta lobes count in eval and pdf: none at all
            // when every lobe is a delta lobe.
            if bsdf_only_delta(p) {
                // (The diffuse lobe's probability 1 - ps - pt rounds to
                // ~1e-10 rather than 0.)
                assert!(bsdf_pdf(p, wo, s.wi) < 1e-6, "delta pdf {what}");
                assert_eq!(bsdf_eval(p, wo, s.wi), Vec3::ZERO, "delta eval {what}");
                tally.only_delta += 1;
            }
            tally.deltas += 1;
            tally.sampled += 1;
            tally.transmitted += (s.wi.z < 0.0) as usize;
        }
        Some(s) => {
            assert_eq!(o[4], 1.0, "sample {what}: the device produced none");
            for k in 0..3 {
                close(o[5 + k], s.wi[k], rel, &format!("sampled wi {what}"));
            }
            // Sharp lobes amplify ulp differences of wi into the pdf, so pdf
            // and f are compared at the device's direction.
            let dwi = Vec3::new(o[5], o[6], o[7]);
            close(
                o[11],
                bsdf_pdf(p, wo, dwi),
                rel,
                &format!("sampled pdf {what}"),
            );
            let f = bsdf_eval(p, wo, dwi);
            for k in 0..3 {
                close(o[8 + k], f[k], rel, &format!("sampled f {what}"));
            }
            tally.sampled += 1;
            tally.transmitted += (s.wi.z < 0.0) as usize;
        }
        None => assert_eq!(o[4], 0.0, "sample {what}: only the device produced one"),
    }
}

/// The directional albedo of the Rust reference BSDF at `p` for outgoing
/// cosine `mu`, by stratified sampling of its own sampler (lobe choice
/// stratified too); transmitted samples are counted times `scale_t` (eta^2
/// undoes the radiance scaling of a refraction, for the energy balance).
pub fn albedo(p: &soupray::trace::material::BsdfParams, mu: f32, scale_t: f32) -> f64 {
    albedo_at(p, glam::Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu), scale_t)
}

/// `albedo` for the outgoing direction `wo` (unit, above the surface), for
/// the lobes that are not symmetric about the normal.
pub fn albedo_at(p: &soupray::trace::material::BsdfParams, wo: glam::Vec3, scale_t: f32) -> f64 {
    use soupray::trace::material::bsdf_sample;
    let n = 64;
    let mut sum = 0.0f64;
    for l in 0..n {
        for i in 0..n {
            for j in 0..n {
                let lobe = (l as f32 + 0.5) / n as f32;
                let (u1, u2) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
                if let Some(s) = bsdf_sample(p, wo, lobe, u1, u2) {
                    let k = if s.wi.z < 0.0 { scale_t } else { 1.0 };
                    sum += (s.f.x * s.wi.z.abs() / s.pdf * k) as f64;
                }
            }
        }
    }
    sum / (n * n * n) as f64
}

/// The full-sphere albedo of the Rust reference at outgoing cosine `mu`, by
/// midpoint quadrature of eval times |cos| over both hemispheres: (above,
/// below).
pub fn sphere_albedo(p: &soupray::trace::material::BsdfParams, mu: f32) -> (f64, f64) {
    sphere_albedo_at(p, glam::Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu))
}

/// `sphere_albedo` for the outgoing direction `wo` (unit, above).
pub fn sphere_albedo_at(p: &soupray::trace::material::BsdfParams, wo: glam::Vec3) -> (f64, f64) {
    use glam::Vec3;
    use soupray::trace::material::bsdf_eval;
    let (nc, np) = (256, 256);
    let (mut up, mut down) = (0.0f64, 0.0f64);
    for i in 0..nc {
        let c = (i as f64 + 0.5) / nc as f64;
        let s = (1.0 - c * c).sqrt();
        for j in 0..np {
            let ph = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
            let (x, y) = ((s * ph.cos()) as f32, (s * ph.sin()) as f32);
            up += bsdf_eval(p, wo, Vec3::new(x, y, c as f32)).x as f64 * c;
            down += bsdf_eval(p, wo, Vec3::new(x, y, -c as f32)).x as f64 * c;
        }
    }
    let k = 2.0 * std::f64::consts::PI / (nc * np) as f64;
    (up * k, down * k)
}

/// The first twelve floats of the dielectric BSDF probes (`bsdf_ext_probe`,
/// `bsdf_layer_probe`): base rgb, metallic, alpha, specular, F0 red,
/// transmission, eta, thin (1 or 0), F0 green, F0 blue.
pub fn dielectric_probe_params(
    p: &soupray::trace::material::BsdfParams,
    dl: &soupray::trace::material::Dielectric,
) -> [f32; 12] {
    [
        p.base.x,
        p.base.y,
        p.base.z,
        p.metallic,
        p.alpha,
        p.specular,
        dl.f0_color.x,
        dl.transmission,
        dl.eta,
        if dl.thin { 1.0 } else { 0.0 },
        dl.f0_color.y,
        dl.f0_color.z,
    ]
}

/// `python3` with Blender 5 importable as `bpy` (`pip install bpy==5.0.1`;
/// `SOUPRAY_BPY_PATH` names a `pip install --target` folder): a maker of
/// such commands, or `None` where it is not installed.
pub fn bpy_python() -> Option<fn() -> Command> {
    fn python() -> Command {
        let mut cmd = Command::new("python3");
        if let Some(p) = std::env::var_os("SOUPRAY_BPY_PATH") {
            cmd.env("PYTHONPATH", p);
        }
        cmd
    }
    let found = python()
        .args(["-c", "import bpy; assert bpy.app.version >= (5, 0, 0)"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .status()
        .is_ok_and(|s| s.success());
    found.then_some(python as fn() -> Command)
}

/// Runs `soupray render FILE --width W --height H --out OUT --name NAME`
/// with `args` after them; the EXR written (frame-numbered names are the
/// caller's to resolve). Panics with soupray's message when it fails.
pub fn render_exr(
    file: &Path,
    (width, height): (u32, u32),
    out: &Path,
    name: &str,
    args: &[&str],
) -> PathBuf {
    let (w, h) = (width.to_string(), height.to_string());
    let mut all = vec![
        "render",
        file.to_str().expect("a UTF-8 path"),
        "--width",
        &w,
        "--height",
        &h,
        "--out",
        out.to_str().expect("a UTF-8 path"),
        "--name",
        name,
    ];
    all.extend_from_slice(args);
    let run = soupray(&all);
    assert!(
        run.status.success(),
        "soupray {}: {}",
        all.join(" "),
        String::from_utf8_lossy(&run.stderr)
    );
    out.join(name)
}
