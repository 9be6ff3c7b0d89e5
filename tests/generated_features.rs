//! The project's own feature scenes (`scripts/make-features.py`): each file
//! is generated here, loaded, and checked against what the glTF
//! specification says it holds, so a clone without the shared folder still
//! tests skins with an inverse-bind hierarchy, sparse morph targets, every
//! interpolation on every path, both camera kinds, every light kind,
//! textures with transforms and a second uv set, and each material
//! extension; and every one renders with exit 0 and no warning.

mod common;

use std::path::PathBuf;
use std::process::Command;

use common::scene::{assert_soup_matches, load, Raw};
use soupray::scene::{LightKind, LoadOptions, Projection, Scene};

/// Every file the generator writes, without its `.gltf`.
const SCENES: [&str; 6] = [
    "skin_chain",
    "morph_sparse",
    "interpolation",
    "cameras_lights",
    "texture_transform",
    "materials",
];

/// Runs the generator into a temporary directory.
fn generate() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    let script = common::repo_file("scripts/make-features.py");
    let out = Command::new("python3")
        .arg(&script)
        .arg(dir.path())
        .output()
        .expect("python3 runs scripts/make-features.py (install Python 3)");
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let path = dir.path().to_path_buf();
    (dir, path)
}

#[test]
fn the_generator_is_deterministic() {
    let (_a, one) = generate();
    let (_b, two) = generate();
    for name in SCENES {
        let f = format!("{name}.gltf");
        assert_eq!(
            std::fs::read(one.join(&f)).unwrap(),
            std::fs::read(two.join(&f)).unwrap(),
            "{f}"
        );
    }
}

#[test]
fn skins_morphs_and_interpolation_match_the_independent_reference() {
    let (_dir, out) = generate();
    // (The reference reads dense accessors only; the sparse target has its
    // own analytic test below.)
    for name in ["skin_chain", "interpolation"] {
        let path = out.join(format!("{name}.gltf"));
        let scene = load(&path, None);
        let raw = Raw::open(&path);
        for t in [0.0, 0.25, 0.5, 0.75, 1.0] {
            let soup = scene.evaluate(t).unwrap().soup;
            assert_soup_matches(
                &soup,
                &raw.soup(Some(0), t),
                1e-5,
                &format!("{name} at t = {t}"),
            );
        }
    }
}

#[test]
fn a_sparse_morph_target_moves_only_its_vertices() {
    let (_dir, out) = generate();
    let scene = load(&out.join("morph_sparse.gltf"), None);
    // At t = 1 the weights are (1, 0.5): the sparse target moves vertices
    // 1 and 2 by (0, 0, 0.5) and (0.25, 0, 0.5), the dense one all four by
    // 0.5 x (0, 0, -0.2).
    let soup = scene.evaluate(1.0).unwrap().soup;
    let corner = |t: usize, k: usize| {
        let p = soup.positions[3 * t + k];
        [p[0], p[1], p[2]]
    };
    // Triangles (0, 1, 2) and (0, 2, 3).
    assert_eq!(corner(0, 0), [-1.0, -1.0, -0.1]);
    assert_eq!(corner(0, 1), [1.0, -1.0, 0.4]);
    assert_eq!(corner(0, 2), [1.25, 1.0, 0.4]);
    assert_eq!(corner(1, 2), [-1.0, 1.0, -0.1]);
}

#[test]
fn step_linear_and_cubicspline_sample_as_the_specification_says() {
    let (_dir, out) = generate();
    let scene = load(&out.join("interpolation.gltf"), None);
    // Box i's translation goes from (i - 1, 0, 0) to (i - 1, 1, 0) over
    // 1 s; at t = 0.5 STEP holds the first key, LINEAR is halfway, and the
    // cubic Hermite spline with out-tangent 3 at the first key and 0 at the
    // second gives p0 h00 + m0 h10 + p1 h01 = 0.5 + 3 x 0.125 = 0.875.
    let pose = scene.pose(0.5);
    let y = |node: usize| pose.world_from_node[node].w_axis.y;
    let boxes: Vec<usize> = (0..3).map(|i| 2 * i).collect();
    assert_eq!(y(boxes[0]), 0.0, "STEP");
    assert!((y(boxes[1]) - 0.5).abs() < 1e-6, "LINEAR: {}", y(boxes[1]));
    assert!(
        (y(boxes[2]) - 0.875).abs() < 1e-6,
        "CUBICSPLINE: {}",
        y(boxes[2])
    );
    // Morph weights the same way: 0, 0.5 and 0.5 + 2 x 0.125 = 0.75.
    let w = |node: usize| pose.morph_weights[node][0];
    assert_eq!(w(1), 0.0, "STEP weight");
    assert!((w(3) - 0.5).abs() < 1e-6, "LINEAR weight {}", w(3));
    assert!((w(5) - 0.75).abs() < 1e-6, "CUBICSPLINE weight {}", w(5));
}

