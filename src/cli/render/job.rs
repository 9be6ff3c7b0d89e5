//! The render job, resolved from the flags before anything is rendered:
//! the frames, the output directory and names, and how every frame is made.

use super::RenderArgs;
use crate::bvh::BuildParams;
use crate::cli::frames::{self, FrameArgs, NamePattern};
use crate::film::{Aovs, Cryptomatte};
use crate::pipeline::FrameSettings;
use crate::scene::compositing::RoleOverrides;
use crate::scene::{Projection, Scene};
use crate::trace::lens::Lens;
use crate::trace::motion::{Shutter, ShutterPosition};
use crate::trace::render::{
    Adaptive, Allocation, Environment, Layering, LightTreeUse, RenderSettings, Traversal,
};
use crate::trace::sampling::{NoisePattern, Sampler};
use crate::UsageError;
use std::path::{Path, PathBuf};

/// The job, resolved from the flags before anything is rendered.
pub(super) struct Job {
    pub frames: Vec<i64>,
    pub notes: Vec<String>,
    pub out_dir: PathBuf,
    pub pattern: NamePattern,
    /// How every frame is made (`settings.render.aovs` adds albedo and
    /// normal to the written AOVs for `--denoise`).
    pub settings: FrameSettings,
    /// The AOVs written to the EXR, by name, for the log.
    pub aov_names: Vec<String>,
    /// How the EXRs store their samples: `--half` and `--exr-compression`.
    pub exr_format: crate::output::ExrFormat,
}

fn parse_env_color(s: &str) -> Result<[f32; 3], UsageError> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let values: Option<Vec<f32>> = parts.iter().map(|p| p.parse::<f32>().ok()).collect();
    match values.as_deref() {
        Some([r, g, b]) if [r, g, b].iter().all(|v| v.is_finite() && **v >= 0.0) => {
            Ok([*r, *g, *b])
        }
        _ => Err(UsageError(format!(
            "--env-color {s:?}: expected three non-negative numbers R,G,B (e.g. 0.5,0.6,1.0)"
        ))),
    }
}

/// The image size: the flags, else 640 wide and the camera's aspect ratio
/// (or 16:9 when the file gives none).
fn image_size(args: &RenderArgs, scene: &Scene) -> Result<(u32, u32), UsageError> {
    let camera_aspect =
        scene
            .camera_instance()
            .and_then(|(_, c)| match scene.cameras()[c].projection {
                Projection::Perspective { aspect, .. } => aspect,
                Projection::Orthographic { xmag, ymag, .. } => Some(xmag / ymag),
            });
    let aspect = match camera_aspect {
        Some(a) if a.is_finite() && a > 0.0 => a,
        _ => 16.0 / 9.0,
    };
    let (w, h) = match (args.width, args.height) {
        (Some(w), Some(h)) => (w, h),
        (Some(w), None) => (w, ((w as f32 / aspect).round() as u32).max(1)),
        (None, Some(h)) => (((h as f32 * aspect).round() as u32).max(1), h),
        (None, None) if camera_aspect.is_some() => (640, ((640.0 / aspect).round() as u32).max(1)),
        (None, None) => (640, 360),
    };
    if w == 0 || h == 0 || w > 16384 || h > 16384 {
        return Err(UsageError(format!(
            "image size {w}x{h} is out of range: use 1 to 16384 pixels per side"
        )));
    }
    Ok((w, h))
}

