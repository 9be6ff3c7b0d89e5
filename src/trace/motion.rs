//! Motion blur's arithmetic, on the host: the shutter interval, where a
//! ray's time falls between the motion steps, the soup interpolated at that
//! time, and each triangle's bounds over all steps.
//!
//! Every function here is the twin of the one of the same name in
//! `kernels/trace/trace_common.h` (`motion_time`, `motion_triangle`) and
//! `kernels/trace/motion.cl` (`motion_bounds`) and `kernels/trace/motion.h`
//! (`motion_camera`, `motion_light`), the same float operations in the
//! same order, so the device agrees with them bit for bit; and
//! `trace_closest_motion` is the CPU reference of the device's traversal at
//! a ray's time. `tests/motion_blur.rs` holds the two together.
//!
//! Layout: the soup at each of `steps` motion steps, one soup after another
//! (step `s`, triangle `t`, corner `k` at `3 * (s * triangles + t) + k`).
//! Step `s` is at shutter time `s / (steps - 1)`, 0 at the opening and 1 at
//! the closing; a ray's time is a uniform sample in [0, 1).

use super::{trace_closest, Hit, Ray};
use crate::bvh::Bvh;
use crate::trace::camera::DeviceCamera;

/// Where the shutter is open relative to the frame's instant (Blender's
/// "Position" of the motion blur shutter).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "lowercase")]
pub enum ShutterPosition {
    /// Open from half the shutter before the frame to half after.
    Center,
    /// Opens at the frame.
    Start,
    /// Closes at the frame.
    End,
}

impl std::str::FromStr for ShutterPosition {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "center" => Ok(ShutterPosition::Center),
            "start" => Ok(ShutterPosition::Start),
            "end" => Ok(ShutterPosition::End),
            _ => Err(format!(
                "--shutter-position {s:?}: use `center` (the default), `start` or `end`"
            )),
        }
    }
}

/// The shutter: how long it is open, in frames, and where.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Shutter {
    pub frames: f64,
    pub position: ShutterPosition,
}

impl Shutter {
    /// The opening and closing times in seconds of the frame at `time`.
    pub fn interval(&self, time: f64, fps: f64) -> (f64, f64) {
        let open = self.frames / fps;
        match self.position {
            ShutterPosition::Center => (time - 0.5 * open, time + 0.5 * open),
            ShutterPosition::Start => (time, time + open),
            ShutterPosition::End => (time - open, time),
        }
    }
}

/// The times in seconds of `steps` evenly spaced motion steps from `open` to
/// `close` (both included; one step: the opening).
pub fn step_times(open: f64, close: f64, steps: u32) -> Vec<f64> {
    if steps <= 1 {
        return vec![open];
    }
    (0..steps)
        .map(|s| open + (close - open) * s as f64 / (steps - 1) as f64)
        .collect()
}

/// `motion_time` of the kernel: the step at or before shutter time `time`
/// in [0, 1) of `steps` >= 2 steps, and the fraction from it to the next.
pub fn motion_time(time: f32, steps: u32) -> (u32, f32) {
    let x = time * (steps - 1) as f32;
    // The kernel's (uint) conversion truncates toward zero, like `as`.
    let k = (x as u32).min(steps - 2);
    (k, x - k as f32)
}

/// `motion_triangle` of the kernel: triangle `prim`'s three corners at
/// `(step, frac)`, from the per-step data (positions or normals).
pub fn motion_triangle(
    data: &[[f32; 4]],
    triangles: usize,
    (step, frac): (u32, f32),
    prim: u32,
) -> [[f32; 4]; 3] {
    let a = 3 * (step as usize * triangles + prim as usize);
    let b = a + 3 * triangles;
    let mut out = [[0.0; 4]; 3];
    for k in 0..3 {
        for i in 0..4 {
            let (x, y) = (data[a + k][i], data[b + k][i]);
            out[k][i] = x + frac * (y - x);
        }
    }
    out
}

/// The whole soup at shutter time `time` (the reference's input).
pub fn positions_at(data: &[[f32; 4]], triangles: usize, steps: u32, time: f32) -> Vec<[f32; 4]> {
    let at = motion_time(time, steps);
    (0..triangles as u32)
        .flat_map(|t| motion_triangle(data, triangles, at, t))
        .collect()
}

