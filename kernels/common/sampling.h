// Random numbers and warps for the path tracer: the samplers (below) and
// the warps, mirroring src/trace/sampling.rs operation for operation.
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

// Samplers. Every random number is a pure function of (seed, frame, pixel,
// sample index, dimension), so a sample's value never depends on which
// work-item, tile or launch computed it. Two samplers, chosen when the
// program is built:
//
// * The default: Owen-scrambled, shuffled Sobol points (Burley, "Practical
//   Hash-based Owen Scrambling", JCGT 2020; Cycles' Sobol-Burley). The
//   dimensions come in sets of four; set k gives the first four Sobol
//   dimensions at a shuffled index, each Owen-scrambled. Per pixel and per
//   set, a seed hashed from (seed, frame, pixel, set) drives both the index
//   shuffle (a nested uniform scramble of the index, which keeps every
//   power-of-two prefix a (0,m,4)-net of the Sobol sequence) and the
//   scrambles. So each pixel has its own randomised Sobol sequence (pixels
//   decorrelated, as in Cycles) and the sets are independent of each other
//   (padding). Within a set the first two components are the best
//   stratified pair; the layout below gives them to what needs 2-D
//   stratification most.
// * SAMPLER_RANDOM (`--sampler random`): independent uniforms, the PCG hash
//   (Jarzynski and Olano, "Hash Functions for GPU Rendering", JCGT 2020)
//   chained over the key words and the dimension.
//
// Mirrored by src/trace/sampling.rs value for value.
//
// The layout of the sets (each `rng_4d` call is one set):
//   set 0                 camera: (filter x, filter y, shutter time, -);
//                         the time is read only with MOTION_BLUR
//   set 1 + 2 b           bounce b's light sample: (u, v, light choice, -)
//   set 2 + 2 b           bounce b's BSDF sample: (u, v, lobe, roulette)
//   SET_LENS              the lens point of depth of field: (u, v, -, -)
//   SET_CATCHER           a shadow catcher's light: (u, v, light choice, -)
//   SET_PASS + ...        pass-through decisions (stochastic BLEND coverage)
//                         keyed by bounce, ray kind and crossing count.
// The pixel filter and the first bounces' light and BSDF samples thus each
// get a set's first two (best stratified) components.
typedef struct {
    // Random: the hash of (seed, frame, pixel, sample). Sobol: the hash of
    // (seed, frame, pixel).
    uint key;
    uint sample;
} SampleRng;

inline SampleRng rng_for_sample(uint seed_lo, uint seed_hi, uint frame_lo, uint frame_hi,
                                uint pixel, uint sample) {
    uint h = pcg_hash(seed_lo);
    h = pcg_hash(h ^ seed_hi);
    h = pcg_hash(h ^ frame_lo);
    h = pcg_hash(h ^ frame_hi);
    h = pcg_hash(h ^ pixel);
#ifdef SAMPLER_RANDOM
    h = pcg_hash(h ^ sample);
#endif
    SampleRng r;
    r.key = h;
    r.sample = sample;
    return r;
}

// The top 24 bits as a uniform in [0, 1).
inline float u32_to_unit(uint x) { return (float)(x >> 8) * (1.0f / 16777216.0f); }

