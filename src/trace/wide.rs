//! W-wide views of the frame's BVH for traversal (W = 8, the default, or
//! 4): each node of the paper's binary tree is collapsed with its largest
//! descendants into a node of up to W children whose boxes are stored axis
//! by axis. A ray then tests W boxes per node fetch, as the lanes of one
//! vector operation, and takes a half (4-wide) or a third (8-wide) as many
//! steps down the tree and through its stack. The tree's leaves, and so
//! the hits, are unchanged.
//!
//! Collapsing: a node starts with its two children and, while it has fewer
//! than W, replaces its inner child of largest surface area by that child's
//! two children (the children a ray is most likely to reach). Nodes are
//! numbered in the order they are made; node 0 is the root.
//!
//! An inner child left in a full node (the only kind with inner children
//! left) whose subtree holds at most `MERGED_LEAF_MAX` triangles becomes one
//! leaf of them instead of a node of its own. With the seed's leaves of up
//! to four triangles, two in five 8-wide nodes were such a subtree: two
//! leaves in a node of eight slots, a node's fetch and test to reach them.
//! The leaf's triangles are the same, so the hits are too.
//!
//! Leaves: the wide traversals read a leaf's triangles in leaf order, laid
//! out for the four-lane triangle test, instead of gathering them from the
//! soup through the primitive-index array. Each leaf gets whole blocks of
//! four slots (`LeafBlock`), numbered as the collapse meets them; a leaf
//! slot's `child` is its first slot, a multiple of four. `leaf_gather` in
//! `kernels/trace/leaf_gather.h` fills the slots' triangles and their
//! coordinates from each frame's soup on the device; `leaf_arrays` is its
//! Rust twin.

use super::intersect::is_degenerate;
use super::{TraceError, LEAF_FLAT_BITS};
use crate::bvh::{Aabb, Bvh, Child, EMPTY_CHILD};
use crate::device_struct::device_struct;
use bytemuck::{Pod, Zeroable};

device_struct! {
/// One 4-wide node (`WideNode` in `kernels/trace_types.h`): the boxes of its
/// up to four children, `lo[axis][slot]` and `hi[axis][slot]`, and per slot
/// `count == 0`: an inner node's index in `child` (or `EMPTY_CHILD`, an
/// absent child with an empty box), `count > 0`: a leaf of `count`
/// primitives from slot `child` of the primitive-index array. 128 bytes.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct WideNode as "WideNode" {
    pub lo: [[f32; 4]; 3],
    pub hi: [[f32; 4]; 3],
    pub child: [u32; 4],
    pub count: [u32; 4],
}
}

device_struct! {
/// One 8-wide node (`Wide8Node`): `WideNode` with eight slots, so that a
/// node's box test fills a 256-bit register. 256 bytes.
#[repr(C, align(32))]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Wide8Node as "Wide8Node" {
    pub lo: [[f32; 8]; 3],
    pub hi: [[f32; 8]; 3],
    pub child: [u32; 8],
    pub count: [u32; 8],
}
}

device_struct! {
/// Four slots of a wide layout's leaves (`LeafBlock`): they hold entries
/// [first, first + count) of the tree's primitive-index array, count 1..=4;
/// the slots past `count` repeat the last of them.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Eq, Pod, Zeroable)]
pub struct LeafBlock as "LeafBlock" {
    pub first: u32,
    pub count: u32,
}
}

/// Floats of a block's coordinates: three vertices, three axes, four lanes
/// (nine `float4`s).
pub const LEAF_BLOCK_FLOAT4S: usize = 9;

const _: () = assert!(std::mem::size_of::<WideNode>() == 128);
const _: () = assert!(std::mem::size_of::<Wide8Node>() == 256);

