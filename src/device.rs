//! The OpenCL plumbing: platform and device discovery, device choice,
//! program building from the embedded `kernels/*.cl` sources, buffers, and
//! one launch helper through which every kernel runs so that each launch is
//! named and timed by OpenCL profiling events (never host clocks).
//!
//! Nothing here knows about BVHs or scenes; the pipeline stages own their
//! kernels and call `Device::launch` with the stage's name.

use opencl3::command_queue::{CommandQueue, CL_QUEUE_PROFILING_ENABLE};
use opencl3::context::Context;
use opencl3::device::{
    Device as ClDevice, CL_DEVICE_TYPE_ACCELERATOR, CL_DEVICE_TYPE_ALL, CL_DEVICE_TYPE_CPU,
    CL_DEVICE_TYPE_GPU, CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT,
};
use opencl3::event::Event;
use opencl3::kernel::{ExecuteKernel, Kernel};
use opencl3::memory::{Buffer, CL_MEM_READ_WRITE};
use opencl3::platform::get_platforms;
use opencl3::program::Program;
use opencl3::types::{cl_bool, cl_event, CL_BLOCKING, CL_NON_BLOCKING};
use std::cell::RefCell;
use std::collections::BTreeMap;
use std::ptr;

/// Why the device layer failed. Messages say what to do about it.
#[derive(Debug, thiserror::Error)]
pub enum DeviceError {
    #[error(
        "no OpenCL platform found ({0}).\n  soupray needs an OpenCL driver. On Debian or Ubuntu:\n    \
         sudo apt-get install pocl-opencl-icd ocl-icd-opencl-dev\n  \
         (PoCL runs the kernels on the CPU; a GPU vendor's OpenCL driver works too)"
    )]
    NoPlatform(String),
    #[error("no OpenCL device found on any platform; install a driver such as pocl-opencl-icd")]
    NoDevice,
    #[error("--device {0:?} matches no device; `soupray devices` lists them (use an index or a name substring)")]
    NoMatch(String),
    #[error("OpenCL program {program} failed to build on {device}:\n{log}")]
    Build {
        program: String,
        device: String,
        log: String,
    },
    #[error("OpenCL {what} failed: {code}")]
    Cl { what: String, code: String },
}

pub type Result<T> = std::result::Result<T, DeviceError>;

fn cl<T, E: std::fmt::Display>(what: &str, r: std::result::Result<T, E>) -> Result<T> {
    r.map_err(|e| DeviceError::Cl {
        what: what.to_owned(),
        code: e.to_string(),
    })
}

/// One OpenCL device as `soupray devices` lists it.
#[derive(Clone, Debug, serde::Serialize)]
pub struct DeviceInfo {
    pub index: usize,
    pub platform: String,
    pub name: String,
    pub kind: &'static str,
    pub compute_units: u32,
    pub global_mem_mib: u64,
    pub local_mem_kib: u64,
    pub max_work_group_size: usize,
    pub version: String,
    /// The driver's version string (`CL_DRIVER_VERSION`).
    pub driver: String,
    /// Whether single-precision division and sqrt can be correctly rounded
    /// (`CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT` in `CL_DEVICE_SINGLE_FP_CONFIG`).
    /// Programs are then built with `-cl-fp32-correctly-rounded-divide-sqrt`.
    pub correctly_rounded_divide_sqrt: bool,
}

fn kind_name(t: u64) -> &'static str {
    if t & CL_DEVICE_TYPE_GPU != 0 {
        "GPU"
    } else if t & CL_DEVICE_TYPE_CPU != 0 {
        "CPU"
    } else if t & CL_DEVICE_TYPE_ACCELERATOR != 0 {
        "accelerator"
    } else {
        "other"
    }
}

