//! What a frame is rendered with: the user's choices (`RenderSettings`:
//! size, samples, depth, traversal, environment, adaptive sampling) and how
//! its work is cut into launches (`Schedule`), which never changes the image.

use std::path::PathBuf;

use super::lens::Lens;
use super::sampling::{NoisePattern, Sampler};
use crate::film::{Aovs, Cryptomatte};
use crate::scene::compositing::RoleOverrides;

/// Which traversal the integrator compiles in. All three find the same
/// hits and the same occlusion, so they make the same image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Traversal {
    /// Front-to-back stack traversal of the builder's binary tree as it is;
    /// shadow rays use any-hit traversal.
    Stack,
    /// Escape-index traversal for every ray (no stack).
    Stackless,
    /// Front-to-back stack traversal of the tree collapsed into 4-wide
    /// nodes (`trace::wide`), closest and any hit: four boxes per node
    /// fetch, half as many steps as the binary tree.
    Wide,
    /// The default: as `Wide`, with 8-wide nodes, whose box test fills a
    /// 256-bit register: a third as many steps as the binary tree, and the
    /// fastest of the four on CPUs (BENCHMARKS.md).
    #[default]
    Wide8,
}

impl Traversal {
    /// The `--traversal` value that selects it.
    pub fn name(self) -> &'static str {
        match self {
            Traversal::Stack => "stack",
            Traversal::Stackless => "stackless",
            Traversal::Wide => "wide",
            Traversal::Wide8 => "wide8",
        }
    }
}

/// Which lights next-event estimation picks through the light tree
/// (`trace::light_tree`) rather than in proportion to their power alone
/// (`--light-tree`, `--no-light-tree`). Both choices give the same image on
/// average; they differ in noise and in the cost of a sample.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LightTreeUse {
    /// The default: the point and spot lights past the looped ones always,
    /// and the emissive triangles when they spread over at least
    /// `EMITTER_SPREAD_MIN` of the scene's extent. Emitters gathered in
    /// one small object (a lamp, a textured helmet) differ little in
    /// position and orientation as seen from the rest of the scene, so the
    /// tree's walk, 14 levels for 14K triangles, costs more than its
    /// choices save (BENCHMARKS.md, "Many lights and a textured emitter").
    #[default]
    Auto,
    /// Every light and emitter, wherever they are.
    Always,
    /// None: every light by its power.
    Never,
}

/// The least extent of the emissive triangles' bounds, as a fraction of the
/// scene's (their diagonals), for which `LightTreeUse::Auto` puts them in
/// the light tree.
pub const EMITTER_SPREAD_MIN: f32 = 0.25;

/// How the dielectric's base (diffuse, diffuse and thin-walled
/// transmission) lies under its specular layer, and the base under the
/// sheen (`--layering`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Layering {
    /// The default: the base is scaled by what the layer above it does not
    /// reflect, its tabulated directional albedo (`trace::energy`,
    /// `ENERGY_LAYERING`), so a white dielectric returns all it receives.
    #[default]
    Energy,
    /// The glTF specification's `fresnel_mix` (1 - F(v.h) per pair of
    /// directions) and the sheen extension's two-sided scaling, literally:
    /// for comparisons with other glTF renderers.
    Spec,
}

impl Layering {
    /// The `--layering` value that selects it.
    pub fn name(self) -> &'static str {
        match self {
            Layering::Energy => "energy",
            Layering::Spec => "spec",
        }
    }
}

impl std::str::FromStr for Layering {
    type Err = ();
    fn from_str(s: &str) -> Result<Layering, ()> {
        match s {
            "energy" => Ok(Layering::Energy),
            "spec" => Ok(Layering::Spec),
            _ => Err(()),
        }
    }
}

/// Where light comes from when rays leave the scene.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum Environment {
    /// None when the scene has KHR_lights_punctual lights of its own;
    /// otherwise the studio sky (`EnvMap::studio_sky`), with a warning.
    /// A scene's emissive materials do not count: they rarely light a
    /// whole frame (a screen, a lamp's bulb, a helmet's displays).
    #[default]
    Default,
    /// `--env-color R,G,B`: constant linear radiance.
    Color([f32; 3]),
    /// `--env FILE.exr`: an equirectangular map, importance sampled.
    Map(PathBuf),
}

