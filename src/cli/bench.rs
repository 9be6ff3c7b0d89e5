//! `soupray bench`: the speed/accuracy trade, measured. For a scene frame
//! it renders a high-spp reference, then sweeps the knobs users turn —
//! SAH bins (and the full sweep builder), leaf size, traversal, samples per
//! pixel with each sampler — and records for each point the build time, SAH cost, trace
//! throughput, total frame time and the error against the reference
//! (relative MSE and FLIP, from `compare`).
//!
//! Bins, leaf size and traversal change only how fast a frame is made, not
//! which triangle a ray hits (ties are broken by triangle index), so at a
//! given spp their images are identical and their points differ in time
//! alone; spp moves along the error axis, and the sampler (Sobol or
//! independent random numbers) moves the whole spp curve, as does
//! `--denoise` (the `denoise` sweep: 1, 4, 16, 64… spp denoised with Open
//! Image Denoise at quality high, its time in the frame time; run where
//! OIDN is installed, skipped with a note elsewhere), as does adaptive
//! sampling (the `threshold` sweep: `--noise-threshold` 0.2, 0.1, 0.05,
//! 0.025 and 0.0125 up to `--max-spp` samples, its points at their mean
//! spp). The reference is
//! rendered with another seed, so its samples are not the test renders'
//! own. The Pareto front of error against
//! frame time is what the defaults are chosen from.
//!
//! Writes `DIR/bench.csv`, `DIR/bench.png` (error against time, the front
//! drawn through) and prints a Markdown section for BENCHMARKS.md.

use crate::bvh::device_builder::DeviceBuilder;
use crate::bvh::{self, BuildParams, Bvh};
use crate::cli::report::median;
use crate::compare::{self, ImageError};
use crate::denoise::Denoiser;
use crate::device::Device;
use crate::film::{Aovs, Image};
use crate::pipeline::{denoise_beauty, replace_beauty, set_frame_materials};
use crate::scene::{LoadOptions, Scene};
use crate::soup::device::DeviceSoup;
use crate::trace::render::{
    Adaptive, Environment, FrameInput, Layering, PathTracer, RenderSettings, Traversal,
};
use crate::trace::sampling::Sampler;
use crate::UsageError;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Measure the speed/accuracy trade: bins, leaf size, traversal, spp with
/// each sampler, `--denoise` and `--noise-threshold` against a high-spp
/// reference, on one frame of each scene.
///
///   soupray bench                        # the shipped animation
///   soupray bench a.glb b.glb --frame 10 --reference-spp 4096
#[derive(clap::Args, Debug, Clone)]
#[command(verbatim_doc_comment)]
pub struct BenchArgs {
    /// glTF scenes or PLY meshes to measure (default: the shipped animation).
    #[arg(value_name = "SCENE")]
    pub scenes: Vec<PathBuf>,
    /// Frame to render (default: the middle of each scene's clip).
    #[arg(long, allow_negative_numbers = true, value_name = "N")]
    pub frame: Option<i64>,
    /// Image size: small, since the reference takes many samples.
    #[arg(long, default_value_t = 160, value_name = "PX")]
    pub width: u32,
    #[arg(long, default_value_t = 90, value_name = "PX")]
    pub height: u32,
    /// Samples per pixel of the reference image.
    #[arg(long, default_value_t = 4096, value_name = "N")]
    pub reference_spp: u32,
    /// Largest spp of the spp sweep (powers of two from 1).
    #[arg(long, default_value_t = 1024, value_name = "N")]
    pub max_spp: u32,
    /// Where bench.csv and bench.png go.
    #[arg(long, default_value = "out/bench", value_name = "DIR")]
    pub out: PathBuf,
    /// OpenCL device, by index or name substring.
    #[arg(long, value_name = "INDEX|NAME")]
    pub device: Option<String>,
    /// Timed renders per point (the median is kept).
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub repeat: u32,
    /// Leave out the `--denoise` sweep (it runs where Open Image Denoise
    /// is installed).
    #[arg(long)]
    pub no_denoise: bool,
}

