//! Depth of field: the thin lens's device functions against their Rust
//! references on random input, and rendered blur against the thin-lens
//! circle of confusion: a small emitter out of focus spreads over a disk
//! (or the aperture's polygon) of radius R |1/F - 1/z| on the image plane.

mod common;

use common::render::*;
use common::{run_probe, Rng};
use glam::Vec3;
use soupray::soup::Soup;
use soupray::trace::lens::{camera_aperture_point, camera_lens_ray, Lens};
use soupray::trace::render::{render_soup, Environment, RenderSettings};

#[test]
fn lens_rays_match_the_reference() {
    let d = common::device();
    let program = d.build_program("pt_probe.cl", &[]).unwrap();
    let mut rng = Rng::new(11);
    let mut input = Vec::new();
    let n = 4096;
    for i in 0..n {
        let blades = [0u32, 3, 5, 6, 9][i % 5] as f32;
        let mut v = [0f32; 24];
        v[0] = rng.f32();
        v[1] = rng.f32();
        v[2] = blades;
        v[3] = rng.f32() * 6.0;
        for x in &mut v[4..19] {
            *x = rng.f32() * 4.0 - 2.0;
        }
        // A camera frame: forward unit, d with component 1 along it.
        let fwd = Vec3::new(v[13], v[14], v[15]).normalize();
        let d = fwd + Vec3::new(v[7], v[8], v[9]) * 0.3 + Vec3::new(v[10], v[11], v[12]) * 0.3;
        v[13..16].copy_from_slice(&fwd.to_array());
        v[16..19].copy_from_slice(&d.to_array());
        v[19] = 0.01;
        v[20] = rng.f32() * 0.2;
        v[21] = 0.5 + rng.f32() * 20.0;
        input.push(v);
    }
    let kernel = d.kernel(&program, "pt_lens_probe").unwrap();
    let got: Vec<[f32; 9]> = run_probe(&d, &kernel, &input, n, n);
    for (v, g) in input.iter().zip(&got) {
        let a = camera_aperture_point(v[0], v[1], v[2] as u32, v[3]);
        let p = |k: usize| Vec3::new(v[k], v[k + 1], v[k + 2]);
        let (org, dir, tmin) =
            camera_lens_ray(p(4), p(7), p(10), p(13), p(16), v[19], v[20], v[21], a);
        let want = [a[0], a[1], org.x, org.y, org.z, dir.x, dir.y, dir.z, tmin];
        for (k, (w, g)) in want.iter().zip(g).enumerate() {
            // The device's sin, cos and sqrt may differ by ulps.
            assert!(
                (w - g).abs() <= 1e-5 * (1.0 + w.abs()),
                "output {k} of {v:?}: reference {w}, device {g}"
            );
        }
    }
}

#[test]
fn aperture_points_fill_the_disk_and_the_polygon_uniformly() {
    // Stratified (u, v): the concentric map keeps strata, so the second
    // moment of a uniform unit disk, 1/2, is met closely.
    let n = 256;
    let grid = |f: &dyn Fn(f32, f32) -> [f32; 2]| -> Vec<[f32; 2]> {
        (0..n * n)
            .map(|i| {
                let u = ((i % n) as f32 + 0.5) / n as f32;
                let v = ((i / n) as f32 + 0.5) / n as f32;
                f(u, v)
            })
            .collect()
    };
    let disk = grid(&|u, v| camera_aperture_point(u, v, 0, 0.0));
    let m2: f64 = disk
        .iter()
        .map(|p| (p[0] * p[0] + p[1] * p[1]) as f64)
        .sum::<f64>()
        / disk.len() as f64;
    assert!((m2 - 0.5).abs() < 1e-3, "disk second moment {m2}");
    assert!(disk.iter().all(|p| p[0].hypot(p[1]) <= 1.0 + 1e-6));
    // A hexagon inscribed in the unit circle, rotated: every point inside,
    // and the second moment of a uniform regular hexagon of circumradius 1,
    // 5/12.
    let rot = 0.3f32;
    let hex = grid(&|u, v| camera_aperture_point(u, v, 6, rot));
    let apothem = (std::f32::consts::PI / 6.0).cos();
    for p in &hex {
        for k in 0..6 {
            let mid = rot + (k as f32 + 0.5) * std::f32::consts::PI / 3.0;
            let along = p[0] * mid.cos() + p[1] * mid.sin();
            assert!(along <= apothem + 1e-5, "{p:?} outside edge {k}");
        }
    }
    let m2: f64 = hex
        .iter()
        .map(|p| (p[0] * p[0] + p[1] * p[1]) as f64)
        .sum::<f64>()
        / hex.len() as f64;
    assert!((m2 - 5.0 / 12.0).abs() < 2e-3, "hexagon second moment {m2}");
}

