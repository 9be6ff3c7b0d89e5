//! Motion blur: the device against its Rust twins (step bounds, traversal
//! at a ray's time, the soup at every step), analytic images (a dark quad
//! sliding over a white background: a linear edge ramp of known width; the
//! same image from a camera sliding the other way; a rotating bar whose blur
//! follows the arc only with enough steps; the image mean of an object in
//! full view unchanged by the shutter), the step rule, and `--shutter 0`
//! equal to the unblurred render bit for bit.

mod common;

use common::render::*;
use common::{asset, soupray};
use glam::{Mat4, Vec3};
use soupray::bvh::device_builder::DeviceBuilder;
use soupray::bvh::BuildParams;
use soupray::device::Arg;
use soupray::scene::{FrameCamera, LoadOptions, Scene};
use soupray::soup::device::DeviceSoup;
use soupray::soup::motion::{motion_program_defines, motion_steps, MotionSoup};
use soupray::soup::Soup;
use soupray::trace::motion::{
    motion_bounds, motion_time, positions_at, step_times, trace_closest_motion,
};
use soupray::trace::render::{Environment, PathTracer};
use soupray::trace::{Hit, Ray};

/// `soup` moved by `offset`.
fn moved(soup: &Soup, offset: Vec3) -> Soup {
    let mut s = soup.clone();
    for p in &mut s.positions {
        p[0] += offset.x;
        p[1] += offset.y;
        p[2] += offset.z;
    }
    s
}

/// `soup` turned by `angle` about +Y through the origin.
fn turned(soup: &Soup, angle: f32) -> Soup {
    let m = Mat4::from_rotation_y(angle);
    let mut s = soup.clone();
    for p in &mut s.positions {
        let q = m.transform_point3(Vec3::new(p[0], p[1], p[2]));
        *p = [q.x, q.y, q.z, 0.0];
    }
    s
}

