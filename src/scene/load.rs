//! Building a [`Scene`] from a file: the node hierarchy (checked to be a
//! forest), the chosen scene, animation and camera, meshes, skins, lights
//! and materials. Everything that does not depend on time is settled here
//! so that evaluating a frame cannot fail on the file's structure.

use std::path::Path;
use std::sync::OnceLock;

use glam::{Mat4, Quat, Vec3};

use super::accessor::Reader;
use super::animation::load_clip;
use super::camera::{load_camera, Projection};
use super::error::{Result, SceneError};
use super::light::load_light;
use super::material::{Material, MaterialTable};
use super::material_load::load_materials;
use super::mesh::{load_mesh, Skipped};
use super::source;
use super::{CameraDef, Clip, LightDef, LoadOptions, Mesh, MeshInstance, Node, Scene, Skin, Trs};

/// The most mesh instances a scene may have (EXT_mesh_gpu_instancing
/// instances included): a bound on what a small file can make soupray
/// allocate per instance, far above real scenes (a forest of 10^6 trees).
const MAX_MESH_INSTANCES: usize = 1 << 24;

pub(super) fn load(path: &Path, opts: &LoadOptions) -> Result<Scene> {
    let file = path.display().to_string();
    if !(opts.fps.is_finite() && opts.fps > 0.0) {
        return Err(SceneError::selection(
            &file,
            format!(
                "--fps {} is not a positive number of frames per second. Fix: pass e.g. --fps 24.",
                opts.fps
            ),
        ));
    }
    let src = source::load(path)?;
    let doc = &src.document;
    let reader = Reader { src: &src };
    let mut warnings = src.warnings.clone();

    let nodes = load_nodes(&file, doc)?;
    let node_order = order_nodes(&file, &nodes)?;

    let selection = select_scene(&file, doc, &nodes, opts.scene, &mut warnings)?;
    let (scene_count, scene_index) = (selection.count, selection.index);
    let scene_nodes = selection.nodes;

    // Materials first: which second uv set the meshes need depends on them.
    let mut materials = load_materials(&src)?;
    for (i, m) in materials.materials.iter_mut().enumerate() {
        super::ranges::material(i, m, &mut warnings);
    }
    warnings.extend(super::material_load::ignored_material_extensions(&src.json));
    let second_uv_set = choose_second_uv_set(&mut materials, &mut warnings);

    let mut meshes = load_meshes(&reader, doc, opts.sanitize, second_uv_set, &mut warnings)?;
    let skins = load_skins(&reader, doc)?;
    let cx = Ctx {
        file: &file,
        reader: &reader,
        nodes: &nodes,
    };
    let instances = place_instances(&cx, &scene_nodes, &meshes, &skins, &mut warnings)?;
    super::soup_size::check_scene_fits(&file, &instances, &meshes)?;
    let (clips, clip) = load_animations(&cx, &meshes, opts.animation.as_deref(), &mut warnings)?;

    // Cameras and lights placed in the scene.
    let mut cameras: Vec<_> = doc.cameras().map(|c| load_camera(&c)).collect();
    physical_cameras(&src.json, &mut cameras, &mut warnings);
    for (i, c) in cameras.iter_mut().enumerate() {
        super::ranges::camera(i, c, &mut warnings);
    }
    let camera_instance = choose_camera(&cx, &scene_nodes, &cameras, opts.camera.as_ref())?;
    let (lights, light_instances) = load_lights(doc, &nodes, &scene_nodes, &mut warnings);

    let variants = super::material_load::variant_names(&src.json);
    if let Some(want) = &opts.variant {
        apply_variant(&file, &src.json, doc, want, &variants, &mut meshes)?;
    }

    // Materials, with the glTF default material appended for primitives
    // that name none, so every triangle's id indexes the table.
    let needs_default = instances
        .iter()
        .flat_map(|i| &meshes[i.mesh].primitives)
        .any(|p| p.material.is_none());
    if needs_default {
        materials.default_material = Some(materials.materials.len() as u32);
        materials.materials.push(Material::default());
    }

    let environment = file_environment(&src.json, scene_index, &mut warnings);

    let instanced = || instances.iter().flat_map(|i| &meshes[i.mesh].primitives);
    let soup_has_normals = instanced().any(|p| p.normals.is_some());
    let soup_has_uvs = instanced().any(|p| p.uvs.is_some());
    let soup_has_uvs1 = instanced().any(|p| p.uvs1.is_some());
    let soup_has_colors = instanced().any(|p| p.colors.is_some());
    if let (Some(set), false) = (second_uv_set, soup_has_uvs1) {
        warnings.push(format!(
            "materials sample textures through TEXCOORD_{set}, but no mesh in the scene has it: \
             those textures are read at uv (0, 0). Fix: re-export the meshes with that uv set."
        ));
    }

    Ok(Scene {
        file,
        options: opts.clone(),
        node_order,
        scene_index,
        scene_count,
        instances,
        meshes,
        skins,
        clips,
        clip,
        cameras,
        camera_instance,
        lights,
        light_instances,
        materials,
        warnings,
        extensions_used: doc.extensions_used().map(str::to_owned).collect(),
        variants,
        // From the file itself: the document handed to the `gltf` crate
        // lacks the required extensions soupray reads on its own.
        extensions_required: src
            .json
            .get("extensionsRequired")
            .and_then(|r| r.as_array())
            .map(|r| {
                r.iter()
                    .filter_map(|e| e.as_str().map(str::to_owned))
                    .collect()
            })
            .unwrap_or_default(),
        soup_has_normals,
        soup_has_uvs,
        soup_has_uvs1,
        soup_has_colors,
        second_uv_set,
        environment,
        clip_bounds: OnceLock::new(),
        nodes,
    })
}

