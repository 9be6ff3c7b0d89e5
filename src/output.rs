//! Writing a frame's files: the EXR (through the `exr` crate), the optional
//! PNG preview, and the per-frame JSON build log; plus the checks
//! `--skip-existing` uses to tell a finished frame from an interrupted one.
//!
//! Every file is written to `temporary_sibling(path)` in the same
//! directory, flushed and fsynced, then renamed over the final name (and the
//! directory fsynced, so the rename survives a power cut). A killed run
//! therefore never leaves a truncated file under a final name; on an error
//! the temporary is removed. A run killed mid-write can leave a hidden
//! `.NAME.PID.tmp`, which is never mistaken for a frame and may be deleted.
//!
//! **EXR layout.** One part, scan lines, ZIP (16 lines) compression,
//! display window = data window = the frame, Rec.709 primaries with a D65
//! white (glTF's linear sRGB). Channels: `R`, `G`, `B`, `A` (linear,
//! premultiplied by coverage), and with the AOVs `Z` (camera distance),
//! `N.X`, `N.Y`, `N.Z` (world-space normal) and `albedo.R`, `albedo.G`,
//! `albedo.B`: the layer.channel names Nuke splits into layers and Blender
//! reads; `sample_count` (samples the pixel took), `noise` (its estimated
//! relative error, `film::noise_estimate`) and `rays` (rays it traced),
//! always f32. EXR stores channels sorted by name, so a reader lists them as
//! `A, B, G, N.X, ..., R, Z, albedo.B, ...`. With `--half` every channel is
//! f16 except `Z`, which stays f32: depths beyond 65504 (including the
//! 1e10 background) do not fit a half float, as in Blender.
//!
//! **Denoised frames** (`--denoise`): `R`, `G`, `B` hold the denoised
//! beauty, so every viewer and compositor shows the final image by default,
//! and the raw (noisy) beauty is kept as the layer `noisy.R`, `noisy.G`,
//! `noisy.B` (`NOISY_LAYER`); `A` is the coverage of both. oiiotool reads
//! the layer with `--ch noisy.R,noisy.G,noisy.B` (or `--ch
//! R=noisy.R,G=noisy.G,B=noisy.B,A`); Blender's Image node shows it as the
//! pass `noisy` beside the combined image, as it does `albedo` and `N`.
//!
//! **EXR metadata.** `software` = `soupray <version>` (a standard
//! attribute), and custom attributes `frame` (int; double for frames
//! outside ±2^31), `time` (double, seconds), `spp` (int) and `seed`
//! (string: EXR has no 64-bit integer type).
//!
//! **PNG preview.** Exposure (`2^stops` multiplier), then the sRGB OETF
//! (IEC 61966-2-1), clamped to [0, 1], 8 bits per channel, opaque: the
//! premultiplied colour as composited over black. No filmic curve: the
//! preview is for checking frames, not grading them.
//!
//! **Build log.** `FrameLog` below documents the JSON schema.

use crate::bvh::device_builder::StageTimes;
use crate::denoise::NOISY_LAYER;
use crate::film::Image;
use exr::prelude::traits::*;
use exr::prelude::{
    f16, AnyChannel, AnyChannels, AttributeValue, Blocks, Compression, Encoding, FlatSamples,
    Layer, LayerAttributes, LineOrder, SmallVec, Text, Vec2,
};
use serde::{Deserialize, Serialize};
use std::fs::File;
use std::io::{BufWriter, Write as _};
use std::path::{Path, PathBuf};

/// The soupray version written into every file.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// What the EXR header records about how the frame was made.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameMetadata {
    pub frame: i64,
    /// Animation time of the frame, seconds.
    pub time: f64,
    pub spp: u32,
    pub seed: u64,
}

