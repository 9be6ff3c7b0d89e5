//! `soupray render --denoise` (Open Image Denoise 2.x, loaded at run time).
//!
//! Without OIDN: `--denoise` fails before rendering with exit code 3 and a
//! message saying how to install it. With OIDN (CI installs it through
//! scripts/setup.sh): the frame is denoised end to end, the EXR keeps the
//! raw beauty bit for bit in the `noisy` layer, the denoised beauty is
//! closer (relative MSE) to a high-spp reference than the raw one, and the
//! log records
//! the library. Those tests skip where OIDN is not installed, unless
//! SOUPRAY_REQUIRE_OIDN=1 (as in CI), where they fail instead.

mod common;

use soupray::compare;
use soupray::denoise::{Denoiser, Quality};
use soupray::film::{Aovs, Image};
use std::collections::BTreeMap;
use std::path::Path;
use std::process::Output;

/// CesiumMan, read in place from the shared folder; `None` (the caller
/// skips) when it is absent.
fn scene() -> Option<String> {
    common::shared::cesium_man().map(|p| p.display().to_string())
}

/// Renders frame 10 of CesiumMan (the shared folder's) at 256x144 into `out`.
fn render(out: &Path, spp: u32, extra: &[&str], env: &[(&str, &str)]) -> Option<Output> {
    let scene = scene()?;
    let spp = spp.to_string();
    let mut cmd = common::soupray_cmd();
    cmd.args(["render", scene.as_str(), "--out", out.to_str().unwrap()])
        .args(["--frame", "10", "--width", "256", "--height", "144"])
        .args(["--spp", spp.as_str(), "--quiet"])
        .args(extra);
    for (k, v) in env {
        cmd.env(k, v);
    }
    Some(cmd.output().expect("run soupray"))
}

/// An `Image` from three channels of an EXR (and its `A`).
fn image_from(ch: &BTreeMap<String, Vec<f32>>, names: [&str; 3], w: u32, h: u32) -> Image {
    let mut img = Image::new(w, h, Aovs::NONE);
    for (i, px) in img.rgba.iter_mut().enumerate() {
        for c in 0..3 {
            px[c] = ch[names[c]][i];
        }
        px[3] = ch["A"][i];
    }
    img
}

/// OIDN, or `None` (with a note) where it is not installed and the run
/// does not require it.
fn oidn_or_skip(test: &str) -> Option<Denoiser> {
    match Denoiser::open(Quality::High) {
        Ok(d) => Some(d),
        Err(e) if std::env::var_os("SOUPRAY_REQUIRE_OIDN").is_some_and(|v| v == "1") => {
            panic!("SOUPRAY_REQUIRE_OIDN=1 but OIDN cannot be used: {e}")
        }
        Err(e) => {
            eprintln!("{test}: skipped, Open Image Denoise is not installed here ({e})");
            None
        }
    }
}

#[test]
fn denoise_without_oidn_fails_before_rendering_with_how_to_install_it() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("frames");
    let missing = dir.path().join("nowhere/libOpenImageDenoise.so.2");
    let Some(o) = render(
        &out,
        1,
        &["--denoise"],
        &[("SOUPRAY_OIDN", missing.to_str().unwrap())],
    ) else {
        return;
    };
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "stderr: {stderr}");
    assert!(
        stderr.contains("Open Image Denoise 2.x")
            && stderr.contains("was not found")
            && stderr.contains(missing.to_str().unwrap())
            && stderr.contains("./scripts/setup.sh")
            && stderr.contains("pip install --no-deps pyoidn")
            && stderr.contains("SOUPRAY_OIDN"),
        "{stderr}"
    );
    // Nothing was rendered or written.
    let written = std::fs::read_dir(&out).map(|d| d.count()).unwrap_or(0);
    assert_eq!(written, 0, "files were written");

    // A file that is not OIDN: refused as unusable, also exit code 3.
    let fake = dir.path().join("libOpenImageDenoise.so.2");
    std::fs::write(&fake, b"not a shared library").unwrap();
    let Some(o) = render(
        &out,
        1,
        &["--denoise"],
        &[("SOUPRAY_OIDN", fake.to_str().unwrap())],
    ) else {
        return;
    };
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(3), "stderr: {stderr}");
    assert!(
        stderr.contains("not a usable Open Image Denoise 2.x library")
            && stderr.contains(fake.to_str().unwrap())
            && stderr.contains("./scripts/setup.sh"),
        "{stderr}"
    );

    // Without --denoise the same environment renders as usual.
    let Some(o) = render(&out, 1, &[], &[("SOUPRAY_OIDN", missing.to_str().unwrap())]) else {
        return;
    };
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
}

