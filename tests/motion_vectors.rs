//! Motion vectors (`--aov motion`) against analytic motion: a sliding card,
//! a turning bar and a moving camera, each animated in glTF and seen at
//! frame 24 (t = 1 s). Every pixel that sees only the moving surface must
//! carry the motion of the surface point at its centre, to the frame
//! before (Vector.X, Y) and to the next (Vector.Z, W), in pixels with y up,
//! within 0.05 px.

mod common;

use std::path::{Path, PathBuf};

use common::scene::Builder;
use glam::Vec2;
use serde_json::json;

const SIZE: u32 = 64;
/// Pixels per scene unit on the plane z = 0: the orthographic camera's xmag
/// 1 spans SIZE pixels over 2 units, and the perspective camera (at z = 5,
/// tan(yfov / 2) = 0.2) sees the same 2 units there.
const SCALE: f32 = SIZE as f32 / 2.0;
const FPS: f32 = 24.0;
/// The tolerance the vectors must meet.
const TOLERANCE: f32 = 0.05;

/// A scene of one card mesh on node 0, animated by `animation` (channels
/// on node 0 or the camera, node 1), seen by `camera`.
fn scene(
    dir: &Path,
    name: &str,
    card: [f32; 4],
    camera: serde_json::Value,
    animate: &[(usize, &str, &[f32], &[f32])],
) -> PathBuf {
    let mut b = Builder::default();
    let positions = [
        card[0], card[2], 0.0, card[1], card[2], 0.0, card[1], card[3], 0.0, card[0], card[3], 0.0,
    ];
    let pos = b.floats(&positions, 3);
    let idx = b.u32s(&[0, 1, 2, 0, 2, 3]);
    let mut samplers = Vec::new();
    let mut channels = Vec::new();
    for (i, &(node, path, times, values)) in animate.iter().enumerate() {
        let input = b.floats(times, 1);
        let width = values.len() / times.len();
        let output = b.floats(values, width);
        b.accessors[input]["min"] = json!([times[0]]);
        b.accessors[input]["max"] = json!([times[times.len() - 1]]);
        samplers.push(json!({"input": input, "output": output, "interpolation": "LINEAR"}));
        channels.push(json!({"sampler": i, "target": {"node": node, "path": path}}));
    }
    let root = json!({
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"name": "Card", "mesh": 0},
            {"name": "Camera", "camera": 0, "translation": [0.0, 0.0, 5.0]},
        ],
        "meshes": [{"primitives": [{"attributes": {"POSITION": pos}, "indices": idx}]}],
        "cameras": [camera],
        "animations": [{"samplers": samplers, "channels": channels}],
    });
    b.write(root, dir, name, true)
}

