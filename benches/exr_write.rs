//! What writing a frame with every compositing pass costs in the EXR's ZIP
//! blocks, stage by stage, on a real frame: the shipped walker's frame 24
//! at 640x360 with every pass (90 channels, 83 MB of samples), rendered
//! once by the release `soupray render`, read back, and cut into the blocks
//! soupray writes (16 lines, each channel's samples of a line in turn,
//! little-endian).
//!
//! ```text
//! cargo bench --bench exr_write
//! cargo bench --bench exr_write -- --runs 15 --out out/bench-exr
//! ```
//!
//! Each run times, one after the other on one thread: OpenEXR's ZIP
//! predictor a byte at a time (`zip_predict_bytewise`, as `ImfZip.cpp`
//! writes it) and soupray's word-at-a-time one (`zip_predict`), which give
//! the same bytes; then zlib (zlib-rs through flate2, as the writer uses it)
//! at level 1, soupray's level and OpenEXR's default 4 on the predicted
//! blocks. The table gives each one's median over the frame's blocks, its
//! ratio to the one it replaces (the byte loop; level 4), and the
//! compressed size.

#[path = "../tests/common/passes.rs"]
mod passes;
mod support;

use soupray::cli::report::median;
use soupray::output::{zip_predict, zip_predict_bytewise, ZIP_LEVEL};
use std::io::Write;
use std::path::PathBuf;
use std::process::Command;
use std::time::Instant;
use support::flag;

/// The zlib level OpenEXR writes ZIP blocks at by default.
const OPENEXR_LEVEL: u32 = 4;

/// Renders the frame and returns its blocks' raw bytes.
fn frame_blocks(out: &std::path::Path) -> Result<(Vec<Vec<u8>>, usize), String> {
    let scene = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("animations/walker/walker.glb");
    let status = Command::new(env!("CARGO_BIN_EXE_soupray"))
        .args(["render", "--quiet", "--frame", "24", "--out"])
        .arg(out)
        .args(passes::EVERY_PASS)
        .arg(&scene)
        .status()
        .map_err(|e| format!("soupray render: {e}"))?;
    if !status.success() {
        return Err(format!("soupray render exited with {status}"));
    }
    let file = out.join("walker.0024.exr");
    let image = exr::prelude::read_all_flat_layers_from_file(&file)
        .map_err(|e| format!("{}: {e}", file.display()))?;
    let layer = &image.layer_data[0];
    let (width, height) = (layer.size.x(), layer.size.y());
    // The file lists its channels sorted by name, as the writer stores them.
    let channels: Vec<Vec<f32>> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.sample_data.values_as_f32().collect())
        .collect();
    let blocks = (0..height)
        .step_by(16)
        .map(|y0| {
            let mut raw = Vec::new();
            for y in y0..(y0 + 16).min(height) {
                for c in &channels {
                    for s in &c[y * width..(y + 1) * width] {
                        raw.extend_from_slice(&s.to_le_bytes());
                    }
                }
            }
            raw
        })
        .collect();
    Ok((blocks, channels.len()))
}

fn zlib(data: &[u8], level: u32) -> usize {
    let mut e = flate2::write::ZlibEncoder::new(
        Vec::with_capacity(data.len() / 2),
        flate2::Compression::new(level),
    );
    e.write_all(data).expect("in memory");
    e.finish().expect("in memory").len()
}

fn main() {
    let runs: usize = flag("--runs").and_then(|r| r.parse().ok()).unwrap_or(11);
    let out = PathBuf::from(flag("--out").unwrap_or_else(|| "out/bench-exr".into()));
    let (blocks, channels) = match frame_blocks(&out) {
        Ok(b) => b,
        Err(e) => {
            println!("skipped: {e}");
            return;
        }
    };
    let bytes: usize = blocks.iter().map(Vec::len).sum();
    for b in &blocks {
        assert_eq!(
            zip_predict(b),
            zip_predict_bytewise(b),
            "the predictors differ"
        );
    }
    let predicted: Vec<Vec<u8>> = blocks.iter().map(|b| zip_predict(b)).collect();
    // OpenEXR's default level last: the ratios are to it.
    let levels = [1u32, ZIP_LEVEL, OPENEXR_LEVEL];
    let mut ms: Vec<Vec<f64>> = vec![Vec::new(); 2 + levels.len()];
    let mut sizes = vec![0usize; levels.len()];
    let time = |f: &mut dyn FnMut()| {
        let start = Instant::now();
        f();
        start.elapsed().as_secs_f64() * 1e3
    };
    for _ in 0..runs {
        ms[0].push(time(&mut || {
            for b in &blocks {
                std::hint::black_box(zip_predict_bytewise(b));
            }
        }));
        ms[1].push(time(&mut || {
            for b in &blocks {
                std::hint::black_box(zip_predict(b));
            }
        }));
        for (k, &level) in levels.iter().enumerate() {
            ms[2 + k].push(time(&mut || {
                sizes[k] = predicted.iter().map(|p| zlib(p, level)).sum();
            }));
        }
    }
    let m: Vec<f64> = ms.into_iter().map(median).collect();
    println!(
        "walker frame 24, 640x360, {channels} channels, {} blocks, {:.1} MB; medians of {runs} runs, one thread",
        blocks.len(),
        bytes as f64 / 1e6
    );
    println!();
    println!("| stage | ms per frame (median) | ratio | compressed MB |");
    println!("|---|---:|---:|---:|");
    println!(
        "| predictor, a byte at a time (OpenEXR's loop) | {:.1} | - | - |",
        m[0]
    );
    println!(
        "| predictor, eight pairs a word (soupray) | {:.1} | {:.2} | - |",
        m[1],
        m[1] / m[0]
    );
    for (k, level) in levels.iter().enumerate() {
        println!(
            "| zlib level {level}{} | {:.1} | {:.2} | {:.2} |",
            match *level {
                ZIP_LEVEL => " (soupray's)",
                OPENEXR_LEVEL => " (OpenEXR's default)",
                _ => "",
            },
            m[2 + k],
            m[2 + k] / m[2 + levels.len() - 1],
            sizes[k] as f64 / 1e6
        );
    }
}
