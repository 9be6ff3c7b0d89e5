//! Writing a frame's files: the EXR (its header through the `exr` crate,
//! its pixel blocks through `exr_blocks`), the optional
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
//! **EXR layout.** One part, scan lines, ZIP (16 lines) compression
//! unless `--exr-compression` chooses another lossless one (`ExrFormat`),
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

mod atomic;
mod exr_blocks;
mod log;

use crate::denoise::NOISY_LAYER;
use crate::film::light::{LIGHT_PASSES, LIGHT_PASS_NAMES};
use crate::film::Image;
pub(crate) use atomic::io_err;
pub use atomic::{check_target, temporary_owner, temporary_sibling, write_atomic};
use exr::meta::header::ImageAttributes;
use exr::prelude::traits::*;
use exr::prelude::{AttributeValue, Compression, IntegerBounds, LayerAttributes, Text, Vec2};
/// OpenEXR's ZIP predictor and level, for `benches/exr_write.rs`.
pub use exr_blocks::{zip_predict, zip_predict_bytewise, ZIP_LEVEL};
pub use log::*;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// The soupray version written into every file.
/// The soupray version written into every file.
pub const VERSION: &str = env!("CARGO_PKG_VERSION");

/// The lossless EXR compressions soupray writes (`--exr-compression`).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum ExrCompression {
    /// zlib over 16 scan lines: the smallest files, the default (as in
    /// Cycles and Nuke).
    #[default]
    Zip,
    /// zlib per scan line: ZIP's ratio, in smaller blocks.
    Zips,
    /// Wavelet and Huffman coding: for grainy images.
    Piz,
    /// Run lengths: fast, larger files.
    Rle,
    /// Stored as they are: the largest files.
    None,
}

impl ExrCompression {
    const ALL: [ExrCompression; 5] = [
        ExrCompression::Zip,
        ExrCompression::Zips,
        ExrCompression::Piz,
        ExrCompression::Rle,
        ExrCompression::None,
    ];

    /// The names `--exr-compression` takes, in the order above.
    pub const NAMES: [&'static str; 5] = {
        let mut names = [""; 5];
        let mut i = 0;
        while i < names.len() {
            names[i] = Self::ALL[i].name();
            i += 1;
        }
        names
    };

    /// Its `--exr-compression` name.
    pub const fn name(self) -> &'static str {
        match self {
            ExrCompression::Zip => "zip",
            ExrCompression::Zips => "zips",
            ExrCompression::Piz => "piz",
            ExrCompression::Rle => "rle",
            ExrCompression::None => "none",
        }
    }

    /// Whether its blocks are zlib streams, which take a level (`zip:N`).
    const fn is_zlib(self) -> bool {
        matches!(self, ExrCompression::Zip | ExrCompression::Zips)
    }

    fn exr(self) -> Compression {
        match self {
            ExrCompression::Zip => Compression::ZIP16,
            ExrCompression::Zips => Compression::ZIP1,
            ExrCompression::Piz => Compression::PIZ,
            ExrCompression::Rle => Compression::RLE,
            ExrCompression::None => Compression::Uncompressed,
        }
    }
}

impl std::str::FromStr for ExrCompression {
    type Err = ();
    fn from_str(s: &str) -> Result<ExrCompression, ()> {
        Self::ALL.into_iter().find(|c| c.name() == s).ok_or(())
    }
}

/// How the EXR stores its samples: `--half` and `--exr-compression`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ExrFormat {
    /// f16 colour channels (every channel but `Z` and the counts).
    pub half: bool,
    pub compression: ExrCompression,
    /// zlib's level for `zip` and `zips` blocks, 1 to 9 (`zip:N`);
    /// `ZIP_LEVEL` unless asked. Readers do not need it: it is not stored.
    pub zlib_level: u32,
}

impl Default for ExrFormat {
    fn default() -> Self {
        ExrFormat::FLOAT
    }
}

impl ExrFormat {
    /// f32 channels, ZIP: the default.
    pub const FLOAT: ExrFormat = ExrFormat {
        half: false,
        compression: ExrCompression::Zip,
        zlib_level: ZIP_LEVEL,
    };
    /// f16 channels, ZIP (`--half`).
    pub const HALF: ExrFormat = ExrFormat {
        half: true,
        compression: ExrCompression::Zip,
        zlib_level: ZIP_LEVEL,
    };

