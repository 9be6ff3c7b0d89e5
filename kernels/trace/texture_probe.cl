// The test probe for texture.h: `texture_sample_probe` runs texture_uv and sample_texture over a list of (binding, uv0, uv1), so
// tests can compare the device with the Rust reference sample by sample.
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
