//! The soup stage on the OpenCL device: a [`DeviceSoup`] evaluates each
//! frame's world-space triangle soup (morphs, skinning, rigid transforms,
//! winding fix, normals, uvs, material ids) with `kernels/soup/soup_eval.cl` and
//! leaves it in device buffers laid out exactly as `Soup` is on the host, so
//! `DeviceBuilder::build_from_device` and the tracer read it without a copy.
//!
//! Everything that does not depend on time is uploaded once per scene:
//! every instanced primitive's vertex data (positions, normals, uvs, joint
//! influences, morph deltas), the triangles' corner lists and the material
//! ids. A frame uploads only its pose, which the CPU computes with the very
//! code of the reference evaluator (`Scene::pose`, `deform::normal_matrix`):
//! per instance a rigid transform, per skin its joint matrices, per instance
//! its morph weights. The program is compiled for the scene's features only
//! (`SoupFeatures`), so a static scene runs nothing but a rigid transform.
//! The kernels mirror `scene::deform` and `Scene::evaluate` operation for
//! operation; `tests/soup_device.rs` holds them to the CPU reference.

use crate::device_struct::{device_consts, device_struct};

mod host;

use bytemuck::{Pod, Zeroable};
use glam::Mat4;
use opencl3::kernel::Kernel;
use opencl3::memory::Buffer;

use super::Soup;
use crate::device::{build_options, Arg, Device, DeviceError};
use crate::scene::deform::normal_matrix;
use crate::scene::{FrameCamera, FrameLight, MeshInstance, Pose, Scene, SceneError};
use host::HostSoup;

device_consts! {
    fn soup_consts;
    /// Marks an absent base index in [`SoupSegment`] (no skin, no morphs).
    pub const SOUP_NONE: u32 = u32::MAX;
    /// [`SoupSegment::flags`]: the primitive has NORMAL (else flat normals).
    pub const SEG_NORMALS: u32 = 1;
    /// [`SoupSegment::flags`]: the primitive has TEXCOORD_0 (else 0, 0).
    pub const SEG_UVS: u32 = 2;
    /// [`SoupSegment::flags`]: skinned by its instance's skin (else rigid).
    pub const SEG_SKINNED: u32 = 4;
    /// The primitive has the soup's second uv set (else 0, 0).
    pub const SEG_UVS1: u32 = 8;
    /// The primitive has COLOR_0 (else white).
    pub const SEG_COLORS: u32 = 16;
}

/// Work-items per work-group of both kernels; they are independent per item.
const WORK_GROUP: usize = 64;

device_struct! {
/// One primitive as placed by one mesh instance: where its static data and its
/// deformed vertices live. Static data is stored once per primitive and shared
/// by every instance of its mesh; deformed vertices are per instance. Uploaded
/// once per scene.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SoupSegment as "SoupSegment" {
    /// first vertex of the primitive in the static arrays
    pub src_vertex: u32,
    /// first deformed vertex of this instance's copy
    pub dst_vertex: u32,
    pub vertex_count: u32,
    /// index into the frame's SoupInstancePose array
    pub instance: u32,
    /// first influence record (INFLUENCE_SETS per vertex)
    pub influence_base: u32,
    /// first joint matrix (4 float4 columns each) of the skin
    pub joint_base: u32,
    /// first delta record (target_count per vertex)
    pub morph_base: u32,
    /// first morph weight of the instance in the frame's weights
    pub weight_base: u32,
    pub target_count: u32,
    /// SEG_*
    pub flags: u32,
    pub pad0: u32,
    pub pad1: u32,
}
}

device_struct! {
/// The rigid transform of one mesh instance for one frame, prepared on the
/// host by the same code as the CPU reference: the node's world matrix, the
/// matrix that carries normals (cofactor * sign(det)) and its determinant.
#[repr(C, align(16))]
#[derive(Clone, Copy, Debug, Default, PartialEq, Pod, Zeroable)]
pub struct SoupInstancePose as "SoupInstancePose" {
    /// columns
    pub world_from_mesh: [[f32; 4]; 4] as "float4",
    /// columns; w unused
    pub normal_matrix: [[f32; 4]; 3] as "float4",
    pub det: f32,
    pub pad: [u32; 3],
}
}

