//! The scene commands of the `soupray` binary: `info`, which describes what
//! a glTF file holds and how soupray will read it, and `soup`, which writes
//! one frame's world-space triangle soup as binary PLY. Both are thin: all
//! the work is in `scene`.

use std::fmt::Write as _;
use std::path::{Path, PathBuf};

use anyhow::Context as _;

use crate::scene::{LightKind, LoadOptions, Projection, Scene};

/// Describe a glTF file: meshes and triangle counts, skins, morph targets,
/// animations and their frame ranges, cameras, lights, materials and
/// extensions.
#[derive(clap::Args, Debug, Clone)]
pub struct InfoArgs {
    /// The glTF 2.0 file: a .glb, or a .gltf with its .bin and image files
    /// beside it (or embedded as data URIs).
    #[arg(value_name = "SCENE")]
    pub path: PathBuf,

    /// Which of the file's scenes to describe (index, from 0). Defaults to
    /// the file's own default scene.
    #[arg(long, value_name = "N")]
    pub scene: Option<usize>,

    /// Frames per second used to report each animation's frame range
    /// (frame N is at time N / FPS).
    #[arg(long, value_name = "FPS", default_value_t = 24.0)]
    pub fps: f64,
}

/// Write the world-space triangle soup of one animation frame as a binary
/// little-endian PLY file (float x y z per vertex, three vertices per face).
#[derive(clap::Args, Debug, Clone)]
pub struct SoupArgs {
    /// The glTF 2.0 file: a .glb, or a .gltf with its .bin files beside it.
    #[arg(value_name = "SCENE")]
    pub path: PathBuf,

    /// Frame to evaluate. Frame N is at time N / FPS seconds; the clip
    /// covers frames 0 to ceil(duration x FPS) (see `soupray info`). Times
    /// outside the clip hold its first or last pose.
    #[arg(
        long,
        value_name = "N",
        default_value_t = 0,
        allow_negative_numbers = true
    )]
    pub frame: i64,

    /// Frames per second of the output animation.
    #[arg(long, value_name = "FPS", default_value_t = 24.0)]
    pub fps: f64,

    /// Animation to play, by name or index (default: the first). Only this
    /// one is applied; nodes it does not animate keep their rest pose.
    #[arg(long, value_name = "NAME|INDEX")]
    pub animation: Option<String>,

    /// Which of the file's scenes to use (index, from 0). Defaults to the
    /// file's own default scene.
    #[arg(long, value_name = "N")]
    pub scene: Option<usize>,

    /// Drop triangles whose vertices are NaN or infinite (reported as a
    /// warning) instead of refusing the file.
    #[arg(long)]
    pub sanitize: bool,

    /// Output .ply file (written to a temporary beside it, then renamed;
    /// an existing path must be a regular file). `-` writes the PLY to
    /// standard output, which must not be a terminal.
    #[arg(short, long, value_name = "FILE.ply")]
    pub output: PathBuf,
}

fn degrees(radians: f32) -> f32 {
    radians.to_degrees()
}

fn named(index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) => format!("{index} \"{n}\""),
        None => index.to_string(),
    }
}

/// The text `soupray info` prints.
pub fn describe(scene: &Scene) -> String {
    let mut out = String::new();
    let o = &mut out;
    describe_file(o, scene);
    describe_meshes(o, scene);
    describe_skins(o, scene);
    describe_animations(o, scene);
    describe_cameras(o, scene);
    describe_lights(o, scene);
    describe_materials(o, scene);

    if !scene.warnings().is_empty() {
        let _ = writeln!(o, "warnings:");
        for w in scene.warnings() {
            let _ = writeln!(o, "  {w}");
        }
    }
    out
}

/// The file, its scenes, variants and extensions.
fn describe_file(o: &mut String, scene: &Scene) {
    let _ = writeln!(o, "file: {}", scene.file());
    let _ = writeln!(
        o,
        "scenes: {}{}",
        scene.scene_count(),
        scene
            .scene_index()
            .map(|s| format!(" (showing scene {s})"))
            .unwrap_or_default()
    );
    let list = |v: &[String]| {
        if v.is_empty() {
            "none".to_owned()
        } else {
            v.join(", ")
        }
    };
    let _ = writeln!(o, "extensions used: {}", list(scene.extensions_used()));
    if !scene.variants().is_empty() {
        let named: Vec<String> = scene
            .variants()
            .iter()
            .enumerate()
            .map(|(i, n)| format!("{i}: {n}"))
            .collect();
        let _ = writeln!(o, "material variants (--variant): {}", named.join(", "));
    }
    let _ = writeln!(
        o,
        "extensions required: {}",
        list(scene.extensions_required())
    );
}

