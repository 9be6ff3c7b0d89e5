//! The stages of one frame on the device: evaluate (once at the frame's
//! instant, or at every motion step when it moves within the shutter),
//! build and trace.

use super::{ms, set_frame_materials, FrameRenderer};
use crate::bvh::device_builder::BuildStats;
use crate::bvh::Bvh;
use crate::scene::{FrameCamera, FrameLight};
use crate::soup::device::FrameInfo;
use crate::soup::motion::motion_steps;
use crate::trace::motion::{step_times, Shutter};
use crate::trace::render::{FrameInput, MotionFrame, RenderOutput};
use crate::trace::vectors::vector_times;
use anyhow::Context as _;
use std::time::Instant;

/// Where the shutter of a frame is open, and how many motion steps cover it.
#[derive(Clone, Copy, Debug)]
pub(super) struct ShutterPlan {
    pub shutter: Shutter,
    pub open: f64,
    pub close: f64,
    pub steps: u32,
    /// The largest rotation of any node or joint over the shutter.
    pub turn_degrees: f64,
}

/// A frame that moves within its shutter, as evaluated.
pub(super) struct MotionState {
    pub steps: u32,
    /// The camera and the punctual lights at each step.
    pub cameras: Vec<FrameCamera>,
    pub lights: Vec<Vec<FrameLight>>,
    pub extra_evaluate_ms: f64,
    pub extra_build_ms: f64,
}

/// A frame's evaluation: camera and lights at the frame's instant, and its
/// motion when it moves within the shutter.
pub(super) struct Evaluated {
    pub info: FrameInfo,
    pub motion: Option<MotionState>,
    /// Motion blur: the shutter, also for frames that do not move.
    pub shutter: Option<ShutterPlan>,
}

