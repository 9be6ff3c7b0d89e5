//! The film: where the tracer's samples become pixels. The path tracer sums
//! each pixel's samples on the device, in sample order; `resolve` turns those
//! sums (`Accumulated`) into an `Image` with its AOVs and each pixel's noise
//! estimate, and `NoiseStats` summarises the frame for its log.
//!
//! **Filter.** The default is a Blackman-Harris window of radius 1.5 px
//! (3 px support, standard deviation about 0.42 px, close to pbrt-v4's
//! default Gaussian): sharp, with no negative lobes, so it cannot ring
//! around bright edges and alpha stays within [0, 1]. `Filter::Box` (the
//! pixel square) and a truncated `Filter::Gaussian` are there for tests and
//! special cases.
//!
//! **Reconstruction by filter importance sampling** (as Cycles and pbrt-v4
//! do): the tracer draws each sample's offset from the pixel centre from the
//! filter (`FilterSampler`'s table, uploaded to the device), so every sample
//! has weight 1 and belongs to its own pixel only; noise stays uncorrelated
//! between pixels and tiles need no halo, and a pixel's value is the plain
//! mean of its kept samples.
//!
//! **Resolve.** RGB, alpha, normal and albedo are the means of the kept
//! samples (samples with NaN or infinite values are dropped and counted), so
//! they are premultiplied by coverage like RGB (a sample that misses
//! contributes what the tracer gives it, normally zero). Depth `Z` is the
//! camera distance averaged over the samples that hit, and
//! `BACKGROUND_DEPTH` where none did, as Blender does.

pub mod cryptomatte;
pub mod light;

pub use cryptomatte::{Cryptomatte, MatteKind, MatteLayer};
pub use light::LightPasses;

use crate::scene::MatteTable;
use crate::UsageError;
use rayon::prelude::*;

/// Depth written where no sample hit anything (Blender's value).
pub const BACKGROUND_DEPTH: f32 = 1.0e10;

/// Entries in `FilterSampler`'s inverse-CDF table, minus one.
const TABLE_CELLS: usize = 1024;

/// The pixel filter, separable in x and y. Offsets are in pixels from the
/// pixel centre.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Filter {
    /// The pixel square (radius 0.5): no overlap between pixels; aliases.
    Box,
    /// The 4-term Blackman-Harris window over [-radius, radius].
    BlackmanHarris { radius: f32 },
    /// A Gaussian truncated at `radius` and shifted to reach zero there.
    Gaussian { radius: f32, sigma: f32 },
}

impl Default for Filter {
    fn default() -> Self {
        Filter::BlackmanHarris { radius: 1.5 }
    }
}

impl Filter {
    /// Checks the parameters (they may come from the command line).
    pub fn check(&self) -> Result<(), UsageError> {
        let ok = |r: f32| r.is_finite() && (0.5..=8.0).contains(&r);
        match *self {
            Filter::Box => Ok(()),
            Filter::BlackmanHarris { radius } if ok(radius) => Ok(()),
            Filter::Gaussian { radius, sigma }
                if ok(radius) && sigma > 0.0 && sigma.is_finite() =>
            {
                Ok(())
            }
            _ => Err(UsageError(format!(
                "filter {self:?}: the radius must be between 0.5 and 8 pixels and sigma positive"
            ))),
        }
    }

    /// Half the width of the filter's support, in pixels.
    pub fn radius(&self) -> f32 {
        match *self {
            Filter::Box => 0.5,
            Filter::BlackmanHarris { radius } | Filter::Gaussian { radius, .. } => radius,
        }
    }

    /// The 1-D filter at offset `x` (not normalised; zero outside the radius).
    pub fn eval_1d(&self, x: f32) -> f32 {
        if let Filter::Box = self {
            // Half-open, so a point on a pixel border belongs to one pixel.
            return if (-0.5..0.5).contains(&x) { 1.0 } else { 0.0 };
        }
        if x.abs() > self.radius() {
            return 0.0;
        }
        match *self {
            Filter::Box => 1.0,
            Filter::BlackmanHarris { radius } => {
                // Centred form of a0 - a1 cos(2πn/N) + a2 cos(4πn/N) - a3 cos(6πn/N).
                let t = std::f64::consts::TAU * (x as f64) / (2.0 * radius as f64);
                let w = 0.35875
                    + 0.48829 * t.cos()
                    + 0.14128 * (2.0 * t).cos()
                    + 0.01168 * (3.0 * t).cos();
                w.max(0.0) as f32
            }
            Filter::Gaussian { radius, sigma } => {
                let g = |v: f32| (-(v * v) / (2.0 * sigma * sigma)).exp();
                (g(x) - g(radius)).max(0.0)
            }
        }
    }

    /// The 2-D filter at `offset`.
    pub fn eval(&self, offset: [f32; 2]) -> f32 {
        self.eval_1d(offset[0]) * self.eval_1d(offset[1])
    }

    /// The importance sampler for this filter.
    pub fn sampler(&self) -> FilterSampler {
        FilterSampler::new(self)
    }
}

/// Draws sample offsets distributed like the filter (for
/// `Reconstruction::FilterImportance`), from a tabulated 1-D inverse CDF
/// used for x and y independently (the filters are separable).
///
/// The device can reproduce `sample` exactly from `table()`: with
/// `n = table.len() - 1`, `s = u * n`, `i = min(floor(s), n - 1)`,
/// `x = table[i] + (s - i) * (table[i + 1] - table[i])`, in f32.
#[derive(Debug, Clone, PartialEq)]
pub struct FilterSampler {
    inverse_cdf: Vec<f32>,
}