#[test]
fn oidn_denoises_a_noisy_image_towards_the_clean_one() {
    let Some(oidn) = oidn_or_skip("oidn_denoises_a_noisy_image_towards_the_clean_one") else {
        return;
    };
    assert!(oidn.version().starts_with("2."), "{}", oidn.version());
    // A smooth gradient under strong per-pixel noise, with flat albedo and
    // normal: the filter must remove most of the noise.
    let (w, h) = (64u32, 48u32);
    let mut rng = common::Rng::new(7);
    let mut clean = Vec::new();
    let mut noisy = Vec::new();
    for y in 0..h {
        for x in 0..w {
            let v = 0.2 + 0.6 * x as f32 / w as f32 + 0.1 * y as f32 / h as f32;
            clean.push([v, 0.5 * v, 0.25]);
            // Mean-preserving noise: each channel is 0 or 2x its value.
            let mut px = [0.0f32; 3];
            for (c, p) in px.iter_mut().enumerate() {
                *p = if rng.f32() < 0.5 {
                    0.0
                } else {
                    2.0 * clean.last().unwrap()[c]
                };
            }
            noisy.push(px);
        }
    }
    let albedo = vec![[0.8f32, 0.8, 0.8]; clean.len()];
    let normal = vec![[0.0f32, 0.0, 1.0]; clean.len()];
    let (out, ms) = oidn.denoise(w, h, &noisy, &albedo, &normal).unwrap();
    assert!(ms > 0.0);
    let mse = |img: &[[f32; 3]]| {
        img.iter()
            .zip(&clean)
            .flat_map(|(a, b)| (0..3).map(move |c| (a[c] - b[c]).powi(2) as f64))
            .sum::<f64>()
            / (3 * clean.len()) as f64
    };
    let (before, after) = (mse(&noisy), mse(&out));
    assert!(
        after < 0.05 * before,
        "MSE {before:.5} before denoising, {after:.5} after"
    );
    // Mismatched sizes are an error, not a crash.
    assert!(oidn.denoise(w, h, &noisy[1..], &albedo, &normal).is_err());
}

#[test]
fn denoised_render_keeps_the_raw_beauty_and_beats_it_against_a_reference() {
    let test = "denoised_render_keeps_the_raw_beauty_and_beats_it_against_a_reference";
    let Some(oidn) = oidn_or_skip(test) else {
        return;
    };
    drop(oidn);
    let dir = tempfile::tempdir().unwrap();
    let (den, raw, reference) = (
        dir.path().join("den"),
        dir.path().join("raw"),
        dir.path().join("ref"),
    );
    for (out, spp, extra) in [
        (&den, 4, &["--denoise", "--aov", "albedo"][..]),
        (&raw, 4, &[][..]),
        (&reference, 512, &[][..]),
    ] {
        let Some(o) = render(out, spp, extra, &[]) else {
            return;
        };
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let exr = |d: &Path| common::exr_channels(&d.join("CesiumMan.0010.exr"));
    let (d, r, f) = (exr(&den), exr(&raw), exr(&reference));

    // Both images in one file: denoised in R, G, B; raw in noisy.*; the
    // AOV asked for (albedo) and not the normal the denoiser also used.
    let names: Vec<&str> = d.keys().map(String::as_str).collect();
    assert_eq!(
        names,
        ["A", "B", "G", "R", "albedo.B", "albedo.G", "albedo.R", "noisy.B", "noisy.G", "noisy.R"]
    );
    // The raw beauty is the frame rendered without --denoise, bit for bit.
    for c in ["R", "G", "B"] {
        assert_eq!(d[&format!("noisy.{c}")], r[c], "noisy.{c}");
    }
    assert_eq!(d["A"], r["A"]);
    assert_ne!(d["R"], r["R"], "R, G, B were not denoised");

    let (w, h) = (256, 144);
    let denoised = image_from(&d, ["R", "G", "B"], w, h);
    let noisy = image_from(&d, ["noisy.R", "noisy.G", "noisy.B"], w, h);
    let refimg = image_from(&f, ["R", "G", "B"], w, h);
    let e_den = compare::compare(&denoised, &refimg, 0.0).unwrap();
    let e_raw = compare::compare(&noisy, &refimg, 0.0).unwrap();
    eprintln!("against 512 spp: raw 4 spp {e_raw:?}, denoised {e_den:?}");
    // Measured: 0.40x (7.6e-4 against 1.9e-3). Mean FLIP is not asserted:
    // at this size the network's blur of the 20-pixel-wide character's
    // edges weighs about as much in FLIP as the raw noise (0.0061 against
    // 0.0057); BENCHMARKS.md compares FLIP at 640x360.
    assert!(
        e_den.rel_mse < 0.6 * e_raw.rel_mse,
        "relative MSE: denoised {} vs raw {}",
        e_den.rel_mse,
        e_raw.rel_mse
    );

    // The log records the library, its version and device, and the filter.
    let log: serde_json::Value =
        serde_json::from_slice(&std::fs::read(den.join("CesiumMan.0010.json")).unwrap()).unwrap();
    let dl = &log["denoise"];
    assert!(dl["version"].as_str().unwrap().starts_with("2."), "{dl}");
    assert!(
        ["cpu", "cuda", "hip", "sycl", "metal"].contains(&dl["device"].as_str().unwrap()),
        "{dl}"
    );
    assert_eq!(dl["filter"], "RT");
    assert_eq!(dl["hdr"], true);
    assert_eq!(dl["clean_aux"], true);
    assert_eq!(dl["aux"], serde_json::json!(["albedo", "normal"]));
    assert_eq!(dl["raw_layer"], "noisy");
    assert!(dl["library"].as_str().unwrap().contains("OpenImageDenoise"));
    assert!(log["timings_ms"]["denoise"].as_f64().unwrap() > 0.0);
    assert_eq!(log["output"]["aovs"], serde_json::json!(["albedo"]));
    // Without --denoise there is no denoise object.
    let plain: serde_json::Value =
        serde_json::from_slice(&std::fs::read(raw.join("CesiumMan.0010.json")).unwrap()).unwrap();
    assert!(plain.get("denoise").is_none());
}
