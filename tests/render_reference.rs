//! The integrator's device functions against their plain Rust references,
//! on random inputs: the struct layouts, the counter-based random numbers
//! (bit for bit), the BSDF's eval, pdf and sample, the punctual lights and
//! the environment map's radiance, pdf and sampling (within tight
//! tolerances: the device's sin, cos, sqrt and atan2 may differ by ulps).

mod common;

use common::{
    check_bsdf_probe, close, random_dir, random_upper_dir, run_probe, upload, BsdfProbeTally, Rng,
};
use glam::Vec3;
use soupray::device::{Arg, Device};
use soupray::scene::{FrameLight, LightKind};
use soupray::trace::light_tree;
use soupray::trace::lights::{
    punctual_incident, DeviceEnv, DeviceLight, EnvMap, ENV_MAP, LIGHT_POINT, LIGHT_SPOT,
};
use soupray::trace::material::BsdfParams;
use soupray::trace::sampling::{SampleRng, Sampler};

fn run(d: &Device, kernel: &str, args: &[Arg], n: usize) {
    let program = d.build_program("pt_probe.cl", &[]).unwrap();
    let k = d.kernel(&program, kernel).unwrap();
    d.launch("probe", &k, n.div_ceil(64), 64, args).unwrap();
    d.finish().unwrap();
}

/// Draws `n` cases of (seed, frame, pixel, sample, dim) on the device
/// built for `sampler` and returns (device values, reference values).
fn random_numbers(sampler: Sampler, samples: &[u32]) -> (Vec<f32>, Vec<f32>) {
    let d = common::device();
    let mut rng = Rng::new(5);
    let mut input = Vec::new();
    let mut want = Vec::new();
    for (i, &sample) in samples.iter().enumerate() {
        let seed = ((rng.f32() * 1e6) as u64) << (i % 40);
        let frame = (rng.f32() * 2000.0) as i64 - 1000;
        let (pixel, dim) = ((rng.f32() * 1e6) as u32, (rng.f32() * 300.0) as u32);
        let f = frame as u64;
        input.extend_from_slice(&[
            seed as u32,
            (seed >> 32) as u32,
            f as u32,
            (f >> 32) as u32,
            pixel,
            sample,
            dim,
        ]);
        want.push(SampleRng::new(sampler, seed, frame, pixel, sample).get(dim));
    }
    let n = samples.len();
    let defines: Vec<(&str, String)> = sampler
        .define()
        .map(|d| vec![(d, "1".to_owned())])
        .unwrap_or_default();
    let program = d.build_program("pt_probe.cl", &defines).unwrap();
    let k = d.kernel(&program, "rng_probe").unwrap();
    let got: Vec<f32> = run_probe(&d, &k, &input, n, n);
    (got, want)
}

#[test]
fn random_numbers_are_the_references_bit_for_bit() {
    // Sample indices small and large: past 65536 the Sobol sampler takes
    // the sample's high bits as they are.
    let samples: Vec<u32> = (0..4096u32)
        .map(|i| match i % 4 {
            0 => i % 97,
            1 => i * 37,
            2 => 65_536 + i * 1009,
            _ => i.wrapping_mul(2_654_435_761),
        })
        .collect();
    for sampler in [Sampler::Sobol, Sampler::Random] {
        let (got, want) = random_numbers(sampler, &samples);
        assert_eq!(got, want, "{sampler:?}");
        // Uniform: the mean and the range of 4096 values.
        let m = got.iter().map(|&v| v as f64).sum::<f64>() / got.len() as f64;
        assert!(
            (m - 0.5).abs() < 0.02 && got.iter().all(|v| (0.0..1.0).contains(v)),
            "{sampler:?}: mean {m}"
        );
    }
}

