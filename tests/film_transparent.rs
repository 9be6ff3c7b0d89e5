//! `--transparent`: the environment the camera sees directly is left out
//! (RGB and alpha 0, premultiplied), while it still lights the scene; and
//! previews composite such frames over a neutral grey.

mod common;

use common::render::*;
use glam::Vec3;
use soupray::film::{Aovs, Image};
use soupray::output::{over_background, PREVIEW_GREY};
use soupray::soup::Soup;
use soupray::trace::render::{render_soup, Environment, RenderSettings};

const SIZE: u32 = 48;
/// The sky's constant radiance.
const SKY: f32 = 1.0;

fn render(transparent: bool) -> Image {
    let d = common::device();
    let mut soup = Soup::default();
    sphere(&mut soup, Vec3::ZERO, 1.0, 24, 48, 0);
    let camera = perspective(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, Vec3::Y, 40.0);
    let settings = RenderSettings {
        environment: Environment::Color([SKY; 3]),
        transparent,
        ..settings(SIZE, 16)
    };
    let white = material([0.8, 0.8, 0.8, 1.0], 0.0, 1.0);
    render_soup(&d, &soup, &table(vec![white]), &camera, &[], &settings, 0)
        .unwrap()
        .image
}

#[test]
fn the_sky_seen_directly_is_left_out_and_still_lights_the_scene() {
    let opaque = render(false);
    let clear = render(true);
    let (mut background, mut covered, mut edge) = (0, 0, 0);
    for (o, c) in opaque.rgba.iter().zip(&clear.rgba) {
        // Coverage is the same: only escaped camera rays change.
        assert_eq!(o[3], c[3]);
        if o[3] == 0.0 {
            // The sky alone: nothing there.
            assert_eq!(*c, [0.0; 4]);
            assert!(o[0] > 0.99 * SKY);
            background += 1;
        } else if o[3] == 1.0 {
            // Every sample hit the sphere, lit by the sky: the same paths,
            // the same values, bit for bit.
            assert_eq!(o, c);
            assert!(c[0] > 0.1, "the sky still lights the sphere: {c:?}");
            covered += 1;
        } else {
            // An edge: the sky's share (1 - alpha) is gone, the rest stays.
            for k in 0..3 {
                let want = o[k] - (1.0 - o[3]) * SKY;
                assert!((c[k] - want).abs() < 1e-5, "edge {o:?} -> {c:?}");
            }
            edge += 1;
        }
    }
    assert!(background > 100 && covered > 100 && edge > 20);
}

#[test]
fn previews_composite_transparent_frames_over_grey() {
    let mut img = Image::new(3, 1, Aovs::NONE);
    img.rgba = vec![[0.0; 4], [0.5, 0.25, 0.1, 1.0], [0.2, 0.2, 0.2, 0.5]];
    let over = over_background(&img, [PREVIEW_GREY; 3]);
    assert_eq!(
        over.rgba[0],
        [PREVIEW_GREY, PREVIEW_GREY, PREVIEW_GREY, 1.0]
    );
    assert_eq!(over.rgba[1], [0.5, 0.25, 0.1, 1.0]);
    let half = 0.2 + 0.5 * PREVIEW_GREY;
    assert_eq!(over.rgba[2], [half, half, half, 1.0]);
}

#[test]
fn the_cli_writes_a_transparent_frame_and_a_grey_preview() {
    let dir = tempfile::tempdir().unwrap();
    let out = common::soupray_cmd()
        .current_dir(common::repo())
        .args([
            "render", "--frames", "0", "--spp", "2", "--width", "32", "--height", "18",
        ])
        .args(["--transparent", "--png", "--quiet", "--out"])
        .arg(dir.path())
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let exr = common::read_exr(&dir.path().join("walker.0000.exr"));
    // The walker's top-left corner sees only the sky.
    assert_eq!(exr.rgba[0], [0.0; 4]);
    let png = image::open(dir.path().join("walker.0000.png"))
        .unwrap()
        .to_rgb8();
    // Middle grey in sRGB: 0.18 -> 118.
    assert_eq!(png.get_pixel(0, 0).0, [118, 118, 118]);
}
