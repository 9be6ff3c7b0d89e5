//! The binned-SAH builder in plain Rust: the reference the device builder
//! is tested against, and the host's share of the device build.
//!
//! It is factored like `kernels/bvh/bvh_common.h`, function for function: bin
//! mapping (`bin_scale`, `bin_index`), bins (`bin_add`, `bin_merge`), split
//! choice (`candidate_cost`, `select_split`, `make_split`) and partition
//! (`goes_left`). Same operations in the same order, so the two builders make
//! the same tree, node for node.
//!
//! `Levels` is the host's part of the paper's scheme, shared by both
//! builders: it keeps one task queue per stage (large, medium, small nodes),
//! turns each level's split results into nodes and the next level's tasks,
//! and attaches the small nodes' subtrees, which the device builds whole, one
//! work-group a small node (`build_small_subtree` is their reference). Node
//! numbering therefore depends only on the splits.

use super::layout::{Bin, BuildTask, BvhNode, PrimRef, SmallSubtree, SplitResult};
use super::{Aabb, BuildParams, Bvh, Child};
use crate::soup::Soup;

/// Nodes of more than this many triangles are "large" (paper: 32K).
pub const LARGE_ABOVE: u32 = 32 * 1024;
/// Nodes of at least this many triangles are "medium"; smaller are "small"
/// and handled one work-group per node (paper: 256).
pub const MEDIUM_FROM: u32 = 256;
/// Triangles per binning/partition work-group for large and medium nodes, so
/// a node is spread over ceil(N/512) work-groups (paper: N/512).
pub const PRIMS_PER_GROUP: u32 = 512;
/// Entries of `build_small`'s node stack (`SMALL_STACK` in the kernel):
/// enough below `MEDIUM_FROM` triangles, since the smaller child goes first.
pub const SMALL_STACK: usize = 8;
/// Work-group bin sets merged by one `reduce_bins` group for large nodes.
pub const REDUCE_FAN: u32 = 64;

/// The three stages of the paper, in the order they run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stage {
    Large,
    Medium,
    Small,
}

impl Stage {
    pub const ALL: [Stage; 3] = [Stage::Large, Stage::Medium, Stage::Small];

    pub fn of(count: u32) -> Stage {
        if count > LARGE_ABOVE {
            Stage::Large
        } else if count >= MEDIUM_FROM {
            Stage::Medium
        } else {
            Stage::Small
        }
    }

    pub fn name(self) -> &'static str {
        match self {
            Stage::Large => "large",
            Stage::Medium => "medium",
            Stage::Small => "small",
        }
    }
}

pub fn prim_ref(v: [[f32; 4]; 3]) -> PrimRef {
    let mut r = PrimRef::default();
    for a in 0..3 {
        r.lo[a] = v[0][a].min(v[1][a]).min(v[2][a]);
        r.hi[a] = v[0][a].max(v[1][a]).max(v[2][a]);
    }
    r
}

pub fn centroid(r: &PrimRef) -> [f32; 4] {
    let mut c = [0.0; 4];
    for a in 0..4 {
        c[a] = (r.lo[a] + r.hi[a]) * 0.5;
    }
    c
}

pub fn bin_empty() -> Bin {
    Bin {
        lo: [f32::INFINITY; 4],
        hi: [f32::NEG_INFINITY; 4],
        clo: [f32::INFINITY; 4],
        chi: [f32::NEG_INFINITY; 4],
        count: 0,
        id_or: 0,
        id_and: u32::MAX,
        pad: 0,
    }
}

pub fn bin_add(b: &mut Bin, r: &PrimRef, id: u32) {
    let c = centroid(r);
    for a in 0..4 {
        b.lo[a] = b.lo[a].min(r.lo[a]);
        b.hi[a] = b.hi[a].max(r.hi[a]);
        b.clo[a] = b.clo[a].min(c[a]);
        b.chi[a] = b.chi[a].max(c[a]);
    }
    b.count += 1;
    b.id_or |= id;
    b.id_and &= id;
}

pub fn bin_merge(x: &Bin, y: &Bin) -> Bin {
    let mut m = *x;
    for a in 0..4 {
        m.lo[a] = x.lo[a].min(y.lo[a]);
        m.hi[a] = x.hi[a].max(y.hi[a]);
        m.clo[a] = x.clo[a].min(y.clo[a]);
        m.chi[a] = x.chi[a].max(y.chi[a]);
    }
    m.count = x.count + y.count;
    m.id_or = x.id_or | y.id_or;
    m.id_and = x.id_and & y.id_and;
    m
}

