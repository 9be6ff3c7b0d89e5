//! Light-path passes (`--passes light`, film::light): the kernel's split of
//! the BSDF into lobes against its Rust twin on random materials and
//! directions; the passes adding up to the beauty on a scene with every
//! lobe, every kind of light and the environment; an analytic Lambertian
//! plane under a sun; the beauty unchanged by turning the passes on; and
//! the CLI's channels and errors.

// Pixels are indices into several passes at once.
#![allow(clippy::needless_range_loop)]

mod common;

use common::render::*;
use common::{random_dir, random_upper_dir, run_probe, Rng};
use glam::Vec3;
use soupray::film::light::{recombine, LIGHT_PASSES, LIGHT_PASS_NAMES};
use soupray::film::{Aovs, Image};
use soupray::scene::{LightKind, Material};
use soupray::soup::Soup;
use soupray::trace::material::{bsdf_eval, bsdf_eval_lobes, BsdfParams, Dielectric, Layers};
use soupray::trace::render::{render_soup, Environment, Layering};

/// The defines of one probe program, and the parameters they read.
struct Config {
    defines: &'static [&'static str],
    transmission: bool,
    layers: bool,
}

#[test]
fn bsdf_lobes_match_the_reference() {
    let d = common::device();
    let configs = [
        Config {
            defines: &["FILM_LIGHT"],
            transmission: false,
            layers: false,
        },
        Config {
            defines: &["FILM_LIGHT", "ENERGY_LAYERING"],
            transmission: false,
            layers: false,
        },
        Config {
            defines: &["FILM_LIGHT", "HAS_TRANSMISSION"],
            transmission: true,
            layers: false,
        },
        Config {
            defines: &[
                "FILM_LIGHT",
                "HAS_TRANSMISSION",
                "HAS_CLEARCOAT",
                "HAS_SHEEN",
                "ENERGY_LAYERING",
                "GGX_ENERGY_COMPENSATION",
            ],
            transmission: true,
            layers: true,
        },
    ];
    let mut rng = Rng::new(41);
    let n = 2000;
    for c in &configs {
        let layering = c.defines.contains(&"ENERGY_LAYERING");
        let compensation = c.defines.contains(&"GGX_ENERGY_COMPENSATION");
        let mut input = Vec::new();
        let mut cases = Vec::new();
        for i in 0..n {
            let base = [rng.f32(), rng.f32(), rng.f32()];
            let metallic = [0.0, 1.0, rng.f32()][i % 3];
            let rough = if i % 7 == 0 { 0.0 } else { rng.f32().max(0.05) };
            let mut p = BsdfParams::new(base, metallic, rough);
            // Every fifth a pure Lambertian (specular 0, metallic 0).
            if i % 5 == 0 {
                p.specular = 0.0;
                p.metallic = 0.0;
            }
            p.energy_layering = layering;
            p.energy_compensation = compensation;
            let dl = Dielectric::new(
                1.0 + rng.f32(),
                if i % 3 == 0 { 1.0 } else { rng.f32() },
                i % 2 == 0,
                i % 4 < 2,
            );
            if c.transmission {
                p = p.with_dielectric(dl);
            }
            let l = Layers::new(
                if i % 4 == 3 { 0.0 } else { rng.f32() },
                rng.f32().max(0.05),
                [rng.f32(), rng.f32(), rng.f32()],
                rng.f32(),
            );
            if c.layers {
                p = p.with_layers(l);
            }
            let wo = random_upper_dir(&mut rng);
            let mut wi = random_dir(&mut rng);
            if !c.transmission {
                wi.z = wi.z.abs();
            }
            input.extend_from_slice(&common::dielectric_probe_params(&p, &dl));
            input.extend_from_slice(&[l.clearcoat, l.coat_alpha, l.sheen_roughness, 0.0]);
            input.extend_from_slice(&[l.sheen_color.x, l.sheen_color.y, l.sheen_color.z, 0.0]);
            input.extend_from_slice(&[wo.x, wo.y, wo.z, 0.0, wi.x, wi.y, wi.z, 0.0]);
            input.extend_from_slice(&[rng.f32(), rng.f32(), rng.f32(), 0.0]);
            input.extend_from_slice(&[0.0; 4]);
            cases.push((p, wo, wi));
        }
        let defines: Vec<(&str, String)> = c.defines.iter().map(|n| (*n, "1".to_owned())).collect();
        let program = d.build_program("pt_probe.cl", &defines).unwrap();
        let k = d.kernel(&program, "bsdf_lobes_probe").unwrap();
        let got: Vec<f32> = run_probe(&d, &k, &input, n, 40 * n);
        let (mut diffuse, mut transmitted, mut glossy) = (0, 0, 0);
        let mut sampled = 0;
        for (i, (p, wo, wi)) in cases.iter().enumerate() {
            let what = format!("{:?} case {i} {p:?} wo {wo} wi {wi}", c.defines);
            let lobes = bsdf_eval_lobes(p, *wo, *wi);
            // The total is bsdf_eval's own value, and the parts lie in it.
            assert_eq!(lobes.total, bsdf_eval(p, *wo, *wi), "{what}");
            let (f, dp, tp) = (lobes.total, lobes.diffuse, lobes.transmission);
            assert!(
                dp.min_element() >= 0.0 && tp.min_element() >= 0.0,
                "{lobes:?} {what}"
            );
            assert!(
                (dp + tp).cmple(f * (1.0 + 1e-5) + Vec3::splat(1e-7)).all(),
                "{lobes:?} {what}"
            );
            if wi.z > 0.0 {
                assert_eq!(tp, Vec3::ZERO, "transmission above the surface: {what}");
            }
            if p.specular == 0.0
                && p.metallic == 0.0
                && p.dielectric.is_none()
                && p.layers.is_none()
            {
                assert_eq!(dp, f, "a pure Lambertian is all diffuse: {what}");
            }
            let o = &got[40 * i..40 * i + 9];
            // bsdf_eval_parts (what the direct light splits with) gives
            // bsdf_eval's and bsdf_lobe_parts' floats, bit for bit.
            let fused = &got[40 * i + 9..40 * i + 18];
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(fused), bits(o), "bsdf_eval_parts: {what}");
            // bsdf_sample_parts (what the first vertex's shares take) gives,
            // at the direction it samples, bsdf_eval's and bsdf_lobe_parts'
            // floats bit for bit; a delta lobe has no diffuse or
            // transmission part there (its share is set by direction).
            let s = &got[40 * i + 18..40 * i + 40];
            if s[0] == 1.0 {
                sampled += 1;
                assert_eq!(
                    bits(&s[4..13]),
                    bits(&s[13..22]),
                    "bsdf_sample_parts: {what}"
                );
            } else if s[0] == 2.0 {
                assert_eq!(&s[7..13], &[0.0; 6], "delta lobe parts: {what}");
            }
            let want = [f, dp, tp];
            for part in 0..3 {
                for ch in 0..3 {
                    let (a, b) = (o[3 * part + ch], want[part][ch]);
                    let scale = a.abs().max(b.abs()).max(1e-3);
                    assert!(
                        (a - b).abs() <= 5e-4 * scale,
                        "part {part} channel {ch}: kernel {a}, reference {b}: {what}"
                    );
                }
            }
            diffuse += (dp.max_element() > 0.0) as usize;
            transmitted += (tp.max_element() > 0.0) as usize;
            glossy += ((f - dp - tp).max_element() > 1e-6 * f.max_element()) as usize;
        }
        eprintln!(
            "{:?}: {n} cases, {diffuse} with diffuse, {glossy} glossy, {transmitted} transmission, \
             {sampled} sampled from a non-delta lobe",
            c.defines
        );
        assert!(diffuse > n / 8 && glossy > n / 8, "{diffuse} {glossy}");
        assert!(sampled > n / 2, "{sampled} of {n} sampled");
        if c.transmission {
            assert!(transmitted > n / 10, "{transmitted}");
        }
    }
}

