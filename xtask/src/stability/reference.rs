//! f64 references, written from SPEC §1-§3 independently of the library:
//! the NDFs, their maxima, Smith Lambda for GGX and Beckmann (with an erfc
//! of our own), exact dielectric Fresnel, and the GGX-Smith conductor and
//! dielectric lobes (value and pdf). Inputs are the library's f32 inputs
//! converted exactly, so the differences measure the library's arithmetic.

use std::f64::consts::PI;

use glam::DVec3;
use microfacet::NdfKind;

/// D(h) of SPEC §1 (supp. eq. 1, 2, 5) for the direction `h` as given
/// (cos^2 = h.z^2, sin^2 = h.x^2 + h.y^2, as the library defines them); 0
/// for h.z <= 0.
pub fn d(kind: NdfKind, alpha: f64, h: DVec3) -> f64 {
    if h.z <= 0.0 {
        return 0.0;
    }
    let (a2, c2, s2) = (alpha * alpha, h.z * h.z, h.x * h.x + h.y * h.y);
    match kind {
        NdfKind::Ggx => {
            let t = c2 + s2 / a2;
            1.0 / (PI * a2 * t * t)
        }
        NdfKind::Beckmann => (-s2 / (a2 * c2)).exp() / (PI * a2 * c2 * c2),
        NdfKind::BlinnPhong => {
            // (n + 2)/(2 pi) c^n with n = 2/a^2 - 2, c^n = (c^2)^(n/2).
            let n = 2.0 / a2 - 2.0;
            let ln_c2 = if s2 < 0.5 { (-s2).ln_1p() } else { c2.ln() };
            (n + 2.0) / (2.0 * PI) * (0.5 * n * ln_c2).exp()
        }
    }
}

/// The supremum of D (SPEC §1 table; GGX above alpha = 1: alpha^2/pi at
/// grazing, SPEC §3 "Domain").
pub fn d_max(kind: NdfKind, alpha: f64) -> f64 {
    match kind {
        NdfKind::Ggx if alpha > 1.0 => alpha * alpha / PI,
        NdfKind::Beckmann if alpha > std::f64::consts::FRAC_1_SQRT_2 => {
            4.0 * alpha * alpha * (1.0 / (alpha * alpha) - 2.0).exp() / PI
        }
        _ => 1.0 / (PI * alpha * alpha),
    }
}

/// Smith Lambda of GGX: (sqrt(1 + a^2 tan^2) - 1)/2, cancellation-free.
pub fn lambda_ggx(alpha: f64, w: DVec3) -> f64 {
    let (c2, s2) = (w.z * w.z, w.x * w.x + w.y * w.y);
    let x = alpha * alpha * s2 / c2;
    x / (2.0 * (1.0 + (1.0 + x).sqrt()))
}

/// Smith Lambda of Beckmann with m = 1/(a tan theta):
/// (exp(-m^2)/(m sqrt(pi)) - erfc(m))/2, evaluated without cancellation for
/// large m through the continued fraction of erfc.
pub fn lambda_beckmann(alpha: f64, w: DVec3) -> f64 {
    let (c2, s2) = (w.z * w.z, w.x * w.x + w.y * w.y);
    if s2 == 0.0 {
        return 0.0;
    }
    let m = (c2 / s2).sqrt() / alpha;
    if m < ERFC_SPLIT {
        0.5 * ((-m * m).exp() / (m * PI.sqrt()) - erfc(m))
    } else {
        // erfc(m) = exp(-m^2)/sqrt(pi) / (m + tail): 1/m - 1/(m + tail) = tail/(m (m + tail)).
        let tail = erfc_cf_tail(m);
        (-m * m).exp() / (2.0 * PI.sqrt()) * tail / (m * (m + tail))
    }
}

