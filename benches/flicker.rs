//! Temporal flicker: how much still regions of a static-camera shot change
//! from frame to frame, for raw, adaptive and denoised output, with a noise
//! pattern that changes per frame and with a fixed one (`--noise-pattern`).
//!
//!   cargo bench --bench flicker
//!   cargo bench --bench flicker -- --size 320x180 --frames 10-17 --spp 16
//!
//! Flags (defaults in brackets): `--scene FILE`, `--size WxH` [480x270], `--frames A-B`
//! [10-17], `--spp N` [16] (raw and denoised), `--threshold T` [0.07]
//! (adaptive, with `--spp 256`), `--ref-spp N` [1024], `--out DIR`
//! [out/bench-flicker], `--fresh-refs`.
//!
//! The shot [`--scene`, BoxAnimated, read in place from the shared folder;
//! without it the bench says so and skips] is filmed by the default camera, which
//! frames the whole clip and does not move: in BoxAnimated the inner box
//! rises out of the outer one, whose inside and walls stay still but are
//! lit by light that bounces off the moving box. Each frame gets a reference
//! at `--ref-spp` (seed 1, cached under OUT/refs/). A pixel is *still* when
//! geometry covers it in every frame (the empty background has no noise),
//! its reference changes between no two consecutive frames by more than 2%
//! of its value (+0.01), and no pixel within 2 of it moves.
//!
//! Per configuration, the frames are rendered by the release `soupray
//! render` (seed 0), and two numbers come out:
//! * flicker: the RMS of the frame-to-frame difference over still pixels,
//!   relative to their mean reference value (what a viewer sees crawl);
//! * error: the frames' mean relative MSE against their references (how
//!   noisy each frame is on its own).
//!
//! Prints a Markdown table and writes OUT/results.md. Without OIDN the
//! denoised rows are skipped with a note.

mod support;

use soupray::compare;
use soupray::film::Image;
use std::path::{Path, PathBuf};
use std::process::Command;

/// `WxH`, for `--size`.
fn parse_size(v: &str) -> Result<(u32, u32), String> {
    let (w, h) = v.split_once('x').ok_or("expected WxH")?;
    Ok((
        w.parse().map_err(|_| "expected WxH")?,
        h.parse().map_err(|_| "expected WxH")?,
    ))
}

/// `A-B` with B > A, for `--frames`.
fn parse_range(v: &str) -> Result<(i64, i64), String> {
    let (a, b) = v.split_once('-').ok_or("expected A-B")?;
    let (a, b): (i64, i64) = (
        a.parse().map_err(|_| "expected A-B")?,
        b.parse().map_err(|_| "expected A-B")?,
    );
    if b <= a {
        return Err("expected A-B with B > A".into());
    }
    Ok((a, b))
}

#[derive(clap::Parser)]
struct Opts {
    #[arg(long, value_parser = parse_size, default_value = "480x270")]
    size: (u32, u32),
    #[arg(long, value_parser = parse_range, default_value = "10-17")]
    frames: (i64, i64),
    /// Samples per pixel of the raw and denoised renders.
    #[arg(long, default_value_t = 16)]
    spp: u32,
    /// `--noise-threshold` of the adaptive renders (up to 256 spp).
    #[arg(long, default_value_t = 0.07)]
    threshold: f32,
    #[arg(long, default_value_t = 1024)]
    ref_spp: u32,
    /// Default: BoxAnimated from the shared folder (set in `main`).
    #[arg(long)]
    scene: Option<PathBuf>,
    #[arg(long, default_value = "out/bench-flicker")]
    out: PathBuf,
    #[arg(long)]
    fresh_refs: bool,
    /// Passed by `cargo bench`.
    #[arg(long, hide = true)]
    bench: bool,
}