impl FilterSampler {
    fn new(filter: &Filter) -> Self {
        let r = filter.radius() as f64;
        // A fine piecewise-constant pdf (midpoint rule), integrated exactly.
        const FINE: usize = 8 * TABLE_CELLS;
        let h = 2.0 * r / FINE as f64;
        let mut cdf = Vec::with_capacity(FINE + 1);
        cdf.push(0.0f64);
        for i in 0..FINE {
            let x = -r + (i as f64 + 0.5) * h;
            let p = filter.eval_1d(x as f32) as f64;
            cdf.push(cdf[i] + p * h);
        }
        let total = cdf[FINE];
        let mut inverse_cdf = Vec::with_capacity(TABLE_CELLS + 1);
        let mut j = 0;
        for k in 0..=TABLE_CELLS {
            let target = total * k as f64 / TABLE_CELLS as f64;
            while j + 1 < FINE && cdf[j + 1] < target {
                j += 1;
            }
            let (c0, c1) = (cdf[j], cdf[j + 1]);
            let t = if c1 > c0 {
                ((target - c0) / (c1 - c0)).clamp(0.0, 1.0)
            } else {
                0.0
            };
            inverse_cdf.push((-r + (j as f64 + t) * h) as f32);
        }
        // Pin the ends and the centre exactly: symmetric filters must map
        // u = 0.5 to the pixel centre.
        inverse_cdf[0] = -r as f32;
        inverse_cdf[TABLE_CELLS] = r as f32;
        inverse_cdf[TABLE_CELLS / 2] = 0.0;
        FilterSampler { inverse_cdf }
    }

    /// The inverse-CDF table, from -radius (u = 0) to +radius (u = 1).
    pub fn table(&self) -> &[f32] {
        &self.inverse_cdf
    }

    fn sample_1d(&self, u: f32) -> f32 {
        let n = (self.inverse_cdf.len() - 1) as f32;
        let s = u.clamp(0.0, 1.0) * n;
        let i = (s.floor() as usize).min(self.inverse_cdf.len() - 2);
        let (a, b) = (self.inverse_cdf[i], self.inverse_cdf[i + 1]);
        a + (s - i as f32) * (b - a)
    }

    /// An offset from the pixel centre for two uniform numbers in [0, 1).
    pub fn sample(&self, u: [f32; 2]) -> [f32; 2] {
        [self.sample_1d(u[0]), self.sample_1d(u[1])]
    }
}

/// Which AOVs the film keeps (each costs memory).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Aovs {
    pub depth: bool,
    pub normal: bool,
    pub albedo: bool,
    /// Samples each pixel took (EXR channel `sample_count`).
    pub sample_count: bool,
    /// Each pixel's estimated relative error (`noise`; `noise_estimate`).
    pub noise: bool,
    /// Rays each pixel traced (`rays`): where the frame's time went.
    pub rays: bool,
    /// Screen-space motion of the first hit, to the frame before and to
    /// the frame after (`motion`; EXR `Vector.X` .. `Vector.W`).
    pub motion: bool,
    /// World-space position of the first hit (`position`).
    pub position: bool,
    /// TEXCOORD_0 at the first hit (`uv`).
    pub uv: bool,
    /// The glTF node covering most of the pixel (`object_id`).
    pub object_id: bool,
    /// The light-path passes (`film::light`), by lobe: `DiffDir`,
    /// `DiffInd` and `DiffCol` (`diffuse`), `Gloss*` (`glossy`), `Trans*`
    /// (`transmission`), `Emit` (`emission`) and `Env` (`environment`);
    /// `light` names all five.
    pub diffuse: bool,
    pub glossy: bool,
    pub transmission: bool,
    pub emission: bool,
    pub environment: bool,
}

/// Each AOV's `--aov` name and other spellings, in the order `names` lists
/// them: one table for parsing, listing and the usage message.
macro_rules! aov_names {
    ($($field:ident: $name:literal $(| $alias:literal)*;)*) => {
        impl Aovs {
            /// No AOV.
            pub const NONE: Aovs = Aovs { $($field: false),* };

            /// Turns on the AOV `--aov` spells `item`; false if none is.
            fn set(&mut self, item: &str) -> bool {
                match item {
                    $($name $(| $alias)* => self.$field = true,)*
                    _ => return false,
                }
                true
            }

            /// The AOVs' names as `--aov` spells them.
            pub fn names(&self) -> Vec<&'static str> {
                let mut v = Vec::new();
                $(if self.$field {
                    v.push($name);
                })*
                v
            }

            /// Every name, for the usage message.
            const CHOICES: &'static str = concat!($($name, ", "),*);

            /// The AOVs on in either set.
            pub const fn union(self, other: Aovs) -> Aovs {
                Aovs { $($field: self.$field || other.$field),* }
            }

            /// The AOVs on in both sets.
            pub const fn intersection(self, other: Aovs) -> Aovs {
                Aovs { $($field: self.$field && other.$field),* }
            }

            /// The AOVs on in this set and off in `other`.
            pub const fn without(self, other: Aovs) -> Aovs {
                Aovs { $($field: self.$field && !other.$field),* }
            }
        }
    };
}

aov_names! {
    depth: "depth" | "z";
    normal: "normal" | "n";
    albedo: "albedo";
    sample_count: "sample_count" | "samples";
    noise: "noise";
    rays: "rays";
    motion: "motion" | "vector";
    position: "position" | "p";
    uv: "uv";
    object_id: "object_id" | "object-id";
    diffuse: "diffuse";
    glossy: "glossy";
    transmission: "transmission";
    emission: "emission" | "emit";
    environment: "environment" | "env";
}

impl Aovs {
    /// The first-hit AOVs: depth, normal and albedo.
    pub const ALL: Aovs = Aovs {
        depth: true,
        normal: true,
        albedo: true,
        ..Aovs::NONE
    };

    /// Every light-path pass (`--passes light`).
    pub const LIGHT: Aovs = Aovs {
        diffuse: true,
        glossy: true,
        transmission: true,
        emission: true,
        environment: true,
        ..Aovs::NONE
    };

    /// These AOVs with the light-path passes `--passes` names (`light`,
    /// or any of diffuse, glossy, transmission, emission, environment).
    pub fn with_light_passes(self, list: &str) -> Result<Aovs, UsageError> {
        let passes = Aovs::parse(list).map_err(|_| {
            UsageError(format!(
                "--passes {list:?}: choose light (every pass) or any of diffuse, glossy, \
                 transmission, emission, environment (e.g. --passes light)"
            ))
        })?;
        let other = passes.without(Aovs::LIGHT);
        if other != Aovs::NONE {
            return Err(UsageError(format!(
                "--passes {list:?}: {} is an AOV, not a light pass; give it to --aov",
                other.names().join(", ")
            )));
        }
        Ok(self.union(passes))
    }

    /// Whether any light-path pass is on (`film::light`).
    pub fn light(&self) -> bool {
        self.intersection(Aovs::LIGHT) != Aovs::NONE
    }

