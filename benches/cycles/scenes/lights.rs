//! The scenes that test light selection and animation against Cycles:
//! DamagedHelmet's emissive texture in the room, a street of point lamps,
//! and CesiumMan walking beside the scan (read in place from the shared
//! folder and merged into the written scene).

use super::*;

/// DamagedHelmet (the shared folder's sample, read in place): its
/// triangles in the file's world space, their texture coordinates, and its
/// emissive image as stored (bytes and file extension).
struct Helmet {
    pts: Vec<Vec3>,
    uvs: Vec<[f32; 2]>,
    emissive: (Vec<u8>, &'static str),
}

impl Helmet {
    fn load() -> Result<Helmet, String> {
        let path = support::sample("DamagedHelmet/DamagedHelmet.glb")?;
        let err = |e: &dyn std::fmt::Display| format!("{}: {e}", path.display());
        let file = gltf::Gltf::open(&path).map_err(|e| err(&e))?;
        let blob = file
            .blob
            .as_deref()
            .ok_or_else(|| err(&"no binary chunk"))?;
        let scene = file.scenes().next().ok_or_else(|| err(&"no scene"))?;
        let mut helmet = Helmet {
            pts: Vec::new(),
            uvs: Vec::new(),
            emissive: (Vec::new(), ""),
        };
        let mut stack: Vec<(gltf::Node, glam::Mat4)> =
            scene.nodes().map(|n| (n, glam::Mat4::IDENTITY)).collect();
        while let Some((node, parent)) = stack.pop() {
            let world = parent * glam::Mat4::from_cols_array_2d(&node.transform().matrix());
            stack.extend(node.children().map(|c| (c, world)));
            let Some(mesh) = node.mesh() else { continue };
            for prim in mesh.primitives() {
                let reader = prim.reader(|b| (b.index() == 0).then_some(blob));
                let pos: Vec<Vec3> = reader
                    .read_positions()
                    .ok_or_else(|| err(&"a primitive without positions"))?
                    .map(|p| world.transform_point3(Vec3::from(p)))
                    .collect();
                let uv: Vec<[f32; 2]> = reader
                    .read_tex_coords(0)
                    .ok_or_else(|| err(&"a primitive without TEXCOORD_0"))?
                    .into_f32()
                    .collect();
                let indices: Vec<u32> = match reader.read_indices() {
                    Some(i) => i.into_u32().collect(),
                    None => (0..pos.len() as u32).collect(),
                };
                for &i in &indices {
                    let i = i as usize;
                    if i >= pos.len() || i >= uv.len() {
                        return Err(err(&"an index past the vertices"));
                    }
                    helmet.pts.push(pos[i]);
                    helmet.uvs.push(uv[i]);
                }
                let texture = prim.material().emissive_texture();
                if let Some(source) = texture.map(|t| t.texture().source().source()) {
                    let gltf::image::Source::View { view, mime_type } = source else {
                        return Err(err(&"the emissive image is not in the binary chunk"));
                    };
                    let bytes = blob
                        .get(view.offset()..view.offset() + view.length())
                        .ok_or_else(|| err(&"the emissive image is past the binary chunk"))?;
                    let ext = if mime_type == "image/png" {
                        "png"
                    } else {
                        "jpg"
                    };
                    helmet.emissive = (bytes.to_vec(), ext);
                }
            }
        }
        if helmet.emissive.0.is_empty() {
            return Err(err(&"no emissive texture"));
        }
        Ok(helmet)
    }

