//! `soupray render`: the batch job users run on workstations and render
//! nodes. It resolves the job once (scene, frames, output names, device)
//! before any work starts, then runs each frame through the pipeline's
//! stages in order: evaluate (the soup on the device) → build (the BVH) →
//! trace (the path tracer) → write (EXR, preview, log). Writing happens on
//! a second thread so the next frame's evaluation overlaps it.
//!
//! Files are only ever written through `output::write_atomic` (temporary
//! beside the target, fsync, rename), so a killed run never leaves a
//! truncated frame under its final name, and `--skip-existing` can resume a
//! re-queued chunk. SIGINT/SIGTERM stop the job at the next stage boundary;
//! the frame in flight is not written and the exit code is 130/143.

use crate::bvh::device_builder::{BuildStats, DeviceBuilder};
use crate::bvh::{self, BuildParams};
use crate::cli::frames::{self, FrameArgs, FramePaths, NamePattern};
use crate::device::Device;
use crate::film::{Aovs, Image};
use crate::output::{self, CameraLog, FrameLog, FrameMetadata};
use crate::scene::{LoadOptions, Projection, Scene};
use crate::soup::device::DeviceSoup;
use crate::soup::motion::{motion_steps, MotionSoup};
use crate::trace::motion::{step_times, Shutter, ShutterPosition};
use crate::trace::render::MotionFrame;
use crate::trace::render::{Adaptive, Allocation};
use crate::trace::render::{
    Environment, FrameInput, PathTracer, RenderOutput, RenderSettings, Traversal,
};
use crate::trace::sampling::{NoisePattern, Sampler};
use crate::UsageError;
use anyhow::Context as _;
use std::io::IsTerminal as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{mpsc, Arc};
use std::time::Instant;

/// The animation `soupray render` renders when no SCENE is given.
pub const DEFAULT_SCENE: &str = "animations/walker/walker.glb";

/// Render frames of a glTF animation to EXR, with a JSON log per frame.
///
/// Examples:
///
///   soupray render                                  # the shipped animation
///   soupray render walk.glb --frames 1-48 --spp 64 --png
///   soupray render walk.glb --start 1 --end 100 --step 1 --out /shots/walk
///   soupray render walk.glb --frame 12 --aov depth,normal,albedo --half
///
/// Each frame N is written as OUT/NAME with #### replaced by N (zero-padded),
/// plus NAME.json with timings, BVH statistics and warnings. Files appear
/// only when complete (written to a temporary file, then renamed).
#[derive(clap::Args, Debug, Clone)]
#[command(verbatim_doc_comment, after_help = crate::EXIT_CODES)]
pub struct RenderArgs {
    /// The glTF 2.0 animation (.glb, or .gltf with its files). Default: the
    /// animation shipped in animations/.
    #[arg(value_name = "SCENE")]
    pub scene: Option<PathBuf>,