    /// Parses `--aov` (any subset of `names`, any order, comma-separated;
    /// `light` is every light-path pass).
    pub fn parse(list: &str) -> Result<Aovs, UsageError> {
        let mut aovs = Aovs::NONE;
        for item in list.split(',').map(str::trim).filter(|s| !s.is_empty()) {
            let item = item.to_ascii_lowercase();
            if item == "light" {
                aovs = aovs.union(Aovs::LIGHT);
            } else if !aovs.set(&item) {
                return Err(UsageError(format!(
                    "--aov: unknown AOV {item:?}; choose from {}, light (e.g. --aov depth,normal,albedo)",
                    Aovs::CHOICES.trim_end_matches(", ")
                )));
            }
        }
        Ok(aovs)
    }
}

/// The resolved frame: row-major, row 0 at the top, linear, premultiplied.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    pub width: u32,
    pub height: u32,
    pub rgba: Vec<[f32; 4]>,
    pub depth: Option<Vec<f32>>,
    pub normal: Option<Vec<[f32; 3]>>,
    pub albedo: Option<Vec<[f32; 3]>>,
    pub sample_count: Option<Vec<f32>>,
    pub noise: Option<Vec<f32>>,
    pub rays: Option<Vec<f32>>,
    /// Per pixel, the motion in pixels (x right, y up) from the frame
    /// before to this one (0, 1) and from this one to the next (2, 3).
    pub motion: Option<Vec<[f32; 4]>>,
    /// Per pixel, the world-space position and TEXCOORD_0 of the first hit,
    /// averaged over the samples that hit (0 where none did).
    pub position: Option<Vec<[f32; 3]>>,
    pub uv: Option<Vec<[f32; 2]>>,
    /// Per pixel, the glTF node index + 1 of the object most of its
    /// samples hit first (0: none).
    pub object_id: Option<Vec<f32>>,
    /// The Cryptomatte layers (`--cryptomatte`), or none.
    pub mattes: Vec<MatteLayer>,
    /// The light-path passes asked for (`film::light`), or none.
    pub light: LightPasses,
    /// With shadow catchers: per pixel, the share of the light that
    /// reaches the catcher (1: no shadow, 0: all of it shadowed), the
    /// factor to multiply a plate by; 1 where no catcher is seen.
    pub shadow: Option<Vec<[f32; 3]>>,
}

/// A frame whose pixels that see geometry average less linear luminance
/// than this is "nearly black": below 1/255 of an 8-bit display's range
/// after the sRGB curve.
pub const NEARLY_BLACK_LUMINANCE: f64 = 3.0e-4;

impl Image {
    /// A warning when the camera sees geometry but the frame is black or
    /// nearly black there: a scene with no light that reaches the camera,
    /// which would otherwise pass unnoticed with exit code 0.
    pub fn darkness_warning(&self) -> Option<String> {
        let (mut covered, mut sum, mut max) = (0usize, 0.0f64, 0.0f32);
        for p in self.rgba.iter().filter(|p| p[3] > 0.0) {
            covered += 1;
            sum += crate::trace::sampling::luminance(glam::Vec3::new(p[0], p[1], p[2])) as f64;
            max = max.max(p[0]).max(p[1]).max(p[2]);
        }
        if covered == 0 {
            return None;
        }
        let mean = sum / covered as f64;
        let share = 100.0 * covered as f64 / self.rgba.len() as f64;
        let fix =
            "Fix: light the scene (--env-color R,G,B, --env FILE.exr, or lights in the file), \
                   or check the exposure of the lights it has";
        if max <= 0.0 {
            Some(format!(
                "the frame is black: the camera sees geometry in {share:.0}% of its pixels, but no light \
                 reaches it. {fix}."
            ))
        } else if mean < NEARLY_BLACK_LUMINANCE {
            Some(format!(
                "the frame is nearly black: the camera sees geometry in {share:.0}% of its pixels, and \
                 their mean luminance is {mean:.2e}. {fix}."
            ))
        } else {
            None
        }
    }

    /// A black, transparent image with the given AOVs (background depth).
    pub fn new(width: u32, height: u32, aovs: Aovs) -> Image {
        let n = width as usize * height as usize;
        Image {
            width,
            height,
            rgba: vec![[0.0; 4]; n],
            depth: aovs.depth.then(|| vec![BACKGROUND_DEPTH; n]),
            normal: aovs.normal.then(|| vec![[0.0; 3]; n]),
            albedo: aovs.albedo.then(|| vec![[0.0; 3]; n]),
            sample_count: aovs.sample_count.then(|| vec![0.0; n]),
            noise: aovs.noise.then(|| vec![0.0; n]),
            rays: aovs.rays.then(|| vec![0.0; n]),
            motion: aovs.motion.then(|| vec![[0.0; 4]; n]),
            position: aovs.position.then(|| vec![[0.0; 3]; n]),
            uv: aovs.uv.then(|| vec![[0.0; 2]; n]),
            object_id: aovs.object_id.then(|| vec![0.0; n]),
            mattes: Vec::new(),
            light: light::black(aovs, n, LightPasses::default()),
            shadow: None,
        }
    }

    /// Which AOVs the image carries.
    pub fn aovs(&self) -> Aovs {
        Aovs {
            depth: self.depth.is_some(),
            normal: self.normal.is_some(),
            albedo: self.albedo.is_some(),
            sample_count: self.sample_count.is_some(),
            noise: self.noise.is_some(),
            rays: self.rays.is_some(),
            motion: self.motion.is_some(),
            position: self.position.is_some(),
            uv: self.uv.is_some(),
            object_id: self.object_id.is_some(),
            diffuse: self.has_light_pass("DiffDir"),
            glossy: self.has_light_pass("GlossDir"),
            transmission: self.has_light_pass("TransDir"),
            emission: self.has_light_pass("Emit"),
            environment: self.has_light_pass("Env"),
        }
    }

    fn has_light_pass(&self, name: &str) -> bool {
        self.light.names().any(|n| n == name)
    }
}

