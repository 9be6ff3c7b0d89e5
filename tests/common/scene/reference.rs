//! The independent reference evaluator (`Raw`): the glTF JSON read with
//! serde_json, the buffers by hand, matrices in f64 with nalgebra, and the
//! animation, morph and skinning rules implemented from the specification
//! text; and the checks of a soup against its triangles.

use super::*;
use nalgebra::{Matrix4, Quaternion, UnitQuaternion, Vector3, Vector4};

pub struct Raw {
    pub json: Value,
    pub bufs: Vec<Vec<u8>>,
}

fn u32_le(b: &[u8], at: usize) -> usize {
    u32::from_le_bytes(b[at..at + 4].try_into().unwrap()) as usize
}

impl Raw {
    pub fn open(path: &Path) -> Raw {
        let bytes = std::fs::read(path).unwrap();
        let (json, bin): (Value, Option<Vec<u8>>) = if &bytes[..4] == b"glTF" {
            let json_len = u32_le(&bytes, 12);
            let json = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
            let bin_at = 20 + json_len;
            let bin = (bin_at + 8 <= bytes.len()).then(|| {
                let len = u32_le(&bytes, bin_at);
                bytes[bin_at + 8..bin_at + 8 + len].to_vec()
            });
            (json, bin)
        } else {
            (serde_json::from_slice(&bytes).unwrap(), None)
        };
        let mut bin = bin;
        let bufs = json["buffers"]
            .as_array()
            .unwrap()
            .iter()
            .map(|b| match b["uri"].as_str() {
                None => bin.take().unwrap(),
                Some(uri) if uri.starts_with("data:") => decode_data_uri(uri),
                Some(uri) => std::fs::read(path.parent().unwrap().join(uri)).unwrap(),
            })
            .collect();
        Raw { json, bufs }
    }

    /// Elements of a dense accessor as f64 (normalized integers mapped per
    /// the specification's table).
    pub fn accessor(&self, i: usize) -> Vec<Vec<f64>> {
        let a = &self.json["accessors"][i];
        assert!(
            a.get("sparse").is_none(),
            "reference reader does not do sparse accessors"
        );
        let width = match a["type"].as_str().unwrap() {
            "SCALAR" => 1,
            "VEC2" => 2,
            "VEC3" => 3,
            "VEC4" => 4,
            "MAT4" => 16,
            t => panic!("reference reader does not do {t}"),
        };
        let ct = a["componentType"].as_u64().unwrap();
        let size = match ct {
            5120 | 5121 => 1,
            5122 | 5123 => 2,
            _ => 4,
        };
        let normalized = a["normalized"].as_bool().unwrap_or(false);
        let count = a["count"].as_u64().unwrap() as usize;
        let v = &self.json["bufferViews"][a["bufferView"].as_u64().unwrap() as usize];
        let buf = &self.bufs[v["buffer"].as_u64().unwrap() as usize];
        let stride = v["byteStride"]
            .as_u64()
            .map_or(width * size, |s| s as usize);
        let base = v["byteOffset"].as_u64().unwrap_or(0) as usize
            + a["byteOffset"].as_u64().unwrap_or(0) as usize;
        (0..count)
            .map(|e| {
                (0..width)
                    .map(|c| {
                        let at = base + e * stride + c * size;
                        let b = &buf[at..at + size];
                        match (ct, normalized) {
                            (5126, _) => f32::from_le_bytes(b.try_into().unwrap()) as f64,
                            (5121, false) => b[0] as f64,
                            (5121, true) => b[0] as f64 / 255.0,
                            (5123, false) => u16::from_le_bytes(b.try_into().unwrap()) as f64,
                            (5123, true) => {
                                u16::from_le_bytes(b.try_into().unwrap()) as f64 / 65535.0
                            }
                            (5125, _) => u32::from_le_bytes(b.try_into().unwrap()) as f64,
                            (5122, true) => (i16::from_le_bytes(b.try_into().unwrap()) as f64
                                / 32767.0)
                                .max(-1.0),
                            (5120, true) => ((b[0] as i8) as f64 / 127.0).max(-1.0),
                            _ => panic!("component type {ct}"),
                        }
                    })
                    .collect()
            })
            .collect()
    }

    pub fn animation_index(&self, name: &str) -> usize {
        self.json["animations"]
            .as_array()
            .unwrap()
            .iter()
            .position(|a| a["name"].as_str() == Some(name))
            .unwrap()
    }