/// A ground, a metal, a rough and a smooth glass, a sheen-and-coat ball,
/// a rough plastic and a frosted pane, lit by a point light, an emissive quad the camera
/// sees and a sky: every lobe, every kind of light, direct and indirect.
fn every_lobe() -> (Soup, Vec<Material>) {
    let mut s = Soup::default();
    quad(&mut s, Vec3::ZERO, Vec3::X * 6.0, Vec3::Z * 6.0, Vec3::Y, 0);
    sphere(&mut s, Vec3::new(-1.3, 0.5, 0.0), 0.5, 16, 32, 1);
    sphere(&mut s, Vec3::new(0.0, 0.5, 0.0), 0.5, 16, 32, 2);
    sphere(&mut s, Vec3::new(1.3, 0.5, 0.0), 0.5, 16, 32, 3);
    sphere(&mut s, Vec3::new(-0.6, 0.35, 1.1), 0.35, 16, 32, 4);
    sphere(&mut s, Vec3::new(0.7, 0.35, 1.1), 0.35, 16, 32, 5);
    quad(
        &mut s,
        Vec3::new(0.0, 1.6, -1.2),
        Vec3::X * 0.8,
        Vec3::Y * 0.3,
        Vec3::Z,
        6,
    );
    // A frosted pane (thin-walled rough glass) with the sky behind it.
    quad(
        &mut s,
        Vec3::new(0.0, 0.8, -2.2),
        Vec3::X * 2.5,
        Vec3::Y * 0.8,
        Vec3::Z,
        2,
    );
    let metal = material([0.9, 0.6, 0.3, 1.0], 1.0, 0.3);
    let glass = |roughness: f32| Material {
        transmission_factor: 1.0,
        ior: 1.5,
        ..material([0.95, 0.95, 1.0, 1.0], 0.0, roughness)
    };
    let velvet = Material {
        sheen_color: [0.8, 0.3, 0.5],
        sheen_roughness: 0.5,
        clearcoat_factor: 0.7,
        clearcoat_roughness: 0.2,
        ..material([0.2, 0.3, 0.7, 1.0], 0.0, 0.6)
    };
    let mut emitter = material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
    emitter.emissive_factor = [1.0, 0.8, 0.6];
    emitter.emissive_strength = 6.0;
    let materials = vec![
        material([0.6, 0.6, 0.55, 1.0], 0.0, 0.9),
        metal,
        glass(0.25),
        glass(0.0),
        velvet,
        material([0.7, 0.2, 0.2, 1.0], 0.0, 0.35),
        emitter,
    ];
    (s, materials)
}

