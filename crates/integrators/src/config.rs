//! What a render does: the algorithm, its strategies and the regularization
//! settings. Parsed names match the `render-cli` flags.

use std::fmt;
use std::str::FromStr;

use regularization::tau::alpha_tau;
use regularization::{Energy, Lobe, Mode, Schedule, ScheduleError};

/// A light-transport algorithm.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Algorithm {
    /// Path tracing with next-event estimation (SPEC §7).
    #[default]
    Pt,
    /// Bidirectional path tracing: the VCM core with merging off.
    Bpt,
    /// Progressive photon mapping (Hachisuka et al. 2008; SmallVCM's
    /// `ppm`): camera paths stop at their first non-specular vertex and
    /// merge there with the photons, no MIS.
    Ppm,
    /// Bidirectional photon mapping: the VCM core with merging only (a
    /// merge at every non-specular camera vertex, MIS between them;
    /// SmallVCM's `bpm`).
    Bpm,
    /// Vertex connection and merging (Georgiev et al. 2012).
    Vcm,
}

impl Algorithm {
    /// Every algorithm with its command-line name.
    pub const ALL: [(Self, &'static str); 5] = [
        (Self::Pt, "pt"),
        (Self::Bpt, "bpt"),
        (Self::Ppm, "ppm"),
        (Self::Bpm, "bpm"),
        (Self::Vcm, "vcm"),
    ];

    /// Every algorithm, in `ALL`'s order.
    pub fn every() -> [Self; 5] {
        Self::ALL.map(|(algorithm, _)| algorithm)
    }

    /// The command-line name.
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(a, _)| *a == self)
            .map_or("?", |(_, n)| n)
    }
}

impl FromStr for Algorithm {
    type Err = ConfigError;
    fn from_str(s: &str) -> Result<Self, ConfigError> {
        Self::ALL
            .iter()
            .find(|(_, n)| n.eq_ignore_ascii_case(s))
            .map(|(a, _)| *a)
            .ok_or_else(|| ConfigError::UnknownName {
                what: "integrator",
                given: s.to_owned(),
                expected: "pt, bpt, ppm, bpm, vcm",
            })
    }
}

impl fmt::Display for Algorithm {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The path tracer's techniques for reaching a light. `Mis` is the renderer;
/// the single-technique variants exist to cross-check it (they estimate the
/// same image with more noise).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Strategies {
    /// Next-event estimation and BSDF sampling, combined with MIS.
    #[default]
    Mis,
    /// Lights are reached only by next-event estimation (emission is counted
    /// on camera rays and after delta bounces, which NEE cannot follow).
    NeeOnly,
    /// Lights are reached only by BSDF-sampled rays (delta lights are never found).
    BsdfOnly,
}

/// Default tau_0: alpha_tau = 1/sqrt(4 pi tau_0) = 0.052 at the first
/// iteration. Chosen by the tau_0 sweep (docs/studies.md, "Regularization
/// against the truth") for the default `unsampleable` rule: with 30 it met the goal
/// on both caustic scenes and lost nothing on the glossy ones, where 7.5
/// (SPEC §5's value, alpha_tau 0.103) was 1.7x worse than no regularization
/// on glossy-cornell-glass. Our tau bounds the outgoing density (D/4 for
/// reflection); implementations that bound D itself use 4x this value.
pub const DEFAULT_TAU_0: f64 = 30.0;

/// Regularization settings (SPEC §5).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Regularization {
    /// Which vertices are regularized.
    pub mode: Mode,
    /// The schedule: tau_0 and, through it, tau_N.
    pub schedule: Schedule,
    /// When false, tau stays tau_0 at every iteration (a fixed blur: biased,
    /// not consistent; used to compare estimators on one integrand).
    pub progressive: bool,
    /// Whether regularized lobes keep their original's energy
    /// (`microfacet::compensation::energy`); `Preserved` by default, `Lost` to compare
    /// with the plain widening.
    pub energy: Energy,
}

impl Regularization {
    /// Settings with `mode`, `tau_0` and `progressive`; an invalid tau_0
    /// (<= 1/(2 pi), NaN) is an error.
    pub fn new(mode: Mode, tau_0: f64, progressive: bool) -> Result<Self, ConfigError> {
        Ok(Self {
            mode,
            schedule: Schedule::new(tau_0).map_err(ConfigError::Tau)?,
            progressive,
            energy: Energy::Preserved,
        })
    }

    /// No regularization.
    pub fn off() -> Self {
        Self::new(Mode::Off, DEFAULT_TAU_0, true).expect("the default tau_0 is valid")
    }

    /// tau_N for iteration `n` (1-based), or infinity when off.
    pub fn tau_at(&self, n: u64) -> f64 {
        match (self.mode, self.progressive) {
            (Mode::Off, _) => f64::INFINITY,
            (_, true) => self.schedule.tau_at(n.max(1)),
            (_, false) => self.schedule.tau_0(),
        }
    }

    /// The roughness a reflection lobe is raised to at iteration `n`,
    /// alpha_tau(tau_N) (SPEC §5): the blur of the regularization.
    pub fn alpha_tau_at(&self, n: u64) -> f64 {
        alpha_tau(Lobe::Reflection, self.tau_at(n))
    }
}

impl Default for Regularization {
    /// Unsampleable, tau_0 = 30, progressive: the tau_0 sweep's choice
    /// (SPEC §5's default rule is selective; docs/studies.md, "Regularization
    /// against the truth").
    fn default() -> Self {
        Self::new(Mode::Unsampleable, DEFAULT_TAU_0, true).expect("the default tau_0 is valid")
    }
}

