//! Edge sweeps: alpha from 1e-7 to 10, cosines down to 1e-8 and
//! exactly 0, eta from 1 + 1e-6 to 4 and its inverse, wi = wo, wi = -wo,
//! directions below the surface. Every value must be finite and non-negative,
//! and `sample` returns `None` rather than a NaN direction.

use crate::common;

use common::*;
use glam::Vec3;
use microfacet::{
    Bsdf, Conductor, Dielectric, Fresnel, Lambertian, MicrofacetModel, TransportMode,
};
use stats::Pcg32;

const EDGE_ALPHAS: [f32; 10] = [1e-7, 1e-5, 9.9e-5, 1e-4, 1e-3, 0.01, 0.3, 1.0, 3.0, 10.0];
const EDGE_COSINES: [f32; 8] = [1.0, 0.5, 1e-2, 1e-4, 1e-6, 1e-8, 0.0, -0.3];
const EDGE_ETAS: [f32; 7] = [1.0, 1.0 + 1e-6, 1.0001, 1.01, 1.5, 2.5, 4.0];

fn edge_lobes() -> Vec<Bsdf> {
    let mut out = vec![Bsdf::Lambertian(Lambertian {
        reflectance: Vec3::ONE,
    })];
    for kind in NDFS {
        for shadowing in SHADOWINGS {
            for alpha in EDGE_ALPHAS {
                let model = MicrofacetModel::new(kind, alpha, shadowing);
                out.push(Bsdf::Conductor(Conductor {
                    model,
                    fresnel: Fresnel::Conductor {
                        eta: Vec3::splat(0.2),
                        k: Vec3::splat(3.0),
                        tint: Vec3::ONE,
                    },
                }));
                for eta in EDGE_ETAS {
                    out.push(Bsdf::Dielectric(Dielectric::new(model, eta)));
                    out.push(Bsdf::Dielectric(Dielectric::new(model, 1.0 / eta)));
                }
            }
        }
    }
    out
}

fn edge_directions() -> Vec<Vec3> {
    let mut out = Vec::new();
    for cos in EDGE_COSINES {
        for phi in [0.0f32, 1.0] {
            let w = direction(cos.abs(), phi) * if cos < 0.0 { -1.0 } else { 1.0 };
            out.push(w);
            out.push(Vec3::new(w.x, w.y, -w.z));
        }
    }
    out
}

fn ok(x: f32) -> bool {
    x.is_finite() && x >= 0.0
}

#[test]
fn every_result_is_finite_and_non_negative() {
    let dirs = edge_directions();
    let mut rng = Pcg32::new(31, 0);
    let mut failures = Vec::new();
    for bsdf in edge_lobes() {
        for &wi in &dirs {
            // Pairs from the sweep, plus wi = wo and wi = -wo explicitly.
            let pairs = dirs.iter().copied().chain([wi, -wi]);
            for wo in pairs {
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    let f = bsdf.eval(wi, wo, mode);
                    if !(ok(f.x) && ok(f.y) && ok(f.z)) {
                        failures.push(format!("eval {bsdf:?} {wi} {wo} {mode:?}: {f}"));
                    }
                }
                let (p, r) = (bsdf.pdf(wi, wo), bsdf.pdf_reverse(wi, wo));
                if !(ok(p) && ok(r)) {
                    failures.push(format!("pdf {bsdf:?} {wi} {wo}: {p} {r}"));
                }
            }
            for _ in 0..16 {
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    let (uc, u) = (rng.uniform_f32(), rng.uniform_vec2());
                    if let Some(s) = bsdf.sample(wi, uc, u, mode) {
                        let good = s.wo.is_finite()
                            && (s.wo.length() - 1.0).abs() < 1e-3
                            && s.f.is_finite()
                            && s.f.min_element() >= 0.0
                            && s.pdf.is_finite()
                            && s.pdf > 0.0
                            && ok(s.pdf_reverse)
                            && s.eta.is_finite()
                            && s.eta > 0.0;
                        if !good {
                            failures.push(format!(
                                "sample {bsdf:?} {wi} uc {uc} u {u} {mode:?}: {s:?}"
                            ));
                        }
                    }
                }
            }
        }
    }
    failures.truncate(20);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn extreme_uniforms_give_none_or_valid_samples() {
    let extremes = [0.0f32, 1e-7, 0.5, 1.0 - f32::EPSILON / 2.0];
    let mut failures = Vec::new();
    for bsdf in edge_lobes() {
        for wi in [Vec3::Z, direction(1e-8, 0.3), direction(0.7, 2.0) * -1.0] {
            for &uc in &extremes {
                for &ux in &extremes {
                    for &uy in &extremes {
                        let u = glam::Vec2::new(ux, uy);
                        if let Some(s) = bsdf.sample(wi, uc, u, TransportMode::Radiance)
                            && !(s.wo.is_finite()
                                && s.pdf.is_finite()
                                && s.pdf > 0.0
                                && s.f.is_finite())
                        {
                            failures.push(format!("{bsdf:?} {wi} {uc} {u}: {s:?}"));
                        }
                    }
                }
            }
        }
    }
    failures.truncate(20);
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn invalid_indices_are_rejected_quietly() {
    let model = MicrofacetModel::new(microfacet::NdfKind::Ggx, 0.3, microfacet::Shadowing::Smith);
    for eta in [0.0f32, -1.5, f32::NAN, f32::INFINITY] {
        let d = Dielectric::new(model, eta);
        let wi = direction(0.6, 0.0);
        assert_eq!(d.eval(wi, -wi, TransportMode::Radiance), glam::Vec3::ZERO);
        assert_eq!(d.pdf(wi, direction(0.6, std::f32::consts::PI)), 0.0);
        assert!(
            d.sample(wi, 0.5, glam::Vec2::splat(0.5), TransportMode::Radiance)
                .is_none()
        );
    }
}
