//! `soupray render`: the batch job users run on workstations and render
//! nodes. It resolves the job once (scene, frames, output names, device)
//! before any work starts, then runs each frame through the library's
//! `pipeline::FrameRenderer` (evaluate → build → trace → film) and writes
//! it (EXR, preview, log) on a second thread, so the next frame's
//! evaluation overlaps the write. This module holds what only the command
//! needs: its flags, the job (`job`), progress and signals (`progress`),
//! the writer thread and the temporaries a killed run left.
//!
//! Files are only ever written through `output::write_atomic` (temporary
//! beside the target, fsync, rename), so a killed run never leaves a
//! truncated frame under its final name, and `--skip-existing` can resume a
//! re-queued chunk. SIGINT/SIGTERM stop the job at the next stage boundary;
//! the frame in flight is not written and the exit code is 130/143.

mod job;
mod progress;

use crate::cli::frames::{self, FramePaths};
use crate::denoise::Denoiser;
use crate::device::Device;
use crate::film::{self, Image};
use crate::output::{self, FrameLog, FrameMetadata};
use crate::pipeline::{self, FrameProgress, FrameRenderer};
use crate::scene::{LoadOptions, Scene};
use crate::UsageError;
use job::Job;
use progress::{Progress, Signals};
use std::path::{Path, PathBuf};
use std::sync::mpsc;
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
    /// The EXR's lossless compression: zip (zlib over 16 scan lines, the
    /// smallest files), zips (zlib per scan line), piz (wavelet, for grainy
    /// images), rle (run lengths: quick to write, larger files) or none.
    /// zip:N and zips:N set zlib's level, 1 (fastest) to 9 (smallest; 2
    /// unless given): with many passes on few cores, zip:1 leaves the trace
    /// more of the CPU for files about 7% larger. docs/output.md
    #[arg(
        long,
        default_value = "zip",
        value_name = "KIND",
        help_heading = "Output"
    )]
    pub exr_compression: String,
    /// Extra EXR channels, comma-separated: depth (Z), normal (N.X N.Y N.Z),
    /// albedo (albedo.R albedo.G albedo.B), sample_count (samples each pixel
    /// took), noise (each pixel's estimated relative error), rays (rays each
    /// pixel traced: where the frame's time went), motion (Vector.X .. W:
    /// each pixel's motion in pixels to the frame before and to the next,
    /// as Blender's Vector pass), position (Position.X .. Z, world space),
    /// uv (UV.U, UV.V: TEXCOORD_0), object_id (the glTF node index + 1 of
    /// the object covering most of the pixel; 0 for none).
    #[arg(long, value_name = "LIST", help_heading = "Output")]
    pub aov: Option<String>,
    /// Light-path passes, named as Blender's: `light` for all, or any of
    /// diffuse (DiffDir, DiffInd, DiffCol), glossy (GlossDir, GlossInd,
    /// GlossCol), transmission (TransDir, TransInd, TransCol), emission
    /// (Emit: what the camera sees emitted) and environment (Env: the
    /// environment the camera sees). Dir is the light that reached the
    /// first surface's lobe from a light, Ind all the rest, Col the lobe's
    /// colour, so that (DiffDir + DiffInd) * DiffCol + (GlossDir +
    /// GlossInd) * GlossCol + (TransDir + TransInd) * TransCol + Emit +
    /// Env = the beauty (RGB; before --denoise and the shadow catcher's
    /// shadow). See docs/output.md.
    #[arg(long, value_name = "LIST", help_heading = "Output")]
    pub passes: Option<String>,
    /// Make NODE's meshes (and its children's) a shadow catcher: invisible
    /// to the camera except for the shadows the rest of the scene casts on
    /// them, written to alpha and to the `shadow` channels, so a CG
    /// element composites onto a filmed plate. Pair with --transparent.
    /// By name or index; repeatable. A node's glTF extras
    /// {"soupray": {"shadow_catcher": true}} do the same.
    #[arg(long, value_name = "NODE", help_heading = "Compositing")]
    pub shadow_catcher: Vec<String>,
    /// Cut NODE's meshes (and its children's) out of the frame: RGB and
    /// alpha 0 where the camera sees them, while they still hide what is
    /// behind them and light and shadow the rest. By name or index;
    /// repeatable; or the node's extras {"soupray": {"holdout": true}}.
    #[arg(long, value_name = "NODE", help_heading = "Compositing")]
    pub holdout: Vec<String>,
    /// Cryptomatte layers, comma-separated: object (each glTF node that
    /// places a mesh, by name, or by its path of names where names repeat),
    /// material (by name) and asset (the object's root node). Written to
    /// the specification Cycles, Nuke and Blender's compositor read:
    /// layers CryptoObject, CryptoMaterial, CryptoAsset with their
    /// manifests. Coverage comes from the same samples as the beauty, so a
    /// pixel's mattes add up to its alpha.
    #[arg(long, value_name = "LIST", help_heading = "Output")]
    pub cryptomatte: Option<String>,
    /// Ranks per pixel in each Cryptomatte layer: how many objects can
    /// share a pixel's edge (rounded up to even; 1 to 16).
    #[arg(long, value_name = "N", default_value_t = 6, help_heading = "Output")]
    pub cryptomatte_depth: u32,
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
    /// Each bounce picks one of the point and spot lights past 8 (fewer are
    /// all sampled at every bounce) through a light tree, by how much each
    /// group may send to the point being shaded: nearby lights facing it
    /// are chosen more often than distant ones. Emissive triangles join the
    /// tree when they spread over at least a quarter of the scene (a street
    /// of lamps, a lit ceiling); gathered in one small object (a lamp, a
    /// glowing helmet) they are picked by power, which costs less per
    /// sample there for about the same noise. This flag puts them in the
    /// tree wherever they are. The frame log's `render.light_selection`
    /// says what was chosen.
    #[arg(long, help_heading = "Image", conflicts_with = "no_light_tree")]
    pub light_tree: bool,
    /// Picks every light and emitter in proportion to its power alone,
    /// wherever the point being shaded is: the same image on average,
    /// noisier among many lights (a street of lamps).
    #[arg(long, help_heading = "Image")]
    pub no_light_tree: bool,
    /// How a dielectric's base (its diffuse and transmission) lies under its
    /// specular layer: `energy` (the default) scales it by what the layer
    /// does not reflect, the layer's tabulated albedo, so a white
    /// dielectric under a white sky returns all it receives at every
    /// roughness (and a sheen leaves its base what it does not reflect);
    /// `spec` is the glTF specification's `fresnel_mix` as written (1 - F
    /// per microfacet, which loses up to 3% on rough white plastic), for
    /// comparisons with other glTF renderers. docs/materials.md
    #[arg(
        long,
        default_value = "energy",
        value_name = "KIND",
        help_heading = "Image"
    )]
    pub layering: String,
    /// Let rays pass through the back faces of single-sided materials
    /// (glTF's doubleSided false), as a rasterizer such as the Khronos
    /// Sample Viewer culls them. By default back faces are shaded as front
    /// faces are, as in Cycles, so a mesh with flipped parts has no holes;
    /// a single-sided emitter emits from its front only either way.
    #[arg(long, help_heading = "Image")]
    pub backface_culling: bool,
    /// Leave the environment out where the camera sees it directly: RGB and
    /// alpha 0 there (premultiplied), for compositing over a plate. It still
    /// lights the scene and shows in reflections and through glass. --png
    /// previews are composited over a neutral grey.
    #[arg(long, help_heading = "Image")]
    pub transparent: bool,
    /// Depth of field: open the camera's lens to this f-number (e.g. 2.8;
    /// smaller is blurrier). glTF cameras are pinholes, so soupray adds a
    /// thin lens with Blender's 36 mm sensor across the image's wider side:
    /// the same f-stop blurs as in Blender. Needs --focus-distance.
    /// Perspective cameras only.
    #[arg(long, value_name = "F_STOP", help_heading = "Depth of field")]
    pub aperture: Option<f32>,
    /// The distance from the camera to the plane in focus, along the view
    /// direction, in scene units (metres in glTF).
    #[arg(long, value_name = "M", help_heading = "Depth of field")]
    pub focus_distance: Option<f32>,
    /// Focus on a node instead, by name or index: each frame the plane in
    /// focus passes through the node's origin, so a moving subject stays
    /// sharp.
    #[arg(long, value_name = "NODE", help_heading = "Depth of field")]
    pub focus_on: Option<String>,
    /// A polygonal aperture with N blades (its bokeh takes that shape);
    /// 0 for a round one.
    #[arg(
        long,
        default_value_t = 0,
        value_name = "N",
        help_heading = "Depth of field"
    )]
    pub blades: u32,
    /// The first blade's angle, in degrees, counter-clockwise from the
    /// image's right.
    #[arg(
        long,
        default_value_t = 0.0,
        value_name = "DEGREES",
        help_heading = "Depth of field"
    )]
    pub blade_rotation: f32,
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
    /// BVH traversal: `wide8` (the default: front to back with a stack, over
    /// the tree collapsed into 8-wide nodes), `wide` (the same over 4-wide
    /// nodes), `stack` (front to back over the builder's binary tree as it
    /// is) or `stackless` (escape indices, the paper's comparison). All four
    /// give the same image; only the time differs.
    #[arg(
        long,
        default_value = "wide8",
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

