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

mod support;

use glam::{Mat3, Quat, Vec3};
use serde_json::json;
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

const USAGE: &str = "\
usage: cargo bench --bench cycles -- [--size WxH] [--spp LIST] [--ref-spp N]
       [--meshes beast,nefertiti] [--lightings sky,sun] [--samplers sobol,random]
       [--max-depth N] [--threads N] [--out DIR] [--fresh-refs] [--scenes-only]";

#[derive(Debug, Clone)]
struct Opts {
    width: u32,
    height: u32,
    spp: Vec<u32>,
    ref_spp: u32,
    meshes: Vec<String>,
    lightings: Vec<String>,
    samplers: Vec<String>,
    max_depth: u32,
    threads: u32,
    out: PathBuf,
    fresh_refs: bool,
    scenes_only: bool,
}

fn list(v: &str) -> Vec<String> {
    v.split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(str::to_owned)
        .collect()
}

fn parse_opts(args: &[String]) -> Result<Opts, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut o = Opts {
        width: 384,
        height: 256,
        spp: vec![16, 64, 256],
        ref_spp: 4096,
        meshes: list("beast,nefertiti"),
        lightings: list("sky,sun"),
        samplers: list("sobol,random"),
        max_depth: 8,
        threads: std::thread::available_parallelism().map_or(2, |n| n.get() as u32),
        out: root.join("out/bench-cycles"),
        fresh_refs: false,
        scenes_only: false,
    };
    let mut i = 0;
    while i < args.len() {
        let (flag, inline) = match args[i].split_once('=') {
            Some((f, v)) if f.starts_with("--") => (f.to_owned(), Some(v.to_owned())),
            _ => (args[i].clone(), None),
        };
        i += 1;
        match flag.as_str() {
            // `cargo bench` passes --bench to every bench binary.
            "--bench" => continue,
            "--fresh-refs" => {
                o.fresh_refs = true;
                continue;
            }
            "--scenes-only" => {
                o.scenes_only = true;
                continue;
            }
            "-h" | "--help" => return Err(String::new()),
            "--size" | "--spp" | "--ref-spp" | "--meshes" | "--lightings" | "--samplers"
            | "--max-depth" | "--threads" | "--out" => {}
            _ => return Err(format!("unknown flag {flag}")),
        }
        let value = match inline {
            Some(v) => v,
            None => {
                let v = args
                    .get(i)
                    .cloned()
                    .ok_or_else(|| format!("{flag} needs a value"))?;
                i += 1;
                v
            }
        };
        let num = |v: &str| -> Result<u32, String> {
            v.trim()
                .parse::<u32>()
                .ok()
                .filter(|&n| n > 0)
                .ok_or_else(|| format!("{flag} {v:?}: want a positive integer"))
        };
        match flag.as_str() {
            "--size" => {
                let (w, h) = value
                    .split_once(['x', 'X'])
                    .ok_or_else(|| format!("--size {value:?}: want WxH"))?;
                o.width = num(w)?;
                o.height = num(h)?;
            }
            "--spp" => {
                o.spp = list(&value)
                    .iter()
                    .map(|v| num(v))
                    .collect::<Result<_, _>>()?
            }
            "--ref-spp" => o.ref_spp = num(&value)?,
            "--meshes" => o.meshes = list(&value),
            "--lightings" => o.lightings = list(&value),
            "--samplers" => o.samplers = list(&value),
            "--max-depth" => o.max_depth = num(&value)?,
            "--threads" => o.threads = num(&value)?,
            "--out" => o.out = root.join(value),
            _ => unreachable!("checked above"),
        }
    }
    for m in &o.meshes {
        if mesh_spec(m).is_none() {
            return Err(format!("--meshes: unknown mesh {m:?} (beast, nefertiti)"));
        }
    }
    for l in &o.lightings {
        if !matches!(l.as_str(), "sky" | "sun") {
            return Err(format!("--lightings: unknown lighting {l:?} (sky, sun)"));
        }
    }
    if o.spp.is_empty() || o.meshes.is_empty() || o.lightings.is_empty() || o.samplers.is_empty() {
        return Err("--spp, --meshes, --lightings and --samplers may not be empty".into());
    }
    Ok(o)
}

