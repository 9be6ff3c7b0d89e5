//! The watertight ray-triangle test (Woop, Benthin, Wald, "Watertight
//! Ray/Triangle Intersection", JCGT 2013), the robust slab test (Ize, "Robust
//! BVH Ray Traversal", JCGT 2013) and the self-intersection offset (Wächter,
//! Binder, Ray Tracing Gems ch. 6), on the CPU.
//!
//! Each function is the twin of the one of the same name in
//! `kernels/trace/trace_common.h`: the same float operations in the same order (Rust
//! never contracts into FMA), so the device's hits equal these bit for bit.
//! The comments there explain the numerics; the short version: edge
//! functions have exact signs (monotonic rounding, exact zeros resolved from
//! FMA rounding errors), exact zeros go to one triangle by a top-left rule,
//! and degenerate triangles (zero geometric normal) are never hit. The
//! magnitudes of ill-conditioned edge functions (slivers, near edge-on
//! views) are recomputed in f64, as the kernel does where the device has
//! `cl_khr_fp64`; a device without it matches these hits except there.

use super::Ray;

/// 1 + 2γ(3), γ(n) = n·u / (1 − n·u), u = 2⁻²⁴, rounded up to a float:
/// 2γ(3) is a little over 3·2⁻²³, so 1 + 4·2⁻²³ (exact, as in the kernel).
pub const BOX_FAR_SCALE: f32 = 1.0 + 4.0 * f32::EPSILON;
/// Boxes are culled only when they start beyond `best * CULL_SCALE`, so a
/// triangle at the closest t (or a hair before, by rounding) is never lost.
pub const CULL_SCALE: f32 = 1.0 + 1.0 / 65536.0;
/// Below this ratio of the determinant to the edge functions' products'
/// magnitudes, t and the barycentrics are computed in f64
/// (`ILL_CONDITIONED` in the kernel, which explains the choice).
pub const ILL_CONDITIONED: f32 = 1.0 / 4096.0;

/// A ray prepared for traversal (`RayPre` in the kernel).
#[derive(Clone, Copy, Debug)]
pub struct RayPre {
    pub o: [f32; 3],
    pub inv: [f32; 3],
    pub neg: [bool; 3],
    pub k: [usize; 3],
    pub ok: [f32; 3],
    pub s: [f32; 3],
    pub tmin: f32,
    pub tmax: f32,
}

impl RayPre {
    /// `None` for an all-zero (or NaN) direction, which hits nothing.
    pub fn new(ray: &Ray) -> Option<RayPre> {
        let d = ray.dir;
        let o = ray.org;
        let (ax, ay, az) = (d[0].abs(), d[1].abs(), d[2].abs());
        let kz = if ax >= ay && ax >= az {
            0
        } else if ay >= az {
            1
        } else {
            2
        };
        if d[kz] == 0.0 || d[kz].is_nan() {
            return None;
        }
        let mut kx = if kz == 2 { 0 } else { kz + 1 };
        let mut ky = if kx == 2 { 0 } else { kx + 1 };
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        Some(RayPre {
            o,
            inv: [1.0 / d[0], 1.0 / d[1], 1.0 / d[2]],
            neg: [
                d[0].is_sign_negative(),
                d[1].is_sign_negative(),
                d[2].is_sign_negative(),
            ],
            k: [kx, ky, kz],
            ok: [o[kx], o[ky], o[kz]],
            s: [d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]],
            tmin: ray.tmin,
            tmax: ray.tmax,
        })
    }

    /// The entry distance of the box `[lo, hi]`, or `INFINITY` when the ray
    /// misses it or enters it beyond `best` (`box_entry` in the kernel).
    #[inline(always)]
    pub fn box_entry(&self, lo: &[f32; 3], hi: &[f32; 3], best: f32) -> f32 {
        let near = |a: usize| (if self.neg[a] { hi[a] } else { lo[a] } - self.o[a]) * self.inv[a];
        let far = |a: usize| (if self.neg[a] { lo[a] } else { hi[a] } - self.o[a]) * self.inv[a];
        // f32::max/min ignore NaN like OpenCL's fmax/fmin: a ray lying in a
        // slab plane (0 * inf) puts no bound on that axis.
        let tn = near(0).max(near(1)).max(near(2).max(self.tmin));
        let tf = far(0).min(far(1)).min(far(2)) * BOX_FAR_SCALE;
        if tn <= tf && tn <= best * CULL_SCALE {
            tn
        } else {
            f32::INFINITY
        }
    }
}

