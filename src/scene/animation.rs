//! Animation clips and their sampling, exactly as glTF 2.0 §3.11 and
//! Appendix C define it: STEP, LINEAR (quaternion slerp on the short path,
//! normalised) and CUBICSPLINE (Hermite with tangents scaled by the key
//! interval, `[in, value, out]` per key, rotations normalised). Times
//! outside the keys clamp to the first / last value.

use gltf::accessor::{DataType, Dimensions};

use super::accessor::Reader;
use super::error::{Result, SceneError};

pub use super::pointer::ValueTarget;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Interpolation {
    Step,
    Linear,
    CubicSpline,
}

impl Interpolation {
    pub fn name(self) -> &'static str {
        match self {
            Interpolation::Step => "STEP",
            Interpolation::Linear => "LINEAR",
            Interpolation::CubicSpline => "CUBICSPLINE",
        }
    }
}

/// The node property a channel drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Property {
    Translation,
    Rotation,
    Scale,
    /// Morph target weights of the node's mesh.
    Weights,
}

/// Keyframes of one channel. `values` holds `width` floats per output
/// element; CUBICSPLINE has three elements per key (in-tangent, value,
/// out-tangent), the others one.
#[derive(Debug, Clone)]
pub struct Sampler {
    pub times: Vec<f32>,
    pub values: Vec<f32>,
    pub width: usize,
    pub interpolation: Interpolation,
}

#[derive(Debug, Clone)]
pub struct Channel {
    pub node: usize,
    pub property: Property,
    pub sampler: Sampler,
}

/// A KHR_animation_pointer channel to a material, light or camera
/// property.
#[derive(Debug, Clone)]
pub struct PointerChannel {
    /// The JSON pointer, as the file spells it.
    pub pointer: String,
    pub target: super::pointer::ValueTarget,
    pub sampler: Sampler,
}

/// One `animations[i]` entry.
#[derive(Debug, Clone)]
pub struct Clip {
    pub index: usize,
    pub name: Option<String>,
    /// Node channels, KHR_animation_pointer ones to node TRS and weights
    /// included (a `/meshes/M/weights` pointer is one channel per node
    /// taking the mesh's weights).
    pub channels: Vec<Channel>,
    /// KHR_animation_pointer channels to material, light and camera
    /// properties.
    pub pointer_channels: Vec<PointerChannel>,
    /// Last key time over all channels, in seconds (the clip starts at 0).
    pub duration: f64,
}

impl Sampler {
    fn key_count(&self) -> usize {
        self.times.len()
    }

    /// Element `e` of the output accessor.
    fn element(&self, e: usize) -> &[f32] {
        &self.values[e * self.width..(e + 1) * self.width]
    }

    /// The value (not tangent) of key `k`.
    fn key_value(&self, k: usize) -> &[f32] {
        match self.interpolation {
            Interpolation::CubicSpline => self.element(3 * k + 1),
            _ => self.element(k),
        }
    }

    /// Writes the sampled value at time `t` (seconds) into `out`
    /// (`width` floats). `rotation` selects quaternion rules.
    pub fn sample(&self, t: f64, rotation: bool, out: &mut [f32]) {
        let n = self.key_count();
        let first = self.times[0] as f64;
        let last = self.times[n - 1] as f64;
        if n == 1 || t <= first {
            out.copy_from_slice(self.key_value(0));
            return;
        }
        if t >= last {
            out.copy_from_slice(self.key_value(n - 1));
            return;
        }
        // Largest k with times[k] <= t; k + 1 < n since t < last.
        let k = self.times.partition_point(|&x| (x as f64) <= t) - 1;
        let (t0, t1) = (self.times[k] as f64, self.times[k + 1] as f64);
        let dt = t1 - t0;
        let s = if dt > 0.0 { (t - t0) / dt } else { 0.0 };
        match self.interpolation {
            Interpolation::Step => out.copy_from_slice(self.key_value(k)),
            Interpolation::Linear => {
                let (a, b) = (self.key_value(k), self.key_value(k + 1));
                if rotation {
                    let q = slerp(
                        [a[0] as f64, a[1] as f64, a[2] as f64, a[3] as f64],
                        [b[0] as f64, b[1] as f64, b[2] as f64, b[3] as f64],
                        s,
                    );
                    for i in 0..4 {
                        out[i] = q[i] as f32;
                    }
                } else {
                    for i in 0..self.width {
                        out[i] = (a[i] as f64 * (1.0 - s) + b[i] as f64 * s) as f32;
                    }
                }
            }
            Interpolation::CubicSpline => {
                let v0 = self.element(3 * k + 1);
                let b0 = self.element(3 * k + 2); // out-tangent of key k
                let a1 = self.element(3 * (k + 1)); // in-tangent of key k+1
                let v1 = self.element(3 * (k + 1) + 1);
                let (s2, s3) = (s * s, s * s * s);
                let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
                let h10 = dt * (s3 - 2.0 * s2 + s);
                let h01 = -2.0 * s3 + 3.0 * s2;
                let h11 = dt * (s3 - s2);
                let mut v = [0.0f64; 4];
                let mut tmp = vec![0.0f64; self.width];
                for i in 0..self.width {
                    tmp[i] = h00 * v0[i] as f64
                        + h10 * b0[i] as f64
                        + h01 * v1[i] as f64
                        + h11 * a1[i] as f64;
                }
                if rotation {
                    v.copy_from_slice(&tmp[..4]);
                    let q = normalize(v);
                    for i in 0..4 {
                        out[i] = q[i] as f32;
                    }
                } else {
                    for i in 0..self.width {
                        out[i] = tmp[i] as f32;
                    }
                }
            }
        }
    }
}

