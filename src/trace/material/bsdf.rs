//! The plain Rust reference of the glTF metallic-roughness BSDF that
//! `kernels/trace/bsdf.h` mirrors operation for operation: the GGX lobes
//! (isotropic and anisotropic), the base BSDF, the clear coat and sheen
//! layers over it, and the entry points `bsdf_eval`, `bsdf_pdf` and
//! `bsdf_sample`. Each function mirrors the one of the same name in the
//! kernel.

// `!(x > 0.0)` is meant: it is also true for NaN, as in the kernels.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

use glam::Vec3;

use super::super::energy::{ggx_albedo, sheen_albedo};
use super::super::sampling::{
    cos_sin_turns, luminance, sample_cosine_hemisphere, sample_uniform_hemisphere, INV_PI, PI,
};

use super::dielectric::*;
use super::layering::{energy_layered, lambert_scaling};

/// The BSDF's parameters at one point (`BsdfParams`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfParams {
    pub base: Vec3,
    pub metallic: f32,
    /// GGX alpha (roughness squared, at least `MIN_GGX_ALPHA`): the base's
    /// specular lobe's along the shading frame's y axis.
    pub alpha: f32,
    /// The base's specular lobe's GGX alpha along the shading frame's x
    /// axis, which is KHR_materials_anisotropy's direction (kernels
    /// compiled with `HAS_ANISOTROPY`): `alpha` without anisotropy.
    pub alpha_t: f32,
    /// 1 for glTF materials, 0 for the pure Lambertian of `--clay`.
    pub specular: f32,
    /// The dielectric extensions (kernels compiled with
    /// `HAS_TRANSMISSION`); `None`: the base model exactly as without.
    pub dielectric: Option<Dielectric>,
    /// Turquin's multiple-scattering compensation of the GGX reflection
    /// lobes (kernels compiled with `GGX_ENERGY_COMPENSATION`).
    pub energy_compensation: bool,
    /// The energy-conserving layering of the base under the specular layer
    /// and the sheen (kernels compiled with `ENERGY_LAYERING`, the default
    /// `--layering energy`); false: the specification's `fresnel_mix`.
    pub energy_layering: bool,
    /// The clear coat and sheen layers over the base (kernels compiled
    /// with `HAS_CLEARCOAT` or `HAS_SHEEN`); `None`: the base alone.
    pub layers: Option<Layers>,
}

/// KHR_materials_clearcoat and KHR_materials_sheen at one point.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Layers {
    /// `clearcoatFactor` (0: no coat).
    pub clearcoat: f32,
    /// The coat's GGX alpha (`clearcoatRoughnessFactor` squared).
    pub coat_alpha: f32,
    /// `sheenColorFactor` (black: no sheen).
    pub sheen_color: Vec3,
    /// `sheenRoughnessFactor`.
    pub sheen_roughness: f32,
    /// The coat's normal in the base's shading frame (z: the base's
    /// shading normal): the interpolated vertex normal, or
    /// `clearcoatNormalTexture` applied to it, since the extension keeps
    /// the base's normal map off the coat. `Vec3::Z` exactly: the base's.
    pub coat_normal: Vec3,
}

impl Layers {
    pub fn new(
        clearcoat: f32,
        coat_roughness: f32,
        sheen_color: [f32; 3],
        sheen_roughness: f32,
    ) -> Layers {
        Layers {
            clearcoat: clearcoat.clamp(0.0, 1.0),
            coat_alpha: ggx_alpha(coat_roughness),
            sheen_color: Vec3::from(sheen_color).clamp(Vec3::ZERO, Vec3::ONE),
            sheen_roughness: sheen_roughness.clamp(0.0, 1.0),
            coat_normal: Vec3::Z,
        }
    }

    /// With the coat's own normal `n` (unit, in the base's shading frame).
    pub fn with_coat_normal(self, n: Vec3) -> Layers {
        Layers {
            coat_normal: n,
            ..self
        }
    }
}

/// The coat's frame (`coat_frame` in kernels/trace/bsdf.h): tangents around the
/// coat normal, `None` when it is the base's (then vectors are used as
/// they are, so a coat without its own normal is exactly the base frame).
pub(super) fn coat_frame(l: &Layers) -> Option<(Vec3, Vec3, Vec3)> {
    let n = l.coat_normal;
    if n.x == 0.0 && n.y == 0.0 {
        return None;
    }
    let (t, b) = crate::trace::sampling::onb(n);
    Some((t, b, n))
}

/// `v` (base frame) in the coat's frame.
pub(super) fn to_coat(f: Option<(Vec3, Vec3, Vec3)>, v: Vec3) -> Vec3 {
    match f {
        None => v,
        Some((t, b, n)) => Vec3::new(v.dot(t), v.dot(b), v.dot(n)),
    }
}

