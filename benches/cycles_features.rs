//! soupray's features against Blender Cycles: the same glTF, the same
//! settings, one image each, and how far apart they are.
//!
//!   cargo bench --bench cycles_features
//!   cargo bench --bench cycles_features -- --size 320x200 --spp 256 --cases blur
//!
//! Flags (defaults in brackets): `--size WxH` [320x200], `--spp N` [256],
//! `--cases LIST` [still,blur,glass,coats], `--out DIR` [out/bench-cycles-features].
//! `BLENDER=PATH` picks Blender (default `blender` on PATH; without it the
//! bench says so and exits 0; Debian: `apt-get install blender
//! python3-numpy`).
//!
//! The scene (written to OUT/blur.gltf): a camera looking down on white
//! clay objects (soupray `--clay`, Cycles a Diffuse BSDF of 0.8:
//! `benches/cycles/render_cycles.py`) lit by a 3 lux sun from behind the
//! camera against a dark sky of 0.1, so they stand out bright: a box sliding
//! 0.625 units a frame (left to right, frames 0-8) and a bar spinning 90° a
//! frame about the view axis (keys every 30°). Frame 4 is rendered.
//!
//! Cases, each rendered by both renderers at `--spp` with their own seeds:
//! * `still`: no motion blur (checks that both see the same frame);
//! * `blur`: `--motion-blur` at the default shutter (0.5 frame, centred)
//!   against Cycles' motion blur with the same shutter and 4 motion steps
//!   (2^(4-1) = 8 steps, enough that Cycles follows the bar's arc);
//! * `glass` (OUT/glass.gltf, materials as the file gives them, Cycles'
//!   from Blender's importer): a solid glass ball (transmission 1, ior 1.5,
//!   with KHR_materials_volume) in front of a red and a blue box, which it
//!   must show refracted and flipped. soupray's and Cycles' dielectric
//!   models differ a little (the glTF BRDF against the Principled BSDF), so
//!   here the error is not expected at the noise floor; the picture is the
//!   check.
//! * `coats` (OUT/coats.gltf, materials as the file gives them): a red ball
//!   under a clear coat (KHR_materials_clearcoat), the same red uncoated,
//!   and a dark blue ball with a white sheen (KHR_materials_sheen). Blender
//!   3.4's importer maps the coat to the Principled BSDF's clearcoat (a
//!   GTR1 lobe of fixed index 1.5) and the sheen to a Velvet BSDF mixed in,
//!   where glTF asks for GGX and Charlie: the picture is the check.
//!
//! For each case it prints the relative MSE between the renderers (and,
//! for scale, between soupray's image and the other case's Cycles image,
//! and between two Cycles seeds: the noise floor), and writes the images
//! side by side as OUT/CASE.png (soupray left, Cycles right).

use serde_json::json;
use soupray::compare;
use soupray::film::Image;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

/// `WxH`, for `--size`.
fn parse_size(v: &str) -> Result<(u32, u32), String> {
    let (w, h) = v.split_once('x').ok_or("expected WxH")?;
    Ok((
        w.parse().map_err(|_| "expected WxH")?,
        h.parse().map_err(|_| "expected WxH")?,
    ))
}

#[derive(clap::Parser)]
struct Opts {
    #[arg(long, value_parser = parse_size, default_value = "320x200")]
    size: (u32, u32),
    #[arg(long, default_value_t = 256)]
    spp: u32,
    #[arg(long, value_delimiter = ',', default_value = "still,blur,glass,coats")]
    cases: Vec<String>,
    #[arg(long, default_value = "out/bench-cycles-features")]
    out: PathBuf,
    /// Passed by `cargo bench`.
    #[arg(long, hide = true)]
    bench: bool,
}

/// Frames per second of the scene's keys (Blender's importer keys at 24).
const FPS: f32 = 24.0;
/// The frame both renderers render.
const FRAME: i64 = 4;