/// Each mesh: primitives, triangles, compression, morph targets, and the
/// nodes that place it.
fn describe_meshes(o: &mut String, scene: &Scene) {
    let _ = writeln!(
        o,
        "meshes: {} ({} placed in the scene, {} triangles per frame)",
        scene.meshes().len(),
        scene.instances().len(),
        scene.triangle_count()
    );
    for (i, mesh) in scene.meshes().iter().enumerate() {
        let tris: usize = mesh.primitives.iter().map(|p| p.triangles.len()).sum();
        let draco = mesh
            .primitives
            .iter()
            .filter(|p| p.draco_compressed)
            .count();
        // One entry per node; an EXT_mesh_gpu_instancing node says how
        // many instances it draws (its instances are adjacent).
        let mut by_node: Vec<(usize, usize)> = Vec::new();
        for inst in scene.instances().iter().filter(|inst| inst.mesh == i) {
            let gpu = inst.node_from_instance.is_some() as usize;
            match by_node.last_mut() {
                Some((node, count)) if *node == inst.node => *count += gpu,
                _ => by_node.push((inst.node, gpu)),
            }
        }
        let placed: Vec<String> = by_node
            .iter()
            .map(|&(node, gpu)| match gpu {
                0 => scene.node_label(node),
                n => format!(
                    "{} ({n} EXT_mesh_gpu_instancing instances)",
                    scene.node_label(node)
                ),
            })
            .collect();
        let _ = writeln!(
            o,
            "  mesh {}: {} primitive(s){}, {tris} triangles{}{}",
            named(i, mesh.name.as_deref()),
            mesh.primitives.len(),
            match draco {
                0 => String::new(),
                n if n == mesh.primitives.len() => " (Draco-compressed)".to_owned(),
                n => format!(" ({n} Draco-compressed)"),
            },
            if mesh.target_count > 0 {
                format!(
                    ", {} morph targets (default weights {:?})",
                    mesh.target_count, mesh.default_weights
                )
            } else {
                String::new()
            },
            if placed.is_empty() {
                ", not placed".to_owned()
            } else {
                format!(", on {}", placed.join(", "))
            }
        );
    }
}

/// Each skin: joints, and the nodes it skins.
fn describe_skins(o: &mut String, scene: &Scene) {
    let _ = writeln!(o, "skins: {}", scene.skins().len());
    for (i, skin) in scene.skins().iter().enumerate() {
        let users: Vec<String> = scene
            .instances()
            .iter()
            .filter(|inst| inst.skin == Some(i))
            .map(|inst| scene.node_label(inst.node))
            .collect();
        let _ = writeln!(
            o,
            "  skin {}: {} joints{}",
            named(i, skin.name.as_deref()),
            skin.joints.len(),
            if users.is_empty() {
                String::new()
            } else {
                format!(", skinning {}", users.join(", "))
            }
        );
    }
}

/// Each animation: duration, channels, interpolations and frame range.
fn describe_animations(o: &mut String, scene: &Scene) {
    let fps = scene.options().fps;
    let _ = writeln!(o, "animations: {}", scene.clips().len());
    let active = scene.active_clip().map(|c| c.index);
    for clip in scene.clips() {
        let mut modes: Vec<&str> = clip
            .channels
            .iter()
            .map(|c| &c.sampler)
            .chain(clip.pointer_channels.iter().map(|c| &c.sampler))
            .map(|s| s.interpolation.name())
            .collect();
        modes.sort_unstable();
        modes.dedup();
        let last = ((clip.duration * fps) - 1e-4).ceil().max(0.0) as i64;
        let _ = writeln!(
            o,
            "  animation {}: {:.3} s, {} channels ({}), frames 0..={last} at {fps} fps{}",
            named(clip.index, clip.name.as_deref()),
            clip.duration,
            clip.channels.len() + clip.pointer_channels.len(),
            modes.join("/"),
            if Some(clip.index) == active {
                " (default)"
            } else {
                ""
            }
        );
    }
}

