//! Mesh primitives in bind (mesh) space, ready for the per-vertex pass:
//! topology turned into a triangle list, attributes read and checked, morph
//! target deltas, and joint influences from every JOINTS_n/WEIGHTS_n set.
//! Nothing here depends on time.

use glam::Vec3;
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;
use gltf::Semantic;

use super::accessor::Reader;
use super::error::Result;

/// One mesh of the file.
#[derive(Debug, Clone)]
pub struct Mesh {
    pub name: Option<String>,
    pub primitives: Vec<Primitive>,
    /// Number of morph targets (the same for every primitive, per spec).
    pub target_count: usize,
    /// `mesh.weights`, or zeros: the weights when neither node nor
    /// animation says otherwise.
    pub default_weights: Vec<f32>,
}

/// A triangle primitive in mesh space.
#[derive(Debug, Clone)]
pub struct Primitive {
    /// Index of the primitive inside its mesh, for messages.
    pub index_in_mesh: usize,
    pub positions: Vec<Vec3>,
    pub normals: Option<Vec<Vec3>>,
    /// TEXCOORD_0.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// The scene's second texture coordinate set (`Scene::second_uv_set`:
    /// TEXCOORD_1 unless the materials sample another), if this primitive
    /// has it; no other set is read.
    pub uvs1: Option<Vec<[f32; 2]>>,
    /// COLOR_0 as linear RGBA (alpha 1 where the accessor is RGB).
    pub colors: Option<Vec<[f32; 4]>>,
    /// Corner indices in the winding glTF defines for the source topology.
    pub triangles: Vec<[u32; 3]>,
    pub targets: Vec<MorphTarget>,
    pub influences: Option<Influences>,
    pub material: Option<usize>,
    /// Whether the file stores it compressed with KHR_draco_mesh_compression
    /// (decoded at load), for `soupray info`.
    pub draco_compressed: bool,
}

/// Per-vertex deltas of one morph target; absent attributes are all zero.
#[derive(Debug, Clone, Default)]
pub struct MorphTarget {
    pub positions: Option<Vec<Vec3>>,
    pub normals: Option<Vec<Vec3>>,
}

/// Joint influences of every vertex: `sets` groups of four (one group per
/// JOINTS_n/WEIGHTS_n pair), stored vertex-major so vertex `v`'s slots are
/// `v*4*sets .. (v+1)*4*sets`. Weights are renormalised to sum to one over
/// all sets together.
#[derive(Debug, Clone)]
pub struct Influences {
    pub sets: usize,
    pub joints: Vec<u32>,
    pub weights: Vec<f32>,
}

impl Influences {
    pub fn slots_per_vertex(&self) -> usize {
        4 * self.sets
    }

    /// The (joint, weight) slots of vertex `v`.
    pub fn of_vertex(&self, v: usize) -> (&[u32], &[f32]) {
        let n = self.slots_per_vertex();
        (
            &self.joints[v * n..(v + 1) * n],
            &self.weights[v * n..(v + 1) * n],
        )
    }
}

impl Primitive {
    pub fn vertex_count(&self) -> usize {
        self.positions.len()
    }
}

pub(crate) fn mode_name(mode: Mode) -> &'static str {
    match mode {
        Mode::Points => "POINTS",
        Mode::Lines => "LINES",
        Mode::LineLoop => "LINE_LOOP",
        Mode::LineStrip => "LINE_STRIP",
        Mode::Triangles => "TRIANGLES",
        Mode::TriangleStrip => "TRIANGLE_STRIP",
        Mode::TriangleFan => "TRIANGLE_FAN",
    }
}

/// Triangles of a triangle-based topology, by the formulas of glTF 2.0
/// §3.7.2.1 (strips alternate winding; fans pivot on the first vertex).
pub fn assemble_triangles(mode: Mode, indices: &[u32]) -> Vec<[u32; 3]> {
    let n = indices.len();
    match mode {
        Mode::Triangles => indices
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect(),
        Mode::TriangleStrip if n >= 3 => (0..n - 2)
            .map(|i| {
                let odd = i % 2;
                [indices[i], indices[i + 1 + odd], indices[i + 2 - odd]]
            })
            .collect(),
        Mode::TriangleFan if n >= 3 => (0..n - 2)
            .map(|i| [indices[i + 1], indices[i + 2], indices[0]])
            .collect(),
        _ => Vec::new(),
    }
}

