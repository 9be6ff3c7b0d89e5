//! The light tree: a bounding-volume hierarchy over the punctual point and
//! spot lights and the emissive triangles, with the cone of each node's
//! emission directions (Conty Estevez & Kulla 2018, "Importance Sampling
//! of Many Lights with Adaptive Tree Splitting"; the bounds, importance and
//! traversal of pbrt-v4's `BVHLightSampler`). Next-event estimation walks
//! it from the root, choosing each child in proportion to its importance at
//! the shading point, so a point is lit mostly by the lights near it and
//! facing it instead of by all of them in proportion to their power.
//!
//! Built on the device each frame, beside the scene's tree, from the
//! frame's lights and emitters at every motion step, so that a moving light
//! stays inside its nodes' bounds for the whole shutter (`device`, the
//! kernels of `kernels/trace/light_tree.cl`). Its shape suits a parallel
//! build: the leaves sorted by the Morton code of their centres, then a
//! complete binary tree over them in heap order (node i's children are
//! 2i + 1 and 2i + 2), whose bounds are unions of its children's, one level
//! at a time from the leaves up. [`build`] is the plain Rust reference of
//! that build; `light_tree_pick` and `light_tree_pmf` in
//! `kernels/trace/lights.h` are the kernel twins of [`pick`] and
//! [`trail_pmf`]. Directional lights and the environment are not in the
//! tree: they stay entries of the frame's selection distribution
//! (`LightSelection`). A BSDF-sampled ray that hits an emitter needs the
//! probability that the tree would have chosen it from the previous vertex
//! (for MIS): each emitter's path from the root, its trail, gives it
//! without a search.

// `!(x > 0.0)` is meant: it is also true for NaN, as in the kernels.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::lights::{DeviceLight, LIGHT_DIRECTIONAL, LIGHT_SPOT};
use super::sampling::luminance;
use crate::device_struct::{device_consts, device_struct};

pub mod device;

device_consts! {
    fn light_tree_consts;
    /// `PtLightNode.child` of a leaf: this bit, and the light's index.
    pub const LIGHT_NODE_LEAF: u32 = 0x8000_0000;
    /// A leaf of an emissive triangle: also this bit, and the triangle's
    /// index among the frame's emitters (`emit_prims`).
    pub const LIGHT_NODE_EMITTER: u32 = 0x4000_0000;
}

device_struct! {
/// One node of the light tree: the bounds of its lights' positions, their
/// total power `phi` (the selection's units: luminance, in watts up to one
/// factor), and the cone of their emission: axis `w`, `cos_theta_o` the
/// cosine of its half-angle, `cos_theta_e` the cosine of the falloff angle
/// past it; `two_sided`: 1 where the cone is mirrored too (double-sided
/// emitters). `child`: an inner node's first child (the second follows
/// it), or `LIGHT_NODE_LEAF` and a leaf's light (or `LIGHT_NODE_EMITTER`
/// and emitter) index.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct DeviceLightNode as "PtLightNode" {
    pub lo: [f32; 3],
    pub phi: f32,
    pub hi: [f32; 3],
    pub cos_theta_o: f32,
    pub w: [f32; 3],
    pub cos_theta_e: f32,
    pub child: u32,
    pub two_sided: u32,
    pub pad: [u32; 2],
}
}

const _: () = assert!(std::mem::size_of::<DeviceLightNode>() == 64);

/// The bounds of a set of lights (pbrt-v4's `LightBounds`).
#[derive(Clone, Copy, Debug)]
struct LightBounds {
    lo: Vec3,
    hi: Vec3,
    phi: f32,
    w: Vec3,
    cos_theta_o: f32,
    cos_theta_e: f32,
    two_sided: bool,
}

