//! The `info` and `soup` commands, called as functions the way main.rs
//! calls them.

mod common;

use clap::Parser;
use common::scene::{asset, load};
use soupray::cli::scene::{describe, run_info, run_soup, InfoArgs, SoupArgs};

#[derive(Parser)]
struct SoupCli {
    #[command(flatten)]
    args: SoupArgs,
}

#[derive(Parser)]
struct InfoCli {
    #[command(flatten)]
    args: InfoArgs,
}

#[test]
fn info_describes_meshes_skins_animations_and_materials() {
    let Some(fox_glb) = asset("Fox/Fox.glb") else {
        return;
    };
    let text = describe(&load(&fox_glb, None));
    for part in [
        "Fox.glb",
        "576 triangles",
        "24 joints",
        "animation 0 \"Survey\": 3.417 s",
        "frames 0..=82",
        "animation 1 \"Walk\"",
        "animation 2 \"Run\"",
        "a default camera frames the whole clip",
        "[texture 0 uv0]",
        "extensions required: none",
    ] {
        assert!(text.contains(part), "missing {part:?} in:\n{text}");
    }
    let Some(morph_stress_test_gltf) = asset("MorphStressTest/MorphStressTest.gltf") else {
        return;
    };
    let text = describe(&load(&morph_stress_test_gltf, None));
    assert!(text.contains("8 morph targets"), "{text}");
    let Some(simple_skin_gltf) = asset("SimpleSkin/SimpleSkin.gltf") else {
        return;
    };
    let args = InfoCli::try_parse_from(["info", simple_skin_gltf.to_str().unwrap()])
        .unwrap()
        .args;
    run_info(&args).unwrap();
}

#[test]
fn soup_writes_the_frame_as_ply() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fox.ply");
    let Some(fox_glb) = asset("Fox/Fox.glb") else {
        return;
    };
    let args = SoupCli::try_parse_from([
        "soup",
        fox_glb.to_str().unwrap(),
        "--frame",
        "7",
        "--animation",
        "Run",
        "-o",
        out.to_str().unwrap(),
    ])
    .unwrap()
    .args;
    run_soup(&args).unwrap();
    let written = soupray::ply::read_soup(&out).unwrap();
    let scene = load(&fox_glb, Some("Run"));
    let expected = scene.evaluate(7.0 / 24.0).unwrap().soup;
    assert_eq!(written.positions, expected.positions);

    // Errors name the input file.
    let missing = SoupCli::try_parse_from(["soup", "nothere.glb", "-o", out.to_str().unwrap()])
        .unwrap()
        .args;
    let msg = run_soup(&missing).unwrap_err().to_string();
    assert!(msg.contains("nothere.glb"), "{msg}");
}

#[test]
fn info_lists_the_material_extensions_as_read() {
    use serde_json::json;
    let dir = tempfile::tempdir().unwrap();
    let mut b = common::scene::Builder::default();
    let p = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let root = json!({
        "extensionsUsed": ["KHR_materials_transmission", "KHR_materials_ior", "KHR_materials_volume", "KHR_materials_specular", "KHR_materials_unlit"],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p}, "material": 0}, {"attributes": {"POSITION": p}, "material": 1}]}],
        "images": [{"uri": "t.png"}],
        "textures": [{"source": 0}],
        "materials": [
            {"name": "water", "extensions": {
                "KHR_materials_transmission": {"transmissionFactor": 1.0, "transmissionTexture": {"index": 0}},
                "KHR_materials_ior": {"ior": 1.33},
                "KHR_materials_volume": {"thicknessFactor": 0.1, "attenuationColor": [0.5, 0.8, 0.9], "attenuationDistance": 2.0},
                "KHR_materials_specular": {"specularFactor": 0.5, "specularColorTexture": {"index": 0, "texCoord": 1}}
            }},
            {"name": "sign", "extensions": {"KHR_materials_unlit": {}}}
        ]
    });
    let path = b.write(root, dir.path(), "exts", true);
    let text = describe(&load(&path, None));
    // Each extension with the glTF properties the file sets, by name.
    for part in [
        "KHR_materials_transmission transmissionFactor 1 transmissionTexture [texture 0 uv0]",
        "KHR_materials_ior ior 1.33",
        "KHR_materials_volume thicknessFactor 0.1 attenuationColor [0.5, 0.8, 0.9] attenuationDistance 2",
        "KHR_materials_specular specularFactor 0.5 specularColorTexture [texture 0 uv1]",
        "refracting volume",
        "material 1 \"sign\"",
        "    unlit",
    ] {
        assert!(text.contains(part), "missing {part:?} in:\n{text}");
    }
}
