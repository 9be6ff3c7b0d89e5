//! The path tracer's guarantees: two renders of a frame are identical bit
//! for bit, so are renders cut into other sample passes, tiles and
//! work-group sizes, and the stack, stackless and wide traversals; the error
//! against a high-spp render falls as 1/sqrt(spp) with independent samples
//! and faster with Sobol points; clay mode; alpha MASK
//! cut-outs, BLEND coverage and single- or double-sided faces; a scene
//! with no light gets the studio sky and says so; the AOVs.

mod common;

use common::render::*;
use glam::Vec3;
use soupray::film::Aovs;
use soupray::scene::{AlphaMode, LightKind};
use soupray::soup::Soup;
use soupray::trace::render::{render_soup, Environment, PathTracer, Schedule, Traversal};
use soupray::trace::sampling::{NoisePattern, Sampler};

#[test]
fn renders_are_identical_whatever_the_schedule_and_traversal() {
    let d = common::device();
    let (s, t, lights) = busy_scene();
    let mut st = settings(29, 12);
    assert_eq!(st.traversal, Traversal::Wide8, "the default traversal");
    // Keyed by the frame number (below); the default fixed pattern is not.
    st.noise_pattern = NoisePattern::PerFrame;
    st.environment = Environment::Color([0.2, 0.3, 0.4]);
    st.aovs = Aovs::ALL;
    let mut pt = PathTracer::with_materials(&d, &t, &st).unwrap();
    let a = pt.render_soup(&s, &busy_camera(), &lights, 3).unwrap();
    let b = pt.render_soup(&s, &busy_camera(), &lights, 3).unwrap();
    assert_eq!(bits(&a.image), bits(&b.image), "two renders differ");
    assert_eq!(a.rays, b.rays);
    for schedule in [
        Schedule {
            samples_per_pass: 1,
            tile: None,
            local_size: 64,
        },
        Schedule {
            samples_per_pass: 5,
            tile: Some((7, 5)),
            local_size: 32,
        },
        Schedule {
            samples_per_pass: 12,
            tile: Some((16, 16)),
            local_size: 1,
        },
    ] {
        pt.set_schedule(schedule);
        let mut passes = Vec::new();
        let c = pt.render_soup(&s, &busy_camera(), &lights, 3).unwrap();
        assert_eq!(
            bits(&a.image),
            bits(&c.image),
            "{schedule:?} changes the image"
        );
        assert_eq!(a.rays, c.rays, "{schedule:?}");
        passes.push(c.rays);
    }
    // Another frame number is another image (the random numbers are keyed
    // by it), and rendering it between does not change frame 3.
    pt.set_schedule(Schedule::default());
    let other = pt.render_soup(&s, &busy_camera(), &lights, 4).unwrap();
    assert_ne!(bits(&a.image), bits(&other.image));
    let again = pt.render_soup(&s, &busy_camera(), &lights, 3).unwrap();
    assert_eq!(bits(&a.image), bits(&again.image));
    // The stackless traversal finds the same hits and the same occlusion.
    st.traversal = Traversal::Stackless;
    let sl = render_soup(&d, &s, &t, &busy_camera(), &lights, &st, 3).unwrap();
    assert_eq!(
        bits(&a.image),
        bits(&sl.image),
        "wide and stackless images differ"
    );
    // So does the 4-wide layout (the default is 8-wide)...
    st.traversal = Traversal::Wide;
    let wide4 = render_soup(&d, &s, &t, &busy_camera(), &lights, &st, 3).unwrap();
    assert_eq!(
        bits(&a.image),
        bits(&wide4.image),
        "8-wide and 4-wide images differ"
    );
    // ...and the stack traversal of the binary tree as built, shadow rays
    // included.
    st.traversal = Traversal::Stack;
    let binary = render_soup(&d, &s, &t, &busy_camera(), &lights, &st, 3).unwrap();
    assert_eq!(
        bits(&a.image),
        bits(&binary.image),
        "wide and binary stack images differ"
    );
    // (Ray counts may differ: which blocker an any-hit query meets first
    // depends on the tree walk, and a cut-out or back-facing one costs a
    // closer look; the answer does not.)
    assert!(a.image.rgba.iter().any(|p| p[0] > 0.0 && p[3] == 1.0));
}

