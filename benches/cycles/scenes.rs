//! The scenes, written as glTF: each scanned mesh stood on a ground quad,
//! framed by a camera, under the sky alone or a sun and a dim sky (clay:
//! every surface a 0.8 Lambertian); and each mesh as a rough gold figure in
//! a white room lit by the sun through a window (the file's materials,
//! where indirect light dominates).

use crate::opts::Opts;
use crate::support;
use crate::{INTERIOR_DEPTH, SCENE_VERSION, SUN_LUX, SUN_SKY};
use glam::{Mat3, Quat, Vec3};
use serde_json::json;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

mod lights;
use lights::{character_scene, emitter_scene, lamps_scene};

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
    /// The sky's radiance.
    pub env: f32,
    /// Path depth (soupray's `--max-depth`; Cycles' bounces are one less).
    pub max_depth: u32,
    /// Render the file's materials (Cycles: the importer's Principled
    /// BSDFs); otherwise clay.
    pub materials: bool,
    /// The animation frame rendered (frame N at N / 24 s).
    pub frame: u32,
}

/// One mesh of a scene: its node's and its own name, its vertices in the
/// scene's buffer (first, count), their bounds and its material; `uv`: the
/// byte offset in the buffer of its TEXCOORD_0, where it has one.
struct Part<'a> {
    node: &'a str,
    mesh: &'a str,
    first: usize,
    count: usize,
    bounds: (Vec3, Vec3),
    material: u32,
    uv: Option<usize>,
}

/// The glTF document of a scene: its nodes, materials and meshes over one
/// buffer of positions (and texture coordinates), each mesh one accessor
/// (two with coordinates); `lights`: the sun, if there is one, and point
/// lamps; `images`: the URIs of the images that the materials' textures
/// 0, 1, … sample.
fn scene_doc(
    name: &str,
    bin: (&str, usize),
    camera: (Vec3, Quat, f32, f32),
    materials: serde_json::Value,
    meshes: &[Part],
    lights: (Option<Quat>, &[PointLamp]),
    images: &[String],
) -> serde_json::Value {
    let (eye, cam_rot, yfov, aspect) = camera;
    let mut accessors: Vec<serde_json::Value> = meshes
        .iter()
        .enumerate()
        .map(|(i, m)| {
            json!(
                {"bufferView": i, "componentType": 5126, "count": m.count, "type": "VEC3",
                 "min": m.bounds.0.to_array(), "max": m.bounds.1.to_array()}
            )
        })
        .collect();
    let mut views: Vec<serde_json::Value> = meshes.iter().map(|m| json!(
        {"buffer": 0, "byteOffset": m.first * 12, "byteLength": m.count * 12, "target": 34962}
    )).collect();
    let mut primitives = Vec::new();
    for (i, m) in meshes.iter().enumerate() {
        let mut attributes = json!({"POSITION": i});
        if let Some(offset) = m.uv {
            attributes["TEXCOORD_0"] = json!(accessors.len());
            accessors.push(json!({"bufferView": views.len(), "componentType": 5126,
                                  "count": m.count, "type": "VEC2"}));
            views.push(
                json!({"buffer": 0, "byteOffset": offset, "byteLength": m.count * 8,
                              "target": 34962}),
            );
        }
        primitives.push(json!([{"attributes": attributes, "material": m.material}]));
    }
    let mut nodes: Vec<serde_json::Value> = meshes
        .iter()
        .enumerate()
        .map(|(i, m)| json!({"name": m.node, "mesh": i}))
        .collect();
    nodes.push(json!({"name": "camera", "camera": 0,
                      "translation": eye.to_array(), "rotation": cam_rot.to_array()}));
    let mut doc = json!({
        "asset": {"version": "2.0", "generator": "soupray benches/cycles.rs"},
        "scene": 0,
        "cameras": [{"type": "perspective", "name": "camera", "perspective": {
            "yfov": yfov, "aspectRatio": aspect, "znear": 0.01, "zfar": 1000.0}}],
        "materials": materials,
        "meshes": meshes.iter().zip(primitives).map(|(m, p)| json!(
            {"name": m.mesh, "primitives": p}
        )).collect::<Vec<_>>(),
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"uri": bin.0, "byteLength": bin.1}],
    });
    if !images.is_empty() {
        doc["samplers"] = json!([{"magFilter": 9729, "minFilter": 9729}]);
        doc["images"] = json!(images
            .iter()
            .map(|uri| json!({"uri": uri}))
            .collect::<Vec<_>>());
        doc["textures"] = json!((0..images.len())
            .map(|i| json!({"source": i, "sampler": 0}))
            .collect::<Vec<_>>());
    }
    // The materials' extensions, then the sun's.
    let mut used: Vec<String> = doc["materials"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(|m| m["extensions"].as_object())
        .flat_map(|e| e.keys().cloned())
        .collect();
    used.sort();
    used.dedup();
    let (sun, lamps) = lights;
    let mut punctual = Vec::new();
    if let Some(sun_rot) = sun {
        nodes.push(json!({"name": "sun", "rotation": sun_rot.to_array(),
                          "extensions": {"KHR_lights_punctual": {"light": punctual.len()}}}));
        punctual.push(
            json!({"name": "sun", "type": "directional", "color": [1.0, 1.0, 1.0],
                             "intensity": SUN_LUX}),
        );
    }
    for (k, lamp) in lamps.iter().enumerate() {
        let name = format!("lamp-{k}");
        nodes.push(json!({"name": name, "translation": lamp.at.to_array(),
                          "extensions": {"KHR_lights_punctual": {"light": punctual.len()}}}));
        punctual.push(json!({"name": name, "type": "point", "color": lamp.color,
                             "intensity": lamp.intensity}));
    }
    if !punctual.is_empty() {
        used.push("KHR_lights_punctual".to_owned());
        doc["extensions"] = json!({"KHR_lights_punctual": {"lights": punctual}});
    }
    if !used.is_empty() {
        doc["extensionsUsed"] = json!(used);
    }
    doc["scenes"] = json!([{"name": name, "nodes": (0..nodes.len()).collect::<Vec<_>>()}]);
    doc["nodes"] = json!(nodes);
    doc
}