/// One measured point.
#[derive(Clone, Debug, serde::Serialize)]
pub struct Point {
    pub scene: String,
    pub frame: i64,
    /// `bins` | `leaf` | `traversal` | `spp` | `sampler` | `denoise` |
    /// `threshold` | `default` (`sampler`: the spp sweep with `--sampler
    /// random`; `denoise`: spp with `--denoise`; `threshold`:
    /// `--noise-threshold` with `spp` as the most a pixel takes).
    pub sweep: &'static str,
    /// `device` or `cpu-sweep`.
    pub builder: &'static str,
    pub bins: u32,
    pub leaf_size: u32,
    pub traversal: &'static str,
    pub sampler: &'static str,
    pub spp: u32,
    /// `--noise-threshold` of the `threshold` sweep.
    pub noise_threshold: Option<f32>,
    /// Samples per pixel taken on average (`spp` but for adaptive points).
    pub spp_mean: f64,
    pub triangles: usize,
    pub build_ms: f64,
    pub sah_cost: f64,
    pub trace_ms: f64,
    pub mrays_per_s: f64,
    pub frame_ms: f64,
    pub rel_mse: f64,
    pub flip: f64,
}

/// A point of the sweep before it is rendered.
#[derive(Clone, Copy, Debug)]
struct Config {
    sweep: &'static str,
    sweep_builder: bool,
    params: BuildParams,
    traversal: Traversal,
    sampler: Sampler,
    spp: u32,
    /// Denoised with OIDN after tracing.
    denoise: bool,
    /// Adaptive sampling to this `--noise-threshold` (`spp` the maximum).
    threshold: Option<f32>,
}

/// The noise thresholds of the `threshold` sweep, halving from 0.2.
const THRESHOLDS: [f32; 5] = [0.2, 0.1, 0.05, 0.025, 0.0125];

/// The sweep: each knob varied alone around the defaults; `denoise` adds
/// the denoised spp sweep (1, 4, 16, … up to `max_spp`); the `threshold`
/// sweep renders to each of `THRESHOLDS` with `max_spp` the most a pixel
/// takes.
fn configs(max_spp: u32, denoise: bool) -> Vec<Config> {
    let base = Config {
        sweep: "default",
        sweep_builder: false,
        params: BuildParams::default(),
        traversal: Traversal::Wide8,
        sampler: Sampler::Sobol,
        spp: 16,
        denoise: false,
        threshold: None,
    };
    let mut out = vec![base];
    for bins in [4, 8, 32] {
        out.push(Config {
            sweep: "bins",
            params: BuildParams {
                bins,
                ..base.params
            },
            ..base
        });
    }
    out.push(Config {
        sweep: "bins",
        sweep_builder: true,
        ..base
    });
    for leaf_size in [1, 2, 8] {
        out.push(Config {
            sweep: "leaf",
            params: BuildParams {
                leaf_size,
                ..base.params
            },
            ..base
        });
    }
    for traversal in [Traversal::Wide, Traversal::Stack, Traversal::Stackless] {
        out.push(Config {
            sweep: "traversal",
            traversal,
            ..base
        });
    }
    let mut spp = 1;
    while spp <= max_spp {
        if spp != base.spp {
            out.push(Config {
                sweep: "spp",
                spp,
                ..base
            });
        }
        out.push(Config {
            sweep: "sampler",
            sampler: Sampler::Random,
            spp,
            ..base
        });
        spp *= 2;
    }
    let mut spp = 1;
    while denoise && spp <= max_spp {
        out.push(Config {
            sweep: "denoise",
            spp,
            denoise: true,
            ..base
        });
        spp *= 4;
    }
    for threshold in THRESHOLDS {
        out.push(Config {
            sweep: "threshold",
            spp: max_spp,
            threshold: Some(threshold),
            ..base
        });
    }
    out
}

