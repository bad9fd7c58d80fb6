//! The MIS pdf of a regularized vertex (paper eq. 13, supp. §4, SPEC §6).
//!
//! A technique that evaluates the regularized BSDF rho-hat at a vertex uses,
//! for MIS, p-hat = (rho-hat / rho) p, with p the pdf under the original
//! alpha. Then f-hat / p-hat = f / p for every technique, so the balance
//! heuristic compares like with like.

use glam::Vec3;
use microfacet::{Bsdf, Shadowing};

/// p-hat for sampling `wo` from `wi` at a vertex whose BSDF `bsdf` (original
/// alpha) is regularized to `alpha_hat`, in closed form (supp. §4, SPEC §6):
/// - V-cavity: G does not depend on alpha, so p-hat = p(wo | alpha-hat);
/// - Smith, visible-normal sampling: p-hat = G1_hat(wo)/G1(wo) p(wo | alpha-hat);
/// - Smith Blinn-Phong (sampled from D cos, no G1 in the pdf):
///   p-hat = G_hat(wi, wo)/G(wi, wo) p(wo | alpha-hat);
/// - Lambertian: p.
///
/// 0 where the unregularized BSDF is 0 through its shadowing (G = 0), where
/// the ratio is undefined and the path carries nothing.
pub fn p_hat(bsdf: &Bsdf, alpha_hat: f32, wi: Vec3, wo: Vec3) -> f32 {
    let p = bsdf.with_alpha(alpha_hat).pdf(wi, wo);
    let model = match bsdf {
        Bsdf::Lambertian(_) => return p,
        Bsdf::Conductor(c) => c.model,
        Bsdf::Dielectric(d) => d.model,
    };
    let hat = model.with_alpha(alpha_hat);
    let ratio = match model.shadowing {
        Shadowing::VCavity => 1.0,
        Shadowing::Smith if model.samples_visible_normals() => hat.ndf.g1(wo) / model.ndf.g1(wo),
        Shadowing::Smith => {
            (hat.ndf.g1(wi) * hat.ndf.g1(wo)) / (model.ndf.g1(wi) * model.ndf.g1(wo))
        }
    };
    if ratio.is_finite() { p * ratio } else { 0.0 }
}
