//! Normal distribution functions D(h) (SPEC §1, supp. §1) with their Smith
//! masking functions and D(h)<h,n> sampling.
//!
//! All three are isotropic and normalised so that the integral of
//! D(h)<h,n> over the hemisphere is 1. `alpha` is the width parameter itself
//! (glTF's perceptual roughness r maps to alpha = r^2).

use std::f32::consts::PI;
use std::f64::consts::PI as PI64;

use glam::{Vec2, Vec3};

use crate::frame::sin2_theta;
use crate::special::{beta_inc_from_front, erfc, ln_gamma, ln_inv_beta};

/// Below this alpha a lobe is a delta (mirror or smooth refraction): its
/// density would exceed 1/(4 pi alpha^2) = 8e6 per steradian, beyond what
/// f32 directions resolve usefully, and integrators must not try to connect
/// through it (SPEC §3) unless regularization widens it first.
pub const SMOOTH_ALPHA: f32 = 1e-4;

/// Smallest alpha the NDFs accept; smaller values (and NaN) are raised to it.
/// At 1e-7, 1/(pi alpha^2) = 3.2e13 is still far from f32 overflow, and
/// every lobe is treated as a delta long before (`SMOOTH_ALPHA`).
pub const ALPHA_MIN: f32 = 1e-7;

/// Largest alpha the NDFs accept; larger values are lowered to it. GGX's
/// maximum alpha^2/pi stays finite in f32 far beyond it.
pub const ALPHA_MAX: f32 = 1e4;

/// Blinn-Phong needs alpha <= 1 (exponent n = 2/alpha^2 - 2 >= 0, SPEC §3
/// "Domain"); larger values are lowered to it.
pub const BLINN_PHONG_ALPHA_MAX: f32 = 1.0;

/// Beckmann's maximum leaves h = n above this alpha (supp. eq. 3): 1/sqrt(2).
pub const BECKMANN_PEAK_SHIFT_ALPHA: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// Below this alpha, Blinn-Phong uses Beckmann's Lambda instead of its exact
/// one. The two differ by about 0.3 alpha^2 in G1 (3e-5 here), while the exact
/// form's continued fraction needs O(1/alpha) steps.
pub const BLINN_PHONG_EXACT_LAMBDA_MIN_ALPHA: f32 = 0.01;

/// Measured excess of the supremum over angles of Smith-Beckmann G1/cos over
/// max(1, 2 sqrt(pi)/alpha): at most 1.6 % (near alpha = 3.55), so bounds are
/// scaled by 1.02 (SPEC §2).
pub const BECKMANN_G1_OVER_COS_SAFETY: f32 = 1.02;

/// A Lambda below this leaves G1 = 1/(1 + Lambda) exactly 1 in f32: 1 +
/// Lambda rounds to 1 below half an ulp of 1, 2^-24, and the factor 4 is
/// margin for rounding in the bounds of `unit_g1_cot2`. [`Ndf::g1`] returns
/// 1 without evaluating Lambda where those bounds put it below this.
const LAMBDA_NEGLIGIBLE: f64 = 1.0 / (1u64 << 26) as f64;

/// The microfacet normal distributions of supp. §1.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum NdfKind {
    /// GGX / Trowbridge-Reitz (supp. eq. 1).
    Ggx,
    /// Beckmann-Spizzichino (supp. eq. 2).
    Beckmann,
    /// Normalised Blinn-Phong with exponent n = 2/alpha^2 - 2 (supp. eq. 5).
    BlinnPhong,
}

/// An isotropic normal distribution: a kind and its width alpha.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ndf {
    kind: NdfKind,
    alpha: f32,
    /// The alpha-only factors of Blinn-Phong's exact Lambda, computed once
    /// here: five ln Gamma evaluations that were 40 % of every Lambda call
    /// (cachegrind, PT on `smallvcm-2`, whose floor is Blinn-Phong).
    exact: BlinnPhongLambda,
    /// cot^2 theta above which Lambda < [`LAMBDA_NEGLIGIBLE`], so G1 is
    /// exactly 1 (see `unit_g1_cot2`): on a glossy Blinn-Phong floor most
    /// directions skip the exact Lambda's f64 powers and continued fraction.
    unit_g1_cot2: f32,
}

