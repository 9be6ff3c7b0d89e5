//! The soup of a frame that moves within the shutter: the device soup
//! evaluated at each motion step and kept side by side, and each triangle's
//! bounds over all steps for the BVH builder (`kernels/trace/motion.cl`).
//!
//! Made only when `--motion-blur` is on, and used only for frames where
//! something moves within the shutter (`motion_steps` returns 1 for the
//! others, which render exactly as without blur).
//!
//! How many steps (`motion_steps`): the pose is probed at 9 evenly spaced
//! times over the shutter. If no node transform, joint matrix or morph
//! weight changes, nothing moves: 1 step (no motion work). Otherwise the
//! rotation each node and joint turns through over the shutter is summed
//! probe to probe (so a turn that comes back still counts), and the frame
//! gets one step per `STEP_DEGREES` of the largest, plus one, and at least
//! 2 (open and close). Linear interpolation between steps `θ` apart
//! follows an arc of radius `r` within `r (1 - cos(θ/2))`: 0.9% of the
//! radius at 15°. `--motion-steps N` replaces the count for moving frames.

use opencl3::kernel::Kernel;
use opencl3::memory::Buffer;

use super::device::{DeviceSoup, FrameInfo, SoupError};
use crate::device::{Arg, Device, DeviceError, GrowBuffer};
use crate::scene::{Pose, Scene};

/// The most motion steps a frame gets from the rule.
pub const MAX_MOTION_STEPS: u32 = 16;
/// The rotation per step the rule allows, in degrees.
pub const STEP_DEGREES: f64 = 15.0;
/// Poses probed over the shutter by the rule.
const PROBES: usize = 8;

/// The rotation (radians) between two transforms, 0 when either has no
/// usable rotation (zero scale, non-finite).
fn rotation_between(a: &glam::Mat4, b: &glam::Mat4) -> f64 {
    let (_, qa, _) = a.to_scale_rotation_translation();
    let (_, qb, _) = b.to_scale_rotation_translation();
    let angle = qa.normalize().angle_between(qb.normalize()) as f64;
    if angle.is_finite() {
        angle
    } else {
        0.0
    }
}

fn same_pose(a: &Pose, b: &Pose) -> bool {
    a.world_from_node == b.world_from_node
        && a.joint_matrices == b.joint_matrices
        && a.morph_weights == b.morph_weights
}

/// Whether KHR_animation_pointer channels change a light or the camera's
/// projection between the probes (the camera then blurs its zoom, and each
/// step's lights take their values at the step).
fn pointer_values_change(scene: &Scene, poses: &[Pose]) -> bool {
    if !scene.has_light_or_camera_animation() {
        return false;
    }
    let first = &poses[0];
    let lights = scene.frame_lights(first);
    let camera = scene
        .camera_instance()
        .map(|(_, c)| scene.projection_at(c, first.time));
    poses[1..].iter().any(|p| {
        scene.frame_lights(p) != lights
            || scene
                .camera_instance()
                .map(|(_, c)| scene.projection_at(c, p.time))
                != camera
    })
}

/// The largest rotation any node or joint turns through over `poses`, in
/// degrees (summed pose to pose).
fn largest_turn(poses: &[Pose]) -> f64 {
    let mut largest = 0.0f64;
    let Some(first) = poses.first() else {
        return 0.0;
    };
    for n in 0..first.world_from_node.len() {
        let turn: f64 = poses
            .windows(2)
            .map(|w| rotation_between(&w[0].world_from_node[n], &w[1].world_from_node[n]))
            .sum();
        largest = largest.max(turn);
    }
    for (s, joints) in first.joint_matrices.iter().enumerate() {
        for j in 0..joints.len() {
            let turn: f64 = poses
                .windows(2)
                .map(|w| rotation_between(&w[0].joint_matrices[s][j], &w[1].joint_matrices[s][j]))
                .sum();
            largest = largest.max(turn);
        }
    }
    largest.to_degrees()
}

/// What the rule found for one frame's shutter.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MotionPlan {
    /// Motion steps: 1 when nothing moves within the shutter.
    pub steps: u32,
    /// The largest rotation of a node or joint over the shutter, degrees.
    pub turn_degrees: f64,
}

/// The motion steps of the shutter `[open, close]` (seconds): the rule of
/// the module's documentation, or `requested` steps when something moves.
pub fn motion_steps(scene: &Scene, open: f64, close: f64, requested: Option<u32>) -> MotionPlan {
    let still = MotionPlan {
        steps: 1,
        turn_degrees: 0.0,
    };
    // A closed shutter (or a NaN time) sees one instant.
    if close.partial_cmp(&open) != Some(std::cmp::Ordering::Greater) {
        return still;
    }
    let poses: Vec<Pose> = (0..=PROBES)
        .map(|i| scene.pose(open + (close - open) * i as f64 / PROBES as f64))
        .collect();
    if poses[1..].iter().all(|p| same_pose(&poses[0], p)) && !pointer_values_change(scene, &poses) {
        return still;
    }
    let turn = largest_turn(&poses);
    let by_rule = ((turn / STEP_DEGREES).ceil() as u32)
        .saturating_add(1)
        .clamp(2, MAX_MOTION_STEPS);
    MotionPlan {
        steps: requested.map_or(by_rule, |n| n.max(2)),
        turn_degrees: turn,
    }
}

