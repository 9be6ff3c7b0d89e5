//! The `soupray bvh` and `soupray devices` commands as a user runs them: the
//! real binary, its JSON, its errors and exit codes.

mod common;

use common::{mesh_arg, soupray};
use std::path::Path;

#[test]
fn bvh_json_reports_a_valid_tree_for_every_builder() {
    let mut costs = Vec::new();
    let Some(input) = mesh_arg("beast.ply") else {
        return;
    };
    for builder in ["device", "cpu-binned", "cpu-sweep"] {
        let out = soupray(&["bvh", &input, "--json", "--builder", builder]);
        assert!(
            out.status.success(),
            "{builder}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let v: serde_json::Value = serde_json::from_slice(&out.stdout).expect("one JSON object");
        assert_eq!(v["triangles"], 64618, "{builder}");
        assert_eq!(v["valid"], true, "{builder}");
        assert_eq!(v["builder"], builder);
        for key in ["nodes", "leaves", "max_depth", "sah_cost", "build_ms"] {
            assert!(v[key].is_number(), "{builder}: {key} missing");
        }
        for stage in ["large", "medium", "small"] {
            assert!(
                v["stages_ms"][stage].is_number(),
                "{builder}: stages_ms.{stage}"
            );
        }
        let leaves = v["leaves"].as_u64().unwrap();
        assert!(
            leaves >= 64618 / 4,
            "{builder}: {leaves} leaves cannot hold 64618 triangles in 4s"
        );
        costs.push(v["sah_cost"].as_f64().unwrap());
    }
    assert_eq!(
        costs[0], costs[1],
        "device and CPU binned builds are the same tree"
    );
    assert!(
        costs[2] <= costs[0],
        "the full sweep is the quality reference"
    );
    // The device build of a 65K mesh spends time in the medium and small stages.
    let out = soupray(&["bvh", &input, "--json"]);
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert!(v["stages_ms"]["medium"].as_f64().unwrap() > 0.0);
    assert!(v["stages_ms"]["small"].as_f64().unwrap() > 0.0);
}

#[test]
fn bins_and_leaf_size_change_the_tree() {
    let Some(input) = mesh_arg("beast.ply") else {
        return;
    };
    let out = soupray(&["bvh", &input, "--json", "--leaf", "1", "--bins", "8"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["leaves"], 64618, "leaves of one triangle");
    assert_eq!(v["bins"], 8);
}

#[test]
fn bad_input_gives_a_clear_error_and_exit_code() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("missing.ply");
    let out = soupray(&["bvh", missing.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(4));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("missing.ply") && err.contains("cannot read"),
        "{err}"
    );

    let quad = dir.path().join("quad.ply");
    std::fs::write(
        &quad,
        "ply\nformat ascii 1.0\nelement vertex 4\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\n1 0 0\n1 1 0\n0 1 0\n4 0 1 2 3\n",
    )
    .unwrap();
    let out = soupray(&["bvh", quad.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(4));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("quad.ply") && err.contains("face 0"), "{err}");

    let nan = dir.path().join("nan.ply");
    std::fs::write(
        &nan,
        "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\n\
         property float z\nelement face 1\nproperty list uchar int vertex_indices\nend_header\n\
         0 0 0\n1 inf 0\n0 1 0\n3 0 1 2\n",
    )
    .unwrap();
    let out = soupray(&["bvh", nan.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(4));
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("nan.ply") && err.contains("vertex 1") && err.contains("not finite"),
        "{err}"
    );

    // The scanned mesh is read in place from the shared folder.
    let Some(beast_ply) = mesh_arg("beast.ply") else {
        return;
    };
    let out = soupray(&["bvh", &beast_ply, "--bins", "12"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("power of two"));

    let out = soupray(&["bvh", &beast_ply, "--device", "no-such-device-xyz"]);
    assert_eq!(out.status.code(), Some(3));
    assert!(String::from_utf8_lossy(&out.stderr).contains("soupray devices"));
}

#[test]
fn devices_lists_the_default_device() {
    let out = soupray(&["devices", "--json"]);
    assert!(out.status.success());
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let list = v.as_array().expect("a list");
    assert!(!list.is_empty());
    assert_eq!(list[0]["index"], 0);
    assert!(list[0]["name"].as_str().is_some_and(|n| !n.is_empty()));
    // What a device check records: the driver and the rounding it offers.
    assert!(list[0]["driver"].as_str().is_some_and(|n| !n.is_empty()));
    assert!(list[0]["correctly_rounded_divide_sqrt"].is_boolean());
    let text = soupray(&["devices"]);
    assert!(String::from_utf8_lossy(&text.stdout).contains("--device"));
}

#[test]
fn bvh_builds_a_gltf_frame() {
    let Some(scene) = common::shared::sample("CesiumMan/CesiumMan.gltf") else {
        return;
    };
    if !Path::new(&scene).exists() {
        panic!("missing test asset {}", scene.display());
    }
    let out = soupray(&["bvh", scene.to_str().unwrap(), "--frame", "10", "--json"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(v["triangles"], 4672);
    assert_eq!(v["valid"], true);
}

#[test]
fn bvh_copies_builds_the_benchmark_arrangement() {
    let Some(beast_ply) = mesh_arg("beast.ply") else {
        return;
    };
    let one = soupray(&["bvh", &beast_ply, "--json"]);
    let three = soupray(&["bvh", &beast_ply, "--copies", "3", "--json"]);
    assert!(
        three.status.success(),
        "{}",
        String::from_utf8_lossy(&three.stderr)
    );
    let one: serde_json::Value = serde_json::from_slice(&one.stdout).unwrap();
    let three: serde_json::Value = serde_json::from_slice(&three.stdout).unwrap();
    assert_eq!(
        three["triangles"].as_u64().unwrap(),
        3 * one["triangles"].as_u64().unwrap()
    );
    assert_eq!(three["valid"], true);
    assert!(three["mapping"].is_string(), "{three}");
    let Some(scene) = common::shared::sample("CesiumMan/CesiumMan.gltf") else {
        return;
    };
    let out = soupray(&["bvh", scene.to_str().unwrap(), "--copies", "2"]);
    assert_eq!(out.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&out.stderr).contains("--copies"));
}
