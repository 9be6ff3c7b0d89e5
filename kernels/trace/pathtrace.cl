// The path tracing integrator: unidirectional path tracing with
// next-event estimation and multiple importance sampling (power heuristic)
// over punctual lights, emissive triangles and the environment, Russian
// roulette, and a per-pixel accumulator.
//
// Scheduling: one launch is one sample pass over one tile; a work-item owns
// one pixel and adds that pass's samples to the pixel's sums in sample
// order. Every random number is keyed by (seed, frame, pixel, sample,
// dimension) and nothing is shared between work-items, so the sums — and the
// image — are the same bit for bit whatever the tiling, the pass sizes and
// the work-group size. FP contraction is off and no fast-math is used.
//
// Surfaces: single-sided materials are invisible from behind (the glTF
// back-face culling), MASK materials above the cutoff are holes and BLEND
// materials are crossed with probability 1 - alpha (stochastic coverage),
// for camera, bounce and shadow rays alike. Compiled with STACK_SIZE,
// TRAVERSAL_STACKLESS for the escape-index traversal or TRAVERSAL_WIDE for
// the stack traversal of the 4-wide layout, HAS_TEXTURES when some
// material is textured, MOTION_BLUR for frames that move within the
// shutter (each camera sample's path sees the soup, camera and lights at
// its own time: trace_common.h, motion.h), HAS_TRANSMISSION when some material uses
// KHR_materials_transmission, _ior, _volume, _specular or
// _diffuse_transmission or _iridescence (the last two also
// HAS_DIFFUSE_TRANSMISSION, the Lambertian transmission lobe, and
// HAS_IRIDESCENCE, the thin film: bsdf.h), and HAS_UNLIT when some
// material is KHR_materials_unlit: such a surface returns its base colour
// (factor times texture) to any ray that reaches it, camera or bounce, and
// ends the path; light sampling does not aim at it.
// HAS_CLEARCOAT and HAS_SHEEN when some material has a clear coat or a
// sheen (the layers over the BSDF, bsdf.h); any of the three binds the
// material-extension table (MATX_DECL).
//
// Transmission (HAS_TRANSMISSION): a BSDF sample below the surface
// continues from just below it. The path keeps the list of volumes it is in
// (media.h: entered through front faces, left through back faces, the most
// recently entered innermost); the index at an interface is relative to the
// volume on its other side, each segment is attenuated by the innermost
// volume's coefficient (Beer-Lambert over its length), and a back face of
// a volume that is not the innermost is a false interface, crossed
// unchanged. Shadow rays cross smooth thin-walled transmissive surfaces with
// their straight-through transmittance (an unbent delta lobe: the shadow
// ray follows the BSDF sample's path exactly) and are blocked by every
// other surface; the matching BSDF sample is a null crossing that keeps
// the MIS state of the vertex before it, so nothing is counted twice.
// Light through refracting or rough glass arrives by the BSDF samples of
// the transmitting vertex (and its own light samples for rough
// transmission), which MIS weighs against its light sampling.
//
// Smooth lobes (alpha <= SMOOTH_GGX_ALPHA, bsdf.h) are delta lobes: light
// sampling cannot reach their direction, so an emitter or the environment
// found after a delta bounce counts with MIS weight 1, and a vertex whose
// lobes are all delta samples no light at all (its sample would be 0).
#pragma OPENCL FP_CONTRACT OFF

#include "trace_common.h"
#include "pt_types.h"
#include "sampling.h"
#ifdef HAS_DOF
#include "lens.h"
#endif
#include "bsdf.h"
#include "lights.h"
#ifdef HAS_TRANSMISSION
#include "media.h"
#endif
#ifdef HAS_TEXTURES
#include "texture.h"
#endif
#ifdef MOTION_BLUR
#include "motion.h"
#endif

// The first bounce after which Russian roulette may end a path.
#define RR_FIRST_BOUNCE 4u

// Crossings of cut-out or culled surfaces allowed per ray segment before
// the segment counts as blocked (camera rays: the path ends).
#define MAX_CROSSINGS 64u

// Everything a path needs, gathered once per work-item.
typedef struct {
    const __global BvhNode* nodes;
    const __global WideNode* wnodes;
    const __global StacklessNode* snodes;
    uint snode_count;
    const __global uint* prim_ids;
    const __global float* positions;
    const __global float* normals;
    const __global float* uvs;
    const __global float* uvs1;
    const __global float* colors;
    const __global uint* material_ids;
    const __global PtMaterial* materials;
    const __global PtLight* lights;
    const __global uint* emit_prims;
    const __global float* emit_cdf;
    const __global float* emit_pmf;
    const __global float* select_cdf;
    PtEnv env;
    const __global float4* env_texels;
    const __global float* env_marginal;
    const __global float* env_conditional;
    PtFrame frame;
    uint rays;
#ifdef MOTION_BLUR
    uint motion_steps;
    uint motion_triangles;
    // The path's time: every triangle, normal and camera is read at it.
    MotionTime mt;
#endif
#ifdef HAS_MATERIAL_EXT
    const __global PtMaterialExt* material_exts;
#endif
#ifdef FILM_MATTES
    // Per soup triangle, its (object, material) pair (scene::MatteTable).
    const __global uint* triangle_mattes;
#endif
#ifdef FILM_CATCHER
    // Per soup triangle, its TRIANGLE_* flags (scene::compositing).
    const __global uint* triangle_flags;
#endif
#ifdef FILM_VECTORS
    // The soup one frame before the frame's centre, at it and one frame
    // after (three steps of 3 * vector_triangles corners), and the camera
    // at each: the motion vectors' ends (trace::vectors).
    const __global float4* vector_positions;
    const __global PtCamera* vector_cameras;
    uint vector_triangles;
#endif
#ifdef FILM_LIGHT
    // Light-path passes: when `split_lobes` (at a path's first scattering
    // vertex), pt_shade_light leaves here the direction of its last light
    // sample and the BSDF's value there, for light_pass_direct to split.
    bool split_lobes;
    float3 shade_wi;
    float3 shade_f;
#endif
} PtScene;

// The scene's geometry at the path's time (the soup itself without
// MOTION_BLUR), as trace_common.h's functions take it.
#define SGEOM(s) GEOM_ARGS((s)->positions, (s)->mt)

#ifdef HAS_TEXTURES
// The texture set's buffers plus the bindings: four per material (base
// colour, metallic-roughness, normal, emissive) at 4 * material + slot.
#define TEX_DECL , TEXTURE_PARAMS, __global const TextureBinding* tex_bindings
#define TEX_PASS , TEXTURE_ARGS, tex_bindings
#else
#define TEX_DECL
#define TEX_PASS
#endif

#ifdef MOTION_BLUR
// With motion blur, pt_render also takes the number of motion steps and of
// triangles per step; `positions`, `normals` and `camera` hold every step.
#define MOTION_DECL , uint motion_steps, uint motion_triangles
#else
#define MOTION_DECL
#endif
#ifdef HAS_MATERIAL_EXT
// The material extensions' table (dielectric, clear coat, sheen), beside
// the materials.
#define MATX_DECL , __global const PtMaterialExt* material_exts
#else
#define MATX_DECL
#endif
#ifdef FILM_MATTES
// Cryptomatte (film::cryptomatte): each triangle's matte pair, and per
// pixel MATTE_SLOTS slots of (pair + 1, samples whose first hit it was).
#define MATTE_DECL , __global const uint* triangle_mattes, __global uint2* matte_slots
#define MATTE_CLEAR_DECL , __global uint2* matte_slots
#else
#define MATTE_DECL
#define MATTE_CLEAR_DECL
#endif
#ifdef FILM_CATCHER
// Shadow catchers and holdouts (scene::compositing): each triangle's flags,
// and per pixel three sums over the samples whose camera ray met a
// catcher: the light it received (rgb) and their count (w), the light it
// would have received were nothing else there, and the radiance seen
// through it.
#define CATCHER_DECL , __global const uint* triangle_flags, __global float4* accum_catcher
#define CATCHER_CLEAR_DECL , __global float4* accum_catcher
#else
#define CATCHER_DECL
#define CATCHER_CLEAR_DECL
#endif
#ifdef FILM_GEOMETRY
// `--aov position` and `uv`: per pixel two sums over the samples that hit,
// the first hit's position (xyz) and TEXCOORD_0 (xy).
#define GEOMETRY_DECL , __global float4* accum_geometry
#else
#define GEOMETRY_DECL
#endif
#ifdef FILM_LIGHT
// Light-path passes (`--passes light`, film::light): per pixel the sums of
// LIGHT_PASSES rgb passes, 3 * LIGHT_PASSES floats in the order of
// film::light::LIGHT_PASS_NAMES.
#define LIGHT_DECL , __global float* accum_light

// The share `part` is of `f`, per channel, in [0, 1] (0 where f is 0).
inline float3 lobe_share(float3 part, float3 f) {
    return (float3)(f.x > 0.0f ? clamp(part.x / f.x, 0.0f, 1.0f) : 0.0f,
                    f.y > 0.0f ? clamp(part.y / f.y, 0.0f, 1.0f) : 0.0f,
                    f.z > 0.0f ? clamp(part.z / f.z, 0.0f, 1.0f) : 0.0f);
}
#else
#define LIGHT_DECL
#endif
#ifdef FILM_VECTORS
// Motion vectors (`--aov motion`): the soup and the camera a frame before,
// at and a frame after the frame's centre, and per pixel the sum of the
// first hits' vectors.
#define VECTOR_DECL , __global const float4* vector_positions, \
    __global const PtCamera* vector_cameras, uint vector_triangles, __global float4* accum_motion
#define VECTOR_CLEAR_DECL , __global float4* accum_motion

// Where world point `p` lands on camera `c`'s image, in pixels from the
// bottom-left corner (x right, y up, as Blender's and Nuke's vectors
// count); false behind a perspective camera. The inverse of pt_path's
// camera ray: a perspective ray runs along forward + right sx + up sy, an
// orthographic one starts at origin + right sx + up sy, with the image
// spanning sx, sy in [-1, 1] (Rust twin: trace::vectors::project).
inline bool pt_project(PtCamera c, float3 p, float width, float height, float2* at) {
    float3 o = (float3)(c.origin[0], c.origin[1], c.origin[2]);
    float3 r = (float3)(c.right[0], c.right[1], c.right[2]);
    float3 u = (float3)(c.up[0], c.up[1], c.up[2]);
    float3 f = (float3)(c.forward[0], c.forward[1], c.forward[2]);
    float3 d = p - o;
    float sx = dot(d, r) / dot(r, r);
    float sy = dot(d, u) / dot(u, u);
    if (c.ortho == 0u) {
        float z = dot(d, f) / dot(f, f);
        if (!(z > 0.0f)) return false;
        sx = sx / z;
        sy = sy / z;
    }
    *at = (float2)((sx + 1.0f) * 0.5f * width, (sy + 1.0f) * 0.5f * height);
    return true;
}

// The point at barycentrics (u, v) of triangle `prim` in vector step `k`.
inline float3 pt_vector_point(const PtScene* s, uint k, uint prim, float u, float v) {
    const __global float4* t = s->vector_positions + ((size_t)k * s->vector_triangles + prim) * 3u;
    float w = 1.0f - u - v;
    return ((w * t[0] + u * t[1]) + v * t[2]).xyz;
}

// The first hit's motion in pixels, as Cycles' Vector pass has it: from
// the frame before to this one in xy, from this one to the next in zw.
// The same point of the surface (triangle and barycentrics) in each step,
// seen by each step's camera; 0 where an end is behind the camera.
inline float4 pt_motion_vector(const PtScene* s, uint prim, float u, float v) {
    float w = (float)s->frame.width, h = (float)s->frame.height;
    float2 before, now, after;
    bool seen = pt_project(s->vector_cameras[0], pt_vector_point(s, 0u, prim, u, v), w, h, &before);
    seen = seen && pt_project(s->vector_cameras[1], pt_vector_point(s, 1u, prim, u, v), w, h, &now);
    seen = seen && pt_project(s->vector_cameras[2], pt_vector_point(s, 2u, prim, u, v), w, h, &after);
    return seen ? (float4)(now - before, after - now) : (float4)(0.0f);
}
#else
#define VECTOR_DECL
#define VECTOR_CLEAR_DECL
#endif

