//! Golden-image tests: small renders of real and generated scenes with a
//! fixed seed and spp, compared with reference EXRs in `tests/golden/`.
//!
//! Comparison: relative MSE of the linear image and mean FLIP of the
//! tonemapped image (`soupray::compare`). On the device that made the
//! references the images are identical bit for bit; the thresholds allow
//! another device (a GPU driver) to land within the Monte Carlo noise. They
//! are measured, not guessed: `SOUPRAY_UPDATE_GOLDEN=1 cargo test --test
//! golden` renders each case with two seeds, and stores twice the
//! seed-to-seed difference (the noise at that spp) as the case's thresholds
//! in `tests/golden/thresholds.json`, beside the new references.
//!
//! A failing case writes the test image, the reference and a FLIP error map
//! as PNGs under `out/golden/`.

mod common;

use common::scene::Builder;
use serde_json::json;
use soupray::film::Image;
use std::path::{Path, PathBuf};

const WIDTH: u32 = 96;
const HEIGHT: u32 = 54;
const SEED: u64 = 7;

/// The constant white sky of radiance 1 the sample assets' references were
/// rendered under (they bring no light of their own); named, since the
/// default for such files is now the studio sky.
const WHITE_SKY: &[&str] = &["--env-color", "1,1,1"];

fn golden_dir() -> PathBuf {
    common::repo().join("tests/golden")
}

fn updating() -> bool {
    std::env::var("SOUPRAY_UPDATE_GOLDEN").is_ok_and(|v| v == "1")
}

/// Renders one frame through the real binary and reads it back.
fn render(scene: &Path, frame: i64, spp: u32, seed: u64, extra: &[&str]) -> Image {
    let dir = tempfile::tempdir().unwrap();
    let out = common::soupray_cmd()
        .arg("render")
        .arg(scene)
        .args(["--frame", &frame.to_string()])
        .args([
            "--width",
            &WIDTH.to_string(),
            "--height",
            &HEIGHT.to_string(),
        ])
        .args([
            "--spp",
            &spp.to_string(),
            "--seed",
            &seed.to_string(),
            "--quiet",
        ])
        .args([
            "--out",
            dir.path().to_str().unwrap(),
            "--name",
            "golden.####.exr",
        ])
        .args(extra)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}: {}",
        scene.display(),
        String::from_utf8_lossy(&out.stderr)
    );
    common::read_exr(&dir.path().join(format!("golden.{frame:04}.exr")))
}

/// Writes a reference. Chunks are compressed one after the other: the
/// parallel writer stores them in the order its threads finish, so an
/// unchanged image would come out as different bytes.
fn write_exr(path: &Path, img: &Image) {
    use exr::prelude::{SpecificChannels, Vec2, WritableImage};
    let w = img.width as usize;
    let pixels = SpecificChannels::rgba(|Vec2(x, y): Vec2<usize>| {
        let p = img.rgba[y * w + x];
        (p[0], p[1], p[2], p[3])
    });
    exr::prelude::Image::from_channels((w, img.height as usize), pixels)
        .write()
        .non_parallel()
        .to_file(path)
        .unwrap();
}

fn write_png(path: &Path, rgb: &[u8], img: &Image) {
    image::save_buffer(
        path,
        rgb,
        img.width,
        img.height,
        image::ExtendedColorType::Rgb8,
    )
    .unwrap();
}

/// Thresholds of one case, with the noise they were derived from.
#[derive(serde::Serialize, serde::Deserialize, Clone, Copy, Debug)]
struct Threshold {
    noise_rel_mse: f64,
    noise_flip: f64,
    rel_mse: f64,
    flip: f64,
}

fn thresholds() -> serde_json::Map<String, serde_json::Value> {
    std::fs::read(golden_dir().join("thresholds.json"))
        .ok()
        .and_then(|b| serde_json::from_slice(&b).ok())
        .unwrap_or_default()
}

