//! Shared fixtures of the microfacet integration tests: every NDF x shadowing
//! combination, the alphas and incident directions the issue asks for, and
//! lossless lobes for energy tests.

use glam::{Vec2, Vec3};
use microfacet::{
    Bsdf, Conductor, Dielectric, Fresnel, MicrofacetModel, NdfKind, Shadowing, TransportMode,
};
use stats::{Chi2Outcome, Pcg32, SphericalChi2, Summary};

/// Every NDF.
pub const NDFS: [NdfKind; 3] = [NdfKind::Ggx, NdfKind::Beckmann, NdfKind::BlinnPhong];

/// Every shadowing model.
pub const SHADOWINGS: [Shadowing; 2] = [Shadowing::Smith, Shadowing::VCavity];

/// The roughnesses of the statistical tests.
pub const ALPHAS: [f32; 4] = [0.05, 0.2, 0.6, 1.0];

/// The relative indices of the transmission tests: into glass and out of it.
pub const ETAS: [f32; 2] = [1.5, 1.0 / 1.5];

/// All (NDF, shadowing, alpha) models of the statistical tests.
pub fn models() -> Vec<MicrofacetModel> {
    let mut out = Vec::new();
    for kind in NDFS {
        for shadowing in SHADOWINGS {
            for alpha in ALPHAS {
                out.push(MicrofacetModel::new(kind, alpha, shadowing));
            }
        }
    }
    out
}

/// Unit direction with cos(theta) = `cos_theta` at azimuth `phi`.
pub fn direction(cos_theta: f32, phi: f32) -> Vec3 {
    let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    Vec3::new(sin_theta * phi.cos(), sin_theta * phi.sin(), cos_theta)
}

/// Incident directions of the chi-square tests: near normal, oblique, grazing,
/// at an azimuth that aligns with no grid axis.
pub fn incident_directions() -> [Vec3; 3] {
    [
        direction(0.95, 0.7),
        direction(0.55, 2.1),
        direction(0.15, 4.0),
    ]
}

/// A conductor that reflects everything (F = 1): the lossless case.
pub fn white_conductor(model: MicrofacetModel) -> Conductor {
    Conductor {
        model,
        fresnel: Fresnel::Schlick { f0: Vec3::ONE },
    }
}

/// A dielectric with relative index `eta`.
pub fn dielectric(model: MicrofacetModel, eta: f32) -> Dielectric {
    Dielectric::new(model, eta)
}

/// Short label for failure messages.
pub fn label(model: &MicrofacetModel) -> String {
    format!(
        "{:?}/{:?}/alpha={}",
        model.ndf.kind(),
        model.shadowing,
        model.alpha()
    )
}

/// (mean, standard error) of the directional albedo (red channel) of `bsdf`
/// queried from `wi` in `mode`, estimated with its own sampler, value and
/// pdf: `replicas` independent jittered `grid` x `grid` estimates (random
/// stream `stream` of `seed`), whose spread gives the standard error.
pub fn stratified_albedo(
    bsdf: &Bsdf,
    wi: Vec3,
    mode: TransportMode,
    (grid, replicas): (usize, usize),
    (seed, stream): (u64, u64),
) -> (f64, f64) {
    let mut rng = Pcg32::new(seed, stream);
    let mut estimates = Summary::new();
    for _ in 0..replicas {
        let mut sum = 0.0;
        for i in 0..grid {
            for j in 0..grid {
                let u = Vec2::new(
                    ((i as f32 + rng.uniform_f32()) / grid as f32).min(0.999_999_9),
                    ((j as f32 + rng.uniform_f32()) / grid as f32).min(0.999_999_9),
                );
                let uc = rng.uniform_f32();
                sum += bsdf.sample(wi, uc, u, mode).map_or(0.0, |s| {
                    let pdf = bsdf.pdf(wi, s.wo);
                    if pdf > 0.0 {
                        f64::from(bsdf.eval(wi, s.wo, mode).x * s.wo.z.abs() / pdf)
                    } else {
                        0.0
                    }
                });
            }
        }
        estimates.push(sum / (grid * grid) as f64);
    }
    (estimates.mean(), estimates.standard_error())
}

/// The chi-square harness with a quadrature fine enough for lobes of width
/// `alpha`.
///
/// The adaptive rule must start with a spacing below the narrowest feature
/// of the pdf, or it can miss a lobe inside a cell. A lobe refracted into
/// glass is about alpha/3 radians wide; a cell side is pi/20 radians.
pub fn chi2_harness(alpha: f32) -> SphericalChi2 {
    let mut test = SphericalChi2::default();
    let cell = std::f64::consts::PI / test.theta_res as f64;
    let lobe = f64::from(alpha) / 3.0;
    test.integration_depth.min = (cell / lobe).log2().ceil().max(1.0) as u32;
    test
}

/// `harness` run on `bsdf`'s Radiance-mode sampling from `wi` against its
/// pdf, with random stream `seed`.
pub fn chi2_of_sampling(harness: &SphericalChi2, bsdf: &Bsdf, wi: Vec3, seed: u64) -> Chi2Outcome {
    let mode = TransportMode::Radiance;
    harness.run(
        &mut Pcg32::new(seed, 0x5eed),
        |rng| {
            let uc = rng.uniform_f32();
            let u = rng.uniform_vec2();
            bsdf.sample(wi, uc, u, mode).map(|s| s.wo)
        },
        |wo| f64::from(bsdf.pdf(wi, wo)),
    )
}
