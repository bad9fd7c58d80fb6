//! The compensation lobe of a regularized dielectric interface: the
//! reflected and transmitted energy that widening alpha to alpha-hat loses
//! on each side, and the reciprocal scaling s(wi) s(wo) where the widened
//! interface gains (module docs of `crate::compensation::dielectric_energy`
//! and `crate::compensation::dielectric_gain`, where the tables and
//! formulas are derived). A `Dielectric` holds one.

use std::f32::consts::FRAC_1_PI;

use glam::Vec3;

use crate::compensation::dielectric_energy::{
    ABOVE, BELOW, dielectric_albedo_table, seen, side, transmittance_above,
};
use crate::compensation::dielectric_gain::dielectric_mean_scale;
use crate::compensation::energy::MIN_DEFICIT_AVERAGE;
use crate::compensation::gain::kept_share;
use crate::ndf::{Ndf, SMOOTH_ALPHA};
use crate::sample::{MixturePdf, TransportMode};
use crate::shadowing::Shadowing;

/// The compensation lobe of a regularized dielectric (module docs): what it
/// needs beyond the lobe (its model at alpha-hat and its eta).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DielectricCompensation {
    /// The original (unregularized) alpha.
    pub alpha: f32,
    /// dE_avg of each side ([`ABOVE`], [`BELOW`]); 0 for a side whose
    /// deficit is below `MIN_DEFICIT_AVERAGE` (then its dE is taken as 0).
    pub deficit_average: [f32; 2],
    /// T_s, the smooth interface's hemispherical transmittance seen from
    /// each side.
    pub transmittance: [f32; 2],
    /// True when the widened lobe gains energy on a side (by more than
    /// `gain::MIN_GAIN` at a table node) and is scaled by s(wi) s(wo)
    /// (`crate::compensation::dielectric_gain`); false keeps it unscaled, bit for bit.
    pub scaled: bool,
}

/// E and E-hat (white, Importance mode) at one direction of a query, with
/// its side and cosine: the one table lookup that the deficit, P_c and the
/// gain scale of that direction share (`DielectricCompensation::lookup`).
/// A sample reads them at wi and wo only, for its value and both densities.
#[derive(Clone, Copy, Debug)]
pub(crate) struct AlbedoLookup {
    side: usize,
    mu: f32,
    /// [E, E-hat], or `None` where no term reads them.
    albedos: Option<[f32; 2]>,
}

impl DielectricCompensation {
    /// The compensation of the widened NDF `ndf` (at alpha-hat) with `shadowing` for an interface of width
    /// `alpha` and index ratio `eta`, or `None` when it would carry nothing
    /// (alpha-hat <= alpha, a smooth NDF, an invalid eta, or both deficits
    /// below `MIN_DEFICIT_AVERAGE`).
    ///
    /// First use: builds the energy tables it reads, once per process
    /// (`crate::compensation::tables`: seconds in a release build, 10-20x
    /// longer unoptimised); [`crate::prepare_tables`] builds them ahead.
    pub fn new(ndf: &Ndf, shadowing: Shadowing, alpha: f32, eta: f32) -> Option<Self> {
        let alpha_hat = ndf.alpha();
        if !(alpha_hat > alpha) || ndf.alpha() < SMOOTH_ALPHA || !(eta > 0.0 && eta.is_finite()) {
            return None;
        }
        let table = dielectric_albedo_table(ndf.kind(), shadowing);
        let mut scaled = false;
        let deficit_average = [ABOVE, BELOW].map(|s| {
            let (average, gains) = table.deficit_average(alpha, alpha_hat, seen(eta, s));
            scaled |= gains;
            let average = average as f32;
            if average > MIN_DEFICIT_AVERAGE {
                average
            } else {
                0.0
            }
        });
        if deficit_average == [0.0, 0.0] && !scaled {
            return None;
        }
        let above = transmittance_above(eta);
        Some(Self {
            alpha,
            deficit_average,
            transmittance: [above, above / (eta * eta)],
            scaled,
        })
    }

    /// dE_s(mu) of the widened `ndf` (alpha-hat) on `side`.
    pub fn deficit(&self, ndf: &Ndf, shadowing: Shadowing, eta: f32, side: usize, mu: f32) -> f32 {
        if self.deficit_average[side] == 0.0 {
            return 0.0;
        }
        let [e, e_hat] = self.albedos(ndf, shadowing, eta, side, mu);
        (e - e_hat).max(0.0)
    }

