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
// the stack traversal of the 4-wide layout (8-wide with WIDE_WIDTH 8),
// HAS_TEXTURES when some material is textured, MOTION_BLUR for frames that move within the
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

// The leaf functions inlined into the traversal (trace_common.h).
#define LEAF_INLINE __attribute__((always_inline))
#include "trace_common.h"
#include "leaf_gather.h"
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

#include "scene_view.h"
#include "direct_light.h"
#include "path_sample.h"

// One camera sample through pixel (px, py): its path from the camera, one
// scattering vertex per bounce, and what the film keeps of it.
inline PtSample pt_path(PtScene* s, __global const PtCamera* cam, __global const float* filter,
                        uint px, uint py, uint sample TEX_DECL) {
    PtSample out = pt_sample_new(s);
    uint pixel = py * s->frame.width + px;
    SampleRng rng = rng_for_sample(s->frame.seed_lo, s->frame.seed_hi, s->frame.frame_lo,
                                   s->frame.frame_hi, pixel, sample);
    PtPath p = pt_path_new();
    p.ray = pt_camera_ray(s, cam, filter, px, py, rng, &p.dir);
    uint max_depth = s->frame.max_depth;
    // `bounce` counts every surface the path meets, null crossings (false
    // interfaces, thin glass's straight-through lobe) included; p.depth
    // only the scattering vertices.
    for (uint bounce = 0u;; ++bounce) {
        Hit h;
        float travelled;
        bool blocked;
        uint crossings = 0u;
        bool found = pt_find_surface(s, p.ray, rng, bounce, 0u, &h, &travelled, &blocked,
                                     &crossings TEX_PASS);
#ifdef FILM_CATCHER
        if (bounce == 0u && found) {
            int seen = pt_through_catchers(s, &out, &p.ray, p.dir, rng, &h, &travelled,
                                           &blocked, &crossings TEX_PASS);
            if (seen < 0) return out;
            found = seen > 0;
        }
#endif
#ifdef HAS_TRANSMISSION
        p.beta = p.beta * pt_attenuation(p.sigma, found ? travelled : INFINITY);
        float reach = p.carried + travelled;
#else
        float reach = travelled;
#endif
        if (!found) {
#ifdef FILM_TRANSPARENT
            // --transparent: the environment the camera ray sees directly
            // (through cut-outs too) is left out; alpha is 0 there.
            if (bounce == 0u) break;
#endif
            if (!blocked && s->env.kind != ENV_NONE)
                pt_env_found(s, &out, p.dir, p.beta, p.depth, p.prev_delta, p.prev_pdf);
            break;
        }
        PtMaterial m = pt_material(s, h.prim);
        PtSurface sf = pt_surface(s, m, h, p.dir TEX_PASS);
#ifdef HAS_MATERIAL_EXT
        uint mat = pt_material_index(s, h.prim);
        PtMaterialExt mx = s->material_exts[mat];
#endif
#ifdef HAS_TRANSMISSION
        bool volume = mx.volume != 0.0f;
        if (volume && !sf.front && media_false_interface(&p.media, mat)) {
            // A false interface (media.h): cross it unchanged.
            media_leave(&p.media, mat);
            p.sigma = pt_medium_sigma(s, media_innermost(&p.media));
            p.carried = reach;
            if (bounce - p.depth >= MAX_CROSSINGS) break;
            ray_restart(&p.ray,
                        offset_ray_origin_scaled(sf.p, -sf.ng, offset_scale(SGEOM(s), h.prim)));
            continue;
        }
#endif
        float3 albedo;
        BsdfParams bp = pt_bsdf_params(s, m, sf.at, &albedo TEX_PASS);
        if (bounce == 0u) pt_first_hit(&out, s, h, sf, travelled, albedo);
        // A single-sided emitter emits from its front only (the light
        // sampler's pdf is 0 behind it too).
        if ((m.flags & MAT_EMISSIVE) != 0u && (sf.front || (m.flags & MAT_DOUBLE_SIDED) != 0u))
            pt_emitter_found(s, &out, m, sf, h.prim, &p, reach TEX_PASS);
#ifdef HAS_UNLIT
        if ((m.flags & MAT_UNLIT) != 0u && (s->frame.flags & FRAME_CLAY) == 0u) {
            out.radiance += p.beta * albedo;
#ifdef FILM_LIGHT
            light_pass_found(&out, p.beta * albedo, p.depth, false);
#endif
            break;
        }
#endif
#ifdef HAS_TRANSMISSION
        // At the depth limit only thin glass's straight-through lobe may
        // go on (a null crossing, which the vertex before counted on).
        bool last = p.depth >= max_depth;
        if (last && !(mx.volume == 0.0f && mx.factor[F_TRANSMISSION] > 0.0f)) break;
#else
        bool last = false;
        if (p.depth >= max_depth) break;
#endif

        float3 wo_w = -p.dir;
        float3 t, b;
        onb(sf.ns, &t, &b);
        float3 wo = to_local(wo_w, t, b, sf.ns);
        float3 above = offset_ray_origin_scaled(sf.p, sf.ng, offset_scale(SGEOM(s), h.prim));
#ifdef HAS_MATERIAL_EXT
        PtMaterialInputs inputs = pt_material_inputs(mx, sf.at TEX_PASS);
        bp.in = &inputs;
#endif
#ifdef HAS_TRANSMISSION
        sf.below = offset_ray_origin_scaled(sf.p, -sf.ng, offset_scale(SGEOM(s), h.prim));
        pt_interface(s, mx, mat, volume, &p.media, rng, bounce, &sf, &p.channel, &p.beta,
                     &bp TEX_PASS);
#endif
#ifdef HAS_ANISOTROPY
        if (pt_anisotropy_frame(s, sf, h.prim, bp, &t, &b)) wo = to_local(wo_w, t, b, sf.ns);
#endif
#ifdef HAS_LAYERS
        pt_layer_params(s, mx, sf, wo_w, t, b, &bp TEX_PASS);
#endif

        pt_next_event(s, &out, sf, bp, wo, t, b, above, p.beta, rng, bounce, p.depth,
                      last TEX_PASS);
        if (!pt_scatter(s, &out, &p, bp, wo, t, b, sf, above, rng, bounce, last,
                        reach SCATTER_VOLUME))
            break;
    }
    return out;
}

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