/// The estimated relative error of a pixel's mean from its sums
/// (`pt_noise_estimate` in kernels/trace/pathtrace.cl, the same float
/// operations): `color` the sum of all samples, `snapshots` the running
/// sums at the last two powers of two (S(2^j) in `snapshots[j % 2]`),
/// `aux` (.., .., dropped samples, samples taken t). The mean A of the
/// first a = 2^j samples (the largest power of two at most t / 2) against
/// the mean B of the other b = t - a: (A - B)^2 a b / t^2 estimates the
/// variance of the mean of all t. Cycles' half buffer (Dammertz et al.
/// 2010) compares even with odd samples instead; both are unbiased for
/// independent samples, but the sampler's first 2^j samples are a
/// stratified set of their own (an aligned block of Owen-scrambled Sobol
/// points), so this split sees the error the stratified mean has where
/// even against odd sees that of independent samples (2.6-3.6x the
/// measured relative MSE at 64 spp on the shipped animation and the clay
/// scan, against 1.1-1.3x). Taken relative to the pixel as the relative
/// MSE is (RMS over the channels over sqrt(I^2 + 0.01)). Infinite below
/// two kept samples.
pub fn noise_estimate(color: [f32; 4], snapshots: [[f32; 4]; 2], aux: [f32; 4]) -> f32 {
    let n = aux[3] - aux[2];
    let t = aux[3] as u32;
    // Also true for NaN, as in the kernel.
    #[allow(clippy::neg_cmp_op_on_partial_ord)]
    if !(n >= 2.0) || t < 2 {
        return f32::INFINITY;
    }
    let j = 30 - t.leading_zeros();
    let first = snapshots[(j & 1) as usize];
    let a = (1u32 << j) as f32;
    let b = t as f32 - a;
    let mean = [color[0] / n, color[1] / n, color[2] / n];
    let d = [0, 1, 2].map(|c| first[c] / a - (color[c] - first[c]) / b);
    let w = (a * b) / (t as f32 * t as f32);
    let num = (((d[0] * d[0] + d[1] * d[1]) + d[2] * d[2]) * w) / 3.0;
    let den = ((mean[0] * mean[0] + mean[1] * mean[1]) + mean[2] * mean[2]) / 3.0 + 0.01;
    (num / den).sqrt()
}

/// Written frames' images, handed back by the writer so that a later
/// frame's resolve (`resolve`) fills their buffers instead of fresh ones: a
/// frame's buffers are tens of megabytes (80 MB at 640x360 with every
/// pass), and fresh ones cost a page fault and a zeroed page per 4 KiB on
/// first touch. Only images already written come back, so a job holds no more
/// images at once than it would without.
pub struct SpareImages(std::sync::mpsc::Receiver<Image>);

impl SpareImages {
    /// The writer's end (send each image once its files are written) and
    /// the renderer's.
    pub fn channel() -> (std::sync::mpsc::Sender<Image>, SpareImages) {
        let (send, receive) = std::sync::mpsc::channel();
        (send, SpareImages(receive))
    }

    /// The latest image handed back, if any; older ones are freed.
    pub fn take(&self) -> Option<Image> {
        self.0.try_iter().last()
    }
}

/// `n` copies of `value`, in `spare`'s memory when it has the room.
pub(crate) fn refill<T: Clone>(spare: Option<Vec<T>>, n: usize, value: T) -> Vec<T> {
    let mut v = spare.unwrap_or_default();
    v.clear();
    v.resize(n, value);
    v
}

/// A frame's accumulators as the path tracer leaves them, per pixel: the
/// sums of colour (RGB and alpha), normal and albedo (empty when their AOVs
/// are off), the two noise snapshots (`noise_estimate`), `aux` (depth sum,
/// depth weight, dropped samples, samples taken) and the rays traced.
#[derive(Clone, Debug, Default)]
pub struct Accumulated {
    pub color: Vec<[f32; 4]>,
    pub normal: Vec<[f32; 4]>,
    pub albedo: Vec<[f32; 4]>,
    pub snapshots: Vec<[f32; 4]>,
    pub aux: Vec<[f32; 4]>,
    pub rays: Vec<u32>,
    /// With `--aov motion`: per pixel, the sum of the motion vectors of
    /// the samples that hit (empty otherwise).
    pub motion: Vec<[f32; 4]>,
    /// With `--aov position` or `uv`: per pixel two sums over the samples
    /// that hit, the position (xyz) and TEXCOORD_0 (xy); empty otherwise.
    pub geometry: Vec<[f32; 4]>,
    /// With shadow catchers: per pixel three sums over the samples whose
    /// camera ray met one: the light it received (RGB) and their count,
    /// the light it would have received unshadowed, and the radiance and
    /// alpha seen through it; empty otherwise.
    pub catcher: Vec<[f32; 4]>,
    /// With `--cryptomatte`: per pixel, its slots of (matte pair + 1,
    /// samples that first hit it); empty otherwise.
    pub matte_slots: Vec<[u32; 2]>,
    /// With light-path passes: per pixel 3 * LIGHT_PASSES sums
    /// (`light::resolve_pixel`); empty otherwise.
    pub light: Vec<f32>,
}

/// A resolved frame: the image with its AOVs, and per pixel the samples it
/// took and its estimated error.
#[derive(Clone, Debug)]
pub struct Resolved {
    pub image: Image,
    pub counts: Vec<u32>,
    pub estimates: Vec<f32>,
    /// Samples dropped for NaN or infinite values, of `taken`.
    pub dropped: u64,
    pub taken: u64,
}

