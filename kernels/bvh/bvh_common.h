// The binned-SAH pieces, factored as in the Rust reference (src/bvh/binned.rs):
// bin mapping, bin accumulate/merge, candidate cost, best split, partition
// side. Both sides use the same operations in the same order, and
// contraction into FMA is off, so the device tree equals the reference tree
// bit for bit. Expects BINS (a power of two, 2..64) to be defined.
#ifndef SOUPRAY_BVH_COMMON_H
#define SOUPRAY_BVH_COMMON_H

#pragma OPENCL FP_CONTRACT OFF

#include "bvh_types.h"

#define INVALID_BINS 0xFFFFFFFFu

// Box minimum and maximum. Coordinates here are never NaN (the soup is
// checked finite), so the NaN rules of fmin/fmax, which cost a CPU two more
// instructions per call, buy nothing; a compare and select is one vminps.
// Where both are zeros of opposite sign either may come out, as with Rust's
// f32::min in the reference: the two compare equal, so no split changes.
inline float4 box_min(float4 a, float4 b) { return b < a ? b : a; }
inline float4 box_max(float4 a, float4 b) { return b > a ? b : a; }

inline Bin bin_empty(void) {
    Bin b;
    b.lo = (float4)(INFINITY);
    b.hi = (float4)(-INFINITY);
    b.clo = b.lo;
    b.chi = b.hi;
    b.count = 0;
    b.id_or = 0;
    b.id_and = 0xFFFFFFFFu;
    b.pad = 0;
    return b;
}

inline float4 centroid(float4 lo, float4 hi) { return (lo + hi) * 0.5f; }

inline void bin_add(Bin* b, float4 lo, float4 hi, float4 c, uint id) {
    b->lo = box_min(b->lo, lo);
    b->hi = box_max(b->hi, hi);
    b->clo = box_min(b->clo, c);
    b->chi = box_max(b->chi, c);
    b->count += 1;
    b->id_or |= id;
    b->id_and &= id;
}

inline Bin bin_merge(Bin a, Bin b) {
    Bin m;
    m.lo = box_min(a.lo, b.lo);
    m.hi = box_max(a.hi, b.hi);
    m.clo = box_min(a.clo, b.clo);
    m.chi = box_max(a.chi, b.chi);
    m.count = a.count + b.count;
    m.id_or = a.id_or | b.id_or;
    m.id_and = a.id_and & b.id_and;
    m.pad = 0;
    return m;
}

inline float axis_of(float4 v, int axis) { return axis == 0 ? v.x : (axis == 1 ? v.y : v.z); }

// The bin of centroid coordinate c. Clamped on both sides, so a mapping
// that rounds a hair outside [0, BINS) still lands in the first or last bin.
inline uint bin_index(float c, float cmin, float scale) {
    float f = (c - cmin) * scale;
    f = fmin(fmax(f, 0.0f), (float)(BINS - 1));
    return (uint)f;
}

// Half the surface area of a box (the factor 2 cancels in every SAH ratio).
inline float half_area(float4 lo, float4 hi) {
    float4 d = hi - lo;
    return d.x * d.y + d.y * d.z + d.z * d.x;
}