/// `v` (coat frame) in the base's frame.
pub(super) fn from_coat(f: Option<(Vec3, Vec3, Vec3)>, v: Vec3) -> Vec3 {
    match f {
        None => v,
        Some((t, b, n)) => (t * v.x + b * v.y) + n * v.z,
    }
}

pub const MIN_GGX_ALPHA: f32 = 1.0e-3;

/// At or below this alpha the GGX lobes are delta lobes (pbrt-v4's
/// `EffectivelySmooth`): `bsdf_eval` and `bsdf_pdf` leave them out and
/// `bsdf_sample` picks their exact direction. Evaluated as GGX at alpha 1e-3
/// they gave light sampling rare ~1/(pi alpha^2) fireflies.
pub const SMOOTH_GGX_ALPHA: f32 = 1.0e-3;

/// Whether a GGX lobe of this alpha is a delta lobe.
pub fn ggx_smooth(alpha: f32) -> bool {
    alpha <= SMOOTH_GGX_ALPHA
}

impl BsdfParams {
    pub fn new(base: [f32; 3], metallic: f32, roughness: f32) -> BsdfParams {
        BsdfParams {
            base: Vec3::from(base),
            metallic: metallic.clamp(0.0, 1.0),
            alpha: ggx_alpha(roughness),
            alpha_t: ggx_alpha(roughness),
            specular: 1.0,
            dielectric: None,
            energy_compensation: false,
            energy_layering: false,
            layers: None,
        }
    }

    /// With the clear coat and sheen layers.
    pub fn with_layers(self, l: Layers) -> BsdfParams {
        BsdfParams {
            layers: Some(l),
            ..self
        }
    }

    /// With the dielectric extensions' parameters.
    pub fn with_dielectric(self, d: Dielectric) -> BsdfParams {
        BsdfParams {
            dielectric: Some(d),
            ..self
        }
    }

    /// With KHR_materials_anisotropy's strength (clamped to 0..1; the
    /// extension texture's blue already applied): the alpha along the
    /// anisotropy direction becomes `anisotropic_alpha`.
    pub fn with_anisotropy(self, strength: f32) -> BsdfParams {
        BsdfParams {
            alpha_t: anisotropic_alpha(self.alpha, strength),
            ..self
        }
    }

    /// `--clay`: white Lambertian of albedo 0.8.
    pub fn clay() -> BsdfParams {
        BsdfParams {
            base: Vec3::splat(0.8),
            metallic: 0.0,
            alpha: 1.0,
            alpha_t: 1.0,
            specular: 0.0,
            dielectric: None,
            energy_compensation: false,
            energy_layering: false,
            layers: None,
        }
    }
}

/// KHR_materials_anisotropy's `alphaT`: `mix(alpha, 1, strength^2)`
/// along the anisotropy direction (the alpha across it stays `alpha`).
/// Strength 0 returns `alpha` itself, so the lobe stays isotropic bit for
/// bit. Mirrors `anisotropic_alpha` in kernels/trace/bsdf.h.
pub fn anisotropic_alpha(alpha: f32, strength: f32) -> f32 {
    let s = strength.clamp(0.0, 1.0);
    if s > 0.0 {
        alpha + (1.0 - alpha) * (s * s)
    } else {
        alpha
    }
}

pub fn ggx_alpha(roughness: f32) -> f32 {
    let r = roughness.clamp(0.0, 1.0);
    (r * r).max(MIN_GGX_ALPHA)
}

pub(super) fn ggx_d(a: f32, cos_h: f32) -> f32 {
    let a2 = a * a;
    let c2 = cos_h * cos_h;
    let k = c2 * (a2 - 1.0) + 1.0;
    a2 / ((PI * k) * k)
}

pub(super) fn ggx_lambda(a: f32, c: f32) -> f32 {
    let c2 = c * c;
    let t2 = (1.0 - c2).max(0.0) / c2;
    ((1.0 + (a * a) * t2).sqrt() - 1.0) * 0.5
}

/// Anisotropic GGX (Heitz 2014, eq. 85): alpha `ax` along x, `ay` along y,
/// at the unit half vector `h`.
pub(super) fn ggx_d_aniso(ax: f32, ay: f32, h: Vec3) -> f32 {
    let x = h.x / ax;
    let y = h.y / ay;
    let k = (x * x + y * y) + h.z * h.z;
    1.0 / (((PI * ax) * ay) * (k * k))
}

/// Smith's Lambda of anisotropic GGX at the unit direction `w`: the
/// isotropic one with the alpha projected on `w`'s azimuth.
pub(super) fn ggx_lambda_aniso(ax: f32, ay: f32, w: Vec3) -> f32 {
    let (x, y) = (ax * w.x, ay * w.y);
    let t2 = (x * x + y * y) / (w.z * w.z);
    ((1.0 + t2).sqrt() - 1.0) * 0.5
}

