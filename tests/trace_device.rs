//! The device tracer against the CPU reference: the struct layouts, then
//! closest hit (stack, stackless and 4-wide) and any hit on ~100K random rays over
//! the real meshes and random soups, bit for bit; the CPU traversal against
//! brute force and against a differently shaped tree; determinism; the depth
//! limit; buffer reuse; the primary-ray generator; and leaves of every size
//! (the device intersects a leaf four triangles at a time).

mod common;

use common::trace::{assert_any_agrees, assert_same, device, random_rays, trace_everything};
use common::{mesh, random_soup, random_triangles};
use soupray::bvh::device_builder::DeviceBuilder;
use soupray::bvh::{sweep, BuildParams, Bvh, BvhNode, Child, MAX_DEPTH};
use soupray::soup::Soup;
use soupray::trace::intersect::is_degenerate;
use soupray::trace::settings::Traversal;
use soupray::trace::traverse::all_hits;
use soupray::trace::{self, DeviceTracer, Hit, PinholeCamera, Ray, TraceError, TraceKind};

/// All twelve tracings agree, and agree with brute force on a sample.
fn check_soup(soup: &Soup, rays: &[Ray], what: &str) -> usize {
    let d = device();
    let t = trace_everything(&d, soup, rays);
    assert_same(
        &t.dev_closest,
        &t.cpu_closest,
        rays,
        &format!("{what}: device vs CPU stack"),
    );
    assert_same(
        &t.dev_stackless,
        &t.dev_closest,
        rays,
        &format!("{what}: device stackless vs stack"),
    );
    assert_same(
        &t.cpu_stackless,
        &t.cpu_closest,
        rays,
        &format!("{what}: CPU stackless vs stack"),
    );
    assert_any_agrees(
        &t.dev_any,
        &t.cpu_closest,
        &format!("{what}: device any-hit"),
    );
    assert_any_agrees(&t.cpu_any, &t.cpu_closest, &format!("{what}: CPU any-hit"));
    assert_same(
        &t.dev_wide,
        &t.cpu_wide,
        rays,
        &format!("{what}: device vs CPU wide"),
    );
    assert_same(
        &t.cpu_wide,
        &t.cpu_closest,
        rays,
        &format!("{what}: CPU wide vs stack"),
    );
    // The wide any-hit twins visit in the same order: the same triangle.
    assert_same(
        &t.dev_any_wide,
        &t.cpu_any_wide,
        rays,
        &format!("{what}: device vs CPU wide any-hit"),
    );
    assert_any_agrees(
        &t.dev_any_wide,
        &t.cpu_closest,
        &format!("{what}: device wide any-hit"),
    );
    assert_same(
        &t.dev_wide8,
        &t.cpu_wide8,
        rays,
        &format!("{what}: device vs CPU 8-wide"),
    );
    assert_same(
        &t.cpu_wide8,
        &t.cpu_closest,
        rays,
        &format!("{what}: CPU 8-wide vs stack"),
    );
    assert_same(
        &t.dev_any_wide8,
        &t.cpu_any_wide8,
        rays,
        &format!("{what}: device vs CPU 8-wide any-hit"),
    );
    assert_any_agrees(
        &t.dev_any_wide8,
        &t.cpu_closest,
        &format!("{what}: device 8-wide any-hit"),
    );
    assert_same(
        &t.dev_wide8q,
        &t.cpu_closest,
        rays,
        &format!("{what}: device quantized 8-wide vs CPU stack"),
    );
    assert_any_agrees(
        &t.dev_any_wide8q,
        &t.cpu_closest,
        &format!("{what}: device quantized 8-wide any-hit"),
    );
    // Culling never loses the closest hit: brute force over every triangle
    // (the first of all hits sorted by t, then index) on a sample.
    let step = (rays.len() / 300).max(1);
    for (i, ray) in rays.iter().enumerate().step_by(step) {
        let brute = all_hits(&soup.positions, ray)
            .first()
            .copied()
            .unwrap_or(Hit::miss(ray.tmax));
        assert_eq!(
            brute.bits(),
            t.cpu_closest[i].bits(),
            "{what}: ray {i} vs brute force"
        );
    }
    t.cpu_closest.iter().filter(|h| h.is_hit()).count()
}

