//! The binary on hostile paths: inputs that are not regular files, outputs
//! that must not be replaced, and the README's exit code for each command.
//!
//! Every path written to lies in a temporary directory. Device nodes are
//! made there (with mknod, where allowed) rather than pointing `-o` at
//! `/dev`; `/dev/null`, `/dev/zero` and `/proc/self/mem` appear only as
//! inputs, which soupray opens read-only.

use std::os::unix::fs::FileTypeExt;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

mod common;
use common::{asset_arg, shared, soupray};

fn corpus(name: &str) -> String {
    common::fuzz_corpus().join(name).display().to_string()
}

fn mkfifo(path: &Path) {
    let c = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    assert_eq!(unsafe { libc::mkfifo(c.as_ptr(), 0o600) }, 0);
}

/// A character device node like /dev/null (1, 3), inside `dir`; `None`
/// where the test may not make device nodes.
fn mknod_null(path: &Path) -> Option<()> {
    let c = std::ffi::CString::new(path.to_str().unwrap()).unwrap();
    // SAFETY: a valid NUL-terminated path.
    let rc = unsafe { libc::mknod(c.as_ptr(), libc::S_IFCHR | 0o666, libc::makedev(1, 3)) };
    (rc == 0).then_some(())
}

#[track_caller]
fn assert_exit(out: &Output, code: i32, mentions: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(code), "stderr: {err}");
    for m in mentions {
        assert!(err.contains(m), "stderr lacks {m:?}: {err}");
    }
    assert!(!err.contains("panicked"), "{err}");
}

fn tmp_path(dir: &tempfile::TempDir, name: &str) -> (PathBuf, String) {
    let p = dir.path().join(name);
    let s = p.display().to_string();
    (p, s)
}

#[test]
fn soup_refuses_to_replace_a_fifo_directory_symlink_or_device() {
    let dir = tempfile::tempdir().unwrap();

    let (fifo, fifo_s) = tmp_path(&dir, "out.fifo");
    mkfifo(&fifo);
    let Some(scene) = asset_arg("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    let out = soupray(&["soup", &scene, "--frame", "0", "-o", &fifo_s]);
    assert_exit(&out, 6, &["out.fifo", "FIFO", "never replaces"]);
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());

    let (sub, sub_s) = tmp_path(&dir, "adir");
    std::fs::create_dir(&sub).unwrap();
    std::fs::write(sub.join("keep"), "x").unwrap();
    let out = soupray(&["soup", &scene, "--frame", "0", "-o", &sub_s]);
    assert_exit(&out, 6, &["adir", "directory"]);
    assert_eq!(std::fs::read_to_string(sub.join("keep")).unwrap(), "x");

    let (target, _) = tmp_path(&dir, "target.ply");
    std::fs::write(&target, "mine").unwrap();
    let (link, link_s) = tmp_path(&dir, "link.ply");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    let out = soupray(&["soup", &scene, "--frame", "0", "-o", &link_s]);
    assert_exit(&out, 6, &["link.ply", "symbolic link"]);
    assert!(std::fs::symlink_metadata(&link)
        .unwrap()
        .file_type()
        .is_symlink());
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "mine");

    let (node, node_s) = tmp_path(&dir, "null");
    if mknod_null(&node).is_some() {
        let out = soupray(&["soup", &scene, "--frame", "0", "-o", &node_s]);
        assert_exit(&out, 6, &["character device"]);
        assert!(std::fs::symlink_metadata(&node)
            .unwrap()
            .file_type()
            .is_char_device());
    }
    // Nothing but the nodes made above is left behind (no temporaries).
    let mut names: Vec<String> = std::fs::read_dir(dir.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    names.retain(|n| n != "null");
    assert_eq!(names, ["adir", "link.ply", "out.fifo", "target.ply"]);
}

