//! What tau bounds, and the roughness alpha-hat that respects it (SPEC §5).
//!
//! tau is the largest solid-angle density a regularized lobe may have in the
//! outgoing direction, so 1/tau is the solid angle of the blur cone: the
//! measure of the progressive schedule (supp. §5) and of virtual merges
//! (supp. §6). [`density_factor`] is the one place that fixes this meaning.
//! Implementations that bound D itself (alpha_tau = 1/sqrt(pi tau)) use a
//! tau four times ours for reflection.

use std::f64::consts::PI;

use microfacet::bounds::transmission_jacobian_sup;
use microfacet::{Bsdf, MicrofacetModel, Ndf, NdfKind, Shadowing};
use thiserror::Error;

/// Interfaces whose indices differ by less than this are not regularized:
/// the refraction Jacobian grows like 1/(eta_i - eta_t)^2, so no roughness can
/// blur an index-matched interface (SPEC §5).
pub const INDEX_MATCH_EPSILON: f32 = 1e-3;

/// Largest alpha-hat regularization produces for GGX and Blinn-Phong: D_max =
/// 1/(pi alpha^2) holds up to alpha = 1 (SPEC §5, transmission clamp).
pub const ALPHA_CAP: f32 = 1.0;

/// Largest alpha-hat for Beckmann, whose maximum leaves h = n above 1/sqrt(2)
/// (supp. eq. 3), so larger alpha no longer lowers the peak as 1/alpha^2.
pub const ALPHA_CAP_BECKMANN: f32 = std::f32::consts::FRAC_1_SQRT_2;

/// Relative slack when checking a bound: alpha-hat is stored in f32.
const BOUND_SLACK: f64 = 1e-5;

/// Which scattering a lobe's roughness must bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Lobe {
    /// Microfacet reflection (conductors).
    Reflection,
    /// Refraction from index `eta_i` (the side of wi) into `eta_t`.
    Transmission {
        /// Index on the side of wi.
        eta_i: f32,
        /// Index on the other side.
        eta_t: f32,
    },
    /// A dielectric interface that both reflects and refracts with one alpha:
    /// alpha-hat is the larger of the two lobes' values.
    Dielectric {
        /// Index on the side of wi.
        eta_i: f32,
        /// Index on the other side.
        eta_t: f32,
    },
}

/// Whether a regularized roughness meets the bound tau.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Bound {
    /// The lobe's peak outgoing density is at most tau.
    Met,
    /// tau needs an alpha beyond the cap (`ALPHA_CAP`/`ALPHA_CAP_BECKMANN`):
    /// alpha-hat stops at the cap and the bound is not met (SPEC §5).
    Clamped,
    /// Index-matched interface: left unchanged, the bound cannot be met.
    IndexMatched,
    /// The input alpha is already beyond the range where raising it lowers
    /// the peak (GGX above 1, Beckmann above 1/sqrt(2)) and its peak exceeds
    /// tau: left unchanged.
    Unreachable,
}

/// A regularized roughness and whether it meets its bound.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AlphaHat {
    /// alpha-hat >= alpha (after the NDF's own clamping of alpha).
    pub alpha: f32,
    /// Whether the bound holds.
    pub bound: Bound,
}

/// The factor k of "tau bounds k D_max(alpha)": the definition of tau.
///
/// The outgoing density of a lobe at normal incidence on the microfacet is
/// D times the half-vector Jacobian: 1/4 for reflection, and at most
/// J_sup = eta_t^2/(eta_i - eta_t)^2 for refraction (SPEC §4). Changing what
/// tau means (e.g. k = 1 to bound D itself) is a change of this function only.
pub fn density_factor(lobe: Lobe) -> f64 {
    match lobe {
        Lobe::Reflection => 0.25,
        Lobe::Transmission { eta_i, eta_t } | Lobe::Dielectric { eta_i, eta_t } => {
            f64::from(transmission_jacobian_sup(eta_i, eta_t))
        }
    }
}

