//! Hostile KHR_draco_mesh_compression payloads and the JSON around them.

use super::*;

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
        let edits = broken_extension_edits(pos, idx);
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

/// Broken extension objects and accessors of the Draco grid, whose
/// positions and indices are accessors `pos` and `idx`; each edit must be
/// refused.
fn broken_extension_edits(pos: usize, idx: usize) -> Vec<(&'static str, Box<Edit>)> {
    let ext = "/meshes/0/primitives/0/extensions/KHR_draco_mesh_compression";
    vec![
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
    ]
}