    /// The helmet `height` tall, standing on y = 0 at `at` (x, z), turned
    /// `turn` radians around +Y.
    fn placed(&self, height: f32, at: (f32, f32), turn: f32) -> Vec<Vec3> {
        let (lo, hi) = bounds(&self.pts);
        let scale = height / (hi.y - lo.y);
        let centre = Vec3::new(0.5 * (lo.x + hi.x), lo.y, 0.5 * (lo.z + hi.z));
        let rot = Quat::from_rotation_y(turn);
        let to = Vec3::new(at.0, 0.0, at.1);
        self.pts
            .iter()
            .map(|&p| rot * ((p - centre) * scale) + to)
            .collect()
    }
}

/// The emissive texture's strength (KHR_materials_emissive_strength): its
/// brightest texels are this many nits.
const HELMET_EMISSION: f32 = 100.0;

/// A textured emitter: the figure in white and DamagedHelmet in grey side
/// by side in the interior's room, lit only by the helmet's emissive
/// texture (no sun, no sky). The texture is mostly black: an emitter
/// sampled by area alone wastes most of its light samples.
pub(super) fn emitter_scene(inputs: &SceneInputs) -> Result<SceneFile, String> {
    let SceneInputs {
        o,
        mesh,
        figure,
        writer,
        ..
    } = *inputs;
    let helmet = Helmet::load()?;
    let image = format!("damaged-helmet-emissive.{}", helmet.emissive.1);
    writer.file(&image, &helmet.emissive.0)?;
    let mut scene = LitScene::new(figure, mesh, 0);
    scene.add("room", &room(), 0);
    let pts = helmet.placed(0.6, (-0.45, 0.55), 1.1);
    scene.add_textured("helmet", &pts, &helmet.uvs, 1);
    scene.images.push(image);
    let materials = json!([
        white(),
        {"name": "helmet", "pbrMetallicRoughness": {
            "baseColorFactor": [0.5, 0.5, 0.5, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 0.5},
         "emissiveFactor": [1.0, 1.0, 1.0],
         "emissiveTexture": {"index": 0},
         "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": HELMET_EMISSION}}}
    ]);
    scene.write(
        writer,
        &format!("{mesh}-emitter"),
        materials,
        room_camera(o),
        Lighting {
            sun: None,
            lamps: Vec::new(),
            sky: 0.0,
        },
        o.max_depth,
    )
}

/// Lamps along each side of the street: this many on each.
const LAMPS_PER_SIDE: usize = 100;
/// Their spacing along the street (m), their height, and the street's
/// half-width.
const LAMP_SPACING: f32 = 0.4;
const LAMP_HEIGHT: f32 = 0.8;
const STREET_HALF: f32 = 1.2;
/// A lamp's warm colour; a point lamp's intensity (cd) and an emissive
/// head's radiance (nits: KHR_materials_emissive_strength).
const LAMP_COLOR: [f32; 3] = [1.0, 0.8, 0.6];
const LAMP_CANDELA: f32 = 0.5;
const LAMP_NITS: f32 = 50.0;
/// An emissive lamp head's half-size (m).
const LAMP_HEAD: f32 = 0.03;

/// The 12 triangles of the axis-aligned cube of centre `c` and half-size
/// `h`, facing out.
fn cube(out: &mut Vec<Vec3>, c: Vec3, h: f32) {
    let v = |x: f32, y: f32, z: f32| c + Vec3::new(x, y, z) * h;
    let faces = [
        [
            v(-1., -1., 1.),
            v(1., -1., 1.),
            v(1., 1., 1.),
            v(-1., 1., 1.),
        ],
        [
            v(1., -1., -1.),
            v(-1., -1., -1.),
            v(-1., 1., -1.),
            v(1., 1., -1.),
        ],
        [
            v(1., -1., 1.),
            v(1., -1., -1.),
            v(1., 1., -1.),
            v(1., 1., 1.),
        ],
        [
            v(-1., -1., -1.),
            v(-1., -1., 1.),
            v(-1., 1., 1.),
            v(-1., 1., -1.),
        ],
        [
            v(-1., 1., 1.),
            v(1., 1., 1.),
            v(1., 1., -1.),
            v(-1., 1., -1.),
        ],
        [
            v(-1., -1., -1.),
            v(1., -1., -1.),
            v(1., -1., 1.),
            v(-1., -1., 1.),
        ],
    ];
    for f in faces {
        quad(out, f);
    }
}