#[test]
fn real_meshes_agree_hit_for_hit() {
    for (name, seed) in [("beast.ply", 1u64), ("nefertiti.ply", 2)] {
        let Some(soup) = mesh(name) else {
            return;
        };
        let mut rays = random_rays(&soup, 40_000, seed);
        let (lo, hi) = soup.bounds().unwrap();
        let camera = PinholeCamera::framing(lo, hi, [0.3, -0.2, -1.0], 40.0, 100, 100);
        rays.extend(camera.rays());
        let hits = check_soup(&soup, &rays, name);
        // The rays must exercise the tree, not just miss it.
        assert!(
            hits > rays.len() / 5,
            "{name}: only {hits} of {} rays hit",
            rays.len()
        );
    }
}

#[test]
fn random_soups_agree_hit_for_hit() {
    for (n, size, seed) in [
        (1usize, 0.5f32, 3u64),
        (7, 0.3, 4),
        (500, 0.1, 5),
        (20_000, 0.02, 6),
    ] {
        let soup = random_soup(n, size, seed);
        let rays = random_rays(&soup, 4_000, seed + 100);
        check_soup(&soup, &rays, &format!("random {n}"));
    }
    // Many coincident triangles: ties at equal t go to the smallest index
    // whatever the tree, stack or stackless.
    // (Below the random soup, which fills the unit cube.)
    let tri = [[0.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 1.0, -1.0]];
    let mut tris = vec![tri; 300];
    tris.extend(random_triangles(300, 0.1, 9));
    let soup = Soup::from_triangles(&tris);
    let rays = random_rays(&soup, 3_000, 10);
    check_soup(&soup, &rays, "coincident");
    let through_stack: Vec<Ray> = (0..50)
        .map(|i| Ray::new([0.1 + 0.01 * i as f32, 0.2, -0.5], [0.0, -0.0, -1.0]))
        .collect();
    let t = trace_everything(&device(), &soup, &through_stack);
    assert!(
        t.dev_closest.iter().all(|h| h.prim == 0 && h.t == 0.5),
        "{:?}",
        &t.dev_closest[..3]
    );
}

#[test]
fn empty_soup_hits_nothing() {
    let soup = Soup::default();
    let rays = random_rays(&soup, 100, 1);
    let t = trace_everything(&device(), &soup, &rays);
    assert!(t
        .dev_closest
        .iter()
        .chain(&t.dev_stackless)
        .chain(&t.dev_any)
        .all(|h| !h.is_hit()));
}

#[test]
fn closest_hit_does_not_depend_on_the_tree() {
    let Some(soup) = mesh("beast.ply") else {
        return;
    };
    let rays = random_rays(&soup, 20_000, 7);
    let d = device();
    let t = trace_everything(&d, &soup, &rays);
    for leaf_size in [1, 8] {
        let other = sweep::build(
            &soup,
            BuildParams {
                bins: 16,
                leaf_size,
            },
        );
        let hits: Vec<Hit> = rays
            .iter()
            .map(|r| trace::trace_closest(&other, &soup.positions, r))
            .collect();
        assert_same(
            &hits,
            &t.cpu_closest,
            &rays,
            &format!("sweep tree, leaf {leaf_size}"),
        );
    }
}

#[test]
fn tracing_is_deterministic() {
    let Some(soup) = mesh("nefertiti.ply") else {
        return;
    };
    let rays = random_rays(&soup, 20_000, 8);
    let d = device();
    let a = trace_everything(&d, &soup, &rays);
    // A second build may order triangles inside leaves differently (device
    // atomics); the hits must not change, bit for bit.
    let b = trace_everything(&d, &soup, &rays);
    assert_same(&a.dev_closest, &b.dev_closest, &rays, "closest, twice");
    assert_same(
        &a.dev_stackless,
        &b.dev_stackless,
        &rays,
        "stackless, twice",
    );
    let occluded = |h: &[Hit]| h.iter().map(Hit::is_hit).collect::<Vec<_>>();
    assert_eq!(occluded(&a.dev_any), occluded(&b.dev_any));
}

/// A chain of `depth` inner nodes, each with a one-triangle leaf on the left.
fn chain(depth: u32) -> (Bvh, Soup) {
    let soup = random_soup(depth as usize + 1, 0.1, 1);
    let whole = soupray::bvh::Aabb {
        lo: [-1.0; 3],
        hi: [2.0; 3],
    };
    let mut nodes = Vec::new();
    for i in 0..depth {
        let mut n = BvhNode::empty();
        n.set_left(Child::Leaf { first: i, count: 1 }, whole);
        if i + 1 < depth {
            n.set_right(Child::Inner(i + 1), whole);
        } else {
            n.set_right(
                Child::Leaf {
                    first: i + 1,
                    count: 1,
                },
                whole,
            );
        }
        nodes.push(n);
    }
    (
        Bvh {
            nodes,
            prim_ids: (0..=depth).collect(),
        },
        soup,
    )
}