/// The base's specular microfacet lobe: GGX with `alpha_t` along the
/// shading frame's x axis and `alpha` along y. Equal alphas take the
/// isotropic formulas, so a material without anisotropy gives the bits it
/// gave before anisotropy existed. Twins of the `spec_*` in kernels/trace/bsdf.h.
pub(super) fn spec_isotropic(p: &BsdfParams) -> bool {
    p.alpha_t == p.alpha
}

/// Whether the base's specular lobe is a delta lobe: smooth both ways.
pub(super) fn spec_smooth(p: &BsdfParams) -> bool {
    ggx_smooth(p.alpha.max(p.alpha_t))
}

pub(super) fn spec_d(p: &BsdfParams, h: Vec3) -> f32 {
    if spec_isotropic(p) {
        ggx_d(p.alpha, h.z)
    } else {
        ggx_d_aniso(p.alpha_t, p.alpha, h)
    }
}

pub(super) fn spec_lambda(p: &BsdfParams, w: Vec3) -> f32 {
    if spec_isotropic(p) {
        ggx_lambda(p.alpha, w.z)
    } else {
        ggx_lambda_aniso(p.alpha_t, p.alpha, w)
    }
}

pub(super) fn spec_vndf_pdf(p: &BsdfParams, wo: Vec3, wi: Vec3) -> f32 {
    if spec_isotropic(p) {
        return ggx_vndf_pdf(p.alpha, wo, wi);
    }
    let hv = wo + wi;
    let hl = hv.length();
    if hl == 0.0 {
        return 0.0;
    }
    let h = hv / hl;
    (spec_d(p, h) / (1.0 + spec_lambda(p, wo))) / (4.0 * wo.z)
}

pub(super) fn spec_sample_vndf(p: &BsdfParams, wo: Vec3, u1: f32, u2: f32) -> Vec3 {
    ggx_sample_vndf(p.alpha_t, p.alpha, wo, u1, u2)
}

/// The white single-scattering albedo of the base's specular lobe at `wo`
/// (Turquin's compensation); anisotropic: `energy::anisotropic_albedo`.
pub(super) fn spec_albedo(p: &BsdfParams, wo: Vec3) -> f32 {
    if spec_isotropic(p) {
        return ggx_albedo(p.alpha, wo.z);
    }
    crate::trace::energy::anisotropic_albedo(p.alpha_t, p.alpha, wo.to_array())
}

/// The probability of sampling the specular lobe.
pub fn spec_probability(p: &BsdfParams, cos_o: f32) -> f32 {
    let fd = p.specular * (0.04 + 0.96 * schlick_weight(cos_o));
    let ws = p.metallic + (1.0 - p.metallic) * fd;
    let wd = ((1.0 - p.metallic) * luminance(p.base)) * (1.0 - fd);
    let sum = ws + wd;
    if sum > 0.0 {
        ws / sum
    } else {
        0.0
    }
}

/// The base's diffuse reflection lobe under a specular layer of Fresnel
/// `fd` at the half vector; before the (1 - metallic) mix.
fn base_diffuse(p: &BsdfParams, wo: Vec3, wi: Vec3, fd: f32) -> Vec3 {
    if energy_layered(p, None) {
        p.base * INV_PI * lambert_scaling(p, None, wo, wi)
    } else {
        p.base * ((1.0 - fd) * INV_PI)
    }
}

/// The base BSDF (without the coat and sheen layers).
pub(super) fn base_eval(p: &BsdfParams, wo: Vec3, wi: Vec3) -> Vec3 {
    if let Some(d) = &p.dielectric {
        return dielectric_eval(p, d, wo, wi);
    }
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return Vec3::ZERO;
    }
    // Pure Lambert (--clay): the same value as below, without the lobe.
    if p.specular == 0.0 && p.metallic == 0.0 {
        return p.base * INV_PI;
    }
    let hv = wo + wi;
    let hl = hv.length();
    if hl == 0.0 {
        return Vec3::ZERO;
    }
    let h = hv / hl;
    let voh = wo.dot(h).max(0.0);
    let d = spec_d(p, h);
    let g2 = 1.0 / ((1.0 + spec_lambda(p, wo)) + spec_lambda(p, wi));
    let s = if spec_smooth(p) {
        0.0
    } else {
        (d * g2) / ((4.0 * wo.z) * wi.z)
    };
    let w = schlick_weight(voh);
    let fd = p.specular * (0.04 + 0.96 * w);
    let fm = p.base + (Vec3::ONE - p.base) * w;
    let diffuse = base_diffuse(p, wo, wi, fd);
    if p.energy_compensation {
        let dielectric =
            diffuse + Vec3::splat(fd * s) * (1.0 + 0.04 * (1.0 / spec_albedo(p, wo) - 1.0));
        let metal = fm * s * (Vec3::ONE + p.base * (1.0 / spec_albedo(p, wo) - 1.0));
        return dielectric * (1.0 - p.metallic) + metal * p.metallic;
    }
    let dielectric = diffuse + Vec3::splat(fd * s);
    let metal = fm * s;
    dielectric * (1.0 - p.metallic) + metal * p.metallic
}

