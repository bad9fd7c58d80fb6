//! Where the energy albedo of a V-cavity dielectric seen from the dense side
//! has kinks below the critical cosine (`crate::compensation::dielectric_energy`, `MuGrid`).
//!
//! V-cavity transmission has G = max(0, G1v(wi) + G1v(wo) - 1), G1v(w) =
//! min(1, |2<n,h><n,w>/<w,h>|) (SPEC §2). Seen from the dense side at a
//! cosine mu below the critical cosine c, the smooth interface reflects
//! totally; as mu grows, two regions of microfacet normals appear in the
//! plane of incidence, and the albedo E(mu) changes slope where each appears:
//!
//! - the **onset of transmission**, x0 = mu/c where the largest G over the
//!   plane's normals reaches 0 (near x = 0.54 for every eta; 0.5354 as
//!   eta -> 1, 0.5437 at 1/2);
//! - the **onset of full visibility**, x1 where it reaches 1 (G1v = 1 on both
//!   sides; sqrt(3)/2 as eta -> 1, 0.8165 at eta 1/2, 0.750 at 1/3).
//!
//! Neither depends on the NDF or alpha (G does not, and every D is > 0 on the
//! hemisphere), so a table row can end a spline segment at each. Measured
//! (Beckmann, eta 1/1.24, alpha 1): the curvature d2E/dx2 is about 2 below
//! x0 and 20-100 within 0.01 above it; around x1 it peaks at -58 (alpha
//! 0.29), on both sides. Off the plane, normals transmit earlier (at eta
//! 1/2 and x = 0.5, G = 0.48 at theta_h = 61 degrees, 34 degrees of
//! azimuth); at some eta they round a kink off (at 1/2 the curvature rises
//! from x = 0.52 on), so the tables' cells are small on both sides of each
//! onset.

/// The two onsets [x0, x1] (module docs) for the critical cosine `c` of an
/// interface, in x = mu / c, by bisection of the largest in-plane G
/// (`largest_in_plane_g`) against 0 and against 1.
pub(crate) fn onsets(c: f64) -> [f64; 2] {
    // c -> 0 (eta -> 1) has the limit of small c; mu = x c must not vanish.
    let c = c.max(SMALLEST_CRITICAL);
    let eta = (1.0 - c * c).sqrt();
    [0.0, 1.0 - FULL_VISIBILITY_SLACK].map(|level| {
        let (mut below, mut above) = SEARCHED;
        for _ in 0..BISECTION_STEPS {
            let x = 0.5 * (below + above);
            if largest_in_plane_g(eta, c, x) >= level {
                above = x;
            } else {
                below = x;
            }
        }
        above
    })
}

/// The x searched for both onsets: they lie near 0.54 and in [0.75, 0.87]
/// for every eta of the tables (`dielectric_energy::ETA_MAX` = 3).
const SEARCHED: (f64, f64) = (0.3, 0.999);

/// Bisection steps: 2^-45 of the searched range, far below the 1e-3 of the
/// smallest cells next to an onset.
const BISECTION_STEPS: usize = 45;

/// The critical cosine used for smaller ones: the onsets converge as c -> 0
/// (x0 0.53547 at c = 0.0045, 0.53540 at 0.0245) and at c = 0 a cosine x c
/// would be 0.
const SMALLEST_CRITICAL: f64 = 1e-3;

/// G = 1 where both G1v clamp to 1: tested as G >= 1 - this, against
/// rounding in the sum.
const FULL_VISIBILITY_SLACK: f64 = 1e-12;

/// Largest microfacet tilt searched, toward wi in the plane of incidence.
/// From the densest side of the tables (eta 1/3) the transmitting region is
/// born at 60 degrees; another one is born at the horizon of the normals
/// (75-89 degrees, where D is small) and would otherwise be found first.
const LARGEST_TILT_DEGREES: f64 = 70.0;

/// Tilts sampled before the largest is refined (1/4 degree apart).
const TILT_SAMPLES: usize = 280;

/// Ternary-search steps refining the largest sample: (2/3)^60 of its
/// two-sample bracket.
const REFINEMENT_STEPS: usize = 60;

