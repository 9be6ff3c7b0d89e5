//! Primary-ray closest-hit throughput: soupray's device traversals (the
//! default 4-wide stack traversal, the binary tree's stack traversal and the
//! stackless escape-index one), the Rust CPU reference, and Embree 3 when built
//! with `--features embree`, on the same soup, camera and rays, in one run.
//!
//!   cargo bench --bench trace_primary                     # soupray only
//!   cargo bench --bench trace_primary --features embree   # with Embree 3
//!   cargo bench --bench trace_primary -- --runs 9 --size 512 --threads 2 --local 64
//!
//! Prints a Markdown table: median device time (profiling events) and wall
//! time per frame of 512x512 primary rays, Mrays/s, the hit fraction, and
//! agreement with the CPU reference; plus the host cost of the stackless
//! layout's escape indices and of the 4-wide collapse after a build.

mod support;

use soupray::bvh::device_builder::DeviceBuilder;
use soupray::bvh::{BuildParams, Bvh};
use soupray::cli::report::median;
use soupray::device::Device;
use soupray::soup::Soup;
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

struct Row {
    mesh: String,
    tris: usize,
    tracer: String,
    device_ms: Option<f64>,
    wall_ms: f64,
    hit_fraction: f64,
    agree: f64,
}

fn agreement(a: &[Hit], b: &[Hit]) -> f64 {
    a.iter().zip(b).filter(|(x, y)| x.prim == y.prim).count() as f64 / a.len() as f64
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
}

