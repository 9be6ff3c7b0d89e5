//! Loading: containers and buffers, topologies, sparse and normalized
//! accessors, scene selection, matrix nodes, cameras, lights, the default
//! framing camera and the material table.

mod common;

use common::scene::{assert_soup_matches, asset, load, Builder, Raw};
use glam::{Mat4, Vec3, Vec4};
use serde_json::json;
use soupray::scene::{AlphaMode, LightKind, LoadOptions, Material, Projection, Scene};
use std::path::{Path, PathBuf};

#[test]
fn gltf_and_glb_of_the_same_asset_give_the_same_frames() {
    let Some(box_animated_glb) = asset("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    let glb = load(&box_animated_glb, None);
    let Some(box_animated_gltf) = asset("BoxAnimated/BoxAnimated.gltf") else {
        return;
    };
    let gltf = load(&box_animated_gltf, None);
    let raw = Raw::open(&box_animated_glb);
    for f in [0, 20, 44, 89] {
        let t = glb.time_of_frame(f);
        let a = glb.evaluate(t).unwrap();
        let b = gltf.evaluate(t).unwrap();
        assert_eq!(a.soup, b.soup, "frame {f}");
        assert_soup_matches(
            &a.soup,
            &raw.soup(Some(0), t),
            1e-5,
            &format!("BoxAnimated frame {f}"),
        );
    }
}

#[test]
fn animated_cube_rotates_and_carries_uvs_and_materials() {
    let Some(file) = asset("AnimatedCube/AnimatedCube.gltf") else {
        return;
    };
    let scene = load(&file, None);
    let raw = Raw::open(&file);
    assert!(scene.has_uvs() && scene.has_normals());
    for f in [0, 13, 30] {
        let t = scene.time_of_frame(f);
        let frame = scene.evaluate(t).unwrap();
        assert_soup_matches(
            &frame.soup,
            &raw.soup(Some(0), t),
            1e-5,
            &format!("AnimatedCube frame {f}"),
        );
        assert_eq!(frame.soup.uvs.len(), 36);
        assert_eq!(frame.soup.normals.len(), 36);
        assert_eq!(frame.soup.material_ids, vec![0; 12]);
        // Rigid rotation keeps normals unit length and perpendicular to
        // their faces.
        for t in 0..12 {
            let c: Vec<Vec3> = (0..3)
                .map(|k| Vec3::from(frame.soup.corner(t, k)))
                .collect();
            let g = (c[1] - c[0]).cross(c[2] - c[0]).normalize();
            let n = Vec4::from(frame.soup.normals[3 * t]).truncate();
            assert!(
                (n.length() - 1.0).abs() < 1e-5 && g.dot(n) > 0.999,
                "triangle {t}: {g} vs {n}"
            );
        }
    }
    // TEXCOORD_0 is passed through unchanged: compare with the raw file.
    let uv = raw.accessor(
        raw.json["meshes"][0]["primitives"][0]["attributes"]["TEXCOORD_0"]
            .as_u64()
            .unwrap() as usize,
    );
    let idx = raw.accessor(
        raw.json["meshes"][0]["primitives"][0]["indices"]
            .as_u64()
            .unwrap() as usize,
    );
    let frame = scene.evaluate(0.0).unwrap();
    for (corner, i) in idx.iter().enumerate() {
        let want = &uv[i[0] as usize];
        assert_eq!(frame.soup.uvs[corner], [want[0] as f32, want[1] as f32]);
    }
}

#[test]
fn embedded_and_external_buffers_load_alike() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let root = json!({"scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "translation": [1.0, 2.0, 3.0]}],
                      "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}]});
    let a = load(&b.write(root.clone(), dir.path(), "embedded", true), None)
        .evaluate(0.0)
        .unwrap()
        .soup;
    let e = load(&b.write(root, dir.path(), "external", false), None)
        .evaluate(0.0)
        .unwrap()
        .soup;
    assert_eq!(a, e);
    assert_eq!(a.corner(0, 2), [1.0, 3.0, 3.0]);
    // No normals or uvs in the file: none in the soup; every triangle uses
    // the appended glTF default material.
    assert!(a.normals.is_empty() && a.uvs.is_empty());
    assert_eq!(a.material_ids, vec![0]);
}

#[test]
fn strips_and_fans_follow_the_spec_and_points_lines_are_skipped_once() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    // Five vertices on a zig-zag, x = index.
    let pos = b.floats(
        &[
            0.0, 0.0, 0.0, 1.0, 1.0, 0.0, 2.0, 0.0, 0.0, 3.0, 1.0, 0.0, 4.0, 0.0, 0.0,
        ],
        3,
    );
    let idx = b.u32s(&[4, 3, 2, 1, 0]);
    let path = b.write(
        json!({"scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": pos}, "mode": 5},
            {"attributes": {"POSITION": pos}, "mode": 6, "indices": idx},
            {"attributes": {"POSITION": pos}, "mode": 0},
            {"attributes": {"POSITION": pos}, "mode": 1},
            {"attributes": {"POSITION": pos}, "mode": 3}
        ]}]}),
        dir.path(),
        "topologies",
        true,
    );
    let scene = load(&path, None);
    let soup = scene.evaluate(0.0).unwrap().soup;
    let x = |t: usize| -> Vec<f32> { (0..3).map(|k| soup.corner(t, k)[0]).collect() };
    // Strip, not indexed: (0,1,2), (1,3,2), (2,3,4).
    assert_eq!(
        (x(0), x(1), x(2)),
        (
            vec![0.0, 1.0, 2.0],
            vec![1.0, 3.0, 2.0],
            vec![2.0, 3.0, 4.0]
        )
    );
    // Fan over indices 4,3,2,1,0: (3,2,4), (2,1,4), (1,0,4).
    assert_eq!(
        (x(3), x(4), x(5)),
        (
            vec![3.0, 2.0, 4.0],
            vec![2.0, 1.0, 4.0],
            vec![1.0, 0.0, 4.0]
        )
    );
    assert_eq!(soup.triangle_count(), 6);
    let skipped: Vec<&String> = scene
        .warnings()
        .iter()
        .filter(|w| w.contains("skipped"))
        .collect();
    assert_eq!(skipped.len(), 1, "{:?}", scene.warnings());
    for word in [
        "POINTS",
        "LINES",
        "LINE_STRIP",
        "primitive 2",
        "primitive 3",
        "primitive 4",
    ] {
        assert!(
            skipped[0].contains(word),
            "{word} missing from {}",
            skipped[0]
        );
    }
}