/// The step positions and the bounds triangles, read back.
pub type StepsAndBounds = (Vec<[f32; 4]>, Vec<[f32; 4]>);

/// A scene's soup at every motion step of a frame, on the device.
pub struct MotionSoup<'d> {
    device: &'d Device,
    bounds_kernel: Kernel,
    _program: opencl3::program::Program,
    triangles: usize,
    positions: GrowBuffer<[f32; 4]>,
    normals: GrowBuffer<[f32; 4]>,
    has_normals: bool,
    bounds: Buffer<[f32; 4]>,
    steps: u32,
    bounds_ms: f64,
}

/// The defines `kernels/trace/motion.cl` is compiled with.
pub fn motion_program_defines() -> Vec<(&'static str, String)> {
    vec![
        ("MOTION_BLUR", "1".to_owned()),
        ("STACK_SIZE", (crate::bvh::MAX_DEPTH + 1).to_string()),
    ]
}

impl<'d> MotionSoup<'d> {
    /// Compiles `kernels/trace/motion.cl` and allocates the bounds buffer for
    /// `soup`'s triangles; the step buffers grow with the steps a frame uses.
    pub fn new(device: &'d Device, soup: &DeviceSoup) -> Result<MotionSoup<'d>, DeviceError> {
        let program = device.build_program("motion.cl", &motion_program_defines())?;
        let bounds_kernel = device.kernel(&program, "motion_bounds")?;
        let triangles = soup.triangle_count();
        Ok(MotionSoup {
            device,
            bounds_kernel,
            _program: program,
            triangles,
            positions: GrowBuffer::new(),
            normals: GrowBuffer::new(),
            has_normals: soup.normals().is_some(),
            bounds: device.buffer(3 * triangles.max(1))?,
            steps: 0,
            bounds_ms: 0.0,
        })
    }

    /// Evaluates `soup` at each of `times` (the steps, in order), keeps each
    /// step's positions and normals, and computes the triangles' bounds over
    /// all steps. Returns each step's frame information (camera, lights).
    /// The soup's own buffers are left holding the last step.
    pub fn evaluate(
        &mut self,
        soup: &mut DeviceSoup,
        scene: &Scene,
        times: &[f64],
    ) -> Result<Vec<FrameInfo>, SoupError> {
        let d = self.device;
        let n3 = 3 * self.triangles;
        let steps = times.len();
        self.steps = 0;
        let positions = self.positions.ensure(d, (n3 * steps).max(1))?;
        let mut normals = if self.has_normals {
            Some(self.normals.ensure(d, (n3 * steps).max(1))?)
        } else {
            None
        };
        let mut infos = Vec::with_capacity(steps);
        for (s, &t) in times.iter().enumerate() {
            infos.push(soup.evaluate(scene, t)?);
            d.copy(soup.positions(), positions, s * n3, n3)?;
            if let (Some(dst), Some(src)) = (normals.as_deref_mut(), soup.normals()) {
                d.copy(src, dst, s * n3, n3)?;
            }
        }
        d.finish()?;
        let t = std::time::Instant::now();
        let positions = self.positions.get();
        d.launch(
            "motion/bounds",
            &self.bounds_kernel,
            self.triangles.div_ceil(64),
            64,
            &[
                Arg::Buf(positions),
                Arg::U32(self.triangles as u32),
                Arg::U32(steps as u32),
                Arg::Buf(&self.bounds),
            ],
        )?;
        d.finish()?;
        self.bounds_ms = t.elapsed().as_secs_f64() * 1e3;
        self.steps = steps as u32;
        Ok(infos)
    }

    /// Wall time of the last `evaluate`'s bounds pass, ms.
    pub fn bounds_ms(&self) -> f64 {
        self.bounds_ms
    }

    /// The steps of the last `evaluate`.
    pub fn steps(&self) -> u32 {
        self.steps
    }

    /// Positions at every step (`trace::motion` documents the layout).
    pub fn positions(&self) -> &Buffer<[f32; 4]> {
        self.positions.get()
    }

    /// Shading normals at every step, when the soup has normals.
    pub fn normals(&self) -> Option<&Buffer<[f32; 4]>> {
        self.has_normals.then(|| self.normals.get())
    }

    /// The "bounds triangles" (lo, hi, lo) of every triangle over all
    /// steps: build the frame's tree from these.
    pub fn bounds(&self) -> &Buffer<[f32; 4]> {
        &self.bounds
    }

    pub fn triangle_count(&self) -> usize {
        self.triangles
    }

    /// Reads the step positions and the bounds back (tests).
    pub fn read_back(&self) -> Result<StepsAndBounds, DeviceError> {
        let n3 = 3 * self.triangles;
        let mut positions = vec![[0.0f32; 4]; n3 * self.steps as usize];
        let mut bounds = vec![[0.0f32; 4]; n3];
        self.device.read(self.positions.get(), &mut positions)?;
        self.device.read(&self.bounds, &mut bounds)?;
        Ok((positions, bounds))
    }
}
