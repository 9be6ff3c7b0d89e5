//! One frame through every stage: evaluate (the soup on the device) →
//! build (the BVH) → trace (the path tracer) → film (the resolved image,
//! denoised with `--denoise`). `FrameRenderer` owns what lives across
//! frames (the soup, the tree builder, the tracer, the denoiser and, for
//! motion blur, the soup at every motion step) and hands back each frame's
//! image with its log; writing the files (`crate::output`) is the caller's
//! step, as are progress bars, signals and file names (`cli::render`).
//!
//! `soupray bench` shares the per-frame pieces: the frame's materials
//! (`set_frame_materials`) and the denoising step (`denoise_beauty`,
//! `replace_beauty`).

mod log;
mod stages;

use crate::bvh::device_builder::{BuildStats, DeviceBuilder};
use crate::bvh::BuildParams;
use crate::denoise::Denoiser;
use crate::device::Device;
use crate::film::{Aovs, Image};
use crate::output::FrameLog;
use crate::scene::Scene;
use crate::soup::device::DeviceSoup;
use crate::soup::motion::MotionSoup;
use crate::trace::motion::Shutter;
use crate::trace::render::{PathTracer, RenderSettings};
use std::path::PathBuf;
use std::time::Instant;

/// How every frame of a job is made.
#[derive(Clone, Debug, PartialEq)]
pub struct FrameSettings {
    /// The scene's file, as the frame log names it.
    pub scene_path: PathBuf,
    /// The tracer's settings. Its `aovs` are what the film keeps, which
    /// with a denoiser must include albedo and normal.
    pub render: RenderSettings,
    /// The BVH builder's parameters.
    pub build: BuildParams,
    /// The AOVs handed back with the image: those the film kept only for
    /// the denoiser are dropped after denoising.
    pub output_aovs: Aovs,
    /// Motion blur: the shutter (a frame moves only when it is open for
    /// some time and the scene is animated).
    pub shutter: Option<Shutter>,
    /// Motion steps per frame; `None` chooses them from the motion.
    pub motion_steps: Option<u32>,
    /// `--focus-on NODE`: each frame focuses the lens at this node's
    /// origin (its distance along the camera's view direction then).
    pub focus_node: Option<usize>,
}

/// A frame that failed; its message names the frame and the stage.
#[derive(Debug, thiserror::Error)]
#[error("frame {frame}: {stage}: {message}")]
pub struct FrameError {
    pub frame: i64,
    pub stage: &'static str,
    pub message: String,
}

/// What the caller sees of a frame while it renders.
pub trait FrameProgress {
    /// Samples per pixel traced so far.
    fn samples(&self, _done: u32) {}
    /// Called after each stage (evaluate, build, trace and, with a
    /// denoiser, denoise); an error stops the frame there and is returned
    /// as it is, not as a `FrameError` (e.g. a signal asking to stop).
    fn stage_done(&self) -> anyhow::Result<()> {
        Ok(())
    }
}

/// A caller that watches nothing and never stops a frame.
impl FrameProgress for () {}

/// What one frame's stages produced.
#[derive(Debug)]
pub struct RenderedFrame {
    /// The resolved film, with the raw beauty and the output AOVs.
    pub image: Image,
    /// The denoised beauty (with a denoiser); `image` keeps the raw one.
    pub denoised: Option<Vec<[f32; 3]>>,
    /// The frame's log, complete but for `output` (the files' names, the
    /// write time and the total, which the writing step fills in).
    pub log: FrameLog,
    /// The tree build's statistics (the log keeps the device stages).
    pub build: BuildStats,
    /// The image's darkness warning (also among the log's warnings).
    pub dark: Option<String>,
}

/// Everything that lives across frames: the device, the compiled stages and
/// their buffers.
pub struct FrameRenderer<'d> {
    device: &'d Device,
    scene: &'d Scene,
    settings: FrameSettings,
    soup: DeviceSoup<'d>,
    builder: DeviceBuilder<'d>,
    tracer: PathTracer<'d>,
    denoiser: Option<Denoiser>,
    /// Motion blur on an animated scene: the soup at every motion step.
    motion: Option<MotionSoup<'d>>,
}

