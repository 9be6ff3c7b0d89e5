//! Hostile glTF input: the regression corpus (`tests/fuzz_corpus/`, made by
//! its `make.py`), inputs that are not regular files, and a time-bounded
//! structured mutation fuzz of the test assets with a fixed seed.
//!
//! Every input must either load (and evaluate) or fail with an error that
//! names the file; none may panic, hang, or reach the last-resort catch of a
//! panic inside loading (`soupray::scene::LAST_RESORT`): an input that does
//! is a gap in the validation, and the test lists it.
//!
//! Nothing here writes outside a temporary directory. Paths such as
//! `/dev/zero` appear only as inputs, opened read-only.

mod common;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use common::scene::asset;
use common::XorshiftStar;
use serde_json::{json, Value};
use soupray::scene::{LoadOptions, Scene, LAST_RESORT};

fn corpus() -> PathBuf {
    common::fuzz_corpus()
}

/// Loads `path` and evaluates a few frames; `Err` is the error's message.
fn outcome(path: &Path) -> Result<Vec<String>, String> {
    let scene = Scene::load(path, &LoadOptions::default()).map_err(|e| e.to_string())?;
    scene
        .materials()
        .decode_used_images()
        .map_err(|e| e.to_string())?;
    let (first, last) = scene.frame_range();
    for frame in [first, (first + last) / 2, last] {
        scene
            .evaluate(scene.time_of_frame(frame))
            .map_err(|e| e.to_string())?;
    }
    Ok(scene.warnings().to_vec())
}

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

// ---------------------------------------------------------------------------
// Structured mutation fuzz.

/// Every location in the document: a path of keys and indices.
fn locations(v: &Value, at: &mut Vec<Value>, out: &mut Vec<Vec<Value>>) {
    out.push(at.clone());
    match v {
        Value::Object(m) => {
            for (k, c) in m {
                at.push(Value::String(k.clone()));
                locations(c, at, out);
                at.pop();
            }
        }
        Value::Array(a) => {
            for (i, c) in a.iter().enumerate().take(64) {
                at.push(Value::from(i));
                locations(c, at, out);
                at.pop();
            }
        }
        _ => {}
    }
}

fn at_mut<'v>(v: &'v mut Value, path: &[Value]) -> Option<&'v mut Value> {
    let mut v = v;
    for k in path {
        v = match k {
            Value::String(s) => v.get_mut(s.as_str())?,
            Value::Number(n) => v.get_mut(n.as_u64()? as usize)?,
            _ => return None,
        };
    }
    Some(v)
}

