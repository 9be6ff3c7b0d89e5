//! Nested dielectrics and thin-walled shadow rays (`HAS_TRANSMISSION`):
//! the device's list of volumes (kernels/trace/media.h) against its Rust twin
//! (`trace::media`) on real and random crossings, and renders against
//! analytic values: a glass slab in water (relative index 1.5/1.33), a
//! liquid-filled glass (the liquid overlapping the glass wall), Beer-Lambert
//! through two nested absorbing volumes, and a floor lit through a
//! thin-walled transmissive pane (a sun: the straight-through Fresnel
//! transmittance; an area light close by: no light counted twice).

mod common;

use common::render::*;
use common::{run_probe, Rng};
use glam::Vec3;
use soupray::scene::{LightKind, Material};
use soupray::soup::Soup;
use soupray::trace::material::{
    f0_of_ior, shadow_straight_through, thin_straight_through, BsdfParams, Dielectric, Layers,
};
use soupray::trace::media::{relative_eta, relative_f0, MediumStack, MEDIUM_STACK};
use soupray::trace::render::{render_soup, Environment};

/// `media_probe`'s steps per case (MEDIA_PROBE_STEPS).
const STEPS: usize = 16;

fn probe_program(d: &soupray::device::Device) -> opencl3::program::Program {
    d.build_program("pt_probe.cl", &[("HAS_TRANSMISSION", "1".to_owned())])
        .unwrap()
}

/// The Rust twin's answers for one case of `media_probe`.
fn media_reference(steps: &[(u32, bool)]) -> Vec<u32> {
    let mut m = MediumStack::default();
    let mut out = Vec::new();
    for &(mat, front) in steps {
        out.push((!front && m.false_interface(mat)) as u32);
        out.push(m.other(mat, front));
        if front {
            m.enter(mat);
        } else {
            m.leave(mat);
        }
        out.push(m.innermost());
        out.push(m.count as u32);
    }
    out
}

#[test]
fn medium_list_matches_the_reference() {
    let d = common::device();
    let program = probe_program(&d);
    let k = d.kernel(&program, "media_probe").unwrap();
    // Real crossings: glass in water and out; a liquid-filled glass (glass
    // 0, liquid 1 overlapping its wall) crossed top to bottom.
    let mut cases: Vec<Vec<(u32, bool)>> = vec![
        vec![(0, true), (1, true), (1, false), (0, false)],
        vec![
            (0, true),
            (1, true),
            (0, false),
            (0, true),
            (1, false),
            (0, false),
        ],
    ];
    // Random: few materials, so paths re-enter and leave out of order, and
    // more entries than the list holds.
    let mut rng = Rng::new(13);
    for _ in 0..2000 {
        let n = 1 + (rng.f32() * STEPS as f32) as usize;
        cases.push(
            (0..n.min(STEPS))
                .map(|_| ((rng.f32() * 5.0) as u32, rng.f32() < 0.6))
                .collect(),
        );
    }
    let mut input = Vec::new();
    for c in &mut cases {
        // Pad with back faces of a material never entered: no change.
        while c.len() < STEPS {
            c.push((99, false));
        }
        for &(m, f) in c.iter() {
            input.push(m);
            input.push(f as u32);
        }
    }
    let n = cases.len();
    let got: Vec<u32> = run_probe(&d, &k, &input, n, n * 4 * STEPS);
    let mut full = 0;
    for (i, c) in cases.iter().enumerate() {
        let want = media_reference(c);
        assert_eq!(
            &got[i * 4 * STEPS..(i + 1) * 4 * STEPS],
            &want[..],
            "case {i}: {c:?}"
        );
        full += want.chunks(4).any(|s| s[3] as usize == MEDIUM_STACK) as usize;
    }
    // The random cases reach a full list often enough to test dropping.
    assert!(full > 100, "{full} cases filled the list");
    // The real cases: the liquid-filled glass's inner wall is false going
    // in (step 2), real going out (step 3: liquid to glass).
    let glass = media_reference(&cases[1]);
    assert_eq!(&glass[8..12], &[1, 1, 1, 1]);
    assert_eq!(&glass[12..16], &[0, 1, 0, 2]);
}

