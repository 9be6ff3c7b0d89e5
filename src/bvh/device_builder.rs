//! The paper's builder on the OpenCL device (kernels/bvh/bvh_build.cl).
//!
//! The host only launches and bookkeeps: per level it uploads the level's
//! tasks and the two work-group arrays (which node each work-group serves,
//! and its index within that node), launches the stage's kernels for every
//! task of the level at once, reads back the split results, and lets
//! `binned::Levels` (shared with the Rust reference) turn them into nodes and
//! the next level's tasks. The small stage is one launch in which each small
//! node's work-group builds its whole subtree; the host packs the subtrees'
//! nodes on the device, reads them back in one piece and attaches them.
//! Binning, the split search and the reordering all run on the device.
//!
//! Buffers are sized for the largest soup seen so far and reused from frame
//! to frame; `allocations()` counts them so a test can prove it.

use super::binned::{BuildError, Levels, Stage, PRIMS_PER_GROUP, REDUCE_FAN};
use super::layout::{Bin, BuildTask, BvhNode, PrimRef, SmallSubtree, SplitResult};
use super::{BuildParams, Bvh};
use crate::device::{Arg, Device};
use crate::soup::Soup;
use opencl3::event::Event;
use opencl3::kernel::Kernel;
use opencl3::memory::Buffer;
use std::time::Instant;

/// Device time per stage of one build, in milliseconds, from profiling
/// events. `soupray bvh --json` and the per-frame log report it as is.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize, serde::Deserialize)]
#[serde(default)]
pub struct StageTimes {
    /// Triangle boxes and the root's bounds.
    pub prepare: f64,
    pub large: f64,
    pub medium: f64,
    pub small: f64,
}

/// What one build cost.
#[derive(Clone, Debug, Default, PartialEq, serde::Serialize)]
pub struct BuildStats {
    /// Wall-clock time of the whole build, uploads and host work included.
    pub build_ms: f64,
    /// Device (kernel) time by stage.
    pub stages_ms: StageTimes,
    /// Host time spent generating tasks and nodes.
    pub host_ms: f64,
    /// Levels processed over all stages.
    pub levels: u32,
    pub kernel_launches: usize,
    /// Device time of each kernel, "stage/kernel" → ms.
    #[serde(skip)]
    pub kernels_ms: std::collections::BTreeMap<String, f64>,
}

struct Kernels {
    compute_prim_refs: Kernel,
    merge_bins: Kernel,
    bin_triangles: Kernel,
    reduce_bins: Kernel,
    find_split: Kernel,
    partition: Kernel,
    gather_ranges: Kernel,
    build_small: Kernel,
    pack_small_nodes: Kernel,
}

/// Device buffers, sized for `capacity` triangles.
struct Buffers {
    capacity: usize,
    /// Triangle boxes, in the same slot order as `ids` (they move together).
    refs: Buffer<PrimRef>,
    refs_scratch: Buffer<PrimRef>,
    ids: Buffer<u32>,
    ids_scratch: Buffer<u32>,
    /// Finished slot ranges to copy from the scratch pair at the end.
    ranges: Buffer<[u32; 2]>,
    /// Per-work-group bins of `compute_prim_refs`, then the root bin.
    root_partials: Buffer<Bin>,
    root_bin: Buffer<Bin>,
    tasks: Buffer<BuildTask>,
    group_task: Buffer<u32>,
    group_index: Buffer<u32>,
    reduce_task: Buffer<u32>,
    reduce_index: Buffer<u32>,
    group_bins: Buffer<Bin>,
    partial_bins: Buffer<Bin>,
    splits: Buffer<SplitResult>,
    cursors: Buffer<u64>,
    /// The small subtrees' nodes where `build_small` writes them (from each
    /// small node's first slot on), their summaries, and the packed copy.
    small_scratch: Buffer<BvhNode>,
    small_results: Buffer<SmallSubtree>,
    small_offsets: Buffer<u32>,
    small_packed: Buffer<BvhNode>,
}

