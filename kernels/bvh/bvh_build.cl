// The per-frame binned-SAH BVH builder of Sopin, Bogolepov and Ulyanov
// (2011), level by level. The host keeps one queue per stage (large nodes of
// more than 32K triangles, medium of 256..32K, small under 256), launches
// every task of a level at once, reads back the splits and generates the
// next level's tasks. The small stage is one launch: each small node's
// work-group splits it and its descendants down to the leaves (see
// build_small below for why). Kernels, in launch order:
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
//   build_small                    small nodes: one work-group a node takes
//                                  it down to its leaves, all in one launch
//   pack_small_nodes               the small subtrees' nodes, packed
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
//   SMALL_WG            work-items of build_small's groups
//   LEAF_SIZE           largest leaf, in triangles
//   HAVE_INT64_ATOMICS  0/1
// On a GPU, BIN_LANES = BINS = 16 is the paper's half-warp scheme: the 16
// threads walk the same 16 triangles and each takes those in its bin, with
// no atomics and no bank conflicts. On a CPU, where work-items run one
// after another, that walk is 16 times the work; there BUILD_WG = BIN_LANES
// = SMALL_WG = 1, and the one work-item keeps all bins in private memory.
// Both mappings produce the same bins, bit for bit.
#pragma OPENCL FP_CONTRACT OFF

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

// ---- Small nodes: one work-group takes a node down to its leaves --------
//
// A small node (under SMALL_MAX triangles) is split, and so are its
// children, by the same work-group in the same launch, depth first. Its
// triangles stay in the work-group's local memory (or, single-lane, in the
// core's cache) for every level of its subtree instead of streaming through
// global memory once per level, and the host has no per-level bookkeeping
// for the hundreds of thousands of small nodes. Every split is the one a
// level-by-level pass would choose: the same bins, the same SAH search.
//
// The node continues with its smaller child and stacks the larger, so a
// stacked node is never smaller than the current one: with j entries on the
// stack the current node holds at most SMALL_MAX / 2^j triangles, and since
// only a node of two inner children (2 * (LEAF_SIZE + 1) >= 4 triangles)
// pushes, 8 entries are enough below 256 triangles.
#define SMALL_STACK 8

// The bin mapping's scale on one axis; bin_scale in src/bvh/binned.rs.
inline float bin_scale_axis(float clo, float chi) {
    float extent = chi - clo;
    float k = (float)BINS * 0.99999f / extent;
    return (extent > 0.0f && isfinite(k)) ? k : 0.0f;
}

// A task for slots start..start+count with the given bounds; make_task in
// src/bvh/binned.rs. Only the fields a small subtree reads are set.
inline BuildTask small_task(uint start, uint count, float4 lo, float4 hi, float4 clo, float4 chi,
                            uint source) {
    BuildTask t;
    t.cmin = clo;
    t.scale = (float4)(bin_scale_axis(clo.x, chi.x), bin_scale_axis(clo.y, chi.y),
                       bin_scale_axis(clo.z, chi.z), 0.0f);
    t.lo = lo;
    t.hi = hi;
    t.clo = clo;
    t.chi = chi;
    t.start = start;
    t.count = count;
    t.first_group = 0;
    t.group_count = 0;
    t.set_first = 0;
    t.set_count = 0;
    t.node = 0;
    t.source = source;
    return t;
}

// Writes one side of a node: a leaf of `count` slots from `start`, or the
// inner node `index` of the subtree (local numbering).
inline void set_side(BvhNode* node, bool right, bool leaf, uint start, uint count, uint index,
                     float4 lo, float4 hi) {
    uint child = leaf ? start : index;
    uint n = leaf ? count : 0u;
    if (right) {
        node->right_min[0] = lo.x;
        node->right_min[1] = lo.y;
        node->right_min[2] = lo.z;
        node->right_max[0] = hi.x;
        node->right_max[1] = hi.y;
        node->right_max[2] = hi.z;
        node->right_child = child;
        node->right_count = n;
    } else {
        node->left_min[0] = lo.x;
        node->left_min[1] = lo.y;
        node->left_min[2] = lo.z;
        node->left_max[0] = hi.x;
        node->left_max[1] = hi.y;
        node->left_max[2] = hi.z;
        node->left_child = child;
        node->left_count = n;
    }
}