    /// Frames to render: a list of N, A-B (inclusive) and A-B:STEP items,
    /// e.g. 1-10,15,20-30:2. Default: the whole animation.
    #[arg(
        long,
        value_name = "SPEC",
        allow_hyphen_values = true,
        help_heading = "Frames"
    )]
    pub frames: Option<String>,
    /// One frame.
    #[arg(
        long,
        value_name = "N",
        allow_negative_numbers = true,
        help_heading = "Frames"
    )]
    pub frame: Option<i64>,
    /// First frame of a chunk (farm templates: --start <first> --end <last>).
    #[arg(
        long,
        value_name = "N",
        allow_negative_numbers = true,
        help_heading = "Frames"
    )]
    pub start: Option<i64>,
    /// Last frame of a chunk, inclusive; never rendered past.
    #[arg(
        long,
        value_name = "N",
        allow_negative_numbers = true,
        help_heading = "Frames"
    )]
    pub end: Option<i64>,
    /// Step between frames of a chunk.
    #[arg(long, value_name = "N", help_heading = "Frames")]
    pub step: Option<i64>,
    /// Frames per second: frame N is at time N / FPS.
    #[arg(
        long,
        default_value_t = 24.0,
        value_name = "FPS",
        help_heading = "Frames"
    )]
    pub fps: f64,

    /// Output directory, created as needed. Default: out/<scene stem>/.
    #[arg(long, value_name = "DIR", help_heading = "Output")]
    pub out: Option<PathBuf>,
    /// File name pattern; the last run of # is the zero-padded frame number.
    /// Default: <stem>.####.exr.
    #[arg(long, value_name = "PATTERN", help_heading = "Output")]
    pub name: Option<String>,
    /// Skip frames whose EXR and log are already complete (resume a chunk).
    #[arg(long, help_heading = "Output")]
    pub skip_existing: bool,
    /// Write half-float (f16) colour channels instead of f32.
    #[arg(long, help_heading = "Output")]
    pub half: bool,
    /// Extra EXR channels, comma-separated: depth (Z), normal (N.X N.Y N.Z),
    /// albedo (albedo.R albedo.G albedo.B), sample_count (samples each pixel
    /// took), noise (each pixel's estimated relative error), rays (rays each
    /// pixel traced: where the frame's time went).
    #[arg(long, value_name = "LIST", help_heading = "Output")]
    pub aov: Option<String>,
    /// Also write a tonemapped sRGB PNG preview beside each EXR.
    #[arg(long, help_heading = "Output")]
    pub png: bool,
    /// Denoise each frame with Intel Open Image Denoise 2.x (its RT filter,
    /// HDR, with prefiltered albedo and normal from the same samples). The
    /// denoised image goes to R, G, B; the raw one is kept as the layer
    /// noisy.R, noisy.G, noisy.B. OIDN is loaded at run time: from
    /// SOUPRAY_OIDN (the library's path), the library path, or where
    /// scripts/setup.sh installs it; without it, exit code 3.
    #[arg(long, help_heading = "Output")]
    pub denoise: bool,
    /// OIDN's filter quality with --denoise: `high` (the default, for final
    /// frames), `balanced` or `fast` (previews: faster, a little less sharp).
    #[arg(
        long,
        default_value = "high",
        value_name = "Q",
        requires = "denoise",
        help_heading = "Output"
    )]
    pub denoise_quality: String,

    /// Image width in pixels. Default 640.
    #[arg(long, value_name = "PX", help_heading = "Image")]
    pub width: Option<u32>,
    /// Image height in pixels. Default: 360, or from the width and the
    /// camera's aspect ratio when the file gives one.
    #[arg(long, value_name = "PX", help_heading = "Image")]
    pub height: Option<u32>,
    /// Samples per pixel; with --noise-threshold, the most a pixel takes.
    #[arg(
        long,
        visible_alias = "max-spp",
        default_value_t = 16,
        value_name = "N",
        help_heading = "Image"
    )]
    pub spp: u32,
    /// Adaptive sampling: a pixel stops once the estimated relative error of
    /// its mean is below T (with --adaptive-allocation error, e.g. 0.02:
    /// the frame's relative MSE then comes out near T^2 or below), or below
    /// T scaled by the work it has done (time, the default: see there; for
    /// the same error T is about half). Checks run after --min-spp and then at
    /// steps of half the count so far (16, 24, 32, 48, 72, ...), at fixed
    /// sample counts, so the image stays reproducible bit for bit.
    /// Raise --spp to let hard pixels go further: `--spp 1024
    /// --noise-threshold 0.02`. The frame log's `noise` says how close the
    /// frame came.
    #[arg(long, value_name = "T", help_heading = "Image")]
    pub noise_threshold: Option<f32>,
    /// With --noise-threshold: how samples are shared among pixels. `time`
    /// (the default) gives the least error for the time: a pixel stops once
    /// its error is below T * sqrt(W / W0), W the rays it has traced and W0
    /// the frame's mean rays per pixel at the first check, so cheap and
    /// smooth pixels stop at lower error and dear, noisy ones (long paths
    /// into crevices) at higher error; the frame reaches a given error
    /// sooner, with a smaller T than `error` needs. `error` takes every
    /// pixel to the same error T (Cycles' rule).
    #[arg(
        long,
        default_value = "time",
        value_name = "KIND",
        help_heading = "Image"
    )]
    pub adaptive_allocation: String,
    /// With --noise-threshold: samples every pixel takes before its first
    /// convergence check. 8 saves time on frames that are mostly cheap,
    /// smooth background, at a little more bias from stopping on the
    /// evidence of fewer samples (BENCHMARKS.md measures both). Cycles'
    /// automatic minimum is 64 at its default threshold 0.01, 32 at 0.1.
    #[arg(long, default_value_t = 16, value_name = "N", help_heading = "Image")]
    pub min_spp: u32,
    /// Stop sampling each frame after this many seconds of path tracing,
    /// wherever it is (combine with --noise-threshold or --spp as the other
    /// limits). NOT reproducible: where a frame stops depends on the
    /// machine's speed and load; the log records the samples it reached.
    #[arg(long, value_name = "SECONDS", help_heading = "Image")]
    pub time_limit: Option<f64>,
    /// Random seed; the same seed, frame and device give the same image.
    #[arg(long, default_value_t = 0, value_name = "N", help_heading = "Image")]
    pub seed: u64,
    /// Longest light path, in bounces.
    #[arg(long, default_value_t = 8, value_name = "N", help_heading = "Image")]
    pub max_depth: u32,
    /// Camera, by name or index (default: the file's first camera, else one
    /// that frames the whole animation).
    #[arg(long, value_name = "NAME|INDEX", help_heading = "Image")]
    pub camera: Option<String>,
    /// Material variant (KHR_materials_variants), by name or index: its
    /// materials replace the primitives' own where the file maps them
    /// (e.g. a shoe's colourways). `soupray info SCENE` lists the variants;
    /// without the flag the default materials are used.
    #[arg(long, value_name = "NAME|INDEX", help_heading = "Image")]
    pub variant: Option<String>,
    /// Replace every material with white clay (albedo 0.8), for lookdev.
    #[arg(long, help_heading = "Image")]
    pub clay: bool,
    /// Turn off the compensation of the energy that single-scattering GGX
    /// loses at high roughness (a fifth at roughness 0.6, 69% at roughness 1
    /// seen head-on, for a white metal). By default the GGX reflection lobes
    /// return it as multiple bounces between microfacets would (Turquin
    /// 2019, a precomputed albedo table), so a white rough metal under a
    /// white sky returns all it receives, as in Cycles' multiscatter GGX;
    /// this flag gives the single-scattering model of the glTF
    /// specification's Appendix B (darker rough metals).
    #[arg(long, help_heading = "Image")]
    pub no_energy_compensation: bool,
    /// Let rays pass through the back faces of single-sided materials
    /// (glTF's doubleSided false), as a rasterizer such as the Khronos
    /// Sample Viewer culls them. By default back faces are shaded as front
    /// faces are, as in Cycles, so a mesh with flipped parts has no holes;
    /// a single-sided emitter emits from its front only either way.
    #[arg(long, help_heading = "Image")]
    pub backface_culling: bool,
    /// Constant environment radiance, linear RGB (e.g. 0.5,0.6,1.0).
    /// Without this or --env: the file's own sky, where its scene's extras
    /// give one ({"soupray": {"environment": [r, g, b]}}); else none when
    /// the scene has KHR_lights_punctual lights, and soupray's grey studio
    /// sky (zenith 1.0, horizon 0.7, ground 0.25) when it has none.
    #[arg(long, value_name = "R,G,B", help_heading = "Image")]
    pub env_color: Option<String>,
    /// Equirectangular environment map (.exr), importance sampled.
    #[arg(long, value_name = "FILE.exr", help_heading = "Image")]
    pub env: Option<PathBuf>,

    /// Motion blur: each camera sample sees the scene at its own time within
    /// the shutter, so whatever moves (skins, morphs, animated nodes, the
    /// camera, lights and emissive surfaces) is blurred along its path. Frames where nothing moves within
    /// the shutter render exactly as without blur, at the same cost.
    #[arg(long, help_heading = "Motion blur")]
    pub motion_blur: bool,
    /// How long the shutter is open, in frames (Blender's "Shutter"): 0.5
    /// is a 180° shutter, 1 blurs over the whole frame interval. 0 renders
    /// the frame's instant, bit for bit the image without --motion-blur.
    #[arg(
        long,
        default_value_t = 0.5,
        value_name = "FRAMES",
        allow_negative_numbers = true,
        requires = "motion_blur",
        help_heading = "Motion blur"
    )]
    pub shutter: f64,
    /// Where the shutter is open relative to the frame's instant: `center`
    /// (half before, half after), `start` (opens at the frame) or `end`
    /// (closes at the frame).
    #[arg(
        long,
        default_value = "center",
        value_name = "WHERE",
        requires = "motion_blur",
        help_heading = "Motion blur"
    )]
    pub shutter_position: String,
    /// Times within the shutter at which the scene is evaluated (2 to 64);
    /// between them every vertex moves in a straight line. Default: chosen
    /// per frame from the motion: 1 + ceil(turn / 15°), at least 2 (open and
    /// close) and at most 16, where `turn` is the largest rotation of any
    /// node or joint over the shutter; 1 (no motion work) when nothing
    /// moves. Raise it for fast spins whose blur should follow an arc, not
    /// a chord.
    #[arg(
        long,
        value_name = "N",
        requires = "motion_blur",
        help_heading = "Motion blur"
    )]
    pub motion_steps: Option<u32>,

    /// Animation to play, by name or index (default: the first).
    #[arg(long, value_name = "NAME|INDEX", help_heading = "Scene")]
    pub animation: Option<String>,
    /// Which of the file's scenes to render (index; default: its default scene).
    #[arg(long = "gltf-scene", value_name = "N", help_heading = "Scene")]
    pub gltf_scene: Option<usize>,
    /// Drop triangles with NaN or infinite vertices (counted in the log's
    /// warnings) instead of failing the frame.
    #[arg(long, help_heading = "Scene")]
    pub sanitize: bool,

    /// OpenCL device, by index or name substring (see `soupray devices`).
    #[arg(long, value_name = "INDEX|NAME", help_heading = "Device")]
    pub device: Option<String>,
    /// BVH traversal: `wide` (the default: front to back with a stack, over
    /// the tree collapsed into 4-wide nodes), `stack` (front to back over the
    /// builder's binary tree as it is) or `stackless` (escape indices, the
    /// paper's comparison). All three give the same image; only the time
    /// differs.
    #[arg(
        long,
        default_value = "wide",
        value_name = "KIND",
        help_heading = "Device"
    )]
    pub traversal: String,
    /// Sampler of the path tracer's random numbers: `sobol` (the default:
    /// Owen-scrambled Sobol points, stratified over samples, so the error
    /// falls faster with spp than with independent samples) or `random`
    /// (independent uniforms, the sampler before; for comparison). Both
    /// converge to the same image.
    #[arg(
        long,
        default_value = "sobol",
        value_name = "KIND",
        help_heading = "Image"
    )]
    pub sampler: String,
    /// Whether the noise changes from frame to frame: `fixed` (the default,
    /// as in Cycles, "animated seed" off) draws the same samples every
    /// frame, so where nothing moves consecutive frames have the same noise
    /// and still regions flicker far less, raw, adaptive or denoised;
    /// `per-frame` seeds each frame's samples with its frame number, so its
    /// noise is new (averaging frames then averages their noise away). docs/noise.md
    /// explains it; BENCHMARKS.md ("Flicker") measures it.
    #[arg(
        long,
        default_value = "fixed",
        value_name = "KIND",
        help_heading = "Image"
    )]
    pub noise_pattern: String,
    /// SAH bins per axis for the BVH (power of two, 2 to 64).
    #[arg(long, default_value_t = 16, value_name = "N", help_heading = "Device")]
    pub bins: u32,
    /// Largest BVH leaf, in triangles.
    #[arg(
        long = "leaf",
        default_value_t = 4,
        value_name = "N",
        help_heading = "Device"
    )]
    pub leaf_size: u32,

    /// Keep rendering the other frames when one fails (exit code 5 at the end).
    #[arg(long, help_heading = "Job")]
    pub keep_going: bool,
    /// Print only errors.
    #[arg(long, short, conflicts_with = "verbose", help_heading = "Job")]
    pub quiet: bool,
    /// Print each frame's stage timings (evaluate, build with its large/
    /// medium/small device split, trace) and ray count.
    #[arg(long, short, help_heading = "Job")]
    pub verbose: bool,
}

