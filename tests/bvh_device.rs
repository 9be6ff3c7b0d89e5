//! The device builder against its references: the Rust binned builder it
//! must equal node for node, and the full-sweep builder its SAH cost must
//! stay near. Random soups, degenerate soups and the real meshes.

mod common;

use common::{device, mesh, random_soup, transformed};
use soupray::bvh::device_builder::{DeviceBuilder, Mapping};
use soupray::bvh::{binned, sah_cost, sweep, validate, BuildParams, Bvh, Child};
use soupray::soup::Soup;

/// The leaves' triangle sets, in node order; the order inside a leaf is
/// whatever the device's atomics left, so it is sorted away.
fn leaf_sets(bvh: &Bvh) -> Vec<Vec<u32>> {
    let mut out = Vec::new();
    for node in &bvh.nodes {
        for (child, _) in [node.left(), node.right()] {
            if let Child::Leaf { first, count } = child {
                let mut s = bvh.prim_ids[first as usize..(first + count) as usize].to_vec();
                s.sort_unstable();
                out.push(s);
            }
        }
    }
    out
}

/// Builds on the device and checks it against the reference: a valid tree,
/// the same nodes bit for bit, the same leaf contents, the same SAH cost.
fn check_equal(soup: &Soup, params: BuildParams, what: &str) -> f64 {
    let d = device();
    let mut cost = 0.0;
    // Both mappings: the CPU one PoCL uses by default, and the paper's
    // half-warp one that GPUs use, run here on PoCL.
    for mapping in [Mapping::SingleLane, Mapping::Paper] {
        let mut builder = DeviceBuilder::with_mapping(&d, params, mapping).unwrap();
        cost = check_one(&mut builder, soup, params, &format!("{what} ({mapping:?})"));
    }
    cost
}

fn check_one(builder: &mut DeviceBuilder, soup: &Soup, params: BuildParams, what: &str) -> f64 {
    let (dev, _) = builder.build(soup).unwrap();
    let reference = binned::build(soup, params).unwrap();
    let shape = validate(&dev, soup, params.leaf_size).unwrap_or_else(|e| panic!("{what}: {e}"));
    assert_eq!(
        shape,
        validate(&reference, soup, params.leaf_size).unwrap(),
        "{what}"
    );
    assert_eq!(dev.nodes.len(), reference.nodes.len(), "{what}: node count");
    let first_diff = dev
        .nodes
        .iter()
        .zip(&reference.nodes)
        .position(|(a, b)| a != b);
    assert_eq!(first_diff, None, "{what}: nodes differ");
    assert_eq!(
        leaf_sets(&dev),
        leaf_sets(&reference),
        "{what}: leaf contents"
    );
    let (a, b) = (sah_cost(&dev), sah_cost(&reference));
    assert!((a - b).abs() <= 0.01 * b, "{what}: SAH {a} vs {b}");
    a
}

#[test]
fn random_soups_match_the_reference() {
    for (n, size, seed) in [
        (2usize, 0.1f32, 1u64),
        (17, 0.1, 2),
        (300, 0.05, 3),
        (5000, 0.02, 4),
        (70_000, 0.01, 5),
    ] {
        check_equal(
            &random_soup(n, size, seed),
            BuildParams::default(),
            &format!("random {n}"),
        );
    }
}

#[test]
fn other_bins_and_leaf_sizes_match_the_reference() {
    let soup = random_soup(20_000, 0.02, 11);
    for (bins, leaf_size) in [(4, 1), (8, 2), (32, 8), (64, 4), (2, 4)] {
        check_equal(
            &soup,
            BuildParams { bins, leaf_size },
            &format!("bins {bins} leaf {leaf_size}"),
        );
    }
}

#[test]
fn degenerate_soups_build() {
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let params = BuildParams::default();
    check_equal(&Soup::default(), params, "empty");
    check_equal(&Soup::from_triangles(&[tri]), params, "one triangle");
    check_equal(
        &Soup::from_triangles(&vec![tri; 5000]),
        params,
        "equal centroids",
    );
    // Zero-area: points and collinear corners.
    let mut rng = common::Rng::new(5);
    let points: Vec<[[f32; 3]; 3]> = (0..3000)
        .map(|_| {
            let p = [rng.f32(), rng.f32(), rng.f32()];
            if rng.f32() < 0.5 {
                [p, p, p]
            } else {
                [p, [p[0] + 0.01, p[1], p[2]], [p[0] + 0.02, p[1], p[2]]]
            }
        })
        .collect();
    check_equal(&Soup::from_triangles(&points), params, "zero-area");
    // All centroids on one line.
    let line: Vec<[[f32; 3]; 3]> = (0..2000)
        .map(|i| {
            let x = i as f32;
            [[x, 0.0, 0.0], [x + 1.0, 0.0, 0.0], [x, 0.0, 0.0]]
        })
        .collect();
    check_equal(&Soup::from_triangles(&line), params, "collinear");
}

