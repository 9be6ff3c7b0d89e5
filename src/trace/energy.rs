//! Energy compensation for the single-scattering GGX lobes (Turquin,
//! "Practical multiple scattering compensation for microfacet models",
//! 2019): a lobe of normal reflectance F0 is scaled by
//! `1 + F0 (1 / E(mu_o) - 1)`, where E is the directional albedo of the
//! white (F = 1) single-scattering lobe. A white rough metal then returns
//! all it receives, as multiple bounces between microfacets would.
//!
//! E is tabulated over roughness and cosine (`ENERGY_SIZE` squared
//! entries) in `kernels/generated/ggx_energy.h`, made by `generate` here and held to
//! it by a test (`SOUPRAY_REGENERATE=1` rewrites it). The table is read by
//! both the kernels (`ggx_albedo` in `kernels/trace/bsdf.h`, under
//! `GGX_ENERGY_COMPENSATION`) and `ggx_albedo` below, from the same text.
//!
//! Anisotropic GGX (KHR_materials_anisotropy) takes the isotropic table at
//! the root-mean-square alpha times a correction tabulated over both
//! alphas, the cosine and the azimuth (`anisotropic_albedo`,
//! `kernels/generated/ggx_aniso_energy.h`), so a white brushed metal returns what it
//! receives too.
//!
//! The same for the KHR_materials_sheen layer: the directional albedo of
//! the white Charlie sheen lobe (`sheen_albedo`, `kernels/generated/sheen_energy.h`,
//! under `HAS_SHEEN`), by which the base under the sheen is scaled
//! (the extension's albedo-scaling layering).
//!
//! The dielectric's layering (`--layering energy`, the kernels'
//! `ENERGY_LAYERING`): the base under the specular layer is scaled by
//! what the layer does not reflect, 1 - E_spec(mu), E_spec the layer's
//! directional albedo. Schlick's Fresnel is linear in F0, so E_spec =
//! F0 E + (1 - F0) E_w, E the white table above and E_w the albedo of the
//! lobe weighted by (1 - v.h)^5 (`schlick_albedo`,
//! `kernels/generated/ggx_schlick_energy.h`); the Lambertian lobes take
//! Kulla and Conty's reciprocal form, which needs the cosine-weighted
//! averages of E, E_w and E_w / E (`albedo_averages`,
//! `kernels/generated/ggx_average_energy.h`).

use std::sync::OnceLock;

/// Entries per side: roughness `i / (N - 1)` by cosine `j / (N - 1)`.
pub const ENERGY_SIZE: usize = 32;

/// The header the kernels include, as committed.
const HEADER: &str = include_str!("../../kernels/generated/ggx_energy.h");

/// The sheen albedo header, as committed.
const SHEEN_HEADER: &str = include_str!("../../kernels/generated/sheen_energy.h");

/// The sheen albedo table parsed from its header (row = sheen roughness).
pub fn sheen_table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| parse_header(SHEEN_HEADER))
}

/// Bilinear lookup in an `ENERGY_SIZE` square table at `x`, `y` in 0..1
/// (row, column); `lut_bilinear` in `kernels/trace/bsdf.h`.
fn lut_bilinear(t: &[f32], x: f32, y: f32) -> f32 {
    let last = (ENERGY_SIZE - 1) as f32;
    let x = x.clamp(0.0, 1.0) * last;
    let y = y.clamp(0.0, 1.0) * last;
    let i0 = (x as usize).min(ENERGY_SIZE - 2);
    let j0 = (y as usize).min(ENERGY_SIZE - 2);
    let fx = x - i0 as f32;
    let fy = y - j0 as f32;
    let e00 = t[i0 * ENERGY_SIZE + j0];
    let e10 = t[(i0 + 1) * ENERGY_SIZE + j0];
    let e01 = t[i0 * ENERGY_SIZE + j0 + 1];
    let e11 = t[(i0 + 1) * ENERGY_SIZE + j0 + 1];
    (e00 * (1.0 - fx) + e10 * fx) * (1.0 - fy) + (e01 * (1.0 - fx) + e11 * fx) * fy
}

