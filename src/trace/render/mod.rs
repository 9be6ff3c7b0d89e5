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
//!
//! Beside this file: `setup` checks and uploads what a tracer is made with,
//! `program` chooses the kernels' defines, `upload` writes each frame's tables,
//! `passes` queues the sample passes, and `host_soup` renders host soups.

mod emitters;
mod host_soup;
mod passes;
mod program;
mod setup;
mod upload;

pub use super::camera::{device_camera, with_lens, DeviceCamera};
pub use super::settings::{
    check_counts, Adaptive, Allocation, Environment, Layering, LightTreeUse, RenderSettings,
    Schedule, Traversal, ADAPTIVE_STEP, EMITTER_SPREAD_MIN,
};
pub use host_soup::render_soup;
use host_soup::HostSoupBuffers;
use program::Kernels;
pub use program::{
    film_defines, layering_defines, material_features, motion_defines, pathtrace_defines,
    FilmFeatures, Lobe, Lobes, LOBES,
};
use setup::{
    check_settings, environment_map, host_materials, texture_slots, upload_materials,
    upload_textures,
};
use upload::{bind_textures, EnvBuffers, FrameTables};
pub use upload::{frame_consts, DeviceFrame};

use opencl3::memory::Buffer;

use super::device::TreeLayouts;
use super::light_tree::device::{BuiltTree, LightTreeBuilder};
use super::light_tree::DeviceLightNode;
use super::lights::{DeviceEnv, DeviceLight};
use super::material::{device_material_exts, device_materials, DeviceMaterial, DeviceMaterialExt};
use super::texture::{TextureBinding, TextureSet};
use super::vectors::{vector_camera, VectorCamera, VECTOR_STEPS};
use super::TraceError;
use crate::bvh::Bvh;
use crate::device::{Arg, Device, GrowBuffer};
use crate::film::{self, Accumulated, Image, NoiseStats, SpareImages};
use crate::scene::compositing::triangle_flags;
use crate::scene::{FrameCamera, FrameLight, MaterialTable, MatteTable, Scene};
use crate::soup::device::DeviceSoup;

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

/// A frame's soup on the device, whoever made it.
/// The frame's light tree as the host keeps it: what the device built, and
/// which punctual lights it holds (the others stay entries of the frame's
/// selection).
#[derive(Default)]
struct FrameLightTree {
    built: BuiltTree,
    holds_light: Vec<bool>,
}

struct SoupBuffers<'a> {
    positions: &'a Buffer<[f32; 4]>,
    normals: Option<&'a Buffer<[f32; 4]>>,
    uvs: Option<&'a Buffer<[f32; 2]>>,
    uvs1: Option<&'a Buffer<[f32; 2]>>,
    colors: Option<&'a Buffer<[f32; 4]>>,
    material_ids: &'a Buffer<u32>,
    triangles: usize,
}

impl<'a> SoupBuffers<'a> {
    /// The device soup's buffers, with `positions` and `normals` in place
    /// of its own (the motion steps' for a frame that moves).
    fn of(
        soup: &'a DeviceSoup<'a>,
        positions: &'a Buffer<[f32; 4]>,
        normals: Option<&'a Buffer<[f32; 4]>>,
    ) -> SoupBuffers<'a> {
        SoupBuffers {
            positions,
            normals,
            uvs: soup.uvs(),
            uvs1: soup.uvs1(),
            colors: soup.colors(),
            material_ids: soup.material_ids(),
            triangles: soup.triangle_count(),
        }
    }
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

/// A motion frame's steps as `render_buffers` takes them: the count, the
/// camera at each step and the lights at each step (or none: the frame's).
type MotionSteps<'a> = (u32, &'a [FrameCamera], &'a [Vec<FrameLight>]);

