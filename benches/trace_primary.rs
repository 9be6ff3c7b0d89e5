//! Ray throughput of soupray's device traversals against Embree 3, on the
//! same soup and the same rays, in one run: the 4-wide and 8-wide stack
//! traversals, the binary tree's stack traversal and the stackless
//! escape-index one, the Rust CPU reference, and Embree (`rtcIntersect1`,
//! `rtcOccluded1`) when built with `--features embree`. Three ray sets per
//! mesh:
//! - primary: one camera ray per pixel (coherent);
//! - bounce: from every primary hit, a cosine-distributed diffuse bounce
//!   (incoherent), closest hit;
//! - shadow: from every primary hit towards a point light, any hit.
//!
//! ```text
//! cargo bench --bench trace_primary                     # soupray only
//! cargo bench --bench trace_primary --features embree   # with Embree 3
//! cargo bench --bench trace_primary -- --runs 9 --size 512 --threads 2 --local 64 \
//!     --meshes beast.ply,nefertiti.ply --leaf 4 --bins 16
//! ```
//!
//! `--candidate NAME[=VALUE],...` measures a kernel variant against the
//! default in the same process: the trace kernels are built a second time
//! with those defines, and each ray set is traced by the default 8-wide
//! traversal, the variant and Embree only. Each run times the default and
//! the variant back to back, so besides the table it prints the median of
//! their per-run ratios, which drift between processes leaves alone
//! (`cargo bench --bench trace_primary -- --candidate BOX_FMA --runs 15`).
//!
//! Each timed run launches every tracer once, in turn (interleaved), and
//! the table gives the median of the runs: device time (profiling events)
//! for soupray, wall time for Embree and the CPU reference, Mrays/s, the
//! share of Embree's throughput, and agreement with the CPU reference (the
//! same triangle; for shadow rays the same occlusion). A second table gives
//! the host cost of each traversal layout after a build.

mod support;

use opencl3::memory::Buffer;
use soupray::bvh::device_builder::DeviceBuilder;
use soupray::bvh::{BuildParams, Bvh};
use soupray::cli::report::median;
use soupray::device::Device;
use soupray::soup::Soup;
use soupray::trace::intersect::{
    geometric_normal, hit_point, offset_ray_origin_scaled, offset_scale,
};
use soupray::trace::sampling::onb;
use soupray::trace::{self, DeviceTracer, Hit, PinholeCamera, Ray, TraceKind};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// A scanned mesh, read in place from the shared folder (`SOUPRAY_SHARED`,
/// or `../shared` beside the checkout or `SOUPRAY_TEST_ROOT`, which the
/// bundle of `scripts/gpu-check.sh` sets); `Err` names the missing file.
fn mesh(name: &str) -> Result<Soup, String> {
    support::mesh(name)
}

/// A camera looking at the box along one of the six axis directions
/// (slightly tilted), close enough that the box's cross-section fills the
/// frame; of the six, the one whose 64x64 preview hits the mesh most, as a
/// scanned object is framed for rendering.
fn filling_camera(bvh: &Bvh, soup: &Soup, size: u32) -> PinholeCamera {
    let (lo, hi) = soup.bounds().unwrap();
    let ext: [f32; 3] = std::array::from_fn(|a| hi[a] - lo[a]);
    let center: [f32; 3] = std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]));
    let fov = 40.0f32;
    let view = |axis: usize, sign: f32, size: u32| {
        let width = (0..3)
            .filter(|&a| a != axis)
            .map(|a| ext[a])
            .fold(0.0, f32::max);
        let dist = 0.5 * width / (0.5 * fov.to_radians()).tan() + 0.5 * ext[axis];
        let mut origin = center;
        origin[axis] += sign * dist;
        origin[(axis + 1) % 3] += 0.1 * dist;
        let up = if axis == 1 {
            [0.0, 0.0, 1.0]
        } else {
            [0.0, 1.0, 0.0]
        };
        PinholeCamera::look_at(origin, center, up, fov, size, size)
    };
    let coverage = |c: &PinholeCamera| {
        c.rays()
            .iter()
            .filter(|r| trace::trace_closest(bvh, &soup.positions, r).is_hit())
            .count()
    };
    let (axis, sign) = (0..3)
        .flat_map(|a| [(a, 1.0f32), (a, -1.0)])
        .max_by_key(|&(a, s)| coverage(&view(a, s, 64)))
        .unwrap();
    view(axis, sign, size)
}