/// The scenes' white: glTF's dielectric, base 0.8, roughness 1,
/// double-sided.
fn white() -> serde_json::Value {
    json!({"name": "white", "doubleSided": true, "pbrMetallicRoughness": {
        "baseColorFactor": [0.8, 0.8, 0.8, 1.0],
        "metallicFactor": 0.0, "roughnessFactor": 1.0}})
}

fn bounds(pts: &[Vec3]) -> (Vec3, Vec3) {
    pts.iter().fold(
        (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY)),
        |(lo, hi), &p| (lo.min(p), hi.max(p)),
    )
}

/// Two triangles of the quad `a b c d` (counter-clockwise seen from where
/// it faces).
fn quad(out: &mut Vec<Vec3>, [a, b, c, d]: [Vec3; 4]) {
    out.extend([a, b, c, a, c, d]);
}

/// The room of the interior around a figure one unit tall at the origin:
/// 3 x 2.2 x 3 m, floor at y = 0, facing in, with a 1.2 x 1 m window in
/// the wall at x = -1.5.
fn room() -> Vec<Vec3> {
    let (x, y, z) = (1.5f32, 2.2f32, 1.5f32);
    let (wy0, wy1, wz) = (0.6f32, 1.6f32, 0.6f32);
    let v = Vec3::new;
    let mut t = Vec::new();
    quad(
        &mut t,
        [v(-x, 0., -z), v(-x, 0., z), v(x, 0., z), v(x, 0., -z)],
    ); // floor
    quad(&mut t, [v(-x, y, -z), v(x, y, -z), v(x, y, z), v(-x, y, z)]); // ceiling
    quad(&mut t, [v(x, 0., -z), v(x, 0., z), v(x, y, z), v(x, y, -z)]); // +x wall
    quad(
        &mut t,
        [v(-x, 0., -z), v(x, 0., -z), v(x, y, -z), v(-x, y, -z)],
    ); // -z wall
    quad(&mut t, [v(-x, 0., z), v(-x, y, z), v(x, y, z), v(x, 0., z)]); // +z wall

    // The window wall, around its opening.
    let wall = |t: &mut Vec<Vec3>, (y0, y1): (f32, f32), (z0, z1): (f32, f32)| {
        quad(
            t,
            [v(-x, y0, z0), v(-x, y0, z1), v(-x, y1, z1), v(-x, y1, z0)],
        );
    };
    wall(&mut t, (0., wy0), (-z, z));
    wall(&mut t, (wy1, y), (-z, z));
    wall(&mut t, (wy0, wy1), (-z, -wz));
    wall(&mut t, (wy0, wy1), (wz, z));
    t
}