/// Writing or reading an output file failed. Names the file and the fix.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{}: cannot {action}: {source}; check the output directory is writable and has space", path.display())]
    Io {
        path: PathBuf,
        action: &'static str,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: cannot encode the {format}: {message}", path.display())]
    Encode {
        path: PathBuf,
        format: &'static str,
        message: String,
    },
    /// An input of `report` (a frame log) could not be read.
    #[error("{}: cannot read: {source}; check that the file is readable", path.display())]
    Read {
        path: PathBuf,
        #[source]
        source: std::io::Error,
    },
    #[error("{}: not a soupray frame log: {message}; delete or move it out of the directory", path.display())]
    BadLog { path: PathBuf, message: String },
    /// The output path names something other than a regular file (a
    /// device, FIFO, directory, socket or symbolic link), which a rename
    /// would replace. It is left untouched.
    #[error("{}: is {kind}; soupray writes only regular files and never replaces {kind}. Fix: choose another output path", path.display())]
    NotRegular { path: PathBuf, kind: &'static str },
}

/// Checks that writing `path` would replace nothing but a regular file:
/// it must not exist, or be a regular file (not a symbolic link, device,
/// FIFO, socket or directory). `write_atomic` calls it before creating the
/// temporary and again just before the rename.
pub fn check_target(path: &Path) -> Result<(), OutputError> {
    let meta = match std::fs::symlink_metadata(path) {
        Ok(m) => m,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(e) => return Err(io_err(path, "inspect")(e)),
    };
    let ft = meta.file_type();
    if ft.is_file() {
        return Ok(());
    }
    Err(OutputError::NotRegular {
        path: path.to_path_buf(),
        kind: crate::input::kind_of(&ft),
    })
}

pub(crate) fn io_err<'a>(
    path: &'a Path,
    action: &'static str,
) -> impl FnOnce(std::io::Error) -> OutputError + 'a {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        action,
        source,
    }
}

/// A temporary path in the same directory as `path`, so that a finished file
/// can be renamed into place atomically (rename is atomic only within one
/// file system): `.<name>.<pid>.tmp`. The process id keeps concurrent
/// writers apart and tells a later run whose temporary it is.
pub fn temporary_sibling(path: &Path) -> PathBuf {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    path.with_file_name(format!(".{name}.{}.tmp", std::process::id()))
}

/// The target file name and writer's process id of a temporary made by
/// `temporary_sibling`, from its file name; `None` for any other file.
pub fn temporary_owner(file_name: &str) -> Option<(&str, u32)> {
    let inner = file_name.strip_prefix('.')?.strip_suffix(".tmp")?;
    let (target, pid) = inner.rsplit_once('.')?;
    Some((target, pid.parse().ok()?))
}

/// Writes `path` atomically: `write` fills a temporary file beside it,
/// which is flushed, fsynced and renamed over `path`. On any error the
/// temporary is removed and `path` is untouched. `path` must not name
/// anything but a regular file (`check_target`), or nothing is written.
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&mut BufWriter<&File>) -> Result<(), OutputError>,
) -> Result<(), OutputError> {
    check_target(path)?;
    let tmp = temporary_sibling(path);
    let result = (|| {
        let file = File::create(&tmp).map_err(io_err(path, "create a temporary file for"))?;
        let mut out = BufWriter::new(&file);
        write(&mut out)?;
        out.flush().map_err(io_err(path, "write"))?;
        drop(out);
        file.sync_all().map_err(io_err(path, "flush to disk"))?;
        drop(file);
        check_target(path)?;
        std::fs::rename(&tmp, path).map_err(io_err(path, "rename the finished temporary file onto"))
    })();
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
        return result;
    }
    // Persist the rename itself; best effort, as not every platform or
    // file system lets a directory be opened and synced.
    if let Some(dir) = path.parent() {
        let dir = if dir.as_os_str().is_empty() {
            Path::new(".")
        } else {
            dir
        };
        if let Ok(d) = File::open(dir) {
            let _ = d.sync_all();
        }
    }
    Ok(())
}

/// Reads the R, G, B, A channels of an EXR's first RGBA layer (the AOVs
/// are not read): for comparisons in the tests and benchmarks.
pub fn read_exr_rgba(path: &Path) -> Result<Image, exr::error::Error> {
    use crate::film::Aovs;
    let image = exr::prelude::read_first_rgba_layer_from_file(
        path,
        |res, _| {
            let img = Image::new(res.width() as u32, res.height() as u32, Aovs::default());
            (img, res.width())
        },
        |(img, w), pos, (r, g, b, a): (f32, f32, f32, f32)| {
            img.rgba[pos.y() * *w + pos.x()] = [r, g, b, a];
        },
    )?;
    Ok(image.layer_data.channel_data.pixels.0)
}

/// Encodes `image` as the EXR described in the module documentation and
/// writes it atomically to `path`.
pub fn write_exr(
    path: &Path,
    image: &Image,
    meta: &FrameMetadata,
    half: bool,
) -> Result<(), OutputError> {
    write_exr_denoised(path, image, None, meta, half)
}