// ---------------------------------------------------------------------------
// Scenes

/// How a scanned mesh is stood up and looked at.
struct MeshSpec {
    file: &'static str,
    /// From the file's axes to glTF's: +Y up, the front facing +Z.
    to_gltf: fn() -> Quat,
    /// Camera direction from the mesh: degrees around +Y from +Z (towards
    /// +X), and above the ground.
    azimuth: f32,
    elevation: f32,
    /// Sun: degrees around +Y from +Z (where it comes from), above the ground.
    sun_azimuth: f32,
    sun_elevation: f32,
}

fn mesh_spec(name: &str) -> Option<MeshSpec> {
    match name {
        // Already +Y up (feet at y = 0), facing +Z.
        "beast" => Some(MeshSpec {
            file: "beast.ply",
            to_gltf: || Quat::IDENTITY,
            azimuth: 30.0,
            elevation: 15.0,
            sun_azimuth: -40.0,
            sun_elevation: 50.0,
        }),
        // +Z up, the face towards -Y.
        "nefertiti" => Some(MeshSpec {
            file: "nefertiti.ply",
            to_gltf: || Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
            azimuth: 35.0,
            elevation: 10.0,
            sun_azimuth: -50.0,
            sun_elevation: 40.0,
        }),
        _ => None,
    }
}

fn dir_from(azimuth_deg: f32, elevation_deg: f32) -> Vec3 {
    let (a, e) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    Vec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos())
}

/// A node rotation whose local -Z is `forward` and whose +Y is as close to
/// world +Y as it can be (a glTF camera looks down -Z, a light shines along it).
fn look_rotation(forward: Vec3) -> Quat {
    let back = -forward.normalize();
    let up_hint = if back.y.abs() > 0.999 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let right = up_hint.cross(back).normalize();
    let up = back.cross(right);
    Quat::from_mat3(&Mat3::from_cols(right, up, back)).normalize()
}

fn fnv1a(hash: u64, bytes: &[u8]) -> u64 {
    bytes.iter().fold(hash, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01B3)
    })
}
const FNV_START: u64 = 0xcbf2_9ce4_8422_2325;

struct SceneFile {
    path: PathBuf,
    /// Hash of the glTF and its buffer.
    hash: u64,
    triangles: usize,
}

