//! The device tracer: compiles `kernels/trace/trace.cl` once per device (with
//! `STACK_SIZE` derived from the BVH depth limit), takes each frame's tree
//! into reused device buffers, and runs one work-item per ray over a ray
//! buffer, writing a hit buffer. Every launch is named and timed by the
//! device layer's profiling events ("trace/closest", "trace/any",
//! "trace/stackless", "trace/primary").
//!
//! The renderer's frame loop: `DeviceBuilder::build_from_device` →
//! `upload_bvh(&bvh)` (or `upload_wide` / `upload_stackless` for the other
//! traversals; `TreeLayouts` keeps all three) →
//! `generate_primary` / `trace(kind, positions, builder.device_prim_ids(),
//! rays, hits, n)` as often as the bounces need, all on the device.

use super::escape::{stackless_layout_into, StacklessNode};
use super::quantized::{quantize_into, Wide8QNode};
use super::settings::Traversal;
use super::traverse::check_depth;
use super::wide::{
    wide_layout_into, LeafBlock, Wide8Node, WideLayout, WideNode, LEAF_BLOCK_FLOAT4S,
};
use super::{Hit, PinholeCamera, Ray, TraceError};
use crate::bvh::{Bvh, BvhNode, MAX_DEPTH};
use crate::device::{Arg, BufferArg, Device, GrowBuffer};
use opencl3::kernel::Kernel;
use opencl3::memory::Buffer;
use std::time::Instant;

/// Which traversal a `trace` launch runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum TraceKind {
    /// Closest hit, front-to-back stack traversal.
    Closest,
    /// Any hit (shadow rays): stops at the first hit.
    Any,
    /// Closest hit, stackless escape-index traversal (needs
    /// `upload_stackless` after each build).
    ClosestStackless,
    /// Closest hit, front-to-back stack traversal of the 4-wide layout
    /// (needs `upload_wide` after each build).
    ClosestWide,
    /// Any hit through the 4-wide layout.
    AnyWide,
    /// Closest hit through the 8-wide layout (needs `upload_wide8`).
    ClosestWide8,
    /// Any hit through the 8-wide layout.
    AnyWide8,
    /// Closest hit through the 8-wide layout with quantized boxes (needs
    /// `upload_wide8_quantized`).
    ClosestWide8Q,
    /// Any hit through the quantized 8-wide layout.
    AnyWide8Q,
}

impl TraceKind {
    /// Every kind, in declaration order (`kind as usize` indexes it).
    const ALL: [TraceKind; 9] = [
        TraceKind::Closest,
        TraceKind::Any,
        TraceKind::ClosestStackless,
        TraceKind::ClosestWide,
        TraceKind::AnyWide,
        TraceKind::ClosestWide8,
        TraceKind::AnyWide8,
        TraceKind::ClosestWide8Q,
        TraceKind::AnyWide8Q,
    ];

    /// The kernel of `trace.cl` that runs it.
    fn kernel_name(self) -> &'static str {
        match self {
            TraceKind::Closest => "trace_closest",
            TraceKind::Any => "trace_any",
            TraceKind::ClosestStackless => "trace_closest_stackless",
            TraceKind::ClosestWide => "trace_closest_wide",
            TraceKind::AnyWide => "trace_any_wide",
            TraceKind::ClosestWide8 => "trace_closest_wide8",
            TraceKind::AnyWide8 => "trace_any_wide8",
            TraceKind::ClosestWide8Q => "trace_closest_wide8q",
            TraceKind::AnyWide8Q => "trace_any_wide8q",
        }
    }

    /// Whether it reads a wide layout (and its leaves' triangles).
    fn is_wide(self) -> bool {
        matches!(
            self,
            TraceKind::ClosestWide
                | TraceKind::AnyWide
                | TraceKind::ClosestWide8
                | TraceKind::AnyWide8
                | TraceKind::ClosestWide8Q
                | TraceKind::AnyWide8Q
        )
    }

    /// The name its launches are timed under (`Timings::ms`).
    pub fn stage(self) -> &'static str {
        match self {
            TraceKind::Closest => "trace/closest",
            TraceKind::Any => "trace/any",
            TraceKind::ClosestStackless => "trace/stackless",
            TraceKind::ClosestWide => "trace/closest_wide",
            TraceKind::AnyWide => "trace/any_wide",
            TraceKind::ClosestWide8 => "trace/closest_wide8",
            TraceKind::AnyWide8 => "trace/any_wide8",
            TraceKind::ClosestWide8Q => "trace/closest_wide8q",
            TraceKind::AnyWide8Q => "trace/any_wide8q",
        }
    }
}

