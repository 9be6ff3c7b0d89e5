//! The material extensions, device against reference and renders against
//! analytic values, one module per topic: the dielectric layer
//! (`dielectric`), energy tables and compensation (`energy`), the other
//! extensions and their textures (`extensions`), diffuse transmission,
//! iridescence, anisotropy and dispersion. This file holds what several of
//! them use: the BSDF probe cases and their check, and the scenes.

#[path = "../common/mod.rs"]
mod common;

mod anisotropy;
mod dielectric;
mod diffuse_roughness;
mod diffuse_transmission;
mod dispersion;
mod energy;
mod extensions;
mod iridescence;
mod layering;

use common::render::*;
use common::{
    albedo, check_bsdf_probe, close, random_dir, random_upper_dir, run_probe, sphere_albedo,
    BsdfProbeTally, Rng,
};
use glam::Vec3;
use soupray::scene::Material;
use soupray::soup::Soup;
use soupray::trace::material::{
    bsdf_eval, bsdf_pdf, bsdf_sample, f0_of_ior, BsdfParams, Dielectric,
};
use soupray::trace::render::{render_soup, Environment};

/// A random outgoing direction above the surface, a random direction
/// anywhere, and the sampler's three random numbers.
fn random_case(rng: &mut Rng) -> (Vec3, Vec3, [f32; 3]) {
    let wo = random_upper_dir(rng);
    let wi = random_dir(rng);
    (wo, wi, [rng.f32(), rng.f32(), rng.f32()])
}

