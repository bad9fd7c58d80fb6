//! p-hat = (rho-hat / rho) p (paper eq. 13), checked numerically against the
//! ratio definition for V-cavity and Smith and every NDF, on random
//! reflection and refraction configurations (supp. §4, SPEC §6).

use glam::Vec3;
use microfacet::{
    Bsdf, Coated, Conductor, Dielectric, Fresnel, MicrofacetModel, NdfKind, Shadowing,
    TransportMode,
};
use regularization::{p_hat, p_hat_of_sample};
use stats::Pcg32;

const REL: f32 = 1e-4;

fn random_direction(rng: &mut Pcg32) -> Vec3 {
    let z = 2.0 * rng.uniform_f32() - 1.0;
    let phi = std::f32::consts::TAU * rng.uniform_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// The lobes compared; the coated one has a black base, so that it is its
/// coat alone, where the mixture rule of `p_hat` is paper eq. 13.
fn lobes(model: MicrofacetModel) -> [Bsdf; 4] {
    [
        Bsdf::Coated(Coated {
            model,
            base_color: Vec3::ZERO,
            metallic: 0.0,
            specular: 0.8,
            specular_color: Vec3::new(1.0, 0.8, 0.6),
            ior: 1.7,
        }),
        Bsdf::Conductor(Conductor {
            model,
            fresnel: Fresnel::Schlick {
                f0: Vec3::new(0.9, 0.6, 0.3),
            },
        }),
        Bsdf::Dielectric(Dielectric::new(model, 1.5)),
        Bsdf::Dielectric(Dielectric::new(model, 1.0 / 1.33)),
    ]
}

/// (ratio definition, closed form, p(wo | alpha-hat) alone) for random
/// configurations where rho > 0 and p > 0.
fn compare(kind: NdfKind, shadowing: Shadowing, seed: u64) -> Vec<(f32, f32, f32)> {
    let mut rng = Pcg32::new(seed, 0);
    let mut out = Vec::new();
    for _ in 0..400 {
        let alpha = rng.log_uniform(1e-3, 0.6) as f32;
        let alpha_hat = alpha * (1.0 + rng.log_uniform(1e-3, 20.0) as f32);
        for bsdf in lobes(MicrofacetModel::new(kind, alpha, shadowing)) {
            let hat = bsdf.with_alpha(alpha_hat);
            let wi = random_direction(&mut rng);
            // Directions from the regularized lobe: where p-hat matters.
            let Some(s) = hat.sample(
                wi,
                rng.uniform_f32(),
                rng.uniform_vec2(),
                TransportMode::Radiance,
            ) else {
                continue;
            };
            let (rho, rho_hat) = (
                bsdf.eval(wi, s.wo, TransportMode::Radiance).x,
                hat.eval(wi, s.wo, TransportMode::Radiance).x,
            );
            let p = bsdf.pdf(wi, s.wo);
            if !(rho > 1e-20 && p > 1e-20 && rho_hat > 0.0) {
                continue;
            }
            let ratio_definition = f64::from(rho_hat) / f64::from(rho) * f64::from(p);
            out.push((
                ratio_definition as f32,
                p_hat(&bsdf, &hat, wi, s.wo),
                hat.pdf(wi, s.wo),
            ));
        }
    }
    out
}

#[test]
fn closed_form_matches_the_ratio_definition() {
    for kind in [NdfKind::Ggx, NdfKind::Beckmann, NdfKind::BlinnPhong] {
        for (k, shadowing) in [Shadowing::Smith, Shadowing::VCavity]
            .into_iter()
            .enumerate()
        {
            let cases = compare(kind, shadowing, 50 + k as u64);
            assert!(
                cases.len() > 500,
                "{kind:?} {shadowing:?}: only {} configurations",
                cases.len()
            );
            for (definition, closed, _) in cases {
                let rel = (closed / definition - 1.0).abs();
                assert!(
                    rel < REL,
                    "{kind:?} {shadowing:?}: definition {definition}, closed form {closed}"
                );
            }
        }
    }
}

/// Negative control: with Smith shadowing, p(wo | alpha-hat) alone is not
/// p-hat; the G1 ratio of supp. §4 is what makes the test above pass.
#[test]
fn smith_needs_the_g1_ratio() {
    let worst = compare(NdfKind::Ggx, Shadowing::Smith, 60)
        .into_iter()
        .map(|(definition, _, plain)| (plain / definition - 1.0).abs())
        .fold(0.0f32, f32::max);
    assert!(
        worst > 100.0 * REL,
        "p(wo | alpha-hat) matches p-hat to {worst}"
    );
}

/// A compensated lobe's sample carries its densities in parts, and
/// `p_hat_of_sample` rescales only the microfacet lobe's part: the pair it
/// returns is `p_hat` of (wi, wo) and of (wo, wi), bit for bit, in both
/// transport modes (other samples take `p_hat` itself). Conductors with
/// both shadowing models; a dielectric with Smith (with V-cavity its
/// p-hat is the regularized lobe's pdf whatever the path), whose table is
/// the cheaper one to build.
#[test]
fn sampled_p_hat_is_p_hat() {
    let mut rng = Pcg32::new(70, 0);
    let mut compensated = 0;
    for (kind, shadowing) in [
        (NdfKind::Ggx, Shadowing::Smith),
        (NdfKind::Beckmann, Shadowing::VCavity),
    ] {
        for _ in 0..100 {
            let alpha = rng.log_uniform(1e-2, 0.3) as f32;
            let alpha_hat = (alpha * (1.0 + rng.log_uniform(0.1, 10.0) as f32)).min(1.0);
            let model = MicrofacetModel::new(kind, alpha, shadowing);
            let conductor = lobes(model)[1];
            let dielectric = Bsdf::Dielectric(Dielectric::new(model, 1.5));
            let bsdfs = if shadowing == Shadowing::Smith {
                vec![conductor, dielectric]
            } else {
                vec![conductor]
            };
            for bsdf in bsdfs {
                let regularized = bsdf.regularized(alpha_hat);
                let wi = random_direction(&mut rng);
                for mode in [TransportMode::Radiance, TransportMode::Importance] {
                    let Some(s) =
                        regularized.sample(wi, rng.uniform_f32(), rng.uniform_vec2(), mode)
                    else {
                        continue;
                    };
                    compensated += usize::from(s.compensated.is_some());
                    let (forward, reverse) = p_hat_of_sample(&bsdf, &regularized, wi, &s);
                    let expected = (
                        p_hat(&bsdf, &regularized, wi, s.wo),
                        p_hat(&bsdf, &regularized, s.wo, wi),
                    );
                    assert_eq!(
                        (forward.to_bits(), reverse.to_bits()),
                        (expected.0.to_bits(), expected.1.to_bits()),
                        "{bsdf:?} -> {alpha_hat}, {wi} -> {}: {forward}, {reverse} vs {expected:?}",
                        s.wo
                    );
                }
            }
        }
    }
    assert!(compensated > 300, "only {compensated} compensated samples");
}
