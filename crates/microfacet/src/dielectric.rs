//! Glass-like interfaces: rough dielectric reflection and Walter et al.'s
//! transmission (SPEC §3, supp. §3), or smooth reflection/refraction when alpha
//! is below `SMOOTH_ALPHA`.
//!
//! The side of the surface a direction is on decides the indices: `eta` is
//! the index below the surface (-z) over the index above it (+z); a query
//! from below sees 1/eta. Reflection is chosen with probability F and
//! refraction with 1 - F, and the pdfs carry those factors (SPEC §3).
//!
//! `tint` multiplies the refracted part only (Khronos glTF 2.0
//! KHR_materials_transmission: `specular_btdf(alpha) * baseColor`; the
//! reflection is not tinted), in both transport modes and whichever side
//! light crosses from; the sampling is unchanged (Fresnel decides), so only
//! the value and the sample weight carry it. White leaves every value as the
//! untinted lobe's, bit for bit.
//!
//! A regularized interface may carry an energy compensation lobe
//! (`crate::compensation::dielectric_energy`): its value is added (its transmitted part
//! tinted like the refraction), and sampling picks it with probability
//! P_c(mu_i) (a cosine-weighted direction on the side its own coin picks), so
//! `pdf` is the mixture (1 - P_c) p_lobe + P_c p_compensation.

use glam::{DVec3, Vec2, Vec3};

use crate::compensation::DielectricCompensation;
use crate::frame::{cosine_hemisphere, reflect, refract_f64};
use crate::fresnel;
use crate::model::MicrofacetModel;
use crate::sample::{BsdfSample, ONE_MINUS_EPSILON, TransportMode};

/// Interfaces with |eta - 1| below this are index-matched (SPEC §5): the lobe
/// is treated as smooth (a delta), whatever its roughness. The refraction
/// Jacobian grows like 1/(eta - 1)^2 (SPEC §4), so below 1e-3 the rough
/// transmission lobe is narrower than f32 directions resolve (densities up to
/// 1e17 at |eta - 1| = 1e-7, where sample and pdf disagreed by 100 %) and no
/// roughness can blur it; the same value makes `regularization` skip such
/// interfaces (its `INDEX_MATCH_EPSILON`, SPEC §5).
pub const INDEX_MATCH_EPSILON: f32 = 1e-3;

/// A dielectric interface lobe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Microfacet distribution and shadowing.
    pub model: MicrofacetModel,
    /// Index below the surface over index above it; must be finite and > 0.
    pub eta: f32,
    /// Colour of the transmitted part (glTF's base colour on a transmissive
    /// material), each channel in [0, 1]; `Vec3::ONE` for clear glass.
    pub tint: Vec3,
    /// The energy compensation of a regularized interface
    /// (`crate::compensation::dielectric_energy`); `None` for every lobe a material
    /// defines, and for one regularized without compensation.
    pub compensation: Option<DielectricCompensation>,
}

/// f, forward pdf and reverse pdf of one configuration.
struct Terms {
    f: f32,
    pdf: f32,
    pdf_reverse: f32,
}

impl Dielectric {
    /// A clear (untinted) interface with microfacet distribution and
    /// shadowing `model` (alpha dimensionless) and index ratio `eta`: the
    /// index below the surface over the index above (seen from above;
    /// 1/`eta` from below), dimensionless, > 0. Without compensation until
    /// `regularized` widens it.
    pub const fn new(model: MicrofacetModel, eta: f32) -> Self {
        Self {
            model,
            eta,
            tint: Vec3::ONE,
            compensation: None,
        }
    }

    /// The interface widened to `alpha_hat` with the energy compensation
    /// that keeps its energy albedo (`crate::compensation::dielectric_energy`); without
    /// compensation when alpha-hat does not exceed alpha, and for an
    /// index-matched interface (a pass-through that regularization skips).
    ///
    /// First use: builds the energy tables it reads, once per process
    /// (`crate::compensation::tables`: seconds in a release build, 10-20x
    /// longer unoptimised); [`crate::prepare_tables`] builds them ahead.
    pub fn regularized(&self, alpha_hat: f32) -> Self {
        let model = self.model.with_alpha(alpha_hat);
        let compensation = if self.is_index_matched() {
            None
        } else {
            DielectricCompensation::new(&model.ndf, model.shadowing, self.model.alpha(), self.eta)
        };
        Self {
            model,
            compensation,
            ..*self
        }
    }

