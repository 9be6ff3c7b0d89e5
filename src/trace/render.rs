//! The frame renderer: `PathTracer` runs `kernels/trace/pathtrace.cl` (path
//! tracing with next-event estimation and MIS, Russian roulette) over a
//! frame's device soup and BVH and returns the resolved image with its
//! AOVs, the number of rays traced and the device time.
//!
//! Made once per scene (`PathTracer::new`): the program, compiled for what
//! the scene needs (traversal kind, textures or none), the material table,
//! the textures, the environment map and the film's filter table. Per frame
//! (`render`): the tree, camera, punctual lights and — when some material
//! emits — the emissive triangles' power distribution, computed on the
//! device and turned into a CDF on the host. Buffers are reused from frame
//! to frame and only grow.
//!
//! Scheduling and determinism: the samples of a frame are split into sample
//! passes and the image into tiles; one launch runs one pass over one tile,
//! a work-item per pixel, adding that pass's samples to the pixel's sums in
//! sample order. Random numbers are keyed by (seed, frame, pixel, sample,
//! dimension). So the image is the same bit for bit on one device whatever
//! the tiles and pass sizes (`set_schedule`), and whichever frames a run
//! renders. Passes are queued ahead so the device never waits for the host;
//! `progress` is called as each pass completes.
//!
//! `render_soup` renders a host `Soup` with a material table, camera and
//! lights without a glTF file (tests, analytic scenes).

use std::path::PathBuf;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use opencl3::kernel::Kernel;
use opencl3::memory::Buffer;
use opencl3::program::Program;

use super::device::TreeLayouts;
use super::lights::{
    environment_power, punctual_power, DeviceEnv, DeviceLight, EmissiveDistribution, EnvMap,
    LightSelection, ENV_CONSTANT, ENV_MAP, ENV_NONE,
};
use super::material::{
    device_material_exts, device_materials, DeviceMaterial, DeviceMaterialExt, MAT_CULL_BACK,
    MAT_DOUBLE_SIDED,
};
use super::sampling::{NoisePattern, Sampler};
use super::texture::{Slot, TextureBinding, TextureSet};
use super::TraceError;
use crate::bvh::device_builder::DeviceBuilder;
use crate::bvh::{BuildParams, Bvh, MAX_DEPTH};
use crate::device::{Arg, Device, GrowBuffer};
use crate::device_struct::{device_consts, device_struct};
use crate::film::{self, noise_estimate, Aovs, Image, NoiseStats, BACKGROUND_DEPTH};
use crate::scene::{FrameCamera, FrameLight, MaterialTable, Projection, Scene};
use crate::soup::device::DeviceSoup;
use crate::soup::Soup;

/// Which traversal the integrator compiles in. All three find the same
/// hits and the same occlusion, so they make the same image.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Traversal {
    /// Front-to-back stack traversal of the builder's binary tree as it is;
    /// shadow rays use any-hit traversal.
    Stack,
    /// Escape-index traversal for every ray (no stack).
    Stackless,
    /// The default: front-to-back stack traversal of the tree collapsed into
    /// 4-wide nodes (`trace::wide`), closest and any hit: four boxes per
    /// node fetch, half as many steps. The fastest of the three here.
    #[default]
    Wide,
}

impl Traversal {
    /// The `--traversal` value that selects it.
    pub fn name(self) -> &'static str {
        match self {
            Traversal::Stack => "stack",
            Traversal::Stackless => "stackless",
            Traversal::Wide => "wide",
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
    /// `--backface-culling`: rays pass through the back faces of
    /// single-sided materials, as the Khronos Sample Viewer's rasterizer
    /// culls them. Off by default: back faces are shaded, as Cycles does.
    pub backface_culling: bool,
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
            traversal: Traversal::Wide,
            sampler: Sampler::Sobol,
            noise_pattern: NoisePattern::default(),
            adaptive: None,
            time_limit: None,
            environment: Environment::Default,
            aovs: Aovs::NONE,
            energy_compensation: true,
            backface_culling: false,
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

/// One frame to render: its soup and tree on the device, camera and lights.
pub struct FrameInput<'a> {
    pub frame: i64,
    pub soup: &'a DeviceSoup<'a>,
    pub bvh: &'a Bvh,
    /// The tree's primitive-index array on the device
    /// (`DeviceBuilder::device_prim_ids`).
    pub prim_ids: &'a Buffer<u32>,
    pub camera: &'a FrameCamera,
    pub lights: &'a [FrameLight],
}

/// A rendered frame.
#[derive(Clone, Debug)]
pub struct RenderOutput {
    pub image: Image,
    /// Rays traced: camera, bounce and shadow rays, and continuations
    /// through cut-out or culled surfaces.
    pub rays: u64,
    /// Rays traced per pixel, row by row (the work `film::stop_threshold`
    /// weighs a pixel's error by).
    pub pixel_rays: Vec<u32>,
    /// Device time of the frame's path tracing launches (profiling events).
    pub trace_ms: f64,
    /// The frame's estimated error and samples (the log's `noise`).
    pub noise: NoiseStats,
    pub warnings: Vec<String>,
}

impl RenderOutput {
    /// Millions of rays per second of device time.
    pub fn mrays_per_s(&self) -> f64 {
        if self.trace_ms > 0.0 {
            self.rays as f64 / (self.trace_ms * 1e3)
        } else {
            0.0
        }
    }
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

/// Paths per launch the automatic pass size aims at: enough to fill a large
/// GPU, few enough that progress is reported often.
const PATHS_PER_LAUNCH: u64 = 1 << 21;

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
    pub pad: [u32; 2],
}
}

device_struct! {
/// Per-frame constants. Next-event estimation at a path vertex samples every
/// punctual light when `light_loop` is set, then one light drawn from the
/// selection distribution (`select_cdf`, `select_count` entries in this
/// order: the punctual lights unless looped, the emissive triangles as one
/// entry when there are any, the environment when it is sampled).
/// `emit_select_pmf` and `env_select_pmf` are the probabilities of choosing
/// the emissive triangles and the environment (0 when not an entry), which
/// MIS needs when a BSDF-sampled ray hits them.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DeviceFrame as "PtFrame" {
    pub seed_lo: u32,
    pub seed_hi: u32,
    pub frame_lo: u32,
    pub frame_hi: u32,
    pub width: u32,
    pub height: u32,
    pub max_depth: u32,
    pub flags: u32,
    pub light_count: u32,
    pub emit_count: u32,
    pub material_count: u32,
    pub select_count: u32,
    /// 1: every punctual light is sampled at every vertex.
    pub light_loop: u32,
    pub emit_select_pmf: f32,
    pub env_select_pmf: f32,
    pub pad: u32,
}
}

device_consts! {
    fn frame_consts;
    /// `PtFrame.flags`: the soup carries NORMAL.
    pub const FRAME_NORMALS: u32 = 1;
    /// The soup carries TEXCOORD_0.
    pub const FRAME_UVS: u32 = 2;
    /// `--clay`: every surface is a Lambertian of albedo 0.8.
    pub const FRAME_CLAY: u32 = 4;
    /// The soup carries a second uv set.
    pub const FRAME_UVS1: u32 = 8;
    /// The soup carries COLOR_0.
    pub const FRAME_COLORS: u32 = 16;
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
        pad: [0; 2],
    }
}

/// A frame's soup on the device, whoever made it.
struct SoupBuffers<'a> {
    positions: &'a Buffer<[f32; 4]>,
    normals: Option<&'a Buffer<[f32; 4]>>,
    uvs: Option<&'a Buffer<[f32; 2]>>,
    uvs1: Option<&'a Buffer<[f32; 2]>>,
    colors: Option<&'a Buffer<[f32; 4]>>,
    material_ids: &'a Buffer<u32>,
    triangles: usize,
}

struct Kernels {
    render: Kernel,
    clear: Kernel,
    converge: Kernel,
    dilate: Kernel,
    emissive_power: Kernel,
    _program: Program,
}

