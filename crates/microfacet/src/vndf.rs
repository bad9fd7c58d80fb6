//! Samplers for microfacet normals as seen from a direction wi: the
//! distribution of visible normals D_wi(h) = G1(wi) max(0, <wi,h>) D(h) / <wi,n>
//! (Heitz & d'Eon 2014), for each NDF and shadowing model (SPEC §1).
//!
//! All samplers expect wi strictly above the surface (wi.z > 0).

use std::f64::consts::{FRAC_2_SQRT_PI, PI};

use crate::sample::ONE_MINUS_EPSILON;
use glam::{DVec3, Vec2, Vec3};

use crate::ndf::Ndf;
use crate::special::{erf_inv, erfc};

/// Uniforms are kept in [SAMPLE_TAIL_CLAMP, 1 - SAMPLE_TAIL_CLAMP] where they
/// are mapped through an inverse CDF with infinite tails (Beckmann slopes):
/// u = 0 would give an infinite slope. The clamp drops 2e-7 of the mass.
pub const SAMPLE_TAIL_CLAMP: f64 = 1e-7;

/// Beckmann slopes beyond this magnitude carry less than erfc(9) = 4e-37 of
/// the mass: the bracket of the visible-slope inversion.
const BECKMANN_SLOPE_LIMIT: f64 = 9.0;

/// Halley-bisection steps allowed when inverting the visible-slope CDF; it
/// converges in fewer than 10 for every input tried, bisection guarantees
/// progress for the rest.
const SLOPE_INVERSION_STEPS: usize = 64;

/// Largest correction (f f'' / 2 f'^2) of Newton's step that the slope
/// inversion takes as Halley's: beyond it the root is too far for the
/// cubic model, whose step can then be tiny (and stop the iteration) without
/// being near the root.
const HALLEY_MAX_CORRECTION: f64 = 0.5;

/// Stop the slope inversion once a step moves x by less than this.
const SLOPE_TOLERANCE: f64 = 1e-9;

/// A Halley step shorter than this also ends the slope inversion: Halley's
/// method converges cubically, so the root then lies within about the
/// step's cube (1e-12) of the new x, far below the f32 precision of the
/// sampled normal (2^-24 = 6e-8), and the evaluation (an erfc and an exp)
/// that a step below [`SLOPE_TOLERANCE`] would take to confirm it is
/// saved: 0.9-1.0 of 3.0-4.6 evaluations on average for alpha 0.01-2,
/// while 0.1 % of the normals move by one f32 rounding (at most 6e-8).
/// Not after a Newton step (quadratic) or a bisection.
const HALLEY_FINAL_STEP: f64 = 1e-4;

/// GGX visible normals, Heitz 2018 ("Sampling the GGX Distribution of Visible
/// Normals", JCGT 7(4)): stretch wi to the hemisphere configuration, sample
/// a projected disk warped towards the visible half, unstretch.
///
/// Computed in f64. The edge of the disk (r = sqrt(u.x) -> 1) maps to the
/// horizon of the visible hemisphere, where the normal's height is a
/// difference of O(1) terms: for u.x = 1 - 2^-24 (the largest f32 below 1)
/// it is about 1e-8 / sin(theta) in exact arithmetic, which f32 rounded to 0
/// (a normal in the tangent plane, rejected by every lobe) or to noise of
/// either sign. In f64 the error is ~1e-16, so for every u in [0, 1)^2 the
/// result is a unit normal with h.z > 0 and <wi,h> >= 0 (strictly positive
/// unless wi is so grazing that its f32 dot product with h underflows the
/// rounding). `None` only when the unstretched normal degenerates to zero
/// length (not observed for finite inputs).
pub fn sample_ggx(wi: Vec3, alpha: f32, u: Vec2) -> Option<Vec3> {
    let a = f64::from(alpha);
    let vh =
        DVec3::new(a * f64::from(wi.x), a * f64::from(wi.y), f64::from(wi.z)).try_normalize()?;
    let len2 = vh.x * vh.x + vh.y * vh.y;
    let t1 = if len2 > 0.0 {
        DVec3::new(-vh.y, vh.x, 0.0) / len2.sqrt()
    } else {
        DVec3::X
    };
    let t2 = vh.cross(t1);
    let r = f64::from(u.x).sqrt();
    let (sin_phi, cos_phi) = (2.0 * PI * f64::from(u.y)).sin_cos();
    let p1 = r * cos_phi;
    let s = 0.5 * (1.0 + vh.z);
    let p2 = (1.0 - s) * (1.0 - p1 * p1).max(0.0).sqrt() + s * r * sin_phi;
    let nh = p1 * t1 + p2 * t2 + (1.0 - p1 * p1 - p2 * p2).max(0.0).sqrt() * vh;
    let h = DVec3::new(a * nh.x, a * nh.y, nh.z.max(0.0)).try_normalize()?;
    Some(h.as_vec3()).filter(|h| h.is_finite())
}