/// The slope of log RMSE against log spp (4, 16, 64 spp against a
/// 1024-spp reference of another seed) with `sampler`.
fn rmse_slope(sampler: Sampler) -> (f64, Vec<(f64, f64)>) {
    let d = common::device();
    let (s, t, lights) = busy_scene();
    let size = 24;
    let mut st = settings(size, 1024);
    st.sampler = sampler;
    st.environment = Environment::Color([0.2, 0.3, 0.4]);
    st.seed = 1234; // independent of the renders below
    let reference = render_soup(&d, &s, &t, &busy_camera(), &lights, &st, 0)
        .unwrap()
        .image;
    let mut pts = Vec::new();
    st.seed = 7;
    for spp in [4u32, 16, 64] {
        st.spp = spp;
        let img = render_soup(&d, &s, &t, &busy_camera(), &lights, &st, 0)
            .unwrap()
            .image;
        let mse: f64 = img
            .rgba
            .iter()
            .zip(&reference.rgba)
            .map(|(a, b)| {
                (0..3)
                    .map(|c| (a[c] as f64 - b[c] as f64).powi(2))
                    .sum::<f64>()
            })
            .sum::<f64>()
            / (3 * size * size) as f64;
        pts.push(((spp as f64).ln(), mse.sqrt().ln()));
    }
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let slope = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
        / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
    (slope, pts)
}

#[test]
fn error_falls_as_one_over_sqrt_spp_with_independent_samples() {
    let (slope, pts) = rmse_slope(Sampler::Random);
    assert!((slope + 0.5).abs() < 0.15, "RMSE slope {slope} ({pts:?})");
}

#[test]
fn error_falls_faster_than_one_over_sqrt_spp_with_sobol() {
    // Stratified samples converge faster than independent ones (up to
    // 1/spp^1.5 for smooth integrands under Owen scrambling); never slower.
    let (slope, pts) = rmse_slope(Sampler::Sobol);
    assert!(
        (-1.5..-0.55).contains(&slope),
        "RMSE slope {slope} ({pts:?})"
    );
}