    /// E_s(mu) at alpha and at alpha-hat (the widened `ndf`) on
    /// `side`, from one lookup of both.
    fn albedos(&self, ndf: &Ndf, shadowing: Shadowing, eta: f32, side: usize, mu: f32) -> [f32; 2] {
        dielectric_albedo_table(ndf.kind(), shadowing).albedos(
            mu,
            [self.alpha, ndf.alpha()],
            seen(eta, side),
        )
    }

    /// E_s(mu) at alpha-hat (white, Importance mode) on `side`.
    pub fn regularized_albedo(
        &self,
        ndf: &Ndf,
        shadowing: Shadowing,
        eta: f32,
        side: usize,
        mu: f32,
    ) -> f32 {
        dielectric_albedo_table(ndf.kind(), shadowing).albedo(mu, ndf.alpha(), seen(eta, side))
    }

    /// t_s = T_s min(1, dE_avg,s' / dE_avg,s): the share of side s's
    /// compensated energy that is transmitted.
    pub fn transmitted_share(&self, side: usize) -> f32 {
        let (own, other) = (self.deficit_average[side], self.deficit_average[1 - side]);
        if own == 0.0 {
            return 0.0;
        }
        self.transmittance[side] * (other / own).min(1.0)
    }

    /// s_s(mu) = m / s-bar of the widened lobe on `side`
    /// (`crate::compensation::dielectric_gain`), m = min(1, E_alpha / E_alpha-hat);
    /// exactly 1 unless it gains.
    pub fn scale(&self, ndf: &Ndf, shadowing: Shadowing, eta: f32, side: usize, mu: f32) -> f32 {
        let albedos = self
            .scaled
            .then(|| self.albedos(ndf, shadowing, eta, side, mu));
        self.scale_at(ndf, shadowing, eta, &AlbedoLookup { side, mu, albedos })
    }

    /// (s(wi) s(wo), the compensation value), sharing the albedo lookups:
    /// the factor of the widened lobe (1 unless it gains) and `value`.
    pub fn terms(
        &self,
        ndf: &Ndf,
        shadowing: Shadowing,
        eta: f32,
        wi: Vec3,
        wo: Vec3,
        mode: TransportMode,
    ) -> (f32, f32) {
        let at_i = self.lookup(ndf, shadowing, eta, wi);
        let at_o = self.lookup(ndf, shadowing, eta, wo);
        self.terms_at(ndf, shadowing, eta, &at_i, &at_o, mode)
    }

    /// What the compensation reads at direction `w`: E and E-hat there,
    /// looked up once when a term needs them (the deficit of a side that
    /// has one, or the gain scale), for `terms_at` and `probability_at`.
    pub(crate) fn lookup(
        &self,
        ndf: &Ndf,
        shadowing: Shadowing,
        eta: f32,
        w: Vec3,
    ) -> AlbedoLookup {
        let (side, mu) = (side(w), w.z.abs());
        let needed = self.deficit_average[side] != 0.0 || self.scaled;
        AlbedoLookup {
            side,
            mu,
            albedos: needed.then(|| self.albedos(ndf, shadowing, eta, side, mu)),
        }
    }

    /// `terms` from the lookups at wi and wo.
    pub(crate) fn terms_at(
        &self,
        ndf: &Ndf,
        shadowing: Shadowing,
        eta: f32,
        at_i: &AlbedoLookup,
        at_o: &AlbedoLookup,
        mode: TransportMode,
    ) -> (f32, f32) {
        let scale =
            self.scale_at(ndf, shadowing, eta, at_i) * self.scale_at(ndf, shadowing, eta, at_o);
        let d_i = self.deficit_at(at_i);
        let value = if at_i.mu == 0.0 || at_o.mu == 0.0 || d_i == 0.0 {
            0.0
        } else {
            let d_o = self.deficit_at(at_o);
            self.value_of_deficits(eta, (at_i.side, d_i), (at_o.side, d_o), mode)
        };
        (scale, value)
    }