/// The seed of the test renders; the reference uses another.
const SEED: u64 = 0;
const REFERENCE_SEED: u64 = 0x5EED_F00D;

fn settings(args: &BenchArgs, spp: u32, c: &Config) -> RenderSettings {
    RenderSettings {
        width: args.width,
        height: args.height,
        spp,
        seed: SEED,
        max_depth: 8,
        clay: false,
        traversal: c.traversal,
        sampler: c.sampler,
        noise_pattern: Default::default(),
        adaptive: c.threshold.map(|threshold| Adaptive {
            threshold,
            // The render command's default.
            min_spp: 16.min(spp),
            allocation: Default::default(),
        }),
        time_limit: None,
        environment: Environment::Default,
        // The denoiser's auxiliary images.
        aovs: Aovs {
            normal: c.denoise,
            albedo: c.denoise,
            ..Aovs::default()
        },
        energy_compensation: true,
        layering: Layering::Energy,
        backface_culling: false,
        ..RenderSettings::default()
    }
}

/// A tree and the primitive-index buffer the tracer reads with it.
struct Tree {
    bvh: Bvh,
    prim_ids: opencl3::memory::Buffer<u32>,
    build_ms: f64,
}

fn build_tree(
    device: &Device,
    soup: &DeviceSoup,
    host_soup: &crate::soup::Soup,
    c: &Config,
) -> anyhow::Result<Tree> {
    let n = soup.triangle_count();
    let mut prim_ids = device.buffer::<u32>(n)?;
    if c.sweep_builder {
        let t = Instant::now();
        let bvh = bvh::sweep::build(host_soup, c.params);
        let build_ms = t.elapsed().as_secs_f64() * 1e3;
        device.write(&mut prim_ids, &bvh.prim_ids)?;
        return Ok(Tree {
            bvh,
            prim_ids,
            build_ms,
        });
    }
    let mut builder = DeviceBuilder::new(device, c.params)?;
    builder.build_from_device(soup.positions(), n)?; // warm-up
    let mut times = Vec::new();
    let mut bvh = None;
    for _ in 0..3 {
        let (b, stats) = builder.build_from_device(soup.positions(), n)?;
        times.push(stats.build_ms);
        bvh = Some(b);
    }
    let bvh = bvh.expect("built");
    device.write(&mut prim_ids, &bvh.prim_ids)?;
    Ok(Tree {
        bvh,
        prim_ids,
        build_ms: median(times),
    })
}

fn bench_scene(
    args: &BenchArgs,
    device: &Device,
    denoiser: Option<&Denoiser>,
    path: &Path,
) -> anyhow::Result<Vec<Point>> {
    let tmp = std::env::temp_dir().join(format!("soupray-bench-{}", std::process::id()));
    let is_ply = path
        .extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("ply"));
    let gltf = if is_ply {
        std::fs::create_dir_all(&tmp)?;
        ply_as_gltf(path, &tmp)?
    } else {
        path.to_path_buf()
    };
    let result = bench_gltf(args, device, denoiser, &gltf, path);
    if is_ply {
        let _ = std::fs::remove_dir_all(&tmp);
    }
    result
}

