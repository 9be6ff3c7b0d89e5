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

#endif
