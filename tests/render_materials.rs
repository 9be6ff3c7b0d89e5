//! The dielectric material extensions (KHR_materials_transmission, _ior,
//! _volume): the device BSDF (`HAS_TRANSMISSION`) against its Rust
//! reference on random inputs, white furnaces of the reference's lobes, and
//! renders against analytic values: glass in a white furnace, a slab's
//! Fresnel transmittance, Beer-Lambert attenuation through a known
//! thickness, and a glass ball that shows what lies behind it flipped.

mod common;

use common::render::*;
use common::{
    albedo, check_bsdf_probe, close, random_dir, random_upper_dir, run_probe, sphere_albedo,
    BsdfProbeTally, Rng,
};
use glam::Vec3;
use soupray::scene::Material;
use soupray::soup::Soup;
use soupray::trace::material::{
    bsdf_eval, bsdf_pdf, bsdf_sample, f0_of_ior, BsdfParams, Dielectric,
};
use soupray::trace::render::{render_soup, Environment};

/// A random outgoing direction above the surface, a random direction
/// anywhere, and the sampler's three random numbers.
fn random_case(rng: &mut Rng) -> (Vec3, Vec3, [f32; 3]) {
    let wo = random_upper_dir(rng);
    let wi = random_dir(rng);
    (wo, wi, [rng.f32(), rng.f32(), rng.f32()])
}

