//! An EXR's pixel blocks, written by soupray rather than by the `exr`
//! crate's image writer: each block's bytes are gathered straight from the
//! film's buffers (`ChannelView`s, no per-channel copy) into the file's
//! layout (per scan line, each channel's samples in the header's channel
//! order), and ZIP blocks are compressed with zlib-rs through `flate2`. The
//! `exr` crate still writes the header, the offset table and the blocks of
//! the other compressions.
//!
//! Why: with every compositing pass a frame has about 90 channels, and the
//! `exr` crate's ZIP (miniz_oxide at level 4) took 650 ms of a 640x360
//! frame's CPU on a 2-core machine, time taken from the next frame's trace;
//! its image writer also needs each channel copied out of the film first
//! (83 MB for that frame, 3 GB at 4K).
//! zlib-rs at the same level compresses the same bytes 2.6x faster to the
//! same size. The ZIP format is OpenEXR's: the bytes split into even and
//! odd halves, each byte replaced by its difference from the one before
//! (plus 128), then a zlib stream; a block that does not shrink is stored
//! raw. Blocks are compressed on rayon's pool, a few at a time so memory
//! stays bounded, and written in order: the file is the same whatever the
//! thread count.

use super::ChannelView;
use exr::block::chunk::{Chunk, CompressedBlock, CompressedScanLineBlock};
use exr::block::writer::ChunksWriter;
use exr::block::{self, BlockIndex, UncompressedBlock};
use exr::error::{Error, UnitResult};
use exr::meta::attribute::{ChannelDescription, ChannelList, SampleType};
use exr::meta::header::{Header, ImageAttributes, LayerAttributes};
use exr::meta::BlockDescription;
use exr::prelude::{Compression, LineOrder, SmallVec, Text, Vec2};
use rayon::prelude::*;
use std::io::{Seek, Write};

/// The zlib level of the ZIP blocks unless `--exr-compression zip:N` asks
/// for another. OpenEXR's default is 4; level 2
/// (zlib-rs's fast deflate, no lazy matching) compresses a frame with every
/// pass in 0.81-0.87x the time to files 0.3% larger (`cargo bench --bench
/// exr_write`), time the next frame's trace gets back on a busy machine. The
/// level is not stored in the file: readers see ordinary ZIP blocks.
pub const ZIP_LEVEL: u32 = 2;

/// Writes a single-part scan-line EXR of `size` pixels to `out`: its
/// channels `channels` (stored sorted by name, as EXR lists them), its
/// blocks compressed with `compression` (ZIP's at zlib level `zlib_level`),
/// and the given attributes.
pub(super) fn write_scan_lines<W: Write + Seek>(
    out: W,
    mut channels: Vec<ChannelView>,
    size: Vec2<usize>,
    compression: Compression,
    zlib_level: u32,
    shared_attributes: ImageAttributes,
    own_attributes: LayerAttributes,
) -> UnitResult {
    channels.sort_by(|a, b| a.name.cmp(&b.name));
    let descriptions = channels
        .iter()
        .map(|c| {
            let name = Text::from(c.name.as_str());
            ChannelDescription {
                // The hint for lossy compressions the exr crate's image
                // writer gives: all but R, G, B, Z (and L, X, Y) are
                // quantized linearly.
                quantize_linearly: ChannelDescription::guess_quantization_linearity(&name),
                name,
                sample_type: if c.half {
                    SampleType::F16
                } else {
                    SampleType::F32
                },
                sampling: Vec2(1, 1),
            }
        })
        .collect();
    let header = Header {
        channels: ChannelList::new(descriptions),
        compression,
        blocks: BlockDescription::ScanLines,
        chunk_count: exr::meta::compute_chunk_count(compression, size, BlockDescription::ScanLines),
        line_order: LineOrder::Increasing,
        layer_size: size,
        shared_attributes,
        own_attributes,
        deep: false,
        deep_data_version: None,
        max_samples_per_pixel: None,
    };
    block::write(out, SmallVec::from_elem(header, 1), true, |meta, writer| {
        let blocks: Vec<(usize, BlockIndex)> =
            block::enumerate_ordered_header_block_indices(&meta.headers).collect();
        let batch = 2 * rayon::current_num_threads().max(1);
        for group in blocks.chunks(batch) {
            let chunks: Vec<Result<Chunk, Error>> = group
                .par_iter()
                .map(|&(_, index)| {
                    encode_block(&meta.headers, &channels, size.x(), index, zlib_level)
                })
                .collect();
            for (&(index_in_header, _), chunk) in group.iter().zip(chunks) {
                writer.write_chunk(index_in_header, chunk?)?;
            }
        }
        Ok(())
    })
}

