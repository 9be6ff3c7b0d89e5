// Structs shared by the host and the trace kernels. Each one is mirrored once
// in src/trace/mod.rs; the test `trace_layout_matches_device` runs the
// `trace_layout_probe` kernel of layout_probe.cl and compares every size and
// offset below with the Rust side.
#ifndef SOUPRAY_TRACE_TYPES_H
#define SOUPRAY_TRACE_TYPES_H

#pragma OPENCL FP_CONTRACT OFF

// One ray: hits count when tmin < t < tmax (tmin >= 0). The direction need
// not be normalised (t is in units of it); an all-zero direction never hits.
// Scalar arrays rather than float3 keep the struct 32 bytes with no padding
// rules that differ between compilers.
typedef struct {
    float org[3];
    float tmin;
    float dir[3];
    float tmax;
} Ray;

// The marker of "no hit" in Hit.prim.
#define MISS 0xFFFFFFFFu

// A hit record: distance, triangle index in the soup, and the barycentrics
// of corners 1 and 2, so that the hit point is
//   (1 - u - v) * p0 + u * p1 + v * p2.
// The shader recomputes the geometric normal from the triangle (it is never
// zero for a hit: degenerate triangles are never hit). prim == MISS: no hit,
// t = tmax. For any-hit queries only prim matters (MISS or not).
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
typedef struct {
    float lo[3];
    uint escape;
    float hi[3];
    uint leaf;
} StacklessNode;

#define LEAF_COUNT_BITS 7u

// A 4-wide node of the traversal layout (src/trace/wide.rs): the boxes of
// up to four children stored axis by axis, lo[axis][slot] and
// hi[axis][slot], and per slot the child as in BvhNode: count == 0 an inner
// node's index (EMPTY_CHILD: absent, with an empty box), count > 0 a leaf of
// `count` primitives from slot `child` of the primitive-index array.
typedef struct {
    float lo[3][4];
    float hi[3][4];
    uint child[4];
    uint count[4];
} WideNode;

#endif
