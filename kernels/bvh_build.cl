// The per-frame binned-SAH BVH builder of Sopin, Bogolepov and Ulyanov
// (2011), level by level. The host keeps one queue per stage (large nodes of
// more than 32K triangles, medium of 256..32K, small under 256), launches
// every task of a level at once, reads back the splits and generates the
// next level's tasks. Kernels, in launch order:
//
//   compute_prim_refs, merge_bins  triangle boxes and the root's bin
//   bin_triangles                  per-work-group bins, 512 triangles a group,
//                                  counted by groups of BIN_LANES threads over
//                                  blocks of BIN_LANES triangles
//   reduce_bins                    large nodes only: REDUCE_FAN group bins -> one
//   find_split                     one work-group a node: final reduction and
//                                  the best SAH split, chosen on the device
//   partition                      one global atomic per work-group reserves
//                                  the group's left and right slots at once;
//                                  writes into the other buffer pair
//   split_small                    small nodes: one work-group a node bins,
//                                  splits and partitions in place
//   gather_ranges                  last: finished ranges left in buffer pair 1
//                                  copied into pair 0
//
// Triangle ids and boxes live in two buffer pairs (a, b). A level's
// partition reads its task's `source` pair and writes the other, so no
// level copies back; the host records which finished ranges end up in b.
//
// Defines:
//   BINS                bins per axis
//   BUILD_WG            work-items of the large/medium kernels' groups
//   BIN_LANES           threads that count one block together; lane `l` owns
//                       the bins b with b % BIN_LANES == l on every axis
//   SMALL_WG            work-items of split_small's groups
//   HAVE_INT64_ATOMICS  0/1
// On a GPU, BIN_LANES = BINS = 16 is the paper's half-warp scheme: the 16
// threads walk the same 16 triangles and each takes those in its bin, with
// no atomics and no bank conflicts. On a CPU, where work-items run one
// after another, that walk is 16 times the work; there BUILD_WG = BIN_LANES
// = SMALL_WG = 1, and the one work-item keeps all bins in private memory.
// Both mappings produce the same bins, bit for bit.
#include "bvh_types.h"
#include "bvh_common.h"

#if HAVE_INT64_ATOMICS
#pragma OPENCL EXTENSION cl_khr_int64_base_atomics : enable
#endif

#define HALVES (BUILD_WG / BIN_LANES)
#define OWNED (BINS / BIN_LANES)
#define PRIMS_PER_GROUP 512
#define ROUNDS (PRIMS_PER_GROUP / BUILD_WG)
#define PRIMS_PER_THREAD (PRIMS_PER_GROUP / BUILD_WG)
#define REDUCE_FAN 64
#define SMALL_MAX 256

// Loads primitive slot p into staging slot k: its box, id and packed bins.
// Boxes travel with their ids through every partition, so `refs` is read
// in slot order, never gathered through the ids.
inline void stage_prim(bool valid, uint p, float4 cmin, float4 scale,
                       __global const uint* ids, __global const PrimRef* refs,
                       __local float4* s_lo, __local float4* s_hi, __local uint* s_bin,
                       __local uint* s_id, uint k) {
    if (!valid) {
        s_bin[k] = INVALID_BINS;
        return;
    }
    uint id = ids[p];
    PrimRef r = refs[p];
    float4 c = centroid(r.lo, r.hi);
    uint bx = bin_index(c.x, cmin.x, scale.x);
    uint by = bin_index(c.y, cmin.y, scale.y);
    uint bz = bin_index(c.z, cmin.z, scale.z);
    s_bin[k] = bx | (by << 8) | (bz << 16);
    s_lo[k] = r.lo;
    s_hi[k] = r.hi;
    s_id[k] = id;
}

// The paper's counting step: the BIN_LANES threads of a group walk the
// same block of BIN_LANES staged primitives, and lane `lane` takes those
// that fall in one of its bins, on each axis. No atomics, no conflicts; each
// thread ends with its own OWNED bins per axis in `acc`.
inline void bin_block(uint base, uint limit, uint lane, __local const float4* s_lo,
                      __local const float4* s_hi, __local const uint* s_bin,
                      __local const uint* s_id, Bin* acc) {
    for (uint j = 0; j < BIN_LANES; ++j) {
        uint k = base + j;
        if (k >= limit) break;
        uint packed = s_bin[k];
        if (packed == INVALID_BINS) continue;
        float4 lo = s_lo[k];
        float4 hi = s_hi[k];
        float4 c = centroid(lo, hi);
        uint id = s_id[k];
        for (uint axis = 0; axis < 3; ++axis) {
            uint b = (packed >> (8 * axis)) & 0xFFu;
            if (b % BIN_LANES == lane) bin_add(&acc[axis * OWNED + b / BIN_LANES], lo, hi, c, id);
        }
    }
}

