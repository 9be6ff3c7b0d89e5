//! KHR_lights_punctual lights, placed each frame by their (possibly
//! animated) nodes. A light shines along its node's local -Z axis.

use glam::{Mat4, Vec3};

#[derive(Debug, Clone, Copy, PartialEq)]
pub enum LightKind {
    Directional,
    Point,
    Spot {
        /// Radians from the axis where falloff starts.
        inner_cone_angle: f32,
        /// Radians from the axis where the light ends.
        outer_cone_angle: f32,
    },
}

impl LightKind {
    pub fn name(&self) -> &'static str {
        match self {
            LightKind::Directional => "directional",
            LightKind::Point => "point",
            LightKind::Spot { .. } => "spot",
        }
    }
}

/// A light of the file, before placement.
#[derive(Debug, Clone)]
pub struct LightDef {
    pub name: Option<String>,
    pub kind: LightKind,
    /// Linear RGB.
    pub color: [f32; 3],
    /// Candela (point, spot) or lux (directional), per the extension.
    pub intensity: f32,
    /// Distance where the light reaches zero; `None` is unlimited.
    pub range: Option<f32>,
}

/// A light of one frame, in world space.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameLight {
    pub name: Option<String>,
    pub node: usize,
    pub kind: LightKind,
    pub color: [f32; 3],
    pub intensity: f32,
    pub range: Option<f32>,
    pub position: Vec3,
    /// Unit direction the light shines in.
    pub direction: Vec3,
}

pub(crate) fn load_light(light: &gltf::khr_lights_punctual::Light) -> LightDef {
    let kind = match light.kind() {
        gltf::khr_lights_punctual::Kind::Directional => LightKind::Directional,
        gltf::khr_lights_punctual::Kind::Point => LightKind::Point,
        gltf::khr_lights_punctual::Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } => LightKind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        },
    };
    LightDef {
        name: light.name().map(str::to_owned),
        kind,
        color: light.color(),
        intensity: light.intensity(),
        range: light.range(),
    }
}

pub(crate) fn place(def: &LightDef, node: usize, world_from_node: &Mat4) -> FrameLight {
    FrameLight {
        name: def.name.clone(),
        node,
        kind: def.kind,
        color: def.color,
        intensity: def.intensity,
        range: def.range,
        position: world_from_node.w_axis.truncate(),
        direction: world_from_node
            .transform_vector3(Vec3::NEG_Z)
            .normalize_or(Vec3::NEG_Z),
    }
}