#[test]
fn sparse_accessor_without_buffer_view_and_normalized_texcoords() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    // POSITION: 3 vertices, all zero except sparse substitutions for
    // vertices 1 and 2.
    let sparse_idx = b.view(&[1u8, 2u8]);
    let sparse_val = b.view(
        &[5.0f32, 0.0, 0.0, 0.0, 6.0, 0.0]
            .iter()
            .flat_map(|f| f.to_le_bytes())
            .collect::<Vec<u8>>(),
    );
    let pos = b.accessor(json!({"componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [5, 6, 0],
        "sparse": {"count": 2, "indices": {"bufferView": sparse_idx, "componentType": 5121},
                   "values": {"bufferView": sparse_val}}}));
    // TEXCOORD_0 as normalized u16: 0, 65535 and 32768 / 65535.
    let uv = b.u16s(&[0, 65535, 65535, 0, 32768, 32768], 2, true);
    let path = b.write(
        json!({"scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
               "meshes": [{"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": uv}}]}]}),
        dir.path(),
        "sparse",
        true,
    );
    let soup = load(&path, None).evaluate(0.0).unwrap().soup;
    assert_eq!(soup.corner(0, 0), [0.0, 0.0, 0.0]);
    assert_eq!(soup.corner(0, 1), [5.0, 0.0, 0.0]);
    assert_eq!(soup.corner(0, 2), [0.0, 6.0, 0.0]);
    assert_eq!(soup.uvs[0], [0.0, 1.0]);
    assert_eq!(soup.uvs[1], [1.0, 0.0]);
    assert!((soup.uvs[2][0] - 32768.0 / 65535.0).abs() < 1e-7);
}