/// Each camera: its lens and the nodes that place it, and which renders.
fn describe_cameras(o: &mut String, scene: &Scene) {
    let _ = writeln!(o, "cameras: {}", scene.cameras().len());
    for (i, cam) in scene.cameras().iter().enumerate() {
        let lens = match cam.projection {
            Projection::Perspective {
                yfov,
                aspect,
                znear,
                zfar,
            } => format!(
                "perspective, yfov {:.1} deg, aspect {}, znear {znear}, zfar {}",
                degrees(yfov),
                aspect.map_or("of the image".to_owned(), |a| format!("{a:.3}")),
                zfar.map_or("infinite".to_owned(), |z| z.to_string())
            ),
            Projection::Orthographic {
                xmag,
                ymag,
                znear,
                zfar,
            } => {
                format!("orthographic, xmag {xmag}, ymag {ymag}, znear {znear}, zfar {zfar}")
            }
        };
        let placed = scene
            .nodes()
            .iter()
            .enumerate()
            .filter(|(_, n)| n.camera == Some(i))
            .map(|(n, _)| scene.node_label(n))
            .collect::<Vec<_>>();
        let _ = writeln!(
            o,
            "  camera {}: {lens}{}{}",
            named(i, cam.name.as_deref()),
            if placed.is_empty() {
                String::new()
            } else {
                format!(", on {}", placed.join(", "))
            },
            if scene.camera_instance().map(|c| c.1) == Some(i) {
                " (default)"
            } else {
                ""
            }
        );
    }
    if scene.camera_instance().is_none() {
        let _ = writeln!(
            o,
            "  (no camera in the scene: a default camera frames the whole clip)"
        );
    }
}

/// Each KHR_lights_punctual light.
fn describe_lights(o: &mut String, scene: &Scene) {
    let _ = writeln!(o, "lights: {}", scene.lights().len());
    for (i, light) in scene.lights().iter().enumerate() {
        let cone = match light.kind {
            LightKind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => format!(
                ", cone {:.1}..{:.1} deg",
                degrees(inner_cone_angle),
                degrees(outer_cone_angle)
            ),
            _ => String::new(),
        };
        let _ = writeln!(
            o,
            "  light {}: {}, color {:?}, intensity {}{}{cone}",
            named(i, light.name.as_deref()),
            light.kind.name(),
            light.color,
            light.intensity,
            light
                .range
                .map(|r| format!(", range {r}"))
                .unwrap_or_default()
        );
    }
}

/// The material table, and each material's parameters.
fn describe_materials(o: &mut String, scene: &Scene) {
    let table = scene.materials();
    let _ = writeln!(
        o,
        "materials: {} ({} textures, {} images)",
        table.materials.len(),
        table.textures.len(),
        table.images.len()
    );
    for (i, m) in table.materials.iter().enumerate() {
        let tex = |r: &Option<crate::scene::TextureRef>| {
            r.as_ref()
                .map(|r| {
                    format!(
                        " [texture {} uv{}{}]",
                        r.texture,
                        r.tex_coord,
                        if r.transform.is_some() {
                            " transformed"
                        } else {
                            ""
                        }
                    )
                })
                .unwrap_or_default()
        };
        let default = if table.default_material == Some(i as u32) {
            " (glTF default material)"
        } else {
            ""
        };
        let _ = writeln!(
            o,
            "  material {}{default}: base color {:?}{}, metallic {} roughness {}{}{}, emissive {:?} x {}{}, {:?}{}{}",
            named(i, m.name.as_deref()),
            m.base_color_factor,
            tex(&m.base_color_texture),
            m.metallic_factor,
            m.roughness_factor,
            tex(&m.metallic_roughness_texture),
            m.normal_texture.as_ref().map(|_| format!(", normal map{}", tex(&m.normal_texture))).unwrap_or_default(),
            m.emissive_factor,
            m.emissive_strength,
            tex(&m.emissive_texture),
            m.alpha_mode,
            if m.alpha_mode == crate::scene::AlphaMode::Mask { format!(" (cutoff {})", m.alpha_cutoff) } else { String::new() },
            if m.double_sided { ", double-sided" } else { "" }
        );
        let exts = material_extensions(m, &tex);
        if !exts.is_empty() {
            let _ = writeln!(o, "    {}", exts.join(", "));
        }
    }
}