/// What the steps of [`load`] that check objects against the node
/// hierarchy read: the file's name (for errors), its accessors and
/// document, and its nodes.
struct Ctx<'a> {
    file: &'a str,
    reader: &'a Reader<'a>,
    nodes: &'a [Node],
}

/// How errors and warnings name node `i`.
fn node_label(nodes: &[Node], i: usize) -> String {
    match &nodes[i].name {
        Some(n) => format!("node {i} \"{n}\""),
        None => format!("node {i}"),
    }
}

/// The scene to render.
struct SceneSelection {
    /// How many scenes the file has.
    count: usize,
    index: Option<usize>,
    /// Its nodes, depth first, parents before children.
    nodes: Vec<usize>,
}

// The scene: explicit, else the file's default, else scene 0; a file
// without scenes shows every root node.
fn select_scene(
    file: &str,
    doc: &gltf::Document,
    nodes: &[Node],
    want: Option<usize>,
    warnings: &mut Vec<String>,
) -> Result<SceneSelection> {
    let label_of = |i: usize| node_label(nodes, i);
    let scene_count = doc.scenes().count();
    let scene_index = match want {
        Some(s) if s >= scene_count => {
            return Err(SceneError::selection(
                file,
                format!(
                    "--scene {s} does not exist: the file has {scene_count} scene(s) (0..{}). Fix: pass a valid index, \
                     or see `soupray info` for the list.",
                    scene_count.saturating_sub(1)
                ),
            ))
        }
        Some(s) => Some(s),
        None => doc.default_scene().map(|s| s.index()).or((scene_count > 0).then_some(0)),
    };
    let roots: Vec<usize> = match scene_index.and_then(|s| doc.scenes().nth(s)) {
        Some(scene) => scene.nodes().map(|n| n.index()).collect(),
        None => {
            if !nodes.is_empty() {
                warnings.push("the file defines no scene; every root node is shown".to_owned());
            }
            (0..nodes.len())
                .filter(|&n| nodes[n].parent.is_none())
                .collect()
        }
    };
    for &r in &roots {
        if let Some(p) = nodes[r].parent {
            return Err(SceneError::invalid(
                file,
                format!(
                    "{} is a root of scene {} but also a child of {}; glTF requires scene roots to have no parent. \
                     Fix: re-export the scene.",
                    label_of(r),
                    scene_index.unwrap_or(0),
                    label_of(p)
                ),
            ));
        }
    }
    let mut scene_nodes = Vec::new();
    let mut stack: Vec<usize> = roots.iter().rev().copied().collect();
    while let Some(n) = stack.pop() {
        scene_nodes.push(n);
        stack.extend(nodes[n].children.iter().rev().copied());
    }
    Ok(SceneSelection {
        count: scene_count,
        index: scene_index,
        nodes: scene_nodes,
    })
}

