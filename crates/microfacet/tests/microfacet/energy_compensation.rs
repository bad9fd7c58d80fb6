//! Energy compensation of regularized lobes (`microfacet::compensation::energy`,
//! `microfacet::compensation::gain`): the albedo tables against brute-force integration,
//! the white furnace of every compensated lobe against its original's
//! albedo (where widening loses energy and where it gains), chi-square of
//! the compensated sampling, and reciprocity of the compensated value.
//!
//! The 1e-3 of the furnace is held without noise by quadrature
//! (`compensated_albedo_matches_the_original_by_quadrature`). The sampled
//! estimates check that the lobes' own sampler, value and pdf agree with it
//! (`eval cos / pdf` of stratified samples: a jittered grid in u and a
//! random coin), repeated `REPLICAS` times with independent jitter; the
//! spread of the replicas gives the standard error, and each tolerance is
//! 1e-3 plus `SIGMAS` of them.

use crate::common;

use common::*;
use glam::Vec3;
use microfacet::compensation::energy::{albedo_quadrature, albedo_table};
use microfacet::compensation::gain::scaled_albedo_quadrature;
use microfacet::{Bsdf, Coated, MicrofacetModel, NdfKind, Shadowing, TransportMode};
use stats::chi2::sidak;
use stats::{Pcg32, SphericalChi2};

/// Side of the jittered grid of one replica.
const GRID: usize = 48;
/// Independent replicas of the stratified estimate.
const REPLICAS: usize = 16;
/// The tolerance on albedos.
const TOLERANCE: f64 = 1e-3;
/// Standard errors allowed beyond `TOLERANCE`: a standard error from 16
/// replicas follows Student's t with 15 degrees of freedom, whose two-sided
/// tail beyond 5 is 1.6e-4, about 2 % over the 150 cases of a test (at 8
/// replicas and 4, a 5e-3 tail: a case 4.9 estimated standard errors off
/// while 1e-4 from the truth at 64x the samples).
const SIGMAS: f64 = 5.0;

/// (mean, standard error) of the directional albedo of `bsdf` (red channel)
/// for a query from `wi`.
fn albedo(bsdf: &Bsdf, wi: Vec3, seed: u64) -> (f64, f64) {
    stratified_albedo(
        bsdf,
        wi,
        TransportMode::Radiance,
        (GRID, REPLICAS),
        (seed, 11),
    )
}

/// Below `GRAZING` (mu < 0.04, beyond 87.7 degrees) the albedo of narrow
/// lobes bends within a cosine of about alpha, finer than the table's nodes,
/// and the interpolated table is held to `GRAZING_TOLERANCE` instead of
/// `TOLERANCE` (the table against 32 x 32 quadrature: up to 2.7e-3 at alpha
/// 0.002, mu 0.012; 8.1e-4 at mu >= 0.04).
const GRAZING: f32 = 0.04;
const GRAZING_TOLERANCE: f64 = 3e-3;

fn tolerance(mu: f32) -> f64 {
    if mu < GRAZING {
        GRAZING_TOLERANCE
    } else {
        TOLERANCE
    }
}