/// The quantity tau bounds: the peak outgoing density k D_max(alpha) of a lobe
/// (the larger of reflection and refraction for `Lobe::Dielectric`).
pub fn peak_density(kind: NdfKind, alpha: f32, lobe: Lobe) -> f64 {
    let d_max = f64::from(Ndf::new(kind, alpha).d_max());
    match lobe {
        Lobe::Dielectric { .. } => {
            d_max * density_factor(lobe).max(density_factor(Lobe::Reflection))
        }
        _ => d_max * density_factor(lobe),
    }
}

/// The roughness whose peak density equals tau, from k/(pi alpha^2) = tau:
/// alpha_tau = sqrt(k / (pi tau)); 1/sqrt(4 pi tau) for reflection and
/// eta_t / (|eta_i - eta_t| sqrt(pi tau)) for refraction (SPEC §5). Not capped.
pub fn alpha_tau(lobe: Lobe, tau: f64) -> f64 {
    (density_factor(lobe) / (PI * tau)).sqrt()
}

/// The largest alpha-hat for an NDF (where its peak is 1/(pi alpha^2)).
pub fn alpha_cap(kind: NdfKind) -> f32 {
    match kind {
        NdfKind::Beckmann => ALPHA_CAP_BECKMANN,
        NdfKind::Ggx | NdfKind::BlinnPhong => ALPHA_CAP,
    }
}

/// Regularized roughness (SPEC §5): alpha-hat = max(alpha, min(alpha_tau, cap)).
///
/// `tau` may be +infinity (no regularization: alpha is returned unchanged);
/// NaN is treated the same way. An alpha that already satisfies the bound is
/// returned unchanged. The result says whether the bound holds (`Bound`).
pub fn alpha_hat(kind: NdfKind, alpha: f32, lobe: Lobe, tau: f64) -> AlphaHat {
    match lobe {
        Lobe::Dielectric { eta_i, eta_t } => {
            let r = single_lobe(kind, alpha, Lobe::Reflection, tau);
            let t = single_lobe(kind, alpha, Lobe::Transmission { eta_i, eta_t }, tau);
            // Below the cap a larger alpha only lowers a peak, so each lobe's
            // status holds at the common (larger) alpha-hat.
            let bound = if t.bound == Bound::Met {
                r.bound
            } else {
                t.bound
            };
            AlphaHat {
                alpha: r.alpha.max(t.alpha),
                bound,
            }
        }
        _ => single_lobe(kind, alpha, lobe, tau),
    }
}

fn single_lobe(kind: NdfKind, alpha: f32, lobe: Lobe, tau: f64) -> AlphaHat {
    let alpha_hat = widened_single(kind, alpha, lobe, tau);
    let bound = if !(tau < f64::INFINITY) {
        Bound::Met
    } else if is_index_matched(lobe) {
        Bound::IndexMatched
    } else {
        match bound_at(kind, alpha_hat, lobe, tau) {
            Bound::Met => Bound::Met,
            _ if alpha_tau(lobe, tau) > f64::from(alpha_cap(kind)) => Bound::Clamped,
            other => other,
        }
    };
    AlphaHat {
        alpha: alpha_hat,
        bound,
    }
}

/// [`alpha_hat`]'s roughness without its bound check: all that a caller
/// asking whether a lobe would be widened needs ([`is_bounded`]).
pub fn widened_alpha(kind: NdfKind, alpha: f32, lobe: Lobe, tau: f64) -> f32 {
    match lobe {
        Lobe::Dielectric { eta_i, eta_t } => {
            let r = widened_single(kind, alpha, Lobe::Reflection, tau);
            let t = widened_single(kind, alpha, Lobe::Transmission { eta_i, eta_t }, tau);
            r.max(t)
        }
        _ => widened_single(kind, alpha, lobe, tau),
    }
}