fn pass(img: &Image, name: &str) -> Vec<[f32; 3]> {
    img.light
        .pass(name)
        .unwrap_or_else(|| panic!("no {name} pass"))
}

/// A pixel's passes, in `LIGHT_PASS_NAMES` order.
fn passes_at(img: &Image, i: usize) -> [[f32; 3]; LIGHT_PASSES as usize] {
    let names: Vec<&str> = img.light.names().collect();
    assert_eq!(names, LIGHT_PASS_NAMES, "every pass is written");
    img.light.pixels[i]
}

fn light_settings(size: u32, spp: u32) -> soupray::trace::render::RenderSettings {
    let mut s = settings(size, spp);
    s.environment = Environment::Color([0.3, 0.4, 0.5]);
    s.layering = Layering::Energy;
    s.aovs = Aovs::parse("light").unwrap();
    s
}

#[test]
fn light_passes_add_up_to_the_beauty() {
    let d = common::device();
    let (soup, materials) = every_lobe();
    let lights = vec![light(
        LightKind::Point,
        Vec3::new(-1.5, 3.0, 2.0),
        Vec3::NEG_Y,
        [1.0; 3],
        25.0,
    )];
    let camera = perspective(
        Vec3::new(0.3, 2.2, 4.5),
        Vec3::new(0.0, 0.4, 0.0),
        Vec3::Y,
        40.0,
    );
    let s = light_settings(64, 32);
    let out = render_soup(&d, &soup, &table(materials), &camera, &lights, &s, 0).unwrap();
    let img = &out.image;
    let mut worst = 0.0f32;
    for i in 0..img.rgba.len() {
        let sum = recombine(&passes_at(img, i));
        for c in 0..3 {
            let beauty = img.rgba[i][c];
            let err = (sum[c] - beauty).abs() / beauty.abs().max(1e-6);
            worst = worst.max(err);
            assert!(
                err <= 1e-5,
                "pixel {i} channel {c}: passes add up to {}, the beauty is {beauty}",
                sum[c]
            );
        }
    }
    // Every pass is used somewhere.
    for name in LIGHT_PASS_NAMES {
        let max = pass(img, name)
            .iter()
            .flatten()
            .fold(0.0f32, |m, &v| m.max(v));
        eprintln!("{name}: max {max}");
        assert!(max > 0.0, "{name} is black everywhere");
    }
    eprintln!("worst relative difference of the recombined passes: {worst:e}");
}