#[test]
fn bsdf_matches_the_reference() {
    let d = common::device();
    let mut rng = Rng::new(11);
    let n = 3000;
    let mut input = Vec::new();
    let mut cases = Vec::new();
    for i in 0..n {
        let p = if i % 7 == 0 {
            BsdfParams::clay()
        } else {
            BsdfParams::new(
                [rng.f32(), rng.f32(), rng.f32()],
                // Every twelfth a smooth metal: only a delta lobe.
                if i % 12 == 1 { 1.0 } else { rng.f32() },
                // Every sixth: smooth, so the reflection is a delta lobe.
                if i % 6 == 1 { 0.0 } else { rng.f32().max(0.05) },
            )
        };
        let wo = random_upper_dir(&mut rng);
        let wi = if i % 5 != 0 {
            random_upper_dir(&mut rng)
        } else {
            random_dir(&mut rng)
        };
        let u = [rng.f32(), rng.f32(), rng.f32()];
        input.extend_from_slice(&[
            p.base.x, p.base.y, p.base.z, p.metallic, p.alpha, p.specular, 0.0, 0.0,
        ]);
        input.extend_from_slice(&[wo.x, wo.y, wo.z, 0.0, wi.x, wi.y, wi.z, 0.0]);
        input.extend_from_slice(&[u[0], u[1], u[2], 0.0]);
        cases.push((p, wo, wi, u));
    }
    let inb = upload(&d, &input);
    let out = upload(&d, &vec![0.0f32; 12 * n]);
    run(
        &d,
        "bsdf_probe",
        &[Arg::Buf(&inb), Arg::Buf(&out), Arg::U32(n as u32)],
        n,
    );
    let mut got = vec![0.0f32; 12 * n];
    d.read(&out, &mut got).unwrap();
    let mut tally = BsdfProbeTally::default();
    for (i, (p, wo, wi, u)) in cases.iter().enumerate() {
        let what = format!("case {i} {p:?} wo {wo} wi {wi}");
        let o = &got[12 * i..12 * i + 12];
        check_bsdf_probe(o, p, *wo, *wi, *u, 2e-4, &what, &mut tally);
    }
    let BsdfProbeTally {
        sampled,
        deltas,
        only_delta,
        ..
    } = tally;
    assert!(sampled > n / 2, "{sampled} of {n} sampled");
    assert!(deltas > n / 40, "{deltas} of {n} from delta lobes");
    assert!(only_delta > 0, "no material with only delta lobes");
}

#[test]
fn punctual_lights_match_the_reference() {
    let d = common::device();
    let mut rng = Rng::new(3);
    let kinds = [
        LightKind::Point,
        LightKind::Directional,
        LightKind::Spot {
            inner_cone_angle: 0.2,
            outer_cone_angle: 0.7,
        },
        LightKind::Spot {
            inner_cone_angle: 0.5,
            outer_cone_angle: 0.5,
        },
    ];
    let lights: Vec<DeviceLight> = (0..8)
        .map(|i| {
            let l = FrameLight {
                name: None,
                node: 0,
                kind: kinds[i % 4],
                color: [rng.f32(), rng.f32(), rng.f32()],
                intensity: 1.0 + 10.0 * rng.f32(),
                range: if i % 3 == 0 {
                    Some(2.0 + rng.f32())
                } else {
                    None
                },
                position: Vec3::new(rng.f32(), rng.f32(), rng.f32()) * 2.0,
                direction: random_dir(&mut rng),
            };
            DeviceLight::from_frame_light(&l)
        })
        .collect();
    let n = 4000;
    let mut input = Vec::new();
    for i in 0..n {
        input.extend_from_slice(&[
            (i % 8) as f32,
            rng.f32() * 4.0 - 1.0,
            rng.f32() * 4.0 - 1.0,
            rng.f32() * 4.0 - 1.0,
        ]);
    }
    let lb = upload(&d, &lights);
    let inb = upload(&d, &input);
    let out = upload(&d, &vec![0.0f32; 8 * n]);
    run(
        &d,
        "light_probe",
        &[
            Arg::Buf(&lb),
            Arg::Buf(&inb),
            Arg::Buf(&out),
            Arg::U32(n as u32),
        ],
        n,
    );
    let mut got = vec![0.0f32; 8 * n];
    d.read(&out, &mut got).unwrap();
    let mut lit = 0;
    for i in 0..n {
        let c = &input[4 * i..4 * i + 4];
        let o = &got[8 * i..8 * i + 8];
        let what = format!("case {i} light {:?} at {c:?}", lights[c[0] as usize]);
        match punctual_incident(&lights[c[0] as usize], Vec3::new(c[1], c[2], c[3])) {
            Some((w, dist, e)) => {
                assert_eq!(o[0], 1.0, "{what}");
                for k in 0..3 {
                    close(o[1 + k], w[k], 1e-5, &what);
                    close(o[5 + k], e[k], 1e-4, &what);
                }
                if dist.is_finite() {
                    close(o[4], dist, 1e-5, &what);
                } else {
                    assert!(o[4].is_infinite(), "{what}");
                }
                lit += 1;
            }
            // Right at a cone or range edge the two may round differently.
            None => assert!(
                o[0] == 0.0 || o[5..8].iter().all(|v| *v < 1e-5),
                "{what}: {o:?}"
            ),
        }
    }
    assert!(lit > n / 3, "{lit}");
}

