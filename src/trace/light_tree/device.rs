//! The light tree's build on the device, each frame (`kernels/trace/
//! light_tree.cl`, whose steps [`super::build`] takes on the host): the
//! leaves from the soup's emitters and the frame's lights, their Morton
//! keys, a bitonic sort, each leaf into its heap slot, and the inner nodes
//! one level at a time from the bottom. The host reads back only the
//! partial boxes it folds into the Morton grid (and the emitters'
//! extent, which decides whether they belong in the tree) and the root.

use glam::Vec3;
use opencl3::kernel::Kernel;
use opencl3::memory::Buffer;
use opencl3::program::Program;

use super::{morton_grid, DeviceLightNode};
use crate::device::{Arg, Device, GrowBuffer, Result};
use crate::trace::lights::DeviceLight;
use crate::trace::material::DeviceMaterial;

/// Work-items of `lt_bounds`: each folds every 1024th leaf.
const BOUNDS_ITEMS: usize = 1024;

/// The light tree's kernels and working buffers, kept from frame to frame.
pub struct LightTreeBuilder {
    leaves_kernel: Kernel,
    bounds_kernel: Kernel,
    keys_kernel: Kernel,
    sort_kernel: Kernel,
    place_kernel: Kernel,
    refit_kernel: Kernel,
    _program: Program,
    leaves: GrowBuffer<DeviceLightNode>,
    partial: GrowBuffer<f32>,
    keys: GrowBuffer<u64>,
    /// The leaves made by the last `make_leaves`: emitters, then lights.
    emitters: u32,
    lights: u32,
    boxes: LeafBoxes,
}

/// The frame's emissive triangles and lights, as the leaves take them.
pub struct LightTreeInputs<'a> {
    /// The soup's corners, three per triangle (xyz, w unused), at each of
    /// `steps` motion steps, step after step.
    pub positions: &'a Buffer<[f32; 4]>,
    pub triangles: u32,
    pub steps: u32,
    pub material_ids: &'a Buffer<u32>,
    pub materials: &'a Buffer<DeviceMaterial>,
    pub material_count: u32,
    /// The emitters' triangles (`emitters` of them) and every triangle's
    /// power (`pt_emissive_power`: the tree's units over π).
    pub prims: &'a Buffer<u32>,
    pub emitters: u32,
    pub power: &'a Buffer<f32>,
    /// `light_count` lights, then the same lights at each further step
    /// (`light_steps` in all).
    pub lights: &'a Buffer<DeviceLight>,
    pub light_count: u32,
    pub light_steps: u32,
}

/// The boxes folded from `lt_bounds`: of the emitters' bounds, and of the
/// emitters' and the lights' centres (empty: lo > hi). Leaves that send
/// nothing are left out.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LeafBoxes {
    pub emitters: (Vec3, Vec3),
    pub emitter_centres: (Vec3, Vec3),
    pub light_centres: (Vec3, Vec3),
}

impl LeafBoxes {
    const EMPTY: (Vec3, Vec3) = (Vec3::INFINITY, Vec3::NEG_INFINITY);

    /// The diagonal of the emitters' box, 0 without one.
    pub fn emitters_extent(&self) -> f32 {
        let (lo, hi) = self.emitters;
        if lo.cmple(hi).all() {
            (hi - lo).length()
        } else {
            0.0
        }
    }
}

/// What the host needs of a built tree: its node count (0: no tree, when
/// nothing in it sends light) and its root's power.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct BuiltTree {
    pub nodes: u32,
    pub root_phi: f32,
    pub holds_emitters: bool,
}

impl LightTreeBuilder {
    pub fn new(device: &Device) -> Result<LightTreeBuilder> {
        let program = device.build_program("light_tree.cl", &[])?;
        Ok(LightTreeBuilder {
            leaves_kernel: device.kernel(&program, "lt_leaves")?,
            bounds_kernel: device.kernel(&program, "lt_bounds")?,
            keys_kernel: device.kernel(&program, "lt_keys")?,
            sort_kernel: device.kernel(&program, "lt_sort")?,
            place_kernel: device.kernel(&program, "lt_place")?,
            refit_kernel: device.kernel(&program, "lt_refit")?,
            _program: program,
            leaves: GrowBuffer::new(),
            partial: GrowBuffer::new(),
            keys: GrowBuffer::new(),
            emitters: 0,
            lights: 0,
            boxes: LeafBoxes {
                emitters: LeafBoxes::EMPTY,
                emitter_centres: LeafBoxes::EMPTY,
                light_centres: LeafBoxes::EMPTY,
            },
        })
    }