    /// The channel outputs of `anim` at time `t`: (node, path, value).
    pub fn sample(&self, anim: usize, t: f64) -> Vec<(usize, String, Vec<f64>)> {
        let a = &self.json["animations"][anim];
        let mut out = Vec::new();
        for ch in a["channels"].as_array().unwrap() {
            let s = &a["samplers"][ch["sampler"].as_u64().unwrap() as usize];
            let times: Vec<f64> = self
                .accessor(s["input"].as_u64().unwrap() as usize)
                .into_iter()
                .map(|v| v[0])
                .collect();
            let raw: Vec<f64> = self
                .accessor(s["output"].as_u64().unwrap() as usize)
                .into_iter()
                .flatten()
                .collect();
            let mode = s["interpolation"].as_str().unwrap_or("LINEAR");
            let path = ch["target"]["path"].as_str().unwrap().to_owned();
            let node = ch["target"]["node"].as_u64().unwrap() as usize;
            let per_key = if mode == "CUBICSPLINE" { 3 } else { 1 };
            let width = raw.len() / (times.len() * per_key);
            let elem = |e: usize| raw[e * width..(e + 1) * width].to_vec();
            let value_of = |k: usize| elem(k * per_key + if per_key == 3 { 1 } else { 0 });
            let n = times.len();
            let value = if t <= times[0] {
                value_of(0)
            } else if t >= times[n - 1] {
                value_of(n - 1)
            } else {
                let mut k = 0;
                while times[k + 1] <= t {
                    k += 1;
                }
                let dt = times[k + 1] - times[k];
                let u = (t - times[k]) / dt;
                match mode {
                    "STEP" => value_of(k),
                    "LINEAR" if path == "rotation" => {
                        let (p, q) = (value_of(k), value_of(k + 1));
                        let d: f64 = p.iter().zip(&q).map(|(a, b)| a * b).sum();
                        let q: Vec<f64> = if d < 0.0 {
                            q.iter().map(|x| -x).collect()
                        } else {
                            q
                        };
                        let theta = d.abs().min(1.0).acos();
                        let (wa, wb) = if theta < 1e-6 {
                            (1.0 - u, u)
                        } else {
                            (
                                ((1.0 - u) * theta).sin() / theta.sin(),
                                (u * theta).sin() / theta.sin(),
                            )
                        };
                        let r: Vec<f64> = p.iter().zip(&q).map(|(a, b)| wa * a + wb * b).collect();
                        let len = r.iter().map(|x| x * x).sum::<f64>().sqrt();
                        r.iter().map(|x| x / len).collect()
                    }
                    "LINEAR" => value_of(k)
                        .iter()
                        .zip(value_of(k + 1))
                        .map(|(a, b)| a + (b - a) * u)
                        .collect(),
                    "CUBICSPLINE" => {
                        let (v0, b0, a1, v1) = (
                            elem(3 * k + 1),
                            elem(3 * k + 2),
                            elem(3 * k + 3),
                            elem(3 * k + 4),
                        );
                        let r: Vec<f64> = (0..width)
                            .map(|i| {
                                (2.0 * u.powi(3) - 3.0 * u * u + 1.0) * v0[i]
                                    + dt * (u.powi(3) - 2.0 * u * u + u) * b0[i]
                                    + (-2.0 * u.powi(3) + 3.0 * u * u) * v1[i]
                                    + dt * (u.powi(3) - u * u) * a1[i]
                            })
                            .collect();
                        if path == "rotation" {
                            let len = r.iter().map(|x| x * x).sum::<f64>().sqrt();
                            r.iter().map(|x| x / len).collect()
                        } else {
                            r
                        }
                    }
                    m => panic!("interpolation {m}"),
                }
            };
            out.push((node, path, value));
        }
        out
    }