/// The 12 triangles of a box of half-extents `h` around the origin, flat
/// (each face its own vertices), as positions and normals.
fn box_mesh(h: [f32; 3]) -> (Vec<f32>, Vec<f32>) {
    let (mut p, mut n) = (Vec::new(), Vec::new());
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let (u, v) = ((axis + 1) % 3, (axis + 2) % 3);
            let corner = |a: f32, b: f32| {
                let mut c = [0.0f32; 3];
                c[axis] = sign * h[axis];
                c[u] = a * h[u];
                c[v] = b * h[v];
                c
            };
            let mut quad = [
                corner(-1.0, -1.0),
                corner(1.0, -1.0),
                corner(1.0, 1.0),
                corner(-1.0, 1.0),
            ];
            if sign < 0.0 {
                quad.reverse();
            }
            for k in [0, 1, 2, 0, 2, 3] {
                p.extend_from_slice(&quad[k]);
                let mut normal = [0.0f32; 3];
                normal[axis] = sign;
                n.extend_from_slice(&normal);
            }
        }
    }
    (p, n)
}

/// Writes the blur scene (see the module docs) as a self-contained .gltf.
/// A glTF binary buffer under construction: float accessors, each with
/// its own buffer view.
#[derive(Default)]
struct Buffer {
    bin: Vec<u8>,
    views: Vec<serde_json::Value>,
    accessors: Vec<serde_json::Value>,
}

impl Buffer {
    /// Adds `data` as an accessor of `kind` (with min/max when `bounds`).
    fn push(&mut self, data: &[f32], kind: &str, bounds: bool) -> usize {
        let offset = self.bin.len();
        for f in data {
            self.bin.extend_from_slice(&f.to_le_bytes());
        }
        self.views
            .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": data.len() * 4}));
        let width = match kind {
            "SCALAR" => 1,
            "VEC3" => 3,
            _ => 4,
        };
        let mut acc = json!({"bufferView": self.views.len() - 1, "componentType": 5126,
            "count": data.len() / width, "type": kind});
        if bounds {
            let mut lo = vec![f32::MAX; width];
            let mut hi = vec![f32::MIN; width];
            for c in data.chunks(width) {
                for k in 0..width {
                    lo[k] = lo[k].min(c[k]);
                    hi[k] = hi[k].max(c[k]);
                }
            }
            acc["min"] = json!(lo);
            acc["max"] = json!(hi);
        }
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// A mesh of one primitive from positions and normals.
    fn mesh(&mut self, (p, n): (Vec<f32>, Vec<f32>), material: Option<usize>) -> serde_json::Value {
        let pa = self.push(&p, "VEC3", true);
        let na = self.push(&n, "VEC3", false);
        let mut prim = json!({"attributes": {"POSITION": pa, "NORMAL": na}});
        if let Some(m) = material {
            prim["material"] = json!(m);
        }
        json!({"primitives": [prim]})
    }

    /// Completes `doc` with the buffer (embedded) and writes it.
    fn write(self, mut doc: serde_json::Value, path: &Path) -> std::io::Result<()> {
        doc["buffers"] = json!([{"byteLength": self.bin.len(),
            "uri": format!("data:application/octet-stream;base64,{}", base64(&self.bin))}]);
        doc["bufferViews"] = json!(self.views);
        doc["accessors"] = json!(self.accessors);
        std::fs::write(path, serde_json::to_vec_pretty(&doc).unwrap())
    }
}

/// A UV sphere of radius `r` around the origin (unindexed, smooth normals).
fn sphere_mesh(r: f32, rings: usize, segments: usize) -> (Vec<f32>, Vec<f32>) {
    let at = |i: usize, j: usize| {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        let phi = std::f32::consts::TAU * j as f32 / segments as f32;
        [
            theta.sin() * phi.cos(),
            theta.cos(),
            -theta.sin() * phi.sin(),
        ]
    };
    let (mut p, mut n) = (Vec::new(), Vec::new());
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
            for v in [a, b, c, a, c, d] {
                p.extend(v.map(|x| x * r));
                n.extend(v);
            }
        }
    }
    (p, n)
}

