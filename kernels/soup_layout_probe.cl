// Reports sizeof/offsetof of every struct in soup_types.h, so a test can hold
// the Rust mirrors in src/soup/device.rs to the compiler's real layout.
#pragma OPENCL FP_CONTRACT OFF

#include "soup_types.h"

#ifndef offsetof
#define offsetof(T, field) __builtin_offsetof(T, field)
#endif
#define PUT(x) out[n++] = (uint)(x)

__kernel void soup_layout_probe(__global uint* out) {
    if (get_global_id(0) != 0) return;
    uint n = 0;
    PUT(sizeof(SoupSegment));
    PUT(offsetof(SoupSegment, src_vertex)); PUT(offsetof(SoupSegment, dst_vertex));
    PUT(offsetof(SoupSegment, vertex_count)); PUT(offsetof(SoupSegment, instance));
    PUT(offsetof(SoupSegment, influence_base)); PUT(offsetof(SoupSegment, joint_base));
    PUT(offsetof(SoupSegment, morph_base)); PUT(offsetof(SoupSegment, weight_base));
    PUT(offsetof(SoupSegment, target_count)); PUT(offsetof(SoupSegment, flags));
    PUT(sizeof(SoupInstancePose));
    PUT(offsetof(SoupInstancePose, world_from_mesh));
    PUT(offsetof(SoupInstancePose, normal_matrix));
    PUT(offsetof(SoupInstancePose, det));
    PUT(sizeof(float2)); PUT(sizeof(uint4)); PUT(sizeof(float4));
    out[n] = 0xFFFFFFFFu;
}
