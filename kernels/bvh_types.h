// Structs shared by the host and the BVH kernels. Each one is mirrored once
// in src/bvh/layout.rs; the test `layout_matches_device` runs
// layout_probe.cl and compares every size and offset below with the Rust side.
#ifndef SOUPRAY_BVH_TYPES_H
#define SOUPRAY_BVH_TYPES_H

#pragma OPENCL FP_CONTRACT OFF

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

#define EMPTY_CHILD 0xFFFFFFFFu

// A triangle's bounding box; its centroid is 0.5 * (lo + hi). `w` is unused.
typedef struct {
    float4 lo;
    float4 hi;
} PrimRef;

// One bin: the primitives whose centroids fall in it. `id_or`/`id_and`
// fold the primitive ids, so a node whose centroids cannot be separated can
// still be split deterministically by the highest id bit that differs.
typedef struct {
    float4 lo;   // bounds of the primitives
    float4 hi;
    float4 clo;  // bounds of their centroids
    float4 chi;
    uint count;
    uint id_or;
    uint id_and;
    uint pad;
} Bin;

// One node to split at the current level (host -> device).
typedef struct {
    float4 cmin;   // bin mapping: bin = (centroid - cmin) * scale, per axis
    float4 scale;  // 0 on an axis whose centroids cannot be binned apart
    float4 lo;     // the node's bounds, inherited by both children of an id split
    float4 hi;
    float4 clo;    // the node's centroid bounds, likewise
    float4 chi;
    uint start;        // first slot of its primitives in the index array
    uint count;
    uint first_group;  // its work-groups in the binning/partition launches
    uint group_count;
    uint set_first;    // the bin sets find_split merges for it
    uint set_count;
    uint node;    // its index in the node array (host bookkeeping)
    uint source;  // which index/box buffer pair holds its triangles: 0 or 1
} BuildTask;

// The split chosen for a task (device -> host). axis >= 0: primitives whose
// centroid bin on `axis` is below `position` go left. axis == -1: an id
// split, primitives whose id has bit `position` clear go left.
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
    uint left_count;   // for id splits, known only after partitioning
    uint right_count;
} SplitResult;

// What building one small node's subtree produced (device -> host). Its
// nodes sit in the scratch node array from the node's first slot on, in
// subtree-local numbering: 0 is the small node itself, inner children
// refer to local indices, leaves to primitive slots as usual.
typedef struct {
    uint nodes;   // nodes written, the small node included
    uint depth;   // deepest leaf, in levels below the small node
    uint status;  // SMALL_OK, or why the subtree was abandoned
    uint pad;
} SmallSubtree;

#define SMALL_OK 0u
#define SMALL_NO_PROGRESS 1u     // a split left one side empty
#define SMALL_COUNT_MISMATCH 2u  // the partition moved other counts than the bins said
#define SMALL_STACK_FULL 3u      // cannot happen below 256 triangles; checked anyway

#endif
