// Random numbers and warps for the path tracer. Every random number is a
// pure function of (seed, frame, pixel, sample, dimension): a counter-based
// generator (the PCG hash of Jarzynski and Olano, "Hash Functions for GPU
// Rendering", JCGT 2020, chained over the key words), so a sample's value
// never depends on which work-item, tile or launch computed it. The warps
// mirror src/trace/sampling.rs operation for operation.
#ifndef SOUPRAY_SAMPLING_H
#define SOUPRAY_SAMPLING_H

#pragma OPENCL FP_CONTRACT OFF

#define PT_PI 3.14159265358979323846f
#define PT_INV_PI 0.31830988618379067154f
#define PT_TWO_PI 6.28318530717958647692f

inline uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// The key of one camera sample: the hash chained over every key word, so
// that neighbouring pixels, samples and frames give unrelated streams.
typedef struct {
    uint key;
} SampleRng;

inline SampleRng rng_for_sample(uint seed_lo, uint seed_hi, uint frame_lo, uint frame_hi,
                                uint pixel, uint sample) {
    uint h = pcg_hash(seed_lo);
    h = pcg_hash(h ^ seed_hi);
    h = pcg_hash(h ^ frame_lo);
    h = pcg_hash(h ^ frame_hi);
    h = pcg_hash(h ^ pixel);
    h = pcg_hash(h ^ sample);
    SampleRng r;
    r.key = h;
    return r;
}

// Uniform in [0, 1): the top 24 bits of the hash of (key, dimension).
inline float rng_1d(SampleRng r, uint dim) {
    uint h = pcg_hash(r.key ^ pcg_hash(dim + 0x9E3779B9u));
    return (float)(h >> 8) * (1.0f / 16777216.0f);
}

// Dimensions: 0..1 the pixel filter; each bounce b owns 16 from
// DIM_BOUNCE + 16 b; pass-through decisions (stochastic BLEND coverage)
// live in their own range, keyed by bounce, ray kind and crossing count.
#define DIM_FILTER_X 0u
#define DIM_FILTER_Y 1u
#define DIM_BOUNCE 16u
#define DIM_LIGHT_PICK 0u
#define DIM_LIGHT_U 1u
#define DIM_LIGHT_V 2u
#define DIM_LOBE 3u
#define DIM_BSDF_U 4u
#define DIM_BSDF_V 5u
#define DIM_RR 6u
#define DIM_PASS 0x40000000u

inline uint dim_bounce(uint bounce, uint slot) { return DIM_BOUNCE + 16u * bounce + slot; }

// kind: 0 path ray, 1 shadow ray.
inline uint dim_pass(uint bounce, uint kind, uint crossing) {
    return DIM_PASS + (bounce * 2u + kind) * 256u + min(crossing, 255u);
}

// Orthonormal basis around unit n (Duff et al., "Building an Orthonormal
// Basis, Revisited", JCGT 2017).
inline void onb(float3 n, float3* t, float3* b) {
    float sign = copysign(1.0f, n.z);
    float a = -1.0f / (sign + n.z);
    float bb = n.x * n.y * a;
    *t = (float3)(1.0f + sign * n.x * n.x * a, sign * bb, -sign * n.x);
    *b = (float3)(bb, sign + n.y * n.y * a, -n.y);
}

inline float3 to_local(float3 v, float3 t, float3 b, float3 n) {
    return (float3)(dot(v, t), dot(v, b), dot(v, n));
}

inline float3 to_world(float3 v, float3 t, float3 b, float3 n) {
    return (t * v.x + b * v.y) + n * v.z;
}

// Cosine-weighted direction around +z (Malley: concentric disk lifted).
inline float3 sample_cosine_hemisphere(float u1, float u2) {
    float ox = 2.0f * u1 - 1.0f;
    float oy = 2.0f * u2 - 1.0f;
    float r, phi;
    if (ox == 0.0f && oy == 0.0f) {
        r = 0.0f;
        phi = 0.0f;
    } else if (fabs(ox) > fabs(oy)) {
        r = ox;
        phi = (PT_PI / 4.0f) * (oy / ox);
    } else {
        r = oy;
        phi = (PT_PI / 2.0f) - (PT_PI / 4.0f) * (ox / oy);
    }
    float x = r * cos(phi);
    float y = r * sin(phi);
    float z = sqrt(fmax(0.0f, (1.0f - x * x) - y * y));
    return (float3)(x, y, z);
}

inline float3 sample_uniform_sphere(float u1, float u2) {
    float z = 1.0f - 2.0f * u1;
    float r = sqrt(fmax(0.0f, 1.0f - z * z));
    float phi = PT_TWO_PI * u2;
    return (float3)(r * cos(phi), r * sin(phi), z);
}

// Uniform barycentrics (b1, b2) on a triangle (the square-root warp).
inline float2 sample_triangle(float u1, float u2) {
    float s = sqrt(u1);
    return (float2)(1.0f - s, u2 * s);
}

// The index i with cdf[i] <= u < cdf[i + 1] over a non-decreasing table of
// n + 1 entries (cdf[0] = 0, cdf[n] = 1); entries of zero width are never
// returned.
inline uint cdf_search(const __global float* cdf, uint n, float u) {
    uint lo = 0u, hi = n;
    while (hi - lo > 1u) {
        uint mid = (lo + hi) / 2u;
        if (cdf[mid] <= u) lo = mid; else hi = mid;
    }
    return lo;
}

inline float luminance(float3 c) { return (0.2126f * c.x + 0.7152f * c.y) + 0.0722f * c.z; }

inline float power_heuristic(float a, float b) {
    float a2 = a * a;
    float b2 = b * b;
    return a2 + b2 > 0.0f ? a2 / (a2 + b2) : 0.0f;
}

#endif