pub(super) fn ggx_vndf_pdf(a: f32, wo: Vec3, wi: Vec3) -> f32 {
    let hv = wo + wi;
    let hl = hv.length();
    if hl == 0.0 {
        return 0.0;
    }
    let h = hv / hl;
    let g1 = 1.0 / (1.0 + ggx_lambda(a, wo.z));
    (g1 * ggx_d(a, h.z)) / (4.0 * wo.z)
}

/// The pdf of `base_sample`.
pub(super) fn base_pdf(p: &BsdfParams, wo: Vec3, wi: Vec3) -> f32 {
    if let Some(d) = &p.dielectric {
        return dielectric_pdf(p, d, wo, wi);
    }
    if wo.z <= 0.0 || wi.z <= 0.0 {
        return 0.0;
    }
    if p.specular == 0.0 && p.metallic == 0.0 {
        return wi.z * INV_PI;
    }
    let ps = spec_probability(p, wo.z);
    let spec = if ps > 0.0 && !spec_smooth(p) {
        spec_vndf_pdf(p, wo, wi)
    } else {
        0.0
    };
    ps * spec + (1.0 - ps) * (wi.z * INV_PI)
}

/// Heitz's visible-normal sampling, for alpha `ax` along x and `ay` along y.
pub(super) fn ggx_sample_vndf(ax: f32, ay: f32, wo: Vec3, u1: f32, u2: f32) -> Vec3 {
    let vh = Vec3::new(ax * wo.x, ay * wo.y, wo.z).normalize();
    let lensq = vh.x * vh.x + vh.y * vh.y;
    let t1 = if lensq > 0.0 {
        Vec3::new(-vh.y, vh.x, 0.0) / lensq.sqrt()
    } else {
        Vec3::X
    };
    let t2 = vh.cross(t1);
    let r = u1.sqrt();
    let (c, s) = cos_sin_turns(u2);
    let p1 = r * c;
    let mut p2 = r * s;
    let s = 0.5 * (1.0 + vh.z);
    p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * p2;
    let nh = (t1 * p1 + t2 * p2) + vh * ((1.0 - p1 * p1) - p2 * p2).max(0.0).sqrt();
    Vec3::new(ax * nh.x, ay * nh.y, nh.z.max(0.0)).normalize()
}

/// A sampled direction: wi, the BSDF value and the mixture pdf; from a
/// delta lobe (`delta`), f is the lobe's reflectance over |wi.z| and pdf the
/// lobe's selection probability, so f |wi.z| / pdf is the weight either way.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    pub wi: Vec3,
    pub f: Vec3,
    pub pdf: f32,
    pub delta: bool,
}

/// The reflectance of the smooth (delta) reflection lobe for outgoing
/// cosine c: the GGX reflection terms of `bsdf_eval` with the microfacet
/// lobe integrated to 1 (h = n, so v.h = c).
pub fn smooth_reflectance(p: &BsdfParams, c: f32) -> Vec3 {
    let w = schlick_weight(c);
    let fm = p.base + (Vec3::ONE - p.base) * w;
    if let Some(d) = &p.dielectric {
        let layer = p.specular * layer_fresnel(d, c);
        let fm = metal_fresnel(p, d, c);
        let (dielectric, metal) = if p.energy_compensation {
            let ms = 1.0 / ggx_albedo(p.alpha, c) - 1.0;
            (
                layer * (Vec3::ONE + d.f0_color * ms),
                fm * (Vec3::ONE + p.base * ms),
            )
        } else {
            (layer, fm)
        };
        return dielectric * (1.0 - p.metallic) + metal * p.metallic;
    }
    let fd = p.specular * (0.04 + 0.96 * w);
    let (dielectric, metal) = if p.energy_compensation {
        (
            Vec3::splat(fd) * (1.0 + 0.04 * (1.0 / ggx_albedo(p.alpha, c) - 1.0)),
            fm * (Vec3::ONE + p.base * (1.0 / ggx_albedo(p.alpha, c) - 1.0)),
        )
    } else {
        (Vec3::splat(fd), fm)
    };
    dielectric * (1.0 - p.metallic) + metal * p.metallic
}

