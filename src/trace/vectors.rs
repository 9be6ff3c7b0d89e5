//! Motion vectors (`--aov motion`): where the surface seen in a pixel was a
//! frame before and will be a frame after, in pixels, as Cycles' Vector
//! pass has them. They come from the animation itself: the soup and the
//! camera are evaluated a frame before the frame's centre, at it and a
//! frame after (`vector_times`; skinning, morphs, node and camera
//! animation all count), and the path tracer follows the first hit's point
//! of its triangle (same barycentrics) through the three steps, projecting
//! each with that step's camera (`project`, the twin of `pt_project` in
//! kernels/trace/scene_view.h).
//!
//! The frame's centre is its instant, or with `--motion-blur` the middle of
//! its shutter: the vectors describe the surface at the shutter's centre,
//! whichever time in the shutter a sample saw it at.

use bytemuck::{Pod, Zeroable};
use glam::{Vec2, Vec3};

use super::camera::DeviceCamera;
use crate::device_struct::device_struct;

/// The soup's steps for motion vectors: before, at and after the centre.
pub const VECTOR_STEPS: usize = 3;

/// The times of the vector steps around `centre`, one frame (`1 / fps`
/// seconds) apart.
pub fn vector_times(centre: f64, fps: f64) -> [f64; VECTOR_STEPS] {
    let frame = 1.0 / fps;
    [centre - frame, centre, centre + frame]
}

device_struct! {
/// A vector step's camera as the motion vectors project with it
/// (`vector_camera`): a world point `p` lands at pixel
/// `(dot(p - origin, to_x), dot(p - origin, to_y)) / w + centre`, with
/// `w = dot(p - origin, to_z)` for a perspective camera and 1 for an
/// orthographic one. The camera's axes come scaled by their squared lengths
/// and the image's half size, so that a projection takes one division
/// (three a sample for the three steps), not one per axis and the depth.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct VectorCamera as "PtVectorCamera" {
    pub origin: [f32; 4],
    pub to_x: [f32; 4],
    pub to_y: [f32; 4],
    pub to_z: [f32; 4],
    /// The image's centre in pixels.
    pub centre: [f32; 2],
    pub ortho: u32,
    pub pad: u32,
}
}

/// `c`, a camera for a `width` x `height` image, as the motion vectors
/// project with it. The inverse of the camera ray: a perspective ray runs
/// along forward + right sx + up sy, an orthographic one starts at
/// origin + right sx + up sy, the image spanning sx, sy in [-1, 1].
pub fn vector_camera(c: &DeviceCamera, width: u32, height: u32) -> VectorCamera {
    let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    let (r, u, f) = (v(c.right), v(c.up), v(c.forward));
    let (half_w, half_h) = (0.5 * width as f32, 0.5 * height as f32);
    // A degenerate axis projects everything to the centre rather than to NaN.
    let scaled = |a: Vec3, half: f32| {
        let s = half / a.dot(a);
        if s.is_finite() {
            a * s
        } else {
            Vec3::ZERO
        }
    };
    let v4 = |a: Vec3| [a.x, a.y, a.z, 0.0];
    VectorCamera {
        origin: c.origin,
        to_x: v4(scaled(r, half_w)),
        to_y: v4(scaled(u, half_h)),
        to_z: v4(scaled(f, 1.0)),
        centre: [half_w, half_h],
        ortho: c.ortho,
        pad: 0,
    }
}

/// Where world point `p` lands on camera `c`'s image, in pixels from the
/// bottom-left corner (x right, y up, as Blender's and Nuke's vectors
/// count); `None` behind a perspective camera. The twin of `pt_project`.
pub fn project(c: &VectorCamera, p: Vec3) -> Option<Vec2> {
    let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    let d = p - v(c.origin);
    let (x, y) = (d.dot(v(c.to_x)), d.dot(v(c.to_y)));
    let centre = Vec2::new(c.centre[0], c.centre[1]);
    if c.ortho != 0 {
        return Some(Vec2::new(x, y) + centre);
    }
    let z = d.dot(v(c.to_z));
    // Also true for NaN, as in the kernel.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(z > 0.0) {
        return None;
    }
    let inv = 1.0 / z;
    Some(Vec2::new(x * inv, y * inv) + centre)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::{FrameCamera, Projection};
    use crate::trace::camera::device_camera;
    use glam::{Mat4, Quat};

    /// A camera ray through pixel (x, y down) lands back on it.
    #[test]
    fn projection_inverts_the_camera_ray() {
        let world_from_camera = Mat4::from_rotation_translation(
            Quat::from_euler(glam::EulerRot::YXZ, 0.4, -0.3, 0.1),
            Vec3::new(1.0, 2.0, 3.0),
        );
        for projection in [
            Projection::Perspective {
                yfov: 0.7,
                aspect: None,
                znear: 0.1,
                zfar: None,
            },
            Projection::Orthographic {
                xmag: 2.0,
                ymag: 1.5,
                znear: 0.1,
                zfar: 100.0,
            },
        ] {
            let cam = FrameCamera {
                name: None,
                world_from_camera,
                projection,
                from_file: true,
            };
            let (w, h) = (320, 180);
            let c = device_camera(&cam, w, h);
            let vc = vector_camera(&c, w, h);
            let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
            for (px, py) in [(0.5f32, 0.5f32), (100.25, 30.75), (319.5, 179.5)] {
                let sx = px / w as f32 * 2.0 - 1.0;
                let sy = 1.0 - py / h as f32 * 2.0;
                let p = if c.ortho != 0 {
                    v(c.origin) + v(c.right) * sx + v(c.up) * sy + v(c.forward) * 4.0
                } else {
                    v(c.origin) + (v(c.forward) + v(c.right) * sx + v(c.up) * sy) * 4.0
                };
                let at = project(&vc, p).unwrap();
                assert!((at.x - px).abs() < 1e-3, "{at} against ({px}, {py})");
                assert!(
                    (at.y - (h as f32 - py)).abs() < 1e-3,
                    "{at} against ({px}, {py})"
                );
            }
            if c.ortho == 0 {
                assert!(project(&vc, v(c.origin) - v(c.forward)).is_none());
            }
        }
    }
}