#[test]
fn both_camera_kinds_and_every_light_kind_load() {
    let (_dir, out) = generate();
    let path = out.join("cameras_lights.gltf");
    let scene = load(&path, None);
    let kinds: Vec<bool> = scene
        .cameras()
        .iter()
        .map(|c| matches!(c.projection, Projection::Perspective { .. }))
        .collect();
    assert_eq!(kinds, [true, false]);
    let ortho = Scene::load(
        &path,
        &LoadOptions {
            camera: Some("orthographic".into()),
            ..Default::default()
        },
    )
    .unwrap();
    let cam = ortho.evaluate(0.0).unwrap().camera;
    assert!(
        matches!(cam.projection, Projection::Orthographic { .. }),
        "{cam:?}"
    );
    let lights = scene.evaluate(0.0).unwrap().lights;
    let kinds: Vec<LightKind> = lights.iter().map(|l| l.kind).collect();
    assert_eq!(kinds.len(), 3);
    assert!(kinds.contains(&LightKind::Directional) && kinds.contains(&LightKind::Point));
    assert!(
        kinds.iter().any(|k| matches!(k, LightKind::Spot { .. })),
        "{kinds:?}"
    );
    // The spot points down (its node turns -Z to -Y).
    let spot = lights
        .iter()
        .find(|l| l.name.as_deref() == Some("spot"))
        .unwrap();
    assert!(
        (spot.direction.y + 1.0).abs() < 1e-5,
        "{:?}",
        spot.direction
    );
}

#[test]
fn a_texture_transform_reads_the_second_uv_set() {
    let (_dir, out) = generate();
    let scene = load(&out.join("texture_transform.gltf"), None);
    let m = &scene.materials().materials[0];
    let t = m.base_color_texture.as_ref().unwrap();
    assert_eq!(t.tex_coord, 1, "the transform's texCoord override");
    let x = t.transform.as_ref().unwrap();
    assert_eq!(
        (x.offset, x.rotation, x.scale),
        ([0.25, 0.5], 0.3, [2.0, 3.0])
    );
    assert_eq!(scene.second_uv_set(), Some(1));
    assert!(scene.has_uvs1());
}

#[test]
fn each_material_extension_is_read() {
    let (_dir, out) = generate();
    let scene = load(&out.join("materials.gltf"), None);
    let by_name = |n: &str| {
        scene
            .materials()
            .materials
            .iter()
            .find(|m| m.name.as_deref() == Some(n))
            .unwrap_or_else(|| panic!("no material {n}"))
            .clone()
    };
    assert_eq!(by_name("KHR_materials_clearcoat").clearcoat_factor, 1.0);
    assert_eq!(by_name("KHR_materials_sheen").sheen_color, [0.9, 0.3, 0.6]);
    let glass = by_name("KHR_materials_transmission");
    assert_eq!(
        (glass.transmission_factor, glass.ior, glass.thickness_factor),
        (1.0, 1.6, 0.5)
    );
    assert_eq!(
        by_name("KHR_materials_specular").specular_color,
        [1.0, 0.6, 0.3]
    );
    assert_eq!(by_name("KHR_materials_iridescence").iridescence_ior, 1.3);
    assert_eq!(by_name("KHR_materials_anisotropy").anisotropy_strength, 0.8);
    assert_eq!(by_name("KHR_materials_dispersion").dispersion, 2.0);
    assert_eq!(
        by_name("KHR_materials_emissive_strength").emissive_strength,
        4.0
    );
    assert!(by_name("KHR_materials_unlit").unlit);
    assert_eq!(
        by_name("KHR_materials_diffuse_transmission").diffuse_transmission,
        0.7
    );
    assert_eq!(
        by_name("KHR_materials_diffuse_roughness").diffuse_roughness,
        0.9
    );
}

#[test]
fn every_feature_scene_renders_cleanly() {
    let (_dir, out) = generate();
    let render_dir = tempfile::tempdir().unwrap();
    for name in SCENES {
        let o = common::soupray_cmd()
            .args([
                "render", "--quiet", "--frame", "6", "--spp", "4", "--width", "48", "--height",
                "32",
            ])
            .arg("--out")
            .arg(render_dir.path().join(name))
            .arg(out.join(format!("{name}.gltf")))
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "{name}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        let log: serde_json::Value = serde_json::from_slice(
            &std::fs::read(
                render_dir
                    .path()
                    .join(name)
                    .join(format!("{name}.0006.json")),
            )
            .unwrap(),
        )
        .unwrap();
        let warnings: Vec<&str> = log["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .filter_map(|w| w.as_str())
            .filter(|w| !w.contains("studio sky"))
            .collect();
        assert!(warnings.is_empty(), "{name}: {warnings:?}");
    }
}