/// alpha-hat of one lobe (SPEC §5): alpha, after the NDF's clamping,
/// raised to alpha_tau capped at [`alpha_cap`]; unchanged under tau =
/// infinity (or NaN) and at an index-matched interface.
fn widened_single(kind: NdfKind, alpha: f32, lobe: Lobe, tau: f64) -> f32 {
    let alpha = Ndf::new(kind, alpha).alpha();
    if !(tau < f64::INFINITY) || is_index_matched(lobe) {
        return alpha;
    }
    let cap = f64::from(alpha_cap(kind));
    alpha.max(round_up(alpha_tau(lobe, tau).min(cap)))
}

/// Refraction between indices closer than [`INDEX_MATCH_EPSILON`].
fn is_index_matched(lobe: Lobe) -> bool {
    matches!(lobe, Lobe::Transmission { eta_i, eta_t } if (eta_i - eta_t).abs() < INDEX_MATCH_EPSILON)
}

/// `Met` if the lobe's peak density at `alpha` is within tau, else `Unreachable`.
fn bound_at(kind: NdfKind, alpha: f32, lobe: Lobe, tau: f64) -> Bound {
    if peak_density(kind, alpha, lobe) <= tau * (1.0 + BOUND_SLACK) {
        Bound::Met
    } else {
        Bound::Unreachable
    }
}

/// The smallest f32 not below `x` (x >= 0): rounding alpha-hat down would
/// raise the peak above tau.
fn round_up(x: f64) -> f32 {
    let y = x as f32;
    if f64::from(y) < x { y.next_up() } else { y }
}

/// The strict variant is defined for Smith shadowing only.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Error)]
#[non_exhaustive]
pub enum StrictError {
    /// V-cavity's G/|cos cos| is unbounded at grazing (supp. §2).
    #[error(
        "the strict regularization variant needs Smith shadowing: V-cavity has no finite bound of G/|cos cos|"
    )]
    VCavity,
}

/// Strict variant (supp. §2, SPEC §5): bounds the whole reflection BSDF,
/// including G/|cos_i cos_o|, by tau. Smith GGX: f <= 1/(pi alpha^4), so
/// alpha_tau = (pi tau)^(-1/4), valid up to alpha = 1; Smith Beckmann (and
/// Blinn-Phong, whose G1/cos is below Beckmann's): f <= 1/alpha^4, so
/// alpha_tau = tau^(-1/4), valid up to 1/sqrt(2) (tau >= 4). Beyond its
/// validity alpha-hat stops at the limit and the result says `Clamped`.
pub fn alpha_hat_strict(model: &MicrofacetModel, tau: f64) -> Result<AlphaHat, StrictError> {
    if model.shadowing == Shadowing::VCavity {
        return Err(StrictError::VCavity);
    }
    let alpha = model.alpha();
    if !(tau < f64::INFINITY) {
        return Ok(AlphaHat {
            alpha,
            bound: Bound::Met,
        });
    }
    let kind = model.ndf.kind();
    let (wanted, cap) = match kind {
        NdfKind::Ggx => ((PI * tau).powf(-0.25), ALPHA_CAP),
        NdfKind::Beckmann | NdfKind::BlinnPhong => (tau.powf(-0.25), ALPHA_CAP_BECKMANN),
    };
    let alpha_hat = alpha.max(round_up(wanted.min(f64::from(cap))));
    let peak = strict_peak(kind, alpha_hat);
    let bound = if peak <= tau * (1.0 + BOUND_SLACK) {
        Bound::Met
    } else if wanted > f64::from(cap) {
        Bound::Clamped
    } else {
        Bound::Unreachable
    };
    Ok(AlphaHat {
        alpha: alpha_hat,
        bound,
    })
}

/// The strict bound of the reflection BSDF at alpha (valid below the cap).
pub fn strict_peak(kind: NdfKind, alpha: f32) -> f64 {
    let a4 = f64::from(alpha).powi(4);
    match kind {
        NdfKind::Ggx => 1.0 / (PI * a4),
        NdfKind::Beckmann | NdfKind::BlinnPhong => 1.0 / a4,
    }
}

