//! Energy: the GGX energy tables against their generator, energy
//! compensation (white metals in a white furnace, the compensated device
//! BSDF against the reference), and smooth metals (a white furnace, a
//! mirror under a sun).

use super::*;

#[test]
fn energy_table_is_what_the_generator_makes() {
    use soupray::trace::energy::{generate, header_text, table, ENERGY_SIZE};
    let fresh = generate();
    common::assert_generated_table(
        &fresh,
        ENERGY_SIZE * ENERGY_SIZE,
        "kernels/generated/ggx_energy.h",
        header_text,
        table(),
    );
    // Smooth: no loss; alpha = 1 head-on: 1 - ln 2 + ... (the analytic
    // single-scattering albedo at alpha 1, mu 1 is exactly 1 - ln 2 only
    // for D = 1/pi, which alpha = 1 is).
    assert!((fresh[ENERGY_SIZE - 1] - 1.0).abs() < 1e-3);
    let rough_head_on = fresh[ENERGY_SIZE * ENERGY_SIZE - 1] as f64;
    assert!(
        (rough_head_on - (1.0 - 2f64.ln())).abs() < 2e-3,
        "{rough_head_on}"
    );
}

#[test]
fn anisotropic_energy_table_is_what_the_generator_makes() {
    use soupray::trace::energy::{
        aniso_header_text, aniso_table, generate_anisotropic, ANISO_SIZES,
    };
    let fresh = generate_anisotropic();
    common::assert_generated_table(
        &fresh,
        ANISO_SIZES.iter().product(),
        "kernels/generated/ggx_aniso_energy.h",
        aniso_header_text,
        aniso_table(),
    );
    // Isotropic nodes (sqrt(alpha / alpha_t) = 1) need no correction but
    // the isotropic table's own interpolation: within 1%. (The furnace
    // below holds what the table is for.)
    let [nt, nr, nm, np] = ANISO_SIZES;
    for i in 1..nt {
        for k in 1..nm {
            for l in 0..np {
                let c = fresh[((i * nr + nr - 1) * nm + k) * np + l];
                assert!((c - 1.0).abs() < 0.01, "node {i} {k} {l}: {c}");
            }
        }
    }
}

