//! Special functions the microfacet formulas need, in f64.
//!
//! Rust's standard library has no stable `erf` yet, and this crate depends on
//! glam alone, so the few functions below are implemented here. Each states
//! its accuracy; the tests check them against the high-precision references
//! of the `stats` crate.

use std::f64::consts::PI;

/// 2 / sqrt(pi).
const TWO_OVER_SQRT_PI: f64 = std::f64::consts::FRAC_2_SQRT_PI;

/// Below this |x|, erf uses its Maclaurin series (7 terms reach 1e-10
/// relative at the edge), where `1 - erfc(x)` would lose relative precision.
const ERF_SERIES_LIMIT: f64 = 0.5;

/// erfc(x), relative error below 1.2e-7 for every x (Chebyshev fit of
/// Press et al., Numerical Recipes 2nd ed. §6.2, `erfcc`): f32-exact.
pub fn erfc(x: f64) -> f64 {
    let z = x.abs();
    let t = 1.0 / (1.0 + 0.5 * z);
    let poly = -z * z - 1.265_512_23
        + t * (1.000_023_68
            + t * (0.374_091_96
                + t * (0.096_784_18
                    + t * (-0.186_288_06
                        + t * (0.278_868_07
                            + t * (-1.135_203_98
                                + t * (1.488_515_87 + t * (-0.822_152_23 + t * 0.170_872_77))))))));
    let r = t * poly.exp();
    if x >= 0.0 { r } else { 2.0 - r }
}

/// erf(x), absolute error below 1.2e-7 and relative error below 2e-7.
pub fn erf(x: f64) -> f64 {
    if x.abs() < ERF_SERIES_LIMIT {
        // erf x = 2/sqrt(pi) sum_n (-1)^n x^(2n+1) / (n! (2n+1)) (A&S 7.1.5)
        let x2 = x * x;
        let series = 1.0
            - x2 * (1.0 / 3.0
                - x2 * (1.0 / 10.0
                    - x2 * (1.0 / 42.0
                        - x2 * (1.0 / 216.0 - x2 * (1.0 / 1320.0 - x2 * (1.0 / 9360.0))))));
        TWO_OVER_SQRT_PI * x * series
    } else {
        x.signum() * (1.0 - erfc(x.abs()))
    }
}

/// Largest w = -ln(1 - y^2) of Giles' single-precision fit (|y| up to
/// 1 - 2^-24, where its relative error is about 1e-7).
const GILES_FIT_W_MAX: f64 = 16.0;

/// Most Halley steps of [`erf_inv`] beyond Giles' fit (eight reach f64
/// round-off from its worst start), and the relative step that ends them.
const ERF_INV_MAX_STEPS: usize = 16;
const ERF_INV_TOLERANCE: f64 = 1e-12;

/// Inverse error function: erf(erf_inv(y)) = y for y in (-1, 1); +-infinity at
/// +-1, NaN outside [-1, 1].
///
/// Giles' single-precision approximation (M. Giles, "Approximating the erfinv
/// function", GPU Computing Gems Jade, 2011: a polynomial in
/// w = -ln(1 - y^2)): up to |y| = 1 - 2^-24 (w = 16) erf of its result is
/// within 1.2e-7 of y relatively (worst of 2e6 points against the `stats`
/// reference), as accurate as `erf` itself, for one logarithm. Beyond, its
/// error grows to a factor 70 in erfc at 1 - 1e-15, and Halley steps on
/// erfc(x) = 1 - |y| refine it to `erfc`'s accuracy. Winitzki's formula with
/// two Newton steps, before, took a logarithm and four exponentials.
pub(crate) fn erf_inv(y: f64) -> f64 {
    if !(-1.0..=1.0).contains(&y) {
        return f64::NAN;
    }
    if y.abs() == 1.0 {
        return y * f64::INFINITY;
    }
    // 1 - y^2 = q (2 - q) keeps relative precision in the tails.
    let q = 1.0 - y.abs();
    let w = -(q * (2.0 - q)).ln();
    let mut x = y.abs() * giles_erf_inv_factor(w);
    if w <= GILES_FIT_W_MAX {
        return x.copysign(y);
    }
    // Beyond the fit's range the start is off by up to a factor 2,000 in
    // erfc (|y| = 1 - 2^-53), from where the steps converge linearly at
    // first: steps until they stop moving x.
    for _ in 0..ERF_INV_MAX_STEPS {
        // Halley on erf(x) = |y| in its tail form f(x) = q - erfc(x), which
        // keeps relative precision (f' = D = 2/sqrt(pi) exp(-x^2),
        // f'' = -2 x D): x - f / (D + x f).
        let density = TWO_OVER_SQRT_PI * (-x * x).exp();
        let f = q - erfc(x);
        let step = f / (density + x * f);
        x -= step;
        if !(step.abs() > ERF_INV_TOLERANCE * x) {
            break;
        }
    }
    x.copysign(y)
}

