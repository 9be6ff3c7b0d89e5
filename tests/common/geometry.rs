//! Generated geometry with known winding, shared by the tests: flat-shaded
//! soups (triangles, quads, cubes, UV spheres), indexed closed meshes with
//! exactly shared vertices (a gridded cube, an icosphere), and the smooth
//! indexed UV sphere the glTF scene builders write.
#![allow(dead_code)]

use glam::Vec3;
use soupray::soup::Soup;

// ---------------------------------------------------------------------------
// Soups: triangles appended straight to a `Soup`

/// Appends triangle (a, b, c), wound so that its geometric normal points
/// along `outward`, with material `mat`.
pub fn push_tri(soup: &mut Soup, a: Vec3, b: Vec3, c: Vec3, outward: Vec3, mat: u32) {
    let n = (b - a).cross(c - a);
    let (b, c) = if n.dot(outward) < 0.0 { (c, b) } else { (b, c) };
    for p in [a, b, c] {
        soup.positions.push([p.x, p.y, p.z, 0.0]);
    }
    soup.material_ids.push(mat);
}

/// A flat-shaded UV sphere (convex polyhedron), outward facing.
pub fn sphere(soup: &mut Soup, center: Vec3, r: f32, lat: usize, lon: usize, mat: u32) {
    let p = |i: usize, j: usize| {
        let th = std::f32::consts::PI * i as f32 / lat as f32;
        let ph = std::f32::consts::TAU * j as f32 / lon as f32;
        center + r * Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
    };
    for i in 0..lat {
        for j in 0..lon {
            let (a, b, c, d) = (p(i, j), p(i + 1, j), p(i + 1, j + 1), p(i, j + 1));
            let mid = (a + b + c + d) * 0.25 - center;
            if i != lat - 1 {
                push_tri(soup, a, b, c, mid, mat);
            }
            if i != 0 {
                push_tri(soup, a, c, d, mid, mat);
            }
        }
    }
}

/// A rectangle centred at `c` spanned by half-axes `u`, `v`, facing `n`.
pub fn quad(soup: &mut Soup, c: Vec3, u: Vec3, v: Vec3, n: Vec3, mat: u32) {
    let (a, b, cc, d) = (c - u - v, c + u - v, c + u + v, c - u + v);
    push_tri(soup, a, b, cc, n, mat);
    push_tri(soup, a, cc, d, n, mat);
}

/// A 100 x 100 ground plane through the origin, facing +Y, material 0.
pub fn ground_plane() -> Soup {
    let mut s = Soup::default();
    quad(
        &mut s,
        Vec3::ZERO,
        Vec3::X * 50.0,
        Vec3::Z * 50.0,
        Vec3::Y,
        0,
    );
    s
}

/// An axis-aligned cube of half-size `h` centred at `c`, outward facing.
pub fn cube(soup: &mut Soup, c: Vec3, h: f32, mat: u32) {
    for axis in 0..3 {
        for s in [-1.0f32, 1.0] {
            let mut n = Vec3::ZERO;
            n[axis] = s;
            let mut u = Vec3::ZERO;
            u[(axis + 1) % 3] = h;
            let mut v = Vec3::ZERO;
            v[(axis + 2) % 3] = h;
            quad(soup, c + n * h, u, v, n, mat);
        }
    }
}

// ---------------------------------------------------------------------------
// Indexed closed meshes

/// An indexed mesh, expanded into a soup so shared vertices are bit-equal.
pub struct Mesh {
    pub vertices: Vec<[f32; 3]>,
    pub faces: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn soup(&self) -> Soup {
        let tris: Vec<[[f32; 3]; 3]> = self
            .faces
            .iter()
            .map(|f| f.map(|i| self.vertices[i as usize]))
            .collect();
        Soup::from_triangles(&tris)
    }

    /// Scaled by `s` about the origin, then moved by `offset` on every axis.
    pub fn transformed(&self, s: f32, offset: f32) -> Mesh {
        Mesh {
            vertices: self
                .vertices
                .iter()
                .map(|v| v.map(|c| c * s + offset))
                .collect(),
            faces: self.faces.clone(),
        }
    }

    /// Every edge once, as (a, b) with a < b.
    pub fn edges(&self) -> Vec<(u32, u32)> {
        let mut e: Vec<(u32, u32)> = self
            .faces
            .iter()
            .flat_map(|f| [(f[0], f[1]), (f[1], f[2]), (f[2], f[0])])
            .map(|(a, b)| (a.min(b), a.max(b)))
            .collect();
        e.sort_unstable();
        e.dedup();
        e
    }
}

