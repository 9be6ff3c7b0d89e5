//! The BVH builder's structs and constants shared with the kernels, defined
//! once here; `kernels/generated/bvh_types.h` is generated from them
//! (src/device_struct.rs), and every size and offset is compared with the
//! device compiler's own by `tests/device_structs.rs`.

use crate::device_struct::{device_consts, device_struct};
use bytemuck::{Pod, Zeroable};

device_consts! {
    fn bvh_consts;
    /// Marks an absent child (`count == 0`), see [`BvhNode`].
    pub const EMPTY_CHILD: u32 = u32::MAX;
    /// `SmallSubtree::status`: the subtree was built.
    pub const SMALL_OK: u32 = 0;
    /// A split left one side empty.
    pub const SMALL_NO_PROGRESS: u32 = 1;
    /// The partition moved other counts than the bins said.
    pub const SMALL_COUNT_MISMATCH: u32 = 2;
    /// Cannot happen below 256 triangles; checked anyway.
    pub const SMALL_STACK_FULL: u32 = 3;
}

device_struct! {
/// A BVH2 node laid out for front-to-back traversal (64 bytes, one cache
/// line). A node holds the boxes of BOTH children, so a ray tests the two
/// boxes together, steps into the nearer child and pushes the farther one
/// without fetching either child node first.
///
/// Child encoding, per side:
///   count == 0, child != EMPTY_CHILD : inner node, `child` indexes the node array
///   count  > 0                       : leaf, `count` primitives starting at
///                                      slot `child` of the primitive-index array
///   count == 0, child == EMPTY_CHILD : no child; its box is empty (min > max)
/// Node 0 is the root. A tree of at most `leaf_size` triangles is a root whose
/// left child is the single leaf and whose right child is empty.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BvhNode as "BvhNode" {
    pub left_min: [f32; 3],
    pub left_child: u32,
    pub left_max: [f32; 3],
    pub left_count: u32,
    pub right_min: [f32; 3],
    pub right_child: u32,
    pub right_max: [f32; 3],
    pub right_count: u32,
}
}

device_struct! {
/// A triangle's box; `w` unused. Its centroid is `0.5 * (lo + hi)`.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct PrimRef as "PrimRef" {
    pub lo: [f32; 4] as "float4",
    pub hi: [f32; 4] as "float4",
}
}

device_struct! {
/// One bin: the primitives whose centroids fall in it. `id_or`/`id_and`
/// fold the primitive ids, so a node whose centroids cannot be separated can
/// still be split deterministically by the highest id bit that differs.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Bin as "Bin" {
    /// bounds of the primitives
    pub lo: [f32; 4] as "float4",
    pub hi: [f32; 4] as "float4",
    /// bounds of their centroids
    pub clo: [f32; 4] as "float4",
    pub chi: [f32; 4] as "float4",
    pub count: u32,
    pub id_or: u32,
    pub id_and: u32,
    pub pad: u32,
}
}

device_struct! {
/// One node to split in the current level (host → device).
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct BuildTask as "BuildTask" {
    /// bin mapping: bin = (centroid - cmin) * scale, per axis
    pub cmin: [f32; 4] as "float4",
    /// 0 on an axis whose centroids cannot be binned apart
    pub scale: [f32; 4] as "float4",
    /// the node's bounds, inherited by both children of an id split
    pub lo: [f32; 4] as "float4",
    pub hi: [f32; 4] as "float4",
    /// the node's centroid bounds, likewise
    pub clo: [f32; 4] as "float4",
    pub chi: [f32; 4] as "float4",
    /// first slot of its primitives in the index array
    pub start: u32,
    pub count: u32,
    /// its work-groups in the binning/partition launches
    pub first_group: u32,
    pub group_count: u32,
    /// the bin sets find_split merges for it
    pub set_first: u32,
    pub set_count: u32,
    /// Its index in the node array (host bookkeeping).
    pub node: u32,
    /// Which index/box buffer pair holds its triangles (0 or 1): levels
    /// ping-pong between the two instead of copying back.
    pub source: u32,
}
}

device_struct! {
/// The split chosen for a task (device -> host). axis >= 0: primitives whose
/// centroid bin on `axis` is below `position` go left. axis == -1: an id
/// split, primitives whose id has bit `position` clear go left.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SplitResult as "SplitResult" {
    pub left_lo: [f32; 4] as "float4",
    pub left_hi: [f32; 4] as "float4",
    pub right_lo: [f32; 4] as "float4",
    pub right_hi: [f32; 4] as "float4",
    pub left_clo: [f32; 4] as "float4",
    pub left_chi: [f32; 4] as "float4",
    pub right_clo: [f32; 4] as "float4",
    pub right_chi: [f32; 4] as "float4",
    pub axis: i32,
    pub position: u32,
    /// for id splits, known only after partitioning
    pub left_count: u32,
    pub right_count: u32,
}
}

device_struct! {
/// What building one small node's subtree produced (device -> host). Its
/// nodes sit in the scratch node array from the node's first slot on, in
/// subtree-local numbering: 0 is the small node itself, inner children
/// refer to local indices, leaves to primitive slots as usual.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SmallSubtree as "SmallSubtree" {
    /// nodes written, the small node included
    pub nodes: u32,
    /// deepest leaf, in levels below the small node
    pub depth: u32,
    /// SMALL_OK, or why the subtree was abandoned
    pub status: u32,
    pub pad: u32,
}
}

const _: () = assert!(std::mem::size_of::<BvhNode>() == 64);
const _: () = assert!(std::mem::size_of::<PrimRef>() == 32);
const _: () = assert!(std::mem::size_of::<Bin>() == 80);
const _: () = assert!(std::mem::size_of::<BuildTask>() == 128);
const _: () = assert!(std::mem::size_of::<SplitResult>() == 144);
