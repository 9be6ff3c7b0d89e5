//! Adaptive sampling (`--noise-threshold`) and the noise estimate: frames
//! reproducible bit for bit whatever the schedule, converged pixels below
//! the threshold by the Rust twin of the device's estimate, a furnace that
//! stops at the minimum and keeps its albedo, the mean of the uniform
//! render, and the estimate against the measured error.

mod common;

use common::render::*;
use glam::Vec3;
use soupray::film::{Aovs, Image};
use soupray::soup::Soup;
use soupray::trace::render::{
    check_counts, render_soup, Adaptive, Allocation, Environment, PathTracer, RenderSettings,
    Schedule,
};

fn base(size: u32, spp: u32) -> RenderSettings {
    let mut st = settings(size, spp);
    st.environment = Environment::Color([0.2, 0.3, 0.4]);
    st
}

fn adaptive(size: u32, spp: u32, threshold: f32) -> RenderSettings {
    let mut st = base(size, spp);
    st.adaptive = Some(Adaptive {
        threshold,
        min_spp: 16,
        allocation: Allocation::Error,
    });
    st.aovs = Aovs {
        sample_count: true,
        noise: true,
        rays: true,
        ..Aovs::NONE
    };
    st
}

fn render(st: &RenderSettings, seed: u64) -> soupray::trace::render::RenderOutput {
    let d = common::device();
    let (s, t, lights) = busy_scene();
    let mut st = st.clone();
    st.seed = seed;
    render_soup(&d, &s, &t, &busy_camera(), &lights, &st, 0).unwrap()
}

fn rel_mse(a: &Image, b: &Image) -> f64 {
    soupray::compare::relative_mse(a, b).unwrap()
}

fn image_mean(img: &Image) -> f64 {
    img.rgba.iter().map(|p| grey(*p)).sum::<f64>() / img.rgba.len() as f64
}

/// Renders the busy scene with `st` under the default schedule and under
/// `schedule`, and checks that the two frames are the same bit for bit
/// (image, sample counts, per-pixel rays, noise report) and that sampling
/// did adapt: some pixels stopped early, some went on.
fn assert_schedule_independent(st: &RenderSettings, schedule: Schedule) {
    let d = common::device();
    let (s, t, lights) = busy_scene();
    let mut a = PathTracer::with_materials(&d, &t, st).unwrap();
    let one = a.render_soup(&s, &busy_camera(), &lights, 0).unwrap();
    let mut b = PathTracer::with_materials(&d, &t, st).unwrap();
    b.set_schedule(schedule);
    let two = b.render_soup(&s, &busy_camera(), &lights, 0).unwrap();
    assert_eq!(bits(&one.image), bits(&two.image));
    assert_eq!(one.image.sample_count, two.image.sample_count);
    assert_eq!(one.pixel_rays, two.pixel_rays);
    assert_eq!(one.noise, two.noise);
    // The `rays` AOV is the per-pixel ray count, exactly.
    let rays: Vec<f32> = one.pixel_rays.iter().map(|&r| r as f32).collect();
    assert_eq!(one.image.rays.as_ref(), Some(&rays));
    assert!(rays.iter().all(|&r| r >= 16.0));
    let counts = one.image.sample_count.as_ref().unwrap();
    let spp = st.spp as f32;
    assert!(counts.iter().any(|&c| c < spp) && counts.iter().any(|&c| c > 16.0));
}

#[test]
fn adaptive_frames_are_identical_whatever_the_schedule() {
    let schedule = Schedule {
        samples_per_pass: 3,
        tile: Some((7, 5)),
        local_size: 13,
    };
    assert_schedule_independent(&adaptive(29, 96, 0.05), schedule);
}

#[test]
fn stopped_pixels_are_below_the_threshold_and_counts_fall_on_checks() {
    // The device decides with pt_noise_estimate; the host reports with its
    // Rust twin from the same sums. A pixel that stopped early did so at a
    // check where its estimate was below the threshold, and its sums have
    // not changed since: the twin must agree.
    let (spp, t) = (128u32, 0.04f32);
    let out = render(&adaptive(32, spp, t), 3);
    let counts = out.image.sample_count.as_ref().unwrap();
    let noise = out.image.noise.as_ref().unwrap();
    let checks = check_counts(16, spp);
    assert_eq!(checks, [16, 24, 32, 48, 72, 104]);
    let mut stopped = 0;
    for (&c, &e) in counts.iter().zip(noise) {
        let c = c as u32;
        assert!(c >= 16 && c <= spp, "count {c}");
        assert!(
            c == spp || checks.contains(&c),
            "count {c} off the checks {checks:?}"
        );
        if c < spp {
            assert!(
                e < t,
                "a pixel stopped at {c} samples with estimate {e} >= {t}"
            );
            stopped += 1;
        }
    }
    assert!(stopped > 0);
    assert_eq!(out.noise.target, Some(t));
    assert_eq!(
        out.noise.spp_max,
        *counts.iter().max_by(|a, b| a.total_cmp(b)).unwrap() as u32
    );
}

