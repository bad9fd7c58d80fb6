//! The MIS pdf of a regularized vertex (paper eq. 13, supp. §4, SPEC §6).
//!
//! A technique that evaluates the regularized BSDF rho-hat at a vertex uses,
//! for MIS, p-hat = (rho-hat / rho) p, with p the pdf under the original
//! alpha. Then f-hat / p-hat = f / p for every technique, so the balance
//! heuristic compares like with like.

use glam::Vec3;
use microfacet::sample::BsdfSample;
use microfacet::{Bsdf, MicrofacetModel, Shadowing};

/// p-hat for sampling `wo` from `wi` at a vertex whose BSDF `bsdf` (original
/// alpha) is regularized to `regularized` (alpha-hat, with or without
/// energy compensation), in closed form (supp. §4, SPEC §6):
/// - V-cavity: G does not depend on alpha, so p-hat = p(wo | alpha-hat);
/// - Smith, visible-normal sampling: p-hat = G1_hat(wo)/G1(wo) p(wo | alpha-hat);
/// - Smith Blinn-Phong (sampled from D cos, no G1 in the pdf):
///   p-hat = G_hat(wi, wo)/G(wi, wo) p(wo | alpha-hat);
/// - Lambertian: p.
/// - Coated (a mixture P_s p_spec + (1 - P_s) p_diffuse): each component
///   with its own rule, P_s p-hat_spec + (1 - P_s) p_diffuse. Paper eq. 13
///   applied to the whole mixture has no closed form (the ratio rho-hat/rho
///   mixes both lobes' values); SPEC §6 only needs every technique to use
///   the same pdf at the vertex, and this one reduces to eq. 13 where one
///   lobe is absent (black or metallic base: the coat alone).
/// - Energy compensation (`microfacet::compensation::energy`): the compensation lobe has
///   no counterpart in the original BSDF (eq. 13's ratio is undefined
///   where rho = 0), so the microfacet lobe's p-hat enters the regularized
///   lobe's own mixture in its place: (1 - P_c) p-hat + P_c mu_o/pi, by the
///   same SPEC §6 argument as the coated mixture. The same for a compensated
///   dielectric (`microfacet::compensation::dielectric_energy`), whose compensation lobe
///   reflects and transmits: (1 - P_c) p-hat + P_c p_c(wi, wo).
///
/// 0 where the unregularized BSDF is 0 through its shadowing (G = 0), where
/// the ratio is undefined and the path carries nothing.
pub fn p_hat(bsdf: &Bsdf, regularized: &Bsdf, wi: Vec3, wo: Vec3) -> f32 {
    let alpha_hat = regularized.alpha().unwrap_or(1.0);
    let hat = bsdf.with_alpha(alpha_hat);
    match (bsdf, regularized) {
        (Bsdf::Conductor(c), Bsdf::Conductor(c_reg)) => {
            let p = hat.pdf(wi, wo) * shadowing_ratio(&c.model, alpha_hat, wi, wo);
            c_reg.model.with_compensation_pdf(wi, wo, p)
        }
        (Bsdf::Dielectric(d), Bsdf::Dielectric(d_reg)) => {
            let p = hat.pdf(wi, wo) * shadowing_ratio(&d.model, alpha_hat, wi, wo);
            d_reg.with_compensation_pdf(wi, wo, p)
        }
        (Bsdf::Coated(c), Bsdf::Coated(c_reg)) => {
            let Bsdf::Coated(c_hat) = hat else {
                unreachable!("with_alpha keeps the lobe kind")
            };
            let specular =
                c_hat.specular_pdf(wi, wo) * shadowing_ratio(&c.model, alpha_hat, wi, wo);
            let specular = c_reg.model.with_compensation_pdf(wi, wo, specular);
            c.specular_probability(wi.z.abs()) * specular + c_hat.diffuse_pdf(wi, wo)
        }
        // Lambertian, and (never produced by regularization) a lobe kind
        // changed by `regularized`: the plain density.
        _ => regularized.pdf(wi, wo),
    }
}

/// [`p_hat`] of a direction sampled from the regularized BSDF, and of its
/// reverse: (p-hat(wi -> s.wo), p-hat(s.wo -> wi)). A compensated conductor
/// or dielectric sample carries its densities in parts
/// (`BsdfSample::compensated`: P_c and the compensation lobe's density at
/// either end, the microfacet lobe's at alpha-hat), so that only the lobe's
/// part is rescaled here, with the same values `p_hat` computes and without
/// a second albedo lookup or lobe evaluation; other samples go through
/// `p_hat`.
pub fn p_hat_of_sample(bsdf: &Bsdf, regularized: &Bsdf, wi: Vec3, s: &BsdfSample) -> (f32, f32) {
    let model = match bsdf {
        Bsdf::Conductor(c) => Some(&c.model),
        Bsdf::Dielectric(d) => Some(&d.model),
        _ => None,
    };
    match (model, regularized.alpha(), s.compensated) {
        (Some(model), Some(alpha_hat), Some([forward, reverse])) => (
            forward.with_lobe(forward.p_lobe * shadowing_ratio(model, alpha_hat, wi, s.wo)),
            reverse.with_lobe(reverse.p_lobe * shadowing_ratio(model, alpha_hat, s.wo, wi)),
        ),
        _ => (
            p_hat(bsdf, regularized, wi, s.wo),
            p_hat(bsdf, regularized, s.wo, wi),
        ),
    }
}

/// The factor p-hat / p(wo | alpha-hat) of a microfacet model (see
/// [`p_hat`]); 0 where it is undefined (G = 0 at the original alpha).
pub(crate) fn shadowing_ratio(model: &MicrofacetModel, alpha_hat: f32, wi: Vec3, wo: Vec3) -> f32 {
    let hat = model.with_alpha(alpha_hat);
    let ratio = match model.shadowing {
        Shadowing::VCavity => 1.0,
        Shadowing::Smith if model.samples_visible_normals() => hat.ndf.g1(wo) / model.ndf.g1(wo),
        Shadowing::Smith => {
            (hat.ndf.g1(wi) * hat.ndf.g1(wo)) / (model.ndf.g1(wi) * model.ndf.g1(wo))
        }
    };
    if ratio.is_finite() { ratio } else { 0.0 }
}
