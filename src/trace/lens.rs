//! Depth of field: a thin lens in front of the glTF camera, which glTF
//! itself does not describe (its cameras are pinholes). `--aperture F_STOP`
//! opens the lens and `--focus-distance M` sets the plane in focus; the
//! aperture is a disk, or a regular polygon with `--blades N` corners.
//!
//! The focal length is the file's where it gives one (the draft
//! `EXT_camera_physical` extension's `focalLength`); otherwise it follows
//! Blender's convention, so a scene exported from Blender renders with the
//! same blur at the same f-stop: a 36 mm sensor across the image's wider
//! side, hence f = 18 mm / tan(half the wider field of view). The lens
//! radius is f / (2 N) in scene units (metres, as glTF's are).
//!
//! A camera sample's ray leaves from a point on the lens and passes through
//! the point the pinhole ray reaches on the focus plane: points on that
//! plane stay sharp, and a point at depth z spreads over a disk of radius
//! R |1/F - 1/z| on the image plane at distance 1. The lens point comes
//! from a sampler set of its own (`SET_LENS`), so its two dimensions are as
//! well stratified as the pixel filter's. `camera_aperture_point` and
//! `camera_lens_ray` mirror `kernels/trace/lens.h` operation for operation.

use glam::Vec3;

use super::sampling::PI;

/// A thin lens: what `--aperture`, `--focus-distance`, `--blades` and
/// `--blade-rotation` ask for.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lens {
    /// The f-number N (focal length over aperture diameter).
    pub f_stop: f32,
    /// Distance from the camera to the plane in focus, along its view
    /// direction, in scene units.
    pub focus_distance: f32,
    /// Corners of a polygonal aperture; below 3, a disk.
    pub blades: u32,
    /// The first corner's angle from the image's right, in radians.
    pub blade_rotation: f32,
    /// The camera's physical focal length in millimetres, where the file
    /// gives one (`EXT_camera_physical`); else Blender's convention.
    pub focal_mm: Option<f32>,
}

/// Blender's default sensor width, in millimetres, across the wider side of
/// the image.
pub const SENSOR_MM: f32 = 36.0;

impl Lens {
    /// The lens radius in scene units for a perspective camera whose image
    /// plane at distance 1 has half extents `half_x`, `half_y`.
    /// The file's physical focal length, where it has one, replaces
    /// Blender's.
    pub fn radius(&self, half_x: f32, half_y: f32) -> f32 {
        let focal_mm = self
            .focal_mm
            .unwrap_or_else(|| 0.5 * SENSOR_MM / half_x.max(half_y));
        focal_mm * 1.0e-3 / (2.0 * self.f_stop)
    }

    /// The settings' problems, for a usage error.
    pub fn check(&self) -> Result<(), String> {
        if !(self.f_stop.is_finite() && self.f_stop > 0.0) {
            return Err(format!(
                "--aperture {}: the f-stop must be a positive number (e.g. 2.8)",
                self.f_stop
            ));
        }
        if !(self.focus_distance.is_finite() && self.focus_distance > 0.0) {
            return Err(format!(
                "--focus-distance {}: the distance to the plane in focus must be positive, in \
                 scene units (metres for glTF)",
                self.focus_distance
            ));
        }
        if self.blades > 64 {
            return Err(format!(
                "--blades {}: at most 64 (0 for a round aperture)",
                self.blades
            ));
        }
        Ok(())
    }
}

/// A point on the unit aperture from two uniforms, uniform in area: the
/// concentric map of the square onto the disk (Shirley and Chiu 1997) for
/// `blades` below 3, else a point of the regular polygon inscribed in the
/// unit circle with `blades` corners, the first at angle `rotation` (one
/// triangle of the fan chosen by `u`, its remainder reused).
pub fn camera_aperture_point(u: f32, v: f32, blades: u32, rotation: f32) -> [f32; 2] {
    if blades < 3 {
        let a = 2.0 * u - 1.0;
        let b = 2.0 * v - 1.0;
        if a == 0.0 && b == 0.0 {
            return [0.0, 0.0];
        }
        let (r, phi) = if a.abs() > b.abs() {
            (a, (0.25 * PI) * (b / a))
        } else {
            (b, 0.5 * PI - (0.25 * PI) * (a / b))
        };
        return [r * phi.cos(), r * phi.sin()];
    }
    let n = blades as f32;
    let fu = u * n;
    let k = (fu as u32).min(blades - 1);
    let w = fu - k as f32;
    let step = (2.0 * PI) / n;
    let a0 = rotation + step * k as f32;
    let a1 = a0 + step;
    let s = w.sqrt();
    let (p, q) = (s * (1.0 - v), s * v);
    [p * a0.cos() + q * a1.cos(), p * a0.sin() + q * a1.sin()]
}

/// `|v|` as the kernel computes it.
fn length(v: Vec3) -> f32 {
    ((v.x * v.x + v.y * v.y) + v.z * v.z).sqrt()
}

/// The ray of a camera sample through the lens: from `origin` (the camera)
/// offset on the lens by `radius` times the aperture point along the unit
/// `right` and `up`, towards `origin + d * focus` (the pinhole direction
/// `d`, whose component along the unit `forward` is 1, meets the focus
/// plane there). Returns the ray's origin, unit direction and the distance
/// along it to the near plane `znear`.
#[allow(clippy::too_many_arguments)]
pub fn camera_lens_ray(
    origin: Vec3,
    right: Vec3,
    up: Vec3,
    forward: Vec3,
    d: Vec3,
    znear: f32,
    radius: f32,
    focus: f32,
    aperture: [f32; 2],
) -> (Vec3, Vec3, f32) {
    let r = right / length(right);
    let u = up / length(up);
    let org = origin + (r * (radius * aperture[0]) + u * (radius * aperture[1]));
    let target = origin + d * focus;
    let to = target - org;
    let dir = to / length(to);
    let cos = (dir.x * forward.x + dir.y * forward.y) + dir.z * forward.z;
    let tmin = if cos > 0.0 { znear / cos } else { 0.0 };
    (org, dir, tmin)
}