/// Each pixel's mean over its kept samples (a box over the pixel's own
/// samples: the reconstruction filter is applied where samples are drawn,
/// by importance), its AOVs, its noise estimate, and with the scene's
/// matte names (`table`) its object ids and the `cryptomatte` layers; in
/// the buffers of `spare` (a written frame's image, `SpareImages`) where
/// it has them.
///
/// Each output is written in one pass over the pixels, straight into its
/// buffer, with the pixels split among the threads (the device is idle
/// meanwhile): one loop over the pixels that stored into every output at
/// once (30 streams with every pass on) took several times as long
/// (BENCHMARKS.md, "Choices measured").
pub fn resolve(
    acc: &Accumulated,
    width: u32,
    height: u32,
    aovs: Aovs,
    cryptomatte: Option<&Cryptomatte>,
    table: Option<&MatteTable>,
    spare: Option<Image>,
) -> Resolved {
    let pixels = width as usize * height as usize;
    let mut spare = spare.unwrap_or_else(|| Image::new(0, 0, Aovs::NONE));
    let aux = &acc.aux[..pixels];
    // Samples taken, and kept: less those dropped.
    let (counts, kept): (Vec<u32>, Vec<u32>) = aux
        .par_iter()
        .map(|a| (a[3] as u32, (a[3] as u32).saturating_sub(a[2] as u32)))
        .unzip();
    let estimates: Vec<f32> = (0..pixels)
        .into_par_iter()
        .map(|i| {
            let snapshots = [acc.snapshots[2 * i], acc.snapshots[2 * i + 1]];
            noise_estimate(acc.color[i], snapshots, aux[i])
        })
        .collect();
    let dropped = aux.iter().map(|a| a[2] as u32 as u64).sum();
    let taken = counts.iter().map(|&c| c as u64).sum();
    let spare_light = std::mem::take(&mut spare.light);
    let spare_mattes = std::mem::take(&mut spare.mattes);
    let mut image = resolve_image(
        acc,
        width,
        height,
        aovs,
        spare,
        (&counts, &kept, &estimates),
    );
    image.light = if acc.light.is_empty() {
        light::black(aovs, pixels, spare_light)
    } else {
        light::resolve(aovs, &acc.light, &kept, spare_light)
    };
    if let (Some(c), Some(table)) = (cryptomatte, table) {
        image.mattes = cryptomatte::resolve_mattes(&acc.matte_slots, &kept, table, c, spare_mattes);
    }
    if let (Some(ids), Some(table)) = (&mut image.object_id, table) {
        let slots = acc.matte_slots.len() / pixels.max(1);
        cryptomatte::resolve_object_ids(&acc.matte_slots, slots, table, ids);
    }
    Resolved {
        image,
        counts,
        estimates,
        dropped,
        taken,
    }
}

/// `resolve`'s image but for the light passes, from the pixels' sample
/// counts, kept samples and noise estimates.
fn resolve_image(
    acc: &Accumulated,
    width: u32,
    height: u32,
    aovs: Aovs,
    mut s: Image,
    (counts, kept, estimates): (&[u32], &[u32], &[f32]),
) -> Image {
    let pixels = width as usize * height as usize;
    let aux = &acc.aux[..pixels];
    // The mean's weight, 1 / kept, where a pixel kept samples; a pixel
    // that kept none keeps each output's default.
    let inv = |i: usize| 1.0 / kept[i] as f32;
    // Averaged over the samples that hit, as depth is.
    let hit = |i: usize| kept[i] > 0 && aux[i][1] > 0.0;
    let mut rgba = fill(Some(std::mem::take(&mut s.rgba)), pixels, |i| {
        if kept[i] == 0 {
            return [0.0; 4];
        }
        let (c, w) = (acc.color[i], inv(i));
        [c[0] * w, c[1] * w, c[2] * w, c[3] * w]
    });
    let mean3 = |sums: &[[f32; 4]], spare: Option<Vec<[f32; 3]>>| {
        fill(spare, pixels, |i| {
            if kept[i] == 0 {
                return [0.0; 3];
            }
            let (c, w) = (sums[i], inv(i));
            [c[0] * w, c[1] * w, c[2] * w]
        })
    };
    let normal = aovs.normal.then(|| mean3(&acc.normal, s.normal.take()));
    let albedo = aovs.albedo.then(|| mean3(&acc.albedo, s.albedo.take()));
    let position = aovs.position.then(|| {
        fill(s.position.take(), pixels, |i| {
            if !hit(i) {
                return [0.0; 3];
            }
            let (p, w) = (acc.geometry[2 * i], 1.0 / aux[i][1]);
            [p[0] * w, p[1] * w, p[2] * w]
        })
    });
    let uv = aovs.uv.then(|| {
        fill(s.uv.take(), pixels, |i| {
            if !hit(i) {
                return [0.0; 2];
            }
            let (t, w) = (acc.geometry[2 * i + 1], 1.0 / aux[i][1]);
            [t[0] * w, t[1] * w]
        })
    });
    let motion = aovs.motion.then(|| {
        fill(s.motion.take(), pixels, |i| {
            if !hit(i) {
                return [0.0; 4];
            }
            let (m, hits) = (acc.motion[i], aux[i][1]);
            [m[0] / hits, m[1] / hits, m[2] / hits, m[3] / hits]
        })
    });
    let depth = aovs.depth.then(|| {
        fill(s.depth.take(), pixels, |i| {
            if hit(i) {
                aux[i][0] / aux[i][1]
            } else {
                BACKGROUND_DEPTH
            }
        })
    });
    let sample_count = aovs
        .sample_count
        .then(|| fill(s.sample_count.take(), pixels, |i| counts[i] as f32));
    let noise = aovs
        .noise
        .then(|| fill(s.noise.take(), pixels, |i| estimates[i]));
    let rays = aovs
        .rays
        .then(|| fill(s.rays.take(), pixels, |i| acc.rays[i] as f32));
    // Filled from the mattes' slots after (`resolve`).
    let object_id = aovs
        .object_id
        .then(|| refill(s.object_id.take(), pixels, 0.0));
    let mut shadow = None;
    if !acc.catcher.is_empty() {
        for i in (0..pixels).filter(|&i| kept[i] > 0) {
            let sums = [
                acc.catcher[3 * i],
                acc.catcher[3 * i + 1],
                acc.catcher[3 * i + 2],
            ];
            // Only a frame with a pixel that kept a sample has the pass.
            let shadow = shadow.get_or_insert_with(|| refill(s.shadow.take(), pixels, [1.0; 3]));
            if let Some((factor, add)) = catcher_shadow(sums, kept[i]) {
                shadow[i] = factor;
                for k in 0..4 {
                    rgba[i][k] += add[k];
                }
            }
        }
    }
    Image {
        width,
        height,
        rgba,
        depth,
        normal,
        albedo,
        sample_count,
        noise,
        rays,
        motion,
        position,
        uv,
        object_id,
        mattes: Vec::new(),
        light: LightPasses::default(),
        shadow,
    }
}

/// `value(i)` for each of the `n` pixels, in `spare`'s memory when it has
/// the room (written once: `refill` then a store per pixel writes twice),
/// the pixels split among the threads.
fn fill<T: Send>(
    spare: Option<Vec<T>>,
    n: usize,
    value: impl Fn(usize) -> T + Sync + Send,
) -> Vec<T> {
    let mut v = spare.unwrap_or_default();
    v.clear();
    v.par_extend((0..n).into_par_iter().map(value));
    v
}

