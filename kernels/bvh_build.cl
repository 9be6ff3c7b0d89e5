// The per-frame binned-SAH BVH builder of Sopin, Bogolepov and Ulyanov
// (2011), level by level. The host keeps one queue per stage (large nodes of
// more than 32K triangles, medium of 256..32K, small under 256), launches
// every task of a level at once, reads back the splits and generates the
// next level's tasks. Kernels, in launch order:
//
//   compute_prim_refs, merge_bins  triangle boxes and the root's bin
//   bin_triangles                  per-work-group bins, 512 triangles a group,
//                                  counted by BINS-thread groups over blocks
//                                  of BINS triangles (the paper's half-warps)
//   reduce_bins                    large nodes only: REDUCE_FAN group bins -> one
//   find_split                     one work-group a node: final reduction and
//                                  the best SAH split, chosen on the device
//   partition                      one global atomic per work-group reserves
//                                  the group's left and right slots at once
//   copy_back                      the partitioned indices back into place
//   split_small                    small nodes: one BINS-thread group a node
//                                  bins, splits and partitions in local memory
//
// Defines: BINS, HAVE_INT64_ATOMICS (0/1).
#include "bvh_types.h"
#include "bvh_common.h"

#if HAVE_INT64_ATOMICS
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable
#endif

#define BUILD_WG 128
#define HALVES (BUILD_WG / BINS)
#define PRIMS_PER_GROUP 512
#define ROUNDS (PRIMS_PER_GROUP / BUILD_WG)
#define REDUCE_FAN 64
#define SMALL_MAX 256

// Loads primitive slot p into staging slot k: its box, id and packed bins.
inline void stage_prim(bool valid, uint p, float4 cmin, float4 scale,
                       __global const uint* ids, __global const PrimRef* refs,
                       __local float4* s_lo, __local float4* s_hi, __local uint* s_bin,
                       __local uint* s_id, uint k) {
    if (!valid) {
        s_bin[k] = INVALID_BINS;
        return;
    }
    uint id = ids[p];
    PrimRef r = refs[id];
    float4 c = centroid(r.lo, r.hi);
    uint bx = bin_index(c.x, cmin.x, scale.x);
    uint by = bin_index(c.y, cmin.y, scale.y);
    uint bz = bin_index(c.z, cmin.z, scale.z);
    s_bin[k] = bx | (by << 8) | (bz << 16);
    s_lo[k] = r.lo;
    s_hi[k] = r.hi;
    s_id[k] = id;
}

// The paper's counting step: the BINS threads of a group walk the same
// block of BINS staged primitives, and thread `lane` takes those that fall
// in bin `lane` of each axis. No atomics, no conflicts; each thread ends
// with its own three bins.
inline void bin_block(uint base, uint limit, uint lane, __local const float4* s_lo,
                      __local const float4* s_hi, __local const uint* s_bin,
                      __local const uint* s_id, Bin* ax, Bin* ay, Bin* az) {
    for (uint j = 0; j < BINS; ++j) {
        uint k = base + j;
        if (k >= limit) break;
        uint packed = s_bin[k];
        if (packed == INVALID_BINS) continue;
        float4 lo = s_lo[k];
        float4 hi = s_hi[k];
        float4 c = centroid(lo, hi);
        uint id = s_id[k];
        if ((packed & 0xFFu) == lane) bin_add(ax, lo, hi, c, id);
        if (((packed >> 8) & 0xFFu) == lane) bin_add(ay, lo, hi, c, id);
        if (((packed >> 16) & 0xFFu) == lane) bin_add(az, lo, hi, c, id);
    }
}

// Reserves l left and r right slots of task ti; returns the slots taken before.
inline uint2 reserve(__global ulong* cursors, uint ti, uint l, uint r) {
#if HAVE_INT64_ATOMICS
    ulong before = atom_add(&cursors[ti], ((ulong)r << 32) | (ulong)l);
    return (uint2)((uint)before, (uint)(before >> 32));
#else
    volatile __global uint* c = (volatile __global uint*)cursors + 2 * ti;
    return (uint2)(atomic_add(c, l), atomic_add(c + 1, r));
#endif
}