/// How the kernels map onto the device's threads (see the header of
/// `kernels/bvh/bvh_build.cl`). Both mappings build the same tree, bit for bit.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
pub enum Mapping {
    /// The paper's: work-groups of 128, bins counted by groups of `bins`
    /// threads over blocks of `bins` triangles, small nodes by one such group.
    /// For GPUs, whose SIMD lanes make the 16-pass walk free.
    Paper,
    /// One work-item per work-group keeps every bin private. For CPU devices,
    /// where the paper's walk would do each triangle's work 16 times.
    SingleLane,
}

impl Mapping {
    /// The mapping for a device: single-lane on CPUs, the paper's elsewhere.
    /// `SOUPRAY_BVH_MAPPING=paper|single-lane` overrides it (tests use this
    /// to run the GPU mapping on PoCL).
    pub fn for_device(device: &Device) -> Mapping {
        match std::env::var("SOUPRAY_BVH_MAPPING").as_deref() {
            Ok("paper") => Mapping::Paper,
            Ok("single-lane") => Mapping::SingleLane,
            _ if device.info.kind == "CPU" => Mapping::SingleLane,
            _ => Mapping::Paper,
        }
    }

    fn build_wg(self) -> usize {
        match self {
            Mapping::Paper => 128,
            Mapping::SingleLane => 1,
        }
    }

    fn bin_lanes(self, bins: u32) -> u32 {
        match self {
            Mapping::Paper => bins,
            Mapping::SingleLane => 1,
        }
    }
}

/// The defines `bvh_build.cl` is compiled with, assembled here and nowhere
/// else (`tests/kernels_portable.rs` compiles every combination with clang).
pub fn program_defines(
    params: BuildParams,
    mapping: Mapping,
    int64_atomics: bool,
) -> Vec<(&'static str, String)> {
    let lanes = mapping.bin_lanes(params.bins);
    vec![
        ("BINS", params.bins.to_string()),
        ("BUILD_WG", mapping.build_wg().to_string()),
        ("BIN_LANES", lanes.to_string()),
        ("SMALL_WG", lanes.to_string()),
        ("LEAF_SIZE", params.leaf_size.to_string()),
        ("HAVE_INT64_ATOMICS", (int64_atomics as u32).to_string()),
    ]
}

/// The builder: compiled kernels and reusable buffers for one device.
pub struct DeviceBuilder<'d> {
    device: &'d Device,
    params: BuildParams,
    mapping: Mapping,
    kernels: Kernels,
    buffers: Option<Buffers>,
    /// Where `build` uploads a host soup (`build_from_device` reads the
    /// caller's buffer instead).
    upload: Option<Buffer<[f32; 4]>>,
    upload_capacity: usize,
    allocations: usize,
    // Host-side scratch, reused across levels and frames.
    /// The level being built (large and medium stages), or the small
    /// stage's roots: its copy on the device is queued from here.
    level: Vec<BuildTask>,
    group_task: Vec<u32>,
    group_index: Vec<u32>,
    reduce_task: Vec<u32>,
    reduce_index: Vec<u32>,
    splits: Vec<SplitResult>,
    cursors: Vec<u64>,
    small_results: Vec<SmallSubtree>,
    small_offsets: Vec<u32>,
    small_nodes: Vec<BvhNode>,
    pending_check: Option<PendingCheck>,
}

