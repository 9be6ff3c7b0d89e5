// The trace stage's kernels: one work-item per ray, closest-hit and any-hit
// stack traversal, the stackless escape-index variant, and a pinhole
// primary-ray generator. The traversal and intersection code lives in
// trace_common.h so the shading kernels can include the same functions.
// Compiled with STACK_SIZE = the BVH depth limit (bvh::MAX_DEPTH).
#pragma OPENCL FP_CONTRACT OFF

#include "trace_common.h"
#include "leaf_gather.h"

// One work-item per ray through the layout of NODE: `hits[i] = FN(ray i)`.
#define TRACE_KERNEL(NAME, NODE, FN)                                              \
    __kernel void NAME(__global const NODE* nodes, __global const uint* prim_ids, \
                       __global const float* positions, __global const Ray* rays, \
                       __global Hit* hits, uint count) {                          \
        uint i = get_global_id(0);                                                \
        if (i >= count) return;                                                   \
        hits[i] = FN(nodes, prim_ids, positions, rays[i]);                        \
    }

TRACE_KERNEL(trace_closest, BvhNode, trace_closest_bvh)
TRACE_KERNEL(trace_any, BvhNode, trace_any_bvh)

// The same through a wide layout: `leaf_prims` and `tris` are its
// triangles in leaf order (`leaf_gather`).
#define TRACE_WIDE_KERNEL(NAME, NODE, FN)                                         \
    __kernel void NAME(__global const NODE* nodes, __global const uint* leaf_prims, \
                       __global const float4* tris, __global const float* positions, \
                       __global const Ray* rays, __global Hit* hits, uint count) {  \
        uint i = get_global_id(0);                                                \
        if (i >= count) return;                                                   \
        hits[i] = FN(nodes, leaf_prims, tris, positions, rays[i]);                \
    }

TRACE_WIDE_KERNEL(trace_closest_wide, WideNode, trace_closest_wide_bvh)
TRACE_WIDE_KERNEL(trace_any_wide, WideNode, trace_any_wide_bvh)
TRACE_WIDE_KERNEL(trace_closest_wide8, Wide8Node, trace_closest_wide8_bvh)
TRACE_WIDE_KERNEL(trace_any_wide8, Wide8Node, trace_any_wide8_bvh)
TRACE_WIDE_KERNEL(trace_closest_wide8q, Wide8QNode, trace_closest_wide8q_bvh)
TRACE_WIDE_KERNEL(trace_any_wide8q, Wide8QNode, trace_any_wide8q_bvh)

__kernel void trace_closest_stackless(__global const StacklessNode* snodes, uint entries,
                                      __global const uint* prim_ids,
                                      __global const float* positions,
                                      __global const Ray* rays, __global Hit* hits,
                                      uint count) {
    uint i = get_global_id(0);
    if (i >= count) return;
    hits[i] = trace_closest_stackless_bvh(snodes, entries, prim_ids, positions, rays[i]);
}

// Pinhole camera: pixel (x, y) (y down, row-major) gets the ray from `org`
// through p00 + (x + 0.5) * du + (y + 0.5) * dv, in the same float operations
// as PinholeCamera::ray on the host.
__kernel void generate_primary(__global Ray* rays, uint width, uint height,
                               float ox, float oy, float oz,
                               float p0x, float p0y, float p0z,
                               float dux, float duy, float duz,
                               float dvx, float dvy, float dvz) {
    uint i = get_global_id(0);
    if (i >= width * height) return;
    float fx = (float)(i % width) + 0.5f;
    float fy = (float)(i / width) + 0.5f;
    Ray r;
    r.org[0] = ox; r.org[1] = oy; r.org[2] = oz;
    r.dir[0] = (p0x + fx * dux) + fy * dvx;
    r.dir[1] = (p0y + fx * duy) + fy * dvy;
    r.dir[2] = (p0z + fx * duz) + fy * dvz;
    r.tmin = 0.0f;
    r.tmax = INFINITY;
    rays[i] = r;
}
