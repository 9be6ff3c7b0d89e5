// Generated from the Rust definitions by soupray::device_struct
// (SOUPRAY_REGENERATE=1 cargo test --test device_structs). Do not edit:
// change the Rust definition named above each item.
//
// Rays, hits and the traversal layouts (src/trace/).
#ifndef SOUPRAY_GENERATED_TRACE_TYPES_H
#define SOUPRAY_GENERATED_TRACE_TYPES_H

#pragma OPENCL FP_CONTRACT OFF

// `Hit::prim` of a ray that hit nothing.
#define MISS 4294967295u
// The bits of the quiet NaN that a leaf block holds for a degenerate
// triangle's coordinates (`wide::leaf_arrays`).
#define LEAF_FLAT_BITS 2143289344u
// Bits of `StacklessNode::leaf` that hold the primitive count.
#define LEAF_COUNT_BITS 7u

// One ray: hits count when tmin < t < tmax (tmin >= 0). The direction need
// not be normalised (t is in units of it); an all-zero direction never hits.
// Scalar arrays rather than float3 keep the struct 32 bytes with no padding
// rules that differ between compilers.
// `Ray` in src/trace/mod.rs (32 bytes).
typedef struct {
    float org[3];
    float tmin;
    float dir[3];
    float tmax;
} Ray;

// A hit record (`Hit` in `kernels/trace_types.h`): distance, triangle
// index in the soup, and the barycentrics of corners 1 and 2, so the hit
// point is `(1 - u - v) p0 + u p1 + v p2`. `prim == MISS` (and `t = tmax`)
// when nothing was hit. The geometric normal is recomputed by the shader
// from the triangle; it is never zero, as degenerate triangles are never hit.
// `Hit` in src/trace/mod.rs (16 bytes).
typedef struct {
    float t;
    uint prim;
    float u;
    float v;
} Hit;

// One entry of the stackless (escape-index) layout, in depth-first preorder:
// a box, and the index of the entry to visit next when this one is missed or
// finished (`escape`; the entry count ends traversal). An inner entry's first
// child is the next entry. leaf == 0 marks an inner entry; otherwise
// leaf = (first << 7) | count, count in 1..=64 primitives from slot `first`
// of the primitive-index array (first < 2^25).
// `StacklessNode` in src/trace/escape.rs (32 bytes).
typedef struct {
    float lo[3];
    uint escape;
    float hi[3];
    uint leaf;
} StacklessNode;

// One 4-wide node (`WideNode` in `kernels/trace_types.h`): the boxes of its
// up to four children, `lo[axis][slot]` and `hi[axis][slot]`, and per slot
// `count == 0`: an inner node's index in `child` (or `EMPTY_CHILD`, an
// absent child with an empty box), `count > 0`: a leaf of `count`
// primitives from slot `child` of the primitive-index array. 128 bytes.
// `WideNode` in src/trace/wide.rs (128 bytes).
typedef struct {
    float lo[3][4];
    float hi[3][4];
    uint child[4];
    uint count[4];
} WideNode;

// One 8-wide node (`Wide8Node`): `WideNode` with eight slots, so that a
// node's box test fills a 256-bit register. 256 bytes.
// `Wide8Node` in src/trace/wide.rs (256 bytes).
typedef struct {
    float lo[3][8];
    float hi[3][8];
    uint child[8];
    uint count[8];
} Wide8Node;

// One quantized 8-wide node (`Wide8QNode`): slot k's box on axis a is
// [origin[a] + qlo[a][k] * scale[a], origin[a] + qhi[a][k] * scale[a]];
// `child` and `count` as in `Wide8Node` (an absent slot has child
// `EMPTY_CHILD`, which the traversal masks: its bytes decode to a box).
// 128 bytes, two cache lines.
// `Wide8QNode` in src/trace/quantized.rs (128 bytes).
typedef struct {
    float origin[3];
    float scale[3];
    uchar qlo[3][8];
    uchar qhi[3][8];
    uchar count[8];
    uint child[8];
    uint pad[4];
} Wide8QNode;

// Four slots of a wide layout's leaves (`LeafBlock`): they hold entries
// [first, first + count) of the tree's primitive-index array, count 1..=4;
// the slots past `count` repeat the last of them.
// `LeafBlock` in src/trace/wide.rs (8 bytes).
typedef struct {
    uint first;
    uint count;
} LeafBlock;

#endif
