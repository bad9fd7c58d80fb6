//! The glTF 2.0 metallic-roughness BRDF: a microfacet specular lobe over a
//! diffuse base, mixed with a Schlick metal (Khronos glTF 2.0 spec,
//! Appendix B "BRDF Implementation"), with `KHR_materials_specular` (the
//! dielectric's F0 colour and strength) and `KHR_materials_ior` (its F0 from
//! the index). Reflection only, two-sided.
//!
//! # The model
//!
//! With F_s the Schlick reflectance of the dielectric coat, per the
//! `KHR_materials_specular` spec ("Implementation"):
//! F0 = min(((ior - 1)/(ior + 1))^2 specularColor, 1), F_s(c) = w (F0 + (1 - F0)(1 - c)^5)
//! with w the specular factor, and F_m(c) = base + (1 - base)(1 - c)^5 the metal's
//! (Appendix B, `conductor_fresnel`):
//!
//! f = (1 - m) [ T(mu_i) T(mu_o) / T_avg (base/pi) + F_s(<wi,h>) f_spec ] + m F_m(<wi,h>) f_spec,
//!
//! f_spec = D G / (4 mu_i mu_o) the Torrance-Sparrow lobe of `model` (SPEC §3),
//! m the metallic factor, mu = |<w,n>|, T(mu) = 1 - max_rgb F_s(mu) the coat's
//! transmittance at the macro cosine, and T_avg = 2 int T(mu) mu dmu its
//! cosine-weighted hemispherical average, in closed form
//! 1 - w (F0 + (1 - F0)/21) for max_rgb F0 (int (1 - mu)^5 2 mu dmu = 1/21).
//!
//! **Deviation from Appendix B.** Its `fresnel_mix` weights the base by
//! 1 - F_s(<wi,h>) at the half vector of the pair. For a white base that
//! reflects up to 1.7 times the incident energy at grazing incidence
//! (cos 0.05: 0.78 from the coat, 0.9 from the base), which breaks a white
//! furnace. Here the base is coupled to the coat as Kelemen & Szirmay-Kalos
//! (2001) do, with the coat's Fresnel as its albedo:
//! T(mu_i) T(mu_o) / T_avg, reciprocal, and the base then reflects exactly
//! T(mu_i) base of what arrives (its integral over mu_o is T_avg), so a
//! white smooth coat over a white base has albedo F_s(mu_i) + T(mu_i) = 1.
//! At normal incidence the base's albedo is Appendix B's (1 - F0 there);
//! at grazing incidence it is darker, by exactly what the coat reflects.
//! The metal and the coat's own lobe are Appendix B's.
//!
//! # Sampling
//!
//! One coin picks the specular lobe with probability P_s(mu_i), the
//! Fresnel-weighted estimate of its share of the albedo (channel means of
//! F(mu_i) against (1 - m) base T(mu_i)); the diffuse lobe is cosine
//! sampled. `pdf` is the mixture P_s p_spec + (1 - P_s) mu_o/pi, so MIS sees
//! one density whichever lobe produced a direction. P_s depends on wi only,
//! not on alpha, so regularization does not change the choice.
//!
//! # Regularized coats
//!
//! Regularization widens the coat's (specular) lobe only; with energy
//! compensation (`crate::compensation::energy`) the specular lobe gains the compensation
//! lobe, tinted with the cosine-weighted average of `specular_fresnel`
//! (`specular_fresnel_average`), sampled inside the specular branch of the
//! coin with probability P_c(mu_i). Where the widened coat gains energy its
//! lobe is scaled by s(mu_i) s(mu_o) (`crate::compensation::gain`), which changes values
//! and sample weights, not densities.
//!
//! # Smooth coats
//!
//! Below `SMOOTH_ALPHA` the specular part is a mirror (a delta), reached
//! only through `sample`, which flags it (`BsdfSample::is_specular`) with
//! the coin's probability P_s as its discrete pdf, as the smooth dielectric
//! does; `eval` and `pdf` then hold the diffuse part alone. The lobe as a
//! whole is specular (`is_specular`) only when it has no diffuse part
//! (a black or fully metallic base, or a coat that reflects everything).

use std::f32::consts::FRAC_1_PI;

use glam::{Vec2, Vec3};

use crate::compensation::reflection::AlbedoLookup;
use crate::frame::{cosine_hemisphere, reflect, same_hemisphere};
use crate::fresnel::{schlick, schlick_average};
use crate::model::{MicrofacetModel, mixture_pdf};
use crate::sample::{BsdfSample, ONE_MINUS_EPSILON};