#[test]
fn device_bounds_and_traversal_at_a_time_match_the_rust_twins() {
    let d = common::device();
    let steps = 3u32;
    let base = common::random_soup(400, 0.08, 11);
    let n = base.triangle_count();
    // Each step moves and turns the soup a little differently.
    let soups: Vec<Soup> = (0..steps)
        .map(|s| {
            let t = s as f32 / (steps - 1) as f32;
            moved(
                &turned(&base, 0.3 * t),
                Vec3::new(0.2 * t, -0.1 * t, 0.05 * t),
            )
        })
        .collect();
    let data: Vec<[f32; 4]> = soups.iter().flat_map(|s| s.positions.clone()).collect();

    let program = d
        .build_program("motion.cl", &motion_program_defines())
        .unwrap();
    let bounds_kernel = d.kernel(&program, "motion_bounds").unwrap();
    let trace_kernel = d.kernel(&program, "motion_trace_closest").unwrap();
    let mut steps_buf = d.buffer::<[f32; 4]>(data.len()).unwrap();
    d.write(&mut steps_buf, &data).unwrap();
    let bounds_buf = d.buffer::<[f32; 4]>(3 * n).unwrap();
    d.launch(
        "motion/bounds",
        &bounds_kernel,
        n.div_ceil(64),
        64,
        &[
            Arg::Buf(&steps_buf),
            Arg::U32(n as u32),
            Arg::U32(steps),
            Arg::Buf(&bounds_buf),
        ],
    )
    .unwrap();
    let mut device_bounds = vec![[0.0f32; 4]; 3 * n];
    d.read(&bounds_buf, &mut device_bounds).unwrap();
    let host_bounds = motion_bounds(&data, n, steps);
    assert_eq!(device_bounds, host_bounds);
    // Every step's corners lie inside their triangle's box.
    for s in 0..steps as usize {
        for t in 0..n {
            for k in 0..3 {
                let p = data[3 * (s * n + t) + k];
                for a in 0..3 {
                    assert!(host_bounds[3 * t][a] <= p[a] && p[a] <= host_bounds[3 * t + 1][a]);
                }
            }
        }
    }

    // The tree over the bounds, and rays at random times.
    let mut builder = DeviceBuilder::new(&d, BuildParams::default()).unwrap();
    let bounds_soup = Soup {
        positions: host_bounds,
        ..Soup::default()
    };
    let (bvh, _) = builder.build(&bounds_soup).unwrap();
    let mut rng = common::Rng::new(5);
    let count = 2000;
    let mut rays = Vec::with_capacity(count);
    let mut times = Vec::with_capacity(count);
    for _ in 0..count {
        let o = [
            rng.f32() * 1.4 - 0.2,
            rng.f32() * 1.4 - 0.2,
            -1.0 + rng.f32() * 0.1,
        ];
        // Aimed at a triangle's centre at the ray's time: most rays hit.
        let time = rng.f32();
        let j = ((rng.f32() * n as f32) as u32).min(n as u32 - 1);
        let at = soupray::trace::motion::motion_triangle(&data, n, motion_time(time, steps), j);
        let target: [f32; 3] = std::array::from_fn(|a| (at[0][a] + at[1][a] + at[2][a]) / 3.0);
        rays.push(Ray::new(
            o,
            [target[0] - o[0], target[1] - o[1], target[2] - o[2]],
        ));
        times.push(time);
    }
    let mut ray_buf = d.buffer::<Ray>(count).unwrap();
    d.write(&mut ray_buf, &rays).unwrap();
    let mut time_buf = d.buffer::<f32>(count).unwrap();
    d.write(&mut time_buf, &times).unwrap();
    let hit_buf = d.buffer::<Hit>(count).unwrap();
    let mut nodes = d.buffer(bvh.nodes.len()).unwrap();
    d.write(&mut nodes, &bvh.nodes).unwrap();
    d.launch(
        "motion/trace",
        &trace_kernel,
        count.div_ceil(64),
        64,
        &[
            Arg::Buf(&nodes),
            Arg::Buf(builder.device_prim_ids().unwrap()),
            Arg::Buf(&steps_buf),
            Arg::U32(steps),
            Arg::U32(n as u32),
            Arg::Buf(&ray_buf),
            Arg::Buf(&time_buf),
            Arg::Buf(&hit_buf),
            Arg::U32(count as u32),
        ],
    )
    .unwrap();
    let mut hits = vec![Hit::miss(0.0); count];
    d.read(&hit_buf, &mut hits).unwrap();
    d.finish().unwrap();
    let mut hit_count = 0;
    for i in 0..count {
        let cpu = trace_closest_motion(&bvh, &data, n, steps, &rays[i], times[i]);
        assert_eq!(hits[i].bits(), cpu.bits(), "ray {i} at time {}", times[i]);
        hit_count += cpu.is_hit() as usize;
        // And the hit is the triangle where the ray meets it at its time.
        if cpu.is_hit() {
            let at = positions_at(&data, n, steps, times[i]);
            let p = soupray::trace::intersect::hit_point(&at, cpu.prim, cpu.u, cpu.v);
            let r = &rays[i];
            for a in 0..3 {
                let q = r.org[a] + cpu.t * r.dir[a];
                assert!((p[a] - q).abs() < 1e-4, "ray {i}: hit point {p:?} vs {q}");
            }
        }
    }
    assert!(hit_count > count * 9 / 10, "{hit_count} hits of {count}");
    let (k, f) = motion_time(0.75, 3);
    assert_eq!((k, f), (1, 0.5));
}