/// Whether a regularized lobe keeps its original's directional albedo
/// (`microfacet::compensation::energy`, Kulla & Conty 2017 applied to the difference
/// between the original and the widened lobe) or loses what widening a
/// single-scattering lobe loses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Energy {
    /// The widened lobe plus a compensation lobe (`Bsdf::regularized`).
    #[default]
    Preserved,
    /// The widened lobe alone (`Bsdf::with_alpha`): darker images, kept for
    /// comparison.
    Lost,
}

/// A BSDF with its roughness regularized under bound `tau`, and the
/// alpha-hat used; `None` for lobes without
/// a microfacet roughness (Lambertian), which are returned unchanged.
///
/// Conductors and coated lobes bound their (specular) reflection; dielectrics both lobes, refraction
/// with the denser side as eta_t whichever side `wi` is on: J_sup is then the
/// larger of the two directions' (max(eta_i, eta_t)^2/(eta_i - eta_t)^2, supp.
/// eq. 7), so the bound holds both ways and the interface gets one alpha-hat.
/// With SPEC §4's per-direction J_sup the camera and the light subpath
/// would give one vertex different roughness, the techniques of a
/// bidirectional method would estimate different integrands even in uniform
/// mode, and their MIS weights would not sum to 1 (SPEC §6, tested in
/// `integrators::bidir`). The cost: rays leaving the dense medium are
/// blurred by eta more in alpha than their own bound needs.
///
/// `tau` is a solid-angle density in 1/sr (module docs): the largest
/// density the widened lobe may scatter with, so 1/tau is the solid angle of
/// its blur cone. tau = 30 (the renderer's default tau_0) gives GGX
/// reflection alpha-hat = 1/sqrt(4 pi 30) = 0.052; the paper's schedule
/// (`Schedule`) multiplies tau_0 by N^(1/3) at iteration N; tau = infinity
/// leaves every lobe unchanged.
///
/// A smooth (delta) lobe becomes glossy when alpha-hat rises above
/// `microfacet::SMOOTH_ALPHA`. With `Energy::Preserved` the widened lobe
/// keeps the original's white albedo (`Bsdf::regularized`).
///
/// First use: with `Energy::Preserved`, builds the energy tables of the
/// lobe's model once per process (seconds in a release build, 10-20x
/// longer unoptimised); `microfacet::prepare_tables` builds them ahead.
pub fn regularize(bsdf: &Bsdf, tau: f64, energy: Energy) -> (Bsdf, Option<AlphaHat>) {
    let Some(hat) = bsdf_alpha_hat(bsdf, tau) else {
        return (*bsdf, None);
    };
    let regularized = if bsdf.alpha() == Some(hat.alpha) {
        *bsdf
    } else {
        match energy {
            Energy::Preserved => bsdf.regularized(hat.alpha),
            Energy::Lost => bsdf.with_alpha(hat.alpha),
        }
    };
    (regularized, Some(hat))
}

/// alpha-hat of the microfacet part of `bsdf` under tau ([`bound_lobe`]).
pub(crate) fn bsdf_alpha_hat(bsdf: &Bsdf, tau: f64) -> Option<AlphaHat> {
    let (kind, alpha, lobe) = bound_lobe(bsdf)?;
    Some(alpha_hat(kind, alpha, lobe, tau))
}

/// The NDF, roughness and lobe whose peak density tau bounds: a coated
/// lobe's microfacet part is a reflection lobe; a dielectric is one
/// interface, bounded both ways (`regularize`). `None` without roughness.
fn bound_lobe(bsdf: &Bsdf) -> Option<(NdfKind, f32, Lobe)> {
    let (model, lobe) = match bsdf {
        Bsdf::Lambertian(_) | Bsdf::ThinDielectric(_) => return None,
        Bsdf::Conductor(c) => (&c.model, Lobe::Reflection),
        Bsdf::Coated(c) => (&c.model, Lobe::Reflection),
        Bsdf::Dielectric(d) => {
            let eta_t = d.eta.max(1.0 / d.eta);
            (&d.model, Lobe::Dielectric { eta_i: 1.0, eta_t })
        }
    };
    Some((model.ndf.kind(), model.alpha(), lobe))
}