/// Smallest probability of either lobe when both can reflect. The coin's
/// estimate P_s uses the Fresnel factor at the macro cosine, which is 0 at
/// normal incidence for F0 = 0 (ior 1) although the lobe reflects at other
/// microfacet angles: a floor keeps every lobe that can be non-zero sampled
/// (the estimator stays unbiased), and bounds the weight f |cos| / pdf of
/// the rarer lobe by 1/0.05 = 20 times its share.
pub(crate) const MIN_LOBE_PROBABILITY: f32 = 0.05;

/// A glTF metallic-roughness lobe (see the module docs).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Coated {
    /// NDF, shadowing and alpha of the specular lobe (glTF: GGX, alpha = r^2).
    pub model: MicrofacetModel,
    /// Base colour in [0, 1]: the diffuse albedo, and the metal's F0.
    pub base_color: Vec3,
    /// Metallic factor m in [0, 1]: the weight of the metal in the mix.
    pub metallic: f32,
    /// `KHR_materials_specular` specularFactor w in [0, 1] (1 without the
    /// extension): the strength of the dielectric coat.
    pub specular: f32,
    /// `KHR_materials_specular` specularColorFactor (1 without the extension):
    /// scales the coat's F0.
    pub specular_color: Vec3,
    /// `KHR_materials_ior` index of the coat (1.5 without the extension;
    /// 0 is the extension's "F0 = 1").
    pub ior: f32,
}

/// Value and both densities of one configuration.
#[derive(Clone, Copy, Debug)]
struct Terms {
    f: Vec3,
    pdf: f32,
    pdf_reverse: f32,
}

impl Coated {
    /// A glTF metallic-roughness lobe (module docs): specular `model` (glTF:
    /// GGX with alpha = r^2, dimensionless), `base_color` in [0, 1] (the
    /// diffuse albedo and the metal's F0), `metallic` in [0, 1] (the metal's
    /// weight in the mix), `KHR_materials_specular`'s `specular` in [0, 1]
    /// and `specular_color` (1 without the extension; scale the coat's F0)
    /// and `KHR_materials_ior`'s `ior` (relative index of the coat, 1.5
    /// without the extension; 0 is the extension's "F0 = 1").
    pub fn new(
        model: MicrofacetModel,
        base_color: Vec3,
        metallic: f32,
        specular: f32,
        specular_color: Vec3,
        ior: f32,
    ) -> Self {
        Self {
            model,
            base_color,
            metallic,
            specular,
            specular_color,
            ior,
        }
    }

    /// The coat's reflectance at normal incidence before the specular
    /// factor: min(((ior - 1)/(ior + 1))^2 specularColor, 1)
    /// (`KHR_materials_specular`, `KHR_materials_ior`).
    pub fn dielectric_f0(&self) -> Vec3 {
        let r = (self.ior - 1.0) / (self.ior + 1.0);
        (r * r * self.specular_color).min(Vec3::ONE)
    }

    /// The coat's Fresnel F_s(c) = w Schlick(F0, c) (`KHR_materials_specular`:
    /// f90 = specularFactor).
    pub fn coat_fresnel(&self, cos: f32) -> Vec3 {
        self.specular * schlick(cos, self.dielectric_f0())
    }

    /// Reflectance that multiplies the specular lobe at microfacet cosine
    /// `cos`: (1 - m) F_s + m F_m (Appendix B's `mix` of the two BRDFs'
    /// specular parts).
    pub fn specular_fresnel(&self, cos: f32) -> Vec3 {
        let metal = schlick(cos, self.base_color);
        self.coat_fresnel(cos).lerp(metal, self.metallic)
    }

    /// 2 int_0^1 `specular_fresnel`(mu) mu dmu, in closed form (both parts
    /// are Schlick: `fresnel::schlick_average`): the colour of the coat's
    /// energy compensation (Kulla & Conty 2017's F_avg).
    pub fn specular_fresnel_average(&self) -> Vec3 {
        let coat = self.specular * schlick_average(self.dielectric_f0());
        coat.lerp(schlick_average(self.base_color), self.metallic)
    }

    /// The coat's transmittance T(mu) = 1 - max_rgb F_s(mu) at macro cosine
    /// `mu` (the `max_value` of `KHR_materials_specular`'s `fresnel_mix`,
    /// so no channel gains energy). Clamped at 0 for factors above 1.
    pub fn coat_transmittance(&self, mu: f32) -> f32 {
        (1.0 - self.coat_fresnel(mu).max_element()).max(0.0)
    }

    /// The coat's cosine-weighted mean transmittance T_avg = 1 - w (F0 + (1 - F0)/21),
    /// F0 = max_rgb `dielectric_f0` (module docs), clamped at 0.
    pub fn coat_mean_transmittance(&self) -> f32 {
        let f0 = self.dielectric_f0().max_element();
        (1.0 - self.specular * (f0 + (1.0 - f0) / 21.0)).max(0.0)
    }

    /// The diffuse albedo under the coat, (1 - m) base.
    pub fn diffuse_albedo(&self) -> Vec3 {
        (1.0 - self.metallic) * self.base_color
    }