/// Many small lights: the figure in white on the white ground at night (no
/// sun, no sky), in a street 40 m long lit by 200 lamps 0.4 m apart,
/// 100 emissive heads (small cubes) down one side and 100 point lights down
/// the other. Most lamps are far from any one point, so a light chosen in
/// proportion to power alone is mostly wasted.
pub(super) fn lamps_scene(inputs: &SceneInputs) -> Result<SceneFile, String> {
    let SceneInputs {
        o,
        mesh,
        spec,
        figure,
        writer,
    } = *inputs;
    let mut scene = LitScene::new(figure, mesh, 0);
    scene.add("ground", &ground_strips(&[])[0], 0);
    let along = |k: usize| (k as f32 - 0.5 * (LAMPS_PER_SIDE - 1) as f32) * LAMP_SPACING;
    let mut heads = Vec::new();
    for k in 0..LAMPS_PER_SIDE {
        cube(
            &mut heads,
            Vec3::new(-STREET_HALF, LAMP_HEIGHT, along(k)),
            LAMP_HEAD,
        );
    }
    scene.add("lamp-heads", &heads, 1);
    let lamps = (0..LAMPS_PER_SIDE)
        .map(|k| PointLamp {
            at: Vec3::new(STREET_HALF, LAMP_HEIGHT, along(k)),
            color: LAMP_COLOR,
            intensity: LAMP_CANDELA,
        })
        .collect();
    let materials = json!([
        white(),
        {"name": "lamp", "pbrMetallicRoughness": {
            "baseColorFactor": [0.0, 0.0, 0.0, 1.0],
            "metallicFactor": 0.0, "roughnessFactor": 1.0},
         "emissiveFactor": LAMP_COLOR,
         "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": LAMP_NITS}}}
    ]);
    scene.write(
        writer,
        &format!("{mesh}-lamps"),
        materials,
        outdoor_camera(o, spec, figure.bounds),
        Lighting {
            sun: None,
            lamps,
            sky: 0.0,
        },
        o.max_depth,
    )
}

/// The frame the animated character is rendered at: 0.5 s into its walk,
/// mid-stride.
const CHARACTER_FRAME: u32 = 12;
/// CesiumMan's height in its file (m).
const CESIUM_MAN_HEIGHT: f32 = 1.5;

/// An animated character under the sun, where per-frame work counts: the
/// figure in white on the white ground (glTF's dielectric, base 0.8,
/// roughness 1) beside CesiumMan (the shared folder's sample, read in
/// place, its skin, animation and texture merged into the scene as they
/// are), as tall as the figure, walking; rendered at `CHARACTER_FRAME`.
/// soupray evaluates the skin and rebuilds the whole scene's BVH for the
/// frame; Cycles imports the animation and syncs the frame's pose.
pub(super) fn character_scene(inputs: &SceneInputs) -> Result<SceneFile, String> {
    let SceneInputs {
        o,
        mesh,
        spec,
        figure,
        writer,
    } = *inputs;
    let path = support::sample("CesiumMan/CesiumMan.glb")?;
    let (json, bin) = read_glb(&path)?;
    let bin_name = "cesium-man.bin";
    writer.file(bin_name, &bin)?;
    let mut scene = LitScene::new(figure, mesh, 0);
    scene.add("ground", &ground_strips(&[])[0], 0);
    let materials = json!([white()]);
    // Beside the figure, on the side away from the sun's shadow.
    let (lo, hi) = figure.bounds;
    let at = Vec3::new(hi.x + 0.35, 0.0, 0.0);
    let reach = Vec3::new(0.35, 1.0, 0.35);
    let camera = outdoor_camera(o, spec, (lo.min(at - reach), hi.max(at + reach)));
    let sun = look_rotation(-dir_from(spec.sun_azimuth, spec.sun_elevation));
    let lighting = Lighting {
        sun: Some(sun),
        lamps: Vec::new(),
        sky: SUN_SKY,
    };
    let mut triangles = 0;
    let mut file = scene.write_edited(
        writer,
        &format!("{mesh}-character"),
        materials,
        (camera, lighting, o.max_depth),
        |doc| {
            triangles = merge_gltf(
                doc,
                &json,
                (bin_name, bin.len()),
                (at, 1.0 / CESIUM_MAN_HEIGHT),
            )
            .map_err(|e| format!("{}: {e}", path.display()))?;
            Ok(())
        },
    )?;
    file.triangles += triangles;
    file.frame = CHARACTER_FRAME;
    Ok(file)
}