/// Writes `DIR/MESH.bin` (mesh then ground positions) and
/// `DIR/MESH-LIGHTING.gltf` for each lighting.
fn write_scenes(o: &Opts, mesh: &str, dir: &Path) -> Result<BTreeMap<String, SceneFile>, String> {
    let spec = mesh_spec(mesh).expect("checked");
    let soup = support::mesh(spec.file)?;
    let rot = (spec.to_gltf)();
    let mut pts: Vec<Vec3> = soup
        .positions
        .iter()
        .map(|p| rot * Vec3::new(p[0], p[1], p[2]))
        .collect();
    let (lo, hi) = pts.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    // One unit tall, standing on y = 0, centred over the origin.
    let scale = 1.0 / (hi.y - lo.y);
    let shift = Vec3::new(-0.5 * (lo.x + hi.x), -lo.y, -0.5 * (lo.z + hi.z));
    for p in &mut pts {
        *p = (*p + shift) * scale;
    }
    let (lo, hi) = ((lo + shift) * scale, (hi + shift) * scale);
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();

    // The ground: a 40 x 40 quad at y = 0, facing up.
    let g = 20.0f32;
    let ground = [
        Vec3::new(-g, 0.0, -g),
        Vec3::new(-g, 0.0, g),
        Vec3::new(g, 0.0, g),
        Vec3::new(-g, 0.0, -g),
        Vec3::new(g, 0.0, g),
        Vec3::new(g, 0.0, -g),
    ];
    let mut bin = Vec::with_capacity((pts.len() + ground.len()) * 12);
    for p in pts.iter().chain(&ground) {
        for c in p.to_array() {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    let bin_name = format!("{mesh}.bin");
    std::fs::write(dir.join(&bin_name), &bin).map_err(|e| format!("{}: {e}", dir.display()))?;

    // The camera: on the view direction, far enough that the mesh's
    // bounding sphere fits the narrower field of view.
    let aspect = o.width as f32 / o.height as f32;
    let yfov = 35f32.to_radians();
    let half = (0.5 * yfov).min(((0.5 * yfov).tan() * aspect).atan());
    let distance = radius / half.sin() * 0.95;
    let view = dir_from(spec.azimuth, spec.elevation);
    let eye = centre + view * distance;
    let cam_rot = look_rotation(centre - eye);
    let sun_rot = look_rotation(-dir_from(spec.sun_azimuth, spec.sun_elevation));

    let mut out = BTreeMap::new();
    for lighting in ["sky", "sun"] {
        let mut nodes = vec![
            json!({"name": "mesh", "mesh": 0}),
            json!({"name": "ground", "mesh": 1}),
            json!({"name": "camera", "camera": 0,
                   "translation": eye.to_array(), "rotation": cam_rot.to_array()}),
        ];
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": "soupray benches/cycles.rs"},
            "scene": 0,
            "scenes": [{"name": format!("{mesh}-{lighting}"), "nodes": [0, 1, 2]}],
            "cameras": [{"type": "perspective", "name": "camera", "perspective": {
                "yfov": yfov, "aspectRatio": aspect, "znear": 0.01, "zfar": 1000.0}}],
            "materials": [{"name": "white", "doubleSided": true, "pbrMetallicRoughness": {
                "baseColorFactor": [0.8, 0.8, 0.8, 1.0],
                "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
            "meshes": [
                {"name": mesh, "primitives": [{"attributes": {"POSITION": 0}, "material": 0}]},
                {"name": "ground", "primitives": [{"attributes": {"POSITION": 1}, "material": 0}]}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": pts.len(), "type": "VEC3",
                 "min": lo.to_array(), "max": hi.to_array()},
                {"bufferView": 1, "componentType": 5126, "count": ground.len(), "type": "VEC3",
                 "min": [-g, 0.0, -g], "max": [g, 0.0, g]}
            ],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": pts.len() * 12, "target": 34962},
                {"buffer": 0, "byteOffset": pts.len() * 12, "byteLength": ground.len() * 12,
                 "target": 34962}
            ],
            "buffers": [{"uri": bin_name, "byteLength": bin.len()}],
        });
        if lighting == "sun" {
            nodes.push(json!({"name": "sun", "rotation": sun_rot.to_array(),
                              "extensions": {"KHR_lights_punctual": {"light": 0}}}));
            doc["scenes"][0]["nodes"] = json!([0, 1, 2, 3]);
            doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
            doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
                {"name": "sun", "type": "directional", "color": [1.0, 1.0, 1.0],
                 "intensity": SUN_LUX}]}});
        }
        doc["nodes"] = json!(nodes);
        let text = serde_json::to_string_pretty(&doc).expect("json");
        let path = dir.join(format!("{mesh}-{lighting}.gltf"));
        std::fs::write(&path, &text).map_err(|e| format!("{}: {e}", path.display()))?;
        let hash = fnv1a(
            fnv1a(fnv1a(FNV_START, text.as_bytes()), &bin),
            &[SCENE_VERSION as u8],
        );
        out.insert(
            lighting.to_owned(),
            SceneFile {
                path,
                hash,
                triangles: soup.triangle_count() + 2,
            },
        );
    }
    Ok(out)
}

// ---------------------------------------------------------------------------
// Renderers

/// One render's image and times.
struct Render {
    image: Image,
    /// The measured time (see the module documentation), seconds.
    time: f64,
    /// soupray's frame total; for Cycles the same as `time`.
    total: f64,
    /// Path tracing alone: soupray's trace time (`time`); Cycles' from its
    /// first sample to the end, from Blender's log (10 ms resolution).
    sampling: f64,
    /// soupray: the OpenCL device from the frame log.
    device: Option<String>,
}

fn read_exr(path: &Path) -> Result<Image, String> {
    soupray::output::read_exr_rgba(path).map_err(|e| format!("{}: {e}", path.display()))
}

