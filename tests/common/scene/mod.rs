//! Shared by the `scene_*` tests (`common::scene`): paths of the shared sample models, a builder
//! for small synthetic glTF files, and an independent reference evaluator.
//!
//! The reference reads the JSON with serde_json and the buffers by hand,
//! does its matrix work in f64 with nalgebra, and implements the glTF
//! animation, morph and skinning rules from the specification text on its
//! own, sharing no code with `soupray::scene`. Its scope is deliberately
//! narrow (dense accessors, TRIANGLES, JOINTS_0/WEIGHTS_0, POSITION morph
//! deltas), which covers the sample assets it is used on.
#![allow(dead_code)]

use std::path::{Path, PathBuf};

use nalgebra::{Matrix4, Quaternion, UnitQuaternion, Vector3, Vector4};
use serde_json::{json, Value};

// Re-exported so `use common::scene::*` brings the asset paths.
#[allow(unused_imports)]
pub use super::{asset, shared};

pub mod avif;
pub mod ktx2;

// ---------------------------------------------------------------------------
// Synthetic files

pub fn base64(bytes: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (b[0] as u32) << 16 | (b[1] as u32) << 8 | b[2] as u32;
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(A[(n >> (18 - 6 * i) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

/// Accumulates one binary buffer with its views and accessors.
#[derive(Default)]
pub struct Builder {
    pub bin: Vec<u8>,
    pub views: Vec<Value>,
    pub accessors: Vec<Value>,
}

fn type_of(width: usize) -> &'static str {
    match width {
        1 => "SCALAR",
        2 => "VEC2",
        3 => "VEC3",
        4 => "VEC4",
        16 => "MAT4",
        _ => panic!("unsupported width {width}"),
    }
}

impl Builder {
    pub fn view(&mut self, bytes: &[u8]) -> usize {
        while !self.bin.len().is_multiple_of(4) {
            self.bin.push(0);
        }
        let offset = self.bin.len();
        self.bin.extend_from_slice(bytes);
        self.views
            .push(json!({"buffer": 0, "byteOffset": offset, "byteLength": bytes.len()}));
        self.views.len() - 1
    }

    pub fn accessor(&mut self, acc: Value) -> usize {
        self.accessors.push(acc);
        self.accessors.len() - 1
    }

    /// Float accessor; VEC3 ones get min/max as POSITION requires.
    pub fn floats(&mut self, data: &[f32], width: usize) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes);
        let mut acc = json!({"bufferView": view, "componentType": 5126, "count": data.len() / width, "type": type_of(width)});
        if width == 3 {
            let mut lo = [f32::INFINITY; 3];
            let mut hi = [f32::NEG_INFINITY; 3];
            for p in data.chunks(3) {
                for a in 0..3 {
                    lo[a] = lo[a].min(p[a]);
                    hi[a] = hi[a].max(p[a]);
                }
            }
            if lo.iter().chain(&hi).all(|v| v.is_finite()) {
                acc["min"] = json!(lo);
                acc["max"] = json!(hi);
            }
        }
        self.accessor(acc)
    }

    pub fn u16s(&mut self, data: &[u16], width: usize, normalized: bool) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessor(
            json!({"bufferView": view, "componentType": 5123, "count": data.len() / width,
            "type": type_of(width), "normalized": normalized}),
        )
    }

    pub fn u8s(&mut self, data: &[u8], width: usize, normalized: bool) -> usize {
        let view = self.view(data);
        self.accessor(
            json!({"bufferView": view, "componentType": 5121, "count": data.len() / width,
            "type": type_of(width), "normalized": normalized}),
        )
    }

    pub fn i16s(&mut self, data: &[i16], width: usize, normalized: bool) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessor(
            json!({"bufferView": view, "componentType": 5122, "count": data.len() / width,
            "type": type_of(width), "normalized": normalized}),
        )
    }

    pub fn i8s(&mut self, data: &[i8], width: usize, normalized: bool) -> usize {
        let bytes: Vec<u8> = data.iter().map(|&v| v as u8).collect();
        let view = self.view(&bytes);
        self.accessor(
            json!({"bufferView": view, "componentType": 5120, "count": data.len() / width,
            "type": type_of(width), "normalized": normalized}),
        )
    }

    pub fn u32s(&mut self, data: &[u32]) -> usize {
        let bytes: Vec<u8> = data.iter().flat_map(|f| f.to_le_bytes()).collect();
        let view = self.view(&bytes);
        self.accessor(json!({"bufferView": view, "componentType": 5125, "count": data.len(), "type": "SCALAR"}))
    }

    /// Completes `root` with asset, buffers, views and accessors and writes
    /// it into `dir` as `name`.gltf, the buffer embedded as a data URI or
    /// written beside it as `name`.bin.
    pub fn write(&self, mut root: Value, dir: &Path, name: &str, embed: bool) -> PathBuf {
        let uri = if embed {
            format!("data:application/octet-stream;base64,{}", base64(&self.bin))
        } else {
            std::fs::write(dir.join(format!("{name}.bin")), &self.bin).unwrap();
            format!("{name}.bin")
        };
        root["asset"] = json!({"version": "2.0"});
        root["buffers"] = json!([{"byteLength": self.bin.len(), "uri": uri}]);
        root["bufferViews"] = json!(self.views);
        root["accessors"] = json!(self.accessors);
        let path = dir.join(format!("{name}.gltf"));
        std::fs::write(&path, serde_json::to_string_pretty(&root).unwrap()).unwrap();
        path
    }
}