/// One mesh's BVH and the host cost of its other layouts: name, triangles,
/// nodes, the escape indices' median ms, the 4-wide nodes and the 4-wide
/// collapse's median ms.
type LayoutRow = (&'static str, usize, usize, f64, usize, f64);

fn main() {
    let s = Settings {
        runs: arg("--runs", 7).max(1),
        size: arg("--size", 512) as u32,
        threads: arg("--threads", 2),
        local: arg("--local", 64),
    };
    let (runs, size, threads, local) = (s.runs, s.size, s.threads, s.local);
    let device = Device::open(None).expect("an OpenCL device");
    println!(
        "device: {} ({}, {} compute units); {size}x{size} primary rays, median of {runs} runs; CPU paths on {threads} threads; work-groups of {local}",
        device.info.name, device.info.platform, device.info.compute_units
    );
    let mut rows = Vec::new();
    let mut escape_rows = Vec::new();
    for name in ["beast.ply", "nefertiti.ply"] {
        let soup = match mesh(name) {
            Ok(soup) => soup,
            Err(e) => {
                println!("{name}: skipped: {e}");
                continue;
            }
        };
        bench_mesh(&device, &s, name, &soup, &mut rows, &mut escape_rows);
    }
    print_tables(&rows, escape_rows, size);
}

/// Every tracer on one mesh: the layouts' host cost, then the CPU
/// reference, the device traversals and (with the feature) Embree, each
/// on the same camera's rays.
fn bench_mesh(
    device: &Device,
    s: &Settings,
    name: &'static str,
    soup: &Soup,
    rows: &mut Vec<Row>,
    escape_rows: &mut Vec<LayoutRow>,
) {
    let n = soup.triangle_count();
    let mut builder = DeviceBuilder::new(device, BuildParams::default()).unwrap();
    let (bvh, _) = builder.build(soup).unwrap();
    let mut positions = device.buffer::<[f32; 4]>(soup.positions.len()).unwrap();
    device.write(&mut positions, &soup.positions).unwrap();
    let prim_ids = builder.device_prim_ids().unwrap();
    let camera = filling_camera(&bvh, soup, s.size);
    let rays_host = camera.rays();
    let count = rays_host.len();

    let mut tracer = DeviceTracer::new(device).unwrap();
    tracer.local_size = s.local;
    tracer.upload_bvh(&bvh).unwrap();
    escape_rows.push(layout_costs(&mut tracer, &bvh, name, n, s.runs));
    let rays = device.buffer::<Ray>(count).unwrap();
    let hits = device.buffer::<Hit>(count).unwrap();
    tracer.generate_primary(&camera, &rays).unwrap();
    device.finish().unwrap();
    let mut generated = vec![Ray::default(); count];
    device.read(&rays, &mut generated).unwrap();
    assert_eq!(generated, rays_host, "device and host primary rays differ");

    let (reference, row) = cpu_reference(&bvh, soup, &rays_host, s, name);
    let hit_fraction = row.hit_fraction;
    rows.push(row);

    for (kind, label, stage) in [
        (
            TraceKind::Closest,
            "soupray device, stack (binary tree)",
            "trace/closest",
        ),
        (
            TraceKind::ClosestStackless,
            "soupray device, stackless",
            "trace/stackless",
        ),
        (
            TraceKind::ClosestWide,
            "soupray device, wide (stack, 4-wide layout; the default)",
            "trace/closest_wide",
        ),
    ] {
        let mut out = vec![Hit::miss(0.0); count];
        tracer
            .trace(kind, &positions, prim_ids, &rays, &hits, count)
            .unwrap();
        device.take_timings().unwrap();
        let (mut dev, mut wall) = (Vec::new(), Vec::new());
        for _ in 0..s.runs {
            let t = Instant::now();
            tracer
                .trace(kind, &positions, prim_ids, &rays, &hits, count)
                .unwrap();
            let timings = device.take_timings().unwrap();
            wall.push(t.elapsed().as_secs_f64() * 1e3);
            dev.push(timings.ms(stage));
        }
        device.read(&hits, &mut out).unwrap();
        rows.push(Row {
            mesh: name.into(),
            tris: n,
            tracer: label.into(),
            device_ms: Some(median(dev)),
            wall_ms: median(wall),
            hit_fraction,
            agree: agreement(&out, &reference),
        });
    }

    #[cfg(feature = "embree")]
    rows.push(embree_row(
        soup,
        &rays_host,
        &reference,
        hit_fraction,
        s,
        name,
    ));
    drop(builder);
}

/// The host cost of the stackless layout's escape indices and of the
/// 4-wide collapse of `bvh`, medians of `runs`.
fn layout_costs(
    tracer: &mut DeviceTracer,
    bvh: &Bvh,
    name: &'static str,
    n: usize,
    runs: usize,
) -> LayoutRow {
    let mut layout_ms = Vec::new();
    let mut wide_ms = Vec::new();
    let mut wide_nodes = 0;
    for _ in 0..runs {
        layout_ms.push(tracer.upload_stackless(bvh).unwrap().layout_ms);
        let wide = tracer.upload_wide(bvh).unwrap();
        wide_ms.push(wide.layout_ms);
        wide_nodes = wide.entries;
    }
    (
        name,
        n,
        bvh.nodes.len(),
        median(layout_ms),
        wide_nodes,
        median(wide_ms),
    )
}

/// The CPU reference: the yardstick for agreement, and a plain-Rust
/// scalar throughput for scale. Returns its hits and its row.
fn cpu_reference(
    bvh: &Bvh,
    soup: &Soup,
    rays_host: &[Ray],
    s: &Settings,
    name: &str,
) -> (Vec<Hit>, Row) {
    let (runs, threads) = (s.runs, s.threads);
    let count = rays_host.len();
    let mut reference = vec![Hit::miss(0.0); count];
    let mut wall = Vec::new();
    for _ in 0..runs.min(3) {
        let t = Instant::now();
        parallel(rays_host, &mut reference, threads, &|r, h| {
            for (ray, hit) in r.iter().zip(h.iter_mut()) {
                *hit = trace::trace_closest(bvh, &soup.positions, ray);
            }
        });
        wall.push(t.elapsed().as_secs_f64() * 1e3);
    }
    let hit_fraction = reference.iter().filter(|h| h.is_hit()).count() as f64 / count as f64;
    let row = Row {
        mesh: name.into(),
        tris: soup.triangle_count(),
        tracer: format!("CPU reference (Rust, stack, {threads} threads)"),
        device_ms: None,
        wall_ms: median(wall),
        hit_fraction,
        agree: 1.0,
    };
    (reference, row)
}

/// Embree 3's `rtcIntersect1` on the same rays, after one untimed run.
#[cfg(feature = "embree")]
fn embree_row(
    soup: &Soup,
    rays_host: &[Ray],
    reference: &[Hit],
    hit_fraction: f64,
    s: &Settings,
    name: &str,
) -> Row {
    let (runs, threads) = (s.runs, s.threads);
    let count = rays_host.len();
    let scene = trace::embree::EmbreeScene::new(&soup.positions, threads);
    let mut out = vec![Hit::miss(0.0); count];
    let mut wall = Vec::new();
    for run in 0..=runs {
        let t = Instant::now();
        parallel(rays_host, &mut out, threads, &|r, h| {
            scene.intersect(r, h, trace::embree::CONTEXT_INCOHERENT)
        });
        if run > 0 {
            wall.push(t.elapsed().as_secs_f64() * 1e3);
        }
    }
    Row {
        mesh: name.into(),
        tris: soup.triangle_count(),
        tracer: format!("Embree 3 rtcIntersect1 ({threads} threads)"),
        device_ms: None,
        wall_ms: median(wall),
        hit_fraction,
        agree: agreement(&out, reference),
    }
}

/// The throughput table and the layouts' host-cost table, in Markdown.
fn print_tables(rows: &[Row], escape_rows: Vec<LayoutRow>, size: u32) {
    println!();
    println!("| mesh | triangles | tracer | device ms | wall ms | Mrays/s (device) | Mrays/s (wall) | rays hitting | same triangle as CPU ref |");
    println!("|---|---:|---|---:|---:|---:|---:|---:|---:|");
    for r in rows {
        let count = (size * size) as f64;
        let (dms, dm) = match r.device_ms {
            Some(ms) => (format!("{ms:.2}"), format!("{:.2}", count / ms / 1e3)),
            None => ("-".into(), "-".into()),
        };
        println!(
            "| {} | {} | {} | {} | {:.2} | {} | {:.2} | {:.1}% | {:.3}% |",
            r.mesh,
            r.tris,
            r.tracer,
            dms,
            r.wall_ms,
            dm,
            count / r.wall_ms / 1e3,
            100.0 * r.hit_fraction,
            100.0 * r.agree
        );
    }
    println!();
    println!("| mesh | triangles | BVH nodes | escape-index layout (host ms, median) | 4-wide nodes | 4-wide collapse (host ms, median) |");
    println!("|---|---:|---:|---:|---:|---:|");
    for (name, n, nodes, ms, wide_nodes, wide_ms) in escape_rows {
        println!("| {name} | {n} | {nodes} | {ms:.2} | {wide_nodes} | {wide_ms:.2} |");
    }
}