const _: () = assert!(std::mem::size_of::<SoupSegment>() == 48);
const _: () = assert!(std::mem::size_of::<SoupInstancePose>() == 128);

/// What the soup program is compiled for: only what the scene uses.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SoupFeatures {
    /// Some instance is skinned.
    pub skin: bool,
    /// JOINTS_n/WEIGHTS_n sets per skinned vertex (0 without skins).
    pub influence_sets: usize,
    /// The most morph targets of any instanced mesh (0: no morphing).
    pub morph_targets: usize,
    pub normals: bool,
    pub uvs: bool,
    /// The soup carries a second texture coordinate set.
    pub uvs1: bool,
    /// The soup carries vertex colours (COLOR_0).
    pub colors: bool,
    /// `--sanitize`: non-finite triangles are collapsed, not an error.
    pub sanitize: bool,
}

impl SoupFeatures {
    pub fn of(scene: &Scene) -> SoupFeatures {
        let skin = scene.has_skins();
        SoupFeatures {
            skin,
            influence_sets: if skin { scene.max_influence_sets() } else { 0 },
            morph_targets: scene.max_morph_targets(),
            normals: scene.has_normals(),
            uvs: scene.has_uvs(),
            uvs1: scene.has_uvs1(),
            colors: scene.has_colors(),
            sanitize: scene.options().sanitize,
        }
    }

    /// The program's defines, assembled here and nowhere else. Flags are
    /// present only when set, so `#ifdef` removes every unused path.
    pub fn defines(&self) -> Vec<(&'static str, String)> {
        let mut d = Vec::new();
        if self.skin {
            d.push(("HAS_SKIN", "1".to_owned()));
        }
        d.push(("INFLUENCE_SETS", self.influence_sets.to_string()));
        d.push(("MORPH_TARGETS", self.morph_targets.to_string()));
        if self.normals {
            d.push(("HAS_NORMALS", "1".to_owned()));
        }
        if self.uvs {
            d.push(("HAS_UVS", "1".to_owned()));
        }
        if self.uvs1 {
            d.push(("HAS_UVS1", "1".to_owned()));
        }
        if self.colors {
            d.push(("HAS_COLORS", "1".to_owned()));
        }
        if self.sanitize {
            d.push(("SANITIZE", "1".to_owned()));
        }
        d
    }
}

/// Why the device soup failed.
#[derive(Debug, thiserror::Error)]
pub enum SoupError {
    #[error(transparent)]
    Device(#[from] DeviceError),
    /// The scene cannot be evaluated (non-finite geometry, size limits).
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("{file}: this device soup was made for {expected} (with {triangles} triangles) and cannot evaluate another scene; make one DeviceSoup per scene")]
    WrongScene {
        file: String,
        expected: String,
        triangles: usize,
    },
}

/// What a frame's evaluation gives besides the soup left on the device.
#[derive(Debug, Clone)]
pub struct FrameInfo {
    pub time: f64,
    pub camera: FrameCamera,
    pub lights: Vec<FrameLight>,
    /// Problems of this frame that `--sanitize` turned into warnings.
    pub warnings: Vec<String>,
    /// The pose equalled the previous frame's, so the soup on the device
    /// was kept and no kernel ran.
    pub reused: bool,
    /// The pose the frame was evaluated at, for what else a frame reads of
    /// its nodes (`--focus-on`) without evaluating the animation again.
    pub pose: Pose,
}

/// A mesh instance as the per-frame pose upload sees it.
struct InstanceSlot {
    instance: MeshInstance,
    /// Index into the frame's joint matrices of its skin's first joint.
    joint_base: Option<u32>,
    /// Where its morph weights go in the frame's weight array, and how many.
    weights: Option<(u32, usize)>,
}

/// Triangles of one segment, for naming a bad triangle in messages.
struct TriangleRange {
    first: usize,
    instance: usize,
    primitive: usize,
}