/// Random point and spot lights as the tree takes them: `count` at each of
/// `steps` motion steps, each light moving a little between steps.
fn random_lights(rng: &mut Rng, count: usize, steps: usize) -> Vec<DeviceLight> {
    let first: Vec<FrameLight> = (0..count)
        .map(|i| FrameLight {
            name: None,
            node: 0,
            kind: if i % 3 == 0 {
                LightKind::Spot {
                    inner_cone_angle: 0.3 * rng.f32(),
                    outer_cone_angle: 0.3 + 0.6 * rng.f32(),
                }
            } else {
                LightKind::Point
            },
            color: [rng.f32(), rng.f32(), rng.f32()],
            intensity: 0.1 + 10.0 * rng.f32(),
            range: None,
            position: Vec3::new(
                rng.f32() * 20.0 - 10.0,
                rng.f32() * 2.0,
                rng.f32() * 4.0 - 2.0,
            ),
            direction: random_dir(rng),
        })
        .collect();
    let mut out = Vec::new();
    for s in 0..steps {
        out.extend(first.iter().map(|l| {
            let mut l = l.clone();
            l.position += Vec3::new(0.1, 0.0, 0.05) * s as f32;
            DeviceLight::from_frame_light(&l)
        }));
    }
    out
}

/// Random emissive triangles in the lights' street, a third double-sided,
/// at each of `steps` motion steps.
fn random_emitters(rng: &mut Rng, count: usize, steps: usize) -> Vec<light_tree::EmissiveTriangle> {
    (0..count)
        .map(|k| {
            let c = Vec3::new(
                rng.f32() * 20.0 - 10.0,
                rng.f32() * 2.0,
                rng.f32() * 4.0 - 2.0,
            );
            let corners = [c, c + random_dir(rng) * 0.2, c + random_dir(rng) * 0.2];
            light_tree::EmissiveTriangle {
                corners: (0..steps)
                    .map(|s| corners.map(|v| v + Vec3::new(0.0, 0.05, 0.1) * s as f32))
                    .collect(),
                power: 0.1 + 5.0 * rng.f32(),
                two_sided: k % 3 == 0,
            }
        })
        .collect()
}

