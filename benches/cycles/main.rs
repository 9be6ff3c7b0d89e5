//! soupray against Blender Cycles, side by side: error against time on the
//! same scenes, each renderer against its own converged reference.
//!
//!   cargo bench --bench cycles
//!   cargo bench --bench cycles -- --size 96x64 --ref-spp 256 --spp 4,16 --meshes beast
//!
//! Flags (defaults in brackets): `--size WxH` [384x256], `--spp LIST`
//! [16,64,256], `--ref-spp N` [4096], `--meshes LIST` [beast,nefertiti],
//! `--lightings LIST` [sky,sun,interior,glossy,glass,emitter,lamps,character], `--samplers LIST` [sobol,random]
//! (soupray's `--sampler`; a soupray without that flag gets one variant,
//! `default`), `--cycles LIST` [3.4,5,5-guided], `--runs N` [1] (timed
//! renders per scene, every renderer in turn in each run, run k with seed
//! k; the report gives the mean error and the median times), `--max-depth N` [8] (the interior's is 64), `--threads N`
//! [all cores] (Cycles' threads; soupray uses the whole OpenCL device),
//! `--out DIR` [out/bench-cycles], `--fresh-refs` (render the references
//! again), `--scenes-only` (write the scenes and stop).
//!
//! The Cycles it runs, each skipped with a message where it is absent:
//! * `3.4`: a Blender binary, `BLENDER=PATH` or `blender` on PATH
//!   (Debian's is 3.4; its glTF importer needs numpy, which the package
//!   does not pull in: `apt-get install blender python3-numpy`);
//! * `5` and `5-guided`: Blender 5 as a Python module (`pip install
//!   bpy==5.0.1`, Python 3.11; `SOUPRAY_BPY_PATH=DIR` for a `pip install
//!   --target DIR`), with its defaults (light tree, tabulated Sobol), path
//!   guiding off and on. The report compares soupray with the better of
//!   the two at each sample count, and with Cycles 3.4.
//!
//! What it does: writes glTF 2.0 scenes from the scanned meshes (the
//! shared folder's meshes/*.ply, read in place), in eight setups:
//! * `sky` and `sun`: the mesh standing on a ground quad, a camera framing
//!   it, every material a 0.8 grey Lambertian (soupray `--clay`, Cycles a
//!   Diffuse BSDF 0.8), under a constant white sky of radiance 1, or a 3
//!   lux KHR_lights_punctual sun, oblique so the mesh casts a shadow, and
//!   a sky of radiance 0.1;
//! * `interior`: the mesh as a rough gold metal figure (roughness 0.4) in
//!   a closed white room (glTF's dielectric, base 0.8, roughness 1), lit by
//!   the same sun and sky through a window, 64 bounces for both: indirect
//!   light dominates. Both renderers render the file's materials (Cycles:
//!   the Principled BSDFs of Blender's importer);
//! * `glossy`: the mesh in polished silver (metal, roughness 0.2) on a
//!   ground of three grey dielectric strips (base 0.5) at roughness 0.05,
//!   0.25 and 0.6, under the sun and sky; the file's materials, as in the
//!   interior;
//! * `glass`: the mesh in clear glass (KHR_materials_transmission with a
//!   volume: a refracting solid of IOR 1.5) on a white ground (base 0.8,
//!   roughness 1) under the sun and sky; the file's materials.
//! * `emitter`: a textured emitter: the mesh in white and DamagedHelmet
//!   (the shared folder's sample, read in place; its emissive texture
//!   written beside the scene) in grey side by side in the interior's
//!   room, lit by the helmet's emissive texture alone (strength 100, no
//!   sun, no sky): mostly black, so light samples spread by area are
//!   mostly wasted;
//! * `lamps`: many small lights: the mesh in white on the white ground at
//!   night, in a street of 200 lamps 0.4 m apart, 100 emissive heads
//!   (small cubes) down one side and 100 KHR_lights_punctual point lights
//!   down the other (Cycles: point lights of radius 0);
//! * `character`: an animated character under the sun, where per-frame
//!   work counts: the mesh in white on the white ground beside CesiumMan
//!   (the shared folder's sample, read in place: its skin, walk and
//!   texture merged into the scene), as tall as the mesh, rendered at
//!   frame 12 (0.5 s, mid-stride) by both: soupray evaluates the skin and
//!   builds the BVH of the whole scene for the frame, Cycles syncs the
//!   frame's pose. The time compared is soupray's evaluation, build and
//!   trace against Cycles' render (sync, BVH build and path tracing).
//!
//! Each scene is rendered by soupray (`soupray render --env-color …`, once
//! per sampler) and by each Cycles (`benches/cycles/render_cycles.py`,
//! which translates the scene like for like: constant world, sun strength
//! = lux, angle 0, no clamping/denoising/adaptive sampling, bounces one
//! fewer than the depth, Blackman-Harris 1.5 px like soupray) at every
//! `--spp`, and each is compared with its own renderer's reference at
//! `--ref-spp` (another seed) by relative MSE (`soupray::compare::relative_mse`); a Blender
//! version's guided and unguided renders share its unguided reference
//! (guiding changes the noise, not the expectation). The
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
//!   path tracing alone, from its first sample to `Finished` in Cycles'
//!   status messages (the script's render_stats handler); for soupray it
//!   is the trace time again.
//! * The product rel. MSE x time is inverse efficiency (lower is better);
//!   the ratio column is soupray's product over Cycles' at the same spp
//!   (below 1: soupray reaches a given error sooner). Each renderer is
//!   measured against its own reference, so a bias of one renderer against
//!   the other is not in the MSE (the reference check above covers it).
//!   Cycles 3.4 samples with its default pattern (progressive
//!   multi-jitter), Cycles 5 with its default (tabulated Sobol); soupray
//!   with each of `--samplers`.
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
use renderers::{find_on_path, run_logged, Cycles, Job, Launcher, Soupray, Times};
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
/// The interior's path depth, for both renderers: light that comes in
/// through a window bounces long.
const INTERIOR_DEPTH: u32 = 64;
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

    let (cycles, script_hash) = cycles_renderers(o, root)?;
    if cycles.is_empty() {
        println!(
            "cycles bench: skipped: none of the Cycles asked for ({}) is installed, and the bench \
             compares soupray with Cycles. Install one (see above), then run `cargo bench --bench cycles` again.",
            o.cycles.join(", ")
        );
        return Ok(());
    }
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
        "soupray vs {}: {}x{}, spp {spp_list}, references {} spp, depth {} (interior {INTERIOR_DEPTH}), {} Cycles threads",
        cycles
            .iter()
            .map(|c| format!("Cycles {}", c.label))
            .collect::<Vec<_>>()
            .join(", "),
        o.width,
        o.height,
        o.ref_spp,
        o.max_depth,
        o.threads
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
            "mesh,lighting,cycles,soupray_mean,cycles_mean,difference,cross_rel_mse,soupray_ref_time_s,cycles_ref_time_s\n",
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