#[test]
fn relative_index_and_f0_match_the_reference_bit_for_bit() {
    let d = common::device();
    let program = probe_program(&d);
    let k = d.kernel(&program, "media_eta_probe").unwrap();
    let mut rng = Rng::new(5);
    let mut input = vec![1.5, 1.0, 1.0, 1.5, 1.0, 0.0, 1.5, 1.33, 1.0, 1.33, 1.5, 0.0];
    for _ in 0..4000 {
        input.push(1.0 + rng.f32() * 2.0);
        input.push(1.0 + rng.f32() * 2.0);
        input.push((rng.f32() < 0.5) as u32 as f32);
    }
    let n = input.len() / 3;
    let got: Vec<f32> = run_probe(&d, &k, &input, n, 2 * n);
    for (i, c) in input.chunks(3).enumerate() {
        let eta = relative_eta(c[0], c[1], c[2] != 0.0);
        let f0 = relative_f0(c[0], c[1]);
        assert_eq!(got[2 * i].to_bits(), eta.to_bits(), "eta, case {c:?}");
        assert_eq!(got[2 * i + 1].to_bits(), f0.to_bits(), "f0, case {c:?}");
    }
    // Against air, a lone volume's indices and F0 exactly.
    assert_eq!(got[0], 1.5);
    assert_eq!(got[2], 1.0 / 1.5);
    assert_eq!(got[1], f0_of_ior(1.5));
    let d = Dielectric::nested(1.5, 1.0, 1.0, true, false);
    assert_eq!(d, Dielectric::new(1.5, 1.0, true, false));
}

fn volume(ior: f32) -> Material {
    Material {
        transmission_factor: 1.0,
        ior,
        thickness_factor: 1.0,
        double_sided: true,
        ..material([1.0; 4], 0.0, 0.0)
    }
}

/// A box 4 x 4 wide between z = z0 and z1, facing outward (`inward`: the
/// faces turned inside, the cavity of a hollow mesh).
fn slab(s: &mut Soup, z0: f32, z1: f32, w: f32, inward: bool, mat: u32) {
    let (c, h) = ((z0 + z1) * 0.5, (z1 - z0) * 0.5);
    let o = Vec3::Z * c;
    let f = if inward { -1.0 } else { 1.0 };
    for (n, at, u, v) in [
        (Vec3::Z, Vec3::Z * h, Vec3::X * w, Vec3::Y * w),
        (Vec3::NEG_Z, Vec3::NEG_Z * h, Vec3::X * w, Vec3::Y * w),
        (Vec3::X, Vec3::X * w, Vec3::Y * w, Vec3::Z * h),
        (Vec3::NEG_X, Vec3::NEG_X * w, Vec3::Y * w, Vec3::Z * h),
        (Vec3::Y, Vec3::Y * w, Vec3::X * w, Vec3::Z * h),
        (Vec3::NEG_Y, Vec3::NEG_Y * w, Vec3::X * w, Vec3::Z * h),
    ] {
        quad(s, o + at, u, v, n * f, mat);
    }
}

/// The soup's slabs between an orthographic camera on +z and an emitter of
/// radiance 1 at z = -3 (material `emitter`), in a black world: the mean
/// and standard error of the centre pixels, which see the stack's
/// transmittance at normal incidence.
fn transmittance(mut s: Soup, mut materials: Vec<Material>) -> (f64, f64) {
    let d = common::device();
    let emitter_id = materials.len() as u32;
    quad(
        &mut s,
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::X * 10.0,
        Vec3::Y * 10.0,
        Vec3::Z,
        emitter_id,
    );
    let mut emitter = material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
    emitter.emissive_factor = [1.0; 3];
    materials.push(emitter);
    let cam = orthographic(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 0.5);
    let mut st = settings(8, 256);
    st.max_depth = 24;
    st.environment = Environment::Color([0.0; 3]);
    let out = render_soup(&d, &s, &table(materials), &cam, &[], &st, 0).unwrap();
    let v: Vec<f64> = out.image.rgba.iter().map(|p| grey(*p)).collect();
    mean_se(&v)
}

/// The transmittance of lossless interfaces of reflectances `r` in a row,
/// with all inter-reflections (incoherent): each pair combines as
/// T = T1 T2 / (1 - R1 R2), R = 1 - T.
fn stack_transmittance(r: &[f64]) -> f64 {
    r.iter()
        .fold(1.0, |t, &ri| t * (1.0 - ri) / (1.0 - (1.0 - t) * ri))
}

