// The glTF 2.0 metallic-roughness BSDF (the specification's Appendix B):
//   f = (1 - m) * [ (1 - Fd) * base / pi + Fd * S ] + m * Fm * S
// with S = D * G2 / (4 |n.l| |n.v|) the GGX (Trowbridge-Reitz) specular lobe
// with height-correlated Smith masking, alpha = roughness^2, Fd the Schlick
// Fresnel of a 4 % dielectric and Fm = base + (1 - base) (1 - v.h)^5 the
// conductor's. Sampling picks the diffuse lobe (cosine) or the specular lobe
// (visible normals, Heitz 2018) with a probability from the lobes' albedo
// estimate and returns the pdf of the whole mixture, for MIS.
//
// With HAS_TRANSMISSION (some material uses KHR_materials_transmission,
// _ior or _volume): F0 comes from the ior, and the share `transmission` of
// the dielectric's diffuse lobe becomes a GGX transmission lobe tinted by
// the base colour, thin-walled (the reflection lobe mirrored through the
// surface) or refracting (Walter et al. 2007, as pbrt-v4's DielectricBxDF
// with its 1/eta^2 radiance scaling); wi may then lie below the surface.
// With HAS_DIFFUSE_TRANSMISSION (KHR_materials_diffuse_transmission, which
// implies HAS_TRANSMISSION) the share `diffuse_transmission` of what stays
// of the diffuse lobe becomes a Lambertian transmission lobe of its own
// colour, weighted by the Fresnel the diffuse reflection would have at the
// mirror of wi. With HAS_IRIDESCENCE (KHR_materials_iridescence, which also
// implies HAS_TRANSMISSION) every Fresnel of the dielectric layer and of the
// metal is mixed towards a thin film's (thin_film_fresnel). With
// HAS_ANISOTROPY (KHR_materials_anisotropy, which implies HAS_TRANSMISSION)
// the base's GGX lobes (reflection, metal, transmission) have alpha_t along
// the local frame's x axis, which pathtrace.cl turns to the anisotropy
// direction, and alpha along y (Heitz 2014's anisotropic GGX and Smith
// masking, the visible-normal sampling stretched by both alphas); equal
// alphas take the isotropic formulas (spec_*).
//
// With GGX_ENERGY_COMPENSATION (`--energy-compensation`), the GGX
// reflection lobes are scaled by 1 + F0 (1 / E(mu_o) - 1) (Turquin 2019),
// E the white single-scattering albedo tabulated in ggx_energy.h
// (src/trace/energy.rs), so a white rough metal loses no energy.
//
// With ENERGY_LAYERING (the default `--layering energy`), the dielectric's
// base (diffuse, diffuse and thin-walled transmission) is scaled by what
// the specular layer does not reflect, and the base under the sheen by what
// the sheen does not (layering.h), instead of fresnel_mix's 1 - F(v.h).
//
// Effectively smooth lobes (alpha at or below SMOOTH_GGX_ALPHA, as pbrt-v4's
// EffectivelySmooth) are delta lobes: bsdf_eval and bsdf_pdf leave them out
// (light sampling cannot hit them; evaluated as GGX at alpha 1e-3 they gave
// rare ~1/(pi alpha^2) fireflies), and bsdf_sample picks the exact mirror,
// straight-through or refracted direction and says so (`delta`), with f =
// the lobe's reflectance over |wi.z| and pdf = the lobe's selection
// probability, so f |wi.z| / pdf is the lobe's weight over its probability.
//
// Directions are in the local shading frame (z = normal), wo pointing
// away from the surface. Every function mirrors src/trace/material.rs
// (`bsdf_eval`, `bsdf_sample`, `bsdf_pdf`); kernels/bsdf_probe.cl holds the
// two to each other.
#ifndef SOUPRAY_BSDF_H
#define SOUPRAY_BSDF_H

#pragma OPENCL FP_CONTRACT OFF

#include "pt_types.h"
#include "sampling.h"
#if (defined(HAS_DIFFUSE_TRANSMISSION) || defined(HAS_IRIDESCENCE) || defined(HAS_ANISOTROPY) || \
     defined(HAS_DISPERSION) || defined(HAS_DIFFUSE_ROUGHNESS)) &&                                \
    !defined(HAS_TRANSMISSION)
#define HAS_TRANSMISSION
#endif
#if defined(GGX_ENERGY_COMPENSATION) || defined(ENERGY_LAYERING)
#include "ggx_energy.h"
#endif
#if defined(GGX_ENERGY_COMPENSATION) && defined(HAS_ANISOTROPY)
#include "ggx_aniso_energy.h"
#endif
#ifdef HAS_SHEEN
#include "sheen_energy.h"
#endif

// The coat and sheen layers (HAS_CLEARCOAT, HAS_SHEEN) wrap the base BSDF;
// the material-extension table is bound when any extension needs it.
#if defined(HAS_CLEARCOAT) || defined(HAS_SHEEN)
#define HAS_LAYERS
#endif
#if defined(HAS_TRANSMISSION) || defined(HAS_LAYERS)
#define HAS_MATERIAL_EXT
#endif

// The material's parameters at one surface point, after textures.
typedef struct {
    float3 base;
    float metallic;
    float alpha; // GGX alpha = roughness^2, clamped away from 0 (along y)
#ifdef HAS_ANISOTROPY
    // The base's GGX alpha along the local frame's x axis (alpha: isotropic).
    float alpha_t;
    // The anisotropy direction in the mesh's tangent space, for the frame
    // pathtrace.cl builds (the BSDF does not read it).
    float2 anisotropy_dir;
#endif
    // Scales the dielectric's Fresnel reflectance: 1 for glTF materials,
    // 0 for the pure Lambertian of --clay.
    float specular;
#ifdef HAS_TRANSMISSION
    float f0;           // normal-incidence reflectance of the dielectric (from the ior)
    float3 f0_color;    // min(f0 * specularColorFactor, 1): the coloured F0
    float transmission; // share of the diffuse lobe that transmits
    float eta;          // relative index, far side over wo's side (1: thin)
    float thin;         // 1: thin-walled, transmission unbent
#ifdef HAS_DIFFUSE_TRANSMISSION
    float diffuse_transmission;       // share of the diffuse lobe transmitted diffusely
    float3 diffuse_transmission_color; // its colour
#endif
#ifdef HAS_IRIDESCENCE
    float iridescence;           // the thin film's weight (0: none)
    float iridescence_ior;       // its index
    float iridescence_thickness; // its thickness, nm
#endif
#endif
#ifdef HAS_CLEARCOAT
    float clearcoat;    // clearcoatFactor (0: no coat)
    float coat_alpha;   // the coat's GGX alpha
    // The coat's normal in the shading frame: (0, 0, 1) exactly when it is
    // the base's shading normal (trace::material::Layers::coat_normal).
    float3 coat_n;
#endif
#ifdef HAS_SHEEN
    float3 sheen_color; // sheenColorFactor (black: no sheen)
#endif
#ifdef HAS_MATERIAL_EXT
    // The extension factors at the point, textures applied, as the file
    // sets them (generated from the material tables): the lobes read a
    // parameter here unless the fields above derive it (the coat's alpha,
    // F0) or clay overrides it.
    // A pointer, so that passing BsdfParams by value does not copy them.
    PtMaterialInputs* in;
#endif
} BsdfParams;

