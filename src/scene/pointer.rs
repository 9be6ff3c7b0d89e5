//! KHR_animation_pointer: animation channels whose target is a JSON
//! pointer into the document rather than a node and path.
//!
//! Pointers to node TRS and morph weights (`/nodes/N/translation`,
//! `rotation`, `scale`, `weights`, and `/meshes/M/weights`, which drives
//! every node taking the mesh's weights) become ordinary node channels, so
//! the pose, the device soup and motion blur treat them exactly like
//! `target.path` channels. Pointers to material factors (and
//! KHR_texture_transform on a material's texture), to KHR_lights_punctual
//! light properties and to camera projections are kept as value channels
//! and applied when a frame's materials, lights and camera are made. Any
//! other pointer is skipped, named in one warning per animation.
//!
//! The `gltf` crate does not know the extension: `validate` keeps pointer
//! channels in the raw JSON (after checking their sampler and pointer),
//! and `source` removes them from the copy the crate reads.

use std::borrow::Cow;

use super::animation::{ClipTargets, Interpolation, Property};
use super::camera::Projection;
use super::light::{LightDef, LightKind};
use super::material::{Material, Slot, TextureTransform, FACTORS};
use super::Scene;

pub(crate) const EXTENSION: &str = "KHR_animation_pointer";

/// A pointer channel as the raw JSON has it (checked by `validate`).
pub(crate) struct RawPointerChannel {
    /// Index in the animation's `channels`.
    pub channel: usize,
    pub pointer: String,
    /// Accessor indices of the sampler's input and output.
    pub input: usize,
    pub output: usize,
    pub interpolation: Interpolation,
}

/// The pointer of a channel (`target.extensions.KHR_animation_pointer.pointer`).
pub(crate) fn channel_pointer(channel: &serde_json::Value) -> Option<&str> {
    let target = channel.get("target")?;
    if target.get("path")?.as_str()? != "pointer" {
        return None;
    }
    target
        .get("extensions")?
        .get(EXTENSION)?
        .get("pointer")?
        .as_str()
}

/// The indices in `animations[anim].channels` of the channels that are not
/// pointer channels (those the `gltf` crate reads), in order.
pub(crate) fn node_channel_indices(json: &serde_json::Value, anim: usize) -> Vec<usize> {
    json.get("animations")
        .and_then(|a| a.get(anim))
        .and_then(|a| a.get("channels"))
        .and_then(|c| c.as_array())
        .map(|channels| {
            channels
                .iter()
                .enumerate()
                .filter(|(_, ch)| channel_pointer(ch).is_none())
                .map(|(i, _)| i)
                .collect()
        })
        .unwrap_or_default()
}

/// The pointer channels of `animations[anim]`, in the file's order.
pub(crate) fn raw_pointer_channels(
    json: &serde_json::Value,
    anim: usize,
) -> Vec<RawPointerChannel> {
    let Some(animation) = json.get("animations").and_then(|a| a.get(anim)) else {
        return Vec::new();
    };
    let samplers = animation.get("samplers").and_then(|s| s.as_array());
    let channels = animation.get("channels").and_then(|c| c.as_array());
    let mut out = Vec::new();
    for (c, ch) in channels.into_iter().flatten().enumerate() {
        let Some(pointer) = channel_pointer(ch) else {
            continue;
        };
        let sampler = ch
            .get("sampler")
            .and_then(|s| s.as_u64())
            .and_then(|s| samplers?.get(s as usize));
        let Some(sampler) = sampler else { continue };
        let accessor = |key: &str| {
            sampler
                .get(key)
                .and_then(|a| a.as_u64())
                .map(|a| a as usize)
        };
        let (Some(input), Some(output)) = (accessor("input"), accessor("output")) else {
            continue;
        };
        let interpolation = match sampler.get("interpolation").and_then(|i| i.as_str()) {
            Some("STEP") => Interpolation::Step,
            Some("CUBICSPLINE") => Interpolation::CubicSpline,
            _ => Interpolation::Linear,
        };
        out.push(RawPointerChannel {
            channel: c,
            pointer: pointer.to_owned(),
            input,
            output,
            interpolation,
        });
    }
    out
}

/// What a pointer animates.
pub(crate) enum Resolved {
    /// Node channels: the nodes, the property and the output width.
    Node(Vec<usize>, Property, usize),
    Value(ValueTarget),
}