#[test]
fn light_tree_picks_as_the_reference() {
    let d = common::device();
    let mut rng = Rng::new(11);
    let lights = random_lights(&mut rng, 200, 1);
    let emitters = random_emitters(&mut rng, 300, 1);
    let tree = light_tree::build(&lights, 200, &emitters);
    let nodes = &tree.nodes;
    assert_eq!(nodes.len(), 2 * 500 - 1, "one leaf per light and emitter");
    let trails = tree.emitter_trails.clone();
    let n = 4000;
    let mut input = Vec::new();
    for i in 0..n {
        let p = Vec3::new(
            rng.f32() * 24.0 - 12.0,
            rng.f32() * 3.0 - 0.5,
            rng.f32() * 6.0 - 3.0,
        );
        let normal = random_dir(&mut rng);
        let trail = f32::from_bits(trails[i % trails.len()]);
        input.extend_from_slice(&[
            p.x,
            p.y,
            p.z,
            normal.x,
            normal.y,
            normal.z,
            rng.f32(),
            trail,
        ]);
    }
    let nb = upload(&d, nodes);
    let inb = upload(&d, &input);
    let out = upload(&d, &vec![0.0f32; 3 * n]);
    run(
        &d,
        "light_tree_probe",
        &[
            Arg::Buf(&nb),
            Arg::Buf(&inb),
            Arg::Buf(&out),
            Arg::U32(n as u32),
        ],
        n,
    );
    let mut got = vec![0.0f32; 3 * n];
    d.read(&out, &mut got).unwrap();
    let (mut same, mut emitters_picked) = (0, 0);
    for i in 0..n {
        let c = &input[8 * i..8 * i + 8];
        let (p, normal) = (Vec3::new(c[0], c[1], c[2]), Vec3::new(c[3], c[4], c[5]));
        let what = format!("case {i} at {p} normal {normal} u {}", c[6]);
        let (leaf, pmf) = (got[3 * i].to_bits() as i32, got[3 * i + 1]);
        // The trail's probability: the kernel's, the reference's, and the
        // sum over the tree for that emitter.
        let k = i % trails.len();
        let want_trail = light_tree::trail_pmf(nodes, p, normal, trails[k]);
        close(got[3 * i + 2], want_trail, 1e-4, &what);
        let emitter = light_tree::LIGHT_NODE_EMITTER | k as u32;
        close(
            want_trail,
            light_tree::pick_pmf(nodes, p, normal, emitter),
            1e-4,
            &what,
        );
        match light_tree::pick(nodes, p, normal, c[6]) {
            Some((l, want_pmf)) if leaf == l as i32 => {
                close(pmf, want_pmf, 1e-4, &what);
                close(pmf, light_tree::pick_pmf(nodes, p, normal, l), 1e-4, &what);
                same += 1;
                emitters_picked += (l & light_tree::LIGHT_NODE_EMITTER != 0) as usize;
            }
            Some(_) => {}
            None => {
                assert_eq!(leaf, -1, "{what}");
                same += 1;
            }
        }
    }
    // Where u falls within rounding of a split, the two may part ways;
    // where no light reaches, both say so.
    assert!(same >= n * 99 / 100, "{same} of {n} picks agree");
    assert!(
        emitters_picked > n / 10,
        "{emitters_picked} emitters picked"
    );
}