/// erf_inv(y) / y as a polynomial in w = -ln(1 - y^2): Giles' coefficients
/// (single precision), one polynomial in w - 2.5 below w = 5, one in
/// sqrt(w) - 3 above.
fn giles_erf_inv_factor(w: f64) -> f64 {
    if w < 5.0 {
        let w = w - 2.5;
        let mut p = 2.810_226_36e-8;
        for c in [
            3.432_739_39e-7,
            -3.523_387_7e-6,
            -4.391_506_54e-6,
            2.185_808_7e-4,
            -1.253_725_03e-3,
            -4.177_681_64e-3,
            2.466_407_27e-1,
            1.501_409_41,
        ] {
            p = c + p * w;
        }
        p
    } else {
        let w = w.sqrt() - 3.0;
        let mut p = -2.002_142_57e-4;
        for c in [
            1.009_505_58e-4,
            1.349_343_22e-3,
            -3.673_428_44e-3,
            5.739_507_73e-3,
            -7.622_461_3e-3,
            9.438_870_47e-3,
            1.001_674_06,
            2.832_976_82,
        ] {
            p = c + p * w;
        }
        p
    }
}

/// ln Gamma(x) for x > 0, relative error below 1e-13.
///
/// Shifts the argument to z >= 8 with Gamma(x) = Gamma(x + k) / (x (x+1) ... (x+k-1))
/// and applies Stirling's series with terms to z^-9 (A&S 6.1.41), which is
/// exact to f64 round-off for arguments >= 8.
pub(crate) fn ln_gamma(x: f64) -> f64 {
    const STIRLING_MIN: f64 = 8.0;
    let mut shift_product = 1.0;
    let mut z = x;
    while z < STIRLING_MIN {
        shift_product *= z;
        z += 1.0;
    }
    let inv = 1.0 / z;
    let inv2 = inv * inv;
    let series = inv
        * (1.0 / 12.0
            - inv2
                * (1.0 / 360.0
                    - inv2 * (1.0 / 1260.0 - inv2 * (1.0 / 1680.0 - inv2 * (1.0 / 1188.0)))));
    (z - 0.5) * z.ln() - z + 0.5 * (2.0 * PI).ln() + series - shift_product.ln()
}

/// Iteration cap of the incomplete-beta continued fraction. It converges in
/// O(sqrt(max(a, b))) steps near the distribution's mean; the microfacet code
/// calls it with a = 1/alpha^2 <= 1e4 (see `ndf::BLINN_PHONG_EXACT_LAMBDA_MIN_ALPHA`).
const BETA_MAX_ITERATIONS: usize = 2_000;
/// Relative convergence threshold of the continued fraction.
const BETA_CONVERGED: f64 = 1e-13;
/// Magnitude at which the continued fraction's convergents are rescaled:
/// the recurrences are linear, so scaling numerator and denominator together
/// changes no convergent, and they stay far from overflow.
const RECURRENCE_RESCALE: f64 = 1e150;

/// Regularized incomplete beta function I_x(a, b), a, b > 0, x in [0, 1].
///
/// Continued fraction of DLMF 8.17.22 (`beta_continued_fraction`), on whichever of x and 1 - x makes it converge fast (DLMF 8.17.4 symmetry).
#[cfg(test)]
pub(crate) fn beta_inc(a: f64, b: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    let front = (ln_inv_beta(a, b) + a * x.ln() + b * (-x).ln_1p()).exp();
    beta_inc_from_front(a, b, x, front)
}

/// ln(1 / B(a, b)) = ln Gamma(a + b) - ln Gamma(a) - ln Gamma(b): the part of
/// [`beta_inc`]'s front factor that does not depend on x.
pub(crate) fn ln_inv_beta(a: f64, b: f64) -> f64 {
    ln_gamma(a + b) - ln_gamma(a) - ln_gamma(b)
}

/// [`beta_inc`] with its whole front factor x^a (1 - x)^b / B(a, b) (DLMF
/// 8.17.22) given, for callers that have its powers at hand without
/// logarithms (`ndf::lambda_blinn_phong`).
pub(crate) fn beta_inc_from_front(a: f64, b: f64, x: f64, front: f64) -> f64 {
    if x <= 0.0 {
        return 0.0;
    }
    if x >= 1.0 {
        return 1.0;
    }
    if x < (a + 1.0) / (a + b + 2.0) {
        front * beta_continued_fraction(a, b, x) / a
    } else {
        1.0 - front * beta_continued_fraction(b, a, 1.0 - x) / b
    }
}

