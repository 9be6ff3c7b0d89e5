//! `soupray render` as farm jobs run it: the real binary in a temporary
//! directory. Frames split over runs give the same files, a killed run
//! leaves no truncated frame and resumes, and every exit code comes from
//! its own cause.

mod common;

use common::soupray;
use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// A small, untextured, animated scene, rendered tiny so the tests are quick.
/// Read in place from the shared folder; `None` (the caller skips) when it
/// is absent.
fn scene() -> Option<String> {
    common::asset_arg("BoxAnimated/BoxAnimated.glb")
}

const SMALL: &[&str] = &["--width", "48", "--height", "27", "--spp", "2"];

fn render(out: &Path, extra: &[&str]) -> Option<Output> {
    let scene = scene()?;
    let mut args = vec!["render", scene.as_str(), "--out", out.to_str().unwrap()];
    args.extend_from_slice(SMALL);
    args.extend_from_slice(extra);
    Some(soupray(&args))
}

fn files(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default();
    names.sort();
    names
}

fn exr_pixels(path: &Path) -> Vec<(String, Vec<f32>)> {
    let image = exr::prelude::read_all_flat_layers_from_file(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let layer = &image.layer_data[0];
    layer
        .channel_data
        .list
        .iter()
        .map(|c| {
            let values: Vec<f32> = c.sample_data.values_as_f32().collect();
            (c.name.to_string(), values)
        })
        .collect()
}

/// A frame log with the fields that legitimately differ between runs
/// (timings, throughput, output paths) removed.
fn stable_log(path: &Path) -> serde_json::Value {
    let mut v: serde_json::Value = serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap();
    let obj = v.as_object_mut().unwrap();
    obj.remove("timings_ms");
    obj.remove("output");
    // The process's peak memory is a measurement, like the timings.
    obj["memory"]
        .as_object_mut()
        .unwrap()
        .remove("peak_resident_bytes");
    obj["build"].as_object_mut().unwrap().remove("stages_ms");
    obj["render"].as_object_mut().unwrap().remove("mrays_per_s");
    v
}

/// A run reuses a written frame's buffers for a later frame's image; with
/// every pass and a shadow catcher, each frame's files are still those of a
/// run that renders it alone.
#[test]
fn frames_with_every_pass_split_over_runs_give_identical_files() {
    let walker = common::repo_file("animations/walker/walker.glb");
    let walker = walker.to_str().unwrap();
    let every_pass: Vec<&str> = ["--width", "64", "--height", "36", "--spp", "2"]
        .into_iter()
        .chain(common::passes::EVERY_PASS)
        .chain(["--shadow-catcher", "ground"])
        .collect();
    let run = |out: &Path, frames: &str| {
        let mut args = vec!["render", walker, "--quiet", "--frames", frames];
        args.extend_from_slice(&every_pass);
        args.extend_from_slice(&["--out", out.to_str().unwrap()]);
        let done = soupray(&args);
        assert!(
            done.status.success(),
            "{}",
            String::from_utf8_lossy(&done.stderr)
        );
    };
    let (one, two) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    run(one.path(), "0-9:3");
    for frame in ["0", "3", "6", "9"] {
        run(two.path(), frame);
    }
    for frame in [0, 3, 6, 9] {
        let name = format!("walker.{frame:04}.exr");
        let a = std::fs::read(one.path().join(&name)).unwrap();
        let b = std::fs::read(two.path().join(&name)).unwrap();
        assert!(
            a == b,
            "{name}: the job's file differs from the frame's own run"
        );
    }
}

#[test]
fn frames_split_over_runs_give_identical_files() {
    let one = tempfile::tempdir().unwrap();
    let two = tempfile::tempdir().unwrap();
    let Some(out) = render(one.path(), &["--frames", "0-5"]) else {
        return;
    };
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for spec in ["0-2", "3-5"] {
        let Some(out) = render(two.path(), &["--frames", spec]) else {
            return;
        };
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
    }
    let names = files(one.path());
    assert_eq!(names, files(two.path()));
    let exrs: Vec<&String> = names.iter().filter(|n| n.ends_with(".exr")).collect();
    assert_eq!(exrs.len(), 6, "{names:?}");
    assert!(names.iter().any(|n| n == "BoxAnimated.0000.exr"));
    assert!(names.iter().any(|n| n == "BoxAnimated.0005.json"));
    for name in &names {
        let (a, b) = (one.path().join(name), two.path().join(name));
        if name.ends_with(".exr") {
            assert_eq!(exr_pixels(&a), exr_pixels(&b), "{name}: pixels differ");
        } else if name.ends_with(".json") {
            assert_eq!(stable_log(&a), stable_log(&b), "{name}: logs differ");
        }
    }
    // The log carries what a farm needs.
    let log: serde_json::Value =
        serde_json::from_slice(&std::fs::read(one.path().join("BoxAnimated.0003.json")).unwrap())
            .unwrap();
    assert_eq!(log["frame"], 3);
    assert!((log["time"].as_f64().unwrap() - 3.0 / 24.0).abs() < 1e-9);
    assert_eq!(log["triangles"], 254);
    for key in ["evaluate", "build", "trace", "write", "total"] {
        assert!(
            log["timings_ms"][key].as_f64().unwrap() >= 0.0,
            "timings_ms.{key}"
        );
    }
    for key in ["large", "medium", "small"] {
        assert!(
            log["build"]["stages_ms"][key].is_number(),
            "build.stages_ms.{key}"
        );
    }
    assert_eq!(log["build"]["leaf_size"], 4);
    assert_eq!(log["render"]["width"], 48);
    assert_eq!(log["render"]["spp"], 2);
    assert_eq!(log["render"]["traversal"], "wide8", "the default traversal");
    assert!(log["render"]["rays"].as_u64().unwrap() >= 48 * 27 * 2);
    assert!(log["camera"]["position"].is_array());
    assert!(log["warnings"].is_array());

    // Start-up (device, program compilation, the warm-up pass) is reported
    // in the first frame each run renders, apart from that frame's build and
    // trace, and is 0 in the others.
    let timings = |dir: &Path, frame: u32| {
        let log: serde_json::Value = serde_json::from_slice(
            &std::fs::read(dir.join(format!("BoxAnimated.{frame:04}.json"))).unwrap(),
        )
        .unwrap();
        log["timings_ms"].clone()
    };
    for (dir, first) in [(one.path(), 0), (two.path(), 0), (two.path(), 3)] {
        let t = timings(dir, first);
        let startup = t["startup"].as_f64().unwrap();
        assert!(
            startup > 0.0 && startup > t["build"].as_f64().unwrap(),
            "frame {first}: {t}"
        );
    }
    for frame in [1, 2, 4, 5] {
        assert_eq!(timings(one.path(), frame)["startup"], 0.0, "frame {frame}");
    }
}

#[test]
fn a_killed_run_leaves_no_partial_frame_and_resumes() {
    let dir = tempfile::tempdir().unwrap();
    let Some(scene) = scene() else {
        return;
    };
    let mut child = common::soupray_cmd()
        .args(["render", &scene, "--out", dir.path().to_str().unwrap()])
        .args([
            "--width", "160", "--height", "90", "--spp", "8", "--frames", "0-40",
        ])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Kill it once it has written some frames but not all.
    let started = Instant::now();
    loop {
        let done = files(dir.path())
            .iter()
            .filter(|n| n.ends_with(".json"))
            .count();
        if done >= 2 || started.elapsed() > Duration::from_secs(120) {
            break;
        }
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL: no chance to clean up
    child.wait().unwrap();
    let after_kill = files(dir.path());
    assert!(
        after_kill.iter().filter(|n| n.ends_with(".json")).count() < 41,
        "the run finished before it was killed; the test needs a slower render"
    );
    for name in after_kill.iter().filter(|n| n.ends_with(".exr")) {
        assert!(
            soupray::output::is_complete_exr(&dir.path().join(name)),
            "{name} is truncated under its final name"
        );
    }
    // Resume: the complete frames are skipped, the rest rendered, and
    // stale temporaries of the killed run do not count as frames.
    let out = common::soupray_cmd()
        .args(["render", &scene, "--out", dir.path().to_str().unwrap()])
        .args([
            "--width", "160", "--height", "90", "--spp", "8", "--frames", "0-40",
        ])
        .arg("--skip-existing")
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("skipped"), "{stderr}");
    let names = files(dir.path());
    let exrs = names.iter().filter(|n| n.ends_with(".exr")).count();
    assert_eq!(exrs, 41, "{names:?}");
    assert!(
        !names.iter().any(|n| n.ends_with(".tmp")),
        "the killed run's temporaries were not cleaned: {names:?}"
    );
    for name in names.iter().filter(|n| n.ends_with(".exr")) {
        assert!(
            soupray::output::is_complete_exr(&dir.path().join(name)),
            "{name}"
        );
    }
}

#[test]
fn exr_compression_is_chosen_logged_and_keeps_the_pixels() {
    // The same frame with ZIP (the default), RLE and ZIP at zlib's level 1:
    // the same pixels in every channel, the log naming the compression; an
    // unknown one, or a level where none is taken or out of range, is a
    // usage error naming the choices.
    let (zip, rle) = (tempfile::tempdir().unwrap(), tempfile::tempdir().unwrap());
    let zip1 = tempfile::tempdir().unwrap();
    let Some(out) = render(zip.path(), &["--frame", "0"]) else {
        return;
    };
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = render(rle.path(), &["--frame", "0", "--exr-compression", "rle"]).unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let exr = |dir: &Path| {
        let name = files(dir)
            .into_iter()
            .find(|n| n.ends_with(".exr"))
            .unwrap();
        dir.join(name)
    };
    let out = render(zip1.path(), &["--frame", "0", "--exr-compression", "zip:1"]).unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert_eq!(exr_pixels(&exr(zip.path())), exr_pixels(&exr(rle.path())));
    assert_eq!(exr_pixels(&exr(zip.path())), exr_pixels(&exr(zip1.path())));
    let log = |dir: &Path| {
        let name = files(dir)
            .into_iter()
            .find(|n| n.ends_with(".json"))
            .unwrap();
        let text = std::fs::read_to_string(dir.join(name)).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        v["output"]["compression"].as_str().unwrap().to_owned()
    };
    assert_eq!(
        (log(zip.path()), log(rle.path()), log(zip1.path())),
        ("zip".into(), "rle".into(), "zip:1".into())
    );
    for (given, message) in [
        (
            "lz4",
            "--exr-compression \"lz4\": use one of zip, zips, piz, rle, none (or zip:N",
        ),
        (
            "rle:3",
            "--exr-compression \"rle:3\": only zip and zips take a level",
        ),
        (
            "zip:0",
            "--exr-compression \"zip:0\": zlib's level is a whole number from 1",
        ),
    ] {
        let out = render(rle.path(), &["--frame", "0", "--exr-compression", given]).unwrap();
        assert_eq!(out.status.code(), Some(2), "{given}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(message), "{given}: {err}");
    }
}

#[test]
fn exit_codes_come_from_their_causes() {
    let dir = tempfile::tempdir().unwrap();
    // 2: usage.
    for spec in ["5-2", "a-b", ""] {
        let Some(out) = render(dir.path(), &["--frames", spec]) else {
            return;
        };
        assert_eq!(out.status.code(), Some(2), "--frames {spec:?}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("--frames") || err.contains("frame"), "{err}");
    }
    // 3: device set-up.
    let Some(out) = render(
        dir.path(),
        &["--device", "no-such-device-xyz", "--frame", "0"],
    ) else {
        return;
    };
    assert_eq!(
        out.status.code(),
        Some(3),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // 4: the scene cannot be read.
    let missing = dir.path().join("missing.glb");
    let out = soupray(&["render", missing.to_str().unwrap(), "--frame", "0"]);
    assert_eq!(out.status.code(), Some(4));
    assert!(String::from_utf8_lossy(&out.stderr).contains("missing.glb"));
    // 5: a frame fails (its EXR name is taken by a directory), and
    // --keep-going still renders the others.
    let frames = dir.path().join("frames");
    std::fs::create_dir_all(frames.join("BoxAnimated.0001.exr")).unwrap();
    let Some(out) = render(&frames, &["--frames", "0-2", "--keep-going"]) else {
        return;
    };
    assert_eq!(
        out.status.code(),
        Some(5),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("frame 1"), "{err}");
    assert!(frames.join("BoxAnimated.0000.exr").is_file());
    assert!(frames.join("BoxAnimated.0002.exr").is_file());
    // 6: the output directory cannot be made, before anything renders.
    let file = dir.path().join("a-file");
    std::fs::write(&file, "").unwrap();
    let Some(out) = render(&file.join("sub"), &["--frame", "0"]) else {
        return;
    };
    assert_eq!(
        out.status.code(),
        Some(6),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[cfg(unix)]
#[test]
fn sigint_and_sigterm_stop_cleanly() {
    for (signal, code) in [("INT", 130), ("TERM", 143)] {
        let dir = tempfile::tempdir().unwrap();
        let Some(scene) = scene() else {
            return;
        };
        let child = common::soupray_cmd()
            .args(["render", &scene, "--out", dir.path().to_str().unwrap()])
            .args([
                "--width", "160", "--height", "90", "--spp", "8", "--frames", "0-100",
            ])
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let started = Instant::now();
        while !files(dir.path()).iter().any(|n| n.ends_with(".json"))
            && started.elapsed() < Duration::from_secs(120)
        {
            std::thread::sleep(Duration::from_millis(20));
        }
        let status = Command::new("kill")
            .args([&format!("-{signal}"), &child.id().to_string()])
            .status()
            .unwrap();
        assert!(status.success());
        let out = child.wait_with_output().unwrap();
        assert_eq!(out.status.code(), Some(code), "SIG{signal}");
        let names = files(dir.path());
        assert!(
            !names.iter().any(|n| n.ends_with(".tmp")),
            "SIG{signal} left temporaries: {names:?}"
        );
        assert!(names.iter().filter(|n| n.ends_with(".exr")).count() < 101);
        for name in names.iter().filter(|n| n.ends_with(".exr")) {
            assert!(soupray::output::is_complete_exr(&dir.path().join(name)));
        }
    }
}

#[test]
fn the_default_animation_is_shipped_with_its_license() {
    // The project's own walker (tests/shipped_animation.rs checks that it is
    // the generator's output); animations/README.md gives its licence.
    let dir = common::repo_file("animations");
    assert!(dir.join("walker/walker.glb").is_file());
    assert!(dir.join("README.md").is_file());
}
