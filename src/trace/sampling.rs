//! The path tracer's random numbers and warps in plain Rust, mirroring
//! `kernels/sampling.h` operation for operation: the counter-based
//! generator keyed by (seed, frame, pixel, sample, dimension), the
//! cosine-hemisphere, sphere and triangle warps, the CDF search and the
//! power heuristic. The device is held to these by `tests/render_reference.rs`.

use glam::Vec3;

pub const PI: f32 = std::f32::consts::PI;
pub const INV_PI: f32 = std::f32::consts::FRAC_1_PI;
pub const TWO_PI: f32 = std::f32::consts::TAU;

/// The PCG hash (Jarzynski and Olano, JCGT 2020).
pub fn pcg_hash(v: u32) -> u32 {
    let state = v.wrapping_mul(747_796_405).wrapping_add(2_891_336_453);
    let word = ((state >> ((state >> 28) + 4)) ^ state).wrapping_mul(277_803_737);
    (word >> 22) ^ word
}

/// The key of one camera sample (`rng_for_sample`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleRng {
    pub key: u32,
}

impl SampleRng {
    pub fn new(seed: u64, frame: i64, pixel: u32, sample: u32) -> SampleRng {
        let frame = frame as u64;
        let mut h = pcg_hash(seed as u32);
        h = pcg_hash(h ^ (seed >> 32) as u32);
        h = pcg_hash(h ^ frame as u32);
        h = pcg_hash(h ^ (frame >> 32) as u32);
        h = pcg_hash(h ^ pixel);
        h = pcg_hash(h ^ sample);
        SampleRng { key: h }
    }

    /// Uniform in [0, 1) for dimension `dim`.
    pub fn get(&self, dim: u32) -> f32 {
        let h = pcg_hash(self.key ^ pcg_hash(dim.wrapping_add(0x9E37_79B9)));
        (h >> 8) as f32 * (1.0 / 16_777_216.0)
    }
}

/// Orthonormal basis around unit `n` (Duff et al. 2017): (t, b).
pub fn onb(n: Vec3) -> (Vec3, Vec3) {
    let sign = 1.0f32.copysign(n.z);
    let a = -1.0 / (sign + n.z);
    let bb = n.x * n.y * a;
    (
        Vec3::new(1.0 + sign * n.x * n.x * a, sign * bb, -sign * n.x),
        Vec3::new(bb, sign + n.y * n.y * a, -n.y),
    )
}

pub fn sample_cosine_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let ox = 2.0 * u1 - 1.0;
    let oy = 2.0 * u2 - 1.0;
    let (r, phi) = if ox == 0.0 && oy == 0.0 {
        (0.0, 0.0)
    } else if ox.abs() > oy.abs() {
        (ox, (PI / 4.0) * (oy / ox))
    } else {
        (oy, (PI / 2.0) - (PI / 4.0) * (ox / oy))
    };
    let x = r * phi.cos();
    let y = r * phi.sin();
    let z = ((1.0 - x * x) - y * y).max(0.0).sqrt();
    Vec3::new(x, y, z)
}

pub fn sample_uniform_sphere(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = TWO_PI * u2;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform barycentrics (b1, b2) on a triangle.
pub fn sample_triangle(u1: f32, u2: f32) -> (f32, f32) {
    let s = u1.sqrt();
    (1.0 - s, u2 * s)
}

/// The index i with cdf[i] <= u < cdf[i + 1] (`cdf_search`); `cdf` has
/// n + 1 entries from 0 to 1.
pub fn cdf_search(cdf: &[f32], u: f32) -> usize {
    let (mut lo, mut hi) = (0usize, cdf.len() - 1);
    while hi - lo > 1 {
        let mid = (lo + hi) / 2;
        if cdf[mid] <= u {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    lo
}

pub fn luminance(c: Vec3) -> f32 {
    (0.2126 * c.x + 0.7152 * c.y) + 0.0722 * c.z
}

pub fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 {
        a2 / (a2 + b2)
    } else {
        0.0
    }
}

/// A normalised CDF of `weights` (n + 1 entries, 0 first, exactly 1 last),
/// summed in f64 so that it does not depend on float rounding order. `None`
/// when the weights sum to zero (or are not finite).
pub fn build_cdf(weights: &[f64]) -> Option<Vec<f32>> {
    let total: f64 = weights.iter().sum();
    if !(total > 0.0 && total.is_finite()) {
        return None;
    }
    let mut cdf = Vec::with_capacity(weights.len() + 1);
    let mut acc = 0.0f64;
    cdf.push(0.0f32);
    for w in weights {
        acc += w;
        cdf.push((acc / total) as f32);
    }
    *cdf.last_mut().expect("one entry at least") = 1.0;
    Some(cdf)
}