fn check(name: &str, scene: &Path, frame: i64, spp: u32, extra: &[&str]) {
    let image = render(scene, frame, spp, SEED, extra);
    let reference_path = golden_dir().join(format!("{name}.exr"));
    if updating() {
        std::fs::create_dir_all(golden_dir()).unwrap();
        write_exr(&reference_path, &image);
        let other = render(scene, frame, spp, SEED + 1, extra);
        let noise = soupray::compare::compare(&other, &image, 0.0).unwrap();
        let t = Threshold {
            noise_rel_mse: noise.rel_mse,
            noise_flip: noise.flip,
            rel_mse: 2.0 * noise.rel_mse + 1e-6,
            flip: 2.0 * noise.flip + 1e-4,
        };
        // Cases run in parallel: merge into the file under a lock.
        static LOCK: std::sync::Mutex<()> = std::sync::Mutex::new(());
        let _guard = LOCK.lock().unwrap();
        let mut all = thresholds();
        all.insert(name.to_string(), serde_json::to_value(t).unwrap());
        let mut sorted: Vec<_> = all.into_iter().collect();
        sorted.sort_by(|a, b| a.0.cmp(&b.0));
        let map: serde_json::Map<_, _> = sorted.into_iter().collect();
        std::fs::write(
            golden_dir().join("thresholds.json"),
            serde_json::to_string_pretty(&map).unwrap() + "\n",
        )
        .unwrap();
        return;
    }
    assert!(
        reference_path.is_file(),
        "{name}: no reference {}; create the references with SOUPRAY_UPDATE_GOLDEN=1 cargo test --test golden",
        reference_path.display()
    );
    let reference = common::read_exr(&reference_path);
    let t: Threshold = serde_json::from_value(
        thresholds()
            .get(name)
            .cloned()
            .unwrap_or_else(|| panic!("{name}: no thresholds in tests/golden/thresholds.json")),
    )
    .unwrap();
    let err = soupray::compare::compare(&image, &reference, 0.0).unwrap();
    if err.rel_mse > t.rel_mse || err.flip > t.flip {
        let out = common::repo().join("out/golden");
        std::fs::create_dir_all(&out).unwrap();
        write_png(
            &out.join(format!("{name}.test.png")),
            &soupray::output::tonemap_srgb8(&image, 0.0),
            &image,
        );
        write_png(
            &out.join(format!("{name}.reference.png")),
            &soupray::output::tonemap_srgb8(&reference, 0.0),
            &image,
        );
        write_png(
            &out.join(format!("{name}.flip.png")),
            &soupray::compare::flip_map_rgb8(&image, &reference, 0.0).unwrap(),
            &image,
        );
        panic!(
            "{name}: differs from its reference: relative MSE {:.3e} (threshold {:.3e}), FLIP {:.4} \
             (threshold {:.4}); images and the error map are in {}",
            err.rel_mse,
            t.rel_mse,
            err.flip,
            t.flip,
            out.display()
        );
    }
}

/// A mesh's positions, normals, indices and TEXCOORD_0.
type Geometry = (Vec<f32>, Vec<f32>, Vec<u32>, Vec<f32>);

/// A UV sphere of `segments` around, centred at `c` with radius `r`; u
/// runs around it, v from top to bottom.
fn sphere(c: [f32; 3], r: f32, segments: usize) -> Geometry {
    let s = common::geometry::uv_sphere(c, r, segments as u32);
    (
        s.positions.concat(),
        s.normals.concat(),
        s.indices,
        s.uvs.concat(),
    )
}

/// A horizontal square of half-size `h` at height `y`, facing up.
fn plane(y: f32, h: f32) -> Geometry {
    (
        vec![-h, y, -h, -h, y, h, h, y, h, h, y, -h],
        [0.0, 1.0, 0.0].repeat(4),
        vec![0, 1, 2, 0, 2, 3],
        vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0, 1.0, 0.0],
    )
}

