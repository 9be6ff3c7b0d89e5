// Probes for the path tracer's device functions, for the tests that hold
// them to their Rust references (src/trace/material.rs, lights.rs,
// sampling.rs): the BSDF (eval, pdf, sample), the
// punctual lights, the environment map and the random numbers, each on
// arrays of inputs the host makes.
#pragma OPENCL FP_CONTRACT OFF

#include "pt_types.h"
#include "sampling.h"
#include "bsdf.h"
#include "lights.h"
#include "lens.h"
#ifdef HAS_TRANSMISSION
#include "media.h"
#endif


// A BSDF probe's first 12 outputs for `p` at wo, wi, sampling with the
// random numbers u (lobe, u1, u2): eval rgb, pdf, sampled (ok: 1, or 2
// from a delta lobe; 0: none), wi xyz, f rgb, pdf.
inline void probe_bsdf_out(BsdfParams p, float3 wo, float3 wi, float3 u, __global float* o) {
    float3 f = bsdf_eval(p, wo, wi);
    o[0] = f.x; o[1] = f.y; o[2] = f.z;
    o[3] = bsdf_pdf(p, wo, wi);
    float3 swi, sf;
    float spdf;
    bool delta;
    bool ok = bsdf_sample(p, wo, u.x, u.y, u.z, &swi, &sf, &spdf, &delta);
    o[4] = ok ? (delta ? 2.0f : 1.0f) : 0.0f;
    o[5] = ok ? swi.x : 0.0f; o[6] = ok ? swi.y : 0.0f; o[7] = ok ? swi.z : 0.0f;
    o[8] = ok ? sf.x : 0.0f; o[9] = ok ? sf.y : 0.0f; o[10] = ok ? sf.z : 0.0f;
    o[11] = ok ? spdf : 0.0f;
}

// Per case: params (base rgb, metallic, alpha, specular, 0, 0), wo (xyz,
// 0), wi (xyz, 0), u (lobe, u1, u2, 0): 20 floats. Out per case: eval rgb,
// pdf, sampled (ok: 1, or 2 from a delta lobe; wi xyz), sampled f rgb, sampled pdf: 12 floats.
__kernel void bsdf_probe(__global const float* in, __global float* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global float* c = in + (size_t)i * 20u;
    BsdfParams p;
    p.base = (float3)(c[0], c[1], c[2]);
    p.metallic = c[3];
    p.alpha = c[4];
    p.specular = c[5];
    float3 wo = (float3)(c[8], c[9], c[10]);
    float3 wi = (float3)(c[12], c[13], c[14]);
    __global float* o = out + (size_t)i * 12u;
    probe_bsdf_out(p, wo, wi, (float3)(c[16], c[17], c[18]), o);
}

#ifdef HAS_MATERIAL_EXT
#endif

#ifdef HAS_TRANSMISSION

// As bsdf_probe with the dielectric extensions: per case params (base rgb,
// metallic, alpha, specular, f0, transmission), (eta, thin, f0 green,
// f0 blue: the coloured F0 is (f0, green, blue)), wo,
// wi, u: 24 floats; with HAS_DIFFUSE_TRANSMISSION, HAS_IRIDESCENCE or
// HAS_DIFFUSE_ROUGHNESS then (diffuse transmission, its colour rgb),
// (iridescence, film ior, film thickness nm, diffuse roughness): 32. With HAS_ANISOTROPY, alpha_t is wo's fourth
// float. Out as bsdf_probe: 12 floats.
#if defined(HAS_DIFFUSE_TRANSMISSION) || defined(HAS_IRIDESCENCE) || defined(HAS_DIFFUSE_ROUGHNESS)
#define BSDF_EXT_PROBE_STRIDE 32u
#else
#define BSDF_EXT_PROBE_STRIDE 24u
#endif
__kernel void bsdf_ext_probe(__global const float* in, __global float* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global float* c = in + (size_t)i * BSDF_EXT_PROBE_STRIDE;
    BsdfParams p;
    p.base = (float3)(c[0], c[1], c[2]);
    p.metallic = c[3];
    p.alpha = c[4];
    p.specular = c[5];
    p.f0 = c[6];
    p.transmission = c[7];
    p.eta = c[8];
    p.thin = c[9];
    p.f0_color = (float3)(c[6], c[10], c[11]);
#ifdef HAS_DIFFUSE_TRANSMISSION
    p.diffuse_transmission = c[24];
    p.diffuse_transmission_color = (float3)(c[25], c[26], c[27]);
#endif
#ifdef HAS_IRIDESCENCE
    p.iridescence = c[28];
    p.iridescence_ior = c[29];
    p.iridescence_thickness = c[30];
#endif
    PtMaterialInputs inputs;
    p.in = &inputs;
#ifdef HAS_DIFFUSE_ROUGHNESS
    p.in->diffuse_roughness = c[31];
#endif
#ifdef HAS_ANISOTROPY
    p.alpha_t = c[15];
#endif
    float3 wo = (float3)(c[12], c[13], c[14]);
    float3 wi = (float3)(c[16], c[17], c[18]);
    __global float* o = out + (size_t)i * 12u;
    probe_bsdf_out(p, wo, wi, (float3)(c[20], c[21], c[22]), o);
}

