//! Soup evaluation benchmark: the device soup stage (`DeviceSoup`) against
//! the BVH build of the same soup and the CPU reference evaluator, on a
//! generated ~100K-triangle skinned mesh, in one run.
//!
//!   cargo bench --bench soup_eval
//!
//! The mesh is a finely tessellated cylinder (normals, uvs) bent by a chain
//! of animated joints, each vertex blended between its two nearest joints,
//! written as a glTF file into a temporary directory. Over 20 frames of its
//! clip the benchmark prints a Markdown table of medians: the soup kernels'
//! device time (profiling events), the soup's wall-clock time per frame
//! (pose on the host, upload, kernels), the BVH build of that soup straight
//! from the device buffer (wall and kernel time), and `Scene::evaluate`.

use serde_json::json;
use soupray::bvh::device_builder::DeviceBuilder;
use soupray::bvh::BuildParams;
use soupray::cli::report::median;
use soupray::device::Device;
use soupray::scene::{LoadOptions, Scene};
use soupray::soup::device::DeviceSoup;
use std::path::{Path, PathBuf};
use std::time::Instant;

const SEGMENTS: usize = 200;
const RINGS: usize = 250;
const JOINTS: usize = 8;
const HEIGHT: f32 = 10.0;
const RADIUS: f32 = 0.6;
const KEYS: usize = 25;
const FRAMES: i64 = 20;

fn bytes<T: bytemuck::Pod>(v: &[T]) -> &[u8] {
    bytemuck::cast_slice(v)
}

