//! The adaptive scheduler: a frame's samples as passes over tiles, queued
//! ahead so the device never waits for the host, with convergence checks at
//! fixed sample counts (`check_counts`), so the image depends only on the
//! samples' values; and reading the accumulators back for the film.

use opencl3::memory::Buffer;

use super::{or_dummy, PathTracer, SoupBuffers};
use crate::device::{Arg, Device};
use crate::film::{self, NoiseStats};
use crate::trace::settings::{check_counts, Adaptive, Allocation};
use crate::trace::TraceError;

/// Floats per pixel of the light-path passes' sums.
const LIGHT_FLOATS: usize = 3 * film::light::LIGHT_PASSES as usize;

/// Paths per launch the automatic pass size aims at: enough to fill a large
/// GPU, few enough that progress is reported often.
const PATHS_PER_LAUNCH: u64 = 1 << 21;

/// How a frame's passes ended.
pub(super) struct PassesDone {
    /// The pixels still sampling after the last check (`None`: no check ran).
    listed: Option<u32>,
    timed_out: bool,
    /// Time allocation: the mean rays per pixel at the first check, and its
    /// inverse (0 until then, and for equal-error allocation).
    work_reference: Option<f64>,
    inv_work_ref: f32,
}

impl PassesDone {
    /// The frame's noise statistics (the log's `noise`): each pixel against
    /// its own stop threshold, from the work it had done when it stopped (a
    /// stopped pixel's counts no longer change).
    pub(super) fn noise_stats(
        &self,
        adaptive: Option<Adaptive>,
        rays: &[u32],
        estimates: &[f32],
        counts: &[u32],
    ) -> NoiseStats {
        let stopped = if self.timed_out {
            "time_limit"
        } else if self.listed == Some(0) {
            "threshold"
        } else {
            "max_spp"
        };
        let thresholds: Option<Vec<f32>> = adaptive.map(|a| {
            rays.iter()
                .map(|&r| film::stop_threshold(a.threshold, r, self.inv_work_ref))
                .collect()
        });
        let mut noise = NoiseStats::with_thresholds(
            adaptive.map(|a| a.threshold),
            thresholds.as_deref(),
            estimates,
            counts,
            stopped,
        );
        noise.allocation = adaptive.map(|a| a.allocation.name().to_owned());
        noise.work_reference = self.work_reference;
        noise
    }
}

