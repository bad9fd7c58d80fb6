//! Special functions for the statistical tests, in f64.
//!
//! These are references, not hot-path code: they favour accuracy (close to
//! f64 round-off) over speed.

use std::f64::consts::PI;

/// Lanczos approximation, g = 7, 9 terms (Numerical Recipes 3rd ed. §6.1;
/// Godfrey's coefficients): relative error below 1e-15 for x > 0.
const LANCZOS_G: f64 = 7.0;
const LANCZOS: [f64; 9] = [
    0.999_999_999_999_809_9,
    676.520_368_121_885_1,
    -1_259.139_216_722_402_8,
    771.323_428_777_653_1,
    -176.615_029_162_140_6,
    12.507_343_278_686_905,
    -0.138_571_095_265_720_12,
    9.984_369_578_019_572e-6,
    1.505_632_735_149_311_6e-7,
];

/// Iteration cap of the incomplete-gamma series and continued fraction; both
/// converge in far fewer steps for the arguments chi-square tests produce.
const MAX_ITERATIONS: usize = 10_000;
/// Relative convergence threshold of the series and continued fractions.
const CONVERGED: f64 = 1e-15;
/// Smallest magnitude the modified Lentz algorithm lets a denominator take.
const LENTZ_TINY: f64 = 1e-300;

/// ln Gamma(x) for x > 0.
pub fn ln_gamma(x: f64) -> f64 {
    if x < 0.5 {
        // Reflection: Gamma(x) Gamma(1-x) = pi / sin(pi x).
        return (PI / (PI * x).sin()).ln() - ln_gamma(1.0 - x);
    }
    let x = x - 1.0;
    let t = x + LANCZOS_G + 0.5;
    let series = LANCZOS[1..]
        .iter()
        .enumerate()
        .fold(LANCZOS[0], |acc, (i, c)| acc + c / (x + i as f64 + 1.0));
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + series.ln()
}

/// Regularized lower incomplete gamma P(a, x) = gamma(a, x) / Gamma(a), a > 0, x >= 0.
pub fn gamma_p(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        0.0
    } else if x < a + 1.0 {
        gamma_p_series(a, x)
    } else {
        1.0 - gamma_q_continued_fraction(a, x)
    }
}

/// Regularized upper incomplete gamma Q(a, x) = 1 - P(a, x), accurate in the tail.
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        1.0
    } else if x < a + 1.0 {
        1.0 - gamma_p_series(a, x)
    } else {
        gamma_q_continued_fraction(a, x)
    }
}

/// P(a, x) = e^-x x^a / Gamma(a+1) * sum_n x^n / ((a+1)...(a+n)).
fn gamma_p_series(a: f64, x: f64) -> f64 {
    let mut term = 1.0 / a;
    let mut sum = term;
    let mut ap = a;
    for _ in 0..MAX_ITERATIONS {
        ap += 1.0;
        term *= x / ap;
        sum += term;
        if term.abs() < sum.abs() * CONVERGED {
            break;
        }
    }
    (sum.ln() - x + a * x.ln() - ln_gamma(a)).exp()
}

/// Q(a, x) by Legendre's continued fraction, evaluated with modified Lentz.
fn gamma_q_continued_fraction(a: f64, x: f64) -> f64 {
    let mut b = x + 1.0 - a;
    let mut c = 1.0 / LENTZ_TINY;
    let mut d = 1.0 / b;
    let mut h = d;
    for i in 1..MAX_ITERATIONS {
        let an = -(i as f64) * (i as f64 - a);
        b += 2.0;
        d = an * d + b;
        if d.abs() < LENTZ_TINY {
            d = LENTZ_TINY;
        }
        c = b + an / c;
        if c.abs() < LENTZ_TINY {
            c = LENTZ_TINY;
        }
        d = 1.0 / d;
        let delta = d * c;
        h *= delta;
        if (delta - 1.0).abs() < CONVERGED {
            break;
        }
    }
    (-x + a * x.ln() - ln_gamma(a)).exp() * h
}

/// Probability that a chi-square variable with `dof` degrees of freedom
/// exceeds `statistic` (the p-value of a chi-square test).
pub fn chi2_survival(statistic: f64, dof: usize) -> f64 {
    gamma_q(0.5 * dof as f64, 0.5 * statistic)
}

