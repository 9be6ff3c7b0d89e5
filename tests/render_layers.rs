//! The layers over the BSDF, KHR_materials_clearcoat and
//! KHR_materials_sheen: the device (`HAS_CLEARCOAT`, `HAS_SHEEN`) against
//! the Rust reference on random inputs, the sheen albedo table against its
//! generator, white furnaces of the reference against what the layering
//! predicts, and renders against analytic values and the reference.
//!
//! What the layering conserves: the coat is `fresnel_coat` (the base
//! weighted by 1 - clearcoat Fc(n.v), the coat's white GGX lobe by
//! clearcoat Fc(n.v)); compensated (`GGX_ENERGY_COMPENSATION`, the default)
//! the coat lobe's albedo is 1, so a coat over a base of albedo 1 returns
//! everything. Without compensation the rough coat loses
//! clearcoat Fc (1 - E_coat). The sheen's albedo scaling
//! min(1 - c E(n.v), 1 - c E(n.l)) keeps the sum at or below 1; it reaches
//! 1 only where E(n.l) <= E(n.v) for every n.l, so over a white base it
//! loses a little, which the quadrature below predicts.

mod common;

use common::render::*;
use common::{
    albedo, check_bsdf_probe, random_dir, random_upper_dir, run_probe, BsdfProbeTally, Rng,
};
use glam::Vec3;
use soupray::scene::Material;
use soupray::soup::Soup;
use soupray::trace::energy::{ggx_albedo, sheen_albedo};
use soupray::trace::material::{
    bsdf_eval, bsdf_only_delta, bsdf_pdf, bsdf_sample, ggx_alpha, sheen_lobe, sheen_scaling,
    BsdfParams, Dielectric, Layers,
};
use soupray::trace::render::{render_soup, Environment};

/// White Lambert: the base model with neither specular layer nor metal.
fn white_lambert() -> BsdfParams {
    let mut p = BsdfParams::new([1.0; 3], 0.0, 1.0);
    p.specular = 0.0;
    p
}

fn coated(mut p: BsdfParams, clearcoat: f32, roughness: f32, compensate: bool) -> BsdfParams {
    p.energy_compensation = compensate;
    p.with_layers(Layers::new(clearcoat, roughness, [0.0; 3], 0.0))
}

fn sheened(p: BsdfParams, color: f32, roughness: f32) -> BsdfParams {
    p.with_layers(Layers::new(0.0, 0.0, [color; 3], roughness))
}

#[test]
fn sheen_table_is_what_the_generator_makes() {
    use soupray::trace::energy::{generate_sheen, sheen_header_text, sheen_table, ENERGY_SIZE};
    let fresh = generate_sheen();
    common::assert_generated_table(
        &fresh,
        ENERGY_SIZE * ENERGY_SIZE,
        "kernels/generated/sheen_energy.h",
        sheen_header_text,
        sheen_table(),
    );
    // A sheen reflects a part, never all.
    assert!(fresh.iter().all(|&e| e > 0.0 && e < 1.0), "{fresh:?}");
}

/// The defines of one probe program and the layers its cases carry.
struct Config {
    clearcoat: bool,
    sheen: bool,
    transmission: bool,
    compensation: bool,
}