    /// Local matrices of every node at `t` under `anim`.
    pub fn locals(&self, anim: Option<usize>, t: f64) -> Vec<Matrix4<f64>> {
        let nodes = self.json["nodes"].as_array().unwrap();
        let mut trs: Vec<(Vec<f64>, Vec<f64>, Vec<f64>)> = nodes
            .iter()
            .map(|n| {
                let get = |k: &str, d: Vec<f64>| {
                    n.get(k).map_or(d, |v| {
                        v.as_array()
                            .unwrap()
                            .iter()
                            .map(|x| x.as_f64().unwrap())
                            .collect()
                    })
                };
                (
                    get("translation", vec![0.0; 3]),
                    get("rotation", vec![0.0, 0.0, 0.0, 1.0]),
                    get("scale", vec![1.0; 3]),
                )
            })
            .collect();
        let mut animated = vec![false; nodes.len()];
        if let Some(anim) = anim {
            for (node, path, v) in self.sample(anim, t) {
                match path.as_str() {
                    "translation" => trs[node].0 = v,
                    "rotation" => trs[node].1 = v,
                    "scale" => trs[node].2 = v,
                    _ => continue,
                }
                animated[node] = true;
            }
        }
        nodes
            .iter()
            .enumerate()
            .map(|(i, n)| match n.get("matrix") {
                Some(m) if !animated[i] => {
                    let m: Vec<f64> = m
                        .as_array()
                        .unwrap()
                        .iter()
                        .map(|x| x.as_f64().unwrap())
                        .collect();
                    Matrix4::from_column_slice(&m)
                }
                _ => {
                    let (t, r, s) = &trs[i];
                    let q =
                        UnitQuaternion::from_quaternion(Quaternion::new(r[3], r[0], r[1], r[2]));
                    Matrix4::new_translation(&Vector3::new(t[0], t[1], t[2]))
                        * q.to_homogeneous()
                        * Matrix4::new_nonuniform_scaling(&Vector3::new(s[0], s[1], s[2]))
                }
            })
            .collect()
    }

    pub fn worlds(&self, anim: Option<usize>, t: f64) -> Vec<Matrix4<f64>> {
        let locals = self.locals(anim, t);
        let nodes = self.json["nodes"].as_array().unwrap();
        let mut parent = vec![None; nodes.len()];
        for (p, n) in nodes.iter().enumerate() {
            for c in n["children"].as_array().into_iter().flatten() {
                parent[c.as_u64().unwrap() as usize] = Some(p);
            }
        }
        (0..nodes.len())
            .map(|mut n| {
                let mut m = locals[n];
                while let Some(p) = parent[n] {
                    m = locals[p] * m;
                    n = p;
                }
                m
            })
            .collect()
    }

    /// The scene's nodes in depth-first order (children in listed order).
    pub fn scene_nodes(&self) -> Vec<usize> {
        let scene = self.json["scene"].as_u64().unwrap_or(0) as usize;
        let mut stack: Vec<usize> = self.json["scenes"][scene]["nodes"]
            .as_array()
            .unwrap()
            .iter()
            .rev()
            .map(|v| v.as_u64().unwrap() as usize)
            .collect();
        let mut out = Vec::new();
        while let Some(n) = stack.pop() {
            out.push(n);
            for c in self.json["nodes"][n]["children"]
                .as_array()
                .into_iter()
                .flatten()
                .rev()
            {
                stack.push(c.as_u64().unwrap() as usize);
            }
        }
        out
    }