/// The job's view of a frame in flight: samples on the bar, and a stop
/// between stages on a signal.
struct Watch<'a> {
    progress: &'a Progress,
    signals: &'a Signals,
}

impl FrameProgress for Watch<'_> {
    fn samples(&self, done: u32) {
        self.progress.samples(done);
    }

    fn stage_done(&self) -> anyhow::Result<()> {
        Ok(self.signals.check()?)
    }
}

/// Runs `frame` through the pipeline and names its files.
fn render_frame(
    renderer: &mut FrameRenderer,
    job: &Job,
    frame: i64,
    progress: &Progress,
    signals: &Signals,
) -> anyhow::Result<FrameResult> {
    let started = Instant::now();
    let done = renderer.render(frame, &Watch { progress, signals })?;
    let paths = frames::frame_paths(&job.out_dir, &job.pattern, frame);
    let mut log = done.log;
    log.output = output::OutputLog {
        exr: paths.exr.display().to_string(),
        png: None,
        half: false,
        compression: String::new(),
        aovs: job.aov_names.clone(),
        cryptomatte: done
            .image
            .mattes
            .iter()
            .map(|m| m.kind.layer_name().to_owned())
            .collect(),
        cryptomatte_depth: job.settings.render.cryptomatte.as_ref().map(|c| c.depth),
    };
    if let Some(dark) = &done.dark {
        progress.warn(&format!("frame {frame}: {dark}"));
    }
    if progress.verbose {
        let (t, stages) = (&log.timings_ms, &done.build.stages_ms);
        progress.line(&format!(
            "frame {frame}: evaluate {:.1} ms, build {:.1} ms \
             (large {:.1} / medium {:.1} / small {:.1} device, host {:.1}), trace {:.1} ms, \
             {} rays",
            t.evaluate,
            t.build,
            stages.large,
            stages.medium,
            stages.small,
            done.build.host_ms,
            t.trace,
            log.render.rays
        ));
    }
    Ok(FrameResult {
        frame,
        paths,
        image: done.image,
        denoised: done.denoised,
        log,
        started,
    })
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}

