//! The scenes: each scanned mesh stood on a ground quad, framed by a
//! camera, under the sky alone or a sun and a dim sky, written as glTF.

use crate::opts::Opts;
use crate::support;
use crate::{SCENE_VERSION, SUN_LUX};
use glam::{Mat3, Quat, Vec3};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// How a scanned mesh is stood up and looked at.
pub struct MeshSpec {
    pub file: &'static str,
    /// From the file's axes to glTF's: +Y up, the front facing +Z.
    pub to_gltf: fn() -> Quat,
    /// Camera direction from the mesh: degrees around +Y from +Z (towards
    /// +X), and above the ground.
    pub azimuth: f32,
    pub elevation: f32,
    /// Sun: degrees around +Y from +Z (where it comes from), above the ground.
    pub sun_azimuth: f32,
    pub sun_elevation: f32,
}

pub fn mesh_spec(name: &str) -> Option<MeshSpec> {
    match name {
        // Already +Y up (feet at y = 0), facing +Z.
        "beast" => Some(MeshSpec {
            file: "beast.ply",
            to_gltf: || Quat::IDENTITY,
            azimuth: 30.0,
            elevation: 15.0,
            sun_azimuth: -40.0,
            sun_elevation: 50.0,
        }),
        // +Z up, the face towards -Y.
        "nefertiti" => Some(MeshSpec {
            file: "nefertiti.ply",
            to_gltf: || Quat::from_rotation_x(-std::f32::consts::FRAC_PI_2),
            azimuth: 35.0,
            elevation: 10.0,
            sun_azimuth: -50.0,
            sun_elevation: 40.0,
        }),
        _ => None,
    }
}

fn dir_from(azimuth_deg: f32, elevation_deg: f32) -> Vec3 {
    let (a, e) = (azimuth_deg.to_radians(), elevation_deg.to_radians());
    Vec3::new(e.cos() * a.sin(), e.sin(), e.cos() * a.cos())
}

/// A node rotation whose local -Z is `forward` and whose +Y is as close to
/// world +Y as it can be (a glTF camera looks down -Z, a light shines along it).
fn look_rotation(forward: Vec3) -> Quat {
    let back = -forward.normalize();
    let up_hint = if back.y.abs() > 0.999 {
        Vec3::Z
    } else {
        Vec3::Y
    };
    let right = up_hint.cross(back).normalize();
    let up = back.cross(right);
    Quat::from_mat3(&Mat3::from_cols(right, up, back)).normalize()
}

pub fn fnv1a(hash: u64, bytes: &[u8]) -> u64 {
    bytes.iter().fold(hash, |h, &b| {
        (h ^ b as u64).wrapping_mul(0x0000_0100_0000_01B3)
    })
}
pub const FNV_START: u64 = 0xcbf2_9ce4_8422_2325;

pub struct SceneFile {
    pub path: PathBuf,
    /// Hash of the glTF and its buffer.
    pub hash: u64,
    pub triangles: usize,
}