    /// The same interface with width `alpha` and no compensation (how
    /// regularization applies alpha-hat when energy is not compensated).
    pub fn with_alpha(&self, alpha: f32) -> Self {
        Self {
            model: self.model.with_alpha(alpha),
            compensation: None,
            ..*self
        }
    }

    /// The same interface with the transmitted part tinted by `tint`.
    pub const fn with_tint(self, tint: Vec3) -> Self {
        Self { tint, ..self }
    }

    /// True for a smooth interface, and for an index-matched one
    /// (|eta - 1| < `INDEX_MATCH_EPSILON`, SPEC §5), whose transmission is a
    /// (nearly) straight pass-through at any roughness. Both are sampled as a
    /// smooth interface with the lobe's own eta: the pass-through with weight
    /// 1 at eta = 1 exactly; Snell refraction, Fresnel and total internal
    /// reflection otherwise. `eval` and `pdf` are 0 for them.
    pub fn is_specular(&self) -> bool {
        self.model.is_smooth() || self.is_index_matched()
    }

    /// |eta - 1| < `INDEX_MATCH_EPSILON` (SPEC §5).
    pub fn is_index_matched(&self) -> bool {
        (self.eta - 1.0).abs() < INDEX_MATCH_EPSILON
    }

    /// f(wi, wo) (SPEC §3): F D G / (4 |cos_i cos_o|) for reflection;
    /// |<wi,h><wo,h>| / |cos_i cos_o| (1 - F) D G / (<wi,h> + eta <wo,h>)^2 for
    /// refraction in Radiance mode, times eta^2 in Importance mode
    /// (eta = eta_t/eta_i; equivalent to SPEC's eta_i^2, eta_t^2 numerators);
    /// the refraction value times `tint` (module docs); for a regularized
    /// interface, the lobe scaled by s(wi) s(wo) where it gains
    /// (`crate::compensation::dielectric_gain`) plus the compensation lobe.
    pub fn eval(&self, wi: Vec3, wo: Vec3, mode: TransportMode) -> Vec3 {
        let refracted = wi.z * wo.z < 0.0;
        let lobe = self.evaluate(wi, wo, mode).map_or(0.0, |t| t.f);
        if self.compensation.is_none() {
            return self.colour(lobe, refracted);
        }
        let (scale, compensation) = self.compensation_terms(wi, wo, mode);
        self.colour(scale * lobe + compensation, refracted)
    }

    /// A scalar value of the lobe as a colour: times `tint` when `refracted`.
    fn colour(&self, f: f32, refracted: bool) -> Vec3 {
        if refracted {
            self.tint * f
        } else {
            Vec3::splat(f)
        }
    }

