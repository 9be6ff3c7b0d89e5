//! soupray against Blender Cycles, side by side: error against time on the
//! same scenes, each renderer against its own converged reference.
//!
//!   cargo bench --bench cycles
//!   cargo bench --bench cycles -- --size 96x64 --ref-spp 256 --spp 4,16 --meshes beast
//!
//! Flags (defaults in brackets): `--size WxH` [384x256], `--spp LIST`
//! [16,64,256], `--ref-spp N` [4096], `--meshes LIST` [beast,nefertiti],
//! `--lightings LIST` [sky,sun], `--samplers LIST` [sobol,random] (soupray's
//! `--sampler`; a soupray without that flag gets one variant, `default`),
//! `--max-depth N` [8], `--threads N` [all cores] (Cycles' threads; soupray
//! uses the whole OpenCL device), `--out DIR` [out/bench-cycles],
//! `--fresh-refs` (render the references again), `--scenes-only` (write the
//! scenes and stop). `BLENDER=PATH` picks the Blender binary (default:
//! `blender` on PATH; without one the bench says so and exits 0). Blender's
//! glTF importer needs numpy in Blender's Python, which Debian's `blender`
//! package does not pull in: `apt-get install blender python3-numpy`.
//!
//! What it does: writes glTF 2.0 scenes from the scanned meshes
//! (the shared folder's meshes/*.ply, read in place) standing on a ground quad, a camera framing
//! each, every material a 0.8 grey Lambertian, in two lightings: `sky`
//! (constant white sky of radiance 1, no lights) and `sun` (a 3 lux
//! KHR_lights_punctual directional light, oblique so the mesh casts a
//! shadow, plus a sky of radiance 0.1). Each scene is rendered by soupray
//! (`soupray render --clay --env-color …`, once per sampler) and by Cycles
//! (`blender -b -P benches/cycles/render_cycles.py`, which translates the
//! scene like for like: Diffuse BSDF 0.8, constant world, sun strength =
//! lux, angle 0, no clamping/denoising/adaptive sampling, bounces = depth -
//! 1, Blackman-Harris 1.5 px like soupray) at every `--spp`, and each is
//! compared with its own renderer's reference at `--ref-spp` (another
//! seed) by relative MSE (`soupray::compare::relative_mse`). The two
//! references must agree on the mean brightness within 3% (printed), or the
//! translation is wrong. References are cached under `OUT/refs/`, keyed by
//! every setting and a hash of the scene (and, for Cycles, of the script
//! and Blender's version; for soupray, of its rendering code: `kernels/`,
//! `src/trace/`, `src/film.rs`); a rerun reuses them, `--fresh-refs`
//! renders them again (after a change elsewhere that alters the image).
//! Prints a Markdown table and writes `OUT/results.csv`, `OUT/results.md`,
//! the references' means `OUT/references.csv` and their previews
//! `OUT/previews/*.png`.
//!
//! Timing caveats:
//! * soupray `time` is the frame log's `timings_ms.trace`: path tracing
//!   and film accumulation only, after the device BVH build; `total` is
//!   `timings_ms.total` (scene evaluation, BVH build, trace, EXR write),
//!   still without process start, OpenCL set-up and kernel compilation.
//!   An untimed 1-spp render per scene and sampler runs first, so that
//!   PoCL's first-launch kernel compilation is not in a trace time.
//! * Cycles `time` is the wall time of `bpy.ops.render.render` in the
//!   script: it includes Cycles' scene sync and Embree BVH build (about
//!   0.1 s here), but not Blender's start-up, the glTF import or the EXR
//!   write. One untimed 1-spp render runs first in each Blender process
//!   so that one-time initialisation is not counted. `sampling` is Cycles'
//!   path tracing alone, from its first sample to `Finished` in Blender's
//!   status lines (10 ms resolution, so meaningless on tiny images); for
//!   soupray it is the trace time again.
//! * The product rel. MSE x time is inverse efficiency (lower is better);
//!   the ratio column is soupray's product over Cycles' at the same spp
//!   (below 1: soupray reaches a given error sooner). Each renderer is
//!   measured against its own reference, so a bias of one renderer against
//!   the other is not in the MSE (the reference check above covers it).
//!   Cycles 3.4 samples with its default pattern (progressive
//!   multi-jitter); soupray with each of `--samplers`.
//! * Both run on the same CPU: soupray through PoCL on every core, Cycles
//!   with `--threads` threads. Run it on a quiet machine: with anything
//!   else running, the times (not the errors) mean little.