/// `bsdf_only_delta` of the base BSDF.
pub(super) fn base_only_delta(p: &BsdfParams) -> bool {
    if !spec_smooth(p) {
        return false;
    }
    if p.metallic >= 1.0 {
        return true;
    }
    if let Some(d) = &p.dielectric {
        if d.transmission >= 1.0 {
            return true;
        }
        if d.transmits_diffusely() {
            return false;
        }
    }
    !(p.base.x > 0.0 || p.base.y > 0.0 || p.base.z > 0.0)
}

/// The smooth thin-walled transmission lobe's reflectance at outgoing
/// cosine `c` (straight through, unbent): what `base_sample`'s delta lobe
/// carries. A shadow ray crossing such a surface keeps this times the
/// layers' scaling of the base (`layered_straight_through`).
pub fn thin_straight_through(p: &BsdfParams, d: &Dielectric, c: f32) -> Vec3 {
    let weight = (1.0 - p.metallic) * d.transmission;
    if energy_layered(p, Some(d)) {
        let keep = super::layering::layer_transmittance(p, Some(d), Vec3::new(0.0, 0.0, c));
        return p.base * keep * weight;
    }
    let fd = p.specular * max3(layer_fresnel(d, c));
    p.base * (weight * (1.0 - fd))
}

/// Samples the base BSDF.
pub(super) fn base_sample(
    p: &BsdfParams,
    wo: Vec3,
    lobe_u: f32,
    u1: f32,
    u2: f32,
) -> Option<BsdfSample> {
    if let Some(d) = &p.dielectric {
        return dielectric_sample(p, d, wo, lobe_u, u1, u2);
    }
    if wo.z <= 0.0 {
        return None;
    }
    let ps = spec_probability(p, wo.z);
    // Pure Lambert (--clay) has no specular lobe: ps is 0.
    if lobe_u < ps && spec_smooth(p) {
        return Some(BsdfSample {
            wi: Vec3::new(-wo.x, -wo.y, wo.z),
            f: smooth_reflectance(p, wo.z) / wo.z,
            pdf: ps,
            delta: true,
        });
    }
    let wi = if lobe_u < ps {
        let h = spec_sample_vndf(p, wo, u1, u2);
        h * (2.0 * wo.dot(h)) - wo
    } else {
        sample_cosine_hemisphere(u1, u2)
    };
    if wi.z <= 0.0 {
        return None;
    }
    let pdf = base_pdf(p, wo, wi);
    if !(pdf > 0.0) {
        return None;
    }
    Some(BsdfSample {
        wi,
        f: base_eval(p, wo, wi),
        pdf,
        delta: false,
    })
}

/// The sheen distribution's roughness floor: the Charlie distribution's
/// exponent is 1 / roughness (the glTF sample viewer's floor too).
pub const SHEEN_MIN_ROUGHNESS: f32 = 0.07;

/// The clear coat's Fresnel weight at cosine `c` with the view: Schlick's
/// for ior 1.5 (the extension's `fresnel_coat` uses N.V, not V.H).
pub(super) fn coat_fresnel(c: f32) -> f32 {
    0.04 + 0.96 * schlick_weight(c)
}

/// The coat's share `clearcoat * Fc(cos_o)` of what leaves towards wo: the
/// weight of the coat lobe and the probability of sampling it.
pub(super) fn coat_weight(l: &Layers, cos_o: f32) -> f32 {
    (l.clearcoat * coat_fresnel(cos_o)).clamp(0.0, 1.0)
}

/// The coat's white GGX lobe D G2 / (4 |n.l| |n.v|) about the coat's
/// normal (0 when smooth: a delta lobe), energy-compensated to albedo 1
/// (its Fresnel is outside, in the mix: F0 = 1 in Turquin's factor) with
/// `GGX_ENERGY_COMPENSATION`. `wo`, `wi` are in the base's frame; the lobe
/// is scaled by (coat n.l) / (base n.l), so that with the renderer's
/// base-frame cosine it reflects as a lobe about its own normal would (and
/// a tilted coat keeps its albedo but for what falls below the surface).
pub(super) fn coat_lobe(p: &BsdfParams, l: &Layers, wo: Vec3, wi: Vec3) -> f32 {
    if !(wi.z > 0.0) || ggx_smooth(l.coat_alpha) {
        return 0.0;
    }
    let f = coat_frame(l);
    let (wo, wi_c) = (to_coat(f, wo), to_coat(f, wi));
    if !(wo.z > 0.0) || !(wi_c.z > 0.0) {
        return 0.0;
    }
    let hv = wo + wi_c;
    let hl = hv.length();
    if hl == 0.0 {
        return 0.0;
    }
    let h = hv / hl;
    let a = l.coat_alpha;
    let g2 = 1.0 / ((1.0 + ggx_lambda(a, wo.z)) + ggx_lambda(a, wi_c.z));
    let s = (ggx_d(a, h.z) * g2) / ((4.0 * wo.z) * wi_c.z);
    let s = if p.energy_compensation {
        s / ggx_albedo(a, wo.z)
    } else {
        s
    };
    if f.is_some() {
        s * (wi_c.z / wi.z)
    } else {
        s
    }
}

