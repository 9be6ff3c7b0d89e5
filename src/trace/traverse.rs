//! The CPU reference traversals, twins of `TRAVERSE_BODY` and
//! `trace_closest_stackless_bvh` in `kernels/trace/trace_common.h`: closest hit and
//! any hit by front-to-back stack traversal, and closest hit by escape
//! indices. They visit nodes in the kernels' order and cull with the same
//! tests, so they agree with the device hit for hit; and because ties go to
//! the smaller triangle index, every traversal of every tree of the same soup
//! returns the same closest hit. `all_hits` (no culling) is for tests.

use super::escape::{StacklessNode, LEAF_COUNT_BITS};
use super::intersect::{intersect_triangle, RayPre, CULL_SCALE};
use super::wide::WideLayout;
use super::{Hit, Ray, TraceError, MISS};
use crate::bvh::{Bvh, Child, MAX_DEPTH};

/// The depth of `bvh` (root = 0, a leaf below the root = 1), or an error when
/// an inner node lies deeper than [`MAX_DEPTH`] (the limit `bvh::validate`
/// enforces), or when a child index is out of range or reached twice. The
/// device stack gets one entry per inner-node level, `STACK_SIZE =
/// MAX_DEPTH + 1`: a push happens at most once per node on the current path.
pub fn check_depth(bvh: &Bvh) -> Result<u32, TraceError> {
    if bvh.nodes.is_empty() {
        return Err(TraceError::Malformed("no root node".into()));
    }
    let mut seen = vec![false; bvh.nodes.len()];
    seen[0] = true;
    let mut stack = vec![(0u32, 0u32)];
    let mut depth = 0;
    while let Some((index, d)) = stack.pop() {
        let node = &bvh.nodes[index as usize];
        for (child, _) in [node.left(), node.right()] {
            match child {
                Child::Empty => {}
                Child::Leaf { first, count } => {
                    depth = depth.max(d + 1);
                    if first as usize + count as usize > bvh.prim_ids.len() {
                        return Err(TraceError::Malformed(format!(
                            "node {index} has a leaf past the primitive array"
                        )));
                    }
                }
                Child::Inner(c) => {
                    if d + 1 > MAX_DEPTH {
                        return Err(TraceError::TooDeep {
                            depth: d + 1,
                            max: MAX_DEPTH,
                        });
                    }
                    match seen.get_mut(c as usize) {
                        None => {
                            return Err(TraceError::Malformed(format!(
                                "node {index} has child {c} out of range"
                            )))
                        }
                        Some(s) if *s => {
                            return Err(TraceError::Malformed(format!("node {c} is reached twice")))
                        }
                        Some(s) => *s = true,
                    }
                    depth = depth.max(d + 1);
                    stack.push((c, d + 1));
                }
            }
        }
    }
    Ok(depth)
}

#[inline(always)]
fn closest_leaf(
    r: &RayPre,
    positions: &[[f32; 4]],
    prim_ids: &[u32],
    first: u32,
    count: u32,
    best: &mut Hit,
) {
    for &prim in &prim_ids[first as usize..(first + count) as usize] {
        if let Some(h) = intersect_triangle(r, positions, prim) {
            if h.t < best.t || (h.t == best.t && prim < best.prim) {
                *best = Hit {
                    t: h.t,
                    prim,
                    u: h.u,
                    v: h.v,
                };
            }
        }
    }
}

fn any_leaf(
    r: &RayPre,
    positions: &[[f32; 4]],
    prim_ids: &[u32],
    first: u32,
    count: u32,
    best: &mut Hit,
) -> bool {
    for &prim in &prim_ids[first as usize..(first + count) as usize] {
        if let Some(h) = intersect_triangle(r, positions, prim) {
            *best = Hit {
                t: h.t,
                prim,
                u: h.u,
                v: h.v,
            };
            return true;
        }
    }
    false
}