/// Renders frames first..=last into `dir`; returns their images.
fn render(o: &Opts, flags: &[String], seed: u32, dir: &Path) -> Result<Vec<Image>, String> {
    let _ = std::fs::remove_dir_all(dir);
    let out = Command::new(env!("CARGO_BIN_EXE_soupray"))
        .arg("render")
        .arg(o.scene())
        .args(["--quiet", "--name", "img.####.exr"])
        .args(["--frames", &format!("{}-{}", o.frames.0, o.frames.1)])
        .args(["--width", &o.size.0.to_string()])
        .args(["--height", &o.size.1.to_string()])
        .args(["--seed", &seed.to_string()])
        .args(flags)
        .arg("--out")
        .arg(dir)
        .output()
        .map_err(|e| format!("cannot run soupray: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "soupray render {flags:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    read_frames(o, dir)
}

fn read_frames(o: &Opts, dir: &Path) -> Result<Vec<Image>, String> {
    (o.frames.0..=o.frames.1)
        .map(|f| {
            let p = dir.join(format!("img.{f:04}.exr"));
            soupray::output::read_exr_rgba(&p).map_err(|e| format!("{}: {e}", p.display()))
        })
        .collect()
}

fn value(p: [f32; 4]) -> f64 {
    (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0
}

/// Still pixels: covered by geometry in every reference (the empty
/// background has no noise to flicker), and the references change between
/// no two consecutive frames by more than 2% (+0.01), 2 pixels away from
/// any that does.
fn still_mask(refs: &[Image]) -> Vec<bool> {
    let (w, h) = (refs[0].width as i64, refs[0].height as i64);
    let n = (w * h) as usize;
    let mut moving = vec![false; n];
    for pair in refs.windows(2) {
        for (i, moved) in moving.iter_mut().enumerate() {
            let (a, b) = (value(pair[0].rgba[i]), value(pair[1].rgba[i]));
            let covered = pair[0].rgba[i][3] == 1.0 && pair[1].rgba[i][3] == 1.0;
            if !covered || (a - b).abs() > 0.02 * a.max(b) + 0.01 {
                *moved = true;
            }
        }
    }
    let mut still = vec![true; n];
    for y in 0..h {
        for x in 0..w {
            if !moving[(y * w + x) as usize] {
                continue;
            }
            for dy in -2..=2 {
                for dx in -2..=2 {
                    let (u, v) = (x + dx, y + dy);
                    if u >= 0 && v >= 0 && u < w && v < h {
                        still[(v * w + u) as usize] = false;
                    }
                }
            }
        }
    }
    still
}

/// The RMS frame-to-frame difference over still pixels, over their mean
/// reference value.
fn flicker(frames: &[Image], refs: &[Image], still: &[bool]) -> f64 {
    let (mut sum_sq, mut count, mut sum_ref) = (0.0, 0usize, 0.0);
    for (pair, r) in frames.windows(2).zip(refs) {
        for (i, &is_still) in still.iter().enumerate() {
            if is_still {
                let d = value(pair[1].rgba[i]) - value(pair[0].rgba[i]);
                sum_sq += d * d;
                sum_ref += value(r.rgba[i]);
                count += 1;
            }
        }
    }
    if count == 0 {
        return f64::NAN;
    }
    (sum_sq / count as f64).sqrt() / (sum_ref / count as f64)
}

impl Opts {
    /// The shot's scene (`main` fills in the default).
    fn scene(&self) -> &Path {
        self.scene.as_deref().expect("main sets the scene")
    }
}

fn main() {
    let mut o = <Opts as clap::Parser>::parse();
    if o.scene.is_none() {
        match support::sample("BoxAnimated/BoxAnimated.glb") {
            Ok(path) => o.scene = Some(path),
            Err(e) => {
                eprintln!("bench flicker: skipped: {e}");
                return;
            }
        }
    }
    let ref_dir = o.out.join("refs").join(format!(
        "{}-{}x{}-{}-{}-spp{}",
        o.scene().file_stem().unwrap_or_default().to_string_lossy(),
        o.size.0,
        o.size.1,
        o.frames.0,
        o.frames.1,
        o.ref_spp
    ));
    let refs = match read_frames(&o, &ref_dir) {
        Ok(r) if !o.fresh_refs => r,
        _ => {
            eprintln!("bench flicker: references at {} spp", o.ref_spp);
            let flags = vec!["--spp".to_string(), o.ref_spp.to_string()];
            render(&o, &flags, 1, &ref_dir).unwrap_or_else(|e| panic!("{e}"))
        }
    };
    let still = still_mask(&refs);
    let still_share = still.iter().filter(|&&s| s).count() as f64 / still.len() as f64;
    let have_oidn = match soupray::denoise::Denoiser::open(soupray::denoise::Quality::High) {
        Ok(_) => true,
        Err(e) => {
            eprintln!("bench flicker: no denoised rows: {e}");
            false
        }
    };
    let spp = o.spp.to_string();
    let mut outputs: Vec<(String, Vec<String>)> = vec![
        (format!("raw, {spp} spp"), vec!["--spp".into(), spp.clone()]),
        (
            format!("adaptive, threshold {}", o.threshold),
            vec![
                "--noise-threshold".into(),
                o.threshold.to_string(),
                "--spp".into(),
                "256".into(),
            ],
        ),
    ];
    if have_oidn {
        outputs.push((
            format!("denoised, {spp} spp"),
            vec!["--spp".into(), spp.clone(), "--denoise".into()],
        ));
    }
    let mut rows = vec![
        "| output | noise pattern | flicker (still regions) | error (rel. MSE) |".to_string(),
        "|---|---|---|---|".into(),
    ];
    for (label, flags) in &outputs {
        for pattern in ["per-frame", "fixed"] {
            let mut all = flags.clone();
            all.extend(["--noise-pattern".to_string(), pattern.to_string()]);
            let dir = o.out.join("runs");
            let frames = render(&o, &all, 0, &dir).unwrap_or_else(|e| panic!("{e}"));
            let f = flicker(&frames, &refs, &still);
            let err = frames
                .iter()
                .zip(&refs)
                .map(|(a, r)| compare::compare(a, r, 0.0).unwrap().rel_mse)
                .sum::<f64>()
                / frames.len() as f64;
            eprintln!("bench flicker: {label}, {pattern}: flicker {f:.4}, rel. MSE {err:.3e}");
            rows.push(format!("| {label} | {pattern} | {f:.4} | {err:.3e} |"));
        }
    }
    let table = rows.join("\n");
    println!(
        "\n{}, frames {}-{} at {}x{}, {:.1}% of the pixels still, against {}-spp references:\n\n{table}",
        o.scene().display(),
        o.frames.0,
        o.frames.1,
        o.size.0,
        o.size.1,
        still_share * 100.0,
        o.ref_spp
    );
    std::fs::create_dir_all(&o.out).unwrap();
    std::fs::write(o.out.join("results.md"), table + "\n").unwrap();
}