// The nested dielectrics' list (media.h): per case MEDIA_PROBE_STEPS
// crossings (material, front: 1 or back: 0) of a transmitting path from
// outside everything. Out per step: whether it is a false interface (back
// faces), the volume on the other side, then the innermost volume and the
// count after the crossing (4 uints).
#define MEDIA_PROBE_STEPS 16u
__kernel void media_probe(__global const uint* in, __global uint* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global uint* c = in + (size_t)i * (2u * MEDIA_PROBE_STEPS);
    __global uint* o = out + (size_t)i * (4u * MEDIA_PROBE_STEPS);
    PtMedia m = media_empty();
    for (uint k = 0u; k < MEDIA_PROBE_STEPS; ++k) {
        uint mat = c[2u * k];
        bool front = c[2u * k + 1u] != 0u;
        o[4u * k] = !front && media_false_interface(&m, mat) ? 1u : 0u;
        o[4u * k + 1u] = media_other(&m, mat, front);
        if (front)
            media_enter(&m, mat);
        else
            media_leave(&m, mat);
        o[4u * k + 2u] = media_innermost(&m);
        o[4u * k + 3u] = m.count;
    }
}

// Per case: ior, index beyond, front (1) or back (0) -> media_eta,
// media_f0 (2 floats).
__kernel void media_eta_probe(__global const float* in, __global float* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global float* c = in + (size_t)i * 3u;
    out[2u * i] = media_eta(c[0], c[1], c[2] != 0.0f);
    out[2u * i + 1u] = media_f0(c[0], c[1]);
}

// Per case: ior, dispersion, channel (-1 to 2) -> media_channel_ior.
__kernel void media_channel_probe(__global const float* in, __global float* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global float* c = in + (size_t)i * 3u;
    out[i] = media_channel_ior(c[0], c[1], (int)c[2]);
}
#endif

// The BsdfParams of a layer probe's case `c` (bsdf_layer_probe): params
// (base rgb, metallic, alpha, specular, f0, transmission), (eta, thin, f0
// green, f0 blue), (clearcoat, coat alpha, sheen roughness, diffuse
// roughness), (sheen rgb, 0), wo, wi, u, (coat normal, 0): 36 floats, each
// read only where its
// define is on (the dielectric ones with HAS_TRANSMISSION; with
// HAS_ANISOTROPY alpha_t is wo's fourth float).
inline BsdfParams probe_layer_params(const __global float* c, PtMaterialInputs* inputs) {
    BsdfParams p;
#ifdef HAS_MATERIAL_EXT
    p.in = inputs;
#endif
    p.base = (float3)(c[0], c[1], c[2]);
    p.metallic = c[3];
    p.alpha = c[4];
    p.specular = c[5];
#ifdef HAS_TRANSMISSION
    p.f0 = c[6];
    p.transmission = c[7];
    p.eta = c[8];
    p.thin = c[9];
    p.f0_color = (float3)(c[6], c[10], c[11]);
#ifdef HAS_DIFFUSE_TRANSMISSION
    p.diffuse_transmission = 0.0f;
    p.diffuse_transmission_color = (float3)(1.0f);
#endif
#ifdef HAS_IRIDESCENCE
    p.iridescence = 0.0f;
#endif
#ifdef HAS_DIFFUSE_ROUGHNESS
    p.in->diffuse_roughness = c[15];
#endif
#ifdef HAS_ANISOTROPY
    p.alpha_t = c[23];
#endif
#endif
#ifdef HAS_CLEARCOAT
    p.clearcoat = c[12];
    p.coat_alpha = c[13];
    p.coat_n = (float3)(c[32], c[33], c[34]);
#endif
#ifdef HAS_SHEEN
    p.in->sheen_roughness = c[14];
    p.sheen_color = (float3)(c[16], c[17], c[18]);
#endif
    return p;
}