#ifdef SAMPLER_RANDOM
inline float4 rng_4d(SampleRng r, uint set) {
    uint d = set * 4u;
    return (float4)(u32_to_unit(pcg_hash(r.key ^ pcg_hash(d + 0x9E3779B9u))),
                    u32_to_unit(pcg_hash(r.key ^ pcg_hash(d + 1u + 0x9E3779B9u))),
                    u32_to_unit(pcg_hash(r.key ^ pcg_hash(d + 2u + 0x9E3779B9u))),
                    u32_to_unit(pcg_hash(r.key ^ pcg_hash(d + 3u + 0x9E3779B9u))));
}
#else
// Generator matrices of the first four Sobol dimensions (Joe and Kuo's
// direction numbers), bit-reversed: column j, the contribution of index
// bit j, is stored with its first binary digit in bit 0, so the points are
// built, scrambled and only then reversed once. src/trace/sampling.rs
// derives the same columns from the primitive polynomials.
__constant uint SOBOL_REVERSED[4][32] = {
    {0x00000001u, 0x00000002u, 0x00000004u, 0x00000008u, 0x00000010u, 0x00000020u, 0x00000040u,
     0x00000080u, 0x00000100u, 0x00000200u, 0x00000400u, 0x00000800u, 0x00001000u, 0x00002000u,
     0x00004000u, 0x00008000u, 0x00010000u, 0x00020000u, 0x00040000u, 0x00080000u, 0x00100000u,
     0x00200000u, 0x00400000u, 0x00800000u, 0x01000000u, 0x02000000u, 0x04000000u, 0x08000000u,
     0x10000000u, 0x20000000u, 0x40000000u, 0x80000000u},
    {0x00000001u, 0x00000003u, 0x00000005u, 0x0000000fu, 0x00000011u, 0x00000033u, 0x00000055u,
     0x000000ffu, 0x00000101u, 0x00000303u, 0x00000505u, 0x00000f0fu, 0x00001111u, 0x00003333u,
     0x00005555u, 0x0000ffffu, 0x00010001u, 0x00030003u, 0x00050005u, 0x000f000fu, 0x00110011u,
     0x00330033u, 0x00550055u, 0x00ff00ffu, 0x01010101u, 0x03030303u, 0x05050505u, 0x0f0f0f0fu,
     0x11111111u, 0x33333333u, 0x55555555u, 0xffffffffu},
    {0x00000001u, 0x00000003u, 0x00000006u, 0x00000009u, 0x00000017u, 0x0000003au, 0x00000071u,
     0x000000a3u, 0x00000116u, 0x00000339u, 0x00000677u, 0x000009aau, 0x00001601u, 0x00003903u,
     0x00007706u, 0x0000aa09u, 0x00010117u, 0x0003033au, 0x00060671u, 0x000909a3u, 0x00171616u,
     0x003a3939u, 0x00717777u, 0x00a3aaaau, 0x01170001u, 0x033a0003u, 0x06710006u, 0x09a30009u,
     0x16160017u, 0x3939003au, 0x77770071u, 0xaaaa00a3u},
    {0x00000001u, 0x00000003u, 0x00000004u, 0x0000000au, 0x0000001fu, 0x0000002eu, 0x00000045u,
     0x000000c9u, 0x0000011bu, 0x000002a4u, 0x0000079au, 0x00000b67u, 0x0000101eu, 0x0000302du,
     0x00004041u, 0x0000a0c3u, 0x0001f104u, 0x0002e28au, 0x000457dfu, 0x000c9baeu, 0x0011a105u,
     0x002a7289u, 0x0079e7dbu, 0x00b6dba4u, 0x0100011au, 0x030002a7u, 0x0400079eu, 0x0a000b6du,
     0x1f001001u, 0x2e003003u, 0x45004004u, 0xc900a00au}};

inline uint reverse_bits32(uint x) {
    x = ((x >> 1) & 0x55555555u) | ((x & 0x55555555u) << 1);
    x = ((x >> 2) & 0x33333333u) | ((x & 0x33333333u) << 2);
    x = ((x >> 4) & 0x0F0F0F0Fu) | ((x & 0x0F0F0F0Fu) << 4);
    x = ((x >> 8) & 0x00FF00FFu) | ((x & 0x00FF00FFu) << 8);
    return (x >> 16) | (x << 16);
}

// Owen (nested uniform) scrambling of a bit-reversed value: the
// Laine-Karras hash in Vegdahl's improved form flips each bit depending
// only on the bits below it, which in reversed order are the binary
// digits before it.
inline uint reversed_bit_owen(uint x, uint seed) {
    x ^= x * 0x3d20adeau;
    x += seed;
    x *= (seed >> 16) | 1u;
    x ^= x * 0x05526c56u;
    x ^= x * 0x53a22864u;
    return x;
}