/// The soup at each step on the device is the device soup evaluated at that
/// step's time, and the bounds enclose every step; the step rule finds no
/// motion in a still shutter and more steps for faster turns.
#[test]
fn motion_soup_keeps_every_step_and_the_rule_counts_the_turn() {
    let d = common::device();
    let Some(animated_cube_gltf) = asset("AnimatedCube/AnimatedCube.gltf") else {
        return;
    };
    let scene = Scene::load(&animated_cube_gltf, &LoadOptions::default()).unwrap();
    let mut soup = DeviceSoup::new(&d, &scene).unwrap();
    let mut motion = MotionSoup::new(&d, &soup).unwrap();
    let n = soup.triangle_count();
    let times = step_times(0.4, 0.6, 4);
    motion.evaluate(&mut soup, &scene, &times).unwrap();
    let (steps, bounds) = motion.read_back().unwrap();
    assert_eq!(steps.len(), 4 * 3 * n);
    for (s, &t) in times.iter().enumerate() {
        soup.evaluate(&scene, t).unwrap();
        let one = soup.read_back().unwrap();
        assert_eq!(
            &steps[3 * n * s..3 * n * (s + 1)],
            &one.positions[..],
            "step {s}"
        );
    }
    assert_eq!(bounds, motion_bounds(&steps, n, 4));
    assert_eq!(motion.steps(), 4);

    // The cube turns a full circle over its clip: the rule's steps grow
    // with the turn within the shutter, and a shutter of no length has none.
    let duration = scene.duration();
    let short = motion_steps(&scene, 0.0, duration / 48.0, None);
    let long = motion_steps(&scene, 0.0, duration / 4.0, None);
    assert!(short.turn_degrees > 0.0, "{short:?}");
    assert!(
        long.turn_degrees > 3.0 * short.turn_degrees,
        "{short:?} {long:?}"
    );
    assert!(
        long.steps > short.steps && short.steps >= 2,
        "{short:?} {long:?}"
    );
    assert_eq!(
        long.steps,
        ((long.turn_degrees / 15.0).ceil() as u32 + 1).clamp(2, 16)
    );
    assert_eq!(motion_steps(&scene, 0.5, 0.5, None).steps, 1);
    assert_eq!(motion_steps(&scene, 0.0, duration / 4.0, Some(9)).steps, 9);
}

// The analytic scenes: a black quad (or bar) over a white environment, seen
// straight down by an orthographic camera, at max_depth 0 so a hit is 0 and
// a miss is 1: a pixel's value is the fraction of the shutter it is not
// covered (convolved with the pixel filter, radius 1.5 px).
const W: u32 = 96;
const H: u32 = 8;
/// Half the view's height in world units; the width is 12 units, 8 px each.
const HALF: f32 = 0.5;

fn strip_camera(x: f32) -> FrameCamera {
    orthographic(
        Vec3::new(x, 10.0, 0.0),
        Vec3::new(x, 0.0, 0.0),
        Vec3::NEG_Z,
        HALF,
    )
}

fn black_tracer(d: &soupray::device::Device, w: u32, h: u32, spp: u32) -> PathTracer<'_> {
    let mut st = settings(w, spp);
    st.height = h;
    st.max_depth = 0;
    st.environment = Environment::Color([1.0, 1.0, 1.0]);
    PathTracer::with_materials(
        d,
        &table(vec![material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0)]),
        &st,
    )
    .unwrap()
}

/// A quad over x in [x0, x1], covering the strip's height.
fn strip_quad(x0: f32, x1: f32) -> Soup {
    let mut s = Soup::default();
    quad(
        &mut s,
        Vec3::new(0.5 * (x0 + x1), 0.0, 0.0),
        Vec3::X * (0.5 * (x1 - x0)),
        Vec3::Z * 2.0,
        Vec3::Y,
        0,
    );
    s
}

/// Column means over the rows.
fn column_means(img: &soupray::film::Image) -> Vec<f64> {
    (0..img.width as usize)
        .map(|x| {
            (0..img.height as usize)
                .map(|y| grey(img.rgba[y * img.width as usize + x]))
                .sum::<f64>()
                / img.height as f64
        })
        .collect()
}

/// The world x of column `x`'s centre.
fn column_x(x: usize) -> f32 {
    ((x as f32 + 0.5) / W as f32 * 2.0 - 1.0) * HALF * (W as f32 / H as f32)
}

/// The fraction of the shutter the quad sliding from [-4, -1] to [-2, 1]
/// covers the point x.
fn sliding_coverage(x: f32) -> f64 {
    let x = x as f64;
    if x <= -4.0 || x >= 1.0 {
        0.0
    } else if x < -2.0 {
        (x + 4.0) / 2.0
    } else if x <= -1.0 {
        1.0
    } else {
        1.0 - (x + 1.0) / 2.0
    }
}

