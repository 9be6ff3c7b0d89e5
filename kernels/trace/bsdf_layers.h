// The clear coat and sheen layers over the base BSDF (KHR_materials_clearcoat,
// KHR_materials_sheen), and the entry points bsdf_eval, bsdf_pdf,
// bsdf_sample and bsdf_only_delta over them; included by bsdf.h after the
// base BSDF. Without HAS_LAYERS the entry points are the base's.
#ifndef SOUPRAY_BSDF_LAYERS_H
#define SOUPRAY_BSDF_LAYERS_H

#pragma OPENCL FP_CONTRACT OFF

// With the light-path passes the layered sampler is bsdf_sample_parts,
// which also leaves the diffuse and transmission parts of the value it
// samples; without them it is bsdf_sample itself.
#ifdef FILM_LIGHT
#define SAMPLE_PARTS(name)                                                              \
    name##_parts(BsdfParams p, float3 wo, float lobe_u, float u1, float u2, float3* wi_out, \
                 float3* f_out, float* pdf_out, bool* delta_out, float3* diffuse,           \
                 float3* transmit)
#else
#define SAMPLE_PARTS(name)                                                       \
    name(BsdfParams p, float3 wo, float lobe_u, float u1, float u2, float3* wi_out, \
         float3* f_out, float* pdf_out, bool* delta_out)
#endif

#ifdef HAS_LAYERS
// The clear coat and sheen layers over the base (KHR_materials_clearcoat,
// KHR_materials_sheen), mirroring trace::material's layered_eval, _pdf and
// _sample: f = (1 - cc Fc(n.v)) (sheen + base * scaling) + cc Fc(n.v) coat.
// A coat or sheen of weight 0 leaves the base's value unchanged.

#ifdef HAS_CLEARCOAT
// Schlick's Fresnel of the ior-1.5 coat at the view cosine (fresnel_coat).
inline float coat_weight(BsdfParams p, float cos_o) {
    return clamp(p.clearcoat * (0.04f + 0.96f * schlick_weight(cos_o)), 0.0f, 1.0f);
}

// The coat's frame (Rust twin: coat_frame, to_coat, from_coat): false
// when the coat's normal is the base's, and vectors are used as they are.
inline bool coat_frame(BsdfParams p, float3* t, float3* b) {
    if (p.coat_n.x == 0.0f && p.coat_n.y == 0.0f) return false;
    onb(p.coat_n, t, b);
    return true;
}

inline float3 to_coat(BsdfParams p, bool tilted, float3 t, float3 b, float3 v) {
    return tilted ? to_local(v, t, b, p.coat_n) : v;
}

inline float3 from_coat(BsdfParams p, bool tilted, float3 t, float3 b, float3 v) {
    return tilted ? (t * v.x + b * v.y) + p.coat_n * v.z : v;
}

// The view's cosine with the coat's normal.
inline float coat_cos(BsdfParams p, float3 wo) {
    float3 t, b;
    bool tilted = coat_frame(p, &t, &b);
    return to_coat(p, tilted, t, b, wo).z;
}

// The coat's white GGX lobe about its own normal (0 when smooth: a delta
// lobe), compensated to albedo 1 with GGX_ENERGY_COMPENSATION, and scaled
// by (coat n.l) / (base n.l) when tilted (see coat_lobe in
// trace::material).
inline float coat_lobe(BsdfParams p, float3 wo, float3 wi) {
    if (!(wi.z > 0.0f) || ggx_smooth(p.coat_alpha)) return 0.0f;
    float3 t, b;
    bool tilted = coat_frame(p, &t, &b);
    float3 wi_c = to_coat(p, tilted, t, b, wi);
    wo = to_coat(p, tilted, t, b, wo);
    if (!(wo.z > 0.0f) || !(wi_c.z > 0.0f)) return 0.0f;
    float3 hv = wo + wi_c;
    float hl = length(hv);
    if (hl == 0.0f) return 0.0f;
    float3 h = hv / hl;
    float a = p.coat_alpha;
    float g2 = 1.0f / ((1.0f + ggx_lambda(a, wo.z)) + ggx_lambda(a, wi_c.z));
    float s = (ggx_d(a, h.z) * g2) / ((4.0f * wo.z) * wi_c.z);
#ifdef GGX_ENERGY_COMPENSATION
    s = s / ggx_albedo(a, wo.z);
#endif
    return tilted ? s * (wi_c.z / wi.z) : s;
}

inline float coat_smooth_reflectance(BsdfParams p, float cos_o) {
    float w = coat_weight(p, cos_o);
#ifdef GGX_ENERGY_COMPENSATION
    return w / ggx_albedo(p.coat_alpha, cos_o);
#else
    return w;
#endif
}
#endif

