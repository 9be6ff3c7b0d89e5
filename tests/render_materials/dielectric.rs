//! The dielectric extensions (KHR_materials_transmission, _ior, _volume):
//! the device BSDF (`HAS_TRANSMISSION`) against its Rust reference on
//! random inputs, white furnaces of the reference's lobes, and renders
//! against analytic values: glass in a white furnace, a slab's Fresnel
//! transmittance, Beer-Lambert attenuation through a known thickness, a
//! glass ball that shows what lies behind it flipped, and a smooth glass
//! ball under a sun without fireflies.

use super::*;

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

#[test]
fn roulette_does_not_cut_paths_inside_glass() {
    // Refraction into glass scales the throughput by 1 / 1.5^2; Russian
    // roulette must judge the path by what it will carry out again, or it
    // cuts more than half the paths it reaches inside the ball and brings
    // the rest back 2.25x too bright: the same mean, with noise. In a white
    // furnace every sample through a clear ball then carries about 1 (or 0,
    // where a path ends for other reasons): at 1 spp, no pixel is 2.25x
    // bright.
    let img = ball_in_white_furnace_sized(glass(1.0, 1.5, true), 64, 1);
    let v = covered(&img);
    let bright = v.iter().filter(|&&x| x > 1.5).count();
    eprintln!(
        "glass ball in a white furnace, 1 spp: {bright} of {} pixels above 1.5",
        v.len()
    );
    assert!(
        bright * 500 < v.len(),
        "{bright} of {} pixels above 1.5",
        v.len()
    );
}

/// A slab of glass (|z| < half) between an orthographic camera and an
/// emitter of radiance 1, in a black world: the centre pixels see the
/// slab's transmittance.
fn slab_transmittance(mat: Material, half: f32) -> f64 {
    let img = slab_image(mat, half, 256);
    let v: Vec<f64> = img.rgba.iter().map(|p| grey(*p)).collect();
    mean_se(&v).0
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