#define MIN_GGX_ALPHA 1.0e-3f
// At or below this alpha the GGX lobes are delta lobes (see above).
#define SMOOTH_GGX_ALPHA 1.0e-3f

inline bool ggx_smooth(float a) { return a <= SMOOTH_GGX_ALPHA; }

inline float ggx_alpha(float roughness) {
    float r = clamp(roughness, 0.0f, 1.0f);
    return fmax(r * r, MIN_GGX_ALPHA);
}

inline float ggx_d(float a, float cos_h) {
    float a2 = a * a;
    float c2 = cos_h * cos_h;
    float k = c2 * (a2 - 1.0f) + 1.0f;
    return a2 / ((PT_PI * k) * k);
}

// Smith's Lambda for GGX at a direction with cosine c to the normal.
inline float ggx_lambda(float a, float c) {
    float c2 = c * c;
    float t2 = fmax(0.0f, 1.0f - c2) / c2;
    return (sqrt(1.0f + (a * a) * t2) - 1.0f) * 0.5f;
}

inline float schlick_weight(float c) {
    float m = clamp(1.0f - c, 0.0f, 1.0f);
    float m2 = m * m;
    return (m2 * m2) * m;
}

#if defined(GGX_ENERGY_COMPENSATION) || defined(HAS_SHEEN) || defined(ENERGY_LAYERING)
// Bilinear lookup in a 32 x 32 table (row x, column y, both in 0..1);
// mirrors trace::energy::lut_bilinear.
inline float lut_bilinear(__constant const float* t, float x01, float y01) {
    float last = 31.0f;
    float x = clamp(x01, 0.0f, 1.0f) * last;
    float y = clamp(y01, 0.0f, 1.0f) * last;
    uint i0 = min((uint)x, 30u);
    uint j0 = min((uint)y, 30u);
    float fx = x - (float)i0;
    float fy = y - (float)j0;
    float e00 = t[i0 * 32u + j0];
    float e10 = t[(i0 + 1u) * 32u + j0];
    float e01 = t[i0 * 32u + j0 + 1u];
    float e11 = t[(i0 + 1u) * 32u + j0 + 1u];
    return (e00 * (1.0f - fx) + e10 * fx) * (1.0f - fy) + (e01 * (1.0f - fx) + e11 * fx) * fy;
}
#endif

#if defined(GGX_ENERGY_COMPENSATION) || defined(ENERGY_LAYERING)
// The white single-scattering albedo E(alpha, mu), bilinear in (roughness,
// cosine); mirrors trace::energy::ggx_albedo.
inline float ggx_albedo(float a, float mu) { return lut_bilinear(GGX_ALBEDO, sqrt(a), mu); }
#endif

// Anisotropic GGX (Heitz 2014, eq. 85): alpha ax along x, ay along y, at
// the unit half vector h (Rust twin: ggx_d_aniso).
inline float ggx_d_aniso(float ax, float ay, float3 h) {
    float x = h.x / ax;
    float y = h.y / ay;
    float k = (x * x + y * y) + h.z * h.z;
    return 1.0f / (((PT_PI * ax) * ay) * (k * k));
}

// Smith's Lambda of anisotropic GGX at the unit direction w.
inline float ggx_lambda_aniso(float ax, float ay, float3 w) {
    float x = ax * w.x;
    float y = ay * w.y;
    float t2 = (x * x + y * y) / (w.z * w.z);
    return (sqrt(1.0f + t2) - 1.0f) * 0.5f;
}

// KHR_materials_anisotropy's alphaT, mix(alpha, 1, strength^2); strength 0
// returns alpha itself (Rust twin: anisotropic_alpha).
inline float anisotropic_alpha(float a, float strength) {
    float s = clamp(strength, 0.0f, 1.0f);
    return s > 0.0f ? a + (1.0f - a) * (s * s) : a;
}

// The base's specular microfacet lobe (Rust twins: spec_*): anisotropic
// when HAS_ANISOTROPY and alpha_t differs from alpha, else the isotropic
// formulas, bit for bit.
inline bool spec_smooth(BsdfParams p) {
#ifdef HAS_ANISOTROPY
    return ggx_smooth(fmax(p.alpha, p.alpha_t));
#else
    return ggx_smooth(p.alpha);
#endif
}

inline float spec_d(BsdfParams p, float3 h) {
#ifdef HAS_ANISOTROPY
    if (p.alpha_t != p.alpha) return ggx_d_aniso(p.alpha_t, p.alpha, h);
#endif
    return ggx_d(p.alpha, h.z);
}

inline float spec_lambda(BsdfParams p, float3 w) {
#ifdef HAS_ANISOTROPY
    if (p.alpha_t != p.alpha) return ggx_lambda_aniso(p.alpha_t, p.alpha, w);
#endif
    return ggx_lambda(p.alpha, w.z);
}

#if defined(GGX_ENERGY_COMPENSATION) && defined(HAS_ANISOTROPY)
// One axis of the anisotropic correction table: coordinate x (0 to 1)
// over n nodes -> the lower node and the fraction towards the next.
inline float aniso_axis(float x, uint n, uint* i) {
    float v = clamp(x, 0.0f, 1.0f) * (float)(n - 1u);
    *i = min((uint)v, n - 2u);
    return v - (float)(*i);
}

