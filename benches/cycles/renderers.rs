//! The renderers, run as processes: `soupray render`, and Cycles through
//! `benches/cycles/render_cycles.py` in a Blender binary or in Python with
//! Blender 5's `bpy` module, each returning the image and its times; and
//! finding them.

use crate::opts::Opts;
use soupray::film::Image;
use std::collections::BTreeMap;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

/// One render's times.
#[derive(Clone, Copy)]
pub struct Times {
    /// The measured time (see the module documentation), seconds.
    pub time: f64,
    /// soupray's frame total; for Cycles the same as `time`.
    pub total: f64,
    /// Path tracing alone: soupray's trace time (`time`); Cycles' from its
    /// first sample to the end, from its status messages (Blender 3.4's
    /// status lines: 10 ms resolution).
    pub sampling: f64,
    /// What comes before path tracing: soupray's scene evaluation and BVH
    /// build; Cycles' scene sync and BVH build (`time - sampling`).
    pub setup: f64,
    /// soupray's rays (camera, bounce and shadow) per sample, from the
    /// frame log; NaN for Cycles, which does not count them.
    pub rays_per_sample: f64,
}

/// One render's image and times.
pub struct Render {
    pub image: Image,
    pub times: Times,
    /// soupray: the OpenCL device from the frame log.
    pub device: Option<String>,
}

pub fn read_exr(path: &Path) -> Result<Image, String> {
    soupray::output::read_exr_rgba(path).map_err(|e| format!("{}: {e}", path.display()))
}

pub fn run_logged(cmd: &mut Command, what: &str) -> Result<String, String> {
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

/// What a render is of: the scene, its sky radiance, path depth, whether
/// it keeps the file's materials (otherwise clay), the animation frame
/// (frame N at N / 24 s; 0 for the still scenes) and the seed.
pub struct Job<'a> {
    pub scene: &'a Path,
    pub env: f32,
    pub max_depth: u32,
    pub materials: bool,
    pub frame: u32,
    pub seed: u64,
}

pub struct Soupray {
    pub exe: PathBuf,
    /// Whether `soupray render` takes `--sampler`.
    pub has_sampler: bool,
}

impl Soupray {
    /// Renders `scene` into `dir` (replacing what is there).
    pub fn render(
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
            .args(["--frame", &job.frame.to_string(), "--quiet"])
            .args(["--spp", &spp.to_string()])
            .args(["--width", &o.width.to_string()])
            .args(["--height", &o.height.to_string()])
            .args(["--max-depth", &job.max_depth.to_string()])
            .args(["--seed", &seed.to_string()])
            .args(["--env-color", &format!("{env},{env},{env}")])
            .args(["--name", "img.####.exr"])
            .arg("--out")
            .arg(dir);
        if !job.materials {
            cmd.arg("--clay");
        }
        if self.has_sampler {
            cmd.args(["--sampler", variant]);
        }
        run_logged(
            &mut cmd,
            &format!("soupray render {} ({variant}, {spp} spp)", scene.display()),
        )?;
        let stem = format!("img.{:04}", job.frame);
        let log_path = dir.join(format!("{stem}.json"));
        let text = std::fs::read_to_string(&log_path)
            .map_err(|e| format!("{}: {e}", log_path.display()))?;
        let log: soupray::output::FrameLog =
            serde_json::from_str(&text).map_err(|e| format!("{}: {e}", log_path.display()))?;
        Ok(Render {
            image: read_exr(&dir.join(format!("{stem}.exr")))?,
            times: Times {
                // An animated scene's frame counts its evaluation and
                // build, as Cycles' render counts its sync and BVH build.
                time: (log.timings_ms.trace
                    + if job.frame > 0 {
                        log.timings_ms.evaluate + log.timings_ms.build
                    } else {
                        0.0
                    })
                    / 1e3,
                total: log.timings_ms.total / 1e3,
                sampling: log.timings_ms.trace / 1e3,
                setup: (log.timings_ms.evaluate + log.timings_ms.build) / 1e3,
                rays_per_sample: log.render.rays as f64
                    / (f64::from(o.width) * f64::from(o.height) * f64::from(spp)),
            },
            device: Some(log.device),
        })
    }
}

/// How a Cycles is started.
#[derive(Clone)]
pub enum Launcher {
    /// A Blender binary (Debian's `blender` is 3.4): `blender -b -P script`.
    Binary(PathBuf),
    /// `python3 script` with Blender as a module (`pip install bpy==5.0.1`;
    /// Python 3.11), `PYTHONPATH` set where it was installed with `--target`.
    Module { pythonpath: Option<OsString> },
}