/// The bin mapping of a node with centroid bounds [clo, chi]: bins per unit
/// length on each axis. An axis whose extent is zero, or so small that the
/// mapping would overflow, gets 0: its centroids cannot be told apart, and
/// no split is tried on it. The factor just under `bins` keeps the largest
/// centroid inside the last bin.
pub fn bin_scale(clo: &[f32; 4], chi: &[f32; 4], bins: u32) -> [f32; 4] {
    let mut s = [0.0; 4];
    for a in 0..3 {
        let extent = chi[a] - clo[a];
        let k = bins as f32 * 0.99999 / extent;
        s[a] = if extent > 0.0 && k.is_finite() {
            k
        } else {
            0.0
        };
    }
    s
}

/// The bin of centroid coordinate `c`, clamped into [0, bins).
pub fn bin_index(c: f32, cmin: f32, scale: f32, bins: u32) -> u32 {
    let f = ((c - cmin) * scale).max(0.0).min((bins - 1) as f32);
    f as u32
}

/// Half a box's surface area; the factor 2 cancels in every SAH ratio.
pub fn half_area(lo: &[f32; 4], hi: &[f32; 4]) -> f32 {
    let d = [hi[0] - lo[0], hi[1] - lo[1], hi[2] - lo[2]];
    d[0] * d[1] + d[1] * d[2] + d[2] * d[0]
}

fn union_range(bins: &[Bin], from: usize, to: usize) -> Bin {
    bins[from..to]
        .iter()
        .fold(bin_empty(), |acc, b| bin_merge(&acc, b))
}

/// The SAH cost of candidate `i = axis * bins + position` (left = the bins
/// below `position`), or `None` where it does not split the node.
pub fn candidate_cost(node_bins: &[Bin], scale: &[f32; 4], i: u32, bins: u32) -> Option<f32> {
    let axis = (i / bins) as usize;
    let position = (i % bins) as usize;
    if position == 0 || scale[axis] <= 0.0 || scale[axis].is_nan() {
        return None;
    }
    let row = &node_bins[axis * bins as usize..(axis + 1) * bins as usize];
    let l = union_range(row, 0, position);
    let r = union_range(row, position, bins as usize);
    if l.count == 0 || r.count == 0 {
        return None;
    }
    Some(half_area(&l.lo, &l.hi) * l.count as f32 + half_area(&r.lo, &r.hi) * r.count as f32)
}

/// The cheapest candidate; on equal cost the lowest index.
pub fn select_split(node_bins: &[Bin], scale: &[f32; 4], bins: u32) -> Option<u32> {
    let mut best: Option<(f32, u32)> = None;
    for i in 0..3 * bins {
        if let Some(c) = candidate_cost(node_bins, scale, i, bins) {
            if best.is_none_or(|(b, _)| c < b) {
                best = Some((c, i));
            }
        }
    }
    best.map(|(_, i)| i)
}

/// The split record for `best`, or the id split when no candidate splits
/// the node (see `make_split` in `kernels/bvh/bvh_common.h` for why).
pub fn make_split(
    node_bins: &[Bin],
    task: &BuildTask,
    best: Option<u32>,
    bins: u32,
) -> SplitResult {
    match best {
        Some(i) => {
            let axis = (i / bins) as usize;
            let position = (i % bins) as usize;
            let row = &node_bins[axis * bins as usize..(axis + 1) * bins as usize];
            let l = union_range(row, 0, position);
            let r = union_range(row, position, bins as usize);
            SplitResult {
                left_lo: l.lo,
                left_hi: l.hi,
                right_lo: r.lo,
                right_hi: r.hi,
                left_clo: l.clo,
                left_chi: l.chi,
                right_clo: r.clo,
                right_chi: r.chi,
                axis: axis as i32,
                position: position as u32,
                left_count: l.count,
                right_count: r.count,
            }
        }
        None => {
            let all = union_range(node_bins, 0, bins as usize);
            let differ = all.id_or ^ all.id_and;
            SplitResult {
                left_lo: task.lo,
                left_hi: task.hi,
                right_lo: task.lo,
                right_hi: task.hi,
                left_clo: task.clo,
                left_chi: task.chi,
                right_clo: task.clo,
                right_chi: task.chi,
                axis: -1,
                position: if differ == 0 {
                    0
                } else {
                    31 - differ.leading_zeros()
                },
                left_count: 0,
                right_count: 0,
            }
        }
    }
}

