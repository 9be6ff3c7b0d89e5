//! The Khronos sample corpus (`../shared/khronos`, read in place): every
//! file renders its first frame with exit code 0 and the warnings it
//! deserves, and the files whose correct render is known by a visible mark
//! show it in real pixels. Skips with a message when the corpus is absent.
//!
//! `SOUPRAY_CONTACT_SHEET=FILE.png cargo test --release --test
//! corpus_conformance` also writes a contact sheet of the corpus (the one
//! in docs/images/khronos-corpus.png).

#[allow(clippy::duplicate_mod)]
mod common;
use common::shared;

use std::path::{Path, PathBuf};

const WIDTH: u32 = 96;
const HEIGHT: u32 = 72;

/// What a file must do.
enum Expect {
    /// Renders with exit 0 and no warning about its content.
    Clean,
    /// Renders with exit 0 and a warning containing this text.
    Warns(&'static str),
    /// Refused (exit 4) with a message containing this text: what soupray
    /// cannot read yet, named with its fix.
    Refused(&'static str),
}

/// Every file of the corpus and what it must do. A file not listed here
/// fails the test, so a new corpus file is never silently unchecked.
const CORPUS: &[(&str, Expect)] = &[
    ("AnimatedCube/glTF/AnimatedCube.gltf", Expect::Clean),
    (
        "AnimatedMorphCube/glTF-Binary/AnimatedMorphCube.glb",
        Expect::Clean,
    ),
    (
        "AnimatedMorphCube/glTF-Quantized/AnimatedMorphCube.gltf",
        Expect::Clean,
    ),
    ("AnimatedMorphSphere/AnimatedMorphSphere.glb", Expect::Clean),
    (
        "AnimatedMorphSphere/glTF-Binary/AnimatedMorphSphere.glb",
        Expect::Clean,
    ),
    ("AnimatedTriangle/glTF/AnimatedTriangle.gltf", Expect::Clean),
    (
        "AnisotropyBarnLamp/glTF-KTX2-Basisu/AnisotropyBarnLamp.gltf",
        Expect::Clean,
    ),
    ("BoxAnimated/glTF-Binary/BoxAnimated.glb", Expect::Clean),
    (
        "BoxVertexColors/glTF-Binary/BoxVertexColors.glb",
        Expect::Clean,
    ),
    ("BrainStem/BrainStem.glb", Expect::Clean),
    ("CesiumMan/glTF-Binary/CesiumMan.glb", Expect::Clean),
    ("CesiumMilkTruck/CesiumMilkTruck.glb", Expect::Clean),
    (
        "CesiumMilkTruck/glTF-Binary/CesiumMilkTruck.glb",
        Expect::Clean,
    ),
    ("Fox/glTF-Binary/Fox.glb", Expect::Clean),
    (
        "InterpolationTest/glTF-Binary/InterpolationTest.glb",
        Expect::Clean,
    ),
    (
        "IridescentDishWithOlives/glTF/IridescentDishWithOlives.gltf",
        Expect::Clean,
    ),
    (
        "MeshPrimitiveModes/glTF-Embedded/MeshPrimitiveModes.gltf",
        Expect::Warns("soupray traces triangles only"),
    ),
    ("Monster/Monster.glb", Expect::Clean),
    ("MorphPrimitivesTest/MorphPrimitivesTest.glb", Expect::Clean),
    (
        "MorphPrimitivesTest/glTF-Binary/MorphPrimitivesTest.glb",
        Expect::Clean,
    ),
    (
        "MorphStressTest/glTF-Binary/MorphStressTest.glb",
        Expect::Clean,
    ),
    ("MultiUVTest/glTF-Binary/MultiUVTest.glb", Expect::Clean),
    ("RecursiveSkeletons/RecursiveSkeletons.glb", Expect::Clean),
    (
        "RecursiveSkeletons/glTF-Binary/RecursiveSkeletons.glb",
        Expect::Clean,
    ),
    ("RiggedFigure/glTF-Binary/RiggedFigure.glb", Expect::Clean),
    ("RiggedSimple/glTF-Binary/RiggedSimple.glb", Expect::Clean),
    ("RiggedSimple/glTF-Draco/RiggedSimple.gltf", Expect::Clean),
    (
        "SimpleInstancing/glTF-Binary/SimpleInstancing.glb",
        Expect::Clean,
    ),
    ("SimpleMorph/glTF/SimpleMorph.gltf", Expect::Clean),
    ("SimpleSkin/glTF/SimpleSkin.gltf", Expect::Clean),
    (
        "SpecGlossVsMetalRough/glTF/SpecGlossVsMetalRough.gltf",
        Expect::Clean,
    ),
    (
        "StainedGlassLamp/glTF-KTX-BasisU/StainedGlassLamp.gltf",
        Expect::Clean,
    ),
    (
        "TextureTransformMultiTest/glTF-Binary/TextureTransformMultiTest.glb",
        Expect::Clean,
    ),
    (
        "VertexColorTest/glTF-Binary/VertexColorTest.glb",
        Expect::Clean,
    ),
    ("WaterBottle/glTF/WaterBottle.gltf", Expect::Clean),
    (
        "derived/AnimatedCube/glTF-AnimPointer-derived/AnimatedCube.gltf",
        Expect::Clean,
    ),
    (
        "derived/AnimatedCube/glTF-AnimPointer-derived/AnimatedCube_required.gltf",
        Expect::Clean,
    ),
    (
        "derived/AnimatedMorphCube/glTF-Meshopt-derived/AnimatedMorphCube.glb",
        Expect::Clean,
    ),
    (
        "derived/BoxTextured/glTF-AVIF-derived/BoxTextured.glb",
        Expect::Refused("EXT_texture_avif"),
    ),
    (
        "derived/BoxTextured/glTF-WEBP-derived/BoxTextured.glb",
        Expect::Clean,
    ),
    (
        "derived/CesiumMan/glTF-Meshopt-derived/CesiumMan.glb",
        Expect::Clean,
    ),
];

/// Warnings every render of a file without lights or sky carries; they
/// say how the frame is lit, not that the file is wrong.
const LIGHTING_NOTES: &[&str] = &["studio sky"];

fn corpus_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let mut entries: Vec<_> = std::fs::read_dir(dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    entries.sort();
    for p in entries {
        if p.is_dir() {
            corpus_files(&p, out);
        } else if matches!(p.extension().and_then(|e| e.to_str()), Some("gltf" | "glb")) {
            out.push(p);
        }
    }
}

struct Rendered {
    rel: String,
    png: PathBuf,
    warnings: Vec<String>,
}

/// Renders frame 0; `Err` holds the exit code and standard error.
fn render(file: &Path, rel: &str, out: &Path) -> Result<Rendered, (Option<i32>, String)> {
    let stem = rel.replace(['/', '.'], "_");
    let dir = out.join(&stem);
    // More samples for the contact sheet, which people look at.
    let spp = std::env::var("SOUPRAY_CONTACT_SPP").unwrap_or_else(|_| "4".into());
    let o = common::soupray_cmd()
        .args(["render", "--quiet", "--frame", "0", "--spp", &spp, "--png"])
        .args([
            "--width",
            &WIDTH.to_string(),
            "--height",
            &HEIGHT.to_string(),
        ])
        .arg("--out")
        .arg(&dir)
        .arg(file)
        .output()
        .unwrap();
    if !o.status.success() {
        return Err((
            o.status.code(),
            String::from_utf8_lossy(&o.stderr).into_owned(),
        ));
    }
    let mut pngs: Vec<PathBuf> = std::fs::read_dir(&dir)
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "png"))
        .collect();
    pngs.sort();
    let png = pngs
        .pop()
        .unwrap_or_else(|| panic!("{rel}: no PNG written"));
    let log: serde_json::Value =
        serde_json::from_slice(&std::fs::read(png.with_extension("json")).unwrap()).unwrap();
    let warnings = log["warnings"]
        .as_array()
        .unwrap()
        .iter()
        .map(|w| w.as_str().unwrap().to_owned())
        .collect();
    Ok(Rendered {
        rel: rel.to_owned(),
        png,
        warnings,
    })
}

