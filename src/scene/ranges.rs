//! Values outside the ranges glTF 2.0 and its extensions allow, in objects
//! that are otherwise usable: cameras, lights and materials. Each is clamped
//! (or replaced by the spec's default where no nearest value exists) with a
//! warning naming the object, the property, the value and what is used
//! instead; the warnings go to the terminal and into every frame's log.
//! Structural problems (bad indices, missing parts) are refused earlier, by
//! `validate`.

use std::f32::consts::{FRAC_PI_2, PI};

use super::camera::{CameraDef, Projection, DEFAULT_YFOV};
use super::light::{LightDef, LightKind};
use super::material::Material;
use super::material::FACTORS;

fn label(kind: &str, index: usize, name: Option<&str>) -> String {
    match name {
        Some(n) => format!("{kind} {index} \"{n}\""),
        None => format!("{kind} {index}"),
    }
}

/// Clamps `v` into `lo..=hi` (NaN to `default`), warning when it changes.
fn clamp(
    warnings: &mut Vec<String>,
    what: &str,
    property: &str,
    v: &mut f32,
    lo: f32,
    hi: f32,
    default: f32,
) {
    let fixed = if v.is_nan() { default } else { v.clamp(lo, hi) };
    if fixed != *v {
        let range = if hi == f32::MAX {
            format!("below {lo}")
        } else {
            format!("outside {lo}..{hi}")
        };
        warnings.push(format!(
            "{what}: {property} {} is {range}; {fixed} is used",
            *v
        ));
        *v = fixed;
    }
}

pub(crate) fn camera(index: usize, cam: &mut CameraDef, warnings: &mut Vec<String>) {
    let what = label("camera", index, cam.name.as_deref());
    match &mut cam.projection {
        Projection::Perspective {
            yfov,
            aspect,
            znear,
            zfar,
        } => {
            if !(yfov.is_finite() && *yfov > 0.0 && *yfov < PI) {
                warnings.push(format!(
                    "{what}: yfov {yfov} is not in (0, pi); {DEFAULT_YFOV} (40 degrees) is used"
                ));
                *yfov = DEFAULT_YFOV;
            }
            if let Some(a) = *aspect {
                if !(a.is_finite() && a > 0.0) {
                    warnings.push(format!(
                        "{what}: aspectRatio {a} is not positive; the image's aspect ratio is used"
                    ));
                    *aspect = None;
                }
            }
            if !(znear.is_finite() && *znear > 0.0) {
                warnings.push(format!(
                    "{what}: znear {znear} is not positive; 0.001 is used"
                ));
                *znear = 0.001;
            }
            if let Some(f) = *zfar {
                if !(f.is_finite() && f > *znear) {
                    warnings.push(format!(
                        "{what}: zfar {f} is not beyond znear {znear}; the projection is made infinite"
                    ));
                    *zfar = None;
                }
            }
        }
        Projection::Orthographic {
            xmag,
            ymag,
            znear,
            zfar,
        } => {
            for (property, m) in [("xmag", xmag), ("ymag", ymag)] {
                if !(m.is_finite() && *m != 0.0) {
                    warnings.push(format!(
                        "{what}: {property} {m} is not a non-zero number; 1 is used"
                    ));
                    *m = 1.0;
                } else if *m < 0.0 {
                    warnings.push(format!(
                        "{what}: {property} {m} is negative; {} is used",
                        -*m
                    ));
                    *m = -*m;
                }
            }
            if !(znear.is_finite() && *znear >= 0.0) {
                warnings.push(format!("{what}: znear {znear} is negative; 0 is used"));
                *znear = 0.0;
            }
            if !(zfar.is_finite() && *zfar > *znear) {
                let fixed = *znear + 1e6;
                warnings.push(format!(
                    "{what}: zfar {zfar} is not beyond znear {znear}; {fixed} is used"
                ));
                *zfar = fixed;
            }
        }
    }
}

pub(crate) fn light(index: usize, light: &mut LightDef, warnings: &mut Vec<String>) {
    let what = label("KHR_lights_punctual light", index, light.name.as_deref());
    clamp(
        warnings,
        &what,
        "intensity",
        &mut light.intensity,
        0.0,
        f32::MAX,
        1.0,
    );
    for (c, name) in light
        .color
        .iter_mut()
        .zip(["color.r", "color.g", "color.b"])
    {
        clamp(warnings, &what, name, c, 0.0, f32::MAX, 1.0);
    }
    if let Some(r) = light.range {
        if !(r.is_finite() && r > 0.0) {
            warnings.push(format!(
                "{what}: range {r} is not positive; the range is unlimited"
            ));
            light.range = None;
        }
    }
    if let LightKind::Spot {
        inner_cone_angle,
        outer_cone_angle,
    } = &mut light.kind
    {
        if inner_cone_angle > outer_cone_angle {
            warnings.push(format!(
                "{what}: innerConeAngle {inner_cone_angle} exceeds outerConeAngle {outer_cone_angle}; the two are swapped"
            ));
            std::mem::swap(inner_cone_angle, outer_cone_angle);
        }
        clamp(
            warnings,
            &what,
            "outerConeAngle",
            outer_cone_angle,
            1e-4,
            FRAC_PI_2,
            std::f32::consts::FRAC_PI_4,
        );
        let outer = *outer_cone_angle;
        clamp(
            warnings,
            &what,
            "innerConeAngle",
            inner_cone_angle,
            0.0,
            outer * 0.999,
            0.0,
        );
    }
}

pub(crate) fn material(index: usize, m: &mut Material, warnings: &mut Vec<String>) {
    let what = label("material", index, m.name.as_deref());
    let w = warnings;
    // KHR_materials_ior: 0 is an infinite index (a perfect mirror), which
    // the largest finite index stands for here.
    if m.ior == 0.0 {
        m.ior = 1.0e6;
    }
    let defaults = Material::default();
    for factor in FACTORS {
        let Some((lo, hi)) = factor.range else {
            continue;
        };
        let default = factor.values(&defaults)[0];
        let name = factor.name();
        let components = factor.components(m);
        let single = components.len() == 1;
        for (c, suffix) in components.iter_mut().zip([".r", ".g", ".b", ".a"]) {
            let property = if single {
                name.clone()
            } else {
                format!("{name}{suffix}")
            };
            clamp(w, &what, &property, c, lo, hi, default);
        }
    }
    if !m.normal_scale.is_finite() {
        w.push(format!(
            "{what}: normalTexture.scale {} is not finite; 1 is used",
            m.normal_scale
        ));
        m.normal_scale = 1.0;
    }
    if m.attenuation_distance.is_nan() || m.attenuation_distance <= 0.0 {
        w.push(format!(
            "{what}: KHR_materials_volume attenuationDistance {} is not above 0; infinity (no attenuation) is used",
            m.attenuation_distance
        ));
        m.attenuation_distance = f32::INFINITY;
    }
}