/// True when regularizing `bsdf` at tau would leave it as it is: its peak
/// outgoing density is already at most tau (SPEC §5), so a connection
/// that evaluates it has a bounded value. A lobe without roughness is
/// bounded; a delta lobe never is (not even an index-matched one, which
/// no roughness can bound).
pub fn is_bounded(bsdf: &Bsdf, tau: f64) -> bool {
    !bsdf.is_specular()
        && bound_lobe(bsdf)
            .is_none_or(|(kind, alpha, lobe)| widened_alpha(kind, alpha, lobe, tau) == alpha)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reflection_formula_matches_spec() {
        // tau = 7.5 (the default tau_0): alpha_tau = 1/sqrt(30 pi) = 0.103.
        let a = alpha_hat(NdfKind::Ggx, 0.01, Lobe::Reflection, 7.5);
        assert!((f64::from(a.alpha) - 1.0 / (30.0 * PI).sqrt()).abs() < 1e-6);
        assert_eq!(a.bound, Bound::Met);
        // Blinn-Phong: n-hat = min(n, 8 pi tau - 2).
        let b = alpha_hat(NdfKind::BlinnPhong, 0.01, Lobe::Reflection, 7.5);
        let n_hat = 2.0 / f64::from(b.alpha).powi(2) - 2.0;
        assert!((n_hat / (8.0 * PI * 7.5 - 2.0) - 1.0).abs() < 1e-5);
    }

    /// One alpha-hat per dielectric interface, meeting the bound for light
    /// entering and for light leaving the dense medium, whether the medium
    /// is below (eta > 1) or above (eta < 1) the surface.
    #[test]
    fn dielectric_bound_holds_in_both_directions() {
        let tau = 50.0;
        for eta in [1.5f32, 1.0 / 1.5, 1.05, 1.0 / 1.05, 2.4] {
            let bsdf = Bsdf::Dielectric(microfacet::Dielectric::new(
                MicrofacetModel::new(NdfKind::Ggx, 0.0, Shadowing::Smith),
                eta,
            ));
            let (_, hat) = regularize(&bsdf, tau, Energy::Preserved);
            let hat = hat.expect("a dielectric has a roughness");
            if hat.bound == Bound::Clamped {
                continue; // eta 1.05 at this tau needs alpha > 1 (SPEC §5)
            }
            for (eta_i, eta_t) in [(1.0, eta), (eta, 1.0)] {
                let peak =
                    peak_density(NdfKind::Ggx, hat.alpha, Lobe::Transmission { eta_i, eta_t });
                assert!(
                    peak <= tau * (1.0 + BOUND_SLACK),
                    "eta {eta}: {peak} > {tau}"
                );
            }
        }
    }

    #[test]
    fn transmission_formula_and_guards() {
        let tau = 100.0;
        let a = alpha_hat(
            NdfKind::Ggx,
            0.01,
            Lobe::Transmission {
                eta_i: 1.0,
                eta_t: 1.5,
            },
            tau,
        );
        let expected = 1.5 / (0.5 * (PI * tau).sqrt());
        assert!((f64::from(a.alpha) / expected - 1.0).abs() < 1e-6);
        assert_eq!(a.bound, Bound::Met);
        // Index-matched: unchanged.
        let m = alpha_hat(
            NdfKind::Ggx,
            0.01,
            Lobe::Transmission {
                eta_i: 1.0,
                eta_t: 1.0005,
            },
            tau,
        );
        assert_eq!((m.alpha, m.bound), (0.01, Bound::IndexMatched));
        // Small tau at eta 1.1 needs alpha > 1: clamped, reported.
        let c = alpha_hat(
            NdfKind::Ggx,
            0.01,
            Lobe::Transmission {
                eta_i: 1.0,
                eta_t: 1.1,
            },
            20.0,
        );
        assert_eq!((c.alpha, c.bound), (ALPHA_CAP, Bound::Clamped));
    }

    /// `widened_alpha` is `alpha_hat`'s roughness, and `is_bounded` says
    /// whether alpha-hat leaves a lobe as it is, over NDFs, roughness from
    /// below `ALPHA_MIN` to beyond the caps, every lobe kind (an
    /// index-matched one too) and tau from tiny to infinite and NaN.
    #[test]
    fn widened_alpha_is_alpha_hats_roughness() {
        let taus = [0.1, 2.0, 7.5, 30.0, 1e3, 1e9, f64::INFINITY, f64::NAN];
        let lobes = [
            Lobe::Reflection,
            Lobe::Transmission {
                eta_i: 1.0,
                eta_t: 1.5,
            },
            Lobe::Transmission {
                eta_i: 1.33,
                eta_t: 1.0,
            },
            Lobe::Transmission {
                eta_i: 1.0,
                eta_t: 1.0005,
            },
            Lobe::Dielectric {
                eta_i: 1.0,
                eta_t: 1.5,
            },
            Lobe::Dielectric {
                eta_i: 1.0,
                eta_t: 1.0005,
            },
        ];
        for kind in [NdfKind::Ggx, NdfKind::Beckmann, NdfKind::BlinnPhong] {
            for alpha in [0.0, 1e-5, 0.02, 0.1, 0.5, 0.8, 1.0, 1.5] {
                let model = MicrofacetModel::new(kind, alpha, Shadowing::Smith);
                let lobes_of_bsdfs = [
                    Bsdf::Conductor(microfacet::Conductor {
                        model,
                        fresnel: microfacet::Fresnel::Schlick {
                            f0: glam::Vec3::ONE,
                        },
                    }),
                    Bsdf::Dielectric(microfacet::Dielectric::new(model, 1.0 / 1.5)),
                ];
                for tau in taus {
                    for lobe in lobes {
                        let hat = alpha_hat(kind, alpha, lobe, tau);
                        let got = widened_alpha(kind, alpha, lobe, tau);
                        assert_eq!(got, hat.alpha, "{kind:?} alpha {alpha} {lobe:?} tau {tau}");
                    }
                    for bsdf in &lobes_of_bsdfs {
                        let unchanged = bsdf_alpha_hat(bsdf, tau).map(|h| h.alpha) == bsdf.alpha();
                        let expected = !bsdf.is_specular() && unchanged;
                        assert_eq!(is_bounded(bsdf, tau), expected, "{bsdf:?} tau {tau}");
                    }
                }
            }
        }
    }

    #[test]
    fn strict_variant() {
        let smith = MicrofacetModel::new(NdfKind::Ggx, 0.01, Shadowing::Smith);
        let a = alpha_hat_strict(&smith, 100.0).unwrap();
        assert!((f64::from(a.alpha) - (PI * 100.0).powf(-0.25)).abs() < 1e-6);
        let vcavity = MicrofacetModel::new(NdfKind::Ggx, 0.01, Shadowing::VCavity);
        assert_eq!(alpha_hat_strict(&vcavity, 100.0), Err(StrictError::VCavity));
    }

    /// A thin sheet has no roughness to widen: regularization returns it
    /// unchanged, and, a delta lobe, it is never bounded (the unsampleable
    /// rule keeps regularizing past it, as past a smooth dielectric).
    #[test]
    fn thin_sheets_are_left_alone_and_never_bounded() {
        let sheet = Bsdf::ThinDielectric(microfacet::ThinDielectric::new(1.5));
        for energy in [Energy::Preserved, Energy::Lost] {
            assert_eq!(regularize(&sheet, 7.5, energy), (sheet, None));
        }
        assert!(!is_bounded(&sheet, 1e12));
    }
}