    /// Density of `wo` given `wi`: pdf_h(wi,h)/(4<wo,h>) F for reflection,
    /// pdf_h(wi,h) eta^2 |<wo,h>| / (<wi,h> + eta <wo,h>)^2 (1 - F) for refraction.
    /// With compensation, the mixture of the module docs.
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let lobe = self
            .evaluate(wi, wo, TransportMode::Radiance)
            .map_or(0.0, |t| t.pdf);
        self.with_compensation_pdf(wi, wo, lobe)
    }

    /// (s(wi) s(wo), f_c(wi, wo)) of a compensated interface: the factor of
    /// the widened lobe's value and the compensation lobe's value, untinted
    /// (`eval` is `tint`-coloured (scale f + f_c) through refraction); (1, 0)
    /// without compensation.
    pub fn compensation_terms(&self, wi: Vec3, wo: Vec3, mode: TransportMode) -> (f32, f32) {
        self.compensation.map_or((1.0, 0.0), |c| {
            c.terms(
                &self.model.ndf,
                self.model.shadowing,
                self.eta,
                wi,
                wo,
                mode,
            )
        })
    }

    /// P_c(wi), the probability of sampling the compensation lobe for a
    /// query from `wi` (0 without compensation).
    pub fn compensation_probability(&self, wi: Vec3) -> f32 {
        self.compensation.map_or(0.0, |c| {
            c.probability(&self.model.ndf, self.model.shadowing, self.eta, wi)
        })
    }

    /// The mixture density (1 - P_c(wi)) `p_lobe` + P_c(wi) p_c(wi, wo) of a
    /// compensated interface (`p_lobe` unchanged without compensation), for
    /// `pdf` and for p-hat at a regularized vertex.
    pub fn with_compensation_pdf(&self, wi: Vec3, wo: Vec3, p_lobe: f32) -> f32 {
        let Some(c) = self.compensation else {
            return p_lobe;
        };
        c.mixture_pdf(self.compensation_probability(wi), wi, wo, p_lobe)
            .pdf()
    }

    /// Samples reflection or refraction through a sampled microfacet normal
    /// (or through the macro normal when smooth or index-matched). `None` on
    /// degenerate input, for a sample that ends on the wrong side of the
    /// surface, and for a direction whose `pdf` is 0: rounding at grazing
    /// angles, or a microfacet within f32 rounding of the horizon (h.z below
    /// ~1e-7, e.g. GGX at u.x = 1 - 2^-24, u.y = 3/4), whose half vector
    /// recovered from the rounded wo can come out below it. A returned sample's pdf, reverse pdf and value are exactly
    /// `pdf(wi, wo)`, `pdf(wo, wi)` and `eval(wi, wo)`. A compensated
    /// interface samples the mixture of the module docs (`sample_compensated`).
    pub fn sample(&self, wi: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        match self.compensation {
            Some(c) if !self.is_specular() => self.sample_compensated(&c, wi, uc, u, mode),
            _ => self.sample_lobe(wi, uc, u, mode),
        }
    }

    /// Sampling with a compensation lobe: the coin `uc` picks it with
    /// probability P_c(mu_i), then (rescaled) transmission with probability
    /// t_s and a cosine-weighted direction on the chosen side; otherwise the
    /// microfacet lobe (`uc` rescaled for its sampler). Value and both
    /// densities are those of the mixture, `eval`, `pdf` and `pdf` reversed,
    /// from one albedo lookup at wi and one at wo.
    fn sample_compensated(
        &self,
        c: &DielectricCompensation,
        wi: Vec3,
        uc: f32,
        u: Vec2,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        if wi.z == 0.0 {
            return None;
        }
        let at_i = c.lookup(&self.model.ndf, self.model.shadowing, self.eta, wi);
        let p_c = c.probability_at(&at_i);
        let wo = if uc < p_c {
            let side = crate::compensation::dielectric_energy::side(wi);
            let transmitted = uc / p_c < c.transmitted_share(side);
            let w = cosine_hemisphere(u)? * wi.z.signum();
            if transmitted { -w } else { w }
        } else {
            let uc = ((uc - p_c) / (1.0 - p_c)).min(ONE_MINUS_EPSILON);
            self.sample_lobe(wi, uc, u, mode)?.wo
        };
        let at_o = c.lookup(&self.model.ndf, self.model.shadowing, self.eta, wo);
        // The lobe's pdf does not depend on the mode; its reverse density is
        // `pdf`'s own query from wo.
        let (lobe_f, lobe_pdf) = self
            .evaluate(wi, wo, mode)
            .map_or((0.0, 0.0), |t| (t.f, t.pdf));
        let lobe_pdf_reverse = self
            .evaluate(wo, wi, TransportMode::Radiance)
            .map_or(0.0, |t| t.pdf);
        let mixture = [
            c.mixture_pdf(p_c, wi, wo, lobe_pdf),
            c.mixture_pdf(c.probability_at(&at_o), wo, wi, lobe_pdf_reverse),
        ];
        let [pdf, pdf_reverse] = mixture.map(|m| m.pdf());
        let (scale, compensation) = c.terms_at(
            &self.model.ndf,
            self.model.shadowing,
            self.eta,
            &at_i,
            &at_o,
            mode,
        );
        let refracted = wi.z * wo.z < 0.0;
        let f = self.colour(scale * lobe_f + compensation, refracted);
        let eta = if !refracted {
            1.0
        } else if wi.z > 0.0 {
            self.eta
        } else {
            1.0 / self.eta
        };
        (pdf > 0.0 && pdf.is_finite() && pdf_reverse.is_finite() && f.is_finite()).then_some(
            BsdfSample {
                wo,
                f,
                pdf,
                pdf_reverse,
                eta,
                is_specular: false,
                compensated: Some(mixture),
            },
        )
    }

    /// The microfacet lobe's own sampler (the module's lobe without the
    /// compensation; see `sample`).
    fn sample_lobe(&self, wi: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
        let (side, wi, eta) = self.oriented(wi)?;
        if self.is_specular() {
            return self.sample_smooth(wi, eta, uc, mode).map(|s| BsdfSample {
                wo: s.wo * side,
                ..s
            });
        }
        let half = self.model.sample_h(wi, u, uc)?;
        let h = half.h;
        let wi_h = wi.dot(h);
        if wi_h <= 0.0 {
            return None;
        }
        // F in f32 for the coin, as in `sample_smooth`.
        let reflected = half.uc < fresnel::dielectric_f64(f64::from(wi_h), eta).0 as f32;
        let wo = if reflected {
            reflect(wi, h).try_normalize()?
        } else {
            refract_f64(wi, h, eta)?
        };
        // A reflection below or a refraction above the surface is discarded
        // (SPEC §3); checked here because `half_vector` below reads the side
        // of wo as the choice between reflection and refraction.
        if (wo.z > 0.0) != reflected {
            return None;
        }
        // Value and pdfs of the returned (rounded) direction, through the
        // half vector that `eval` and `pdf` recover from it, so that the
        // sample's pdf is exactly `pdf(wi, wo)`: near eta = 1 the sampled h and
        // the one implied by the rounded wo differ (pdfs by 2 % at eta = 1.001).
        let t = self.terms(wi, wo, half_vector(wi, wo, eta)?, eta, mode)?;
        // At grazing angles the recovered h can miss a narrow lobe entirely
        // (wi + wo of length 1e-6 carries f32 errors of 6e-8): `pdf` is then 0
        // for this direction, and so the sampler must not return it.
        if !(t.pdf > 0.0) {
            return None;
        }
        Some(BsdfSample {
            wo: wo * side,
            f: self.colour(t.f, !reflected),
            pdf: t.pdf,
            pdf_reverse: t.pdf_reverse,
            eta: if reflected { 1.0 } else { eta as f32 },
            is_specular: false,
            compensated: None,
        })
    }

    /// Fresnel-weighted choice between mirror reflection and refraction
    /// through the macro normal (wi above the surface, eta = eta_t/eta_i).
    /// Reflectance and transmittance come from the f64 Fresnel (each exact
    /// to f32 rounding, also where F -> 1 near the critical angle).
    fn sample_smooth(
        &self,
        wi: Vec3,
        eta: f64,
        uc: f32,
        mode: TransportMode,
    ) -> Option<BsdfSample> {
        let (f, t) = fresnel::dielectric_f64(f64::from(wi.z), eta);
        // The coin compares with F in f32: a branch chosen this way has an
        // f32 probability above 0 (F > uc >= 0, or F <= 1 - 2^-24 and so
        // 1 - F >= 2^-25).
        let (f, t) = (f as f32, t as f32);
        if uc < f {
            return Some(BsdfSample {
                wo: Vec3::new(-wi.x, -wi.y, wi.z),
                f: Vec3::splat(f / wi.z),
                pdf: f,
                pdf_reverse: f,
                eta: 1.0,
                is_specular: true,
                compensated: None,
            });
        }
        let wo = refract_f64(wi, Vec3::Z, eta)?;
        let eta = eta as f32;
        let scale = match mode {
            TransportMode::Radiance => 1.0 / (eta * eta),
            TransportMode::Importance => 1.0,
        };
        Some(BsdfSample {
            wo,
            f: self.colour(t * scale / wo.z.abs(), true),
            pdf: t,
            pdf_reverse: t,
            eta,
            is_specular: true,
            compensated: None,
        })
    }

    /// Value and both pdfs for a query pair, after orienting wi upwards and
    /// finding the generalized half vector.
    fn evaluate(&self, wi: Vec3, wo: Vec3, mode: TransportMode) -> Option<Terms> {
        if self.is_specular() {
            return None;
        }
        let (side, wi, eta) = self.oriented(wi)?;
        let wo = wo * side;
        self.terms(wi, wo, half_vector(wi, wo, eta)?, eta, mode)
    }

    /// The core shared by `eval`, `pdf` and `sample`: wi above the surface,
    /// `half` the oriented microfacet normal, eta = eta_t/eta_i.
    fn terms(
        &self,
        wi: Vec3,
        wo: Vec3,
        half: Half,
        eta: f64,
        mode: TransportMode,
    ) -> Option<Terms> {
        let h = half.h;
        let (wi_h, wo_h) = (half.wi_h as f32, half.wo_h as f32);
        // Discard back-facing microfacets (SPEC §3).
        if !(h.z > 0.0 && wi_h > 0.0 && wo_h * wo.z > 0.0) {
            return None;
        }
        let (cos_i, cos_o) = (wi.z, wo.z.abs());
        // F and 1 - F each to f32 precision (1 - F from an f32 F is not,
        // near the critical angle).
        let (f_r, t) = fresnel::dielectric_f64(half.wi_h, eta);
        let (f_r, t, eta) = (f_r as f32, t as f32, eta as f32);
        let facet = self.model.facet_terms(wi, wo, h);
        let terms = if wo.z > 0.0 {
            Terms {
                f: f_r * facet.d * facet.g / (4.0 * cos_i * cos_o),
                pdf: facet.pdf_h_wi / (4.0 * wi_h) * f_r,
                pdf_reverse: facet.pdf_h_wo / (4.0 * wo_h) * f_r,
            }
        } else {
            // (<wi,h> + eta <wo,h>)^2 = |wi + eta wo|^2 (h is its direction),
            // from the f64 sum: in f32 the dot products cancel as eta -> 1.
            let denominator2 = half.sum2 as f32;
            let radiance =
                facet.d * facet.g * t * (wi_h * wo_h).abs() / (cos_i * cos_o * denominator2);
            Terms {
                f: match mode {
                    TransportMode::Radiance => radiance,
                    TransportMode::Importance => radiance * eta * eta,
                },
                pdf: facet.pdf_h_wi * eta * eta * wo_h.abs() / denominator2 * t,
                // The reverse query comes from -wo above the flipped surface,
                // through the same microfacet with 1/eta (SPEC §3).
                pdf_reverse: facet.pdf_h_wo * wi_h / denominator2 * t,
            }
        };
        // Near eta = 1 the refracted lobe is nearly a delta and its density can
        // exceed f32; such a configuration is dropped rather than returned as inf.
        (terms.f.is_finite() && terms.pdf.is_finite() && terms.pdf_reverse.is_finite())
            .then_some(terms)
    }

    /// (sign of wi.z, wi flipped upwards, eta seen from wi), or `None` for a
    /// direction in the tangent plane or an invalid index. The index is
    /// returned in f64: the f32 1/eta of a query from below is off by up to
    /// 6e-8 relative, which moves cos^2(theta_t) near the critical angle by
    /// as much as f32 round-off did (see `frame::cos2_theta_t`).
    fn oriented(&self, wi: Vec3) -> Option<(f32, Vec3, f64)> {
        if wi.z == 0.0 || !(self.eta > 0.0 && self.eta.is_finite()) {
            return None;
        }
        let side = wi.z.signum();
        Some((
            side,
            wi * side,
            if side > 0.0 {
                f64::from(self.eta)
            } else {
                1.0 / f64::from(self.eta)
            },
        ))
    }
}