/// One mutation a spec-aware adversary would try at a random location:
/// indices past the end or past 32 bits, wrong types, removed or repeated
/// members, misaligned offsets, hostile URIs, bad versions and paths.
fn mutate(doc: &mut Value, rng: &mut XorshiftStar) -> String {
    let mut all = Vec::new();
    locations(doc, &mut Vec::new(), &mut all);
    let path = all[rng.below(all.len())].clone();
    let Some(target) = at_mut(doc, &path) else {
        return "none".into();
    };
    let old = target.clone();
    let choices: &[&str] = &[
        "2^32+k",
        "2^32",
        "+1",
        "-1",
        "0",
        "huge",
        "half",
        "null",
        "string",
        "array",
        "object",
        "delete",
        "duplicate",
        "+2",
        "+3",
        "float",
        "uri",
        "path",
        "version",
    ];
    let choice = choices[rng.below(choices.len())];
    let n = old.as_u64().unwrap_or(0);
    let new: Option<Value> = match choice {
        "2^32+k" => Some(4_294_967_296u64.saturating_add(n).into()),
        "2^32" => Some(4_294_967_295u64.into()),
        "+1" => Some(n.saturating_add(1).into()),
        "+2" => Some(n.saturating_add(2).into()),
        "+3" => Some(n.saturating_add(3).into()),
        "-1" => Some((-1).into()),
        "0" => Some(0.into()),
        "huge" => Some(u64::MAX.into()),
        "half" => Some(0.5.into()),
        "float" => Some(serde_json::json!(-1e30)),
        "null" => Some(Value::Null),
        "string" => Some("x".into()),
        "array" => Some(serde_json::json!([])),
        "object" => Some(serde_json::json!({})),
        "uri" => {
            let uris = [
                "/dev/zero",
                "/dev/urandom",
                ".",
                "/",
                "/proc/self/mem",
                "data:,",
                "data:x;base64,@@",
                "missing.bin",
                "%zz",
            ];
            Some(uris[rng.below(uris.len())].into())
        }
        "path" => {
            Some(["pointer", "weights", "rotation", "scale", "translation"][rng.below(5)].into())
        }
        "version" => Some(["3.0", "banana", "2.1", "1.0", ""][rng.below(5)].into()),
        _ => None,
    };
    match (choice, new) {
        (_, Some(v)) => *target = v,
        ("delete", _) | ("duplicate", _) => {
            let (Some(last), parent) = (
                path.last().cloned(),
                path[..path.len().saturating_sub(1)].to_vec(),
            ) else {
                return "root".into();
            };
            let Some(parent) = at_mut(doc, &parent) else {
                return "none".into();
            };
            match (parent, last, choice) {
                (Value::Object(m), Value::String(k), "delete") => {
                    m.remove(&k);
                }
                (Value::Array(a), Value::Number(i), "delete") => {
                    a.remove(i.as_u64().unwrap() as usize);
                }
                (Value::Array(a), Value::Number(_), _) => a.push(old),
                _ => {}
            }
        }
        _ => {}
    }
    format!("{choice} at {}", serde_json::to_string(&path).unwrap())
}

fn glb_parts(bytes: &[u8]) -> (Value, Vec<u8>) {
    let u32_at = |at: usize| u32::from_le_bytes(bytes[at..at + 4].try_into().unwrap()) as usize;
    let json_len = u32_at(12);
    let json = serde_json::from_slice(&bytes[20..20 + json_len]).unwrap();
    let bin_at = 20 + json_len;
    let bin = if bin_at + 8 <= bytes.len() {
        bytes[bin_at + 8..bin_at + 8 + u32_at(bin_at)].to_vec()
    } else {
        Vec::new()
    };
    (json, bin)
}

fn glb(json: &Value, bin: &[u8]) -> Vec<u8> {
    let mut j = json.to_string().into_bytes();
    while !j.len().is_multiple_of(4) {
        j.push(b' ');
    }
    let mut b = bin.to_vec();
    while !b.len().is_multiple_of(4) {
        b.push(0);
    }
    let total = 12 + 8 + j.len() + 8 + b.len();
    let mut out = Vec::with_capacity(total);
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x4E4F_534Au32.to_le_bytes());
    out.extend_from_slice(&j);
    out.extend_from_slice(&(b.len() as u32).to_le_bytes());
    out.extend_from_slice(&0x004E_4942u32.to_le_bytes());
    out.extend_from_slice(&b);
    out
}

