//! KHR_materials_diffuse_roughness: the EON lobe on the device against the
//! reference, a white lobe that reflects everything at every roughness, a
//! white rough dielectric in a white furnace, and a textured square under
//! a sun against the lobe's value.

use super::*;
use soupray::trace::material::{eon_eval, eon_fon_albedo};

#[test]
fn diffuse_roughness_bsdf_matches_the_reference() {
    let d = common::device();
    let mut rng = Rng::new(41);
    let n = 4000;
    let mut cases = Vec::new();
    for i in 0..n {
        let volume = i % 2 == 0;
        let transmission = if i % 3 == 0 { 0.0 } else { rng.f32() };
        let rough = if i % 5 == 0 { 0.0 } else { rng.f32().max(0.05) };
        let diffuse_roughness = if i % 7 == 0 { 0.0 } else { rng.f32() };
        let base = [rng.f32(), rng.f32(), rng.f32()];
        let metallic = if i % 3 == 0 { 0.0 } else { 0.5 * rng.f32() };
        let dl = Dielectric::new(1.0 + 1.5 * rng.f32(), transmission, volume, i % 4 < 2)
            .with_diffuse_roughness(diffuse_roughness);
        let p = BsdfParams::new(base, metallic, rough).with_dielectric(dl);
        let (wo, wi, u) = random_case(&mut rng);
        cases.push((p, wo, wi, u));
    }
    for defines in [
        &["HAS_TRANSMISSION", "HAS_DIFFUSE_ROUGHNESS"][..],
        &["HAS_DIFFUSE_ROUGHNESS", "ENERGY_LAYERING"][..],
    ] {
        let layered = defines.contains(&"ENERGY_LAYERING");
        let cases: Vec<_> = (cases.iter())
            .map(|&(mut p, wo, wi, u)| {
                p.energy_layering = layered;
                (p, wo, wi, u)
            })
            .collect();
        let tally = check_ext_probe(&d, defines, &cases, 5e-4);
        eprintln!(
            "diffuse roughness probe {defines:?}: {} sampled",
            tally.sampled
        );
        assert!(tally.sampled > n / 2, "{} of {n} sampled", tally.sampled);
    }
}

#[test]
fn white_eon_lobe_reflects_everything_at_every_roughness() {
    // The lobe's directional albedo, by quadrature over the hemisphere:
    // Fujii's single scattering loses what the multiple-scattering term
    // gives back, so white reflects 1 (to the albedo fit's accuracy), and
    // roughness 0 is Lambert's lobe exactly.
    let (nc, np) = (512, 256);
    for &r in &[0.0f32, 0.25, 0.5, 1.0] {
        for &mu in &[1.0f32, 0.7, 0.3, 0.05] {
            let wo = Vec3::new((1.0 - mu * mu).sqrt(), 0.0, mu);
            let mut sum = 0.0f64;
            for i in 0..nc {
                let c = (i as f64 + 0.5) / nc as f64;
                let s = (1.0 - c * c).sqrt();
                for j in 0..np {
                    let ph = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
                    let wi = Vec3::new((s * ph.cos()) as f32, (s * ph.sin()) as f32, c as f32);
                    sum += eon_eval(Vec3::ONE, r, wo, wi).x as f64 * c;
                }
            }
            let e = sum * 2.0 * std::f64::consts::PI / (nc * np) as f64;
            eprintln!("EON white albedo, roughness {r}, mu {mu}: {e:.5}");
            assert!((e - 1.0).abs() < 2e-3, "roughness {r} mu {mu}: {e}");
        }
    }
    assert_eq!(eon_fon_albedo(0.3, 0.0), 1.0);
    let lambert = eon_eval(Vec3::new(0.2, 0.5, 0.9), 0.0, Vec3::Z, Vec3::X);
    assert!((lambert - Vec3::new(0.2, 0.5, 0.9) * std::f32::consts::FRAC_1_PI).length() < 1e-7);
}

