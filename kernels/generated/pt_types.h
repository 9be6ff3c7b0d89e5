// Generated from the Rust definitions by soupray::device_struct
// (SOUPRAY_REGENERATE=1 cargo test --test device_structs). Do not edit:
// change the Rust definition named above each item.
//
// The path tracer's per-frame tables: camera, frame, materials, lights, environment (src/trace/).
#ifndef SOUPRAY_GENERATED_PT_TYPES_H
#define SOUPRAY_GENERATED_PT_TYPES_H

#pragma OPENCL FP_CONTRACT OFF

// `PtFrame.flags`: the soup carries NORMAL.
#define FRAME_NORMALS 1u
// The soup carries TEXCOORD_0.
#define FRAME_UVS 2u
// `--clay`: every surface is a Lambertian of albedo 0.8.
#define FRAME_CLAY 4u
// The soup carries a second uv set.
#define FRAME_UVS1 8u
// The soup carries COLOR_0.
#define FRAME_COLORS 16u
// Material flags (`PtMaterial.flags`): both faces are shaded.
#define MAT_DOUBLE_SIDED 1u
#define MAT_ALPHA_MASK 2u
#define MAT_ALPHA_BLEND 4u
#define MAT_EMISSIVE 8u
// KHR_materials_unlit (read only by kernels built with `HAS_UNLIT`).
#define MAT_UNLIT 16u
// `--backface-culling`: rays pass through the material's back faces, as a
// rasterizer culls them (set on single-sided materials only).
#define MAT_CULL_BACK 32u
#define F_TRANSMISSION 0u
#define F_IOR 1u
#define F_SPECULAR 2u
#define F_SPECULAR_COLOR 3u
#define F_CLEARCOAT 6u
#define F_CLEARCOAT_ROUGHNESS 7u
#define F_CLEARCOAT_NORMAL_TEXTURE_SCALE 8u
#define F_SHEEN_COLOR 9u
#define F_SHEEN_ROUGHNESS 12u
#define F_DIFFUSE_TRANSMISSION 13u
#define F_DIFFUSE_TRANSMISSION_COLOR 14u
#define F_IRIDESCENCE 17u
#define F_IRIDESCENCE_IOR 18u
#define F_IRIDESCENCE_THICKNESS_MINIMUM 19u
#define F_IRIDESCENCE_THICKNESS_MAXIMUM 20u
#define F_ANISOTROPY_STRENGTH 21u
#define F_DISPERSION 22u
#define F_DIFFUSE_ROUGHNESS 23u
#define TEX_TRANSMISSION 0u
#define TEX_SPECULAR 1u
#define TEX_SPECULAR_COLOR 2u
#define TEX_CLEARCOAT 3u
#define TEX_CLEARCOAT_ROUGHNESS 4u
#define TEX_CLEARCOAT_NORMAL 5u
#define TEX_SHEEN_COLOR 6u
#define TEX_SHEEN_ROUGHNESS 7u
#define TEX_DIFFUSE_TRANSMISSION 8u
#define TEX_DIFFUSE_TRANSMISSION_COLOR 9u
#define TEX_IRIDESCENCE 10u
#define TEX_IRIDESCENCE_THICKNESS 11u
#define TEX_ANISOTROPY 12u
#define TEX_DIFFUSE_ROUGHNESS 13u
// `PtLight.kind`: a KHR_lights_punctual point light.
#define LIGHT_POINT 0u
#define LIGHT_SPOT 1u
#define LIGHT_DIRECTIONAL 2u
// `PtEnv.kind`: no environment (black).
#define ENV_NONE 0u
// A constant radiance, `PtEnv.color`.
#define ENV_CONSTANT 1u
// An equirectangular map times `PtEnv.color`.
#define ENV_MAP 2u
// `PtLightNode.child` of a leaf: this bit, and the light's index.
#define LIGHT_NODE_LEAF 2147483648u
// A leaf of an emissive triangle: also this bit, and the triangle's
// index among the frame's emitters (`emit_prims`).
#define LIGHT_NODE_EMITTER 1073741824u
// A triangle's flags (`triangle_flags`): a shadow catcher's.
#define TRIANGLE_SHADOW_CATCHER 1u
// A holdout's.
#define TRIANGLE_HOLDOUT 2u
// The diffuse lobe's three sums in a pixel's light passes (direct,
// indirect, colour); glossy's and transmission's follow.
#define LIGHT_DIFFUSE 0u
// The glossy lobe's three sums.
#define LIGHT_GLOSSY 3u
// The transmission lobe's three sums.
#define LIGHT_TRANSMISSION 6u
// Emission the camera saw.
#define LIGHT_EMIT 9u
// Environment the camera saw.
#define LIGHT_ENV 10u
// The rgb passes per pixel.
#define LIGHT_PASSES 11u