    /// Parses `--exr-compression`: a compression's name, or `zip:N` or
    /// `zips:N` with zlib's level N from 1 (fastest) to 9 (smallest), as
    /// OpenImageIO spells it. The compression and the zlib level; the
    /// error says what is wrong and what is accepted.
    pub fn parse_compression(text: &str) -> Result<(ExrCompression, u32), String> {
        let (name, level) = match text.split_once(':') {
            Some((name, level)) => (name, Some(level)),
            None => (text, None),
        };
        let compression: ExrCompression = name.parse().map_err(|_| {
            format!(
                "use one of {} (or zip:N, zips:N for zlib's level N from 1 to 9)",
                ExrCompression::NAMES.join(", ")
            )
        })?;
        let Some(level) = level else {
            return Ok((compression, ZIP_LEVEL));
        };
        if !compression.is_zlib() {
            return Err(format!(
                "only zip and zips take a level (zip:N); {name} has none"
            ));
        }
        match level.parse::<u32>() {
            Ok(n @ 1..=9) => Ok((compression, n)),
            _ => Err(format!(
                "zlib's level is a whole number from 1 (fastest) to 9 (smallest files), not {level:?}"
            )),
        }
    }

    /// The compression as `--exr-compression` spells it: `zip:N` where the
    /// level is not the default.
    pub fn compression_name(&self) -> String {
        let name = self.compression.name();
        if self.compression.is_zlib() && self.zlib_level != ZIP_LEVEL {
            format!("{name}:{}", self.zlib_level)
        } else {
            name.to_owned()
        }
    }
}

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
    format: ExrFormat,
) -> Result<(), OutputError> {
    write_exr_denoised(path, image, None, meta, format, &mut Vec::new())
}

/// `write_exr`, with the denoised beauty `denoised` (one RGB per pixel)
/// when given: it goes to `R`, `G`, `B`, and `image`'s raw RGB to the
/// `noisy` layer (see the module documentation). The file is encoded in
/// `encoded` first (cleared, its capacity kept): a writer of many frames
/// passes the same one each time, as a fresh buffer grows by copies into
/// fresh pages, a page fault per 4 KiB (80 MB a frame uncompressed with
/// every pass).
pub fn write_exr_denoised(
    path: &Path,
    image: &Image,
    denoised: Option<&[[f32; 3]]>,
    meta: &FrameMetadata,
    format: ExrFormat,
    encoded: &mut Vec<u8>,
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
    let size = Vec2(image.width as usize, image.height as usize);
    let mut image_attributes = ImageAttributes::new(IntegerBounds::from_dimensions(size));
    image_attributes.chromaticities = Some(exr::meta::attribute::Chromaticities {
        red: Vec2(0.64, 0.33),
        green: Vec2(0.30, 0.60),
        blue: Vec2(0.15, 0.06),
        white: Vec2(0.3127, 0.3290),
    });
    // Encoded in memory first: the exr crate writes the custom attributes
    // (frame, time, spp, seed) in its hash map's order, which changes from
    // run to run; `canonical_attribute_order` sorts them, so the same frame
    // is the same file byte for byte (for checksums and `cmp`).
    encoded.clear();
    exr_blocks::write_scan_lines(
        std::io::Cursor::new(&mut *encoded),
        exr_channels(image, denoised, format.half),
        size,
        format.compression.exr(),
        format.zlib_level,
        image_attributes,
        exr_attributes(image, meta),
    )
    .map_err(|e| OutputError::Encode {
        path: path.to_path_buf(),
        format: "EXR",
        message: e.to_string(),
    })?;
    canonical_attribute_order(encoded);
    write_atomic(path, |out| {
        out.write_all(encoded).map_err(|source| OutputError::Io {
            path: path.to_path_buf(),
            action: "write",
            source,
        })
    })
}

/// One EXR channel: its name, its samples where the film holds them (no
/// copy: a frame with every pass has 90 channels), and whether the file
/// stores them as f16.
pub(crate) struct ChannelView<'a> {
    pub name: String,
    pub samples: Strided<'a>,
    pub half: bool,
}

