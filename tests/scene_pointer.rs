//! KHR_animation_pointer: pointer channels to node TRS equal the
//! `target.path` channels they rewrite (the Khronos AnimatedCube with its
//! rotation as a pointer), and generated scenes whose material, light,
//! camera and texture-transform pointers change the rendered frames as the
//! animation says. Renders run the real binary (`soupray render`), so the
//! per-frame material upload is what is tested.

mod common;

use std::path::{Path, PathBuf};

use common::scene::{shared, Builder};
use serde_json::{json, Value};
use soupray::scene::{LoadOptions, Projection, Scene};

fn load(path: &Path) -> Scene {
    Scene::load(path, &LoadOptions::default()).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn animated_cube_with_a_rotation_pointer_equals_the_original() {
    let Some(original) = shared::khronos("AnimatedCube/glTF/AnimatedCube.gltf") else {
        return;
    };
    let Some(used) =
        shared::khronos("derived/AnimatedCube/glTF-AnimPointer-derived/AnimatedCube.gltf")
    else {
        return;
    };
    let Some(required) =
        shared::khronos("derived/AnimatedCube/glTF-AnimPointer-derived/AnimatedCube_required.gltf")
    else {
        return;
    };
    let reference = load(&original);
    let (first, last) = reference.frame_range();
    assert!(last > 10, "the cube turns over {last} frames");
    for path in [used, required] {
        let scene = load(&path);
        assert!(
            scene.warnings().iter().all(|w| !w.contains("pointer")),
            "{}: {:?}",
            path.display(),
            scene.warnings()
        );
        assert_eq!(scene.frame_range(), (first, last), "{}", path.display());
        for frame in [first, 1, last / 4, last / 3, last / 2, last - 1, last] {
            let t = scene.time_of_frame(frame);
            let (a, b) = (reference.evaluate(t).unwrap(), scene.evaluate(t).unwrap());
            assert_eq!(a.soup.positions, b.soup.positions, "frame {frame}");
            assert_eq!(a.soup.normals, b.soup.normals, "frame {frame}");
            assert_eq!(a.soup.uvs, b.soup.uvs, "frame {frame}");
            assert_eq!(a.soup.material_ids, b.soup.material_ids, "frame {frame}");
        }
        // And it does turn: frame 0 and the middle differ.
        let (a, b) = (
            scene.evaluate(0.0).unwrap(),
            scene.evaluate(scene.time_of_frame(last / 3)).unwrap(),
        );
        assert_ne!(a.soup.positions, b.soup.positions);
    }
}

/// A 2x1 RGBA PNG: red on the left, green on the right.
fn red_green_png() -> Vec<u8> {
    common::scene::png(2, 1, &[255, 0, 0, 255, 0, 255, 0, 255])
}

/// A unit quad at z = 0 facing +Z (uvs 0..1 left to right), its material
/// `material`; a perspective camera at z = 3 (yfov 0.5, square); a point
/// light at z = 2 (intensity 10); and one animation: `pointer` from the
/// `values` (`width` floats per key) at times 0 and 1 s, LINEAR, plus any
/// `extra` pointer channels on the same keys.
fn quad_scene(
    dir: &Path,
    name: &str,
    material: Value,
    pointers: &[(&str, &[f32], usize)],
    with_texture: bool,
) -> PathBuf {
    let mut b = Builder::default();
    let positions = b.floats(
        &[
            -0.5, -0.5, 0.0, 0.5, -0.5, 0.0, 0.5, 0.5, 0.0, -0.5, 0.5, 0.0,
        ],
        3,
    );
    let normals = b.floats(&[0.0, 0.0, 1.0].repeat(4), 3);
    let uvs = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], 2);
    let indices = b.u16s(&[0, 1, 2, 0, 2, 3], 1, false);
    let times = b.floats(&[0.0, 1.0], 1);
    let mut samplers = Vec::new();
    let mut channels = Vec::new();
    for (i, (pointer, values, width)) in pointers.iter().enumerate() {
        let out = b.floats(values, *width);
        samplers.push(json!({"input": times, "output": out, "interpolation": "LINEAR"}));
        channels.push(json!({"sampler": i, "target": {"path": "pointer",
            "extensions": {"KHR_animation_pointer": {"pointer": pointer}}}}));
    }
    let mut root = json!({
        "extensionsUsed": ["KHR_animation_pointer", "KHR_lights_punctual", "KHR_materials_unlit", "KHR_texture_transform"],
        "extensionsRequired": ["KHR_animation_pointer"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2]}],
        "nodes": [
            {"mesh": 0},
            {"camera": 0, "translation": [0.0, 0.0, 3.0]},
            {"translation": [0.0, 0.0, 2.0], "extensions": {"KHR_lights_punctual": {"light": 0}}}
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": positions, "NORMAL": normals, "TEXCOORD_0": uvs},
                                    "indices": indices, "material": 0}]}],
        "materials": [material],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.5, "aspectRatio": 1.0, "znear": 0.1}}],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 10.0}]}},
        "animations": [{"samplers": samplers, "channels": channels}]
    });
    if pointers.is_empty() {
        root.as_object_mut().unwrap().remove("animations");
    }
    if with_texture {
        let png = b.view(&red_green_png());
        root["images"] = json!([{"bufferView": png, "mimeType": "image/png"}]);
        root["samplers"] = json!([{"magFilter": 9728, "minFilter": 9728}]);
        root["textures"] = json!([{"source": 0, "sampler": 0}]);
    }
    b.write(root, dir, name, true)
}

