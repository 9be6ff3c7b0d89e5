//! 10^5 coincident triangles: a fast build, and the image of one.

use super::*;

#[test]
fn coincident_triangles_build_fast_and_render_like_one() {
    // Run on a thread of its own, so a build that never ends fails the test
    // instead of hanging it.
    let (tx, rx) = std::sync::mpsc::channel();
    std::thread::spawn(move || {
        let d = common::device();
        let dir = tempfile::tempdir().unwrap();
        let spec = |copies: usize| {
            let mut s = base_spec();
            s.parts.truncate(1);
            s.parts.push(Part {
                name: "stack",
                positions: vec![[-1.0, 0.3, 0.5], [1.2, 0.4, 0.0], [-0.2, 1.3, -0.5]],
                normals: None,
                indices: [0, 1, 2].repeat(copies),
                material: diffuse([0.3, 0.6, 0.9]),
            });
            s
        };
        let st = settings(16, 7);
        let one = render(&d, &write(&spec(1), dir.path(), "one"), &st, Tree::Device);
        let many = render(
            &d,
            &write(&spec(100_000), dir.path(), "many"),
            &st,
            Tree::Device,
        );
        tx.send((one, many)).unwrap();
    });
    let (one, many) = rx
        .recv_timeout(Duration::from_secs(120))
        .expect("10^5 coincident triangles: no image after 120 s");
    assert_eq!(many.soup.triangle_count(), 100_002);
    let shape = many.bvh.shape();
    eprintln!(
        "10^5 coincident triangles: build {:?}, {} leaves, depth {}",
        many.build, shape.leaves, shape.max_depth
    );
    assert!(
        many.build < Duration::from_secs(10),
        "build took {:?}",
        many.build
    );
    // Ties break by triangle index: the first copy is the one every ray
    // hits, and blocks the same shadow rays, so the image is the same.
    assert!(
        bits(&one.image) == bits(&many.image),
        "10^5 coincident triangles render differently from one"
    );
}