// The best split of a node from its 3 * BINS bins: the lowest SAH cost
// half_area(L) * N(L) + half_area(R) * N(R) over the candidates
// i = axis * BINS + position (left = the bins below `position`), and on equal
// cost the lowest i, which is what the reference's scan in candidate order
// picks. Threads 0..2 each sweep one axis (right to left for the right
// sides, then left to right), then the three axis winners are compared.
// -1 when no candidate has triangles on both sides. s_cost and s_idx hold
// three entries; all n threads must call it.
inline int select_split(__local const Bin* bins, float4 scale, __local float* s_cost,
                        __local int* s_idx, uint lid, uint n) {
    for (uint axis = lid; axis < 3; axis += n) {
        float best = 0.0f;
        int best_i = -1;
        if (axis_of(scale, (int)axis) > 0.0f) {
            float right_area[BINS];
            uint right_count[BINS];
            float4 lo = (float4)(INFINITY);
            float4 hi = (float4)(-INFINITY);
            uint count = 0;
            for (uint k = BINS - 1; k >= 1; --k) {
                Bin b = bins[axis * BINS + k];
                lo = box_min(lo, b.lo);
                hi = box_max(hi, b.hi);
                count += b.count;
                right_area[k] = half_area(lo, hi);
                right_count[k] = count;
            }
            lo = (float4)(INFINITY);
            hi = (float4)(-INFINITY);
            count = 0;
            for (uint k = 1; k < BINS; ++k) {
                Bin b = bins[axis * BINS + k - 1];
                lo = box_min(lo, b.lo);
                hi = box_max(hi, b.hi);
                count += b.count;
                if (count == 0 || right_count[k] == 0) continue;
                float cost = half_area(lo, hi) * (float)count + right_area[k] * (float)right_count[k];
                if (best_i < 0 || cost < best) {
                    best = cost;
                    best_i = (int)(axis * BINS + k);
                }
            }
        }
        s_cost[axis] = best;
        s_idx[axis] = best_i;
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    int chosen = -1;
    float chosen_cost = 0.0f;
    for (uint axis = 0; axis < 3; ++axis) {
        if (s_idx[axis] >= 0 && (chosen < 0 || s_cost[axis] < chosen_cost)) {
            chosen = s_idx[axis];
            chosen_cost = s_cost[axis];
        }
    }
    barrier(CLK_LOCAL_MEM_FENCE);
    return chosen;
}

// The split record for candidate `best`. With no candidate, the node is
// split by the highest bit in which its primitive ids differ: deterministic
// whatever order the atomics left the primitives in, never empty on either
// side, and at most 32 such splits in a row. Both children then inherit the
// node's bounds, and their counts come from the partition.
inline SplitResult make_split(__local const Bin* bins, BuildTask t, int best) {
    SplitResult s;
    if (best >= 0) {
        uint axis = (uint)best / BINS;
        uint position = (uint)best % BINS;
        Bin l = bin_empty();
        Bin r = bin_empty();
        for (uint k = 0; k < position; ++k) l = bin_merge(l, bins[axis * BINS + k]);
        for (uint k = position; k < BINS; ++k) r = bin_merge(r, bins[axis * BINS + k]);
        s.left_lo = l.lo;
        s.left_hi = l.hi;
        s.right_lo = r.lo;
        s.right_hi = r.hi;
        s.left_clo = l.clo;
        s.left_chi = l.chi;
        s.right_clo = r.clo;
        s.right_chi = r.chi;
        s.axis = (int)axis;
        s.position = position;
        s.left_count = l.count;
        s.right_count = r.count;
    } else {
        Bin all = bin_empty();
        for (uint k = 0; k < BINS; ++k) all = bin_merge(all, bins[k]);
        uint differ = all.id_or ^ all.id_and;
        s.left_lo = t.lo;
        s.left_hi = t.hi;
        s.right_lo = t.lo;
        s.right_hi = t.hi;
        s.left_clo = t.clo;
        s.left_chi = t.chi;
        s.right_clo = t.clo;
        s.right_chi = t.chi;
        s.axis = -1;
        s.position = differ == 0 ? 0 : 31 - clz(differ);
        s.left_count = 0;
        s.right_count = 0;
    }
    return s;
}

// Which side of split s a primitive goes to: the same bin mapping that binned it.
inline bool goes_left(BuildTask t, SplitResult s, float4 lo, float4 hi, uint id) {
    if (s.axis < 0) return ((id >> s.position) & 1u) == 0;
    float4 c = centroid(lo, hi);
    return bin_index(axis_of(c, s.axis), axis_of(t.cmin, s.axis), axis_of(t.scale, s.axis)) <
           s.position;
}

// Exclusive prefix sum of v over the n threads of a work-group (n a power
// of two); *total receives the sum over all of them.
inline uint wg_exclusive_scan(uint v, __local uint* tmp, uint lid, uint n, uint* total) {
    tmp[lid] = v;
    barrier(CLK_LOCAL_MEM_FENCE);
    for (uint offset = 1; offset < n; offset <<= 1) {
        uint add = lid >= offset ? tmp[lid - offset] : 0;
        barrier(CLK_LOCAL_MEM_FENCE);
        tmp[lid] += add;
        barrier(CLK_LOCAL_MEM_FENCE);
    }
    uint inclusive = tmp[lid];
    *total = tmp[n - 1];
    barrier(CLK_LOCAL_MEM_FENCE);
    return inclusive - v;
}

#endif