/// The cost of making a traversal layout (stackless, 4-wide or 8-wide) for
/// one tree.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct LayoutStats {
    /// Host time to compute the layout from the tree.
    pub layout_ms: f64,
    /// Wall time of the upload.
    pub upload_ms: f64,
    /// Entries (stackless) or nodes (4-wide, 8-wide) of the layout.
    pub entries: usize,
}

/// A frame's tree on the device in the layout each traversal reads: the
/// binary nodes as built, their 4-wide and 8-wide collapses, the stackless
/// entries. Buffers (and the host scratch of the layouts) are kept from
/// frame to frame and grow only when a tree outgrows them. Shared by
/// `DeviceTracer` and the path tracer.
#[derive(Default)]
pub struct TreeLayouts {
    nodes: GrowBuffer<BvhNode>,
    /// The depth of the uploaded binary tree; `None`: none uploaded.
    depth: Option<u32>,
    wide4: WideTree<WideNode>,
    wide8: WideTree<Wide8Node>,
    /// The 8-wide layout quantized (`upload_wide8_quantized`); its leaves
    /// are the 8-wide layout's.
    wide8q: GrowBuffer<Wide8QNode>,
    wide8q_host: Vec<Wide8QNode>,
    wide8q_count: usize,
    snodes: GrowBuffer<StacklessNode>,
    snode_host: Vec<StacklessNode>,
    snode_count: usize,
}

impl TreeLayouts {
    /// Device buffer (re)allocations so far.
    pub fn allocations(&self) -> usize {
        self.nodes.allocations()
            + self.wide4.allocations()
            + self.wide8.allocations()
            + self.wide8q.allocations()
            + self.snodes.allocations()
    }

    /// Checks the tree's depth against the stack and uploads its nodes.
    /// Returns the depth.
    pub fn upload_binary(&mut self, device: &Device, bvh: &Bvh) -> Result<u32, TraceError> {
        self.depth = None;
        let depth = check_depth(bvh)?;
        device.write(self.nodes.ensure(device, bvh.nodes.len())?, &bvh.nodes)?;
        self.depth = Some(depth);
        Ok(depth)
    }

    /// Computes the escape-index layout on the host and uploads it.
    pub fn upload_stackless(
        &mut self,
        device: &Device,
        bvh: &Bvh,
    ) -> Result<LayoutStats, TraceError> {
        self.snode_count = 0;
        let start = Instant::now();
        stackless_layout_into(bvh, &mut self.snode_host)?;
        let stats = upload_layout(device, &mut self.snodes, &self.snode_host, start)?;
        self.snode_count = stats.entries;
        Ok(stats)
    }

    /// Checks the tree's depth, collapses it into the wide layout of
    /// `traversal` (`Wide` or `Wide8`) on the host, uploads that and queues
    /// the gather of its leaves.
    pub fn upload_wide(
        &mut self,
        device: &Device,
        bvh: &Bvh,
        traversal: Traversal,
        leaves: &LeafSource,
    ) -> Result<LayoutStats, TraceError> {
        match traversal {
            Traversal::Wide8 => {
                // A quantized layout of the tree before is stale now.
                self.wide8q_count = 0;
                self.wide8.upload(device, bvh, leaves)
            }
            Traversal::Wide => self.wide4.upload(device, bvh, leaves),
            Traversal::Stack | Traversal::Stackless => Err(not_wide(traversal)),
        }
    }

    /// The tree of an empty soup in every layout: an empty root for the
    /// binary and wide traversals, no stackless entries. Nothing is hit.
    pub fn upload_empty(&mut self, device: &Device) -> Result<(), TraceError> {
        device.write(self.nodes.ensure(device, 1)?, &[BvhNode::empty()])?;
        self.wide4.upload_empty(device)?;
        self.wide8.upload_empty(device)?;
        device.write(self.wide8q.ensure(device, 1)?, &[Wide8QNode::empty()])?;
        self.wide8q_count = 1;
        self.snodes.ensure(device, 1)?;
        self.depth = Some(0);
        self.snode_count = 0;
        Ok(())
    }