/// The view's cosine with the coat's normal.
pub(super) fn coat_cos(l: &Layers, wo: Vec3) -> f32 {
    to_coat(coat_frame(l), wo).z
}

/// The smooth coat's reflectance towards the mirror direction (its lobe
/// integrated to 1, compensated as `coat_lobe`).
pub(super) fn coat_smooth_reflectance(p: &BsdfParams, l: &Layers, cos_o: f32) -> f32 {
    let w = coat_weight(l, cos_o);
    if p.energy_compensation {
        w / ggx_albedo(l.coat_alpha, cos_o)
    } else {
        w
    }
}

/// The Charlie sheen's Lambda: the extension's fit `l` of Estevez and Kulla.
pub(super) fn sheen_l(x: f32, a: f32) -> f32 {
    let t = (1.0 - a) * (1.0 - a);
    let mix = |p1: f32, p0: f32| p1 + (p0 - p1) * t;
    mix(21.5473, 25.3245) / (1.0 + mix(3.82987, 3.32435) * x.powf(mix(0.19823, 0.16801)))
        + mix(-1.9776, -1.27393) * x
        + mix(-4.32054, -4.85967)
}

pub(super) fn sheen_lambda(c: f32, a: f32) -> f32 {
    if c < 0.5 {
        sheen_l(c, a).exp()
    } else {
        (2.0 * sheen_l(0.5, a) - sheen_l(1.0 - c, a)).exp()
    }
}

/// The white Charlie sheen lobe D V of KHR_materials_sheen (Estevez and
/// Kulla 2017: D = (2 + 1/a) sin^(1/a)(h) / (2 pi), a = sheen roughness; V
/// = 1 / ((1 + Lambda(wo) + Lambda(wi)) 4 |n.v| |n.l|)), 0 below.
pub fn sheen_lobe(roughness: f32, wo: Vec3, wi: Vec3) -> f32 {
    if !(wo.z > 0.0) || !(wi.z > 0.0) {
        return 0.0;
    }
    let hv = wo + wi;
    let hl = hv.length();
    if hl == 0.0 {
        return 0.0;
    }
    let ch = hv.z / hl;
    let a = roughness.max(SHEEN_MIN_ROUGHNESS);
    let s2 = (1.0 - ch * ch).max(0.0);
    let d = ((2.0 + 1.0 / a) * s2.powf(0.5 / a)) * (0.5 * INV_PI);
    d / (((1.0 + sheen_lambda(wo.z, a)) + sheen_lambda(wi.z, a)) * ((4.0 * wo.z) * wi.z))
}

/// The sheen's probability of being sampled: its albedo max(colour) E(cos_o).
pub(super) fn sheen_probability(l: &Layers, cos_o: f32) -> f32 {
    (max3(l.sheen_color) * sheen_albedo(l.sheen_roughness, cos_o)).clamp(0.0, 1.0)
}

/// The extension's albedo scaling of the base under the sheen,
/// min(1 - max(colour) E(n.v), 1 - max(colour) E(n.l)).
pub fn sheen_scaling(l: &Layers, cos_o: f32, cos_i: f32) -> f32 {
    let m = max3(l.sheen_color);
    (1.0 - m * sheen_albedo(l.sheen_roughness, cos_o))
        .min(1.0 - m * sheen_albedo(l.sheen_roughness, cos_i))
}

/// The base's scaling under the sheen: the extension's `sheen_scaling`,
/// or with the energy layering what the sheen leaves towards wo, 1 -
/// max(colour) E(n.v) (OpenPBR's albedo scaling of its fuzz), so that a
/// base that returns all it receives keeps the sum at 1 under it.
pub(super) fn sheen_base_scaling(p: &BsdfParams, l: &Layers, cos_o: f32, cos_i: f32) -> f32 {
    if p.energy_layering {
        1.0 - max3(l.sheen_color) * sheen_albedo(l.sheen_roughness, cos_o)
    } else {
        sheen_scaling(l, cos_o, cos_i)
    }
}

