//! The path tracer's lights on the host: the punctual-light list
//! (`DeviceLight`, mirrored by `PtLight` in `kernels/trace/lights.h`) made from
//! each frame's `FrameLight`s, the environment (`DeviceEnv`: none, a
//! constant, or an equirectangular map with its importance-sampling CDFs),
//! the distribution over emissive triangles in proportion to their power,
//! and the plain Rust reference of every light-sampling function the
//! kernels use (`punctual_incident`, `EnvMap::radiance`, `pdf`, `sample`).
//!
//! Units follow KHR_lights_punctual: candela for point and spot lights,
//! lux for directional ones, so radiance comes out in nits.

// `!(x > 0.0)` is meant: it is also true for NaN, as in the kernels.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use std::path::Path;

use bytemuck::{Pod, Zeroable};
use glam::Vec3;

use super::sampling::{build_cdf, cdf_search, luminance, sample_uniform_sphere, PI, TWO_PI};
use crate::device_struct::{device_consts, device_struct};
use crate::scene::{FrameLight, LightKind};

device_consts! {
    fn light_consts;
    /// `PtLight.kind`: a KHR_lights_punctual point light.
    pub const LIGHT_POINT: u32 = 0;
    pub const LIGHT_SPOT: u32 = 1;
    pub const LIGHT_DIRECTIONAL: u32 = 2;
    /// `PtEnv.kind`: no environment (black).
    pub const ENV_NONE: u32 = 0;
    /// A constant radiance, `PtEnv.color`.
    pub const ENV_CONSTANT: u32 = 1;
    /// An equirectangular map times `PtEnv.color`.
    pub const ENV_MAP: u32 = 2;
}

device_struct! {
/// One punctual light.
/// `intensity` is color * intensity; range <= 0 means unlimited; the spot
/// falloff is saturate(cos * angle_scale + angle_offset)^2, the extension's
/// formula with its precomputed scale and offset.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct DeviceLight as "PtLight" {
    pub position: [f32; 3],
    pub kind: u32,
    pub direction: [f32; 3],
    /// Distance where the light ends; 0 for unlimited.
    pub range: f32,
    /// Colour times intensity.
    pub intensity: [f32; 3],
    pub angle_scale: f32,
    pub angle_offset: f32,
    pub pad: [f32; 3],
}
}

const _: () = assert!(std::mem::size_of::<DeviceLight>() == 64);

impl DeviceLight {
    /// The device form of a frame's light, with the spot cone's scale and
    /// offset precomputed as the extension does:
    /// `scale = 1 / max(0.001, cos(inner) - cos(outer))`,
    /// `offset = -cos(outer) * scale`.
    pub fn from_frame_light(l: &FrameLight) -> DeviceLight {
        let (kind, scale, offset) = match l.kind {
            LightKind::Point => (LIGHT_POINT, 0.0, 0.0),
            LightKind::Directional => (LIGHT_DIRECTIONAL, 0.0, 0.0),
            LightKind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => {
                let co = outer_cone_angle.cos();
                let ci = inner_cone_angle.cos();
                let scale = 1.0 / (ci - co).max(0.001);
                (LIGHT_SPOT, scale, -co * scale)
            }
        };
        let i = l.intensity;
        DeviceLight {
            position: l.position.into(),
            kind,
            direction: l.direction.normalize_or(Vec3::NEG_Z).into(),
            range: l.range.filter(|r| *r > 0.0 && r.is_finite()).unwrap_or(0.0),
            intensity: [l.color[0] * i, l.color[1] * i, l.color[2] * i],
            angle_scale: scale,
            angle_offset: offset,
            pad: [0.0; 3],
        }
    }
}

/// What a punctual light sends to point `p`: (unit direction to the light,
/// distance (infinite for directional), irradiance on a surface facing it).
pub fn punctual_incident(l: &DeviceLight, p: Vec3) -> Option<(Vec3, f32, Vec3)> {
    let intensity = Vec3::from(l.intensity);
    let dir = Vec3::from(l.direction);
    if l.kind == LIGHT_DIRECTIONAL {
        return Some((-dir, f32::INFINITY, intensity));
    }
    let to = Vec3::from(l.position) - p;
    let d2 = to.dot(to);
    if !(d2 > 0.0) {
        return None;
    }
    let d = d2.sqrt();
    let w = to / d;
    let mut atten = 1.0 / d2;
    if l.range > 0.0 {
        let r = d / l.range;
        let r2 = r * r;
        atten *= (1.0 - r2 * r2).clamp(0.0, 1.0);
    }
    if l.kind == LIGHT_SPOT {
        let cd = -dir.dot(w);
        let s = (cd * l.angle_scale + l.angle_offset).clamp(0.0, 1.0);
        atten *= s * s;
    }
    if !(atten > 0.0) {
        return None;
    }
    Some((w, d, intensity * atten))
}

