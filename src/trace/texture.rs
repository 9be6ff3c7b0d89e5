//! Textures on the device: the images a scene's materials sample, decoded
//! once and uploaded as one texel buffer with one [`TextureInfo`] record per
//! texture, the per-slot [`TextureBinding`]s the shading kernels sample
//! through (`kernels/trace/texture.h`), and the plain Rust reference of that
//! sampling ([`texture_uv_ref`], [`sample_texture_ref`]) which the tests hold
//! the device to, bit for bit.
//!
//! Layout: every texel is RGBA8 packed into one `u32` (R in the low byte,
//! rows top to bottom), so host and device memory stay at 4 bytes a texel;
//! textures that share an image share its texels. Only the images of the
//! slots a renderer samples are decoded: base colour, metallic-roughness,
//! normal and emissive ([`Slot::SHADED`]). Occlusion maps are skipped by
//! default because a path tracer computes the occlusion they bake, so a
//! missing AO image does not stop a render ([`TextureSet::with_slots`] asks
//! for them). An untextured scene gets an empty set and no device buffers.
//!
//! sRGB is a property of the *use*: base colour and emissive textures are
//! sRGB-encoded, the others linear (glTF 2.0, section 3.9), so the flag lives in
//! the binding and one image can serve both kinds of slot. Decoding is by a
//! 512-entry table (`TEXTURE_DECODE` in `kernels/trace/texture.h`, [`decode_table`]
//! here), exact on every device, applied to texels before filtering as GPUs
//! do.
//!
//! KHR_texture_transform: the binding's 2x3 matrix is `T(offset) * R * S(scale)`
//! with `u' = cos·sx·u + sin·sy·v + ox`, `v' = -sin·sx·u + cos·sy·v + oy`: the
//! rotation the extension's own example and the Khronos sample viewer use
//! ("lower left quadrant, rotated clockwise 90°"; glTF issue #1563: the GLSL
//! listing in the extension text rotates the other way).

pub use crate::scene::material::Slot;
use std::cell::OnceCell;

use bytemuck::{Pod, Zeroable};
use opencl3::kernel::Kernel;
use opencl3::memory::Buffer;
use opencl3::program::Program;

use crate::device::{Arg, Device, DeviceError};
use crate::device_struct::{device_consts, device_struct};
use crate::scene::material::{Filter, Material, MaterialTable, TextureRef, TextureTransform, Wrap};
use crate::scene::SceneError;

device_consts! {
    fn texture_consts;
    /// [`TextureInfo::wrap_s`] / `wrap_t` values.
    pub const TEXTURE_WRAP_REPEAT: u32 = 0;
    pub const TEXTURE_WRAP_CLAMP_TO_EDGE: u32 = 1;
    pub const TEXTURE_WRAP_MIRRORED_REPEAT: u32 = 2;
    /// [`TextureInfo::filter`] values.
    pub const TEXTURE_FILTER_NEAREST: u32 = 0;
    pub const TEXTURE_FILTER_LINEAR: u32 = 1;
    /// [`TextureBinding::texture`] of a slot without a texture: it samples
    /// as (1, 1, 1, 1), which leaves a glTF factor unchanged.
    pub const TEXTURE_NONE: u32 = u32::MAX;
    /// `texture_triangle_mean` samples a triangle at the centroids of the
    /// grid² congruent triangles it divides into.
    pub const TEXTURE_MEAN_GRID: u32 = 4;
}

device_struct! {
/// One glTF texture (image + sampler) the scene samples. Its texels are
/// texels[offset + y * width + x], rows top to bottom (uv (0, 0) is the
/// image's upper left corner), each an RGBA8 texel packed as
/// R | G << 8 | B << 16 | A << 24. Textures sharing an image share texels.
/// Whether texels are sRGB is a property of the use, so it lives in
/// TextureBinding, not here.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Pod, Zeroable)]
pub struct TextureInfo as "TextureInfo" {
    pub offset: u32,
    pub width: u32,
    pub height: u32,
    pub wrap_s: u32,
    pub wrap_t: u32,
    /// The sampler's magFilter ([`TEXTURE_FILTER_NEAREST`] or [`TEXTURE_FILTER_LINEAR`]).
    pub filter: u32,
}
}