/// Every device of every platform, in a stable order (platform, then device).
fn enumerate() -> Result<Vec<(DeviceInfo, ClDevice)>> {
    let platforms = get_platforms().map_err(|e| DeviceError::NoPlatform(e.to_string()))?;
    if platforms.is_empty() {
        return Err(DeviceError::NoPlatform("the ICD loader lists none".into()));
    }
    let mut out = Vec::new();
    for platform in platforms {
        let pname = platform.name().unwrap_or_default();
        let Ok(ids) = platform.get_devices(CL_DEVICE_TYPE_ALL) else {
            continue;
        };
        for id in ids {
            let d = ClDevice::new(id);
            let info = DeviceInfo {
                index: out.len(),
                platform: pname.trim().to_owned(),
                name: d.name().unwrap_or_default().trim().to_owned(),
                kind: kind_name(d.dev_type().unwrap_or(0)),
                compute_units: d.max_compute_units().unwrap_or(0),
                global_mem_mib: d.global_mem_size().unwrap_or(0) >> 20,
                local_mem_kib: d.local_mem_size().unwrap_or(0) >> 10,
                max_work_group_size: d.max_work_group_size().unwrap_or(0),
                version: d.version().unwrap_or_default().trim().to_owned(),
                driver: d.driver_version().unwrap_or_default().trim().to_owned(),
                correctly_rounded_divide_sqrt: d
                    .single_fp_config()
                    .is_ok_and(|c| c & CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT != 0),
            };
            out.push((info, d));
        }
    }
    if out.is_empty() {
        return Err(DeviceError::NoDevice);
    }
    Ok(out)
}

/// All OpenCL devices, for `soupray devices`.
pub fn list_devices() -> Result<Vec<DeviceInfo>> {
    Ok(enumerate()?.into_iter().map(|(i, _)| i).collect())
}

/// Chooses a device: `selector` is an index into `list_devices()` or a
/// case-insensitive substring of "platform name"; without one, the first GPU,
/// else the first device. `SOUPRAY_DEVICE` stands in for a missing selector so
/// test suites and farm jobs can pin a device without new flags.
fn choose(selector: Option<&str>) -> Result<(DeviceInfo, ClDevice)> {
    let mut all = enumerate()?;
    let env = std::env::var("SOUPRAY_DEVICE").ok();
    let selector = selector.or(env.as_deref()).filter(|s| !s.is_empty());
    let at = match selector {
        Some(s) => if let Ok(i) = s.parse::<usize>() {
            (i < all.len()).then_some(i)
        } else {
            let needle = s.to_lowercase();
            all.iter().position(|(i, _)| {
                format!("{} {}", i.platform, i.name)
                    .to_lowercase()
                    .contains(&needle)
            })
        }
        .ok_or_else(|| DeviceError::NoMatch(s.to_owned()))?,
        None => all.iter().position(|(i, _)| i.kind == "GPU").unwrap_or(0),
    };
    Ok(all.swap_remove(at))
}

/// Device time of named launches, from profiling events, in milliseconds.
#[derive(Clone, Debug, Default)]
pub struct Timings {
    pub by_stage: BTreeMap<String, f64>,
    pub launches: usize,
}

impl Timings {
    /// Time under `stage`: launches named `stage` or `stage/<kernel>`.
    pub fn ms(&self, stage: &str) -> f64 {
        self.by_stage
            .iter()
            .filter(|(name, _)| {
                name.as_str() == stage
                    || name
                        .strip_prefix(stage)
                        .is_some_and(|rest| rest.starts_with('/'))
            })
            .map(|(_, ms)| ms)
            .sum::<f64>()
            // An empty float sum is -0.0, which would print as "-0.00".
            + 0.0
    }
}

/// A chosen device with its context and one in-order, profiling queue.
pub struct Device {
    pub info: DeviceInfo,
    device: ClDevice,
    pub context: Context,
    pub queue: CommandQueue,
    /// Launches not yet folded into `timings`: (stage, event).
    pending: RefCell<Vec<(&'static str, Event)>>,
    timings: RefCell<Timings>,
}

/// A kernel argument, so launches can be written as one call with a list.
pub enum Arg<'a> {
    Buf(&'a dyn BufferArg),
    U32(u32),
    I32(i32),
    F32(f32),
    Local(usize),
}

/// Any device buffer, whatever its element type.
pub trait BufferArg {
    fn set(&self, exec: &mut ExecuteKernel);
}

impl<T> BufferArg for Buffer<T> {
    fn set(&self, exec: &mut ExecuteKernel) {
        // SAFETY: a cl_mem handle is a valid kernel argument for a
        // `global T*` parameter; the kernel signatures are checked by the
        // tests that run every kernel.
        unsafe {
            exec.set_arg(self);
        }
    }
}

impl Device {
    /// Opens the device `selector` names (see `choose`).
    pub fn open(selector: Option<&str>) -> Result<Device> {
        let (info, device) = choose(selector)?;
        let context = cl("clCreateContext", Context::from_device(&device))?;
        // The deprecated entry point is the one every OpenCL 1.2 driver has.
        #[allow(deprecated)]
        let queue = cl(
            "clCreateCommandQueue",
            CommandQueue::create_default(&context, CL_QUEUE_PROFILING_ENABLE),
        )?;
        Ok(Device {
            info,
            device,
            context,
            queue,
            pending: RefCell::new(Vec::new()),
            timings: RefCell::new(Timings::default()),
        })
    }