// One pixel's running sums (film::resolve reads them): loaded before the
// pixel's samples of a pass, added to per sample, stored after.
typedef struct {
    float4 color;
    float4 nrm;
    float4 alb;
    float4 aux;
#ifdef FILM_VECTORS
    float4 motion;
#endif
#ifdef FILM_GEOMETRY
    float4 geometry_p;
    float4 geometry_uv;
#endif
#ifdef FILM_CATCHER
    float4 catcher_lit;
    float4 catcher_unshadowed;
    float4 catcher_behind;
#endif
#ifdef FILM_MATTES
    uint2 mattes[MATTE_SLOTS];
#endif
#ifdef FILM_LIGHT
    float3 light[LIGHT_PASSES];
#endif
} PtPixelSums;

// Adds one sample to a pixel's sums. The sample comes by pointer: PoCL
// keeps this function a call, and by value the sample (288 bytes with
// every pass) would be copied (`rep movsb`) for every sample.
inline void pixel_sums_add(PtPixelSums* p, const PtSample* r) {
    bool finite = isfinite(r->radiance.x) && isfinite(r->radiance.y) &&
                  isfinite(r->radiance.z) && isfinite(r->depth) && isfinite(r->normal.x) &&
                  isfinite(r->normal.y) && isfinite(r->normal.z);
    if (!finite) {
        // Counted and dropped as a whole, as the film does.
        p->aux.z += 1.0f;
        return;
    }
    p->color += (float4)(r->radiance, r->alpha);
    p->nrm += (float4)(r->normal, 0.0f);
    p->alb += (float4)(r->albedo, 0.0f);
    if (r->alpha > 0.0f) {
        p->aux.x += r->depth;
        p->aux.y += 1.0f;
    }
#ifdef FILM_MATTES
    if (r->matte != 0u) matte_count(p->mattes, r->matte);
#endif
#ifdef FILM_LIGHT
    light_sums_add(p->light, r);
#endif
#ifdef FILM_GEOMETRY
    // Summed over the samples that hit, as depth is (film::resolve).
    if (r->alpha > 0.0f) {
        p->geometry_p += (float4)(r->position, 0.0f);
        p->geometry_uv += (float4)(r->uv, 0.0f, 0.0f);
    }
#endif
#ifdef FILM_CATCHER
    if (r->catcher && isfinite(r->catcher_lit.x) && isfinite(r->catcher_lit.y) &&
        isfinite(r->catcher_lit.z) && isfinite(r->catcher_unshadowed.x) &&
        isfinite(r->catcher_unshadowed.y) && isfinite(r->catcher_unshadowed.z)) {
        p->catcher_lit += (float4)(r->catcher_lit, 1.0f);
        p->catcher_unshadowed += (float4)(r->catcher_unshadowed, 0.0f);
        p->catcher_behind += (float4)(r->radiance, r->alpha);
    }
#endif
#ifdef FILM_VECTORS
    // Summed over the samples that hit, as depth is (film::resolve).
    if (r->alpha > 0.0f && isfinite(r->motion.x) && isfinite(r->motion.y) &&
        isfinite(r->motion.z) && isfinite(r->motion.w)) {
        p->motion += r->motion;
    }
#endif
}