fn normalize(q: [f64; 4]) -> [f64; 4] {
    let len = (q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]).sqrt();
    if len > 0.0 {
        [q[0] / len, q[1] / len, q[2] / len, q[3] / len]
    } else {
        [0.0, 0.0, 0.0, 1.0]
    }
}

/// Spherical linear interpolation along the shorter arc (Appendix C):
/// q and -q are the same rotation, so a negative dot product means the
/// direct path is the long way round and one end is negated first.
pub fn slerp(a: [f64; 4], b: [f64; 4], s: f64) -> [f64; 4] {
    let mut dot = a[0] * b[0] + a[1] * b[1] + a[2] * b[2] + a[3] * b[3];
    let sign = if dot < 0.0 { -1.0 } else { 1.0 };
    dot *= sign;
    let (wa, wb) = if dot > 0.9995 {
        // Nearly parallel: sin(theta) ~ 0, and linear blending is exact to
        // within rounding after normalisation.
        (1.0 - s, s)
    } else {
        let theta = dot.clamp(-1.0, 1.0).acos();
        let sin_theta = theta.sin();
        (
            ((1.0 - s) * theta).sin() / sin_theta,
            (s * theta).sin() / sin_theta,
        )
    };
    normalize([
        wa * a[0] + sign * wb * b[0],
        wa * a[1] + sign * wb * b[1],
        wa * a[2] + sign * wb * b[2],
        wa * a[3] + sign * wb * b[3],
    ])
}

/// What a clip's channels may target, for resolving KHR_animation_pointer
/// pointers: the morph target count of every node's mesh, and per mesh its
/// target count and the nodes that take its `weights` (those without their
/// own).
pub(crate) struct ClipTargets<'a> {
    pub targets_of_node: &'a dyn Fn(usize) -> usize,
    pub mesh_targets: Vec<usize>,
    pub mesh_weight_nodes: Vec<Vec<usize>>,
}