// A layer probe case's wo and wi.
inline float3 probe_layer_wo(const __global float* c) { return (float3)(c[20], c[21], c[22]); }
inline float3 probe_layer_wi(const __global float* c) { return (float3)(c[24], c[25], c[26]); }

#ifdef HAS_LAYERS
// As bsdf_ext_probe with the coat and sheen layers: per case the 36 floats
// of probe_layer_params. Out as bsdf_probe: 12 floats, plus only-delta: 13.
__kernel void bsdf_layer_probe(__global const float* in, __global float* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global float* c = in + (size_t)i * 36u;
    PtMaterialInputs inputs;
    BsdfParams p = probe_layer_params(c, &inputs);
    float3 wo = probe_layer_wo(c);
    float3 wi = probe_layer_wi(c);
    __global float* o = out + (size_t)i * 13u;
    probe_bsdf_out(p, wo, wi, (float3)(c[28], c[29], c[30]), o);
    o[12] = bsdf_only_delta(p) ? 1.0f : 0.0f;
}
#endif

#ifdef FILM_LIGHT
// bsdf_eval and bsdf_lobe_parts on the cases of probe_layer_params (36
// floats; u: the lobe and direction numbers). Out per case (40 floats):
// the value, its diffuse part and its transmission part (9 floats), the
// same three from bsdf_eval_parts (9); then bsdf_sample_parts' result
// (sampled: 1, or 2 from a delta lobe; 0: none), its wi, value and parts
// (10), and bsdf_eval and bsdf_lobe_parts at that wi (9, zero unsampled).
__kernel void bsdf_lobes_probe(__global const float* in, __global float* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global float* c = in + (size_t)i * 36u;
    PtMaterialInputs inputs;
    BsdfParams p = probe_layer_params(c, &inputs);
    float3 wo = probe_layer_wo(c);
    float3 wi = probe_layer_wi(c);
    float3 d, t;
    float3 f = bsdf_eval(p, wo, wi);
    bsdf_lobe_parts(p, wo, wi, &d, &t);
    __global float* o = out + (size_t)i * 40u;
    o[0] = f.x; o[1] = f.y; o[2] = f.z;
    o[3] = d.x; o[4] = d.y; o[5] = d.z;
    o[6] = t.x; o[7] = t.y; o[8] = t.z;
    f = bsdf_eval_parts(p, wo, wi, &d, &t);
    o[9] = f.x; o[10] = f.y; o[11] = f.z;
    o[12] = d.x; o[13] = d.y; o[14] = d.z;
    o[15] = t.x; o[16] = t.y; o[17] = t.z;
    float3 swi = (float3)(0.0f);
    float spdf;
    bool delta;
    f = d = t = (float3)(0.0f);
    bool ok = bsdf_sample_parts(p, wo, c[28], c[29], c[30], &swi, &f, &spdf, &delta, &d, &t);
    o[18] = ok ? (delta ? 2.0f : 1.0f) : 0.0f;
    if (!ok) swi = f = d = t = (float3)(0.0f);
    o[19] = swi.x; o[20] = swi.y; o[21] = swi.z;
    o[22] = f.x; o[23] = f.y; o[24] = f.z;
    o[25] = d.x; o[26] = d.y; o[27] = d.z;
    o[28] = t.x; o[29] = t.y; o[30] = t.z;
    float3 e = (float3)(0.0f);
    d = t = (float3)(0.0f);
    if (ok && !delta) {
        e = bsdf_eval(p, wo, swi);
        bsdf_lobe_parts(p, wo, swi, &d, &t);
    }
    o[31] = e.x; o[32] = e.y; o[33] = e.z;
    o[34] = d.x; o[35] = d.y; o[36] = d.z;
    o[37] = t.x; o[38] = t.y; o[39] = t.z;
}
#endif

