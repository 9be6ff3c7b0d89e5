// Structs shared by the host and the texture sampling code in texture.h.
// Each one is mirrored once in src/trace/texture.rs; the test
// `texture_layout_matches_device` runs the `texture_layout_probe` kernel of
// texture_layout_probe.cl and compares every size and offset with the Rust
// side. Only 4-byte scalars (and two 2-byte ones) and scalar arrays, so no
// compiler can pad them differently.
#ifndef SOUPRAY_TEXTURE_TYPES_H
#define SOUPRAY_TEXTURE_TYPES_H

#pragma OPENCL FP_CONTRACT OFF

// TextureInfo.wrap_s / wrap_t: the glTF sampler's wrap modes.
#define TEXTURE_WRAP_REPEAT 0u
#define TEXTURE_WRAP_CLAMP_TO_EDGE 1u
#define TEXTURE_WRAP_MIRRORED_REPEAT 2u
// TextureInfo.filter: the glTF sampler's magFilter (there are no mipmaps, so
// minification uses it too; a path tracer averages many samples per pixel).
#define TEXTURE_FILTER_NEAREST 0u
#define TEXTURE_FILTER_LINEAR 1u
// TextureBinding.texture of a slot without a texture: sampling it gives
// (1, 1, 1, 1), the value that leaves a glTF factor unchanged.
#define TEXTURE_NONE 0xFFFFFFFFu

// One glTF texture (image + sampler) the scene samples. Its texels are
// texels[offset + y * width + x], rows top to bottom (uv (0, 0) is the
// image's upper left corner), each an RGBA8 texel packed as
// R | G << 8 | B << 16 | A << 24. Textures sharing an image share texels.
// Whether texels are sRGB is a property of the use, so it lives in
// TextureBinding, not here.
typedef struct {
    uint offset;
    uint width;
    uint height;
    uint wrap_s;
    uint wrap_t;
    uint filter;
} TextureInfo;

// A material slot's use of a texture: which texture, which TEXCOORD set
// (0 or 1, after KHR_texture_transform's texCoord override), the
// KHR_texture_transform as a row-major 2x3 matrix
//   u' = transform[0] * u + transform[1] * v + transform[2]
//   v' = transform[3] * u + transform[4] * v + transform[5]
// (identity without the extension), and whether RGB is sRGB-encoded (base
// colour and emissive textures; alpha and all other textures are linear).
typedef struct {
    float transform[6];
    uint texture;
    ushort tex_coord;
    ushort srgb;
} TextureBinding;

#endif