/// A microfacet normal recovered from a pair of directions.
#[derive(Clone, Copy, Debug)]
struct Half {
    /// The oriented normal, h.z > 0.
    h: Vec3,
    /// |wi + wo|^2 for reflection, |wi + eta wo|^2 for refraction: the
    /// squared denominator (<wi,h> + eta <wo,h>)^2 of SPEC §3's refraction
    /// terms, in f64 (see `half_vector`).
    sum2: f64,
    /// <wi,h> and <wo,h> from the f64 normal: Fresnel needs them to more
    /// than f32 precision where the microfacet is seen at grazing incidence
    /// or near the critical angle (forward and reverse query then agree).
    wi_h: f64,
    wo_h: f64,
}

/// The oriented microfacet normal of a pair (wi above the surface, eta =
/// eta_t/eta_i; SPEC §3): h ~ wi + wo for reflection, h ~ eta_i wi + eta_t wo
/// ~ wi + eta wo for refraction, flipped so that h.z > 0. The sum is formed in
/// f64: near eta = 1 it cancels to |eta - 1| of the inputs' size, and in f32
/// its direction would carry a relative error of 6e-8/|eta - 1| (6e-5 at
/// eta = 1.001, enough to move D by 2 % at alpha = 0.01), different for the
/// forward and the reverse query of one pair. Also returns <wi,h> and <wo,h>
/// in f64. `None` for wo in the tangent plane or a zero-length sum (wo = -wi
/// at eta = 1).
fn half_vector(wi: Vec3, wo: Vec3, eta: f64) -> Option<Half> {
    if wo.z == 0.0 {
        return None;
    }
    // Unit length in f64 first: an f32 direction's length is off by up to
    // 1e-7, and <wi,h> - <wo,h> = (|wi|^2 - |wo|^2)/|wi + wo| for reflection,
    // 3e-6 when grazing directions nearly cancel; near the critical angle
    // that moved F by 1e-3 between the forward and the reverse query.
    let (wi, wo) = (
        wi.as_dvec3().try_normalize()?,
        wo.as_dvec3().try_normalize()?,
    );
    let sum: DVec3 = if wo.z > 0.0 { wi + wo } else { wi + eta * wo };
    let h = sum.try_normalize()?;
    let h = if h.z < 0.0 { -h } else { h };
    Some(Half {
        h: h.as_vec3(),
        sum2: sum.length_squared(),
        wi_h: h.dot(wi),
        wo_h: h.dot(wo),
    })
}
