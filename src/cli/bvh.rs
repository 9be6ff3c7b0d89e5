//! The builder's commands: `soupray devices` lists the OpenCL devices, and
//! `soupray bvh` builds one tree and prints its measurements.
//!
//! `bvh --json` prints one JSON object (documented in `BvhReport`), so
//! scripts and benchmarks can read a build without parsing prose.

use crate::bvh::device_builder::{DeviceBuilder, StageTimes};
use crate::bvh::{self, binned, sweep, BuildParams};
use crate::cli::report::median;
use crate::device::{list_devices, Device};
use crate::scene::{LoadOptions, Scene};
use crate::soup::device::DeviceSoup;
use crate::soup::Soup;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// List the OpenCL devices soupray can use, with the index `--device` takes.
#[derive(clap::Args, Debug, Clone)]
pub struct DevicesArgs {
    /// Print the list as JSON.
    #[arg(long)]
    pub json: bool,
}

#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum BuilderKind {
    /// The paper's binned-SAH builder on the OpenCL device (what `render` uses).
    Device,
    /// The same algorithm in plain Rust on one CPU thread (its test reference).
    CpuBinned,
    /// Full-sweep SAH on one CPU thread: slower, the quality reference.
    CpuSweep,
}

impl BuilderKind {
    pub fn name(self) -> &'static str {
        match self {
            BuilderKind::Device => "device",
            BuilderKind::CpuBinned => "cpu-binned",
            BuilderKind::CpuSweep => "cpu-sweep",
        }
    }
}

/// Build one BVH from a triangle soup and report its size, quality and cost.
///
/// INPUT is a PLY triangle mesh (ASCII or binary), or a glTF scene (.gltf or
/// .glb) evaluated at --frame. Example:
///
///   soupray bvh mesh.ply --json
///   soupray bvh walk.glb --frame 12 --bins 8 --leaf 2
#[derive(clap::Args, Debug, Clone)]
#[command(verbatim_doc_comment)]
pub struct BvhArgs {
    /// A .ply triangle mesh, or a .gltf/.glb scene.
    #[arg(value_name = "INPUT")]
    pub input: PathBuf,
    /// Print one JSON object instead of text.
    #[arg(long)]
    pub json: bool,
    /// Which builder makes the tree.
    #[arg(long, value_enum, default_value_t = BuilderKind::Device)]
    pub builder: BuilderKind,
    /// SAH bins per axis: a power of two from 2 to 64.
    #[arg(long, default_value_t = 16, value_name = "N")]
    pub bins: u32,
    /// Largest leaf, in triangles (1 to 64).
    #[arg(long = "leaf", default_value_t = 4, value_name = "N")]
    pub leaf_size: u32,
    /// Frame to evaluate when INPUT is a glTF scene (time = N / fps).
    #[arg(
        long,
        default_value_t = 0,
        allow_negative_numbers = true,
        value_name = "N"
    )]
    pub frame: i64,
    /// Frames per second of the animation, for --frame.
    #[arg(long, default_value_t = 24.0, value_name = "FPS")]
    pub fps: f64,
    /// Animation to play (glTF), by name or index.
    #[arg(long, value_name = "NAME|INDEX")]
    pub animation: Option<String>,
    /// Scene of the glTF file to use (index).
    #[arg(long, value_name = "N")]
    pub scene: Option<usize>,
    /// OpenCL device, by index or name substring (see `soupray devices`).
    #[arg(long, value_name = "INDEX|NAME")]
    pub device: Option<String>,
    /// Builds to run; with more than one, times are the median (the tree is
    /// the same every time).
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub repeat: u32,
    /// Build N copies of a PLY INPUT on a grid instead (the build
    /// benchmark's crowded arrangement: `--copies 10` and `--copies 25` of
    /// ../shared/meshes/nefertiti.ply are its 1M and 2.5M soups).
    #[arg(long, default_value_t = 1, value_name = "N")]
    pub copies: usize,
    /// Also print each kernel's device time (of the last build) on stderr.
    #[arg(long, short)]
    pub verbose: bool,
}

