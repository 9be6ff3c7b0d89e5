//! Light tree build benchmark: the device's build (`light_tree::device`,
//! what every frame runs) against its plain Rust reference
//! (`light_tree::build`, one host thread) on the same emitters, in one run.
//!
//!   cargo bench --bench light_tree [-- --counts 1000,10000,100000,1000000 --runs 5]
//!
//! The emitters are small random triangles scattered through a 16 x 5 x 16
//! box, a third of them double-sided, as a soup of twice as many triangles
//! (every other one emits), with 1000 point lights beside them. The device
//! time is wall-clock from the leaves to the root read back; the host's
//! from its leaves' bounds to its last node. Prints a Markdown table of
//! medians.

use glam::Vec3;
use soupray::cli::report::median;
use soupray::device::{Device, GrowBuffer};
use soupray::scene::{FrameLight, LightKind};
use soupray::trace::light_tree::device::{LightTreeBuilder, LightTreeInputs};
use soupray::trace::light_tree::{self, EmissiveTriangle};
use soupray::trace::lights::DeviceLight;
use soupray::trace::material::{DeviceMaterial, MAT_DOUBLE_SIDED};
use std::time::Instant;

/// A small deterministic generator (xorshift), so every run builds the same
/// scene.
struct Rng(u64);

impl Rng {
    fn f32(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 24) as f32
    }

    fn in_box(&mut self) -> Vec3 {
        Vec3::new(
            self.f32() * 16.0 - 8.0,
            self.f32() * 5.0 + 1.0,
            self.f32() * 16.0 - 8.0,
        )
    }
}

fn arg<T: std::str::FromStr>(args: &[String], name: &str) -> Option<T> {
    let at = args.iter().position(|a| a == name)?;
    args.get(at + 1)?.parse().ok()
}

fn upload<T: Copy>(d: &Device, v: &[T]) -> opencl3::memory::Buffer<T> {
    let mut b = d.buffer::<T>(v.len().max(1)).expect("buffer");
    d.write(&mut b, v).expect("write");
    b
}

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let counts: Vec<usize> = arg::<String>(&args, "--counts")
        .unwrap_or_else(|| "1000,10000,100000,1000000".to_owned())
        .split(',')
        .filter_map(|c| c.trim().parse().ok())
        .collect();
    let runs: usize = arg(&args, "--runs").unwrap_or(5);
    let d = Device::open(None).expect("an OpenCL device");
    let mut builder = LightTreeBuilder::new(&d).expect("the light tree's kernels");
    println!("device: {}", d.info.name);
    println!();
    println!("| emitters | lights | nodes | host reference (ms) | device (ms) | host / device |");
    println!("|---:|---:|---:|---:|---:|---:|");
    for &n in &counts {
        let mut rng = Rng(0x9e37_79b9_7f4a_7c15 ^ n as u64);
        let light_count = 1000;
        let lights: Vec<DeviceLight> = (0..light_count)
            .map(|_| {
                DeviceLight::from_frame_light(&FrameLight {
                    name: None,
                    node: 0,
                    kind: LightKind::Point,
                    color: [1.0, 0.9, 0.8],
                    intensity: 1.0 + rng.f32(),
                    range: None,
                    position: rng.in_box(),
                    direction: Vec3::NEG_Y,
                })
            })
            .collect();
        let triangles = 2 * n;
        let mut positions = vec![[0.0f32; 4]; 3 * triangles];
        let mut power = vec![0.0f32; triangles];
        let mut material_ids = vec![1u32; triangles];
        let prims: Vec<u32> = (0..n as u32).map(|k| 2 * k + 1).collect();
        let mut emitters = Vec::with_capacity(n);
        for (k, &prim) in prims.iter().enumerate() {
            let c = rng.in_box();
            let corners = [
                c,
                c + Vec3::new(0.05, 0.0, 0.0),
                c + Vec3::new(0.0, 0.0, 0.05),
            ];
            let p = 0.5 + rng.f32();
            let two_sided = k % 3 == 0;
            let prim = prim as usize;
            power[prim] = p;
            material_ids[prim] = if two_sided { 0 } else { 1 };
            for (j, v) in corners.iter().enumerate() {
                positions[3 * prim + j] = [v.x, v.y, v.z, 0.0];
            }
            emitters.push(EmissiveTriangle {
                corners: vec![corners],
                power: std::f32::consts::PI * p,
                two_sided,
            });
        }
        let mut materials = [<DeviceMaterial as bytemuck::Zeroable>::zeroed(); 2];
        materials[0].flags = MAT_DOUBLE_SIDED;
        let (pos_buf, ids_buf, mat_buf) = (
            upload(&d, &positions),
            upload(&d, &material_ids),
            upload(&d, &materials),
        );
        let (prim_buf, power_buf, light_buf) =
            (upload(&d, &prims), upload(&d, &power), upload(&d, &lights));
        let trails = upload(&d, &vec![0u32; triangles]);
        let inputs = LightTreeInputs {
            positions: &pos_buf,
            triangles: triangles as u32,
            steps: 1,
            material_ids: &ids_buf,
            materials: &mat_buf,
            material_count: 2,
            prims: &prim_buf,
            emitters: n as u32,
            power: &power_buf,
            lights: &light_buf,
            light_count: light_count as u32,
            light_steps: 1,
        };
        let mut nodes = GrowBuffer::new();
        let (mut host_ms, mut device_ms) = (Vec::new(), Vec::new());
        let mut node_count = 0;
        // One warm-up of each, then `runs` interleaved.
        for run in 0..=runs {
            let t = Instant::now();
            let tree = light_tree::build(&lights, light_count, &emitters);
            let host = t.elapsed().as_secs_f64() * 1e3;
            let t = Instant::now();
            builder.make_leaves(&d, &inputs).expect("leaves");
            let built = builder
                .build(&d, true, &prim_buf, &mut nodes, &trails)
                .expect("build");
            d.finish().expect("finish");
            let device = t.elapsed().as_secs_f64() * 1e3;
            assert_eq!(built.nodes as usize, tree.nodes.len(), "the same tree");
            node_count = built.nodes;
            if run > 0 {
                host_ms.push(host);
                device_ms.push(device);
            }
        }
        let (h, dv) = (median(host_ms), median(device_ms));
        println!(
            "| {n} | {light_count} | {node_count} | {h:.2} | {dv:.2} | {:.1}x |",
            h / dv
        );
    }
}