fn run_logged(cmd: &mut Command, what: &str) -> Result<String, String> {
    let out = cmd
        .output()
        .map_err(|e| format!("{what}: cannot start {:?}: {e}", cmd.get_program()))?;
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    if !out.status.success() {
        let stderr = String::from_utf8_lossy(&out.stderr);
        let tail = |s: &str| -> String {
            let lines: Vec<&str> = s.lines().collect();
            lines[lines.len().saturating_sub(25)..].join("\n")
        };
        return Err(format!(
            "{what} failed ({}):\n{}\n{}",
            out.status,
            tail(&stdout),
            tail(&stderr)
        ));
    }
    Ok(stdout)
}

/// What a render is of: the scene, its sky radiance and the seed.
struct Job<'a> {
    scene: &'a Path,
    env: f32,
    seed: u64,
}

struct Soupray {
    exe: PathBuf,
    /// Whether `soupray render` takes `--sampler`.
    has_sampler: bool,
}

impl Soupray {
    /// Renders `scene` into `dir` (replacing what is there).
    fn render(
        &self,
        o: &Opts,
        job: &Job,
        variant: &str,
        spp: u32,
        dir: &Path,
    ) -> Result<Render, String> {
        let (scene, env, seed) = (job.scene, job.env, job.seed);
        let _ = std::fs::remove_dir_all(dir);
        let mut cmd = Command::new(&self.exe);
        cmd.arg("render")
            .arg(scene)
            .args(["--frame", "0", "--quiet", "--clay"])
            .args(["--spp", &spp.to_string()])
            .args(["--width", &o.width.to_string()])
            .args(["--height", &o.height.to_string()])
            .args(["--max-depth", &o.max_depth.to_string()])
            .args(["--seed", &seed.to_string()])
            .args(["--env-color", &format!("{env},{env},{env}")])
            .args(["--name", "img.####.exr"])
            .arg("--out")
            .arg(dir);
        if self.has_sampler {
            cmd.args(["--sampler", variant]);
        }
        run_logged(
            &mut cmd,
            &format!("soupray render {} ({variant}, {spp} spp)", scene.display()),
        )?;
        let log_path = dir.join("img.0000.json");
        let text = std::fs::read_to_string(&log_path)
            .map_err(|e| format!("{}: {e}", log_path.display()))?;
        let log: soupray::output::FrameLog =
            serde_json::from_str(&text).map_err(|e| format!("{}: {e}", log_path.display()))?;
        Ok(Render {
            image: read_exr(&dir.join("img.0000.exr"))?,
            time: log.timings_ms.trace / 1e3,
            total: log.timings_ms.total / 1e3,
            sampling: log.timings_ms.trace / 1e3,
            device: Some(log.device),
        })
    }
}

struct Cycles {
    blender: PathBuf,
    script: PathBuf,
    version: String,
}