#[test]
fn a_million_copies_of_one_triangle_build() {
    let tri = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];
    let soup = Soup::from_triangles(&vec![tri; 1_000_000]);
    let d = device();
    let mut builder = DeviceBuilder::new(&d, BuildParams::default()).unwrap();
    let (bvh, _) = builder.build(&soup).unwrap();
    let shape = validate(&bvh, &soup, 4).unwrap();
    assert!(
        shape.max_depth <= 21,
        "id splits halve the id range: depth {}",
        shape.max_depth
    );
}

#[test]
fn real_meshes_match_the_reference_and_the_sweep() {
    for name in ["beast.ply", "nefertiti.ply"] {
        let Some(soup) = mesh(name) else {
            return;
        };
        let cost = check_equal(&soup, BuildParams::default(), name);
        let sweep = sah_cost(&sweep::build(&soup, BuildParams::default()));
        assert!(
            cost <= sweep * 1.05,
            "{name}: binned SAH {cost} over 5% above sweep {sweep}"
        );
    }
}

#[test]
fn extremes_of_scale_and_offset_keep_the_tree() {
    let Some(base) = mesh("beast.ply") else {
        return;
    };
    let params = BuildParams::default();
    let ratio_at = |soup: &Soup| {
        let cost = check_equal(soup, params, "extreme");
        cost / sah_cost(&sweep::build(soup, params))
    };
    let unit = ratio_at(&base);
    for (scale, offset) in [(1e-4f32, 0.0f32), (1e4, 0.0), (1.0, 1e6)] {
        let r = ratio_at(&transformed(&base, scale, offset));
        assert!(
            (r - unit).abs() < 0.02,
            "scale {scale} offset {offset}: SAH/sweep {r} vs {unit} at scale 1"
        );
    }
}

#[test]
fn buffers_are_reused_between_frames() {
    let d = device();
    let mut builder = DeviceBuilder::new(&d, BuildParams::default()).unwrap();
    let a = random_soup(10_000, 0.02, 21);
    let b = random_soup(10_000, 0.03, 22);
    builder.build(&a).unwrap();
    let after_first_frame = builder.allocations();
    builder.build(&b).unwrap();
    builder.build(&random_soup(9_000, 0.03, 23)).unwrap();
    assert_eq!(
        builder.allocations(),
        after_first_frame,
        "frames of the same or smaller size reallocated"
    );
    let (again, _) = builder.build(&a).unwrap();
    assert_eq!(builder.allocations(), after_first_frame);
    builder.build(&random_soup(12_000, 0.03, 24)).unwrap();
    assert!(
        builder.allocations() > after_first_frame,
        "a bigger frame must grow the buffers"
    );
    assert_eq!(
        again.nodes,
        binned::build(&a, BuildParams::default()).unwrap().nodes
    );
}

#[test]
fn leaves_cut_straight_from_big_nodes_keep_their_triangles() {
    // A medium root (302 triangles) whose best split cuts off the two far
    // outliers as a leaf: its partition writes that leaf into the second
    // buffer pair, from which it must be gathered back at the end.
    let mut tris: Vec<[[f32; 3]; 3]> = random_soup(300, 0.01, 31)
        .positions
        .chunks(3)
        .map(|c| std::array::from_fn(|k| [c[k][0], c[k][1], c[k][2]]))
        .collect();
    // First in the soup, so the slots they end in held other triangles.
    for x in [100.0f32, 101.0] {
        tris.insert(0, [[x, 0.0, 0.0], [x + 0.01, 0.0, 0.0], [x, 0.01, 0.0]]);
    }
    let soup = Soup::from_triangles(&tris);
    check_equal(&soup, BuildParams::default(), "outlier leaf");
    // And a large node (over 32K) doing the same.
    let mut big: Vec<[[f32; 3]; 3]> = random_soup(40_000, 0.002, 32)
        .positions
        .chunks(3)
        .map(|c| std::array::from_fn(|k| [c[k][0], c[k][1], c[k][2]]))
        .collect();
    big.insert(
        0,
        [[500.0, 0.0, 0.0], [500.01, 0.0, 0.0], [500.0, 0.01, 0.0]],
    );
    check_equal(
        &Soup::from_triangles(&big),
        BuildParams::default(),
        "large outlier leaf",
    );
}