/// The table entry E(mu, alpha) against the white conductor's albedo,
/// between the nodes (where interpolation error is largest).
#[test]
fn albedo_tables_match_brute_force() {
    let mut failures = Vec::new();
    let mut worst: f64 = 0.0;
    for (n, (kind, shadowing)) in kinds().into_iter().enumerate() {
        let start = std::time::Instant::now();
        let table = albedo_table(kind, shadowing);
        println!("{kind:?}/{shadowing:?} table: {:?}", start.elapsed());
        for (k, alpha) in [0.048f32, 0.2, 0.37, 0.66, 0.98].into_iter().enumerate() {
            for (m, mu) in [0.02f32, 0.045, 0.2, 0.51, 0.83, 0.99]
                .into_iter()
                .enumerate()
            {
                let bsdf = Bsdf::Conductor(white_conductor(MicrofacetModel::new(
                    kind, alpha, shadowing,
                )));
                let (mean, se) = albedo(&bsdf, direction(mu, 0.4), (n * 100 + k * 10 + m) as u64);
                let e = f64::from(table.albedo(mu, alpha));
                worst = worst.max((e - mean).abs());
                if (e - mean).abs() > tolerance(mu) + SIGMAS * se {
                    failures.push(format!(
                        "{kind:?}/{shadowing:?} alpha {alpha} mu {mu}: table {e}, brute force {mean} +- {se}"
                    ));
                }
            }
        }
    }
    println!("largest |table - brute force| {worst:.2e}");
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

fn kinds() -> Vec<(NdfKind, Shadowing)> {
    NDFS.into_iter()
        .flat_map(|k| SHADOWINGS.into_iter().map(move |s| (k, s)))
        .collect()
}

/// Original widths (0 = a mirror) and regularized widths of the furnace tests.
const ORIGINAL: [f32; 3] = [0.0, 0.05, 0.3];
const REGULARIZED: [f32; 3] = [0.1, 0.45, 0.9];
const COSINES: [f32; 5] = [1.0, 0.6, 0.25, 0.08, 0.04];

/// The albedo of a lobe of width `alpha` (1 for a mirror, exactly).
fn original_albedo(bsdf: &Bsdf, wi: Vec3, seed: u64) -> (f64, f64) {
    if bsdf.is_specular() {
        (1.0, 0.0)
    } else {
        albedo(bsdf, wi, seed)
    }
}

/// White furnace: a white conductor regularized with compensation reflects
/// what the original reflected, within 1e-3, for every NDF x shadowing:
/// where widening loses energy (the compensation lobe adds it) and where it
/// gains (V-cavity, and Beckmann/Blinn-Phong near grazing: the widened
/// lobe is scaled down, `microfacet::compensation::gain`). The largest loss and gain of
/// the plain widened lobe are printed.
#[test]
fn compensated_conductor_keeps_the_original_albedo() {
    let mut failures = Vec::new();
    let (mut worst, mut lost, mut gain): (f64, f64, f64) = (0.0, 0.0, 0.0);
    let mut seed = 0;
    for (kind, shadowing) in kinds() {
        for alpha in ORIGINAL {
            let original = Bsdf::Conductor(white_conductor(MicrofacetModel::new(
                kind,
                alpha.max(1e-5),
                shadowing,
            )));
            for alpha_hat in REGULARIZED.into_iter().filter(|&a| a > alpha) {
                let regularized = original.regularized(alpha_hat);
                let plain = original.with_alpha(alpha_hat);
                for cos in COSINES {
                    seed += 1;
                    let wi = direction(cos, 1.3);
                    let (e, se) = original_albedo(&original, wi, seed);
                    let (e_hat, se_hat) = albedo(&regularized, wi, seed + 5000);
                    let (e_plain, _) = albedo(&plain, wi, seed + 9000);
                    let se = (se * se + se_hat * se_hat).sqrt();
                    lost = lost.max(e - e_plain);
                    gain = gain.max(e_plain - e);
                    let difference = (e_hat - e).abs();
                    worst = worst.max(difference);
                    if difference > tolerance(cos) + SIGMAS * se {
                        failures.push(format!(
                            "{kind:?}/{shadowing:?} {alpha} -> {alpha_hat} cos {cos}: \
                             original {e} +- {se}, compensated {e_hat} +- {se_hat}"
                        ));
                    }
                }
            }
        }
    }
    println!(
        "largest |compensated - original| {worst:.2e}; without compensation: largest loss \
         {lost:.3}, largest gain {gain:.3}"
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Reference albedos of the noise-free furnace (`albedo_quadrature`, nodes
/// per piece): 32 x 32 agree with 64 x 64 within 4e-6 for every NDF and
/// shadowing model (tables: 16 x 16, 5e-5).
const REFERENCE: (usize, usize) = (32, 32);

/// The furnace without Monte Carlo noise: the compensated lobe s(mu_i)
/// s(mu_o) f-hat + f_c reflects E_s(mu) + dE(mu), so its difference from
/// the original's E(alpha) is the tables' error. E and E_s are fine
/// quadratures (E_s with the lobe's own s at every quadrature direction,
/// `scaled_albedo_quadrature`), dE the lobe's own
/// (`Compensation::deficit`), over originals (mirror to 0.3), widths to 1
/// and cosines to 0.04: within 1e-3 (`tolerance`), where widening loses
/// energy and where it gains (the pairs of the largest gains among
/// them: 0.01 -> 0.09, 0.09 -> 0.35, 0.11 -> 0.47).
#[test]
fn compensated_albedo_matches_the_original_by_quadrature() {
    let originals = [0.0f32, 0.002, 0.01, 0.03, 0.06, 0.09, 0.11, 0.2, 0.3];
    let widened = [0.05f32, 0.07, 0.09, 0.15, 0.25, 0.35, 0.47, 0.75, 1.0];
    let cosines = [
        0.02f32, 0.04, 0.05, 0.06, 0.08, 0.1, 0.13, 0.2, 0.3, 0.45, 0.65, 0.85, 1.0,
    ];
    let mut failures = Vec::new();
    let mut scaled_cases = 0;
    for (kind, shadowing) in kinds() {
        let mut worst = [(0.0f64, String::new()), (0.0, String::new())];
        for mu in cosines {
            let truth =
                |alpha: f32| albedo_quadrature(kind, shadowing, alpha, f64::from(mu), REFERENCE);
            for alpha in originals {
                let original = truth(alpha);
                let model = MicrofacetModel::new(kind, alpha.max(1e-5), shadowing);
                for alpha_hat in widened.into_iter().filter(|&a| a > alpha) {
                    let regularized = model.regularized(alpha_hat, Vec3::ONE);
                    let (deficit, scaled) = regularized.compensation().map_or((0.0, false), |c| {
                        (
                            f64::from(c.deficit(&regularized.ndf, regularized.shadowing, mu)),
                            c.scaled,
                        )
                    });
                    let scale = |mu: f32| {
                        regularized.compensation().map_or(1.0, |c| {
                            c.scale(&regularized.ndf, regularized.shadowing, mu)
                        })
                    };
                    let widened = scaled_albedo_quadrature(
                        kind,
                        shadowing,
                        alpha_hat,
                        f64::from(mu),
                        REFERENCE,
                        scale,
                    );
                    scaled_cases += usize::from(scaled);
                    let error = (widened + deficit - original).abs();
                    let case = format!(
                        "{kind:?}/{shadowing:?} {alpha} -> {alpha_hat} mu {mu}: original \
                         {original:.5}, widened{} {widened:.5} + dE {deficit:.5} (error {error:.1e})",
                        if scaled { " and scaled" } else { "" }
                    );
                    let allowed = tolerance(mu);
                    let class = &mut worst[usize::from(allowed != TOLERANCE)];
                    if error > class.0 {
                        *class = (error, case.clone());
                    }
                    if error > allowed {
                        failures.push(case);
                    }
                }
            }
        }
        println!(
            "largest |compensated - original|, mu >= {GRAZING}: {:.2e} ({})",
            worst[0].0, worst[0].1
        );
        println!(
            "largest below mu {GRAZING}: {:.2e} ({})",
            worst[1].0, worst[1].1
        );
    }
    println!("{scaled_cases} cases scaled");
    assert!(
        failures.is_empty(),
        "{}\n{} failures",
        failures.join("\n"),
        failures.len()
    );
}

/// The compensation lobe alone reflects exactly the tabulated deficit:
/// int f_c(wi, wo) mu_o dwo = dE(mu_i) (module docs of `microfacet::compensation::energy`),
/// up to the midpoint rule in mu_o (f_c depends on wo through mu_o only).
#[test]
fn compensation_lobe_carries_the_tabulated_deficit() {
    let nodes = 20_000;
    let mut worst: f64 = 0.0;
    for (kind, shadowing) in kinds() {
        for (alpha, alpha_hat) in [(0.0f32, 0.1f32), (0.05, 0.45), (0.3, 0.9)] {
            let model = MicrofacetModel::new(kind, alpha.max(1e-5), shadowing)
                .regularized(alpha_hat, Vec3::ONE);
            let Some(c) = model.compensation() else {
                continue;
            };
            for mu_i in [0.04f32, 0.3, 0.7, 1.0] {
                let energy: f64 = (0..nodes)
                    .map(|k| {
                        let mu_o = (k as f32 + 0.5) / nodes as f32;
                        f64::from(c.value(&model.ndf, model.shadowing, mu_i, mu_o) * mu_o)
                    })
                    .sum::<f64>()
                    * 2.0
                    * std::f64::consts::PI
                    / f64::from(nodes);
                let deficit = f64::from(c.deficit(&model.ndf, model.shadowing, mu_i));
                worst = worst.max((energy - deficit).abs());
                assert!(
                    (energy - deficit).abs() < 1e-5,
                    "{kind:?}/{shadowing:?} {alpha} -> {alpha_hat} mu {mu_i}: {energy} vs dE {deficit}"
                );
            }
        }
    }
    println!("largest |int f_c mu dwo - dE| {worst:.1e}");
}

/// A white coat over a black base is a white conductor lobe with Schlick's
/// F0 = specular factor 1 ... here the coat of a fully metallic white lobe
/// (F = 1): its compensated albedo is the original's.
#[test]
fn compensated_coat_keeps_the_original_albedo() {
    let mut failures = Vec::new();
    let mut seed = 77_000;
    for alpha in [0.0f32, 0.1] {
        let original = Bsdf::Coated(Coated {
            model: MicrofacetModel::new(NdfKind::Ggx, alpha.max(1e-5), Shadowing::Smith),
            base_color: Vec3::ONE,
            metallic: 1.0,
            specular: 1.0,
            specular_color: Vec3::ONE,
            ior: 1.5,
        });
        for alpha_hat in [0.3f32, 0.7] {
            let regularized = original.regularized(alpha_hat);
            for cos in COSINES {
                seed += 1;
                let wi = direction(cos, 0.2);
                let (e, se) = original_albedo(&original, wi, seed);
                let (e_hat, se_hat) = albedo(&regularized, wi, seed + 1000);
                if (e_hat - e).abs() > TOLERANCE + SIGMAS * (se * se + se_hat * se_hat).sqrt() {
                    failures.push(format!(
                        "coat {alpha} -> {alpha_hat} cos {cos}: {e} +- {se} vs {e_hat} +- {se_hat}"
                    ));
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// The compensated lobes' samplers against their mixture pdf (pbrt-v4's
/// chi-square test, significance 0.01 with a Sidak correction).
#[test]
fn compensated_sampling_matches_its_pdf() {
    let lobes: Vec<(String, Bsdf)> = kinds()
        .into_iter()
        .flat_map(|(kind, shadowing)| {
            let conductor =
                Bsdf::Conductor(white_conductor(MicrofacetModel::new(kind, 0.05, shadowing)))
                    .regularized(0.6);
            let coat = Bsdf::Coated(Coated {
                model: MicrofacetModel::new(kind, 0.05, shadowing),
                base_color: Vec3::new(0.8, 0.5, 0.2),
                metallic: 0.5,
                specular: 1.0,
                specular_color: Vec3::ONE,
                ior: 1.5,
            })
            .regularized(0.6);
            [
                (format!("conductor {kind:?}/{shadowing:?}"), conductor),
                (format!("coated {kind:?}/{shadowing:?}"), coat),
            ]
        })
        .collect();
    let significance = sidak(0.01, lobes.len() * 3);
    let mut failures = Vec::new();
    for (n, (name, bsdf)) in lobes.iter().enumerate() {
        for (k, wi) in incident_directions().into_iter().enumerate() {
            let harness = SphericalChi2::default();
            let outcome = chi2_of_sampling(&harness, bsdf, wi, (n * 10 + k) as u64);
            if !outcome.passes(significance) {
                failures.push(format!("{name} wi {wi}: {outcome:?}"));
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Widths of each model whose widening gains energy somewhere (the scaled
/// lobes of `microfacet::compensation::gain`) and loses it elsewhere (with a compensation
/// lobe too): the largest gains, and a sharp lobe widened a lot.
const GAINING: [(f32, f32); 3] = [(0.01, 0.09), (0.09, 0.35), (0.11, 0.47)];

/// f(wi, wo) = f(wo, wi) for the compensated conductor and coat, a
/// sample's value is `eval` (so its weight f cos / pdf is `eval` cos /
/// `pdf`: the scaling reweights, the densities are unchanged) and its pdfs
/// are `pdf` both ways; for lobes that lose energy (0.02 -> 0.5) and lobes
/// that gain some and are scaled (`GAINING`, each model has one).
#[test]
fn compensated_lobes_are_reciprocal() {
    let mut rng = Pcg32::new(5, 5);
    for (kind, shadowing) in kinds() {
        let mut scaled = 0;
        for (alpha, alpha_hat) in [(0.02, 0.5)].into_iter().chain(GAINING) {
            let model = MicrofacetModel::new(kind, alpha, shadowing);
            scaled += usize::from(
                model
                    .regularized(alpha_hat, Vec3::ONE)
                    .compensation()
                    .is_some_and(|c| c.scaled),
            );
            let lobes = [
                Bsdf::Conductor(white_conductor(model)).regularized(alpha_hat),
                Bsdf::Coated(Coated {
                    model,
                    base_color: Vec3::new(0.9, 0.4, 0.1),
                    metallic: 0.3,
                    specular: 1.0,
                    specular_color: Vec3::ONE,
                    ior: 1.5,
                })
                .regularized(alpha_hat),
            ];
            for bsdf in lobes {
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    for _ in 0..200 {
                        let wi = direction(
                            rng.range_f64(0.02, 1.0) as f32,
                            rng.uniform_f32() * std::f32::consts::TAU,
                        );
                        let Some(s) = bsdf.sample(wi, rng.uniform_f32(), rng.uniform_vec2(), mode)
                        else {
                            continue;
                        };
                        let (a, b) = (bsdf.eval(wi, s.wo, mode), bsdf.eval(s.wo, wi, mode));
                        let case =
                            format!("{kind:?}/{shadowing:?} {alpha} -> {alpha_hat} {mode:?}");
                        assert!(
                            (a - b).abs().max_element() <= 1e-4 * a.max_element().max(1.0),
                            "{case}: f(wi,wo) {a} != f(wo,wi) {b}"
                        );
                        assert!(
                            (s.f - a).abs().max_element() <= 1e-5 * a.max_element(),
                            "{case}: sampled value {} vs eval {a}",
                            s.f
                        );
                        let pdf = bsdf.pdf(wi, s.wo);
                        assert!(
                            (s.pdf - pdf).abs() <= 1e-3 * pdf,
                            "{case}: pdf {} vs {pdf}",
                            s.pdf
                        );
                        let reverse = bsdf.pdf(s.wo, wi);
                        assert!(
                            (s.pdf_reverse - reverse).abs() <= 1e-3 * reverse,
                            "{case} {bsdf:?} wi {wi} wo {}: reverse {} vs {reverse}",
                            s.wo,
                            s.pdf_reverse
                        );
                        // Both samplers share one albedo lookup per
                        // direction among these: value and pdf are the
                        // queries' own, bit for bit, and so is the
                        // conductor's reverse pdf (the coated lobe's comes
                        // from the forward pair's half vector, within
                        // rounding of the reverse query's, checked above).
                        assert_eq!((s.f, s.pdf), (a, pdf), "{case}: sample vs eval and pdf");
                        if let Bsdf::Conductor(_) = bsdf {
                            assert_eq!(s.pdf_reverse, reverse, "{case}: reverse pdf");
                        }
                    }
                }
            }
        }
        assert!(scaled > 0, "{kind:?}/{shadowing:?}: no scaled lobe tested");
    }
}

/// Where the widened lobe gains nothing (at any table node) it is not
/// scaled: s(mu_i) s(mu_o) is exactly 1, and the regularized conductor's
/// value is bit for bit the widened lobe's plus the compensation lobe's,
/// as before the scaling existed. Both kinds of pairs occur for every
/// model (the test is not vacuous).
#[test]
fn lobes_without_gain_are_unscaled() {
    let widths = [0.0f32, 0.005, 0.02, 0.05, 0.1, 0.2, 0.3, 0.5, 0.7, 1.0];
    let mut rng = Pcg32::new(9, 3);
    for (kind, shadowing) in kinds() {
        let table = albedo_table(kind, shadowing);
        let (mut unscaled, mut scaled) = (0, 0);
        for (n, &alpha) in widths.iter().enumerate() {
            for &alpha_hat in &widths[n + 1..] {
                let model = MicrofacetModel::new(kind, alpha.max(1e-5), shadowing);
                let regularized = model.regularized(alpha_hat, Vec3::ONE);
                if regularized.compensation().is_some_and(|c| c.scaled) {
                    scaled += 1;
                    continue;
                }
                unscaled += 1;
                // No gain beyond the tables' accuracy (`gain::MIN_GAIN`,
                // 1e-4) at the tables' 64 cosines, where `Compensation::new`
                // looks.
                for k in 0..64 {
                    let mu = (k as f32 / 63.0).powi(2).max(1e-3);
                    let gain = table.albedo(mu, alpha_hat) - table.albedo(mu, alpha.max(1e-5));
                    assert!(
                        gain <= 1e-4,
                        "{kind:?}/{shadowing:?} {alpha} -> {alpha_hat} mu {mu}: {gain}"
                    );
                }
                let conductor = white_conductor(regularized);
                let plain = white_conductor(model.with_alpha(alpha_hat));
                for _ in 0..100 {
                    let wi = direction(rng.uniform_f32(), rng.uniform_f32() * 6.0);
                    let wo = direction(rng.uniform_f32(), rng.uniform_f32() * 6.0);
                    assert_eq!(regularized.lobe_scale(wi.z, wo.z), 1.0);
                    let expected = plain.eval(wi, wo) + regularized.compensation_value(wi, wo);
                    assert_eq!(conductor.eval(wi, wo), expected, "{kind:?}/{shadowing:?}");
                }
            }
        }
        println!("{kind:?}/{shadowing:?}: {unscaled} pairs unscaled, {scaled} scaled");
        assert!(unscaled > 0 && scaled > 0, "{kind:?}/{shadowing:?}");
    }
}

/// The scaling vanishes as alpha-hat -> alpha (consistency): for pairs that
/// gain, s stays within 2e-3 of 1 when alpha-hat is alpha + 1e-3.
#[test]
fn scaling_vanishes_as_alpha_hat_reaches_alpha() {
    for (kind, shadowing) in kinds() {
        for (alpha, alpha_hat) in GAINING {
            let far =
                MicrofacetModel::new(kind, alpha, shadowing).regularized(alpha_hat, Vec3::ONE);
            let near =
                MicrofacetModel::new(kind, alpha, shadowing).regularized(alpha + 1e-3, Vec3::ONE);
            for mu in [0.02f32, 0.1, 0.3, 0.6, 1.0] {
                let s = |m: &MicrofacetModel| {
                    m.compensation()
                        .map_or(1.0, |c| c.scale(&m.ndf, m.shadowing, mu))
                };
                let (s_far, s_near) = (s(&far), s(&near));
                assert!(
                    (s_near - 1.0).abs() < 2e-3
                        && (s_near - 1.0).abs() <= (s_far - 1.0).abs() + 1e-4,
                    "{kind:?}/{shadowing:?} {alpha} mu {mu}: s {s_near} at +1e-3, {s_far} at {alpha_hat}"
                );
            }
        }
    }
}

/// The compensation vanishes as alpha-hat -> alpha (consistency) and is
/// absent without regularization.
#[test]
fn compensation_vanishes_as_alpha_hat_reaches_alpha() {
    let model = MicrofacetModel::new(NdfKind::Ggx, 0.3, Shadowing::Smith);
    assert_eq!(model.regularized(0.3, Vec3::ONE).compensation(), None);
    assert_eq!(model.regularized(0.2, Vec3::ONE).compensation(), None);
    let near = model.regularized(0.3001, Vec3::ONE).compensation();
    assert!(near.is_none_or(|c| c.deficit_average < 1e-3), "{near:?}");
    let far = model.regularized(0.9, Vec3::ONE).compensation().unwrap();
    assert!(far.deficit_average > 0.05, "{far:?}");
}
