//! The frame files end to end: EXRs written by `output::write_exr` read back
//! with the `exr` crate (channels, values, metadata, half mode), truncated
//! files caught by `--skip-existing`'s check, atomic writes that leave
//! neither temporaries nor partial files, the PNG preview, and the output
//! directory check.

use exr::prelude::traits::*;
use exr::prelude::{AnyChannels, AttributeValue, FlatSamples, Layer, Text};
use soupray::cli::frames::{check_output_dir, frame_paths, NamePattern};
use soupray::film::{Aovs, Image, BACKGROUND_DEPTH};
use soupray::output::{
    is_complete_exr, is_frame_done, write_atomic, write_exr, write_log, write_png_preview,
    ExrFormat, FrameLog, FrameMetadata, OutputError,
};
use std::collections::HashMap;
use std::path::Path;

type ReadLayer = Layer<AnyChannels<FlatSamples>>;

fn read_back(
    path: &Path,
) -> (
    ReadLayer,
    HashMap<Text, AttributeValue>,
    exr::image::Image<ReadLayer>,
) {
    let image = exr::prelude::read()
        .no_deep_data()
        .largest_resolution_level()
        .all_channels()
        .first_valid_layer()
        .all_attributes()
        .pedantic()
        .from_file(path)
        .unwrap();
    // Custom attributes may be reported with the image or the layer.
    let mut attrs = image.attributes.other.clone();
    attrs.extend(image.layer_data.attributes.other.clone());
    (image.layer_data.clone(), attrs, image)
}

/// A 5x3 image whose every value is distinct and exact in f16.
fn test_image(aovs: Aovs) -> Image {
    let mut img = Image::new(5, 3, aovs);
    for i in 0..15 {
        let v = i as f32;
        img.rgba[i] = [
            v / 16.0,
            v / 8.0,
            v / 4.0,
            if i % 2 == 0 { 1.0 } else { 0.5 },
        ];
        if let Some(z) = &mut img.depth {
            z[i] = if i == 14 {
                BACKGROUND_DEPTH
            } else {
                100.0 + v * 1000.25
            };
        }
        if let Some(n) = &mut img.normal {
            n[i] = [v / 32.0 - 0.25, 0.5, -1.0];
        }
        if let Some(a) = &mut img.albedo {
            a[i] = [0.125, v / 64.0, 0.75];
        }
    }
    img
}

fn meta() -> FrameMetadata {
    FrameMetadata {
        frame: -12,
        time: -0.5,
        spp: 64,
        seed: u64::MAX - 1,
    }
}

fn values(layer: &ReadLayer, name: &str) -> Vec<f32> {
    let ch = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name == *name)
        .unwrap_or_else(|| panic!("no channel {name}"));
    ch.sample_data.values_as_f32().collect()
}

fn is_f16(layer: &ReadLayer, name: &str) -> bool {
    let ch = layer
        .channel_data
        .list
        .iter()
        .find(|c| c.name == *name)
        .unwrap();
    matches!(ch.sample_data, FlatSamples::F16(_))
}

#[test]
fn every_exr_compression_is_lossless_and_recorded_in_the_header() {
    use soupray::output::ExrCompression;
    let dir = tempfile::tempdir().unwrap();
    let img = test_image(Aovs::ALL);
    let mut sizes = Vec::new();
    for name in ExrCompression::NAMES {
        let compression: ExrCompression = name.parse().unwrap();
        assert_eq!(compression.name(), name);
        let path = dir.path().join(format!("{name}.exr"));
        let format = ExrFormat {
            half: false,
            compression,
            ..ExrFormat::FLOAT
        };
        write_exr(&path, &img, &meta(), format).unwrap();
        let (layer, _, _) = read_back(&path);
        let want = match name {
            "zip" => exr::compression::Compression::ZIP16,
            "zips" => exr::compression::Compression::ZIP1,
            "piz" => exr::compression::Compression::PIZ,
            "rle" => exr::compression::Compression::RLE,
            _ => exr::compression::Compression::Uncompressed,
        };
        assert_eq!(layer.encoding.compression, want, "{name}");
        for (c, channel) in ["R", "G", "B", "A"].into_iter().enumerate() {
            let expect: Vec<f32> = img.rgba.iter().map(|p| p[c]).collect();
            let got: Vec<f32> = (layer.channel_data.list.iter())
                .find(|ch| ch.name.to_string() == channel)
                .unwrap()
                .sample_data
                .values_as_f32()
                .collect();
            assert_eq!(got, expect, "{name} {channel}");
        }
        sizes.push(std::fs::metadata(&path).unwrap().len());
    }
    assert!("lz4".parse::<ExrCompression>().is_err());
    assert_eq!(ExrCompression::default(), ExrCompression::Zip);
    eprintln!("file sizes {:?}: {sizes:?}", ExrCompression::NAMES);
}

