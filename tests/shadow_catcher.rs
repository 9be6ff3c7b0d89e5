//! Shadow catchers and holdouts, for compositing a CG element onto a plate:
//! a sphere of radius 1 whose centre is 2 above a catching ground, seen
//! with `--transparent`. Under a sun straight overhead the ground is clear
//! (alpha 0) out of the shadow and opaque in it; under a white sky its
//! alpha is the share of the sky the sphere hides, weighted by the cosine,
//! against the analytic value sin^2(a) cos(t) of a cap of half-angle a
//! seen at angle t from the normal. A holdout cuts a hole (RGB and alpha
//! 0) even in front of the sphere.

// Pixels are indices into several channels at once.
#![allow(clippy::needless_range_loop)]

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use common::scene::Builder;
use glam::Vec3;
use serde_json::json;

const W: u32 = 96;
const H: u32 = 72;
const RADIUS: f32 = 1.0;
const HEIGHT: f32 = 2.0;
/// The camera: at (0, 6, 6) looking at the origin, 40 degrees tall.
const EYE: Vec3 = Vec3::new(0.0, 6.0, 6.0);
const YFOV: f32 = 0.698_131_7;

/// A latitude-longitude sphere (fine enough that its silhouette is within
/// 0.1% of the sphere's).
fn sphere(b: &mut Builder, centre: Vec3, r: f32) -> serde_json::Value {
    let (rings, segments) = (48u32, 96u32);
    let mut pos = Vec::new();
    for i in 0..=rings {
        let theta = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..=segments {
            let phi = std::f32::consts::TAU * j as f32 / segments as f32;
            let p = centre
                + r * Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                );
            pos.extend([p.x, p.y, p.z]);
        }
    }
    let mut idx = Vec::new();
    for i in 0..rings {
        for j in 0..segments {
            let a = i * (segments + 1) + j;
            let c = a + segments + 1;
            idx.extend([a, a + 1, c, a + 1, c + 1, c]);
        }
    }
    let p = b.floats(&pos, 3);
    let i = b.u32s(&idx);
    json!({"primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": 0}]})
}

fn quad(b: &mut Builder, corners: [Vec3; 4]) -> serde_json::Value {
    let pos: Vec<f32> = corners.iter().flat_map(|c| [c.x, c.y, c.z]).collect();
    let p = b.floats(&pos, 3);
    let i = b.u32s(&[0, 1, 2, 0, 2, 3]);
    json!({"primitives": [{"attributes": {"POSITION": p}, "indices": i, "material": 0}]})
}

/// The sphere over the ground (node "Ground"), a sun straight down when
/// `sun`, and with `card` a card (node "Card") between the camera and the
/// sphere; `ground_extras` goes on the ground node.
fn scene(dir: &Path, sun: bool, card: bool, ground_extras: serde_json::Value) -> PathBuf {
    let mut b = Builder::default();
    let ball = sphere(&mut b, Vec3::new(0.0, HEIGHT, 0.0), RADIUS);
    let g = 12.0;
    let ground = quad(
        &mut b,
        [
            Vec3::new(-g, 0.0, g),
            Vec3::new(g, 0.0, g),
            Vec3::new(g, 0.0, -g),
            Vec3::new(-g, 0.0, -g),
        ],
    );
    // A small card facing the camera, in front of the sphere's top.
    let card_mesh = quad(
        &mut b,
        [
            Vec3::new(-0.5, 3.1, 1.5),
            Vec3::new(0.5, 3.1, 1.5),
            Vec3::new(0.5, 3.9, 2.3),
            Vec3::new(-0.5, 3.9, 2.3),
        ],
    );
    let (s, c) = (
        (-std::f32::consts::FRAC_PI_8).sin(),
        std::f32::consts::FRAC_PI_8.cos(),
    );
    let mut nodes = vec![
        json!({"name": "Ball", "mesh": 0}),
        json!({"name": "Ground", "mesh": 1, "extras": ground_extras}),
        json!({"name": "Camera", "camera": 0, "translation": [EYE.x, EYE.y, EYE.z], "rotation": [s, 0.0, 0.0, c]}),
    ];
    let mut root = json!({
        "scene": 0,
        "meshes": [ball, ground, card_mesh],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.8, 0.8, 1.0], "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": YFOV, "znear": 0.1}}],
    });
    if card {
        nodes.push(json!({"name": "Card", "mesh": 2}));
    }
    if sun {
        let half = std::f32::consts::FRAC_PI_4;
        nodes.push(json!({"name": "Sun", "extensions": {"KHR_lights_punctual": {"light": 0}}, "rotation": [-half.sin(), 0.0, 0.0, half.cos()]}));
        root["extensionsUsed"] = json!(["KHR_lights_punctual"]);
        root["extensions"] =
            json!({"KHR_lights_punctual": {"lights": [{"type": "directional", "intensity": 3.0}]}});
    }
    root["scenes"] = json!([{"nodes": (0..nodes.len()).collect::<Vec<_>>()}]);
    root["nodes"] = json!(nodes);
    b.write(root, dir, "catch", true)
}

fn render(file: &Path, extra: &[&str]) -> BTreeMap<String, Vec<f32>> {
    let mut args = vec!["--transparent"];
    args.extend_from_slice(extra);
    let out = file.with_extension("out");
    common::exr_channels(&common::render_exr(file, (W, H), &out, "c.exr", &args))
}

/// The camera ray through the centre of pixel `i`.
fn ray(i: usize) -> Vec3 {
    let (px, py) = ((i % W as usize) as f32 + 0.5, (i / W as usize) as f32 + 0.5);
    let t = (YFOV / 2.0).tan();
    let sx = (px / W as f32 * 2.0 - 1.0) * t * W as f32 / H as f32;
    let sy = (1.0 - py / H as f32 * 2.0) * t;
    let forward = Vec3::new(0.0, -1.0, -1.0).normalize();
    let up = Vec3::new(0.0, 1.0, -1.0).normalize();
    (forward + Vec3::X * sx + up * sy).normalize()
}