/// Why a render job stopped short. Frame failures carry the frames.
#[derive(Debug, thiserror::Error)]
pub enum JobError {
    #[error("{} of {total} frames failed: {}", failed.len(), list(failed))]
    FramesFailed { failed: Vec<i64>, total: usize },
    #[error("interrupted by {name}; the frame in flight was not written")]
    Interrupted { signal: i32, name: &'static str },
}

fn list(frames: &[i64]) -> String {
    let shown: Vec<String> = frames.iter().take(20).map(i64::to_string).collect();
    let more = frames.len().saturating_sub(20);
    if more > 0 {
        format!("{} and {more} more", shown.join(", "))
    } else {
        shown.join(", ")
    }
}

/// A frame that failed; its message names the frame and the stage.
#[derive(Debug, thiserror::Error)]
#[error("frame {frame}: {stage}: {message}")]
pub struct FrameError {
    pub frame: i64,
    pub stage: &'static str,
    pub message: String,
}

/// The job, resolved from the flags before anything is rendered.
struct Job {
    scene_path: PathBuf,
    frames: Vec<i64>,
    notes: Vec<String>,
    out_dir: PathBuf,
    pattern: NamePattern,
    settings: RenderSettings,
    params: BuildParams,
    aov_names: Vec<String>,
    /// The AOVs written to the EXR (`settings.aovs` adds albedo and normal
    /// for `--denoise`).
    output_aovs: Aovs,
    /// `--motion-blur`: the shutter (a frame moves only when it is open for
    /// some time).
    shutter: Option<Shutter>,
    motion_steps: Option<u32>,
}

fn parse_env_color(s: &str) -> Result<[f32; 3], UsageError> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let values: Option<Vec<f32>> = parts.iter().map(|p| p.parse::<f32>().ok()).collect();
    match values.as_deref() {
        Some([r, g, b]) if [r, g, b].iter().all(|v| v.is_finite() && **v >= 0.0) => {
            Ok([*r, *g, *b])
        }
        _ => Err(UsageError(format!(
            "--env-color {s:?}: expected three non-negative numbers R,G,B (e.g. 0.5,0.6,1.0)"
        ))),
    }
}

/// The image size: the flags, else 640 wide and the camera's aspect ratio
/// (or 16:9 when the file gives none).
fn image_size(args: &RenderArgs, scene: &Scene) -> Result<(u32, u32), UsageError> {
    let camera_aspect =
        scene
            .camera_instance()
            .and_then(|(_, c)| match scene.cameras()[c].projection {
                Projection::Perspective { aspect, .. } => aspect,
                Projection::Orthographic { xmag, ymag, .. } => Some(xmag / ymag),
            });
    let aspect = match camera_aspect {
        Some(a) if a.is_finite() && a > 0.0 => a,
        _ => 16.0 / 9.0,
    };
    let (w, h) = match (args.width, args.height) {
        (Some(w), Some(h)) => (w, h),
        (Some(w), None) => (w, ((w as f32 / aspect).round() as u32).max(1)),
        (None, Some(h)) => (((h as f32 * aspect).round() as u32).max(1), h),
        (None, None) if camera_aspect.is_some() => (640, ((640.0 / aspect).round() as u32).max(1)),
        (None, None) => (640, 360),
    };
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(UsageError(format!(
            "image size {w}x{h} is out of range: use 1 to 16384 pixels per side"
        )));
    }
    Ok((w, h))
}