/// What `soupray bvh --json` prints. `nodes` counts inner nodes and leaves;
/// `max_depth` is the deepest leaf (root = 0); `sah_cost` is
/// `bvh::sah_cost` (K_T = K_I = 1, normalised by the root box's area);
/// `valid` is whether `bvh::validate` passed (`invalid_reason` says why not);
/// `build_ms` is wall-clock; `stages_ms` is device kernel time per stage
/// from profiling events (zero for CPU builders).
#[derive(serde::Serialize, Debug)]
pub struct BvhReport {
    pub input: String,
    pub builder: &'static str,
    pub device: Option<String>,
    /// The device builder's thread mapping (`Paper` or `SingleLane`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mapping: Option<bvh::device_builder::Mapping>,
    pub bins: u32,
    pub leaf_size: u32,
    pub triangles: usize,
    pub nodes: usize,
    pub leaves: usize,
    pub max_depth: u32,
    pub sah_cost: f64,
    pub valid: bool,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub invalid_reason: Option<String>,
    pub build_ms: f64,
    pub stages_ms: StagesMs,
    pub mtris_per_s: f64,
}

/// The build's device time per stage, and the host's task generation.
#[derive(serde::Serialize, Debug, Default)]
pub struct StagesMs {
    #[serde(flatten)]
    pub device: StageTimes,
    pub host: f64,
}

pub fn run_devices(args: &DevicesArgs) -> anyhow::Result<()> {
    let devices = list_devices()?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&devices)?);
        return Ok(());
    }
    let default = devices.iter().position(|d| d.kind == "GPU").unwrap_or(0);
    for d in &devices {
        println!(
            "{} {}: {} [{}] {} compute units, {} MiB, {} KiB local, {} ({}, driver {})",
            if d.index == default { "*" } else { " " },
            d.index,
            d.name,
            d.kind,
            d.compute_units,
            d.global_mem_mib,
            d.local_mem_kib,
            d.version,
            d.platform,
            d.driver,
        );
    }
    println!("\n* the default; choose another with --device INDEX or --device NAME-SUBSTRING");
    Ok(())
}

/// Reads INPUT into a soup: PLY directly, glTF evaluated at a frame on the
/// CPU. The kind comes from the extension, else from the first bytes.
pub fn load_soup(args: &BvhArgs) -> anyhow::Result<Soup> {
    if input_kind(&args.input)? == "gltf" {
        let (scene, time) = load_scene(args)?;
        return Ok(scene.evaluate(time)?.soup);
    }
    let soup = crate::ply::read_soup(&args.input)?;
    Ok(match args.copies {
        0 | 1 => soup,
        n => soup.arrangement(n),
    })
}

/// "ply" or "gltf" from a file's first bytes; anything else is an input
/// error (exit 4), as is a path that is not a regular file.
fn sniff(path: &Path) -> Result<&'static str, crate::input::InputError> {
    use std::io::Read as _;
    let fail = |detail: String| crate::input::InputError {
        path: path.to_path_buf(),
        detail,
    };
    let (file, _) =
        crate::input::open_regular(path).map_err(|e| fail(format!("cannot read it: {e}")))?;
    let mut head = Vec::new();
    file.take(4)
        .read_to_end(&mut head)
        .map_err(|e| fail(format!("cannot read it: {e}")))?;
    if head.starts_with(b"ply") {
        Ok("ply")
    } else if head.starts_with(b"glTF") || head.first() == Some(&b'{') {
        Ok("gltf")
    } else {
        Err(fail(
            "unknown input type (no .ply, .gltf or .glb extension, and the content is neither); \
             soupray bvh reads .ply triangle meshes and .gltf/.glb scenes"
                .into(),
        ))
    }
}

/// "gltf" or "ply": from the extension, else from the first bytes.
fn input_kind(p: &Path) -> Result<&'static str, crate::input::InputError> {
    match extension(p).as_str() {
        "gltf" | "glb" => Ok("gltf"),
        "ply" => Ok("ply"),
        _ => sniff(p),
    }
}

/// The glTF scene of INPUT and the time of --frame.
fn load_scene(args: &BvhArgs) -> anyhow::Result<(Scene, f64)> {
    let opts = LoadOptions {
        scene: args.scene,
        animation: args.animation.clone(),
        fps: args.fps,
        ..LoadOptions::default()
    };
    let scene = Scene::load(&args.input, &opts)?;
    let time = scene.time_of_frame(args.frame);
    Ok((scene, time))
}

fn extension(p: &Path) -> String {
    p.extension()
        .map(|e| e.to_string_lossy().to_lowercase())
        .unwrap_or_default()
}

