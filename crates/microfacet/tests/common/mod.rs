//! Shared fixtures of the microfacet integration tests: every NDF x shadowing
//! combination, the alphas and incident directions the issue asks for, and
//! lossless lobes for energy tests.
#![allow(dead_code)]

use glam::Vec3;
use microfacet::{Conductor, Dielectric, Fresnel, MicrofacetModel, NdfKind, Shadowing};

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