    /// Makes sure all three buffers exist, for a kernel that takes them all
    /// though its traversal reads one (see `buffers`).
    pub fn ensure_all(&mut self, device: &Device) -> Result<(), TraceError> {
        self.nodes.ensure(device, 1)?;
        self.wide4.nodes.ensure(device, 1)?;
        self.wide8.nodes.ensure(device, 1)?;
        self.wide4.ensure_leaves(device)?;
        self.wide8.ensure_leaves(device)?;
        self.snodes.ensure(device, 1)?;
        Ok(())
    }

    /// The binary and stackless buffers, after `ensure_all`; those never
    /// uploaded are unread (`wide_arg` gives the wide one).
    pub fn buffers(&self) -> (&Buffer<BvhNode>, &Buffer<StacklessNode>) {
        (self.nodes.get(), self.snodes.get())
    }

    /// The wide nodes a kernel compiled for `traversal` reads (8-wide for
    /// `Wide8`, else 4-wide, unread by the binary traversals), after
    /// `ensure_all`.
    pub fn wide_arg(&self, traversal: Traversal) -> &dyn BufferArg {
        if traversal == Traversal::Wide8 {
            self.wide8.nodes.get()
        } else {
            self.wide4.nodes.get()
        }
    }

    /// The wide layout's triangles in leaf order and their coordinates
    /// (`leaf_gather`) for a kernel compiled for `traversal`, after
    /// `ensure_all`; `None` for the binary and stackless traversals, which
    /// read the tree's primitive-index array.
    pub fn leaf_args(&self, traversal: Traversal) -> Option<WideLeaves<'_>> {
        match traversal {
            Traversal::Wide8 => Some(self.wide8.leaves()),
            Traversal::Wide => Some(self.wide4.leaves()),
            Traversal::Stack | Traversal::Stackless => None,
        }
    }

    /// The binary nodes, once uploaded.
    pub fn binary(&self) -> Option<&Buffer<BvhNode>> {
        self.depth.and(self.nodes.buffer())
    }

    /// The 4-wide nodes, once uploaded.
    pub fn wide(&self) -> Option<&Buffer<WideNode>> {
        self.wide4.uploaded()
    }

    /// Quantizes the uploaded 8-wide layout's host copy and uploads it.
    pub fn upload_wide8_quantized(&mut self, device: &Device) -> Result<LayoutStats, TraceError> {
        self.wide8q_count = 0;
        if self.wide8.count == 0 {
            return Err(TraceError::Malformed("no 8-wide layout to quantize".into()));
        }
        let start = Instant::now();
        quantize_into(&self.wide8.host, &mut self.wide8q_host)?;
        let stats = upload_layout(device, &mut self.wide8q, &self.wide8q_host, start)?;
        self.wide8q_count = stats.entries;
        Ok(stats)
    }

    /// The quantized 8-wide nodes, once uploaded.
    pub fn wide8_quantized(&self) -> Option<&Buffer<Wide8QNode>> {
        self.wide8q.buffer().filter(|_| self.wide8q_count > 0)
    }

    /// The 8-wide nodes, once uploaded.
    pub fn wide8(&self) -> Option<&Buffer<Wide8Node>> {
        self.wide8.uploaded()
    }

    /// The stackless entries and their count, once uploaded.
    pub fn stackless(&self) -> Option<(&Buffer<StacklessNode>, u32)> {
        let buffer = self.snodes.buffer().filter(|_| self.snode_count > 0)?;
        Some((buffer, self.snode_count as u32))
    }
}

/// The error for a wide-layout call made with a binary traversal.
fn not_wide(traversal: Traversal) -> TraceError {
    TraceError::Unsupported(format!("{traversal:?} has no wide layout"))
}

/// A wide layout's triangles in leaf order on the device (`leaf_gather`):
/// four slots per block, and per block the nine `float4`s of its corners.
pub struct WideLeaves<'a> {
    pub slots: &'a Buffer<u32>,
    pub tris: &'a Buffer<[f32; 4]>,
    /// Blocks of the last upload (0 after `upload_empty`).
    pub blocks: usize,
}

