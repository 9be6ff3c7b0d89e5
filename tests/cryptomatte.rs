//! Cryptomatte: two cards seen by an orthographic camera, each matte
//! decoded from the EXR as a compositor does (ids from the header's
//! manifest, coverage summed over the ranks) against the cards' analytic
//! areas; the mattes of every pixel add up to its alpha; and, where Blender
//! 5 is installed as a Python module, its compositor's Cryptomatte node
//! extracts the same matte from soupray's file.

mod common;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use common::scene::Builder;
use serde_json::json;

const SIZE: u32 = 64;
/// Pixels per scene unit: the camera's xmag 1 spans SIZE pixels over 2 units.
const SCALE: f64 = SIZE as f64 / 2.0;
/// The front card (x0, x1, y0, y1) at z = 0 and the back card at z = -0.5,
/// sharing the front card's right edge.
const FRONT: [f32; 4] = [-0.7, 0.05, -0.6, 0.4];
const BACK: [f32; 4] = [0.05, 0.8, -0.3, 0.5];

fn card(b: &mut Builder, r: [f32; 4], z: f32, material: usize) -> serde_json::Value {
    let positions = [r[0], r[2], z, r[1], r[2], z, r[1], r[3], z, r[0], r[3], z];
    let pos = b.floats(&positions, 3);
    let uv = b.floats(&[0.0, 0.0, 1.0, 0.0, 1.0, 1.0, 0.0, 1.0], 2);
    let idx = b.u32s(&[0, 1, 2, 0, 2, 3]);
    json!({"primitives": [{"attributes": {"POSITION": pos, "TEXCOORD_0": uv}, "indices": idx, "material": material}]})
}

/// Two roots, "Set" and "Prop", each with a child named "Card": the
/// objects are told apart by their paths, the assets are the roots.
fn scene(dir: &Path) -> PathBuf {
    let mut b = Builder::default();
    let front = card(&mut b, FRONT, 0.0, 0);
    let back = card(&mut b, BACK, -0.5, 1);
    let lambert = |name: &str, c: [f32; 4]| json!({"name": name, "pbrMetallicRoughness": {"baseColorFactor": c, "metallicFactor": 0.0, "roughnessFactor": 1.0}});
    let root = json!({
        "scene": 0,
        "scenes": [{"nodes": [0, 2, 4]}],
        "nodes": [
            {"name": "Set", "children": [1]},
            {"name": "Card", "mesh": 0},
            {"name": "Prop", "children": [3]},
            {"name": "Card", "mesh": 1},
            {"name": "Camera", "camera": 0, "translation": [0.0, 0.0, 5.0]},
        ],
        "meshes": [front, back],
        "materials": [lambert("Red", [0.8, 0.1, 0.1, 1.0]), lambert("Blue", [0.1, 0.1, 0.8, 1.0])],
        "cameras": [{"type": "orthographic", "orthographic": {"xmag": 1.0, "ymag": 1.0, "znear": 0.1, "zfar": 100.0}}],
    });
    b.write(root, dir, "cards", true)
}

/// Renders the cards at 64 spp under a white sky with every Cryptomatte
/// layer and `extra`; the EXR's path.
fn render(dir: &Path, extra: &[&str]) -> PathBuf {
    let mut args = vec![
        "--spp",
        "64",
        "--env-color",
        "1,1,1",
        "--cryptomatte",
        "object,material,asset",
    ];
    args.extend_from_slice(extra);
    common::render_exr(
        &scene(dir),
        (SIZE, SIZE),
        &dir.join("out"),
        "cards.exr",
        &args,
    )
}

/// A Cryptomatte layer as a compositor reads it: the manifest from the
/// header, the rank channels from the pixels.
struct Decoded {
    manifest: BTreeMap<String, u32>,
    /// Per rank pair k: the R, G, B, A channels of `<layer>0k`.
    ranks: Vec<[Vec<f32>; 4]>,
}

