//! Which techniques compete, and the constants they share.

use crate::numeric::nonneg;
use crate::{Heuristic, MisError};

/// Smallest eta_VCM = N pi r^2 the recursion uses when merging is on.
///
/// A radius so small that N pi r^2 underflows (r = 1e-200) would make eta 0
/// and switch merging off silently; flooring it at 1e-300 keeps merges in the
/// technique set with a weight below any f64 resolution, which is what such a
/// radius means. (The merge estimator's own normalisation 1/(N pi r^2) is the
/// caller's business.)
const ETA_MIN: f64 = 1e-300;

/// The techniques that compete for a path (Georgiev et al. 2012, §4).
///
/// Unidirectional emitter hits (s = 0) are always a technique. The other
/// families can be switched off, so that one code path serves
/// - bidirectional path tracing: [`Techniques::BPT`] (merging off; SmallVCM's
///   `kBpt`),
/// - photon-mapping-style merging: [`Techniques::MERGING`] (connections off;
///   SmallVCM's `kBpm`, except that emitter hits keep their MIS weight here),
/// - vertex connection and merging: [`Techniques::VCM`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Techniques {
    /// Vertex connections: next-event estimation (s = 1), connections between
    /// sub-path vertices (s, t >= 2) and light tracing to the camera (t = 1).
    pub connections: bool,
    /// Vertex merging (photon density estimation) at every non-specular vertex.
    pub merging: bool,
    /// Virtual merges through regularized vertices (supp. §6; see the crate
    /// documentation, "Virtual merges"). Needs `connections`.
    pub virtual_merges: bool,
}

impl Techniques {
    /// Bidirectional path tracing: connections, no merging.
    pub const BPT: Self = Self {
        connections: true,
        merging: false,
        virtual_merges: false,
    };

    /// Merging only (bidirectional photon mapping), plus emitter hits.
    pub const MERGING: Self = Self {
        connections: false,
        merging: true,
        virtual_merges: false,
    };

    /// Vertex connection and merging.
    pub const VCM: Self = Self {
        connections: true,
        merging: true,
        virtual_merges: false,
    };

    /// The same techniques with virtual merges switched on or off.
    #[must_use]
    pub const fn with_virtual_merges(self, on: bool) -> Self {
        Self {
            connections: self.connections,
            merging: self.merging,
            virtual_merges: on,
        }
    }
}

/// Everything the MIS weights depend on beyond the path itself: the technique
/// set, the number of light sub-paths N, the merge radius r and the heuristic.
///
/// Derived constants (tech. rep. eq. 20, with n_VC = 1 and n_VM = N):
/// eta_VCM = N pi r^2, and its power eta_VCM^beta, which is what the
/// recursion adds per merge.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MisConfig {
    techniques: Techniques,
    light_paths: f64,
    radius: f64,
    heuristic: Heuristic,
    /// eta_VCM = N pi r^2 (0 when merging is off).
    eta: f64,
    /// eta_VCM^beta (0 when merging is off).
    pub(crate) mis_eta: f64,
    /// N^beta: light tracing (t = 1) takes N samples per camera sample.
    pub(crate) mis_light_paths: f64,
    /// 1 when connections are on, 0 otherwise: multiplies every connection term.
    pub(crate) connect: f64,
}

impl MisConfig {
    /// A configuration.
    ///
    /// - `light_paths`: N, the number of light sub-paths traced per iteration.
    ///   Light tracing (t = 1) splats every one of them into the image, and
    ///   every camera vertex merges with the vertices of all of them, so both
    ///   count N samples per camera sample (tech. rep. §4.2, SmallVCM's
    ///   `mLightSubPathCount`).
    /// - `radius`: the merge radius r of this iteration (ignored unless merging).
    /// - `heuristic`: balance (beta = 1) or power heuristic.
    ///
    /// # Errors
    /// - [`MisError::NoLightPaths`] if `light_paths` is 0,
    /// - [`MisError::InvalidRadius`] if `radius` is NaN, infinite or negative,
    ///   or zero while merging is on,
    /// - [`MisError::VirtualMergesNeedConnections`] if virtual merges are on
    ///   and connections off.
    pub fn new(
        techniques: Techniques,
        light_paths: u64,
        radius: f64,
        heuristic: Heuristic,
    ) -> Result<Self, MisError> {
        if light_paths == 0 {
            return Err(MisError::NoLightPaths);
        }
        if !(radius.is_finite() && radius >= 0.0) || (techniques.merging && radius == 0.0) {
            return Err(MisError::InvalidRadius(radius));
        }
        if techniques.virtual_merges && !techniques.connections {
            return Err(MisError::VirtualMergesNeedConnections);
        }
        let light_paths = light_paths as f64;
        let eta = if techniques.merging {
            // N pi r^2 may overflow for a huge radius (then merges dominate
            // every connection) or underflow for a tiny one: keep it in range.
            nonneg(light_paths * std::f64::consts::PI * radius * radius).max(ETA_MIN)
        } else {
            0.0
        };
        Ok(Self {
            techniques,
            light_paths,
            radius,
            heuristic,
            eta,
            // eta^beta can underflow (eta = 1e-300, beta = 2) even when eta
            // does not; a merge must stay a technique (it may be the only one
            // that can produce a path), so floor the power as well.
            mis_eta: if techniques.merging {
                heuristic.apply(eta).max(ETA_MIN)
            } else {
                0.0
            },
            mis_light_paths: heuristic.apply(light_paths),
            connect: if techniques.connections { 1.0 } else { 0.0 },
        })
    }

