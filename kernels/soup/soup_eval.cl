// The frame's world-space triangle soup on the device, in two passes that
// mirror the CPU reference (src/scene/evaluate.rs, src/scene/deform.rs)
// operation for operation, so the two agree to rounding:
//
//   deform_vertices   one work-item per deformed vertex (per instance of a
//                     primitive): morph blend, skin matrix blend (or the
//                     instance's rigid transform), transform to world space.
//                     Writes (position, det) and the unit normal.
//   assemble_triangles one work-item per triangle: gathers its three corners,
//                     fixes the winding under mirroring transforms, writes
//                     the soup's positions, normals and uvs where the BVH
//                     builder and the tracer read them.
//
// Compiled per scene with only the features it uses (see SoupFeatures in
// src/soup/device.rs, which assembles these defines in one place):
//   HAS_SKIN          defined when some instance is skinned; without it no
//                     skinning code exists
//   INFLUENCE_SETS    JOINTS_n/WEIGHTS_n sets per skinned vertex (0 without skins)
//   MORPH_TARGETS     the most morph targets of any mesh (0: no morph code)
//   HAS_NORMALS       the soup carries shading normals
//   HAS_UVS           the soup carries TEXCOORD_0
//   HAS_UVS1          the soup carries a second uv set (Scene::second_uv_set)
//   HAS_COLORS        the soup carries COLOR_0
//   SANITIZE          non-finite triangles are collapsed (and counted) rather
//                     than reported as an error
//
// FMA contraction is off: the CPU reference rounds every product and sum.
#pragma OPENCL FP_CONTRACT OFF

#include "soup_types.h"

#ifndef MORPH_TARGETS
#define MORPH_TARGETS 0
#endif
#ifndef INFLUENCE_SETS
#define INFLUENCE_SETS 0
#endif

// glam's Vec3::cross and Vec3::dot, spelled out so no builtin reorders them.
inline float3 cross3(float3 a, float3 b) {
    return (float3)(a.y * b.z - b.y * a.z, a.z * b.x - b.z * a.x, a.x * b.y - b.x * a.y);
}

inline float dot3(float3 a, float3 b) {
    return ((a.x * b.x) + (a.y * b.y)) + (a.z * b.z);
}

// glam's normalize_or_zero: multiply by the reciprocal length when it is
// finite and positive.
inline float3 normalize_or_zero(float3 v) {
    float rcp = 1.0f / sqrt(dot3(v, v));
    if (isfinite(rcp) && rcp > 0.0f) {
        return v * rcp;
    }
    return (float3)(0.0f, 0.0f, 0.0f);
}

// Mat4::transform_point3: ((x*px + y*py) + z*pz) + w.
inline float3 transform_point(const float4* m, float3 p) {
    float3 r = m[0].xyz * p.x;
    r = m[1].xyz * p.y + r;
    r = m[2].xyz * p.z + r;
    r = m[3].xyz + r;
    return r;
}

// Mat3 * Vec3: (x*nx + y*ny) + z*nz.
inline float3 mat3_mul(const float3* m, float3 v) {
    float3 r = m[0] * v.x;
    r = r + m[1] * v.y;
    r = r + m[2] * v.z;
    return r;
}

__kernel void deform_vertices(
    __global const SoupSegment* segments,
    __global const uint* vertex_segment,
    uint vertex_count,
    __global const float4* base_positions,
#ifdef HAS_NORMALS
    __global const float4* base_normals,
#endif
#if MORPH_TARGETS > 0
    __global const float4* position_deltas,
#ifdef HAS_NORMALS
    __global const float4* normal_deltas,
#endif
    __global const float* morph_weights,
#endif
#ifdef HAS_SKIN
    __global const uint4* influence_joints,
    __global const float4* influence_weights,
    __global const float4* joint_matrices,
#endif
    __global const SoupInstancePose* instances,
    __global float4* out_positions,
    __global float4* out_normals)
{
    uint i = get_global_id(0);
    if (i >= vertex_count) return;
    SoupSegment seg = segments[vertex_segment[i]];
    uint v = i - seg.dst_vertex;
    uint s = seg.src_vertex + v;

    float3 position = base_positions[s].xyz;
#ifdef HAS_NORMALS
    bool has_normal = (seg.flags & SEG_NORMALS) != 0;
    float3 normal = has_normal ? base_normals[s].xyz : (float3)(0.0f, 0.0f, 0.0f);
#endif

#if MORPH_TARGETS > 0
    // morph_blend: targets in order, zero weights skipped.
    for (uint t = 0; t < MORPH_TARGETS; ++t) {
        if (t >= seg.target_count) break;
        float w = morph_weights[seg.weight_base + t];
        if (w != 0.0f) {
            uint d = seg.morph_base + v * seg.target_count + t;
            position += w * position_deltas[d].xyz;
#ifdef HAS_NORMALS
            if (has_normal) normal += w * normal_deltas[d].xyz;
#endif
        }
    }
#endif

    __global const SoupInstancePose* inst = &instances[seg.instance];
    float4 m[4];
    float3 n[3];
    float det;
#ifdef HAS_SKIN
    if (seg.flags & SEG_SKINNED) {
        // skin_matrix: sum of weight * joint matrix, zero weights skipped,
        // set by set and slot by slot.
        for (int c = 0; c < 4; ++c) m[c] = (float4)(0.0f);
        for (uint k = 0; k < INFLUENCE_SETS; ++k) {
            uint r = seg.influence_base + v * INFLUENCE_SETS + k;
            uint4 js = influence_joints[r];
            float4 ws = influence_weights[r];
            uint jj[4] = {js.x, js.y, js.z, js.w};
            float ww[4] = {ws.x, ws.y, ws.z, ws.w};
            for (int q = 0; q < 4; ++q) {
                float w = ww[q];
                if (w != 0.0f) {
                    __global const float4* j = &joint_matrices[4 * (seg.joint_base + jj[q])];
                    for (int c = 0; c < 4; ++c) m[c] = m[c] + j[c] * w;
                }
            }
        }
        // normal_matrix: cofactors times the sign of the determinant.
        float3 c0 = m[0].xyz, c1 = m[1].xyz, c2 = m[2].xyz;
        float3 c12 = cross3(c1, c2);
        det = dot3(c0, c12);
        float sign = det < 0.0f ? -1.0f : 1.0f;
        n[0] = c12 * sign;
        n[1] = cross3(c2, c0) * sign;
        n[2] = cross3(c0, c1) * sign;
    } else
#endif
    {
        for (int c = 0; c < 4; ++c) m[c] = inst->world_from_mesh[c];
        for (int c = 0; c < 3; ++c) n[c] = inst->normal_matrix[c].xyz;
        det = inst->det;
    }

    float3 p = transform_point(m, position);
    out_positions[i] = (float4)(p, det);
#ifdef HAS_NORMALS
    out_normals[i] = (float4)(normalize_or_zero(mat3_mul(n, normal)), 0.0f);
#endif
}