/// The Cycles of `--cycles` that are installed (each missing one skipped
/// with a message), and the hash of their script (part of the references'
/// cache key).
fn cycles_renderers(o: &Opts, root: &Path) -> Result<(Vec<Cycles>, u64), String> {
    let script = root.join("benches/cycles/render_cycles.py");
    let script_hash = fnv1a(
        FNV_START,
        &std::fs::read(&script).map_err(|e| format!("{}: {e}", script.display()))?,
    );
    let mut found = Vec::new();
    for want in &o.cycles {
        let (launcher, guiding, install) = if want == "3.4" {
            let blender = std::env::var_os("BLENDER")
                .map(PathBuf::from)
                .or_else(|| find_on_path("blender"));
            let Some(blender) = blender else {
                println!(
                    "cycles bench: Cycles 3.4 skipped: no `blender` on PATH. Install it \
                     (Debian/Ubuntu: `apt-get install blender python3-numpy`) or point \
                     BLENDER=/path/to/blender at one."
                );
                continue;
            };
            (Launcher::Binary(blender), false, "BLENDER")
        } else {
            let pythonpath = std::env::var_os("SOUPRAY_BPY_PATH");
            (
                Launcher::Module { pythonpath },
                want == "5-guided",
                "`pip install bpy==5.0.1` (Python 3.11; SOUPRAY_BPY_PATH=DIR for a \
                 `pip install --target DIR`)",
            )
        };
        let Some(version) = launcher.version() else {
            println!(
                "cycles bench: Cycles {want} skipped: no Blender starts; install it: {install}"
            );
            continue;
        };
        // `Blender 5.0.1` -> `5.0`.
        let anchor = version
            .trim_start_matches("Blender ")
            .split('.')
            .take(2)
            .collect::<Vec<_>>()
            .join(".");
        let label = if guiding {
            format!("{anchor} guided")
        } else {
            anchor.clone()
        };
        found.push(Cycles {
            launcher,
            script: script.clone(),
            version,
            anchor,
            label,
            guiding,
        });
    }
    Ok((found, script_hash))
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
    cycles: Vec<Cycles>,
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
        let tag = format!("{mesh}-{lighting}");
        eprintln!("{tag} ({} triangles): references…", scene.triangles);

        let ref_job = Job {
            scene: &scene.path,
            env: scene.env,
            max_depth: scene.max_depth,
            materials: scene.materials,
            frame: scene.frame,
            seed: REF_SEED,
        };
        let (s_ref, c_refs) = self.references(mesh, lighting, scene, &ref_job, results)?;
        let start = results.rows.len();
        for run in 1..=o.runs {
            if o.runs > 1 {
                eprintln!("  run {run} of {}", o.runs);
            }
            // Each run its own seed: one image's error is one draw, and on
            // scenes with caustics a few pixels decide it; the mean over
            // the runs estimates the expected error.
            let job = Job {
                seed: TEST_SEED + u64::from(run) - 1,
                ..ref_job
            };
            self.timed_renders(mesh, lighting, &job, (&s_ref, &c_refs), results)?;
        }
        let runs = results.rows.split_off(start);
        results.rows.extend(combine_runs(runs));
        Ok(())
    }

    /// One run of the timed renders: soupray's, then each Cycles', each
    /// against its own reference.
    fn timed_renders(
        &self,
        mesh: &String,
        lighting: &String,
        job: &Job,
        (s_ref, c_refs): (&Image, &BTreeMap<String, Image>),
        results: &mut Results,
    ) -> Result<(), String> {
        let o = self.o;
        let tag = format!("{mesh}-{lighting}");
        self.soupray_renders(mesh, lighting, job, s_ref, results)?;
        for cycles in &self.cycles {
            eprintln!("  Cycles {} {} spp…", cycles.label, self.spp_list);
            let dir = o
                .out
                .join("renders")
                .join(&tag)
                .join(format!("cycles-{}", cycles.label.replace(' ', "-")));
            let renders = cycles.render(o, job, &o.spp, &dir)?;
            for (&spp, r) in o.spp.iter().zip(renders) {
                let rel_mse = soupray::compare::relative_mse(&r.image, &c_refs[&cycles.anchor])
                    .map_err(|e| e.to_string())?;
                results.rows.push(Row::measured(
                    (mesh, lighting, spp),
                    ("cycles", &cycles.label, &cycles.anchor),
                    rel_mse,
                    &r,
                ));
            }
        }
        Ok(())
    }

    /// soupray's reference of the scene and each Blender version's (cached;
    /// a version's is rendered with guiding off), their previews, and how
    /// far they agree.
    fn references(
        &self,
        mesh: &String,
        lighting: &String,
        scene: &SceneFile,
        ref_job: &Job,
        results: &mut Results,
    ) -> Result<(Image, BTreeMap<String, Image>), String> {
        let (o, soupray) = (self.o, &self.soupray);
        let (code_hash, script_hash) = (self.code_hash, self.script_hash);
        let tag = format!("{mesh}-{lighting}");
        let common = format!(
            "{tag}-{}x{}-spp{}-seed{REF_SEED}-depth{}-frame{}-scene{:016x}",
            o.width, o.height, o.ref_spp, scene.max_depth, scene.frame, scene.hash
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
        let p = self.previews.join(format!("{tag}-soupray.png"));
        soupray::output::write_png_preview(&p, &s_ref, 0.0, false)
            .map_err(|e| format!("{}: {e}", p.display()))?;
        let mut c_refs = BTreeMap::new();
        for cycles in &self.cycles {
            if c_refs.contains_key(&cycles.anchor) {
                continue;
            }
            let unguided = Cycles {
                guiding: false,
                ..cycles.clone()
            };
            let t = Instant::now();
            let (c_ref, c_ref_time, c_cached) = cached_reference(
                o,
                &o.out.join("refs").join(format!(
                    "cycles-{}-{common}-threads{}-script{script_hash:016x}-{:016x}",
                    cycles.anchor,
                    o.threads,
                    fnv1a(FNV_START, cycles.version.as_bytes())
                )),
                |dir| {
                    unguided
                        .render(o, ref_job, &[o.ref_spp], dir)
                        .map(|mut v| v.remove(0))
                },
            )?;
            eprintln!(
                "  Cycles {} reference: {}",
                cycles.anchor,
                if c_cached {
                    "cached".to_owned()
                } else {
                    format!("{:.1} s", t.elapsed().as_secs_f64())
                }
            );
            let p = self
                .previews
                .join(format!("{tag}-cycles-{}.png", cycles.anchor));
            soupray::output::write_png_preview(&p, &c_ref, 0.0, false)
                .map_err(|e| format!("{}: {e}", p.display()))?;
            if (s_ref.width, s_ref.height) != (c_ref.width, c_ref.height) {
                return Err(format!(
                    "{tag}: soupray's reference is {}x{}, Cycles {}' {}x{}",
                    s_ref.width, s_ref.height, cycles.anchor, c_ref.width, c_ref.height
                ));
            }
            let (sm, cm) = (mean_rgb(&s_ref), mean_rgb(&c_ref));
            let diff = sm / cm - 1.0;
            let cross =
                soupray::compare::relative_mse(&s_ref, &c_ref).map_err(|e| e.to_string())?;
            if diff.abs() > MEAN_TOLERANCE {
                results.mismatches.push(format!(
                    "{tag}: soupray {sm:.4} vs Cycles {} {cm:.4}",
                    cycles.anchor
                ));
            }
            results.ref_lines.push(format!(
                "| {mesh} | {lighting} | {} | {sm:.4} | {cm:.4} | {:+.2}% | {} |",
                cycles.anchor,
                diff * 100.0,
                fmt_sci(cross)
            ));
            let _ = writeln!(
                results.ref_csv,
                "{mesh},{lighting},{},{sm},{cm},{diff},{cross},{s_ref_time},{c_ref_time}",
                cycles.anchor
            );
            c_refs.insert(cycles.anchor.clone(), c_ref);
        }
        Ok((s_ref, c_refs))
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
                let rel_mse =
                    soupray::compare::relative_mse(&r.image, s_ref).map_err(|e| e.to_string())?;
                results.rows.push(Row::measured(
                    (mesh, lighting, spp),
                    ("soupray", variant, ""),
                    rel_mse,
                    &r,
                ));
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
        time_split_table(&results.rows, o, &mut md);
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

    /// The report's header: the machine and settings, and the references'
    /// table.
    fn report_header(&self, command: &str, results: &Results) -> String {
        let o = self.o;
        let mut md = String::new();
        let mut versions: Vec<&str> = self.cycles.iter().map(|c| c.version.as_str()).collect();
        versions.dedup();
        let _ = writeln!(
            md,
            "\nsoupray vs Cycles — machine: {}; soupray device: {}; {}; {}\ncommand: `{command}`\n",
            machine(),
            results.device.as_deref().unwrap_or("?"),
            versions.join(", "),
            date()
        );
        let _ = writeln!(
            md,
            "{}x{}, max depth {} (Cycles: {} bounces; the interior {INTERIOR_DEPTH}), references {} spp (seed {REF_SEED}; \
             soupray's with the `{}` sampler, Cycles' with guiding off), renders seeds {TEST_SEED} to {} (one per run; rel. MSE is their mean, beside the smallest and largest of them; times the median), \
             Cycles on {} threads.\n",
            o.width,
            o.height,
            o.max_depth,
            o.max_depth.max(1) - 1,
            o.ref_spp,
            self.samplers[0],
            TEST_SEED + u64::from(o.runs) - 1,
            o.threads
        );
        let _ = writeln!(
            md,
            "References (mean of R, G, B over the image; the two renderers must agree):\n"
        );
        let _ = writeln!(
            md,
            "| mesh | lighting | Cycles | soupray mean | Cycles mean | difference | rel. MSE between them |"
        );
        let _ = writeln!(md, "|---|---|---|---:|---:|---:|---:|");
        for l in &results.ref_lines {
            let _ = writeln!(md, "{l}");
        }
        md
    }
}

/// One row per renderer, variant and sample count of several runs' rows
/// (in the order of the first run): the mean error (each run has its own
/// seed) and the median of each time.
fn combine_runs(rows: Vec<Row>) -> Vec<Row> {
    let mut groups: Vec<Vec<Row>> = Vec::new();
    for r in rows {
        let same = |g: &Vec<Row>| {
            let f = &g[0];
            (f.renderer, &f.variant, f.spp) == (r.renderer, &r.variant, r.spp)
        };
        match groups.iter_mut().find(|g| same(g)) {
            Some(g) => g.push(r),
            None => groups.push(vec![r]),
        }
    }
    groups
        .into_iter()
        .map(|g| {
            let median = |f: fn(&Row) -> f64| {
                let mut v: Vec<f64> = g.iter().map(f).collect();
                v.sort_by(f64::total_cmp);
                v[v.len() / 2]
            };
            let run_rel_mse: Vec<f64> = g
                .iter()
                .flat_map(|r| r.run_rel_mse.iter().copied())
                .collect();
            Row {
                rel_mse: run_rel_mse.iter().sum::<f64>() / run_rel_mse.len() as f64,
                run_rel_mse,
                times: Times {
                    time: median(|r| r.times.time),
                    total: median(|r| r.times.total),
                    sampling: median(|r| r.times.sampling),
                    setup: median(|r| r.times.setup),
                    rays_per_sample: median(|r| r.times.rays_per_sample),
                },
                ..g.into_iter().next().expect("a group has a row")
            }
        })
        .collect()
}

/// Where the time goes at the largest sample count: soupray's setup
/// (evaluate and build) and trace with its rays per sample and ray rate,
/// beside the better setting of the newest Cycles: its scene sync and BVH
/// build, and its path tracing.
fn time_split_table(rows: &[Row], o: &Opts, md: &mut String) {
    let Some(&spp) = o.spp.iter().max() else {
        return;
    };
    let newest = anchors(rows).first().copied().unwrap_or("");
    let _ = writeln!(
        md,
        "\nWhere the time goes at {spp} spp: soupray's setup (scene evaluation and BVH \
         build, from the frame log) and trace, its rays per sample (camera, bounce and \
         shadow) and rate; Cycles {newest}'s better setting: setup (scene sync and BVH \
         build) and path tracing.\n"
    );
    let _ = writeln!(
        md,
        "| mesh | lighting | soupray | setup (s) | trace (s) | rays per sample | Mrays/s | \
         Cycles setup (s) | Cycles path tracing (s) | trace / Cycles' |"
    );
    let _ = writeln!(md, "|---|---|---|---:|---:|---:|---:|---:|---:|---:|");
    for r in rows
        .iter()
        .filter(|r| r.renderer == "soupray" && r.spp == spp)
    {
        let cycles = best_cycles(rows, r, newest);
        let t = &r.times;
        let mrays = t.rays_per_sample * f64::from(o.width) * f64::from(o.height) * f64::from(spp)
            / t.sampling
            / 1e6;
        let of_cycles = |f: fn(&Times) -> f64| cycles.map_or(f64::NAN, |c| f(&c.times));
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.3} | {:.3} | {:.2} | {:.2} | {} | {} | {} |",
            r.mesh,
            r.lighting,
            r.variant,
            t.setup,
            t.sampling,
            t.rays_per_sample,
            mrays,
            cell(of_cycles(|c| c.setup), 3),
            cell(of_cycles(|c| c.sampling), 3),
            cell(t.sampling / of_cycles(|c| c.sampling), 2),
        );
    }
}

