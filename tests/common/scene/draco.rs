//! KHR_draco_mesh_compression: a skinned, morphed grid, plain and
//! compressed by `draco-core`'s encoder.

use super::*;

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
