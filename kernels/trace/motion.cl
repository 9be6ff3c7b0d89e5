// Motion blur's own kernels, compiled (with MOTION_BLUR) only when a frame
// moves within the shutter; the path tracer's motion variant is
// pathtrace.cl with MOTION_BLUR. Rust twins in src/trace/motion.rs.
//
//   motion_bounds        one work-item per triangle: the box of its corners
//                        at every motion step, written as a degenerate
//                        "bounds triangle" (lo, hi, lo) so the BVH builder's
//                        own prim-ref pass turns it into exactly that box.
//   motion_trace_closest closest hit of rays with their own times through
//                        the binary tree (the reference tests' kernel).
//   motion_camera_probe, motion_light_probe: motion.h's camera and light
//                        interpolation on host-made inputs (tests).
#pragma OPENCL FP_CONTRACT OFF

#include "trace_common.h"
#include "motion.h"

__kernel void motion_bounds(__global const float4* steps_positions, uint triangles, uint steps,
                            __global float4* bounds) {
    uint i = get_global_id(0);
    if (i >= triangles) return;
    float4 lo = steps_positions[3u * i];
    float4 hi = lo;
    for (uint s = 0u; s < steps; ++s) {
        size_t at = (size_t)s * (size_t)triangles * 3u + (size_t)i * 3u;
        for (uint k = 0u; k < 3u; ++k) {
            float4 v = steps_positions[at + k];
            lo = fmin(lo, v);
            hi = fmax(hi, v);
        }
    }
    lo.w = 0.0f;
    hi.w = 0.0f;
    bounds[3u * i] = lo;
    bounds[3u * i + 1u] = hi;
    bounds[3u * i + 2u] = lo;
}

__kernel void motion_trace_closest(__global const BvhNode* nodes, __global const uint* prim_ids,
                                   __global const float* positions, uint steps, uint triangles,
                                   __global const Ray* rays, __global const float* times,
                                   __global Hit* hits, uint count) {
    uint i = get_global_id(0);
    if (i >= count) return;
    MotionTime mt = motion_time(times[i], steps, triangles);
    hits[i] = trace_closest_bvh(nodes, prim_ids, GEOM_ARGS(positions, mt), rays[i]);
}

__kernel void motion_camera_probe(__global const PtCamera* cams, uint steps,
                                  __global const float* times, __global PtCamera* out,
                                  uint count) {
    uint i = get_global_id(0);
    if (i >= count) return;
    out[i] = motion_camera(cams, motion_time(times[i], steps, 0u));
}

__kernel void motion_light_probe(__global const PtLight* a, __global const PtLight* b,
                                 __global const float* fracs, __global PtLight* out,
                                 uint count) {
    uint i = get_global_id(0);
    if (i >= count) return;
    out[i] = motion_light(a[i], b[i], fracs[i]);
}