#[test]
fn scenes_matrices_and_hierarchy() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    // Node 1: matrix = translate (10, 0, 0) * scale 2 (column-major), child
    // of node 0 (translate y by 1). Scene 1 (the default) shows node 2.
    let path = b.write(
        json!({"scene": 1, "scenes": [{"nodes": [0]}, {"nodes": [2]}],
               "nodes": [{"translation": [0.0, 1.0, 0.0], "children": [1]},
                         {"mesh": 0, "matrix": [2,0,0,0, 0,2,0,0, 0,0,2,0, 10,0,0,1]},
                         {"mesh": 0, "translation": [0.0, 0.0, -5.0]}],
               "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}]}),
        dir.path(),
        "scenes",
        true,
    );
    let default = load(&path, None);
    assert_eq!(default.scene_index(), Some(1));
    assert_eq!(
        default.evaluate(0.0).unwrap().soup.corner(0, 1),
        [1.0, 0.0, -5.0]
    );
    let opts = LoadOptions {
        scene: Some(0),
        ..Default::default()
    };
    let first = Scene::load(&path, &opts).unwrap();
    // (1, 0, 0) * 2 + (10, 0, 0) + (0, 1, 0).
    assert_eq!(
        first.evaluate(0.0).unwrap().soup.corner(0, 1),
        [12.0, 1.0, 0.0]
    );
    assert_eq!(first.instances().len(), 1);
}

fn camera_scene(dir: &std::path::Path) -> std::path::PathBuf {
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let times = b.floats(&[0.0, 2.0], 1);
    let moves = b.floats(&[0.0, 0.0, 10.0, 4.0, 0.0, 10.0], 3);
    let s = std::f32::consts::FRAC_1_SQRT_2;
    b.write(
        json!({
            "extensionsUsed": ["KHR_lights_punctual"],
            "extensions": {"KHR_lights_punctual": {"lights": [
                {"type": "spot", "name": "spot", "color": [1.0, 0.5, 0.25], "intensity": 30.0, "range": 9.0,
                 "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}},
                {"type": "directional", "name": "sun", "intensity": 3.0}]}},
            "scenes": [{"nodes": [0, 1, 2, 3, 4]}],
            "cameras": [
                {"name": "persp", "type": "perspective", "perspective": {"yfov": 0.8, "aspectRatio": 1.5, "znear": 0.1, "zfar": 100.0}},
                {"name": "ortho", "type": "orthographic", "orthographic": {"xmag": 3.0, "ymag": 2.0, "znear": 0.5, "zfar": 50.0}}],
            "nodes": [
                {"mesh": 0},
                {"name": "rig", "camera": 0, "translation": [0.0, 0.0, 10.0]},
                {"name": "top", "camera": 1, "translation": [0.0, 20.0, 0.0], "rotation": [-s, 0.0, 0.0, s]},
                {"name": "lamp", "translation": [0.0, 0.0, 10.0], "extensions": {"KHR_lights_punctual": {"light": 0}}},
                {"rotation": [-s, 0.0, 0.0, s], "extensions": {"KHR_lights_punctual": {"light": 1}}}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}],
            "animations": [{"channels": [{"sampler": 0, "target": {"node": 1, "path": "translation"}},
                                         {"sampler": 0, "target": {"node": 3, "path": "translation"}}],
                            "samplers": [{"input": times, "output": moves}]}]
        }),
        dir,
        "cameras",
        true,
    )
}

#[test]
fn cameras_and_lights_follow_their_animated_nodes() {
    let dir = tempfile::tempdir().unwrap();
    let path = camera_scene(dir.path());
    let scene = load(&path, None);
    let frame = scene.evaluate(1.0).unwrap();
    // The first camera in the scene, moved halfway from x = 0 to x = 4.
    assert!(frame.camera.from_file);
    assert_eq!(frame.camera.name.as_deref(), Some("persp"));
    assert_eq!(frame.camera.position(), Vec3::new(2.0, 0.0, 10.0));
    assert_eq!(frame.camera.forward(), Vec3::NEG_Z);
    assert_eq!(
        frame.camera.projection,
        Projection::Perspective {
            yfov: 0.8,
            aspect: Some(1.5),
            znear: 0.1,
            zfar: Some(100.0)
        }
    );
    // Lights: the spot moves with its node; the sun is turned -90 degrees
    // about x, so it shines along -y.
    assert_eq!(frame.lights.len(), 2);
    let spot = &frame.lights[0];
    assert_eq!(spot.position, Vec3::new(2.0, 0.0, 10.0));
    assert_eq!(spot.direction, Vec3::NEG_Z);
    assert_eq!(
        spot.kind,
        LightKind::Spot {
            inner_cone_angle: 0.2,
            outer_cone_angle: 0.6
        }
    );
    assert_eq!(
        (spot.color, spot.intensity, spot.range),
        ([1.0, 0.5, 0.25], 30.0, Some(9.0))
    );
    let sun = &frame.lights[1];
    assert_eq!(sun.kind, LightKind::Directional);
    assert!(
        (sun.direction - Vec3::NEG_Y).length() < 1e-6,
        "{}",
        sun.direction
    );

    // By name (camera or node) or index.
    for pick in ["ortho", "top", "1"] {
        let opts = LoadOptions {
            camera: Some(pick.into()),
            ..Default::default()
        };
        let frame = Scene::load(&path, &opts).unwrap().evaluate(0.0).unwrap();
        assert_eq!(
            frame.camera.projection,
            Projection::Orthographic {
                xmag: 3.0,
                ymag: 2.0,
                znear: 0.5,
                zfar: 50.0
            }
        );
        assert!((frame.camera.forward() - Vec3::NEG_Y).length() < 1e-6);
        assert_eq!(frame.camera.position(), Vec3::new(0.0, 20.0, 0.0));
    }
}

/// Every corner of every frame projects inside a square image of the
/// default camera and lies in front of its near plane.
fn assert_default_camera_sees_everything(scene: &Scene) {
    let (first, last) = scene.frame_range();
    let camera = scene.evaluate(0.0).unwrap().camera;
    assert!(!camera.from_file);
    let Projection::Perspective { yfov, znear, .. } = camera.projection else {
        panic!()
    };
    let camera_from_world: Mat4 = camera.world_from_camera.inverse();
    let limit = (yfov / 2.0).tan();
    for f in first..=last {
        let frame = scene.evaluate(scene.time_of_frame(f)).unwrap();
        assert_eq!(
            frame.camera, camera,
            "the default camera is fixed over the clip"
        );
        for p in &frame.soup.positions {
            let c = camera_from_world.transform_point3(Vec3::new(p[0], p[1], p[2]));
            assert!(-c.z > znear, "frame {f}: {c} is behind the near plane");
            assert!(
                (c.x / -c.z).abs() <= limit && (c.y / -c.z).abs() <= limit,
                "frame {f}: {c} out of view"
            );
        }
    }
}

#[test]
fn default_camera_frames_the_whole_clip() {
    let Some(fox_glb) = asset("Fox/Fox.glb") else {
        return;
    };
    assert_default_camera_sees_everything(&load(&fox_glb, Some("Survey")));
    let Some(box_animated_glb) = asset("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    assert_default_camera_sees_everything(&load(&box_animated_glb, None));
}

/// A 2x1 PNG made with the `image` crate.
fn tiny_png() -> Vec<u8> {
    common::scene::png(2, 1, &[255, 0, 0, 255, 0, 0, 255, 255])
}

#[test]
fn material_table_reads_every_property() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let png = b.view(&tiny_png());
    let path = b.write(
        json!({
            "extensionsUsed": ["KHR_materials_emissive_strength", "KHR_texture_transform"],
            "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "images": [{"bufferView": png, "mimeType": "image/png"}],
            "samplers": [{"magFilter": 9728, "wrapS": 33071}],
            "textures": [{"source": 0, "sampler": 0}],
            "materials": [{
                "name": "glow",
                "pbrMetallicRoughness": {"baseColorFactor": [0.5, 0.25, 1.0, 0.5], "metallicFactor": 0.3, "roughnessFactor": 0.7,
                    "baseColorTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.0], "scale": [2.0, 2.0], "texCoord": 1}}}},
                "normalTexture": {"index": 0, "scale": 0.8, "extensions": {"KHR_texture_transform": {"rotation": 1.5}}},
                "emissiveFactor": [1.0, 0.5, 0.0],
                "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 5.0}},
                "alphaMode": "MASK", "alphaCutoff": 0.3, "doubleSided": true}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "material": 0}, {"attributes": {"POSITION": pos}}]}]
        }),
        dir.path(),
        "materials",
        true,
    );
    let scene = load(&path, None);
    let table = scene.materials();
    assert_eq!(
        table.materials.len(),
        2,
        "the file's material plus the default one"
    );
    assert_eq!(table.default_material, Some(1));
    let m = &table.materials[0];
    assert_eq!(m.name.as_deref(), Some("glow"));
    assert_eq!(m.base_color_factor, [0.5, 0.25, 1.0, 0.5]);
    assert_eq!((m.metallic_factor, m.roughness_factor), (0.3, 0.7));
    assert_eq!(m.emissive_factor, [1.0, 0.5, 0.0]);
    assert_eq!(m.emissive_strength, 5.0);
    assert_eq!(
        (m.alpha_mode, m.alpha_cutoff, m.double_sided),
        (AlphaMode::Mask, 0.3, true)
    );
    let base = m.base_color_texture.as_ref().unwrap();
    assert_eq!(
        base.tex_coord, 1,
        "KHR_texture_transform texCoord overrides"
    );
    let tt = base.transform.unwrap();
    assert_eq!(
        (tt.offset, tt.scale, tt.rotation),
        ([0.5, 0.0], [2.0, 2.0], 0.0)
    );
    let normal = m.normal_texture.as_ref().unwrap();
    assert_eq!(
        (m.normal_scale, normal.transform.unwrap().rotation),
        (0.8, 1.5)
    );
    assert_eq!(
        table.textures[0].mag_filter,
        soupray::scene::material::Filter::Nearest
    );
    assert_eq!(
        table.textures[0].wrap_s,
        soupray::scene::material::Wrap::ClampToEdge
    );
    let default = &table.materials[1];
    assert_eq!(
        (
            default.metallic_factor,
            default.roughness_factor,
            default.base_color_factor
        ),
        (1.0, 1.0, [1.0; 4])
    );
    // Triangles carry their material ids; the material-less one uses the default.
    assert_eq!(scene.evaluate(0.0).unwrap().soup.material_ids, vec![0, 1]);
    // The image decodes on request.
    assert!(table.has_textured_materials());
    table.decode_used_images().unwrap();
    let img = table.images[0].decoded(0).unwrap();
    assert_eq!((img.width, img.height), (2, 1));
    assert_eq!(img.rgba8, vec![255, 0, 0, 255, 0, 0, 255, 255]);
}