// The camera. For a perspective camera `right` and `up` are scaled by the
// half extents of the image plane at distance 1; for an orthographic one by
// xmag and ymag.
// `DeviceCamera` in src/trace/camera.rs (96 bytes).
typedef struct {
    float origin[4];
    float right[4];
    float up[4];
    float forward[4];
    uint ortho;
    float znear;
    // Depth of field (`HAS_DOF` kernels only): the lens radius in scene
    // units (0: a pinhole), the distance to the plane in focus along
    // `forward`, and the aperture's corners (below 3: a disk) and the
    // first corner's angle (src/trace/lens.rs).
    float lens_radius;
    float focus_distance;
    uint blades;
    float blade_rotation;
    uint pad[2];
} PtCamera;

// A vector step's camera as the motion vectors project with it
// (`vector_camera`): a world point `p` lands at pixel
// `(dot(p - origin, to_x), dot(p - origin, to_y)) / w + centre`, with
// `w = dot(p - origin, to_z)` for a perspective camera and 1 for an
// orthographic one. The camera's axes come scaled by their squared lengths
// and the image's half size, so that a projection takes one division
// (three a sample for the three steps), not one per axis and the depth.
// `VectorCamera` in src/trace/vectors.rs (80 bytes).
typedef struct {
    float origin[4];
    float to_x[4];
    float to_y[4];
    float to_z[4];
    // The image's centre in pixels.
    float centre[2];
    uint ortho;
    uint pad;
} PtVectorCamera;

// Per-frame constants. Next-event estimation at a path vertex samples every
// punctual light when `light_loop` is set, then one light drawn from the
// selection distribution (`select_cdf`, `select_count` entries in this
// order: the punctual lights unless looped, the light tree as one entry
// when `light_tree` (its node count) is not 0, the emissive triangles as
// one entry when there are any, the environment when it is sampled).
// `emit_select_pmf` and `env_select_pmf` are the probabilities of choosing
// the emissive triangles (or the tree that holds them) and the environment
// (0 when not an entry), which MIS needs when a BSDF-sampled ray hits them.
// `DeviceFrame` in src/trace/render/upload.rs (80 bytes).
typedef struct {
    uint seed_lo;
    uint seed_hi;
    uint frame_lo;
    uint frame_hi;
    uint width;
    uint height;
    uint max_depth;
    uint flags;
    uint light_count;
    uint emit_count;
    uint material_count;
    uint select_count;
    // 1: every punctual light is sampled at every vertex.
    uint light_loop;
    float emit_select_pmf;
    float env_select_pmf;
    // The light tree's node count: 0 when it is not an entry.
    uint light_tree;
    // 1 when the emitters are in the light tree (not an entry of their
    // own); `emit_select_pmf` is then the tree's probability.
    uint emit_tree;
    uint pad[3];
} PtFrame;

// One material as the device shades it. Texture
// slots index the texture bindings, -1 for none.
// `DeviceMaterial` in src/trace/material/mod.rs (80 bytes).
typedef struct {
    float base_color[4];
    float emissive[4];
    float metallic;
    float roughness;
    float alpha_cutoff;
    float normal_scale;
    uint flags;
    int base_color_tex;
    int metallic_roughness_tex;
    int normal_tex;
    int emissive_tex;
    uint pad[3];
} PtMaterial;

