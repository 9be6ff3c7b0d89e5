//! A frame's log (`output::FrameLog`) from what its stages did.

use super::stages::{Evaluated, ShutterPlan};
use super::FrameRenderer;
use crate::bvh::device_builder::BuildStats;
use crate::bvh::{self, Bvh};
use crate::film::NoiseStats;
use crate::output::{self, CameraLog, FrameLog};
use crate::scene::{FrameCamera, Projection};
use crate::trace::motion::ShutterPosition;

/// What the log is filled in from.
pub(super) struct Frame<'a> {
    pub frame: i64,
    pub time: f64,
    pub ev: &'a Evaluated,
    pub tree: &'a Bvh,
    pub build: &'a BuildStats,
    /// The trace's rays, its own time and noise statistics.
    pub traced: (u64, f64, &'a NoiseStats),
}

impl FrameRenderer<'_> {
    /// The frame's log, but for the timings of the stages, the denoiser,
    /// the warnings and the output.
    pub(super) fn frame_log(&self, f: Frame) -> FrameLog {
        let settings = &self.settings;
        let render = &settings.render;
        let (rays, trace_ms, noise) = f.traced;
        let shape = f.tree.shape();
        let mut log = FrameLog::new();
        log.frame = f.frame;
        log.time = f.time;
        log.scene = settings.scene_path.display().to_string();
        log.device = self.device.info.name.clone();
        log.triangles = self.soup.triangle_count() as u64;
        log.mesh_instances = self.scene.instances().len() as u64;
        log.gpu_instances = self.scene.gpu_instance_count() as u64;
        log.memory = output::MemoryLog {
            soup_bytes: self.soup.soup_bytes(),
            peak_resident_bytes: output::peak_resident_bytes(),
        };
        log.build = output::BuildLog {
            builder: "device".into(),
            bins: settings.build.bins,
            leaf_size: settings.build.leaf_size,
            nodes: shape.nodes as u64,
            leaves: shape.leaves as u64,
            max_depth: shape.max_depth,
            sah_cost: bvh::sah_cost(f.tree),
            stages_ms: f.build.stages_ms,
        };
        log.render = output::RenderLog {
            width: render.width,
            height: render.height,
            spp: render.spp,
            rays,
            mrays_per_s: rays as f64 / (trace_ms.max(1e-9) * 1e3),
            traversal: render.traversal.name().to_owned(),
            sampler: render.sampler.name().to_owned(),
            noise_pattern: render.noise_pattern.name().to_owned(),
            material_features: self
                .tracer
                .material_features()
                .iter()
                .map(|f| (*f).to_owned())
                .collect(),
            light_selection: self.tracer.light_selection().to_owned(),
            emitter_spread: self.tracer.emitter_spread().map(f64::from),
            light_tree_ms: self.tracer.light_tree_ms(),
        };
        log.camera = camera_log(&f.ev.info.camera);
        // The lens the frame was traced through (the focus moves with
        // --focus-on).
        if let Some(lens) = &self.tracer.settings().lens {
            log.camera.f_stop = Some(lens.f_stop as f64);
            log.camera.focus_distance = Some(lens.focus_distance as f64);
        }
        log.noise = noise.clone();
        log.motion =
            f.ev.shutter
                .map(|plan| self.motion_log(plan, f.ev.motion.as_ref()));
        log
    }

    fn motion_log(
        &self,
        plan: ShutterPlan,
        motion: Option<&super::stages::MotionState>,
    ) -> output::MotionLog {
        let (extra_evaluate_ms, extra_build_ms) =
            motion.map_or((0.0, 0.0), |m| (m.extra_evaluate_ms, m.extra_build_ms));
        output::MotionLog {
            shutter_frames: plan.shutter.frames,
            shutter_position: match plan.shutter.position {
                ShutterPosition::Center => "center",
                ShutterPosition::Start => "start",
                ShutterPosition::End => "end",
            }
            .to_owned(),
            open: plan.open,
            close: plan.close,
            steps: plan.steps,
            steps_from: if self.settings.motion_steps.is_some() && plan.steps > 1 {
                "--motion-steps"
            } else {
                "rule"
            }
            .to_owned(),
            turn_degrees: plan.turn_degrees,
            extra_evaluate_ms,
            extra_build_ms,
        }
    }
}

fn camera_log(camera: &FrameCamera) -> CameraLog {
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