/// `write_exr`, with the denoised beauty `denoised` (one RGB per pixel)
/// when given: it goes to `R`, `G`, `B`, and `image`'s raw RGB to the
/// `noisy` layer (see the module documentation).
pub fn write_exr_denoised(
    path: &Path,
    image: &Image,
    denoised: Option<&[[f32; 3]]>,
    meta: &FrameMetadata,
    half: bool,
) -> Result<(), OutputError> {
    let n = image.width as usize * image.height as usize;
    if image.rgba.len() != n {
        return Err(OutputError::Encode {
            path: path.to_path_buf(),
            format: "EXR",
            message: format!("image buffer holds {} pixels, not {n}", image.rgba.len()),
        });
    }
    if denoised.is_some_and(|d| d.len() != n) {
        return Err(OutputError::Encode {
            path: path.to_path_buf(),
            format: "EXR",
            message: format!("denoised image holds a different number of pixels than {n}"),
        });
    }
    let channels = exr_channels(image, denoised, half);
    let attrs = exr_attributes(image, meta);

    let size = (image.width as usize, image.height as usize);
    let encoding = Encoding {
        compression: Compression::ZIP16,
        blocks: Blocks::ScanLines,
        line_order: LineOrder::Increasing,
    };
    let layer = Layer::new(
        size,
        attrs,
        encoding,
        AnyChannels::sort(SmallVec::from_vec(channels)),
    );
    let mut exr_image = exr::image::Image::from_layer(layer);
    exr_image.attributes.chromaticities = Some(exr::meta::attribute::Chromaticities {
        red: Vec2(0.64, 0.33),
        green: Vec2(0.30, 0.60),
        blue: Vec2(0.15, 0.06),
        white: Vec2(0.3127, 0.3290),
    });
    // Encoded in memory first: the exr crate writes the custom attributes
    // (frame, time, spp, seed) in its hash map's order, which changes from
    // run to run; `canonical_attribute_order` sorts them, so the same frame
    // is the same file byte for byte (for checksums and `cmp`).
    let mut bytes = std::io::Cursor::new(Vec::new());
    exr_image
        .write()
        .to_buffered(&mut bytes)
        .map_err(|e| OutputError::Encode {
            path: path.to_path_buf(),
            format: "EXR",
            message: e.to_string(),
        })?;
    let mut bytes = bytes.into_inner();
    canonical_attribute_order(&mut bytes);
    write_atomic(path, |out| {
        out.write_all(&bytes).map_err(|source| OutputError::Io {
            path: path.to_path_buf(),
            action: "write",
            source,
        })
    })
}

/// The EXR's channels: the beauty (denoised in `R`, `G`, `B` when given,
/// the raw one in the `noisy` layer), then each pass the image holds.
fn exr_channels(
    image: &Image,
    denoised: Option<&[[f32; 3]]>,
    half: bool,
) -> Vec<AnyChannel<FlatSamples>> {
    let mut channels: Vec<AnyChannel<FlatSamples>> = Vec::with_capacity(14);
    for (c, name) in ["R", "G", "B", "A"].into_iter().enumerate() {
        let v = match denoised {
            Some(d) if c < 3 => d.iter().map(|p| p[c]).collect(),
            _ => image.rgba.iter().map(|p| p[c]).collect(),
        };
        channels.push(AnyChannel::new(name, samples(v, half)));
    }
    if denoised.is_some() {
        for (c, name) in ["R", "G", "B"].into_iter().enumerate() {
            let v = image.rgba.iter().map(|p| p[c]).collect();
            let name = format!("{NOISY_LAYER}.{name}");
            channels.push(AnyChannel::new(name.as_str(), samples(v, half)));
        }
    }
    if let Some(z) = &image.depth {
        channels.push(AnyChannel::new("Z", samples(z.clone(), false)));
    }
    // Counts and error estimates stay f32: half floats would round counts
    // past 2048.
    for (buf, name) in [
        (&image.sample_count, "sample_count"),
        (&image.noise, "noise"),
        (&image.rays, "rays"),
    ] {
        if let Some(v) = buf {
            channels.push(AnyChannel::new(name, samples(v.clone(), false)));
        }
    }
    for (buf, names) in [
        (&image.normal, ["N.X", "N.Y", "N.Z"]),
        (&image.albedo, ["albedo.R", "albedo.G", "albedo.B"]),
    ] {
        if let Some(buf) = buf {
            channels.extend(component_channels(names, buf, half));
        }
    }

    // The data passes stay f32 whatever --half says: motion vectors in
    // pixels (Blender's Vector pass layout), first-hit positions and uvs,
    // object ids (exact integers) and the shadow catchers' factor.
    if let Some(m) = &image.motion {
        let names = ["Vector.X", "Vector.Y", "Vector.Z", "Vector.W"];
        channels.extend(component_channels(names, m, false));
    }
    if let Some(p) = &image.position {
        let names = ["Position.X", "Position.Y", "Position.Z"];
        channels.extend(component_channels(names, p, false));
    }
    if let Some(uv) = &image.uv {
        channels.extend(component_channels(["UV.U", "UV.V"], uv, false));
    }
    if let Some(ids) = &image.object_id {
        channels.push(AnyChannel::new("object_id", samples(ids.clone(), false)));
    }
    if let Some(shadow) = &image.shadow {
        let names = ["shadow.R", "shadow.G", "shadow.B"];
        channels.extend(component_channels(names, shadow, false));
    }
    // Light-path passes are colours, as the beauty is: --half applies.
    for pass in &image.light {
        for (c, component) in ["R", "G", "B"].into_iter().enumerate() {
            let v = pass.pixels.iter().map(|p| p[c]).collect();
            let name = format!("{}.{component}", pass.name());
            channels.push(AnyChannel::new(name.as_str(), samples(v, half)));
        }
    }
    // Cryptomatte: ids and coverages stay f32 whatever --half says (an id
    // is a hash's 32 bits).
    for layer in &image.mattes {
        for k in 0..layer.depth / 2 {
            for (c, name) in layer.channel_names(k).iter().enumerate() {
                let (rank, part) = (2 * k + c / 2, c % 2);
                let v = layer
                    .ranks
                    .chunks(layer.depth)
                    .map(|ranks| ranks[rank][part])
                    .collect();
                channels.push(AnyChannel::new(name.as_str(), samples(v, false)));
            }
        }
    }
    channels
}