/// Every mesh of the file, with one warning for all the primitives
/// skipped for not being triangles.
fn load_meshes(
    reader: &Reader,
    doc: &gltf::Document,
    sanitize: bool,
    second_uv_set: Option<u32>,
    warnings: &mut Vec<String>,
) -> Result<Vec<Mesh>> {
    let mut skipped = Skipped::default();
    let mut meshes = Vec::new();
    for mesh in doc.meshes() {
        meshes.push(load_mesh(
            reader,
            &mesh,
            sanitize,
            second_uv_set,
            &mut skipped,
            warnings,
        )?);
    }
    if !skipped.by_mode.is_empty() {
        let mut modes: Vec<&str> = skipped.by_mode.iter().map(|(m, _)| *m).collect();
        modes.sort_unstable();
        modes.dedup();
        let places: Vec<&str> = skipped.by_mode.iter().map(|(_, w)| w.as_str()).collect();
        warnings.push(format!(
            "skipped {} {} primitive(s) ({}): soupray traces triangles only",
            skipped.by_mode.len(),
            modes.join("/"),
            places.join(", ")
        ));
    }
    Ok(meshes)
}

/// Every skin of the file, with as many inverse bind matrices as joints
/// (identities when the file gives none).
fn load_skins(reader: &Reader, doc: &gltf::Document) -> Result<Vec<Skin>> {
    let mut skins = Vec::new();
    for skin in doc.skins() {
        let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
        let joint_from_bind = match skin.inverse_bind_matrices() {
            Some(acc) => {
                let usage = format!("inverse bind matrices of skin {}", skin.index());
                let m = reader.mat4s(&acc, &usage)?;
                if m.len() < joints.len() {
                    return Err(reader.error(
                        &acc,
                        &usage,
                        format!(
                            "has {} matrices but the skin has {} joints. Fix: re-export the skin.",
                            m.len(),
                            joints.len()
                        ),
                    ));
                }
                m
            }
            None => vec![Mat4::IDENTITY; joints.len()],
        };
        skins.push(Skin {
            name: skin.name().map(str::to_owned),
            joints,
            joint_from_bind,
        });
    }
    Ok(skins)
}

// Mesh instances of the scene, with their skins checked against the
// joint numbers their vertices use.
fn place_instances(
    cx: &Ctx,
    scene_nodes: &[usize],
    meshes: &[Mesh],
    skins: &[Skin],
    warnings: &mut Vec<String>,
) -> Result<Vec<MeshInstance>> {
    let (file, reader, nodes) = (cx.file, cx.reader, cx.nodes);
    let label_of = |i: usize| node_label(nodes, i);
    let mut instances = Vec::new();
    for &n in scene_nodes {
        let Some(mesh) = nodes[n].mesh else { continue };
        let skin = instance_skin(cx, n, mesh, meshes, skins, warnings)?;
        if let Some(w) = &nodes[n].weights {
            if w.len() != meshes[mesh].target_count {
                return Err(SceneError::invalid(
                    file,
                    format!(
                        "{} has {} morph weights but its mesh has {} morph targets. Fix: re-export the scene.",
                        label_of(n),
                        w.len(),
                        meshes[mesh].target_count
                    ),
                ));
            }
        }
        let label = label_of(n);
        match super::instancing::node_instances(reader, &reader.src.json, n, &label)? {
            None => instances.push(MeshInstance {
                node: n,
                mesh,
                skin,
                node_from_instance: None,
            }),
            Some(transforms) => {
                // Bounded before the instances are made: each costs a slot,
                // and the soup they expand to is checked below.
                let total = instances.len().saturating_add(transforms.len());
                if total > MAX_MESH_INSTANCES {
                    return Err(SceneError::invalid(
                        file,
                        format!(
                            "{label} asks for {} EXT_mesh_gpu_instancing instances, which takes the scene past                              soupray's limit of {MAX_MESH_INSTANCES} mesh instances. Fix: split the scene.",
                            transforms.len()
                        ),
                    ));
                }
                instances.extend(transforms.into_iter().map(|m| MeshInstance {
                    node: n,
                    mesh,
                    skin,
                    node_from_instance: Some(m),
                }));
            }
        }
    }
    Ok(instances)
}