inline Hit pt_trace_closest(PtScene* s, Ray ray) {
    s->rays += 1u;
#ifdef TRAVERSAL_STACKLESS
    return trace_closest_stackless_bvh(s->snodes, s->snode_count, s->prim_ids, SGEOM(s), ray);
#elif defined(TRAVERSAL_WIDE)
    return trace_closest_wide_bvh(s->wnodes, s->prim_ids, SGEOM(s), ray);
#else
    return trace_closest_bvh(s->nodes, s->prim_ids, SGEOM(s), ray);
#endif
}

inline PtMaterial pt_material(const PtScene* s, uint prim) {
    uint id = s->material_ids[prim];
    uint last = s->frame.material_count - 1u;
    return s->materials[min(id, last)];
}

#ifdef HAS_MATERIAL_EXT
// The material table's index of `prim`'s material; it also names the
// volume inside a refracting mesh (media.h).
inline uint pt_material_index(const PtScene* s, uint prim) {
    uint id = s->material_ids[prim];
    uint last = s->frame.material_count - 1u;
    return min(id, last);
}

inline PtMaterialExt pt_material_ext(const PtScene* s, uint prim) {
    return s->material_exts[pt_material_index(s, prim)];
}
#endif

#ifdef HAS_TRANSMISSION
// A volume's refractive index (NO_MEDIUM: air, 1) for the path's colour
// channel (media_channel_ior; -1: none picked).
inline float pt_medium_ior(const PtScene* s, uint medium, int channel) {
    if (medium == NO_MEDIUM) return 1.0f;
    PtMaterialExt mx = s->material_exts[medium];
    return media_channel_ior(mx.ior, mx.dispersion, channel);
}

// A volume's attenuation coefficient (NO_MEDIUM: none).
inline float3 pt_medium_sigma(const PtScene* s, uint medium) {
    if (medium == NO_MEDIUM) return (float3)(0.0f);
    PtMaterialExt mx = s->material_exts[medium];
    return (float3)(mx.sigma[0], mx.sigma[1], mx.sigma[2]);
}
#endif

#ifdef HAS_TRANSMISSION

// Beer-Lambert transmittance over `t` for coefficients `sigma` (a zero
// coefficient transmits everything, even over an infinite segment).
inline float3 pt_attenuation(float3 sigma, float t) {
    return (float3)(sigma.x > 0.0f ? exp(-sigma.x * t) : 1.0f,
                    sigma.y > 0.0f ? exp(-sigma.y * t) : 1.0f,
                    sigma.z > 0.0f ? exp(-sigma.z * t) : 1.0f);
}
#endif

// The vertex attributes at a point of a triangle, interpolated: both uv
// sets (TEXCOORD_0 in uv.xy, the soup's second set in uv.zw, each 0 where
// the soup lacks it) and COLOR_0 (white without it).
typedef struct {
    float4 uv;
    float4 color;
} PtAttrs;

inline float2 pt_interpolate_uv(const __global float* uvs, uint prim, float u, float v) {
    const __global float* t = uvs + (size_t)prim * 6u;
    float w = 1.0f - u - v;
    return (float2)((w * t[0] + u * t[2]) + v * t[4], (w * t[1] + u * t[3]) + v * t[5]);
}

inline PtAttrs pt_attrs(const PtScene* s, uint prim, float u, float v) {
    PtAttrs a;
    float2 uv0 = (s->frame.flags & FRAME_UVS) != 0u ? pt_interpolate_uv(s->uvs, prim, u, v)
                                                    : (float2)(0.0f);
    float2 uv1 = (s->frame.flags & FRAME_UVS1) != 0u ? pt_interpolate_uv(s->uvs1, prim, u, v)
                                                     : (float2)(0.0f);
    a.uv = (float4)(uv0, uv1);
    a.color = (float4)(1.0f);
    if ((s->frame.flags & FRAME_COLORS) != 0u) {
        const __global float* c = s->colors + (size_t)prim * 12u;
        float w = 1.0f - u - v;
        a.color = (float4)((w * c[0] + u * c[4]) + v * c[8], (w * c[1] + u * c[5]) + v * c[9],
                           (w * c[2] + u * c[6]) + v * c[10], (w * c[3] + u * c[7]) + v * c[11]);
    }
    return a;
}

// The texture of `binding` at a point, through the binding's uv set. Every
// texture lookup of the integrator goes through pt_texture, which compiles
// to nothing without HAS_TEXTURES.
inline float4 pt_texture(int binding, PtAttrs at TEX_DECL) {
#ifdef HAS_TEXTURES
    if (binding >= 0) {
        TextureBinding b = tex_bindings[binding];
        return sample_texture(TEXTURE_ARGS, b, texture_uv(b, at.uv.xy, at.uv.zw));
    }
#endif
    return (float4)(1.0f);
}

// The material's base colour (linear RGBA) at a point: the factor times
// the vertex colour times the base colour texture (glTF 2.0 §3.9.2).
inline float4 pt_base_color(PtMaterial m, PtAttrs at TEX_DECL) {
    float4 f = (float4)(m.base_color[0], m.base_color[1], m.base_color[2], m.base_color[3]);
    return (f * at.color) * pt_texture(m.base_color_tex, at TEX_PASS);
}

// Whether a ray crossing `prim` from `dir` passes through it: a culled back
// face (--backface-culling only: by default a single-sided material's back
// face is shaded, as Cycles does, so flipped parts of a mesh leave no
// holes), a MASK hole, or a BLEND crossing drawn with probability 1 - alpha.
inline bool pt_passes(const PtScene* s, PtMaterial m, uint prim, float u, float v, float3 dir,
                      SampleRng rng, uint dim TEX_DECL) {
    if ((m.flags & MAT_CULL_BACK) != 0u) {
        if (dot(dir, geometric_normal(SGEOM(s), prim)) >= 0.0f) return true;
    }
    if ((m.flags & (MAT_ALPHA_MASK | MAT_ALPHA_BLEND)) == 0u) return false;
    float alpha = pt_base_color(m, pt_attrs(s, prim, u, v) TEX_PASS).w;
    if ((m.flags & MAT_ALPHA_MASK) != 0u) return alpha < m.alpha_cutoff;
    return rng_1d(rng, dim) >= alpha;
}

// The first surface along `ray` that is not crossed. `kind`: 0 path ray,
// 1 shadow ray (for the crossing decisions' dimensions). Returns false when
// the ray escapes; `blocked` is set when the crossing budget ran out.
// `crossings` counts the segment's crossings so far (in and out), so a
// shadow ray through thin glass goes on numbering its decisions.
inline bool pt_find_surface(PtScene* s, Ray ray, SampleRng rng, uint bounce, uint kind,
                            Hit* out, float* travelled, bool* blocked, uint* crossings TEX_DECL) {
    *blocked = false;
    *travelled = 0.0f;
    for (; *crossings < MAX_CROSSINGS; *crossings = *crossings + 1u) {
        uint c = *crossings;
        Hit h = pt_trace_closest(s, ray);
        if (h.prim == MISS) return false;
        float3 dir = (float3)(ray.dir[0], ray.dir[1], ray.dir[2]);
        PtMaterial m = pt_material(s, h.prim);
        if (!pt_passes(s, m, h.prim, h.u, h.v, dir, rng, dim_pass(bounce, kind, c) TEX_PASS)) {
            *travelled = *travelled + h.t;
            *out = h;
            return true;
        }
        // Continue just beyond the crossed surface.
        float3 p = hit_point(SGEOM(s), h.prim, h.u, h.v);
        float3 ng = geometric_normal(SGEOM(s), h.prim);
        float3 n = dot(dir, ng) > 0.0f ? ng : -ng;
        float3 o = offset_ray_origin_scaled(p, n, offset_scale(SGEOM(s), h.prim));
        ray.org[0] = o.x; ray.org[1] = o.y; ray.org[2] = o.z;
        *travelled = *travelled + h.t;
        ray.tmin = 0.0f;
        ray.tmax = ray.tmax - h.t;
        if (!(ray.tmax > 0.0f)) return false;
    }
    *blocked = true;
    return false;
}

#ifndef TRAVERSAL_STACKLESS
// Any surface along `r` (MISS: none), for the shadow rays' common case:
// a hit on a surface that blocks for certain (pt_blocks_for_certain)
// settles them; otherwise they take the exact answer, which agrees with
// it, so the stack and stackless traversals give the same result.
inline Hit pt_trace_any(PtScene* s, Ray r) {
    s->rays += 1u;
#ifdef TRAVERSAL_WIDE
    return trace_any_wide_bvh(s->wnodes, s->prim_ids, SGEOM(s), r);
#else
    return trace_any_bvh(s->nodes, s->prim_ids, SGEOM(s), r);
#endif
}

// Whether `prim` (material `m`) blocks a ray along `dir` whatever its
// texture: opaque, and not culled or facing the ray.
inline bool pt_blocks_for_certain(const PtScene* s, PtMaterial m, uint prim, float3 dir) {
    return (m.flags & (MAT_ALPHA_MASK | MAT_ALPHA_BLEND)) == 0u &&
           ((m.flags & MAT_CULL_BACK) == 0u || dot(dir, geometric_normal(SGEOM(s), prim)) < 0.0f);
}
#endif

// The shadow ray of the segment org + t dir, t in (0, tmax).
inline Ray pt_segment_ray(float3 org, float3 dir, float tmax) {
    Ray r;
    r.org[0] = org.x; r.org[1] = org.y; r.org[2] = org.z;
    r.dir[0] = dir.x; r.dir[1] = dir.y; r.dir[2] = dir.z;
    r.tmin = 0.0f;
    r.tmax = tmax;
    return r;
}

#ifndef HAS_TRANSMISSION
// Whether the segment org + t dir, t in (0, tmax), is blocked (with
// HAS_TRANSMISSION: pt_shadow_transmittance).
inline bool pt_occluded(PtScene* s, float3 org, float3 dir, float tmax, SampleRng rng,
                        uint bounce TEX_DECL) {
    Ray r = pt_segment_ray(org, dir, tmax);
#ifndef TRAVERSAL_STACKLESS
    Hit a = pt_trace_any(s, r);
    if (a.prim == MISS) return false;
    if (pt_blocks_for_certain(s, pt_material(s, a.prim), a.prim, dir)) return true;
#endif
    Hit h;
    float travelled;
    bool blocked;
    uint crossings = 0u;
    bool found =
        pt_find_surface(s, r, rng, bounce, 1u, &h, &travelled, &blocked, &crossings TEX_PASS);
    return found || blocked;
}
#endif

inline float3 pt_emission(PtMaterial m, PtAttrs at TEX_DECL) {
    float3 e = (float3)(m.emissive[0], m.emissive[1], m.emissive[2]);
#ifdef HAS_TEXTURES
    if (m.emissive_tex >= 0) e = e * pt_texture(m.emissive_tex, at TEX_PASS).xyz;
#endif
    return e;
}

inline float pt_triangle_area(GEOM_DECL(positions), uint prim) {
    TRI_LOAD(p, positions, mt, prim);
    float3 e1 = (float3)(p[4] - p[0], p[5] - p[1], p[6] - p[2]);
    float3 e2 = (float3)(p[8] - p[0], p[9] - p[1], p[10] - p[2]);
    return 0.5f * length(cross(e1, e2));
}

// The light-sampling pdf (solid angle, selection included) of reaching
// emissive triangle `prim` at distance `dist` with cosine `cos_l` there.
inline float pt_emissive_pdf(const PtScene* s, uint prim, float dist, float cos_l) {
    float pmf = s->emit_pmf[prim];
    if (!(pmf > 0.0f) || !(cos_l > 0.0f)) return 0.0f;
    float area = pt_triangle_area(SGEOM(s), prim);
    return ((pmf * s->frame.emit_select_pmf) * (dist * dist)) / (area * cos_l);
}

