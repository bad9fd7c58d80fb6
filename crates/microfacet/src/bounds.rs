//! Bounds that regularization needs (SPEC §4, supp. §1-§3).
//!
//! D_max and the G1/cos limits live with their NDF (`Ndf::d_max`,
//! `Ndf::d_max_bound`, `Ndf::g1_over_cos_limit`, `Ndf::g1_over_cos_sup`,
//! `MicrofacetModel::g1_over_cos_sup`); this module holds the transmission
//! Jacobian and its bounds.

/// Walter's half-vector Jacobian of refraction (supp. §3):
/// J = eta_t^2 / (eta_i <wi,h> + eta_t <wo,h>)^2. +infinity when the
/// denominator vanishes (index-matched, straight-through configuration).
pub fn transmission_jacobian(eta_i: f32, eta_t: f32, wi_h: f32, wo_h: f32) -> f32 {
    let denominator = eta_i * wi_h + eta_t * wo_h;
    eta_t * eta_t / (denominator * denominator)
}

/// The exact supremum of the transmission Jacobian over all valid
/// refraction configurations: eta_t^2 / (eta_i - eta_t)^2 (SPEC §4; reached at
/// normal incidence on the microfacet). +infinity for eta_i = eta_t: an
/// index-matched interface cannot be regularized through roughness.
pub fn transmission_jacobian_sup(eta_i: f32, eta_t: f32) -> f32 {
    let delta = eta_i - eta_t;
    eta_t * eta_t / (delta * delta)
}

/// The supplemental's bound of the Jacobian, max(eta_i, eta_t)^2 / (eta_i - eta_t)^2
/// (supp. eq. 7). Not tight when eta_i > eta_t (rays leaving a dense medium);
/// kept for comparison with implementations that follow the supplemental.
pub fn transmission_jacobian_bound_supp_eq7(eta_i: f32, eta_t: f32) -> f32 {
    let delta = eta_i - eta_t;
    let m = eta_i.max(eta_t);
    m * m / (delta * delta)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn supremum_is_reached_at_normal_incidence() {
        // wi = h, wo = -h: <wi,h> = 1, <wo,h> = -1.
        for (ei, et) in [(1.0, 1.5), (1.5, 1.0), (1.0, 1.33), (2.0, 1.0)] {
            let j = transmission_jacobian(ei, et, 1.0, -1.0);
            assert!((j / transmission_jacobian_sup(ei, et) - 1.0).abs() < 1e-6);
            assert!(
                transmission_jacobian_bound_supp_eq7(ei, et) >= transmission_jacobian_sup(ei, et)
            );
        }
        assert_eq!(transmission_jacobian_sup(1.2, 1.2), f32::INFINITY);
    }
}
