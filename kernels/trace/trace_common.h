// Ray-triangle intersection and BVH traversal, shared by the trace kernels
// and (through #include) the later shading kernels. Every function here has a
// line-for-line Rust twin in src/trace/intersect.rs and src/trace/traverse.rs:
// the same float operations in the same order, with FMA contraction off, so
// that the device agrees with the CPU reference bit for bit.
//
// Intersection: Woop, Benthin and Wald, "Watertight Ray/Triangle
// Intersection" (JCGT 2013). The three 2D edge functions are computed in
// float; rounding is monotonic, so a non-zero value always has the exact
// sign, and an exact 0.0 is resolved with the products' FMA rounding errors
// (no doubles needed, which not every GPU has). A ray through a shared edge
// or vertex exactly is given to one triangle only, by a top-left rule on the
// orientation-normalised edge: no cracks and no double hits.
//
// The signs decide coverage; the magnitudes give t and the barycentrics.
// Each edge function is a difference of two products of ray-space
// coordinates, rounded at 2^-24 of the products, not of the difference: for a
// sliver (aspect ratio 1e5 and up) or a triangle seen almost edge-on the
// products dwarf the doubled area and the barycentrics and t lose most of
// their digits (hit points a unit off along a 250-long sliver, shadow rays
// re-hitting the plane they leave). When the products' sum exceeds the
// determinant by more than ILL_CONDITIONED, the edge functions and t are
// recomputed in double from the same float inputs: the products of floats
// are exact in double, so the values are accurate and have the same signs
// as the float ones (coverage, and so watertightness, is unchanged). Ordinary
// triangles never take that path. Without cl_khr_fp64 (or with
// SOUPRAY_NO_FP64 defined) the float values are kept: hits are the same, but
// slivers shade less accurately and no longer match the CPU reference,
// which always takes the double path.
//
// Boxes: the slab test with near/far planes chosen by the direction's sign
// bit (so -0 and +0 both work, and 0 * inf = NaN from a ray lying in a slab
// plane is ignored by the max and min), and the far distance scaled by 1 + 2*gamma(3)
// (Ize, "Robust BVH Ray Traversal", JCGT 2013) so a box is never missed by
// rounding.
#ifndef SOUPRAY_TRACE_COMMON_H
#define SOUPRAY_TRACE_COMMON_H

#pragma OPENCL FP_CONTRACT OFF

// The compiler defines cl_khr_fp64 exactly when the device supports it.
#if defined(cl_khr_fp64) && !defined(SOUPRAY_NO_FP64)
#pragma OPENCL EXTENSION cl_khr_fp64 : enable
#define SOUPRAY_FP64 1
#endif

#include "bvh_types.h"
#include "trace_types.h"

#ifndef STACK_SIZE
#define STACK_SIZE 96
#endif

// 1 + 2 * gamma(3), gamma(n) = n u / (1 - n u), u = 2^-24, rounded up to a
// float: 2 gamma(3) is a little over 3 * 2^-23, so 1 + 4 * 2^-23 (exact).
#define BOX_FAR_SCALE (1.0f + 4.0f * FLT_EPSILON)
// A box is culled only when it starts clearly beyond the closest hit so far:
// the margin (2^-16 relative) covers the rounding of both the box's entry
// distance and the triangle's t, so a triangle at the same t with a smaller
// index is never culled away and ties resolve the same in every tree.
#define CULL_SCALE (1.0f + 1.0f / 65536.0f)
#define NO_NODE 0xFFFFFFFFu
// The float edge functions' error is about 2^-24 of the products' sum, so
// below this ratio of determinant to that sum the barycentrics would carry
// an error above 2^-12 relative, and t one of 2^-12 of the vertices' depths:
// recompute them in double. Ordinary triangles stay far above it (the ratio
// is about the inverse of the aspect ratio times the obliquity).
#define ILL_CONDITIONED (1.0f / 4096.0f)

// Motion blur (compiled only with MOTION_BLUR, for frames where something
// moves within the shutter). `positions` (and the shading normals) then hold
// the soup at each of the shutter's motion steps, one soup after another
// (12 floats per triangle per step), and every triangle is read at the ray's
// time: linearly between the two steps around it. The tree's boxes enclose
// each triangle at every step, so they enclose it at every time in between.
// Without MOTION_BLUR the macros below are the single-soup reads, so a
// static frame compiles exactly the code it did before. Rust twin:
// src/trace/motion.rs.
#ifdef MOTION_BLUR
typedef struct {
    uint step;   // the step at or before the ray's time
    float frac;  // where the time lies between it and the next, in [0, 1)
    size_t at0;  // float offset of that step's soup
    size_t at1;  // and of the next step's
} MotionTime;

// The steps around shutter time `time` in [0, 1) of `steps` >= 2 evenly
// spaced steps (step 0 at the shutter's opening, the last at its closing).
inline MotionTime motion_time(float time, uint steps, uint triangles) {
    float x = time * (float)(steps - 1u);
    uint k = min((uint)x, steps - 2u);
    MotionTime m;
    m.step = k;
    m.frac = x - (float)k;
    m.at0 = (size_t)k * (size_t)triangles * 12u;
    m.at1 = m.at0 + (size_t)triangles * 12u;
    return m;
}

// Triangle `prim`'s 12 floats (three xyzw corners) at time `m`.
inline void motion_triangle(const __global float* data, MotionTime m, uint prim, float* p) {
    const __global float* a = data + m.at0 + (size_t)prim * 12u;
    const __global float* b = data + m.at1 + (size_t)prim * 12u;
    for (uint i = 0u; i < 12u; ++i) p[i] = a[i] + m.frac * (b[i] - a[i]);
}

