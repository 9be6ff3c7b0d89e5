//! Scale and distance: scenes scaled by 1e-4 and 1e4, and a million units
//! from the origin, against the unit scene.

use super::*;

#[test]
fn scaled_and_far_away_scenes_match_the_unit_scene() {
    let d = common::device();
    let dir = tempfile::tempdir().unwrap();
    let spp = 32;
    let unit = write(&base_spec(), dir.path(), "unit");
    let a = render(&d, &unit, &settings(spp, 7), Tree::Device);
    let b = render(&d, &unit, &settings(spp, 8), Tree::Device);
    let (full, none) = coverage(&a.image);
    assert!(full > 0 && none > 0, "scene and sky in view");
    let reference = Reference::new(a.image, &b.image);
    // At 1e6 from the origin a float32 coordinate is a multiple of 0.0625,
    // and a new ray starts 256 of those ulps (16 units) off its surface
    // (Wächter and Binder's margin over the hit point's error of a few
    // ulps). So that scene is also scaled by 1000: spheres of radius 600
    // and 450, the camera 4500 units away, vertices moved by at most 0.03
    // units and rays offset by under 3 % of a radius. (At scale 100 the
    // 16-unit offset is a quarter of the red sphere's radius: its contact
    // shadow thins and the image is 3.9x the noise away.) What is tested is
    // that offsets, intersection and the tree stay robust there.
    for (scale, offset) in [
        (1e-4f32, Vec3::ZERO),
        (1e4, Vec3::ZERO),
        (1000.0, Vec3::splat(1e6)),
    ] {
        let what = format!("scale {scale:e}, offset {offset}");
        let spec = Spec {
            scale,
            offset,
            ..base_spec()
        };
        let path = write(&spec, dir.path(), "scaled");
        let f = render(&d, &path, &settings(spp, 7), Tree::Device);
        // The soup really is where it should be.
        let (lo, hi) = f.soup.bounds().unwrap();
        let want_lo = Vec3::new(-3.0, 0.0, -3.0) * scale + offset;
        let want_hi = Vec3::new(3.0, 1.2, 3.0) * scale + offset;
        for a in 0..3 {
            let tol = 1e-3 * scale.abs() + offset[a].abs() * 1e-6;
            assert!(
                (lo[a] - want_lo[a]).abs() <= tol && (hi[a] - want_hi[a]).abs() <= tol,
                "{what}: soup bounds {lo:?}..{hi:?}"
            );
        }
        assert!(f.bvh.shape().leaves > 0);
        reference.assert_matches(&f.image, &what);
    }
}
