//! The path tracer against analytic values: furnaces (diffuse and GGX
//! spheres under a uniform environment), a point light, a spot cone and a
//! directional light over a Lambertian plane, an emissive rectangle over a
//! plane (the rectangle's form factor), and an equirectangular map against
//! its irradiance summed texel by texel; and the light selection: a sun
//! over a sky (noise-free), more point lights than are looped over, and an
//! emitter, a sky and a point light together.

mod common;

use common::render::*;
use glam::Vec3;
use soupray::scene::LightKind;
use soupray::soup::Soup;
use soupray::trace::lights::LOOPED_PUNCTUAL_MAX;
use soupray::trace::material::{bsdf_eval, bsdf_sample, BsdfParams};
use soupray::trace::render::{render_soup, Environment, LightTreeUse};
use soupray::trace::sampling::Sampler;

const PI: f64 = std::f64::consts::PI;

fn sphere_scene() -> Soup {
    let mut s = Soup::default();
    sphere(&mut s, Vec3::ZERO, 1.0, 16, 32, 0);
    s
}

#[test]
fn furnace_clay_sphere_returns_albedo_times_environment() {
    let d = common::device();
    let cam = perspective(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    let mut st = settings(32, 128);
    st.clay = true;
    st.environment = Environment::Color([1.0, 1.0, 1.0]);
    let out = render_soup(&d, &sphere_scene(), &table(vec![]), &cam, &[], &st, 0).unwrap();
    let v = covered(&out.image);
    assert!(v.len() > 300, "sphere covers {} pixels", v.len());
    let (m, se) = mean_se(&v);
    // A convex object sees only the environment: L = 0.8 * 1.
    assert!((m - 0.8).abs() < 4.0 * se + 2e-3, "mean {m} ± {se}");
    // No outliers: per pixel, 128 samples of NEE + MIS are within ~5 sigma.
    for p in &v {
        assert!((p - 0.8).abs() < 0.15, "pixel {p}");
    }
    // Background pixels see the environment itself.
    for p in out.image.rgba.iter().filter(|p| p[3] == 0.0) {
        assert_eq!(grey(*p), 1.0);
    }
    assert!(out.rays > 0 && out.trace_ms > 0.0);
}

#[test]
fn furnace_white_dielectric_and_closed_box_never_gain_energy() {
    let d = common::device();
    let cam = perspective(Vec3::new(2.0, 1.5, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    let mut st = settings(32, 32);
    st.environment = Environment::Color([0.5, 0.5, 0.5]);
    let mut s = Soup::default();
    cube(&mut s, Vec3::ZERO, 0.8, 0);
    let t = table(vec![material([1.0; 4], 0.0, 1.0)]);
    let out = render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap();
    let (m, se) = mean_se(&covered(&out.image));
    // White base colour with a 4 % dielectric coat: (1 - F) diffuse + F GGX
    // loses a little to the rough lobe's masking, never gains.
    assert!(m <= 0.5 + 4.0 * se + 1e-3 && m > 0.47, "mean {m} ± {se}");
}

/// The directional albedo of the Rust reference BSDF at cosine `mu`, by
/// midpoint quadrature over the hemisphere (uniform in cos theta and phi,
/// so dω = dμ dφ): independent of the BSDF's own sampling, but too coarse
/// for sharp lobes.
fn albedo_quadrature(p: &BsdfParams, mu: f32) -> f64 {
    let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
    let (nm, np) = (600, 600);
    let mut sum = 0.0f64;
    for i in 0..nm {
        let c = (i as f64 + 0.5) / nm as f64;
        let s = (1.0 - c * c).sqrt();
        for j in 0..np {
            let ph = 2.0 * PI * (j as f64 + 0.5) / np as f64;
            let wi = Vec3::new((s * ph.cos()) as f32, (s * ph.sin()) as f32, c as f32);
            sum += bsdf_eval(p, wo, wi).x as f64 * c;
        }
    }
    sum * (2.0 * PI) / (nm * np) as f64
}

/// The directional albedo by stratified importance sampling of the Rust
/// reference (exact for any lobe width when its pdf is right; the uniform
/// quadrature above checks that at alpha = 1).
fn albedo_sampled(p: &BsdfParams, mu: f32) -> f64 {
    let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
    let n = 400;
    let mut sum = 0.0f64;
    for i in 0..n {
        for j in 0..n {
            let (u1, u2) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            if let Some(s) = bsdf_sample(p, wo, 0.0, u1, u2) {
                sum += (s.f.x * s.wi.z / s.pdf) as f64;
            }
        }
    }
    sum / (n * n) as f64
}

#[test]
fn ggx_furnace_energy_never_grows() {
    let d = common::device();
    // Single-scattering GGX at alpha = 1, seen head-on: D = 1/pi and
    // G2 = 2 mu / (1 + mu), so the albedo is 1 - ln 2 exactly.
    let rough = BsdfParams::new([1.0; 3], 1.0, 1.0);
    let e = albedo_quadrature(&rough, 1.0);
    assert!((e - (1.0 - 2f64.ln())).abs() < 1e-3, "quadrature {e}");
    for mu in [1.0, 0.5] {
        let (a, b) = (albedo_quadrature(&rough, mu), albedo_sampled(&rough, mu));
        assert!(
            (a - b).abs() < 2e-3,
            "mu {mu}: quadrature {a} vs sampled {b}"
        );
    }
    // A white metal plane under a uniform environment of radiance 1, seen
    // by orthographic cameras at view cosines 1 and 0.5: every pixel is the
    // directional albedo at that cosine (the plane never sees itself).
    let s = ground_plane();
    for roughness in [0.1f32, 0.3, 0.6, 1.0] {
        for mu in [1.0f32, 0.5] {
            let view = Vec3::new((1.0 - mu * mu).sqrt(), mu, 0.0);
            let up = if mu == 1.0 { Vec3::NEG_Z } else { Vec3::Y };
            let cam = orthographic(view * 10.0, Vec3::ZERO, up, 1.0);
            let mut st = settings(16, 64);
            st.environment = Environment::Color([1.0, 1.0, 1.0]);
            let t = table(vec![material([1.0; 4], 1.0, roughness)]);
            let out = render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap();
            let v: Vec<f64> = out.image.rgba.iter().map(|p| grey(*p)).collect();
            let (m, se) = mean_se(&v);
            let want = albedo_sampled(&BsdfParams::new([1.0; 3], 1.0, roughness), mu);
            assert!(
                want <= 1.0 + 1e-3,
                "roughness {roughness} mu {mu}: albedo {want} > 1"
            );
            assert!(
                (m - want).abs() < 4.0 * se + 2e-3,
                "roughness {roughness} mu {mu}: {m} ± {se} vs albedo {want}"
            );
            assert!(
                m <= 1.0 + 4.0 * se,
                "roughness {roughness} mu {mu}: {m} gains energy"
            );
            if roughness <= 0.6 {
                assert!(m > 0.75, "roughness {roughness} mu {mu}: {m}");
            }
        }
    }
    // And on a sphere (every view cosine at once): never above 1.
    let cam = perspective(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    for roughness in [0.1f32, 0.3, 0.6, 1.0] {
        let mut st = settings(24, 32);
        st.environment = Environment::Color([1.0, 1.0, 1.0]);
        let t = table(vec![material([1.0; 4], 1.0, roughness)]);
        let out = render_soup(&d, &sphere_scene(), &t, &cam, &[], &st, 0).unwrap();
        let (m, se) = mean_se(&covered(&out.image));
        assert!(
            m <= 1.0 + 4.0 * se + 1e-3,
            "sphere roughness {roughness}: {m} ± {se}"
        );
    }
}

/// The expected value of a pixel of `top_down(half)` (square, `size`
/// pixels) whose radiance at world point p is `f(p)`: `f` averaged over the
/// film filter's sample distribution (a 24 x 24 grid of its inverse CDF).
fn filtered(half: f32, size: u32, x: u32, y: u32, f: impl Fn(Vec3) -> f64) -> f64 {
    let sampler = soupray::film::Filter::default().sampler();
    let n = 24;
    let mut sum = 0.0;
    for i in 0..n {
        for j in 0..n {
            let o = sampler.sample([(i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32]);
            let sx = ((x as f32 + 0.5 + o[0]) / size as f32) * 2.0 - 1.0;
            let sy = 1.0 - ((y as f32 + 0.5 + o[1]) / size as f32) * 2.0;
            sum += f(Vec3::new(sx * half, 0.0, -sy * half));
        }
    }
    sum / (n * n) as f64
}

/// Renders the y = 0 plane (clay, albedo 0.8) from above, lit by `lights`.
fn plane_under(
    lights: &[soupray::scene::FrameLight],
    size: u32,
    spp: u32,
    half: f32,
) -> soupray::film::Image {
    plane_under_chosen(lights, size, spp, half, true)
}

/// `plane_under`, many lights chosen through the light tree or by power.
fn plane_under_chosen(
    lights: &[soupray::scene::FrameLight],
    size: u32,
    spp: u32,
    half: f32,
    light_tree: bool,
) -> soupray::film::Image {
    let d = common::device();
    let s = ground_plane();
    let mut st = settings(size, spp);
    st.light_tree = if light_tree {
        LightTreeUse::Always
    } else {
        LightTreeUse::Never
    };
    st.clay = true;
    st.max_depth = 1;
    render_soup(&d, &s, &table(vec![]), &top_down(half), lights, &st, 0)
        .unwrap()
        .image
}

#[test]
fn point_light_over_lambertian_plane_matches_inverse_square_law() {
    let (size, half) = (24u32, 2.0f32);
    let lp = Vec3::new(0.3, 1.5, -0.2);
    let intensity = 12.0f32;
    let color = [1.0, 0.5, 0.25];
    let l = light(LightKind::Point, lp, Vec3::NEG_Y, color, intensity);
    let img = plane_under(&[l], size, 128, half);
    let (mut rel_sum, mut n) = (0.0f64, 0);
    for y in (0..size).step_by(3) {
        for x in (0..size).step_by(3) {
            // E = I cos(theta) / d^2, L = albedo / pi * E, through the filter.
            let e = filtered(half, size, x, y, |p| {
                let to = lp - p;
                (intensity * to.normalize().y / to.length_squared()) as f64
            }) as f32;
            let got = img.rgba[(y * size + x) as usize];
            for c in 0..3 {
                let want = 0.8 / std::f32::consts::PI * e * color[c];
                // What remains is the noise of 128 filter offsets over
                // the pixel's gradient: about 1 % at the corners.
                assert!(
                    (got[c] - want).abs() < 0.03 * want + 1e-5,
                    "pixel ({x},{y}) channel {c}: {} vs {want}",
                    got[c]
                );
                rel_sum += ((got[c] - want) / want) as f64;
                n += 1;
            }
        }
    }
    let bias = rel_sum / n as f64;
    assert!(bias.abs() < 2e-3, "mean relative error {bias}");
}

#[test]
fn spot_cone_falls_off_per_the_extension() {
    let (size, half) = (32u32, 2.0f32);
    let lp = Vec3::new(0.0, 1.0, 0.0);
    let (inner, outer) = (20f32.to_radians(), 45f32.to_radians());
    let mut l = light(
        LightKind::Spot {
            inner_cone_angle: inner,
            outer_cone_angle: outer,
        },
        lp,
        Vec3::NEG_Y,
        [1.0; 3],
        5.0,
    );
    l.range = None;
    let img = plane_under(&[l], size, 128, half);
    let (mut inside, mut falloff, mut dark) = (0, 0, 0);
    let peak = 0.8 / std::f32::consts::PI * 5.0;
    let (mut got_sum, mut want_sum) = (0.0f64, 0.0f64);
    for y in 0..size {
        for x in 0..size {
            let p = top_down_point(half, size, x, y);
            let to = lp - p;
            let w = to.normalize();
            let cd = w.y; // angle to the spot axis (-Y)
            let angle = cd.acos();
            // Skip pixels whose filter footprint straddles a cone edge.
            if angle > outer + 0.15 && (x + y) % 2 == 1 {
                continue;
            }
            let scale = 1.0 / (inner.cos() - outer.cos());
            let want = filtered(half, size, x, y, |p| {
                let to = lp - p;
                let w = to.normalize();
                let s = ((w.y - outer.cos()) * scale).clamp(0.0, 1.0);
                (0.8 / std::f32::consts::PI * 5.0 * s * s * w.y / to.length_squared()) as f64
            }) as f32;
            let got = img.rgba[(y * size + x) as usize][0];
            got_sum += got as f64;
            want_sum += want as f64;
            // Offset noise is largest on the steep cone edge: 3 % of the peak.
            assert!(
                (got - want).abs() < 0.03 * peak,
                "pixel ({x},{y}) at {:.1} deg: {got} vs {want}",
                angle.to_degrees()
            );
            if angle < inner {
                inside += 1;
            } else if angle < outer {
                falloff += 1;
            } else {
                dark += 1;
            }
        }
    }
    assert!(
        inside > 10 && falloff > 20 && dark > 20,
        "{inside} {falloff} {dark}"
    );
    let ratio = got_sum / want_sum;
    assert!((ratio - 1.0).abs() < 3e-3, "total {got_sum} vs {want_sum}");
}

#[test]
fn directional_light_gives_lux_times_cosine() {
    let dir = Vec3::new(1.0, -2.0, 0.5).normalize();
    let lux = 3.0f32;
    let l = light(LightKind::Directional, Vec3::ZERO, dir, [1.0; 3], lux);
    let img = plane_under(&[l], 16, 4, 2.0);
    let want = 0.8 / std::f32::consts::PI * lux * (-dir.y);
    for p in &img.rgba {
        assert!(
            (p[1] - want).abs() < 1e-4 * want.max(1.0),
            "{} vs {want}",
            p[1]
        );
        assert_eq!(p[3], 1.0);
    }
}

/// Form factor from a point to a parallel rectangle with one corner above
/// it, sides X, Y in units of the height (signed: odd in X and Y).
fn corner_form_factor(x: f64, y: f64) -> f64 {
    let a = (1.0 + x * x).sqrt();
    let b = (1.0 + y * y).sqrt();
    (x / a * (y / a).atan() + y / b * (x / b).atan()) / (2.0 * PI)
}

/// The emissive rectangle of the form-factor tests: height, half width
/// along X, half depth along Z.
const RECT: (f32, f32, f32) = (1.0, 0.6, 0.4);

/// The ground plane (material 0, 0.8 grey) under the rectangle `RECT`
/// facing down with radiance `le` (material 1). The camera above sees
/// through its (culled) back.
fn emitter_over_plane(le: f32) -> (Soup, soupray::scene::MaterialTable) {
    let (h, a, b) = RECT;
    let mut s = ground_plane();
    quad(
        &mut s,
        Vec3::new(0.0, h, 0.0),
        Vec3::X * a,
        Vec3::Z * b,
        Vec3::NEG_Y,
        1,
    );
    let mut emitter = material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
    emitter.emissive_factor = [1.0, 1.0, 1.0];
    emitter.emissive_strength = le;
    let t = table(vec![material([0.8, 0.8, 0.8, 1.0], 0.0, 1.0), emitter]);
    (s, t)
}

/// The form factor from ground point `p` to the rectangle `RECT`.
fn rectangle_form_factor(p: Vec3) -> f64 {
    let (h, a, b) = RECT;
    let (x1, x2) = ((-a - p.x) as f64 / h as f64, (a - p.x) as f64 / h as f64);
    let (z1, z2) = ((-b - p.z) as f64 / h as f64, (b - p.z) as f64 / h as f64);
    corner_form_factor(x2, z2) - corner_form_factor(x1, z2) - corner_form_factor(x2, z1)
        + corner_form_factor(x1, z1)
}

#[test]
fn emissive_rectangle_lights_a_plane_by_its_form_factor() {
    let d = common::device();
    let (size, half) = (16u32, 1.5f32);
    let le = 4.0f32;
    let (s, t) = emitter_over_plane(le);
    let mut st = settings(size, 256);
    st.clay = true; // pure Lambert (emission is kept)
    st.max_depth = 1;
    // The emitter is the only light: no sky.
    st.environment = Environment::Color([0.0; 3]);
    // The camera looks down at the plane through the emitter's back, which
    // culling lets it see through.
    st.backface_culling = true;
    let out = render_soup(&d, &s, &t, &top_down(half), &[], &st, 0).unwrap();
    assert!(
        out.warnings.iter().all(|w| !w.contains("no light")),
        "{:?}",
        out.warnings
    );
    let mut checked = 0;
    let mut err_sum = 0.0;
    for y in 0..size {
        for x in 0..size {
            let p = top_down_point(half, size, x, y);
            let f = rectangle_form_factor(p);
            let want = 0.8 / PI * (PI * le as f64 * f);
            let got = out.image.rgba[(y * size + x) as usize][0] as f64;
            // 256 samples of NEE + MIS: about 3 % noise per pixel; no
            // outliers (the bias is checked on the mean below).
            assert!(
                (got - want).abs() < 0.15 * want + 2e-3,
                "pixel ({x},{y}): {got} vs {want}"
            );
            err_sum += (got - want) / want;
            checked += 1;
        }
    }
    let bias = err_sum / checked as f64;
    assert!(bias.abs() < 0.008, "mean relative error {bias}");
}

/// Writes an equirectangular EXR of `w` x `h` texels from `f(x, y)`.
fn write_env(
    path: &std::path::Path,
    w: usize,
    h: usize,
    f: impl Fn(usize, usize) -> [f32; 3] + Sync,
) {
    exr::prelude::write_rgb_file(path, w, h, |x, y| {
        let c = f(x, y);
        (c[0], c[1], c[2])
    })
    .unwrap();
}

#[test]
fn environment_map_importance_sampling_matches_its_irradiance() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("sky.exr");
    let (w, h) = (64usize, 32usize);
    // A dim sky with a small, very bright sun: uniform sampling would be
    // hopeless here; importance sampling must find the sun.
    let texel = |x: usize, y: usize| -> [f32; 3] {
        if (20..23).contains(&x) && (5..7).contains(&y) {
            [400.0, 350.0, 300.0]
        } else if y < h / 2 {
            [0.3, 0.4, 0.6]
        } else {
            [0.05, 0.05, 0.05]
        }
    };
    write_env(&path, w, h, texel);
    // The irradiance of an up-facing plane, texel by texel: each row spans
    // theta in [y, y + 1] pi / h, and ∫ cos θ sin θ dθ = (sin² θ1 - sin² θ0) / 2.
    let mut e = [0.0f64; 3];
    for y in 0..h / 2 {
        let t0 = PI * y as f64 / h as f64;
        let t1 = PI * (y + 1) as f64 / h as f64;
        let band = (t1.sin().powi(2) - t0.sin().powi(2)) / 2.0 * (2.0 * PI / w as f64);
        for x in 0..w {
            let c = texel(x, y);
            for k in 0..3 {
                e[k] += c[k] as f64 * band;
            }
        }
    }
    let d = common::device();
    let s = ground_plane();
    let mut st = settings(16, 128);
    st.clay = true;
    st.max_depth = 1;
    st.environment = Environment::Map(path.clone());
    let out = render_soup(&d, &s, &table(vec![]), &top_down(1.0), &[], &st, 0).unwrap();
    for k in 0..3 {
        let want = 0.8 / PI * e[k];
        let v: Vec<f64> = out.image.rgba.iter().map(|p| p[k] as f64).collect();
        let (m, se) = mean_se(&v);
        assert!(
            (m - want).abs() < 4.0 * se + 0.01 * want,
            "channel {k}: {m} ± {se} vs {want}"
        );
        // No outliers: with the sun importance sampled, every pixel's 128
        // samples land within a quarter of the irradiance.
        for p in &v {
            assert!(
                (p - want).abs() < 0.25 * want,
                "channel {k}: pixel {p} vs {want}"
            );
        }
    }
    // The same map read as a constant gives the constant's irradiance.
    let flat = dir.path().join("flat.exr");
    write_env(&flat, 16, 8, |_, _| [0.7, 0.7, 0.7]);
    st.environment = Environment::Map(flat);
    let a = render_soup(&d, &s, &table(vec![]), &top_down(1.0), &[], &st, 0).unwrap();
    st.environment = Environment::Color([0.7, 0.7, 0.7]);
    let b = render_soup(&d, &s, &table(vec![]), &top_down(1.0), &[], &st, 0).unwrap();
    let ma = mean_se(&a.image.rgba.iter().map(|p| grey(*p)).collect::<Vec<_>>()).0;
    let mb = mean_se(&b.image.rgba.iter().map(|p| grey(*p)).collect::<Vec<_>>()).0;
    assert!(
        (ma - 0.56).abs() < 0.01 && (mb - 0.56).abs() < 0.01,
        "{ma} {mb}"
    );
    // A missing file is an error that names it.
    st.environment = Environment::Map(dir.path().join("missing.exr"));
    let e = render_soup(&d, &s, &table(vec![]), &top_down(1.0), &[], &st, 0).unwrap_err();
    assert!(e.to_string().contains("missing.exr"), "{e}");
}

#[test]
fn a_black_environment_is_no_light_to_sample() {
    // With a point light, `--env-color 0,0,0` must render exactly like no
    // environment at all: a black sky adds nothing, so it must not take a
    // share of the light samples (that would only add noise).
    let d = common::device();
    let s = ground_plane();
    let lights = [light(
        LightKind::Point,
        Vec3::new(0.0, 4.0, 0.0),
        Vec3::NEG_Y,
        [1.0; 3],
        80.0,
    )];
    let mut st = settings(32, 8);
    st.clay = true;
    let none = render_soup(&d, &s, &table(vec![]), &top_down(6.0), &lights, &st, 0).unwrap();
    st.environment = Environment::Color([0.0, 0.0, 0.0]);
    let black = render_soup(&d, &s, &table(vec![]), &top_down(6.0), &lights, &st, 0).unwrap();
    assert_eq!(bits(&black.image), bits(&none.image));
}

#[test]
fn sun_over_a_sky_lights_a_plane_without_noise() {
    // A directional light is sampled at every vertex (no on/off noise of a
    // light chosen or not), and a constant sky over a Lambertian plane by
    // the cosine-weighted BSDF sample: every sample then returns exactly
    // albedo * (E cos / pi + L), whichever sampler.
    let d = common::device();
    let dir = Vec3::new(1.0, -2.0, 0.5).normalize();
    let (lux, sky) = (3.0f32, 0.1f32);
    let l = light(LightKind::Directional, Vec3::ZERO, dir, [1.0; 3], lux);
    let want = 0.8 / std::f32::consts::PI * lux * (-dir.y) + 0.8 * sky;
    for sampler in [Sampler::Sobol, Sampler::Random] {
        let mut st = settings(16, 4);
        st.clay = true;
        st.max_depth = 1;
        st.sampler = sampler;
        st.environment = Environment::Color([sky; 3]);
        let img = render_soup(
            &d,
            &ground_plane(),
            &table(vec![]),
            &top_down(2.0),
            std::slice::from_ref(&l),
            &st,
            0,
        )
        .unwrap()
        .image;
        for p in &img.rgba {
            assert!(
                (p[1] - want).abs() < 1e-4 * want,
                "{sampler:?}: {} vs {want}",
                p[1]
            );
        }
    }
}

/// The plane's radiance under point lights `lights` (albedo 0.8), through
/// the pixel filter.
fn plane_radiance(
    lights: &[soupray::scene::FrameLight],
    half: f32,
    size: u32,
    x: u32,
    y: u32,
) -> f64 {
    filtered(half, size, x, y, |p| {
        let e: f64 = lights
            .iter()
            .map(|l| {
                let to = l.position - p;
                (l.intensity * to.normalize().y / to.length_squared()) as f64
            })
            .sum();
        0.8 / PI * e
    })
}

/// Each pixel's relative error against `plane_radiance`: their mean (the
/// bias) and root mean square (the noise).
fn plane_errors(
    img: &soupray::film::Image,
    lights: &[soupray::scene::FrameLight],
    half: f32,
    size: u32,
    tolerance: f64,
) -> (f64, f64) {
    let (mut sum, mut sum2, mut n) = (0.0f64, 0.0f64, 0);
    for y in 0..size {
        for x in 0..size {
            let want = plane_radiance(lights, half, size, x, y);
            let got = img.rgba[(y * size + x) as usize][1] as f64;
            let rel = (got - want) / want;
            assert!(rel.abs() < tolerance, "pixel ({x},{y}): {got} vs {want}");
            sum += rel;
            sum2 += rel * rel;
            n += 1;
        }
    }
    (sum / n as f64, (sum2 / n as f64).sqrt())
}

#[test]
fn many_point_lights_are_chosen_without_bias() {
    // More punctual lights than are looped over: one is chosen per vertex,
    // through the light tree or in proportion to its power. The sum of
    // their inverse-square irradiances must come out on average.
    let (size, half) = (16u32, 2.0f32);
    let lights: Vec<_> = (0..LOOPED_PUNCTUAL_MAX + 4)
        .map(|i| {
            let a = i as f32 * 0.7;
            let p = Vec3::new(1.5 * a.cos(), 1.0 + 0.2 * i as f32, 1.5 * a.sin());
            light(
                LightKind::Point,
                p,
                Vec3::NEG_Y,
                [1.0; 3],
                1.0 + i as f32 * 2.0,
            )
        })
        .collect();
    for tree in [true, false] {
        let img = plane_under_chosen(&lights, size, 256, half, tree);
        let (bias, _) = plane_errors(&img, &lights, half, size, 0.25);
        assert!(bias.abs() < 0.01, "tree {tree}: mean relative error {bias}");
    }
}

#[test]
fn a_street_of_lamps_is_less_noisy_through_the_light_tree() {
    // 100 lamps along 40 m of street, 0.6 m over the plane: at any pixel a
    // few lamps give most of the light. The tree chooses those; power
    // alone chooses any lamp alike. Both converge to the same image.
    let (size, half) = (16u32, 2.0f32);
    let lights: Vec<_> = (0..100)
        .map(|i| {
            let z = if i % 2 == 0 { -1.0 } else { 1.0 };
            let p = Vec3::new(-20.0 + 0.4 * i as f32, 0.6, z);
            light(LightKind::Point, p, Vec3::NEG_Y, [1.0; 3], 1.0)
        })
        .collect();
    let tree = plane_under_chosen(&lights, size, 256, half, true);
    let power = plane_under_chosen(&lights, size, 256, half, false);
    let (tree_bias, tree_rms) = plane_errors(&tree, &lights, half, size, 0.2);
    let (power_bias, power_rms) = plane_errors(&power, &lights, half, size, 1.0);
    eprintln!(
        "street: tree bias {tree_bias:.4} noise {tree_rms:.4}; power bias {power_bias:.4} noise {power_rms:.4}"
    );
    assert!(
        tree_bias.abs() < 0.01,
        "tree: mean relative error {tree_bias}"
    );
    assert!(
        power_bias.abs() < 0.05,
        "power: mean relative error {power_bias}"
    );
    assert!(
        tree_rms < 0.25 * power_rms,
        "relative noise: tree {tree_rms}, power {power_rms}"
    );
}

#[test]
fn emitter_sky_and_point_light_add_up_under_power_selection() {
    // An emissive rectangle, a constant sky and a point light together: the
    // emitter and the sky share the selection distribution by power, and
    // the MIS weights of BSDF-sampled hits must use those same
    // probabilities. Radiance = albedo * (Le F + L (1 - F)) plus the point
    // light's albedo / pi * I cos / d^2, F the rectangle's form factor.
    let d = common::device();
    let (size, half) = (16u32, 1.5f32);
    let (le, sky) = (4.0f32, 0.5f32);
    let (s, t) = emitter_over_plane(le);
    // Off to the side, so that the rectangle shades no pixel in view.
    let lp = Vec3::new(3.0, 2.0, 0.0);
    let l = light(LightKind::Point, lp, Vec3::NEG_Y, [1.0; 3], 6.0);
    let mut st = settings(size, 256);
    st.clay = true;
    st.max_depth = 1;
    st.environment = Environment::Color([sky; 3]);
    // The camera looks down through the emitter's back (see above).
    st.backface_culling = true;
    let out = render_soup(&d, &s, &t, &top_down(half), &[l], &st, 0).unwrap();
    let (mut err_sum, mut n) = (0.0, 0);
    for y in 0..size {
        for x in 0..size {
            let p = top_down_point(half, size, x, y);
            let f = rectangle_form_factor(p);
            let to = lp - p;
            let e_point = (6.0 * to.normalize().y / to.length_squared()) as f64;
            let want = 0.8 * (le as f64 * f + sky as f64 * (1.0 - f)) + 0.8 / PI * e_point;
            let got = out.image.rgba[(y * size + x) as usize][0] as f64;
            assert!(
                (got - want).abs() < 0.15 * want,
                "pixel ({x},{y}): {got} vs {want}"
            );
            err_sum += (got - want) / want;
            n += 1;
        }
    }
    let bias = err_sum / n as f64;
    assert!(bias.abs() < 0.008, "mean relative error {bias}");
}
