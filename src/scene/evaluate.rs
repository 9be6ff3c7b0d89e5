//! One frame on the CPU: the per-vertex pass of `deform` over every mesh
//! instance of the scene, then triangle assembly into the world-space soup
//! (with the winding fixed for mirrored transforms), and the frame's camera
//! and lights. This is the reference the device path is checked against.

use glam::{Mat4, Vec3};

use super::camera::{framing, rigid, FrameCamera};
use super::deform::{morph_blend, skin_matrix, transform_vertex, DeformedVertex};
use super::error::{Result, SceneError};
use super::light::{place, FrameLight};
use super::mesh::Primitive;
use super::pose::Pose;
use super::Scene;
use crate::soup::Soup;

/// Frames sampled to find the default camera's framing bounds; longer clips
/// are sampled evenly (their end frames always included).
const MAX_FRAMING_SAMPLES: i64 = 240;

/// A frame, ready to trace.
#[derive(Debug, Clone)]
pub struct FrameSoup {
    pub time: f64,
    pub soup: Soup,
    pub camera: FrameCamera,
    pub lights: Vec<FrameLight>,
    /// Problems of this frame that `--sanitize` turned into warnings.
    pub warnings: Vec<String>,
}

/// Runs the per-vertex pass over one primitive.
pub fn deform_primitive(
    prim: &Primitive,
    morph_weights: &[f32],
    world_from_node: &Mat4,
    joint_matrices: Option<&[Mat4]>,
) -> Vec<DeformedVertex> {
    (0..prim.vertex_count())
        .map(|v| {
            let position = morph_blend(prim.positions[v], morph_weights, |t| {
                prim.targets[t].positions.as_ref().map(|d| d[v])
            });
            let normal = match &prim.normals {
                Some(normals) => morph_blend(normals[v], morph_weights, |t| {
                    prim.targets[t].normals.as_ref().map(|d| d[v])
                }),
                None => Vec3::ZERO,
            };
            let world_from_mesh = match (joint_matrices, &prim.influences) {
                (Some(joints), Some(inf)) => {
                    let (j, w) = inf.of_vertex(v);
                    skin_matrix(j, w, joints)
                }
                _ => *world_from_node,
            };
            transform_vertex(&world_from_mesh, position, normal)
        })
        .collect()
}

/// Appends a triangle's three corners of one vertex attribute to the soup,
/// in the soup's corner `order`, or `missing` where the primitive lacks it.
fn push_corners<T: Copy>(
    out: &mut Vec<T>,
    values: Option<&[T]>,
    tri: &[u32; 3],
    order: &[usize; 3],
    missing: T,
) {
    out.extend(
        order
            .iter()
            .map(|&k| values.map_or(missing, |v| v[tri[k] as usize])),
    );
}

impl Scene {
    /// The world-space triangle soup, camera and lights at `time` seconds.
    pub fn evaluate(&self, time: f64) -> Result<FrameSoup> {
        let pose = self.pose(time);
        let mut warnings = Vec::new();
        let soup = self.soup_of(&pose, true, &mut warnings)?;
        Ok(FrameSoup {
            time,
            soup,
            camera: self.frame_camera(&pose)?,
            lights: self.frame_lights(&pose),
            warnings,
        })
    }

    /// The camera of a pose: the chosen camera's node, or the default
    /// camera framing the whole clip. Shared with the device soup path so
    /// both place the camera identically.
    pub fn frame_camera(&self, pose: &Pose) -> Result<FrameCamera> {
        Ok(match self.camera_instance() {
            Some((node, camera)) => {
                let def = &self.cameras()[camera];
                FrameCamera {
                    name: def.name.clone(),
                    world_from_camera: rigid(&pose.world_from_node[node]),
                    projection: self.projection_at(camera, pose.time),
                    from_file: true,
                }
            }
            None => {
                let (lo, hi) = self.clip_bounds()?;
                framing(lo, hi)
            }
        })
    }

    /// The lights of a pose, in world space.
    pub fn frame_lights(&self, pose: &Pose) -> Vec<FrameLight> {
        self.light_instances()
            .iter()
            .map(|&(node, light)| {
                place(
                    &self.light_at(light, pose.time),
                    node,
                    &pose.world_from_node[node],
                )
            })
            .collect()
    }

    /// Bounds of the geometry over every frame of the clip.
    pub fn clip_bounds(&self) -> Result<(Vec3, Vec3)> {
        if let Some(b) = self.clip_bounds.get() {
            return Ok(*b);
        }
        let (first, last) = self.frame_range();
        let span = last - first;
        let samples = span.min(MAX_FRAMING_SAMPLES);
        let mut lo = Vec3::splat(f32::INFINITY);
        let mut hi = Vec3::splat(f32::NEG_INFINITY);
        let mut ignored = Vec::new();
        for s in 0..=samples {
            let frame = if samples == 0 {
                first
            } else {
                first + span * s / samples
            };
            let soup = self.soup_of(&self.pose(self.time_of_frame(frame)), false, &mut ignored)?;
            if let Some((a, b)) = soup.bounds() {
                lo = lo.min(Vec3::from(a));
                hi = hi.max(Vec3::from(b));
            }
        }
        let _ = self.clip_bounds.set((lo, hi));
        Ok((lo, hi))
    }