#if defined(HAS_TEXTURES) || defined(HAS_ANISOTROPY)
// The unit tangent dP/du of triangle `prim` for the texture coordinates
// t0, t1, t2 at its corners, made orthogonal to the unit normal n: false
// where the uvs are degenerate.
inline bool pt_uv_tangent(const PtScene* s, uint prim, float3 n, float2 t0, float2 t1, float2 t2,
                          float3* out) {
    TRI_LOAD(p, s->positions, s->mt, prim);
    float3 e1 = (float3)(p[4] - p[0], p[5] - p[1], p[6] - p[2]);
    float3 e2 = (float3)(p[8] - p[0], p[9] - p[1], p[10] - p[2]);
    float2 d1 = t1 - t0;
    float2 d2 = t2 - t0;
    float r = d1.x * d2.y - d2.x * d1.y;
    if (r == 0.0f || !isfinite(r)) return false;
    float3 tg = (e1 * d2.y - e2 * d1.y) / r;
    tg = tg - n * dot(n, tg);
    float tl = length(tg);
    if (!(tl > 0.0f)) return false;
    *out = tg / tl;
    return true;
}
#endif

#ifdef HAS_TEXTURES
// glTF normal mapping: the tangent is dP/du of the triangle in the normal
// texture's (transformed) uv space, made orthogonal to the front-side
// shading normal n, the bitangent is n x t, and on a back face all three
// flip (as the Khronos sample viewer does). Degenerate uvs keep n.
inline float3 pt_normal_map(const PtScene* s, int binding, float scale, uint prim, float3 n,
                            bool front, PtAttrs at TEX_DECL) {
    TextureBinding b = tex_bindings[binding];
    // The tangent follows the uv set the normal texture is mapped through.
    bool second = b.tex_coord == 1 && (s->frame.flags & FRAME_UVS1) != 0u;
    const __global float* t = (second ? s->uvs1 : s->uvs) + (size_t)prim * 6u;
    float2 t0 = texture_uv(b, (float2)(t[0], t[1]), (float2)(t[0], t[1]));
    float2 t1 = texture_uv(b, (float2)(t[2], t[3]), (float2)(t[2], t[3]));
    float2 t2 = texture_uv(b, (float2)(t[4], t[5]), (float2)(t[4], t[5]));
    float3 sn = front ? n : -n;
    float3 tg;
    if (!pt_uv_tangent(s, prim, n, t0, t1, t2, &tg)) return sn;
    float3 bt = cross(n, tg);
    float4 c = sample_texture(TEXTURE_ARGS, b, texture_uv(b, at.uv.xy, at.uv.zw));
    float3 tn = (float3)((c.x * 2.0f - 1.0f) * scale, (c.y * 2.0f - 1.0f) * scale,
                         c.z * 2.0f - 1.0f);
    float3 mapped = (tg * tn.x + bt * tn.y) + n * tn.z;
    float ml = length(mapped);
    if (!(ml > 0.0f)) return sn;
    mapped = mapped / ml;
    return front ? mapped : -mapped;
}
#endif

// The shading frame at a hit: geometric normal facing the incoming ray,
// shading normal on the same side and on the viewer's side.
typedef struct {
    float3 p;
    float3 ng;
    float3 ns;
    PtAttrs at;
    bool front;
#ifdef HAS_TRANSMISSION
    float3 below; // ray origin for directions below the surface
    // The volumes (media.h) a light sample's shadow ray travels through
    // above (on the viewer's side) and below the surface.
    uint medium_above;
    uint medium_below;
    // The colour channel the path carries alone since it met a dispersive
    // volume (KHR_materials_dispersion), -1 before: the indices its shadow
    // rays' surfaces and volumes take.
    int channel;
#endif
#ifdef HAS_CLEARCOAT
    // The interpolated normal before the base's normal map, on the viewer's
    // side: the clear coat's normal without its own map (the extension
    // keeps the base's normal map off the coat).
    float3 n_unmapped;
    uint prim;
#endif
} PtSurface;

// A shading normal `n` facing away from the viewer (direction `wo`) or
// from the geometric normal `ng` would make the surface black: `ng` is used
// there instead (for the base's normal and the clear coat's alike).
inline float3 pt_facing(float3 n, float3 wo, float3 ng) {
    return dot(n, wo) <= 0.0f || dot(n, ng) <= 0.0f ? ng : n;
}

inline PtSurface pt_surface(const PtScene* s, PtMaterial m, Hit h, float3 dir TEX_DECL) {
    PtSurface sf;
    sf.p = hit_point(SGEOM(s), h.prim, h.u, h.v);
    float3 ng = geometric_normal(SGEOM(s), h.prim);
    sf.front = dot(dir, ng) < 0.0f;
    if (!sf.front) ng = -ng;
    sf.ng = ng;
    sf.at = pt_attrs(s, h.prim, h.u, h.v);
    float3 ns = ng;
    if ((s->frame.flags & FRAME_NORMALS) != 0u) {
        TRI_LOAD(n, s->normals, s->mt, h.prim);
        float w = 1.0f - h.u - h.v;
        float3 si = (float3)((w * n[0] + h.u * n[4]) + h.v * n[8],
                             (w * n[1] + h.u * n[5]) + h.v * n[9],
                             (w * n[2] + h.u * n[6]) + h.v * n[10]);
        float l = length(si);
        if (l > 0.0f) {
            si = si / l;
            ns = sf.front ? si : -si;
        }
    }
#ifdef HAS_CLEARCOAT
    sf.n_unmapped = pt_facing(ns, -dir, ng);
    sf.prim = h.prim;
#endif
#ifdef HAS_TEXTURES
    if (m.normal_tex >= 0 && (s->frame.flags & FRAME_CLAY) == 0u &&
        (s->frame.flags & FRAME_UVS) != 0u)
        ns = pt_normal_map(s, m.normal_tex, m.normal_scale, h.prim, sf.front ? ns : -ns, sf.front,
                           sf.at TEX_PASS);
#endif
    sf.ns = pt_facing(ns, -dir, ng);
    return sf;
}

inline BsdfParams pt_bsdf_params(const PtScene* s, PtMaterial m, PtAttrs at, float3* albedo TEX_DECL) {
    BsdfParams p;
    if ((s->frame.flags & FRAME_CLAY) != 0u) {
        p.base = (float3)(0.8f);
        p.metallic = 0.0f;
        p.alpha = 1.0f;
        p.specular = 0.0f;
#ifdef HAS_ANISOTROPY
        p.alpha_t = p.alpha;
        p.anisotropy_dir = (float2)(1.0f, 0.0f);
#endif
        *albedo = p.base;
        return p;
    }
    float4 bc = pt_base_color(m, at TEX_PASS);
    float metallic = m.metallic;
    float roughness = m.roughness;
#ifdef HAS_TEXTURES
    if (m.metallic_roughness_tex >= 0) {
        float4 mr = pt_texture(m.metallic_roughness_tex, at TEX_PASS);
        roughness = roughness * mr.y;
        metallic = metallic * mr.z;
    }
#endif
    p.base = bc.xyz;
    p.metallic = clamp(metallic, 0.0f, 1.0f);
    p.alpha = ggx_alpha(roughness);
    p.specular = 1.0f;
#ifdef HAS_ANISOTROPY
    // pt_dielectric_params sets the anisotropy.
    p.alpha_t = p.alpha;
    p.anisotropy_dir = (float2)(1.0f, 0.0f);
#endif
    *albedo = p.base;
    return p;
}

#ifdef HAS_LAYERS
// The clear coat and sheen of extension `mx` at surface `sf` seen along
// `wo_w`, in the shading frame (t, b, sf.ns) (clay has neither). The
// layers' textures scale their factors: clearcoat by R, its roughness by
// G, the sheen colour by RGB (sRGB-decoded), its roughness by A. The coat's
// normal is the unmapped interpolated normal, or clearcoatNormalTexture
// applied to it.
inline void pt_layer_params(const PtScene* s, PtMaterialExt mx, PtSurface sf, float3 wo_w,
                            float3 t, float3 b, BsdfParams* bp TEX_DECL) {
    bool layered = (s->frame.flags & FRAME_CLAY) == 0u;
#ifdef HAS_CLEARCOAT
    float clearcoat = mx.clearcoat;
    float coat_roughness = mx.clearcoat_roughness;
    float3 nc = sf.n_unmapped;
#ifdef HAS_TEXTURES
    if (mx.clearcoat_tex >= 0) clearcoat *= pt_texture(mx.clearcoat_tex, sf.at TEX_PASS).x;
    if (mx.clearcoat_roughness_tex >= 0)
        coat_roughness *= pt_texture(mx.clearcoat_roughness_tex, sf.at TEX_PASS).y;
    if (layered && mx.clearcoat_normal_tex >= 0 && (s->frame.flags & FRAME_UVS) != 0u) {
        nc = pt_normal_map(s, mx.clearcoat_normal_tex, mx.clearcoat_normal_scale, sf.prim,
                           sf.front ? nc : -nc, sf.front, sf.at TEX_PASS);
        nc = pt_facing(nc, wo_w, sf.ng);
    }
#endif
    bp->clearcoat = layered ? clearcoat : 0.0f;
    bp->coat_alpha = ggx_alpha(coat_roughness);
    bp->coat_n = (float3)(0.0f, 0.0f, 1.0f);
    if (layered && (nc.x != sf.ns.x || nc.y != sf.ns.y || nc.z != sf.ns.z))
        bp->coat_n = normalize(to_local(nc, t, b, sf.ns));
#endif
#ifdef HAS_SHEEN
    float3 sheen_color = (float3)(mx.sheen_color[0], mx.sheen_color[1], mx.sheen_color[2]);
    float sheen_roughness = mx.sheen_roughness;
#ifdef HAS_TEXTURES
    if (mx.sheen_color_tex >= 0) sheen_color *= pt_texture(mx.sheen_color_tex, sf.at TEX_PASS).xyz;
    if (mx.sheen_roughness_tex >= 0)
        sheen_roughness *= pt_texture(mx.sheen_roughness_tex, sf.at TEX_PASS).w;
#endif
    bp->sheen_color = layered ? sheen_color : (float3)(0.0f);
    bp->sheen_roughness = sheen_roughness;
#endif
}
#endif