/// One W-wide layout of the frame's tree: its nodes on the device, the host
/// scratch it is collapsed into, how many nodes were uploaded (0: none), and
/// its triangles in leaf order (`wide::leaf_arrays`), gathered on the device.
struct WideTree<N> {
    nodes: GrowBuffer<N>,
    host: Vec<N>,
    count: usize,
    blocks: GrowBuffer<LeafBlock>,
    host_blocks: Vec<LeafBlock>,
    leaf_prims: GrowBuffer<u32>,
    leaf_tris: GrowBuffer<[f32; 4]>,
}

impl<N> Default for WideTree<N> {
    fn default() -> Self {
        WideTree {
            nodes: GrowBuffer::new(),
            host: Vec::new(),
            count: 0,
            blocks: GrowBuffer::new(),
            host_blocks: Vec::new(),
            leaf_prims: GrowBuffer::new(),
            leaf_tris: GrowBuffer::new(),
        }
    }
}

/// What a wide layout's leaves are gathered from on the device: the frame's
/// soup and the tree's primitive-index array, by `leaf_gather` (compiled
/// into `trace.cl` and `pathtrace.cl`). Without `with_tris` (motion blur,
/// whose corners are interpolated per ray) only the slots' triangles are
/// gathered.
pub struct LeafSource<'a> {
    pub gather: &'a Kernel,
    pub positions: &'a Buffer<[f32; 4]>,
    pub prim_ids: &'a Buffer<u32>,
    pub with_tris: bool,
}

impl<N: WideLayout> WideTree<N> {
    /// Checks the tree's depth, collapses it on the host, uploads it and
    /// queues the gather of its leaves.
    fn upload(
        &mut self,
        device: &Device,
        bvh: &Bvh,
        leaves: &LeafSource,
    ) -> Result<LayoutStats, TraceError> {
        self.count = 0;
        check_depth(bvh)?;
        let start = Instant::now();
        wide_layout_into(bvh, &mut self.host, &mut self.host_blocks)?;
        let stats = upload_layout(device, &mut self.nodes, &self.host, start)?;
        let blocks = self.host_blocks.len();
        device.write(self.blocks.ensure(device, blocks)?, &self.host_blocks)?;
        self.leaf_prims.ensure(device, 4 * blocks)?;
        let tris = if leaves.with_tris { blocks } else { 0 };
        self.leaf_tris.ensure(device, LEAF_BLOCK_FLOAT4S * tris)?;
        if blocks > 0 {
            let local = 64;
            device.launch(
                "trace/leaf_gather",
                leaves.gather,
                blocks.div_ceil(local),
                local,
                &[
                    Arg::Buf(self.blocks.get()),
                    Arg::U32(blocks as u32),
                    Arg::Buf(leaves.prim_ids),
                    Arg::Buf(leaves.positions),
                    Arg::U32(leaves.with_tris as u32),
                    Arg::Buf(self.leaf_prims.get()),
                    Arg::Buf(self.leaf_tris.get()),
                ],
            )?;
        }
        self.count = stats.entries;
        Ok(stats)
    }

    /// One node with no child: an empty tree.
    fn upload_empty(&mut self, device: &Device) -> Result<(), TraceError> {
        device.write(self.nodes.ensure(device, 1)?, &[N::empty()])?;
        self.host_blocks.clear();
        self.ensure_leaves(device)?;
        self.count = 1;
        Ok(())
    }

    fn ensure_leaves(&mut self, device: &Device) -> Result<(), TraceError> {
        self.leaf_prims.ensure(device, 1)?;
        self.leaf_tris.ensure(device, 1)?;
        Ok(())
    }

    fn uploaded(&self) -> Option<&Buffer<N>> {
        self.nodes.buffer().filter(|_| self.count > 0)
    }

    /// The slots' triangles and the blocks' coordinates, after `upload` or
    /// `ensure_leaves`.
    fn leaves(&self) -> WideLeaves<'_> {
        WideLeaves {
            slots: self.leaf_prims.get(),
            tris: self.leaf_tris.get(),
            blocks: self.host_blocks.len(),
        }
    }

    fn allocations(&self) -> usize {
        self.nodes.allocations()
            + self.blocks.allocations()
            + self.leaf_prims.allocations()
            + self.leaf_tris.allocations()
    }
}

