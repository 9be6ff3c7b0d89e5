//! BVH build benchmark: the device builder side by side with the `bvh`
//! crate's parallel builder, soupray's CPU builders and (built with
//! `--features embree`) Embree 3's scene build, on real meshes and
//! instanced arrangements of them, in one run.
//!
//!   cargo bench --bench bvh_build            # all sizes
//!   cargo bench --bench bvh_build --features embree  # with Embree 3
//!   cargo bench --bench bvh_build -- --quick # 70K and 250K only
//!   cargo bench --bench bvh_build -- --write-ply DIR  # the soups as PLY files
//!
//! Prints a Markdown table for BENCHMARKS.md: median build ms, Mtris/s, the
//! device's per-stage split, SAH cost relative to the full sweep, and each
//! builder's peak host memory (VmHWM, reset before each builder).

mod support;

use opencl3::memory::Buffer;
use soupray::bvh::device_builder::{DeviceBuilder, Mapping};
use soupray::bvh::{binned, sah_cost, sweep, validate, BuildParams};
use soupray::cli::report::median;
use soupray::device::Device;
use soupray::soup::Soup;
use std::path::Path;
use std::time::Instant;

/// A scanned mesh, read in place from the shared folder; `Err` names the
/// missing file (its scenes are skipped).
fn mesh(name: &str) -> Result<Soup, String> {
    support::mesh(name)
}

/// The crowded arrangement of `copies` copies (`Soup::arrangement`, which
/// `soupray bvh --copies` uses too).
fn arrangement(base: &Soup, copies: usize) -> Soup {
    base.arrangement(copies)
}

/// Peak resident memory since the last reset, in MiB (Linux).
fn peak_mib() -> f64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    status
        .lines()
        .find(|l| l.starts_with("VmHWM:"))
        .and_then(|l| l.split_whitespace().nth(1))
        .and_then(|kb| kb.parse::<f64>().ok())
        .map_or(f64::NAN, |kb| kb / 1024.0)
}

/// Peak memory of one builder on one scene, measured in a child process of
/// this benchmark (`--peak-of BUILDER SCENE`), so builders do not inherit
/// each other's high-water marks.
fn peak_of(builder: &str, scene: usize, quick: bool) -> f64 {
    let mut cmd = std::process::Command::new(std::env::current_exe().expect("own path"));
    cmd.args(["--peak-of", builder, &scene.to_string()]);
    if quick {
        cmd.arg("--quick");
    }
    let out = cmd.output().expect("run the peak-memory child");
    String::from_utf8_lossy(&out.stdout)
        .trim()
        .parse()
        .unwrap_or(f64::NAN)
}

