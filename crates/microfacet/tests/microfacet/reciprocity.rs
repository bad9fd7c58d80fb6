//! Reciprocity and the adjoint rule (SPEC §0 and §3):
//! - reflection: f(wi, wo) = f(wo, wi) in both transport modes;
//! - refraction: f_Radiance(wi, wo) = f_Importance(wo, wi) (the adjoint BSDF)
//!   and f_Radiance(wi, wo) = f_Importance(wi, wo) (eta_i/eta_t)^2;
//! - `sample` agrees with `eval`, `pdf` and `pdf_reverse`.

use crate::common;

use common::*;
use glam::Vec3;
use microfacet::frame::same_hemisphere;
use microfacet::{Bsdf, Lambertian, TransportMode};
use stats::Pcg32;

/// Relative agreement required of two evaluations of the same quantity: a
/// lobe of alpha = 0.05 changes by 2e-4 when its half vector moves by f32
/// round-off, and any formula error shows up far above this.
const REL: f32 = 1e-3;
/// Values below this (the far tails, where f32 round-off in the half vector
/// dominates) are compared in absolute terms; lobe peaks reach 1e6 and more.
const ABS: f32 = 1e-6;

fn close(a: f32, b: f32) -> bool {
    (a - b).abs() <= REL * a.abs().max(b.abs()) + ABS
}

/// The half vector of a pair is the normalised sum wi + wo (reflection) or
/// wi + eta wo (refraction). When the sum is short, f32 round-off in the
/// sampled direction moves the recomputed half vector noticeably, so `eval`
/// cannot reproduce the sampled value to `REL`: such pairs are skipped.
const MIN_HALF_VECTOR_LENGTH: f32 = 0.05;

/// Near the critical angle Snell's map is singular and 1 - F has an infinite
/// slope: a change of 1e-6 in wo changes f by 1 %. Refraction pairs whose
/// microfacet cosines are this close to zero are skipped too.
const MIN_MICROFACET_COSINE: f32 = 0.02;

fn well_conditioned(bsdf: &Bsdf, wi: Vec3, wo: Vec3) -> bool {
    let raw = match bsdf {
        Bsdf::Dielectric(d) if !same_hemisphere(wi, wo) => {
            wi + if wi.z > 0.0 { d.eta } else { 1.0 / d.eta } * wo
        }
        _ => wi + wo,
    };
    let h = raw.normalize_or_zero();
    raw.length() >= MIN_HALF_VECTOR_LENGTH
        && wi.dot(h).abs() >= MIN_MICROFACET_COSINE
        && wo.dot(h).abs() >= MIN_MICROFACET_COSINE
}

fn random_direction(rng: &mut Pcg32) -> Vec3 {
    let z = 2.0 * rng.uniform_f32() - 1.0;
    direction(z, 2.0 * std::f32::consts::PI * rng.uniform_f32())
}

fn lobes() -> Vec<Bsdf> {
    let mut out = vec![Bsdf::Lambertian(Lambertian {
        reflectance: Vec3::new(0.2, 0.5, 0.8),
    })];
    for model in models() {
        out.push(Bsdf::Conductor(microfacet::Conductor {
            model,
            fresnel: microfacet::Fresnel::Conductor {
                eta: Vec3::new(0.2, 0.9, 1.1),
                k: Vec3::new(3.9, 2.4, 2.2),
                tint: Vec3::ONE,
            },
        }));
        for eta in ETAS {
            out.push(Bsdf::Dielectric(dielectric(model, eta)));
        }
    }
    out
}

#[test]
fn reflection_is_reciprocal() {
    let mut rng = Pcg32::new(11, 0);
    for bsdf in lobes() {
        for _ in 0..300 {
            let (wi, wo) = (random_direction(&mut rng), random_direction(&mut rng));
            if !same_hemisphere(wi, wo) {
                continue;
            }
            for mode in [TransportMode::Radiance, TransportMode::Importance] {
                let (a, b) = (bsdf.eval(wi, wo, mode), bsdf.eval(wo, wi, mode));
                assert!(
                    (0..3).all(|c| close(a[c], b[c])),
                    "{bsdf:?} {wi} {wo}: {a} vs {b}"
                );
            }
        }
    }
}

#[test]
fn refraction_follows_the_adjoint_rule() {
    let mut rng = Pcg32::new(12, 0);
    let mut tested = 0;
    for bsdf in lobes() {
        let Bsdf::Dielectric(d) = bsdf else { continue };
        for _ in 0..300 {
            let (wi, wo) = (random_direction(&mut rng), random_direction(&mut rng));
            if same_hemisphere(wi, wo) || !well_conditioned(&bsdf, wi, wo) {
                continue;
            }
            let radiance = d.eval(wi, wo, TransportMode::Radiance).x;
            let importance = d.eval(wi, wo, TransportMode::Importance).x;
            let adjoint = d.eval(wo, wi, TransportMode::Importance).x;
            // eta_t / eta_i as seen from wi.
            let eta = if wi.z > 0.0 { d.eta } else { 1.0 / d.eta };
            assert!(
                close(radiance, adjoint),
                "{d:?} {wi} {wo}: {radiance} vs adjoint {adjoint}"
            );
            assert!(
                close(radiance, importance / (eta * eta)),
                "{d:?}: {radiance} vs {importance}"
            );
            tested += usize::from(radiance > 0.0);
        }
    }
    assert!(
        tested > 1000,
        "only {tested} non-zero refraction configurations"
    );
}

#[test]
fn samples_agree_with_eval_and_pdfs() {
    let mut rng = Pcg32::new(13, 0);
    let (mut tested, mut skipped) = (0, 0);
    for bsdf in lobes() {
        for mode in [TransportMode::Radiance, TransportMode::Importance] {
            for _ in 0..300 {
                let wi = random_direction(&mut rng);
                let Some(s) = bsdf.sample(wi, rng.uniform_f32(), rng.uniform_vec2(), mode) else {
                    continue;
                };
                if !well_conditioned(&bsdf, wi, s.wo) {
                    skipped += 1;
                    continue;
                }
                tested += 1;
                let f = bsdf.eval(wi, s.wo, mode);
                assert!(
                    (0..3).all(|c| close(s.f[c], f[c])),
                    "{bsdf:?} {mode:?} f {} vs {f}",
                    s.f
                );
                assert!(
                    close(s.pdf, bsdf.pdf(wi, s.wo)),
                    "{bsdf:?} pdf {} vs {}",
                    s.pdf,
                    bsdf.pdf(wi, s.wo)
                );
                let reverse = bsdf.pdf_reverse(wi, s.wo);
                assert!(
                    close(s.pdf_reverse, reverse),
                    "{bsdf:?} reverse {} vs {reverse}",
                    s.pdf_reverse
                );
                assert!(s.pdf > 0.0 && !s.is_specular);
                let expected_eta = match bsdf {
                    Bsdf::Dielectric(d) if !same_hemisphere(wi, s.wo) => {
                        if wi.z > 0.0 {
                            d.eta
                        } else {
                            1.0 / d.eta
                        }
                    }
                    _ => 1.0,
                };
                assert_eq!(s.eta, expected_eta);
            }
        }
    }
    assert!(
        skipped * 100 < tested,
        "skipped {skipped} of {}",
        tested + skipped
    );
}
