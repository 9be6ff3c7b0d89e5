// Reports sizeof/offsetof of every host-visible struct, so a test can hold
// the Rust mirrors in src/bvh/layout.rs to the compiler's real layout.
#pragma OPENCL FP_CONTRACT OFF

#include "bvh_types.h"
#include "trace_types.h"

#ifndef offsetof
#define offsetof(T, field) __builtin_offsetof(T, field)
#endif
#define PUT(x) out[n++] = (uint)(x)

__kernel void layout_probe(__global uint* out) {
    if (get_global_id(0) != 0) return;
    uint n = 0;
    PUT(sizeof(BvhNode));
    PUT(offsetof(BvhNode, left_min)); PUT(offsetof(BvhNode, left_child));
    PUT(offsetof(BvhNode, left_max)); PUT(offsetof(BvhNode, left_count));
    PUT(offsetof(BvhNode, right_min)); PUT(offsetof(BvhNode, right_child));
    PUT(offsetof(BvhNode, right_max)); PUT(offsetof(BvhNode, right_count));
    PUT(sizeof(PrimRef));
    PUT(offsetof(PrimRef, lo)); PUT(offsetof(PrimRef, hi));
    PUT(sizeof(Bin));
    PUT(offsetof(Bin, lo)); PUT(offsetof(Bin, hi)); PUT(offsetof(Bin, clo));
    PUT(offsetof(Bin, chi)); PUT(offsetof(Bin, count)); PUT(offsetof(Bin, id_or));
    PUT(offsetof(Bin, id_and));
    PUT(sizeof(BuildTask));
    PUT(offsetof(BuildTask, cmin)); PUT(offsetof(BuildTask, scale));
    PUT(offsetof(BuildTask, lo)); PUT(offsetof(BuildTask, hi));
    PUT(offsetof(BuildTask, clo)); PUT(offsetof(BuildTask, chi));
    PUT(offsetof(BuildTask, start)); PUT(offsetof(BuildTask, count));
    PUT(offsetof(BuildTask, first_group)); PUT(offsetof(BuildTask, group_count));
    PUT(offsetof(BuildTask, set_first)); PUT(offsetof(BuildTask, set_count));
    PUT(offsetof(BuildTask, node)); PUT(offsetof(BuildTask, source));
    PUT(sizeof(SplitResult));
    PUT(offsetof(SplitResult, left_lo)); PUT(offsetof(SplitResult, left_hi));
    PUT(offsetof(SplitResult, right_lo)); PUT(offsetof(SplitResult, right_hi));
    PUT(offsetof(SplitResult, left_clo)); PUT(offsetof(SplitResult, left_chi));
    PUT(offsetof(SplitResult, right_clo)); PUT(offsetof(SplitResult, right_chi));
    PUT(offsetof(SplitResult, axis)); PUT(offsetof(SplitResult, position));
    PUT(offsetof(SplitResult, left_count)); PUT(offsetof(SplitResult, right_count));
    PUT(sizeof(SmallSubtree));
    PUT(offsetof(SmallSubtree, nodes)); PUT(offsetof(SmallSubtree, depth));
    PUT(offsetof(SmallSubtree, status));
    out[n] = 0xFFFFFFFFu;
}

// The trace stage's structs (kernels/trace_types.h), compared with
// soupray::trace::trace_layout() by tests/trace_layout.rs.
__kernel void trace_layout_probe(__global uint* out) {
    if (get_global_id(0) != 0) return;
    uint n = 0;
    PUT(sizeof(Ray));
    PUT(offsetof(Ray, org)); PUT(offsetof(Ray, tmin));
    PUT(offsetof(Ray, dir)); PUT(offsetof(Ray, tmax));
    PUT(sizeof(Hit));
    PUT(offsetof(Hit, t)); PUT(offsetof(Hit, prim));
    PUT(offsetof(Hit, u)); PUT(offsetof(Hit, v));
    PUT(sizeof(StacklessNode));
    PUT(offsetof(StacklessNode, lo)); PUT(offsetof(StacklessNode, escape));
    PUT(offsetof(StacklessNode, hi)); PUT(offsetof(StacklessNode, leaf));
    PUT(sizeof(WideNode));
    PUT(offsetof(WideNode, lo)); PUT(offsetof(WideNode, hi));
    PUT(offsetof(WideNode, child)); PUT(offsetof(WideNode, count));
    out[n] = 0xFFFFFFFFu;
}