// ---------------------------------------------------------------------------
// Independent reference evaluator

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

/// A triangle facing +z (counter-clockwise seen from +z), skinned fully to
/// joint node 1, whose transform is `joint`; the mesh node sits at
/// `mesh_node_translation`, which skinning must ignore.
pub fn skinned_triangle(
    dir: &std::path::Path,
    joint: serde_json::Value,
    mesh_node_translation: [f32; 3],
) -> std::path::PathBuf {
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let nrm = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], 3);
    let joints = b.u8s(&[0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0], 4, false);
    let weights = b.floats(
        &[1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0],
        4,
    );
    let mut joint_node = joint;
    joint_node["name"] = json!("joint");
    b.write(
        json!({
            "scenes": [{"nodes": [0, 1]}],
            "nodes": [{"mesh": 0, "skin": 0, "translation": mesh_node_translation}, joint_node],
            "skins": [{"joints": [1]}],
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos, "NORMAL": nrm, "JOINTS_0": joints, "WEIGHTS_0": weights}}]}]
        }),
        dir,
        "skinned",
        true,
    )
}

// ---------------------------------------------------------------------------
// EXT_meshopt_compression

/// A unit quad in z = 0 (two triangles, four vertices) whose bufferViews
/// are compressed with meshoptimizer's codecs: float positions with the
/// EXPONENTIAL filter, BYTE normals with OCTAHEDRAL, and TRIANGLES indices,
/// all pointing at a fallback buffer with no data. Returns the JSON (buffer
/// 0 without its uri) and the compressed bytes of buffer 0.
pub fn meshopt_quad() -> (Value, Vec<u8>) {
    let positions: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [1.0, 1.0, 0.0],
        [0.0, 1.0, 0.0],
    ];
    let exp = meshopt::encoding::encode_filter_exp(
        &positions,
        24,
        meshopt::encoding::EncodeExpMode::Separate,
    );
    let normals = meshopt::encoding::encode_filter_oct::<i8>(&[[0.0, 0.0, 1.0, 0.0]; 4], 8);
    let indices = [0u32, 1, 2, 0, 2, 3];
    let parts = [
        meshopt::encoding::encode_vertex_buffer(&exp).unwrap(),
        meshopt::encoding::encode_vertex_buffer(&normals).unwrap(),
        meshopt::encoding::encode_index_buffer(&indices, 4).unwrap(),
    ];
    let mut bin = Vec::new();
    let mut at = Vec::new();
    for p in &parts {
        while !bin.len().is_multiple_of(4) {
            bin.push(0);
        }
        at.push((bin.len(), p.len()));
        bin.extend_from_slice(p);
    }
    let ext = |k: usize, stride: usize, count: usize, mode: &str, filter: Option<&str>| {
        let mut e = json!({"buffer": 0, "byteOffset": at[k].0, "byteLength": at[k].1,
                           "byteStride": stride, "count": count, "mode": mode});
        if let Some(f) = filter {
            e["filter"] = json!(f);
        }
        json!({"EXT_meshopt_compression": e})
    };
    let root = json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["EXT_meshopt_compression", "KHR_mesh_quantization"],
        "extensionsRequired": ["EXT_meshopt_compression", "KHR_mesh_quantization"],
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1}, "indices": 2}]}],
        "buffers": [
            {"byteLength": bin.len()},
            {"byteLength": 76, "extensions": {"EXT_meshopt_compression": {"fallback": true}}}
        ],
        "bufferViews": [
            {"buffer": 1, "byteOffset": 0, "byteLength": 48, "byteStride": 12,
             "extensions": ext(0, 12, 4, "ATTRIBUTES", Some("EXPONENTIAL"))},
            {"buffer": 1, "byteOffset": 48, "byteLength": 16, "byteStride": 4,
             "extensions": ext(1, 4, 4, "ATTRIBUTES", Some("OCTAHEDRAL"))},
            {"buffer": 1, "byteOffset": 64, "byteLength": 12,
             "extensions": ext(2, 2, 6, "TRIANGLES", None)}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3",
             "min": [0.0, 0.0, 0.0], "max": [1.0, 1.0, 0.0]},
            {"bufferView": 1, "componentType": 5120, "normalized": true, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ]
    });
    (root, bin)
}