fn bench_gltf(
    args: &BenchArgs,
    device: &Device,
    denoiser: Option<&Denoiser>,
    path: &Path,
    named: &Path,
) -> anyhow::Result<Vec<Point>> {
    let scene = Scene::load(path, &LoadOptions::default())?;
    let (first, last) = scene.frame_range();
    let frame = args.frame.unwrap_or((first + last) / 2);
    let time = scene.time_of_frame(frame);
    let mut soup = DeviceSoup::new(device, &scene)?;
    let t = Instant::now();
    let info = soup.evaluate(&scene, time)?;
    let evaluate_ms = t.elapsed().as_secs_f64() * 1e3;
    let host_soup = soup.read_back()?;
    let name = named
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    let render = |tree: &Tree, s: &RenderSettings| -> anyhow::Result<(Image, f64, f64, u64, f64)> {
        let mut tracer = PathTracer::new(device, &scene, s)?;
        set_frame_materials(&mut tracer, &scene, time)?;
        let input = FrameInput {
            frame,
            soup: &soup,
            bvh: &tree.bvh,
            prim_ids: &tree.prim_ids,
            camera: &info.camera,
            lights: &info.lights,
        };
        let mut walls = Vec::new();
        let mut traces = Vec::new();
        let mut last = None;
        for _ in 0..args.repeat.max(1) {
            let t = Instant::now();
            let mut out = tracer.render(&input, &mut |_| {})?;
            // The denoised sweep's points: settings with the denoiser's
            // albedo and normal (render's --denoise step).
            if let Some(d) = denoiser.filter(|_| s.aovs.albedo) {
                let (rgb, _) = denoise_beauty(d, &out.image)?;
                replace_beauty(&mut out.image, &rgb);
            }
            walls.push(t.elapsed().as_secs_f64() * 1e3);
            traces.push(out.trace_ms);
            last = Some(out);
        }
        let out = last.expect("rendered");
        let spp_mean = out.noise.spp_mean;
        Ok((out.image, median(walls), median(traces), out.rays, spp_mean))
    };
    eprintln!("bench {name}: reference at {} spp", args.reference_spp);
    let default_tree = build_tree(device, &soup, &host_soup, &configs(1, false)[0])?;
    let reference = {
        let mut tracer = PathTracer::new(
            device,
            &scene,
            &RenderSettings {
                seed: REFERENCE_SEED,
                ..settings(args, args.reference_spp, &configs(1, false)[0])
            },
        )?;
        set_frame_materials(&mut tracer, &scene, time)?;
        let input = FrameInput {
            frame,
            soup: &soup,
            bvh: &default_tree.bvh,
            prim_ids: &default_tree.prim_ids,
            camera: &info.camera,
            lights: &info.lights,
        };
        tracer.render(&input, &mut |_| {})?.image
    };
    let mut points = Vec::new();
    for c in configs(args.max_spp, denoiser.is_some()) {
        eprintln!(
            "bench {name}: {} bins={} leaf={} traversal={:?} sampler={} spp={}{}",
            c.sweep,
            c.params.bins,
            c.params.leaf_size,
            c.traversal,
            c.sampler.name(),
            c.spp,
            c.threshold
                .map_or(String::new(), |t| format!(" noise-threshold={t}"))
        );
        let tree = build_tree(device, &soup, &host_soup, &c)?;
        let (image, wall_ms, trace_ms, rays, spp_mean) = render(&tree, &settings(args, c.spp, &c))?;
        let ImageError { rel_mse, flip } = compare::compare(&image, &reference, 0.0)?;
        points.push(Point {
            scene: name.clone(),
            frame,
            sweep: c.sweep,
            builder: if c.sweep_builder {
                "cpu-sweep"
            } else {
                "device"
            },
            bins: c.params.bins,
            leaf_size: c.params.leaf_size,
            traversal: c.traversal.name(),
            sampler: c.sampler.name(),
            spp: c.spp,
            noise_threshold: c.threshold,
            spp_mean,
            triangles: soup.triangle_count(),
            build_ms: tree.build_ms,
            sah_cost: bvh::sah_cost(&tree.bvh),
            trace_ms,
            mrays_per_s: rays as f64 / (trace_ms.max(1e-9) * 1e3),
            frame_ms: evaluate_ms + tree.build_ms + wall_ms,
            rel_mse,
            flip,
        });
    }
    Ok(points)
}