#define GEOM_DECL(name) const __global float* name, MotionTime mt
#define GEOM_ARGS(name, m) name, m
#define TRI_LOAD(p, data, m, prim) float p[12]; motion_triangle(data, m, prim, p)
#else
#define GEOM_DECL(name) const __global float* name
#define GEOM_ARGS(name, m) name
#define TRI_LOAD(p, data, m, prim) const __global float* p = (data) + (size_t)(prim) * 12u
#endif

// A ray prepared for traversal: the box test's reciprocals and near-plane
// choice, and the watertight test's axis permutation and shear.
typedef struct {
    float ox, oy, oz;
    float ix, iy, iz;
    int nx, ny, nz;      // 1 when that direction component's sign bit is set
    int kx, ky, kz;      // kz: the dominant axis; (kx, ky) keep the winding
    float okx, oky, okz; // the origin, permuted
    float sx, sy, sz;    // the shear
    float tmin, tmax;
} RayPre;

// Prepares `ray`; false for an all-zero (or NaN) direction, which hits nothing.
__attribute__((always_inline)) inline bool ray_prepare(RayPre* r, Ray ray) {
    float d[3] = {ray.dir[0], ray.dir[1], ray.dir[2]};
    float o[3] = {ray.org[0], ray.org[1], ray.org[2]};
    float ax = fabs(d[0]), ay = fabs(d[1]), az = fabs(d[2]);
    int kz = (ax >= ay && ax >= az) ? 0 : (ay >= az ? 1 : 2);
    if (d[kz] == 0.0f || isnan(d[kz])) return false;
    int kx = kz == 2 ? 0 : kz + 1;
    int ky = kx == 2 ? 0 : kx + 1;
    if (d[kz] < 0.0f) { int s = kx; kx = ky; ky = s; }
    r->ox = o[0]; r->oy = o[1]; r->oz = o[2];
    r->ix = 1.0f / d[0]; r->iy = 1.0f / d[1]; r->iz = 1.0f / d[2];
    r->nx = signbit(d[0]) ? 1 : 0;
    r->ny = signbit(d[1]) ? 1 : 0;
    r->nz = signbit(d[2]) ? 1 : 0;
    r->kx = kx; r->ky = ky; r->kz = kz;
    r->okx = o[kx]; r->oky = o[ky]; r->okz = o[kz];
    r->sx = d[kx] / d[kz];
    r->sy = d[ky] / d[kz];
    r->sz = 1.0f / d[kz];
    r->tmin = ray.tmin;
    r->tmax = ray.tmax;
    return true;
}

// max(a, m) and min(a, m) that return m where a is NaN, for an m that is
// never NaN: fmax and fmin then agree with them (a slab's NaN, 0 x inf from
// a ray parallel to it starting on its plane, leaves the others to decide),
// but cost one instruction where fmax is three on x86 (maxps, then a
// compare and blend for NaNs), and a chain of them needs no NaN checks.
#define MAX_NAN_KEEPS(a, m) ((a) > (m) ? (a) : (m))
#define MIN_NAN_KEEPS(a, m) ((a) < (m) ? (a) : (m))

// The slab test's entry `tn` and exit `tf` (of type T, float or a vector)
// from the per-axis near and far distances: the near planes' max with tmin,
// the far planes' min scaled by BOX_FAR_SCALE, NaN distances ignored.
#define SLAB_SPAN(T, tn, tf, nx, ny, nz, fx, fy, fz, tmin)                       \
    T tn = (T)(tmin);                                                            \
    tn = MAX_NAN_KEEPS(nx, tn);                                                  \
    tn = MAX_NAN_KEEPS(ny, tn);                                                  \
    tn = MAX_NAN_KEEPS(nz, tn);                                                  \
    T tf = (T)(INFINITY);                                                        \
    tf = MIN_NAN_KEEPS(fx, tf);                                                  \
    tf = MIN_NAN_KEEPS(fy, tf);                                                  \
    tf = MIN_NAN_KEEPS(fz, tf) * BOX_FAR_SCALE

// The entry distance of the box [lo, hi], or INFINITY when the ray misses it
// or enters it beyond `best` (the closest hit so far).
inline float box_entry(const RayPre* r, float lo0, float lo1, float lo2,
                       float hi0, float hi1, float hi2, float best) {
    float tnx = ((r->nx ? hi0 : lo0) - r->ox) * r->ix;
    float tny = ((r->ny ? hi1 : lo1) - r->oy) * r->iy;
    float tnz = ((r->nz ? hi2 : lo2) - r->oz) * r->iz;
    float tfx = ((r->nx ? lo0 : hi0) - r->ox) * r->ix;
    float tfy = ((r->ny ? lo1 : hi1) - r->oy) * r->iy;
    float tfz = ((r->nz ? lo2 : hi2) - r->oz) * r->iz;
    SLAB_SPAN(float, tn, tf, tnx, tny, tnz, tfx, tfy, tfz, r->tmin);
    return (tn <= tf && tn <= best * CULL_SCALE) ? tn : INFINITY;
}

// The 2D edge function of the directed edge P->Q at the origin,
// qx*py - qy*px, with an exact 0.0 resolved from the products' rounding
// errors: its sign is then exact, and it is 0.0 only when the origin lies
// exactly on the edge's line.
inline float edge_function(float px, float py, float qx, float qy) {
    float a = qx * py;
    float b = qy * px;
    float e = a - b;
    if (e == 0.0f) {
        float ea = fma(qx, py, -a);
        float eb = fma(qy, px, -b);
        e = ea - eb;
    }
    return e;
}