/// Uploads a layout made on the host since `start` into `buffer`.
fn upload_layout<T>(
    device: &Device,
    buffer: &mut GrowBuffer<T>,
    host: &[T],
    start: Instant,
) -> Result<LayoutStats, TraceError> {
    let layout_ms = start.elapsed().as_secs_f64() * 1e3;
    let start = Instant::now();
    device.write(buffer.ensure(device, host.len())?, host)?;
    Ok(LayoutStats {
        layout_ms,
        upload_ms: start.elapsed().as_secs_f64() * 1e3,
        entries: host.len(),
    })
}

/// The defines `trace.cl` is compiled with: the traversal stack holds one
/// entry per inner-node level.
pub fn trace_defines() -> Vec<(&'static str, String)> {
    vec![("STACK_SIZE", (MAX_DEPTH + 1).to_string())]
}

/// The trace kernels and the current tree, on one device.
pub struct DeviceTracer<'d> {
    device: &'d Device,
    /// One per `TraceKind`, at `kind as usize`.
    kernels: Vec<Kernel>,
    primary: Kernel,
    leaf_gather: Kernel,
    layouts: TreeLayouts,
    /// Scratch for `trace_rays` (tests, tools).
    rays: GrowBuffer<Ray>,
    hits: GrowBuffer<Hit>,
    /// Work-items per work-group of the trace launches.
    pub local_size: usize,
}

impl<'d> DeviceTracer<'d> {
    /// Compiles the trace kernels. The traversal stack holds one entry per
    /// inner-node level: `STACK_SIZE = MAX_DEPTH + 1`, and `upload_bvh`
    /// refuses deeper trees.
    pub fn new(device: &'d Device) -> Result<DeviceTracer<'d>, TraceError> {
        Self::with_defines(device, &[])
    }

    /// As [`DeviceTracer::new`], with `extra` defines on top of
    /// [`trace_defines`]: a kernel variant, for measuring a candidate
    /// against the default in one process (`benches/trace_primary.rs`).
    pub fn with_defines(
        device: &'d Device,
        extra: &[(&str, String)],
    ) -> Result<DeviceTracer<'d>, TraceError> {
        let mut defines: Vec<(&str, String)> = trace_defines();
        defines.extend(extra.iter().cloned());
        let program = device.build_program("trace.cl", &defines)?;
        let k = |name| device.kernel(&program, name);
        Ok(DeviceTracer {
            device,
            kernels: TraceKind::ALL
                .iter()
                .map(|kind| k(kind.kernel_name()))
                .collect::<Result<_, _>>()?,
            primary: k("generate_primary")?,
            leaf_gather: k("leaf_gather")?,
            layouts: TreeLayouts::default(),
            rays: GrowBuffer::new(),
            hits: GrowBuffer::new(),
            local_size: 64,
        })
    }

    /// Device buffer (re)allocations so far: only when a frame outgrows the
    /// buffers, never every frame.
    pub fn allocations(&self) -> usize {
        self.layouts.allocations() + self.rays.allocations() + self.hits.allocations()
    }

    /// Checks the tree's depth against the stack and uploads its nodes into
    /// the reused node buffer. Returns the depth. The primitive-index array
    /// stays where the builder left it (`DeviceBuilder::device_prim_ids`).
    pub fn upload_bvh(&mut self, bvh: &Bvh) -> Result<u32, TraceError> {
        self.layouts.upload_binary(self.device, bvh)
    }

    /// Computes the tree's escape-index layout on the host and uploads it:
    /// needed after every build before `TraceKind::ClosestStackless`.
    pub fn upload_stackless(&mut self, bvh: &Bvh) -> Result<LayoutStats, TraceError> {
        self.layouts.upload_stackless(self.device, bvh)
    }

    /// Collapses the tree into the 4-wide layout on the host, uploads it and
    /// gathers its leaves' triangles from `positions` (the soup) through
    /// `prim_ids` (the tree's primitive-index array): needed after every
    /// build before `ClosestWide`/`AnyWide`.
    pub fn upload_wide(
        &mut self,
        bvh: &Bvh,
        positions: &Buffer<[f32; 4]>,
        prim_ids: &Buffer<u32>,
    ) -> Result<LayoutStats, TraceError> {
        self.upload_wide_as(Traversal::Wide, bvh, positions, prim_ids)
    }

