//! The dielectric extensions of the BSDF (`HAS_TRANSMISSION` and the lobes
//! built on it): KHR_materials_ior's F0, the transmission lobe (thin-walled
//! or refracting), diffuse transmission, the Fresnel terms and the thin
//! film of KHR_materials_iridescence. Each function mirrors the one of the
//! same name in `kernels/trace/bsdf.h`.

// `!(x > 0.0)` is meant: it is also true for NaN, as in the kernels.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::Vec3;

use super::super::sampling::{luminance, sample_cosine_hemisphere, INV_PI, PI};

use super::bsdf::*;
use super::layering::{energy_layered, lambert_scaling, layer_transmittance, refraction_scaling};

/// The dielectric extensions at one point (`HAS_TRANSMISSION` only).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Normal-incidence reflectance, `((ior - 1) / (ior + 1))^2`.
    pub f0: f32,
    /// The coloured F0 of KHR_materials_specular, `min(f0 * color, 1)`.
    pub f0_color: Vec3,
    /// Share of the diffuse lobe that transmits.
    pub transmission: f32,
    /// Relative index: the far side's over wo's side (1 thin-walled).
    pub eta: f32,
    /// Thin-walled: transmission goes straight through, unbent.
    pub thin: bool,
    /// KHR_materials_diffuse_transmission: the share of the (untransmitted)
    /// diffuse lobe that is transmitted diffusely, 0 without it.
    pub diffuse_transmission: f32,
    /// The diffusely transmitted light's colour (white without it).
    pub diffuse_transmission_color: Vec3,
    /// KHR_materials_iridescence: the thin film's weight (0: none), its
    /// index and its thickness in nanometres.
    pub iridescence: f32,
    pub iridescence_ior: f32,
    pub iridescence_thickness: f32,
    /// KHR_materials_diffuse_roughness (`HAS_DIFFUSE_ROUGHNESS`): the
    /// diffuse lobe's roughness, 0 (Lambert) without it.
    pub diffuse_roughness: f32,
}

impl Dielectric {
    /// For a material of index `ior` in air, seen from outside (`front`)
    /// or inside; `volume`: refracting rather than thin-walled.
    pub fn new(ior: f32, transmission: f32, volume: bool, front: bool) -> Dielectric {
        Dielectric::nested(ior, 1.0, transmission, volume, front)
    }

    /// With index `n_other` on the surface's other side (for a thin-walled
    /// surface, the volume it is in; `trace::media`): F0 from the relative
    /// index `ior / n_other`, and for a volume the relative index
    /// `media::relative_eta`. Mirrors `pt_dielectric_params` in
    /// `kernels/trace/scene_view.h`.
    pub fn nested(
        ior: f32,
        n_other: f32,
        transmission: f32,
        volume: bool,
        front: bool,
    ) -> Dielectric {
        let eta = if volume {
            crate::trace::media::relative_eta(ior, n_other, front)
        } else {
            1.0
        };
        let f0 = crate::trace::media::relative_f0(ior, n_other);
        Dielectric {
            f0,
            f0_color: Vec3::splat(f0),
            transmission: transmission.clamp(0.0, 1.0),
            eta,
            thin: !volume,
            diffuse_transmission: 0.0,
            diffuse_transmission_color: Vec3::ONE,
            iridescence: 0.0,
            iridescence_ior: 1.3,
            iridescence_thickness: 400.0,
            diffuse_roughness: 0.0,
        }
    }
}

impl Dielectric {
    /// With KHR_materials_specular's `specularColorFactor` (the factor is
    /// `BsdfParams::specular`).
    pub fn with_specular_color(self, color: [f32; 3]) -> Dielectric {
        Dielectric {
            f0_color: (Vec3::splat(self.f0) * Vec3::from(color)).min(Vec3::ONE),
            ..self
        }
    }

    /// With KHR_materials_diffuse_transmission's factor and colour.
    pub fn with_diffuse_transmission(self, factor: f32, color: [f32; 3]) -> Dielectric {
        Dielectric {
            diffuse_transmission: factor.clamp(0.0, 1.0),
            diffuse_transmission_color: Vec3::from(color),
            ..self
        }
    }

