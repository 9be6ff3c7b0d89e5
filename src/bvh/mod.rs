//! The BVH stage: a full binned-SAH BVH rebuilt from the frame's soup.
//!
//! * `device_builder`: the paper's level-by-level builder on the OpenCL
//!   device, the one the renderer uses.
//! * `binned`: its plain Rust reference, the same algorithm with the same bin
//!   mapping, split choice and node numbering, run sequentially; the device
//!   tree must equal it.
//! * `sweep`: a full-sweep SAH builder, the quality reference.
//! * `layout`: the node layout traversal reads, mirrored with the kernels.
//!
//! `validate` and `sah_cost` judge any tree, whichever builder made it.

pub mod binned;
pub mod device_builder;
pub mod layout;
pub mod sweep;

pub use layout::{BvhNode, EMPTY_CHILD};

use crate::soup::Soup;
use glam::Vec3;

/// Tree-shape parameters shared by every builder.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub struct BuildParams {
    /// SAH bins per axis (a power of two from 2 to 64; the paper uses 16).
    pub bins: u32,
    /// A node of at most this many triangles becomes a leaf (1 to 64; the
    /// paper uses 4).
    pub leaf_size: u32,
}

impl Default for BuildParams {
    fn default() -> Self {
        BuildParams {
            bins: 16,
            leaf_size: 4,
        }
    }
}

impl BuildParams {
    /// Checks the ranges the kernels are compiled for.
    pub fn check(&self) -> Result<(), String> {
        if !(2..=64).contains(&self.bins) || !self.bins.is_power_of_two() {
            return Err(format!(
                "--bins {} is not supported: use a power of two from 2 to 64 (16 is the default)",
                self.bins
            ));
        }
        if !(1..=64).contains(&self.leaf_size) {
            return Err(format!(
                "--leaf {} is not supported: use 1 to 64 triangles (4 is the default)",
                self.leaf_size
            ));
        }
        Ok(())
    }
}

/// The deepest tree any builder may produce. Traversal keeps one stack entry
/// per level in private memory, so the renderer sizes its stack from this,
/// and a tree beyond it is refused at build time rather than traced wrong.
pub const MAX_DEPTH: u32 = 96;

/// An axis-aligned box; empty when `lo > hi`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    pub lo: [f32; 3],
    pub hi: [f32; 3],
}

impl Aabb {
    pub const EMPTY: Aabb = Aabb {
        lo: [f32::INFINITY; 3],
        hi: [f32::NEG_INFINITY; 3],
    };

    pub fn is_empty(&self) -> bool {
        (0..3).any(|a| self.lo[a] > self.hi[a])
    }

    pub fn union(&self, o: &Aabb) -> Aabb {
        let mut r = *self;
        for a in 0..3 {
            r.lo[a] = r.lo[a].min(o.lo[a]);
            r.hi[a] = r.hi[a].max(o.hi[a]);
        }
        r
    }

    pub fn grow(&mut self, p: [f32; 3]) {
        for a in 0..3 {
            self.lo[a] = self.lo[a].min(p[a]);
            self.hi[a] = self.hi[a].max(p[a]);
        }
    }

    /// The length of the diagonal (0 for an empty box).
    pub fn diagonal(&self) -> f32 {
        if self.is_empty() {
            return 0.0;
        }
        (Vec3::from(self.hi) - Vec3::from(self.lo)).length()
    }

    pub fn contains(&self, o: &Aabb) -> bool {
        o.is_empty() || (0..3).all(|a| self.lo[a] <= o.lo[a] && o.hi[a] <= self.hi[a])
    }

    /// Surface area in f64, so that the SAH sums of big trees at large
    /// scales neither overflow nor lose the small nodes.
    pub fn area(&self) -> f64 {
        if self.is_empty() {
            return 0.0;
        }
        let d: Vec<f64> = (0..3)
            .map(|a| self.hi[a] as f64 - self.lo[a] as f64)
            .collect();
        2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])
    }

    pub fn of_triangle(soup: &Soup, t: usize) -> Aabb {
        let mut b = Aabb::EMPTY;
        for k in 0..3 {
            b.grow(soup.corner(t, k));
        }
        b
    }
}

/// A child slot of a node, decoded.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Child {
    Empty,
    Inner(u32),
    Leaf { first: u32, count: u32 },
}

impl BvhNode {
    pub fn left(&self) -> (Child, Aabb) {
        (
            Child::decode(self.left_child, self.left_count),
            Aabb {
                lo: self.left_min,
                hi: self.left_max,
            },
        )
    }

    pub fn right(&self) -> (Child, Aabb) {
        (
            Child::decode(self.right_child, self.right_count),
            Aabb {
                lo: self.right_min,
                hi: self.right_max,
            },
        )
    }