impl Launcher {
    /// The command that runs `script` with the arguments that follow.
    fn command(&self, script: &Path) -> Command {
        match self {
            Launcher::Binary(blender) => {
                let mut cmd = Command::new(blender);
                cmd.args([
                    "-b",
                    "-noaudio",
                    "--factory-startup",
                    "--python-exit-code",
                    "1",
                ])
                .arg("-P")
                .arg(script);
                cmd
            }
            Launcher::Module { pythonpath } => {
                let mut cmd = python(pythonpath);
                cmd.arg(script);
                cmd
            }
        }
    }

    /// Blender's version line (`Blender 3.4.1`), or `None` where this
    /// launcher finds no Blender.
    pub fn version(&self) -> Option<String> {
        let out = match self {
            Launcher::Binary(blender) => Command::new(blender)
                .args(["-b", "--factory-startup", "--version"])
                .stderr(Stdio::null())
                .output(),
            Launcher::Module { pythonpath } => python(pythonpath)
                .args(["-c", "import bpy; print('Blender', bpy.app.version_string)"])
                .stderr(Stdio::null())
                .output(),
        }
        .ok()
        .filter(|o| o.status.success())?;
        String::from_utf8_lossy(&out.stdout)
            .lines()
            .find(|l| l.starts_with("Blender "))
            .map(|l| l.trim().to_owned())
    }
}

fn python(pythonpath: &Option<OsString>) -> Command {
    let mut cmd = Command::new("python3");
    if let Some(p) = pythonpath {
        cmd.env("PYTHONPATH", p);
    }
    cmd
}

/// One Cycles configuration: a Blender, and whether path guiding is on.
#[derive(Clone)]
pub struct Cycles {
    pub launcher: Launcher,
    pub script: PathBuf,
    /// Blender's version line, e.g. `Blender 5.0.1`.
    pub version: String,
    /// Blender's major and minor version (`5.0`): the configurations of
    /// one version share its reference, and the better one is compared.
    pub anchor: String,
    /// The report's name for it: `3.4`, `5.0`, `5.0 guided`.
    pub label: String,
    /// Path guiding on surfaces and volumes (Cycles' CPU-only guiding).
    pub guiding: bool,
}

impl Cycles {
    /// Renders `scene` at each of `spps` in one Blender process; the EXRs
    /// go to `dir/cycles-sppN.exr`.
    pub fn render(
        &self,
        o: &Opts,
        job: &Job,
        spps: &[u32],
        dir: &Path,
    ) -> Result<Vec<Render>, String> {
        let (scene, env, seed) = (job.scene, job.env, job.seed);
        std::fs::create_dir_all(dir).map_err(|e| format!("{}: {e}", dir.display()))?;
        let spp_list = spps
            .iter()
            .map(u32::to_string)
            .collect::<Vec<_>>()
            .join(",");
        let mut cmd = self.launcher.command(&self.script);
        cmd.arg("--")
            .arg("--scene")
            .arg(scene)
            .args(["--width", &o.width.to_string()])
            .args(["--height", &o.height.to_string()])
            .args(["--spp", &spp_list])
            .args(["--seed", &seed.to_string()])
            .args(["--max-bounces", &(job.max_depth.max(1) - 1).to_string()])
            .args(["--threads", &o.threads.to_string()])
            .args(["--env", &format!("{env},{env},{env}")])
            .arg("--warmup")
            .arg("--out-dir")
            .arg(dir);
        if self.guiding {
            cmd.arg("--guiding");
        }
        if job.materials {
            cmd.arg("--keep-materials");
        }
        if job.frame > 0 {
            cmd.args(["--frame", &job.frame.to_string()]);
        }
        let stdout = run_logged(
            &mut cmd,
            &format!("Cycles {} {} ({spp_list} spp)", self.label, scene.display()),
        )?;
        let mut seconds = BTreeMap::new();
        // Blender 3.4 hands its render_stats handler nothing, but prints
        // its status lines: the elapsed time when the first sample starts
        // and when it finishes (10 ms resolution).
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
                    .and_then(|v| v.parse::<f64>().ok())
            };
            if let (Some(spp), Some(s)) = (field("spp"), field("seconds")) {
                let sampling = match (field("sampling"), first_sample, finished) {
                    (Some(t), _, _) if t.is_finite() => t,
                    (_, Some(a), Some(b)) if b >= a => b - a,
                    _ => f64::NAN,
                };
                seconds.insert(spp as u32, (s, sampling));
            }
            (first_sample, finished) = (None, None);
        }
        spps.iter()
            .map(|&spp| {
                let (time, sampling) = *seconds.get(&spp).ok_or_else(|| {
                    format!("blender printed no CYCLES_RENDER line for {spp} spp")
                })?;
                Ok(Render {
                    image: read_exr(&dir.join(format!("cycles-spp{spp}.exr")))?,
                    times: Times {
                        time,
                        total: time,
                        sampling,
                        setup: time - sampling,
                        rays_per_sample: f64::NAN,
                    },
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

pub fn find_on_path(name: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(name))
            .find(|p| p.is_file())
    })
}