fn resolve_job(args: &RenderArgs, scene: &Scene, scene_path: &Path) -> anyhow::Result<Job> {
    let params = BuildParams {
        bins: args.bins,
        leaf_size: args.leaf_size,
    };
    params.check().map_err(UsageError)?;
    if args.spp == 0 {
        return Err(UsageError("--spp 0: render at least one sample per pixel".into()).into());
    }
    let allocation: Allocation = args.adaptive_allocation.parse().map_err(|_| {
        UsageError(format!(
            "--adaptive-allocation {:?}: use `time` (the default) or `error`",
            args.adaptive_allocation
        ))
    })?;
    let adaptive = match args.noise_threshold {
        None => None,
        Some(t) if t.is_finite() && t > 0.0 => Some(Adaptive {
            threshold: t,
            min_spp: args.min_spp.clamp(1, args.spp),
            allocation,
        }),
        Some(t) => {
            return Err(UsageError(format!(
                "--noise-threshold {t}: must be a positive number, e.g. 0.02"
            ))
            .into())
        }
    };
    let time_limit = match args.time_limit {
        None => None,
        Some(t) if t.is_finite() && t > 0.0 => Some(std::time::Duration::from_secs_f64(t)),
        Some(t) => {
            return Err(UsageError(format!(
                "--time-limit {t}: must be a positive number of seconds"
            ))
            .into())
        }
    };
    if !(args.fps.is_finite() && args.fps > 0.0) {
        return Err(UsageError(format!("--fps {}: must be a positive number", args.fps)).into());
    }
    let traversal = match args.traversal.as_str() {
        "wide" => Traversal::Wide,
        "stack" => Traversal::Stack,
        "stackless" => Traversal::Stackless,
        other => {
            return Err(UsageError(format!(
                "--traversal {other:?}: use `wide` (the default), `stack` or `stackless`"
            ))
            .into())
        }
    };
    let sampler: Sampler = args.sampler.parse().map_err(|_| {
        UsageError(format!(
            "--sampler {:?}: use `sobol` (the default) or `random`",
            args.sampler
        ))
    })?;
    let noise_pattern: NoisePattern = args.noise_pattern.parse().map_err(|_| {
        UsageError(format!(
            "--noise-pattern {:?}: use `per-frame` or `fixed`",
            args.noise_pattern
        ))
    })?;
    let environment = match (&args.env_color, &args.env) {
        (Some(_), Some(_)) => {
            return Err(UsageError("--env-color and --env exclude each other".into()).into())
        }
        (Some(c), None) => Environment::Color(parse_env_color(c)?),
        (None, Some(p)) => {
            // Refused before the device is set up: not a regular file (exit 4).
            crate::input::open_regular(p).map_err(|e| crate::trace::lights::EnvError::Read {
                path: p.display().to_string(),
                detail: format!(
                    "cannot be read ({e}). Fix: give an equirectangular .exr file, or use --env-color R,G,B."
                ),
            })?;
            Environment::Map(p.clone())
        }
        (None, None) => scene
            .environment()
            .map_or(Environment::Default, Environment::Color),
    };
    let output_aovs = Aovs::parse(args.aov.as_deref().unwrap_or(""))?;
    // The denoiser's auxiliary images come from the film's AOVs.
    let aovs = Aovs {
        normal: output_aovs.normal || args.denoise,
        albedo: output_aovs.albedo || args.denoise,
        ..output_aovs
    };
    let shutter = if args.motion_blur {
        if !(args.shutter.is_finite() && args.shutter >= 0.0 && args.shutter <= 100.0) {
            return Err(UsageError(format!(
                "--shutter {}: the shutter's open time in frames must be a number from 0 to 100 (0.5 is a 180° shutter)",
                args.shutter
            ))
            .into());
        }
        let position: ShutterPosition = args.shutter_position.parse().map_err(UsageError)?;
        Some(Shutter {
            frames: args.shutter,
            position,
        })
    } else {
        None
    };
    if let Some(n) = args.motion_steps {
        if !(2..=64).contains(&n) {
            return Err(UsageError(format!(
                "--motion-steps {n}: use 2 (the shutter's opening and closing) to 64"
            ))
            .into());
        }
    }
    let (width, height) = image_size(args, scene)?;
    let frame_args = FrameArgs {
        frames: args.frames.clone(),
        frame: args.frame,
        start: args.start,
        end: args.end,
        step: args.step,
    };
    let list = frames::resolve_frames(&frame_args, scene.frame_range())?;
    let pattern_text = args
        .name
        .clone()
        .unwrap_or_else(|| frames::default_name_pattern(scene_path));
    let pattern = NamePattern::new(&pattern_text, list.frames.len())?;
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| frames::default_out_dir(scene_path));
    Ok(Job {
        scene_path: scene_path.to_path_buf(),
        frames: list.frames,
        notes: list.notes,
        out_dir,
        pattern,
        settings: RenderSettings {
            width,
            height,
            spp: args.spp,
            seed: args.seed,
            max_depth: args.max_depth,
            clay: args.clay,
            traversal,
            sampler,
            noise_pattern,
            adaptive,
            time_limit,
            environment,
            aovs,
            energy_compensation: !args.no_energy_compensation,
            backface_culling: args.backface_culling,
        },
        params,
        aov_names: output_aovs.names().iter().map(|s| s.to_string()).collect(),
        output_aovs,
        shutter,
        motion_steps: args.motion_steps,
    })
}

/// How the job talks to the person or the farm watching it.
struct Progress {
    bars: Option<(
        indicatif::MultiProgress,
        indicatif::ProgressBar,
        indicatif::ProgressBar,
    )>,
    quiet: bool,
    verbose: bool,
}

impl Progress {
    fn new(frames: usize, spp: u32, args: &RenderArgs) -> Progress {
        let bars = (!args.quiet && std::io::stderr().is_terminal()).then(|| {
            let multi = indicatif::MultiProgress::new();
            let style = indicatif::ProgressStyle::with_template(
                "{prefix:>8} [{bar:40}] {pos}/{len} {msg} ETA {eta}",
            )
            .expect("a valid template")
            .progress_chars("=> ");
            let frames_bar = multi.add(indicatif::ProgressBar::new(frames as u64));
            frames_bar.set_style(style.clone());
            frames_bar.set_prefix("frames");
            let samples = multi.add(indicatif::ProgressBar::new(spp as u64));
            samples.set_style(style);
            samples.set_prefix("samples");
            (multi, frames_bar, samples)
        });
        Progress {
            bars,
            quiet: args.quiet,
            verbose: args.verbose,
        }
    }

    /// A line for the person or the farm log, above the bars on a terminal.
    fn line(&self, text: &str) {
        if self.quiet {
            return;
        }
        match &self.bars {
            Some((multi, _, _)) => {
                let _ = multi.println(text);
            }
            None => eprintln!("{text}"),
        }
    }

    fn warn(&self, text: &str) {
        match &self.bars {
            Some((multi, _, _)) => {
                let _ = multi.println(format!("warning: {text}"));
            }
            None => eprintln!("warning: {text}"),
        }
    }

    fn frame_started(&self, frame: i64) {
        if let Some((_, frames, samples)) = &self.bars {
            frames.set_message(format!("frame {frame}"));
            samples.set_position(0);
        }
    }