/// The largest V-cavity transmission G over normals tilted by theta in [0,
/// `LARGEST_TILT_DEGREES`] toward wi in the plane of incidence, for wi at
/// mu = x c seen from the dense side (index ratio `eta` < 1, critical cosine
/// `c`); -1 where no normal transmits.
fn largest_in_plane_g(eta: f64, c: f64, x: f64) -> f64 {
    let g = |theta: f64| in_plane_g(eta, x * c, theta);
    let tilt = |k: usize| LARGEST_TILT_DEGREES.to_radians() * k as f64 / TILT_SAMPLES as f64;
    let best = (0..=TILT_SAMPLES)
        .max_by(|&a, &b| g(tilt(a)).total_cmp(&g(tilt(b))))
        .unwrap_or(0);
    let (mut lo, mut hi) = (
        tilt(best.saturating_sub(1)),
        tilt((best + 1).min(TILT_SAMPLES)),
    );
    for _ in 0..REFINEMENT_STEPS {
        let (a, b) = (lo + (hi - lo) / 3.0, hi - (hi - lo) / 3.0);
        if g(a) < g(b) {
            lo = a;
        } else {
            hi = b;
        }
    }
    g(0.5 * (lo + hi)).max(g(tilt(best)))
}

/// V-cavity transmission G (SPEC §2) of wi = (sqrt(1 - mu^2), 0, mu) through
/// the normal h = (sin theta, 0, cos theta), refracted with index ratio
/// `eta` (Snell, as `crate::frame::refract_f64`); -1 where it reflects
/// totally or the refracted direction is not below both the facet and the
/// surface.
fn in_plane_g(eta: f64, mu: f64, theta: f64) -> f64 {
    let sin_i = (1.0 - mu * mu).sqrt();
    let (h_x, h_z) = (theta.sin(), theta.cos());
    let wi_h = sin_i * h_x + mu * h_z;
    let sin2_t = (1.0 - wi_h * wi_h) / (eta * eta);
    if wi_h <= 0.0 || sin2_t >= 1.0 {
        return -1.0;
    }
    let k = wi_h / eta - (1.0 - sin2_t).sqrt();
    let (wo_x, wo_z) = (-sin_i / eta + k * h_x, -mu / eta + k * h_z);
    let wo_h = wo_x * h_x + wo_z * h_z;
    if wo_z >= 0.0 || wo_h >= 0.0 {
        return -1.0;
    }
    let g1 = |w_z: f64, w_h: f64| (2.0 * h_z * w_z / w_h).abs().min(1.0);
    g1(mu, wi_h) + g1(wo_z, wo_h) - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    /// At each onset the largest G over a fine scan of in-plane normals
    /// (1/100 degree, independent of the search's samples) crosses its
    /// level: below 0 (below 1) just before x0 (x1), at or above it just
    /// after; and as eta -> 1 they tend to the measured limits (module
    /// docs: x1 = 0.86603 = sqrt(3)/2 to 1e-5).
    #[test]
    fn onsets_are_where_the_in_plane_g_crosses_its_level() {
        let scan = |eta: f64, c: f64, x: f64| {
            (0..=7000)
                .map(|k| in_plane_g(eta, x * c, (k as f64 / 100.0).to_radians()))
                .fold(f64::NEG_INFINITY, f64::max)
        };
        for c in [0.05f64, 0.3, 0.59, 0.866, 0.9428] {
            let eta = (1.0 - c * c).sqrt();
            let [x0, x1] = onsets(c);
            assert!(x0 < x1, "{c}: {x0} {x1}");
            for (x, level) in [(x0, 0.0), (x1, 1.0 - FULL_VISIBILITY_SLACK)] {
                assert!(scan(eta, c, x - 2e-4) < level, "{c}: below {x}");
                assert!(scan(eta, c, x + 2e-4) >= level, "{c}: above {x}");
            }
        }
        let [x0, x1] = onsets(0.0);
        assert!((x0 - 0.5354).abs() < 1e-3, "{x0}");
        assert!((x1 - 3f64.sqrt() / 2.0).abs() < 1e-4, "{x1}");
    }
}
