//! The path tracer's random numbers and warps in plain Rust, mirroring
//! `kernels/common/sampling.h` operation for operation: the samplers (Owen-scrambled
//! Sobol, the default, and independent hashed uniforms), both pure functions
//! of (seed, frame, pixel, sample, dimension), the
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

/// Which sampler draws the path tracer's random numbers (`--sampler`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Sampler {
    /// Owen-scrambled, shuffled Sobol points (Burley 2020), decorrelated
    /// between pixels: the default.
    #[default]
    Sobol,
    /// Independent uniforms from a hash (the sampler before Sobol; for
    /// comparison).
    Random,
}

impl Sampler {
    /// The `--sampler` value that selects it.
    pub fn name(self) -> &'static str {
        match self {
            Sampler::Sobol => "sobol",
            Sampler::Random => "random",
        }
    }

    /// The kernel define that compiles it in, if any.
    pub fn define(self) -> Option<&'static str> {
        match self {
            Sampler::Sobol => None,
            Sampler::Random => Some("SAMPLER_RANDOM"),
        }
    }
}

impl std::str::FromStr for Sampler {
    type Err = String;
    fn from_str(s: &str) -> Result<Sampler, String> {
        match s {
            "sobol" => Ok(Sampler::Sobol),
            "random" => Ok(Sampler::Random),
            _ => Err(format!("unknown sampler {s:?}: use sobol or random")),
        }
    }
}

/// Whether the noise pattern changes from frame to frame (`--noise-pattern`).
///
/// `PerFrame` hashes the frame number into every pixel's sampler seed, so
/// each frame's noise is new. `Fixed` seeds every frame as frame 0: where
/// nothing moves, consecutive frames draw the same samples, so a still
/// region keeps the same noise and does not flicker (Cycles' default, its
/// "animated seed" off). A frame's image is a function of its inputs either
/// way. (`Fixed` is frame 0's pattern, so frame 0 renders the same with both.)
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum NoisePattern {
    PerFrame,
    /// The default: it flickers 1.7-6.6x less in still regions at the same
    /// per-frame error (`cargo bench --bench flicker`, BENCHMARKS.md "Flicker").
    #[default]
    Fixed,
}

impl NoisePattern {
    /// The `--noise-pattern` value that selects it.
    pub fn name(self) -> &'static str {
        match self {
            NoisePattern::PerFrame => "per-frame",
            NoisePattern::Fixed => "fixed",
        }
    }

    /// The frame number the sampler is seeded with for `frame`.
    pub fn sampler_frame(self, frame: i64) -> i64 {
        match self {
            NoisePattern::PerFrame => frame,
            NoisePattern::Fixed => 0,
        }
    }
}

impl std::str::FromStr for NoisePattern {
    type Err = String;
    fn from_str(s: &str) -> Result<NoisePattern, String> {
        match s {
            "per-frame" => Ok(NoisePattern::PerFrame),
            "fixed" => Ok(NoisePattern::Fixed),
            _ => Err(format!(
                "unknown noise pattern {s:?}: use per-frame or fixed"
            )),
        }
    }
}

/// The set of the camera sample: (filter x, filter y, shutter time, -); the
/// time (component 2) is read only with motion blur (`trace::motion`).
pub const SET_CAMERA: u32 = 0;
/// The lens point of depth of field (`SET_LENS`).
pub const SET_LENS: u32 = 0x0800_0000;
/// The light a shadow catcher receives (`SET_CATCHER`).
pub const SET_CATCHER: u32 = 0x0800_0001;
/// Slots of a bounce's sets (`set_bounce`).
pub const SET_LIGHT: u32 = 0;
pub const SET_BSDF: u32 = 1;

/// Bounce `bounce`'s light set (u, v, light choice, -) or BSDF set (u, v,
/// lobe, roulette). The layout is documented in `kernels/common/sampling.h`.
pub fn set_bounce(bounce: u32, slot: u32) -> u32 {
    1 + 2 * bounce + slot
}