#[path = "../support/mod.rs"]
mod support;

mod opts;
mod references;
mod renderers;
mod report;
mod scenes;

use opts::{parse_opts, Opts, USAGE};
use references::{cached_reference, mean_rgb, source_hash};
use renderers::{find_on_path, run_logged, Cycles, Job, Soupray};
use report::{date, fmt_sci, machine, Row};
use scenes::{fnv1a, mesh_spec, write_scenes, SceneFile, FNV_START};
use soupray::film::Image;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};
use std::time::Instant;

/// Seed of the timed renders, and of the references (different, so a
/// render and its reference share no random numbers).
const TEST_SEED: u64 = 1;
const REF_SEED: u64 = 1000;
/// The sun: irradiance (lux, as soupray reads it) and the constant sky under it.
const SUN_LUX: f32 = 3.0;
const SUN_SKY: f32 = 0.1;
/// How far the two references' mean brightness may differ.
const MEAN_TOLERANCE: f64 = 0.03;
/// Bump when the scene generation or the cache layout changes.
const SCENE_VERSION: u32 = 1;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let o = match parse_opts(&args) {
        Ok(o) => o,
        Err(e) if e.is_empty() => {
            println!("{USAGE}");
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("cycles bench: {e}\n{USAGE}");
            return ExitCode::from(2);
        }
    };
    match run(&o, &args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("cycles bench: error: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The bench, step by step: the scenes, the two renderers, then per scene
/// the references and the timed renders, and last the report.
fn run(o: &Opts, args: &[String]) -> Result<(), String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scenes_dir = o.out.join("scenes");
    let scenes = write_all_scenes(o, &scenes_dir)?;
    if o.scenes_only {
        println!("scenes written to {}", scenes_dir.display());
        return Ok(());
    }

    let blender = match std::env::var_os("BLENDER") {
        Some(b) => Some(PathBuf::from(b)),
        None => find_on_path("blender"),
    };
    let Some(blender) = blender else {
        println!(
            "cycles bench: skipped: Blender (`blender`) is not on PATH, and the bench compares \
             soupray with Blender's Cycles.\nInstall it (Debian/Ubuntu: `apt-get install blender python3-numpy`) \
             or point BLENDER=/path/to/blender at one, then run `cargo bench --bench cycles` again."
        );
        return Ok(());
    };
    let (cycles, script_hash) = cycles_renderer(root, blender)?;
    let (soupray, samplers) = soupray_renderer(o)?;
    let code_hash = source_hash(&[
        root.join("kernels"),
        root.join("src/trace"),
        root.join("src/film.rs"),
    ])?;

    let command = bench_command(args);
    let spp_list = o
        .spp
        .iter()
        .map(u32::to_string)
        .collect::<Vec<_>>()
        .join(",");
    eprintln!(
        "soupray vs {}: {}x{}, spp {spp_list}, references {} spp, depth {}, {} Cycles threads",
        cycles.version, o.width, o.height, o.ref_spp, o.max_depth, o.threads
    );

    let previews = o.out.join("previews");
    std::fs::create_dir_all(&previews).map_err(|e| format!("{}: {e}", previews.display()))?;
    let bench = Bench {
        o,
        soupray,
        cycles,
        samplers,
        code_hash,
        script_hash,
        previews,
        spp_list,
    };
    let mut results = Results {
        rows: Vec::new(),
        ref_lines: Vec::new(),
        ref_csv: String::from(
            "mesh,lighting,soupray_mean,cycles_mean,difference,cross_rel_mse,soupray_ref_time_s,cycles_ref_time_s\n",
        ),
        mismatches: Vec::new(),
        device: None,
    };
    for mesh in o.meshes.iter().filter(|m| scenes.contains_key(*m)) {
        for lighting in &o.lightings {
            bench.scene(mesh, lighting, &scenes[mesh][lighting], &mut results)?;
        }
    }
    bench.report(&command, &results)
}

/// Writes the scenes of every mesh under `scenes_dir`; a mesh missing from
/// the shared folder skips its rows.
fn write_all_scenes(
    o: &Opts,
    scenes_dir: &Path,
) -> Result<BTreeMap<String, BTreeMap<String, SceneFile>>, String> {
    std::fs::create_dir_all(scenes_dir).map_err(|e| format!("{}: {e}", scenes_dir.display()))?;
    let mut scenes = BTreeMap::new();
    for mesh in &o.meshes {
        // A mesh missing from the shared folder skips its rows.
        if let Err(e) = support::mesh_path(mesh_spec(mesh).expect("checked").file) {
            eprintln!("cycles bench: {mesh}: {e}; skipped");
            continue;
        }
        scenes.insert(mesh.clone(), write_scenes(o, mesh, scenes_dir)?);
    }
    Ok(scenes)
}

/// Cycles through `blender`, and the hash of its script (part of the
/// references' cache key).
fn cycles_renderer(root: &Path, blender: PathBuf) -> Result<(Cycles, u64), String> {
    let version = run_logged(
        Command::new(&blender).args(["-b", "--factory-startup", "--version"]),
        "blender --version",
    )?
    .lines()
    .find(|l| l.starts_with("Blender "))
    .unwrap_or("Blender (unknown version)")
    .trim()
    .to_owned();
    let script = root.join("benches/cycles/render_cycles.py");
    let script_hash = fnv1a(
        FNV_START,
        &std::fs::read(&script).map_err(|e| format!("{}: {e}", script.display()))?,
    );
    let cycles = Cycles {
        blender,
        script,
        version,
    };
    Ok((cycles, script_hash))
}

/// This build's soupray binary, and the sampler variants it is run with
/// (one, `default`, when its `render` has no `--sampler`).
fn soupray_renderer(o: &Opts) -> Result<(Soupray, Vec<String>), String> {
    let exe = PathBuf::from(env!("CARGO_BIN_EXE_soupray"));
    let help = run_logged(
        Command::new(&exe).args(["render", "--help"]),
        "soupray render --help",
    )?;
    let has_sampler = help.contains("--sampler");
    let samplers: Vec<String> = if has_sampler {
        o.samplers.clone()
    } else {
        println!(
            "note: this soupray's `render` has no --sampler yet; one soupray variant, `default`, \
             with its built-in sampler (--samplers {} ignored)",
            o.samplers.join(",")
        );
        vec!["default".into()]
    };
    Ok((Soupray { exe, has_sampler }, samplers))
}

/// The command that reproduces this run, for the report.
fn bench_command(args: &[String]) -> String {
    let rest: Vec<&str> = args
        .iter()
        .map(String::as_str)
        .filter(|a| *a != "--bench")
        .collect();
    if rest.is_empty() {
        "cargo bench --bench cycles".to_owned()
    } else {
        format!("cargo bench --bench cycles -- {}", rest.join(" "))
    }
}

/// What every scene's renders share: the options, the renderers, the
/// references' cache keys and where the previews go.
struct Bench<'a> {
    o: &'a Opts,
    soupray: Soupray,
    cycles: Cycles,
    samplers: Vec<String>,
    code_hash: u64,
    script_hash: u64,
    previews: PathBuf,
    spp_list: String,
}