    /// With KHR_materials_iridescence's weight, film index and thickness
    /// (nanometres).
    pub fn with_iridescence(self, factor: f32, ior: f32, thickness: f32) -> Dielectric {
        Dielectric {
            iridescence: factor.clamp(0.0, 1.0),
            iridescence_ior: ior,
            iridescence_thickness: thickness,
            ..self
        }
    }

    /// With KHR_materials_diffuse_roughness's roughness.
    pub fn with_diffuse_roughness(self, roughness: f32) -> Dielectric {
        Dielectric {
            diffuse_roughness: roughness.clamp(0.0, 1.0),
            ..self
        }
    }

    /// Whether the diffuse transmission lobe can carry light.
    pub(super) fn transmits_diffusely(&self) -> bool {
        self.diffuse_transmission > 0.0 && self.diffuse_transmission_color.max_element() > 0.0
    }
}

pub fn f0_of_ior(ior: f32) -> f32 {
    let r = (ior - 1.0) / (ior + 1.0);
    r * r
}

pub(super) fn schlick_weight(c: f32) -> f32 {
    let m = (1.0 - c).clamp(0.0, 1.0);
    let m2 = m * m;
    (m2 * m2) * m
}

/// Schlick's Fresnel of a dielectric of normal reflectance `f0` and
/// relative index `eta` at cosine `c` on wo's side: taken with the cosine
/// on the optically thinner side, 1 under total internal reflection.
pub fn fresnel_dielectric(f0: f32, eta: f32, c: f32) -> f32 {
    match thinner_side_cos(eta, c) {
        Some(c) => f0 + (1.0 - f0) * schlick_weight(c),
        None => 1.0,
    }
}

/// The cosine on the optically thinner side of an interface of relative
/// index `eta` (the far side's over wo's) for cosine `c` on wo's side:
/// `c` itself when wo's side is the thinner one, else the refracted
/// cosine; `None` under total internal reflection.
pub(super) fn thinner_side_cos(eta: f32, c: f32) -> Option<f32> {
    if eta < 1.0 {
        let s2t = (1.0 - c * c).max(0.0) / (eta * eta);
        if s2t >= 1.0 {
            return None;
        }
        return Some((1.0 - s2t).sqrt());
    }
    Some(c)
}

/// `fresnel_dielectric` per channel of a coloured F0.
pub fn fresnel_dielectric3(f0: Vec3, eta: f32, c: f32) -> Vec3 {
    match thinner_side_cos(eta, c) {
        Some(c) => f0 + (Vec3::ONE - f0) * schlick_weight(c),
        None => Vec3::ONE,
    }
}

pub(super) fn max3(v: Vec3) -> f32 {
    v.x.max(v.y).max(v.z)
}

