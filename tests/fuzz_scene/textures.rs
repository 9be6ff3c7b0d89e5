//! Hostile texture payloads: KTX2 (Basis Universal) and WebP, whose bytes a
//! decoder trusts. Each is sampled by the valid corpus file's material, so
//! loading decodes it.

use super::*;

/// `valid.gltf` with one material whose base colour samples `image` (a
/// file beside it in `dir`, named in the error messages), through
/// KHR_texture_basisu for a `.ktx2`.
fn with_texture(dir: &Path, case: &str, image: &str, bytes: &[u8]) -> PathBuf {
    std::fs::write(dir.join(image), bytes).unwrap();
    let mut doc: Value =
        serde_json::from_str(&std::fs::read_to_string(corpus().join("valid.gltf")).unwrap())
            .unwrap();
    doc["images"][0] = serde_json::json!({"uri": image});
    doc["textures"] = if image.ends_with(".ktx2") {
        doc["extensionsUsed"]
            .as_array_mut()
            .unwrap()
            .push("KHR_texture_basisu".into());
        serde_json::json!([{"extensions": {"KHR_texture_basisu": {"source": 0}}}])
    } else {
        serde_json::json!([{"source": 0}])
    };
    doc["materials"] =
        serde_json::json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc["meshes"][0]["primitives"][0]["material"] = 0.into();
    let path = dir.join(format!("{case}.gltf"));
    std::fs::write(&path, doc.to_string()).unwrap();
    path
}

fn put_u32(bytes: &mut [u8], at: usize, v: u32) {
    bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
}

fn put_u64(bytes: &mut [u8], at: usize, v: u64) {
    bytes[at..at + 8].copy_from_slice(&v.to_le_bytes());
}

/// KTX2 header fields and level 0's index entry, by byte offset.
const KTX2_VK_FORMAT: usize = 12;
const KTX2_PIXEL_WIDTH: usize = 20;
const KTX2_PIXEL_HEIGHT: usize = 24;
const KTX2_FACE_COUNT: usize = 36;
const KTX2_LEVEL_COUNT: usize = 40;
const KTX2_SCHEME: usize = 44;
const KTX2_SGD_OFFSET: usize = 64;
const KTX2_LEVEL0_OFFSET: usize = 80;
const KTX2_LEVEL0_LENGTH: usize = 88;
const KTX2_LEVEL0_UNCOMPRESSED: usize = 96;