// The top-left rule for an edge the ray passes through exactly: with the
// triangle's orientation normalised (det > 0), the edge is owned when it
// points up, or right when horizontal. Two triangles on either side of a
// shared edge see it in opposite directions, so exactly one owns it.
inline bool owns_edge(float px, float py, float qx, float qy, float det) {
    if (det < 0.0f) {
        float tx = px, ty = py;
        px = qx; py = qy; qx = tx; qy = ty;
    }
    return qy > py || (qy == py && qx > px);
}

// Whether triangle (a, b, c) has an exactly zero geometric normal
// (b - a) x (c - a): the products of intersect::is_degenerate, on floats or
// on float4 lanes (then -1 in each degenerate lane).
#define ZERO_NORMAL(ax, ay, az, bx, by, bz, cx, cy, cz)                            \
    (((((by) - (ay)) * ((cz) - (az)) - ((bz) - (az)) * ((cy) - (ay))) == 0.0f) &  \
     ((((bz) - (az)) * ((cx) - (ax)) - ((bx) - (ax)) * ((cz) - (az))) == 0.0f) &  \
     ((((bx) - (ax)) * ((cy) - (ay)) - ((by) - (ay)) * ((cx) - (ax))) == 0.0f))

// ZERO_NORMAL of the 12-float corners `p` (xyz of each corner at 4k).
#define CORNERS_DEGENERATE(p) ZERO_NORMAL((p)[0], (p)[1], (p)[2], (p)[4], (p)[5], (p)[6], \
                                          (p)[8], (p)[9], (p)[10])

// Intersects triangle `prim` (corners at positions[12*prim + 4*k], xyz).
// Returns true with t, u, v when it is hit within (tmin, tmax); degenerate
// triangles (exactly zero geometric normal) are never hit.
__attribute__((always_inline)) inline bool intersect_triangle(const RayPre* r, GEOM_DECL(positions),
                               uint prim, float* t_out, float* u_out, float* v_out) {
    TRI_LOAD(p, positions, mt, prim);
    int kx = r->kx, ky = r->ky, kz = r->kz;
    float az_ = p[kz] - r->okz;
    float bz_ = p[4 + kz] - r->okz;
    float cz_ = p[8 + kz] - r->okz;
    float ax = (p[kx] - r->okx) - r->sx * az_;
    float ay = (p[ky] - r->oky) - r->sy * az_;
    float bx = (p[4 + kx] - r->okx) - r->sx * bz_;
    float by = (p[4 + ky] - r->oky) - r->sy * bz_;
    float cx = (p[8 + kx] - r->okx) - r->sx * cz_;
    float cy = (p[8 + ky] - r->oky) - r->sy * cz_;
    float u = edge_function(bx, by, cx, cy);
    float v = edge_function(cx, cy, ax, ay);
    float w = edge_function(ax, ay, bx, by);
    if ((u < 0.0f || v < 0.0f || w < 0.0f) && (u > 0.0f || v > 0.0f || w > 0.0f))
        return false;
    float det = u + v + w;
    if (det == 0.0f) return false;
    if (u == 0.0f && !owns_edge(bx, by, cx, cy, det)) return false;
    if (v == 0.0f && !owns_edge(cx, cy, ax, ay, det)) return false;
    if (w == 0.0f && !owns_edge(ax, ay, bx, by, det)) return false;
    float az = r->sz * az_;
    float bz = r->sz * bz_;
    float cz = r->sz * cz_;
    float t, bu, bv;
#ifdef SOUPRAY_FP64
    // The products' magnitudes, as edge_function forms them.
    float mag = fabs(cx * by) + fabs(cy * bx) + fabs(ax * cy) + fabs(ay * cx) +
                fabs(bx * ay) + fabs(by * ax);
    if (fabs(det) < mag * ILL_CONDITIONED) {
        // Exact products, one rounding per difference: same signs as u, v,
        // w (both exact), so det_d is non-zero like det.
        double u_d = (double)cx * (double)by - (double)cy * (double)bx;
        double v_d = (double)ax * (double)cy - (double)ay * (double)cx;
        double w_d = (double)bx * (double)ay - (double)by * (double)ax;
        double det_d = u_d + v_d + w_d;
        double tt_d = u_d * (double)az + v_d * (double)bz + w_d * (double)cz;
        t = (float)(tt_d / det_d);
        bu = (float)(v_d / det_d);
        bv = (float)(w_d / det_d);
    } else
#endif
    {
        float tt = u * az + v * bz + w * cz;
        float rcp = 1.0f / det;
        t = tt * rcp;
        bu = v * rcp;
        bv = w * rcp;
    }
    if (!(t > r->tmin && t < r->tmax)) return false;
    // Degenerate triangles: their projected area may round to non-zero, so
    // they are recognised in 3D, only for the few candidates that get here.
    if (CORNERS_DEGENERATE(p)) return false;
    *t_out = t;
    *u_out = bu;
    *v_out = bv;
    return true;
}

// Keeps the closest hit; at equal t the smaller triangle index wins, so the
// result is the same whatever order the tree visits triangles in.
inline void closest_update(Hit* best, uint prim, float t, float u, float v) {
    if (t < best->t || (t == best->t && prim < best->prim)) {
        best->t = t;
        best->prim = prim;
        best->u = u;
        best->v = v;
    }
}

