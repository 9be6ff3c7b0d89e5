//! PLY triangle soups in and out.
//!
//! Reading accepts ASCII and binary (either endianness) PLY with a `vertex`
//! element holding `x y z` of any scalar type and a `face` element with one
//! list property of vertex indices. Every face must be a triangle: soupray
//! takes triangle soups, and silently triangulating polygons would change the
//! primitive count the build logs report. Writing produces the binary
//! little-endian form `soupray soup` promises: `float x y z`, faces as
//! `list uchar uint`, three unshared vertices per triangle.

use crate::soup::Soup;
use std::io::{BufRead, BufReader, Read as _};
use std::path::{Path, PathBuf};

/// Why a PLY file could not be read. Every message names the file.
#[derive(Debug, thiserror::Error)]
pub enum PlyError {
    #[error("{path}: cannot read: {cause}")]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("{path}: not a PLY file (it does not start with the line `ply`)")]
    NotPly { path: PathBuf },
    #[error("{path}: bad header: {what}")]
    Header { path: PathBuf, what: String },
    #[error("{path}: {element} {index}: {what}")]
    Element {
        path: PathBuf,
        element: &'static str,
        index: usize,
        what: String,
    },
    #[error("{path}: the file ends early, inside {element} {index} (truncated?)")]
    Truncated {
        path: PathBuf,
        element: &'static str,
        index: usize,
    },
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Format {
    Ascii,
    BinaryLe,
    BinaryBe,
}

#[derive(Clone, Copy, Debug, PartialEq)]
enum Scalar {
    I8,
    U8,
    I16,
    U16,
    I32,
    U32,
    F32,
    F64,
}

impl Scalar {
    fn parse(name: &str) -> Option<Scalar> {
        Some(match name {
            "char" | "int8" => Scalar::I8,
            "uchar" | "uint8" => Scalar::U8,
            "short" | "int16" => Scalar::I16,
            "ushort" | "uint16" => Scalar::U16,
            "int" | "int32" => Scalar::I32,
            "uint" | "uint32" => Scalar::U32,
            "float" | "float32" => Scalar::F32,
            "double" | "float64" => Scalar::F64,
            _ => return None,
        })
    }

