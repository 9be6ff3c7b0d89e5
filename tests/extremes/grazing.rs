//! Grazing views and grazing light: no self-intersection acne.

use super::*;

#[test]
fn grazing_views_and_grazing_light_have_no_acne() {
    let d = common::device();
    let dir = tempfile::tempdir().unwrap();
    // A 800 x 800 plane cut into 32 x 32 quads, tilted by an arbitrary
    // rotation so its vertices and hit points carry rounding error in every
    // coordinate (an axis-aligned plane at y = 0 would be exact). The camera
    // is 0.02 above it, looking 1 degree down: rays meet the plane at angles
    // from 16 degrees down to 0.003 degrees at its far edge. The sun is
    // 0.25 degrees above the plane.
    let tilt = Quat::from_axis_angle(Vec3::new(1.0, 2.0, 3.0).normalize(), 0.7);
    let to_world = |p: Vec3| tilt * p + Vec3::new(3.0, -2.0, 1.0);
    let (n, h) = (32u32, 400.0f32);
    let mut positions = Vec::new();
    for i in 0..=n {
        for j in 0..=n {
            let p = Vec3::new(
                -h + 2.0 * h * i as f32 / n as f32,
                0.0,
                -h + 2.0 * h * j as f32 / n as f32,
            );
            positions.push(to_world(p).to_array());
        }
    }
    let mut indices = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (a, b) = (i * (n + 1) + j, (i + 1) * (n + 1) + j);
            // +Y facing: (x, z) → (x, z + 1) → (x + 1, z + 1).
            indices.extend([a, a + 1, b + 1, a, b + 1, b]);
        }
    }
    let plane = |material: Value| Part {
        name: "plane",
        positions: positions.clone(),
        normals: None,
        indices: indices.clone(),
        material,
    };
    let elevation = 0.25f32.to_radians();
    let sun_dir = tilt * Vec3::new(0.0, -elevation.sin(), -elevation.cos());
    let eye = to_world(Vec3::new(0.0, 0.02, 350.0));
    let spec = |material: Value| Spec {
        parts: vec![plane(material)],
        eye,
        target: eye + tilt * Vec3::new(0.0, -(1f32.to_radians().tan()), -1.0),
        up: tilt * Vec3::Y,
        yfov: 30f32.to_radians(),
        znear: 0.001,
        lamps: vec![Lamp::Sun(sun_dir, 100.0)],
        scale: 1.0,
        offset: Vec3::ZERO,
    };

    // Direct light only, no sky (so next-event estimation always picks the
    // sun): every fully covered pixel is rho/pi * E * sin(elevation), with
    // no noise (a delta light on a flat plane). Acne (a shadow ray hitting
    // the plane it left) would make pixels darker or black.
    let mut st = settings(8, 7);
    st.clay = true;
    st.max_depth = 1;
    st.environment = Environment::Default;
    let f = render(
        &d,
        &write(&spec(diffuse([1.0; 3])), dir.path(), "direct"),
        &st,
        Tree::Device,
    );
    let want = 0.8 / std::f64::consts::PI * 100.0 * (elevation as f64).sin();
    let (full, none) = coverage(&f.image);
    assert!(
        full > f.image.rgba.len() * 4 / 10 && none > f.image.rgba.len() / 4,
        "the plane covers {full} pixels, the sky {none}"
    );
    for (i, p) in f.image.rgba.iter().enumerate() {
        if p[3] == 1.0 {
            assert!(
                (grey(p) / want - 1.0).abs() < 0.01,
                "pixel {i} (row {}) is {p:?}, expected {want}",
                i as u32 / WIDTH
            );
        }
    }

    // Everything on: sky, bounces, a glossy dielectric (grazing Fresnel).
    // No pixel is NaN or black, and none is a speckle: every covered
    // pixel is within [0.5, 2] times the median of its covered neighbours.
    let mut st = settings(64, 7);
    st.environment = Environment::Color([0.3, 0.35, 0.4]);
    let glossy = json!({"pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.6, 0.6, 1.0],
        "metallicFactor": 0.0, "roughnessFactor": 0.4}});
    let f = render(
        &d,
        &write(&spec(glossy), dir.path(), "all"),
        &st,
        Tree::Device,
    );
    let img = &f.image;
    let (w, hh) = (WIDTH as i64, HEIGHT as i64);
    let mut checked = 0;
    for y in 0..hh {
        for x in 0..w {
            let p = img.rgba[(y * w + x) as usize];
            if p[3] != 1.0 {
                continue;
            }
            let mut nb: Vec<f64> = Vec::new();
            for (dx, dy) in [
                (-1, -1),
                (0, -1),
                (1, -1),
                (-1, 0),
                (1, 0),
                (-1, 1),
                (0, 1),
                (1, 1),
            ] {
                let (u, v) = (x + dx, y + dy);
                if (0..w).contains(&u) && (0..hh).contains(&v) {
                    let q = img.rgba[(v * w + u) as usize];
                    if q[3] == 1.0 {
                        nb.push(grey(&q));
                    }
                }
            }
            if nb.len() < 3 {
                continue;
            }
            nb.sort_by(f64::total_cmp);
            let median = nb[nb.len() / 2];
            let g = grey(&p);
            assert!(
                g > 0.0 && g >= 0.5 * median && g <= 2.0 * median,
                "pixel ({x}, {y}) is {g}, its neighbours' median {median}"
            );
            checked += 1;
        }
    }
    assert!(checked > img.rgba.len() / 3, "{checked} pixels checked");
}