// Up to four of a leaf's triangles, [first, first + count) with count
// 2..=4, intersected at once: intersect_triangle's float operations, in the
// same order, on four lanes (the same values bit for bit, FMA contraction
// being off). A lane is decided here when its three edge functions are
// non-zero: `hit` has bit i set when the i-th triangle is hit within
// (tmin, tmax), with its t, u and v in the lanes. The rare lanes that need
// intersect_triangle's other paths (an edge function exactly 0.0, so the
// top-left rule or the FMA correction; an ill-conditioned triangle, whose
// values come from double) have their bit set in `exact` instead, for the
// caller to give to intersect_triangle. A lane whose non-zero edge
// functions have opposite signs is a miss whatever those paths would do,
// since a non-zero edge function has the exact sign. So the hits are those
// of intersect_triangle, bit for bit, and there is no Rust twin to keep.
// Unused lanes repeat the last triangle and are masked off.
//
// The wide layouts give the leaf's triangles laid out for this test
// (`tris`, made by `leaf_gather` for each frame): a leaf starts at a slot
// that is a multiple of four, and each four slots have their three
// vertices' coordinates as nine `float4`s, axis by axis, lane i the slot's
// triangle, so that a lane vector is one aligned load instead of four
// gathered from the soup through the primitive-index array. The values are
// the soup's, so the hits are the same bit for bit. The binary and
// stackless traversals, and every traversal with motion blur (whose
// vertices are interpolated per ray), pass no `tris` and gather.
typedef struct {
    float4 t, u, v;
    uint hit, exact;
} LeafHits4;

// The four-lane test and ray_prepare are always inlined: in the path
// tracer's large kernel PoCL's compiler kept them as calls, the test
// returning its LeafHits4 through memory. The path tracer also inlines the
// leaf functions that call it (LEAF_INLINE, defined by pathtrace.cl): the
// interior of the Cycles comparison takes 0.945x the time per frame with
// all of them inlined, and inlining the leaf functions too is 0.981x of
// inlining the test and set-up alone. The trace kernels leave the leaf
// functions to the compiler: forced into the eight leaf sites of the
// unrolled node scan, their rays took 1.01-1.06x the time (shadow rays up
// to 1.36x), where the test and set-up alone took 0.94-1.04x. lane_hit,
// which a leaf function calls once per lane to decide, is always inlined
// into it: called, it was passed the whole LeafHits4 through the stack for
// each lane, and closest hits took 1.00-1.05x the time.
#ifndef LEAF_INLINE
#define LEAF_INLINE
#endif
//
// Bit i set where lane i of the comparison mask `m` is true.
inline uint lane_bits(int4 m) {
    return (m.x ? 1u : 0u) | (m.y ? 2u : 0u) | (m.z ? 4u : 0u) | (m.w ? 8u : 0u);
}

__attribute__((always_inline)) inline LeafHits4 leaf_intersect4(const RayPre* r, const __global uint* prim_ids,
                                 const __global float4* tris, GEOM_DECL(positions), uint first,
                                 uint count) {
    int kx = r->kx, ky = r->ky, kz = r->kz;
    float4 pax, pay, paz, pbx, pby, pbz, pcx, pcy, pcz;
    // Lanes of degenerate triangles, never hit. The leaf blocks hold NaN
    // for them (leaf_gather), which no lane test passes; triangles read from
    // the soup are checked here, by their 3D normal: in the permuted axes its
    // components are the same products, so each is +-0 exactly when
    // intersect_triangle's is.
    int4 flat = (int4)(0);
#ifndef MOTION_BLUR
    if (tris != 0) {
        const __global float4* b = tris + (size_t)(first >> 2) * 9u;
        pax = b[kx], pay = b[ky], paz = b[kz];
        pbx = b[3 + kx], pby = b[3 + ky], pbz = b[3 + kz];
        pcx = b[6 + kx], pcy = b[6 + ky], pcz = b[6 + kz];
    } else
#endif
    {
        uint last = count - 1u;
        uint q0 = prim_ids[first], q1 = prim_ids[first + 1u];
        uint q2 = prim_ids[first + min(2u, last)], q3 = prim_ids[first + min(3u, last)];
        TRI_LOAD(p0, positions, mt, q0);
        TRI_LOAD(p1, positions, mt, q1);
        TRI_LOAD(p2, positions, mt, q2);
        TRI_LOAD(p3, positions, mt, q3);
#define LANES(o) ((float4)(p0[o], p1[o], p2[o], p3[o]))
        pax = LANES(kx), pay = LANES(ky), paz = LANES(kz);
        pbx = LANES(4 + kx), pby = LANES(4 + ky), pbz = LANES(4 + kz);
        pcx = LANES(8 + kx), pcy = LANES(8 + ky), pcz = LANES(8 + kz);
#undef LANES
        flat = ZERO_NORMAL(pax, pay, paz, pbx, pby, pbz, pcx, pcy, pcz);
    }
    float4 az_ = paz - r->okz;
    float4 bz_ = pbz - r->okz;
    float4 cz_ = pcz - r->okz;
    float4 ax = (pax - r->okx) - r->sx * az_;
    float4 ay = (pay - r->oky) - r->sy * az_;
    float4 bx = (pbx - r->okx) - r->sx * bz_;
    float4 by = (pby - r->oky) - r->sy * bz_;
    float4 cx = (pcx - r->okx) - r->sx * cz_;
    float4 cy = (pcy - r->oky) - r->sy * cz_;
    float4 u = cx * by - cy * bx;
    float4 v = ax * cy - ay * cx;
    float4 w = bx * ay - by * ax;
    int4 lanes = (int4)(0, 1, 2, 3) < (int4)((int)count);
    int4 outside = ((u < 0.0f) | (v < 0.0f) | (w < 0.0f)) & ((u > 0.0f) | (v > 0.0f) | (w > 0.0f));
    int4 candidate = lanes & ~outside;
    int4 zero = (u == 0.0f) | (v == 0.0f) | (w == 0.0f);
    int4 exact = candidate & zero;
    // All three non-zero and of one sign: det is non-zero.
    int4 here = candidate & ~zero;
    float4 det = u + v + w;
#ifdef SOUPRAY_FP64
    float4 mag = fabs(cx * by) + fabs(cy * bx) + fabs(ax * cy) + fabs(ay * cx) +
                 fabs(bx * ay) + fabs(by * ax);
    int4 ill = fabs(det) < mag * ILL_CONDITIONED;
    exact |= here & ill;
    here &= ~ill;
#endif
    float4 az = r->sz * az_;
    float4 bz = r->sz * bz_;
    float4 cz = r->sz * cz_;
    float4 tt = u * az + v * bz + w * cz;
    float4 rcp = 1.0f / det;
    LeafHits4 h;
    h.t = tt * rcp;
    h.u = v * rcp;
    h.v = w * rcp;
    here &= (h.t > r->tmin) & (h.t < r->tmax) & ~flat;
    h.hit = lane_bits(here);
    h.exact = lane_bits(exact);
    return h;
}