/// The benchmark's scenes: (name, how to make it). Made one at a time, so
/// a memory child holds only the scene it measures.
type MakeScene = (&'static str, fn() -> Result<Soup, String>);

fn scene_list(quick: bool) -> Vec<MakeScene> {
    let mut list: Vec<MakeScene> = vec![
        ("beast (real)", || mesh("beast.ply")),
        ("4 x beast", || Ok(arrangement(&mesh("beast.ply")?, 4))),
    ];
    if !quick {
        list.push(("10 x nefertiti", || {
            Ok(arrangement(&mesh("nefertiti.ply")?, 10))
        }));
        list.push(("25 x nefertiti", || {
            Ok(arrangement(&mesh("nefertiti.ply")?, 25))
        }));
    }
    list
}

/// The child side of `peak_of`: loads the scene, builds once, prints VmHWM.
fn run_peak_child(builder: &str, scene: usize, quick: bool) {
    let Ok(soup) = (scene_list(quick)[scene].1)() else {
        // A missing mesh: no figure (the parent skipped the scene).
        return;
    };
    let params = BuildParams::default();
    match builder {
        "device" | "paper" => {
            let device = Device::open(None).expect("an OpenCL device");
            let mapping = if builder == "paper" {
                Mapping::Paper
            } else {
                Mapping::SingleLane
            };
            let mut b = DeviceBuilder::with_mapping(&device, params, mapping).unwrap();
            b.build(&soup).unwrap();
        }
        "cpu-binned" => {
            binned::build(&soup, params).unwrap();
        }
        "cpu-sweep" => {
            sweep::build(&soup, params);
        }
        #[cfg(feature = "embree")]
        "embree" => {
            drop(soupray::trace::embree::EmbreeScene::new(&soup.positions, 2));
        }
        _ => {
            let mut shapes: Vec<Tri> = (0..soup.triangle_count())
                .map(|t| Tri(std::array::from_fn(|k| soup.corner(t, k)), 0))
                .collect();
            let _ = <bvh::bvh::Bvh<f32, 3> as bvh::bounding_hierarchy::BoundingHierarchy<f32, 3>>::build_par(&mut shapes);
        }
    }
    println!("{}", peak_mib());
}

struct Tri([[f32; 3]; 3], usize);

impl bvh::aabb::Bounded<f32, 3> for Tri {
    fn aabb(&self) -> bvh::aabb::Aabb<f32, 3> {
        let mut b = bvh::aabb::Aabb::empty();
        for v in &self.0 {
            b.grow_mut(&nalgebra::Point3::new(v[0], v[1], v[2]));
        }
        b
    }
}

impl bvh::bounding_hierarchy::BHShape<f32, 3> for Tri {
    fn set_bh_node_index(&mut self, i: usize) {
        self.1 = i;
    }
    fn bh_node_index(&self) -> usize {
        self.1
    }
}

/// SAH cost of a `bvh` crate tree (leaves of one triangle), by the same
/// definition as `soupray::bvh::sah_cost`.
fn bvh_crate_sah(tree: &bvh::bvh::Bvh<f32, 3>) -> f64 {
    use bvh::bvh::BvhNode;
    let area = |b: &bvh::aabb::Aabb<f32, 3>| {
        let d = [
            (b.max.x - b.min.x) as f64,
            (b.max.y - b.min.y) as f64,
            (b.max.z - b.min.z) as f64,
        ];
        2.0 * (d[0] * d[1] + d[1] * d[2] + d[2] * d[0])
    };
    let BvhNode::Node {
        child_l_aabb,
        child_r_aabb,
        ..
    } = &tree.nodes[0]
    else {
        return 0.0;
    };
    let root = area(&child_l_aabb.join(child_r_aabb));
    let mut cost = root;
    for node in &tree.nodes {
        if let BvhNode::Node {
            child_l_index,
            child_l_aabb,
            child_r_index,
            child_r_aabb,
            ..
        } = node
        {
            for (i, b) in [(child_l_index, child_l_aabb), (child_r_index, child_r_aabb)] {
                // An inner child costs its box once; a leaf its box times one triangle.
                let _ = i;
                cost += area(b);
            }
        }
    }
    cost / root
}

struct Row {
    scene: String,
    builder: &'static str,
    ms: f64,
    mtris: f64,
    stages: String,
    sah: f64,
    sah_vs_sweep: f64,
    peak: f64,
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    if let Some(i) = args.iter().position(|a| a == "--peak-of") {
        run_peak_child(&args[i + 1], args[i + 2].parse().unwrap(), quick);
        return;
    }
    let scenes = scene_list(quick);
    if let Some(i) = args.iter().position(|a| a == "--write-ply") {
        write_plys(&scenes, Path::new(&args[i + 1]));
        return;
    }
    let device = Device::open(None).expect("an OpenCL device");
    let params = BuildParams::default();
    let mut builder = DeviceBuilder::with_mapping(&device, params, Mapping::SingleLane).unwrap();
    // The paper's GPU mapping run on the same CPU device: the variant the
    // single-lane mapping replaces on CPUs.
    let mut paper = DeviceBuilder::with_mapping(&device, params, Mapping::Paper).unwrap();
    let mut rows = Vec::new();
    for (scene_index, (name, make)) in scenes.iter().enumerate() {
        let soup = &match make() {
            Ok(soup) => soup,
            Err(e) => {
                eprintln!("bvh_build: {name}: {e}; skipped");
                continue;
            }
        };
        let n = soup.triangle_count();
        let case = Case {
            soup,
            label: format!("{name}, {:.0}K", n as f64 / 1e3),
            index: scene_index,
            // About 2M triangles' worth of builds, 5 at least: a 10 ms
            // build on a shared machine needs many for a stable median.
            reps: (2_000_000 / n.max(1)).clamp(5, 31),
            quick,
        };
        let sweep = time_sweep(&case, params);
        let sweep_sah = sweep.sah;
        rows.push(sweep);
        // The soup's corners go to the device once, outside the timings: a
        // frame's soup is evaluated there and built from there
        // (`build_from_device`), as Embree builds from shared buffers.
        let mut corners = device
            .buffer::<[f32; 4]>(soup.positions.len().max(1))
            .unwrap();
        device.write(&mut corners, &soup.positions).unwrap();
        let on_device = (&corners, n);
        rows.push(time_device(
            &case,
            &mut builder,
            on_device,
            params,
            sweep_sah,
        ));
        rows.push(time_paper(&case, &mut paper, on_device, sweep_sah));
        rows.push(time_cpu_binned(&case, params, sweep_sah));
        rows.push(time_bvh_crate(&case, sweep_sah));
        #[cfg(feature = "embree")]
        rows.push(time_embree(&case));
    }
    print_table(&rows);
}

/// `--write-ply DIR`: the soups as PLY files, for `soupray bvh` runs (A/B
/// of two binaries).
fn write_plys(scenes: &[MakeScene], dir: &Path) {
    for (index, (name, make)) in scenes.iter().enumerate() {
        let path = dir.join(format!("{index}-{}.ply", name.replace([' ', '(', ')'], "")));
        let soup = match make() {
            Ok(soup) => soup,
            Err(e) => {
                eprintln!("bvh_build: {name}: {e}; skipped");
                continue;
            }
        };
        soupray::ply::write_soup(&path, &soup).unwrap();
        println!("{}", path.display());
    }
}

/// One scene of the run: its soup, its label in the table, its index in
/// `scene_list` (for the memory child), and the timed builds per builder.
struct Case<'a> {
    soup: &'a Soup,
    label: String,
    index: usize,
    reps: usize,
    quick: bool,
}