// One sample pass over one tile: samples [sample_begin, sample_end) of
// every pixel of the tile, added to the pixel's sums in sample order.
// accum_color: rgb, alpha; accum_normal / accum_albedo: rgb; accum_aux:
// depth sum over hits, hit count, dropped samples, samples taken;
// accum_snapshots: two per pixel, the running sums at the last two powers
// of two (pt_noise_estimate). With `adaptive`, pixels whose `active` flag is 0
// have converged and take no more samples; `listed` > 0 launches over the
// first `listed` entries of `pixel_list` (the pixels still active at the
// last check) instead of the tile.
__kernel void pt_render(__global const BvhNode* nodes, __global const PtWideNode* wnodes,
                        __global const StacklessNode* snodes,
                        uint snode_count, __global const uint* prim_ids,
                        __global const float4* leaf_tris, __global const float* positions, __global const float* normals,
                        __global const float* uvs, __global const float* uvs1,
                        __global const float* colors, __global const uint* material_ids,
                        __global const PtMaterial* materials, __global const PtLight* lights,
                        __global const uint* emit_prims, __global const float* emit_cdf,
                        __global const float* emit_pmf, __global const float* select_cdf,
                        __global const PtLightNode* light_nodes,
                        __global const uint* emit_trails, __global const PtEnv* env,
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
    s.leaf_tris = leaf_tris;
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
    s.light_nodes = light_nodes;
    s.emit_trails = emit_trails;
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
    PtPixelSums p;
    p.color = accum_color[i];
    p.nrm = accum_normal[i];
    p.alb = accum_albedo[i];
    p.aux = accum_aux[i];
#ifdef FILM_VECTORS
    p.motion = accum_motion[i];
#endif
#ifdef FILM_GEOMETRY
    p.geometry_p = accum_geometry[2u * i];
    p.geometry_uv = accum_geometry[2u * i + 1u];
#endif
#ifdef FILM_CATCHER
    p.catcher_lit = accum_catcher[3u * i];
    p.catcher_unshadowed = accum_catcher[3u * i + 1u];
    p.catcher_behind = accum_catcher[3u * i + 2u];
#endif
#ifdef FILM_MATTES
    for (uint j = 0u; j < MATTE_SLOTS; ++j) p.mattes[j] = matte_slots[i * MATTE_SLOTS + j];
#endif
#ifdef FILM_LIGHT
    __global float* light_at = accum_light + (size_t)i * (3u * LIGHT_PASSES);
    for (uint j = 0u; j < LIGHT_PASSES; ++j) p.light[j] = vload3(j, light_at);
#endif
    for (uint k = sample_begin; k < sample_end; ++k) {
        if (k != 0u && (k & (k - 1u)) == 0u) {
            if (((31u - clz(k)) & 1u) == 0u) {
                snap0 = p.color;
            } else {
                snap1 = p.color;
            }
        }
        PtSample r = pt_path(&s, camera, filter, px, py, k TEX_PASS);
        pixel_sums_add(&p, &r);
    }
    p.aux.w += (float)(sample_end - sample_begin);
    accum_color[i] = p.color;
    accum_snapshots[2u * i] = snap0;
    accum_snapshots[2u * i + 1u] = snap1;
    accum_normal[i] = p.nrm;
    accum_albedo[i] = p.alb;
    accum_aux[i] = p.aux;
    ray_counts[i] += s.rays;
#ifdef FILM_MATTES
    for (uint j = 0u; j < MATTE_SLOTS; ++j) matte_slots[i * MATTE_SLOTS + j] = p.mattes[j];
#endif
#ifdef FILM_LIGHT
    for (uint j = 0u; j < LIGHT_PASSES; ++j) vstore3(p.light[j], j, light_at);
#endif
#ifdef FILM_VECTORS
    accum_motion[i] = p.motion;
#endif
#ifdef FILM_GEOMETRY
    accum_geometry[2u * i] = p.geometry_p;
    accum_geometry[2u * i + 1u] = p.geometry_uv;
#endif
#ifdef FILM_CATCHER
    accum_catcher[3u * i] = p.catcher_lit;
    accum_catcher[3u * i + 1u] = p.catcher_unshadowed;
    accum_catcher[3u * i + 2u] = p.catcher_behind;
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

#ifdef HAS_TEXTURES
// For each triangle, what its emitted power takes from its material's
// emissive texture: the texture's mean over the triangle
// (texture_triangle_mean), each channel no lower than EMIT_TEXTURE_FLOOR;
// 1 without one. Only the choice of triangle uses it, so a mean off by
// any factor costs noise, never bias; the floor keeps every part of a
// textured emitter within reach of next-event estimation should its
// samples all fall on black.
#define EMIT_TEXTURE_FLOOR (1.0f / 64.0f)
__kernel void pt_emissive_texture_factor(__global const float* uvs, __global const float* uvs1,
                                         uint frame_flags, __global const uint* material_ids,
                                         __global const PtMaterial* materials,
                                         uint material_count, uint n,
                                         __global float4* factor TEX_DECL) {
    uint i = get_global_id(0);
    if (i >= n) return;
    PtMaterial m = materials[min(material_ids[i], material_count - 1u)];
    float4 f = (float4)(1.0f);
    if ((m.flags & MAT_EMISSIVE) != 0u && m.emissive_tex >= 0) {
        float2 t0[3], t1[3];
        for (uint k = 0u; k < 3u; ++k) {
            t0[k] = (frame_flags & FRAME_UVS) != 0u
                        ? (float2)(uvs[6u * i + 2u * k], uvs[6u * i + 2u * k + 1u])
                        : (float2)(0.0f);
            t1[k] = (frame_flags & FRAME_UVS1) != 0u
                        ? (float2)(uvs1[6u * i + 2u * k], uvs1[6u * i + 2u * k + 1u])
                        : (float2)(0.0f);
        }
        f = texture_triangle_mean(TEXTURE_ARGS, tex_bindings[m.emissive_tex], t0[0], t0[1],
                                  t0[2], t1[0], t1[1], t1[2]);
        f = fmax(f, (float4)(EMIT_TEXTURE_FLOOR));
    }
    factor[i] = f;
}
#endif

// Each word of `current` against `kept`, which then holds it: `same` (1 on
// entry) becomes 0 at any difference. The host keeps the emissive texture
// factors from frame to frame while their inputs stay the same bit for bit.
__kernel void pt_compare_and_keep(__global const uint* current, __global uint* kept, uint n,
                                  __global volatile uint* same) {
    uint i = get_global_id(0);
    if (i >= n) return;
    uint w = current[i];
    if (kept[i] != w) {
        kept[i] = w;
        atomic_and(same, 0u);
    }
}

// Each triangle's emitted power up to a constant factor (luminance of the
// emissive factor, times the texture factor when `has_factor`
// (pt_emissive_texture_factor), times the area; twice that when
// double-sided), 0 for triangles whose material does not emit. The host
// turns it into the emissive triangles' sampling distribution.
__kernel void pt_emissive_power(__global const float* positions,
                                __global const uint* material_ids,
                                __global const PtMaterial* materials, uint material_count,
                                uint n, __global const float4* factor, uint has_factor,
                                __global float* power) {
    uint i = get_global_id(0);
    if (i >= n) return;
    PtMaterial m = materials[min(material_ids[i], material_count - 1u)];
    float p = 0.0f;
    if ((m.flags & MAT_EMISSIVE) != 0u) {
        float3 e = (float3)(m.emissive[0], m.emissive[1], m.emissive[2]);
        if (has_factor != 0u) e = e * factor[i].xyz;
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