inline float lane4(float4 x, uint i) {
    return i == 0u ? x.x : (i == 1u ? x.y : (i == 2u ? x.z : x.w));
}

// Lane i of `h`, triangle `prim`: its hit as leaf_intersect4 decided it,
// or, for a lane it left to the one-triangle test, as intersect_triangle
// decides it.
__attribute__((always_inline)) inline bool lane_hit(const RayPre* r, GEOM_DECL(positions), LeafHits4 h, uint i, uint prim,
                     float* t, float* u, float* v) {
    if ((h.hit >> i) & 1u) {
        *t = lane4(h.t, i);
        *u = lane4(h.u, i);
        *v = lane4(h.v, i);
        return true;
    }
    return intersect_triangle(r, GEOM_ARGS(positions, mt), prim, t, u, v);
}

// LEAF_HITS(ON_HIT): runs ON_HIT with `prim`, `t`, `u` and `v` for each
// triangle of the leaf [first, first + count) the ray hits, in the leaf's
// order. Leaves of more than one triangle are intersected four at a time
// (leaf_intersect4); a single triangle, and the lanes it leaves undecided,
// by intersect_triangle.
#define LEAF_HITS(ON_HIT)                                                         \
    uint end = first + count;                                                     \
    for (uint s = first; s < end; s += 4u) {                                      \
        uint n = min(end - s, 4u);                                                \
        LeafHits4 h;                                                              \
        if (n == 1u) {                                                            \
            h.hit = 0u;                                                           \
            h.exact = 1u;                                                         \
        } else {                                                                  \
            h = leaf_intersect4(r, prim_ids, tris, GEOM_ARGS(positions, mt), s, n); \
        }                                                                         \
        uint m = h.hit | h.exact;                                                 \
        while (m != 0u) {                                                         \
            uint i = 31u - clz(m & (0u - m));                                     \
            m &= m - 1u;                                                          \
            uint prim = prim_ids[s + i];                                          \
            float t, u, v;                                                        \
            if (lane_hit(r, GEOM_ARGS(positions, mt), h, i, prim, &t, &u, &v)) {  \
                ON_HIT                                                            \
            }                                                                     \
        }                                                                         \
    }

LEAF_INLINE inline void closest_leaf(const RayPre* r, const __global uint* prim_ids,
                         const __global float4* tris, GEOM_DECL(positions), uint first,
                         uint count, Hit* best) {
    LEAF_HITS(closest_update(best, prim, t, u, v);)
}

// The first hit in the leaf's order.
LEAF_INLINE inline bool any_leaf(const RayPre* r, const __global uint* prim_ids,
                     const __global float4* tris, GEOM_DECL(positions), uint first, uint count,
                     Hit* best) {
    LEAF_HITS(best->t = t; best->prim = prim; best->u = u; best->v = v; return true;)
    return false;
}

// The pieces every traversal below shares, as macros over the caller's
// `ray`, `prim_ids` and `positions`:
// RAY_START: the closest hit so far (none, at tmax) and the prepared ray;
// an all-zero direction returns at once.
#define RAY_START                                                                 \
    Hit best;                                                                     \
    best.t = ray.tmax; best.prim = MISS; best.u = 0.0f; best.v = 0.0f;            \
    RayPre r;                                                                     \
    if (!ray_prepare(&r, ray)) return best;
// STACK_START(SIZE): an empty stack of nodes and their entry distances, at
// the root.
#define STACK_START(SIZE)                                                         \
    uint stack_node[SIZE];                                                        \
    float stack_t[SIZE];                                                          \
    int sp = 0;                                                                   \
    uint node = 0;
// VISIT_LEAF: intersects a leaf whose box the ray hits; any-hit returns at
// its first hit.
#define VISIT_LEAF(ANY, first, count)                                             \
    if (ANY) {                                                                    \
        if (any_leaf(&r, prim_ids, tris, GEOM_ARGS(positions, mt), first, count,   \
                     &best))                                                      \
            return best;                                                          \
    } else {                                                                      \
        closest_leaf(&r, prim_ids, tris, GEOM_ARGS(positions, mt), first, count,   \
                     &best);                                                      \
    }