/// The skin node `n`'s instance of `mesh` is drawn with: the node's, when
/// the mesh has joints and weights, after checking that every weighted
/// joint number is one of the skin's.
fn instance_skin(
    cx: &Ctx,
    n: usize,
    mesh: usize,
    meshes: &[Mesh],
    skins: &[Skin],
    warnings: &mut Vec<String>,
) -> Result<Option<usize>> {
    let (file, reader, nodes) = (cx.file, cx.reader, cx.nodes);
    let doc = &reader.src.document;
    let label_of = |i: usize| node_label(nodes, i);
    let skinned = meshes[mesh]
        .primitives
        .iter()
        .any(|p| p.influences.is_some());
    let skin = match (nodes[n].skin, skinned) {
        (Some(s), true) => Some(s),
        (Some(_), false) => {
            warnings.push(format!(
                "{} has a skin but its mesh has no JOINTS_0/WEIGHTS_0; it is drawn unskinned",
                label_of(n)
            ));
            None
        }
        (None, _) => None,
    };
    if let Some(s) = skin {
        let joint_count = skins[s].joints.len() as u32;
        for p in &meshes[mesh].primitives {
            let Some(inf) = &p.influences else { continue };
            let bad = inf
                .joints
                .iter()
                .zip(&inf.weights)
                .position(|(&j, &w)| j >= joint_count && w != 0.0);
            if let Some(slot) = bad {
                let set = (slot % inf.slots_per_vertex()) / 4;
                let acc = doc
                    .meshes()
                    .nth(mesh)
                    .and_then(|m| m.primitives().nth(p.index_in_mesh))
                    .and_then(|pr| pr.get(&gltf::Semantic::Joints(set as u32)));
                let usage = format!("JOINTS_{set} of mesh {mesh} primitive {}", p.index_in_mesh);
                let problem = format!(
                        "vertex {} uses joint {}, but skin {s} (used by {}) has only {joint_count} joints. \
                         Fix: re-export the skinned mesh with its skin.",
                        slot / inf.slots_per_vertex(),
                        inf.joints[slot],
                        label_of(n)
                    );
                return Err(match acc {
                    Some(acc) => reader.error(&acc, &usage, problem),
                    None => SceneError::invalid(file, format!("{usage}: {problem}")),
                });
            }
        }
    }
    Ok(skin)
}

/// Animations: all are read (for `info`), the one `want` names (or the
/// default) is applied.
fn load_animations(
    cx: &Ctx,
    meshes: &[Mesh],
    want: Option<&str>,
    warnings: &mut Vec<String>,
) -> Result<(Vec<Clip>, Option<usize>)> {
    let (file, reader, nodes) = (cx.file, cx.reader, cx.nodes);
    let doc = &reader.src.document;
    let label_of = |i: usize| node_label(nodes, i);
    let mut clips = Vec::new();
    let targets_of = |node: usize| nodes[node].mesh.map_or(0, |m| meshes[m].target_count);
    let clip_targets = super::animation::ClipTargets {
        targets_of_node: &targets_of,
        mesh_targets: meshes.iter().map(|m| m.target_count).collect(),
        mesh_weight_nodes: (0..meshes.len())
            .map(|m| {
                (0..nodes.len())
                    .filter(|&n| nodes[n].mesh == Some(m) && nodes[n].weights.is_none())
                    .collect()
            })
            .collect(),
    };
    for anim in doc.animations() {
        clips.push(load_clip(reader, &anim, &clip_targets, warnings)?);
    }
    let clip = select_clip(file, &clips, want)?;
    if let Some(c) = clip {
        for ch in &clips[c].channels {
            if nodes[ch.node].rest_matrix.is_some() && ch.property != super::Property::Weights {
                warnings.push(format!(
                    "{} is animated but defines its rest pose by `matrix`, which glTF forbids for animated nodes; \
                     the matrix is decomposed into TRS",
                    label_of(ch.node)
                ));
            }
        }
    }
    Ok((clips, clip))
}