    pub fn set_left(&mut self, child: Child, b: Aabb) {
        (self.left_child, self.left_count) = child.encode();
        (self.left_min, self.left_max) = (b.lo, b.hi);
    }

    pub fn set_right(&mut self, child: Child, b: Aabb) {
        (self.right_child, self.right_count) = child.encode();
        (self.right_min, self.right_max) = (b.lo, b.hi);
    }

    /// A node with both children absent.
    pub fn empty() -> BvhNode {
        let mut n = BvhNode::default();
        n.set_left(Child::Empty, Aabb::EMPTY);
        n.set_right(Child::Empty, Aabb::EMPTY);
        n
    }
}

impl Child {
    fn decode(child: u32, count: u32) -> Child {
        match (child, count) {
            (EMPTY_CHILD, 0) => Child::Empty,
            (c, 0) => Child::Inner(c),
            (first, count) => Child::Leaf { first, count },
        }
    }

    fn encode(self) -> (u32, u32) {
        match self {
            Child::Empty => (EMPTY_CHILD, 0),
            Child::Inner(i) => (i, 0),
            Child::Leaf { first, count } => (first, count),
        }
    }
}

/// A built tree: the nodes (root at 0) and the primitive-index array the
/// leaves point into (slot → triangle index in the soup).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    pub prim_ids: Vec<u32>,
}

/// The shape of a valid tree, from [`validate`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub struct TreeShape {
    /// Inner nodes plus leaves.
    pub nodes: usize,
    pub inner_nodes: usize,
    pub leaves: usize,
    /// Root = depth 0; a leaf hanging off the root is at depth 1.
    pub max_depth: u32,
}

impl Bvh {
    /// The tree's node count, leaf count and depth (what `validate` reports
    /// for a valid tree), without checking it against a soup.
    pub fn shape(&self) -> TreeShape {
        let mut shape = TreeShape::default();
        if self.nodes.is_empty() {
            return shape;
        }
        shape.nodes = 1;
        shape.inner_nodes = 1;
        let mut stack = vec![(0u32, 0u32)];
        while let Some((index, depth)) = stack.pop() {
            let node = &self.nodes[index as usize];
            for (child, _) in [node.left(), node.right()] {
                match child {
                    Child::Empty => {}
                    Child::Inner(c) if (c as usize) < self.nodes.len() && depth < MAX_DEPTH => {
                        shape.nodes += 1;
                        shape.inner_nodes += 1;
                        stack.push((c, depth + 1));
                    }
                    Child::Inner(_) => {}
                    Child::Leaf { .. } => {
                        shape.nodes += 1;
                        shape.leaves += 1;
                        shape.max_depth = shape.max_depth.max(depth + 1);
                    }
                }
            }
        }
        shape
    }

    /// The box of everything in the tree: the union of the root's children.
    pub fn root_bounds(&self) -> Aabb {
        match self.nodes.first() {
            Some(root) => root.left().1.union(&root.right().1),
            None => Aabb::EMPTY,
        }
    }
}