/// A node of a W-wide layout: `WideNode` (W = 4) or `Wide8Node` (W = 8).
pub trait WideLayout: Copy + Pod {
    /// Children per node.
    const WIDTH: usize;
    /// A node with every child absent.
    fn empty() -> Self;
    /// Slot `k` decoded.
    fn slot(&self, k: usize) -> (Child, Aabb);
    /// Slot `k`'s box.
    fn slot_box(&self, k: usize) -> ([f32; 3], [f32; 3]);
    /// Sets slot `k`: `count == 0` an inner node's index, else a leaf.
    fn set_slot(&mut self, k: usize, b: &Aabb, child: u32, count: u32);
    /// Slot `k`'s child and count fields, as stored.
    fn child_count(&self, k: usize) -> (u32, u32);
}

macro_rules! wide_layout_impl {
    ($node:ty, $w:literal) => {
        impl WideLayout for $node {
            const WIDTH: usize = $w;

            fn empty() -> Self {
                Self {
                    lo: [[f32::INFINITY; $w]; 3],
                    hi: [[f32::NEG_INFINITY; $w]; 3],
                    child: [EMPTY_CHILD; $w],
                    count: [0; $w],
                }
            }

            fn slot(&self, k: usize) -> (Child, Aabb) {
                let child = match (self.child[k], self.count[k]) {
                    (EMPTY_CHILD, 0) => Child::Empty,
                    (c, 0) => Child::Inner(c),
                    (first, count) => Child::Leaf { first, count },
                };
                let (lo, hi) = self.slot_box(k);
                (child, Aabb { lo, hi })
            }

            fn slot_box(&self, k: usize) -> ([f32; 3], [f32; 3]) {
                (
                    [self.lo[0][k], self.lo[1][k], self.lo[2][k]],
                    [self.hi[0][k], self.hi[1][k], self.hi[2][k]],
                )
            }

            fn set_slot(&mut self, k: usize, b: &Aabb, child: u32, count: u32) {
                for a in 0..3 {
                    self.lo[a][k] = b.lo[a];
                    self.hi[a][k] = b.hi[a];
                }
                self.child[k] = child;
                self.count[k] = count;
            }

            fn child_count(&self, k: usize) -> (u32, u32) {
                (self.child[k], self.count[k])
            }
        }
    };
}
wide_layout_impl!(WideNode, 4);
wide_layout_impl!(Wide8Node, 8);

/// The present (not empty) children of binary node `index`.
fn children(bvh: &Bvh, index: u32) -> Result<impl Iterator<Item = (Child, Aabb)>, TraceError> {
    let node = bvh.nodes.get(index as usize).ok_or_else(|| {
        TraceError::Malformed(format!("the tree refers to a missing node {index}"))
    })?;
    Ok([node.left(), node.right()]
        .into_iter()
        .filter(|(c, _)| *c != Child::Empty))
}

/// The W-wide layout of `bvh`: its nodes, and the blocks of its leaves'
/// slots.
pub fn wide_layout<N: WideLayout>(bvh: &Bvh) -> Result<(Vec<N>, Vec<LeafBlock>), TraceError> {
    let (mut out, mut blocks) = (Vec::new(), Vec::new());
    wide_layout_into(bvh, &mut out, &mut blocks)?;
    Ok((out, blocks))
}

