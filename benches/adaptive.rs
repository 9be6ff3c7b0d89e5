//! `--noise-threshold` against uniform sampling: the trace time each takes
//! to reach a given relative MSE, side by side in one run.
//!
//!   cargo bench --bench adaptive
//!   cargo bench --bench adaptive -- --scene beast-sun --runs 5 \
//!       --configs "u64;--noise-threshold 0.04;--noise-threshold 0.028 --min-spp 8"
//!
//! Flags (defaults in brackets): `--scene NAME` [cesium] (`cesium` is frame
//! 24 of CesiumMan from the shared folder; `MESH-LIGHTING` a scene that
//! `cargo bench --bench cycles -- --scenes-only` writes, frame 0: the
//! `sky` and `sun` scans `--clay` under a sky of 1 or of 0.1 and the sun,
//! `emitter` and `lamps` their materials and lights with no sky, the others
//! their materials under the sun and a sky of 0.1), `--size WxH` [640x360], `--ref-spp
//! N` [1024], `--max-spp N` [1024] (the adaptive renders' `--spp`),
//! `--runs N` [3], `--configs LIST` (`;`-separated: `uN [FLAGS]` is
//! uniform N spp, anything else the extra flags of an adaptive render; [u64 and the
//! default time rule at 0.022 and, with `--min-spp 8`, 0.016]; a leading
//! `@PATH` renders a configuration with another soupray binary, e.g. the
//! build a change replaces),
//! `--out DIR` [out/bench-adaptive].
//!
//! Each configuration is rendered by the release `soupray render` (seed 0;
//! the reference seed 77, cached under OUT/refs/), one process per frame,
//! the configurations interleaved round by round so that a change in the
//! machine's load falls on all of them. Per configuration: the relative MSE
//! against the reference, the image mean's offset from the reference's
//! (adaptive sampling's bias: stopping is correlated with the samples;
//! uniform's shows the reference's own noise), mean spp and rays (exact: the renders are
//! deterministic), every run's `timings_ms.trace` (device time of the
//! path-tracing launches, checks included), their median and its ratio to
//! the first configuration's median. Prints a Markdown table and writes
//! OUT/results.md.
//!
//! `--oracle K` instead bounds what any per-pixel allocation could reach:
//! K uniform renders of `--oracle-spp N` [64] samples (seeds 1..K) with
//! the `noise` and `rays` AOVs give each pixel's relative variance per
//! sample v (the mean of its squared error estimates, times N) and its rays
//! per sample c. Uniform N spp takes time N sum(c) for error sum(v) / N
//! (summed over pixels). For the same error, Cycles' equal-error rule
//! (samples in proportion to v) takes P sum(v c) / (sum(v) sum(c)) of
//! that, P the count of pixels with any variance (the others take none),
//! and the best allocation there is (samples in
//! proportion to sqrt(v / c), at least `m` in every pixel) takes
//! sum(n c) / (N sum(c)), n solved for the same error. Rays stand in for
//! time, and the square root of a noisy v makes the bound slightly
//! optimistic: no allocation does better than it.

mod support;

use soupray::compare;
use std::path::{Path, PathBuf};

struct Opts {
    scene: String,
    width: u32,
    height: u32,
    ref_spp: u32,
    max_spp: u32,
    runs: usize,
    configs: Vec<String>,
    out: PathBuf,
    oracle: usize,
    oracle_spp: u32,
}

fn parse() -> Result<Opts, String> {
    let mut o = Opts {
        scene: "cesium".into(),
        width: 640,
        height: 360,
        ref_spp: 1024,
        max_spp: 1024,
        runs: 3,
        configs: vec![
            "u64".into(),
            "--noise-threshold 0.022".into(),
            "--noise-threshold 0.016 --min-spp 8".into(),
        ],
        out: PathBuf::from("out/bench-adaptive"),
        oracle: 0,
        oracle_spp: 64,
    };
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        let mut value = || args.next().ok_or(format!("{a} needs a value"));
        match a.as_str() {
            "--scene" => o.scene = value()?,
            "--size" => {
                let v = value()?;
                let (w, h) = v
                    .split_once('x')
                    .ok_or(format!("--size {v}: expected WxH"))?;
                o.width = w.parse().map_err(|_| format!("--size {v}"))?;
                o.height = h.parse().map_err(|_| format!("--size {v}"))?;
            }
            "--ref-spp" => o.ref_spp = value()?.parse().map_err(|e| format!("{e}"))?,
            "--max-spp" => o.max_spp = value()?.parse().map_err(|e| format!("{e}"))?,
            "--runs" => o.runs = value()?.parse().map_err(|e| format!("{e}"))?,
            "--configs" => {
                o.configs = value()?
                    .split(';')
                    .map(|c| c.trim().to_owned())
                    .filter(|c| !c.is_empty())
                    .collect()
            }
            "--out" => o.out = PathBuf::from(value()?),
            "--oracle" => o.oracle = value()?.parse().map_err(|e| format!("{e}"))?,
            "--oracle-spp" => o.oracle_spp = value()?.parse().map_err(|e| format!("{e}"))?,
            // cargo bench passes --bench to every harness-less bench.
            "--bench" => {}
            _ => return Err(format!("unknown flag {a}")),
        }
    }
    if o.configs.is_empty() || o.runs == 0 {
        return Err("nothing to run: --configs and --runs must not be empty".into());
    }
    Ok(o)
}

