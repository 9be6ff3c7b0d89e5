//! soupray: an offline path tracer for glTF animations.
//!
//! Each frame flows one way through the pipeline, one module per stage:
//! scene (glTF loading and animation) → soup (world-space triangles) →
//! bvh (binned-SAH build on the OpenCL device) → trace → film → output.
//! The OpenCL plumbing lives in `device`; input meshes in PLY form in `ply`.

// Axis loops index several arrays in lockstep (lo, hi, centroid, scale);
// iterator zips would hide the math the kernels mirror line for line.
#![allow(clippy::needless_range_loop)]

pub mod bench;
pub mod bvh;
pub mod cli_bvh;
pub mod cli_scene;
pub mod compare;
pub mod device;
pub mod film;
pub mod frames;
pub mod output;
pub mod ply;
pub mod render;
pub mod report;
pub mod scene;
pub mod soup;
pub mod trace;

/// A mistake in how soupray was invoked (exit code 2), as opposed to a
/// failure while doing the work.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
pub struct UsageError(pub String);