// The single-lane counting step: one work-item takes a triangle straight
// from global memory into its own 3 * BINS bins (no staging, no lanes).
inline void bin_direct(BuildTask t, uint id, PrimRef r, Bin* acc) {
    float4 c = centroid(r.lo, r.hi);
    bin_add(&acc[bin_index(c.x, t.cmin.x, t.scale.x)], r.lo, r.hi, c, id);
    bin_add(&acc[BINS + bin_index(c.y, t.cmin.y, t.scale.y)], r.lo, r.hi, c, id);
    bin_add(&acc[2 * BINS + bin_index(c.z, t.cmin.z, t.scale.z)], r.lo, r.hi, c, id);
}

// Stores a lane's bins into the group's 3 * BINS bin array `out`.
inline void store_lane_bins(const Bin* acc, uint lane, __local Bin* out) {
    for (uint axis = 0; axis < 3; ++axis) {
        for (uint o = 0; o < OWNED; ++o) out[axis * BINS + o * BIN_LANES + lane] = acc[axis * OWNED + o];
    }
}

// Reserves l left and r right slots of task ti; returns the slots taken before.
#define IDS(t) ((t).source ? ids_b : ids_a)
#define REFS(t) ((t).source ? refs_b : refs_a)

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
    uint lid = get_local_id(0);
    uint begin = get_group_id(0) * PRIMS_PER_GROUP;
    uint end = min(begin + PRIMS_PER_GROUP, n);
    Bin b = bin_empty();
    for (uint i = begin + lid; i < end; i += BUILD_WG) {
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
                   __global const uint* group_index, __global const uint* ids_a,
                   __global const PrimRef* refs_a, __global const uint* ids_b,
                   __global const PrimRef* refs_b, __global Bin* group_bins) {
    __local float4 s_lo[BUILD_WG];
    __local float4 s_hi[BUILD_WG];
    __local uint s_bin[BUILD_WG];
    __local uint s_id[BUILD_WG];
    __local Bin s_red[3 * BINS * HALVES];
    uint g = get_group_id(0);
    uint lid = get_local_id(0);
    BuildTask t = tasks[group_task[g]];
    __global const uint* ids = IDS(t);
    __global const PrimRef* refs = REFS(t);
    uint begin = t.start + group_index[g] * PRIMS_PER_GROUP;
    uint end = min(begin + PRIMS_PER_GROUP, t.start + t.count);
    uint group_of_lanes = lid / BIN_LANES;
    uint lane = lid % BIN_LANES;
    Bin acc[3 * OWNED];
    for (uint i = 0; i < 3 * OWNED; ++i) acc[i] = bin_empty();
#if BIN_LANES == 1 && BUILD_WG == 1
    for (uint p = begin; p < end; ++p) bin_direct(t, ids[p], refs[p], acc);
    for (uint i = 0; i < 3 * BINS; ++i) group_bins[g * 3 * BINS + i] = acc[i];
    return;
#endif
    for (uint round = 0; round < ROUNDS; ++round) {
        uint first = begin + round * BUILD_WG;
        if (first >= end) break;  // the same for the whole group
        stage_prim(first + lid < end, first + lid, t.cmin, t.scale, ids, refs, s_lo, s_hi, s_bin,
                   s_id, lid);
        barrier(CLK_LOCAL_MEM_FENCE);
        bin_block(group_of_lanes * BIN_LANES, BUILD_WG, lane, s_lo, s_hi, s_bin, s_id, acc);
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    store_lane_bins(acc, lane, s_red + group_of_lanes * 3 * BINS);
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
    __local float s_cost[3];
    __local int s_idx[3];
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
               __global uint* ids_a, __global PrimRef* refs_a, __global uint* ids_b,
               __global PrimRef* refs_b, __global ulong* cursors, __global const Bin* group_bins) {
    __local uint s_scan[BUILD_WG];
    __local uint2 s_base;
    uint g = get_group_id(0);
    uint lid = get_local_id(0);
    uint ti = group_task[g];
    BuildTask t = tasks[ti];
    SplitResult s = splits[ti];
    __global const uint* ids_in = IDS(t);
    __global const PrimRef* refs_in = REFS(t);
    __global uint* ids_out = t.source ? ids_a : ids_b;
    __global PrimRef* refs_out = t.source ? refs_a : refs_b;
    uint begin = t.start + group_index[g] * PRIMS_PER_GROUP;
    uint end = min(begin + PRIMS_PER_GROUP, t.start + t.count);
    // Each thread takes a contiguous chunk, so the scan keeps the order.
    uint chunk_begin = min(begin + lid * PRIMS_PER_THREAD, end);
    uint chunk_end = min(chunk_begin + PRIMS_PER_THREAD, end);
    uint nl = 0;
#if BUILD_WG == 1
    // One work-item takes the whole group, and its own bins already say how
    // many of its triangles go left: no counting pass over the triangles.
    if (s.axis >= 0) {
        __global const Bin* mine = group_bins + g * 3 * BINS + s.axis * BINS;
        for (uint b = 0; b < s.position; ++b) nl += mine[b].count;
    } else
#endif
    {
        for (uint p = chunk_begin; p < chunk_end; ++p) {
            PrimRef r = refs_in[p];
            nl += (uint)goes_left(t, s, r.lo, r.hi, ids_in[p]);
        }
    }
    uint n = chunk_end - chunk_begin;
    // Left and right counts travel packed in one word (each is at most 512).
    uint total;
    uint before = wg_exclusive_scan(((n - nl) << 16) | nl, s_scan, lid, BUILD_WG, &total);
    if (lid == 0) s_base = reserve(cursors, ti, total & 0xFFFFu, total >> 16);
    barrier(CLK_LOCAL_MEM_FENCE);
    uint left_slot = t.start + s_base.x + (before & 0xFFFFu);
    uint right_rank = s_base.y + (before >> 16);
    uint last = t.start + t.count - 1;
    for (uint p = chunk_begin; p < chunk_end; ++p) {
        uint id = ids_in[p];
        PrimRef r = refs_in[p];
        uint slot = goes_left(t, s, r.lo, r.hi, id) ? left_slot++ : last - right_rank++;
        ids_out[slot] = id;
        refs_out[slot] = r;
    }
}

// Copies each finished range (first slot, count) from buffer pair b's ids
// into pair a's, one work-group a range. Boxes are not needed after the build.
__kernel __attribute__((reqd_work_group_size(BUILD_WG, 1, 1)))
void gather_ranges(__global const uint2* ranges, __global const uint* ids_b,
                   __global uint* ids_a) {
    uint2 range = ranges[get_group_id(0)];
    for (uint p = range.x + get_local_id(0); p < range.x + range.y; p += BUILD_WG) ids_a[p] = ids_b[p];
}

#if SMALL_WG == 1
// One small node by one work-item: binned straight from global memory and
// partitioned in place from both ends (the order inside each side is free:
// only the sides' contents matter, and one work-item is deterministic).
inline void split_small_node_single_lane(uint g, BuildTask t, __global uint* ids,
                                         __global PrimRef* refs, __global SplitResult* splits,
                                         __global ulong* cursors, __local Bin* s_bins,
                                         __local float* s_cost, __local int* s_idx) {
    Bin acc[3 * BINS];
    for (uint i = 0; i < 3 * BINS; ++i) acc[i] = bin_empty();
    uint end = t.start + t.count;
    for (uint p = t.start; p < end; ++p) bin_direct(t, ids[p], refs[p], acc);
    for (uint i = 0; i < 3 * BINS; ++i) s_bins[i] = acc[i];
    int best = select_split(s_bins, t.scale, s_cost, s_idx, 0, 1);
    SplitResult s = make_split(s_bins, t, best);
    uint lo = t.start;
    uint hi = end;  // [lo, hi) is still undecided
    while (lo < hi) {
        PrimRef r = refs[lo];
        uint id = ids[lo];
        if (goes_left(t, s, r.lo, r.hi, id)) {
            ++lo;
        } else {
            --hi;
            refs[lo] = refs[hi];
            ids[lo] = ids[hi];
            refs[hi] = r;
            ids[hi] = id;
        }
    }
    s.left_count = lo - t.start;
    s.right_count = end - lo;
    splits[g] = s;
    cursors[g] = ((ulong)s.right_count << 32) | (ulong)s.left_count;
}
#endif

// One small node: binned, split and partitioned by one work-group.
inline void split_small_node(uint g, __global const BuildTask* tasks, __global uint* ids_a,
                             __global PrimRef* refs_a, __global uint* ids_b,
                             __global PrimRef* refs_b, __global SplitResult* splits,
                             __global ulong* cursors, __local float4* s_lo, __local float4* s_hi,
                             __local uint* s_bin, __local uint* s_id, __local uchar* s_left,
                             __local Bin* s_bins, __local float* s_cost, __local int* s_idx,
                             __local uint* s_scan) {
    uint lid = get_local_id(0);
    BuildTask t = tasks[g];
    __global uint* ids = IDS(t);
    __global PrimRef* refs = REFS(t);
#if SMALL_WG == 1
    split_small_node_single_lane(g, t, ids, refs, splits, cursors, s_bins, s_cost, s_idx);
    return;
#endif
    for (uint k = lid; k < t.count; k += SMALL_WG) {
        stage_prim(true, t.start + k, t.cmin, t.scale, ids, refs, s_lo, s_hi, s_bin, s_id, k);
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    // SMALL_WG / BIN_LANES groups of lanes take turns over the blocks.
    uint group_of_lanes = lid / BIN_LANES;
    uint lane = lid % BIN_LANES;
    Bin acc[3 * OWNED];
    for (uint i = 0; i < 3 * OWNED; ++i) acc[i] = bin_empty();
    for (uint base = group_of_lanes * BIN_LANES; base < t.count; base += SMALL_WG) {
        bin_block(base, t.count, lane, s_lo, s_hi, s_bin, s_id, acc);
    }
    store_lane_bins(acc, lane, s_bins + group_of_lanes * 3 * BINS);
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint i = lid; i < 3 * BINS; i += SMALL_WG) {
        for (uint h = 1; h < SMALL_WG / BIN_LANES; ++h) s_bins[i] = bin_merge(s_bins[i], s_bins[h * 3 * BINS + i]);
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    int best = select_split(s_bins, t.scale, s_cost, s_idx, lid, SMALL_WG);
    SplitResult s = make_split(s_bins, t, best);

    // Each thread partitions one contiguous chunk, so the scan keeps order.
    uint chunk = (t.count + SMALL_WG - 1) / SMALL_WG;
    uint begin = min(lid * chunk, t.count);
    uint end = min(begin + chunk, t.count);
    uint nl = 0;
    for (uint k = begin; k < end; ++k) {
        bool left = goes_left(t, s, s_lo[k], s_hi[k], s_id[k]);
        s_left[k] = (uchar)left;
        nl += (uint)left;
    }
    uint total;
    uint before = wg_exclusive_scan(((end - begin - nl) << 16) | nl, s_scan, lid, SMALL_WG, &total);
    uint left_slot = t.start + (before & 0xFFFFu);
    uint right_rank = before >> 16;
    uint last = t.start + t.count - 1;
    for (uint k = begin; k < end; ++k) {
        uint slot = s_left[k] ? left_slot++ : last - right_rank++;
        ids[slot] = s_id[k];
        refs[slot].lo = s_lo[k];
        refs[slot].hi = s_hi[k];
    }
    if (lid == 0) {
        s.left_count = total & 0xFFFFu;
        s.right_count = total >> 16;
        splits[g] = s;
        cursors[g] = ((ulong)s.right_count << 32) | (ulong)s.left_count;
    }
}

__kernel __attribute__((reqd_work_group_size(SMALL_WG, 1, 1)))
void split_small(__global const BuildTask* tasks, __global uint* ids_a,
                 __global PrimRef* refs_a, __global uint* ids_b, __global PrimRef* refs_b,
                 __global SplitResult* splits,
                 __global ulong* cursors) {
    __local float4 s_lo[SMALL_MAX];
    __local float4 s_hi[SMALL_MAX];
    __local uint s_bin[SMALL_MAX];
    __local uint s_id[SMALL_MAX];
    __local uchar s_left[SMALL_MAX];
    __local Bin s_bins[3 * BINS * (SMALL_WG / BIN_LANES)];
    __local float s_cost[3];
    __local int s_idx[3];
    __local uint s_scan[SMALL_WG];
    split_small_node(get_group_id(0), tasks, ids_a, refs_a, ids_b, refs_b, splits, cursors, s_lo,
                     s_hi, s_bin, s_id, s_left, s_bins, s_cost, s_idx, s_scan);
}