/// erf(x) to near f64 round-off: a reference for faster approximations.
///
/// |x| < 3: the everywhere-positive series
/// erf(x) = 2/sqrt(pi) e^-x^2 sum_n 2^n x^(2n+1) / (1 3 5 ... (2n+1))
/// (Abramowitz & Stegun 7.1.6), which has no cancellation. Otherwise
/// 1 - erfc(x).
pub fn erf_reference(x: f64) -> f64 {
    if x.abs() >= 3.0 {
        return x.signum() * (1.0 - erfc_reference(x.abs()));
    }
    let x2 = x * x;
    let mut term = x;
    let mut sum = x;
    let mut n = 0.0;
    while term.abs() > sum.abs() * 1e-17 {
        n += 1.0;
        term *= 2.0 * x2 / (2.0 * n + 1.0);
        sum += term;
    }
    2.0 / PI.sqrt() * (-x2).exp() * sum
}

/// erfc(x) to near f64 round-off (relative), a reference for approximations.
///
/// x >= 3: Laplace's continued fraction (A&S 7.1.14),
/// erfc(x) = e^-x^2/sqrt(pi) * 1/(x + (1/2)/(x + 1/(x + (3/2)/(x + ...)))),
/// evaluated with modified Lentz; otherwise 1 - erf(x).
pub fn erfc_reference(x: f64) -> f64 {
    if x < 3.0 {
        return 1.0 - erf_reference(x);
    }
    // f = x + K_{n>=1} (n/2) / x
    let mut f = x;
    let mut c = x;
    let mut d = 0.0;
    for n in 1..MAX_ITERATIONS {
        let an = n as f64 * 0.5;
        d = x + an * d;
        d = if d.abs() < LENTZ_TINY {
            1.0 / LENTZ_TINY
        } else {
            1.0 / d
        };
        c = x + an / c;
        if c.abs() < LENTZ_TINY {
            c = LENTZ_TINY;
        }
        let delta = c * d;
        f *= delta;
        if (delta - 1.0).abs() < CONVERGED {
            break;
        }
    }
    (-x * x).exp() / PI.sqrt() / f
}

#[cfg(test)]
mod tests {
    use super::*;

    fn rel(a: f64, b: f64) -> f64 {
        ((a - b) / b).abs()
    }

    #[test]
    fn ln_gamma_known_values() {
        assert!(rel(ln_gamma(0.5), 0.5 * PI.ln()) < 1e-13);
        assert!(ln_gamma(1.0).abs() < 1e-13);
        assert!(ln_gamma(2.0).abs() < 1e-13);
        // Gamma(11) = 10! = 3628800
        assert!(rel(ln_gamma(11.0), 3_628_800f64.ln()) < 1e-13);
        assert!(rel(ln_gamma(100.5), 361.435_540_467_777_6) < 1e-12);
    }

    #[test]
    fn chi2_survival_known_values() {
        // dof 2: survival is exactly exp(-x/2).
        for x in [0.1, 1.0, 5.0, 40.0] {
            assert!(rel(chi2_survival(x, 2), (-0.5 * x).exp()) < 1e-12);
        }
        // Tabulated 0.05 critical values (NIST/SEMATECH e-Handbook, table 1.3.6.7.4).
        assert!(rel(chi2_survival(3.841_459, 1), 0.05) < 1e-5);
        assert!(rel(chi2_survival(18.307_038, 10), 0.05) < 1e-5);
        assert!(rel(chi2_survival(124.342_113, 100), 0.05) < 1e-5);
        // 0.01 critical value at dof 50.
        assert!(rel(chi2_survival(76.153_891, 50), 0.01) < 1e-5);
    }

    #[test]
    fn p_plus_q_is_one() {
        for &(a, x) in &[
            (0.5, 0.2),
            (3.0, 2.0),
            (3.0, 9.0),
            (50.0, 48.0),
            (200.0, 260.0),
        ] {
            assert!((gamma_p(a, x) + gamma_q(a, x) - 1.0).abs() < 1e-13);
        }
    }

    #[test]
    fn erf_reference_known_values() {
        // Values from A&S table 7.1 and mpmath (30 digits, rounded).
        assert!(rel(erf_reference(0.5), 0.520_499_877_813_046_5) < 1e-14);
        assert!(rel(erf_reference(1.0), 0.842_700_792_949_714_9) < 1e-14);
        assert!(rel(erf_reference(2.5), 0.999_593_047_982_555) < 1e-14);
        assert!(rel(erfc_reference(3.0), 2.209_049_699_858_544e-5) < 1e-12);
        assert!(rel(erfc_reference(6.0), 2.151_973_671_249_891_3e-17) < 1e-12);
        assert!(rel(erfc_reference(2.9), 4.109_787_809_945_886e-5) < 1e-10);
        assert_eq!(erf_reference(0.0), 0.0);
        assert!(rel(erf_reference(-1.0), -0.842_700_792_949_714_9) < 1e-14);
    }
}
