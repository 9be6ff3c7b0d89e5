// The dielectric's energy-conserving layering (ENERGY_LAYERING, the default
// `--layering energy`), included by bsdf.h; mirrors
// src/trace/material/layering.rs, which says why. The base under the
// specular layer is scaled by what the layer does not reflect, its
// directional albedo E_spec = F0 E + (1 - F0) E_w (times Turquin's factor
// with GGX_ENERGY_COMPENSATION), per channel: the Lambertian lobes by Kulla
// and Conty's reciprocal (1 - E_spec(mu_o)) (1 - E_spec(mu_i)) /
// (1 - E_spec_avg), the thin-walled transmission by 1 - E_spec(mu_o).
#ifndef SOUPRAY_LAYERING_H
#define SOUPRAY_LAYERING_H

#pragma OPENCL FP_CONTRACT OFF

#ifdef ENERGY_LAYERING
#include "ggx_schlick_energy.h"
#include "ggx_average_energy.h"

// Whether the layering applies: wo outside (or thin-walled), where the
// layer's Fresnel is Schlick's of the cosine (Rust twin: energy_layered).
inline bool energy_layered(BsdfParams p) {
#ifdef HAS_TRANSMISSION
    return p.eta >= 1.0f;
#else
    return true;
#endif
}

inline float3 layer_f0(BsdfParams p) {
#ifdef HAS_TRANSMISSION
    return p.f0_color;
#else
    return (float3)(0.04f);
#endif
}

inline float schlick_albedo(float a, float mu) {
    return lut_bilinear(GGX_SCHLICK_ALBEDO, sqrt(a), mu);
}

// The cosine-weighted averages of E, E_w and E_w / E at alpha a, linear
// between the roughness nodes.
inline float3 albedo_averages(float a) {
    float x = clamp(sqrt(a), 0.0f, 1.0f) * 31.0f;
    uint i = min((uint)x, 30u);
    float f = x - (float)i;
    return (float3)(GGX_ALBEDO_AVERAGE[i] * (1.0f - f) + GGX_ALBEDO_AVERAGE[i + 1u] * f,
                    GGX_ALBEDO_AVERAGE[32u + i] * (1.0f - f) + GGX_ALBEDO_AVERAGE[33u + i] * f,
                    GGX_ALBEDO_AVERAGE[64u + i] * (1.0f - f) + GGX_ALBEDO_AVERAGE[65u + i] * f);
}

#ifdef HAS_TRANSMISSION
#include "ggx_refraction_energy.h"

// Trilinear lookup in `plane` of GGX_REFRACTION_ALBEDO at index ratio
// `ratio` (1 to 3), alpha a and cosine mu (Rust twin:
// trace::energy::refraction_lookup).
inline float refraction_lookup(uint plane, float ratio, float a, float mu) {
    float x0 = clamp((ratio - 1.0f) * 0.5f, 0.0f, 1.0f) * (float)(GGX_REFRACTION_ETA - 1u);
    float x1 = clamp(sqrt(a), 0.0f, 1.0f) * (float)(GGX_REFRACTION_R - 1u);
    float x2 = clamp(mu, 0.0f, 1.0f) * (float)(GGX_REFRACTION_MU - 1u);
    uint i0 = min((uint)x0, GGX_REFRACTION_ETA - 2u);
    uint i1 = min((uint)x1, GGX_REFRACTION_R - 2u);
    uint i2 = min((uint)x2, GGX_REFRACTION_MU - 2u);
    float f0 = x0 - (float)i0;
    float f1 = x1 - (float)i1;
    float f2 = x2 - (float)i2;
    float sum = 0.0f;
    for (uint c = 0u; c < 8u; ++c) {
        uint u0 = c & 1u;
        uint u1 = (c >> 1) & 1u;
        uint u2 = (c >> 2) & 1u;
        uint index = ((plane * GGX_REFRACTION_ETA + i0 + u0) * GGX_REFRACTION_R + i1 + u1) *
                         GGX_REFRACTION_MU +
                     i2 + u2;
        float w = ((u0 != 0u ? f0 : 1.0f - f0) * (u1 != 0u ? f1 : 1.0f - f1)) *
                  (u2 != 0u ? f2 : 1.0f - f2);
        sum += GGX_REFRACTION_ALBEDO[index] * w;
    }
    return sum;
}

// The energy albedo of the Fresnel-less refraction lobe (Rust twin:
// trace::energy::refraction_albedo).
inline float refraction_albedo(float a, float mu, float eta) {
    return eta >= 1.0f ? refraction_lookup(0u, eta, a, mu) : refraction_lookup(1u, 1.0f / eta, a, mu);
}
#endif

inline float layer_rms_alpha(BsdfParams p) {
#ifdef HAS_ANISOTROPY
    if (p.alpha_t != p.alpha) return sqrt((p.alpha_t * p.alpha_t + p.alpha * p.alpha) * 0.5f);
#endif
    return p.alpha;
}