pub(super) fn layered_eval(p: &BsdfParams, l: &Layers, wo: Vec3, wi: Vec3) -> Vec3 {
    if !(wo.z > 0.0) {
        return Vec3::ZERO;
    }
    let base = base_eval(p, wo, wi);
    let under = base * sheen_base_scaling(p, l, wo.z, wi.z.abs())
        + l.sheen_color * sheen_lobe(l.sheen_roughness, wo, wi);
    let wc = coat_weight(l, coat_cos(l, wo));
    under * (1.0 - wc) + Vec3::splat(wc * coat_lobe(p, l, wo, wi))
}

pub(super) fn layered_pdf(p: &BsdfParams, l: &Layers, wo: Vec3, wi: Vec3) -> f32 {
    if !(wo.z > 0.0) {
        return 0.0;
    }
    let f = coat_frame(l);
    let (wo_c, wi_c) = (to_coat(f, wo), to_coat(f, wi));
    let pc = coat_weight(l, wo_c.z);
    let psh = sheen_probability(l, wo.z);
    let sheen = if wi.z > 0.0 { 0.5 * INV_PI } else { 0.0 };
    let coat = if wi.z > 0.0 && wi_c.z > 0.0 && pc > 0.0 && !ggx_smooth(l.coat_alpha) {
        ggx_vndf_pdf(l.coat_alpha, wo_c, wi_c)
    } else {
        0.0
    };
    (1.0 - pc) * (psh * sheen + (1.0 - psh) * base_pdf(p, wo, wi)) + pc * coat
}

pub(super) fn layered_sample(
    p: &BsdfParams,
    l: &Layers,
    wo: Vec3,
    lobe_u: f32,
    u1: f32,
    u2: f32,
) -> Option<BsdfSample> {
    if !(wo.z > 0.0) {
        return None;
    }
    let f = coat_frame(l);
    let wo_c = to_coat(f, wo);
    let pc = coat_weight(l, wo_c.z);
    let wi = if lobe_u < pc {
        if !(wo_c.z > 0.0) {
            return None;
        }
        if ggx_smooth(l.coat_alpha) {
            let wi = from_coat(f, Vec3::new(-wo_c.x, -wo_c.y, wo_c.z));
            if !(wi.z > 0.0) {
                return None;
            }
            return Some(BsdfSample {
                wi,
                f: Vec3::splat(coat_smooth_reflectance(p, l, wo_c.z) / wi.z),
                pdf: pc,
                delta: true,
            });
        }
        let h = ggx_sample_vndf(l.coat_alpha, l.coat_alpha, wo_c, u1, u2);
        let wi_c = h * (2.0 * wo_c.dot(h)) - wo_c;
        // Below the coat (its pdf there is 0) or below the surface.
        let wi = from_coat(f, wi_c);
        if !(wi_c.z > 0.0) || !(wi.z > 0.0) {
            return None;
        }
        wi
    } else {
        // The rest of lobe_u picks among the sheen and the base's lobes.
        let u = (lobe_u - pc) / (1.0 - pc);
        let psh = sheen_probability(l, wo.z);
        if u < psh {
            sample_uniform_hemisphere(u1, u2)
        } else {
            let s = base_sample(p, wo, (u - psh) / (1.0 - psh), u1, u2)?;
            if s.delta {
                let scale = sheen_base_scaling(p, l, wo.z, s.wi.z.abs()) * (1.0 - pc);
                return Some(BsdfSample {
                    wi: s.wi,
                    f: s.f * scale,
                    pdf: s.pdf * ((1.0 - pc) * (1.0 - psh)),
                    delta: true,
                });
            }
            s.wi
        }
    };
    if wi.z == 0.0 {
        return None;
    }
    let pdf = layered_pdf(p, l, wo, wi);
    if !(pdf > 0.0) {
        return None;
    }
    Some(BsdfSample {
        wi,
        f: layered_eval(p, l, wo, wi),
        pdf,
        delta: false,
    })
}

/// What a shadow ray crossing a smooth thin-walled surface keeps
/// (`bsdf_shadow_straight_through` in kernels/trace/bsdf.h): the straight-through
/// lobe as `bsdf_sample` carries it, under the coat and the sheen (for that
/// lobe wi = -wo, so both cosines are `wo.z`; the coat's is taken with its
/// own normal). `wo`: the ray's reverse direction in the shading frame.
pub fn shadow_straight_through(p: &BsdfParams, d: &Dielectric, wo: Vec3) -> Vec3 {
    let c = wo.z;
    let t = thin_straight_through(p, d, c);
    match &p.layers {
        Some(l) => t * ((1.0 - coat_weight(l, coat_cos(l, wo))) * sheen_base_scaling(p, l, c, c)),
        None => t,
    }
}

/// The BSDF (without the cosine) for local directions wo, wi (z = normal):
/// the base, under the sheen (albedo-scaled), under the clear coat
/// (`fresnel_coat`: mixed by clearcoat * Fc(n.v)).
pub fn bsdf_eval(p: &BsdfParams, wo: Vec3, wi: Vec3) -> Vec3 {
    match &p.layers {
        Some(l) => layered_eval(p, l, wo, wi),
        None => base_eval(p, wo, wi),
    }
}

