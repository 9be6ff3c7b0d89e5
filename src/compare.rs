//! Image error measures for golden tests and the speed/accuracy sweep.
//!
//! Two numbers, as production image tests use them:
//! * relative MSE on the linear radiance, per channel
//!   `(test - ref)^2 / (ref^2 + 0.01)`, averaged (the 0.01 keeps black
//!   pixels from dominating; pbrt's and Mitsuba's tests use the same form);
//! * mean FLIP (NVIDIA's LDR ꟻLIP, through the `nv-flip` bindings) between
//!   the two images tonemapped the way `--png` previews are: what a person
//!   comparing the frames would see.

use crate::film::Image;

/// How far `test` is from `reference`.
#[derive(Clone, Copy, Debug, PartialEq, serde::Serialize)]
pub struct ImageError {
    pub rel_mse: f64,
    pub flip: f64,
}

/// Why two images cannot be compared.
#[derive(Debug, thiserror::Error)]
#[error("cannot compare a {0}x{1} image with a {2}x{3} reference")]
pub struct SizeMismatch(pub u32, pub u32, pub u32, pub u32);

fn check(test: &Image, reference: &Image) -> Result<(), SizeMismatch> {
    if (test.width, test.height) != (reference.width, reference.height) {
        return Err(SizeMismatch(
            test.width,
            test.height,
            reference.width,
            reference.height,
        ));
    }
    Ok(())
}

/// Relative MSE over the RGB channels of the linear images.
pub fn relative_mse(test: &Image, reference: &Image) -> Result<f64, SizeMismatch> {
    check(test, reference)?;
    let mut sum = 0.0;
    for (t, r) in test.rgba.iter().zip(&reference.rgba) {
        for c in 0..3 {
            let (t, r) = (t[c] as f64, r[c] as f64);
            sum += (t - r) * (t - r) / (r * r + 0.01);
        }
    }
    Ok(sum / (3 * test.rgba.len().max(1)) as f64)
}

/// The FLIP error map (0 = identical, 1 = maximal) of the tonemapped images.
pub fn flip_map(test: &Image, reference: &Image, exposure: f32) -> Result<Vec<f32>, SizeMismatch> {
    check(test, reference)?;
    let (w, h) = (test.width, test.height);
    let t = nv_flip::FlipImageRgb8::with_data(w, h, &crate::output::tonemap_srgb8(test, exposure));
    let r =
        nv_flip::FlipImageRgb8::with_data(w, h, &crate::output::tonemap_srgb8(reference, exposure));
    Ok(nv_flip::flip(r, t, nv_flip::DEFAULT_PIXELS_PER_DEGREE).to_vec())
}

/// Both measures at once.
pub fn compare(test: &Image, reference: &Image, exposure: f32) -> Result<ImageError, SizeMismatch> {
    let map = flip_map(test, reference, exposure)?;
    let flip = map.iter().map(|&v| v as f64).sum::<f64>() / map.len().max(1) as f64;
    Ok(ImageError {
        rel_mse: relative_mse(test, reference)?,
        flip,
    })
}

/// The FLIP error map as an 8-bit image (magma colours), for a person to look at.
pub fn flip_map_rgb8(
    test: &Image,
    reference: &Image,
    exposure: f32,
) -> Result<Vec<u8>, SizeMismatch> {
    let map = flip_map(test, reference, exposure)?;
    let float = nv_flip::FlipImageFloat::with_data(test.width, test.height, &map);
    Ok(float.apply_color_lut(&nv_flip::magma_lut()).to_vec())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::film::Aovs;

    fn image(w: u32, h: u32, f: impl Fn(u32, u32) -> [f32; 4]) -> Image {
        let mut img = Image::new(w, h, Aovs::default());
        for y in 0..h {
            for x in 0..w {
                img.rgba[(y * w + x) as usize] = f(x, y);
            }
        }
        img
    }

    #[test]
    fn identical_images_have_no_error() {
        let a = image(32, 24, |x, y| [x as f32 / 32.0, y as f32 / 24.0, 0.5, 1.0]);
        let e = compare(&a, &a, 0.0).unwrap();
        assert_eq!(e.rel_mse, 0.0);
        assert_eq!(e.flip, 0.0);
    }

    #[test]
    fn error_grows_with_the_difference() {
        let a = image(32, 24, |x, _| [x as f32 / 32.0, 0.3, 0.3, 1.0]);
        let small = image(32, 24, |x, _| [x as f32 / 32.0 + 0.02, 0.3, 0.3, 1.0]);
        let big = image(32, 24, |x, _| [x as f32 / 32.0 + 0.3, 0.3, 0.3, 1.0]);
        let e1 = compare(&small, &a, 0.0).unwrap();
        let e2 = compare(&big, &a, 0.0).unwrap();
        assert!(e1.rel_mse > 0.0 && e2.rel_mse > e1.rel_mse);
        assert!(e1.flip > 0.0 && e2.flip > e1.flip, "{e1:?} {e2:?}");
        // relative MSE of a constant offset d on a value r: d^2 / (r^2 + 0.01)
        let flat = image(4, 4, |_, _| [0.5, 0.5, 0.5, 1.0]);
        let off = image(4, 4, |_, _| [0.6, 0.6, 0.6, 1.0]);
        let e = relative_mse(&off, &flat).unwrap();
        assert!((e - 0.01 / 0.26).abs() < 1e-6, "{e}");
    }

    #[test]
    fn sizes_must_match() {
        let a = image(4, 4, |_, _| [0.0; 4]);
        let b = image(4, 5, |_, _| [0.0; 4]);
        assert!(compare(&a, &b, 0.0).is_err());
    }
}