#[test]
fn fox_texture_decodes_from_the_glb() {
    let Some(fox_glb) = asset("Fox/Fox.glb") else {
        return;
    };
    let scene = load(&fox_glb, None);
    let table = scene.materials();
    let texture = table.materials[0]
        .base_color_texture
        .as_ref()
        .unwrap()
        .texture;
    let image = table.textures[texture].image;
    let decoded = table.images[image].decoded(image).unwrap();
    assert!(decoded.width > 0 && decoded.height > 0);
    assert_eq!(
        decoded.rgba8.len(),
        (decoded.width * decoded.height * 4) as usize
    );
}

#[test]
fn dielectric_extensions_are_read_and_ignored_ones_named_once() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let path = write_dielectric_scene(&b, pos, dir.path());
    // Required transmission and volume are accepted.
    let scene = load(&path, None);
    let m = &scene.materials().materials;
    assert_eq!((m[0].transmission_factor, m[0].ior), (0.9, 1.33));
    assert_eq!(m[0].thickness_factor, 0.2);
    assert_eq!(m[0].attenuation_color, [0.5, 0.8, 1.0]);
    assert_eq!(m[0].attenuation_distance, 3.0);
    assert!(m[0].needs_transmission() && m[0].has_volume());
    // Without the extensions: the glTF defaults, and no transmission code.
    assert_eq!((m[1].transmission_factor, m[1].ior), (0.0, 1.5));
    assert_eq!(m[1].attenuation_distance, f32::INFINITY);
    assert!(!m[1].needs_transmission());
    assert!(m[3].unlit && !m[0].unlit);
    assert_eq!(
        (m[4].specular_factor, m[4].specular_color),
        (0.5, [2.0, 1.0, 0.5])
    );
    assert!(m[4].needs_transmission() && !m[4].has_volume());
    // Out of range: clamped with a warning.
    assert_eq!((m[2].transmission_factor, m[2].ior), (1.0, 1.0));
    // Clear coat and sheen factors are read (the sheen colour clamped to
    // 0..1 with a warning), and their textures.
    assert_eq!(
        (m[0].clearcoat_factor, m[0].clearcoat_roughness),
        (1.0, 0.0)
    );
    assert_eq!(
        (m[1].clearcoat_factor, m[1].clearcoat_roughness),
        (0.5, 0.25)
    );
    assert_eq!(
        (m[1].sheen_color, m[1].sheen_roughness),
        ([1.0, 0.5, 1.0], 0.4)
    );
    assert!(m[1].has_clearcoat() && m[1].has_sheen());
    assert!(!m[2].has_clearcoat() && !m[2].has_sheen());
    let w = scene.warnings();
    assert_eq!(m[1].clearcoat_texture.as_ref().map(|t| t.texture), Some(0));
    assert!(m[1].clearcoat_normal_texture.is_none() && m[0].clearcoat_texture.is_none());
    assert!(!w.iter().any(|w| w.contains("clearcoatTexture")), "{w:?}");
    assert!(
        w.iter().any(|w| w.contains("sheenColorFactor.b 2")),
        "{w:?}"
    );
    assert_lobes_read(m, w);
    for ext in [
        "KHR_materials_clearcoat",
        "KHR_materials_sheen",
        "KHR_materials_diffuse_transmission",
        "KHR_materials_iridescence",
        "KHR_materials_anisotropy",
        "KHR_materials_dispersion",
    ] {
        assert!(
            !w.iter().any(|w| w.contains(ext) && w.contains("ignores")),
            "{ext} is rendered: {w:?}"
        );
    }
    {
        let (ext, first) = ("KHR_materials_volume_scatter", "extensionsUsed");
        let hits: Vec<&String> = w.iter().filter(|w| w.contains(ext)).collect();
        assert_eq!(hits.len(), 1, "one warning for {ext}: {w:?}");
        assert!(
            hits[0].contains(first) && hits[0].contains("ignores"),
            "{}",
            hits[0]
        );
    }
    assert!(w
        .iter()
        .any(|w| w.contains("transmissionFactor 2") && w.contains("1 is used")));
    assert!(!w.iter().any(|w| w.contains("KHR_materials_ior is used")));

    assert_required_extensions(&b, pos, dir.path());
}