struct Kernels {
    deform: Kernel,
    assemble: Kernel,
}

/// Static data, uploaded once.
struct StaticBuffers {
    segments: Buffer<SoupSegment>,
    vertex_segment: Buffer<u32>,
    triangles: Buffer<[u32; 4]>,
    base_positions: Buffer<[f32; 4]>,
    base_normals: Option<Buffer<[f32; 4]>>,
    base_uvs: Option<Buffer<[f32; 2]>>,
    base_uvs1: Option<Buffer<[f32; 2]>>,
    base_colors: Option<Buffer<[f32; 4]>>,
    position_deltas: Option<Buffer<[f32; 4]>>,
    normal_deltas: Option<Buffer<[f32; 4]>>,
    influence_joints: Option<Buffer<[u32; 4]>>,
    influence_weights: Option<Buffer<[f32; 4]>>,
}

/// The frame's pose on the device and the soup it produces.
struct FrameBuffers {
    instances: Buffer<SoupInstancePose>,
    joint_matrices: Option<Buffer<[f32; 4]>>,
    morph_weights: Option<Buffer<f32>>,
    deformed_positions: Buffer<[f32; 4]>,
    deformed_normals: Option<Buffer<[f32; 4]>>,
    status: Buffer<u32>,
    positions: Buffer<[f32; 4]>,
    normals: Option<Buffer<[f32; 4]>>,
    uvs: Option<Buffer<[f32; 2]>>,
    uvs1: Option<Buffer<[f32; 2]>>,
    colors: Option<Buffer<[f32; 4]>>,
    material_ids: Buffer<u32>,
}

/// The host side of one frame's pose upload, kept to spot unchanged poses.
#[derive(Default, PartialEq)]
struct PoseUpload {
    instances: Vec<SoupInstancePose>,
    joints: Vec<[f32; 4]>,
    weights: Vec<f32>,
}

/// A scene's soup evaluator on one device: compiled program, static data
/// and every buffer, made once and reused for every frame.
pub struct DeviceSoup<'d> {
    device: &'d Device,
    file: String,
    features: SoupFeatures,
    kernels: Kernels,
    statics: StaticBuffers,
    frame: FrameBuffers,
    instances: Vec<InstanceSlot>,
    ranges: Vec<TriangleRange>,
    joint_count: usize,
    weight_count: usize,
    vertex_count: usize,
    triangle_count: usize,
    allocations: usize,
    upload: PoseUpload,
    /// The upload the device soup currently holds, or `None` when no frame
    /// has completed (or the last one failed).
    last: Option<PoseUpload>,
    last_warnings: Vec<String>,
}

/// A count as a kernel's `uint`, or the scene is too large for the kernels.
fn as_u32(file: &str, what: &str, n: usize) -> Result<u32, SceneError> {
    u32::try_from(n).map_err(|_| SceneError::Invalid {
        file: file.to_owned(),
        detail: format!(
            "the scene has {n} {what}, more than the device soup's 32-bit indices can address. \
             Fix: render a smaller scene or split it."
        ),
    })
}

/// A device buffer of `len` elements, counted in `allocations`.
fn allocate<T>(
    device: &Device,
    len: usize,
    allocations: &mut usize,
) -> Result<Buffer<T>, DeviceError> {
    *allocations += 1;
    device.buffer(len)
}

/// `allocate` when `present`.
fn allocate_if<T>(
    present: bool,
    device: &Device,
    len: usize,
    allocations: &mut usize,
) -> Result<Option<Buffer<T>>, DeviceError> {
    present
        .then(|| allocate(device, len, allocations))
        .transpose()
}

/// A device buffer holding `data`, counted in `allocations`.
fn upload<T>(
    device: &Device,
    data: &[T],
    allocations: &mut usize,
) -> Result<Buffer<T>, DeviceError> {
    let mut b = allocate(device, data.len(), allocations)?;
    device.write(&mut b, data)?;
    Ok(b)
}

fn cols4(m: &Mat4) -> [[f32; 4]; 4] {
    m.to_cols_array_2d()
}