impl Cycles {
    /// Renders `scene` at each of `spps` in one Blender process; the EXRs
    /// go to `dir/cycles-sppN.exr`.
    fn render(&self, o: &Opts, job: &Job, spps: &[u32], dir: &Path) -> Result<Vec<Render>, String> {
        let (scene, env, seed) = (job.scene, job.env, job.seed);
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let spp_list = spps
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(",");
        let mut cmd = Command::new(&self.blender);
        cmd.args([
            "-b",
            "-noaudio",
            "--factory-startup",
            "--python-exit-code",
            "1",
        ])
        .arg("-P")
        .arg(&self.script)
        .arg("--")
        .arg("--scene")
        .arg(scene)
        .args(["--width", &o.width.to_string()])
        .args(["--height", &o.height.to_string()])
        .args(["--spp", &spp_list])
        .args(["--seed", &seed.to_string()])
        .args(["--max-bounces", &(o.max_depth.max(1) - 1).to_string()])
        .args(["--threads", &o.threads.to_string()])
        .args(["--env", &format!("{env},{env},{env}")])
        .arg("--warmup")
        .arg("--out-dir")
        .arg(dir);
        let stdout = run_logged(
            &mut cmd,
            &format!("blender {} ({spp_list} spp)", scene.display()),
        )?;
        let mut seconds = BTreeMap::new();
        // Blender's status lines of the render in progress: the elapsed
        // time when the first sample starts and when it finishes.
        let (mut first_sample, mut finished) = (None, None);
        for line in stdout.lines() {
            if line.starts_with("CYCLES_INFO") {
                eprintln!("  {line}");
            }
            if line.starts_with("Fra:") {
                if line.contains("| Sample 0/") {
                    first_sample = blender_elapsed(line);
                } else if line.ends_with("| Finished") {
                    finished = blender_elapsed(line);
                }
            }
            let Some(rest) = line.strip_prefix("CYCLES_RENDER ") else {
                continue;
            };
            let field = |k: &str| {
                rest.split_whitespace()
                    .find_map(|f| f.strip_prefix(k).and_then(|v| v.strip_prefix('=')))
            };
            if let (Some(spp), Some(s)) = (field("spp"), field("seconds")) {
                if let (Ok(spp), Ok(s)) = (spp.parse::<u32>(), s.parse::<f64>()) {
                    let sampling = match (first_sample, finished) {
                        (Some(a), Some(b)) if b >= a => b - a,
                        _ => f64::NAN,
                    };
                    seconds.insert(spp, (s, sampling));
                }
                (first_sample, finished) = (None, None);
            }
        }
        spps.iter()
            .map(|&spp| {
                let (time, sampling) = *seconds.get(&spp).ok_or_else(|| {
                    format!("blender printed no CYCLES_RENDER line for {spp} spp")
                })?;
                Ok(Render {
                    image: read_exr(&dir.join(format!("cycles-spp{spp}.exr")))?,
                    time,
                    total: time,
                    sampling,
                    device: None,
                })
            })
            .collect()
    }
}

/// The `Time:` of one of Blender's `Fra:` status lines, seconds
/// (`MM:SS.cc`, or `HH:MM:SS.cc`).
fn blender_elapsed(line: &str) -> Option<f64> {
    let t = line
        .split(" | ")
        .find_map(|f| f.trim().strip_prefix("Time:"))?;
    t.split(':').try_fold(0.0, |acc, part| {
        Some(acc * 60.0 + part.parse::<f64>().ok()?)
    })
}

// ---------------------------------------------------------------------------
// References

fn mean_rgb(img: &Image) -> f64 {
    let sum: f64 = img
        .rgba
        .iter()
        .map(|p| (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0)
        .sum();
    sum / img.rgba.len().max(1) as f64
}

/// A cached reference: the image and the seconds it took.
fn cached_reference(
    o: &Opts,
    dir: &Path,
    render: impl FnOnce(&Path) -> Result<Render, String>,
) -> Result<(Image, f64, bool), String> {
    let exr = dir.join("reference.exr");
    let meta = dir.join("reference.json");
    if !o.fresh_refs && exr.exists() && meta.exists() {
        let time = std::fs::read_to_string(&meta)
            .ok()
            .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
            .and_then(|v| v["time_s"].as_f64())
            .unwrap_or(f64::NAN);
        return Ok((read_exr(&exr)?, time, true));
    }
    let _ = std::fs::remove_dir_all(dir);
    let work = dir.join("work");
    std::fs::create_dir_all(&work).map_err(|e| format!("{}: {e}", work.display()))?;
    let r = render(&work)?;
    let produced = std::fs::read_dir(&work)
        .map_err(|e| e.to_string())?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|x| x == "exr"))
        .ok_or("the reference render left no EXR")?;
    std::fs::rename(&produced, &exr).map_err(|e| format!("{}: {e}", exr.display()))?;
    let _ = std::fs::remove_dir_all(&work);
    std::fs::write(
        &meta,
        serde_json::to_string_pretty(&json!({"time_s": r.time, "total_s": r.total})).expect("json"),
    )
    .map_err(|e| format!("{}: {e}", meta.display()))?;
    Ok((r.image, r.time, false))
}

// ---------------------------------------------------------------------------
// The report

struct Row {
    mesh: String,
    lighting: String,
    spp: u32,
    renderer: &'static str,
    variant: String,
    rel_mse: f64,
    time: f64,
    total: f64,
    sampling: f64,
}

impl Row {
    fn product(&self) -> f64 {
        self.rel_mse * self.time
    }
    fn sampling_product(&self) -> f64 {
        self.rel_mse * self.sampling
    }
}

