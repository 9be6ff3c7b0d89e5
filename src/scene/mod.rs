//! The scene side of soupray: a glTF 2.0 file loaded once, then evaluated at
//! any time into the exact world-space triangle soup the specification
//! defines, together with the frame's camera and lights.
//!
//! Loading (`load`) reads and checks everything that does not depend on
//! time. Each frame then runs in two stages that the OpenCL path mirrors:
//! `pose` computes the per-frame data (node world matrices, joint matrices
//! `world_from_joint * joint_from_bind`, morph weights) and `evaluate` runs
//! the per-vertex pass of `deform` over every mesh instance.

mod accessor;
pub mod animation;
pub mod camera;
pub mod compositing;
pub mod deform;
mod draco;
pub mod error;
mod evaluate;
mod image_decode;
mod instancing;
mod ktx2_basis;
pub mod light;
mod load;
pub mod material;
pub(crate) mod material_load;
pub mod mattes;
pub mod mesh;
mod meshopt_views;
pub mod pointer;
pub mod pose;
mod ranges;
pub mod soup_size;
mod source;
mod texture_source;
mod validate;

use std::sync::OnceLock;

use glam::{Mat4, Quat, Vec3};

pub use animation::{Clip, Interpolation, Property};
pub use camera::{CameraDef, FrameCamera, Projection};
pub use error::SceneError;
pub use evaluate::FrameSoup;
pub use light::{FrameLight, LightDef, LightKind};
pub use material::{AlphaMode, Material, MaterialTable, TextureRef, TextureTransform};
pub use mattes::MatteTable;
pub use mesh::{Influences, Mesh, MorphTarget, Primitive};
pub use pose::Pose;
pub use source::supported_extensions;

/// The words that mark an error produced by catching a panic inside
/// loading (see [`Scene::load`]); tests assert no input reaches it.
pub const LAST_RESORT: &str = "could not be loaded: the glTF reader failed on it";

/// How to load a file and which of its contents to use.
#[derive(Debug, Clone, PartialEq)]
pub struct LoadOptions {
    /// Index of the scene to use; `None` is the file's default scene.
    pub scene: Option<usize>,
    /// Animation name or index; `None` is animation 0 (when there is one).
    pub animation: Option<String>,
    /// Camera name (of the camera or of its node) or camera index; `None`
    /// is the first camera found in the scene, or a framing default camera.
    pub camera: Option<String>,
    /// Frames per second: frame N is at time N / fps.
    pub fps: f64,
    /// Drop triangles with NaN/infinite vertices (counted as warnings)
    /// instead of failing.
    pub sanitize: bool,
    /// KHR_materials_variants: the variant (name or index) whose materials
    /// replace the primitives' own; `None` keeps the default materials.
    pub variant: Option<String>,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            scene: None,
            animation: None,
            camera: None,
            fps: 24.0,
            sanitize: false,
            variant: None,
        }
    }
}

/// Translation, rotation, scale: the animatable form of a local transform.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trs {
    pub translation: Vec3,
    pub rotation: Quat,
    pub scale: Vec3,
}

impl Trs {
    /// `T * R * S`, the order glTF defines.
    pub fn matrix(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }
}

#[derive(Debug, Clone)]
pub struct Node {
    pub name: Option<String>,
    pub parent: Option<usize>,
    pub children: Vec<usize>,
    /// The rest pose as TRS (decomposed from `matrix` when the node has one).
    pub rest: Trs,
    /// The node's `matrix`, used verbatim unless an animation targets it.
    pub rest_matrix: Option<Mat4>,
    pub mesh: Option<usize>,
    pub skin: Option<usize>,
    pub camera: Option<usize>,
    pub light: Option<usize>,
    /// `node.weights`, overriding `mesh.weights`.
    pub weights: Option<Vec<f32>>,
    /// Its own `extras.soupray` compositing role (`compositing`).
    pub role: Option<compositing::Role>,
}