/// The reflectance of a thin film of index `film_ior` and thickness
/// `thickness` (nm) in air over a base of normal reflectance `f0` (per
/// channel), at cosine `cos1` with the normal in air: the Airy sum of the
/// film's two interfaces with the phase of each round trip, integrated
/// against the sRGB primaries' spectral sensitivities in Fourier space
/// (Belcour and Barla 2017, "A Practical Extension to Microfacet Theory for
/// the Modeling of Varying Iridescence", in the form KHR_materials_iridescence
/// gives: the first two orders, Schlick's Fresnel from the base's F0). Two
/// departures from the extension's listing, both so that a vanishing film
/// leaves exactly the base's Fresnel: the air-film interface takes the exact
/// dielectric Fresnel (Schlick's is not 0 at grazing angles between equal
/// indices), and R12 R23 is not floored at 1e-5 (the floor left interference
/// terms of weight ~sqrt(1e-5) where the film reflects nothing: 0.007 at
/// normal incidence). A film thinner than 0.03 nm fades into the air; the
/// result is clamped to 0..1.
pub fn thin_film_fresnel(film_ior: f32, cos1: f32, thickness: f32, f0: Vec3) -> Vec3 {
    // smoothstep(0, 0.03, thickness)
    let x = (thickness / 0.03).clamp(0.0, 1.0);
    let n2 = 1.0 + (film_ior - 1.0) * ((x * x) * (3.0 - 2.0 * x));
    let sin2_sq = (1.0 / (n2 * n2)) * (1.0 - cos1 * cos1);
    let cos2_sq = 1.0 - sin2_sq;
    if cos2_sq < 0.0 {
        return Vec3::ONE;
    }
    let cos2 = cos2_sq.sqrt();
    // Air to film.
    // The exact Fresnel of the air-film interface (unpolarised).
    let rs_12 = (cos1 - n2 * cos2) / (cos1 + n2 * cos2);
    let rp_12 = (n2 * cos1 - cos2) / (n2 * cos1 + cos2);
    let r12 = 0.5 * (rs_12 * rs_12 + rp_12 * rp_12);
    let t121 = 1.0 - r12;
    let phi12 = if n2 < 1.0 { PI } else { 0.0 };
    let phi21 = PI - phi12;
    // Film to base: the base's index from its F0 (below 1, so finite).
    let sqrt3 = |v: Vec3| Vec3::new(v.x.sqrt(), v.y.sqrt(), v.z.sqrt());
    let sf0 = sqrt3(f0.clamp(Vec3::ZERO, Vec3::splat(0.9999)));
    let base_ior = (Vec3::ONE + sf0) / (Vec3::ONE - sf0);
    let r1 = ((base_ior - Vec3::splat(n2)) / (base_ior + Vec3::splat(n2)))
        * ((base_ior - Vec3::splat(n2)) / (base_ior + Vec3::splat(n2)));
    let r23 = r1 + (Vec3::ONE - r1) * schlick_weight(cos2);
    let phi23 = Vec3::new(
        if base_ior.x < n2 { PI } else { 0.0 },
        if base_ior.y < n2 { PI } else { 0.0 },
        if base_ior.z < n2 { PI } else { 0.0 },
    );
    // Optical path difference of one round trip, and the phase shifts.
    let opd = ((2.0 * n2) * thickness) * cos2;
    let phi = Vec3::splat(phi21) + phi23;
    let r123 = (r12 * r23).clamp(Vec3::ZERO, Vec3::splat(0.9999));
    let r123_sqrt = sqrt3(r123);
    let rs = ((t121 * t121) * r23) / (Vec3::ONE - r123);
    // The incoherent (m = 0) term, then the first two interference orders.
    let mut sum = r12 + rs;
    let mut cm = rs - Vec3::splat(t121);
    for m in 1..=2 {
        cm *= r123_sqrt;
        let sm = film_sensitivity(m as f32 * opd, phi * m as f32) * 2.0;
        sum += cm * sm;
    }
    sum.clamp(Vec3::ZERO, Vec3::ONE)
}

/// The Fourier transform of the sRGB primaries' spectral sensitivities at
/// optical path difference `opd` (nm) with phase shifts `shift`: Gaussian
/// fits of the CIE 1931 matching functions (Belcour and Barla 2017), then
/// XYZ to linear Rec. 709.
pub(super) fn film_sensitivity(opd: f32, shift: Vec3) -> Vec3 {
    let phase = (2.0 * PI) * opd * 1.0e-9;
    let val = Vec3::new(5.4856e-13, 4.4201e-13, 5.2481e-13);
    let pos = Vec3::new(1.6810e6, 1.7953e6, 2.2084e6);
    let var = Vec3::new(4.3278e9, 9.3046e9, 6.6121e9);
    let gauss = |v: f32, p: f32, s: f32, sh: f32| {
        ((v * ((2.0 * PI) * s).sqrt()) * (p * phase + sh).cos()) * (-(phase * phase) * s).exp()
    };
    let mut xyz = Vec3::new(
        gauss(val.x, pos.x, var.x, shift.x),
        gauss(val.y, pos.y, var.y, shift.y),
        gauss(val.z, pos.z, var.z, shift.z),
    );
    xyz.x += gauss(9.7470e-14, 2.2399e6, 4.5282e9, shift.x);
    xyz /= 1.0685e-7;
    Vec3::new(
        (3.2404542 * xyz.x - 1.5371385 * xyz.y) - 0.4985314 * xyz.z,
        (-0.969266 * xyz.x + 1.8760108 * xyz.y) + 0.0415560 * xyz.z,
        (0.0556434 * xyz.x - 0.2040259 * xyz.y) + 1.0572252 * xyz.z,
    )
}