#[test]
fn exr_round_trip_with_aovs() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("shot.-012.exr");
    let img = test_image(Aovs::ALL);
    write_exr(&path, &img, &meta(), ExrFormat::FLOAT).unwrap();

    let (layer, attrs, image) = read_back(&path);
    let mut names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    names.sort();
    let mut expected = [
        "R", "G", "B", "A", "Z", "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B",
    ]
    .map(String::from)
    .to_vec();
    expected.sort();
    assert_eq!(names, expected);
    assert!(layer
        .channel_data
        .list
        .iter()
        .all(|c| !is_f16(&layer, &c.name.to_string())));
    assert_eq!((layer.size.0, layer.size.1), (5, 3));

    // Row-major from the top: the flat order of the image buffers.
    for (c, name) in ["R", "G", "B", "A"].into_iter().enumerate() {
        let expect: Vec<f32> = img.rgba.iter().map(|p| p[c]).collect();
        assert_eq!(values(&layer, name), expect, "{name}");
    }
    assert_eq!(values(&layer, "Z"), *img.depth.as_ref().unwrap());
    for (c, name) in ["N.X", "N.Y", "N.Z"].into_iter().enumerate() {
        let expect: Vec<f32> = img.normal.as_ref().unwrap().iter().map(|p| p[c]).collect();
        assert_eq!(values(&layer, name), expect, "{name}");
    }
    for (c, name) in ["albedo.R", "albedo.G", "albedo.B"].into_iter().enumerate() {
        let expect: Vec<f32> = img.albedo.as_ref().unwrap().iter().map(|p| p[c]).collect();
        assert_eq!(values(&layer, name), expect, "{name}");
    }

    assert_eq!(
        attrs.get(&Text::from("frame")),
        Some(&AttributeValue::I32(-12))
    );
    assert_eq!(
        attrs.get(&Text::from("time")),
        Some(&AttributeValue::F64(-0.5))
    );
    assert_eq!(
        attrs.get(&Text::from("spp")),
        Some(&AttributeValue::I32(64))
    );
    assert_eq!(
        attrs.get(&Text::from("seed")),
        Some(&AttributeValue::Text(Text::from(
            (u64::MAX - 1).to_string().as_str()
        )))
    );
    assert_eq!(
        layer
            .attributes
            .software_name
            .as_ref()
            .map(|t| t.to_string()),
        Some(format!("soupray {}", env!("CARGO_PKG_VERSION")))
    );
    let chroma = image.attributes.chromaticities.expect("chromaticities");
    assert_eq!((chroma.red.0, chroma.white.0), (0.64, 0.3127));
    assert!(is_complete_exr(&path));
}

#[test]
fn exr_half_keeps_depth_in_f32() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("h.exr");
    let img = test_image(Aovs::ALL);
    write_exr(&path, &img, &meta(), ExrFormat::HALF).unwrap();
    let (layer, attrs, _) = read_back(&path);
    for name in [
        "R", "G", "B", "A", "N.X", "N.Y", "N.Z", "albedo.R", "albedo.G", "albedo.B",
    ] {
        assert!(is_f16(&layer, name), "{name} should be half");
    }
    assert!(
        !is_f16(&layer, "Z"),
        "Z stays f32: 1e10 does not fit a half"
    );
    // The test values are exact in f16.
    let expect: Vec<f32> = img.rgba.iter().map(|p| p[2]).collect();
    assert_eq!(values(&layer, "B"), expect);
    assert_eq!(values(&layer, "Z"), *img.depth.as_ref().unwrap());
    assert_eq!(
        attrs.get(&Text::from("frame")),
        Some(&AttributeValue::I32(-12))
    );
    // Half is smaller than full float for the same image.
    let full = dir.path().join("f.exr");
    write_exr(&full, &img, &meta(), ExrFormat::FLOAT).unwrap();
    assert!(std::fs::metadata(&path).unwrap().len() < std::fs::metadata(&full).unwrap().len());
}