// POP_NODE: the most recently stacked node that may still hold a closer hit
// goes into `node`; the traversal returns when none is left.
#define POP_NODE                                                                  \
    for (;;) {                                                                    \
        if (sp == 0) return best;                                                 \
        sp--;                                                                     \
        if (stack_t[sp] <= best.t * CULL_SCALE) break;                            \
    }                                                                             \
    node = stack_node[sp];

// Front-to-back stack traversal of the BVH2 (node 0 = root). Leaf children
// are intersected as soon as their box is hit; of the inner children the
// nearer is entered and the farther pushed with its entry distance, and
// skipped on pop if a closer hit has been found since. `ANY` stops at the
// first hit (shadow rays). The stack holds at most one entry per tree level,
// and the host refuses trees deeper than STACK_SIZE.
#define TRAVERSE_BODY(ANY)                                                        \
    RAY_START                                                                     \
    STACK_START(STACK_SIZE)                                                       \
    for (;;) {                                                                    \
        const __global BvhNode* n = nodes + node;                                 \
        float tl = box_entry(&r, n->left_min[0], n->left_min[1], n->left_min[2],  \
                             n->left_max[0], n->left_max[1], n->left_max[2],      \
                             best.t);                                             \
        float tr = box_entry(&r, n->right_min[0], n->right_min[1], n->right_min[2], \
                             n->right_max[0], n->right_max[1], n->right_max[2],   \
                             best.t);                                             \
        uint c0 = n->left_child, n0 = n->left_count;                              \
        uint c1 = n->right_child, n1 = n->right_count;                            \
        if (tr < tl) {                                                            \
            float ts = tl; tl = tr; tr = ts;                                      \
            uint cs = c0; c0 = c1; c1 = cs;                                       \
            uint ns = n0; n0 = n1; n1 = ns;                                       \
        }                                                                         \
        uint next = NO_NODE;                                                      \
        if (tl != INFINITY) {                                                     \
            if (n0 > 0) {                                                         \
                VISIT_LEAF(ANY, c0, n0)                                           \
            } else {                                                              \
                next = c0;                                                        \
            }                                                                     \
        }                                                                         \
        if (tr != INFINITY && tr <= best.t * CULL_SCALE) {                        \
            if (n1 > 0) {                                                         \
                VISIT_LEAF(ANY, c1, n1)                                           \
            } else if (next == NO_NODE) {                                         \
                next = c1;                                                        \
            } else {                                                              \
                stack_node[sp] = c1;                                              \
                stack_t[sp] = tr;                                                 \
                sp++;                                                             \
            }                                                                     \
        }                                                                         \
        if (next != NO_NODE) {                                                    \
            node = next;                                                          \
            continue;                                                             \
        }                                                                         \
        POP_NODE                                                                  \
    }

// The closest hit of `ray` (prim == MISS when none).
inline Hit trace_closest_bvh(const __global BvhNode* nodes, const __global uint* prim_ids,
                             GEOM_DECL(positions), Ray ray) {
    const __global float4* tris = 0; // gathered from the soup
    TRAVERSE_BODY(0)
}

// Any hit of `ray` within (tmin, tmax): prim != MISS means occluded.
inline Hit trace_any_bvh(const __global BvhNode* nodes, const __global uint* prim_ids,
                         GEOM_DECL(positions), Ray ray) {
    const __global float4* tris = 0; // gathered from the soup
    TRAVERSE_BODY(1)
}

