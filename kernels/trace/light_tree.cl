// The light tree's build, each frame on the device beside the scene's tree
// (src/trace/light_tree/mod.rs: `build` is the plain Rust reference, step
// for step; src/trace/light_tree/device.rs launches these):
//   lt_leaves   one leaf per emitter and light: its bounds over the motion
//               steps (power 0 for one that sends nothing);
//   lt_bounds   partial boxes of the emitters and of the leaves' centres,
//               which the host folds into the Morton grid;
//   lt_keys     each leaf's Morton code and index, one 64-bit key;
//   lt_sort     one bitonic merge step over the keys;
//   lt_place    each leaf into its heap slot, each emitter's trail;
//   lt_refit    one level of inner nodes from their children.
#pragma OPENCL FP_CONTRACT OFF

#include "sampling.h"
#include "pt_types.h"

// pbrt-v4's DirectionCone::Union, `a` turned towards `b` by Rodrigues'
// formula (`cone_union`).
inline float3 lt_cone_union(float3 a, float cos_a, float3 b, float cos_b, float* cos_out) {
    float theta_a = acos(clamp(cos_a, -1.0f, 1.0f));
    float theta_b = acos(clamp(cos_b, -1.0f, 1.0f));
    float theta_d = acos(clamp(dot(a, b), -1.0f, 1.0f));
    if (fmin(theta_d + theta_b, PT_PI) <= theta_a) {
        *cos_out = cos_a;
        return a;
    }
    if (fmin(theta_d + theta_a, PT_PI) <= theta_b) {
        *cos_out = cos_b;
        return b;
    }
    float theta_o = 0.5f * (theta_a + theta_d + theta_b);
    if (theta_o >= PT_PI) {
        *cos_out = -1.0f;
        return (float3)(0.0f, 0.0f, 1.0f);
    }
    // Axes parallel to rounding (the same emitter at two motion steps):
    // the cone around `a`, or every direction where they are opposite.
    float3 axis = cross(a, b);
    if (dot(axis, axis) == 0.0f) {
        bool same = dot(a, b) > 0.0f;
        *cos_out = same ? cos(theta_o) : -1.0f;
        return same ? a : (float3)(0.0f, 0.0f, 1.0f);
    }
    float3 k = normalize(axis);
    float turn = theta_o - theta_a;
    float s = sin(turn), c = cos(turn);
    float3 w = a * c + cross(k, a) * s + k * (dot(k, a) * (1.0f - c));
    *cos_out = cos(theta_o);
    return normalize(w);
}

inline float3 lt_lo(PtLightNode n) { return (float3)(n.lo[0], n.lo[1], n.lo[2]); }
inline float3 lt_hi(PtLightNode n) { return (float3)(n.hi[0], n.hi[1], n.hi[2]); }
inline float3 lt_w(PtLightNode n) { return (float3)(n.w[0], n.w[1], n.w[2]); }

inline PtLightNode lt_node(float3 lo, float3 hi, float phi, float3 w, float cos_o, float cos_e,
                           uint two_sided, uint child) {
    PtLightNode n;
    n.lo[0] = lo.x;
    n.lo[1] = lo.y;
    n.lo[2] = lo.z;
    n.phi = phi;
    n.hi[0] = hi.x;
    n.hi[1] = hi.y;
    n.hi[2] = hi.z;
    n.cos_theta_o = cos_o;
    n.w[0] = w.x;
    n.w[1] = w.y;
    n.w[2] = w.z;
    n.cos_theta_e = cos_e;
    n.child = child;
    n.two_sided = two_sided;
    n.pad[0] = 0u;
    n.pad[1] = 0u;
    return n;
}

// A leaf that sends nothing (`LightBounds::NOTHING`).
inline PtLightNode lt_nothing(uint child) {
    return lt_node((float3)(0.0f), (float3)(0.0f), 0.0f, (float3)(0.0f, 0.0f, 1.0f), 1.0f, 0.0f, 0u,
                   child);
}

// Both bounds in one, the power `phi` (`LightBounds::merge`, which sums it;
// a light over its steps takes the largest instead).
inline PtLightNode lt_merge(PtLightNode a, PtLightNode b, float phi, uint child) {
    float cos_o;
    float3 w = lt_cone_union(lt_w(a), a.cos_theta_o, lt_w(b), b.cos_theta_o, &cos_o);
    return lt_node(fmin(lt_lo(a), lt_lo(b)), fmax(lt_hi(a), lt_hi(b)), phi, w, cos_o,
                   fmin(a.cos_theta_e, b.cos_theta_e), a.two_sided | b.two_sided, child);
}

inline bool lt_finite3(float3 v) { return isfinite(v.x) && isfinite(v.y) && isfinite(v.z); }

