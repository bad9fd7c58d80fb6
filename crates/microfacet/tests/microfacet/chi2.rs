//! Chi-square goodness of fit of every sampler against its pdf,
//! after pbrt-v4's `bsdfs_test.cpp`: a (theta, phi) histogram over the
//! sphere, the pdf integrated per cell, low-count cells pooled, significance
//! 0.01 with a Sidak correction over all tests of this file.

use crate::common;

use common::*;
use glam::Vec3;
use microfacet::{Bsdf, Lambertian, MicrofacetModel, TransportMode};
use stats::Pcg32;
use stats::chi2::sidak;

/// Number of chi-square tests in this file (for the Sidak correction):
/// microfacet normals, conductor, dielectric at two etas, for every model and
/// incident direction, plus the Lambertian lobe.
fn family_size() -> usize {
    let per_model = 3 * (1 + 1 + ETAS.len());
    models().len() * per_model + 3
}

fn significance() -> f64 {
    sidak(0.01, family_size())
}

/// Runs one test and returns a failure description, if any.
fn check(
    name: &str,
    alpha: f32,
    seed: u64,
    sample: impl FnMut(&mut Pcg32) -> Option<Vec3>,
    pdf: impl Fn(Vec3) -> f64,
) -> Option<String> {
    let outcome = chi2_harness(alpha).run(&mut Pcg32::new(seed, 0x5eed), sample, pdf);
    (!outcome.passes(significance())).then(|| format!("{name}: {outcome:?}"))
}

fn bsdf_sampler(
    bsdf: Bsdf,
    wi: Vec3,
    mode: TransportMode,
) -> impl FnMut(&mut Pcg32) -> Option<Vec3> {
    move |rng: &mut Pcg32| {
        let uc = rng.uniform_f32();
        let u = rng.uniform_vec2();
        bsdf.sample(wi, uc, u, mode).map(|s| s.wo)
    }
}

fn assert_all_pass(failures: Vec<String>) {
    assert!(
        failures.is_empty(),
        "{} failure(s):\n{}",
        failures.len(),
        failures.join("\n")
    );
}

/// Tests the microfacet-normal samplers of every model with the given NDF.
fn normal_samplers(filter: impl Fn(&MicrofacetModel) -> bool) -> Vec<String> {
    let mut failures = Vec::new();
    for (m, model) in models().into_iter().enumerate().filter(|(_, m)| filter(m)) {
        for (k, wi) in incident_directions().into_iter().enumerate() {
            let name = format!("sample_h {} wi={wi}", label(&model));
            let sample = move |rng: &mut Pcg32| {
                let u = rng.uniform_vec2();
                model.sample_h(wi, u, rng.uniform_f32()).map(|s| s.h)
            };
            failures.extend(check(
                &name,
                model.alpha(),
                (m * 10 + k) as u64,
                sample,
                |h| f64::from(model.pdf_h(wi, h)),
            ));
        }
    }
    failures
}

fn conductors(filter: impl Fn(&MicrofacetModel) -> bool) -> Vec<String> {
    let mut failures = Vec::new();
    for (m, model) in models().into_iter().enumerate().filter(|(_, m)| filter(m)) {
        let bsdf = Bsdf::Conductor(white_conductor(model));
        for (k, wi) in incident_directions().into_iter().enumerate() {
            let name = format!("conductor {} wi={wi}", label(&model));
            let sampler = bsdf_sampler(bsdf, wi, TransportMode::Radiance);
            failures.extend(check(
                &name,
                model.alpha(),
                1000 + (m * 10 + k) as u64,
                sampler,
                |wo| f64::from(bsdf.pdf(wi, wo)),
            ));
        }
    }
    failures
}

fn dielectrics(filter: impl Fn(&MicrofacetModel) -> bool) -> Vec<String> {
    let mut failures = Vec::new();
    for (m, model) in models().into_iter().enumerate().filter(|(_, m)| filter(m)) {
        for (e, eta) in ETAS.into_iter().enumerate() {
            let bsdf = Bsdf::Dielectric(dielectric(model, eta));
            for (k, wi) in incident_directions().into_iter().enumerate() {
                let name = format!("dielectric eta={eta} {} wi={wi}", label(&model));
                let sampler = bsdf_sampler(bsdf, wi, TransportMode::Radiance);
                let seed = 2000 + (m * 100 + e * 10 + k) as u64;
                failures.extend(check(&name, model.alpha(), seed, sampler, |wo| {
                    f64::from(bsdf.pdf(wi, wo))
                }));
            }
        }
    }
    failures
}

