//! The other material extensions: none compiled for the shipped animation,
//! KHR_materials_unlit, KHR_materials_specular, and the extensions' and
//! layers' textures scaling their factors (a clearcoat normal map among
//! them), rendered on a textured square.

use super::*;

#[test]
fn the_shipped_animation_compiles_no_material_extension_code() {
    // Only what the scene needs: CesiumMan uses none of the extensions, so
    // its program is built with exactly the defines it had before them.
    use soupray::scene::{LoadOptions, Scene};
    use soupray::trace::render::{
        material_features, pathtrace_defines, Layering, Lobes, Traversal,
    };
    use soupray::trace::sampling::Sampler;
    let Some(path) = common::shared::cesium_man() else {
        return;
    };
    let scene = Scene::load(&path, &LoadOptions::default()).unwrap();
    let table = scene.materials();
    assert!(!table.materials.iter().any(|m| m.needs_transmission()));
    assert!(!scene.warnings().iter().any(|w| w.contains("KHR_materials")));
    assert_eq!(
        material_features(table, true, false, Layering::Spec),
        ["metallic_roughness", "textures"]
    );
    let names: Vec<&str> = pathtrace_defines(
        Traversal::Wide,
        true,
        Sampler::Sobol,
        false,
        false,
        false,
        Lobes::of(table),
    )
    .iter()
    .map(|(n, _)| *n)
    .collect();
    assert_eq!(names, ["STACK_SIZE", "TRAVERSAL_WIDE", "HAS_TEXTURES"]);
}

#[test]
fn unlit_surfaces_show_their_base_colour_whatever_the_light() {
    // KHR_materials_unlit: an unlit quad under a bright sun and sky shows
    // exactly its base colour; beside it, a lit white diffuse quad does not.
    let d = common::device();
    let mut s = Soup::default();
    quad(
        &mut s,
        Vec3::new(-0.5, 0.0, 0.0),
        Vec3::X * 0.5,
        Vec3::Z * 0.5,
        Vec3::Y,
        0,
    );
    quad(
        &mut s,
        Vec3::new(0.5, 0.0, 0.0),
        Vec3::X * 0.5,
        Vec3::Z * 0.5,
        Vec3::Y,
        1,
    );
    let unlit = Material {
        unlit: true,
        ..material([0.2, 0.5, 0.9, 1.0], 0.0, 1.0)
    };
    let t = table(vec![unlit, material([1.0; 4], 0.0, 1.0)]);
    let sun = light(
        soupray::scene::LightKind::Directional,
        Vec3::ZERO,
        Vec3::NEG_Y,
        [1.0; 3],
        5.0,
    );
    let mut st = settings(16, 4);
    st.environment = Environment::Color([0.5, 0.5, 0.5]);
    let out = render_soup(&d, &s, &t, &top_down(1.0), &[sun], &st, 0).unwrap();
    let left = out.image.rgba[8 * 16 + 3];
    let right = out.image.rgba[8 * 16 + 12];
    for (k, want) in [0.2f32, 0.5, 0.9].iter().enumerate() {
        assert!((left[k] - want).abs() < 1e-6, "unlit pixel {left:?}");
    }
    assert!(right[0] > 1.0, "lit pixel {right:?}");
}

#[test]
fn specular_extension_weights_and_colours_the_dielectric_layer() {
    // specularFactor 0: no layer at all, a white dielectric is exactly
    // Lambertian (albedo 1 at every angle).
    let mut p =
        BsdfParams::new([1.0; 3], 0.0, 0.5).with_dielectric(Dielectric::new(1.5, 0.0, false, true));
    p.specular = 0.0;
    for &mu in &[1.0f32, 0.5, 0.2] {
        let a = albedo(&p, mu, 1.0);
        assert!((a - 1.0).abs() < 2e-3, "mu {mu}: {a}");
    }
    // A coloured layer on a black base reflects its colour: head-on the
    // smooth layer returns F0 = min(f0 * colour, 1) per channel.
    let q = BsdfParams::new([0.0; 3], 0.0, 0.0).with_dielectric(
        Dielectric::new(1.5, 0.0, false, true).with_specular_color([2.0, 1.0, 0.0]),
    );
    let wo = Vec3::Z;
    let mut sum = Vec3::ZERO;
    let n = 64;
    for i in 0..n {
        for j in 0..n {
            let (u1, u2) = ((i as f32 + 0.5) / n as f32, (j as f32 + 0.5) / n as f32);
            if let Some(s) = bsdf_sample(&q, wo, 0.0, u1, u2) {
                sum += s.f * s.wi.z / s.pdf;
            }
        }
    }
    let r = sum / (n * n) as f32;
    let f0 = f0_of_ior(1.5);
    eprintln!("coloured layer head-on: {r} (f0 {f0})");
    assert!(
        (r.x - 2.0 * f0).abs() < 2e-3 && (r.y - f0).abs() < 2e-3 && r.z < 1e-4,
        "{r}"
    );
}