/// A configuration's flags: `uN [FLAGS]` is uniform N spp (with FLAGS),
/// anything else adaptive flags on top of `--spp MAX`; a leading `@PATH`
/// renders it with that soupray binary instead of this build.
fn config_flags(o: &Opts, config: &str) -> Vec<String> {
    if let Some(rest) = config.strip_prefix('@') {
        let (binary, rest) = rest.split_once(' ').unwrap_or((rest, ""));
        let mut f = vec![format!("@{binary}")];
        f.extend(config_flags(o, rest));
        return f;
    }
    let mut words = config.split_whitespace();
    let first = words.next().unwrap_or("");
    match first.strip_prefix('u').and_then(|n| n.parse::<u32>().ok()) {
        Some(spp) => {
            let mut f = vec!["--spp".into(), spp.to_string()];
            f.extend(words.map(str::to_owned));
            f
        }
        None => {
            let mut f = vec!["--spp".into(), o.max_spp.to_string()];
            f.extend(config.split_whitespace().map(str::to_owned));
            f
        }
    }
}

/// One frame with `seed` and `flags` (a leading `@PATH`: by that build).
fn render(
    o: &Opts,
    (scene, frame, lighting): (&Path, &str, &[String]),
    flags: &[String],
    seed: u32,
    dir: &Path,
) -> Result<support::Frame, String> {
    // `@PATH` first: that build of soupray (the variant a change replaces).
    let (binary, flags) = match flags.split_first() {
        Some((first, rest)) if first.starts_with('@') => (first[1..].to_owned(), rest),
        _ => (env!("CARGO_BIN_EXE_soupray").to_owned(), flags),
    };
    let mut args = vec!["--seed".to_owned(), seed.to_string()];
    args.extend_from_slice(lighting);
    args.extend_from_slice(flags);
    support::render_frame(&binary, scene, frame, (o.width, o.height), &args, dir)
}

/// The mean over the pixels and RGB channels.
fn image_mean(image: &soupray::film::Image) -> f64 {
    let sum: f64 = image
        .rgba
        .iter()
        .map(|p| p[0] as f64 + p[1] as f64 + p[2] as f64)
        .sum();
    sum / (3 * image.rgba.len().max(1)) as f64
}

fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

fn run(o: &Opts) -> Result<String, String> {
    let (scene, frame, lighting) = support::scene(&o.scene, "24")?;
    let spec = (scene.as_path(), frame, lighting.as_slice());
    let ref_dir = o.out.join(format!(
        "refs/{}-{}x{}-{}",
        o.scene, o.width, o.height, o.ref_spp
    ));
    let ref_exr = ref_dir.join(format!("img.{frame:0>4}.exr"));
    let reference = if ref_exr.exists() {
        soupray::output::read_exr_rgba(&ref_exr).map_err(|e| format!("{e}"))?
    } else {
        eprintln!("reference: {} spp, seed 77", o.ref_spp);
        let flags = vec!["--spp".to_owned(), o.ref_spp.to_string()];
        render(o, spec, &flags, 77, &ref_dir)?.image
    };
    let mut times = vec![Vec::new(); o.configs.len()];
    let mut stats = vec![None; o.configs.len()];
    for round in 0..o.runs {
        for (i, config) in o.configs.iter().enumerate() {
            let r = render(
                o,
                spec,
                &config_flags(o, config),
                0,
                &o.out.join(format!("run{i}")),
            )?;
            let trace = r.log.timings_ms.trace;
            eprintln!("round {round} [{config}]: trace {trace:.0} ms");
            times[i].push(trace);
            if stats[i].is_none() {
                let mse =
                    compare::relative_mse(&r.image, &reference).map_err(|e| format!("{e:?}"))?;
                let bias = image_mean(&r.image) / image_mean(&reference) - 1.0;
                stats[i] = Some((mse, bias, r.log.noise.spp_mean, r.log.render.rays));
            }
        }
    }
    let base = median(&times[0]);
    let mut md = format!(
        "{} at {}x{} against {} spp of seed 77; trace ms of {} interleaved runs\n\n\
         | configuration | rel. MSE | mean vs ref. | mean spp | rays | trace ms (runs) | median | of {} |\n\
         |---|---:|---:|---:|---:|---|---:|---:|\n",
        o.scene, o.width, o.height, o.ref_spp, o.runs, o.configs[0]
    );
    for (i, config) in o.configs.iter().enumerate() {
        let (mse, bias, spp, rays) = stats[i].expect("rendered");
        let runs: Vec<String> = times[i].iter().map(|t| format!("{t:.0}")).collect();
        let m = median(&times[i]);
        md += &format!(
            "| {config} | {mse:.3e} | {:+.3}% | {spp:.1} | {:.2}M | {} | {m:.0} | {:.2} |\n",
            100.0 * bias,
            rays as f64 * 1e-6,
            runs.join(", "),
            m / base
        );
    }
    Ok(md)
}