device_struct! {
/// A material slot's use of a texture: which texture, which TEXCOORD set
/// (0 or 1, after KHR_texture_transform's texCoord override), the
/// KHR_texture_transform as a row-major 2x3 matrix
///   u' = transform[0] * u + transform[1] * v + transform[2]
///   v' = transform[3] * u + transform[4] * v + transform[5]
/// (identity without the extension), and whether RGB is sRGB-encoded (base
/// colour and emissive textures; alpha and all other textures are linear).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable)]
pub struct TextureBinding as "TextureBinding" {
    pub transform: [f32; 6],
    pub texture: u32,
    pub tex_coord: u16,
    pub srgb: u16,
}
}

const _: () = assert!(std::mem::size_of::<TextureInfo>() == 24);
const _: () = assert!(std::mem::size_of::<TextureBinding>() == 32);

/// The identity transform: `u' = u`, `v' = v`.
const IDENTITY: [f32; 6] = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0];

impl TextureBinding {
    /// A slot without a texture: samples as (1, 1, 1, 1).
    pub const NONE: TextureBinding = TextureBinding {
        transform: IDENTITY,
        texture: TEXTURE_NONE,
        tex_coord: 0,
        srgb: 0,
    };

    /// A binding of texture record `texture` (an index into the info buffer).
    pub fn new(
        texture: u32,
        tex_coord: u32,
        transform: Option<&TextureTransform>,
        srgb: bool,
    ) -> TextureBinding {
        TextureBinding {
            transform: transform_matrix(transform),
            texture,
            // TextureSet::new refuses sets beyond 1; saturate rather than wrap.
            tex_coord: tex_coord.min(u16::MAX as u32) as u16,
            srgb: srgb as u16,
        }
    }

    pub fn is_none(&self) -> bool {
        self.texture == TEXTURE_NONE
    }
}

/// KHR_texture_transform as the row-major 2x3 matrix of a binding, `T * R *
/// S` (see the module text for the rotation's direction); the identity
/// without the extension.
pub fn transform_matrix(t: Option<&TextureTransform>) -> [f32; 6] {
    let Some(t) = t else { return IDENTITY };
    let (s, c) = t.rotation.sin_cos();
    let [sx, sy] = t.scale;
    let [ox, oy] = t.offset;
    [c * sx, s * sy, ox, -s * sx, c * sy, oy]
}

/// How the tracer binds the slots.
impl Slot {
    /// The slots a path tracer shades with: all but occlusion.
    pub const SHADED: [Slot; Slot::COUNT - 1] = {
        let mut shaded = [Slot::BaseColor; Slot::COUNT - 1];
        let (mut i, mut j) = (0, 0);
        while i < Slot::ALL.len() {
            if !matches!(Slot::ALL[i], Slot::Occlusion) {
                shaded[j] = Slot::ALL[i];
                j += 1;
            }
            i += 1;
        }
        shaded
    };
    /// The slots of `PtMaterial` (four bindings per material).
    pub const BASE: [Slot; 4] = [
        Slot::BaseColor,
        Slot::MetallicRoughness,
        Slot::Normal,
        Slot::Emissive,
    ];
    /// How many slots `PtMaterialExt` binds: the extensions' textures.
    pub const EXT_COUNT: usize = {
        let (mut i, mut n) = (0, 0);
        while i < Slot::ALL.len() {
            if Slot::ALL[i].feature().is_some() {
                n += 1;
            }
            i += 1;
        }
        n
    };
    /// The slots of `PtMaterialExt` (`tex`, after every material's four
    /// bindings), in the table's order: every extension's texture, read by
    /// the kernels compiled with its `feature`.
    pub const EXT: [Slot; Slot::EXT_COUNT] = {
        let mut ext = [Slot::BaseColor; Slot::EXT_COUNT];
        let (mut i, mut j) = (0, 0);
        while i < Slot::ALL.len() {
            if Slot::ALL[i].feature().is_some() {
                ext[j] = Slot::ALL[i];
                j += 1;
            }
            i += 1;
        }
        ext
    };