/// The directional albedo of the white Charlie sheen lobe at sheen
/// roughness `r` and cosine `mu`; mirrors `sheen_albedo` in `kernels/trace/bsdf.h`.
pub fn sheen_albedo(r: f32, mu: f32) -> f32 {
    lut_bilinear(sheen_table(), r, mu)
}

/// Computes the sheen table: per entry the integral of the white sheen
/// lobe (`material::sheen_lobe` in f64) times the cosine over the
/// hemisphere, by the midpoint rule in (cosine, azimuth), in f64.
pub fn generate_sheen() -> Vec<f32> {
    let n = ENERGY_SIZE;
    let (mc, mp) = (128, 64);
    let mut out = Vec::with_capacity(n * n);
    for i in 0..n {
        let r = i as f64 / (n - 1) as f64;
        for j in 0..n {
            let mu = (j as f64 / (n - 1) as f64).max(1.0e-3);
            let wo = [(1.0 - mu * mu).sqrt(), 0.0, mu];
            let mut sum = 0.0;
            for k in 0..mc {
                let ci = (k as f64 + 0.5) / mc as f64;
                let si = (1.0 - ci * ci).sqrt();
                for l in 0..mp {
                    // Symmetric in azimuth: half the circle, twice.
                    let phi = std::f64::consts::PI * (l as f64 + 0.5) / mp as f64;
                    let wi = [si * phi.cos(), si * phi.sin(), ci];
                    sum += sheen_lobe_f64(r, wo, wi) * ci;
                }
            }
            let e = sum * 2.0 * std::f64::consts::PI / (mc * mp) as f64;
            out.push(e as f32);
        }
    }
    out
}

/// The white Charlie sheen lobe D V of the extension (no colour), in f64
/// for the table; `material::sheen_lobe` is the f32 twin of the kernels'.
pub fn sheen_lobe_f64(r: f64, wo: [f64; 3], wi: [f64; 3]) -> f64 {
    let a = r.max(super::material::SHEEN_MIN_ROUGHNESS as f64);
    let h = [wo[0] + wi[0], wo[1] + wi[1], wo[2] + wi[2]];
    let hl = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
    if hl == 0.0 || wo[2] <= 0.0 || wi[2] <= 0.0 {
        return 0.0;
    }
    let ch = h[2] / hl;
    let s2 = (1.0 - ch * ch).max(0.0);
    let d = (2.0 + 1.0 / a) * s2.powf(0.5 / a) / (2.0 * std::f64::consts::PI);
    let l = |x: f64| {
        let t = (1.0 - a) * (1.0 - a);
        let mix = |p1: f64, p0: f64| p1 + (p0 - p1) * t;
        mix(21.5473, 25.3245) / (1.0 + mix(3.82987, 3.32435) * x.powf(mix(0.19823, 0.16801)))
            + mix(-1.97760, -1.27393) * x
            + mix(-4.32054, -4.85967)
    };
    let lambda = |c: f64| {
        if c < 0.5 {
            l(c).exp()
        } else {
            (2.0 * l(0.5) - l(1.0 - c)).exp()
        }
    };
    d / ((1.0 + lambda(wo[2]) + lambda(wi[2])) * (4.0 * wo[2] * wi[2]))
}

/// The sheen header text for `table`.
pub fn sheen_header_text(table: &[f32]) -> String {
    header(
        "// Generated by soupray::trace::energy::generate_sheen (SOUPRAY_REGENERATE=1\n\
         // cargo test --test render_layers sheen_table): the directional albedo of\n\
         // the white Charlie sheen lobe of KHR_materials_sheen, row i = sheen\n\
         // roughness i / 31, column j = cosine j / 31. Do not edit.\n\
         #ifndef SOUPRAY_SHEEN_ENERGY_H\n#define SOUPRAY_SHEEN_ENERGY_H\n\n\
         #pragma OPENCL FP_CONTRACT OFF\n\n\
         __constant float SHEEN_ALBEDO[1024] = {\n",
        table,
    )
}

/// The albedo table parsed from the header (row = roughness).
pub fn table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| parse_header(HEADER))
}

/// The numbers between the header's braces.
pub fn parse_header(text: &str) -> Vec<f32> {
    let body = text
        .split_once('{')
        .and_then(|(_, rest)| rest.split_once('}'))
        .map_or("", |(body, _)| body);
    body.split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .filter_map(|s| s.trim_end_matches('f').parse::<f32>().ok())
        .collect()
}

