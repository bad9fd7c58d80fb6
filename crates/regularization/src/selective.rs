//! Selective regularization, the "path diffusion" heuristic (SPEC §5): how
//! much a vertex may be blurred depends on how blurred the path already is.
//!
//! The paper's exact formula is not at hand; SPEC §5 fixes this definition:
//! on camera subpaths, with rho the largest alpha (clamped to 1; diffuse
//! counts 1) of the vertices between the camera and this one, tau_k =
//! tau_N / max(rho^2, 1e-8), i.e. alpha_tau,k = alpha_tau,N rho; on light
//! subpaths tau_k = tau_N. What is seen directly or only through mirrors stays
//! sharp; a glass sphere seen on a diffuse floor is regularized.
//!
//! `Mode::Unsampleable` goes beyond the paper (the repository's ARCHITECTURE.md):
//! it regularizes only subpaths whose prefix does not yet guarantee that an
//! unregularized technique of the integrator samples every path through it,
//! after Kaplanyan & Dachsbacher 2013 ("Path Space Regularization for
//! Holistic and Robust Light Transport"), who regularize only paths that no
//! unbiased technique can sample.

use std::fmt;
use std::str::FromStr;

use microfacet::Bsdf;

use crate::memo::RegularizationMemo;
use crate::tau::{AlphaHat, Energy, is_bounded, regularize};

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
    /// The path-diffusion rule above (SPEC §5).
    Selective,
    /// The selective rule, on subpaths whose prefix does not yet make every
    /// path through it sampleable by an unregularized technique
    /// ([`Techniques`]); `Selective` for integrators without such techniques.
    /// The default of the rlt renderer, chosen by a study against unbiased
    /// references (the repository's docs/studies.md).
    Unsampleable,
}

impl Mode {
    /// Every mode with its name, as command lines and manifests spell it.
    pub const ALL: [(Self, &'static str); 4] = [
        (Self::Off, "off"),
        (Self::Uniform, "uniform"),
        (Self::Selective, "selective"),
        (Self::Unsampleable, "unsampleable"),
    ];

    /// The mode's name (`off`, `uniform`, `selective`, `unsampleable`).
    pub fn name(self) -> &'static str {
        Self::ALL
            .iter()
            .find(|(mode, _)| *mode == self)
            .map_or("off", |(_, name)| name)
    }
}

impl fmt::Display for Mode {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A name that is not a regularization mode.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown regularization mode '{0}' (expected one of: off, uniform, selective, unsampleable)"
)]
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