    fn samples(&self, done: u32) {
        if let Some((_, _, samples)) = &self.bars {
            samples.set_position(done as u64);
        }
    }

    fn frame_finished(&self) {
        if let Some((_, frames, _)) = &self.bars {
            frames.inc(1);
        }
    }

    fn finish(&self) {
        if let Some((_, frames, samples)) = &self.bars {
            samples.finish_and_clear();
            frames.finish();
        }
    }
}

/// SIGINT/SIGTERM. While the scene loads and the device is set up (nothing
/// of ours is being written), a signal ends the process at once with
/// 128 + signal.
/// Once frames render, the handler records it and the job stops cleanly
/// between stages; a second signal of either kind ends the process at once.
struct Signals {
    received: Arc<AtomicUsize>,
    /// When set, the next signal exits at once. Set during set-up and by
    /// the first signal while rendering.
    immediate: Arc<std::sync::atomic::AtomicBool>,
}

impl Signals {
    fn install() -> Signals {
        use signal_hook::consts::{SIGINT, SIGTERM};
        let received = Arc::new(AtomicUsize::new(0));
        let immediate = Arc::new(std::sync::atomic::AtomicBool::new(true));
        for sig in [SIGINT, SIGTERM] {
            // Runs first: exits (with 128 + signal, as a shell would) when
            // `immediate` is set.
            let _ = signal_hook::flag::register_conditional_shutdown(
                sig,
                128 + sig,
                Arc::clone(&immediate),
            );
            let flag = Arc::clone(&received);
            // SAFETY: the handler only stores to an atomic.
            let _ = unsafe {
                signal_hook::low_level::register(sig, move || {
                    flag.store(sig as usize, Ordering::SeqCst);
                })
            };
            // A second signal exits at once.
            let _ = signal_hook::flag::register(sig, Arc::clone(&immediate));
        }
        Signals {
            received,
            immediate,
        }
    }

    /// From now on a first signal stops the job cleanly instead of at once
    /// (a signal that came in the meantime is reported by `check`).
    fn deferred(&self) {
        self.immediate.store(false, Ordering::SeqCst);
    }

    /// From now on a signal ends the process at once again.
    fn immediate(&self) {
        self.immediate.store(true, Ordering::SeqCst);
    }

    fn check(&self) -> Result<(), JobError> {
        match self.received.load(Ordering::SeqCst) as i32 {
            0 => Ok(()),
            signal => Err(JobError::Interrupted {
                signal,
                name: if signal == signal_hook::consts::SIGTERM {
                    "SIGTERM"
                } else {
                    "SIGINT"
                },
            }),
        }
    }
}

/// Everything that lives across frames: the device, the compiled stages and
/// their buffers.
struct Pipeline<'d> {
    device: &'d Device,
    scene: &'d Scene,
    soup: DeviceSoup<'d>,
    builder: DeviceBuilder<'d>,
    tracer: PathTracer<'d>,
    /// `--denoise`: OIDN, loaded before the first frame.
    denoiser: Option<crate::denoise::Denoiser>,
    /// `--motion-blur` on an animated scene: the soup at every motion step.
    motion: Option<MotionSoup<'d>>,
}

/// A frame that moves within its shutter, as evaluated.
struct MotionState {
    steps: u32,
    /// The camera and the punctual lights at each step.
    cameras: Vec<crate::scene::FrameCamera>,
    lights: Vec<Vec<crate::scene::FrameLight>>,
    extra_evaluate_ms: f64,
    extra_build_ms: f64,
}

/// A frame's evaluation: camera and lights at the frame's instant, and its
/// motion when it moves within the shutter.
struct Evaluated {
    info: crate::soup::device::FrameInfo,
    motion: Option<MotionState>,
    /// `--motion-blur`: the shutter, also for frames that do not move.
    shutter: Option<(Shutter, f64, f64, u32, f64)>,
}

/// What one frame's stages produced, handed to the writer.
struct FrameResult {
    frame: i64,
    paths: FramePaths,
    image: Image,
    /// The denoised beauty (`--denoise`); `image` keeps the raw one.
    denoised: Option<Vec<[f32; 3]>>,
    log: FrameLog,
    started: Instant,
}

impl<'d> Pipeline<'d> {
    /// One pass of `frame` through every stage, its results discarded
    /// (the trace at one sample per pixel): the first launch of every
    /// kernel happens here, where drivers that compile at first launch
    /// (PoCL) do so, and is counted as start-up rather than as the first
    /// frame's build and trace. Evaluation and build are deterministic, so
    /// the frame then renders exactly as it would have.
    fn warm_up(&mut self, job: &Job, frame: i64) -> Result<(), anyhow::Error> {
        let ev = self.evaluate(job, self.scene.time_of_frame(frame))?;
        let (tree, _) = self.build(&ev)?;
        self.trace(frame, &ev, &tree, None)?;
        Ok(())
    }

    /// Evaluates the frame at `time`: once at that instant, or, with motion
    /// blur and something moving within the shutter, at every motion step.
    fn evaluate(&mut self, job: &Job, time: f64) -> Result<Evaluated, anyhow::Error> {
        let planned = match (job.shutter, &self.motion) {
            (Some(shutter), Some(_)) => {
                let (open, close) = shutter.interval(time, self.scene.options().fps);
                let plan = motion_steps(self.scene, open, close, job.motion_steps);
                Some((shutter, open, close, plan.steps, plan.turn_degrees))
            }
            _ => None,
        };
        let (Some((_, open, close, steps, _)), Some(motion)) = (planned, &mut self.motion) else {
            return Ok(Evaluated {
                info: self.soup.evaluate(self.scene, time)?,
                motion: None,
                // Nothing can move (no clip, or the shutter is closed).
                shutter: job.shutter.map(|s| {
                    let (open, close) = s.interval(time, self.scene.options().fps);
                    (s, open, close, 1, 0.0)
                }),
            });
        };
        if steps < 2 {
            return Ok(Evaluated {
                info: self.soup.evaluate(self.scene, time)?,
                motion: None,
                shutter: planned,
            });
        }
        let times = step_times(open, close, steps);
        let t = Instant::now();
        let infos = motion.evaluate(&mut self.soup, self.scene, &times)?;
        let all_ms = ms(t);
        // Lights, and the camera the log reports, at the frame's instant.
        let pose = self.scene.pose(time);
        let mut warnings: Vec<String> = Vec::new();
        for w in infos.iter().flat_map(|i| i.warnings.iter()) {
            if !warnings.contains(w) {
                warnings.push(w.clone());
            }
        }
        let info = crate::soup::device::FrameInfo {
            time,
            camera: self.scene.frame_camera(&pose)?,
            lights: self.scene.frame_lights(&pose),
            warnings,
            reused: false,
        };
        Ok(Evaluated {
            info,
            motion: Some(MotionState {
                steps,
                lights: infos.iter().map(|i| i.lights.clone()).collect(),
                cameras: infos.into_iter().map(|i| i.camera).collect(),
                extra_evaluate_ms: (all_ms - motion.bounds_ms()) * (steps - 1) as f64
                    / steps as f64,
                extra_build_ms: motion.bounds_ms(),
            }),
            shutter: planned,
        })
    }