/// A pixel's shadow-catcher sums (`Accumulated::catcher`) over its `kept`
/// samples as the shadow factor, the light over the unshadowed light per
/// channel (the ratio of the sums, so where nothing shadows it is exactly
/// one), and what the catcher adds to the pixel: the shadow's opacity to
/// alpha, over the share of samples that saw the environment through the
/// catcher, and the radiance seen through it darkened by the shadow.
/// `None` where no sample met a catcher.
fn catcher_shadow(sums: [[f32; 4]; 3], kept: u32) -> Option<([f32; 3], [f32; 4])> {
    let [lit, unshadowed, behind] = sums;
    let count = lit[3];
    if count <= 0.0 || count.is_nan() || kept == 0 {
        return None;
    }
    let factor = [0, 1, 2].map(|c| {
        if unshadowed[c] > 0.0 {
            (lit[c] / unshadowed[c]).clamp(0.0, 1.0)
        } else {
            1.0
        }
    });
    let density = 1.0 - (factor[0] + factor[1] + factor[2]) / 3.0;
    let inv = 1.0 / kept as f32;
    // Samples that saw the environment through the catcher (alpha 0 there)
    // take the shadow's opacity.
    let clear = (count - behind[3]).max(0.0) * inv;
    let rgba = [
        -behind[0] * inv * (1.0 - factor[0]),
        -behind[1] * inv * (1.0 - factor[1]),
        -behind[2] * inv * (1.0 - factor[2]),
        clear * density,
    ];
    Some((factor, rgba))
}

/// The error below which a pixel stops sampling (`pt_stop_threshold` in
/// kernels/trace/pathtrace.cl, the same float operations). With `inv_work_ref`
/// 0 (equal-error allocation) it is `threshold` for every pixel; otherwise
/// (time allocation) `threshold * sqrt(work / work_ref)`, `work` the rays
/// the pixel has traced and `work_ref` the frame's mean rays per pixel at
/// the first check. Stopping once e^2 / work < threshold^2 / work_ref
/// stops a pixel where one more unit of work buys less squared error than
/// the same unit elsewhere would: the frame's least squared error for its
/// work, with samples in proportion to a pixel's spread over the square
/// root of its cost per sample (equal error gives them in proportion to
/// the variance, the same squared error as uniform sampling for the same
/// samples on the pixels that have any).
pub fn stop_threshold(threshold: f32, work: u32, inv_work_ref: f32) -> f32 {
    if inv_work_ref == 0.0 {
        return threshold;
    }
    threshold * (work as f32 * inv_work_ref).sqrt()
}

/// How close a frame came to its noise target, for the frame log's `noise`
/// object.
#[derive(Debug, Clone, PartialEq, Default, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct NoiseStats {
    /// `--noise-threshold`, or `null` for a uniform render.
    pub target: Option<f32>,
    /// Mean and 99th percentile over the pixels of the estimated relative
    /// error (`noise_estimate`) of the finished frame. Their squares are
    /// comparable with a relative MSE against a converged reference.
    pub estimated_mean: f64,
    pub estimated_p99: f64,
    /// Fraction of the pixels whose estimate is below their stop threshold
    /// (`stop_threshold`: the target itself with `allocation` `error`)
    /// (`null` without a target).
    pub converged_fraction: Option<f64>,
    /// With a target: how samples were shared (`error`: every pixel to the
    /// target; `time`: the least squared error for the work, see
    /// `stop_threshold`); `null` without one.
    pub allocation: Option<String>,
    /// With `allocation` `time`: the frame's mean rays per pixel at the
    /// first convergence check (`work_ref` of `stop_threshold`).
    pub work_reference: Option<f64>,
    /// Samples taken per pixel.
    pub spp_min: u32,
    pub spp_mean: f64,
    pub spp_max: u32,
    /// Why sampling stopped: `threshold` (every pixel converged), `max_spp`
    /// (some pixels reached `--spp` unconverged, or a uniform render took
    /// its `--spp`), or `time_limit` (`--time-limit`; not reproducible).
    pub stopped: String,
}

impl NoiseStats {
    /// From each pixel's estimate and sample count; a pixel has converged
    /// when its estimate is below `target`.
    pub fn new(target: Option<f32>, estimates: &[f32], counts: &[u32], stopped: &str) -> Self {
        let thresholds = target.map(|t| vec![t; estimates.len()]);
        let mut stats =
            Self::with_thresholds(target, thresholds.as_deref(), estimates, counts, stopped);
        stats.allocation = target.map(|_| "error".to_owned());
        stats
    }