// Quadrilinear lookup in GGX_ANISO_ALBEDO at sqrt(alpha_t), sqrt(alpha /
// alpha_t), the cosine and the azimuth over pi/2 (Rust twin:
// trace::energy::aniso_lookup).
inline float aniso_lookup(float st, float q, float mu, float phi) {
    uint i0, i1, i2, i3;
    float f0 = aniso_axis(st, GGX_ANISO_T, &i0);
    float f1 = aniso_axis(q, GGX_ANISO_R, &i1);
    float f2 = aniso_axis(mu, GGX_ANISO_MU, &i2);
    float f3 = aniso_axis(phi, GGX_ANISO_PHI, &i3);
    float sum = 0.0f;
    for (uint c = 0u; c < 16u; ++c) {
        uint u0 = c & 1u;
        uint u1 = (c >> 1) & 1u;
        uint u2 = (c >> 2) & 1u;
        uint u3 = (c >> 3) & 1u;
        uint index = (((i0 + u0) * GGX_ANISO_R + (i1 + u1)) * GGX_ANISO_MU + (i2 + u2)) *
                         GGX_ANISO_PHI +
                     (i3 + u3);
        float w = 1.0f;
        w *= u0 != 0u ? f0 : 1.0f - f0;
        w *= u1 != 0u ? f1 : 1.0f - f1;
        w *= u2 != 0u ? f2 : 1.0f - f2;
        w *= u3 != 0u ? f3 : 1.0f - f3;
        sum += GGX_ANISO_ALBEDO[index] * w;
    }
    return sum;
}
#endif

#ifdef GGX_ENERGY_COMPENSATION
// The white single-scattering albedo of the base's specular lobe at wo;
// anisotropic: the isotropic table at the root-mean-square alpha times the
// tabulated correction (Rust twin: trace::energy::anisotropic_albedo).
inline float spec_albedo(BsdfParams p, float3 wo) {
#ifdef HAS_ANISOTROPY
    if (p.alpha_t != p.alpha) {
        float at = p.alpha_t;
        float ab = p.alpha;
        float rms = sqrt((at * at + ab * ab) * 0.5f);
        float phi = atan2(fabs(wo.y), fabs(wo.x)) * 0.63661977236758134f; // 2 / pi
        return ggx_albedo(rms, wo.z) * aniso_lookup(sqrt(at), sqrt(ab / at), wo.z, phi);
    }
#endif
    return ggx_albedo(p.alpha, wo.z);
}
#endif

// The probability of sampling the specular lobe, for outgoing cosine `cos_o`.
inline float bsdf_spec_probability(BsdfParams p, float cos_o) {
    float fd = p.specular * (0.04f + 0.96f * schlick_weight(cos_o));
    float ws = p.metallic + (1.0f - p.metallic) * fd;
    float wd = ((1.0f - p.metallic) * luminance(p.base)) * (1.0f - fd);
    float sum = ws + wd;
    return sum > 0.0f ? ws / sum : 0.0f;
}


#ifdef HAS_TRANSMISSION
inline float f0_of_ior(float ior) {
    float r = (ior - 1.0f) / (ior + 1.0f);
    return r * r;
}

// Schlick's Fresnel on the optically thinner side; 1 under total internal
// reflection.
// The cosine on the optically thinner side of an interface of relative
// index `eta` for cosine `c` on wo's side (c itself when wo's side is the
// thinner one); false under total internal reflection. Mirrors
// trace::material::thinner_side_cos.
inline bool thinner_side_cos(float eta, float c, float* ct) {
    *ct = c;
    if (eta < 1.0f) {
        float s2t = fmax(1.0f - c * c, 0.0f) / (eta * eta);
        if (s2t >= 1.0f) return false;
        *ct = sqrt(1.0f - s2t);
    }
    return true;
}

inline float fresnel_dielectric(float f0, float eta, float c) {
    float ct;
    if (!thinner_side_cos(eta, c, &ct)) return 1.0f;
    return f0 + (1.0f - f0) * schlick_weight(ct);
}

// The coloured Fresnel (KHR_materials_specular's fresnel_mix layer) with
// the cosine on the thinner side; 1 under total internal reflection.
inline float3 fresnel_dielectric3(float3 f0, float eta, float c) {
    float ct;
    if (!thinner_side_cos(eta, c, &ct)) return (float3)(1.0f);
    return f0 + ((float3)(1.0f) - f0) * schlick_weight(ct);
}

inline float max3(float3 v) { return fmax(fmax(v.x, v.y), v.z); }

#ifdef HAS_IRIDESCENCE
// The Fourier transform of the sRGB primaries' spectral sensitivities at
// optical path difference `opd` (nm) with phase shifts `shift` (Belcour and
// Barla 2017); mirrors trace::material::film_sensitivity.
inline float film_gauss(float v, float p, float s, float sh, float phase) {
    return ((v * sqrt((2.0f * PT_PI) * s)) * cos(p * phase + sh)) * exp(-(phase * phase) * s);
}

inline float3 film_sensitivity(float opd, float3 shift) {
    float phase = ((2.0f * PT_PI) * opd) * 1.0e-9f;
    float3 xyz = (float3)(film_gauss(5.4856e-13f, 1.6810e6f, 4.3278e9f, shift.x, phase),
                          film_gauss(4.4201e-13f, 1.7953e6f, 9.3046e9f, shift.y, phase),
                          film_gauss(5.2481e-13f, 2.2084e6f, 6.6121e9f, shift.z, phase));
    xyz.x += film_gauss(9.7470e-14f, 2.2399e6f, 4.5282e9f, shift.x, phase);
    xyz = xyz / 1.0685e-7f;
    return (float3)((3.2404542f * xyz.x - 1.5371385f * xyz.y) - 0.4985314f * xyz.z,
                    (-0.9692660f * xyz.x + 1.8760108f * xyz.y) + 0.0415560f * xyz.z,
                    (0.0556434f * xyz.x - 0.2040259f * xyz.y) + 1.0572252f * xyz.z);
}