const SIZE: u32 = 128;
const YFOV_DEG: f32 = 30.0;
/// The emitter: a small sphere on the axis at depth `DEPTH`, large enough
/// that every pixel of its blur sees it through many lens samples.
const DEPTH: f32 = 5.0;
const EMITTER_RADIUS: f32 = 0.1;

/// A small white emitter on the view axis under a black sky, rendered
/// through `lens`; the image's luminance.
fn render_emitter(lens: Option<Lens>, spp: u32) -> Vec<f64> {
    let d = common::device();
    let mut soup = Soup::default();
    sphere(
        &mut soup,
        Vec3::new(0.0, 0.0, -DEPTH),
        EMITTER_RADIUS,
        12,
        24,
        0,
    );
    let mut glow = material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
    glow.emissive_factor = [1.0; 3];
    let camera = perspective(Vec3::ZERO, Vec3::new(0.0, 0.0, -1.0), Vec3::Y, YFOV_DEG);
    let settings = RenderSettings {
        environment: Environment::Color([0.0; 3]),
        max_depth: 1,
        lens,
        ..settings(SIZE, spp)
    };
    let out = render_soup(&d, &soup, &table(vec![glow]), &camera, &[], &settings, 0).unwrap();
    out.image.rgba.iter().map(|&p| grey(p)).collect()
}

/// Pixels per unit of the image plane at distance 1.
fn pixels_per_unit() -> f64 {
    SIZE as f64 / 2.0 / (0.5 * YFOV_DEG.to_radians() as f64).tan()
}

/// The lit disk's radius in pixels from the image's second moment about
/// its centroid (a uniform disk of radius r has E[rho^2] = r^2 / 2), less
/// the emitter's own image and the pixel filter's spread.
fn blur_radius(img: &[f64]) -> (f64, f64, f64) {
    let total: f64 = img.iter().sum();
    let (mut cx, mut cy) = (0.0, 0.0);
    for (i, v) in img.iter().enumerate() {
        cx += v * ((i as u32 % SIZE) as f64 + 0.5);
        cy += v * ((i as u32 / SIZE) as f64 + 0.5);
    }
    cx /= total;
    cy /= total;
    let mut m2 = 0.0;
    for (i, v) in img.iter().enumerate() {
        let dx = (i as u32 % SIZE) as f64 + 0.5 - cx;
        let dy = (i as u32 / SIZE) as f64 + 0.5 - cy;
        m2 += v * (dx * dx + dy * dy);
    }
    m2 /= total;
    // The sphere's own image: a disk of radius tan(asin(rho / z)).
    let (rho, z) = (EMITTER_RADIUS as f64, DEPTH as f64);
    let own = rho / (z * z - rho * rho).sqrt() * pixels_per_unit();
    // Blackman-Harris of radius 1.5 px: a standard deviation of about
    // 0.42 px per axis.
    let filter = 2.0 * 0.42f64 * 0.42;
    let r2 = 2.0 * (m2 - 0.5 * own * own - filter);
    (r2.max(0.0).sqrt(), cx, cy)
}