#[test]
fn depth_beyond_the_limit_is_an_error() {
    let d = device();
    let mut tracer = DeviceTracer::new(&d).unwrap();
    // Inner nodes down to depth MAX_DEPTH are fine, and traced correctly:
    // this is the deepest stack the kernel needs.
    let (ok, soup) = chain(MAX_DEPTH + 1);
    assert_eq!(tracer.upload_bvh(&ok).unwrap(), MAX_DEPTH + 1);
    let mut positions = d.buffer::<[f32; 4]>(soup.positions.len()).unwrap();
    d.write(&mut positions, &soup.positions).unwrap();
    let mut ids = d.buffer::<u32>(ok.prim_ids.len()).unwrap();
    d.write(&mut ids, &ok.prim_ids).unwrap();
    let rays = random_rays(&soup, 2_000, 3);
    let got = tracer
        .trace_rays(TraceKind::Closest, &positions, &ids, &rays)
        .unwrap();
    let want: Vec<Hit> = rays
        .iter()
        .map(|r| trace::trace_closest(&ok, &soup.positions, r))
        .collect();
    assert_same(&got, &want, &rays, "deepest allowed tree");
    assert!(want.iter().any(Hit::is_hit));
    // One level more is refused, before anything is traced.
    let (deep, _) = chain(MAX_DEPTH + 2);
    match tracer.upload_bvh(&deep) {
        Err(TraceError::TooDeep { max, .. }) => assert_eq!(max, MAX_DEPTH),
        other => panic!("a tree deeper than the stack was accepted: {other:?}"),
    }
    assert!(matches!(
        trace::check_depth(&deep),
        Err(TraceError::TooDeep { .. })
    ));
    // ... and the tracer does not keep tracing the previous tree.
    let err = tracer.trace_rays(TraceKind::Closest, &positions, &ids, &rays);
    assert!(err.is_err(), "traced after a refused upload");
}

#[test]
fn buffers_are_reused_across_frames() {
    let d = device();
    let mut tracer = DeviceTracer::new(&d).unwrap();
    let mut builder = DeviceBuilder::new(&d, BuildParams::default()).unwrap();
    let base = random_soup(5_000, 0.05, 2);
    let mut positions = d.buffer::<[f32; 4]>(base.positions.len()).unwrap();
    let rays = random_rays(&base, 1_000, 4);
    let mut allocations = Vec::new();
    for frame in 0..5 {
        let soup = common::transformed(&base, 1.0 + 0.01 * frame as f32, 0.0);
        let (bvh, _) = builder.build(&soup).unwrap();
        d.write(&mut positions, &soup.positions).unwrap();
        tracer.upload_bvh(&bvh).unwrap();
        tracer.upload_stackless(&bvh).unwrap();
        let ids = builder.device_prim_ids().unwrap();
        tracer
            .trace_rays(TraceKind::Closest, &positions, ids, &rays)
            .unwrap();
        tracer
            .trace_rays(TraceKind::ClosestStackless, &positions, ids, &rays)
            .unwrap();
        allocations.push(tracer.allocations());
    }
    assert!(
        allocations.windows(2).skip(1).all(|w| w[0] == w[1]),
        "{allocations:?}"
    );
}

#[test]
fn primary_rays_match_the_host_camera() {
    let d = device();
    let tracer = DeviceTracer::new(&d).unwrap();
    let Some(soup) = mesh("beast.ply") else {
        return;
    };
    let (lo, hi) = soup.bounds().unwrap();
    let camera = PinholeCamera::framing(lo, hi, [0.0, 0.0, -1.0], 45.0, 64, 48);
    let rays = d.buffer::<Ray>(64 * 48).unwrap();
    tracer.generate_primary(&camera, &rays).unwrap();
    let mut got = vec![Ray::default(); 64 * 48];
    d.read(&rays, &mut got).unwrap();
    assert_eq!(got, camera.rays());
    // The frame is centred on the mesh: its middle pixel hits, its corner
    // misses (the bounding sphere fills the height).
    let (bvh, _) = DeviceBuilder::new(&d, BuildParams::default())
        .unwrap()
        .build(&soup)
        .unwrap();
    assert!(trace::trace_closest(&bvh, &soup.positions, &camera.ray(32, 24)).is_hit());
    assert!(!trace::trace_closest(&bvh, &soup.positions, &camera.ray(0, 0)).is_hit());
}