/// The directional albedo E of the white single-scattering GGX lobe at
/// GGX `alpha` and outgoing cosine `mu`, interpolated bilinearly in
/// (roughness, cosine). Mirrors `ggx_albedo` in `kernels/trace/bsdf.h`.
pub fn ggx_albedo(alpha: f32, mu: f32) -> f32 {
    lut_bilinear(table(), alpha.sqrt(), mu)
}

/// Computes the table: per entry, the albedo by stratified sampling of the
/// visible normals (weight G2 / G1), in f64.
pub fn generate() -> Vec<f32> {
    generate_weighted(|_| 1.0)
}

/// The albedo of the GGX lobe weighted by `fresnel(v.h)` over the
/// `ENERGY_SIZE` square of (roughness, cosine), in f64.
fn generate_weighted(fresnel: impl Fn(f64) -> f64) -> Vec<f32> {
    let n = ENERGY_SIZE;
    let m = 96;
    let mut out = Vec::with_capacity(n * n);
    for i in 0..n {
        let r = i as f64 / (n - 1) as f64;
        let a = (r * r).max(super::material::MIN_GGX_ALPHA as f64);
        for j in 0..n {
            let mu = (j as f64 / (n - 1) as f64).max(1.0e-3);
            let wo = [(1.0 - mu * mu).sqrt(), 0.0, mu];
            let lambda = |w: [f64; 3]| {
                let c2 = w[2] * w[2];
                let t2 = (1.0 - c2).max(0.0) / c2;
                ((1.0 + a * a * t2).sqrt() - 1.0) * 0.5
            };
            out.push(vndf_albedo(a, a, wo, m, lambda, &fresnel) as f32);
        }
    }
    out
}

/// The single-scattering albedo at `wo` of the GGX lobe of alphas `ax`
/// (along x) and `ay` (along y) times `fresnel(wo.h)`, `lambda` its Smith
/// Lambda: `m` x `m` stratified samples of the visible normals, each
/// weighted by G2 / G1 = (1 + Lambda(wo)) / (1 + Lambda(wo) + Lambda(wi)),
/// in f64.
fn vndf_albedo(
    ax: f64,
    ay: f64,
    wo: [f64; 3],
    m: usize,
    lambda: impl Fn([f64; 3]) -> f64,
    fresnel: &dyn Fn(f64) -> f64,
) -> f64 {
    let lo = lambda(wo);
    let mut sum = 0.0;
    for k in 0..m {
        for l in 0..m {
            let u1 = (k as f64 + 0.5) / m as f64;
            let u2 = (l as f64 + 0.5) / m as f64;
            let h = sample_vndf(ax, ay, wo, u1, u2);
            let oh = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
            let wi = [
                2.0 * oh * h[0] - wo[0],
                2.0 * oh * h[1] - wo[1],
                2.0 * oh * h[2] - wo[2],
            ];
            if wi[2] > 0.0 {
                sum += fresnel(oh) * ((1.0 + lo) / (1.0 + lo + lambda(wi)));
            }
        }
    }
    sum / (m * m) as f64
}