/// The cone of directions around `a` of half-angle acos(`cos_a`) and the
/// one around `b` of acos(`cos_b`), in one cone (pbrt-v4's
/// `DirectionCone::Union`). `a` turns towards `b` by Rodrigues' formula,
/// as `lt_cone_union` in the kernels does.
fn cone_union(a: Vec3, cos_a: f32, b: Vec3, cos_b: f32) -> (Vec3, f32) {
    let pi = std::f32::consts::PI;
    let theta_a = cos_a.clamp(-1.0, 1.0).acos();
    let theta_b = cos_b.clamp(-1.0, 1.0).acos();
    let theta_d = a.dot(b).clamp(-1.0, 1.0).acos();
    if (theta_d + theta_b).min(pi) <= theta_a {
        return (a, cos_a);
    }
    if (theta_d + theta_a).min(pi) <= theta_b {
        return (b, cos_b);
    }
    let theta_o = 0.5 * (theta_a + theta_d + theta_b);
    if theta_o >= pi {
        return (Vec3::Z, -1.0);
    }
    // Axes parallel to rounding (the same emitter at two motion steps):
    // the cone around `a`, or every direction where they are opposite.
    let axis = a.cross(b);
    if axis.length_squared() == 0.0 {
        return if a.dot(b) > 0.0 {
            (a, theta_o.cos())
        } else {
            (Vec3::Z, -1.0)
        };
    }
    let k = axis.normalize();
    let turn = theta_o - theta_a;
    let (s, c) = (turn.sin(), turn.cos());
    let w = a * c + k.cross(a) * s + k * (k.dot(a) * (1.0 - c));
    (w.normalize(), theta_o.cos())
}

impl LightBounds {
    /// A leaf that sends nothing: a light the tree never chooses (a
    /// directional light, one without power, an emitter degenerate at some
    /// motion step). It keeps its place, so that every light and emitter
    /// has a leaf, and its importance is 0 everywhere.
    const NOTHING: LightBounds = LightBounds {
        lo: Vec3::ZERO,
        hi: Vec3::ZERO,
        phi: 0.0,
        w: Vec3::Z,
        cos_theta_o: 1.0,
        cos_theta_e: 0.0,
        two_sided: false,
    };

    /// Both bounds in one; the power is summed.
    fn merge(&self, o: &LightBounds) -> LightBounds {
        let (w, cos_theta_o) = cone_union(self.w, self.cos_theta_o, o.w, o.cos_theta_o);
        LightBounds {
            lo: self.lo.min(o.lo),
            hi: self.hi.max(o.hi),
            phi: self.phi + o.phi,
            w,
            cos_theta_o,
            cos_theta_e: self.cos_theta_e.min(o.cos_theta_e),
            two_sided: self.two_sided || o.two_sided,
        }
    }

    /// The bounds of a node over both children: one that sends nothing
    /// adds nothing (pbrt-v4's `Union`).
    fn union(&self, o: &LightBounds) -> LightBounds {
        if self.phi == 0.0 {
            *o
        } else if o.phi == 0.0 {
            *self
        } else {
            self.merge(o)
        }
    }

    fn node(&self, child: u32) -> DeviceLightNode {
        DeviceLightNode {
            lo: self.lo.to_array(),
            phi: self.phi,
            hi: self.hi.to_array(),
            cos_theta_o: self.cos_theta_o,
            w: self.w.to_array(),
            cos_theta_e: self.cos_theta_e,
            child,
            two_sided: self.two_sided as u32,
            pad: [0; 2],
        }
    }

    fn of_node(n: &DeviceLightNode) -> LightBounds {
        LightBounds {
            lo: Vec3::from(n.lo),
            hi: Vec3::from(n.hi),
            phi: n.phi,
            w: Vec3::from(n.w),
            cos_theta_o: n.cos_theta_o,
            cos_theta_e: n.cos_theta_e,
            two_sided: n.two_sided != 0,
        }
    }

    fn centre(&self) -> Vec3 {
        0.5 * (self.lo + self.hi)
    }
}

/// A point or spot light's power in the selection's units (as
/// `punctual_power`: luminance; a spot's as pbrt-v4's `SpotLight::Phi`).
pub fn device_light_power(l: &DeviceLight) -> f32 {
    let pi = std::f32::consts::PI;
    let lum = luminance(Vec3::from(l.intensity));
    let p = if l.kind == LIGHT_SPOT {
        let (cos_inner, cos_outer) = spot_cosines(l);
        2.0 * pi * lum * ((1.0 - cos_inner) + (cos_inner - cos_outer).max(0.0) / 2.0)
    } else {
        4.0 * pi * lum
    };
    if p.is_finite() && p > 0.0 {
        p
    } else {
        0.0
    }
}