    /// The extension slots the kernels compiled with `define` read.
    pub fn read_under(define: &str) -> impl Iterator<Item = Slot> + '_ {
        Slot::EXT
            .into_iter()
            .filter(move |s| s.feature() == Some(define))
    }
}

/// Why textures could not be prepared or uploaded.
#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    /// An image a material samples is missing or cannot be decoded; `cause`
    /// names the file and the image index and says how to fix it.
    #[error("{cause} (the image is sampled as the {slot} of material {material}{name})")]
    Image {
        material: usize,
        /// ` "name"` or empty.
        name: String,
        slot: &'static str,
        // Not a `#[source]`: the message already says it. Boxed to keep
        // every `Result` of this module small.
        cause: Box<SceneError>,
    },
    #[error(
        "material {material}{name} samples its {slot} through TEXCOORD_{set}, but soupray carries \
         only TEXCOORD_0 and TEXCOORD_1. Fix: re-export the asset with that texture mapped \
         through TEXCOORD_0 or TEXCOORD_1."
    )]
    TexCoord {
        material: usize,
        name: String,
        slot: &'static str,
        set: u32,
    },
    /// A material table whose indices do not hold (only possible for tables
    /// built by hand: loading checks them).
    #[error("material {material} {slot}: {detail}. Fix: build the material table with valid texture and image indices.")]
    Dangling {
        material: usize,
        slot: &'static str,
        detail: String,
    },
    #[error("image {image}: {detail}")]
    BadImage { image: String, detail: String },
    #[error(
        "the textures hold {texels} texels in all, more than the 2^32 a texture offset can \
         address. Fix: downscale the scene's textures (4096x4096 is plenty for most renders)."
    )]
    TooLarge { texels: u64 },
    #[error("{0}")]
    Usage(String),
    #[error(transparent)]
    Device(#[from] DeviceError),
}

pub type Result<T, E = TextureError> = std::result::Result<T, E>;

/// [`TextureSet::sample_batch`]'s answer: the transformed uvs and the samples.
pub type SampleBatch = (Vec<[f32; 2]>, Vec<[f32; 4]>);

/// The sRGB transfer function inverted (IEC 61966-2-1), evaluated in f64.
pub fn srgb_to_linear(c: f32) -> f32 {
    srgb_to_linear_f64(c as f64) as f32
}

fn srgb_to_linear_f64(c: f64) -> f64 {
    if c <= 0.04045 {
        c / 12.92
    } else {
        ((c + 0.055) / 1.055).powf(2.4)
    }
}

/// Texel byte to float, as `TEXTURE_DECODE` in `kernels/trace/texture.h`:
/// `[c]` is c / 255 (linear channels and alpha), `[256 + c]` the sRGB
/// decode of c / 255.
pub fn decode_table() -> &'static [f32; 512] {
    static TABLE: std::sync::OnceLock<[f32; 512]> = std::sync::OnceLock::new();
    TABLE.get_or_init(|| {
        std::array::from_fn(|i| {
            if i < 256 {
                i as f32 / 255.0
            } else {
                srgb_to_linear_f64((i - 256) as f64 / 255.0) as f32
            }
        })
    })
}

/// The texels and records of a texture set, on the host: what
/// [`TextureSet`] uploads, and what the reference samples.
#[derive(Clone, Debug, Default)]
pub struct HostTextures {
    pub info: Vec<TextureInfo>,
    /// RGBA8 texels, R in the low byte.
    pub texels: Vec<u32>,
    /// Per glTF texture of the material table: its record in `info`, or
    /// [`TEXTURE_NONE`] when no sampled slot uses it.
    pub record_of_texture: Vec<u32>,
}

