// Part of pathtrace.cl, after direct_light.h: one camera sample's results
// (PtSample), what its path carries from vertex to vertex (PtPath), and the
// steps of the path that pt_path strings together: the camera ray, the
// film's first-hit values, light found by the path (environment, emitters)
// and by next-event estimation, the light-path passes' bookkeeping, shadow
// catchers and holdouts, dielectric interfaces, and the BSDF sample that
// continues the path, with Russian roulette.
#ifndef SOUPRAY_PATH_SAMPLE_H
#define SOUPRAY_PATH_SAMPLE_H

#pragma OPENCL FP_CONTRACT OFF

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

// What a path carries from one vertex to the next.
typedef struct {
    Ray ray;
    float3 dir; // the ray's direction, unit length
    float3 beta; // throughput
    // The last scattering vertex's BSDF pdf, and whether it took a delta
    // lobe: light sampling cannot reach that direction, so an emitter found
    // along it counts in full (MIS weight 1).
    float prev_pdf;
    bool prev_delta;
    // The last scattering vertex and its shading normal: where the light
    // tree would have chosen an emitter the path finds (for MIS).
    float3 prev_p;
    float3 prev_n;
    uint depth; // scattering vertices so far
#ifdef HAS_TRANSMISSION
    // The volumes the path is in (media.h) and the innermost one's
    // attenuation coefficient (0: none).
    PtMedia media;
    int channel; // the colour channel carried alone (pt_dielectric_params)
    float3 sigma;
    // The distance from the last scattering vertex to this segment's start
    // (null crossings), for the pdf of light sampling an emitter found.
    float carried;
#endif
} PtPath;

inline PtPath pt_path_new(void) {
    PtPath p;
    p.beta = (float3)(1.0f);
    p.prev_pdf = 0.0f;
    p.prev_delta = false;
    p.prev_p = (float3)(0.0f);
    p.prev_n = (float3)(0.0f);
    p.depth = 0u;
#ifdef HAS_TRANSMISSION
    p.media = media_empty();
    p.channel = -1;
    p.sigma = (float3)(0.0f);
    p.carried = 0.0f;
#endif
    return p;
}

// Starts `ray` again from `org`, along its direction, unbounded.
inline void ray_restart(Ray* ray, float3 org) {
    ray->org[0] = org.x; ray->org[1] = org.y; ray->org[2] = org.z;
    ray->tmin = 0.0f;
    ray->tmax = INFINITY;
}

#ifdef FILM_LIGHT
// At the path's first scattering vertex, the sampled direction wi (BSDF
// value f of diffuse part fd and transmission part ft, pdf, from a delta
// lobe or not): the lobe weight f |cos| / pdf,
// whose mean is the lobes' albedo (the colour passes), and the shares of
// it the diffuse and transmission lobes gave. A delta lobe is glossy above
// the surface and transmission below.
inline void pt_first_lobes(PtSample* out, float3 wi, float3 f, float3 fd, float3 ft, float pdf,
                           bool delta) {
    if (delta) {
        out->share_transmit = (float3)(wi.z < 0.0f ? 1.0f : 0.0f);
    } else {
        out->share_diffuse = lobe_share(fd, f);
        out->share_transmit = lobe_share(ft, f);
    }
    float3 w = f * (fabs(wi.z) / pdf);
    if (isfinite(w.x) && isfinite(w.y) && isfinite(w.z)) out->weight = w;
}

