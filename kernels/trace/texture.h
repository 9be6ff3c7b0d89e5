// Texture sampling for the shading kernels: texture_uv picks a binding's
// TEXCOORD set and applies its KHR_texture_transform; sample_texture reads
// the texture with its sampler's wrap modes and filter and returns linear
// RGBA. Kernels that sample take TEXTURE_PARAMS and pass TEXTURE_ARGS on, and
// include this header only when the scene has textures (HAS_TEXTURES), so an
// untextured scene compiles none of it.
//
// Every function has an operation-for-operation twin in
// src/trace/texture.rs (FMA contraction off), so the device agrees with the
// CPU reference bit for bit; the tests check this on real and random input.
//
// Filtering follows GPU texture units: bilinear on the texel grid whose
// centres sit at (i + 0.5) / size, wrap modes applied to each of the four
// texel indices, and texels decoded (sRGB to linear) before they are
// filtered. Coordinates are first reduced into one period of their wrap mode,
// which is exact in float and keeps far-away uvs as precise as uvs in [0, 1];
// NaN and infinite coordinates read as 0 so a broken uv never indexes out of
// bounds.
#ifndef SOUPRAY_TEXTURE_H
#define SOUPRAY_TEXTURE_H

#pragma OPENCL FP_CONTRACT OFF

#include "texture_types.h"

#define TEXTURE_PARAMS __global const TextureInfo* tex_info, __global const uint* texels
#define TEXTURE_ARGS tex_info, texels