/// Smith Lambda where a closed form exists: GGX, Beckmann, Blinn-Phong
/// below alpha = 0.01 (where the library uses Beckmann's, documented; the
/// switch is decided on the library's f32 alpha) and at alpha = 1
/// ((sqrt(1 + mu^2) - mu)/(2 mu), mu = cot theta).
pub fn lambda(kind: NdfKind, alpha_f32: f32, w: DVec3) -> Option<f64> {
    let alpha = f64::from(alpha_f32);
    match kind {
        NdfKind::Ggx => Some(lambda_ggx(alpha, w)),
        NdfKind::Beckmann => Some(lambda_beckmann(alpha, w)),
        NdfKind::BlinnPhong if alpha_f32 < 0.01 => Some(lambda_beckmann(alpha, w)),
        NdfKind::BlinnPhong if alpha_f32 == 1.0 => {
            let s2 = w.x * w.x + w.y * w.y;
            if s2 == 0.0 {
                return Some(0.0);
            }
            let mu = (w.z * w.z / s2).sqrt();
            Some(((1.0 + mu * mu).sqrt() - mu) / (2.0 * mu))
        }
        NdfKind::BlinnPhong => None,
    }
}

/// Below this argument erfc = 1 - erf (series of positive terms), above it
/// the continued fraction.
const ERFC_SPLIT: f64 = 3.0;

/// erf by the series 2/sqrt(pi) exp(-x^2) sum_n (2x^2)^n x / (2n+1)!!
/// (all terms positive: no cancellation), for 0 <= x < 3 or so.
fn erf_series(x: f64) -> f64 {
    let mut term = x;
    let mut sum = x;
    let mut n = 0.0;
    while term > 1e-18 * sum {
        n += 1.0;
        term *= 2.0 * x * x / (2.0 * n + 1.0);
        sum += term;
    }
    2.0 / PI.sqrt() * (-x * x).exp() * sum
}

/// t - x of the continued fraction erfc(x) = exp(-x^2)/sqrt(pi) / t,
/// t = x + (1/2)/(x + 1/(x + (3/2)/(x + ...))), for x >= 3.
fn erfc_cf_tail(x: f64) -> f64 {
    let mut t = x;
    for k in (2..=200).rev() {
        t = x + 0.5 * f64::from(k) / t;
    }
    0.5 / t
}

/// The complementary error function, relative accuracy about 1e-13.
pub fn erfc(x: f64) -> f64 {
    if x < 0.0 {
        2.0 - erfc(-x)
    } else if x < ERFC_SPLIT {
        1.0 - erf_series(x)
    } else {
        (-x * x).exp() / PI.sqrt() / (x + erfc_cf_tail(x))
    }
}

/// Unpolarised dielectric Fresnel (Born & Wolf), `eta` = eta_t/eta_i,
/// `cos_i` on the side of the incident direction (negative: the far side,
/// seen with 1/eta). 1 on total internal reflection.
pub fn fresnel_dielectric(cos_i: f64, eta: f64) -> f64 {
    let (cos_i, eta) = if cos_i < 0.0 {
        (-cos_i, 1.0 / eta)
    } else {
        (cos_i, eta)
    };
    let cos_i = cos_i.min(1.0);
    // cos_t^2 = 1 - (1 - cos_i^2)/eta^2 = ((eta - 1)(eta + 1) + cos_i^2)/eta^2:
    // no cancellation near eta = 1 (exactly cos_i for eta = 1).
    let cos2_t = ((eta - 1.0) * (eta + 1.0) + cos_i * cos_i) / (eta * eta);
    if cos2_t <= 0.0 {
        return 1.0;
    }
    let cos_t = cos2_t.sqrt();
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    0.5 * (rp * rp + rs * rs)
}

