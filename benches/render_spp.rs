//! Path tracing throughput on sample models from the shared folder: for each scene, a
//! few frames spread over its clip are evaluated (device soup), built
//! (device BVH) and path traced at 640x360 with 16 spp; the table gives
//! the medians of path-traced samples per second and Mrays/s (over device
//! time of the path tracing launches), the trace time per frame, rays per
//! sample and the wall time of `render`.
//!
//!   cargo bench --bench render_spp
//!   cargo bench --bench render_spp -- --frames 5 --spp 16 --size 640x360 --max-depth 8

mod support;

use soupray::bvh::device_builder::DeviceBuilder;
use soupray::bvh::BuildParams;
use soupray::cli::report::median;
use soupray::device::Device;
use soupray::scene::{LoadOptions, Scene};
use soupray::soup::device::DeviceSoup;
use soupray::trace::render::{FrameInput, PathTracer, RenderSettings};
use std::path::Path;
use std::time::Instant;

/// Sample models, read in place from the shared folder.
const SCENES: &[&str] = &[
    "BoxAnimated/BoxAnimated.glb",
    "CesiumMan/CesiumMan.gltf",
    "Fox/Fox.glb",
];

fn arg<T: std::str::FromStr>(args: &[String], name: &str, default: T) -> T {
    args.iter()
        .position(|a| a == name)
        .and_then(|i| args.get(i + 1))
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let frames: i64 = arg(&args, "--frames", 5);
    let spp: u32 = arg(&args, "--spp", 16);
    let max_depth: u32 = arg(&args, "--max-depth", 8);
    let size: String = arg(&args, "--size", "640x360".to_owned());
    let (width, height) = size
        .split_once('x')
        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)))
        .unwrap_or((640, 360));
    let device = Device::open(None).expect("an OpenCL device");
    println!(
        "device: {} ({}), {width}x{height}, {spp} spp, max depth {max_depth}, median of {frames} frames\n",
        device.info.name, device.info.platform
    );
    println!("| scene | triangles | textures | samples/s | Mrays/s | trace ms | rays/sample | render wall ms |");
    println!("|---|---:|---|---:|---:|---:|---:|---:|");
    // The shared folder: SOUPRAY_SHARED, or ../shared beside the checkout
    // (or beside SOUPRAY_TEST_ROOT, scripts/gpu-check.sh's bundle).
    for rel in SCENES {
        let path = match support::sample(rel) {
            Ok(path) => path,
            Err(e) => {
                println!("| {rel} | skipped: {e} |");
                continue;
            }
        };
        let scene = match Scene::load(&path, &LoadOptions::default()) {
            Ok(s) => s,
            Err(e) => {
                println!("| {rel} | skipped: {e} |");
                continue;
            }
        };
        let mut soup = DeviceSoup::new(&device, &scene).expect("device soup");
        let mut builder = DeviceBuilder::new(&device, BuildParams::default()).expect("builder");
        let settings = RenderSettings {
            width,
            height,
            spp,
            max_depth,
            ..RenderSettings::default()
        };
        let mut pt = PathTracer::new(&device, &scene, &settings).expect("path tracer");
        let (first, last) = scene.frame_range();
        let (mut sps, mut mrays, mut ms, mut rps, mut wall) =
            (vec![], vec![], vec![], vec![], vec![]);
        let mut warnings = Vec::new();
        for k in 0..frames {
            let frame = first + (last - first) * k / (frames - 1).max(1);
            let info = soup
                .evaluate(&scene, scene.time_of_frame(frame))
                .expect("frame");
            let (bvh, _) = builder
                .build_from_device(soup.positions(), soup.triangle_count())
                .expect("build");
            let start = Instant::now();
            let out = pt
                .render(
                    &FrameInput {
                        frame,
                        soup: &soup,
                        bvh: &bvh,
                        prim_ids: builder.device_prim_ids().expect("ids"),
                        camera: &info.camera,
                        lights: &info.lights,
                    },
                    &mut |_| {},
                )
                .expect("render");
            wall.push(start.elapsed().as_secs_f64() * 1e3);
            let samples = width as f64 * height as f64 * spp as f64;
            sps.push(samples / (out.trace_ms * 1e-3));
            mrays.push(out.mrays_per_s());
            ms.push(out.trace_ms);
            rps.push(out.rays as f64 / samples);
            warnings = out.warnings;
        }
        let name = Path::new(rel)
            .file_stem()
            .unwrap()
            .to_string_lossy()
            .into_owned();
        println!(
            "| {name} | {} | {} | {:.3e} | {:.2} | {:.1} | {:.2} | {:.1} |",
            soup.triangle_count(),
            if pt.has_textures() { "yes" } else { "no" },
            median(sps.clone()),
            median(mrays.clone()),
            median(ms.clone()),
            median(rps.clone()),
            median(wall.clone())
        );
        for w in warnings {
            eprintln!("  {name}: {w}");
        }
    }
}