#[test]
fn an_emitter_out_of_focus_spreads_over_the_circle_of_confusion() {
    let focus = 0.5;
    let lens = Lens {
        f_stop: 0.9,
        focus_distance: focus,
        blades: 0,
        blade_rotation: 0.0,
        focal_mm: None,
    };
    let half = (0.5 * YFOV_DEG.to_radians()).tan();
    let radius = lens.radius(half, half) as f64;
    let want = radius * (1.0 / focus as f64 - 1.0 / DEPTH as f64) * pixels_per_unit();
    assert!(want > 10.0 && want < 30.0, "the test's blur: {want} px");
    let blurred = render_emitter(Some(lens), 512);
    let (got, cx, cy) = blur_radius(&blurred);
    eprintln!("circle of confusion: {got:.3} px rendered, {want:.3} px by the thin lens");
    assert!(
        (got - want).abs() < 0.02 * want,
        "circle of confusion: {got:.3} px rendered, {want:.3} px by the thin lens"
    );
    let centre = SIZE as f64 / 2.0;
    assert!(
        (cx - centre).abs() < 0.1 && (cy - centre).abs() < 0.1,
        "centroid {cx}, {cy}"
    );
    // The lens moves light, it does not make or lose it: the image's total
    // is the pinhole's.
    let sharp = render_emitter(None, 64);
    let (a, b): (f64, f64) = (blurred.iter().sum(), sharp.iter().sum());
    assert!(
        (a / b - 1.0).abs() < 0.02,
        "total {a} through the lens, {b} without"
    );
}

#[test]
fn an_emitter_in_focus_stays_sharp() {
    let lens = Lens {
        f_stop: 0.9,
        focus_distance: DEPTH,
        blades: 0,
        blade_rotation: 0.0,
        focal_mm: None,
    };
    let (focused, ..) = blur_radius(&render_emitter(Some(lens), 64));
    let (pinhole, ..) = blur_radius(&render_emitter(None, 64));
    assert!(
        focused < 1.0 && (focused - pinhole).abs() < 0.3,
        "in focus {focused:.3} px, pinhole {pinhole:.3} px"
    );
}

#[test]
fn a_six_bladed_aperture_makes_hexagonal_bokeh() {
    // The lit area: a hexagon inscribed in the circle of confusion, 0.827
    // of the disk (counted as the pixels above half the bokeh's level).
    let focus = 0.5;
    let area = |blades: u32| -> (f64, f64) {
        let lens = Lens {
            f_stop: 0.5,
            focus_distance: focus,
            blades,
            blade_rotation: 0.0,
            focal_mm: None,
        };
        let half = (0.5 * YFOV_DEG.to_radians()).tan();
        let r = lens.radius(half, half) as f64
            * (1.0 / focus as f64 - 1.0 / DEPTH as f64)
            * pixels_per_unit();
        let img = render_emitter(Some(lens), 512);
        // The bokeh's level: the mean of the 9 x 9 pixels at its centre.
        let c = SIZE as usize / 2;
        let level = (c - 4..=c + 4)
            .flat_map(|y| (c - 4..=c + 4).map(move |x| (x, y)))
            .map(|(x, y)| img[y * SIZE as usize + x])
            .sum::<f64>()
            / 81.0;
        let lit = img.iter().filter(|&&v| v > 0.5 * level).count() as f64;
        (lit, r)
    };
    let (disk, r) = area(0);
    let (hexagon, _) = area(6);
    eprintln!("bokeh of radius {r:.2} px: disk {disk} px lit, hexagon {hexagon} px lit");
    assert!(r > 15.0 && r < 40.0, "the test's blur: {r} px");
    let pi = std::f64::consts::PI;
    assert!(
        (disk / (pi * r * r) - 1.0).abs() < 0.04,
        "disk bokeh: {disk} px lit, pi r^2 = {:.0}",
        pi * r * r
    );
    let hex_area = 1.5 * 3f64.sqrt() * r * r;
    assert!(
        (hexagon / hex_area - 1.0).abs() < 0.04,
        "hexagonal bokeh: {hexagon} px lit, a hexagon of circumradius {r:.1} px has {hex_area:.0}"
    );
}