/// Seed and time bound: `SOUPRAY_FUZZ_SEED`, `SOUPRAY_FUZZ_SECS` (default
/// 30 s, so CI stays well inside its budget). A failure prints the seed and
/// case number, which reproduce it.
#[test]
fn structured_mutation_fuzz() {
    let seed: u64 = std::env::var("SOUPRAY_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x50u64 << 56 | 14);
    let secs: u64 = std::env::var("SOUPRAY_FUZZ_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30);
    let deadline = Instant::now() + Duration::from_secs(secs);

    // Small assets only: each case is a full load and three evaluations.
    let mut bases: Vec<(String, Value, Vec<u8>, Option<PathBuf>)> = Vec::new();
    // Generated seeds first, so a clone without the shared folder still
    // fuzzes skins, morphs, every interpolation, textures, lights, cameras,
    // instancing and compressed views: the shipped animation, and the
    // support module's generated scenes (data-URI buffers).
    let generated = tempfile::tempdir().unwrap();
    let walker = std::fs::read(common::repo_file("animations/walker/walker.glb")).unwrap();
    let (json, bin) = glb_parts(&walker);
    bases.push(("animations/walker/walker.glb".into(), json, bin, None));
    let (meshopt, meshopt_bin) = common::scene::meshopt_quad();
    for (name, path) in [
        (
            "generated EXT_mesh_gpu_instancing row",
            common::scene::instanced_triangles(generated.path(), true),
        ),
        (
            "generated skinned triangle",
            common::scene::skinned_triangle(
                generated.path(),
                serde_json::json!({"translation": [0.0, 1.0, 0.0]}),
                [1.0, 0.0, 0.0],
            ),
        ),
        (
            "generated EXT_meshopt_compression quad",
            common::scene::write_with_buffer(
                meshopt.clone(),
                &meshopt_bin,
                generated.path(),
                "meshopt",
            ),
        ),
    ] {
        let json = serde_json::from_slice(&std::fs::read(&path).unwrap()).unwrap();
        bases.push((name.into(), json, Vec::new(), None));
    }
    for rel in [
        "BoxAnimated/BoxAnimated.glb",
        "RiggedSimple/RiggedSimple.glb",
        "AnimatedMorphCube/AnimatedMorphCube.glb",
        "InterpolationTest/InterpolationTest.glb",
        "SimpleSkin/SimpleSkin.gltf",
        "SimpleMorph/SimpleMorph.gltf",
        "AnimatedCube/AnimatedCube.gltf",
    ] {
        // The seeds are read in place and mutated in memory; a missing one
        // (no shared folder) is left out, with a message naming it.
        let Some(path) = asset(rel) else {
            continue;
        };
        let bytes = std::fs::read(&path).unwrap();
        if rel.ends_with(".glb") {
            let (json, bin) = glb_parts(&bytes);
            bases.push((rel.into(), json, bin, None));
        } else {
            let json = serde_json::from_slice(&bytes).unwrap();
            bases.push((
                rel.into(),
                json,
                Vec::new(),
                path.parent().map(Path::to_path_buf),
            ));
        }
    }
    // A Draco-compressed skinned grid, generated (no shared folder needed).
    let (json, bin) = common::scene::draco_grid(12, 5).draco;
    bases.push(("generated Draco grid".into(), json, bin, None));
    for f in std::fs::read_dir(corpus()).unwrap() {
        let p = f.unwrap().path();
        if p.extension().is_some_and(|e| e == "gltf") && p.file_stem().is_some_and(|s| s == "valid")
        {
            let json = serde_json::from_slice(&std::fs::read(&p).unwrap()).unwrap();
            bases.push(("fuzz_corpus/valid.gltf".into(), json, Vec::new(), None));
        }
    }

    let dir = tempfile::tempdir().unwrap();
    // External buffers and images of the .gltf assets, beside the cases.
    for (_, _, _, from) in &bases {
        if let Some(from) = from {
            for f in std::fs::read_dir(from).unwrap() {
                let p = f.unwrap().path();
                if p.extension()
                    .is_some_and(|e| e == "bin" || e == "png" || e == "jpg")
                {
                    std::fs::copy(&p, dir.path().join(p.file_name().unwrap())).unwrap();
                }
            }
        }
    }
    let mut rng = XorshiftStar(seed);
    let (mut cases, mut loaded, mut refused) = (0usize, 0usize, 0usize);
    let mut failures = Vec::new();
    while Instant::now() < deadline && cases < 100_000 {
        let (name, json, bin, external) = &bases[rng.below(bases.len())];
        let mut doc = json.clone();
        let mut what = Vec::new();
        for _ in 0..1 + rng.below(3) {
            what.push(mutate(&mut doc, &mut rng));
        }
        let is_glb = external.is_none() && !bin.is_empty();
        let path = dir.path().join(format!(
            "case{cases}.{}",
            if is_glb { "glb" } else { "gltf" }
        ));
        let mut bytes = if is_glb {
            glb(&doc, bin)
        } else {
            doc.to_string().into_bytes()
        };
        // Now and then, damage the container or the binary data too.
        match rng.below(10) {
            0 => bytes.truncate(rng.below(bytes.len())),
            1 if is_glb => {
                let at = 8 + 4 * rng.below(2);
                let v = [0u32, 1, u32::MAX, bytes.len() as u32 + 4][rng.below(4)];
                bytes[at..at + 4].copy_from_slice(&v.to_le_bytes());
                what.push(format!("length field at {at} = {v}"));
            }
            2 => {
                for _ in 0..8 {
                    let at = rng.below(bytes.len());
                    bytes[at] = rng.next() as u8;
                }
                what.push("8 random bytes".into());
            }
            _ => {}
        }
        std::fs::write(&path, &bytes).unwrap();
        let file = path.file_name().unwrap().to_str().unwrap().to_owned();
        let result = std::panic::catch_unwind(|| outcome(&path));
        match result {
            Ok(Ok(_)) => loaded += 1,
            Ok(Err(msg)) if msg.contains(&file) && !msg.contains(LAST_RESORT) => refused += 1,
            Ok(Err(msg)) => failures.push(format!("case {cases} ({name}: {what:?}): {msg}")),
            Err(_) => failures.push(format!(
                "case {cases} ({name}: {what:?}): panicked while evaluating"
            )),
        }
        let _ = std::fs::remove_file(&path);
        cases += 1;
    }
    eprintln!("fuzz: seed {seed}, {cases} cases in {secs} s: {loaded} loaded, {refused} refused cleanly, {} failed", failures.len());
    assert!(cases >= 50, "only {cases} cases ran");
    assert!(failures.is_empty(), "seed {seed}:\n{}", failures.join("\n"));
}

/// A change to a glTF document.
type Edit = dyn Fn(&mut Value);

/// Hostile KHR_draco_mesh_compression payloads and JSON around them, made
/// from a generated Draco grid (every connectivity coder): the payload cut
/// at every length, every byte with a bit flipped, random bytes, accessor
/// counts that lie, and broken extension objects. Each must load or be
/// refused with a message naming the file, quickly, and never panic; the
/// lies about counts, the cut payloads and the broken extensions must be
/// refused, naming the mesh and primitive.
#[test]
fn draco_payload_mutations_are_refused_cleanly() {
    let dir = tempfile::tempdir().unwrap();
    let mut rng = XorshiftStar(0xD4AC0);
    let mut failures = Vec::new();
    let (mut cases, mut loaded) = (0usize, 0usize);
    let started = Instant::now();
    for speed in [10, 5, 1] {
        let pair = common::scene::draco_grid(12, speed);
        let (root, bin) = pair.draco.clone();
        let view = root["bufferViews"][pair.payload_view].clone();
        let at = view["byteOffset"].as_u64().unwrap() as usize;
        let len = view["byteLength"].as_u64().unwrap() as usize;
        let mut run = |what: String, root: Value, bin: Vec<u8>, must_fail: bool| {
            let name = format!("draco{cases}");
            let path = common::scene::write_with_buffer(root, &bin, dir.path(), &name);
            let t = Instant::now();
            let result = std::panic::catch_unwind(|| outcome(&path));
            let file = format!("{name}.gltf");
            let took = t.elapsed();
            let problem = match &result {
                Err(_) => Some("panicked".to_owned()),
                Ok(Err(msg)) if !msg.contains(&file) || msg.contains(LAST_RESORT) => {
                    Some(format!("bad message: {msg}"))
                }
                Ok(Err(msg)) if must_fail && !msg.contains("mesh 0 primitive 0") => {
                    Some(format!("refused without naming the primitive: {msg}"))
                }
                Ok(Ok(_)) if must_fail => Some("loaded".to_owned()),
                _ => None,
            };
            if took > Duration::from_secs(2) {
                failures.push(format!("speed {speed}, {what}: took {took:?}"));
            }
            if let Some(p) = problem {
                failures.push(format!("speed {speed}, {what}: {p}"));
            }
            if matches!(result, Ok(Ok(_))) {
                loaded += 1;
            }
            let _ = std::fs::remove_file(&path);
            cases += 1;
        };
        run("unchanged".into(), root.clone(), bin.clone(), false);

        // Truncated: the view ends early, or the buffer's bytes do.
        for cut in 0..len {
            let mut r = root.clone();
            r["bufferViews"][pair.payload_view]["byteLength"] = cut.max(1).into();
            run(format!("payload cut to {cut} bytes"), r, bin.clone(), true);
        }
        for cut in [at, at + 1, at + len / 2, at + len - 1] {
            let mut short = bin.clone();
            short.truncate(cut);
            run(format!("buffer cut at {cut}"), root.clone(), short, true);
        }
        // Bit flips: every byte once, then bursts of random bytes.
        for k in 0..len {
            let mut b = bin.clone();
            b[at + k] ^= 1 << rng.below(8);
            run(format!("bit flipped in byte {k}"), root.clone(), b, false);
        }
        for n in 0..64 {
            let mut b = bin.clone();
            for _ in 0..1 + rng.below(8) {
                b[at + rng.below(len)] = rng.next() as u8;
            }
            run(format!("random bytes {n}"), root.clone(), b, false);
        }

        // Accessor counts that lie about the payload.
        let pos = root["meshes"][0]["primitives"][0]["attributes"]["POSITION"]
            .as_u64()
            .unwrap() as usize;
        let idx = root["meshes"][0]["primitives"][0]["indices"]
            .as_u64()
            .unwrap() as usize;
        let (points, corners) = (pair.points, pair.faces * 3);
        for (acc, count) in [
            (pos, points + 1),
            (pos, points - 1),
            (pos, 1),
            (pos, 1 << 28),
            (pos, (1 << 28) + 1),
            (pos, usize::MAX >> 1),
            (idx, corners + 3),
            (idx, corners - 3),
            (idx, corners + 1),
            (idx, 3 << 27),
            (idx, (1 << 28) + 3),
        ] {
            let mut r = root.clone();
            r["accessors"][acc]["count"] = count.into();
            run(
                format!("accessor {acc} count {count}"),
                r,
                bin.clone(),
                true,
            );
        }
        // Every attribute's accessor claims one point more.
        let mut r = root.clone();
        let names: Vec<String> = r["meshes"][0]["primitives"][0]["attributes"]
            .as_object()
            .unwrap()
            .keys()
            .cloned()
            .collect();
        for n in &names {
            let a = r["meshes"][0]["primitives"][0]["attributes"][n]
                .as_u64()
                .unwrap() as usize;
            if r["accessors"][a].get("bufferView").is_none() {
                r["accessors"][a]["count"] = (points + 1).into();
            }
        }
        run("every count one more".into(), r, bin.clone(), true);

        // Broken extension objects and accessors.
        let ext = "/meshes/0/primitives/0/extensions/KHR_draco_mesh_compression";
        let edits: Vec<(&str, Box<Edit>)> = vec![
            (
                "bufferView 99",
                Box::new(|r| r.pointer_mut(ext).unwrap()["bufferView"] = 99.into()),
            ),
            (
                "bufferView -1",
                Box::new(|r| r.pointer_mut(ext).unwrap()["bufferView"] = (-1).into()),
            ),
            (
                "bufferView of the skin matrices",
                Box::new(|r| {
                    let ibm = r["skins"][0]["inverseBindMatrices"].as_u64().unwrap() as usize;
                    let v = r["accessors"][ibm]["bufferView"].clone();
                    r.pointer_mut(ext).unwrap()["bufferView"] = v;
                }),
            ),
            (
                "no bufferView",
                Box::new(|r| {
                    r.pointer_mut(ext)
                        .unwrap()
                        .as_object_mut()
                        .unwrap()
                        .remove("bufferView");
                }),
            ),
            (
                "no attributes",
                Box::new(|r| {
                    r.pointer_mut(ext)
                        .unwrap()
                        .as_object_mut()
                        .unwrap()
                        .remove("attributes");
                }),
            ),
            (
                "extension not an object",
                Box::new(|r| *r.pointer_mut(ext).unwrap() = json!([1])),
            ),
            (
                "POSITION id 99",
                Box::new(|r| r.pointer_mut(ext).unwrap()["attributes"]["POSITION"] = 99.into()),
            ),
            (
                "POSITION id of NORMAL",
                Box::new(|r| {
                    let n = r.pointer(ext).unwrap()["attributes"]["NORMAL"].clone();
                    r.pointer_mut(ext).unwrap()["attributes"]["POSITION"] = n;
                }),
            ),
            (
                "TEXCOORD_0 id of JOINTS_0",
                Box::new(|r| {
                    let n = r.pointer(ext).unwrap()["attributes"]["JOINTS_0"].clone();
                    r.pointer_mut(ext).unwrap()["attributes"]["TEXCOORD_0"] = n;
                }),
            ),
            (
                "POSITION id 2^32",
                Box::new(|r| {
                    r.pointer_mut(ext).unwrap()["attributes"]["POSITION"] = (1u64 << 32).into()
                }),
            ),
            (
                "POSITION id a string",
                Box::new(|r| r.pointer_mut(ext).unwrap()["attributes"]["POSITION"] = "0".into()),
            ),
            (
                "mode POINTS",
                Box::new(|r| r["meshes"][0]["primitives"][0]["mode"] = 0.into()),
            ),
            (
                "no indices",
                Box::new(|r| {
                    r["meshes"][0]["primitives"][0]
                        .as_object_mut()
                        .unwrap()
                        .remove("indices");
                }),
            ),
            (
                "indices FLOAT",
                Box::new(move |r| r["accessors"][idx]["componentType"] = 5126.into()),
            ),
            (
                "indices VEC2",
                Box::new(move |r| r["accessors"][idx]["type"] = "VEC2".into()),
            ),
            (
                "POSITION VEC2",
                Box::new(move |r| r["accessors"][pos]["type"] = "VEC2".into()),
            ),
            (
                "POSITION MAT4",
                Box::new(move |r| r["accessors"][pos]["type"] = "MAT4".into()),
            ),
            (
                "JOINTS_0 as UNSIGNED_BYTE VEC3",
                Box::new(|r| {
                    let j = r["meshes"][0]["primitives"][0]["attributes"]["JOINTS_0"]
                        .as_u64()
                        .unwrap() as usize;
                    r["accessors"][j]["type"] = "VEC3".into();
                }),
            ),
            (
                "POSITION sparse",
                Box::new(move |r| {
                    r["accessors"][pos]["sparse"] = json!({"count": 1,
                "indices": {"bufferView": 0, "componentType": 5121}, "values": {"bufferView": 0}})
                }),
            ),
        ];
        for (what, edit) in edits {
            let mut r = root.clone();
            edit(&mut r);
            run(what.into(), r, bin.clone(), true);
        }
        // Indices narrower than the points they name are refused when a
        // point does not fit (it always fits UNSIGNED_BYTE here).
        let mut r = root.clone();
        r["accessors"][idx]["componentType"] = 5121.into();
        run("indices as UNSIGNED_BYTE".into(), r, bin.clone(), false);
    }
    eprintln!(
        "Draco mutations: {cases} cases in {:?}, {loaded} loaded, {} failed",
        started.elapsed(),
        failures.len()
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// ---------------------------------------------------------------------------
// Hostile texture payloads: KTX2 (Basis Universal) and WebP, whose bytes a
// decoder trusts. Each is sampled by the valid corpus file's material, so
// loading decodes it.

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
