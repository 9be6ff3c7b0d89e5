// Lights for next-event estimation: KHR_lights_punctual point, spot and
// directional lights in the extension's units (candela for point and spot,
// lux for directional; soupray's radiance is then in nits), with the
// extension's recommended range window and smooth spot-cone falloff, and
// the environment: a constant radiance or an equirectangular map sampled
// by its luminance times sin(theta) (marginal and conditional CDFs built on
// the host). Emissive triangles are sampled in pathtrace.cl, where the
// material table is. Each function mirrors src/trace/lights.rs.
#ifndef SOUPRAY_LIGHTS_H
#define SOUPRAY_LIGHTS_H

#pragma OPENCL FP_CONTRACT OFF

#include "pt_types.h"
#include "sampling.h"


// The light a punctual light sends to point p: the unit direction to the
// light, its distance (INFINITY for directional), and the incident
// irradiance on a surface facing it (color * intensity * falloff / d^2, or
// the lux of a directional light). False when it sends nothing.
inline bool punctual_incident(PtLight l, float3 p, float3* wi, float* dist, float3* e) {
    float3 intensity = (float3)(l.intensity[0], l.intensity[1], l.intensity[2]);
    float3 dir = (float3)(l.direction[0], l.direction[1], l.direction[2]);
    if (l.kind == LIGHT_DIRECTIONAL) {
        *wi = -dir;
        *dist = INFINITY;
        *e = intensity;
        return true;
    }
    float3 to = (float3)(l.position[0], l.position[1], l.position[2]) - p;
    float d2 = dot(to, to);
    if (!(d2 > 0.0f)) return false;
    float d = sqrt(d2);
    float3 w = to / d;
    float atten = 1.0f / d2;
    if (l.range > 0.0f) {
        float r = d / l.range;
        float r2 = r * r;
        atten = atten * clamp(1.0f - r2 * r2, 0.0f, 1.0f);
    }
    if (l.kind == LIGHT_SPOT) {
        float cd = -dot(dir, w);
        float s = clamp(cd * l.angle_scale + l.angle_offset, 0.0f, 1.0f);
        atten = atten * (s * s);
    }
    if (!(atten > 0.0f)) return false;
    *wi = w;
    *dist = d;
    *e = intensity * atten;
    return true;
}

// Equirectangular mapping, +Y up: u = 0.5 + atan2(x, -z) / (2 pi) (u grows
// with the azimuth; the image's centre column looks down -Z),
// v = acos(y) / pi (row 0 at the zenith).
inline float2 env_dir_to_uv(float3 d) {
    float u = 0.5f + atan2(d.x, -d.z) * (1.0f / PT_TWO_PI);
    float v = acos(clamp(d.y, -1.0f, 1.0f)) * PT_INV_PI;
    return (float2)(u, v);
}

inline float3 env_uv_to_dir(float u, float v) {
    float theta = v * PT_PI;
    float phi = (u - 0.5f) * PT_TWO_PI;
    float st = sin(theta);
    return (float3)(st * sin(phi), cos(theta), -(st * cos(phi)));
}

inline uint env_texel(PtEnv env, float2 uv) {
    uint x = (uint)clamp((int)floor(uv.x * (float)env.width), 0, (int)env.width - 1);
    uint y = (uint)clamp((int)floor(uv.y * (float)env.height), 0, (int)env.height - 1);
    return y * env.width + x;
}

// Radiance arriving from direction d (unit) out of the environment.
inline float3 env_radiance(PtEnv env, const __global float4* texels, float3 d) {
    float3 scale = (float3)(env.color[0], env.color[1], env.color[2]);
    if (env.kind == ENV_CONSTANT) return scale;
    if (env.kind == ENV_MAP) {
        float4 t = texels[env_texel(env, env_dir_to_uv(d))];
        return t.xyz * scale;
    }
    return (float3)(0.0f);
}

// Solid-angle pdf of sampling direction d with env_sample.
inline float env_pdf(PtEnv env, const __global float* marginal, const __global float* conditional,
                     float3 d) {
    if (env.kind == ENV_CONSTANT) return 1.0f / (4.0f * PT_PI);
    if (env.kind != ENV_MAP) return 0.0f;
    float2 uv = env_dir_to_uv(d);
    float st = sqrt(fmax(0.0f, 1.0f - d.y * d.y));
    if (!(st > 0.0f)) return 0.0f;
    uint i = env_texel(env, uv);
    uint x = i % env.width;
    uint y = i / env.width;
    const __global float* row = conditional + (size_t)y * (env.width + 1u);
    float p = ((marginal[y + 1u] - marginal[y]) * (float)env.height) *
              ((row[x + 1u] - row[x]) * (float)env.width);
    return p / ((2.0f * PT_PI * PT_PI) * st);
}

// Samples a direction towards the environment; returns its radiance and
// solid-angle pdf (0: no sample).
inline float3 env_sample(PtEnv env, const __global float4* texels, const __global float* marginal,
                         const __global float* conditional, float u1, float u2, float3* wi,
                         float* pdf) {
    *pdf = 0.0f;
    if (env.kind == ENV_CONSTANT) {
        *wi = sample_uniform_sphere(u1, u2);
        *pdf = 1.0f / (4.0f * PT_PI);
        return (float3)(env.color[0], env.color[1], env.color[2]);
    }
    if (env.kind != ENV_MAP) return (float3)(0.0f);
    uint y = cdf_search(marginal, env.height, u1);
    float m0 = marginal[y], m1 = marginal[y + 1u];
    float dv = (u1 - m0) / (m1 - m0);
    const __global float* row = conditional + (size_t)y * (env.width + 1u);
    uint x = cdf_search(row, env.width, u2);
    float c0 = row[x], c1 = row[x + 1u];
    float du = (u2 - c0) / (c1 - c0);
    float u = ((float)x + du) / (float)env.width;
    float v = ((float)y + dv) / (float)env.height;
    float3 d = env_uv_to_dir(u, v);
    float st = sin(v * PT_PI);
    if (!(st > 0.0f)) return (float3)(0.0f);
    *wi = d;
    *pdf = (((m1 - m0) * (float)env.height) * ((c1 - c0) * (float)env.width)) /
           ((2.0f * PT_PI * PT_PI) * st);
    float4 t = texels[y * env.width + x];
    return t.xyz * (float3)(env.color[0], env.color[1], env.color[2]);
}