// Texel byte to float. Decoding by table rather than with pow() or a
// division makes the result exact and identical on every device (pow and
// division may be off by several ulp on GPUs). The values are those of
// `decode_table()` in src/trace/texture.rs, which a test compares with this
// text entry by entry.
__constant float TEXTURE_DECODE[512] = {
    // [0, 256): c / 255 (linear data, and alpha)
    0.0f, 0.00392156886f, 0.00784313772f, 0.0117647061f, 0.0156862754f, 0.0196078438f,
    0.0235294122f, 0.0274509806f, 0.0313725509f, 0.0352941193f, 0.0392156877f, 0.0431372561f,
    0.0470588244f, 0.0509803928f, 0.0549019612f, 0.0588235296f, 0.0627451017f, 0.0666666701f,
    0.0705882385f, 0.0745098069f, 0.0784313753f, 0.0823529437f, 0.0862745121f, 0.0901960805f,
    0.0941176489f, 0.0980392173f, 0.101960786f, 0.105882354f, 0.109803922f, 0.113725491f,
    0.117647059f, 0.121568628f, 0.125490203f, 0.129411772f, 0.13333334f, 0.137254909f,
    0.141176477f, 0.145098045f, 0.149019614f, 0.152941182f, 0.156862751f, 0.160784319f,
    0.164705887f, 0.168627456f, 0.172549024f, 0.176470593f, 0.180392161f, 0.184313729f,
    0.188235298f, 0.192156866f, 0.196078435f, 0.200000003f, 0.203921571f, 0.20784314f,
    0.211764708f, 0.215686277f, 0.219607845f, 0.223529413f, 0.227450982f, 0.23137255f,
    0.235294119f, 0.239215687f, 0.243137255f, 0.247058824f, 0.250980407f, 0.254901975f,
    0.258823544f, 0.262745112f, 0.266666681f, 0.270588249f, 0.274509817f, 0.278431386f,
    0.282352954f, 0.286274523f, 0.290196091f, 0.294117659f, 0.298039228f, 0.301960796f,
    0.305882365f, 0.309803933f, 0.313725501f, 0.31764707f, 0.321568638f, 0.325490206f,
    0.329411775f, 0.333333343f, 0.337254912f, 0.34117648f, 0.345098048f, 0.349019617f,
    0.352941185f, 0.356862754f, 0.360784322f, 0.36470589f, 0.368627459f, 0.372549027f,
    0.376470596f, 0.380392164f, 0.384313732f, 0.388235301f, 0.392156869f, 0.396078438f,
    0.400000006f, 0.403921574f, 0.407843143f, 0.411764711f, 0.41568628f, 0.419607848f,
    0.423529416f, 0.427450985f, 0.431372553f, 0.435294122f, 0.43921569f, 0.443137258f,
    0.447058827f, 0.450980395f, 0.454901963f, 0.458823532f, 0.4627451f, 0.466666669f,
    0.470588237f, 0.474509805f, 0.478431374f, 0.482352942f, 0.486274511f, 0.490196079f,
    0.494117647f, 0.498039216f, 0.501960814f, 0.505882382f, 0.509803951f, 0.513725519f,
    0.517647088f, 0.521568656f, 0.525490224f, 0.529411793f, 0.533333361f, 0.53725493f,
    0.541176498f, 0.545098066f, 0.549019635f, 0.552941203f, 0.556862772f, 0.56078434f,
    0.564705908f, 0.568627477f, 0.572549045f, 0.576470613f, 0.580392182f, 0.58431375f,
    0.588235319f, 0.592156887f, 0.596078455f, 0.600000024f, 0.603921592f, 0.607843161f,
    0.611764729f, 0.615686297f, 0.619607866f, 0.623529434f, 0.627451003f, 0.631372571f,
    0.635294139f, 0.639215708f, 0.643137276f, 0.647058845f, 0.650980413f, 0.654901981f,
    0.65882355f, 0.662745118f, 0.666666687f, 0.670588255f, 0.674509823f, 0.678431392f,
    0.68235296f, 0.686274529f, 0.690196097f, 0.694117665f, 0.698039234f, 0.701960802f,
    0.70588237f, 0.709803939f, 0.713725507f, 0.717647076f, 0.721568644f, 0.725490212f,
    0.729411781f, 0.733333349f, 0.737254918f, 0.741176486f, 0.745098054f, 0.749019623f,
    0.752941191f, 0.75686276f, 0.760784328f, 0.764705896f, 0.768627465f, 0.772549033f,
    0.776470602f, 0.78039217f, 0.784313738f, 0.788235307f, 0.792156875f, 0.796078444f,
    0.800000012f, 0.80392158f, 0.807843149f, 0.811764717f, 0.815686285f, 0.819607854f,
    0.823529422f, 0.827450991f, 0.831372559f, 0.835294127f, 0.839215696f, 0.843137264f,
    0.847058833f, 0.850980401f, 0.854901969f, 0.858823538f, 0.862745106f, 0.866666675f,
    0.870588243f, 0.874509811f, 0.87843138f, 0.882352948f, 0.886274517f, 0.890196085f,
    0.894117653f, 0.898039222f, 0.90196079f, 0.905882359f, 0.909803927f, 0.913725495f,
    0.917647064f, 0.921568632f, 0.925490201f, 0.929411769f, 0.933333337f, 0.937254906f,
    0.941176474f, 0.945098042f, 0.949019611f, 0.952941179f, 0.956862748f, 0.960784316f,
    0.964705884f, 0.968627453f, 0.972549021f, 0.97647059f, 0.980392158f, 0.984313726f,
    0.988235295f, 0.992156863f, 0.996078432f, 1.0f,
    // [256, 512): the sRGB transfer function inverted at c / 255
    0.0f, 0.000303526991f, 0.000607053982f, 0.000910580973f, 0.00121410796f, 0.00151763496f,
    0.00182116195f, 0.00212468882f, 0.00242821593f, 0.0027317428f, 0.00303526991f, 0.00334653584f,
    0.00367650739f, 0.00402471703f, 0.00439144205f, 0.00477695325f, 0.00518151652f, 0.00560539169f,
    0.00604883302f, 0.00651209056f, 0.00699541019f, 0.00749903219f, 0.00802319311f, 0.00856812578f,
    0.00913405884f, 0.00972121768f, 0.010329823f, 0.0109600937f, 0.0116122449f, 0.012286488f,
    0.0129830325f, 0.0137020834f, 0.0144438436f, 0.0152085144f, 0.0159962941f, 0.0168073755f,
    0.0176419541f, 0.01850022f, 0.0193823613f, 0.0202885624f, 0.0212190095f, 0.0221738853f,
    0.0231533665f, 0.0241576321f, 0.0251868591f, 0.0262412224f, 0.0273208916f, 0.02842604f,
    0.0295568351f, 0.0307134446f, 0.0318960324f, 0.0331047662f, 0.0343398079f, 0.0356013142f,
    0.0368894488f, 0.0382043719f, 0.0395462364f, 0.0409151986f, 0.0423114114f, 0.043735031f,
    0.045186203f, 0.0466650873f, 0.0481718257f, 0.0497065671f, 0.0512694567f, 0.0528606474f,
    0.054480277f, 0.0561284907f, 0.0578054301f, 0.0595112368f, 0.0612460524f, 0.0630100146f,
    0.064803265f, 0.0666259378f, 0.0684781671f, 0.0703600943f, 0.0722718537f, 0.0742135718f,
    0.0761853829f, 0.078187421f, 0.0802198201f, 0.0822827071f, 0.0843762085f, 0.0865004584f,
    0.0886555836f, 0.0908417106f, 0.0930589661f, 0.0953074694f, 0.097587347f, 0.0998987257f,
    0.102241732f, 0.104616486f, 0.107023105f, 0.10946171f, 0.111932427f, 0.114435375f,
    0.116970666f, 0.119538426f, 0.122138776f, 0.124771819f, 0.127437681f, 0.130136475f,
    0.13286832f, 0.135633335f, 0.138431609f, 0.141263291f, 0.144128472f, 0.147027269f,
    0.149959788f, 0.152926147f, 0.155926466f, 0.158960834f, 0.162029371f, 0.165132195f,
    0.168269396f, 0.171441108f, 0.174647406f, 0.177888423f, 0.18116425f, 0.18447499f,
    0.187820777f, 0.191201687f, 0.194617838f, 0.198069319f, 0.20155625f, 0.205078736f,
    0.208636865f, 0.212230757f, 0.215860501f, 0.219526201f, 0.223227963f, 0.226965874f,
    0.230740055f, 0.23455058f, 0.238397568f, 0.242281124f, 0.246201321f, 0.25015828f,
    0.254152089f, 0.258182853f, 0.262250662f, 0.266355604f, 0.270497799f, 0.274677306f,
    0.278894275f, 0.283148736f, 0.287440836f, 0.291770637f, 0.296138257f, 0.300543785f,
    0.304987311f, 0.309468925f, 0.313988715f, 0.318546772f, 0.323143214f, 0.327778101f,
    0.332451522f, 0.337163627f, 0.341914415f, 0.346704066f, 0.351532608f, 0.356400132f,
    0.361306787f, 0.366252601f, 0.371237695f, 0.376262128f, 0.38132602f, 0.386429429f,
    0.391572475f, 0.396755219f, 0.401977777f, 0.407240212f, 0.412542611f, 0.417885065f,
    0.423267663f, 0.428690493f, 0.434153646f, 0.439657182f, 0.445201188f, 0.450785786f,
    0.456411034f, 0.462076992f, 0.467783809f, 0.473531485f, 0.479320168f, 0.48514995f,
    0.491020858f, 0.496932983f, 0.502886474f, 0.50888133f, 0.514917672f, 0.520995557f,
    0.527115107f, 0.533276379f, 0.539479494f, 0.545724452f, 0.55201143f, 0.558340371f,
    0.564711511f, 0.571124852f, 0.577580452f, 0.584078431f, 0.590618849f, 0.597201765f,
    0.603827357f, 0.610495567f, 0.617206573f, 0.623960376f, 0.630757153f, 0.637596846f,
    0.644479692f, 0.651405632f, 0.658374846f, 0.665387273f, 0.672443151f, 0.679542482f,
    0.686685324f, 0.693871737f, 0.701101899f, 0.708375752f, 0.715693474f, 0.723055124f,
    0.730460763f, 0.73791039f, 0.745404184f, 0.752942204f, 0.760524511f, 0.768151164f,
    0.775822222f, 0.783537805f, 0.791297913f, 0.799102724f, 0.806952238f, 0.814846575f,
    0.822785735f, 0.830769897f, 0.838799f, 0.846873224f, 0.854992628f, 0.863157213f,
    0.871367097f, 0.8796224f, 0.887923121f, 0.896269381f, 0.904661179f, 0.913098633f,
    0.921581864f, 0.930110872f, 0.938685715f, 0.947306514f, 0.955973327f, 0.964686275f,
    0.973445296f, 0.982250571f, 0.991102099f, 1.0f,
};

