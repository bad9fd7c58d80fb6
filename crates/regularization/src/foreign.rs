//! Regularization of another renderer's microfacet lobes (SPEC §5-§6).
//!
//! [`regularize`](crate::regularize) and [`p_hat`](crate::p_hat) take this
//! workspace's closed [`Bsdf`](microfacet::Bsdf) enum. A renderer with lobes of
//! its own describes each one by the few numbers regularization reads
//! ([`MicrofacetLobe`]: NDF, shadowing, alpha, index ratio) and gets a
//! [`RegularizedLobe`]: the roughness alpha-hat to evaluate and sample its own
//! lobe with, the energy compensation that keeps the original lobe's albedo,
//! and the MIS pdf p-hat (paper eq. 13). Its Fresnel term, colour and
//! sampling code stay its own.

use glam::Vec3;
use microfacet::{Dielectric, MicrofacetModel, NdfKind, Shadowing, TransportMode};

use crate::pdf::shadowing_ratio;
use crate::tau::{AlphaHat, Energy, Lobe, alpha_hat};

/// What regularization needs to know of a microfacet lobe.
///
/// The lobe is assumed to sample as this crate's models do (`p_hat` depends on
/// it): visible normals for GGX and Beckmann (Heitz 2018) and for V-cavity
/// shadowing, D(h)<h,n> for Smith Blinn-Phong (SPEC §1).
pub trait MicrofacetLobe {
    /// The normal distribution's family.
    fn ndf(&self) -> NdfKind;

    /// The masking-shadowing model.
    fn shadowing(&self) -> Shadowing;

    /// The microfacet width alpha (not a perceptual roughness: glTF's
    /// roughness r gives alpha = r^2).
    fn alpha(&self) -> f32;

    /// For an interface that reflects and refracts: eta = eta_below /
    /// eta_above (1.5 for glass in air seen from the air side). `None` (the
    /// default) for a reflection lobe (conductors, coats).
    fn eta(&self) -> Option<f32> {
        None
    }
}

/// A foreign lobe regularized under a bound tau: alpha-hat, the energy
/// compensation of the widened lobe, and p-hat.
///
/// Regularized value of the lobe, with `f_hat` the foreign lobe's own value
/// at alpha-hat and `(scale, value)` = [`compensation_terms`](Self::compensation_terms):
/// `scale * f_hat + value * F_avg` for a reflection lobe (F_avg its Fresnel
/// term's cosine-weighted average, Kulla & Conty 2017), `scale * f_hat +
/// value` for an interface.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RegularizedLobe {
    /// The roughness to evaluate and sample the lobe with, and whether it
    /// meets tau.
    pub alpha_hat: AlphaHat,
    original: MicrofacetModel,
    widened: Widened,
}

/// The widened lobe as one of this crate's models, which carries its
/// compensation.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Widened {
    Reflection(MicrofacetModel),
    Interface(Dielectric),
}

impl RegularizedLobe {
    /// Regularizes `lobe` under `tau` (1/sr, see [`crate::tau`]): alpha-hat
    /// as [`alpha_hat`] gives it, for an interface the denser side as eta_t
    /// (as [`crate::regularize`] does, so that both directions of a
    /// bidirectional method see one roughness). With [`Energy::Preserved`]
    /// the widened lobe gets its compensation, which reads energy tables
    /// built at their first use in the process (`microfacet::compensation`:
    /// seconds for an interface; `microfacet::prepare_tables` builds them
    /// ahead of time).
    pub fn new(lobe: &impl MicrofacetLobe, tau: f64, energy: Energy) -> Self {
        let original = MicrofacetModel::new(lobe.ndf(), lobe.alpha(), lobe.shadowing());
        let bound = match lobe.eta() {
            None => Lobe::Reflection,
            Some(eta) => Lobe::Dielectric {
                eta_i: 1.0,
                eta_t: eta.max(1.0 / eta),
            },
        };
        let alpha_hat = alpha_hat(original.ndf.kind(), original.alpha(), bound, tau);
        let widen = alpha_hat.alpha != original.alpha() && energy == Energy::Preserved;
        let widened = match lobe.eta() {
            None if widen => Widened::Reflection(original.regularized(alpha_hat.alpha, Vec3::ONE)),
            None => Widened::Reflection(original.with_alpha(alpha_hat.alpha)),
            Some(eta) if widen => {
                Widened::Interface(Dielectric::new(original, eta).regularized(alpha_hat.alpha))
            }
            Some(eta) => {
                Widened::Interface(Dielectric::new(original.with_alpha(alpha_hat.alpha), eta))
            }
        };
        Self {
            alpha_hat,
            original,
            widened,
        }
    }