impl<'d> DeviceBuilder<'d> {
    /// Compiles the builder's kernels for `params` on `device`, with the
    /// device's mapping (`Mapping::for_device`).
    pub fn new(device: &'d Device, params: BuildParams) -> Result<DeviceBuilder<'d>, BuildError> {
        Self::with_mapping(device, params, Mapping::for_device(device))
    }

    pub fn with_mapping(
        device: &'d Device,
        params: BuildParams,
        mapping: Mapping,
    ) -> Result<DeviceBuilder<'d>, BuildError> {
        params.check().map_err(BuildError::Params)?;
        let defines = program_defines(params, mapping, device.has_int64_atomics());
        let program = device.build_program("bvh_build.cl", &defines)?;
        let k = |name| device.kernel(&program, name);
        let kernels = Kernels {
            compute_prim_refs: k("compute_prim_refs")?,
            merge_bins: k("merge_bins")?,
            bin_triangles: k("bin_triangles")?,
            reduce_bins: k("reduce_bins")?,
            find_split: k("find_split")?,
            partition: k("partition")?,
            gather_ranges: k("gather_ranges")?,
            build_small: k("build_small")?,
            pack_small_nodes: k("pack_small_nodes")?,
        };
        // The local arrays grow with the bin count (3 * bins bins per group
        // in build_small); refuse a count the device cannot hold, by name,
        // rather than fail at the first launch.
        let available = device.local_mem_bytes();
        for (name, kernel) in [
            ("bin_triangles", &kernels.bin_triangles),
            ("find_split", &kernels.find_split),
            ("build_small", &kernels.build_small),
        ] {
            let needed = device.kernel_local_mem(kernel)?;
            if available > 0 && needed > available {
                return Err(BuildError::Params(format!(
                    "--bins {} is too many for {}: the builder's {name} kernel needs {} bytes of \
                     local memory with the {mapping:?} mapping and the device has {available}; \
                     use fewer bins (16 is the default), or the single-lane mapping \
                     (SOUPRAY_BVH_MAPPING=single-lane), which keeps bins in private memory",
                    params.bins, device.info.name, needed
                )));
            }
        }
        Ok(DeviceBuilder {
            device,
            params,
            mapping,
            kernels,
            buffers: None,
            upload: None,
            upload_capacity: 0,
            allocations: 0,
            level: Vec::new(),
            group_task: Vec::new(),
            group_index: Vec::new(),
            reduce_task: Vec::new(),
            reduce_index: Vec::new(),
            splits: Vec::new(),
            cursors: Vec::new(),
            small_results: Vec::new(),
            small_offsets: Vec::new(),
            small_nodes: Vec::new(),
            pending_check: None,
        })
    }

    pub fn params(&self) -> BuildParams {
        self.params
    }

    pub fn mapping(&self) -> Mapping {
        self.mapping
    }

    /// How many times the device buffers have been (re)allocated: once for
    /// the first frame, and again only when a frame has more triangles than
    /// any before it.
    pub fn allocations(&self) -> usize {
        self.allocations
    }

    fn ensure_capacity(&mut self, n: usize) -> Result<(), BuildError> {
        if self.buffers.as_ref().is_some_and(|b| b.capacity >= n) {
            return Ok(());
        }
        let d = self.device;
        let n = n.max(1);
        let bins = 3 * self.params.bins as usize;
        // Tasks of one level (and the small nodes) are disjoint and each
        // holds more than leaf_size triangles; large and medium tasks hold 256
        // or more, and only they get work-groups.
        let max_tasks = n / (self.params.leaf_size as usize + 1) + 1;
        let max_split_tasks = n / super::binned::MEDIUM_FROM as usize + 1;
        let max_groups = n / PRIMS_PER_GROUP as usize + n / super::binned::MEDIUM_FROM as usize + 1;
        let max_partials =
            max_groups / REDUCE_FAN as usize + n / super::binned::LARGE_ABOVE as usize + 1;
        self.buffers = Some(Buffers {
            capacity: n,
            refs: d.buffer(n)?,
            refs_scratch: d.buffer(n)?,
            ids: d.buffer(n)?,
            ids_scratch: d.buffer(n)?,
            // Small-node roots (each over leaf_size triangles) plus leaves cut
            // straight from nodes of 256 or more.
            ranges: d.buffer(n / (self.params.leaf_size as usize + 1) + n / 128 + 2)?,
            root_partials: d.buffer(n.div_ceil(PRIMS_PER_GROUP as usize))?,
            root_bin: d.buffer(1)?,
            tasks: d.buffer(max_tasks)?,
            group_task: d.buffer(max_groups)?,
            group_index: d.buffer(max_groups)?,
            reduce_task: d.buffer(max_partials)?,
            reduce_index: d.buffer(max_partials)?,
            group_bins: d.buffer(max_groups * bins)?,
            partial_bins: d.buffer(max_partials * bins)?,
            splits: d.buffer(max_split_tasks)?,
            cursors: d.buffer(max_split_tasks)?,
            // A subtree of m triangles has at most m - leaf_size nodes.
            small_scratch: d.buffer(n)?,
            small_results: d.buffer(max_tasks)?,
            small_offsets: d.buffer(max_tasks + 1)?,
            small_packed: d.buffer(n)?,
        });
        self.allocations += 1;
        Ok(())
    }