/// Renders `frames` of `scene` (32x32, `spp`, black environment) and reads
/// the images back in frame order.
fn render(scene: &Path, frames: &str, spp: u32) -> Vec<soupray::film::Image> {
    let out = scene.with_extension("out");
    let run = common::soupray_cmd()
        .args(["render", scene.to_str().unwrap(), "--frames", frames])
        .args(["--width", "32", "--height", "32", "--spp", &spp.to_string()])
        .args(["--env-color", "0,0,0", "--out", out.to_str().unwrap()])
        .output()
        .expect("run soupray");
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let mut exrs: Vec<PathBuf> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "exr"))
        .collect();
    exrs.sort();
    exrs.iter()
        .map(|p| soupray::output::read_exr_rgba(p).unwrap())
        .collect()
}

fn pixel(img: &soupray::film::Image, x: u32, y: u32) -> [f32; 4] {
    img.rgba[(y * img.width + x) as usize]
}

/// Mean RGB over the central 8x8 pixels (all on the quad).
fn centre(img: &soupray::film::Image) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    for y in 12..20 {
        for x in 12..20 {
            let p = pixel(img, x, y);
            for c in 0..3 {
                sum[c] += p[c] as f64 / 64.0;
            }
        }
    }
    sum
}

fn close(a: f64, b: f64, tol: f64, what: &str) {
    assert!((a - b).abs() <= tol, "{what}: {a} vs {b} (tolerance {tol})");
}

#[test]
fn base_color_factor_pointer_changes_the_rendered_colour() {
    let dir = tempfile::tempdir().unwrap();
    let path = quad_scene(
        dir.path(),
        "base_color",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0]},
               "extensions": {"KHR_materials_unlit": {}}}),
        &[(
            "/materials/0/pbrMetallicRoughness/baseColorFactor",
            &[1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0],
            4,
        )],
        false,
    );
    let scene = load(&path);
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    assert!(scene.has_material_animation());
    let at_half = scene.materials_at(0.5).unwrap();
    assert_eq!(at_half[0].base_color_factor, [0.5, 0.0, 0.5, 1.0]);
    assert!(Scene::materials_at(&load(&asset_without_pointers(dir.path())), 0.5).is_none());

    // Unlit: a pixel on the quad is its base colour, whatever the sampling.
    let frames = render(&path, "0,12,24", 2);
    for (img, want) in frames
        .iter()
        .zip([[1.0, 0.0, 0.0], [0.5, 0.0, 0.5], [0.0, 0.0, 1.0]])
    {
        let got = centre(img);
        for c in 0..3 {
            close(got[c], want[c], 1e-4, "unlit base colour");
        }
    }
}

/// A scene with no pointer channel at all (for the no-animation path).
fn asset_without_pointers(dir: &Path) -> PathBuf {
    quad_scene(
        dir,
        "still",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0]}}),
        &[],
        false,
    )
}

#[test]
fn light_intensity_pointer_scales_the_brightness() {
    let dir = tempfile::tempdir().unwrap();
    let path = quad_scene(
        dir.path(),
        "light",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}),
        &[(
            "/extensions/KHR_lights_punctual/lights/0/intensity",
            &[10.0, 40.0],
            1,
        )],
        false,
    );
    let scene = load(&path);
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    let lights = |t: f64| scene.frame_lights(&scene.pose(t));
    assert_eq!(lights(0.0)[0].intensity, 10.0);
    assert_eq!(lights(0.5)[0].intensity, 25.0);
    assert_eq!(lights(1.0)[0].intensity, 40.0);
    assert!(!scene.has_material_animation());

    // One flat quad under one point light: only direct light, which
    // next-event estimation computes without noise; what varies between
    // samples is where in the pixel they land (the filter), which the
    // 64-pixel mean averages. The brightness follows the intensity.
    let frames = render(&path, "0,12,24", 16);
    // Motion blur sees the change: a shutter over which the intensity
    // changes has motion steps, each with its own lights.
    let plan = soupray::soup::motion::motion_steps(&scene, 0.4, 0.6, None);
    assert!(plan.steps >= 2, "{plan:?}");
    let still = load(&asset_without_pointers(dir.path()));
    assert_eq!(
        soupray::soup::motion::motion_steps(&still, 0.4, 0.6, None).steps,
        1
    );

    let lum: Vec<f64> = frames.iter().map(|i| centre(i)[1]).collect();
    assert!(lum[0] > 0.1, "frame 0 is lit: {lum:?}");
    close(lum[1] / lum[0], 2.5, 0.025, "intensity 25 vs 10");
    close(lum[2] / lum[0], 4.0, 0.04, "intensity 40 vs 10");
}