/// The dielectric layer's Fresnel at cosine `c` on wo's side: the coloured
/// Schlick of `fresnel_dielectric3`, mixed towards the thin film's by the
/// iridescence weight (the film taken at the cosine on the thinner side,
/// 1 under total internal reflection).
pub(super) fn layer_fresnel(d: &Dielectric, c: f32) -> Vec3 {
    let Some(ct) = thinner_side_cos(d.eta, c) else {
        return Vec3::ONE;
    };
    let f = d.f0_color + (Vec3::ONE - d.f0_color) * schlick_weight(ct);
    if !(d.iridescence > 0.0) {
        return f;
    }
    let film = thin_film_fresnel(d.iridescence_ior, ct, d.iridescence_thickness, d.f0_color);
    f + (film - f) * d.iridescence
}

/// The metal's Fresnel at cosine `c`: Schlick's from the base colour,
/// mixed towards the thin film's over it by the iridescence weight.
pub(super) fn metal_fresnel(p: &BsdfParams, d: &Dielectric, c: f32) -> Vec3 {
    let f = p.base + (Vec3::ONE - p.base) * schlick_weight(c);
    if !(d.iridescence > 0.0) {
        return f;
    }
    let film = thin_film_fresnel(d.iridescence_ior, c, d.iridescence_thickness, p.base);
    f + (film - f) * d.iridescence
}

/// The probabilities of the specular reflection, the specular
/// transmission and the diffuse transmission lobes (the diffuse reflection
/// lobe has the rest), with the dielectric extensions.
pub fn lobe_probabilities(p: &BsdfParams, d: &Dielectric, cos_o: f32) -> (f32, f32, f32) {
    let mut fo = p.specular * max3(layer_fresnel(d, cos_o));
    if p.energy_layering && d.eta < 1.0 {
        // Inside a volume the Fresnel at the normal is 1 beyond the
        // critical angle, where a rough lobe still refracts: the layer's
        // albedo, which leaves the refraction its share.
        let wo = Vec3::new((1.0 - cos_o * cos_o).max(0.0).sqrt(), 0.0, cos_o);
        fo = max3(super::layering::layer_albedo(p, Some(d), wo)).min(1.0);
    }
    let ws = p.metallic + (1.0 - p.metallic) * fo;
    let wb = ((1.0 - p.metallic) * luminance(p.base)) * (1.0 - fo);
    let wt = wb * d.transmission;
    let wd = (wb * (1.0 - d.transmission)) * (1.0 - d.diffuse_transmission);
    let wdt = (((1.0 - p.metallic) * luminance(d.diffuse_transmission_color)) * (1.0 - fo))
        * ((1.0 - d.transmission) * d.diffuse_transmission);
    let sum = ((ws + wt) + wd) + wdt;
    if sum > 0.0 {
        (ws / sum, wt / sum, wdt / sum)
    } else {
        (0.0, 0.0, 0.0)
    }
}

/// The diffuse transmission lobe (KHR_materials_diffuse_transmission) for
/// wi below the surface: Lambertian, of the extension's colour, weighted by
/// one minus the Fresnel the diffuse reflection lobe has at the mirror of
/// wi, so that moving the diffuse lobe's share across the surface moves
/// its energy exactly.
pub(super) fn diffuse_transmission_eval(
    p: &BsdfParams,
    d: &Dielectric,
    wo: Vec3,
    wi: Vec3,
) -> Vec3 {
    let weight = ((1.0 - p.metallic) * (1.0 - d.transmission)) * d.diffuse_transmission;
    if !(weight > 0.0) {
        return Vec3::ZERO;
    }
    let hv = wo + Vec3::new(wi.x, wi.y, -wi.z);
    let hl = hv.length();
    if hl == 0.0 {
        return Vec3::ZERO;
    }
    if energy_layered(p, Some(d)) {
        let mirror = Vec3::new(wi.x, wi.y, -wi.z);
        return d.diffuse_transmission_color
            * lambert_scaling(p, Some(d), wo, mirror)
            * (weight * INV_PI);
    }
    let voh = wo.dot(hv / hl).max(0.0);
    let fd = max3(p.specular * layer_fresnel(d, voh));
    d.diffuse_transmission_color * ((weight * (1.0 - fd)) * INV_PI)
}