    /// dE_s(mu) from a lookup (`deficit`).
    fn deficit_at(&self, at: &AlbedoLookup) -> f32 {
        match at.albedos {
            Some([e, e_hat]) if self.deficit_average[at.side] != 0.0 => (e - e_hat).max(0.0),
            _ => 0.0,
        }
    }

    /// s_s(mu) from a lookup (`scale`): 1 unless the lobe gains.
    fn scale_at(&self, ndf: &Ndf, shadowing: Shadowing, eta: f32, at: &AlbedoLookup) -> f32 {
        let Some([e, e_hat]) = at.albedos.filter(|_| self.scaled) else {
            return 1.0;
        };
        let kind = ndf.kind();
        let mean = dielectric_mean_scale(
            kind,
            shadowing,
            self.alpha,
            ndf.alpha(),
            seen(eta, at.side),
            at.mu,
        );
        kept_share(e, e_hat) / mean
    }

    /// The compensation value for `wi`, `wo` (untinted), in `mode`: f_R on
    /// one side, f_T across (module docs), 0 at grazing.
    pub fn value(
        &self,
        ndf: &Ndf,
        shadowing: Shadowing,
        eta: f32,
        wi: Vec3,
        wo: Vec3,
        mode: TransportMode,
    ) -> f32 {
        self.terms(ndf, shadowing, eta, wi, wo, mode).1
    }

    /// `value` from the sides and deficits of wi and wo.
    fn value_of_deficits(
        &self,
        eta: f32,
        (s_i, d_i): (usize, f32),
        (s_o, d_o): (usize, f32),
        mode: TransportMode,
    ) -> f32 {
        if s_i == s_o {
            let reflected = 1.0 - self.transmitted_share(s_i);
            return reflected * d_i * d_o * FRAC_1_PI / self.deficit_average[s_i];
        }
        let largest = self.deficit_average[0].max(self.deficit_average[1]);
        let importance = self.transmittance[s_i] * d_i * d_o * FRAC_1_PI / largest;
        match mode {
            TransportMode::Importance => importance,
            // (eta_i/eta_t)^2 = 1/eta_seen^2, as the lobe's refraction.
            TransportMode::Radiance => importance / seen(eta, s_i).powi(2),
        }
    }

    /// P_c(mu_i) = dE_s / (E_hat,s + dE_s): the probability of sampling the
    /// compensation lobe for a query from `wi`, its share of the energy albedo.
    pub fn probability(&self, ndf: &Ndf, shadowing: Shadowing, eta: f32, wi: Vec3) -> f32 {
        let (side, mu) = (side(wi), wi.z.abs());
        if self.deficit_average[side] == 0.0 {
            return 0.0;
        }
        let albedos = Some(self.albedos(ndf, shadowing, eta, side, mu));
        self.probability_at(&AlbedoLookup { side, mu, albedos })
    }

    /// `probability` from the lookup at wi.
    pub(crate) fn probability_at(&self, at_i: &AlbedoLookup) -> f32 {
        let deficit = self.deficit_at(at_i);
        let Some([_, e_hat]) = at_i.albedos else {
            return 0.0;
        };
        let total = deficit + e_hat;
        if deficit > 0.0 && total > 0.0 {
            (deficit / total).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// The mixture density (1 - `p_c`) `p_lobe` + `p_c` p_c(wi, wo), with
    /// `p_c` = P_c(mu_i) (`probability`), in its parts; `p_lobe` alone
    /// (`p_c` taken as 0) for a direction in the interface's plane.
    pub(crate) fn mixture_pdf(&self, p_c: f32, wi: Vec3, wo: Vec3, p_lobe: f32) -> MixturePdf {
        let p_c = if wi.z == 0.0 || wo.z == 0.0 { 0.0 } else { p_c };
        let p_compensation = if p_c == 0.0 {
            0.0
        } else {
            self.sampling_pdf(wi, wo)
        };
        MixturePdf {
            p_c,
            p_compensation,
            p_lobe,
        }
    }

    /// Density of the compensation lobe's sampler: cosine on the side that
    /// the coin picks (transmission with probability t_s).
    pub fn sampling_pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let s = side(wi);
        let share = if s == side(wo) {
            1.0 - self.transmitted_share(s)
        } else {
            self.transmitted_share(s)
        };
        share * wo.z.abs() * FRAC_1_PI
    }
}