#[test]
fn ktx2_that_lies_is_refused_before_transcoding() {
    let dir = tempfile::tempdir().unwrap();
    let colours = [[200, 10, 10, 255]; 4];
    let raw = common::scene::ktx2::uastc_ktx2(8, 8, &colours, false, None);
    let zstd = common::scene::ktx2::uastc_ktx2(8, 8, &colours, true, None);
    let level_at = u64::from_le_bytes(raw[80..88].try_into().unwrap()) as usize;
    type Lie = fn(&mut Vec<u8>, usize);
    let cases: &[(&str, bool, Lie, &[&str])] = &[
        (
            "truncated_header",
            false,
            |b, _| b.truncate(60),
            &["damaged KTX2"],
        ),
        (
            "truncated_level",
            true,
            |b, _| b.truncate(b.len() - 9),
            &["damaged KTX2"],
        ),
        (
            "level_past_file",
            false,
            |b, _| put_u64(b, KTX2_LEVEL0_LENGTH, 1 << 40),
            &["damaged KTX2"],
        ),
        (
            "level_offset_wraps",
            false,
            |b, _| put_u64(b, KTX2_LEVEL0_OFFSET, u64::MAX - 8),
            &["damaged KTX2"],
        ),
        (
            "level_short_for_size",
            false,
            |b, _| put_u64(b, KTX2_LEVEL0_LENGTH, 32),
            &["mip level 0", "needs 64"],
        ),
        (
            "uncompressed_length_lies",
            true,
            |b, _| put_u64(b, KTX2_LEVEL0_UNCOMPRESSED, 1 << 62),
            &["uncompressed length", "needs 64"],
        ),
        (
            "pixel_width_absurd",
            false,
            |b, _| put_u32(b, KTX2_PIXEL_WIDTH, u32::MAX),
            &["4294967295x8", "MiB"],
        ),
        (
            "pixels_absurd",
            true,
            |b, _| {
                put_u32(b, KTX2_PIXEL_WIDTH, 1 << 16);
                put_u32(b, KTX2_PIXEL_HEIGHT, 1 << 16);
            },
            &["65536x65536", "MiB"],
        ),
        (
            "level_count_lies",
            false,
            |b, _| put_u32(b, KTX2_LEVEL_COUNT, 1000),
            &["damaged KTX2"],
        ),
        (
            "more_levels_than_size",
            false,
            |b, _| put_u32(b, KTX2_LEVEL_COUNT, 5),
            &["KTX2"],
        ),
        (
            "cube_map",
            false,
            |b, _| put_u32(b, KTX2_FACE_COUNT, 6),
            &["6 faces"],
        ),
        (
            "not_basis",
            false,
            |b, _| put_u32(b, KTX2_VK_FORMAT, 37),
            &["vkFormat 37"],
        ),
        (
            "uastc_under_basislz",
            false,
            |b, _| put_u32(b, KTX2_SCHEME, 1),
            &["scheme 1"],
        ),
        (
            "sgd_past_file",
            false,
            |b, _| put_u64(b, KTX2_SGD_OFFSET, 1 << 50),
            &["damaged KTX2"],
        ),
        // A block whose mode code (69) names no UASTC mode: the transcoder's own refusal.
        (
            "block_mode_invalid",
            false,
            |b, at| b[at] = 69,
            &["cannot be transcoded"],
        ),
    ];
    let started = Instant::now();
    for (case, is_zstd, lie, mentions) in cases {
        let mut bytes = if *is_zstd { zstd.clone() } else { raw.clone() };
        lie(&mut bytes, level_at);
        let image = format!("{case}.ktx2");
        let path = with_texture(dir.path(), case, &image, &bytes);
        let msg = outcome(&path)
            .map(|w| format!("loaded: {w:?}"))
            .unwrap_or_else(|e| e);
        let file = format!("{case}.gltf");
        for m in [file.as_str(), "image 0"]
            .into_iter()
            .chain(mentions.iter().copied())
        {
            assert!(
                msg.contains(m) && !msg.contains(LAST_RESORT),
                "{case}: {m:?} missing from: {msg}"
            );
        }
    }
    assert!(
        started.elapsed() < Duration::from_secs(20),
        "{:?}",
        started.elapsed()
    );
}

/// A small ETC1S (BasisLZ) texture of the shared folder, 512x512 with 10
/// mip levels, for the lies only ETC1S can tell; `None` without the folder.
fn shared_etc1s() -> Option<Vec<u8>> {
    let path = common::shared::khronos(
        "StainedGlassLamp/glTF-KTX-BasisU/StainedGlassLamp_hardware_basecolor.ktx2",
    )?;
    Some(std::fs::read(path).unwrap())
}