    /// Uploads `soup` and builds its tree.
    pub fn build(&mut self, soup: &Soup) -> Result<(Bvh, BuildStats), BuildError> {
        let start = Instant::now();
        let n = soup.triangle_count();
        if self.upload.is_none() || self.upload_capacity < n {
            self.upload = Some(self.device.buffer(3 * n.max(1))?);
            self.upload_capacity = n;
            self.allocations += 1;
        }
        let mut upload = self.upload.take().expect("allocated above");
        let result = self
            .device
            .write(&mut upload, &soup.positions)
            .map_err(BuildError::from)
            .and_then(|()| self.build_timed(&upload, n, start));
        self.upload = Some(upload);
        result
    }

    /// Builds the tree of the `n` triangles whose corners are already in
    /// `positions` on the device (three `float4` per triangle), as the
    /// frame's soup kernel leaves them: nothing crosses to the host.
    pub fn build_from_device(
        &mut self,
        positions: &Buffer<[f32; 4]>,
        n: usize,
    ) -> Result<(Bvh, BuildStats), BuildError> {
        self.build_timed(positions, n, Instant::now())
    }

    /// The primitive-index array of the last build, still on the device:
    /// leaf slot → triangle index, for the tracer.
    pub fn device_prim_ids(&self) -> Option<&Buffer<u32>> {
        self.buffers.as_ref().map(|b| &b.ids)
    }

    fn build_timed(
        &mut self,
        positions: &Buffer<[f32; 4]>,
        n: usize,
        start: Instant,
    ) -> Result<(Bvh, BuildStats), BuildError> {
        let built = self.build_levels(positions, n, start);
        if built.is_err() {
            // Copies and reads queued without waiting use the builder's own
            // vectors (the level, its tables, the splits, the cursors):
            // drain the queue before they are touched again.
            let _ = self.device.finish();
        }
        built
    }

    fn build_levels(
        &mut self,
        positions: &Buffer<[f32; 4]>,
        n: usize,
        start: Instant,
    ) -> Result<(Bvh, BuildStats), BuildError> {
        self.ensure_capacity(n)?;
        let d = self.device;
        let mut host = 0.0;
        let mut levels_done = 0;
        d.take_timings()?; // start this build's profile from zero
        let b = self.buffers.as_mut().expect("allocated above");
        let root = if n == 0 {
            super::binned::bin_empty()
        } else {
            let groups = n.div_ceil(PRIMS_PER_GROUP as usize);
            let wg = self.mapping.build_wg();
            let k = &self.kernels;
            d.launch(
                "bvh.prepare/compute_prim_refs",
                &k.compute_prim_refs,
                groups,
                wg,
                &[
                    Arg::Buf(positions),
                    Arg::U32(n as u32),
                    Arg::Buf(&b.refs),
                    Arg::Buf(&b.ids),
                    Arg::Buf(&b.root_partials),
                ],
            )?;
            d.launch(
                "bvh.prepare/merge_bins",
                &k.merge_bins,
                1,
                wg,
                &[
                    Arg::Buf(&b.root_partials),
                    Arg::U32(groups as u32),
                    Arg::Buf(&b.root_bin),
                ],
            )?;
            let mut root = [super::binned::bin_empty()];
            d.read(&b.root_bin, &mut root)?;
            root[0]
        };
        let t0 = Instant::now();
        let mut levels = Levels::new(&root, n as u32, self.params);
        host += t0.elapsed().as_secs_f64();
        for stage in [Stage::Large, Stage::Medium] {
            self.level = levels.take_stage(stage);
            while !self.level.is_empty() {
                self.run_level(stage)?;
                let t0 = Instant::now();
                self.level = levels.accept(stage, &self.level, &self.splits)?;
                host += t0.elapsed().as_secs_f64();
                levels_done += 1;
            }
        }
        self.check_cursors()?;
        self.level = levels.take_stage(Stage::Small);
        if !self.level.is_empty() {
            self.run_small_stage()?;
            let t0 = Instant::now();
            let small = &self.level;
            // Every packed node but the small nodes themselves is new.
            levels
                .nodes
                .reserve(self.small_nodes.len().saturating_sub(small.len()));
            for ((root, summary), range) in small
                .iter()
                .zip(&self.small_results)
                .zip(self.small_offsets.windows(2))
            {
                let nodes = &self.small_nodes[range[0] as usize..range[1] as usize];
                levels.attach_small(root, nodes, summary)?;
            }
            host += t0.elapsed().as_secs_f64();
            levels_done += 1;
        }
        let b = self.buffers.as_mut().expect("allocated above");
        if !levels.finished_in_second.is_empty() {
            d.write(&mut b.ranges, &levels.finished_in_second)?;
            d.launch(
                "bvh.small/gather_ranges",
                &self.kernels.gather_ranges,
                levels.finished_in_second.len(),
                self.mapping.build_wg(),
                &[
                    Arg::Buf(&b.ranges),
                    Arg::Buf(&b.ids_scratch),
                    Arg::Buf(&b.ids),
                ],
            )?;
        }
        let mut prim_ids = vec![0u32; n];
        d.read(&b.ids, &mut prim_ids)?;
        let timings = d.take_timings()?;
        let stats = BuildStats {
            build_ms: start.elapsed().as_secs_f64() * 1e3,
            stages_ms: StageTimes {
                prepare: timings.ms("bvh.prepare"),
                large: timings.ms("bvh.large"),
                medium: timings.ms("bvh.medium"),
                small: timings.ms("bvh.small"),
            },
            host_ms: host * 1e3,
            levels: levels_done,
            kernel_launches: timings.launches,
            kernels_ms: timings.by_stage.clone(),
        };
        Ok((
            Bvh {
                nodes: levels.nodes,
                prim_ids,
            },
            stats,
        ))
    }

