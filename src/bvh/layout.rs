//! The host mirrors of the structs in `kernels/bvh_types.h`, declared once
//! here and once there. Sizes are asserted at compile time; every offset is
//! compared with the device compiler's own by the `layout_matches_device`
//! test, which runs `kernels/layout_probe.cl`. The meaning of each field is
//! documented beside the C declaration.

use bytemuck::{Pod, Zeroable};

/// Marks an absent child (`count == 0`), see [`BvhNode`].
pub const EMPTY_CHILD: u32 = u32::MAX;

/// A BVH2 node made for front-to-back traversal: it holds both children's
/// boxes, so one node fetch tests both, steps into the nearer and pushes the
/// farther. Per side, `count == 0` means `child` is an inner node's index
/// (or [`EMPTY_CHILD`], with an empty box), and `count > 0` means a leaf of
/// `count` primitives from slot `child` of the primitive-index array. Node 0
/// is the root; 64 bytes, one cache line.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode {
    pub left_min: [f32; 3],
    pub left_child: u32,
    pub left_max: [f32; 3],
    pub left_count: u32,
    pub right_min: [f32; 3],
    pub right_child: u32,
    pub right_max: [f32; 3],
    pub right_count: u32,
}

/// A triangle's box; `w` unused. Its centroid is `0.5 * (lo + hi)`.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PrimRef {
    pub lo: [f32; 4],
    pub hi: [f32; 4],
}

/// One SAH bin: its primitives' bounds, their centroids' bounds, their
/// count, and the OR/AND of their ids (for the id split of inseparable nodes).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Bin {
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    pub clo: [f32; 4],
    pub chi: [f32; 4],
    pub count: u32,
    pub id_or: u32,
    pub id_and: u32,
    pub pad: u32,
}

/// One node to split in the current level (host → device).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BuildTask {
    pub cmin: [f32; 4],
    pub scale: [f32; 4],
    pub lo: [f32; 4],
    pub hi: [f32; 4],
    pub clo: [f32; 4],
    pub chi: [f32; 4],
    pub start: u32,
    pub count: u32,
    pub first_group: u32,
    pub group_count: u32,
    pub set_first: u32,
    pub set_count: u32,
    /// Its index in the node array (host bookkeeping).
    pub node: u32,
    /// Which index/box buffer pair holds its triangles (0 or 1): levels
    /// ping-pong between the two instead of copying back.
    pub source: u32,
}

/// The split chosen for a task (device → host). `axis == -1` is an id
/// split on bit `position`; its counts come from the partition cursors.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SplitResult {
    pub left_lo: [f32; 4],
    pub left_hi: [f32; 4],
    pub right_lo: [f32; 4],
    pub right_hi: [f32; 4],
    pub left_clo: [f32; 4],
    pub left_chi: [f32; 4],
    pub right_clo: [f32; 4],
    pub right_chi: [f32; 4],
    pub axis: i32,
    pub position: u32,
    pub left_count: u32,
    pub right_count: u32,
}

/// What building one small node's subtree produced (device → host): the
/// nodes it wrote (the small node included), its deepest leaf below the
/// small node, and a status (`SMALL_*` in `kernels/bvh_types.h`).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SmallSubtree {
    pub nodes: u32,
    pub depth: u32,
    pub status: u32,
    pub pad: u32,
}

/// `SmallSubtree::status` values, as in `kernels/bvh_types.h`.
pub const SMALL_OK: u32 = 0;
pub const SMALL_NO_PROGRESS: u32 = 1;
pub const SMALL_COUNT_MISMATCH: u32 = 2;
pub const SMALL_STACK_FULL: u32 = 3;

const _: () = assert!(std::mem::size_of::<BvhNode>() == 64);
const _: () = assert!(std::mem::size_of::<PrimRef>() == 32);
const _: () = assert!(std::mem::size_of::<Bin>() == 80);
const _: () = assert!(std::mem::size_of::<BuildTask>() == 128);
const _: () = assert!(std::mem::size_of::<SplitResult>() == 144);

/// The values `layout_probe.cl` reports, in its order, for the Rust side.
pub fn host_layout() -> Vec<u32> {
    use std::mem::{offset_of, size_of};
    let v = |x: usize| x as u32;
    vec![
        v(size_of::<BvhNode>()),
        v(offset_of!(BvhNode, left_min)),
        v(offset_of!(BvhNode, left_child)),
        v(offset_of!(BvhNode, left_max)),
        v(offset_of!(BvhNode, left_count)),
        v(offset_of!(BvhNode, right_min)),
        v(offset_of!(BvhNode, right_child)),
        v(offset_of!(BvhNode, right_max)),
        v(offset_of!(BvhNode, right_count)),
        v(size_of::<PrimRef>()),
        v(offset_of!(PrimRef, lo)),
        v(offset_of!(PrimRef, hi)),
        v(size_of::<Bin>()),
        v(offset_of!(Bin, lo)),
        v(offset_of!(Bin, hi)),
        v(offset_of!(Bin, clo)),
        v(offset_of!(Bin, chi)),
        v(offset_of!(Bin, count)),
        v(offset_of!(Bin, id_or)),
        v(offset_of!(Bin, id_and)),
        v(size_of::<BuildTask>()),
        v(offset_of!(BuildTask, cmin)),
        v(offset_of!(BuildTask, scale)),
        v(offset_of!(BuildTask, lo)),
        v(offset_of!(BuildTask, hi)),
        v(offset_of!(BuildTask, clo)),
        v(offset_of!(BuildTask, chi)),
        v(offset_of!(BuildTask, start)),
        v(offset_of!(BuildTask, count)),
        v(offset_of!(BuildTask, first_group)),
        v(offset_of!(BuildTask, group_count)),
        v(offset_of!(BuildTask, set_first)),
        v(offset_of!(BuildTask, set_count)),
        v(offset_of!(BuildTask, node)),
        v(offset_of!(BuildTask, source)),
        v(size_of::<SplitResult>()),
        v(offset_of!(SplitResult, left_lo)),
        v(offset_of!(SplitResult, left_hi)),
        v(offset_of!(SplitResult, right_lo)),
        v(offset_of!(SplitResult, right_hi)),
        v(offset_of!(SplitResult, left_clo)),
        v(offset_of!(SplitResult, left_chi)),
        v(offset_of!(SplitResult, right_clo)),
        v(offset_of!(SplitResult, right_chi)),
        v(offset_of!(SplitResult, axis)),
        v(offset_of!(SplitResult, position)),
        v(offset_of!(SplitResult, left_count)),
        v(offset_of!(SplitResult, right_count)),
        v(size_of::<SmallSubtree>()),
        v(offset_of!(SmallSubtree, nodes)),
        v(offset_of!(SmallSubtree, depth)),
        v(offset_of!(SmallSubtree, status)),
    ]
}