impl FrameRenderer<'_> {
    /// Evaluates the frame at `time`: once at that instant, or, with motion
    /// blur and something moving within the shutter, at every motion step.
    pub(super) fn evaluate(&mut self, time: f64) -> anyhow::Result<Evaluated> {
        let fps = self.scene.options().fps;
        if self.settings.render.aovs.motion {
            self.evaluate_vector_steps(time, fps)?;
        }
        let planned = match (self.settings.shutter, &self.motion) {
            (Some(shutter), Some(_)) => {
                let (open, close) = shutter.interval(time, fps);
                let plan = motion_steps(self.scene, open, close, self.settings.motion_steps);
                Some(ShutterPlan {
                    shutter,
                    open,
                    close,
                    steps: plan.steps,
                    turn_degrees: plan.turn_degrees,
                })
            }
            _ => None,
        };
        let (Some(plan), Some(motion)) = (planned, &mut self.motion) else {
            return Ok(Evaluated {
                info: self.soup.evaluate(self.scene, time)?,
                motion: None,
                // Nothing can move (no clip, or the shutter is closed).
                shutter: self.settings.shutter.map(|shutter| {
                    let (open, close) = shutter.interval(time, fps);
                    ShutterPlan {
                        shutter,
                        open,
                        close,
                        steps: 1,
                        turn_degrees: 0.0,
                    }
                }),
            });
        };
        let steps = plan.steps;
        if steps < 2 {
            return Ok(Evaluated {
                info: self.soup.evaluate(self.scene, time)?,
                motion: None,
                shutter: planned,
            });
        }
        let times = step_times(plan.open, plan.close, steps);
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
        let info = FrameInfo {
            time,
            camera: self.scene.frame_camera(&pose)?,
            lights: self.scene.frame_lights(&pose),
            warnings,
            reused: false,
            pose,
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

    /// Motion vectors' steps (`trace::vectors`): the soup and the camera a
    /// frame before the frame's centre (its instant, or the middle of its
    /// shutter), at it and a frame after, handed to the tracer. Evaluated
    /// before the frame itself, which leaves the soup's buffers holding it
    /// (and, at the centre, reuses the last step's).
    fn evaluate_vector_steps(&mut self, time: f64, fps: f64) -> anyhow::Result<()> {
        let centre = self.settings.shutter.map_or(time, |shutter| {
            let (open, close) = shutter.interval(time, fps);
            0.5 * (open + close)
        });
        let times = vector_times(centre, fps);
        // The centre last: where it is the frame's own instant (no motion
        // blur, or a centred shutter) the frame's evaluation that follows
        // finds the same pose on the device and runs no kernel.
        for step in [0, 2, 1] {
            let info = self.soup.evaluate(self.scene, times[step])?;
            self.tracer
                .set_vector_step(step, &self.soup, &info.camera)?;
        }
        Ok(())
    }

    /// Builds the frame's tree: over the soup, or over every triangle's
    /// bounds across the motion steps.
    pub(super) fn build(&mut self, ev: &Evaluated) -> anyhow::Result<(Bvh, BuildStats)> {
        let positions = match (&ev.motion, &self.motion) {
            (Some(_), Some(m)) => m.bounds(),
            _ => self.soup.positions(),
        };
        Ok(self
            .builder
            .build_from_device(positions, self.soup.triangle_count())?)
    }

    /// Traces the frame, reporting the samples per pixel done.
    pub(super) fn trace(
        &mut self,
        frame: i64,
        ev: &Evaluated,
        tree: &Bvh,
        report: &mut dyn FnMut(u32),
    ) -> anyhow::Result<RenderOutput> {
        self.trace_with(frame, ev, tree, Some(report))
            .map(|out| out.expect("a traced frame"))
    }

    /// The warm-up pass of the trace: one sample per pixel, discarded.
    pub(super) fn trace_warm_up(
        &mut self,
        frame: i64,
        ev: &Evaluated,
        tree: &Bvh,
    ) -> anyhow::Result<()> {
        self.trace_with(frame, ev, tree, None).map(|_| ())
    }

    /// The trace (`report: Some`) or its warm-up (`None`, nothing returned).
    fn trace_with(
        &mut self,
        frame: i64,
        ev: &Evaluated,
        tree: &Bvh,
        report: Option<&mut dyn FnMut(u32)>,
    ) -> anyhow::Result<Option<RenderOutput>> {
        // KHR_animation_pointer material channels: the frame's materials.
        set_frame_materials(&mut self.tracer, self.scene, ev.info.time)?;
        if let Some(node) = self.settings.focus_node {
            let distance = focus_distance(&ev.info.pose, node, &ev.info.camera);
            self.tracer.set_focus_distance(distance);
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
        match (&ev.motion, &self.motion) {
            (Some(state), Some(m)) => {
                let motion = MotionFrame {
                    positions: m.positions(),
                    normals: m.normals(),
                    steps: state.steps,
                    cameras: &state.cameras,
                    lights: &state.lights,
                };
                match report {
                    None => self.tracer.warm_up_motion(&input, &motion).map(|()| None),
                    Some(r) => self.tracer.render_motion(&input, &motion, r).map(Some),
                }
            }
            _ => match report {
                None => self.tracer.warm_up(&input).map(|()| None),
                Some(r) => self.tracer.render(&input, r).map(Some),
            },
        }
        .map_err(Into::into)
    }
}

/// The distance along `camera`'s view direction to `node`'s origin in
/// `pose` (`--focus-on`); a node beside or behind the camera gives the
/// near plane's distance, the closest focus there is.
fn focus_distance(
    pose: &crate::scene::Pose,
    node: usize,
    camera: &crate::scene::FrameCamera,
) -> f32 {
    let target = pose.world_from_node[node].w_axis.truncate();
    let m = camera.world_from_camera;
    let forward = (-m.z_axis.truncate()).normalize_or(glam::Vec3::NEG_Z);
    let along = (target - m.w_axis.truncate()).dot(forward);
    let near = match camera.projection {
        crate::scene::Projection::Perspective { znear, .. }
        | crate::scene::Projection::Orthographic { znear, .. } => znear,
    };
    along.max(near.max(1.0e-3))
}
