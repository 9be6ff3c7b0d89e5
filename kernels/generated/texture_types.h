// Generated from the Rust definitions by soupray::device_struct
// (SOUPRAY_REGENERATE=1 cargo test --test device_structs). Do not edit:
// change the Rust definition named above each item.
//
// Textures and their bindings (src/trace/texture.rs).
#ifndef SOUPRAY_GENERATED_TEXTURE_TYPES_H
#define SOUPRAY_GENERATED_TEXTURE_TYPES_H

#pragma OPENCL FP_CONTRACT OFF

// [`TextureInfo::wrap_s`] / `wrap_t` values.
#define TEXTURE_WRAP_REPEAT 0u
#define TEXTURE_WRAP_CLAMP_TO_EDGE 1u
#define TEXTURE_WRAP_MIRRORED_REPEAT 2u
// [`TextureInfo::filter`] values.
#define TEXTURE_FILTER_NEAREST 0u
#define TEXTURE_FILTER_LINEAR 1u
// [`TextureBinding::texture`] of a slot without a texture: it samples
// as (1, 1, 1, 1), which leaves a glTF factor unchanged.
#define TEXTURE_NONE 4294967295u
// `texture_triangle_mean` samples a triangle at the centroids of the
// grid² congruent triangles it divides into.
#define TEXTURE_MEAN_GRID 4u

// One glTF texture (image + sampler) the scene samples. Its texels are
// texels[offset + y * width + x], rows top to bottom (uv (0, 0) is the
// image's upper left corner), each an RGBA8 texel packed as
// R | G << 8 | B << 16 | A << 24. Textures sharing an image share texels.
// Whether texels are sRGB is a property of the use, so it lives in
// TextureBinding, not here.
// `TextureInfo` in src/trace/texture.rs (24 bytes).
typedef struct {
    uint offset;
    uint width;
    uint height;
    uint wrap_s;
    uint wrap_t;
    // The sampler's magFilter ([`TEXTURE_FILTER_NEAREST`] or [`TEXTURE_FILTER_LINEAR`]).
    uint filter;
} TextureInfo;

// A material slot's use of a texture: which texture, which TEXCOORD set
// (0 or 1, after KHR_texture_transform's texCoord override), the
// KHR_texture_transform as a row-major 2x3 matrix
//   u' = transform[0] * u + transform[1] * v + transform[2]
//   v' = transform[3] * u + transform[4] * v + transform[5]
// (identity without the extension), and whether RGB is sRGB-encoded (base
// colour and emissive textures; alpha and all other textures are linear).
// `TextureBinding` in src/trace/texture.rs (32 bytes).
typedef struct {
    float transform[6];
    uint texture;
    ushort tex_coord;
    ushort srgb;
} TextureBinding;

#endif
