//! The compensation lobe of a regularized reflection lobe (conductor, and
//! the coat of `Coated`): Kulla & Conty's lobe f_c = dE(mu_i) dE(mu_o) /
//! (pi dE_avg) for the energy that widening alpha to alpha-hat loses, and
//! the reciprocal scaling s(mu_i) s(mu_o) of a widened lobe that gains
//! (module docs of `crate::compensation::energy` and
//! `crate::compensation::gain`, where the tables and formulas are derived).
//! A `MicrofacetModel` holds one; its methods read the tables through it.

use std::f32::consts::FRAC_1_PI;

use glam::Vec3;

use crate::compensation::energy::{MIN_DEFICIT_AVERAGE, albedo_table, positive_part_moment};
use crate::compensation::gain::{MIN_GAIN, kept_share, mean_scale_table};
use crate::ndf::{Ndf, SMOOTH_ALPHA};
use crate::shadowing::Shadowing;

/// The compensation lobe of a regularized model: what it needs beyond the
/// model itself (the original alpha, dE_avg, the colour).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Compensation {
    /// The original (unregularized) alpha.
    pub alpha: f32,
    /// dE_avg = 2 int_0^1 dE(mu) mu dmu; 0 when the compensation lobe is
    /// left out (below `MIN_DEFICIT_AVERAGE`: the lobe only gains).
    pub deficit_average: f32,
    /// The colour of the compensated energy: the lobe's Fresnel average
    /// F_avg = 2 int F(mu) mu dmu (Kulla & Conty's choice for their
    /// multiple-scattering colour; direction-independent, so f_c stays
    /// reciprocal); white until the lobe sets it.
    pub tint: Vec3,
    /// True when the widened lobe gains energy at some mu (by more than
    /// `gain::MIN_GAIN` at a table node) and is scaled by s(mu_i) s(mu_o)
    /// (`crate::compensation::gain`); false keeps it unscaled, bit for bit.
    pub scaled: bool,
}

impl Compensation {
    /// The compensation of the widened NDF `ndf` (at alpha-hat) with `shadowing` for a lobe of width
    /// `alpha`, or `None` when it would change nothing (alpha-hat <= alpha,
    /// or dE_avg below `MIN_DEFICIT_AVERAGE` and no gain).
    ///
    /// First use: builds the energy tables it reads, once per process
    /// (`crate::compensation::tables`: seconds in a release build, 10-20x
    /// longer unoptimised); [`crate::prepare_tables`] builds them ahead.
    pub fn new(ndf: &Ndf, shadowing: Shadowing, alpha: f32) -> Option<Self> {
        let alpha_hat = ndf.alpha();
        if !(alpha_hat > alpha) || ndf.alpha() < SMOOTH_ALPHA {
            return None;
        }
        let table = albedo_table(ndf.kind(), shadowing);
        let nodes = table.deficit_nodes(alpha, alpha_hat);
        let average = positive_part_moment(&nodes) as f32;
        let scaled = nodes.iter().any(|&d| d < -MIN_GAIN);
        let deficit_average = if average > MIN_DEFICIT_AVERAGE {
            average
        } else {
            0.0
        };
        (deficit_average > 0.0 || scaled).then_some(Self {
            alpha,
            deficit_average,
            tint: Vec3::ONE,
            scaled,
        })
    }

    /// True when the compensation lobe f_c is present (dE_avg above
    /// `MIN_DEFICIT_AVERAGE`).
    pub fn has_lobe(&self) -> bool {
        self.deficit_average > 0.0
    }

    /// dE(mu) of the widened `ndf` (its alpha is alpha-hat): what the
    /// compensation lobe reflects (0 without it).
    pub fn deficit(&self, ndf: &Ndf, shadowing: Shadowing, mu: f32) -> f32 {
        if !self.has_lobe() {
            return 0.0;
        }
        let (e, e_hat) = self.albedos(ndf, shadowing, mu);
        (e - e_hat).max(0.0)
    }

    /// s(mu) = m(mu) / s-bar(mu) of the widened lobe (`crate::compensation::gain`),
    /// m = min(1, E_alpha / E_alpha-hat); exactly 1 unless it gains.
    pub fn scale(&self, ndf: &Ndf, shadowing: Shadowing, mu: f32) -> f32 {
        let albedos = self.scaled.then(|| self.albedos(ndf, shadowing, mu));
        self.scale_at(ndf, shadowing, &AlbedoLookup { mu, albedos })
    }