#[test]
fn sliding_quad_edges_are_linear_ramps_of_the_distance_travelled() {
    let d = common::device();
    let spp = 256;
    let mut pt = black_tracer(&d, W, H, spp);
    let open = strip_quad(-4.0, -1.0);
    let close = moved(&open, Vec3::X * 2.0);
    let cam = strip_camera(0.0);
    let out = pt
        .render_motion_soup(&[open.clone(), close], &[cam.clone(), cam.clone()], &[], 0)
        .unwrap();
    let cols = column_means(&out.image);
    let samples = (spp * H) as f64;
    let mut checked = 0;
    for (x, &v) in cols.iter().enumerate() {
        let wx = column_x(x);
        let f = sliding_coverage(wx);
        // Away from the ramps' ends by more than the filter radius (2 px =
        // 0.25 units), the filter's average of the linear ramp is its value
        // at the pixel's centre.
        let near_kink = [-4.0f32, -2.0, -1.0, 1.0]
            .iter()
            .any(|k| (wx - k).abs() < 0.25);
        if near_kink {
            continue;
        }
        // Each sample is covered or not: the Bernoulli standard error (an
        // upper bound for stratified samples).
        let se = (f * (1.0 - f) / samples).sqrt();
        assert!(
            (v - (1.0 - f)).abs() <= 3.0 * se + 1e-6,
            "column {x} (x = {wx}): {v} against {} ± {se}",
            1.0 - f
        );
        checked += 1;
    }
    assert!(checked > 60, "{checked} columns checked");

    // Each ramp's width from a least-squares line through its interior:
    // the distance travelled, 2 units = 16 px, within 5%.
    for (lo, hi, sign) in [(-3.75f32, -2.25f32, -1.0f64), (-0.75, 0.75, 1.0)] {
        let pts: Vec<(f64, f64)> = (0..W as usize)
            .filter(|&x| column_x(x) > lo && column_x(x) < hi)
            .map(|x| (x as f64, cols[x]))
            .collect();
        let n = pts.len() as f64;
        let mx = pts.iter().map(|p| p.0).sum::<f64>() / n;
        let my = pts.iter().map(|p| p.1).sum::<f64>() / n;
        let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
        let sxx: f64 = pts.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
        let slope = sxy / sxx;
        let width = 1.0 / (sign * slope);
        assert!(
            (width - 16.0).abs() < 0.05 * 16.0,
            "ramp over [{lo}, {hi}]: width {width} px, expected 16"
        );
    }

    // Energy: the quad is in full view all the time, so the image mean is
    // what it is without blur (1 - 3/12), within noise.
    let still = pt
        .render_motion_soup(&[open.clone(), open], &[cam.clone(), cam], &[], 0)
        .unwrap();
    let mean = |img: &soupray::film::Image| {
        img.rgba.iter().map(|p| grey(*p)).sum::<f64>() / img.rgba.len() as f64
    };
    let (blurred, sharp) = (mean(&out.image), mean(&still.image));
    // At most 32 columns of ramp, each of SE 1/(2 sqrt(samples)) at worst.
    let se = 32.0 * 0.5 / samples.sqrt() / W as f64;
    assert!((blurred - 0.75).abs() < 3.0 * se, "blurred mean {blurred}");
    assert!((sharp - 0.75).abs() < 3.0 * se, "sharp mean {sharp}");
}

