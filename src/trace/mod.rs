//! The trace stage's core: rays against the frame's BVH and soup, on the
//! OpenCL device, with a plain Rust reference that agrees hit for hit.
//!
//! * `intersect`: the watertight ray-triangle test (Woop, Benthin, Wald 2013)
//!   and the robust ray-origin offset (Wächter, Binder 2019), on the CPU.
//! * `traverse`: the CPU reference traversals: closest hit and any hit by
//!   front-to-back stack traversal, closest hit by stackless escape indices.
//! * `escape`: the stackless (escape-index) layout of a `Bvh`, recomputed
//!   after every build.
//! * `device`: `DeviceTracer`, which runs `kernels/trace/trace.cl` over ray buffers.
//! * `camera`: a pinhole camera for primary rays (tests and benchmarks).
//! * `motion`: motion blur's shutter, time interpolation and step bounds,
//!   the twins of `kernels/trace/motion.h`, `motion.cl` and the motion reads of
//!   `trace_common.h`.
//!
//! The kernels share `kernels/trace/trace_common.h`, whose functions mirror the
//! Rust ones operation for operation, so device and CPU results are bit for
//! bit equal on a device with correctly rounded division (PoCL).
//! Closest-hit ties at equal t go to the smaller triangle index, so the
//! result never depends on the tree's shape or the traversal order.

pub mod camera;
pub mod device;
#[cfg(feature = "embree")]
pub mod embree;
pub mod energy;
pub mod escape;
pub mod intersect;
pub mod lens;
pub mod light_tree;
pub mod lights;
pub mod material;
pub mod media;
pub mod motion;
pub mod quantized;
pub mod render;
pub mod sampling;
pub mod settings;
pub mod texture;
pub mod texture_mean;
pub mod traverse;
pub mod vectors;
pub mod wide;

pub use camera::PinholeCamera;
pub use device::{DeviceTracer, TraceKind};
pub use escape::{stackless_layout, StacklessNode};
pub use traverse::{
    check_depth, trace_any, trace_any_wide, trace_closest, trace_closest_stackless,
    trace_closest_wide,
};
pub use wide::{leaf_arrays, wide_layout, LeafBlock, Wide8Node, WideLayout, WideNode};

use crate::device_struct::{device_consts, device_struct};
use bytemuck::{Pod, Zeroable};

device_consts! {
    fn trace_consts;
    /// `Hit::prim` of a ray that hit nothing.
    pub const MISS: u32 = u32::MAX;
    /// The bits of the quiet NaN that a leaf block holds for a degenerate
    /// triangle's coordinates (`wide::leaf_arrays`).
    pub const LEAF_FLAT_BITS: u32 = 0x7fc0_0000;
}

device_struct! {
/// One ray: hits count when tmin < t < tmax (tmin >= 0). The direction need
/// not be normalised (t is in units of it); an all-zero direction never hits.
/// Scalar arrays rather than float3 keep the struct 32 bytes with no padding
/// rules that differ between compilers.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct Ray as "Ray" {
    pub org: [f32; 3],
    pub tmin: f32,
    pub dir: [f32; 3],
    pub tmax: f32,
}
}

impl Ray {
    /// A ray over `(0, ∞)`.
    pub fn new(org: [f32; 3], dir: [f32; 3]) -> Ray {
        Ray {
            org,
            tmin: 0.0,
            dir,
            tmax: f32::INFINITY,
        }
    }
}

device_struct! {
/// A hit record (`Hit` in `kernels/trace_types.h`): distance, triangle
/// index in the soup, and the barycentrics of corners 1 and 2, so the hit
/// point is `(1 - u - v) p0 + u p1 + v p2`. `prim == MISS` (and `t = tmax`)
/// when nothing was hit. The geometric normal is recomputed by the shader
/// from the triangle; it is never zero, as degenerate triangles are never hit.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct Hit as "Hit" {
    pub t: f32,
    pub prim: u32,
    pub u: f32,
    pub v: f32,
}
}

impl Hit {
    pub fn miss(tmax: f32) -> Hit {
        Hit {
            t: tmax,
            prim: MISS,
            u: 0.0,
            v: 0.0,
        }
    }

    pub fn is_hit(&self) -> bool {
        self.prim != MISS
    }

    /// Equality of every bit, for comparing device and CPU results.
    pub fn bits(&self) -> [u32; 4] {
        [
            self.t.to_bits(),
            self.prim,
            self.u.to_bits(),
            self.v.to_bits(),
        ]
    }
}

const _: () = assert!(std::mem::size_of::<Ray>() == 32);
const _: () = assert!(std::mem::size_of::<Hit>() == 16);
const _: () = assert!(std::mem::size_of::<StacklessNode>() == 32);

/// Why tracing failed.
#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    #[error("the BVH is {depth} levels deep, beyond the traversal stack of {max}; the builder must refuse such trees")]
    TooDeep { depth: u32, max: u32 },
    #[error("the BVH is malformed: {0}")]
    Malformed(String),
    #[error("{0}")]
    Unsupported(String),
    #[error(transparent)]
    Device(#[from] crate::device::DeviceError),
    /// `--env` cannot be read (exit 4, an input error).
    #[error(transparent)]
    Env(#[from] lights::EnvError),
}
