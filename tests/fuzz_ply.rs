//! A time-bounded, fixed-seed structured mutation fuzz of the PLY reader
//! (`soupray bvh` input): header lies (counts, types, formats), damaged
//! bodies and truncation. Each case reads a soup or fails with an error
//! naming the file; none panics or allocates from a count alone. All files
//! live in a temporary directory.

mod common;

use common::XorshiftStar;
use std::time::{Duration, Instant};

fn base(binary: bool) -> Vec<u8> {
    let verts: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [0.0, 0.0, 1.0],
    ];
    let faces: [[u32; 3]; 4] = [[0, 1, 2], [0, 1, 3], [0, 2, 3], [1, 2, 3]];
    let mut out = format!(
        "ply\nformat {} 1.0\ncomment fuzz\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nproperty uchar red\nelement face 4\nproperty list uchar int vertex_indices\n\
         element extra 1\nproperty double w\nend_header\n",
        if binary { "binary_little_endian" } else { "ascii" }
    )
    .into_bytes();
    if binary {
        for v in verts {
            for c in v {
                out.extend_from_slice(&c.to_le_bytes());
            }
            out.push(200);
        }
        for f in faces {
            out.push(3);
            for i in f {
                out.extend_from_slice(&(i as i32).to_le_bytes());
            }
        }
        out.extend_from_slice(&1.5f64.to_le_bytes());
    } else {
        for v in verts {
            out.extend_from_slice(format!("{} {} {} 200\n", v[0], v[1], v[2]).as_bytes());
        }
        for f in faces {
            out.extend_from_slice(format!("3 {} {} {}\n", f[0], f[1], f[2]).as_bytes());
        }
        out.extend_from_slice(b"1.5\n");
    }
    out
}

/// Replaces one header word with a hostile one.
fn mutate_header(bytes: &[u8], rng: &mut XorshiftStar) -> Vec<u8> {
    let end = bytes
        .windows(11)
        .position(|w| w == b"end_header\n")
        .map_or(bytes.len(), |p| p + 11);
    let header = String::from_utf8_lossy(&bytes[..end]).into_owned();
    let mut words: Vec<String> = header.split(' ').map(str::to_owned).collect();
    let hostile = [
        "0",
        "-1",
        "4294967295",
        "18446744073709551615",
        "99999999999999999999",
        "1e9",
        "nan",
        "char",
        "uchar",
        "short",
        "ushort",
        "int",
        "uint",
        "float",
        "double",
        "int8",
        "float64",
        "list",
        "vertex",
        "face",
        "binary_big_endian",
        "ascii",
        "binary_little_endian",
        "\n",
        "",
        "x",
    ];
    let at = rng.below(words.len());
    let keep_newline = words[at].ends_with('\n');
    words[at] = hostile[rng.below(hostile.len())].to_owned();
    if keep_newline && !words[at].ends_with('\n') {
        words[at].push('\n');
    }
    let mut out = words.join(" ").into_bytes();
    out.extend_from_slice(&bytes[end..]);
    out
}

#[test]
fn ply_mutation_fuzz() {
    let seed: u64 = std::env::var("SOUPRAY_FUZZ_SEED")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(0x9e37_79b9_7f4a_7c15);
    let secs: u64 = std::env::var("SOUPRAY_FUZZ_SECS")
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(30)
        .min(15);
    let deadline = Instant::now() + Duration::from_secs(secs);
    let dir = tempfile::tempdir().unwrap();
    let mut rng = XorshiftStar(seed);
    let (mut cases, mut ok, mut refused) = (0usize, 0usize, 0usize);
    let mut failures = Vec::new();
    while Instant::now() < deadline && cases < 200_000 {
        let mut bytes = base(rng.below(2) == 0);
        for _ in 0..1 + rng.below(3) {
            match rng.below(4) {
                0 | 1 => bytes = mutate_header(&bytes, &mut rng),
                2 if !bytes.is_empty() => {
                    let at = rng.below(bytes.len());
                    bytes[at] = rng.next() as u8;
                }
                _ => bytes.truncate(rng.below(bytes.len() + 1)),
            }
        }
        let path = dir.path().join(format!("case{cases}.ply"));
        std::fs::write(&path, &bytes).unwrap();
        match std::panic::catch_unwind(|| soupray::ply::read_soup(&path)) {
            Ok(Ok(_)) => ok += 1,
            Ok(Err(e)) if e.to_string().contains(&format!("case{cases}.ply")) => refused += 1,
            Ok(Err(e)) => failures.push(format!("case {cases}: error without the file: {e}")),
            Err(_) => failures.push(format!(
                "case {cases}: panicked on {:?}",
                String::from_utf8_lossy(&bytes[..bytes.len().min(300)])
            )),
        }
        let _ = std::fs::remove_file(&path);
        cases += 1;
    }
    eprintln!(
        "ply fuzz: seed {seed}, {cases} cases: {ok} read, {refused} refused cleanly, {} failed",
        failures.len()
    );
    assert!(cases >= 50);
    assert!(failures.is_empty(), "seed {seed}:\n{}", failures.join("\n"));
}