fn wrap_code(w: Wrap) -> u32 {
    match w {
        Wrap::Repeat => TEXTURE_WRAP_REPEAT,
        Wrap::ClampToEdge => TEXTURE_WRAP_CLAMP_TO_EDGE,
        Wrap::MirroredRepeat => TEXTURE_WRAP_MIRRORED_REPEAT,
    }
}

fn filter_code(f: Filter) -> u32 {
    match f {
        Filter::Nearest => TEXTURE_FILTER_NEAREST,
        Filter::Linear => TEXTURE_FILTER_LINEAR,
    }
}

fn quoted(name: &Option<String>) -> String {
    name.as_deref()
        .map(|n| format!(" \"{n}\""))
        .unwrap_or_default()
}

impl HostTextures {
    /// The textures of the [`Slot::SHADED`] slots of `materials`.
    pub fn new(materials: &MaterialTable) -> Result<HostTextures> {
        HostTextures::with_slots(materials, &Slot::SHADED)
    }

    /// The textures `slots` of any material use, decoded (each image once)
    /// and packed; nothing else is decoded.
    pub fn with_slots(materials: &MaterialTable, slots: &[Slot]) -> Result<HostTextures> {
        let textures = &materials.textures;
        let images = &materials.images;
        // Which textures are sampled, checked, with the first use of each
        // image for messages.
        let mut used = vec![false; textures.len()];
        let mut image_use: Vec<Option<(usize, Slot)>> = vec![None; images.len()];
        for (mi, m) in materials.materials.iter().enumerate() {
            for &slot in slots {
                let Some(r) = slot.of(m) else { continue };
                let dangling = |detail: String| TextureError::Dangling {
                    material: mi,
                    slot: slot.name(),
                    detail,
                };
                let Some(t) = textures.get(r.texture) else {
                    return Err(dangling(format!(
                        "texture {} does not exist (the table has {})",
                        r.texture,
                        textures.len()
                    )));
                };
                if t.image >= images.len() {
                    return Err(dangling(format!(
                        "texture {} uses image {}, which does not exist (the table has {})",
                        r.texture,
                        t.image,
                        images.len()
                    )));
                }
                if r.tex_coord > 1 {
                    return Err(TextureError::TexCoord {
                        material: mi,
                        name: quoted(&m.name),
                        slot: slot.name(),
                        set: r.tex_coord,
                    });
                }
                used[r.texture] = true;
                image_use[t.image].get_or_insert((mi, slot));
            }
        }

        // Decode every needed image before packing any, so a bad image is
        // reported before any work, and so the total size is known.
        let mut decoded = Vec::new();
        for (image, first_use) in image_use.iter().enumerate() {
            let Some((mi, slot)) = *first_use else {
                continue;
            };
            let pixels = images[image]
                .decoded(image)
                .map_err(|cause| TextureError::Image {
                    material: mi,
                    name: quoted(&materials.materials[mi].name),
                    slot: slot.name(),
                    cause: Box::new(cause),
                })?;
            decoded.push((image, pixels));
        }
        let total: u64 = decoded
            .iter()
            .map(|(_, p)| p.width as u64 * p.height as u64)
            .sum();
        if total > u32::MAX as u64 {
            return Err(TextureError::TooLarge { texels: total });
        }

        let mut host = HostTextures {
            texels: Vec::with_capacity(total as usize),
            ..HostTextures::default()
        };
        let mut offset_of_image = vec![None; images.len()];
        for (image, pixels) in &decoded {
            let name = format!("{image}{}", quoted(&images[*image].name));
            offset_of_image[*image] =
                Some(host.push_image(&name, pixels.width, pixels.height, &pixels.rgba8)?);
        }
        host.record_of_texture = vec![TEXTURE_NONE; textures.len()];
        for (ti, t) in textures.iter().enumerate() {
            if !used[ti] {
                continue;
            }
            let Some(offset) = offset_of_image[t.image] else {
                continue;
            };
            let pixels = &decoded
                .iter()
                .find(|(i, _)| *i == t.image)
                .expect("every used texture's image was decoded above")
                .1;
            host.record_of_texture[ti] = host.info.len() as u32;
            host.info.push(TextureInfo {
                offset,
                width: pixels.width,
                height: pixels.height,
                wrap_s: wrap_code(t.wrap_s),
                wrap_t: wrap_code(t.wrap_t),
                filter: filter_code(t.mag_filter),
            });
        }
        Ok(host)
    }

