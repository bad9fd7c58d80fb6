//! The glTF metallic-roughness (coated) lobe: chi-square of its sampling
//! against its mixture pdf, energy (white furnace), reciprocity and the
//! agreement of `sample` with `eval`/`pdf`, and its limits (black base:
//! the coat alone; metallic 1: the Schlick conductor).

use crate::common;

use common::*;
use glam::Vec3;
use microfacet::{
    Bsdf, Coated, Conductor, Fresnel, MicrofacetModel, NdfKind, Shadowing, TransportMode,
};
use stats::chi2::sidak;
use stats::{Pcg32, SphericalChi2, Summary};

/// A coated lobe with GGX/Smith of width `alpha`.
fn coated(alpha: f32, base: Vec3, metallic: f32) -> Coated {
    Coated {
        model: MicrofacetModel::new(NdfKind::Ggx, alpha, Shadowing::Smith),
        base_color: base,
        metallic,
        specular: 1.0,
        specular_color: Vec3::ONE,
        ior: 1.5,
    }
}

/// The materials of the statistical tests: a coloured plastic, a black
/// dielectric (the coat alone), a half-metal with a tinted, weakened coat
/// (`KHR_materials_specular`) of index 2, a metal.
fn materials(alpha: f32) -> Vec<(&'static str, Coated)> {
    vec![
        ("plastic", coated(alpha, Vec3::new(0.8, 0.5, 0.2), 0.0)),
        ("black", coated(alpha, Vec3::ZERO, 0.0)),
        (
            "half-metal",
            Coated {
                specular: 0.6,
                specular_color: Vec3::new(1.0, 0.7, 0.4),
                ior: 2.0,
                ..coated(alpha, Vec3::new(0.3, 0.6, 0.9), 0.5)
            },
        ),
        ("metal", coated(alpha, Vec3::new(0.95, 0.6, 0.3), 1.0)),
    ]
}

// ---------------------------------------------------------------- chi-square

/// Widths of the chi-square tests: smooth (the mirror part is a delta),
/// narrow, medium, rough.
const CHI2_ALPHAS: [f32; 4] = [0.0, 0.05, 0.3, 0.8];

/// Incident directions: near normal, grazing, and one from below (two-sided).
fn chi2_directions() -> [Vec3; 3] {
    [
        direction(0.9, 0.7),
        direction(0.12, 4.0),
        -direction(0.55, 2.1),
    ]
}

/// Number of chi-square tests in this file (Sidak correction): every
/// material, alpha and direction, plus the other NDF/shadowing pairs.
fn family_size() -> usize {
    CHI2_ALPHAS.len() * 4 * chi2_directions().len() + other_models().len() * 3
}

/// Blinn-Phong (the MTL mapping) and a V-cavity model (whose sampler
/// consumes the rescaled coin uniform).
fn other_models() -> [MicrofacetModel; 2] {
    [
        MicrofacetModel::new(NdfKind::BlinnPhong, 0.3, Shadowing::Smith),
        MicrofacetModel::new(NdfKind::Beckmann, 0.3, Shadowing::VCavity),
    ]
}

/// The harness with a quadrature fine enough for a reflection lobe of width
/// `alpha` (as in `chi2.rs`).
fn harness(alpha: f32) -> SphericalChi2 {
    let mut test = SphericalChi2::default();
    let cell = std::f64::consts::PI / test.theta_res as f64;
    let lobe = f64::from(alpha.max(0.05)) / 3.0;
    test.integration_depth.min = (cell / lobe).log2().ceil().max(1.0) as u32;
    test
}

/// Runs one chi-square test; delta samples count as rejected, so the
/// expected rejected mass is the mirror's probability, 1 - integral of `pdf`.
fn chi2(bsdf: Bsdf, wi: Vec3, seed: u64, pdf: impl Fn(Vec3) -> f64) -> Option<String> {
    let alpha = bsdf.alpha().unwrap_or(1.0);
    if bsdf.is_specular() {
        return None; // a pure mirror: nothing to bin (tested in `black_dielectric_reflects_its_coat`)
    }
    let sample = move |rng: &mut Pcg32| {
        let uc = rng.uniform_f32();
        let u = rng.uniform_vec2();
        bsdf.sample(wi, uc, u, TransportMode::Radiance)
            .filter(|s| !s.is_specular)
            .map(|s| s.wo)
    };
    let outcome = harness(alpha).run(&mut Pcg32::new(seed, 0xc0a7), sample, pdf);
    (!outcome.passes(sidak(0.01, family_size()))).then(|| format!("{bsdf:?} wi={wi}: {outcome:?}"))
}

