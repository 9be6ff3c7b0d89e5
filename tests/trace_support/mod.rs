//! Helpers for the trace tests: closed meshes with exactly shared vertices,
//! random rays over a soup's bounds, and one call that traces a ray set
//! every way there is (device and CPU, stack and stackless, closest and any).
#![allow(dead_code)]

pub use crate::common::device;
use crate::common::Rng;
use soupray::bvh::device_builder::DeviceBuilder;
use soupray::bvh::{BuildParams, Bvh};
use soupray::device::Device;
use soupray::soup::Soup;
use soupray::trace::{self, DeviceTracer, Hit, Ray, TraceKind};

/// An indexed mesh, expanded into a soup so shared vertices are bit-equal.
pub struct Mesh {
    pub vertices: Vec<[f32; 3]>,
    pub faces: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn soup(&self) -> Soup {
        let tris: Vec<[[f32; 3]; 3]> = self
            .faces
            .iter()
            .map(|f| f.map(|i| self.vertices[i as usize]))
            .collect();
        Soup::from_triangles(&tris)
    }

    /// Scaled by `s` about the origin, then moved by `offset` on every axis.
    pub fn transformed(&self, s: f32, offset: f32) -> Mesh {
        Mesh {
            vertices: self
                .vertices
                .iter()
                .map(|v| v.map(|c| c * s + offset))
                .collect(),
            faces: self.faces.clone(),
        }
    }

    /// Every edge once, as (a, b) with a < b.
    pub fn edges(&self) -> Vec<(u32, u32)> {
        let mut e: Vec<(u32, u32)> = self
            .faces
            .iter()
            .flat_map(|f| [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .collect();
        e.sort_unstable();
        e.dedup();
        e
    }
}

/// The cube [-1, 1]^3, each face an n x n grid of quads split into two
/// triangles, outward-facing, with vertices shared exactly between faces.
pub fn cube_grid(n: u32) -> Mesh {
    let mut vertices: Vec<[f32; 3]> = Vec::new();
    let mut faces = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut vid = |p: [f32; 3], vertices: &mut Vec<[f32; 3]>| -> u32 {
        *index.entry(p.map(f32::to_bits)).or_insert_with(|| {
            vertices.push(p);
            vertices.len() as u32 - 1
        })
    };
    let coord = |i: u32| -1.0 + 2.0 * i as f32 / n as f32;
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let (u_ax, v_ax) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: u32, dj: u32| {
                        let mut p = [0.0; 3];
                        p[axis] = side;
                        p[u_ax] = coord(i + di);
                        p[v_ax] = coord(j + dj);
                        p
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                    let q = q.map(|p| vid(p, &mut vertices));
                    // Outward winding: (u, v, axis) is right-handed.
                    if side > 0.0 {
                        faces.push([q[0], q[1], q[2]]);
                        faces.push([q[0], q[2], q[3]]);
                    } else {
                        faces.push([q[0], q[2], q[1]]);
                        faces.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    Mesh { vertices, faces }
}

/// A unit icosphere: an icosahedron subdivided `levels` times, projected.
pub fn icosphere(levels: u32) -> Mesh {
    let t = (1.0 + 5.0f64.sqrt()) / 2.0;
    let mut v: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for tri in &f {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                m[k] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (pa, pb) = (v[a as usize], v[b as usize]);
                    v.push(std::array::from_fn(|i| 0.5 * (pa[i] + pb[i])));
                    v.len() as u32 - 1
                });
            }
            next.push([tri[0], m[0], m[2]]);
            next.push([tri[1], m[1], m[0]]);
            next.push([tri[2], m[2], m[1]]);
            next.push(m);
        }
        f = next;
    }
    let vertices = v
        .iter()
        .map(|p| {
            let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            p.map(|c| (c / l) as f32)
        })
        .collect();
    Mesh { vertices, faces: f }
}

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
    pub dev_closest: Vec<Hit>,
    pub dev_stackless: Vec<Hit>,
    pub dev_any: Vec<Hit>,
    pub dev_wide: Vec<Hit>,
    pub dev_any_wide: Vec<Hit>,
    pub bvh: Bvh,
}

/// Builds `soup`'s tree on the device and traces `rays` on the device and
/// with the CPU reference: stack, stackless and wide, closest and any.
pub fn trace_everything(d: &Device, soup: &Soup, rays: &[Ray]) -> Traced {
    let mut builder = DeviceBuilder::new(d, BuildParams::default()).unwrap();
    let (bvh, _) = builder.build(soup).unwrap();
    let mut positions = d.buffer::<[f32; 4]>(soup.positions.len()).unwrap();
    d.write(&mut positions, &soup.positions).unwrap();
    let mut tracer = DeviceTracer::new(d).unwrap();
    tracer.upload_bvh(&bvh).unwrap();
    tracer.upload_stackless(&bvh).unwrap();
    tracer.upload_wide(&bvh).unwrap();
    let prim_ids = builder.device_prim_ids().unwrap();
    let mut dev = |k| tracer.trace_rays(k, &positions, prim_ids, rays).unwrap();
    let dev_closest = dev(TraceKind::Closest);
    let dev_stackless = dev(TraceKind::ClosestStackless);
    let dev_any = dev(TraceKind::Any);
    let dev_wide = dev(TraceKind::ClosestWide);
    let dev_any_wide = dev(TraceKind::AnyWide);
    let snodes = trace::stackless_layout(&bvh).unwrap();
    let wnodes = trace::wide_layout(&bvh).unwrap();
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
            .map(|r| trace::trace_closest_wide(&wnodes, &bvh.prim_ids, p, r))
            .collect(),
        cpu_any_wide: rays
            .iter()
            .map(|r| trace::trace_any_wide(&wnodes, &bvh.prim_ids, p, r))
            .collect(),
        dev_closest,
        dev_stackless,
        dev_any,
        dev_wide,
        dev_any_wide,
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