#[test]
fn glass_slab_in_water_transmits_the_relative_fresnel() {
    // Water |z| < 1 (1.33) around a glass slab |z| < 0.25 (1.5): the
    // interfaces air-water, water-glass, glass-water, water-air. Against
    // air the glass's faces would reflect f0(1.5) = 4 %, against water
    // f0(1.5/1.33) = 0.36 %.
    let mut s = Soup::default();
    slab(&mut s, -1.0, 1.0, 2.0, false, 0);
    slab(&mut s, -0.25, 0.25, 1.5, false, 1);
    let (got, se) = transmittance(s, vec![volume(1.33), volume(1.5)]);
    let (rw, rg) = (f0_of_ior(1.33) as f64, f0_of_ior(1.5 / 1.33) as f64);
    let want = stack_transmittance(&[rw, rg, rg, rw]);
    let as_in_air = stack_transmittance(&[rw, f0_of_ior(1.5) as f64, f0_of_ior(1.5) as f64, rw]);
    eprintln!("glass in water: {got} ± {se} (analytic {want}; glass against air {as_in_air})");
    assert!(
        (got - want).abs() < 4.0 * se + 1e-3,
        "{got} ± {se} vs {want}"
    );
    assert!(want - as_in_air > 0.05);
}

#[test]
fn liquid_filled_glass_transmits_the_relative_fresnel() {
    // A hollow glass box (walls 0.4 < |z| < 0.5) filled with liquid whose
    // surface overlaps the walls (|z| < 0.45): air-glass, glass-liquid,
    // liquid-glass, glass-air. The glass's inner faces inside the liquid
    // and the liquid's faces inside the glass are false interfaces on the
    // way in and out respectively.
    let mut s = Soup::default();
    slab(&mut s, -0.5, 0.5, 2.0, false, 0);
    slab(&mut s, -0.4, 0.4, 1.8, true, 0);
    slab(&mut s, -0.45, 0.45, 1.9, false, 1);
    let (got, se) = transmittance(s, vec![volume(1.5), volume(1.33)]);
    let (rg, rl) = (f0_of_ior(1.5) as f64, f0_of_ior(1.5 / 1.33) as f64);
    let want = stack_transmittance(&[rg, rl, rl, rg]);
    eprintln!("liquid-filled glass: {got} ± {se} (analytic {want})");
    assert!(
        (got - want).abs() < 4.0 * se + 1e-3,
        "{got} ± {se} vs {want}"
    );
}

#[test]
fn nested_absorbing_volumes_attenuate_by_the_product_of_exponentials() {
    // Index 1 everywhere (no Fresnel, no bending), so only Beer-Lambert
    // remains: an outer volume |z| < 1 of colour 0.5 per unit length, an
    // inner |z| < 0.25 of 0.5 per 0.25. The path spends 1.5 in the outer
    // one (0.5^1.5) and 0.5 in the inner (0.5^2).
    let mut outer = volume(1.0);
    outer.attenuation_color = [0.5; 3];
    outer.attenuation_distance = 1.0;
    let mut inner = volume(1.0);
    inner.attenuation_color = [0.5; 3];
    inner.attenuation_distance = 0.25;
    let mut s = Soup::default();
    slab(&mut s, -1.0, 1.0, 2.0, false, 0);
    slab(&mut s, -0.25, 0.25, 1.5, false, 1);
    let (got, se) = transmittance(s, vec![outer, inner]);
    let want = 0.5f64.powf(1.5) * 0.25;
    eprintln!("nested absorbers: {got} ± {se} (analytic {want})");
    assert!(
        (got - want).abs() < 4.0 * se + 1e-4 * want,
        "{got} ± {se} vs {want}"
    );
}

/// A diffuse floor (y = 0) seen from below a pane at y = 0.5 (the camera
/// between them, looking down, sees the floor only), lit by `lights` and
/// an emissive square `emitter` (half size, height) in a black world, with
/// or without the pane: the grey of every pixel.
fn floor_under_pane(
    pane: Option<Material>,
    lights: &[soupray::scene::FrameLight],
    emitter: Option<(f32, f32)>,
    spp: u32,
) -> Vec<f64> {
    let d = common::device();
    let mut s = Soup::default();
    quad(&mut s, Vec3::ZERO, Vec3::X * 4.0, Vec3::Z * 4.0, Vec3::Y, 0);
    let mut materials = vec![material([0.5, 0.5, 0.5, 1.0], 0.0, 1.0)];
    if let Some(p) = pane {
        // Facing down, towards the floor: a shadow ray meets its front.
        quad(
            &mut s,
            Vec3::Y * 0.5,
            Vec3::X * 4.0,
            Vec3::Z * 4.0,
            Vec3::NEG_Y,
            1,
        );
        materials.push(p);
    } else {
        // The same scene's kernel (HAS_TRANSMISSION) without a pane.
        materials.push(volume(1.5));
    }
    if let Some((half, height)) = emitter {
        let mut e = material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
        e.emissive_factor = [1.0; 3];
        quad(
            &mut s,
            Vec3::Y * height,
            Vec3::X * half,
            Vec3::Z * half,
            Vec3::NEG_Y,
            2,
        );
        materials.push(e);
    }
    let cam = orthographic(Vec3::new(0.0, 0.25, 0.0), Vec3::ZERO, Vec3::NEG_Z, 0.25);
    let mut st = settings(16, spp);
    st.max_depth = 1;
    st.environment = Environment::Color([0.0; 3]);
    let out = render_soup(&d, &s, &table(materials), &cam, lights, &st, 0).unwrap();
    out.image.rgba.iter().map(|p| grey(*p)).collect()
}