// A material's extension factors (dielectric, coats, sheen, diffuse
// transmission, iridescence, anisotropy, dispersion), in a table beside
// the materials that only kernels built with `HAS_MATERIAL_EXT` read.
// `DeviceMaterialExt` in src/trace/material/mod.rs (180 bytes).
typedef struct {
    // The factors the kernels read as the file sets them: each row of
    // `scene::material::FACTORS` marked `on_device`, in the table's
    // order (a colour takes three floats). The kernels index it with the
    // generated `F_<KEY>` defines.
    float factor[24];
    // 1 when transmissive with a volume (refraction, attenuation), 0
    // thin-walled.
    float volume;
    // The volume's attenuation coefficient per unit length,
    // `-ln(attenuationColor) / attenuationDistance` (rgb, 0).
    float sigma[4];
    // The cosine and sine of KHR_materials_anisotropy's
    // `anisotropyRotation` (counter-clockwise from the tangent), taken
    // here once rather than at every hit.
    float anisotropy_cos;
    float anisotropy_sin;
    // Texture binding indices (-1: none) of the extensions' textures, in
    // `Slot::EXT` order. The kernels index it with the generated
    // `TEX_<SLOT>` defines.
    int tex[14];
} PtMaterialExt;

// One punctual light.
// `intensity` is color * intensity; range <= 0 means unlimited; the spot
// falloff is saturate(cos * angle_scale + angle_offset)^2, the extension's
// formula with its precomputed scale and offset.
// `DeviceLight` in src/trace/lights.rs (64 bytes).
typedef struct {
    float position[3];
    uint kind;
    float direction[3];
    // Distance where the light ends; 0 for unlimited.
    float range;
    // Colour times intensity.
    float intensity[3];
    float angle_scale;
    float angle_offset;
    float pad[3];
} PtLight;

// The environment: its kind, the constant radiance (or the map's
// multiplier), and the map's size.
// `DeviceEnv` in src/trace/lights.rs (32 bytes).
typedef struct {
    float color[4];
    uint kind;
    uint width;
    uint height;
    uint pad;
} PtEnv;

// One node of the light tree: the bounds of its lights' positions, their
// total power `phi` (the selection's units: luminance, in watts up to one
// factor), and the cone of their emission: axis `w`, `cos_theta_o` the
// cosine of its half-angle, `cos_theta_e` the cosine of the falloff angle
// past it; `two_sided`: 1 where the cone is mirrored too (double-sided
// emitters). `child`: an inner node's first child (the second follows
// it), or `LIGHT_NODE_LEAF` and a leaf's light (or `LIGHT_NODE_EMITTER`
// and emitter) index.
// `DeviceLightNode` in src/trace/light_tree/mod.rs (64 bytes).
typedef struct {
    float lo[3];
    float phi;
    float hi[3];
    float cos_theta_o;
    float w[3];
    float cos_theta_e;
    uint child;
    uint two_sided;
    uint pad[2];
} PtLightNode;

// The extension factors at one surface point (`BsdfParams.in`): each
// of `PtMaterialExt.factor`, times its texture's channel where the
// material table gives it one (src/trace/material/inputs.rs).
typedef struct {
    float transmission;
    float ior;
    float specular;
    float3 specular_color;
    float clearcoat;
    float clearcoat_roughness;
    float clearcoat_normal_texture_scale;
    float3 sheen_color;
    float sheen_roughness;
    float diffuse_transmission;
    float3 diffuse_transmission_color;
    float iridescence;
    float iridescence_ior;
    float iridescence_thickness_minimum;
    float iridescence_thickness_maximum;
    float anisotropy_strength;
    float dispersion;
    float diffuse_roughness;
} PtMaterialInputs;