/// Beckmann visible normals (Heitz & d'Eon 2014, §4): stretch wi to alpha = 1,
/// sample the visible slope (x along the azimuth of wi, y across it), rotate
/// and unstretch. Computed in f64.
///
/// With mu = cot(theta_i), the visible slopes have density proportional to
/// (mu - x) exp(-x^2 - y^2) for x < mu, so y = erf^-1(2u - 1) and x solves
/// erfc(-x) + tan(theta_i) exp(-x^2)/sqrt(pi) = u * (same at x = mu)
/// (see `sample_visible_slope_x`).
pub fn sample_beckmann(wi: Vec3, alpha: f32, u: Vec2) -> Option<Vec3> {
    let a = f64::from(alpha);
    let ws =
        DVec3::new(a * f64::from(wi.x), a * f64::from(wi.y), f64::from(wi.z)).try_normalize()?;
    let sin_theta = ws.x.hypot(ws.y);
    let (cos_phi, sin_phi) = if sin_theta > 0.0 {
        (ws.x / sin_theta, ws.y / sin_theta)
    } else {
        (1.0, 0.0)
    };
    let clamp = |v: f32| f64::from(v).clamp(SAMPLE_TAIL_CLAMP, 1.0 - SAMPLE_TAIL_CLAMP);
    let x = sample_visible_slope_x(ws.z, sin_theta, clamp(u.x));
    let y = erf_inv(2.0 * clamp(u.y) - 1.0);
    let slope_x = cos_phi * x - sin_phi * y;
    let slope_y = sin_phi * x + cos_phi * y;
    let h = DVec3::new(-a * slope_x, -a * slope_y, 1.0).normalize();
    Some(h.as_vec3()).filter(|h| h.is_finite())
}

/// Inverts the marginal CDF of the visible Beckmann slope along wi (alpha = 1):
/// F(x) = N(x)/N(mu), N(x) = erfc(-x) + tan(theta) exp(-x^2)/sqrt(pi), by
/// Halley steps (cubic convergence) kept inside a shrinking bracket
/// (bisection when a step leaves it), with
/// N'(x) = 2/sqrt(pi) exp(-x^2) (1 - x tan(theta)) and
/// N''(x) = 2/sqrt(pi) exp(-x^2) (-2x (1 - x tan(theta)) - tan(theta)).
fn sample_visible_slope_x(cos_theta: f64, sin_theta: f64, u: f64) -> f64 {
    if sin_theta == 0.0 {
        // Normal incidence: the visible slopes are the slopes.
        return erf_inv(2.0 * u - 1.0);
    }
    let tan = sin_theta / cos_theta;
    let mu = cos_theta / sin_theta;
    let n = |x: f64, gauss: f64| erfc(-x) + tan * gauss / PI.sqrt();
    let gauss_mu = (-mu * mu).exp();
    let n_mu = n(mu, gauss_mu);
    let target = u * n_mu;
    let (mut lo, mut hi) = (-BECKMANN_SLOPE_LIMIT, mu.min(BECKMANN_SLOPE_LIMIT));
    // The slope at normal incidence, unless it lies beyond mu (large u):
    // near mu N is quadratic (N'(mu) = 0), N(mu) - N(x) ~ |N''(mu)| (mu - x)^2 / 2
    // with |N''(mu)| = 2/sqrt(pi) exp(-mu^2) tan(theta), and N(mu) - N(x) is
    // (1 - u) N(mu) at the root: the start solves that.
    let mut x = erf_inv(2.0 * u - 1.0);
    if !(x < hi) {
        let curvature = FRAC_2_SQRT_PI * gauss_mu * tan;
        x = mu - (2.0 * (1.0 - u) * n_mu / curvature).sqrt();
    }
    x = x.clamp(lo, hi);
    for _ in 0..SLOPE_INVERSION_STEPS {
        let gauss = (-x * x).exp();
        let value = n(x, gauss) - target;
        if value == 0.0 {
            break;
        }
        if value > 0.0 {
            hi = x;
        } else {
            lo = x;
        }
        let d1 = FRAC_2_SQRT_PI * gauss * (1.0 - x * tan);
        let d2 = FRAC_2_SQRT_PI * gauss * (-2.0 * x * (1.0 - x * tan) - tan);
        // Halley's step as Newton's with a correction; where the correction
        // is large (far from the root, or near x = mu where N' vanishes) its
        // step can be tiny without converging: Newton's step alone then.
        let newton = value / d1;
        let correction = 0.5 * newton * d2 / d1;
        let halley = correction.abs() < HALLEY_MAX_CORRECTION;
        let delta = if halley {
            newton / (1.0 - correction)
        } else {
            newton
        };
        let mut next = x - delta;
        let bisected = !(next > lo && next < hi);
        if bisected {
            next = 0.5 * (lo + hi);
        }
        let step = (next - x).abs();
        x = next;
        if step < SLOPE_TOLERANCE || (halley && !bisected && step < HALLEY_FINAL_STEP) {
            break;
        }
    }
    x
}