    /// As `upload_wide`, the 8-wide layout: needed after every build before
    /// `ClosestWide8`/`AnyWide8`.
    pub fn upload_wide8(
        &mut self,
        bvh: &Bvh,
        positions: &Buffer<[f32; 4]>,
        prim_ids: &Buffer<u32>,
    ) -> Result<LayoutStats, TraceError> {
        self.upload_wide_as(Traversal::Wide8, bvh, positions, prim_ids)
    }

    /// As `upload_wide8`, then the same layout with quantized boxes: needed
    /// after every build before `ClosestWide8Q`/`AnyWide8Q`.
    pub fn upload_wide8_quantized(
        &mut self,
        bvh: &Bvh,
        positions: &Buffer<[f32; 4]>,
        prim_ids: &Buffer<u32>,
    ) -> Result<LayoutStats, TraceError> {
        let wide = self.upload_wide_as(Traversal::Wide8, bvh, positions, prim_ids)?;
        let q = self.layouts.upload_wide8_quantized(self.device)?;
        Ok(LayoutStats {
            layout_ms: wide.layout_ms + q.layout_ms,
            upload_ms: wide.upload_ms + q.upload_ms,
            entries: q.entries,
        })
    }

    fn upload_wide_as(
        &mut self,
        traversal: Traversal,
        bvh: &Bvh,
        positions: &Buffer<[f32; 4]>,
        prim_ids: &Buffer<u32>,
    ) -> Result<LayoutStats, TraceError> {
        // The tracer's soups are static: the corners are gathered too.
        let leaves = LeafSource {
            gather: &self.leaf_gather,
            positions,
            prim_ids,
            with_tris: true,
        };
        self.layouts
            .upload_wide(self.device, bvh, traversal, &leaves)
    }

    /// The slots' triangles and the blocks' corners of the wide layout
    /// `traversal` reads, as gathered on the device (blocking; for tests).
    pub fn read_leaves(
        &self,
        traversal: Traversal,
    ) -> Result<(Vec<u32>, Vec<[f32; 4]>), TraceError> {
        let leaves = self
            .layouts
            .leaf_args(traversal)
            .ok_or_else(|| not_wide(traversal))?;
        let mut slots = vec![0u32; 4 * leaves.blocks];
        let mut tris = vec![[0.0f32; 4]; LEAF_BLOCK_FLOAT4S * leaves.blocks];
        self.device.read(leaves.slots, &mut slots)?;
        self.device.read(leaves.tris, &mut tris)?;
        self.device.finish()?;
        Ok((slots, tris))
    }