/// The glass case: a solid glass ball (KHR_materials_transmission 1,
/// ior 1.5, KHR_materials_volume, so it refracts rather than being
/// thin-walled) in front of a red and a blue box on a white floor, under a
/// sun and a grey sky.
fn write_glass_scene(path: &Path) -> std::io::Result<()> {
    let mut buf = Buffer::default();
    let meshes = vec![
        buf.mesh(box_mesh([3.0, 0.05, 3.0]), Some(0)),
        buf.mesh(box_mesh([0.4, 0.4, 0.4]), Some(1)),
        buf.mesh(box_mesh([0.4, 0.4, 0.4]), Some(2)),
        buf.mesh(sphere_mesh(0.6, 48, 96), Some(3)),
    ];
    let pbr = |c: [f32; 3], rough: f32| json!({"baseColorFactor": [c[0], c[1], c[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": rough});
    let doc = json!({
        "asset": {"version": "2.0", "generator": "soupray cycles_features bench"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3, 4, 5]}],
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_transmission",
            "KHR_materials_ior", "KHR_materials_volume"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "sun", "type": "directional", "intensity": 3.0}]}},
        "nodes": [
            {"name": "camera", "camera": 0, "translation": [0.0, 0.7, 4.5]},
            // Down -z, tilted 50 degrees about x: from above, behind the camera.
            {"name": "sun", "extensions": {"KHR_lights_punctual": {"light": 0}},
                "rotation": [-0.4226, 0.0, 0.0, 0.9063]},
            {"name": "floor", "mesh": 0, "translation": [0.0, -0.05, 0.0]},
            {"name": "red", "mesh": 1, "translation": [-0.55, 0.4, -0.9]},
            {"name": "blue", "mesh": 2, "translation": [0.55, 0.4, -0.9]},
            {"name": "ball", "mesh": 3, "translation": [0.0, 0.6, 1.2]},
        ],
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": 0.6, "aspectRatio": 1.6, "znear": 0.1, "zfar": 100.0}}],
        "materials": [
            {"name": "floor", "pbrMetallicRoughness": pbr([0.8, 0.8, 0.8], 1.0)},
            {"name": "red", "pbrMetallicRoughness": pbr([0.8, 0.05, 0.05], 0.6)},
            {"name": "blue", "pbrMetallicRoughness": pbr([0.05, 0.1, 0.8], 0.6)},
            {"name": "glass", "pbrMetallicRoughness": pbr([1.0, 1.0, 1.0], 0.0),
                "extensions": {
                    "KHR_materials_transmission": {"transmissionFactor": 1.0},
                    "KHR_materials_ior": {"ior": 1.5},
                    "KHR_materials_volume": {"thicknessFactor": 1.2}}},
        ],
        "meshes": meshes,
    });
    buf.write(doc, path)
}