/// A triangle with a material per dielectric and lobe extension case,
/// some out of range, and an extension soupray ignores.
fn write_dielectric_scene(b: &Builder, pos: usize, dir: &Path) -> PathBuf {
    b.write(
        json!({
            "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume",
                               "KHR_materials_clearcoat", "KHR_materials_sheen", "KHR_materials_dispersion",
                               "KHR_materials_volume_scatter",
                               "KHR_materials_iridescence", "KHR_materials_anisotropy",
                               "KHR_materials_diffuse_transmission"],
            "extensionsRequired": ["KHR_materials_transmission", "KHR_materials_volume"],
            "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "materials": [
                {"name": "glass", "extensions": {
                    "KHR_materials_transmission": {"transmissionFactor": 0.9},
                    "KHR_materials_ior": {"ior": 1.33},
                    "KHR_materials_volume": {"thicknessFactor": 0.2, "attenuationColor": [0.5, 0.8, 1.0], "attenuationDistance": 3.0},
                    "KHR_materials_clearcoat": {"clearcoatFactor": 1.0}}},
                {"name": "paint", "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 0.5,
                                                      "clearcoatRoughnessFactor": 0.25, "clearcoatTexture": {"index": 0}},
                                                  "KHR_materials_sheen": {"sheenColorFactor": [1, 0.5, 2], "sheenRoughnessFactor": 0.4}}},
                {"name": "bad", "extensions": {"KHR_materials_transmission": {"transmissionFactor": 2.0},
                                                "KHR_materials_ior": {"ior": 0.5},
                                                "KHR_materials_iridescence": {"iridescenceFactor": 0.5,
                                                    "iridescenceIor": 1e30, "iridescenceThicknessMaximum": -5}}},
                {"name": "flat", "extensions": {"KHR_materials_unlit": {}}},
                {"name": "spec", "extensions": {"KHR_materials_specular": {"specularFactor": 0.5, "specularColorFactor": [2.0, 1.0, 0.5]}}},
                {"name": "wax", "extensions": {
                    "KHR_materials_diffuse_transmission": {"diffuseTransmissionFactor": 0.4,
                        "diffuseTransmissionColorFactor": [1.0, 0.5, 0.2], "diffuseTransmissionColorTexture": {"index": 0}},
                    "KHR_materials_volume": {"thicknessFactor": 1.0}}},
                {"name": "bubble", "extensions": {"KHR_materials_iridescence": {"iridescenceFactor": 0.8,
                    "iridescenceIor": 1.33, "iridescenceThicknessMaximum": 600,
                    "iridescenceThicknessTexture": {"index": 0}}}},
                {"name": "brushed", "extensions": {"KHR_materials_anisotropy": {"anisotropyStrength": 0.6,
                    "anisotropyRotation": 1.25, "anisotropyTexture": {"index": 0}}}},
                {"name": "too brushed", "extensions": {"KHR_materials_anisotropy": {"anisotropyStrength": 3.0}}},
                {"name": "prism", "extensions": {"KHR_materials_dispersion": {"dispersion": 0.33},
                    "KHR_materials_transmission": {"transmissionFactor": 1.0},
                    "KHR_materials_volume": {"thicknessFactor": 1.0}}},
                {"name": "rutile squared", "extensions": {"KHR_materials_dispersion": {"dispersion": 50.0}}}
            ],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "material": 0}]}],
            "textures": [{"source": 0}],
            "images": [{"uri": "coat.png"}]
        }),
        dir,
        "dielectric",
        true,
    )
}