#[test]
fn exr_counts_and_estimates_stay_f32_with_half() {
    // Sample counts and rays past 2048 are not exact in a half float, nor
    // are small error estimates: these channels stay f32 whatever --half.
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("c.exr");
    let mut img = test_image(Aovs {
        sample_count: true,
        noise: true,
        rays: true,
        ..Aovs::NONE
    });
    for i in 0..15 {
        img.sample_count.as_mut().unwrap()[i] = 2049.0 + i as f32;
        img.noise.as_mut().unwrap()[i] = 1e-5 * (i as f32 + 1.0 / 3.0);
        img.rays.as_mut().unwrap()[i] = 100_003.0 * i as f32;
    }
    write_exr(&path, &img, &meta(), ExrFormat::HALF).unwrap();
    let (layer, _, _) = read_back(&path);
    for (name, buf) in [
        ("sample_count", &img.sample_count),
        ("noise", &img.noise),
        ("rays", &img.rays),
    ] {
        assert!(!is_f16(&layer, name), "{name} should stay f32");
        assert_eq!(values(&layer, name), *buf.as_ref().unwrap(), "{name}");
    }
    assert!(is_f16(&layer, "R"));
}

#[test]
fn exr_without_aovs_is_plain_rgba() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.exr");
    write_exr(&path, &test_image(Aovs::NONE), &meta(), ExrFormat::FLOAT).unwrap();
    let (layer, _, _) = read_back(&path);
    let names: Vec<String> = layer
        .channel_data
        .list
        .iter()
        .map(|c| c.name.to_string())
        .collect();
    assert_eq!(names, ["A", "B", "G", "R"]);
}

#[test]
fn truncated_or_foreign_exr_is_incomplete() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("t.exr");
    // Big enough for several ZIP blocks, with noise so it compresses poorly.
    let mut img = Image::new(64, 64, Aovs::ALL);
    let mut x = 1u32;
    for p in img.rgba.iter_mut() {
        x = x.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        *p = [(x >> 8) as f32 / 16_777_216.0, 0.5, 0.25, 1.0];
    }
    write_exr(&path, &img, &meta(), ExrFormat::FLOAT).unwrap();
    assert!(is_complete_exr(&path));
    let bytes = std::fs::read(&path).unwrap();
    let cut = dir.path().join("cut.exr");
    for len in [
        bytes.len() - 1,
        bytes.len() - 100,
        bytes.len() / 2,
        400,
        10,
        0,
    ] {
        std::fs::write(&cut, &bytes[..len]).unwrap();
        assert!(
            !is_complete_exr(&cut),
            "truncated to {len} of {} bytes",
            bytes.len()
        );
    }
    // A flipped byte in the last block's compressed data.
    let mut bad = bytes.clone();
    let n = bad.len();
    bad[n - 20] ^= 0xff;
    bad[n - 21] ^= 0xff;
    std::fs::write(&cut, &bad).unwrap();
    assert!(!is_complete_exr(&cut), "corrupted block");
    std::fs::write(&cut, b"not an exr at all").unwrap();
    assert!(!is_complete_exr(&cut));
    assert!(!is_complete_exr(&dir.path().join("missing.exr")));
}

#[test]
fn frame_is_done_only_with_exr_and_log() {
    let dir = tempfile::tempdir().unwrap();
    let pattern = NamePattern::new("s.####.exr", 2).unwrap();
    let paths = frame_paths(dir.path(), &pattern, 3);
    assert!(!is_frame_done(&paths.exr, &paths.log));
    write_exr(
        &paths.exr,
        &test_image(Aovs::NONE),
        &meta(),
        ExrFormat::FLOAT,
    )
    .unwrap();
    assert!(
        !is_frame_done(&paths.exr, &paths.log),
        "killed before the log"
    );
    let mut log = FrameLog::new();
    log.frame = 3;
    write_log(&paths.log, &log).unwrap();
    assert!(is_frame_done(&paths.exr, &paths.log));
    let bytes = std::fs::read(&paths.exr).unwrap();
    std::fs::write(&paths.exr, &bytes[..bytes.len() / 2]).unwrap();
    assert!(!is_frame_done(&paths.exr, &paths.log), "truncated EXR");
}