// A point or spot light's power in the selection's units
// (`device_light_power`).
inline float lt_light_power(PtLight l, float* cos_inner, float* cos_outer) {
    float ci = 1.0f, co = -1.0f;
    if (l.angle_scale > 0.0f && isfinite(l.angle_scale)) {
        co = clamp(-l.angle_offset / l.angle_scale, -1.0f, 1.0f);
        ci = clamp((1.0f - l.angle_offset) / l.angle_scale, co, 1.0f);
    }
    *cos_inner = ci;
    *cos_outer = co;
    float lum = luminance((float3)(l.intensity[0], l.intensity[1], l.intensity[2]));
    float p = l.kind == LIGHT_SPOT
                  ? 2.0f * PT_PI * lum * ((1.0f - ci) + fmax(ci - co, 0.0f) / 2.0f)
                  : 4.0f * PT_PI * lum;
    return isfinite(p) && p > 0.0f ? p : 0.0f;
}

// Leaf `i` of `emitters + light_count`: emitter i (triangle prims[i] of the
// soup, whose `power` is per triangle) or light i − emitters (`lights`
// holds `light_count` lights per step), over `steps` motion steps.
__kernel void lt_leaves(__global const float4* positions, uint triangles, uint steps,
                        __global const uint* material_ids, __global const PtMaterial* materials,
                        uint material_count, __global const uint* prims, uint emitters,
                        __global const float* power, __global const PtLight* lights,
                        uint light_count, uint light_steps, __global PtLightNode* leaves) {
    uint i = get_global_id(0);
    if (i >= emitters + light_count) return;
    if (i < emitters) {
        uint prim = prims[i];
        uint child = LIGHT_NODE_LEAF | LIGHT_NODE_EMITTER | i;
        PtMaterial m = materials[min(material_ids[prim], material_count - 1u)];
        uint two_sided = (m.flags & MAT_DOUBLE_SIDED) != 0u ? 1u : 0u;
        float phi = PT_PI * power[prim];
        PtLightNode out = lt_nothing(child);
        for (uint s = 0u; s < max(steps, 1u); ++s) {
            const __global float4* c = positions + ((size_t)s * (size_t)triangles + prim) * 3u;
            float3 c0 = c[0].xyz, c1 = c[1].xyz, c2 = c[2].xyz;
            float3 nrm = cross(c1 - c0, c2 - c0);
            float len = length(nrm);
            if (!(len > 0.0f) || !isfinite(len)) {
                leaves[i] = lt_nothing(child);
                return;
            }
            nrm = nrm / len;
            if (!lt_finite3(nrm)) {
                leaves[i] = lt_nothing(child);
                return;
            }
            PtLightNode b = lt_node(fmin(fmin(c0, c1), c2), fmax(fmax(c0, c1), c2), phi, nrm, 1.0f,
                                    0.0f, two_sided, child);
            out = s == 0u ? b : lt_merge(out, b, phi, child);
        }
        bool ok = out.phi > 0.0f && lt_finite3(lt_lo(out)) && lt_finite3(lt_hi(out));
        leaves[i] = ok ? out : lt_nothing(child);
        return;
    }
    uint li = i - emitters;
    uint child = LIGHT_NODE_LEAF | li;
    PtLightNode out = lt_nothing(child);
    for (uint s = 0u; s < max(light_steps, 1u); ++s) {
        PtLight l = lights[(size_t)s * light_count + li];
        if (l.kind == LIGHT_DIRECTIONAL) {
            leaves[i] = lt_nothing(child);
            return;
        }
        float ci, co;
        float phi = lt_light_power(l, &ci, &co);
        float3 p = (float3)(l.position[0], l.position[1], l.position[2]);
        float3 w = (float3)(0.0f, 0.0f, 1.0f);
        float cos_o = -1.0f, cos_e = 0.0f;
        if (l.kind == LIGHT_SPOT) {
            float3 d = (float3)(l.direction[0], l.direction[1], l.direction[2]);
            float len = length(d);
            if (len > 0.0f && isfinite(len)) {
                w = d / len;
                cos_o = ci;
                cos_e = cos(fmax(acos(co) - acos(ci), 0.0f));
            }
        }
        PtLightNode b = lt_node(p, p, phi, w, cos_o, cos_e, 0u, child);
        out = s == 0u ? b : lt_merge(out, b, fmax(out.phi, b.phi), child);
    }
    bool ok = out.phi > 0.0f && lt_finite3(lt_lo(out)) && lt_finite3(lt_hi(out));
    leaves[i] = ok ? out : lt_nothing(child);
}

// Work-item g's partial boxes over leaves g, g + stride, ...: of the
// emitters' bounds, of the emitters' centres and of the lights' centres,
// leaves that send nothing left out; 18 floats (lo, hi of each).
__kernel void lt_bounds(__global const PtLightNode* leaves, uint emitters, uint total,
                        __global float* out) {
    uint g = get_global_id(0), stride = get_global_size(0);
    float3 inf = (float3)(INFINITY);
    float3 box_lo = inf, box_hi = -inf, ec_lo = inf, ec_hi = -inf, lc_lo = inf, lc_hi = -inf;
    for (uint i = g; i < total; i += stride) {
        PtLightNode n = leaves[i];
        if (!(n.phi > 0.0f)) continue;
        float3 c = 0.5f * (lt_lo(n) + lt_hi(n));
        if (i < emitters) {
            box_lo = fmin(box_lo, lt_lo(n));
            box_hi = fmax(box_hi, lt_hi(n));
            ec_lo = fmin(ec_lo, c);
            ec_hi = fmax(ec_hi, c);
        } else {
            lc_lo = fmin(lc_lo, c);
            lc_hi = fmax(lc_hi, c);
        }
    }
    __global float* o = out + (size_t)g * 18u;
    float3 v[6] = {box_lo, box_hi, ec_lo, ec_hi, lc_lo, lc_hi};
    for (uint k = 0u; k < 6u; ++k) {
        o[3u * k] = v[k].x;
        o[3u * k + 1u] = v[k].y;
        o[3u * k + 2u] = v[k].z;
    }
}