/// One block of lines, compressed as the header says.
fn encode_block(
    headers: &[Header],
    channels: &[ChannelView],
    width: usize,
    index: BlockIndex,
    zlib_level: u32,
) -> Result<Chunk, Error> {
    let header = &headers[index.layer];
    let zip = matches!(header.compression, Compression::ZIP16 | Compression::ZIP1);
    // ZIP's bytes are little-endian; the `exr` crate's compressors take
    // native-endian bytes and convert them.
    let data = gather_lines(channels, width, index, zip);
    if !zip {
        return UncompressedBlock { index, data }.compress_to_chunk(headers);
    }
    let y = i32::try_from(index.pixel_position.y())
        .map_err(|_| Error::Invalid("scan line index".into()))?
        + header.own_attributes.layer_position.y();
    Ok(Chunk {
        layer_index: index.layer,
        compressed_block: CompressedBlock::ScanLine(CompressedScanLineBlock {
            y_coordinate: y,
            compressed_pixels_le: zip_compress(data, zlib_level)?,
        }),
    })
}

/// The block's bytes: for each of its lines, each channel's samples of that
/// line, little-endian with `le`, else native-endian.
fn gather_lines(channels: &[ChannelView], width: usize, index: BlockIndex, le: bool) -> Vec<u8> {
    let (y0, lines) = (index.pixel_position.y(), index.pixel_size.height());
    let bytes_per_pixel: usize = channels.iter().map(|c| if c.half { 2 } else { 4 }).sum();
    // Sized once and filled in place: pushing four bytes at a time checked
    // the capacity at every sample.
    let mut data = vec![0u8; bytes_per_pixel * width * lines];
    let mut lines_out = data.chunks_exact_mut(bytes_per_pixel * width);
    for y in y0..y0 + lines {
        let mut out = lines_out.next().expect("one per line");
        for c in channels {
            let samples = c.samples.run(y * width, width);
            let (line, rest) = out.split_at_mut(if c.half { 2 } else { 4 } * width);
            out = rest;
            if c.half {
                for (o, s) in line.chunks_exact_mut(2).zip(samples) {
                    let b = exr::prelude::f16::from_f32(s).to_bits();
                    o.copy_from_slice(&if le { b.to_le_bytes() } else { b.to_ne_bytes() });
                }
            } else {
                for (o, s) in line.chunks_exact_mut(4).zip(samples) {
                    o.copy_from_slice(&if le { s.to_le_bytes() } else { s.to_ne_bytes() });
                }
            }
        }
    }
    data
}

/// OpenEXR's ZIP compression of a block's little-endian bytes at zlib
/// level `level`: the raw bytes where compressing does not shrink them, as
/// OpenEXR does.
fn zip_compress(raw: Vec<u8>, level: u32) -> Result<Vec<u8>, Error> {
    let n = raw.len();
    let predicted = zip_predict(&raw);
    let mut encoder =
        flate2::write::ZlibEncoder::new(Vec::with_capacity(n / 2), flate2::Compression::new(level));
    encoder.write_all(&predicted).map_err(Error::Io)?;
    let compressed = encoder.finish().map_err(Error::Io)?;
    Ok(if compressed.len() < n {
        compressed
    } else {
        raw
    })
}

/// The ZIP predictor as OpenEXR's `ImfZip.cpp` writes it, a byte at a
/// time (soupray's own before `zip_predict`): the reference `zip_predict`
/// is tested and benchmarked against.
pub fn zip_predict_bytewise(raw: &[u8]) -> Vec<u8> {
    let n = raw.len();
    let mut predicted = vec![0u8; n];
    let (even, odd) = predicted.split_at_mut(n.div_ceil(2));
    for (i, pair) in raw.chunks(2).enumerate() {
        even[i] = pair[0];
        if let Some(&b) = pair.get(1) {
            odd[i] = b;
        }
    }
    let mut previous = predicted.first().copied().unwrap_or(0);
    for b in predicted.iter_mut().skip(1) {
        let current = *b;
        *b = current.wrapping_sub(previous).wrapping_add(128);
        previous = current;
    }
    predicted
}