/// Writes `DIR/MESH.bin` (mesh then ground positions) and
/// `DIR/MESH-LIGHTING.gltf` for each lighting.
pub fn write_scenes(
    o: &Opts,
    mesh: &str,
    dir: &Path,
) -> Result<BTreeMap<String, SceneFile>, String> {
    let spec = mesh_spec(mesh).expect("checked");
    let soup = support::mesh(spec.file)?;
    let rot = (spec.to_gltf)();
    let mut pts: Vec<Vec3> = soup
        .positions
        .iter()
        .map(|p| rot * Vec3::new(p[0], p[1], p[2]))
        .collect();
    let (lo, hi) = pts.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    );
    // One unit tall, standing on y = 0, centred over the origin.
    let scale = 1.0 / (hi.y - lo.y);
    let shift = Vec3::new(-0.5 * (lo.x + hi.x), -lo.y, -0.5 * (lo.z + hi.z));
    for p in &mut pts {
        *p = (*p + shift) * scale;
    }
    let (lo, hi) = ((lo + shift) * scale, (hi + shift) * scale);
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();

    // The ground: a 40 x 40 quad at y = 0, facing up.
    let g = 20.0f32;
    let ground = [
        Vec3::new(-g, 0.0, -g),
        Vec3::new(-g, 0.0, g),
        Vec3::new(g, 0.0, g),
        Vec3::new(-g, 0.0, -g),
        Vec3::new(g, 0.0, g),
        Vec3::new(g, 0.0, -g),
    ];
    let mut bin = Vec::with_capacity((pts.len() + ground.len()) * 12);
    for p in pts.iter().chain(&ground) {
        for c in p.to_array() {
            bin.extend_from_slice(&c.to_le_bytes());
        }
    }
    let bin_name = format!("{mesh}.bin");
    std::fs::write(dir.join(&bin_name), &bin).map_err(|e| format!("{}: {e}", dir.display()))?;

    // The camera: on the view direction, far enough that the mesh's
    // bounding sphere fits the narrower field of view.
    let aspect = o.width as f32 / o.height as f32;
    let yfov = 35f32.to_radians();
    let half = (0.5 * yfov).min(((0.5 * yfov).tan() * aspect).atan());
    let distance = radius / half.sin() * 0.95;
    let view = dir_from(spec.azimuth, spec.elevation);
    let eye = centre + view * distance;
    let cam_rot = look_rotation(centre - eye);
    let sun_rot = look_rotation(-dir_from(spec.sun_azimuth, spec.sun_elevation));

    let mut out = BTreeMap::new();
    for lighting in ["sky", "sun"] {
        let mut nodes = vec![
            json!({"name": "mesh", "mesh": 0}),
            json!({"name": "ground", "mesh": 1}),
            json!({"name": "camera", "camera": 0,
                   "translation": eye.to_array(), "rotation": cam_rot.to_array()}),
        ];
        let mut doc = json!({
            "asset": {"version": "2.0", "generator": "soupray benches/cycles.rs"},
            "scene": 0,
            "scenes": [{"name": format!("{mesh}-{lighting}"), "nodes": [0, 1, 2]}],
            "cameras": [{"type": "perspective", "name": "camera", "perspective": {
                "yfov": yfov, "aspectRatio": aspect, "znear": 0.01, "zfar": 1000.0}}],
            "materials": [{"name": "white", "doubleSided": true, "pbrMetallicRoughness": {
                "baseColorFactor": [0.8, 0.8, 0.8, 1.0],
                "metallicFactor": 0.0, "roughnessFactor": 1.0}}],
            "meshes": [
                {"name": mesh, "primitives": [{"attributes": {"POSITION": 0}, "material": 0}]},
                {"name": "ground", "primitives": [{"attributes": {"POSITION": 1}, "material": 0}]}
            ],
            "accessors": [
                {"bufferView": 0, "componentType": 5126, "count": pts.len(), "type": "VEC3",
                 "min": lo.to_array(), "max": hi.to_array()},
                {"bufferView": 1, "componentType": 5126, "count": ground.len(), "type": "VEC3",
                 "min": [-g, 0.0, -g], "max": [g, 0.0, g]}
            ],
            "bufferViews": [
                {"buffer": 0, "byteOffset": 0, "byteLength": pts.len() * 12, "target": 34962},
                {"buffer": 0, "byteOffset": pts.len() * 12, "byteLength": ground.len() * 12,
                 "target": 34962}
            ],
            "buffers": [{"uri": bin_name, "byteLength": bin.len()}],
        });
        if lighting == "sun" {
            nodes.push(json!({"name": "sun", "rotation": sun_rot.to_array(),
                              "extensions": {"KHR_lights_punctual": {"light": 0}}}));
            doc["scenes"][0]["nodes"] = json!([0, 1, 2, 3]);
            doc["extensionsUsed"] = json!(["KHR_lights_punctual"]);
            doc["extensions"] = json!({"KHR_lights_punctual": {"lights": [
                {"name": "sun", "type": "directional", "color": [1.0, 1.0, 1.0],
                 "intensity": SUN_LUX}]}});
        }
        doc["nodes"] = json!(nodes);
        let text = serde_json::to_string_pretty(&doc).expect("json");
        let path = dir.join(format!("{mesh}-{lighting}.gltf"));
        std::fs::write(&path, &text).map_err(|e| format!("{}: {e}", path.display()))?;
        let hash = fnv1a(
            fnv1a(fnv1a(FNV_START, text.as_bytes()), &bin),
            &[SCENE_VERSION as u8],
        );
        out.insert(
            lighting.to_owned(),
            SceneFile {
                path,
                hash,
                triangles: soup.triangle_count() + 2,
            },
        );
    }
    Ok(out)
}
