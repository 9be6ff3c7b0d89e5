//! Portable kernels, checked without a GPU.
//!
//! Every program in `kernels/*.cl` is compiled, with every combination of
//! defines the host can produce, by clang's OpenCL front-end for NVIDIA's
//! target (`nvptx64-nvidia-nvcl`) with exactly the extensions NVIDIA's
//! OpenCL driver offers (fp64, 32- and 64-bit base and extended atomics, no
//! fp16), OpenCL C 1.2 and the host's own build options. Warnings of `-Wall
//! -Wdouble-promotion` are errors: an implicit double on a GPU is a 32x slower
//! operation and a value the Rust reference does not compute. Each program is
//! also compiled to PTX, whose `.shared` declarations give every kernel's
//! local memory; each must fit the 48 KiB a CUDA-class GPU gives a
//! work-group, for every `--bins` the CLI accepts.
//!
//! The defines come from the functions the host itself calls
//! (`device_builder::program_defines`, `render::pathtrace_defines`, ...), and
//! the parameter ranges from the host's own checks (`BuildParams::check`), so
//! a new define or a new accepted value is covered without editing this test.
//!
//! clang: `SOUPRAY_CLANG`, else `clang` on the PATH (Debian's `clang`
//! package; CI installs it). Without clang the test prints why and passes,
//! except under CI (`CI` set), where a missing clang is a failure.
//!
//! The second half holds the numerical build rules: `FP_CONTRACT OFF` in
//! every kernel file, no `native_*`/`half_*` built-ins, no fast-math option
//! anywhere, and `-cl-fp32-correctly-rounded-divide-sqrt` wherever the device
//! reports `CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT`.

mod common;

use soupray::bvh::device_builder::{program_defines, Mapping};
use soupray::bvh::BuildParams;
use soupray::device::{assemble_source, assemble_text, build_options, Device};
use soupray::device_struct::probe_source;
use soupray::kernels::{generated_headers, KERNEL_SOURCES};
use soupray::soup::device::SoupFeatures;
use soupray::soup::motion::motion_program_defines;
use soupray::trace::device::trace_defines;
use soupray::trace::render::{
    film_defines, layering_defines, motion_defines, pathtrace_defines, FilmFeatures, Layering,
    Lobes, Traversal, LOBES,
};
use soupray::trace::sampling::Sampler;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// What NVIDIA's OpenCL driver reports (`clinfo` on its devices): fp64, the
/// 32-bit global/local base and extended atomics, the 64-bit ones, byte
/// stores; no cl_khr_fp16. `-all` first, so nothing else is assumed.
const NVIDIA_EXTENSIONS: &str = "-all,+cl_khr_fp64,+cl_khr_byte_addressable_store,\
+cl_khr_global_int32_base_atomics,+cl_khr_global_int32_extended_atomics,\
+cl_khr_local_int32_base_atomics,+cl_khr_local_int32_extended_atomics,\
+cl_khr_int64_base_atomics,+cl_khr_int64_extended_atomics";

/// Local memory per work-group on NVIDIA GPUs without an opt-in carve-out
/// (OpenCL's CL_DEVICE_LOCAL_MEM_SIZE there is 48 KiB).
const GPU_LOCAL_MEM: u64 = 48 * 1024;

fn kernels_dir() -> PathBuf {
    common::repo_file("kernels")
}

/// kernels/ and each folder in it.
fn kernel_dirs() -> Vec<PathBuf> {
    let root = kernels_dir();
    let mut dirs = vec![root.clone()];
    for entry in std::fs::read_dir(&root).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            dirs.push(path);
        }
    }
    dirs.sort();
    dirs
}

/// Every file under `dir`, its folders walked.
fn kernel_files(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(kernel_files(&path));
        } else {
            out.push(path);
        }
    }
    out
}

/// The layout probe generated from the struct definitions
/// (src/device_struct.rs), compiled like the files.
const STRUCT_PROBE: &str = "struct_layout_probe.cl";