/// Uploads the scene's static data: the buffers the program reads, the
/// optional ones only where its features need them.
fn upload_statics(
    device: &Device,
    features: &SoupFeatures,
    host: &HostSoup,
    allocations: &mut usize,
) -> Result<StaticBuffers, DeviceError> {
    let morphs = features.morph_targets > 0;
    let mut up = |present: bool, data: &[[f32; 4]]| -> Result<_, DeviceError> {
        present
            .then(|| upload(device, data, &mut *allocations))
            .transpose()
    };
    let base_normals = up(features.normals, &host.base_normals)?;
    let position_deltas = up(morphs, &host.position_deltas)?;
    let normal_deltas = up(morphs && features.normals, &host.normal_deltas)?;
    let influence_weights = up(features.skin, &host.influence_weights)?;
    let a = allocations;
    Ok(StaticBuffers {
        segments: upload(device, &host.segments, a)?,
        vertex_segment: upload(device, &host.vertex_segment, a)?,
        triangles: upload(device, &host.triangles, a)?,
        base_positions: upload(device, &host.base_positions, a)?,
        base_normals,
        base_uvs: features
            .uvs
            .then(|| upload(device, &host.base_uvs, a))
            .transpose()?,
        base_uvs1: features
            .uvs1
            .then(|| upload(device, &host.base_uvs1, a))
            .transpose()?,
        base_colors: features
            .colors
            .then(|| upload(device, &host.base_colors, a))
            .transpose()?,
        position_deltas,
        normal_deltas,
        influence_joints: features
            .skin
            .then(|| upload(device, &host.influence_joints, a))
            .transpose()?,
        influence_weights,
    })
}

