// The camera and the punctual lights at a path's time, for pathtrace.cl's
// MOTION_BLUR variant (and motion.cl's probes): linear between the two
// motion steps around the time, like the soup (trace_common.h). Rust twins:
// trace::motion::camera_at and light_at.
#ifndef SOUPRAY_MOTION_H
#define SOUPRAY_MOTION_H

#pragma OPENCL FP_CONTRACT OFF

#include "trace_common.h"
#include "pt_types.h"
#include "lights.h"

// The camera at time `m`: `cam` holds it at every motion step, and each
// vector is interpolated between the two steps around the time (steps are
// close enough that the basis stays near orthogonal).
inline PtCamera motion_camera(__global const PtCamera* cam, MotionTime m) {
    PtCamera a = cam[m.step];
    PtCamera b = cam[m.step + 1u];
    PtCamera c = a;
    for (uint i = 0u; i < 4u; ++i) {
        c.origin[i] = a.origin[i] + m.frac * (b.origin[i] - a.origin[i]);
        c.right[i] = a.right[i] + m.frac * (b.right[i] - a.right[i]);
        c.up[i] = a.up[i] + m.frac * (b.up[i] - a.up[i]);
        c.forward[i] = a.forward[i] + m.frac * (b.forward[i] - a.forward[i]);
    }
    return c;
}

// A light between its states `a` and `b` at two steps: position
// interpolated, direction interpolated and renormalised; the rest is `a`'s
// (glTF does not animate colour or intensity without KHR_animation_pointer).
inline PtLight motion_light(PtLight a, PtLight b, float f) {
    for (uint k = 0u; k < 3u; ++k) a.position[k] = a.position[k] + f * (b.position[k] - a.position[k]);
    float3 d = (float3)(a.direction[0] + f * (b.direction[0] - a.direction[0]),
                        a.direction[1] + f * (b.direction[1] - a.direction[1]),
                        a.direction[2] + f * (b.direction[2] - a.direction[2]));
    float l = sqrt(d.x * d.x + d.y * d.y + d.z * d.z);
    if (l > 0.0f) d = d / l;
    a.direction[0] = d.x;
    a.direction[1] = d.y;
    a.direction[2] = d.z;
    return a;
}

#endif
