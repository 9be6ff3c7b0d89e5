//! The report's rows and what it says about the machine and the run.

use crate::renderers::{Render, Times};
use std::process::Command;

pub struct Row {
    pub mesh: String,
    pub lighting: String,
    pub spp: u32,
    pub renderer: &'static str,
    /// soupray's sampler, or the Cycles' label (`5.0 guided`).
    pub variant: String,
    /// For Cycles: its Blender version (`5.0`), the anchor its rows
    /// stand for; the better of a version's settings is the one compared.
    pub anchor: String,
    /// The mean of `run_rel_mse`.
    pub rel_mse: f64,
    /// Each run's error (one seed each): where a few bright paths carry most
    /// of an image's error, one seed's draw is far from the mean, and their
    /// spread says how far.
    pub run_rel_mse: Vec<f64>,
    pub times: Times,
}

impl Row {
    /// The row of render `r` of scene (mesh, lighting, spp) by (renderer,
    /// variant, anchor), with its error against its reference.
    pub fn measured(
        (mesh, lighting, spp): (&str, &str, u32),
        (renderer, variant, anchor): (&'static str, &str, &str),
        rel_mse: f64,
        r: &Render,
    ) -> Row {
        Row {
            mesh: mesh.to_owned(),
            lighting: lighting.to_owned(),
            spp,
            renderer,
            variant: variant.to_owned(),
            anchor: anchor.to_owned(),
            rel_mse,
            run_rel_mse: vec![rel_mse],
            times: r.times,
        }
    }

    /// The smallest and largest of the runs' errors.
    pub fn run_range(&self) -> (f64, f64) {
        let min = self
            .run_rel_mse
            .iter()
            .copied()
            .fold(f64::INFINITY, f64::min);
        let max = self
            .run_rel_mse
            .iter()
            .copied()
            .fold(f64::NEG_INFINITY, f64::max);
        (min, max)
    }

    pub fn product(&self) -> f64 {
        self.rel_mse * self.times.time
    }
    pub fn sampling_product(&self) -> f64 {
        self.rel_mse * self.times.sampling
    }
}

pub fn machine() -> String {
    let cpuinfo = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let model = cpuinfo
        .lines()
        .find_map(|l| {
            l.strip_prefix("model name")
                .map(|v| v.trim_start_matches([' ', '\t', ':']))
        })
        .unwrap_or("unknown CPU")
        .trim()
        .to_owned();
    let logical = cpuinfo
        .lines()
        .filter(|l| l.starts_with("processor"))
        .count();
    // Physical cores: distinct (physical id, core id) pairs.
    let mut cores = std::collections::BTreeSet::new();
    let mut package = "";
    for l in cpuinfo.lines() {
        let value = l.split_once(':').map_or("", |(_, v)| v.trim());
        if l.starts_with("physical id") {
            package = value;
        } else if l.starts_with("core id") {
            cores.insert((package, value));
        }
    }
    let avail = std::thread::available_parallelism().map_or(0, |n| n.get());
    format!(
        "{model}, {} cores, {logical} logical CPUs ({avail} available to this process)",
        if cores.is_empty() {
            logical
        } else {
            cores.len()
        }
    )
}

pub fn date() -> String {
    Command::new("date")
        .args(["-u", "+%Y-%m-%d %H:%M UTC"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| String::from_utf8_lossy(&o.stdout).trim().to_owned())
        .unwrap_or_else(|| "unknown date".into())
}

pub fn fmt_sci(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3e}")
    } else {
        "–".into()
    }
}