fn chi2_for(alphas: &[f32]) -> Vec<String> {
    chi2_of(alphas, |_| true)
}

/// The tests of `alphas` for the materials whose name `keep` accepts.
fn chi2_of(alphas: &[f32], keep: impl Fn(&str) -> bool) -> Vec<String> {
    let mut failures = Vec::new();
    for &alpha in alphas {
        let a = CHI2_ALPHAS.iter().position(|&x| x == alpha).unwrap_or(9);
        for (m, (name, lobe)) in materials(alpha).into_iter().enumerate() {
            if !keep(name) {
                continue;
            }
            for (k, wi) in chi2_directions().into_iter().enumerate() {
                let bsdf = Bsdf::Coated(lobe);
                let seed = (a * 100 + m * 10 + k) as u64;
                failures.extend(chi2(bsdf, wi, seed, |wo| f64::from(bsdf.pdf(wi, wo))));
            }
        }
    }
    failures
}

fn assert_all_pass(failures: Vec<String>) {
    assert!(
        failures.is_empty(),
        "{} failure(s):\n{}",
        failures.len(),
        failures.join("\n")
    );
}

#[test]
fn chi2_smooth() {
    assert_all_pass(chi2_for(&CHI2_ALPHAS[..1]));
}

// The narrow lobe needs the finest quadrature: one test per material.
#[test]
fn chi2_narrow_plastic() {
    assert_all_pass(chi2_of(&CHI2_ALPHAS[1..2], |m| m == "plastic"));
}

#[test]
fn chi2_narrow_black() {
    assert_all_pass(chi2_of(&CHI2_ALPHAS[1..2], |m| m == "black"));
}

#[test]
fn chi2_narrow_half_metal() {
    assert_all_pass(chi2_of(&CHI2_ALPHAS[1..2], |m| m == "half-metal"));
}

#[test]
fn chi2_narrow_metal() {
    assert_all_pass(chi2_of(&CHI2_ALPHAS[1..2], |m| m == "metal"));
}

#[test]
fn chi2_medium() {
    assert_all_pass(chi2_for(&CHI2_ALPHAS[2..3]));
}

#[test]
fn chi2_rough() {
    assert_all_pass(chi2_for(&CHI2_ALPHAS[3..]));
}

#[test]
fn chi2_other_ndfs_and_shadowing() {
    let mut failures = Vec::new();
    for (m, model) in other_models().into_iter().enumerate() {
        let lobe = Coated {
            model,
            ..materials(0.3)[0].1
        };
        for (k, wi) in chi2_directions().into_iter().enumerate() {
            let bsdf = Bsdf::Coated(lobe);
            failures.extend(chi2(bsdf, wi, 900 + (m * 10 + k) as u64, |wo| {
                f64::from(bsdf.pdf(wi, wo))
            }));
        }
    }
    assert_all_pass(failures);
}

/// Negative control: the harness rejects a mixture pdf whose specular part
/// is weighted 15 % too much or too little, or whose lobe probability is
/// taken at the wrong direction (wo instead of wi).
#[test]
fn chi2_detects_a_wrong_mixture_pdf() {
    let lobe = materials(0.3)[0].1;
    let bsdf = Bsdf::Coated(lobe);
    let wi = direction(0.12, 4.0);
    for scale in [1.15, 0.85] {
        let wrong = |wo: Vec3| {
            let p_s = lobe.specular_probability(wi.z.abs());
            let extra = (scale - 1.0) * p_s * lobe.specular_pdf(wi, wo);
            f64::from(bsdf.pdf(wi, wo) + extra)
        };
        assert!(chi2(bsdf, wi, 77, wrong).is_some(), "scale {scale} passed");
    }
    let swapped = |wo: Vec3| {
        let p_s = lobe.specular_probability(wo.z.abs());
        let diffuse = if wo.z * wi.z > 0.0 {
            wo.z.abs() / std::f32::consts::PI
        } else {
            0.0
        };
        f64::from(p_s * lobe.specular_pdf(wi, wo) + (1.0 - p_s) * diffuse)
    };
    assert!(chi2(bsdf, wi, 78, swapped).is_some());
}

// -------------------------------------------------------------------- energy

const FURNACE_SAMPLES: usize = 10_000;
/// What the issue allows beyond 1, before the estimate's own error.
const ALLOWED_GAIN: f64 = 1e-3;
const SIGMAS: f64 = 4.0;