    /// The roughness to evaluate and sample the foreign lobe with.
    pub fn alpha(&self) -> f32 {
        self.alpha_hat.alpha
    }

    /// (s(wi) s(wo), f_c(wi, wo)): the factor of the widened lobe's value (1
    /// unless the widened lobe gains energy, `microfacet::compensation`) and
    /// the compensation lobe's value, untinted (see the type's docs); (1, 0)
    /// without compensation.
    pub fn compensation_terms(&self, wi: Vec3, wo: Vec3, mode: TransportMode) -> (f32, f32) {
        match self.widened {
            Widened::Reflection(model) => {
                let (scale, value) = model.compensation_terms(wi, wo);
                (scale, value.x)
            }
            Widened::Interface(d) => d.compensation_terms(wi, wo, mode),
        }
    }

    /// P_c(wi): the probability with which a sampler picks the compensation
    /// lobe instead of the foreign lobe (0 without compensation). The
    /// compensation lobe samples a cosine-weighted direction: on wi's side
    /// for a reflection lobe; for an interface on a side it chooses by the
    /// share of its energy that it transmits
    /// (`microfacet::compensation::DielectricCompensation::transmitted_share`).
    /// [`pdf`](Self::pdf) is the density of that mixture.
    pub fn compensation_probability(&self, wi: Vec3) -> f32 {
        match self.widened {
            Widened::Reflection(model) => model.compensation_probability(wi.z.abs()),
            Widened::Interface(d) => d.compensation_probability(wi),
        }
    }

    /// The density of sampling `wo` from `wi` through the regularized lobe:
    /// (1 - P_c) `p_lobe` + P_c p_c(wi, wo), where `p_lobe` is the foreign
    /// lobe's own density at alpha-hat.
    pub fn pdf(&self, wi: Vec3, wo: Vec3, p_lobe: f32) -> f32 {
        match self.widened {
            Widened::Reflection(model) => model.with_compensation_pdf(wi, wo, p_lobe),
            Widened::Interface(d) => d.with_compensation_pdf(wi, wo, p_lobe),
        }
    }