    /// Runs one level of `stage` on the device and leaves the level's split
    /// results, with their final counts, in `self.splits`.
    fn run_level(&mut self, stage: Stage) -> Result<(), BuildError> {
        self.check_cursors()?;
        // The two arrays that tell each work-group its node and its index
        // within the node, and the same for the large stage's reduction.
        self.group_task.clear();
        self.group_index.clear();
        self.reduce_task.clear();
        self.reduce_index.clear();
        let mut partials = 0u32;
        for (ti, t) in self.level.iter_mut().enumerate() {
            t.first_group = self.group_task.len() as u32;
            t.group_count = t.count.div_ceil(PRIMS_PER_GROUP);
            for gi in 0..t.group_count {
                self.group_task.push(ti as u32);
                self.group_index.push(gi);
            }
            if stage == Stage::Large {
                t.set_first = partials;
                t.set_count = t.group_count.div_ceil(REDUCE_FAN);
                for r in 0..t.set_count {
                    self.reduce_task.push(ti as u32);
                    self.reduce_index.push(r);
                }
                partials += t.set_count;
            } else {
                t.set_first = t.first_group;
                t.set_count = t.group_count;
            }
        }
        let groups = self.group_task.len();
        let (splits_read, cursors_read) = self.enqueue_level(stage, groups)?;
        splits_read
            .wait()
            .map_err(|e| device_error("reading splits", e))?;
        self.pending_check = Some(PendingCheck {
            cursors_read,
            nodes: self.level.iter().map(|t| t.node).collect(),
        });
        if self.splits.iter().any(|s| s.axis < 0) {
            self.check_cursors()?;
        }
        Ok(())
    }

