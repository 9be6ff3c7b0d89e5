//! The per-frame world-space triangle soup: the one input of the BVH builder
//! and the tracer. Triangles share nothing; vertex `3*t + k` is corner `k` of
//! triangle `t`. Positions are padded to four floats so the host array is the
//! device buffer byte for byte (OpenCL `float4`).
//!
//! `device` evaluates the soup of a frame on the OpenCL device, straight
//! into the buffers the BVH builder and the tracer read.
//! `motion` keeps the soup at each motion step of a frame that moves within
//! the shutter (`--motion-blur`) and chooses how many steps it needs.

pub mod device;
pub mod motion;

use std::fmt;

/// A world-space triangle soup.
#[derive(Clone, Default, PartialEq)]
pub struct Soup {
    /// Corner positions, three per triangle; `w` is 0 and unused.
    pub positions: Vec<[f32; 4]>,
    /// Shading normals, one per corner (same length as `positions`), or empty
    /// when the source had none (the tracer then uses the geometric normal).
    pub normals: Vec<[f32; 4]>,
    /// Texture coordinates (TEXCOORD_0), one per corner, or empty.
    pub uvs: Vec<[f32; 2]>,
    /// The second texture coordinate set the materials sample (TEXCOORD_1,
    /// or the one other set they use: `Scene::second_uv_set`), one per
    /// corner, or empty.
    pub uvs1: Vec<[f32; 2]>,
    /// Vertex colours (COLOR_0, linear RGBA, alpha 1 for RGB), one per
    /// corner, or empty when no primitive has them.
    pub colors: Vec<[f32; 4]>,
    /// Index into the scene's material table, one per triangle, or empty
    /// (every triangle uses the default material).
    pub material_ids: Vec<u32>,
}

impl Soup {
    /// A soup of positions only, from triangles given as three corners each.
    pub fn from_triangles(triangles: &[[[f32; 3]; 3]]) -> Soup {
        let positions = triangles
            .iter()
            .flat_map(|t| t.iter().map(|p| [p[0], p[1], p[2], 0.0]))
            .collect();
        Soup {
            positions,
            ..Soup::default()
        }
    }

    pub fn triangle_count(&self) -> usize {
        self.positions.len() / 3
    }

    pub fn is_empty(&self) -> bool {
        self.positions.is_empty()
    }

    /// Corner `k` of triangle `t`.
    pub fn corner(&self, t: usize, k: usize) -> [f32; 3] {
        let p = self.positions[3 * t + k];
        [p[0], p[1], p[2]]
    }

    /// The axis-aligned bounds of every corner, or `None` for an empty soup.
    pub fn bounds(&self) -> Option<([f32; 3], [f32; 3])> {
        let mut it = self.positions.iter();
        let first = it.next()?;
        let mut lo = [first[0], first[1], first[2]];
        let mut hi = lo;
        for p in it {
            for a in 0..3 {
                lo[a] = lo[a].min(p[a]);
                hi[a] = hi[a].max(p[a]);
            }
        }
        Some((lo, hi))
    }

    /// `copies` copies of this soup's positions on a square grid, each turned
    /// about the vertical axis by the golden angle times its index and spaced
    /// at 0.7 of the mesh's width, so neighbours overlap as in a crowded
    /// scene: the build benchmark's large soups (`benches/bvh_build.rs`,
    /// `soupray bvh --copies`; 10 and 25 copies of nefertiti.ply are its 1M
    /// and 2.5M-triangle soups).
    pub fn arrangement(&self, copies: usize) -> Soup {
        let Some((lo, hi)) = self.bounds() else {
            return Soup::default();
        };
        let width = (hi[0] - lo[0]).max(hi[2] - lo[2]);
        let side = (copies as f64).sqrt().ceil() as usize;
        let mut out = Soup::default();
        out.positions.reserve(self.positions.len() * copies);
        for c in 0..copies {
            let angle = c as f32 * 2.399; // golden angle: no two copies alike
            let (s, co) = angle.sin_cos();
            let dx = (c % side) as f32 * width * 0.7;
            let dz = (c / side) as f32 * width * 0.7;
            for p in &self.positions {
                let x = p[0] - lo[0];
                let z = p[2] - lo[2];
                out.positions
                    .push([co * x - s * z + dx, p[1], s * x + co * z + dz, 0.0]);
            }
        }
        out
    }
}

impl fmt::Debug for Soup {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Soup")
            .field("triangles", &self.triangle_count())
            .field("normals", &!self.normals.is_empty())
            .field("uvs", &!self.uvs.is_empty())
            .field("uvs1", &!self.uvs1.is_empty())
            .field("colors", &!self.colors.is_empty())
            .field("materials", &!self.material_ids.is_empty())
            .finish()
    }
}