/// `q.x * p.y - q.y * p.x`, with an exact zero resolved from the products'
/// rounding errors, so its sign is exact (`edge_function` in the kernel).
#[inline(always)]
pub fn edge_function(px: f32, py: f32, qx: f32, qy: f32) -> f32 {
    let a = qx * py;
    let b = qy * px;
    let e = a - b;
    if e == 0.0 {
        let ea = qx.mul_add(py, -a);
        let eb = qy.mul_add(px, -b);
        return ea - eb;
    }
    e
}

/// The top-left rule on the orientation-normalised edge P→Q.
#[inline(always)]
pub fn owns_edge(px: f32, py: f32, qx: f32, qy: f32, det: f32) -> bool {
    let (px, py, qx, qy) = if det < 0.0 {
        (qx, qy, px, py)
    } else {
        (px, py, qx, qy)
    };
    qy > py || (qy == py && qx > px)
}

/// A hit of one triangle: t and the barycentrics of corners 1 and 2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TriHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
}

/// Intersects triangle `prim` of `positions` (three `[x, y, z, _]` per
/// triangle) within `(tmin, tmax)`.
#[inline(always)]
pub fn intersect_triangle(r: &RayPre, positions: &[[f32; 4]], prim: u32) -> Option<TriHit> {
    let p = &positions[3 * prim as usize..3 * prim as usize + 3];
    let [kx, ky, kz] = r.k;
    let [okx, oky, okz] = r.ok;
    let [sx, sy, sz] = r.s;
    let az_ = p[0][kz] - okz;
    let bz_ = p[1][kz] - okz;
    let cz_ = p[2][kz] - okz;
    let ax = (p[0][kx] - okx) - sx * az_;
    let ay = (p[0][ky] - oky) - sy * az_;
    let bx = (p[1][kx] - okx) - sx * bz_;
    let by = (p[1][ky] - oky) - sy * bz_;
    let cx = (p[2][kx] - okx) - sx * cz_;
    let cy = (p[2][ky] - oky) - sy * cz_;
    let u = edge_function(bx, by, cx, cy);
    let v = edge_function(cx, cy, ax, ay);
    let w = edge_function(ax, ay, bx, by);
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    if u == 0.0 && !owns_edge(bx, by, cx, cy, det) {
        return None;
    }
    if v == 0.0 && !owns_edge(cx, cy, ax, ay, det) {
        return None;
    }
    if w == 0.0 && !owns_edge(ax, ay, bx, by, det) {
        return None;
    }
    let az = sz * az_;
    let bz = sz * bz_;
    let cz = sz * cz_;
    // The products' magnitudes, as `edge_function` forms them.
    let mag = (cx * by).abs()
        + (cy * bx).abs()
        + (ax * cy).abs()
        + (ay * cx).abs()
        + (bx * ay).abs()
        + (by * ax).abs();
    let (t, bu, bv) = if det.abs() < mag * ILL_CONDITIONED {
        // Exact products of floats, one rounding per difference: the same
        // signs as u, v, w, accurate magnitudes.
        let d = |x: f32| x as f64;
        let u_d = d(cx) * d(by) - d(cy) * d(bx);
        let v_d = d(ax) * d(cy) - d(ay) * d(cx);
        let w_d = d(bx) * d(ay) - d(by) * d(ax);
        let det_d = u_d + v_d + w_d;
        let tt_d = u_d * d(az) + v_d * d(bz) + w_d * d(cz);
        (
            (tt_d / det_d) as f32,
            (v_d / det_d) as f32,
            (w_d / det_d) as f32,
        )
    } else {
        let tt = u * az + v * bz + w * cz;
        let rcp = 1.0 / det;
        (tt * rcp, v * rcp, w * rcp)
    };
    if !(t > r.tmin && t < r.tmax) {
        return None;
    }
    if is_degenerate(positions, prim) {
        return None;
    }
    Some(TriHit { t, u: bu, v: bv })
}