#ifdef HAS_TRANSMISSION
// The dielectric extensions' parameters at a surface of extension `mx`
// (`volume`: refracting, seen from its front or back) with index
// `n_other` on the surface's other side (for thin-walled surfaces: the
// volume they are in). F0 comes from the relative index mx.ior / n_other
// (symmetric in the two indices); against air both are what a lone surface
// has. Rust twin: trace::material::Dielectric::nested.
inline void pt_dielectric_params(const PtScene* s, PtMaterialExt mx, bool volume, bool front,
                                 float n_other, int channel, PtAttrs at, BsdfParams* bp TEX_DECL) {
    if ((s->frame.flags & FRAME_CLAY) != 0u) {
        bp->f0 = 0.04f;
        bp->f0_color = (float3)(0.04f);
        bp->transmission = 0.0f;
        bp->eta = 1.0f;
        bp->thin = 1.0f;
#ifdef HAS_DIFFUSE_TRANSMISSION
        bp->diffuse_transmission = 0.0f;
        bp->diffuse_transmission_color = (float3)(1.0f);
#endif
#ifdef HAS_IRIDESCENCE
        bp->iridescence = 0.0f;
#endif
        return;
    }
    float3 specular_color =
        (float3)(mx.specular_color[0], mx.specular_color[1], mx.specular_color[2]);
    float specular = mx.specular;
    float transmission = mx.transmission;
#ifdef HAS_IRIDESCENCE
    // Without a thickness texture the film is the range's maximum thick.
    float iridescence = mx.iridescence;
    float thickness = mx.iridescence_thickness_max;
#endif
#ifdef HAS_DIFFUSE_TRANSMISSION
    float diffuse_transmission = mx.diffuse_transmission;
    float3 diffuse_transmission_color =
        (float3)(mx.diffuse_transmission_color[0], mx.diffuse_transmission_color[1],
                 mx.diffuse_transmission_color[2]);
#endif
#ifdef HAS_TEXTURES
    // The extensions' textures scale their factors: transmission by R,
    // specular by A, the specular colour by RGB (sRGB-decoded).
    if (mx.transmission_tex >= 0) transmission *= pt_texture(mx.transmission_tex, at TEX_PASS).x;
    if (mx.specular_tex >= 0) specular *= pt_texture(mx.specular_tex, at TEX_PASS).w;
    if (mx.specular_color_tex >= 0)
        specular_color *= pt_texture(mx.specular_color_tex, at TEX_PASS).xyz;
#ifdef HAS_DIFFUSE_TRANSMISSION
    // Diffuse transmission by A, its colour by RGB (sRGB-decoded).
    if (mx.diffuse_transmission_tex >= 0)
        diffuse_transmission *= pt_texture(mx.diffuse_transmission_tex, at TEX_PASS).w;
    if (mx.diffuse_transmission_color_tex >= 0)
        diffuse_transmission_color *= pt_texture(mx.diffuse_transmission_color_tex, at TEX_PASS).xyz;
#endif
#ifdef HAS_IRIDESCENCE
    // Iridescence by R; the thickness between its minimum and maximum by G.
    if (mx.iridescence_tex >= 0) iridescence *= pt_texture(mx.iridescence_tex, at TEX_PASS).x;
    if (mx.iridescence_thickness_tex >= 0) {
        float g = pt_texture(mx.iridescence_thickness_tex, at TEX_PASS).y;
        thickness = mx.iridescence_thickness_min +
                    (mx.iridescence_thickness_max - mx.iridescence_thickness_min) * g;
    }
#endif
#endif
    // Dispersion is the volume's: a thin-walled surface keeps its index.
    float ior = volume ? media_channel_ior(mx.ior, mx.dispersion, channel) : mx.ior;
    bp->f0 = media_f0(ior, n_other);
    bp->f0_color = fmin((float3)(bp->f0) * specular_color, (float3)(1.0f));
    bp->specular = specular;
    bp->transmission = clamp(transmission, 0.0f, 1.0f);
    bp->eta = volume ? media_eta(ior, n_other, front) : 1.0f;
    bp->thin = volume ? 0.0f : 1.0f;
#ifdef HAS_DIFFUSE_TRANSMISSION
    bp->diffuse_transmission = clamp(diffuse_transmission, 0.0f, 1.0f);
    bp->diffuse_transmission_color = diffuse_transmission_color;
#endif
#ifdef HAS_IRIDESCENCE
    bp->iridescence = clamp(iridescence, 0.0f, 1.0f);
    bp->iridescence_ior = mx.iridescence_ior;
    bp->iridescence_thickness = thickness;
#endif
#ifdef HAS_ANISOTROPY
    // KHR_materials_anisotropy: the direction (1, 0) in tangent space, or
    // anisotropyTexture's RG mapped to -1..1 (its B scales the strength),
    // turned counter-clockwise by anisotropyRotation. A texel of no
    // direction (RG 0.5) leaves the lobe isotropic.
    float strength = mx.anisotropy_strength;
    float2 dir = (float2)(1.0f, 0.0f);
#ifdef HAS_TEXTURES
    if (mx.anisotropy_tex >= 0) {
        float4 a = pt_texture(mx.anisotropy_tex, at TEX_PASS);
        dir = (float2)(a.x * 2.0f - 1.0f, a.y * 2.0f - 1.0f);
        strength *= a.z;
        if (!(dot(dir, dir) > 0.0f)) strength = 0.0f;
    }
#endif
    float cr = mx.anisotropy_cos;
    float sr = mx.anisotropy_sin;
    bp->anisotropy_dir = (float2)(cr * dir.x - sr * dir.y, sr * dir.x + cr * dir.y);
    bp->alpha_t = anisotropic_alpha(bp->alpha, strength);
#endif
}

#ifdef HAS_ANISOTROPY
// KHR_materials_anisotropy's shading frame at `sf` on triangle `prim`: x
// along the anisotropy direction, bp.anisotropy_dir in the tangent frame of
// dP/du for TEXCOORD_0 (the tangent MikkTSpace gives a flat triangle; the
// soup carries no TANGENT attribute) and n x dP/du, n the front side's
// normal so both sides agree; y = ns x x. False, and t and b unchanged, for
// an isotropic lobe or where the uvs give no tangent.
inline bool pt_anisotropy_frame(const PtScene* s, PtSurface sf, uint prim, BsdfParams bp,
                                float3* t, float3* b) {
    if (bp.alpha_t == bp.alpha || (s->frame.flags & FRAME_UVS) == 0u) return false;
    const __global float* uv = s->uvs + (size_t)prim * 6u;
    float3 nf = sf.front ? sf.ns : -sf.ns;
    float3 tg;
    if (!pt_uv_tangent(s, prim, nf, (float2)(uv[0], uv[1]), (float2)(uv[2], uv[3]),
                       (float2)(uv[4], uv[5]), &tg))
        return false;
    float3 x = tg * bp.anisotropy_dir.x + cross(nf, tg) * bp.anisotropy_dir.y;
    float xl = length(x);
    if (!(xl > 0.0f)) return false;
    *t = x / xl;
    *b = cross(sf.ns, *t);
    return true;
}
#endif

// Whether a shadow ray may cross `prim` (material `m`): thin-walled,
// transmissive, and smooth unless a texture may lower its roughness
// (pt_shadow_transmittance decides at the point). The roughness factor
// first: the extension is read only where it can matter.
inline bool pt_maybe_clear(const PtScene* s, PtMaterial m, uint prim) {
    if ((s->frame.flags & FRAME_CLAY) != 0u ||
        !(ggx_smooth(ggx_alpha(m.roughness)) || m.metallic_roughness_tex >= 0))
        return false;
    PtMaterialExt mx = pt_material_ext(s, prim);
    return mx.volume == 0.0f && mx.transmission > 0.0f;
}

// The transmittance of the shadow segment org + t dir, t in (0, tmax),
// travelling in volume `medium`: 0 where blocked. Smooth thin-walled
// transmissive surfaces let it through with their straight-through
// transmittance (bsdf_shadow_straight_through, the glTF thin-walled rule:
// that lobe is a delta lobe that does not bend the ray, so the shadow ray
// follows exactly the path its BSDF sample would take, and the path
// tracer counts that sample as a null crossing, pt_path). Refracting
// surfaces, rough thin ones and opaque ones block. The medium's
// Beer-Lambert attenuation applies over the whole segment.
inline float3 pt_shadow_transmittance(PtScene* s, float3 org, float3 dir, float tmax, uint medium,
                                      int channel, SampleRng rng, uint bounce TEX_DECL) {
    float3 tr = (float3)(1.0f);
    if (medium != NO_MEDIUM) {
        tr = pt_attenuation(pt_medium_sigma(s, medium), tmax * length(dir));
        if (!(tr.x > 0.0f || tr.y > 0.0f || tr.z > 0.0f)) return (float3)(0.0f);
    }
    Ray r = pt_segment_ray(org, dir, tmax);
#ifndef TRAVERSAL_STACKLESS
    Hit a = pt_trace_any(s, r);
    if (a.prim == MISS) return tr;
    PtMaterial am = pt_material(s, a.prim);
    if (pt_blocks_for_certain(s, am, a.prim, dir) && !pt_maybe_clear(s, am, a.prim))
        return (float3)(0.0f);
#endif
    float3 d = normalize(dir);
    float n_medium = pt_medium_ior(s, medium, channel);
    uint crossings = 0u;
    for (;;) {
        Hit h;
        float travelled;
        bool blocked;
        bool found =
            pt_find_surface(s, r, rng, bounce, 1u, &h, &travelled, &blocked, &crossings TEX_PASS);
        if (blocked) return (float3)(0.0f);
        if (!found) return tr;
        PtMaterial m = pt_material(s, h.prim);
        if (!pt_maybe_clear(s, m, h.prim)) return (float3)(0.0f);
        PtMaterialExt mx = pt_material_ext(s, h.prim);
        PtSurface sf = pt_surface(s, m, h, d TEX_PASS);
        float3 albedo;
        BsdfParams bp = pt_bsdf_params(s, m, sf.at, &albedo TEX_PASS);
        pt_dielectric_params(s, mx, false, sf.front, n_medium, channel, sf.at, &bp TEX_PASS);
        float3 t, b;
        onb(sf.ns, &t, &b);
#ifdef HAS_LAYERS
        pt_layer_params(s, mx, sf, -d, t, b, &bp TEX_PASS);
#endif
        if (!spec_smooth(bp)) return (float3)(0.0f);
        tr = tr * bsdf_shadow_straight_through(bp, to_local(-d, t, b, sf.ns));
        if (!(tr.x > 0.0f || tr.y > 0.0f || tr.z > 0.0f)) return (float3)(0.0f);
        crossings += 1u;
        if (crossings >= MAX_CROSSINGS) return (float3)(0.0f);
        float3 o = offset_ray_origin_scaled(sf.p, -sf.ng, offset_scale(SGEOM(s), h.prim));
        r.org[0] = o.x; r.org[1] = o.y; r.org[2] = o.z;
        r.tmin = 0.0f;
        r.tmax = r.tmax - travelled;
        if (!(r.tmax > 0.0f)) return tr;
    }
}
#endif

// A light sample's contribution at a vertex: the BSDF times the cosine
// times `contrib` (radiance or irradiance over the sampling pdf), weighted
// by MIS against the BSDF sample when `light_pdf` > 0 (0: a delta light),
// if the shadow ray from `above` along `shadow_dir` (to `shadow_t`) is
// clear.
inline float3 pt_shade_light(PtScene* s, PtSurface sf, BsdfParams bp, float3 wo, float3 t,
                             float3 b, float3 above, float3 beta, float3 wi_w, float3 contrib,
                             float light_pdf, float3 shadow_dir, float shadow_t, SampleRng rng,
                             uint bounce TEX_DECL) {
#ifdef HAS_TRANSMISSION
    // Below the surface: only through a transmissive material, and the
    // shadow ray starts below it (towards the same point for finite lights).
    bool reflected = dot(wi_w, sf.ng) > 0.0f;
    if (!reflected && !(bsdf_transmits(bp) && dot(wi_w, sf.ng) < 0.0f)) return (float3)(0.0f);
    float3 wi = to_local(wi_w, t, b, sf.ns);
    if (reflected ? !(wi.z > 0.0f) : !(wi.z < 0.0f)) return (float3)(0.0f);
    float cos_i = fabs(wi.z);
    if (!reflected) {
        if (!isinf(shadow_t)) shadow_dir = shadow_dir + (above - sf.below);
        above = sf.below;
    }
#else
    if (!(dot(wi_w, sf.ng) > 0.0f)) return (float3)(0.0f);
    float3 wi = to_local(wi_w, t, b, sf.ns);
    if (!(wi.z > 0.0f)) return (float3)(0.0f);
    float cos_i = wi.z;
#endif
    float3 f = bsdf_eval(bp, wo, wi);
    if (!(f.x > 0.0f || f.y > 0.0f || f.z > 0.0f)) return (float3)(0.0f);
#ifdef FILM_LIGHT
    if (s->split_lobes) {
        s->shade_wi = wi;
        s->shade_f = f;
    }
#endif
    float w = 1.0f;
    if (light_pdf > 0.0f) w = power_heuristic(light_pdf, bsdf_pdf(bp, wo, wi));
    float3 c = beta * f * (cos_i * w) * contrib;
    if (!(c.x > 0.0f || c.y > 0.0f || c.z > 0.0f)) return (float3)(0.0f);
#ifdef HAS_TRANSMISSION
    uint medium = reflected ? sf.medium_above : sf.medium_below;
    return c * pt_shadow_transmittance(s, above, shadow_dir, shadow_t, medium, sf.channel, rng,
                                       bounce TEX_PASS);
#else
    if (pt_occluded(s, above, shadow_dir, shadow_t, rng, bounce TEX_PASS)) return (float3)(0.0f);
    return c;
#endif
}