fn thin_pane(base: [f32; 3], ior: f32) -> Material {
    Material {
        transmission_factor: 1.0,
        ior,
        double_sided: true,
        ..material([base[0], base[1], base[2], 1.0], 0.0, 0.0)
    }
}

#[test]
fn thin_pane_passes_the_suns_light_with_its_straight_through_transmittance() {
    // Floor irradiance with and without the pane: the ratio is the
    // straight-through transmittance base (1 - F(cos)) at the light's
    // angle: a sun straight down and at cos 0.6, and a point light 2 above
    // the seen floor (every pixel within 8 degrees of straight down, where
    // 1 - F differs from normal incidence by under 1e-6).
    let base = [0.9, 0.7, 0.5];
    for (kind, dir) in [
        (LightKind::Directional, Vec3::NEG_Y),
        (LightKind::Directional, Vec3::new(0.8, -0.6, 0.0)),
        (LightKind::Point, Vec3::NEG_Y),
    ] {
        let sun = light(kind, Vec3::Y * 2.0, dir, [1.0; 3], 3.0);
        let with = floor_under_pane(
            Some(thin_pane(base, 1.5)),
            std::slice::from_ref(&sun),
            None,
            4,
        );
        let without = floor_under_pane(None, &[sun], None, 4);
        let (mw, sw) = mean_se(&with);
        let (mo, so) = mean_se(&without);
        let cos = -dir.normalize().y;
        let p =
            BsdfParams::new(base, 0.0, 0.0).with_dielectric(Dielectric::new(1.5, 1.0, false, true));
        let t = thin_straight_through(&p, p.dielectric.as_ref().unwrap(), cos);
        let want = (t.x + t.y + t.z) as f64 / 3.0;
        // And the same from Schlick's formula directly.
        let f0 = f0_of_ior(1.5) as f64;
        let fresnel = f0 + (1.0 - f0) * (1.0 - cos as f64).powi(5);
        let analytic = (0.9 + 0.7 + 0.5) / 3.0 * (1.0 - fresnel);
        eprintln!(
            "{kind:?} at cos {cos}: with pane {mw} ± {sw}, without {mo} ± {so}, ratio {} (analytic {analytic})",
            mw / mo
        );
        assert!((want - analytic).abs() < 1e-6);
        assert!(mo > 0.1, "floor lit: {mo}");
        assert!(
            (mw / mo - analytic).abs() < 1e-4,
            "ratio {} vs {analytic}",
            mw / mo
        );
    }
}