impl<'d> DeviceSoup<'d> {
    /// Compiles the soup program for `scene`'s features on `device`, uploads
    /// the scene's static data and allocates every per-frame buffer.
    pub fn new(device: &'d Device, scene: &Scene) -> Result<DeviceSoup<'d>, SoupError> {
        let file = scene.file().to_owned();
        let features = SoupFeatures::of(scene);
        let program = device.build_program("soup_eval.cl", &features.defines())?;
        let kernels = Kernels {
            deform: device.kernel(&program, "deform_vertices")?,
            assemble: device.kernel(&program, "assemble_triangles")?,
        };
        let morphs = features.morph_targets > 0;
        let host = HostSoup::build(scene, &features, &file)?;
        let (joint_count, weight_count) = (host.joint_count, host.weight_count);
        let triangle_count = host.triangles.len();
        let vertex_count = host.vertex_segment.len();
        // Corner slots 3t+k are computed in 32 bits on the device.
        as_u32(&file, "triangle corners", 3 * triangle_count)?;
        as_u32(&file, "deformed vertices", vertex_count)?;
        as_u32(&file, "joint matrix columns", 4 * joint_count)?;

        let mut allocations = 0usize;
        let statics = upload_statics(device, &features, &host, &mut allocations)?;
        let a = &mut allocations;
        // Material ids do not depend on the frame (nor on the winding), so
        // the soup's material buffer is filled here, once.
        let material_ids = upload(device, &host.material_ids, a)?;
        let frame = FrameBuffers {
            joint_matrices: allocate_if(features.skin, device, 4 * joint_count, a)?,
            morph_weights: allocate_if(morphs, device, weight_count, a)?,
            deformed_normals: allocate_if(features.normals, device, vertex_count, a)?,
            normals: allocate_if(features.normals, device, 3 * triangle_count, a)?,
            uvs: allocate_if(features.uvs, device, 3 * triangle_count, a)?,
            uvs1: allocate_if(features.uvs1, device, 3 * triangle_count, a)?,
            colors: allocate_if(features.colors, device, 3 * triangle_count, a)?,
            instances: allocate(device, host.instances.len(), a)?,
            deformed_positions: allocate(device, vertex_count, a)?,
            status: allocate(device, 2, a)?,
            positions: allocate(device, 3 * triangle_count, a)?,
            material_ids,
        };

        Ok(DeviceSoup {
            device,
            file,
            features,
            kernels,
            statics,
            frame,
            instances: host.instances,
            ranges: host.ranges,
            joint_count,
            weight_count,
            vertex_count,
            triangle_count,
            allocations,
            upload: PoseUpload::default(),
            last: None,
            last_warnings: Vec::new(),
        })
    }

    /// Evaluates the frame at `time` seconds into the device buffers and
    /// returns its camera, lights and warnings. The kernels' device time is
    /// recorded under the stage "soup" (`soup/deform`, `soup/assemble`); read
    /// it with `Device::take_timings` before the BVH build, which restarts
    /// the timings.
    pub fn evaluate(&mut self, scene: &Scene, time: f64) -> Result<FrameInfo, SoupError> {
        if scene.file() != self.file || scene.triangle_count() != self.triangle_count {
            return Err(SoupError::WrongScene {
                file: scene.file().to_owned(),
                expected: self.file.clone(),
                triangles: self.triangle_count,
            });
        }
        let pose = scene.pose(time);
        self.fill_upload(&pose);
        let reused = self.last.as_ref() == Some(&self.upload);
        let warnings = if reused {
            self.last_warnings.clone()
        } else {
            // A failed frame leaves no soup to reuse.
            let previous = self.last.take();
            let warnings = self.run(&pose, scene)?;
            // The previous upload's vectors become next frame's scratch.
            let upload = std::mem::replace(&mut self.upload, previous.unwrap_or_default());
            self.last = Some(upload);
            self.last_warnings = warnings.clone();
            warnings
        };
        Ok(FrameInfo {
            time,
            camera: scene.frame_camera(&pose)?,
            lights: scene.frame_lights(&pose),
            warnings,
            reused,
            pose,
        })
    }

    /// The frame's pose in the kernels' form, computed with the CPU
    /// reference's own functions so both start from identical numbers.
    fn fill_upload(&mut self, pose: &Pose) {
        let u = &mut self.upload;
        u.instances.clear();
        u.joints.clear();
        u.weights.clear();
        u.weights.resize(self.weight_count, 0.0);
        u.joints.resize(4 * self.joint_count, [0.0; 4]);
        for slot in &self.instances {
            let m = &slot.instance.world_from_mesh(pose);
            let (n, det) = normal_matrix(m);
            let n = n.to_cols_array_2d();
            u.instances.push(SoupInstancePose {
                world_from_mesh: cols4(m),
                normal_matrix: [
                    [n[0][0], n[0][1], n[0][2], 0.0],
                    [n[1][0], n[1][1], n[1][2], 0.0],
                    [n[2][0], n[2][1], n[2][2], 0.0],
                ],
                det,
                pad: [0; 3],
            });
            if let (Some(base), Some(joints)) =
                (slot.joint_base, slot.instance.joint_matrices(pose))
            {
                for (j, m) in joints.iter().enumerate() {
                    let at = 4 * (base as usize + j);
                    u.joints[at..at + 4].copy_from_slice(&cols4(m));
                }
            }
            if let Some((base, count)) = slot.weights {
                let w = &pose.morph_weights[slot.instance.node];
                let base = base as usize;
                let k = count.min(w.len());
                u.weights[base..base + k].copy_from_slice(&w[..k]);
            }
        }
    }

    /// Uploads the pose, runs both kernels and checks the result.
    fn run(&mut self, pose: &Pose, scene: &Scene) -> Result<Vec<String>, SoupError> {
        let d = self.device;
        let f = &mut self.frame;
        let s = &self.statics;
        d.write(&mut f.instances, &self.upload.instances)?;
        if let Some(b) = &mut f.joint_matrices {
            d.write(b, &self.upload.joints)?;
        }
        if let Some(b) = &mut f.morph_weights {
            d.write(b, &self.upload.weights)?;
        }
        d.write(&mut f.status, &[u32::MAX, 0])?;

        let mut args = vec![
            Arg::Buf(&s.segments),
            Arg::Buf(&s.vertex_segment),
            Arg::U32(self.vertex_count as u32),
            Arg::Buf(&s.base_positions),
        ];
        if let Some(b) = &s.base_normals {
            args.push(Arg::Buf(b));
        }
        if self.features.morph_targets > 0 {
            args.extend(s.position_deltas.as_ref().map(|b| Arg::Buf(b)));
            args.extend(s.normal_deltas.as_ref().map(|b| Arg::Buf(b)));
            args.extend(f.morph_weights.as_ref().map(|b| Arg::Buf(b)));
        }
        if self.features.skin {
            args.extend(s.influence_joints.as_ref().map(|b| Arg::Buf(b)));
            args.extend(s.influence_weights.as_ref().map(|b| Arg::Buf(b)));
            args.extend(f.joint_matrices.as_ref().map(|b| Arg::Buf(b)));
        }
        args.push(Arg::Buf(&f.instances));
        args.push(Arg::Buf(&f.deformed_positions));
        // The kernel always takes a normal output; without normals it is
        // never written, and the position buffer stands in.
        args.push(Arg::Buf(
            f.deformed_normals.as_ref().unwrap_or(&f.deformed_positions),
        ));
        d.launch(
            "soup/deform",
            &self.kernels.deform,
            self.vertex_count.div_ceil(WORK_GROUP),
            WORK_GROUP,
            &args,
        )?;

        let mut args = vec![
            Arg::Buf(&s.segments),
            Arg::Buf(&s.triangles),
            Arg::U32(self.triangle_count as u32),
            Arg::Buf(&f.deformed_positions),
        ];
        args.extend(f.deformed_normals.as_ref().map(|b| Arg::Buf(b)));
        args.extend(s.base_uvs.as_ref().map(|b| Arg::Buf(b)));
        args.extend(s.base_uvs1.as_ref().map(|b| Arg::Buf(b)));
        args.extend(s.base_colors.as_ref().map(|b| Arg::Buf(b)));
        args.push(Arg::Buf(&f.positions));
        args.extend(f.normals.as_ref().map(|b| Arg::Buf(b)));
        args.extend(f.uvs.as_ref().map(|b| Arg::Buf(b)));
        args.extend(f.uvs1.as_ref().map(|b| Arg::Buf(b)));
        args.extend(f.colors.as_ref().map(|b| Arg::Buf(b)));
        args.push(Arg::Buf(&f.status));
        d.launch(
            "soup/assemble",
            &self.kernels.assemble,
            self.triangle_count.div_ceil(WORK_GROUP),
            WORK_GROUP,
            &args,
        )?;

        let mut status = [0u32; 2];
        d.read(&f.status, &mut status)?;
        d.finish()?;
        let [first_bad, bad] = status;
        if bad == 0 {
            return Ok(Vec::new());
        }
        if self.features.sanitize {
            return Ok(vec![format!(
                "--sanitize collapsed {bad} triangle(s) with non-finite corners to points at t = {:.4} s \
                 (the device soup keeps every triangle)",
                pose.time
            )]);
        }
        Err(self
            .non_finite_error(scene, pose, first_bad as usize)
            .into())
    }

    /// The CPU reference's message for a triangle with a non-finite corner.
    fn non_finite_error(&self, scene: &Scene, pose: &Pose, t: usize) -> SceneError {
        let at = self
            .ranges
            .partition_point(|r| r.first <= t)
            .saturating_sub(1);
        let detail = match self.ranges.get(at) {
            Some(r) => {
                let inst = &scene.instances()[r.instance];
                let mesh = &scene.meshes()[inst.mesh];
                format!(
                    "at t = {:.4} s, triangle {} of mesh {}{} primitive {} (on {}) has a corner that is not \
                     a finite number. Fix: repair the asset's vertex, skin or animation data, or pass \
                     --sanitize to drop such triangles.",
                    pose.time,
                    t - r.first,
                    inst.mesh,
                    mesh.name.as_deref().map(|n| format!(" \"{n}\"")).unwrap_or_default(),
                    mesh.primitives[r.primitive].index_in_mesh,
                    scene.node_label(inst.node)
                )
            }
            None => format!(
                "at t = {:.4} s, triangle {t} has a corner that is not a finite number. Fix: repair the asset, \
                 or pass --sanitize.",
                pose.time
            ),
        };
        SceneError::Evaluation {
            file: self.file.clone(),
            detail,
        }
    }

    /// Corner positions, three `float4` per triangle (`w` = 0): the layout
    /// `DeviceBuilder::build_from_device` reads. Consumers only read the
    /// output buffers: an unchanged pose keeps them as they are.
    pub fn positions(&self) -> &Buffer<[f32; 4]> {
        &self.frame.positions
    }

    /// Unit shading normals, three `float4` per triangle, when the scene
    /// has normals.
    pub fn normals(&self) -> Option<&Buffer<[f32; 4]>> {
        self.frame.normals.as_ref()
    }

    /// TEXCOORD_0, three `float2` per triangle, when the scene has uvs.
    pub fn uvs(&self) -> Option<&Buffer<[f32; 2]>> {
        self.frame.uvs.as_ref()
    }

    /// The second texture coordinate set, three `float2` per triangle, when
    /// the scene has one.
    pub fn uvs1(&self) -> Option<&Buffer<[f32; 2]>> {
        self.frame.uvs1.as_ref()
    }

    /// COLOR_0, three `float4` per triangle, when the scene has vertex
    /// colours.
    pub fn colors(&self) -> Option<&Buffer<[f32; 4]>> {
        self.frame.colors.as_ref()
    }

    /// One material index per triangle, into `Scene::materials`.
    pub fn material_ids(&self) -> &Buffer<u32> {
        &self.frame.material_ids
    }

    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// Bytes of the frame's soup on the device: three corners of position
    /// and of each corner attribute the scene has, and the material ids.
    pub fn soup_bytes(&self) -> u64 {
        let f = &self.features;
        let corner =
            16 + 16 * (f.normals as u64 + f.colors as u64) + 8 * (f.uvs as u64 + f.uvs1 as u64);
        self.triangle_count as u64 * (3 * corner + 4)
    }

    /// What the program was compiled for.
    pub fn features(&self) -> &SoupFeatures {
        &self.features
    }

    /// The exact build options the program was compiled with.
    pub fn build_options(&self) -> String {
        build_options(
            &self.features.defines(),
            self.device.info.correctly_rounded_divide_sqrt,
        )
    }

    /// Device buffers allocated so far; all are made by `new`, so this never
    /// changes from frame to frame.
    pub fn allocations(&self) -> usize {
        self.allocations
    }

    /// Reads the soup of the last evaluated frame back into a host `Soup`
    /// (for tests and `soupray soup`).
    pub fn read_back(&self) -> Result<Soup, SoupError> {
        let d = self.device;
        let n = self.triangle_count;
        let f = &self.frame;
        let mut soup = Soup {
            positions: vec![[0.0; 4]; 3 * n],
            normals: Vec::new(),
            material_ids: vec![0; n],
            ..Soup::default()
        };
        d.read(&f.positions, &mut soup.positions)?;
        // An attribute the scene lacks stays empty in the soup.
        soup.normals = read_corners(d, &f.normals, n, [0.0; 4])?;
        soup.uvs = read_corners(d, &f.uvs, n, [0.0; 2])?;
        soup.uvs1 = read_corners(d, &f.uvs1, n, [0.0; 2])?;
        soup.colors = read_corners(d, &f.colors, n, [0.0; 4])?;
        d.read(&f.material_ids, &mut soup.material_ids)?;
        Ok(soup)
    }
}

/// Three corners per triangle of an attribute buffer, or nothing without one.
fn read_corners<T: Copy>(
    d: &Device,
    buffer: &Option<Buffer<T>>,
    triangles: usize,
    zero: T,
) -> Result<Vec<T>, SoupError> {
    let Some(b) = buffer else {
        return Ok(Vec::new());
    };
    let mut out = vec![zero; 3 * triangles];
    d.read(b, &mut out)?;
    Ok(out)
}