/// Heitz's visible-normal sampling for alphas `ax` along x and `ay` along y.
fn sample_vndf(ax: f64, ay: f64, wo: [f64; 3], u1: f64, u2: f64) -> [f64; 3] {
    let v = [ax * wo[0], ay * wo[1], wo[2]];
    let vl = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let vh = [v[0] / vl, v[1] / vl, v[2] / vl];
    let lensq = vh[0] * vh[0] + vh[1] * vh[1];
    let t1 = if lensq > 0.0 {
        [-vh[1] / lensq.sqrt(), vh[0] / lensq.sqrt(), 0.0]
    } else {
        [1.0, 0.0, 0.0]
    };
    let t2 = [
        vh[1] * t1[2] - vh[2] * t1[1],
        vh[2] * t1[0] - vh[0] * t1[2],
        vh[0] * t1[1] - vh[1] * t1[0],
    ];
    let r = u1.sqrt();
    let phi = std::f64::consts::TAU * u2;
    let p1 = r * phi.cos();
    let s = 0.5 * (1.0 + vh[2]);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * phi.sin();
    let p3 = (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt();
    let nh = [
        t1[0] * p1 + t2[0] * p2 + vh[0] * p3,
        t1[1] * p1 + t2[1] * p2 + vh[1] * p3,
        t1[2] * p1 + t2[2] * p2 + vh[2] * p3,
    ];
    let h = [ax * nh[0], ay * nh[1], nh[2].max(0.0)];
    let hl = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
    [h[0] / hl, h[1] / hl, h[2] / hl]
}

/// The sides of the anisotropic correction table: sqrt(alpha_t) (0 to 1),
/// sqrt(alpha / alpha_t) (0 to 1), the outgoing cosine (0 to 1) and the
/// outgoing azimuth from the anisotropy direction (0 to pi/2; the lobe is
/// symmetric about both axes).
pub const ANISO_SIZES: [usize; 4] = [8, 8, 16, 6];

/// Generated by `generate_anisotropic`; read by `anisotropic_correction`
/// and by `kernels/trace/bsdf.h` (`HAS_ANISOTROPY` with
/// `GGX_ENERGY_COMPENSATION`).
const ANISO_HEADER: &str = include_str!("../../kernels/generated/ggx_aniso_energy.h");

/// The anisotropic correction table parsed from its header.
pub fn aniso_table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| parse_header(ANISO_HEADER))
}

/// The table coordinates (each 0 to 1) of an anisotropic lobe of alphas
/// `at` (along x) and `ab` (along y, at most `at`) seen from `wo`.
fn aniso_coordinates(at: f32, ab: f32, wo: [f32; 3]) -> [f32; 4] {
    let phi = wo[1].abs().atan2(wo[0].abs()) * std::f32::consts::FRAC_2_PI;
    [at.sqrt(), (ab / at).sqrt(), wo[2], phi]
}

/// Quadrilinear lookup in the anisotropic table at coordinates `x` (each
/// clamped to 0..1). Mirrors `aniso_lookup` in kernels/trace/bsdf.h.
fn aniso_lookup(t: &[f32], x: [f32; 4]) -> f32 {
    let mut base = [0usize; 4];
    let mut frac = [0.0f32; 4];
    for d in 0..4 {
        let last = (ANISO_SIZES[d] - 1) as f32;
        let v = x[d].clamp(0.0, 1.0) * last;
        let i = (v as usize).min(ANISO_SIZES[d] - 2);
        base[d] = i;
        frac[d] = v - i as f32;
    }
    let mut sum = 0.0f32;
    for corner in 0..16usize {
        let mut index = 0usize;
        let mut weight = 1.0f32;
        for d in 0..4 {
            let up = (corner >> d) & 1;
            index = index * ANISO_SIZES[d] + base[d] + up;
            weight *= if up == 1 { frac[d] } else { 1.0 - frac[d] };
        }
        sum += t[index] * weight;
    }
    sum
}

/// The white single-scattering albedo of anisotropic GGX (alphas `at`
/// along x, `ab` along y, `ab <= at`) at the unit direction `wo`: the
/// isotropic table at the root-mean-square alpha, times the tabulated
/// correction. Mirrors `spec_albedo` in kernels/trace/bsdf.h.
pub fn anisotropic_albedo(at: f32, ab: f32, wo: [f32; 3]) -> f32 {
    let rms = ((at * at + ab * ab) * 0.5).sqrt();
    ggx_albedo(rms, wo[2]) * aniso_lookup(aniso_table(), aniso_coordinates(at, ab, wo))
}

