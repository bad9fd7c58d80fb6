//! The BSDF: an enum over the lobes of this crate, dispatching evaluation,
//! sampling and both directional pdfs to them.
//!
//! Conventions (SPEC §0): directions are in the shading frame (n = +z) and
//! point away from the surface; `wi` is the query direction (towards the
//! previous vertex of the subpath being built), `wo` the other one. Values
//! returned by `eval` do not include the cosine |<wo,n>|.

use glam::{Vec2, Vec3};

use crate::coated::Coated;
use crate::compensation::EnergyTable;
use crate::conductor::Conductor;
use crate::dielectric::Dielectric;
use crate::lambertian::Lambertian;
use crate::model::MicrofacetModel;
use crate::sample::{BsdfSample, TransportMode};
use crate::thin_dielectric::ThinDielectric;

/// A surface scattering function: one of the lobes of this crate.
///
/// A plain enum (no trait objects) keeps dispatch cheap and exhaustive.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bsdf {
    /// Ideal diffuse reflection.
    Lambertian(Lambertian),
    /// Rough or smooth metal.
    Conductor(Conductor),
    /// Rough or smooth glass-like interface.
    Dielectric(Dielectric),
    /// glTF metallic-roughness: a specular coat over a diffuse base, mixed
    /// with a metal (reflection only).
    Coated(Coated),
    /// A thin dielectric sheet: delta reflection, and straight transmission.
    ThinDielectric(ThinDielectric),
}

impl Bsdf {
    /// f(wi, wo) (0 for delta lobes, which only `sample` can produce).
    pub fn eval(&self, wi: Vec3, wo: Vec3, mode: TransportMode) -> Vec3 {
        match self {
            Bsdf::Lambertian(l) => l.eval(wi, wo),
            Bsdf::Conductor(c) => c.eval(wi, wo),
            Bsdf::Dielectric(d) => d.eval(wi, wo, mode),
            // Reflection only: both transport modes see the same value.
            Bsdf::Coated(c) => c.eval(wi, wo),
            Bsdf::ThinDielectric(_) => Vec3::ZERO,
        }
    }

    /// Samples `wo` given `wi` from two uniforms `u` and one more, `uc`, for
    /// discrete choices. `None` when no valid direction results (never a NaN).
    pub fn sample(&self, wi: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        match self {
            Bsdf::Lambertian(l) => l.sample(wi, u),
            Bsdf::Conductor(c) => c.sample(wi, uc, u),
            Bsdf::Dielectric(d) => d.sample(wi, uc, u, mode),
            Bsdf::Coated(c) => c.sample(wi, uc, u),
            Bsdf::ThinDielectric(t) => t.sample(wi, uc),
        }
    }

    /// Density with which `sample` produces `wo` given `wi` (0 for delta lobes).
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        match self {
            Bsdf::Lambertian(l) => l.pdf(wi, wo),
            Bsdf::Conductor(c) => c.pdf(wi, wo),
            Bsdf::Dielectric(d) => d.pdf(wi, wo),
            Bsdf::Coated(c) => c.pdf(wi, wo),
            Bsdf::ThinDielectric(_) => 0.0,
        }
    }

    /// Density with which `sample` would produce `wi` given `wo`.
    pub fn pdf_reverse(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.pdf(wo, wi)
    }

    /// True when the lobe is a delta (nothing to evaluate or connect through).
    /// A smooth coat over a diffuse base is not: its mirror part is reached
    /// only by `sample` (flagged in `BsdfSample`), its base by everything.
    pub fn is_specular(&self) -> bool {
        match self {
            Bsdf::Lambertian(_) => false,
            Bsdf::Conductor(c) => c.is_specular(),
            Bsdf::Dielectric(d) => d.is_specular(),
            Bsdf::Coated(c) => c.is_specular(),
            Bsdf::ThinDielectric(_) => true,
        }
    }

    /// The microfacet width, if the lobe has one (not a Lambertian lobe, not
    /// a thin sheet).
    pub fn alpha(&self) -> Option<f32> {
        match self {
            Bsdf::Lambertian(_) | Bsdf::ThinDielectric(_) => None,
            Bsdf::Conductor(c) => Some(c.model.alpha()),
            Bsdf::Dielectric(d) => Some(d.model.alpha()),
            Bsdf::Coated(c) => Some(c.model.alpha()),
        }
    }

    /// The BSDF regularized to `alpha_hat` with its energy compensated
    /// (`crate::compensation::energy`): the microfacet lobe at alpha-hat plus the lobe that
    /// restores the original white albedo, tinted with the lobe's Fresnel
    /// average (conductors, coats); for dielectrics the lobe that restores
    /// the energy albedo, split between reflection and transmission
    /// (`crate::compensation::dielectric_energy`). Lambertian lobes and thin sheets are
    /// unchanged.
    ///
    /// First use: builds the energy tables it reads, once per process
    /// (`crate::compensation::tables`: seconds in a release build, 10-20x
    /// longer unoptimised); [`crate::prepare_tables`] builds them ahead.
    pub fn regularized(&self, alpha_hat: f32) -> Self {
        match *self {
            Bsdf::Conductor(c) => Bsdf::Conductor(Conductor {
                model: c.model.regularized(alpha_hat, c.fresnel.average()),
                ..c
            }),
            Bsdf::Coated(c) => Bsdf::Coated(Coated {
                model: c.model.regularized(alpha_hat, c.specular_fresnel_average()),
                ..c
            }),
            Bsdf::Dielectric(d) => Bsdf::Dielectric(d.regularized(alpha_hat)),
            Bsdf::Lambertian(_) | Bsdf::ThinDielectric(_) => self.with_alpha(alpha_hat),
        }
    }

    /// The energy tables that `regularized` reads for this lobe, which it
    /// builds at their first use in the process (seconds for a dielectric:
    /// `crate::compensation::tables`); none for a Lambertian lobe, a thin
    /// sheet and an index-matched interface. [`crate::prepare_tables`]
    /// builds them ahead.
    pub fn energy_tables(&self) -> Vec<EnergyTable> {
        let reflection =
            |m: &MicrofacetModel| EnergyTable::of_reflection(m.ndf.kind(), m.shadowing).to_vec();
        match self {
            Bsdf::Conductor(c) => reflection(&c.model),
            Bsdf::Coated(c) => reflection(&c.model),
            Bsdf::Dielectric(d) if !d.is_index_matched() => {
                EnergyTable::of_interface(d.model.ndf.kind(), d.model.shadowing, d.eta)
            }
            Bsdf::Dielectric(_) | Bsdf::Lambertian(_) | Bsdf::ThinDielectric(_) => Vec::new(),
        }
    }

    /// The same BSDF with microfacet width `alpha` (regularization's alpha-hat);
    /// a Lambertian lobe or a thin sheet is returned unchanged, a coated lobe's diffuse base too
    /// (only its specular lobe has a width).
    pub fn with_alpha(&self, alpha: f32) -> Self {
        match *self {
            Bsdf::Lambertian(_) | Bsdf::ThinDielectric(_) => *self,
            Bsdf::Conductor(c) => Bsdf::Conductor(Conductor {
                model: c.model.with_alpha(alpha),
                ..c
            }),
            Bsdf::Dielectric(d) => Bsdf::Dielectric(d.with_alpha(alpha)),
            Bsdf::Coated(c) => Bsdf::Coated(Coated {
                model: c.model.with_alpha(alpha),
                ..c
            }),
        }
    }
}