device_struct! {
/// The environment: its kind, the constant radiance (or the map's
/// multiplier), and the map's size.
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct DeviceEnv as "PtEnv" {
    pub color: [f32; 4],
    pub kind: u32,
    pub width: u32,
    pub height: u32,
    pub pad: u32,
}
}

const _: () = assert!(std::mem::size_of::<DeviceEnv>() == 32);

/// An equirectangular environment map (+Y up, row 0 at the zenith, the
/// centre column looking down -Z) with its sampling distribution: rows by
/// their luminance times sin(theta), then columns within the row.
#[derive(Clone, Debug, PartialEq)]
pub struct EnvMap {
    pub width: u32,
    pub height: u32,
    /// Linear RGB radiance, rows top to bottom (w unused).
    pub texels: Vec<[f32; 4]>,
    /// height + 1 entries.
    pub marginal: Vec<f32>,
    /// height rows of width + 1 entries.
    pub conditional: Vec<f32>,
}

/// The studio sky's radiance for a direction whose up component (+Y) is
/// `up`: 0.25 below the horizon, 0.7 at it rising linearly to 1.0 at the
/// zenith, blended over 6 degrees about the horizon.
pub fn studio_sky_radiance(up: f32) -> f32 {
    let sky = 0.7 + 0.3 * up.max(0.0);
    let ground = 0.25;
    let t = ((up + 0.05) / 0.1).clamp(0.0, 1.0);
    let t = t * t * (3.0 - 2.0 * t);
    ground + (sky - ground) * t
}

/// The most texels an environment map may have (16 bytes each on the
/// host): 8192x4096 is 32M.
pub const MAX_ENV_TEXELS: u64 = 1 << 26;

/// Why an environment map could not be used.
#[derive(Debug, thiserror::Error)]
pub enum EnvError {
    #[error("--env {path}: {detail}")]
    Read { path: String, detail: String },
}