/// Everything an integrator needs besides the scene.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderConfig {
    /// The algorithm.
    pub algorithm: Algorithm,
    /// PT techniques.
    pub strategies: Strategies,
    /// Longest path, in segments (1: emitters seen directly only).
    pub max_depth: u32,
    /// Seed of every random stream.
    pub seed: u64,
    /// Regularization settings.
    pub regularization: Regularization,
    /// Virtual merges (supp. §6) in BPT and VCM; `None`: on for VCM with
    /// regularization, off otherwise.
    pub virtual_merges: Option<bool>,
    /// Merge radius of the first iteration, as a fraction of the radius of
    /// the scene's bounding sphere (PPM, BPM, VCM).
    pub radius_factor: f32,
    /// The progressive radius exponent alpha_r of SPEC §7:
    /// r_i = r_1 i^((alpha_r - 1) / 2).
    pub radius_alpha: f32,
    /// Russian roulette on the shadow rays of next-event estimation, vertex
    /// connections and light tracing in BPT and VCM (Veach 1997, §10.4.1):
    /// a contribution below this fraction of the mean pixel value is tested
    /// for visibility only with probability contribution / threshold. 0
    /// traces every shadow ray.
    pub shadow_roulette: f32,
    /// PT only: trace the paths of each run of pixels as a wavefront
    /// (`pt/wavefront.rs`, the default: its Lambertian vertices are shaded
    /// in SIMD lanes, `pt/lanes.rs`) instead of one path after the other
    /// (`false`: the readable reference loop). The image is the same, byte
    /// for byte; only the speed differs.
    pub wavefront: bool,
}

/// Default first merge radius: 0.3 % of the scene's bounding-sphere radius
/// (SmallVCM's default factor).
pub const DEFAULT_RADIUS_FACTOR: f32 = 0.003;

/// Default shadow-ray roulette threshold, as a fraction of the mean pixel
/// value. Measured on `cornell-box` (BPT, 128x128, 64 iterations), against
/// no roulette: 0.1 traces 26 % fewer rays (9.9 instead of 13.4 per
/// sample) and raises the mean per-pixel variance by 0.1 %, the mean
/// relative variance (var / (mean^2 + 0.01), SPEC §8) by 6.5 %. With
/// connections and light tracing only (next-event estimation outside the
/// roulette): 0.1, 0.25 and 0.5 skip 23 %, 32 % and 38 % of the rays and
/// raise the relative variance by 5 %, 34 % and 105 % (a threshold set by
/// the image mean makes dark pixels noisier).
pub const DEFAULT_SHADOW_ROULETTE: f32 = 0.1;

/// Default radius reduction exponent alpha_r (SPEC §7; Knaus and Zwicker 2011).
pub const DEFAULT_RADIUS_ALPHA: f32 = 0.75;

impl RenderConfig {
    /// Whether BPT/VCM run virtual merges (see [`RenderConfig::virtual_merges`]).
    pub fn uses_virtual_merges(&self) -> bool {
        let regularized = self.regularization.mode != Mode::Off;
        match self.algorithm {
            Algorithm::Bpt | Algorithm::Vcm => {
                regularized
                    && self
                        .virtual_merges
                        .unwrap_or(self.algorithm == Algorithm::Vcm)
            }
            Algorithm::Pt | Algorithm::Ppm | Algorithm::Bpm => false,
        }
    }
}

/// Default longest path, in segments.
pub const DEFAULT_MAX_DEPTH: u32 = 12;

impl Default for RenderConfig {
    fn default() -> Self {
        Self {
            algorithm: Algorithm::Pt,
            strategies: Strategies::Mis,
            max_depth: DEFAULT_MAX_DEPTH,
            seed: 0,
            regularization: Regularization::default(),
            virtual_merges: None,
            radius_factor: DEFAULT_RADIUS_FACTOR,
            radius_alpha: DEFAULT_RADIUS_ALPHA,
            shadow_roulette: DEFAULT_SHADOW_ROULETTE,
            wavefront: true,
        }
    }
}

/// An invalid setting, with a message naming it.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ConfigError {
    /// A name that is not one of the accepted values.
    #[error("unknown {what} '{given}' (expected one of: {expected})")]
    UnknownName {
        /// What was being named.
        what: &'static str,
        /// The name given.
        given: String,
        /// The accepted names.
        expected: &'static str,
    },
    /// tau_0 out of its domain.
    #[error("tau0: {0}")]
    Tau(ScheduleError),
    /// Other out-of-range values.
    #[error("{0}")]
    Invalid(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_parse_and_errors_list_the_choices() {
        assert_eq!("PT".parse::<Algorithm>(), Ok(Algorithm::Pt));
        let e = "xyz".parse::<Algorithm>().unwrap_err().to_string();
        assert!(e.contains("'xyz'") && e.contains("pt"), "{e}");
    }

    #[test]
    fn tau_follows_mode_and_schedule() {
        let r = Regularization::new(Mode::Uniform, 30.0, true).unwrap();
        assert_eq!(r.tau_at(1), 30.0);
        assert!(r.tau_at(10_000) > 2.0 * r.tau_at(1024) * 0.9);
        let fixed = Regularization {
            progressive: false,
            ..r
        };
        assert_eq!(fixed.tau_at(10_000), 30.0);
        assert_eq!(Regularization::off().tau_at(5), f64::INFINITY);
        assert!(Regularization::new(Mode::Uniform, 0.1, true).is_err());
        assert!(Regularization::new(Mode::Uniform, f64::NAN, true).is_err());
    }
}