    /// Builds the frame's tree: over the soup, or over every triangle's
    /// bounds across the motion steps.
    fn build(&mut self, ev: &Evaluated) -> Result<(bvh::Bvh, BuildStats), anyhow::Error> {
        let positions = match (&ev.motion, &self.motion) {
            (Some(_), Some(m)) => m.bounds(),
            _ => self.soup.positions(),
        };
        Ok(self
            .builder
            .build_from_device(positions, self.soup.triangle_count())?)
    }

    /// Traces the frame; `progress: None` is the warm-up pass (1 spp).
    fn trace(
        &mut self,
        frame: i64,
        ev: &Evaluated,
        tree: &bvh::Bvh,
        progress: Option<&Progress>,
    ) -> Result<RenderOutput, anyhow::Error> {
        // KHR_animation_pointer material channels: the frame's materials.
        if let Some(materials) = self.scene.materials_at(ev.info.time) {
            self.tracer.set_materials(materials)?;
        }
        let prim_ids = self
            .builder
            .device_prim_ids()
            .context("the BVH builder has no primitive buffer")?;
        let input = FrameInput {
            frame,
            soup: &self.soup,
            bvh: tree,
            prim_ids,
            camera: &ev.info.camera,
            lights: &ev.info.lights,
        };
        let mut report = |done| {
            if let Some(p) = progress {
                p.samples(done)
            }
        };
        match (&ev.motion, &self.motion) {
            (Some(state), Some(m)) => {
                let motion = MotionFrame {
                    positions: m.positions(),
                    normals: m.normals(),
                    steps: state.steps,
                    cameras: &state.cameras,
                    lights: &state.lights,
                };
                if progress.is_none() {
                    self.tracer.warm_up_motion(&input, &motion)?;
                    return Ok(RenderOutput {
                        image: crate::film::Image::new(1, 1, Aovs::NONE),
                        rays: 0,
                        pixel_rays: Vec::new(),
                        trace_ms: 0.0,
                        noise: Default::default(),
                        warnings: Vec::new(),
                    });
                }
                Ok(self.tracer.render_motion(&input, &motion, &mut report)?)
            }
            _ => {
                if progress.is_none() {
                    self.tracer.warm_up(&input)?;
                    return Ok(RenderOutput {
                        image: crate::film::Image::new(1, 1, Aovs::NONE),
                        rays: 0,
                        pixel_rays: Vec::new(),
                        trace_ms: 0.0,
                        noise: Default::default(),
                        warnings: Vec::new(),
                    });
                }
                Ok(self.tracer.render(&input, &mut report)?)
            }
        }
    }
}

fn camera_log(camera: &crate::scene::FrameCamera) -> CameraLog {
    let m = camera.world_from_camera;
    let v = |x: glam::Vec3| [x.x as f64, x.y as f64, x.z as f64];
    let mut log = CameraLog {
        position: v(camera.position()),
        forward: v(camera.forward()),
        up: v(m.y_axis.truncate().normalize_or_zero()),
        ..CameraLog::default()
    };
    match camera.projection {
        Projection::Perspective { yfov, .. } => {
            log.projection = "perspective".into();
            log.yfov_deg = Some(yfov.to_degrees() as f64);
        }
        Projection::Orthographic { xmag, ymag, .. } => {
            log.projection = "orthographic".into();
            log.xmag = Some(xmag as f64);
            log.ymag = Some(ymag as f64);
        }
    }
    log
}

/// Runs evaluate → build → trace for one frame and fills in its log.
fn render_frame(
    pipe: &mut Pipeline,
    job: &Job,
    frame: i64,
    progress: &Progress,
    signals: &Signals,
) -> Result<FrameResult, anyhow::Error> {
    let started = Instant::now();
    let fail = |stage: &'static str| {
        move |e: anyhow::Error| {
            anyhow::Error::new(FrameError {
                frame,
                stage,
                message: format!("{e:#}"),
            })
        }
    };
    let time = pipe.scene.time_of_frame(frame);

    let t = Instant::now();
    let ev = pipe.evaluate(job, time).map_err(fail("evaluate"))?;
    let evaluate_ms = ms(t);
    signals.check()?;

    let t = Instant::now();
    let (tree, build) = pipe.build(&ev).map_err(fail("build"))?;
    let build_ms = ms(t);
    signals.check()?;

    let t = Instant::now();
    let traced = pipe
        .trace(frame, &ev, &tree, Some(progress))
        .map_err(fail("trace"))?;
    let info = &ev.info;
    let trace_ms = ms(t);
    signals.check()?;

    let mut image = traced.image;
    let mut denoise_log = None;
    let mut denoised = None;
    if let Some(denoiser) = &pipe.denoiser {
        let (d, log) = denoise_image(denoiser, &image).map_err(fail("denoise"))?;
        denoised = Some(d);
        denoise_log = Some(log);
        signals.check()?;
    }
    // AOVs the film kept only for the denoiser are not written.
    if !job.output_aovs.normal {
        image.normal = None;
    }
    if !job.output_aovs.albedo {
        image.albedo = None;
    }

    let shape = tree.shape();
    let paths = frames::frame_paths(&job.out_dir, &job.pattern, frame);
    let mut log = FrameLog::new();
    log.frame = frame;
    log.time = time;
    log.scene = job.scene_path.display().to_string();
    log.device = pipe.device.info.name.clone();
    log.triangles = pipe.soup.triangle_count() as u64;
    log.mesh_instances = pipe.scene.instances().len() as u64;
    log.gpu_instances = pipe.scene.gpu_instance_count() as u64;
    log.memory = output::MemoryLog {
        soup_bytes: pipe.soup.soup_bytes(),
        peak_resident_bytes: output::peak_resident_bytes(),
    };
    log.timings_ms.evaluate = evaluate_ms;
    log.timings_ms.build = build_ms;
    log.timings_ms.trace = trace_ms;
    log.timings_ms.denoise = denoise_log.as_ref().map_or(0.0, |d| d.time_ms);
    log.denoise = denoise_log;
    log.build = output::BuildLog {
        builder: "device".into(),
        bins: job.params.bins,
        leaf_size: job.params.leaf_size,
        nodes: shape.nodes as u64,
        leaves: shape.leaves as u64,
        max_depth: shape.max_depth,
        sah_cost: bvh::sah_cost(&tree),
        stages_ms: build.stages_ms,
    };
    log.render = output::RenderLog {
        width: job.settings.width,
        height: job.settings.height,
        spp: job.settings.spp,
        rays: traced.rays,
        mrays_per_s: traced.rays as f64 / (traced.trace_ms.max(1e-9) * 1e3),
        traversal: job.settings.traversal.name().to_owned(),
        sampler: job.settings.sampler.name().to_owned(),
        noise_pattern: job.settings.noise_pattern.name().to_owned(),
        material_features: pipe
            .tracer
            .material_features()
            .iter()
            .map(|f| (*f).to_owned())
            .collect(),
    };
    log.camera = camera_log(&info.camera);
    log.output = output::OutputLog {
        exr: paths.exr.display().to_string(),
        png: None,
        half: false,
        aovs: job.aov_names.clone(),
    };
    log.noise = traced.noise.clone();
    log.motion = ev.shutter.map(|(shutter, open, close, steps, turn)| {
        let (extra_evaluate_ms, extra_build_ms) = ev
            .motion
            .as_ref()
            .map_or((0.0, 0.0), |m| (m.extra_evaluate_ms, m.extra_build_ms));
        output::MotionLog {
            shutter_frames: shutter.frames,
            shutter_position: match shutter.position {
                ShutterPosition::Center => "center",
                ShutterPosition::Start => "start",
                ShutterPosition::End => "end",
            }
            .to_owned(),
            open,
            close,
            steps,
            steps_from: if job.motion_steps.is_some() && steps > 1 {
                "--motion-steps"
            } else {
                "rule"
            }
            .to_owned(),
            turn_degrees: turn,
            extra_evaluate_ms,
            extra_build_ms,
        }
    });
    // The scene's own warnings (values clamped, channels skipped...) in
    // every frame's log, so each log tells the whole story of its frame.
    log.warnings = pipe.scene.warnings().to_vec();
    log.warnings.extend(info.warnings.iter().cloned());
    log.warnings.extend(traced.warnings.iter().cloned());
    if let Some(dark) = image.darkness_warning() {
        progress.warn(&format!("frame {frame}: {dark}"));
        log.warnings.push(dark);
    }
    if progress.verbose {
        progress.line(&format!(
            "frame {frame}: evaluate {evaluate_ms:.1} ms, build {build_ms:.1} ms \
             (large {:.1} / medium {:.1} / small {:.1} device, host {:.1}), trace {trace_ms:.1} ms, \
             {} rays",
            build.stages_ms.large, build.stages_ms.medium, build.stages_ms.small, build.host_ms, traced.rays
        ));
    }
    Ok(FrameResult {
        frame,
        paths,
        image,
        denoised,
        log,
        started,
    })
}