/// The half vector of a refraction from wo (z > 0) to wi (z < 0) with
/// relative index eta, and its cosines with wo and wi; `None` when the
/// pair cannot be a refraction through a front-facing microfacet.
pub(super) fn refraction_half(eta: f32, wo: Vec3, wi: Vec3) -> Option<(Vec3, f32, f32)> {
    let hv = wo + wi * eta;
    let hl = hv.length();
    if !(hl > 0.0) {
        return None;
    }
    let mut h = hv / hl;
    if h.z < 0.0 {
        h = -h;
    }
    let oh = wo.dot(h);
    let ih = wi.dot(h);
    if !(oh > 0.0) || !(ih < 0.0) {
        return None;
    }
    Some((h, oh, ih))
}

const EON_C1: f32 = 0.5 - 2.0 / (3.0 * PI);
const EON_C2: f32 = 2.0 / 3.0 - 28.0 / (15.0 * PI);

/// Fujii's Oren-Nayar directional albedo at cosine `mu` and roughness `r`,
/// the EON paper's polynomial fit.
pub fn eon_fon_albedo(mu: f32, r: f32) -> f32 {
    let m = 1.0 - mu;
    let g = m * (0.057_108_53 + m * (0.491_881_87 + m * (-0.332_181_44 + m * 0.071_442_99)));
    (1.0 + r * g) / (1.0 + EON_C1 * r)
}

/// KHR_materials_diffuse_roughness's lobe: the energy-preserving
/// Oren-Nayar BRDF (EON: Portsmouth, Kutz and Hill 2024, Listing 1, as
/// OpenPBR's diffuse) of albedo `rho` and roughness `r`, for wo and wi
/// above the surface: Fujii's Oren-Nayar single scattering plus the
/// multiple scattering that makes a white lobe reflect everything. It
/// stands where Lambert's `rho / pi` would.
pub fn eon_eval(rho: Vec3, r: f32, wo: Vec3, wi: Vec3) -> Vec3 {
    let s = wi.dot(wo) - wi.z * wo.z;
    let s_over_t = if s > 0.0 { s / wi.z.max(wo.z) } else { s };
    let af = 1.0 / (1.0 + EON_C1 * r);
    let single = rho * ((INV_PI * af) * (1.0 + r * s_over_t));
    let e_avg = af * (1.0 + EON_C2 * r);
    let rho_ms = ((rho * rho) * e_avg) / (Vec3::ONE - rho * (1.0 - e_avg));
    let k = ((1.0 - eon_fon_albedo(wo.z, r)).max(1.0e-7)
        * (1.0 - eon_fon_albedo(wi.z, r)).max(1.0e-7))
        / (1.0 - e_avg).max(1.0e-7);
    single + rho_ms * (INV_PI * k)
}

/// The dielectric's diffuse reflection lobe for wi above the surface,
/// under the specular layer of Fresnel `layer` at the half vector; before
/// the (1 - metallic) mix. Lambert's, or with a diffuse roughness EON's.
pub(super) fn dielectric_diffuse(
    p: &BsdfParams,
    d: &Dielectric,
    wo: Vec3,
    wi: Vec3,
    layer: Vec3,
) -> Vec3 {
    if d.diffuse_roughness > 0.0 {
        let f = eon_eval(p.base, d.diffuse_roughness, wo, wi);
        // Under the layer it keeps 1 - E_spec(wo) (see the kernel's
        // dielectric_diffuse for why not Lambert's reciprocal scaling).
        return if energy_layered(p, Some(d)) {
            f * layer_transmittance(p, Some(d), wo) * diffuse_share(d, 0.0)
        } else {
            f * diffuse_share(d, max3(layer))
        };
    }
    if energy_layered(p, Some(d)) {
        p.base * lambert_scaling(p, Some(d), wo, wi) * (diffuse_share(d, 0.0) * INV_PI)
    } else {
        p.base * (diffuse_share(d, max3(layer)) * INV_PI)
    }
}