#if SMALL_WG == 1
// Bit masks of a node's occupied bins, one per axis (bins are at most 64).
typedef ulong BinMask;

inline uint lowest_bin(BinMask m) { return 63 - (uint)clz(m & (~m + 1)); }

// select_split over the occupied bins only, for one work-item. The same
// answer: merging an empty bin changes no box or count, so a candidate
// after an empty bin costs exactly what the one before it costs, and the
// search keeps the lower index on a tie. Candidate j + 1 (left: the bins up
// to occupied bin j) is the first of each such run.
inline int select_split_occupied(__local const Bin* bins, const BinMask* occupied,
                                 float4 scale) {
    int chosen = -1;
    float chosen_cost = 0.0f;
    for (uint axis = 0; axis < 3; ++axis) {
        BinMask m = occupied[axis];
        if (!(axis_of(scale, (int)axis) > 0.0f) || popcount(m) < 2) continue;
        __local const Bin* row = bins + axis * BINS;
        float right_area[BINS];
        uint right_count[BINS];
        float4 lo = (float4)(INFINITY);
        float4 hi = (float4)(-INFINITY);
        uint count = 0;
        for (BinMask r = m; r != 0;) {
            uint k = 63 - (uint)clz(r);
            r &= ~((BinMask)1 << k);
            Bin b = row[k];
            lo = box_min(lo, b.lo);
            hi = box_max(hi, b.hi);
            count += b.count;
            right_area[k] = half_area(lo, hi);
            right_count[k] = count;
        }
        lo = (float4)(INFINITY);
        hi = (float4)(-INFINITY);
        count = 0;
        float best = 0.0f;
        int best_i = -1;
        BinMask l = m;
        uint k = lowest_bin(l);
        l &= l - 1;
        while (l != 0) {
            Bin b = row[k];
            lo = box_min(lo, b.lo);
            hi = box_max(hi, b.hi);
            count += b.count;
            uint next = lowest_bin(l);
            l &= l - 1;
            float cost = half_area(lo, hi) * (float)count + right_area[next] * (float)right_count[next];
            if (best_i < 0 || cost < best) {
                best = cost;
                best_i = (int)(axis * BINS + k + 1);
            }
            k = next;
        }
        if (best_i >= 0 && (chosen < 0 || best < chosen_cost)) {
            chosen = best_i;
            chosen_cost = best;
        }
    }
    return chosen;
}