/// The coats case: three balls on a grey floor under a sun and a grey sky:
/// a rough red dielectric under a smooth clear coat
/// (KHR_materials_clearcoat 1, coat roughness 0.05), the same red without
/// the coat, and a dark blue cloth with a white sheen
/// (KHR_materials_sheen, roughness 0.5).
fn write_coats_scene(path: &Path) -> std::io::Result<()> {
    let mut buf = Buffer::default();
    let meshes = vec![
        buf.mesh(box_mesh([3.0, 0.05, 3.0]), Some(0)),
        buf.mesh(sphere_mesh(0.45, 48, 96), Some(1)),
        buf.mesh(sphere_mesh(0.45, 48, 96), Some(2)),
        buf.mesh(sphere_mesh(0.45, 48, 96), Some(3)),
    ];
    let pbr = |c: [f32; 3], rough: f32| json!({"baseColorFactor": [c[0], c[1], c[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": rough});
    let doc = json!({
        "asset": {"version": "2.0", "generator": "soupray cycles_features bench"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3, 4, 5]}],
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_clearcoat", "KHR_materials_sheen"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "sun", "type": "directional", "intensity": 3.0}]}},
        "nodes": [
            {"name": "camera", "camera": 0, "translation": [0.0, 0.9, 4.0],
                "rotation": [-0.0998, 0.0, 0.0, 0.995]},
            // Down -z, tilted 50 degrees about x, turned 30 degrees about y.
            {"name": "sun", "extensions": {"KHR_lights_punctual": {"light": 0}},
                "rotation": [-0.4082, 0.1094, 0.0468, 0.9050]},
            {"name": "floor", "mesh": 0, "translation": [0.0, -0.05, 0.0]},
            {"name": "coated", "mesh": 1, "translation": [-1.05, 0.45, 0.0]},
            {"name": "plain", "mesh": 2, "translation": [0.0, 0.45, 0.0]},
            {"name": "cloth", "mesh": 3, "translation": [1.05, 0.45, 0.0]},
        ],
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": 0.6, "aspectRatio": 1.6, "znear": 0.1, "zfar": 100.0}}],
        "materials": [
            {"name": "floor", "pbrMetallicRoughness": pbr([0.8, 0.8, 0.8], 1.0)},
            {"name": "coated", "pbrMetallicRoughness": pbr([0.8, 0.05, 0.05], 0.6),
                "extensions": {"KHR_materials_clearcoat": {
                    "clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.05}}},
            {"name": "plain", "pbrMetallicRoughness": pbr([0.8, 0.05, 0.05], 0.6)},
            {"name": "cloth", "pbrMetallicRoughness": pbr([0.02, 0.03, 0.2], 1.0),
                "extensions": {"KHR_materials_sheen": {
                    "sheenColorFactor": [0.9, 0.9, 0.9], "sheenRoughnessFactor": 0.5}}},
        ],
        "meshes": meshes,
    });
    buf.write(doc, path)
}

fn write_blur_scene(path: &Path) -> std::io::Result<()> {
    let mut buf = Buffer::default();
    let meshes = vec![
        buf.mesh(box_mesh([0.5, 0.5, 0.5]), None),
        buf.mesh(box_mesh([1.0, 0.1, 0.1]), None),
    ];
    // The slider: x from -2.5 to 2.5 over frames 0-8, linear.
    let slide_t = buf.push(&[0.0, 8.0 / FPS], "SCALAR", true);
    let slide_x = buf.push(&[-2.5, 0.8, 0.6, 2.5, 0.8, 0.6], "VEC3", false);
    // The spinner: 90 degrees a frame about +z, a key every 30 degrees.
    let keys = 24 * 3 + 1;
    let times: Vec<f32> = (0..keys).map(|k| k as f32 / (3.0 * FPS)).collect();
    let rots: Vec<f32> = (0..keys)
        .flat_map(|k| {
            let half = (k as f32 * 30.0).to_radians() / 2.0;
            [0.0, 0.0, half.sin(), half.cos()]
        })
        .collect();
    let spin_t = buf.push(&times, "SCALAR", true);
    let spin_r = buf.push(&rots, "VEC4", false);
    let doc = json!({
        "asset": {"version": "2.0", "generator": "soupray cycles_features bench"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "extensionsUsed": ["KHR_lights_punctual"],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"name": "sun", "type": "directional", "intensity": 3.0}]}},
        "nodes": [
            {"name": "camera", "camera": 0, "translation": [0.0, 0.0, 7.0]},
            // Shining down -z, tilted 25 degrees about x.
            {"name": "sun", "extensions": {"KHR_lights_punctual": {"light": 0}},
                "rotation": [0.2164, 0.0, 0.0, 0.9763]},
            {"name": "slider", "mesh": 0, "translation": [-2.5, 0.8, 0.6]},
            {"name": "spinner", "mesh": 1, "translation": [0.0, -1.0, 0.6]},
        ],
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": 0.72, "aspectRatio": 1.6, "znear": 0.1, "zfar": 100.0}}],
        "meshes": meshes,
        "animations": [{"name": "move",
            "samplers": [
                {"input": slide_t, "output": slide_x, "interpolation": "LINEAR"},
                {"input": spin_t, "output": spin_r, "interpolation": "LINEAR"}],
            "channels": [
                {"sampler": 0, "target": {"node": 2, "path": "translation"}},
                {"sampler": 1, "target": {"node": 3, "path": "rotation"}}]}],
    });
    buf.write(doc, path)
}

fn base64(bytes: &[u8]) -> String {
    const T: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut s = String::new();
    for c in bytes.chunks(3) {
        let n = (c[0] as u32) << 16
            | (*c.get(1).unwrap_or(&0) as u32) << 8
            | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(T[(n >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

fn soupray(o: &Opts, scene: &Path, extra: &[&str], dir: &Path) -> Result<Image, String> {
    let _ = std::fs::remove_dir_all(dir);
    let out = Command::new(env!("CARGO_BIN_EXE_soupray"))
        .arg("render")
        .arg(scene)
        .args([
            "--frame",
            &FRAME.to_string(),
            "--quiet",
            "--name",
            "img.####.exr",
        ])
        .args([
            "--width",
            &o.size.0.to_string(),
            "--height",
            &o.size.1.to_string(),
        ])
        .args(["--spp", &o.spp.to_string(), "--seed", "1"])
        .args(extra)
        .arg("--out")
        .arg(dir)
        .output()
        .map_err(|e| format!("soupray: {e}"))?;
    if !out.status.success() {
        return Err(format!("soupray: {}", String::from_utf8_lossy(&out.stderr)));
    }
    let exr = dir.join(format!("img.{FRAME:04}.exr"));
    soupray::output::read_exr_rgba(&exr).map_err(|e| format!("{}: {e}", exr.display()))
}

fn cycles(
    o: &Opts,
    blender: &str,
    scene: &Path,
    extra: &[&str],
    seed: u32,
    dir: &Path,
) -> Result<Image, String> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("benches/cycles/render_cycles.py");
    let out = Command::new(blender)
        .args(["-b", "-noaudio", "--factory-startup", "-P"])
        .arg(&script)
        .arg("--")
        .arg("--scene")
        .arg(scene)
        .args([
            "--width",
            &o.size.0.to_string(),
            "--height",
            &o.size.1.to_string(),
        ])
        .args(["--spp", &o.spp.to_string(), "--seed", &seed.to_string()])
        .args(["--frame", &FRAME.to_string()])
        .args(extra)
        .arg("--out-dir")
        .arg(dir)
        .output()
        .map_err(|e| format!("blender: {e}"))?;
    if !out.status.success() {
        return Err(format!(
            "blender: {}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    let exr = dir.join(format!("cycles-spp{}.exr", o.spp));
    soupray::output::read_exr_rgba(&exr).map_err(|e| format!("{}: {e}", exr.display()))
}

/// A comparison: its scene file and each renderer's flags.
struct Case {
    name: &'static str,
    scene: &'static str,
    soupray: &'static [&'static str],
    cycles: &'static [&'static str],
    /// The case whose Cycles image a wrong result would resemble.
    other: Option<&'static str>,
}

const CASES: [Case; 4] = [
    Case {
        name: "still",
        scene: "blur.gltf",
        soupray: &["--clay", "--env-color", "0.1,0.1,0.1"],
        cycles: &["--env", "0.1,0.1,0.1"],
        other: Some("blur"),
    },
    Case {
        name: "blur",
        scene: "blur.gltf",
        soupray: &["--clay", "--env-color", "0.1,0.1,0.1", "--motion-blur"],
        cycles: &[
            "--env",
            "0.1,0.1,0.1",
            "--motion-blur",
            "0.5",
            "--motion-steps",
            "4",
        ],
        other: Some("still"),
    },
    Case {
        name: "glass",
        scene: "glass.gltf",
        soupray: &["--env-color", "0.3,0.3,0.3"],
        cycles: &["--env", "0.3,0.3,0.3", "--keep-materials"],
        other: None,
    },
    Case {
        name: "coats",
        scene: "coats.gltf",
        soupray: &["--env-color", "0.3,0.3,0.3"],
        cycles: &["--env", "0.3,0.3,0.3", "--keep-materials"],
        other: None,
    },
];

/// The two images side by side, tonemapped as `--png` previews are.
fn side_by_side(a: &Image, b: &Image, path: &Path) {
    let (w, h) = (a.width, a.height);
    let (ta, tb) = (
        soupray::output::tonemap_srgb8(a, 0.0),
        soupray::output::tonemap_srgb8(b, 0.0),
    );
    let mut img = image::RgbImage::new(2 * w + 4, h);
    for y in 0..h {
        for x in 0..w {
            let i = ((y * w + x) * 3) as usize;
            img.put_pixel(x, y, image::Rgb([ta[i], ta[i + 1], ta[i + 2]]));
            img.put_pixel(w + 4 + x, y, image::Rgb([tb[i], tb[i + 1], tb[i + 2]]));
        }
    }
    img.save(path).unwrap();
}

fn main() -> ExitCode {
    let o = <Opts as clap::Parser>::parse();
    let blender = std::env::var("BLENDER").unwrap_or_else(|_| "blender".into());
    if Command::new(&blender).arg("--version").output().is_err() {
        eprintln!("bench cycles_features: no Blender ({blender}); skipped");
        return ExitCode::SUCCESS;
    }
    std::fs::create_dir_all(&o.out).unwrap();
    let dir = std::fs::canonicalize(&o.out).unwrap();
    write_blur_scene(&dir.join("blur.gltf")).unwrap();
    write_glass_scene(&dir.join("glass.gltf")).unwrap();
    write_coats_scene(&dir.join("coats.gltf")).unwrap();
    let mut rows = vec![
        "| case | soupray vs Cycles | soupray vs Cycles of the other case | Cycles vs Cycles (seeds) | mean, soupray | mean, Cycles |".to_string(),
        "|---|---:|---:|---:|---:|---:|".to_string(),
    ];
    let mean = |i: &Image| {
        i.rgba
            .iter()
            .map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0)
            .sum::<f64>()
            / i.rgba.len() as f64
    };
    let mut done: Vec<(&str, Image, Image, Image)> = Vec::new();
    for case in CASES.iter().filter(|c| o.cases.iter().any(|n| n == c.name)) {
        let scene = dir.join(case.scene);
        let name = case.name;
        let s = soupray(
            &o,
            &scene,
            case.soupray,
            &o.out.join(format!("soupray-{name}")),
        )
        .unwrap_or_else(|e| panic!("{e}"));
        let [c, c2] = [1, 2].map(|seed| {
            cycles(
                &o,
                &blender,
                &scene,
                case.cycles,
                seed,
                &o.out.join(format!("cycles{seed}-{name}")),
            )
            .unwrap_or_else(|e| panic!("{e}"))
        });
        side_by_side(&s, &c, &o.out.join(format!("{name}.png")));
        done.push((name, s, c, c2));
    }
    for case in CASES.iter() {
        let Some((name, s, c, c2)) = done.iter().find(|d| d.0 == case.name) else {
            continue;
        };
        let e = compare::compare(s, c, 0.0).unwrap();
        let floor = compare::compare(c2, c, 0.0).unwrap();
        let cross = case
            .other
            .and_then(|other| done.iter().find(|d| d.0 == other))
            .map(|d| format!("{:.3e}", compare::compare(s, &d.2, 0.0).unwrap().rel_mse))
            .unwrap_or_default();
        eprintln!(
            "bench cycles_features: {name}: rel. MSE {:.3e}, FLIP {:.4}",
            e.rel_mse, e.flip
        );
        rows.push(format!(
            "| {name} | {:.3e} (FLIP {:.4}) | {cross} | {:.3e} | {:.4} | {:.4} |",
            e.rel_mse,
            e.flip,
            floor.rel_mse,
            mean(s),
            mean(c)
        ));
    }
    let table = rows.join("\n");
    println!(
        "\nsoupray and Cycles ({} spp, {}x{}, frame {FRAME}; scenes in {}):\n\n{table}",
        o.spp,
        o.size.0,
        o.size.1,
        dir.display()
    );
    std::fs::write(o.out.join("results.md"), table + "\n").unwrap();
    ExitCode::SUCCESS
}