// Punctual light `i` at the path's time: with MOTION_BLUR the lights buffer
// holds every light at each motion step (step after step), and position and
// direction are interpolated between the two steps around the time (the
// direction renormalised: motion_light in motion.h).
inline PtLight pt_light(const PtScene* s, uint i) {
#ifdef MOTION_BLUR
    uint count = s->frame.light_count;
    return motion_light(s->lights[s->mt.step * count + i],
                        s->lights[(s->mt.step + 1u) * count + i], s->mt.frac);
#else
    return s->lights[i];
#endif
}

// Punctual light `i`, chosen with probability `pmf`.
inline float3 pt_punctual_direct(PtScene* s, uint i, float pmf, PtSurface sf, BsdfParams bp,
                                 float3 wo, float3 t, float3 b, float3 above, float3 beta,
                                 SampleRng rng, uint bounce TEX_DECL) {
    float3 wi_w, e;
    float dist;
    PtLight light = pt_light(s, i);
    if (!(pmf > 0.0f) || !punctual_incident(light, sf.p, &wi_w, &dist, &e))
        return (float3)(0.0f);
    float3 shadow_dir = wi_w;
    float shadow_t = INFINITY;
    if (!isinf(dist)) {
        float3 lp = (float3)(light.position[0], light.position[1], light.position[2]);
        shadow_dir = lp - above;
        shadow_t = 1.0f;
    }
    return pt_shade_light(s, sf, bp, wo, t, b, above, beta, wi_w, e / pmf, 0.0f, shadow_dir,
                          shadow_t, rng, bounce TEX_PASS);
}

// A point on an emissive triangle, chosen by power (the selection
// probability is in pt_emissive_pdf).
inline float3 pt_emissive_direct(PtScene* s, float u1, float u2, PtSurface sf, BsdfParams bp,
                                 float3 wo, float3 t, float3 b, float3 above, float3 beta,
                                 SampleRng rng, uint bounce TEX_DECL) {
    uint k = cdf_search(s->emit_cdf, s->frame.emit_count, u1);
    float c0 = s->emit_cdf[k], c1 = s->emit_cdf[k + 1u];
    float ur = (u1 - c0) / (c1 - c0);
    uint prim = s->emit_prims[k];
    float2 bc = sample_triangle(ur, u2);
    float3 q = hit_point(SGEOM(s), prim, bc.x, bc.y);
    float3 to = q - sf.p;
    float d = sqrt(dot(to, to));
    if (!(d > 0.0f)) return (float3)(0.0f);
    float3 wi_w = to / d;
    PtMaterial lm = pt_material(s, prim);
    float3 nl = geometric_normal(SGEOM(s), prim);
    float cos_l = -dot(wi_w, nl);
    if ((lm.flags & MAT_DOUBLE_SIDED) != 0u) cos_l = fabs(cos_l);
    float pdf = pt_emissive_pdf(s, prim, d, cos_l);
    if (!(pdf > 0.0f)) return (float3)(0.0f);
    PtAttrs luv = pt_attrs(s, prim, bc.x, bc.y);
    float3 contrib = pt_emission(lm, luv TEX_PASS) / pdf;
    // Stop just short of the emitter itself.
    return pt_shade_light(s, sf, bp, wo, t, b, above, beta, wi_w, contrib, pdf, q - above,
                          1.0f - 1.0e-4f, rng, bounce TEX_PASS);
}

// A direction towards the environment map, by its importance (a constant
// environment is left to the BSDF sample: see LightSelection).
inline float3 pt_env_direct(PtScene* s, float u1, float u2, PtSurface sf, BsdfParams bp, float3 wo,
                            float3 t, float3 b, float3 above, float3 beta, SampleRng rng,
                            uint bounce TEX_DECL) {
    float3 wi_w;
    float pdf;
    float3 le = env_sample(s->env, s->env_texels, s->env_marginal, s->env_conditional, u1, u2,
                           &wi_w, &pdf);
    pdf = pdf * s->frame.env_select_pmf;
    if (!(pdf > 0.0f)) return (float3)(0.0f);
    return pt_shade_light(s, sf, bp, wo, t, b, above, beta, wi_w, le / pdf, pdf, wi_w, INFINITY,
                          rng, bounce TEX_PASS);
}

#ifdef FILM_CATCHER
// Whether the segment from `org` along `dir` (to `tmax`) is clear, as a
// colour (with HAS_TRANSMISSION thin glass lets some light through).
inline float3 pt_catcher_visible(PtScene* s, float3 org, float3 dir, float tmax, SampleRng rng
                                 TEX_DECL) {
#ifdef HAS_TRANSMISSION
    return pt_shadow_transmittance(s, org, dir, tmax, NO_MEDIUM, -1, rng, 0u TEX_PASS);
#else
    return pt_occluded(s, org, dir, tmax, rng, 0u TEX_PASS) ? (float3)(0.0f) : (float3)(1.0f);
#endif
}

// The light a shadow catcher at `p` (normal `n`, on the camera's side of
// triangle `prim`) receives as a white Lambertian, with the rest of the
// scene's shadows (`lit`) and without them (`unshadowed`): one
// cosine-distributed direction towards the environment and one punctual
// light, from the same random numbers, so that where nothing shadows the
// two are equal and the pixel stays clear. Emissive meshes are not
// counted (they rarely light a plate's ground).
inline void pt_catcher_light(PtScene* s, float3 p, float3 n, uint prim, SampleRng rng,
                             float3* lit, float3* unshadowed TEX_DECL) {
    float4 u = rng_4d(rng, SET_CATCHER);
    float3 above = offset_ray_origin_scaled(p, n, offset_scale(SGEOM(s), prim));
    *lit = (float3)(0.0f);
    *unshadowed = (float3)(0.0f);
    if (s->env.kind != ENV_NONE) {
        float3 t, b;
        onb(n, &t, &b);
        float3 l = sample_cosine_hemisphere(u.x, u.y);
        float3 wi = (t * l.x + b * l.y) + n * l.z;
        // Cosine-distributed: the Lambertian's f cos / pdf is 1.
        float3 le = env_radiance(s->env, s->env_texels, wi);
        *unshadowed += le;
        if (le.x > 0.0f || le.y > 0.0f || le.z > 0.0f) {
            *lit += le * pt_catcher_visible(s, above, wi, INFINITY, rng TEX_PASS);
        }
    }
    uint count = s->frame.light_count;
    if (count > 0u) {
        uint i = min((uint)(u.z * (float)count), count - 1u);
        PtLight light = pt_light(s, i);
        float3 wi, e;
        float dist;
        if (punctual_incident(light, p, &wi, &dist, &e)) {
            float c = dot(wi, n);
            if (c > 0.0f) {
                float3 v = e * ((c / PT_PI) * (float)count);
                *unshadowed += v;
                float3 dir = wi;
                float tmax = INFINITY;
                if (!isinf(dist)) {
                    dir = (float3)(light.position[0], light.position[1], light.position[2]) - above;
                    tmax = 1.0f;
                }
                *lit += v * pt_catcher_visible(s, above, dir, tmax, rng TEX_PASS);
            }
        }
    }
}
#endif

// Results of one camera sample.
typedef struct {
    float3 radiance;
    float alpha;
    float depth;
    float3 normal;
    float3 albedo;
#ifdef FILM_MATTES
    uint matte; // the first hit's matte pair + 1; 0: no hit
#endif
#ifdef FILM_VECTORS
    float4 motion; // the first hit's motion vectors (pt_motion_vector)
#endif
#ifdef FILM_GEOMETRY
    float3 position; // the first hit's world-space point
    float2 uv;       // and TEXCOORD_0 there
#endif
#ifdef FILM_CATCHER
    // The camera ray met a shadow catcher first: the light there with the
    // scene's shadows and without them (pt_catcher_light).
    bool catcher;
    float3 catcher_lit;
    float3 catcher_unshadowed;
#endif
#ifdef FILM_LIGHT
    // This sample's light for the light-path passes (film::light), kept
    // in as few sums as the passes allow and split by lobe once, when the
    // pixel adds it (light_sums_add): the emission and environment the
    // camera saw; the light sampled at the first scattering vertex, by
    // lobe there; the light found after that vertex, straight from a light
    // (`after_direct`) or beyond; and the first vertex's lobe weight f
    // |cos| / pdf and the diffuse and transmission shares of it, which
    // split all that comes after.
    float3 seen_emit;
    float3 seen_env;
    float3 first_diffuse;
    float3 first_glossy;
    float3 first_transmit;
    float3 after_direct;
    float3 after_indirect;
    float3 weight;
    float3 share_diffuse;
    float3 share_transmit;
#endif
} PtSample;

#ifdef FILM_LIGHT
// At the path's first scattering vertex, the sampled direction wi (BSDF
// value f, pdf, from a delta lobe or not): the lobe weight f |cos| / pdf,
// whose mean is the lobes' albedo (the colour passes), and the shares of
// it the diffuse and transmission lobes gave. A delta lobe is glossy above
// the surface and transmission below.
inline void pt_first_lobes(PtSample* out, BsdfParams bp, float3 wo, float3 wi, float3 f,
                           float pdf, bool delta) {
    if (delta) {
        out->share_transmit = (float3)(wi.z < 0.0f ? 1.0f : 0.0f);
    } else {
        // f is bsdf_eval's value at wi (bsdf_sample's own).
        float3 fd, ft;
        bsdf_lobe_parts(bp, wo, wi, &fd, &ft);
        out->share_diffuse = lobe_share(fd, f);
        out->share_transmit = lobe_share(ft, f);
    }
    float3 w = f * (fabs(wi.z) / pdf);
    if (isfinite(w.x) && isfinite(w.y) && isfinite(w.z)) out->weight = w;
}

// Adds `c`, a light sample's contribution at a vertex after `depth`
// scattering ones (at `wi`, where the BSDF is `f`), to the light-path
// passes: at the first vertex by its lobes there, later to the light
// found after it.
inline void light_pass_direct(PtSample* out, BsdfParams bp, float3 wo, float3 wi, float3 f,
                              float3 c, uint depth) {
    if (depth != 0u) {
        out->after_indirect += c;
        return;
    }
    if (!(c.x > 0.0f || c.y > 0.0f || c.z > 0.0f)) return;
    float3 fd, ft;
    bsdf_lobe_parts(bp, wo, wi, &fd, &ft);
    float3 d = c * lobe_share(fd, f);
    float3 t = c * lobe_share(ft, f);
    out->first_diffuse += d;
    out->first_glossy += fmax((c - d) - t, (float3)(0.0f));
    out->first_transmit += t;
}

// Adds `c`, emission or environment (`env`) found after `depth`
// scattering vertices, to the light-path passes.
inline void light_pass_found(PtSample* out, float3 c, uint depth, bool env) {
    if (depth == 0u) {
        if (env)
            out->seen_env += c;
        else
            out->seen_emit += c;
    } else if (depth == 1u) {
        out->after_direct += c;
    } else {
        out->after_indirect += c;
    }
}

// Adds a kept sample `r` to a pixel's light-path pass sums (film::light's
// LIGHT_PASS_NAMES order): the light after the first vertex split by its
// shares there, glossy taking what the other two do not.
inline void light_sums_add(float3* light, PtSample r) {
    float3 zero = (float3)(0.0f);
    float3 dd = r.after_direct * r.share_diffuse, dt = r.after_direct * r.share_transmit;
    float3 id = r.after_indirect * r.share_diffuse, it = r.after_indirect * r.share_transmit;
    float3 wd = r.weight * r.share_diffuse, wt = r.weight * r.share_transmit;
    light[LIGHT_DIFFUSE] += r.first_diffuse + dd;
    light[LIGHT_DIFFUSE + 1u] += id;
    light[LIGHT_DIFFUSE + 2u] += wd;
    light[LIGHT_GLOSSY] += r.first_glossy + fmax((r.after_direct - dd) - dt, zero);
    light[LIGHT_GLOSSY + 1u] += fmax((r.after_indirect - id) - it, zero);
    light[LIGHT_GLOSSY + 2u] += fmax((r.weight - wd) - wt, zero);
    light[LIGHT_TRANSMISSION] += r.first_transmit + dt;
    light[LIGHT_TRANSMISSION + 1u] += it;
    light[LIGHT_TRANSMISSION + 2u] += wt;
    light[LIGHT_EMIT] += r.seen_emit;
    light[LIGHT_ENV] += r.seen_env;
}
#endif