// The reflectance of a thin film of index `film_ior`, `thickness` nm thick,
// in air over a base of normal reflectance `f0`, at cosine `cos1` in air;
// mirrors trace::material::thin_film_fresnel (which says where it departs
// from the extension's listing, and why).
inline float3 thin_film_fresnel(float film_ior, float cos1, float thickness, float3 f0) {
    float x = clamp(thickness / 0.03f, 0.0f, 1.0f);
    float n2 = 1.0f + (film_ior - 1.0f) * ((x * x) * (3.0f - 2.0f * x));
    float sin2_sq = (1.0f / (n2 * n2)) * (1.0f - cos1 * cos1);
    float cos2_sq = 1.0f - sin2_sq;
    if (cos2_sq < 0.0f) return (float3)(1.0f);
    float cos2 = sqrt(cos2_sq);
    float rs_12 = (cos1 - n2 * cos2) / (cos1 + n2 * cos2);
    float rp_12 = (n2 * cos1 - cos2) / (n2 * cos1 + cos2);
    float r12 = 0.5f * (rs_12 * rs_12 + rp_12 * rp_12);
    float t121 = 1.0f - r12;
    float phi12 = n2 < 1.0f ? PT_PI : 0.0f;
    float phi21 = PT_PI - phi12;
    float3 sf0 = sqrt(clamp(f0, (float3)(0.0f), (float3)(0.9999f)));
    float3 base_ior = ((float3)(1.0f) + sf0) / ((float3)(1.0f) - sf0);
    float3 q = (base_ior - (float3)(n2)) / (base_ior + (float3)(n2));
    float3 r1 = q * q;
    float3 r23 = r1 + ((float3)(1.0f) - r1) * schlick_weight(cos2);
    float3 phi23 = (float3)(base_ior.x < n2 ? PT_PI : 0.0f, base_ior.y < n2 ? PT_PI : 0.0f,
                            base_ior.z < n2 ? PT_PI : 0.0f);
    float opd = ((2.0f * n2) * thickness) * cos2;
    float3 phi = (float3)(phi21) + phi23;
    float3 r123 = clamp(r12 * r23, (float3)(0.0f), (float3)(0.9999f));
    float3 r123_sqrt = sqrt(r123);
    float3 rs = ((t121 * t121) * r23) / ((float3)(1.0f) - r123);
    float3 sum = r12 + rs;
    float3 cm = rs - (float3)(t121);
    for (int m = 1; m <= 2; ++m) {
        cm = cm * r123_sqrt;
        float3 sm = film_sensitivity((float)m * opd, phi * (float)m) * 2.0f;
        sum = sum + cm * sm;
    }
    return clamp(sum, (float3)(0.0f), (float3)(1.0f));
}
#endif

// The dielectric layer's Fresnel at cosine `c` on wo's side, mixed towards
// the thin film's with HAS_IRIDESCENCE; mirrors layer_fresnel.
inline float3 layer_fresnel(BsdfParams p, float c) {
    float ct;
    if (!thinner_side_cos(p.eta, c, &ct)) return (float3)(1.0f);
    float3 f = p.f0_color + ((float3)(1.0f) - p.f0_color) * schlick_weight(ct);
#ifdef HAS_IRIDESCENCE
    if (!(p.iridescence > 0.0f)) return f;
    float3 film = thin_film_fresnel(p.iridescence_ior, ct, p.iridescence_thickness, p.f0_color);
    return f + (film - f) * p.iridescence;
#else
    return f;
#endif
}

// The metal's Fresnel at cosine `c` (Schlick's from the base colour),
// mixed towards the thin film's with HAS_IRIDESCENCE; mirrors metal_fresnel.
inline float3 metal_fresnel(BsdfParams p, float c) {
    float3 f = p.base + ((float3)(1.0f) - p.base) * schlick_weight(c);
#ifdef HAS_IRIDESCENCE
    if (!(p.iridescence > 0.0f)) return f;
    float3 film = thin_film_fresnel(p.iridescence_ior, c, p.iridescence_thickness, p.base);
    return f + (film - f) * p.iridescence;
#else
    return f;
#endif
}

#endif

// Included here, between the dielectric's Fresnel terms and its lobes, for
// both (the sources are assembled with each header inlined once).
#include "layering.h"

// With the light-path passes, dielectric_eval_split and
// base_bsdf_eval_split leave in `diffuse_part` their value's diffuse part
// (base_bsdf_lobe_parts' `diffuse`: the same floats, without evaluating the
// diffuse lobe twice), and dielectric_eval and base_bsdf_eval wrap them.
// base_bsdf_sample_split does the same for the value it samples (0 for a
// delta lobe). Without the passes the functions below are dielectric_eval,
// base_bsdf_eval and base_bsdf_sample themselves: frames without them run
// the same code.
#ifdef FILM_LIGHT
#define EVAL_SPLIT(name) name##_split(BsdfParams p, float3 wo, float3 wi, float3* diffuse_part)
#define SAMPLE_SPLIT(name)                                                              \
    name##_split(BsdfParams p, float3 wo, float lobe_u, float u1, float u2, float3* wi_out, \
                 float3* f_out, float* pdf_out, bool* delta_out, float3* diffuse_part)
#define DIFFUSE_PART(v) (*diffuse_part = (v))
#define EVAL_WITH_PART(name, p, wo, wi) name##_split(p, wo, wi, diffuse_part)
#else
#define EVAL_SPLIT(name) name(BsdfParams p, float3 wo, float3 wi)
#define SAMPLE_SPLIT(name)                                                       \
    name(BsdfParams p, float3 wo, float lobe_u, float u1, float u2, float3* wi_out, \
         float3* f_out, float* pdf_out, bool* delta_out)
#define DIFFUSE_PART(v) ((void)0)
#define EVAL_WITH_PART(name, p, wo, wi) name(p, wo, wi)
#endif

#ifdef HAS_TRANSMISSION
// The probabilities of the specular reflection (x), specular transmission
// (y) and diffuse transmission (z, 0 without HAS_DIFFUSE_TRANSMISSION)
// lobes; the diffuse reflection lobe has the rest.
inline float3 lobe_probabilities(BsdfParams p, float cos_o) {
    float fo = p.specular * max3(layer_fresnel(p, cos_o));
#ifdef ENERGY_LAYERING
    // Inside a volume: the layer's albedo (Rust twin: lobe_probabilities).
    if (p.eta < 1.0f) {
        float3 wo = (float3)(sqrt(fmax(1.0f - cos_o * cos_o, 0.0f)), 0.0f, cos_o);
        fo = fmin(max3(layer_albedo(p, wo)), 1.0f);
    }
#endif
    float ws = p.metallic + (1.0f - p.metallic) * fo;
    float wb = ((1.0f - p.metallic) * luminance(p.base)) * (1.0f - fo);
    float wt = wb * p.transmission;
#ifdef HAS_DIFFUSE_TRANSMISSION
    float wd = (wb * (1.0f - p.transmission)) * (1.0f - p.diffuse_transmission);
    float wdt = (((1.0f - p.metallic) * luminance(p.diffuse_transmission_color)) * (1.0f - fo)) *
                ((1.0f - p.transmission) * p.diffuse_transmission);
    float sum = ((ws + wt) + wd) + wdt;
    return sum > 0.0f ? (float3)(ws / sum, wt / sum, wdt / sum) : (float3)(0.0f);
#else
    float wd = wb * (1.0f - p.transmission);
    float sum = (ws + wt) + wd;
    return sum > 0.0f ? (float3)(ws / sum, wt / sum, 0.0f) : (float3)(0.0f);
#endif
}

// The diffuse reflection lobe's weight after the specular layer's Fresnel
// `fd`: what neither transmission takes.
inline float diffuse_share(BsdfParams p, float fd) {
#ifdef HAS_DIFFUSE_TRANSMISSION
    return ((1.0f - fd) * (1.0f - p.transmission)) * (1.0f - p.diffuse_transmission);
#else
    return (1.0f - fd) * (1.0f - p.transmission);
#endif
}