fn arg(name: &str, default: usize) -> usize {
    let args: Vec<String> = std::env::args().collect();
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// Runs `f` over `rays` in tiles of 256 handed out to `threads` threads.
fn parallel(
    rays: &[Ray],
    hits: &mut [Hit],
    threads: usize,
    f: &(dyn Fn(&[Ray], &mut [Hit]) + Sync),
) {
    const TILE: usize = 256;
    let next = AtomicUsize::new(0);
    let chunks: Vec<(usize, &mut [Hit])> = hits.chunks_mut(TILE).enumerate().collect();
    let chunks = std::sync::Mutex::new(chunks.into_iter().map(Some).collect::<Vec<_>>());
    std::thread::scope(|s| {
        for _ in 0..threads {
            s.spawn(|| loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some((c, out)) = chunks.lock().unwrap().get_mut(i).and_then(|c| c.take())
                else {
                    break;
                };
                f(&rays[c * TILE..(c * TILE + out.len())], out);
            });
        }
    });
}

/// The bench's settings, from the command line.
struct Settings {
    /// Timed runs per tracer (the median is reported).
    runs: usize,
    /// The image's side, in pixels (one primary ray each).
    size: u32,
    /// Threads of the CPU paths.
    threads: usize,
    /// The device kernels' work-group size.
    local: usize,
    /// The meshes, by file name under the shared `meshes/`.
    meshes: Vec<String>,
    /// The build's parameters (`--leaf`, `--bins`; the defaults otherwise).
    params: BuildParams,
    /// `--candidate`: the defines of a kernel variant, `NAME[=VALUE],...`.
    candidate: Option<String>,
}

/// `NAME[=VALUE],...` as build defines (a bare name is defined as 1).
fn defines(list: &str) -> Vec<(&str, String)> {
    list.split(',')
        .filter(|d| !d.is_empty())
        .map(|d| match d.split_once('=') {
            Some((name, value)) => (name, value.to_owned()),
            None => (d, "1".to_owned()),
        })
        .collect()
}

/// The meshes of the issue's table: three scans, two scanned statues and a
/// bumpy sphere of 977K triangles.
const MESHES: &str = "beast.ply,nefertiti.ply,stanford-bunny.ply,ogre.ply,sphere1m.ply";

/// One ray set of a mesh.
#[derive(Clone, Copy, PartialEq)]
enum RaySet {
    Primary,
    Bounce,
    Shadow,
}

impl RaySet {
    fn name(self) -> &'static str {
        match self {
            RaySet::Primary => "primary",
            RaySet::Bounce => "diffuse bounce",
            RaySet::Shadow => "shadow",
        }
    }
}

