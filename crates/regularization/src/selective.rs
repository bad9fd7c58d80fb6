//! Selective regularization, the "path diffusion" heuristic (SPEC §5): how
//! much a vertex may be blurred depends on how blurred the path already is.
//!
//! The paper's exact formula is not at hand; SPEC §5 fixes this definition:
//! on camera subpaths, with rho the largest alpha (clamped to 1; diffuse
//! counts 1) of the vertices between the camera and this one, tau_k =
//! tau_N / max(rho^2, 1e-8), i.e. alpha_tau,k = alpha_tau,N rho; on light
//! subpaths tau_k = tau_N. What is seen directly or only through mirrors stays
//! sharp; a glass sphere seen on a diffuse floor is regularized.

use std::fmt;
use std::str::FromStr;

use microfacet::Bsdf;

use crate::tau::{AlphaHat, regularize};

/// Floor of rho^2 in tau_N / rho^2 (SPEC §5): keeps tau finite (at most
/// 1e8 tau_N, far beyond any roughness f32 resolves) while rho = 0.
pub const MIN_RHO_SQUARED: f64 = 1e-8;

/// Regularization mode of an integrator.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Mode {
    /// No regularization: every tau is +infinity.
    Off,
    /// tau_k = tau_N at every vertex, including the first camera vertex.
    Uniform,
    /// The path-diffusion rule above (the default).
    Selective,
}

impl Mode {
    /// Every mode with its name, as command lines and manifests spell it.
    pub const ALL: [(Self, &'static str); 3] = [
        (Self::Off, "off"),
        (Self::Uniform, "uniform"),
        (Self::Selective, "selective"),
    ];

    /// The mode's name (`off`, `uniform`, `selective`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::Uniform => "uniform",
            Self::Selective => "selective",
        }
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that is not a regularization mode.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("unknown regularization mode '{0}' (expected one of: off, uniform, selective)")]
pub struct UnknownMode(pub String);

impl FromStr for Mode {
    type Err = UnknownMode;
    /// Parses a mode name, ignoring ASCII case.
    fn from_str(s: &str) -> Result<Self, UnknownMode> {
        Self::ALL
            .iter()
            .find(|(_, name)| name.eq_ignore_ascii_case(s))
            .map(|(mode, _)| *mode)
            .ok_or_else(|| UnknownMode(s.to_owned()))
    }
}

/// Which end a subpath starts from.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Subpath {
    /// Traced from the camera (Radiance).
    Camera,
    /// Traced from a light (Importance).
    Light,
}

/// Whether a regularized lobe keeps its original's directional albedo
/// (`microfacet::energy`, Kulla & Conty 2017 applied to the difference
/// between the original and the widened lobe) or loses what widening a
/// single-scattering lobe loses.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum Energy {
    /// The widened lobe plus a compensation lobe (`Bsdf::regularized`).
    #[default]
    Preserved,
    /// The widened lobe alone (`Bsdf::with_alpha`): darker images, kept for
    /// comparison.
    Lost,
}

/// Regularization state carried along a subpath: yields tau and alpha-hat
/// for the next vertex, and is updated with each vertex's roughness.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathRegularization {
    mode: Mode,
    subpath: Subpath,
    tau_n: f64,
    /// Largest alpha (clamped to 1) of the vertices so far.
    rho: f32,
    /// Energy compensation of the regularized lobes.
    energy: Energy,
}

impl PathRegularization {
    /// State at the start of a subpath, with the iteration's tau_N.
    pub fn new(mode: Mode, subpath: Subpath, tau_n: f64) -> Self {
        Self {
            mode,
            subpath,
            tau_n,
            rho: 0.0,
            energy: Energy::Preserved,
        }
    }

    /// The same state with energy compensation `energy`.
    pub fn with_energy(self, energy: Energy) -> Self {
        Self { energy, ..self }
    }

    /// The bound tau_k for the next vertex (+infinity when nothing is regularized).
    pub fn tau(&self) -> f64 {
        match (self.mode, self.subpath) {
            (Mode::Off, _) => f64::INFINITY,
            (Mode::Uniform, _) | (Mode::Selective, Subpath::Light) => self.tau_n,
            (Mode::Selective, Subpath::Camera) => {
                self.tau_n / (f64::from(self.rho) * f64::from(self.rho)).max(MIN_RHO_SQUARED)
            }
        }
    }

