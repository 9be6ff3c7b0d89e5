// Nested dielectrics (HAS_TRANSMISSION): the refracting volumes a path is
// inside, as a short list of material indices, innermost last. Rust twin:
// src/trace/media.rs (`MediumStack`); pt_probe.cl's media_probe holds the
// two to each other.
//
// The modelling rule (Schmidt & Budge 2002 without priorities, the most
// recently entered volume winning): a path enters a volume material when it
// transmits through a front face of it, and leaves it when it transmits
// through a back face. At a front face the two sides are the innermost
// volume (air when none) and the material entered. At a back face of the
// innermost volume they are that volume and the one it was entered from. A
// back face of a volume the path is in but that is not the innermost is a
// false interface (the space beyond it is still the innermost volume): the
// path crosses it unchanged and the volume leaves the list. A back face of
// a volume not in the list (a path that started inside it, or one whose
// entry fell off a full list) is a real interface against the innermost.
//
// Liquid in a glass is modelled with the liquid's outer surface slightly
// inside the glass's wall (overlapping it), not coincident with the glass's
// inner surface: going in, the liquid's surface is then the glass-to-liquid
// interface (ior 1.33/1.5) and the glass's inner surface a false interface;
// going out, the glass's inner surface is the liquid-to-glass interface and
// the liquid's outer surface the false one. Coincident surfaces are hit in
// an arbitrary order and are not supported.
//
// When the list is full, entering drops the outermost entry.
#ifndef SOUPRAY_MEDIA_H
#define SOUPRAY_MEDIA_H

#pragma OPENCL FP_CONTRACT OFF

// Volumes a path can be inside at once.
#define MEDIUM_STACK 4u
// No volume: the space outside every volume (air, index 1).
#define NO_MEDIUM 0xFFFFFFFFu

typedef struct {
    uint id[MEDIUM_STACK];
    uint count;
} PtMedia;

inline PtMedia media_empty(void) {
    PtMedia m;
    for (uint i = 0u; i < MEDIUM_STACK; ++i) m.id[i] = NO_MEDIUM;
    m.count = 0u;
    return m;
}

inline uint media_innermost(const PtMedia* m) {
    return m->count > 0u ? m->id[m->count - 1u] : NO_MEDIUM;
}

// The position of the most recent entry of `mat`, MEDIUM_STACK if none.
inline uint media_find(const PtMedia* m, uint mat) {
    uint k = MEDIUM_STACK;
    for (uint i = 0u; i < m->count; ++i)
        if (m->id[i] == mat) k = i;
    return k;
}

// Whether a back face of `mat` is a false interface (see above).
inline bool media_false_interface(const PtMedia* m, uint mat) {
    uint k = media_find(m, mat);
    return k < MEDIUM_STACK && k + 1u < m->count;
}

// The volume on the other side of `mat`'s surface from `mat`'s own side,
// for a path at its front face (`front`) or back face.
inline uint media_other(const PtMedia* m, uint mat, bool front) {
    uint inner = media_innermost(m);
    if (front || inner != mat) return inner;
    return m->count > 1u ? m->id[m->count - 2u] : NO_MEDIUM;
}

inline void media_enter(PtMedia* m, uint mat) {
    if (m->count == MEDIUM_STACK) {
        for (uint i = 1u; i < MEDIUM_STACK; ++i) m->id[i - 1u] = m->id[i];
        m->count = MEDIUM_STACK - 1u;
    }
    m->id[m->count] = mat;
    m->count = m->count + 1u;
}

// Removes the most recent entry of `mat` (none: nothing changes).
inline void media_leave(PtMedia* m, uint mat) {
    uint k = media_find(m, mat);
    if (k >= MEDIUM_STACK) return;
    for (uint i = k + 1u; i < m->count; ++i) m->id[i - 1u] = m->id[i];
    m->count = m->count - 1u;
    m->id[m->count] = NO_MEDIUM;
}

// The relative index at a surface of a material of index `ior` with index
// `n_other` on its other side, as BsdfParams.eta (far side over wo's side):
// ior / n_other at a front face, n_other / ior at a back face. With air
// (n_other 1) these are ior and 1 / ior, as for a lone volume.
inline float media_eta(float ior, float n_other, bool front) {
    return front ? ior / n_other : n_other / ior;
}

// The interface's normal-incidence reflectance, from the ratio of the two
// indices (symmetric in them; against air, the material's own F0). Needs
// bsdf.h's f0_of_ior.
inline float media_f0(float ior, float n_other) { return f0_of_ior(ior / n_other); }

// KHR_materials_dispersion's index for colour channel `channel` (0 red, 1
// green, 2 blue; -1: a path that has not picked one) of a volume of index
// `ior` and `dispersion` (20 / Abbe number): the extension's three indices
// ior -/+ (ior - 1) 0.025 dispersion for red and blue, red at least 1.
// Without HAS_DISPERSION, or without dispersion, `ior` itself. Rust twin:
// trace::media::channel_ior.
inline float media_channel_ior(float ior, float dispersion, int channel) {
#ifdef HAS_DISPERSION
    if (channel < 0 || channel == 1 || !(dispersion > 0.0f)) return ior;
    float half_spread = ((ior - 1.0f) * 0.025f) * dispersion;
    return channel == 0 ? fmax(ior - half_spread, 1.0f) : ior + half_spread;
#else
    return ior;
#endif
}

#endif