#[derive(Debug, Clone)]
pub struct Skin {
    pub name: Option<String>,
    /// Node index of each joint.
    pub joints: Vec<usize>,
    /// Inverse bind matrices (identity when the file has none).
    pub joint_from_bind: Vec<Mat4>,
}

/// A mesh placed in the scene by a node.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MeshInstance {
    pub node: usize,
    pub mesh: usize,
    /// The node's skin, when its mesh carries joint influences.
    pub skin: Option<usize>,
    /// One of the node's EXT_mesh_gpu_instancing instances: its transform
    /// in the node's space. `None` for a node that draws its mesh once.
    pub node_from_instance: Option<Mat4>,
}

impl MeshInstance {
    /// Where an unskinned instance's mesh sits in the pose.
    pub fn world_from_mesh(&self, pose: &Pose) -> Mat4 {
        let world_from_node = pose.world_from_node[self.node];
        match self.node_from_instance {
            Some(m) => world_from_node * m,
            None => world_from_node,
        }
    }

    /// The joint matrices of a skinned instance in the pose. Skinning
    /// places vertices in world space and ignores the node's transform, so
    /// an instance's transform moves the skinned mesh about the node:
    /// `world_from_node * node_from_instance * node_from_world` before each
    /// joint matrix.
    pub fn joint_matrices<'p>(&self, pose: &'p Pose) -> Option<std::borrow::Cow<'p, [Mat4]>> {
        let joints = pose.joint_matrices[self.skin?].as_slice();
        Some(match self.node_from_instance {
            None => std::borrow::Cow::Borrowed(joints),
            Some(m) => {
                let w = pose.world_from_node[self.node];
                let about_node = w * m * w.inverse();
                std::borrow::Cow::Owned(joints.iter().map(|j| about_node * *j).collect())
            }
        })
    }
}

/// A loaded glTF file with one scene, animation and camera chosen.
#[derive(Debug)]
pub struct Scene {
    file: String,
    options: LoadOptions,
    nodes: Vec<Node>,
    /// Every node in the hierarchy, parents before children.
    node_order: Vec<usize>,
    scene_index: Option<usize>,
    scene_count: usize,
    instances: Vec<MeshInstance>,
    meshes: Vec<Mesh>,
    skins: Vec<Skin>,
    clips: Vec<Clip>,
    clip: Option<usize>,
    cameras: Vec<CameraDef>,
    /// (node, camera) of the chosen camera.
    camera_instance: Option<(usize, usize)>,
    lights: Vec<LightDef>,
    /// (node, light) of every light placed in the scene.
    light_instances: Vec<(usize, usize)>,
    materials: MaterialTable,
    warnings: Vec<String>,
    extensions_used: Vec<String>,
    /// KHR_materials_variants: the file's variant names.
    variants: Vec<String>,
    extensions_required: Vec<String>,
    soup_has_normals: bool,
    soup_has_uvs: bool,
    soup_has_uvs1: bool,
    soup_has_colors: bool,
    /// Which TEXCOORD_n the soup's second uv slot carries, when a material
    /// samples one besides TEXCOORD_0.
    second_uv_set: Option<u32>,
    /// The file's own constant environment (`extras.soupray.environment`).
    environment: Option<[f32; 3]>,
    /// Bounds of every frame of the clip, for the default camera.
    clip_bounds: OnceLock<(Vec3, Vec3)>,
}

impl Scene {
    /// Loads `path` (.gltf or .glb) and selects scene, animation and camera.
    ///
    /// The document is validated before the `gltf` crate indexes into it
    /// (`validate`), so a broken file is an error, not a panic. As a last
    /// resort, a panic inside loading anyway becomes an error naming the
    /// file whose message contains [`LAST_RESORT`], which the fuzz tests
    /// look for: every input that reaches it is a validation gap.
    pub fn load(path: &std::path::Path, opts: &LoadOptions) -> Result<Scene, SceneError> {
        catching_panics(path, || load::load(path, opts))
    }