/// A GLB file's JSON and its binary chunk.
fn read_glb(path: &Path) -> Result<(serde_json::Value, Vec<u8>), String> {
    let err = |e: &str| format!("{}: {e}", path.display());
    let data = std::fs::read(path).map_err(|e| err(&e.to_string()))?;
    let word = |at: usize| -> Result<usize, String> {
        let b = data.get(at..at + 4).ok_or_else(|| err("truncated"))?;
        Ok(u32::from_le_bytes(b.try_into().expect("4 bytes")) as usize)
    };
    if data.get(0..4) != Some(b"glTF") {
        return Err(err("not a GLB file"));
    }
    let json_len = word(12)?;
    let json_chunk = data
        .get(20..20 + json_len)
        .ok_or_else(|| err("truncated"))?;
    let json = serde_json::from_slice(json_chunk).map_err(|e| err(&e.to_string()))?;
    let bin_at = 20 + json_len;
    let bin_len = word(bin_at)?;
    let bin = data
        .get(bin_at + 8..bin_at + 8 + bin_len)
        .ok_or_else(|| err("truncated"))?
        .to_vec();
    Ok((json, bin))
}

fn shift(v: &mut serde_json::Value, by: u64) {
    if let Some(i) = v.as_u64() {
        *v = json!(i + by);
    }
}

/// Moves `obj[key]` where it is present (indexing would insert a null).
fn shift_key(obj: &mut serde_json::Value, key: &str, by: u64) {
    if let Some(v) = obj.get_mut(key) {
        shift(v, by);
    }
}

/// A material holds indices only in its texture references.
fn shift_texture_indices(v: &mut serde_json::Value, by: u64) {
    use serde_json::Value;
    match v {
        Value::Object(map) => {
            for (k, v) in map.iter_mut() {
                match v.as_u64() {
                    Some(i) if k == "index" => *v = json!(i + by),
                    _ => shift_texture_indices(v, by),
                }
            }
        }
        Value::Array(list) => list.iter_mut().for_each(|v| shift_texture_indices(v, by)),
        _ => {}
    }
}

/// Moves a merged mesh primitive's accessor and material indices past the
/// document's own; returns its triangles (`src_accessors`: the merged
/// file's accessors, which hold the counts).
fn merged_primitive(
    p: &mut serde_json::Value,
    src_accessors: &serde_json::Value,
    accessors: u64,
    materials: u64,
) -> usize {
    use serde_json::Value;
    // Counted before the shift: the indices are the merged file's.
    let counted = p.get("indices").unwrap_or(&p["attributes"]["POSITION"]);
    let count = counted
        .as_u64()
        .and_then(|i| src_accessors[i as usize]["count"].as_u64());
    for a in p["attributes"]
        .as_object_mut()
        .into_iter()
        .flat_map(|a| a.values_mut())
    {
        shift(a, accessors);
    }
    for t in p
        .get_mut("targets")
        .and_then(Value::as_array_mut)
        .into_iter()
        .flatten()
    {
        for a in t.as_object_mut().into_iter().flat_map(|a| a.values_mut()) {
            shift(a, accessors);
        }
    }
    shift_key(p, "indices", accessors);
    shift_key(p, "material", materials);
    count.unwrap_or(0) as usize / 3
}