/// The light tree built on the device (`light_tree::device`) is the
/// reference's (`light_tree::build`): the same shape, leaves and trails, and
/// bounds within the device's acos and cos; with motion steps, a
/// directional light and a degenerate emitter (leaves that send nothing),
/// and with the emitters left out.
#[test]
fn light_tree_builds_on_the_device_as_the_reference() {
    use soupray::device::GrowBuffer;
    use soupray::trace::light_tree::device::{LightTreeBuilder, LightTreeInputs};
    use soupray::trace::material::DeviceMaterial;
    let d = common::device();
    let mut builder = LightTreeBuilder::new(&d).unwrap();
    let mut rng = Rng::new(21);
    for (lights_n, emitters_n, steps) in [(200, 300, 1), (40, 700, 3), (0, 1, 1), (9, 0, 2)] {
        let mut lights = random_lights(&mut rng, lights_n, steps);
        if lights_n > 5 {
            for s in 0..steps {
                lights[s * lights_n + 5].kind = soupray::trace::lights::LIGHT_DIRECTIONAL;
            }
        }
        let mut emitters = random_emitters(&mut rng, emitters_n, steps);
        // Triangles of the soup: the emitters among as many that are not.
        let triangles = 2 * emitters_n + 1;
        let prims: Vec<u32> = (0..emitters_n as u32).map(|k| 2 * k + 1).collect();
        let mut power = vec![0.0f32; triangles];
        let mut material_ids = vec![1u32; triangles];
        let mut positions = vec![[0.0f32; 4]; 3 * triangles * steps];
        if emitters_n > 3 {
            // Degenerate at the last step only.
            let c = &mut emitters[3].corners[steps - 1];
            c[2] = c[1];
        }
        for (k, t) in emitters.iter_mut().enumerate() {
            let prim = prims[k] as usize;
            power[prim] = t.power;
            t.power *= std::f32::consts::PI;
            material_ids[prim] = if t.two_sided { 0 } else { 1 };
            for (s, c) in t.corners.iter().enumerate() {
                for (j, v) in c.iter().enumerate() {
                    positions[3 * (s * triangles + prim) + j] = [v.x, v.y, v.z, 0.0];
                }
            }
        }
        let mut materials = [<DeviceMaterial as bytemuck::Zeroable>::zeroed(); 2];
        materials[0].flags = soupray::trace::material::MAT_DOUBLE_SIDED;
        // A buffer is never empty: a zeroed record where there is nothing.
        let mut light_records = lights.clone();
        light_records.push(<DeviceLight as bytemuck::Zeroable>::zeroed());
        let light_buf = upload(&d, &light_records);
        let inputs = LightTreeInputs {
            positions: &upload(&d, &positions),
            triangles: triangles as u32,
            steps: steps as u32,
            material_ids: &upload(&d, &material_ids),
            materials: &upload(&d, &materials),
            material_count: 2,
            prims: &upload(&d, &[prims.as_slice(), &[0]].concat()),
            emitters: emitters_n as u32,
            power: &upload(&d, &power),
            lights: &light_buf,
            light_count: lights_n as u32,
            light_steps: steps as u32,
        };
        let boxes = builder.make_leaves(&d, &inputs).unwrap();
        for with_emitters in [true, false] {
            let what = format!("{lights_n} lights, {emitters_n} emitters, {steps} steps, emitters in: {with_emitters}");
            let want = light_tree::build(
                &lights,
                lights_n,
                if with_emitters { &emitters } else { &[] },
            );
            let mut nodes = GrowBuffer::new();
            let trails = upload(&d, &vec![u32::MAX; triangles]);
            let built = builder
                .build(&d, with_emitters, inputs.prims, &mut nodes, &trails)
                .unwrap();
            d.finish().unwrap();
            assert_eq!(built.nodes as usize, want.nodes.len(), "{what}");
            if want.nodes.is_empty() {
                continue;
            }
            assert_eq!(
                built.holds_emitters,
                with_emitters && emitters_n > 0,
                "{what}"
            );
            let mut got = vec![light_tree::DeviceLightNode::default(); want.nodes.len()];
            d.read(nodes.get(), &mut got).unwrap();
            close(built.root_phi, want.nodes[0].phi, 1e-5, &what);
            for (i, (g, w)) in got.iter().zip(&want.nodes).enumerate() {
                let at = format!("{what}, node {i}");
                assert_eq!((g.child, g.two_sided), (w.child, w.two_sided), "{at}");
                assert_eq!((g.lo, g.hi), (w.lo, w.hi), "{at}");
                close(g.phi, w.phi, 1e-5, &at);
                // A cone within about 10 degrees of every direction may
                // round to the whole sphere on one side and not the other
                // (θo ≥ π in the union), and its axis then means little.
                if g.cos_theta_o > -0.985 && w.cos_theta_o > -0.985 {
                    for k in 0..3 {
                        assert!((g.w[k] - w.w[k]).abs() < 2e-3, "{at}: {g:?} vs {w:?}");
                    }
                    let cos_o = (g.cos_theta_o - w.cos_theta_o).abs();
                    assert!(cos_o < 2e-3, "{at}: {g:?} vs {w:?}");
                } else {
                    assert!(
                        g.cos_theta_o.max(w.cos_theta_o) < -0.95,
                        "{at}: {g:?} vs {w:?}"
                    );
                }
                assert!(
                    (g.cos_theta_e - w.cos_theta_e).abs() < 2e-3,
                    "{at}: {g:?} vs {w:?}"
                );
            }
            if with_emitters {
                let mut got_trails = vec![0u32; triangles];
                d.read(&trails, &mut got_trails).unwrap();
                for (k, &prim) in prims.iter().enumerate() {
                    assert_eq!(
                        got_trails[prim as usize], want.emitter_trails[k],
                        "{what}, emitter {k}"
                    );
                }
            }
            // Leaves that send nothing are in the tree, and never chosen.
            let leaves = || {
                want.nodes
                    .iter()
                    .filter(|n| n.child & light_tree::LIGHT_NODE_LEAF != 0)
            };
            let nothing = leaves().filter(|n| n.phi == 0.0).count();
            let expected = (lights_n > 5) as usize + (with_emitters && emitters_n > 3) as usize;
            assert_eq!(nothing, expected, "{what}");
        }
        // The emitters' box, the degenerate one left out.
        let corners = emitters
            .iter()
            .enumerate()
            .filter(|(k, _)| *k != 3)
            .flat_map(|(_, t)| t.corners.iter().flatten());
        let want = corners.fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(lo, hi), &v| {
            (lo.min(v), hi.max(v))
        });
        assert_eq!(
            boxes.emitters, want,
            "{lights_n} lights, {emitters_n} emitters"
        );
    }
}