fn machine() -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpuinfo
        .lines()
        .find_map(|l| {
            l.strip_prefix("model name")
                .map(|v| v.trim_start_matches([' ', '\t', ':']))
        })
        .unwrap_or("unknown CPU")
        .trim()
        .to_owned();
    let logical = cpuinfo
        .lines()
        .filter(|l| l.starts_with("processor"))
        .count();
    // Physical cores: distinct (physical id, core id) pairs.
    let mut cores = std::collections::BTreeSet::new();
    let mut package = "";
    for l in cpuinfo.lines() {
        let value = l.split_once(':').map_or("", |(_, v)| v.trim());
        if l.starts_with("physical id") {
            package = value;
        } else if l.starts_with("core id") {
            cores.insert((package, value));
        }
    }
    let avail = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!(
        "{model}, {} cores, {logical} logical CPUs ({avail} available to this process)",
        if cores.is_empty() {
            logical
        } else {
            cores.len()
        }
    )
}

fn date() -> String {
    Command::new("date")
        .args(["-u", "+%Y-%m-%d %H:%M UTC"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        .unwrap_or_else(|| "unknown date".into())
}

/// A hash of the files at `paths` (files, or directories read recursively),
/// with their names.
fn source_hash(paths: &[PathBuf]) -> Result<u64, String> {
    fn walk(p: &Path, files: &mut Vec<PathBuf>) -> Result<(), String> {
        if p.is_dir() {
            let mut entries: Vec<PathBuf> = std::fs::read_dir(p)
                .map_err(|e| format!("{}: {e}", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .collect();
            entries.sort();
            for e in entries {
                walk(&e, files)?;
            }
        } else if p.is_file() {
            files.push(p.to_owned());
        }
        Ok(())
    }
    let mut files = Vec::new();
    for p in paths {
        walk(p, &mut files)?;
    }
    let mut h = FNV_START;
    for f in files {
        let name = f.strip_prefix(env!("CARGO_MANIFEST_DIR")).unwrap_or(&f);
        h = fnv1a(h, name.to_string_lossy().as_bytes());
        h = fnv1a(
            h,
            &std::fs::read(&f).map_err(|e| format!("{}: {e}", f.display()))?,
        );
    }
    Ok(h)
}

fn find_on_path(name: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(name))
            .find(|p| p.is_file())
    })
}

fn fmt_sci(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3e}")
    } else {
        "–".into()
    }
}

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