/// Computes the anisotropic correction table: per entry, the albedo of the
/// white single-scattering anisotropic lobe by stratified sampling of its
/// visible normals (weight G2 / G1, in f64), over the isotropic table's
/// value at the root-mean-square alpha, so that their product is the
/// albedo at every node.
pub fn generate_anisotropic() -> Vec<f32> {
    let [nt, nr, nm, np] = ANISO_SIZES;
    let m = 48;
    let min = super::material::MIN_GGX_ALPHA as f64;
    let mut out = Vec::with_capacity(nt * nr * nm * np);
    for i in 0..nt {
        let st = i as f64 / (nt - 1) as f64;
        let at = (st * st).max(min);
        for j in 0..nr {
            let q = j as f64 / (nr - 1) as f64;
            let ab = (q * q * at).max(min).min(at);
            for k in 0..nm {
                let mu = (k as f64 / (nm - 1) as f64).max(1.0e-3);
                let s = (1.0 - mu * mu).sqrt();
                for l in 0..np {
                    let phi = std::f64::consts::FRAC_PI_2 * l as f64 / (np - 1) as f64;
                    let wo = [s * phi.cos(), s * phi.sin(), mu];
                    let lambda = |w: [f64; 3]| {
                        let (x, y) = (at * w[0], ab * w[1]);
                        ((1.0 + (x * x + y * y) / (w[2] * w[2])).sqrt() - 1.0) * 0.5
                    };
                    let e = vndf_albedo(at, ab, wo, m, lambda, &|_| 1.0);
                    let rms = ((at * at + ab * ab) * 0.5).sqrt();
                    out.push((e / ggx_albedo(rms as f32, mu as f32) as f64) as f32);
                }
            }
        }
    }
    out
}

/// The header text for `table` (each value printed so it reads back to
/// the same f32).
pub fn header_text(table: &[f32]) -> String {
    header(
        "// Generated by soupray::trace::energy::generate (SOUPRAY_REGENERATE=1\n\
         // cargo test --test render_materials energy_table): the directional\n\
         // albedo of the white single-scattering GGX lobe, row i = roughness\n\
         // i / 31, column j = cosine j / 31. Do not edit.\n\
         #ifndef SOUPRAY_GGX_ENERGY_H\n#define SOUPRAY_GGX_ENERGY_H\n\n\
         #pragma OPENCL FP_CONTRACT OFF\n\n\
         #define GGX_ENERGY_SIZE 32u\n\n\
         __constant float GGX_ALBEDO[1024] = {\n",
        table,
    )
}

/// The header text for the anisotropic correction table.
pub fn aniso_header_text(table: &[f32]) -> String {
    let [nt, nr, nm, np] = ANISO_SIZES;
    header(
        &format!(
            "// Generated by soupray::trace::energy::generate_anisotropic\n\
             // (SOUPRAY_REGENERATE=1 cargo test --test render_materials\n\
             // anisotropic_energy_table): the white single-scattering albedo of\n\
             // anisotropic GGX over the isotropic table's at the root-mean-square\n\
             // alpha, indexed [sqrt(alpha_t) i / {a}][sqrt(alpha / alpha_t) j / {b}]\n\
             // [cosine k / {c}][azimuth from the anisotropy direction l / {d} of pi / 2].\n\
             // Do not edit.\n\
             #ifndef SOUPRAY_GGX_ANISO_ENERGY_H\n#define SOUPRAY_GGX_ANISO_ENERGY_H\n\n\
             #pragma OPENCL FP_CONTRACT OFF\n\n\
             #define GGX_ANISO_T {nt}u\n#define GGX_ANISO_R {nr}u\n\
             #define GGX_ANISO_MU {nm}u\n#define GGX_ANISO_PHI {np}u\n\n\
             __constant float GGX_ANISO_ALBEDO[{n}] = {{\n",
            a = nt - 1,
            b = nr - 1,
            c = nm - 1,
            d = np - 1,
            n = table.len()
        ),
        table,
    )
}

/// `head`, then the table's rows (each value printed so it reads back to
/// the same f32), then the end of the array and the include guard.
fn header(head: &str, table: &[f32]) -> String {
    let mut s = String::from(head);
    for row in table.chunks(ENERGY_SIZE) {
        s.push_str("   ");
        for v in row {
            s.push_str(&format!(" {v:?}f,"));
        }
        s.push('\n');
    }
    s.push_str("};\n\n#endif\n");
    s
}

/// The Schlick-weighted albedo header, as committed.
const SCHLICK_HEADER: &str = include_str!("../../kernels/generated/ggx_schlick_energy.h");

/// The averages header, as committed.
const AVERAGE_HEADER: &str = include_str!("../../kernels/generated/ggx_average_energy.h");

/// The Schlick-weighted albedo table parsed from its header (row =
/// roughness, column = cosine).
pub fn schlick_table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| parse_header(SCHLICK_HEADER))
}

