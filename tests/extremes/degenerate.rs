//! Degenerate triangles mixed into a scene are never hit.

use super::*;

#[test]
fn degenerate_triangles_are_never_hit() {
    let d = common::device();
    let dir = tempfile::tempdir().unwrap();
    let base = base_spec();
    let mut spec = base.clone();
    // Mixed into the floor's and the red sphere's primitives, between their
    // real triangles (whose relative order, and so every tie, is kept):
    // points, triangles with repeated corners and exactly collinear ones,
    // on and in front of the surfaces where rays hit.
    for (k, part) in spec.parts.iter_mut().take(2).enumerate() {
        let v0 = part.positions.len() as u32;
        let extra: Vec<[f32; 3]> = if k == 0 {
            // On the floor (y = 0): a line along x, one along the diagonal
            // (multiples of 0.25, so exactly collinear), a point.
            vec![
                [-2.0, 0.0, 1.0],
                [0.0, 0.0, 1.0],
                [2.0, 0.0, 1.0],
                [-1.0, 0.0, -1.0],
                [0.25, 0.0, 0.25],
                [1.5, 0.0, 1.5],
                [0.5, 0.0, 0.5],
            ]
        } else {
            // In front of the red sphere, across the view.
            vec![
                [-1.5, 0.6, 0.7],
                [-0.7, 0.6, 0.7],
                [0.5, 0.6, 0.7],
                [-0.7, 0.25, 0.75],
                [-0.7, 0.5, 0.75],
                [-0.7, 1.0, 0.75],
                [-0.7, 0.6, 0.6],
            ]
        };
        let n = part.positions.len() as u32;
        part.positions.extend(&extra);
        if let Some(normals) = &mut part.normals {
            normals.extend(std::iter::repeat_n([0.0, 1.0, 0.0], extra.len()));
        }
        let degenerate: Vec<[u32; 3]> = vec![
            [v0, v0 + 1, v0 + 2],     // collinear
            [v0 + 3, v0 + 4, v0 + 5], // collinear
            [v0 + 6, v0 + 6, v0 + 6], // a point
            [0, 0, 0],                // a point on an existing vertex
            [1, 1, 2],                // repeated corner along an edge
            [2, n - 1, n - 1],        // repeated corner
            [v0 + 5, v0 + 3, v0 + 4], // collinear, other winding
            [v0 + 1, v0 + 1, v0 + 6], // repeated corner
        ];
        let real: Vec<[u32; 3]> = part.indices.chunks(3).map(|c| [c[0], c[1], c[2]]).collect();
        let mut mixed = Vec::new();
        let every = (real.len() / degenerate.len()).max(1);
        let mut extra_tris = degenerate.iter();
        for (i, t) in real.iter().enumerate() {
            if i % every == 0 {
                if let Some(x) = extra_tris.next() {
                    mixed.extend(x);
                }
            }
            mixed.extend(t);
        }
        for x in extra_tris {
            mixed.extend(x);
        }
        part.indices = mixed;
    }
    let mut st = settings(16, 7);
    st.aovs = Aovs::ALL;
    let clean = render(&d, &write(&base, dir.path(), "clean"), &st, Tree::Device);
    let mixed = render(&d, &write(&spec, dir.path(), "mixed"), &st, Tree::Device);
    assert_eq!(
        mixed.soup.triangle_count(),
        clean.soup.triangle_count() + 16,
        "the degenerate triangles reach the soup"
    );
    assert!(
        bits(&mixed.image) == bits(&clean.image),
        "degenerate triangles change the image"
    );
    // Also with the stackless traversal, whose escape indices are built
    // from the same tree.
    st.traversal = Traversal::Stackless;
    let sl = render(&d, &write(&spec, dir.path(), "mixed"), &st, Tree::Device);
    assert!(bits(&sl.image) == bits(&clean.image), "stackless differs");
    st.traversal = Traversal::Stack;
    let binary = render(&d, &write(&spec, dir.path(), "mixed"), &st, Tree::Device);
    assert!(
        bits(&binary.image) == bits(&clean.image),
        "binary stack differs"
    );
}