/// A material, light or camera property a pointer channel drives.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ValueTarget {
    /// `FACTORS[factor]` of a material.
    MaterialFactor { material: usize, factor: usize },
    /// KHR_texture_transform `offset`, `rotation` or `scale` of one of the
    /// material's textures.
    TextureTransform {
        material: usize,
        slot: Slot,
        part: TransformPart,
    },
    Light {
        light: usize,
        property: LightProperty,
    },
    Camera {
        camera: usize,
        property: CameraProperty,
    },
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TransformPart {
    Offset,
    Rotation,
    Scale,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LightProperty {
    Color,
    Intensity,
    Range,
    InnerConeAngle,
    OuterConeAngle,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum CameraProperty {
    Yfov,
    AspectRatio,
    Znear,
    Zfar,
    Xmag,
    Ymag,
}

fn v3(v: &[f32]) -> [f32; 3] {
    [v[0], v[1], v[2]]
}

impl ValueTarget {
    /// Floats per key.
    pub fn width(&self) -> usize {
        match *self {
            ValueTarget::MaterialFactor { factor, .. } => FACTORS[factor].width(),
            ValueTarget::TextureTransform { part, .. } => match part {
                TransformPart::Rotation => 1,
                TransformPart::Offset | TransformPart::Scale => 2,
            },
            ValueTarget::Light { property, .. } => match property {
                LightProperty::Color => 3,
                _ => 1,
            },
            ValueTarget::Camera { .. } => 1,
        }
    }

    pub fn is_material(&self) -> bool {
        matches!(
            self,
            ValueTarget::MaterialFactor { .. } | ValueTarget::TextureTransform { .. }
        )
    }

    /// Sets a material property to `v` (`width` floats).
    fn apply_material(&self, materials: &mut [Material], v: &[f32]) {
        match *self {
            ValueTarget::MaterialFactor { material, factor } => {
                if let Some(m) = materials.get_mut(material) {
                    FACTORS[factor]
                        .components(m)
                        .copy_from_slice(&v[..FACTORS[factor].width()]);
                }
            }
            ValueTarget::TextureTransform {
                material,
                slot,
                part,
            } => {
                let Some(m) = materials.get_mut(material) else {
                    return;
                };
                let Some(reference) = slot.of_mut(m).as_mut() else {
                    return;
                };
                // A texture without KHR_texture_transform has the identity.
                let t = reference.transform.get_or_insert(TextureTransform {
                    offset: [0.0, 0.0],
                    rotation: 0.0,
                    scale: [1.0, 1.0],
                    tex_coord: None,
                });
                match part {
                    TransformPart::Offset => t.offset = [v[0], v[1]],
                    TransformPart::Rotation => t.rotation = v[0],
                    TransformPart::Scale => t.scale = [v[0], v[1]],
                }
            }
            _ => {}
        }
    }
}

fn index_and_rest(path: &str) -> Option<(usize, &str)> {
    let (index, rest) = path.split_once('/')?;
    if index.is_empty() || index.len() > 9 || !index.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    Some((index.parse().ok()?, rest))
}

/// What `pointer` animates, or why soupray does not animate it.
pub(crate) fn resolve(
    json: &serde_json::Value,
    pointer: &str,
    targets: &ClipTargets,
) -> Result<Resolved, String> {
    let unsupported = || "not a property soupray animates".to_owned();
    let exists = |p: &str| json.pointer(p).is_some();
    if let Some(rest) = pointer.strip_prefix("/nodes/") {
        let (node, property) = index_and_rest(rest).ok_or_else(unsupported)?;
        if !exists(&format!("/nodes/{node}")) {
            return Err(format!("the file has no node {node}"));
        }
        let (property, width) = match property {
            "translation" => (Property::Translation, 3),
            "rotation" => (Property::Rotation, 4),
            "scale" => (Property::Scale, 3),
            "weights" => match (targets.targets_of_node)(node) {
                0 => return Err(format!("node {node} has no morph targets")),
                t => (Property::Weights, t),
            },
            _ => return Err(unsupported()),
        };
        return Ok(Resolved::Node(vec![node], property, width));
    }
    if let Some(rest) = pointer.strip_prefix("/meshes/") {
        let (mesh, property) = index_and_rest(rest).ok_or_else(unsupported)?;
        if property != "weights" {
            return Err(unsupported());
        }
        return match targets.mesh_targets.get(mesh) {
            None => Err(format!("the file has no mesh {mesh}")),
            Some(0) => Err(format!("mesh {mesh} has no morph targets")),
            Some(&t) => Ok(Resolved::Node(
                targets.mesh_weight_nodes[mesh].clone(),
                Property::Weights,
                t,
            )),
        };
    }
    if let Some(rest) = pointer.strip_prefix("/materials/") {
        let (material, property) = index_and_rest(rest).ok_or_else(unsupported)?;
        if !exists(&format!("/materials/{material}")) {
            return Err(format!("the file has no material {material}"));
        }
        if let Some(factor) = FACTORS.iter().position(|f| f.path == property) {
            return Ok(Resolved::Value(ValueTarget::MaterialFactor {
                material,
                factor,
            }));
        }
        for slot in Slot::ALL {
            let path = slot.path();
            let Some(part) = property
                .strip_prefix(path)
                .and_then(|p| p.strip_prefix("/extensions/KHR_texture_transform/"))
            else {
                continue;
            };
            let part = match part {
                "offset" => TransformPart::Offset,
                "rotation" => TransformPart::Rotation,
                "scale" => TransformPart::Scale,
                _ => return Err(unsupported()),
            };
            if !exists(&format!("/materials/{material}/{path}")) {
                return Err(format!("material {material} has no {path}"));
            }
            return Ok(Resolved::Value(ValueTarget::TextureTransform {
                material,
                slot,
                part,
            }));
        }
        return Err(unsupported());
    }
    if let Some(rest) = pointer.strip_prefix("/extensions/KHR_lights_punctual/lights/") {
        let (light, property) = index_and_rest(rest).ok_or_else(unsupported)?;
        let base = format!("/extensions/KHR_lights_punctual/lights/{light}");
        if !exists(&base) {
            return Err(format!("the file has no KHR_lights_punctual light {light}"));
        }
        let property = match property {
            "color" => LightProperty::Color,
            "intensity" => LightProperty::Intensity,
            "range" => LightProperty::Range,
            "spot/innerConeAngle" => LightProperty::InnerConeAngle,
            "spot/outerConeAngle" => LightProperty::OuterConeAngle,
            _ => return Err(unsupported()),
        };
        if property.is_spot() && !exists(&format!("{base}/spot")) {
            return Err(format!("light {light} is not a spot light"));
        }
        return Ok(Resolved::Value(ValueTarget::Light { light, property }));
    }
    if let Some(rest) = pointer.strip_prefix("/cameras/") {
        let (camera, property) = index_and_rest(rest).ok_or_else(unsupported)?;
        let (kind, property) = property.split_once('/').ok_or_else(unsupported)?;
        let property = match (kind, property) {
            ("perspective", "yfov") => CameraProperty::Yfov,
            ("perspective", "aspectRatio") => CameraProperty::AspectRatio,
            ("perspective" | "orthographic", "znear") => CameraProperty::Znear,
            ("perspective" | "orthographic", "zfar") => CameraProperty::Zfar,
            ("orthographic", "xmag") => CameraProperty::Xmag,
            ("orthographic", "ymag") => CameraProperty::Ymag,
            _ => return Err(unsupported()),
        };
        if !exists(&format!("/cameras/{camera}")) {
            return Err(format!("the file has no camera {camera}"));
        }
        if !exists(&format!("/cameras/{camera}/{kind}")) {
            return Err(format!("camera {camera} is not {kind}"));
        }
        return Ok(Resolved::Value(ValueTarget::Camera { camera, property }));
    }
    Err(unsupported())
}

impl LightProperty {
    fn is_spot(self) -> bool {
        matches!(
            self,
            LightProperty::InnerConeAngle | LightProperty::OuterConeAngle
        )
    }
}

/// Sets a light property to `v`.
fn apply_light(def: &mut LightDef, property: LightProperty, v: &[f32]) {
    match property {
        LightProperty::Color => def.color = v3(v),
        LightProperty::Intensity => def.intensity = v[0],
        LightProperty::Range => def.range = Some(v[0]),
        LightProperty::InnerConeAngle | LightProperty::OuterConeAngle => {
            if let LightKind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } = &mut def.kind
            {
                if property == LightProperty::InnerConeAngle {
                    *inner_cone_angle = v[0];
                } else {
                    *outer_cone_angle = v[0];
                }
            }
        }
    }
}

/// Sets a camera property to `v` (properties of the other projection type
/// were refused when the pointer was resolved).
fn apply_camera(projection: &mut Projection, property: CameraProperty, v: f32) {
    match projection {
        Projection::Perspective {
            yfov,
            aspect,
            znear,
            zfar,
        } => match property {
            CameraProperty::Yfov => *yfov = v,
            CameraProperty::AspectRatio => *aspect = Some(v),
            CameraProperty::Znear => *znear = v,
            CameraProperty::Zfar => *zfar = Some(v),
            _ => {}
        },
        Projection::Orthographic {
            xmag,
            ymag,
            znear,
            zfar,
        } => match property {
            CameraProperty::Xmag => *xmag = v,
            CameraProperty::Ymag => *ymag = v,
            CameraProperty::Znear => *znear = v,
            CameraProperty::Zfar => *zfar = v,
            _ => {}
        },
    }
}

/// At most this many key times are visited by `material_key_times`.
const MAX_MATERIAL_KEY_TIMES: usize = 1024;

impl Scene {
    /// The active clip's pointer channels.
    fn pointer_channels(&self) -> &[super::animation::PointerChannel] {
        self.active_clip()
            .map_or(&[][..], |c| c.pointer_channels.as_slice())
    }

    /// Whether the active clip animates some material property (then the
    /// renderer re-uploads the materials every frame).
    pub fn has_material_animation(&self) -> bool {
        self.pointer_channels()
            .iter()
            .any(|c| c.target.is_material())
    }

    /// Whether the active clip animates a light or camera property.
    pub fn has_light_or_camera_animation(&self) -> bool {
        self.pointer_channels()
            .iter()
            .any(|c| !c.target.is_material())
    }

    /// The material table's materials at `time` seconds, or `None` when no
    /// material is animated (the loaded ones hold at every time). Animated
    /// values are brought into their valid ranges as loading does.
    pub fn materials_at(&self, time: f64) -> Option<Vec<Material>> {
        if !self.has_material_animation() {
            return None;
        }
        let mut materials = self.materials().materials.clone();
        let mut touched = vec![false; materials.len()];
        let mut value = Vec::new();
        for ch in self.pointer_channels() {
            if !ch.target.is_material() {
                continue;
            }
            value.resize(ch.sampler.width, 0.0);
            ch.sampler.sample(time, false, &mut value);
            ch.target.apply_material(&mut materials, &value);
            if let ValueTarget::MaterialFactor { material, .. }
            | ValueTarget::TextureTransform { material, .. } = ch.target
            {
                if let Some(t) = touched.get_mut(material) {
                    *t = true;
                }
            }
        }
        let mut ignored = Vec::new();
        for (i, m) in materials.iter_mut().enumerate() {
            if touched[i] {
                super::ranges::material(i, m, &mut ignored);
            }
        }
        Some(materials)
    }

    /// Every key time of the active clip's material channels (at most
    /// `MAX_MATERIAL_KEY_TIMES`, evenly picked), sorted: where the animated
    /// materials take each key's value, for deciding which material
    /// features the renderer compiles in.
    pub fn material_key_times(&self) -> Vec<f64> {
        let mut times: Vec<f64> = self
            .pointer_channels()
            .iter()
            .filter(|c| c.target.is_material())
            .flat_map(|c| c.sampler.times.iter().map(|&t| t as f64))
            .collect();
        times.sort_by(f64::total_cmp);
        times.dedup();
        if times.len() > MAX_MATERIAL_KEY_TIMES {
            let n = times.len();
            times = (0..MAX_MATERIAL_KEY_TIMES)
                .map(|i| times[i * (n - 1) / (MAX_MATERIAL_KEY_TIMES - 1)])
                .collect();
        }
        times
    }

    /// Light `light` of the file at `time` seconds.
    pub fn light_at(&self, light: usize, time: f64) -> Cow<'_, LightDef> {
        let def = &self.lights()[light];
        let mut animated: Option<LightDef> = None;
        let mut value = [0.0f32; 3];
        for ch in self.pointer_channels() {
            if let ValueTarget::Light { light: l, property } = ch.target {
                if l == light {
                    let v = &mut value[..ch.sampler.width];
                    ch.sampler.sample(time, false, v);
                    apply_light(animated.get_or_insert_with(|| def.clone()), property, v);
                }
            }
        }
        match animated {
            Some(mut a) => {
                let mut ignored = Vec::new();
                super::ranges::light(light, &mut a, &mut ignored);
                Cow::Owned(a)
            }
            None => Cow::Borrowed(def),
        }
    }

    /// The projection of camera `camera` at `time` seconds.
    pub fn projection_at(&self, camera: usize, time: f64) -> Projection {
        let def = &self.cameras()[camera];
        let mut animated: Option<super::CameraDef> = None;
        let mut value = [0.0f32; 1];
        for ch in self.pointer_channels() {
            if let ValueTarget::Camera {
                camera: c,
                property,
            } = ch.target
            {
                if c == camera {
                    ch.sampler.sample(time, false, &mut value);
                    let a = animated.get_or_insert_with(|| def.clone());
                    apply_camera(&mut a.projection, property, value[0]);
                }
            }
        }
        match animated {
            Some(mut a) => {
                let mut ignored = Vec::new();
                super::ranges::camera(camera, &mut a, &mut ignored);
                a.projection
            }
            None => def.projection,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn node_targets(node: usize) -> usize {
        if node == 1 {
            2
        } else {
            0
        }
    }

    fn targets() -> ClipTargets<'static> {
        ClipTargets {
            targets_of_node: &node_targets,
            mesh_targets: vec![0, 2],
            mesh_weight_nodes: vec![vec![], vec![1, 3]],
        }
    }

    fn doc() -> serde_json::Value {
        serde_json::json!({
            "nodes": [{}, {}, {}, {}],
            "meshes": [{}, {}],
            "materials": [{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}],
            "cameras": [{"type": "perspective", "perspective": {"yfov": 1.0, "znear": 0.1}}],
            "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point"}]}}
        })
    }

    #[test]
    fn resolves_the_pointers_soupray_animates() {
        let (j, t) = (doc(), targets());
        let r = |p: &str| resolve(&j, p, &t);
        assert!(matches!(
            r("/nodes/2/rotation"),
            Ok(Resolved::Node(n, Property::Rotation, 4)) if n == vec![2]
        ));
        assert!(matches!(
            r("/meshes/1/weights"),
            Ok(Resolved::Node(n, Property::Weights, 2)) if n == vec![1, 3]
        ));
        assert!(matches!(
            r("/materials/0/pbrMetallicRoughness/baseColorFactor"),
            Ok(Resolved::Value(ValueTarget::MaterialFactor {
                material: 0,
                factor: 0
            }))
        ));
        assert!(matches!(
            r("/materials/0/pbrMetallicRoughness/baseColorTexture/extensions/KHR_texture_transform/offset"),
            Ok(Resolved::Value(ValueTarget::TextureTransform { material: 0, slot: Slot::BaseColor, part: TransformPart::Offset }))
        ));
        assert!(matches!(
            r("/extensions/KHR_lights_punctual/lights/0/intensity"),
            Ok(Resolved::Value(ValueTarget::Light {
                light: 0,
                property: LightProperty::Intensity
            }))
        ));
        assert!(matches!(
            r("/cameras/0/perspective/yfov"),
            Ok(Resolved::Value(ValueTarget::Camera {
                camera: 0,
                property: CameraProperty::Yfov
            }))
        ));
    }

    #[test]
    fn says_why_a_pointer_is_not_animated() {
        let (j, t) = (doc(), targets());
        let r = |p: &str| resolve(&j, p, &t).err().unwrap_or_default();
        assert_eq!(r("/nodes/9/translation"), "the file has no node 9");
        assert_eq!(r("/nodes/0/weights"), "node 0 has no morph targets");
        assert_eq!(r("/nodes/0/matrix"), "not a property soupray animates");
        assert_eq!(r("/asset/version"), "not a property soupray animates");
        assert_eq!(
            r("/materials/0/normalTexture/extensions/KHR_texture_transform/offset"),
            "material 0 has no normalTexture"
        );
        assert_eq!(
            r("/extensions/KHR_lights_punctual/lights/0/spot/outerConeAngle"),
            "light 0 is not a spot light"
        );
        assert_eq!(
            r("/cameras/0/orthographic/xmag"),
            "camera 0 is not orthographic"
        );
        assert_eq!(
            r("/nodes/01x/translation"),
            "not a property soupray animates"
        );
    }
}