/// Samples `offset`, `offset + stride`, ... of `data`: one component of an
/// interleaved buffer, or a plane (stride 1).
#[derive(Clone, Copy)]
pub(crate) struct Strided<'a> {
    data: &'a [f32],
    stride: usize,
    offset: usize,
}

impl<'a> Strided<'a> {
    /// Component `offset` of `pixels`, `N` floats per pixel.
    fn component<const N: usize>(pixels: &'a [[f32; N]], offset: usize) -> Self {
        Strided {
            data: pixels.as_flattened(),
            stride: N,
            offset,
        }
    }

    fn plane(data: &'a [f32]) -> Self {
        Strided {
            data,
            stride: 1,
            offset: 0,
        }
    }

    /// The samples of pixels `first..first + count`.
    pub fn run(&self, first: usize, count: usize) -> impl Iterator<Item = f32> + 'a {
        let start = first * self.stride + self.offset;
        let end = (first + count - 1) * self.stride + self.offset + 1;
        let data: &'a [f32] = if count == 0 {
            &[]
        } else {
            &self.data[start..end]
        };
        data.iter().step_by(self.stride).copied()
    }
}

/// The EXR's channels: the beauty (denoised in `R`, `G`, `B` when given,
/// the raw one in the `noisy` layer), then each pass the image holds.
fn exr_channels<'a>(
    image: &'a Image,
    denoised: Option<&'a [[f32; 3]]>,
    half: bool,
) -> Vec<ChannelView<'a>> {
    let mut channels: Vec<ChannelView<'a>> = Vec::with_capacity(16);
    let mut push = |name: String, samples: Strided<'a>, half: bool| {
        channels.push(ChannelView {
            name,
            samples,
            half,
        });
    };
    for (c, name) in ["R", "G", "B", "A"].into_iter().enumerate() {
        let samples = match denoised {
            Some(d) if c < 3 => Strided::component(d, c),
            _ => Strided::component(&image.rgba, c),
        };
        push(name.to_owned(), samples, half);
    }
    if denoised.is_some() {
        for (c, name) in ["R", "G", "B"].into_iter().enumerate() {
            let samples = Strided::component(&image.rgba, c);
            push(format!("{NOISY_LAYER}.{name}"), samples, half);
        }
    }
    if let Some(z) = &image.depth {
        push("Z".to_owned(), Strided::plane(z), false);
    }
    // Counts and error estimates stay f32: half floats would round counts
    // past 2048.
    for (buf, name) in [
        (&image.sample_count, "sample_count"),
        (&image.noise, "noise"),
        (&image.rays, "rays"),
    ] {
        if let Some(v) = buf {
            push(name.to_owned(), Strided::plane(v), false);
        }
    }
    for (buf, names) in [
        (&image.normal, ["N.X", "N.Y", "N.Z"]),
        (&image.albedo, ["albedo.R", "albedo.G", "albedo.B"]),
    ] {
        if let Some(buf) = buf {
            for (c, name) in names.into_iter().enumerate() {
                push(name.to_owned(), Strided::component(buf, c), half);
            }
        }
    }
    // The data passes stay f32 whatever --half says: motion vectors in
    // pixels (Blender's Vector pass layout), first-hit positions and uvs,
    // object ids (exact integers) and the shadow catchers' factor.
    if let Some(m) = &image.motion {
        for (c, name) in ["Vector.X", "Vector.Y", "Vector.Z", "Vector.W"]
            .into_iter()
            .enumerate()
        {
            push(name.to_owned(), Strided::component(m, c), false);
        }
    }
    if let Some(p) = &image.position {
        for (c, name) in ["Position.X", "Position.Y", "Position.Z"]
            .into_iter()
            .enumerate()
        {
            push(name.to_owned(), Strided::component(p, c), false);
        }
    }
    if let Some(uv) = &image.uv {
        for (c, name) in ["UV.U", "UV.V"].into_iter().enumerate() {
            push(name.to_owned(), Strided::component(uv, c), false);
        }
    }
    if let Some(ids) = &image.object_id {
        push("object_id".to_owned(), Strided::plane(ids), false);
    }
    if let Some(shadow) = &image.shadow {
        for (c, name) in ["shadow.R", "shadow.G", "shadow.B"].into_iter().enumerate() {
            push(name.to_owned(), Strided::component(shadow, c), false);
        }
    }
    // Light-path passes are colours, as the beauty is: --half applies.
    let light = image.light.pixels.as_flattened().as_flattened();
    for &k in &image.light.written {
        for (c, component) in ["R", "G", "B"].into_iter().enumerate() {
            let samples = Strided {
                data: light,
                stride: 3 * LIGHT_PASSES as usize,
                offset: 3 * k + c,
            };
            push(
                format!("{}.{component}", LIGHT_PASS_NAMES[k]),
                samples,
                half,
            );
        }
    }
    // Cryptomatte: ids and coverages stay f32 whatever --half says (an id
    // is a hash's 32 bits). A pixel's ranks are `depth` (id, coverage)
    // pairs in a row.
    for layer in &image.mattes {
        for k in 0..layer.depth / 2 {
            for (c, name) in layer.channel_names(k).into_iter().enumerate() {
                let (rank, part) = (2 * k + c / 2, c % 2);
                let samples = Strided {
                    data: layer.ranks.as_flattened(),
                    stride: 2 * layer.depth,
                    offset: 2 * rank + part,
                };
                push(name, samples, false);
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
    exr::prelude::read()
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::{Aovs, Image};
    use exr::prelude::FlatSamples;

    #[test]
    fn exr_compression_parses_names_and_zlib_levels() {
        let parse = ExrFormat::parse_compression;
        assert_eq!(parse("zip"), Ok((ExrCompression::Zip, ZIP_LEVEL)));
        assert_eq!(parse("rle"), Ok((ExrCompression::Rle, ZIP_LEVEL)));
        assert_eq!(parse("zip:1"), Ok((ExrCompression::Zip, 1)));
        assert_eq!(parse("zips:9"), Ok((ExrCompression::Zips, 9)));
        for bad in ["zip:0", "zip:10", "zip:", "zip:x", "zip:-1"] {
            let err = parse(bad).unwrap_err();
            assert!(
                err.starts_with("zlib's level is a whole number"),
                "{bad}: {err}"
            );
        }
        assert!(parse("piz:4").unwrap_err().contains("only zip and zips"));
        assert!(parse("lz4")
            .unwrap_err()
            .starts_with("use one of zip, zips"));
        // The log's spelling: the level only where it is not the default,
        // and read back as given.
        for text in ["zip", "zip:1", "zips:9", "rle", "none"] {
            let (compression, zlib_level) = parse(text).unwrap();
            let format = ExrFormat {
                half: false,
                compression,
                zlib_level,
            };
            assert_eq!(format.compression_name(), text);
        }
        let explicit = parse(&format!("zip:{ZIP_LEVEL}")).unwrap();
        assert_eq!(explicit, (ExrCompression::Zip, ZIP_LEVEL));
    }

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
                write_exr(&p, &img, &meta, ExrFormat::FLOAT).unwrap();
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

    /// A writer's reused buffer gives each file as a fresh one does: a
    /// small frame after a large one is not left with the large one's tail.
    #[test]
    fn a_reused_encoding_buffer_writes_each_file_as_a_fresh_one() {
        let dir = tempfile::tempdir().unwrap();
        let meta = FrameMetadata {
            frame: 1,
            time: 0.0,
            spp: 4,
            seed: 0,
        };
        let mut large = Image::new(40, 30, Aovs::ALL);
        for (i, p) in large.rgba.iter_mut().enumerate() {
            *p = [i as f32 * 0.37, 0.5, (i % 7) as f32, 1.0];
        }
        let small = Image::new(3, 2, Aovs::NONE);
        let mut encoded = Vec::new();
        for (k, img) in [&large, &small, &large].into_iter().enumerate() {
            let reused = dir.path().join(format!("reused{k}.exr"));
            let fresh = dir.path().join(format!("fresh{k}.exr"));
            let format = ExrFormat::FLOAT;
            write_exr_denoised(&reused, img, None, &meta, format, &mut encoded).unwrap();
            write_exr(&fresh, img, &meta, format).unwrap();
            assert_eq!(
                std::fs::read(&reused).unwrap(),
                std::fs::read(&fresh).unwrap(),
                "file {k}"
            );
        }
    }

    /// Every compression, in f16 and f32, reads back with the `exr` crate
    /// as exactly the samples written: soupray gathers and ZIP-compresses
    /// the blocks itself (`exr_blocks`). 37 lines: two full 16-line ZIP
    /// blocks and a short one; smooth channels (which compress) and
    /// random bits, NaNs and infinities included (which do not).
    #[test]
    fn every_compression_writes_the_exact_samples() {
        let (w, h) = (13u32, 37u32);
        let n = (w * h) as usize;
        let mut state = 0x2545_f491_u32;
        let mut bits = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            f32::from_bits(state)
        };
        let mut img = Image::new(w, h, Aovs::NONE);
        img.rgba = (0..n)
            .map(|i| [i as f32 * 0.01, 0.5, bits(), 1.0])
            .collect();
        // Random bits alone do not compress: ZIP stores such blocks raw.
        img.albedo = Some((0..n).map(|_| [bits(), bits(), bits()]).collect());
        img.depth = Some((0..n).map(|_| bits()).collect());
        img.normal = Some((0..n).map(|i| [0.0, 1.0, (i % 7) as f32]).collect());
        img.motion = Some(
            (0..n)
                .map(|_| [bits(), bits(), -1.5, f32::INFINITY])
                .collect(),
        );
        img.object_id = Some((0..n).map(|i| (i / 40) as f32).collect());
        let meta = FrameMetadata {
            frame: 1,
            time: 0.0,
            spp: 1,
            seed: 0,
        };
        let dir = tempfile::tempdir().unwrap();
        // Every compression, and zip at zlib's fastest and smallest levels.
        let formats = ExrCompression::ALL
            .into_iter()
            .map(|c| (c, ZIP_LEVEL))
            .chain([(ExrCompression::Zip, 1), (ExrCompression::Zips, 9)]);
        for (compression, zlib_level) in formats {
            for half in [false, true] {
                let format = ExrFormat {
                    half,
                    compression,
                    zlib_level,
                };
                let p = dir
                    .path()
                    .join(format!("{}-{half}.exr", format.compression_name()));
                write_exr(&p, &img, &meta, format).unwrap();
                let read = exr::prelude::read()
                    .no_deep_data()
                    .largest_resolution_level()
                    .all_channels()
                    .first_valid_layer()
                    .all_attributes()
                    .from_file(&p)
                    .unwrap_or_else(|e| panic!("{}: {e}", p.display()));
                let read = &read.layer_data.channel_data.list;
                let written = exr_channels(&img, None, half);
                assert_eq!(read.len(), written.len());
                for c in &written {
                    let back = read.iter().find(|r| r.name.eq(c.name.as_str())).unwrap();
                    let got: Vec<u32> = match &back.sample_data {
                        FlatSamples::F16(v) => v.iter().map(|x| x.to_bits() as u32).collect(),
                        FlatSamples::F32(v) => v.iter().map(|x| x.to_bits()).collect(),
                        FlatSamples::U32(v) => v.clone(),
                    };
                    let want: Vec<u32> = c
                        .samples
                        .run(0, n)
                        .map(|x| {
                            if c.half {
                                exr::prelude::f16::from_f32(x).to_bits() as u32
                            } else {
                                x.to_bits()
                            }
                        })
                        .collect();
                    assert!(
                        matches!(back.sample_data, FlatSamples::F16(_)) == c.half,
                        "{}: channel {} has the wrong type",
                        p.display(),
                        c.name
                    );
                    assert!(got == want, "{}: channel {} differs", p.display(), c.name);
                }
            }
        }
        // ZIP does compress: the smooth channels shrink the file.
        let size = |name: &str| std::fs::metadata(dir.path().join(name)).unwrap().len();
        assert!(size("zip-false.exr") < size("none-false.exr") * 9 / 10);
        // And a block of random bits alone is stored raw, and reads back.
        let mut noise = Image::new(w, 2, Aovs::NONE);
        noise.rgba = (0..2 * w as usize)
            .map(|_| [bits(), bits(), bits(), bits()])
            .collect();
        let p = dir.path().join("noise.exr");
        write_exr(&p, &noise, &meta, ExrFormat::FLOAT).unwrap();
        let back = read_exr_rgba(&p).unwrap().rgba;
        let as_bits = |v: &[[f32; 4]]| v.iter().flatten().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(as_bits(&back), as_bits(&noise.rgba));
        assert!(
            size("noise.exr") > 2 * w as u64 * 16,
            "stored raw: {}",
            size("noise.exr")
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
