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

use glam::{Vec2, Vec3};

use super::camera::DeviceCamera;

/// The soup's steps for motion vectors: before, at and after the centre.
pub const VECTOR_STEPS: usize = 3;

/// The times of the vector steps around `centre`, one frame (`1 / fps`
/// seconds) apart.
pub fn vector_times(centre: f64, fps: f64) -> [f64; VECTOR_STEPS] {
    let frame = 1.0 / fps;
    [centre - frame, centre, centre + frame]
}

/// Where world point `p` lands on camera `c`'s `width` x `height` image, in
/// pixels from the bottom-left corner (x right, y up); `None` behind a
/// perspective camera. The inverse of the camera ray: a perspective ray
/// runs along forward + right sx + up sy, an orthographic one starts at
/// origin + right sx + up sy, the image spanning sx, sy in [-1, 1].
pub fn project(c: &DeviceCamera, p: Vec3, width: u32, height: u32) -> Option<Vec2> {
    let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    let (o, r, u, f) = (v(c.origin), v(c.right), v(c.up), v(c.forward));
    let d = p - o;
    let mut sx = d.dot(r) / r.dot(r);
    let mut sy = d.dot(u) / u.dot(u);
    if c.ortho == 0 {
        let z = d.dot(f) / f.dot(f);
        // Also true for NaN, as in the kernel.
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        if !(z > 0.0) {
            return None;
        }
        sx /= z;
        sy /= z;
    }
    Some(Vec2::new(
        (sx + 1.0) * 0.5 * width as f32,
        (sy + 1.0) * 0.5 * height as f32,
    ))
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
            let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
            for (px, py) in [(0.5f32, 0.5f32), (100.25, 30.75), (319.5, 179.5)] {
                let sx = px / w as f32 * 2.0 - 1.0;
                let sy = 1.0 - py / h as f32 * 2.0;
                let p = if c.ortho != 0 {
                    v(c.origin) + v(c.right) * sx + v(c.up) * sy + v(c.forward) * 4.0
                } else {
                    v(c.origin) + (v(c.forward) + v(c.right) * sx + v(c.up) * sy) * 4.0
                };
                let at = project(&c, p, w, h).unwrap();
                assert!((at.x - px).abs() < 1e-3, "{at} against ({px}, {py})");
                assert!(
                    (at.y - (h as f32 - py)).abs() < 1e-3,
                    "{at} against ({px}, {py})"
                );
            }
            if c.ortho == 0 {
                assert!(project(&c, v(c.origin) - v(c.forward), w, h).is_none());
            }
        }
    }
}