    /// What the compensation reads at cosine `mu`: E and E-hat there,
    /// looked up once when a term needs them (the deficit, or the gain
    /// scale), for `terms_at` and `probability_at`.
    pub(crate) fn lookup(&self, ndf: &Ndf, shadowing: Shadowing, mu: f32) -> AlbedoLookup {
        let needed = self.has_lobe() || self.scaled;
        AlbedoLookup {
            mu,
            albedos: needed.then(|| self.albedos(ndf, shadowing, mu)),
        }
    }

    /// dE(mu) from a lookup (`deficit`).
    fn deficit_at(&self, at: &AlbedoLookup) -> f32 {
        match at.albedos {
            Some((e, e_hat)) if self.has_lobe() => (e - e_hat).max(0.0),
            _ => 0.0,
        }
    }

    /// s(mu) from a lookup (`scale`).
    fn scale_at(&self, ndf: &Ndf, shadowing: Shadowing, at: &AlbedoLookup) -> f32 {
        let Some((e, e_hat)) = at.albedos.filter(|_| self.scaled) else {
            return 1.0;
        };
        let mean =
            mean_scale_table(ndf.kind(), shadowing).mean_scale(self.alpha, ndf.alpha(), at.mu);
        kept_share(e, e_hat) / mean
    }

    /// (E_alpha(mu), E_alpha-hat(mu)) (white) of the widened `ndf`.
    fn albedos(&self, ndf: &Ndf, shadowing: Shadowing, mu: f32) -> (f32, f32) {
        let table = albedo_table(ndf.kind(), shadowing);
        (table.albedo(mu, self.alpha), table.albedo(mu, ndf.alpha()))
    }

    /// E_alpha-hat(mu) (white) of the widened `ndf`.
    pub fn regularized_albedo(&self, ndf: &Ndf, shadowing: Shadowing, mu: f32) -> f32 {
        albedo_table(ndf.kind(), shadowing).albedo(mu, ndf.alpha())
    }

    /// f_c(wi, wo) = dE(mu_i) dE(mu_o) / (pi dE_avg), untinted (0 without
    /// the lobe).
    pub fn value(&self, ndf: &Ndf, shadowing: Shadowing, mu_i: f32, mu_o: f32) -> f32 {
        self.terms(ndf, shadowing, mu_i, mu_o).1
    }

    /// (s(mu_i) s(mu_o), f_c(wi, wo) untinted): the scaling of the widened
    /// lobe and the compensation lobe's value, sharing the albedo lookups.
    pub fn terms(&self, ndf: &Ndf, shadowing: Shadowing, mu_i: f32, mu_o: f32) -> (f32, f32) {
        self.terms_at(
            ndf,
            shadowing,
            &self.lookup(ndf, shadowing, mu_i),
            &self.lookup(ndf, shadowing, mu_o),
        )
    }

    /// `terms` from the lookups at mu_i and mu_o.
    pub(crate) fn terms_at(
        &self,
        ndf: &Ndf,
        shadowing: Shadowing,
        at_i: &AlbedoLookup,
        at_o: &AlbedoLookup,
    ) -> (f32, f32) {
        let scale = self.scale_at(ndf, shadowing, at_i) * self.scale_at(ndf, shadowing, at_o);
        let value = if self.has_lobe() {
            self.deficit_at(at_i) * self.deficit_at(at_o) * FRAC_1_PI / self.deficit_average
        } else {
            0.0
        };
        (scale, value)
    }

    /// The probability of sampling the compensation lobe for a query at
    /// `mu_i`: its share dE / (E_alpha-hat + dE) of the white albedo.
    pub fn probability(&self, ndf: &Ndf, shadowing: Shadowing, mu_i: f32) -> f32 {
        if !self.has_lobe() {
            return 0.0;
        }
        self.probability_at(&self.lookup(ndf, shadowing, mu_i))
    }

    /// `probability` from the lookup at mu_i.
    pub(crate) fn probability_at(&self, at_i: &AlbedoLookup) -> f32 {
        let deficit = self.deficit_at(at_i);
        let Some((_, e_hat)) = at_i.albedos.filter(|_| self.has_lobe()) else {
            return 0.0;
        };
        let total = deficit + e_hat;
        if total > 0.0 {
            (deficit / total).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// E and E-hat (white) at one cosine: the one lookup of both albedos that
/// the deficit, P_c and the gain scale at that cosine share
/// (`Compensation::lookup`). A sample reads them at mu_i and mu_o only,
/// for its value and both densities.
#[derive(Clone, Copy, Debug)]
pub(crate) struct AlbedoLookup {
    mu: f32,
    /// (E, E-hat), or `None` where no term reads them.
    albedos: Option<(f32, f32)>,
}