    /// Whether the device supports 64-bit global atomics, which the builder
    /// uses to reserve both sides of a partition with one atomic.
    pub fn has_int64_atomics(&self) -> bool {
        self.device
            .extensions()
            .map(|e| e.contains("cl_khr_int64_base_atomics"))
            .unwrap_or(false)
    }

    /// Builds a program from an embedded entry file with its headers inlined,
    /// under `defines` (each `NAME=VALUE` becomes `-D NAME=VALUE`). A failed
    /// build returns the device compiler's log, whose line markers name the
    /// original files.
    pub fn build_program(&self, entry: &str, defines: &[(&str, String)]) -> Result<Program> {
        self.build_assembled(entry, &assemble_source(entry), defines)
    }

    /// As [`Device::build_program`], for a program made at run time
    /// (`text`, named `name` in messages) that includes embedded headers.
    pub fn build_program_text(
        &self,
        name: &str,
        text: &str,
        defines: &[(&str, String)],
    ) -> Result<Program> {
        self.build_assembled(name, &assemble_text(name, text), defines)
    }

    fn build_assembled(
        &self,
        entry: &str,
        source: &str,
        defines: &[(&str, String)],
    ) -> Result<Program> {
        let options = build_options(defines, self.info.correctly_rounded_divide_sqrt);
        let program = Program::create_and_build_from_source(&self.context, source, &options)
            .map_err(|log| DeviceError::Build {
                program: entry.to_owned(),
                device: self.info.name.clone(),
                log,
            })?;
        if let Some(dir) = std::env::var_os("SOUPRAY_BUILD_LOG_DIR").filter(|d| !d.is_empty()) {
            self.save_build_log(std::path::Path::new(&dir), entry, &options, &program);
        }
        Ok(program)
    }

    /// The options `program` was built with, as the driver reports them
    /// (`CL_PROGRAM_BUILD_OPTIONS`).
    pub fn program_build_options(&self, program: &Program) -> Result<String> {
        cl(
            "clGetProgramBuildInfo(CL_PROGRAM_BUILD_OPTIONS)",
            program.get_build_options(self.device.id()),
        )
    }

    /// `SOUPRAY_BUILD_LOG_DIR`: appends the program's options and the
    /// driver's build log (warnings, register use where the driver reports
    /// it) to `DIR/<entry>.log`, for device checks (`scripts/gpu-check.sh`).
    /// Best effort: a log that cannot be written never fails the build.
    fn save_build_log(&self, dir: &std::path::Path, entry: &str, options: &str, program: &Program) {
        use std::io::Write;
        let log = program.get_build_log(self.device.id()).unwrap_or_default();
        let _ = std::fs::create_dir_all(dir);
        if let Ok(mut f) = std::fs::OpenOptions::new()
            .create(true)
            .append(true)
            .open(dir.join(format!("{entry}.log")))
        {
            let _ = writeln!(
                f,
                "=== {entry} on {} ({}; driver {})\noptions: {options}\n{}\n",
                self.info.name,
                self.info.platform,
                self.info.driver,
                log.trim_end()
            );
        }
    }

    pub fn kernel(&self, program: &Program, name: &str) -> Result<Kernel> {
        cl(
            &format!("creating kernel {name}"),
            Kernel::create(program, name),
        )
    }

    /// The local memory `kernel` needs on this device, in bytes
    /// (`CL_KERNEL_LOCAL_MEM_SIZE`: its `__local` arrays).
    pub fn kernel_local_mem(&self, kernel: &Kernel) -> Result<u64> {
        cl(
            "clGetKernelWorkGroupInfo(CL_KERNEL_LOCAL_MEM_SIZE)",
            kernel.get_local_mem_size(self.device.id()),
        )
    }