/// Writes `root` with `bin` as buffer 0's data URI into `dir`/`name`.gltf.
pub fn write_with_buffer(mut root: Value, bin: &[u8], dir: &Path, name: &str) -> PathBuf {
    root["buffers"][0]["uri"] = json!(format!(
        "data:application/octet-stream;base64,{}",
        base64(bin)
    ));
    let path = dir.join(format!("{name}.gltf"));
    std::fs::write(&path, serde_json::to_string(&root).unwrap()).unwrap();
    path
}

// ---------------------------------------------------------------------------
// EXT_mesh_gpu_instancing

/// The instance transforms of [`instanced_triangles`] as TRS: a row of
/// four, each turned about z by a multiple of 30 degrees and scaled.
pub fn instance_trs() -> Vec<([f32; 3], [f32; 4], [f32; 3])> {
    (0..4)
        .map(|i| {
            let a = (i as f32 * 30.0_f32).to_radians() / 2.0;
            (
                [2.0 * i as f32, 0.5 * i as f32, -(i as f32)],
                [0.0, 0.0, a.sin(), a.cos()],
                [1.0 + 0.25 * i as f32, 1.0, 0.5 + 0.5 * i as f32],
            )
        })
        .collect()
}

/// A triangle mesh drawn four times by a node whose translation is
/// animated (LINEAR over 1 s). `instanced` writes it with
/// EXT_mesh_gpu_instancing (rotations as normalized SHORT, as gltfpack
/// writes them); otherwise as its flat twin, one child node per instance.
pub fn instanced_triangles(dir: &Path, instanced: bool) -> PathBuf {
    let mut b = Builder::default();
    let pos = b.floats(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], 3);
    let nrm = b.floats(&[0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0], 3);
    let times = b.floats(&[0.0, 1.0], 1);
    let moves = b.floats(&[0.0, 0.0, 0.0, 1.0, 2.0, 3.0], 3);
    let trs = instance_trs();
    let mut nodes = vec![json!({"name": "row", "translation": [0.5, 0.0, 0.0]})];
    let root_extensions;
    if instanced {
        let t: Vec<f32> = trs.iter().flat_map(|x| x.0).collect();
        let r: Vec<i16> = trs
            .iter()
            .flat_map(|x| x.1)
            .map(|c| (c * 32767.0).round() as i16)
            .collect();
        let s: Vec<f32> = trs.iter().flat_map(|x| x.2).collect();
        let (t, r, s) = (b.floats(&t, 3), b.i16s(&r, 4, true), b.floats(&s, 3));
        nodes[0]["mesh"] = json!(0);
        nodes[0]["extensions"] = json!({"EXT_mesh_gpu_instancing": {"attributes": {
            "TRANSLATION": t, "ROTATION": r, "SCALE": s}}});
        root_extensions = json!(["EXT_mesh_gpu_instancing", "KHR_mesh_quantization"]);
    } else {
        nodes[0]["children"] = json!([1, 2, 3, 4]);
        for (t, r, s) in &trs {
            // The same rounding the instanced file's SHORT rotations get.
            let r: Vec<f32> = r.iter().map(|c| (c * 32767.0).round() / 32767.0).collect();
            nodes.push(json!({"mesh": 0, "translation": t, "rotation": r, "scale": s}));
        }
        root_extensions = json!([]);
    }
    b.write(
        json!({
            "extensionsUsed": root_extensions,
            "scenes": [{"nodes": [0]}],
            "nodes": nodes,
            "meshes": [{"primitives": [{"attributes": {"POSITION": pos, "NORMAL": nrm}}]}],
            "animations": [{"channels": [{"sampler": 0, "target": {"node": 0, "path": "translation"}}],
                            "samplers": [{"input": times, "output": moves}]}]
        }),
        dir,
        if instanced { "instanced" } else { "flat" },
        true,
    )
}