/// The BSDF's value split into the lobes the light-path passes name:
/// `diffuse` (Lambertian reflection, diffuse transmission, sheen) and
/// `transmission` (GGX transmission, thin-walled or refracting); the
/// glossy part (specular reflection, metal, coat) is `total` less both.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LobeSplit {
    /// `bsdf_eval`'s value, bit for bit.
    pub total: Vec3,
    pub diffuse: Vec3,
    pub transmission: Vec3,
}

/// `base_eval` split into its lobes (kernel twin: base_bsdf_lobe_parts,
/// which leaves out the total).
fn base_eval_lobes(p: &BsdfParams, wo: Vec3, wi: Vec3) -> LobeSplit {
    let total = base_eval(p, wo, wi);
    let mut lobes = LobeSplit {
        total,
        diffuse: Vec3::ZERO,
        transmission: Vec3::ZERO,
    };
    if !(wo.z > 0.0) || wi.z == 0.0 {
        return lobes;
    }
    if let Some(d) = &p.dielectric {
        if wi.z < 0.0 {
            lobes.diffuse = diffuse_transmission_eval(p, d, wo, wi);
            lobes.transmission = (total - lobes.diffuse).max(Vec3::ZERO);
            return lobes;
        }
    } else if wi.z < 0.0 {
        return lobes;
    } else if p.specular == 0.0 && p.metallic == 0.0 {
        // Pure Lambert (--clay) is all diffuse.
        lobes.diffuse = total;
        return lobes;
    }
    let hv = wo + wi;
    let hl = hv.length();
    if hl == 0.0 {
        return lobes;
    }
    let voh = wo.dot(hv / hl).max(0.0);
    let diffuse = match &p.dielectric {
        Some(d) => dielectric_diffuse(p, d, wo, wi, p.specular * layer_fresnel(d, voh)),
        None => base_diffuse(p, wo, wi, p.specular * (0.04 + 0.96 * schlick_weight(voh))),
    };
    lobes.diffuse = diffuse * (1.0 - p.metallic);
    lobes
}

/// `bsdf_eval` split into its lobes (`LobeSplit`; kernel twins: bsdf_eval and
/// bsdf_lobe_parts): the sheen is diffuse, the coat glossy, and the layers
/// scale the base's parts as they scale the base.
pub fn bsdf_eval_lobes(p: &BsdfParams, wo: Vec3, wi: Vec3) -> LobeSplit {
    let total = bsdf_eval(p, wo, wi);
    if !(wo.z > 0.0) {
        return LobeSplit {
            total,
            diffuse: Vec3::ZERO,
            transmission: Vec3::ZERO,
        };
    }
    let base = base_eval_lobes(p, wo, wi);
    let (mut diffuse, mut transmission) = (base.diffuse, base.transmission);
    if let Some(l) = &p.layers {
        let scaling = sheen_base_scaling(p, l, wo.z, wi.z.abs());
        diffuse = diffuse * scaling + l.sheen_color * sheen_lobe(l.sheen_roughness, wo, wi);
        transmission *= scaling;
        let keep = 1.0 - coat_weight(l, coat_cos(l, wo));
        diffuse *= keep;
        transmission *= keep;
    }
    LobeSplit {
        total,
        diffuse,
        transmission,
    }
}

/// The solid-angle pdf of `bsdf_sample` producing wi.
pub fn bsdf_pdf(p: &BsdfParams, wo: Vec3, wi: Vec3) -> f32 {
    match &p.layers {
        Some(l) => layered_pdf(p, l, wo, wi),
        None => base_pdf(p, wo, wi),
    }
}

/// Samples wi for wo (`lobe_u` picks the lobe); `None` below the surface.
pub fn bsdf_sample(p: &BsdfParams, wo: Vec3, lobe_u: f32, u1: f32, u2: f32) -> Option<BsdfSample> {
    match &p.layers {
        Some(l) => layered_sample(p, l, wo, lobe_u, u1, u2),
        None => base_sample(p, wo, lobe_u, u1, u2),
    }
}

/// True when every lobe is a delta lobe: `bsdf_eval` is 0 for every pair
/// of directions, and the path tracer skips light sampling there.
pub fn bsdf_only_delta(p: &BsdfParams) -> bool {
    let layers_delta = p.layers.is_none_or(|l| {
        (!(l.clearcoat > 0.0) || ggx_smooth(l.coat_alpha)) && !(max3(l.sheen_color) > 0.0)
    });
    layers_delta && base_only_delta(p)
}
