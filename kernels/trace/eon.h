// Part of the BSDF (bsdf.h includes it with HAS_DIFFUSE_ROUGHNESS).
#ifndef SOUPRAY_EON_H
#define SOUPRAY_EON_H

#pragma OPENCL FP_CONTRACT OFF

// KHR_materials_diffuse_roughness: the energy-preserving Oren-Nayar BRDF
// (EON: Portsmouth, Kutz and Hill 2024, Listing 1, as OpenPBR's diffuse),
// Fujii's Oren-Nayar single scattering plus the multiple scattering that
// makes a white lobe reflect everything. Roughness 0 is Lambert's lobe.
// Rust twins: eon_fon_albedo, eon_eval.
#define EON_C1 (0.5f - 2.0f / (3.0f * PT_PI))
#define EON_C2 (2.0f / 3.0f - 28.0f / (15.0f * PT_PI))

// Fujii's Oren-Nayar directional albedo at cosine `mu`, the paper's fit.
inline float eon_fon_albedo(float mu, float r) {
    float m = 1.0f - mu;
    float g = m * (0.0571085289f + m * (0.491881867f + m * (-0.332181442f + m * 0.0714429953f)));
    return (1.0f + r * g) / (1.0f + EON_C1 * r);
}

// The rough diffuse BRDF of albedo `rho` and roughness `r` for wo, wi above
// the surface: in place of rho / pi.
inline float3 eon_eval(float3 rho, float r, float3 wo, float3 wi) {
    float s = dot(wi, wo) - wi.z * wo.z;
    float s_over_t = s > 0.0f ? s / fmax(wi.z, wo.z) : s;
    float af = 1.0f / (1.0f + EON_C1 * r);
    float3 single = rho * ((PT_INV_PI * af) * (1.0f + r * s_over_t));
    float e_avg = af * (1.0f + EON_C2 * r);
    float3 rho_ms = ((rho * rho) * e_avg) / ((float3)(1.0f) - rho * (1.0f - e_avg));
    float k = (fmax(1.0e-7f, 1.0f - eon_fon_albedo(wo.z, r)) * fmax(1.0e-7f, 1.0f - eon_fon_albedo(wi.z, r))) /
              fmax(1.0e-7f, 1.0f - e_avg);
    return single + rho_ms * (PT_INV_PI * k);
}

#endif