#[test]
fn etc1s_ktx2_whose_basislz_data_lies_is_refused() {
    let Some(etc1s) = shared_etc1s() else {
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let sgd = u64::from_le_bytes(etc1s[64..72].try_into().unwrap()) as usize;
    // (case, byte offset, value written as u32, what the message says)
    let cases: &[(&str, usize, u32, &[&str])] = &[
        ("no_endpoints", sgd, 0, &["does not add up", "0 endpoints"]),
        ("endpoints_longer", sgd + 4, 1 << 30, &["does not add up"]),
        ("tables_longer", sgd + 12, u32::MAX, &["does not add up"]),
        (
            "rgb_slice_past_level",
            sgd + 20 + 4,
            u32::MAX - 3,
            &["mip level 0's colour slice"],
        ),
        (
            "rgb_slice_empty",
            sgd + 20 + 8,
            0,
            &["mip level 0's colour slice"],
        ),
        (
            "alpha_slice_past_level",
            sgd + 20 * 4 + 12,
            1 << 31,
            &["mip level 3's alpha slice"],
        ),
        (
            "level_shorter",
            KTX2_LEVEL0_LENGTH,
            16,
            &["mip level 0's colour slice"],
        ),
        (
            "width_lies",
            KTX2_PIXEL_WIDTH,
            1 << 20,
            &["1048576x512", "MiB"],
        ),
    ];
    for (case, at, value, mentions) in cases {
        let mut bytes = etc1s.clone();
        put_u32(&mut bytes, *at, *value);
        if *at == KTX2_LEVEL0_LENGTH {
            put_u32(&mut bytes, at + 4, 0);
        }
        let path = with_texture(dir.path(), case, &format!("{case}.ktx2"), &bytes);
        let msg = outcome(&path)
            .map(|w| format!("loaded: {w:?}"))
            .unwrap_or_else(|e| e);
        let file = format!("{case}.gltf");
        for m in [file.as_str(), "image 0"]
            .into_iter()
            .chain(mentions.iter().copied())
        {
            assert!(
                msg.contains(m) && !msg.contains(LAST_RESORT),
                "{case}: {m:?} missing from: {msg}"
            );
        }
    }
}

#[test]
fn damaged_webp_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let pixels: Vec<u8> = (0..64u32)
        .flat_map(|i| [i as u8 * 4, 255 - i as u8, 7, 255])
        .collect();
    let mut webp = Vec::new();
    image::codecs::webp::WebPEncoder::new_lossless(&mut webp)
        .encode(&pixels, 8, 8, image::ExtendedColorType::Rgba8)
        .unwrap();
    let path = with_texture(dir.path(), "webp_whole", "whole.webp", &webp);
    assert!(outcome(&path).is_ok(), "{:?}", outcome(&path));
    for (case, cut) in [
        ("webp_header_only", 12),
        ("webp_half", webp.len() / 2),
        ("webp_short", webp.len() - 3),
    ] {
        let path = with_texture(dir.path(), case, &format!("{case}.webp"), &webp[..cut]);
        let msg = outcome(&path)
            .err()
            .unwrap_or_else(|| panic!("{case} loaded"));
        for m in [&format!("{case}.gltf"), "image 0", "cannot be decoded"] {
            assert!(
                msg.contains(m) && !msg.contains(LAST_RESORT),
                "{case}: {m:?} missing from: {msg}"
            );
        }
    }
    // The RIFF size claiming more than there is, and every single-bit flip
    // of the first 64 bytes: refused or decoded, never a panic or a hang.
    let mut lying = webp.clone();
    lying[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    let path = with_texture(dir.path(), "webp_riff_lies", "riff_lies.webp", &lying);
    if let Err(msg) = outcome(&path) {
        assert!(
            msg.contains("webp_riff_lies.gltf") && !msg.contains(LAST_RESORT),
            "{msg}"
        );
    }
    let started = Instant::now();
    for bit in 0..64 * 8 {
        let mut flipped = webp.clone();
        flipped[bit / 8] ^= 1 << (bit % 8);
        let case = format!("webp_bit{bit}");
        let path = with_texture(dir.path(), &case, &format!("{case}.webp"), &flipped);
        match std::panic::catch_unwind(|| outcome(&path)) {
            Ok(Ok(_)) => {}
            Ok(Err(msg)) => assert!(
                msg.contains(&format!("{case}.gltf")) && !msg.contains(LAST_RESORT),
                "{msg}"
            ),
            Err(_) => panic!("{case}: panicked"),
        }
    }
    assert!(
        started.elapsed() < Duration::from_secs(30),
        "{:?}",
        started.elapsed()
    );
}

/// Time-bounded byte mutation of KTX2 textures (the synthetic UASTC ones,
/// and an ETC1S and a UASTC+Zstandard one of the shared folder when present): truncation, bit flips, and
/// header, index and global-data words set to edge values. Every case must
/// decode or be refused naming the file, within a second. Seed and time:
/// `SOUPRAY_FUZZ_SEED`, `SOUPRAY_KTX2_FUZZ_SECS` (default 10 s).
#[test]
fn ktx2_byte_mutation_fuzz() {
    let seed: u64 = std::env::var("SOUPRAY_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x4b54_5832);
    let secs: u64 = std::env::var("SOUPRAY_KTX2_FUZZ_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(10);
    let colours: Vec<[u8; 4]> = (0..16u8).map(|i| [i * 16, 255 - i * 8, i, 200]).collect();
    let mut seeds = vec![
        common::scene::ktx2::uastc_ktx2(16, 16, &colours, false, Some("rd")),
        common::scene::ktx2::uastc_ktx2(16, 13, &colours, true, None),
    ];
    seeds.extend(shared_etc1s());
    // UASTC under Zstandard as an encoder writes it, 256x256 with 9 levels.
    seeds.extend(
        common::shared::khronos(
            "StainedGlassLamp/glTF-KTX-BasisU/StainedGlassLamp_steel_occlusion-rough-metal.ktx2",
        )
        .map(|p| std::fs::read(p).unwrap()),
    );
    let dir = tempfile::tempdir().unwrap();
    let mut rng = XorshiftStar(seed);
    let deadline = Instant::now() + Duration::from_secs(secs);
    let (mut cases, mut loaded, mut failures) = (0usize, 0usize, Vec::new());
    while Instant::now() < deadline && cases < 20_000 {
        let base = &seeds[rng.below(seeds.len())];
        let mut bytes = base.clone();
        // Words worth lying in: the header, the level index and (ETC1S)
        // the BasisLZ global data's header and first image descriptors.
        let sgd = u64::from_le_bytes(base[64..72].try_into().unwrap()) as usize;
        let what = match rng.below(4) {
            0 => {
                let n = rng.below(bytes.len());
                bytes.truncate(n);
                format!("truncated to {n}")
            }
            1 => {
                let flips = 1 + rng.below(8);
                for _ in 0..flips {
                    let at = rng.below(bytes.len());
                    bytes[at] ^= 1 << rng.below(8);
                }
                format!("{flips} bit flips")
            }
            _ => {
                let at = if sgd > 0 && rng.below(2) == 0 {
                    sgd + 4 * rng.below(10)
                } else {
                    12 + 4 * rng.below(23)
                };
                let v = [
                    0u32,
                    1,
                    2,
                    3,
                    6,
                    16,
                    255,
                    1 << 16,
                    1 << 31,
                    u32::MAX - 3,
                    u32::MAX,
                ][rng.below(11)];
                put_u32(&mut bytes, at, v);
                format!("word at {at} = {v}")
            }
        };
        let case = format!("ktx2_case{cases}");
        let path = with_texture(dir.path(), &case, &format!("{case}.ktx2"), &bytes);
        let started = Instant::now();
        let result = std::panic::catch_unwind(|| outcome(&path));
        let took = started.elapsed();
        match result {
            Ok(Ok(_)) => loaded += 1,
            Ok(Err(msg)) if msg.contains(&format!("{case}.gltf")) && !msg.contains(LAST_RESORT) => {
            }
            Ok(Err(msg)) => failures.push(format!("{case} ({what}): {msg}")),
            Err(_) => failures.push(format!("{case} ({what}): panicked")),
        }
        if took > Duration::from_secs(1) {
            failures.push(format!("{case} ({what}): took {took:?}"));
        }
        let _ = std::fs::remove_file(&path);
        let _ = std::fs::remove_file(dir.path().join(format!("{case}.ktx2")));
        cases += 1;
    }
    eprintln!(
        "ktx2 fuzz: seed {seed}, {cases} cases in {secs} s, {loaded} decoded, {} failed",
        failures.len()
    );
    assert!(cases >= 50, "only {cases} cases ran");
    assert!(failures.is_empty(), "seed {seed}:\n{}", failures.join("\n"));
}
