//! The dielectric's energy-conserving layering (`--layering energy`, the
//! kernels' `ENERGY_LAYERING`; mirrored by `kernels/trace/layering.h`).
//!
//! The specification's `fresnel_mix` weights the base under the specular
//! layer by 1 - F(v.h) of each pair of directions, which is not what the
//! layer leaves: a rough layer reflects less than F on average (its
//! masking loses the rest), and 1 - F(v.h) over the base's directions is
//! not 1 - the layer's albedo. Here the base is scaled by what the layer
//! does not reflect, its directional albedo E_spec (albedo scaling, as
//! KHR_materials_sheen, Enterprise PBR and OpenPBR do):
//!
//! - the Lambertian lobes (diffuse reflection and transmission) by Kulla
//!   and Conty's reciprocal (1 - E_spec(mu_o)) (1 - E_spec(mu_i)) /
//!   (1 - E_spec_avg), which integrates to exactly 1 - E_spec(mu_o);
//! - the thin-walled transmission lobe by 1 - E_spec(mu_o), the lobe
//!   itself compensated to albedo 1 with `GGX_ENERGY_COMPENSATION`;
//! - a refracting volume's transmission lobe (Walter's microfacet
//!   refraction without its Fresnel) by 1 - E_spec(mu_o), from either side,
//!   compensated to energy albedo 1 (`energy::refraction_albedo`).
//!
//! E_spec is per channel (the layer's F0 is KHR_materials_specular's
//! coloured one), with Turquin's compensation when the lobe has it, from
//! the white table E and the Schlick-weighted table E_w
//! (`energy::schlick_albedo`; from inside a volume, at the thinner side's
//! cosine, `energy::inside_schlick_albedo`): Schlick's Fresnel is linear in
//! F0. The Lambertian lobes of a volume seen from inside keep the
//! specification's weighting (the reciprocal form's averages are tabulated
//! for the outside only).

// `!(x > 0.0)` is meant: it is also true for NaN, as in the kernels.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::Vec3;

use super::super::energy::{
    albedo_averages, anisotropic_albedo, ggx_albedo, inside_schlick_albedo, refraction_albedo,
    schlick_albedo,
};
use super::bsdf::{spec_isotropic, spec_smooth, BsdfParams};
use super::dielectric::{layer_fresnel, schlick_weight, Dielectric};

/// Whether the energy layering applies: asked for, and wo on the outside
/// (or thin-walled), where the layer's Fresnel is Schlick's of the cosine.
pub(super) fn energy_layered(p: &BsdfParams, d: Option<&Dielectric>) -> bool {
    p.energy_layering && d.is_none_or(|d| d.eta >= 1.0)
}

/// The specular layer's normal reflectance: KHR_materials_specular's
/// coloured F0, or glTF's 4 % without the dielectric extensions.
fn layer_f0(d: Option<&Dielectric>) -> Vec3 {
    d.map_or(Vec3::splat(0.04), |d| d.f0_color)
}

/// The root-mean-square alpha of the base's lobe (its alpha if isotropic).
fn rms_alpha(p: &BsdfParams) -> f32 {
    if spec_isotropic(p) {
        p.alpha
    } else {
        ((p.alpha_t * p.alpha_t + p.alpha * p.alpha) * 0.5).sqrt()
    }
}

/// The white (E) and Schlick-weighted (E_w) albedos of the base's lobe
/// towards `w` (above the surface); inside a volume (a relative index
/// below one) E_w is taken at the thinner side's cosine, 1 under total
/// internal reflection. Anisotropic: the isotropic pair at the
/// root-mean-square alpha, with E the anisotropic table's when compensated
/// (the one Turquin's factor uses) and E_w scaled as E is.
fn lobe_albedos(p: &BsdfParams, d: Option<&Dielectric>, w: Vec3) -> (f32, f32) {
    let a = rms_alpha(p);
    let ew = match d {
        Some(d) if d.eta < 1.0 => inside_schlick_albedo(a, w.z, d.eta),
        _ => schlick_albedo(a, w.z),
    };
    let e = ggx_albedo(a, w.z);
    if spec_isotropic(p) || !p.energy_compensation {
        return (e, ew);
    }
    let ea = anisotropic_albedo(p.alpha_t, p.alpha, w.to_array());
    (ea, ew * (ea / e))
}