// The diffuse transmission lobe for wi below the surface (0 without
// HAS_DIFFUSE_TRANSMISSION); mirrors diffuse_transmission_eval.
inline float3 diffuse_transmission_eval(BsdfParams p, float3 wo, float3 wi) {
#ifdef HAS_DIFFUSE_TRANSMISSION
    float weight = ((1.0f - p.metallic) * (1.0f - p.transmission)) * p.diffuse_transmission;
    if (!(weight > 0.0f)) return (float3)(0.0f);
    float3 hv = wo + (float3)(wi.x, wi.y, -wi.z);
    float hl = length(hv);
    if (hl == 0.0f) return (float3)(0.0f);
#ifdef ENERGY_LAYERING
    if (energy_layered(p))
        return p.diffuse_transmission_color *
               lambert_scaling(p, wo, (float3)(wi.x, wi.y, -wi.z)) * (weight * PT_INV_PI);
#endif
    float voh = fmax(dot(wo, hv / hl), 0.0f);
    float fd = max3(p.specular * layer_fresnel(p, voh));
    return p.diffuse_transmission_color * ((weight * (1.0f - fd)) * PT_INV_PI);
#else
    return (float3)(0.0f);
#endif
}

// The half vector of a refraction wo -> wi; false when the pair is not a
// refraction through a front-facing microfacet.
inline bool refraction_half(float eta, float3 wo, float3 wi, float3* h_out, float* oh_out,
                            float* ih_out) {
    float3 hv = wo + wi * eta;
    float hl = length(hv);
    if (!(hl > 0.0f)) return false;
    float3 h = hv / hl;
    if (h.z < 0.0f) h = -h;
    float oh = dot(wo, h);
    float ih = dot(wi, h);
    if (!(oh > 0.0f) || !(ih < 0.0f)) return false;
    *h_out = h;
    *oh_out = oh;
    *ih_out = ih;
    return true;
}

#ifdef HAS_DIFFUSE_ROUGHNESS
#include "eon.h"
#endif

// The dielectric's diffuse reflection lobe for wi above the surface, under
// the specular layer of Fresnel `layer` at the half vector (Rust twin: the
// `diffuse` of dielectric_eval); before the (1 - metallic) mix.
inline float3 dielectric_diffuse(BsdfParams p, float3 wo, float3 wi, float3 layer) {
#ifdef HAS_DIFFUSE_ROUGHNESS
    // The rough lobe under the layer keeps what the layer leaves towards
    // wo, 1 - E_spec(wo): Lambert's reciprocal scaling assumes the base
    // spreads light as cos / pi, and under EON's back-scattering it lost 4 %
    // of a white base at grazing views.
    if (p.in->diffuse_roughness > 0.0f) {
        float3 f = eon_eval(p.base, p.in->diffuse_roughness, wo, wi);
#ifdef ENERGY_LAYERING
        if (energy_layered(p)) return f * layer_transmittance(p, wo) * diffuse_share(p, 0.0f);
#endif
        return f * diffuse_share(p, max3(layer));
    }
#endif
#ifdef ENERGY_LAYERING
    if (energy_layered(p))
        return p.base * lambert_scaling(p, wo, wi) * (diffuse_share(p, 0.0f) * PT_INV_PI);
#endif
    return p.base * (diffuse_share(p, max3(layer)) * PT_INV_PI);
}

// The dielectric base's value (and its diffuse part: EVAL_SPLIT above).
inline float3 EVAL_SPLIT(dielectric_eval) {
    DIFFUSE_PART((float3)(0.0f));
    if (wo.z <= 0.0f || wi.z == 0.0f) return (float3)(0.0f);
    if (wi.z > 0.0f) {
        float3 hv = wo + wi;
        float hl = length(hv);
        if (hl == 0.0f) return (float3)(0.0f);
        float3 h = hv / hl;
        float voh = fmax(dot(wo, h), 0.0f);
        float d = spec_d(p, h);
        float g2 = 1.0f / ((1.0f + spec_lambda(p, wo)) + spec_lambda(p, wi));
        float s = spec_smooth(p) ? 0.0f : (d * g2) / ((4.0f * wo.z) * wi.z);
        float3 layer = p.specular * layer_fresnel(p, voh);
        float3 fm = metal_fresnel(p, voh);
        float3 diffuse = dielectric_diffuse(p, wo, wi, layer);
        DIFFUSE_PART(diffuse * (1.0f - p.metallic));
#ifdef GGX_ENERGY_COMPENSATION
        float ms = 1.0f / spec_albedo(p, wo) - 1.0f;
#ifdef ENERGY_LAYERING
        float3 dielectric =
            diffuse + (layer * s) * ((float3)(1.0f) + reflection_compensation_f0(p, wo) * ms);
#else
        float3 dielectric = diffuse + (layer * s) * ((float3)(1.0f) + p.f0_color * ms);
#endif
        float3 metal = fm * s * ((float3)(1.0f) + p.base * ms);
#else
        float3 dielectric = diffuse + layer * s;
        float3 metal = fm * s;
#endif
        return dielectric * (1.0f - p.metallic) + metal * p.metallic;
    }
    float3 diffuse = diffuse_transmission_eval(p, wo, wi);
    DIFFUSE_PART(diffuse);
    float weight = (1.0f - p.metallic) * p.transmission;
    if (!(weight > 0.0f) || spec_smooth(p)) return diffuse;
    if (p.thin != 0.0f) {
        float3 r = (float3)(wi.x, wi.y, -wi.z);
        float3 hv = wo + r;
        float hl = length(hv);
        if (hl == 0.0f) return (float3)(0.0f);
        float3 h = hv / hl;
        float voh = fmax(dot(wo, h), 0.0f);
        float d = spec_d(p, h);
        float g2 = 1.0f / ((1.0f + spec_lambda(p, wo)) + spec_lambda(p, r));
        float s = (d * g2) / ((4.0f * wo.z) * r.z);
#ifdef ENERGY_LAYERING
        // The white lobe, compensated to albedo 1, under the layer.
        if (energy_layered(p)) {
#ifdef GGX_ENERGY_COMPENSATION
            s = s / spec_albedo(p, wo);
#endif
            return p.base * layer_transmittance(p, wo) * (weight * s) + diffuse;
        }
#endif
        // Thin-walled: eta is 1.
        float fd = p.specular * max3(layer_fresnel(p, voh));
        return p.base * ((weight * (1.0f - fd)) * s) + diffuse;
    }
    float3 h;
    float oh, ih;
    if (!refraction_half(p.eta, wo, wi, &h, &oh, &ih)) return diffuse;
    float denom = ih + oh / p.eta;
    float g2 = 1.0f / ((1.0f + spec_lambda(p, wo)) + spec_lambda(p, wi));
#ifdef ENERGY_LAYERING
    // The Fresnel-less lobe under the layer.
    {
        float ft = fabs((spec_d(p, h) * g2) * ((ih * oh) / (((denom * denom) * wi.z) * wo.z))) /
                   (p.eta * p.eta);
        return p.base * refraction_scaling(p, wo) * (weight * ft) + diffuse;
    }
#endif
    float fd = p.specular * max3(layer_fresnel(p, oh));
    float ft = fabs(((spec_d(p, h) * (1.0f - fd)) * g2) *
                    ((ih * oh) / (((denom * denom) * wi.z) * wo.z))) /
               (p.eta * p.eta);
    return p.base * (weight * ft) + diffuse;
}