__kernel __attribute__((reqd_work_group_size(BUILD_WG, 1, 1)))
void compute_prim_refs(__global const float4* positions, uint n, __global PrimRef* refs,
                       __global uint* ids, __global Bin* partials) {
    __local Bin s_bins[BUILD_WG];
    uint i = get_global_id(0);
    uint lid = get_local_id(0);
    Bin b = bin_empty();
    if (i < n) {
        float4 v0 = positions[3 * i];
        float4 v1 = positions[3 * i + 1];
        float4 v2 = positions[3 * i + 2];
        PrimRef r;
        r.lo = fmin(fmin(v0, v1), v2);
        r.hi = fmax(fmax(v0, v1), v2);
        r.lo.w = 0.0f;
        r.hi.w = 0.0f;
        refs[i] = r;
        ids[i] = i;
        bin_add(&b, r.lo, r.hi, centroid(r.lo, r.hi), i);
    }
    s_bins[lid] = b;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint stride = BUILD_WG / 2; stride > 0; stride >>= 1) {
        if (lid < stride) s_bins[lid] = bin_merge(s_bins[lid], s_bins[lid + stride]);
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (lid == 0) partials[get_group_id(0)] = s_bins[0];
}

__kernel __attribute__((reqd_work_group_size(BUILD_WG, 1, 1)))
void merge_bins(__global const Bin* in, uint n, __global Bin* out) {
    __local Bin s_bins[BUILD_WG];
    uint lid = get_local_id(0);
    Bin b = bin_empty();
    for (uint i = lid; i < n; i += BUILD_WG) b = bin_merge(b, in[i]);
    s_bins[lid] = b;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint stride = BUILD_WG / 2; stride > 0; stride >>= 1) {
        if (lid < stride) s_bins[lid] = bin_merge(s_bins[lid], s_bins[lid + stride]);
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    if (lid == 0) out[0] = s_bins[0];
}

__kernel __attribute__((reqd_work_group_size(BUILD_WG, 1, 1)))
void bin_triangles(__global const BuildTask* tasks, __global const uint* group_task,
                   __global const uint* group_index, __global const uint* ids,
                   __global const PrimRef* refs, __global Bin* group_bins) {
    __local float4 s_lo[BUILD_WG];
    __local float4 s_hi[BUILD_WG];
    __local uint s_bin[BUILD_WG];
    __local uint s_id[BUILD_WG];
    __local Bin s_red[3 * BUILD_WG];
    uint g = get_group_id(0);
    uint lid = get_local_id(0);
    BuildTask t = tasks[group_task[g]];
    uint begin = t.start + group_index[g] * PRIMS_PER_GROUP;
    uint end = min(begin + PRIMS_PER_GROUP, t.start + t.count);
    uint half_warp = lid / BINS;
    uint lane = lid % BINS;
    Bin ax = bin_empty();
    Bin ay = bin_empty();
    Bin az = bin_empty();
    for (uint round = 0; round < ROUNDS; ++round) {
        uint first = begin + round * BUILD_WG;
        if (first >= end) break;  // the same for the whole group
        stage_prim(first + lid < end, first + lid, t.cmin, t.scale, ids, refs, s_lo, s_hi, s_bin,
                   s_id, lid);
        barrier(CLK_LOCAL_MEM_FENCE);
        bin_block(half_warp * BINS, BUILD_WG, lane, s_lo, s_hi, s_bin, s_id, &ax, &ay, &az);
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    s_red[(half_warp * 3 + 0) * BINS + lane] = ax;
    s_red[(half_warp * 3 + 1) * BINS + lane] = ay;
    s_red[(half_warp * 3 + 2) * BINS + lane] = az;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint i = lid; i < 3 * BINS; i += BUILD_WG) {
        Bin b = bin_empty();
        for (uint h = 0; h < HALVES; ++h) b = bin_merge(b, s_red[h * 3 * BINS + i]);
        group_bins[g * 3 * BINS + i] = b;
    }
}

