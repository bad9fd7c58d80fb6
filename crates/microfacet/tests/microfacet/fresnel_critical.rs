//! Fresnel near the critical angle from the dense side, against an f64
//! reference evaluated on the same f32 inputs: there the transmittance
//! 1 - F goes to 0 like cos(theta_t), and cos^2(theta_t) = 1 - sin^2(theta_i)/eta^2
//! is a difference of nearly equal numbers.

use glam::{Vec2, Vec3};
use microfacet::{Dielectric, MicrofacetModel, NdfKind, Shadowing, TransportMode, fresnel};

/// (F, 1 - F) in f64 by the textbook route (Born & Wolf): sin_t = sin_i/eta.
fn reference(cos_i: f64, eta: f64) -> Option<(f64, f64)> {
    let sin2_t = (1.0 - cos_i * cos_i) / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let rp = (eta * cos_i - cos_t) / (eta * cos_i + cos_t);
    let rs = (cos_i - eta * cos_t) / (cos_i + eta * cos_t);
    // 1 - r^2 = 4ab/(a+b)^2 for r = (a-b)/(a+b): no cancellation as F -> 1.
    let tp = 4.0 * eta * cos_i * cos_t / (eta * cos_i + cos_t).powi(2);
    let ts = 4.0 * eta * cos_i * cos_t / (cos_i + eta * cos_t).powi(2);
    Some((0.5 * (rp * rp + rs * rs), 0.5 * (tp + ts)))
}

/// Incident cosines just above the critical one, cos_c = sqrt(1 - eta^2)
/// (eta = eta_t/eta_i < 1), with their f32 values.
fn near_critical(eta: f64) -> Vec<f32> {
    let cos_c = (1.0 - eta * eta).sqrt();
    (1..=7)
        .map(|k| (cos_c * (1.0 + 10f64.powi(-k))) as f32)
        .filter(|&c| c < 1.0)
        .collect()
}

/// The transmittance a smooth dielectric reports as the pdf of its refracted
/// sample (SPEC §3: refraction is chosen with probability 1 - F) agrees with
/// the f64 reference to 1e-4 near the critical angle, queried from the dense
/// side both ways: from above (eta < 1) and from below (eta > 1, seen as 1/eta).
#[test]
fn transmittance_near_the_critical_angle_matches_f64() {
    let smooth = MicrofacetModel::new(NdfKind::Ggx, 1e-5, Shadowing::Smith);
    let top = 1.0 - f32::EPSILON / 2.0;
    let mut failures = Vec::new();
    let mut worst = 0.0f64;
    for dense in [1.5f32, 1.33, 2.5, 1.01] {
        // From above into the light medium: eta = 1/dense as given (f32).
        // From below out of a dense medium: eta = dense, seen as 1/dense.
        for (lobe_eta, seen, side) in [
            (1.0 / dense, f64::from(1.0 / dense), 1.0f32),
            (dense, 1.0 / f64::from(dense), -1.0),
        ] {
            let d = Dielectric::new(smooth, lobe_eta);
            for cos_i in near_critical(seen) {
                let Some((f_ref, t_ref)) = reference(f64::from(cos_i), seen) else {
                    continue;
                };
                let wi = Vec3::new((1.0 - cos_i * cos_i).sqrt(), 0.0, cos_i) * side;
                let s = d.sample(wi, top, Vec2::splat(0.5), TransportMode::Radiance);
                let pdf = s.filter(|s| s.wo.z * side < 0.0).map_or(0.0, |s| s.pdf);
                let err = (f64::from(pdf) - t_ref).abs() / t_ref;
                worst = worst.max(err);
                let f = fresnel::dielectric(cos_i * side, lobe_eta);
                let f_err = (f64::from(f) - f_ref).abs() / f_ref;
                if err > 1e-4 || f_err > 1e-6 {
                    failures.push(format!(
                        "eta {lobe_eta} side {side} cos_i {cos_i}: 1-F {pdf:e} (f64 {t_ref:e}, rel {err:.2e}); F {f} (f64 {f_ref}, rel {f_err:.1e})"
                    ));
                }
            }
        }
    }
    println!("worst relative error of 1 - F: {worst:.2e}");
    assert!(
        failures.is_empty(),
        "worst relative error {worst:.2e}:\n{}",
        failures.join("\n")
    );
}

/// The same against `fresnel::dielectric_transmittance` itself, from both
/// sides of the interface (a negative cosine sees 1/eta).
#[test]
fn transmittance_function_matches_f64() {
    for dense in [1.5f32, 1.33, 2.5, 1.01, 1.0005] {
        let eta = 1.0 / dense;
        for (cos_i, lobe_eta, seen) in near_critical(f64::from(eta))
            .into_iter()
            .map(|c| (c, eta, f64::from(eta)))
            .chain(
                near_critical(1.0 / f64::from(dense))
                    .into_iter()
                    .map(|c| (-c, dense, 1.0 / f64::from(dense))),
            )
        {
            let Some((_, t_ref)) = reference(f64::from(cos_i.abs()), seen) else {
                continue;
            };
            let t = fresnel::dielectric_transmittance(cos_i, lobe_eta);
            let err = (f64::from(t) - t_ref).abs() / t_ref;
            assert!(err < 1e-5, "eta {lobe_eta} cos {cos_i}: {t:e} vs {t_ref:e}");
        }
    }
}