/// The (node, camera) to render through: the first camera placed in the
/// scene, or the one `--camera` names (by camera or node name, or by
/// camera index).
fn choose_camera(
    cx: &Ctx,
    scene_nodes: &[usize],
    cameras: &[CameraDef],
    want: Option<&String>,
) -> Result<Option<(usize, usize)>> {
    let (file, nodes) = (cx.file, cx.nodes);
    let label_of = |i: usize| node_label(nodes, i);
    let camera_nodes: Vec<(usize, usize)> = scene_nodes
        .iter()
        .filter_map(|&n| nodes[n].camera.map(|c| (n, c)))
        .collect();
    let camera_instance = match want {
        None => camera_nodes.first().copied(),
        Some(want) => {
            let by_name = camera_nodes.iter().find(|&&(n, c)| {
                cameras[c].name.as_deref() == Some(want.as_str())
                    || nodes[n].name.as_deref() == Some(want.as_str())
            });
            let by_index = || {
                want.parse::<usize>()
                    .ok()
                    .and_then(|i| camera_nodes.iter().find(|&&(_, c)| c == i))
            };
            match by_name.or_else(by_index) {
                Some(&found) => Some(found),
                None => {
                    let listed: Vec<String> = camera_nodes
                        .iter()
                        .map(|&(n, c)| {
                            format!(
                                "{c} \"{}\" on {}",
                                cameras[c].name.as_deref().unwrap_or(""),
                                label_of(n)
                            )
                        })
                        .collect();
                    return Err(SceneError::selection(
                        file,
                        format!(
                            "--camera {want} matches no camera placed in the scene ({}). Fix: pass one of those names \
                             or indices, or omit --camera to {}.",
                            if listed.is_empty() { "the scene has none".to_owned() } else { listed.join("; ") },
                            if listed.is_empty() { "use the default framing camera" } else { "use the first" }
                        ),
                    ));
                }
            }
        }
    };
    Ok(camera_instance)
}

/// The file's lights, and the (node, light) pairs placed in the scene.
fn load_lights(
    doc: &gltf::Document,
    nodes: &[Node],
    scene_nodes: &[usize],
    warnings: &mut Vec<String>,
) -> (Vec<LightDef>, Vec<(usize, usize)>) {
    let mut lights: Vec<_> = doc
        .lights()
        .map(|ls| ls.map(|l| load_light(&l)).collect())
        .unwrap_or_default();
    for (i, l) in lights.iter_mut().enumerate() {
        super::ranges::light(i, l, warnings);
    }
    let light_instances: Vec<(usize, usize)> = scene_nodes
        .iter()
        .filter_map(|&n| nodes[n].light.map(|l| (n, l)))
        .filter(|&(_, l)| l < lights.len())
        .collect();
    (lights, light_instances)
}

// KHR_materials_variants: the chosen variant's materials replace the
// primitives' own.
fn apply_variant(
    file: &str,
    json: &serde_json::Value,
    doc: &gltf::Document,
    want: &str,
    variants: &[String],
    meshes: &mut [Mesh],
) -> Result<()> {
    let chosen = variants
        .iter()
        .position(|n| n == want)
        .or_else(|| want.parse::<usize>().ok().filter(|&i| i < variants.len()))
        .ok_or_else(|| {
            SceneError::invalid(
                file,
                format!(
                    "--variant {want}: the file has no such material variant (its variants: {}). \
                         Fix: pass one of these names or indices; `soupray info` lists them.",
                    if variants.is_empty() {
                        "none".to_owned()
                    } else {
                        variants.join(", ")
                    }
                ),
            )
        })?;
    let material_count = doc.materials().len();
    for (m, mesh) in meshes.iter_mut().enumerate() {
        for p in &mut mesh.primitives {
            if let Some(material) =
                super::material_load::variant_material(json, m, p.index_in_mesh, chosen)
            {
                if material >= material_count {
                    return Err(SceneError::invalid(
                            file,
                            format!(
                                "mesh {m} primitive {}: KHR_materials_variants maps variant {chosen} to material {material}, \
                                 but the file has {material_count} materials. Fix: re-export the asset.",
                                p.index_in_mesh
                            ),
                        ));
                }
                p.material = Some(material);
            }
        }
    }
    Ok(())
}