    /// Queues one level of `stage`: its tables, the binning (and the large
    /// stage's reduction), the split search and the partition, and the
    /// reads of the splits and the partition's cursors, whose events it
    /// returns.
    fn enqueue_level(&mut self, stage: Stage, groups: usize) -> Result<(Event, Event), BuildError> {
        let d = self.device;
        let b = self.buffers.as_mut().expect("allocated by the caller");
        let k = &self.kernels;
        let wg = self.mapping.build_wg();
        let tasks = self.level.len();
        let name = level_kernel_name(stage);
        // Without a round trip each (PoCL blocks a write for tens of
        // microseconds, and a level has up to five).
        // SAFETY: the level and its tables are the builder's own, untouched
        // until run_level's wait on the splits' read, queued after these
        // (the queue is in order), or build_timed's drain on an error.
        unsafe {
            d.write_async(&mut b.tasks, &self.level)?;
            d.write_async(&mut b.group_task, &self.group_task)?;
            d.write_async(&mut b.group_index, &self.group_index)?;
        }
        d.launch(
            name("bin"),
            &k.bin_triangles,
            groups,
            wg,
            &[
                Arg::Buf(&b.tasks),
                Arg::Buf(&b.group_task),
                Arg::Buf(&b.group_index),
                Arg::Buf(&b.ids),
                Arg::Buf(&b.refs),
                Arg::Buf(&b.ids_scratch),
                Arg::Buf(&b.refs_scratch),
                Arg::Buf(&b.group_bins),
            ],
        )?;
        let sets = if stage == Stage::Large {
            // SAFETY: as above.
            unsafe {
                d.write_async(&mut b.reduce_task, &self.reduce_task)?;
                d.write_async(&mut b.reduce_index, &self.reduce_index)?;
            }
            d.launch(
                name("reduce"),
                &k.reduce_bins,
                self.reduce_task.len(),
                wg,
                &[
                    Arg::Buf(&b.tasks),
                    Arg::Buf(&b.reduce_task),
                    Arg::Buf(&b.reduce_index),
                    Arg::Buf(&b.group_bins),
                    Arg::Buf(&b.partial_bins),
                ],
            )?;
            &b.partial_bins
        } else {
            &b.group_bins
        };
        d.launch(
            name("split"),
            &k.find_split,
            tasks,
            wg,
            &[
                Arg::Buf(&b.tasks),
                Arg::Buf(sets),
                Arg::Buf(&b.splits),
                Arg::Buf(&b.cursors),
            ],
        )?;
        // Read the splits as soon as find_split is done and let the device
        // partition while the host turns them into the next level's tasks.
        // The partition's cursors are only needed now for id splits, whose
        // counts are not known before; otherwise they are checked against
        // the bins' counts at the next sync point.
        self.splits.resize(tasks, SplitResult::default());
        // SAFETY: `self.splits` is not touched until `splits_read` completes.
        let splits_read = unsafe { d.read_async(&b.splits, &mut self.splits)? };
        self.enqueue_partition(stage, groups)?;
        let b = self.buffers.as_mut().expect("allocated by the caller");
        self.cursors.resize(tasks, 0);
        // SAFETY: `self.cursors` is only touched again in `check_cursors`,
        // which waits for this read first.
        let cursors_read = unsafe { d.read_async(&b.cursors, &mut self.cursors)? };
        d.flush()?;
        Ok((splits_read, cursors_read))
    }

    /// Builds every small node's subtree (one work-group each), packs their
    /// nodes and reads them into `self.small_nodes`, subtree after subtree;
    /// `self.small_results` gets each one's summary.
    fn run_small_stage(&mut self) -> Result<(), BuildError> {
        let d = self.device;
        let b = self.buffers.as_mut().expect("allocated by the caller");
        let k = &self.kernels;
        let roots = &self.level;
        // SAFETY: the roots are the builder's own, untouched until the
        // blocking read of the results below, queued after this copy (the
        // queue is in order), or build_timed's drain on an error.
        unsafe { d.write_async(&mut b.tasks, roots)? };
        d.launch(
            "bvh.small/build_small",
            &k.build_small,
            roots.len(),
            self.mapping.bin_lanes(self.params.bins) as usize,
            &[
                Arg::Buf(&b.tasks),
                Arg::Buf(&b.ids),
                Arg::Buf(&b.refs),
                Arg::Buf(&b.ids_scratch),
                Arg::Buf(&b.refs_scratch),
                Arg::Buf(&b.small_scratch),
                Arg::Buf(&b.small_results),
            ],
        )?;
        self.small_results
            .resize(roots.len(), SmallSubtree::default());
        d.read(&b.small_results, &mut self.small_results)?;
        // Subtree g's nodes go to small_offsets[g]..small_offsets[g + 1]. A
        // subtree the device gave up on is reported by attach_small; its
        // count is not trusted for the copy.
        self.small_offsets.clear();
        let mut total = 0u32;
        for (root, r) in roots.iter().zip(&self.small_results) {
            self.small_offsets.push(total);
            let cap = root.count - self.params.leaf_size;
            if r.status == super::layout::SMALL_OK && r.nodes <= cap {
                total += r.nodes;
            }
        }
        self.small_offsets.push(total);
        d.write(&mut b.small_offsets, &self.small_offsets)?;
        d.launch(
            "bvh.small/pack_small_nodes",
            &k.pack_small_nodes,
            roots.len(),
            self.mapping.build_wg(),
            &[
                Arg::Buf(&b.tasks),
                Arg::Buf(&b.small_offsets),
                Arg::Buf(&b.small_scratch),
                Arg::Buf(&b.small_packed),
            ],
        )?;
        self.small_nodes.resize(total as usize, BvhNode::default());
        if total > 0 {
            d.read(&b.small_packed, &mut self.small_nodes)?;
        }
        Ok(())
    }

