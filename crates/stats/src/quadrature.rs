//! Adaptive Simpson quadrature in one and two dimensions.
//!
//! The chi-square tests integrate a pdf over every cell of a (theta, phi)
//! grid; near-specular lobes put all their mass in a small part of one cell,
//! so the rule refines where the integrand changes and stops where it is smooth.
//!
//! An adaptive rule only sees what its sample points see: a feature narrower
//! than the initial spacing can be missed entirely. `min_depth` therefore
//! forces a uniform refinement to 2^min_depth intervals before adaptivity
//! may stop; choose it so that the spacing is below the narrowest feature.

/// Refinement limits of the adaptive rules.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Depth {
    /// Levels of uniform refinement before the error test may stop it.
    pub min: u32,
    /// Levels after which refinement stops regardless of the error.
    pub max: u32,
}

/// Integral of `f` over [a, b] by adaptive Simpson with absolute tolerance `eps`.
pub fn adaptive_simpson(
    f: &mut impl FnMut(f64) -> f64,
    a: f64,
    b: f64,
    eps: f64,
    depth: Depth,
) -> f64 {
    let fa = f(a);
    let fb = f(b);
    let m = 0.5 * (a + b);
    let fm = f(m);
    let whole = simpson(a, b, fa, fm, fb);
    refine(f, (a, b), (fa, fm, fb), whole, eps, depth)
}

fn simpson(a: f64, b: f64, fa: f64, fm: f64, fb: f64) -> f64 {
    (b - a) / 6.0 * (fa + 4.0 * fm + fb)
}

fn refine(
    f: &mut impl FnMut(f64) -> f64,
    (a, b): (f64, f64),
    (fa, fm, fb): (f64, f64, f64),
    whole: f64,
    eps: f64,
    depth: Depth,
) -> f64 {
    let m = 0.5 * (a + b);
    let lm = 0.5 * (a + m);
    let rm = 0.5 * (m + b);
    let flm = f(lm);
    let frm = f(rm);
    let left = simpson(a, m, fa, flm, fm);
    let right = simpson(m, b, fm, frm, fb);
    let delta = left + right - whole;
    if depth.max == 0 || (depth.min == 0 && delta.abs() <= 15.0 * eps) {
        // Richardson extrapolation of the two estimates.
        return left + right + delta / 15.0;
    }
    let next = Depth {
        min: depth.min.saturating_sub(1),
        max: depth.max - 1,
    };
    refine(f, (a, m), (fa, flm, fm), left, 0.5 * eps, next)
        + refine(f, (m, b), (fm, frm, fb), right, 0.5 * eps, next)
}

/// Integral of `f(x, y)` over [x0, x1] x [y0, y1] as nested adaptive Simpson
/// rules: the inner one over y for each x the outer one visits.
pub fn adaptive_simpson_2d(
    f: &mut impl FnMut(f64, f64) -> f64,
    (x0, x1): (f64, f64),
    (y0, y1): (f64, f64),
    eps: f64,
    depth: Depth,
) -> f64 {
    let inner_eps = eps / (x1 - x0).abs().max(f64::MIN_POSITIVE);
    let mut outer = |x: f64| adaptive_simpson(&mut |y| f(x, y), y0, y1, inner_eps, depth);
    adaptive_simpson(&mut outer, x0, x1, eps, depth)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn integrates_smooth_and_peaked_functions() {
        let s = adaptive_simpson(
            &mut |x: f64| x.sin(),
            0.0,
            std::f64::consts::PI,
            1e-10,
            Depth { min: 0, max: 20 },
        );
        assert!((s - 2.0).abs() < 1e-9);
        // A narrow Gaussian of width 1e-3 inside [0, 1]: integral sqrt(pi) * 1e-3.
        // The uniform start (2^10 intervals) is what lets the rule see it.
        let w = 1e-3;
        let gauss = |x: f64| (-((x - 0.3) / w).powi(2)).exp();
        let g = adaptive_simpson(&mut { gauss }, 0.0, 1.0, 1e-12, Depth { min: 10, max: 30 });
        assert!(
            (g / (std::f64::consts::PI.sqrt() * w) - 1.0).abs() < 1e-6,
            "{g}"
        );
        // Without it, the five initial points all miss the peak.
        let missed = adaptive_simpson(&mut { gauss }, 0.0, 1.0, 1e-12, Depth { min: 0, max: 30 });
        assert!(missed < 1e-6 * w);
    }

    #[test]
    fn integrates_in_two_dimensions() {
        let depth = Depth { min: 2, max: 12 };
        let v = adaptive_simpson_2d(
            &mut |x: f64, y: f64| x * y * y,
            (0.0, 2.0),
            (0.0, 3.0),
            1e-10,
            depth,
        );
        // (2^2 / 2) (3^3 / 3) = 18
        assert!((v - 18.0).abs() < 1e-8);
    }
}
