//! The regression corpus (`tests/fuzz_corpus/`), each file's outcome as
//! recorded, and inputs that are not regular files: FIFOs, devices,
//! directories.

use super::*;

#[test]
fn regression_corpus_outcomes() {
    let expect: Value =
        serde_json::from_str(&std::fs::read_to_string(corpus().join("expect.json")).unwrap())
            .unwrap();
    let expect = expect.as_object().unwrap();
    assert!(expect.len() >= 60, "corpus has {} cases", expect.len());
    let mut failures = Vec::new();
    for (name, want) in expect {
        let path = corpus().join(name);
        let mentions: Vec<&str> = want["mentions"]
            .as_array()
            .unwrap()
            .iter()
            .map(|m| m.as_str().unwrap())
            .collect();
        let got = outcome(&path);
        let problem = match (want["outcome"].as_str().unwrap(), &got) {
            ("error", Err(msg)) => {
                let missing: Vec<_> = std::iter::once(name.as_str())
                    .chain(mentions.iter().copied())
                    .filter(|m| !msg.contains(m))
                    .collect();
                (!missing.is_empty() || msg.contains(LAST_RESORT))
                    .then(|| format!("message lacks {missing:?} or is a last resort: {msg}"))
            }
            ("ok", Ok(warnings)) => {
                let all = warnings.join("\n");
                let missing: Vec<_> = mentions.iter().filter(|m| !all.contains(*m)).collect();
                (!missing.is_empty()).then(|| format!("warnings lack {missing:?}: {warnings:?}"))
            }
            (want, got) => Some(format!("expected {want}, got {got:?}")),
        };
        if let Some(p) = problem {
            failures.push(format!("{name}: {p}"));
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn fifo_as_scene_buffer_or_image_is_refused_without_blocking() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("pipe");
    let c = std::ffi::CString::new(fifo.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
    let started = Instant::now();

    let e = Scene::load(&fifo, &LoadOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("pipe") && e.contains("FIFO"), "{e}");

    let valid: Value =
        serde_json::from_str(&std::fs::read_to_string(corpus().join("valid.gltf")).unwrap())
            .unwrap();
    let mut doc = valid.clone();
    doc["buffers"][0]["uri"] = "pipe".into();
    let path = dir.path().join("buffer_fifo.gltf");
    std::fs::write(&path, doc.to_string()).unwrap();
    let e = Scene::load(&path, &LoadOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("buffer_fifo.gltf") && e.contains("FIFO"), "{e}");

    let mut doc = valid;
    doc["images"][0] = serde_json::json!({"uri": "pipe"});
    doc["textures"] = serde_json::json!([{"source": 0}]);
    doc["materials"] =
        serde_json::json!([{"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}}}]);
    doc["meshes"][0]["primitives"][0]["material"] = 0.into();
    let path = dir.path().join("image_fifo.gltf");
    std::fs::write(&path, doc.to_string()).unwrap();
    let e = match Scene::load(&path, &LoadOptions::default()) {
        Err(e) => e.to_string(),
        Ok(s) => s
            .materials()
            .decode_used_images()
            .err()
            .unwrap()
            .to_string(),
    };
    assert!(e.contains("image_fifo.gltf") && e.contains("FIFO"), "{e}");
    assert!(started.elapsed() < Duration::from_secs(10));
}

#[test]
fn devices_and_directories_as_scene_are_refused() {
    for path in ["/dev/zero", "/dev/urandom", "/dev/null", "/"] {
        let e = Scene::load(Path::new(path), &LoadOptions::default())
            .err()
            .unwrap()
            .to_string();
        assert!(
            e.starts_with(path) && (e.contains("device") || e.contains("directory")),
            "{e}"
        );
    }
    // /proc files report no size: read as empty, an error, not a runaway read.
    let e = Scene::load(Path::new("/proc/self/maps"), &LoadOptions::default())
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("/proc/self/maps"), "{e}");
}