/// A frame the writer finished: its farm-log line, or why it failed.
type Written = (i64, Result<String, String>);

/// How the writer thread writes each frame.
#[derive(Clone, Copy)]
struct WriteOptions {
    format: output::ExrFormat,
    png: bool,
    /// `--transparent`: previews are composited over a neutral grey.
    transparent: bool,
    spp: u32,
    seed: u64,
}

/// Writes finished frames on its own thread, in order: EXR, preview, then
/// the log (which records the write time), each atomically. The log comes
/// last, so a frame counts as done only when everything is on disk.
fn spawn_writer(
    options: WriteOptions,
    spare: mpsc::Sender<Image>,
) -> (
    mpsc::SyncSender<FrameResult>,
    std::thread::JoinHandle<Vec<Written>>,
) {
    // One frame in the queue at most: evaluation of the next frame overlaps
    // the write of this one, without piling images up in memory.
    let (send, receive) = mpsc::sync_channel::<FrameResult>(1);
    let handle = std::thread::spawn(move || {
        let mut results = Vec::new();
        // The encoded file, reused from frame to frame (`write_exr_denoised`).
        let mut encoded = Vec::new();
        for mut done in receive {
            let written = write_frame(&mut done, options, &mut encoded);
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
            // Its buffers, for a later frame's image (none if the renderer
            // is gone).
            let _ = spare.send(done.image);
        }
        results
    });
    (send, handle)
}