fn decode(exr: &Path, layer: &str) -> Decoded {
    let image = exr::prelude::read_all_flat_layers_from_file(exr).unwrap();
    let attrs = &image.layer_data[0].attributes.other;
    let text = |k: &str| -> Option<String> {
        attrs.iter().find_map(|(name, v)| match v {
            exr::meta::attribute::AttributeValue::Text(t) if *name == *k => {
                Some(String::from_utf8(t.bytes().to_vec()).unwrap())
            }
            _ => None,
        })
    };
    // The key: the first 7 hex digits of the hash of the layer's name,
    // found as the compositor finds it, by the `name` attribute.
    let key = attrs
        .keys()
        .map(|k| k.to_string())
        .filter_map(|k| k.strip_suffix("/name").map(str::to_owned))
        .find(|k| text(&format!("{k}/name")).as_deref() == Some(layer))
        .unwrap_or_else(|| panic!("no cryptomatte/<key>/name = {layer} in the header"));
    assert_eq!(text(&format!("{key}/hash")).unwrap(), "MurmurHash3_32");
    assert_eq!(
        text(&format!("{key}/conversion")).unwrap(),
        "uint32_to_float32"
    );
    let manifest: BTreeMap<String, String> =
        serde_json::from_str(&text(&format!("{key}/manifest")).unwrap()).unwrap();
    let manifest = manifest
        .into_iter()
        .map(|(n, hex)| (n, u32::from_str_radix(&hex, 16).unwrap()))
        .collect();
    let channels = common::exr_channels(exr);
    let ranks = (0..)
        .map_while(|k| {
            let c = |ch: &str| channels.get(&format!("{layer}{k:02}.{ch}")).cloned();
            Some([c("R")?, c("G")?, c("B")?, c("A")?])
        })
        .collect();
    Decoded { manifest, ranks }
}

impl Decoded {
    /// Each pixel's coverage by `name`.
    fn matte(&self, name: &str) -> Vec<f32> {
        let id = self.manifest[name];
        let n = self.ranks[0][0].len();
        (0..n)
            .map(|i| {
                let mut c = 0.0;
                for r in &self.ranks {
                    for (idc, cov) in [(&r[0], &r[1]), (&r[2], &r[3])] {
                        if idc[i].to_bits() == id {
                            c += cov[i];
                        }
                    }
                }
                c
            })
            .collect()
    }

    /// Each pixel's summed coverage over every rank.
    fn total(&self) -> Vec<f32> {
        let n = self.ranks[0][0].len();
        (0..n)
            .map(|i| self.ranks.iter().map(|r| r[1][i] + r[3][i]).sum())
            .collect()
    }
}

fn area_px(r: [f32; 4]) -> f64 {
    (r[1] - r[0]) as f64 * (r[3] - r[2]) as f64 * SCALE * SCALE
}

/// The pixel (column, row) of scene point (x, y).
fn pixel_of(x: f64, y: f64) -> usize {
    let col = ((x + 1.0) * SCALE).floor() as usize;
    let row = ((1.0 - y) * SCALE).floor() as usize;
    row * SIZE as usize + col
}

#[test]
fn each_matte_covers_its_card_and_the_mattes_add_up_to_alpha() {
    let dir = tempfile::tempdir().unwrap();
    let exr = render(dir.path(), &[]);
    let object = decode(&exr, "CryptoObject");
    let material = decode(&exr, "CryptoMaterial");
    let asset = decode(&exr, "CryptoAsset");
    // Depth 6: three rank pairs per layer.
    assert_eq!(object.ranks.len(), 3);
    // Names repeat ("Card" twice), so objects are named by their paths.
    assert_eq!(
        object.manifest.keys().collect::<Vec<_>>(),
        ["Prop/Card", "Set/Card"]
    );
    assert_eq!(
        material.manifest.keys().collect::<Vec<_>>(),
        ["Blue", "Red"]
    );
    assert_eq!(asset.manifest.keys().collect::<Vec<_>>(), ["Prop", "Set"]);

    let alpha = &common::exr_channels(&exr)["A"];
    for layer in [&object, &material, &asset] {
        for (i, (t, a)) in layer.total().iter().zip(alpha).enumerate() {
            assert!(
                (t - a).abs() < 1e-6,
                "pixel {i}: mattes {t} against alpha {a}"
            );
        }
    }

    // Coverage is the filtered share of samples: over the image it adds up
    // to each card's visible area in pixels.
    for (layer, name, r) in [
        (&object, "Set/Card", FRONT),
        (&object, "Prop/Card", BACK),
        (&material, "Red", FRONT),
        (&asset, "Prop", BACK),
    ] {
        let sum: f64 = layer.matte(name).iter().map(|&c| c as f64).sum();
        let want = area_px(r);
        eprintln!("{name}: summed coverage {sum:.2} px, analytic {want:.2} px");
        assert!(
            (sum - want).abs() < 0.005 * want,
            "{name}: summed coverage {sum:.2} px, the card covers {want:.2} px"
        );
    }
    // Inside a card, away from its edges by more than the filter's radius,
    // its matte is exactly 1; outside both, every rank is empty.
    let front = object.matte("Set/Card");
    let back = object.matte("Prop/Card");
    let inside = pixel_of(-0.3, 0.0);
    assert_eq!((front[inside], back[inside]), (1.0, 0.0));
    assert_eq!(material.matte("Red")[inside], 1.0);
    assert_eq!(asset.matte("Set")[inside], 1.0);
    let behind = pixel_of(0.5, 0.2);
    assert_eq!((front[behind], back[behind]), (0.0, 1.0));
    let outside = pixel_of(-0.9, 0.9);
    assert_eq!(object.total()[outside], 0.0);
    assert_eq!(object.ranks[0][0][outside], 0.0);
    // Along the shared edge both cards have a share, most first.
    let edge = pixel_of(0.05, 0.0);
    assert!(
        front[edge] > 0.1 && back[edge] > 0.1,
        "{} {}",
        front[edge],
        back[edge]
    );
    assert!(object.ranks[0][1][edge] >= object.ranks[0][3][edge]);
}

