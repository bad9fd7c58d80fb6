//! GGX visible-normal sampling and refraction at the ends of [0, 1): u = 0
//! and u = 1 - 2^-24, the largest f32 below 1, in both coordinates.

use crate::common;

use common::*;
use glam::{Vec2, Vec3};
use microfacet::{Dielectric, MicrofacetModel, NdfKind, Shadowing, TransportMode, vndf};

/// The largest f32 below 1.
const TOP: f32 = 1.0 - f32::EPSILON / 2.0;

fn uniforms() -> Vec<Vec2> {
    let coords = [0.0, TOP, 0.25, 0.5, 0.75];
    let mut out = Vec::new();
    for x in coords {
        for y in coords {
            if x == 0.0 || x == TOP || y == 0.0 || y == TOP {
                out.push(Vec2::new(x, y));
            }
        }
    }
    out
}

fn incident() -> Vec<Vec3> {
    vec![
        Vec3::Z,
        direction(0.7, 0.3),
        direction(0.2, 1.0),
        direction(0.01, 2.0),
        direction(0.99, 4.0),
    ]
}

/// Every extreme uniform gives a unit microfacet normal strictly above the
/// surface (h.z > 0) and facing wi (<wi,h> > 0): the support of the visible
/// normal distribution, which the dielectric and conductor lobes require.
#[test]
fn ggx_visible_normals_at_extreme_uniforms() {
    let mut failures = Vec::new();
    for alpha in [0.01f32, 0.1, 0.5, 1.0, 3.0] {
        for wi in incident() {
            for u in uniforms() {
                let h = vndf::sample_ggx(wi, alpha, u);
                let good = h.is_some_and(|h| {
                    h.is_finite() && (h.length() - 1.0).abs() < 1e-6 && h.z > 0.0 && wi.dot(h) > 0.0
                });
                if !good {
                    failures.push(format!("alpha {alpha} wi {wi} u {u}: {h:?}"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A sampled microfacet closer to the horizon than this (h.z) is within f32
/// rounding of it: the half vector recovered from the rounded refracted
/// direction can fall on either side, and below it `pdf` is 0, so `sample`
/// returns `None` (documented on `Dielectric::sample`). u.x = 1 - 2^-24
/// gives h.z down to ~5e-9 at u.y = 3/4.
const HORIZON_ROUNDING: f32 = 1e-6;

/// Refraction into glass (eta = 1.5, no total internal reflection) with the
/// Fresnel coin at its top (refraction unless F = 1) returns a refracted
/// sample for every extreme uniform, with the pdf that `pdf` gives; `None`
/// only for a microfacet within rounding of the horizon.
#[test]
fn ggx_refraction_at_extreme_uniforms() {
    let mut failures = Vec::new();
    for alpha in [0.01f32, 0.1, 0.5, 1.0, 3.0] {
        let d = Dielectric::new(
            MicrofacetModel::new(NdfKind::Ggx, alpha, Shadowing::Smith),
            1.5,
        );
        for wi in incident() {
            for u in uniforms() {
                let s = d.sample(wi, TOP, u, TransportMode::Radiance);
                let good = s.is_some_and(|s| {
                    let p = d.pdf(wi, s.wo);
                    s.wo.z < 0.0
                        && s.pdf > 0.0
                        && s.pdf.is_finite()
                        && (s.pdf - p).abs() <= 1e-3 * p
                });
                let h = vndf::sample_ggx(wi, alpha, u);
                let excused = s.is_none() && h.is_some_and(|h| h.z < HORIZON_ROUNDING);
                if !good && !excused {
                    failures.push(format!("alpha {alpha} wi {wi} u {u}: {s:?} (h {h:?})"));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