/// The specular layer's directional albedo E_spec towards `w` (above the
/// surface), per channel: what its reflection lobe (`dielectric_eval`,
/// `base_eval`) returns of white light from every direction. A smooth
/// layer's is its Fresnel exactly (with the thin film, if any).
pub(super) fn layer_albedo(p: &BsdfParams, d: Option<&Dielectric>, w: Vec3) -> Vec3 {
    let f0 = layer_f0(d);
    let mu = w.z;
    if spec_smooth(p) {
        let f = match d {
            Some(d) => layer_fresnel(d, mu),
            None => Vec3::splat(0.04 + 0.96 * schlick_weight(mu)),
        } * p.specular;
        if p.energy_compensation {
            return f * (Vec3::ONE + f0 * (1.0 / ggx_albedo(p.alpha, mu) - 1.0));
        }
        return f;
    }
    let (e, ew) = lobe_albedos(p, d, w);
    let f = (f0 * e + (Vec3::ONE - f0) * ew) * p.specular;
    if p.energy_compensation {
        f * (Vec3::ONE + compensation_f0(d, f0, e, ew) * (1.0 / e - 1.0))
    } else {
        f
    }
}

/// The F0 of Turquin's factor 1 + F0 (1 / E - 1) for the layer's rough
/// reflection lobe: its F0, or inside a volume its mean Fresnel F0 + (1 -
/// F0) E_w / E, which is 1 where total internal reflection makes the lobe
/// a white mirror (F0 would leave its multiple scattering to the
/// refraction, which cannot carry it there).
fn compensation_f0(d: Option<&Dielectric>, f0: Vec3, e: f32, ew: f32) -> Vec3 {
    match d {
        Some(d) if d.eta < 1.0 => f0 + (Vec3::ONE - f0) * (ew / e),
        _ => f0,
    }
}

/// `compensation_f0` of the rough reflection lobe towards wo, with the
/// energy layering: what `dielectric_eval` compensates it with.
pub(super) fn reflection_compensation_f0(p: &BsdfParams, d: &Dielectric, wo: Vec3) -> Vec3 {
    if !p.energy_layering || d.eta >= 1.0 || spec_smooth(p) {
        return d.f0_color;
    }
    let (e, ew) = lobe_albedos(p, Some(d), wo);
    compensation_f0(Some(d), d.f0_color, e, ew)
}

/// The cosine-weighted average of `layer_albedo` over the hemisphere.
/// With Turquin's factor the albedo is F0 (1 - F0) E + F0^2 + (1 - F0)^2
/// E_w + F0 (1 - F0) E_w / E, each term averaged by the table; a smooth
/// layer's is Schlick's average, F0 + (1 - F0) / 21.
pub(super) fn layer_average(p: &BsdfParams, d: Option<&Dielectric>) -> Vec3 {
    let f0 = layer_f0(d);
    let g = Vec3::ONE - f0;
    if spec_smooth(p) {
        return (f0 + g / 21.0) * p.specular;
    }
    let [e, ew, ratio] = albedo_averages(rms_alpha(p));
    let avg = if p.energy_compensation {
        f0 * g * e + f0 * f0 + g * g * ew + f0 * g * ratio
    } else {
        f0 * e + g * ew
    };
    avg * p.specular
}

/// Kulla and Conty's reciprocal scaling of a Lambertian lobe under the
/// layer, for wo and `wi_up` (wi, or its mirror for a lobe below the
/// surface): (1 - E_spec(wo)) (1 - E_spec(wi)) / (1 - E_spec_avg).
pub(super) fn lambert_scaling(
    p: &BsdfParams,
    d: Option<&Dielectric>,
    wo: Vec3,
    wi_up: Vec3,
) -> Vec3 {
    let keep_o = (Vec3::ONE - layer_albedo(p, d, wo)).max(Vec3::ZERO);
    let keep_i = (Vec3::ONE - layer_albedo(p, d, wi_up)).max(Vec3::ZERO);
    let rest = Vec3::ONE - layer_average(p, d);
    let ratio = |k: f32, r: f32| if r > 0.0 { k / r } else { 0.0 };
    Vec3::new(
        ratio(keep_o.x * keep_i.x, rest.x),
        ratio(keep_o.y * keep_i.y, rest.y),
        ratio(keep_o.z * keep_i.z, rest.z),
    )
}

/// The scaling of a refracting volume's transmission lobe (the
/// Fresnel-less microfacet refraction, on either side): what the layer
/// leaves it towards wo, 1 - E_spec(wo), over the lobe's own energy albedo
/// when compensated (at most 100-fold, where total internal reflection
/// leaves the lobe almost nothing), so that reflection and refraction
/// together return all they receive.
pub(super) fn refraction_scaling(p: &BsdfParams, d: &Dielectric, wo: Vec3) -> Vec3 {
    let keep = layer_transmittance(p, Some(d), wo);
    if p.energy_compensation && !spec_smooth(p) {
        keep / refraction_albedo(rms_alpha(p), wo.z, d.eta).max(0.01)
    } else {
        keep
    }
}

/// What the layer leaves the base towards wo: 1 - E_spec(wo).
pub(super) fn layer_transmittance(p: &BsdfParams, d: Option<&Dielectric>, wo: Vec3) -> Vec3 {
    (Vec3::ONE - layer_albedo(p, d, wo)).max(Vec3::ZERO)
}