/// Runs OIDN on a resolved frame (which must carry albedo and normal);
/// pixels no sample hit keep their raw value (`denoise::keep_uncovered`).
fn denoise_image(
    denoiser: &crate::denoise::Denoiser,
    image: &Image,
) -> anyhow::Result<(Vec<[f32; 3]>, crate::denoise::DenoiseLog)> {
    let (Some(albedo), Some(normal)) = (&image.albedo, &image.normal) else {
        anyhow::bail!("the film kept no albedo and normal for the denoiser");
    };
    let color: Vec<[f32; 3]> = image.rgba.iter().map(|p| [p[0], p[1], p[2]]).collect();
    let (mut out, time_ms) = denoiser.denoise(image.width, image.height, &color, albedo, normal)?;
    crate::denoise::keep_uncovered(&mut out, &image.rgba);
    Ok((out, denoiser.log(time_ms)))
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// A frame the writer finished: its farm-log line, or why it failed.
type Written = (i64, Result<String, String>);

/// Writes finished frames on its own thread, in order: EXR, preview, then
/// the log (which records the write time), each atomically. The log comes
/// last, so a frame counts as done only when everything is on disk.
fn spawn_writer(
    half: bool,
    png: bool,
    spp: u32,
    seed: u64,
) -> (
    mpsc::SyncSender<FrameResult>,
    std::thread::JoinHandle<Vec<Written>>,
) {
    // One frame in the queue at most: evaluation of the next frame overlaps
    // the write of this one, without piling images up in memory.
    let (send, receive) = mpsc::sync_channel::<FrameResult>(1);
    let handle = std::thread::spawn(move || {
        let mut results = Vec::new();
        for mut done in receive {
            let t = Instant::now();
            let meta = FrameMetadata {
                frame: done.frame,
                time: done.log.time,
                spp,
                seed,
            };
            let written = output::write_exr_denoised(
                &done.paths.exr,
                &done.image,
                done.denoised.as_deref(),
                &meta,
                half,
            )
            .and_then(|()| {
                if png {
                    // The preview shows the final (denoised) beauty.
                    let preview = match &done.denoised {
                        Some(d) => {
                            let mut p = done.image.clone();
                            for (px, rgb) in p.rgba.iter_mut().zip(d) {
                                px[..3].copy_from_slice(rgb);
                            }
                            std::borrow::Cow::Owned(p)
                        }
                        None => std::borrow::Cow::Borrowed(&done.image),
                    };
                    output::write_png_preview(&done.paths.png, &preview, 0.0)?;
                    done.log.output.png = Some(done.paths.png.display().to_string());
                }
                done.log.output.half = half;
                done.log.timings_ms.write = ms(t);
                done.log.timings_ms.total = ms(done.started);
                output::write_log(&done.paths.log, &done.log)
            });
            // The run's start-up, on the line of the frame whose log has it.
            let startup = match done.log.timings_ms.startup {
                ms if ms > 0.0 => format!(" startup_ms={ms:.1}"),
                _ => String::new(),
            };
            let line = format!(
                "frame {} done{startup} build_ms={:.1} trace_ms={:.1} write_ms={:.1} total_ms={:.1} triangles={} out={}",
                done.frame,
                done.log.timings_ms.build,
                done.log.timings_ms.trace,
                done.log.timings_ms.write,
                done.log.timings_ms.total,
                done.log.triangles,
                done.paths.exr.display()
            );
            results.push((
                done.frame,
                written.map(|()| line).map_err(|e| format!("{e}")),
            ));
        }
        results
    });
    (send, handle)
}

/// Removes the temporaries a killed run left for this job's frames: files
/// named by `output::temporary_sibling` whose
/// process is gone. Only this job's frames are touched, and only when the
/// writer is not running on this machine, so a chunk still writing on
/// another node sharing the directory keeps its files.
fn remove_stale_temporaries(job: &Job) -> usize {
    let Ok(entries) = std::fs::read_dir(&job.out_dir) else {
        return 0;
    };
    let mut targets = std::collections::HashSet::new();
    for &frame in &job.frames {
        let p = frames::frame_paths(&job.out_dir, &job.pattern, frame);
        for f in [p.exr, p.png, p.log] {
            if let Some(name) = f.file_name() {
                targets.insert(name.to_string_lossy().into_owned());
            }
        }
    }
    let mut removed = 0;
    for entry in entries.flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let Some((target, pid)) = output::temporary_owner(&name) else {
            continue;
        };
        let alive = pid == std::process::id() || Path::new(&format!("/proc/{pid}")).exists();
        if targets.contains(target) && !alive && std::fs::remove_file(entry.path()).is_ok() {
            removed += 1;
        }
    }
    removed
}