/// Rows of the image's middle column that show the quad.
fn covered_rows(img: &soupray::film::Image) -> usize {
    (0..img.height)
        .filter(|&y| pixel(img, img.width / 2, y)[0] > 0.5)
        .count()
}

#[test]
fn camera_yfov_pointer_changes_the_projected_size() {
    let dir = tempfile::tempdir().unwrap();
    let path = quad_scene(
        dir.path(),
        "camera",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0]},
               "extensions": {"KHR_materials_unlit": {}}}),
        &[("/cameras/0/perspective/yfov", &[0.5, 1.0], 1)],
        false,
    );
    let scene = load(&path);
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    let yfov = |t: f64| match scene.frame_camera(&scene.pose(t)).unwrap().projection {
        Projection::Perspective { yfov, .. } => yfov,
        p => panic!("{p:?}"),
    };
    assert_eq!(yfov(0.0), 0.5);
    assert_eq!(yfov(0.5), 0.75);
    assert_eq!(yfov(1.0), 1.0);
    // Motion blur counts the zoom as motion.
    let plan = soupray::soup::motion::motion_steps(&scene, 0.4, 0.6, None);
    assert!(plan.steps >= 2, "{plan:?}");

    // The quad (height 1 at distance 3) covers (1/6) / tan(yfov/2) of the
    // image's height: 20.9 of 32 rows at yfov 0.5, 9.8 at yfov 1.
    let frames = render(&path, "0,24", 1);
    let rows: Vec<usize> = frames.iter().map(covered_rows).collect();
    let expect = |yfov: f64| 32.0 / 6.0 / (yfov / 2.0).tan();
    close(rows[0] as f64, expect(0.5), 1.0, "rows at yfov 0.5");
    close(rows[1] as f64, expect(1.0), 1.0, "rows at yfov 1");
}

#[test]
fn texture_transform_offset_pointer_moves_the_texture() {
    let dir = tempfile::tempdir().unwrap();
    let path = quad_scene(
        dir.path(),
        "offset",
        json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}},
               "extensions": {"KHR_materials_unlit": {}}}),
        &[(
            "/materials/0/pbrMetallicRoughness/baseColorTexture/extensions/KHR_texture_transform/offset",
            &[0.0, 0.0, 0.5, 0.0],
            2,
        )],
        true,
    );
    let scene = load(&path);
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    let offset = |t: f64| {
        scene.materials_at(t).unwrap()[0]
            .base_color_texture
            .as_ref()
            .unwrap()
            .transform
            .unwrap()
            .offset
    };
    assert_eq!(offset(0.0), [0.0, 0.0]);
    assert_eq!(offset(0.5), [0.25, 0.0]);
    assert_eq!(offset(1.0), [0.5, 0.0]);
    // The loaded material has no transform at all.
    assert!(scene.materials().materials[0]
        .base_color_texture
        .as_ref()
        .unwrap()
        .transform
        .is_none());

    // uv' = uv + (0.5, 0): the left of the quad (u = 0.25) samples u = 0.75,
    // the texture's green half, once the offset is 0.5.
    let frames = render(&path, "0,24", 2);
    let left = |img: &soupray::film::Image| pixel(img, 12, 16);
    let (a, b) = (left(&frames[0]), left(&frames[1]));
    assert!(a[0] > 0.9 && a[1] < 0.1, "frame 0 left is red: {a:?}");
    assert!(b[1] > 0.9 && b[0] < 0.1, "frame 24 left is green: {b:?}");
}