struct MeshSpec {
    geometry: Geometry,
    material: serde_json::Value,
}

/// A glTF with the given meshes (one node each), a camera looking at the
/// origin from `eye`, and optional KHR_lights_punctual lights.
fn scene_file(
    dir: &Path,
    name: &str,
    meshes: Vec<MeshSpec>,
    eye: [f32; 3],
    lights: Vec<(serde_json::Value, serde_json::Value)>,
) -> PathBuf {
    let mut b = Builder::default();
    let mut gl_meshes = Vec::new();
    let mut materials = Vec::new();
    let mut nodes = Vec::new();
    for (i, m) in meshes.into_iter().enumerate() {
        let (pos, nrm, idx, uv) = m.geometry;
        let p = b.floats(&pos, 3);
        let n = b.floats(&nrm, 3);
        let ix = b.u32s(&idx);
        let mut attributes = json!({"POSITION": p, "NORMAL": n});
        // Texture coordinates only where a material reads them (the
        // anisotropy's tangent frame), so the other scenes stay as their
        // goldens were made.
        if m.material.to_string().contains("KHR_materials_anisotropy") {
            attributes["TEXCOORD_0"] = json!(b.floats(&uv, 2));
        }
        materials.push(m.material);
        gl_meshes.push(
            json!({"primitives": [{"attributes": attributes, "indices": ix, "material": i}]}),
        );
        nodes.push(json!({"mesh": i}));
    }
    // Camera at `eye` looking at the origin (+Y up): rotation about Y then X.
    let d = [-eye[0], -eye[1], -eye[2]];
    let yaw = (-d[0]).atan2(-d[2]);
    let pitch = (d[1] / (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()).asin();
    let (qy, qx) = (
        [0.0, (yaw / 2.0).sin(), 0.0, (yaw / 2.0).cos()],
        [(pitch / 2.0).sin(), 0.0, 0.0, (pitch / 2.0).cos()],
    );
    let q = [
        qy[3] * qx[0] + qy[0] * qx[3] + qy[1] * qx[2] - qy[2] * qx[1],
        qy[3] * qx[1] - qy[0] * qx[2] + qy[1] * qx[3] + qy[2] * qx[0],
        qy[3] * qx[2] + qy[0] * qx[1] - qy[1] * qx[0] + qy[2] * qx[3],
        qy[3] * qx[3] - qy[0] * qx[0] - qy[1] * qx[1] - qy[2] * qx[2],
    ];
    nodes.push(json!({"camera": 0, "translation": eye, "rotation": q}));
    let mut root = json!({
        "scene": 0,
        "meshes": gl_meshes,
        "materials": materials,
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.7, "znear": 0.01, "aspectRatio": WIDTH as f32 / HEIGHT as f32}}],
    });
    if !lights.is_empty() {
        let mut defs = Vec::new();
        for (i, (def, mut node)) in lights.into_iter().enumerate() {
            defs.push(def);
            node["extensions"] = json!({"KHR_lights_punctual": {"light": i}});
            nodes.push(node);
        }
        root["extensionsUsed"] = json!(["KHR_lights_punctual"]);
        root["extensions"] = json!({"KHR_lights_punctual": {"lights": defs}});
    }
    let all: Vec<usize> = (0..nodes.len()).collect();
    root["nodes"] = json!(nodes);
    root["scenes"] = json!([{"nodes": all}]);
    b.write(root, dir, name, true)
}

