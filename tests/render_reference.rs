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
use soupray::trace::lights::{punctual_incident, DeviceEnv, DeviceLight, EnvMap, ENV_MAP};
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
