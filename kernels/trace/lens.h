// Depth of field: a thin lens in front of the glTF camera (HAS_DOF).
// Mirrors src/trace/lens.rs (`camera_aperture_point`, `camera_lens_ray`)
// operation for operation; that file explains the model.
#ifndef SOUPRAY_LENS_H
#define SOUPRAY_LENS_H

#pragma OPENCL FP_CONTRACT OFF

#include "sampling.h"

// A point on the unit aperture, uniform in area: the concentric disk for
// blades below 3, else the regular polygon with `blades` corners, the first
// at angle `rotation`.
inline float2 camera_aperture_point(float u, float v, uint blades, float rotation) {
    if (blades < 3u) {
        float a = 2.0f * u - 1.0f;
        float b = 2.0f * v - 1.0f;
        if (a == 0.0f && b == 0.0f) return (float2)(0.0f, 0.0f);
        float r, phi;
        if (fabs(a) > fabs(b)) {
            r = a;
            phi = (0.25f * PT_PI) * (b / a);
        } else {
            r = b;
            phi = 0.5f * PT_PI - (0.25f * PT_PI) * (a / b);
        }
        return (float2)(r * cos(phi), r * sin(phi));
    }
    float n = (float)blades;
    float fu = u * n;
    uint k = min((uint)fu, blades - 1u);
    float w = fu - (float)k;
    float step = (2.0f * PT_PI) / n;
    float a0 = rotation + step * (float)k;
    float a1 = a0 + step;
    float s = sqrt(w);
    float p = s * (1.0f - v);
    float q = s * v;
    return (float2)(p * cos(a0) + q * cos(a1), p * sin(a0) + q * sin(a1));
}

inline float lens_length(float3 v) { return sqrt((v.x * v.x + v.y * v.y) + v.z * v.z); }

// The ray through the lens of a camera sample whose pinhole direction is
// `d` (component 1 along the unit `forward`): from the camera origin offset
// by `radius` times the aperture point along the unit right and up, towards
// the point `d` reaches on the focus plane.
inline void camera_lens_ray(float3 origin, float3 right, float3 up, float3 forward, float3 d,
                            float znear, float radius, float focus, float2 aperture,
                            float3* org, float3* dir, float* tmin) {
    float3 r = right / lens_length(right);
    float3 u = up / lens_length(up);
    float3 o = origin + (r * (radius * aperture.x) + u * (radius * aperture.y));
    float3 target = origin + d * focus;
    float3 to = target - o;
    float3 w = to / lens_length(to);
    float c = (w.x * forward.x + w.y * forward.y) + w.z * forward.z;
    *org = o;
    *dir = w;
    *tmin = c > 0.0f ? znear / c : 0.0f;
}

#endif
