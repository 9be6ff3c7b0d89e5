// Part of pathtrace.cl, which includes it after its own defines: the
// path tracer's view of the frame's scene (PtScene, gathered once per
// work-item, and the kernel arguments each option adds), and what a ray
// finds there: the surface, its material, its attributes and textures,
// and its BSDF's parameters.
#ifndef SOUPRAY_SCENE_VIEW_H
#define SOUPRAY_SCENE_VIEW_H

#pragma OPENCL FP_CONTRACT OFF

// The wide layout's node: 8-wide with WIDE_WIDTH = 8, else 4-wide.
#if defined(TRAVERSAL_WIDE) && WIDE_WIDTH == 8
typedef Wide8Node PtWideNode;
#define PT_TRACE_CLOSEST_WIDE trace_closest_wide8_bvh
#define PT_TRACE_ANY_WIDE trace_any_wide8_bvh
#else
typedef WideNode PtWideNode;
#define PT_TRACE_CLOSEST_WIDE trace_closest_wide_bvh
#define PT_TRACE_ANY_WIDE trace_any_wide_bvh
#endif

// Everything a path needs, gathered once per work-item.
typedef struct {
    const __global BvhNode* nodes;
    const __global PtWideNode* wnodes;
    const __global StacklessNode* snodes;
    uint snode_count;
    // The binary and stackless traversals: the tree's primitive-index
    // array. The wide ones: its triangles in leaf order, and laid out for
    // the four-lane test (`leaf_gather`).
    const __global uint* prim_ids;
    const __global float4* leaf_tris;
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
    const __global PtLightNode* light_nodes;
    const __global uint* emit_trails;
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
    const __global PtVectorCamera* vector_cameras;
    uint vector_triangles;
#endif
#ifdef FILM_LIGHT
    // Light-path passes: when `split_lobes` (at a path's first scattering
    // vertex), pt_shade_light leaves here the BSDF's value in the direction
    // of its last light sample and the value's diffuse and transmission
    // parts (bsdf_eval_parts), for light_pass_direct to split.
    bool split_lobes;
    float3 shade_f;
    float3 shade_diffuse;
    float3 shade_transmit;
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
    __global const PtVectorCamera* vector_cameras, uint vector_triangles, __global float4* accum_motion
#define VECTOR_CLEAR_DECL , __global float4* accum_motion

// Where world point `p` lands on camera `c`'s image, in pixels from the
// bottom-left corner (x right, y up, as Blender's and Nuke's vectors
// count); false behind a perspective camera. One division: the axes come
// scaled (Rust twin: trace::vectors::project, which says how).
inline bool pt_project(PtVectorCamera c, float3 p, float2* at) {
    float3 d = p - (float3)(c.origin[0], c.origin[1], c.origin[2]);
    float x = dot(d, (float3)(c.to_x[0], c.to_x[1], c.to_x[2]));
    float y = dot(d, (float3)(c.to_y[0], c.to_y[1], c.to_y[2]));
    float2 centre = (float2)(c.centre[0], c.centre[1]);
    if (c.ortho != 0u) {
        *at = (float2)(x, y) + centre;
        return true;
    }
    float z = dot(d, (float3)(c.to_z[0], c.to_z[1], c.to_z[2]));
    if (!(z > 0.0f)) return false;
    float inv = 1.0f / z;
    *at = (float2)(x * inv, y * inv) + centre;
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
    float2 before, now, after;
    bool seen = pt_project(s->vector_cameras[0], pt_vector_point(s, 0u, prim, u, v), &before);
    seen = seen && pt_project(s->vector_cameras[1], pt_vector_point(s, 1u, prim, u, v), &now);
    seen = seen && pt_project(s->vector_cameras[2], pt_vector_point(s, 2u, prim, u, v), &after);
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
    return PT_TRACE_CLOSEST_WIDE(s->wnodes, s->prim_ids, s->leaf_tris, SGEOM(s), ray);
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
    return media_channel_ior(mx.factor[F_IOR], mx.factor[F_DISPERSION], channel);
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
    return PT_TRACE_ANY_WIDE(s->wnodes, s->prim_ids, s->leaf_tris, SGEOM(s), r);
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

// The probability that next-event estimation at `p` (normal `nrm`)
// chooses emissive triangle `prim`, selection included: through the light
// tree along the triangle's trail when the emitters are in it, else by
// power.
inline float pt_emitter_pmf(const PtScene* s, uint prim, float3 p, float3 nrm) {
    float pmf = s->emit_pmf[prim];
    if (!(pmf > 0.0f)) return 0.0f;
    if (s->frame.emit_tree != 0u)
        return s->frame.emit_select_pmf * light_tree_pmf(s->light_nodes, p, nrm, s->emit_trails[prim]);
    return pmf * s->frame.emit_select_pmf;
}

// The light-sampling pdf (solid angle) of reaching emissive triangle `prim`,
// chosen with probability `pmf`, at distance `dist` with cosine `cos_l`
// there.
inline float pt_emissive_pdf(const PtScene* s, uint prim, float pmf, float dist, float cos_l) {
    if (!(pmf > 0.0f) || !(cos_l > 0.0f)) return 0.0f;
    float area = pt_triangle_area(SGEOM(s), prim);
    return (pmf * (dist * dist)) / (area * cos_l);
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

#ifdef HAS_MATERIAL_EXT
// The extension factors of material `mx` at a point of attributes `at`,
// each texture that scales one applied (generated from the material
// tables into pt_types.h).
inline PtMaterialInputs pt_material_inputs(PtMaterialExt mx, PtAttrs at TEX_DECL) {
    PtMaterialInputs v;
    PT_MATERIAL_FACTORS(v, mx);
    PT_MATERIAL_TEXTURES(v, mx, at);
    return v;
}
#endif

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
// `wo_w`, in the shading frame (t, b, sf.ns) (clay has neither), from the
// textured factors in bp->in. The coat's normal is the unmapped
// interpolated normal, or clearcoatNormalTexture applied to it.
inline void pt_layer_params(const PtScene* s, PtMaterialExt mx, PtSurface sf, float3 wo_w,
                            float3 t, float3 b, BsdfParams* bp TEX_DECL) {
    bool layered = (s->frame.flags & FRAME_CLAY) == 0u;
#ifdef HAS_CLEARCOAT
    float3 nc = sf.n_unmapped;
#ifdef HAS_TEXTURES
    if (layered && mx.tex[TEX_CLEARCOAT_NORMAL] >= 0 && (s->frame.flags & FRAME_UVS) != 0u) {
        nc = pt_normal_map(s, mx.tex[TEX_CLEARCOAT_NORMAL], bp->in->clearcoat_normal_texture_scale, sf.prim,
                           sf.front ? nc : -nc, sf.front, sf.at TEX_PASS);
        nc = pt_facing(nc, wo_w, sf.ng);
    }
#endif
    bp->clearcoat = layered ? bp->in->clearcoat : 0.0f;
    bp->coat_alpha = ggx_alpha(bp->in->clearcoat_roughness);
    bp->coat_n = (float3)(0.0f, 0.0f, 1.0f);
    if (layered && (nc.x != sf.ns.x || nc.y != sf.ns.y || nc.z != sf.ns.z))
        bp->coat_n = normalize(to_local(nc, t, b, sf.ns));
#endif
#ifdef HAS_SHEEN
    bp->sheen_color = layered ? bp->in->sheen_color : (float3)(0.0f);
#endif
}
#endif

#ifdef HAS_TRANSMISSION
// The dielectric extensions' parameters at a surface of extension `mx`
// (`volume`: refracting, seen from its front or back) with index
// `n_other` on the surface's other side (for thin-walled surfaces: the
// volume they are in). F0 comes from the relative index ior / n_other
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
        bp->in->diffuse_roughness = 0.0f;
        return;
    }
    float3 specular_color = bp->in->specular_color;
    float specular = bp->in->specular;
    float transmission = bp->in->transmission;
#ifdef HAS_IRIDESCENCE
    // Without a thickness texture the film is the range's maximum thick.
    float iridescence = bp->in->iridescence;
    float thickness = mx.factor[F_IRIDESCENCE_THICKNESS_MAXIMUM];
#endif
#ifdef HAS_DIFFUSE_TRANSMISSION
    float diffuse_transmission = bp->in->diffuse_transmission;
    float3 diffuse_transmission_color = bp->in->diffuse_transmission_color;
#endif
#if defined(HAS_TEXTURES) && defined(HAS_IRIDESCENCE)
    // The film's thickness between its minimum and maximum by G (the
    // textures that scale a factor are in bp->in already).
    if (mx.tex[TEX_IRIDESCENCE_THICKNESS] >= 0) {
        float g = pt_texture(mx.tex[TEX_IRIDESCENCE_THICKNESS], at TEX_PASS).y;
        thickness = mx.factor[F_IRIDESCENCE_THICKNESS_MINIMUM] +
                    (mx.factor[F_IRIDESCENCE_THICKNESS_MAXIMUM] - mx.factor[F_IRIDESCENCE_THICKNESS_MINIMUM]) * g;
    }
#endif
    // Dispersion is the volume's: a thin-walled surface keeps its index.
    float ior = volume ? media_channel_ior(mx.factor[F_IOR], mx.factor[F_DISPERSION], channel) : mx.factor[F_IOR];
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
    bp->iridescence_ior = mx.factor[F_IRIDESCENCE_IOR];
    bp->iridescence_thickness = thickness;
#endif
#ifdef HAS_ANISOTROPY
    // KHR_materials_anisotropy: the direction (1, 0) in tangent space, or
    // anisotropyTexture's RG mapped to -1..1 (its B scales the strength),
    // turned counter-clockwise by anisotropyRotation. A texel of no
    // direction (RG 0.5) leaves the lobe isotropic.
    float strength = mx.factor[F_ANISOTROPY_STRENGTH];
    float2 dir = (float2)(1.0f, 0.0f);
#ifdef HAS_TEXTURES
    if (mx.tex[TEX_ANISOTROPY] >= 0) {
        float4 a = pt_texture(mx.tex[TEX_ANISOTROPY], at TEX_PASS);
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
#endif // HAS_TRANSMISSION

#endif
