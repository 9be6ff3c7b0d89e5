//! soupray: an offline path tracer for glTF animations.
//!
//! Each frame flows one way through the pipeline, one module per stage:
//! scene (glTF loading and animation) → soup (world-space triangles) →
//! bvh (binned-SAH build on the OpenCL device) → trace → film → output.
//! `pipeline` runs one frame through the stages up to the film
//! (`pipeline::FrameRenderer`); writing its files is the caller's step.
//! The OpenCL plumbing lives in `device`; input meshes in PLY form in `ply`.
//!
//! The binary's commands (render, bench, report, bvh, devices, info, soup)
//! are thin layers over the stages and live apart from them in `cli`.

// Axis loops index several arrays in lockstep (lo, hi, centroid, scale);
// iterator zips would hide the math the kernels mirror line for line.
#![allow(clippy::needless_range_loop)]

pub mod bvh;
pub mod cli;
pub mod compare;
pub mod denoise;
pub mod device;
pub mod device_struct;
pub mod film;
pub mod input;
pub mod kernels;
pub mod output;
pub mod pipeline;
pub mod ply;
pub mod scene;
pub mod soup;
pub mod trace;

/// A mistake in how soupray was invoked (exit code 2), as opposed to a
/// failure while doing the work.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);

/// The exit codes of the `soupray` binary, for `--help` (and the README).
pub const EXIT_CODES: &str = "\
Exit codes:
  0    success: everything requested was done
  1    any other failure
  2    usage error (bad flags or values)
  3    set-up failed: the OpenCL device (no platform, no matching device, kernel
       build), or for --denoise the Open Image Denoise library (not installed,
       not 2.x, no usable device)
  4    the input could not be read (missing, malformed or unsupported scene or mesh)
  5    a frame failed (with --keep-going: at least one frame failed)
  6    the output directory cannot be created or written
  130  interrupted (SIGINT); 143 terminated (SIGTERM)";
