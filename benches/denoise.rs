//! `--denoise` against raw sample counts: error against a high-spp
//! reference, and time.
//!
//!   cargo bench --bench denoise
//!   cargo bench --bench denoise -- --size 320x180 --ref-spp 1024 --scenes cesium
//!
//! Flags (defaults in brackets): `--size WxH` [640x360], `--ref-spp N`
//! [4096], `--raw LIST` [16,64,256] (raw spp), `--denoised LIST` [4,16]
//! (spp with `--denoise`), `--qualities LIST` [high,fast]
//! (`--denoise-quality`), `--scenes LIST` [cesium,beast-sun,nefertiti-sun],
//! `--out DIR` [out/bench-denoise], `--fresh-refs`.
//!
//! Scenes: `cesium` is frame 10 of CesiumMan (shared folder) as `soupray
//! render` renders it; `MESH-LIGHTING` is a clay scan scene that
//! `cargo bench --bench cycles -- --scenes-only` writes to
//! out/bench-cycles/scenes/ (frame 0, `--clay`, sky radiance 1 for `sky`,
//! 0.1 under the sun for `sun`, as that bench renders them); a scene whose
//! file is missing is skipped with a note.
//!
//! Each configuration is rendered by the release `soupray render` (seed 0;
//! the reference with seed 1 at `--ref-spp`, cached under OUT/refs/ by
//! scene, size and spp: `--fresh-refs` after a change to the renderer)
//! and compared with the reference: mean FLIP and relative MSE
//! (`soupray::compare`, exposure 0). `time` is the frame log's
//! `timings_ms.trace + timings_ms.denoise` (path tracing, plus OIDN's
//! upload, three filters and readback, filter set-up included: one frame
//! per process); `total` is `timings_ms.total` (evaluation, BVH build,
//! trace, denoise, EXR write). Prints a Markdown table and writes
//! OUT/results.md and OUT/results.csv. Without OIDN the denoised rows are
//! skipped with a note.

mod support;

use soupray::compare;
use soupray::film::Image;
use std::path::{Path, PathBuf};

struct Opts {
    width: u32,
    height: u32,
    ref_spp: u32,
    raw: Vec<u32>,
    denoised: Vec<u32>,
    qualities: Vec<String>,
    scenes: Vec<String>,
    out: PathBuf,
    fresh_refs: bool,
}

fn parse() -> Result<Opts, String> {
    let mut o = Opts {
        width: 640,
        height: 360,
        ref_spp: 4096,
        raw: vec![16, 64, 256],
        denoised: vec![4, 16],
        qualities: vec!["high".into(), "fast".into()],
        scenes: vec!["cesium".into(), "beast-sun".into(), "nefertiti-sun".into()],
        out: PathBuf::from("out/bench-denoise"),
        fresh_refs: false,
    };
    let args: Vec<String> = std::env::args().skip(1).collect();
    let list = |v: &str| -> Result<Vec<u32>, String> {
        v.split(',')
            .map(|x| x.trim().parse().map_err(|_| format!("not a number: {x}")))
            .collect()
    };
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
        match flag {
            "--size" => {
                let (w, h) = v.split_once('x').ok_or("--size WxH")?;
                o.width = w.parse().map_err(|_| "--size WxH")?;
                o.height = h.parse().map_err(|_| "--size WxH")?;
            }
            "--ref-spp" => o.ref_spp = v.parse().map_err(|_| "--ref-spp N")?,
            "--raw" => o.raw = list(v)?,
            "--denoised" => o.denoised = list(v)?,
            "--qualities" => o.qualities = v.split(',').map(str::to_string).collect(),
            "--scenes" => o.scenes = v.split(',').map(str::to_string).collect(),
            "--out" => o.out = PathBuf::from(v),
            _ => return Err(format!("unknown flag {flag}")),
        }
        i += 2;
    }
    Ok(o)
}

/// One frame at `spp` with `seed` and `extra` flags, by this build.
fn render(
    o: &Opts,
    scene: &Path,
    frame: &str,
    extra: &[String],
    spp: u32,
    seed: u32,
    dir: &Path,
) -> Result<support::Frame, String> {
    let mut args = vec![
        "--spp".to_owned(),
        spp.to_string(),
        "--seed".into(),
        seed.to_string(),
    ];
    args.extend_from_slice(extra);
    support::render_frame(
        env!("CARGO_BIN_EXE_soupray"),
        scene,
        frame,
        (o.width, o.height),
        &args,
        dir,
    )
}