impl EnvMap {
    /// Reads an equirectangular OpenEXR file (its first RGBA layer).
    pub fn load(path: &Path) -> Result<EnvMap, EnvError> {
        use exr::prelude::*;
        let err = |detail: String| EnvError::Read {
            path: path.display().to_string(),
            detail,
        };
        // Only a regular file (a FIFO would block, a device never end),
        // and no header may make soupray allocate more than MAX_ENV_TEXELS.
        crate::input::open_regular(path).map_err(|e| {
            err(format!(
                "cannot be read ({e}). Fix: give an equirectangular .exr file, or use --env-color R,G,B."
            ))
        })?;
        let meta = exr::meta::MetaData::read_from_file(path, false).map_err(|e| {
            err(format!(
                "cannot be read as an OpenEXR image ({e}). Fix: give an equirectangular .exr file \
                 (2:1, RGB), or use --env-color R,G,B."
            ))
        })?;
        for header in &meta.headers {
            let size = header.layer_size;
            if size.width() as u64 * size.height() as u64 > MAX_ENV_TEXELS {
                return Err(err(format!(
                    "declares a {}x{} image, more than the {MAX_ENV_TEXELS} texels soupray reads. \
                     Fix: downscale the map.",
                    size.width(),
                    size.height()
                )));
            }
        }
        let image = read_first_rgba_layer_from_file(
            path,
            |resolution, _| {
                (
                    resolution.width(),
                    vec![[0.0f32; 4]; resolution.width() * resolution.height()],
                )
            },
            |(w, texels): &mut (usize, Vec<[f32; 4]>), pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                texels[pos.y() * *w + pos.x()] = [r, g, b, 0.0];
            },
        )
        .map_err(|e| {
            err(format!(
                "cannot be read as an OpenEXR image ({e}). Fix: give an equirectangular .exr file \
                 (2:1, RGB), or use --env-color R,G,B."
            ))
        })?;
        let size = image.layer_data.size;
        let (_, texels) = image.layer_data.channel_data.pixels;
        EnvMap::from_texels(size.width() as u32, size.height() as u32, texels)
            .ok_or_else(|| err("is empty. Fix: give a non-empty image.".into()))
    }

    /// soupray's default sky for scenes that bring no light of their own
    /// (`Environment::Default`): a grey studio sky, brighter at the zenith
    /// (1.0) than at the horizon (0.7), over a darker ground (0.25), with a
    /// soft horizon. Unlike a constant sky it shades a white surface by
    /// its orientation, so a white object never vanishes against it, and it
    /// is neutral grey, so colours stay as the file gives them.
    pub fn studio_sky() -> EnvMap {
        const W: u32 = 64;
        const H: u32 = 64;
        let mut texels = Vec::with_capacity((W * H) as usize);
        for y in 0..H {
            let theta = PI * (y as f32 + 0.5) / H as f32;
            let up = theta.cos();
            let l = studio_sky_radiance(up);
            texels.extend(std::iter::repeat_n([l, l, l, 0.0], W as usize));
        }
        EnvMap::from_texels(W, H, texels).expect("the sky map is not empty")
    }

    /// A map from texels (row-major, top row first). Non-finite or negative
    /// values are read as 0. `None` for an empty image.
    pub fn from_texels(width: u32, height: u32, mut texels: Vec<[f32; 4]>) -> Option<EnvMap> {
        if width == 0 || height == 0 || texels.len() != width as usize * height as usize {
            return None;
        }
        for t in &mut texels {
            for c in &mut t[..3] {
                if !(c.is_finite() && *c > 0.0) {
                    *c = 0.0;
                }
            }
            t[3] = 0.0;
        }
        let (w, h) = (width as usize, height as usize);
        let mut conditional = Vec::with_capacity(h * (w + 1));
        let mut row_weights = Vec::with_capacity(h);
        for y in 0..h {
            let sin_theta = (PI as f64 * (y as f64 + 0.5) / h as f64).sin();
            let row: Vec<f64> = texels[y * w..(y + 1) * w]
                .iter()
                .map(|t| luminance(Vec3::new(t[0], t[1], t[2])) as f64)
                .collect();
            let sum: f64 = row.iter().sum();
            // A black row is sampled uniformly; it gets no row weight anyway.
            let cdf = build_cdf(&row)
                .unwrap_or_else(|| build_cdf(&vec![1.0; w]).expect("uniform weights are positive"));
            conditional.extend_from_slice(&cdf);
            row_weights.push(sum * sin_theta);
        }
        // An all-black map is sampled uniformly over its rows by sin(theta).
        let marginal = build_cdf(&row_weights).unwrap_or_else(|| {
            let w: Vec<f64> = (0..h)
                .map(|y| (PI as f64 * (y as f64 + 0.5) / h as f64).sin())
                .collect();
            build_cdf(&w).expect("sin(theta) is positive inside the rows")
        });
        Some(EnvMap {
            width,
            height,
            texels,
            marginal,
            conditional,
        })
    }

    fn texel(&self, uv: (f32, f32)) -> usize {
        let x = ((uv.0 * self.width as f32).floor() as i32).clamp(0, self.width as i32 - 1);
        let y = ((uv.1 * self.height as f32).floor() as i32).clamp(0, self.height as i32 - 1);
        y as usize * self.width as usize + x as usize
    }

    /// The map's mean radiance luminance over the sphere (texels weighted
    /// by the solid angle they cover).
    pub fn mean_luminance(&self) -> f32 {
        let (w, h) = (self.width as usize, self.height as usize);
        let (mut sum, mut weight) = (0.0f64, 0.0f64);
        for y in 0..h {
            let sin_theta = (PI as f64 * (y as f64 + 0.5) / h as f64).sin();
            for t in &self.texels[y * w..(y + 1) * w] {
                sum += luminance(Vec3::new(t[0], t[1], t[2])) as f64 * sin_theta;
                weight += sin_theta;
            }
        }
        if weight > 0.0 {
            (sum / weight) as f32
        } else {
            0.0
        }
    }

    /// Radiance from unit direction `d` (times `scale`).
    pub fn radiance(&self, d: Vec3) -> Vec3 {
        let t = self.texels[self.texel(env_dir_to_uv(d))];
        Vec3::new(t[0], t[1], t[2])
    }

    /// Solid-angle pdf of `sample` producing `d`.
    pub fn pdf(&self, d: Vec3) -> f32 {
        let st = (1.0 - d.y * d.y).max(0.0).sqrt();
        if !(st > 0.0) {
            return 0.0;
        }
        let i = self.texel(env_dir_to_uv(d));
        let w = self.width as usize;
        let (x, y) = (i % w, i / w);
        let row = &self.conditional[y * (w + 1)..(y + 1) * (w + 1)];
        let p = ((self.marginal[y + 1] - self.marginal[y]) * self.height as f32)
            * ((row[x + 1] - row[x]) * self.width as f32);
        p / ((2.0 * PI * PI) * st)
    }

    /// Samples a direction: (direction, radiance, pdf).
    pub fn sample(&self, u1: f32, u2: f32) -> Option<(Vec3, Vec3, f32)> {
        let w = self.width as usize;
        let y = cdf_search(&self.marginal, u1);
        let (m0, m1) = (self.marginal[y], self.marginal[y + 1]);
        let dv = (u1 - m0) / (m1 - m0);
        let row = &self.conditional[y * (w + 1)..(y + 1) * (w + 1)];
        let x = cdf_search(row, u2);
        let (c0, c1) = (row[x], row[x + 1]);
        let du = (u2 - c0) / (c1 - c0);
        let u = (x as f32 + du) / self.width as f32;
        let v = (y as f32 + dv) / self.height as f32;
        let d = env_uv_to_dir(u, v);
        let st = (v * PI).sin();
        if !(st > 0.0) {
            return None;
        }
        let pdf = (((m1 - m0) * self.height as f32) * ((c1 - c0) * self.width as f32))
            / ((2.0 * PI * PI) * st);
        let t = self.texels[y * w + x];
        Some((d, Vec3::new(t[0], t[1], t[2]), pdf))
    }
}