impl<'d> FrameRenderer<'d> {
    /// Sets up the stages on `device`: uploads the scene, compiles the
    /// tracer (and, when some frame can move, the motion-blur programs)
    /// and the tree builder.
    pub fn new(
        device: &'d Device,
        scene: &'d Scene,
        settings: FrameSettings,
        denoiser: Option<Denoiser>,
    ) -> anyhow::Result<FrameRenderer<'d>> {
        let soup = DeviceSoup::new(device, scene)?;
        let mut tracer = PathTracer::new(device, scene, &settings.render)?;
        // Blur's programs only when some frame can move: a shutter that
        // stays open on an animated scene.
        let motion =
            if settings.shutter.is_some_and(|s| s.frames > 0.0) && scene.active_clip().is_some() {
                tracer.prepare_motion()?;
                Some(MotionSoup::new(device, &soup)?)
            } else {
                None
            };
        let builder = DeviceBuilder::new(device, settings.build)?;
        Ok(FrameRenderer {
            device,
            scene,
            settings,
            soup,
            builder,
            tracer,
            denoiser,
            motion,
        })
    }

    pub fn settings(&self) -> &FrameSettings {
        &self.settings
    }

    pub fn denoiser(&self) -> Option<&Denoiser> {
        self.denoiser.as_ref()
    }

    /// One pass of `frame` through every stage, its results discarded
    /// (the trace at one sample per pixel): the first launch of every
    /// kernel happens here, where drivers that compile at first launch
    /// (PoCL) do so, and is counted as start-up rather than as the first
    /// frame's build and trace. Evaluation and build are deterministic, so
    /// the frame then renders exactly as it would have.
    pub fn warm_up(&mut self, frame: i64) -> anyhow::Result<()> {
        let ev = self.evaluate(self.scene.time_of_frame(frame))?;
        let (tree, _) = self.build(&ev)?;
        self.trace_warm_up(frame, &ev, &tree)
    }

    /// Fills each frame's image in the buffers of the images `spare` hands
    /// back once written (`film::SpareImages`).
    pub fn reuse_images(&mut self, spare: crate::film::SpareImages) {
        self.tracer.reuse_images(spare);
    }

    /// Runs evaluate → build → trace → film for `frame` and fills in its
    /// log. A stage's failure is a `FrameError`; an error from
    /// `progress.stage_done` is returned as it is.
    pub fn render(
        &mut self,
        frame: i64,
        progress: &dyn FrameProgress,
    ) -> anyhow::Result<RenderedFrame> {
        let fail = |stage: &'static str| {
            move |e: anyhow::Error| {
                anyhow::Error::new(FrameError {
                    frame,
                    stage,
                    message: format!("{e:#}"),
                })
            }
        };
        let time = self.scene.time_of_frame(frame);

        let t = Instant::now();
        let ev = self.evaluate(time).map_err(fail("evaluate"))?;
        let evaluate_ms = ms(t);
        progress.stage_done()?;

        let t = Instant::now();
        let (tree, build) = self.build(&ev).map_err(fail("build"))?;
        let build_ms = ms(t);
        progress.stage_done()?;

        let t = Instant::now();
        let traced = self
            .trace(frame, &ev, &tree, &mut |done| progress.samples(done))
            .map_err(fail("trace"))?;
        let trace_ms = ms(t);
        progress.stage_done()?;

        let mut image = traced.image;
        let mut denoise_log = None;
        let mut denoised = None;
        if let Some(denoiser) = &self.denoiser {
            let (d, time_ms) = denoise_beauty(denoiser, &image).map_err(fail("denoise"))?;
            denoised = Some(d);
            denoise_log = Some(denoiser.log(time_ms));
            progress.stage_done()?;
        }
        // AOVs the film kept only for the denoiser are not handed back.
        if !self.settings.output_aovs.normal {
            image.normal = None;
        }
        if !self.settings.output_aovs.albedo {
            image.albedo = None;
        }

        let mut log = self.frame_log(log::Frame {
            frame,
            time,
            ev: &ev,
            tree: &tree,
            build: &build,
            traced: (traced.rays, traced.trace_ms, &traced.noise),
        });
        log.timings_ms.evaluate = evaluate_ms;
        log.timings_ms.build = build_ms;
        log.timings_ms.trace = trace_ms;
        log.timings_ms.denoise = denoise_log.as_ref().map_or(0.0, |d| d.time_ms);
        log.denoise = denoise_log;
        // The scene's own warnings (values clamped, channels skipped...) in
        // every frame's log, so each log tells the whole story of its frame.
        log.warnings = self.scene.warnings().to_vec();
        log.warnings.extend(ev.info.warnings.iter().cloned());
        log.warnings.extend(traced.warnings.iter().cloned());
        let dark = image.darkness_warning();
        if let Some(dark) = &dark {
            log.warnings.push(dark.clone());
        }
        Ok(RenderedFrame {
            image,
            denoised,
            log,
            build,
            dark,
        })
    }
}

/// Sets the tracer's materials to the scene's at `time` when the scene
/// animates them (KHR_animation_pointer); else leaves them as they are.
pub fn set_frame_materials(
    tracer: &mut PathTracer,
    scene: &Scene,
    time: f64,
) -> anyhow::Result<()> {
    if let Some(materials) = scene.materials_at(time) {
        tracer.set_materials(materials)?;
    }
    Ok(())
}

/// Runs the denoiser on a resolved frame (which must carry albedo and
/// normal); pixels no sample hit keep their raw value
/// (`denoise::keep_uncovered`). Returns the denoised beauty and the
/// denoiser's time.
pub fn denoise_beauty(denoiser: &Denoiser, image: &Image) -> anyhow::Result<(Vec<[f32; 3]>, f64)> {
    let (Some(albedo), Some(normal)) = (&image.albedo, &image.normal) else {
        anyhow::bail!("the film kept no albedo and normal for the denoiser");
    };
    let color: Vec<[f32; 3]> = image.rgba.iter().map(|p| [p[0], p[1], p[2]]).collect();
    let (mut out, time_ms) = denoiser.denoise(image.width, image.height, &color, albedo, normal)?;
    crate::denoise::keep_uncovered(&mut out, &image.rgba);
    Ok((out, time_ms))
}

/// Puts a denoised beauty in place of the image's RGB (alpha stays).
pub fn replace_beauty(image: &mut Image, rgb: &[[f32; 3]]) {
    for (px, c) in image.rgba.iter_mut().zip(rgb) {
        px[..3].copy_from_slice(c);
    }
}

fn ms(t: Instant) -> f64 {
    t.elapsed().as_secs_f64() * 1e3
}