    /// The device's local memory per work-group, in bytes.
    pub fn local_mem_bytes(&self) -> u64 {
        self.device.local_mem_size().unwrap_or(0)
    }

    /// A device buffer of `len` elements (at least one, as OpenCL forbids
    /// empty buffers).
    pub fn buffer<T>(&self, len: usize) -> Result<Buffer<T>> {
        // SAFETY: no host pointer is passed, so the driver allocates.
        unsafe {
            cl(
                "clCreateBuffer",
                Buffer::<T>::create(
                    &self.context,
                    CL_MEM_READ_WRITE,
                    len.max(1),
                    ptr::null_mut(),
                ),
            )
        }
    }

    /// Copies `data` into the start of `buffer`, blocking.
    pub fn write<T>(&self, buffer: &mut Buffer<T>, data: &[T]) -> Result<()> {
        // SAFETY: the copy is done when this returns, while `data` lives.
        unsafe { self.enqueue_write(buffer, data, CL_BLOCKING) }
    }

    /// Queues a copy of `data` into the start of `buffer` without waiting
    /// (ordered with the launches: the queue is in order).
    ///
    /// # Safety
    /// `data` must stay alive and unchanged until the copy completes: until
    /// a blocking call or a wait on a command queued after it, or `finish`.
    pub unsafe fn write_async<T>(&self, buffer: &mut Buffer<T>, data: &[T]) -> Result<()> {
        // SAFETY: the caller keeps `data` alive and unchanged until the copy
        // completes.
        unsafe { self.enqueue_write(buffer, data, CL_NON_BLOCKING) }
    }

    /// `write` and `write_async`: nothing is queued for no data.
    ///
    /// # Safety
    /// As `write_async` when `blocking` is `CL_NON_BLOCKING`.
    unsafe fn enqueue_write<T>(
        &self,
        buffer: &mut Buffer<T>,
        data: &[T],
        blocking: cl_bool,
    ) -> Result<()> {
        if data.is_empty() {
            return Ok(());
        }
        // SAFETY: a slice no longer than the buffer (callers size buffers
        // from the same counts), alive as the caller promises.
        unsafe {
            cl(
                "clEnqueueWriteBuffer",
                self.queue
                    .enqueue_write_buffer(buffer, blocking, 0, data, &[]),
            )?;
        }
        Ok(())
    }

    /// Queues a copy of `len` elements from the start of `src` to `dst` at
    /// element `dst_at`, on the device (ordered with the launches).
    pub fn copy<T>(
        &self,
        src: &Buffer<T>,
        dst: &mut Buffer<T>,
        dst_at: usize,
        len: usize,
    ) -> Result<()> {
        if len == 0 {
            return Ok(());
        }
        let size = std::mem::size_of::<T>();
        // SAFETY: both ranges lie inside their buffers (callers size `dst`
        // for every step's copy); the in-order queue orders it.
        unsafe {
            cl(
                "clEnqueueCopyBuffer",
                self.queue
                    .enqueue_copy_buffer(src, dst, 0, dst_at * size, len * size, &[]),
            )?;
        }
        Ok(())
    }

    /// Reads the first `out.len()` elements of `buffer`, blocking.
    pub fn read<T>(&self, buffer: &Buffer<T>, out: &mut [T]) -> Result<()> {
        if out.is_empty() {
            return Ok(());
        }
        // SAFETY: blocking read into a live slice no longer than the buffer.
        unsafe {
            cl(
                "clEnqueueReadBuffer",
                self.queue
                    .enqueue_read_buffer(buffer, CL_BLOCKING, 0, out, &[]),
            )?;
        }
        Ok(())
    }

    /// Queues a read of the first `out.len()` elements of `buffer` without
    /// waiting, and returns its event.
    ///
    /// # Safety
    /// `out` must stay alive and untouched until the event completes (wait
    /// on it, or `finish` the queue).
    pub unsafe fn read_async<T>(&self, buffer: &Buffer<T>, out: &mut [T]) -> Result<Event> {
        // SAFETY: the caller keeps `out` alive until the read completes.
        unsafe {
            cl(
                "clEnqueueReadBuffer",
                self.queue
                    .enqueue_read_buffer(buffer, CL_NON_BLOCKING, 0, out, &[]),
            )
        }
    }