/// The path tracer of one scene on one device.
pub struct PathTracer<'d> {
    device: &'d Device,
    settings: RenderSettings,
    /// The film's options compiled in, from `settings`: which of the
    /// optional buffers below a frame clears, binds and reads.
    film: FilmFeatures,
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
    /// The frame's light tree, built on the device (`light_tree::device`):
    /// its node count (0 without one), root power and which punctual lights
    /// it holds.
    light_tree: FrameLightTree,
    /// The light tree's kernels, compiled for the first frame that has one.
    light_tree_builder: Option<LightTreeBuilder>,
    /// The wall time of the last frame's light tree build (`None`: no tree).
    light_tree_ms: Option<f64>,
    /// The frame's emitters' extent over the scene's (`emitter_spread`).
    emitter_spread: Option<f32>,
    light_nodes: GrowBuffer<DeviceLightNode>,
    /// Each emissive triangle's trail in the light tree, by triangle.
    emit_trails: GrowBuffer<u32>,
    /// The frame's lights as uploaded (with motion, at every step).
    host_lights: Vec<DeviceLight>,
    power: GrowBuffer<f32>,
    power_host: Vec<f32>,
    /// The textured emitters' factors, kept while their inputs stay.
    texture_factors: emitters::TextureFactors,
    /// Counts `set_materials` calls: the texture factors' key.
    materials_generation: u64,
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
    /// With `--cryptomatte`: the scene's matte names and each triangle's
    /// pair on the device (`set_mattes`), and the per-pixel slots.
    mattes: Option<(MatteTable, Buffer<u32>)>,
    matte_slots: GrowBuffer<[u32; 2]>,
    /// With `--aov motion`: the soup and the camera at each vector step
    /// (`set_vector_step`), the steps set since the last frame (bits) for
    /// how many triangles, and the per-pixel sums.
    vector_positions: GrowBuffer<[f32; 4]>,
    vector_cameras: Buffer<VectorCamera>,
    /// The host copy of `vector_cameras`, so setting a step writes it
    /// without reading the others back.
    vector_cameras_host: [VectorCamera; VECTOR_STEPS],
    vector_steps: (u8, usize),
    accum_motion: GrowBuffer<[f32; 4]>,
    /// With shadow catchers or holdouts: each triangle's flags on the
    /// device (and how many), and three sums per pixel.
    triangle_flags: Option<(Buffer<u32>, usize)>,
    accum_catcher: GrowBuffer<[f32; 4]>,
    /// With `--aov position` or `uv`: two sums per pixel.
    accum_geometry: GrowBuffer<[f32; 4]>,
    accum_light: GrowBuffer<f32>,
    /// The accumulators read back, reused from frame to frame.
    readback: Accumulated,
    /// Written frames' images, whose buffers the next resolve fills.
    spare_images: Option<SpareImages>,
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

    /// The last frame's emissive triangles' extent as a fraction of the
    /// scene's (the diagonals of their bounds), which decides whether the
    /// light tree holds them by default (`EMITTER_SPREAD_MIN`); `None`
    /// without emitters or where `--no-light-tree` left them ungathered.
    pub fn emitter_spread(&self) -> Option<f32> {
        self.emitter_spread
    }

    /// The wall time of the last frame's light tree build on the device,
    /// its leaves to its root (`None` without a tree).
    pub fn light_tree_ms(&self) -> Option<f64> {
        self.light_tree_ms
    }

    /// How the last frame's light samples chose among its lights
    /// (`RenderLog::light_selection`).
    pub fn light_selection(&self) -> &'static str {
        if self.light_tree.built.holds_emitters {
            "tree"
        } else if self.light_tree.built.nodes > 0 {
            "tree for point lights"
        } else {
            "power"
        }
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
        // The nodes' own compositing roles join the command line's.
        let settings = &RenderSettings {
            roles: settings.roles.with_extras_of(scene),
            ..settings.clone()
        };
        let mut tracer =
            Self::with_animated_materials(device, scene.materials(), &animated, settings)?;
        if tracer.film.matte_slots.is_some() {
            tracer.set_mattes(MatteTable::of(scene))?;
        }
        if let Some(flags) = triangle_flags(scene, &settings.roles) {
            let mut buf = device.buffer::<u32>(flags.len().max(1))?;
            if !flags.is_empty() {
                device.write(&mut buf, &flags)?;
            }
            tracer.triangle_flags = Some((buf, flags.len()));
        }
        Ok(tracer)
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
        check_settings(settings)?;
        let mut warnings = Vec::new();
        let mut host_materials = host_materials(table, settings);

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
        let lobes = Lobes::of(features_of);
        let mut host_exts =
            (transmission || !lobes.is_empty()).then(|| device_material_exts(table));
        let slots = &texture_slots(transmission, &lobes)[..];

        // Textures: only when some material samples one (and not in clay
        // mode, where only alpha cut-outs would need them: those are kept).
        let textures = upload_textures(
            device,
            table,
            slots,
            &mut host_materials,
            host_exts.as_deref_mut(),
            &mut warnings,
        )?;

        // Clay is a pure Lambertian: no GGX lobe to compensate.
        let compensation = settings.energy_compensation && !settings.clay;
        let layering = if settings.clay {
            Layering::Spec
        } else {
            settings.layering
        };
        let features = material_features(features_of, textures.is_some(), compensation, layering);
        let defines = pathtrace_defines(
            settings.traversal,
            textures.is_some(),
            settings.sampler,
            transmission,
            compensation,
            features_of.materials.iter().any(|m| m.unlit),
            lobes,
        );
        let defines = layering_defines(defines, layering);
        let film = FilmFeatures::of(settings);
        let defines = film_defines(defines, &film);
        let kernels = Kernels::build(device, &defines)?;

        let (materials, material_exts) = upload_materials(device, &host_materials, host_exts)?;
        let any_emissive = host_materials.iter().any(DeviceMaterial::emits);

        let env_map = environment_map(device, settings)?;

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
            film,
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
            light_tree: FrameLightTree::default(),
            light_tree_builder: None,
            light_tree_ms: None,
            emitter_spread: None,
            light_nodes: GrowBuffer::new(),
            emit_trails: GrowBuffer::new(),
            host_lights: Vec::new(),
            power: GrowBuffer::new(),
            power_host: Vec::new(),
            texture_factors: emitters::TextureFactors::new(),
            materials_generation: 0,
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
            mattes: None,
            matte_slots: GrowBuffer::new(),
            vector_positions: GrowBuffer::new(),
            vector_cameras: device.buffer(VECTOR_STEPS)?,
            vector_cameras_host: [VectorCamera::default(); VECTOR_STEPS],
            vector_steps: (0, 0),
            accum_motion: GrowBuffer::new(),
            triangle_flags: None,
            accum_catcher: GrowBuffer::new(),
            accum_geometry: GrowBuffer::new(),
            accum_light: GrowBuffer::new(),
            readback: Accumulated::default(),
            spare_images: None,
        })
    }

    /// The scene's matte names, for `--cryptomatte`: its triangles' pairs
    /// go to the device once, as the soup's triangle order never changes.
    pub fn set_mattes(&mut self, table: MatteTable) -> Result<(), TraceError> {
        let mut pairs = self
            .device
            .buffer::<u32>(table.triangle_pairs.len().max(1))?;
        if !table.triangle_pairs.is_empty() {
            self.device.write(&mut pairs, &table.triangle_pairs)?;
        }
        self.mattes = Some((table, pairs));
        Ok(())
    }

    /// Keeps `soup` as it is now, and `camera`, as motion-vector step
    /// `step` (`--aov motion`; `trace::vectors`): 0 a frame before the
    /// frame's centre, 1 at it, 2 a frame after. Each frame needs all three.
    pub fn set_vector_step(
        &mut self,
        step: usize,
        soup: &DeviceSoup,
        camera: &FrameCamera,
    ) -> Result<(), TraceError> {
        assert!(step < VECTOR_STEPS, "vector step {step}");
        let d = self.device;
        let n3 = 3 * soup.triangle_count();
        if self.vector_steps.1 != soup.triangle_count() {
            self.vector_steps = (0, soup.triangle_count());
        }
        let positions = self
            .vector_positions
            .ensure(d, (VECTOR_STEPS * n3).max(1))?;
        if n3 > 0 {
            d.copy(soup.positions(), positions, step * n3, n3)?;
        }
        let (w, h) = (self.settings.width, self.settings.height);
        self.vector_cameras_host[step] = vector_camera(&device_camera(camera, w, h), w, h);
        d.write(&mut self.vector_cameras, &self.vector_cameras_host)?;
        self.vector_steps.0 |= 1 << step;
        Ok(())
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
        self.materials_generation += 1;
        Ok(())
    }

    /// Frames so far whose textured emitters' factors were computed, and
    /// kept from the frame before (for tests and tools).
    pub fn emitter_texture_factor_frames(&self) -> (u64, u64) {
        (self.texture_factors.computed, self.texture_factors.reused)
    }

    /// Fills each frame's image in the buffers of the images `spare` hands
    /// back (`film::SpareImages`).
    pub fn reuse_images(&mut self, spare: SpareImages) {
        self.spare_images = Some(spare);
    }

    /// Changes how frames are cut into launches (the image does not change).
    pub fn set_schedule(&mut self, schedule: Schedule) {
        self.schedule = schedule;
    }

    /// `--focus-on`: the lens's focus for the frames that follow (a pinhole
    /// camera ignores it).
    pub fn set_focus_distance(&mut self, distance: f32) {
        if let Some(lens) = &mut self.settings.lens {
            lens.focus_distance = distance;
        }
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
        let soup = SoupBuffers::of(frame.soup, frame.soup.positions(), frame.soup.normals());
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
        let soup = SoupBuffers::of(frame.soup, motion.positions, motion.normals);
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
        // The kernel reads every vector step of every triangle it hits.
        if self.film.vectors {
            let all = (1u8 << VECTOR_STEPS) - 1;
            if self.vector_steps != (all, soup.triangles) {
                return Err(usage(format!(
                    "--aov motion needs the soup at each of the {VECTOR_STEPS} vector steps of this \
                     frame (PathTracer::set_vector_step)"
                )));
            }
        }
        // The kernel reads the flags of every triangle a camera ray hits.
        if self.film.catcher {
            let flags = self.triangle_flags.as_ref().map(|(_, n)| *n);
            if flags != Some(soup.triangles) {
                return Err(usage(format!(
                    "--shadow-catcher and --holdout need the flags of the scene's {} triangles, which \
                     only a tracer made for the scene (PathTracer::new) has",
                    soup.triangles
                )));
            }
        }
        // The kernel reads a matte pair for every triangle it hits.
        if self.film.matte_slots.is_some() {
            let pairs = self.mattes.as_ref().map(|(t, _)| t.triangle_pairs.len());
            if pairs != Some(soup.triangles) {
                return Err(usage(format!(
                    "--cryptomatte needs the matte names of the scene's {} triangles (PathTracer::set_mattes), \
                     but has them for {}",
                    soup.triangles,
                    pairs.map_or("none".to_owned(), |n| n.to_string())
                )));
            }
        }
        let mut warnings = std::mem::take(&mut self.setup_warnings);
        let (w, h) = (self.settings.width, self.settings.height);
        let pixels = w as usize * h as usize;

        // An empty soup has an empty tree: nothing can be hit, and the stack
        // traversal gets an empty root to read.
        let empty = soup.triangles == 0 || bvh.nodes.is_empty();
        self.upload_lights(lights, motion)?;
        let flags = self.frame_flags(soup);
        let emit = self.upload_emitters(soup, flags)?;
        self.upload_light_tree(soup, bvh, lights.len(), &emit, motion.map_or(1, |m| m.0))?;
        let env = self.upload_environment(lights, &mut warnings)?;
        self.warn_missing_uvs(soup, &mut warnings);
        let frame = FrameTables {
            lights,
            emit: &emit,
            env: &env,
            flags,
            sampler_frame: self.settings.noise_pattern.sampler_frame(frame_index),
        };
        self.upload_frame(bvh, &frame)?;
        let motion_steps = self.upload_cameras(camera, motion)?;
        // With motion blur the kernel interpolates each ray's corners, so the
        // wide layouts gather only their slots' triangles.
        let snode_count =
            self.upload_tree(bvh, empty, soup.positions, prim_ids, motion_steps.is_none())?;

        let first_event = self.clear_accumulators(pixels)?;
        let passes = self.run_passes(soup, prim_ids, snode_count, empty, motion_steps, progress)?;
        let trace_ms = self.device_ms_since(first_event);

        self.read_accumulators(pixels)?;
        let accumulated = &self.readback;
        let spare = self.spare_images.as_ref().and_then(SpareImages::take);
        let resolved = film::resolve(
            accumulated,
            w,
            h,
            self.settings.aovs,
            self.settings.cryptomatte.as_ref(),
            self.mattes.as_ref().map(|(table, _)| table),
            spare,
        );
        if resolved.dropped > 0 {
            warnings.push(format!(
                "path tracing: dropped {} of {} samples with NaN or infinite values",
                resolved.dropped, resolved.taken
            ));
        }
        let noise = passes.noise_stats(
            self.settings.adaptive,
            &accumulated.rays,
            &resolved.estimates,
            &resolved.counts,
        );
        let rays = accumulated.rays.clone();
        Ok(RenderOutput {
            image: resolved.image,
            rays: rays.iter().map(|&r| r as u64).sum(),
            pixel_rays: rays,
            trace_ms,
            noise,
            warnings,
        })
    }
}