/// Without `--cryptomatte` a frame has no matte channels; with it, the
/// same samples make the same beauty, bit for bit.
#[test]
fn mattes_leave_the_beauty_alone_and_are_absent_unless_asked_for() {
    let dir = tempfile::tempdir().unwrap();
    let with = common::exr_channels(&render(dir.path(), &[]));
    let plain_dir = tempfile::tempdir().unwrap();
    let file = scene(plain_dir.path());
    let plain = common::render_exr(
        &file,
        (SIZE, SIZE),
        plain_dir.path(),
        "plain.exr",
        &["--spp", "64", "--env-color", "1,1,1"],
    );
    let plain = common::exr_channels(&plain);
    assert_eq!(plain.keys().collect::<Vec<_>>(), ["A", "B", "G", "R"]);
    for c in ["R", "G", "B", "A"] {
        let bits = |v: &Vec<f32>| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&plain[c]), bits(&with[c]), "channel {c}");
    }
    assert_eq!(with.len(), 4 + 3 * 3 * 4);
}

#[test]
fn a_bad_layer_name_is_refused_with_the_choices() {
    let dir = tempfile::tempdir().unwrap();
    let file = scene(dir.path());
    let run = common::soupray(&["render", file.to_str().unwrap(), "--cryptomatte", "objects"]);
    assert!(!run.status.success());
    let err = String::from_utf8_lossy(&run.stderr);
    assert!(
        err.contains("unknown layer \"objects\"") && err.contains("object, material, asset"),
        "{err}"
    );
}

/// Blender's compositor (the Cryptomatte node, reading soupray's file as an
/// image) extracts the matte of `name`; its values per pixel.
const BLENDER_MATTE: &str = r#"
import bpy, sys
path, layer, name, out, w, h = sys.argv[-6:]
img = bpy.data.images.load(path)
scene = bpy.context.scene
for o in list(scene.objects):
    if o.type != 'CAMERA':
        bpy.data.objects.remove(o)
scene.render.resolution_x = int(w)
scene.render.resolution_y = int(h)
scene.render.resolution_percentage = 100
scene.render.engine = 'BLENDER_WORKBENCH'
tree = bpy.data.node_groups.new("soupray", "CompositorNodeTree")
scene.compositing_node_group = tree
node = tree.nodes.new("CompositorNodeCryptomatteV2")
node.source = 'IMAGE'
node.image = img
node.layer_name = layer
node.matte_id = name
output = tree.nodes.new("NodeGroupOutput")
tree.interface.new_socket(name="Image", in_out='OUTPUT', socket_type='NodeSocketColor')
tree.links.new(node.outputs['Matte'], output.inputs[0])
scene.render.image_settings.file_format = 'OPEN_EXR'
scene.render.image_settings.color_depth = '32'
scene.render.filepath = out
bpy.ops.render.render(write_still=True)
"#;