#[test]
fn a_sliding_camera_blurs_like_the_sliding_quad() {
    let d = common::device();
    let spp = 64;
    let mut pt = black_tracer(&d, W, H, spp);
    let open = strip_quad(-4.0, -1.0);
    let quad_moves = pt
        .render_motion_soup(
            &[open.clone(), moved(&open, Vec3::X * 2.0)],
            &[strip_camera(0.0), strip_camera(0.0)],
            &[],
            0,
        )
        .unwrap();
    // The camera slides by -2 instead: the same relative motion, the same
    // samples, so the same image up to rounding at the edges.
    let camera_moves = pt
        .render_motion_soup(
            &[open.clone(), open],
            &[strip_camera(0.0), strip_camera(-2.0)],
            &[],
            0,
        )
        .unwrap();
    let a = column_means(&quad_moves.image);
    let b = column_means(&camera_moves.image);
    // The camera's view is shifted by the slide: column x of the moving
    // camera at time 0 is column x of the still one.
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| (x - y).abs())
        .fold(0.0, f64::max);
    assert!(worst <= 2.0 / (spp * H) as f64, "columns differ by {worst}");
    assert!(a.iter().any(|&v| v > 0.2 && v < 0.8), "a ramp was rendered");
}

/// A black bar of half-length 1 and half-width 0.1 through the origin,
/// turned by `angle` about +Y.
fn bar(angle: f32) -> Soup {
    let mut s = Soup::default();
    quad(&mut s, Vec3::ZERO, Vec3::X, Vec3::Z * 0.1, Vec3::Y, 0);
    turned(&s, angle)
}

#[test]
fn a_turning_bar_blurs_along_the_arc_with_enough_steps() {
    let d = common::device();
    let size = 64;
    let half = 1.2;
    let spp = 256;
    let mut pt = black_tracer(&d, size, size, spp);
    let cam = top_down(half);
    let turn = std::f32::consts::FRAC_PI_2;
    let render = |pt: &mut PathTracer, steps: u32| {
        let soups: Vec<Soup> = (0..steps)
            .map(|s| bar(turn * s as f32 / (steps - 1) as f32))
            .collect();
        let cams = vec![cam.clone(); steps as usize];
        pt.render_motion_soup(&soups, &cams, &[], 0).unwrap().image
    };
    // The pixel at radius 0.95 halfway through the turn (on the diagonal
    // between the bar's first and last directions).
    let rho = 0.95f32;
    let mid = Mat4::from_rotation_y(0.5 * turn).transform_point3(Vec3::X * rho);
    let px = ((mid.x / half + 1.0) * 0.5 * size as f32) as u32;
    let py = ((mid.z / half + 1.0) * 0.5 * size as f32) as u32;
    let at = |img: &soupray::film::Image| grey(img.rgba[(py * size + px) as usize]);

    // Two steps: every vertex moves along its chord, the bar shrinks to
    // 0.71 of its length halfway and never reaches the pixel.
    let chord = render(&mut pt, 2);
    assert_eq!(at(&chord), 1.0, "two steps cut the corner");
    // The step rule's count for a 90° turn (one step per 15°, plus one):
    // the bar sweeps the arc, covering the pixel for the fraction of the
    // turn its width subtends at that radius.
    let steps = (90.0f64 / 15.0).ceil() as u32 + 1;
    let arc = render(&mut pt, steps);
    let f = 2.0 * (0.1f64 / rho as f64).asin() / std::f64::consts::FRAC_PI_2;
    let se = (f * (1.0 - f) / spp as f64).sqrt();
    let v = at(&arc);
    assert!(
        (v - (1.0 - f)).abs() < 3.0 * se + 0.01,
        "arc pixel {v}, expected {} ± {se}",
        1.0 - f
    );
}

