//! EXT_mesh_gpu_instancing: a row of instanced triangles, and the same
//! scene flattened into plain nodes.

use super::*;

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