/// The continued fraction 1/(1 + e_1/(1 + e_2/(1 + ...))) of DLMF 8.17.22
/// (Numerical Recipes' `betacf`), with e_1 = -(a + b) x / (a + 1) and for
/// m >= 1
/// e_2m = m (b - m) x / ((a + 2m - 1)(a + 2m)),
/// e_2m+1 = -(a + m)(a + b + m) x / ((a + 2m)(a + 2m + 1)).
///
/// Evaluated by the forward recurrence of its convergents A_k / B_k
/// (Wallis; DLMF 1.12.5): A_k = A_k-1 + e_k-1 A_k-2, the same for B. Unlike
/// the modified Lentz method, no division depends on the previous step's,
/// so the steps pipeline (Lentz's chained divisions made this function 8 %
/// of PT's time on a Blinn-Phong floor). Stops when a pair of steps changes
/// the convergent by less than `BETA_CONVERGED` relative, compared without
/// dividing.
fn beta_continued_fraction(a: f64, b: f64, x: f64) -> f64 {
    // (A_k-1, B_k-1) and (A_k, B_k) after the first coefficient: 1/(1 + e_1).
    let (mut a_prev, mut b_prev) = (1.0, 1.0);
    let (mut a_k, mut b_k) = (1.0, 1.0 - (a + b) * x / (a + 1.0));
    let step = |(a_prev, b_prev): (f64, f64), (a_k, b_k): (f64, f64), e: f64| {
        (a_k + e * a_prev, b_k + e * b_prev)
    };
    for m in 1..BETA_MAX_ITERATIONS {
        let m = m as f64;
        let even = m * (b - m) * x / ((a + 2.0 * m - 1.0) * (a + 2.0 * m));
        let odd = -(a + m) * (a + b + m) * x / ((a + 2.0 * m) * (a + 2.0 * m + 1.0));
        let after_even = step((a_prev, b_prev), (a_k, b_k), even);
        let after_odd = step((a_k, b_k), after_even, odd);
        (a_prev, b_prev) = after_even;
        (a_k, b_k) = after_odd;
        // |A_odd / B_odd - A_even / B_even| < eps |A_even / B_even|.
        let change = (a_k * b_prev - a_prev * b_k).abs();
        if change < BETA_CONVERGED * (a_prev * b_k).abs() {
            break;
        }
        if b_k.abs() > RECURRENCE_RESCALE {
            let s = 1.0 / RECURRENCE_RESCALE;
            (a_prev, b_prev, a_k, b_k) = (a_prev * s, b_prev * s, a_k * s, b_k * s);
        }
    }
    a_k / b_k
}

#[cfg(test)]
mod tests {
    use super::*;
    use stats::special as reference;

    #[test]
    fn erfc_matches_reference_in_relative_terms() {
        let mut worst: f64 = 0.0;
        for i in -6000..27_000 {
            let x = f64::from(i) * 1e-3;
            let r = reference::erfc_reference(x);
            if r > 1e-300 {
                worst = worst.max(((erfc(x) - r) / r).abs());
            }
        }
        assert!(worst < 1.2e-7, "worst relative error {worst:e}");
    }

    #[test]
    fn erf_matches_reference() {
        let mut worst: f64 = 0.0;
        for i in -6000..6000 {
            let x = f64::from(i) * 1e-3 + 1e-9;
            let r = reference::erf_reference(x);
            worst = worst.max(((erf(x) - r) / r).abs());
        }
        assert!(worst < 2e-7, "worst relative error {worst:e}");
        assert_eq!(erf(0.0), 0.0);
    }

    #[test]
    fn erf_inv_inverts_erf() {
        for i in 1..2000 {
            let y = -1.0 + f64::from(i) * 1e-3;
            let x = erf_inv(y);
            assert!(
                (reference::erf_reference(x) - y).abs() < 3e-7 * y.abs().max(1e-3),
                "y {y} x {x}"
            );
        }
        // Deep tails keep relative precision in 1 - |y|.
        for q in [1e-8, 1e-12, 1e-15] {
            let y = 1.0 - q;
            let q = 1.0 - y; // what the input can represent
            let x = erf_inv(y);
            assert!(
                (reference::erfc_reference(x) / q - 1.0).abs() < 1e-5,
                "q {q}"
            );
        }
        assert_eq!(erf_inv(1.0), f64::INFINITY);
        assert_eq!(erf_inv(-1.0), f64::NEG_INFINITY);
        assert!(erf_inv(1.5).is_nan());
    }

    #[test]
    fn ln_gamma_matches_reference() {
        for i in 1..400 {
            let x = f64::from(i) * 0.0371;
            let r = reference::ln_gamma(x);
            assert!((ln_gamma(x) - r).abs() < 1e-12 * r.abs().max(1.0), "x {x}");
        }
        assert!((ln_gamma(1e6) - reference::ln_gamma(1e6)).abs() < 1e-12 * 1.3e7);
    }

    #[test]
    fn beta_inc_known_values() {
        // I_x(1, b) = 1 - (1 - x)^b and I_x(a, 1) = x^a.
        for x in [0.01, 0.3, 0.7, 0.999] {
            assert!((beta_inc(1.0, 0.5, x) - (1.0 - (1.0 - x).sqrt())).abs() < 1e-12);
            assert!((beta_inc(3.5, 1.0, x) - x.powf(3.5)).abs() < 1e-12);
            // Symmetry I_x(a, b) = 1 - I_{1-x}(b, a).
            assert!((beta_inc(40.0, 0.5, x) + beta_inc(0.5, 40.0, 1.0 - x) - 1.0).abs() < 1e-12);
        }
        assert_eq!(beta_inc(2.0, 0.5, 0.0), 0.0);
        assert_eq!(beta_inc(2.0, 0.5, 1.0), 1.0);
    }
}