    fn size(self) -> usize {
        match self {
            Scalar::I8 | Scalar::U8 => 1,
            Scalar::I16 | Scalar::U16 => 2,
            Scalar::I32 | Scalar::U32 | Scalar::F32 => 4,
            Scalar::F64 => 8,
        }
    }
}

#[derive(Clone, Debug)]
enum Property {
    Scalar { name: String, ty: Scalar },
    List { count: Scalar, item: Scalar },
}

#[derive(Clone, Debug)]
struct Element {
    name: String,
    count: usize,
    properties: Vec<Property>,
}

/// Reads a PLY triangle mesh into a soup (positions only).
pub fn read_soup(path: &Path) -> Result<Soup, PlyError> {
    // A regular file only (a FIFO would block, a device never end), read
    // no further than its size.
    let (file, size) = crate::input::open_regular(path).map_err(|cause| PlyError::Io {
        path: path.to_owned(),
        cause,
    })?;
    let mut reader = BufReader::new(file.take(size));
    let (format, elements) = read_header(path, &mut reader)?;
    let mut body = Body {
        path,
        format,
        reader,
        line: Vec::new(),
        tokens: Vec::new(),
        token_at: 0,
    };

    let mut vertices: Vec<[f32; 3]> = Vec::new();
    let mut triangles: Vec<[u32; 3]> = Vec::new();
    for element in &elements {
        match element.name.as_str() {
            "vertex" => vertices = body.read_vertices(element)?,
            "face" => triangles = body.read_faces(element)?,
            _ => body.skip_element(element)?,
        }
    }
    if !elements.iter().any(|e| e.name == "vertex") {
        return Err(header_error(path, "no `vertex` element"));
    }
    if !elements.iter().any(|e| e.name == "face") {
        return Err(header_error(
            path,
            "no `face` element: a point cloud is not a triangle soup",
        ));
    }

    let mut positions = Vec::with_capacity(triangles.len() * 3);
    for (face, tri) in triangles.iter().enumerate() {
        for &v in tri {
            let p = vertices.get(v as usize).ok_or_else(|| PlyError::Element {
                path: path.to_owned(),
                element: "face",
                index: face,
                what: format!(
                    "vertex index {v} is out of range (the file has {} vertices)",
                    vertices.len()
                ),
            })?;
            positions.push([p[0], p[1], p[2], 0.0]);
        }
    }
    Ok(Soup {
        positions,
        ..Soup::default()
    })
}

fn header_error(path: &Path, what: impl Into<String>) -> PlyError {
    PlyError::Header {
        path: path.to_owned(),
        what: what.into(),
    }
}

fn read_header(path: &Path, reader: &mut impl BufRead) -> Result<(Format, Vec<Element>), PlyError> {
    let io = |cause| PlyError::Io {
        path: path.to_owned(),
        cause,
    };
    let mut line = String::new();
    let mut next_line = |line: &mut String| -> Result<bool, PlyError> {
        line.clear();
        let mut raw = Vec::new();
        let n = reader.read_until(b'\n', &mut raw).map_err(io)?;
        *line = String::from_utf8_lossy(&raw).trim().to_owned();
        Ok(n > 0)
    };
    if !next_line(&mut line)? || line != "ply" {
        return Err(PlyError::NotPly {
            path: path.to_owned(),
        });
    }
    let mut format = None;
    let mut elements: Vec<Element> = Vec::new();
    loop {
        if !next_line(&mut line)? {
            return Err(header_error(path, "no `end_header` line"));
        }
        let words: Vec<&str> = line.split_whitespace().collect();
        match words.as_slice() {
            ["end_header"] => break,
            ["comment", ..] | ["obj_info", ..] | [] => {}
            ["format", kind, _version] => {
                format = Some(match *kind {
                    "ascii" => Format::Ascii,
                    "binary_little_endian" => Format::BinaryLe,
                    "binary_big_endian" => Format::BinaryBe,
                    other => return Err(header_error(path, format!("unknown format `{other}`"))),
                })
            }
            ["element", name, count] => {
                let count = count.parse().map_err(|_| {
                    header_error(path, format!("element `{name}` has a bad count `{count}`"))
                })?;
                elements.push(Element {
                    name: name.to_string(),
                    count,
                    properties: Vec::new(),
                });
            }
            ["property", "list", count, item, name] => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| header_error(path, "a property before any element"))?;
                let (Some(count), Some(item)) = (Scalar::parse(count), Scalar::parse(item)) else {
                    return Err(header_error(
                        path,
                        format!("property list `{name}` has an unknown type"),
                    ));
                };
                element.properties.push(Property::List { count, item });
            }
            ["property", ty, name] => {
                let element = elements
                    .last_mut()
                    .ok_or_else(|| header_error(path, "a property before any element"))?;
                let ty = Scalar::parse(ty).ok_or_else(|| {
                    header_error(path, format!("property `{name}` has unknown type `{ty}`"))
                })?;
                element.properties.push(Property::Scalar {
                    name: name.to_string(),
                    ty,
                });
            }
            _ => return Err(header_error(path, format!("unexpected line `{line}`"))),
        }
    }
    let format = format.ok_or_else(|| header_error(path, "no `format` line"))?;
    Ok((format, elements))
}

struct Body<'a, R> {
    path: &'a Path,
    format: Format,
    reader: R,
    line: Vec<u8>,
    tokens: Vec<String>,
    token_at: usize,
}