/// `VISIT_LEAF`: intersects a leaf whose box the ray hits. True when an
/// any-hit query has its answer in `best`.
#[inline(always)]
fn visit_leaf(
    r: &RayPre,
    positions: &[[f32; 4]],
    prim_ids: &[u32],
    (first, count): (u32, u32),
    any: bool,
    best: &mut Hit,
) -> bool {
    if any {
        any_leaf(r, positions, prim_ids, first, count, best)
    } else {
        closest_leaf(r, positions, prim_ids, first, count, best);
        false
    }
}

/// `POP_NODE`: the most recently stacked node that may still hold a closer
/// hit than `best`, or `None` when the traversal is done.
fn pop_node(stack: &mut Vec<(u32, f32)>, best: &Hit) -> Option<u32> {
    while let Some((c, t)) = stack.pop() {
        if t <= best.t * CULL_SCALE {
            return Some(c);
        }
    }
    None
}

fn traverse(bvh: &Bvh, positions: &[[f32; 4]], ray: &Ray, any: bool) -> Hit {
    let mut best = Hit::miss(ray.tmax);
    let Some(r) = RayPre::new(ray) else {
        return best;
    };
    // The device's stack is a fixed array of MAX_DEPTH entries; this one
    // grows, but `check_depth` bounds both the same way.
    let mut stack: Vec<(u32, f32)> = Vec::with_capacity(MAX_DEPTH as usize);
    let mut node = 0u32;
    loop {
        let n = &bvh.nodes[node as usize];
        let mut tl = r.box_entry(&n.left_min, &n.left_max, best.t);
        let mut tr = r.box_entry(&n.right_min, &n.right_max, best.t);
        let (mut c0, mut n0) = (n.left_child, n.left_count);
        let (mut c1, mut n1) = (n.right_child, n.right_count);
        if tr < tl {
            std::mem::swap(&mut tl, &mut tr);
            std::mem::swap(&mut c0, &mut c1);
            std::mem::swap(&mut n0, &mut n1);
        }
        let mut next = None;
        if tl != f32::INFINITY {
            if n0 > 0 {
                if visit_leaf(&r, positions, &bvh.prim_ids, (c0, n0), any, &mut best) {
                    return best;
                }
            } else {
                next = Some(c0);
            }
        }
        if tr != f32::INFINITY && tr <= best.t * CULL_SCALE {
            if n1 > 0 {
                if visit_leaf(&r, positions, &bvh.prim_ids, (c1, n1), any, &mut best) {
                    return best;
                }
            } else if next.is_none() {
                next = Some(c1);
            } else {
                stack.push((c1, tr));
            }
        }
        match next.or_else(|| pop_node(&mut stack, &best)) {
            Some(c) => node = c,
            None => return best,
        }
    }
}

/// The closest hit of `ray` in the tree `bvh` of the soup `positions`.
pub fn trace_closest(bvh: &Bvh, positions: &[[f32; 4]], ray: &Ray) -> Hit {
    traverse(bvh, positions, ray, false)
}

/// Any hit of `ray` within `(tmin, tmax)`; `prim != MISS` means occluded.
/// Which triangle is reported depends on the tree; occlusion does not.
pub fn trace_any(bvh: &Bvh, positions: &[[f32; 4]], ray: &Ray) -> Hit {
    traverse(bvh, positions, ray, true)
}