#[test]
fn soup_exit_codes() {
    let dir = tempfile::tempdir().unwrap();
    let (ply, ply_s) = tmp_path(&dir, "box.ply");
    let Some(scene) = asset_arg("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    assert_exit(
        &soupray(&["soup", &scene, "--frame", "0", "-o", &ply_s]),
        0,
        &[],
    );
    assert!(std::fs::read(&ply).unwrap().starts_with(b"ply\n"));
    // Replacing a regular file is fine.
    assert_exit(
        &soupray(&["soup", &scene, "--frame", "1", "-o", &ply_s]),
        0,
        &[],
    );
    assert_exit(
        &soupray(&["soup", &scene, "--frame", "x", "-o", &ply_s]),
        2,
        &[],
    );
    assert_exit(
        &soupray(&[
            "soup",
            &corpus("mesh_index_2_32.gltf"),
            "-o",
            &ply_s,
            "--frame",
            "0",
        ]),
        4,
        &["mesh_index_2_32.gltf", "4294967296"],
    );
    let (_, missing_dir) = tmp_path(&dir, "no/such/dir/out.ply");
    assert_exit(
        &soupray(&["soup", &scene, "--frame", "0", "-o", &missing_dir]),
        6,
        &["out.ply"],
    );
}

#[test]
fn soup_to_stdout_with_dash() {
    let Some(box_animated_glb) = asset_arg("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    let out = common::soupray_cmd()
        .args(["soup", &box_animated_glb, "--frame", "0", "-o", "-"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert_exit(&out, 0, &["standard output"]);
    assert!(out
        .stdout
        .starts_with(b"ply\nformat binary_little_endian 1.0\n"));
    assert!(!Path::new("-").exists());
}

#[test]
fn inputs_that_are_not_regular_files_are_refused_quickly() {
    let dir = tempfile::tempdir().unwrap();
    let (fifo, fifo_s) = tmp_path(&dir, "scene.glb");
    mkfifo(&fifo);
    let started = Instant::now();
    for cmd in ["info", "render", "bvh"] {
        let out = soupray(&[cmd, &fifo_s]);
        assert_exit(&out, 4, &["scene.glb", "FIFO"]);
    }
    for input in ["/dev/zero", "/dev/null", "/"] {
        assert_exit(&soupray(&["info", input]), 4, &[input]);
    }
    // The /dev/zero buffer of the corpus, through the binary.
    assert_exit(
        &soupray(&["info", &corpus("buffer_uri_dev_zero.gltf")]),
        4,
        &["/dev/zero", "character device"],
    );
    assert!(started.elapsed() < Duration::from_secs(60));
}

#[test]
fn bvh_exit_codes() {
    let dir = tempfile::tempdir().unwrap();
    for input in ["/dev/null", "/proc/self/mem"] {
        assert_exit(
            &soupray(&["bvh", input, "--builder", "cpu-binned"]),
            4,
            &[input],
        );
    }
    let (noext, noext_s) = tmp_path(&dir, "mesh");
    std::fs::write(&noext, b"\x00\x01garbage").unwrap();
    assert_exit(
        &soupray(&["bvh", &noext_s, "--builder", "cpu-binned"]),
        4,
        &["mesh", "unknown input type"],
    );
    // Without an extension, a PLY is recognised by its content (a scanned
    // mesh from the shared folder; only this part skips without it).
    if let Some(some_ply) = shared::mesh_path("beast.ply") {
        std::fs::copy(&some_ply, &noext).unwrap();
        assert_exit(
            &soupray(&["bvh", &noext_s, "--builder", "cpu-binned"]),
            0,
            &[],
        );
        assert_exit(&soupray(&["bvh", &noext_s, "--bins", "0"]), 2, &[]);
    }
    let (fifo, fifo_s) = tmp_path(&dir, "m.ply");
    mkfifo(&fifo);
    assert_exit(
        &soupray(&["bvh", &fifo_s, "--builder", "cpu-binned"]),
        4,
        &["m.ply", "FIFO"],
    );
}

#[test]
fn info_exit_codes() {
    let Some(box_animated_glb) = asset_arg("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    assert_exit(&soupray(&["info", &box_animated_glb]), 0, &[]);
    assert_exit(&soupray(&["info"]), 2, &[]);
    assert_exit(
        &soupray(&["info", &corpus("anim_target_node_out_of_range.gltf")]),
        4,
        &["anim_target_node_out_of_range.gltf", "target.node"],
    );
    // An unknown animation path is a warning, not an error.
    let out = soupray(&["info", &corpus("anim_path_unknown.gltf")]);
    assert_exit(&out, 0, &[]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("\"colour\""));
    // A KHR_animation_pointer channel to a node's rotation is read: two
    // channels, no warning.
    let out = soupray(&["info", &corpus("anim_path_pointer.gltf")]);
    assert_exit(&out, 0, &[]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(stdout.contains("2 channels"), "{stdout}");
    assert!(!stdout.contains("skipped"), "{stdout}");
}

#[test]
fn report_exit_codes() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().display().to_string();
    // No logs: an input error, and it says what is missing.
    assert_exit(&soupray(&["report", &d]), 4, &["no per-frame logs"]);
    let (_, missing) = tmp_path(&dir, "missing");
    assert_exit(
        &soupray(&["report", &missing]),
        4,
        &["cannot read the directory"],
    );
    assert_exit(&soupray(&["report"]), 2, &[]);
    // A non-UTF-8 log is skipped as not a log, not blamed on disk space.
    std::fs::write(dir.path().join("walk.0001.json"), b"{\"frame\": \xff}").unwrap();
    let out = soupray(&["report", &d]);
    assert_exit(&out, 4, &["not UTF-8"]);
    assert!(!String::from_utf8_lossy(&out.stderr).contains("space"));
    // With a real log: 0; its CSV going to a FIFO: 6, the FIFO untouched.
    let mut log = soupray::output::FrameLog::new();
    log.frame = 1;
    log.timings_ms.total = 5.0;
    soupray::output::write_log(&dir.path().join("walk.0002.json"), &log).unwrap();
    assert_exit(&soupray(&["report", &d, "--no-files"]), 0, &[]);
    let (fifo, fifo_s) = tmp_path(&dir, "r.csv");
    mkfifo(&fifo);
    assert_exit(
        &soupray(&["report", &d, "--csv", &fifo_s]),
        6,
        &["r.csv", "FIFO"],
    );
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
}

#[test]
fn render_env_that_cannot_be_read_is_an_input_error() {
    let dir = tempfile::tempdir().unwrap();
    let (out_dir, out_s) = tmp_path(&dir, "out");
    let (_, missing) = tmp_path(&dir, "missing.exr");
    let (fifo, fifo_s) = tmp_path(&dir, "sky.exr");
    mkfifo(&fifo);
    let (garbage, garbage_s) = tmp_path(&dir, "garbage.exr");
    std::fs::write(&garbage, "not an exr").unwrap();
    let Some(scene) = asset_arg("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    for (env, word) in [
        (&missing, "missing.exr"),
        (&fifo_s, "FIFO"),
        (&garbage_s, "OpenEXR"),
    ] {
        let out = soupray(&[
            "render", &scene, "--frame", "0", "--env", env, "--out", &out_s,
        ]);
        assert_exit(&out, 4, &["--env", word]);
    }
    // Nothing was rendered.
    let frames = std::fs::read_dir(&out_dir)
        .map(|d| {
            d.filter(|e| {
                e.as_ref()
                    .unwrap()
                    .path()
                    .extension()
                    .is_some_and(|x| x == "exr")
            })
            .count()
        })
        .unwrap_or(0);
    assert_eq!(frames, 0);
}

/// Sends SIGTERM to `child` and checks that it exits with 143 (128 +
/// SIGTERM), as a shell reports a job the signal ended.
fn terminate(child: std::process::Child) {
    let status = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(status.success());
    let out = child.wait_with_output().unwrap();
    assert_eq!(
        out.status.code(),
        Some(143),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn sigterm_during_set_up_ends_the_render() {
    let dir = tempfile::tempdir().unwrap();
    let Some(fox_glb) = asset_arg("Fox/Fox.glb") else {
        return;
    };
    let child = common::soupray_cmd()
        .args(["render", &fox_glb, "--out", dir.path().to_str().unwrap()])
        .args([
            "--width", "64", "--height", "36", "--spp", "1", "--frames", "0-1000",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(300));
    let started = Instant::now();
    terminate(child);
    assert!(started.elapsed() < Duration::from_secs(60));
    let temporaries = std::fs::read_dir(dir.path())
        .unwrap()
        .filter(|e| {
            e.as_ref()
                .unwrap()
                .file_name()
                .to_string_lossy()
                .ends_with(".tmp")
        })
        .count();
    assert_eq!(temporaries, 0);
}

#[test]
fn clamped_values_are_warned_about_in_the_frame_log() {
    let dir = tempfile::tempdir().unwrap();
    let out_s = dir.path().display().to_string();
    for (case, mentions) in [
        ("camera_yfov_negative", &["camera 0", "yfov -0.5"][..]),
        ("spot_cones_reversed", &["light 0", "swapped"][..]),
    ] {
        let out = soupray(&[
            "render",
            &corpus(&format!("{case}.gltf")),
            "--frame",
            "0",
            "--width",
            "32",
            "--height",
            "18",
            "--spp",
            "1",
            "--out",
            &out_s,
        ]);
        assert_exit(&out, 0, mentions);
        let log: serde_json::Value = serde_json::from_str(
            &std::fs::read_to_string(dir.path().join(format!("{case}.0000.json"))).unwrap(),
        )
        .unwrap();
        let warnings = log["warnings"].to_string();
        for m in mentions {
            assert!(
                warnings.contains(m),
                "{case}: log warnings lack {m:?}: {warnings}"
            );
        }
    }
}

#[test]
fn skip_existing_does_not_block_on_a_fifo_under_a_frame_name() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("BoxAnimated.0000.exr");
    mkfifo(&fifo);
    let started = Instant::now();
    let Some(box_animated_glb) = asset_arg("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    let out = soupray(&[
        "render",
        &box_animated_glb,
        "--frame",
        "0",
        "--width",
        "16",
        "--height",
        "16",
        "--spp",
        "1",
        "--skip-existing",
        "--out",
        dir.path().to_str().unwrap(),
    ]);
    // The frame cannot be written over the FIFO: a failed frame, not a hang.
    assert_exit(&out, 5, &["FIFO"]);
    assert!(std::fs::symlink_metadata(&fifo)
        .unwrap()
        .file_type()
        .is_fifo());
    assert!(started.elapsed() < Duration::from_secs(120));
}

#[test]
fn sigterm_while_loading_a_large_scene_exits_at_once() {
    use std::fmt::Write as _;
    // 800,000 nodes: a valid file that takes about a second to load.
    let n = 800_000;
    let mut json = String::from(r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":["#);
    for i in 0..n {
        let _ = write!(json, "{}{i}", if i > 0 { "," } else { "" });
    }
    json.push_str(r#"]}],"nodes":["#);
    for i in 0..n {
        let _ = write!(
            json,
            "{}{{\"translation\":[{i},0,0]}}",
            if i > 0 { "," } else { "" }
        );
    }
    json.push_str("]}");
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("big.gltf");
    std::fs::write(&scene, json).unwrap();
    let out_dir = dir.path().join("out");
    let child = common::soupray_cmd()
        .args([
            "render",
            scene.to_str().unwrap(),
            "--out",
            out_dir.to_str().unwrap(),
        ])
        .args([
            "--frame", "0", "--width", "16", "--height", "16", "--spp", "1",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(150));
    terminate(child);
    // The output directory is made right after loading: it does not exist,
    // so the signal ended the load itself (before, it was only recorded).
    assert!(!out_dir.exists(), "the load finished before the signal");
}

#[test]
fn an_unknown_adaptive_allocation_is_a_usage_error() {
    let Some(box_animated_glb) = asset_arg("BoxAnimated/BoxAnimated.glb") else {
        return;
    };
    assert_exit(
        &soupray(&[
            "render",
            &box_animated_glb,
            "--noise-threshold",
            "0.05",
            "--adaptive-allocation",
            "fastest",
        ]),
        2,
        &["--adaptive-allocation", "fastest", "time", "error"],
    );
}
