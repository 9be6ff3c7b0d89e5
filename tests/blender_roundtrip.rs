//! Blender 5's glTF exporter against soupray (`scripts/blender-roundtrip.py`):
//! scenes built in Blender and exported with Draco, GPU instancing, vertex
//! colours, two UV sets and WebP give soupray soups that match Blender's
//! own evaluation at several frames. Needs Blender as a Python module
//! (`pip install bpy==5.0.1`, Python 3.11; `SOUPRAY_BPY_PATH` names a
//! `pip install --target` folder) and skips with a message without it.

mod common;

use std::io::Write;
use std::process::Command;

#[test]
fn blender_exports_give_blenders_soup_at_every_frame() {
    let script = common::repo_file("scripts/blender-roundtrip.py");
    let out = tempfile::tempdir().unwrap();
    let mut cmd = Command::new("python3");
    if let Some(p) = std::env::var_os("SOUPRAY_BPY_PATH") {
        cmd.env("PYTHONPATH", p);
    }
    let o = cmd
        .arg(&script)
        .args(["--soupray", common::SOUPRAY])
        .arg(out.path())
        .output()
        .expect("python3 runs");
    let stdout = String::from_utf8_lossy(&o.stdout);
    if o.status.code() == Some(2) {
        let _ = writeln!(
            std::io::stderr(),
            "skipped blender_exports_give_blenders_soup_at_every_frame: {}",
            stdout.trim()
        );
        return;
    }
    let table: Vec<&str> = stdout
        .lines()
        .filter(|l| !l.contains("INFO") && !l.trim().is_empty())
        .collect();
    eprintln!("{}", table.join("\n"));
    assert!(
        o.status.success(),
        "{}\n{}",
        table.join("\n"),
        String::from_utf8_lossy(&o.stderr)
    );
}