/// The factors of Blinn-Phong's exact Lambda that depend on alpha alone
/// (see [`lambda_blinn_phong`]): zero for other kinds and for alphas below
/// [`BLINN_PHONG_EXACT_LAMBDA_MIN_ALPHA`] (a pure function of kind and
/// alpha, so it never makes two equal NDFs differ).
#[derive(Clone, Copy, Debug, PartialEq)]
struct BlinnPhongLambda {
    /// C = Gamma(p + 1/2) / (sqrt(pi) Gamma(p)), p = 1/alpha^2.
    c: f64,
    /// 1 / B(p, 1/2), the constant of I_x(p, 1/2)'s front factor.
    inv_beta: f64,
}

impl BlinnPhongLambda {
    const NONE: Self = Self {
        c: 0.0,
        inv_beta: 0.0,
    };

    fn new(alpha: f32) -> Self {
        let p = blinn_phong_p(alpha);
        Self {
            c: (ln_gamma(p + 0.5) - ln_gamma(p)).exp() / PI64.sqrt(),
            inv_beta: ln_inv_beta(p, 0.5).exp(),
        }
    }
}

/// p = 1/alpha^2, the shape parameter of Blinn-Phong's slope marginal.
fn blinn_phong_p(alpha: f32) -> f64 {
    1.0 / f64::from(alpha).powi(2)
}

impl Ndf {
    /// An NDF of `kind` with width `alpha`, clamped to
    /// [`ALPHA_MIN`, `ALPHA_MAX`] ([`ALPHA_MIN`, 1] for Blinn-Phong); NaN
    /// becomes `ALPHA_MIN`.
    pub fn new(kind: NdfKind, alpha: f32) -> Self {
        let max = match kind {
            NdfKind::BlinnPhong => BLINN_PHONG_ALPHA_MAX,
            NdfKind::Ggx | NdfKind::Beckmann => ALPHA_MAX,
        };
        let alpha = alpha.max(ALPHA_MIN).min(max);
        let exact = if kind == NdfKind::BlinnPhong && alpha >= BLINN_PHONG_EXACT_LAMBDA_MIN_ALPHA {
            BlinnPhongLambda::new(alpha)
        } else {
            BlinnPhongLambda::NONE
        };
        let unit_g1_cot2 = unit_g1_cot2(kind, alpha, &exact);
        Self {
            kind,
            alpha,
            exact,
            unit_g1_cot2,
        }
    }

    /// The distribution family.
    pub fn kind(&self) -> NdfKind {
        self.kind
    }

    /// The width parameter alpha (after clamping).
    pub fn alpha(&self) -> f32 {
        self.alpha
    }

    /// The same family with another alpha.
    pub fn with_alpha(&self, alpha: f32) -> Self {
        Self::new(self.kind, alpha)
    }

    /// Blinn-Phong exponent n = 2/alpha^2 - 2 equivalent to this alpha (supp. eq. 5).
    pub fn blinn_phong_exponent(&self) -> f64 {
        2.0 / f64::from(self.alpha).powi(2) - 2.0
    }

    /// D(h) (supp. eq. 1, 2, 5) for a unit microfacet normal h; 0 when h is
    /// not strictly above the surface (h.z <= 0).
    pub fn d(&self, h: Vec3) -> f32 {
        if h.z <= 0.0 {
            return 0.0;
        }
        let a2 = self.alpha * self.alpha;
        let s2 = sin2_theta(h);
        let c2 = h.z * h.z;
        match self.kind {
            // 1 / (pi a^2 (c^2 + s^2/a^2)^2): finite for every h, no tan^2 overflow.
            NdfKind::Ggx => {
                let t = c2 + s2 / a2;
                1.0 / (PI * a2 * t * t)
            }
            // exp(-tan^2/a^2) / (pi a^2 c^4), in f64: c^4 a^2 underflows f32 at grazing.
            NdfKind::Beckmann => {
                let (a2, s2, c2) = (f64::from(a2), f64::from(s2), f64::from(c2));
                ((-s2 / (a2 * c2)).exp() / (PI64 * a2 * c2 * c2)) as f32
            }
            // c^n / (pi a^2), c^n = exp(n/2 ln c^2) with ln c^2 = ln(1 - s^2)
            // near the normal (exact there) and ln(c^2) towards grazing.
            NdfKind::BlinnPhong => {
                let n = self.blinn_phong_exponent();
                let ln_c2 = if s2 < 0.5 {
                    (-f64::from(s2)).ln_1p()
                } else {
                    f64::from(c2).ln()
                };
                let cn = if n == 0.0 {
                    1.0
                } else {
                    (0.5 * n * ln_c2).exp()
                };
                (cn / (PI64 * f64::from(a2))) as f32
            }
        }
    }

