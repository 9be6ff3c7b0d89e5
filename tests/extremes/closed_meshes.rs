//! The camera inside closed meshes sees only the mesh.

use super::*;

/// A closed cube of half-size `h` at the origin; `inward` winds its faces to
/// face the inside.
fn closed_box(h: f32, inward: bool, material: Value) -> Part {
    let positions: Vec<[f32; 3]> = (0..8)
        .map(|i| {
            let s = |b: u32| if i & b != 0 { h } else { -h };
            [s(1), s(2), s(4)]
        })
        .collect();
    // Per face: four corners counter-clockwise seen from outside.
    let faces = [
        [0, 4, 6, 2], // -x
        [1, 3, 7, 5], // +x
        [0, 1, 5, 4], // -y
        [2, 6, 7, 3], // +y
        [0, 2, 3, 1], // -z
        [4, 5, 7, 6], // +z
    ];
    let mut indices = Vec::new();
    for f in faces {
        let mut t = vec![f[0], f[1], f[2], f[0], f[2], f[3]];
        if inward {
            t = t.chunks(3).flat_map(|c| [c[0], c[2], c[1]]).collect();
        }
        indices.extend(t);
    }
    Part {
        name: "box",
        positions,
        normals: None,
        indices,
        material,
    }
}

/// Every pixel covered (nothing leaks through the mesh around the camera),
/// lit and finite under the brightness-5 sky.
fn assert_closed(image: &Image, what: &str) {
    assert_eq!(coverage(image).0, image.rgba.len(), "{what}");
    assert!(
        image.rgba.iter().all(|p| grey(p) > 0.0 && grey(p) < 5.0),
        "{what}"
    );
}

#[test]
fn camera_inside_closed_meshes_sees_only_the_mesh() {
    let d = common::device();
    let dir = tempfile::tempdir().unwrap();
    let (r, intensity) = (2.0f32, 10.0f32);
    let inside = |part: Part| Spec {
        parts: vec![part],
        eye: Vec3::new(0.3, 0.2, 0.25),
        target: Vec3::new(-1.0, -0.3, -2.0),
        up: Vec3::Y,
        yfov: 1.4,
        znear: 0.01,
        lamps: vec![Lamp::Point(Vec3::ZERO, intensity)],
        scale: 1.0,
        offset: Vec3::ZERO,
    };
    // No environment for the sphere (the point light is the only light, so
    // next-event estimation always picks it: direct light is noise-free);
    // a bright sky that must never be seen for the boxes.
    let mut st = settings(16, 7);
    st.environment = Environment::Default;
    st.clay = true;

    // A closed sphere, double-sided (its faces point out, the camera sees
    // their backs), a point light at its centre. Clay is a Lambertian of
    // albedo 0.8 and the light is white-ish (mean 0.95), so direct light
    // alone is rho/pi * I/r^2 everywhere (flat facets: within 1 %), and
    // with n scattering events an integrating sphere adds a geometric
    // series: sum_{k<n} rho^k.
    let ball = sphere("ball", Vec3::ZERO, r, 48, double_sided(diffuse([1.0; 3])));
    let ball = Part {
        normals: None,
        ..ball
    };
    let path = write(&inside(ball), dir.path(), "ball");
    let rho = 0.8f64;
    let direct = rho / std::f64::consts::PI * intensity as f64 * 0.95 / (r * r) as f64;
    for depth in [1u32, 8] {
        st.max_depth = depth;
        let f = render(&d, &path, &st, Tree::Device);
        let what = format!("inside a double-sided sphere, depth {depth}");
        assert_eq!(coverage(&f.image).0, f.image.rgba.len(), "{what}: leaks");
        let want = direct * (1.0 - rho.powi(depth as i32)) / (1.0 - rho);
        let mean = f.image.rgba.iter().map(grey).sum::<f64>() / f.image.rgba.len() as f64;
        eprintln!("{what}: mean {mean:.5}, expected {want:.5}");
        assert!(
            (mean / want - 1.0).abs() < 0.03,
            "{what}: mean {mean} vs {want}"
        );
        if depth == 1 {
            for p in &f.image.rgba {
                assert!(
                    (grey(p) / want - 1.0).abs() < 0.02,
                    "{what}: pixel {p:?} vs {want}"
                );
            }
        }
    }

    // A room: a single-sided box facing inwards. Seen from inside it is
    // closed; every pixel covered, lit and finite.
    st.max_depth = 8;
    st.environment = Environment::Color([5.0, 5.0, 5.0]);
    let room = render(
        &d,
        &write(
            &inside(closed_box(r, true, diffuse([1.0; 3]))),
            dir.path(),
            "room",
        ),
        &st,
        Tree::Device,
    );
    assert_closed(&room.image, "room leaks");
    // The same box double-sided but facing outwards: also closed.
    let shell = render(
        &d,
        &write(
            &inside(closed_box(r, false, double_sided(diffuse([1.0; 3])))),
            dir.path(),
            "shell",
        ),
        &st,
        Tree::Device,
    );
    assert_closed(&shell.image, "shell leaks");
    // Single-sided and facing outwards, every face is a back face from
    // inside. By default back faces are shaded (as in Cycles), so the box
    // is as closed as the double-sided one...
    let outward = write(
        &inside(closed_box(r, false, diffuse([1.0; 3]))),
        dir.path(),
        "outward",
    );
    let flipped = render(&d, &outward, &st, Tree::Device);
    assert_closed(&flipped.image, "a single-sided box seen from inside leaks");
    // ...and with --backface-culling they are culled as a rasterizer does,
    // so the camera sees the sky through the box (this pins the culling,
    // it is not a leak).
    st.backface_culling = true;
    let culled = render(&d, &outward, &st, Tree::Device);
    assert_eq!(coverage(&culled.image).1, culled.image.rgba.len());
    assert!(culled.image.rgba.iter().all(|p| p[..3] == [5.0, 5.0, 5.0]));
}