impl Case<'_> {
    /// The row of `builder` (its peak memory measured by the child
    /// `peak_key`), against the sweep's SAH cost.
    fn row(
        &self,
        builder: &'static str,
        ms: f64,
        stages: String,
        sah: f64,
        sweep_sah: f64,
        peak_key: &str,
    ) -> Row {
        Row {
            scene: self.label.clone(),
            builder,
            ms,
            mtris: self.soup.triangle_count() as f64 / ms / 1e3,
            stages,
            sah,
            sah_vs_sweep: sah / sweep_sah,
            peak: peak_of(peak_key, self.index, self.quick),
        }
    }
}

/// The CPU full sweep, once: the SAH cost the others are measured against.
fn time_sweep(case: &Case, params: BuildParams) -> Row {
    let (soup, n, label) = (case.soup, case.soup.triangle_count(), &case.label);
    eprintln!("{label}: sweep");
    let t = Instant::now();
    let sweep_tree = sweep::build(soup, params);
    let sweep_ms = t.elapsed().as_secs_f64() * 1e3;
    let sweep_sah = sah_cost(&sweep_tree);
    drop(sweep_tree);
    Row {
        scene: label.clone(),
        builder: "soupray cpu-sweep (1 thread)",
        ms: sweep_ms,
        mtris: n as f64 / sweep_ms / 1e3,
        stages: String::new(),
        sah: sweep_sah,
        sah_vs_sweep: 1.0,
        peak: peak_of("cpu-sweep", case.index, case.quick),
    }
}

/// The device builder (single-lane mapping) after a warm-up build, with
/// its per-stage split; its last tree is validated.
fn time_device(
    case: &Case,
    builder: &mut DeviceBuilder,
    (corners, n): (&Buffer<[f32; 4]>, usize),
    params: BuildParams,
    sweep_sah: f64,
) -> Row {
    let (soup, label) = (case.soup, &case.label);
    eprintln!("{label}: device");
    builder.build_from_device(corners, n).unwrap(); // warm-up: buffers and caches
    let mut times = Vec::new();
    let mut stats = Vec::new();
    let mut tree = None;
    for _ in 0..case.reps {
        let (t, s) = builder.build_from_device(corners, n).unwrap();
        times.push(s.build_ms);
        stats.push(s);
        tree = Some(t);
    }
    let tree = tree.unwrap();
    validate(&tree, soup, params.leaf_size).expect("device tree valid");
    let ms = median(times);
    let st = |f: fn(&soupray::bvh::device_builder::BuildStats) -> f64| {
        median(stats.iter().map(f).collect())
    };
    let stages = format!(
        "prep {:.1} / large {:.1} / medium {:.1} / small {:.1} / host {:.1}",
        st(|s| s.stages_ms.prepare),
        st(|s| s.stages_ms.large),
        st(|s| s.stages_ms.medium),
        st(|s| s.stages_ms.small),
        st(|s| s.host_ms)
    );
    let sah = sah_cost(&tree);
    drop(tree);
    case.row(
        "soupray device, single-lane mapping (CPU default)",
        ms,
        stages,
        sah,
        sweep_sah,
        "device",
    )
}