/// Who traces a ray set: a device kernel, or Embree on the host.
#[derive(Clone, Copy)]
enum Tracer {
    Device(TraceKind, &'static str),
    /// The kernel variant of `--candidate`.
    Candidate(TraceKind),
    #[cfg_attr(not(feature = "embree"), allow(dead_code))]
    Embree,
}

/// The tracers of a ray set, the default traversal first; with a
/// candidate, the default, the candidate and Embree.
fn tracers(set: RaySet, candidate: bool) -> Vec<Tracer> {
    if candidate {
        let kind = match set {
            RaySet::Shadow => TraceKind::AnyWide8,
            _ => TraceKind::ClosestWide8,
        };
        let mut t = vec![
            Tracer::Device(kind, "soupray 8-wide (the default)"),
            Tracer::Candidate(kind),
        ];
        if cfg!(feature = "embree") {
            t.push(Tracer::Embree);
        }
        return t;
    }
    let mut t = match set {
        RaySet::Shadow => vec![
            Tracer::Device(TraceKind::AnyWide8, "soupray 8-wide any-hit (the default)"),
            Tracer::Device(TraceKind::AnyWide8Q, "soupray 8-wide quantized any-hit"),
            Tracer::Device(TraceKind::AnyWide, "soupray 4-wide any-hit"),
            Tracer::Device(TraceKind::Any, "soupray binary any-hit"),
        ],
        _ => vec![
            Tracer::Device(TraceKind::ClosestWide8, "soupray 8-wide (the default)"),
            Tracer::Device(TraceKind::ClosestWide8Q, "soupray 8-wide quantized"),
            Tracer::Device(TraceKind::ClosestWide, "soupray 4-wide"),
            Tracer::Device(TraceKind::Closest, "soupray binary, stack"),
        ],
    };
    if set == RaySet::Primary {
        t.push(Tracer::Device(
            TraceKind::ClosestStackless,
            "soupray binary, stackless",
        ));
    }
    if cfg!(feature = "embree") {
        t.push(Tracer::Embree);
    }
    t
}

struct Row {
    mesh: String,
    tris: usize,
    set: RaySet,
    rays: usize,
    tracer: String,
    /// Median ms per launch: device time for soupray, wall for the others.
    ms: f64,
    embree: bool,
    agree: f64,
}

/// One mesh's tree and the host cost of its traversal layouts: name,
/// triangles, binary nodes, then (nodes, median ms) of the escape-index,
/// 4-wide and 8-wide layouts.
type LayoutRow = (String, usize, usize, [(usize, f64); 3]);

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let meshes = args
        .iter()
        .position(|a| a == "--meshes")
        .and_then(|i| args.get(i + 1))
        .map(String::as_str)
        .unwrap_or(MESHES);
    let s = Settings {
        runs: arg("--runs", 7).max(1),
        size: arg("--size", 512) as u32,
        threads: arg("--threads", 2),
        local: arg("--local", 64),
        meshes: meshes.split(',').map(str::to_owned).collect(),
        params: BuildParams {
            leaf_size: arg("--leaf", BuildParams::default().leaf_size as usize) as u32,
            bins: arg("--bins", BuildParams::default().bins as usize) as u32,
        },
        candidate: args
            .iter()
            .position(|a| a == "--candidate")
            .and_then(|i| args.get(i + 1))
            .cloned(),
    };
    let device = Device::open(None).expect("an OpenCL device");
    println!(
        "device: {} ({}, {} compute units); {}x{} primary rays and the bounce and shadow rays of their hits; median of {} interleaved runs; CPU paths on {} threads; work-groups of {}; leaves of at most {} triangles, {} bins",
        device.info.name, device.info.platform, device.info.compute_units, s.size, s.size, s.runs, s.threads, s.local, s.params.leaf_size, s.params.bins
    );
    let mut rows = Vec::new();
    let mut layout_rows = Vec::new();
    for name in &s.meshes {
        let soup = match mesh(name) {
            Ok(soup) => soup,
            Err(e) => {
                println!("{name}: skipped: {e}");
                continue;
            }
        };
        bench_mesh(&device, &s, name, &soup, &mut rows, &mut layout_rows);
    }
    print_tables(&rows, &layout_rows);
}

/// A small deterministic generator for the bounce directions.
struct Rng(u64);

impl Rng {
    fn f32(&mut self) -> f32 {
        // SplitMix64.
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        ((z ^ (z >> 31)) >> 40) as f32 / (1u64 << 24) as f32
    }
}

