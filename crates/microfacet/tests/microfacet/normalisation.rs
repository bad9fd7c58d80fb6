//! Normalisation (SPEC §1): the integral of D(h)<h,n> is 1, and so is
//! the integral of the density of every microfacet-normal sampler, within
//! 1e-3 for alpha from 0.01 to 1 (Beckmann and GGX also at 2 and 5).

use crate::common;

use std::f64::consts::{FRAC_PI_2, PI};

use common::*;
use microfacet::{MicrofacetModel, Ndf, NdfKind};
use stats::chi2::spherical_direction;
use stats::quadrature::{Depth, adaptive_simpson, adaptive_simpson_2d};

const TOLERANCE: f64 = 1e-3;

/// Alphas from 0.01 to 1 (log-spaced) and the NDF-specific extremes.
fn alphas(kind: NdfKind) -> Vec<f32> {
    let mut out: Vec<f32> = (0..=8)
        .map(|i| 0.01 * 100f32.powf(i as f32 / 8.0))
        .collect();
    if kind != NdfKind::BlinnPhong {
        out.extend([2.0, 5.0]);
    }
    out
}

/// Integral over the upper hemisphere in (theta, phi), with the theta range
/// split at a few multiples of alpha so that the quadrature resolves the peak.
fn hemisphere_integral(alpha: f32, f: impl Fn(glam::Vec3) -> f64) -> f64 {
    let a = f64::from(alpha);
    let mut splits = vec![0.0];
    splits.extend(
        [a, 4.0 * a, 16.0 * a]
            .into_iter()
            .map(f64::atan)
            .filter(|&t| t < FRAC_PI_2),
    );
    splits.push(FRAC_PI_2);
    let depth = Depth { min: 3, max: 12 };
    splits
        .windows(2)
        .map(|w| {
            adaptive_simpson_2d(
                &mut |theta, phi| f(spherical_direction(theta, phi)) * theta.sin(),
                (w[0], w[1]),
                (0.0, 2.0 * PI),
                1e-6,
                depth,
            )
        })
        .sum()
}

#[test]
fn projected_ndf_integrates_to_one() {
    for kind in NDFS {
        for alpha in alphas(kind) {
            let ndf = Ndf::new(kind, alpha);
            // Isotropic: 2 pi int D(theta) cos sin dtheta, split at atan(alpha).
            let a = f64::from(alpha);
            let integrand = |t: f64| {
                let h = glam::Vec3::new(t.sin() as f32, 0.0, t.cos() as f32);
                f64::from(ndf.d(h)) * t.cos() * t.sin()
            };
            let depth = Depth { min: 6, max: 18 };
            let split = a.atan().min(1.0);
            let total = 2.0
                * PI
                * (adaptive_simpson(&mut { integrand }, 0.0, split, 1e-10, depth)
                    + adaptive_simpson(&mut { integrand }, split, FRAC_PI_2, 1e-10, depth));
            assert!(
                (total - 1.0).abs() < TOLERANCE,
                "{kind:?} alpha {alpha}: {total}"
            );
        }
    }
}

#[test]
fn sampling_densities_integrate_to_one() {
    for kind in NDFS {
        for shadowing in SHADOWINGS {
            for alpha in alphas(kind) {
                let model = MicrofacetModel::new(kind, alpha, shadowing);
                for cos in [0.99f32, 0.5, 0.05] {
                    let wi = direction(cos, 0.4);
                    let total = hemisphere_integral(alpha, |h| f64::from(model.pdf_h(wi, h)));
                    assert!(
                        (total - 1.0).abs() < TOLERANCE,
                        "{} cos {cos}: {total}",
                        label(&model)
                    );
                }
            }
        }
    }
}

/// With Smith shadowing, D_wi(h) = G1(wi) <wi,h>+ D(h) / <wi,n> integrates to
/// one only if Lambda matches D. This checks Lambda itself, including the exact
/// Blinn-Phong Lambda (whose sampler draws from D cos and so does not test it).
#[test]
fn smith_visible_normals_integrate_to_one() {
    for kind in NDFS {
        for alpha in alphas(kind) {
            let ndf = Ndf::new(kind, alpha);
            for cos in [0.99f32, 0.5, 0.05, 0.005] {
                let wi = direction(cos, 1.3);
                let visible = |h: glam::Vec3| {
                    f64::from(ndf.g1(wi)) * f64::from(wi.dot(h).max(0.0)) * f64::from(ndf.d(h))
                        / f64::from(wi.z)
                };
                let total = hemisphere_integral(alpha, visible);
                assert!(
                    (total - 1.0).abs() < TOLERANCE,
                    "{kind:?} alpha {alpha} cos {cos}: {total}"
                );
            }
        }
    }
}