/// The material extensions' parameters `m` departs from the defaults in,
/// by extension, as `soupray render` reads them (`tex` formats a texture
/// reference): every extension row of `scene::material`.
fn material_extensions(
    m: &crate::scene::Material,
    tex: &dyn Fn(&Option<crate::scene::TextureRef>) -> String,
) -> Vec<String> {
    use crate::scene::material::{Slot, FACTORS};
    let mut by_extension: Vec<(&str, Vec<String>)> = Vec::new();
    let mut add =
        |ext: &'static str, item: String| match by_extension.iter_mut().find(|(e, _)| *e == ext) {
            Some((_, items)) => items.push(item),
            None => by_extension.push((ext, vec![item])),
        };
    let default = crate::scene::Material::default();
    for factor in FACTORS {
        let Some((ext, key)) = factor.extension_key() else {
            continue;
        };
        let (v, d) = (factor.values(m), factor.values(&default));
        // The emissive strength is on the core line.
        if v != d && ext != "KHR_materials_emissive_strength" {
            let shown = match v {
                [x] => x.to_string(),
                _ => format!("{v:?}"),
            };
            add(ext, format!("{key} {shown}"));
        }
    }
    for slot in Slot::ALL {
        if let (Some((ext, key)), Some(t)) = (slot.extension_key(), slot.of(m)) {
            add(ext, format!("{key}{}", tex(&Some(t.clone()))));
        }
    }
    let mut out: Vec<String> = Vec::new();
    if m.unlit {
        out.push("unlit".to_owned());
    }
    out.extend(
        by_extension
            .into_iter()
            .map(|(ext, items)| format!("{ext} {}", items.join(" "))),
    );
    if m.has_volume() {
        out.push("refracting volume".to_owned());
    } else if m.transmission_factor > 0.0 || m.has_diffuse_transmission() {
        out.push("thin-walled".to_owned());
    }
    out
}

pub fn run_info(args: &InfoArgs) -> anyhow::Result<()> {
    let opts = LoadOptions {
        scene: args.scene,
        fps: args.fps,
        ..LoadOptions::default()
    };
    let scene = Scene::load(&args.path, &opts)?;
    print!("{}", describe(&scene));
    Ok(())
}

pub fn run_soup(args: &SoupArgs) -> anyhow::Result<()> {
    let to_stdout = args.output.as_os_str() == "-";
    if to_stdout {
        use std::io::IsTerminal as _;
        if std::io::stdout().is_terminal() {
            return Err(crate::UsageError(
                "-o -: standard output is a terminal; redirect or pipe it (soupray soup ... -o - > F.ply)".into(),
            )
            .into());
        }
    } else {
        // Before any work: the output must not replace a device, FIFO or
        // directory (exit 6, the node untouched).
        crate::output::check_target(&args.output)?;
    }
    let opts = LoadOptions {
        scene: args.scene,
        animation: args.animation.clone(),
        camera: None,
        fps: args.fps,
        sanitize: args.sanitize,
        variant: None,
    };
    let scene = Scene::load(&args.path, &opts)?;
    for w in scene.warnings() {
        eprintln!("warning: {}: {w}", scene.file());
    }
    let (first, last) = scene.frame_range();
    if args.frame < first || args.frame > last {
        eprintln!(
            "warning: frame {} is outside the clip's frames {first}..={last}; it holds the clip's {} pose",
            args.frame,
            if args.frame < first { "first" } else { "last" }
        );
    }
    let time = scene.time_of_frame(args.frame);
    let frame = scene.evaluate(time)?;
    for w in &frame.warnings {
        eprintln!("warning: {}: {w}", scene.file());
    }
    if to_stdout {
        use std::io::Write as _;
        let mut out = std::io::BufWriter::new(std::io::stdout().lock());
        crate::ply::write_soup_to(&mut out, &frame.soup)
            .and_then(|()| out.flush())
            .map_err(crate::output::io_err(
                Path::new("-"),
                "write the PLY to standard output",
            ))?;
        eprintln!(
            "{}: frame {} (t = {time:.4} s): {} triangles written to standard output",
            scene.file(),
            args.frame,
            frame.soup.triangle_count()
        );
        return Ok(());
    }
    crate::ply::write_soup(&args.output, &frame.soup).with_context(|| {
        format!(
            "cannot write {}; check that its directory exists and is writable",
            args.output.display()
        )
    })?;
    println!(
        "{}: frame {} (t = {time:.4} s): {} triangles written to {}",
        scene.file(),
        args.frame,
        frame.soup.triangle_count(),
        args.output.display()
    );
    Ok(())
}