#ifdef FILM_LIGHT
inline float3 dielectric_eval(BsdfParams p, float3 wo, float3 wi) {
    float3 unused;
    return dielectric_eval_split(p, wo, wi, &unused);
}
#endif
#endif

// The base's diffuse reflection lobe under a specular layer of Fresnel
// `fd` at the half vector (Rust twin: the `diffuse` of base_eval); before
// the (1 - metallic) mix.
inline float3 base_diffuse(BsdfParams p, float3 wo, float3 wi, float fd) {
#ifdef ENERGY_LAYERING
    return p.base * PT_INV_PI * lambert_scaling(p, wo, wi);
#else
    return p.base * ((1.0f - fd) * PT_INV_PI);
#endif
}

// The base BSDF's value (without the cosine) for wo, wi in the local
// frame (and its diffuse part: EVAL_SPLIT above).
inline float3 EVAL_SPLIT(base_bsdf_eval) {
#ifdef HAS_TRANSMISSION
#ifdef FILM_LIGHT
    return dielectric_eval_split(p, wo, wi, diffuse_part);
#else
    return dielectric_eval(p, wo, wi);
#endif
#endif
    DIFFUSE_PART((float3)(0.0f));
    if (wo.z <= 0.0f || wi.z <= 0.0f) return (float3)(0.0f);
    // Pure Lambert (--clay): the same value as below, without the lobe.
    if (p.specular == 0.0f && p.metallic == 0.0f) {
        DIFFUSE_PART(p.base * PT_INV_PI);
        return p.base * PT_INV_PI;
    }
    float3 hv = wo + wi;
    float hl = length(hv);
    if (hl == 0.0f) return (float3)(0.0f);
    float3 h = hv / hl;
    float voh = fmax(dot(wo, h), 0.0f);
    float d = spec_d(p, h);
    float g2 = 1.0f / ((1.0f + spec_lambda(p, wo)) + spec_lambda(p, wi));
    float s = spec_smooth(p) ? 0.0f : (d * g2) / ((4.0f * wo.z) * wi.z);
    float w = schlick_weight(voh);
    float fd = p.specular * (0.04f + 0.96f * w);
    float3 fm = p.base + ((float3)(1.0f) - p.base) * w;
    float3 diffuse = base_diffuse(p, wo, wi, fd);
    DIFFUSE_PART(diffuse * (1.0f - p.metallic));
#ifdef GGX_ENERGY_COMPENSATION
    float3 dielectric = diffuse + (float3)(fd * s) * (1.0f + 0.04f * (1.0f / spec_albedo(p, wo) - 1.0f));
    float3 metal = fm * s * ((float3)(1.0f) + p.base * (1.0f / spec_albedo(p, wo) - 1.0f));
#else
    float3 dielectric = diffuse + (float3)(fd * s);
    float3 metal = fm * s;
#endif
    return dielectric * (1.0f - p.metallic) + metal * p.metallic;
}

#ifdef FILM_LIGHT
inline float3 base_bsdf_eval(BsdfParams p, float3 wo, float3 wi) {
    float3 unused;
    return base_bsdf_eval_split(p, wo, wi, &unused);
}
#endif

#ifdef FILM_LIGHT
// Two of the parts of base_bsdf_eval that the light-path passes name (Rust
// twin: base_eval_lobes): `diffuse`, the Lambertian reflection and diffuse
// transmission lobes, and `transmit`, the GGX transmission lobe
// (thin-walled or refracting). The glossy part is the rest (specular
// reflection, metal). Only refraction needs the whole value.
inline void base_bsdf_lobe_parts(BsdfParams p, float3 wo, float3 wi, float3* diffuse,
                                 float3* transmit) {
    *diffuse = (float3)(0.0f);
    *transmit = (float3)(0.0f);
    if (!(wo.z > 0.0f) || wi.z == 0.0f) return;
#ifdef HAS_TRANSMISSION
    if (wi.z < 0.0f) {
        float3 dt = diffuse_transmission_eval(p, wo, wi);
        *diffuse = dt;
        *transmit = fmax(base_bsdf_eval(p, wo, wi) - dt, (float3)(0.0f));
        return;
    }
#else
    if (wi.z < 0.0f) return;
    // Pure Lambert (--clay) is all diffuse.
    if (p.specular == 0.0f && p.metallic == 0.0f) {
        *diffuse = p.base * PT_INV_PI;
        return;
    }
#endif
    float3 hv = wo + wi;
    float hl = length(hv);
    if (hl == 0.0f) return;
    float voh = fmax(dot(wo, hv / hl), 0.0f);
#ifdef HAS_TRANSMISSION
    *diffuse = dielectric_diffuse(p, wo, wi, p.specular * layer_fresnel(p, voh)) * (1.0f - p.metallic);
#else
    float fd = p.specular * (0.04f + 0.96f * schlick_weight(voh));
    *diffuse = base_diffuse(p, wo, wi, fd) * (1.0f - p.metallic);
#endif
}
#endif

// The pdf of the visible-normal sampling of the specular lobe, per solid
// angle of wi: G1(wo) D(h) / (4 wo.z).
inline float ggx_vndf_pdf(float a, float3 wo, float3 wi) {
    float3 hv = wo + wi;
    float hl = length(hv);
    if (hl == 0.0f) return 0.0f;
    float3 h = hv / hl;
    float g1 = 1.0f / (1.0f + ggx_lambda(a, wo.z));
    return (g1 * ggx_d(a, h.z)) / (4.0f * wo.z);
}

