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
}
