//! The host copies of a scene's static soup data, built primitive by
//! primitive before anything is uploaded. A mesh placed by several nodes
//! stores its vertex data once.

use std::collections::HashMap;

use super::{
    as_u32, InstanceSlot, SoupFeatures, SoupSegment, TriangleRange, SEG_COLORS, SEG_NORMALS,
    SEG_SKINNED, SEG_UVS, SEG_UVS1, SOUP_NONE,
};
use crate::scene::{Influences, Mesh, MeshInstance, Primitive, Scene, SceneError};

fn v4(v: glam::Vec3) -> [f32; 4] {
    [v.x, v.y, v.z, 0.0]
}

/// Where a primitive's static data lies: (first vertex, first morph delta,
/// first influence record), `SOUP_NONE` for what it has none of (yet).
type Stored = (u32, u32, u32);

#[derive(Default)]
pub(super) struct HostSoup {
    pub base_positions: Vec<[f32; 4]>,
    pub base_normals: Vec<[f32; 4]>,
    pub base_uvs: Vec<[f32; 2]>,
    pub base_uvs1: Vec<[f32; 2]>,
    pub base_colors: Vec<[f32; 4]>,
    pub position_deltas: Vec<[f32; 4]>,
    pub normal_deltas: Vec<[f32; 4]>,
    pub influence_joints: Vec<[u32; 4]>,
    pub influence_weights: Vec<[f32; 4]>,
    pub segments: Vec<SoupSegment>,
    pub vertex_segment: Vec<u32>,
    pub triangles: Vec<[u32; 4]>,
    pub material_ids: Vec<u32>,
    pub ranges: Vec<TriangleRange>,
    pub instances: Vec<InstanceSlot>,
    /// (mesh, primitive) → where its static data lies.
    stored: HashMap<(usize, usize), Stored>,
    /// Skin → its joint matrices' first slot, for the instances sharing them.
    skin_base: HashMap<usize, u32>,
    pub joint_count: usize,
    pub weight_count: usize,
}

impl HostSoup {
    /// Lays out `scene`'s static data for a program compiled for
    /// `features`; `file` names the scene in errors.
    pub fn build(scene: &Scene, features: &SoupFeatures, file: &str) -> Result<Self, SceneError> {
        let mut host = HostSoup::default();
        let morphs = features.morph_targets > 0;
        let default_material = scene.materials().default_material.unwrap_or(0);

        for (ii, inst) in scene.instances().iter().enumerate() {
            let mesh = &scene.meshes()[inst.mesh];
            let joint_base = host.joint_base(scene, inst, file)?;
            let weights = if morphs && mesh.target_count > 0 {
                let base = as_u32(file, "morph weights", host.weight_count)?;
                host.weight_count += mesh.target_count;
                Some((base, mesh.target_count))
            } else {
                None
            };
            host.instances.push(InstanceSlot {
                instance: *inst,
                joint_base,
                weights,
            });

            for (pi, prim) in mesh.primitives.iter().enumerate() {
                let n = prim.vertex_count();
                // The loader guarantees this; the kernel's delta stride and
                // weight count both rely on it.
                if prim.targets.len() != mesh.target_count {
                    return Err(SceneError::Invalid {
                        file: file.to_owned(),
                        detail: format!(
                            "mesh {} primitive {} has {} morph targets but the mesh has {}. Fix: re-export the mesh.",
                            inst.mesh,
                            prim.index_in_mesh,
                            prim.targets.len(),
                            mesh.target_count
                        ),
                    });
                }
                let entry = match host.stored.get(&(inst.mesh, pi)) {
                    Some(&e) => e,
                    None => {
                        let e = host.store_vertices(features, mesh, prim, file)?;
                        host.stored.insert((inst.mesh, pi), e);
                        e
                    }
                };
                let (src_vertex, morph_base, mut influence_base) = entry;
                let skinned = joint_base.is_some() && prim.influences.is_some();
                if let (true, Some(inf)) =
                    (skinned && influence_base == SOUP_NONE, &prim.influences)
                {
                    influence_base =
                        host.store_influences(features.influence_sets, inf, n, file)?;
                    host.stored
                        .insert((inst.mesh, pi), (src_vertex, morph_base, influence_base));
                }

                let seg = as_u32(file, "primitive instances", host.segments.len())?;
                let dst_vertex = as_u32(file, "deformed vertices", host.vertex_segment.len())?;
                host.segments.push(SoupSegment {
                    src_vertex,
                    dst_vertex,
                    vertex_count: as_u32(file, "vertices", n)?,
                    instance: as_u32(file, "mesh instances", ii)?,
                    influence_base: if skinned { influence_base } else { SOUP_NONE },
                    joint_base: match (skinned, joint_base) {
                        (true, Some(base)) => base,
                        _ => SOUP_NONE,
                    },
                    morph_base,
                    weight_base: weights.map_or(SOUP_NONE, |(b, _)| b),
                    target_count: if morph_base == SOUP_NONE {
                        0
                    } else {
                        mesh.target_count as u32
                    },
                    flags: segment_flags(prim, skinned),
                    pad0: 0,
                    pad1: 0,
                });
                host.vertex_segment.extend(std::iter::repeat_n(seg, n));
                host.ranges.push(TriangleRange {
                    first: host.triangles.len(),
                    instance: ii,
                    primitive: pi,
                });
                let material = prim.material.map_or(default_material, |m| m as u32);
                host.triangles
                    .extend(prim.triangles.iter().map(|t| [t[0], t[1], t[2], seg]));
                host.material_ids
                    .extend(std::iter::repeat_n(material, prim.triangles.len()));
            }
        }
        Ok(host)
    }