/// Checks every invariant a renderer relies on and returns the tree's shape:
/// every triangle in exactly one leaf, every box enclosing its triangles and
/// children, no empty inner node (but the root of an empty soup), each node
/// reached exactly once, leaves of 1..=leaf_size triangles, depth within
/// [`MAX_DEPTH`].
pub fn validate(bvh: &Bvh, soup: &Soup, leaf_size: u32) -> Result<TreeShape, String> {
    let n = soup.triangle_count();
    if bvh.prim_ids.len() != n {
        return Err(format!(
            "the primitive-index array has {} entries for {n} triangles",
            bvh.prim_ids.len()
        ));
    }
    let Some(root) = bvh.nodes.first() else {
        return Err("the tree has no root node".into());
    };
    let mut seen_prim = vec![false; n];
    let mut seen_slot = vec![false; n];
    let mut seen_node = vec![false; bvh.nodes.len()];
    let mut shape = TreeShape {
        nodes: 1,
        inner_nodes: 1,
        ..TreeShape::default()
    };
    if n == 0 {
        return match (root.left().0, root.right().0) {
            (Child::Empty, Child::Empty) => Ok(shape),
            _ => Err("the tree of an empty soup has children".into()),
        };
    }
    // (node, depth)
    let mut stack = vec![(0u32, 0u32)];
    seen_node[0] = true;
    while let Some((index, depth)) = stack.pop() {
        let node = &bvh.nodes[index as usize];
        let sides = [node.left(), node.right()];
        if sides.iter().all(|(c, _)| *c == Child::Empty) {
            return Err(format!("inner node {index} has no children"));
        }
        if index != 0 && sides.iter().any(|(c, _)| *c == Child::Empty) {
            return Err(format!("inner node {index} has only one child"));
        }
        for (side, (child, bounds)) in sides.iter().enumerate() {
            let side_name = ["left", "right"][side];
            match *child {
                Child::Empty => {}
                Child::Inner(c) => {
                    let Some(cn) = bvh.nodes.get(c as usize) else {
                        return Err(format!(
                            "node {index} {side_name} child {c} is out of range"
                        ));
                    };
                    if std::mem::replace(&mut seen_node[c as usize], true) {
                        return Err(format!("node {c} is reached twice"));
                    }
                    for (_, cb) in [cn.left(), cn.right()] {
                        if !bounds.contains(&cb) {
                            return Err(format!(
                                "node {index} {side_name} box {bounds:?} does not enclose its child node {c}'s box {cb:?}"
                            ));
                        }
                    }
                    if depth + 1 > MAX_DEPTH {
                        return Err(format!("the tree is deeper than {MAX_DEPTH} levels"));
                    }
                    shape.nodes += 1;
                    shape.inner_nodes += 1;
                    stack.push((c, depth + 1));
                }
                Child::Leaf { first, count } => {
                    if count > leaf_size {
                        return Err(format!(
                            "node {index} {side_name} leaf holds {count} triangles, over the leaf size {leaf_size}"
                        ));
                    }
                    let end = first as usize + count as usize;
                    if end > n {
                        return Err(format!(
                            "node {index} {side_name} leaf slots {first}..{end} run past {n}"
                        ));
                    }
                    for slot in first as usize..end {
                        if std::mem::replace(&mut seen_slot[slot], true) {
                            return Err(format!("primitive slot {slot} is in two leaves"));
                        }
                        let t = bvh.prim_ids[slot] as usize;
                        if t >= n {
                            return Err(format!("slot {slot} names triangle {t} of {n}"));
                        }
                        if std::mem::replace(&mut seen_prim[t], true) {
                            return Err(format!("triangle {t} is in two leaves"));
                        }
                        let tb = Aabb::of_triangle(soup, t);
                        if !bounds.contains(&tb) {
                            return Err(format!(
                                "node {index} {side_name} leaf box {bounds:?} does not enclose triangle {t} {tb:?}"
                            ));
                        }
                    }
                    shape.nodes += 1;
                    shape.leaves += 1;
                    shape.max_depth = shape.max_depth.max(depth + 1);
                }
            }
        }
    }
    if let Some(t) = seen_prim.iter().position(|s| !s) {
        return Err(format!("triangle {t} is in no leaf"));
    }
    if let Some(i) = seen_node.iter().position(|s| !s) {
        return Err(format!("node {i} is not reachable from the root"));
    }
    Ok(shape)
}

/// The tree's SAH cost with K_T = K_I = 1, normalised by the root box's
/// area: Σ_inner A(n)/A(root) + Σ_leaf A(l)·N(l)/A(root). The root counts as
/// an inner node (its box is the union of its children's). The cost is the
/// expected number of box and triangle tests of a random ray that hits the
/// root box, which makes trees of different builders directly comparable.
/// 0 for an empty tree.
pub fn sah_cost(bvh: &Bvh) -> f64 {
    let root_area = bvh.root_bounds().area();
    if root_area <= 0.0 || !root_area.is_finite() {
        return 0.0;
    }
    let mut cost = root_area;
    for node in &bvh.nodes {
        for (child, bounds) in [node.left(), node.right()] {
            match child {
                Child::Empty => {}
                Child::Inner(_) => cost += bounds.area(),
                Child::Leaf { count, .. } => cost += bounds.area() * count as f64,
            }
        }
    }
    cost / root_area
}

#[cfg(test)]
pub(crate) mod test_util {
    //! Deterministic test geometry.
    use crate::soup::Soup;

    /// A small xorshift generator, so test soups are the same everywhere.
    pub struct Rng(pub u64);
    impl Rng {
        pub fn next_f32(&mut self) -> f32 {
            self.0 ^= self.0 << 13;
            self.0 ^= self.0 >> 7;
            self.0 ^= self.0 << 17;
            (self.0 >> 40) as f32 / (1u64 << 24) as f32
        }
    }

    /// `n` random triangles of size about `size` in the unit cube.
    pub fn random_soup(n: usize, size: f32, seed: u64) -> Soup {
        let mut rng = Rng(seed.wrapping_mul(0x9E3779B97F4A7C15) | 1);
        let tris: Vec<[[f32; 3]; 3]> = (0..n)
            .map(|_| {
                let c = [rng.next_f32(), rng.next_f32(), rng.next_f32()];
                let mut t = [[0.0; 3]; 3];
                for v in &mut t {
                    for a in 0..3 {
                        v[a] = c[a] + (rng.next_f32() - 0.5) * size;
                    }
                }
                t
            })
            .collect();
        Soup::from_triangles(&tris)
    }
}