/// One program as the host may build it.
struct Variant {
    entry: &'static str,
    defines: Vec<(&'static str, String)>,
    /// Also compile to PTX (codegen, and the local-memory check). The
    /// leaf-size sweep of the builder is checked by the front-end only, at
    /// the default bin count: the leaf size is a loop bound, never in an
    /// `#if` or an array size (`every_kernel_file_is_covered` holds that),
    /// and every bin count is compiled to PTX at leaves of 1, 4 and 64.
    codegen: bool,
}

impl Variant {
    fn describe(&self) -> String {
        let d: Vec<String> = self
            .defines
            .iter()
            .map(|(n, v)| format!("{n}={v}"))
            .collect();
        format!("{} [{}]", self.entry, d.join(" "))
    }
}

// Exhaustive matches: a new variant of these enums fails to compile here
// until the lists below include it.
fn all_mappings() -> Vec<Mapping> {
    let _ = |m: Mapping| match m {
        Mapping::Paper | Mapping::SingleLane => (),
    };
    vec![Mapping::Paper, Mapping::SingleLane]
}

fn all_traversals() -> Vec<Traversal> {
    let _ = |t: Traversal| match t {
        Traversal::Stack | Traversal::Stackless | Traversal::Wide | Traversal::Wide8 => (),
    };
    vec![
        Traversal::Stack,
        Traversal::Stackless,
        Traversal::Wide,
        Traversal::Wide8,
    ]
}

fn all_samplers() -> Vec<Sampler> {
    let _ = |s: Sampler| match s {
        Sampler::Sobol | Sampler::Random => (),
    };
    vec![Sampler::Sobol, Sampler::Random]
}

/// Every `--bins` value `BuildParams::check` accepts (the CLI's check).
fn accepted_bins() -> Vec<u32> {
    (0..=1024)
        .filter(|&bins| {
            BuildParams {
                bins,
                ..BuildParams::default()
            }
            .check()
            .is_ok()
        })
        .collect()
}

fn accepted_leaf_sizes() -> Vec<u32> {
    (0..=1024)
        .filter(|&leaf_size| {
            BuildParams {
                leaf_size,
                ..BuildParams::default()
            }
            .check()
            .is_ok()
        })
        .collect()
}

fn variants() -> Vec<Variant> {
    let mut v = builder_variants();
    v.push(Variant {
        entry: "trace.cl",
        defines: trace_defines(),
        codegen: true,
    });
    v.extend(pathtrace_variants());
    v.extend(soup_variants());
    v.extend(film_variants());
    v.push(Variant {
        entry: "motion.cl",
        defines: motion_program_defines(),
        codegen: true,
    });
    v.extend(sampler_probe_variants());
    v.extend(lobe_variants());
    v.push(Variant {
        entry: "pt_probe.cl",
        defines: Lobes::ALL
            .iter()
            .map(|lobe| (lobe.define, "1".to_owned()))
            .chain([
                ("HAS_TRANSMISSION", "1".to_owned()),
                ("GGX_ENERGY_COMPENSATION", "1".to_owned()),
                ("ENERGY_LAYERING", "1".to_owned()),
                ("FILM_LIGHT", "1".to_owned()),
            ])
            .collect(),
        codegen: true,
    });
    for entry in ["texture_probe.cl", "light_tree.cl", STRUCT_PROBE] {
        v.push(Variant {
            entry,
            defines: Vec::new(),
            codegen: true,
        });
    }
    v
}

/// `bvh_build.cl` at every accepted bin count and leaf size, mapping and
/// atomics width.
fn builder_variants() -> Vec<Variant> {
    let mut v = Vec::new();
    let leaves = accepted_leaf_sizes();
    let default_leaf = BuildParams::default().leaf_size;
    let (min_leaf, max_leaf) = (leaves[0], *leaves.last().unwrap());
    let default_bins = BuildParams::default().bins;
    for bins in accepted_bins() {
        for &leaf_size in &leaves {
            for mapping in all_mappings() {
                for int64 in [false, true] {
                    let codegen = [min_leaf, default_leaf, max_leaf].contains(&leaf_size);
                    // Every bin count, mapping and atomics at the smallest,
                    // default and largest leaf, to PTX; every other leaf
                    // size through the front-end, with both mappings and
                    // atomics at the default bin count.
                    if codegen || bins == default_bins {
                        let params = BuildParams { bins, leaf_size };
                        v.push(Variant {
                            entry: "bvh_build.cl",
                            defines: program_defines(params, mapping, int64),
                            codegen,
                        });
                    }
                }
            }
        }
    }
    v
}

/// `pathtrace.cl` for every traversal, texturing, sampler, transmission
/// and energy compensation, with its motion-blur variant.
fn pathtrace_variants() -> Vec<Variant> {
    let mut v = Vec::new();
    for traversal in all_traversals() {
        for textures in [false, true] {
            for sampler in all_samplers() {
                for transmission in [false, true] {
                    for compensation in [false, true] {
                        // Compensation is independent of the traversal.
                        if compensation && traversal != Traversal::Wide8 {
                            continue;
                        }
                        let defines = pathtrace_defines(
                            traversal,
                            textures,
                            sampler,
                            transmission,
                            compensation,
                            compensation,
                            // Every lobe with compensation, those that
                            // build on the dielectric with transmission.
                            LOBES
                                .iter()
                                .enumerate()
                                .filter(|(_, l)| {
                                    compensation && (transmission || !l.with_transmission)
                                })
                                .map(|(i, _)| i)
                                .collect::<Lobes>(),
                        );
                        // The energy layering with compensation (the default),
                        // the specification's without.
                        let layering = if compensation {
                            Layering::Energy
                        } else {
                            Layering::Spec
                        };
                        let defines = layering_defines(defines, layering);
                        v.push(Variant {
                            entry: "pathtrace.cl",
                            defines: defines.clone(),
                            codegen: true,
                        });
                        // The motion-blur variant of every combination (the
                        // compensation tables are independent of motion).
                        if !compensation {
                            v.push(Variant {
                                entry: "pathtrace.cl",
                                defines: motion_defines(defines),
                                codegen: true,
                            });
                        }
                    }
                }
            }
        }
    }
    v
}

/// `soup_eval.cl` for the soup's features.
fn soup_variants() -> Vec<Variant> {
    let mut v = Vec::new();
    // The soup's counts come from the scene (joint sets per vertex, morph
    // targets per mesh) and are loop bounds; 0 (no code), 1, 2 and a large
    // count cover the code paths.
    for skin in [false, true] {
        let sets: &[usize] = if skin { &[1, 2, 3, 8] } else { &[0] };
        for &influence_sets in sets {
            for morph_targets in [0, 1, 2, 8] {
                for normals in [false, true] {
                    for uvs in [false, true] {
                        for sanitize in [false, true] {
                            let f = SoupFeatures {
                                skin,
                                influence_sets,
                                morph_targets,
                                normals,
                                uvs,
                                // The extra corner attributes are gathered
                                // like the uvs: on and off with them.
                                uvs1: uvs,
                                colors: uvs,
                                sanitize,
                            };
                            v.push(Variant {
                                entry: "soup_eval.cl",
                                defines: f.defines(),
                                codegen: true,
                            });
                        }
                    }
                }
            }
        }
    }
    v
}

/// `pathtrace.cl` with every film option.
fn film_variants() -> Vec<Variant> {
    let mut v = Vec::new();
    // Depth of field with a transparent film, Cryptomatte, motion vectors,
    // shadow catchers, the position and uv AOVs and the light-path passes,
    // alone and with motion blur.
    let lens = film_defines(
        pathtrace_defines(
            Traversal::Wide8,
            true,
            Sampler::default(),
            false,
            false,
            false,
            Lobes::NONE,
        ),
        &FilmFeatures {
            lens: true,
            transparent: true,
            matte_slots: Some(6),
            vectors: true,
            catcher: true,
            geometry: true,
            light: true,
        },
    );
    v.push(Variant {
        entry: "pathtrace.cl",
        defines: lens.clone(),
        codegen: true,
    });
    // The light-path passes over every lobe.
    v.push(Variant {
        entry: "pathtrace.cl",
        defines: film_defines(
            pathtrace_defines(
                Traversal::Wide8,
                true,
                Sampler::default(),
                true,
                false,
                false,
                Lobes::ALL,
            ),
            &FilmFeatures {
                light: true,
                ..FilmFeatures::default()
            },
        ),
        codegen: true,
    });
    v.push(Variant {
        entry: "pathtrace.cl",
        defines: motion_defines(lens),
        codegen: true,
    });
    v
}

/// The test-only probe `pt_probe.cl` for each sampler, and with the
/// dielectric extensions.
fn sampler_probe_variants() -> Vec<Variant> {
    let mut v = Vec::new();
    // Test-only probes, built by the tests on the device.
    for sampler in all_samplers() {
        v.push(Variant {
            entry: "pt_probe.cl",
            defines: sampler
                .define()
                .map(|d| vec![(d, "1".to_owned())])
                .unwrap_or_default(),
            codegen: true,
        });
    }
    v.push(Variant {
        entry: "pt_probe.cl",
        defines: vec![("HAS_TRANSMISSION", "1".to_owned())],
        codegen: true,
    });
    v
}

/// `pathtrace.cl` and `pt_probe.cl` with each material lobe.
fn lobe_variants() -> Vec<Variant> {
    let mut v = Vec::new();
    // Each lobe alone, with and without the dielectric extensions (the
    // kernels read only the fields their defines declare), those that build
    // on them with them only.
    for (i, lobe) in LOBES.iter().enumerate() {
        for transmission in [false, true] {
            if lobe.with_transmission && !transmission {
                continue;
            }
            v.push(Variant {
                entry: "pathtrace.cl",
                defines: pathtrace_defines(
                    Traversal::Wide8,
                    true,
                    Sampler::default(),
                    transmission,
                    false,
                    false,
                    Lobes::only(i),
                ),
                codegen: true,
            });
            // The probe with the lobe's define alone: bsdf.h defines
            // HAS_TRANSMISSION with those that build on it.
            let mut probe = vec![(lobe.define, "1".to_owned())];
            if transmission && !lobe.with_transmission {
                probe.push(("HAS_TRANSMISSION", "1".to_owned()));
            }
            v.push(Variant {
                entry: "pt_probe.cl",
                defines: probe,
                codegen: true,
            });
        }
    }
    v
}

fn find_clang() -> Option<PathBuf> {
    let candidates: Vec<PathBuf> = match std::env::var_os("SOUPRAY_CLANG") {
        Some(c) => vec![PathBuf::from(c)],
        None => [
            "clang", "clang-19", "clang-18", "clang-17", "clang-16", "clang-15", "clang-14",
        ]
        .iter()
        .map(PathBuf::from)
        .collect(),
    };
    candidates.into_iter().find(|c| {
        Command::new(c)
            .arg("--version")
            .output()
            .is_ok_and(|o| o.status.success())
    })
}

/// clang, or `None` after saying why the test skips. Under CI a missing
/// clang fails instead: the check must not silently stop running there.
fn clang_or_skip() -> Option<PathBuf> {
    match find_clang() {
        Some(c) => Some(c),
        None if std::env::var_os("CI").is_some() => panic!(
            "clang is not installed, and CI is set: the portable-kernel check must run in CI \
             (.ci/run installs Debian's clang package)"
        ),
        None => {
            eprintln!(
                "kernels_portable: SKIPPED, clang not found (install Debian's `clang` package, \
                 or set SOUPRAY_CLANG); CI runs this check"
            );
            None
        }
    }
}

/// The clang arguments for one variant: the NVIDIA target and extensions,
/// the warnings, and the host's own options for it (as if the device reports
/// correctly rounded division, as NVIDIA's does).
fn clang_args(variant: &Variant, source: &Path, out: Option<&Path>) -> Vec<String> {
    let mut args: Vec<String> = [
        "-x",
        "cl",
        "-target",
        "nvptx64-nvidia-nvcl",
        "-Xclang",
        "-finclude-default-header",
        "-Xclang",
        &format!("-cl-ext={NVIDIA_EXTENSIONS}"),
        "-Wall",
        "-Wdouble-promotion",
        "-Werror",
    ]
    .iter()
    .map(|s| s.to_string())
    .collect();
    // `#include` names a file alone, as the host's embedded sources do:
    // every folder of kernels/ is on the include path.
    for dir in kernel_dirs() {
        args.push("-I".into());
        args.push(dir.display().to_string());
    }
    args.extend(
        build_options(&variant.defines, true)
            .split_whitespace()
            .map(str::to_owned),
    );
    match out {
        Some(out) => {
            args.extend(["-S".into(), "-o".into()]);
            args.push(out.display().to_string());
        }
        None => args.push("-fsyntax-only".into()),
    }
    args.push(source.display().to_string());
    args
}

/// Bytes of `.shared` (OpenCL local) memory per kernel in a PTX module.
/// clang names a kernel's `__local` arrays `<kernel>_$_<array>`.
fn shared_bytes_by_kernel(ptx: &str) -> Vec<(String, u64)> {
    let mut kernels: Vec<(String, u64)> = ptx
        .lines()
        .filter_map(|l| l.trim().strip_prefix(".entry "))
        .map(|rest| (rest.split('(').next().unwrap().trim().to_owned(), 0))
        .collect();
    for line in ptx.lines() {
        let line = line.trim();
        if !line.starts_with(".shared ") && !line.starts_with(".global .shared") {
            continue;
        }
        let Some(decl) = line.split_whitespace().last() else {
            continue;
        };
        let (name, size) = decl
            .trim_end_matches(';')
            .split_once('[')
            .unwrap_or_else(|| panic!("unexpected .shared line in PTX: {line}"));
        let size: u64 = size.trim_end_matches(']').parse().unwrap_or(1);
        let bytes = if line.contains(".b8 ") {
            size
        } else if line.contains(".b32 ") || line.contains(".u32 ") || line.contains(".f32 ") {
            4 * size
        } else {
            8 * size
        };
        let kernel = name
            .split_once("_$_")
            .map(|(k, _)| k)
            .unwrap_or_else(|| panic!("a .shared array outside any kernel: {line}"));
        match kernels.iter_mut().find(|(k, _)| k == kernel) {
            Some((_, total)) => *total += bytes,
            None => kernels.push((kernel.to_owned(), bytes)),
        }
    }
    kernels
}

#[test]
fn every_kernel_file_is_covered() {
    let variants = variants();
    for path in kernel_files(&kernels_dir()) {
        let name = path.file_name().unwrap().to_string_lossy().into_owned();
        assert!(
            KERNEL_SOURCES.iter().any(|(n, _)| *n == name),
            "{} is not embedded in src/kernels.rs KERNEL_SOURCES",
            path.display()
        );
        if name.ends_with(".cl") {
            assert!(
                variants.iter().any(|v| v.entry == name),
                "kernels/{name} is not compiled by tests/kernels_portable.rs: add its variants"
            );
        }
    }
    // The leaf size never shapes code or memory, only loop bounds, which is
    // why its sweep is checked by the front-end alone.
    for (name, text) in KERNEL_SOURCES {
        for line in text.lines() {
            let l = line.trim_start();
            assert!(
                !(l.starts_with('#') && l.contains("LEAF_SIZE") && !l.starts_with("#define")),
                "{name}: LEAF_SIZE in a preprocessor condition ({line}); codegen-check every leaf size"
            );
            assert!(
                !(l.contains("__local") && l.contains("LEAF_SIZE")),
                "{name}: LEAF_SIZE sizes local memory ({line}); check its local memory per leaf size"
            );
        }
    }
}

#[test]
fn kernels_compile_for_nvidia_with_every_define_combination() {
    let Some(clang) = clang_or_skip() else {
        return;
    };
    let variants = variants();
    let bins = accepted_bins();
    assert!(
        bins.contains(&16) && bins.len() >= 2,
        "accepted --bins: {bins:?}"
    );
    let dir = tempfile::tempdir().unwrap();
    // Each entry file once, as the host assembles it (headers inlined with
    // #line markers, so clang's messages name the original files).
    let mut entries: Vec<&str> = variants.iter().map(|v| v.entry).collect();
    entries.sort_unstable();
    entries.dedup();
    for entry in &entries {
        let text = if *entry == STRUCT_PROBE {
            assemble_text(entry, &probe_source(&generated_headers()))
        } else {
            assemble_source(entry)
        };
        std::fs::write(dir.path().join(entry), text).unwrap();
    }

    let next = AtomicUsize::new(0);
    let failures = Mutex::new(Vec::<String>::new());
    let local_mem = Mutex::new(Vec::<(String, String, u64)>::new());
    let workers = std::thread::available_parallelism()
        .map(|n| n.get())
        .unwrap_or(1)
        .min(8);
    let started = std::time::Instant::now();
    std::thread::scope(|s| {
        for w in 0..workers {
            let (variants, next, failures, local_mem, clang, dir) =
                (&variants, &next, &failures, &local_mem, &clang, dir.path());
            s.spawn(move || loop {
                let i = next.fetch_add(1, Ordering::Relaxed);
                let Some(v) = variants.get(i) else { break };
                let source = dir.join(v.entry);
                let ptx = dir.join(format!("w{w}.ptx"));
                let args = clang_args(v, &source, v.codegen.then_some(ptx.as_path()));
                let out = Command::new(clang).args(&args).output().unwrap();
                if !out.status.success() {
                    failures.lock().unwrap().push(format!(
                        "{} failed to compile for NVIDIA (clang {}):\n{}",
                        v.describe(),
                        args.join(" "),
                        String::from_utf8_lossy(&out.stderr)
                    ));
                    continue;
                }
                if v.codegen {
                    let text = std::fs::read_to_string(&ptx).unwrap();
                    let mut lm = local_mem.lock().unwrap();
                    for (kernel, bytes) in shared_bytes_by_kernel(&text) {
                        lm.push((v.describe(), kernel, bytes));
                    }
                }
            });
        }
    });
    let failures = failures.into_inner().unwrap();
    let local_mem = local_mem.into_inner().unwrap();
    let codegen = variants.iter().filter(|v| v.codegen).count();
    eprintln!(
        "kernels_portable: {} program variants ({codegen} to PTX) with {} in {:.1} s",
        variants.len(),
        clang.display(),
        started.elapsed().as_secs_f64()
    );
    assert!(
        failures.is_empty(),
        "{} of {} kernel variants do not compile for NVIDIA's OpenCL:\n\n{}",
        failures.len(),
        variants.len(),
        failures
            .iter()
            .take(5)
            .cloned()
            .collect::<Vec<_>>()
            .join("\n\n")
    );

    // Local memory: every kernel of every variant within 48 KiB. The
    // builder's largest users are reported per bin count for the record.
    let too_big: Vec<String> = local_mem
        .iter()
        .filter(|(_, _, bytes)| *bytes > GPU_LOCAL_MEM)
        .map(|(v, k, bytes)| format!("{v}: kernel {k} needs {bytes} bytes of local memory"))
        .collect();
    assert!(
        too_big.is_empty(),
        "kernels over the GPU's {GPU_LOCAL_MEM} bytes of local memory (--bins must refuse \
         these values on such devices):\n{}",
        too_big.join("\n")
    );
    for &b in &bins {
        let tag = format!("BINS={b} BUILD_WG=128 ");
        let max = local_mem
            .iter()
            .filter(|(v, _, _)| v.contains(&tag))
            .max_by_key(|(_, _, bytes)| *bytes)
            .unwrap_or_else(|| panic!("no PTX of the paper mapping at {b} bins"));
        eprintln!(
            "kernels_portable: paper mapping, {b:>2} bins: most local memory {} bytes ({})",
            max.2, max.1
        );
    }
    // The parse found the builder's local arrays at all (a PTX format change
    // must not pass as "zero bytes").
    assert!(local_mem
        .iter()
        .any(|(v, k, bytes)| v.starts_with("bvh_build.cl")
            && k == "build_small"
            && *bytes > 16 * 1024));
}

/// Files under `dir` (recursively) with one of `exts`, as (path, text).
fn sources(dir: &Path, exts: &[&str]) -> Vec<(PathBuf, String)> {
    let mut out = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            out.extend(sources(&path, exts));
        } else if exts
            .iter()
            .any(|e| path.extension().is_some_and(|x| x == *e))
        {
            out.push((path.clone(), std::fs::read_to_string(&path).unwrap()));
        }
    }
    out
}