/// A scanned mesh in the bench's frame: one unit tall, standing on y = 0,
/// centred over the origin.
struct Figure {
    pts: Vec<Vec3>,
    bounds: (Vec3, Vec3),
    triangles: usize,
}

impl Figure {
    fn load(spec: &MeshSpec) -> Result<Figure, String> {
        let soup = support::mesh(spec.file)?;
        let rot = (spec.to_gltf)();
        let mut pts: Vec<Vec3> = soup
            .positions
            .iter()
            .map(|p| rot * Vec3::new(p[0], p[1], p[2]))
            .collect();
        let (lo, hi) = bounds(&pts);
        let scale = 1.0 / (hi.y - lo.y);
        let shift = Vec3::new(-0.5 * (lo.x + hi.x), -lo.y, -0.5 * (lo.z + hi.z));
        for p in &mut pts {
            *p = (*p + shift) * scale;
        }
        Ok(Figure {
            pts,
            bounds: ((lo + shift) * scale, (hi + shift) * scale),
            triangles: soup.triangle_count(),
        })
    }

    /// The figure as the scene's first mesh, in `material`.
    fn part<'a>(&self, mesh: &'a str, material: u32) -> Part<'a> {
        Part {
            node: "mesh",
            mesh,
            first: 0,
            count: self.pts.len(),
            bounds: self.bounds,
            material,
            uv: None,
        }
    }
}

/// Writes a scene's buffer and glTF into one folder.
struct SceneWriter<'a> {
    dir: &'a Path,
}

impl SceneWriter<'_> {
    /// `DIR/NAME`, holding `bytes`.
    fn file(&self, name: &str, bytes: &[u8]) -> Result<(), String> {
        let path = self.dir.join(name);
        std::fs::write(&path, bytes).map_err(|e| format!("{}: {e}", path.display()))
    }

    /// `DIR/NAME`: the positions, little-endian f32, then `tail`; returns
    /// its bytes.
    fn bin(
        &self,
        name: &str,
        pts: &[Vec3],
        tail: impl Iterator<Item = u8>,
    ) -> Result<Vec<u8>, String> {
        let bin: Vec<u8> = pts
            .iter()
            .flat_map(|p| p.to_array())
            .flat_map(f32::to_le_bytes)
            .chain(tail)
            .collect();
        std::fs::write(self.dir.join(name), &bin)
            .map_err(|e| format!("{}: {e}", self.dir.display()))?;
        Ok(bin)
    }

    /// `DIR/NAME.gltf`; returns its path and the hash of the scene (text,
    /// buffer and scene version), which keys the cached references.
    fn gltf(
        &self,
        name: &str,
        doc: &serde_json::Value,
        bin: &[u8],
    ) -> Result<(PathBuf, u64), String> {
        let text = serde_json::to_string_pretty(doc).expect("json");
        let path = self.dir.join(format!("{name}.gltf"));
        std::fs::write(&path, &text).map_err(|e| format!("{}: {e}", path.display()))?;
        let hash = fnv1a(
            fnv1a(fnv1a(FNV_START, text.as_bytes()), bin),
            &[SCENE_VERSION as u8],
        );
        Ok((path, hash))
    }
}

/// What every scene of a mesh is written from.
#[derive(Clone, Copy)]
struct SceneInputs<'a> {
    o: &'a Opts,
    mesh: &'a str,
    spec: &'a MeshSpec,
    figure: &'a Figure,
    writer: &'a SceneWriter<'a>,
}