    /// Bidirectional path tracing with `light_paths` light sub-paths per
    /// iteration (they matter for light tracing, t = 1).
    ///
    /// # Errors
    /// As [`MisConfig::new`].
    pub fn bpt(light_paths: u64, heuristic: Heuristic) -> Result<Self, MisError> {
        Self::new(Techniques::BPT, light_paths, 0.0, heuristic)
    }

    /// Vertex connection and merging with merge radius `radius`.
    ///
    /// # Errors
    /// As [`MisConfig::new`].
    pub fn vcm(light_paths: u64, radius: f64, heuristic: Heuristic) -> Result<Self, MisError> {
        Self::new(Techniques::VCM, light_paths, radius, heuristic)
    }

    /// The technique set.
    pub fn techniques(&self) -> Techniques {
        self.techniques
    }

    /// N, the number of light sub-paths per iteration.
    pub fn light_paths(&self) -> f64 {
        self.light_paths
    }

    /// The merge radius r.
    pub fn radius(&self) -> f64 {
        self.radius
    }

    /// The heuristic.
    pub fn heuristic(&self) -> Heuristic {
        self.heuristic
    }

    /// eta_VCM = N pi r^2 (tech. rep. eq. 20), 0 when merging is off. Clamped
    /// to [1e-300, 1e300] when merging is on.
    pub fn eta_vcm(&self) -> f64 {
        self.eta
    }

    /// The acceptance probability of a virtual merge sampled at a vertex with
    /// regularization bound `tau`, for a direction of solid-angle pdf `pdf_w`
    /// (supp. eq. 14, clamped): min(1, pdf_w / tau).
    ///
    /// 0 when virtual merges are off, when `tau` is infinite (the vertex is not
    /// regularized), NaN or not positive. See
    /// [`acceptance_probability`](crate::acceptance_probability).
    #[inline]
    pub fn acceptance(&self, pdf_w: f64, tau: f64) -> f64 {
        if self.techniques.virtual_merges {
            crate::acceptance_probability(pdf_w, tau)
        } else {
            0.0
        }
    }

    /// x^beta with the configured heuristic (guarded, see
    /// [`Heuristic::apply`]).
    #[inline]
    pub(crate) fn mis(&self, x: f64) -> f64 {
        self.heuristic.apply(x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eta_is_n_pi_r_squared() {
        let c = MisConfig::vcm(1000, 0.01, Heuristic::BALANCE).unwrap();
        assert!((c.eta_vcm() - 1000.0 * std::f64::consts::PI * 1e-4).abs() < 1e-15);
        assert_eq!(c.mis_eta, c.eta_vcm());
        let p = MisConfig::vcm(1000, 0.01, Heuristic::POWER).unwrap();
        assert!((p.mis_eta - p.eta_vcm() * p.eta_vcm()).abs() < 1e-15);
        let b = MisConfig::bpt(1000, Heuristic::BALANCE).unwrap();
        assert_eq!(b.eta_vcm(), 0.0);
        assert_eq!(b.mis_eta, 0.0);
    }

    #[test]
    fn invalid_configurations_are_errors() {
        let h = Heuristic::BALANCE;
        assert_eq!(
            MisConfig::new(Techniques::VCM, 0, 1.0, h),
            Err(MisError::NoLightPaths)
        );
        for r in [f64::NAN, f64::INFINITY, -1.0, 0.0] {
            assert!(matches!(
                MisConfig::new(Techniques::VCM, 1, r, h),
                Err(MisError::InvalidRadius(_))
            ));
        }
        assert!(MisConfig::new(Techniques::BPT, 1, 0.0, h).is_ok());
        assert_eq!(
            MisConfig::new(Techniques::MERGING.with_virtual_merges(true), 1, 1.0, h),
            Err(MisError::VirtualMergesNeedConnections)
        );
    }

    #[test]
    fn eta_stays_in_range_for_extreme_radii() {
        for r in [1e-300, 1e-160, 1e160, 1e300] {
            let c = MisConfig::vcm(u64::MAX, r, Heuristic::POWER).unwrap();
            assert!(c.eta_vcm() > 0.0 && c.eta_vcm().is_finite());
            assert!(c.mis_eta > 0.0 && c.mis_eta.is_finite());
        }
    }
}