/// From each primary hit: a diffuse bounce (cosine-distributed about the
/// normal on the side the camera sees) and a shadow ray towards `light`,
/// both from the offset hit point.
fn secondary_rays(
    soup: &Soup,
    primary: &[Ray],
    hits: &[Hit],
    light: [f32; 3],
) -> (Vec<Ray>, Vec<Ray>) {
    let mut rng = Rng(7);
    let (mut bounce, mut shadow) = (Vec::new(), Vec::new());
    for (ray, hit) in primary.iter().zip(hits).filter(|(_, h)| h.is_hit()) {
        let p = hit_point(&soup.positions, hit.prim, hit.u, hit.v);
        let mut n = geometric_normal(&soup.positions, hit.prim);
        if (0..3).map(|a| n[a] * ray.dir[a]).sum::<f32>() > 0.0 {
            n = n.map(|c| -c);
        }
        let o = offset_ray_origin_scaled(p, n, offset_scale(&soup.positions, hit.prim));
        let nv = glam::Vec3::from(n);
        let (t, bt) = onb(nv);
        let (u1, u2) = (rng.f32(), rng.f32());
        let r = u1.sqrt();
        let phi = std::f32::consts::TAU * u2;
        let (x, y, z) = (r * phi.cos(), r * phi.sin(), (1.0 - u1).max(0.0).sqrt());
        bounce.push(Ray::new(o, (t * x + bt * y + nv * z).to_array()));
        let to: [f32; 3] = std::array::from_fn(|k| light[k] - o[k]);
        let dist = to.iter().map(|c| c * c).sum::<f32>().sqrt();
        let mut s = Ray::new(o, to.map(|c| c / dist));
        s.tmax = dist * (1.0 - 1e-4);
        shadow.push(s);
    }
    (bounce, shadow)
}

/// The CPU reference's hits (closest, or any for shadow rays), on the
/// bench's threads.
fn reference(bvh: &Bvh, soup: &Soup, rays: &[Ray], set: RaySet, threads: usize) -> Vec<Hit> {
    let mut out = vec![Hit::miss(0.0); rays.len()];
    parallel(rays, &mut out, threads, &|r, h| {
        for (ray, hit) in r.iter().zip(h.iter_mut()) {
            *hit = if set == RaySet::Shadow {
                trace::trace_any(bvh, &soup.positions, ray)
            } else {
                trace::trace_closest(bvh, &soup.positions, ray)
            };
        }
    });
    out
}

/// Agreement with the reference: the same triangle, or for shadow rays the
/// same occlusion (any-hit may report any occluder).
fn agreement(a: &[Hit], b: &[Hit], set: RaySet) -> f64 {
    let same = |x: &Hit, y: &Hit| {
        if set == RaySet::Shadow {
            x.is_hit() == y.is_hit()
        } else {
            x.prim == y.prim
        }
    };
    a.iter().zip(b).filter(|(x, y)| same(x, y)).count() as f64 / a.len().max(1) as f64
}