pub(super) fn dielectric_eval(p: &BsdfParams, d: &Dielectric, wo: Vec3, wi: Vec3) -> Vec3 {
    if wo.z <= 0.0 || wi.z == 0.0 {
        return Vec3::ZERO;
    }
    if wi.z > 0.0 {
        let hv = wo + wi;
        let hl = hv.length();
        if hl == 0.0 {
            return Vec3::ZERO;
        }
        let h = hv / hl;
        let voh = wo.dot(h).max(0.0);
        let dd = spec_d(p, h);
        let g2 = 1.0 / ((1.0 + spec_lambda(p, wo)) + spec_lambda(p, wi));
        let s = if spec_smooth(p) {
            0.0
        } else {
            (dd * g2) / ((4.0 * wo.z) * wi.z)
        };
        let layer = p.specular * layer_fresnel(d, voh);
        let fm = metal_fresnel(p, d, voh);
        let diffuse = dielectric_diffuse(p, d, wo, wi, layer);
        if p.energy_compensation {
            let ms = 1.0 / spec_albedo(p, wo) - 1.0;
            let f0 = super::layering::reflection_compensation_f0(p, d, wo);
            let dielectric = diffuse + (layer * s) * (Vec3::ONE + f0 * ms);
            let metal = fm * s * (Vec3::ONE + p.base * ms);
            return dielectric * (1.0 - p.metallic) + metal * p.metallic;
        }
        let dielectric = diffuse + layer * s;
        let metal = fm * s;
        return dielectric * (1.0 - p.metallic) + metal * p.metallic;
    }
    let diffuse = diffuse_transmission_eval(p, d, wo, wi);
    let weight = (1.0 - p.metallic) * d.transmission;
    if !(weight > 0.0) || spec_smooth(p) {
        return diffuse;
    }
    if d.thin {
        // The reflection lobe mirrored through the surface.
        let r = Vec3::new(wi.x, wi.y, -wi.z);
        let hv = wo + r;
        let hl = hv.length();
        if hl == 0.0 {
            return Vec3::ZERO;
        }
        let h = hv / hl;
        let voh = wo.dot(h).max(0.0);
        let dd = spec_d(p, h);
        let g2 = 1.0 / ((1.0 + spec_lambda(p, wo)) + spec_lambda(p, r));
        let s = (dd * g2) / ((4.0 * wo.z) * r.z);
        if energy_layered(p, Some(d)) {
            // The white lobe, compensated to albedo 1, under the layer.
            let s = if p.energy_compensation {
                s / spec_albedo(p, wo)
            } else {
                s
            };
            return p.base * layer_transmittance(p, Some(d), wo) * (weight * s) + diffuse;
        }
        // Thin-walled: eta is 1.
        let fd = p.specular * max3(layer_fresnel(d, voh));
        return p.base * ((weight * (1.0 - fd)) * s) + diffuse;
    }
    let Some((h, oh, ih)) = refraction_half(d.eta, wo, wi) else {
        return diffuse;
    };
    let denom = ih + oh / d.eta;
    let g2 = 1.0 / ((1.0 + spec_lambda(p, wo)) + spec_lambda(p, wi));
    if p.energy_layering {
        // The Fresnel-less lobe under the layer.
        let ft = ((spec_d(p, h) * g2) * ((ih * oh) / (((denom * denom) * wi.z) * wo.z))).abs()
            / (d.eta * d.eta);
        return p.base * refraction_scaling(p, d, wo) * (weight * ft) + diffuse;
    }
    let fd = p.specular * max3(layer_fresnel(d, oh));
    let ft = (((spec_d(p, h) * (1.0 - fd)) * g2) * ((ih * oh) / (((denom * denom) * wi.z) * wo.z)))
        .abs()
        / (d.eta * d.eta);
    p.base * (weight * ft) + diffuse
}

/// The diffuse reflection lobe's weight after the specular layer's
/// Fresnel `fd`: what neither transmission takes.
pub(super) fn diffuse_share(d: &Dielectric, fd: f32) -> f32 {
    ((1.0 - fd) * (1.0 - d.transmission)) * (1.0 - d.diffuse_transmission)
}