/// The EXR's header attributes: the frame, its time, spp and seed, and the
/// Cryptomatte manifests.
fn exr_attributes(image: &Image, meta: &FrameMetadata) -> LayerAttributes {
    let mut attrs = LayerAttributes {
        software_name: Some(Text::from(format!("soupray {VERSION}").as_str())),
        ..LayerAttributes::default()
    };
    let mut put = |k: &str, v: AttributeValue| {
        attrs.other.insert(Text::from(k), v);
    };
    put(
        "frame",
        i32::try_from(meta.frame)
            .map_or(AttributeValue::F64(meta.frame as f64), AttributeValue::I32),
    );
    put("time", AttributeValue::F64(meta.time));
    for layer in &image.mattes {
        for (k, v) in layer.attributes() {
            // UTF-8 bytes as Cycles writes them: names need not be
            // Latin-1, which is all `Text::from` takes.
            put(
                &k,
                AttributeValue::Text(Text::from_slice_unchecked(v.as_bytes())),
            );
        }
    }
    put(
        "spp",
        i32::try_from(meta.spp).map_or(AttributeValue::F64(meta.spp as f64), AttributeValue::I32),
    );
    put(
        "seed",
        AttributeValue::Text(Text::from(meta.seed.to_string().as_str())),
    );
    attrs
}

/// A channel's samples, f16 with `half`.
fn samples(v: Vec<f32>, half: bool) -> FlatSamples {
    if half {
        FlatSamples::F16(v.into_iter().map(f16::from_f32).collect())
    } else {
        FlatSamples::F32(v)
    }
}

/// One channel per component of `pixels`, named by `names`.
fn component_channels<'p, const N: usize>(
    names: [&'static str; N],
    pixels: &'p [[f32; N]],
    half: bool,
) -> impl Iterator<Item = AnyChannel<FlatSamples>> + 'p {
    names.into_iter().enumerate().map(move |(c, name)| {
        let v = pixels.iter().map(|p| p[c]).collect();
        AnyChannel::new(name, samples(v, half))
    })
}

