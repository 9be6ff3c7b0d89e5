//! A minimal binding to Embree 3 (`libembree3`, Debian's libembree-dev), only
//! behind the `embree` cargo feature: the reference the trace benchmark
//! measures soupray's traversal against, on the same soup and rays. Just
//! enough of the API for one triangle mesh, `rtcIntersect1` and `rtcOccluded1`.

use super::{Hit, Ray, MISS};
use std::ffi::c_void;
use std::os::raw::{c_char, c_int, c_uint};

type RtcDevice = *mut c_void;
type RtcScene = *mut c_void;
type RtcGeometry = *mut c_void;

const RTC_GEOMETRY_TYPE_TRIANGLE: c_int = 0;
const RTC_BUFFER_TYPE_INDEX: c_int = 0;
const RTC_BUFFER_TYPE_VERTEX: c_int = 1;
const RTC_FORMAT_UINT3: c_int = 0x5003;
const RTC_FORMAT_FLOAT3: c_int = 0x9003;
const RTC_INVALID_GEOMETRY_ID: c_uint = u32::MAX;
/// `RTC_INTERSECT_CONTEXT_FLAG_COHERENT`.
pub const CONTEXT_COHERENT: c_int = 1;
/// `RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT`.
pub const CONTEXT_INCOHERENT: c_int = 0;

/// `struct RTCRayHit` (rtcore_ray.h, RTC_MAX_INSTANCE_LEVEL_COUNT = 1).
#[repr(C, align(16))]
#[derive(Clone, Copy, Default)]
struct RtcRayHit {
    org: [f32; 3],
    tnear: f32,
    dir: [f32; 3],
    time: f32,
    tfar: f32,
    mask: c_uint,
    id: c_uint,
    flags: c_uint,
    ng: [f32; 3],
    u: f32,
    v: f32,
    prim_id: c_uint,
    geom_id: c_uint,
    inst_id: [c_uint; 1],
}

impl RtcRayHit {
    /// `ray`, with no hit yet.
    fn new(ray: &Ray) -> RtcRayHit {
        RtcRayHit {
            org: ray.org,
            tnear: ray.tmin,
            dir: ray.dir,
            tfar: ray.tmax,
            mask: u32::MAX,
            flags: 0,
            geom_id: RTC_INVALID_GEOMETRY_ID,
            prim_id: RTC_INVALID_GEOMETRY_ID,
            inst_id: [RTC_INVALID_GEOMETRY_ID],
            ..RtcRayHit::default()
        }
    }
}

/// `struct RTCIntersectContext` (no min-width, one instance level).
#[repr(C)]
struct RtcIntersectContext {
    flags: c_int,
    filter: *const c_void,
    inst_id: [c_uint; 1],
}

impl RtcIntersectContext {
    /// `rtcInitIntersectContext` with the context flags `flags`.
    fn new(flags: c_int) -> RtcIntersectContext {
        RtcIntersectContext {
            flags,
            filter: std::ptr::null(),
            inst_id: [RTC_INVALID_GEOMETRY_ID],
        }
    }
}

#[link(name = "embree3")]
extern "C" {
    fn rtcNewDevice(config: *const c_char) -> RtcDevice;
    fn rtcReleaseDevice(device: RtcDevice);
    fn rtcNewScene(device: RtcDevice) -> RtcScene;
    fn rtcReleaseScene(scene: RtcScene);
    fn rtcCommitScene(scene: RtcScene);
    fn rtcNewGeometry(device: RtcDevice, kind: c_int) -> RtcGeometry;
    fn rtcReleaseGeometry(geometry: RtcGeometry);
    fn rtcCommitGeometry(geometry: RtcGeometry);
    fn rtcAttachGeometry(scene: RtcScene, geometry: RtcGeometry) -> c_uint;
    fn rtcSetSharedGeometryBuffer(
        geometry: RtcGeometry,
        kind: c_int,
        slot: c_uint,
        format: c_int,
        ptr: *const c_void,
        byte_offset: usize,
        byte_stride: usize,
        item_count: usize,
    );
    fn rtcIntersect1(scene: RtcScene, context: *mut RtcIntersectContext, rayhit: *mut RtcRayHit);
    fn rtcOccluded1(scene: RtcScene, context: *mut RtcIntersectContext, ray: *mut RtcRayHit);
}

/// An Embree scene of one triangle soup, sharing the soup's memory.
pub struct EmbreeScene<'a> {
    device: RtcDevice,
    scene: RtcScene,
    _positions: &'a [[f32; 4]],
    _indices: Vec<[u32; 3]>,
}

// SAFETY: Embree scenes are safe to query from many threads once committed.
unsafe impl Sync for EmbreeScene<'_> {}