    /// The first joint matrix slot of `inst`'s skin, if it has one.
    fn joint_base(
        &mut self,
        scene: &Scene,
        inst: &MeshInstance,
        file: &str,
    ) -> Result<Option<u32>, SceneError> {
        Ok(match inst.skin {
            Some(s) => {
                // Instances of a skin share its joint matrices, except an
                // EXT_mesh_gpu_instancing instance, which has its own
                // (`MeshInstance::joint_matrices`).
                let shared = inst.node_from_instance.is_none().then_some(s);
                match shared.and_then(|s| self.skin_base.get(&s)) {
                    Some(&b) => Some(b),
                    None => {
                        let b = as_u32(file, "joint matrices", self.joint_count)?;
                        self.joint_count += scene.skins()[s].joints.len();
                        if let Some(s) = shared {
                            self.skin_base.insert(s, b);
                        }
                        Some(b)
                    }
                }
            }
            None => None,
        })
    }

    /// Stores a primitive's vertex attributes (defaults where it lacks one
    /// the program reads) and its morph deltas; its influences wait for a
    /// skinned instance.
    fn store_vertices(
        &mut self,
        features: &SoupFeatures,
        mesh: &Mesh,
        prim: &Primitive,
        file: &str,
    ) -> Result<Stored, SceneError> {
        let n = prim.vertex_count();
        let src = as_u32(file, "vertices", self.base_positions.len())?;
        self.base_positions
            .extend(prim.positions.iter().map(|&p| v4(p)));
        if features.normals {
            match &prim.normals {
                Some(nr) => self.base_normals.extend(nr.iter().map(|&p| v4(p))),
                None => self.base_normals.extend(std::iter::repeat_n([0.0; 4], n)),
            }
        }
        if features.uvs {
            match &prim.uvs {
                Some(uv) => self.base_uvs.extend_from_slice(uv),
                None => self.base_uvs.extend(std::iter::repeat_n([0.0; 2], n)),
            }
        }
        if features.uvs1 {
            match &prim.uvs1 {
                Some(uv) => self.base_uvs1.extend_from_slice(uv),
                None => self.base_uvs1.extend(std::iter::repeat_n([0.0; 2], n)),
            }
        }
        if features.colors {
            match &prim.colors {
                Some(c) => self.base_colors.extend_from_slice(c),
                None => self.base_colors.extend(std::iter::repeat_n([1.0; 4], n)),
            }
        }
        let mut morph_base = SOUP_NONE;
        if features.morph_targets > 0 && mesh.target_count > 0 {
            morph_base = as_u32(file, "morph deltas", self.position_deltas.len())?;
            // Vertex-major, so one vertex's deltas are adjacent.
            for v in 0..n {
                for target in &prim.targets {
                    self.position_deltas
                        .push(target.positions.as_ref().map_or([0.0; 4], |d| v4(d[v])));
                    if features.normals {
                        self.normal_deltas
                            .push(target.normals.as_ref().map_or([0.0; 4], |d| v4(d[v])));
                    }
                }
            }
        }
        Ok((src, morph_base, SOUP_NONE))
    }

    /// Stores a primitive's `n` vertices' joint influences, the first time
    /// a skinned instance needs them, padded to `sets` (INFLUENCE_SETS)
    /// with zero weights (which the blend skips, as the CPU skips them);
    /// returns the first record.
    fn store_influences(
        &mut self,
        sets: usize,
        inf: &Influences,
        n: usize,
        file: &str,
    ) -> Result<u32, SceneError> {
        let base = as_u32(file, "influence records", self.influence_joints.len())?;
        for v in 0..n {
            let (j, w) = inf.of_vertex(v);
            for s in 0..sets {
                if s < inf.sets {
                    self.influence_joints.push([
                        j[4 * s],
                        j[4 * s + 1],
                        j[4 * s + 2],
                        j[4 * s + 3],
                    ]);
                    self.influence_weights.push([
                        w[4 * s],
                        w[4 * s + 1],
                        w[4 * s + 2],
                        w[4 * s + 3],
                    ]);
                } else {
                    self.influence_joints.push([0; 4]);
                    self.influence_weights.push([0.0; 4]);
                }
            }
        }
        Ok(base)
    }
}

/// The `SEG_*` flags of a primitive's segment.
fn segment_flags(prim: &Primitive, skinned: bool) -> u32 {
    let mut flags = 0;
    if prim.normals.is_some() {
        flags |= SEG_NORMALS;
    }
    if prim.uvs.is_some() {
        flags |= SEG_UVS;
    }
    if prim.uvs1.is_some() {
        flags |= SEG_UVS1;
    }
    if prim.colors.is_some() {
        flags |= SEG_COLORS;
    }
    if skinned {
        flags |= SEG_SKINNED;
    }
    flags
}
