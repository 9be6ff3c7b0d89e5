//! The tests' small random number generators, so generated cases are the
//! same everywhere and on every run. They are three different algorithms,
//! kept apart on purpose: each test's stream (and so each case it has ever
//! checked) stays what it was.
#![allow(dead_code)]

use glam::Vec3;

/// A small xorshift generator (xorshift64 13/7/17, 24-bit floats), so test
/// soups, rays and BSDF cases are the same everywhere.
pub struct Rng(pub u64);
impl Rng {
    pub fn new(seed: u64) -> Rng {
        Rng(seed.wrapping_mul(0x9E3779B97F4A7C15) | 1)
    }
    pub fn f32(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// A uniformly distributed unit vector, by rejection from the cube
/// [-1, 1]^3 (points nearer the centre than 0.05 are rejected too).
pub fn random_dir(rng: &mut Rng) -> Vec3 {
    loop {
        let v = Vec3::new(
            rng.f32() * 2.0 - 1.0,
            rng.f32() * 2.0 - 1.0,
            rng.f32() * 2.0 - 1.0,
        );
        let l = v.length();
        if l > 0.05 && l <= 1.0 {
            return v / l;
        }
    }
}

/// `random_dir` folded into the upper hemisphere (z >= 0.02, so never
/// grazing), renormalised: an outgoing direction for the BSDF tests. It
/// draws the same numbers as `random_dir`.
pub fn random_upper_dir(rng: &mut Rng) -> Vec3 {
    let v = random_dir(rng);
    Vec3::new(v.x, v.y, v.z.abs().max(0.02)).normalize()
}

/// xorshift64* on the raw seed: the fuzz tests' generator of mutations
/// (which case, which byte, which value).
pub struct XorshiftStar(pub u64);

impl XorshiftStar {
    pub fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    /// A number below `n` (0 when `n` is 0).
    pub fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

/// Marsaglia's 32-bit xorshift (13/17/5): the byte corruptions of a file.
pub struct Xorshift32(pub u32);

impl Xorshift32 {
    pub fn next(&mut self) -> u32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 17;
        self.0 ^= self.0 << 5;
        self.0
    }
}
