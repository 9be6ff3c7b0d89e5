//! Structured mutation fuzz: the test assets' documents with keys, values
//! and containers changed at random, under a fixed seed and a time bound.

use super::*;

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

/// A seed document: its name, its JSON, its binary chunk (a GLB's; empty
/// for a .gltf) and the folder of its external files (a .gltf read in place).
type Base = (String, Value, Vec<u8>, Option<PathBuf>);

/// The documents the fuzz mutates.
fn fuzz_bases() -> Vec<Base> {
    // Small assets only: each case is a full load and three evaluations.
    let mut bases: Vec<Base> = Vec::new();
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
    bases
}

/// Copies the external buffers and images of the .gltf bases into `dir`,
/// where the cases are written.
fn copy_external_files(bases: &[Base], dir: &Path) {
    for (_, _, _, from) in bases {
        if let Some(from) = from {
            for f in std::fs::read_dir(from).unwrap() {
                let p = f.unwrap().path();
                if p.extension()
                    .is_some_and(|e| e == "bin" || e == "png" || e == "jpg")
                {
                    std::fs::copy(&p, dir.join(p.file_name().unwrap())).unwrap();
                }
            }
        }
    }
}

/// Now and then, damages the container or the binary data too, adding
/// what it did to `what`.
fn damage(bytes: &mut Vec<u8>, is_glb: bool, rng: &mut XorshiftStar, what: &mut Vec<String>) {
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

    let bases = fuzz_bases();
    let dir = tempfile::tempdir().unwrap();
    copy_external_files(&bases, dir.path());
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
        damage(&mut bytes, is_glb, &mut rng, &mut what);
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