/// What the loader did not turn into triangles, so it can warn once.
#[derive(Default)]
pub(crate) struct Skipped {
    pub by_mode: Vec<(&'static str, String)>,
}

pub(crate) fn load_mesh(
    reader: &Reader,
    mesh: &gltf::Mesh,
    sanitize: bool,
    second_uv_set: Option<u32>,
    skipped: &mut Skipped,
    warnings: &mut Vec<String>,
) -> Result<Mesh> {
    let file = &reader.src.file;
    let label = match mesh.name() {
        Some(n) => format!("mesh {} \"{n}\"", mesh.index()),
        None => format!("mesh {}", mesh.index()),
    };
    let mut primitives = Vec::new();
    let mut target_count = None;
    for prim in mesh.primitives() {
        let where_ = format!("{label} primitive {}", prim.index());
        let targets = prim.morph_targets().count();
        match target_count {
            None => target_count = Some(targets),
            Some(t) if t != targets => {
                return Err(super::error::SceneError::invalid(
                    file,
                    format!(
                        "{where_} has {targets} morph targets but an earlier primitive of the mesh has {t}; \
                         glTF requires the same count in every primitive. Fix: re-export the mesh."
                    ),
                ))
            }
            _ => {}
        }
        match prim.mode() {
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan => {}
            other => {
                skipped.by_mode.push((mode_name(other), where_));
                continue;
            }
        }
        match load_primitive(reader, &prim, &where_, sanitize, second_uv_set, warnings)? {
            Some(mut p) => {
                p.draco_compressed =
                    super::draco::is_draco_primitive(&reader.src.json, mesh.index(), prim.index());
                primitives.push(p)
            }
            None => warnings.push(format!(
                "{where_} has no POSITION attribute and is skipped, as glTF 2.0 §3.7.2.1 allows"
            )),
        }
    }
    let target_count = target_count.unwrap_or(0);
    let default_weights = match mesh.weights() {
        Some(w) if w.len() == target_count => w.to_vec(),
        Some(w) => {
            return Err(super::error::SceneError::invalid(
                file,
                format!(
                    "{label} has {} default weights but {target_count} morph targets. Fix: re-export the mesh.",
                    w.len()
                ),
            ))
        }
        None => vec![0.0; target_count],
    };
    Ok(Mesh {
        name: mesh.name().map(str::to_owned),
        primitives,
        target_count,
        default_weights,
    })
}

fn load_primitive(
    reader: &Reader,
    prim: &gltf::Primitive,
    where_: &str,
    sanitize: bool,
    second_uv_set: Option<u32>,
    warnings: &mut Vec<String>,
) -> Result<Option<Primitive>> {
    let Some(pos_acc) = prim.get(&Semantic::Positions) else {
        return Ok(None);
    };
    let usage = |attr: &str| format!("{attr} of {where_}");
    let quantized = reader.src.uses_extension(QUANTIZATION);
    expect_vertex(
        reader,
        &pos_acc,
        &usage("POSITION"),
        Dimensions::Vec3,
        Attribute::Position,
        quantized,
    )?;
    let positions = reader.vec3s(&pos_acc, &usage("POSITION"), !sanitize)?;
    let vertex_count = positions.len();
    let attrs = PrimitiveReader {
        reader,
        prim,
        where_,
        sanitize,
        quantized,
        position_accessor: pos_acc.index(),
        vertex_count,
    };

    let normals = attrs.normals()?;
    let uvs = attrs.uv_set(0)?;
    let uvs1 = match second_uv_set {
        Some(set) => attrs.uv_set(set)?,
        None => None,
    };
    let colors = attrs.colors()?;
    let indices = attrs.indices()?;
    if prim.mode() == Mode::Triangles && !indices.len().is_multiple_of(3) {
        warnings.push(format!(
            "{where_} has {} indices, not a multiple of 3; the last {} are ignored",
            indices.len(),
            indices.len() % 3
        ));
    }
    let triangles = assemble_triangles(prim.mode(), &indices);
    let targets = attrs.morph_targets()?;
    let influences = load_influences(reader, prim, where_, vertex_count, warnings)?;

    Ok(Some(Primitive {
        index_in_mesh: prim.index(),
        positions,
        normals,
        uvs,
        uvs1,
        colors,
        triangles,
        targets,
        influences,
        material: prim.material().index(),
        draco_compressed: false,
    }))
}

/// Reads one primitive's attributes other than POSITION, each checked to
/// have one element per vertex.
struct PrimitiveReader<'a> {
    reader: &'a Reader<'a>,
    prim: &'a gltf::Primitive<'a>,
    /// The primitive, as errors and warnings name it.
    where_: &'a str,
    sanitize: bool,
    /// KHR_mesh_quantization is in use: integer attributes are allowed.
    quantized: bool,
    position_accessor: usize,
    vertex_count: usize,
}

