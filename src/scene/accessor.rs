//! Reading accessors into plain arrays, with every byte range checked
//! against the buffer that actually exists. Handles strides, matrix column
//! padding, normalized integers, and sparse accessors (with or without a
//! base bufferView). Any problem becomes an error naming the file, the
//! accessor and what the accessor was being read for.

use glam::{Mat4, Vec3};
use gltf::accessor::{DataType, Dimensions};

use super::error::{Result, SceneError};
use super::source::Source;

/// A count beyond this is a broken file, not a real mesh, and must not
/// exhaust memory.
pub(crate) const MAX_ELEMENTS: usize = 1 << 28;

/// Accessors with no backing bytes (all zeros, or sparse over zeros) cost
/// memory the file does not pay for in bytes: at most this many components
/// (256 MiB as f64), far above any real sparse morph target.
const MAX_ZERO_COMPONENTS: usize = 1 << 25;

pub(crate) struct Reader<'a> {
    pub src: &'a Source,
}

fn component_size(ty: DataType) -> usize {
    match ty {
        DataType::I8 | DataType::U8 => 1,
        DataType::I16 | DataType::U16 => 2,
        DataType::U32 | DataType::F32 => 4,
    }
}

pub(crate) fn type_name(ty: DataType) -> &'static str {
    match ty {
        DataType::I8 => "BYTE",
        DataType::U8 => "UNSIGNED_BYTE",
        DataType::I16 => "SHORT",
        DataType::U16 => "UNSIGNED_SHORT",
        DataType::U32 => "UNSIGNED_INT",
        DataType::F32 => "FLOAT",
    }
}

fn dims_name(d: Dimensions) -> &'static str {
    match d {
        Dimensions::Scalar => "SCALAR",
        Dimensions::Vec2 => "VEC2",
        Dimensions::Vec3 => "VEC3",
        Dimensions::Vec4 => "VEC4",
        Dimensions::Mat2 => "MAT2",
        Dimensions::Mat3 => "MAT3",
        Dimensions::Mat4 => "MAT4",
    }
}

/// (columns, rows): vectors are one column.
fn shape(d: Dimensions) -> (usize, usize) {
    match d {
        Dimensions::Scalar => (1, 1),
        Dimensions::Vec2 => (1, 2),
        Dimensions::Vec3 => (1, 3),
        Dimensions::Vec4 => (1, 4),
        Dimensions::Mat2 => (2, 2),
        Dimensions::Mat3 => (3, 3),
        Dimensions::Mat4 => (4, 4),
    }
}