    /// True when the diffuse lobe reflects anything.
    pub fn has_diffuse(&self) -> bool {
        self.diffuse_albedo().max_element() > 0.0 && self.coat_mean_transmittance() > 0.0
    }

    /// True when the specular lobe reflects anything: a metal, or a coat of
    /// non-zero strength (whose Fresnel reaches w at grazing angles).
    pub fn has_specular(&self) -> bool {
        self.metallic > 0.0 || self.specular > 0.0
    }

    /// True when the whole lobe is a mirror: a smooth specular lobe with no
    /// diffuse part. A smooth coat over a diffuse base is not (see module docs).
    pub fn is_specular(&self) -> bool {
        self.model.is_smooth() && !self.has_diffuse()
    }

    /// P_s(mu): the probability of sampling the specular lobe for a query
    /// at macro cosine `mu`, the channel mean of F(mu) against that of
    /// (1 - m) base T(mu), kept in `MIN_LOBE_PROBABILITY`,
    /// 1 - `MIN_LOBE_PROBABILITY` when both lobes reflect.
    pub fn specular_probability(&self, mu: f32) -> f32 {
        match (self.has_specular(), self.has_diffuse()) {
            (false, _) => 0.0,
            (true, false) => 1.0,
            (true, true) => {
                let specular = mean(self.specular_fresnel(mu));
                let diffuse = mean(self.diffuse_albedo()) * self.coat_transmittance(mu);
                let p = specular / (specular + diffuse);
                if p.is_finite() {
                    p.clamp(MIN_LOBE_PROBABILITY, 1.0 - MIN_LOBE_PROBABILITY)
                } else {
                    0.5
                }
            }
        }
    }