#[test]
fn shutter_zero_is_the_unblurred_frame_bit_for_bit_and_the_log_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let Some(scene) = asset("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    let scene = scene.to_str().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "render",
            scene,
            "--frame",
            "30",
            "--width",
            "48",
            "--height",
            "27",
            "--spp",
            "4",
            "--quiet",
            "--out",
            out.to_str().unwrap(),
        ];
        args.extend_from_slice(extra);
        let o = soupray(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let img = common::read_exr(&out.join("BoxAnimated.0030.exr"));
        let log: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("BoxAnimated.0030.json")).unwrap())
                .unwrap();
        (img, log)
    };
    let (plain, plain_log) = run("plain", &[]);
    let (zero, zero_log) = run("zero", &["--motion-blur", "--shutter", "0"]);
    let (blur, blur_log) = run("blur", &["--motion-blur", "--shutter", "2"]);
    assert!(plain_log.get("motion").is_none());
    assert_eq!(zero_log["motion"]["steps"], 1);
    assert_eq!(bits(&plain), bits(&zero), "--shutter 0 changed the image");
    // Frame 30 moves: blur evaluates two or more steps and changes pixels.
    let steps = blur_log["motion"]["steps"].as_u64().unwrap();
    assert!(steps >= 2, "{blur_log}");
    assert_eq!(blur_log["motion"]["shutter_frames"], 2.0);
    assert_eq!(blur_log["motion"]["shutter_position"], "center");
    assert!(blur_log["motion"]["close"].as_f64() > blur_log["motion"]["open"].as_f64());
    assert_ne!(bits(&plain), bits(&blur));
    // A bad shutter is a usage error naming the flag.
    let o = soupray(&["render", scene, "--motion-blur", "--shutter", "-1"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--shutter"));
    let o = soupray(&[
        "render",
        scene,
        "--motion-blur",
        "--shutter-position",
        "middle",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--shutter-position"));
}

/// An emitter sliding over a lit floor: the blurred floor is the average of
/// the floor lit from where the emitter is over the shutter (next-event
/// estimation samples the emitter where it is at each path's time, and MIS
/// weighs it with the same time's pdf), not the floor lit from where it
/// was when the shutter opened.
#[test]
fn a_moving_emitter_lights_the_floor_from_where_it_is_at_each_time() {
    let d = common::device();
    let size = 24;
    let spp = 64;
    let travel = 1.2f32;
    let floor_and_emitter = |x: f32| {
        let mut s = ground_plane();
        quad(
            &mut s,
            Vec3::new(x, 1.0, 0.0),
            Vec3::X * 0.6,
            Vec3::Z * 0.4,
            Vec3::NEG_Y,
            1,
        );
        s
    };
    let mut emitter = material([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
    emitter.emissive_factor = [1.0, 1.0, 1.0];
    emitter.emissive_strength = 4.0;
    let t = table(vec![material([0.8, 0.8, 0.8, 1.0], 0.0, 1.0), emitter]);
    let mut st = settings(size, spp);
    st.max_depth = 1;
    st.environment = Environment::Color([0.0, 0.0, 0.0]);
    // The camera above sees the floor through the emitter's culled back.
    let cam = top_down(1.5);
    let bands = |img: &soupray::film::Image| -> [f64; 3] {
        let mut sums = [0.0; 3];
        for (i, p) in img.rgba.iter().enumerate() {
            sums[(i % size as usize) * 3 / size as usize] += grey(*p);
        }
        sums.map(|s| s / (img.rgba.len() / 3) as f64)
    };
    let mut pt = PathTracer::with_materials(&d, &t, &st).unwrap();
    let blurred = pt
        .render_motion_soup(
            &[
                floor_and_emitter(-0.5 * travel),
                floor_and_emitter(0.5 * travel),
            ],
            &[cam.clone(), cam.clone()],
            &[],
            0,
        )
        .unwrap();
    let blurred = bands(&blurred.image);
    // The time average by the midpoint rule over still frames.
    let k = 12;
    let mut average = [0.0; 3];
    let mut at_open = [0.0; 3];
    for i in 0..k {
        let x = travel * ((i as f32 + 0.5) / k as f32 - 0.5);
        let img = pt
            .render_soup(&floor_and_emitter(x), &cam, &[], i as i64)
            .unwrap()
            .image;
        let b = bands(&img);
        for j in 0..3 {
            average[j] += b[j] / k as f64;
        }
        if i == 0 {
            at_open = b;
        }
    }
    for j in 0..3 {
        let rel = (blurred[j] - average[j]).abs() / average[j];
        assert!(
            rel < 0.03,
            "band {j}: blurred {} against the time average {} ({rel})",
            blurred[j],
            average[j]
        );
    }
    // The test can tell: the floor lit from the opening position differs.
    let rel_open = (at_open[0] - average[0]).abs() / average[0];
    assert!(
        rel_open > 0.1,
        "opening position differs by only {rel_open}"
    );
}

/// A point light sliding over the floor: the blurred floor is the time
/// average of the floor lit from each position (lights are read at each
/// path's time), not the floor lit from the frame's instant.
#[test]
fn a_moving_point_light_lights_the_floor_from_where_it_is_at_each_time() {
    use soupray::scene::LightKind;
    let d = common::device();
    let size = 24;
    let spp = 16;
    let travel = 1.6f32;
    let lamp = |x: f32| {
        vec![light(
            LightKind::Point,
            Vec3::new(x, 0.7, 0.0),
            Vec3::NEG_Y,
            [1.0, 1.0, 1.0],
            2.0,
        )]
    };
    let t = table(vec![material([0.8, 0.8, 0.8, 1.0], 0.0, 1.0)]);
    let mut st = settings(size, spp);
    st.max_depth = 1;
    st.environment = Environment::Color([0.0, 0.0, 0.0]);
    let cam = top_down(1.5);
    let bands = |img: &soupray::film::Image| -> [f64; 3] {
        let mut sums = [0.0; 3];
        for (i, p) in img.rgba.iter().enumerate() {
            sums[(i % size as usize) * 3 / size as usize] += grey(*p);
        }
        sums.map(|s| s / (img.rgba.len() / 3) as f64)
    };
    let floor = ground_plane();
    let mut pt = PathTracer::with_materials(&d, &t, &st).unwrap();
    let blurred = pt
        .render_motion_soup(
            &[floor.clone(), floor.clone()],
            &[cam.clone(), cam.clone()],
            &[lamp(-0.5 * travel), lamp(0.5 * travel)],
            0,
        )
        .unwrap();
    let blurred = bands(&blurred.image);
    let k = 16;
    let mut average = [0.0; 3];
    for i in 0..k {
        let x = travel * ((i as f32 + 0.5) / k as f32 - 0.5);
        let img = pt
            .render_soup(&floor, &cam, &lamp(x), i as i64)
            .unwrap()
            .image;
        let b = bands(&img);
        for j in 0..3 {
            average[j] += b[j] / k as f64;
        }
    }
    let still = bands(&pt.render_soup(&floor, &cam, &lamp(0.0), 0).unwrap().image);
    for j in 0..3 {
        let rel = (blurred[j] - average[j]).abs() / average[j];
        assert!(
            rel < 0.03,
            "band {j}: blurred {} against the time average {} ({rel})",
            blurred[j],
            average[j]
        );
    }
    // The frame's instant alone lights the side bands differently.
    let rel_still = (still[0] - average[0]).abs() / average[0];
    assert!(
        rel_still > 0.1,
        "the still light differs by only {rel_still}"
    );
}

/// A frame where nothing moves within the shutter (the walk's frame 0: its
/// shutter ends before the clip's first key moves anything) does no motion
/// work and renders the unblurred image bit for bit.
#[test]
fn a_frame_still_within_its_shutter_renders_as_without_blur() {
    let Some(scene) = common::shared::cesium_man() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let scene = scene.to_str().unwrap();
    let run = |name: &str, extra: &[&str]| {
        let out = dir.path().join(name);
        let mut args = vec![
            "render", scene, "--frame", "0", "--width", "48", "--height", "27", "--spp", "2",
            "--quiet", "--out",
        ];
        let out_s = out.to_str().unwrap().to_owned();
        args.push(&out_s);
        args.extend_from_slice(extra);
        let o = soupray(&args);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let img = common::read_exr(&out.join("CesiumMan.0000.exr"));
        let log: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("CesiumMan.0000.json")).unwrap())
                .unwrap();
        (img, log)
    };
    let (plain, _) = run("plain", &[]);
    let (blur, log) = run("blur", &["--motion-blur"]);
    assert_eq!(log["motion"]["steps"], 1, "{log}");
    assert_eq!(log["motion"]["extra_evaluate_ms"], 0.0);
    assert!(log["motion"]["open"].as_f64() < log["motion"]["close"].as_f64());
    assert_eq!(bits(&plain), bits(&blur));
}

/// The camera and light interpolation of `kernels/trace/motion.h` against their
/// Rust twins, bit for bit, on random cameras, lights and times.
#[test]
fn camera_and_light_at_a_time_match_the_rust_twins() {
    use soupray::trace::lights::DeviceLight;
    use soupray::trace::motion::{camera_at, light_at};
    use soupray::trace::render::{device_camera, DeviceCamera};
    let d = common::device();
    let program = d
        .build_program("motion.cl", &motion_program_defines())
        .unwrap();
    let mut rng = common::Rng::new(9);
    let steps = 5u32;
    let cams: Vec<DeviceCamera> = (0..steps)
        .map(|_| {
            let eye = Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 4.0 + Vec3::Z * 3.0;
            device_camera(&perspective(eye, Vec3::ZERO, Vec3::Y, 40.0), 64, 36)
        })
        .collect();
    let n = 256;
    let times: Vec<f32> = (0..n).map(|_| rng.f32()).collect();
    let mut cam_buf = d.buffer::<DeviceCamera>(cams.len()).unwrap();
    d.write(&mut cam_buf, &cams).unwrap();
    let mut time_buf = d.buffer::<f32>(n).unwrap();
    d.write(&mut time_buf, &times).unwrap();
    let out_buf = d.buffer::<DeviceCamera>(n).unwrap();
    let k = d.kernel(&program, "motion_camera_probe").unwrap();
    d.launch(
        "probe",
        &k,
        n.div_ceil(64),
        64,
        &[
            Arg::Buf(&cam_buf),
            Arg::U32(steps),
            Arg::Buf(&time_buf),
            Arg::Buf(&out_buf),
            Arg::U32(n as u32),
        ],
    )
    .unwrap();
    let mut out = vec![DeviceCamera::default(); n];
    d.read(&out_buf, &mut out).unwrap();
    for i in 0..n {
        let host = camera_at(&cams, motion_time(times[i], steps));
        assert_eq!(
            bytemuck::bytes_of(&out[i]),
            bytemuck::bytes_of(&host),
            "time {}",
            times[i]
        );
    }

    let light = |rng: &mut common::Rng| DeviceLight {
        position: [rng.f32(), rng.f32(), rng.f32()],
        kind: 1,
        direction: {
            let v = Vec3::new(rng.f32() - 0.5, rng.f32() - 0.5, rng.f32() - 0.5).normalize();
            [v.x, v.y, v.z]
        },
        range: 0.0,
        intensity: [1.0, 2.0, 3.0],
        angle_scale: 1.5,
        angle_offset: -0.5,
        pad: [0.0; 3],
    };
    let a: Vec<DeviceLight> = (0..n).map(|_| light(&mut rng)).collect();
    let b: Vec<DeviceLight> = (0..n).map(|_| light(&mut rng)).collect();
    let mut a_buf = d.buffer::<DeviceLight>(n).unwrap();
    d.write(&mut a_buf, &a).unwrap();
    let mut b_buf = d.buffer::<DeviceLight>(n).unwrap();
    d.write(&mut b_buf, &b).unwrap();
    let out_buf = d.buffer::<DeviceLight>(n).unwrap();
    let k = d.kernel(&program, "motion_light_probe").unwrap();
    d.launch(
        "probe",
        &k,
        n.div_ceil(64),
        64,
        &[
            Arg::Buf(&a_buf),
            Arg::Buf(&b_buf),
            Arg::Buf(&time_buf),
            Arg::Buf(&out_buf),
            Arg::U32(n as u32),
        ],
    )
    .unwrap();
    let mut out = vec![a[0]; n];
    d.read(&out_buf, &mut out).unwrap();
    d.finish().unwrap();
    for i in 0..n {
        let host = light_at(&a[i], &b[i], times[i]);
        assert_eq!(
            bytemuck::bytes_of(&out[i]),
            bytemuck::bytes_of(&host),
            "light {i} at {}",
            times[i]
        );
    }
}