/// The points no other point of the same scene beats in both frame time
/// and FLIP.
pub fn pareto_front(points: &[Point]) -> Vec<usize> {
    let mut front: Vec<usize> = (0..points.len())
        .filter(|&i| {
            !points.iter().enumerate().any(|(j, q)| {
                j != i
                    && q.scene == points[i].scene
                    && q.frame_ms <= points[i].frame_ms
                    && q.flip <= points[i].flip
                    && (q.frame_ms < points[i].frame_ms || q.flip < points[i].flip)
            })
        })
        .collect();
    front.sort_by(|&a, &b| {
        (points[a].scene.as_str(), points[a].frame_ms)
            .partial_cmp(&(points[b].scene.as_str(), points[b].frame_ms))
            .unwrap_or(std::cmp::Ordering::Equal)
    });
    front
}

/// A PLY mesh as a minimal glTF (one unindexed mesh, a diffuse grey
/// material, no camera: the default camera frames it), so real scanned
/// meshes go through exactly the pipeline a glTF frame does.
fn ply_as_gltf(ply: &Path, dir: &Path) -> anyhow::Result<PathBuf> {
    let soup = crate::ply::read_soup(ply)?;
    let (lo, hi) = soup
        .bounds()
        .ok_or_else(|| anyhow::anyhow!("{}: the mesh has no triangles", ply.display()))?;
    let bytes: Vec<u8> = soup
        .positions
        .iter()
        .flat_map(|p| p[..3].iter().flat_map(|c| c.to_le_bytes()))
        .collect();
    let stem = ply
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    std::fs::write(dir.join(format!("{stem}.bin")), &bytes)?;
    let json = serde_json::json!({
        "asset": {"version": "2.0", "generator": "soupray bench (from PLY)"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "buffers": [{"byteLength": bytes.len(), "uri": format!("{stem}.bin")}],
        "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": bytes.len()}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": soup.positions.len(), "type": "VEC3", "min": lo, "max": hi}],
    });
    let path = dir.join(format!("{stem}.gltf"));
    std::fs::write(&path, serde_json::to_vec_pretty(&json)?)?;
    Ok(path)
}

fn csv(points: &[Point]) -> String {
    let mut s = String::from(
        "scene,frame,sweep,builder,bins,leaf_size,traversal,sampler,spp,noise_threshold,spp_mean,triangles,build_ms,sah_cost,trace_ms,mrays_per_s,frame_ms,rel_mse,flip,pareto\n",
    );
    let front = pareto_front(points);
    for (i, p) in points.iter().enumerate() {
        s.push_str(&format!(
            "{},{},{},{},{},{},{},{},{},{},{:.3},{},{:.3},{:.4},{:.3},{:.3},{:.3},{:.6e},{:.6},{}\n",
            p.scene,
            p.frame,
            p.sweep,
            p.builder,
            p.bins,
            p.leaf_size,
            p.traversal,
            p.sampler,
            p.spp,
            p.noise_threshold.map_or(String::new(), |t| t.to_string()),
            p.spp_mean,
            p.triangles,
            p.build_ms,
            p.sah_cost,
            p.trace_ms,
            p.mrays_per_s,
            p.frame_ms,
            p.rel_mse,
            p.flip,
            front.contains(&i)
        ));
    }
    s
}

fn markdown(points: &[Point]) -> String {
    let front = pareto_front(points);
    let mut s = String::from(
        "| scene | sweep | builder | bins | leaf | traversal | sampler | spp | threshold | mean spp | build ms | SAH | trace Mrays/s | frame ms | rel. MSE | FLIP | Pareto |\n\
         |---|---|---|---:|---:|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---|\n",
    );
    for (i, p) in points.iter().enumerate() {
        s.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} | {} | {:.1} | {:.2} | {:.2} | {:.2} | {:.1} | {:.2e} | {:.4} | {} |\n",
            p.scene,
            p.sweep,
            p.builder,
            p.bins,
            p.leaf_size,
            p.traversal,
            p.sampler,
            p.spp,
            p.noise_threshold.map_or(String::new(), |t| t.to_string()),
            p.spp_mean,
            p.build_ms,
            p.sah_cost,
            p.mrays_per_s,
            p.frame_ms,
            p.rel_mse,
            p.flip,
            if front.contains(&i) { "yes" } else { "" }
        ));
    }
    s
}