impl<R: BufRead> Body<'_, R> {
    fn read_vertices(&mut self, element: &Element) -> Result<Vec<[f32; 3]>, PlyError> {
        let mut axis_of = Vec::with_capacity(element.properties.len());
        for p in &element.properties {
            axis_of.push(match p {
                Property::Scalar { name, .. } => match name.as_str() {
                    "x" => Some(0),
                    "y" => Some(1),
                    "z" => Some(2),
                    _ => None,
                },
                Property::List { .. } => None,
            });
        }
        for axis in 0..3 {
            if !axis_of.contains(&Some(axis)) {
                return Err(header_error(
                    self.path,
                    format!(
                        "element `vertex` has no `{}` property",
                        ["x", "y", "z"][axis]
                    ),
                ));
            }
        }
        let mut out = Vec::with_capacity(element.count.min(1 << 26));
        for index in 0..element.count {
            self.start_record("vertex", index)?;
            let mut p = [0.0f32; 3];
            for (prop, axis) in element.properties.iter().zip(&axis_of) {
                match prop {
                    Property::Scalar { ty, .. } => {
                        let v = self.scalar(*ty, "vertex", index)?;
                        if let Some(a) = axis {
                            p[*a] = v as f32;
                        }
                    }
                    Property::List { count, item, .. } => {
                        self.skip_list(*count, *item, "vertex", index)?
                    }
                }
            }
            if !p.iter().all(|c| c.is_finite()) {
                return Err(PlyError::Element {
                    path: self.path.to_owned(),
                    element: "vertex",
                    index,
                    what: format!(
                        "coordinates ({}, {}, {}) are not finite; remove or repair that vertex",
                        p[0], p[1], p[2]
                    ),
                });
            }
            out.push(p);
        }
        Ok(out)
    }

    fn read_faces(&mut self, element: &Element) -> Result<Vec<[u32; 3]>, PlyError> {
        let lists = element
            .properties
            .iter()
            .filter(|p| matches!(p, Property::List { .. }))
            .count();
        if lists != 1 {
            return Err(header_error(
                self.path,
                format!("element `face` needs exactly one list property (vertex_indices), it has {lists}"),
            ));
        }
        let mut out = Vec::with_capacity(element.count.min(1 << 26));
        for index in 0..element.count {
            self.start_record("face", index)?;
            let mut tri = [0u32; 3];
            for prop in &element.properties {
                match prop {
                    Property::Scalar { ty, .. } => {
                        self.scalar(*ty, "face", index)?;
                    }
                    Property::List { count, item, .. } => {
                        let n = self.scalar(*count, "face", index)?;
                        if n != 3.0 {
                            return Err(PlyError::Element {
                                path: self.path.to_owned(),
                                element: "face",
                                index,
                                what: format!(
                                    "has {n} vertices; soupray reads triangle soups only \
                                     (triangulate the mesh first, e.g. in Blender)"
                                ),
                            });
                        }
                        for corner in &mut tri {
                            let v = self.scalar(*item, "face", index)?;
                            if v < 0.0 || v > u32::MAX as f64 || v.fract() != 0.0 {
                                return Err(PlyError::Element {
                                    path: self.path.to_owned(),
                                    element: "face",
                                    index,
                                    what: format!("vertex index {v} is not a valid index"),
                                });
                            }
                            *corner = v as u32;
                        }
                    }
                }
            }
            out.push(tri);
        }
        Ok(out)
    }

    fn skip_element(&mut self, element: &Element) -> Result<(), PlyError> {
        for index in 0..element.count {
            self.start_record("element", index)?;
            for prop in &element.properties {
                match prop {
                    Property::Scalar { ty, .. } => {
                        self.scalar(*ty, "element", index)?;
                    }
                    Property::List { count, item, .. } => {
                        self.skip_list(*count, *item, "element", index)?
                    }
                }
            }
        }
        Ok(())
    }

    fn skip_list(
        &mut self,
        count: Scalar,
        item: Scalar,
        element: &'static str,
        index: usize,
    ) -> Result<(), PlyError> {
        let n = self.scalar(count, element, index)?;
        if !(0.0..=1e9).contains(&n) {
            return Err(PlyError::Element {
                path: self.path.to_owned(),
                element,
                index,
                what: format!("list length {n} is invalid"),
            });
        }
        for _ in 0..n as usize {
            self.scalar(item, element, index)?;
        }
        Ok(())
    }

    /// ASCII records are one per line; binary records need no framing.
    fn start_record(&mut self, element: &'static str, index: usize) -> Result<(), PlyError> {
        if self.format != Format::Ascii {
            return Ok(());
        }
        loop {
            self.line.clear();
            let n = self
                .reader
                .read_until(b'\n', &mut self.line)
                .map_err(|cause| PlyError::Io {
                    path: self.path.to_owned(),
                    cause,
                })?;
            if n == 0 {
                return Err(PlyError::Truncated {
                    path: self.path.to_owned(),
                    element,
                    index,
                });
            }
            let text = String::from_utf8_lossy(&self.line);
            self.tokens = text.split_whitespace().map(str::to_owned).collect();
            self.token_at = 0;
            if !self.tokens.is_empty() {
                return Ok(());
            }
        }
    }

    fn scalar(&mut self, ty: Scalar, element: &'static str, index: usize) -> Result<f64, PlyError> {
        if self.format == Format::Ascii {
            let token = self
                .tokens
                .get(self.token_at)
                .ok_or_else(|| PlyError::Element {
                    path: self.path.to_owned(),
                    element,
                    index,
                    what: "the line has too few values".into(),
                })?;
            self.token_at += 1;
            return token.parse::<f64>().map_err(|_| PlyError::Element {
                path: self.path.to_owned(),
                element,
                index,
                what: format!("`{token}` is not a number"),
            });
        }
        let mut buf = [0u8; 8];
        let bytes = &mut buf[..ty.size()];
        self.reader.read_exact(bytes).map_err(|e| {
            if e.kind() == std::io::ErrorKind::UnexpectedEof {
                PlyError::Truncated {
                    path: self.path.to_owned(),
                    element,
                    index,
                }
            } else {
                PlyError::Io {
                    path: self.path.to_owned(),
                    cause: e,
                }
            }
        })?;
        if self.format == Format::BinaryBe {
            bytes.reverse();
        }
        Ok(match ty {
            Scalar::I8 => bytes[0] as i8 as f64,
            Scalar::U8 => bytes[0] as f64,
            Scalar::I16 => i16::from_le_bytes([bytes[0], bytes[1]]) as f64,
            Scalar::U16 => u16::from_le_bytes([bytes[0], bytes[1]]) as f64,
            Scalar::I32 => i32::from_le_bytes(bytes[..4].try_into().unwrap()) as f64,
            Scalar::U32 => u32::from_le_bytes(bytes[..4].try_into().unwrap()) as f64,
            Scalar::F32 => f32::from_le_bytes(bytes[..4].try_into().unwrap()) as f64,
            Scalar::F64 => f64::from_le_bytes(buf),
        })
    }
}