/// Where pixel `i`'s centre sees the ground, when its ray (and the
/// filter's 1.5 px around it, approximated by a 0.15 margin) misses the
/// sphere and the card.
fn ground_point(i: usize) -> Option<Vec3> {
    let d = ray(i);
    let centre = Vec3::new(0.0, HEIGHT, 0.0);
    let along = (centre - EYE).dot(d);
    let miss = (EYE + d * along - centre).length();
    if miss < RADIUS + 0.15 {
        return None;
    }
    let t = -EYE.y / d.y;
    (t > 0.0).then(|| EYE + d * t)
}

#[test]
fn under_a_sun_the_catcher_is_clear_but_for_the_shadow() {
    let dir = tempfile::tempdir().unwrap();
    let file = scene(dir.path(), true, false, json!({}));
    let c = render(&file, &["--spp", "16", "--shadow-catcher", "Ground"]);
    let (mut lit, mut shadowed) = (0, 0);
    for i in 0..(W * H) as usize {
        let Some(p) = ground_point(i) else { continue };
        let from_axis = (p.x * p.x + p.z * p.z).sqrt();
        // The sun is straight overhead: the umbra is the sphere's disk.
        // Pixels within 0.25 of its edge (the filter's 1.5 px on the
        // ground) hold both.
        if from_axis > RADIUS + 0.25 {
            assert_eq!(
                (c["A"][i], c["R"][i]),
                (0.0, 0.0),
                "pixel {i} at {p}: clear ground"
            );
            assert_eq!(c["shadow.R"][i], 1.0);
            lit += 1;
        } else if from_axis < RADIUS - 0.25 {
            assert!(
                (c["A"][i] - 1.0).abs() < 1e-6,
                "pixel {i} at {p}: alpha {}",
                c["A"][i]
            );
            assert_eq!(c["shadow.G"][i], 0.0);
            // The shadow is black: it darkens the plate under it.
            assert_eq!(c["R"][i], 0.0);
            shadowed += 1;
        }
    }
    eprintln!("{lit} clear pixels, {shadowed} in the shadow");
    assert!(
        lit > 1000 && shadowed > 50,
        "{lit} clear, {shadowed} shadowed"
    );
}

#[test]
fn under_a_sky_the_shadow_is_the_share_of_sky_the_sphere_hides() {
    let dir = tempfile::tempdir().unwrap();
    // The catcher given by the file's extras this time.
    let file = scene(
        dir.path(),
        false,
        false,
        json!({"soupray": {"shadow_catcher": true}}),
    );
    let c = render(&file, &["--spp", "256", "--env-color", "1,1,1"]);
    // Rings around the point under the sphere: measured and analytic
    // alpha, averaged over each ring's pixels.
    let mut rings = [(0.0f64, 0.0f64, 0usize); 3];
    for i in 0..(W * H) as usize {
        let Some(p) = ground_point(i) else { continue };
        let to_centre = Vec3::new(0.0, HEIGHT, 0.0) - p;
        let dist = to_centre.length();
        let sin_a = RADIUS / dist;
        let cos_t = HEIGHT / dist;
        // The cap must stay above the horizon for the formula.
        if sin_a.asin() + cos_t.acos() > 1.45 {
            continue;
        }
        let ring = (p.x * p.x + p.z * p.z).sqrt() as usize;
        if ring < rings.len() {
            let want = sin_a * sin_a * cos_t;
            rings[ring].0 += c["A"][i] as f64;
            rings[ring].1 += want as f64;
            rings[ring].2 += 1;
        }
    }
    for (k, (got, want, n)) in rings.iter().enumerate() {
        assert!(*n > 30, "ring {k}: {n} pixels");
        let (got, want) = (got / *n as f64, want / *n as f64);
        eprintln!(
            "ring {k}..{}: alpha {got:.4}, analytic {want:.4} ({n} pixels)",
            k + 1
        );
        assert!(
            (got - want).abs() < 0.03 * want,
            "ring {k}: alpha {got:.4} against the analytic {want:.4}"
        );
    }
}

#[test]
fn a_holdout_cuts_a_hole_even_in_front_of_the_sphere() {
    let dir = tempfile::tempdir().unwrap();
    let file = scene(dir.path(), true, true, json!({}));
    let plain = render(&file, &["--spp", "16"]);
    let cut = render(&file, &["--spp", "16", "--holdout", "Card"]);
    let (mut hole, mut same) = (0, 0);
    for i in 0..(W * H) as usize {
        if plain["A"][i] == 1.0 && cut["A"][i] == 0.0 {
            assert_eq!(
                [cut["R"][i], cut["G"][i], cut["B"][i]],
                [0.0; 3],
                "pixel {i}"
            );
            hole += 1;
        } else if cut["A"][i] == plain["A"][i] {
            same += 1;
        }
    }
    // The card covers about 0.6 x 0.85 units at 6 from the camera.
    assert!(hole > 40, "{hole} pixels cut");
    assert!(
        same > (W * H) as usize - 4 * hole,
        "{same} pixels unchanged"
    );
}

#[test]
fn an_unknown_node_is_refused_with_the_fix() {
    let dir = tempfile::tempdir().unwrap();
    let file = scene(dir.path(), true, true, json!({}));
    let run = common::soupray(&[
        "render",
        file.to_str().unwrap(),
        "--shadow-catcher",
        "Floor",
    ]);
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("--shadow-catcher Floor: no node has that name or index")
            && err.contains("Fix"),
        "{err}"
    );
}
