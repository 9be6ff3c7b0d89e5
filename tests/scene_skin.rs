//! Skinning: SimpleSkin worked out by hand; the rigged sample figures
//! compared joint by joint and corner by corner with the tests' independent
//! reference evaluator (nalgebra, f64); and generated files for mirrored
//! skins, JOINTS_1/WEIGHTS_1 and quantized weights.

mod common;

use common::scene::{assert_soup_matches, asset, bounds_of, load, skinned_triangle, Builder, Raw};
use nalgebra::Vector3;
use serde_json::json;

fn near(p: [f32; 3], q: [f64; 3], tol: f64) -> bool {
    (0..3).all(|a| (p[a] as f64 - q[a]).abs() <= tol)
}

#[test]
fn simple_skin_by_hand() {
    let Some(simple_skin_gltf) = asset("SimpleSkin/SimpleSkin.gltf") else {
        return;
    };
    let scene = load(&simple_skin_gltf, None);
    // t = 1 s is key 2 exactly: joint node 2 is turned 90 degrees about z
    // (quaternion 0.707, 0.707, normalised) about its bind position
    // (0, 1, 0) (inverse bind matrix is a translation by -1 in y).
    let frame = scene.evaluate(1.0).unwrap();
    let soup = &frame.soup;
    // Indices: triangle 6 = (6, 7, 9), triangle 7 = (6, 9, 8), triangle 3 =
    // (2, 5, 4), triangle 0 = (0, 1, 3).
    // Vertex 9 (0.5, 2, 0), all on joint 1: (0.5, 1) about (0,1) -> (-1, 1.5).
    assert!(
        near(soup.corner(6, 2), [-1.0, 1.5, 0.0], 1e-5),
        "{:?}",
        soup.corner(6, 2)
    );
    // Vertex 8 (-0.5, 2, 0): (-0.5, 1) -> (-1, -0.5) + (0, 1) = (-1, 0.5).
    assert!(
        near(soup.corner(7, 2), [-1.0, 0.5, 0.0], 1e-5),
        "{:?}",
        soup.corner(7, 2)
    );
    // Vertex 4 (-0.5, 1, 0), half on each joint: ((-0.5,1) + (0,0.5)) / 2.
    assert!(
        near(soup.corner(3, 2), [-0.25, 0.75, 0.0], 1e-5),
        "{:?}",
        soup.corner(3, 2)
    );
    // Vertices 0 and 1 are fully on the unanimated root joint.
    assert!(
        near(soup.corner(0, 0), [-0.5, 0.0, 0.0], 1e-6)
            && near(soup.corner(0, 1), [0.5, 0.0, 0.0], 1e-6)
    );

    // t = 0.25 s: halfway between identity and the key at 0.5 s, a turn of
    // 2*atan2(0.383, 0.924) (stored values); slerp gives half that angle.
    let raw = Raw::open(&simple_skin_gltf);
    let key1 = &raw.accessor(6)[1];
    let angle = (2.0 * key1[2].atan2(key1[3])) / 2.0;
    let frame = scene.evaluate(0.25).unwrap();
    let (s, c) = angle.sin_cos();
    // Vertex 9 relative to the pivot is (0.5, 1): rotated by `angle`.
    let rotated = [0.5 * c - 1.0 * s, 1.0 + 0.5 * s + 1.0 * c, 0.0];
    assert!(
        near(frame.soup.corner(6, 2), rotated, 1e-5),
        "{:?} vs {rotated:?}",
        frame.soup.corner(6, 2)
    );
}

