//! Metal: Torrance-Sparrow microfacet reflection (SPEC §3), or a perfect
//! mirror when alpha is below `SMOOTH_ALPHA`. Two-sided.
//!
//! A regularized conductor may carry an energy compensation lobe
//! (`crate::compensation::energy`, tinted with `Fresnel::average`): its value is added,
//! and sampling picks it with probability P_c(mu_i) (cosine-weighted
//! directions), so `pdf` is the mixture (1 - P_c) p_spec + P_c mu_o/pi.
//! Where the widened lobe gains energy its value is scaled by s(mu_i)
//! s(mu_o) (`crate::compensation::gain`): the sample's weight changes, its pdfs do not.

use glam::{Vec2, Vec3};

use crate::compensation::Compensation;
use crate::frame::{cosine_hemisphere, reflect, same_hemisphere};
use crate::fresnel::Fresnel;
use crate::model::{MicrofacetModel, mixture_pdf};
use crate::sample::{BsdfSample, ONE_MINUS_EPSILON};

/// A conductor lobe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Conductor {
    /// Microfacet distribution and shadowing.
    pub model: MicrofacetModel,
    /// Reflectance model.
    pub fresnel: Fresnel,
}

impl Conductor {
    /// A conductor of microfacet distribution and shadowing `model` (alpha
    /// is the microfacet width, dimensionless) with reflectance `fresnel`
    /// (Schlick's F0 per channel in [0, 1], or a complex index eta + i k
    /// relative to the outside medium, SPEC §3); unregularized, without
    /// compensation until `Bsdf::regularized` widens it.
    pub fn new(model: MicrofacetModel, fresnel: Fresnel) -> Self {
        Self { model, fresnel }
    }

    /// True when the lobe is a perfect mirror.
    pub fn is_specular(&self) -> bool {
        self.model.is_smooth()
    }

    /// f_r = F(<wi,h>) D(h) G(wi,wo) / (4 |<wi,n><wo,n>|), h = normalize(wi + wo)
    /// (SPEC §3); for a regularized conductor scaled by s(mu_i) s(mu_o),
    /// plus the compensation lobe (module docs). 0 for opposite sides,
    /// grazing directions, or a mirror.
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        self.value(wi, wo, self.model.compensation_terms(wi, wo))
    }

    /// `eval` from the compensation's (scale, value) of the pair.
    fn value(&self, wi: Vec3, wo: Vec3, (scale, compensation): (f32, Vec3)) -> Vec3 {
        let specular = match self.configuration(wi, wo) {
            Some((wi, wo, h)) => {
                let t = self.model.facet_terms(wi, wo, h);
                self.fresnel.eval(wi.dot(h)) * t.d * t.g / (4.0 * wi.z * wo.z) * scale
            }
            None => Vec3::ZERO,
        };
        specular + compensation
    }

    /// pdf(wo) = pdf_h(wi, h) / (4 <wo,h>) (SPEC §3); with compensation the
    /// mixture of the module docs.
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.model
            .with_compensation_pdf(wi, wo, self.specular_pdf(wi, wo))
    }

    /// The microfacet lobe's own density (`pdf` without compensation).
    fn specular_pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        match self.configuration(wi, wo) {
            Some((wi, _, h)) => self.model.pdf_h(wi, h) / (4.0 * wi.dot(h)),
            None => 0.0,
        }
    }

    /// Samples a microfacet normal and reflects wi about it.
    pub fn sample(&self, wi: Vec3, uc: f32, u: Vec2) -> Option<BsdfSample> {
        if wi.z == 0.0 {
            return None;
        }
        let side = wi.z.signum();
        let wi = wi * side;
        if self.is_specular() {
            let wo = Vec3::new(-wi.x, -wi.y, wi.z);
            return Some(BsdfSample {
                wo: wo * side,
                f: self.fresnel.eval(wi.z) / wi.z,
                pdf: 1.0,
                pdf_reverse: 1.0,
                eta: 1.0,
                is_specular: true,
                compensated: None,
            });
        }
        if let Some(c) = self.model.compensation {
            return self.sample_compensated(&c, wi, uc, u).map(|s| BsdfSample {
                wo: s.wo * side,
                ..s
            });
        }
        let h = self.model.sample_h(wi, u, uc)?.h;
        let wi_h = wi.dot(h);
        let wo = reflect(wi, h).try_normalize()?;
        if !(wi_h > 0.0 && wo.z > 0.0) {
            return None;
        }
        let t = self.model.facet_terms(wi, wo, h);
        Some(BsdfSample {
            wo: wo * side,
            f: self.fresnel.eval(wi_h) * t.d * t.g / (4.0 * wi.z * wo.z),
            pdf: t.pdf_h_wi / (4.0 * wi_h),
            pdf_reverse: t.pdf_h_wo / (4.0 * wi_h),
            eta: 1.0,
            is_specular: false,
            compensated: None,
        })
    }

    /// Sampling with a compensation lobe (wi above the surface): the coin
    /// `uc` picks it with probability P_c(mu_i) (a cosine-weighted
    /// direction) or the microfacet lobe (`uc` rescaled for its sampler);
    /// value and both densities are those of the mixture, `eval`, `pdf` and
    /// `pdf` reversed, from one albedo lookup at mu_i and one at mu_o.
    fn sample_compensated(
        &self,
        c: &Compensation,
        wi: Vec3,
        uc: f32,
        u: Vec2,
    ) -> Option<BsdfSample> {
        let at_i = c.lookup(&self.model.ndf, self.model.shadowing, wi.z);
        let p_c = c.probability_at(&at_i);
        let wo = if uc < p_c {
            cosine_hemisphere(u)?
        } else {
            let uc = ((uc - p_c) / (1.0 - p_c)).min(ONE_MINUS_EPSILON);
            let h = self.model.sample_h(wi, u, uc)?.h;
            let wo = reflect(wi, h).try_normalize()?;
            if !(wi.dot(h) > 0.0 && wo.z > 0.0) {
                return None;
            }
            wo
        };
        let at_o = c.lookup(&self.model.ndf, self.model.shadowing, wo.z.abs());
        let mixture = [
            mixture_pdf(p_c, wi, wo, self.specular_pdf(wi, wo)),
            mixture_pdf(c.probability_at(&at_o), wo, wi, self.specular_pdf(wo, wi)),
        ];
        let [pdf, pdf_reverse] = mixture.map(|m| m.pdf());
        let terms = if same_hemisphere(wi, wo) {
            let (scale, value) = c.terms_at(&self.model.ndf, self.model.shadowing, &at_i, &at_o);
            (scale, c.tint * value)
        } else {
            (1.0, Vec3::ZERO)
        };
        let f = self.value(wi, wo, terms);
        (pdf > 0.0 && f.is_finite()).then_some(BsdfSample {
            wo,
            f,
            pdf,
            pdf_reverse,
            eta: 1.0,
            is_specular: false,
            compensated: Some(mixture),
        })
    }

    /// (wi, wo, h) flipped to the upper hemisphere, if they form a valid
    /// rough reflection: same side, not grazing, front-facing microfacet.
    fn configuration(&self, wi: Vec3, wo: Vec3) -> Option<(Vec3, Vec3, Vec3)> {
        if self.is_specular() || !same_hemisphere(wi, wo) {
            return None;
        }
        let side = wi.z.signum();
        let (wi, wo) = (wi * side, wo * side);
        let h = (wi + wo).try_normalize()?;
        (wi.dot(h) > 0.0 && h.z > 0.0).then_some((wi, wo, h))
    }
}