impl PrimitiveReader<'_> {
    fn usage(&self, attr: &str) -> String {
        format!("{attr} of {}", self.where_)
    }

    fn same_count(&self, acc: &gltf::Accessor, attr: &str) -> Result<()> {
        let vertex_count = self.vertex_count;
        if acc.count() != vertex_count {
            return Err(self.reader.error(
                acc,
                &self.usage(attr),
                format!(
                    "has {} elements but POSITION (accessor {}) has {vertex_count}; every attribute of a \
                     primitive needs one element per vertex. Fix: re-export the mesh.",
                    acc.count(),
                    self.position_accessor
                ),
            ));
        }
        Ok(())
    }

    fn normals(&self) -> Result<Option<Vec<Vec3>>> {
        let (reader, quantized, sanitize) = (self.reader, self.quantized, self.sanitize);
        Ok(match self.prim.get(&Semantic::Normals) {
            Some(acc) => {
                expect_vertex(
                    reader,
                    &acc,
                    &self.usage("NORMAL"),
                    Dimensions::Vec3,
                    Attribute::Normal,
                    quantized,
                )?;
                self.same_count(&acc, "NORMAL")?;
                Some(reader.vec3s(&acc, &self.usage("NORMAL"), !sanitize)?)
            }
            None => None,
        })
    }

    fn uv_set(&self, set: u32) -> Result<Option<Vec<[f32; 2]>>> {
        let reader = self.reader;
        let Some(acc) = self.prim.get(&Semantic::TexCoords(set)) else {
            return Ok(None);
        };
        let attr = format!("TEXCOORD_{set}");
        expect_vertex(
            reader,
            &acc,
            &self.usage(&attr),
            Dimensions::Vec2,
            Attribute::TexCoord,
            self.quantized,
        )?;
        self.same_count(&acc, &attr)?;
        let flat = reader.floats(&acc, &self.usage(&attr))?;
        if !self.sanitize {
            reader.check_finite(&acc, &self.usage(&attr), &flat)?;
        }
        Ok(Some(flat.chunks_exact(2).map(|c| [c[0], c[1]]).collect()))
    }

    /// COLOR_0 multiplies the base colour (glTF 2.0 §3.9.2): RGB or RGBA,
    /// float or normalized unsigned bytes and shorts.
    fn colors(&self) -> Result<Option<Vec<[f32; 4]>>> {
        let reader = self.reader;
        let usage = |attr: &str| self.usage(attr);
        let sanitize = self.sanitize;
        Ok(match self.prim.get(&Semantic::Colors(0)) {
            Some(acc) => {
                reader.expect(
                    &acc,
                    &usage("COLOR_0"),
                    &[Dimensions::Vec3, Dimensions::Vec4],
                    &[DataType::F32, DataType::U8, DataType::U16],
                )?;
                self.same_count(&acc, "COLOR_0")?;
                let flat = reader.floats(&acc, &usage("COLOR_0"))?;
                if !sanitize {
                    reader.check_finite(&acc, &usage("COLOR_0"), &flat)?;
                }
                let width = if acc.dimensions() == Dimensions::Vec3 {
                    3
                } else {
                    4
                };
                Some(
                    flat.chunks_exact(width)
                        .map(|c| [c[0], c[1], c[2], if width == 4 { c[3] } else { 1.0 }])
                        .collect(),
                )
            }
            None => None,
        })
    }

    /// The primitive's indices (0..vertex_count without an accessor), each
    /// naming a vertex.
    fn indices(&self) -> Result<Vec<u32>> {
        let (reader, where_, vertex_count) = (self.reader, self.where_, self.vertex_count);
        Ok(match self.prim.indices() {
            Some(acc) => {
                let what = format!("indices of {where_}");
                reader.expect(
                    &acc,
                    &what,
                    &[Dimensions::Scalar],
                    &[DataType::U8, DataType::U16, DataType::U32],
                )?;
                let indices = reader.uints(&acc, &what)?;
                if let Some(at) = indices.iter().position(|&i| i as usize >= vertex_count) {
                    return Err(reader.error(
                    &acc,
                    &what,
                    format!(
                        "index {} at position {at} is out of range: the primitive has {vertex_count} vertices \
                         (POSITION accessor {}). Fix: re-export the mesh; its index buffer does not match its \
                         vertex data.",
                        indices[at],
                        self.position_accessor
                    ),
                ));
                }
                indices
            }
            None => (0..vertex_count as u32).collect(),
        })
    }

    /// The morph targets' POSITION and NORMAL deltas.
    fn morph_targets(&self) -> Result<Vec<MorphTarget>> {
        let reader = self.reader;
        let usage = |attr: &str| self.usage(attr);
        let (quantized, sanitize) = (self.quantized, self.sanitize);
        let mut targets = Vec::new();
        for (t, target) in self.prim.morph_targets().enumerate() {
            let mut loaded = MorphTarget::default();
            for (acc, attr, kind, slot) in [
                (
                    target.positions(),
                    "POSITION",
                    Attribute::PositionDelta,
                    &mut loaded.positions,
                ),
                (
                    target.normals(),
                    "NORMAL",
                    Attribute::Normal,
                    &mut loaded.normals,
                ),
            ] {
                if let Some(acc) = acc {
                    let what = format!("morph target {t} {attr}");
                    expect_vertex(
                        reader,
                        &acc,
                        &usage(&what),
                        Dimensions::Vec3,
                        kind,
                        quantized,
                    )?;
                    self.same_count(&acc, &what)?;
                    *slot = Some(reader.vec3s(&acc, &usage(&what), !sanitize)?);
                }
            }
            targets.push(loaded);
        }
        Ok(targets)
    }
}