inline uint lt_spread_bits(uint x) {
    x &= 0x3ffu;
    x = (x | (x << 16)) & 0x030000ffu;
    x = (x | (x << 8)) & 0x0300f00fu;
    x = (x | (x << 4)) & 0x030c30c3u;
    return (x | (x << 2)) & 0x09249249u;
}

// The keys of leaves first .. first + count (`morton_code`; the leaf's
// index below it, so that every key differs), then ULONG_MAX up to `padded`
// (a power of two) for the bitonic sort.
__kernel void lt_keys(__global const PtLightNode* leaves, uint first, uint count, uint padded,
                      float lo_x, float lo_y, float lo_z, float scale_x, float scale_y,
                      float scale_z, __global ulong* keys) {
    uint i = get_global_id(0);
    if (i >= padded) return;
    if (i >= count) {
        keys[i] = ULONG_MAX;
        return;
    }
    PtLightNode n = leaves[first + i];
    uint code = 0xffffffffu;
    if (n.phi > 0.0f) {
        float3 c = 0.5f * (lt_lo(n) + lt_hi(n));
        const float top = 1023.0f;
        uint qx = (uint)clamp((c.x - lo_x) * scale_x, 0.0f, top);
        uint qy = (uint)clamp((c.y - lo_y) * scale_y, 0.0f, top);
        uint qz = (uint)clamp((c.z - lo_z) * scale_z, 0.0f, top);
        code = (lt_spread_bits(qx) << 2) | (lt_spread_bits(qy) << 1) | lt_spread_bits(qz);
    }
    keys[i] = ((ulong)code << 32) | (ulong)i;
}

// One step of the bitonic sort: stage `k`, distance `j`.
__kernel void lt_sort(__global ulong* keys, uint j, uint k) {
    uint i = get_global_id(0);
    uint l = i ^ j;
    if (l <= i) return;
    ulong a = keys[i], b = keys[l];
    bool up = (i & k) == 0u;
    if ((a > b) == up) {
        keys[i] = b;
        keys[l] = a;
    }
}

// The heap slot of sorted leaf `s` of `n` (`leaf_slot`).
inline uint lt_leaf_slot(uint s, uint n) {
    uint nodes = 2u * n - 1u;
    uint deepest = 1u << (31u - clz(nodes));
    uint at_bottom = nodes + 1u - deepest;
    return s < at_bottom ? deepest - 1u + s : n - 1u + (s - at_bottom);
}

// The trail of heap node `k` (`heap_trail`).
inline uint lt_heap_trail(uint k) {
    uint path = k + 1u;
    uint depth = 31u - clz(path);
    uint trail = 0u;
    for (uint d = 0u; d < depth; ++d) trail |= ((path >> (depth - 1u - d)) & 1u) << d;
    return trail;
}

// Sorted leaf s of `count` (leaves first ..) into its slot of `nodes`; an
// emitter's trail into `trails`, by its triangle.
__kernel void lt_place(__global const ulong* keys, __global const PtLightNode* leaves, uint first,
                       uint count, __global const uint* prims, __global PtLightNode* nodes,
                       __global uint* trails) {
    uint s = get_global_id(0);
    if (s >= count) return;
    PtLightNode leaf = leaves[first + (uint)(keys[s] & 0xffffffffu)];
    uint slot = lt_leaf_slot(s, count);
    nodes[slot] = leaf;
    if ((leaf.child & LIGHT_NODE_EMITTER) != 0u) {
        uint k = leaf.child & ~(LIGHT_NODE_LEAF | LIGHT_NODE_EMITTER);
        trails[prims[k]] = lt_heap_trail(slot);
    }
}

// Inner nodes begin ..= end (one level) from their children; one that
// sends nothing adds nothing (`LightBounds::union`).
__kernel void lt_refit(__global PtLightNode* nodes, uint begin, uint end) {
    uint i = begin + get_global_id(0);
    if (i > end) return;
    uint c = 2u * i + 1u;
    PtLightNode a = nodes[c], b = nodes[c + 1u];
    PtLightNode out;
    if (a.phi == 0.0f) {
        out = b;
    } else if (b.phi == 0.0f) {
        out = a;
    } else {
        out = lt_merge(a, b, a.phi + b.phi, c);
    }
    out.child = c;
    nodes[i] = out;
}