#ifdef HAS_SHEEN
#define SHEEN_MIN_ROUGHNESS 0.07f

inline float sheen_albedo(float r, float mu) { return lut_bilinear(SHEEN_ALBEDO, r, mu); }

inline float sheen_l(float x, float a) {
    float t = (1.0f - a) * (1.0f - a);
    float ma = 21.5473f + (25.3245f - 21.5473f) * t;
    float mb = 3.82987f + (3.32435f - 3.82987f) * t;
    float mc = 0.19823f + (0.16801f - 0.19823f) * t;
    float md = -1.9776f + (-1.27393f - -1.9776f) * t;
    float me = -4.32054f + (-4.85967f - -4.32054f) * t;
    return (ma / (1.0f + mb * pow(x, mc)) + md * x) + me;
}

inline float sheen_lambda(float c, float a) {
    return c < 0.5f ? exp(sheen_l(c, a)) : exp(2.0f * sheen_l(0.5f, a) - sheen_l(1.0f - c, a));
}

// The white Charlie sheen lobe D V (Estevez and Kulla 2017, the
// extension's fits), 0 below the surface.
inline float sheen_lobe(float roughness, float3 wo, float3 wi) {
    if (!(wo.z > 0.0f) || !(wi.z > 0.0f)) return 0.0f;
    float3 hv = wo + wi;
    float hl = length(hv);
    if (hl == 0.0f) return 0.0f;
    float ch = hv.z / hl;
    float a = fmax(roughness, SHEEN_MIN_ROUGHNESS);
    float s2 = fmax(1.0f - ch * ch, 0.0f);
    float d = ((2.0f + 1.0f / a) * pow(s2, 0.5f / a)) * (0.5f * PT_INV_PI);
    return d / (((1.0f + sheen_lambda(wo.z, a)) + sheen_lambda(wi.z, a)) * ((4.0f * wo.z) * wi.z));
}

inline float sheen_max3(float3 v) { return fmax(fmax(v.x, v.y), v.z); }

inline float sheen_probability(BsdfParams p, float cos_o) {
    return clamp(sheen_max3(p.sheen_color) * sheen_albedo(p.in->sheen_roughness, cos_o), 0.0f, 1.0f);
}

// The extension's albedo scaling of the base under the sheen; with
// ENERGY_LAYERING what the sheen leaves towards wo (Rust twin:
// sheen_base_scaling).
inline float sheen_scaling(BsdfParams p, float cos_o, float cos_i) {
    float m = sheen_max3(p.sheen_color);
#ifdef ENERGY_LAYERING
    return 1.0f - m * sheen_albedo(p.in->sheen_roughness, cos_o);
#endif
    return fmin(1.0f - m * sheen_albedo(p.in->sheen_roughness, cos_o),
                1.0f - m * sheen_albedo(p.in->sheen_roughness, cos_i));
}
#endif

inline float3 bsdf_eval(BsdfParams p, float3 wo, float3 wi) {
    if (!(wo.z > 0.0f)) return (float3)(0.0f);
    float3 under = base_bsdf_eval(p, wo, wi);
#ifdef HAS_SHEEN
    under = under * sheen_scaling(p, wo.z, fabs(wi.z)) +
            p.sheen_color * sheen_lobe(p.in->sheen_roughness, wo, wi);
#endif
#ifdef HAS_CLEARCOAT
    float wc = coat_weight(p, coat_cos(p, wo));
    return under * (1.0f - wc) + (float3)(wc * coat_lobe(p, wo, wi));
#else
    return under;
#endif
}

#ifdef FILM_LIGHT
// bsdf_eval, leaving its diffuse and transmission parts in `diffuse` and
// `transmit`: bsdf_lobe_parts' floats, with each lobe evaluated once.
inline float3 bsdf_eval_parts(BsdfParams p, float3 wo, float3 wi, float3* diffuse,
                              float3* transmit) {
    *diffuse = (float3)(0.0f);
    *transmit = (float3)(0.0f);
    if (!(wo.z > 0.0f)) return (float3)(0.0f);
    float3 d;
    float3 under = base_bsdf_eval_split(p, wo, wi, &d);
    float3 t = (float3)(0.0f);
#ifdef HAS_TRANSMISSION
    if (wi.z < 0.0f) t = fmax(under - d, (float3)(0.0f));
#endif
#ifdef HAS_SHEEN
    float scaling = sheen_scaling(p, wo.z, fabs(wi.z));
    float3 sheen = p.sheen_color * sheen_lobe(p.in->sheen_roughness, wo, wi);
    under = under * scaling + sheen;
    d = d * scaling + sheen;
    t = t * scaling;
#endif
#ifdef HAS_CLEARCOAT
    float wc = coat_weight(p, coat_cos(p, wo));
    float keep = 1.0f - wc;
    *diffuse = d * keep;
    *transmit = t * keep;
    return under * (1.0f - wc) + (float3)(wc * coat_lobe(p, wo, wi));
#else
    *diffuse = d;
    *transmit = t;
    return under;
#endif
}