/// A spot light's cosines where its falloff ends (inner: full intensity
/// within) and where it reaches zero (outer), from the falloff's scale and
/// offset: saturate(cos * scale + offset) is 1 at the inner cone, 0 at the
/// outer.
fn spot_cosines(l: &DeviceLight) -> (f32, f32) {
    if !(l.angle_scale > 0.0) || !l.angle_scale.is_finite() {
        return (1.0, -1.0);
    }
    let cos_outer = (-l.angle_offset / l.angle_scale).clamp(-1.0, 1.0);
    let cos_inner = ((1.0 - l.angle_offset) / l.angle_scale).clamp(cos_outer, 1.0);
    (cos_inner, cos_outer)
}

/// The bounds of light `steps[0]` over its motion steps (the same light at
/// each), `None` for a directional light or one that sends nothing.
fn light_bounds(steps: &[DeviceLight]) -> Option<LightBounds> {
    let mut out: Option<LightBounds> = None;
    for l in steps {
        if l.kind == LIGHT_DIRECTIONAL {
            return None;
        }
        let p = Vec3::from(l.position);
        let (w, cos_theta_o, cos_theta_e) = if l.kind == LIGHT_SPOT {
            let (cos_inner, cos_outer) = spot_cosines(l);
            let axis = Vec3::from(l.direction).normalize_or_zero();
            if axis == Vec3::ZERO {
                (Vec3::Z, -1.0, 0.0)
            } else {
                let theta_e = cos_outer.acos() - cos_inner.acos();
                (axis, cos_inner, theta_e.max(0.0).cos())
            }
        } else {
            (Vec3::Z, -1.0, 0.0)
        };
        let b = LightBounds {
            lo: p,
            hi: p,
            phi: device_light_power(l),
            w,
            cos_theta_o,
            cos_theta_e,
            two_sided: false,
        };
        out = Some(match out {
            // The same light at another time: its power is the largest.
            Some(a) => LightBounds {
                phi: a.phi.max(b.phi),
                ..a.merge(&b)
            },
            None => b,
        });
    }
    out.filter(|b| b.phi > 0.0 && b.lo.is_finite() && b.hi.is_finite())
}

/// Whether the light tree holds light `i` of `lights` (`count` lights,
/// then the same lights at each further motion step): a point or spot
/// light that sends something. The others stay entries of the frame's
/// selection.
pub fn holds_light(lights: &[DeviceLight], count: usize, i: usize) -> bool {
    let steps = lights.len().checked_div(count).unwrap_or(0);
    let at: Vec<DeviceLight> = (0..steps).map(|s| lights[s * count + i]).collect();
    light_bounds(&at).is_some()
}

/// An emissive triangle as the tree takes it: its corners at each motion
/// step (one step without motion), its power in the selection's units (π
/// times luminance times area, doubled when double-sided) and whether it
/// emits from both sides.
#[derive(Clone, Debug)]
pub struct EmissiveTriangle {
    pub corners: Vec<[Vec3; 3]>,
    pub power: f32,
    pub two_sided: bool,
}

/// The bounds of an emissive triangle over its steps: the corners' box and
/// the cone of its normals, each a hemisphere's emission (θe = π/2).
fn emitter_bounds(t: &EmissiveTriangle) -> Option<LightBounds> {
    let mut out: Option<LightBounds> = None;
    for c in &t.corners {
        let normal = (c[1] - c[0]).cross(c[2] - c[0]).normalize_or_zero();
        if normal == Vec3::ZERO || !normal.is_finite() {
            return None;
        }
        let b = LightBounds {
            lo: c[0].min(c[1]).min(c[2]),
            hi: c[0].max(c[1]).max(c[2]),
            phi: t.power,
            w: normal,
            cos_theta_o: 1.0,
            cos_theta_e: 0.0,
            two_sided: t.two_sided,
        };
        out = Some(match out {
            Some(a) => LightBounds {
                phi: a.phi,
                ..a.merge(&b)
            },
            None => b,
        });
    }
    out.filter(|b| b.phi > 0.0 && b.lo.is_finite() && b.hi.is_finite())
}