    /// The path as given, as it appears in messages.
    pub fn file(&self) -> &str {
        &self.file
    }

    pub fn options(&self) -> &LoadOptions {
        &self.options
    }

    /// First and last frame of the chosen clip: 0 ..= ceil(duration * fps).
    pub fn frame_range(&self) -> (i64, i64) {
        let frames = self.duration() * self.options.fps;
        // Key times are f32; allow their rounding so that a clip of exactly
        // N frames does not grow a spurious frame N + 1.
        let last = (frames - 1e-4).ceil().max(0.0);
        (0, last as i64)
    }

    pub fn time_of_frame(&self, frame: i64) -> f64 {
        frame as f64 / self.options.fps
    }

    /// Duration of the chosen clip in seconds (0 without animation).
    pub fn duration(&self) -> f64 {
        self.active_clip().map_or(0.0, |c| c.duration)
    }

    pub fn active_clip(&self) -> Option<&Clip> {
        self.clip.map(|c| &self.clips[c])
    }

    /// Every animation of the file (only the active one is ever applied).
    pub fn clips(&self) -> &[Clip] {
        &self.clips
    }

    pub fn nodes(&self) -> &[Node] {
        &self.nodes
    }

    /// Nodes ordered so that every parent precedes its children.
    pub fn node_order(&self) -> &[usize] {
        &self.node_order
    }

    pub fn meshes(&self) -> &[Mesh] {
        &self.meshes
    }

    pub fn skins(&self) -> &[Skin] {
        &self.skins
    }

    /// The mesh instances of the chosen scene, in traversal order.
    pub fn instances(&self) -> &[MeshInstance] {
        &self.instances
    }

    pub fn cameras(&self) -> &[CameraDef] {
        &self.cameras
    }

    /// (node, camera index) of the camera frames are seen through, or
    /// `None` when the default framing camera is used.
    pub fn camera_instance(&self) -> Option<(usize, usize)> {
        self.camera_instance
    }

    pub fn lights(&self) -> &[LightDef] {
        &self.lights
    }

    pub fn light_instances(&self) -> &[(usize, usize)] {
        &self.light_instances
    }

    pub fn materials(&self) -> &MaterialTable {
        &self.materials
    }

    /// Problems found while loading that did not stop it.
    pub fn warnings(&self) -> &[String] {
        &self.warnings
    }

    pub fn scene_index(&self) -> Option<usize> {
        self.scene_index
    }

    pub fn scene_count(&self) -> usize {
        self.scene_count
    }

    /// The file's KHR_materials_variants names, in order.
    pub fn variants(&self) -> &[String] {
        &self.variants
    }

    pub fn extensions_used(&self) -> &[String] {
        &self.extensions_used
    }

    pub fn extensions_required(&self) -> &[String] {
        &self.extensions_required
    }

    /// Whether any mesh instance is skinned.
    pub fn has_skins(&self) -> bool {
        self.instances.iter().any(|i| i.skin.is_some())
    }

    /// The most morph targets any instanced mesh has (0: no morphing).
    pub fn max_morph_targets(&self) -> usize {
        self.instances
            .iter()
            .map(|i| self.meshes[i.mesh].target_count)
            .max()
            .unwrap_or(0)
    }

    /// The most JOINTS_n/WEIGHTS_n sets any skinned primitive has.
    pub fn max_influence_sets(&self) -> usize {
        self.instances
            .iter()
            .filter(|i| i.skin.is_some())
            .flat_map(|i| &self.meshes[i.mesh].primitives)
            .filter_map(|p| p.influences.as_ref().map(|inf| inf.sets))
            .max()
            .unwrap_or(0)
    }

    /// The largest joint count of any skin in use.
    pub fn max_joints(&self) -> usize {
        self.instances
            .iter()
            .filter_map(|i| i.skin.map(|s| self.skins[s].joints.len()))
            .max()
            .unwrap_or(0)
    }