    /// Makes the leaves of `inputs`' emitters and lights, and folds their
    /// boxes.
    pub fn make_leaves(&mut self, d: &Device, inputs: &LightTreeInputs) -> Result<LeafBoxes> {
        let total = inputs.emitters as usize + inputs.light_count as usize;
        self.emitters = inputs.emitters;
        self.lights = inputs.light_count;
        let leaves = self.leaves.ensure(d, total.max(1))?;
        d.launch(
            "light_tree",
            &self.leaves_kernel,
            total.div_ceil(64),
            64,
            &[
                Arg::Buf(inputs.positions),
                Arg::U32(inputs.triangles),
                Arg::U32(inputs.steps),
                Arg::Buf(inputs.material_ids),
                Arg::Buf(inputs.materials),
                Arg::U32(inputs.material_count),
                Arg::Buf(inputs.prims),
                Arg::U32(inputs.emitters),
                Arg::Buf(inputs.power),
                Arg::Buf(inputs.lights),
                Arg::U32(inputs.light_count),
                Arg::U32(inputs.light_steps),
                Arg::Buf(&*leaves),
            ],
        )?;
        let items = BOUNDS_ITEMS.min(total.div_ceil(64) * 64).max(64);
        let partial = self.partial.ensure(d, 18 * items)?;
        d.launch(
            "light_tree",
            &self.bounds_kernel,
            items / 64,
            64,
            &[
                Arg::Buf(self.leaves.get()),
                Arg::U32(inputs.emitters),
                Arg::U32(total as u32),
                Arg::Buf(&*partial),
            ],
        )?;
        let mut host = vec![0.0f32; 18 * items];
        d.read(partial, &mut host)?;
        let mut boxes = [LeafBoxes::EMPTY; 3];
        for p in host.chunks_exact(18) {
            for (k, b) in boxes.iter_mut().enumerate() {
                let v = |j: usize| {
                    Vec3::new(p[6 * k + 3 * j], p[6 * k + 3 * j + 1], p[6 * k + 3 * j + 2])
                };
                b.0 = b.0.min(v(0));
                b.1 = b.1.max(v(1));
            }
        }
        self.boxes = LeafBoxes {
            emitters: boxes[0],
            emitter_centres: boxes[1],
            light_centres: boxes[2],
        };
        Ok(self.boxes)
    }

    /// Builds the tree over the leaves of the last `make_leaves` (the
    /// emitters' only with `with_emitters`) into `nodes`, each emitter's
    /// trail into `trails` (by triangle; `prims` names them).
    pub fn build(
        &mut self,
        d: &Device,
        with_emitters: bool,
        prims: &Buffer<u32>,
        nodes: &mut GrowBuffer<DeviceLightNode>,
        trails: &Buffer<u32>,
    ) -> Result<BuiltTree> {
        let first = if with_emitters { 0 } else { self.emitters };
        let count = self.emitters + self.lights - first;
        let (mut lo, mut hi) = self.boxes.light_centres;
        if with_emitters {
            lo = lo.min(self.boxes.emitter_centres.0);
            hi = hi.max(self.boxes.emitter_centres.1);
        }
        // Nothing sends light, or more leaves than a trail can name.
        if count == 0 || count > 1 << 30 || !lo.cmple(hi).all() {
            return Ok(BuiltTree::default());
        }
        let (lo, scale) = morton_grid(lo, hi);
        let padded = count.next_power_of_two() as usize;
        let local = padded.min(64);
        let keys = self.keys.ensure(d, padded)?;
        let leaves = self.leaves.get();
        d.launch(
            "light_tree",
            &self.keys_kernel,
            padded / local,
            local,
            &[
                Arg::Buf(leaves),
                Arg::U32(first),
                Arg::U32(count),
                Arg::U32(padded as u32),
                Arg::F32(lo.x),
                Arg::F32(lo.y),
                Arg::F32(lo.z),
                Arg::F32(scale.x),
                Arg::F32(scale.y),
                Arg::F32(scale.z),
                Arg::Buf(&*keys),
            ],
        )?;
        let mut k = 2;
        while k <= padded {
            let mut j = k / 2;
            while j > 0 {
                d.launch(
                    "light_tree",
                    &self.sort_kernel,
                    padded / local,
                    local,
                    &[Arg::Buf(&*keys), Arg::U32(j as u32), Arg::U32(k as u32)],
                )?;
                j /= 2;
            }
            k *= 2;
        }
        let node_count = 2 * count - 1;
        let nodes = nodes.ensure(d, node_count as usize)?;
        d.launch(
            "light_tree",
            &self.place_kernel,
            (count as usize).div_ceil(64),
            64,
            &[
                Arg::Buf(&*keys),
                Arg::Buf(leaves),
                Arg::U32(first),
                Arg::U32(count),
                Arg::Buf(prims),
                Arg::Buf(&*nodes),
                Arg::Buf(trails),
            ],
        )?;
        // The inner nodes 0 ..= count − 2, deepest level first: level L
        // holds 2^L − 1 ..= 2^(L+1) − 2.
        if count > 1 {
            let last = count - 2;
            let top_level = 31 - (last + 1).leading_zeros();
            for level in (0..=top_level).rev() {
                let begin = (1u32 << level) - 1;
                let end = ((1u32 << (level + 1)) - 2).min(last);
                let n = (end - begin + 1) as usize;
                d.launch(
                    "light_tree",
                    &self.refit_kernel,
                    n.div_ceil(64),
                    64,
                    &[Arg::Buf(&*nodes), Arg::U32(begin), Arg::U32(end)],
                )?;
            }
        }
        let mut root = [DeviceLightNode::default()];
        d.read(nodes, &mut root)?;
        if !(root[0].phi > 0.0) {
            return Ok(BuiltTree::default());
        }
        Ok(BuiltTree {
            nodes: node_count,
            root_phi: root[0].phi,
            holds_emitters: with_emitters && self.emitters > 0,
        })
    }
}
