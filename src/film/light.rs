//! Light-path passes (`--passes light`), named as Blender's: the light
//! each kind of lobe at the first scattering vertex passed on to the
//! camera, directly (`DiffDir`: the vertex was the last before the light)
//! and indirectly (`DiffInd`), the lobe's colour (`DiffCol`), the same for
//! the glossy (`Gloss*`) and transmission (`Trans*`) lobes, and the
//! emission (`Emit`) and environment (`Env`) the camera saw directly. As
//! in Blender, light and colour are stored apart, so
//!
//! ```text
//! (DiffDir + DiffInd) DiffCol + (GlossDir + GlossInd) GlossCol
//!   + (TransDir + TransInd) TransCol + Emit + Env = beauty
//! ```
//!
//! to float rounding (tests/light_passes.rs checks it to 1e-5).
//!
//! The kernel (kernels/trace/pathtrace.cl, `FILM_LIGHT`) splits each
//! contribution by the shares of the first vertex's BSDF value the lobes
//! give: at the light sample's direction for direct light (the parts come
//! with the value there, `bsdf_eval_parts`), at the sampled direction for
//! all that follows it (`bsdf_lobe_parts`). Diffuse is the
//! Lambertian reflection, diffuse transmission and sheen; transmission the
//! GGX transmission (thin or refracting); glossy the rest (specular,
//! metal, clear coat), and a delta lobe is glossy above the surface and
//! transmission below. A lobe's colour is the mean of its weight f |cos| /
//! pdf at the sampled direction, whose expectation is the lobe's albedo
//! towards the camera.

use super::Aovs;
use crate::device_struct::device_consts;

device_consts! {
    fn light_pass_consts;
    /// The diffuse lobe's three sums in a pixel's light passes (direct,
    /// indirect, colour); glossy's and transmission's follow.
    pub const LIGHT_DIFFUSE: u32 = 0;
    /// The glossy lobe's three sums.
    pub const LIGHT_GLOSSY: u32 = 3;
    /// The transmission lobe's three sums.
    pub const LIGHT_TRANSMISSION: u32 = 6;
    /// Emission the camera saw.
    pub const LIGHT_EMIT: u32 = 9;
    /// Environment the camera saw.
    pub const LIGHT_ENV: u32 = 10;
    /// The rgb passes per pixel.
    pub const LIGHT_PASSES: u32 = 11;
}

/// The passes, in the order the kernel keeps them (`LIGHT_*`).
pub const LIGHT_PASS_NAMES: [&str; LIGHT_PASSES as usize] = [
    "DiffDir", "DiffInd", "DiffCol", "GlossDir", "GlossInd", "GlossCol", "TransDir", "TransInd",
    "TransCol", "Emit", "Env",
];

/// A pixel's light passes, in `LIGHT_PASS_NAMES` order.
pub type PixelPasses = [[f32; 3]; LIGHT_PASSES as usize];

/// A frame's light-path passes: the ones to write, and every pass's value
/// per pixel. A pixel's passes lie together, as the kernel's sums do, so
/// that resolving them is one stream in and one out; and all of them are
/// kept whichever are asked for, since the kernel sums them all.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct LightPasses {
    /// The passes asked for, as places in `LIGHT_PASS_NAMES`, in order;
    /// empty when none is (and then `pixels` is empty too).
    pub written: Vec<usize>,
    pub pixels: Vec<PixelPasses>,
}

impl LightPasses {
    pub fn is_empty(&self) -> bool {
        self.written.is_empty()
    }

    /// The EXR layer names of the passes written, as Blender's.
    pub fn names(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.written.iter().map(|&k| LIGHT_PASS_NAMES[k])
    }

    /// Pass `name`'s value per pixel, if it is written.
    pub fn pass(&self, name: &str) -> Option<Vec<[f32; 3]>> {
        let k = self
            .written
            .iter()
            .find(|&&k| LIGHT_PASS_NAMES[k] == name)?;
        Some(self.pixels.iter().map(|p| p[*k]).collect())
    }
}

/// Which passes `aovs` asks for, as places in `LIGHT_PASS_NAMES`.
fn written(aovs: Aovs) -> Vec<usize> {
    let on = [
        aovs.diffuse,
        aovs.diffuse,
        aovs.diffuse,
        aovs.glossy,
        aovs.glossy,
        aovs.glossy,
        aovs.transmission,
        aovs.transmission,
        aovs.transmission,
        aovs.emission,
        aovs.environment,
    ];
    (0..LIGHT_PASS_NAMES.len()).filter(|&k| on[k]).collect()
}