fn run(o: &Opts, args: &[String]) -> Result<(), String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let scenes_dir = o.out.join("scenes");
    std::fs::create_dir_all(&scenes_dir).map_err(|e| format!("{}: {e}", scenes_dir.display()))?;
    let mut scenes = BTreeMap::new();
    for mesh in &o.meshes {
        // A mesh missing from the shared folder skips its rows.
        if let Err(e) = support::mesh_path(mesh_spec(mesh).expect("checked").file) {
            eprintln!("cycles bench: {mesh}: {e}; skipped");
            continue;
        }
        scenes.insert(mesh.clone(), write_scenes(o, mesh, &scenes_dir)?);
    }
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
    let soupray = Soupray { exe, has_sampler };
    let code_hash = source_hash(&[
        root.join("kernels"),
        root.join("src/trace"),
        root.join("src/film.rs"),
    ])?;

    let command = {
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
    };
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
    let mut rows: Vec<Row> = Vec::new();
    let mut ref_lines: Vec<String> = Vec::new();
    let mut ref_csv = String::from(
        "mesh,lighting,soupray_mean,cycles_mean,difference,cross_rel_mse,soupray_ref_time_s,cycles_ref_time_s\n",
    );
    let mut mismatches = Vec::new();
    let mut device = None;
    for mesh in o.meshes.iter().filter(|m| scenes.contains_key(*m)) {
        for lighting in &o.lightings {
            let scene = &scenes[mesh][lighting];
            let env = if lighting == "sun" { SUN_SKY } else { 1.0 };
            let tag = format!("{mesh}-{lighting}");
            let common = format!(
                "{tag}-{}x{}-spp{}-seed{REF_SEED}-depth{}-scene{:016x}",
                o.width, o.height, o.ref_spp, o.max_depth, scene.hash
            );
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
            // soupray's reference: the first sampler variant.
            let ref_variant = samplers[0].clone();
            let t = Instant::now();
            let (s_ref, s_ref_time, s_cached) = cached_reference(
                o,
                &o.out.join("refs").join(format!(
                    "soupray-{ref_variant}-{common}-code{code_hash:016x}"
                )),
                |dir| soupray.render(o, &ref_job, &ref_variant, o.ref_spp, dir),
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
                        .render(o, &ref_job, &[o.ref_spp], dir)
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
                let p = previews.join(format!("{tag}-{name}.png"));
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
            let cross =
                soupray::compare::relative_mse(&s_ref, &c_ref).map_err(|e| e.to_string())?;
            if diff.abs() > MEAN_TOLERANCE {
                mismatches.push(format!("{tag}: soupray {sm:.4} vs Cycles {cm:.4}"));
            }
            ref_lines.push(format!(
                "| {mesh} | {lighting} | {sm:.4} | {cm:.4} | {:+.2}% | {} |",
                diff * 100.0,
                fmt_sci(cross)
            ));
            let _ = writeln!(
                ref_csv,
                "{mesh},{lighting},{sm},{cm},{diff},{cross},{s_ref_time},{c_ref_time}"
            );

            // The timed renders, each variant after an untimed 1-spp render
            // (PoCL compiles a kernel for its work-group size at the first
            // launch, inside the trace time; its cache keeps it for later runs).
            for variant in &samplers {
                let warm = o
                    .out
                    .join("renders")
                    .join(&tag)
                    .join(format!("soupray-{variant}-warmup"));
                soupray.render(o, &job, variant, 1, &warm)?;
                for &spp in &o.spp {
                    eprintln!("  soupray {variant} {spp} spp…");
                    let dir = o
                        .out
                        .join("renders")
                        .join(&tag)
                        .join(format!("soupray-{variant}-spp{spp}"));
                    let r = soupray.render(o, &job, variant, spp, &dir)?;
                    device = device.or(r.device.clone());
                    rows.push(Row {
                        mesh: mesh.clone(),
                        lighting: lighting.clone(),
                        spp,
                        renderer: "soupray",
                        variant: variant.clone(),
                        rel_mse: soupray::compare::relative_mse(&r.image, &s_ref)
                            .map_err(|e| e.to_string())?,
                        time: r.time,
                        total: r.total,
                        sampling: r.sampling,
                    });
                }
            }
            eprintln!("  Cycles {spp_list} spp…");
            let dir = o.out.join("renders").join(&tag).join("cycles");
            let renders = cycles.render(o, &job, &o.spp, &dir)?;
            for (&spp, r) in o.spp.iter().zip(renders) {
                rows.push(Row {
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
        }
    }

    // The report.
    let mut md = String::new();
    let _ = writeln!(
        md,
        "\nsoupray vs Cycles — machine: {}; soupray device: {}; {}; {}\ncommand: `{command}`\n",
        machine(),
        device.as_deref().unwrap_or("?"),
        cycles.version,
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
        samplers[0],
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
    for l in &ref_lines {
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
    for r in &rows {
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
    print!("{md}");
    let csv_path = o.out.join("results.csv");
    std::fs::write(&csv_path, csv).map_err(|e| format!("{}: {e}", csv_path.display()))?;
    let ref_path = o.out.join("references.csv");
    std::fs::write(&ref_path, ref_csv).map_err(|e| format!("{}: {e}", ref_path.display()))?;
    let md_path = o.out.join("results.md");
    std::fs::write(&md_path, &md).map_err(|e| format!("{}: {e}", md_path.display()))?;
    println!(
        "\nwritten: {}, {}, {}, previews in {}",
        csv_path.display(),
        ref_path.display(),
        md_path.display(),
        previews.display()
    );
    if !mismatches.is_empty() {
        println!(
            "\nWARNING: the references disagree on the mean brightness by more than {}%: {}. \
             The scene translation (units, materials, sun strength, camera) is not like for like.",
            MEAN_TOLERANCE * 100.0,
            mismatches.join("; ")
        );
    }
    Ok(())
}