/// The device builder with the paper's 16-lane mapping, after a warm-up.
fn time_paper(
    case: &Case,
    paper: &mut DeviceBuilder,
    (corners, n): (&Buffer<[f32; 4]>, usize),
    sweep_sah: f64,
) -> Row {
    let label = &case.label;
    eprintln!("{label}: device, paper mapping");
    paper.build_from_device(corners, n).unwrap();
    let mut times = Vec::new();
    let mut sah = 0.0;
    for _ in 0..if n > 500_000 { 1 } else { 3 } {
        let (tree, stats) = paper.build_from_device(corners, n).unwrap();
        times.push(stats.build_ms);
        sah = sah_cost(&tree);
    }
    let ms = median(times);
    case.row(
        "soupray device, paper's 16-lane mapping",
        ms,
        String::new(),
        sah,
        sweep_sah,
        "paper",
    )
}

/// soupray's binned CPU builder, on one thread.
fn time_cpu_binned(case: &Case, params: BuildParams, sweep_sah: f64) -> Row {
    let (soup, label) = (case.soup, &case.label);
    eprintln!("{label}: cpu-binned");
    let mut times = Vec::new();
    let mut sah = 0.0;
    for _ in 0..case.reps.min(3) {
        let t = Instant::now();
        let tree = binned::build(soup, params).unwrap();
        times.push(t.elapsed().as_secs_f64() * 1e3);
        sah = sah_cost(&tree);
    }
    let ms = median(times);
    case.row(
        "soupray cpu-binned (1 thread)",
        ms,
        String::new(),
        sah,
        sweep_sah,
        "cpu-binned",
    )
}

/// The `bvh` crate's parallel builder (rayon, leaves of one triangle).
fn time_bvh_crate(case: &Case, sweep_sah: f64) -> Row {
    let (soup, n, label) = (case.soup, case.soup.triangle_count(), &case.label);
    eprintln!("{label}: bvh crate");
    let mut times = Vec::new();
    let mut sah = 0.0;
    for _ in 0..case.reps.min(3) {
        let mut shapes: Vec<Tri> = (0..n)
            .map(|t| Tri(std::array::from_fn(|k| soup.corner(t, k)), 0))
            .collect();
        let t = Instant::now();
        let tree = <bvh::bvh::Bvh<f32, 3> as bvh::bounding_hierarchy::BoundingHierarchy<
            f32,
            3,
        >>::build_par(&mut shapes);
        times.push(t.elapsed().as_secs_f64() * 1e3);
        sah = bvh_crate_sah(&tree);
    }
    let ms = median(times);
    case.row(
        "bvh 0.13 build_par (rayon, leaf 1)",
        ms,
        String::new(),
        sah,
        sweep_sah,
        "bvh",
    )
}

/// Embree 3's scene build (its default: BVH of the CPU's widest SIMD,
/// build quality MEDIUM, spatial splits off) on 2 threads, the same count
/// as the device's compute units here. Embree keeps its tree to itself, so
/// no SAH cost.
#[cfg(feature = "embree")]
fn time_embree(case: &Case) -> Row {
    let label = &case.label;
    eprintln!("{label}: embree");
    let mut times = Vec::new();
    for _ in 0..=case.reps {
        let (scene, ms) = soupray::trace::embree::EmbreeScene::new_timed(&case.soup.positions, 2);
        drop(scene);
        times.push(ms);
    }
    times.remove(0); // the warm-up
    let ms = median(times);
    let mut row = case.row(
        "Embree 3 rtcCommitScene (2 threads)",
        ms,
        String::new(),
        f64::NAN,
        1.0,
        "embree",
    );
    row.sah_vs_sweep = f64::NAN;
    row
}

/// The table for BENCHMARKS.md, in Markdown.
fn print_table(rows: &[Row]) {
    println!("| scene | builder | build ms (median) | Mtris/s | device stages ms | SAH cost | SAH / sweep | peak host MiB |");
    println!("|---|---|---:|---:|---|---:|---:|---:|");
    for r in rows {
        let (sah, vs) = if r.sah.is_nan() {
            ("-".to_owned(), "-".to_owned())
        } else {
            (format!("{:.2}", r.sah), format!("{:.3}", r.sah_vs_sweep))
        };
        println!(
            "| {} | {} | {:.1} | {:.2} | {} | {} | {} | {:.0} |",
            r.scene, r.builder, r.ms, r.mtris, r.stages, sah, vs, r.peak
        );
    }
}