    /// The supremum of D over all h (SPEC §1 table, supp. eq. 1-3, 5).
    ///
    /// 1/(pi alpha^2) at h = n, except GGX with alpha > 1 (alpha^2/pi, at
    /// grazing) and Beckmann with alpha > 1/sqrt(2) (supp. eq. 3, at
    /// <h,n> = 1/(sqrt(2) alpha)).
    pub fn d_max(&self) -> f32 {
        let a = self.alpha;
        match self.kind {
            NdfKind::Ggx if a > 1.0 => a * a / PI,
            NdfKind::Beckmann if a > BECKMANN_PEAK_SHIFT_ALPHA => {
                let a = f64::from(a);
                (4.0 * a * a * (1.0 / (a * a) - 2.0).exp() / PI64) as f32
            }
            _ => 1.0 / (PI * a * a),
        }
    }

    /// An upper bound of D that can be inverted for alpha: `d_max` except for
    /// Beckmann with alpha > 1/sqrt(2), where it is supp. eq. 4,
    /// (4 alpha^2 + 2(e^2 - 1)) / (pi e^2).
    pub fn d_max_bound(&self) -> f32 {
        match self.kind {
            NdfKind::Beckmann if self.alpha > BECKMANN_PEAK_SHIFT_ALPHA => {
                let e2 = std::f32::consts::E * std::f32::consts::E;
                (4.0 * self.alpha * self.alpha + 2.0 * (e2 - 1.0)) / (PI * e2)
            }
            _ => self.d_max(),
        }
    }

    /// Smith's Lambda(w) (SPEC §1); depends on |cos theta| only. 0 at normal
    /// incidence, +infinity for w in the tangent plane.
    ///
    /// Blinn-Phong uses its exact Lambda (see `lambda_blinn_phong`), not
    /// Beckmann's: with Beckmann's, a lossless Blinn-Phong lobe at alpha = 1
    /// reflects up to 30 % more energy than it receives.
    pub fn lambda(&self, w: Vec3) -> f32 {
        let c2 = w.z * w.z;
        if c2 == 0.0 {
            return f32::INFINITY;
        }
        let s2 = sin2_theta(w);
        match self.kind {
            NdfKind::Ggx => {
                // (sqrt(1 + x) - 1)/2 = x / (2 (1 + sqrt(1 + x))), x = a^2 tan^2: no cancellation.
                let x = self.alpha * self.alpha * s2 / c2;
                if x.is_finite() {
                    x / (2.0 * (1.0 + (1.0 + x).sqrt()))
                } else {
                    f32::INFINITY
                }
            }
            NdfKind::Beckmann => lambda_beckmann(self.alpha, s2, c2),
            NdfKind::BlinnPhong if self.alpha < BLINN_PHONG_EXACT_LAMBDA_MIN_ALPHA => {
                lambda_beckmann(self.alpha, s2, c2)
            }
            NdfKind::BlinnPhong => lambda_blinn_phong(self.alpha, &self.exact, s2, c2),
        }
    }

    /// Smith's masking G1(w) = 1 / (1 + Lambda(w)), in [0, 1].
    /// Exactly 1 where Lambda is too small to move it (`unit_g1_cot2`).
    pub fn g1(&self, w: Vec3) -> f32 {
        if w.z * w.z >= self.unit_g1_cot2 * sin2_theta(w) {
            return 1.0;
        }
        1.0 / (1.0 + self.lambda(w))
    }