    /// As `new`, a pixel converged when its estimate is below its own
    /// stop threshold (`stop_threshold`). `allocation` and
    /// `work_reference` are left for the caller.
    pub fn with_thresholds(
        target: Option<f32>,
        thresholds: Option<&[f32]>,
        estimates: &[f32],
        counts: &[u32],
        stopped: &str,
    ) -> Self {
        let mut finite: Vec<f32> = estimates
            .iter()
            .copied()
            .filter(|e| e.is_finite())
            .collect();
        finite.sort_by(f32::total_cmp);
        let mean = if finite.is_empty() {
            0.0
        } else {
            finite.iter().map(|&e| e as f64).sum::<f64>() / finite.len() as f64
        };
        let p99 = finite
            .get(((finite.len() as f64 * 0.99).ceil() as usize).saturating_sub(1))
            .map_or(0.0, |&e| e as f64);
        let n = counts.len().max(1) as f64;
        NoiseStats {
            target,
            estimated_mean: mean,
            estimated_p99: p99,
            converged_fraction: thresholds.map(|t| {
                estimates.iter().zip(t).filter(|(e, t)| e < t).count() as f64
                    / estimates.len().max(1) as f64
            }),
            allocation: None,
            work_reference: None,
            spp_min: counts.iter().copied().min().unwrap_or(0),
            spp_mean: counts.iter().map(|&c| c as f64).sum::<f64>() / n,
            spp_max: counts.iter().copied().max().unwrap_or(0),
            stopped: stopped.to_owned(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_frame_that_sees_geometry_but_no_light_is_named_black() {
        let mut img = Image::new(4, 2, Aovs::NONE);
        // Nothing covered: an empty view is not a dark frame.
        img.rgba.fill([0.0; 4]);
        assert_eq!(img.darkness_warning(), None);
        // Half the pixels see geometry, all black.
        for p in &mut img.rgba[..4] {
            *p = [0.0, 0.0, 0.0, 1.0];
        }
        let w = img.darkness_warning().unwrap();
        assert!(
            w.contains("the frame is black") && w.contains("50%") && w.contains("Fix:"),
            "{w}"
        );
        // Nearly black: a faint glow on one covered pixel.
        img.rgba[0] = [1e-4, 1e-4, 1e-4, 1.0];
        let w = img.darkness_warning().unwrap();
        assert!(w.contains("nearly black") && w.contains("2.50e-5"), "{w}");
        // Lit: no warning, whatever the background does.
        img.rgba[1] = [0.2, 0.1, 0.05, 1.0];
        assert_eq!(img.darkness_warning(), None);
    }

    #[test]
    fn filter_sampler_follows_the_filter() {
        for filter in [
            Filter::Box,
            Filter::default(),
            Filter::Gaussian {
                radius: 1.5,
                sigma: 0.5,
            },
        ] {
            let s = filter.sampler();
            let r = filter.radius();
            assert_eq!(s.sample([0.0, 1.0]), [-r, r]);
            assert_eq!(s.sample([0.5, 0.5]), [0.0, 0.0]);
            assert!(s.table().windows(2).all(|w| w[0] <= w[1]), "monotonic");
            // Histogram of 1-D samples against the normalised filter.
            const BINS: usize = 12;
            let n = 200_000;
            let mut hist = [0f64; BINS];
            for k in 0..n {
                let x = s.sample([(k as f32 + 0.5) / n as f32, 0.5])[0];
                let b = (((x + r) / (2.0 * r)) * BINS as f32) as usize;
                hist[b.min(BINS - 1)] += 1.0 / n as f64;
            }
            let fine = 4000;
            let mut expect = [0f64; BINS];
            let mut total = 0.0;
            for k in 0..fine {
                let x = -r + (k as f32 + 0.5) * 2.0 * r / fine as f32;
                let p = filter.eval_1d(x) as f64;
                expect[(k * BINS / fine).min(BINS - 1)] += p;
                total += p;
            }
            for b in 0..BINS {
                let e = expect[b] / total;
                assert!(
                    (hist[b] - e).abs() < 2e-3,
                    "{filter:?} bin {b}: {} vs {e}",
                    hist[b]
                );
            }
        }
    }

    #[test]
    fn blackman_harris_shape() {
        let f = Filter::default();
        assert_eq!(f.eval_1d(0.0), 1.0);
        assert!(f.eval_1d(1.5) < 1e-4 && f.eval_1d(1.6) == 0.0);
        assert_eq!(f.eval_1d(0.7), f.eval_1d(-0.7));
        assert!(f.check().is_ok());
        assert!(Filter::BlackmanHarris { radius: 0.0 }.check().is_err());
        // Its standard deviation, documented above as about 0.42 px.
        let (mut m2, mut m0) = (0.0f64, 0.0f64);
        for k in 0..3000 {
            let x = -1.5 + (k as f64 + 0.5) * 3.0 / 3000.0;
            let p = f.eval_1d(x as f32) as f64;
            m0 += p;
            m2 += p * x * x;
        }
        let sd = (m2 / m0).sqrt();
        assert!((sd - 0.415).abs() < 0.005, "sd {sd}");
    }

    #[test]
    fn noise_estimate_splits_at_the_largest_power_of_two_in_the_first_half() {
        // Six grey samples: the first a = 2 (snapshot 1, S(2)) against the
        // other b = 4, and the variance of the mean (A - B)^2 a b / t^2.
        let x = [0.5f32, 0.7, 0.2, 0.4, 0.9, 0.3];
        let sum: f32 = x.iter().sum();
        let s2 = x[0] + x[1];
        let color = [sum, sum, sum, 6.0];
        // Snapshot 0 holds S(4) (the later power of two): not the split.
        let s4 = s2 + x[2] + x[3];
        let snapshots = [[s4, s4, s4, 4.0], [s2, s2, s2, 2.0]];
        let e = noise_estimate(color, snapshots, [0.0, 0.0, 0.0, 6.0]);
        let (a, b) = (s2 as f64 / 2.0, (sum - s2) as f64 / 4.0);
        let var = (a - b).powi(2) * 8.0 / 36.0;
        let mean = sum as f64 / 6.0;
        let want = (var / (mean * mean + 0.01)).sqrt();
        assert!((e as f64 - want).abs() < 1e-6 * want, "{e} vs {want}");
        // At t = 8 the split is 4 + 4, snapshot 0; below two samples none.
        let e8 = noise_estimate([sum + 1.0; 4], snapshots, [0.0, 0.0, 0.0, 8.0]);
        let (a, b) = (s4 as f64 / 4.0, (sum + 1.0 - s4) as f64 / 4.0);
        let mean = (sum + 1.0) as f64 / 8.0;
        let want = ((a - b).powi(2) / 4.0 / (mean * mean + 0.01)).sqrt();
        assert!((e8 as f64 - want).abs() < 1e-6 * want, "{e8} vs {want}");
        assert!(noise_estimate(color, snapshots, [0.0, 0.0, 0.0, 1.0]).is_infinite());
        assert!(noise_estimate(color, snapshots, [0.0, 0.0, 5.0, 6.0]).is_infinite());
    }

    #[test]
    fn resolve_takes_the_mean_of_the_kept_samples() {
        // Pixel 0: 4 samples, 1 dropped, 3 kept, hit at depths summing to
        // 6 over weight 2. Pixel 1: every sample dropped.
        let acc = Accumulated {
            color: vec![[3.0, 6.0, 1.5, 3.0], [0.0; 4]],
            normal: vec![[0.0, 3.0, 0.0, 0.0], [0.0; 4]],
            albedo: vec![[1.5, 1.5, 1.5, 0.0], [0.0; 4]],
            snapshots: vec![[0.0; 4]; 4],
            aux: vec![[6.0, 2.0, 1.0, 4.0], [0.0, 0.0, 2.0, 2.0]],
            rays: vec![9, 4],
            ..Accumulated::default()
        };
        let every = Aovs::parse("depth,normal,albedo,sample_count,noise,rays").unwrap();
        let r = resolve(&acc, 2, 1, every, None, None, None);
        assert_eq!(r.image.rgba[0], [1.0, 2.0, 0.5, 1.0]);
        assert_eq!(r.image.normal.as_ref().unwrap()[0], [0.0, 1.0, 0.0]);
        assert_eq!(r.image.albedo.as_ref().unwrap()[0], [0.5, 0.5, 0.5]);
        assert_eq!(r.image.depth.as_ref().unwrap()[0], 3.0);
        assert_eq!(r.image.rgba[1], [0.0; 4]);
        assert_eq!(r.image.depth.as_ref().unwrap()[1], BACKGROUND_DEPTH);
        assert_eq!(r.image.sample_count.as_ref().unwrap()[..], [4.0, 2.0]);
        assert_eq!(r.image.rays.as_ref().unwrap()[..], [9.0, 4.0]);
        assert_eq!((r.dropped, r.taken), (3, 6));
        assert_eq!(r.counts, [4, 2]);
        // Fewer than two kept samples: no estimate.
        assert!(r.estimates[1].is_infinite());
    }

    /// Sums for `pixels` pixels from a seed, with pixels that kept no
    /// sample, that dropped some and that no sample hit.
    fn random_sums(pixels: usize, seed: u32) -> Accumulated {
        let mut state = seed.wrapping_mul(747_796_405).wrapping_add(1);
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            (state >> 8) as f32 / (1u32 << 24) as f32
        };
        let mut quad = |k: usize| -> Vec<[f32; 4]> {
            (0..k).map(|_| [next(), next(), next(), next()]).collect()
        };
        let color = quad(pixels);
        let (normal, albedo, snapshots) = (quad(pixels), quad(pixels), quad(2 * pixels));
        let (motion, geometry, catcher) = (quad(pixels), quad(2 * pixels), quad(3 * pixels));
        let aux = (0..pixels)
            .map(|i| match i % 4 {
                0 => [0.0, 0.0, 3.0, 3.0], // every sample dropped
                1 => [2.0, 0.0, 0.0, 8.0], // no sample hit
                2 => [5.0, 4.0, 1.0, 8.0], // one dropped
                _ => [9.0, 8.0, 0.0, 8.0],
            })
            .collect();
        let light = (0..3 * light::LIGHT_PASSES as usize * pixels)
            .map(|k| {
                if k % 7 == 0 {
                    0.0
                } else {
                    (k % 13) as f32 * 0.25
                }
            })
            .collect();
        Accumulated {
            color,
            normal,
            albedo,
            snapshots,
            aux,
            rays: (0..pixels as u32).collect(),
            motion,
            geometry,
            catcher,
            matte_slots: Vec::new(),
            light,
        }
    }

    #[test]
    fn resolve_writes_every_output_per_pixel_whatever_buffers_it_reuses() {
        let (w, h) = (37, 5);
        let every = Aovs::parse("depth,normal,albedo,sample_count,noise,rays,motion,position,uv")
            .unwrap()
            .with_light_passes("light")
            .unwrap();
        let acc = random_sums((w * h) as usize, 1);
        let fresh = resolve(&acc, w, h, every, None, None, None);
        // A larger frame's buffers, another frame's, and a frame with no
        // AOV's, reused.
        for (sw, sh, aovs) in [(64, 9, every), (w, h, every), (w, h, Aovs::NONE)] {
            let spare = resolve(
                &random_sums((sw * sh) as usize, 2),
                sw,
                sh,
                aovs,
                None,
                None,
                None,
            );
            let reused = resolve(&acc, w, h, every, None, None, Some(spare.image));
            assert_eq!(
                reused.image, fresh.image,
                "reusing a {sw}x{sh} frame's buffers"
            );
        }
        let image = &fresh.image;
        let per = 3 * light::LIGHT_PASSES as usize;
        // Samples taken less those dropped.
        let kept_at = |i: usize| (acc.aux[i][3] - acc.aux[i][2]) as u32;
        for i in 0..(w * h) as usize {
            let kept = kept_at(i);
            let hits = acc.aux[i][1];
            assert_eq!(
                image.light.pixels[i],
                light::resolve_pixel(&acc.light[per * i..per * (i + 1)], kept)
            );
            let position = image.position.as_ref().unwrap()[i];
            let motion = image.motion.as_ref().unwrap()[i];
            if kept == 0 || hits == 0.0 {
                assert_eq!(position, [0.0; 3], "pixel {i}");
                assert_eq!(motion, [0.0; 4], "pixel {i}");
                assert_eq!(image.depth.as_ref().unwrap()[i], BACKGROUND_DEPTH);
            } else {
                let (p, inv) = (acc.geometry[2 * i], 1.0 / hits);
                assert_eq!(position, [p[0] * inv, p[1] * inv, p[2] * inv]);
                assert_eq!(motion, acc.motion[i].map(|v| v / hits));
            }
            if kept == 0 {
                assert_eq!(image.rgba[i], [0.0; 4]);
            }
        }
        // The catcher's sums make a shadow pass, 1 where no sample was kept.
        let shadow = image.shadow.as_ref().unwrap();
        assert!((0..(w * h) as usize).all(|i| kept_at(i) > 0 || shadow[i] == [1.0; 3]));
    }

    #[test]
    fn aov_flags() {
        assert_eq!(Aovs::parse("depth,normal,albedo").unwrap(), Aovs::ALL);
        assert_eq!(Aovs::parse("").unwrap(), Aovs::NONE);
        let a = Aovs::parse(" albedo ").unwrap();
        assert_eq!(a.names(), vec!["albedo"]);
        let a = Aovs::parse("rays,noise,sample_count").unwrap();
        assert_eq!(a.names(), vec!["sample_count", "noise", "rays"]);
        let a = Aovs::parse("object_id,uv,motion,position").unwrap();
        assert_eq!(a.names(), vec!["motion", "position", "uv", "object_id"]);
        let e = Aovs::parse("depth,uvw").unwrap_err().0;
        assert!(
            e.contains("\"uvw\"") && e.contains("depth, normal, albedo"),
            "{e}"
        );
    }
}