__kernel __attribute__((reqd_work_group_size(BUILD_WG, 1, 1)))
void reduce_bins(__global const BuildTask* tasks, __global const uint* reduce_task,
                 __global const uint* reduce_index, __global const Bin* group_bins,
                 __global Bin* partial_bins) {
    uint p = get_group_id(0);
    uint lid = get_local_id(0);
    BuildTask t = tasks[reduce_task[p]];
    uint r = reduce_index[p];
    uint first = t.first_group + r * REDUCE_FAN;
    uint n = min((uint)REDUCE_FAN, t.group_count - r * REDUCE_FAN);
    for (uint i = lid; i < 3 * BINS; i += BUILD_WG) {
        Bin b = bin_empty();
        for (uint k = 0; k < n; ++k) b = bin_merge(b, group_bins[(first + k) * 3 * BINS + i]);
        partial_bins[(t.set_first + r) * 3 * BINS + i] = b;
    }
}

__kernel __attribute__((reqd_work_group_size(BUILD_WG, 1, 1)))
void find_split(__global const BuildTask* tasks, __global const Bin* sets,
                __global SplitResult* splits, __global ulong* cursors) {
    __local Bin s_bins[3 * BINS];
    __local float s_cost[BUILD_WG];
    __local int s_idx[BUILD_WG];
    uint g = get_group_id(0);
    uint lid = get_local_id(0);
    BuildTask t = tasks[g];
    for (uint i = lid; i < 3 * BINS; i += BUILD_WG) {
        Bin b = bin_empty();
        for (uint k = 0; k < t.set_count; ++k) b = bin_merge(b, sets[(t.set_first + k) * 3 * BINS + i]);
        s_bins[i] = b;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    int best = select_split(s_bins, t.scale, s_cost, s_idx, lid, BUILD_WG);
    if (lid == 0) {
        splits[g] = make_split(s_bins, t, best);
        cursors[g] = 0;
    }
}

__kernel __attribute__((reqd_work_group_size(BUILD_WG, 1, 1)))
void partition(__global const BuildTask* tasks, __global const uint* group_task,
               __global const uint* group_index, __global const SplitResult* splits,
               __global const uint* ids_in, __global const PrimRef* refs, __global uint* ids_out,
               __global ulong* cursors) {
    __local uint s_scan[BUILD_WG];
    __local uint2 s_base;
    uint g = get_group_id(0);
    uint lid = get_local_id(0);
    uint ti = group_task[g];
    BuildTask t = tasks[ti];
    SplitResult s = splits[ti];
    uint begin = t.start + group_index[g] * PRIMS_PER_GROUP;
    uint end = min(begin + PRIMS_PER_GROUP, t.start + t.count);
    uint mine[PRIMS_PER_GROUP / BUILD_WG];
    uint sides = 0;
    uint n = 0;
    uint nl = 0;
    for (uint k = 0; k < PRIMS_PER_GROUP / BUILD_WG; ++k) {
        uint p = begin + lid * (PRIMS_PER_GROUP / BUILD_WG) + k;
        if (p < end) {
            uint id = ids_in[p];
            PrimRef r = refs[id];
            bool left = goes_left(t, s, r.lo, r.hi, id);
            mine[k] = id;
            sides |= (uint)left << k;
            nl += (uint)left;
            n += 1;
        }
    }
    // Left and right counts travel packed in one word (each is at most 512).
    uint total;
    uint before = wg_exclusive_scan(((n - nl) << 16) | nl, s_scan, lid, BUILD_WG, &total);
    if (lid == 0) s_base = reserve(cursors, ti, total & 0xFFFFu, total >> 16);
    barrier(CLK_LOCAL_MEM_FENCE);
    uint left_slot = t.start + s_base.x + (before & 0xFFFFu);
    uint right_rank = s_base.y + (before >> 16);
    uint last = t.start + t.count - 1;
    for (uint k = 0; k < n; ++k) {
        if ((sides >> k) & 1u) {
            ids_out[left_slot++] = mine[k];
        } else {
            ids_out[last - right_rank++] = mine[k];
        }
    }
}

__kernel __attribute__((reqd_work_group_size(BUILD_WG, 1, 1)))
void copy_back(__global const BuildTask* tasks, __global const uint* group_task,
               __global const uint* group_index, __global const uint* src, __global uint* dst) {
    uint g = get_group_id(0);
    BuildTask t = tasks[group_task[g]];
    uint begin = t.start + group_index[g] * PRIMS_PER_GROUP;
    uint end = min(begin + PRIMS_PER_GROUP, t.start + t.count);
    for (uint p = begin + get_local_id(0); p < end; p += BUILD_WG) dst[p] = src[p];
}

__kernel __attribute__((reqd_work_group_size(BINS, 1, 1)))
void split_small(__global const BuildTask* tasks, __global uint* ids,
                 __global const PrimRef* refs, __global SplitResult* splits,
                 __global ulong* cursors) {
    __local float4 s_lo[SMALL_MAX];
    __local float4 s_hi[SMALL_MAX];
    __local uint s_bin[SMALL_MAX];
    __local uint s_id[SMALL_MAX];
    __local uchar s_left[SMALL_MAX];
    __local Bin s_bins[3 * BINS];
    __local float s_cost[BINS];
    __local int s_idx[BINS];
    __local uint s_scan[BINS];
    uint g = get_group_id(0);
    uint lane = get_local_id(0);
    BuildTask t = tasks[g];
    for (uint k = lane; k < t.count; k += BINS) {
        stage_prim(true, t.start + k, t.cmin, t.scale, ids, refs, s_lo, s_hi, s_bin, s_id, k);
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    Bin ax = bin_empty();
    Bin ay = bin_empty();
    Bin az = bin_empty();
    for (uint base = 0; base < t.count; base += BINS) {
        bin_block(base, t.count, lane, s_lo, s_hi, s_bin, s_id, &ax, &ay, &az);
    }
    s_bins[lane] = ax;
    s_bins[BINS + lane] = ay;
    s_bins[2 * BINS + lane] = az;
    barrier(CLK_LOCAL_MEM_FENCE);
    int best = select_split(s_bins, t.scale, s_cost, s_idx, lane, BINS);
    SplitResult s = make_split(s_bins, t, best);

    // Each thread partitions one contiguous chunk, so the scan keeps order.
    uint chunk = (t.count + BINS - 1) / BINS;
    uint begin = min(lane * chunk, t.count);
    uint end = min(begin + chunk, t.count);
    uint nl = 0;
    for (uint k = begin; k < end; ++k) {
        bool left = goes_left(t, s, s_lo[k], s_hi[k], s_id[k]);
        s_left[k] = (uchar)left;
        nl += (uint)left;
    }
    uint total;
    uint before = wg_exclusive_scan(((end - begin - nl) << 16) | nl, s_scan, lane, BINS, &total);
    uint left_slot = t.start + (before & 0xFFFFu);
    uint right_rank = before >> 16;
    uint last = t.start + t.count - 1;
    for (uint k = begin; k < end; ++k) {
        if (s_left[k]) {
            ids[left_slot++] = s_id[k];
        } else {
            ids[last - right_rank++] = s_id[k];
        }
    }
    if (lane == 0) {
        s.left_count = total & 0xFFFFu;
        s.right_count = total >> 16;
        splits[g] = s;
        cursors[g] = ((ulong)s.right_count << 32) | (ulong)s.left_count;
    }
}