/// Writes `DIR/MESH.bin` (mesh then ground positions) and
/// `DIR/MESH-LIGHTING.gltf` for each lighting; the interior has its own
/// buffer, `DIR/MESH-interior.bin`.
pub fn write_scenes(
    o: &Opts,
    mesh: &str,
    dir: &Path,
) -> Result<BTreeMap<String, SceneFile>, String> {
    let spec = mesh_spec(mesh).expect("checked");
    let figure = Figure::load(&spec)?;
    let writer = SceneWriter { dir };
    let inputs = SceneInputs {
        o,
        mesh,
        spec: &spec,
        figure: &figure,
        writer: &writer,
    };
    let mut out = outdoor_scenes(&inputs)?;
    out.insert("interior".to_owned(), interior_scene(&inputs)?);
    out.insert("glossy".to_owned(), glossy_scene(&inputs)?);
    out.insert("glass".to_owned(), glass_scene(&inputs)?);
    out.insert("emitter".to_owned(), emitter_scene(&inputs)?);
    out.insert("lamps".to_owned(), lamps_scene(&inputs)?);
    out.insert("character".to_owned(), character_scene(&inputs)?);
    Ok(out)
}

/// The figure on a ground quad in clay, under the sky and under the sun.
fn outdoor_scenes(inputs: &SceneInputs) -> Result<BTreeMap<String, SceneFile>, String> {
    let SceneInputs {
        o,
        mesh,
        spec,
        figure,
        writer,
    } = *inputs;
    let g = GROUND_HALF;
    let ground = ground_strips(&[]).remove(0);
    let bin_name = format!("{mesh}.bin");
    let bin = writer.bin(
        &bin_name,
        &[figure.pts.as_slice(), &ground].concat(),
        std::iter::empty(),
    )?;

    let (eye, cam_rot, yfov, aspect) = outdoor_camera(o, spec, figure.bounds);
    let sun_rot = look_rotation(-dir_from(spec.sun_azimuth, spec.sun_elevation));
    let materials = json!([white()]);
    let meshes = [
        figure.part(mesh, 0),
        Part {
            node: "ground",
            mesh: "ground",
            first: figure.pts.len(),
            count: ground.len(),
            bounds: (Vec3::new(-g, 0.0, -g), Vec3::new(g, 0.0, g)),
            material: 0,
            uv: None,
        },
    ];

    let mut out = BTreeMap::new();
    for (lighting, env) in [("sky", 1.0), ("sun", SUN_SKY)] {
        let name = format!("{mesh}-{lighting}");
        let doc = scene_doc(
            &name,
            (&bin_name, bin.len()),
            (eye, cam_rot, yfov, aspect),
            materials.clone(),
            &meshes,
            ((lighting == "sun").then_some(sun_rot), &[]),
            &[],
        );
        let (path, hash) = writer.gltf(&name, &doc, &bin)?;
        out.insert(
            lighting.to_owned(),
            SceneFile {
                path,
                hash,
                triangles: figure.triangles + 2,
                env,
                max_depth: o.max_depth,
                materials: false,
                frame: 0,
            },
        );
    }
    Ok(out)
}

/// The camera of the outdoor scenes: on the mesh's view direction, far
/// enough that its bounding sphere fits the narrower field of view. Eye,
/// rotation, vertical field of view and aspect.
fn outdoor_camera(o: &Opts, spec: &MeshSpec, (lo, hi): (Vec3, Vec3)) -> (Vec3, Quat, f32, f32) {
    let centre = 0.5 * (lo + hi);
    let radius = 0.5 * (hi - lo).length();
    let aspect = o.width as f32 / o.height as f32;
    let yfov = 35f32.to_radians();
    let half = (0.5 * yfov).min(((0.5 * yfov).tan() * aspect).atan());
    let distance = radius / half.sin() * 0.95;
    let eye = centre + dir_from(spec.azimuth, spec.elevation) * distance;
    (eye, look_rotation(centre - eye), yfov, aspect)
}

/// A scene that renders its glTF materials: its meshes, the figure first,
/// over one buffer (every mesh's positions, then the texture coordinates
/// of those that have them), and the images its textures sample.
struct LitScene<'a> {
    pts: Vec<Vec3>,
    uvs: Vec<[f32; 2]>,
    /// Each part with coordinates: its index and first coordinate.
    uv_parts: Vec<(usize, usize)>,
    parts: Vec<Part<'a>>,
    images: Vec<String>,
}

/// How a scene is lit: the sun's rotation, if it has one, its point lamps,
/// and the sky's radiance.
struct Lighting {
    sun: Option<Quat>,
    lamps: Vec<PointLamp>,
    sky: f32,
}

/// A KHR_lights_punctual point light: where, its colour and its intensity
/// (candela).
struct PointLamp {
    at: Vec3,
    color: [f32; 3],
    intensity: f32,
}