/// Merges the glTF document `src`, whose one buffer is the file `bin` (URI,
/// bytes), into `doc` under a new node at `place` (translation, uniform
/// scale): every index it holds is moved past `doc`'s own. Returns the
/// triangles of its meshes' primitives.
fn merge_gltf(
    doc: &mut serde_json::Value,
    src: &serde_json::Value,
    bin: (&str, usize),
    (at, scale): (Vec3, f32),
) -> Result<usize, String> {
    use serde_json::Value;
    let base = |doc: &Value, key: &str| doc[key].as_array().map_or(0, Vec::len) as u64;
    let [buffer, views, accessors, images, samplers, textures, materials, meshes, skins, nodes] = [
        "buffers",
        "bufferViews",
        "accessors",
        "images",
        "samplers",
        "textures",
        "materials",
        "meshes",
        "skins",
        "nodes",
    ]
    .map(|k| base(doc, k));
    let items = |key: &str| src[key].as_array().cloned().unwrap_or_default();
    let push = |doc: &mut Value, key: &str, v: Value| {
        if !doc[key].is_array() {
            doc[key] = json!([]);
        }
        doc[key].as_array_mut().expect("an array").push(v);
    };
    if src["buffers"].as_array().map_or(0, Vec::len) != 1 || src.get("extensionsRequired").is_some()
    {
        return Err("merging needs one buffer and no required extensions".into());
    }
    push(doc, "buffers", json!({"uri": bin.0, "byteLength": bin.1}));
    for mut v in items("bufferViews") {
        v["buffer"] = json!(buffer);
        push(doc, "bufferViews", v);
    }
    for mut a in items("accessors") {
        if a.get("sparse").is_some() {
            return Err("a sparse accessor".into());
        }
        shift_key(&mut a, "bufferView", views);
        push(doc, "accessors", a);
    }
    for mut i in items("images") {
        shift_key(&mut i, "bufferView", views);
        push(doc, "images", i);
    }
    for s in items("samplers") {
        push(doc, "samplers", s);
    }
    for mut t in items("textures") {
        shift_key(&mut t, "sampler", samplers);
        shift_key(&mut t, "source", images);
        push(doc, "textures", t);
    }
    for mut m in items("materials") {
        shift_texture_indices(&mut m, textures);
        push(doc, "materials", m);
    }
    let mut triangles = 0;
    for mut m in items("meshes") {
        for p in m["primitives"].as_array_mut().into_iter().flatten() {
            triangles += merged_primitive(p, &src["accessors"], accessors, materials);
        }
        push(doc, "meshes", m);
    }
    for mut s in items("skins") {
        shift_key(&mut s, "inverseBindMatrices", accessors);
        shift_key(&mut s, "skeleton", nodes);
        for j in s["joints"].as_array_mut().into_iter().flatten() {
            shift(j, nodes);
        }
        push(doc, "skins", s);
    }
    for mut n in items("nodes") {
        shift_key(&mut n, "mesh", meshes);
        shift_key(&mut n, "skin", skins);
        for c in n
            .get_mut("children")
            .and_then(Value::as_array_mut)
            .into_iter()
            .flatten()
        {
            shift(c, nodes);
        }
        push(doc, "nodes", n);
    }
    for mut a in items("animations") {
        for s in a["samplers"].as_array_mut().into_iter().flatten() {
            shift_key(s, "input", accessors);
            shift_key(s, "output", accessors);
        }
        for c in a["channels"].as_array_mut().into_iter().flatten() {
            shift_key(&mut c["target"], "node", nodes);
        }
        push(doc, "animations", a);
    }
    let scene = src["scene"].as_u64().unwrap_or(0) as usize;
    let roots: Vec<u64> = src["scenes"][scene]["nodes"]
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(Value::as_u64)
        .map(|i| i + nodes)
        .collect();
    let placed = base(doc, "nodes");
    push(
        doc,
        "nodes",
        json!({"name": "character", "translation": at.to_array(),
               "scale": [scale, scale, scale], "children": roots}),
    );
    push(&mut doc["scenes"][0], "nodes", json!(placed));
    Ok(triangles)
}