fn rgb(png: &Path) -> image::RgbImage {
    image::open(png).unwrap().to_rgb8()
}

/// Pixels where one channel dominates (`which` 0, 1, 2 for R, G, B), and
/// where two do (the complement of `which`: cyan, magenta, yellow).
fn dominant(img: &image::RgbImage, which: usize) -> (usize, usize) {
    let mut primary = 0;
    let mut complement = 0;
    for p in img.pixels() {
        let c = [p[0] as i32, p[1] as i32, p[2] as i32];
        let others: Vec<i32> = (0..3).filter(|&k| k != which).map(|k| c[k]).collect();
        if c[which] > 100 && others.iter().all(|&o| o < c[which] / 3) {
            primary += 1;
        }
        if c[which] < 60 && others.iter().all(|&o| o > 120) {
            complement += 1;
        }
    }
    (primary, complement)
}

#[test]
fn every_corpus_file_renders_with_the_warnings_it_deserves() {
    let Some(root) = shared::shared("khronos") else {
        return;
    };
    let mut files = Vec::new();
    corpus_files(&root, &mut files);
    let out = tempfile::tempdir().unwrap();
    let mut failures = Vec::new();
    let mut rendered = Vec::new();
    let mut refused = 0;
    for file in &files {
        let rel = file
            .strip_prefix(&root)
            .unwrap()
            .to_string_lossy()
            .replace('\\', "/");
        let Some((_, expect)) = CORPUS.iter().find(|(r, _)| *r == rel) else {
            failures.push(format!(
                "{rel}: not in the test's table; add what it must do"
            ));
            continue;
        };
        match render(file, &rel, out.path()) {
            Err((code, stderr)) => match expect {
                Expect::Refused(what)
                    if code == Some(4) && stderr.contains(what) && stderr.contains("Fix:") =>
                {
                    refused += 1
                }
                _ => failures.push(format!("{rel}: exit {code:?}: {stderr}")),
            },
            Ok(r) => {
                let content: Vec<&String> = r
                    .warnings
                    .iter()
                    .filter(|w| !LIGHTING_NOTES.iter().any(|n| w.contains(n)))
                    .collect();
                match expect {
                    Expect::Refused(what) => failures.push(format!(
                        "{rel}: rendered, but the table expects it refused ({what})"
                    )),
                    Expect::Clean if !content.is_empty() => {
                        failures.push(format!("{rel}: unexpected warnings {content:?}"))
                    }
                    Expect::Warns(w) if !content.iter().any(|c| c.contains(w)) => {
                        failures.push(format!("{rel}: no warning containing {w:?} in {content:?}"))
                    }
                    _ => {}
                }
                rendered.push(r);
            }
        }
    }
    eprintln!(
        "rendered {} of {} corpus files; {refused} refused as the table expects",
        rendered.len(),
        files.len()
    );
    if let Some(sheet) = std::env::var_os("SOUPRAY_CONTACT_SHEET") {
        contact_sheet(&rendered, Path::new(&sheet));
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn vertex_color_test_shows_check_marks_not_crosses() {
    let Some(file) = shared::khronos("VertexColorTest/glTF-Binary/VertexColorTest.glb") else {
        return;
    };
    let out = tempfile::tempdir().unwrap();
    let r = render(&file, "VertexColorTest", out.path()).unwrap_or_else(|e| panic!("{e:?}"));
    let img = rgb(&r.png);
    // COLOR_0 ignored shows cyan, magenta and yellow crosses in the test
    // row; applied, red, green and blue check marks.
    for (k, name) in ["red", "green", "blue"].iter().enumerate() {
        let (primary, complement) = dominant(&img, k);
        assert!(
            primary > 10 && complement < primary / 10,
            "{name}: {primary} {name} pixels, {complement} of its complement"
        );
    }
}

#[test]
fn water_bottle_is_lit_by_the_default_sky() {
    let Some(file) = shared::khronos("WaterBottle/glTF/WaterBottle.gltf") else {
        return;
    };
    let out = tempfile::tempdir().unwrap();
    let r = render(&file, "WaterBottle", out.path()).unwrap_or_else(|e| panic!("{e:?}"));
    let img = rgb(&r.png);
    let mean = img
        .pixels()
        .map(|p| p[0] as f64 + p[1] as f64 + p[2] as f64)
        .sum::<f64>()
        / (3.0 * img.pixels().len() as f64);
    assert!(
        mean > 40.0,
        "mean 8-bit value {mean}: the bottle renders dark"
    );
    assert!(
        !r.warnings.iter().any(|w| w.contains("black")),
        "{:?}",
        r.warnings
    );
}

/// The rendered frames in a grid, each labelled with its model and
/// variant, written as a PNG.
fn contact_sheet(rendered: &[Rendered], path: &Path) {
    use plotters::prelude::*;
    let cols = 7u32;
    let label = 14u32;
    let rows = (rendered.len() as u32).div_ceil(cols);
    let (cw, ch) = (WIDTH * 2, HEIGHT * 2 + label * 2);
    let (w, h) = (cols * cw, rows * ch);
    let mut buf = vec![255u8; (w * h * 3) as usize];
    {
        let font = include_bytes!("../assets/fonts/DejaVuSansMono.ttf");
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, font);
        let root = BitMapBackend::with_buffer(&mut buf, (w, h)).into_drawing_area();
        for (i, r) in rendered.iter().enumerate() {
            let (x0, y0) = ((i as u32 % cols) * cw, (i as u32 / cols) * ch);
            let img = image::imageops::resize(
                &rgb(&r.png),
                WIDTH * 2,
                HEIGHT * 2,
                image::imageops::FilterType::Nearest,
            );
            for (x, y, p) in img.enumerate_pixels() {
                root.draw_pixel(
                    ((x0 + x) as i32, (y0 + y) as i32),
                    &RGBColor(p[0], p[1], p[2]),
                )
                .unwrap();
            }
            let parts: Vec<&str> = r.rel.split('/').collect();
            let (model, variant) = match parts.as_slice() {
                ["derived", m, v, ..] => (m.to_string(), v.to_string()),
                [m, v, _] => (m.to_string(), v.to_string()),
                [m, _] => (m.to_string(), String::new()),
                _ => (r.rel.clone(), String::new()),
            };
            let style = ("sans-serif", 11).into_font().color(&BLACK);
            let y = (y0 + HEIGHT * 2 + 1) as i32;
            root.draw_text(&model, &style, (x0 as i32 + 2, y)).unwrap();
            root.draw_text(&variant, &style, (x0 as i32 + 2, y + label as i32 - 1))
                .unwrap();
        }
        root.present().unwrap();
    }
    image::save_buffer(path, &buf, w, h, image::ColorType::Rgb8).unwrap();
    eprintln!("wrote the contact sheet {}", path.display());
}