    /// Queues the level's partition (into the other buffer pair).
    fn enqueue_partition(&mut self, stage: Stage, groups: usize) -> Result<(), BuildError> {
        let d = self.device;
        let b = self.buffers.as_mut().expect("allocated by the caller");
        let k = &self.kernels;
        let wg = self.mapping.build_wg();
        let name = match stage {
            Stage::Large => "bvh.large/partition",
            _ => "bvh.medium/partition",
        };
        d.launch(
            name,
            &k.partition,
            groups,
            wg,
            &[
                Arg::Buf(&b.tasks),
                Arg::Buf(&b.group_task),
                Arg::Buf(&b.group_index),
                Arg::Buf(&b.splits),
                Arg::Buf(&b.ids),
                Arg::Buf(&b.refs),
                Arg::Buf(&b.ids_scratch),
                Arg::Buf(&b.refs_scratch),
                Arg::Buf(&b.cursors),
                Arg::Buf(&b.group_bins),
            ],
        )?;
        Ok(())
    }

    /// Waits for the last level's partition cursors, fills in the counts of
    /// id splits, and checks that every other split moved exactly the
    /// triangles its bins counted.
    fn check_cursors(&mut self) -> Result<(), BuildError> {
        let Some(check) = self.pending_check.take() else {
            return Ok(());
        };
        check
            .cursors_read
            .wait()
            .map_err(|e| device_error("reading partition cursors", e))?;
        for ((split, &cursor), &node) in self.splits.iter_mut().zip(&self.cursors).zip(&check.nodes)
        {
            let moved = (cursor as u32, (cursor >> 32) as u32);
            if split.axis < 0 {
                (split.left_count, split.right_count) = moved;
            } else if (split.left_count, split.right_count) != moved {
                return Err(BuildError::CountMismatch {
                    node,
                    expected: (split.left_count, split.right_count),
                    got: moved,
                });
            }
        }
        Ok(())
    }
}

/// The launch name of a level's `kernel` ("bin", "reduce" or "split") in
/// `stage`: "bvh.<stage>/<kernel>", so the log can show both the stage
/// totals and each kernel's share.
fn level_kernel_name(stage: Stage) -> impl Fn(&str) -> &'static str {
    move |kernel| match (stage, kernel) {
        (Stage::Large, "bin") => "bvh.large/bin_triangles",
        (Stage::Large, "reduce") => "bvh.large/reduce_bins",
        (Stage::Large, _) => "bvh.large/find_split",
        (_, "bin") => "bvh.medium/bin_triangles",
        _ => "bvh.medium/find_split",
    }
}

/// A partition whose cursors are still being read back.
struct PendingCheck {
    cursors_read: Event,
    nodes: Vec<u32>,
}

fn device_error(what: &str, e: impl std::fmt::Display) -> BuildError {
    BuildError::Device(crate::device::DeviceError::Cl {
        what: what.to_owned(),
        code: e.to_string(),
    })
}