/// Generator matrix of Sobol dimension `d` (0..4) from Joe and Kuo's
/// primitive polynomials and initial direction numbers, bit-reversed: column
/// j (the contribution of index bit j) is v_j = m_j / 2^(j+1) with its first
/// binary digit in bit 0. `kernels/common/sampling.h` holds the same table as
/// literals; the device tests hold the two together.
const fn sobol_reversed(d: usize) -> [u32; 32] {
    let mut m = [0u32; 32];
    let mut out = [0u32; 32];
    if d == 0 {
        let mut j = 0;
        while j < 32 {
            out[j] = 1 << j;
            j += 1;
        }
        return out;
    }
    // (degree s, coefficients a, initial m) of dimensions 2, 3 and 4.
    let (s, a, m0): (usize, u32, [u32; 3]) = match d {
        1 => (1, 0, [1, 0, 0]),
        2 => (2, 1, [1, 3, 0]),
        _ => (3, 1, [1, 3, 1]),
    };
    let mut k = 0;
    while k < 32 {
        if k < s {
            m[k] = m0[k];
        } else {
            let mut v = m[k - s] ^ (m[k - s] << s);
            let mut i = 1;
            while i < s {
                if (a >> (s - 1 - i)) & 1 == 1 {
                    v ^= m[k - i] << i;
                }
                i += 1;
            }
            m[k] = v;
        }
        out[k] = (m[k] << (31 - k)).reverse_bits();
        k += 1;
    }
    out
}

pub const SOBOL_REVERSED: [[u32; 32]; 4] = [
    sobol_reversed(0),
    sobol_reversed(1),
    sobol_reversed(2),
    sobol_reversed(3),
];

/// Owen scrambling of a bit-reversed value (`reversed_bit_owen`): the
/// Laine-Karras hash in Vegdahl's improved form.
pub fn reversed_bit_owen(mut x: u32, seed: u32) -> u32 {
    x ^= x.wrapping_mul(0x3d20_adea);
    x = x.wrapping_add(seed);
    x = x.wrapping_mul((seed >> 16) | 1);
    x ^= x.wrapping_mul(0x0552_6c56);
    x ^= x.wrapping_mul(0x53a2_2864);
    x
}

fn u32_to_unit(x: u32) -> f32 {
    (x >> 8) as f32 * (1.0 / 16_777_216.0)
}

/// The random numbers of one camera sample (`SampleRng` and `rng_4d` of
/// `kernels/common/sampling.h`, value for value).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SampleRng {
    pub sampler: Sampler,
    /// Random: the hash of (seed, frame, pixel, sample); Sobol: of (seed,
    /// frame, pixel).
    pub key: u32,
    pub sample: u32,
}

impl SampleRng {
    pub fn new(sampler: Sampler, seed: u64, frame: i64, pixel: u32, sample: u32) -> SampleRng {
        let frame = frame as u64;
        let mut h = pcg_hash(seed as u32);
        h = pcg_hash(h ^ (seed >> 32) as u32);
        h = pcg_hash(h ^ frame as u32);
        h = pcg_hash(h ^ (frame >> 32) as u32);
        h = pcg_hash(h ^ pixel);
        if sampler == Sampler::Random {
            h = pcg_hash(h ^ sample);
        }
        SampleRng {
            sampler,
            key: h,
            sample,
        }
    }