    /// Appends an image's RGBA8 pixels (rows top to bottom) and returns the
    /// offset of its first texel. `name` is for messages.
    fn push_image(&mut self, name: &str, width: u32, height: u32, rgba8: &[u8]) -> Result<u32> {
        let bad = |detail: String| TextureError::BadImage {
            image: name.to_owned(),
            detail,
        };
        let count = width as u64 * height as u64;
        if count == 0 {
            return Err(bad(format!(
                "is {width}x{height}, with no pixels. Fix: re-export the texture."
            )));
        }
        if rgba8.len() as u64 != count * 4 {
            return Err(bad(format!(
                "has {} bytes of RGBA8 for {width}x{height} pixels (needs {})",
                rgba8.len(),
                count * 4
            )));
        }
        let offset = self.texels.len() as u64;
        if offset + count > u32::MAX as u64 + 1 {
            return Err(TextureError::TooLarge {
                texels: offset + count,
            });
        }
        self.texels.extend(
            rgba8
                .chunks_exact(4)
                .map(|p| u32::from_le_bytes([p[0], p[1], p[2], p[3]])),
        );
        Ok(offset as u32)
    }

    /// Appends a texture with its own image and returns its record index,
    /// for textures that do not come from a material table (tests, tools).
    pub fn push_texture(
        &mut self,
        width: u32,
        height: u32,
        rgba8: &[u8],
        wrap_s: Wrap,
        wrap_t: Wrap,
        filter: Filter,
    ) -> Result<u32> {
        let name = format!("of record {}", self.info.len());
        let offset = self.push_image(&name, width, height, rgba8)?;
        self.info.push(TextureInfo {
            offset,
            width,
            height,
            wrap_s: wrap_code(wrap_s),
            wrap_t: wrap_code(wrap_t),
            filter: filter_code(filter),
        });
        Ok(self.info.len() as u32 - 1)
    }

    pub fn is_empty(&self) -> bool {
        self.info.is_empty()
    }

    /// The binding of a material's texture reference (see
    /// [`TextureSet::binding`]).
    pub fn binding(&self, t: &TextureRef, srgb: bool) -> TextureBinding {
        binding_of(&self.record_of_texture, t, srgb)
    }
}

fn binding_of(record_of_texture: &[u32], t: &TextureRef, srgb: bool) -> TextureBinding {
    match record_of_texture.get(t.texture) {
        Some(&record) if record != TEXTURE_NONE => {
            TextureBinding::new(record, t.tex_coord, t.transform.as_ref(), srgb)
        }
        _ => TextureBinding::NONE,
    }
}

/// `texture_uv` of `kernels/trace/texture.h`: the binding's TEXCOORD set through
/// its transform, with the same float operations in the same order.
pub fn texture_uv_ref(b: &TextureBinding, uv0: [f32; 2], uv1: [f32; 2]) -> [f32; 2] {
    let [x, y] = if b.tex_coord == 1 { uv1 } else { uv0 };
    let m = &b.transform;
    [m[0] * x + m[1] * y + m[2], m[3] * x + m[4] * y + m[5]]
}

/// `texture_wrap_coord` of `kernels/trace/texture.h`.
fn wrap_coord(u: f32, wrap: u32) -> f32 {
    let u = if u.is_finite() { u } else { 0.0 };
    match wrap {
        TEXTURE_WRAP_REPEAT => u - u.floor(),
        TEXTURE_WRAP_MIRRORED_REPEAT => u - 2.0 * (u * 0.5).floor(),
        // OpenCL's fmin(fmax(u, -1), 2); u is finite, so no NaN rules apply.
        _ => u.clamp(-1.0, 2.0),
    }
}