/// V-cavity visible normals (Heitz & d'Eon 2014, §5; SPEC §1): sample h from
/// D(h)<h,n>, form the mirrored facet h' = (-h.x, -h.y, h.z) and pick h' with
/// probability max(0,<wi,h'>) / (max(0,<wi,h>) + max(0,<wi,h'>)).
///
/// The choice consumes `uc`; the returned uniform is `uc` rescaled to [0, 1)
/// within the chosen interval, so it stays independent of the choice and can
/// drive a later decision (the Fresnel coin of a dielectric).
/// `None` if neither facet faces wi.
pub fn sample_vcavity(ndf: &Ndf, wi: Vec3, u: Vec2, uc: f32) -> Option<(Vec3, f32)> {
    let h = ndf.sample_d_cos(u);
    let mirrored = Vec3::new(-h.x, -h.y, h.z);
    let front = wi.dot(h).max(0.0);
    let back = wi.dot(mirrored).max(0.0);
    let total = front + back;
    if total <= 0.0 {
        return None;
    }
    let p_mirrored = back / total;
    if uc < p_mirrored {
        Some((mirrored, (uc / p_mirrored).min(ONE_MINUS_EPSILON)))
    } else {
        Some((
            h,
            ((uc - p_mirrored) / (1.0 - p_mirrored)).min(ONE_MINUS_EPSILON),
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::ndf::NdfKind;

    #[test]
    fn samplers_return_unit_upper_normals_at_the_edges() {
        let dirs = [
            Vec3::Z,
            Vec3::new(1.0, 0.0, 1e-8).normalize(),
            Vec3::new(0.0, 1.0, 1e-30).normalize(),
            Vec3::new(0.6, -0.3, 0.2).normalize(),
        ];
        let us = [
            Vec2::ZERO,
            Vec2::new(0.999_999_9, 0.999_999_9),
            Vec2::new(0.5, 0.25),
        ];
        for alpha in [1e-7, 1e-3, 0.5, 1.0, 10.0] {
            for wi in dirs {
                for u in us {
                    for h in [sample_ggx(wi, alpha, u), sample_beckmann(wi, alpha, u)]
                        .into_iter()
                        .flatten()
                    {
                        assert!(
                            h.is_finite() && (h.length() - 1.0).abs() < 1e-5 && h.z >= 0.0,
                            "{alpha} {wi} {u} {h}"
                        );
                    }
                    let ndf = Ndf::new(NdfKind::Ggx, alpha);
                    if let Some((h, uc)) = sample_vcavity(&ndf, wi, u, 0.3) {
                        assert!(h.is_finite() && (0.0..1.0).contains(&uc));
                    }
                }
            }
        }
    }

    /// The inverted slope is the root of F(x) = u: its CDF value matches
    /// u, and where the root is well conditioned (u away from 0 and 1, at
    /// whose ends F is flat) x matches a root found by 200 bisections to
    /// within 1e-9 (relative above 1), a sixtieth of what the f32 normal
    /// resolves: stopping after a short Halley step (`HALLEY_FINAL_STEP`)
    /// loses nothing the normal could show.
    #[test]
    fn slope_inversion_hits_its_target() {
        for cos in [1e-6, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 0.999_999] {
            let sin = (1.0f64 - cos * cos).sqrt();
            let tan = sin / cos;
            let mu = cos / sin;
            let n = |x: f64| erfc(-x) + tan * (-x * x).exp() / PI.sqrt();
            for u in [1e-7, 0.001, 0.01, 0.1, 0.3, 0.5, 0.7, 0.9, 0.99, 1.0 - 1e-7] {
                let x = sample_visible_slope_x(cos, sin, u);
                let f = n(x) / n(mu);
                assert!(
                    (f - u).abs() < 1e-6 * u.max(1e-2),
                    "cos {cos} u {u} x {x} F {f}"
                );
                let (mut lo, mut hi) = (-BECKMANN_SLOPE_LIMIT, mu.min(BECKMANN_SLOPE_LIMIT));
                for _ in 0..200 {
                    let mid = 0.5 * (lo + hi);
                    if n(mid) / n(mu) < u {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let root = 0.5 * (lo + hi);
                let conditioned = (0.001..=0.99).contains(&u);
                assert!(
                    !conditioned || (x - root).abs() <= 1e-9 * root.abs().max(1.0),
                    "cos {cos} u {u}: x {x}, bisection {root}"
                );
            }
        }
    }
}