    /// The next vertex's BSDF, regularized, and its alpha-hat (`None` for
    /// lobes without roughness). Store the result in the vertex: every later
    /// use must see the same alpha-hat (SPEC §5).
    pub fn regularize(&self, bsdf: &Bsdf) -> (Bsdf, Option<AlphaHat>) {
        match self.mode {
            Mode::Off => (*bsdf, None),
            Mode::Uniform | Mode::Selective => regularize(bsdf, self.tau(), self.energy),
        }
    }

    /// The state after a vertex with BSDF `bsdf` (its original roughness; a
    /// Lambertian lobe counts as alpha = 1, and so does a coated lobe with a
    /// diffuse base: the path may have left through the base, and rho is
    /// the largest alpha of the path's lobes, SPEC §5).
    pub fn after_vertex(self, bsdf: &Bsdf) -> Self {
        let alpha = match bsdf {
            Bsdf::Coated(c) if c.has_diffuse() => 1.0,
            _ => bsdf.alpha().unwrap_or(1.0).min(1.0),
        };
        Self {
            rho: self.rho.max(alpha),
            ..self
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use microfacet::{Conductor, Fresnel, Lambertian, MicrofacetModel, NdfKind, Shadowing};

    #[test]
    fn mode_names_round_trip_and_errors_list_the_choices() {
        for (mode, name) in Mode::ALL {
            assert_eq!(mode.to_string(), name);
            assert_eq!(name.parse::<Mode>(), Ok(mode));
            assert_eq!(name.to_uppercase().parse::<Mode>(), Ok(mode));
        }
        let e = "strict".parse::<Mode>().unwrap_err().to_string();
        assert!(e.contains("'strict'") && e.contains("selective"), "{e}");
    }

    fn mirror() -> Bsdf {
        Bsdf::Conductor(Conductor {
            model: MicrofacetModel::new(NdfKind::Ggx, 0.0, Shadowing::Smith),
            fresnel: Fresnel::Schlick { f0: Vec3::ONE },
        })
    }

    #[test]
    fn camera_paths_stay_sharp_until_a_rough_vertex() {
        let start = PathRegularization::new(Mode::Selective, Subpath::Camera, 10.0);
        // Seen directly: tau = 1e9, effectively no blur.
        assert_eq!(start.tau(), 10.0 / MIN_RHO_SQUARED);
        let after_mirror = start.after_vertex(&mirror());
        assert!(after_mirror.tau() > 1e8);
        let after_diffuse = after_mirror.after_vertex(&Bsdf::Lambertian(Lambertian {
            reflectance: Vec3::ONE,
        }));
        assert_eq!(after_diffuse.tau(), 10.0);
        // Light subpaths and uniform mode use tau_N throughout.
        assert_eq!(
            PathRegularization::new(Mode::Selective, Subpath::Light, 10.0).tau(),
            10.0
        );
        assert_eq!(
            PathRegularization::new(Mode::Uniform, Subpath::Camera, 10.0).tau(),
            10.0
        );
        assert_eq!(
            PathRegularization::new(Mode::Off, Subpath::Light, 10.0).tau(),
            f64::INFINITY
        );
    }

    /// A coated lobe counts as diffuse (rho = 1) when it has a base, and as
    /// its coat's alpha when the base is black (SPEC §5's "diffuse counts 1").
    #[test]
    fn coated_vertices_count_their_base() {
        let coated = |base: Vec3| {
            Bsdf::Coated(microfacet::Coated {
                model: MicrofacetModel::new(NdfKind::Ggx, 0.1, Shadowing::Smith),
                base_color: base,
                metallic: 0.0,
                specular: 1.0,
                specular_color: Vec3::ONE,
                ior: 1.5,
            })
        };
        let start = PathRegularization::new(Mode::Selective, Subpath::Camera, 10.0);
        assert_eq!(start.after_vertex(&coated(Vec3::splat(0.5))).tau(), 10.0);
        let after_coat = start.after_vertex(&coated(Vec3::ZERO)).tau();
        assert!((after_coat / 1000.0 - 1.0).abs() < 1e-6, "{after_coat}");
    }

    #[test]
    fn regularized_mirror_becomes_glossy() {
        let state = PathRegularization::new(Mode::Uniform, Subpath::Camera, 7.5);
        let (bsdf, hat) = state.regularize(&mirror());
        assert!(mirror().is_specular());
        assert!(!bsdf.is_specular());
        assert!((hat.unwrap().alpha - 0.103).abs() < 1e-3);
        let (off, none) =
            PathRegularization::new(Mode::Off, Subpath::Camera, 7.5).regularize(&mirror());
        assert_eq!((off, none), (mirror(), None));
    }
}