impl<'a> EmbreeScene<'a> {
    /// Builds Embree's BVH over `positions` (three `[x, y, z, _]` per
    /// triangle, shared, not copied) with `threads` build threads.
    pub fn new(positions: &'a [[f32; 4]], threads: usize) -> EmbreeScene<'a> {
        Self::new_timed(positions, threads).0
    }

    /// `new`, and the milliseconds of its BVH build alone (the geometry
    /// and scene commits; not the device's thread-pool start-up).
    pub fn new_timed(positions: &'a [[f32; 4]], threads: usize) -> (EmbreeScene<'a>, f64) {
        let n = positions.len() / 3;
        let indices: Vec<[u32; 3]> = (0..n as u32)
            .map(|t| [3 * t, 3 * t + 1, 3 * t + 2])
            .collect();
        let config = std::ffi::CString::new(format!("threads={threads}")).unwrap();
        // SAFETY: plain Embree API use; the shared buffers (`positions`,
        // `indices`) live as long as the scene (the struct holds them), and
        // Embree reads 16 bytes per vertex (the padding is ours).
        unsafe {
            let device = rtcNewDevice(config.as_ptr());
            assert!(!device.is_null(), "rtcNewDevice failed");
            let scene = rtcNewScene(device);
            let geometry = rtcNewGeometry(device, RTC_GEOMETRY_TYPE_TRIANGLE);
            rtcSetSharedGeometryBuffer(
                geometry,
                RTC_BUFFER_TYPE_VERTEX,
                0,
                RTC_FORMAT_FLOAT3,
                positions.as_ptr() as *const c_void,
                0,
                16,
                positions.len(),
            );
            rtcSetSharedGeometryBuffer(
                geometry,
                RTC_BUFFER_TYPE_INDEX,
                0,
                RTC_FORMAT_UINT3,
                indices.as_ptr() as *const c_void,
                0,
                12,
                n,
            );
            let start = std::time::Instant::now();
            rtcCommitGeometry(geometry);
            rtcAttachGeometry(scene, geometry);
            rtcReleaseGeometry(geometry);
            rtcCommitScene(scene);
            let ms = start.elapsed().as_secs_f64() * 1e3;
            let scene = EmbreeScene {
                device,
                scene,
                _positions: positions,
                _indices: indices,
            };
            (scene, ms)
        }
    }

    /// Closest hits of `rays` with `rtcIntersect1`, into `hits`, with the
    /// context flags `flags` (`CONTEXT_COHERENT` or `CONTEXT_INCOHERENT`).
    pub fn intersect(&self, rays: &[Ray], hits: &mut [Hit], flags: c_int) {
        let mut context = RtcIntersectContext::new(flags);
        for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
            let mut rh = RtcRayHit::new(ray);
            // SAFETY: a committed scene, an initialised context and ray.
            unsafe { rtcIntersect1(self.scene, &mut context, &mut rh) };
            *hit = if rh.geom_id == RTC_INVALID_GEOMETRY_ID {
                Hit::miss(ray.tmax)
            } else {
                Hit {
                    t: rh.tfar,
                    prim: rh.prim_id,
                    u: rh.u,
                    v: rh.v,
                }
            };
            debug_assert!(hit.prim != MISS || rh.geom_id == RTC_INVALID_GEOMETRY_ID);
        }
    }
}

impl EmbreeScene<'_> {
    /// Occlusion of `rays` with `rtcOccluded1`: `hits[i]` is a hit (its
    /// `prim` is 0, Embree does not say which triangle) when something lies
    /// within the ray's interval, else a miss.
    pub fn occluded(&self, rays: &[Ray], hits: &mut [Hit], flags: c_int) {
        let mut context = RtcIntersectContext::new(flags);
        for (ray, hit) in rays.iter().zip(hits.iter_mut()) {
            // An RTCRay is the first 48 bytes of an RTCRayHit.
            let mut rh = RtcRayHit::new(ray);
            // SAFETY: a committed scene, an initialised context and ray.
            unsafe { rtcOccluded1(self.scene, &mut context, &mut rh) };
            *hit = if rh.tfar == f32::NEG_INFINITY {
                Hit {
                    t: ray.tmax,
                    prim: 0,
                    u: 0.0,
                    v: 0.0,
                }
            } else {
                Hit::miss(ray.tmax)
            };
        }
    }
}

impl Drop for EmbreeScene<'_> {
    fn drop(&mut self) {
        // SAFETY: releasing what `new` created, once.
        unsafe {
            rtcReleaseScene(self.scene);
            rtcReleaseDevice(self.device);
        }
    }
}