/// Reads one animation: its `node`/`path` channels through the `gltf`
/// crate, its KHR_animation_pointer channels from the raw JSON (which the
/// crate never sees).
pub(crate) fn load_clip(
    reader: &Reader,
    anim: &gltf::Animation,
    targets: &ClipTargets,
    warnings: &mut Vec<String>,
) -> Result<Clip> {
    let label = match anim.name() {
        Some(n) => format!("animation {} \"{n}\"", anim.index()),
        None => format!("animation {}", anim.index()),
    };
    let mut channels = Vec::new();
    let mut duration = 0.0f64;
    // The crate's channels are the file's without the pointer ones: their
    // indices in the file, for messages.
    let file_index = super::pointer::node_channel_indices(&reader.src.json, anim.index());
    for (c, channel) in anim.channels().enumerate() {
        let c = file_index.get(c).copied().unwrap_or(c);
        let target = channel.target();
        let node = target.node().index();
        let property = match target.property() {
            gltf::animation::Property::Translation => Property::Translation,
            gltf::animation::Property::Rotation => Property::Rotation,
            gltf::animation::Property::Scale => Property::Scale,
            gltf::animation::Property::MorphTargetWeights => Property::Weights,
        };
        let sampler = channel.sampler();
        let interpolation = match sampler.interpolation() {
            gltf::animation::Interpolation::Step => Interpolation::Step,
            gltf::animation::Interpolation::Linear => Interpolation::Linear,
            gltf::animation::Interpolation::CubicSpline => Interpolation::CubicSpline,
        };
        let width = match property {
            Property::Translation | Property::Scale => 3,
            Property::Rotation => 4,
            Property::Weights => {
                let t = (targets.targets_of_node)(node);
                if t == 0 {
                    warnings.push(format!(
                        "{label} channel {c} animates morph weights of node {node}, which has no morph targets; ignored"
                    ));
                    continue;
                }
                t
            }
        };
        let keys = KeySource {
            label: &label,
            channel: c,
            input: sampler.input(),
            output: sampler.output(),
            interpolation,
        };
        let Some(sampler) = read_keys(reader, &keys, property_kind(property), width, warnings)?
        else {
            continue;
        };
        duration = duration.max(*sampler.times.last().unwrap_or(&0.0) as f64);
        channels.push(Channel {
            node,
            property,
            sampler,
        });
    }

    let mut pointer_channels = Vec::new();
    let mut skipped: std::collections::BTreeMap<String, (String, usize)> = Default::default();
    for raw in super::pointer::raw_pointer_channels(&reader.src.json, anim.index()) {
        let resolved = match super::pointer::resolve(&reader.src.json, &raw.pointer, targets) {
            Ok(r) => r,
            Err(why) => {
                skipped.entry(raw.pointer.clone()).or_insert((why, 0)).1 += 1;
                continue;
            }
        };
        let doc = &reader.src.document;
        let (Some(input), Some(output)) = (
            doc.accessors().nth(raw.input),
            doc.accessors().nth(raw.output),
        ) else {
            continue;
        };
        let keys = KeySource {
            label: &label,
            channel: raw.channel,
            input,
            output,
            interpolation: raw.interpolation,
        };
        let (kind, width) = match &resolved {
            super::pointer::Resolved::Node(_, property, width) => {
                (property_kind(*property), *width)
            }
            super::pointer::Resolved::Value(target) => (ValueKind::Factor, target.width()),
        };
        let Some(sampler) = read_keys(reader, &keys, kind, width, warnings)? else {
            continue;
        };
        duration = duration.max(*sampler.times.last().unwrap_or(&0.0) as f64);
        match resolved {
            super::pointer::Resolved::Node(nodes, property, _) => {
                for node in nodes {
                    channels.push(Channel {
                        node,
                        property,
                        sampler: sampler.clone(),
                    });
                }
            }
            super::pointer::Resolved::Value(target) => pointer_channels.push(PointerChannel {
                pointer: raw.pointer,
                target,
                sampler,
            }),
        }
    }
    if !skipped.is_empty() {
        let list: Vec<String> = skipped
            .iter()
            .take(8)
            .map(|(pointer, (why, n))| {
                let times = if *n > 1 {
                    format!(", {n} channels")
                } else {
                    String::new()
                };
                format!("\"{pointer}\" ({why}{times})")
            })
            .collect();
        let more = skipped.len().saturating_sub(8);
        warnings.push(format!(
            "{label}: skipped KHR_animation_pointer channel(s) animating {}{}, which soupray does not animate",
            list.join(", "),
            if more > 0 { format!(" and {more} more pointer(s)") } else { String::new() }
        ));
    }
    Ok(Clip {
        index: anim.index(),
        name: anim.name().map(str::to_owned),
        channels,
        pointer_channels,
        duration,
    })
}

/// How a channel's output accessor is read and checked.
#[derive(Clone, Copy, PartialEq, Eq)]
enum ValueKind {
    /// Translation or scale: FLOAT vec3.
    Vector,
    /// Unit quaternions: FLOAT or normalized integer vec4.
    Rotation,
    /// Morph weights: FLOAT or normalized integer scalars.
    Weights,
    /// A KHR_animation_pointer factor: FLOAT (or normalized integer)
    /// scalars or vectors of the property's width.
    Factor,
}

fn property_kind(property: Property) -> ValueKind {
    match property {
        Property::Translation | Property::Scale => ValueKind::Vector,
        Property::Rotation => ValueKind::Rotation,
        Property::Weights => ValueKind::Weights,
    }
}

/// A channel's sampler, as `read_keys` needs it.
struct KeySource<'a, 'd> {
    label: &'a str,
    channel: usize,
    input: gltf::Accessor<'d>,
    output: gltf::Accessor<'d>,
    interpolation: Interpolation,
}