/// The averages table parsed from its header: three rows of
/// `ENERGY_SIZE` roughness nodes (see `generate_averages`).
pub fn average_table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| parse_header(AVERAGE_HEADER))
}

/// The albedo of the single-scattering GGX lobe weighted by Schlick's
/// (1 - v.h)^5 at GGX `alpha` and cosine `mu`. Mirrors `schlick_albedo`
/// in `kernels/trace/layering.h`.
pub fn schlick_albedo(alpha: f32, mu: f32) -> f32 {
    lut_bilinear(schlick_table(), alpha.sqrt(), mu)
}

/// The cosine-weighted averages 2 \int f(mu) mu dmu of E, E_w and E_w / E
/// at GGX `alpha`, linear between the roughness nodes. Mirrors
/// `albedo_averages` in `kernels/trace/layering.h`.
pub fn albedo_averages(alpha: f32) -> [f32; 3] {
    let t = average_table();
    let last = (ENERGY_SIZE - 1) as f32;
    let x = alpha.sqrt().clamp(0.0, 1.0) * last;
    let i = (x as usize).min(ENERGY_SIZE - 2);
    let f = x - i as f32;
    [0, 1, 2].map(|k| {
        let row = &t[k * ENERGY_SIZE..(k + 1) * ENERGY_SIZE];
        row[i] * (1.0 - f) + row[i + 1] * f
    })
}

/// Computes the Schlick-weighted table as `generate` does the white one.
pub fn generate_schlick() -> Vec<f32> {
    generate_weighted(|c| (1.0 - c).clamp(0.0, 1.0).powi(5))
}

/// Computes the averages from the white table `white` and the Schlick
/// table `schlick` (each `ENERGY_SIZE` square): per roughness node, the
/// cosine-weighted averages of the tables as the lookups interpolate
/// them (linear in the cosine), so that the reciprocal layering integrates
/// to exactly 1 - E_spec: row 0 E, row 1 E_w, row 2 E_w / E. Midpoint rule
/// over 64 steps per cell, in f64.
pub fn generate_averages(white: &[f32], schlick: &[f32]) -> Vec<f32> {
    let n = ENERGY_SIZE;
    let steps = 64;
    let mut rows = vec![vec![0.0f32; n]; 3];
    for i in 0..n {
        let (e, w) = (&white[i * n..(i + 1) * n], &schlick[i * n..(i + 1) * n]);
        let mut sums = [0.0f64; 3];
        for j in 0..n - 1 {
            for k in 0..steps {
                let f = (k as f64 + 0.5) / steps as f64;
                let mu = (j as f64 + f) / (n - 1) as f64;
                let ev = e[j] as f64 * (1.0 - f) + e[j + 1] as f64 * f;
                let wv = w[j] as f64 * (1.0 - f) + w[j + 1] as f64 * f;
                let dmu = 2.0 * mu / ((n - 1) * steps) as f64;
                sums[0] += ev * dmu;
                sums[1] += wv * dmu;
                sums[2] += wv / ev * dmu;
            }
        }
        for k in 0..3 {
            rows[k][i] = sums[k] as f32;
        }
    }
    rows.concat()
}

/// The header text for the Schlick-weighted table.
pub fn schlick_header_text(table: &[f32]) -> String {
    header(
        "// Generated by soupray::trace::energy::generate_schlick (SOUPRAY_REGENERATE=1\n\
         // cargo test --test render_materials layering_tables): the albedo of the\n\
         // single-scattering GGX lobe weighted by Schlick's (1 - v.h)^5, row i =\n\
         // roughness i / 31, column j = cosine j / 31. Do not edit.\n\
         #ifndef SOUPRAY_GGX_SCHLICK_ENERGY_H\n#define SOUPRAY_GGX_SCHLICK_ENERGY_H\n\n\
         #pragma OPENCL FP_CONTRACT OFF\n\n\
         __constant float GGX_SCHLICK_ALBEDO[1024] = {\n",
        table,
    )
}

