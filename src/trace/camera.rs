//! The cameras rays start from. `DeviceCamera` (`PtCamera` in the
//! generated kernel header) is the glTF camera as the path tracer reads it,
//! made per frame by `device_camera`, with depth of field's thin lens added
//! by `with_lens`. `PinholeCamera` is a camera for primary rays that frames
//! a bounding box, for tests and benchmarks: an origin and, per pixel, the
//! direction `p00 + (x + 0.5) du + (y + 0.5) dv` (rows top to bottom), which
//! the `generate_primary` kernel computes with the same floats.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use crate::device_struct::device_struct;
use crate::scene::{FrameCamera, Projection};
use crate::trace::lens::Lens;

device_struct! {
/// The camera. For a perspective camera `right` and `up` are scaled by the
/// half extents of the image plane at distance 1; for an orthographic one by
/// xmag and ymag.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DeviceCamera as "PtCamera" {
    pub origin: [f32; 4],
    pub right: [f32; 4],
    pub up: [f32; 4],
    pub forward: [f32; 4],
    pub ortho: u32,
    pub znear: f32,
    /// Depth of field (`HAS_DOF` kernels only): the lens radius in scene
    /// units (0: a pinhole), the distance to the plane in focus along
    /// `forward`, and the aperture's corners (below 3: a disk) and the
    /// first corner's angle (src/trace/lens.rs).
    pub lens_radius: f32,
    pub focus_distance: f32,
    pub blades: u32,
    pub blade_rotation: f32,
    pub pad: [u32; 2],
}
}

/// The camera for a `width` x `height` image. The image's aspect ratio is
/// used (a file's `aspectRatio` would stretch the picture); an
/// orthographic camera keeps `ymag` and widens `xmag` to the image.
pub fn device_camera(cam: &FrameCamera, width: u32, height: u32) -> DeviceCamera {
    let m = cam.world_from_camera;
    let origin = m.w_axis.truncate();
    let right = m.x_axis.truncate().normalize_or(Vec3::X);
    let up = m.y_axis.truncate().normalize_or(Vec3::Y);
    let forward = (-m.z_axis.truncate()).normalize_or(Vec3::NEG_Z);
    let aspect = width as f32 / height as f32;
    let v4 = |v: Vec3| [v.x, v.y, v.z, 0.0];
    let (half_x, half_y, ortho, znear) = match cam.projection {
        Projection::Perspective { yfov, znear, .. } => {
            let t = (0.5 * yfov).tan();
            (t * aspect, t, 0, znear)
        }
        Projection::Orthographic { ymag, znear, .. } => (ymag * aspect, ymag, 1, znear),
    };
    DeviceCamera {
        origin: v4(origin),
        right: v4(right * half_x),
        up: v4(up * half_y),
        forward: v4(forward),
        ortho,
        znear: if znear.is_finite() {
            znear.max(0.0)
        } else {
            0.0
        },
        lens_radius: 0.0,
        focus_distance: 0.0,
        blades: 0,
        blade_rotation: 0.0,
        pad: [0; 2],
    }
}

/// `camera` with `lens` (a perspective camera only: an orthographic one
/// stays sharp everywhere).
pub fn with_lens(mut camera: DeviceCamera, lens: Option<&Lens>) -> DeviceCamera {
    if let Some(lens) = lens.filter(|_| camera.ortho == 0) {
        let half = |v: [f32; 4]| Vec3::new(v[0], v[1], v[2]).length();
        camera.lens_radius = lens.radius(half(camera.right), half(camera.up));
        camera.focus_distance = lens.focus_distance;
        camera.blades = lens.blades;
        camera.blade_rotation = lens.blade_rotation;
    }
    camera
}

use super::Ray;

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PinholeCamera {
    pub origin: [f32; 3],
    /// Direction to the top-left corner of the image plane (pixel (0, 0)'s
    /// corner, not its centre).
    pub p00: [f32; 3],
    /// One pixel to the right, one pixel down, on the image plane.
    pub du: [f32; 3],
    pub dv: [f32; 3],
    pub width: u32,
    pub height: u32,
}

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn cross(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

fn normalize(a: [f32; 3]) -> [f32; 3] {
    let l = (a[0] * a[0] + a[1] * a[1] + a[2] * a[2]).sqrt();
    [a[0] / l, a[1] / l, a[2] / l]
}

impl PinholeCamera {
    /// A camera at `origin` looking at `target`, `up` roughly up, with a
    /// vertical field of view of `fov_y_degrees`.
    pub fn look_at(
        origin: [f32; 3],
        target: [f32; 3],
        up: [f32; 3],
        fov_y_degrees: f32,
        width: u32,
        height: u32,
    ) -> PinholeCamera {
        let forward = normalize(sub(target, origin));
        let right = normalize(cross(forward, up));
        let true_up = cross(right, forward);
        let half_h = (fov_y_degrees.to_radians() * 0.5).tan();
        let half_w = half_h * width as f32 / height as f32;
        let du: [f32; 3] = std::array::from_fn(|a| right[a] * 2.0 * half_w / width as f32);
        let dv: [f32; 3] = std::array::from_fn(|a| -true_up[a] * 2.0 * half_h / height as f32);
        let p00 = std::array::from_fn(|a| forward[a] - right[a] * half_w + true_up[a] * half_h);
        PinholeCamera {
            origin,
            p00,
            du,
            dv,
            width,
            height,
        }
    }

    /// A camera framing the box `[lo, hi]` from the direction `view`
    /// (camera towards box), at a distance where the box's bounding sphere
    /// fills the vertical field of view, with +y up (+z if viewing along y).
    pub fn framing(
        lo: [f32; 3],
        hi: [f32; 3],
        view: [f32; 3],
        fov_y_degrees: f32,
        width: u32,
        height: u32,
    ) -> PinholeCamera {
        let center: [f32; 3] = std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
        let radius = 0.5
            * (0..3)
                .map(|a| (hi[a] - lo[a]) * (hi[a] - lo[a]))
                .sum::<f32>()
                .sqrt();
        let dir = normalize(view);
        let dist = radius / (fov_y_degrees.to_radians() * 0.5).sin();
        let origin = std::array::from_fn(|a| center[a] - dir[a] * dist);
        let up = if dir[0].abs() < 1e-3 && dir[2].abs() < 1e-3 {
            [0.0, 0.0, 1.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        PinholeCamera::look_at(origin, center, up, fov_y_degrees, width, height)
    }

    /// The ray through the centre of pixel `(x, y)`, as `generate_primary`
    /// computes it.
    pub fn ray(&self, x: u32, y: u32) -> Ray {
        let fx = x as f32 + 0.5;
        let fy = y as f32 + 0.5;
        Ray::new(
            self.origin,
            std::array::from_fn(|a| (self.p00[a] + fx * self.du[a]) + fy * self.dv[a]),
        )
    }

    /// Every pixel's ray, row by row.
    pub fn rays(&self) -> Vec<Ray> {
        (0..self.height)
            .flat_map(|y| (0..self.width).map(move |x| self.ray(x, y)))
            .collect()
    }
}
