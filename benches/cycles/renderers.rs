//! The two renderers, run as processes: `soupray render` and Blender with
//! `benches/cycles/render_cycles.py`, each returning the image and its
//! times; and finding Blender.

use crate::opts::Opts;
use soupray::film::Image;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::Command;

/// One render's image and times.
pub struct Render {
    pub image: Image,
    /// The measured time (see the module documentation), seconds.
    pub time: f64,
    /// soupray's frame total; for Cycles the same as `time`.
    pub total: f64,
    /// Path tracing alone: soupray's trace time (`time`); Cycles' from its
    /// first sample to the end, from Blender's log (10 ms resolution).
    pub sampling: f64,
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

/// What a render is of: the scene, its sky radiance and the seed.
pub struct Job<'a> {
    pub scene: &'a Path,
    pub env: f32,
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

pub struct Cycles {
    pub blender: PathBuf,
    pub script: PathBuf,
    pub version: String,
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

pub fn find_on_path(name: &str) -> Option<PathBuf> {
    std::env::var_os("PATH").and_then(|paths| {
        std::env::split_paths(&paths)
            .map(|d| d.join(name))
            .find(|p| p.is_file())
    })
}
