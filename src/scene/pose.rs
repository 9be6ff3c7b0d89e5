//! The per-frame data, computed once per frame and shared by every vertex:
//! local transforms after the active clip is sampled, node world matrices,
//! skin joint matrices `world_from_joint * joint_from_bind`, and each mesh
//! node's morph weights. This is exactly what the device kernel receives.

use glam::Mat4;

use super::animation::Property;
use super::{Scene, Trs};

/// Everything about one instant that does not depend on a vertex.
#[derive(Debug, Clone)]
pub struct Pose {
    pub time: f64,
    /// Local transform of every node (rest pose unless animated).
    pub local: Vec<Trs>,
    pub world_from_node: Vec<Mat4>,
    /// Per skin, per joint: `world_from_joint * joint_from_bind`.
    pub joint_matrices: Vec<Vec<Mat4>>,
    /// Per node: morph weights of its mesh (empty without morph targets).
    pub morph_weights: Vec<Vec<f32>>,
}

impl Scene {
    /// Samples the active clip at `time` (seconds) and derives the frame's
    /// matrices and weights. Nodes the clip does not touch keep their rest
    /// pose; other clips are never blended in.
    pub fn pose(&self, time: f64) -> Pose {
        let nodes = self.nodes();
        let mut local: Vec<Trs> = nodes.iter().map(|n| n.rest).collect();
        let mut animated = vec![false; nodes.len()];
        let mut morph_weights: Vec<Vec<f32>> = nodes
            .iter()
            .map(|n| match n.mesh {
                Some(m) if self.meshes()[m].target_count > 0 => n
                    .weights
                    .clone()
                    .unwrap_or_else(|| self.meshes()[m].default_weights.clone()),
                _ => Vec::new(),
            })
            .collect();

        if let Some(clip) = self.active_clip() {
            let mut value = [0.0f32; 4];
            for ch in &clip.channels {
                let trs = &mut local[ch.node];
                match ch.property {
                    Property::Translation => {
                        ch.sampler.sample(time, false, &mut value[..3]);
                        trs.translation = glam::Vec3::from_slice(&value[..3]);
                        animated[ch.node] = true;
                    }
                    Property::Scale => {
                        ch.sampler.sample(time, false, &mut value[..3]);
                        trs.scale = glam::Vec3::from_slice(&value[..3]);
                        animated[ch.node] = true;
                    }
                    Property::Rotation => {
                        ch.sampler.sample(time, true, &mut value);
                        trs.rotation = glam::Quat::from_array(value).normalize();
                        animated[ch.node] = true;
                    }
                    Property::Weights => {
                        let w = &mut morph_weights[ch.node];
                        if w.len() == ch.sampler.width {
                            ch.sampler.sample(time, false, w);
                        }
                    }
                }
            }
        }

        let mut world_from_node = vec![Mat4::IDENTITY; nodes.len()];
        for &n in self.node_order() {
            let local_matrix = match nodes[n].rest_matrix {
                Some(m) if !animated[n] => m,
                _ => local[n].matrix(),
            };
            world_from_node[n] = match nodes[n].parent {
                Some(p) => world_from_node[p] * local_matrix,
                None => local_matrix,
            };
        }

        let joint_matrices = self
            .skins()
            .iter()
            .map(|skin| {
                skin.joints
                    .iter()
                    .zip(&skin.joint_from_bind)
                    .map(|(&j, joint_from_bind)| world_from_node[j] * *joint_from_bind)
                    .collect()
            })
            .collect();

        Pose {
            time,
            local,
            world_from_node,
            joint_matrices,
            morph_weights,
        }
    }
}