/// A frame's light tree: its nodes (node 0 the root; empty when nothing
/// is in it), and each emitter's trail, the turns from the root to its
/// leaf (bit k: 1 for the second child at depth k).
#[derive(Clone, Debug, Default)]
pub struct LightTree {
    pub nodes: Vec<DeviceLightNode>,
    pub emitter_trails: Vec<u32>,
}

/// The Morton code's bits per axis: 1024 cells along each side of the
/// leaves' centres' box.
pub const MORTON_BITS: u32 = 10;

/// The sort key of a leaf that sends nothing: after every Morton code.
const KEY_NOTHING: u32 = u32::MAX;

/// The quantization of the leaves' centres: the lower corner of their box
/// and, per axis, the cells per unit, the same along every axis (0 where
/// the box is a point). Cubic cells keep the box's shape: along a street
/// of lamps the upper splits all cut the street, as a split of the
/// longest axis would, instead of cutting its height and width as early.
/// The host computes it from the box (`lt_bounds`' partial boxes) and hands
/// it to `lt_keys`, so both sides quantize with the same numbers.
pub fn morton_grid(lo: Vec3, hi: Vec3) -> (Vec3, Vec3) {
    let cells = (1u32 << MORTON_BITS) as f32;
    let ext = (hi - lo).max_element();
    let scale = if ext > 0.0 { cells / ext } else { 0.0 };
    (lo, Vec3::splat(if scale.is_finite() { scale } else { 0.0 }))
}

/// `x`'s low 10 bits spread to every third bit.
fn spread_bits(mut x: u32) -> u32 {
    x &= 0x3ff;
    x = (x | (x << 16)) & 0x0300_00ff;
    x = (x | (x << 8)) & 0x0300_f00f;
    x = (x | (x << 4)) & 0x030c_30c3;
    (x | (x << 2)) & 0x0924_9249
}

/// The Morton code of centre `c` in the grid (`morton_grid`).
pub fn morton_code(c: Vec3, lo: Vec3, scale: Vec3) -> u32 {
    let top = ((1u32 << MORTON_BITS) - 1) as f32;
    let q = |a: usize| ((c[a] - lo[a]) * scale[a]).clamp(0.0, top) as u32;
    (spread_bits(q(0)) << 2) | (spread_bits(q(1)) << 1) | spread_bits(q(2))
}

/// The heap index of the leaf at position `s` of `n` sorted leaves in a
/// complete binary tree of 2n − 1 nodes: the deepest level's leaves come
/// first from the left, then those of the level above.
pub fn leaf_slot(s: u32, n: u32) -> u32 {
    let nodes = 2 * n - 1;
    let deepest = 1u32 << (31 - nodes.leading_zeros());
    let at_bottom = nodes + 1 - deepest;
    if s < at_bottom {
        deepest - 1 + s
    } else {
        n - 1 + (s - at_bottom)
    }
}

/// The trail of heap node `k`: the bits of k + 1 below its leading one
/// are the turns from the root, the first turn the highest.
pub fn heap_trail(k: u32) -> u32 {
    let path = k + 1;
    let depth = 31 - path.leading_zeros();
    let mut trail = 0;
    for d in 0..depth {
        trail |= ((path >> (depth - 1 - d)) & 1) << d;
    }
    trail
}