/// Renders, at 64x32 and 16 spp under a blue-grey sky, a square facing an
/// orthographic camera that fills the frame, its UVs running 0-1 left to
/// right, with `material` (whose textures, if any, are image 0: `uri`,
/// nearest-filtered).
fn render_textured_square(material: serde_json::Value, uri: &str) -> soupray::film::Image {
    render_square(material, uri, None, &["--env-color", "0.5,0.6,0.8"])
}

/// The largest relative difference between `a` and `b` over the pixels of
/// columns `cols` (RGB).
fn max_rel_diff(
    a: &soupray::film::Image,
    b: &soupray::film::Image,
    cols: std::ops::Range<usize>,
) -> f32 {
    let mut worst = 0.0f32;
    for y in 0..a.height as usize {
        for x in cols.clone() {
            let (p, q) = (
                a.rgba[y * a.width as usize + x],
                b.rgba[y * b.width as usize + x],
            );
            for c in 0..3 {
                worst = worst.max((p[c] - q[c]).abs() / q[c].abs().max(1e-3));
            }
        }
    }
    worst
}

/// Each half of `textured` (columns 0-27 and 36-63: the pixel filter
/// reaches 4 pixels across the seam) renders as the factor-only render of
/// that half's texel (`lf`, `rf`), and those two differ.
fn assert_halves_match(
    what: &str,
    textured: &soupray::film::Image,
    lf: &soupray::film::Image,
    rf: &soupray::film::Image,
) {
    let (left, right) = (0..28, 36..64);
    let (l, r) = (
        max_rel_diff(textured, lf, left.clone()),
        max_rel_diff(textured, rf, right),
    );
    eprintln!("{what} textures: left {l:.2e}, right {r:.2e}");
    assert!(l < 1e-5 && r < 1e-5, "{what}: left {l}, right {r}");
    assert!(max_rel_diff(lf, rf, left) > 0.05);
}