// The first 16 columns of SOBOL_REVERSED, XORed together four at a time:
// entry 16 p + v is the point of the index bits 4p..4p+3 read from the
// bit-reversed index, (rev >> (28 - 4p)) & 15, whose bit b is index bit
// 4p + 3 - b. Four lookups replace sixteen conditional XORs.
__constant uint4 SOBOL_NIBBLES[64] = {
    (uint4)(0x00000000u, 0x00000000u, 0x00000000u, 0x00000000u),
    (uint4)(0x00000008u, 0x0000000fu, 0x00000009u, 0x0000000au),
    (uint4)(0x00000004u, 0x00000005u, 0x00000006u, 0x00000004u),
    (uint4)(0x0000000cu, 0x0000000au, 0x0000000fu, 0x0000000eu),
    (uint4)(0x00000002u, 0x00000003u, 0x00000003u, 0x00000003u),
    (uint4)(0x0000000au, 0x0000000cu, 0x0000000au, 0x00000009u),
    (uint4)(0x00000006u, 0x00000006u, 0x00000005u, 0x00000007u),
    (uint4)(0x0000000eu, 0x00000009u, 0x0000000cu, 0x0000000du),
    (uint4)(0x00000001u, 0x00000001u, 0x00000001u, 0x00000001u),
    (uint4)(0x00000009u, 0x0000000eu, 0x00000008u, 0x0000000bu),
    (uint4)(0x00000005u, 0x00000004u, 0x00000007u, 0x00000005u),
    (uint4)(0x0000000du, 0x0000000bu, 0x0000000eu, 0x0000000fu),
    (uint4)(0x00000003u, 0x00000002u, 0x00000002u, 0x00000002u),
    (uint4)(0x0000000bu, 0x0000000du, 0x0000000bu, 0x00000008u),
    (uint4)(0x00000007u, 0x00000007u, 0x00000004u, 0x00000006u),
    (uint4)(0x0000000fu, 0x00000008u, 0x0000000du, 0x0000000cu),
    (uint4)(0x00000000u, 0x00000000u, 0x00000000u, 0x00000000u),
    (uint4)(0x00000080u, 0x000000ffu, 0x000000a3u, 0x000000c9u),
    (uint4)(0x00000040u, 0x00000055u, 0x00000071u, 0x00000045u),
    (uint4)(0x000000c0u, 0x000000aau, 0x000000d2u, 0x0000008cu),
    (uint4)(0x00000020u, 0x00000033u, 0x0000003au, 0x0000002eu),
    (uint4)(0x000000a0u, 0x000000ccu, 0x00000099u, 0x000000e7u),
    (uint4)(0x00000060u, 0x00000066u, 0x0000004bu, 0x0000006bu),
    (uint4)(0x000000e0u, 0x00000099u, 0x000000e8u, 0x000000a2u),
    (uint4)(0x00000010u, 0x00000011u, 0x00000017u, 0x0000001fu),
    (uint4)(0x00000090u, 0x000000eeu, 0x000000b4u, 0x000000d6u),
    (uint4)(0x00000050u, 0x00000044u, 0x00000066u, 0x0000005au),
    (uint4)(0x000000d0u, 0x000000bbu, 0x000000c5u, 0x00000093u),
    (uint4)(0x00000030u, 0x00000022u, 0x0000002du, 0x00000031u),
    (uint4)(0x000000b0u, 0x000000ddu, 0x0000008eu, 0x000000f8u),
    (uint4)(0x00000070u, 0x00000077u, 0x0000005cu, 0x00000074u),
    (uint4)(0x000000f0u, 0x00000088u, 0x000000ffu, 0x000000bdu),
    (uint4)(0x00000000u, 0x00000000u, 0x00000000u, 0x00000000u),
    (uint4)(0x00000800u, 0x00000f0fu, 0x000009aau, 0x00000b67u),
    (uint4)(0x00000400u, 0x00000505u, 0x00000677u, 0x0000079au),
    (uint4)(0x00000c00u, 0x00000a0au, 0x00000fddu, 0x00000cfdu),
    (uint4)(0x00000200u, 0x00000303u, 0x00000339u, 0x000002a4u),
    (uint4)(0x00000a00u, 0x00000c0cu, 0x00000a93u, 0x000009c3u),
    (uint4)(0x00000600u, 0x00000606u, 0x0000054eu, 0x0000053eu),
    (uint4)(0x00000e00u, 0x00000909u, 0x00000ce4u, 0x00000e59u),
    (uint4)(0x00000100u, 0x00000101u, 0x00000116u, 0x0000011bu),
    (uint4)(0x00000900u, 0x00000e0eu, 0x000008bcu, 0x00000a7cu),
    (uint4)(0x00000500u, 0x00000404u, 0x00000761u, 0x00000681u),
    (uint4)(0x00000d00u, 0x00000b0bu, 0x00000ecbu, 0x00000de6u),
    (uint4)(0x00000300u, 0x00000202u, 0x0000022fu, 0x000003bfu),
    (uint4)(0x00000b00u, 0x00000d0du, 0x00000b85u, 0x000008d8u),
    (uint4)(0x00000700u, 0x00000707u, 0x00000458u, 0x00000425u),
    (uint4)(0x00000f00u, 0x00000808u, 0x00000df2u, 0x00000f42u),
    (uint4)(0x00000000u, 0x00000000u, 0x00000000u, 0x00000000u),
    (uint4)(0x00008000u, 0x0000ffffu, 0x0000aa09u, 0x0000a0c3u),
    (uint4)(0x00004000u, 0x00005555u, 0x00007706u, 0x00004041u),
    (uint4)(0x0000c000u, 0x0000aaaau, 0x0000dd0fu, 0x0000e082u),
    (uint4)(0x00002000u, 0x00003333u, 0x00003903u, 0x0000302du),
    (uint4)(0x0000a000u, 0x0000ccccu, 0x0000930au, 0x000090eeu),
    (uint4)(0x00006000u, 0x00006666u, 0x00004e05u, 0x0000706cu),
    (uint4)(0x0000e000u, 0x00009999u, 0x0000e40cu, 0x0000d0afu),
    (uint4)(0x00001000u, 0x00001111u, 0x00001601u, 0x0000101eu),
    (uint4)(0x00009000u, 0x0000eeeeu, 0x0000bc08u, 0x0000b0ddu),
    (uint4)(0x00005000u, 0x00004444u, 0x00006107u, 0x0000505fu),
    (uint4)(0x0000d000u, 0x0000bbbbu, 0x0000cb0eu, 0x0000f09cu),
    (uint4)(0x00003000u, 0x00002222u, 0x00002f02u, 0x00002033u),
    (uint4)(0x0000b000u, 0x0000ddddu, 0x0000850bu, 0x000080f0u),
    (uint4)(0x00007000u, 0x00007777u, 0x00005804u, 0x00006072u),
    (uint4)(0x0000f000u, 0x00008888u, 0x0000f20du, 0x0000c0b1u)};