    /// lim G1(w)/|<w,n>| as <w,n> -> 0 (supp. §2): 2/alpha for GGX,
    /// 2 sqrt(pi)/alpha for Beckmann. Blinn-Phong: the limit of its exact
    /// Lambda, (2a - 1) sqrt(pi) Gamma(a) / Gamma(a + 1/2) with a = 1/alpha^2,
    /// which tends to Beckmann's value as alpha -> 0.
    pub fn g1_over_cos_limit(&self) -> f32 {
        let a = f64::from(self.alpha);
        let limit = match self.kind {
            NdfKind::Ggx => 2.0 / a,
            NdfKind::Beckmann => 2.0 * PI64.sqrt() / a,
            NdfKind::BlinnPhong if self.alpha < BLINN_PHONG_EXACT_LAMBDA_MIN_ALPHA => {
                2.0 * PI64.sqrt() / a
            }
            NdfKind::BlinnPhong => {
                let p = 1.0 / (a * a);
                (2.0 * p - 1.0) * PI64.sqrt() * (ln_gamma(p) - ln_gamma(p + 0.5)).exp()
            }
        };
        limit as f32
    }

    /// The supremum over all directions of G1(w)/|<w,n>| (SPEC §2): at normal
    /// incidence the ratio is 1, so the bound is max(1, limit); for Beckmann
    /// the ratio has an interior maximum near alpha = 3.6, covered by
    /// `BECKMANN_G1_OVER_COS_SAFETY`.
    pub fn g1_over_cos_sup(&self) -> f32 {
        let bound = self.g1_over_cos_limit().max(1.0);
        match self.kind {
            NdfKind::Ggx => bound,
            NdfKind::Beckmann | NdfKind::BlinnPhong => bound * BECKMANN_G1_OVER_COS_SAFETY,
        }
    }

    /// Samples a microfacet normal with density D(h)<h,n> (per solid angle of h).
    ///
    /// theta_h by inverting the marginal CDF: tan^2 = a^2 u/(1-u) for GGX,
    /// -a^2 ln(1-u) for Beckmann, cos^2 = u^(a^2) for Blinn-Phong; phi = 2 pi u.y.
    /// Computed in f64 through cos^2 and sin^2 directly, so u.x = 0 or 1 and
    /// tiny alpha give finite unit vectors.
    pub fn sample_d_cos(&self, u: Vec2) -> Vec3 {
        let (cos2, sin2) = self.d_cos_polar(f64::from(u.x));
        let phi = 2.0 * PI64 * f64::from(u.y);
        let sin_theta = sin2.max(0.0).sqrt();
        Vec3::new(
            (sin_theta * phi.cos()) as f32,
            (sin_theta * phi.sin()) as f32,
            cos2.max(0.0).sqrt() as f32,
        )
    }

    /// (cos^2, sin^2) of the polar angle that `sample_d_cos` gives the
    /// radial uniform `u1`, in f64 (the albedo quadrature needs u1 closer to
    /// 1 than f32 resolves: GGX's normals near the horizon).
    pub(crate) fn d_cos_polar(&self, u1: f64) -> (f64, f64) {
        let a2 = f64::from(self.alpha).powi(2);
        match self.kind {
            NdfKind::Ggx => {
                let denominator = (1.0 - u1) + a2 * u1;
                ((1.0 - u1) / denominator, a2 * u1 / denominator)
            }
            NdfKind::Beckmann => {
                let tan2 = -a2 * (-u1).ln_1p();
                if tan2.is_finite() {
                    (1.0 / (1.0 + tan2), tan2 / (1.0 + tan2))
                } else {
                    (0.0, 1.0)
                }
            }
            NdfKind::BlinnPhong => {
                let ln_cos2 = a2 * u1.ln();
                (ln_cos2.exp(), -ln_cos2.exp_m1())
            }
        }
    }

    /// Density of `sample_d_cos`: D(h)<h,n>.
    pub fn pdf_d_cos(&self, h: Vec3) -> f32 {
        self.d(h) * h.z.max(0.0)
    }
}