#[test]
fn extension_textures_scale_their_factors() {
    use serde_json::json;
    // Each half of the square samples one texel (nearest filtering), so a
    // textured material must render each half as the untextured material
    // whose factor is the factor times that texel. Columns within 4 pixels
    // of the seam (the pixel filter reaches across it) are left out.
    let (left, right) = (0..28, 36..64);
    let byte = |b: u8| b as f32 / 255.0;
    let srgb = |b: u8| soupray::trace::texture::srgb_to_linear(byte(b));
    let blank = png_uri([255; 4], [255; 4]);

    // transmissionTexture (R), through a KHR_texture_transform that mirrors
    // u (offset 1, scale -1): the left half reads the right texel.
    let glass = |factor: f32, texture: Option<serde_json::Value>| {
        let mut t = json!({"transmissionFactor": factor});
        if let Some(tex) = texture {
            t["transmissionTexture"] = tex;
        }
        json!({
            "pbrMetallicRoughness": {"baseColorFactor": [0.9, 0.8, 0.3, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.4},
            "doubleSided": true,
            "extensions": {"KHR_materials_transmission": t}
        })
    };
    let textured = render_textured_square(
        glass(
            0.9,
            Some(
                json!({"index": 0, "extensions": {"KHR_texture_transform": {"offset": [1.0, 0.0], "scale": [-1.0, 1.0]}}}),
            ),
        ),
        &png_uri([64, 0, 0, 255], [255, 0, 0, 255]),
    );
    let full = render_textured_square(glass(0.9 * byte(255), None), &blank);
    let quarter = render_textured_square(glass(0.9 * byte(64), None), &blank);
    let (l, r) = (
        max_rel_diff(&textured, &full, left.clone()),
        max_rel_diff(&textured, &quarter, right.clone()),
    );
    eprintln!(
        "transmission texture: left vs factor 0.9: {l:.2e}, right vs factor 0.9*64/255: {r:.2e}"
    );
    assert!(l < 1e-5 && r < 1e-5, "left {l}, right {r}");
    // The two factors give visibly different images, so the check above
    // would catch a texture that is ignored.
    assert!(max_rel_diff(&full, &quarter, left.clone()) > 0.05);

    // specularTexture (A) and specularColorTexture (RGB, sRGB) from one
    // image, on a black dielectric: only the specular layer shows.
    let coat = |factor: f32, color: [f32; 3], textured: bool| {
        let mut sp = json!({"specularFactor": factor, "specularColorFactor": color});
        if textured {
            sp["specularTexture"] = json!({"index": 0});
            sp["specularColorTexture"] = json!({"index": 0});
        }
        json!({
            "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.3},
            "extensions": {"KHR_materials_specular": sp}
        })
    };
    let textured = render_textured_square(
        coat(0.8, [1.0, 0.9, 0.7], true),
        &png_uri([255, 40, 0, 255], [0, 255, 128, 100]),
    );
    let lf = render_textured_square(coat(0.8, [srgb(255), 0.9 * srgb(40), 0.0], false), &blank);
    let rf = render_textured_square(
        coat(0.8 * byte(100), [0.0, 0.9, 0.7 * srgb(128)], false),
        &blank,
    );
    assert_halves_match("specular", &textured, &lf, &rf);
}

#[test]
fn layer_textures_scale_their_factors() {
    use serde_json::json;
    // As extension_textures_scale_their_factors, for the clear coat's and
    // the sheen's textures: each half must render as the untextured
    // material whose factors are the factors times that half's texel.
    let byte = |b: u8| b as f32 / 255.0;
    let srgb = |b: u8| soupray::trace::texture::srgb_to_linear(byte(b));
    let blank = png_uri([255; 4], [255; 4]);
    let base = json!({"baseColorFactor": [0.6, 0.2, 0.1, 1.0], "metallicFactor": 0.0, "roughnessFactor": 0.5});

    // clearcoatTexture (R) and clearcoatRoughnessTexture (G), one image.
    let coat = |factor: f32, roughness: f32, textured: bool| {
        let mut cc = json!({"clearcoatFactor": factor, "clearcoatRoughnessFactor": roughness});
        if textured {
            cc["clearcoatTexture"] = json!({"index": 0});
            cc["clearcoatRoughnessTexture"] = json!({"index": 0});
        }
        json!({"pbrMetallicRoughness": base, "extensions": {"KHR_materials_clearcoat": cc}})
    };
    let textured = render_textured_square(
        coat(0.9, 0.8, true),
        &png_uri([200, 60, 0, 255], [40, 230, 0, 255]),
    );
    let lf = render_textured_square(coat(0.9 * byte(200), 0.8 * byte(60), false), &blank);
    let rf = render_textured_square(coat(0.9 * byte(40), 0.8 * byte(230), false), &blank);
    assert_halves_match("clear coat", &textured, &lf, &rf);

    // sheenColorTexture (RGB, sRGB) and sheenRoughnessTexture (A).
    let sheen = |color: [f32; 3], roughness: f32, textured: bool| {
        let mut sh = json!({"sheenColorFactor": color, "sheenRoughnessFactor": roughness});
        if textured {
            sh["sheenColorTexture"] = json!({"index": 0});
            sh["sheenRoughnessTexture"] = json!({"index": 0});
        }
        json!({"pbrMetallicRoughness": base, "extensions": {"KHR_materials_sheen": sh}})
    };
    let textured = render_textured_square(
        sheen([1.0, 0.8, 0.6], 0.9, true),
        &png_uri([255, 128, 30, 200], [60, 200, 255, 50]),
    );
    let lf = render_textured_square(
        sheen(
            [srgb(255), 0.8 * srgb(128), 0.6 * srgb(30)],
            0.9 * byte(200),
            false,
        ),
        &blank,
    );
    let rf = render_textured_square(
        sheen(
            [srgb(60), 0.8 * srgb(200), 0.6 * srgb(255)],
            0.9 * byte(50),
            false,
        ),
        &blank,
    );
    assert_halves_match("sheen", &textured, &lf, &rf);
}

#[test]
fn clearcoat_normal_map_tilts_the_coat_and_the_base_normal_map_does_not() {
    use serde_json::json;
    use soupray::trace::material::{bsdf_eval, BsdfParams, Layers};
    // A rough coat (roughness 0.3) over black metal, head-on under a sun
    // and a black sky: every sample sees only the sun through the coat's
    // lobe, so the image is f(wo, sun) cos E everywhere, no noise. The
    // coat normal texel is tilted ~20 degrees and the sun placed at the
    // mirror of the view about it: the coat's glint. E comes from a
    // `--clay` render (0.8/pi cos E).
    let texel = [171u8, 128, 247, 255];
    let tilted = Vec3::new(
        texel[0] as f32 / 255.0 * 2.0 - 1.0,
        texel[1] as f32 / 255.0 * 2.0 - 1.0,
        texel[2] as f32 / 255.0 * 2.0 - 1.0,
    )
    .normalize();
    let sun = (tilted * (2.0 * tilted.z) - Vec3::Z).normalize();
    let uri = png_uri(texel, texel);
    let coat = |coat_map: bool, base_map: bool| {
        let mut cc = json!({"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.3});
        if coat_map {
            cc["clearcoatNormalTexture"] = json!({"index": 0});
        }
        let mut m = json!({
            "pbrMetallicRoughness": {"baseColorFactor": [0.0, 0.0, 0.0, 1.0], "metallicFactor": 1.0, "roughnessFactor": 1.0},
            "extensions": {"KHR_materials_clearcoat": cc}
        });
        if base_map {
            m["normalTexture"] = json!({"index": 0});
        }
        m
    };
    let black = ["--env-color", "0,0,0"];
    let mean = |img: &soupray::film::Image| {
        img.rgba
            .iter()
            .map(|p| (p[0] + p[1] + p[2]) as f64 / 3.0)
            .sum::<f64>()
            / img.rgba.len() as f64
    };
    let clay = mean(&render_square(
        coat(false, false),
        &uri,
        Some(sun),
        &["--env-color", "0,0,0", "--clay"],
    ));
    let irradiance = clay * std::f64::consts::PI / 0.8; // E cos(sun)
    let predict = |n: Vec3| {
        let mut p = BsdfParams::new([0.0; 3], 1.0, 1.0);
        p.energy_compensation = true;
        let p = p.with_layers(Layers::new(1.0, 0.3, [0.0; 3], 0.0).with_coat_normal(n));
        bsdf_eval(&p, Vec3::Z, sun).x as f64 * irradiance
    };
    let glint = mean(&render_square(coat(true, false), &uri, Some(sun), &black));
    let plain = mean(&render_square(coat(false, false), &uri, Some(sun), &black));
    let base_mapped = mean(&render_square(coat(false, true), &uri, Some(sun), &black));
    let (want_glint, want_plain) = (predict(tilted), predict(Vec3::Z));
    eprintln!(
        "coat normal map: {glint:.5} (reference {want_glint:.5}); none: {plain:.5} (reference {want_plain:.5}); \
         base normal map only: {base_mapped:.5}"
    );
    assert!(
        (glint - want_glint).abs() < 2e-3 * want_glint,
        "{glint} vs {want_glint}"
    );
    assert!(
        (plain - want_plain).abs() < 2e-3 * want_plain,
        "{plain} vs {want_plain}"
    );
    assert!(
        glint > 20.0 * plain,
        "the tilted coat should catch the sun: {glint} vs {plain}"
    );
    // The extension keeps the base's normal map off the coat.
    assert!(
        (base_mapped - plain).abs() < 0.01 * plain,
        "the base's normal map moved the coat: {base_mapped} vs {plain}"
    );
}