    /// p-hat (paper eq. 13, supp. §4; as [`crate::p_hat`]) of `wo` sampled
    /// from `wi`, from `p_lobe`, the foreign lobe's own density of that
    /// direction at alpha-hat: the shadowing ratio of the original and
    /// widened models times `p_lobe`, mixed with the compensation as
    /// [`pdf`](Self::pdf).
    pub fn p_hat(&self, wi: Vec3, wo: Vec3, p_lobe: f32) -> f32 {
        let ratio = shadowing_ratio(&self.original, self.alpha(), wi, wo);
        self.pdf(wi, wo, ratio * p_lobe)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pdf::p_hat;
    use crate::tau::regularize;
    use microfacet::{Bsdf, Conductor, Fresnel};

    /// A lobe described only through the trait, as another renderer would.
    struct Foreign {
        ndf: NdfKind,
        shadowing: Shadowing,
        alpha: f32,
        eta: Option<f32>,
    }

    impl MicrofacetLobe for Foreign {
        fn ndf(&self) -> NdfKind {
            self.ndf
        }
        fn shadowing(&self) -> Shadowing {
            self.shadowing
        }
        fn alpha(&self) -> f32 {
            self.alpha
        }
        fn eta(&self) -> Option<f32> {
            self.eta
        }
    }

    /// The same lobe as this workspace's `Bsdf`, with a coloured Fresnel
    /// term for conductors (whose F_avg tints the compensation).
    fn as_bsdf(lobe: &Foreign) -> Bsdf {
        let model = MicrofacetModel::new(lobe.ndf, lobe.alpha, lobe.shadowing);
        match lobe.eta {
            None => Bsdf::Conductor(Conductor {
                model,
                fresnel: Fresnel::Schlick {
                    f0: Vec3::new(0.9, 0.6, 0.3),
                },
            }),
            Some(eta) => Bsdf::Dielectric(Dielectric::new(model, eta)),
        }
    }

    /// Pairs of directions on both sides, away from the horizon.
    fn direction_pairs() -> Vec<(Vec3, Vec3)> {
        let dir = |theta: f32, phi: f32| {
            Vec3::new(
                theta.sin() * phi.cos(),
                theta.sin() * phi.sin(),
                theta.cos(),
            )
        };
        let mut pairs = Vec::new();
        for (i, theta_i) in [0.1f32, 0.6, 1.2].into_iter().enumerate() {
            for theta_o in [0.05f32, 0.4, 1.0, 2.0, 2.6, 3.0] {
                pairs.push((
                    dir(theta_i, 0.3 * i as f32),
                    dir(theta_o, 2.9 + 0.2 * i as f32),
                ));
            }
        }
        pairs
    }

    fn assert_close(what: &str, got: f32, want: f32) {
        let tolerance = 1e-5 * want.abs().max(1e-3);
        assert!(
            (got - want).abs() <= tolerance,
            "{what}: {got} against the Bsdf path's {want}"
        );
    }

    /// A foreign lobe regularized through the trait gets the alpha-hat,
    /// value and p-hat that the same lobe gets as a `Bsdf`.
    #[test]
    fn foreign_lobes_agree_with_the_bsdf_path() {
        let tau = 30.0;
        let lobes = [
            Foreign {
                ndf: NdfKind::Ggx,
                shadowing: Shadowing::Smith,
                alpha: 0.01,
                eta: None,
            },
            Foreign {
                ndf: NdfKind::Beckmann,
                shadowing: Shadowing::VCavity,
                alpha: 0.02,
                eta: None,
            },
            Foreign {
                ndf: NdfKind::BlinnPhong,
                shadowing: Shadowing::Smith,
                alpha: 0.05,
                eta: None,
            },
            Foreign {
                ndf: NdfKind::Ggx,
                shadowing: Shadowing::Smith,
                alpha: 0.02,
                eta: Some(1.5),
            },
            Foreign {
                ndf: NdfKind::Ggx,
                shadowing: Shadowing::Smith,
                alpha: 0.02,
                eta: Some(1.0 / 1.5),
            },
        ];
        for lobe in &lobes {
            let bsdf = as_bsdf(lobe);
            let (reference, hat) = regularize(&bsdf, tau, Energy::Preserved);
            let regularized = RegularizedLobe::new(lobe, tau, Energy::Preserved);
            assert_eq!(Some(regularized.alpha_hat), hat);
            assert!(
                regularized.alpha() > lobe.alpha,
                "tau = {tau} widens alpha {}",
                lobe.alpha
            );
            let widened = bsdf.with_alpha(regularized.alpha());
            let tint = match bsdf {
                Bsdf::Conductor(c) => c.fresnel.average(),
                _ => Vec3::ONE,
            };
            for (wi, wo) in direction_pairs() {
                let mode = TransportMode::Radiance;
                let (scale, value) = regularized.compensation_terms(wi, wo, mode);
                let f = scale * widened.eval(wi, wo, mode) + value * tint;
                let want = reference.eval(wi, wo, mode);
                assert_close("value", f.x, want.x);
                assert_close("value", f.z, want.z);
                let p = regularized.p_hat(wi, wo, widened.pdf(wi, wo));
                assert_close("p-hat", p, p_hat(&bsdf, &reference, wi, wo));
            }
        }
    }

    /// Without energy preservation the widened lobe has no compensation.
    #[test]
    fn energy_lost_has_no_compensation() {
        let lobe = Foreign {
            ndf: NdfKind::Ggx,
            shadowing: Shadowing::Smith,
            alpha: 0.0,
            eta: Some(1.5),
        };
        let regularized = RegularizedLobe::new(&lobe, 10.0, Energy::Lost);
        let (wi, wo) = direction_pairs()[3];
        assert_eq!(
            regularized.compensation_terms(wi, wo, TransportMode::Radiance),
            (1.0, 0.0)
        );
        assert_eq!(regularized.compensation_probability(wi), 0.0);
        assert_eq!(regularized.pdf(wi, wo, 0.25), 0.25);
    }
}