#[test]
fn white_rough_diffuse_dielectric_keeps_its_energy() {
    // The dielectric layer over a white EON base: what the specular layer
    // does not reflect towards wo reaches the base and comes back (the
    // energy layering), so the BSDF's albedo (by quadrature) is 1 within
    // 0.5 %. At specular roughness 0.2 the quadrature cannot resolve the
    // narrow lobe at grazing views, for Lambert's base as for EON's: there
    // the two agree. A ball of it in a white furnace vanishes.
    let white = |spec: f32, dr: f32, mu: f32| {
        let mut p = BsdfParams::new([1.0; 3], 0.0, spec)
            .with_dielectric(Dielectric::new(1.5, 0.0, false, true).with_diffuse_roughness(dr));
        p.energy_compensation = true;
        p.energy_layering = true;
        let (r, t) = sphere_albedo(&p, mu);
        assert_eq!(t, 0.0);
        r
    };
    for &spec in &[0.2f32, 0.5, 1.0] {
        for &mu in &[0.9f32, 0.5, 0.2] {
            let lambert = white(spec, 0.0, mu);
            for &dr in &[0.5f32, 1.0] {
                let a = white(spec, dr, mu);
                eprintln!(
                    "white dielectric, roughness {spec}, diffuse roughness {dr}, mu {mu}: {a:.5} \
                     (Lambert's base {lambert:.5})"
                );
                assert!((a - lambert).abs() < 1e-3, "{a} vs {lambert}");
                if spec >= 0.5 {
                    assert!((a - 1.0).abs() < 5e-3, "{a}");
                }
            }
        }
    }
    let m = Material {
        diffuse_roughness: 1.0,
        ..material([1.0; 4], 0.0, 0.6)
    };
    let (mean, se) = ball_in_white_furnace(m);
    eprintln!("diffuse roughness furnace: {mean} ± {se}");
    assert!((mean - 1.0).abs() < 4.0 * se + 0.01, "mean {mean} ± {se}");
}

#[test]
fn textured_diffuse_roughness_square_under_a_sun_matches_the_lobe() {
    use serde_json::json;
    // A Lambertian square (specularFactor 0: no Fresnel) seen head-on by an
    // orthographic camera (wo is the normal everywhere) under a sun and a
    // black sky: each pixel is the EON lobe's value times E cos, which a
    // --clay render gives (0.8 / pi E cos). diffuseRoughnessTexture's R
    // scales the factor: 0.8 x 1 on the left half, 0.8 x 0.2 on the right.
    let (left, right) = (0..28, 36..64);
    let texels = ([255u8, 0, 0, 255], [51, 0, 0, 255]);
    let uri = png_uri(texels.0, texels.1);
    let (base, factor) = ([0.9f32, 0.6, 0.3], 0.8f32);
    let square = json!({
        "pbrMetallicRoughness": {"baseColorFactor": [base[0], base[1], base[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.7},
        "extensions": {
            "KHR_materials_specular": {"specularFactor": 0.0},
            "KHR_materials_diffuse_roughness": {
                "diffuseRoughnessFactor": factor,
                "diffuseRoughnessTexture": {"index": 0}
            }
        }
    });
    let sun = Vec3::new(0.7, 0.2, 0.35).normalize();
    let black = ["--env-color", "0,0,0"];
    let clay = render_square(
        square.clone(),
        &uri,
        Some(sun),
        &["--env-color", "0,0,0", "--clay"],
    );
    let rough = render_square(square, &uri, Some(sun), &black);
    let mut means = Vec::new();
    for (cols, t) in [(left, texels.0), (right, texels.1)] {
        let r = factor * (t[0] as f32 / 255.0);
        let f = eon_eval(Vec3::from(base), r, Vec3::Z, sun);
        let mut worst = 0.0f32;
        let mut mean = 0.0f32;
        for y in 0..clay.height as usize {
            for x in cols.clone() {
                let i = y * clay.width as usize + x;
                let e_cos = clay.rgba[i][0] * std::f32::consts::PI / 0.8;
                for c in 0..3 {
                    let want = f[c] * e_cos;
                    worst = worst.max((rough.rgba[i][c] - want).abs() / want);
                }
                mean += rough.rgba[i][0] / (base[0] * e_cos * std::f32::consts::FRAC_1_PI);
            }
        }
        mean /= (clay.height as usize * cols.len()) as f32;
        eprintln!(
            "roughness {r}: pixel {:?}, lobe {f}; red over Lambert's {mean:.4}; worst relative error {worst:.2e}",
            &rough.rgba[cols.start][..3]
        );
        assert!(
            clay.rgba[cols.start][0] > 0.1,
            "the sun must light the square"
        );
        assert!(worst < 1e-4, "worst relative error {worst}");
        means.push(mean);
    }
    // Seen along the normal, a rough surface is darker than Lambert's
    // under a low sun, and more so the rougher it is.
    assert!(means[0] < means[1] && means[1] < 1.0, "{means:?}");
}