/// R, G, B, A of an EXR (the denoised beauty of a `--denoise` frame).
fn read_exr(path: &Path) -> Result<Image, String> {
    soupray::output::read_exr_rgba(path).map_err(|e| format!("{}: {e}", path.display()))
}

fn main() {
    let o = match parse() {
        Ok(o) => o,
        Err(e) => {
            eprintln!("bench denoise: {e}");
            std::process::exit(2);
        }
    };
    let oidn = soupray::denoise::Denoiser::open(soupray::denoise::Quality::High);
    if let Err(e) = &oidn {
        eprintln!("bench denoise: no denoised rows: {e}");
    }
    let have_oidn = oidn.is_ok();
    drop(oidn);
    let header =
        "| scene | configuration | spp | FLIP | rel. MSE | time (s) | of raw 256 spp | total (s) |";
    let mut rows = vec![
        header.to_string(),
        "|---|---|---|---|---|---|---|---|".into(),
    ];
    let mut csv = vec!["scene,config,spp,flip,rel_mse,time_s,total_s".to_string()];
    for name in &o.scenes {
        let (scene, frame, extra) = match support::scene(name, "10") {
            Ok(s) => s,
            Err(e) => {
                eprintln!("bench denoise: {e}; skipped");
                continue;
            }
        };
        let refs = o.out.join("refs");
        let ref_dir = refs.join(format!("{name}-{}x{}-spp{}", o.width, o.height, o.ref_spp));
        let ref_exr = ref_dir.join(format!("img.{:0>4}.exr", frame));
        let reference = if ref_exr.exists() && !o.fresh_refs {
            read_exr(&ref_exr).unwrap()
        } else {
            eprintln!("bench denoise: {name}: reference at {} spp", o.ref_spp);
            render(&o, &scene, frame, &extra, o.ref_spp, 1, &ref_dir)
                .unwrap_or_else(|e| panic!("{e}"))
                .image
        };
        let mut configs: Vec<(String, u32, Vec<String>)> = o
            .raw
            .iter()
            .map(|&s| ("raw".to_string(), s, vec![]))
            .collect();
        if have_oidn {
            for q in &o.qualities {
                for &s in &o.denoised {
                    configs.push((
                        format!("--denoise ({q})"),
                        s,
                        vec!["--denoise".into(), "--denoise-quality".into(), q.clone()],
                    ));
                }
            }
        }
        let mut results = Vec::new();
        for (label, spp, flags) in &configs {
            let mut all = extra.clone();
            all.extend(flags.iter().cloned());
            let dir = o.out.join("runs").join(name);
            let r =
                render(&o, &scene, frame, &all, *spp, 0, &dir).unwrap_or_else(|e| panic!("{e}"));
            let e = compare::compare(&r.image, &reference, 0.0).unwrap();
            let t = (r.log.timings_ms.trace + r.log.timings_ms.denoise) / 1e3;
            eprintln!(
                "bench denoise: {name} {label} {spp} spp: FLIP {:.4}, rel. MSE {:.3e}, {t:.2} s",
                e.flip, e.rel_mse
            );
            results.push((label.clone(), *spp, e, t, r.log.timings_ms.total / 1e3));
        }
        let raw256 = results
            .iter()
            .find(|r| r.0 == "raw" && r.1 == 256)
            .map(|r| r.3);
        for (label, spp, e, t, total) in results {
            let share = raw256.map_or(String::new(), |b| format!("1/{:.1}", b / t));
            rows.push(format!(
                "| {name} | {label} | {spp} | {:.4} | {:.3e} | {t:.2} | {share} | {total:.2} |",
                e.flip, e.rel_mse
            ));
            csv.push(format!(
                "{name},{label},{spp},{},{},{t},{total}",
                e.flip, e.rel_mse
            ));
        }
    }
    let table = rows.join("\n");
    println!(
        "\nAgainst {} spp references at {}x{}:\n\n{table}",
        o.ref_spp, o.width, o.height
    );
    std::fs::create_dir_all(&o.out).unwrap();
    std::fs::write(o.out.join("results.md"), table + "\n").unwrap();
    std::fs::write(o.out.join("results.csv"), csv.join("\n") + "\n").unwrap();
}