/// The header text for the averages table.
pub fn average_header_text(table: &[f32]) -> String {
    header(
        "// Generated by soupray::trace::energy::generate_averages (SOUPRAY_REGENERATE=1\n\
         // cargo test --test render_materials layering_tables): the cosine-weighted\n\
         // averages 2 int f(mu) mu dmu of the white albedo E (row 0), the\n\
         // Schlick-weighted albedo E_w (row 1) and E_w / E (row 2), column i =\n\
         // roughness i / 31. Do not edit.\n\
         #ifndef SOUPRAY_GGX_AVERAGE_ENERGY_H\n#define SOUPRAY_GGX_AVERAGE_ENERGY_H\n\n\
         #pragma OPENCL FP_CONTRACT OFF\n\n\
         __constant float GGX_ALBEDO_AVERAGE[96] = {\n",
        table,
    )
}

/// The sides of the refraction table: the index ratio (the larger of eta
/// and 1 / eta, 1 to 3), roughness (0 to 1) and cosine (0 to 1).
pub const REFRACTION_SIZES: [usize; 3] = [9, 16, 32];

/// The refraction header, as committed.
const REFRACTION_HEADER: &str = include_str!("../../kernels/generated/ggx_refraction_energy.h");

/// The refraction table parsed from its header: three planes (see
/// `generate_refraction`), each [index ratio][roughness][cosine].
pub fn refraction_table() -> &'static [f32] {
    static TABLE: OnceLock<Vec<f32>> = OnceLock::new();
    TABLE.get_or_init(|| parse_header(REFRACTION_HEADER))
}

