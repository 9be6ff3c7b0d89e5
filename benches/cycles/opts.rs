//! The bench's command line (`USAGE`), parsed into `Opts`.

use crate::scenes::mesh_spec;
use std::path::{Path, PathBuf};

pub const USAGE: &str = "\
usage: cargo bench --bench cycles -- [--size WxH] [--spp LIST] [--ref-spp N]
       [--meshes beast,nefertiti] [--lightings sky,sun,interior,glossy,glass,emitter,lamps,character] [--samplers sobol,random]
       [--cycles 3.4,5,5-guided] [--runs N] [--max-depth N] [--threads N] [--out DIR]
       [--fresh-refs] [--scenes-only]";

#[derive(Debug, Clone)]
pub struct Opts {
    pub width: u32,
    pub height: u32,
    pub spp: Vec<u32>,
    pub ref_spp: u32,
    pub meshes: Vec<String>,
    pub lightings: Vec<String>,
    pub samplers: Vec<String>,
    /// The Cycles to run: `3.4` (a Blender binary), `5` and `5-guided`
    /// (Blender 5's `bpy` module, path guiding off and on).
    pub cycles: Vec<String>,
    /// Timed renders per scene, interleaved; the report takes medians.
    pub runs: u32,
    pub max_depth: u32,
    pub threads: u32,
    pub out: PathBuf,
    pub fresh_refs: bool,
    pub scenes_only: bool,
}

fn list(v: &str) -> Vec<String> {
    v.split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .map(str::to_owned)
        .collect()
}

pub fn parse_opts(args: &[String]) -> Result<Opts, String> {
    let root = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut o = Opts {
        width: 384,
        height: 256,
        spp: vec![16, 64, 256],
        ref_spp: 4096,
        meshes: list("beast,nefertiti"),
        lightings: list("sky,sun,interior,glossy,glass,emitter,lamps,character"),
        samplers: list("sobol,random"),
        cycles: list("3.4,5,5-guided"),
        runs: 1,
        max_depth: 8,
        threads: std::thread::available_parallelism().map_or(2, |n| n.get() as u32),
        out: root.join("out/bench-cycles"),
        fresh_refs: false,
        scenes_only: false,
    };
    let mut i = 0;
    while i < args.len() {
        let (flag, inline) = match args[i].split_once('=') {
            Some((f, v)) if f.starts_with("--") => (f.to_owned(), Some(v.to_owned())),
            _ => (args[i].clone(), None),
        };
        i += 1;
        match flag.as_str() {
            // `cargo bench` passes --bench to every bench binary.
            "--bench" => continue,
            "--fresh-refs" => {
                o.fresh_refs = true;
                continue;
            }
            "--scenes-only" => {
                o.scenes_only = true;
                continue;
            }
            "-h" | "--help" => return Err(String::new()),
            "--size" | "--spp" | "--ref-spp" | "--meshes" | "--lightings" | "--samplers"
            | "--cycles" | "--runs" | "--max-depth" | "--threads" | "--out" => {}
            _ => return Err(format!("unknown flag {flag}")),
        }
        let value = match inline {
            Some(v) => v,
            None => {
                let v = args
                    .get(i)
                    .cloned()
                    .ok_or_else(|| format!("{flag} needs a value"))?;
                i += 1;
                v
            }
        };
        let num = |v: &str| -> Result<u32, String> {
            v.trim()
                .parse::<u32>()
                .ok()
                .filter(|&n| n > 0)
                .ok_or_else(|| format!("{flag} {v:?}: want a positive integer"))
        };
        match flag.as_str() {
            "--size" => {
                let (w, h) = value
                    .split_once(['x', 'X'])
                    .ok_or_else(|| format!("--size {value:?}: want WxH"))?;
                o.width = num(w)?;
                o.height = num(h)?;
            }
            "--spp" => {
                o.spp = list(&value)
                    .iter()
                    .map(|v| num(v))
                    .collect::<Result<_, _>>()?
            }
            "--ref-spp" => o.ref_spp = num(&value)?,
            "--meshes" => o.meshes = list(&value),
            "--lightings" => o.lightings = list(&value),
            "--samplers" => o.samplers = list(&value),
            "--cycles" => o.cycles = list(&value),
            "--runs" => o.runs = num(&value)?,
            "--max-depth" => o.max_depth = num(&value)?,
            "--threads" => o.threads = num(&value)?,
            "--out" => o.out = root.join(value),
            _ => unreachable!("checked above"),
        }
    }
    for m in &o.meshes {
        if mesh_spec(m).is_none() {
            return Err(format!("--meshes: unknown mesh {m:?} (beast, nefertiti)"));
        }
    }
    for l in &o.lightings {
        if !matches!(
            l.as_str(),
            "sky" | "sun" | "interior" | "glossy" | "glass" | "emitter" | "lamps" | "character"
        ) {
            return Err(format!(
                "--lightings: unknown lighting {l:?} (sky, sun, interior, glossy, glass, emitter, lamps, character)"
            ));
        }
    }
    for c in &o.cycles {
        if !matches!(c.as_str(), "3.4" | "5" | "5-guided") {
            return Err(format!(
                "--cycles: unknown Cycles {c:?} (3.4: a Blender binary; 5, 5-guided: the bpy module)"
            ));
        }
    }
    if o.spp.is_empty() || o.meshes.is_empty() || o.lightings.is_empty() || o.samplers.is_empty() {
        return Err("--spp, --meshes, --lightings and --samplers may not be empty".into());
    }
    Ok(o)
}