#[test]
fn layered_bsdf_matches_the_reference() {
    let d = common::device();
    let configs = [
        Config {
            clearcoat: true,
            sheen: false,
            transmission: false,
            compensation: false,
        },
        Config {
            clearcoat: false,
            sheen: true,
            transmission: false,
            compensation: false,
        },
        Config {
            clearcoat: true,
            sheen: true,
            transmission: false,
            compensation: true,
        },
        Config {
            clearcoat: true,
            sheen: true,
            transmission: true,
            compensation: true,
        },
    ];
    let mut rng = Rng::new(29);
    let n = 2000;
    for c in &configs {
        let mut defines = Vec::new();
        for (on, name) in [
            (c.clearcoat, "HAS_CLEARCOAT"),
            (c.sheen, "HAS_SHEEN"),
            (c.transmission, "HAS_TRANSMISSION"),
            (c.compensation, "GGX_ENERGY_COMPENSATION"),
        ] {
            if on {
                defines.push((name, "1".to_owned()));
            }
        }
        let mut input = Vec::new();
        let mut cases = Vec::new();
        for i in 0..n {
            let rough = |rng: &mut Rng, k: usize| {
                if i % k == 0 {
                    0.0
                } else {
                    rng.f32().max(0.05)
                }
            };
            let base = [rng.f32(), rng.f32(), rng.f32()];
            let metallic = if i % 4 == 0 { 1.0 } else { rng.f32() };
            let mut p = BsdfParams::new(base, metallic, rough(&mut rng, 5));
            p.energy_compensation = c.compensation;
            let dl = Dielectric::new(
                1.0 + rng.f32(),
                if i % 3 == 0 { 1.0 } else { rng.f32() },
                i % 2 == 0,
                i % 4 < 2,
            );
            if c.transmission {
                p = p.with_dielectric(dl);
            }
            let clearcoat = if c.clearcoat && i % 6 != 5 {
                rng.f32().max(0.1)
            } else {
                0.0
            };
            let coat_rough = rough(&mut rng, 3);
            let sheen = if c.sheen && i % 6 != 4 {
                [rng.f32(), rng.f32(), rng.f32()]
            } else {
                [0.0; 3]
            };
            let sheen_rough = rng.f32();
            let mut l = Layers::new(clearcoat, coat_rough, sheen, sheen_rough);
            // A third of the coats have their own normal (a clearcoat
            // normal map, or the unmapped normal under a mapped base),
            // tilted up to ~50 degrees from the shading normal.
            if c.clearcoat && i % 3 != 0 {
                let t = random_dir(&mut rng) * 1.2;
                l = l.with_coat_normal(Vec3::new(t.x, t.y, 1.0).normalize());
            }
            let p = p.with_layers(l);
            let wo = random_upper_dir(&mut rng);
            let mut wi = random_dir(&mut rng);
            if !c.transmission {
                wi.z = wi.z.abs();
            }
            let u = [rng.f32(), rng.f32(), rng.f32()];
            input.extend_from_slice(&common::dielectric_probe_params(&p, &dl));
            input.extend_from_slice(&[l.clearcoat, l.coat_alpha, l.sheen_roughness, 0.0]);
            input.extend_from_slice(&[l.sheen_color.x, l.sheen_color.y, l.sheen_color.z, 0.0]);
            input.extend_from_slice(&[wo.x, wo.y, wo.z, 0.0, wi.x, wi.y, wi.z, 0.0]);
            input.extend_from_slice(&[u[0], u[1], u[2], 0.0]);
            let cn = l.coat_normal;
            input.extend_from_slice(&[cn.x, cn.y, cn.z, 0.0]);
            cases.push((p, wo, wi, u));
        }
        let program = d.build_program("pt_probe.cl", &defines).unwrap();
        let k = d.kernel(&program, "bsdf_layer_probe").unwrap();
        let got: Vec<f32> = run_probe(&d, &k, &input, n, 13 * n);
        let mut tally = BsdfProbeTally::default();
        let mut max_rel = 0.0f32;
        for (i, (p, wo, wi, u)) in cases.iter().enumerate() {
            let what = format!("{defines:?} case {i} {p:?} wo {wo} wi {wi}");
            let o = &got[13 * i..13 * i + 13];
            check_bsdf_probe(o, p, *wo, *wi, *u, 5e-4, &what, &mut tally);
            assert_eq!(o[12] == 1.0, bsdf_only_delta(p), "only delta {what}");
            let f = bsdf_eval(p, *wo, *wi);
            for k in 0..3 {
                let scale = o[k].abs().max(f[k].abs());
                if scale > 1e-6 {
                    max_rel = max_rel.max((o[k] - f[k]).abs() / scale);
                }
            }
        }
        eprintln!(
            "{defines:?}: {} sampled, {} from delta lobes, {} only delta; max relative eval error {max_rel:e}",
            tally.sampled, tally.deltas, tally.only_delta
        );
        assert!(tally.sampled > n / 2, "{} of {n} sampled", tally.sampled);
        assert!(
            tally.deltas > n / 50,
            "{} of {n} from delta lobes",
            tally.deltas
        );
    }
}