// bsdf_eval's diffuse and transmission parts (see base_bsdf_lobe_parts):
// the sheen is diffuse, the coat glossy, and the layers above scale the
// base's parts as they scale the base (Rust twin: bsdf_eval_lobes).
inline void bsdf_lobe_parts(BsdfParams p, float3 wo, float3 wi, float3* diffuse,
                            float3* transmit) {
    *diffuse = (float3)(0.0f);
    *transmit = (float3)(0.0f);
    if (!(wo.z > 0.0f)) return;
    float3 d, t;
    base_bsdf_lobe_parts(p, wo, wi, &d, &t);
#ifdef HAS_SHEEN
    float scaling = sheen_scaling(p, wo.z, fabs(wi.z));
    d = d * scaling + p.sheen_color * sheen_lobe(p.in->sheen_roughness, wo, wi);
    t = t * scaling;
#endif
#ifdef HAS_CLEARCOAT
    float keep = 1.0f - coat_weight(p, coat_cos(p, wo));
    d = d * keep;
    t = t * keep;
#endif
    *diffuse = d;
    *transmit = t;
}
#endif

inline float bsdf_pdf(BsdfParams p, float3 wo, float3 wi) {
    if (!(wo.z > 0.0f)) return 0.0f;
    float pdf = base_bsdf_pdf(p, wo, wi);
#ifdef HAS_SHEEN
    float psh = sheen_probability(p, wo.z);
    float sheen = wi.z > 0.0f ? 0.5f * PT_INV_PI : 0.0f;
    pdf = psh * sheen + (1.0f - psh) * pdf;
#endif
#ifdef HAS_CLEARCOAT
    float3 t, b;
    bool tilted = coat_frame(p, &t, &b);
    float3 wo_c = to_coat(p, tilted, t, b, wo);
    float3 wi_c = to_coat(p, tilted, t, b, wi);
    float pc = coat_weight(p, wo_c.z);
    float coat = wi.z > 0.0f && wi_c.z > 0.0f && pc > 0.0f && !ggx_smooth(p.coat_alpha)
                     ? ggx_vndf_pdf(p.coat_alpha, wo_c, wi_c) : 0.0f;
    pdf = (1.0f - pc) * pdf + pc * coat;
#endif
    return pdf;
}

// Samples wi for wo (as base_bsdf_sample); with the light-path passes
// (bsdf_sample_parts) it also leaves its value's diffuse and transmission
// parts, as bsdf_eval_parts does (0 for a delta lobe).
inline bool SAMPLE_PARTS(bsdf_sample) {
    *delta_out = false;
#ifdef FILM_LIGHT
    *diffuse = (float3)(0.0f);
    *transmit = (float3)(0.0f);
#endif
    if (!(wo.z > 0.0f)) return false;
    float3 wi;
    float u = lobe_u;
    float keep = 1.0f; // the probability of reaching the base's sampler
    float under_weight = 1.0f; // what scales the base's delta lobes
    bool chosen = false;
#ifdef HAS_CLEARCOAT
    float3 ct, cb;
    bool tilted = coat_frame(p, &ct, &cb);
    float3 wo_c = to_coat(p, tilted, ct, cb, wo);
    float pc = coat_weight(p, wo_c.z);
    if (u < pc) {
        if (!(wo_c.z > 0.0f)) return false;
        if (ggx_smooth(p.coat_alpha)) {
            wi = from_coat(p, tilted, ct, cb, (float3)(-wo_c.x, -wo_c.y, wo_c.z));
            if (!(wi.z > 0.0f)) return false;
            *wi_out = wi;
            *f_out = (float3)(coat_smooth_reflectance(p, wo_c.z) / wi.z);
            *pdf_out = pc;
            *delta_out = true;
            return true;
        }
        float3 h = ggx_sample_vndf(p.coat_alpha, p.coat_alpha, wo_c, u1, u2);
        float3 wi_c = h * (2.0f * dot(wo_c, h)) - wo_c;
        // Below the coat (its pdf there is 0) or below the surface.
        wi = from_coat(p, tilted, ct, cb, wi_c);
        if (!(wi_c.z > 0.0f) || !(wi.z > 0.0f)) return false;
        chosen = true;
    } else {
        u = (u - pc) / (1.0f - pc);
        keep = 1.0f - pc;
        under_weight = 1.0f - pc;
    }
#endif
#ifdef HAS_SHEEN
    float psh = sheen_probability(p, wo.z);
    if (!chosen) {
        if (u < psh) {
            wi = sample_uniform_hemisphere(u1, u2);
            chosen = true;
        } else {
            u = (u - psh) / (1.0f - psh);
            keep = keep * (1.0f - psh);
        }
    }
#endif
    if (!chosen) {
        float3 bf;
        float bpdf;
        bool bdelta;
        if (!base_bsdf_sample(p, wo, u, u1, u2, &wi, &bf, &bpdf, &bdelta)) return false;
        if (bdelta) {
#ifdef HAS_SHEEN
            float scale = sheen_scaling(p, wo.z, fabs(wi.z)) * under_weight;
#else
            float scale = under_weight;
#endif
            *wi_out = wi;
            *f_out = bf * scale;
            *pdf_out = bpdf * keep;
            *delta_out = true;
            return true;
        }
    }
    if (wi.z == 0.0f) return false;
    float pdf = bsdf_pdf(p, wo, wi);
    if (!(pdf > 0.0f)) return false;
    *wi_out = wi;
#ifdef FILM_LIGHT
    *f_out = bsdf_eval_parts(p, wo, wi, diffuse, transmit);
#else
    *f_out = bsdf_eval(p, wo, wi);
#endif
    *pdf_out = pdf;
    return true;
}