pub(super) fn dielectric_pdf(p: &BsdfParams, d: &Dielectric, wo: Vec3, wi: Vec3) -> f32 {
    if wo.z <= 0.0 || wi.z == 0.0 {
        return 0.0;
    }
    let (ps, pt, pdt) = lobe_probabilities(p, d, wo.z);
    if wi.z > 0.0 {
        let spec = if ps > 0.0 && !spec_smooth(p) {
            spec_vndf_pdf(p, wo, wi)
        } else {
            0.0
        };
        return ps * spec + (((1.0 - ps) - pt) - pdt) * (wi.z * INV_PI);
    }
    let diffuse = pdt * (-wi.z * INV_PI);
    if !(pt > 0.0) || spec_smooth(p) {
        return diffuse;
    }
    if d.thin {
        return pt * spec_vndf_pdf(p, wo, Vec3::new(wi.x, wi.y, -wi.z)) + diffuse;
    }
    let Some((h, oh, ih)) = refraction_half(d.eta, wo, wi) else {
        return diffuse;
    };
    let g1 = 1.0 / (1.0 + spec_lambda(p, wo));
    let pdf_h = ((g1 * spec_d(p, h)) * oh) / wo.z;
    let denom = ih + oh / d.eta;
    pt * (pdf_h * (-ih / (denom * denom))) + diffuse
}

pub(super) fn dielectric_sample(
    p: &BsdfParams,
    d: &Dielectric,
    wo: Vec3,
    lobe_u: f32,
    u1: f32,
    u2: f32,
) -> Option<BsdfSample> {
    if wo.z <= 0.0 {
        return None;
    }
    let (ps, pt, pdt) = lobe_probabilities(p, d, wo.z);
    if spec_smooth(p) && lobe_u < ps + pt {
        let (wi, value, pdf) = if lobe_u < ps {
            (
                Vec3::new(-wo.x, -wo.y, wo.z),
                smooth_reflectance(p, wo.z),
                ps,
            )
        } else {
            let weight = (1.0 - p.metallic) * d.transmission;
            let (wi, value) = if d.thin {
                (-wo, thin_straight_through(p, d, wo.z))
            } else {
                let c = wo.z;
                let s2t = (1.0 - c * c).max(0.0) / (d.eta * d.eta);
                if s2t >= 1.0 {
                    return None;
                }
                let ct = (1.0 - s2t).sqrt();
                let wi = -wo / d.eta + Vec3::Z * (c / d.eta - ct);
                if p.energy_layering {
                    let keep = layer_transmittance(p, Some(d), wo);
                    (wi, p.base * keep * (weight / (d.eta * d.eta)))
                } else {
                    let fd = p.specular * max3(layer_fresnel(d, c));
                    (wi, p.base * (weight * ((1.0 - fd) / (d.eta * d.eta))))
                }
            };
            if wi.z >= 0.0 {
                return None;
            }
            (wi, value, pt)
        };
        if !(pdf > 0.0) {
            return None;
        }
        return Some(BsdfSample {
            wi,
            f: value / wi.z.abs(),
            pdf,
            delta: true,
        });
    }
    let wi = if lobe_u < ps {
        let h = spec_sample_vndf(p, wo, u1, u2);
        let wi = h * (2.0 * wo.dot(h)) - wo;
        if wi.z <= 0.0 {
            return None;
        }
        wi
    } else if lobe_u < ps + pt {
        let h = spec_sample_vndf(p, wo, u1, u2);
        let c = wo.dot(h);
        let wi = if d.thin {
            let r = h * (2.0 * c) - wo;
            Vec3::new(r.x, r.y, -r.z)
        } else {
            if !(c > 0.0) {
                return None;
            }
            let s2t = (1.0 - c * c).max(0.0) / (d.eta * d.eta);
            if s2t >= 1.0 {
                return None;
            }
            let ct = (1.0 - s2t).sqrt();
            -wo / d.eta + h * (c / d.eta - ct)
        };
        if wi.z >= 0.0 {
            return None;
        }
        wi
    } else if lobe_u < (ps + pt) + pdt {
        // Diffuse transmission: the cosine hemisphere below.
        let wi = sample_cosine_hemisphere(u1, u2);
        if wi.z <= 0.0 {
            return None;
        }
        Vec3::new(wi.x, wi.y, -wi.z)
    } else {
        let wi = sample_cosine_hemisphere(u1, u2);
        if wi.z <= 0.0 {
            return None;
        }
        wi
    };
    let pdf = dielectric_pdf(p, d, wo, wi);
    if !(pdf > 0.0) {
        return None;
    }
    Some(BsdfSample {
        wi,
        f: dielectric_eval(p, d, wo, wi),
        pdf,
        delta: false,
    })
}