inline PtSample pt_path(PtScene* s, __global const PtCamera* cam, __global const float* filter,
                        uint px, uint py, uint sample TEX_DECL) {
    PtSample out;
    out.radiance = (float3)(0.0f);
    out.alpha = 0.0f;
    out.depth = 0.0f;
    out.normal = (float3)(0.0f);
    out.albedo = (float3)(0.0f);
#ifdef FILM_MATTES
    out.matte = 0u;
#endif
#ifdef FILM_VECTORS
    out.motion = (float4)(0.0f);
#endif
#ifdef FILM_GEOMETRY
    out.position = (float3)(0.0f);
    out.uv = (float2)(0.0f);
#endif
#ifdef FILM_CATCHER
    out.catcher = false;
    out.catcher_lit = (float3)(0.0f);
    out.catcher_unshadowed = (float3)(0.0f);
#endif
#ifdef FILM_LIGHT
    out.seen_emit = (float3)(0.0f);
    out.seen_env = (float3)(0.0f);
    out.first_diffuse = (float3)(0.0f);
    out.first_glossy = (float3)(0.0f);
    out.first_transmit = (float3)(0.0f);
    out.after_direct = (float3)(0.0f);
    out.after_indirect = (float3)(0.0f);
    out.weight = (float3)(0.0f);
    out.share_diffuse = (float3)(0.0f);
    out.share_transmit = (float3)(0.0f);
    s->split_lobes = false;
    s->shade_wi = (float3)(0.0f);
    s->shade_f = (float3)(0.0f);
#endif
    uint pixel = py * s->frame.width + px;
    SampleRng rng = rng_for_sample(s->frame.seed_lo, s->frame.seed_hi, s->frame.frame_lo,
                                   s->frame.frame_hi, pixel, sample);

    // Filter importance sampling: the offset from the pixel centre follows
    // the film's filter (the table of film::FilterSampler, same arithmetic).
    float ox, oy;
    float4 uc = rng_4d(rng, SET_CAMERA);
    {
        float n = 1024.0f;
        float fu = uc.x * n;
        uint i = min((uint)floor(fu), 1023u);
        ox = filter[i] + (fu - (float)i) * (filter[i + 1u] - filter[i]);
        float fv = uc.y * n;
        uint j = min((uint)floor(fv), 1023u);
        oy = filter[j] + (fv - (float)j) * (filter[j + 1u] - filter[j]);
    }
#ifdef MOTION_BLUR
    // The path's time in the shutter: the camera set's third dimension, so
    // time is stratified over the samples jointly with the pixel filter.
    s->mt = motion_time(uc.z, s->motion_steps, s->motion_triangles);
    PtCamera cv = motion_camera(cam, s->mt);
#else
    PtCamera cv = cam[0];
#endif
    float sx = (((float)px + 0.5f + ox) / (float)s->frame.width) * 2.0f - 1.0f;
    float sy = 1.0f - (((float)py + 0.5f + oy) / (float)s->frame.height) * 2.0f;
    float3 c_org = (float3)(cv.origin[0], cv.origin[1], cv.origin[2]);
    float3 c_right = (float3)(cv.right[0], cv.right[1], cv.right[2]);
    float3 c_up = (float3)(cv.up[0], cv.up[1], cv.up[2]);
    float3 c_fwd = (float3)(cv.forward[0], cv.forward[1], cv.forward[2]);
    float3 org, dir;
    float tmin;
    if (cv.ortho != 0u) {
        org = (c_org + c_right * sx) + c_up * sy;
        dir = c_fwd;
        tmin = cv.znear;
    } else {
        float3 d = (c_fwd + c_right * sx) + c_up * sy;
#ifdef HAS_DOF
        if (cv.lens_radius > 0.0f) {
            float4 ul = rng_4d(rng, SET_LENS);
            float2 a = camera_aperture_point(ul.x, ul.y, cv.blades, cv.blade_rotation);
            camera_lens_ray(c_org, c_right, c_up, c_fwd, d, cv.znear, cv.lens_radius,
                            cv.focus_distance, a, &org, &dir, &tmin);
        } else
#endif
        {
            float l = length(d);
            org = c_org;
            dir = d / l;
            tmin = cv.znear * l;
        }
    }
    Ray ray;
    ray.org[0] = org.x; ray.org[1] = org.y; ray.org[2] = org.z;
    ray.dir[0] = dir.x; ray.dir[1] = dir.y; ray.dir[2] = dir.z;
    ray.tmin = tmin;
    ray.tmax = INFINITY;

    float3 beta = (float3)(1.0f);
    float prev_pdf = 0.0f;
    // The last bounce took a delta lobe: light sampling cannot reach its
    // direction, so an emitter found along it counts in full (MIS weight 1).
    bool prev_delta = false;
    uint max_depth = s->frame.max_depth;
    // Scattering vertices so far: `bounce` also counts null crossings (false
    // interfaces, thin glass's straight-through lobe), which keep the MIS
    // state of the vertex before them and count towards no limit but
    // MAX_CROSSINGS.
    uint depth = 0u;
#ifdef HAS_TRANSMISSION
    // The volumes the path is in (media.h) and the innermost one's
    // attenuation coefficient (0: none).
    PtMedia media = media_empty();
    int channel = -1; // the colour channel carried alone (pt_dielectric_params)
    float3 sigma = (float3)(0.0f);
    // The distance from the last scattering vertex to this segment's start
    // (null crossings), for the pdf of light sampling an emitter found.
    float carried = 0.0f;
#endif
    for (uint bounce = 0u;; ++bounce) {
        Hit h;
        float travelled;
        bool blocked;
        uint crossings = 0u;
        bool found = pt_find_surface(s, ray, rng, bounce, 0u, &h, &travelled, &blocked,
                                     &crossings TEX_PASS);
#ifdef FILM_CATCHER
        // The camera ray: a holdout cuts the frame (nothing of the sample
        // is kept); it sees through shadow catchers (a closed one has two
        // sides to cross), measuring the light at the first.
        for (uint k = 0u; bounce == 0u && found && k < MAX_CROSSINGS; ++k) {
            uint flags = s->triangle_flags[h.prim];
            if ((flags & TRIANGLE_HOLDOUT) != 0u) return out;
            if ((flags & TRIANGLE_SHADOW_CATCHER) == 0u) break;
            float3 p = hit_point(SGEOM(s), h.prim, h.u, h.v);
            float3 ng = geometric_normal(SGEOM(s), h.prim);
            float3 facing = dot(dir, ng) > 0.0f ? -ng : ng;
            if (!out.catcher) {
                out.catcher = true;
                pt_catcher_light(s, p, facing, h.prim, rng, &out.catcher_lit,
                                 &out.catcher_unshadowed TEX_PASS);
            }
            float3 o = offset_ray_origin_scaled(p, -facing, offset_scale(SGEOM(s), h.prim));
            ray.org[0] = o.x; ray.org[1] = o.y; ray.org[2] = o.z;
            ray.tmin = 0.0f;
            ray.tmax = INFINITY;
            float before = travelled;
            found = pt_find_surface(s, ray, rng, bounce, 0u, &h, &travelled, &blocked,
                                    &crossings TEX_PASS);
            travelled += before;
        }
#endif
#ifdef HAS_TRANSMISSION
        beta = beta * pt_attenuation(sigma, found ? travelled : INFINITY);
        float reach = carried + travelled;
#else
        float reach = travelled;
#endif
        if (!found) {
#ifdef FILM_TRANSPARENT
            // --transparent: the environment the camera ray sees directly
            // (through cut-outs too) is left out; alpha is 0 there.
            if (bounce == 0u) break;
#endif
            if (!blocked && s->env.kind != ENV_NONE) {
                float3 le = env_radiance(s->env, s->env_texels, dir);
                float w = 1.0f;
                if (depth > 0u && !prev_delta && s->frame.env_select_pmf > 0.0f) {
                    float pl = s->frame.env_select_pmf *
                               env_pdf(s->env, s->env_marginal, s->env_conditional, dir);
                    w = power_heuristic(prev_pdf, pl);
                }
                out.radiance += beta * le * w;
#ifdef FILM_LIGHT
                light_pass_found(&out, beta * le * w, depth, true);
#endif
            }
            break;
        }
        PtMaterial m = pt_material(s, h.prim);
        PtSurface sf = pt_surface(s, m, h, dir TEX_PASS);
#ifdef HAS_MATERIAL_EXT
        uint mat = pt_material_index(s, h.prim);
        PtMaterialExt mx = s->material_exts[mat];
#endif
#ifdef HAS_TRANSMISSION
        bool volume = mx.volume != 0.0f;
        if (volume && !sf.front && media_false_interface(&media, mat)) {
            // A false interface (media.h): cross it unchanged.
            media_leave(&media, mat);
            sigma = pt_medium_sigma(s, media_innermost(&media));
            carried = reach;
            if (bounce - depth >= MAX_CROSSINGS) break;
            float3 o = offset_ray_origin_scaled(sf.p, -sf.ng, offset_scale(SGEOM(s), h.prim));
            ray.org[0] = o.x; ray.org[1] = o.y; ray.org[2] = o.z;
            ray.tmin = 0.0f;
            ray.tmax = INFINITY;
            continue;
        }
#endif
        float3 albedo;
        BsdfParams bp = pt_bsdf_params(s, m, sf.at, &albedo TEX_PASS);
        if (bounce == 0u) {
            out.alpha = 1.0f;
            out.depth = travelled;
            out.normal = sf.ns;
            out.albedo = albedo;
#ifdef FILM_MATTES
            out.matte = s->triangle_mattes[h.prim] + 1u;
#endif
#ifdef FILM_VECTORS
            out.motion = pt_motion_vector(s, h.prim, h.u, h.v);
#endif
#ifdef FILM_GEOMETRY
            out.position = sf.p;
            out.uv = sf.at.uv.xy;
#endif
        }
        // A single-sided emitter emits from its front only (the light
        // sampler's pdf is 0 behind it too).
        if ((m.flags & MAT_EMISSIVE) != 0u && (sf.front || (m.flags & MAT_DOUBLE_SIDED) != 0u)) {
            float3 le = pt_emission(m, sf.at TEX_PASS);
            float w = 1.0f;
            if (depth > 0u && !prev_delta) {
                float cos_l = dot(-dir, sf.ng);
                w = power_heuristic(prev_pdf, pt_emissive_pdf(s, h.prim, reach, cos_l));
            }
            out.radiance += beta * le * w;
#ifdef FILM_LIGHT
            light_pass_found(&out, beta * le * w, depth, false);
#endif
        }
#ifdef HAS_UNLIT
        if ((m.flags & MAT_UNLIT) != 0u && (s->frame.flags & FRAME_CLAY) == 0u) {
            out.radiance += beta * albedo;
#ifdef FILM_LIGHT
            light_pass_found(&out, beta * albedo, depth, false);
#endif
            break;
        }
#endif
#ifdef HAS_TRANSMISSION
        // At the depth limit only thin glass's straight-through lobe may
        // go on (a null crossing, which the vertex before counted on).
        bool last = depth >= max_depth;
        if (last && !(mx.volume == 0.0f && mx.transmission > 0.0f)) break;
#else
        bool last = false;
        if (depth >= max_depth) break;
#endif

        float3 wo_w = -dir;
        float3 t, b;
        onb(sf.ns, &t, &b);
        float3 wo = to_local(wo_w, t, b, sf.ns);
        float3 above = offset_ray_origin_scaled(sf.p, sf.ng, offset_scale(SGEOM(s), h.prim));
#ifdef HAS_TRANSMISSION
        sf.below = offset_ray_origin_scaled(sf.p, -sf.ng, offset_scale(SGEOM(s), h.prim));
        // The indices on the two sides: the volume the path is in, and for a
        // refracting surface the one beyond it (media.h).
        uint inner = media_innermost(&media);
        uint other = volume ? media_other(&media, mat, sf.front) : inner;
#ifdef HAS_DISPERSION
        // KHR_materials_dispersion: at the first dispersive volume it
        // meets, the path picks one colour channel uniformly and carries it
        // alone, three times as strong (unbiased per channel), with that
        // channel's indices from here on. The light set's fourth number is
        // unused by light sampling.
        if (channel < 0 && volume && mx.dispersion > 0.0f && mx.transmission > 0.0f &&
            (s->frame.flags & FRAME_CLAY) == 0u) {
            float u = rng_4d(rng, set_bounce(bounce, SET_LIGHT)).w;
            channel = min((int)(u * 3.0f), 2);
            beta = (float3)(channel == 0 ? 3.0f * beta.x : 0.0f, channel == 1 ? 3.0f * beta.y : 0.0f,
                            channel == 2 ? 3.0f * beta.z : 0.0f);
        }
#endif
        pt_dielectric_params(s, mx, volume, sf.front, pt_medium_ior(s, other, channel), channel, sf.at,
                             &bp TEX_PASS);
        sf.medium_above = inner;
        sf.medium_below = volume && sf.front ? mat : other;
        sf.channel = channel;
#endif
#ifdef HAS_ANISOTROPY
        if (pt_anisotropy_frame(s, sf, h.prim, bp, &t, &b)) wo = to_local(wo_w, t, b, sf.ns);
#endif
#ifdef HAS_LAYERS
        pt_layer_params(s, mx, sf, wo_w, t, b, &bp TEX_PASS);
#endif

        // Next-event estimation: every punctual light when the frame loops
        // over them, then one light from the selection distribution; none
        // where every lobe is a delta lobe (bsdf_eval is 0 there). Skipping
        // draws no sample, and the sampler's dimensions are fixed per set,
        // so the other sets are unchanged.
        bool only_delta = bsdf_only_delta(bp);
#ifdef FILM_LIGHT
        s->split_lobes = depth == 0u;
#endif
        if (!only_delta && !last && s->frame.light_loop != 0u) {
            for (uint i = 0u; i < s->frame.light_count; ++i) {
                float3 c = pt_punctual_direct(s, i, 1.0f, sf, bp, wo, t, b, above, beta, rng,
                                              bounce TEX_PASS);
                out.radiance += c;
#ifdef FILM_LIGHT
                light_pass_direct(&out, bp, wo, s->shade_wi, s->shade_f, c, depth);
#endif
            }
        }
        if (!only_delta && !last && s->frame.select_count > 0u) {
            float4 ul = rng_4d(rng, set_bounce(bounce, SET_LIGHT));
            uint pick = cdf_search(s->select_cdf, s->frame.select_count, ul.z);
            uint first = s->frame.light_loop != 0u ? 0u : s->frame.light_count;
            float3 c;
            if (pick < first) {
                float pmf = s->select_cdf[pick + 1u] - s->select_cdf[pick];
                c = pt_punctual_direct(s, pick, pmf, sf, bp, wo, t, b, above, beta, rng,
                                       bounce TEX_PASS);
            } else if (pick == first && s->frame.emit_count > 0u) {
                c = pt_emissive_direct(s, ul.x, ul.y, sf, bp, wo, t, b, above, beta, rng,
                                       bounce TEX_PASS);
            } else {
                c = pt_env_direct(s, ul.x, ul.y, sf, bp, wo, t, b, above, beta, rng,
                                  bounce TEX_PASS);
            }
            out.radiance += c;
#ifdef FILM_LIGHT
            light_pass_direct(&out, bp, wo, s->shade_wi, s->shade_f, c, depth);
#endif
        }

        // Continue the path by sampling the BSDF.
        float3 wi, f;
        float pdf;
        bool delta;
        float4 ub = rng_4d(rng, set_bounce(bounce, SET_BSDF));
        if (!bsdf_sample(bp, wo, ub.z, ub.x, ub.y, &wi, &f, &pdf, &delta))
            break;
        float3 wi_w = to_world(wi, t, b, sf.ns);
        float wl = length(wi_w);
        wi_w = wi_w / wl;
#ifdef HAS_TRANSMISSION
        bool transmitted = wi.z < 0.0f;
        if (transmitted ? dot(wi_w, sf.ng) >= 0.0f : dot(wi_w, sf.ng) <= 0.0f) break;
        beta = beta * f * (fabs(wi.z) / pdf);
        if (transmitted) {
            above = sf.below;
            if (volume) {
                if (sf.front)
                    media_enter(&media, mat);
                else
                    media_leave(&media, mat);
                sigma = pt_medium_sigma(s, media_innermost(&media));
            }
        }
        // Smooth thin glass's straight-through lobe is a null crossing: the
        // shadow rays of the vertex before it cross such glass
        // (pt_shadow_transmittance), so a light found beyond it is weighed
        // by MIS against that vertex's light sample (its pdf, its
        // distance), not counted in full as after a delta bounce.
        bool scattered = !(delta && transmitted && bp.thin != 0.0f);
        if (last && scattered) break;
        carried = scattered ? 0.0f : reach;
        if (!scattered && bounce - depth >= MAX_CROSSINGS) break;
#else
        if (dot(wi_w, sf.ng) <= 0.0f) break;
        beta = beta * f * (wi.z / pdf);
        bool scattered = true;
#endif
        if (scattered) {
#ifdef FILM_LIGHT
            if (depth == 0u)
                pt_first_lobes(&out, bp, wo, wi, f, pdf, delta);
#endif
            prev_pdf = pdf;
            prev_delta = delta;
            // Russian roulette from the sixth vertex on (after the fifth
            // bounce's sample), keeping throughput near 1 where it survives.
            // Started at the fourth vertex it was the largest source of noise
            // on the clay scan under a sky: a path ground -> mesh -> ground
            // became 0 or 2x instead of 0.51, 3.2x the error of starting here
            // for 0.9% fewer rays (BENCHMARKS.md); Mitsuba 3 starts at the same
            // depth.
            if (depth >= RR_FIRST_BOUNCE) {
                float q = fmin(fmax(fmax(beta.x, beta.y), beta.z), 1.0f);
                if (!(q > 0.0f)) break;
                if (q < 1.0f) {
                    if (ub.w >= q) break;
                    beta = beta / q;
                }
            }
            depth += 1u;
        }
        dir = wi_w;
        ray.org[0] = above.x; ray.org[1] = above.y; ray.org[2] = above.z;
        ray.dir[0] = dir.x; ray.dir[1] = dir.y; ray.dir[2] = dir.z;
        ray.tmin = 0.0f;
        ray.tmax = INFINITY;
    }
    return out;
}