#[test]
fn a_clear_coated_pane_passes_what_its_coat_lets_through() {
    // The same pane under a smooth clear coat (clearcoatFactor 1): the
    // shadow ray keeps the straight-through transmittance times the coat's
    // 1 - Fc(cos), Fc Schlick's at F0 0.04, as the BSDF sample through it
    // carries (kernels/trace/bsdf.h bsdf_shadow_straight_through).
    let base = [0.9, 0.7, 0.5];
    for dir in [Vec3::NEG_Y, Vec3::new(0.8, -0.6, 0.0)] {
        let sun = light(LightKind::Directional, Vec3::Y * 2.0, dir, [1.0; 3], 3.0);
        let coated = Material {
            clearcoat_factor: 1.0,
            clearcoat_roughness: 0.0,
            ..thin_pane(base, 1.5)
        };
        let with = floor_under_pane(Some(coated), std::slice::from_ref(&sun), None, 4);
        let without = floor_under_pane(None, &[sun], None, 4);
        let (mw, mo) = (mean_se(&with).0, mean_se(&without).0);
        let cos = -dir.normalize().y;
        let mut p =
            BsdfParams::new(base, 0.0, 0.0).with_dielectric(Dielectric::new(1.5, 1.0, false, true));
        p.layers = Some(Layers::new(1.0, 0.0, [0.0; 3], 0.0));
        let wo = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
        let t = shadow_straight_through(&p, p.dielectric.as_ref().unwrap(), wo);
        let want = (t.x + t.y + t.z) as f64 / 3.0;
        let schlick = |f0: f64| f0 + (1.0 - f0) * (1.0 - cos as f64).powi(5);
        let analytic = (0.9 + 0.7 + 0.5) / 3.0
            * (1.0 - schlick(f0_of_ior(1.5) as f64))
            * (1.0 - schlick(0.04));
        eprintln!(
            "coated pane at cos {cos}: ratio {} (analytic {analytic})",
            mw / mo
        );
        assert!((want - analytic).abs() < 1e-6, "{want} vs {analytic}");
        assert!(
            (mw / mo - analytic).abs() < 1e-4,
            "ratio {} vs {analytic}",
            mw / mo
        );
    }
}

#[test]
fn thin_pane_under_an_area_light_counts_its_light_once() {
    // A pane that only filters (specular 0: no Fresnel; base 0.5) between a
    // large emitter close above and the floor: half the direct light, at
    // every angle. Light reaches the floor both by its light samples
    // through the pane and by BSDF samples that cross the pane and hit the
    // emitter; MIS must weigh the two as one path (a crossing treated as a
    // delta bounce counts the BSDF share again: here ~25 % more).
    let mut pane = thin_pane([0.5; 3], 1.5);
    pane.specular_factor = 0.0;
    let with = floor_under_pane(Some(pane), &[], Some((1.5, 1.0)), 64);
    let without = floor_under_pane(None, &[], Some((1.5, 1.0)), 64);
    let diff: Vec<f64> = with
        .iter()
        .zip(&without)
        .map(|(w, o)| w - 0.5 * o)
        .collect();
    let (m, se) = mean_se(&diff);
    let (mo, _) = mean_se(&without);
    eprintln!("area light through a filter: with - 0.5 without = {m} ± {se} (without {mo})");
    assert!(mo > 0.1);
    assert!(m.abs() < 4.0 * se + 1e-3 * mo, "{m} ± {se}");
}

/// A sphere facing inward (the cavity of a hollow mesh).
fn inward_sphere(s: &mut Soup, r: f32, mat: u32) {
    let mut t = Soup::default();
    sphere(&mut t, Vec3::ZERO, r, 16, 32, mat);
    for (tri, &m) in t.positions.chunks(3).zip(&t.material_ids) {
        s.positions.extend([tri[0], tri[2], tri[1]]);
        s.material_ids.push(m);
    }
}

#[test]
fn nested_glass_in_a_white_furnace_is_invisible() {
    // Lossless interfaces conserve radiance once the 1/eta^2 scalings of
    // the way in and out cancel, which they do only if each interface uses
    // the relative index the path really crosses: a glass ball in a water
    // ball, and a glass bowl (hollow ball) full of liquid overlapping its
    // wall, vanish in a white furnace.
    let d = common::device();
    let cam = perspective(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    let mut marble = Soup::default();
    sphere(&mut marble, Vec3::ZERO, 1.0, 16, 32, 0);
    sphere(&mut marble, Vec3::ZERO, 0.5, 16, 32, 1);
    let mut bowl = Soup::default();
    sphere(&mut bowl, Vec3::ZERO, 1.0, 16, 32, 1);
    inward_sphere(&mut bowl, 0.85, 1);
    sphere(&mut bowl, Vec3::ZERO, 0.9, 16, 32, 0);
    for (name, s) in [("glass in water", marble), ("liquid in glass", bowl)] {
        let mut st = settings(24, 64);
        st.max_depth = 128;
        st.environment = Environment::Color([1.0, 1.0, 1.0]);
        let t = table(vec![volume(1.33), volume(1.5)]);
        let out = render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap();
        let v = covered(&out.image);
        assert!(v.len() > 150, "{name}: covers {} pixels", v.len());
        let (m, se) = mean_se(&v);
        eprintln!("{name} in a white furnace: {m} ± {se}");
        // 128 bounces: next to no path is cut by the depth limit.
        assert!((m - 1.0).abs() < 4.0 * se + 0.002, "{name}: {m} ± {se}");
    }
}