/// The tree's probabilities over its lights and emitters sum to at most 1
/// (less where a node's cone reaches a point that none of its children's
/// does: the pick then finds no light), to 1 with point lights alone; a
/// light is chosen exactly where it shines, an emitter wherever it can; a
/// light that moves between motion steps stays inside the root's bounds.
#[test]
fn light_tree_probabilities_sum_to_one() {
    let mut rng = Rng::new(12);
    for (steps, spots) in [(1, true), (3, true), (1, false)] {
        let mut lights = random_lights(&mut rng, 50, steps);
        if !spots {
            lights.iter_mut().for_each(|l| l.kind = LIGHT_POINT);
        }
        // Point lights alone make a tree whose cones never cut: there the
        // probabilities sum to 1 exactly.
        let emitters = random_emitters(&mut rng, if spots { 40 } else { 0 }, steps);
        let nodes = light_tree::build(&lights, 50, &emitters).nodes;
        for n in &nodes {
            assert!(n.phi > 0.0 && n.cos_theta_o >= -1.0 && n.cos_theta_o <= 1.0);
        }
        let root = &nodes[0];
        for l in &lights {
            let p = Vec3::from(l.position);
            assert!(
                (0..3).all(|k| root.lo[k] <= p[k] && p[k] <= root.hi[k]),
                "light at {p} outside the root {root:?}"
            );
        }
        for _ in 0..200 {
            let p = Vec3::new(
                rng.f32() * 24.0 - 12.0,
                rng.f32() * 3.0,
                rng.f32() * 6.0 - 3.0,
            );
            let normal = random_dir(&mut rng);
            let emitter_leaves =
                (0..emitters.len() as u32).map(|k| light_tree::LIGHT_NODE_EMITTER | k);
            let leaves = (0..50).chain(emitter_leaves);
            let sum: f32 = leaves
                .map(|l| light_tree::pick_pmf(&nodes, p, normal, l))
                .sum();
            assert!(sum <= 1.0 + 1e-4, "{sum} at {p}");
            let points = lights[..50].iter().all(|l| l.kind != LIGHT_SPOT);
            assert!(!points || (sum - 1.0).abs() < 1e-4, "{sum} at {p}");
            if steps > 1 {
                continue;
            }
            // An emitter is chosen wherever it can shine.
            for (k, t) in emitters.iter().enumerate() {
                let c = t.corners[0];
                let n = (c[1] - c[0]).cross(c[2] - c[0]);
                if t.two_sided || (p - c[0]).dot(n) > 1e-3 * n.length() {
                    let leaf = light_tree::LIGHT_NODE_EMITTER | k as u32;
                    let pmf = light_tree::pick_pmf(&nodes, p, normal, leaf);
                    assert!(pmf > 0.0, "emitter {k} at {p}: {pmf}");
                }
            }
            // A spot light is chosen exactly where it shines.
            for (i, l) in lights.iter().enumerate() {
                if let Some((_, _, e)) = punctual_incident(l, p) {
                    let pmf = light_tree::pick_pmf(&nodes, p, normal, i as u32);
                    assert_eq!(pmf > 0.0, e.max_element() > 0.0, "light {i} at {p}: {pmf}");
                }
            }
        }
    }
}

