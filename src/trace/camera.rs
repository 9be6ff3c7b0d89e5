//! A pinhole camera for primary rays: an origin and, per pixel, the
//! direction `p00 + (x + 0.5) du + (y + 0.5) dv` (rows top to bottom). The
//! `generate_primary` kernel computes the same floats on the device. The
//! glTF camera comes later; this one frames a bounding box, for tests and
//! benchmarks.

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