/// The lobe extensions of `write_dielectric_scene`: diffuse transmission,
/// iridescence, anisotropy and dispersion are read, and out-of-range
/// values clamped with the warnings in `w`.
fn assert_lobes_read(m: &[Material], w: &[String]) {
    // Diffuse transmission: factor, colour and colour texture; with
    // KHR_materials_volume the mesh bounds a volume.
    assert_eq!(
        (m[5].diffuse_transmission, m[5].diffuse_transmission_color),
        (0.4, [1.0, 0.5, 0.2])
    );
    assert_eq!(
        m[5].diffuse_transmission_color_texture
            .as_ref()
            .map(|t| t.texture),
        Some(0)
    );
    assert!(m[5].diffuse_transmission_texture.is_none());
    assert!(m[5].has_diffuse_transmission() && m[5].needs_transmission() && m[5].has_volume());
    assert!(!m[4].has_diffuse_transmission());
    // Iridescence: factor, film index, thickness range (the minimum at its
    // default) and texture; it needs the dielectric code.
    assert_eq!(
        (
            m[6].iridescence,
            m[6].iridescence_ior,
            m[6].iridescence_thickness_min,
            m[6].iridescence_thickness_max
        ),
        (0.8, 1.33, 100.0, 600.0)
    );
    assert_eq!(
        m[6].iridescence_thickness_texture
            .as_ref()
            .map(|t| t.texture),
        Some(0)
    );
    assert!(m[6].has_iridescence() && m[6].needs_transmission() && !m[5].has_iridescence());
    // KHR_materials_anisotropy: strength, rotation and texture; a strength
    // above 1 clamped with a warning.
    assert_eq!(
        (m[7].anisotropy_strength, m[7].anisotropy_rotation),
        (0.6, 1.25)
    );
    assert_eq!(m[7].anisotropy_texture.as_ref().map(|t| t.texture), Some(0));
    assert!(m[7].has_anisotropy() && m[7].needs_transmission() && !m[6].has_anisotropy());
    assert_eq!(m[8].anisotropy_strength, 1.0);
    // KHR_materials_dispersion: read, compiled only on a refracting volume,
    // above 20 (Abbe number 1) clamped with a warning.
    assert_eq!(m[9].dispersion, 0.33);
    assert!(m[9].has_dispersion() && !m[0].has_dispersion());
    assert_eq!(m[10].dispersion, 20.0);
    assert!(
        !m[10].has_dispersion(),
        "an opaque material does not disperse"
    );
    assert!(
        w.iter()
            .any(|w| w.contains("dispersion 50") && w.contains("20 is used")),
        "{w:?}"
    );
    assert!(
        w.iter()
            .any(|w| w.contains("anisotropyStrength 3") && w.contains("1 is used")),
        "{w:?}"
    );
    // Out of range: the film's index bounded (its optical path stays
    // finite), a negative thickness raised to 0, each with a warning.
    assert_eq!(
        (m[2].iridescence_ior, m[2].iridescence_thickness_max),
        (100.0, 0.0)
    );
    assert!(
        w.iter()
            .any(|w| w.contains("iridescenceIor") && w.contains("100 is used")),
        "{w:?}"
    );
    assert!(
        w.iter()
            .any(|w| w.contains("iridescenceThicknessMaximum -5") && w.contains("0 is used")),
        "{w:?}"
    );
}

