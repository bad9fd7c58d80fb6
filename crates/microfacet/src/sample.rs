//! What every lobe shares with the [`crate::Bsdf`] that dispatches to it:
//! the transport mode that makes refraction adjoint-correct, and the
//! record of a sampled direction. Below both, so that lobes and the
//! dispatch do not import each other.

use glam::Vec3;

/// The largest f32 below 1: a uniform rescaled after a discrete choice
/// (lobe coins, the V-cavity facet choice) must stay in [0, 1).
pub const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Which quantity a subpath carries (SPEC §0; Veach's thesis, ch. 5).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum TransportMode {
    /// Camera subpaths: radiance is eta^2 brighter inside a dense medium, so
    /// refraction carries (eta_i/eta_t)^2 relative to `Importance`.
    Radiance,
    /// Light subpaths: the adjoint BSDF, which conserves flux.
    Importance,
}

/// A sampled outgoing direction with everything an integrator needs.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BsdfSample {
    /// The sampled direction, a unit vector.
    pub wo: Vec3,
    /// BSDF value f(wi, wo) without the cosine; for a delta lobe, the weight
    /// of the delta (so that f |<wo,n>| / pdf is the sample's throughput).
    pub f: Vec3,
    /// Density of `wo` given `wi` (solid angle), or the discrete probability
    /// of the chosen delta lobe.
    pub pdf: f32,
    /// Density of `wi` had it been sampled from `wo` (the reverse pdf BPT and
    /// VCM need), in the same measure as `pdf`.
    pub pdf_reverse: f32,
    /// Relative index eta_t/eta_i crossed by a refraction; 1 for reflection.
    pub eta: f32,
    /// True when `wo` came from a delta lobe.
    pub is_specular: bool,
    /// `pdf` and `pdf_reverse` split into their parts, for a conductor or
    /// dielectric lobe with energy compensation (`crate::compensation::energy`,
    /// `crate::compensation::dielectric_energy`); `None` for every other sample.
    pub compensated: Option<[MixturePdf; 2]>,
}

/// The density of a lobe with energy compensation, in its parts:
/// (1 - `p_c`) `p_lobe` + `p_c` `p_compensation`, P_c of the query
/// direction (module docs of `crate::compensation::energy` and `crate::compensation::dielectric_energy`).
/// A sample carries it so that a density which changes only the microfacet
/// lobe's part (p-hat of a regularized vertex, paper eq. 13) needs no
/// second albedo lookup: `with_lobe`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MixturePdf {
    /// P_c: the probability of sampling the compensation lobe.
    pub p_c: f32,
    /// The compensation lobe's density of the direction.
    pub p_compensation: f32,
    /// The microfacet lobe's density of the direction.
    pub p_lobe: f32,
}

impl MixturePdf {
    /// The mixture density.
    pub fn pdf(&self) -> f32 {
        self.with_lobe(self.p_lobe)
    }

    /// The mixture density with `p_lobe` in place of the microfacet lobe's.
    pub fn with_lobe(&self, p_lobe: f32) -> f32 {
        if self.p_c == 0.0 {
            p_lobe
        } else {
            (1.0 - self.p_c) * p_lobe + self.p_c * self.p_compensation
        }
    }
}