/// The draft `EXT_camera_physical` (KhronosGroup/glTF pull request 2608):
/// a perspective camera's `focalLength` in millimetres, which the core
/// camera's `yfov` cannot give back. A draft may still change, so reading
/// it is said once; a value that is not a positive number is ignored with
/// a warning.
fn physical_cameras(
    json: &serde_json::Value,
    cameras: &mut [CameraDef],
    warnings: &mut Vec<String>,
) {
    let Some(list) = json.get("cameras").and_then(|c| c.as_array()) else {
        return;
    };
    let mut read = false;
    for (i, camera) in list.iter().enumerate() {
        let Some(ext) = camera
            .get("extensions")
            .and_then(|e| e.get("EXT_camera_physical"))
        else {
            continue;
        };
        let Some(def) = cameras.get_mut(i) else {
            continue;
        };
        match ext.get("focalLength").and_then(|f| f.as_f64()) {
            Some(f)
                if f.is_finite()
                    && f > 0.0
                    && matches!(def.projection, Projection::Perspective { .. }) =>
            {
                def.focal_mm = Some(f as f32);
                read = true;
            }
            _ => warnings.push(format!(
                "camera {i}: EXT_camera_physical's focalLength is {}, not a positive number of \
                 millimetres on a perspective camera: ignored",
                ext.get("focalLength")
                    .map_or("missing".to_owned(), |f| f.to_string())
            )),
        }
    }
    if read {
        warnings.push(
            "EXT_camera_physical is a draft extension (KhronosGroup/glTF pull request 2608): \
             soupray reads its focalLength for the lens --aperture opens; the draft may change"
                .to_owned(),
        );
    }
}

/// `{"soupray": {"environment": [r, g, b]}}` (constant linear radiance):
/// glTF has no sky of its own. Anything else there is ignored with a warning.
fn file_environment(
    json: &serde_json::Value,
    scene_index: Option<usize>,
    warnings: &mut Vec<String>,
) -> Option<[f32; 3]> {
    let value = json
        .get("scenes")?
        .get(scene_index.unwrap_or(0))?
        .get("extras")?
        .get("soupray")?
        .get("environment")?;
    let rgb: Option<Vec<f32>> = value.as_array().filter(|a| a.len() == 3).and_then(|a| {
        a.iter()
            .map(|c| {
                c.as_f64()
                    .map(|c| c as f32)
                    .filter(|c| c.is_finite() && *c >= 0.0)
            })
            .collect()
    });
    match rgb {
        Some(c) => Some([c[0], c[1], c[2]]),
        None => {
            warnings.push(format!(
                "the scene's extras.soupray.environment is {value}, not three finite, \
                 non-negative numbers [r, g, b]: ignored"
            ));
            None
        }
    }
}

/// The texture coordinate set the soup carries beside TEXCOORD_0: the one
/// other set the materials sample (TEXCOORD_1 in nearly every file). Texture
/// uses are renumbered to the soup's two slots (0: TEXCOORD_0, 1: the second
/// set), and the meshes load that set alone. A scene whose materials
/// sample two or more sets besides TEXCOORD_0 keeps the lowest, and the
/// others are read with TEXCOORD_0, with a warning.
fn choose_second_uv_set(materials: &mut MaterialTable, warnings: &mut Vec<String>) -> Option<u32> {
    let mut used = std::collections::BTreeSet::new();
    for m in &mut materials.materials {
        for t in m.texture_refs_mut().into_iter().flatten() {
            if t.tex_coord != 0 {
                used.insert(t.tex_coord);
            }
        }
    }
    let second = used.iter().copied().find(|&s| s <= 3);
    let dropped: Vec<String> = used
        .iter()
        .filter(|&&s| Some(s) != second)
        .map(|s| format!("TEXCOORD_{s}"))
        .collect();
    if !dropped.is_empty() {
        warnings.push(format!(
            "materials sample {} besides {}: soupray carries TEXCOORD_0 and one more set, so those \
             textures are read with TEXCOORD_0. Fix: map them through TEXCOORD_0{} in the authoring tool.",
            dropped.join(", "),
            second.map_or("TEXCOORD_0".to_owned(), |s| format!("TEXCOORD_{s}")),
            second.map_or(String::new(), |s| format!(" or TEXCOORD_{s}"))
        ));
    }
    for m in &mut materials.materials {
        for t in m.texture_refs_mut().into_iter().flatten() {
            t.tex_coord = u32::from(t.tex_coord != 0 && Some(t.tex_coord) == second);
        }
    }
    second
}