    /// Whether frames carry per-corner normals.
    pub fn has_normals(&self) -> bool {
        self.soup_has_normals
    }

    /// Whether frames carry TEXCOORD_0.
    pub fn has_uvs(&self) -> bool {
        self.soup_has_uvs
    }

    /// Whether the soup carries a second texture coordinate set.
    pub fn has_uvs1(&self) -> bool {
        self.soup_has_uvs1
    }

    /// Which TEXCOORD_n the soup's second set is, if a material samples one
    /// besides TEXCOORD_0 (the materials' texture uses are renumbered: 1
    /// means this set).
    pub fn second_uv_set(&self) -> Option<u32> {
        self.second_uv_set
    }

    /// The constant environment radiance the file asks for in its scene's
    /// `extras` (`{"soupray": {"environment": [r, g, b]}}`), used when the
    /// command line chooses none.
    pub fn environment(&self) -> Option<[f32; 3]> {
        self.environment
    }

    /// Whether the soup carries vertex colours (COLOR_0).
    pub fn has_colors(&self) -> bool {
        self.soup_has_colors
    }

    /// Triangles per frame (topology never changes with time; `--sanitize`
    /// may drop some from a frame).
    pub fn triangle_count(&self) -> usize {
        triangle_count(&self.instances, &self.meshes)
    }

    /// Mesh instances drawn by EXT_mesh_gpu_instancing nodes.
    pub fn gpu_instance_count(&self) -> usize {
        self.instances
            .iter()
            .filter(|i| i.node_from_instance.is_some())
            .count()
    }

    /// Each instance with each primitive of its mesh, in the order the
    /// soup lays their triangles out: what per-triangle tables (materials,
    /// matte pairs, compositing flags) are expanded from.
    pub fn instance_primitives(&self) -> impl Iterator<Item = (&MeshInstance, &Primitive)> {
        self.instances
            .iter()
            .flat_map(|i| self.meshes[i.mesh].primitives.iter().map(move |p| (i, p)))
    }

    /// "node 3 \"Arm\"" for messages.
    pub fn node_label(&self, node: usize) -> String {
        match &self.nodes[node].name {
            Some(n) => format!("node {node} \"{n}\""),
            None => format!("node {node}"),
        }
    }
}

/// Triangles of the soup the instances make of the meshes.
fn triangle_count(instances: &[MeshInstance], meshes: &[Mesh]) -> usize {
    instances
        .iter()
        .flat_map(|i| &meshes[i.mesh].primitives)
        .map(|p| p.triangles.len())
        .sum()
}

/// Runs `load`, turning a panic inside it into an error naming `path` whose
/// message contains [`LAST_RESORT`].
fn catching_panics<T>(
    path: &std::path::Path,
    load: impl FnOnce() -> Result<T, SceneError>,
) -> Result<T, SceneError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(load)).unwrap_or_else(|panic| {
        let what = panic
            .downcast_ref::<&str>()
            .map(|s| s.to_string())
            .or_else(|| panic.downcast_ref::<String>().cloned())
            .unwrap_or_else(|| "unknown panic".into());
        Err(SceneError::Malformed {
            file: path.display().to_string(),
            detail: format!(
                "{LAST_RESORT} ({what}). The file is malformed in a way soupray's checks missed. \
                 Fix: run it through the Khronos glTF-Validator and re-export it; please report the file."
            ),
        })
    })
}

#[cfg(test)]
mod last_resort_tests {
    use super::*;

    #[test]
    fn a_panic_inside_loading_is_an_error_naming_the_file() {
        let path = std::path::Path::new("dir/broken.glb");
        let e = catching_panics::<()>(path, || panic!("index out of bounds")).unwrap_err();
        let msg = e.to_string();
        assert!(msg.starts_with("dir/broken.glb: "), "{msg}");
        assert!(
            msg.contains(LAST_RESORT) && msg.contains("index out of bounds"),
            "{msg}"
        );
        assert!(catching_panics(path, || Ok(7)).is_ok());
    }
}
