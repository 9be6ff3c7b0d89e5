// Part of trace.cl and pathtrace.cl: the wide layouts' triangles in leaf
// order, made once per frame after the collapse (src/trace/wide.rs; its
// Rust twin is `wide::leaf_arrays`). The collapse numbers each leaf's
// blocks of four slots (`LeafBlock`: the slots' first entry of the tree's
// primitive-index array and how many of the four are used); a slot past a
// leaf's last triangle repeats that triangle, as the four-lane test's
// unused lanes do.
#ifndef SOUPRAY_LEAF_GATHER_H
#define SOUPRAY_LEAF_GATHER_H

#pragma OPENCL FP_CONTRACT OFF

// One work-item per block: `leaf_prims[4 b + i]` is slot i's triangle and,
// with `with_tris` (no motion blur), `leaf_tris[9 b + 3 v + a]` lane i is
// coordinate a of its vertex v, as `leaf_intersect4` loads them, or NaN
// for a degenerate triangle, which the lane test then never hits: the
// test need not check each triangle's normal per ray. The collapse checked
// every block (count 1..=4, within the primitive-index array).
__kernel void leaf_gather(__global const LeafBlock* blocks, uint block_count,
                          __global const uint* prim_ids,
                          __global const float* positions, uint with_tris,
                          __global uint* leaf_prims, __global float4* leaf_tris) {
    uint b = get_global_id(0);
    if (b >= block_count) return;
    LeafBlock k = blocks[b];
    uint q[4];
    for (uint i = 0u; i < 4u; ++i) {
        q[i] = prim_ids[k.first + min(i, k.count - 1u)];
        leaf_prims[4u * b + i] = q[i];
    }
    if (with_tris == 0u) return;
    int4 flat = (int4)(CORNERS_DEGENERATE(positions + (size_t)q[0] * 12u) ? -1 : 0,
                       CORNERS_DEGENERATE(positions + (size_t)q[1] * 12u) ? -1 : 0,
                       CORNERS_DEGENERATE(positions + (size_t)q[2] * 12u) ? -1 : 0,
                       CORNERS_DEGENERATE(positions + (size_t)q[3] * 12u) ? -1 : 0);
    for (uint v = 0u; v < 3u; ++v) {
        for (uint a = 0u; a < 3u; ++a) {
            uint o = 4u * v + a;
            float4 c =
                (float4)(positions[(size_t)q[0] * 12u + o], positions[(size_t)q[1] * 12u + o],
                         positions[(size_t)q[2] * 12u + o], positions[(size_t)q[3] * 12u + o]);
            leaf_tris[9u * b + 3u * v + a] = select(c, (float4)(as_float(LEAF_FLAT_BITS)), flat);
        }
    }
}

#endif
