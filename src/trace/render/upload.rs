//! What the path tracer uploads for a scene and for each frame: the camera
//! and per-frame constants (`PtCamera`, `PtFrame`), the materials' texture
//! bindings, the environment map, the tree, the lights and the emissive
//! triangles' power distribution.

use bytemuck::{Pod, Zeroable};
use glam::Vec3;
use opencl3::memory::Buffer;

use super::{usage, FrameLightTree, MotionSteps, PathTracer, SoupBuffers};
use crate::bvh::Bvh;
use crate::device::Device;
use crate::device_struct::{device_consts, device_struct};
use crate::scene::FrameCamera;
use crate::scene::FrameLight;
use crate::trace::camera::{device_camera, with_lens, DeviceCamera};
use crate::trace::device::LeafSource;
use crate::trace::light_tree::{self, device::LightTreeBuilder, device::LightTreeInputs};
use crate::trace::lights::{
    environment_power, punctual_power, DeviceLight, EmissiveDistribution, LightSelection,
    ENV_CONSTANT, ENV_NONE,
};
use crate::trace::lights::{DeviceEnv, EnvMap, ENV_MAP, LOOPED_PUNCTUAL_MAX};
use crate::trace::material::{DeviceMaterial, DeviceMaterialExt};
use crate::trace::settings::{Environment, LightTreeUse, Traversal, EMITTER_SPREAD_MIN};
use crate::trace::texture::{Slot, TextureBinding, TextureSet};
use crate::trace::TraceError;

device_struct! {
/// Per-frame constants. Next-event estimation at a path vertex samples every
/// punctual light when `light_loop` is set, then one light drawn from the
/// selection distribution (`select_cdf`, `select_count` entries in this
/// order: the punctual lights unless looped, the light tree as one entry
/// when `light_tree` (its node count) is not 0, the emissive triangles as
/// one entry when there are any, the environment when it is sampled).
/// `emit_select_pmf` and `env_select_pmf` are the probabilities of choosing
/// the emissive triangles (or the tree that holds them) and the environment
/// (0 when not an entry), which MIS needs when a BSDF-sampled ray hits them.
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
    /// The light tree's node count: 0 when it is not an entry.
    pub light_tree: u32,
    /// 1 when the emitters are in the light tree (not an entry of their
    /// own); `emit_select_pmf` is then the tree's probability.
    pub emit_tree: u32,
    pub pad: [u32; 3],
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

/// The texture bindings of `materials` in `set`: four per material
/// (`PtMaterial`), then `Slot::EXT.len()` per material for `PtMaterialExt`
/// when compiled in (those of slots outside the set's stay -1). The
/// materials' records get their binding indices.
pub(super) fn bind_textures(
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
            for (j, slot) in Slot::EXT.into_iter().enumerate() {
                x.tex[j] = bind(m, slot, at + j);
            }
        }
    }
    bindings
}

/// An environment map on the device: its record, texels and CDFs.
/// The map's device form, texels, marginal and conditional CDFs, and mean
/// luminance.
pub(super) type EnvBuffers = (DeviceEnv, Buffer<[f32; 4]>, Buffer<f32>, Buffer<f32>, f32);

/// An environment map on the device, with its sampling tables.
pub(super) fn upload_env_map(device: &Device, map: &EnvMap) -> Result<EnvBuffers, TraceError> {
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

/// What a frame's constants are made of, besides the settings.
pub(super) struct FrameTables<'a> {
    pub lights: &'a [FrameLight],
    pub emit: &'a EmissiveDistribution,
    pub env: &'a DeviceEnv,
    /// `PtFrame.flags`: the soup's attributes and `--clay`.
    pub flags: u32,
    /// The frame number the sampler is keyed by (`NoisePattern`).
    pub sampler_frame: i64,
}

