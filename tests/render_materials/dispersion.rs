//! KHR_materials_dispersion: the per-channel indices against the
//! reference, dispersive glass invisible in a white furnace, a slab's
//! per-channel Fresnel transmittance, and an edge seen through a glass ball
//! split into its colours.

use super::*;

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
