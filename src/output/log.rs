//! The per-frame JSON build log (`FrameLog` documents its schema), written
//! beside each frame and read back by `report` and `--skip-existing`.

use std::io::Write as _;
use std::path::Path;

use serde::{Deserialize, Serialize};

use super::{io_err, write_atomic, OutputError, VERSION};
use crate::bvh::device_builder::StageTimes;

/// Current version of the build-log schema, in `FrameLog::schema`.
pub const LOG_SCHEMA: u32 = 1;

/// The per-frame build log, `<stem>.####.json` beside the EXR. Times are
/// milliseconds of wall-clock time unless noted; lengths are scene units.
///
/// ```json
/// {
///   "schema": 1, "soupray": "0.1.0",
///   "frame": 12, "time": 0.5, "scene": "walk.glb", "device": "pthread-cpu (PoCL)",
///   "triangles": 88000, "mesh_instances": 3, "gpu_instances": 0,
///   "memory": { "soup_bytes": 17248000, "peak_resident_bytes": 612000000 },
///   "timings_ms": { "startup": 0.0, "evaluate": 3.1, "build": 9.8, "trace": 1520.0, "denoise": 0.0,
///                   "write": 41.0, "total": 1574.2 },
///   "build": { "builder": "device", "bins": 16, "leaf_size": 4, "nodes": 45000,
///              "leaves": 22500, "max_depth": 24, "sah_cost": 61.2,
///              "stages_ms": { "large": 2.0, "medium": 4.1, "small": 2.9 } },
///   "render": { "width": 1920, "height": 1080, "spp": 64, "rays": 398000000, "mrays_per_s": 261.8,
///               "traversal": "wide", "sampler": "sobol" },
///   "camera": { "projection": "perspective", "position": [0, 1, 5],
///               "forward": [0, 0, -1], "up": [0, 1, 0], "yfov_deg": 39.6 },
///   "output": { "exr": "out/walk/walk.0012.exr", "png": null, "half": false, "aovs": [] },
///   "denoise": { "library": "/root/.local/share/soupray/pyoidn/pyoidn/oidn/lib/libOpenImageDenoise.so.2",
///                "version": "2.5.1", "device": "cpu", "filter": "RT", "hdr": true,
///                "clean_aux": true, "aux": ["albedo", "normal"], "quality": "high",
///                "raw_layer": "noisy", "time_ms": 950.0 },
///   "warnings": []
/// }
/// ```
///
/// Readers should ignore fields they do not know; fields are only added
/// within one `schema` number.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct FrameLog {
    /// `LOG_SCHEMA` of the writer.
    pub schema: u32,
    /// soupray version of the writer.
    pub soupray: String,
    pub frame: i64,
    /// Animation time of the frame, seconds.
    pub time: f64,
    /// The scene file as given on the command line.
    pub scene: String,
    /// The OpenCL device that built the BVH (and traced).
    pub device: String,
    /// Triangles in the frame's soup.
    pub triangles: u64,
    /// Mesh instances the soup was made of, EXT_mesh_gpu_instancing
    /// instances counted one by one.
    pub mesh_instances: u64,
    /// Of those, instances drawn by EXT_mesh_gpu_instancing.
    pub gpu_instances: u64,
    pub memory: MemoryLog,
    pub timings_ms: Timings,
    pub build: BuildLog,
    pub render: RenderLog,
    /// The frame's estimated error and its samples per pixel
    /// (`film::NoiseStats`): `target` (`--noise-threshold` or null),
    /// `estimated_mean` and `estimated_p99` (relative error of the pixels'
    /// means), `converged_fraction`, `allocation` (`time` or `error`) and
    /// `work_reference` (time allocation's W0), `spp_min`, `spp_mean`,
    /// `spp_max`, and `stopped` (`threshold`, `max_spp` or `time_limit`).
    pub noise: crate::film::NoiseStats,
    pub camera: CameraLog,
    pub output: OutputLog,
    /// With `--denoise` only (absent otherwise): the Open Image Denoise
    /// library, its version, the OIDN device it ran on (`cpu`, `cuda`, …),
    /// and the filter settings; `denoise::DenoiseLog` documents the fields.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub denoise: Option<crate::denoise::DenoiseLog>,
    /// With `--motion-blur` only (absent otherwise): the shutter and what
    /// blur cost this frame (`MotionLog`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub motion: Option<MotionLog>,
    /// Anything the user should know about this frame (clamped or dropped
    /// samples, a stepped range stopping short, fallbacks taken).
    pub warnings: Vec<String>,
}