// The set's four Sobol dimensions at the shuffled sample index, each
// Owen-scrambled with its own seed.
//
// The shuffle is a nested uniform scramble of the index: bit j of the
// shuffled index depends only on the sample's bits at and above j, so the
// samples [0, 2^k) map onto one aligned block of 2^k Sobol indices (a
// (0,k,2)-net in every pair of the first two dimensions). Only the low 16
// bits of the shuffle are kept, the sample's own bits above them: the
// block's high bits add a constant to every point before the scramble,
// which the scramble absorbs, and dropping them halves the work; past
// 65536 samples the sample's high bits pick the next block.
inline float4 rng_4d(SampleRng r, uint set) {
    uint seed = pcg_hash(r.key ^ pcg_hash(set + 0x9E3779B9u));
    // The shuffled index, bit-reversed: its bit 31 - j is index bit j.
    uint shuffled = reversed_bit_owen(reverse_bits32(r.sample), seed ^ 0xc2c1a055u);
    uint4 x = SOBOL_NIBBLES[shuffled >> 28] ^ SOBOL_NIBBLES[16u + ((shuffled >> 24) & 15u)] ^
              SOBOL_NIBBLES[32u + ((shuffled >> 20) & 15u)] ^
              SOBOL_NIBBLES[48u + ((shuffled >> 16) & 15u)];
    // (OpenCL takes shift counts modulo 32: the bound is explicit.)
    for (uint j = 16u; j < 32u && (r.sample >> j) != 0u; ++j) {
        uint4 column = (uint4)(SOBOL_REVERSED[0][j], SOBOL_REVERSED[1][j], SOBOL_REVERSED[2][j],
                               SOBOL_REVERSED[3][j]);
        x ^= column & (uint4)(0u - ((r.sample >> j) & 1u));
    }
    return (float4)(u32_to_unit(reverse_bits32(reversed_bit_owen(x.x, seed ^ 0x39d8a3b4u))),
                    u32_to_unit(reverse_bits32(reversed_bit_owen(x.y, seed ^ 0x8c5e8f21u))),
                    u32_to_unit(reverse_bits32(reversed_bit_owen(x.z, seed ^ 0x3c0a2e6bu))),
                    u32_to_unit(reverse_bits32(reversed_bit_owen(x.w, seed ^ 0x5b72d8f5u))));
}
#endif

// One dimension: component dim % 4 of set dim / 4.
inline float rng_1d(SampleRng r, uint dim) {
    float4 v = rng_4d(r, dim >> 2);
    uint c = dim & 3u;
    return c == 0u ? v.x : c == 1u ? v.y : c == 2u ? v.z : v.w;
}