/// The cot^2 theta = mu^2 above which Lambda < [`LAMBDA_NEGLIGIBLE`] = eps,
/// from upper bounds of Lambda that are decreasing in mu:
/// - Beckmann, and Blinn-Phong below the exact form's alpha: `lambda_beckmann`
///   drops its erfc term, Lambda <= exp(-m^2) / (2 m sqrt(pi)) with
///   m = mu/alpha; for m >= 1 that is below eps once m^2 >= ln(1 / (2 sqrt(pi) eps)).
/// - Blinn-Phong's exact Lambda drops its incomplete beta term (>= 0):
///   Lambda <= K (1 + mu^2)^(1/2 - p) / mu with K = C / (2p - 1). On mu >= m0
///   that is below eps once ln(1 + mu^2) >= ln(K / (m0 eps)) / (p - 1/2).
///   First with m0 = 1; if the threshold t1 found lies below 1, again with
///   m0 = sqrt(t1), which gives a larger threshold, so mu >= m0 holds on it.
/// - GGX: never (its Lambda costs one square root).
fn unit_g1_cot2(kind: NdfKind, alpha: f32, exact: &BlinnPhongLambda) -> f32 {
    let cot2 = match kind {
        NdfKind::Ggx => f64::INFINITY,
        NdfKind::BlinnPhong if exact.c > 0.0 => {
            let p = blinn_phong_p(alpha);
            let ln_k_over_eps = (exact.c / (2.0 * p - 1.0) / LAMBDA_NEGLIGIBLE).ln();
            let threshold = |ln_m0: f64| ((ln_k_over_eps - ln_m0) / (p - 0.5)).exp_m1();
            let t1 = threshold(0.0);
            if t1 >= 1.0 {
                t1
            } else {
                threshold(0.5 * t1.ln())
            }
        }
        NdfKind::Beckmann | NdfKind::BlinnPhong => {
            let m2 = (1.0 / (2.0 * PI64.sqrt() * LAMBDA_NEGLIGIBLE))
                .ln()
                .max(1.0);
            m2 * f64::from(alpha).powi(2)
        }
    };
    cot2 as f32
}

/// Beckmann's Lambda (Walter et al. 2007) with m = 1/(a tan theta):
/// (erf(m) - 1)/2 + exp(-m^2)/(2 m sqrt(pi)) = (exp(-m^2)/(m sqrt(pi)) - erfc(m))/2,
/// in f64 with the f32-exact erfc (SPEC §1: not Walter's rational fit).
fn lambda_beckmann(alpha: f32, s2: f32, c2: f32) -> f32 {
    if s2 == 0.0 {
        return 0.0;
    }
    let m = (f64::from(c2) / f64::from(s2)).sqrt() / f64::from(alpha);
    let lambda = 0.5 * ((-m * m).exp() / (m * PI64.sqrt()) - erfc(m));
    lambda.max(0.0) as f32
}