/// Directional albedo int f(wi, wo) |cos| dwo, per channel (red), estimated
/// with `eval`/`pdf` called separately for non-delta samples and the
/// sample's own weight for the mirror.
fn albedo(bsdf: &Bsdf, wi: Vec3, seed: u64) -> Summary {
    let mut rng = Pcg32::new(seed, 3);
    let mut summary = Summary::new();
    for _ in 0..FURNACE_SAMPLES {
        let (uc, u) = (rng.uniform_f32(), rng.uniform_vec2());
        let weight = bsdf
            .sample(wi, uc, u, TransportMode::Radiance)
            .map_or(0.0, |s| {
                if s.is_specular {
                    return f64::from(s.f.x * s.wo.z.abs() / s.pdf);
                }
                let pdf = bsdf.pdf(wi, s.wo);
                let f = bsdf.eval(wi, s.wo, TransportMode::Radiance).x;
                f64::from(f * s.wo.z.abs() / pdf)
            });
        summary.push(weight);
    }
    summary
}

/// A white coated surface (base 1, every alpha, ior, specular factor,
/// incidence, and a half metal; the full metal is the conductor of
/// `energy.rs`, see `full_metal_is_the_schlick_conductor`) reflects at most
/// what it receives.
#[test]
fn white_furnace_albedo_is_at_most_one() {
    let mut failures = Vec::new();
    let mut seed = 0;
    for alpha in [0.0f32, 0.05, 0.3, 1.0] {
        for ior in [1.0f32, 1.5, 3.0] {
            for specular in [0.0f32, 0.5, 1.0] {
                for metallic in [0.0f32, 0.5] {
                    let lobe = Coated {
                        specular,
                        ior,
                        ..coated(alpha, Vec3::ONE, metallic)
                    };
                    for cos in [1.0f32, 0.7, 0.3, 0.05, 0.01] {
                        seed += 1;
                        let s = albedo(&Bsdf::Coated(lobe), direction(cos, 0.3), seed);
                        let limit = 1.0 + ALLOWED_GAIN + SIGMAS * s.standard_error();
                        if s.mean() > limit {
                            failures.push(format!("{lobe:?} cos {cos}: {} > {limit}", s.mean()));
                        }
                        // Sanity: away from grazing a white surface with a
                        // narrow GGX lobe keeps nearly all of the energy
                        // (a smooth one all of it, module docs).
                        if alpha <= 0.05 && cos >= 0.3 && s.mean() < 0.95 {
                            failures.push(format!("{lobe:?} cos {cos}: {} too low", s.mean()));
                        }
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

// --------------------------------------------------------------- reciprocity

/// Relative agreement of two evaluations of the same quantity (as in
/// `reciprocity.rs`): a lobe of alpha 0.05 changes by 2e-4 when its half
/// vector moves by f32 round-off.
const REL: f32 = 1e-3;
const ABS: f32 = 1e-6;

fn close(a: Vec3, b: Vec3) -> bool {
    (a - b).abs().max_element() <= REL * a.abs().max_element().max(b.abs().max_element()) + ABS
}

fn random_direction(rng: &mut Pcg32) -> Vec3 {
    let z = 2.0 * rng.uniform_f32() - 1.0;
    direction(z, 2.0 * std::f32::consts::PI * rng.uniform_f32())
}

#[test]
fn eval_is_reciprocal() {
    let mut rng = Pcg32::new(21, 0);
    for alpha in [0.0, 0.05, 0.3, 1.0] {
        for (name, lobe) in materials(alpha) {
            let bsdf = Bsdf::Coated(lobe);
            for _ in 0..500 {
                let (wi, wo) = (random_direction(&mut rng), random_direction(&mut rng));
                let (a, b) = (
                    bsdf.eval(wi, wo, TransportMode::Radiance),
                    bsdf.eval(wo, wi, TransportMode::Radiance),
                );
                assert!(close(a, b), "{name} alpha {alpha}: {wi} {wo}: {a} vs {b}");
                // Reflection only: the transport modes agree.
                assert_eq!(a, bsdf.eval(wi, wo, TransportMode::Importance));
            }
        }
    }
}

#[test]
fn sample_agrees_with_eval_and_both_pdfs() {
    let mut rng = Pcg32::new(22, 0);
    for alpha in [0.0, 0.05, 0.3, 1.0] {
        for (name, lobe) in materials(alpha) {
            let bsdf = Bsdf::Coated(lobe);
            for _ in 0..500 {
                let wi = random_direction(&mut rng);
                let (uc, u) = (rng.uniform_f32(), rng.uniform_vec2());
                let Some(s) = bsdf.sample(wi, uc, u, TransportMode::Radiance) else {
                    continue;
                };
                assert!(s.wo.z * wi.z > 0.0, "{name}: sampled through the surface");
                if s.is_specular {
                    assert!(lobe.model.is_smooth());
                    assert!((s.wo - Vec3::new(-wi.x, -wi.y, wi.z)).length() < 1e-6);
                    continue;
                }
                let f = bsdf.eval(wi, s.wo, TransportMode::Radiance);
                assert!(close(s.f, f), "{name}: f {} vs {f}", s.f);
                let (pdf, rev) = (bsdf.pdf(wi, s.wo), bsdf.pdf_reverse(wi, s.wo));
                assert!(close(Vec3::splat(s.pdf), Vec3::splat(pdf)), "{name}");
                assert!(
                    close(Vec3::splat(s.pdf_reverse), Vec3::splat(rev)),
                    "{name}"
                );
            }
        }
    }
}

// -------------------------------------------------------------------- limits

/// The first symptom: a black-base dielectric rendered exactly 0.
/// Here it is its coat: about F0 = 4 % at normal incidence, more at grazing.
#[test]
fn black_dielectric_reflects_its_coat() {
    let rough = Bsdf::Coated(coated(0.3, Vec3::ZERO, 0.0));
    let wi = direction(0.9, 0.2);
    let wo = direction(0.9, 0.2 + std::f32::consts::PI);
    assert!(rough.eval(wi, wo, TransportMode::Radiance).min_element() > 0.0);
    let normal = albedo(&rough, direction(1.0, 0.0), 5).mean();
    let grazing = albedo(&rough, direction(0.1, 0.0), 6).mean();
    assert!((0.02..0.1).contains(&normal), "{normal}");
    assert!(grazing > normal, "{grazing} <= {normal}");

    // Smooth: a mirror with Schlick's reflectance, and nothing else.
    let smooth = Bsdf::Coated(coated(0.0, Vec3::ZERO, 0.0));
    assert!(smooth.is_specular());
    let s = smooth
        .sample(wi, 0.5, glam::Vec2::splat(0.5), TransportMode::Radiance)
        .unwrap();
    let f = microfacet::fresnel::schlick(0.9, Vec3::splat(0.04));
    assert!(s.is_specular && close(s.f * s.wo.z / s.pdf, f), "{s:?}");
}

/// metallic = 1 is Appendix B's metal: the Schlick conductor with F0 = base.
#[test]
fn full_metal_is_the_schlick_conductor() {
    let mut rng = Pcg32::new(23, 0);
    for alpha in [0.0, 0.05, 0.3, 1.0] {
        let base = Vec3::new(0.95, 0.6, 0.3);
        let lobe = Bsdf::Coated(coated(alpha, base, 1.0));
        let conductor = Bsdf::Conductor(Conductor {
            model: MicrofacetModel::new(NdfKind::Ggx, alpha, Shadowing::Smith),
            fresnel: Fresnel::Schlick { f0: base },
        });
        assert_eq!(lobe.is_specular(), conductor.is_specular());
        for _ in 0..300 {
            let (wi, wo) = (random_direction(&mut rng), random_direction(&mut rng));
            let mode = TransportMode::Radiance;
            assert!(close(lobe.eval(wi, wo, mode), conductor.eval(wi, wo, mode)));
            let (p, q) = (lobe.pdf(wi, wo), conductor.pdf(wi, wo));
            assert!(close(Vec3::splat(p), Vec3::splat(q)), "{p} vs {q}");
            let (uc, u) = (rng.uniform_f32(), rng.uniform_vec2());
            let (a, b) = (
                lobe.sample(wi, uc, u, mode),
                conductor.sample(wi, uc, u, mode),
            );
            assert_eq!(a.is_some(), b.is_some());
            if let (Some(a), Some(b)) = (a, b) {
                assert!((a.wo - b.wo).length() < 1e-5 && close(a.f, b.f));
            }
        }
    }
}

/// Regularization widens the coat only: the diffuse base is unchanged and a
/// smooth coat becomes a glossy lobe that `eval` sees.
#[test]
fn with_alpha_widens_the_specular_lobe_only() {
    let smooth = Bsdf::Coated(coated(0.0, Vec3::ZERO, 0.0));
    let glossy = smooth.with_alpha(0.1);
    assert!(smooth.is_specular() && !glossy.is_specular());
    assert_eq!(glossy.alpha(), Some(0.1));
    let wi = direction(0.8, 0.0);
    let mirror = Vec3::new(-wi.x, -wi.y, wi.z);
    assert_eq!(smooth.eval(wi, mirror, TransportMode::Radiance), Vec3::ZERO);
    assert!(glossy.eval(wi, mirror, TransportMode::Radiance).x > 0.0);
    let Bsdf::Coated(c) = glossy.with_alpha(0.5) else {
        unreachable!()
    };
    assert_eq!(c.base_color, Vec3::ZERO);
    assert_eq!(c.model.alpha(), 0.5);
}