/// Whether triangle `prim`'s geometric normal `(p1 - p0) × (p2 - p0)` is
/// exactly zero in float: repeated corners, collinear corners, zero area.
pub fn is_degenerate(positions: &[[f32; 4]], prim: u32) -> bool {
    let n = unnormalised_normal(positions, prim);
    n[0] == 0.0 && n[1] == 0.0 && n[2] == 0.0
}

fn unnormalised_normal(positions: &[[f32; 4]], prim: u32) -> [f32; 3] {
    let p = &positions[3 * prim as usize..3 * prim as usize + 3];
    let e1 = [p[1][0] - p[0][0], p[1][1] - p[0][1], p[1][2] - p[0][2]];
    let e2 = [p[2][0] - p[0][0], p[2][1] - p[0][1], p[2][2] - p[0][2]];
    [
        e1[1] * e2[2] - e1[2] * e2[1],
        e1[2] * e2[0] - e1[0] * e2[2],
        e1[0] * e2[1] - e1[1] * e2[0],
    ]
}

/// The unit geometric normal `(p1 - p0) × (p2 - p0)`, normalised.
pub fn geometric_normal(positions: &[[f32; 4]], prim: u32) -> [f32; 3] {
    let n = unnormalised_normal(positions, prim);
    // In f64 so that tiny triangles (1e-3 scenes) do not underflow.
    let len = (n.iter().map(|&c| c as f64 * c as f64).sum::<f64>()).sqrt();
    n.map(|c| (c as f64 / len) as f32)
}

/// The hit point from the barycentrics, which stays on the triangle far
/// from the origin, unlike `org + t * dir`.
pub fn hit_point(positions: &[[f32; 4]], prim: u32, u: f32, v: f32) -> [f32; 3] {
    let p = &positions[3 * prim as usize..3 * prim as usize + 3];
    let w = 1.0 - u - v;
    std::array::from_fn(|a| w * p[0][a] + u * p[1][a] + v * p[2][a])
}

/// Wächter and Binder's offset of one coordinate along the unit normal's
/// component `n`: a fixed number of ulps (so it scales with the magnitude of
/// `p`), or a small fixed distance near the origin where ulps vanish. That
/// distance, and what counts as near, are `scale` times theirs (see
/// [`offset_scale`]).
pub fn offset_component(p: f32, n: f32, scale: f32) -> f32 {
    let origin = scale * (1.0 / 32.0);
    let float_scale = scale * (1.0 / 65536.0);
    const INT_SCALE: f32 = 256.0;
    let of_i = (INT_SCALE * n) as i32;
    let p_i = f32::from_bits(
        (p.to_bits() as i32).wrapping_add(if p < 0.0 { -of_i } else { of_i }) as u32,
    );
    if p.abs() < origin {
        p + float_scale * n
    } else {
        p_i
    }
}

/// The scale of the offsets from triangle `prim`: its largest coordinate
/// magnitude, capped at 1. A hit point's error is a few ulps of that
/// magnitude, so the fixed distance near the origin (sized for unit scenes)
/// shrinks with it: a scene at 1e-4 is offset like the unit scene, scaled.
/// From 1 up the published constants apply unchanged.
pub fn offset_scale(positions: &[[f32; 4]], prim: u32) -> f32 {
    let p = &positions[3 * prim as usize..3 * prim as usize + 3];
    let mut m = 0.0f32;
    for c in p {
        m = m.max(c[0].abs().max(c[1].abs().max(c[2].abs())));
    }
    m.min(1.0)
}

/// A new ray's origin for a ray leaving the surface at `p` of a triangle
/// whose [`offset_scale`] is `scale`, on the side of the unit normal `n`
/// (flip `n` to the side the ray leaves from): it neither re-hits the
/// surface it starts on nor skips nearby geometry.
pub fn offset_ray_origin_scaled(p: [f32; 3], n: [f32; 3], scale: f32) -> [f32; 3] {
    std::array::from_fn(|a| offset_component(p[a], n[a], scale))
}

/// [`offset_ray_origin_scaled`] for triangles with a coordinate of
/// magnitude 1 or more (scale 1).
pub fn offset_ray_origin(p: [f32; 3], n: [f32; 3]) -> [f32; 3] {
    offset_ray_origin_scaled(p, n, 1.0)
}