/// The black passes `aovs` asks for, of `pixels` pixels, in the buffer of
/// `spare` where it has one.
pub fn black(aovs: Aovs, pixels: usize, spare: LightPasses) -> LightPasses {
    let written = written(aovs);
    let n = if written.is_empty() { 0 } else { pixels };
    LightPasses {
        written,
        pixels: super::refill(Some(spare.pixels), n, [[0.0; 3]; LIGHT_PASSES as usize]),
    }
}

/// The passes `aovs` asks for, from the frame's sums (3 * LIGHT_PASSES
/// floats per pixel, as the kernel leaves them) over each pixel's `kept`
/// samples (`resolve_pixel`), in the buffer of `spare` where it has one;
/// the pixels split among the threads.
pub fn resolve(aovs: Aovs, sums: &[f32], kept: &[u32], spare: LightPasses) -> LightPasses {
    use rayon::prelude::*;
    let mut out = black(aovs, 0, spare);
    if !out.is_empty() {
        let per = 3 * LIGHT_PASSES as usize;
        out.pixels.par_extend(
            sums.par_chunks_exact(per)
                .zip(kept.par_iter())
                .map(|(s, &n)| resolve_pixel(s, n)),
        );
    }
    out
}

/// A pixel's light passes from its sums (3 * LIGHT_PASSES floats, as the
/// kernel leaves them) over its `kept` samples: each sum's mean, with the
/// light of each lobe divided by its colour. Where a colour channel is 0
/// and light still came through that lobe (a lobe the sampled directions
/// never weighed), the colour is 1 and the light passes carry the light, so
/// that the passes still add up to the beauty.
pub fn resolve_pixel(sums: &[f32], kept: u32) -> PixelPasses {
    let mut out = [[0.0f32; 3]; LIGHT_PASSES as usize];
    if kept == 0 {
        return out;
    }
    let inv = 1.0 / kept as f32;
    for (k, px) in out.iter_mut().enumerate() {
        for c in 0..3 {
            px[c] = sums[3 * k + c] * inv;
        }
    }
    for lobe in [LIGHT_DIFFUSE, LIGHT_GLOSSY, LIGHT_TRANSMISSION] {
        let (dir, ind, col) = (lobe as usize, lobe as usize + 1, lobe as usize + 2);
        for c in 0..3 {
            let colour = out[col][c];
            if colour > 0.0 {
                out[dir][c] /= colour;
                out[ind][c] /= colour;
            } else if out[dir][c] != 0.0 || out[ind][c] != 0.0 {
                out[col][c] = 1.0;
            }
        }
    }
    out
}

/// The beauty the passes of one pixel add up to (the formula above).
pub fn recombine(passes: &PixelPasses) -> [f32; 3] {
    let mut sum = [0.0f32; 3];
    for c in 0..3 {
        for lobe in [LIGHT_DIFFUSE, LIGHT_GLOSSY, LIGHT_TRANSMISSION] {
            let l = lobe as usize;
            sum[c] += (passes[l][c] + passes[l + 1][c]) * passes[l + 2][c];
        }
        sum[c] += passes[LIGHT_EMIT as usize][c] + passes[LIGHT_ENV as usize][c];
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn resolved_passes_add_up_to_the_mean_of_their_light() {
        // Two samples: diffuse light 0.3 of colour 0.5, glossy 0.1 with
        // colour 0 (light that the sampled directions never weighed), and
        // emission 0.2 and environment 0.05 seen directly.
        let mut sums = vec![0.0f32; 3 * LIGHT_PASSES as usize];
        let set = |s: &mut Vec<f32>, pass: u32, v: f32| {
            for c in 0..3 {
                s[3 * pass as usize + c] = v;
            }
        };
        set(&mut sums, LIGHT_DIFFUSE, 0.6);
        set(&mut sums, LIGHT_DIFFUSE + 2, 1.0);
        set(&mut sums, LIGHT_GLOSSY + 1, 0.2);
        set(&mut sums, LIGHT_EMIT, 0.4);
        set(&mut sums, LIGHT_ENV, 0.1);
        let p = resolve_pixel(&sums, 2);
        assert_eq!(p[LIGHT_DIFFUSE as usize], [0.6; 3]);
        assert_eq!(p[LIGHT_DIFFUSE as usize + 2], [0.5; 3]);
        assert_eq!(p[LIGHT_GLOSSY as usize + 1], [0.1; 3]);
        assert_eq!(p[LIGHT_GLOSSY as usize + 2], [1.0; 3]);
        let beauty = 0.3 + 0.1 + 0.2 + 0.05;
        for v in recombine(&p) {
            assert!((v - beauty).abs() < 1e-6, "{v} against {beauty}");
        }
    }
}
