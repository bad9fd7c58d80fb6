//! A microfacet surface model: an NDF together with a shadowing model, and
//! the visible-normal sampler that belongs to the pair (SPEC §1-§2).

use glam::{Vec2, Vec3};

use crate::compensation::reflection::{AlbedoLookup, Compensation};
use crate::frame::same_hemisphere;
use crate::ndf::{Ndf, NdfKind};
use crate::sample::MixturePdf;
use crate::shadowing::Shadowing;
use crate::vndf;

/// Re-exported where lobes are built (`MicrofacetModel::is_smooth`).
pub use crate::ndf::SMOOTH_ALPHA;

/// NDF + shadowing: everything a Torrance-Sparrow or Walter lobe needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MicrofacetModel {
    /// The normal distribution.
    pub ndf: Ndf,
    /// The masking-shadowing model.
    pub shadowing: Shadowing,
    /// The energy compensation of a regularized model (`compensation`).
    pub(crate) compensation: Option<Compensation>,
}

/// D, G and both microfacet-normal densities of one configuration (wi, wo, h),
/// computed once for a lobe's value, forward pdf and reverse pdf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct FacetTerms {
    /// D(h).
    pub d: f32,
    /// G(wi, wo) for reflection or transmission, as the sides of wi and wo say.
    pub g: f32,
    /// `pdf_h` for the query from wi.
    pub pdf_h_wi: f32,
    /// `pdf_h` for the reverse query from wo (seen from its own side).
    pub pdf_h_wo: f32,
}

/// A sampled microfacet normal and a fresh uniform for later choices.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HalfVectorSample {
    /// The microfacet normal, h.z >= 0.
    pub h: Vec3,
    /// A uniform in [0, 1) independent of `h` (the input `uc`, rescaled if
    /// the sampler consumed part of it).
    pub uc: f32,
}

impl MicrofacetModel {
    /// A model with NDF `kind` of width `alpha` (see `Ndf::new` for clamping).
    pub fn new(kind: NdfKind, alpha: f32, shadowing: Shadowing) -> Self {
        Self {
            ndf: Ndf::new(kind, alpha),
            shadowing,
            compensation: None,
        }
    }

    /// The energy compensation of a regularized model
    /// (`crate::compensation::reflection`): `None` for every model a material
    /// defines, and for a regularized one built without compensation. Set
    /// only by `regularized`, so it always belongs to this model's NDF.
    pub fn compensation(&self) -> Option<Compensation> {
        self.compensation
    }

    /// The width alpha.
    pub fn alpha(&self) -> f32 {
        self.ndf.alpha()
    }

    /// The same model with another alpha (how regularization applies
    /// alpha-hat when energy is not compensated); no compensation.
    pub fn with_alpha(&self, alpha: f32) -> Self {
        Self {
            ndf: self.ndf.with_alpha(alpha),
            shadowing: self.shadowing,
            compensation: None,
        }
    }

    /// The model at `alpha_hat` with the energy compensation that keeps the
    /// white albedo of this model (`crate::compensation`), coloured `tint` (the
    /// lobe's Fresnel average); without compensation when alpha-hat does
    /// not exceed alpha.
    ///
    /// First use: builds the energy tables it reads, once per process
    /// (`crate::compensation::tables`: seconds in a release build, 10-20x
    /// longer unoptimised); [`crate::prepare_tables`] builds them ahead.
    pub fn regularized(&self, alpha_hat: f32, tint: Vec3) -> Self {
        let mut model = self.with_alpha(alpha_hat);
        model.compensation = Compensation::new(&model.ndf, model.shadowing, self.alpha())
            .map(|c| Compensation { tint, ..c });
        model
    }

    /// The probability of sampling the compensation lobe for a query at
    /// macro cosine `mu_i` (0 without compensation).
    pub fn compensation_probability(&self, mu_i: f32) -> f32 {
        self.compensation
            .map_or(0.0, |c| c.probability(&self.ndf, self.shadowing, mu_i))
    }

    /// s(mu_i) s(mu_o), the reciprocal scaling of a widened lobe that gains
    /// energy (`crate::compensation::gain`): multiplies the microfacet lobe's value and a
    /// sample's weight, never its pdf. Exactly 1 for every other model.
    pub fn lobe_scale(&self, mu_i: f32, mu_o: f32) -> f32 {
        match self.compensation {
            Some(c) if c.scaled => c.terms(&self.ndf, self.shadowing, mu_i, mu_o).0,
            _ => 1.0,
        }
    }