/// Every tracer on one mesh's three ray sets, interleaved run by run.
fn bench_mesh(
    device: &Device,
    s: &Settings,
    name: &str,
    soup: &Soup,
    rows: &mut Vec<Row>,
    layout_rows: &mut Vec<LayoutRow>,
) {
    let n = soup.triangle_count();
    let mut builder = DeviceBuilder::new(device, s.params).unwrap();
    let (bvh, _) = builder.build(soup).unwrap();
    let mut positions = device.buffer::<[f32; 4]>(soup.positions.len()).unwrap();
    device.write(&mut positions, &soup.positions).unwrap();
    let prim_ids = builder.device_prim_ids().unwrap();
    let camera = filling_camera(&bvh, soup, s.size);
    let primary = camera.rays();

    let mut tracer = DeviceTracer::new(device).unwrap();
    tracer.local_size = s.local;
    tracer.upload_bvh(&bvh).unwrap();
    layout_rows.push(layout_costs(
        &mut tracer,
        &bvh,
        (&positions, prim_ids),
        name,
        n,
        s.runs,
    ));
    tracer
        .upload_wide8_quantized(&bvh, &positions, prim_ids)
        .unwrap();
    let candidate = s.candidate.as_deref().map(|list| {
        let mut c = DeviceTracer::with_defines(device, &defines(list)).unwrap();
        c.local_size = s.local;
        c.upload_bvh(&bvh).unwrap();
        c.upload_wide8(&bvh, &positions, prim_ids).unwrap();
        c
    });
    // The device's own camera rays are the host's, bit for bit.
    let generated = device.buffer::<Ray>(primary.len()).unwrap();
    tracer.generate_primary(&camera, &generated).unwrap();
    let mut back = vec![Ray::default(); primary.len()];
    device.read(&generated, &mut back).unwrap();
    assert_eq!(back, primary, "device and host primary rays differ");

    let primary_hits = reference(&bvh, soup, &primary, RaySet::Primary, s.threads);
    let (lo, hi) = soup.bounds().unwrap();
    let diag = (0..3).map(|a| (hi[a] - lo[a]).powi(2)).sum::<f32>().sqrt();
    let light: [f32; 3] =
        std::array::from_fn(|a| 0.5 * (lo[a] + hi[a]) + diag * [0.4, 1.0, 0.3][a]);
    let (bounce, shadow) = secondary_rays(soup, &primary, &primary_hits, light);
    #[cfg(feature = "embree")]
    let scene = trace::embree::EmbreeScene::new(&soup.positions, s.threads);

    for (set, rays) in [
        (RaySet::Primary, primary),
        (RaySet::Bounce, bounce),
        (RaySet::Shadow, shadow),
    ] {
        let count = rays.len();
        let expected = reference(&bvh, soup, &rays, set, s.threads);
        let mut ray_buffer = device.buffer::<Ray>(count.max(1)).unwrap();
        device.write(&mut ray_buffer, &rays).unwrap();
        let hits = device.buffer::<Hit>(count.max(1)).unwrap();
        let list = tracers(set, candidate.is_some());
        let mut ms: Vec<Vec<f64>> = vec![Vec::new(); list.len()];
        let mut agree = vec![0.0; list.len()];
        let mut out = vec![Hit::miss(0.0); count];
        // Run 0 warms every tracer up and checks its hits; runs 1.. are timed.
        for run in 0..=s.runs {
            for (i, t) in list.iter().enumerate() {
                // A pause, so that no tracer starts on threads another one
                // has left busy (PoCL's workers spin for a while).
                std::thread::sleep(std::time::Duration::from_millis(5));
                let elapsed = match *t {
                    Tracer::Device(kind, _) | Tracer::Candidate(kind) => {
                        let by = match *t {
                            Tracer::Candidate(_) => candidate.as_ref().unwrap(),
                            _ => &tracer,
                        };
                        by.trace(kind, &positions, prim_ids, &ray_buffer, &hits, count)
                            .unwrap();
                        let timings = device.take_timings().unwrap();
                        if run == 0 {
                            device.read(&hits, &mut out).unwrap();
                        }
                        timings.ms(kind.stage())
                    }
                    Tracer::Embree => {
                        let start = Instant::now();
                        #[cfg(feature = "embree")]
                        parallel(&rays, &mut out, s.threads, &|r, h| {
                            let flags = trace::embree::CONTEXT_INCOHERENT;
                            if set == RaySet::Shadow {
                                scene.occluded(r, h, flags)
                            } else {
                                scene.intersect(r, h, flags)
                            }
                        });
                        start.elapsed().as_secs_f64() * 1e3
                    }
                };
                if run == 0 {
                    agree[i] = agreement(&out, &expected, set);
                } else {
                    ms[i].push(elapsed);
                }
            }
        }
        if candidate.is_some() {
            // The default is list[0] and the candidate list[1], timed back
            // to back in every run.
            let mut ratios: Vec<f64> = ms[1].iter().zip(&ms[0]).map(|(c, d)| c / d).collect();
            ratios.sort_by(f64::total_cmp);
            println!(
                "{name} {}: candidate / default, per run: median {:.3} (min {:.3}, max {:.3}, {} runs)",
                set.name(),
                median(ratios.clone()),
                ratios[0],
                ratios[ratios.len() - 1],
                ratios.len()
            );
        }
        for (i, t) in list.iter().enumerate() {
            let (label, embree) = match *t {
                Tracer::Device(_, label) => (label.to_owned(), false),
                Tracer::Candidate(_) => (
                    format!(
                        "soupray 8-wide candidate ({})",
                        s.candidate.as_deref().unwrap_or("")
                    ),
                    false,
                ),
                Tracer::Embree => {
                    let call = if set == RaySet::Shadow {
                        "rtcOccluded1"
                    } else {
                        "rtcIntersect1"
                    };
                    (format!("Embree 3 {call} ({} threads)", s.threads), true)
                }
            };
            rows.push(Row {
                mesh: name.into(),
                tris: n,
                set,
                rays: count,
                tracer: label,
                ms: median(std::mem::take(&mut ms[i])),
                embree,
                agree: agree[i],
            });
        }
    }
    drop(builder);
}

