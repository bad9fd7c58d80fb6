//! Masking-shadowing models (SPEC §2, supp. §2 and §4).
//!
//! Smith's model derives G1 from the NDF (`Ndf::g1`); the V-cavity model of
//! Torrance and Sparrow is purely geometric and independent of alpha, which is
//! what makes its regularized pdf a plain re-evaluation with alpha-hat (supp. §4).

use glam::Vec3;

use crate::ndf::Ndf;

/// Which masking-shadowing model a microfacet surface uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Shadowing {
    /// Smith, separable: G(wi, wo) = G1(wi) G1(wo).
    Smith,
    /// V-cavity (Torrance-Sparrow 1967; Heitz & d'Eon 2014 for sampling).
    VCavity,
}

/// V-cavity masking of direction `w` by the cavity of microfacet `h` (SPEC §2):
/// min(1, |2<n,h><n,w> / <w,h>|), zero unless (w.h)(w.n) > 0. In [0, 1].
pub fn g1_vcavity(w: Vec3, h: Vec3) -> f32 {
    let w_h = w.dot(h);
    if w_h * w.z <= 0.0 {
        return 0.0;
    }
    (2.0 * h.z * w.z / w_h).abs().min(1.0)
}

impl Shadowing {
    /// Shadowing-masking G(wi, wo) from the two masking terms (SPEC §2):
    /// - Smith: G1(wi) G1(wo), for reflection and transmission;
    /// - V-cavity reflection: min(G1v(wi), G1v(wo)) (both directions see the
    ///   same end of the facet);
    /// - V-cavity transmission: max(0, G1v(wi) + G1v(wo) - 1) (the two visible
    ///   intervals start at opposite ends of the facet).
    pub fn g(self, g1_wi: f32, g1_wo: f32, reflection: bool) -> f32 {
        match self {
            Shadowing::Smith => g1_wi * g1_wo,
            Shadowing::VCavity if reflection => g1_wi.min(g1_wo),
            Shadowing::VCavity => (g1_wi + g1_wo - 1.0).max(0.0),
        }
    }

    /// Masking G1(w, h) of direction `w` by microfacet `h` of `ndf`, zero
    /// unless (w.h)(w.n) > 0 (back-facing microfacets are discarded, SPEC §3):
    /// Smith's from the NDF (`Ndf::g1`), V-cavity's from the geometry
    /// (`g1_vcavity`). What `MicrofacetModel::g1` and the energy tables'
    /// quadrature (`crate::compensation`) evaluate.
    pub fn masking(self, ndf: &Ndf, w: Vec3, h: Vec3) -> f32 {
        match self {
            Shadowing::Smith if w.dot(h) * w.z > 0.0 => ndf.g1(w),
            Shadowing::Smith => 0.0,
            Shadowing::VCavity => g1_vcavity(w, h),
        }
    }

    /// Shadowing-masking G(wi, wo) for microfacet `h` of `ndf` (SPEC §2):
    /// reflection when wi and wo are on the same side, transmission
    /// otherwise (`g` of the two `masking` terms). Symmetric.
    pub fn masking_shadowing(self, ndf: &Ndf, wi: Vec3, wo: Vec3, h: Vec3) -> f32 {
        self.g(
            self.masking(ndf, wi, h),
            self.masking(ndf, wo, h),
            wi.z * wo.z > 0.0,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn vcavity_limits() {
        // Facet aligned with the normal: fully visible.
        assert_eq!(g1_vcavity(Vec3::new(0.6, 0.0, 0.8), Vec3::Z), 1.0);
        // Back-facing microfacet: invisible.
        let h = Vec3::new(0.8, 0.0, 0.6);
        assert_eq!(g1_vcavity(Vec3::new(-0.8, 0.0, 0.6), h), 0.0);
        // Grazing direction sees only a sliver of a tilted facet.
        let w = Vec3::new(1.0, 0.0, 1e-4).normalize();
        assert!(g1_vcavity(w, h) < 1e-3);
        // Transmission through both ends: clamps at zero.
        let g = Shadowing::VCavity.g(g1_vcavity(w, h), g1_vcavity(-w, h), false);
        assert_eq!(g, 0.0);
    }
}