/// `texture_wrap_index` of `kernels/trace/texture.h` (Rust's `%` truncates like C's).
fn wrap_index(i: i32, n: i32, wrap: u32) -> i32 {
    match wrap {
        TEXTURE_WRAP_REPEAT => {
            let m = i % n;
            if m < 0 {
                m + n
            } else {
                m
            }
        }
        TEXTURE_WRAP_MIRRORED_REPEAT => {
            let p = 2 * n;
            let mut m = i % p;
            if m < 0 {
                m += p;
            }
            if m >= n {
                p - 1 - m
            } else {
                m
            }
        }
        // n >= 1: push_image refuses empty images.
        _ => i.clamp(0, n - 1),
    }
}

/// `texture_texel` of `kernels/trace/texture.h`.
fn texel(host: &HostTextures, t: &TextureInfo, x: i32, y: i32, srgb: bool) -> [f32; 4] {
    let p = host.texels[(t.offset + y as u32 * t.width + x as u32) as usize];
    let table = decode_table();
    let base = if srgb { 256 } else { 0 };
    [
        table[base + (p & 0xFF) as usize],
        table[base + ((p >> 8) & 0xFF) as usize],
        table[base + ((p >> 16) & 0xFF) as usize],
        table[(p >> 24) as usize],
    ]
}

/// `sample_texture` of `kernels/trace/texture.h`: linear RGBA of the binding's
/// texture at `uv` (already through [`texture_uv_ref`]), with the sampler's
/// wrap modes and filter, sRGB decoded before filtering when the binding
/// says so; (1, 1, 1, 1) for a binding without a texture.
pub fn sample_texture_ref(host: &HostTextures, b: &TextureBinding, uv: [f32; 2]) -> [f32; 4] {
    let Some(t) = host.info.get(b.texture as usize) else {
        return [1.0; 4];
    };
    let srgb = b.srgb != 0;
    let su = wrap_coord(uv[0], t.wrap_s);
    let sv = wrap_coord(uv[1], t.wrap_t);
    let w = t.width as f32;
    let h = t.height as f32;
    let nw = t.width as i32;
    let nh = t.height as i32;
    if t.filter == TEXTURE_FILTER_NEAREST {
        let x = wrap_index((su * w).floor() as i32, nw, t.wrap_s);
        let y = wrap_index((sv * h).floor() as i32, nh, t.wrap_t);
        return texel(host, t, x, y, srgb);
    }
    let x = su * w - 0.5;
    let y = sv * h - 0.5;
    let x0 = x.floor();
    let y0 = y.floor();
    let fx = x - x0;
    let fy = y - y0;
    let ix = x0 as i32;
    let iy = y0 as i32;
    let xa = wrap_index(ix, nw, t.wrap_s);
    let xb = wrap_index(ix + 1, nw, t.wrap_s);
    let ya = wrap_index(iy, nh, t.wrap_t);
    let yb = wrap_index(iy + 1, nh, t.wrap_t);
    let c00 = texel(host, t, xa, ya, srgb);
    let c10 = texel(host, t, xb, ya, srgb);
    let c01 = texel(host, t, xa, yb, srgb);
    let c11 = texel(host, t, xb, yb, srgb);
    std::array::from_fn(|k| {
        let top = c00[k] + (c10[k] - c00[k]) * fx;
        let bottom = c01[k] + (c11[k] - c01[k]) * fx;
        top + (bottom - top) * fy
    })
}

/// The scene's textures on the device: one texel buffer and one info buffer,
/// uploaded once; none at all for an untextured scene.
pub struct TextureSet<'d> {
    device: &'d Device,
    record_of_texture: Vec<u32>,
    buffers: Option<(Buffer<TextureInfo>, Buffer<u32>)>,
    texture_count: usize,
    texel_count: usize,
    /// The sampling probe, built on first use by [`TextureSet::sample_batch`].
    probe: OnceCell<(Program, Kernel)>,
}

