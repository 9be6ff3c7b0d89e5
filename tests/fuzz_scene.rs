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

mod scene_support;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use scene_support::asset;
use serde_json::{json, Value};
use soupray::scene::{LoadOptions, Scene, LAST_RESORT};

fn corpus() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fuzz_corpus")
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

struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        // xorshift64*
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_F491_4F6C_DD1D)
    }
    fn below(&mut self, n: usize) -> usize {
        (self.next() % n.max(1) as u64) as usize
    }
}

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
fn mutate(doc: &mut Value, rng: &mut Rng) -> String {
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
    let walker =
        std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("animations/walker/walker.glb"))
            .unwrap();
    let (json, bin) = glb_parts(&walker);
    bases.push(("animations/walker/walker.glb".into(), json, bin, None));
    let (meshopt, meshopt_bin) = scene_support::meshopt_quad();
    for (name, path) in [
        (
            "generated EXT_mesh_gpu_instancing row",
            scene_support::instanced_triangles(generated.path(), true),
        ),
        (
            "generated skinned triangle",
            scene_support::skinned_triangle(
                generated.path(),
                serde_json::json!({"translation": [0.0, 1.0, 0.0]}),
                [1.0, 0.0, 0.0],
            ),
        ),
        (
            "generated EXT_meshopt_compression quad",
            scene_support::write_with_buffer(
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
    let (json, bin) = scene_support::draco_grid(12, 5).draco;
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
    let mut rng = Rng(seed);
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
    let mut rng = Rng(0xD4AC0);
    let mut failures = Vec::new();
    let (mut cases, mut loaded) = (0usize, 0usize);
    let started = Instant::now();
    for speed in [10, 5, 1] {
        let pair = scene_support::draco_grid(12, speed);
        let (root, bin) = pair.draco.clone();
        let view = root["bufferViews"][pair.payload_view].clone();
        let at = view["byteOffset"].as_u64().unwrap() as usize;
        let len = view["byteLength"].as_u64().unwrap() as usize;
        let mut run = |what: String, root: Value, bin: Vec<u8>, must_fail: bool| {
            let name = format!("draco{cases}");
            let path = scene_support::write_with_buffer(root, &bin, dir.path(), &name);
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