/// The extension that lets vertex attributes be stored as (normalized)
/// integers, the node transform carrying the dequantization.
pub(crate) const QUANTIZATION: &str = "KHR_mesh_quantization";

/// Which row of the component-type tables an attribute reads from.
#[derive(Clone, Copy, PartialEq)]
enum Attribute {
    Position,
    /// A morph target's POSITION delta (signed types only: a delta has a sign).
    PositionDelta,
    /// NORMAL of the base mesh or of a morph target: unit vectors, so
    /// integers must be normalized.
    Normal,
    TexCoord,
}

/// Checks an attribute's type and component type against glTF 2.0
/// §3.7.2.1 and, when the file uses KHR_mesh_quantization, that
/// extension's table of additional types.
fn expect_vertex(
    reader: &Reader,
    acc: &gltf::Accessor,
    usage: &str,
    dims: Dimensions,
    attribute: Attribute,
    quantized: bool,
) -> Result<()> {
    use DataType::{F32, I16, I8, U16, U8};
    let core: &[DataType] = match attribute {
        Attribute::TexCoord => &[F32, U8, U16],
        _ => &[F32],
    };
    let widened: &[DataType] = match attribute {
        Attribute::Position | Attribute::TexCoord => &[F32, I8, U8, I16, U16],
        Attribute::PositionDelta => &[F32, I8, I16],
        Attribute::Normal => &[F32, I8, I16],
    };
    let ty = acc.data_type();
    if !quantized && !core.contains(&ty) && widened.contains(&ty) {
        return Err(reader.error(
            acc,
            usage,
            format!(
                "is stored as integers ({}), which glTF 2.0 allows only with the extension                  {QUANTIZATION}, and the file does not list it in extensionsUsed. Fix: add                  \"{QUANTIZATION}\" to extensionsUsed and extensionsRequired, or re-export the asset                  with float attributes.",
                super::accessor::type_name(ty)
            ),
        ));
    }
    reader.expect(acc, usage, &[dims], if quantized { widened } else { core })?;
    let needs_normalized = match attribute {
        Attribute::Normal => ty != F32,
        // Core glTF's integer texture coordinates are fractions; the
        // extension adds unnormalized ones scaled by KHR_texture_transform.
        Attribute::TexCoord => !quantized && ty != F32,
        Attribute::Position | Attribute::PositionDelta => false,
    };
    if needs_normalized && !acc.normalized() {
        return Err(reader.error(
            acc,
            usage,
            format!(
                "is {} without normalized: true; this attribute allows integers only as normalized                  fractions. Fix: re-export the asset.",
                super::accessor::type_name(ty)
            ),
        ));
    }
    Ok(())
}