// PT_MATERIAL_FACTORS(v, mx): PtMaterialInputs `v` from material `mx`'s
// factors; PT_MATERIAL_TEXTURES(v, mx, at): then each texture that
// scales a factor applied at attributes `at` (src/scene/material.rs,
// texture_slots!: the `scales` column). scene_view.h's
// pt_material_inputs expands them. A texture of a lobe not compiled
// in scales a factor no code reads, which the compiler drops.
#define PT_MATERIAL_FACTORS(v, mx) \
    (v).transmission = (mx).factor[F_TRANSMISSION]; \
    (v).ior = (mx).factor[F_IOR]; \
    (v).specular = (mx).factor[F_SPECULAR]; \
    (v).specular_color = (float3)((mx).factor[F_SPECULAR_COLOR], (mx).factor[F_SPECULAR_COLOR + 1], (mx).factor[F_SPECULAR_COLOR + 2]); \
    (v).clearcoat = (mx).factor[F_CLEARCOAT]; \
    (v).clearcoat_roughness = (mx).factor[F_CLEARCOAT_ROUGHNESS]; \
    (v).clearcoat_normal_texture_scale = (mx).factor[F_CLEARCOAT_NORMAL_TEXTURE_SCALE]; \
    (v).sheen_color = (float3)((mx).factor[F_SHEEN_COLOR], (mx).factor[F_SHEEN_COLOR + 1], (mx).factor[F_SHEEN_COLOR + 2]); \
    (v).sheen_roughness = (mx).factor[F_SHEEN_ROUGHNESS]; \
    (v).diffuse_transmission = (mx).factor[F_DIFFUSE_TRANSMISSION]; \
    (v).diffuse_transmission_color = (float3)((mx).factor[F_DIFFUSE_TRANSMISSION_COLOR], (mx).factor[F_DIFFUSE_TRANSMISSION_COLOR + 1], (mx).factor[F_DIFFUSE_TRANSMISSION_COLOR + 2]); \
    (v).iridescence = (mx).factor[F_IRIDESCENCE]; \
    (v).iridescence_ior = (mx).factor[F_IRIDESCENCE_IOR]; \
    (v).iridescence_thickness_minimum = (mx).factor[F_IRIDESCENCE_THICKNESS_MINIMUM]; \
    (v).iridescence_thickness_maximum = (mx).factor[F_IRIDESCENCE_THICKNESS_MAXIMUM]; \
    (v).anisotropy_strength = (mx).factor[F_ANISOTROPY_STRENGTH]; \
    (v).dispersion = (mx).factor[F_DISPERSION]; \
    (v).diffuse_roughness = (mx).factor[F_DIFFUSE_ROUGHNESS];
#ifdef HAS_TEXTURES
#define PT_MATERIAL_TEXTURES(v, mx, at) \
    if ((mx).tex[TEX_TRANSMISSION] >= 0) \
        (v).transmission *= pt_texture((mx).tex[TEX_TRANSMISSION], (at) TEX_PASS).x; \
    if ((mx).tex[TEX_SPECULAR] >= 0) \
        (v).specular *= pt_texture((mx).tex[TEX_SPECULAR], (at) TEX_PASS).w; \
    if ((mx).tex[TEX_SPECULAR_COLOR] >= 0) \
        (v).specular_color *= pt_texture((mx).tex[TEX_SPECULAR_COLOR], (at) TEX_PASS).xyz; \
    if ((mx).tex[TEX_CLEARCOAT] >= 0) \
        (v).clearcoat *= pt_texture((mx).tex[TEX_CLEARCOAT], (at) TEX_PASS).x; \
    if ((mx).tex[TEX_CLEARCOAT_ROUGHNESS] >= 0) \
        (v).clearcoat_roughness *= pt_texture((mx).tex[TEX_CLEARCOAT_ROUGHNESS], (at) TEX_PASS).y; \
    if ((mx).tex[TEX_SHEEN_COLOR] >= 0) \
        (v).sheen_color *= pt_texture((mx).tex[TEX_SHEEN_COLOR], (at) TEX_PASS).xyz; \
    if ((mx).tex[TEX_SHEEN_ROUGHNESS] >= 0) \
        (v).sheen_roughness *= pt_texture((mx).tex[TEX_SHEEN_ROUGHNESS], (at) TEX_PASS).w; \
    if ((mx).tex[TEX_DIFFUSE_TRANSMISSION] >= 0) \
        (v).diffuse_transmission *= pt_texture((mx).tex[TEX_DIFFUSE_TRANSMISSION], (at) TEX_PASS).w; \
    if ((mx).tex[TEX_DIFFUSE_TRANSMISSION_COLOR] >= 0) \
        (v).diffuse_transmission_color *= pt_texture((mx).tex[TEX_DIFFUSE_TRANSMISSION_COLOR], (at) TEX_PASS).xyz; \
    if ((mx).tex[TEX_IRIDESCENCE] >= 0) \
        (v).iridescence *= pt_texture((mx).tex[TEX_IRIDESCENCE], (at) TEX_PASS).x; \
    if ((mx).tex[TEX_DIFFUSE_ROUGHNESS] >= 0) \
        (v).diffuse_roughness *= pt_texture((mx).tex[TEX_DIFFUSE_ROUGHNESS], (at) TEX_PASS).x;
#else
#define PT_MATERIAL_TEXTURES(v, mx, at)
#endif

#endif