#[test]
fn unsupported_pointer_is_skipped_with_one_warning_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let path = quad_scene(
        dir.path(),
        "unsupported",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0]}}),
        &[
            ("/materials/0/extensions/EXT_unknown/factor", &[0.0, 1.0], 1),
            ("/materials/0/extensions/EXT_unknown/factor", &[0.0, 1.0], 1),
            ("/materials/0/extensions/EXT_unknown/factor", &[0.0, 1.0], 1),
            ("/nodes/0/translation", &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0], 3),
        ],
        false,
    );
    let scene = load(&path);
    let naming: Vec<&String> = scene
        .warnings()
        .iter()
        .filter(|w| w.contains("/materials/0/extensions/EXT_unknown/factor"))
        .collect();
    assert_eq!(naming.len(), 1, "{:?}", scene.warnings());
    assert!(
        naming[0].contains("3 channels") && naming[0].contains("not a property soupray animates"),
        "{}",
        naming[0]
    );
    assert_eq!(scene.warnings().len(), 1, "{:?}", scene.warnings());
    // The supported channel beside them still animates.
    let clip = scene.active_clip().unwrap();
    assert_eq!(clip.channels.len(), 1);
    assert!(clip.pointer_channels.is_empty());
    let a = scene.evaluate(0.0).unwrap();
    let b = scene.evaluate(1.0).unwrap();
    assert_eq!(b.soup.positions[0][0] - a.soup.positions[0][0], 1.0);
}

#[test]
fn mesh_weights_pointer_drives_the_nodes_that_take_them() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let positions = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let delta = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], 3);
    let times = b.floats(&[0.0, 1.0], 1);
    let weights = b.floats(&[0.0, 1.0], 1);
    let root = json!({
        "extensionsUsed": ["KHR_animation_pointer"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"mesh": 0, "weights": [0.0], "translation": [5.0, 0.0, 0.0]}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": positions}, "targets": [{"POSITION": delta}]}]}],
        "animations": [{"samplers": [{"input": times, "output": weights}],
                        "channels": [{"sampler": 0, "target": {"path": "pointer",
                            "extensions": {"KHR_animation_pointer": {"pointer": "/meshes/0/weights"}}}}]}]
    });
    let path = b.write(root, dir.path(), "weights", true);
    let scene = load(&path);
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    let pose = scene.pose(0.5);
    // Node 0 takes the mesh's weights; node 1 has its own.
    assert_eq!(pose.morph_weights[0], vec![0.5]);
    assert_eq!(pose.morph_weights[1], vec![0.0]);
}

#[test]
fn emissive_factor_pointer_lights_the_surface_from_black() {
    let dir = tempfile::tempdir().unwrap();
    // No light reaches the quad (the point light is off): what the camera
    // sees is the emission alone, 0 at rest and at frame 0, 2 at frame 24.
    let path = quad_scene(
        dir.path(),
        "emissive",
        json!({"pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0}}),
        &[
            (
                "/materials/0/emissiveFactor",
                &[0.0, 0.0, 0.0, 1.0, 0.5, 0.25],
                3,
            ),
            (
                "/materials/0/extensions/KHR_materials_emissive_strength/emissiveStrength",
                &[2.0, 2.0],
                1,
            ),
            (
                "/extensions/KHR_lights_punctual/lights/0/intensity",
                &[0.0, 0.0],
                1,
            ),
        ],
        false,
    );
    let scene = load(&path);
    assert!(scene.warnings().is_empty(), "{:?}", scene.warnings());
    let frames = render(&path, "0,24", 2);
    let (a, b) = (centre(&frames[0]), centre(&frames[1]));
    for v in a {
        close(v, 0.0, 1e-6, "frame 0 is black");
    }
    for (c, want) in [2.0, 1.0, 0.5].into_iter().enumerate() {
        close(
            b[c],
            want,
            2e-3 * want,
            "frame 24 emits emissiveFactor x strength",
        );
    }
}

#[test]
fn animated_layer_factors_compile_their_features_in() {
    let dir = tempfile::tempdir().unwrap();
    let material = json!({"pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.5, 0.5, 1.0]}});
    let animated = quad_scene(
        dir.path(),
        "coat",
        material.clone(),
        &[(
            "/materials/0/extensions/KHR_materials_clearcoat/clearcoatFactor",
            &[0.0, 1.0],
            1,
        )],
        false,
    );
    let still = quad_scene(dir.path(), "no_coat", material, &[], false);
    let d = common::device();
    let settings = soupray::trace::render::RenderSettings {
        width: 8,
        height: 8,
        spp: 1,
        ..Default::default()
    };
    let features = |path: &Path| {
        let scene = load(path);
        soupray::trace::render::PathTracer::new(&d, &scene, &settings)
            .unwrap()
            .material_features()
            .to_vec()
    };
    // At rest the material has no coat; at the clip's last key it has.
    let scene = load(&animated);
    assert_eq!(scene.materials().materials[0].clearcoat_factor, 0.0);
    assert_eq!(scene.materials_at(1.0).unwrap()[0].clearcoat_factor, 1.0);
    assert!(
        features(&animated).contains(&"clearcoat"),
        "{:?}",
        features(&animated)
    );
    assert!(
        !features(&still).contains(&"clearcoat"),
        "{:?}",
        features(&still)
    );
}