    /// The four uniforms in [0, 1) of dimension set `set`.
    pub fn get4(&self, set: u32) -> [f32; 4] {
        match self.sampler {
            Sampler::Random => std::array::from_fn(|c| {
                let d = (set * 4).wrapping_add(c as u32);
                u32_to_unit(pcg_hash(self.key ^ pcg_hash(d.wrapping_add(0x9E37_79B9))))
            }),
            Sampler::Sobol => {
                let seed = pcg_hash(self.key ^ pcg_hash(set.wrapping_add(0x9E37_79B9)));
                let shuffled = reversed_bit_owen(self.sample.reverse_bits(), seed ^ 0xc2c1_a055)
                    .reverse_bits();
                let index = (shuffled & 0xFFFF) | (self.sample & 0xFFFF_0000);
                let mut x = [0u32; 4];
                for j in 0..32 {
                    if (index >> j) & 1 == 1 {
                        for (d, v) in x.iter_mut().enumerate() {
                            *v ^= SOBOL_REVERSED[d][j];
                        }
                    }
                }
                const SALT: [u32; 4] = [0x39d8_a3b4, 0x8c5e_8f21, 0x3c0a_2e6b, 0x5b72_d8f5];
                std::array::from_fn(|c| {
                    u32_to_unit(reversed_bit_owen(x[c], seed ^ SALT[c]).reverse_bits())
                })
            }
        }
    }