fn diffuse(rgb: [f32; 3]) -> serde_json::Value {
    json!({"pbrMetallicRoughness": {"baseColorFactor": [rgb[0], rgb[1], rgb[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}})
}

/// The shipped animation (generated by scripts/make-walker.py, so it needs
/// no shared folder): a skinned, textured figure under its own sun and sky,
/// sharp at two frames and motion blurred.
#[test]
fn shipped_walker_sharp_and_blurred() {
    let scene = common::repo().join("animations/walker/walker.glb");
    check("walker_f0", &scene, 0, 64, &[]);
    check("walker_f24", &scene, 24, 64, &[]);
    check("walker_f24_blur", &scene, 24, 64, &["--motion-blur"]);
}

#[test]
fn textured_skinned_character_at_two_frames() {
    let Some(scene) = common::shared::cesium_man() else {
        return;
    };
    check("cesiumman_f0", &scene, 0, 64, WHITE_SKY);
    check("cesiumman_f30", &scene, 30, 64, WHITE_SKY);
}

/// Motion blur (`--motion-blur`, the default half-frame shutter on the
/// walk; a whole-frame shutter on the fox's run), beside the sharp frames
/// above.
#[test]
fn motion_blurred_character_and_fox() {
    let Some([scene, fox]) = common::shared::shared_all([
        "assets/CesiumMan/glTF-Binary/CesiumMan.glb",
        "assets/Fox/glTF-Binary/Fox.glb",
    ]) else {
        return;
    };
    check(
        "cesiumman_f30_blur",
        &scene,
        30,
        64,
        &["--motion-blur", "--env-color", "1,1,1"],
    );
    check(
        "fox_run_f8_blur",
        &fox,
        8,
        64,
        &[
            "--animation",
            "2",
            "--motion-blur",
            "--shutter",
            "1",
            "--env-color",
            "1,1,1",
        ],
    );
}

#[test]
fn skinned_fox_running() {
    let Some(fox) = common::shared::sample("Fox/Fox.glb") else {
        return;
    };
    check(
        "fox_run_f8",
        &fox,
        8,
        64,
        &["--animation", "2", "--env-color", "1,1,1"],
    );
}

#[test]
fn morph_target_animation() {
    let Some(gltf) = common::shared::sample("MorphStressTest/MorphStressTest.gltf") else {
        return;
    };
    let dir = gltf.parent().unwrap();
    let scene = std::fs::read_dir(dir)
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .find(|p| p.extension().is_some_and(|x| x == "glb" || x == "gltf"))
        .expect("MorphStressTest asset");
    check("morph_stress_f12", &scene, 12, 64, WHITE_SKY);
}

#[test]
fn clay_render_of_an_animated_box() {
    let Some(scene) = common::shared::sample("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    check(
        "box_animated_clay_f10",
        &scene,
        10,
        64,
        &["--clay", "--env-color", "1,1,1"],
    );
}

#[test]
fn punctual_lights() {
    let dir = tempfile::tempdir().unwrap();
    let scene = scene_file(
        dir.path(),
        "lights",
        vec![
            MeshSpec {
                geometry: plane(0.0, 3.0),
                material: diffuse([0.8, 0.8, 0.8]),
            },
            MeshSpec {
                geometry: sphere([0.0, 0.6, 0.0], 0.6, 32),
                material: diffuse([0.8, 0.3, 0.2]),
            },
        ],
        [0.0, 2.5, 4.5],
        vec![
            (
                json!({"type": "point", "color": [1.0, 0.9, 0.8], "intensity": 30.0}),
                json!({"translation": [1.5, 2.5, 1.0]}),
            ),
            (
                json!({"type": "spot", "color": [0.3, 0.5, 1.0], "intensity": 60.0, "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.45}}),
                json!({"translation": [-1.5, 3.0, 0.5], "rotation": [-0.6427876, 0.0, 0.0, 0.7660444]}),
            ),
            (
                json!({"type": "directional", "color": [1.0, 1.0, 1.0], "intensity": 0.5}),
                json!({"rotation": [-0.3826834, 0.0, 0.0, 0.9238795]}),
            ),
        ],
    );
    check("punctual_lights", &scene, 0, 256, &["--env-color", "0,0,0"]);
}

#[test]
fn emissive_area_light() {
    let dir = tempfile::tempdir().unwrap();
    // A downward-facing 1.2 x 1.2 emitter, 2 units above the floor.
    let (mut pos, _, _, uv) = plane(0.0, 0.6);
    for y in pos.iter_mut().skip(1).step_by(3) {
        *y = 2.0;
    }
    let down: Vec<f32> = [0.0, -1.0, 0.0].repeat(4);
    let emitter = MeshSpec {
        geometry: (pos, down, vec![0, 2, 1, 0, 3, 2], uv),
        material: json!({"emissiveFactor": [1.0, 0.9, 0.7], "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 8.0}}, "pbrMetallicRoughness": {"baseColorFactor": [0,0,0,1]}}),
    };
    let scene = scene_file(
        dir.path(),
        "emissive",
        vec![
            MeshSpec {
                geometry: plane(0.0, 3.0),
                material: diffuse([0.8, 0.8, 0.8]),
            },
            MeshSpec {
                geometry: sphere([0.0, 0.5, 0.0], 0.5, 32),
                material: diffuse([0.2, 0.8, 0.3]),
            },
            emitter,
        ],
        [0.0, 1.8, 4.0],
        vec![],
    );
    check(
        "emissive_area_light",
        &scene,
        0,
        256,
        &["--env-color", "0,0,0"],
    );
}

#[test]
fn hdr_environment_map() {
    let dir = tempfile::tempdir().unwrap();
    let env = dir.path().join("sky.exr");
    // A deterministic sky: a bright warm sun, a blue gradient, a dark ground.
    let (w, h) = (64usize, 32usize);
    exr::prelude::write_rgb_file(&env, w, h, |x, y| {
        let v = (y as f32 + 0.5) / h as f32;
        let u = (x as f32 + 0.5) / w as f32;
        let sun = ((u - 0.3).powi(2) + (v - 0.25).powi(2)).sqrt() < 0.04;
        if sun {
            (60.0, 50.0, 40.0)
        } else if v < 0.5 {
            (0.3 + 0.4 * v, 0.5 + 0.4 * v, 1.0)
        } else {
            (0.1, 0.08, 0.06)
        }
    })
    .unwrap();
    let scene = scene_file(
        dir.path(),
        "env",
        vec![
            MeshSpec {
                geometry: plane(0.0, 3.0),
                material: diffuse([0.7, 0.7, 0.7]),
            },
            MeshSpec {
                geometry: sphere([0.0, 0.6, 0.0], 0.6, 32),
                material: diffuse([0.9, 0.9, 0.9]),
            },
        ],
        [0.0, 1.5, 4.0],
        vec![],
    );
    check(
        "hdr_environment",
        &scene,
        0,
        256,
        &["--env", env.to_str().unwrap()],
    );
}

#[test]
fn glossy_metal() {
    let dir = tempfile::tempdir().unwrap();
    let metal = json!({"pbrMetallicRoughness": {"baseColorFactor": [0.95, 0.64, 0.54, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.25}});
    let scene = scene_file(
        dir.path(),
        "metal",
        vec![
            MeshSpec {
                geometry: plane(0.0, 3.0),
                material: diffuse([0.5, 0.5, 0.5]),
            },
            MeshSpec {
                geometry: sphere([0.0, 0.6, 0.0], 0.6, 48),
                material: metal,
            },
        ],
        [0.0, 1.6, 3.5],
        vec![(
            json!({"type": "point", "color": [1.0, 1.0, 1.0], "intensity": 20.0}),
            json!({"translation": [1.0, 2.5, 2.0]}),
        )],
    );
    check(
        "glossy_metal",
        &scene,
        0,
        256,
        &["--env-color", "0.2,0.25,0.3"],
    );
}

#[test]
fn glass_transmission_and_volume() {
    // KHR_materials_transmission + _ior + _volume: a refracting, tinted
    // glass ball in front of two coloured balls, and a thin-walled, rough
    // transmissive ball, under a sky and a point light.
    let dir = tempfile::tempdir().unwrap();
    let glass = json!({
        "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.0},
        "extensions": {
            "KHR_materials_transmission": {"transmissionFactor": 1.0},
            "KHR_materials_ior": {"ior": 1.5},
            "KHR_materials_volume": {"thicknessFactor": 1.0, "attenuationColor": [0.7, 0.9, 1.0], "attenuationDistance": 1.5}
        }
    });
    let frosted = json!({
        "pbrMetallicRoughness": {"baseColorFactor": [0.9, 1.0, 0.9, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.35},
        "extensions": {"KHR_materials_transmission": {"transmissionFactor": 0.9}}
    });
    let scene = scene_file(
        dir.path(),
        "glass",
        vec![
            MeshSpec {
                geometry: plane(0.0, 3.0),
                material: diffuse([0.6, 0.6, 0.6]),
            },
            MeshSpec {
                geometry: sphere([-0.5, 0.35, -1.2], 0.35, 32),
                material: diffuse([0.8, 0.1, 0.1]),
            },
            MeshSpec {
                geometry: sphere([0.5, 0.35, -1.2], 0.35, 32),
                material: diffuse([0.1, 0.2, 0.8]),
            },
            MeshSpec {
                geometry: sphere([0.0, 0.5, 0.0], 0.5, 48),
                material: glass,
            },
            MeshSpec {
                geometry: sphere([1.1, 0.3, 0.4], 0.3, 32),
                material: frosted,
            },
        ],
        [0.0, 1.2, 3.5],
        vec![(
            json!({"type": "point", "color": [1.0, 1.0, 1.0], "intensity": 15.0}),
            json!({"translation": [1.5, 3.0, 2.0]}),
        )],
    );
    check(
        "glass_transmission_and_volume",
        &scene,
        0,
        256,
        &["--env-color", "0.5,0.6,0.8", "--max-depth", "12"],
    );
}

#[test]
fn clearcoat_over_paint_and_metal() {
    // KHR_materials_clearcoat: a smooth coat over red diffuse paint, a
    // rough coat over rough copper, and a coat over black (only the coat's
    // Fresnel reflects), beside an uncoated red ball, under a sky and a
    // point light.
    let dir = tempfile::tempdir().unwrap();
    let coat = |base: serde_json::Value, cc: f32, r: f32| {
        json!({
            "pbrMetallicRoughness": base,
            "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": cc, "clearcoatRoughnessFactor": r}}
        })
    };
    let red = json!({"baseColorFactor": [0.7, 0.05, 0.05, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.6});
    let copper = json!({"baseColorFactor": [0.95, 0.64, 0.54, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.5});
    let black = json!({"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0});
    let scene = scene_file(
        dir.path(),
        "clearcoat",
        vec![
            MeshSpec {
                geometry: plane(0.0, 3.0),
                material: diffuse([0.6, 0.6, 0.6]),
            },
            MeshSpec {
                geometry: sphere([-1.05, 0.35, 0.0], 0.35, 32),
                material: json!({"pbrMetallicRoughness": red}),
            },
            MeshSpec {
                geometry: sphere([-0.35, 0.35, 0.0], 0.35, 32),
                material: coat(red, 1.0, 0.0),
            },
            MeshSpec {
                geometry: sphere([0.35, 0.35, 0.0], 0.35, 32),
                material: coat(copper, 1.0, 0.3),
            },
            MeshSpec {
                geometry: sphere([1.05, 0.35, 0.0], 0.35, 32),
                material: coat(black, 1.0, 0.0),
            },
        ],
        [0.0, 1.2, 3.5],
        vec![(
            json!({"type": "point", "color": [1.0, 1.0, 1.0], "intensity": 15.0}),
            json!({"translation": [1.5, 3.0, 2.0]}),
        )],
    );
    check(
        "clearcoat_over_paint_and_metal",
        &scene,
        0,
        256,
        &["--env-color", "0.5,0.6,0.8"],
    );
}

#[test]
fn iridescent_films() {
    // KHR_materials_iridescence: a coating (index 1.9, 300 nm) on a
    // glossy black dielectric (a film of the base's own index, 1.5, would
    // show nothing: its lower interface would not reflect), a film (index 1.8, 500 nm) on rough white
    // metal, and a soap bubble (a smooth thin-walled transmissive ball with
    // a 380 nm film of index 1.33), beside the same black ball without a
    // film, under a sky and a point light.
    let dir = tempfile::tempdir().unwrap();
    let film = |base: serde_json::Value, ior: f32, nm: f32, extra: serde_json::Value| {
        let mut exts = json!({"KHR_materials_iridescence": {
            "iridescenceFactor": 1.0, "iridescenceIor": ior, "iridescenceThicknessMaximum": nm}});
        if let (Some(e), Some(x)) = (exts.as_object_mut(), extra.as_object()) {
            e.extend(x.clone());
        }
        json!({"pbrMetallicRoughness": base, "extensions": exts})
    };
    let black = json!({"baseColorFactor": [0.02, 0.02, 0.02, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.15});
    let white_metal = json!({"baseColorFactor": [0.9, 0.9, 0.9, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.3});
    let clear = json!({"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.0});
    let scene = scene_file(
        dir.path(),
        "iridescence",
        vec![
            MeshSpec {
                geometry: plane(0.0, 3.0),
                material: diffuse([0.6, 0.6, 0.6]),
            },
            MeshSpec {
                geometry: sphere([-1.05, 0.35, 0.0], 0.35, 32),
                material: json!({"pbrMetallicRoughness": black.clone()}),
            },
            MeshSpec {
                geometry: sphere([-0.35, 0.35, 0.0], 0.35, 32),
                material: film(black, 1.9, 300.0, json!({})),
            },
            MeshSpec {
                geometry: sphere([0.35, 0.35, 0.0], 0.35, 32),
                material: film(white_metal, 1.8, 500.0, json!({})),
            },
            MeshSpec {
                geometry: sphere([1.05, 0.35, 0.0], 0.35, 32),
                material: film(
                    clear,
                    1.33,
                    380.0,
                    json!({"KHR_materials_transmission": {"transmissionFactor": 1.0}}),
                ),
            },
        ],
        [0.0, 1.2, 3.5],
        vec![(
            json!({"type": "point", "color": [1.0, 1.0, 1.0], "intensity": 15.0}),
            json!({"translation": [1.5, 3.0, 2.0]}),
        )],
    );
    check(
        "iridescent_films",
        &scene,
        0,
        256,
        &["--env-color", "0.5,0.6,0.8"],
    );
}

#[test]
fn brushed_metal_and_dispersive_glass() {
    // KHR_materials_anisotropy on two gold spheres brushed around (the
    // tangent follows u, around the sphere) and along the meridians (turned
    // a quarter), beside an isotropic one of the same roughness, and
    // KHR_materials_dispersion on a glass ball (ior 1.6, dispersion 4:
    // Abbe number 5, exaggerated) over a checker of dark and light tiles,
    // under a sky and a point light.
    let dir = tempfile::tempdir().unwrap();
    let gold = |anisotropy: serde_json::Value| {
        let mut m = json!({"pbrMetallicRoughness": {"baseColorFactor": [1.0, 0.78, 0.34, 1.0], "metallicFactor": 1.0, "roughnessFactor": 0.35}});
        if !anisotropy.is_null() {
            m["extensions"] = json!({"KHR_materials_anisotropy": anisotropy});
        }
        m
    };
    let mut meshes = vec![
        MeshSpec {
            geometry: plane(0.0, 3.0),
            material: diffuse([0.6, 0.6, 0.6]),
        },
        MeshSpec {
            geometry: sphere([-1.05, 0.35, 0.0], 0.35, 48),
            material: gold(serde_json::Value::Null),
        },
        MeshSpec {
            geometry: sphere([-0.35, 0.35, 0.0], 0.35, 48),
            material: gold(json!({"anisotropyStrength": 0.9})),
        },
        MeshSpec {
            geometry: sphere([0.35, 0.35, 0.0], 0.35, 48),
            material: gold(
                json!({"anisotropyStrength": 0.9, "anisotropyRotation": std::f32::consts::FRAC_PI_2}),
            ),
        },
        MeshSpec {
            geometry: sphere([1.05, 0.35, 0.0], 0.35, 48),
            material: json!({
                "pbrMetallicRoughness": {"baseColorFactor": [1.0, 1.0, 1.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.0},
                "extensions": {
                    "KHR_materials_transmission": {"transmissionFactor": 1.0},
                    "KHR_materials_volume": {"thicknessFactor": 0.7},
                    "KHR_materials_ior": {"ior": 1.6},
                    "KHR_materials_dispersion": {"dispersion": 4.0}
                }
            }),
        },
    ];
    // Dark tiles behind the glass ball: edges for the colours to split at.
    for (x, z) in [
        (0.8f32, -0.9f32),
        (1.3, -0.9),
        (1.05, -1.4),
        (0.55, -1.4),
        (1.55, -1.4),
    ] {
        let (mut pos, nrm, idx, uv) = plane(0.001, 0.25);
        for k in 0..4 {
            pos[3 * k] += x;
            pos[3 * k + 2] += z;
        }
        meshes.push(MeshSpec {
            geometry: (pos, nrm, idx, uv),
            material: diffuse([0.03, 0.03, 0.03]),
        });
    }
    let scene = scene_file(
        dir.path(),
        "brushed",
        meshes,
        [0.0, 1.2, 3.5],
        vec![(
            json!({"type": "point", "color": [1.0, 1.0, 1.0], "intensity": 15.0}),
            json!({"translation": [1.5, 3.0, 2.0]}),
        )],
    );
    check(
        "brushed_metal_and_dispersive_glass",
        &scene,
        0,
        256,
        &["--env-color", "0.5,0.6,0.8"],
    );
}

#[test]
fn sheen_over_fabric() {
    // KHR_materials_sheen: a dark blue velvet (white sheen, low sheen
    // roughness), a rough sheen over pink cloth, and the same cloth without
    // sheen, under a sky and a point light behind them (sheen shows at
    // grazing angles).
    let dir = tempfile::tempdir().unwrap();
    let sheen = |base: [f32; 3], color: [f32; 3], r: f32| {
        json!({
            "pbrMetallicRoughness": {"baseColorFactor": [base[0], base[1], base[2], 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.9},
            "extensions": {"KHR_materials_sheen": {"sheenColorFactor": color, "sheenRoughnessFactor": r}}
        })
    };
    let scene = scene_file(
        dir.path(),
        "sheen",
        vec![
            MeshSpec {
                geometry: plane(0.0, 3.0),
                material: diffuse([0.5, 0.5, 0.5]),
            },
            MeshSpec {
                geometry: sphere([-0.8, 0.4, 0.0], 0.4, 32),
                material: sheen([0.02, 0.02, 0.15], [0.9, 0.9, 1.0], 0.3),
            },
            MeshSpec {
                geometry: sphere([0.0, 0.4, 0.0], 0.4, 32),
                material: sheen([0.6, 0.3, 0.35], [1.0, 0.8, 0.8], 0.8),
            },
            MeshSpec {
                geometry: sphere([0.8, 0.4, 0.0], 0.4, 32),
                material: diffuse([0.6, 0.3, 0.35]),
            },
        ],
        [0.0, 1.2, 3.5],
        vec![(
            json!({"type": "point", "color": [1.0, 1.0, 1.0], "intensity": 20.0}),
            json!({"translation": [0.0, 2.0, -2.0]}),
        )],
    );
    check(
        "sheen_over_fabric",
        &scene,
        0,
        256,
        &["--env-color", "0.4,0.45,0.5"],
    );
}