/// The material extensions soupray reads load when required; a required
/// one it does not read is refused.
fn assert_required_extensions(b: &Builder, pos: usize, dir: &Path) {
    // The extensions soupray reads itself load when required.
    for ext in [
        "KHR_materials_anisotropy",
        "KHR_materials_diffuse_transmission",
        "KHR_materials_dispersion",
        "KHR_materials_iridescence",
        "KHR_materials_clearcoat",
        "KHR_materials_pbrSpecularGlossiness",
    ] {
        let path = b.write(
            json!({
                "extensionsUsed": [ext],
                "extensionsRequired": [ext],
                "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
                "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}]
            }),
            dir,
            "required",
            true,
        );
        if let Err(e) = Scene::load(&path, &LoadOptions::default()) {
            panic!("a required {ext} is refused: {e}");
        }
    }

    // An unsupported material extension that is required is refused.
    let path = b.write(
        json!({
            "extensionsUsed": ["KHR_materials_volume_scatter"],
            "extensionsRequired": ["KHR_materials_volume_scatter"],
            "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}]
        }),
        dir,
        "coat",
        true,
    );
    let Err(err) = Scene::load(&path, &LoadOptions::default()) else {
        panic!("a required KHR_materials_volume_scatter is refused");
    };
    assert!(
        err.to_string().contains("KHR_materials_volume_scatter"),
        "{err}"
    );
}

