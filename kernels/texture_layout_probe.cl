// Test probes for texture.h. `texture_layout_probe` reports sizeof/offsetof
// of every struct in texture_types.h, so a test can hold the Rust mirrors in
// src/trace/texture.rs to the compiler's real layout. `texture_sample_probe`
// runs texture_uv and sample_texture over a list of (binding, uv0, uv1), so
// tests can compare the device with the Rust reference sample by sample.
#pragma OPENCL FP_CONTRACT OFF

#include "texture.h"

#ifndef offsetof
#define offsetof(T, field) __builtin_offsetof(T, field)
#endif
#define PUT(x) out[n++] = (uint)(x)

__kernel void texture_layout_probe(__global uint* out) {
    if (get_global_id(0) != 0) return;
    uint n = 0;
    PUT(sizeof(TextureInfo));
    PUT(offsetof(TextureInfo, offset)); PUT(offsetof(TextureInfo, width));
    PUT(offsetof(TextureInfo, height)); PUT(offsetof(TextureInfo, wrap_s));
    PUT(offsetof(TextureInfo, wrap_t)); PUT(offsetof(TextureInfo, filter));
    PUT(sizeof(TextureBinding));
    PUT(offsetof(TextureBinding, transform)); PUT(offsetof(TextureBinding, texture));
    PUT(offsetof(TextureBinding, tex_coord)); PUT(offsetof(TextureBinding, srgb));
    PUT(sizeof(float2)); PUT(sizeof(float4));
    out[n] = 0xFFFFFFFFu;
}

__kernel void texture_sample_probe(TEXTURE_PARAMS, __global const TextureBinding* bindings,
                                   __global const float2* uv0, __global const float2* uv1,
                                   __global float2* out_uv, __global float4* out_rgba, uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    TextureBinding b = bindings[i];
    float2 uv = texture_uv(b, uv0[i], uv1[i]);
    out_uv[i] = uv;
    out_rgba[i] = sample_texture(TEXTURE_ARGS, b, uv);
}
