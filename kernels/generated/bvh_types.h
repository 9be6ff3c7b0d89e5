// Generated from the Rust definitions by soupray::device_struct
// (SOUPRAY_REGENERATE=1 cargo test --test device_structs). Do not edit:
// change the Rust definition named above each item.
//
// The BVH builder's structs (src/bvh/layout.rs).
#ifndef SOUPRAY_GENERATED_BVH_TYPES_H
#define SOUPRAY_GENERATED_BVH_TYPES_H

#pragma OPENCL FP_CONTRACT OFF

// Marks an absent child (`count == 0`), see [`BvhNode`].
#define EMPTY_CHILD 4294967295u
// `SmallSubtree::status`: the subtree was built.
#define SMALL_OK 0u
// A split left one side empty.
#define SMALL_NO_PROGRESS 1u
// The partition moved other counts than the bins said.
#define SMALL_COUNT_MISMATCH 2u
// Cannot happen below 256 triangles; checked anyway.
#define SMALL_STACK_FULL 3u

// A BVH2 node laid out for front-to-back traversal (64 bytes, one cache
// line). A node holds the boxes of BOTH children, so a ray tests the two
// boxes together, steps into the nearer child and pushes the farther one
// without fetching either child node first.
//
// Child encoding, per side:
//   count == 0, child != EMPTY_CHILD : inner node, `child` indexes the node array
//   count  > 0                       : leaf, `count` primitives starting at
//                                      slot `child` of the primitive-index array
//   count == 0, child == EMPTY_CHILD : no child; its box is empty (min > max)
// Node 0 is the root. A tree of at most `leaf_size` triangles is a root whose
// left child is the single leaf and whose right child is empty.
// `BvhNode` in src/bvh/layout.rs (64 bytes).
typedef struct {
    float left_min[3];
    uint left_child;
    float left_max[3];
    uint left_count;
    float right_min[3];
    uint right_child;
    float right_max[3];
    uint right_count;
} BvhNode;

// A triangle's box; `w` unused. Its centroid is `0.5 * (lo + hi)`.
// `PrimRef` in src/bvh/layout.rs (32 bytes).
typedef struct {
    float4 lo;
    float4 hi;
} PrimRef;

// One bin: the primitives whose centroids fall in it. `id_or`/`id_and`
// fold the primitive ids, so a node whose centroids cannot be separated can
// still be split deterministically by the highest id bit that differs.
// `Bin` in src/bvh/layout.rs (80 bytes).
typedef struct {
    // bounds of the primitives
    float4 lo;
    float4 hi;
    // bounds of their centroids
    float4 clo;
    float4 chi;
    uint count;
    uint id_or;
    uint id_and;
    uint pad;
} Bin;

// One node to split in the current level (host → device).
// `BuildTask` in src/bvh/layout.rs (128 bytes).
typedef struct {
    // bin mapping: bin = (centroid - cmin) * scale, per axis
    float4 cmin;
    // 0 on an axis whose centroids cannot be binned apart
    float4 scale;
    // the node's bounds, inherited by both children of an id split
    float4 lo;
    float4 hi;
    // the node's centroid bounds, likewise
    float4 clo;
    float4 chi;
    // first slot of its primitives in the index array
    uint start;
    uint count;
    // its work-groups in the binning/partition launches
    uint first_group;
    uint group_count;
    // the bin sets find_split merges for it
    uint set_first;
    uint set_count;
    // Its index in the node array (host bookkeeping).
    uint node;
    // Which index/box buffer pair holds its triangles (0 or 1): levels
    // ping-pong between the two instead of copying back.
    uint source;
} BuildTask;

// The split chosen for a task (device -> host). axis >= 0: primitives whose
// centroid bin on `axis` is below `position` go left. axis == -1: an id
// split, primitives whose id has bit `position` clear go left.
// `SplitResult` in src/bvh/layout.rs (144 bytes).
typedef struct {
    float4 left_lo;
    float4 left_hi;
    float4 right_lo;
    float4 right_hi;
    float4 left_clo;
    float4 left_chi;
    float4 right_clo;
    float4 right_chi;
    int axis;
    uint position;
    // for id splits, known only after partitioning
    uint left_count;
    uint right_count;
} SplitResult;

// What building one small node's subtree produced (device -> host). Its
// nodes sit in the scratch node array from the node's first slot on, in
// subtree-local numbering: 0 is the small node itself, inner children
// refer to local indices, leaves to primitive slots as usual.
// `SmallSubtree` in src/bvh/layout.rs (16 bytes).
typedef struct {
    // nodes written, the small node included
    uint nodes;
    // deepest leaf, in levels below the small node
    uint depth;
    // SMALL_OK, or why the subtree was abandoned
    uint status;
    uint pad;
} SmallSubtree;

#endif