#[test]
fn clay_overrides_every_material() {
    let d = common::device();
    let (s, t, lights) = busy_scene();
    let mut st = settings(16, 4);
    st.clay = true;
    st.aovs = Aovs::ALL;
    let out = render_soup(&d, &s, &t, &busy_camera(), &lights, &st, 0).unwrap();
    for (p, a) in out
        .image
        .rgba
        .iter()
        .zip(out.image.albedo.as_ref().unwrap())
    {
        if p[3] == 1.0 {
            assert_eq!(*a, [0.8, 0.8, 0.8], "clay albedo");
        }
    }
    // A clay furnace: albedo 0.8 of a uniform environment (convex sphere).
    let mut one = Soup::default();
    sphere(&mut one, Vec3::ZERO, 1.0, 12, 24, 1);
    st.environment = Environment::Color([2.0, 2.0, 2.0]);
    st.spp = 64;
    let cam = perspective(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    let out = render_soup(&d, &one, &t, &cam, &[], &st, 0).unwrap();
    let v = covered(&out.image);
    let (m, se) = mean_se(&v);
    assert!((m - 1.6).abs() < 4.0 * se + 2e-3, "{m} ± {se}");
}

/// A 2x2 quad at z = 0 facing +Z (or -Z), in front of a camera on +Z.
fn facing_quad(towards_camera: bool, mat: u32) -> Soup {
    let mut s = Soup::default();
    let n = if towards_camera { Vec3::Z } else { Vec3::NEG_Z };
    quad(&mut s, Vec3::ZERO, Vec3::X, Vec3::Y, n, mat);
    s
}

fn coverage(img: &soupray::film::Image) -> f64 {
    img.rgba.iter().map(|p| p[3] as f64).sum::<f64>() / img.rgba.len() as f64
}

#[test]
fn alpha_modes_and_sidedness() {
    let d = common::device();
    // The quad fills the whole view.
    let cam = orthographic(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 0.5);
    let mut st = settings(8, 16);
    st.environment = Environment::Color([1.0; 3]);
    let mut m = material([1.0, 1.0, 1.0, 0.3], 0.0, 1.0);
    let cases = [
        (AlphaMode::Opaque, 0.3, true, false, false, 1.0),
        (AlphaMode::Mask, 0.3, true, false, false, 0.0),
        (AlphaMode::Mask, 0.7, true, false, false, 1.0),
        // Seen from behind: shaded by default, single-sided or not (as in
        // Cycles); with --backface-culling a single-sided face is culled.
        (AlphaMode::Opaque, 1.0, false, false, false, 1.0),
        (AlphaMode::Opaque, 1.0, false, true, false, 1.0),
        (AlphaMode::Opaque, 1.0, false, false, true, 0.0),
        (AlphaMode::Opaque, 1.0, false, true, true, 1.0),
        (AlphaMode::Opaque, 1.0, true, false, true, 1.0),
    ];
    for (mode, alpha, front, double, cull, want) in cases {
        m.alpha_mode = mode;
        m.base_color_factor[3] = alpha;
        m.double_sided = double;
        st.backface_culling = cull;
        let out = render_soup(
            &d,
            &facing_quad(front, 0),
            &table(vec![m.clone()]),
            &cam,
            &[],
            &st,
            0,
        )
        .unwrap();
        let c = coverage(&out.image);
        assert_eq!(
            c, want,
            "{mode:?} alpha {alpha} front {front} double {double} culling {cull}"
        );
        if want == 1.0 {
            // Lit from the camera's side, whichever way it faces.
            assert!(
                out.image.rgba.iter().all(|p| p[0] > 0.3),
                "{mode:?} {front} {double}"
            );
        }
    }
    // BLEND is stochastic coverage: alpha 0.25 covers a quarter.
    m.alpha_mode = AlphaMode::Blend;
    m.base_color_factor[3] = 0.25;
    m.double_sided = false;
    st.spp = 64;
    let out = render_soup(
        &d,
        &facing_quad(true, 0),
        &table(vec![m.clone()]),
        &cam,
        &[],
        &st,
        0,
    )
    .unwrap();
    let c = coverage(&out.image);
    // 4096 Bernoulli(0.25) samples: sigma 0.0068.
    assert!((c - 0.25).abs() < 0.03, "blend coverage {c}");
    // A cut-out casts no shadow: a plane under a MASK hole is fully lit.
    let mut s = Soup::default();
    quad(
        &mut s,
        Vec3::ZERO,
        Vec3::X * 20.0,
        Vec3::Z * 20.0,
        Vec3::Y,
        0,
    );
    quad(
        &mut s,
        Vec3::new(0.0, 1.0, 0.0),
        Vec3::X * 20.0,
        Vec3::Z * 20.0,
        Vec3::Y,
        1,
    );
    let hole = Material {
        alpha_mode: AlphaMode::Mask,
        base_color_factor: [1.0, 1.0, 1.0, 0.1],
        double_sided: true,
        ..material([1.0; 4], 0.0, 1.0)
    };
    let t = table(vec![material([0.8, 0.8, 0.8, 1.0], 0.0, 1.0), hole]);
    let l = light(
        LightKind::Directional,
        Vec3::ZERO,
        Vec3::NEG_Y,
        [1.0; 3],
        2.0,
    );
    let mut st = settings(8, 4);
    st.clay = true;
    st.max_depth = 1;
    let out = render_soup(&d, &s, &t, &top_down(1.0), &[l], &st, 0).unwrap();
    let want = 0.8 / std::f32::consts::PI * 2.0;
    for p in &out.image.rgba {
        assert!((p[0] - want).abs() < 1e-4, "{} vs {want}", p[0]);
    }
}

use soupray::scene::Material;

#[test]
fn a_scene_without_lights_gets_the_studio_sky_and_says_so() {
    let d = common::device();
    let mut s = Soup::default();
    sphere(&mut s, Vec3::ZERO, 1.0, 12, 24, 0);
    let cam = perspective(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y, 60.0);
    let mut st = settings(16, 16);
    st.clay = true;
    let out = render_soup(&d, &s, &table(vec![]), &cam, &[], &st, 0).unwrap();
    assert!(
        out.warnings
            .iter()
            .any(|w| w.contains("no KHR_lights_punctual light") && w.contains("studio sky")),
        "{:?}",
        out.warnings
    );
    // The background is the grey sky near the horizon, alpha 0.
    let bg = out.image.rgba[0];
    assert!(bg[0] == bg[1] && bg[1] == bg[2] && bg[3] == 0.0, "{bg:?}");
    assert!((0.7..=1.0).contains(&bg[0]), "{bg:?}");
    // A white object does not vanish against it: the sphere's top, facing
    // the zenith, is brighter than its bottom, facing the ground, and its
    // centre differs from the sky behind it.
    let px = |x: usize, y: usize| out.image.rgba[y * 16 + x];
    let (top, centre, bottom) = (px(8, 5), px(8, 8), px(8, 11));
    assert!(top[0] > bottom[0] + 0.1, "top {top:?} bottom {bottom:?}");
    assert!(
        (centre[0] - bg[0]).abs() > 0.05,
        "centre {centre:?} sky {bg:?}"
    );
    // With a light, there is no environment and no warning.
    let l = light(
        LightKind::Point,
        Vec3::new(0.0, 3.0, 3.0),
        Vec3::NEG_Y,
        [1.0; 3],
        10.0,
    );
    let lit = render_soup(&d, &s, &table(vec![]), &cam, &[l], &st, 0).unwrap();
    assert!(lit.warnings.is_empty(), "{:?}", lit.warnings);
    assert_eq!(lit.image.rgba[0], [0.0; 4]);
}

#[test]
fn aovs_report_first_hit_depth_normal_and_albedo() {
    let d = common::device();
    let mut s = facing_quad(true, 0);
    // Smooth normals tilted towards +X: the normal AOV is the shading normal.
    let n = Vec3::new(0.6, 0.0, 0.8);
    s.normals = vec![[n.x, n.y, n.z, 0.0]; s.positions.len()];
    let cam = perspective(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, Vec3::Y, 10.0);
    let mut st = settings(8, 8);
    st.aovs = Aovs::ALL;
    let t = table(vec![material([0.2, 0.4, 0.6, 1.0], 0.0, 1.0)]);
    let out = render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap();
    let img = &out.image;
    for i in 0..img.rgba.len() {
        assert_eq!(img.rgba[i][3], 1.0);
        let z = img.depth.as_ref().unwrap()[i];
        // The distance to the plane z = 0 from (0, 0, 3): at least 3, at
        // most along the corner rays widened by the filter's 1.5 px reach.
        let tan_max = 2f32.sqrt() * 5f32.to_radians().tan() * (1.0 + 1.5 / 4.0);
        assert!(
            z >= 3.0 * 0.99999 && z < 3.0 * (1.0 + tan_max * tan_max).sqrt(),
            "depth {z}"
        );
        let nn = img.normal.as_ref().unwrap()[i];
        assert!(
            (nn[0] - 0.6).abs() < 1e-5 && (nn[2] - 0.8).abs() < 1e-5,
            "{nn:?}"
        );
        let a = img.albedo.as_ref().unwrap()[i];
        assert!(
            (a[0] - 0.2).abs() < 1e-6 && (a[1] - 0.4).abs() < 1e-6 && (a[2] - 0.6).abs() < 1e-6
        );
    }
    // Background pixels: background depth, zero normal and albedo.
    let mut empty = Soup::default();
    quad(
        &mut empty,
        Vec3::new(100.0, 0.0, 0.0),
        Vec3::X * 0.1,
        Vec3::Y * 0.1,
        Vec3::Z,
        0,
    );
    let out = render_soup(&d, &empty, &t, &cam, &[], &st, 0).unwrap();
    assert_eq!(
        out.image.depth.as_ref().unwrap()[0],
        soupray::film::BACKGROUND_DEPTH
    );
    assert_eq!(out.image.normal.as_ref().unwrap()[0], [0.0; 3]);
}

#[test]
fn bad_settings_are_refused_with_the_fix() {
    let d = common::device();
    let mut st = settings(0, 4);
    let e = render_soup(
        &d,
        &Soup::default(),
        &table(vec![]),
        &top_down(1.0),
        &[],
        &st,
        0,
    )
    .unwrap_err();
    assert!(e.to_string().contains("--width"), "{e}");
    st = settings(4, 0);
    let e = render_soup(
        &d,
        &Soup::default(),
        &table(vec![]),
        &top_down(1.0),
        &[],
        &st,
        0,
    )
    .unwrap_err();
    assert!(e.to_string().contains("--spp"), "{e}");
    // An empty soup renders the environment.
    st = settings(4, 2);
    st.environment = Environment::Color([0.5; 3]);
    let out = render_soup(
        &d,
        &Soup::default(),
        &table(vec![]),
        &top_down(1.0),
        &[],
        &st,
        0,
    )
    .unwrap();
    assert!(out.image.rgba.iter().all(|p| *p == [0.5, 0.5, 0.5, 0.0]));
}

#[test]
fn a_fixed_noise_pattern_draws_the_same_samples_every_frame() {
    let d = common::device();
    let (s, t, lights) = busy_scene();
    let mut st = settings(17, 4);
    st.noise_pattern = NoisePattern::Fixed;
    let fixed_3 = render_soup(&d, &s, &t, &busy_camera(), &lights, &st, 3).unwrap();
    let fixed_40 = render_soup(&d, &s, &t, &busy_camera(), &lights, &st, 40).unwrap();
    assert_eq!(
        bits(&fixed_3.image),
        bits(&fixed_40.image),
        "a still scene renders the same pixels in every frame with a fixed pattern"
    );
    // It is frame 0's pattern, and the per-frame pattern of another frame
    // is another image.
    st.noise_pattern = NoisePattern::PerFrame;
    let per_frame_0 = render_soup(&d, &s, &t, &busy_camera(), &lights, &st, 0).unwrap();
    let per_frame_40 = render_soup(&d, &s, &t, &busy_camera(), &lights, &st, 40).unwrap();
    assert_eq!(bits(&fixed_3.image), bits(&per_frame_0.image));
    assert_ne!(bits(&per_frame_0.image), bits(&per_frame_40.image));
}