/// `motion_bounds` of `kernels/trace/motion.cl`: per triangle the box of its
/// corners at every step, as the "bounds triangle" (lo, hi, lo) whose own
/// bounds the BVH builder computes to exactly that box.
pub fn motion_bounds(data: &[[f32; 4]], triangles: usize, steps: u32) -> Vec<[f32; 4]> {
    let mut out = Vec::with_capacity(3 * triangles);
    for i in 0..triangles {
        let mut lo = data[3 * i];
        let mut hi = lo;
        for s in 0..steps as usize {
            let at = 3 * (s * triangles + i);
            for v in &data[at..at + 3] {
                for a in 0..4 {
                    lo[a] = lo[a].min(v[a]);
                    hi[a] = hi[a].max(v[a]);
                }
            }
        }
        lo[3] = 0.0;
        hi[3] = 0.0;
        out.extend([lo, hi, lo]);
    }
    out
}

/// The closest hit of `ray` at shutter time `time` through `bvh` (built
/// over `motion_bounds`): the kernel's `motion_trace_closest`.
pub fn trace_closest_motion(
    bvh: &Bvh,
    data: &[[f32; 4]],
    triangles: usize,
    steps: u32,
    ray: &Ray,
    time: f32,
) -> Hit {
    trace_closest(bvh, &positions_at(data, triangles, steps, time), ray)
}

/// `motion_camera` of `kernels/trace/motion.h`: the camera's vectors
/// interpolated between the steps around the time.
pub fn camera_at(cameras: &[DeviceCamera], (step, frac): (u32, f32)) -> DeviceCamera {
    let a = cameras[step as usize];
    let b = cameras[step as usize + 1];
    let lerp = |x: [f32; 4], y: [f32; 4]| -> [f32; 4] {
        let mut o = [0.0; 4];
        for i in 0..4 {
            o[i] = x[i] + frac * (y[i] - x[i]);
        }
        o
    };
    DeviceCamera {
        origin: lerp(a.origin, b.origin),
        right: lerp(a.right, b.right),
        up: lerp(a.up, b.up),
        forward: lerp(a.forward, b.forward),
        ..a
    }
}

/// `motion_light` of `kernels/trace/motion.h`: a light's position and direction
/// interpolated between two steps at fraction `frac`, the direction
/// renormalised.
pub fn light_at(
    a: &crate::trace::lights::DeviceLight,
    b: &crate::trace::lights::DeviceLight,
    frac: f32,
) -> crate::trace::lights::DeviceLight {
    let mut l = *a;
    for k in 0..3 {
        l.position[k] = a.position[k] + frac * (b.position[k] - a.position[k]);
    }
    let d: [f32; 3] =
        std::array::from_fn(|k| a.direction[k] + frac * (b.direction[k] - a.direction[k]));
    let len = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
    l.direction = if len > 0.0 { d.map(|x| x / len) } else { d };
    l
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn motion_time_covers_the_shutter() {
        assert_eq!(motion_time(0.0, 2), (0, 0.0));
        assert_eq!(motion_time(0.5, 3), (1, 0.0));
        let (k, f) = motion_time(0.999_999_9, 3);
        assert_eq!(k, 1);
        assert!(f > 0.99 && f < 1.0);
        assert_eq!(motion_time(0.25, 5), (1, 0.0));
    }

    #[test]
    fn shutter_intervals() {
        let s = |position| Shutter {
            frames: 0.5,
            position,
        };
        assert_eq!(
            s(ShutterPosition::Center).interval(1.0, 10.0),
            (0.975, 1.025)
        );
        assert_eq!(s(ShutterPosition::Start).interval(1.0, 10.0), (1.0, 1.05));
        assert_eq!(s(ShutterPosition::End).interval(1.0, 10.0), (0.95, 1.0));
        assert_eq!(step_times(0.0, 1.0, 3), vec![0.0, 0.5, 1.0]);
    }

    #[test]
    fn bounds_enclose_every_step() {
        // One triangle moving along x over three steps.
        let mut data = Vec::new();
        for s in 0..3 {
            let x = s as f32;
            data.extend([
                [x, 0.0, 0.0, 0.0],
                [x + 1.0, 0.0, 0.0, 0.0],
                [x, 1.0, 0.0, 0.0],
            ]);
        }
        let b = motion_bounds(&data, 1, 3);
        assert_eq!(b[0], [0.0, 0.0, 0.0, 0.0]);
        assert_eq!(b[1], [3.0, 1.0, 0.0, 0.0]);
        let mid = positions_at(&data, 1, 3, 0.75);
        assert_eq!(mid[0], [1.5, 0.0, 0.0, 0.0]);
    }
}