#[derive(Clone, Debug, PartialEq)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    pub spp: u32,
    pub seed: u64,
    /// Scattering events per path (1: direct lighting only).
    pub max_depth: u32,
    /// `--clay`: every material becomes a white Lambertian of albedo 0.8
    /// (emission, alpha cut-outs and sidedness are kept).
    pub clay: bool,
    pub traversal: Traversal,
    /// The sampler of the path tracer's random numbers (`--sampler`).
    pub sampler: Sampler,
    /// Whether the noise changes from frame to frame (`--noise-pattern`).
    pub noise_pattern: NoisePattern,
    /// Adaptive sampling (`--noise-threshold`); `None`: every pixel takes
    /// `spp` samples. With it, `spp` is the most a pixel takes.
    pub adaptive: Option<Adaptive>,
    /// Stop sampling a frame once this much wall time has passed
    /// (`--time-limit`). The only setting that makes a frame depend on
    /// more than its inputs: where it stops depends on the machine's speed.
    pub time_limit: Option<std::time::Duration>,
    pub environment: Environment,
    pub aovs: Aovs,
    /// Turquin's multiple-scattering compensation of the GGX reflection
    /// lobes (`GGX_ENERGY_COMPENSATION`; on by default, off with
    /// `--no-energy-compensation`; never compiled for `--clay`, whose
    /// materials have no GGX lobe).
    pub energy_compensation: bool,
    /// How the dielectric's base lies under its specular layer
    /// (`--layering`; `ENERGY_LAYERING` by default, never compiled for
    /// `--clay`).
    pub layering: Layering,
    /// Which lights next-event estimation picks through the light tree, by
    /// their importance at the shading point, rather than by power.
    pub light_tree: LightTreeUse,
    /// `--backface-culling`: rays pass through the back faces of
    /// single-sided materials, as the Khronos Sample Viewer's rasterizer
    /// culls them. Off by default: back faces are shaded, as Cycles does.
    pub backface_culling: bool,
    /// Depth of field (`--aperture`, `--focus-distance`); `None`: a
    /// pinhole camera, everything sharp.
    pub lens: Option<Lens>,
    /// `--transparent`: the environment seen directly by camera rays is
    /// left out (RGB and alpha 0 there, premultiplied), for compositing over
    /// a plate; it still lights the scene and shows in reflections and
    /// through glass.
    pub transparent: bool,
    /// `--cryptomatte`: the Cryptomatte layers each frame carries, or none.
    pub cryptomatte: Option<Cryptomatte>,
    /// `--shadow-catcher` and `--holdout`: nodes whose meshes the camera
    /// sees only as shadows, or as a hole (`scene::compositing`; a scene's
    /// own extras add to them).
    pub roles: RoleOverrides,
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 640,
            height: 360,
            spp: 16,
            seed: 0,
            max_depth: 8,
            clay: false,
            traversal: Traversal::Wide8,
            sampler: Sampler::Sobol,
            noise_pattern: NoisePattern::default(),
            adaptive: None,
            time_limit: None,
            environment: Environment::Default,
            aovs: Aovs::NONE,
            energy_compensation: true,
            light_tree: LightTreeUse::Auto,
            layering: Layering::Energy,
            backface_culling: false,
            lens: None,
            transparent: false,
            cryptomatte: None,
            roles: RoleOverrides::default(),
        }
    }
}

/// Adaptive sampling: each pixel stops once the estimated relative error
/// of its mean (`film::noise_estimate`) is below its stop threshold
/// (`film::stop_threshold`): `threshold` itself (`Allocation::Error`), or
/// `threshold` scaled by the square root of the work the pixel has done
/// against the frame's mean at the first check (`Allocation::Time`).
///
/// Every pixel first takes `min_spp` samples; from then on convergence
/// checks run at the counts of `check_counts` (fixed sample counts, so the
/// image depends only on the samples' values: reproducible bit for bit,
/// whatever the tiling or pass sizes). A pixel keeps sampling while it or
/// one of its eight neighbours is above the threshold.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    pub threshold: f32,
    pub min_spp: u32,
    pub allocation: Allocation,
}

/// How adaptive sampling shares samples among pixels
/// (`--adaptive-allocation`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Allocation {
    /// Every pixel to the same estimated error (Cycles' rule): samples in
    /// proportion to a pixel's variance.
    Error,
    /// The least squared error of the frame for its work: samples in
    /// proportion to a pixel's spread over the square root of its cost
    /// per sample (the rays it traces), by stopping a pixel once its error
    /// is below `threshold * sqrt(work / work_ref)`.
    #[default]
    Time,
}

impl Allocation {
    /// The name in the frame log's `noise.allocation` and on the command
    /// line.
    pub fn name(self) -> &'static str {
        match self {
            Allocation::Error => "error",
            Allocation::Time => "time",
        }
    }
}

impl std::str::FromStr for Allocation {
    type Err = String;
    fn from_str(s: &str) -> Result<Allocation, String> {
        match s {
            "error" => Ok(Allocation::Error),
            "time" => Ok(Allocation::Time),
            _ => Err(format!("unknown allocation {s:?}: use time or error")),
        }
    }
}

/// The granularity of convergence checks: a multiple of 8 keeps each
/// pixel's Sobol points whole nets of 8.
pub const ADAPTIVE_STEP: u32 = 8;

/// The sample counts at which convergence is checked, below `spp`: `min_spp`,
/// then steps of half the count so far (in multiples of `ADAPTIVE_STEP`,
/// at least one): 16, 24, 32, 48, 72, 104, 152, ... Each check costs a
/// launch over the whole image, and on PoCL a pass over mostly converged
/// pixels costs about as much as the launch itself; geometric steps keep the
/// checks to a dozen up to 1024 spp, for at most 50% more samples in a
/// pixel than it needed.
pub fn check_counts(min_spp: u32, spp: u32) -> Vec<u32> {
    let mut checks = Vec::new();
    let mut c = min_spp.max(2);
    while c < spp {
        checks.push(c);
        let step = (c / 2 / ADAPTIVE_STEP * ADAPTIVE_STEP).max(ADAPTIVE_STEP);
        c = c.saturating_add(step);
    }
    checks
}

/// How a frame's work is cut into launches. Any schedule gives the same
/// image, bit for bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Schedule {
    /// Samples per pixel per launch; 0 picks a size from the image.
    pub samples_per_pass: u32,
    /// Tile width and height in pixels; `None`: the whole image.
    pub tile: Option<(u32, u32)>,
    /// Work-items per work-group.
    pub local_size: usize,
}

impl Default for Schedule {
    fn default() -> Self {
        Schedule {
            samples_per_pass: 0,
            tile: None,
            local_size: 64,
        }
    }
}