fn orthographic() -> serde_json::Value {
    json!({"type": "orthographic", "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 100.0}})
}

fn perspective() -> serde_json::Value {
    json!({"type": "perspective", "perspective": {"yfov": 2.0 * 0.2f32.atan(), "znear": 0.1}})
}

/// Frame 24's alpha and vectors (x, y, z, w per pixel, rows top first).
fn render(file: &Path, extra: &[&str]) -> (Vec<f32>, Vec<[f32; 4]>) {
    let mut args = vec![
        "--frame",
        "24",
        "--spp",
        "16",
        "--env-color",
        "1,1,1",
        "--aov",
        "motion",
    ];
    args.extend_from_slice(extra);
    let out = file.with_extension("out");
    common::render_exr(file, (SIZE, SIZE), &out, "f.####.exr", &args);
    let c = common::exr_channels(&out.join("f.0024.exr"));
    let v = (0..c["A"].len())
        .map(|i| {
            [
                c["Vector.X"][i],
                c["Vector.Y"][i],
                c["Vector.Z"][i],
                c["Vector.W"][i],
            ]
        })
        .collect();
    (c["A"].clone(), v)
}

/// The scene point (z = 0) at the centre of pixel `i`.
fn point_of(i: usize) -> Vec2 {
    let (col, row) = ((i % SIZE as usize) as f32, (i / SIZE as usize) as f32);
    Vec2::new((col + 0.5) / SCALE - 1.0, 1.0 - (row + 0.5) / SCALE)
}

/// Pixels whose every sample saw the card: they and their neighbours two
/// pixels around (past the filter's 1.5 px radius) have alpha 1.
fn interior(alpha: &[f32]) -> Vec<usize> {
    let n = SIZE as i64;
    (0..alpha.len())
        .filter(|&i| {
            let (x, y) = (i as i64 % n, i as i64 / n);
            (-2..=2).all(|dy| {
                (-2..=2).all(|dx| {
                    let (u, v) = (x + dx, y + dy);
                    (0..n).contains(&u) && (0..n).contains(&v) && alpha[(v * n + u) as usize] == 1.0
                })
            })
        })
        .collect()
}

/// Every interior pixel's vectors against `want(point)` (pixels, y up).
fn check(name: &str, alpha: &[f32], v: &[[f32; 4]], want: impl Fn(Vec2) -> [f32; 4]) {
    let pixels = interior(alpha);
    assert!(
        pixels.len() > 50,
        "{name}: {} interior pixels",
        pixels.len()
    );
    let mut worst = 0.0f32;
    for &i in &pixels {
        let w = want(point_of(i));
        for k in 0..4 {
            let err = (v[i][k] - w[k]).abs();
            worst = worst.max(err);
            assert!(
                err < TOLERANCE,
                "{name}: pixel {i} at {:?}: vectors {:?}, analytic {w:?}",
                point_of(i),
                v[i]
            );
        }
    }
    eprintln!("{name}: {} pixels, worst error {worst:.4} px", pixels.len());
    // Where nothing was hit there is no motion.
    let empty = alpha
        .iter()
        .position(|&a| a == 0.0)
        .expect("a background pixel");
    assert_eq!(v[empty], [0.0; 4], "{name}: background");
}

#[test]
fn a_sliding_card_moves_by_its_speed_per_frame() {
    let dir = tempfile::tempdir().unwrap();
    // 1 unit per second along x.
    let file = scene(
        dir.path(),
        "slide",
        [-0.9, -0.1, -0.5, 0.5],
        orthographic(),
        &[(
            0,
            "translation",
            &[0.0, 2.0],
            &[0.0, 0.0, 0.0, 2.0, 0.0, 0.0],
        )],
    );
    let step = SCALE / FPS;
    for blur in [false, true] {
        let extra: &[&str] = if blur { &["--motion-blur"] } else { &[] };
        let (alpha, v) = render(&file, extra);
        let name = if blur {
            "sliding card, motion blur"
        } else {
            "sliding card"
        };
        check(name, &alpha, &v, |_| [step, 0.0, step, 0.0]);
    }
}

#[test]
fn a_turning_bar_moves_each_point_along_its_circle() {
    let dir = tempfile::tempdir().unwrap();
    // A quarter turn about z in 2 s (slerp: constant angular speed).
    let (s, c) = (
        std::f32::consts::FRAC_PI_4.sin(),
        std::f32::consts::FRAC_PI_4.cos(),
    );
    let file = scene(
        dir.path(),
        "turn",
        [-0.85, 0.85, -0.2, 0.2],
        orthographic(),
        &[(
            0,
            "rotation",
            &[0.0, 2.0],
            &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, s, c],
        )],
    );
    let (alpha, v) = render(&file, &[]);
    let per_frame = std::f32::consts::FRAC_PI_4 / FPS;
    let turn =
        |p: Vec2, a: f32| Vec2::new(p.x * a.cos() - p.y * a.sin(), p.x * a.sin() + p.y * a.cos());
    check("turning bar", &alpha, &v, |p| {
        let before = (p - turn(p, -per_frame)) * SCALE;
        let after = (turn(p, per_frame) - p) * SCALE;
        [before.x, before.y, after.x, after.y]
    });
}

#[test]
fn a_moving_camera_moves_the_still_scene_the_other_way() {
    let dir = tempfile::tempdir().unwrap();
    // The camera slides 0.5 units per second along x, 5 units from the card.
    let file = scene(
        dir.path(),
        "pan",
        [-0.6, 0.6, -0.6, 0.6],
        perspective(),
        &[(
            1,
            "translation",
            &[0.0, 2.0],
            &[0.0, 0.0, 5.0, 1.0, 0.0, 5.0],
        )],
    );
    let (alpha, v) = render(&file, &[]);
    let step = -0.5 * SCALE / FPS;
    check("moving camera", &alpha, &v, |_| [step, 0.0, step, 0.0]);
}