/// Sorts the header attributes of a single-part EXR by name, in place. The
/// header keeps its length, so the offset table after it stays valid; the
/// specification leaves attribute order free. Anything but a single-part
/// file with a well-formed header is left as it is.
fn canonical_attribute_order(exr: &mut [u8]) {
    const MULTIPART: u32 = 0x1000;
    const NON_IMAGE: u32 = 0x800;
    if exr.len() < 8 || exr[..4] != [0x76, 0x2f, 0x31, 0x01] {
        return;
    }
    let flags = u32::from_le_bytes([exr[4], exr[5], exr[6], exr[7]]);
    if flags & (MULTIPART | NON_IMAGE) != 0 {
        return;
    }
    // Each attribute: name NUL, type NUL, i32 size, value; a NUL ends the header.
    let nul_after = |at: usize| exr.get(at..)?.iter().position(|&b| b == 0).map(|i| at + i);
    let mut spans: Vec<(usize, usize, usize)> = Vec::new(); // start, name end, end
    let mut at = 8;
    loop {
        let Some(name_end) = nul_after(at) else {
            return;
        };
        if name_end == at {
            break; // the header's terminating NUL
        }
        let Some(type_end) = nul_after(name_end + 1) else {
            return;
        };
        let Some(size) = exr.get(type_end + 1..type_end + 5) else {
            return;
        };
        let size = i32::from_le_bytes([size[0], size[1], size[2], size[3]]);
        let Ok(size) = usize::try_from(size) else {
            return;
        };
        let end = type_end + 5 + size;
        if end > exr.len() {
            return;
        }
        spans.push((at, name_end, end));
        at = end;
    }
    let header = exr[8..at].to_vec();
    spans.sort_by(|a, b| header[a.0 - 8..a.1 - 8].cmp(&header[b.0 - 8..b.1 - 8]));
    let mut sorted = Vec::with_capacity(header.len());
    for (start, _, end) in spans {
        sorted.extend_from_slice(&header[start - 8..end - 8]);
    }
    exr[8..at].copy_from_slice(&sorted);
}

/// Whether `path` is a complete, readable EXR: every block present and
/// decodable (pedantic reading, so a truncated or corrupted file is caught
/// whatever its header claims). Decoding costs about as much as a load in
/// a compositor, far less than rendering the frame again.
pub fn is_complete_exr(path: &Path) -> bool {
    // A FIFO or device under a frame's name would block or never end.
    if crate::input::open_regular(path).is_err() {
        return false;
    }
    read()
        .no_deep_data()
        .all_resolution_levels()
        .all_channels()
        .all_layers()
        .all_attributes()
        .pedantic()
        .from_file(path)
        .is_ok()
}

/// Whether a frame can be skipped by `--skip-existing`: its EXR is complete
/// and its build log parses. The log is written after the EXR, so a run
/// killed between the two re-renders the frame rather than leaving it
/// without a log.
pub fn is_frame_done(exr: &Path, log: &Path) -> bool {
    is_complete_exr(exr) && read_log(log).is_ok()
}

/// The 8-bit sRGB value of a linear value after `gain`.
fn srgb8(linear: f32, gain: f32) -> u8 {
    let v = linear * gain;
    // NaN (a broken pixel) maps to black rather than poisoning the cast.
    let v = if v.is_nan() { 0.0 } else { v.clamp(0.0, 1.0) };
    let e = if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    };
    (e * 255.0 + 0.5) as u8
}

/// Tonemaps `image` as described in the module documentation (exposure in
/// stops) into 8-bit sRGB, row-major, 3 bytes per pixel.
pub fn tonemap_srgb8(image: &Image, exposure: f32) -> Vec<u8> {
    tonemap_pixels(image.rgba.iter().copied(), exposure)
}

fn tonemap_pixels(rgba: impl Iterator<Item = [f32; 4]>, exposure: f32) -> Vec<u8> {
    let gain = exposure.exp2();
    rgba.flat_map(|p| [srgb8(p[0], gain), srgb8(p[1], gain), srgb8(p[2], gain)])
        .collect()
}

/// The neutral grey, linear, that `--transparent` previews are composited
/// over (photographic middle grey).
pub const PREVIEW_GREY: f32 = 0.18;

/// `image` composited over a constant linear `background` (its beauty is
/// premultiplied by alpha): what a transparent frame looks like over a plate.
pub fn over_background(image: &Image, background: [f32; 3]) -> Image {
    let mut out = image.clone();
    for p in &mut out.rgba {
        *p = over(*p, background);
    }
    out
}

/// One premultiplied pixel over a constant linear `background`.
fn over(p: [f32; 4], background: [f32; 3]) -> [f32; 4] {
    let a = p[3].clamp(0.0, 1.0);
    let mut out = [0.0, 0.0, 0.0, 1.0];
    for c in 0..3 {
        out[c] = p[c] + (1.0 - a) * background[c];
    }
    out
}