/// Eight bytes' high bits.
const HIGH_BITS: u64 = 0x8080_8080_8080_8080;

/// OpenEXR's ZIP predictor: the bytes at even offsets, then those at odd
/// offsets, each replaced by its difference from the byte before it in
/// that order, plus 128 (the first byte kept as it is).
///
/// Eight pairs at a time in two 64-bit words: the bytes split by shifts and
/// masks and subtracted bytewise, in one pass. A plain loop over the pairs
/// does not vectorise (single bytes stored at two strides) and took 2.5x as
/// long over a 90-channel frame (BENCHMARKS.md, "Compositing passes").
pub fn zip_predict(raw: &[u8]) -> Vec<u8> {
    let n = raw.len();
    let half = n.div_ceil(2);
    let mut out = vec![0u8; n];
    if n == 0 {
        return out;
    }
    let (even, odd) = out.split_at_mut(half);
    // 128 before the first byte leaves it as it is; the odd bytes follow
    // the last even one.
    let mut prev_even = 128u8;
    let mut prev_odd = raw[2 * (half - 1)];
    for ((e, o), pairs) in even
        .chunks_exact_mut(8)
        .zip(odd.chunks_exact_mut(8))
        .zip(raw.chunks_exact(16))
    {
        let (a, b) = pairs.split_at(8);
        let a = u64::from_le_bytes(a.try_into().expect("8 bytes"));
        let b = u64::from_le_bytes(b.try_into().expect("8 bytes"));
        let evens = low_bytes(a) | low_bytes(b) << 32;
        let odds = low_bytes(a >> 8) | low_bytes(b >> 8) << 32;
        let de = sub_bytes(evens, evens << 8 | u64::from(prev_even)) ^ HIGH_BITS;
        let dodd = sub_bytes(odds, odds << 8 | u64::from(prev_odd)) ^ HIGH_BITS;
        e.copy_from_slice(&de.to_le_bytes());
        o.copy_from_slice(&dodd.to_le_bytes());
        prev_even = (evens >> 56) as u8;
        prev_odd = (odds >> 56) as u8;
    }
    for i in 8 * (n / 16)..n / 2 {
        let (x, y) = (raw[2 * i], raw[2 * i + 1]);
        even[i] = x.wrapping_sub(prev_even).wrapping_add(128);
        odd[i] = y.wrapping_sub(prev_odd).wrapping_add(128);
        prev_even = x;
        prev_odd = y;
    }
    if n % 2 == 1 {
        even[half - 1] = raw[n - 1].wrapping_sub(prev_even).wrapping_add(128);
    }
    out
}

/// The low byte of each of the word's four 16-bit halves, packed into its
/// low 32 bits in order.
fn low_bytes(x: u64) -> u64 {
    let x = x & 0x00FF_00FF_00FF_00FF;
    let x = (x | (x >> 8)) & 0x0000_FFFF_0000_FFFF;
    (x | (x >> 16)) & 0xFFFF_FFFF
}

/// `a - b` in each of the eight bytes, wrapping, without borrows between
/// them (Hacker's Delight, 2-18).
fn sub_bytes(a: u64, b: u64) -> u64 {
    ((a | HIGH_BITS) - (b & !HIGH_BITS)) ^ ((a ^ !b) & HIGH_BITS)
}

#[cfg(test)]
mod tests {
    use super::{zip_predict, zip_predict_bytewise};

    #[test]
    fn the_word_predictor_is_openexrs_byte_for_byte() {
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut byte = || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 24) as u8
        };
        // Every length around the 16-byte words, and longer runs with long
        // equal stretches (borrows across byte lanes) and random bytes.
        for n in (0..300).chain([1023, 1024, 1025, 4096 + 7]) {
            let random: Vec<u8> = (0..n).map(|_| byte()).collect();
            assert_eq!(
                zip_predict(&random),
                zip_predict_bytewise(&random),
                "{n} random bytes"
            );
            let runs: Vec<u8> = (0..n)
                .map(|i| [0u8, 255, 128, 127, 1][(i / 5) % 5])
                .collect();
            assert_eq!(
                zip_predict(&runs),
                zip_predict_bytewise(&runs),
                "{n} bytes in runs"
            );
        }
    }
}