impl PathTracer<'_> {
    /// The frame's tree in the traversal's layout, a wide one with its
    /// leaves gathered from `positions` through `prim_ids` (their corners
    /// too with `with_tris`); the stackless layout's entry count (0 for the
    /// others).
    pub(super) fn upload_tree(
        &mut self,
        bvh: &Bvh,
        empty: bool,
        positions: &Buffer<[f32; 4]>,
        prim_ids: &Buffer<u32>,
        with_tris: bool,
    ) -> Result<u32, TraceError> {
        let d = self.device;
        let leaves = LeafSource {
            gather: &self.kernels.leaf_gather,
            positions,
            prim_ids,
            with_tris,
        };
        let snode_count = match self.settings.traversal {
            _ if empty => {
                self.layouts.upload_empty(d)?;
                0
            }
            Traversal::Stack => {
                self.layouts.upload_binary(d, bvh)?;
                0
            }
            Traversal::Wide | Traversal::Wide8 => {
                self.layouts
                    .upload_wide(d, bvh, self.settings.traversal, &leaves)?;
                0
            }
            Traversal::Stackless => self.layouts.upload_stackless(d, bvh)?.entries as u32,
        };
        self.layouts.ensure_all(d)?;
        Ok(snode_count)
    }

    /// The punctual lights: the frame's, or with motion every light at each
    /// step, step after step (`pt_light`).
    pub(super) fn upload_lights(
        &mut self,
        lights: &[FrameLight],
        motion: Option<MotionSteps>,
    ) -> Result<(), TraceError> {
        let d = self.device;
        let mut host_lights: Vec<DeviceLight> =
            lights.iter().map(DeviceLight::from_frame_light).collect();
        if let Some((steps, _, step_lights)) = motion {
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
        self.host_lights = host_lights;
        Ok(())
    }

    /// The light tree over the point and spot lights (when there are more
    /// than are looped over) and the emitters `emit` of `soup` at each of
    /// its `steps` motion steps, built on the device with each emitter's
    /// trail, as `settings.light_tree` asks (`LightTreeUse`; `bvh` bounds
    /// the scene); `--no-light-tree` leaves it empty.
    pub(super) fn upload_light_tree(
        &mut self,
        soup: &SoupBuffers,
        bvh: &Bvh,
        light_count: usize,
        emit: &EmissiveDistribution,
        steps: u32,
    ) -> Result<(), TraceError> {
        let d = self.device;
        let use_tree = self.settings.light_tree;
        let on = use_tree != LightTreeUse::Never;
        let punctual = if on && light_count > LOOPED_PUNCTUAL_MAX {
            light_count
        } else {
            0
        };
        let emitters = if on { emit.prims.len() } else { 0 };
        self.light_tree = FrameLightTree::default();
        self.emitter_spread = None;
        self.light_tree_ms = None;
        // The render kernel takes both whether or not there is a tree.
        self.light_nodes.ensure(d, 1)?;
        self.emit_trails.ensure(d, soup.triangles.max(1))?;
        if punctual == 0 && emitters == 0 {
            return Ok(());
        }
        let start = std::time::Instant::now();
        let builder = match &mut self.light_tree_builder {
            Some(b) => b,
            None => self.light_tree_builder.insert(LightTreeBuilder::new(d)?),
        };
        let light_steps = self.host_lights.len().checked_div(light_count).unwrap_or(1);
        let boxes = builder.make_leaves(
            d,
            &LightTreeInputs {
                positions: soup.positions,
                triangles: soup.triangles as u32,
                steps: steps.max(1),
                material_ids: soup.material_ids,
                materials: &self.materials,
                material_count: self.material_count,
                prims: self.emit_prims.buffer().unwrap_or(&self.dummy_u32),
                emitters: emitters as u32,
                power: self.power.buffer().unwrap_or(&self.dummy_f32),
                lights: self.lights.get(),
                light_count: punctual as u32,
                light_steps: light_steps as u32,
            },
        )?;
        let scene = 2.0 * scene_radius(bvh);
        self.emitter_spread =
            (emitters > 0 && scene > 0.0).then(|| (boxes.emitters_extent() / scene).min(1.0));
        let with_emitters = emitters > 0
            && !(use_tree == LightTreeUse::Auto
                && self.emitter_spread.is_some_and(|s| s < EMITTER_SPREAD_MIN));
        let built = builder.build(
            d,
            with_emitters,
            self.emit_prims.buffer().unwrap_or(&self.dummy_u32),
            &mut self.light_nodes,
            self.emit_trails.get(),
        )?;
        let holds_light = (0..light_count)
            .map(|i| {
                built.nodes > 0
                    && punctual > 0
                    && light_tree::holds_light(&self.host_lights, light_count, i)
            })
            .collect();
        self.light_tree_ms = (built.nodes > 0).then(|| start.elapsed().as_secs_f64() * 1e3);
        self.light_tree = FrameLightTree { built, holds_light };
        Ok(())
    }

    /// The environment. The default: the studio sky unless the scene has
    /// punctual lights of its own (`Environment::Default`).
    pub(super) fn upload_environment(
        &mut self,
        lights: &[FrameLight],
        warnings: &mut Vec<String>,
    ) -> Result<DeviceEnv, TraceError> {
        let d = self.device;
        if matches!(self.settings.environment, Environment::Default) && lights.is_empty() {
            if self.env_map.is_none() {
                self.env_map = Some(upload_env_map(d, &EnvMap::studio_sky())?);
            }
            warnings.push(
                "the scene has no KHR_lights_punctual light: lit by soupray's default studio sky \
                 (pass --env-color R,G,B or --env FILE.exr to choose another, --env-color 0,0,0 for none)"
                    .to_owned(),
            );
        }
        let env = match (&self.settings.environment, &self.env_map) {
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
        Ok(env)
    }

    /// `PtFrame.flags`: the attributes the soup carries, and `--clay`.
    pub(super) fn frame_flags(&self, soup: &SoupBuffers) -> u32 {
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
        }
        if self.settings.clay {
            flags |= FRAME_CLAY;
        }
        flags
    }

    /// Warns when an anisotropic material has no TEXCOORD_0 to give its
    /// direction.
    pub(super) fn warn_missing_uvs(&self, soup: &SoupBuffers, warnings: &mut Vec<String>) {
        if soup.uvs.is_none() && self.features.contains(&"anisotropy") {
            warnings.push(
                "a material uses KHR_materials_anisotropy but the scene has no TEXCOORD_0: the \
                 anisotropy direction, which is given in the tangent frame of the texture \
                 coordinates, is arbitrary (export the meshes with UVs)"
                    .to_owned(),
            );
        }
    }

    /// The frame's constants (`PtFrame`), with the distribution next-event
    /// estimation draws lights from, by estimated power.
    pub(super) fn upload_frame(&mut self, bvh: &Bvh, f: &FrameTables) -> Result<(), TraceError> {
        let d = self.device;
        let s = &self.settings;
        let radius = scene_radius(bvh);
        let punctual: Vec<f64> = f.lights.iter().map(|l| punctual_power(l, radius)).collect();
        let env_power = match f.env.kind {
            ENV_MAP => Some(environment_power(
                self.env_map.as_ref().map_or(0.0, |m| m.4),
                radius,
            )),
            _ => None,
        };
        let built = self.light_tree.built;
        let mut in_tree = vec![false; f.lights.len()];
        for (i, &held) in self.light_tree.holds_light.iter().enumerate() {
            if let Some(slot) = in_tree.get_mut(i) {
                *slot = held;
            }
        }
        let emit_tree = built.holds_emitters;
        let tree = (built.nodes > 0).then_some(built.root_phi as f64);
        let selection = LightSelection::new(
            &punctual,
            tree.map(|power| (power, in_tree.as_slice())),
            (!f.emit.is_empty() && !emit_tree).then_some(f.emit.power),
            env_power,
        );
        d.write(
            self.select_cdf.ensure(d, selection.cdf.len())?,
            &selection.cdf,
        )?;
        let fr = DeviceFrame {
            seed_lo: s.seed as u32,
            seed_hi: (s.seed >> 32) as u32,
            frame_lo: f.sampler_frame as u64 as u32,
            frame_hi: ((f.sampler_frame as u64) >> 32) as u32,
            width: s.width,
            height: s.height,
            max_depth: s.max_depth,
            flags: f.flags,
            light_count: f.lights.len() as u32,
            emit_count: f.emit.prims.len() as u32,
            material_count: self.material_count,
            select_count: selection.count(),
            light_loop: selection.loop_punctual as u32,
            emit_select_pmf: if emit_tree {
                selection.tree_pmf
            } else {
                selection.emit_pmf
            },
            env_select_pmf: selection.env_pmf,
            light_tree: if selection.tree { built.nodes } else { 0 },
            emit_tree: emit_tree as u32,
            pad: [0; 3],
        };
        d.write(&mut self.frame, &[fr])?;
        Ok(())
    }

    /// The camera, and with motion the camera at each step; the motion
    /// step count.
    pub(super) fn upload_cameras(
        &mut self,
        camera: &FrameCamera,
        motion: Option<MotionSteps>,
    ) -> Result<Option<u32>, TraceError> {
        let d = self.device;
        let (w, h) = (self.settings.width, self.settings.height);
        let lens = self.settings.lens.as_ref();
        d.write(
            &mut self.camera,
            &[with_lens(device_camera(camera, w, h), lens)],
        )?;
        let Some((steps, cameras, _)) = motion else {
            return Ok(None);
        };
        if steps < 2 || cameras.len() != steps as usize || self.motion_kernels.is_none() {
            return Err(usage(format!(
                "a motion frame needs at least 2 steps, one camera per step and the motion program \
                 (prepare_motion); got {steps} steps and {} cameras",
                cameras.len()
            )));
        }
        let cams: Vec<DeviceCamera> = cameras
            .iter()
            .map(|c| with_lens(device_camera(c, w, h), lens))
            .collect();
        d.write(self.motion_cameras.ensure(d, cams.len())?, &cams)?;
        Ok(Some(steps))
    }
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
