//! Shared scene builders for the path tracer's tests (`common::render`):
//! the analytic geometry of `common::geometry` (spheres, quads, boxes with
//! known winding), cameras and lights made in code, materials, and small
//! statistics helpers.
#![allow(dead_code)]

use glam::{Mat4, Vec3};
use soupray::film::Image;
use soupray::scene::{FrameCamera, FrameLight, LightKind, Material, MaterialTable, Projection};
use soupray::soup::Soup;
use soupray::trace::render::{Environment, Layering, RenderSettings, Traversal};

// Re-exported so `use common::render::*` brings the geometry.
#[allow(unused_imports)]
pub use super::geometry::{cube, ground_plane, push_tri, quad, sphere};

pub fn perspective(eye: Vec3, target: Vec3, up: Vec3, yfov_deg: f32) -> FrameCamera {
    FrameCamera {
        name: None,
        world_from_camera: Mat4::look_at_rh(eye, target, up).inverse(),
        projection: Projection::Perspective {
            yfov: yfov_deg.to_radians(),
            aspect: None,
            znear: 0.01,
            zfar: None,
        },
        from_file: false,
    }
}

/// An orthographic camera at `eye` looking at `target`, half height `ymag`.
pub fn orthographic(eye: Vec3, target: Vec3, up: Vec3, ymag: f32) -> FrameCamera {
    FrameCamera {
        name: None,
        world_from_camera: Mat4::look_at_rh(eye, target, up).inverse(),
        projection: Projection::Orthographic {
            xmag: ymag,
            ymag,
            znear: 0.0,
            zfar: 100.0,
        },
        from_file: false,
    }
}

/// A camera straight above the origin looking down -Y (up on screen is
/// -Z), seeing [-half, half]^2 of the y = 0 plane.
pub fn top_down(half: f32) -> FrameCamera {
    orthographic(Vec3::new(0.0, 10.0, 0.0), Vec3::ZERO, Vec3::NEG_Z, half)
}

/// The world point on y = 0 at the centre of pixel (x, y) of `top_down(half)`
/// for a square image of `size` pixels.
pub fn top_down_point(half: f32, size: u32, x: u32, y: u32) -> Vec3 {
    let sx = ((x as f32 + 0.5) / size as f32) * 2.0 - 1.0;
    let sy = 1.0 - ((y as f32 + 0.5) / size as f32) * 2.0;
    // right = +X, up = -Z
    Vec3::new(sx * half, 0.0, -sy * half)
}

pub fn light(
    kind: LightKind,
    position: Vec3,
    direction: Vec3,
    color: [f32; 3],
    intensity: f32,
) -> FrameLight {
    FrameLight {
        name: None,
        node: 0,
        kind,
        color,
        intensity,
        range: None,
        position,
        direction: direction.normalize(),
    }
}

pub fn material(base: [f32; 4], metallic: f32, roughness: f32) -> Material {
    Material {
        base_color_factor: base,
        metallic_factor: metallic,
        roughness_factor: roughness,
        ..Material::default()
    }
}

pub fn table(materials: Vec<Material>) -> MaterialTable {
    MaterialTable {
        materials,
        ..MaterialTable::default()
    }
}

pub fn settings(size: u32, spp: u32) -> RenderSettings {
    RenderSettings {
        width: size,
        height: size,
        spp,
        seed: 7,
        max_depth: 8,
        clay: false,
        traversal: Traversal::default(),
        sampler: Default::default(),
        noise_pattern: Default::default(),
        adaptive: None,
        time_limit: None,
        environment: Environment::Default,
        aovs: soupray::film::Aovs::NONE,
        energy_compensation: false,
        // The specification's layering, as the renders' expected values
        // assume; the energy layering's tests ask for it.
        layering: Layering::Spec,
        backface_culling: false,
        ..RenderSettings::default()
    }
}

pub fn bits(img: &Image) -> Vec<u32> {
    let mut b: Vec<u32> = img.rgba.iter().flatten().map(|v| v.to_bits()).collect();
    b.extend(img.depth.iter().flatten().map(|v| v.to_bits()));
    b.extend(img.normal.iter().flatten().flatten().map(|v| v.to_bits()));
    b.extend(img.albedo.iter().flatten().flatten().map(|v| v.to_bits()));
    b
}

/// Mean and standard error of the mean of `v`.
pub fn mean_se(v: &[f64]) -> (f64, f64) {
    let n = v.len() as f64;
    let m = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (n - 1.0).max(1.0);
    (m, (var / n).sqrt())
}

/// Luminance-free channel mean of a pixel.
pub fn grey(p: [f32; 4]) -> f64 {
    (p[0] as f64 + p[1] as f64 + p[2] as f64) / 3.0
}

/// The grey values of the pixels an object covers fully (alpha exactly 1).
pub fn covered(img: &Image) -> Vec<f64> {
    img.rgba
        .iter()
        .filter(|p| p[3] == 1.0)
        .map(|p| grey(*p))
        .collect()
}

/// A sphere on a plane, lit by a point light, an emissive quad and a sky:
/// every light path of the integrator is used.
pub fn busy_scene() -> (
    Soup,
    soupray::scene::MaterialTable,
    Vec<soupray::scene::FrameLight>,
) {
    let mut s = Soup::default();
    quad(&mut s, Vec3::ZERO, Vec3::X * 5.0, Vec3::Z * 5.0, Vec3::Y, 0);
    sphere(&mut s, Vec3::new(0.0, 0.6, 0.0), 0.6, 12, 24, 1);
    quad(
        &mut s,
        Vec3::new(1.0, 2.0, 0.5),
        Vec3::X * 0.3,
        Vec3::Z * 0.3,
        Vec3::NEG_Y,
        2,
    );
    let mut emitter = material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
    emitter.emissive_factor = [1.0, 0.9, 0.8];
    emitter.emissive_strength = 5.0;
    let t = table(vec![
        material([0.7, 0.7, 0.7, 1.0], 0.0, 0.8),
        material([0.9, 0.6, 0.3, 1.0], 1.0, 0.35),
        emitter,
    ]);
    let lights = vec![light(
        LightKind::Point,
        Vec3::new(-1.5, 2.5, 1.5),
        Vec3::NEG_Y,
        [1.0; 3],
        8.0,
    )];
    (s, t, lights)
}

pub fn busy_camera() -> soupray::scene::FrameCamera {
    perspective(
        Vec3::new(0.5, 1.5, 3.5),
        Vec3::new(0.0, 0.5, 0.0),
        Vec3::Y,
        45.0,
    )
}