// The binding's uv: TEXCOORD_0 or TEXCOORD_1, through its transform.
inline float2 texture_uv(TextureBinding b, float2 uv0, float2 uv1) {
    float2 uv = b.tex_coord == 1 ? uv1 : uv0;
    float u = b.transform[0] * uv.x + b.transform[1] * uv.y + b.transform[2];
    float v = b.transform[3] * uv.x + b.transform[4] * uv.y + b.transform[5];
    return (float2)(u, v);
}

// `u` reduced to one period of `wrap` (exact: a float minus its floor, or
// minus twice the floor of its half, loses no bits). Clamped coordinates only
// need to stay in a range where the texel index cannot overflow.
inline float texture_wrap_coord(float u, uint wrap) {
    if (!isfinite(u)) u = 0.0f;
    if (wrap == TEXTURE_WRAP_REPEAT) return u - floor(u);
    if (wrap == TEXTURE_WRAP_MIRRORED_REPEAT) return u - 2.0f * floor(u * 0.5f);
    return fmin(fmax(u, -1.0f), 2.0f);
}

// A texel index wrapped into [0, n): OpenGL's rules for the three modes
// (mirrored repeat reflects every other period: n, n+1, ... read n-1, n-2).
inline int texture_wrap_index(int i, int n, uint wrap) {
    if (wrap == TEXTURE_WRAP_REPEAT) {
        int m = i % n;
        return m < 0 ? m + n : m;
    }
    if (wrap == TEXTURE_WRAP_MIRRORED_REPEAT) {
        int p = 2 * n;
        int m = i % p;
        if (m < 0) m += p;
        return m >= n ? p - 1 - m : m;
    }
    return min(max(i, 0), n - 1);
}

