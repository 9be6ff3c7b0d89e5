//! KHR_materials_iridescence: the device BSDF against the reference, the
//! thin film's physical limits, and an iridescent square under a sun
//! against the reference.

use super::*;

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
        // The renderer's defaults: compensation and the energy layering.
        p.energy_compensation = true;
        p.energy_layering = true;
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