/// Value of one component, normalized to [0,1] / [-1,1] when the accessor
/// says so (glTF 2.0 §3.11 "Animations" and §3.6.2.3 give these formulas).
fn component(bytes: &[u8], ty: DataType, normalized: bool) -> f64 {
    match ty {
        DataType::I8 => {
            let v = bytes[0] as i8 as f64;
            if normalized {
                (v / 127.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U8 => {
            let v = bytes[0] as f64;
            if normalized {
                v / 255.0
            } else {
                v
            }
        }
        DataType::I16 => {
            let v = i16::from_le_bytes([bytes[0], bytes[1]]) as f64;
            if normalized {
                (v / 32767.0).max(-1.0)
            } else {
                v
            }
        }
        DataType::U16 => {
            let v = u16::from_le_bytes([bytes[0], bytes[1]]) as f64;
            if normalized {
                v / 65535.0
            } else {
                v
            }
        }
        DataType::U32 => {
            let v = u32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64;
            if normalized {
                v / 4294967295.0
            } else {
                v
            }
        }
        DataType::F32 => f32::from_le_bytes([bytes[0], bytes[1], bytes[2], bytes[3]]) as f64,
    }
}

impl Reader<'_> {
    pub fn error(
        &self,
        acc: &gltf::Accessor,
        usage: &str,
        problem: impl Into<String>,
    ) -> SceneError {
        SceneError::Accessor {
            file: self.src.file.clone(),
            accessor: acc.index(),
            name: acc.name().map(|n| format!(" \"{n}\"")).unwrap_or_default(),
            usage: usage.to_owned(),
            problem: problem.into(),
        }
    }

    /// Checks the accessor's shape against what the usage allows.
    pub fn expect(
        &self,
        acc: &gltf::Accessor,
        usage: &str,
        dims: &[Dimensions],
        types: &[DataType],
    ) -> Result<()> {
        let ok_dims = dims.contains(&acc.dimensions());
        let ok_type = types.contains(&acc.data_type());
        if ok_dims && ok_type {
            return Ok(());
        }
        let allowed = |d: &[Dimensions], t: &[DataType]| {
            format!(
                "{} of {}",
                d.iter()
                    .map(|&d| dims_name(d))
                    .collect::<Vec<_>>()
                    .join("/"),
                t.iter()
                    .map(|&t| type_name(t))
                    .collect::<Vec<_>>()
                    .join("/")
            )
        };
        Err(self.error(
            acc,
            usage,
            format!(
                "is {} {}, but this use needs {}. Fix: re-export the asset; the file does not follow the glTF 2.0 specification.",
                dims_name(acc.dimensions()),
                type_name(acc.data_type()),
                allowed(dims, types)
            ),
        ))
    }

    /// The bytes `start..start+len` of a bufferView, checked against the
    /// view's length and the buffer's real size.
    fn view_bytes(
        &self,
        acc: &gltf::Accessor,
        usage: &str,
        view: &gltf::buffer::View,
        start: usize,
        len: usize,
        what: &str,
    ) -> Result<&[u8]> {
        let end = start.saturating_add(len);
        if end > view.length() {
            return Err(self.error(
                acc,
                usage,
                format!(
                    "{what} needs bytes {start}..{end} of bufferView {}, which is only {} bytes long. \
                     Fix: re-export the asset; its accessor and bufferView sizes disagree.",
                    view.index(),
                    view.length()
                ),
            ));
        }
        let buffer = view.buffer().index();
        let data = &self.src.buffers[buffer];
        let abs_start = view.offset().saturating_add(start);
        let abs_end = view.offset().saturating_add(end);
        if abs_end > data.len() {
            let why = self.src.short_buffers[buffer].clone().unwrap_or_else(|| {
                format!(
                    "bufferView {} reaches past the end of buffer {buffer}",
                    view.index()
                )
            });
            return Err(self.error(
                acc,
                usage,
                format!(
                    "{what} needs bytes {abs_start}..{abs_end} of buffer {buffer}, which holds only {} bytes ({why}). \
                     Fix: re-export the asset or re-copy it completely.",
                    data.len()
                ),
            ));
        }
        Ok(&data[abs_start..abs_end])
    }

    /// Every component of every element as f64, in element order (matrix
    /// columns packed without their padding).
    fn decode(&self, acc: &gltf::Accessor, usage: &str) -> Result<Vec<f64>> {
        let ty = acc.data_type();
        let cs = component_size(ty);
        let (cols, rows) = shape(acc.dimensions());
        let comps = cols * rows;
        let column_bytes = if cols > 1 {
            (rows * cs + 3) & !3
        } else {
            rows * cs
        };
        let elem_size = cols * column_bytes;
        let count = acc.count();
        if count > MAX_ELEMENTS {
            return Err(self.error(
                acc,
                usage,
                format!("count {count} is implausibly large. Fix: re-export the asset."),
            ));
        }
        if acc.view().is_none() && count.saturating_mul(comps) > MAX_ZERO_COMPONENTS {
            return Err(self.error(
                acc,
                usage,
                format!(
                    "has no bufferView but {count} elements of {comps} components, more than the \
                     {MAX_ZERO_COMPONENTS} components soupray fills with zeros. Fix: re-export the asset."
                ),
            ));
        }
        let normalized = acc.normalized();
        let read_element = |bytes: &[u8], out: &mut Vec<f64>| {
            for c in 0..cols {
                for r in 0..rows {
                    let at = c * column_bytes + r * cs;
                    out.push(component(&bytes[at..at + cs], ty, normalized));
                }
            }
        };

        let mut values = Vec::with_capacity(count * comps);
        match acc.view() {
            Some(view) => {
                let stride = view.stride().unwrap_or(elem_size);
                if stride < elem_size {
                    return Err(self.error(
                        acc,
                        usage,
                        format!(
                            "bufferView {} has byteStride {stride}, smaller than one {}-byte element. Fix: re-export the asset.",
                            view.index(),
                            elem_size
                        ),
                    ));
                }
                if count > 0 {
                    let span = stride
                        .checked_mul(count - 1)
                        .and_then(|s| s.checked_add(elem_size))
                        .unwrap_or(usize::MAX);
                    let bytes =
                        self.view_bytes(acc, usage, &view, acc.offset(), span, "its data")?;
                    for i in 0..count {
                        read_element(&bytes[i * stride..i * stride + elem_size], &mut values);
                    }
                }
            }
            None => values.resize(count * comps, 0.0),
        }

        if let Some(sparse) = acc.sparse() {
            let n = sparse.count();
            if n > count {
                return Err(self.error(
                    acc,
                    usage,
                    format!("has {n} sparse substitutions but only {count} elements. Fix: re-export the asset."),
                ));
            }
            let indices = sparse.indices();
            let (index_ty, index_size) = match indices.index_type() {
                gltf::accessor::sparse::IndexType::U8 => (DataType::U8, 1),
                gltf::accessor::sparse::IndexType::U16 => (DataType::U16, 2),
                gltf::accessor::sparse::IndexType::U32 => (DataType::U32, 4),
            };
            let index_bytes = self.view_bytes(
                acc,
                usage,
                &indices.view(),
                indices.offset(),
                n * index_size,
                "its sparse indices",
            )?;
            let value_bytes = self.view_bytes(
                acc,
                usage,
                &sparse.values().view(),
                sparse.values().offset(),
                n * elem_size,
                "its sparse values",
            )?;
            let mut element = Vec::with_capacity(comps);
            for k in 0..n {
                let target = component(&index_bytes[k * index_size..], index_ty, false) as usize;
                if target >= count {
                    return Err(self.error(
                        acc,
                        usage,
                        format!(
                            "sparse index {target} (substitution {k}) is out of range: the accessor has {count} elements. \
                             Fix: re-export the asset."
                        ),
                    ));
                }
                element.clear();
                read_element(
                    &value_bytes[k * elem_size..(k + 1) * elem_size],
                    &mut element,
                );
                values[target * comps..(target + 1) * comps].copy_from_slice(&element);
            }
        }
        Ok(values)
    }

    /// Float data (normalized integers converted), `components` per element.
    pub fn floats(&self, acc: &gltf::Accessor, usage: &str) -> Result<Vec<f32>> {
        Ok(self
            .decode(acc, usage)?
            .into_iter()
            .map(|v| v as f32)
            .collect())
    }

    /// Like [`Reader::floats`] but refusing NaN and infinities.
    pub fn finite_floats(&self, acc: &gltf::Accessor, usage: &str) -> Result<Vec<f32>> {
        let values = self.floats(acc, usage)?;
        self.check_finite(acc, usage, &values)?;
        Ok(values)
    }

    pub fn check_finite(&self, acc: &gltf::Accessor, usage: &str, values: &[f32]) -> Result<()> {
        let comps = shape(acc.dimensions()).0 * shape(acc.dimensions()).1;
        if let Some(bad) = values.iter().position(|v| !v.is_finite()) {
            return Err(self.error(
                acc,
                usage,
                format!(
                    "element {} holds {} (not a finite number). Fix: repair or re-export the asset{}.",
                    bad / comps,
                    values[bad],
                    if usage.contains("POSITION") || usage.contains("NORMAL") {
                        ", or pass --sanitize to drop the triangles that use such vertices"
                    } else {
                        ""
                    }
                ),
            ));
        }
        Ok(())
    }

    pub fn vec3s(&self, acc: &gltf::Accessor, usage: &str, finite: bool) -> Result<Vec<Vec3>> {
        let flat = if finite {
            self.finite_floats(acc, usage)?
        } else {
            self.floats(acc, usage)?
        };
        Ok(flat.chunks_exact(3).map(Vec3::from_slice).collect())
    }

    pub fn mat4s(&self, acc: &gltf::Accessor, usage: &str) -> Result<Vec<Mat4>> {
        self.expect(acc, usage, &[Dimensions::Mat4], &[DataType::F32])?;
        let flat = self.finite_floats(acc, usage)?;
        Ok(flat.chunks_exact(16).map(Mat4::from_cols_slice).collect())
    }

    /// Integer data read exactly (indices, joint numbers).
    pub fn uints(&self, acc: &gltf::Accessor, usage: &str) -> Result<Vec<u32>> {
        if acc.data_type() == DataType::F32 || acc.normalized() {
            return Err(self.error(
                acc,
                usage,
                format!(
                    "is {}{}, but this use needs unnormalized integers. Fix: re-export the asset.",
                    type_name(acc.data_type()),
                    if acc.normalized() {
                        " (normalized)"
                    } else {
                        ""
                    }
                ),
            ));
        }
        Ok(self
            .decode(acc, usage)?
            .into_iter()
            .map(|v| v as u32)
            .collect())
    }
}