/// The bytes of a base64 `data:` URI (as [`Builder::write`] embeds them).
pub fn decode_data_uri(uri: &str) -> Vec<u8> {
    let b64 = uri.split(',').nth(1).unwrap();
    let table = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        _ => 63,
    };
    let bytes: Vec<u8> = b64.bytes().filter(|&c| c != b'=').collect();
    let mut out = Vec::new();
    for chunk in bytes.chunks(4) {
        let mut n = 0u32;
        for (i, &c) in chunk.iter().enumerate() {
            n |= (table(c) as u32) << (18 - 6 * i);
        }
        for i in 0..chunk.len().saturating_sub(1) {
            out.push((n >> (16 - 8 * i)) as u8);
        }
    }
    out
}

// ---------------------------------------------------------------------------
// KHR_draco_mesh_compression

/// A skinned, morphed grid (6 x 3 vertices, 20 triangles) as plain glTF and
/// as KHR_draco_mesh_compression, compressed by `draco-core`'s encoder.
pub struct DracoPair {
    /// The plain file: root JSON and buffer 0's bytes (for
    /// [`write_with_buffer`]).
    pub plain: (Value, Vec<u8>),
    /// The compressed file, the same way; its Draco payload is bufferView
    /// `payload_view`.
    pub draco: (Value, Vec<u8>),
    pub payload_view: usize,
    /// One step of the positions' quantization grid, in mesh units: the
    /// largest extent over the (2^bits - 1) steps the encoder kept.
    pub position_step: f64,
    /// The vertex and triangle counts the payload decodes to.
    pub points: usize,
    pub faces: usize,
}

struct GridVertex {
    position: [f32; 3],
    normal: [f32; 3],
    uv: [f32; 2],
    joints: [u8; 4],
    weights: [f32; 4],
}

/// The grid's vertex `i`: row i / 6, column i % 6, gently waved in z;
/// weighted from joint 0 at x = 0 to joint 1 at x = 5.
fn grid_vertex(i: usize) -> GridVertex {
    let (x, y) = ((i % 6) as f32, (i / 6) as f32);
    let w = x / 5.0;
    GridVertex {
        position: [x, y, 0.25 * (x * 0.7).sin() * y],
        normal: [0.0, 0.0, 1.0],
        uv: [x / 5.0, y / 2.0],
        joints: [0, 1, 0, 0],
        weights: [1.0 - w, w, 0.0, 0.0],
    }
}

/// The morph target's delta at a (decoded) position: 0.1 x along z.
pub fn grid_delta(p: [f32; 3]) -> [f32; 3] {
    [0.0, 0.0, 0.1 * p[0]]
}