impl Kernels {
    fn build(device: &Device, defines: &[(&'static str, String)]) -> Result<Kernels, TraceError> {
        let program = device.build_program("pathtrace.cl", defines)?;
        Ok(Kernels {
            render: device.kernel(&program, "pt_render")?,
            clear: device.kernel(&program, "pt_clear")?,
            converge: device.kernel(&program, "pt_converge")?,
            dilate: device.kernel(&program, "pt_dilate")?,
            emissive_power: device.kernel(&program, "pt_emissive_power")?,
            _program: program,
        })
    }
}

/// The defines `pathtrace.cl` is compiled with, assembled here and nowhere
/// else (`tests/kernels_portable.rs` compiles every combination with clang).
pub fn pathtrace_defines(
    traversal: Traversal,
    textures: bool,
    sampler: Sampler,
    transmission: bool,
    energy_compensation: bool,
    unlit: bool,
    layers: LayerDefines,
) -> Vec<(&'static str, String)> {
    let mut defines = vec![("STACK_SIZE", (MAX_DEPTH + 1).to_string())];
    match traversal {
        Traversal::Stack => {}
        Traversal::Stackless => defines.push(("TRAVERSAL_STACKLESS", "1".to_owned())),
        Traversal::Wide => defines.push(("TRAVERSAL_WIDE", "1".to_owned())),
    }
    if textures {
        defines.push(("HAS_TEXTURES", "1".to_owned()));
    }
    if let Some(define) = sampler.define() {
        defines.push((define, "1".to_owned()));
    }
    if transmission {
        defines.push(("HAS_TRANSMISSION", "1".to_owned()));
    }
    if energy_compensation {
        defines.push(("GGX_ENERGY_COMPENSATION", "1".to_owned()));
    }
    if unlit {
        defines.push(("HAS_UNLIT", "1".to_owned()));
    }
    if layers.clearcoat {
        defines.push(("HAS_CLEARCOAT", "1".to_owned()));
    }
    if layers.sheen {
        defines.push(("HAS_SHEEN", "1".to_owned()));
    }
    if layers.diffuse_transmission {
        defines.push(("HAS_DIFFUSE_TRANSMISSION", "1".to_owned()));
    }
    if layers.iridescence {
        defines.push(("HAS_IRIDESCENCE", "1".to_owned()));
    }
    if layers.anisotropy {
        defines.push(("HAS_ANISOTROPY", "1".to_owned()));
    }
    if layers.dispersion {
        defines.push(("HAS_DISPERSION", "1".to_owned()));
    }
    defines
}

/// Which lobes beyond the dielectric's a program compiles: the layers over
/// the BSDF (`HAS_CLEARCOAT`, `HAS_SHEEN`), the diffuse transmission lobe
/// under it (`HAS_DIFFUSE_TRANSMISSION`), the thin film on its Fresnel
/// (`HAS_IRIDESCENCE`), the anisotropic specular lobes (`HAS_ANISOTROPY`)
/// and the per-channel indices of dispersive volumes (`HAS_DISPERSION`),
/// the last four compiled with `HAS_TRANSMISSION`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct LayerDefines {
    pub clearcoat: bool,
    pub sheen: bool,
    pub diffuse_transmission: bool,
    pub iridescence: bool,
    pub anisotropy: bool,
    pub dispersion: bool,
}

impl LayerDefines {
    /// The lobes some material of `table` has.
    pub fn of(table: &MaterialTable) -> LayerDefines {
        LayerDefines {
            clearcoat: table.materials.iter().any(|m| m.has_clearcoat()),
            sheen: table.materials.iter().any(|m| m.has_sheen()),
            diffuse_transmission: table.materials.iter().any(|m| m.has_diffuse_transmission()),
            iridescence: table.materials.iter().any(|m| m.has_iridescence()),
            anisotropy: table.materials.iter().any(|m| m.has_anisotropy()),
            dispersion: table.materials.iter().any(|m| m.has_dispersion()),
        }
    }

    /// Whether a layer over the BSDF is compiled (diffuse transmission
    /// needs `HAS_TRANSMISSION`, which binds the extension table anyway).
    fn any(self) -> bool {
        self.clearcoat || self.sheen
    }
}

/// The defines of `pathtrace.cl`'s motion-blur variant: `base` (from
/// `pathtrace_defines`) and `MOTION_BLUR`.
pub fn motion_defines(mut base: Vec<(&'static str, String)>) -> Vec<(&'static str, String)> {
    base.push(("MOTION_BLUR", "1".to_owned()));
    base
}

/// A frame that moves within the shutter, for `PathTracer::render_motion`:
/// the soup at each motion step on the device (`trace::motion` gives the
/// layout), its tree built over `motion_bounds`, and the camera at each
/// step. Lights are those of the frame's instant.
pub struct MotionFrame<'a> {
    /// Positions at every step, `steps * 3 * triangles` corners.
    pub positions: &'a Buffer<[f32; 4]>,
    /// Shading normals at every step, when the soup has normals.
    pub normals: Option<&'a Buffer<[f32; 4]>>,
    /// Motion steps, at least 2.
    pub steps: u32,
    /// The camera at each step.
    pub cameras: &'a [FrameCamera],
    /// The punctual lights at each step (each as many as `FrameInput`'s),
    /// or empty: the frame's lights throughout.
    pub lights: &'a [Vec<FrameLight>],
}

/// The material features a table compiles into the path tracer, by define
/// name (for the frame log): only what some material uses.
pub fn material_features(
    table: &MaterialTable,
    textures: bool,
    energy_compensation: bool,
) -> Vec<&'static str> {
    let mut v = vec!["metallic_roughness"];
    if energy_compensation {
        v.push("energy_compensation");
    }
    if textures {
        v.push("textures");
    }
    if table.materials.iter().any(|m| m.needs_transmission()) {
        v.push("transmission");
    }
    if table.materials.iter().any(|m| m.unlit) {
        v.push("unlit");
    }
    let layers = LayerDefines::of(table);
    if layers.clearcoat {
        v.push("clearcoat");
    }
    if layers.sheen {
        v.push("sheen");
    }
    if layers.diffuse_transmission {
        v.push("diffuse_transmission");
    }
    if layers.iridescence {
        v.push("iridescence");
    }
    if layers.anisotropy {
        v.push("anisotropy");
    }
    if layers.dispersion {
        v.push("dispersion");
    }
    v
}

/// A motion frame's steps as `render_buffers` takes them: the count, the
/// camera at each step and the lights at each step (or none: the frame's).
type MotionSteps<'a> = (u32, &'a [FrameCamera], &'a [Vec<FrameLight>]);

/// The texture bindings of `materials` in `set`: four per material
/// (`PtMaterial`), then `Slot::EXT.len()` per material for `PtMaterialExt`
/// when compiled in (those of slots outside the set's stay -1). The
/// materials' records get their binding indices.
fn bind_textures(
    set: &TextureSet,
    materials: &[crate::scene::Material],
    host_materials: &mut [DeviceMaterial],
    host_exts: Option<&mut [DeviceMaterialExt]>,
) -> Vec<TextureBinding> {
    let n = materials.len();
    let mut bindings = Vec::with_capacity((4 + Slot::EXT.len()) * n);
    let mut bind = |m: &crate::scene::Material, slot: Slot, index: usize| {
        let b = set.slot_binding(m, slot);
        bindings.push(b);
        if b.is_none() {
            -1
        } else {
            index as i32
        }
    };
    for (i, m) in materials.iter().enumerate() {
        let dm = &mut host_materials[i];
        dm.base_color_tex = bind(m, Slot::BaseColor, 4 * i);
        dm.metallic_roughness_tex = bind(m, Slot::MetallicRoughness, 4 * i + 1);
        dm.normal_tex = bind(m, Slot::Normal, 4 * i + 2);
        dm.emissive_tex = bind(m, Slot::Emissive, 4 * i + 3);
    }
    if let Some(exts) = host_exts {
        for (i, m) in materials.iter().enumerate() {
            let x = &mut exts[i];
            let at = 4 * n + Slot::EXT.len() * i;
            x.transmission_tex = bind(m, Slot::Transmission, at);
            x.specular_tex = bind(m, Slot::Specular, at + 1);
            x.specular_color_tex = bind(m, Slot::SpecularColor, at + 2);
            x.clearcoat_tex = bind(m, Slot::Clearcoat, at + 3);
            x.clearcoat_roughness_tex = bind(m, Slot::ClearcoatRoughness, at + 4);
            x.clearcoat_normal_tex = bind(m, Slot::ClearcoatNormal, at + 5);
            x.sheen_color_tex = bind(m, Slot::SheenColor, at + 6);
            x.sheen_roughness_tex = bind(m, Slot::SheenRoughness, at + 7);
            x.diffuse_transmission_tex = bind(m, Slot::DiffuseTransmission, at + 8);
            x.diffuse_transmission_color_tex = bind(m, Slot::DiffuseTransmissionColor, at + 9);
            x.iridescence_tex = bind(m, Slot::Iridescence, at + 10);
            x.iridescence_thickness_tex = bind(m, Slot::IridescenceThickness, at + 11);
            x.anisotropy_tex = bind(m, Slot::Anisotropy, at + 12);
        }
    }
    bindings
}

