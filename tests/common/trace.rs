//! Helpers for the trace tests: closed meshes with exactly shared vertices,
//! random rays over a soup's bounds, and one call that traces a ray set
//! every way there is (device and CPU, stack and stackless, closest and any).
#![allow(dead_code)]

#[allow(unused_imports)]
pub use super::device;
use super::Rng;
use soupray::bvh::device_builder::DeviceBuilder;
use soupray::bvh::{BuildParams, Bvh};
use soupray::device::Device;
use soupray::soup::Soup;
use soupray::trace::{self, DeviceTracer, Hit, Ray, TraceKind};

// Re-exported so `use common::trace::*` brings the closed meshes.
#[allow(unused_imports)]
pub use super::geometry::{cube_grid, icosphere, Mesh};

/// `n` rays from random points of the soup's box (grown by 20%) towards
/// other random points of it; every 16th ray gets one or two direction
/// components set to +0 or -0 (axis-parallel and planar rays).
pub fn random_rays(soup: &Soup, n: usize, seed: u64) -> Vec<Ray> {
    let (lo, hi) = soup.bounds().unwrap_or(([0.0; 3], [1.0; 3]));
    let mut rng = Rng::new(seed);
    let point = |rng: &mut Rng| -> [f32; 3] {
        std::array::from_fn(|a| {
            let ext = hi[a] - lo[a];
            lo[a] - 0.2 * ext + rng.f32() * 1.4 * ext
        })
    };
    (0..n)
        .map(|i| {
            let o = point(&mut rng);
            let target = point(&mut rng);
            let mut d: [f32; 3] = std::array::from_fn(|a| target[a] - o[a]);
            if i % 16 == 0 {
                let zeros = 1 + (rng.f32() * 2.0) as usize;
                for _ in 0..zeros {
                    let a = (rng.f32() * 3.0) as usize % 3;
                    d[a] = if rng.f32() < 0.5 { 0.0 } else { -0.0 };
                }
            }
            Ray::new(o, d)
        })
        .collect()
}

/// Every way of tracing one ray set.
pub struct Traced {
    pub cpu_closest: Vec<Hit>,
    pub cpu_stackless: Vec<Hit>,
    pub cpu_any: Vec<Hit>,
    pub cpu_wide: Vec<Hit>,
    pub cpu_any_wide: Vec<Hit>,
    pub cpu_wide8: Vec<Hit>,
    pub cpu_any_wide8: Vec<Hit>,
    pub dev_closest: Vec<Hit>,
    pub dev_stackless: Vec<Hit>,
    pub dev_any: Vec<Hit>,
    pub dev_wide: Vec<Hit>,
    pub dev_any_wide: Vec<Hit>,
    pub dev_wide8: Vec<Hit>,
    pub dev_any_wide8: Vec<Hit>,
    /// The quantized 8-wide layout's: it visits more boxes than the 8-wide
    /// layout, so its any-hit may find another occluder.
    pub dev_wide8q: Vec<Hit>,
    pub dev_any_wide8q: Vec<Hit>,
    pub bvh: Bvh,
}

/// Builds `soup`'s tree on the device and traces `rays` on the device and
/// with the CPU reference: stack, stackless, 4-wide and 8-wide, closest and
/// any.
pub fn trace_everything(d: &Device, soup: &Soup, rays: &[Ray]) -> Traced {
    let mut builder = DeviceBuilder::new(d, BuildParams::default()).unwrap();
    let (bvh, _) = builder.build(soup).unwrap();
    let mut positions = d.buffer::<[f32; 4]>(soup.positions.len()).unwrap();
    d.write(&mut positions, &soup.positions).unwrap();
    let mut tracer = DeviceTracer::new(d).unwrap();
    tracer.upload_bvh(&bvh).unwrap();
    tracer.upload_stackless(&bvh).unwrap();
    let prim_ids = builder.device_prim_ids().unwrap();
    tracer.upload_wide(&bvh, &positions, prim_ids).unwrap();
    tracer
        .upload_wide8_quantized(&bvh, &positions, prim_ids)
        .unwrap();
    let mut dev = |k| tracer.trace_rays(k, &positions, prim_ids, rays).unwrap();
    let dev_closest = dev(TraceKind::Closest);
    let dev_stackless = dev(TraceKind::ClosestStackless);
    let dev_any = dev(TraceKind::Any);
    let dev_wide = dev(TraceKind::ClosestWide);
    let dev_any_wide = dev(TraceKind::AnyWide);
    let dev_wide8 = dev(TraceKind::ClosestWide8);
    let dev_any_wide8 = dev(TraceKind::AnyWide8);
    let dev_wide8q = dev(TraceKind::ClosestWide8Q);
    let dev_any_wide8q = dev(TraceKind::AnyWide8Q);
    let snodes = trace::stackless_layout(&bvh).unwrap();
    let (wnodes, blocks) = trace::wide_layout::<trace::WideNode>(&bvh).unwrap();
    let (w8nodes, blocks8) = trace::wide_layout::<trace::Wide8Node>(&bvh).unwrap();
    let slots = trace::leaf_arrays(&blocks, &bvh.prim_ids, None).0;
    let slots8 = trace::leaf_arrays(&blocks8, &bvh.prim_ids, None).0;
    let p = &soup.positions;
    Traced {
        cpu_closest: rays
            .iter()
            .map(|r| trace::trace_closest(&bvh, p, r))
            .collect(),
        cpu_stackless: rays
            .iter()
            .map(|r| trace::trace_closest_stackless(&snodes, &bvh.prim_ids, p, r))
            .collect(),
        cpu_any: rays.iter().map(|r| trace::trace_any(&bvh, p, r)).collect(),
        cpu_wide: rays
            .iter()
            .map(|r| trace::trace_closest_wide(&wnodes, &slots, p, r))
            .collect(),
        cpu_any_wide: rays
            .iter()
            .map(|r| trace::trace_any_wide(&wnodes, &slots, p, r))
            .collect(),
        cpu_wide8: rays
            .iter()
            .map(|r| trace::trace_closest_wide(&w8nodes, &slots8, p, r))
            .collect(),
        cpu_any_wide8: rays
            .iter()
            .map(|r| trace::trace_any_wide(&w8nodes, &slots8, p, r))
            .collect(),
        dev_closest,
        dev_stackless,
        dev_any,
        dev_wide,
        dev_any_wide,
        dev_wide8,
        dev_any_wide8,
        dev_wide8q,
        dev_any_wide8q,
        bvh,
    }
}

/// Asserts two hit lists equal bit for bit, naming the first difference.
pub fn assert_same(a: &[Hit], b: &[Hit], rays: &[Ray], what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    if let Some(i) = (0..a.len()).find(|&i| a[i].bits() != b[i].bits()) {
        panic!(
            "{what}: ray {i} {:?} differs: {:?} vs {:?} ({} of {} differ)",
            rays[i],
            a[i],
            b[i],
            (0..a.len()).filter(|&i| a[i].bits() != b[i].bits()).count(),
            a.len()
        );
    }
}

/// Asserts any-hit occlusion agrees with closest-hit, and that an any-hit
/// triangle really is hit within the ray's interval.
pub fn assert_any_agrees(any: &[Hit], closest: &[Hit], what: &str) {
    for (i, (a, c)) in any.iter().zip(closest).enumerate() {
        assert_eq!(
            a.is_hit(),
            c.is_hit(),
            "{what}: ray {i}: any-hit {a:?} vs closest {c:?}"
        );
        if a.is_hit() {
            assert!(a.t >= c.t, "{what}: ray {i}: any-hit nearer than closest");
        }
    }
}