// The white (x) and Schlick-weighted (y) albedos of the base's lobe
// towards w (Rust twin: lobe_albedos).
inline float2 lobe_albedos(BsdfParams p, float3 w) {
    float a = layer_rms_alpha(p);
    float e = ggx_albedo(a, w.z);
#ifdef HAS_TRANSMISSION
    float ew = p.eta < 1.0f ? refraction_lookup(2u, 1.0f / p.eta, a, w.z) : schlick_albedo(a, w.z);
#else
    float ew = schlick_albedo(a, w.z);
#endif
#if defined(HAS_ANISOTROPY) && defined(GGX_ENERGY_COMPENSATION)
    if (p.alpha_t != p.alpha) {
        float ea = spec_albedo(p, w);
        return (float2)(ea, ew * (ea / e));
    }
#endif
    return (float2)(e, ew);
}

// The specular layer's directional albedo towards w, per channel.
inline float3 layer_albedo(BsdfParams p, float3 w) {
    float3 f0 = layer_f0(p);
    float mu = w.z;
    if (spec_smooth(p)) {
#ifdef HAS_TRANSMISSION
        float3 f = layer_fresnel(p, mu) * p.specular;
#else
        float3 f = (float3)(0.04f + 0.96f * schlick_weight(mu)) * p.specular;
#endif
#ifdef GGX_ENERGY_COMPENSATION
        return f * ((float3)(1.0f) + f0 * (1.0f / ggx_albedo(p.alpha, mu) - 1.0f));
#else
        return f;
#endif
    }
    float2 e = lobe_albedos(p, w);
    float3 f = (f0 * e.x + ((float3)(1.0f) - f0) * e.y) * p.specular;
#ifdef GGX_ENERGY_COMPENSATION
#ifdef HAS_TRANSMISSION
    // Inside a volume Turquin's F0 is the lobe's mean Fresnel (Rust twin:
    // compensation_f0).
    if (p.eta < 1.0f) f0 = f0 + ((float3)(1.0f) - f0) * (e.y / e.x);
#endif
    return f * ((float3)(1.0f) + f0 * (1.0f / e.x - 1.0f));
#else
    return f;
#endif
}

// The cosine-weighted average of layer_albedo over the hemisphere.
inline float3 layer_average(BsdfParams p) {
    float3 f0 = layer_f0(p);
    float3 g = (float3)(1.0f) - f0;
    if (spec_smooth(p)) return (f0 + g / 21.0f) * p.specular;
    float3 m = albedo_averages(layer_rms_alpha(p));
#ifdef GGX_ENERGY_COMPENSATION
    float3 avg = ((f0 * g * m.x + f0 * f0) + g * g * m.y) + f0 * g * m.z;
#else
    float3 avg = f0 * m.x + g * m.y;
#endif
    return avg * p.specular;
}

inline float layering_ratio(float k, float r) { return r > 0.0f ? k / r : 0.0f; }

// Kulla and Conty's reciprocal scaling of a Lambertian lobe under the
// layer, for wo and wi_up (wi, or its mirror for a lobe below).
inline float3 lambert_scaling(BsdfParams p, float3 wo, float3 wi_up) {
    float3 keep_o = fmax((float3)(1.0f) - layer_albedo(p, wo), (float3)(0.0f));
    float3 keep_i = fmax((float3)(1.0f) - layer_albedo(p, wi_up), (float3)(0.0f));
    float3 rest = (float3)(1.0f) - layer_average(p);
    return (float3)(layering_ratio(keep_o.x * keep_i.x, rest.x),
                    layering_ratio(keep_o.y * keep_i.y, rest.y),
                    layering_ratio(keep_o.z * keep_i.z, rest.z));
}

// What the layer leaves the base towards wo: 1 - E_spec(wo).
inline float3 layer_transmittance(BsdfParams p, float3 wo) {
    return fmax((float3)(1.0f) - layer_albedo(p, wo), (float3)(0.0f));
}

#ifdef HAS_TRANSMISSION
// The F0 of Turquin's factor for the rough reflection lobe towards wo
// (Rust twin: reflection_compensation_f0).
inline float3 reflection_compensation_f0(BsdfParams p, float3 wo) {
    if (p.eta >= 1.0f || spec_smooth(p)) return p.f0_color;
    float2 e = lobe_albedos(p, wo);
    return p.f0_color + ((float3)(1.0f) - p.f0_color) * (e.y / e.x);
}

// The scaling of a refracting volume's Fresnel-less transmission lobe:
// 1 - E_spec(wo) over the lobe's energy albedo when compensated (Rust
// twin: refraction_scaling).
inline float3 refraction_scaling(BsdfParams p, float3 wo) {
    float3 keep = layer_transmittance(p, wo);
#ifdef GGX_ENERGY_COMPENSATION
    if (!spec_smooth(p)) return keep / fmax(refraction_albedo(layer_rms_alpha(p), wo.z, p.eta), 0.01f);
#endif
    return keep;
}
#endif
#endif

#endif