    /// The compensation lobe's value f_c(wi, wo) with its tint, for
    /// directions on the same side (0 otherwise and without compensation).
    pub fn compensation_value(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        self.compensation_terms(wi, wo).1
    }

    /// (`lobe_scale`, `compensation_value`) of a pair, sharing their table
    /// lookups: what a lobe's value needs of the compensation; (1, 0)
    /// without it and for directions on opposite sides.
    pub fn compensation_terms(&self, wi: Vec3, wo: Vec3) -> (f32, Vec3) {
        if !same_hemisphere(wi, wo) {
            return (1.0, Vec3::ZERO);
        }
        let [at_i, at_o] = [wi, wo].map(|w| self.compensation_lookup(w.z.abs()));
        self.compensation_terms_at(at_i.as_ref(), at_o.as_ref())
    }

    /// The compensation's albedo lookup at macro cosine `mu` (`None`
    /// without compensation), which `compensation_probability_at` and
    /// `compensation_terms_at` share: one per direction of a query.
    pub(crate) fn compensation_lookup(&self, mu: f32) -> Option<AlbedoLookup> {
        self.compensation
            .map(|c| c.lookup(&self.ndf, self.shadowing, mu))
    }

    /// `compensation_probability` from the lookup at mu_i.
    pub(crate) fn compensation_probability_at(&self, at_i: Option<&AlbedoLookup>) -> f32 {
        match (self.compensation, at_i) {
            (Some(c), Some(at_i)) => c.probability_at(at_i),
            _ => 0.0,
        }
    }

    /// `compensation_terms` of a pair on the same side from the lookups at
    /// its two cosines.
    pub(crate) fn compensation_terms_at(
        &self,
        at_i: Option<&AlbedoLookup>,
        at_o: Option<&AlbedoLookup>,
    ) -> (f32, Vec3) {
        match (self.compensation, at_i, at_o) {
            (Some(c), Some(at_i), Some(at_o)) => {
                let (scale, value) = c.terms_at(&self.ndf, self.shadowing, at_i, at_o);
                (scale, c.tint * value)
            }
            _ => (1.0, Vec3::ZERO),
        }
    }

    /// The mixture density (1 - P_c(mu_i)) `p_lobe` + P_c(mu_i) mu_o/pi of a
    /// reflection lobe with compensation (`p_lobe` unchanged without it).
    pub fn with_compensation_pdf(&self, wi: Vec3, wo: Vec3, p_lobe: f32) -> f32 {
        mixture_pdf(self.compensation_probability(wi.z.abs()), wi, wo, p_lobe).pdf()
    }

    /// True when lobes built on this model are deltas (alpha < `SMOOTH_ALPHA`).
    pub fn is_smooth(&self) -> bool {
        self.alpha() < SMOOTH_ALPHA
    }

    /// True when `sample_h` draws visible normals; false for Smith Blinn-Phong,
    /// which has no visible-normal sampler and draws from D(h)<h,n> (SPEC §1).
    pub fn samples_visible_normals(&self) -> bool {
        !(self.shadowing == Shadowing::Smith && self.ndf.kind() == NdfKind::BlinnPhong)
    }

    /// D(h).
    pub fn d(&self, h: Vec3) -> f32 {
        self.ndf.d(h)
    }

    /// Masking of `w` by microfacet `h`, zero unless (w.h)(w.n) > 0 (back-facing
    /// microfacets are discarded, SPEC §3).
    pub fn g1(&self, w: Vec3, h: Vec3) -> f32 {
        self.shadowing.masking(&self.ndf, w, h)
    }

    /// Shadowing-masking G(wi, wo) for microfacet `h` (SPEC §2): reflection
    /// when wi and wo are on the same side, transmission otherwise. Symmetric.
    pub fn g(&self, wi: Vec3, wo: Vec3, h: Vec3) -> f32 {
        self.shadowing.masking_shadowing(&self.ndf, wi, wo, h)
    }

