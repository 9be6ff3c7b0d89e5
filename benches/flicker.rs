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
//! The shot [`--scene`, BoxAnimated] is filmed by the default camera, which
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

use soupray::compare;
use soupray::film::Image;
use std::path::{Path, PathBuf};
use std::process::Command;

struct Opts {
    width: u32,
    height: u32,
    first: i64,
    last: i64,
    spp: u32,
    threshold: f32,
    ref_spp: u32,
    scene: PathBuf,
    out: PathBuf,
    fresh_refs: bool,
}

fn parse() -> Result<Opts, String> {
    let mut o = Opts {
        width: 480,
        height: 270,
        first: 10,
        last: 17,
        spp: 16,
        threshold: 0.07,
        ref_spp: 1024,
        scene: PathBuf::from("tests/assets/BoxAnimated/BoxAnimated.glb"),
        out: PathBuf::from("out/bench-flicker"),
        fresh_refs: false,
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let mut i = 0;
    while i < args.len() {
        let flag = args[i].as_str();
        // cargo bench passes --bench to harness-less benches.
        if flag == "--bench" {
            i += 1;
            continue;
        }
        if flag == "--fresh-refs" {
            o.fresh_refs = true;
            i += 1;
            continue;
        }
        let v = args
            .get(i + 1)
            .ok_or_else(|| format!("{flag} needs a value"))?;
        let bad = |what: &str| format!("{flag} {v}: expected {what}");
        match flag {
            "--size" => {
                let (w, h) = v.split_once('x').ok_or_else(|| bad("WxH"))?;
                o.width = w.parse().map_err(|_| bad("WxH"))?;
                o.height = h.parse().map_err(|_| bad("WxH"))?;
            }
            "--frames" => {
                let (a, b) = v.split_once('-').ok_or_else(|| bad("A-B"))?;
                o.first = a.parse().map_err(|_| bad("A-B"))?;
                o.last = b.parse().map_err(|_| bad("A-B"))?;
                if o.last <= o.first {
                    return Err(bad("A-B with B > A"));
                }
            }
            "--spp" => o.spp = v.parse().map_err(|_| bad("a number"))?,
            "--threshold" => o.threshold = v.parse().map_err(|_| bad("a number"))?,
            "--ref-spp" => o.ref_spp = v.parse().map_err(|_| bad("a number"))?,
            "--scene" => o.scene = PathBuf::from(v),
            "--out" => o.out = PathBuf::from(v),
            _ => return Err(format!("unknown flag {flag}")),
        }
        i += 2;
    }
    Ok(o)
}

/// Renders frames first..=last into `dir`; returns their images.
fn render(o: &Opts, flags: &[String], seed: u32, dir: &Path) -> Result<Vec<Image>, String> {
    let _ = std::fs::remove_dir_all(dir);
    let out = Command::new(env!("CARGO_BIN_EXE_soupray"))
        .arg("render")
        .arg(&o.scene)
        .args(["--quiet", "--name", "img.####.exr"])
        .args(["--frames", &format!("{}-{}", o.first, o.last)])
        .args(["--width", &o.width.to_string()])
        .args(["--height", &o.height.to_string()])
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
    (o.first..=o.last)
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

fn main() {
    let o = match parse() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("bench flicker: {e}");
            std::process::exit(2);
        }
    };
    let ref_dir = o.out.join("refs").join(format!(
        "{}-{}x{}-{}-{}-spp{}",
        o.scene.file_stem().unwrap_or_default().to_string_lossy(),
        o.width,
        o.height,
        o.first,
        o.last,
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
        o.scene.display(),
        o.first,
        o.last,
        o.width,
        o.height,
        still_share * 100.0,
        o.ref_spp
    );
    std::fs::create_dir_all(&o.out).unwrap();
    std::fs::write(o.out.join("results.md"), table + "\n").unwrap();
}