pub fn env_dir_to_uv(d: Vec3) -> (f32, f32) {
    let u = 0.5 + d.x.atan2(-d.z) * (1.0 / TWO_PI);
    let v = d.y.clamp(-1.0, 1.0).acos() * (1.0 / PI);
    (u, v)
}

pub fn env_uv_to_dir(u: f32, v: f32) -> Vec3 {
    let theta = v * PI;
    let phi = (u - 0.5) * TWO_PI;
    let st = theta.sin();
    Vec3::new(st * phi.sin(), theta.cos(), -(st * phi.cos()))
}

/// The constant environment's sampling (uniform over the sphere).
pub fn constant_env_sample(u1: f32, u2: f32) -> (Vec3, f32) {
    (sample_uniform_sphere(u1, u2), 1.0 / (4.0 * PI))
}

/// The emissive triangles' sampling distribution for one frame: the
/// triangles with power, a CDF over them, and per triangle of the soup its
/// probability (0 for the others), which MIS needs when a path hits one.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct EmissiveDistribution {
    pub prims: Vec<u32>,
    pub cdf: Vec<f32>,
    pub pmf_by_prim: Vec<f32>,
    /// The triangles' total power (π times the sum of luminance times area,
    /// both sides counted for double-sided materials).
    pub power: f64,
}

impl EmissiveDistribution {
    /// From each triangle's power (`pt_emissive_power`); empty when nothing
    /// emits.
    pub fn from_power(power: &[f32]) -> EmissiveDistribution {
        let prims: Vec<u32> = power
            .iter()
            .enumerate()
            .filter(|(_, p)| **p > 0.0 && p.is_finite())
            .map(|(i, _)| i as u32)
            .collect();
        let weights: Vec<f64> = prims.iter().map(|&i| power[i as usize] as f64).collect();
        let Some(cdf) = build_cdf(&weights) else {
            return EmissiveDistribution::default();
        };
        let total: f64 = weights.iter().sum();
        let mut pmf_by_prim = vec![0.0f32; power.len()];
        for (&i, w) in prims.iter().zip(&weights) {
            pmf_by_prim[i as usize] = (w / total) as f32;
        }
        EmissiveDistribution {
            prims,
            cdf,
            pmf_by_prim,
            power: std::f64::consts::PI * total,
        }
    }

    pub fn is_empty(&self) -> bool {
        self.prims.is_empty()
    }
}

/// Punctual lights sampled at every path vertex rather than chosen: up to
/// this many. A delta light can only be reached by next-event estimation,
/// and a sun sampled with probability p < 1 turns direct sunlight into
/// on/off noise; one shadow ray per light is cheaper than the samples that
/// noise would take to average away. Past this count the lights join the
/// selection distribution (one shadow ray per vertex, as for many lights).
pub const LOOPED_PUNCTUAL_MAX: usize = 8;

/// The light-power estimates that weight the selection, in watts up to one
/// common factor (luminance instead of radiometric power): pbrt-v4's `Phi`
/// of each light. Lights without finite power use the scene's bounding
/// sphere of radius `r`: a directional light of irradiance E delivers
/// π r² E through the sphere's cross-section, and an environment of mean
/// radiance L delivers 4π · π r² · L onto the sphere from all directions.
pub fn punctual_power(l: &FrameLight, scene_radius: f32) -> f64 {
    let c = l.color;
    let lum = luminance(Vec3::new(c[0], c[1], c[2])) as f64 * l.intensity as f64;
    let pi = std::f64::consts::PI;
    let p = match l.kind {
        LightKind::Point => 4.0 * pi * lum,
        LightKind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => {
            // pbrt-v4's SpotLight::Phi: full intensity inside the inner
            // cone, half on average across the falloff.
            let (ci, co) = (
                (inner_cone_angle as f64).cos(),
                (outer_cone_angle as f64).cos(),
            );
            2.0 * pi * lum * ((1.0 - ci) + (ci - co).max(0.0) / 2.0)
        }
        LightKind::Directional => pi * (scene_radius as f64).powi(2) * lum,
    };
    if p.is_finite() && p > 0.0 {
        p
    } else {
        0.0
    }
}

