// The test probes for texture.h: `texture_sample_probe` runs texture_uv and
// sample_texture over a list of (binding, uv0, uv1), and
// `texture_mean_probe` texture_triangle_mean over a list of (binding, three
// corners' uv0, three corners' uv1), so tests can compare the device with
// the Rust reference sample by sample.
#pragma OPENCL FP_CONTRACT OFF

#include "texture.h"

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

__kernel void texture_mean_probe(TEXTURE_PARAMS, __global const TextureBinding* bindings,
                                 __global const float2* corners, __global float4* out_rgba,
                                 uint n) {
    uint i = get_global_id(0);
    if (i >= n) return;
    const __global float2* c = corners + 6u * i;
    out_rgba[i] = texture_triangle_mean(TEXTURE_ARGS, bindings[i], c[0], c[1], c[2], c[3], c[4], c[5]);
}