/// Exact Smith Lambda of the Blinn-Phong NDF.
///
/// Its slope distribution is P22 = D cos^4 = (n+2)/(2 pi) (1 + r^2)^-(n+4)/2,
/// whose 1-D marginal is P2(q) = C (1 + q^2)^-(p + 1/2) with p = 1/alpha^2
/// and C = Gamma(p + 1/2) / (sqrt(pi) Gamma(p)) (a scaled Student t). With
/// mu = cot theta, Smith's Lambda (1/mu) int_mu^inf (q - mu) P2(q) dq becomes
/// Lambda = [C (1 + mu^2)^(1/2 - p) / (2p - 1) - (mu/2) I_x(p, 1/2)] / mu,
/// x = 1/(1 + mu^2), I the regularized incomplete beta function.
/// `exact` holds C and 1/B(p, 1/2) for this alpha. Both terms share the
/// power U = (1 + mu^2)^(1/2 - p): I_x's front factor x^p (1 - x)^(1/2) / B
/// is mu U x / B, so one logarithm and one exponential serve both (they
/// were a quarter of Lambda's instructions as separate logarithms).
fn lambda_blinn_phong(alpha: f32, exact: &BlinnPhongLambda, s2: f32, c2: f32) -> f32 {
    if s2 == 0.0 {
        return 0.0;
    }
    let p = blinn_phong_p(alpha);
    let mu2 = f64::from(c2) / f64::from(s2);
    let mu = mu2.sqrt();
    let power = ((0.5 - p) * mu2.ln_1p()).exp();
    let upper = exact.c * power / (2.0 * p - 1.0);
    let x = 1.0 / (1.0 + mu2);
    let front = exact.inv_beta * mu * power * x;
    let tail = 0.5 * mu * beta_inc_from_front(p, 0.5, x, front);
    ((upper - tail) / mu).max(0.0) as f32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn alpha_is_clamped_to_the_domain() {
        assert_eq!(Ndf::new(NdfKind::Ggx, 0.0).alpha(), ALPHA_MIN);
        assert_eq!(Ndf::new(NdfKind::Ggx, f32::NAN).alpha(), ALPHA_MIN);
        assert_eq!(Ndf::new(NdfKind::Beckmann, 1e9).alpha(), ALPHA_MAX);
        assert_eq!(Ndf::new(NdfKind::BlinnPhong, 3.0).alpha(), 1.0);
        assert_eq!(Ndf::new(NdfKind::Ggx, 3.0).alpha(), 3.0);
    }

    #[test]
    fn peak_values_match_the_table() {
        for kind in [NdfKind::Ggx, NdfKind::Beckmann, NdfKind::BlinnPhong] {
            let ndf = Ndf::new(kind, 0.3);
            let expected = 1.0 / (PI * 0.09);
            assert!((ndf.d(Vec3::Z) / expected - 1.0).abs() < 1e-6, "{kind:?}");
            assert!((ndf.d_max() / expected - 1.0).abs() < 1e-6, "{kind:?}");
        }
        // Blinn-Phong with alpha = 1 is the constant 1/pi.
        let flat = Ndf::new(NdfKind::BlinnPhong, 1.0);
        assert!((flat.d(Vec3::new(0.6, 0.0, 0.8)) - 1.0 / PI).abs() < 1e-7);
    }

    #[test]
    fn beckmann_off_normal_maximum() {
        let a = 1.5f32;
        let ndf = Ndf::new(NdfKind::Beckmann, a);
        let c = 1.0 / (2f32.sqrt() * a);
        let h = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
        assert!((ndf.d(h) / ndf.d_max() - 1.0).abs() < 1e-5);
        assert!(ndf.d_max_bound() >= ndf.d_max());
        // Continuity of eq. 3 and eq. 4 with 1/(pi alpha^2) at alpha = 1/sqrt(2).
        let at = Ndf::new(NdfKind::Beckmann, BECKMANN_PEAK_SHIFT_ALPHA);
        let just_above = Ndf::new(NdfKind::Beckmann, BECKMANN_PEAK_SHIFT_ALPHA * (1.0 + 1e-6));
        assert!((at.d_max() / just_above.d_max() - 1.0).abs() < 1e-4);
        assert!((at.d_max() / just_above.d_max_bound() - 1.0).abs() < 1e-4);
    }

    #[test]
    fn blinn_phong_exact_lambda_at_alpha_one() {
        // n = 0: Lambda = (sqrt(1 + mu^2) - mu) / (2 mu) in closed form.
        let ndf = Ndf::new(NdfKind::BlinnPhong, 1.0);
        for c in [0.05f32, 0.3, 0.7, 0.99] {
            let w = Vec3::new((1.0 - c * c).sqrt(), 0.0, c);
            let mu = c / (1.0 - c * c).sqrt();
            let expected = ((1.0 + mu * mu).sqrt() - mu) / (2.0 * mu);
            assert!((ndf.lambda(w) / expected - 1.0).abs() < 1e-5, "c {c}");
        }
        assert!((ndf.g1_over_cos_limit() - 2.0).abs() < 1e-5);
    }

    #[test]
    fn blinn_phong_lambda_tends_to_beckmann() {
        // Just above and below the switch to Beckmann's Lambda: close to each other.
        let w = Vec3::new(0.995f32.sqrt(), 0.0, 0.005f32.sqrt());
        let exact = Ndf::new(NdfKind::BlinnPhong, BLINN_PHONG_EXACT_LAMBDA_MIN_ALPHA);
        let beckmann = Ndf::new(NdfKind::Beckmann, BLINN_PHONG_EXACT_LAMBDA_MIN_ALPHA);
        assert!(
            (exact.g1(w) - beckmann.g1(w)).abs() < 1e-4,
            "{} {}",
            exact.g1(w),
            beckmann.g1(w)
        );
    }

    #[test]
    fn d_cos_sampling_edges_stay_finite() {
        for kind in [NdfKind::Ggx, NdfKind::Beckmann, NdfKind::BlinnPhong] {
            for alpha in [1e-7, 0.5, 1.0, 10.0] {
                let ndf = Ndf::new(kind, alpha);
                for u in [Vec2::ZERO, Vec2::new(1.0, 0.999_999_9), Vec2::new(0.5, 0.5)] {
                    let h = ndf.sample_d_cos(u);
                    assert!(
                        h.is_finite() && (h.length() - 1.0).abs() < 1e-5,
                        "{kind:?} {alpha} {u} {h}"
                    );
                    assert!(h.z >= 0.0);
                }
            }
        }
    }

    /// The precomputed factors and the shared power change no bit of
    /// Blinn-Phong's exact Lambda: the formula evaluated in full (C and I_x
    /// from scratch, its front factor by logarithms) agrees exactly. (So did
    /// the present code against the former one, front factor by logarithms
    /// and continued fraction by the Lentz method, on a 200 x 999 grid of
    /// alpha and cosine, checked once.)
    #[test]
    fn blinn_phong_lambda_factors_are_exact() {
        use crate::special::beta_inc;
        for alpha in [BLINN_PHONG_EXACT_LAMBDA_MIN_ALPHA, 0.0743, 0.3, 0.9, 1.0] {
            let ndf = Ndf::new(NdfKind::BlinnPhong, alpha);
            for cos in [1e-4f32, 0.05, 0.3, 0.7, 0.99] {
                let w = Vec3::new((1.0 - cos * cos).sqrt(), 0.0, cos);
                let (s2, c2) = (sin2_theta(w), w.z * w.z);
                let p = 1.0 / f64::from(alpha).powi(2);
                let mu2 = f64::from(c2) / f64::from(s2);
                let mu = mu2.sqrt();
                let c = (ln_gamma(p + 0.5) - ln_gamma(p)).exp() / PI64.sqrt();
                let upper = c * ((0.5 - p) * mu2.ln_1p()).exp() / (2.0 * p - 1.0);
                let tail = 0.5 * mu * beta_inc(p, 0.5, 1.0 / (1.0 + mu2));
                let direct = ((upper - tail) / mu).max(0.0) as f32;
                assert_eq!(ndf.lambda(w).to_bits(), direct.to_bits(), "{alpha} {cos}");
            }
        }
    }

    /// G1's shortcut to 1 changes no bit of G1: on a fine grid of angles
    /// around each threshold, `g1` equals 1/(1 + Lambda) exactly. The
    /// thresholds are also not vacuous: on SmallVCM's glossy floor (Blinn-Phong,
    /// alpha 0.0743) G1 skips Lambda for every direction within 70 degrees of
    /// the normal. (A `LAMBDA_NEGLIGIBLE` of 2^-16 fails it, checked once.)
    #[test]
    fn unit_g1_shortcut_is_exact() {
        for kind in [NdfKind::Beckmann, NdfKind::BlinnPhong] {
            for alpha in [1e-3f32, 0.005, 0.01, 0.0743, 0.2, 0.5, 0.9, 1.0] {
                let ndf = Ndf::new(kind, alpha);
                let cot = ndf.unit_g1_cot2.sqrt();
                let mut skipped = 0;
                for i in -2000..=2000 {
                    let theta = (1.0f32 / cot).atan() * (1.0 + i as f32 * 1e-4);
                    let w = Vec3::new(theta.sin(), 0.0, theta.cos());
                    let full = 1.0 / (1.0 + ndf.lambda(w));
                    assert_eq!(
                        ndf.g1(w).to_bits(),
                        full.to_bits(),
                        "{kind:?} {alpha} {theta}"
                    );
                    skipped += usize::from(w.z * w.z >= ndf.unit_g1_cot2 * sin2_theta(w));
                }
                assert!(skipped > 1000, "{kind:?} {alpha}: {skipped}");
            }
        }
        let floor = Ndf::new(NdfKind::BlinnPhong, 0.0743);
        assert!(floor.unit_g1_cot2 < 70f32.to_radians().tan().recip().powi(2));
    }
}