/// Trilinear lookup in `plane` of the refraction table at index ratio
/// `ratio` (1 to 3), GGX `alpha` and cosine `mu`. Mirrors
/// `refraction_lookup` in `kernels/trace/layering.h`.
fn refraction_lookup(plane: usize, ratio: f32, alpha: f32, mu: f32) -> f32 {
    let t = refraction_table();
    let x = [(ratio - 1.0) * 0.5, alpha.sqrt(), mu];
    let mut base = [0usize; 3];
    let mut frac = [0.0f32; 3];
    for d in 0..3 {
        let last = (REFRACTION_SIZES[d] - 1) as f32;
        let v = x[d].clamp(0.0, 1.0) * last;
        let i = (v as usize).min(REFRACTION_SIZES[d] - 2);
        base[d] = i;
        frac[d] = v - i as f32;
    }
    let [nk, nr, nm] = REFRACTION_SIZES;
    let mut sum = 0.0f32;
    for corner in 0..8usize {
        let (u0, u1, u2) = (corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
        let index = ((plane * nk + base[0] + u0) * nr + base[1] + u1) * nm + base[2] + u2;
        let w = (if u0 == 1 { frac[0] } else { 1.0 - frac[0] })
            * (if u1 == 1 { frac[1] } else { 1.0 - frac[1] })
            * (if u2 == 1 { frac[2] } else { 1.0 - frac[2] });
        sum += t[index] * w;
    }
    sum
}

/// The energy albedo (times eta^2, the radiance scaling undone) of the
/// Fresnel-less GGX refraction lobe at GGX `alpha`, cosine `mu` and
/// relative index `eta` (the far side's over wo's).
pub fn refraction_albedo(alpha: f32, mu: f32, eta: f32) -> f32 {
    if eta >= 1.0 {
        refraction_lookup(0, eta, alpha, mu)
    } else {
        refraction_lookup(1, 1.0 / eta, alpha, mu)
    }
}

/// From inside (relative index `eta` below 1): the albedo of the GGX
/// reflection lobe weighted by Schlick's (1 - c)^5 at the cosine on the
/// thinner side, 1 under total internal reflection.
pub fn inside_schlick_albedo(alpha: f32, mu: f32, eta: f32) -> f32 {
    refraction_lookup(2, 1.0 / eta, alpha, mu)
}

/// Computes the refraction table by stratified sampling of the visible
/// normals (96 x 96 per entry, in f64): plane 0 the refraction lobe's
/// energy albedo entering (eta = ratio), plane 1 leaving (eta = 1 /
/// ratio), each microfacet weighted by G2 / G1 where it refracts (none
/// under total internal reflection); plane 2 leaving, the reflection lobe
/// weighted by Schlick's weight at the thinner side's cosine (1 under
/// total internal reflection).
pub fn generate_refraction() -> Vec<f32> {
    let [nk, nr, nm] = REFRACTION_SIZES;
    let m = 96;
    let mut out = Vec::with_capacity(3 * nk * nr * nm);
    for plane in 0..3 {
        for k in 0..nk {
            let ratio = 1.0 + 2.0 * k as f64 / (nk - 1) as f64;
            let eta = if plane == 0 { ratio } else { 1.0 / ratio };
            for i in 0..nr {
                let r = i as f64 / (nr - 1) as f64;
                let a = (r * r).max(super::material::MIN_GGX_ALPHA as f64);
                for j in 0..nm {
                    let mu = (j as f64 / (nm - 1) as f64).max(1.0e-3);
                    out.push(refraction_entry(plane, a, mu, eta, m) as f32);
                }
            }
        }
    }
    out
}

/// One entry of `generate_refraction`.
fn refraction_entry(plane: usize, a: f64, mu: f64, eta: f64, m: usize) -> f64 {
    let wo = [(1.0 - mu * mu).sqrt(), 0.0, mu];
    let lambda = |w: [f64; 3]| {
        let c2 = w[2] * w[2];
        let t2 = (1.0 - c2).max(0.0) / c2;
        ((1.0 + a * a * t2).sqrt() - 1.0) * 0.5
    };
    let lo = lambda(wo);
    let mut sum = 0.0;
    for k in 0..m {
        for l in 0..m {
            let u1 = (k as f64 + 0.5) / m as f64;
            let u2 = (l as f64 + 0.5) / m as f64;
            let h = sample_vndf(a, a, wo, u1, u2);
            let c = wo[0] * h[0] + wo[1] * h[1] + wo[2] * h[2];
            if c <= 0.0 {
                continue;
            }
            let s2t = (1.0 - c * c).max(0.0) / (eta * eta);
            let wi = if plane == 2 {
                [
                    2.0 * c * h[0] - wo[0],
                    2.0 * c * h[1] - wo[1],
                    2.0 * c * h[2] - wo[2],
                ]
            } else {
                if s2t >= 1.0 {
                    continue;
                }
                let q = c / eta - (1.0 - s2t).sqrt();
                [
                    -wo[0] / eta + h[0] * q,
                    -wo[1] / eta + h[1] * q,
                    -wo[2] / eta + h[2] * q,
                ]
            };
            let side_ok = if plane == 2 { wi[2] > 0.0 } else { wi[2] < 0.0 };
            if !side_ok {
                continue;
            }
            let weight = if plane == 2 && s2t < 1.0 {
                (1.0 - (1.0 - s2t).sqrt()).clamp(0.0, 1.0).powi(5)
            } else {
                1.0
            };
            sum += weight * ((1.0 + lo) / (1.0 + lo + lambda(wi)));
        }
    }
    sum / (m * m) as f64
}

/// The header text for the refraction table.
pub fn refraction_header_text(table: &[f32]) -> String {
    let [nk, nr, nm] = REFRACTION_SIZES;
    header(
        &format!(
            "// Generated by soupray::trace::energy::generate_refraction\n\
             // (SOUPRAY_REGENERATE=1 cargo test --test render_materials layering_tables):\n\
             // plane 0 the energy albedo of the Fresnel-less GGX refraction lobe\n\
             // entering (eta = ratio), plane 1 leaving (eta = 1 / ratio), plane 2\n\
             // leaving, the reflection lobe weighted by Schlick's weight on the thinner\n\
             // side (1 under total internal reflection); each indexed [ratio 1 + 2 k /\n\
             // {a}][roughness i / {b}][cosine j / {c}]. Do not edit.\n\
             #ifndef SOUPRAY_GGX_REFRACTION_ENERGY_H\n#define SOUPRAY_GGX_REFRACTION_ENERGY_H\n\n\
             #pragma OPENCL FP_CONTRACT OFF\n\n\
             #define GGX_REFRACTION_ETA {nk}u\n#define GGX_REFRACTION_R {nr}u\n\
             #define GGX_REFRACTION_MU {nm}u\n\n\
             __constant float GGX_REFRACTION_ALBEDO[{n}] = {{\n",
            a = nk - 1,
            b = nr - 1,
            c = nm - 1,
            n = table.len()
        ),
        table,
    )
}
