//! The frame's emissive triangles for next-event estimation: each
//! triangle's power on the device (`pt_emissive_power`), turned into a CDF
//! on the host. A textured emitter's power includes its emissive texture's
//! mean over the triangle (`pt_emissive_texture_factor`, 16 texture samples
//! per triangle); those factors are kept from frame to frame while their
//! inputs stay the same bit for bit (uvs, material ids, materials), so an
//! animation whose emitters only move pays for them once. Reusing them only
//! then keeps every frame's image what it would be rendered alone.

use opencl3::memory::Buffer;

use super::{or_dummy, PathTracer, SoupBuffers};
use crate::device::{Arg, BufferArg, Device, GrowBuffer};
use crate::trace::lights::EmissiveDistribution;
use crate::trace::TraceError;

/// The textured emitters' factors of the last frame, and the inputs they
/// were computed from.
pub(super) struct TextureFactors {
    factor: GrowBuffer<[f32; 4]>,
    kept_uvs: GrowBuffer<u32>,
    kept_uvs1: GrowBuffer<u32>,
    kept_ids: GrowBuffer<u32>,
    same: Option<Buffer<u32>>,
    /// The materials' generation (`PathTracer::set_materials` counts), the
    /// triangles and the frame flags the factors were computed for; `None`
    /// before the first frame.
    key: Option<(u64, usize, u32)>,
    /// Frames whose factors were computed, and reused.
    pub(super) computed: u64,
    pub(super) reused: u64,
}

impl TextureFactors {
    pub(super) fn new() -> TextureFactors {
        TextureFactors {
            factor: GrowBuffer::new(),
            kept_uvs: GrowBuffer::new(),
            kept_uvs1: GrowBuffer::new(),
            kept_ids: GrowBuffer::new(),
            same: None,
            key: None,
            computed: 0,
            reused: 0,
        }
    }
}

/// Queues a comparison of `words` words of `current` with `kept` on the
/// device, which then holds `current`; a difference clears `same`. Returns
/// false when `kept` had to grow, since its words were then not the last
/// frame's whatever they hold.
fn compare_and_keep(
    d: &Device,
    kernel: &opencl3::kernel::Kernel,
    current: &dyn BufferArg,
    kept: &mut GrowBuffer<u32>,
    words: usize,
    same: &Buffer<u32>,
) -> Result<bool, TraceError> {
    let allocations = kept.allocations();
    kept.ensure(d, words.max(1))?;
    d.launch(
        "pathtrace/emissive_texture_compare",
        kernel,
        words.div_ceil(64),
        64,
        &[
            Arg::Buf(current),
            Arg::Buf(kept.get()),
            Arg::U32(words as u32),
            Arg::Buf(same),
        ],
    )?;
    Ok(kept.allocations() == allocations)
}

impl PathTracer<'_> {
    /// The textured emitters' factors for this frame's soup (frame flags
    /// `flags`): kept from the last frame when every input is the same, else
    /// computed. False when no material has textures (the factors are all
    /// 1).
    fn texture_factors(&mut self, soup: &SoupBuffers, flags: u32) -> Result<bool, TraceError> {
        let (Some((set, bindings)), Some(kernel)) =
            (&self.textures, &self.kernels.emissive_texture_factor)
        else {
            return Ok(false);
        };
        let d = self.device;
        let n = soup.triangles;
        let tf = &mut self.texture_factors;
        let same = match &mut tf.same {
            Some(b) => b,
            None => tf.same.insert(d.buffer::<u32>(1)?),
        };
        // Every input is compared (and kept) each frame, whatever the key,
        // under one flag read back once.
        d.write(same, &[1u32])?;
        let compare = &self.kernels.compare_and_keep;
        let mut unchanged = tf.key == Some((self.materials_generation, n, flags));
        unchanged &= compare_and_keep(d, compare, soup.material_ids, &mut tf.kept_ids, n, same)?;
        if let Some(uvs) = soup.uvs {
            unchanged &= compare_and_keep(d, compare, uvs, &mut tf.kept_uvs, 6 * n, same)?;
        }
        if let Some(uvs1) = soup.uvs1 {
            unchanged &= compare_and_keep(d, compare, uvs1, &mut tf.kept_uvs1, 6 * n, same)?;
        }
        let mut flag = [0u32];
        d.read(same, &mut flag)?;
        unchanged &= flag[0] == 1;
        tf.key = Some((self.materials_generation, n, flags));
        if unchanged && tf.factor.buffer().is_some() {
            tf.reused += 1;
            return Ok(true);
        }
        let factor = tf.factor.ensure(d, n)?;
        d.launch(
            "pathtrace/emissive_texture_factor",
            kernel,
            n.div_ceil(64),
            64,
            &[
                or_dummy(soup.uvs, &self.dummy_f32),
                or_dummy(soup.uvs1, &self.dummy_f32),
                Arg::U32(flags),
                Arg::Buf(soup.material_ids),
                Arg::Buf(&self.materials),
                Arg::U32(self.material_count),
                Arg::U32(n as u32),
                Arg::Buf(&*factor),
                Arg::Buf(set.info_buffer().expect("non-empty set")),
                Arg::Buf(set.texel_buffer().expect("non-empty set")),
                Arg::Buf(bindings),
            ],
        )?;
        tf.computed += 1;
        Ok(true)
    }

    /// Emissive triangles, chosen in proportion to their power: computed on
    /// the device, turned into a CDF on the host.
    pub(super) fn upload_emitters(
        &mut self,
        soup: &SoupBuffers,
        flags: u32,
    ) -> Result<EmissiveDistribution, TraceError> {
        let d = self.device;
        let mut emit = EmissiveDistribution::default();
        if self.any_emissive && soup.triangles > 0 {
            let n = soup.triangles;
            let has_factor = self.texture_factors(soup, flags)?;
            let factor: &dyn BufferArg = match self.texture_factors.factor.buffer() {
                Some(f) if has_factor => f,
                _ => &self.dummy_f4,
            };
            let pbuf = self.power.ensure(d, n)?;
            d.launch(
                "pathtrace/emissive_power",
                &self.kernels.emissive_power,
                n.div_ceil(64),
                64,
                &[
                    Arg::Buf(soup.positions),
                    Arg::Buf(soup.material_ids),
                    Arg::Buf(&self.materials),
                    Arg::U32(self.material_count),
                    Arg::U32(n as u32),
                    Arg::Buf(factor),
                    Arg::U32(has_factor as u32),
                    Arg::Buf(&*pbuf),
                ],
            )?;
            self.power_host.resize(n, 0.0);
            d.read(pbuf, &mut self.power_host)?;
            emit = EmissiveDistribution::from_power(&self.power_host);
        }
        if !emit.is_empty() {
            d.write(self.emit_prims.ensure(d, emit.prims.len())?, &emit.prims)?;
            d.write(self.emit_cdf.ensure(d, emit.cdf.len())?, &emit.cdf)?;
            d.write(
                self.emit_pmf.ensure(d, emit.pmf_by_prim.len())?,
                &emit.pmf_by_prim,
            )?;
        } else {
            // MIS reads the pmf of every hit triangle: all zero.
            let n = soup.triangles.max(1);
            d.write(self.emit_pmf.ensure(d, n)?, &vec![0.0f32; n])?;
            self.emit_prims.ensure(d, 1)?;
            self.emit_cdf.ensure(d, 2)?;
        }
        Ok(emit)
    }
}