#[test]
fn material_variants_replace_the_mapped_materials() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let path = b.write(
        json!({
            "extensionsUsed": ["KHR_materials_variants"],
            "extensionsRequired": ["KHR_materials_variants"],
            "extensions": {"KHR_materials_variants": {"variants": [{"name": "red"}, {"name": "blue"}, {}]}},
            "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
            "materials": [{"name": "white"}, {"name": "red"}, {"name": "blue"}],
            "meshes": [{"primitives": [
                {"attributes": {"POSITION": pos}, "material": 0,
                 "extensions": {"KHR_materials_variants": {"mappings": [
                     {"material": 1, "variants": [0]}, {"material": 2, "variants": [1, 2]}]}}},
                {"attributes": {"POSITION": pos}, "material": 0}
            ]}]
        }),
        dir.path(),
        "variants",
        true,
    );
    let with = |variant: Option<&str>| {
        Scene::load(
            &path,
            &LoadOptions {
                variant: variant.map(str::to_owned),
                ..LoadOptions::default()
            },
        )
    };
    let ids = |s: &Scene| s.evaluate(0.0).unwrap().soup.material_ids;
    let default = with(None).unwrap();
    assert_eq!(default.variants(), ["red", "blue", "2"]);
    assert!(!default.warnings().iter().any(|w| w.contains("variants")));
    assert_eq!(ids(&default), vec![0, 0]);
    // By name or index; unmapped primitives keep their own material.
    assert_eq!(ids(&with(Some("red")).unwrap()), vec![1, 0]);
    assert_eq!(ids(&with(Some("blue")).unwrap()), vec![2, 0]);
    assert_eq!(ids(&with(Some("2")).unwrap()), vec![2, 0]);
    let Err(err) = with(Some("green")) else {
        panic!("an unknown variant is refused");
    };
    let msg = err.to_string();
    assert!(
        msg.contains("--variant green")
            && msg.contains("red, blue, 2")
            && msg.contains("variants.gltf"),
        "{msg}"
    );
}