inline bool finite3(float4 p) {
    return isfinite(p.x) && isfinite(p.y) && isfinite(p.z);
}

__kernel void assemble_triangles(
    __global const SoupSegment* segments,
    __global const uint4* triangles,
    uint triangle_count,
    __global const float4* deformed_positions,
#ifdef HAS_NORMALS
    __global const float4* deformed_normals,
#endif
#ifdef HAS_UVS
    __global const float2* base_uvs,
#endif
#ifdef HAS_UVS1
    __global const float2* base_uvs1,
#endif
#ifdef HAS_COLORS
    __global const float4* base_colors,
#endif
    __global float4* positions,
#ifdef HAS_NORMALS
    __global float4* normals,
#endif
#ifdef HAS_UVS
    __global float2* uvs,
#endif
#ifdef HAS_UVS1
    __global float2* uvs1,
#endif
#ifdef HAS_COLORS
    __global float4* colors,
#endif
    __global uint* status)
{
    uint t = get_global_id(0);
    if (t >= triangle_count) return;
    uint4 tri = triangles[t];
    SoupSegment seg = segments[tri.w];
    uint src[3] = {tri.x, tri.y, tri.z};
    float4 c[3];
    for (int k = 0; k < 3; ++k) c[k] = deformed_positions[seg.dst_vertex + src[k]];

    if (!(finite3(c[0]) && finite3(c[1]) && finite3(c[2]))) {
        // status[0]: the first bad triangle (for the message), status[1]: how many.
        atomic_min(&status[0], t);
        atomic_inc(&status[1]);
#ifdef SANITIZE
        // The soup keeps a fixed triangle count, so a dropped triangle is
        // collapsed to a point: its first finite corner, else the origin.
        float4 keep = (float4)(0.0f, 0.0f, 0.0f, 1.0f);
        for (int k = 2; k >= 0; --k) if (finite3(c[k])) keep = c[k];
        c[0] = c[1] = c[2] = keep;
#endif
    }

    // glTF's winding is counter-clockwise for a positive determinant; when
    // at least two corners are mirrored, swap corners 1 and 2.
    int mirrored = (c[0].w < 0.0f) + (c[1].w < 0.0f) + (c[2].w < 0.0f);
    int o1 = mirrored >= 2 ? 2 : 1;
    int o2 = mirrored >= 2 ? 1 : 2;
    int order[3] = {0, o1, o2};

    for (int k = 0; k < 3; ++k) {
        positions[3 * t + k] = (float4)(c[order[k]].xyz, 0.0f);
    }
#ifdef HAS_NORMALS
    if (seg.flags & SEG_NORMALS) {
        for (int k = 0; k < 3; ++k) {
            float3 nk = deformed_normals[seg.dst_vertex + src[order[k]]].xyz;
            normals[3 * t + k] = (float4)(nk, 0.0f);
        }
    } else {
        // No normals: glTF asks for flat shading.
        float3 a = c[order[0]].xyz, b = c[order[1]].xyz, d = c[order[2]].xyz;
        float4 flat = (float4)(normalize_or_zero(cross3(b - a, d - a)), 0.0f);
        for (int k = 0; k < 3; ++k) normals[3 * t + k] = flat;
    }
#endif
#ifdef HAS_UVS
    for (int k = 0; k < 3; ++k) {
        uvs[3 * t + k] = (seg.flags & SEG_UVS) ? base_uvs[seg.src_vertex + src[order[k]]]
                                               : (float2)(0.0f, 0.0f);
    }
#endif
#ifdef HAS_UVS1
    for (int k = 0; k < 3; ++k) {
        uvs1[3 * t + k] = (seg.flags & SEG_UVS1) ? base_uvs1[seg.src_vertex + src[order[k]]]
                                                 : (float2)(0.0f, 0.0f);
    }
#endif
#ifdef HAS_COLORS
    for (int k = 0; k < 3; ++k) {
        colors[3 * t + k] = (seg.flags & SEG_COLORS) ? base_colors[seg.src_vertex + src[order[k]]]
                                                     : (float4)(1.0f);
    }
#endif
}