#[test]
fn coat_over_a_white_base_returns_what_it_receives_when_compensated() {
    // Compensated, the coat lobe's albedo is 1: over white Lambert or a
    // compensated white rough metal the sum is 1 at every angle.
    for &(cc, r) in &[(1.0f32, 0.0f32), (1.0, 0.3), (1.0, 0.7), (0.5, 0.5)] {
        for (name, base) in [
            ("white Lambert", white_lambert()),
            (
                "white metal roughness 0.5",
                BsdfParams::new([1.0; 3], 1.0, 0.5),
            ),
        ] {
            let p = coated(base, cc, r, true);
            for &mu in &[1.0f32, 0.5, 0.2] {
                let a = albedo(&p, mu, 1.0);
                eprintln!("coat {cc} roughness {r} over {name}, mu {mu}: albedo {a:.5} (model: 1)");
                assert!(
                    (a - 1.0).abs() < 0.01,
                    "coat {cc} r {r} over {name} mu {mu}: {a}"
                );
            }
        }
    }
}

#[test]
fn uncompensated_rough_coat_loses_what_single_scattering_loses() {
    // Without compensation the coat reflects clearcoat Fc(mu) E(alpha, mu):
    // over white Lambert, 1 - clearcoat Fc (1 - E).
    for &r in &[0.5f32, 0.8] {
        let p = coated(white_lambert(), 1.0, r, false);
        for &mu in &[1.0f32, 0.5, 0.2] {
            let a = albedo(&p, mu, 1.0);
            let fc = 0.04 + 0.96 * (1.0 - mu).powi(5);
            let want = 1.0 - fc * (1.0 - ggx_albedo(ggx_alpha(r), mu));
            let q = quadrature_albedo(&p, mu);
            eprintln!("uncompensated coat roughness {r}, mu {mu}: sampled {a:.5}, quadrature {q:.5} (model {want:.5})");
            assert!(a < 1.0 + 1e-3, "gains energy: {a}");
            // The quadrature of eval is the model up to the table's
            // interpolation; sampling adds the lobe choice's stratification.
            assert!(
                (q - want as f64).abs() < 3e-3,
                "r {r} mu {mu}: {q} vs {want}"
            );
            assert!(
                (a - want as f64).abs() < 1e-2,
                "r {r} mu {mu}: {a} vs {want}"
            );
        }
    }
}

#[test]
fn coat_over_black_shows_the_fresnel_reflectance() {
    // A black Lambert base: only the smooth coat reflects, clearcoat
    // Fc(mu), a delta lobe picked with probability clearcoat Fc(mu).
    let mut black = white_lambert();
    black.base = Vec3::ZERO;
    for &cc in &[1.0f32, 0.6] {
        let p = coated(black, cc, 0.0, false);
        for &mu in &[1.0f32, 0.7, 0.4, 0.2, 0.1] {
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let want = cc * (0.04 + 0.96 * (1.0 - mu).powi(5));
            let s = bsdf_sample(&p, wo, 0.0, 0.5, 0.5).unwrap();
            assert!(s.delta && s.wi == Vec3::new(-wo.x, -wo.y, wo.z));
            let reflectance = s.f.x * s.wi.z;
            eprintln!("smooth coat {cc} over black, mu {mu}: {reflectance:.6} (Schlick {want:.6}), picked with {:.6}", s.pdf);
            assert!(
                (reflectance - want).abs() < 1e-6,
                "cc {cc} mu {mu}: {reflectance} vs {want}"
            );
            assert!((s.pdf - want).abs() < 1e-6);
            // Nothing else: the base is black, and no sample from it carries light.
            assert!(bsdf_sample(&p, wo, 0.999, 0.3, 0.6).is_none_or(|s| s.f == Vec3::ZERO));
        }
    }
}