/// Reads and checks a channel's keyframes: `Ok(None)` (with a warning) for
/// a channel without keys.
fn read_keys(
    reader: &Reader,
    keys: &KeySource,
    kind: ValueKind,
    width: usize,
    warnings: &mut Vec<String>,
) -> Result<Option<Sampler>> {
    let file = &reader.src.file;
    let (label, c, interpolation) = (keys.label, keys.channel, keys.interpolation);
    let (input, output) = (&keys.input, &keys.output);
    let in_usage = format!("keyframe times of {label} channel {c}");
    let out_usage = format!("keyframe values of {label} channel {c}");
    reader.expect(input, &in_usage, &[Dimensions::Scalar], &[DataType::F32])?;
    let times = reader.finite_floats(input, &in_usage)?;
    if times.is_empty() {
        warnings.push(format!(
            "{label} channel {c} has no keyframes and is ignored"
        ));
        return Ok(None);
    }
    if let Some(k) = times.windows(2).position(|w| w[1] <= w[0]) {
        return Err(reader.error(
            input,
            &in_usage,
            format!(
                "key times do not increase at key {} ({} after {}); glTF requires strictly increasing times. \
                 Fix: re-export the animation.",
                k + 1,
                times[k + 1],
                times[k]
            ),
        ));
    }
    const NORMALIZED: &[DataType] = &[
        DataType::F32,
        DataType::I8,
        DataType::U8,
        DataType::I16,
        DataType::U16,
    ];
    let factor_dims = match width {
        1 => Dimensions::Scalar,
        2 => Dimensions::Vec2,
        3 => Dimensions::Vec3,
        _ => Dimensions::Vec4,
    };
    let (dims, types): (&[Dimensions], &[DataType]) = match kind {
        ValueKind::Vector => (&[Dimensions::Vec3], &[DataType::F32]),
        ValueKind::Rotation => (&[Dimensions::Vec4], NORMALIZED),
        ValueKind::Weights => (&[Dimensions::Scalar], NORMALIZED),
        ValueKind::Factor => (std::slice::from_ref(&factor_dims), NORMALIZED),
    };
    reader.expect(output, &out_usage, dims, types)?;
    let values = reader.finite_floats(output, &out_usage)?;
    let per_key = if interpolation == Interpolation::CubicSpline {
        3
    } else {
        1
    };
    let expected = times.len() * per_key * width;
    if values.len() != expected {
        return Err(reader.error(
            output,
            &out_usage,
            format!(
                "holds {} floats but {} keys of {} interpolation need {expected} ({per_key} x {width} per key). \
                 Fix: re-export the animation.",
                values.len(),
                times.len(),
                interpolation.name()
            ),
        ));
    }
    let mut values = values;
    if kind == ValueKind::Rotation && interpolation != Interpolation::CubicSpline {
        // Keys must be unit quaternions, but exporters round them (e.g.
        // to 3 decimals); slerp's angle is only right for unit inputs.
        for (k, q) in values.chunks_exact_mut(4).enumerate() {
            let len = q
                .iter()
                .map(|&x| (x as f64) * (x as f64))
                .sum::<f64>()
                .sqrt();
            if len < 1e-6 {
                return Err(SceneError::invalid(
                    file,
                    format!("{label} channel {c} key {k} is a zero quaternion, which is no rotation. Fix: re-export the animation."),
                ));
            }
            for x in q {
                *x = (*x as f64 / len) as f32;
            }
        }
    }
    Ok(Some(Sampler {
        times,
        values,
        width,
        interpolation,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sampler(
        times: &[f32],
        values: &[f32],
        width: usize,
        interpolation: Interpolation,
    ) -> Sampler {
        Sampler {
            times: times.to_vec(),
            values: values.to_vec(),
            width,
            interpolation,
        }
    }

    #[test]
    fn linear_clamps_outside_keys() {
        let s = sampler(&[1.0, 2.0], &[10.0, 20.0], 1, Interpolation::Linear);
        let mut out = [0.0];
        s.sample(0.0, false, &mut out);
        assert_eq!(out, [10.0]);
        s.sample(5.0, false, &mut out);
        assert_eq!(out, [20.0]);
        s.sample(1.25, false, &mut out);
        assert!((out[0] - 12.5).abs() < 1e-6);
    }

    #[test]
    fn cubic_spline_uses_scaled_tangents() {
        // p(s) with v0=0, v1=0, out-tangent b0=1, in-tangent a1=0 and dt=2:
        // h10 = dt (s^3 - 2 s^2 + s) -> at s=0.5: 2 * 0.125 = 0.25
        let s = sampler(
            &[0.0, 2.0],
            &[9.0, 0.0, 1.0, 0.0, 0.0, 9.0],
            1,
            Interpolation::CubicSpline,
        );
        let mut out = [0.0];
        s.sample(1.0, false, &mut out);
        assert!((out[0] - 0.25).abs() < 1e-6, "{out:?}");
    }

    #[test]
    fn slerp_takes_short_path() {
        let a = [0.0, 0.0, 0.0, 1.0];
        let b = [0.0, 0.0, -0.0087265, -0.9999619]; // -q of a 1 degree turn
        let m = slerp(a, b, 0.5);
        // Halfway along the short path is a 0.5 degree turn about -z... or +z
        let half = (0.5f64.to_radians() / 2.0).sin();
        assert!(
            (m[2].abs() - half).abs() < 1e-6 && m[3].abs() > 0.9999,
            "{m:?}"
        );
    }
}