#[test]
fn microfacet_normal_samplers_ggx() {
    assert_all_pass(normal_samplers(|m| {
        m.ndf.kind() == microfacet::NdfKind::Ggx
    }));
}

#[test]
fn microfacet_normal_samplers_beckmann() {
    assert_all_pass(normal_samplers(|m| {
        m.ndf.kind() == microfacet::NdfKind::Beckmann
    }));
}

#[test]
fn microfacet_normal_samplers_blinn_phong() {
    assert_all_pass(normal_samplers(|m| {
        m.ndf.kind() == microfacet::NdfKind::BlinnPhong
    }));
}

#[test]
fn conductor_smith() {
    assert_all_pass(conductors(|m| m.shadowing == microfacet::Shadowing::Smith));
}

#[test]
fn conductor_vcavity() {
    assert_all_pass(conductors(|m| {
        m.shadowing == microfacet::Shadowing::VCavity
    }));
}

#[test]
fn dielectric_ggx() {
    assert_all_pass(dielectrics(|m| m.ndf.kind() == microfacet::NdfKind::Ggx));
}

#[test]
fn dielectric_beckmann() {
    assert_all_pass(dielectrics(|m| {
        m.ndf.kind() == microfacet::NdfKind::Beckmann
    }));
}

#[test]
fn dielectric_blinn_phong() {
    assert_all_pass(dielectrics(|m| {
        m.ndf.kind() == microfacet::NdfKind::BlinnPhong
    }));
}

#[test]
fn lambertian() {
    let bsdf = Bsdf::Lambertian(Lambertian {
        reflectance: Vec3::splat(0.5),
    });
    let mut failures = Vec::new();
    for (k, wi) in incident_directions().into_iter().enumerate() {
        // One query from below: the lobe is two-sided.
        let wi = if k == 1 { -wi } else { wi };
        let sampler = bsdf_sampler(bsdf, wi, TransportMode::Radiance);
        failures.extend(check(
            &format!("lambertian wi={wi}"),
            1.0,
            9000 + k as u64,
            sampler,
            |wo| f64::from(bsdf.pdf(wi, wo)),
        ));
    }
    assert_all_pass(failures);
}

/// Negative control: the same harness rejects every lobe kind when its pdf is
/// off by 10 %, so the passing tests above are evidence, not formality.
#[test]
fn detects_a_pdf_off_by_ten_percent() {
    let model = MicrofacetModel::new(microfacet::NdfKind::Ggx, 0.2, microfacet::Shadowing::Smith);
    let wi = incident_directions()[1];
    let bsdfs = [
        Bsdf::Conductor(white_conductor(model)),
        Bsdf::Dielectric(dielectric(model, 1.5)),
        Bsdf::Lambertian(Lambertian {
            reflectance: Vec3::ONE,
        }),
    ];
    for (scale, name) in [(1.1, "10 % too high"), (0.9, "10 % too low")] {
        for bsdf in bsdfs {
            let sampler = bsdf_sampler(bsdf, wi, TransportMode::Radiance);
            let failure = check(name, 0.2, 77, sampler, |wo| {
                scale * f64::from(bsdf.pdf(wi, wo))
            });
            assert!(
                failure.is_some(),
                "{name}: {bsdf:?} passed with a wrong pdf"
            );
        }
        let sample =
            move |rng: &mut Pcg32| model.sample_h(wi, rng.uniform_vec2(), 0.5).map(|s| s.h);
        assert!(
            check(name, 0.2, 78, sample, |h| scale
                * f64::from(model.pdf_h(wi, h)))
            .is_some()
        );
    }
    // A 10 % error on part of the domain only (transmitted directions) too.
    let bsdf = Bsdf::Dielectric(dielectric(model, 1.5));
    let sampler = bsdf_sampler(bsdf, wi, TransportMode::Radiance);
    let partial = |wo: Vec3| f64::from(bsdf.pdf(wi, wo)) * if wo.z < 0.0 { 1.1 } else { 1.0 };
    assert!(check("transmission 10 % off", 0.2, 79, sampler, partial).is_some());
}