    /// Uniform in [0, 1) for dimension `dim`: component dim % 4 of set
    /// dim / 4.
    pub fn get(&self, dim: u32) -> f32 {
        self.get4(dim >> 2)[(dim & 3) as usize]
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

/// cos and sin of `a` in [-pi/4, pi/4] by their Taylor polynomials
/// (`cos_sin_quarter`: the same float operations, so bit for bit).
#[allow(clippy::excessive_precision)]
pub fn cos_sin_quarter(a: f32) -> (f32, f32) {
    let a2 = a * a;
    let c = 1.0
        + a2 * (-5.000000000e-01
            + a2 * (4.166666791e-02 + a2 * (-1.388888923e-03 + a2 * 2.480158764e-05)));
    let s = a
        * (1.0
            + a2 * (-1.666666716e-01
                + a2 * (8.333333768e-03 + a2 * (-1.984127011e-04 + a2 * 2.755731884e-06))));
    (c, s)
}

/// cos and sin of 2 pi u for u in [0, 1] (`cos_sin_turns`).
#[allow(clippy::excessive_precision)]
pub fn cos_sin_turns(u: f32) -> (f32, f32) {
    let q = u * 4.0;
    let k = q.floor();
    let f = q - k;
    let (c, s) = if f < 0.5 {
        cos_sin_quarter(f * 1.570796371e+00)
    } else {
        let (c, s) = cos_sin_quarter((1.0 - f) * 1.570796371e+00);
        (s, c)
    };
    match (k as i32) & 3 {
        1 => (-s, c),
        2 => (-c, -s),
        3 => (s, -c),
        _ => (c, s),
    }
}

#[allow(clippy::excessive_precision)]
pub fn sample_cosine_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let ox = 2.0 * u1 - 1.0;
    let oy = 2.0 * u2 - 1.0;
    let (x, y) = if ox == 0.0 && oy == 0.0 {
        (0.0, 0.0)
    } else if ox.abs() > oy.abs() {
        let (c, s) = cos_sin_quarter(7.853981853e-01 * (oy / ox));
        (ox * c, ox * s)
    } else {
        let (c, s) = cos_sin_quarter(7.853981853e-01 * (ox / oy));
        (oy * s, oy * c)
    };
    let z = ((1.0 - x * x) - y * y).max(0.0).sqrt();
    Vec3::new(x, y, z)
}

pub fn sample_uniform_sphere(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (c, s) = cos_sin_turns(u2);
    Vec3::new(r * c, r * s, z)
}

/// A uniform direction on the upper hemisphere (pdf 1 / (2 pi)).
pub fn sample_uniform_hemisphere(u1: f32, u2: f32) -> Vec3 {
    let z = 1.0 - u1;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let (c, s) = cos_sin_turns(u2);
    Vec3::new(r * c, r * s, z)
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

#[cfg(test)]
mod tests {
    use super::*;

    /// Whether `points` (2^k of them in [0,1)^2) put exactly one point in
    /// every elementary interval of area 2^-k: a (0,k,2)-net.
    fn is_net(points: &[(f32, f32)]) -> bool {
        let k = points.len().trailing_zeros();
        (0..=k).all(|a| {
            let (nx, ny) = (1u32 << a, 1u32 << (k - a));
            let mut seen = vec![false; points.len()];
            points.iter().all(|&(x, y)| {
                let cell = ((x * nx as f32) as u32 * ny + (y * ny as f32) as u32) as usize;
                !std::mem::replace(&mut seen[cell], true)
            })
        })
    }

    #[test]
    fn polynomial_cos_sin_are_accurate() {
        for i in 0..=4096 {
            let u = i as f32 / 4096.0;
            let (c, s) = cos_sin_turns(u);
            let a = std::f64::consts::TAU * u as f64;
            assert!((c as f64 - a.cos()).abs() < 3e-7, "cos at {u}: {c}");
            assert!((s as f64 - a.sin()).abs() < 3e-7, "sin at {u}: {s}");
        }
        for i in -1024..=1024 {
            let a = i as f32 / 1024.0 * (PI / 4.0);
            let (c, s) = cos_sin_quarter(a);
            assert!((c as f64 - (a as f64).cos()).abs() < 2e-7, "cos({a})");
            assert!((s as f64 - (a as f64).sin()).abs() < 2e-7, "sin({a})");
        }
    }

    #[test]
    fn sobol_matrices_are_joe_kuo() {
        // The first columns of dimensions 2-4 (Joe and Kuo's direction
        // numbers of x + 1, x^2 + x + 1 and x^3 + x + 1, whose v_j start
        // 0.1, 0.11, 0.101, 0.1111, ... in binary for the second), reversed.
        assert_eq!(SOBOL_REVERSED[1][..5], [1, 3, 5, 15, 17]);
        assert_eq!(SOBOL_REVERSED[2][..5], [1, 3, 6, 9, 23]);
        assert_eq!(SOBOL_REVERSED[3][..5], [1, 3, 4, 10, 31]);
    }

    #[test]
    fn every_power_of_two_prefix_is_stratified() {
        // For any pixel and set: the first 2^k samples are a (0,k,2)-net in
        // the set's first two dimensions and stratified in each dimension
        // alone, and so is each later block of 2^k, past 65536 too.
        for (pixel, set, start) in [(0, 0, 0), (7, 1, 0), (12345, 2, 256), (99, 9, 65_536)] {
            for k in [2u32, 4, 6, 8] {
                let n = 1u32 << k;
                let values: Vec<[f32; 4]> = (start..start + n)
                    .map(|s| SampleRng::new(Sampler::Sobol, 3, 5, pixel, s).get4(set))
                    .collect();
                let pairs: Vec<(f32, f32)> = values.iter().map(|v| (v[0], v[1])).collect();
                assert!(is_net(&pairs), "pixel {pixel} set {set} k {k}");
                for d in 0..4 {
                    let mut strata: Vec<u32> =
                        values.iter().map(|v| (v[d] * n as f32) as u32).collect();
                    strata.sort_unstable();
                    assert_eq!(strata, (0..n).collect::<Vec<_>>(), "dim {d} k {k}");
                }
            }
        }
    }

    #[test]
    fn pixels_and_sets_are_decorrelated() {
        // Two pixels, or two sets of one pixel, do not repeat each other's
        // sequence.
        let a = SampleRng::new(Sampler::Sobol, 0, 0, 10, 3);
        let b = SampleRng::new(Sampler::Sobol, 0, 0, 11, 3);
        assert_ne!(a.get4(1), b.get4(1));
        assert_ne!(a.get4(1), a.get4(2));
        // And the value depends on the frame and the seed.
        assert_ne!(
            a.get4(1),
            SampleRng::new(Sampler::Sobol, 0, 1, 10, 3).get4(1)
        );
        assert_ne!(
            a.get4(1),
            SampleRng::new(Sampler::Sobol, 1, 0, 10, 3).get4(1)
        );
    }
}
