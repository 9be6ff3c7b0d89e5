//! The structs and constants the host shares with the kernels are defined
//! once, in Rust (src/device_struct.rs); these tests hold the generated C
//! to those definitions: the headers in `kernels/generated/` must be what
//! the definitions generate, and the device compiler must lay out every
//! field of every struct at Rust's offset and size.

mod common;

use soupray::device_struct::{header_text, host_layout, probe_source};
use soupray::kernels::generated_headers;

/// `SOUPRAY_REGENERATE=1 cargo test --test device_structs` rewrites the
/// headers after a change to a definition.
#[test]
fn generated_headers_match_the_rust_definitions() {
    let dir = common::repo().join("kernels/generated");
    let regenerate = std::env::var_os("SOUPRAY_REGENERATE").is_some();
    let mut stale = Vec::new();
    for h in generated_headers() {
        let text = header_text(&h);
        let path = dir.join(h.file);
        if regenerate {
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(&path, &text).unwrap();
        } else if std::fs::read_to_string(&path).ok().as_deref() != Some(text.as_str()) {
            stale.push(h.file);
        }
    }
    assert!(
        stale.is_empty(),
        "kernels/generated/{stale:?} differ from the Rust definitions; regenerate them with \
         SOUPRAY_REGENERATE=1 cargo test --test device_structs"
    );
}

#[test]
fn every_field_has_rusts_offset_and_size_on_the_device() {
    let headers = generated_headers();
    let want = host_layout(&headers);
    let d = common::device();
    let got = d
        .run_layout_probe(&probe_source(&headers), "struct_layout_probe", want.len())
        .unwrap();
    let differ: Vec<String> = want
        .iter()
        .zip(&got)
        .filter(|((_, w), g)| w != *g)
        .map(|((what, w), g)| format!("{what}: Rust {w}, device {g}"))
        .collect();
    assert!(differ.is_empty(), "layouts differ:\n{}", differ.join("\n"));
    // Every struct is probed, each with all its fields.
    let fields: usize = headers
        .iter()
        .flat_map(|h| &h.structs)
        .map(|s| 1 + 2 * s.fields.len())
        .sum::<usize>()
        + soupray::device_struct::VECTOR_SIZES.len();
    assert_eq!(got.len(), fields);
    assert!(headers.iter().map(|h| h.structs.len()).sum::<usize>() >= 18);
}

/// A definition's field docs and C vector types reach the header.
#[test]
fn headers_carry_docs_and_vector_types() {
    let headers = generated_headers();
    let bvh = headers.iter().find(|h| h.file == "bvh_types.h").unwrap();
    let text = header_text(bvh);
    assert!(text.contains("    float4 lo;"), "{text}");
    assert!(text.contains("} BuildTask;"));
    assert!(text.contains("#define EMPTY_CHILD 4294967295u"));
    let pt = headers.iter().find(|h| h.file == "pt_types.h").unwrap();
    let text = header_text(pt);
    assert!(text.contains(
        "    // 1 when transmissive with a volume (refraction, attenuation), 0\n    // thin-walled.\n    float volume;"
    ));
    // The material table's defines: a factor's offset and a slot's index.
    assert!(text.contains("#define F_SHEEN_ROUGHNESS "), "{text}");
    assert!(text.contains("#define TEX_SHEEN_ROUGHNESS "), "{text}");
    assert!(text.contains("    float sigma[4];"));
}