/// FLIP against frame time, log-log, one colour per sweep, the front drawn.
fn chart(points: &[Point]) -> anyhow::Result<Vec<u8>> {
    use crate::cli::report::{format_axis, plot_err, register_font};
    use plotters::prelude::*;
    register_font()?;
    let (w, h) = (1200u32, 800u32);
    let mut buf = vec![0u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(plot_err)?;
        let finite = |v: f64| v.is_finite() && v > 0.0;
        let xs: Vec<f64> = points
            .iter()
            .map(|p| p.frame_ms)
            .filter(|&v| finite(v))
            .collect();
        let ys: Vec<f64> = points
            .iter()
            .map(|p| p.flip)
            .filter(|&v| finite(v))
            .collect();
        let range = |v: &[f64]| {
            let lo = v.iter().copied().fold(f64::MAX, f64::min);
            let hi = v.iter().copied().fold(f64::MIN, f64::max);
            if lo < hi {
                (lo * 0.8)..(hi * 1.25)
            } else {
                (lo.max(1e-6) * 0.5)..(lo.max(1e-6) * 2.0)
            }
        };
        let mut chart = ChartBuilder::on(&root)
            .caption(
                "error against frame time (FLIP vs ms, log-log)",
                ("sans-serif", 22),
            )
            .margin(16)
            .x_label_area_size(44)
            .y_label_area_size(80)
            .build_cartesian_2d(range(&xs).log_scale(), range(&ys).log_scale())
            .map_err(plot_err)?;
        chart
            .configure_mesh()
            .x_desc("frame ms (evaluate + build + trace, + denoise)")
            .y_desc("mean FLIP against the reference")
            .x_label_formatter(&|x| format_axis(*x))
            .y_label_formatter(&|y| format!("{y:.4}"))
            .y_labels(8)
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(plot_err)?;
        let colours = [
            ("spp", BLUE),
            ("bins", RED),
            ("leaf", RGBColor(0, 140, 0)),
            ("traversal", MAGENTA),
            ("sampler", RGBColor(230, 140, 0)),
            ("denoise", RGBColor(0, 170, 170)),
            ("threshold", RGBColor(150, 80, 200)),
            ("default", BLACK),
        ];
        for (sweep, colour) in colours {
            let pts: Vec<(f64, f64)> = points
                .iter()
                .filter(|p| p.sweep == sweep && finite(p.frame_ms) && finite(p.flip))
                .map(|p| (p.frame_ms, p.flip))
                .collect();
            if pts.is_empty() {
                continue;
            }
            chart
                .draw_series(pts.iter().map(|&p| Circle::new(p, 5, colour.filled())))
                .map_err(plot_err)?
                .label(sweep)
                .legend(move |(x, y)| Circle::new((x + 8, y), 5, colour.filled()));
        }
        // One front per scene: points of different scenes do not compete.
        let front = pareto_front(points);
        let mut scenes: Vec<&str> = front.iter().map(|&i| points[i].scene.as_str()).collect();
        scenes.dedup();
        for (k, scene) in scenes.iter().enumerate() {
            let line: Vec<(f64, f64)> = front
                .iter()
                .filter(|&&i| points[i].scene == *scene)
                .map(|&i| (points[i].frame_ms, points[i].flip))
                .filter(|&(x, y)| finite(x) && finite(y))
                .collect();
            let series = chart
                .draw_series(LineSeries::new(line, BLACK.mix(0.5).stroke_width(2)))
                .map_err(plot_err)?;
            if k == 0 {
                series.label("Pareto front (per scene)").legend(|(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], BLACK.stroke_width(2))
                });
            }
        }
        chart
            .configure_series_labels()
            .position(SeriesLabelPosition::UpperRight)
            .label_font(("sans-serif", 14))
            .background_style(WHITE.mix(0.85))
            .border_style(BLACK)
            .draw()
            .map_err(plot_err)?;
        root.present().map_err(plot_err)?;
    }
    Ok(buf)
}