/// Writes one frame's EXR, preview and log, and records the write time.
fn write_frame(
    done: &mut FrameResult,
    options: WriteOptions,
    encoded: &mut Vec<u8>,
) -> Result<(), output::OutputError> {
    let WriteOptions {
        format,
        png,
        transparent,
        spp,
        seed,
    } = options;
    let t = Instant::now();
    let meta = FrameMetadata {
        frame: done.frame,
        time: done.log.time,
        spp,
        seed,
    };
    output::write_exr_denoised(
        &done.paths.exr,
        &done.image,
        done.denoised.as_deref(),
        &meta,
        format,
        encoded,
    )?;
    if png {
        // The preview shows the final (denoised) beauty.
        let preview = match &done.denoised {
            Some(d) => {
                let mut p = done.image.clone();
                pipeline::replace_beauty(&mut p, d);
                std::borrow::Cow::Owned(p)
            }
            None => std::borrow::Cow::Borrowed(&done.image),
        };
        output::write_png_preview(&done.paths.png, &preview, 0.0, transparent)?;
        done.log.output.png = Some(done.paths.png.display().to_string());
    }
    done.log.output.half = format.half;
    done.log.output.compression = format.compression_name();
    done.log.timings_ms.write = ms(t);
    done.log.timings_ms.total = ms(done.started);
    output::write_log(&done.paths.log, &done.log)
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

/// The scene named on the command line, or the shipped animation.
fn load_scene(args: &RenderArgs) -> anyhow::Result<(PathBuf, Scene)> {
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
    Ok((scene_path, scene))
}

/// Tells what the job is about to do, after clearing what a killed run
/// left, and checks that a frame's soup fits the device.
fn announce(
    job: &Job,
    scene: &Scene,
    device: &Device,
    denoiser: Option<&Denoiser>,
    progress: &Progress,
) -> anyhow::Result<()> {
    let scene_path = &job.settings.scene_path;
    let render = &job.settings.render;
    let stale = remove_stale_temporaries(job);
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
        render.width,
        render.height,
        render.spp,
        device.info.name
    ));
    if let Some(d) = denoiser {
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
    Ok(())
}

/// How the frame loop ended: the frames that failed, and the signal that
/// stopped it, if one did.
struct Rendered {
    failed: Vec<i64>,
    interrupted: Option<(i32, &'static str)>,
}

/// Renders the job's frames in order and hands each to the writer. The
/// first frame rendered is warmed up first, and its log reports the
/// start-up time (from `startup`).
fn render_frames(
    args: &RenderArgs,
    job: &Job,
    renderer: &mut FrameRenderer,
    progress: &Progress,
    signals: &Signals,
    startup: Instant,
    writer: mpsc::SyncSender<FrameResult>,
) -> Rendered {
    let mut failed = Vec::new();
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
            Some(_) => render_frame(renderer, job, frame, progress, signals),
            // A frame whose warm-up fails fails the same way when rendered,
            // which reports the stage; the next frame warms up again.
            None => match renderer.warm_up(frame) {
                Ok(()) => {
                    let ms = ms(startup);
                    startup_ms = Some(ms);
                    render_frame(renderer, job, frame, progress, signals).map(|mut r| {
                        r.log.timings_ms.startup = ms;
                        r
                    })
                }
                Err(_) => render_frame(renderer, job, frame, progress, signals),
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
                    let interrupted = match j {
                        JobError::Interrupted { signal, name } => Some((*signal, *name)),
                        _ => None,
                    };
                    return Rendered {
                        failed,
                        interrupted,
                    };
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
    Rendered {
        failed,
        interrupted: None,
    }
}

pub fn run_render(args: &RenderArgs) -> anyhow::Result<()> {
    // First, before anything touches OpenCL: the OpenCL compiler (LLVM in
    // PoCL) installs SIGINT/SIGTERM handlers that re-raise the signal with
    // its default action. Installed after them, ours would chain to theirs
    // and the process would die mid-frame; installed first, theirs restore
    // ours before re-raising, and the job stops cleanly.
    let signals = Signals::install();
    let (scene_path, scene) = load_scene(args)?;
    let job = job::resolve_job(args, &scene, &scene_path)?;
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
        Some(Denoiser::open(args.denoise_quality.parse()?)?)
    } else {
        None
    };
    let device = Device::open(args.device.as_deref())?;
    let (spp, seed) = (job.settings.render.spp, job.settings.render.seed);
    let progress = Progress::new(job.frames.len(), spp, args);
    announce(&job, &scene, &device, denoiser.as_ref(), &progress)?;
    let mut renderer = FrameRenderer::new(&device, &scene, job.settings.clone(), denoiser)?;
    signals.deferred();
    signals.check()?;
    let (spare_send, spare) = film::SpareImages::channel();
    renderer.reuse_images(spare);
    let (writer, writer_done) = spawn_writer(
        WriteOptions {
            format: job.exr_format,
            png: args.png,
            transparent: args.transparent,
            spp,
            seed,
        },
        spare_send,
    );
    let Rendered {
        mut failed,
        interrupted,
    } = render_frames(
        args,
        &job,
        &mut renderer,
        &progress,
        &signals,
        startup,
        writer,
    );
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