#[test]
fn an_aperture_without_a_focus_distance_is_refused_with_the_fix() {
    let out = common::soupray_cmd()
        .args(["render", "--aperture", "2.8", "--frames", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--focus-distance"), "{err}");
    let out = common::soupray_cmd()
        .args(["render", "--focus-distance", "3", "--frames", "0"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--aperture"), "{err}");
}

/// The walker's generator, scripts/make-walker.py: the distance from the
/// camera to the hips along its view at time `t`, where the camera's keys
/// fall (every quarter second) and so is exactly `camera_at(t)`.
fn walker_hips_distance(t: f64) -> f64 {
    let (speed, start_z, gait) = (1.4, -1.4, 1.0);
    let walker = start_z + speed * t;
    let eye = Vec3::new(
        (4.4 - 0.4 * t) as f32,
        (1.55 + 0.1 * t) as f32,
        (walker - 2.8 + 1.0 * t) as f32,
    );
    let target = Vec3::new(0.0, 0.85, (walker + 0.3) as f32);
    let phase = 2.0 * std::f64::consts::PI * t / gait;
    let hips = Vec3::new(
        0.0,
        (0.95 + 0.025 * (2.0 * phase).cos()) as f32,
        walker as f32,
    );
    (hips - eye).dot((target - eye).normalize()) as f64
}

#[test]
fn focus_on_a_node_follows_it_frame_by_frame() {
    let dir = tempfile::tempdir().unwrap();
    let out = common::soupray_cmd()
        .current_dir(common::repo())
        .args([
            "render", "--frames", "0,24", "--spp", "1", "--width", "32", "--height", "18",
        ])
        .args([
            "--aperture",
            "2.8",
            "--focus-on",
            "hips",
            "--quiet",
            "--out",
        ])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for (frame, t) in [(0, 0.0), (24, 1.0)] {
        let log: serde_json::Value = serde_json::from_slice(
            &std::fs::read(dir.path().join(format!("walker.{frame:04}.json"))).unwrap(),
        )
        .unwrap();
        let got = log["camera"]["focus_distance"].as_f64().unwrap();
        let want = walker_hips_distance(t);
        assert!(
            (got - want).abs() < 1e-3,
            "frame {frame}: focus {got} m, the hips are {want} m away"
        );
        assert_eq!(log["camera"]["f_stop"].as_f64(), Some(2.8f32 as f64));
    }
    // A name the file lacks is refused with the names it has.
    let out = common::soupray_cmd()
        .current_dir(common::repo())
        .args([
            "render",
            "--frames",
            "0",
            "--aperture",
            "2.8",
            "--focus-on",
            "tail",
        ])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("--focus-on tail") && err.contains("hips"),
        "{err}"
    );
}

/// The draft EXT_camera_physical: a camera's `focalLength` is read (with
/// one warning that the extension is a draft) and sets the lens radius
/// `--aperture` opens, f / (2 N); without it the radius follows Blender's
/// 36 mm sensor.
#[test]
fn ext_camera_physical_sets_the_focal_length_of_the_lens() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("physical.gltf");
    let root = serde_json::json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["EXT_camera_physical"],
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"camera": 0}],
        "cameras": [{
            "type": "perspective",
            "perspective": {"yfov": 0.5, "znear": 0.1},
            "extensions": {"EXT_camera_physical": {"focalLength": 85.0, "sensorSize": [36.0, 24.0]}}
        }],
    });
    std::fs::write(&path, serde_json::to_string(&root).unwrap()).unwrap();
    let scene = soupray::scene::Scene::load(&path, &Default::default()).unwrap();
    assert_eq!(scene.cameras()[0].focal_mm, Some(85.0));
    let drafts: Vec<_> = scene
        .warnings()
        .iter()
        .filter(|w| w.contains("EXT_camera_physical is a draft"))
        .collect();
    assert_eq!(drafts.len(), 1, "{:?}", scene.warnings());
    let lens = Lens {
        f_stop: 2.0,
        focus_distance: 3.0,
        blades: 0,
        blade_rotation: 0.0,
        focal_mm: Some(85.0),
    };
    // 85 mm at f/2: a 21.25 mm radius, whatever the field of view.
    assert!((lens.radius(0.4, 0.3) - 0.02125).abs() < 1e-7);
    // Blender's convention: 18 mm over the wider half extent.
    let blender = Lens {
        focal_mm: None,
        ..lens
    };
    assert!((blender.radius(0.4, 0.3) - 0.01125).abs() < 1e-7);
}