pub fn run_bench(args: &BenchArgs) -> anyhow::Result<()> {
    if args.reference_spp < args.max_spp.saturating_mul(4) {
        return Err(UsageError(format!(
            "--reference-spp {} must be at least 4x --max-spp {}, or the reference's own noise \
             dominates the error it measures",
            args.reference_spp, args.max_spp
        ))
        .into());
    }
    let scenes = if args.scenes.is_empty() {
        vec![PathBuf::from(crate::cli::render::DEFAULT_SCENE)]
    } else {
        args.scenes.clone()
    };
    crate::cli::frames::check_output_dir(&args.out)?;
    let device = Device::open(args.device.as_deref())?;
    let denoiser = if args.no_denoise {
        None
    } else {
        match Denoiser::open(crate::denoise::Quality::High) {
            Ok(d) => Some(d),
            Err(e) => {
                eprintln!("bench: no --denoise sweep: {e}");
                None
            }
        }
    };
    let mut points = Vec::new();
    for path in &scenes {
        points.extend(bench_scene(args, &device, denoiser.as_ref(), path)?);
    }
    crate::output::write_atomic(&args.out.join("bench.csv"), |out| {
        use std::io::Write as _;
        out.write_all(csv(&points).as_bytes())
            .map_err(|e| crate::output::OutputError::Io {
                path: args.out.join("bench.csv"),
                action: "write",
                source: e,
            })
    })?;
    let pixels = chart(&points)?;
    crate::cli::report::write_rgb_png(&args.out.join("bench.png"), &pixels, 1200, 800)?;
    println!(
        "## Speed against accuracy (`soupray bench`)\n\nDevice: {}. Image {}x{}, reference {} spp. \
         Written: {}, {}.\n\n{}",
        device.info.name,
        args.width,
        args.height,
        args.reference_spp,
        args.out.join("bench.csv").display(),
        args.out.join("bench.png").display(),
        markdown(&points)
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_denoise_sweep_runs_only_with_a_denoiser() {
        let with = configs(64, true);
        let denoised: Vec<u32> = with.iter().filter(|c| c.denoise).map(|c| c.spp).collect();
        assert_eq!(denoised, [1, 4, 16, 64]);
        assert!(with.iter().all(|c| c.denoise == (c.sweep == "denoise")));
        assert!(!configs(64, false).iter().any(|c| c.denoise));
        assert_eq!(
            configs(64, false).len() + 4,
            with.len(),
            "the other sweeps are unchanged"
        );
    }

    #[test]
    fn the_threshold_sweep_samples_adaptively_up_to_max_spp() {
        let all = configs(256, false);
        let adaptive: Vec<&Config> = all.iter().filter(|c| c.threshold.is_some()).collect();
        assert_eq!(adaptive.len(), THRESHOLDS.len());
        assert!(adaptive
            .iter()
            .all(|c| c.sweep == "threshold" && c.spp == 256 && !c.denoise));
        let args = BenchArgs {
            scenes: vec![],
            frame: None,
            width: 8,
            height: 8,
            reference_spp: 64,
            max_spp: 256,
            out: PathBuf::new(),
            device: None,
            repeat: 1,
            no_denoise: true,
        };
        let s = settings(&args, 256, adaptive[2]);
        let a = s.adaptive.expect("adaptive settings");
        assert_eq!((a.threshold, a.min_spp, s.spp), (0.05, 16, 256));
        assert!(settings(&args, 16, &all[0]).adaptive.is_none());
    }
}