/// The unregularized techniques of an integrator that a subpath's prefix
/// can guarantee (`Mode::Unsampleable`; SPEC §5 terms, tau_N the bound):
/// a vertex is *bounded* when its lobe's peak density is at most tau_N
/// (`tau::is_bounded`: regularization would not change it); the camera
/// and a light's emission point count as bounded ends.
///
/// - `connections` (BPT, VCM): once a subpath's prefix has an edge between
///   two bounded vertices, the connection at that edge samples every path
///   through the prefix, each subpath sampling its own sharp lobes.
/// - `merges` (VCM, photon mapping): once the prefix has a bounded vertex
///   after its origin, merging there samples every path through it (the
///   other subpath reaches the vertex by sampling alone).
///
/// Light subpaths are never regularized in this mode: a light subpath's
/// own vertices are only sampled, and sampling a sharp lobe never makes a
/// path unsampleable; where a technique evaluates a light vertex (a
/// connection), the vertex is rebuilt with the camera subpath's rule
/// (SPEC §5), which decides.
///
/// With neither (path tracing, whose only connection is next-event
/// estimation at the path's end), `Unsampleable` is `Selective`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Techniques {
    /// Vertex connections (including light tracing).
    pub connections: bool,
    /// Vertex merging.
    pub merges: bool,
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
    /// The integrator's unregularized techniques (`Mode::Unsampleable`).
    techniques: Techniques,
    /// The previous vertex (or the subpath's origin) is bounded at tau_N.
    previous_bounded: bool,
    /// The prefix so far makes every path through it sampleable by one of
    /// `techniques` (`Mode::Unsampleable`: no more regularization).
    sampleable: bool,
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
            techniques: Techniques::default(),
            previous_bounded: true,
            sampleable: false,
        }
    }

    /// The same state for an integrator with unregularized `techniques`.
    pub fn with_techniques(self, techniques: Techniques) -> Self {
        Self { techniques, ..self }
    }

    /// The same state with energy compensation `energy`.
    pub fn with_energy(self, energy: Energy) -> Self {
        Self { energy, ..self }
    }

    /// The bound tau_k for the next vertex (+infinity when nothing is regularized).
    pub fn tau(&self) -> f64 {
        match (self.mode, self.subpath) {
            (Mode::Off, _) | (Mode::Unsampleable, Subpath::Light) => f64::INFINITY,
            (Mode::Unsampleable, Subpath::Camera) if self.sampleable => f64::INFINITY,
            (Mode::Uniform, _) | (Mode::Selective, Subpath::Light) => self.tau_n,
            (Mode::Selective | Mode::Unsampleable, Subpath::Camera) => {
                self.tau_n / (f64::from(self.rho) * f64::from(self.rho)).max(MIN_RHO_SQUARED)
            }
        }
    }

    /// The next vertex's BSDF, regularized, and its alpha-hat (`None` for
    /// lobes without roughness). Store the result in the vertex: every later
    /// use must see the same alpha-hat (SPEC §5).
    ///
    /// First use: with `Energy::Preserved`, builds the energy tables of the
    /// lobe's model once per process (seconds in a release build, 10-20x
    /// longer unoptimised); `microfacet::prepare_tables` builds them ahead.
    pub fn regularize(&self, bsdf: &Bsdf) -> (Bsdf, Option<AlphaHat>) {
        match self.mode {
            Mode::Off => (*bsdf, None),
            Mode::Uniform | Mode::Selective | Mode::Unsampleable => {
                regularize(bsdf, self.tau(), self.energy)
            }
        }
    }

    /// True when `regularize` may widen a lobe with its energy
    /// compensation, the only widening worth a memo (`regularize_with`).
    pub fn compensates(&self) -> bool {
        self.mode != Mode::Off && self.energy == Energy::Preserved
    }

    /// `regularize`, with the widened lobe from `memo` when it holds it
    /// (bit for bit the same result).
    ///
    /// First use: with `Energy::Preserved`, builds the energy tables of the
    /// lobe's model once per process (seconds in a release build, 10-20x
    /// longer unoptimised); `microfacet::prepare_tables` builds them ahead.
    pub fn regularize_with(
        &self,
        bsdf: &Bsdf,
        memo: &mut RegularizationMemo,
    ) -> (Bsdf, Option<AlphaHat>) {
        match self.mode {
            Mode::Off => (*bsdf, None),
            Mode::Uniform | Mode::Selective | Mode::Unsampleable => {
                memo.regularize(bsdf, self.tau(), self.energy)
            }
        }
    }

    /// The state after a vertex with BSDF `bsdf` (its original roughness; a
    /// Lambertian lobe counts as alpha = 1, and so does a coated lobe with a
    /// diffuse base: the path may have left through the base, and rho is
    /// the largest alpha of the path's lobes, SPEC §5).
    ///
    /// In `Unsampleable` mode it also records whether the prefix now has
    /// what one of the integrator's techniques needs ([`Techniques`]).
    pub fn after_vertex(self, bsdf: &Bsdf) -> Self {
        self.through_vertex(bsdf).0
    }

    /// [`Self::after_vertex`] and [`Self::is_camera_only`] of one vertex,
    /// with its bound (`tau::is_bounded`, most of the cost of both)
    /// computed once.
    pub fn through_vertex(self, bsdf: &Bsdf) -> (Self, bool) {
        let alpha = match bsdf {
            Bsdf::Coated(c) if c.has_diffuse() => 1.0,
            _ => bsdf.alpha().unwrap_or(1.0).min(1.0),
        };
        // Only a camera subpath of an integrator with connections or merges
        // uses the record (`tau`), and only until it is sampleable: skip the
        // bound elsewhere.
        let recording = self.is_tracked() && !self.sampleable;
        let bounded = recording && self.is_bounded(bsdf);
        let after = if recording {
            self.after_bounded(bounded)
        } else {
            self
        };
        let after = Self {
            rho: self.rho.max(alpha),
            ..after
        };
        (after, recording && !bounded)
    }

    /// Whether `bsdf` is bounded at this iteration's tau_N (`tau::is_bounded`).
    pub fn is_bounded(&self, bsdf: &Bsdf) -> bool {
        is_bounded(bsdf, self.tau_n)
    }

    /// A camera subpath in `Unsampleable` mode of an integrator with
    /// connections or merges: the only state that records its prefix.
    fn is_tracked(&self) -> bool {
        self.mode == Mode::Unsampleable
            && self.subpath == Subpath::Camera
            && (self.techniques.connections || self.techniques.merges)
    }

    /// The record after a vertex that is `bounded` (or not).
    fn after_bounded(self, bounded: bool) -> Self {
        let connectable = self.techniques.connections && self.previous_bounded;
        let guaranteed = bounded && (connectable || self.techniques.merges);
        Self {
            previous_bounded: bounded,
            sampleable: self.sampleable || guaranteed,
            ..self
        }
    }

    /// Whether the next vertex of this camera subpath, with BSDF `bsdf`, is
    /// one that only camera subpaths may scatter at (`Mode::Unsampleable`):
    /// the prefix guarantees no technique yet and the lobe is not bounded,
    /// so the rule may widen it, while light subpaths, never regularized,
    /// sample it sharp. A technique whose light subpath scatters there
    /// estimates another integrand; such techniques are left out of the
    /// path's MIS weights (this state's `mis` quantities drop them) and
    /// are not made ([`Self::admits_light_interior`]), so the techniques
    /// that remain agree on every vertex and their weights sum to 1.
    pub fn is_camera_only(&self, bsdf: &Bsdf) -> bool {
        self.through_vertex(bsdf).1
    }

    /// Whether a technique may join this camera subpath state (after the
    /// technique's last light vertex, rebuilt with the camera rule) to the
    /// light subpath whose earlier vertices are `bounded`, from the one
    /// before the last back to the light's first: none of them may be
    /// camera-only ([`Self::is_camera_only`]) as seen by the camera rule
    /// continuing along the light subpath. The walk ends within two
    /// vertices: a vertex that is not bounded ends it, and two bounded ones
    /// in a row guarantee a technique.
    pub fn admits_light_interior(self, bounded: impl IntoIterator<Item = bool>) -> bool {
        let mut state = self;
        for bounded in bounded {
            if !state.is_tracked() || state.sampleable {
                return true;
            }
            if !bounded {
                return false;
            }
            state = state.after_bounded(bounded);
        }
        true
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

    fn lambertian() -> Bsdf {
        Bsdf::Lambertian(Lambertian {
            reflectance: Vec3::ONE,
        })
    }

    /// `Unsampleable` with connections: a camera subpath stops regularizing
    /// once its prefix has an edge between two bounded vertices (the camera
    /// counts as one), not after a single bounded vertex behind a mirror.
    #[test]
    fn unsampleable_stops_after_a_bounded_edge_with_connections() {
        let connections = Techniques {
            connections: true,
            merges: false,
        };
        let tau_n = 10.0;
        {
            let subpath = Subpath::Camera;
            let start = PathRegularization::new(Mode::Unsampleable, subpath, tau_n)
                .with_techniques(connections);
            let selective = PathRegularization::new(Mode::Selective, subpath, tau_n);
            // Origin - diffuse: a connectable edge; nothing after it is blurred.
            assert_eq!(start.after_vertex(&lambertian()).tau(), f64::INFINITY);
            // Origin - mirror - diffuse: no bounded edge yet, the selective
            // rule applies; one more bounded vertex makes one.
            let behind_mirror = start.after_vertex(&mirror()).after_vertex(&lambertian());
            let expected = selective
                .after_vertex(&mirror())
                .after_vertex(&lambertian())
                .tau();
            assert_eq!(behind_mirror.tau(), expected);
            assert!(expected.is_finite());
            assert_eq!(
                behind_mirror.after_vertex(&lambertian()).tau(),
                f64::INFINITY
            );
            // A glossy lobe sharper than tau_N bounds no edge.
            let glossy = Bsdf::Conductor(Conductor {
                model: MicrofacetModel::new(NdfKind::Ggx, 0.02, Shadowing::Smith),
                fresnel: Fresnel::Schlick { f0: Vec3::ONE },
            });
            assert!(!crate::is_bounded(&glossy, tau_n) && crate::is_bounded(&glossy, 1e4));
            let after_glossy = behind_mirror
                .after_vertex(&glossy)
                .after_vertex(&lambertian());
            assert!(after_glossy.tau().is_finite());
        }
    }

    /// Camera-only vertices (`Unsampleable` with connections): not bounded
    /// and before the prefix guarantees a technique. A technique is
    /// admitted while the camera rule, walking on along the light subpath,
    /// meets no such vertex among the light's scattering vertices.
    #[test]
    fn camera_only_vertices_and_admitted_light_subpaths() {
        let connections = Techniques {
            connections: true,
            merges: false,
        };
        let start = PathRegularization::new(Mode::Unsampleable, Subpath::Camera, 10.0)
            .with_techniques(connections);
        assert!(start.is_camera_only(&mirror()));
        assert!(!start.is_camera_only(&lambertian()));
        // Camera - diffuse is a bounded edge: nothing after it is camera-only.
        let sampleable = start.after_vertex(&lambertian());
        assert!(!sampleable.is_camera_only(&mirror()));
        assert!(sampleable.admits_light_interior([false, false]));
        // After a mirror (a connection ending there, rebuilt): the light's
        // earlier vertices must not include an unbounded one before two
        // bounded vertices in a row make an edge.
        let after_mirror = start.after_vertex(&mirror());
        assert!(after_mirror.admits_light_interior([]));
        assert!(after_mirror.admits_light_interior([true]));
        assert!(!after_mirror.admits_light_interior([false]));
        assert!(!after_mirror.admits_light_interior([true, false]));
        assert!(after_mirror.admits_light_interior([true, true, false]));
        // With merges one bounded vertex is enough.
        let merges = PathRegularization::new(Mode::Unsampleable, Subpath::Camera, 10.0)
            .with_techniques(Techniques {
                connections: true,
                merges: true,
            })
            .after_vertex(&mirror());
        assert!(merges.admits_light_interior([true, false]));
        // Other modes have no camera-only vertices and admit everything.
        for mode in [Mode::Off, Mode::Uniform, Mode::Selective] {
            let state = PathRegularization::new(mode, Subpath::Camera, 10.0)
                .with_techniques(connections)
                .after_vertex(&mirror());
            assert!(!state.is_camera_only(&mirror()));
            assert!(state.admits_light_interior([false, false]));
        }
    }

    /// With merges one bounded vertex is enough; light subpaths are never
    /// regularized; without connections or merges the camera rule is
    /// `Selective`.
    #[test]
    fn unsampleable_with_merges_and_without_techniques() {
        let merges = Techniques {
            connections: true,
            merges: true,
        };
        let camera = PathRegularization::new(Mode::Unsampleable, Subpath::Camera, 10.0)
            .with_techniques(merges);
        let behind_mirror = camera.after_vertex(&mirror()).after_vertex(&lambertian());
        assert_eq!(behind_mirror.tau(), f64::INFINITY);
        for techniques in [merges, Techniques::default()] {
            let light = PathRegularization::new(Mode::Unsampleable, Subpath::Light, 10.0)
                .with_techniques(techniques);
            assert_eq!(light.tau(), f64::INFINITY);
            assert_eq!(light.after_vertex(&mirror()).tau(), f64::INFINITY);
        }
        let mut unsampleable = PathRegularization::new(Mode::Unsampleable, Subpath::Camera, 10.0);
        let mut selective = PathRegularization::new(Mode::Selective, Subpath::Camera, 10.0);
        for bsdf in [mirror(), lambertian(), lambertian(), mirror()] {
            assert_eq!(unsampleable.tau(), selective.tau());
            unsampleable = unsampleable.after_vertex(&bsdf);
            selective = selective.after_vertex(&bsdf);
        }
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