// Texel (x, y) of `t`, decoded: RGB through the sRGB table when `srgb`.
inline float4 texture_texel(__global const uint* texels, TextureInfo t, int x, int y, uint srgb) {
    uint p = texels[t.offset + (uint)y * t.width + (uint)x];
    uint rgb_base = srgb != 0 ? 256u : 0u;
    return (float4)(TEXTURE_DECODE[rgb_base + (p & 0xFFu)],
                    TEXTURE_DECODE[rgb_base + ((p >> 8) & 0xFFu)],
                    TEXTURE_DECODE[rgb_base + ((p >> 16) & 0xFFu)],
                    TEXTURE_DECODE[p >> 24]);
}

// Linear RGBA of the binding's texture at `uv` (already through texture_uv);
// (1, 1, 1, 1) for TEXTURE_NONE.
inline float4 sample_texture(TEXTURE_PARAMS, TextureBinding b, float2 uv) {
    if (b.texture == TEXTURE_NONE) return (float4)(1.0f);
    TextureInfo t = tex_info[b.texture];
    float su = texture_wrap_coord(uv.x, t.wrap_s);
    float sv = texture_wrap_coord(uv.y, t.wrap_t);
    float w = (float)t.width;
    float h = (float)t.height;
    int nw = (int)t.width;
    int nh = (int)t.height;
    if (t.filter == TEXTURE_FILTER_NEAREST) {
        int x = texture_wrap_index((int)floor(su * w), nw, t.wrap_s);
        int y = texture_wrap_index((int)floor(sv * h), nh, t.wrap_t);
        return texture_texel(texels, t, x, y, b.srgb);
    }
    float x = su * w - 0.5f;
    float y = sv * h - 0.5f;
    float x0 = floor(x);
    float y0 = floor(y);
    float fx = x - x0;
    float fy = y - y0;
    int ix = (int)x0;
    int iy = (int)y0;
    int xa = texture_wrap_index(ix, nw, t.wrap_s);
    int xb = texture_wrap_index(ix + 1, nw, t.wrap_s);
    int ya = texture_wrap_index(iy, nh, t.wrap_t);
    int yb = texture_wrap_index(iy + 1, nh, t.wrap_t);
    float4 c00 = texture_texel(texels, t, xa, ya, b.srgb);
    float4 c10 = texture_texel(texels, t, xb, ya, b.srgb);
    float4 c01 = texture_texel(texels, t, xa, yb, b.srgb);
    float4 c11 = texture_texel(texels, t, xb, yb, b.srgb);
    float4 top = c00 + (c10 - c00) * fx;
    float4 bottom = c01 + (c11 - c01) * fx;
    return top + (bottom - top) * fy;
}

// A uv set at barycentrics (u, v) of a triangle whose corners have the
// uvs t0, t1, t2 (w = 1 - u - v), as the path tracer interpolates them.
inline float2 texture_interpolate_uv(float2 t0, float2 t1, float2 t2, float u, float v) {
    float w = 1.0f - u - v;
    return (float2)((w * t0.x + u * t1.x) + v * t2.x, (w * t0.y + u * t1.y) + v * t2.y);
}

// The mean of the binding's texture over a triangle, whose corners have
// the uvs a0, b0, c0 (TEXCOORD_0) and a1, b1, c1 (the second set): the
// average of its samples at the centroids of the TEXTURE_MEAN_GRID²
// congruent triangles the triangle divides into, so stratified over its
// area and its uv footprint.
inline float4 texture_triangle_mean(TEXTURE_PARAMS, TextureBinding b, float2 a0, float2 b0,
                                    float2 c0, float2 a1, float2 b1, float2 c1) {
    const float g = (float)TEXTURE_MEAN_GRID;
    float4 sum = (float4)(0.0f);
    for (uint i = 0u; i < TEXTURE_MEAN_GRID; ++i) {
        for (uint j = 0u; i + j < TEXTURE_MEAN_GRID; ++j) {
            // The upright cell's centroid, and the inverted one's beside it.
            for (uint k = 0u; k < (i + j + 1u < TEXTURE_MEAN_GRID ? 2u : 1u); ++k) {
                float s = k == 0u ? 1.0f / 3.0f : 2.0f / 3.0f;
                float u = ((float)i + s) / g, v = ((float)j + s) / g;
                float2 uv = texture_uv(b, texture_interpolate_uv(a0, b0, c0, u, v),
                                       texture_interpolate_uv(a1, b1, c1, u, v));
                sum += sample_texture(TEXTURE_ARGS, b, uv);
            }
        }
    }
    return sum / (g * g);
}

#endif
