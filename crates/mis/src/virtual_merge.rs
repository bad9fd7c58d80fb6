//! The acceptance of a virtual merge (supp. §6).

use crate::numeric::{abs, div, mul, nonneg};

/// The acceptance probability of a virtual merge (supp. eq. 14, clamped):
/// the probability that a direction sampled from the vertex's BSDF falls into
/// the cone of solid angle 1/tau around the connecting direction, in the
/// single-sample approximation of VCM: p_acc = min(1, pdf_w / tau).
///
/// - `pdf_w`: the solid-angle pdf of the connecting direction (p_hat at a
///   regularized vertex; SPEC §6),
/// - `tau`: the vertex's regularization bound (SPEC §5: 1/tau is the cone's
///   solid angle). `f64::INFINITY` means "not regularized" and gives 0; so do
///   NaN and non-positive values.
///
/// The clamp matters: p_hat can exceed tau (by G1/cos at grazing angles,
/// spec-review O2), and a probability cannot exceed 1.
#[inline]
pub fn acceptance_probability(pdf_w: f64, tau: f64) -> f64 {
    if tau > 0.0 && tau.is_finite() {
        // 1e300 / tiny tau saturates at 1e300, which the clamp turns into 1.
        div(nonneg(pdf_w), tau).min(1.0)
    } else {
        0.0
    }
}

/// The acceptance area of a virtual merge seen as a merge at the far vertex
/// x_b: A = d^2 / (tau_a |cos theta_b|), the area the cone of solid angle
/// 1/tau_a around x_a -> x_b cuts out of x_b's surface (SPEC §6).
///
/// With p_A(x_b) = pdf_w |cos theta_b| / d^2, the area pdf with which x_a's
/// sub-path samples x_b, p_A(x_b) A = pdf_w / tau_a: the virtual merge's path
/// pdf has the form of a VCM merge's, P_conn p_A(x_b) eta, with eta = N pi r^2
/// replaced by A. Returns a finite value (saturating at 1e300; 0 for an
/// infinite, NaN or non-positive tau).
pub fn acceptance_area(tau: f64, distance: f64, cos_far: f64) -> f64 {
    if tau > 0.0 && tau.is_finite() {
        let d = abs(distance);
        div(mul(d, d), mul(tau, abs(cos_far)))
    } else {
        0.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn acceptance_is_pdf_over_tau_clamped() {
        assert_eq!(acceptance_probability(2.0, 8.0), 0.25);
        assert_eq!(acceptance_probability(80.0, 8.0), 1.0);
        assert_eq!(acceptance_probability(2.0, f64::INFINITY), 0.0);
        assert_eq!(acceptance_probability(2.0, 0.0), 0.0);
        assert_eq!(acceptance_probability(2.0, f64::NAN), 0.0);
        assert_eq!(acceptance_probability(f64::NAN, 8.0), 0.0);
        assert_eq!(acceptance_probability(1e300, 1e-300), 1.0);
    }

    #[test]
    fn area_times_area_pdf_is_acceptance() {
        let (pdf_w, tau, d, cos) = (3.0, 40.0, 2.5, 0.3);
        let pdf_a = pdf_w * cos / (d * d);
        let a = acceptance_area(tau, d, cos);
        assert!((pdf_a * a - acceptance_probability(pdf_w, tau)).abs() < 1e-15);
        assert_eq!(acceptance_area(f64::INFINITY, d, cos), 0.0);
        assert!(acceptance_area(tau, 1e200, 0.0).is_finite());
    }
}