/// A frame's motion blur: its shutter, the motion steps it was evaluated at
/// and the work blur added. A frame where nothing moves within the shutter
/// has `steps` 1 and renders exactly as without blur.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct MotionLog {
    /// `--shutter`, in frames.
    pub shutter_frames: f64,
    /// `--shutter-position`: `center`, `start` or `end`.
    pub shutter_position: String,
    /// Animation times (seconds) the shutter opens and closes.
    pub open: f64,
    pub close: f64,
    /// Times the soup was evaluated at (1: nothing moves within the shutter).
    pub steps: u32,
    /// `--motion-steps`, or `rule` when the steps came from the motion.
    pub steps_from: String,
    /// The largest rotation of a node or joint over the shutter, degrees
    /// (what the step rule reads).
    pub turn_degrees: f64,
    /// The evaluation of the steps beyond the first (wall time, including
    /// copying each step's soup aside): the evaluate work blur adds.
    pub extra_evaluate_ms: f64,
    /// Computing each triangle's bounds over all steps for the builder
    /// (wall time): the build work blur adds. The build itself has as many
    /// triangles as without blur; its boxes are larger (`build.sah_cost`
    /// is the tree's SAH cost over the moving bounds), which is what costs
    /// trace time. BENCHMARKS.md measures blur against no blur.
    pub extra_build_ms: f64,
}

/// What a frame held in memory.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct MemoryLog {
    /// The frame's triangle soup as the host holds it (positions and the
    /// corner attributes the scene has).
    pub soup_bytes: u64,
    /// The process's peak resident memory so far (Linux `VmHWM`), when the
    /// system reports it: with PoCL this includes the device's buffers.
    pub peak_resident_bytes: Option<u64>,
}

/// The process's peak resident set size so far, from `/proc/self/status`.
pub fn peak_resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

/// Wall-clock times of a frame's stages. `total` covers the frame from the
/// start of evaluation to the end of writing its EXR (and PNG); it is at
/// least the sum of the others, `startup` excepted.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct Timings {
    /// The run's start-up, in the first frame a `soupray render` process
    /// renders and 0 in the others: opening the device, compiling the
    /// OpenCL programs (the driver's program cache makes this fast on a
    /// warm node: `POCL_CACHE_DIR`, `CUDA_CACHE_PATH`, docs/farm.md) and a
    /// warm-up pass of that frame through every stage at one sample per
    /// pixel, which is where drivers that compile kernels at their first
    /// launch (PoCL) do so. Not part of `total`, `build` or `trace`, which
    /// then measure the frame alone on every frame of the run. (That
    /// frame's `evaluate` is then near 0: the device soup keeps a pose that
    /// has not changed since the warm-up evaluated it.)
    pub startup: f64,
    /// Animation evaluation into the triangle soup.
    pub evaluate: f64,
    /// BVH build, upload to readback, as `soupray bvh` measures it.
    pub build: f64,
    /// Tracing and film accumulation.
    pub trace: f64,
    /// Denoising with OIDN (`--denoise`; 0 without).
    pub denoise: f64,
    /// Resolving the film and writing the EXR and preview.
    pub write: f64,
    pub total: f64,
}

/// The BVH build, as `soupray bvh --json` reports it.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct BuildLog {
    /// `device`, `cpu-binned` or `cpu-sweep`.
    pub builder: String,
    pub bins: u32,
    pub leaf_size: u32,
    /// Inner nodes plus leaves.
    pub nodes: u64,
    pub leaves: u64,
    /// Depth of the deepest leaf (root = 0).
    pub max_depth: u32,
    /// `bvh::sah_cost`: K_T = K_I = 1, normalised by the root box area.
    pub sah_cost: f64,
    /// Device kernel time per stage from profiling events (zero on CPU).
    pub stages_ms: StageTimes,
}

