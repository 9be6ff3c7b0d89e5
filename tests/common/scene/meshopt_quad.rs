//! EXT_meshopt_compression: a quad compressed with meshoptimizer's codecs.

use super::*;

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