/// The W-wide layout of `bvh` into `out` and its leaves' blocks into
/// `blocks` (both cleared first, their capacity kept from frame to frame).
pub fn wide_layout_into<N: WideLayout>(
    bvh: &Bvh,
    out: &mut Vec<N>,
    blocks: &mut Vec<LeafBlock>,
) -> Result<(), TraceError> {
    out.clear();
    blocks.clear();
    if bvh.nodes.is_empty() {
        return Err(TraceError::Malformed("the tree has no root node".into()));
    }
    let prims = bvh.prim_ids.len();
    // A slot index is 4 x the block's, and there are at most as many blocks
    // as triangles.
    if prims >= 1 << 30 {
        return Err(TraceError::Unsupported(format!(
            "{prims} triangles in one tree (the wide layouts hold fewer than 2^30)"
        )));
    }
    out.push(N::empty());
    // (binary node, its wide node)
    let mut work = vec![(0u32, 0usize)];
    let mut slots: Vec<(Child, Aabb)> = Vec::with_capacity(N::WIDTH);
    while let Some((binary, wide)) = work.pop() {
        slots.clear();
        slots.extend(children(bvh, binary)?);
        while slots.len() < N::WIDTH {
            // The inner child of largest surface area is opened.
            let open = slots
                .iter()
                .enumerate()
                .filter_map(|(k, (c, b))| match c {
                    Child::Inner(index) => Some((k, *index, b.area())),
                    _ => None,
                })
                .max_by(|a, b| a.2.total_cmp(&b.2));
            let Some((k, index, _)) = open else {
                break;
            };
            slots.swap_remove(k);
            slots.extend(children(bvh, index)?);
        }
        let mut w = N::empty();
        for (k, (child, b)) in slots.iter().enumerate() {
            let child = match *child {
                Child::Inner(c) => {
                    merged_leaf(bvh, c)?.map_or(Child::Inner(c), |(first, count)| Child::Leaf {
                        first,
                        count,
                    })
                }
                other => other,
            };
            match child {
                Child::Leaf { first, count } => {
                    if count == 0 || first as usize + count as usize > prims {
                        return Err(TraceError::Malformed(format!(
                            "a leaf of {count} triangles from entry {first} of {prims}"
                        )));
                    }
                    set_leaf(&mut w, k, b, first, count, blocks);
                }
                Child::Inner(c) => {
                    w.set_slot(k, b, out.len() as u32, 0);
                    out.push(N::empty());
                    work.push((c, out.len() - 1));
                }
                Child::Empty => {}
            }
        }
        out[wide] = w;
    }
    Ok(())
}

/// The most triangles of a subtree that a full node takes as one leaf
/// (`wide_layout_into`): two of the seed's leaves of four, two blocks of the
/// four-lane test. Merging into leaves of up to 4, 8 and 16 triangles took
/// 0.96-1.02x, 0.92-1.03x and 0.96-1.03x the time of no merging
/// (BENCHMARKS.md); 8 was below on 27 of 30 paired medians.
pub const MERGED_LEAF_MAX: u32 = 8;

/// Slot `k` of `w` as the leaf of entries [first, first + count) of the
/// primitive-index array, in whole blocks of four appended to `blocks`.
fn set_leaf<N: WideLayout>(
    w: &mut N,
    k: usize,
    b: &Aabb,
    first: u32,
    count: u32,
    blocks: &mut Vec<LeafBlock>,
) {
    w.set_slot(k, b, 4 * blocks.len() as u32, count);
    for at in (0..count).step_by(4) {
        blocks.push(LeafBlock {
            first: first + at,
            count: (count - at).min(4),
        });
    }
}

/// Binary node `index`'s triangles as one leaf, (first entry, count), when
/// they are at most `MERGED_LEAF_MAX` and their leaves' entries follow one
/// another in the primitive-index array (the builders partition in place, so
/// they do). The walk stops once the count passes the limit, or after as
/// many inner nodes as such a subtree can have, so it reads a few nodes
/// whatever the tree.
fn merged_leaf(bvh: &Bvh, index: u32) -> Result<Option<(u32, u32)>, TraceError> {
    fn walk(
        bvh: &Bvh,
        index: u32,
        range: &mut Option<(u32, u32)>,
        inner_left: &mut u32,
    ) -> Result<bool, TraceError> {
        if *inner_left == 0 {
            return Ok(false);
        }
        *inner_left -= 1;
        for (child, _) in children(bvh, index)? {
            match child {
                // Malformed: left to the layout's loop, which reports it.
                Child::Leaf { count: 0, .. } => return Ok(false),
                Child::Leaf { first, count } => match range {
                    None => *range = Some((first, count)),
                    Some((f, n)) if f.checked_add(*n) == Some(first) => *n += count,
                    Some(_) => return Ok(false),
                },
                Child::Inner(i) => {
                    if !walk(bvh, i, range, inner_left)? {
                        return Ok(false);
                    }
                }
                Child::Empty => {}
            }
            if range.is_some_and(|(_, n)| n > MERGED_LEAF_MAX) {
                return Ok(false);
            }
        }
        Ok(true)
    }
    let (mut range, mut inner_left) = (None, MERGED_LEAF_MAX - 1);
    Ok(walk(bvh, index, &mut range, &mut inner_left)?
        .then_some(range)
        .flatten())
}