/// Writes the skinned cylinder as `cylinder.gltf` + `.bin` into `dir`.
fn skinned_cylinder(dir: &Path) -> PathBuf {
    let mut pos = Vec::new();
    let mut nrm = Vec::new();
    let mut uv = Vec::new();
    let mut joints: Vec<u16> = Vec::new();
    let mut weights = Vec::new();
    let segment = HEIGHT / (JOINTS - 1) as f32;
    for r in 0..=RINGS {
        let y = HEIGHT * r as f32 / RINGS as f32;
        // Blend between the two joints around this height.
        let s = (y / segment).min((JOINTS - 1) as f32 - 1e-4);
        let j = s.floor() as u16;
        let f = s - j as f32;
        for k in 0..SEGMENTS {
            let a = std::f32::consts::TAU * k as f32 / SEGMENTS as f32;
            let (sin, cos) = a.sin_cos();
            pos.extend_from_slice(&[RADIUS * cos, y, RADIUS * sin]);
            nrm.extend_from_slice(&[cos, 0.0, sin]);
            uv.extend_from_slice(&[k as f32 / SEGMENTS as f32, r as f32 / RINGS as f32]);
            joints.extend_from_slice(&[j, j + 1, 0, 0]);
            weights.extend_from_slice(&[1.0 - f, f, 0.0, 0.0]);
        }
    }
    let mut indices: Vec<u32> = Vec::new();
    for r in 0..RINGS {
        for k in 0..SEGMENTS {
            let a = (r * SEGMENTS + k) as u32;
            let b = (r * SEGMENTS + (k + 1) % SEGMENTS) as u32;
            let c = a + SEGMENTS as u32;
            let d = b + SEGMENTS as u32;
            indices.extend_from_slice(&[a, c, b, b, c, d]);
        }
    }
    // Joint j sits at height j * segment, a child of joint j - 1; its
    // inverse bind matrix undoes that height.
    let mut ibm = Vec::new();
    for j in 0..JOINTS {
        let mut m = [0.0f32; 16];
        m[0] = 1.0;
        m[5] = 1.0;
        m[10] = 1.0;
        m[15] = 1.0;
        m[13] = -(j as f32) * segment;
        ibm.extend_from_slice(&m);
    }
    let times: Vec<f32> = (0..KEYS).map(|k| k as f32 / (KEYS - 1) as f32).collect();

    let mut bin: Vec<u8> = Vec::new();
    let mut views = Vec::new();
    let mut accessors = Vec::new();
    let mut add = |data: &[u8],
                   component: u32,
                   count: usize,
                   ty: &str,
                   extra: serde_json::Value| {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        views.push(json!({"buffer": 0, "byteOffset": bin.len(), "byteLength": data.len()}));
        bin.extend_from_slice(data);
        let mut acc = json!({"bufferView": views.len() - 1, "componentType": component, "count": count, "type": ty});
        if let (Some(a), Some(e)) = (acc.as_object_mut(), extra.as_object()) {
            a.extend(e.clone());
        }
        accessors.push(acc);
        accessors.len() - 1
    };
    let nverts = pos.len() / 3;
    let p = add(
        bytes(&pos),
        5126,
        nverts,
        "VEC3",
        json!({"min": [-RADIUS, 0.0, -RADIUS], "max": [RADIUS, HEIGHT, RADIUS]}),
    );
    let n = add(bytes(&nrm), 5126, nverts, "VEC3", json!({}));
    let t = add(bytes(&uv), 5126, nverts, "VEC2", json!({}));
    let jo = add(bytes(&joints), 5123, nverts, "VEC4", json!({}));
    let w = add(bytes(&weights), 5126, nverts, "VEC4", json!({}));
    let i = add(bytes(&indices), 5125, indices.len(), "SCALAR", json!({}));
    let ib = add(bytes(&ibm), 5126, JOINTS, "MAT4", json!({}));
    let tm = add(
        bytes(&times),
        5126,
        KEYS,
        "SCALAR",
        json!({"min": [0.0], "max": [1.0]}),
    );
    let mut channels = Vec::new();
    let mut samplers = Vec::new();
    for j in 0..JOINTS {
        // Each joint swings about z and x with its own phase.
        let mut q = Vec::new();
        for k in 0..KEYS {
            let phase = std::f32::consts::TAU * (k as f32 / (KEYS - 1) as f32 + j as f32 * 0.13);
            let half = 0.5 * 0.25 * phase.sin();
            let half_x = 0.5 * 0.15 * (2.0 * phase).cos();
            let qz = glam::Quat::from_xyzw(0.0, 0.0, half.sin(), half.cos());
            let qx = glam::Quat::from_xyzw(half_x.sin(), 0.0, 0.0, half_x.cos());
            q.extend_from_slice(&(qz * qx).normalize().to_array());
        }
        let out = add(bytes(&q), 5126, KEYS, "VEC4", json!({}));
        samplers.push(json!({"input": tm, "output": out}));
        channels.push(json!({"sampler": j, "target": {"node": j + 1, "path": "rotation"}}));
    }
    let mut nodes = vec![json!({"name": "cylinder", "mesh": 0, "skin": 0})];
    for j in 0..JOINTS {
        let mut node = json!({"name": format!("joint{j}"),
            "translation": [0.0, if j == 0 { 0.0 } else { segment }, 0.0]});
        if j + 1 < JOINTS {
            node["children"] = json!([j + 2]);
        }
        nodes.push(node);
    }
    std::fs::write(dir.join("cylinder.bin"), &bin).expect("write cylinder.bin");
    let root = json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": nodes,
        "skins": [{"joints": (1..=JOINTS).collect::<Vec<_>>(), "inverseBindMatrices": ib}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": t,
            "JOINTS_0": jo, "WEIGHTS_0": w}, "indices": i}]}],
        "animations": [{"channels": channels, "samplers": samplers}],
        "buffers": [{"byteLength": bin.len(), "uri": "cylinder.bin"}],
        "bufferViews": views,
        "accessors": accessors,
    });
    let path = dir.join("cylinder.gltf");
    std::fs::write(&path, serde_json::to_string(&root).expect("json"))
        .expect("write cylinder.gltf");
    path
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = tempfile::tempdir()?;
    let path = skinned_cylinder(dir.path());
    let scene = Scene::load(&path, &LoadOptions::default())?;
    let device = Device::open(None)?;
    let mut soup = DeviceSoup::new(&device, &scene)?;
    let mut builder = DeviceBuilder::new(&device, BuildParams::default())?;
    let n = soup.triangle_count();

    // Warm-up: first launches compile lazily in some drivers, and the CPU
    // reference computes its default camera's clip bounds once.
    // (At a time no measured frame uses, so none of them reuses its soup.)
    scene.evaluate(0.777)?;
    soup.evaluate(&scene, 0.777)?;
    builder.build_from_device(soup.positions(), n)?;

    let (first, last) = scene.frame_range();
    let diag = {
        let (lo, hi) = scene.clip_bounds()?;
        (hi - lo).length()
    };
    let mut soup_kernel = Vec::new();
    let mut deform = Vec::new();
    let mut assemble = Vec::new();
    let mut soup_wall = Vec::new();
    let mut bvh_wall = Vec::new();
    let mut bvh_kernel = Vec::new();
    let mut cpu = Vec::new();
    let mut worst = 0.0f32;
    for s in 0..FRAMES {
        let frame = first + (last - first) * s / (FRAMES - 1);
        // Distinct times so no frame reuses the previous soup.
        let t = scene.time_of_frame(frame) + 1e-3 * s as f64 / FRAMES as f64;
        device.take_timings()?;
        let start = Instant::now();
        let info = soup.evaluate(&scene, t)?;
        soup_wall.push(start.elapsed().as_secs_f64() * 1e3);
        assert!(!info.reused);
        let timings = device.take_timings()?;
        soup_kernel.push(timings.ms("soup"));
        deform.push(timings.ms("soup/deform"));
        assemble.push(timings.ms("soup/assemble"));

        let (_, stats) = builder.build_from_device(soup.positions(), n)?;
        bvh_wall.push(stats.build_ms);
        let s = stats.stages_ms;
        bvh_kernel.push(s.prepare + s.large + s.medium + s.small);

        let start = Instant::now();
        let reference = scene.evaluate(t)?;
        cpu.push(start.elapsed().as_secs_f64() * 1e3);
        let got = soup.read_back()?;
        for (a, b) in got.positions.iter().zip(&reference.soup.positions) {
            for k in 0..3 {
                worst = worst.max((a[k] - b[k]).abs());
            }
        }
    }
    assert!(
        worst <= 1e-5 * diag,
        "device soup differs from the CPU by {worst}"
    );

    println!(
        "Skinned cylinder: {n} triangles, {} vertices, {JOINTS} joints (2 influences a vertex), \
         normals + uvs; {FRAMES} frames; device: {} ({}); worst corner difference from the CPU \
         reference {:.1e} of the diagonal",
        scene.meshes()[0].primitives[0].vertex_count(),
        device.info.name,
        device.info.platform,
        worst / diag
    );
    println!();
    println!("| stage | median ms |");
    println!("|---|---:|");
    println!(
        "| device soup, kernels (soup/deform + soup/assemble, profiling events) | {:.2} |",
        median(soup_kernel.clone())
    );
    println!(
        "| of which soup/deform (per vertex) | {:.2} |",
        median(deform)
    );
    println!(
        "| of which soup/assemble (per triangle) | {:.2} |",
        median(assemble)
    );
    println!(
        "| device soup, wall per frame (pose on host + upload + kernels) | {:.2} |",
        median(soup_wall)
    );
    println!(
        "| BVH build from the device soup, kernels | {:.2} |",
        median(bvh_kernel.clone())
    );
    println!(
        "| BVH build from the device soup, wall | {:.2} |",
        median(bvh_wall.clone())
    );
    println!("| CPU reference `Scene::evaluate` | {:.2} |", median(cpu));
    println!();
    println!(
        "Soup kernels / BVH build wall: {:.1}%",
        100.0 * median(soup_kernel) / median(bvh_wall)
    );
    Ok(())
}