    /// Assembles the soup of a pose; `attributes` false gives positions only.
    fn soup_of(&self, pose: &Pose, attributes: bool, warnings: &mut Vec<String>) -> Result<Soup> {
        let with_normals = attributes && self.has_normals();
        let with_uvs = attributes && self.has_uvs();
        let with_uvs1 = attributes && self.has_uvs1();
        let with_colors = attributes && self.has_colors();
        let triangles = self.triangle_count();
        let mut soup = Soup {
            positions: Vec::with_capacity(3 * triangles),
            normals: Vec::with_capacity(if with_normals { 3 * triangles } else { 0 }),
            uvs: Vec::with_capacity(if with_uvs { 3 * triangles } else { 0 }),
            uvs1: Vec::with_capacity(if with_uvs1 { 3 * triangles } else { 0 }),
            colors: Vec::with_capacity(if with_colors { 3 * triangles } else { 0 }),
            material_ids: Vec::with_capacity(if attributes { triangles } else { 0 }),
        };
        let default_material = self.materials().default_material.unwrap_or(0);
        let mut dropped = 0usize;
        for inst in self.instances() {
            let mesh = &self.meshes()[inst.mesh];
            let joints = inst.joint_matrices(pose);
            let world_from_mesh = inst.world_from_mesh(pose);
            let weights = &pose.morph_weights[inst.node];
            for prim in &mesh.primitives {
                let verts = deform_primitive(prim, weights, &world_from_mesh, joints.as_deref());
                let material = prim.material.map_or(default_material, |m| m as u32);
                for (t, tri) in prim.triangles.iter().enumerate() {
                    let c = [
                        verts[tri[0] as usize],
                        verts[tri[1] as usize],
                        verts[tri[2] as usize],
                    ];
                    if !c.iter().all(|v| v.position.is_finite()) {
                        if self.options().sanitize {
                            dropped += 1;
                            continue;
                        }
                        return Err(SceneError::Evaluation {
                            file: self.file().to_owned(),
                            detail: format!(
                                "at t = {:.4} s, triangle {t} of mesh {}{} primitive {} (on {}) has a corner that is not \
                                 a finite number. Fix: repair the asset's vertex, skin or animation data, or pass \
                                 --sanitize to drop such triangles.",
                                pose.time,
                                inst.mesh,
                                mesh.name.as_deref().map(|n| format!(" \"{n}\"")).unwrap_or_default(),
                                prim.index_in_mesh,
                                self.node_label(inst.node)
                            ),
                        });
                    }
                    // glTF's winding is counter-clockwise for a positive
                    // determinant; under a mirroring transform the same
                    // corner order would face inward, so swap two corners.
                    let mirrored = c.iter().filter(|v| v.det < 0.0).count() >= 2;
                    let order = if mirrored { [0, 2, 1] } else { [0, 1, 2] };
                    for &k in &order {
                        let p = c[k].position;
                        soup.positions.push([p.x, p.y, p.z, 0.0]);
                    }
                    if !attributes {
                        continue;
                    }
                    if with_normals {
                        if prim.normals.is_some() {
                            for &k in &order {
                                let n = c[k].normal;
                                soup.normals.push([n.x, n.y, n.z, 0.0]);
                            }
                        } else {
                            // No normals: glTF asks for flat shading.
                            let (a, b, d) = (
                                c[order[0]].position,
                                c[order[1]].position,
                                c[order[2]].position,
                            );
                            let n = (b - a).cross(d - a).normalize_or_zero();
                            soup.normals
                                .extend(std::iter::repeat_n([n.x, n.y, n.z, 0.0], 3));
                        }
                    }
                    // The corner attributes that do not move: a primitive
                    // without one takes its neutral value.
                    if with_uvs {
                        push_corners(&mut soup.uvs, prim.uvs.as_deref(), tri, &order, [0.0; 2]);
                    }
                    if with_uvs1 {
                        push_corners(&mut soup.uvs1, prim.uvs1.as_deref(), tri, &order, [0.0; 2]);
                    }
                    if with_colors {
                        push_corners(
                            &mut soup.colors,
                            prim.colors.as_deref(),
                            tri,
                            &order,
                            [1.0; 4],
                        );
                    }
                    soup.material_ids.push(material);
                }
            }
        }
        if dropped > 0 {
            warnings.push(format!(
                "--sanitize dropped {dropped} triangle(s) with non-finite corners at t = {:.4} s",
                pose.time
            ));
        }
        Ok(soup)
    }
}