#[test]
fn smooth_tilted_coat_mirrors_about_its_own_normal() {
    // A coat with its own normal nc (clearcoatNormalTexture, or the
    // unmapped normal under a mapped base) over black: the delta sample
    // mirrors wo about nc and carries clearcoat Fc(wo.nc), not the base
    // normal's Fc(wo.z).
    let mut black = white_lambert();
    black.base = Vec3::ZERO;
    let mut checked = 0;
    for &tilt in &[0.2f32, -0.35, 0.5] {
        let nc = Vec3::new(tilt.sin(), 0.0, tilt.cos());
        let p = black.with_layers(Layers::new(0.8, 0.0, [0.0; 3], 0.0).with_coat_normal(nc));
        for &mu in &[1.0f32, 0.8, 0.5] {
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let c = wo.dot(nc);
            let mirror = nc * (2.0 * c) - wo;
            let want = 0.8 * (0.04 + 0.96 * (1.0 - c).powi(5));
            let s = bsdf_sample(&p, wo, 0.0, 0.5, 0.5);
            if mirror.z <= 0.0 {
                assert!(s.is_none(), "tilt {tilt} mu {mu}: mirror below the surface");
                continue;
            }
            let s = s.unwrap();
            let reflectance = s.f.x * s.wi.z;
            eprintln!("smooth coat tilted {tilt} rad over black, mu {mu}: wi {} (mirror {mirror}), {reflectance:.6} (Schlick at wo.nc {want:.6})", s.wi);
            assert!(s.delta && (s.wi - mirror).length() < 1e-5);
            assert!(
                (reflectance - want).abs() < 1e-6,
                "tilt {tilt} mu {mu}: {reflectance} vs {want}"
            );
            assert!((s.pdf - want).abs() < 1e-6);
            checked += 1;
        }
    }
    assert!(checked >= 7, "{checked} cases");
}

#[test]
fn rough_tilted_coat_samples_what_it_evaluates() {
    // Sampling, pdf and eval of a rough coat about its own normal agree:
    // the albedo by the sampler (f cos / pdf) is the albedo by quadrature
    // of bsdf_eval. Tilts in the x-z plane keep the quadrature's y symmetry.
    for &(tilt, r, compensate) in &[
        (0.3f32, 0.4f32, true),
        (-0.45, 0.6, false),
        (0.6, 0.25, true),
    ] {
        let nc = Vec3::new(tilt.sin(), 0.0, tilt.cos());
        let mut p = white_lambert();
        p.energy_compensation = compensate;
        let p = p.with_layers(Layers::new(1.0, r, [0.0; 3], 0.0).with_coat_normal(nc));
        for &mu in &[0.9f32, 0.5] {
            let (sampled, quad) = (albedo(&p, mu, 1.0), quadrature_albedo(&p, mu));
            eprintln!("rough coat tilted {tilt} rad, roughness {r}, mu {mu}: sampled {sampled:.5}, quadrature {quad:.5}");
            assert!(
                (sampled - quad).abs() < 0.01 * quad,
                "tilt {tilt} r {r} mu {mu}: {sampled} vs {quad}"
            );
            assert!(quad <= 1.0 + 1e-3, "more out than in: {quad}");
        }
    }
}

/// The albedo over the upper hemisphere by quadrature of the reference's
/// eval (`common::sphere_albedo`).
fn quadrature_albedo(p: &BsdfParams, mu: f32) -> f64 {
    common::sphere_albedo(p, mu).0
}