// True when every lobe is a delta lobe (see base_only_delta).
inline bool bsdf_only_delta(BsdfParams p) {
#ifdef HAS_CLEARCOAT
    if (p.clearcoat > 0.0f && !ggx_smooth(p.coat_alpha)) return false;
#endif
#ifdef HAS_SHEEN
    if (sheen_max3(p.sheen_color) > 0.0f) return false;
#endif
    return base_only_delta(p);
}
#else
// Without layers the BSDF is the base.
inline float3 bsdf_eval(BsdfParams p, float3 wo, float3 wi) { return base_bsdf_eval(p, wo, wi); }
inline float bsdf_pdf(BsdfParams p, float3 wo, float3 wi) { return base_bsdf_pdf(p, wo, wi); }
inline bool bsdf_only_delta(BsdfParams p) { return base_only_delta(p); }
#ifndef FILM_LIGHT
inline bool bsdf_sample(BsdfParams p, float3 wo, float lobe_u, float u1, float u2,
                        float3* wi_out, float3* f_out, float* pdf_out, bool* delta_out) {
    return base_bsdf_sample(p, wo, lobe_u, u1, u2, wi_out, f_out, pdf_out, delta_out);
}
#else
inline bool bsdf_sample_parts(BsdfParams p, float3 wo, float lobe_u, float u1, float u2,
                              float3* wi_out, float3* f_out, float* pdf_out, bool* delta_out,
                              float3* diffuse, float3* transmit) {
    *transmit = (float3)(0.0f);
    bool ok = base_bsdf_sample_split(p, wo, lobe_u, u1, u2, wi_out, f_out, pdf_out, delta_out,
                                     diffuse);
#ifdef HAS_TRANSMISSION
    if (ok && !*delta_out && wi_out->z < 0.0f) *transmit = fmax(*f_out - *diffuse, (float3)(0.0f));
#endif
    return ok;
}
inline void bsdf_lobe_parts(BsdfParams p, float3 wo, float3 wi, float3* diffuse,
                            float3* transmit) {
    base_bsdf_lobe_parts(p, wo, wi, diffuse, transmit);
}
inline float3 bsdf_eval_parts(BsdfParams p, float3 wo, float3 wi, float3* diffuse,
                              float3* transmit) {
    *transmit = (float3)(0.0f);
    float3 f = base_bsdf_eval_split(p, wo, wi, diffuse);
#ifdef HAS_TRANSMISSION
    if (wi.z < 0.0f) *transmit = fmax(f - *diffuse, (float3)(0.0f));
#endif
    return f;
}
#endif
#endif

#ifdef FILM_LIGHT
// bsdf_sample_parts without the parts (for the probes).
inline bool bsdf_sample(BsdfParams p, float3 wo, float lobe_u, float u1, float u2,
                        float3* wi_out, float3* f_out, float* pdf_out, bool* delta_out) {
    float3 diffuse, transmit;
    return bsdf_sample_parts(p, wo, lobe_u, u1, u2, wi_out, f_out, pdf_out, delta_out, &diffuse,
                             &transmit);
}
#endif
#undef SAMPLE_PARTS

#endif