fn grid_triangles() -> Vec<u32> {
    let mut idx = Vec::new();
    for y in 0..2u32 {
        for x in 0..5u32 {
            let v = y * 6 + x;
            idx.extend_from_slice(&[v, v + 1, v + 7, v, v + 7, v + 6]);
        }
    }
    idx
}

/// Nodes, skin and mesh around the given accessors: joint 2 sits 2.5 along
/// x from joint 1 and is turned 30 degrees about z, so skinning bends the
/// grid; the morph target has weight 0.5.
fn grid_document(
    attributes: Value,
    indices: usize,
    target: usize,
    ibm: usize,
    extensions: Option<Value>,
) -> Value {
    let half = 15f64.to_radians();
    let mut prim =
        json!({"attributes": attributes, "indices": indices, "targets": [{"POSITION": target}]});
    if let Some(e) = extensions {
        prim["extensions"] = e;
    }
    json!({
        "asset": {"version": "2.0"},
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [
            {"mesh": 0, "skin": 0},
            {"children": [2]},
            {"translation": [2.5, 0.0, 0.0], "rotation": [0.0, 0.0, half.sin(), half.cos()]}
        ],
        "skins": [{"joints": [1, 2], "inverseBindMatrices": ibm}],
        "meshes": [{"primitives": [prim], "weights": [0.5]}],
    })
}

fn finish(b: Builder, mut root: Value) -> (Value, Vec<u8>) {
    root["buffers"] = json!([{"byteLength": b.bin.len()}]);
    root["bufferViews"] = json!(b.views);
    root["accessors"] = json!(b.accessors);
    (root, b.bin)
}