// box_entry for the W boxes of a W-wide node at once (W = 4 or 8), lane by
// lane the same operations, so the same W results. A node stores `lo` as
// its first 3W floats and `hi` as the next 3W, axis by axis; the near and
// far planes are loaded from the offsets the ray's direction signs pick,
// rather than both loaded and one selected.
#define BOX_ENTRY_WIDE(W, NODE)                                                   \
    inline float##W box_entry_wide##W(const RayPre* r, const __global NODE* n,    \
                                      float best) {                               \
        const __global float* f = (const __global float*)n;                       \
        int nx = r->nx * 3 * W, ny = r->ny * 3 * W + W, nz = r->nz * 3 * W + 2 * W; \
        int fx = 3 * W - r->nx * 3 * W, fy = 4 * W - r->ny * 3 * W;               \
        int fz = 5 * W - r->nz * 3 * W;                                           \
        float##W tnx = (vload##W(0, f + nx) - r->ox) * r->ix;                     \
        float##W tny = (vload##W(0, f + ny) - r->oy) * r->iy;                     \
        float##W tnz = (vload##W(0, f + nz) - r->oz) * r->iz;                     \
        float##W tfx = (vload##W(0, f + fx) - r->ox) * r->ix;                     \
        float##W tfy = (vload##W(0, f + fy) - r->oy) * r->iy;                     \
        float##W tfz = (vload##W(0, f + fz) - r->oz) * r->iz;                     \
        SLAB_SPAN(float##W, tn, tf, tnx, tny, tnz, tfx, tfy, tfz, r->tmin);      \
        int##W hit = (tn <= tf) & (tn <= (float##W)(best * CULL_SCALE));          \
        return select((float##W)(INFINITY), tn, hit);                             \
    }
BOX_ENTRY_WIDE(4, WideNode)
BOX_ENTRY_WIDE(8, Wide8Node)

// box_entry_wide8 for a quantized node (`Wide8QNode`): each plane decoded
// as origin + q * scale (the product exact, the sum rounded once, as the
// host's `quantized::decode`, which chose the bytes so that the decoded box
// contains the slot's), then the same test. The planes are bytes, `qlo` then
// `qhi`, axis by axis, so the sign-picked offsets are those of the float
// layout. Absent slots (child EMPTY_CHILD) decode to a box: they are masked.
inline float8 box_entry_wide8q(const RayPre* r, const __global Wide8QNode* n, float best) {
    const __global uchar* q = (const __global uchar*)n->qlo;
    int nx = r->nx * 24, ny = r->ny * 24 + 8, nz = r->nz * 24 + 16;
    int fx = 24 - r->nx * 24, fy = 32 - r->ny * 24, fz = 40 - r->nz * 24;
    float8 ox = (float8)(n->origin[0]), oy = (float8)(n->origin[1]), oz = (float8)(n->origin[2]);
    float8 sx = (float8)(n->scale[0]), sy = (float8)(n->scale[1]), sz = (float8)(n->scale[2]);
    float8 tnx = ((ox + convert_float8(vload8(0, q + nx)) * sx) - r->ox) * r->ix;
    float8 tny = ((oy + convert_float8(vload8(0, q + ny)) * sy) - r->oy) * r->iy;
    float8 tnz = ((oz + convert_float8(vload8(0, q + nz)) * sz) - r->oz) * r->iz;
    float8 tfx = ((ox + convert_float8(vload8(0, q + fx)) * sx) - r->ox) * r->ix;
    float8 tfy = ((oy + convert_float8(vload8(0, q + fy)) * sy) - r->oy) * r->iy;
    float8 tfz = ((oz + convert_float8(vload8(0, q + fz)) * sz) - r->oz) * r->iz;
    SLAB_SPAN(float8, tn, tf, tnx, tny, tnz, tfx, tfy, tfz, r->tmin);
    int8 present = vload8(0, n->child) != (uint8)(EMPTY_CHILD);
    int8 hit = (tn <= tf) & (tn <= (float8)(best * CULL_SCALE)) & present;
    return select((float8)(INFINITY), tn, hit);
}

// Front-to-back stack traversal of a W-wide layout (node 0 = root): the
// node's W boxes are tested, hit leaves intersected at once, and the hit
// inner children pushed with their entry distances, each inserted among
// this node's pushes so that the nearest ends on top; then the top is
// popped (an entry is skipped on pop if a closer hit has been found since).
// Sorting in place on the stack, as Embree does, rather than in a list of
// its own that is then copied onto it, took 0.93-0.99x the time
// (BENCHMARKS.md). The slots are scanned in a loop of constant length,
// unrolled (`#pragma unroll`): PoCL's compiler kept it rolled, and each slot's
// hit-or-miss branch then shared one entry of the branch predictor
// (unrolled, 0.89-0.94x the time; a loop over the set bits of a hit mask
// measured 1.03-1.3x slower). A node pushes at most W entries, one of which
// is popped at once, and a path holds at most one node per binary-tree
// level: the stack holds (W - 1) * STACK_SIZE + 1 entries. The nodes are
// `wnodes`, of type NODE.
#define TRAVERSE_WIDE_BODY(ANY, W, NODE) TRAVERSE_WIDE_BOXES(ANY, W, NODE, box_entry_wide##W)

// TRAVERSE_WIDE_BODY with the box test BOX (a box_entry_wide* function).
// Equal entry distances keep their scan order: the first scanned is
// popped first.
#define TRAVERSE_WIDE_BOXES(ANY, W, NODE, BOX)                                   \
    RAY_START                                                                     \
    STACK_START((W - 1) * STACK_SIZE + 1)                                         \
    for (;;) {                                                                    \
        const __global NODE* n = wnodes + node;                                   \
        int base = sp; /* this node's pushes start here */                        \
        float entries[W];                                                         \
        vstore##W(BOX(&r, n, best.t), 0, entries);                                \
        _Pragma("unroll")                                                         \
        for (uint c = 0; c < W; ++c) {                                            \
            float t = entries[c];                                                 \
            if (t == INFINITY) continue; /* missed, culled, or an empty slot */   \
            uint child = n->child[c], count = n->count[c];                        \
            if (count > 0) {                                                      \
                VISIT_LEAF(ANY, child, count)                                     \
                continue;                                                         \
            }                                                                     \
            int j = sp++;                                                         \
            while (j > base && stack_t[j - 1] <= t) {                             \
                stack_t[j] = stack_t[j - 1];                                      \
                stack_node[j] = stack_node[j - 1];                                \
                j--;                                                              \
            }                                                                     \
            stack_t[j] = t;                                                       \
            stack_node[j] = child;                                                \
        }                                                                         \
        POP_NODE                                                                  \
    }

// The wide traversals: `leaf_prims` and `tris` are the layout's triangles
// in leaf order (`leaf_gather`); with motion blur `tris` is unread.
// The closest hit of `ray` through the 4-wide layout.
inline Hit trace_closest_wide_bvh(const __global WideNode* wnodes,
                                  const __global uint* prim_ids, const __global float4* tris,
                                  GEOM_DECL(positions), Ray ray) {
    TRAVERSE_WIDE_BODY(0, 4, WideNode)
}

// Any hit of `ray` through the 4-wide layout.
inline Hit trace_any_wide_bvh(const __global WideNode* wnodes, const __global uint* prim_ids,
                              const __global float4* tris, GEOM_DECL(positions), Ray ray) {
    TRAVERSE_WIDE_BODY(1, 4, WideNode)
}

// The closest hit of `ray` through the 8-wide layout.
inline Hit trace_closest_wide8_bvh(const __global Wide8Node* wnodes,
                                   const __global uint* prim_ids, const __global float4* tris,
                                   GEOM_DECL(positions), Ray ray) {
    TRAVERSE_WIDE_BODY(0, 8, Wide8Node)
}

// Any hit of `ray` through the 8-wide layout.
inline Hit trace_any_wide8_bvh(const __global Wide8Node* wnodes, const __global uint* prim_ids,
                               const __global float4* tris, GEOM_DECL(positions), Ray ray) {
    TRAVERSE_WIDE_BODY(1, 8, Wide8Node)
}

// The closest hit of `ray` through the quantized 8-wide layout.
inline Hit trace_closest_wide8q_bvh(const __global Wide8QNode* wnodes,
                                    const __global uint* prim_ids, const __global float4* tris,
                                    GEOM_DECL(positions), Ray ray) {
    TRAVERSE_WIDE_BOXES(0, 8, Wide8QNode, box_entry_wide8q)
}

// Any hit of `ray` through the quantized 8-wide layout.
inline Hit trace_any_wide8q_bvh(const __global Wide8QNode* wnodes,
                                const __global uint* prim_ids, const __global float4* tris,
                                GEOM_DECL(positions), Ray ray) {
    TRAVERSE_WIDE_BOXES(1, 8, Wide8QNode, box_entry_wide8q)
}

// The closest hit by stackless traversal of the escape-index layout: entries
// in depth-first preorder, a hit inner entry continues with its first child
// (the next entry), a missed or finished one jumps to its escape index. The
// order is fixed (left first), not front to back.
inline Hit trace_closest_stackless_bvh(const __global StacklessNode* snodes, uint entries,
                                       const __global uint* prim_ids,
                                       GEOM_DECL(positions), Ray ray) {
    const __global float4* tris = 0; // gathered from the soup
    RAY_START
    uint i = 0;
    while (i < entries) {
        const __global StacklessNode* e = snodes + i;
        float t = box_entry(&r, e->lo[0], e->lo[1], e->lo[2], e->hi[0], e->hi[1], e->hi[2],
                            best.t);
        if (t == INFINITY) {
            i = e->escape;
        } else if (e->leaf != 0u) {
            closest_leaf(&r, prim_ids, tris, GEOM_ARGS(positions, mt), e->leaf >> LEAF_COUNT_BITS,
                         e->leaf & ((1u << LEAF_COUNT_BITS) - 1u), &best);
            i = e->escape;
        } else {
            i = i + 1u;
        }
    }
    return best;
}

// Wächter and Binder, "A Fast and Robust Method for Avoiding
// Self-Intersection" (Ray Tracing Gems, ch. 6): moves a hit point off its
// surface along the unit normal `n` (flip it to the side the new ray leaves
// from) by a fixed number of ulps, so the offset scales with the point's
// magnitude; near the origin, where ulps vanish, by a small fixed distance.
// That distance (and the "near") is `scale` times theirs: `offset_scale`.
inline float offset_component(float p, float n, float scale) {
    const float origin = scale * (1.0f / 32.0f);
    const float float_scale = scale * (1.0f / 65536.0f);
    const float int_scale = 256.0f;
    int of_i = (int)(int_scale * n);
    float p_i = as_float(as_int(p) + (p < 0.0f ? -of_i : of_i));
    return fabs(p) < origin ? p + float_scale * n : p_i;
}

inline float3 offset_ray_origin_scaled(float3 p, float3 n, float scale) {
    return (float3)(offset_component(p.x, n.x, scale), offset_component(p.y, n.y, scale),
                    offset_component(p.z, n.z, scale));
}

// The scale of the offsets from triangle `prim`: its largest coordinate
// magnitude, capped at 1. A hit point's error is a few ulps of that
// magnitude, so the fixed distance near the origin, sized for unit scenes,
// shrinks with it: a scene at 1e-4 is offset like the unit scene, scaled,
// instead of by a quarter of a sphere's radius. From 1 up it is 1 (the
// published constants, unchanged).
inline float offset_scale(GEOM_DECL(positions), uint prim) {
    TRI_LOAD(p, positions, mt, prim);
    float m = 0.0f;
    for (uint k = 0u; k < 3u; ++k) {
        m = fmax(m, fmax(fabs(p[4u * k]), fmax(fabs(p[4u * k + 1u]), fabs(p[4u * k + 2u]))));
    }
    return fmin(m, 1.0f);
}

// The hit point from the barycentrics (more precise than org + t * dir far
// from the origin) and the unit geometric normal (p1 - p0) x (p2 - p0).
inline float3 hit_point(GEOM_DECL(positions), uint prim, float u, float v) {
    TRI_LOAD(p, positions, mt, prim);
    float w = 1.0f - u - v;
    return (float3)(w * p[0] + u * p[4] + v * p[8], w * p[1] + u * p[5] + v * p[9],
                    w * p[2] + u * p[6] + v * p[10]);
}

inline float3 geometric_normal(GEOM_DECL(positions), uint prim) {
    TRI_LOAD(p, positions, mt, prim);
    float3 e1 = (float3)(p[4] - p[0], p[5] - p[1], p[6] - p[2]);
    float3 e2 = (float3)(p[8] - p[0], p[9] - p[1], p[10] - p[2]);
    return normalize(cross(e1, e2));
}

#endif