#[test]
fn kernel_sources_follow_the_numerical_rules() {
    // OpenCL C's half_* built-ins (reduced-precision maths). `half_area` and
    // the like are our own functions, not these.
    const HALF_BUILTINS: &[&str] = &[
        "cos", "divide", "exp", "exp2", "exp10", "log", "log2", "log10", "powr", "recip", "rsqrt",
        "sin", "sqrt", "tan",
    ];
    let root = common::repo();
    for (path, text) in sources(&root.join("kernels"), &["cl", "h"]) {
        let name = path.display();
        assert!(
            text.lines()
                .any(|l| l.trim() == "#pragma OPENCL FP_CONTRACT OFF"),
            "{name}: every kernel file must say `#pragma OPENCL FP_CONTRACT OFF`"
        );
        assert!(
            !text.contains("FP_CONTRACT ON") && !text.contains("FP_CONTRACT DEFAULT"),
            "{name}: FP contraction switched back on"
        );
        let code: String = text
            .lines()
            .map(|l| l.split("//").next().unwrap())
            .collect::<Vec<_>>()
            .join("\n");
        for (i, _) in code.match_indices("native_") {
            let before = code[..i].chars().last();
            assert!(
                before.is_some_and(|c| c.is_alphanumeric() || c == '_'),
                "{name}: native_* built-ins are not allowed (their precision is the driver's)"
            );
        }
        for f in HALF_BUILTINS {
            let call = format!("half_{f}(");
            for (i, _) in code.match_indices(&call) {
                let before = code[..i].chars().last();
                assert!(
                    before.is_some_and(|c| c.is_alphanumeric() || c == '_'),
                    "{name}: half_{f} is not allowed (reduced precision)"
                );
            }
        }
        for pragma in ["fast", "unsafe"] {
            assert!(
                !code
                    .lines()
                    .any(|l| l.trim_start().starts_with("#pragma") && l.contains(pragma)),
                "{name}: a {pragma} pragma"
            );
        }
        assert!(
            !code.contains("mad("),
            "{name}: mad() may be contracted or approximated; write a * b + c"
        );
    }
    // No option that relaxes floating point, anywhere the host or a tool
    // could pass one.
    const RELAXING: &[&str] = &[
        "-cl-fast-relaxed-math",
        "-cl-unsafe-math-optimizations",
        "-cl-mad-enable",
        "-cl-finite-math-only",
        "-cl-no-signed-zeros",
        "-cl-denorms-are-zero",
        "-ffast-math",
    ];
    let mut checked = 0;
    for dir in ["src", "kernels", "benches", "scripts"] {
        for (path, text) in sources(&root.join(dir), &["rs", "cl", "h", "sh"]) {
            checked += 1;
            for opt in RELAXING {
                assert!(
                    !text.contains(opt),
                    "{}: mentions {opt}; soupray never relaxes floating point",
                    path.display()
                );
            }
        }
    }
    assert!(checked > 20, "scanned only {checked} files");

    // The one place options are assembled adds correct rounding exactly when
    // asked, and never anything relaxed.
    let d = vec![("BINS", "16".to_owned())];
    let with = build_options(&d, true);
    let without = build_options(&d, false);
    assert!(with
        .split_whitespace()
        .any(|o| o == "-cl-fp32-correctly-rounded-divide-sqrt"));
    assert!(!without.contains("correctly-rounded"));
    assert!(with.contains("-cl-std=CL1.2") && without.contains("-cl-std=CL1.2"));
}

/// On the device at hand: the driver reports exactly the options the rules
/// ask for (correct rounding iff the device offers it).
#[test]
fn device_programs_are_built_with_the_rounding_the_device_offers() {
    let device = Device::open(None).expect("an OpenCL device (PoCL here)");
    let program = device
        .build_program("trace.cl", &trace_defines())
        .expect("trace.cl builds");
    let options = device.program_build_options(&program).unwrap();
    assert_eq!(
        options.contains("-cl-fp32-correctly-rounded-divide-sqrt"),
        device.info.correctly_rounded_divide_sqrt,
        "{}: options {options:?}, CL_FP_CORRECTLY_ROUNDED_DIVIDE_SQRT {}",
        device.info.name,
        device.info.correctly_rounded_divide_sqrt
    );
    assert!(options.contains("-cl-std=CL1.2"), "{options:?}");
    assert!(!options.contains("fast-relaxed"), "{options:?}");
}