/// Joint world positions and the whole soup against the reference.
fn check_figure(file: &str, animation: Option<&str>, frames: &[i64], tol: f64) {
    let Some(path) = asset(file) else {
        return;
    };
    let scene = load(&path, animation);
    let raw = Raw::open(&path);
    let anim = match animation {
        Some(name) => raw.animation_index(name),
        None => 0,
    };
    let skin = &scene.skins()[0];
    for &f in frames {
        let t = scene.time_of_frame(f);
        let what = format!("{file} {animation:?} frame {f}");
        let reference_worlds = raw.worlds(Some(anim), t);
        let pose = scene.pose(t);
        for &j in &skin.joints {
            let ours = pose.world_from_node[j].w_axis;
            let theirs = reference_worlds[j].column(3);
            for a in 0..3 {
                assert!(
                    (ours[a] as f64 - theirs[a]).abs() <= tol,
                    "{what}: joint node {j} at {ours:?}, reference {theirs:?}"
                );
            }
        }
        let reference = raw.soup(Some(anim), t);
        let frame = scene.evaluate(t).unwrap();
        assert_soup_matches(&frame.soup, &reference, tol, &what);
        let (lo, hi) = bounds_of(&reference);
        let (slo, shi) = frame.soup.bounds().unwrap();
        for a in 0..3 {
            assert!(
                (slo[a] as f64 - lo[a]).abs() <= tol && (shi[a] as f64 - hi[a]).abs() <= tol,
                "{what}: bounds"
            );
        }
    }
}

#[test]
fn rigged_simple_matches_reference() {
    check_figure(
        "RiggedSimple/RiggedSimple.glb",
        None,
        &[0, 13, 25, 50],
        1e-4,
    );
}

#[test]
fn rigged_figure_matches_reference() {
    check_figure("RiggedFigure/RiggedFigure.glb", None, &[0, 7, 15, 30], 1e-4);
}

#[test]
fn cesium_man_matches_reference() {
    check_figure("CesiumMan/CesiumMan.gltf", None, &[0, 17, 48], 1e-4);
}

#[test]
fn fox_matches_reference_in_all_three_clips() {
    // The fox is about 150 units long; f32 skinning keeps ~1e-5 relative.
    check_figure("Fox/Fox.glb", Some("Survey"), &[0, 40, 82], 2e-3);
    check_figure("Fox/Fox.glb", Some("Walk"), &[0, 5, 17], 2e-3);
    check_figure("Fox/Fox.glb", Some("Run"), &[3, 14, 28], 2e-3);
}

fn geometric_normal(soup: &soupray::soup::Soup, t: usize) -> Vector3<f64> {
    let c: Vec<Vector3<f64>> = (0..3)
        .map(|k| {
            let p = soup.corner(t, k);
            Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64)
        })
        .collect();
    (c[1] - c[0]).cross(&(c[2] - c[0])).normalize()
}