fn load_influences(
    reader: &Reader,
    prim: &gltf::Primitive,
    where_: &str,
    vertex_count: usize,
    warnings: &mut Vec<String>,
) -> Result<Option<Influences>> {
    let mut sets = Vec::new();
    loop {
        let n = sets.len() as u32;
        let (joints, weights) = (
            prim.get(&Semantic::Joints(n)),
            prim.get(&Semantic::Weights(n)),
        );
        let (joints, weights) = match (joints, weights) {
            (Some(j), Some(w)) => (j, w),
            (None, None) => break,
            (j, _) => {
                let missing = if j.is_some() { "WEIGHTS" } else { "JOINTS" };
                return Err(super::error::SceneError::invalid(
                    &reader.src.file,
                    format!(
                        "{where_} has {}_{n} without {missing}_{n}; skinning needs both. Fix: re-export the skinned mesh.",
                        if j.is_some() { "JOINTS" } else { "WEIGHTS" }
                    ),
                ));
            }
        };
        let j_usage = format!("JOINTS_{n} of {where_}");
        let w_usage = format!("WEIGHTS_{n} of {where_}");
        reader.expect(
            &joints,
            &j_usage,
            &[Dimensions::Vec4],
            &[DataType::U8, DataType::U16],
        )?;
        reader.expect(
            &weights,
            &w_usage,
            &[Dimensions::Vec4],
            &[DataType::F32, DataType::U8, DataType::U16],
        )?;
        for (acc, what) in [(&joints, &j_usage), (&weights, &w_usage)] {
            if acc.count() != vertex_count {
                return Err(reader.error(
                    acc,
                    what,
                    format!(
                        "has {} elements but the primitive has {vertex_count} vertices. Fix: re-export the skinned mesh.",
                        acc.count()
                    ),
                ));
            }
        }
        let j = reader.uints(&joints, &j_usage)?;
        let w = reader.finite_floats(&weights, &w_usage)?;
        if let Some(at) = w.iter().position(|&x| x < 0.0) {
            return Err(reader.error(
                &weights,
                &w_usage,
                format!(
                    "element {} holds a negative weight {}. Fix: re-export the skinned mesh.",
                    at / 4,
                    w[at]
                ),
            ));
        }
        sets.push((j, w));
    }
    if sets.is_empty() {
        return Ok(None);
    }
    let per_vertex = 4 * sets.len();
    let mut joints = Vec::with_capacity(vertex_count * per_vertex);
    let mut weights = Vec::with_capacity(vertex_count * per_vertex);
    let mut unweighted = 0usize;
    for v in 0..vertex_count {
        let start = weights.len();
        for (j, w) in &sets {
            joints.extend_from_slice(&j[4 * v..4 * v + 4]);
            weights.extend_from_slice(&w[4 * v..4 * v + 4]);
        }
        // Quantized weights rarely sum to exactly one; the spec asks for the
        // sum to be one, so divide by it rather than trusting the file.
        let sum: f64 = weights[start..].iter().map(|&x| x as f64).sum();
        if sum > 0.0 {
            for x in &mut weights[start..] {
                *x = (*x as f64 / sum) as f32;
            }
        } else {
            // A vertex with no weight would collapse to the origin; bind it
            // rigidly to its first listed joint instead.
            unweighted += 1;
            weights[start] = 1.0;
        }
    }
    if unweighted > 0 {
        warnings.push(format!(
            "{where_}: {unweighted} vertices have all skin weights zero; each is bound fully to its first listed joint"
        ));
    }
    Ok(Some(Influences {
        sets: sets.len(),
        joints,
        weights,
    }))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strip_alternates_winding_per_spec() {
        let t = assemble_triangles(Mode::TriangleStrip, &[0, 1, 2, 3, 4]);
        assert_eq!(t, vec![[0, 1, 2], [1, 3, 2], [2, 3, 4]]);
    }

    #[test]
    fn fan_pivots_on_first_vertex_per_spec() {
        let t = assemble_triangles(Mode::TriangleFan, &[0, 1, 2, 3]);
        assert_eq!(t, vec![[1, 2, 0], [2, 3, 0]]);
    }
}
