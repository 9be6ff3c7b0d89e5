//! Shared by the `scene_*` tests (`common::scene`): paths of the shared sample models, a builder
//! for small synthetic glTF files, and an independent reference evaluator.
//!
//! The reference (`reference`) reads the JSON with serde_json and the
//! buffers by hand, does its matrix work in f64 with nalgebra, and
//! implements the glTF animation, morph and skinning rules from the
//! specification text on its own, sharing no code with `soupray::scene`.
//! Its scope is deliberately narrow (dense accessors, TRIANGLES,
//! JOINTS_0/WEIGHTS_0, POSITION morph deltas), which covers the sample
//! assets it is used on.
//!
//! This file holds the builder; the generated scenes of the compression
//! and instancing extensions have a module each, their items re-exported
//! here.

#![allow(dead_code)]

use std::path::{Path, PathBuf};

use serde_json::{json, Value};

// Re-exported so `use common::scene::*` brings the asset paths.
#[allow(unused_imports)]
pub use super::{asset, shared};

pub mod avif;
mod draco;
mod instancing;
pub mod ktx2;
mod meshopt_quad;
mod reference;

#[allow(unused_imports)]
pub use draco::{draco_grid, grid_delta, DracoPair};
#[allow(unused_imports)]
pub use instancing::{instance_trs, instanced_triangles};
#[allow(unused_imports)]
pub use meshopt_quad::meshopt_quad;
#[allow(unused_imports)]
pub use reference::{assert_soup_matches, bounds_of, instance_triangles, load, Raw};

// ---------------------------------------------------------------------------
// Synthetic files

/// A `w` x `h` RGBA8 image (rows top to bottom) encoded as PNG.
pub fn png(w: u32, h: u32, rgba: &[u8]) -> Vec<u8> {
    let mut out = Vec::new();
    image::RgbaImage::from_raw(w, h, rgba.to_vec())
        .expect("w * h * 4 bytes")
        .write_to(&mut std::io::Cursor::new(&mut out), image::ImageFormat::Png)
        .unwrap();
    out
}

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