    /// Launches `kernel` over `groups` work-groups of `local` items, timed
    /// under `stage`. Nothing is launched for zero groups.
    pub fn launch(
        &self,
        stage: &'static str,
        kernel: &Kernel,
        groups: usize,
        local: usize,
        args: &[Arg],
    ) -> Result<()> {
        if groups == 0 {
            return Ok(());
        }
        let mut exec = ExecuteKernel::new(kernel);
        for arg in args {
            // SAFETY: scalar arguments are plain values matching the kernel's
            // declared types; local sizes allocate local memory.
            unsafe {
                match arg {
                    Arg::Buf(b) => b.set(&mut exec),
                    Arg::U32(v) => {
                        exec.set_arg(v);
                    }
                    Arg::I32(v) => {
                        exec.set_arg(v);
                    }
                    Arg::F32(v) => {
                        exec.set_arg(v);
                    }
                    Arg::Local(bytes) => {
                        exec.set_arg_local_buffer(*bytes);
                    }
                }
            }
        }
        exec.set_global_work_size(groups * local)
            .set_local_work_size(local);
        // SAFETY: arguments are set above; buffers outlive the queue's use of
        // them because callers synchronise before dropping them.
        let event = unsafe { cl(stage, exec.enqueue_nd_range(&self.queue))? };
        self.pending.borrow_mut().push((stage, event));
        Ok(())
    }

    /// Submits queued commands without waiting for them.
    pub fn flush(&self) -> Result<()> {
        cl("clFlush", self.queue.flush())
    }

    /// Waits for the queue and folds finished launches into the timings.
    pub fn finish(&self) -> Result<()> {
        cl("clFinish", self.queue.finish())?;
        let mut timings = self.timings.borrow_mut();
        for (stage, event) in self.pending.borrow_mut().drain(..) {
            let start = cl("profiling", event.profiling_command_start())?;
            let end = cl("profiling", event.profiling_command_end())?;
            *timings.by_stage.entry(stage.to_owned()).or_default() +=
                end.saturating_sub(start) as f64 * 1e-6;
            timings.launches += 1;
        }
        Ok(())
    }

    /// Returns and clears the accumulated timings (after a `finish`).
    pub fn take_timings(&self) -> Result<Timings> {
        self.finish()?;
        Ok(std::mem::take(&mut *self.timings.borrow_mut()))
    }

    /// Runs a layout probe: a one-work-item kernel `kernel` of the program
    /// `text` that writes `count` sizes and offsets of the structs it
    /// names. Tests compare the result with the Rust definitions.
    pub fn run_layout_probe(&self, text: &str, kernel: &str, count: usize) -> Result<Vec<u32>> {
        let program = self.build_program_text("layout_probe.cl", text, &[])?;
        let kernel = self.kernel(&program, kernel)?;
        let mut out = self.buffer::<u32>(count.max(1))?;
        self.write(&mut out, &vec![u32::MAX; count.max(1)])?;
        self.launch("layout_probe", &kernel, 1, 1, &[Arg::Buf(&out)])?;
        let mut got = vec![0u32; count.max(1)];
        self.read(&out, &mut got)?;
        got.truncate(count);
        Ok(got)
    }

    /// Events are only needed for profiling; a raw list is exposed for the
    /// rare caller that must wait on one launch.
    pub fn pending_events(&self) -> Vec<cl_event> {
        self.pending.borrow().iter().map(|(_, e)| e.get()).collect()
    }
}

/// A device buffer that grows to the largest size asked for and is then
/// reused frame after frame (with some headroom, so a slowly growing
/// animation does not reallocate every frame). `allocations` counts the
/// (re)allocations, so tests can prove the reuse.
pub struct GrowBuffer<T> {
    buffer: Option<Buffer<T>>,
    capacity: usize,
    allocations: usize,
}

impl<T> Default for GrowBuffer<T> {
    fn default() -> Self {
        GrowBuffer {
            buffer: None,
            capacity: 0,
            allocations: 0,
        }
    }
}

impl<T> GrowBuffer<T> {
    pub fn new() -> GrowBuffer<T> {
        GrowBuffer::default()
    }