impl PathTracer<'_> {
    /// Sizes and clears the accumulators; the index of the first pending
    /// event of the frame's path tracing, for its device time.
    pub(super) fn clear_accumulators(&mut self, pixels: usize) -> Result<usize, TraceError> {
        let d = self.device;
        self.accum_color.ensure(d, pixels)?;
        self.accum_normal.ensure(d, pixels)?;
        self.accum_albedo.ensure(d, pixels)?;
        self.accum_aux.ensure(d, pixels)?;
        self.ray_counts.ensure(d, pixels)?;
        self.accum_snapshots.ensure(d, 2 * pixels)?;
        self.active.ensure(d, pixels)?;
        self.unconverged.ensure(d, pixels)?;
        self.pixel_list.ensure(d, pixels)?;
        let film = self.film;
        if let Some(slots) = film.matte_slots {
            self.matte_slots.ensure(d, slots as usize * pixels)?;
        }
        if film.vectors {
            self.accum_motion.ensure(d, pixels)?;
        }
        if film.catcher {
            self.accum_catcher.ensure(d, 3 * pixels)?;
        }
        if film.geometry {
            self.accum_geometry.ensure(d, 2 * pixels)?;
        }
        if film.light {
            self.accum_light.ensure(d, LIGHT_FLOATS * pixels)?;
        }
        let first_event = d.pending_events().len();
        let mut args = vec![
            Arg::Buf(self.accum_color.get()),
            Arg::Buf(self.accum_normal.get()),
            Arg::Buf(self.accum_albedo.get()),
            Arg::Buf(self.accum_aux.get()),
            Arg::Buf(self.ray_counts.get()),
            Arg::Buf(self.accum_snapshots.get()),
            Arg::Buf(self.active.get()),
            Arg::U32(pixels as u32),
        ];
        if film.matte_slots.is_some() {
            args.push(Arg::Buf(self.matte_slots.get()));
        }
        if film.vectors {
            args.push(Arg::Buf(self.accum_motion.get()));
        }
        if film.catcher {
            args.push(Arg::Buf(self.accum_catcher.get()));
        }
        if film.geometry {
            args.push(Arg::Buf(self.accum_geometry.get()));
        }
        if film.light {
            args.push(Arg::Buf(self.accum_light.get()));
        }
        d.launch(
            "pathtrace/clear",
            &self.kernels.clear,
            pixels.div_ceil(64),
            64,
            &args,
        )?;
        Ok(first_event)
    }

    /// Sample passes over tiles, ending at every convergence check. One
    /// pass is queued ahead of the one the host waits for, so the device
    /// never idles, and a time limit stops within a pass.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn run_passes(
        &mut self,
        soup: &SoupBuffers,
        prim_ids: &Buffer<u32>,
        snode_count: u32,
        empty: bool,
        motion_steps: Option<u32>,
        progress: &mut dyn FnMut(u32),
    ) -> Result<PassesDone, TraceError> {
        let d = self.device;
        let s = self.settings.clone();
        let (w, h) = (s.width, s.height);
        let pixels = w as usize * h as usize;
        let spp = s.spp;
        let checks = s
            .adaptive
            .map_or_else(Vec::new, |a| check_counts(a.min_spp, spp));
        let mut next_check = checks.iter().copied().peekable();
        let started = std::time::Instant::now();
        let mut queued: std::collections::VecDeque<(usize, u32)> = Default::default();
        let mut begin = 0;
        let mut done = PassesDone {
            // After a check, passes launch over the pixels still active
            // only: a launch over a mostly converged image costs as much as
            // sampling.
            listed: None,
            timed_out: false,
            work_reference: None,
            inv_work_ref: 0.0,
        };
        let mut flags = Vec::new();
        while begin < spp {
            if done.listed == Some(0) {
                break; // every pixel converged
            }
            // A pass holds the schedule's samples per pass (by default sized
            // to the pixels still sampling) and ends at every check.
            let items = done.listed.map_or(pixels, |n| n as usize);
            let mut end = begin
                .saturating_add(self.samples_per_pass(items, spp))
                .min(spp);
            let check = next_check.peek().is_some_and(|&c| c <= end);
            if check {
                end = next_check.next().expect("peeked");
            }
            // An empty soup's tree hits nothing: any buffer stands in.
            let positions = if empty {
                &self.dummy_f4
            } else {
                soup.positions
            };
            self.enqueue_pass(
                soup,
                prim_ids,
                positions,
                snode_count,
                empty,
                (begin, end),
                done.listed,
                motion_steps,
            )?;
            if check {
                let time = s.adaptive.map(|a| a.allocation) == Some(Allocation::Time);
                if time && done.work_reference.is_none() {
                    // Once per frame, at the first check: the host sums the
                    // integer counts, so the reference is exact and the
                    // same whatever the schedule.
                    let mut rays = vec![0u32; pixels];
                    d.read(self.ray_counts.get(), &mut rays)?;
                    let total: u64 = rays.iter().map(|&r| r as u64).sum();
                    let mean = total as f64 / pixels.max(1) as f64;
                    done.work_reference = Some(mean);
                    done.inv_work_ref = if total > 0 { (1.0 / mean) as f32 } else { 0.0 };
                }
                self.enqueue_check(pixels, w, h, done.inv_work_ref)?;
                flags.resize(pixels, 0u32);
                d.read(self.active.get(), &mut flags)?;
                let list: Vec<u32> = (0..pixels as u32)
                    .filter(|&i| flags[i as usize] != 0)
                    .collect();
                if !list.is_empty() {
                    d.write(self.pixel_list.ensure(d, pixels)?, &list)?;
                }
                done.listed = Some(list.len() as u32);
            }
            d.flush()?;
            queued.push_back((d.pending_events().len(), end));
            begin = end;
            while queued.len() > 1 {
                let (count, done) = queued.pop_front().expect("queued");
                wait_pass(d, count)?;
                progress(done);
            }
            if s.time_limit.is_some_and(|limit| started.elapsed() >= limit) {
                done.timed_out = true;
                break;
            }
        }
        for (count, done) in queued {
            wait_pass(d, count)?;
            progress(done);
        }
        Ok(done)
    }

    /// Device time, in milliseconds, of the launches from pending event
    /// `first_event` on (profiling events).
    pub(super) fn device_ms_since(&self, first_event: usize) -> f64 {
        use opencl3::event::{
            get_event_profiling_info, CL_PROFILING_COMMAND_END, CL_PROFILING_COMMAND_START,
        };
        let mut ms = 0.0;
        for e in self.device.pending_events().iter().skip(first_event) {
            let t0: u64 = get_event_profiling_info(*e, CL_PROFILING_COMMAND_START)
                .map(Into::into)
                .unwrap_or(0);
            let t1: u64 = get_event_profiling_info(*e, CL_PROFILING_COMMAND_END)
                .map(Into::into)
                .unwrap_or(0);
            ms += t1.saturating_sub(t0) as f64 * 1e-6;
        }
        ms
    }

    /// The accumulators, read back into `self.readback` for the film's
    /// resolve (the optional sums only when their passes are written). The
    /// host buffers are the last frame's: tens of megabytes with every
    /// pass, which fresh would cost a page fault per 4 KiB.
    pub(super) fn read_accumulators(&mut self, pixels: usize) -> Result<(), TraceError> {
        let d = self.device;
        let acc = &mut self.readback;
        fit(&mut acc.color, pixels);
        fit(&mut acc.aux, pixels);
        fit(&mut acc.snapshots, 2 * pixels);
        fit(&mut acc.rays, pixels);
        d.read(self.accum_color.get(), &mut acc.color)?;
        d.read(self.accum_aux.get(), &mut acc.aux)?;
        d.read(self.accum_snapshots.get(), &mut acc.snapshots)?;
        d.read(self.ray_counts.get(), &mut acc.rays)?;
        fit(
            &mut acc.normal,
            if self.settings.aovs.normal { pixels } else { 0 },
        );
        fit(
            &mut acc.albedo,
            if self.settings.aovs.albedo { pixels } else { 0 },
        );
        fit(
            &mut acc.catcher,
            if self.film.catcher { 3 * pixels } else { 0 },
        );
        fit(
            &mut acc.geometry,
            if self.film.geometry { 2 * pixels } else { 0 },
        );
        fit(&mut acc.motion, if self.film.vectors { pixels } else { 0 });
        let slots = self.film.matte_slots.map_or(0, |s| s as usize);
        fit(&mut acc.matte_slots, slots * pixels);
        fit(
            &mut acc.light,
            if self.film.light {
                LIGHT_FLOATS * pixels
            } else {
                0
            },
        );
        if !acc.normal.is_empty() {
            d.read(self.accum_normal.get(), &mut acc.normal)?;
        }
        if !acc.albedo.is_empty() {
            d.read(self.accum_albedo.get(), &mut acc.albedo)?;
        }
        if !acc.catcher.is_empty() {
            d.read(self.accum_catcher.get(), &mut acc.catcher)?;
        }
        if !acc.geometry.is_empty() {
            d.read(self.accum_geometry.get(), &mut acc.geometry)?;
        }
        if !acc.motion.is_empty() {
            d.read(self.accum_motion.get(), &mut acc.motion)?;
        }
        if !acc.matte_slots.is_empty() {
            d.read(self.matte_slots.get(), &mut acc.matte_slots)?;
        }
        if !acc.light.is_empty() {
            d.read(self.accum_light.get(), &mut acc.light)?;
        }
        Ok(())
    }

    /// Samples per pixel in one pass over `items` pixels.
    fn samples_per_pass(&self, items: usize, spp: u32) -> u32 {
        if self.schedule.samples_per_pass > 0 {
            self.schedule.samples_per_pass
        } else {
            (PATHS_PER_LAUNCH / items.max(1) as u64).clamp(1, spp as u64) as u32
        }
    }

    /// Queues samples [begin, end) of every pixel, tile by tile, or of the
    /// first `listed` pixels of the pixel list in one launch.
    #[allow(clippy::too_many_arguments)]
    fn enqueue_pass(
        &self,
        soup: &SoupBuffers,
        prim_ids: &Buffer<u32>,
        positions: &Buffer<[f32; 4]>,
        snode_count: u32,
        empty: bool,
        (begin, end): (u32, u32),
        listed: Option<u32>,
        motion_steps: Option<u32>,
    ) -> Result<(), TraceError> {
        let (kernel, camera) = match (motion_steps, &self.motion_kernels) {
            (Some(_), Some(k)) => (&k.render, self.motion_cameras.get()),
            _ => (&self.kernels.render, &self.camera),
        };
        let d = self.device;
        // A listed launch is one "tile" of `listed` items in a row.
        let (w, h) = match listed {
            Some(n) => (n, 1),
            None => (self.settings.width, self.settings.height),
        };
        let (tw, th) = match listed {
            Some(n) => (n, 1),
            None => self.schedule.tile.unwrap_or((w, h)),
        };
        let (tw, th) = (tw.clamp(1, w), th.clamp(1, h));
        let local = self.schedule.local_size.max(1);
        let adaptive = self.settings.adaptive.is_some();
        let leaves = self.layouts.leaf_args(self.settings.traversal);
        for ty in (0..h).step_by(th as usize) {
            for tx in (0..w).step_by(tw as usize) {
                let cw = tw.min(w - tx);
                let ch = th.min(h - ty);
                let items = cw as usize * ch as usize;
                let mut args = vec![
                    Arg::Buf(self.layouts.buffers().0),
                    Arg::Buf(self.layouts.wide_arg(self.settings.traversal)),
                    Arg::Buf(self.layouts.buffers().1),
                    Arg::U32(snode_count),
                    // The wide layouts read their triangles in leaf order.
                    Arg::Buf(leaves.as_ref().map_or(prim_ids, |l| l.slots)),
                    match &leaves {
                        Some(l) => Arg::Buf(l.tris),
                        None => Arg::Buf(&self.dummy_f32),
                    },
                    Arg::Buf(positions),
                    // An attribute the soup lacks binds a dummy (its frame
                    // flag keeps the kernel from reading it).
                    or_dummy(soup.normals, &self.dummy_f32),
                    or_dummy(soup.uvs, &self.dummy_f32),
                    or_dummy(soup.uvs1, &self.dummy_f32),
                    or_dummy(soup.colors, &self.dummy_f32),
                    Arg::Buf(if empty {
                        &self.dummy_u32
                    } else {
                        soup.material_ids
                    }),
                    Arg::Buf(&self.materials),
                    Arg::Buf(self.lights.get()),
                    Arg::Buf(self.emit_prims.get()),
                    Arg::Buf(self.emit_cdf.get()),
                    Arg::Buf(self.emit_pmf.get()),
                    Arg::Buf(self.select_cdf.get()),
                    Arg::Buf(self.light_nodes.get()),
                    Arg::Buf(self.emit_trails.get()),
                    Arg::Buf(&self.env),
                ];
                match &self.env_map {
                    Some((_, t, m, c, _)) => {
                        args.push(Arg::Buf(t));
                        args.push(Arg::Buf(m));
                        args.push(Arg::Buf(c));
                    }
                    None => {
                        args.push(Arg::Buf(&self.dummy_f4));
                        args.push(Arg::Buf(&self.dummy_f32));
                        args.push(Arg::Buf(&self.dummy_f32));
                    }
                }
                args.extend([
                    Arg::Buf(&self.filter),
                    Arg::Buf(camera),
                    Arg::Buf(&self.frame),
                    Arg::Buf(self.accum_color.get()),
                    Arg::Buf(self.accum_normal.get()),
                    Arg::Buf(self.accum_albedo.get()),
                    Arg::Buf(self.accum_aux.get()),
                    Arg::Buf(self.ray_counts.get()),
                    Arg::Buf(self.accum_snapshots.get()),
                    Arg::Buf(self.active.get()),
                    Arg::U32(adaptive as u32),
                    Arg::Buf(self.pixel_list.get()),
                    Arg::U32(listed.unwrap_or(0)),
                    Arg::U32(tx),
                    Arg::U32(ty),
                    Arg::U32(cw),
                    Arg::U32(ch),
                    Arg::U32(begin),
                    Arg::U32(end),
                ]);
                if let Some((set, bindings)) = &self.textures {
                    args.push(Arg::Buf(set.info_buffer().expect("non-empty set")));
                    args.push(Arg::Buf(set.texel_buffer().expect("non-empty set")));
                    args.push(Arg::Buf(bindings));
                }
                if let Some(exts) = &self.material_exts {
                    args.push(Arg::Buf(exts));
                }
                if let Some(steps) = motion_steps {
                    args.push(Arg::U32(steps));
                    args.push(Arg::U32(soup.triangles as u32));
                }
                if self.film.matte_slots.is_some() {
                    let pairs = self.mattes.as_ref().map(|(_, b)| b);
                    args.push(Arg::Buf(pairs.unwrap_or(&self.dummy_u32)));
                    args.push(Arg::Buf(self.matte_slots.get()));
                }
                if self.film.vectors {
                    args.push(Arg::Buf(self.vector_positions.get()));
                    args.push(Arg::Buf(&self.vector_cameras));
                    args.push(Arg::U32(soup.triangles as u32));
                    args.push(Arg::Buf(self.accum_motion.get()));
                }
                if self.film.catcher {
                    let flags = self.triangle_flags.as_ref().map(|(b, _)| b);
                    args.push(Arg::Buf(flags.unwrap_or(&self.dummy_u32)));
                    args.push(Arg::Buf(self.accum_catcher.get()));
                }
                if self.film.geometry {
                    args.push(Arg::Buf(self.accum_geometry.get()));
                }
                if self.film.light {
                    args.push(Arg::Buf(self.accum_light.get()));
                }
                d.launch(
                    "pathtrace/render",
                    kernel,
                    items.div_ceil(local),
                    local,
                    &args,
                )?;
            }
        }
        Ok(())
    }

    /// Queues a convergence check: each pixel's estimate against the
    /// threshold, then the dilation that decides which pixels go on.
    fn enqueue_check(
        &self,
        pixels: usize,
        w: u32,
        h: u32,
        inv_work_ref: f32,
    ) -> Result<(), TraceError> {
        let d = self.device;
        let threshold = self.settings.adaptive.map_or(0.0, |a| a.threshold);
        d.launch(
            "pathtrace/converge",
            &self.kernels.converge,
            pixels.div_ceil(64),
            64,
            &[
                Arg::Buf(self.accum_color.get()),
                Arg::Buf(self.accum_snapshots.get()),
                Arg::Buf(self.accum_aux.get()),
                Arg::Buf(self.ray_counts.get()),
                Arg::Buf(self.unconverged.get()),
                Arg::F32(threshold),
                Arg::F32(inv_work_ref),
                Arg::U32(w),
                Arg::U32(h),
            ],
        )?;
        d.launch(
            "pathtrace/dilate",
            &self.kernels.dilate,
            pixels.div_ceil(64),
            64,
            &[
                Arg::Buf(self.unconverged.get()),
                Arg::Buf(self.active.get()),
                Arg::U32(w),
                Arg::U32(h),
            ],
        )?;
        Ok(())
    }
}

/// Waits for the event that ends a pass (the `count`-th pending event).
fn wait_pass(d: &Device, count: usize) -> Result<(), TraceError> {
    let events = d.pending_events();
    if let Some(e) = events.get(count.wrapping_sub(1)) {
        opencl3::event::wait_for_events(&[*e]).map_err(|c| {
            TraceError::Device(crate::device::DeviceError::Cl {
                what: "clWaitForEvents (path tracing pass)".into(),
                code: c.to_string(),
            })
        })?;
    }
    Ok(())
}

/// `v` resized to `n` (the device read overwrites its values).
fn fit<T: Clone + Default>(v: &mut Vec<T>, n: usize) {
    v.resize(n, T::default());
}