inline float spec_vndf_pdf(BsdfParams p, float3 wo, float3 wi) {
#ifdef HAS_ANISOTROPY
    if (p.alpha_t != p.alpha) {
        float3 hv = wo + wi;
        float hl = length(hv);
        if (hl == 0.0f) return 0.0f;
        float3 h = hv / hl;
        return (spec_d(p, h) / (1.0f + spec_lambda(p, wo))) / (4.0f * wo.z);
    }
#endif
    return ggx_vndf_pdf(p.alpha, wo, wi);
}

#ifdef HAS_TRANSMISSION
inline float dielectric_pdf(BsdfParams p, float3 wo, float3 wi) {
    if (wo.z <= 0.0f || wi.z == 0.0f) return 0.0f;
    float3 pr = lobe_probabilities(p, wo.z);
    float ps = pr.x, pt = pr.y, pdt = pr.z;
    if (wi.z > 0.0f) {
        float spec = ps > 0.0f && !spec_smooth(p) ? spec_vndf_pdf(p, wo, wi) : 0.0f;
        return ps * spec + (((1.0f - ps) - pt) - pdt) * (wi.z * PT_INV_PI);
    }
    float diffuse = pdt * (-wi.z * PT_INV_PI);
    if (!(pt > 0.0f) || spec_smooth(p)) return diffuse;
    if (p.thin != 0.0f)
        return pt * spec_vndf_pdf(p, wo, (float3)(wi.x, wi.y, -wi.z)) + diffuse;
    float3 h;
    float oh, ih;
    if (!refraction_half(p.eta, wo, wi, &h, &oh, &ih)) return diffuse;
    float g1 = 1.0f / (1.0f + spec_lambda(p, wo));
    float pdf_h = ((g1 * spec_d(p, h)) * oh) / wo.z;
    float denom = ih + oh / p.eta;
    return pt * (pdf_h * (-ih / (denom * denom))) + diffuse;
}
#endif

inline float base_bsdf_pdf(BsdfParams p, float3 wo, float3 wi) {
#ifdef HAS_TRANSMISSION
    return dielectric_pdf(p, wo, wi);
#endif
    if (wo.z <= 0.0f || wi.z <= 0.0f) return 0.0f;
    if (p.specular == 0.0f && p.metallic == 0.0f) return wi.z * PT_INV_PI;
    float ps = bsdf_spec_probability(p, wo.z);
    float spec = ps > 0.0f && !spec_smooth(p) ? spec_vndf_pdf(p, wo, wi) : 0.0f;
    return ps * spec + (1.0f - ps) * (wi.z * PT_INV_PI);
}

// Heitz, "Sampling the GGX Distribution of Visible Normals" (JCGT 2018),
// for alpha ax along x and ay along y.
inline float3 ggx_sample_vndf(float ax, float ay, float3 wo, float u1, float u2) {
    float3 vh = normalize((float3)(ax * wo.x, ay * wo.y, wo.z));
    float lensq = vh.x * vh.x + vh.y * vh.y;
    float3 t1 = lensq > 0.0f ? (float3)(-vh.y, vh.x, 0.0f) / sqrt(lensq)
                             : (float3)(1.0f, 0.0f, 0.0f);
    float3 t2 = cross(vh, t1);
    float r = sqrt(u1);
    float2 cs = cos_sin_turns(u2);
    float p1 = r * cs.x;
    float p2 = r * cs.y;
    float s = 0.5f * (1.0f + vh.z);
    p2 = (1.0f - s) * sqrt(fmax(0.0f, 1.0f - p1 * p1)) + s * p2;
    float3 nh = (t1 * p1 + t2 * p2) + vh * sqrt(fmax(0.0f, (1.0f - p1 * p1) - p2 * p2));
    return normalize((float3)(ax * nh.x, ay * nh.y, fmax(0.0f, nh.z)));
}

inline float3 spec_sample_vndf(BsdfParams p, float3 wo, float u1, float u2) {
#ifdef HAS_ANISOTROPY
    return ggx_sample_vndf(p.alpha_t, p.alpha, wo, u1, u2);
#else
    return ggx_sample_vndf(p.alpha, p.alpha, wo, u1, u2);
#endif
}

// The reflectance of the smooth (delta) reflection lobe for outgoing
// cosine c: the GGX reflection terms of bsdf_eval with the microfacet
// lobe integrated to 1 (h = n, so v.h = c).
inline float3 smooth_reflectance(BsdfParams p, float c) {
    float w = schlick_weight(c);
    float3 fm = p.base + ((float3)(1.0f) - p.base) * w;
#ifdef HAS_TRANSMISSION
    float3 layer = p.specular * layer_fresnel(p, c);
    fm = metal_fresnel(p, c);
#ifdef GGX_ENERGY_COMPENSATION
    float ms = 1.0f / ggx_albedo(p.alpha, c) - 1.0f;
    float3 dielectric = layer * ((float3)(1.0f) + p.f0_color * ms);
    float3 metal = fm * ((float3)(1.0f) + p.base * ms);
#else
    float3 dielectric = layer;
    float3 metal = fm;
#endif
#else
    float fd = p.specular * (0.04f + 0.96f * w);
#ifdef GGX_ENERGY_COMPENSATION
    float3 dielectric = (float3)(fd) * (1.0f + 0.04f * (1.0f / ggx_albedo(p.alpha, c) - 1.0f));
    float3 metal = fm * ((float3)(1.0f) + p.base * (1.0f / ggx_albedo(p.alpha, c) - 1.0f));
#else
    float3 dielectric = (float3)(fd);
    float3 metal = fm;
#endif
#endif
    return dielectric * (1.0f - p.metallic) + metal * p.metallic;
}

// True when every lobe of the material is a delta lobe, so bsdf_eval is 0
// for every pair of directions and light sampling can be skipped.
inline bool base_only_delta(BsdfParams p) {
    if (!spec_smooth(p)) return false;
    if (p.metallic >= 1.0f) return true;
#ifdef HAS_TRANSMISSION
    if (p.transmission >= 1.0f) return true;
#ifdef HAS_DIFFUSE_TRANSMISSION
    if (p.diffuse_transmission > 0.0f && max3(p.diffuse_transmission_color) > 0.0f) return false;
#endif
#endif
    return !(p.base.x > 0.0f || p.base.y > 0.0f || p.base.z > 0.0f);
}

#ifdef HAS_TRANSMISSION
// Whether some lobe may carry light below the surface.
inline bool bsdf_transmits(BsdfParams p) {
#ifdef HAS_DIFFUSE_TRANSMISSION
    if (p.diffuse_transmission > 0.0f) return true;
#endif
    return p.transmission > 0.0f;
}