// The light tree (src/trace/light_tree/mod.rs, whose `importance` and `pick`
// these mirror): how much node `n`'s lights may send to a surface at `p`
// with normal `nrm` (pbrt-v4's LightBounds::Importance).
inline float cos_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 1.0f : cos_a * cos_b + sin_a * sin_b;
}
inline float sin_sub_clamped(float sin_a, float cos_a, float sin_b, float cos_b) {
    return cos_a > cos_b ? 0.0f : sin_a * cos_b - cos_a * sin_b;
}
inline float light_node_importance(PtLightNode n, float3 p, float3 nrm) {
    float3 lo = (float3)(n.lo[0], n.lo[1], n.lo[2]);
    float3 hi = (float3)(n.hi[0], n.hi[1], n.hi[2]);
    float3 pc = 0.5f * (lo + hi);
    float3 diag = hi - lo;
    float half_diagonal2 = 0.25f * dot(diag, diag);
    float3 to = p - pc;
    float to2 = dot(to, to);
    float d2 = fmax(fmax(to2, half_diagonal2), 1e-12f);
    float3 wi = to2 > 0.0f ? to / sqrt(to2) : (float3)(0.0f);
    float cos_w = dot((float3)(n.w[0], n.w[1], n.w[2]), wi);
    if (n.two_sided != 0u) cos_w = fabs(cos_w);
    float sin_w = sqrt(fmax(0.0f, 1.0f - cos_w * cos_w));
    float cos_b = to2 > half_diagonal2 ? sqrt(fmax(0.0f, 1.0f - half_diagonal2 / to2)) : -1.0f;
    float sin_b = sqrt(fmax(0.0f, 1.0f - cos_b * cos_b));
    float sin_o = sqrt(fmax(0.0f, 1.0f - n.cos_theta_o * n.cos_theta_o));
    float cos_x = cos_sub_clamped(sin_w, cos_w, sin_o, n.cos_theta_o);
    float sin_x = sin_sub_clamped(sin_w, cos_w, sin_o, n.cos_theta_o);
    float cos_p = cos_sub_clamped(sin_x, cos_x, sin_b, cos_b);
    if (cos_p <= n.cos_theta_e) return 0.0f;
    float imp = n.phi * cos_p / d2;
    if (nrm.x != 0.0f || nrm.y != 0.0f || nrm.z != 0.0f) {
        float cos_i = fabs(dot(wi, nrm));
        float sin_i = sqrt(fmax(0.0f, 1.0f - cos_i * cos_i));
        imp = imp * cos_sub_clamped(sin_i, cos_i, sin_b, cos_b);
    }
    return fmax(imp, 0.0f);
}

// Walks the light tree from the root with the random number `u`, each
// child chosen in proportion to its importance at `p`: the leaf's payload
// (a light's index, or LIGHT_NODE_EMITTER and an emitter's) and its
// probability in `pmf`, -1 where no light can reach `p`.
inline int light_tree_pick(const __global PtLightNode* nodes, float3 p, float3 nrm, float u,
                           float* pmf) {
    uint at = 0u;
    *pmf = 1.0f;
    const float one_minus_epsilon = 0x1.fffffep-1f;
    for (;;) {
        PtLightNode n = nodes[at];
        if ((n.child & LIGHT_NODE_LEAF) != 0u) return (int)(n.child & ~LIGHT_NODE_LEAF);
        uint c = n.child;
        float i0 = light_node_importance(nodes[c], p, nrm);
        float i1 = light_node_importance(nodes[c + 1u], p, nrm);
        if (!(i0 > 0.0f) && !(i1 > 0.0f)) return -1;
        float p0 = i0 / (i0 + i1);
        if (u < p0) {
            *pmf = *pmf * p0;
            u = fmin(u / p0, one_minus_epsilon);
            at = c;
        } else {
            *pmf = *pmf * (1.0f - p0);
            u = fmin((u - p0) / (1.0f - p0), one_minus_epsilon);
            at = c + 1u;
        }
    }
}

// The probability that light_tree_pick chooses the leaf at the end of
// `trail` (bit k: the second child at depth k) at `p`: the same products
// along one path.
inline float light_tree_pmf(const __global PtLightNode* nodes, float3 p, float3 nrm, uint trail) {
    uint at = 0u;
    float pmf = 1.0f;
    for (;;) {
        PtLightNode n = nodes[at];
        if ((n.child & LIGHT_NODE_LEAF) != 0u) return pmf;
        uint c = n.child;
        float i0 = light_node_importance(nodes[c], p, nrm);
        float i1 = light_node_importance(nodes[c + 1u], p, nrm);
        if (!(i0 > 0.0f) && !(i1 > 0.0f)) return 0.0f;
        float p0 = i0 / (i0 + i1);
        if ((trail & 1u) == 0u) {
            pmf = pmf * p0;
            at = c;
        } else {
            pmf = pmf * (1.0f - p0);
            at = c + 1u;
        }
        trail = trail >> 1;
    }
}

#endif