#[test]
fn energy_compensated_white_metal_returns_what_it_receives() {
    // The Rust reference's directional albedo, then the device in a
    // white furnace.
    for &r in &[0.3f32, 0.6, 0.8, 1.0] {
        let mut p = BsdfParams::new([1.0; 3], 1.0, r);
        let plain: Vec<f64> = [1.0f32, 0.5, 0.2]
            .iter()
            .map(|&mu| albedo(&p, mu, 1.0))
            .collect();
        p.energy_compensation = true;
        for (k, &mu) in [1.0f32, 0.5, 0.2].iter().enumerate() {
            let a = albedo(&p, mu, 1.0);
            eprintln!("roughness {r} mu {mu}: {} -> {a}", plain[k]);
            assert!((a - 1.0).abs() < 0.01, "roughness {r} mu {mu}: {a}");
        }
    }
    let d = common::device();
    let cam = perspective(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    let mut s = Soup::default();
    sphere(&mut s, Vec3::ZERO, 1.0, 16, 32, 0);
    let t = table(vec![material([1.0; 4], 1.0, 1.0)]);
    let mut means = Vec::new();
    for compensate in [false, true] {
        let mut st = settings(24, 64);
        st.environment = Environment::Color([1.0, 1.0, 1.0]);
        st.energy_compensation = compensate;
        let out = render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap();
        let v = covered(&out.image);
        let (m, se) = mean_se(&v);
        eprintln!("rough white metal furnace, compensation {compensate}: {m} ± {se}");
        means.push((m, se));
    }
    // Without: single scattering loses a good part; with: within 1%.
    assert!(means[0].0 < 0.9, "{:?}", means[0]);
    assert!(
        (means[1].0 - 1.0).abs() < 0.01 + 4.0 * means[1].1,
        "{:?}",
        means[1]
    );
}

#[test]
fn energy_compensated_bsdf_matches_the_reference() {
    let d = common::device();
    let mut rng = Rng::new(17);
    let n = 1000;
    let mut input = Vec::new();
    let mut cases = Vec::new();
    for i in 0..n {
        let mut p = BsdfParams::new(
            [rng.f32(), rng.f32(), rng.f32()],
            rng.f32(),
            // Every third smooth: the compensated delta reflection.
            if i % 3 == 1 { 0.0 } else { rng.f32().max(0.05) },
        );
        p.energy_compensation = true;
        if i % 2 == 0 {
            p = p.with_dielectric(Dielectric::new(
                1.0 + rng.f32(),
                rng.f32(),
                i % 4 == 0,
                true,
            ));
        }
        let wo = random_upper_dir(&mut rng);
        let mut wi = random_dir(&mut rng);
        if p.dielectric.is_none() {
            wi.z = wi.z.abs();
        }
        cases.push((p, wo, wi));
    }
    for with_ext in [false, true] {
        let mut defines = vec![("GGX_ENERGY_COMPENSATION", "1".to_owned())];
        if with_ext {
            defines.push(("HAS_TRANSMISSION", "1".to_owned()));
        }
        let program = d.build_program("pt_probe.cl", &defines).unwrap();
        let subset: Vec<&(BsdfParams, Vec3, Vec3)> = cases
            .iter()
            .filter(|c| c.0.dielectric.is_some() == with_ext)
            .collect();
        input.clear();
        for (p, wo, wi) in &subset {
            let dl = p
                .dielectric
                .unwrap_or(Dielectric::new(1.5, 0.0, false, true));
            let params = common::dielectric_probe_params(p, &dl);
            if with_ext {
                input.extend_from_slice(&params);
            } else {
                // bsdf_probe: the first six, padded to eight.
                input.extend_from_slice(&params[..6]);
                input.extend_from_slice(&[0.0, 0.0]);
            }
            input.extend_from_slice(&[
                wo.x, wo.y, wo.z, 0.0, wi.x, wi.y, wi.z, 0.0, 0.0, 0.5, 0.5, 0.0,
            ]);
        }
        let m = subset.len();
        let mut deltas = 0;
        let k = d
            .kernel(
                &program,
                if with_ext {
                    "bsdf_ext_probe"
                } else {
                    "bsdf_probe"
                },
            )
            .unwrap();
        let got: Vec<f32> = run_probe(&d, &k, &input, m, 12 * m);
        for (i, (p, wo, wi)) in subset.iter().enumerate() {
            let f = bsdf_eval(p, *wo, *wi);
            for c in 0..3 {
                close(
                    got[12 * i + c],
                    f[c],
                    5e-4,
                    &format!("eval {p:?} {wo} {wi}"),
                );
            }
            // Lobe 0 picks the reflection: a delta lobe when smooth, its
            // compensated reflectance the same on both sides.
            if let Some(s) = bsdf_sample(p, *wo, 0.0, 0.5, 0.5).filter(|s| s.delta) {
                let o = &got[12 * i..12 * i + 12];
                assert_eq!(o[4], 2.0, "delta sample {p:?} {wo}");
                for c in 0..3 {
                    close(o[8 + c], s.f[c], 5e-4, &format!("delta f {p:?} {wo}"));
                }
                close(o[11], s.pdf, 5e-4, &format!("delta pdf {p:?} {wo}"));
                deltas += 1;
            }
        }
        assert!(deltas > m / 5, "{deltas} of {m} from delta lobes");
    }
}

#[test]
fn smooth_white_metal_in_a_white_furnace_returns_what_it_receives() {
    // A smooth metal is a delta lobe: the mirror direction with weight F
    // (1 for white), and the environment seen along it counts in full.
    let d = common::device();
    let cam = perspective(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    let mut s = Soup::default();
    sphere(&mut s, Vec3::ZERO, 1.0, 16, 32, 0);
    let t = table(vec![material([1.0; 4], 1.0, 0.0)]);
    let mut st = settings(24, 16);
    st.environment = Environment::Color([1.0, 1.0, 1.0]);
    st.energy_compensation = true;
    let out = render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap();
    let v = covered(&out.image);
    assert!(v.len() > 150, "sphere covers {} pixels", v.len());
    let (m, se) = mean_se(&v);
    eprintln!("smooth white metal furnace: {m} ± {se}");
    assert!((m - 1.0).abs() < 0.01, "mean {m} ± {se}");
}

#[test]
fn smooth_mirror_under_a_sun_shows_the_sky_not_the_sun() {
    // A smooth white metal floor seen straight down under a sun straight
    // down: the mirror direction of every pixel is the sun's. A delta sun in
    // a delta mirror is no image (both have no extent); what each pixel
    // shows is the sky, 0.2, reflected with F = 1. As GGX at alpha 1e-3 the
    // sun's light sample landed in the lobe at every pixel: ~1e5.
    let d = common::device();
    let mut s = Soup::default();
    quad(&mut s, Vec3::ZERO, Vec3::X * 2.0, Vec3::Z * 2.0, Vec3::Y, 0);
    let t = table(vec![material([1.0; 4], 1.0, 0.0)]);
    let sun = light(
        soupray::scene::LightKind::Directional,
        Vec3::ZERO,
        Vec3::NEG_Y,
        [1.0; 3],
        3.0,
    );
    let mut st = settings(8, 4);
    st.environment = Environment::Color([0.2, 0.2, 0.2]);
    st.energy_compensation = true;
    let out = render_soup(&d, &s, &t, &top_down(1.0), &[sun], &st, 0).unwrap();
    for p in &out.image.rgba {
        for k in 0..3 {
            assert!((p[k] - 0.2).abs() < 2e-3, "pixel {p:?}");
        }
    }
}