/// The host cost of the escape-index, 4-wide and 8-wide layouts of `bvh`,
/// medians of `runs`.
fn layout_costs(
    tracer: &mut DeviceTracer,
    bvh: &Bvh,
    (positions, prim_ids): (&Buffer<[f32; 4]>, &Buffer<u32>),
    name: &str,
    n: usize,
    runs: usize,
) -> LayoutRow {
    let mut ms: [Vec<f64>; 3] = Default::default();
    let mut nodes = [0usize; 3];
    for _ in 0..runs {
        let stats = [
            tracer.upload_stackless(bvh).unwrap(),
            tracer.upload_wide(bvh, positions, prim_ids).unwrap(),
            tracer.upload_wide8(bvh, positions, prim_ids).unwrap(),
        ];
        for (k, st) in stats.iter().enumerate() {
            ms[k].push(st.layout_ms);
            nodes[k] = st.entries;
        }
    }
    let [a, b, c] = ms.map(median);
    (
        name.into(),
        n,
        bvh.nodes.len(),
        [(nodes[0], a), (nodes[1], b), (nodes[2], c)],
    )
}

/// The throughput table and the layouts' host-cost table, in Markdown.
fn print_tables(rows: &[Row], layout_rows: &[LayoutRow]) {
    println!();
    println!("| mesh | triangles | rays | count | tracer | ms (median) | Mrays/s | share of Embree | same result as CPU ref |");
    println!("|---|---:|---|---:|---|---:|---:|---:|---:|");
    for r in rows {
        let embree = rows
            .iter()
            .find(|e| e.embree && e.mesh == r.mesh && e.set == r.set)
            .map(|e| e.ms);
        let share = match embree {
            Some(e) if !r.embree => format!("{:.0}%", 100.0 * e / r.ms),
            _ => "-".into(),
        };
        println!(
            "| {} | {} | {} | {} | {} | {:.2} | {:.2} | {} | {:.3}% |",
            r.mesh,
            r.tris,
            r.set.name(),
            r.rays,
            r.tracer,
            r.ms,
            r.rays as f64 / r.ms / 1e3,
            share,
            100.0 * r.agree
        );
    }
    println!();
    println!("| mesh | triangles | BVH nodes | escape-index layout (host ms) | 4-wide nodes | 4-wide collapse (host ms) | 8-wide nodes | 8-wide collapse (host ms) |");
    println!("|---|---:|---:|---:|---:|---:|---:|---:|");
    for (name, n, nodes, [(_, esc), (w4, w4ms), (w8, w8ms)]) in layout_rows {
        println!("| {name} | {n} | {nodes} | {esc:.2} | {w4} | {w4ms:.2} | {w8} | {w8ms:.2} |");
    }
}