/// The light tree over the point and spot lights of `lights` (`count`
/// lights, then, with motion, the same lights at each further step) and
/// the emissive triangles `emitters`: the plain Rust reference of the
/// device's build (`device::LightTreeBuilder`), the same leaves, order and
/// unions. Every light and emitter has a leaf (payload: the light's index,
/// or `LIGHT_NODE_EMITTER` and the emitter's), the emitters' first; one
/// that sends nothing has a leaf of power 0, which the walk never takes.
/// The tree is empty when nothing in it sends light.
pub fn build(lights: &[DeviceLight], count: usize, emitters: &[EmissiveTriangle]) -> LightTree {
    let steps = lights.len().checked_div(count).unwrap_or(0);
    let mut leaves: Vec<DeviceLightNode> = emitters
        .iter()
        .enumerate()
        .map(|(k, t)| {
            emitter_bounds(t)
                .unwrap_or(LightBounds::NOTHING)
                .node(LIGHT_NODE_LEAF | LIGHT_NODE_EMITTER | k as u32)
        })
        .collect();
    leaves.extend((0..count).map(|i| {
        let at: Vec<DeviceLight> = (0..steps).map(|s| lights[s * count + i]).collect();
        light_bounds(&at)
            .unwrap_or(LightBounds::NOTHING)
            .node(LIGHT_NODE_LEAF | i as u32)
    }));
    let mut tree = LightTree {
        nodes: Vec::new(),
        emitter_trails: vec![0; emitters.len()],
    };
    let n = leaves.len();
    if !leaves.iter().any(|l| l.phi > 0.0) || n > 1 << 30 {
        return tree;
    }
    let (mut lo, mut hi) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for l in leaves.iter().filter(|l| l.phi > 0.0) {
        let c = LightBounds::of_node(l).centre();
        lo = lo.min(c);
        hi = hi.max(c);
    }
    let (lo, scale) = morton_grid(lo, hi);
    let mut keys: Vec<u64> = leaves
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let code = if l.phi > 0.0 {
                morton_code(LightBounds::of_node(l).centre(), lo, scale)
            } else {
                KEY_NOTHING
            };
            ((code as u64) << 32) | i as u64
        })
        .collect();
    keys.sort_unstable();
    tree.nodes = vec![DeviceLightNode::default(); 2 * n - 1];
    for (s, key) in keys.iter().enumerate() {
        let leaf = leaves[(*key & 0xffff_ffff) as usize];
        let slot = leaf_slot(s as u32, n as u32);
        tree.nodes[slot as usize] = leaf;
        if leaf.child & LIGHT_NODE_EMITTER != 0 {
            let k = (leaf.child & !(LIGHT_NODE_LEAF | LIGHT_NODE_EMITTER)) as usize;
            tree.emitter_trails[k] = heap_trail(slot);
        }
    }
    // The children come after their parent: from the last inner node
    // back, each is the union of two that are done.
    for i in (0..n - 1).rev() {
        let a = LightBounds::of_node(&tree.nodes[2 * i + 1]);
        let b = LightBounds::of_node(&tree.nodes[2 * i + 2]);
        tree.nodes[i] = a.union(&b).node(2 * i as u32 + 1);
    }
    tree
}

/// cos(max(θa − θb, 0)) from the sines and cosines.
fn cos_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        1.0
    } else {
        cos_a * cos_b + sin_a * sin_b
    }
}

/// sin(max(θa − θb, 0)) from the sines and cosines.
fn sin_sub_clamped(sin_a: f32, cos_a: f32, sin_b: f32, cos_b: f32) -> f32 {
    if cos_a > cos_b {
        0.0
    } else {
        sin_a * cos_b - cos_a * sin_b
    }
}

fn safe_sqrt(x: f32) -> f32 {
    x.max(0.0).sqrt()
}

/// How much the lights of node `n` may send to a surface at `p` with
/// normal `normal` (pbrt-v4's `LightBounds::Importance`): power over the
/// squared distance to the bounds' centre (no less than the squared
/// half-diagonal), times the bound on the emission cosine towards `p` and
/// on the incidence cosine at `p`. 0 only where no light of the node can
/// reach `p`: outside every spot's cone.
pub fn importance(n: &DeviceLightNode, p: Vec3, normal: Vec3) -> f32 {
    let (lo, hi) = (Vec3::from(n.lo), Vec3::from(n.hi));
    let pc = 0.5 * (lo + hi);
    let half_diagonal2 = 0.25 * (hi - lo).length_squared();
    let to = p - pc;
    let to2 = to.length_squared();
    let d2 = to2.max(half_diagonal2).max(1e-12);
    let wi = if to2 > 0.0 {
        to / to2.sqrt()
    } else {
        Vec3::ZERO
    };
    let mut cos_w = Vec3::from(n.w).dot(wi);
    if n.two_sided != 0 {
        cos_w = cos_w.abs();
    }
    let sin_w = safe_sqrt(1.0 - cos_w * cos_w);
    // The cone of directions from `p` to the bounds' sphere: all of them
    // from inside it.
    let cos_b = if to2 > half_diagonal2 {
        safe_sqrt(1.0 - half_diagonal2 / to2)
    } else {
        -1.0
    };
    let sin_b = safe_sqrt(1.0 - cos_b * cos_b);
    let sin_o = safe_sqrt(1.0 - n.cos_theta_o * n.cos_theta_o);
    let cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, n.cos_theta_o);
    let sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, n.cos_theta_o);
    let cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
    if cos_p <= n.cos_theta_e {
        return 0.0;
    }
    let mut imp = n.phi * cos_p / d2;
    if normal != Vec3::ZERO {
        let cos_i = wi.dot(normal).abs();
        let sin_i = safe_sqrt(1.0 - cos_i * cos_i);
        imp *= cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
    }
    imp.max(0.0)
}