#[test]
fn environment_map_matches_the_reference() {
    let d = common::device();
    let mut rng = Rng::new(9);
    let (w, h) = (24u32, 12u32);
    let texels: Vec<[f32; 4]> = (0..w * h)
        .map(|i| {
            let hot = if i == 40 || i == 41 { 50.0 } else { 1.0 };
            [rng.f32() * hot, rng.f32() * hot, rng.f32(), 0.0]
        })
        .collect();
    let map = EnvMap::from_texels(w, h, texels).unwrap();
    let env = DeviceEnv {
        color: [1.0, 1.0, 1.0, 0.0],
        kind: ENV_MAP,
        width: w,
        height: h,
        pad: 0,
    };
    let n = 4000;
    let mut input = Vec::new();
    for _ in 0..n {
        let dir = random_dir(&mut rng);
        input.extend_from_slice(&[rng.f32(), rng.f32(), dir.x, dir.y, dir.z]);
    }
    let bufs = (
        upload(&d, &[env]),
        upload(&d, &map.texels),
        upload(&d, &map.marginal),
        upload(&d, &map.conditional),
    );
    let inb = upload(&d, &input);
    let out = upload(&d, &vec![0.0f32; 11 * n]);
    run(
        &d,
        "env_probe",
        &[
            Arg::Buf(&bufs.0),
            Arg::Buf(&bufs.1),
            Arg::Buf(&bufs.2),
            Arg::Buf(&bufs.3),
            Arg::Buf(&inb),
            Arg::Buf(&out),
            Arg::U32(n as u32),
        ],
        n,
    );
    let mut got = vec![0.0f32; 11 * n];
    d.read(&out, &mut got).unwrap();
    let mut mismatched_texel = 0;
    for i in 0..n {
        let c = &input[5 * i..5 * i + 5];
        let o = &got[11 * i..11 * i + 11];
        let what = format!("case {i} {c:?}");
        let (dir, l, pdf) = map.sample(c[0], c[1]).unwrap();
        for k in 0..3 {
            close(o[k], dir[k], 1e-4, &what);
            close(o[3 + k], l[k], 1e-6, &what);
        }
        close(o[6], pdf, 1e-4, &what);
        // The sampled direction's own pdf agrees with the sampling pdf.
        close(map.pdf(dir), pdf, 1e-2, &what);
        let q = Vec3::new(c[2], c[3], c[4]).normalize();
        let r = map.radiance(q);
        // A direction on a texel border may round into either texel.
        if (0..3).any(|k| (o[7 + k] - r[k]).abs() > 1e-6) {
            mismatched_texel += 1;
            continue;
        }
        close(o[10], map.pdf(q), 1e-3, &what);
    }
    assert!(
        mismatched_texel < n / 500,
        "{mismatched_texel} directions read another texel"
    );
    // The pdf integrates to 1 over the sphere (midpoint rule in u, v).
    let mut total = 0.0f64;
    let (nu, nv) = (480, 240);
    for j in 0..nv {
        for i in 0..nu {
            let (u, v) = ((i as f32 + 0.5) / nu as f32, (j as f32 + 0.5) / nv as f32);
            let dir = soupray::trace::lights::env_uv_to_dir(u, v);
            let dw = (2.0 * std::f64::consts::PI / nu as f64)
                * (std::f64::consts::PI / nv as f64)
                * (v as f64 * std::f64::consts::PI).sin();
            total += map.pdf(dir) as f64 * dw;
        }
    }
    assert!((total - 1.0).abs() < 1e-2, "pdf integrates to {total}");
}