/// The Blender versions of the Cycles rows, newest first.
fn anchors(rows: &[Row]) -> Vec<&str> {
    let mut anchors: Vec<&str> = rows
        .iter()
        .filter(|r| r.renderer == "cycles")
        .map(|r| r.anchor.as_str())
        .collect();
    anchors.sort_by(|a, b| b.cmp(a));
    anchors.dedup();
    anchors
}

/// A table cell: `v` with `digits` decimals, empty where it is not a number.
fn cell(v: f64, digits: usize) -> String {
    if v.is_finite() {
        format!("{v:.digits$}")
    } else {
        String::new()
    }
}

/// The best (lowest MSE x time) Cycles row of `anchor` for the same scene
/// and sample count as `r`.
fn best_cycles<'a>(rows: &'a [Row], r: &Row, anchor: &str) -> Option<&'a Row> {
    rows.iter()
        .filter(|c| {
            c.renderer == "cycles"
                && c.anchor == anchor
                && c.mesh == r.mesh
                && c.lighting == r.lighting
                && c.spp == r.spp
        })
        .min_by(|a, b| a.product().total_cmp(&b.product()))
}

/// The renders' table, its explanation and heading added to `md`; returns
/// the CSV. soupray's rows carry a ratio to each Blender version's better
/// setting, newest first.
fn result_table(rows: &[Row], md: &mut String) -> String {
    let anchors = anchors(rows);
    let newest = anchors.first().copied().unwrap_or("");
    let _ = writeln!(
        md,
        "\nEach render against its own renderer's reference (rel. MSE). time: soupray = \
         trace (frame log `timings_ms.trace`; for the animated character, with its \
         `evaluate` and `build`), Cycles = bpy.ops.render.render (scene sync, \
         BVH build and path tracing). ratio to Cycles V: soupray's MSE x time over that of \
         Cycles V's better setting at the same spp (below 1: soupray is more efficient). \
         total: soupray's whole frame (evaluate, build, trace, write). sampling: path tracing \
         alone (soupray: trace; Cycles: first sample to finished, from its status messages), \
         and the ratio on it to Cycles {newest}'s better setting.\n"
    );
    let ratio_heads: String = anchors
        .iter()
        .map(|a| format!(" ratio to Cycles {a} |"))
        .collect();
    let _ = writeln!(
        md,
        "| mesh | lighting | spp | renderer | rel. MSE | runs' rel. MSE | time (s) | MSE x time |{ratio_heads} \
         total (s) | sampling (s) | ratio, sampling only |"
    );
    let _ = writeln!(
        md,
        "|---|---|---:|---|---:|---:|---:|---:|{}---:|---:|---:|",
        "---:|".repeat(anchors.len())
    );
    let mut csv = String::from(
        "mesh,lighting,spp,renderer,variant,rel_mse,rel_mse_min,rel_mse_max,time_s,total_s,sampling_s,mse_x_time",
    );
    for a in &anchors {
        let _ = write!(csv, ",ratio_to_cycles_{a}");
    }
    csv.push_str(",sampling_ratio_to_cycles\n");
    for r in rows {
        let ratio = |anchor: &str, f: fn(&Row) -> f64| match best_cycles(rows, r, anchor) {
            Some(c) if r.renderer == "soupray" && f(c) > 0.0 => f(r) / f(c),
            _ => f64::NAN,
        };
        let ratios: Vec<f64> = anchors.iter().map(|a| ratio(a, Row::product)).collect();
        let sampling_ratio = ratio(newest, Row::sampling_product);
        let name = if r.renderer == "cycles" {
            format!("Cycles {}", r.variant)
        } else {
            format!("soupray {}", r.variant)
        };
        let (lo, hi) = r.run_range();
        let runs = if r.run_rel_mse.len() > 1 {
            format!("{}-{}", fmt_sci(lo), fmt_sci(hi))
        } else {
            String::new()
        };
        let ratio_cells: String = ratios
            .iter()
            .map(|&v| format!(" {} |", cell(v, 2)))
            .collect();
        let _ = writeln!(
            md,
            "| {} | {} | {} | {name} | {} | {runs} | {:.3} | {} |{ratio_cells} {} | {} | {} |",
            r.mesh,
            r.lighting,
            r.spp,
            fmt_sci(r.rel_mse),
            r.times.time,
            fmt_sci(r.product()),
            if r.renderer == "soupray" {
                cell(r.times.total, 3)
            } else {
                String::new()
            },
            cell(r.times.sampling, 3),
            cell(sampling_ratio, 2),
        );
        let _ = write!(
            csv,
            "{},{},{},{},{},{},{},{},{},{},{},{}",
            r.mesh,
            r.lighting,
            r.spp,
            r.renderer,
            r.variant,
            r.rel_mse,
            lo,
            hi,
            r.times.time,
            r.times.total,
            r.times.sampling,
            r.product(),
        );
        for &v in ratios.iter().chain([&sampling_ratio]) {
            let _ = write!(
                csv,
                ",{}",
                if v.is_finite() {
                    v.to_string()
                } else {
                    String::new()
                }
            );
        }
        csv.push('\n');
    }
    csv
}