/// The layout's triangles in leaf order (`leaf_gather`'s Rust twin), for
/// the blocks `wide_layout_into` made: per slot its triangle, and with
/// `positions` (the soup, three corners per triangle) per block the nine
/// lane vectors of its coordinates, vertex by vertex and axis by axis. A
/// degenerate triangle's lane holds NaN (`LEAF_FLAT_BITS`) instead, which
/// the four-lane test never hits, so it need not test each triangle's
/// normal per ray.
pub fn leaf_arrays(
    blocks: &[LeafBlock],
    prim_ids: &[u32],
    positions: Option<&[[f32; 4]]>,
) -> (Vec<u32>, Vec<[f32; 4]>) {
    let mut slots = Vec::with_capacity(4 * blocks.len());
    let mut tris =
        Vec::with_capacity(LEAF_BLOCK_FLOAT4S * blocks.len() * positions.is_some() as usize);
    for b in blocks {
        let q: [u32; 4] =
            std::array::from_fn(|i| prim_ids[(b.first + (i as u32).min(b.count - 1)) as usize]);
        slots.extend(q);
        if let Some(p) = positions {
            let flat = q.map(|t| is_degenerate(p, t));
            for v in 0..3 {
                for a in 0..3 {
                    tris.push(std::array::from_fn(|i| {
                        if flat[i] {
                            f32::from_bits(LEAF_FLAT_BITS)
                        } else {
                            p[3 * q[i] as usize + v][a]
                        }
                    }));
                }
            }
        }
    }
    (slots, tris)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::test_util::random_soup;
    use crate::bvh::{binned, BuildParams};

    /// Each leaf's triangles, in leaf order, sorted by leaf.
    fn leaves_of_binary(bvh: &Bvh) -> Vec<Vec<u32>> {
        let mut out: Vec<Vec<u32>> = bvh
            .nodes
            .iter()
            .flat_map(|n| [n.left().0, n.right().0])
            .filter_map(|c| match c {
                Child::Leaf { first, count } => {
                    Some(bvh.prim_ids[first as usize..(first + count) as usize].to_vec())
                }
                _ => None,
            })
            .collect();
        out.sort_unstable();
        out
    }

    /// Per wide node, the triangles in its subtree (children are numbered
    /// after their parent).
    fn triangles_under<N: WideLayout>(wide: &[N]) -> Vec<u32> {
        let mut under = vec![0u32; wide.len()];
        for i in (0..wide.len()).rev() {
            under[i] = (0..N::WIDTH)
                .map(|k| match wide[i].slot(k).0 {
                    Child::Leaf { count, .. } => count,
                    Child::Inner(c) => under[c as usize],
                    Child::Empty => 0,
                })
                .sum();
        }
        under
    }

    fn check_layout<N: WideLayout>() {
        let w = N::WIDTH;
        for (n, seed) in [(1usize, 1u64), (3, 2), (100, 3), (5000, 4)] {
            let mut soup = random_soup(n, 0.05, seed);
            // Every seventh triangle degenerate (its last corner on its
            // second), from the 100-triangle soup up.
            if n >= 100 {
                for t in (0..n).step_by(7) {
                    soup.positions[3 * t + 2] = soup.positions[3 * t + 1];
                }
            }
            let bvh = binned::build(&soup, BuildParams::default()).unwrap();
            let (wide, blocks) = wide_layout::<N>(&bvh).unwrap();
            let (slots, tris) = leaf_arrays(&blocks, &bvh.prim_ids, Some(&soup.positions));
            assert_eq!(slots.len(), 4 * blocks.len());
            assert_eq!(tris.len(), LEAF_BLOCK_FLOAT4S * blocks.len());
            let mut leaves = Vec::new();
            let mut reached = vec![0u32; wide.len()];
            reached[0] = 1;
            for node in &wide {
                let used = (0..w).filter(|&k| node.slot(k).0 != Child::Empty).count();
                assert!(
                    (1..=w).contains(&used),
                    "{w}/{n}: a node of {used} children"
                );
                for k in 0..w {
                    match node.slot(k).0 {
                        Child::Leaf { first, count } => {
                            assert_eq!(first % 4, 0, "{w}/{n}: a leaf at slot {first}");
                            let (f, c) = (first as usize, count as usize);
                            leaves.push(slots[f..f + c].to_vec());
                            let (lo, hi) = node.slot_box(k);
                            for &q in &slots[f..f + c] {
                                let tri = Aabb::of_triangle(&soup, q as usize);
                                assert!(Aabb { lo, hi }.contains(&tri), "{w}/{n}: leaf box");
                            }
                            // The last block's unused slots repeat its last
                            // triangle, and each block's lanes are its
                            // slots' coordinates.
                            let end = f + c.div_ceil(4) * 4;
                            assert!(slots[f + c..end].iter().all(|&q| q == slots[f + c - 1]));
                            for s in f..end {
                                let (b, lane) = (s / 4, s % 4);
                                for v in 0..3 {
                                    for a in 0..3 {
                                        let q = slots[s];
                                        let want = if is_degenerate(&soup.positions, q) {
                                            LEAF_FLAT_BITS
                                        } else {
                                            soup.positions[3 * q as usize + v][a].to_bits()
                                        };
                                        assert_eq!(
                                            tris[LEAF_BLOCK_FLOAT4S * b + 3 * v + a][lane]
                                                .to_bits(),
                                            want
                                        );
                                    }
                                }
                            }
                        }
                        Child::Inner(c) => reached[c as usize] += 1,
                        Child::Empty => {}
                    }
                }
            }
            // Each leaf is whole leaves of the binary tree, one after
            // another: one of them, or the merge of a subtree of at most
            // MERGED_LEAF_MAX triangles.
            let binary = leaves_of_binary(&bvh);
            let starting: std::collections::HashMap<u32, &Vec<u32>> =
                binary.iter().map(|l| (l[0], l)).collect();
            let mut pieces = Vec::new();
            for leaf in &leaves {
                assert!(
                    leaf.len() <= MERGED_LEAF_MAX.max(4) as usize,
                    "{w}/{n}: a leaf of {}",
                    leaf.len()
                );
                let mut rest = &leaf[..];
                while let Some(piece) = rest.first().and_then(|q| starting.get(q)) {
                    assert!(rest.starts_with(piece), "{w}/{n}: {leaf:?}");
                    pieces.push(piece.to_vec());
                    rest = &rest[piece.len()..];
                }
                assert!(rest.is_empty(), "{w}/{n}: {leaf:?} is not whole leaves");
            }
            pieces.sort_unstable();
            assert_eq!(pieces, binary, "{w}/{n}: leaves");
            // And no inner child is left that a leaf could have taken.
            let under = triangles_under(&wide);
            for node in &wide {
                for k in 0..w {
                    if let Child::Inner(c) = node.slot(k).0 {
                        assert!(under[c as usize] > MERGED_LEAF_MAX, "{w}/{n}: node {c}");
                    }
                }
            }
            if n == 5000 {
                assert!(
                    leaves.iter().any(|l| l.len() > 4),
                    "{w}/{n}: nothing merged"
                );
            }
            assert!(reached.iter().all(|&r| r == 1), "{w}/{n}: {reached:?}");
            // Each wide node stands for a distinct binary node.
            assert!(
                wide.len() <= bvh.nodes.len(),
                "{w}/{n}: {} of {}",
                wide.len(),
                bvh.nodes.len()
            );
        }
    }

    #[test]
    fn the_wide_layouts_keep_every_leaf_once_and_reach_every_node_once() {
        check_layout::<WideNode>();
        check_layout::<Wide8Node>();
    }
}
