// Part of pathtrace.cl, after scene_view.h: light sampling at a path's
// vertex (next-event estimation over punctual lights, emissive triangles
// and the environment, with the shadow rays that cross thin glass), and
// the light a shadow catcher receives.
#ifndef SOUPRAY_DIRECT_LIGHT_H
#define SOUPRAY_DIRECT_LIGHT_H

#pragma OPENCL FP_CONTRACT OFF

#ifdef HAS_TRANSMISSION
// Whether a shadow ray may cross `prim` (material `m`): thin-walled,
// transmissive, and smooth unless a texture may lower its roughness
// (pt_shadow_transmittance decides at the point). The roughness factor
// first: the extension is read only where it can matter.
inline bool pt_maybe_clear(const PtScene* s, PtMaterial m, uint prim) {
    if ((s->frame.flags & FRAME_CLAY) != 0u ||
        !(ggx_smooth(ggx_alpha(m.roughness)) || m.metallic_roughness_tex >= 0))
        return false;
    PtMaterialExt mx = pt_material_ext(s, prim);
    return mx.volume == 0.0f && mx.factor[F_TRANSMISSION] > 0.0f;
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
        PtMaterialInputs inputs = pt_material_inputs(mx, sf.at TEX_PASS);
        bp.in = &inputs;
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
#ifdef FILM_LIGHT
    float3 fd, ft;
    float3 f = s->split_lobes ? bsdf_eval_parts(bp, wo, wi, &fd, &ft) : bsdf_eval(bp, wo, wi);
#else
    float3 f = bsdf_eval(bp, wo, wi);
#endif
    if (!(f.x > 0.0f || f.y > 0.0f || f.z > 0.0f)) return (float3)(0.0f);
#ifdef FILM_LIGHT
    if (s->split_lobes) {
        s->shade_f = f;
        s->shade_diffuse = fd;
        s->shade_transmit = ft;
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

// A point on emissive triangle `prim`, chosen with probability `pmf`
// (selection included), at the uniforms `u1`, `u2`.
inline float3 pt_emissive_triangle(PtScene* s, uint prim, float pmf, float u1, float u2,
                                   PtSurface sf, BsdfParams bp, float3 wo, float3 t, float3 b,
                                   float3 above, float3 beta, SampleRng rng,
                                   uint bounce TEX_DECL) {
    float2 bc = sample_triangle(u1, u2);
    float3 q = hit_point(SGEOM(s), prim, bc.x, bc.y);
    float3 to = q - sf.p;
    float d = sqrt(dot(to, to));
    if (!(d > 0.0f)) return (float3)(0.0f);
    float3 wi_w = to / d;
    PtMaterial lm = pt_material(s, prim);
    float3 nl = geometric_normal(SGEOM(s), prim);
    float cos_l = -dot(wi_w, nl);
    if ((lm.flags & MAT_DOUBLE_SIDED) != 0u) cos_l = fabs(cos_l);
    float pdf = pt_emissive_pdf(s, prim, pmf, d, cos_l);
    if (!(pdf > 0.0f)) return (float3)(0.0f);
    PtAttrs luv = pt_attrs(s, prim, bc.x, bc.y);
    float3 contrib = pt_emission(lm, luv TEX_PASS) / pdf;
    // Stop just short of the emitter itself.
    return pt_shade_light(s, sf, bp, wo, t, b, above, beta, wi_w, contrib, pdf, q - above,
                          1.0f - 1.0e-4f, rng, bounce TEX_PASS);
}

// A point on an emissive triangle chosen by power: `u1` picks the triangle
// and, rescaled, places the point with `u2`.
inline float3 pt_emissive_direct(PtScene* s, float u1, float u2, PtSurface sf, BsdfParams bp,
                                 float3 wo, float3 t, float3 b, float3 above, float3 beta,
                                 SampleRng rng, uint bounce TEX_DECL) {
    uint k = cdf_search(s->emit_cdf, s->frame.emit_count, u1);
    float c0 = s->emit_cdf[k], c1 = s->emit_cdf[k + 1u];
    float ur = (u1 - c0) / (c1 - c0);
    uint prim = s->emit_prims[k];
    float pmf = s->emit_pmf[prim] * s->frame.emit_select_pmf;
    return pt_emissive_triangle(s, prim, pmf, ur, u2, sf, bp, wo, t, b, above, beta, rng,
                                bounce TEX_PASS);
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

#endif