pub fn run_render(args: &RenderArgs) -> anyhow::Result<()> {
    // First, before anything touches OpenCL: the OpenCL compiler (LLVM in
    // PoCL) installs SIGINT/SIGTERM handlers that re-raise the signal with
    // its default action. Installed after them, ours would chain to theirs
    // and the process would die mid-frame; installed first, theirs restore
    // ours before re-raising, and the job stops cleanly.
    let signals = Signals::install();
    let scene_path = args
        .scene
        .clone()
        .unwrap_or_else(|| PathBuf::from(DEFAULT_SCENE));
    if args.scene.is_none() && !scene_path.exists() {
        return Err(UsageError(format!(
            "no SCENE given and the default animation {DEFAULT_SCENE} is not here; \
             run from the soupray repository or name a .glb/.gltf file"
        ))
        .into());
    }
    let opts = LoadOptions {
        scene: args.gltf_scene,
        animation: args.animation.clone(),
        camera: args.camera.clone(),
        fps: args.fps,
        sanitize: args.sanitize,
        variant: args.variant.clone(),
    };
    let scene = Scene::load(&scene_path, &opts)?;
    let job = resolve_job(args, &scene, &scene_path)?;
    // Fail on an unusable output directory before any rendering starts
    // (a signal now lets its probe file be removed).
    signals.deferred();
    frames::check_output_dir(&job.out_dir)?;
    signals.check()?;
    // Device set-up writes nothing of ours: a signal ends it at once. (A
    // signal merely recorded here would let the OpenCL compiler's own
    // handler delete its temporaries and fail the kernel build.)
    signals.immediate();
    // Start-up: opening the device, compiling the programs (from the
    // driver's cache when it has them) and the warm-up pass before the
    // first frame; the first rendered frame's log reports it apart.
    let startup = Instant::now();
    // And on a missing denoiser (exit code 3, with how to install it).
    let denoiser = if args.denoise {
        Some(crate::denoise::Denoiser::open(
            args.denoise_quality.parse()?,
        )?)
    } else {
        None
    };
    let device = Device::open(args.device.as_deref())?;
    let progress = Progress::new(job.frames.len(), job.settings.spp, args);
    let stale = remove_stale_temporaries(&job);
    if stale > 0 {
        progress.line(&format!(
            "removed {stale} temporary file(s) left by a killed run"
        ));
    }
    for note in job.notes.iter().chain(scene.warnings()) {
        progress.warn(note);
    }
    progress.line(&format!(
        "soupray {}: {} frame(s) of {} at {}x{}, {} spp, on {}",
        output::VERSION,
        job.frames.len(),
        scene_path.display(),
        job.settings.width,
        job.settings.height,
        job.settings.spp,
        device.info.name
    ));
    if let Some(d) = &denoiser {
        progress.line(&format!(
            "denoising with Open Image Denoise {} on its {} device ({})",
            d.version(),
            d.device_type(),
            d.library()
        ));
    }
    let triangles = scene.triangle_count();
    crate::scene::soup_size::check_frame_fits(triangles, Some(device.info.global_mem_mib << 20))
        .map_err(|e| crate::scene::SceneError::invalid(&scene_path.display().to_string(), e))?;
    progress.line(&format!(
        "scene: {triangles} triangles from {} mesh instance(s){}",
        scene.instances().len(),
        match scene.gpu_instance_count() {
            0 => String::new(),
            n => format!(", {n} of them by EXT_mesh_gpu_instancing"),
        }
    ));
    let soup = DeviceSoup::new(&device, &scene)?;
    let mut tracer = PathTracer::new(&device, &scene, &job.settings)?;
    // Blur's programs only when some frame can move: a shutter that stays
    // open on an animated scene.
    let motion = if job.shutter.is_some_and(|s| s.frames > 0.0) && scene.active_clip().is_some() {
        tracer.prepare_motion()?;
        Some(MotionSoup::new(&device, &soup)?)
    } else {
        None
    };
    let mut pipe = Pipeline {
        device: &device,
        scene: &scene,
        soup,
        builder: DeviceBuilder::new(&device, job.params)?,
        tracer,
        denoiser,
        motion,
    };
    signals.deferred();
    signals.check()?;
    let (writer, writer_done) =
        spawn_writer(args.half, args.png, job.settings.spp, job.settings.seed);
    let mut failed = Vec::new();
    let mut interrupted = None;
    let mut startup_ms = None;
    for &frame in &job.frames {
        let paths = frames::frame_paths(&job.out_dir, &job.pattern, frame);
        if args.skip_existing && output::is_frame_done(&paths.exr, &paths.log) {
            progress.line(&format!(
                "frame {frame} skipped (complete) out={}",
                paths.exr.display()
            ));
            progress.frame_finished();
            continue;
        }
        progress.frame_started(frame);
        let result = match startup_ms {
            Some(_) => render_frame(&mut pipe, &job, frame, &progress, &signals),
            // A frame whose warm-up fails fails the same way when rendered,
            // which reports the stage; the next frame warms up again.
            None => match pipe.warm_up(&job, frame) {
                Ok(()) => {
                    let ms = ms(startup);
                    startup_ms = Some(ms);
                    render_frame(&mut pipe, &job, frame, &progress, &signals).map(|mut r| {
                        r.log.timings_ms.startup = ms;
                        r
                    })
                }
                Err(_) => render_frame(&mut pipe, &job, frame, &progress, &signals),
            },
        };
        match result {
            Ok(result) => {
                if writer.send(result).is_err() {
                    break;
                }
            }
            Err(e) => {
                if let Some(j) = e.downcast_ref::<JobError>() {
                    if let JobError::Interrupted { signal, name } = j {
                        interrupted = Some((*signal, *name));
                    }
                    break;
                }
                progress.warn(&format!("{e:#}"));
                failed.push(frame);
                if !args.keep_going {
                    break;
                }
            }
        }
        progress.frame_finished();
    }
    drop(writer);
    let written = writer_done.join().unwrap_or_default();
    for (frame, result) in &written {
        match result {
            Ok(line) => progress.line(line),
            Err(e) => {
                progress.warn(&format!("frame {frame}: write: {e}"));
                failed.push(*frame);
            }
        }
    }
    progress.finish();
    if let Some((signal, name)) = interrupted {
        return Err(JobError::Interrupted { signal, name }.into());
    }
    if !failed.is_empty() {
        failed.sort_unstable();
        return Err(JobError::FramesFailed {
            failed,
            total: job.frames.len(),
        }
        .into());
    }
    Ok(())
}
