//! Glass-like interfaces: rough dielectric reflection and Walter et al.'s
//! transmission (SPEC §3, supp. §3), or smooth reflection/refraction when alpha
//! is below `SMOOTH_ALPHA`.
//!
//! The side of the surface a direction is on decides the indices: `eta` is
//! the index below the surface (-z) over the index above it (+z); a query
//! from below sees 1/eta. Reflection is chosen with probability F and
//! refraction with 1 - F, and the pdfs carry those factors (SPEC §3).

use glam::{Vec2, Vec3};

use crate::frame::{reflect, refract_f64};
use crate::fresnel;
use crate::model::MicrofacetModel;
use crate::sample::{BsdfSample, TransportMode};

/// A dielectric interface lobe.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dielectric {
    /// Microfacet distribution and shadowing.
    pub model: MicrofacetModel,
    /// Index below the surface over index above it; must be finite and > 0.
    pub eta: f32,
}

/// f, forward pdf and reverse pdf of one configuration.
struct Terms {
    f: f32,
    pdf: f32,
    pdf_reverse: f32,
}

impl Dielectric {
    /// True for a smooth interface, and for an index-matched one (eta = 1),
    /// whose transmission is a straight pass-through at any roughness.
    pub fn is_specular(&self) -> bool {
        self.model.is_smooth() || self.eta == 1.0
    }

    /// f(wi, wo) (SPEC §3): F D G / (4 |cos_i cos_o|) for reflection;
    /// |<wi,h><wo,h>| / |cos_i cos_o| (1 - F) D G / (<wi,h> + eta <wo,h>)^2 for
    /// refraction in Radiance mode, times eta^2 in Importance mode
    /// (eta = eta_t/eta_i; equivalent to SPEC's eta_i^2, eta_t^2 numerators).
    pub fn eval(&self, wi: Vec3, wo: Vec3, mode: TransportMode) -> f32 {
        self.evaluate(wi, wo, mode).map_or(0.0, |t| t.f)
    }

    /// Density of `wo` given `wi`: pdf_h(wi,h)/(4<wo,h>) F for reflection,
    /// pdf_h(wi,h) eta^2 |<wo,h>| / (<wi,h> + eta <wo,h>)^2 (1 - F) for refraction.
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        self.evaluate(wi, wo, TransportMode::Radiance)
            .map_or(0.0, |t| t.pdf)
    }

    /// Samples reflection or refraction through a sampled microfacet normal
    /// (or through the macro normal when smooth). `None` on degenerate input
    /// or a sample that ends on the wrong side of the surface.
    pub fn sample(&self, wi: Vec3, uc: f32, u: Vec2, mode: TransportMode) -> Option<BsdfSample> {
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
        let t = self.terms(wi, wo, h, eta, mode)?;
        Some(BsdfSample {
            wo: wo * side,
            f: Vec3::splat(t.f),
            pdf: t.pdf,
            pdf_reverse: t.pdf_reverse,
            eta: if reflected { 1.0 } else { eta as f32 },
            is_specular: false,
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
            f: Vec3::splat(t * scale / wo.z.abs()),
            pdf: t,
            pdf_reverse: t,
            eta,
            is_specular: true,
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
        if wo.z == 0.0 {
            return None;
        }
        // Reflection: h ~ wi + wo; refraction: h ~ eta_i wi + eta_t wo ~ wi + eta wo.
        let h = if wo.z > 0.0 {
            wi + wo
        } else {
            wi + eta as f32 * wo
        };
        // Zero length only for wo = -wi at eta = 1, excluded above; kept for round-off.
        let h = h.try_normalize()?;
        let h = if h.z < 0.0 { -h } else { h };
        self.terms(wi, wo, h, eta, mode)
    }

    /// The core shared by `eval`, `pdf` and `sample`: wi above the surface,
    /// h the oriented microfacet normal, eta = eta_t/eta_i.
    fn terms(&self, wi: Vec3, wo: Vec3, h: Vec3, eta: f64, mode: TransportMode) -> Option<Terms> {
        let (wi_h, wo_h) = (wi.dot(h), wo.dot(h));
        // Discard back-facing microfacets (SPEC §3).
        if !(h.z > 0.0 && wi_h > 0.0 && wo_h * wo.z > 0.0) {
            return None;
        }
        let (cos_i, cos_o) = (wi.z, wo.z.abs());
        // F and 1 - F each to f32 precision (1 - F from an f32 F is not,
        // near the critical angle).
        let (f_r, t) = fresnel::dielectric_f64(f64::from(wi_h), eta);
        let (f_r, t, eta) = (f_r as f32, t as f32, eta as f32);
        let facet = self.model.facet_terms(wi, wo, h);
        let terms = if wo.z > 0.0 {
            Terms {
                f: f_r * facet.d * facet.g / (4.0 * cos_i * cos_o),
                pdf: facet.pdf_h_wi / (4.0 * wi_h) * f_r,
                pdf_reverse: facet.pdf_h_wo / (4.0 * wo_h) * f_r,
            }
        } else {
            let denominator = wi_h + eta * wo_h;
            let denominator2 = denominator * denominator;
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