/// The power estimate of an environment of mean radiance luminance `mean`.
pub fn environment_power(mean: f32, scene_radius: f32) -> f64 {
    let pi = std::f64::consts::PI;
    let p = 4.0 * pi * pi * (scene_radius as f64).powi(2) * mean as f64;
    if p.is_finite() && p > 0.0 {
        p
    } else {
        0.0
    }
}

/// How next-event estimation picks its light at a path vertex: every
/// punctual light when there are few (`loop_punctual`), then one entry of
/// the selection distribution, chosen in proportion to its estimated power:
/// the punctual lights unless looped (those in the light tree with weight
/// 0), the light tree as one entry, the emissive triangles as one entry,
/// the environment map. When every power estimate is zero the entries are
/// chosen uniformly. `PtFrame` in `kernels/pt_types.h` carries it.
///
/// A constant environment is no entry: it is reached by the BSDF sample
/// alone, which for a constant radiance is the best single strategy (it
/// follows f cos exactly and spends nothing under the horizon). Measured on
/// the clay scan under a white sky (384x256, 64 spp), next-event
/// estimation of it, cosine-weighted about the shading normal and
/// MIS-weighted, lowered the error by 18% but took 53% longer (a shadow ray
/// per vertex): 25% worse in error times time (BENCHMARKS.md).
#[derive(Clone, Debug, PartialEq)]
pub struct LightSelection {
    pub loop_punctual: bool,
    /// `count + 1` entries from 0 to 1.
    pub cdf: Vec<f32>,
    /// Whether the light tree is an entry, and the probability of choosing
    /// it.
    pub tree: bool,
    pub tree_pmf: f32,
    /// Probability of choosing the emissive triangles (0 when not an entry).
    pub emit_pmf: f32,
    /// Probability of choosing the environment (0 when not an entry).
    pub env_pmf: f32,
}

impl LightSelection {
    /// `punctual`: each punctual light's power; `tree`: the power of the
    /// lights and emitters in the light tree, where there is one, and which
    /// punctual lights it holds (their own entries get weight 0; it holds
    /// none while they are looped); `emissive`, `environment`: the power of
    /// those entries, `None` when they are not sampled by next-event
    /// estimation (the emitters are not an entry of their own when the tree
    /// holds them).
    pub fn new(
        punctual: &[f64],
        tree: Option<(f64, &[bool])>,
        emissive: Option<f64>,
        environment: Option<f64>,
    ) -> Self {
        let loop_punctual = punctual.len() <= LOOPED_PUNCTUAL_MAX;
        let mut weights: Vec<f64> = if loop_punctual {
            Vec::new()
        } else {
            punctual
                .iter()
                .enumerate()
                .map(|(i, &p)| match tree {
                    Some((_, in_tree)) if in_tree.get(i) == Some(&true) => 0.0,
                    _ => p,
                })
                .collect()
        };
        if let Some((power, _)) = tree {
            weights.push(power);
        }
        let emit_index = emissive.map(|p| {
            weights.push(p);
            weights.len() - 1
        });
        let env_index = environment.map(|p| {
            weights.push(p);
            weights.len() - 1
        });
        let cdf = if weights.is_empty() {
            vec![0.0]
        } else {
            build_cdf(&weights)
                .or_else(|| build_cdf(&vec![1.0; weights.len()]))
                .expect("uniform weights are positive")
        };
        // The pmf exactly as the kernel computes it from the table.
        let pmf = |i: Option<usize>| i.map_or(0.0, |i| cdf[i + 1] - cdf[i]);
        let tree_index = tree.map(|_| if loop_punctual { 0 } else { punctual.len() });
        LightSelection {
            loop_punctual,
            tree: tree.is_some(),
            tree_pmf: pmf(tree_index),
            emit_pmf: pmf(emit_index),
            env_pmf: pmf(env_index),
            cdf,
        }
    }

    /// Number of entries of the distribution.
    pub fn count(&self) -> u32 {
        (self.cdf.len() - 1) as u32
    }
}