/// The cube [-1, 1]^3, each face an n x n grid of quads split into two
/// triangles, outward-facing, with vertices shared exactly between faces.
pub fn cube_grid(n: u32) -> Mesh {
    let mut vertices: Vec<[f32; 3]> = Vec::new();
    let mut faces = Vec::new();
    let mut index = std::collections::HashMap::new();
    let mut vid = |p: [f32; 3], vertices: &mut Vec<[f32; 3]>| -> u32 {
        *index.entry(p.map(f32::to_bits)).or_insert_with(|| {
            vertices.push(p);
            vertices.len() as u32 - 1
        })
    };
    let coord = |i: u32| -1.0 + 2.0 * i as f32 / n as f32;
    for axis in 0..3 {
        for side in [-1.0f32, 1.0] {
            let (u_ax, v_ax) = ((axis + 1) % 3, (axis + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let corner = |di: u32, dj: u32| {
                        let mut p = [0.0; 3];
                        p[axis] = side;
                        p[u_ax] = coord(i + di);
                        p[v_ax] = coord(j + dj);
                        p
                    };
                    let q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                    let q = q.map(|p| vid(p, &mut vertices));
                    // Outward winding: (u, v, axis) is right-handed.
                    if side > 0.0 {
                        faces.push([q[0], q[1], q[2]]);
                        faces.push([q[0], q[2], q[3]]);
                    } else {
                        faces.push([q[0], q[2], q[1]]);
                        faces.push([q[0], q[3], q[2]]);
                    }
                }
            }
        }
    }
    Mesh { vertices, faces }
}

/// A unit icosphere: an icosahedron subdivided `levels` times, projected.
pub fn icosphere(levels: u32) -> Mesh {
    let t = (1.0 + 5.0f64.sqrt()) / 2.0;
    let mut v: Vec<[f64; 3]> = vec![
        [-1.0, t, 0.0],
        [1.0, t, 0.0],
        [-1.0, -t, 0.0],
        [1.0, -t, 0.0],
        [0.0, -1.0, t],
        [0.0, 1.0, t],
        [0.0, -1.0, -t],
        [0.0, 1.0, -t],
        [t, 0.0, -1.0],
        [t, 0.0, 1.0],
        [-t, 0.0, -1.0],
        [-t, 0.0, 1.0],
    ];
    let mut f: Vec<[u32; 3]> = vec![
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    for _ in 0..levels {
        let mut mid = std::collections::HashMap::new();
        let mut next = Vec::new();
        for tri in &f {
            let mut m = [0u32; 3];
            for k in 0..3 {
                let (a, b) = (tri[k], tri[(k + 1) % 3]);
                m[k] = *mid.entry((a.min(b), a.max(b))).or_insert_with(|| {
                    let (pa, pb) = (v[a as usize], v[b as usize]);
                    v.push(std::array::from_fn(|i| 0.5 * (pa[i] + pb[i])));
                    v.len() as u32 - 1
                });
            }
            next.push([tri[0], m[0], m[2]]);
            next.push([tri[1], m[1], m[0]]);
            next.push([tri[2], m[2], m[1]]);
            next.push(m);
        }
        f = next;
    }
    let vertices = v
        .iter()
        .map(|p| {
            let l = (p[0] * p[0] + p[1] * p[1] + p[2] * p[2]).sqrt();
            p.map(|c| (c / l) as f32)
        })
        .collect();
    Mesh { vertices, faces: f }
}

// ---------------------------------------------------------------------------
// A smooth indexed UV sphere, for glTF files

/// A smooth UV sphere with shared vertices, as exporters write it.
pub struct UvSphere {
    pub positions: Vec<[f32; 3]>,
    pub normals: Vec<[f32; 3]>,
    /// TEXCOORD_0: u runs around the sphere, v from top to bottom.
    pub uvs: Vec<[f32; 2]>,
    /// Wound counter-clockwise seen from outside.
    pub indices: Vec<u32>,
}

/// A UV sphere of `segments` around and `segments / 2` rings, centred at
/// `c` with radius `r`. Every ring repeats its first vertex at its end (the
/// texture seam), and the poles' first and last rings hold degenerate
/// triangles; the vertices are shared, so the sphere is closed.
pub fn uv_sphere(c: [f32; 3], r: f32, segments: u32) -> UvSphere {
    let mut s = UvSphere {
        positions: Vec::new(),
        normals: Vec::new(),
        uvs: Vec::new(),
        indices: Vec::new(),
    };
    let c = Vec3::from(c);
    let rings = segments / 2;
    for i in 0..=rings {
        let th = std::f32::consts::PI * i as f32 / rings as f32;
        for j in 0..=segments {
            let ph = std::f32::consts::TAU * j as f32 / segments as f32;
            let n = Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin());
            s.positions.push((c + r * n).to_array());
            s.normals.push(n.to_array());
            s.uvs
                .push([j as f32 / segments as f32, i as f32 / rings as f32]);
        }
    }
    let row = segments + 1;
    for i in 0..rings {
        for j in 0..segments {
            let (a, b) = (i * row + j, (i + 1) * row + j);
            s.indices.extend([a, a + 1, b, a + 1, b + 1, b]);
        }
    }
    s
}