    /// Supremum of G1(w)/|<w,n>| over directions (supp. §2), +infinity for the
    /// V-cavity model, whose ratio is unbounded at grazing.
    pub fn g1_over_cos_sup(&self) -> f32 {
        match self.shadowing {
            Shadowing::Smith => self.ndf.g1_over_cos_sup(),
            Shadowing::VCavity => f32::INFINITY,
        }
    }

    /// Samples a microfacet normal for a query from `wi` (wi.z > 0): visible
    /// normals for GGX and Beckmann with Smith (Heitz 2018; Heitz & d'Eon
    /// 2014) and for every NDF with V-cavity; D(h)<h,n> for Smith Blinn-Phong.
    /// Its density is `pdf_h`. `None` if wi is not above the surface or the
    /// sampler degenerates.
    pub fn sample_h(&self, wi: Vec3, u: Vec2, uc: f32) -> Option<HalfVectorSample> {
        if !(wi.z > 0.0) {
            return None;
        }
        let alpha = self.alpha();
        let h = match (self.shadowing, self.ndf.kind()) {
            (Shadowing::VCavity, _) => {
                let (h, uc) = vndf::sample_vcavity(&self.ndf, wi, u, uc)?;
                return Some(HalfVectorSample { h, uc });
            }
            (Shadowing::Smith, NdfKind::Ggx) => vndf::sample_ggx(wi, alpha, u)?,
            (Shadowing::Smith, NdfKind::Beckmann) => vndf::sample_beckmann(wi, alpha, u)?,
            (Shadowing::Smith, NdfKind::BlinnPhong) => self.ndf.sample_d_cos(u),
        };
        Some(HalfVectorSample { h, uc })
    }

    /// D, G and the densities of `sample_h` from both directions, for wi
    /// above the surface (wi.z > 0), wo on either side and h.z > 0. Equal to
    /// `d(h)`, `g(wi, wo, h)`, `pdf_h(wi, h)` and `pdf_h(wo_up, h)` with
    /// wo_up = wo flipped above the surface, at the cost of one D and two G1.
    pub(crate) fn facet_terms(&self, wi: Vec3, wo: Vec3, h: Vec3) -> FacetTerms {
        let d = self.d(h);
        let (g1_wi, g1_wo) = (self.g1(wi, h), self.g1(wo, h));
        let g = self.shadowing.g(g1_wi, g1_wo, wo.z > 0.0);
        let (pdf_h_wi, pdf_h_wo) = if self.samples_visible_normals() {
            // G1 is zero unless (w.h)(w.n) > 0, so |w.h| / |w.n| is safe here.
            (
                g1_wi * wi.dot(h).abs() * d / wi.z,
                g1_wo * wo.dot(h).abs() * d / wo.z.abs(),
            )
        } else {
            let p = d * h.z;
            (p, p)
        };
        FacetTerms {
            d,
            g,
            pdf_h_wi,
            pdf_h_wo,
        }
    }

    /// Density of `sample_h` per solid angle of h (SPEC §1):
    /// D_wi(h) = G1(wi, h) max(0, <wi,h>) D(h) / <wi,n>, or D(h)<h,n> for Smith
    /// Blinn-Phong. 0 unless wi.z > 0 and h.z > 0.
    pub fn pdf_h(&self, wi: Vec3, h: Vec3) -> f32 {
        if !(wi.z > 0.0 && h.z > 0.0) {
            return 0.0;
        }
        if !self.samples_visible_normals() {
            return self.ndf.pdf_d_cos(h);
        }
        let wi_h = wi.dot(h);
        if wi_h <= 0.0 {
            return 0.0;
        }
        self.g1(wi, h) * wi_h * self.d(h) / wi.z
    }
}

/// The mixture density (1 - `p_c`) `p_lobe` + `p_c` mu_o/pi of a reflection
/// lobe with compensation, `p_c` = P_c(mu_i) (module docs of
/// `crate::conductor`), in its parts: the cosine lobe only on wi's side.
pub(crate) fn mixture_pdf(p_c: f32, wi: Vec3, wo: Vec3, p_lobe: f32) -> MixturePdf {
    let p_compensation = if same_hemisphere(wi, wo) {
        wo.z.abs() * std::f32::consts::FRAC_1_PI
    } else {
        0.0
    };
    MixturePdf {
        p_c,
        p_compensation,
        p_lobe,
    }
}