/// `encoding_speed` picks the Draco connectivity coder: 10 sequential, 5
/// EdgeBreaker (the default), below 5 EdgeBreaker valence.
pub fn draco_grid(position_bits: i32, encoding_speed: i32) -> DracoPair {
    use draco_core::{DataType, GeometryAttributeType as G, PointAttribute};
    let n = 18;
    let verts: Vec<_> = (0..n).map(grid_vertex).collect();
    let tris = grid_triangles();
    let ibm: Vec<f32> = [
        [
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0,
        ],
        [
            1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 1.0, 0.0, -2.5, 0.0, 0.0, 1.0,
        ],
    ]
    .concat();

    // The plain twin.
    let mut b = Builder::default();
    let flat = |k: usize| -> Vec<f32> {
        verts
            .iter()
            .flat_map(|v| match k {
                0 => v.position.to_vec(),
                1 => v.normal.to_vec(),
                2 => v.uv.to_vec(),
                _ => v.weights.to_vec(),
            })
            .collect()
    };
    let pos = b.floats(&flat(0), 3);
    let nrm = b.floats(&flat(1), 3);
    let uv = b.floats(&flat(2), 2);
    let joints: Vec<u8> = verts.iter().flat_map(|v| v.joints).collect();
    let jnt = b.u8s(&joints, 4, false);
    let wgt = b.floats(&flat(3), 4);
    let idx = b.u32s(&tris);
    let deltas: Vec<f32> = verts.iter().flat_map(|v| grid_delta(v.position)).collect();
    let tgt = b.floats(&deltas, 3);
    let ibm_acc = b.floats(&ibm, 16);
    let attributes = json!({"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv, "JOINTS_0": jnt, "WEIGHTS_0": wgt});
    let plain = finish(b, grid_document(attributes, idx, tgt, ibm_acc, None));

    // The Draco mesh: POSITION, NORMAL and TEXCOORD_0 quantized, JOINTS_0
    // as bytes and WEIGHTS_0 as unquantized floats (both generic).
    let mut mesh = draco_core::Mesh::new();
    let mut add = |ty: G, comps: u8, dt: DataType, bytes: Vec<u8>| -> i32 {
        let mut a = PointAttribute::new();
        a.init(ty, comps, dt, false, n);
        a.buffer_mut().write(0, &bytes);
        mesh.add_attribute(a)
    };
    let le = |v: Vec<f32>| -> Vec<u8> { v.iter().flat_map(|f| f.to_le_bytes()).collect() };
    let a_pos = add(G::Position, 3, DataType::Float32, le(flat(0)));
    let a_nrm = add(G::Normal, 3, DataType::Float32, le(flat(1)));
    let a_uv = add(G::TexCoord, 2, DataType::Float32, le(flat(2)));
    let a_jnt = add(G::Generic, 4, DataType::Uint8, joints.clone());
    let a_wgt = add(G::Generic, 4, DataType::Float32, le(flat(3)));
    mesh.set_num_faces(tris.len() / 3);
    for (f, t) in tris.chunks_exact(3).enumerate() {
        mesh.set_face(
            draco_core::FaceIndex(f as u32),
            [t[0], t[1], t[2]].map(draco_core::PointIndex),
        );
    }
    let mut options = draco_core::EncoderOptions::new();
    options.set_global_int("encoding_speed", encoding_speed);
    options.set_global_int("decoding_speed", encoding_speed);
    options.set_attribute_quantization(a_pos, position_bits);
    options.set_attribute_quantization(a_nrm, 10);
    options.set_attribute_quantization(a_uv, 12);
    let mut encoder = draco_core::MeshEncoder::new();
    encoder.set_mesh(mesh);
    let mut out = draco_core::EncoderBuffer::new();
    encoder
        .encode(&options, &mut out)
        .expect("draco-core encodes the grid");
    let payload = out.data().to_vec();

    // What the payload decodes to: its counts are the accessors', and the
    // morph deltas follow its vertex order, as the extension asks of
    // generators.
    let mut decoded = draco_core::Mesh::new();
    draco_core::MeshDecoder::new()
        .decode(&mut draco_core::DecoderBuffer::new(&payload), &mut decoded)
        .expect("draco-core decodes its own output");
    let points = decoded.num_points();
    let faces = decoded.num_faces();
    let decoded_pos = decoded
        .attribute_by_unique_id(a_pos as u32)
        .unwrap()
        .read_f32s(points, 3);
    let (mut lo, mut hi) = ([f32::INFINITY; 3], [f32::NEG_INFINITY; 3]);
    for p in decoded_pos.chunks_exact(3) {
        for k in 0..3 {
            lo[k] = lo[k].min(p[k]);
            hi[k] = hi[k].max(p[k]);
        }
    }
    let extent = (0..3).map(|k| f64::from(hi[k] - lo[k])).fold(0.0, f64::max);
    let position_step = extent / f64::from((1u32 << position_bits) - 1);

    let mut b = Builder::default();
    let payload_view = b.view(&payload);
    let no_view = |b: &mut Builder, ct: u32, ty: &str, count: usize| {
        b.accessor(json!({"componentType": ct, "count": count, "type": ty}))
    };
    let pos = b.accessor(
        json!({"componentType": 5126, "count": points, "type": "VEC3", "min": lo, "max": hi}),
    );
    let nrm = no_view(&mut b, 5126, "VEC3", points);
    let uv = no_view(&mut b, 5126, "VEC2", points);
    let jnt = no_view(&mut b, 5121, "VEC4", points);
    let wgt = no_view(&mut b, 5126, "VEC4", points);
    let idx = no_view(&mut b, 5125, "SCALAR", faces * 3);
    let deltas: Vec<f32> = decoded_pos
        .chunks_exact(3)
        .flat_map(|p| grid_delta([p[0], p[1], p[2]]))
        .collect();
    let tgt = b.floats(&deltas, 3);
    let ibm_acc = b.floats(&ibm, 16);
    let attributes = json!({"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv, "JOINTS_0": jnt, "WEIGHTS_0": wgt});
    let ext = json!({"KHR_draco_mesh_compression": {
        "bufferView": payload_view,
        "attributes": {"POSITION": a_pos, "NORMAL": a_nrm, "TEXCOORD_0": a_uv, "JOINTS_0": a_jnt, "WEIGHTS_0": a_wgt}
    }});
    let mut root = grid_document(attributes, idx, tgt, ibm_acc, Some(ext));
    root["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
    root["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    let draco = finish(b, root);
    DracoPair {
        plain,
        draco,
        payload_view,
        position_step,
        points,
        faces,
    }
}