#[test]
fn mirrored_skin_keeps_the_winding_facing_its_normals() {
    let dir = tempfile::tempdir().unwrap();
    // Joint mirrored in x; the skinned mesh node's own translation (100)
    // must be ignored, and absent inverse bind matrices are identities.
    let path = skinned_triangle(
        dir.path(),
        json!({"scale": [-1.0, 1.0, 1.0]}),
        [100.0, 0.0, 0.0],
    );
    let scene = load(&path, None);
    let soup = scene.evaluate(0.0).unwrap().soup;
    // Corners, as a set, are the mirror images: (0,0,0), (-1,0,0), (0,1,0).
    let mut corners: Vec<[f32; 3]> = (0..3).map(|k| soup.corner(0, k)).collect();
    corners.sort_by(|a, b| a.partial_cmp(b).unwrap());
    assert_eq!(
        corners,
        vec![[-1.0, 0.0, 0.0], [0.0, 0.0, 0.0], [0.0, 1.0, 0.0]]
    );
    // Mirroring x keeps a +z face facing +z: the shading normals stay +z
    // (inverse transpose of diag(-1,1,1)), and the corners were swapped so
    // the counter-clockwise winding gives +z too.
    let g = geometric_normal(&soup, 0);
    assert!((g - Vector3::z()).norm() < 1e-6, "geometric normal {g}");
    for k in 0..3 {
        let n = soup.normals[k];
        assert!((n[2] - 1.0).abs() < 1e-6, "shading normal {n:?}");
    }

    // The same mirror on a rigid (unskinned) node.
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let path = b.write(
        json!({"scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0, "scale": [1.0, 1.0, -1.0]}],
               "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}]}),
        dir.path(),
        "rigid_mirror",
        true,
    );
    let soup = load(&path, None).evaluate(0.0).unwrap().soup;
    // Mirroring z turns the +z face to face -z.
    let g = geometric_normal(&soup, 0);
    assert!((g + Vector3::z()).norm() < 1e-6, "geometric normal {g}");
}

#[test]
fn second_influence_set_and_quantized_weights_are_used_and_renormalised() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    // Every vertex: set 0 puts 64/255 on joint 0, set 1 puts 64/255 on
    // joint 1 (u8 normalized; the sum is 0.502, not 1). Renormalised, each
    // joint gets one half.
    let j0 = b.u8s(&[0; 12], 4, false);
    let w0 = b.u8s(&[64, 0, 0, 0, 64, 0, 0, 0, 64, 0, 0, 0], 4, true);
    let j1 = b.u16s(&[1, 0, 0, 0, 1, 0, 0, 0, 1, 0, 0, 0], 4, false);
    let w1 = b.u8s(&[64, 0, 0, 0, 64, 0, 0, 0, 64, 0, 0, 0], 4, true);
    // Inverse bind matrices: joint 1's bind pose is at x = 1.
    let ibm = b.floats(
        &[
            [
                1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
            ],
            [
                1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -1.0, 0.0, 0.0, 1.0,
            ],
        ]
        .concat(),
        16,
    );
    let path = b.write(
        json!({
            "scenes": [{"nodes": [0, 1, 2]}],
            "nodes": [{"mesh": 0, "skin": 0}, {"name": "j0"}, {"name": "j1", "translation": [1.0, 0.0, 4.0]}],
            "skins": [{"joints": [1, 2], "inverseBindMatrices": ibm}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos,
                "JOINTS_0": j0, "WEIGHTS_0": w0, "JOINTS_1": j1, "WEIGHTS_1": w1}}]}]
        }),
        dir.path(),
        "two_sets",
        false,
    );
    let scene = load(&path, None);
    assert_eq!(scene.max_influence_sets(), 2);
    assert!(scene.has_skins());
    // Joint 1 moved by (0, 0, 4) from its bind pose: half of that.
    let soup = scene.evaluate(0.0).unwrap().soup;
    assert!(
        near(soup.corner(0, 0), [0.0, 0.0, 2.0], 1e-6),
        "{:?}",
        soup.corner(0, 0)
    );
    assert!(
        near(soup.corner(0, 1), [1.0, 0.0, 2.0], 1e-6),
        "{:?}",
        soup.corner(0, 1)
    );
}

#[test]
fn morph_normals_are_blended_before_skinning() {
    let dir = tempfile::tempdir().unwrap();
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let nrm = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], 3);
    let dpos = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 3);
    let dnrm = b.floats(&[1.0, 0.0, -1.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0], 3);
    let joints = b.u8s(&[0; 12], 4, false);
    let weights = b.floats(
        &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        4,
    );
    // Joint turned 90 degrees about y: (x, y, z) -> (z, y, -x).
    let s = std::f32::consts::FRAC_1_SQRT_2;
    let path = b.write(
        json!({
            "scenes": [{"nodes": [0, 1]}],
            "nodes": [{"mesh": 0, "skin": 0, "weights": [0.5]}, {"rotation": [0.0, s, 0.0, s]}],
            "skins": [{"joints": [1]}],
            "meshes": [{"weights": [0.0], "primitives": [{"attributes": {"POSITION": pos, "NORMAL": nrm,
                "JOINTS_0": joints, "WEIGHTS_0": weights}, "targets": [{"POSITION": dpos, "NORMAL": dnrm}]}]}]
        }),
        dir.path(),
        "morph_skin",
        true,
    );
    let scene = load(&path, None);
    let frame = scene.evaluate(0.0).unwrap();
    // Node weights (0.5) override mesh weights (0). Vertex 0 morphs to
    // (0, 0, 0.5) and its normal to (0.5, 0, 0.5); skinning turns them to
    // (0.5, 0, 0) and (0.5, 0, -0.5) -> normalised (0.7071, 0, -0.7071).
    assert!(
        near(frame.soup.corner(0, 0), [0.5, 0.0, 0.0], 1e-6),
        "{:?}",
        frame.soup.corner(0, 0)
    );
    let n = frame.soup.normals[0];
    assert!(
        near(
            [n[0], n[1], n[2]],
            [0.5f64.sqrt(), 0.0, -(0.5f64.sqrt())],
            1e-6
        ),
        "{n:?}"
    );
}