/// Writes a soup as binary little-endian PLY, three unshared vertices per
/// triangle, atomically (`output::write_atomic`).
pub fn write_soup(path: &Path, soup: &Soup) -> Result<(), crate::output::OutputError> {
    crate::output::write_atomic(path, |out| {
        write_soup_to(out, soup).map_err(crate::output::io_err(path, "write"))
    })
}

/// The binary PLY of `soup` into any writer (`soupray soup -o -`: stdout).
pub fn write_soup_to(out: &mut impl std::io::Write, soup: &Soup) -> std::io::Result<()> {
    {
        let tris = soup.triangle_count();
        let mut body = || -> std::io::Result<()> {
            write!(
                out,
                "ply\nformat binary_little_endian 1.0\ncomment written by soupray {}\n\
                 element vertex {}\nproperty float x\nproperty float y\nproperty float z\n\
                 element face {}\nproperty list uchar uint vertex_indices\nend_header\n",
                env!("CARGO_PKG_VERSION"),
                tris * 3,
                tris
            )?;
            for p in &soup.positions {
                for c in &p[..3] {
                    out.write_all(&c.to_le_bytes())?;
                }
            }
            for t in 0..tris as u32 {
                out.write_all(&[3u8])?;
                for k in 0..3 {
                    out.write_all(&(3 * t + k).to_le_bytes())?;
                }
            }
            Ok(())
        };
        body()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, bytes).unwrap();
        p
    }

    #[test]
    fn ascii_round_trip_through_binary_writer() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "a.ply",
            b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
              property float z\nelement face 2\nproperty list uchar int vertex_indices\nend_header\n\
              0 0 0\n1 0 0\n0 1 0\n0 0 1\n3 0 1 2\n3 0 2 3\n",
        );
        let soup = read_soup(&p).unwrap();
        assert_eq!(soup.triangle_count(), 2);
        assert_eq!(soup.corner(1, 2), [0.0, 0.0, 1.0]);
        let out = dir.path().join("b.ply");
        write_soup(&out, &soup).unwrap();
        let again = read_soup(&out).unwrap();
        assert_eq!(again.positions, soup.positions);
    }

    #[test]
    fn quads_are_rejected_with_the_face_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "quad.ply",
            b"ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
              property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
              0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n",
        );
        let msg = read_soup(&p).unwrap_err().to_string();
        assert!(
            msg.contains("quad.ply") && msg.contains("face 0") && msg.contains("4 vertices"),
            "{msg}"
        );
    }

    #[test]
    fn nan_vertex_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "nan.ply",
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
              property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
              0 0 0\n1 nan 0\n0 1 0\n3 0 1 2\n",
        );
        let msg = read_soup(&p).unwrap_err().to_string();
        assert!(
            msg.contains("nan.ply") && msg.contains("vertex 1") && msg.contains("not finite"),
            "{msg}"
        );
    }

    #[test]
    fn truncated_binary_is_reported() {
        let dir = tempfile::tempdir().unwrap();
        let mut bytes =
            b"ply\nformat binary_little_endian 1.0\nelement vertex 3\nproperty float x\n\
              property float y\nproperty float z\nelement face 1\n\
              property list uchar uint vertex_indices\nend_header\n"
                .to_vec();
        bytes.extend_from_slice(&[0u8; 20]);
        let p = write(dir.path(), "cut.ply", &bytes);
        let msg = read_soup(&p).unwrap_err().to_string();
        assert!(
            msg.contains("cut.ply") && msg.contains("ends early"),
            "{msg}"
        );
    }

    #[test]
    fn out_of_range_index_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = write(
            dir.path(),
            "oob.ply",
            b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
              property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
              0 0 0\n1 0 0\n0 1 0\n3 0 1 7\n",
        );
        let msg = read_soup(&p).unwrap_err().to_string();
        assert!(
            msg.contains("face 0") && msg.contains("out of range"),
            "{msg}"
        );
    }
}