/// `TRAVERSE_WIDE_BODY`: front-to-back stack traversal of a W-wide layout.
/// Hit leaves are intersected in slot order as their boxes are tested; the
/// hit inner children are pushed, each inserted among this node's pushes
/// so that the nearest ends on top (equal distances in slot order, the
/// first on top, as the kernel's), and the top is popped next.
fn traverse_wide<N: WideLayout>(
    wnodes: &[N],
    prim_ids: &[u32],
    positions: &[[f32; 4]],
    ray: &Ray,
    any: bool,
) -> Hit {
    let mut best = Hit::miss(ray.tmax);
    let Some(r) = RayPre::new(ray) else {
        return best;
    };
    let mut stack: Vec<(u32, f32)> = Vec::with_capacity((N::WIDTH - 1) * MAX_DEPTH as usize + 1);
    let mut entries = vec![0.0f32; N::WIDTH];
    let mut node = 0usize;
    loop {
        let n = &wnodes[node];
        // Every entry first, against the closest hit on entry to the node,
        // as the kernel tests the node's boxes at once.
        for (c, e) in entries.iter_mut().enumerate() {
            let (lo, hi) = n.slot_box(c);
            *e = r.box_entry(&lo, &hi, best.t);
        }
        let base = stack.len();
        for (c, &t) in entries.iter().enumerate() {
            if t == f32::INFINITY {
                continue;
            }
            let (child, count) = n.child_count(c);
            if count > 0 {
                if visit_leaf(&r, positions, prim_ids, (child, count), any, &mut best) {
                    return best;
                }
                continue;
            }
            // Below every push of this node at t or nearer.
            let at = base
                + stack[base..]
                    .iter()
                    .position(|&(_, u)| u <= t)
                    .unwrap_or(stack.len() - base);
            stack.insert(at, (child, t));
        }
        match pop_node(&mut stack, &best) {
            Some(c) => node = c as usize,
            None => return best,
        }
    }
}

/// The closest hit through a W-wide layout (`wide::wide_layout_into`).
pub fn trace_closest_wide<N: WideLayout>(
    wnodes: &[N],
    prim_ids: &[u32],
    positions: &[[f32; 4]],
    ray: &Ray,
) -> Hit {
    traverse_wide(wnodes, prim_ids, positions, ray, false)
}

/// Any hit through a W-wide layout.
pub fn trace_any_wide<N: WideLayout>(
    wnodes: &[N],
    prim_ids: &[u32],
    positions: &[[f32; 4]],
    ray: &Ray,
) -> Hit {
    traverse_wide(wnodes, prim_ids, positions, ray, true)
}

/// The closest hit by stackless traversal of the escape-index layout.
pub fn trace_closest_stackless(
    snodes: &[StacklessNode],
    prim_ids: &[u32],
    positions: &[[f32; 4]],
    ray: &Ray,
) -> Hit {
    let mut best = Hit::miss(ray.tmax);
    let Some(r) = RayPre::new(ray) else {
        return best;
    };
    let mut i = 0usize;
    while i < snodes.len() {
        let e = &snodes[i];
        let t = r.box_entry(&e.lo, &e.hi, best.t);
        if t == f32::INFINITY {
            i = e.escape as usize;
        } else if e.leaf != 0 {
            closest_leaf(
                &r,
                positions,
                prim_ids,
                e.leaf >> LEAF_COUNT_BITS,
                e.leaf & ((1 << LEAF_COUNT_BITS) - 1),
                &mut best,
            );
            i = e.escape as usize;
        } else {
            i += 1;
        }
    }
    best
}

/// Every triangle `ray` hits within `(tmin, tmax)`, by brute force over the
/// soup, sorted by (t, triangle): for watertightness tests, which count the
/// surfaces a ray crosses.
pub fn all_hits(positions: &[[f32; 4]], ray: &Ray) -> Vec<Hit> {
    let Some(r) = RayPre::new(ray) else {
        return Vec::new();
    };
    let mut out: Vec<Hit> = (0..(positions.len() / 3) as u32)
        .filter_map(|prim| {
            intersect_triangle(&r, positions, prim).map(|h| Hit {
                t: h.t,
                prim,
                u: h.u,
                v: h.v,
            })
        })
        .collect();
    out.sort_by(|a, b| a.t.total_cmp(&b.t).then(a.prim.cmp(&b.prim)));
    debug_assert!(out.iter().all(|h| h.prim != MISS));
    out
}
