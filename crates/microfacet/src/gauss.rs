//! Gauss-Legendre rules on [0, 1]: the quadrature under the Fresnel average
//! (`Fresnel::average`) and under the energy-compensation tables
//! (`crate::compensation`), which integrate the lobes with them.

use std::sync::OnceLock;

/// The 8-point Gauss-Legendre rule on [0, 1] (exact for polynomials of
/// degree 15), for the Fresnel average of `Fresnel::average` and the
/// moments of the dielectric tables' interpolated deficit
/// (`crate::compensation::dielectric_energy`).
pub(crate) fn gauss_legendre_8() -> &'static [(f64, f64)] {
    static NODES: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    NODES.get_or_init(|| gauss_legendre(8))
}

/// The 4-point Gauss-Legendre rule on [0, 1] (exact for polynomials of
/// degree 7), for the moments of the interpolated energy deficit.
pub(crate) fn gauss_legendre_4() -> &'static [(f64, f64)] {
    static NODES: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    NODES.get_or_init(|| gauss_legendre(4))
}

/// n-point Gauss-Legendre rule on [0, 1]: roots of P_n by Newton's method
/// from Tricomi's initial guess cos(pi (i - 1/4)/(n + 1/2)) (Abramowitz &
/// Stegun 25.4.29; Numerical Recipes §4.6), mapped from [-1, 1].
pub(crate) fn gauss_legendre(n: usize) -> Vec<(f64, f64)> {
    (0..n)
        .map(|i| {
            let mut x = (std::f64::consts::PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
            for _ in 0..100 {
                let (p, dp) = legendre(n, x);
                let dx = p / dp;
                x -= dx;
                if dx.abs() < 1e-15 {
                    break;
                }
            }
            let (_, dp) = legendre(n, x);
            let weight = 2.0 / ((1.0 - x * x) * dp * dp);
            (0.5 * (1.0 - x), 0.5 * weight)
        })
        .collect()
}

/// (P_n(x), P_n'(x)) by the three-term recurrence.
fn legendre(n: usize, x: f64) -> (f64, f64) {
    let (mut p0, mut p1) = (1.0, x);
    for k in 2..=n {
        let k = k as f64;
        let p2 = ((2.0 * k - 1.0) * x * p1 - (k - 1.0) * p0) / k;
        p0 = p1;
        p1 = p2;
    }
    (p1, n as f64 * (x * p1 - p0) / (x * x - 1.0))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let rule = gauss_legendre(8);
        let sum: f64 = rule.iter().map(|&(x, w)| w * x.powi(15)).sum();
        assert!((sum - 1.0 / 16.0).abs() < 1e-14, "{sum}");
        let total: f64 = rule.iter().map(|&(_, w)| w).sum();
        assert!((total - 1.0).abs() < 1e-14);
    }
}