/// What the scenes' runs add up to, for the report.
struct Results {
    rows: Vec<Row>,
    /// The references' table rows and CSV.
    ref_lines: Vec<String>,
    ref_csv: String,
    /// The scenes whose references disagree on the mean brightness.
    mismatches: Vec<String>,
    /// soupray's OpenCL device, from the first frame log.
    device: Option<String>,
}

impl Bench<'_> {
    /// One scene in one lighting: both references, then the timed renders
    /// of each renderer against its own.
    fn scene(
        &self,
        mesh: &String,
        lighting: &String,
        scene: &SceneFile,
        results: &mut Results,
    ) -> Result<(), String> {
        let o = self.o;
        let env = if lighting == "sun" { SUN_SKY } else { 1.0 };
        let tag = format!("{mesh}-{lighting}");
        eprintln!("{tag} ({} triangles): references…", scene.triangles);

        let ref_job = Job {
            scene: &scene.path,
            env,
            seed: REF_SEED,
        };
        let job = Job {
            seed: TEST_SEED,
            ..ref_job
        };
        let (s_ref, c_ref) = self.references(mesh, lighting, scene, &ref_job, results)?;
        self.soupray_renders(mesh, lighting, &job, &s_ref, results)?;
        eprintln!("  Cycles {} spp…", self.spp_list);
        let dir = o.out.join("renders").join(&tag).join("cycles");
        let renders = self.cycles.render(o, &job, &o.spp, &dir)?;
        for (&spp, r) in o.spp.iter().zip(renders) {
            results.rows.push(Row {
                mesh: mesh.clone(),
                lighting: lighting.clone(),
                spp,
                renderer: "cycles",
                variant: "cycles".into(),
                rel_mse: soupray::compare::relative_mse(&r.image, &c_ref)
                    .map_err(|e| e.to_string())?,
                time: r.time,
                total: r.total,
                sampling: r.sampling,
            });
        }
        Ok(())
    }

    /// soupray's and Cycles' references of the scene (cached), their
    /// previews, and how far they agree.
    fn references(
        &self,
        mesh: &String,
        lighting: &String,
        scene: &SceneFile,
        ref_job: &Job,
        results: &mut Results,
    ) -> Result<(Image, Image), String> {
        let (o, soupray, cycles) = (self.o, &self.soupray, &self.cycles);
        let (code_hash, script_hash) = (self.code_hash, self.script_hash);
        let tag = format!("{mesh}-{lighting}");
        let common = format!(
            "{tag}-{}x{}-spp{}-seed{REF_SEED}-depth{}-scene{:016x}",
            o.width, o.height, o.ref_spp, o.max_depth, scene.hash
        );
        // soupray's reference: the first sampler variant.
        let ref_variant = self.samplers[0].clone();
        let t = Instant::now();
        let (s_ref, s_ref_time, s_cached) = cached_reference(
            o,
            &o.out.join("refs").join(format!(
                "soupray-{ref_variant}-{common}-code{code_hash:016x}"
            )),
            |dir| soupray.render(o, ref_job, &ref_variant, o.ref_spp, dir),
        )?;
        eprintln!(
            "  soupray reference ({ref_variant}): {}",
            if s_cached {
                "cached".to_owned()
            } else {
                format!("{:.1} s", t.elapsed().as_secs_f64())
            }
        );
        let t = Instant::now();
        let (c_ref, c_ref_time, c_cached) = cached_reference(
            o,
            &o.out.join("refs").join(format!(
                "cycles-{common}-threads{}-script{script_hash:016x}-{:016x}",
                o.threads,
                fnv1a(FNV_START, cycles.version.as_bytes())
            )),
            |dir| {
                cycles
                    .render(o, ref_job, &[o.ref_spp], dir)
                    .map(|mut v| v.remove(0))
            },
        )?;
        eprintln!(
            "  Cycles reference: {}",
            if c_cached {
                "cached".to_owned()
            } else {
                format!("{:.1} s", t.elapsed().as_secs_f64())
            }
        );
        for (name, img) in [("soupray", &s_ref), ("cycles", &c_ref)] {
            let p = self.previews.join(format!("{tag}-{name}.png"));
            soupray::output::write_png_preview(&p, img, 0.0, false)
                .map_err(|e| format!("{}: {e}", p.display()))?;
        }
        if (s_ref.width, s_ref.height) != (c_ref.width, c_ref.height) {
            return Err(format!(
                "{tag}: soupray's reference is {}x{}, Cycles' {}x{}",
                s_ref.width, s_ref.height, c_ref.width, c_ref.height
            ));
        }
        let (sm, cm) = (mean_rgb(&s_ref), mean_rgb(&c_ref));
        let diff = sm / cm - 1.0;
        let cross = soupray::compare::relative_mse(&s_ref, &c_ref).map_err(|e| e.to_string())?;
        if diff.abs() > MEAN_TOLERANCE {
            results
                .mismatches
                .push(format!("{tag}: soupray {sm:.4} vs Cycles {cm:.4}"));
        }
        results.ref_lines.push(format!(
            "| {mesh} | {lighting} | {sm:.4} | {cm:.4} | {:+.2}% | {} |",
            diff * 100.0,
            fmt_sci(cross)
        ));
        let _ = writeln!(
            results.ref_csv,
            "{mesh},{lighting},{sm},{cm},{diff},{cross},{s_ref_time},{c_ref_time}"
        );
        Ok((s_ref, c_ref))
    }

    /// The timed soupray renders of the scene, each sampler variant after an
    /// untimed 1-spp render (PoCL compiles a kernel for its work-group size
    /// at the first launch, inside the trace time; its cache keeps it for
    /// later runs).
    fn soupray_renders(
        &self,
        mesh: &String,
        lighting: &String,
        job: &Job,
        s_ref: &Image,
        results: &mut Results,
    ) -> Result<(), String> {
        let o = self.o;
        let tag = format!("{mesh}-{lighting}");
        for variant in &self.samplers {
            let warm = o
                .out
                .join("renders")
                .join(&tag)
                .join(format!("soupray-{variant}-warmup"));
            self.soupray.render(o, job, variant, 1, &warm)?;
            for &spp in &o.spp {
                eprintln!("  soupray {variant} {spp} spp…");
                let dir = o
                    .out
                    .join("renders")
                    .join(&tag)
                    .join(format!("soupray-{variant}-spp{spp}"));
                let r = self.soupray.render(o, job, variant, spp, &dir)?;
                results.device = results.device.take().or(r.device.clone());
                results.rows.push(Row {
                    mesh: mesh.clone(),
                    lighting: lighting.clone(),
                    spp,
                    renderer: "soupray",
                    variant: variant.clone(),
                    rel_mse: soupray::compare::relative_mse(&r.image, s_ref)
                        .map_err(|e| e.to_string())?,
                    time: r.time,
                    total: r.total,
                    sampling: r.sampling,
                });
            }
        }
        Ok(())
    }

    /// Prints the report (Markdown) and writes `results.csv`,
    /// `references.csv` and `results.md`; warns when the references
    /// disagree on the mean brightness.
    fn report(&self, command: &str, results: &Results) -> Result<(), String> {
        let o = self.o;
        let mut md = self.report_header(command, results);
        let csv = result_table(&results.rows, &mut md);
        print!("{md}");
        let csv_path = o.out.join("results.csv");
        std::fs::write(&csv_path, csv).map_err(|e| format!("{}: {e}", csv_path.display()))?;
        let ref_path = o.out.join("references.csv");
        std::fs::write(&ref_path, &results.ref_csv)
            .map_err(|e| format!("{}: {e}", ref_path.display()))?;
        let md_path = o.out.join("results.md");
        std::fs::write(&md_path, &md).map_err(|e| format!("{}: {e}", md_path.display()))?;
        println!(
            "\nwritten: {}, {}, {}, previews in {}",
            csv_path.display(),
            ref_path.display(),
            md_path.display(),
            self.previews.display()
        );
        if !results.mismatches.is_empty() {
            println!(
                "\nWARNING: the references disagree on the mean brightness by more than {}%: {}. \
                 The scene translation (units, materials, sun strength, camera) is not like for like.",
                MEAN_TOLERANCE * 100.0,
                results.mismatches.join("; ")
            );
        }
        Ok(())
    }

    /// The report's header: the machine and settings, the references'
    /// table, and the heading of the renders' table.
    fn report_header(&self, command: &str, results: &Results) -> String {
        let o = self.o;
        let mut md = String::new();
        let _ = writeln!(
            md,
            "\nsoupray vs Cycles — machine: {}; soupray device: {}; {}; {}\ncommand: `{command}`\n",
            machine(),
            results.device.as_deref().unwrap_or("?"),
            self.cycles.version,
            date()
        );
        let _ = writeln!(
            md,
            "{}x{}, max depth {} (Cycles: {} bounces), references {} spp (seed {REF_SEED}; \
             soupray's with the `{}` sampler), renders seed {TEST_SEED}, Cycles on {} threads.\n",
            o.width,
            o.height,
            o.max_depth,
            o.max_depth.max(1) - 1,
            o.ref_spp,
            self.samplers[0],
            o.threads
        );
        let _ = writeln!(
            md,
            "References (mean of R, G, B over the image; the two renderers must agree):\n"
        );
        let _ = writeln!(
            md,
            "| mesh | lighting | soupray mean | Cycles mean | difference | rel. MSE between them |"
        );
        let _ = writeln!(md, "|---|---|---:|---:|---:|---:|");
        for l in &results.ref_lines {
            let _ = writeln!(md, "{l}");
        }
        let _ = writeln!(
            md,
            "\nEach render against its own renderer's reference (rel. MSE). time: soupray = \
             trace (frame log `timings_ms.trace`), Cycles = bpy.ops.render.render (scene sync, \
             BVH build and path tracing). ratio: soupray's MSE x time over Cycles' at the same \
             spp (below 1: soupray is more efficient). total: soupray's whole frame (evaluate, \
             build, trace, write). sampling: path tracing alone (soupray: trace; Cycles: first \
             sample to finished, from Blender's log, 10 ms resolution), and the ratio on it.\n"
        );
        let _ = writeln!(
            md,
            "| mesh | lighting | spp | renderer | rel. MSE | time (s) | MSE x time | ratio to Cycles \
             | total (s) | sampling (s) | ratio, sampling only |"
        );
        let _ = writeln!(md, "|---|---|---:|---|---:|---:|---:|---:|---:|---:|---:|");
        md
    }
}