/// The path tracer of one scene on one device.
pub struct PathTracer<'d> {
    device: &'d Device,
    settings: RenderSettings,
    schedule: Schedule,
    kernels: Kernels,
    materials: Buffer<DeviceMaterial>,
    material_count: u32,
    any_emissive: bool,
    textures: Option<(TextureSet<'d>, Buffer<TextureBinding>)>,
    /// The material extensions' table, when compiled in (`HAS_TRANSMISSION`,
    /// `HAS_CLEARCOAT`, `HAS_SHEEN`).
    material_exts: Option<Buffer<DeviceMaterialExt>>,
    /// The material features compiled in (`material_features`).
    features: Vec<&'static str>,
    env_map: Option<EnvBuffers>,
    filter: Buffer<f32>,
    camera: Buffer<DeviceCamera>,
    frame: Buffer<DeviceFrame>,
    env: Buffer<DeviceEnv>,
    dummy_f32: Buffer<f32>,
    dummy_u32: Buffer<u32>,
    dummy_f4: Buffer<[f32; 4]>,
    /// The frame's tree in the layout of `settings.traversal`.
    layouts: TreeLayouts,
    lights: GrowBuffer<DeviceLight>,
    power: GrowBuffer<f32>,
    power_host: Vec<f32>,
    emit_prims: GrowBuffer<u32>,
    emit_cdf: GrowBuffer<f32>,
    emit_pmf: GrowBuffer<f32>,
    select_cdf: GrowBuffer<f32>,
    accum_color: GrowBuffer<[f32; 4]>,
    accum_normal: GrowBuffer<[f32; 4]>,
    accum_albedo: GrowBuffer<[f32; 4]>,
    accum_aux: GrowBuffer<[f32; 4]>,
    ray_counts: GrowBuffer<u32>,
    /// Two per pixel: the running sums at the last two powers of two (the
    /// noise estimate's first part; `film::noise_estimate`).
    accum_snapshots: GrowBuffer<[f32; 4]>,
    /// Per pixel: 1 while it takes samples (adaptive sampling).
    active: GrowBuffer<u32>,
    unconverged: GrowBuffer<u32>,
    /// The pixels still active after the last check, for compact launches.
    pixel_list: GrowBuffer<u32>,
    /// Warnings of `new`, repeated in the first frame's output.
    setup_warnings: Vec<String>,
    /// Host soup uploads for `render_soup`.
    host_soup: Option<HostSoupBuffers>,
    /// The program's defines, for compiling its motion-blur variant.
    defines: Vec<(&'static str, String)>,
    /// `pathtrace.cl` with MOTION_BLUR, compiled at the first frame that
    /// moves within its shutter.
    motion_kernels: Option<Kernels>,
    /// The camera at each motion step.
    motion_cameras: GrowBuffer<DeviceCamera>,
}

/// An environment map on the device: its record, texels and CDFs.
/// The map's device form, texels, marginal and conditional CDFs, and mean
/// luminance.
type EnvBuffers = (DeviceEnv, Buffer<[f32; 4]>, Buffer<f32>, Buffer<f32>, f32);

/// An environment map on the device, with its sampling tables.
fn upload_env_map(device: &Device, map: &EnvMap) -> Result<EnvBuffers, TraceError> {
    let mut texels = device.buffer::<[f32; 4]>(map.texels.len())?;
    device.write(&mut texels, &map.texels)?;
    let mut marginal = device.buffer::<f32>(map.marginal.len())?;
    device.write(&mut marginal, &map.marginal)?;
    let mut conditional = device.buffer::<f32>(map.conditional.len())?;
    device.write(&mut conditional, &map.conditional)?;
    let env = DeviceEnv {
        color: [1.0, 1.0, 1.0, 0.0],
        kind: ENV_MAP,
        width: map.width,
        height: map.height,
        pad: 0,
    };
    Ok((env, texels, marginal, conditional, map.mean_luminance()))
}

struct HostSoupBuffers {
    positions: GrowBuffer<[f32; 4]>,
    normals: GrowBuffer<[f32; 4]>,
    uvs: GrowBuffer<[f32; 2]>,
    uvs1: GrowBuffer<[f32; 2]>,
    colors: GrowBuffer<[f32; 4]>,
    material_ids: GrowBuffer<u32>,
}

/// The kernel argument for an optional buffer: the buffer, or `dummy`.
fn or_dummy<'b, T>(buffer: Option<&'b Buffer<T>>, dummy: &'b Buffer<f32>) -> Arg<'b> {
    match buffer {
        Some(b) => Arg::Buf(b),
        None => Arg::Buf(dummy),
    }
}

fn usage(msg: String) -> TraceError {
    TraceError::Unsupported(msg)
}

impl<'d> PathTracer<'d> {
    /// The material features compiled in (`material_features`).
    pub fn material_features(&self) -> &[&'static str] {
        &self.features
    }

    /// Compiles the kernels for what the scene needs and uploads its
    /// materials, textures and the environment once.
    pub fn new(
        device: &'d Device,
        scene: &Scene,
        settings: &RenderSettings,
    ) -> Result<Self, TraceError> {
        // A scene that animates its materials (KHR_animation_pointer)
        // compiles in every feature the materials have at some key, and
        // has them re-uploaded per frame (`set_materials`).
        let animated: Vec<crate::scene::Material> = if scene.has_material_animation() {
            scene
                .material_key_times()
                .into_iter()
                .filter_map(|t| scene.materials_at(t))
                .flatten()
                .collect()
        } else {
            Vec::new()
        };
        Self::with_animated_materials(device, scene.materials(), &animated, settings)
    }

    /// As `new`, from a material table alone (scenes made in code).
    pub fn with_materials(
        device: &'d Device,
        table: &MaterialTable,
        settings: &RenderSettings,
    ) -> Result<Self, TraceError> {
        Self::with_animated_materials(device, table, &[], settings)
    }

    /// As `with_materials`, compiling in also the features of `animated`:
    /// other values the table's materials take over the clip, which
    /// `set_materials` uploads later.
    pub fn with_animated_materials(
        device: &'d Device,
        table: &MaterialTable,
        animated: &[crate::scene::Material],
        settings: &RenderSettings,
    ) -> Result<Self, TraceError> {
        if settings.width == 0
            || settings.height == 0
            || settings.width > 65536
            || settings.height > 65536
        {
            return Err(usage(format!(
                "render size {}x{}: both sides must be 1 to 65536 pixels (--width, --height)",
                settings.width, settings.height
            )));
        }
        if settings.spp == 0 {
            return Err(usage(
                "--spp 0: at least one sample per pixel is needed".into(),
            ));
        }
        let mut warnings = Vec::new();
        let mut host_materials = device_materials(table);
        if settings.backface_culling {
            for m in &mut host_materials {
                if m.flags & MAT_DOUBLE_SIDED == 0 {
                    m.flags |= MAT_CULL_BACK;
                }
            }
        }

        // What the kernels are compiled for: the table's materials and the
        // values animation gives them.
        let with_animated;
        let features_of = if animated.is_empty() {
            table
        } else {
            with_animated = MaterialTable {
                materials: table.materials.iter().chain(animated).cloned().collect(),
                textures: table.textures.clone(),
                images: Vec::new(),
                default_material: table.default_material,
            };
            &with_animated
        };
        let transmission = features_of.materials.iter().any(|m| m.needs_transmission());
        // The dielectric extensions' table (`HAS_TRANSMISSION` kernels only),
        // its texture slots filled below.
        let layers = LayerDefines::of(features_of);
        let mut host_exts = (transmission || layers.any()).then(|| device_material_exts(table));
        // The slots the kernels read: the extensions' only where their code
        // is compiled in.
        let mut slots: Vec<Slot> = Slot::BASE.to_vec();
        if transmission {
            slots.extend(Slot::DIELECTRIC);
        }
        if layers.clearcoat {
            slots.extend(Slot::CLEARCOAT);
        }
        if layers.sheen {
            slots.extend(Slot::SHEEN);
        }
        if layers.diffuse_transmission {
            slots.extend(Slot::DIFFUSE_TRANSMISSION);
        }
        if layers.iridescence {
            slots.extend(Slot::IRIDESCENCE);
        }
        if layers.anisotropy {
            slots.extend(Slot::ANISOTROPY);
        }
        let slots = &slots[..];

        // Textures: only when some material samples one (and not in clay
        // mode, where only alpha cut-outs would need them: those are kept).
        let mut textures = None;
        let textured = table
            .materials
            .iter()
            .any(|m| slots.iter().any(|s| s.of(m).is_some()));
        if textured {
            match TextureSet::with_slots(device, table, slots) {
                Ok(set) if !set.is_empty() => {
                    // Four bindings per material (`PtMaterial`), then
                    // `Slot::EXT.len()` per material for `PtMaterialExt` when compiled in
                    // (those of slots outside `slots` stay -1).
                    let bindings = bind_textures(
                        &set,
                        &table.materials,
                        &mut host_materials,
                        host_exts.as_deref_mut(),
                    );
                    let mut buf = device.buffer::<TextureBinding>(bindings.len())?;
                    device.write(&mut buf, &bindings)?;
                    textures = Some((set, buf));
                }
                Ok(_) => {}
                Err(e) => warnings.push(format!(
                    "textures are not used ({e}); materials are rendered with their factors only"
                )),
            }
        }

        // Clay is a pure Lambertian: no GGX lobe to compensate.
        let compensation = settings.energy_compensation && !settings.clay;
        let features = material_features(features_of, textures.is_some(), compensation);
        let defines = pathtrace_defines(
            settings.traversal,
            textures.is_some(),
            settings.sampler,
            transmission,
            compensation,
            features_of.materials.iter().any(|m| m.unlit),
            layers,
        );
        let kernels = Kernels::build(device, &defines)?;

        let mut materials = device.buffer::<DeviceMaterial>(host_materials.len())?;
        device.write(&mut materials, &host_materials)?;
        let material_exts = match host_exts {
            Some(exts) => {
                let mut buf = device.buffer::<DeviceMaterialExt>(exts.len())?;
                device.write(&mut buf, &exts)?;
                Some(buf)
            }
            None => None,
        };
        let any_emissive = host_materials.iter().any(DeviceMaterial::emits);

        let env_map = match &settings.environment {
            Environment::Map(path) => Some(upload_env_map(device, &EnvMap::load(path)?)?),
            Environment::Color(c) => {
                if !c.iter().all(|v| v.is_finite() && *v >= 0.0) {
                    return Err(usage(format!(
                        "--env-color {c:?}: the radiance must be three finite, non-negative numbers"
                    )));
                }
                None
            }
            Environment::Default => None,
        };

        let table_f = film::Filter::default().sampler().table().to_vec();
        let mut filter = device.buffer::<f32>(table_f.len())?;
        device.write(&mut filter, &table_f)?;
        let mut dummy_f32 = device.buffer::<f32>(4)?;
        device.write(&mut dummy_f32, &[0.0f32; 4])?;
        let mut dummy_u32 = device.buffer::<u32>(4)?;
        device.write(&mut dummy_u32, &[0u32; 4])?;
        let mut dummy_f4 = device.buffer::<[f32; 4]>(1)?;
        device.write(&mut dummy_f4, &[[0.0f32; 4]])?;

        Ok(PathTracer {
            device,
            settings: settings.clone(),
            schedule: Schedule::default(),
            kernels,
            materials,
            material_count: host_materials.len() as u32,
            any_emissive,
            textures,
            material_exts,
            features,
            env_map,
            filter,
            camera: device.buffer(1)?,
            frame: device.buffer(1)?,
            env: device.buffer(1)?,
            dummy_f32,
            dummy_u32,
            dummy_f4,
            layouts: TreeLayouts::default(),
            lights: GrowBuffer::new(),
            power: GrowBuffer::new(),
            power_host: Vec::new(),
            emit_prims: GrowBuffer::new(),
            emit_cdf: GrowBuffer::new(),
            emit_pmf: GrowBuffer::new(),
            select_cdf: GrowBuffer::new(),
            accum_color: GrowBuffer::new(),
            accum_normal: GrowBuffer::new(),
            accum_albedo: GrowBuffer::new(),
            accum_aux: GrowBuffer::new(),
            ray_counts: GrowBuffer::new(),
            accum_snapshots: GrowBuffer::new(),
            active: GrowBuffer::new(),
            unconverged: GrowBuffer::new(),
            pixel_list: GrowBuffer::new(),
            setup_warnings: warnings,
            host_soup: None,
            defines,
            motion_kernels: None,
            motion_cameras: GrowBuffer::new(),
        })
    }

    /// Replaces the materials' factors (and texture transforms) with
    /// `materials`, the same materials at another time of an animation
    /// (`Scene::materials_at`): the material buffers, the extension table
    /// and the texture bindings are written again. Only scenes that
    /// animate materials call it, once per frame; the kernels were
    /// compiled for every value (`with_animated_materials`).
    pub fn set_materials(
        &mut self,
        materials: Vec<crate::scene::Material>,
    ) -> Result<(), TraceError> {
        let table = MaterialTable {
            materials,
            ..MaterialTable::default()
        };
        let materials = &table.materials;
        let mut host = device_materials(&table);
        if host.len() as u32 != self.material_count {
            return Err(usage(format!(
                "set_materials: {} materials given, the tracer was made for {}",
                materials.len(),
                self.material_count.saturating_sub(1)
            )));
        }
        let mut exts = self
            .material_exts
            .is_some()
            .then(|| device_material_exts(&table));
        if let Some((set, buf)) = &mut self.textures {
            let bindings = bind_textures(set, materials, &mut host, exts.as_deref_mut());
            self.device.write(buf, &bindings)?;
        }
        self.device.write(&mut self.materials, &host)?;
        if let (Some(buf), Some(e)) = (&mut self.material_exts, &exts) {
            self.device.write(buf, e)?;
        }
        self.any_emissive = host.iter().any(DeviceMaterial::emits);
        Ok(())
    }

    /// Changes how frames are cut into launches (the image does not change).
    pub fn set_schedule(&mut self, schedule: Schedule) {
        self.schedule = schedule;
    }

    pub fn settings(&self) -> &RenderSettings {
        &self.settings
    }

    /// Whether the program was compiled with texture sampling.
    pub fn has_textures(&self) -> bool {
        self.textures.is_some()
    }

    /// Renders one frame; `progress(samples_done)` is called between
    /// sample passes.
    /// Renders `frame` at one sample per pixel and throws the image away:
    /// every kernel of a frame is then launched once, with the real frames'
    /// work-group and grid sizes, so a driver that compiles kernels at their
    /// first launch (PoCL) does it here, in the run's start-up, and not in
    /// the first frame's trace time. (An 8x8-pixel pass was not enough: on
    /// PoCL 3.1 the first full-size frame still traced 1 s slower, a second
    /// specialisation of the kernel.) Costs 1/spp of a frame's trace.
    pub fn warm_up(&mut self, frame: &FrameInput) -> Result<(), TraceError> {
        let saved = self.settings.clone();
        let warnings = self.setup_warnings.clone();
        self.settings.spp = 1;
        let result = self.render(frame, &mut |_| {});
        self.settings = saved;
        self.setup_warnings = warnings;
        result.map(|_| ())
    }

    pub fn render(
        &mut self,
        frame: &FrameInput,
        progress: &mut dyn FnMut(u32),
    ) -> Result<RenderOutput, TraceError> {
        let soup = SoupBuffers {
            positions: frame.soup.positions(),
            normals: frame.soup.normals(),
            uvs: frame.soup.uvs(),
            uvs1: frame.soup.uvs1(),
            colors: frame.soup.colors(),
            material_ids: frame.soup.material_ids(),
            triangles: frame.soup.triangle_count(),
        };
        self.render_buffers(
            &soup,
            frame.bvh,
            frame.prim_ids,
            frame.camera,
            frame.lights,
            frame.frame,
            None,
            progress,
        )
    }

    /// Compiles the motion-blur variant of the program, once.
    pub fn prepare_motion(&mut self) -> Result<(), TraceError> {
        if self.motion_kernels.is_none() {
            let defines = motion_defines(self.defines.clone());
            self.motion_kernels = Some(Kernels::build(self.device, &defines)?);
        }
        Ok(())
    }

    /// Renders a frame that moves within the shutter: `frame.bvh` and
    /// `frame.prim_ids` are the tree over the triangles' bounds at every
    /// step, `motion` the soup and camera at each step (`frame.soup`
    /// supplies the uvs and material ids, which do not move). Each camera
    /// sample draws a time in the shutter (sampler set 0, dimension 2) and
    /// its whole path sees the scene at that time.
    pub fn render_motion(
        &mut self,
        frame: &FrameInput,
        motion: &MotionFrame,
        progress: &mut dyn FnMut(u32),
    ) -> Result<RenderOutput, TraceError> {
        let soup = SoupBuffers {
            positions: motion.positions,
            normals: motion.normals,
            uvs: frame.soup.uvs(),
            uvs1: frame.soup.uvs1(),
            colors: frame.soup.colors(),
            material_ids: frame.soup.material_ids(),
            triangles: frame.soup.triangle_count(),
        };
        self.render_buffers(
            &soup,
            frame.bvh,
            frame.prim_ids,
            frame.camera,
            frame.lights,
            frame.frame,
            Some((motion.steps, motion.cameras, motion.lights)),
            progress,
        )
    }

    /// `render_motion` at one sample per pixel, the image thrown away (the
    /// motion program's first launch, as `warm_up`).
    pub fn warm_up_motion(
        &mut self,
        frame: &FrameInput,
        motion: &MotionFrame,
    ) -> Result<(), TraceError> {
        let saved = self.settings.clone();
        let warnings = self.setup_warnings.clone();
        self.settings.spp = 1;
        let result = self.render_motion(frame, motion, &mut |_| {});
        self.settings = saved;
        self.setup_warnings = warnings;
        result.map(|_| ())
    }

    /// Renders host soups at `steps.len()` >= 2 motion steps (same
    /// triangles, uvs and materials in each; `cameras` one per step, and
    /// `lights` the punctual lights at each step or none at all), their
    /// tree built here on the device over the triangles' bounds at every
    /// step (`motion::motion_bounds`). For tests and tools; the renderer
    /// keeps everything on the device with `render_motion`.
    pub fn render_motion_soup(
        &mut self,
        steps: &[Soup],
        cameras: &[FrameCamera],
        lights: &[Vec<FrameLight>],
        frame: i64,
    ) -> Result<RenderOutput, TraceError> {
        let count = steps.len();
        if count < 2 || cameras.len() != count || !(lights.is_empty() || lights.len() == count) {
            return Err(usage(format!(
                "render_motion_soup: {count} soups, {} cameras and {} light sets; give at least 2 steps, \
                 one camera per step and one light set per step (or none)",
                cameras.len(),
                lights.len()
            )));
        }
        let n = steps[0].triangle_count();
        if steps.iter().any(|s| s.triangle_count() != n) {
            return Err(usage(
                "render_motion_soup: every step must have the same triangles".into(),
            ));
        }
        let mut positions: Vec<[f32; 4]> = Vec::with_capacity(3 * n * count);
        for s in steps {
            positions.extend_from_slice(&s.positions);
        }
        let normals: Option<Vec<[f32; 4]>> =
            (n > 0 && steps.iter().all(|s| s.normals.len() == 3 * n)).then(|| {
                steps
                    .iter()
                    .flat_map(|s| s.normals.iter().copied())
                    .collect()
            });
        let bounds = Soup {
            positions: super::motion::motion_bounds(&positions, n, count as u32),
            ..Soup::default()
        };
        self.prepare_motion()?;
        self.render_host(
            &bounds,
            &positions,
            normals.as_deref(),
            &steps[0],
            &cameras[count / 2],
            lights.get(count / 2).map_or(&[], |l| l.as_slice()),
            frame,
            Some((count as u32, cameras, lights)),
        )
    }

    /// Renders a host soup (uploaded into buffers kept for the next call)
    /// whose tree is built here on the device. Missing material ids mean
    /// material 0 of the table (or the default material when it is empty).
    pub fn render_soup(
        &mut self,
        soup: &Soup,
        camera: &FrameCamera,
        lights: &[FrameLight],
        frame: i64,
    ) -> Result<RenderOutput, TraceError> {
        let n = soup.triangle_count();
        let normals = (soup.normals.len() == 3 * n && n > 0).then_some(soup.normals.as_slice());
        self.render_host(
            soup,
            &soup.positions,
            normals,
            soup,
            camera,
            lights,
            frame,
            None,
        )
    }

    /// The host-soup path of `render_soup` and `render_motion_soup`: builds
    /// the tree over `tree`'s triangles, uploads `positions` and `normals`
    /// (one soup's, or every motion step's side by side) with `first`'s
    /// texture coordinates and material ids into the buffers kept for the
    /// next call, and renders.
    #[allow(clippy::too_many_arguments)]
    fn render_host(
        &mut self,
        tree: &Soup,
        positions: &[[f32; 4]],
        normals: Option<&[[f32; 4]]>,
        first: &Soup,
        camera: &FrameCamera,
        lights: &[FrameLight],
        frame: i64,
        motion: Option<MotionSteps>,
    ) -> Result<RenderOutput, TraceError> {
        let n = first.triangle_count();
        let d = self.device;
        let mut builder = DeviceBuilder::new(d, BuildParams::default())
            .map_err(|e| usage(format!("BVH build: {e}")))?;
        let (bvh, _) = builder
            .build(tree)
            .map_err(|e| usage(format!("BVH build: {e}")))?;
        let mut hs = self.host_soup.take().unwrap_or(HostSoupBuffers {
            positions: GrowBuffer::new(),
            normals: GrowBuffer::new(),
            uvs: GrowBuffer::new(),
            uvs1: GrowBuffer::new(),
            colors: GrowBuffer::new(),
            material_ids: GrowBuffer::new(),
        });
        let result = (|| {
            d.write(hs.positions.ensure(d, positions.len().max(1))?, positions)?;
            if let Some(normals) = normals {
                d.write(hs.normals.ensure(d, normals.len())?, normals)?;
            }
            let has_uvs = first.uvs.len() == 3 * n && n > 0;
            if has_uvs {
                d.write(hs.uvs.ensure(d, 3 * n)?, &first.uvs)?;
            }
            let has_uvs1 = first.uvs1.len() == 3 * n && n > 0;
            if has_uvs1 {
                d.write(hs.uvs1.ensure(d, 3 * n)?, &first.uvs1)?;
            }
            let has_colors = first.colors.len() == 3 * n && n > 0;
            if has_colors {
                d.write(hs.colors.ensure(d, 3 * n)?, &first.colors)?;
            }
            let ids = if first.material_ids.len() == n {
                first.material_ids.clone()
            } else {
                vec![0; n]
            };
            d.write(hs.material_ids.ensure(d, n.max(1))?, &ids)?;
            let buffers = SoupBuffers {
                positions: hs.positions.get(),
                normals: normals.is_some().then(|| hs.normals.get()),
                uvs: has_uvs.then(|| hs.uvs.get()),
                uvs1: has_uvs1.then(|| hs.uvs1.get()),
                colors: has_colors.then(|| hs.colors.get()),
                material_ids: hs.material_ids.get(),
                triangles: n,
            };
            let prim_ids = builder
                .device_prim_ids()
                .ok_or_else(|| usage("BVH build left no primitive ids".into()))?;
            self.render_buffers(
                &buffers,
                &bvh,
                prim_ids,
                camera,
                lights,
                frame,
                motion,
                &mut |_| {},
            )
        })();
        self.host_soup = Some(hs);
        result
    }

    #[allow(clippy::too_many_arguments)]
    fn render_buffers(
        &mut self,
        soup: &SoupBuffers,
        bvh: &Bvh,
        prim_ids: &Buffer<u32>,
        camera: &FrameCamera,
        lights: &[FrameLight],
        frame_index: i64,
        motion: Option<MotionSteps>,
        progress: &mut dyn FnMut(u32),
    ) -> Result<RenderOutput, TraceError> {
        let d = self.device;
        let s = self.settings.clone();
        let sampler_frame = s.noise_pattern.sampler_frame(frame_index);
        let mut warnings = std::mem::take(&mut self.setup_warnings);
        let (w, h) = (s.width, s.height);
        let pixels = w as usize * h as usize;

        // The tree. An empty soup has an empty tree: nothing can be hit, and
        // the stack traversal gets an empty root to read.
        let empty = soup.triangles == 0 || bvh.nodes.is_empty();
        let snode_count = match s.traversal {
            _ if empty => {
                self.layouts.upload_empty(d)?;
                0
            }
            Traversal::Stack => {
                self.layouts.upload_binary(d, bvh)?;
                0
            }
            Traversal::Wide => {
                self.layouts.upload_wide(d, bvh)?;
                0
            }
            Traversal::Stackless => self.layouts.upload_stackless(d, bvh)?.entries as u32,
        };
        self.layouts.ensure_all(d)?;

        // Lights.
        let mut host_lights: Vec<DeviceLight> =
            lights.iter().map(DeviceLight::from_frame_light).collect();
        if let Some((steps, _, step_lights)) = motion {
            // Every light at each step, step after step (`pt_light`).
            let at_frame = std::mem::take(&mut host_lights);
            for s in 0..steps as usize {
                match step_lights.get(s) {
                    Some(l) if l.len() == at_frame.len() => {
                        host_lights.extend(l.iter().map(DeviceLight::from_frame_light))
                    }
                    Some(l) => {
                        return Err(usage(format!(
                            "motion step {s} has {} lights, the frame {}",
                            l.len(),
                            at_frame.len()
                        )))
                    }
                    None => host_lights.extend_from_slice(&at_frame),
                }
            }
        }
        let lbuf = self.lights.ensure(d, host_lights.len())?;
        d.write(lbuf, &host_lights)?;

        // Emissive triangles, in proportion to their power.
        let mut emit = EmissiveDistribution::default();
        if self.any_emissive && soup.triangles > 0 {
            let n = soup.triangles;
            let pbuf = self.power.ensure(d, n)?;
            d.launch(
                "pathtrace/emissive_power",
                &self.kernels.emissive_power,
                n.div_ceil(64),
                64,
                &[
                    Arg::Buf(soup.positions),
                    Arg::Buf(soup.material_ids),
                    Arg::Buf(&self.materials),
                    Arg::U32(self.material_count),
                    Arg::U32(n as u32),
                    Arg::Buf(&*pbuf),
                ],
            )?;
            self.power_host.resize(n, 0.0);
            d.read(pbuf, &mut self.power_host)?;
            emit = EmissiveDistribution::from_power(&self.power_host);
        }
        if !emit.is_empty() {
            d.write(self.emit_prims.ensure(d, emit.prims.len())?, &emit.prims)?;
            d.write(self.emit_cdf.ensure(d, emit.cdf.len())?, &emit.cdf)?;
            d.write(
                self.emit_pmf.ensure(d, emit.pmf_by_prim.len())?,
                &emit.pmf_by_prim,
            )?;
        } else {
            // MIS reads the pmf of every hit triangle: all zero.
            let n = soup.triangles.max(1);
            d.write(self.emit_pmf.ensure(d, n)?, &vec![0.0f32; n])?;
            self.emit_prims.ensure(d, 1)?;
            self.emit_cdf.ensure(d, 2)?;
        }

        // The environment. The default: the studio sky unless the scene
        // has punctual lights of its own (`Environment::Default`).
        if matches!(s.environment, Environment::Default) && lights.is_empty() {
            if self.env_map.is_none() {
                self.env_map = Some(upload_env_map(d, &EnvMap::studio_sky())?);
            }
            warnings.push(
                "the scene has no KHR_lights_punctual light: lit by soupray's default studio sky \
                 (pass --env-color R,G,B or --env FILE.exr to choose another, --env-color 0,0,0 for none)"
                    .to_owned(),
            );
        }
        let env = match (&s.environment, &self.env_map) {
            (Environment::Map(_), Some((env, ..))) => *env,
            (Environment::Default, Some((env, ..))) if lights.is_empty() => *env,
            (Environment::Color(c), _) if c.iter().any(|&v| v > 0.0) => DeviceEnv {
                color: [c[0], c[1], c[2], 0.0],
                kind: ENV_CONSTANT,
                ..DeviceEnv::zeroed()
            },
            // A black environment adds no light: as a light to sample it
            // would only take samples away from the lights that do.
            (Environment::Color(_), _) => DeviceEnv {
                kind: ENV_NONE,
                ..DeviceEnv::zeroed()
            },
            _ => DeviceEnv {
                kind: ENV_NONE,
                ..DeviceEnv::zeroed()
            },
        };
        d.write(&mut self.env, &[env])?;

        let mut flags = 0;
        if soup.normals.is_some() {
            flags |= FRAME_NORMALS;
        }
        if soup.uvs1.is_some() {
            flags |= FRAME_UVS1;
        }
        if soup.colors.is_some() {
            flags |= FRAME_COLORS;
        }
        if soup.uvs.is_some() {
            flags |= FRAME_UVS;
        } else if self.features.contains(&"anisotropy") {
            warnings.push(
                "a material uses KHR_materials_anisotropy but the scene has no TEXCOORD_0: the \
                 anisotropy direction, which is given in the tangent frame of the texture \
                 coordinates, is arbitrary (export the meshes with UVs)"
                    .to_owned(),
            );
        }
        if s.clay {
            flags |= FRAME_CLAY;
        }

        // Which light next-event estimation samples, by estimated power.
        let radius = scene_radius(bvh);
        let punctual: Vec<f64> = lights.iter().map(|l| punctual_power(l, radius)).collect();
        let env_power = match env.kind {
            ENV_MAP => Some(environment_power(
                self.env_map.as_ref().map_or(0.0, |m| m.4),
                radius,
            )),
            _ => None,
        };
        let selection = LightSelection::new(
            &punctual,
            (!emit.is_empty()).then_some(emit.power),
            env_power,
        );
        d.write(
            self.select_cdf.ensure(d, selection.cdf.len())?,
            &selection.cdf,
        )?;
        let select_count = selection.count();
        let fr = DeviceFrame {
            seed_lo: s.seed as u32,
            seed_hi: (s.seed >> 32) as u32,
            frame_lo: sampler_frame as u64 as u32,
            frame_hi: ((sampler_frame as u64) >> 32) as u32,
            width: w,
            height: h,
            max_depth: s.max_depth,
            flags,
            light_count: lights.len() as u32,
            emit_count: emit.prims.len() as u32,
            material_count: self.material_count,
            select_count,
            light_loop: selection.loop_punctual as u32,
            emit_select_pmf: selection.emit_pmf,
            env_select_pmf: selection.env_pmf,
            pad: 0,
        };
        d.write(&mut self.frame, &[fr])?;
        d.write(&mut self.camera, &[device_camera(camera, w, h)])?;
        let motion_steps = match motion {
            Some((steps, cameras, _)) => {
                if steps < 2 || cameras.len() != steps as usize || self.motion_kernels.is_none() {
                    return Err(usage(format!(
                        "a motion frame needs at least 2 steps, one camera per step and the motion program \
                         (prepare_motion); got {steps} steps and {} cameras",
                        cameras.len()
                    )));
                }
                let cams: Vec<DeviceCamera> =
                    cameras.iter().map(|c| device_camera(c, w, h)).collect();
                d.write(self.motion_cameras.ensure(d, cams.len())?, &cams)?;
                Some(steps)
            }
            None => None,
        };

        // Accumulators.
        self.accum_color.ensure(d, pixels)?;
        self.accum_normal.ensure(d, pixels)?;
        self.accum_albedo.ensure(d, pixels)?;
        self.accum_aux.ensure(d, pixels)?;
        self.ray_counts.ensure(d, pixels)?;
        self.accum_snapshots.ensure(d, 2 * pixels)?;
        self.active.ensure(d, pixels)?;
        self.unconverged.ensure(d, pixels)?;
        self.pixel_list.ensure(d, pixels)?;
        let first_event = d.pending_events().len();
        d.launch(
            "pathtrace/clear",
            &self.kernels.clear,
            pixels.div_ceil(64),
            64,
            &[
                Arg::Buf(self.accum_color.get()),
                Arg::Buf(self.accum_normal.get()),
                Arg::Buf(self.accum_albedo.get()),
                Arg::Buf(self.accum_aux.get()),
                Arg::Buf(self.ray_counts.get()),
                Arg::Buf(self.accum_snapshots.get()),
                Arg::Buf(self.active.get()),
                Arg::U32(pixels as u32),
            ],
        )?;

        // Sample passes over tiles, ending at every convergence check. One
        // pass is queued ahead of the one the host waits for, so the device
        // never idles, and a time limit stops within a pass.
        let spp = s.spp;
        let empty_soup_positions;
        let positions: &Buffer<[f32; 4]> = if empty {
            empty_soup_positions = &self.dummy_f4;
            empty_soup_positions
        } else {
            soup.positions
        };
        let checks = s
            .adaptive
            .map_or_else(Vec::new, |a| check_counts(a.min_spp, spp));
        let mut next_check = checks.iter().copied().peekable();
        let started = std::time::Instant::now();
        let mut queued: std::collections::VecDeque<(usize, u32)> = Default::default();
        let mut begin = 0;
        let mut timed_out = false;
        // After a check, passes launch over the pixels still active only:
        // a launch over a mostly converged image costs as much as sampling.
        let mut listed: Option<u32> = None;
        let mut flags = Vec::new();
        // Time allocation: 1 / the mean rays per pixel at the first check
        // (0 until then, and for equal-error allocation).
        let mut inv_work_ref = 0.0f32;
        let mut work_reference = None;
        while begin < spp {
            if listed == Some(0) {
                break; // every pixel converged
            }
            // A pass holds the schedule's samples per pass (by default sized
            // to the pixels still sampling) and ends at every check.
            let items = listed.map_or(pixels, |n| n as usize);
            let mut end = begin
                .saturating_add(self.samples_per_pass(items, spp))
                .min(spp);
            let check = next_check.peek().is_some_and(|&c| c <= end);
            if check {
                end = next_check.next().expect("peeked");
            }
            self.enqueue_pass(
                soup,
                prim_ids,
                positions,
                snode_count,
                empty,
                (begin, end),
                listed,
                motion_steps,
            )?;
            if check {
                let time = s.adaptive.map(|a| a.allocation) == Some(Allocation::Time);
                if time && work_reference.is_none() {
                    // Once per frame, at the first check: the host sums the
                    // integer counts, so the reference is exact and the
                    // same whatever the schedule.
                    let mut rays = vec![0u32; pixels];
                    d.read(self.ray_counts.get(), &mut rays)?;
                    let total: u64 = rays.iter().map(|&r| r as u64).sum();
                    let mean = total as f64 / pixels.max(1) as f64;
                    work_reference = Some(mean);
                    inv_work_ref = if total > 0 { (1.0 / mean) as f32 } else { 0.0 };
                }
                self.enqueue_check(pixels, w, h, inv_work_ref)?;
                flags.resize(pixels, 0u32);
                d.read(self.active.get(), &mut flags)?;
                let list: Vec<u32> = (0..pixels as u32)
                    .filter(|&i| flags[i as usize] != 0)
                    .collect();
                if !list.is_empty() {
                    d.write(self.pixel_list.ensure(d, pixels)?, &list)?;
                }
                listed = Some(list.len() as u32);
            }
            d.flush()?;
            queued.push_back((d.pending_events().len(), end));
            begin = end;
            while queued.len() > 1 {
                let (count, done) = queued.pop_front().expect("queued");
                wait_pass(d, count)?;
                progress(done);
            }
            if s.time_limit.is_some_and(|limit| started.elapsed() >= limit) {
                timed_out = true;
                break;
            }
        }
        for (count, done) in queued {
            wait_pass(d, count)?;
            progress(done);
        }
        let events = d.pending_events();
        let mut trace_ms = 0.0;
        for e in events.iter().skip(first_event) {
            use opencl3::event::{
                get_event_profiling_info, CL_PROFILING_COMMAND_END, CL_PROFILING_COMMAND_START,
            };
            let t0: u64 = get_event_profiling_info(*e, CL_PROFILING_COMMAND_START)
                .map(Into::into)
                .unwrap_or(0);
            let t1: u64 = get_event_profiling_info(*e, CL_PROFILING_COMMAND_END)
                .map(Into::into)
                .unwrap_or(0);
            trace_ms += t1.saturating_sub(t0) as f64 * 1e-6;
        }

        // Resolve: means over each pixel's kept samples.
        let mut color = vec![[0.0f32; 4]; pixels];
        let mut aux = vec![[0.0f32; 4]; pixels];
        let mut snapshots = vec![[0.0f32; 4]; 2 * pixels];
        let mut rays = vec![0u32; pixels];
        d.read(self.accum_color.get(), &mut color)?;
        d.read(self.accum_aux.get(), &mut aux)?;
        d.read(self.accum_snapshots.get(), &mut snapshots)?;
        d.read(self.ray_counts.get(), &mut rays)?;
        let mut normal = Vec::new();
        let mut albedo = Vec::new();
        if s.aovs.normal {
            normal = vec![[0.0f32; 4]; pixels];
            d.read(self.accum_normal.get(), &mut normal)?;
        }
        if s.aovs.albedo {
            albedo = vec![[0.0f32; 4]; pixels];
            d.read(self.accum_albedo.get(), &mut albedo)?;
        }
        let mut image = Image::new(w, h, s.aovs);
        let mut dropped = 0u64;
        let mut taken = 0u64;
        let mut counts = Vec::with_capacity(pixels);
        let mut estimates = Vec::with_capacity(pixels);
        for i in 0..pixels {
            let bad = aux[i][2] as u32;
            let samples = aux[i][3] as u32;
            dropped += bad as u64;
            taken += samples as u64;
            counts.push(samples);
            let e = noise_estimate(color[i], [snapshots[2 * i], snapshots[2 * i + 1]], aux[i]);
            estimates.push(e);
            if let Some(c) = &mut image.sample_count {
                c[i] = samples as f32;
            }
            if let Some(n) = &mut image.noise {
                n[i] = e;
            }
            if let Some(r) = &mut image.rays {
                r[i] = rays[i] as f32;
            }
            let kept = samples.saturating_sub(bad);
            if kept == 0 {
                continue;
            }
            let inv = 1.0 / kept as f32;
            let c = color[i];
            image.rgba[i] = [c[0] * inv, c[1] * inv, c[2] * inv, c[3] * inv];
            if let Some(n) = &mut image.normal {
                n[i] = [normal[i][0] * inv, normal[i][1] * inv, normal[i][2] * inv];
            }
            if let Some(a) = &mut image.albedo {
                a[i] = [albedo[i][0] * inv, albedo[i][1] * inv, albedo[i][2] * inv];
            }
            if let Some(z) = &mut image.depth {
                z[i] = if aux[i][1] > 0.0 {
                    aux[i][0] / aux[i][1]
                } else {
                    BACKGROUND_DEPTH
                };
            }
        }
        if dropped > 0 {
            warnings.push(format!(
                "path tracing: dropped {dropped} of {taken} samples with NaN or infinite values"
            ));
        }
        let stopped = if timed_out {
            "time_limit"
        } else if listed == Some(0) {
            "threshold"
        } else {
            "max_spp"
        };
        // Each pixel against its own stop threshold, from the work it had
        // done when it stopped (a stopped pixel's counts no longer change).
        let thresholds: Option<Vec<f32>> = s.adaptive.map(|a| {
            rays.iter()
                .map(|&r| film::stop_threshold(a.threshold, r, inv_work_ref))
                .collect()
        });
        let mut noise = NoiseStats::with_thresholds(
            s.adaptive.map(|a| a.threshold),
            thresholds.as_deref(),
            &estimates,
            &counts,
            stopped,
        );
        noise.allocation = s.adaptive.map(|a| a.allocation.name().to_owned());
        noise.work_reference = work_reference;
        Ok(RenderOutput {
            image,
            rays: rays.iter().map(|&r| r as u64).sum(),
            pixel_rays: rays,
            trace_ms,
            noise,
            warnings,
        })
    }

    /// Samples per pixel in one pass over `items` pixels.
    fn samples_per_pass(&self, items: usize, spp: u32) -> u32 {
        if self.schedule.samples_per_pass > 0 {
            self.schedule.samples_per_pass
        } else {
            (PATHS_PER_LAUNCH / items.max(1) as u64).clamp(1, spp as u64) as u32
        }
    }

    /// Queues samples [begin, end) of every pixel, tile by tile, or of the
    /// first `listed` pixels of the pixel list in one launch.
    #[allow(clippy::too_many_arguments)]
    fn enqueue_pass(
        &self,
        soup: &SoupBuffers,
        prim_ids: &Buffer<u32>,
        positions: &Buffer<[f32; 4]>,
        snode_count: u32,
        empty: bool,
        (begin, end): (u32, u32),
        listed: Option<u32>,
        motion_steps: Option<u32>,
    ) -> Result<(), TraceError> {
        let (kernel, camera) = match (motion_steps, &self.motion_kernels) {
            (Some(_), Some(k)) => (&k.render, self.motion_cameras.get()),
            _ => (&self.kernels.render, &self.camera),
        };
        let d = self.device;
        // A listed launch is one "tile" of `listed` items in a row.
        let (w, h) = match listed {
            Some(n) => (n, 1),
            None => (self.settings.width, self.settings.height),
        };
        let (tw, th) = match listed {
            Some(n) => (n, 1),
            None => self.schedule.tile.unwrap_or((w, h)),
        };
        let (tw, th) = (tw.clamp(1, w), th.clamp(1, h));
        let local = self.schedule.local_size.max(1);
        let adaptive = self.settings.adaptive.is_some();
        for ty in (0..h).step_by(th as usize) {
            for tx in (0..w).step_by(tw as usize) {
                let cw = tw.min(w - tx);
                let ch = th.min(h - ty);
                let items = cw as usize * ch as usize;
                let mut args = vec![
                    Arg::Buf(self.layouts.buffers().0),
                    Arg::Buf(self.layouts.buffers().1),
                    Arg::Buf(self.layouts.buffers().2),
                    Arg::U32(snode_count),
                    Arg::Buf(prim_ids),
                    Arg::Buf(positions),
                    // An attribute the soup lacks binds a dummy (its frame
                    // flag keeps the kernel from reading it).
                    or_dummy(soup.normals, &self.dummy_f32),
                    or_dummy(soup.uvs, &self.dummy_f32),
                    or_dummy(soup.uvs1, &self.dummy_f32),
                    or_dummy(soup.colors, &self.dummy_f32),
                    Arg::Buf(if empty {
                        &self.dummy_u32
                    } else {
                        soup.material_ids
                    }),
                    Arg::Buf(&self.materials),
                    Arg::Buf(self.lights.get()),
                    Arg::Buf(self.emit_prims.get()),
                    Arg::Buf(self.emit_cdf.get()),
                    Arg::Buf(self.emit_pmf.get()),
                    Arg::Buf(self.select_cdf.get()),
                    Arg::Buf(&self.env),
                ];
                match &self.env_map {
                    Some((_, t, m, c, _)) => {
                        args.push(Arg::Buf(t));
                        args.push(Arg::Buf(m));
                        args.push(Arg::Buf(c));
                    }
                    None => {
                        args.push(Arg::Buf(&self.dummy_f4));
                        args.push(Arg::Buf(&self.dummy_f32));
                        args.push(Arg::Buf(&self.dummy_f32));
                    }
                }
                args.extend([
                    Arg::Buf(&self.filter),
                    Arg::Buf(camera),
                    Arg::Buf(&self.frame),
                    Arg::Buf(self.accum_color.get()),
                    Arg::Buf(self.accum_normal.get()),
                    Arg::Buf(self.accum_albedo.get()),
                    Arg::Buf(self.accum_aux.get()),
                    Arg::Buf(self.ray_counts.get()),
                    Arg::Buf(self.accum_snapshots.get()),
                    Arg::Buf(self.active.get()),
                    Arg::U32(adaptive as u32),
                    Arg::Buf(self.pixel_list.get()),
                    Arg::U32(listed.unwrap_or(0)),
                    Arg::U32(tx),
                    Arg::U32(ty),
                    Arg::U32(cw),
                    Arg::U32(ch),
                    Arg::U32(begin),
                    Arg::U32(end),
                ]);
                if let Some((set, bindings)) = &self.textures {
                    args.push(Arg::Buf(set.info_buffer().expect("non-empty set")));
                    args.push(Arg::Buf(set.texel_buffer().expect("non-empty set")));
                    args.push(Arg::Buf(bindings));
                }
                if let Some(exts) = &self.material_exts {
                    args.push(Arg::Buf(exts));
                }
                if let Some(steps) = motion_steps {
                    args.push(Arg::U32(steps));
                    args.push(Arg::U32(soup.triangles as u32));
                }
                d.launch(
                    "pathtrace/render",
                    kernel,
                    items.div_ceil(local),
                    local,
                    &args,
                )?;
            }
        }
        Ok(())
    }

    /// Queues a convergence check: each pixel's estimate against the
    /// threshold, then the dilation that decides which pixels go on.
    fn enqueue_check(
        &self,
        pixels: usize,
        w: u32,
        h: u32,
        inv_work_ref: f32,
    ) -> Result<(), TraceError> {
        let d = self.device;
        let threshold = self.settings.adaptive.map_or(0.0, |a| a.threshold);
        d.launch(
            "pathtrace/converge",
            &self.kernels.converge,
            pixels.div_ceil(64),
            64,
            &[
                Arg::Buf(self.accum_color.get()),
                Arg::Buf(self.accum_snapshots.get()),
                Arg::Buf(self.accum_aux.get()),
                Arg::Buf(self.ray_counts.get()),
                Arg::Buf(self.unconverged.get()),
                Arg::F32(threshold),
                Arg::F32(inv_work_ref),
                Arg::U32(w),
                Arg::U32(h),
            ],
        )?;
        d.launch(
            "pathtrace/dilate",
            &self.kernels.dilate,
            pixels.div_ceil(64),
            64,
            &[
                Arg::Buf(self.unconverged.get()),
                Arg::Buf(self.active.get()),
                Arg::U32(w),
                Arg::U32(h),
            ],
        )?;
        Ok(())
    }
}

/// Renders a host soup with `table`'s materials (soup material ids index
/// it), `camera` and `lights`: a tracer made for this one frame.
pub fn render_soup(
    device: &Device,
    soup: &Soup,
    table: &MaterialTable,
    camera: &FrameCamera,
    lights: &[FrameLight],
    settings: &RenderSettings,
    frame: i64,
) -> Result<RenderOutput, TraceError> {
    let mut pt = PathTracer::with_materials(device, table, settings)?;
    pt.render_soup(soup, camera, lights, frame)
}

/// The radius of the scene's bounding sphere: half the diagonal of the
/// tree's root box (0 for an empty tree). Lights without finite power
/// (directional, environment) are weighed by it.
fn scene_radius(bvh: &Bvh) -> f32 {
    let Some(root) = bvh.nodes.first() else {
        return 0.0;
    };
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for (min, max) in [
        (root.left_min, root.left_max),
        (root.right_min, root.right_max),
    ] {
        let (a, b) = (Vec3::from(min), Vec3::from(max));
        if a.is_finite() && b.is_finite() && a.cmple(b).all() {
            lo = lo.min(a);
            hi = hi.max(b);
        }
    }
    if lo.cmple(hi).all() {
        0.5 * (hi - lo).length()
    } else {
        0.0
    }
}

/// Waits for the event that ends a pass (the `count`-th pending event).
fn wait_pass(d: &Device, count: usize) -> Result<(), TraceError> {
    let events = d.pending_events();
    if let Some(e) = events.get(count.wrapping_sub(1)) {
        opencl3::event::wait_for_events(&[*e]).map_err(|c| {
            TraceError::Device(crate::device::DeviceError::Cl {
                what: "clWaitForEvents (path tracing pass)".into(),
                code: c.to_string(),
            })
        })?;
    }
    Ok(())
}
