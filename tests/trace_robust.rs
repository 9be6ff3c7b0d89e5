//! Intersection you can trust: watertightness on closed meshes (rays aimed
//! exactly at shared vertices and edges, from inside and outside, at scales
//! from 1e-3 to 1e5 and 1e6 from the origin), axis-parallel rays with +0 and
//! -0 direction components, degenerate triangles, and self-intersection of
//! rays spawned from hit points with the robust offset. The CPU reference
//! counts every crossing (brute force); the device must agree bit for bit.

mod common;

use common::trace::{
    assert_any_agrees, assert_same, cube_grid, device, icosphere, trace_everything, Mesh,
};
use common::Rng;
use soupray::soup::Soup;
use soupray::trace::intersect::{geometric_normal, hit_point, is_degenerate, offset_ray_origin};
use soupray::trace::traverse::all_hits;
use soupray::trace::{self, Hit, Ray};

/// (scale, offset) of every test: 1e-3, 1 and 1e5 about the origin, and
/// 1 and 1e3 a million units away.
const PLACEMENTS: [(f32, f32); 5] = [(1e-3, 0.0), (1.0, 0.0), (1e5, 0.0), (1.0, 1e6), (1e3, 1e6)];

fn sub(a: [f32; 3], b: [f32; 3]) -> [f32; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

fn dot(a: [f32; 3], b: [f32; 3]) -> f32 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

fn corners(soup: &Soup, prim: u32) -> [[f32; 3]; 3] {
    std::array::from_fn(|k| soup.corner(prim as usize, k))
}

/// Rays aimed exactly at every vertex and at every edge's midpoint of a
/// closed convex mesh centred on `center` with radius about `radius`: from
/// inside each crosses the surface exactly once, from outside exactly twice
/// (never zero: no cracks; never more: no double hits), the closest hit is
/// at the target (t = 1) on a triangle that has the target's vertex or edge,
/// and the device agrees bit for bit. Returns the number of rays.
fn check_watertight(mesh: &Mesh, center: [f32; 3], radius: f32, what: &str) -> usize {
    let soup = mesh.soup();
    let mut rng = Rng::new(11);
    // (target, the vertices the hit triangle must have, crossings expected)
    let mut targets: Vec<([f32; 3], Vec<[f32; 3]>)> =
        mesh.vertices.iter().map(|&v| (v, vec![v])).collect();
    for (a, b) in mesh.edges() {
        let (pa, pb) = (mesh.vertices[a as usize], mesh.vertices[b as usize]);
        let mid = std::array::from_fn(|i| pa[i] + (pb[i] - pa[i]) * 0.5);
        targets.push((mid, vec![pa, pb]));
    }
    let mut rays = Vec::new();
    let mut expect = Vec::new();
    for (target, must_have) in &targets {
        let jitter = |rng: &mut Rng| -> [f32; 3] {
            std::array::from_fn(|_| (rng.f32() - 0.5) * 0.4 * radius)
        };
        let j = jitter(&mut rng);
        let inside: [f32; 3] = std::array::from_fn(|i| center[i] + j[i]);
        let j = jitter(&mut rng);
        let outside: [f32; 3] =
            std::array::from_fn(|i| center[i] + (target[i] - center[i]) * 3.0 + j[i]);
        for (origin, crossings) in [(inside, 1), (outside, 2)] {
            rays.push(Ray::new(origin, sub(*target, origin)));
            expect.push((must_have.clone(), crossings));
        }
    }
    for (i, (ray, (must_have, crossings))) in rays.iter().zip(&expect).enumerate() {
        let all = all_hits(&soup.positions, ray);
        assert_eq!(
            all.len(),
            *crossings,
            "{what}: ray {i} {ray:?} crosses the closed surface {} times, expected {crossings}: {all:?}",
            all.len()
        );
        let first = all[0];
        assert!(
            (first.t - 1.0).abs() < 1e-3,
            "{what}: ray {i} hits at t = {} instead of at its target",
            first.t
        );
        let c = corners(&soup, first.prim);
        assert!(
            must_have.iter().all(|v| c.contains(v)),
            "{what}: ray {i} hit triangle {} {c:?}, which lacks the target's vertices {must_have:?}",
            first.prim
        );
    }
    let t = trace_everything(&device(), &soup, &rays);
    let brute: Vec<Hit> = rays
        .iter()
        .map(|r| all_hits(&soup.positions, r)[0])
        .collect();
    assert_same(
        &t.cpu_closest,
        &brute,
        &rays,
        &format!("{what}: CPU traversal vs brute force"),
    );
    assert_same(
        &t.dev_closest,
        &brute,
        &rays,
        &format!("{what}: device stack"),
    );
    assert_same(
        &t.dev_stackless,
        &brute,
        &rays,
        &format!("{what}: device stackless"),
    );
    assert_same(&t.dev_wide, &brute, &rays, &format!("{what}: device wide"));
    assert_same(
        &t.dev_wide8,
        &brute,
        &rays,
        &format!("{what}: device 8-wide"),
    );
    assert_any_agrees(&t.dev_any, &brute, &format!("{what}: device any-hit"));
    assert_any_agrees(
        &t.dev_any_wide,
        &brute,
        &format!("{what}: device wide any-hit"),
    );
    assert_any_agrees(
        &t.dev_any_wide8,
        &brute,
        &format!("{what}: device 8-wide any-hit"),
    );
    rays.len()
}

#[test]
fn closed_meshes_are_watertight_at_every_scale() {
    let cube = cube_grid(6);
    let sphere = icosphere(2);
    let mut total = 0;
    for (s, off) in PLACEMENTS {
        let c = [off; 3];
        total += check_watertight(
            &cube.transformed(s, off),
            c,
            s,
            &format!("cube x{s} +{off}"),
        );
        // A unit sphere a million units out would be rounded to 1/16 steps.
        if !(s == 1.0 && off != 0.0) {
            total += check_watertight(
                &sphere.transformed(s, off),
                c,
                s,
                &format!("sphere x{s} +{off}"),
            );
        }
    }
    assert!(total > 10_000, "only {total} rays");
}

/// Axis-parallel rays, with every combination of +0 and -0 in the other two
/// components, through every vertex and edge midpoint of one face's grid
/// (exact, as the grid is on powers of two): from outside they enter through
/// that face and leave through the opposite one; from the centre they leave
/// through that face; always on a triangle with the target's vertices.
#[test]
fn axis_parallel_rays_with_signed_zeros_hit_the_right_triangle() {
    let n = 4u32;
    for (s, off) in PLACEMENTS {
        let mesh = cube_grid(n).transformed(s, off);
        let soup = mesh.soup();
        let mut rays = Vec::new();
        let mut checks = Vec::new();
        for axis in 0..3 {
            let (ua, va) = ((axis + 1) % 3, (axis + 2) % 3);
            for side in [-1.0f32, 1.0] {
                // Interior grid points (and half steps) of this face; the
                // border would graze the neighbouring faces.
                for i in 1..2 * n {
                    for j in 1..2 * n {
                        let g = |k: u32| (-1.0 + k as f32 / n as f32) * s + off;
                        let mut target = [0.0f32; 3];
                        target[axis] = side * s + off;
                        target[ua] = g(i);
                        target[va] = g(j);
                        for zeros in 0..4 {
                            let z = |bit: u32| if zeros & bit == 0 { 0.0f32 } else { -0.0 };
                            let mut dir = [0.0f32; 3];
                            dir[ua] = z(1);
                            dir[va] = z(2);
                            // From outside, towards the face.
                            let mut o = target;
                            o[axis] = side * 10.0 * s + off;
                            dir[axis] = -side;
                            rays.push(Ray::new(o, dir));
                            checks.push((target, axis, side, 2));
                            // From the centre plane, towards the face.
                            let mut o = target;
                            o[axis] = off;
                            dir[axis] = side;
                            rays.push(Ray::new(o, dir));
                            checks.push((target, axis, side, 1));
                        }
                    }
                }
            }
        }
        for (i, (ray, &(target, axis, side, crossings))) in rays.iter().zip(&checks).enumerate() {
            let all = all_hits(&soup.positions, ray);
            assert_eq!(
                all.len(),
                crossings,
                "x{s} +{off}: ray {i} {ray:?}: {all:?}"
            );
            let c = corners(&soup, all[0].prim);
            assert!(
                c.iter().all(|p| p[axis] == side * s + off),
                "x{s} +{off}: ray {i} {ray:?} hit triangle {c:?}, not on the face it aims at"
            );
            // The hit triangle contains the target (a vertex, or a point of
            // an edge or of the face): its barycentrics are within [0, 1].
            let h = all[0];
            assert!(h.u >= 0.0 && h.v >= 0.0 && h.u + h.v <= 1.0 + 1e-6, "{h:?}");
            let p = hit_point(&soup.positions, h.prim, h.u, h.v);
            let tol = 1e-5 * (s + off.abs());
            assert!(
                (0..3).all(|a| (p[a] - target[a]).abs() <= tol),
                "x{s} +{off}: ray {i}: hit point {p:?} is not the target {target:?}"
            );
        }
        let t = trace_everything(&device(), &soup, &rays);
        let brute: Vec<Hit> = rays
            .iter()
            .map(|r| all_hits(&soup.positions, r)[0])
            .collect();
        assert_same(
            &t.dev_closest,
            &brute,
            &rays,
            &format!("x{s} +{off}: device"),
        );
        assert_same(
            &t.dev_stackless,
            &brute,
            &rays,
            &format!("x{s} +{off}: stackless"),
        );
        assert_same(&t.dev_wide, &brute, &rays, &format!("x{s} +{off}: wide"));
        assert_same(&t.dev_wide8, &brute, &rays, &format!("x{s} +{off}: 8-wide"));
        assert_same(&t.cpu_closest, &brute, &rays, &format!("x{s} +{off}: CPU"));
    }
}

/// Zero-area triangles (a point, repeated corners, exactly collinear
/// corners) are never hit, whatever aims at them: their corners, points of
/// their segment, along their line, or at random.
#[test]
fn degenerate_triangles_are_never_hit() {
    let mut rng = Rng::new(3);
    let mut tris: Vec<[[f32; 3]; 3]> = Vec::new();
    // Coordinates on a 1/64 grid, so collinear corners are exactly collinear.
    let grid =
        |rng: &mut Rng| -> [f32; 3] { std::array::from_fn(|_| (rng.f32() * 64.0).floor() / 64.0) };
    for i in 0..600 {
        let a = grid(&mut rng);
        let b = grid(&mut rng);
        let d = sub(b, a);
        let along = |k: f32| -> [f32; 3] { std::array::from_fn(|x| a[x] + k * d[x]) };
        tris.push(match i % 6 {
            0 => [a, a, a],
            1 => [a, a, b],
            2 => [a, b, b],
            3 => [a, b, a],
            4 => [a, along(0.5), b],
            _ => [along(0.5), a, along(2.0)],
        });
    }
    let degenerate = tris.len() as u32;
    // A few ordinary triangles behind them, so rays have something to hit.
    tris.push([[-1.0, -1.0, -2.0], [3.0, -1.0, -2.0], [-1.0, 3.0, -2.0]]);
    tris.push([[-2.0, -1.0, -1.0], [-2.0, 3.0, -1.0], [-2.0, -1.0, 3.0]]);
    let soup = Soup::from_triangles(&tris);
    for p in 0..degenerate {
        assert!(
            is_degenerate(&soup.positions, p),
            "test triangle {p} is not degenerate"
        );
    }
    let mut rays = Vec::new();
    for p in 0..degenerate as usize {
        let c = corners(&soup, p as u32);
        let mut aims: Vec<[f32; 3]> = c.to_vec();
        aims.push(std::array::from_fn(|x| 0.5 * (c[0][x] + c[2][x])));
        aims.push(std::array::from_fn(|x| 0.25 * c[0][x] + 0.75 * c[1][x]));
        for aim in aims {
            let o: [f32; 3] = std::array::from_fn(|_| rng.f32() * 4.0 - 1.5);
            rays.push(Ray::new(o, sub(aim, o)));
        }
        // Along the segment's own line, from beyond one end.
        let d = sub(c[2], c[0]);
        if d != [0.0; 3] {
            let o: [f32; 3] = std::array::from_fn(|x| c[0][x] - d[x]);
            rays.push(Ray::new(o, d));
        }
    }
    let t = trace_everything(&device(), &soup, &rays);
    for (i, ray) in rays.iter().enumerate() {
        let all = all_hits(&soup.positions, ray);
        assert!(
            all.iter().all(|h| h.prim >= degenerate),
            "ray {i} {ray:?} hit a degenerate triangle: {all:?}"
        );
        for (h, how) in [
            (t.dev_closest[i], "device closest"),
            (t.dev_stackless[i], "device stackless"),
            (t.dev_any[i], "device any"),
            (t.dev_wide[i], "device wide"),
            (t.dev_any_wide[i], "device wide any"),
            (t.dev_wide8[i], "device 8-wide"),
            (t.dev_any_wide8[i], "device 8-wide any"),
            (t.cpu_closest[i], "CPU closest"),
        ] {
            assert!(
                !h.is_hit() || h.prim >= degenerate,
                "{how}: ray {i} hit degenerate {h:?}"
            );
        }
    }
    assert_same(&t.dev_closest, &t.cpu_closest, &rays, "device vs CPU");
    // The ordinary triangles are still found.
    assert!(t.cpu_closest.iter().filter(|h| h.is_hit()).count() > rays.len() / 10);
}

/// Rays spawned from hit points with the robust offset: towards a light on
/// the lit side they never find their own surface (on a convex mesh nothing
/// at all), and into the surface they find a different triangle. Without
/// the offset, the same rays do hit their own triangle (so the test can
/// fail).
#[test]
fn offset_rays_do_not_self_intersect() {
    let sphere = icosphere(3);
    let mut rng = Rng::new(5);
    let mut unoffset_failures = 0;
    for (s, off) in PLACEMENTS {
        if s == 1.0 && off != 0.0 {
            continue; // see closed_meshes_are_watertight_at_every_scale
        }
        let what = format!("sphere x{s} +{off}");
        let soup = sphere.transformed(s, off).soup();
        let center = [off; 3];
        let unit = |rng: &mut Rng| -> [f32; 3] {
            loop {
                let v: [f32; 3] = std::array::from_fn(|_| rng.f32() * 2.0 - 1.0);
                let l = dot(v, v);
                if l > 0.01 && l <= 1.0 {
                    let l = l.sqrt();
                    return v.map(|c| c / l);
                }
            }
        };
        // Camera rays from outside at random points of the sphere.
        let primary: Vec<Ray> = (0..2000)
            .map(|_| {
                let from = unit(&mut rng);
                let at = unit(&mut rng);
                let o = std::array::from_fn(|a| center[a] + from[a] * 3.0 * s);
                let target = std::array::from_fn(|a| center[a] + at[a] * 0.8 * s);
                Ray::new(o, sub(target, o))
            })
            .collect();
        let first = trace_everything(&device(), &soup, &primary);
        let mut shadow = Vec::new();
        let mut inward = Vec::new();
        let mut raw_shadow = Vec::new();
        let mut sources = Vec::new();
        for (ray, h) in primary.iter().zip(&first.dev_closest) {
            assert!(h.is_hit(), "{what}: a camera ray missed the sphere");
            let p = hit_point(&soup.positions, h.prim, h.u, h.v);
            let mut n = geometric_normal(&soup.positions, h.prim);
            if dot(n, ray.dir) > 0.0 {
                n = n.map(|c| -c);
            }
            // A direction in the lit hemisphere (dot with n at least 0.1).
            let d = loop {
                let d = unit(&mut rng);
                if dot(d, n) >= 0.1 {
                    break d;
                }
            };
            let light: [f32; 3] = std::array::from_fn(|a| p[a] + d[a] * 4.0 * s);
            let o = offset_ray_origin(p, n);
            shadow.push(Ray {
                tmax: 1.0,
                ..Ray::new(o, sub(light, o))
            });
            raw_shadow.push(Ray {
                tmax: 1.0,
                ..Ray::new(p, sub(light, p))
            });
            let neg = n.map(|c| -c);
            let d_in = loop {
                let d = unit(&mut rng);
                if dot(d, neg) >= 0.1 {
                    break d;
                }
            };
            inward.push(Ray::new(offset_ray_origin(p, neg), d_in));
            sources.push(h.prim);
        }
        let sh = trace_everything(&device(), &soup, &shadow);
        for (i, h) in sh.dev_any.iter().enumerate() {
            assert!(
                !h.is_hit(),
                "{what}: shadow ray {i} {:?} from triangle {} is blocked by {h:?}",
                shadow[i],
                sources[i]
            );
        }
        assert!(
            sh.cpu_any
                .iter()
                .chain(&sh.dev_closest)
                .all(|h| !h.is_hit()),
            "{what}: shadow"
        );
        let inn = trace_everything(&device(), &soup, &inward);
        assert_same(&inn.dev_closest, &inn.cpu_closest, &inward, &what);
        for (i, h) in inn.dev_closest.iter().enumerate() {
            assert!(
                h.is_hit(),
                "{what}: inward ray {i} escaped the closed sphere"
            );
            assert_ne!(
                h.prim, sources[i],
                "{what}: inward ray {i} re-hit its own triangle at t = {}",
                h.t
            );
        }
        unoffset_failures += raw_shadow
            .iter()
            .filter(|r| trace::trace_any(&first.bvh, &soup.positions, r).is_hit())
            .count();
    }
    assert!(
        unoffset_failures > 0,
        "the test cannot tell: no unoffset ray self-intersects"
    );
}