#[test]
fn sheen_over_white_lambert_stays_at_or_below_one_as_the_scaling_predicts() {
    for &r in &[0.2f32, 0.5, 1.0] {
        for &c in &[1.0f32, 0.5] {
            let p = sheened(white_lambert(), c, r);
            let l = p.layers.unwrap();
            for &mu in &[1.0f32, 0.5, 0.2] {
                let a = albedo(&p, mu, 1.0);
                let want = quadrature_albedo(&p, mu);
                // With the n.v term alone the scaling would give exactly
                // c E(mu) + 1 - c E(mu) = 1 (up to the table's fit of E).
                let sheen_part = c as f64 * sheen_albedo(r, mu) as f64;
                eprintln!(
                    "sheen {c} roughness {r} over white Lambert, mu {mu}: albedo {a:.5}, quadrature {want:.5}, sheen lobe {sheen_part:.4}, scaling at n.l = n.v {:.4}",
                    sheen_scaling(&l, mu, mu)
                );
                assert!(a <= 1.0 + 2e-3, "r {r} c {c} mu {mu}: {a} above 1");
                assert!(
                    want <= 1.0 + 1e-3,
                    "r {r} c {c} mu {mu}: quadrature {want} above 1"
                );
                assert!(
                    (a - want).abs() < 1e-2,
                    "r {r} c {c} mu {mu}: sampled {a} vs quadrature {want}"
                );
                // The sheen lobe alone integrates to its table value.
                let mut lobe = 0.0f64;
                let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
                let (nc, np) = (256, 128);
                for i in 0..nc {
                    let cz = (i as f64 + 0.5) / nc as f64;
                    let s = (1.0 - cz * cz).sqrt();
                    for j in 0..np {
                        let ph = std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                        let wi = Vec3::new((s * ph.cos()) as f32, (s * ph.sin()) as f32, cz as f32);
                        lobe += sheen_lobe(r, wo, wi) as f64 * cz;
                    }
                }
                lobe *= 2.0 * std::f64::consts::PI / (nc * np) as f64;
                let e = sheen_albedo(r, mu) as f64;
                assert!(
                    (lobe - e).abs() < 0.01 * e + 1e-3,
                    "E table {e} vs lobe {lobe}"
                );
                // The sampler's pdf is a density: it integrates to 1 (no
                // delta lobe here).
                let mut pdf = 0.0f64;
                for i in 0..nc {
                    let cz = (i as f64 + 0.5) / nc as f64;
                    let s = (1.0 - cz * cz).sqrt();
                    for j in 0..np {
                        let ph = std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                        let wi = Vec3::new((s * ph.cos()) as f32, (s * ph.sin()) as f32, cz as f32);
                        pdf += bsdf_pdf(&p, wo, wi) as f64;
                    }
                }
                pdf *= 2.0 * std::f64::consts::PI / (nc * np) as f64;
                assert!((pdf - 1.0).abs() < 2e-3, "pdf integrates to {pdf}");
            }
        }
    }
}

fn coat_material(base: Material, cc: f32, r: f32) -> Material {
    Material {
        clearcoat_factor: cc,
        clearcoat_roughness: r,
        ..base
    }
}

/// A unit sphere under a white sky seen orthographically: the mean over
/// the sphere's pixels of the render and of the reference's albedo at each
/// pixel's n.v (a convex surface sees only the sky: one bounce).
fn furnace_sphere(m: Material, p: &BsdfParams) -> ((f64, f64), f64) {
    let d = common::device();
    let size = 24;
    let mut s = Soup::default();
    sphere(&mut s, Vec3::ZERO, 1.0, 24, 48, 0);
    let t = table(vec![m]);
    let cam = orthographic(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, 1.0);
    let mut st = settings(size, 64);
    st.environment = Environment::Color([1.0, 1.0, 1.0]);
    st.energy_compensation = p.energy_compensation;
    let out = render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap();
    // The reference's albedo tabulated in n.v, interpolated per pixel.
    let mus: Vec<f32> = (0..=16).map(|k| (k as f32 / 16.0).max(0.02)).collect();
    let table_a: Vec<f64> = mus.iter().map(|&mu| albedo(p, mu, 1.0)).collect();
    let (mut v, mut want) = (Vec::new(), Vec::new());
    for (i, px) in out.image.rgba.iter().enumerate() {
        // Pixel centres on the film [-1, 1]^2; inside 0.9 only, away from
        // the silhouette's partly covered pixels.
        let x = ((i % size as usize) as f32 + 0.5) / size as f32 * 2.0 - 1.0;
        let y = ((i / size as usize) as f32 + 0.5) / size as f32 * 2.0 - 1.0;
        let r2 = x * x + y * y;
        if px[3] != 1.0 || r2 > 0.81 {
            continue;
        }
        let mu = (1.0 - r2).sqrt();
        let f = mu * 16.0;
        let k = (f as usize).min(15);
        let w = (f - k as f32) as f64;
        want.push(table_a[k] * (1.0 - w) + table_a[k + 1] * w);
        v.push(grey(*px));
    }
    assert!(v.len() > 200, "sphere covers {} pixels", v.len());
    let predicted = want.iter().sum::<f64>() / want.len() as f64;
    (mean_se(&v), predicted)
}