fn load_nodes(file: &str, doc: &gltf::Document) -> Result<Vec<Node>> {
    let mut nodes: Vec<Node> = doc
        .nodes()
        .map(|n| {
            let (rest, rest_matrix) = match n.transform() {
                gltf::scene::Transform::Matrix { matrix } => {
                    let m = Mat4::from_cols_array_2d(&matrix);
                    let (scale, rotation, translation) = m.to_scale_rotation_translation();
                    (
                        Trs {
                            translation,
                            rotation,
                            scale,
                        },
                        Some(m),
                    )
                }
                gltf::scene::Transform::Decomposed {
                    translation,
                    rotation,
                    scale,
                } => (
                    Trs {
                        translation: Vec3::from(translation),
                        // The spec requires unit quaternions; normalising
                        // forgives exporters' rounding.
                        rotation: Quat::from_array(rotation).normalize(),
                        scale: Vec3::from(scale),
                    },
                    None,
                ),
            };
            Node {
                name: n.name().map(str::to_owned),
                parent: None,
                children: n.children().map(|c| c.index()).collect(),
                rest,
                rest_matrix,
                mesh: n.mesh().map(|m| m.index()),
                skin: n.skin().map(|s| s.index()),
                camera: n.camera().map(|c| c.index()),
                light: n.light().map(|l| l.index()),
                weights: n.weights().map(<[f32]>::to_vec),
                role: super::compositing::Role::of_extras(n.extras().as_deref()),
            }
        })
        .collect();
    for p in 0..nodes.len() {
        for c in nodes[p].children.clone() {
            if let Some(other) = nodes[c].parent {
                return Err(SceneError::invalid(
                    file,
                    format!(
                        "node {c} is a child of both node {other} and node {p}; glTF node hierarchies must be trees. \
                         Fix: re-export the scene."
                    ),
                ));
            }
            nodes[c].parent = Some(p);
        }
        let rest = &nodes[p].rest;
        if !(rest.translation.is_finite() && rest.rotation.is_finite() && rest.scale.is_finite())
            || nodes[p].rest_matrix.is_some_and(|m| !m.is_finite())
        {
            return Err(SceneError::invalid(
                file,
                format!("node {p} has a non-finite transform. Fix: re-export the scene."),
            ));
        }
    }
    Ok(nodes)
}

/// Parents before children; a node left out is on a cycle.
fn order_nodes(file: &str, nodes: &[Node]) -> Result<Vec<usize>> {
    let mut order = Vec::with_capacity(nodes.len());
    let mut stack: Vec<usize> = (0..nodes.len())
        .rev()
        .filter(|&n| nodes[n].parent.is_none())
        .collect();
    while let Some(n) = stack.pop() {
        order.push(n);
        stack.extend(nodes[n].children.iter().rev().copied());
    }
    if order.len() != nodes.len() {
        let mut seen = vec![false; nodes.len()];
        for &n in &order {
            seen[n] = true;
        }
        let on_cycle = seen.iter().position(|s| !s).unwrap_or(0);
        return Err(SceneError::invalid(
            file,
            format!("node {on_cycle} is part of a cycle in the node hierarchy. Fix: re-export the scene."),
        ));
    }
    Ok(order)
}

fn select_clip(file: &str, clips: &[super::Clip], want: Option<&str>) -> Result<Option<usize>> {
    let Some(want) = want else {
        return Ok((!clips.is_empty()).then_some(0));
    };
    if let Some(c) = clips.iter().position(|c| c.name.as_deref() == Some(want)) {
        return Ok(Some(c));
    }
    if let Ok(i) = want.parse::<usize>() {
        if i < clips.len() {
            return Ok(Some(i));
        }
    }
    let listed: Vec<String> = clips
        .iter()
        .map(|c| format!("{} \"{}\"", c.index, c.name.as_deref().unwrap_or("")))
        .collect();
    Err(SceneError::selection(
        file,
        format!(
            "--animation {want} matches no animation ({}). Fix: pass one of those names or indices{}.",
            if listed.is_empty() { "the file has none".to_owned() } else { listed.join(", ") },
            if listed.is_empty() { ", or omit --animation" } else { "" }
        ),
    ))
}