impl<'a> LitScene<'a> {
    fn new(figure: &Figure, mesh: &'a str, material: u32) -> LitScene<'a> {
        LitScene {
            pts: figure.pts.clone(),
            uvs: Vec::new(),
            uv_parts: Vec::new(),
            parts: vec![figure.part(mesh, material)],
            images: Vec::new(),
        }
    }

    /// Adds mesh `name`, the triangles `tris`, in `material`.
    fn add(&mut self, name: &'a str, tris: &[Vec3], material: u32) {
        self.parts.push(Part {
            node: name,
            mesh: name,
            first: self.pts.len(),
            count: tris.len(),
            bounds: bounds(tris),
            material,
            uv: None,
        });
        self.pts.extend_from_slice(tris);
    }

    /// Adds mesh `name` with texture coordinates `uvs` (one per vertex of
    /// `tris`).
    fn add_textured(&mut self, name: &'a str, tris: &[Vec3], uvs: &[[f32; 2]], material: u32) {
        self.uv_parts.push((self.parts.len(), self.uvs.len()));
        self.uvs.extend_from_slice(uvs);
        self.add(name, tris, material);
    }

    /// `write` with the outdoor scenes' camera and sun, at depth
    /// `--max-depth`.
    fn write_outdoor(
        self,
        inputs: &SceneInputs,
        name: &str,
        materials: serde_json::Value,
    ) -> Result<SceneFile, String> {
        let SceneInputs {
            o, spec, figure, ..
        } = *inputs;
        let sun = look_rotation(-dir_from(spec.sun_azimuth, spec.sun_elevation));
        self.write(
            inputs.writer,
            name,
            materials,
            outdoor_camera(o, spec, figure.bounds),
            Lighting {
                sun: Some(sun),
                lamps: Vec::new(),
                sky: SUN_SKY,
            },
            o.max_depth,
        )
    }

    /// Writes `DIR/NAME.bin` and `DIR/NAME.gltf`.
    fn write(
        self,
        writer: &SceneWriter,
        name: &str,
        materials: serde_json::Value,
        camera: (Vec3, Quat, f32, f32),
        lighting: Lighting,
        max_depth: u32,
    ) -> Result<SceneFile, String> {
        let view = (camera, lighting, max_depth);
        self.write_edited(writer, name, materials, view, |_| Ok(()))
    }

    /// `write`, with the glTF document changed by `edit` before it is
    /// written.
    fn write_edited(
        mut self,
        writer: &SceneWriter,
        name: &str,
        materials: serde_json::Value,
        (camera, lighting, max_depth): ((Vec3, Quat, f32, f32), Lighting, u32),
        edit: impl FnOnce(&mut serde_json::Value) -> Result<(), String>,
    ) -> Result<SceneFile, String> {
        let uv_base = self.pts.len() * 12;
        for &(part, first) in &self.uv_parts {
            self.parts[part].uv = Some(uv_base + first * 8);
        }
        let bin_name = format!("{name}.bin");
        let uv_bytes = self.uvs.iter().flatten().flat_map(|v| v.to_le_bytes());
        let bin = writer.bin(&bin_name, &self.pts, uv_bytes)?;
        let mut doc = scene_doc(
            name,
            (&bin_name, bin.len()),
            camera,
            materials,
            &self.parts,
            (lighting.sun, &lighting.lamps),
            &self.images,
        );
        edit(&mut doc)?;
        let (path, hash) = writer.gltf(name, &doc, &bin)?;
        Ok(SceneFile {
            path,
            hash,
            triangles: self.pts.len() / 3,
            env: lighting.sky,
            max_depth,
            frame: 0,
            materials: true,
        })
    }
}

/// The camera of the scenes in the room: in the far corner, looking back at
/// the window wall and the figure. Eye, rotation, vertical field of view
/// and aspect.
fn room_camera(o: &Opts) -> (Vec3, Quat, f32, f32) {
    let eye = Vec3::new(1.3, 1.3, 1.3);
    let cam_rot = look_rotation(Vec3::new(-0.6, 0.45, -0.3) - eye);
    (
        eye,
        cam_rot,
        60f32.to_radians(),
        o.width as f32 / o.height as f32,
    )
}

/// The interior: the figure in rough gold, the room white (glTF's
/// dielectric at roughness 1, its specular layer included), the sun
/// through the window onto the floor beside the figure, and the camera in
/// the far corner looking back at both.
fn interior_scene(inputs: &SceneInputs) -> Result<SceneFile, String> {
    let SceneInputs {
        o,
        mesh,
        figure,
        writer,
        ..
    } = *inputs;
    let mut scene = LitScene::new(figure, mesh, 1);
    scene.add("room", &room(), 0);
    let materials = json!([
        white(),
        {"name": "gold", "doubleSided": true, "pbrMetallicRoughness": {
            "baseColorFactor": [1.0, 0.766, 0.336, 1.0],
            "metallicFactor": 1.0, "roughnessFactor": 0.4}}
    ]);
    scene.write(
        writer,
        &format!("{mesh}-interior"),
        materials,
        room_camera(o),
        Lighting {
            sun: Some(look_rotation(Vec3::new(1.0, -0.7, 0.25))),
            lamps: Vec::new(),
            sky: SUN_SKY,
        },
        INTERIOR_DEPTH,
    )
}

/// Half the side of the outdoor scenes' ground.
const GROUND_HALF: f32 = 20.0;

/// The ground of the outdoor scenes, split into strips at these x: a 40 x
/// 40 quad at y = 0 facing up, one strip per pair.
fn ground_strips(cuts: &[f32]) -> Vec<Vec<Vec3>> {
    let g = GROUND_HALF;
    let xs: Vec<f32> = [-g]
        .into_iter()
        .chain(cuts.iter().copied())
        .chain([g])
        .collect();
    xs.windows(2)
        .map(|x| {
            let mut t = Vec::new();
            quad(
                &mut t,
                [
                    Vec3::new(x[0], 0.0, -g),
                    Vec3::new(x[0], 0.0, g),
                    Vec3::new(x[1], 0.0, g),
                    Vec3::new(x[1], 0.0, -g),
                ],
            );
            t
        })
        .collect()
}

/// Glossy surfaces at several roughnesses under the sun: the figure in
/// polished silver (roughness 0.2) on a ground of three grey dielectric
/// strips (glTF's specular layer over a 0.5 base) at roughness 0.05, 0.25
/// and 0.6, the figure on the middle one.
fn glossy_scene(inputs: &SceneInputs) -> Result<SceneFile, String> {
    let mesh = inputs.mesh;
    let mut scene = LitScene::new(inputs.figure, mesh, 0);
    let strips = ground_strips(&[-0.5, 0.5]);
    for (k, (strip, name)) in strips
        .iter()
        .zip(["strip-a", "strip-b", "strip-c"])
        .enumerate()
    {
        scene.add(name, strip, k as u32 + 1);
    }
    let grey = |name: &str, roughness: f32| {
        json!({"name": name, "doubleSided": true, "pbrMetallicRoughness": {
            "baseColorFactor": [0.5, 0.5, 0.5, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": roughness}})
    };
    let materials = json!([
        {"name": "silver", "doubleSided": true, "pbrMetallicRoughness": {
            "baseColorFactor": [0.97, 0.96, 0.91, 1.0],
            "metallicFactor": 1.0, "roughnessFactor": 0.2}},
        grey("grey-0.05", 0.05),
        grey("grey-0.25", 0.25),
        grey("grey-0.6", 0.6)
    ]);
    scene.write_outdoor(inputs, &format!("{mesh}-glossy"), materials)
}

/// Glass over diffuse: the figure in clear glass (KHR_materials_transmission
/// with a volume, so both renderers refract through a solid, IOR 1.5,
/// smooth) on the white ground (glTF's dielectric, base 0.8, roughness 1),
/// under the sun and sky.
fn glass_scene(inputs: &SceneInputs) -> Result<SceneFile, String> {
    let mesh = inputs.mesh;
    let mut scene = LitScene::new(inputs.figure, mesh, 1);
    scene.add("ground", &ground_strips(&[])[0], 0);
    let materials = json!([
        white(),
        {"name": "glass", "pbrMetallicRoughness": {
            "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 0.0},
         "extensions": {
            "KHR_materials_transmission": {"transmissionFactor": 1.0},
            "KHR_materials_volume": {"thicknessFactor": 0.1}}}
    ]);
    scene.write_outdoor(inputs, &format!("{mesh}-glass"), materials)
}