#[test]
fn blenders_compositor_extracts_the_same_matte() {
    let Some(python) = common::bpy_python() else {
        eprintln!(
            "skipped: Blender 5 as a Python module (pip install bpy==5.0.1; SOUPRAY_BPY_PATH) \
             is not installed"
        );
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let exr = render(dir.path(), &[]);
    let script = dir.path().join("matte.py");
    std::fs::write(&script, BLENDER_MATTE).unwrap();
    for (layer, name) in [("CryptoObject", "Prop/Card"), ("CryptoMaterial", "Red")] {
        let out = dir.path().join(format!("{layer}.exr"));
        let run = python()
            .args([
                script.to_str().unwrap(),
                exr.to_str().unwrap(),
                layer,
                name,
                out.to_str().unwrap(),
                &SIZE.to_string(),
                &SIZE.to_string(),
            ])
            .output()
            .unwrap();
        assert!(
            out.exists(),
            "Blender wrote no matte: {}",
            String::from_utf8_lossy(&run.stderr)
        );
        let ours = decode(&exr, layer).matte(name);
        let blender = &common::exr_channels(&out)["R"];
        let mut differ = 0;
        for (i, (a, b)) in ours.iter().zip(blender).enumerate() {
            if (a - b).abs() > 1e-5 {
                differ += 1;
                eprintln!("{layer} {name} pixel {i}: soupray {a}, Blender {b}");
            }
        }
        assert_eq!(differ, 0, "{layer} {name}: Blender's matte differs");
        eprintln!(
            "{layer} {name}: Blender's matte equals soupray's at all {} pixels",
            ours.len()
        );
        assert!(ours.iter().sum::<f32>() > 100.0);
    }
}

/// `--aov position,uv,object_id`: at every pixel that sees only one card,
/// the card's point under the pixel's centre, its uv there (the cards'
/// uvs run 0 to 1 across them) and the card's node index + 1; 0 where
/// nothing was hit.
#[test]
#[allow(clippy::needless_range_loop)] // a pixel indexes several channels
fn position_uv_and_object_id_are_those_of_the_first_hit() {
    let dir = tempfile::tempdir().unwrap();
    let exr = render(dir.path(), &["--aov", "position,uv,object_id"]);
    let c = common::exr_channels(&exr);
    let (mut front, mut back) = (0, 0);
    for i in 0..(SIZE * SIZE) as usize {
        let (col, row) = ((i % SIZE as usize) as f64, (i / SIZE as usize) as f64);
        let (x, y) = ((col + 0.5) / SCALE - 1.0, 1.0 - (row + 0.5) / SCALE);
        // 2 px (past the filter's radius) inside a card.
        let inside = |r: [f32; 4]| {
            let m = 2.0 / SCALE;
            x > r[0] as f64 + m && x < r[1] as f64 - m && y > r[2] as f64 + m && y < r[3] as f64 - m
        };
        let (card, z, id) = if inside(FRONT) {
            front += 1;
            (FRONT, 0.0, 2.0)
        } else if inside(BACK) {
            back += 1;
            (BACK, -0.5, 4.0)
        } else {
            if c["A"][i] == 0.0 {
                assert_eq!(c["object_id"][i], 0.0);
                assert_eq!(c["Position.X"][i], 0.0);
            }
            continue;
        };
        let want_u = (x - card[0] as f64) / (card[1] - card[0]) as f64;
        let want_v = (y - card[2] as f64) / (card[3] - card[2]) as f64;
        for (name, got, want) in [
            ("Position.X", c["Position.X"][i], x),
            ("Position.Y", c["Position.Y"][i], y),
            ("Position.Z", c["Position.Z"][i], z),
            ("UV.U", c["UV.U"][i], want_u),
            ("UV.V", c["UV.V"][i], want_v),
        ] {
            assert!(
                (got as f64 - want).abs() < 1e-3,
                "pixel {i}: {name} {got}, the card's {want}"
            );
        }
        assert_eq!(c["object_id"][i], id, "pixel {i}");
    }
    assert!(front > 400 && back > 300, "{front} front, {back} back");
}

/// `--aov object_id` alone (its pair table without Cryptomatte's layers)
/// gives the same ids as with them.
#[test]
fn object_ids_alone_match_those_beside_cryptomatte() {
    let dir = tempfile::tempdir().unwrap();
    let with = common::exr_channels(&render(dir.path(), &["--aov", "object_id"]));
    let alone_dir = tempfile::tempdir().unwrap();
    let file = scene(alone_dir.path());
    let alone = common::render_exr(
        &file,
        (SIZE, SIZE),
        alone_dir.path(),
        "alone.exr",
        &["--spp", "64", "--env-color", "1,1,1", "--aov", "object_id"],
    );
    let alone = common::exr_channels(&alone);
    assert!(!alone.keys().any(|k| k.starts_with("Crypto")));
    assert_eq!(alone["object_id"], with["object_id"]);
    assert!(alone["object_id"].contains(&2.0));
    assert!(alone["object_id"].contains(&4.0));
}