    /// Queues `kind` over the first `n` rays of `rays`, writing `hits`.
    /// `positions` is the frame's soup (three `float4` per triangle) and
    /// `prim_ids` the tree's primitive-index array, both on the device; the
    /// wide kinds read the triangles their upload gathered from these.
    /// Nothing waits: `Device::finish` (or a blocking read) does.
    pub fn trace(
        &self,
        kind: TraceKind,
        positions: &Buffer<[f32; 4]>,
        prim_ids: &Buffer<u32>,
        rays: &Buffer<Ray>,
        hits: &Buffer<Hit>,
        n: usize,
    ) -> Result<(), TraceError> {
        if n == 0 {
            return Ok(());
        }
        let count = u32::try_from(n)
            .map_err(|_| TraceError::Unsupported(format!("{n} rays in one launch")))?;
        let groups = n.div_ceil(self.local_size);
        let missing =
            |what: &str, fix: &str| TraceError::Malformed(format!("no {what} uploaded ({fix})"));
        // The tree's arguments for this kind, then the ones all kernels share.
        let mut args = match kind {
            TraceKind::Closest | TraceKind::Any => {
                let nodes = self.layouts.binary();
                vec![Arg::Buf(
                    nodes.ok_or_else(|| missing("tree", "upload_bvh"))?,
                )]
            }
            TraceKind::ClosestWide
            | TraceKind::AnyWide
            | TraceKind::ClosestWide8
            | TraceKind::AnyWide8
            | TraceKind::ClosestWide8Q
            | TraceKind::AnyWide8Q => {
                // The nodes, then the leaves they share with their layout.
                let (nodes, traversal): (Option<&dyn BufferArg>, _) = match kind {
                    TraceKind::ClosestWide | TraceKind::AnyWide => (
                        self.layouts.wide().map(|b| b as &dyn BufferArg),
                        Traversal::Wide,
                    ),
                    TraceKind::ClosestWide8 | TraceKind::AnyWide8 => (
                        self.layouts.wide8().map(|b| b as &dyn BufferArg),
                        Traversal::Wide8,
                    ),
                    _ => (
                        self.layouts.wide8_quantized().map(|b| b as &dyn BufferArg),
                        Traversal::Wide8,
                    ),
                };
                let nodes = nodes.ok_or_else(|| {
                    missing(
                        &format!("{kind:?} layout"),
                        "upload_wide, upload_wide8 or upload_wide8_quantized",
                    )
                })?;
                let leaves = self.layouts.leaf_args(traversal).expect("uploaded");
                vec![
                    Arg::Buf(nodes),
                    Arg::Buf(leaves.slots),
                    Arg::Buf(leaves.tris),
                ]
            }
            TraceKind::ClosestStackless => {
                let (snodes, entries) = self
                    .layouts
                    .stackless()
                    .ok_or_else(|| missing("stackless layout", "upload_stackless"))?;
                vec![Arg::Buf(snodes), Arg::U32(entries)]
            }
        };
        if !kind.is_wide() {
            args.push(Arg::Buf(prim_ids));
        }
        args.extend([
            Arg::Buf(positions),
            Arg::Buf(rays),
            Arg::Buf(hits),
            Arg::U32(count),
        ]);
        let kernel = &self.kernels[kind as usize];
        self.device
            .launch(kind.stage(), kernel, groups, self.local_size, &args)?;
        Ok(())
    }

    /// Queues the generation of `camera`'s primary rays (row-major, one per
    /// pixel) into `rays`, which must hold `width * height` rays.
    pub fn generate_primary(
        &self,
        camera: &PinholeCamera,
        rays: &Buffer<Ray>,
    ) -> Result<(), TraceError> {
        let n = camera.width as usize * camera.height as usize;
        let [ox, oy, oz] = camera.origin;
        let [p0x, p0y, p0z] = camera.p00;
        let [dux, duy, duz] = camera.du;
        let [dvx, dvy, dvz] = camera.dv;
        self.device.launch(
            "trace/primary",
            &self.primary,
            n.div_ceil(self.local_size),
            self.local_size,
            &[
                Arg::Buf(rays),
                Arg::U32(camera.width),
                Arg::U32(camera.height),
                Arg::F32(ox),
                Arg::F32(oy),
                Arg::F32(oz),
                Arg::F32(p0x),
                Arg::F32(p0y),
                Arg::F32(p0z),
                Arg::F32(dux),
                Arg::F32(duy),
                Arg::F32(duz),
                Arg::F32(dvx),
                Arg::F32(dvy),
                Arg::F32(dvz),
            ],
        )?;
        Ok(())
    }

    /// Uploads host rays, traces them and reads the hits back (blocking),
    /// through scratch buffers kept from call to call. For tests and tools;
    /// the renderer keeps rays and hits on the device with `trace`.
    pub fn trace_rays(
        &mut self,
        kind: TraceKind,
        positions: &Buffer<[f32; 4]>,
        prim_ids: &Buffer<u32>,
        rays: &[Ray],
    ) -> Result<Vec<Hit>, TraceError> {
        let n = rays.len();
        let mut hits = vec![Hit::miss(0.0); n];
        if n == 0 {
            return Ok(hits);
        }
        let result = (|| {
            self.device.write(self.rays.ensure(self.device, n)?, rays)?;
            self.hits.ensure(self.device, n)?;
            self.trace(
                kind,
                positions,
                prim_ids,
                self.rays.get(),
                self.hits.get(),
                n,
            )?;
            self.device.read(self.hits.get(), &mut hits)?;
            self.device.finish()?;
            Ok::<(), TraceError>(())
        })();
        result.map(|()| hits)
    }
}