/// Runs `bsdf_ext_probe` (built with `defines`) on `cases` (parameters with
/// the dielectric extensions, wo, wi, random numbers) and holds each to
/// the Rust reference within `rel`. The kernel reads the parameters (12
/// floats), wo, wi and u (12), and with the diffuse transmission,
/// iridescence or diffuse roughness defines the diffuse transmission and
/// its colour, the film's weight, index and thickness, and the diffuse
/// roughness (8).
fn check_ext_probe(
    d: &soupray::device::Device,
    defines: &[&'static str],
    cases: &[(BsdfParams, Vec3, Vec3, [f32; 3])],
    rel: f32,
) -> BsdfProbeTally {
    let extended = defines.iter().any(|&k| {
        k == "HAS_DIFFUSE_TRANSMISSION" || k == "HAS_IRIDESCENCE" || k == "HAS_DIFFUSE_ROUGHNESS"
    });
    let mut input = Vec::new();
    for (p, wo, wi, u) in cases {
        let dl = p.dielectric.unwrap();
        input.extend_from_slice(&common::dielectric_probe_params(p, &dl));
        // wo's fourth float: alpha_t, read with HAS_ANISOTROPY.
        input.extend_from_slice(&[wo.x, wo.y, wo.z, p.alpha_t, wi.x, wi.y, wi.z, 0.0]);
        input.extend_from_slice(&[u[0], u[1], u[2], 0.0]);
        if extended {
            let c = dl.diffuse_transmission_color;
            input.extend_from_slice(&[dl.diffuse_transmission, c.x, c.y, c.z]);
            input.extend_from_slice(&[
                dl.iridescence,
                dl.iridescence_ior,
                dl.iridescence_thickness,
                dl.diffuse_roughness,
            ]);
        }
    }
    let defines: Vec<(&str, String)> = defines.iter().map(|&k| (k, "1".to_owned())).collect();
    let program = d.build_program("pt_probe.cl", &defines).unwrap();
    let k = d.kernel(&program, "bsdf_ext_probe").unwrap();
    let n = cases.len();
    let got: Vec<f32> = run_probe(d, &k, &input, n, 12 * n);
    let mut tally = BsdfProbeTally::default();
    for (i, (p, wo, wi, u)) in cases.iter().enumerate() {
        let what = format!("case {i} {p:?} wo {wo} wi {wi}");
        check_bsdf_probe(
            &got[12 * i..12 * i + 12],
            p,
            *wo,
            *wi,
            *u,
            rel,
            &what,
            &mut tally,
        );
    }
    tally
}

fn glass(transmission: f32, ior: f32, volume: bool) -> Material {
    Material {
        transmission_factor: transmission,
        ior,
        thickness_factor: if volume { 1.0 } else { 0.0 },
        double_sided: true,
        ..material([1.0; 4], 0.0, 0.0)
    }
}

/// A unit ball of `m` in a white furnace (24x24, 64 spp, 24 bounces): the
/// mean and standard error of the pixels it covers.
fn ball_in_white_furnace(m: Material) -> (f64, f64) {
    let v = covered(&ball_in_white_furnace_image(m));
    assert!(v.len() > 150, "the ball covers {} pixels", v.len());
    mean_se(&v)
}

/// The image `ball_in_white_furnace` measures.
fn ball_in_white_furnace_image(m: Material) -> soupray::film::Image {
    ball_in_white_furnace_sized(m, 24, 64)
}

/// `ball_in_white_furnace_image` at `size` x `size` pixels and `spp`.
fn ball_in_white_furnace_sized(m: Material, size: u32, spp: u32) -> soupray::film::Image {
    let d = common::device();
    let cam = perspective(Vec3::new(0.0, 0.0, 3.5), Vec3::ZERO, Vec3::Y, 40.0);
    let mut st = settings(size, spp);
    st.max_depth = 24;
    st.environment = Environment::Color([1.0, 1.0, 1.0]);
    let mut s = Soup::default();
    sphere(&mut s, Vec3::ZERO, 1.0, 16, 32, 0);
    render_soup(&d, &s, &table(vec![m]), &cam, &[], &st, 0)
        .unwrap()
        .image
}

/// The mean and its standard error of each colour channel over the pixels
/// an object covers fully.
fn covered_channels(img: &soupray::film::Image) -> [(f64, f64); 3] {
    let inside: Vec<&[f32; 4]> = img.rgba.iter().filter(|p| p[3] == 1.0).collect();
    assert!(inside.len() > 150, "{} pixels covered", inside.len());
    [0, 1, 2].map(|c| mean_se(&inside.iter().map(|p| p[c] as f64).collect::<Vec<_>>()))
}

/// The image `slab_transmittance` measures, at `spp`.
fn slab_image(mat: Material, half: f32, spp: u32) -> soupray::film::Image {
    let d = common::device();
    let mut s = Soup::default();
    // A box 4 x 4 wide, 2 * half thick.
    let (w, h) = (2.0, half);
    for (n, c, u, v) in [
        (Vec3::Z, Vec3::Z * h, Vec3::X * w, Vec3::Y * w),
        (Vec3::NEG_Z, Vec3::NEG_Z * h, Vec3::X * w, Vec3::Y * w),
        (Vec3::X, Vec3::X * w, Vec3::Y * w, Vec3::Z * h),
        (Vec3::NEG_X, Vec3::NEG_X * w, Vec3::Y * w, Vec3::Z * h),
        (Vec3::Y, Vec3::Y * w, Vec3::X * w, Vec3::Z * h),
        (Vec3::NEG_Y, Vec3::NEG_Y * w, Vec3::X * w, Vec3::Z * h),
    ] {
        quad(&mut s, c, u, v, n, 0);
    }
    quad(
        &mut s,
        Vec3::new(0.0, 0.0, -3.0),
        Vec3::X * 10.0,
        Vec3::Y * 10.0,
        Vec3::Z,
        1,
    );
    let mut emitter = material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
    emitter.emissive_factor = [1.0; 3];
    let t = table(vec![mat, emitter]);
    let cam = orthographic(Vec3::new(0.0, 0.0, 5.0), Vec3::ZERO, Vec3::Y, 0.5);
    let mut st = settings(8, spp);
    st.max_depth = 24;
    st.environment = Environment::Color([0.0; 3]);
    render_soup(&d, &s, &t, &cam, &[], &st, 0).unwrap().image
}

/// A 2x1 RGBA PNG (left texel, right texel) as a data URI.
fn png_uri(left: [u8; 4], right: [u8; 4]) -> String {
    let img = image::RgbaImage::from_raw(2, 1, [left, right].concat()).unwrap();
    let mut png = std::io::Cursor::new(Vec::new());
    img.write_to(&mut png, image::ImageFormat::Png).unwrap();
    format!(
        "data:image/png;base64,{}",
        common::scene::base64(png.get_ref())
    )
}

/// As `render_textured_square`, lit by a directional light of intensity 3
/// arriving from `sun` (unit, world; the square faces +z) when given, with
/// the extra options `args` (the sky's colour among them).
fn render_square(
    material: serde_json::Value,
    uri: &str,
    sun: Option<Vec3>,
    args: &[&str],
) -> soupray::film::Image {
    use serde_json::json;
    let dir = tempfile::tempdir().unwrap();
    let mut b = common::scene::Builder::default();
    let p = b.floats(
        &[
            -1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0,
        ],
        3,
    );
    let n = b.floats(&[0.0, 0.0, 1.0].repeat(4), 3);
    let uv = b.floats(&[0.0, 1.0, 1.0, 1.0, 1.0, 0.0, 0.0, 0.0], 2);
    let ix = b.u32s(&[0, 1, 2, 0, 2, 3]);
    let mut root = json!({
        "extensionsUsed": ["KHR_texture_transform", "KHR_materials_transmission", "KHR_materials_specular",
                           "KHR_materials_clearcoat", "KHR_materials_sheen", "KHR_materials_diffuse_transmission",
                           "KHR_materials_iridescence", "KHR_materials_diffuse_roughness", "KHR_lights_punctual"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0.0, 0.0, 3.0]}],
        "cameras": [{"type": "orthographic", "orthographic": {"xmag": 0.9, "ymag": 0.45, "znear": 0.01, "zfar": 100.0}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": p, "NORMAL": n, "TEXCOORD_0": uv}, "indices": ix, "material": 0}]}],
        "materials": [material],
        "images": [{"uri": uri}],
        "samplers": [{"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}],
        "textures": [{"source": 0, "sampler": 0}],
    });
    if let Some(sun) = sun {
        // A directional light shines along its node's -z: turn +z to `sun`.
        let q = glam::Quat::from_rotation_arc(Vec3::Z, sun);
        root["extensions"] =
            json!({"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 3.0}]}});
        root["nodes"].as_array_mut().unwrap().push(json!({
            "rotation": [q.x, q.y, q.z, q.w],
            "extensions": {"KHR_lights_punctual": {"light": 0}}
        }));
        root["scenes"][0]["nodes"] = json!([0, 1, 2]);
    }
    let scene = b.write(root, dir.path(), "square", true);
    let out = common::soupray_cmd()
        .arg("render")
        .arg(&scene)
        .args([
            "--frame", "0", "--width", "64", "--height", "32", "--spp", "16",
        ])
        .args(["--seed", "5", "--quiet"])
        .args(args)
        .args([
            "--out",
            dir.path().to_str().unwrap(),
            "--name",
            "sq.####.exr",
        ])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let log = std::fs::read_to_string(dir.path().join("sq.0000.json")).unwrap();
    assert!(
        !log.contains("is not supported") && !log.contains("ignores"),
        "an extension or texture was reported as ignored: {log}"
    );
    common::read_exr(&dir.path().join("sq.0000.exr"))
}

/// `render_square` of `square` under a sun from `sun` and a black sky, as
/// `--clay` and as itself.
fn square_under_a_sun(
    square: serde_json::Value,
    uri: &str,
    sun: Vec3,
) -> (soupray::film::Image, soupray::film::Image) {
    let clay = render_square(
        square.clone(),
        uri,
        Some(sun),
        &["--env-color", "0,0,0", "--clay"],
    );
    let img = render_square(square, uri, Some(sun), &["--env-color", "0,0,0"]);
    (clay, img)
}

/// For a square under a sun and a black sky seen head-on (`img`), the
/// largest relative error over columns `cols` against `f` E cos, E cos from
/// the `--clay` render of the same scene (0.8 / pi E cos); and the last
/// pixel's value.
fn worst_against_sun_reference(
    clay: &soupray::film::Image,
    img: &soupray::film::Image,
    cols: std::ops::Range<usize>,
    f: Vec3,
) -> (f32, [f32; 3]) {
    let mut worst = 0.0f32;
    let mut at = [0.0f32; 3];
    for y in 0..clay.height as usize {
        for x in cols.clone() {
            let i = y * clay.width as usize + x;
            let e_cos = clay.rgba[i][0] / 0.8 * std::f32::consts::PI;
            for c in 0..3 {
                let want = f[c] * e_cos;
                worst = worst.max((img.rgba[i][c] - want).abs() / want);
            }
            at = [img.rgba[i][0], img.rgba[i][1], img.rgba[i][2]];
        }
    }
    (worst, at)
}