/// The renders' table: its Markdown rows added to `md`; returns the CSV.
fn result_table(rows: &[Row], md: &mut String) -> String {
    let mut csv = String::from(
        "mesh,lighting,spp,renderer,variant,rel_mse,time_s,total_s,sampling_s,mse_x_time,\
         ratio_to_cycles,sampling_ratio_to_cycles\n",
    );
    let num = |v: f64, digits: usize| {
        if v.is_finite() {
            format!("{v:.digits$}")
        } else {
            String::new()
        }
    };
    for r in rows {
        let cycles = rows.iter().find(|c| {
            c.renderer == "cycles" && c.mesh == r.mesh && c.lighting == r.lighting && c.spp == r.spp
        });
        let ratio = |f: fn(&Row) -> f64| match cycles {
            Some(c) if r.renderer == "soupray" && f(c) > 0.0 => f(r) / f(c),
            _ => f64::NAN,
        };
        let (ratio, sampling_ratio) = (ratio(Row::product), ratio(Row::sampling_product));
        let name = if r.renderer == "cycles" {
            "Cycles".to_owned()
        } else {
            format!("soupray {}", r.variant)
        };
        let _ = writeln!(
            md,
            "| {} | {} | {} | {name} | {} | {:.3} | {} | {} | {} | {} | {} |",
            r.mesh,
            r.lighting,
            r.spp,
            fmt_sci(r.rel_mse),
            r.time,
            fmt_sci(r.product()),
            num(ratio, 2),
            if r.renderer == "soupray" {
                num(r.total, 3)
            } else {
                String::new()
            },
            num(r.sampling, 3),
            num(sampling_ratio, 2),
        );
        let _ = writeln!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{},{}",
            r.mesh,
            r.lighting,
            r.spp,
            r.renderer,
            r.variant,
            r.rel_mse,
            r.time,
            r.total,
            r.sampling,
            r.product(),
            if ratio.is_finite() {
                ratio.to_string()
            } else {
                String::new()
            },
            if sampling_ratio.is_finite() {
                sampling_ratio.to_string()
            } else {
                String::new()
            },
        );
    }
    csv
}
