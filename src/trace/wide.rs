//! A 4-wide view of the frame's BVH for traversal: each node of the paper's
//! binary tree is collapsed with its largest descendants into a node of up
//! to four children whose boxes are stored axis by axis. A ray then tests
//! four boxes per node fetch and takes half as many steps down the tree and
//! through its stack. The tree's leaves, and so the hits, are unchanged.
//!
//! Collapsing: a node starts with its two children and, while it has fewer
//! than four, replaces its inner child of largest surface area by that
//! child's two children (the children a ray is most likely to reach). Nodes
//! are numbered in the order they are made; node 0 is the root.

use super::TraceError;
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

const _: () = assert!(std::mem::size_of::<WideNode>() == 128);

impl WideNode {
    /// A node with four absent children.
    pub fn empty() -> WideNode {
        WideNode {
            lo: [[f32::INFINITY; 4]; 3],
            hi: [[f32::NEG_INFINITY; 4]; 3],
            child: [EMPTY_CHILD; 4],
            count: [0; 4],
        }
    }

    /// Slot `k` decoded.
    pub fn slot(&self, k: usize) -> (Child, Aabb) {
        let child = match (self.child[k], self.count[k]) {
            (EMPTY_CHILD, 0) => Child::Empty,
            (c, 0) => Child::Inner(c),
            (first, count) => Child::Leaf { first, count },
        };
        let b = Aabb {
            lo: [self.lo[0][k], self.lo[1][k], self.lo[2][k]],
            hi: [self.hi[0][k], self.hi[1][k], self.hi[2][k]],
        };
        (child, b)
    }
}

/// The present (not empty) children of binary node `index`.
fn children(bvh: &Bvh, index: u32) -> Result<impl Iterator<Item = (Child, Aabb)>, TraceError> {
    let node = bvh.nodes.get(index as usize).ok_or_else(|| {
        TraceError::Malformed(format!("the tree refers to a missing node {index}"))
    })?;
    Ok([node.left(), node.right()]
        .into_iter()
        .filter(|(c, _)| *c != Child::Empty))
}

/// The 4-wide layout of `bvh`.
pub fn wide_layout(bvh: &Bvh) -> Result<Vec<WideNode>, TraceError> {
    let mut out = Vec::new();
    wide_layout_into(bvh, &mut out)?;
    Ok(out)
}

/// The 4-wide layout of `bvh` into `out` (cleared first, its capacity kept
/// from frame to frame).
pub fn wide_layout_into(bvh: &Bvh, out: &mut Vec<WideNode>) -> Result<(), TraceError> {
    out.clear();
    if bvh.nodes.is_empty() {
        return Err(TraceError::Malformed("the tree has no root node".into()));
    }
    out.push(WideNode::empty());
    // (binary node, its wide node)
    let mut work = vec![(0u32, 0usize)];
    let mut slots: Vec<(Child, Aabb)> = Vec::with_capacity(4);
    while let Some((binary, wide)) = work.pop() {
        slots.clear();
        slots.extend(children(bvh, binary)?);
        while slots.len() < 4 {
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
        let mut w = WideNode::empty();
        for (k, (child, b)) in slots.iter().enumerate() {
            for a in 0..3 {
                w.lo[a][k] = b.lo[a];
                w.hi[a][k] = b.hi[a];
            }
            match *child {
                Child::Leaf { first, count } => {
                    w.child[k] = first;
                    w.count[k] = count;
                }
                Child::Inner(c) => {
                    w.child[k] = out.len() as u32;
                    out.push(WideNode::empty());
                    work.push((c, w.child[k] as usize));
                }
                Child::Empty => {}
            }
        }
        out[wide] = w;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::test_util::random_soup;
    use crate::bvh::{binned, BuildParams};

    fn leaves_of_binary(bvh: &Bvh) -> Vec<(u32, u32)> {
        let mut out: Vec<(u32, u32)> = bvh
            .nodes
            .iter()
            .flat_map(|n| [n.left().0, n.right().0])
            .filter_map(|c| match c {
                Child::Leaf { first, count } => Some((first, count)),
                _ => None,
            })
            .collect();
        out.sort_unstable();
        out
    }

    #[test]
    fn the_wide_layout_keeps_every_leaf_once_and_reaches_every_node_once() {
        for (n, seed) in [(1usize, 1u64), (3, 2), (100, 3), (5000, 4)] {
            let soup = random_soup(n, 0.05, seed);
            let bvh = binned::build(&soup, BuildParams::default()).unwrap();
            let wide = wide_layout(&bvh).unwrap();
            let mut leaves = Vec::new();
            let mut reached = vec![0u32; wide.len()];
            reached[0] = 1;
            for node in &wide {
                let used = (0..4).filter(|&k| node.slot(k).0 != Child::Empty).count();
                assert!((1..=4).contains(&used), "{n}: a node of {used} children");
                for k in 0..4 {
                    match node.slot(k).0 {
                        Child::Leaf { first, count } => leaves.push((first, count)),
                        Child::Inner(c) => reached[c as usize] += 1,
                        Child::Empty => {}
                    }
                }
            }
            leaves.sort_unstable();
            assert_eq!(leaves, leaves_of_binary(&bvh), "{n}: leaves");
            assert!(reached.iter().all(|&r| r == 1), "{n}: {reached:?}");
            // Each wide node stands for a distinct binary node.
            assert!(
                wide.len() <= bvh.nodes.len(),
                "{n}: {} of {}",
                wide.len(),
                bvh.nodes.len()
            );
        }
    }
}