/// A channel of an EXR that soupray wrote, as f32.
fn channel(path: &Path, name: &str) -> Result<Vec<f32>, String> {
    let image = exr::prelude::read_all_flat_layers_from_file(path)
        .map_err(|e| format!("{}: {e}", path.display()))?;
    let ch = image.layer_data[0]
        .channel_data
        .list
        .iter()
        .find(|c| c.name == *name)
        .ok_or(format!("{}: no channel {name}", path.display()))?;
    Ok(ch.sample_data.values_as_f32().collect())
}

/// The time (in rays) the best allocation with at least `min` samples per
/// pixel takes for uniform `spp`'s error, over uniform's time: n = max(min,
/// k sqrt(v / c)), k found by bisection so that sum(v / n) = sum(v) / spp.
fn optimal_ratio(v: &[f64], c: &[f64], spp: f64, min: f64) -> f64 {
    let target: f64 = v.iter().sum::<f64>() / spp;
    let error = |k: f64| -> f64 {
        v.iter()
            .zip(c)
            .map(|(&v, &c)| {
                let n = (k * (v / c.max(1e-9)).sqrt()).max(min);
                v / n
            })
            .sum()
    };
    let (mut lo, mut hi) = (0.0f64, 1.0f64);
    while error(hi) > target {
        hi *= 2.0;
        if hi > 1e30 {
            return f64::INFINITY; // the floor alone is above the target
        }
    }
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if error(mid) > target {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    let time: f64 = v
        .iter()
        .zip(c)
        .map(|(&v, &c)| (hi * (v / c.max(1e-9)).sqrt()).max(min) * c)
        .sum();
    time / (spp * c.iter().sum::<f64>())
}

fn oracle(o: &Opts) -> Result<String, String> {
    let (scene, frame, lighting) = support::scene(&o.scene, "24")?;
    let spec = (scene.as_path(), frame, lighting.as_slice());
    let n = o.oracle_spp as f64;
    let pixels = (o.width * o.height) as usize;
    let mut v = vec![0.0f64; pixels];
    let mut c = vec![0.0f64; pixels];
    for seed in 1..=o.oracle as u32 {
        let dir = o.out.join("oracle");
        let flags = vec![
            "--spp".to_owned(),
            o.oracle_spp.to_string(),
            "--aov".into(),
            "noise,rays".into(),
        ];
        render(o, spec, &flags, seed, &dir)?;
        let exr = dir.join(format!("img.{frame:0>4}.exr"));
        let (e, r) = (channel(&exr, "noise")?, channel(&exr, "rays")?);
        for i in 0..pixels {
            v[i] += (e[i] as f64).powi(2) * n / o.oracle as f64;
            c[i] += r[i] as f64 / n / o.oracle as f64;
        }
    }
    let (sv, sc): (f64, f64) = (v.iter().sum(), c.iter().sum());
    let svc: f64 = v.iter().zip(&c).map(|(v, c)| v * c).sum();
    // Equal error: n = v / e^2 in the pixels with any variance (none in
    // the others), e^2 such that the frame's mean is uniform's.
    let noisy = v.iter().filter(|&&v| v > 0.0).count() as f64;
    let equal_error = noisy * svc / (sv * sc);
    let mut md = format!(
        "{} at {}x{}: {} uniform renders of {} spp; time in rays, for uniform {4} spp's \
         error ({:.3e} estimated; {:.1}% of the pixels have any variance)\n\n\
         | allocation | of uniform's time |\n|---|---:|\n\
         | equal error (samples in proportion to v) | {equal_error:.2} |\n",
        o.scene,
        o.width,
        o.height,
        o.oracle,
        o.oracle_spp,
        sv / (pixels as f64 * n),
        100.0 * noisy / pixels as f64,
    );
    for min in [1.0, 4.0, 8.0, 16.0] {
        md += &format!(
            "| best, at least {min} spp | {:.2} |\n",
            optimal_ratio(&v, &c, n, min)
        );
    }
    Ok(md)
}

fn main() {
    let o = match parse() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("bench adaptive: {e}");
            std::process::exit(2);
        }
    };
    // A scene whose file is missing (CesiumMan without the shared folder)
    // skips the bench rather than failing it.
    if let Err(e) = support::scene(&o.scene, "24") {
        eprintln!("bench adaptive: {e}; skipped");
        return;
    }
    let result = if o.oracle > 0 { oracle(&o) } else { run(&o) };
    match result {
        Ok(md) => {
            println!("{md}");
            let _ = std::fs::create_dir_all(&o.out);
            if let Err(e) = std::fs::write(o.out.join("results.md"), &md) {
                eprintln!("bench adaptive: cannot write results.md: {e}");
            }
        }
        Err(e) => {
            eprintln!("bench adaptive: {e}");
            std::process::exit(1);
        }
    }
}