/// Which side of `split` a primitive goes to, by the mapping that binned it.
pub fn goes_left(task: &BuildTask, split: &SplitResult, r: &PrimRef, id: u32, bins: u32) -> bool {
    if split.axis < 0 {
        return (id >> split.position) & 1 == 0;
    }
    let a = split.axis as usize;
    let c = centroid(r);
    bin_index(c[a], task.cmin[a], task.scale[a], bins) < split.position
}

/// A task for the primitives in slots `start..start+count`, with the bin
/// mapping derived from its centroid bounds.
pub fn make_task(
    start: u32,
    count: u32,
    bounds: (&[f32; 4], &[f32; 4]),
    cbounds: (&[f32; 4], &[f32; 4]),
    node: u32,
    bins: u32,
) -> BuildTask {
    BuildTask {
        cmin: *cbounds.0,
        scale: bin_scale(cbounds.0, cbounds.1, bins),
        lo: *bounds.0,
        hi: *bounds.1,
        clo: *cbounds.0,
        chi: *cbounds.1,
        start,
        count,
        node,
        ..BuildTask::default()
    }
}

/// Why a build failed. Only a broken device (or a bug) gets here: every
/// input soup of finite coordinates builds.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("the BVH build made no progress at node {node} ({count} triangles split {left}/{right}); this is a bug in the builder or the device's OpenCL driver")]
    NoProgress {
        node: u32,
        count: u32,
        left: u32,
        right: u32,
    },
    #[error("the device and the split disagree at node {node}: bins counted {expected:?} triangles left/right, partition moved {got:?}; the device's OpenCL driver miscompiled or lost atomics")]
    CountMismatch {
        node: u32,
        expected: (u32, u32),
        got: (u32, u32),
    },
    #[error("the device gave up on the small subtree at node {node} ({why}); this is a bug in the builder or the device's OpenCL driver")]
    SmallSubtree { node: u32, why: &'static str },
    #[error("the BVH is deeper than {max} levels ({depth}); the traversal stack cannot hold it")]
    TooDeep { depth: u32, max: u32 },
    #[error("{0}")]
    Params(String),
    #[error(transparent)]
    Device(#[from] crate::device::DeviceError),
}

/// The host's share of the level-by-level build, shared by both builders.
pub struct Levels {
    params: BuildParams,
    pub nodes: Vec<BvhNode>,
    queues: [Vec<BuildTask>; 3],
    depth: Vec<u32>,
    pub max_depth: u32,
    /// Slot ranges whose final order is in buffer pair 1 (the device
    /// builder ping-pongs between two pairs; see `BuildTask::source`).
    pub finished_in_second: Vec<[u32; 2]>,
}

impl Levels {
    /// Starts a tree of `count` triangles whose root bin is `root`.
    pub fn new(root: &Bin, count: u32, params: BuildParams) -> Levels {
        let mut levels = Levels {
            params,
            nodes: vec![BvhNode::empty()],
            queues: [Vec::new(), Vec::new(), Vec::new()],
            depth: vec![0],
            max_depth: 0,
            finished_in_second: Vec::new(),
        };
        if count == 0 {
            return levels;
        }
        let bounds = Aabb {
            lo: [root.lo[0], root.lo[1], root.lo[2]],
            hi: [root.hi[0], root.hi[1], root.hi[2]],
        };
        if count <= params.leaf_size {
            levels.nodes[0].set_left(Child::Leaf { first: 0, count }, bounds);
            levels.max_depth = 1;
        } else {
            let task = make_task(
                0,
                count,
                (&root.lo, &root.hi),
                (&root.clo, &root.chi),
                0,
                params.bins,
            );
            levels.queues[Stage::of(count) as usize].push(task);
        }
        levels
    }

    /// The tasks waiting for `stage`; later stages' tasks stay queued.
    pub fn take_stage(&mut self, stage: Stage) -> Vec<BuildTask> {
        std::mem::take(&mut self.queues[stage as usize])
    }

    /// Records one level's splits of the large or medium stage: writes each
    /// task's node, and returns the children that belong to the same stage
    /// (the next level); smaller children wait in their stage's queue.
    pub fn accept(
        &mut self,
        stage: Stage,
        tasks: &[BuildTask],
        splits: &[SplitResult],
    ) -> Result<Vec<BuildTask>, BuildError> {
        debug_assert!(stage != Stage::Small, "small nodes are built whole");
        let mut next = Vec::new();
        for (task, split) in tasks.iter().zip(splits) {
            if split.left_count == 0
                || split.right_count == 0
                || split.left_count + split.right_count != task.count
            {
                return Err(BuildError::NoProgress {
                    node: task.node,
                    count: task.count,
                    left: split.left_count,
                    right: split.right_count,
                });
            }
            let depth = self.depth[task.node as usize] + 1;
            // Partitions write into the other buffer pair.
            let source = 1 - task.source;
            let sides = [
                (
                    task.start,
                    split.left_count,
                    &split.left_lo,
                    &split.left_hi,
                    &split.left_clo,
                    &split.left_chi,
                ),
                (
                    task.start + split.left_count,
                    split.right_count,
                    &split.right_lo,
                    &split.right_hi,
                    &split.right_clo,
                    &split.right_chi,
                ),
            ];
            for (side, (start, count, lo, hi, clo, chi)) in sides.into_iter().enumerate() {
                let bounds = Aabb {
                    lo: [lo[0], lo[1], lo[2]],
                    hi: [hi[0], hi[1], hi[2]],
                };
                let child = if count <= self.params.leaf_size {
                    self.max_depth = self.max_depth.max(depth);
                    if source == 1 {
                        self.finished_in_second.push([start, count]);
                    }
                    Child::Leaf {
                        first: start,
                        count,
                    }
                } else {
                    let index = self.nodes.len() as u32;
                    self.nodes.push(BvhNode::empty());
                    self.depth.push(depth);
                    if depth >= super::MAX_DEPTH {
                        return Err(BuildError::TooDeep {
                            depth: depth + 1,
                            max: super::MAX_DEPTH,
                        });
                    }
                    let t = make_task(start, count, (lo, hi), (clo, chi), index, self.params.bins);
                    let child_stage = Stage::of(count);
                    let t = BuildTask { source, ..t };
                    // A small node's whole subtree is partitioned in place,
                    // so its range ends where it starts.
                    if child_stage == Stage::Small && source == 1 {
                        self.finished_in_second.push([start, count]);
                    }
                    if child_stage == stage {
                        next.push(t);
                    } else {
                        self.queues[child_stage as usize].push(t);
                    }
                    Child::Inner(index)
                };
                let node = &mut self.nodes[task.node as usize];
                if side == 0 {
                    node.set_left(child, bounds);
                } else {
                    node.set_right(child, bounds);
                }
            }
        }
        Ok(next)
    }

    /// Attaches the subtree built for the small node `root`: `nodes` in
    /// subtree-local numbering (0 is `root` itself, inner children refer to
    /// local indices), as `build_small_subtree` and the device's
    /// `build_small` produce them. The descendants are appended in local
    /// order, so attaching the small nodes in queue order numbers the tree
    /// the same way in both builders.
    pub fn attach_small(
        &mut self,
        root: &BuildTask,
        nodes: &[BvhNode],
        summary: &SmallSubtree,
    ) -> Result<(), BuildError> {
        let why = match summary.status {
            super::layout::SMALL_OK => None,
            super::layout::SMALL_NO_PROGRESS => Some("a split left one side empty"),
            super::layout::SMALL_COUNT_MISMATCH => {
                Some("the partition moved other counts than the bins said")
            }
            _ => Some("its node stack overflowed"),
        };
        if let Some(why) = why {
            return Err(BuildError::SmallSubtree {
                node: root.node,
                why,
            });
        }
        let depth = self.depth[root.node as usize] + summary.depth;
        // The deepest inner node lies one level above the deepest leaf.
        if depth > super::MAX_DEPTH {
            return Err(BuildError::TooDeep {
                depth,
                max: super::MAX_DEPTH,
            });
        }
        self.max_depth = self.max_depth.max(depth);
        let base = self.nodes.len() as u32 - 1;
        let global = |mut node: BvhNode| {
            for (child, count) in [
                (&mut node.left_child, node.left_count),
                (&mut node.right_child, node.right_count),
            ] {
                if count == 0 && *child != super::layout::EMPTY_CHILD {
                    *child += base;
                }
            }
            node
        };
        let Some((first, rest)) = nodes.split_first() else {
            return Err(BuildError::SmallSubtree {
                node: root.node,
                why: "it wrote no node",
            });
        };
        self.nodes[root.node as usize] = global(*first);
        self.nodes.extend(rest.iter().map(|&n| global(n)));
        Ok(())
    }
}

/// The reference for one small node's subtree, as the device's
/// `build_small` makes it: split depth first, the smaller child first (the
/// larger stacked; on a tie the left goes first), children numbered as they
/// are made, left before right. Returns the nodes in subtree-local numbering
/// (see `Levels::attach_small`) and the summary the device reports.
pub fn build_small_subtree(
    root: &BuildTask,
    ids: &mut [u32],
    refs: &[PrimRef],
    params: BuildParams,
) -> (Vec<BvhNode>, SmallSubtree) {
    let leaf = params.leaf_size;
    let mut nodes = vec![BvhNode::empty()];
    let mut summary = SmallSubtree::default();
    // (task, local index, depth below the small node)
    let mut stack: Vec<(BuildTask, u32, u32)> = Vec::new();
    let mut current = (*root, 0u32, 0u32);
    loop {
        let (task, local, depth) = current;
        let split = split_task(&task, ids, refs, params.bins);
        if split.left_count == 0 || split.right_count == 0 {
            summary.status = super::layout::SMALL_NO_PROGRESS;
            break;
        }
        let sides = [
            (
                task.start,
                split.left_count,
                (&split.left_lo, &split.left_hi),
                (&split.left_clo, &split.left_chi),
            ),
            (
                task.start + split.left_count,
                split.right_count,
                (&split.right_lo, &split.right_hi),
                (&split.right_clo, &split.right_chi),
            ),
        ];
        let mut inner = Vec::with_capacity(2);
        let mut node = BvhNode::empty();
        for (side, (start, count, bounds, cbounds)) in sides.into_iter().enumerate() {
            let child = if count <= leaf {
                summary.depth = summary.depth.max(depth + 1);
                Child::Leaf {
                    first: start,
                    count,
                }
            } else {
                let index = nodes.len() as u32;
                nodes.push(BvhNode::empty());
                let t = make_task(start, count, bounds, cbounds, 0, params.bins);
                inner.push((
                    BuildTask {
                        source: task.source,
                        ..t
                    },
                    index,
                    depth + 1,
                ));
                Child::Inner(index)
            };
            let b = Aabb {
                lo: [bounds.0[0], bounds.0[1], bounds.0[2]],
                hi: [bounds.1[0], bounds.1[1], bounds.1[2]],
            };
            if side == 0 {
                node.set_left(child, b);
            } else {
                node.set_right(child, b);
            }
        }
        nodes[local as usize] = node;
        current = match inner[..] {
            [l, r] => {
                let (go, stay) = if r.0.count < l.0.count {
                    (r, l)
                } else {
                    (l, r)
                };
                stack.push(stay);
                debug_assert!(
                    stack.len() <= SMALL_STACK,
                    "the device's stack would overflow"
                );
                go
            }
            [one] => one,
            _ => match stack.pop() {
                Some(next) => next,
                None => break,
            },
        };
    }
    summary.nodes = nodes.len() as u32;
    (nodes, summary)
}

/// The root bin of a set of primitive boxes.
pub fn root_bin(refs: &[PrimRef]) -> Bin {
    let mut b = bin_empty();
    for (i, r) in refs.iter().enumerate() {
        bin_add(&mut b, r, i as u32);
    }
    b
}

pub fn prim_refs(soup: &Soup) -> Vec<PrimRef> {
    soup.positions
        .chunks_exact(3)
        .map(|v| prim_ref([v[0], v[1], v[2]]))
        .collect()
}

/// Bins, splits and stably partitions one task, as one work-group would.
pub fn split_task(task: &BuildTask, ids: &mut [u32], refs: &[PrimRef], bins: u32) -> SplitResult {
    let range = task.start as usize..(task.start + task.count) as usize;
    let mut node_bins = vec![bin_empty(); 3 * bins as usize];
    for &id in &ids[range.clone()] {
        let r = &refs[id as usize];
        let c = centroid(r);
        for a in 0..3 {
            let b = bin_index(c[a], task.cmin[a], task.scale[a], bins);
            bin_add(&mut node_bins[a * bins as usize + b as usize], r, id);
        }
    }
    let best = select_split(&node_bins, &task.scale, bins);
    let mut split = make_split(&node_bins, task, best, bins);
    let (left, right): (Vec<u32>, Vec<u32>) = ids[range.clone()]
        .iter()
        .partition(|&&id| goes_left(task, &split, &refs[id as usize], id, bins));
    split.left_count = left.len() as u32;
    split.right_count = right.len() as u32;
    ids[range.start..range.start + left.len()].copy_from_slice(&left);
    ids[range.start + left.len()..range.end].copy_from_slice(&right);
    split
}

/// The reference build: the device algorithm run sequentially.
pub fn build(soup: &Soup, params: BuildParams) -> Result<Bvh, BuildError> {
    params.check().map_err(BuildError::Params)?;
    let refs = prim_refs(soup);
    let n = refs.len() as u32;
    let mut ids: Vec<u32> = (0..n).collect();
    let mut levels = Levels::new(&root_bin(&refs), n, params);
    for stage in [Stage::Large, Stage::Medium] {
        let mut level = levels.take_stage(stage);
        while !level.is_empty() {
            let splits: Vec<SplitResult> = level
                .iter()
                .map(|t| split_task(t, &mut ids, &refs, params.bins))
                .collect();
            level = levels.accept(stage, &level, &splits)?;
        }
    }
    for root in levels.take_stage(Stage::Small) {
        let (nodes, summary) = build_small_subtree(&root, &mut ids, &refs, params);
        levels.attach_small(&root, &nodes, &summary)?;
    }
    Ok(Bvh {
        nodes: levels.nodes,
        prim_ids: ids,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh::test_util::random_soup;
    use crate::bvh::{sah_cost, validate};

    #[test]
    fn extreme_centroids_land_in_the_end_bins() {
        for bins in [2u32, 4, 16, 64] {
            for (lo, hi) in [
                (0.0f32, 1.0f32),
                (1e6, 1e6 + 0.125),
                (-3e-4, 7e-4),
                (1e-30, 2e-30),
            ] {
                let s = bin_scale(&[lo; 4], &[hi; 4], bins);
                assert!(s[0] > 0.0);
                assert_eq!(bin_index(lo, lo, s[0], bins), 0);
                assert_eq!(
                    bin_index(hi, lo, s[0], bins),
                    bins - 1,
                    "{lo}..{hi} with {bins} bins"
                );
            }
        }
        assert_eq!(bin_scale(&[1.0; 4], &[1.0; 4], 16)[0], 0.0);
        assert_eq!(
            bin_scale(&[0.0; 4], &[1e-44; 4], 16)[0],
            0.0,
            "a subnormal extent must not map"
        );
    }

    #[test]
    fn random_soups_build_valid_trees() {
        for (n, seed) in [(1usize, 1u64), (5, 2), (100, 3), (5000, 4)] {
            let soup = random_soup(n, 0.05, seed);
            let bvh = build(&soup, BuildParams::default()).unwrap();
            let shape = validate(&bvh, &soup, 4).unwrap();
            assert!(shape.leaves >= n.div_ceil(4));
            assert!(sah_cost(&bvh) >= 1.0);
        }
    }

    #[test]
    fn a_small_subtree_the_device_gave_up_on_is_an_error() {
        let soup = random_soup(100, 0.05, 7);
        let refs = prim_refs(&soup);
        let params = BuildParams::default();
        let mut levels = Levels::new(&root_bin(&refs), 100, params);
        let root = levels.take_stage(Stage::Small).pop().unwrap();
        let mut ids: Vec<u32> = (0..100).collect();
        let (nodes, mut summary) = build_small_subtree(&root, &mut ids, &refs, params);
        assert_eq!(summary.status, crate::bvh::layout::SMALL_OK);
        assert!(nodes.len() as u32 <= 100 - params.leaf_size);
        summary.status = crate::bvh::layout::SMALL_COUNT_MISMATCH;
        let err = levels.attach_small(&root, &nodes, &summary).unwrap_err();
        assert!(
            err.to_string()
                .contains("at node 0 (the partition moved other counts than the bins said)"),
            "{err}"
        );
    }

    #[test]
    fn identical_triangles_split_by_id_and_terminate() {
        let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
        let soup = Soup::from_triangles(&vec![tri; 1000]);
        let bvh = build(&soup, BuildParams::default()).unwrap();
        let shape = validate(&bvh, &soup, 4).unwrap();
        assert!(shape.max_depth <= 11, "depth {}", shape.max_depth);
    }
}