/// The largest f32 below 1: where a rescaled random number is clamped.
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Walks the tree from the root with the random number `u`, choosing each
/// child in proportion to its importance at `p`: the leaf chosen (a light's
/// index, or `LIGHT_NODE_EMITTER` and an emitter's) and its probability,
/// `None` where no light can reach `p`.
pub fn pick(nodes: &[DeviceLightNode], p: Vec3, normal: Vec3, mut u: f32) -> Option<(u32, f32)> {
    let mut at = 0usize;
    let mut pmf = 1.0f32;
    loop {
        let n = nodes.get(at)?;
        if n.child & LIGHT_NODE_LEAF != 0 {
            return Some((n.child & !LIGHT_NODE_LEAF, pmf));
        }
        let c = n.child as usize;
        let i0 = importance(nodes.get(c)?, p, normal);
        let i1 = importance(nodes.get(c + 1)?, p, normal);
        if !(i0 > 0.0) && !(i1 > 0.0) {
            return None;
        }
        let p0 = i0 / (i0 + i1);
        if u < p0 {
            pmf *= p0;
            u = (u / p0).min(ONE_MINUS_EPSILON);
            at = c;
        } else {
            pmf *= 1.0 - p0;
            u = ((u - p0) / (1.0 - p0)).min(ONE_MINUS_EPSILON);
            at = c + 1;
        }
    }
}

/// The probability that [`pick`] chooses the leaf at the end of `trail`
/// (`LightTree::emitter_trails`) at `p`: the same products, along one path.
pub fn trail_pmf(nodes: &[DeviceLightNode], p: Vec3, normal: Vec3, mut trail: u32) -> f32 {
    let mut at = 0usize;
    let mut pmf = 1.0f32;
    loop {
        let Some(n) = nodes.get(at) else {
            return 0.0;
        };
        if n.child & LIGHT_NODE_LEAF != 0 {
            return pmf;
        }
        let c = n.child as usize;
        let (Some(n0), Some(n1)) = (nodes.get(c), nodes.get(c + 1)) else {
            return 0.0;
        };
        let (i0, i1) = (importance(n0, p, normal), importance(n1, p, normal));
        if !(i0 > 0.0) && !(i1 > 0.0) {
            return 0.0;
        }
        let p0 = i0 / (i0 + i1);
        if trail & 1 == 0 {
            pmf *= p0;
            at = c;
        } else {
            pmf *= 1.0 - p0;
            at = c + 1;
        }
        trail >>= 1;
    }
}

/// The probability that [`pick`] chooses leaf `payload` at `p` (summing
/// over the tree: for tests).
pub fn pick_pmf(nodes: &[DeviceLightNode], p: Vec3, normal: Vec3, payload: u32) -> f32 {
    fn walk(nodes: &[DeviceLightNode], at: usize, p: Vec3, normal: Vec3, payload: u32) -> f32 {
        let n = &nodes[at];
        if n.child & LIGHT_NODE_LEAF != 0 {
            return if n.child & !LIGHT_NODE_LEAF == payload {
                1.0
            } else {
                0.0
            };
        }
        let c = n.child as usize;
        let i0 = importance(&nodes[c], p, normal);
        let i1 = importance(&nodes[c + 1], p, normal);
        if !(i0 + i1 > 0.0) {
            return 0.0;
        }
        let p0 = i0 / (i0 + i1);
        p0 * walk(nodes, c, p, normal, payload)
            + (1.0 - p0) * walk(nodes, c + 1, p, normal, payload)
    }
    if nodes.is_empty() {
        0.0
    } else {
        walk(nodes, 0, p, normal, payload)
    }
}