/// Writes the tonemapped preview of `image` as a PNG, atomically; a
/// transparent frame is shown over `PREVIEW_GREY`.
pub fn write_png_preview(
    path: &Path,
    image: &Image,
    exposure: f32,
    transparent: bool,
) -> Result<(), OutputError> {
    use image::ImageEncoder as _;
    // Composited pixel by pixel as they are tonemapped: no copy of the
    // frame and its AOVs.
    let pixels = if transparent {
        let grey = [PREVIEW_GREY; 3];
        tonemap_pixels(image.rgba.iter().map(|&p| over(p, grey)), exposure)
    } else {
        tonemap_srgb8(image, exposure)
    };
    write_atomic(path, |out| {
        image::codecs::png::PngEncoder::new(out)
            .write_image(
                &pixels,
                image.width,
                image.height,
                image::ExtendedColorType::Rgb8,
            )
            .map_err(|e| OutputError::Encode {
                path: path.to_path_buf(),
                format: "PNG",
                message: e.to_string(),
            })
    })
}

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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::{Aovs, Image};

    #[test]
    fn the_same_frame_is_the_same_file_byte_for_byte() {
        // The custom attributes live in a hash map whose order changes with
        // every map: without sorting, two writes differed.
        let dir = tempfile::tempdir().unwrap();
        let mut img = Image::new(3, 2, Aovs::NONE);
        img.rgba[4] = [0.5, 0.25, 1.0, 1.0];
        let meta = FrameMetadata {
            frame: 12,
            time: 0.5,
            spp: 16,
            seed: 3,
        };
        let files: Vec<Vec<u8>> = (0..6)
            .map(|i| {
                let p = dir.path().join(format!("f{i}.exr"));
                write_exr(&p, &img, &meta, false).unwrap();
                std::fs::read(&p).unwrap()
            })
            .collect();
        assert!(files.windows(2).all(|w| w[0] == w[1]), "the writes differ");
        // And the sorted file still reads back whole, attributes included.
        let p = dir.path().join("f0.exr");
        assert!(is_complete_exr(&p));
        assert_eq!(read_exr_rgba(&p).unwrap().rgba, img.rgba);
        let names: Vec<usize> = ["frame", "seed", "spp", "time"]
            .iter()
            .map(|n| {
                let key = format!("{n}\0");
                files[0]
                    .windows(key.len())
                    .position(|w| w == key.as_bytes())
                    .unwrap_or_else(|| panic!("no {n} attribute"))
            })
            .collect();
        assert!(
            names.windows(2).all(|w| w[0] < w[1]),
            "not sorted: {names:?}"
        );
    }

    #[test]
    fn srgb_oetf_and_exposure() {
        assert_eq!(srgb8(0.0, 1.0), 0);
        assert_eq!(srgb8(1.0, 1.0), 255);
        assert_eq!(srgb8(7.0, 1.0), 255, "clamped");
        assert_eq!(srgb8(-1.0, 1.0), 0);
        assert_eq!(srgb8(f32::NAN, 1.0), 0);
        // Linear 0.18 is sRGB 0.4613 → 118.
        assert_eq!(srgb8(0.18, 1.0), 118);
        // One stop up: 0.36 → 0.6342 → 162.
        assert_eq!(srgb8(0.18, 2f32.powf(1.0)), 162);
        // The linear toe: 0.002 → 0.02584 → 7.
        assert_eq!(srgb8(0.002, 1.0), 7);
        let mut img = Image::new(2, 1, Aovs::NONE);
        img.rgba[1] = [0.09, 0.18, 1.0, 1.0];
        assert_eq!(tonemap_srgb8(&img, 1.0), vec![0, 0, 0, 118, 162, 255]);
    }

    #[test]
    fn log_round_trip_and_rejection() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.0001.json");
        let mut log = FrameLog::new();
        log.frame = -3;
        log.camera.yfov_deg = Some(40.0);
        log.warnings.push("w".into());
        write_log(&path, &log).unwrap();
        assert_eq!(read_log(&path).unwrap(), log);
        let text = std::fs::read_to_string(&path).unwrap();
        assert!(text.contains("\"yfov_deg\"") && !text.contains("\"xmag\""));
        std::fs::write(&path, "{\"name\": \"package\"}").unwrap();
        let e = read_log(&path).unwrap_err().to_string();
        assert!(e.contains("x.0001.json") && e.contains("\"frame\""), "{e}");
        std::fs::write(&path, "{\"frame\": 1, \"timings").unwrap();
        assert!(read_log(&path)
            .unwrap_err()
            .to_string()
            .contains("invalid JSON"));
    }
}