pub(super) fn resolve_job(
    args: &RenderArgs,
    scene: &Scene,
    scene_path: &Path,
) -> anyhow::Result<Job> {
    let params = BuildParams {
        bins: args.bins,
        leaf_size: args.leaf_size,
    };
    params.check().map_err(UsageError)?;
    let (adaptive, time_limit) = sampling_limits(args)?;
    if !(args.fps.is_finite() && args.fps > 0.0) {
        return Err(UsageError(format!("--fps {}: must be a positive number", args.fps)).into());
    }
    let (traversal, sampler, noise_pattern) = tracer_kinds(args)?;
    let layering = layering(args)?;
    let (compression, zlib_level) =
        crate::output::ExrFormat::parse_compression(&args.exr_compression).map_err(|e| {
            UsageError(format!("--exr-compression {:?}: {e}", args.exr_compression))
        })?;
    let exr_format = crate::output::ExrFormat {
        half: args.half,
        compression,
        zlib_level,
    };
    let environment = environment(args, scene)?;
    let output_aovs = Aovs::parse(args.aov.as_deref().unwrap_or(""))?
        .with_light_passes(args.passes.as_deref().unwrap_or(""))?;
    // The denoiser's auxiliary images come from the film's AOVs.
    let aovs = Aovs {
        normal: output_aovs.normal || args.denoise,
        albedo: output_aovs.albedo || args.denoise,
        ..output_aovs
    };
    let shutter = shutter(args)?;
    let (width, height) = image_size(args, scene)?;
    let frame_args = FrameArgs {
        frames: args.frames.clone(),
        frame: args.frame,
        start: args.start,
        end: args.end,
        step: args.step,
    };
    let list = frames::resolve_frames(&frame_args, scene.frame_range())?;
    let pattern_text = args
        .name
        .clone()
        .unwrap_or_else(|| frames::default_name_pattern(scene_path));
    let pattern = NamePattern::new(&pattern_text, list.frames.len())?;
    let out_dir = args
        .out
        .clone()
        .unwrap_or_else(|| frames::default_out_dir(scene_path));
    Ok(Job {
        frames: list.frames,
        notes: list.notes,
        out_dir,
        pattern,
        settings: FrameSettings {
            scene_path: scene_path.to_path_buf(),
            render: RenderSettings {
                width,
                height,
                spp: args.spp,
                seed: args.seed,
                max_depth: args.max_depth,
                clay: args.clay,
                traversal,
                sampler,
                noise_pattern,
                adaptive,
                time_limit,
                environment,
                aovs,
                energy_compensation: !args.no_energy_compensation,
                light_tree: match (args.light_tree, args.no_light_tree) {
                    (_, true) => LightTreeUse::Never,
                    (true, false) => LightTreeUse::Always,
                    (false, false) => LightTreeUse::Auto,
                },
                layering,
                backface_culling: args.backface_culling,
                lens: lens(args, scene)?,
                transparent: args.transparent,
                cryptomatte: args
                    .cryptomatte
                    .as_deref()
                    .map(|list| Cryptomatte::parse(list, args.cryptomatte_depth))
                    .transpose()?,
                roles: role_overrides(args, scene)?,
            },
            build: params,
            output_aovs,
            shutter,
            motion_steps: args.motion_steps,
            focus_node: focus_node(args, scene)?,
        },
        aov_names: output_aovs.names().iter().map(|s| s.to_string()).collect(),
        exr_format,
    })
}

/// `--spp`, `--noise-threshold` (with `--min-spp` and
/// `--adaptive-allocation`) and `--time-limit`.
fn sampling_limits(
    args: &RenderArgs,
) -> anyhow::Result<(Option<Adaptive>, Option<std::time::Duration>)> {
    if args.spp == 0 {
        return Err(UsageError("--spp 0: render at least one sample per pixel".into()).into());
    }
    let allocation: Allocation = args.adaptive_allocation.parse().map_err(|_| {
        UsageError(format!(
            "--adaptive-allocation {:?}: use `time` (the default) or `error`",
            args.adaptive_allocation
        ))
    })?;
    let adaptive = match args.noise_threshold {
        None => None,
        Some(t) if t.is_finite() && t > 0.0 => Some(Adaptive {
            threshold: t,
            min_spp: args.min_spp.clamp(1, args.spp),
            allocation,
        }),
        Some(t) => {
            return Err(UsageError(format!(
                "--noise-threshold {t}: must be a positive number, e.g. 0.02"
            ))
            .into())
        }
    };
    let time_limit = match args.time_limit {
        None => None,
        Some(t) if t.is_finite() && t > 0.0 => Some(std::time::Duration::from_secs_f64(t)),
        Some(t) => {
            return Err(UsageError(format!(
                "--time-limit {t}: must be a positive number of seconds"
            ))
            .into())
        }
    };
    Ok((adaptive, time_limit))
}

/// `--traversal`, `--sampler` and `--noise-pattern`.
fn tracer_kinds(args: &RenderArgs) -> Result<(Traversal, Sampler, NoisePattern), UsageError> {
    let traversal = match args.traversal.as_str() {
        "wide" => Traversal::Wide,
        "wide8" => Traversal::Wide8,
        "stack" => Traversal::Stack,
        "stackless" => Traversal::Stackless,
        other => {
            return Err(UsageError(format!(
                "--traversal {other:?}: use `wide8` (the default), `wide`, `stack` or `stackless`"
            )))
        }
    };
    let sampler: Sampler = args.sampler.parse().map_err(|_| {
        UsageError(format!(
            "--sampler {:?}: use `sobol` (the default) or `random`",
            args.sampler
        ))
    })?;
    let noise_pattern: NoisePattern = args.noise_pattern.parse().map_err(|_| {
        UsageError(format!(
            "--noise-pattern {:?}: use `per-frame` or `fixed`",
            args.noise_pattern
        ))
    })?;
    Ok((traversal, sampler, noise_pattern))
}

/// `--layering`.
fn layering(args: &RenderArgs) -> Result<Layering, UsageError> {
    args.layering.parse().map_err(|_| {
        UsageError(format!(
            "--layering {:?}: use `energy` (the default) or `spec`",
            args.layering
        ))
    })
}

/// `--env-color` or `--env`, else the scene's own sky or the default.
fn environment(args: &RenderArgs, scene: &Scene) -> anyhow::Result<Environment> {
    Ok(match (&args.env_color, &args.env) {
        (Some(_), Some(_)) => {
            return Err(UsageError("--env-color and --env exclude each other".into()).into())
        }
        (Some(c), None) => Environment::Color(parse_env_color(c)?),
        (None, Some(p)) => {
            // Refused before the device is set up: not a regular file (exit 4).
            crate::input::open_regular(p).map_err(|e| crate::trace::lights::EnvError::Read {
                path: p.display().to_string(),
                detail: format!(
                    "cannot be read ({e}). Fix: give an equirectangular .exr file, or use --env-color R,G,B."
                ),
            })?;
            Environment::Map(p.clone())
        }
        (None, None) => scene
            .environment()
            .map_or(Environment::Default, Environment::Color),
    })
}