/// Runs `bsdf_ext_probe` (built with `defines`) on `cases` (parameters with
/// the dielectric extensions, wo, wi, random numbers) and holds each to
/// the Rust reference within `rel`. The kernel reads the parameters (12
/// floats), wo, wi and u (12), and with the diffuse transmission or
/// iridescence defines the diffuse transmission and its colour and the
/// film's weight, index and thickness (8).
fn check_ext_probe(
    d: &soupray::device::Device,
    defines: &[&'static str],
    cases: &[(BsdfParams, Vec3, Vec3, [f32; 3])],
    rel: f32,
) -> BsdfProbeTally {
    let extended = defines
        .iter()
        .any(|&k| k == "HAS_DIFFUSE_TRANSMISSION" || k == "HAS_IRIDESCENCE");
    let mut input = Vec::new();
    for (p, wo, wi, u) in cases {
        let dl = p.dielectric.unwrap();
        input.extend_from_slice(&common::dielectric_probe_params(p, &dl));
        // wo's fourth float: alpha_t, read with HAS_ANISOTROPY.
        input.extend_from_slice(&[wo.x, wo.y, wo.z, p.alpha_t, wi.x, wi.y, wi.z, 0.0]);
        input.extend_from_slice(&[u[0], u[1], u[2], 0.0]);
        if extended {
            let c = dl.diffuse_transmission_color;
            input.extend_from_slice(&[dl.diffuse_transmission, c.x, c.y, c.z]);
            input.extend_from_slice(&[
                dl.iridescence,
                dl.iridescence_ior,
                dl.iridescence_thickness,
                0.0,
            ]);
        }
    }
    let defines: Vec<(&str, String)> = defines.iter().map(|&k| (k, "1".to_owned())).collect();
    let program = d.build_program("pt_probe.cl", &defines).unwrap();
    let k = d.kernel(&program, "bsdf_ext_probe").unwrap();
    let n = cases.len();
    let got: Vec<f32> = run_probe(d, &k, &input, n, 12 * n);
    let mut tally = BsdfProbeTally::default();
    for (i, (p, wo, wi, u)) in cases.iter().enumerate() {
        let what = format!("case {i} {p:?} wo {wo} wi {wi}");
        check_bsdf_probe(
            &got[12 * i..12 * i + 12],
            p,
            *wo,
            *wi,
            *u,
            rel,
            &what,
            &mut tally,
        );
    }
    tally
}

fn glass(transmission: f32, ior: f32, volume: bool) -> Material {
    Material {
        transmission_factor: transmission,
        ior,
        thickness_factor: if volume { 1.0 } else { 0.0 },
        double_sided: true,
        ..material([1.0; 4], 0.0, 0.0)
    }
}

#[test]
fn dielectric_bsdf_matches_the_reference() {
    let d = common::device();
    let mut rng = Rng::new(13);
    let n = 4000;
    let mut cases = Vec::new();
    for i in 0..n {
        let ior = 1.0 + 1.5 * rng.f32();
        let transmission = if i % 3 == 0 { 1.0 } else { rng.f32() };
        let volume = i % 2 == 0;
        let front = i % 4 < 2;
        let rough = if i % 5 == 0 { 0.0 } else { rng.f32().max(0.05) };
        let base = [rng.f32(), rng.f32(), rng.f32()];
        let metallic = if i % 3 == 0 { 0.0 } else { rng.f32() };
        let mut dl = Dielectric::new(ior, transmission, volume, front);
        if i % 7 == 1 {
            // KHR_materials_specular: a coloured, weighted layer.
            dl = dl.with_specular_color([3.0 * rng.f32(), 3.0 * rng.f32(), 3.0 * rng.f32()]);
        }
        let mut p = BsdfParams::new(base, metallic, rough).with_dielectric(dl);
        if i % 7 == 1 {
            p.specular = rng.f32();
        }
        let (wo, wi, u) = random_case(&mut rng);
        cases.push((p, wo, wi, u));
    }
    let tally = check_ext_probe(&d, &["HAS_TRANSMISSION"], &cases, 5e-4);
    let BsdfProbeTally {
        sampled,
        transmitted,
        deltas,
        only_delta,
    } = tally;
    assert!(sampled > n / 2, "{sampled} of {n} sampled");
    assert!(transmitted > n / 5, "{transmitted} of {n} transmitted");
    assert!(deltas > n / 20, "{deltas} of {n} from delta lobes");
    assert!(only_delta > 0, "no material with only delta lobes");
}

/// Also checks that the sampler's pdf is the one `bsdf_pdf` gives: the
/// mean of 1/pdf over the samples of one lobe is no check of energy, so
/// instead the estimate is compared with a quadrature of eval over the
/// sphere for a rough lobe (below).
#[test]
fn furnace_smooth_glass_lobes_conserve_energy() {
    for &mu in &[1.0f32, 0.7, 0.3] {
        // Thin-walled: Fresnel reflection plus the rest straight through.
        let thin = BsdfParams::new([1.0; 3], 0.0, 0.0)
            .with_dielectric(Dielectric::new(1.5, 1.0, false, true));
        let a = albedo(&thin, mu, 1.0);
        eprintln!("thin mu {mu}: {a}");
        assert!((a - 1.0).abs() < 0.01, "thin mu {mu}: {a}");
        // Entering and leaving a volume (leaving: total internal reflection
        // past the critical angle; the Fresnel reflectance makes up the rest).
        for front in [true, false] {
            let glass = BsdfParams::new([1.0; 3], 0.0, 0.0)
                .with_dielectric(Dielectric::new(1.5, 1.0, true, front));
            let eta = glass.dielectric.unwrap().eta;
            let a = albedo(&glass, mu, eta * eta);
            eprintln!("volume front {front} mu {mu}: {a}");
            assert!((a - 1.0).abs() < 0.01, "volume front {front} mu {mu}: {a}");
        }
    }
}

#[test]
fn rough_transmission_pdf_integrates_to_the_lobe_probability() {
    // The pdf of a rough refraction over the lower hemisphere, by midpoint
    // quadrature, is the probability of choosing the transmission lobe
    // less what falls outside (total internal reflection, below-surface
    // microfacets): at most it, and most of it.
    let p =
        BsdfParams::new([1.0; 3], 0.0, 0.6).with_dielectric(Dielectric::new(1.5, 1.0, true, true));
    let wo = Vec3::new(0.6, 0.0, 0.8);
    let (nm, np) = (400, 400);
    let mut pdf_sum = 0.0f64;
    for i in 0..nm {
        let c = (i as f64 + 0.5) / nm as f64;
        let s = (1.0 - c * c).sqrt();
        for j in 0..np {
            let ph = 2.0 * std::f64::consts::PI * (j as f64 + 0.5) / np as f64;
            let wi = Vec3::new((s * ph.cos()) as f32, (s * ph.sin()) as f32, -c as f32);
            pdf_sum += bsdf_pdf(&p, wo, wi) as f64;
        }
    }
    let integral = pdf_sum * 2.0 * std::f64::consts::PI / (nm * np) as f64;
    let pt =
        soupray::trace::material::lobe_probabilities(&p, &p.dielectric.unwrap(), wo.z).1 as f64;
    assert!(
        integral <= pt * 1.01 && integral > pt * 0.9,
        "integral {integral} vs lobe probability {pt}"
    );
}

/// A unit ball of `m` in a white furnace (24x24, 64 spp, 24 bounces): the
/// mean and standard error of the pixels it covers.
fn ball_in_white_furnace(m: Material) -> (f64, f64) {
    let v = covered(&ball_in_white_furnace_image(m));
    assert!(v.len() > 150, "the ball covers {} pixels", v.len());
    mean_se(&v)
}

/// The image `ball_in_white_furnace` measures.
fn ball_in_white_furnace_image(m: Material) -> soupray::film::Image {
    let d = common::device();
    let cam = perspective(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    let mut st = settings(24, 64);
    st.max_depth = 24;
    st.environment = Environment::Color([1.0, 1.0, 1.0]);
    let mut s = Soup::default();
    sphere(&mut s, Vec3::ZERO, 1.0, 16, 32, 0);
    render_soup(&d, &s, &table(vec![m]), &cam, &[], &st, 0)
        .unwrap()
        .image
}

/// The mean and its standard error of each colour channel over the pixels
/// an object covers fully.
fn covered_channels(img: &soupray::film::Image) -> [(f64, f64); 3] {
    let inside: Vec<&[f32; 4]> = img.rgba.iter().filter(|p| p[3] == 1.0).collect();
    assert!(inside.len() > 150, "{} pixels covered", inside.len());
    [0, 1, 2].map(|c| mean_se(&inside.iter().map(|p| p[c] as f64).collect::<Vec<_>>()))
}

#[test]
fn glass_in_a_white_furnace_is_invisible() {
    for volume in [true, false] {
        let (m, se) = ball_in_white_furnace(glass(1.0, 1.5, volume));
        eprintln!("glass furnace, volume {volume}: {m} ± {se}");
        // Paths cut by the depth limit inside the ball lose a little.
        assert!(
            (m - 1.0).abs() < 4.0 * se + 0.01,
            "volume {volume}: mean {m} ± {se}"
        );
    }
}

/// A slab of glass (|z| < half) between an orthographic camera and an
/// emitter of radiance 1, in a black world: the centre pixels see the
/// slab's transmittance.
fn slab_transmittance(mat: Material, half: f32) -> f64 {
    let img = slab_image(mat, half, 256);
    let v: Vec<f64> = img.rgba.iter().map(|p| grey(*p)).collect();
    mean_se(&v).0
}

/// The image `slab_transmittance` measures, at `spp`.
fn slab_image(mat: Material, half: f32, spp: u32) -> soupray::film::Image {
    let d = common::device();
    let mut s = Soup::default();
    // A box 4 x 4 wide, 2 * half thick.
    let (w, h) = (2.0, half);
    for (n, c, u, v) in [
        (Vec3::Z, Vec3::Z * h, Vec3::X * w, Vec3::Y * w),
        (Vec3::NEG_Z, Vec3::NEG_Z * h, Vec3::X * w, Vec3::Y * w),
        (Vec3::X, Vec3::X * w, Vec3::Y * w, Vec3::Z * h),
        (Vec3::NEG_X, Vec3::NEG_X * w, Vec3::Y * w, Vec3::Z * h),
        (Vec3::Y, Vec3::Y * w, Vec3::X * w, Vec3::Z * h),
        (Vec3::NEG_Y, Vec3::NEG_Y * w, Vec3::X * w, Vec3::Z * h),
    ] {
        quad(&mut s, c, u, v, n, 0);
    }
    quad(
        &mut s,
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::X * 10.0,
        Vec3::Y * 10.0,
        Vec3::Z,
        1,
    );
    let mut emitter = material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
    emitter.emissive_factor = [1.0; 3];
    let t = table(vec![mat, emitter]);
    let cam = orthographic(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 0.5);
    let mut st = settings(8, spp);
    st.max_depth = 24;
    st.environment = Environment::Color([0.0; 3]);
    render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap().image
}

#[test]
fn glass_slab_transmits_the_fresnel_transmittance() {
    // Normal incidence: R = f0 at each face, and the inter-reflections
    // sum to (1 - R)^2 / (1 - R^2) = (1 - R) / (1 + R).
    let r = f0_of_ior(1.5) as f64;
    let want = (1.0 - r) / (1.0 + r);
    let got = slab_transmittance(glass(1.0, 1.5, true), 0.25);
    eprintln!("slab ior 1.5: {got} (analytic {want})");
    assert!((got - want).abs() < 0.01 * want, "{got} vs {want}");
    // A higher index reflects more at each face.
    let r = f0_of_ior(2.4) as f64;
    let want = (1.0 - r) / (1.0 + r);
    let got = slab_transmittance(glass(1.0, 2.4, true), 0.25);
    eprintln!("slab ior 2.4: {got} (analytic {want})");
    assert!((got - want).abs() < 0.01 * want, "ior 2.4: {got} vs {want}");
}

#[test]
fn volume_attenuates_by_beer_lambert() {
    // attenuationColor 0.5 at attenuationDistance = the slab's thickness:
    // each crossing transmits tau = 0.5 per channel; with the faces'
    // Fresnel: (1 - R)^2 tau / (1 - R^2 tau^2).
    let mut m = glass(1.0, 1.5, true);
    m.attenuation_color = [0.5, 0.5, 0.5];
    m.attenuation_distance = 0.5;
    let got = slab_transmittance(m, 0.25);
    let (r, tau) = (f0_of_ior(1.5) as f64, 0.5f64);
    let want = (1.0 - r) * (1.0 - r) * tau / (1.0 - r * r * tau * tau);
    eprintln!("attenuating slab: {got} (analytic {want})");
    assert!((got - want).abs() < 0.01 * want, "{got} vs {want}");
}

#[test]
fn glass_ball_shows_the_boxes_behind_it_flipped() {
    // A red emitter box on the left and a blue one on the right, far behind
    // a glass ball: through the ball (a thick lens, focal length 1.5 radii
    // from its centre) they appear swapped; beside it, as they are.
    let d = common::device();
    let mut s = Soup::default();
    sphere(&mut s, Vec3::ZERO, 1.0, 24, 48, 0);
    cube(&mut s, Vec3::new(-2.0, 0.0, -6.0), 1.5, 1);
    cube(&mut s, Vec3::new(2.0, 0.0, -6.0), 1.5, 2);
    let emitter = |c: [f32; 3]| {
        let mut m = material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
        m.emissive_factor = c;
        m
    };
    let t = table(vec![
        glass(1.0, 1.5, true),
        emitter([1.0, 0.0, 0.0]),
        emitter([0.0, 0.0, 1.0]),
    ]);
    let cam = perspective(Vec3::new(0.0, 0.0, 6.0), Vec3::ZERO, Vec3::Y, 40.0);
    let mut st = settings(48, 16);
    st.max_depth = 12;
    st.environment = Environment::Color([0.0; 3]);
    let out = render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap();
    let px = |x: usize, y: usize| out.image.rgba[y * 48 + x];
    // The ball spans about 17 pixels either side of the centre.
    let (mut left, mut right) = ([0.0f64; 3], [0.0f64; 3]);
    for y in 20..28 {
        for x in 16..22 {
            let p = px(x, y);
            for k in 0..3 {
                left[k] += p[k] as f64;
            }
        }
        for x in 26..32 {
            let p = px(x, y);
            for k in 0..3 {
                right[k] += p[k] as f64;
            }
        }
    }
    eprintln!("left {left:?} right {right:?}");
    assert!(
        left[2] > 4.0 * left[0] && left[2] > 1.0,
        "left of the ball's centre shows blue: {left:?}"
    );
    assert!(
        right[0] > 4.0 * right[2] && right[0] > 1.0,
        "right of the ball's centre shows red: {right:?}"
    );
}

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
fn the_shipped_animation_compiles_no_material_extension_code() {
    // Only what the scene needs: CesiumMan uses none of the extensions, so
    // its program is built with exactly the defines it had before them.
    use soupray::scene::{LoadOptions, Scene};
    use soupray::trace::render::{material_features, pathtrace_defines, Lobes, Traversal};
    use soupray::trace::sampling::Sampler;
    let Some(path) = common::shared::cesium_man() else {
        return;
    };
    let scene = Scene::load(&path, &LoadOptions::default()).unwrap();
    let table = scene.materials();
    assert!(!table.materials.iter().any(|m| m.needs_transmission()));
    assert!(!scene.warnings().iter().any(|w| w.contains("KHR_materials")));
    assert_eq!(
        material_features(table, true, false),
        ["metallic_roughness", "textures"]
    );
    let names: Vec<&str> = pathtrace_defines(
        Traversal::Wide,
        true,
        Sampler::Sobol,
        false,
        false,
        false,
        Lobes::of(table),
    )
    .iter()
    .map(|(n, _)| *n)
    .collect();
    assert_eq!(names, ["STACK_SIZE", "TRAVERSAL_WIDE", "HAS_TEXTURES"]);
}

#[test]
fn unlit_surfaces_show_their_base_colour_whatever_the_light() {
    // KHR_materials_unlit: an unlit quad under a bright sun and sky shows
    // exactly its base colour; beside it, a lit white diffuse quad does not.
    let d = common::device();
    let mut s = Soup::default();
    quad(
        &mut s,
        Vec3::new(-0.5, 0.0, 0.0),
        Vec3::X * 0.5,
        Vec3::Z * 0.5,
        Vec3::Y,
        0,
    );
    quad(
        &mut s,
        Vec3::new(0.5, 0.0, 0.0),
        Vec3::X * 0.5,
        Vec3::Z * 0.5,
        Vec3::Y,
        1,
    );
    let unlit = Material {
        unlit: true,
        ..material([0.2, 0.5, 0.9, 1.0], 0.0, 1.0)
    };
    let t = table(vec![unlit, material([1.0; 4], 0.0, 1.0)]);
    let sun = light(
        soupray::scene::LightKind::Directional,
        Vec3::ZERO,
        Vec3::NEG_Y,
        [1.0; 3],
        5.0,
    );
    let mut st = settings(16, 4);
    st.environment = Environment::Color([0.5, 0.5, 0.5]);
    let out = render_soup(&d, &s, &t, &top_down(1.0), &[sun], &st, 0).unwrap();
    let left = out.image.rgba[8 * 16 + 3];
    let right = out.image.rgba[8 * 16 + 12];
    for (k, want) in [0.2f32, 0.5, 0.9].iter().enumerate() {
        assert!((left[k] - want).abs() < 1e-6, "unlit pixel {left:?}");
    }
    assert!(right[0] > 1.0, "lit pixel {right:?}");
}

#[test]
fn specular_extension_weights_and_colours_the_dielectric_layer() {
    // specularFactor 0: no layer at all, a white dielectric is exactly
    // Lambertian (albedo 1 at every angle).
    let mut p =
        BsdfParams::new([1.0; 3], 0.0, 0.5).with_dielectric(Dielectric::new(1.5, 0.0, false, true));
    p.specular = 0.0;
    for &mu in &[1.0f32, 0.5, 0.2] {
        let a = albedo(&p, mu, 1.0);
        assert!((a - 1.0).abs() < 2e-3, "mu {mu}: {a}");
    }
    // A coloured layer on a black base reflects its colour: head-on the
    // smooth layer returns F0 = min(f0 * colour, 1) per channel.
    let q = BsdfParams::new([0.0; 3], 0.0, 0.0).with_dielectric(
        Dielectric::new(1.5, 0.0, false, true).with_specular_color([2.0, 1.0, 0.0]),
    );
    let wo = Vec3::Z;
    let mut sum = Vec3::ZERO;
    let n = 64;
    for i in 0..n {
        for j in 0..n {
            let (u1, u2) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            if let Some(s) = bsdf_sample(&q, wo, 0.0, u1, u2) {
                sum += s.f * s.wi.z / s.pdf;
            }
        }
    }
    let r = sum / (n * n) as f32;
    let f0 = f0_of_ior(1.5);
    eprintln!("coloured layer head-on: {r} (f0 {f0})");
    assert!(
        (r.x - 2.0 * f0).abs() < 2e-3 && (r.y - f0).abs() < 2e-3 && r.z < 1e-4,
        "{r}"
    );
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

/// A glass ball (roughness `roughness`) on a white floor under a sun and a
/// dim sky, seen from above at an angle: the grey of every pixel.
fn glass_ball_under_a_sun(roughness: f32, spp: u32) -> Vec<f64> {
    let d = common::device();
    let mut s = Soup::default();
    quad(&mut s, Vec3::ZERO, Vec3::X * 2.0, Vec3::Z * 2.0, Vec3::Y, 0);
    sphere(&mut s, Vec3::new(0.0, 0.5, 0.0), 0.5, 16, 32, 1);
    let ball = Material {
        roughness_factor: roughness,
        ..glass(1.0, 1.5, true)
    };
    let t = table(vec![material([0.8, 0.8, 0.8, 1.0], 0.0, 1.0), ball]);
    let sun = light(
        soupray::scene::LightKind::Directional,
        Vec3::ZERO,
        Vec3::new(0.3, -1.0, 0.2).normalize(),
        [1.0; 3],
        3.0,
    );
    let cam = perspective(Vec3::new(0.0, 2.5, 2.5), Vec3::ZERO, Vec3::Y, 50.0);
    let mut st = settings(32, spp);
    st.max_depth = 8;
    st.environment = Environment::Color([0.2, 0.2, 0.2]);
    let out = render_soup(&d, &s, &t, &cam, &[sun], &st, 0).unwrap();
    out.image.rgba.iter().map(|p| grey(*p)).collect()
}

#[test]
fn smooth_glass_ball_under_a_sun_shows_no_fireflies() {
    // Smooth glass as GGX at alpha 1e-3 let the sun's sample land in its
    // tiny lobe now and then, worth ~1/(pi alpha^2): white specks. As delta
    // lobes, light sampling leaves them out.
    let smooth = glass_ball_under_a_sun(0.0, 128);
    // Just above the smooth threshold: the near-delta GGX lobe still there.
    let near = glass_ball_under_a_sun(0.04, 128);
    let stats = |v: &[f64]| {
        let max = v.iter().cloned().fold(0.0, f64::max);
        let (m, se) = mean_se(v);
        (max, m, se)
    };
    let (smax, smean, sse) = stats(&smooth);
    let (nmax, nmean, nse) = stats(&near);
    eprintln!(
        "smooth: max {smax} mean {smean} ± {sse}; alpha 1.6e-3: max {nmax} mean {nmean} ± {nse}"
    );
    // The true scale: the floor under sun and sky is about 0.9 at most.
    assert!(smax < 2.0, "brightest pixel {smax}");
    // Same light as the near-delta lobe brings (same seed: the two
    // estimates are correlated, so their difference is far below se).
    assert!((smean - nmean).abs() < 0.02, "mean {smean} vs {nmean}");
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

/// A 2x1 RGBA PNG (left texel, right texel) as a data URI.
fn png_uri(left: [u8; 4], right: [u8; 4]) -> String {
    let img = image::RgbaImage::from_raw(2, 1, [left, right].concat()).unwrap();
    let mut png = std::io::Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png).unwrap();
    format!(
        "data:image/png;base64,{}",
        common::scene::base64(png.get_ref())
    )
}

/// Renders, at 64x32 and 16 spp under a blue-grey sky, a square facing an
/// orthographic camera that fills the frame, its UVs running 0-1 left to
/// right, with `material` (whose textures, if any, are image 0: `uri`,
/// nearest-filtered).
fn render_textured_square(material: serde_json::Value, uri: &str) -> soupray::film::Image {
    render_square(material, uri, None, &["--env-color", "0.5,0.6,0.8"])
}

/// As `render_textured_square`, lit by a directional light of intensity 3
/// arriving from `sun` (unit, world; the square faces +z) when given, with
/// the extra options `args` (the sky's colour among them).
fn render_square(
    material: serde_json::Value,
    uri: &str,
    sun: Option<Vec3>,
    args: &[&str],
) -> soupray::film::Image {
    use serde_json::json;
    let dir = tempfile::tempdir().unwrap();
    let mut b = common::scene::Builder::default();
    let p = b.floats(
        &[
            -1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0,
        ],
        3,
    );
    let n = b.floats(&[0.0, 0.0, 1.0].repeat(4), 3);
    let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], 2);
    let ix = b.u32s(&[0, 1, 2, 0, 2, 3]);
    let mut root = json!({
        "extensionsUsed": ["KHR_texture_transform", "KHR_materials_transmission", "KHR_materials_specular",
                           "KHR_materials_clearcoat", "KHR_materials_sheen", "KHR_materials_diffuse_transmission",
                           "KHR_materials_iridescence", "KHR_lights_punctual"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0.0, 0.0, 3.0]}],
        "cameras": [{"type": "orthographic", "orthographic": {"xmag": 0.9, "ymag": 0.45, "znear": 0.01, "zfar": 100.0}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": uv}, "indices": ix, "material": 0}]}],
        "materials": [material],
        "images": [{"uri": uri}],
        "samplers": [{"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}],
        "textures": [{"source": 0, "sampler": 0}],
    });
    if let Some(sun) = sun {
        // A directional light shines along its node's -z: turn +z to `sun`.
        let q = glam::Quat::from_rotation_arc(Vec3::Z, sun);
        root["extensions"] =
            json!({"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 3.0}]}});
        root["nodes"].as_array_mut().unwrap().push(json!({
            "rotation": [q.x, q.y, q.z, q.w],
            "extensions": {"KHR_lights_punctual": {"light": 0}}
        }));
        root["scenes"][0]["nodes"] = json!([0, 1, 2]);
    }
    let scene = b.write(root, dir.path(), "square", true);
    let out = common::soupray_cmd()
        .arg("render")
        .arg(&scene)
        .args([
            "--frame", "0", "--width", "64", "--height", "32", "--spp", "16",
        ])
        .args(["--seed", "5", "--quiet"])
        .args(args)
        .args([
            "--out",
            dir.path().to_str().unwrap(),
            "--name",
            "sq.####.exr",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let log = std::fs::read_to_string(dir.path().join("sq.0000.json")).unwrap();
    assert!(
        !log.contains("is not supported") && !log.contains("ignores"),
        "an extension or texture was reported as ignored: {log}"
    );
    common::read_exr(&dir.path().join("sq.0000.exr"))
}

/// The largest relative difference between `a` and `b` over the pixels of
/// columns `cols` (RGB).
fn max_rel_diff(
    a: &soupray::film::Image,
    b: &soupray::film::Image,
    cols: std::ops::Range<usize>,
) -> f32 {
    let mut worst = 0.0f32;
    for y in 0..a.height as usize {
        for x in cols.clone() {
            let (p, q) = (
                a.rgba[y * a.width as usize + x],
                b.rgba[y * b.width as usize + x],
            );
            for c in 0..3 {
                worst = worst.max((p[c] - q[c]).abs() / q[c].abs().max(1e-3));
            }
        }
    }
    worst
}

/// Each half of `textured` (columns 0-27 and 36-63: the pixel filter
/// reaches 4 pixels across the seam) renders as the factor-only render of
/// that half's texel (`lf`, `rf`), and those two differ.
fn assert_halves_match(
    what: &str,
    textured: &soupray::film::Image,
    lf: &soupray::film::Image,
    rf: &soupray::film::Image,
) {
    let (left, right) = (0..28, 36..64);
    let (l, r) = (
        max_rel_diff(textured, lf, left.clone()),
        max_rel_diff(textured, rf, right),
    );
    eprintln!("{what} textures: left {l:.2e}, right {r:.2e}");
    assert!(l < 1e-5 && r < 1e-5, "{what}: left {l}, right {r}");
    assert!(max_rel_diff(lf, rf, left) > 0.05);
}

#[test]
fn extension_textures_scale_their_factors() {
    use serde_json::json;
    // Each half of the square samples one texel (nearest filtering), so a
    // textured material must render each half as the untextured material
    // whose factor is the factor times that texel. Columns within 4 pixels
    // of the seam (the pixel filter reaches across it) are left out.
    let (left, right) = (0..28, 36..64);
    let byte = |b: u8| b as f32 / 255.0;
    let srgb = |b: u8| soupray::trace::texture::srgb_to_linear(byte(b));
    let blank = png_uri([255; 4], [255; 4]);

    // transmissionTexture (R), through a KHR_texture_transform that mirrors
    // u (offset 1, scale -1): the left half reads the right texel.
    let glass = |factor: f32, texture: Option<serde_json::Value>| {
        let mut t = json!({"transmissionFactor": factor});
        if let Some(tex) = texture {
            t["transmissionTexture"] = tex;
        }
        json!({
            "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.3, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.4},
            "doubleSided": true,
            "extensions": {"KHR_materials_transmission": t}
        })
    };
    let textured = render_textured_square(
        glass(
            0.9,
            Some(
                json!({"index": 0, "extensions": {"KHR_texture_transform": {"offset": [1.0, 0.0], "scale": [-1.0, 1.0]}}}),
            ),
        ),
        &png_uri([64, 0, 0, 255], [255, 0, 0, 255]),
    );
    let full = render_textured_square(glass(0.9 * byte(255), None), &blank);
    let quarter = render_textured_square(glass(0.9 * byte(64), None), &blank);
    let (l, r) = (
        max_rel_diff(&textured, &full, left.clone()),
        max_rel_diff(&textured, &quarter, right.clone()),
    );
    eprintln!(
        "transmission texture: left vs factor 0.9: {l:.2e}, right vs factor 0.9*64/255: {r:.2e}"
    );
    assert!(l < 1e-5 && r < 1e-5, "left {l}, right {r}");
    // The two factors give visibly different images, so the check above
    // would catch a texture that is ignored.
    assert!(max_rel_diff(&full, &quarter, left.clone()) > 0.05);

    // specularTexture (A) and specularColorTexture (RGB, sRGB) from one
    // image, on a black dielectric: only the specular layer shows.
    let coat = |factor: f32, color: [f32; 3], textured: bool| {
        let mut sp = json!({"specularFactor": factor, "specularColorFactor": color});
        if textured {
            sp["specularTexture"] = json!({"index": 0});
            sp["specularColorTexture"] = json!({"index": 0});
        }
        json!({
            "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.3},
            "extensions": {"KHR_materials_specular": sp}
        })
    };
    let textured = render_textured_square(
        coat(0.8, [1.0, 0.9, 0.7], true),
        &png_uri([255, 40, 0, 255], [0, 255, 128, 100]),
    );
    let lf = render_textured_square(coat(0.8, [srgb(255), 0.9 * srgb(40), 0.0], false), &blank);
    let rf = render_textured_square(
        coat(0.8 * byte(100), [0.0, 0.9, 0.7 * srgb(128)], false),
        &blank,
    );
    assert_halves_match("specular", &textured, &lf, &rf);
}

#[test]
fn layer_textures_scale_their_factors() {
    use serde_json::json;
    // As extension_textures_scale_their_factors, for the clear coat's and
    // the sheen's textures: each half must render as the untextured
    // material whose factors are the factors times that half's texel.
    let byte = |b: u8| b as f32 / 255.0;
    let srgb = |b: u8| soupray::trace::texture::srgb_to_linear(byte(b));
    let blank = png_uri([255; 4], [255; 4]);
    let base = json!({"baseColorFactor": [0.6, 0.2, 0.1, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5});

    // clearcoatTexture (R) and clearcoatRoughnessTexture (G), one image.
    let coat = |factor: f32, roughness: f32, textured: bool| {
        let mut cc = json!({"clearcoatFactor": factor, "clearcoatRoughnessFactor": roughness});
        if textured {
            cc["clearcoatTexture"] = json!({"index": 0});
            cc["clearcoatRoughnessTexture"] = json!({"index": 0});
        }
        json!({"pbrMetallicRoughness": base, "extensions": {"KHR_materials_clearcoat": cc}})
    };
    let textured = render_textured_square(
        coat(0.9, 0.8, true),
        &png_uri([200, 60, 0, 255], [40, 230, 0, 255]),
    );
    let lf = render_textured_square(coat(0.9 * byte(200), 0.8 * byte(60), false), &blank);
    let rf = render_textured_square(coat(0.9 * byte(40), 0.8 * byte(230), false), &blank);
    assert_halves_match("clear coat", &textured, &lf, &rf);

    // sheenColorTexture (RGB, sRGB) and sheenRoughnessTexture (A).
    let sheen = |color: [f32; 3], roughness: f32, textured: bool| {
        let mut sh = json!({"sheenColorFactor": color, "sheenRoughnessFactor": roughness});
        if textured {
            sh["sheenColorTexture"] = json!({"index": 0});
            sh["sheenRoughnessTexture"] = json!({"index": 0});
        }
        json!({"pbrMetallicRoughness": base, "extensions": {"KHR_materials_sheen": sh}})
    };
    let textured = render_textured_square(
        sheen([1.0, 0.8, 0.6], 0.9, true),
        &png_uri([255, 128, 30, 200], [60, 200, 255, 50]),
    );
    let lf = render_textured_square(
        sheen(
            [srgb(255), 0.8 * srgb(128), 0.6 * srgb(30)],
            0.9 * byte(200),
            false,
        ),
        &blank,
    );
    let rf = render_textured_square(
        sheen(
            [srgb(60), 0.8 * srgb(200), 0.6 * srgb(255)],
            0.9 * byte(50),
            false,
        ),
        &blank,
    );
    assert_halves_match("sheen", &textured, &lf, &rf);
}

#[test]
fn clearcoat_normal_map_tilts_the_coat_and_the_base_normal_map_does_not() {
    use serde_json::json;
    use soupray::trace::material::{bsdf_eval, BsdfParams, Layers};
    // A rough coat (roughness 0.3) over black metal, head-on under a sun
    // and a black sky: every sample sees only the sun through the coat's
    // lobe, so the image is f(wo, sun) cos E everywhere, no noise. The
    // coat normal texel is tilted ~20 degrees and the sun placed at the
    // mirror of the view about it: the coat's glint. E comes from a
    // `--clay` render (0.8/pi cos E).
    let texel = [171u8, 128, 247, 255];
    let tilted = Vec3::new(
        texel[0] as f32 / 255.0 * 2.0 - 1.0,
        texel[1] as f32 / 255.0 * 2.0 - 1.0,
        texel[2] as f32 / 255.0 * 2.0 - 1.0,
    )
    .normalize();
    let sun = (tilted * (2.0 * tilted.z) - Vec3::Z).normalize();
    let uri = png_uri(texel, texel);
    let coat = |coat_map: bool, base_map: bool| {
        let mut cc = json!({"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.3});
        if coat_map {
            cc["clearcoatNormalTexture"] = json!({"index": 0});
        }
        let mut m = json!({
            "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 1.0, "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_clearcoat": cc}
        });
        if base_map {
            m["normalTexture"] = json!({"index": 0});
        }
        m
    };
    let black = ["--env-color", "0,0,0"];
    let mean = |img: &soupray::film::Image| {
        img.rgba
            .iter()
            .map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0)
            .sum::<f64>()
            / img.rgba.len() as f64
    };
    let clay = mean(&render_square(
        coat(false, false),
        &uri,
        Some(sun),
        &["--env-color", "0,0,0", "--clay"],
    ));
    let irradiance = clay * std::f64::consts::PI / 0.8; // E cos(sun)
    let predict = |n: Vec3| {
        let mut p = BsdfParams::new([0.0; 3], 1.0, 1.0);
        p.energy_compensation = true;
        let p = p.with_layers(Layers::new(1.0, 0.3, [0.0; 3], 0.0).with_coat_normal(n));
        bsdf_eval(&p, Vec3::Z, sun).x as f64 * irradiance
    };
    let glint = mean(&render_square(coat(true, false), &uri, Some(sun), &black));
    let plain = mean(&render_square(coat(false, false), &uri, Some(sun), &black));
    let base_mapped = mean(&render_square(coat(false, true), &uri, Some(sun), &black));
    let (want_glint, want_plain) = (predict(tilted), predict(Vec3::Z));
    eprintln!(
        "coat normal map: {glint:.5} (reference {want_glint:.5}); none: {plain:.5} (reference {want_plain:.5}); \
         base normal map only: {base_mapped:.5}"
    );
    assert!(
        (glint - want_glint).abs() < 2e-3 * want_glint,
        "{glint} vs {want_glint}"
    );
    assert!(
        (plain - want_plain).abs() < 2e-3 * want_plain,
        "{plain} vs {want_plain}"
    );
    assert!(
        glint > 20.0 * plain,
        "the tilted coat should catch the sun: {glint} vs {plain}"
    );
    // The extension keeps the base's normal map off the coat.
    assert!(
        (base_mapped - plain).abs() < 0.01 * plain,
        "the base's normal map moved the coat: {base_mapped} vs {plain}"
    );
}

#[test]
fn diffuse_transmission_bsdf_matches_the_reference() {
    let d = common::device();
    let mut rng = Rng::new(29);
    let n = 4000;
    let mut cases = Vec::new();
    let mut smooth_transmitted = 0;
    for i in 0..n {
        let volume = i % 2 == 0;
        let front = i % 4 < 2;
        let transmission = if i % 3 == 0 { 0.0 } else { rng.f32() };
        let dt = if i % 4 == 1 { 1.0 } else { rng.f32() };
        let color = [rng.f32(), rng.f32(), rng.f32()];
        let rough = if i % 5 == 0 { 0.0 } else { rng.f32().max(0.05) };
        let base = [rng.f32(), rng.f32(), rng.f32()];
        let metallic = if i % 3 == 0 { 0.0 } else { 0.5 * rng.f32() };
        let mut dl = Dielectric::new(1.0 + 1.5 * rng.f32(), transmission, volume, front)
            .with_diffuse_transmission(dt, color);
        if i % 7 == 1 {
            dl = dl.with_specular_color([3.0 * rng.f32(), 3.0 * rng.f32(), 3.0 * rng.f32()]);
        }
        let mut p = BsdfParams::new(base, metallic, rough).with_dielectric(dl);
        if i % 7 == 1 {
            p.specular = rng.f32();
        }
        let (wo, wi, u) = random_case(&mut rng);
        // A smooth surface transmits off the delta direction only through
        // the diffuse transmission lobe.
        if let Some(s) = bsdf_sample(&p, wo, u[0], u[1], u[2]) {
            if rough == 0.0 && s.wi.z < 0.0 && !s.delta {
                smooth_transmitted += 1;
            }
        }
        cases.push((p, wo, wi, u));
    }
    let tally = check_ext_probe(
        &d,
        &["HAS_TRANSMISSION", "HAS_DIFFUSE_TRANSMISSION"],
        &cases,
        5e-4,
    );
    eprintln!(
        "diffuse transmission probe: {} sampled, {} transmitted, {smooth_transmitted} diffusely through smooth surfaces",
        tally.sampled, tally.transmitted
    );
    assert!(tally.sampled > n / 2, "{} of {n} sampled", tally.sampled);
    assert!(
        tally.transmitted > n / 4,
        "{} of {n} transmitted",
        tally.transmitted
    );
    assert!(
        smooth_transmitted > n / 50,
        "{smooth_transmitted} diffusely transmitted"
    );
}

#[test]
fn diffuse_transmission_moves_the_diffuse_lobe_across_and_loses_nothing() {
    // White base and white transmission colour: the share dt of the
    // diffuse lobe leaves below the surface, and the total over the sphere
    // is the opaque material's (the lobe's Fresnel is the reflection's at
    // the mirror direction). The sampler's estimate matches the quadrature
    // (its pdf is the one it samples with).
    for (volume, rough) in [(false, 0.5f32), (true, 0.3), (false, 0.0)] {
        for &mu in &[0.9f32, 0.4] {
            let opaque = BsdfParams::new([1.0; 3], 0.0, rough)
                .with_dielectric(Dielectric::new(1.5, 0.0, volume, true));
            let (r0, t0) = sphere_albedo(&opaque, mu);
            assert_eq!(t0, 0.0);
            // The specular layer alone (black base), and so the diffuse
            // lobe's part of the opaque albedo.
            let mut black = opaque;
            black.base = Vec3::ZERO;
            let diffuse0 = r0 - sphere_albedo(&black, mu).0;
            for &dt in &[0.3f32, 1.0] {
                let mut p = opaque;
                p.dielectric = Some(
                    p.dielectric
                        .unwrap()
                        .with_diffuse_transmission(dt, [1.0; 3]),
                );
                let (r, t) = sphere_albedo(&p, mu);
                let sampled = albedo(&p, mu, 1.0);
                eprintln!(
                    "volume {volume} roughness {rough} mu {mu} dt {dt}: reflected {r:.5} + transmitted {t:.5} = {:.5} \
                     (opaque {r0:.5}); sampled {sampled:.5}",
                    r + t
                );
                assert!(((r + t) - r0).abs() < 1e-4 * r0, "{} vs {r0}", r + t);
                let want_t = dt as f64 * diffuse0;
                assert!(
                    (t - want_t).abs() < 1e-4 * want_t,
                    "transmitted {t} vs {want_t}"
                );
                // Smooth surfaces: the delta mirror is not in the quadrature.
                if rough > 0.0 {
                    assert!(
                        (sampled - (r + t)).abs() < 0.01 * (r + t),
                        "{sampled} vs {}",
                        r + t
                    );
                }
            }
        }
    }
}

#[test]
fn white_diffuse_transmitter_in_a_white_furnace_is_invisible() {
    // A white Lambertian (specularFactor 0) that transmits half its light
    // diffusely reflects and transmits all of it: a closed ball of it in a
    // white furnace disappears, thin-walled or with a volume.
    for volume in [false, true] {
        let m = Material {
            specular_factor: 0.0,
            diffuse_transmission: 0.5,
            thickness_factor: if volume { 1.0 } else { 0.0 },
            double_sided: true,
            ..material([1.0; 4], 0.0, 0.5)
        };
        let (m, se) = ball_in_white_furnace(m);
        eprintln!("diffuse transmission furnace, volume {volume}: {m} ± {se}");
        assert!(
            (m - 1.0).abs() < 4.0 * se + 0.01,
            "volume {volume}: mean {m} ± {se}"
        );
    }
}

#[test]
fn backlit_leaf_shows_its_diffuse_transmission() {
    use serde_json::json;
    // A thin Lambertian leaf (specularFactor 0: no Fresnel) under a sun and
    // a black sky, seen head-on. Lit from the front it shows (1 - dt) base
    // E cos / pi; lit from behind, dt colour E cos / pi, every pixel and
    // without noise (the sun is the only light, sampled exactly). Both
    // halves carry textures: diffuseTransmissionTexture (A) scales the
    // factor, diffuseTransmissionColorTexture (RGB, sRGB) the colour. E cos
    // comes from a --clay render (0.8 / pi E cos).
    let (left, right) = (0..28, 36..64);
    let byte = |b: u8| b as f32 / 255.0;
    let srgb = |b: u8| soupray::trace::texture::srgb_to_linear(byte(b));
    let texels = ([230u8, 120, 40, 200], [60, 200, 250, 90]);
    let uri = png_uri(texels.0, texels.1);
    let (base, dt, color) = ([0.2f32, 0.6, 0.1], 0.8f32, [1.0f32, 0.9, 0.5]);
    let leaf = json!({
        "pbrMetallicRoughness": {"baseColorFactor": [base[0], base[1], base[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.7},
        "doubleSided": true,
        "extensions": {
            "KHR_materials_specular": {"specularFactor": 0.0},
            "KHR_materials_diffuse_transmission": {
                "diffuseTransmissionFactor": dt,
                "diffuseTransmissionTexture": {"index": 0},
                "diffuseTransmissionColorFactor": color,
                "diffuseTransmissionColorTexture": {"index": 0}
            }
        }
    });
    let front_sun = Vec3::new(0.5, 0.2, 0.8).normalize();
    let back_sun = Vec3::new(front_sun.x, front_sun.y, -front_sun.z);
    let black = ["--env-color", "0,0,0"];
    let clay = render_square(
        leaf.clone(),
        &uri,
        Some(front_sun),
        &["--env-color", "0,0,0", "--clay"],
    );
    let front = render_square(leaf.clone(), &uri, Some(front_sun), &black);
    let back = render_square(leaf, &uri, Some(back_sun), &black);
    for (cols, t) in [(left, texels.0), (right, texels.1)] {
        let dt_here = dt * byte(t[3]);
        let color_here = [0, 1, 2].map(|c| color[c] * srgb(t[c]));
        let mut worst = 0.0f32;
        for y in 0..clay.height as usize {
            for x in cols.clone() {
                let i = y * clay.width as usize + x;
                let e_cos = clay.rgba[i][0] / 0.8; // E cos / pi
                for c in 0..3 {
                    let want_front = (1.0 - dt_here) * base[c] * e_cos;
                    let want_back = dt_here * color_here[c] * e_cos;
                    worst = worst
                        .max((front.rgba[i][c] - want_front).abs() / want_front)
                        .max((back.rgba[i][c] - want_back).abs() / want_back);
                }
            }
        }
        let i = cols.start;
        eprintln!(
            "leaf texel {t:?}: front {:?}, back {:?} (E cos / pi {}); worst relative error {worst:.2e}",
            &front.rgba[i][..3],
            &back.rgba[i][..3],
            clay.rgba[i][0] / 0.8
        );
        assert!(clay.rgba[i][0] > 0.1, "the sun must light the leaf");
        assert!(worst < 1e-4, "worst relative error {worst}");
    }
}

#[test]
fn iridescent_bsdf_matches_the_reference() {
    // Every dielectric lobe with a thin film on its Fresnel (and diffuse
    // transmission beside it), device against Rust on random inputs.
    let d = common::device();
    let mut rng = Rng::new(31);
    let n = 4000;
    let mut cases = Vec::new();
    for i in 0..n {
        let volume = i % 2 == 0;
        let front = i % 4 < 2;
        let transmission = if i % 3 == 0 {
            0.0
        } else {
            0.5 + 0.5 * rng.f32()
        };
        let dt = if i % 5 == 2 { rng.f32() } else { 0.0 };
        let rough = if i % 5 == 0 { 0.0 } else { rng.f32().max(0.05) };
        let base = [
            0.3 + 0.7 * rng.f32(),
            0.3 + 0.7 * rng.f32(),
            0.3 + 0.7 * rng.f32(),
        ];
        let metallic = if i % 8 == 3 { 1.0 } else { 0.3 * rng.f32() };
        let film = if i % 3 == 1 { 0.0 } else { rng.f32().max(0.1) };
        let film_ior = 1.0 + 1.3 * rng.f32();
        let thickness = 1200.0 * rng.f32();
        let mut dl = Dielectric::new(1.0 + 1.5 * rng.f32(), transmission, volume, front)
            .with_diffuse_transmission(dt, [1.0, 0.8, 0.6])
            .with_iridescence(film, film_ior, thickness);
        if i % 7 == 1 {
            dl = dl.with_specular_color([2.0 * rng.f32(), 2.0 * rng.f32(), 2.0 * rng.f32()]);
        }
        let p = BsdfParams::new(base, metallic, rough).with_dielectric(dl);
        let (wo, wi, u) = random_case(&mut rng);
        cases.push((p, wo, wi, u));
    }
    let tally = check_ext_probe(
        &d,
        &[
            "HAS_TRANSMISSION",
            "HAS_DIFFUSE_TRANSMISSION",
            "HAS_IRIDESCENCE",
        ],
        &cases,
        1e-3,
    );
    eprintln!(
        "iridescence probe: {} sampled, {} transmitted, {} from delta lobes",
        tally.sampled, tally.transmitted, tally.deltas
    );
    assert!(tally.sampled > n / 2, "{} of {n} sampled", tally.sampled);
    assert!(
        tally.transmitted > n / 5,
        "{} transmitted",
        tally.transmitted
    );
    assert!(tally.deltas > n / 20, "{} from delta lobes", tally.deltas);
}

#[test]
fn thin_film_has_the_limits_of_its_physics() {
    use soupray::trace::material::{fresnel_dielectric3, thin_film_fresnel};
    let f0 = Vec3::splat(0.04);
    for &c in &[1.0f32, 0.7, 0.3] {
        // No film: the base's own Fresnel.
        let none = thin_film_fresnel(1.33, c, 0.0, f0);
        let schlick = fresnel_dielectric3(f0, 1.0, c);
        assert!(
            (none - schlick).abs().max_element() < 1e-5,
            "{none} vs {schlick}"
        );
        // A film far thicker than the light's coherence length: the
        // incoherent sum of the two interfaces' reflections, colourless.
        let thick = thin_film_fresnel(1.33, c, 20000.0, f0);
        let cos2 = (1.0 - (1.0 - c * c) / (1.33f32 * 1.33)).sqrt();
        // The air-film interface's exact Fresnel, the base's Schlick.
        let n = 1.33f32;
        let rs = (c - n * cos2) / (c + n * cos2);
        let rp = (n * c - cos2) / (n * c + cos2);
        let r12 = 0.5 * (rs * rs + rp * rp);
        let b = (1.0 + 0.2f32) / (1.0 - 0.2); // the base's index from F0 0.04
        let r1 = ((b - 1.33) / (b + 1.33)).powi(2);
        let r23 = fresnel_dielectric3(Vec3::splat(r1), 1.0, cos2).x;
        let incoherent = r12 + (1.0 - r12).powi(2) * r23 / (1.0 - r12 * r23);
        eprintln!("cos {c}: no film {none}, 20 µm film {thick}, incoherent sum {incoherent}");
        assert!(
            (thick - Vec3::splat(incoherent)).abs().max_element() < 2e-3,
            "{thick} vs {incoherent}"
        );
    }
    // A soap film (index 1.33, 300 nm) over glass is coloured, and its
    // colour changes with its thickness; no channel leaves 0..1.
    let mut hues = Vec::new();
    for t in [250.0f32, 300.0, 350.0, 400.0, 450.0] {
        let r = thin_film_fresnel(1.33, 1.0, t, f0);
        eprintln!("{t} nm at normal incidence: {r}");
        assert!(r.min_element() >= 0.0 && r.max_element() <= 1.0);
        assert!(r.max_element() - r.min_element() > 0.01, "{t} nm: {r}");
        hues.push(r / r.max_element());
    }
    assert!(
        hues.windows(2)
            .any(|w| (w[0] - w[1]).abs().max_element() > 0.2),
        "the film's colour should change with its thickness: {hues:?}"
    );
    // The ends of the ranges a file may give stay finite and in 0..1.
    for (ior, t) in [(1.0f32, 0.0f32), (100.0, 0.0), (100.0, 1.0e5), (1.0, 1.0e5)] {
        for &c in &[1.0f32, 0.01] {
            for f0 in [Vec3::ZERO, Vec3::ONE, Vec3::splat(0.5)] {
                let r = thin_film_fresnel(ior, c, t, f0);
                assert!(
                    r.is_finite() && r.min_element() >= 0.0 && r.max_element() <= 1.0,
                    "ior {ior} thickness {t} cos {c} f0 {f0}: {r}"
                );
            }
        }
    }
}

/// `render_square` of `square` under a sun from `sun` and a black sky, as
/// `--clay` and as itself.
fn square_under_a_sun(
    square: serde_json::Value,
    uri: &str,
    sun: Vec3,
) -> (soupray::film::Image, soupray::film::Image) {
    let clay = render_square(
        square.clone(),
        uri,
        Some(sun),
        &["--env-color", "0,0,0", "--clay"],
    );
    let img = render_square(square, uri, Some(sun), &["--env-color", "0,0,0"]);
    (clay, img)
}

/// For a square under a sun and a black sky seen head-on (`img`), the
/// largest relative error over columns `cols` against `f` E cos, E cos from
/// the `--clay` render of the same scene (0.8 / pi E cos); and the last
/// pixel's value.
fn worst_against_sun_reference(
    clay: &soupray::film::Image,
    img: &soupray::film::Image,
    cols: std::ops::Range<usize>,
    f: Vec3,
) -> (f32, [f32; 3]) {
    let mut worst = 0.0f32;
    let mut at = [0.0f32; 3];
    for y in 0..clay.height as usize {
        for x in cols.clone() {
            let i = y * clay.width as usize + x;
            let e_cos = clay.rgba[i][0] / 0.8 * std::f32::consts::PI;
            for c in 0..3 {
                let want = f[c] * e_cos;
                worst = worst.max((img.rgba[i][c] - want).abs() / want);
            }
            at = [img.rgba[i][0], img.rgba[i][1], img.rgba[i][2]];
        }
    }
    (worst, at)
}

#[test]
fn iridescent_square_under_a_sun_matches_the_reference() {
    use serde_json::json;
    // A rough iridescent dielectric under a sun and a black sky, seen
    // head-on: every pixel is f(wo, sun) E cos, without noise. Each half
    // carries its own texel: iridescenceTexture (R) scales the factor,
    // iridescenceThicknessTexture (G) picks the thickness between the
    // minimum and the maximum. The prediction is the Rust BSDF with E cos
    // from a --clay render (0.8 / pi E cos).
    let (left, right) = (0..28, 36..64);
    let byte = |b: u8| b as f32 / 255.0;
    let texels = ([230u8, 40, 0, 255], [120, 210, 0, 255]);
    let uri = png_uri(texels.0, texels.1);
    let (base, roughness) = ([0.05f32, 0.05, 0.05], 0.35f32);
    let (factor, ior, tmin, tmax) = (1.0f32, 1.4f32, 150.0f32, 700.0f32);
    let square = json!({
        "pbrMetallicRoughness": {"baseColorFactor": [base[0], base[1], base[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": roughness},
        "extensions": {"KHR_materials_iridescence": {
            "iridescenceFactor": factor, "iridescenceTexture": {"index": 0},
            "iridescenceIor": ior,
            "iridescenceThicknessMinimum": tmin, "iridescenceThicknessMaximum": tmax,
            "iridescenceThicknessTexture": {"index": 0}
        }}
    });
    let sun = Vec3::new(0.35, 0.1, 0.93).normalize();
    let (clay, img) = square_under_a_sun(square, &uri, sun);
    for (cols, t) in [(left, texels.0), (right, texels.1)] {
        let film = factor * byte(t[0]);
        let thickness = tmin + (tmax - tmin) * byte(t[1]);
        let mut p = BsdfParams::new(base, 0.0, roughness).with_dielectric(
            Dielectric::new(1.5, 0.0, false, true).with_iridescence(film, ior, thickness),
        );
        p.energy_compensation = true;
        let mut plain = p;
        plain.dielectric = Some(Dielectric::new(1.5, 0.0, false, true));
        let f = bsdf_eval(&p, Vec3::Z, sun);
        let f_plain = bsdf_eval(&plain, Vec3::Z, sun);
        let (worst, at) = worst_against_sun_reference(&clay, &img, cols, f);
        eprintln!(
            "iridescence {film:.3} at {thickness:.0} nm: pixel {at:?}, reference f {f} (no film {f_plain}); worst relative error {worst:.2e}"
        );
        assert!(worst < 2e-3, "worst relative error {worst}");
        // The film changes the colour.
        assert!((f - f_plain).abs().max_element() > 0.05 * f_plain.max_element());
    }
}

/// Random anisotropic materials: every dielectric lobe (and the metal) with
/// a strength of 0 to 1 (a quarter isotropic), from smooth to rough.
fn anisotropic_cases(rng: &mut Rng, n: usize) -> Vec<(BsdfParams, Vec3, Vec3, [f32; 3])> {
    let mut cases = Vec::new();
    for i in 0..n {
        let volume = i % 2 == 0;
        let front = i % 4 < 2;
        let transmission = if i % 3 == 0 { 0.0 } else { rng.f32() };
        let rough = if i % 5 == 0 { 0.0 } else { rng.f32().max(0.05) };
        let strength = if i % 4 == 3 { 0.0 } else { rng.f32() };
        let base = [rng.f32(), rng.f32(), rng.f32()];
        let metallic = if i % 6 == 1 { 1.0 } else { 0.3 * rng.f32() };
        let dl = Dielectric::new(1.0 + 1.5 * rng.f32(), transmission, volume, front);
        let p = BsdfParams::new(base, metallic, rough)
            .with_anisotropy(strength)
            .with_dielectric(dl);
        let (wo, wi, u) = random_case(rng);
        cases.push((p, wo, wi, u));
    }
    cases
}

#[test]
fn anisotropic_bsdf_matches_the_reference() {
    // KHR_materials_anisotropy: the base's GGX lobes with alpha_t along x,
    // device against Rust on random inputs, with and without the energy
    // compensation (whose albedo lookup the anisotropy changes).
    let d = common::device();
    let mut rng = Rng::new(37);
    let n = 4000;
    let cases = anisotropic_cases(&mut rng, n);
    let anisotropic = cases.iter().filter(|c| c.0.alpha_t != c.0.alpha).count();
    assert!(anisotropic > n / 2, "{anisotropic} of {n} anisotropic");
    let tally = check_ext_probe(&d, &["HAS_TRANSMISSION", "HAS_ANISOTROPY"], &cases, 1e-3);
    eprintln!(
        "anisotropy probe: {} sampled, {} transmitted, {} from delta lobes",
        tally.sampled, tally.transmitted, tally.deltas
    );
    assert!(tally.sampled > n / 2, "{} of {n} sampled", tally.sampled);
    assert!(
        tally.transmitted > n / 20,
        "{} transmitted",
        tally.transmitted
    );
    assert!(tally.deltas > n / 40, "{} from delta lobes", tally.deltas);
    let compensated: Vec<_> = cases
        .iter()
        .map(|&(mut p, wo, wi, u)| {
            p.energy_compensation = true;
            (p, wo, wi, u)
        })
        .collect();
    check_ext_probe(
        &d,
        &[
            "HAS_TRANSMISSION",
            "HAS_ANISOTROPY",
            "GGX_ENERGY_COMPENSATION",
        ],
        &compensated,
        1e-3,
    );
}

#[test]
fn anisotropic_lobes_sample_what_they_evaluate() {
    // The stretched visible-normal sampling and its pdf against the lobe:
    // the sampled albedo (f cos / pdf) equals the quadrature of eval over
    // the sphere, for outgoing directions along, across and between the
    // anisotropy's axes; and the lobe does depend on the azimuth.
    for (metallic, transmission, volume) in [(1.0, 0.0, false), (0.0, 1.0, true), (0.0, 0.7, false)]
    {
        let dl = Dielectric::new(1.5, transmission, volume, true);
        let p = BsdfParams::new([0.9, 0.9, 0.9], metallic, 0.5)
            .with_anisotropy(0.7)
            .with_dielectric(dl);
        let mut along = Vec::new();
        for phi in [0.0f32, 0.8, std::f32::consts::FRAC_PI_2] {
            let mu = 0.6f32;
            let s = (1.0 - mu * mu).sqrt();
            let wo = Vec3::new(s * phi.cos(), s * phi.sin(), mu);
            let (up, down) = common::sphere_albedo_at(&p, wo);
            let scale_t = if volume { 1.5f32 * 1.5 } else { 1.0 };
            let quadrature = up + down * scale_t as f64;
            let sampled = common::albedo_at(&p, wo, scale_t);
            eprintln!(
                "metallic {metallic} transmission {transmission} volume {volume} phi {phi}: sampled {sampled:.5}, quadrature {quadrature:.5}"
            );
            assert!(
                (sampled - quadrature).abs() < 0.01 * quadrature,
                "phi {phi}: sampled {sampled}, quadrature {quadrature}"
            );
            along.push(bsdf_eval(&p, wo, Vec3::new(-wo.x, -wo.y, wo.z)).x);
        }
        // The metal's mirror direction differs along and across the axes.
        if metallic == 1.0 {
            assert!(
                (along[0] - along[2]).abs() > 0.1 * along[0].max(along[2]),
                "{along:?}"
            );
        }
    }
}

#[test]
fn energy_compensated_anisotropic_white_metal_returns_what_it_receives() {
    // Turquin's compensation for the anisotropic lobe: the isotropic table
    // at the root-mean-square alpha times the tabulated correction
    // (trace::energy::anisotropic_albedo). Over roughness, strength,
    // elevation and azimuth, between the table's nodes too, the Rust
    // reference's directional albedo is 1 within 1%; then the device in a
    // white furnace.
    let mut worst = (0.0f64, 0.0f32, 0.0f32, 0.0f32, 0.0f32);
    let (mut sum_ms, mut sum_ss, mut count) = (0.0f64, 0.0f64, 0usize);
    for roughness in [0.1f32, 0.3, 0.5, 0.8, 1.0] {
        for strength in [0.3f32, 0.6, 1.0] {
            for mu in [0.9f32, 0.6, 0.3, 0.15] {
                for phi in [0.0f32, 0.8, std::f32::consts::FRAC_PI_2] {
                    let s = (1.0 - mu * mu).sqrt();
                    let wo = Vec3::new(s * phi.cos(), s * phi.sin(), mu);
                    let mut p = BsdfParams::new([1.0; 3], 1.0, roughness)
                        .with_anisotropy(strength)
                        .with_dielectric(Dielectric::new(1.5, 0.0, false, true));
                    let ss = common::albedo_at(&p, wo, 1.0);
                    p.energy_compensation = true;
                    let ms = common::albedo_at(&p, wo, 1.0);
                    if (ms - 1.0).abs() > worst.0.abs() {
                        worst = (ms - 1.0, roughness, strength, mu, phi);
                    }
                    sum_ms += (ms - 1.0).abs();
                    sum_ss += (ss - 1.0).abs();
                    count += 1;
                }
            }
        }
    }
    let (mean_ms, mean_ss) = (sum_ms / count as f64, sum_ss / count as f64);
    eprintln!(
        "anisotropic furnace: mean |albedo - 1| {mean_ms:.4} compensated, {mean_ss:.4} single scattering; worst compensated {:+.4} (roughness {}, strength {}, mu {}, phi {})",
        worst.0, worst.1, worst.2, worst.3, worst.4
    );
    assert!(worst.0.abs() < 0.01, "{worst:?}");
    assert!(mean_ms < 0.005, "{mean_ms} vs {mean_ss}");
    // A rough white brushed metal ball in the white furnace.
    let d = common::device();
    let cam = perspective(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    let mut s = Soup::default();
    sphere(&mut s, Vec3::ZERO, 1.0, 16, 32, 0);
    let brushed = Material {
        anisotropy_strength: 0.8,
        ..material([1.0; 4], 1.0, 0.6)
    };
    let mut st = settings(24, 64);
    st.environment = Environment::Color([1.0, 1.0, 1.0]);
    st.energy_compensation = true;
    let out = render_soup(&d, &s, &table(vec![brushed]), &cam, &[], &st, 0).unwrap();
    let (m, se) = mean_se(&covered(&out.image));
    eprintln!("rough white brushed metal furnace: {m} ± {se}");
    assert!((m - 1.0).abs() < 4.0 * se + 0.01, "{m} ± {se}");
    // The ball has no texture coordinates: its direction is arbitrary,
    // and the frame's warnings say so.
    assert!(
        out.warnings
            .iter()
            .any(|w| w.contains("KHR_materials_anisotropy") && w.contains("no TEXCOORD_0")),
        "{:?}",
        out.warnings
    );
}

#[test]
fn anisotropic_square_under_a_sun_matches_the_reference() {
    use serde_json::json;
    // A brushed metal square under a sun and a black sky, seen head-on:
    // every pixel is f(wo, sun) E cos, without noise. The square's u runs
    // along +x and v along -y, so its tangent is +x and the bitangent n x t
    // is +y. Each half carries its own anisotropyTexture texel: RG the
    // direction in that frame, B the strength's scale; anisotropyRotation
    // turns both counter-clockwise. The prediction is the Rust BSDF in the
    // frame whose x is that direction, with E cos from a --clay render.
    let (left, right) = (0..28, 36..64);
    let byte = |b: u8| b as f32 / 255.0;
    let texels = ([255u8, 128, 255, 255], [128, 255, 140, 255]);
    let uri = png_uri(texels.0, texels.1);
    let (base, roughness, strength, rotation) = ([0.9f32, 0.8, 0.7], 0.3f32, 0.9f32, 0.4f32);
    let square = json!({
        "pbrMetallicRoughness": {"baseColorFactor": [base[0], base[1], base[2], 1.0], "metallicFactor": 1.0, "roughnessFactor": roughness},
        "extensions": {"KHR_materials_anisotropy": {
            "anisotropyStrength": strength, "anisotropyRotation": rotation,
            "anisotropyTexture": {"index": 0}
        }}
    });
    let sun = Vec3::new(0.45, 0.25, 0.86).normalize();
    let (clay, img) = square_under_a_sun(square, &uri, sun);
    let mut seen = Vec::new();
    for (cols, t) in [(left, texels.0), (right, texels.1)] {
        let (dx, dy) = (byte(t[0]) * 2.0 - 1.0, byte(t[1]) * 2.0 - 1.0);
        let (s, c) = rotation.sin_cos();
        let x = Vec3::new(c * dx - s * dy, s * dx + c * dy, 0.0).normalize();
        let y = Vec3::Z.cross(x);
        let local = |v: Vec3| Vec3::new(v.dot(x), v.dot(y), v.z);
        let mut p = BsdfParams::new(base, 1.0, roughness)
            .with_anisotropy(strength * byte(t[2]))
            .with_dielectric(Dielectric::new(1.5, 0.0, false, true));
        p.energy_compensation = true;
        let f = bsdf_eval(&p, Vec3::Z, local(sun));
        // The same lobe turned a quarter: what a wrong frame would give.
        let turned = bsdf_eval(&p, Vec3::Z, Vec3::new(-local(sun).y, local(sun).x, sun.z));
        let (worst, at) = worst_against_sun_reference(&clay, &img, cols, f);
        eprintln!(
            "anisotropy direction {x}: pixel {at:?}, reference f {f} (turned a quarter {turned}); worst relative error {worst:.2e}"
        );
        assert!(worst < 2e-3, "worst relative error {worst}");
        assert!((f - turned).abs().max_element() > 0.1 * f.max_element());
        seen.push(f);
    }
    assert!((seen[0] - seen[1]).abs().max_element() > 0.1 * seen[0].max_element());
}

#[test]
fn dispersion_indices_match_the_reference() {
    // KHR_materials_dispersion's per-channel indices, device against Rust,
    // and the extension's own numbers: ior 1.5 at dispersion 1 (Abbe
    // number 20) spreads to 1.4875, 1.5 and 1.5125.
    use soupray::trace::media::channel_ior;
    assert_eq!(
        [0, 1, 2].map(|c| channel_ior(1.5, 1.0, Some(c))),
        [1.4875, 1.5, 1.5125]
    );
    assert_eq!(channel_ior(1.5, 1.0, None), 1.5);
    assert_eq!(channel_ior(1.05, 50.0, Some(0)), 1.0, "red at least 1");
    let d = common::device();
    let mut rng = Rng::new(41);
    let mut input = Vec::new();
    let mut want = Vec::new();
    for i in 0..2000 {
        let ior = if i % 50 == 0 {
            1.0e6
        } else {
            1.0 + 2.0 * rng.f32()
        };
        let dispersion = if i % 7 == 0 { 0.0 } else { 20.0 * rng.f32() };
        let channel: i32 = i % 4 - 1;
        input.extend_from_slice(&[ior, dispersion, channel as f32]);
        want.push(channel_ior(ior, dispersion, usize::try_from(channel).ok()));
    }
    let program = d
        .build_program("pt_probe.cl", &[("HAS_DISPERSION", "1".to_owned())])
        .unwrap();
    let k = d.kernel(&program, "media_channel_probe").unwrap();
    let got: Vec<f32> = run_probe(&d, &k, &input, want.len(), want.len());
    for (i, (g, w)) in got.iter().zip(&want).enumerate() {
        close(
            *g,
            *w,
            1e-6,
            &format!("case {i} {:?}", &input[3 * i..3 * i + 3]),
        );
    }
}

fn dispersive_glass(dispersion: f32) -> Material {
    Material {
        dispersion,
        ..glass(1.0, 1.5, true)
    }
}

#[test]
fn dispersive_glass_in_a_white_furnace_is_invisible() {
    // Each path carries one colour channel, three times as strong, from
    // the first dispersive volume on: every channel's mean stays 1.
    let img = ball_in_white_furnace_image(dispersive_glass(5.0));
    for (c, (m, se)) in covered_channels(&img).into_iter().enumerate() {
        eprintln!("dispersive glass furnace, channel {c}: {m} ± {se}");
        assert!((m - 1.0).abs() < 4.0 * se + 0.01, "channel {c}: {m} ± {se}");
    }
}

#[test]
fn dispersive_slab_transmits_each_channel_its_fresnel_transmittance() {
    // Normal incidence through a slab of ior 1.5 at dispersion 10 (Abbe
    // number 2, exaggerated): each channel sees the Fresnel transmittance
    // (1 - R) / (1 + R) of its own index, 1.375, 1.5 and 1.625.
    use soupray::trace::media::channel_ior;
    let img = slab_image(dispersive_glass(10.0), 0.25, 1024);
    let mut got = [0.0f64; 3];
    for c in 0..3 {
        let (m, se) = mean_se(&img.rgba.iter().map(|p| p[c] as f64).collect::<Vec<_>>());
        let r = f0_of_ior(channel_ior(1.5, 10.0, Some(c))) as f64;
        let want = (1.0 - r) / (1.0 + r);
        eprintln!("dispersive slab, channel {c}: {m} ± {se} (analytic {want})");
        assert!(
            (m - want).abs() < 4.0 * se + 0.002,
            "channel {c}: {m} ± {se} vs {want}"
        );
        got[c] = m;
    }
    assert!(got[0] > got[1] && got[1] > got[2], "{got:?}");
}

/// A glass ball (ior 1.5, `dispersion`) before an emitter that fills the
/// left half of the view far behind it, in a black world: 48 x 48 pixels.
fn ball_before_an_edge(dispersion: f32, spp: u32) -> soupray::film::Image {
    let d = common::device();
    let mut s = Soup::default();
    sphere(&mut s, Vec3::ZERO, 1.0, 24, 48, 0);
    quad(
        &mut s,
        Vec3::new(-5.0, 0.0, -6.0),
        Vec3::X * 5.0,
        Vec3::Y * 10.0,
        Vec3::Z,
        1,
    );
    let mut emitter = material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
    emitter.emissive_factor = [1.0; 3];
    let t = table(vec![dispersive_glass(dispersion), emitter]);
    let cam = perspective(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    let mut st = settings(48, spp);
    st.max_depth = 16;
    st.environment = Environment::Color([0.0; 3]);
    render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap().image
}

#[test]
fn dispersion_splits_the_colours_of_an_edge_seen_through_glass() {
    // Without dispersion every path carries the three channels alike, so
    // red equals blue exactly. With it the ball bends red less than blue
    // and the edge's image inside the ball gets colour fringes: some column
    // of the ball has a mean red-minus-blue far beyond its noise, red on
    // one side of the edge's image and blue on the other.
    let plain = ball_before_an_edge(0.0, 16);
    let worst = plain
        .rgba
        .iter()
        .map(|p| (p[0] - p[2]).abs())
        .fold(0.0f32, f32::max);
    assert_eq!(worst, 0.0, "red and blue differ without dispersion");
    let img = ball_before_an_edge(10.0, 256);
    let w = img.width as usize;
    let mut columns = Vec::new();
    for x in 0..w {
        let v: Vec<f64> = (0..img.height as usize)
            .map(|y| img.rgba[y * w + x])
            .filter(|p| p[3] == 1.0)
            .map(|p| p[0] as f64 - p[2] as f64)
            .collect();
        if v.len() > 10 {
            let (m, se) = mean_se(&v);
            columns.push((x, m, se));
        }
    }
    let strongest = |sign: f64| {
        columns
            .iter()
            .map(|&(x, m, se)| (x, sign * m / se.max(1e-9)))
            .fold((0, f64::MIN), |a, b| if b.1 > a.1 { b } else { a })
    };
    let (red_at, red) = strongest(1.0);
    let (blue_at, blue) = strongest(-1.0);
    eprintln!("fringes: red ahead at column {red_at} ({red:.1} standard errors), blue at {blue_at} ({blue:.1})");
    assert!(red > 8.0 && blue > 8.0, "red {red}, blue {blue}");
    assert!(red_at != blue_at);
}
