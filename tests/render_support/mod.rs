//! Shared scene builders for the path tracer's tests: analytic geometry
//! (spheres, quads, boxes) with known winding, cameras and lights made in
//! code, materials, and small statistics helpers.
#![allow(dead_code)]

use glam::{Mat4, Vec3};
use soupray::film::Image;
use soupray::scene::{FrameCamera, FrameLight, LightKind, Material, MaterialTable, Projection};
use soupray::soup::Soup;
use soupray::trace::render::{Environment, RenderSettings, Traversal};

/// Appends triangle (a, b, c), wound so that its geometric normal points
/// along `outward`, with material `mat`.
pub fn push_tri(soup: &mut Soup, a: Vec3, b: Vec3, c: Vec3, outward: Vec3, mat: u32) {
    let n = (b - a).cross(c - a);
    let (b, c) = if n.dot(outward) < 0.0 { (c, b) } else { (b, c) };
    for p in [a, b, c] {
        soup.positions.push([p.x, p.y, p.z, 0.0]);
    }
    soup.material_ids.push(mat);
}

/// A flat-shaded UV sphere (convex polyhedron), outward facing.
pub fn sphere(soup: &mut Soup, center: Vec3, r: f32, lat: usize, lon: usize, mat: u32) {
    let p = |i: usize, j: usize| {
        let th = std::f32::consts::PI * i as f32 / lat as f32;
        let ph = std::f32::consts::TAU * j as f32 / lon as f32;
        center + r * Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
    };
    for i in 0..lat {
        for j in 0..lon {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            let mid = (a + b + c + d) * 0.25 - center;
            if i != lat - 1 {
                push_tri(soup, a, b, c, mid, mat);
            }
            if i != 0 {
                push_tri(soup, a, c, d, mid, mat);
            }
        }
    }
}

/// A rectangle centred at `c` spanned by half-axes `u`, `v`, facing `n`.
pub fn quad(soup: &mut Soup, c: Vec3, u: Vec3, v: Vec3, n: Vec3, mat: u32) {
    let (a, b, cc, d) = (c - u - v, c + u - v, c + u + v, c - u + v);
    push_tri(soup, a, b, cc, n, mat);
    push_tri(soup, a, cc, d, n, mat);
}

/// An axis-aligned box, outward facing.
/// A 100 x 100 ground plane through the origin, facing +Y, material 0.
pub fn ground_plane() -> Soup {
    let mut s = Soup::default();
    quad(
        &mut s,
        Vec3::ZERO,
        Vec3::X * 50.0,
        Vec3::Z * 50.0,
        Vec3::Y,
        0,
    );
    s
}

pub fn cube(soup: &mut Soup, c: Vec3, h: f32, mat: u32) {
    for axis in 0..3 {
        for s in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = s;
            let mut u = Vec3::ZERO;
            u[(axis + 1) % 3] = h;
            let mut v = Vec3::ZERO;
            v[(axis + 2) % 3] = h;
            quad(soup, c + n * h, u, v, n, mat);
        }
    }
}

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
        backface_culling: false,
        lens: None,
        transparent: false,
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