#[test]
fn light_passes_leave_the_beauty_unchanged() {
    let d = common::device();
    let (soup, materials) = every_lobe();
    let camera = perspective(
        Vec3::new(0.3, 2.2, 4.5),
        Vec3::new(0.0, 0.4, 0.0),
        Vec3::Y,
        40.0,
    );
    let with = light_settings(32, 8);
    let without = soupray::trace::render::RenderSettings {
        aovs: Aovs::NONE,
        ..with.clone()
    };
    let t = table(materials);
    let a = render_soup(&d, &soup, &t, &camera, &[], &with, 2).unwrap();
    let b = render_soup(&d, &soup, &t, &camera, &[], &without, 2).unwrap();
    assert_eq!(bits(&a.image), bits(&b.image));
    assert!(b.image.light.is_empty());
}

/// A Lambertian plane of albedo 0.5 seen from straight above, under a sun
/// straight down of irradiance 3 and a black sky: each pixel's light is all
/// diffuse and direct, DiffDir = 3 / pi and DiffCol = 0.5 (the cosine
/// sampling's weight is the albedo itself), and nothing else is lit.
#[test]
fn a_lambertian_plane_under_a_sun_is_diffuse_direct_light() {
    let d = common::device();
    let soup = ground_plane();
    let mut lambert = material([0.5, 0.5, 0.5, 1.0], 0.0, 1.0);
    lambert.specular_factor = 0.0;
    let sun = light(
        LightKind::Directional,
        Vec3::ZERO,
        Vec3::NEG_Y,
        [1.0; 3],
        3.0,
    );
    let mut s = light_settings(16, 4);
    s.environment = Environment::Color([0.0; 3]);
    let out = render_soup(
        &d,
        &soup,
        &table(vec![lambert]),
        &top_down(1.0),
        &[sun],
        &s,
        0,
    )
    .unwrap();
    let img = &out.image;
    let dir = 3.0 / std::f32::consts::PI;
    for i in 0..img.rgba.len() {
        let p = passes_at(img, i);
        for c in 0..3 {
            assert!((p[0][c] - dir).abs() < 1e-5 * dir, "DiffDir {:?}", p[0]);
            assert!((p[2][c] - 0.5).abs() < 1e-6, "DiffCol {:?}", p[2]);
            assert!(
                (img.rgba[i][c] - 0.5 * dir).abs() < 1e-5,
                "beauty {:?}",
                img.rgba[i]
            );
        }
        for k in [1, 3, 4, 6, 7, 9, 10] {
            assert_eq!(p[k], [0.0; 3], "{} {:?}", LIGHT_PASS_NAMES[k], p[k]);
        }
    }
}

#[test]
fn the_cli_writes_the_passes_it_is_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let scene = common::repo_file("animations/walker/walker.glb");
    let args = [
        "--frames",
        "3",
        "--spp",
        "4",
        "--passes",
        "diffuse,emission",
    ];
    common::render_exr(&scene, (24, 16), dir.path(), "w.#.exr", &args);
    let exr = dir.path().join("w.3.exr");
    let channels = common::exr_channels(&exr);
    for name in ["DiffDir", "DiffInd", "DiffCol", "Emit"] {
        for c in ["R", "G", "B"] {
            assert!(
                channels.contains_key(&format!("{name}.{c}")),
                "{name}.{c}: {:?}",
                channels.keys()
            );
        }
    }
    assert!(!channels
        .keys()
        .any(|k| k.starts_with("Gloss") || k.starts_with("Env")));

    let run = common::soupray(&["render", "--passes", "depth", "--frames", "1"]);
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(err.contains("--passes") && err.contains("--aov"), "{err}");
}