// One sample pass over one tile: samples [sample_begin, sample_end) of
// every pixel of the tile, added to the pixel's sums in sample order.
#ifdef FILM_MATTES
// Counts a sample under matte pair `key` (+ 1) in a pixel's slots, which
// fill in order: the first slot that holds the key, or the first empty one.
// With every slot taken by other pairs the sample is not counted (the
// pixel's mattes then add up to less than its alpha).
inline void matte_count(uint2* slots, uint key) {
    for (uint j = 0u; j < MATTE_SLOTS; ++j) {
        if (slots[j].x == key) {
            slots[j].y += 1u;
            return;
        }
        if (slots[j].x == 0u) {
            slots[j] = (uint2)(key, 1u);
            return;
        }
    }
}
#endif

// accum_color: rgb, alpha; accum_normal / accum_albedo: rgb; accum_aux:
// depth sum over hits, hit count, dropped samples, samples taken;
// accum_snapshots: two per pixel, the running sums at the last two powers
// of two (pt_noise_estimate). With `adaptive`, pixels whose `active` flag is 0
// have converged and take no more samples; `listed` > 0 launches over the
// first `listed` entries of `pixel_list` (the pixels still active at the
// last check) instead of the tile.
__kernel void pt_render(__global const BvhNode* nodes, __global const WideNode* wnodes,
                        __global const StacklessNode* snodes,
                        uint snode_count, __global const uint* prim_ids,
                        __global const float* positions, __global const float* normals,
                        __global const float* uvs, __global const float* uvs1,
                        __global const float* colors, __global const uint* material_ids,
                        __global const PtMaterial* materials, __global const PtLight* lights,
                        __global const uint* emit_prims, __global const float* emit_cdf,
                        __global const float* emit_pmf, __global const float* select_cdf,
                        __global const PtEnv* env,
                        __global const float4* env_texels, __global const float* env_marginal,
                        __global const float* env_conditional, __global const float* filter,
                        __global const PtCamera* camera, __global const PtFrame* frame,
                        __global float4* accum_color, __global float4* accum_normal,
                        __global float4* accum_albedo, __global float4* accum_aux,
                        __global uint* ray_counts, __global float4* accum_snapshots,
                        __global const uint* active, uint adaptive,
                        __global const uint* pixel_list, uint listed, uint tile_x, uint tile_y,
                        uint tile_w, uint tile_h, uint sample_begin, uint sample_end TEX_DECL
                        MATX_DECL MOTION_DECL MATTE_DECL VECTOR_DECL CATCHER_DECL GEOMETRY_DECL LIGHT_DECL) {
    uint gid = get_global_id(0);
    uint px, py;
    if (listed > 0u) {
        if (gid >= listed) return;
        uint p = pixel_list[gid];
        px = p % frame[0].width;
        py = p / frame[0].width;
    } else {
        if (gid >= tile_w * tile_h) return;
        px = tile_x + gid % tile_w;
        py = tile_y + gid / tile_w;
    }
    PtScene s;
    s.nodes = nodes;
    s.wnodes = wnodes;
    s.snodes = snodes;
    s.snode_count = snode_count;
    s.prim_ids = prim_ids;
    s.positions = positions;
    s.normals = normals;
    s.uvs = uvs;
    s.uvs1 = uvs1;
    s.colors = colors;
    s.material_ids = material_ids;
    s.materials = materials;
    s.lights = lights;
    s.emit_prims = emit_prims;
    s.emit_cdf = emit_cdf;
    s.emit_pmf = emit_pmf;
    s.select_cdf = select_cdf;
    s.env = env[0];
    s.env_texels = env_texels;
    s.env_marginal = env_marginal;
    s.env_conditional = env_conditional;
    s.frame = frame[0];
    s.rays = 0u;
#ifdef MOTION_BLUR
    s.motion_steps = motion_steps;
    s.motion_triangles = motion_triangles;
#endif
#ifdef HAS_MATERIAL_EXT
    s.material_exts = material_exts;
#endif
#ifdef FILM_MATTES
    s.triangle_mattes = triangle_mattes;
#endif
#ifdef FILM_CATCHER
    s.triangle_flags = triangle_flags;
#endif
#ifdef FILM_VECTORS
    s.vector_positions = vector_positions;
    s.vector_cameras = vector_cameras;
    s.vector_triangles = vector_triangles;
#endif
    if (px >= s.frame.width || py >= s.frame.height) return;
    uint i = py * s.frame.width + px;
    if (adaptive != 0u && active[i] == 0u) return;
    // The running sum at the last two powers of two (the noise estimate's
    // first part, pt_noise_estimate): S(2^j) in snapshot j % 2.
    float4 snap0 = accum_snapshots[2u * i];
    float4 snap1 = accum_snapshots[2u * i + 1u];
    float4 color = accum_color[i];
    float4 nrm = accum_normal[i];
    float4 alb = accum_albedo[i];
    float4 aux = accum_aux[i];
#ifdef FILM_VECTORS
    float4 motion = accum_motion[i];
#endif
#ifdef FILM_GEOMETRY
    float4 geometry_p = accum_geometry[2u * i];
    float4 geometry_uv = accum_geometry[2u * i + 1u];
#endif
#ifdef FILM_CATCHER
    float4 catcher_lit = accum_catcher[3u * i];
    float4 catcher_unshadowed = accum_catcher[3u * i + 1u];
    float4 catcher_behind = accum_catcher[3u * i + 2u];
#endif
#ifdef FILM_MATTES
    uint2 mattes[MATTE_SLOTS];
    for (uint j = 0u; j < MATTE_SLOTS; ++j) mattes[j] = matte_slots[i * MATTE_SLOTS + j];
#endif
#ifdef FILM_LIGHT
    float3 light[LIGHT_PASSES];
    __global float* light_at = accum_light + (size_t)i * (3u * LIGHT_PASSES);
    for (uint j = 0u; j < LIGHT_PASSES; ++j) light[j] = vload3(j, light_at);
#endif
    for (uint k = sample_begin; k < sample_end; ++k) {
        if (k != 0u && (k & (k - 1u)) == 0u) {
            if (((31u - clz(k)) & 1u) == 0u) {
                snap0 = color;
            } else {
                snap1 = color;
            }
        }
        PtSample r = pt_path(&s, camera, filter, px, py, k TEX_PASS);
        bool finite = isfinite(r.radiance.x) && isfinite(r.radiance.y) &&
                      isfinite(r.radiance.z) && isfinite(r.depth) && isfinite(r.normal.x) &&
                      isfinite(r.normal.y) && isfinite(r.normal.z);
        if (!finite) {
            // Counted and dropped as a whole, as the film does.
            aux.z += 1.0f;
            continue;
        }
        color += (float4)(r.radiance, r.alpha);
        nrm += (float4)(r.normal, 0.0f);
        alb += (float4)(r.albedo, 0.0f);
        if (r.alpha > 0.0f) {
            aux.x += r.depth;
            aux.y += 1.0f;
        }
#ifdef FILM_MATTES
        if (r.matte != 0u) matte_count(mattes, r.matte);
#endif
#ifdef FILM_LIGHT
        light_sums_add(light, r);
#endif
#ifdef FILM_GEOMETRY
        // Summed over the samples that hit, as depth is (film::resolve).
        if (r.alpha > 0.0f) {
            geometry_p += (float4)(r.position, 0.0f);
            geometry_uv += (float4)(r.uv, 0.0f, 0.0f);
        }
#endif
#ifdef FILM_CATCHER
        if (r.catcher && isfinite(r.catcher_lit.x) && isfinite(r.catcher_lit.y) &&
            isfinite(r.catcher_lit.z) && isfinite(r.catcher_unshadowed.x) &&
            isfinite(r.catcher_unshadowed.y) && isfinite(r.catcher_unshadowed.z)) {
            catcher_lit += (float4)(r.catcher_lit, 1.0f);
            catcher_unshadowed += (float4)(r.catcher_unshadowed, 0.0f);
            catcher_behind += (float4)(r.radiance, r.alpha);
        }
#endif
#ifdef FILM_VECTORS
        // Summed over the samples that hit, as depth is (film::resolve).
        if (r.alpha > 0.0f && isfinite(r.motion.x) && isfinite(r.motion.y) &&
            isfinite(r.motion.z) && isfinite(r.motion.w)) {
            motion += r.motion;
        }
#endif
    }
    aux.w += (float)(sample_end - sample_begin);
    accum_color[i] = color;
    accum_snapshots[2u * i] = snap0;
    accum_snapshots[2u * i + 1u] = snap1;
    accum_normal[i] = nrm;
    accum_albedo[i] = alb;
    accum_aux[i] = aux;
    ray_counts[i] += s.rays;
#ifdef FILM_MATTES
    for (uint j = 0u; j < MATTE_SLOTS; ++j) matte_slots[i * MATTE_SLOTS + j] = mattes[j];
#endif
#ifdef FILM_LIGHT
    for (uint j = 0u; j < LIGHT_PASSES; ++j) vstore3(light[j], j, light_at);
#endif
#ifdef FILM_VECTORS
    accum_motion[i] = motion;
#endif
#ifdef FILM_GEOMETRY
    accum_geometry[2u * i] = geometry_p;
    accum_geometry[2u * i + 1u] = geometry_uv;
#endif
#ifdef FILM_CATCHER
    accum_catcher[3u * i] = catcher_lit;
    accum_catcher[3u * i + 1u] = catcher_unshadowed;
    accum_catcher[3u * i + 2u] = catcher_behind;
#endif
}

