//! The stackless layout for escape-index traversal (Smits 1998; the variant
//! Sopin et al. 2011 compare with stack traversal): every child slot of the
//! BVH becomes one entry, in depth-first preorder, with its box and the index
//! of the entry that follows its subtree (its escape index). A ray that hits
//! an inner entry continues with the next entry (its first child); a ray
//! that misses an entry, or finishes a leaf, jumps to its escape index. The
//! order is fixed, left child first, so no stack is needed but nor is there
//! front-to-back culling.
//!
//! Escape indices depend on the whole tree's shape, so the layout is
//! recomputed after every build: O(nodes) on the host from the node array
//! the builder returns (see `stackless_layout`'s cost in BENCHMARKS.md via
//! `benches/trace_primary.rs`).

use super::TraceError;
use crate::bvh::{Aabb, Bvh, Child};
use crate::device_struct::{device_consts, device_struct};
use bytemuck::{Pod, Zeroable};

device_consts! {
    fn stackless_consts;
    /// Bits of `StacklessNode::leaf` that hold the primitive count.
    pub const LEAF_COUNT_BITS: u32 = 7;
}

device_struct! {
/// One entry of the stackless (escape-index) layout, in depth-first preorder:
/// a box, and the index of the entry to visit next when this one is missed or
/// finished (`escape`; the entry count ends traversal). An inner entry's first
/// child is the next entry. leaf == 0 marks an inner entry; otherwise
/// leaf = (first << 7) | count, count in 1..=64 primitives from slot `first`
/// of the primitive-index array (first < 2^25).
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct StacklessNode as "StacklessNode" {
    pub lo: [f32; 3],
    pub escape: u32,
    pub hi: [f32; 3],
    pub leaf: u32,
}
}

/// The escape-index layout of `bvh`: the root's box first (the union of its
/// children), then every child slot in preorder. An empty soup gives one
/// entry with an empty box.
pub fn stackless_layout(bvh: &Bvh) -> Result<Vec<StacklessNode>, TraceError> {
    let mut out = Vec::with_capacity(2 * bvh.nodes.len() + 1);
    stackless_layout_into(bvh, &mut out)?;
    Ok(out)
}

/// As [`stackless_layout`], reusing `out`'s allocation from frame to frame.
pub fn stackless_layout_into(bvh: &Bvh, out: &mut Vec<StacklessNode>) -> Result<(), TraceError> {
    out.clear();
    if bvh.nodes.is_empty() {
        return Err(TraceError::Malformed("no root node".into()));
    }
    if bvh.prim_ids.len() >= 1 << (32 - LEAF_COUNT_BITS) {
        return Err(TraceError::Unsupported(format!(
            "stackless traversal packs leaf offsets in 25 bits; {} triangles are too many",
            bvh.prim_ids.len()
        )));
    }
    // Entries whose escape index is not known yet: each one's escape is the
    // length of `out` when its subtree is finished. The explicit stack holds
    // (entry, child to emit next) so deep trees cannot overflow the host
    // stack either.
    enum Work {
        Emit(Child, Aabb),
        Close(usize),
    }
    let root = bvh.root_bounds();
    let mut work = vec![Work::Emit(Child::Inner(0), root)];
    while let Some(item) = work.pop() {
        match item {
            Work::Close(entry) => out[entry].escape = out.len() as u32,
            Work::Emit(child, b) => {
                let at = out.len();
                let leaf = match child {
                    Child::Empty => continue,
                    Child::Leaf { first, count } => {
                        if count == 0 || count >= 1 << LEAF_COUNT_BITS {
                            return Err(TraceError::Unsupported(format!(
                                "a leaf of {count} triangles does not fit the stackless layout"
                            )));
                        }
                        first << LEAF_COUNT_BITS | count
                    }
                    Child::Inner(_) => 0,
                };
                out.push(StacklessNode {
                    lo: b.lo,
                    escape: at as u32 + 1,
                    hi: b.hi,
                    leaf,
                });
                if let Child::Inner(index) = child {
                    let node = bvh.nodes.get(index as usize).ok_or_else(|| {
                        TraceError::Malformed(format!("child {index} is out of range"))
                    })?;
                    if out.len() > 2 * bvh.nodes.len() + 1 {
                        return Err(TraceError::Malformed("the tree has a cycle".into()));
                    }
                    let (lc, lb) = node.left();
                    let (rc, rb) = node.right();
                    // Popped in reverse: left subtree, right subtree, close.
                    work.push(Work::Close(at));
                    work.push(Work::Emit(rc, rb));
                    work.push(Work::Emit(lc, lb));
                }
            }
        }
    }
    Ok(())
}