// One node of a small subtree by one work-item, straight from global memory.
// Its bins keep only what the SAH search reads (box and count). A first
// pass finds each triangle's bins (kept for the partition) and which bins
// are occupied; only those are cleared and filled, without a branch per
// triangle. The children's boxes and centroid bounds, which make_split
// would take from the bins, are gathered while partitioning instead: the
// same minima and maxima over the same triangles, so the same values. The
// partition runs in place from both ends (the order inside each side is
// free). The counts are the partition's.
inline SplitResult split_small_node(BuildTask t, __global uint* ids, __global PrimRef* refs,
                                    __local Bin* s_bins, __local float* s_cost,
                                    __local int* s_idx, bool* mismatch) {
    uint packed[SMALL_MAX];
    BinMask occupied[3] = {0, 0, 0};
    uint end = t.start + t.count;
    for (uint i = 0; i < t.count; ++i) {
        PrimRef r = refs[t.start + i];
        float4 c = centroid(r.lo, r.hi);
        uint bx = bin_index(c.x, t.cmin.x, t.scale.x);
        uint by = bin_index(c.y, t.cmin.y, t.scale.y);
        uint bz = bin_index(c.z, t.cmin.z, t.scale.z);
        packed[i] = bx | (by << 8) | (bz << 16);
        occupied[0] |= (BinMask)1 << bx;
        occupied[1] |= (BinMask)1 << by;
        occupied[2] |= (BinMask)1 << bz;
    }
    for (uint a = 0; a < 3; ++a) {
        for (BinMask m = occupied[a]; m != 0; m &= m - 1) {
            __local Bin* bin = &s_bins[a * BINS + lowest_bin(m)];
            bin->lo = (float4)(INFINITY);
            bin->hi = (float4)(-INFINITY);
            bin->count = 0;
        }
    }
    for (uint i = 0; i < t.count; ++i) {
        PrimRef r = refs[t.start + i];
        uint p = packed[i];
        for (uint a = 0; a < 3; ++a) {
            __local Bin* bin = &s_bins[a * BINS + ((p >> (8 * a)) & 0xFFu)];
            bin->lo = box_min(bin->lo, r.lo);
            bin->hi = box_max(bin->hi, r.hi);
            bin->count += 1;
        }
    }
    int best = select_split_occupied(s_bins, occupied, t.scale);
    Bin empty = bin_empty();
    SplitResult s;
    uint binned_left = 0;
    if (best >= 0) {
        s.axis = best / BINS;
        s.position = best % BINS;
        for (BinMask m = occupied[s.axis] & (((BinMask)1 << s.position) - 1); m != 0; m &= m - 1) {
            binned_left += s_bins[s.axis * BINS + lowest_bin(m)].count;
        }
    } else {
        // No bin split: the id split of make_split.
        uint id_or = 0;
        uint id_and = 0xFFFFFFFFu;
        for (uint p = t.start; p < end; ++p) {
            id_or |= ids[p];
            id_and &= ids[p];
        }
        uint differ = id_or ^ id_and;
        s.axis = -1;
        s.position = differ == 0 ? 0 : 31 - clz(differ);
    }
    Bin left = empty;
    Bin right = empty;
    uint lo = t.start;
    uint hi = end;  // [lo, hi) is still undecided
    uint shift = s.axis >= 0 ? 8 * (uint)s.axis : 0;
    while (lo < hi) {
        PrimRef r = refs[lo];
        uint id = ids[lo];
        uint p = packed[lo - t.start];
        float4 c = centroid(r.lo, r.hi);
        // goes_left, from the bin found above
        bool go_left = s.axis >= 0 ? ((p >> shift) & 0xFFu) < s.position
                                   : ((id >> s.position) & 1u) == 0;
        if (go_left) {
            bin_add(&left, r.lo, r.hi, c, id);
            ++lo;
        } else {
            bin_add(&right, r.lo, r.hi, c, id);
            --hi;
            refs[lo] = refs[hi];
            ids[lo] = ids[hi];
            packed[lo - t.start] = packed[hi - t.start];
            refs[hi] = r;
            ids[hi] = id;
            packed[hi - t.start] = p;
        }
    }
    if (s.axis >= 0) {
        s.left_lo = left.lo;
        s.left_hi = left.hi;
        s.right_lo = right.lo;
        s.right_hi = right.hi;
        s.left_clo = left.clo;
        s.left_chi = left.chi;
        s.right_clo = right.clo;
        s.right_chi = right.chi;
    } else {
        // Both children of an id split inherit the node's bounds.
        s.left_lo = t.lo;
        s.left_hi = t.hi;
        s.right_lo = t.lo;
        s.right_hi = t.hi;
        s.left_clo = t.clo;
        s.left_chi = t.chi;
        s.right_clo = t.clo;
        s.right_chi = t.chi;
    }
    *mismatch = s.axis >= 0 && binned_left != lo - t.start;
    s.left_count = lo - t.start;
    s.right_count = end - lo;
    return s;
}
#else
// One node of a small subtree by the work-group, on the subtree's triangles
// staged in local memory (slot p of the subtree at index p - base): the
// paper's lane-wise counting, then a stable partition through t_* and back.
inline SplitResult split_small_node(BuildTask t, uint base, __local float4* s_lo,
                                    __local float4* s_hi, __local uint* s_id,
                                    __local uint* s_bin, __local uchar* s_left,
                                    __local float4* t_lo, __local float4* t_hi,
                                    __local uint* t_id, __local Bin* s_bins,
                                    __local float* s_cost, __local int* s_idx,
                                    __local uint* s_scan, bool* mismatch) {
    uint lid = get_local_id(0);
    uint first = t.start - base;
    uint n = t.count;
    for (uint k = first + lid; k < first + n; k += SMALL_WG) {
        float4 c = centroid(s_lo[k], s_hi[k]);
        uint bx = bin_index(c.x, t.cmin.x, t.scale.x);
        uint by = bin_index(c.y, t.cmin.y, t.scale.y);
        uint bz = bin_index(c.z, t.cmin.z, t.scale.z);
        s_bin[k] = bx | (by << 8) | (bz << 16);
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    // SMALL_WG / BIN_LANES groups of lanes take turns over the blocks.
    uint group_of_lanes = lid / BIN_LANES;
    uint lane = lid % BIN_LANES;
    Bin acc[3 * OWNED];
    for (uint i = 0; i < 3 * OWNED; ++i) acc[i] = bin_empty();
    for (uint b = group_of_lanes * BIN_LANES; b < n; b += SMALL_WG) {
        bin_block(first + b, first + n, lane, s_lo, s_hi, s_bin, s_id, acc);
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
    uint chunk = (n + SMALL_WG - 1) / SMALL_WG;
    uint begin = min(first + lid * chunk, first + n);
    uint end = min(begin + chunk, first + n);
    uint nl = 0;
    for (uint k = begin; k < end; ++k) {
        bool left = goes_left(t, s, s_lo[k], s_hi[k], s_id[k]);
        s_left[k] = (uchar)left;
        nl += (uint)left;
    }
    uint total;
    uint before = wg_exclusive_scan(((end - begin - nl) << 16) | nl, s_scan, lid, SMALL_WG, &total);
    uint left_slot = first + (before & 0xFFFFu);
    uint right_slot = first + (total & 0xFFFFu) + (before >> 16);
    for (uint k = begin; k < end; ++k) {
        uint slot = s_left[k] ? left_slot++ : right_slot++;
        t_lo[slot] = s_lo[k];
        t_hi[slot] = s_hi[k];
        t_id[slot] = s_id[k];
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint k = first + lid; k < first + n; k += SMALL_WG) {
        s_lo[k] = t_lo[k];
        s_hi[k] = t_hi[k];
        s_id[k] = t_id[k];
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    uint left = total & 0xFFFFu;
    uint right = total >> 16;
    *mismatch = s.axis >= 0 && (s.left_count != left || s.right_count != right);
    s.left_count = left;
    s.right_count = right;
    return s;
}
#endif

// One private stack entry: a node still to split.
typedef struct {
    BuildTask task;
    uint index;  // its index in the subtree's numbering
    uint depth;  // its depth below the small node
} SmallEntry;

// Every small node of the stage, one work-group each, down to the leaves.
// Nodes go to scratch[root.start + index] (a subtree of n triangles has at
// most n - LEAF_SIZE nodes, so subtrees never overlap); the summary to
// results[g]. Children are numbered as they are made, left before right, and
// the subtree is walked smaller child first; binned::build_small_subtree
// does the same, so the numbering matches the reference.
__kernel __attribute__((reqd_work_group_size(SMALL_WG, 1, 1)))
void build_small(__global const BuildTask* tasks, __global uint* ids_a,
                 __global PrimRef* refs_a, __global uint* ids_b, __global PrimRef* refs_b,
                 __global BvhNode* scratch, __global SmallSubtree* results) {
    __local Bin s_bins[3 * BINS * (SMALL_WG / BIN_LANES)];
    __local float s_cost[3];
    __local int s_idx[3];
    uint g = get_group_id(0);
    BuildTask root = tasks[g];
    __global uint* ids = IDS(root);
    __global PrimRef* refs = REFS(root);
#if SMALL_WG > 1
    __local float4 s_lo[SMALL_MAX];
    __local float4 s_hi[SMALL_MAX];
    __local uint s_id[SMALL_MAX];
    __local float4 t_lo[SMALL_MAX];
    __local float4 t_hi[SMALL_MAX];
    __local uint t_id[SMALL_MAX];
    __local uint s_bin[SMALL_MAX];
    __local uchar s_left[SMALL_MAX];
    __local uint s_scan[SMALL_WG];
    uint lid = get_local_id(0);
    for (uint k = lid; k < root.count; k += SMALL_WG) {
        PrimRef r = refs[root.start + k];
        s_lo[k] = r.lo;
        s_hi[k] = r.hi;
        s_id[k] = ids[root.start + k];
    }
    barrier(CLK_LOCAL_MEM_FENCE);
#endif
    __global BvhNode* out = scratch + root.start;
    SmallEntry stack[SMALL_STACK];
    uint sp = 0;
    BuildTask t = root;
    uint index = 0;
    uint depth = 0;
    uint next_local = 1;
    uint max_depth = 0;
    uint status = SMALL_OK;
    for (;;) {
        bool mismatch;
#if SMALL_WG == 1
        SplitResult s = split_small_node(t, ids, refs, s_bins, s_cost, s_idx, &mismatch);
#else
        SplitResult s = split_small_node(t, root.start, s_lo, s_hi, s_id, s_bin, s_left, t_lo,
                                         t_hi, t_id, s_bins, s_cost, s_idx, s_scan, &mismatch);
#endif
        if (mismatch) {
            status = SMALL_COUNT_MISMATCH;
            break;
        }
        if (s.left_count == 0 || s.right_count == 0) {
            status = SMALL_NO_PROGRESS;
            break;
        }
        uint left_local = 0;
        uint right_local = 0;
        bool left_inner = s.left_count > LEAF_SIZE;
        bool right_inner = s.right_count > LEAF_SIZE;
        if (left_inner) left_local = next_local++;
        if (right_inner) right_local = next_local++;
        if (!left_inner || !right_inner) max_depth = max(max_depth, depth + 1);
        BvhNode node;
        set_side(&node, false, !left_inner, t.start, s.left_count, left_local, s.left_lo,
                 s.left_hi);
        set_side(&node, true, !right_inner, t.start + s.left_count, s.right_count, right_local,
                 s.right_lo, s.right_hi);
#if SMALL_WG > 1
        if (lid == 0)
#endif
            out[index] = node;
        BuildTask left = small_task(t.start, s.left_count, s.left_lo, s.left_hi, s.left_clo,
                                    s.left_chi, t.source);
        BuildTask right = small_task(t.start + s.left_count, s.right_count, s.right_lo,
                                     s.right_hi, s.right_clo, s.right_chi, t.source);
        depth += 1;
        if (left_inner && right_inner) {
            if (sp == SMALL_STACK) {
                status = SMALL_STACK_FULL;
                break;
            }
            // The smaller goes on; on a tie the left.
            bool right_first = right.count < left.count;
            stack[sp].task = right_first ? left : right;
            stack[sp].index = right_first ? left_local : right_local;
            stack[sp].depth = depth;
            ++sp;
            t = right_first ? right : left;
            index = right_first ? right_local : left_local;
        } else if (left_inner) {
            t = left;
            index = left_local;
        } else if (right_inner) {
            t = right;
            index = right_local;
        } else {
            if (sp == 0) break;
            --sp;
            t = stack[sp].task;
            index = stack[sp].index;
            depth = stack[sp].depth;
        }
    }
#if SMALL_WG > 1
    for (uint k = lid; k < root.count; k += SMALL_WG) ids[root.start + k] = s_id[k];
    if (lid == 0)
#endif
    {
        SmallSubtree r;
        r.nodes = next_local;
        r.depth = max_depth;
        r.status = status;
        r.pad = 0;
        results[g] = r;
    }
}

// Copies each small subtree's nodes from the scratch array into one packed
// array, one work-group a subtree: subtree g's nodes go to
// out[offsets[g]..offsets[g + 1]] (the host sizes them from `results`).
__kernel __attribute__((reqd_work_group_size(BUILD_WG, 1, 1)))
void pack_small_nodes(__global const BuildTask* tasks, __global const uint* offsets,
                      __global const BvhNode* scratch, __global BvhNode* out) {
    uint g = get_group_id(0);
    uint n = offsets[g + 1] - offsets[g];
    __global const BvhNode* from = scratch + tasks[g].start;
    __global BvhNode* to = out + offsets[g];
    for (uint k = get_local_id(0); k < n; k += BUILD_WG) to[k] = from[k];
}