/// Leaves of every size agree with the CPU reference bit for bit, closest
/// and any hit: the device intersects a leaf's triangles four at a time, so
/// leaves of 2, 3, 5 and 8 leave lanes unused in their last four, and the
/// coincident triangles (ties at equal t) and the rays through shared edges
/// of a grid send lanes to the one-triangle test. Degenerate triangles in
/// the grid's leaves are gathered as NaN lanes and never hit.
#[test]
fn leaves_of_every_size_agree_hit_for_hit() {
    let d = device();
    let tri = [[0.0, 0.0, -1.0], [1.0, 0.0, -1.0], [0.0, 1.0, -1.0]];
    let mut tris = vec![tri; 40];
    // A grid of unit squares at z = -2, two triangles each: rays through its
    // vertices and edge midpoints cross shared edges exactly.
    for i in 0..8 {
        for j in 0..8 {
            let (x, y) = (i as f32, j as f32);
            tris.push([[x, y, -2.0], [x + 1.0, y, -2.0], [x + 1.0, y + 1.0, -2.0]]);
            tris.push([[x, y, -2.0], [x + 1.0, y + 1.0, -2.0], [x, y + 1.0, -2.0]]);
        }
    }
    // Degenerate triangles among them: repeated and collinear corners.
    for i in 0..8 {
        let (x, y) = (i as f32 + 0.25, i as f32 + 0.5);
        tris.push([[x, y, -2.0], [x, y, -2.0], [x + 0.5, y, -2.0]]);
        tris.push([
            [x, y, -1.5],
            [x + 0.5, y + 0.5, -1.5],
            [x + 1.0, y + 1.0, -1.5],
        ]);
    }
    tris.extend(random_triangles(2_000, 0.05, 21));
    let soup = Soup::from_triangles(&tris);
    assert!((0..soup.triangle_count() as u32).any(|p| is_degenerate(&soup.positions, p)));
    let mut rays = random_rays(&soup, 3_000, 22);
    // Interior points only: on the grid's border, the top-left rule gives
    // half the outer edges to no triangle.
    for i in 1..16 {
        for j in 1..16 {
            let (x, y) = (i as f32 * 0.5, j as f32 * 0.5);
            rays.push(Ray::new([x, y, 1.0], [0.0, 0.0, -1.0]));
        }
    }
    let mut positions = d.buffer::<[f32; 4]>(soup.positions.len()).unwrap();
    d.write(&mut positions, &soup.positions).unwrap();
    for leaf_size in [2, 3, 5, 8] {
        let mut builder = DeviceBuilder::new(
            &d,
            BuildParams {
                leaf_size,
                ..BuildParams::default()
            },
        )
        .unwrap();
        let (bvh, _) = builder.build(&soup).unwrap();
        let mut tracer = DeviceTracer::new(&d).unwrap();
        let prim_ids = builder.device_prim_ids().unwrap();
        tracer.upload_wide8(&bvh, &positions, prim_ids).unwrap();
        let closest = tracer
            .trace_rays(TraceKind::ClosestWide8, &positions, prim_ids, &rays)
            .unwrap();
        let any = tracer
            .trace_rays(TraceKind::AnyWide8, &positions, prim_ids, &rays)
            .unwrap();
        let (nodes, blocks) = trace::wide_layout::<trace::Wide8Node>(&bvh).unwrap();
        let (slots, tris) = trace::leaf_arrays(&blocks, &bvh.prim_ids, Some(&soup.positions));
        // The device's gather is its Rust twin's, bit for bit.
        let (dev_slots, dev_tris) = tracer.read_leaves(Traversal::Wide8).unwrap();
        assert_eq!(
            dev_slots, slots,
            "leaf size {leaf_size}: the slots' triangles"
        );
        assert!(
            dev_tris
                .iter()
                .flatten()
                .map(|x| x.to_bits())
                .eq(tris.iter().flatten().map(|x| x.to_bits())),
            "leaf size {leaf_size}: the leaves' corners"
        );
        let p = &soup.positions;
        let cpu_closest: Vec<Hit> = rays
            .iter()
            .map(|r| trace::trace_closest_wide(&nodes, &slots, p, r))
            .collect();
        let cpu_any: Vec<Hit> = rays
            .iter()
            .map(|r| trace::trace_any_wide(&nodes, &slots, p, r))
            .collect();
        assert_same(
            &closest,
            &cpu_closest,
            &rays,
            &format!("leaf {leaf_size}: closest"),
        );
        assert_same(&any, &cpu_any, &rays, &format!("leaf {leaf_size}: any hit"));
        // The grid's rays all hit: the watertight test leaves no crack.
        let grid_hits = closest[3_000..].iter().filter(|h| h.is_hit()).count();
        assert_eq!(
            grid_hits,
            15 * 15,
            "leaf {leaf_size}: rays through the grid"
        );
    }
}