/// `--motion-blur` with `--shutter`, `--shutter-position` and
/// `--motion-steps`.
/// `--focus-on NODE`: the node, by name or index.
fn focus_node(args: &RenderArgs, scene: &Scene) -> Result<Option<usize>, UsageError> {
    args.focus_on
        .as_deref()
        .map(|want| node_named("--focus-on", want, scene))
        .transpose()
}

/// `--shadow-catcher` and `--holdout`: their nodes.
fn role_overrides(args: &RenderArgs, scene: &Scene) -> Result<RoleOverrides, UsageError> {
    let nodes = |option: &str, list: &[String]| -> Result<Vec<usize>, UsageError> {
        list.iter()
            .map(|want| node_named(option, want, scene))
            .collect()
    };
    Ok(RoleOverrides {
        shadow_catchers: nodes("--shadow-catcher", &args.shadow_catcher)?,
        holdouts: nodes("--holdout", &args.holdout)?,
    })
}

/// The node `option` names, by name or index.
fn node_named(option: &str, want: &str, scene: &Scene) -> Result<usize, UsageError> {
    let nodes = scene.nodes();
    let by_name: Vec<usize> = (0..nodes.len())
        .filter(|&i| nodes[i].name.as_deref() == Some(want))
        .collect();
    match (by_name.as_slice(), want.parse::<usize>()) {
        ([one], _) => Ok(*one),
        ([], Ok(i)) if i < nodes.len() => Ok(i),
        ([], _) => {
            let names: Vec<String> = (0..nodes.len())
                .take(12)
                .map(|i| scene.node_label(i))
                .collect();
            Err(UsageError(format!(
                "{option} {want}: no node has that name or index. Fix: pass one of the {} nodes \
                 (`soupray info SCENE` lists them), e.g. {}",
                nodes.len(),
                names.join(", ")
            )))
        }
        (many, _) => Err(UsageError(format!(
            "{option} {want}: {} nodes have that name; pass the index of one ({})",
            many.len(),
            many.iter()
                .map(|i| i.to_string())
                .collect::<Vec<_>>()
                .join(", ")
        ))),
    }
}

/// `--aperture` with `--focus-distance`, `--blades` and `--blade-rotation`.
fn lens(args: &RenderArgs, scene: &Scene) -> Result<Option<Lens>, UsageError> {
    let Some(f_stop) = args.aperture else {
        if args.focus_distance.is_some()
            || args.focus_on.is_some()
            || args.blades != 0
            || args.blade_rotation != 0.0
        {
            return Err(UsageError(
                "--focus-distance, --focus-on, --blades and --blade-rotation shape the lens that \
                 --aperture F_STOP opens: add --aperture (e.g. --aperture 2.8)"
                    .into(),
            ));
        }
        return Ok(None);
    };
    let focus_distance = match (args.focus_distance, &args.focus_on) {
        (Some(_), Some(_)) => {
            return Err(UsageError(
                "--focus-distance and --focus-on both set the focus: pass one".into(),
            ))
        }
        (Some(d), None) => d,
        // Set each frame from the node's distance.
        (None, Some(_)) => 1.0,
        (None, None) => {
            return Err(UsageError(format!(
                "--aperture {f_stop} needs --focus-distance M (the distance from the camera to \
                 the plane in focus, in scene units: metres for glTF) or --focus-on NODE"
            )))
        }
    };
    let lens = Lens {
        f_stop,
        focus_distance,
        blades: args.blades,
        blade_rotation: args.blade_rotation.to_radians(),
        focal_mm: scene
            .camera_instance()
            .and_then(|(_, camera)| scene.cameras().get(camera))
            .and_then(|c| c.focal_mm),
    };
    lens.check().map_err(UsageError)?;
    Ok(Some(lens))
}

fn shutter(args: &RenderArgs) -> Result<Option<Shutter>, UsageError> {
    let shutter = if args.motion_blur {
        if !(args.shutter.is_finite() && args.shutter >= 0.0 && args.shutter <= 100.0) {
            return Err(UsageError(format!(
                "--shutter {}: the shutter's open time in frames must be a number from 0 to 100 (0.5 is a 180° shutter)",
                args.shutter
            )));
        }
        let position: ShutterPosition = args.shutter_position.parse().map_err(UsageError)?;
        Some(Shutter {
            frames: args.shutter,
            position,
        })
    } else {
        None
    };
    if let Some(n) = args.motion_steps {
        if !(2..=64).contains(&n) {
            return Err(UsageError(format!(
                "--motion-steps {n}: use 2 (the shutter's opening and closing) to 64"
            )));
        }
    }
    Ok(shutter)
}
