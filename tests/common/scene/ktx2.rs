//! Small KTX2 files made from code, for the KHR_texture_basisu tests: UASTC
//! of solid-colour blocks (which UASTC stores exactly), raw or under a
//! Zstandard frame of stored blocks, so no encoder is needed.

/// One UASTC block of mode 8, a solid colour: the mode's 5-bit code 0b10111,
/// then R, G, B and A, the ETC1 hints after them zero. UASTC stores it
/// losslessly, so a texture of these decodes to exact colours.
pub fn uastc_solid(c: [u8; 4]) -> [u8; 16] {
    let v = 0x17u128
        | (c[0] as u128) << 5
        | (c[1] as u128) << 13
        | (c[2] as u128) << 21
        | (c[3] as u128) << 29;
    v.to_le_bytes()
}

/// `data` as one Zstandard frame of raw (stored) blocks: what a UASTC+Zstd
/// level holds, without needing a compressor.
pub fn zstd_stored(data: &[u8]) -> Vec<u8> {
    let mut out = vec![0x28, 0xB5, 0x2F, 0xFD, 0xA0]; // magic; single segment, 4-byte size
    out.extend_from_slice(&(data.len() as u32).to_le_bytes());
    let chunks: Vec<&[u8]> = data.chunks(1 << 16).collect();
    for (i, chunk) in chunks.iter().enumerate() {
        let last = (i + 1 == chunks.len()) as u32;
        out.extend_from_slice(&((chunk.len() as u32) << 3 | last).to_le_bytes()[..3]);
        out.extend_from_slice(chunk);
    }
    out
}

/// A KTX2 file of one UASTC level, `width` x `height` texels, whose 4x4
/// blocks (row-major, top row first) are the solid `colours`; under
/// Zstandard if `zstd`, with a `KTXorientation` of `orientation` if given.
/// The layout is KTX 2.0's: header, level index, DFD, key/value data, level.
pub fn uastc_ktx2(
    width: u32,
    height: u32,
    colours: &[[u8; 4]],
    zstd: bool,
    orientation: Option<&str>,
) -> Vec<u8> {
    let blocks = (width.div_ceil(4) * height.div_ceil(4)) as usize;
    assert_eq!(colours.len(), blocks);
    let raw: Vec<u8> = colours.iter().flat_map(|&c| uastc_solid(c)).collect();
    let level = if zstd { zstd_stored(&raw) } else { raw.clone() };
    // DFD: one basic block, colour model UASTC (166), BT.709, sRGB, 4x4x1
    // texel blocks of 16 bytes, one RGBA sample (channel 3) of 128 bits.
    let mut dfd = Vec::new();
    for v in [
        44u32,
        0,
        2 | 40 << 16,
        166 | 1 << 8 | 2 << 16,
        3 | 3 << 8,
        16,
        0,
    ] {
        dfd.extend_from_slice(&v.to_le_bytes());
    }
    for v in [127u32 << 16 | 3 << 24, 0, 0, u32::MAX] {
        dfd.extend_from_slice(&v.to_le_bytes());
    }
    let mut kvd = Vec::new();
    if let Some(o) = orientation {
        let entry = format!("KTXorientation\0{o}\0");
        kvd.extend_from_slice(&(entry.len() as u32).to_le_bytes());
        kvd.extend_from_slice(entry.as_bytes());
        kvd.resize(kvd.len().next_multiple_of(4), 0);
    }
    let dfd_at = 80 + 24;
    let kvd_at = dfd_at + dfd.len();
    let level_at = (kvd_at + kvd.len()).next_multiple_of(16);
    let mut out = b"\xabKTX 20\xbb\r\n\x1a\n".to_vec();
    for v in [0u32, 1, width, height, 0, 0, 1, 1, if zstd { 2 } else { 0 }] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    let kvd_offset = if kvd.is_empty() { 0 } else { kvd_at };
    for v in [dfd_at, dfd.len(), kvd_offset, kvd.len()] {
        out.extend_from_slice(&(v as u32).to_le_bytes());
    }
    for v in [
        0u64,
        0,
        level_at as u64,
        level.len() as u64,
        raw.len() as u64,
    ] {
        out.extend_from_slice(&v.to_le_bytes());
    }
    out.extend_from_slice(&dfd);
    out.extend_from_slice(&kvd);
    out.resize(level_at, 0);
    out.extend_from_slice(&level);
    out
}