fn listing(dir: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn atomic_writes_leave_no_temporaries_and_no_partial_files() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("a.0001.exr");
    write_exr(&path, &test_image(Aovs::ALL), &meta(), ExrFormat::FLOAT).unwrap();
    write_png_preview(
        &path.with_extension("png"),
        &test_image(Aovs::NONE),
        0.0,
        false,
    )
    .unwrap();
    write_log(&path.with_extension("json"), &FrameLog::new()).unwrap();
    assert_eq!(
        listing(dir.path()),
        ["a.0001.exr", "a.0001.json", "a.0001.png"]
    );

    // A writer failing halfway: no final file, no temporary.
    let failing = dir.path().join("b.0001.exr");
    let e = write_atomic(&failing, |out| {
        use std::io::Write as _;
        out.write_all(&[7u8; 100_000]).unwrap();
        Err(OutputError::Encode {
            path: failing.clone(),
            format: "EXR",
            message: "simulated failure".into(),
        })
    })
    .unwrap_err();
    assert!(e.to_string().contains("b.0001.exr"), "{e}");
    assert_eq!(
        listing(dir.path()),
        ["a.0001.exr", "a.0001.json", "a.0001.png"]
    );

    // A failure overwriting an existing frame leaves the old one intact.
    let before = std::fs::read(&path).unwrap();
    let mut broken = test_image(Aovs::NONE);
    broken.rgba.pop();
    let e = write_exr(&path, &broken, &meta(), ExrFormat::FLOAT).unwrap_err();
    assert!(e.to_string().contains("a.0001.exr"), "{e}");
    assert_eq!(std::fs::read(&path).unwrap(), before);
    assert_eq!(
        listing(dir.path()),
        ["a.0001.exr", "a.0001.json", "a.0001.png"]
    );

    // A directory that does not exist: a clear error naming the file.
    let nowhere = dir.path().join("no/such/dir/c.exr");
    let e = write_exr(&nowhere, &test_image(Aovs::NONE), &meta(), ExrFormat::FLOAT).unwrap_err();
    let msg = e.to_string();
    assert!(msg.contains("c.exr") && msg.contains("writable"), "{msg}");
}

#[test]
fn png_preview_is_tonemapped_srgb() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("p.0001.png");
    let mut img = Image::new(3, 2, Aovs::NONE);
    img.rgba[0] = [0.18, 0.36, 4.0, 1.0];
    img.rgba[5] = [0.09, 0.0, -1.0, 1.0];
    write_png_preview(&path, &img, 1.0, false).unwrap();
    let png = image::open(&path).unwrap().to_rgb8();
    assert_eq!(png.dimensions(), (3, 2));
    // +1 stop: 0.36 → 162, 0.72 → 221, 8 → 255 (clamped).
    assert_eq!(png.get_pixel(0, 0).0, [162, 221, 255]);
    assert_eq!(png.get_pixel(2, 1).0, [118, 0, 0]);
    assert_eq!(png.get_pixel(1, 0).0, [0, 0, 0]);
}

#[test]
fn unusable_output_dir_is_a_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("a-file");
    std::fs::write(&file, b"x").unwrap();
    // A directory cannot be created under a regular file (this holds even
    // for root, unlike permission bits).
    let e = check_output_dir(&file.join("frames"))
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("cannot create it") && e.contains("--out") && e.contains("a-file"),
        "{e}"
    );
    let e = check_output_dir(&file).unwrap_err().to_string();
    assert!(e.contains("not a directory"), "{e}");
    check_output_dir(&dir.path().join("new/deep")).unwrap();
    assert_eq!(listing(&dir.path().join("new/deep")), Vec::<String>::new());
}