impl<'d> TextureSet<'d> {
    /// Decodes the images the [`Slot::SHADED`] slots of `materials` use, and
    /// uploads them.
    pub fn new(device: &'d Device, materials: &MaterialTable) -> Result<TextureSet<'d>> {
        TextureSet::with_slots(device, materials, &Slot::SHADED)
    }

    /// As [`TextureSet::new`], for the textures of `slots`.
    pub fn with_slots(
        device: &'d Device,
        materials: &MaterialTable,
        slots: &[Slot],
    ) -> Result<TextureSet<'d>> {
        let host = HostTextures::with_slots(materials, slots)?;
        TextureSet::upload(device, &host)
    }

    /// Uploads `host` (no device buffers when it is empty).
    pub fn upload(device: &'d Device, host: &HostTextures) -> Result<TextureSet<'d>> {
        let buffers = if host.is_empty() {
            None
        } else {
            let mut info = device.buffer::<TextureInfo>(host.info.len())?;
            device.write(&mut info, &host.info)?;
            let mut texels = device.buffer::<u32>(host.texels.len())?;
            device.write(&mut texels, &host.texels)?;
            Some((info, texels))
        };
        Ok(TextureSet {
            device,
            record_of_texture: host.record_of_texture.clone(),
            buffers,
            texture_count: host.info.len(),
            texel_count: host.texels.len(),
            probe: OnceCell::new(),
        })
    }

    /// True when no material samples a texture: kernels are then built
    /// without `HAS_TEXTURES` and take no texture arguments.
    pub fn is_empty(&self) -> bool {
        self.buffers.is_none()
    }

    /// The `TextureInfo` records (`tex_info` of `TEXTURE_PARAMS`); `None`
    /// exactly when [`is_empty`](Self::is_empty).
    pub fn info_buffer(&self) -> Option<&Buffer<TextureInfo>> {
        self.buffers.as_ref().map(|(info, _)| info)
    }

    /// The packed RGBA8 texels (`texels` of `TEXTURE_PARAMS`); `None`
    /// exactly when [`is_empty`](Self::is_empty).
    pub fn texel_buffer(&self) -> Option<&Buffer<u32>> {
        self.buffers.as_ref().map(|(_, texels)| texels)
    }

    /// The device the set lives on.
    pub(super) fn device(&self) -> &Device {
        self.device
    }

    pub fn texture_count(&self) -> usize {
        self.texture_count
    }

    /// Device memory the texels take, in bytes.
    pub fn texel_bytes(&self) -> usize {
        self.texel_count * 4
    }

    /// The device binding of a material's texture reference; `srgb` is the
    /// slot's encoding ([`Slot::is_srgb`]). A texture that was not uploaded
    /// (a slot outside the set's slots) gives [`TextureBinding::NONE`].
    pub fn binding(&self, t: &TextureRef, srgb: bool) -> TextureBinding {
        binding_of(&self.record_of_texture, t, srgb)
    }

    /// The binding of one slot of a material, [`TextureBinding::NONE`] when
    /// the slot has no texture.
    pub fn slot_binding(&self, m: &Material, slot: Slot) -> TextureBinding {
        slot.of(m)
            .map_or(TextureBinding::NONE, |t| self.binding(t, slot.is_srgb()))
    }

    /// Runs `texture_uv` and `sample_texture` on the device for each
    /// `(bindings[i], uv0[i], uv1[i])` and returns the transformed uvs and
    /// the samples: the device side of the tests (one launch, timed as
    /// "texture/probe").
    pub fn sample_batch(
        &self,
        bindings: &[TextureBinding],
        uv0: &[[f32; 2]],
        uv1: &[[f32; 2]],
    ) -> Result<SampleBatch> {
        let n = bindings.len();
        if uv0.len() != n || uv1.len() != n {
            return Err(TextureError::Usage(format!(
                "sample_batch needs as many uvs as bindings ({n}), got {} and {}",
                uv0.len(),
                uv1.len()
            )));
        }
        let Some((info, texels)) = &self.buffers else {
            // Nothing can be bound in an empty set: every binding is NONE.
            let uvs = (0..n).map(|i| texture_uv_ref(&bindings[i], uv0[i], uv1[i]));
            return Ok((uvs.collect(), vec![[1.0; 4]; n]));
        };
        if let Some(b) = bindings
            .iter()
            .find(|b| !b.is_none() && b.texture as usize >= self.texture_count)
        {
            return Err(TextureError::Usage(format!(
                "binding of texture record {} in a set of {}",
                b.texture, self.texture_count
            )));
        }
        if self.probe.get().is_none() {
            let program = self.device.build_program("texture_probe.cl", &[])?;
            let kernel = self.device.kernel(&program, "texture_sample_probe")?;
            let _ = self.probe.set((program, kernel));
        }
        let (_, kernel) = self.probe.get().expect("built above");
        let d = self.device;
        let mut b_buf = d.buffer::<TextureBinding>(n)?;
        d.write(&mut b_buf, bindings)?;
        let mut uv0_buf = d.buffer::<[f32; 2]>(n)?;
        d.write(&mut uv0_buf, uv0)?;
        let mut uv1_buf = d.buffer::<[f32; 2]>(n)?;
        d.write(&mut uv1_buf, uv1)?;
        let uv_out = d.buffer::<[f32; 2]>(n)?;
        let rgba_out = d.buffer::<[f32; 4]>(n)?;
        const LOCAL: usize = 64;
        d.launch(
            "texture/probe",
            kernel,
            n.div_ceil(LOCAL),
            LOCAL,
            &[
                Arg::Buf(info),
                Arg::Buf(texels),
                Arg::Buf(&b_buf),
                Arg::Buf(&uv0_buf),
                Arg::Buf(&uv1_buf),
                Arg::Buf(&uv_out),
                Arg::Buf(&rgba_out),
                Arg::U32(n as u32),
            ],
        )?;
        let mut uvs = vec![[0.0f32; 2]; n];
        let mut rgba = vec![[0.0f32; 4]; n];
        d.read(&uv_out, &mut uvs)?;
        d.read(&rgba_out, &mut rgba)?;
        d.finish()?;
        Ok((uvs, rgba))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_index_follows_opengl() {
        let r: Vec<i32> = (-4..8)
            .map(|i| wrap_index(i, 3, TEXTURE_WRAP_REPEAT))
            .collect();
        assert_eq!(r, [2, 0, 1, 2, 0, 1, 2, 0, 1, 2, 0, 1]);
        let m: Vec<i32> = (-4..8)
            .map(|i| wrap_index(i, 3, TEXTURE_WRAP_MIRRORED_REPEAT))
            .collect();
        // Period 6: 0 1 2 | 2 1 0, and -1 mirrors to 0.
        assert_eq!(m, [2, 2, 1, 0, 0, 1, 2, 2, 1, 0, 0, 1]);
        let c: Vec<i32> = (-2..5)
            .map(|i| wrap_index(i, 3, TEXTURE_WRAP_CLAMP_TO_EDGE))
            .collect();
        assert_eq!(c, [0, 0, 0, 1, 2, 2, 2]);
    }

    #[test]
    fn wrap_coord_reduces_exactly() {
        assert_eq!(wrap_coord(2.25, TEXTURE_WRAP_REPEAT), 0.25);
        assert_eq!(wrap_coord(-0.25, TEXTURE_WRAP_REPEAT), 0.75);
        assert_eq!(wrap_coord(-0.25, TEXTURE_WRAP_MIRRORED_REPEAT), 1.75);
        assert_eq!(wrap_coord(5.5, TEXTURE_WRAP_MIRRORED_REPEAT), 1.5);
        assert_eq!(wrap_coord(f32::NAN, TEXTURE_WRAP_REPEAT), 0.0);
        assert_eq!(wrap_coord(1e30, TEXTURE_WRAP_CLAMP_TO_EDGE), 2.0);
    }
}