// Clears the sums of a frame; every pixel starts active.
__kernel void pt_clear(__global float4* accum_color, __global float4* accum_normal,
                       __global float4* accum_albedo, __global float4* accum_aux,
                       __global uint* ray_counts, __global float4* accum_snapshots,
                       __global uint* active, uint n MATTE_CLEAR_DECL VECTOR_CLEAR_DECL CATCHER_CLEAR_DECL GEOMETRY_DECL LIGHT_DECL) {
    uint i = get_global_id(0);
    if (i >= n) return;
#ifdef FILM_MATTES
    for (uint j = 0u; j < MATTE_SLOTS; ++j) matte_slots[i * MATTE_SLOTS + j] = (uint2)(0u);
#endif
#ifdef FILM_VECTORS
    accum_motion[i] = (float4)(0.0f);
#endif
#ifdef FILM_GEOMETRY
    accum_geometry[2u * i] = (float4)(0.0f);
    accum_geometry[2u * i + 1u] = (float4)(0.0f);
#endif
#ifdef FILM_CATCHER
    accum_catcher[3u * i] = (float4)(0.0f);
    accum_catcher[3u * i + 1u] = (float4)(0.0f);
    accum_catcher[3u * i + 2u] = (float4)(0.0f);
#endif
#ifdef FILM_LIGHT
    for (uint k = 0u; k < 3u * LIGHT_PASSES; ++k) accum_light[3u * LIGHT_PASSES * i + k] = 0.0f;
#endif
    accum_color[i] = (float4)(0.0f);
    accum_normal[i] = (float4)(0.0f);
    accum_albedo[i] = (float4)(0.0f);
    accum_aux[i] = (float4)(0.0f);
    ray_counts[i] = 0u;
    accum_snapshots[2u * i] = (float4)(0.0f);
    accum_snapshots[2u * i + 1u] = (float4)(0.0f);
    active[i] = 1u;
}

// The estimated relative error of a pixel's mean (Rust twin:
// film::noise_estimate) after t samples: the mean A of the first
// a = 2^j of them (the largest power of two at most t / 2; their sum is
// snapshot j % 2) against the mean B of the other b = t - a. (A - B)^2 a b
// / t^2 estimates the variance of the mean of all t; Cycles' half buffer
// (Dammertz et al. 2010) splits the samples into even and odd ones
// instead. Both are unbiased for independent samples, but the sampler's
// first 2^j samples are a stratified set of their own (an aligned block of
// Owen-scrambled Sobol points, sampling.h), so this split sees the error
// the stratified mean has, where even against odd sees that of
// independent samples: 2.6-3.6x the measured relative MSE on the shipped
// animation and the clay scan at 64 spp, against 1.1-1.3x for this split
// (BENCHMARKS.md). Taken relative to the pixel as the relative MSE is:
// RMS over the three channels, over sqrt(I^2 + 0.01). Infinite below two
// kept samples. (Dropped samples are not told apart: a pixel with any is
// estimated as if it had none; they are rare.)
inline float pt_noise_estimate(float4 color, float4 snap0, float4 snap1, float4 aux) {
    float n = aux.w - aux.z;
    uint t = (uint)aux.w;
    if (!(n >= 2.0f) || t < 2u) return INFINITY;
    uint j = 30u - clz(t);
    float4 first = (j & 1u) == 0u ? snap0 : snap1;
    float a = (float)(1u << j);
    float b = (float)t - a;
    float3 mean = color.xyz / n;
    float3 d = first.xyz / a - (color.xyz - first.xyz) / b;
    float w = (a * b) / ((float)t * (float)t);
    float num = (((d.x * d.x + d.y * d.y) + d.z * d.z) * w) / 3.0f;
    float den = ((mean.x * mean.x + mean.y * mean.y) + mean.z * mean.z) / 3.0f + 0.01f;
    return sqrt(num / den);
}

// The error below which a pixel stops (Rust twin: film::stop_threshold).
// Equal-error allocation (`inv_work_ref` 0): `threshold` itself. Time
// allocation: threshold * sqrt(work / work_ref), `work` the rays the pixel
// has traced so far. A pixel stops once its error's marginal gain per unit
// of work, e^2 / work, is below threshold^2 / work_ref: the allocation
// that minimises the frame's squared error for the work spent gives each
// pixel samples in proportion to its spread over the square root of its
// cost per sample, not to its variance.
inline float pt_stop_threshold(float threshold, uint work, float inv_work_ref) {
    if (inv_work_ref == 0.0f) return threshold;
    return threshold * sqrt((float)work * inv_work_ref);
}

// A convergence check: whether each pixel's estimated error is at or above
// its stop threshold (pt_stop_threshold).
__kernel void pt_converge(__global const float4* accum_color, __global const float4* accum_snapshots,
                          __global const float4* accum_aux, __global const uint* ray_counts,
                          __global uint* unconverged, float threshold, float inv_work_ref,
                          uint width, uint height) {
    uint i = get_global_id(0);
    if (i >= width * height) return;
    float e = pt_noise_estimate(accum_color[i], accum_snapshots[2u * i],
                                accum_snapshots[2u * i + 1u], accum_aux[i]);
    float t = pt_stop_threshold(threshold, ray_counts[i], inv_work_ref);
    unconverged[i] = e < t ? 0u : 1u;
}

// Grows the unconverged region by a pixel: a pixel keeps sampling while it
// or any of its eight neighbours is unconverged, so isolated pixels do not
// stop early next to noisy ones. Stopping is final: a stopped pixel's
// samples are always the first `count` of its sequence.
__kernel void pt_dilate(__global const uint* unconverged, __global uint* active, uint width,
                        uint height) {
    uint i = get_global_id(0);
    if (i >= width * height) return;
    int x = (int)(i % width), y = (int)(i / width);
    uint any = 0u;
    for (int dy = -1; dy <= 1; ++dy) {
        for (int dx = -1; dx <= 1; ++dx) {
            int nx = x + dx, ny = y + dy;
            if (nx >= 0 && ny >= 0 && nx < (int)width && ny < (int)height)
                any |= unconverged[ny * (int)width + nx];
        }
    }
    active[i] = active[i] & any;
}

// Each triangle's emitted power up to a constant factor (luminance of the
// emissive factor times the area; twice that when double-sided), 0 for
// triangles whose material does not emit. The host turns it into the
// emissive triangles' sampling distribution.
__kernel void pt_emissive_power(__global const float* positions,
                                __global const uint* material_ids,
                                __global const PtMaterial* materials, uint material_count,
                                uint n, __global float* power) {
    uint i = get_global_id(0);
    if (i >= n) return;
    PtMaterial m = materials[min(material_ids[i], material_count - 1u)];
    float p = 0.0f;
    if ((m.flags & MAT_EMISSIVE) != 0u) {
        float3 e = (float3)(m.emissive[0], m.emissive[1], m.emissive[2]);
#ifdef MOTION_BLUR
        // The power at the shutter's opening (step 0) drives the choice of
        // triangle only; the pdf of a sample uses the area at its path's
        // time, so the estimate stays unbiased.
        MotionTime mt;
        mt.step = 0u;
        mt.frac = 0.0f;
        mt.at0 = 0u;
        mt.at1 = 0u;
#endif
        p = luminance(e) * pt_triangle_area(GEOM_ARGS(positions, mt), i);
        if ((m.flags & MAT_DOUBLE_SIDED) != 0u) p = p * 2.0f;
        if (!isfinite(p)) p = 0.0f;
    }
    power[i] = p;
}