#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct RenderLog {
    pub width: u32,
    pub height: u32,
    /// Camera samples per pixel.
    pub spp: u32,
    /// All rays traced for the frame (camera, bounce and shadow rays).
    pub rays: u64,
    /// `rays / trace time`, millions per second.
    pub mrays_per_s: f64,
    /// The BVH traversal (`--traversal`): `wide`, `stack` or `stackless`.
    pub traversal: String,
    /// The sampler (`--sampler`): `sobol` or `random`.
    pub sampler: String,
    /// `--noise-pattern`: `per-frame` or `fixed`.
    pub noise_pattern: String,
    /// The material features compiled into the path tracer for this scene:
    /// `metallic_roughness` always, `textures` when some material is
    /// textured, `transmission` when some material uses
    /// KHR_materials_transmission, _ior or _volume.
    pub material_features: Vec<String>,
    /// How next-event estimation chose among the frame's lights: `tree`
    /// (the light tree holds the emitters, and the point and spot lights
    /// past 8 if any), `tree for point lights` (the emitters by power),
    /// or `power` (everything by power; also when there is nothing to
    /// choose between).
    pub light_selection: String,
    /// The emissive triangles' extent as a fraction of the scene's (the
    /// diagonals of their bounds, over the shutter): by default the light
    /// tree holds them from 0.25. Absent without emitters, or with
    /// `--no-light-tree`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub emitter_spread: Option<f64>,
    /// The light tree's build on the device, in milliseconds of wall time
    /// (part of the trace's): absent without a tree.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub light_tree_ms: Option<f64>,
}

/// The camera of the frame, in world space. `projection` is `perspective`
/// (with `yfov_deg`, the full vertical field of view) or `orthographic`
/// (with `xmag`, `ymag`: glTF's half-extents of the view, scene units);
/// the fields of the other projection are left out.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct CameraLog {
    pub projection: String,
    pub position: [f64; 3],
    pub forward: [f64; 3],
    pub up: [f64; 3],
    #[serde(skip_serializing_if = "Option::is_none")]
    pub yfov_deg: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub xmag: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub ymag: Option<f64>,
    /// Depth of field (`--aperture`): the f-number and the distance to the
    /// plane in focus this frame.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub f_stop: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub focus_distance: Option<f64>,
}

/// The frame's files, as paths relative to where soupray ran (or absolute).
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
#[serde(default)]
pub struct OutputLog {
    pub exr: String,
    /// The preview, when `--png` was given.
    pub png: Option<String>,
    /// Whether the EXR's colour channels are f16 (`--half`).
    pub half: bool,
    /// The EXR's compression, as `--exr-compression` spells it (`zip:1`
    /// where zlib's level is not the default).
    pub compression: String,
    /// The AOVs in the EXR, as `--aov` names them.
    pub aovs: Vec<String>,
    /// The Cryptomatte layers in the EXR (`CryptoObject`, ...), and the
    /// ranks each keeps per pixel.
    pub cryptomatte: Vec<String>,
    pub cryptomatte_depth: Option<u32>,
}

impl FrameLog {
    /// A log with `schema` and `soupray` filled in.
    pub fn new() -> FrameLog {
        FrameLog {
            schema: LOG_SCHEMA,
            soupray: VERSION.to_string(),
            ..FrameLog::default()
        }
    }
}

/// Writes `log` as pretty JSON, atomically.
pub fn write_log(path: &Path, log: &FrameLog) -> Result<(), OutputError> {
    write_atomic(path, |out| {
        serde_json::to_writer_pretty(&mut *out, log).map_err(|e| OutputError::Encode {
            path: path.to_path_buf(),
            format: "JSON log",
            message: e.to_string(),
        })?;
        out.write_all(b"\n").map_err(io_err(path, "write"))
    })
}

/// Reads a frame log. A JSON file without the `frame` and `timings_ms`
/// fields is refused as not being a frame log.
pub fn read_log(path: &Path) -> Result<FrameLog, OutputError> {
    let bad = |message: String| OutputError::BadLog {
        path: path.to_path_buf(),
        message,
    };
    // A log is a few KiB; anything over 16 MiB, or not a regular file,
    // is not one.
    let bytes = crate::input::read_regular(path, 16 << 20).map_err(|e| match e.kind() {
        std::io::ErrorKind::InvalidInput | std::io::ErrorKind::InvalidData => bad(e.to_string()),
        _ => OutputError::Read {
            path: path.to_path_buf(),
            source: e,
        },
    })?;
    let text = String::from_utf8(bytes).map_err(|e| {
        bad(format!(
            "it is not UTF-8 text (invalid byte at {})",
            e.utf8_error().valid_up_to()
        ))
    })?;
    let value: serde_json::Value =
        serde_json::from_str(&text).map_err(|e| bad(format!("invalid JSON ({e})")))?;
    for key in ["frame", "timings_ms"] {
        if value.get(key).is_none() {
            return Err(bad(format!("it has no \"{key}\" field")));
        }
    }
    serde_json::from_value(value).map_err(|e| bad(e.to_string()))
}