// Per case: light index, point (xyz). Out: ok, wi xyz, dist, e rgb (8).
__kernel void light_probe(__global const PtLight* lights, __global const float* in,
                          __global float* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global float* c = in + (size_t)i * 4u;
    float3 wi, e;
    float dist;
    bool ok = punctual_incident(lights[(uint)c[0]], (float3)(c[1], c[2], c[3]), &wi, &dist, &e);
    __global float* o = out + (size_t)i * 8u;
    o[0] = ok ? 1.0f : 0.0f;
    o[1] = ok ? wi.x : 0.0f; o[2] = ok ? wi.y : 0.0f; o[3] = ok ? wi.z : 0.0f;
    o[4] = ok ? dist : 0.0f;
    o[5] = ok ? e.x : 0.0f; o[6] = ok ? e.y : 0.0f; o[7] = ok ? e.z : 0.0f;
}

// Per case: a point (xyz), a normal (xyz), u and a trail (its bits). Out:
// the leaf the tree picks (its payload's bits, -1: none), its probability,
// and the probability of the trail's leaf.
__kernel void light_tree_probe(__global const PtLightNode* nodes, __global const float* in,
                               __global float* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global float* c = in + (size_t)i * 8u;
    float3 p = (float3)(c[0], c[1], c[2]);
    float3 nrm = (float3)(c[3], c[4], c[5]);
    float pmf = 0.0f;
    int leaf = light_tree_pick(nodes, p, nrm, c[6], &pmf);
    out[3u * i] = as_float(leaf);
    out[3u * i + 1u] = leaf >= 0 ? pmf : 0.0f;
    out[3u * i + 2u] = light_tree_pmf(nodes, p, nrm, as_uint(c[7]));
}

// Per case: u1, u2, and a direction (xyz). Out: sampled wi xyz, radiance
// rgb, pdf, then the radiance rgb and pdf of the given direction (11).
__kernel void env_probe(__global const PtEnv* env, __global const float4* texels,
                        __global const float* marginal, __global const float* conditional,
                        __global const float* in, __global float* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global float* c = in + (size_t)i * 5u;
    float3 wi = (float3)(0.0f);
    float pdf;
    float3 l = env_sample(env[0], texels, marginal, conditional, c[0], c[1], &wi, &pdf);
    __global float* o = out + (size_t)i * 11u;
    o[0] = wi.x; o[1] = wi.y; o[2] = wi.z;
    o[3] = l.x; o[4] = l.y; o[5] = l.z;
    o[6] = pdf;
    float3 d = normalize((float3)(c[2], c[3], c[4]));
    float3 r = env_radiance(env[0], texels, d);
    o[7] = r.x; o[8] = r.y; o[9] = r.z;
    o[10] = env_pdf(env[0], marginal, conditional, d);
}

// Random numbers of the sampler the probe was built with (SAMPLER_RANDOM or
// not): per case (seed lo, seed hi, frame lo, frame hi, pixel, sample, dim)
// → the uniform.
__kernel void rng_probe(__global const uint* in, __global float* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global uint* c = in + (size_t)i * 7u;
    SampleRng r = rng_for_sample(c[0], c[1], c[2], c[3], c[4], c[5]);
    out[i] = rng_1d(r, c[6]);
}

// Depth of field's lens rays: per case 24 inputs (u, v, blades, rotation, origin,
// right, up, forward and d xyz, znear, radius, focus, 2 unused)
// and 9 outputs (aperture point xy, origin xyz, direction xyz, tmin).
__kernel void pt_lens_probe(__global const float* in, __global float* out, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    __global const float* a = in + 24u * i;
    float2 ap = camera_aperture_point(a[0], a[1], (uint)a[2], a[3]);
    float3 org, dir;
    float tmin;
    camera_lens_ray((float3)(a[4], a[5], a[6]), (float3)(a[7], a[8], a[9]),
                    (float3)(a[10], a[11], a[12]), (float3)(a[13], a[14], a[15]),
                    (float3)(a[16], a[17], a[18]), a[19], a[20], a[21], ap, &org, &dir, &tmin);
    __global float* o = out + 9u * i;
    o[0] = ap.x; o[1] = ap.y;
    o[2] = org.x; o[3] = org.y; o[4] = org.z;
    o[5] = dir.x; o[6] = dir.y; o[7] = dir.z;
    o[8] = tmin;
}