/// Schlick's F0 + (1 - F0)(1 - cos)^5.
pub fn schlick(cos: f64, f0: f64) -> f64 {
    f0 + (1.0 - f0) * (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

/// Smith G1 of GGX for microfacet `h`: zero unless (w.h)(w.n) > 0.
fn g1_ggx(alpha: f64, w: DVec3, h: DVec3) -> f64 {
    if w.dot(h) * w.z <= 0.0 {
        return 0.0;
    }
    1.0 / (1.0 + lambda_ggx(alpha, w))
}

/// Value and pdf of a rough GGX-Smith conductor with Schlick reflectance
/// `f0` (one channel), SPEC §3: f = F D G1 G1 / (4 |cos_i cos_o|),
/// pdf = G1(wi) D / (4 cos_i) (visible normals). (0, 0) where the library's
/// lobe is 0 by definition (opposite sides, back-facing microfacet).
pub fn conductor_ggx(alpha: f64, f0: f64, wi: DVec3, wo: DVec3) -> (f64, f64) {
    if wi.z * wo.z <= 0.0 {
        return (0.0, 0.0);
    }
    let side = wi.z.signum();
    let (wi, wo) = (wi * side, wo * side);
    let Some(h) = (wi + wo).try_normalize() else {
        return (0.0, 0.0);
    };
    if !(wi.dot(h) > 0.0 && h.z > 0.0) {
        return (0.0, 0.0);
    }
    let dh = d(NdfKind::Ggx, alpha, h);
    let (g1i, g1o) = (g1_ggx(alpha, wi, h), g1_ggx(alpha, wo, h));
    let f = schlick(wi.dot(h), f0) * dh * g1i * g1o / (4.0 * wi.z * wo.z);
    let pdf = g1i * dh / (4.0 * wi.z);
    (f, pdf)
}

/// Value and pdf of a rough GGX-Smith dielectric (Walter et al. 2007, SPEC
/// §3), `eta` the index below over the index above; reflection with
/// probability F, refraction with 1 - F. Importance mode carries eta^2
/// (eta seen from wi) relative to Radiance mode.
pub fn dielectric_ggx(alpha: f64, eta: f64, wi: DVec3, wo: DVec3, importance: bool) -> (f64, f64) {
    if wi.z == 0.0 || wo.z == 0.0 {
        return (0.0, 0.0);
    }
    let side = wi.z.signum();
    let (wi, wo) = (wi * side, wo * side);
    let eta = if side > 0.0 { eta } else { 1.0 / eta };
    let reflection = wo.z > 0.0;
    let h = if reflection { wi + wo } else { wi + eta * wo };
    let Some(h) = h.try_normalize() else {
        return (0.0, 0.0);
    };
    let h = if h.z < 0.0 { -h } else { h };
    let (wi_h, wo_h) = (wi.dot(h), wo.dot(h));
    if !(h.z > 0.0 && wi_h > 0.0 && wo_h * wo.z > 0.0) {
        return (0.0, 0.0);
    }
    let f_r = fresnel_dielectric(wi_h, eta);
    let dh = d(NdfKind::Ggx, alpha, h);
    let (g1i, g1o) = (g1_ggx(alpha, wi, h), g1_ggx(alpha, wo, h));
    let pdf_h = g1i * wi_h * dh / wi.z;
    let (cos_i, cos_o) = (wi.z, wo.z.abs());
    if reflection {
        (
            f_r * dh * g1i * g1o / (4.0 * cos_i * cos_o),
            pdf_h / (4.0 * wi_h) * f_r,
        )
    } else {
        let t = 1.0 - f_r;
        let denominator = (wi_h + eta * wo_h).powi(2);
        let radiance = dh * g1i * g1o * t * (wi_h * wo_h).abs() / (cos_i * cos_o * denominator);
        let f = if importance {
            radiance * eta * eta
        } else {
            radiance
        };
        (f, pdf_h * eta * eta * wo_h.abs() / denominator * t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn erfc_matches_tabulated_values() {
        // Abramowitz & Stegun / high-precision values.
        for (x, expected) in [
            (0.0, 1.0),
            (0.5, 0.479_500_122_186_953_5),
            (1.0, 0.157_299_207_050_285_13),
            (2.0, 4.677_734_981_047_265e-3),
            (2.999, 2.223_016_859_983_405_8e-5),
            (3.0, 2.209_049_699_858_543_8e-5),
            (4.0, 1.541_725_790_028_002e-8),
            (6.0, 2.151_973_671_249_891_6e-17),
            (10.0, 2.088_487_583_762_545e-45),
            (-1.0, 1.842_700_792_949_715),
        ] {
            let got = erfc(x);
            assert!(
                ((got - expected) / expected).abs() < 1e-12,
                "erfc({x}) = {got:e}, expected {expected:e}"
            );
        }
    }

    #[test]
    fn beckmann_lambda_is_continuous_across_the_split_and_matches_the_asymptote() {
        // Same alpha, m just below and above 3.
        let w = |m: f64| {
            // tan theta = 1/m for alpha = 1
            let t = 1.0 / m;
            DVec3::new(t, 0.0, 1.0).normalize()
        };
        let below = lambda_beckmann(1.0, w(3.0 - 1e-9));
        let above = lambda_beckmann(1.0, w(3.0 + 1e-9));
        assert!((below / above - 1.0).abs() < 1e-7, "{below:e} {above:e}");
        // Large m: Lambda ~ exp(-m^2)/(4 m^3 sqrt(pi)) (1 - 3/(2 m^2)).
        let m: f64 = 20.0;
        let asymptote = (-m * m).exp() / (4.0 * m * m * m * PI.sqrt()) * (1.0 - 1.5 / (m * m));
        let got = lambda_beckmann(1.0, w(m));
        assert!(
            (got / asymptote - 1.0).abs() < 1e-4,
            "{got:e} {asymptote:e}"
        );
        // Grazing: Lambda ~ 1/(2 m sqrt(pi)) - 1/2.
        let m = 1e-6;
        let got = lambda_beckmann(1.0, w(m));
        assert!((got / (1.0 / (2.0 * m * PI.sqrt()) - 0.5) - 1.0).abs() < 1e-9);
    }

    #[test]
    fn ndf_references_are_normalised_at_the_peak() {
        for kind in [NdfKind::Ggx, NdfKind::Beckmann, NdfKind::BlinnPhong] {
            let peak = d(kind, 0.3, DVec3::Z);
            assert!((peak / d_max(kind, 0.3) - 1.0).abs() < 1e-12, "{kind:?}");
        }
        // Beckmann above 1/sqrt(2): the maximum is at cos = 1/(sqrt(2) alpha).
        let a = 1.5;
        let c = 1.0 / (2f64.sqrt() * a);
        let h = DVec3::new((1.0 - c * c).sqrt(), 0.0, c);
        assert!((d(NdfKind::Beckmann, a, h) / d_max(NdfKind::Beckmann, a) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn fresnel_reference_known_values() {
        assert!((fresnel_dielectric(1.0, 1.5) - 0.04).abs() < 1e-15);
        assert_eq!(fresnel_dielectric(0.5, 1.0 / 1.5), 1.0);
        assert_eq!(fresnel_dielectric(0.7, 1.0), 0.0);
        // Index-matched stays 0 down to grazing; glass at grazing reflects almost all.
        assert_eq!(fresnel_dielectric(1e-9, 1.0), 0.0);
        assert!(fresnel_dielectric(1e-9, 1.5) > 0.99999);
    }

    #[test]
    fn dielectric_reference_modes_differ_by_eta_squared() {
        let wi = DVec3::new(0.3, 0.1, 0.9).normalize();
        let wo = DVec3::new(-0.2, 0.0, -0.95).normalize();
        let (fr, p1) = dielectric_ggx(0.3, 1.5, wi, wo, false);
        let (fi, p2) = dielectric_ggx(0.3, 1.5, wi, wo, true);
        assert!(fr > 0.0 && (fi / fr - 2.25).abs() < 1e-12 && p1 == p2);
    }
}
