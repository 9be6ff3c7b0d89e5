//! Textured emitters: next-event estimation chooses an emissive triangle by
//! its power, and an emissive texture's mean over the triangle is part of
//! that power. A lamp whose emissive texture is black over half its
//! triangles must then light the floor as a lamp of only the bright half
//! does: the same image in expectation, and about the same noise, since
//! hardly any light sample is spent on black triangles.

mod common;

use std::path::{Path, PathBuf};

use common::render::perspective;
use common::scene::Builder;
use glam::Vec3;
use serde_json::json;
use soupray::scene::{LoadOptions, Scene};
use soupray::trace::render::PathTracer;
use soupray::trace::settings::{Environment, RenderSettings};

/// A 2x1 RGBA PNG: white on the left, black on the right.
fn white_black_png() -> Vec<u8> {
    common::scene::png(2, 1, &[255, 255, 255, 255, 0, 0, 0, 255])
}

/// Positions, normals, uvs and indices of a grid of `nx` x `nz` cells over
/// x in [x0, x1] and z in [-0.5, 0.5] at height `y`, facing -y, with u
/// running from 0 at x = -1 to 1 at x = 1.
fn lamp_grid(
    x0: f32,
    x1: f32,
    nx: usize,
    nz: usize,
    y: f32,
) -> (Vec<f32>, Vec<f32>, Vec<f32>, Vec<u16>) {
    let (mut p, mut n, mut uv, mut idx) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
    for j in 0..=nz {
        for i in 0..=nx {
            let x = x0 + (x1 - x0) * i as f32 / nx as f32;
            let z = -0.5 + j as f32 / nz as f32;
            p.extend([x, y, z]);
            n.extend([0.0, -1.0, 0.0]);
            uv.extend([(x + 1.0) / 2.0, z + 0.5]);
        }
    }
    let at = |i: usize, j: usize| (j * (nx + 1) + i) as u16;
    for j in 0..nz {
        for i in 0..nx {
            // Counter-clockwise seen from below (-y).
            idx.extend([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            idx.extend([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    (p, n, uv, idx)
}

/// A grey floor under a lamp 1 above it, seen from a camera between them
/// looking straight down (so the camera never sees the lamp). `textured`:
/// the lamp spans x in [-1, 1], white where u < 0.5 and black beyond by its
/// emissive texture; otherwise it is only the white half, untextured.
fn lamp_scene(dir: &Path, textured: bool) -> PathBuf {
    lamp_scene_on(dir, textured, 2.0)
}

/// `lamp_scene` on a floor reaching `floor` from the lamp's centre in x
/// and z.
fn lamp_scene_on(dir: &Path, textured: bool, floor: f32) -> PathBuf {
    let mut b = Builder::default();
    let f = floor;
    let floor_p = b.floats(&[-f, 0.0, -f, -f, 0.0, f, f, 0.0, f, f, 0.0, -f], 3);
    let floor_n = b.floats(&[0.0, 1.0, 0.0].repeat(4), 3);
    let floor_i = b.u16s(&[0, 1, 2, 0, 2, 3], 1, false);
    let (p, n, uv, idx) = if textured {
        lamp_grid(-1.0, 1.0, 8, 4, 1.0)
    } else {
        lamp_grid(-1.0, 0.0, 4, 4, 1.0)
    };
    let lamp_p = b.floats(&p, 3);
    let lamp_n = b.floats(&n, 3);
    let lamp_uv = b.floats(&uv, 2);
    let lamp_i = b.u16s(&idx, 1, false);
    let lamp = json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0},
        "emissiveFactor": [1.0, 1.0, 1.0],
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}
    });
    let mut root = json!({
        "extensionsUsed": ["KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"mesh": 0},
            {"mesh": 1},
            // Between the lamp and the floor, looking down -y.
            {"camera": 0, "translation": [0.0, 0.9, 0.0],
             "rotation": [-std::f32::consts::FRAC_1_SQRT_2, 0.0, 0.0, std::f32::consts::FRAC_1_SQRT_2]}
        ],
        "meshes": [
            {"primitives": [{"attributes": {"POSITION": floor_p, "NORMAL": floor_n},
                             "indices": floor_i, "material": 0}]},
            {"primitives": [{"attributes": {"POSITION": lamp_p, "NORMAL": lamp_n, "TEXCOORD_0": lamp_uv},
                             "indices": lamp_i, "material": 1}]}
        ],
        "materials": [
            {"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}},
            lamp
        ],
        "cameras": [{"type": "orthographic", "orthographic": {"xmag": 1.5, "ymag": 1.5, "znear": 0.01, "zfar": 10.0}}]
    });
    if textured {
        root["materials"][1]["emissiveTexture"] = json!({"index": 0});
        let png = b.view(&white_black_png());
        root["images"] = json!([{"bufferView": png, "mimeType": "image/png"}]);
        root["samplers"] = json!([{"magFilter": 9728, "minFilter": 9728}]);
        root["textures"] = json!([{"source": 0, "sampler": 0}]);
    }
    let lamp = if textured { "textured" } else { "half" };
    b.write(root, dir, &format!("{lamp}-floor{floor}"), true)
}

/// The scene rendered at 48x48 and `spp` with `seed`, under a black sky,
/// with independent random samples: Sobol points stratify the choice of
/// triangle too, and how well depends on the order of the triangles, which
/// differs between the two lamps; independent samples measure the choice's
/// weights alone.
fn render(scene: &Path, seed: u32, spp: u32, light_tree: bool) -> soupray::film::Image {
    let tree = if light_tree {
        "--light-tree"
    } else {
        "--no-light-tree"
    };
    render_with(scene, seed, spp, tree).0
}

/// As `render`, with `tree` the light tree's flag (or "" for the default),
/// and the frame log's `render.light_selection`.
fn render_with(scene: &Path, seed: u32, spp: u32, tree: &str) -> (soupray::film::Image, String) {
    let (seed, spp) = (seed.to_string(), spp.to_string());
    let mut args = vec![
        "--frames",
        "0",
        "--spp",
        &spp,
        "--seed",
        &seed,
        "--env-color",
        "0,0,0",
        "--sampler",
        "random",
    ];
    if !tree.is_empty() {
        args.push(tree);
    }
    let exr = common::render_exr(
        scene,
        (48, 48),
        &scene.with_extension(format!("seed{seed}-tree{}", tree.trim_start_matches('-'))),
        "f.exr",
        &args,
    );
    let log: serde_json::Value =
        serde_json::from_slice(&std::fs::read(exr.with_extension("json")).unwrap()).unwrap();
    let selection = log["render"]["light_selection"]
        .as_str()
        .unwrap()
        .to_owned();
    (soupray::output::read_exr_rgba(&exr).unwrap(), selection)
}

fn mean(img: &soupray::film::Image) -> f64 {
    img.rgba.iter().map(|p| p[0] as f64).sum::<f64>() / img.rgba.len() as f64
}

/// The per-pixel variance of one render, relative to the squared mean,
/// from two renders with different seeds.
fn relative_variance(a: &soupray::film::Image, b: &soupray::film::Image) -> f64 {
    let m = 0.5 * (mean(a) + mean(b));
    let var = a
        .rgba
        .iter()
        .zip(&b.rgba)
        .map(|(p, q)| 0.5 * (p[0] as f64 - q[0] as f64).powi(2))
        .sum::<f64>()
        / a.rgba.len() as f64;
    var / (m * m)
}

#[test]
fn a_half_black_emissive_texture_lights_and_samples_as_its_bright_half() {
    let dir = tempfile::tempdir().unwrap();
    let textured = lamp_scene(dir.path(), true);
    let half = lamp_scene(dir.path(), false);
    let spp = 16;
    // The emitters chosen by power alone, which the texture weights: the
    // light tree's importance starts from the same power.
    let (t1, t2) = (
        render(&textured, 1, spp, false),
        render(&textured, 2, spp, false),
    );
    let (h1, h2) = (render(&half, 1, spp, false), render(&half, 2, spp, false));
    // The floor is lit, and the camera does not see the lamp itself.
    assert!(mean(&h1) > 0.05, "the floor is dark: {}", mean(&h1));
    // The same light in expectation: 2 x 2304 pixels of 16 samples each put
    // the means' noise well under 1%.
    let (mt, mh) = (mean(&t1) + mean(&t2), mean(&h1) + mean(&h2));
    assert!(
        (mt / mh - 1.0).abs() < 0.01,
        "textured lamp {mt} against its bright half {mh}"
    );
    // About the same noise (measured 1.07x): choosing triangles by area
    // alone spends half the light samples on black ones (measured 6.5x).
    let (vt, vh) = (relative_variance(&t1, &t2), relative_variance(&h1, &h2));
    assert!(
        vt < 1.15 * vh,
        "textured lamp's relative variance {vt} against its bright half's {vh}"
    );
    // Through the light tree, each floor point draws mostly the bright
    // triangles near it: the same mean, far less noise (measured 5.6x).
    let (tt1, tt2) = (
        render(&textured, 1, spp, true),
        render(&textured, 2, spp, true),
    );
    let mtt = mean(&tt1) + mean(&tt2);
    assert!(
        (mtt / mh - 1.0).abs() < 0.01,
        "textured lamp through the tree {mtt} against its bright half {mh}"
    );
    let vtt = relative_variance(&tt1, &tt2);
    assert!(
        vtt < 0.5 * vt,
        "relative variance through the tree {vtt}, by power {vt}"
    );
}

/// By default the light tree holds the emitters where they spread over the
/// scene (the lamp over its own floor: 0.39 of the scene's diagonal) and
/// not where they gather in a small part of it (the same lamp over a floor
/// 20 times as wide: 0.04), where choosing by power costs less per sample;
/// `--light-tree` and `--no-light-tree` choose either anywhere. The image
/// is the one the chosen selection renders, bit for bit.
#[test]
fn the_light_tree_holds_emitters_by_default_where_they_spread() {
    let dir = tempfile::tempdir().unwrap();
    let near = lamp_scene(dir.path(), true);
    let wide = lamp_scene_on(dir.path(), true, 40.0);
    let (auto, selection) = render_with(&near, 1, 4, "");
    assert_eq!(selection, "tree");
    let (tree, selection) = render_with(&near, 1, 4, "--light-tree");
    assert_eq!(selection, "tree");
    assert!(auto.rgba == tree.rgba, "auto and --light-tree differ");
    let (auto, selection) = render_with(&wide, 1, 4, "");
    assert_eq!(selection, "power");
    let (power, selection) = render_with(&wide, 1, 4, "--no-light-tree");
    assert_eq!(selection, "power");
    assert!(auto.rgba == power.rgba, "auto and --no-light-tree differ");
    let (tree, selection) = render_with(&wide, 1, 4, "--light-tree");
    assert_eq!(selection, "tree");
    assert!(tree.rgba != power.rgba, "the tree changed nothing");
    // Both light the floor under the lamp alike on average.
    let (mp, mt) = (mean(&power), mean(&tree));
    assert!(mp > 0.05, "the floor is dark: {mp}");
    assert!(
        (mt / mp - 1.0).abs() < 0.05,
        "through the tree {mt}, by power {mp}"
    );
}

#[test]
fn texture_factors_are_kept_while_their_inputs_stay_and_frames_stay_exact() {
    let dir = tempfile::tempdir().unwrap();
    let scene = Scene::load(&lamp_scene(dir.path(), true), &LoadOptions::default()).unwrap();
    let table = scene.materials();
    let d = common::device();
    let settings = RenderSettings {
        width: 24,
        height: 24,
        spp: 4,
        environment: Environment::Color([0.0; 3]),
        ..RenderSettings::default()
    };
    let camera = perspective(Vec3::new(0.0, 0.5, 2.5), Vec3::ZERO, Vec3::Y, 50.0);
    let still = scene.evaluate(0.0).unwrap().soup;
    // The lamp moved: new positions, the same uvs and materials.
    let mut moved = still.clone();
    for p in &mut moved.positions {
        if p[1] > 0.5 {
            p[0] += 0.25;
        }
    }
    // The uvs changed: the lamp's texture slides.
    let mut slid = moved.clone();
    for uv in &mut slid.uvs {
        uv[0] += 0.125;
    }
    let mut pt = PathTracer::with_materials(&d, table, &settings).unwrap();
    let mut images = Vec::new();
    for (frame, soup) in [&still, &moved, &slid].into_iter().enumerate() {
        let out = pt.render_soup(soup, &camera, &[], frame as i64).unwrap();
        images.push(out.image);
    }
    // Computed for the first frame and for the slid uvs; kept for the move.
    assert_eq!(pt.emitter_texture_factor_frames(), (2, 1));
    // Each frame as it would be rendered alone, bit for bit.
    for (frame, soup) in [&moved, &slid].into_iter().enumerate() {
        let frame = frame + 1;
        let mut alone = PathTracer::with_materials(&d, table, &settings).unwrap();
        let out = alone.render_soup(soup, &camera, &[], frame as i64).unwrap();
        let bits = |i: &soupray::film::Image| -> Vec<u32> {
            i.rgba.iter().flatten().map(|v| v.to_bits()).collect()
        };
        assert_eq!(bits(&out.image), bits(&images[frame]), "frame {frame}");
        assert_eq!(alone.emitter_texture_factor_frames(), (1, 0));
    }
    assert!(images[1].rgba.iter().any(|p| p[0] > 0.0), "a black frame");
}
