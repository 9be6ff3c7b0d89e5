//! KHR_materials_diffuse_transmission: the device BSDF against the
//! reference, the diffuse lobe moved across the surface without loss, a
//! white transmitter invisible in a white furnace, and a backlit leaf.

use super::*;

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