// Adds `c`, a light sample's contribution at a vertex after `depth`
// scattering ones (where the BSDF is `f`, of diffuse part `fd` and
// transmission part `ft`), to the light-path passes: at the first vertex
// by its lobes there, later to the light found after it.
inline void light_pass_direct(PtSample* out, float3 f, float3 fd, float3 ft, float3 c,
                              uint depth) {
    if (depth != 0u) {
        out->after_indirect += c;
        return;
    }
    if (!(c.x > 0.0f || c.y > 0.0f || c.z > 0.0f)) return;
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
inline void light_sums_add(float3* light, const PtSample* r) {
    float3 zero = (float3)(0.0f);
    float3 dd = r->after_direct * r->share_diffuse, dt = r->after_direct * r->share_transmit;
    float3 id = r->after_indirect * r->share_diffuse, it = r->after_indirect * r->share_transmit;
    float3 wd = r->weight * r->share_diffuse, wt = r->weight * r->share_transmit;
    light[LIGHT_DIFFUSE] += r->first_diffuse + dd;
    light[LIGHT_DIFFUSE + 1u] += id;
    light[LIGHT_DIFFUSE + 2u] += wd;
    light[LIGHT_GLOSSY] += r->first_glossy + fmax((r->after_direct - dd) - dt, zero);
    light[LIGHT_GLOSSY + 1u] += fmax((r->after_indirect - id) - it, zero);
    light[LIGHT_GLOSSY + 2u] += fmax((r->weight - wd) - wt, zero);
    light[LIGHT_TRANSMISSION] += r->first_transmit + dt;
    light[LIGHT_TRANSMISSION + 1u] += it;
    light[LIGHT_TRANSMISSION + 2u] += wt;
    light[LIGHT_EMIT] += r->seen_emit;
    light[LIGHT_ENV] += r->seen_env;
}
#endif

// A sample that has found nothing yet; with FILM_LIGHT, the path's lobe
// split state cleared too.
inline PtSample pt_sample_new(PtScene* s) {
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
    s->shade_f = (float3)(0.0f);
    s->shade_diffuse = (float3)(0.0f);
    s->shade_transmit = (float3)(0.0f);
#endif
    return out;
}

// The camera ray of sample `rng` through pixel (px, py), its direction in
// `dir_out`: the pixel filter's offset, the motion-blurred camera and the
// lens.
inline Ray pt_camera_ray(PtScene* s, __global const PtCamera* cam, __global const float* filter,
                         uint px, uint py, SampleRng rng, float3* dir_out) {
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
    *dir_out = dir;
    return ray;
}

// What the film keeps of the surface the camera ray finds: coverage,
// depth, normal and albedo, and the mattes, vectors and geometry passes
// compiled in.
inline void pt_first_hit(PtSample* out, PtScene* s, Hit h, PtSurface sf, float travelled,
                         float3 albedo) {
    out->alpha = 1.0f;
    out->depth = travelled;
    out->normal = sf.ns;
    out->albedo = albedo;
#ifdef FILM_MATTES
    out->matte = s->triangle_mattes[h.prim] + 1u;
#endif
#ifdef FILM_VECTORS
    out->motion = pt_motion_vector(s, h.prim, h.u, h.v);
#endif
#ifdef FILM_GEOMETRY
    out->position = sf.p;
    out->uv = sf.at.uv.xy;
#endif
}

// Next-event estimation at a scattering vertex: every punctual light when
// the frame loops over them, then one light from the selection
// distribution; none where every lobe is a delta lobe (bsdf_eval is 0
// there), nor at the `last` vertex. Skipping draws no sample, and the
// sampler's dimensions are fixed per set, so the other sets are unchanged.
inline void pt_next_event(PtScene* s, PtSample* out, PtSurface sf, BsdfParams bp, float3 wo,
                          float3 t, float3 b, float3 above, float3 beta, SampleRng rng,
                          uint bounce, uint depth, bool last TEX_DECL) {
    bool only_delta = bsdf_only_delta(bp);
#ifdef FILM_LIGHT
    s->split_lobes = depth == 0u;
#endif
    if (!only_delta && !last && s->frame.light_loop != 0u) {
        for (uint i = 0u; i < s->frame.light_count; ++i) {
            float3 c = pt_punctual_direct(s, i, 1.0f, sf, bp, wo, t, b, above, beta, rng,
                                          bounce TEX_PASS);
            out->radiance += c;
#ifdef FILM_LIGHT
            light_pass_direct(out, s->shade_f, s->shade_diffuse, s->shade_transmit, c, depth);
#endif
        }
    }
    if (!only_delta && !last && s->frame.select_count > 0u) {
        float4 ul = rng_4d(rng, set_bounce(bounce, SET_LIGHT));
        uint pick = cdf_search(s->select_cdf, s->frame.select_count, ul.z);
        uint first = s->frame.light_loop != 0u ? 0u : s->frame.light_count;
        uint tree = s->frame.light_tree != 0u ? 1u : 0u;
        float3 c = (float3)(0.0f);
        if (pick < first) {
            float pmf = s->select_cdf[pick + 1u] - s->select_cdf[pick];
            c = pt_punctual_direct(s, pick, pmf, sf, bp, wo, t, b, above, beta, rng,
                                   bounce TEX_PASS);
        } else if (pick == first && tree != 0u) {
            // The light tree: one of its lights or emitters by importance
            // at sf.p, with the dimension the punctual lights leave unused
            // (an emitter's point takes the two after it).
            float pmf = s->select_cdf[pick + 1u] - s->select_cdf[pick];
            float tree_pmf;
            int leaf = light_tree_pick(s->light_nodes, sf.p, sf.ns, ul.x, &tree_pmf);
            if (leaf >= 0 && ((uint)leaf & LIGHT_NODE_EMITTER) != 0u) {
                uint prim = s->emit_prims[(uint)leaf & ~LIGHT_NODE_EMITTER];
                c = pt_emissive_triangle(s, prim, pmf * tree_pmf, ul.y, ul.w, sf, bp, wo, t, b,
                                         above, beta, rng, bounce TEX_PASS);
            } else if (leaf >= 0) {
                c = pt_punctual_direct(s, (uint)leaf, pmf * tree_pmf, sf, bp, wo, t, b, above,
                                       beta, rng, bounce TEX_PASS);
            }
        } else if (pick == first + tree && s->frame.emit_count > 0u &&
                   s->frame.emit_tree == 0u) {
            c = pt_emissive_direct(s, ul.x, ul.y, sf, bp, wo, t, b, above, beta, rng,
                                   bounce TEX_PASS);
        } else {
            c = pt_env_direct(s, ul.x, ul.y, sf, bp, wo, t, b, above, beta, rng,
                              bounce TEX_PASS);
        }
        out->radiance += c;
#ifdef FILM_LIGHT
        light_pass_direct(out, s->shade_f, s->shade_diffuse, s->shade_transmit, c, depth);
#endif
    }
}

// The environment seen along `dir` where the path escapes, weighed by MIS
// against light sampling (which can reach it) unless the last bounce was a
// delta lobe.
inline void pt_env_found(PtScene* s, PtSample* out, float3 dir, float3 beta, uint depth,
                         bool prev_delta, float prev_pdf) {
    float3 le = env_radiance(s->env, s->env_texels, dir);
    float w = 1.0f;
    if (depth > 0u && !prev_delta && s->frame.env_select_pmf > 0.0f) {
        float pl = s->frame.env_select_pmf *
                   env_pdf(s->env, s->env_marginal, s->env_conditional, dir);
        w = power_heuristic(prev_pdf, pl);
    }
    out->radiance += beta * le * w;
#ifdef FILM_LIGHT
    light_pass_found(out, beta * le * w, depth, true);
#endif
}

// An emitter the path finds at `reach` from its last scattering vertex,
// weighed by MIS as pt_env_found.
inline void pt_emitter_found(PtScene* s, PtSample* out, PtMaterial m, PtSurface sf, uint prim,
                             const PtPath* p, float reach TEX_DECL) {
    float3 le = pt_emission(m, sf.at TEX_PASS);
    float3 dir = p->dir, beta = p->beta;
    uint depth = p->depth;
    float w = 1.0f;
    // A black texel adds nothing whatever its weight: the weight's walk of
    // the light tree is skipped (most of a textured emitter is black).
    if (depth > 0u && !p->prev_delta && (le.x > 0.0f || le.y > 0.0f || le.z > 0.0f)) {
        float cos_l = dot(-dir, sf.ng);
        float pmf = pt_emitter_pmf(s, prim, p->prev_p, p->prev_n);
        w = power_heuristic(p->prev_pdf, pt_emissive_pdf(s, prim, pmf, reach, cos_l));
    }
    out->radiance += beta * le * w;
#ifdef FILM_LIGHT
    light_pass_found(out, beta * le * w, depth, false);
#endif
}

// Russian roulette with the path's random number `u`: false ends the path,
// true keeps it with its throughput raised to stay unbiased; `eta_scale`
// undoes refraction's radiance scaling in the survival probability. Applied from
// the sixth vertex on (after the fifth bounce's sample). Started at the fourth
// vertex it was the largest source of noise on the clay scan under a sky: a
// path ground -> mesh -> ground became 0 or 2x instead of 0.51, 3.2x the error
// of starting here for 0.9% fewer rays (BENCHMARKS.md); Mitsuba 3 starts at the
// same depth. A path survives with twice its throughput: roulette ends only
// paths below 1/2 and leaves the survivors at 1/2, not 1, which halves the
// weight it adds. Surviving with the throughput itself, the interior lit
// through a window had 1.6x the error of no roulette at all; twice it, 1.2x for
// 1.24x the rays (0.91x the error times time; 1.5x and 3x were worse, and no
// scene measured lost).
inline bool pt_roulette(float3* beta, float eta_scale, float u) {
    float q = fmin(2.0f * fmax(fmax(beta->x, beta->y), beta->z) * eta_scale, 1.0f);
    if (!(q > 0.0f)) return false;
    if (q < 1.0f) {
        if (u >= q) return false;
        *beta = *beta / q;
    }
    return true;
}

#ifdef FILM_CATCHER
// The camera ray's first surface `h`, when it is a shadow catcher or a
// holdout: a holdout cuts the frame (-1: nothing of the sample is kept); the
// ray sees through shadow catchers (a closed one has two sides to cross),
// measuring the light at the first, and goes on to what lies beyond (1:
// found, `h`, `travelled` and the ray updated; 0: nothing).
inline int pt_through_catchers(PtScene* s, PtSample* out, Ray* ray, float3 dir, SampleRng rng,
                               Hit* h, float* travelled, bool* blocked,
                               uint* crossings TEX_DECL) {
    bool found = true;
    for (uint k = 0u; found && k < MAX_CROSSINGS; ++k) {
        uint flags = s->triangle_flags[h->prim];
        if ((flags & TRIANGLE_HOLDOUT) != 0u) return -1;
        if ((flags & TRIANGLE_SHADOW_CATCHER) == 0u) break;
        float3 p = hit_point(SGEOM(s), h->prim, h->u, h->v);
        float3 ng = geometric_normal(SGEOM(s), h->prim);
        float3 facing = dot(dir, ng) > 0.0f ? -ng : ng;
        if (!out->catcher) {
            out->catcher = true;
            pt_catcher_light(s, p, facing, h->prim, rng, &out->catcher_lit,
                             &out->catcher_unshadowed TEX_PASS);
        }
        ray_restart(ray, offset_ray_origin_scaled(p, -facing, offset_scale(SGEOM(s), h->prim)));
        float before = *travelled;
        found = pt_find_surface(s, *ray, rng, 0u, 0u, h, travelled, blocked,
                                crossings TEX_PASS);
        *travelled += before;
    }
    return found ? 1 : 0;
}
#endif

#ifdef HAS_TRANSMISSION
// A dielectric interface the path meets: the indices on its two sides (the
// volume the path is in, and for a refracting surface the one beyond it,
// media.h) into the surface and the BSDF's parameters, and the colour
// channel a dispersive volume makes the path carry alone.
inline void pt_interface(PtScene* s, PtMaterialExt mx, uint mat, bool volume, PtMedia* media,
                         SampleRng rng, uint bounce, PtSurface* sf, int* channel, float3* beta,
                         BsdfParams* bp TEX_DECL) {
    uint inner = media_innermost(media);
    uint other = volume ? media_other(media, mat, sf->front) : inner;
#ifdef HAS_DISPERSION
    // KHR_materials_dispersion: at the first dispersive volume it meets, the
    // path picks one colour channel uniformly and carries it alone, three
    // times as strong (unbiased per channel), with that channel's indices
    // from here on. The light set's fourth number is unused by light
    // sampling.
    if (*channel < 0 && volume && mx.factor[F_DISPERSION] > 0.0f && mx.factor[F_TRANSMISSION] > 0.0f &&
        (s->frame.flags & FRAME_CLAY) == 0u) {
        float u = rng_4d(rng, set_bounce(bounce, SET_LIGHT)).w;
        *channel = min((int)(u * 3.0f), 2);
        float3 b = *beta;
        *beta = (float3)(*channel == 0 ? 3.0f * b.x : 0.0f, *channel == 1 ? 3.0f * b.y : 0.0f,
                         *channel == 2 ? 3.0f * b.z : 0.0f);
    }
#endif
    pt_dielectric_params(s, mx, volume, sf->front, pt_medium_ior(s, other, *channel), *channel,
                         sf->at, bp TEX_PASS);
    sf->medium_above = inner;
    sf->medium_below = volume && sf->front ? mat : other;
    sf->channel = *channel;
}
#endif

// The BSDF sample at a vertex that continues path `p` (above: the ray
// origin on the surface's front; sf.below its back), with Russian
// roulette; false ends the path. A volume's interface enters or leaves it.
// Always inline: with the light-path passes PoCL kept it as a call, and
// inlined the walker's frames with every pass trace in 0.98x the time (21
// paired rounds; the same image), without them in the same time.
#ifdef HAS_TRANSMISSION
#define SCATTER_VOLUME , volume, mat
#define SCATTER_VOLUME_DECL , bool volume, uint mat
#else
#define SCATTER_VOLUME
#define SCATTER_VOLUME_DECL
#endif
__attribute__((always_inline)) inline bool pt_scatter(PtScene* s, PtSample* out, PtPath* p, BsdfParams bp, float3 wo, float3 t,
                       float3 b, PtSurface sf, float3 above, SampleRng rng, uint bounce,
                       bool last, float reach SCATTER_VOLUME_DECL) {
    float3 wi, f;
    float pdf;
    bool delta;
    float4 ub = rng_4d(rng, set_bounce(bounce, SET_BSDF));
#ifdef FILM_LIGHT
    // The value's lobe parts come with it, for the first vertex's shares.
    float3 fd, ft;
    if (!bsdf_sample_parts(bp, wo, ub.z, ub.x, ub.y, &wi, &f, &pdf, &delta, &fd, &ft))
        return false;
#else
    if (!bsdf_sample(bp, wo, ub.z, ub.x, ub.y, &wi, &f, &pdf, &delta)) return false;
#endif
    float3 wi_w = to_world(wi, t, b, sf.ns);
    float wl = length(wi_w);
    wi_w = wi_w / wl;
#ifdef HAS_TRANSMISSION
    bool transmitted = wi.z < 0.0f;
    if (transmitted ? dot(wi_w, sf.ng) >= 0.0f : dot(wi_w, sf.ng) <= 0.0f) return false;
    p->beta = p->beta * f * (fabs(wi.z) / pdf);
    if (transmitted) {
        above = sf.below;
        if (volume) {
            if (sf.front)
                media_enter(&p->media, mat);
            else
                media_leave(&p->media, mat);
            p->sigma = pt_medium_sigma(s, media_innermost(&p->media));
        }
    }
    // Smooth thin glass's straight-through lobe is a null crossing: the
    // shadow rays of the vertex before it cross such glass
    // (pt_shadow_transmittance), so a light found beyond it is weighed by
    // MIS against that vertex's light sample (its pdf, its distance), not
    // counted in full as after a delta bounce.
    bool scattered = !(delta && transmitted && bp.thin != 0.0f);
    if (last && scattered) return false;
    p->carried = scattered ? 0.0f : reach;
    if (!scattered && bounce - p->depth >= MAX_CROSSINGS) return false;
#else
    if (dot(wi_w, sf.ng) <= 0.0f) return false;
    p->beta = p->beta * f * (wi.z / pdf);
    bool scattered = true;
#endif
    if (scattered) {
#ifdef FILM_LIGHT
        if (p->depth == 0u) pt_first_lobes(out, wi, f, fd, ft, pdf, delta);
#endif
        p->prev_pdf = pdf;
        p->prev_delta = delta;
        p->prev_p = sf.p;
        p->prev_n = sf.ns;
#ifdef HAS_TRANSMISSION
        // Each refraction scales radiance by 1 / eta^2, which roulette must
        // not see, or a path inside glass (throughput 1 / 1.5^2) would be
        // cut more than half the time and come back 2.25x bright (pbrt-v4's
        // etaScale). The ratios telescope: the scale is the innermost
        // medium's index squared, the camera being in air.
        float n = pt_medium_ior(s, media_innermost(&p->media), p->channel);
        float eta_scale = n * n;
#else
        float eta_scale = 1.0f;
#endif
        if (p->depth >= RR_FIRST_BOUNCE && !pt_roulette(&p->beta, eta_scale, ub.w)) return false;
        p->depth += 1u;
    }
    p->dir = wi_w;
    p->ray.dir[0] = wi_w.x; p->ray.dir[1] = wi_w.y; p->ray.dir[2] = wi_w.z;
    ray_restart(&p->ray, above);
    return true;
}

#endif