#[test]
fn coated_rough_white_metal_in_a_white_furnace_returns_what_it_receives() {
    let m = coat_material(material([1.0; 4], 1.0, 0.6), 1.0, 0.4);
    let p = coated(BsdfParams::new([1.0; 3], 1.0, 0.6), 1.0, 0.4, true);
    let ((m, se), want) = furnace_sphere(m, &p);
    eprintln!(
        "coated rough white metal furnace: device {m:.4} ± {se:.4}, reference {want:.4}, model 1"
    );
    assert!((m - 1.0).abs() < 0.01 + 3.0 * se, "{m} ± {se}");
    assert!((m - want).abs() < 0.01 + 3.0 * se, "{m} vs {want}");
}

#[test]
fn sheen_over_white_metal_in_a_white_furnace_matches_the_reference() {
    let mut m = material([1.0; 4], 1.0, 0.6);
    m.sheen_color = [1.0; 3];
    m.sheen_roughness = 0.5;
    let mut p =
        BsdfParams::new([1.0; 3], 1.0, 0.6).with_layers(Layers::new(0.0, 0.0, [1.0; 3], 0.5));
    p.energy_compensation = true;
    let ((m, se), want) = furnace_sphere(m, &p);
    eprintln!("sheen over white metal furnace: device {m:.4} ± {se:.4}, reference {want:.4}");
    assert!(m <= 1.0 + 3.0 * se, "{m} ± {se} above 1");
    assert!((m - want).abs() < 0.01 + 3.0 * se, "{m} vs {want}");
}

#[test]
fn smooth_coat_over_black_metal_shows_the_coat_fresnel_head_on() {
    // Orthographic, head-on, under a sky of 1: a smooth black metal
    // reflects (1 - mu)^5 = 0 head-on, the coat clearcoat * 0.04. Every
    // path is one delta bounce into the sky: the coat, picked with
    // probability clearcoat * 0.04, carries weight exactly 1, the base 0;
    // the image's mean is the coat's Fresnel reflectance.
    let d = common::device();
    let mut s = Soup::default();
    quad(&mut s, Vec3::ZERO, Vec3::X * 2.0, Vec3::Y * 2.0, Vec3::Z, 0);
    for &cc in &[1.0f32, 0.5] {
        let t = table(vec![coat_material(
            material([0.0, 0.0, 0.0, 1.0], 1.0, 0.0),
            cc,
            0.0,
        )]);
        let cam = orthographic(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, 0.5);
        let mut st = settings(16, 64);
        st.environment = Environment::Color([1.0, 1.0, 1.0]);
        let out = render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap();
        let want = cc as f64 * 0.04;
        let v: Vec<f64> = out.image.rgba.iter().map(|p| grey(*p)).collect();
        let (m, se) = mean_se(&v);
        eprintln!("smooth coat {cc} over black metal head-on: image mean {m:.5} ± {se:.5} (Fresnel {want})");
        assert!(
            v.iter().all(|&x| (0.0..=1.0).contains(&x)),
            "a sample weighs more than 1"
        );
        assert!(
            (m - want).abs() < 0.03 * want + 3.0 * se,
            "clearcoat {cc}: {m} ± {se} vs {want}"
        );
    }
}