    /// The buffer, with room for at least `n` elements.
    pub fn ensure(&mut self, device: &Device, n: usize) -> Result<&mut Buffer<T>> {
        if self.buffer.is_none() || self.capacity < n {
            let cap = n.max(1) + n / 8;
            self.buffer = Some(device.buffer(cap)?);
            self.capacity = cap;
            self.allocations += 1;
        }
        Ok(self.buffer.as_mut().expect("allocated above"))
    }

    /// The buffer, if it has been allocated.
    pub fn buffer(&self) -> Option<&Buffer<T>> {
        self.buffer.as_ref()
    }

    /// The buffer, after an `ensure`.
    pub fn get(&self) -> &Buffer<T> {
        self.buffer
            .as_ref()
            .expect("GrowBuffer::ensure runs before use")
    }

    pub fn allocations(&self) -> usize {
        self.allocations
    }
}

/// The build options, assembled in one place. Fast-relaxed math is never
/// used: frames must be reproducible and the builder must agree bit for bit
/// with its Rust reference. Contraction into FMA is switched off in the
/// sources themselves (`#pragma OPENCL FP_CONTRACT OFF` in every file).
/// Where the device can (`correctly_rounded`, from
/// `CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT`), division and sqrt are correctly
/// rounded as in Rust: OpenCL 1.2 otherwise allows 2.5 ulp for `x / y`
/// (NVIDIA's driver uses that licence), and the device tree would stop
/// matching the reference. `tests/kernels_portable.rs` holds these rules.
pub fn build_options(defines: &[(&str, String)], correctly_rounded: bool) -> String {
    let mut options = String::from("-cl-std=CL1.2");
    if correctly_rounded {
        options.push_str(" -cl-fp32-correctly-rounded-divide-sqrt");
    }
    for (name, value) in defines {
        options.push_str(&format!(" -D {name}={value}"));
    }
    options
}

/// The entry file's text with each `#include "x.h"` replaced by that
/// embedded header, wrapped in `#line` markers so that compiler messages
/// name the original file and line. Each header is inlined once.
pub fn assemble_source(entry: &str) -> String {
    match crate::kernels::KERNEL_SOURCES
        .iter()
        .find(|(n, _)| *n == entry)
    {
        Some((_, text)) => assemble_text(entry, text),
        None => format!("#error \"missing embedded kernel source {entry}\"\n"),
    }
}

/// As [`assemble_source`], for a program's text `text` named `name`.
pub fn assemble_text(name: &str, text: &str) -> String {
    fn header(name: &str, out: &mut String, seen: &mut Vec<String>) {
        if seen.iter().any(|s| s == name) {
            return;
        }
        seen.push(name.to_owned());
        match crate::kernels::KERNEL_SOURCES
            .iter()
            .find(|(n, _)| *n == name)
        {
            Some((_, text)) => inline(name, text, out, seen),
            None => out.push_str(&format!(
                "#error \"missing embedded kernel source {name}\"\n"
            )),
        }
    }
    fn inline(name: &str, text: &str, out: &mut String, seen: &mut Vec<String>) {
        out.push_str(&format!("#line 1 \"{name}\"\n"));
        for (i, line) in text.lines().enumerate() {
            let trimmed = line.trim_start();
            if let Some(rest) = trimmed.strip_prefix("#include \"") {
                header(rest.trim_end_matches('"'), out, seen);
                out.push_str(&format!("#line {} \"{name}\"\n", i + 2));
            } else {
                out.push_str(line);
                out.push('\n');
            }
        }
    }
    let mut out = String::new();
    inline(name, text, &mut out, &mut vec![name.to_owned()]);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn headers_are_inlined_once_with_line_markers() {
        let src = assemble_source("bvh_build.cl");
        assert!(src.contains("#line 1 \"bvh_types.h\""));
        assert!(src.contains("#line 1 \"bvh_common.h\""));
        assert_eq!(src.matches("#line 1 \"bvh_types.h\"").count(), 1);
        assert!(!src.contains("#include \"bvh_types.h\""));
    }

    #[test]
    fn build_options_have_no_relaxed_math() {
        let o = build_options(&[("BINS", "16".into())], false);
        assert!(o.contains("-D BINS=16"));
        assert!(!o.contains("fast-relaxed"));
        assert!(!o.contains("correctly-rounded"));
        let o = build_options(&[("BINS", "16".into())], true);
        assert!(o.contains(" -cl-fp32-correctly-rounded-divide-sqrt"));
    }
}