    /// The triangle corners of the whole scene at `t`, in scene order, each
    /// primitive's triangles in index order.
    pub fn soup(&self, anim: Option<usize>, t: f64) -> Vec<[Vector3<f64>; 3]> {
        let worlds = self.worlds(anim, t);
        let sampled = anim.map(|a| self.sample(a, t)).unwrap_or_default();
        let mut tris = Vec::new();
        for n in self.scene_nodes() {
            let node = &self.json["nodes"][n];
            let Some(mesh) = node["mesh"].as_u64() else {
                continue;
            };
            let mesh = &self.json["meshes"][mesh as usize];
            let mut weights: Vec<f64> = node["weights"]
                .as_array()
                .or(mesh["weights"].as_array())
                .map(|w| w.iter().map(|x| x.as_f64().unwrap()).collect())
                .unwrap_or_default();
            for (tn, path, v) in &sampled {
                if *tn == n && path == "weights" {
                    weights = v.clone();
                }
            }
            let joint_matrices: Option<Vec<Matrix4<f64>>> = node["skin"].as_u64().map(|s| {
                let skin = &self.json["skins"][s as usize];
                let joints: Vec<usize> = skin["joints"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|j| j.as_u64().unwrap() as usize)
                    .collect();
                let ibms: Vec<Matrix4<f64>> = match skin["inverseBindMatrices"].as_u64() {
                    Some(a) => self
                        .accessor(a as usize)
                        .iter()
                        .map(|m| Matrix4::from_column_slice(m))
                        .collect(),
                    None => vec![Matrix4::identity(); joints.len()],
                };
                joints
                    .iter()
                    .zip(&ibms)
                    .map(|(&j, ibm)| worlds[j] * ibm)
                    .collect()
            });
            for prim in mesh["primitives"].as_array().unwrap() {
                assert_eq!(
                    prim["mode"].as_u64().unwrap_or(4),
                    4,
                    "reference does TRIANGLES only"
                );
                let attr = |k: &str| {
                    prim["attributes"][k]
                        .as_u64()
                        .map(|a| self.accessor(a as usize))
                };
                let mut pos: Vec<Vector3<f64>> = attr("POSITION")
                    .unwrap()
                    .iter()
                    .map(|p| Vector3::new(p[0], p[1], p[2]))
                    .collect();
                for (k, target) in prim["targets"].as_array().into_iter().flatten().enumerate() {
                    if let Some(a) = target["POSITION"].as_u64() {
                        for (p, d) in pos.iter_mut().zip(self.accessor(a as usize)) {
                            *p += weights[k] * Vector3::new(d[0], d[1], d[2]);
                        }
                    }
                }
                let world: Vec<Vector3<f64>> =
                    match (&joint_matrices, attr("JOINTS_0"), attr("WEIGHTS_0")) {
                        (Some(jm), Some(j), Some(w)) => pos
                            .iter()
                            .enumerate()
                            .map(|(v, p)| {
                                let sum: f64 = w[v].iter().sum();
                                let mut m = Matrix4::zeros();
                                for i in 0..4 {
                                    m += jm[j[v][i] as usize] * (w[v][i] / sum);
                                }
                                (m * Vector4::new(p.x, p.y, p.z, 1.0)).xyz()
                            })
                            .collect(),
                        _ => pos
                            .iter()
                            .map(|p| (worlds[n] * Vector4::new(p.x, p.y, p.z, 1.0)).xyz())
                            .collect(),
                    };
                let indices: Vec<usize> = match prim["indices"].as_u64() {
                    Some(a) => self
                        .accessor(a as usize)
                        .iter()
                        .map(|i| i[0] as usize)
                        .collect(),
                    None => (0..world.len()).collect(),
                };
                for c in indices.chunks_exact(3) {
                    tris.push([world[c[0]], world[c[1]], world[c[2]]]);
                }
            }
        }
        tris
    }
}

/// Asserts that `soup` equals the reference triangles corner by corner
/// within `tol` (absolute, in world units).
pub fn assert_soup_matches(
    soup: &soupray::soup::Soup,
    reference: &[[Vector3<f64>; 3]],
    tol: f64,
    what: &str,
) {
    assert_eq!(
        soup.triangle_count(),
        reference.len(),
        "{what}: triangle count"
    );
    let mut worst = 0.0f64;
    for (t, tri) in reference.iter().enumerate() {
        for (k, r) in tri.iter().enumerate() {
            let p = soup.corner(t, k);
            let d = (Vector3::new(p[0] as f64, p[1] as f64, p[2] as f64) - r).norm();
            worst = worst.max(d);
            assert!(
                d <= tol,
                "{what}: triangle {t} corner {k} is {p:?}, reference {r:?} (off by {d})"
            );
        }
    }
    assert!(worst.is_finite());
}

pub fn bounds_of(tris: &[[Vector3<f64>; 3]]) -> (Vector3<f64>, Vector3<f64>) {
    let mut lo = Vector3::repeat(f64::INFINITY);
    let mut hi = Vector3::repeat(f64::NEG_INFINITY);
    for p in tris.iter().flatten() {
        lo = lo.inf(p);
        hi = hi.sup(p);
    }
    (lo, hi)
}

/// The soup triangles that the mesh instance on `node` produced.
pub fn instance_triangles(scene: &soupray::scene::Scene, node: usize) -> std::ops::Range<usize> {
    let mut start = 0;
    for inst in scene.instances() {
        let n: usize = scene.meshes()[inst.mesh]
            .primitives
            .iter()
            .map(|p| p.triangles.len())
            .sum();
        if inst.node == node {
            return start..start + n;
        }
        start += n;
    }
    panic!("no mesh instance on node {node}");
}

pub fn load(path: &Path, animation: Option<&str>) -> soupray::scene::Scene {
    let opts = soupray::scene::LoadOptions {
        animation: animation.map(str::to_owned),
        ..Default::default()
    };
    soupray::scene::Scene::load(path, &opts).unwrap_or_else(|e| panic!("{e}"))
}