#define SET_CAMERA 0u
#define SET_BOUNCE 1u
#define SET_LIGHT 0u
#define SET_BSDF 1u
#define SET_PASS 0x10000000u
// The lens point of depth of field (HAS_DOF): a set of its own, so its two
// dimensions are a set's best stratified pair.
#define SET_LENS 0x08000000u
// The light a shadow catcher receives (FILM_CATCHER): its own set.
#define SET_CATCHER 0x08000001u

inline uint set_bounce(uint bounce, uint slot) { return SET_BOUNCE + 2u * bounce + slot; }

// The dimension of a pass-through decision; kind: 0 path ray, 1 shadow ray.
inline uint dim_pass(uint bounce, uint kind, uint crossing) {
    return 4u * SET_PASS + (bounce * 2u + kind) * 256u + min(crossing, 255u);
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

// cos and sin of a in [-pi/4, pi/4]: their Taylor polynomials to the
// 8th and 9th power (truncation errors below 3e-8 and 2e-9 there, under
// float rounding). The warps use these instead of cos() and sin(), whose
// argument reduction PoCL runs in full for every call, and the Rust twin
// does the same float operations, so the two agree bit for bit.
inline float2 cos_sin_quarter(float a) {
    float a2 = a * a;
    float c = 1.0f + a2 * (-5.000000000e-01f +
                           a2 * (4.166666791e-02f +
                                 a2 * (-1.388888923e-03f + a2 * 2.480158764e-05f)));
    float s = a * (1.0f + a2 * (-1.666666716e-01f +
                                a2 * (8.333333768e-03f +
                                      a2 * (-1.984127011e-04f + a2 * 2.755731884e-06f))));
    return (float2)(c, s);
}

// cos and sin of 2 pi u for u in [0, 1]: the quadrant k = floor(4u), the
// angle f pi / 2 within it (f = 4u - k) taken from whichever end is within
// pi / 4, then turned by k quarter turns (exact sign swaps).
inline float2 cos_sin_turns(float u) {
    float q = u * 4.0f;
    float k = floor(q);
    float f = q - k;
    float2 cs = f < 0.5f ? cos_sin_quarter(f * 1.570796371e+00f)
                         : cos_sin_quarter((1.0f - f) * 1.570796371e+00f).yx;
    int quadrant = ((int)k) & 3;
    if (quadrant == 1) return (float2)(-cs.y, cs.x);
    if (quadrant == 2) return (float2)(-cs.x, -cs.y);
    if (quadrant == 3) return (float2)(cs.y, -cs.x);
    return cs;
}

// Cosine-weighted direction around +z (Malley: concentric disk lifted).
inline float3 sample_cosine_hemisphere(float u1, float u2) {
    float ox = 2.0f * u1 - 1.0f;
    float oy = 2.0f * u2 - 1.0f;
    // The concentric map: phi = pi/4 oy/ox, or pi/2 - pi/4 ox/oy (whose
    // cos and sin are the sin and cos of pi/4 ox/oy).
    float x, y;
    if (ox == 0.0f && oy == 0.0f) {
        x = 0.0f;
        y = 0.0f;
    } else if (fabs(ox) > fabs(oy)) {
        float2 cs = cos_sin_quarter(7.853981853e-01f * (oy / ox));
        x = ox * cs.x;
        y = ox * cs.y;
    } else {
        float2 cs = cos_sin_quarter(7.853981853e-01f * (ox / oy));
        x = oy * cs.y;
        y = oy * cs.x;
    }
    float z = sqrt(fmax(0.0f, (1.0f - x * x) - y * y));
    return (float3)(x, y, z);
}

inline float3 sample_uniform_sphere(float u1, float u2) {
    float z = 1.0f - 2.0f * u1;
    float r = sqrt(fmax(0.0f, 1.0f - z * z));
    float2 cs = cos_sin_turns(u2);
    return (float3)(r * cs.x, r * cs.y, z);
}

// A uniform direction on the upper hemisphere (pdf 1 / (2 pi));
// trace::sampling::sample_uniform_hemisphere.
inline float3 sample_uniform_hemisphere(float u1, float u2) {
    float z = 1.0f - u1;
    float r = sqrt(fmax(0.0f, 1.0f - z * z));
    float2 cs = cos_sin_turns(u2);
    return (float3)(r * cs.x, r * cs.y, z);
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