pub fn run_bvh(args: &BvhArgs) -> anyhow::Result<()> {
    let params = BuildParams {
        bins: args.bins,
        leaf_size: args.leaf_size,
    };
    params.check().map_err(crate::UsageError)?;
    if args.copies == 0 || (args.copies > 1 && extension(&args.input) != "ply") {
        return Err(crate::UsageError(format!(
            "--copies {}: use 1 or more copies, of a .ply INPUT",
            args.copies
        ))
        .into());
    }
    let repeat = args.repeat.max(1);
    let mut times = Vec::new();
    let mut stages = Vec::new();
    let mut device_name = None;
    let mut mapping = None;
    let (soup, tree) = match args.builder {
        BuilderKind::Device => {
            let device = Device::open(args.device.as_deref())?;
            device_name = Some(device.info.name.clone());
            let mut builder = DeviceBuilder::new(&device, params)?;
            mapping = Some(builder.mapping());
            // A glTF frame is evaluated on the device straight into the
            // builder's input, as `render` does; a PLY is uploaded.
            let mut device_soup = None;
            let soup = if input_kind(&args.input)? == "gltf" {
                let (scene, time) = load_scene(args)?;
                let mut ds = DeviceSoup::new(&device, &scene)?;
                ds.evaluate(&scene, time)?;
                let soup = ds.read_back()?;
                device_soup = Some(ds);
                soup
            } else {
                load_soup(args)?
            };
            let mut tree = None;
            for _ in 0..repeat {
                let (t, s) = match &device_soup {
                    Some(ds) => builder.build_from_device(ds.positions(), ds.triangle_count())?,
                    None => builder.build(&soup)?,
                };
                times.push(s.build_ms);
                stages.push(s);
                tree = Some(t);
            }
            (soup, tree.expect("at least one build"))
        }
        kind => {
            let soup = load_soup(args)?;
            let mut tree = None;
            for _ in 0..repeat {
                let start = Instant::now();
                let t = match kind {
                    BuilderKind::CpuBinned => binned::build(&soup, params)?,
                    _ => sweep::build(&soup, params),
                };
                times.push(start.elapsed().as_secs_f64() * 1e3);
                tree = Some(t);
            }
            (soup, tree.expect("at least one build"))
        }
    };
    let build_ms = median(times);
    let stage = |f: fn(&bvh::device_builder::BuildStats) -> f64| {
        if stages.is_empty() {
            0.0
        } else {
            median(stages.iter().map(f).collect())
        }
    };
    let stages_ms = StagesMs {
        device: StageTimes {
            prepare: stage(|s| s.stages_ms.prepare),
            large: stage(|s| s.stages_ms.large),
            medium: stage(|s| s.stages_ms.medium),
            small: stage(|s| s.stages_ms.small),
        },
        host: stage(|s| s.host_ms),
    };
    let validation = bvh::validate(&tree, &soup, params.leaf_size);
    let shape = validation.clone().unwrap_or_default();
    let report = BvhReport {
        input: args.input.display().to_string(),
        builder: args.builder.name(),
        device: device_name,
        mapping,
        bins: params.bins,
        leaf_size: params.leaf_size,
        triangles: soup.triangle_count(),
        nodes: shape.nodes,
        leaves: shape.leaves,
        max_depth: shape.max_depth,
        sah_cost: bvh::sah_cost(&tree),
        valid: validation.is_ok(),
        invalid_reason: validation.err(),
        build_ms,
        stages_ms,
        mtris_per_s: soup.triangle_count() as f64 / (build_ms * 1e3).max(1e-9),
    };
    if args.verbose {
        if let Some(last) = stages.last() {
            for (kernel, ms) in &last.kernels_ms {
                eprintln!("  {kernel:<32} {ms:8.2} ms");
            }
        }
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&report)?);
    } else {
        print_report(&report);
    }
    if let Some(reason) = &report.invalid_reason {
        anyhow::bail!("the tree failed validation: {reason}");
    }
    Ok(())
}

fn print_report(r: &BvhReport) {
    println!("input      {}", r.input);
    println!(
        "builder    {}{}{} (bins {}, leaf {})",
        r.builder,
        r.device
            .as_deref()
            .map(|d| format!(" on {d}"))
            .unwrap_or_default(),
        r.mapping
            .map(|m| format!(", {m:?} mapping"))
            .unwrap_or_default(),
        r.bins,
        r.leaf_size
    );
    println!("triangles  {}", r.triangles);
    println!(
        "nodes      {} ({} leaves), max depth {}",
        r.nodes, r.leaves, r.max_depth
    );
    println!("SAH cost   {:.3}", r.sah_cost);
    println!("valid      {}", if r.valid { "yes" } else { "NO" });
    println!(
        "build      {:.2} ms ({:.2} Mtris/s)",
        r.build_ms, r.mtris_per_s
    );
    if r.builder == "device" {
        let s = &r.stages_ms;
        println!(
            "stages     prepare {:.2} ms, large {:.2} ms, medium {:.2} ms, small {:.2} ms (device); host {:.2} ms",
            s.device.prepare, s.device.large, s.device.medium, s.device.small, s.host
        );
    }
}
