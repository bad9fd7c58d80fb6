//! The transmission tint of a dielectric (Khronos glTF 2.0,
//! KHR_materials_transmission: `specular_btdf * baseColor`, the reflection
//! untinted): exact on single values, and in the furnace the tinted lobe's
//! albedo is the clear lobe's reflected albedo plus its transmitted albedo
//! times the tint.

use crate::common;

use common::*;
use glam::Vec3;
use microfacet::{Bsdf, Dielectric, MicrofacetModel, NdfKind, Shadowing, TransportMode};
use stats::{Pcg32, Summary};

/// A tint whose channels differ, none of them 1.
const TINT: Vec3 = Vec3::new(0.8, 0.45, 0.1);

/// Samples per albedo estimate (each of the two lobes).
const SAMPLES: usize = 20_000;

/// Standard errors of the difference of two independent estimates allowed.
const SIGMAS: f64 = 4.0;

fn modes() -> [TransportMode; 2] {
    [TransportMode::Radiance, TransportMode::Importance]
}

fn random_direction(rng: &mut Pcg32) -> Vec3 {
    let u = rng.uniform_vec2();
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

#[test]
fn tint_scales_only_the_refracted_values_exactly() {
    let mut rng = Pcg32::new(41, 1);
    let (mut reflected, mut refracted) = (0, 0);
    let smooth = MicrofacetModel::new(NdfKind::Ggx, 0.0, Shadowing::Smith);
    for model in models().into_iter().chain([smooth]) {
        for eta in ETAS {
            let clear = Dielectric::new(model, eta);
            let white = clear.with_tint(Vec3::ONE);
            let tinted = clear.with_tint(TINT);
            for mode in modes() {
                for _ in 0..50 {
                    let (wi, wo) = (random_direction(&mut rng), random_direction(&mut rng));
                    let f = clear.eval(wi, wo, mode);
                    assert_eq!(f, Vec3::splat(f.x), "a clear lobe is grey");
                    assert_eq!(white.eval(wi, wo, mode), f);
                    let expected = if wi.z * wo.z < 0.0 { TINT * f } else { f };
                    assert_eq!(tinted.eval(wi, wo, mode), expected);

                    let (uc, u) = (rng.uniform_f32(), rng.uniform_vec2());
                    let s = clear.sample(wi, uc, u, mode);
                    assert_eq!(white.sample(wi, uc, u, mode), s);
                    let t = tinted.sample(wi, uc, u, mode);
                    let (Some(s), Some(t)) = (s, t) else {
                        assert!(s.is_none() && t.is_none());
                        continue;
                    };
                    let through = s.wo.z * wi.z < 0.0;
                    assert_eq!(
                        (t.wo, t.pdf, t.pdf_reverse, t.eta),
                        (s.wo, s.pdf, s.pdf_reverse, s.eta)
                    );
                    assert_eq!(t.f, if through { TINT * s.f } else { s.f });
                    if through {
                        refracted += 1;
                    } else {
                        reflected += 1;
                    }
                }
            }
        }
    }
    assert!(
        reflected > 500 && refracted > 500,
        "{reflected} {refracted}"
    );
}

/// Importance-sampled albedo of `bsdf` from `wi`, split into the reflected
/// and the transmitted part (value per channel: eval / pdf, not the
/// sample's own weight, so that eval is what is checked).
fn albedo(bsdf: &Bsdf, wi: Vec3, mode: TransportMode, seed: u64) -> [[Summary; 3]; 2] {
    let mut rng = Pcg32::new(seed, 7);
    let mut parts: [[Summary; 3]; 2] = Default::default();
    for _ in 0..SAMPLES {
        let (uc, u) = (rng.uniform_f32(), rng.uniform_vec2());
        let (through, weight) = bsdf
            .sample(wi, uc, u, mode)
            .map_or((false, Vec3::ZERO), |s| {
                let through = s.wo.z * wi.z < 0.0;
                if s.is_specular {
                    (through, s.f * s.wo.z.abs() / s.pdf)
                } else {
                    let pdf = bsdf.pdf(wi, s.wo);
                    let w = if pdf > 0.0 {
                        bsdf.eval(wi, s.wo, mode) * s.wo.z.abs() / pdf
                    } else {
                        Vec3::ZERO
                    };
                    (through, w)
                }
            });
        for c in 0..3 {
            let w = f64::from(weight[c]);
            parts[usize::from(through)][c].push(w);
            parts[usize::from(!through)][c].push(0.0);
        }
    }
    parts
}

#[test]
fn tinted_albedo_is_reflection_plus_tinted_transmission() {
    let mut failures = Vec::new();
    let mut seed = 0;
    for alpha in [0.0f32, 0.2, 0.6] {
        let model = MicrofacetModel::new(NdfKind::Ggx, alpha, Shadowing::Smith);
        for eta in ETAS {
            for cos in [0.9f32, 0.3] {
                let wi = direction(cos, 0.4);
                for mode in modes() {
                    seed += 2;
                    let clear = Bsdf::Dielectric(Dielectric::new(model, eta));
                    let tinted = Bsdf::Dielectric(Dielectric::new(model, eta).with_tint(TINT));
                    let [r, t] = albedo(&clear, wi, mode, seed);
                    let tinted = albedo(&tinted, wi, mode, seed + 1);
                    for c in 0..3 {
                        let got = tinted[0][c].mean() + tinted[1][c].mean();
                        let expected = r[0].mean() + f64::from(TINT[c]) * t[0].mean();
                        // Independent estimates: the variances add; each
                        // total's variance is at most twice the sum of its parts'.
                        let var = 2.0
                            * (tinted[0][c].standard_error().powi(2)
                                + tinted[1][c].standard_error().powi(2)
                                + r[0].standard_error().powi(2)
                                + (f64::from(TINT[c]) * t[0].standard_error()).powi(2));
                        let tolerance = SIGMAS * var.sqrt() + 1e-6;
                        if (got - expected).abs() > tolerance {
                            failures.push(format!(
                                "alpha {alpha} eta {eta} cos {cos} {mode:?} channel {c}: \
                                 {got} vs {expected} (tolerance {tolerance})"
                            ));
                        }
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}
