//! The full-sweep SAH builder: the quality reference binned builds are
//! measured against. At every node it tries every split between
//! centroid-sorted neighbours on all three axes, not just bin boundaries.
//!
//! Centroids are sorted once per axis; each split then stably partitions the
//! three orders, so every level costs O(N) and the build O(N log N). It uses
//! the same termination rule as the binned builders (a node of more than
//! `leaf_size` triangles is always split), so SAH costs compare like for like.

use super::binned::{centroid, prim_refs};
use super::layout::PrimRef;
use super::{Aabb, BuildParams, Bvh, BvhNode, Child};
use crate::soup::Soup;

fn ref_box(r: &PrimRef) -> Aabb {
    Aabb {
        lo: [r.lo[0], r.lo[1], r.lo[2]],
        hi: [r.hi[0], r.hi[1], r.hi[2]],
    }
}

/// Builds the full-sweep SAH tree of `soup`.
pub fn build(soup: &Soup, params: BuildParams) -> Bvh {
    let refs = prim_refs(soup);
    let n = refs.len();
    let mut nodes = vec![BvhNode::empty()];
    if n == 0 {
        return Bvh {
            nodes,
            prim_ids: Vec::new(),
        };
    }
    let cents: Vec<[f32; 4]> = refs.iter().map(centroid).collect();
    // Ties broken by index, so the build is deterministic.
    let mut orders: [Vec<u32>; 3] = std::array::from_fn(|a| {
        let mut o: Vec<u32> = (0..n as u32).collect();
        o.sort_by(|&x, &y| {
            cents[x as usize][a]
                .total_cmp(&cents[y as usize][a])
                .then(x.cmp(&y))
        });
        o
    });
    let bounds_of = |ids: &[u32]| {
        ids.iter()
            .fold(Aabb::EMPTY, |b, &i| b.union(&ref_box(&refs[i as usize])))
    };

    let leaf = params.leaf_size as usize;
    let root_box = bounds_of(&orders[0]);
    if n <= leaf {
        nodes[0].set_left(
            Child::Leaf {
                first: 0,
                count: n as u32,
            },
            root_box,
        );
        return Bvh {
            nodes,
            prim_ids: orders[0].clone(),
        };
    }
    let mut goes_left = vec![false; n];
    let mut right_areas = vec![0f64; n];
    let mut scratch = Vec::with_capacity(n);
    // (node index, start, end): the node's triangles are orders[a][start..end].
    let mut stack = vec![(0u32, 0usize, n)];
    while let Some((node, start, end)) = stack.pop() {
        let count = end - start;
        let mut best: Option<(f64, usize, usize)> = None; // (cost, axis, left count)
        for (a, order) in orders.iter().enumerate() {
            let slice = &order[start..end];
            let mut b = Aabb::EMPTY;
            for k in (1..count).rev() {
                b = b.union(&ref_box(&refs[slice[k] as usize]));
                right_areas[k] = b.area();
            }
            let mut b = Aabb::EMPTY;
            for k in 1..count {
                b = b.union(&ref_box(&refs[slice[k - 1] as usize]));
                let cost = b.area() * k as f64 + right_areas[k] * (count - k) as f64;
                if best.is_none_or(|(c, _, _)| cost < c) {
                    best = Some((cost, a, k));
                }
            }
        }
        let (_, axis, left_count) = best.expect("a node of two or more triangles has a split");
        for (k, &id) in orders[axis][start..end].iter().enumerate() {
            goes_left[id as usize] = k < left_count;
        }
        for (a, order) in orders.iter_mut().enumerate() {
            if a == axis {
                continue;
            }
            scratch.clear();
            scratch.extend(
                order[start..end]
                    .iter()
                    .filter(|&&id| goes_left[id as usize]),
            );
            scratch.extend(
                order[start..end]
                    .iter()
                    .filter(|&&id| !goes_left[id as usize]),
            );
            order[start..end].copy_from_slice(&scratch);
        }
        let mid = start + left_count;
        for (side, (s, e)) in [(start, mid), (mid, end)].into_iter().enumerate() {
            let bounds = bounds_of(&orders[0][s..e]);
            let child = if e - s <= leaf {
                Child::Leaf {
                    first: s as u32,
                    count: (e - s) as u32,
                }
            } else {
                let index = nodes.len() as u32;
                nodes.push(BvhNode::empty());
                stack.push((index, s, e));
                Child::Inner(index)
            };
            if side == 0 {
                nodes[node as usize].set_left(child, bounds);
            } else {
                nodes[node as usize].set_right(child, bounds);
            }
        }
    }
    Bvh {
        nodes,
        prim_ids: std::mem::take(&mut orders[0]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::test_util::random_soup;
    use crate::bvh::{binned, sah_cost, validate};

    #[test]
    fn sweep_is_valid_and_no_worse_than_binned() {
        for (n, seed) in [(1usize, 7u64), (4, 8), (9, 9), (3000, 10)] {
            let soup = random_soup(n, 0.02, seed);
            let params = BuildParams::default();
            let sweep = build(&soup, params);
            validate(&sweep, &soup, 4).unwrap();
            let binned = binned::build(&soup, params).unwrap();
            assert!(
                sah_cost(&sweep) <= sah_cost(&binned) * 1.02,
                "{} vs {}",
                sah_cost(&sweep),
                sah_cost(&binned)
            );
        }
    }
}