    /// f(wi, wo) of the module docs; 0 for opposite sides and grazing
    /// directions; for a smooth coat, the diffuse part alone.
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        self.evaluate(wi, wo).map_or(Vec3::ZERO, |t| t.f)
    }

    /// The mixture density P_s(mu_i) p_spec(wo) + (1 - P_s(mu_i)) mu_o/pi,
    /// p_spec = pdf_h(wi, h) / (4 <wo,h>) (SPEC §3); the diffuse part alone
    /// for a smooth coat.
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.evaluate(wi, wo).map_or(0.0, |t| t.pdf)
    }

    /// The specular lobe's own density p_spec(wo) (no lobe probability;
    /// 0 for a smooth coat), for the MIS pdf of a regularized vertex.
    pub fn specular_pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        match self.configuration(wi, wo) {
            Some((wi, _, h)) if !self.model.is_smooth() => {
                self.model.pdf_h(wi, h) / (4.0 * wi.dot(h))
            }
            _ => 0.0,
        }
    }

    /// The diffuse component of the mixture density, (1 - P_s(mu_i)) mu_o/pi
    /// (lobe probability included), for the MIS pdf of a regularized vertex.
    pub fn diffuse_pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if same_hemisphere(wi, wo) {
            (1.0 - self.specular_probability(wi.z.abs())) * wo.z.abs() * FRAC_1_PI
        } else {
            0.0
        }
    }

    /// Picks a lobe with `uc` (specular with probability P_s(mu_i)), then
    /// samples it: a microfacet normal reflected about (or the mirror
    /// direction for a smooth coat), or a cosine-weighted direction. The
    /// returned value and density of a non-delta sample are exactly `eval`
    /// and `pdf` of the returned direction, its reverse density `pdf(wo, wi)`
    /// to rounding (through the pair's half vector), all from one albedo
    /// lookup per direction. `None` for degenerate input and for directions
    /// whose `pdf` is 0.
    pub fn sample(&self, wi: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wi.z == 0.0 {
            return None;
        }
        let side = wi.z.signum();
        let wi = wi * side;
        let p_specular = self.specular_probability(wi.z);
        let at_i = self.model.compensation_lookup(wi.z);
        let wo = if uc < p_specular {
            if self.model.is_smooth() {
                return Some(self.sample_mirror(wi, p_specular, side));
            }
            // The coin's uniform, rescaled to [0, 1), for samplers that need one.
            let uc = (uc / p_specular).min(ONE_MINUS_EPSILON);
            // A regularized coat's compensation lobe, with its share P_c.
            let p_c = self.model.compensation_probability_at(at_i.as_ref());
            if uc < p_c {
                cosine_hemisphere(u)?
            } else {
                let uc = ((uc - p_c) / (1.0 - p_c)).min(ONE_MINUS_EPSILON);
                let h = self.model.sample_h(wi, u, uc)?.h;
                reflect(wi, h).try_normalize()?
            }
        } else {
            cosine_hemisphere(u)?
        };
        if !same_hemisphere(wi, wo) {
            return None;
        }
        let t = self.evaluate_oriented(wi, wo, at_i)?;
        (t.pdf > 0.0).then_some(BsdfSample {
            wo: wo * side,
            f: t.f,
            pdf: t.pdf,
            pdf_reverse: t.pdf_reverse,
            eta: 1.0,
            is_specular: false,
            compensated: None,
        })
    }

    /// The delta of a smooth coat: mirror direction, weight F(mu_i)/mu_i (so
    /// that f mu / pdf = F / P_s), the coin's probability as both pdfs (the
    /// mirror direction has the same mu, so the reverse coin is the same).
    fn sample_mirror(&self, wi: Vec3, p_specular: f32, side: f32) -> BsdfSample {
        BsdfSample {
            wo: Vec3::new(-wi.x, -wi.y, wi.z) * side,
            f: self.specular_fresnel(wi.z) / wi.z,
            pdf: p_specular,
            pdf_reverse: p_specular,
            eta: 1.0,
            is_specular: true,
            compensated: None,
        }
    }

    /// Value, forward and reverse mixture pdf of a pair on the same side.
    fn evaluate(&self, wi: Vec3, wo: Vec3) -> Option<Terms> {
        if !same_hemisphere(wi, wo) {
            return None;
        }
        let side = wi.z.signum();
        let (wi, wo) = (wi * side, wo * side);
        self.evaluate_oriented(wi, wo, self.model.compensation_lookup(wi.z))
    }

    /// `evaluate` of a pair above the surface, with the compensation's
    /// lookup at wi (`at_i`, which a sampler has already made for its
    /// coin): with the one at wo, all that the value and both densities
    /// read of the tables.
    fn evaluate_oriented(&self, wi: Vec3, wo: Vec3, at_i: Option<AlbedoLookup>) -> Option<Terms> {
        let at_o = self.model.compensation_lookup(wo.z);
        let (at_i, at_o) = (at_i.as_ref(), at_o.as_ref());
        let (p_i, p_o) = (
            self.specular_probability(wi.z),
            self.specular_probability(wo.z),
        );
        let diffuse_f = if self.has_diffuse() {
            self.diffuse_albedo()
                * (self.coat_transmittance(wi.z) * self.coat_transmittance(wo.z)
                    / self.coat_mean_transmittance()
                    * FRAC_1_PI)
        } else {
            Vec3::ZERO
        };
        let mut terms = Terms {
            f: diffuse_f,
            pdf: (1.0 - p_i) * wo.z * FRAC_1_PI,
            pdf_reverse: (1.0 - p_o) * wi.z * FRAC_1_PI,
        };
        // The coat's compensation: s(mu_i) s(mu_o) scales its lobe where
        // the widened coat gains energy (`crate::compensation::gain`; exactly 1
        // otherwise), and the compensation lobe belongs to it: its value is
        // added and its density shares the specular coin.
        let (scale, compensation) = self.model.compensation_terms_at(at_i, at_o);
        let (specular_pdf, specular_pdf_reverse) = match self.configuration(wi, wo) {
            Some((wi, wo, h)) if !self.model.is_smooth() => {
                let facet = self.model.facet_terms(wi, wo, h);
                let wi_h = wi.dot(h);
                terms.f +=
                    self.specular_fresnel(wi_h) * (facet.d * facet.g / (4.0 * wi.z * wo.z) * scale);
                // <wo,h> = <wi,h> for a reflection.
                (facet.pdf_h_wi / (4.0 * wi_h), facet.pdf_h_wo / (4.0 * wi_h))
            }
            _ => (0.0, 0.0),
        };
        terms.f += compensation;
        let [p_c_i, p_c_o] = [at_i, at_o].map(|at| self.model.compensation_probability_at(at));
        terms.pdf += p_i * mixture_pdf(p_c_i, wi, wo, specular_pdf).pdf();
        terms.pdf_reverse += p_o * mixture_pdf(p_c_o, wo, wi, specular_pdf_reverse).pdf();
        (terms.f.is_finite() && terms.pdf.is_finite() && terms.pdf_reverse.is_finite())
            .then_some(terms)
    }

    /// (wi, wo, h) flipped to the upper hemisphere, if they form a valid
    /// microfacet reflection: same side, front-facing microfacet.
    fn configuration(&self, wi: Vec3, wo: Vec3) -> Option<(Vec3, Vec3, Vec3)> {
        if !same_hemisphere(wi, wo) {
            return None;
        }
        let side = wi.z.signum();
        let (wi, wo) = (wi * side, wo * side);
        let h = (wi + wo).try_normalize()?;
        (wi.dot(h) > 0.0 && h.z > 0.0).then_some((wi, wo, h))
    }
}

/// Channel mean of an RGB value.
fn mean(c: Vec3) -> f32 {
    (c.x + c.y + c.z) / 3.0
}