#[test]
fn furnace_stops_at_the_minimum_and_keeps_the_albedo() {
    // A convex clay sphere under a uniform sky: every sample of an interior
    // pixel is exactly 0.8, so the estimate is 0 at the first check.
    let d = common::device();
    let mut s = Soup::default();
    sphere(&mut s, Vec3::ZERO, 1.0, 16, 32, 0);
    let cam = perspective(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    let mut st = adaptive(32, 256, 0.01);
    st.clay = true;
    st.environment = Environment::Color([1.0; 3]);
    let out = render_soup(&d, &s, &table(vec![]), &cam, &[], &st, 0).unwrap();
    let counts = out.image.sample_count.as_ref().unwrap();
    let mut interior = 0;
    for (i, p) in out.image.rgba.iter().enumerate() {
        if p[3] == 1.0 && (grey(*p) - 0.8).abs() < 1e-6 {
            interior += 1;
        }
        if p[3] == 0.0 {
            assert_eq!(grey(*p), 1.0, "background");
        }
        let _ = counts[i];
    }
    assert!(interior > 300, "{interior} interior pixels at exactly 0.8");
    // Interior pixels far from the silhouette (not dilated) stop at 16.
    assert!(
        counts.iter().filter(|&&c| c == 16.0).count() > 200,
        "{:?}",
        out.noise
    );
    // Only silhouette pixels (a mix of sphere and sky) go on: the mean
    // stays below a quarter of --spp.
    assert!(out.noise.spp_mean < 64.0, "{:?}", out.noise);
}

#[test]
fn adaptive_mean_matches_the_uniform_render() {
    // Stopping where the estimate is low is correlated with the samples
    // (a pixel that saw no rare event by a check stops without it), so
    // adaptive sampling is not exactly unbiased; on this scene the image
    // mean stays within 0.5% of the uniform render's.
    let uniform = render(&base(48, 256), 11);
    let adapt = render(&adaptive(48, 256, 0.03), 11);
    let (mu, ma) = (image_mean(&uniform.image), image_mean(&adapt.image));
    assert!(
        ((ma - mu) / mu).abs() < 5e-3,
        "adaptive mean {ma} vs uniform {mu} (spp mean {})",
        adapt.noise.spp_mean
    );
    assert!(adapt.noise.spp_mean < 200.0, "{:?}", adapt.noise);
}

#[test]
fn the_estimate_tracks_the_measured_error() {
    // sqrt of the mean squared estimate against the measured relative RMS
    // error (against a 2048-spp reference of another seed) of uniform
    // renders: within a factor of 2 either way (measured: see the message).
    let reference = render(&base(32, 2048), 99);
    for spp in [16u32, 64] {
        let mut st = base(32, spp);
        st.aovs = Aovs {
            noise: true,
            ..Aovs::NONE
        };
        let out = render(&st, 5);
        let noise = out.image.noise.as_ref().unwrap();
        let est =
            (noise.iter().map(|&e| (e as f64).powi(2)).sum::<f64>() / noise.len() as f64).sqrt();
        let measured = rel_mse(&out.image, &reference.image).sqrt();
        let ratio = est / measured;
        eprintln!("spp {spp}: estimated {est:.4}, measured {measured:.4}, ratio {ratio:.2}");
        assert!(
            (0.5..2.0).contains(&ratio),
            "spp {spp}: estimated {est} vs measured {measured}"
        );
    }
}

fn time_allocation(size: u32, spp: u32, threshold: f32) -> RenderSettings {
    let mut st = adaptive(size, spp, threshold);
    st.adaptive.as_mut().unwrap().allocation = Allocation::Time;
    st
}

#[test]
fn time_allocation_frames_are_identical_whatever_the_schedule() {
    let schedule = Schedule {
        samples_per_pass: 5,
        tile: Some((6, 11)),
        local_size: 7,
    };
    assert_schedule_independent(&time_allocation(29, 96, 0.03), schedule);
}

#[test]
fn time_allocation_stops_dear_pixels_at_a_higher_error() {
    // The device decides with pt_stop_threshold from the rays each pixel
    // traced; its Rust twin (film::stop_threshold) from the same counts and
    // the logged reference must agree for every pixel that stopped early.
    // Some of them stopped above T itself: pixels dearer than the frame's
    // mean at the first check, which equal-error allocation would have
    // sampled on.
    let (spp, t) = (128u32, 0.03f32);
    let out = render(&time_allocation(32, spp, t), 3);
    let counts = out.image.sample_count.as_ref().unwrap();
    let noise = out.image.noise.as_ref().unwrap();
    let work_ref = out.noise.work_reference.expect("time allocation logs it");
    let total: u64 = out.pixel_rays.iter().map(|&r| r as u64).sum();
    assert_eq!(total, out.rays);
    assert!(
        work_ref >= 16.0 && work_ref <= total as f64 / 1024.0,
        "{work_ref}"
    );
    assert_eq!(out.noise.allocation.as_deref(), Some("time"));
    let inv = (1.0 / work_ref) as f32;
    let checks = check_counts(16, spp);
    let (mut stopped, mut above_t, mut converged) = (0, 0, 0);
    for ((&c, &e), &w) in counts.iter().zip(noise).zip(&out.pixel_rays) {
        let c = c as u32;
        assert!(c == spp || checks.contains(&c), "count {c}");
        let limit = soupray::film::stop_threshold(t, w, inv);
        if e < limit {
            converged += 1;
        }
        if c < spp {
            assert!(
                e < limit,
                "a pixel stopped at {c} samples, {w} rays, with estimate {e} >= {limit}"
            );
            stopped += 1;
            if e >= t {
                above_t += 1;
            }
        }
    }
    assert!(
        stopped > 0 && above_t > 0,
        "{stopped} stopped, {above_t} above T"
    );
    let fraction = converged as f64 / counts.len() as f64;
    assert_eq!(out.noise.converged_fraction, Some(fraction));
}

#[test]
fn time_allocation_mean_matches_the_uniform_render() {
    // As adaptive_mean_matches_the_uniform_render, with the time rule.
    let uniform = render(&base(48, 256), 11);
    let adapt = render(&time_allocation(48, 256, 0.015), 11);
    let (mu, ma) = (image_mean(&uniform.image), image_mean(&adapt.image));
    assert!(
        ((ma - mu) / mu).abs() < 5e-3,
        "adaptive mean {ma} vs uniform {mu} (spp mean {})",
        adapt.noise.spp_mean
    );
    assert!(adapt.noise.spp_mean < 200.0, "{:?}", adapt.noise);
}

#[test]
fn stop_threshold_scales_with_the_square_root_of_the_work() {
    use soupray::film::stop_threshold;
    // Equal-error allocation: the threshold itself, whatever the work.
    assert_eq!(stop_threshold(0.05, 12345, 0.0), 0.05);
    // Time allocation: T at the reference work, 2T at four times it.
    assert_eq!(stop_threshold(0.05, 100, 0.01), 0.05);
    assert_eq!(stop_threshold(0.05, 400, 0.01), 0.1);
    assert_eq!(stop_threshold(0.05, 0, 0.01), 0.0);
}

/// Frame 24 of CesiumMan (the shared folder's) at 192x108 through the CLI; the EXR's
/// channels and the frame log.
fn render_shipped(
    dir: &std::path::Path,
    args: &[&str],
) -> Option<(
    std::collections::BTreeMap<String, Vec<f32>>,
    soupray::output::FrameLog,
)> {
    let scene = common::shared::cesium_man()?;
    let out = common::soupray_cmd()
        .arg("render")
        .arg(&scene)
        .args([
            "--frame", "24", "--width", "192", "--height", "108", "--quiet",
        ])
        .args(args)
        .arg("--out")
        .arg(dir)
        .output()
        .expect("run soupray");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let log = soupray::output::read_log(&dir.join("CesiumMan.0024.json")).unwrap();
    Some((common::exr_channels(&dir.join("CesiumMan.0024.exr")), log))
}

#[test]
fn the_estimate_tracks_the_measured_error_on_the_shipped_animation() {
    // The sampler's points are stratified, so the error of a mean falls
    // faster than independent samples' would: the estimate must see that
    // (film::noise_estimate), not the independent-sample error, which was
    // 1.9x the measured RMS error here at 64 spp with the even/odd split.
    let dir = tempfile::tempdir().unwrap();
    let Some((reference, _)) =
        render_shipped(&dir.path().join("ref"), &["--spp", "1024", "--seed", "77"])
    else {
        return;
    };
    for spp in ["16", "64"] {
        let Some((ch, log)) = render_shipped(
            &dir.path().join(spp),
            &["--spp", spp, "--aov", "noise,rays"],
        ) else {
            return;
        };
        let noise = &ch["noise"];
        let est =
            (noise.iter().map(|&e| (e as f64).powi(2)).sum::<f64>() / noise.len() as f64).sqrt();
        let mut sum = 0.0;
        for c in ["R", "G", "B"] {
            for (t, r) in ch[c].iter().zip(&reference[c]) {
                let (t, r) = (*t as f64, *r as f64);
                sum += (t - r) * (t - r) / (r * r + 0.01);
            }
        }
        let measured = (sum / (3 * noise.len()) as f64).sqrt();
        let ratio = est / measured;
        eprintln!("spp {spp}: estimated {est:.5}, measured {measured:.5}, ratio {ratio:.2}");
        assert!(
            (0.75..1.35).contains(&ratio),
            "spp {spp}: estimated {est} vs measured {measured}"
        );
        // The `rays` AOV adds up to the log's rays, every pixel at least one
        // camera ray per sample.
        let rays = &ch["rays"];
        assert_eq!(rays.iter().map(|&r| r as u64).sum::<u64>(), log.render.rays);
        let spp: f32 = spp.parse().unwrap();
        assert!(rays.iter().all(|&r| r >= spp && r.fract() == 0.0));
    }
}