// The smooth thin-walled transmission lobe's reflectance (straight
// through, unbent) at outgoing cosine c: what bsdf_sample's delta lobe
// carries, and what a shadow ray crossing such a surface keeps.
inline float3 bsdf_thin_straight_through(BsdfParams p, float c) {
    float weight = (1.0f - p.metallic) * p.transmission;
#ifdef ENERGY_LAYERING
    if (energy_layered(p)) return p.base * layer_transmittance(p, (float3)(0.0f, 0.0f, c)) * weight;
#endif
    float fd = p.specular * max3(layer_fresnel(p, c));
    return p.base * (weight * (1.0f - fd));
}
#endif

// Samples wi for wo: returns false when no direction is produced (it
// would lie below the surface). `lobe_u` picks the lobe; `delta_out` says
// whether wi came from a delta lobe (f and pdf as described at the top).
// (And its value's diffuse part: SAMPLE_SPLIT above.)
inline bool SAMPLE_SPLIT(base_bsdf_sample) {
    *delta_out = false;
    DIFFUSE_PART((float3)(0.0f));
    if (wo.z <= 0.0f) return false;
#ifdef HAS_TRANSMISSION
    {
        float3 pr = lobe_probabilities(p, wo.z);
        float ps = pr.x, pt = pr.y, pdt = pr.z;
        float3 wi;
        if (spec_smooth(p) && lobe_u < ps + pt) {
            float3 value;
            if (lobe_u < ps) {
                wi = (float3)(-wo.x, -wo.y, wo.z);
                value = smooth_reflectance(p, wo.z);
                *pdf_out = ps;
            } else {
                float weight = (1.0f - p.metallic) * p.transmission;
                if (p.thin != 0.0f) {
                    wi = -wo;
                    value = bsdf_thin_straight_through(p, wo.z);
                } else {
                    float c = wo.z;
                    float s2t = fmax(1.0f - c * c, 0.0f) / (p.eta * p.eta);
                    if (s2t >= 1.0f) return false;
                    float ct = sqrt(1.0f - s2t);
                    wi = -wo / p.eta + (float3)(0.0f, 0.0f, 1.0f) * (c / p.eta - ct);
#ifdef ENERGY_LAYERING
                    value = p.base * layer_transmittance(p, wo) * (weight / (p.eta * p.eta));
#else
                    float fd = p.specular * max3(layer_fresnel(p, c));
                    value = p.base * (weight * ((1.0f - fd) / (p.eta * p.eta)));
#endif
                }
                if (wi.z >= 0.0f) return false;
                *pdf_out = pt;
            }
            if (!(*pdf_out > 0.0f)) return false;
            *wi_out = wi;
            *f_out = value / fabs(wi.z);
            *delta_out = true;
            return true;
        }
        if (lobe_u < ps) {
            float3 h = spec_sample_vndf(p, wo, u1, u2);
            wi = h * (2.0f * dot(wo, h)) - wo;
            if (wi.z <= 0.0f) return false;
        } else if (lobe_u < ps + pt) {
            float3 h = spec_sample_vndf(p, wo, u1, u2);
            float c = dot(wo, h);
            if (p.thin != 0.0f) {
                float3 r = h * (2.0f * c) - wo;
                wi = (float3)(r.x, r.y, -r.z);
            } else {
                if (!(c > 0.0f)) return false;
                float s2t = fmax(1.0f - c * c, 0.0f) / (p.eta * p.eta);
                if (s2t >= 1.0f) return false;
                float ct = sqrt(1.0f - s2t);
                wi = -wo / p.eta + h * (c / p.eta - ct);
            }
            if (wi.z >= 0.0f) return false;
        } else if (lobe_u < (ps + pt) + pdt) {
            // Diffuse transmission: the cosine hemisphere below.
            wi = sample_cosine_hemisphere(u1, u2);
            if (wi.z <= 0.0f) return false;
            wi.z = -wi.z;
        } else {
            wi = sample_cosine_hemisphere(u1, u2);
            if (wi.z <= 0.0f) return false;
        }
        float pdf = dielectric_pdf(p, wo, wi);
        if (!(pdf > 0.0f)) return false;
        *wi_out = wi;
        *f_out = EVAL_WITH_PART(dielectric_eval, p, wo, wi);
        *pdf_out = pdf;
        return true;
    }
#endif
    float ps = bsdf_spec_probability(p, wo.z);
    float3 wi;
    // Pure Lambert (--clay) has no specular lobe: ps is 0.
    if (lobe_u < ps && spec_smooth(p)) {
        *wi_out = (float3)(-wo.x, -wo.y, wo.z);
        *f_out = smooth_reflectance(p, wo.z) / wo.z;
        *pdf_out = ps;
        *delta_out = true;
        return true;
    }
    if (lobe_u < ps) {
        float3 h = spec_sample_vndf(p, wo, u1, u2);
        wi = h * (2.0f * dot(wo, h)) - wo;
    } else {
        wi = sample_cosine_hemisphere(u1, u2);
    }
    if (wi.z <= 0.0f) return false;
    float pdf = base_bsdf_pdf(p, wo, wi);
    if (!(pdf > 0.0f)) return false;
    *wi_out = wi;
    *f_out = EVAL_WITH_PART(base_bsdf_eval, p, wo, wi);
    *pdf_out = pdf;
    return true;
}

#ifdef FILM_LIGHT
inline bool base_bsdf_sample(BsdfParams p, float3 wo, float lobe_u, float u1, float u2,
                             float3* wi_out, float3* f_out, float* pdf_out, bool* delta_out) {
    float3 unused;
    return base_bsdf_sample_split(p, wo, lobe_u, u1, u2, wi_out, f_out, pdf_out, delta_out,
                                  &unused);
}
#endif
#undef EVAL_SPLIT
#undef SAMPLE_SPLIT
#undef DIFFUSE_PART
#undef EVAL_WITH_PART

// The coat and sheen layers over the base, and the entry points.
#include "bsdf_layers.h"

#ifdef HAS_TRANSMISSION
// What a shadow ray crossing a smooth thin-walled surface keeps: the
// straight-through lobe as bsdf_sample carries it, under the coat and
// the sheen (for that lobe wi = -wo, so both cosines are wo.z; the coat's
// is taken with its own normal). Rust twin:
// trace::material::shadow_straight_through.
inline float3 bsdf_shadow_straight_through(BsdfParams p, float3 wo) {
    float c = wo.z;
    float3 t = bsdf_thin_straight_through(p, c);
#ifdef HAS_CLEARCOAT
    t = t * (1.0f - coat_weight(p, coat_cos(p, wo)));
#endif
#ifdef HAS_SHEEN
    t = t * sheen_scaling(p, c, c);
#endif
    return t;
}
#endif

#endif
