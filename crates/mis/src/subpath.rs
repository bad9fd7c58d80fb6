//! The recursive sub-path quantities (tech. rep. §4-§5), extended by virtual
//! merges.

use crate::MisConfig;
use crate::numeric::{abs, add, div, mul};

/// How an emitter can be sampled and hit.
///
/// | kind | hit by a random ray (s = 0) | position measure |
/// |---|---|---|
/// | `Area` | yes | area (finite) |
/// | `Point` | no (delta position) | area (finite) |
/// | `Directional` | no (delta direction) | solid angle (infinite) |
/// | `Environment` | yes | solid angle (infinite) |
///
/// For delta emitters the delta factor itself is left out of every pdf (it is
/// common to all techniques that can sample the path): pass the selection
/// probability where a pdf of the delta quantity is asked for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum EmitterKind {
    /// An emitting surface (finite, can be hit).
    Area,
    /// A point light (finite, delta position: never hit).
    Point,
    /// A directional light (infinite, delta direction: never hit).
    Directional,
    /// An environment map or constant background (infinite, can be hit).
    Environment,
}

impl EmitterKind {
    /// Whether a random ray can hit the emitter (technique s = 0 exists).
    pub fn is_hittable(self) -> bool {
        matches!(self, Self::Area | Self::Environment)
    }

    /// Whether the emitter is at infinity. Its "position" is then a
    /// direction: position pdfs are solid-angle pdfs, and the first segment of
    /// a light sub-path has no 1/d^2 (tech. rep. §5.1).
    pub fn is_infinite(self) -> bool {
        matches!(self, Self::Directional | Self::Environment)
    }

    /// Whether the emitter has a surface whose cosine enters the pdfs
    /// (only `Area`).
    pub(crate) fn has_surface(self) -> bool {
        matches!(self, Self::Area)
    }
}

/// An emitted light sub-path ray, as sampled by the light sub-path.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Emission {
    /// The emitter's kind.
    pub kind: EmitterKind,
    /// The pdf with which next-event estimation would choose this emission
    /// point, including the light-selection probability: area measure for
    /// finite emitters, solid angle (of the direction) for infinite ones
    /// (SmallVCM's `directPdfA`).
    pub direct_pdf_a: f64,
    /// The pdf of the emitted ray, position times direction, including the
    /// light-selection probability (SmallVCM's `emissionPdfW`). For infinite
    /// emitters: direction pdf times the pdf of the ray's origin on the disc
    /// that covers the scene.
    pub emission_pdf_w: f64,
    /// |cos| between the emitter's surface normal and the emitted direction.
    /// Used for `Area` only; the other kinds use 1.
    pub cos_light: f64,
}

/// The solid-angle pdfs at a surface vertex, for the two directions of one
/// path through it, and the vertex's regularization bound.
///
/// The pdfs are those of the BSDF sampler of the vertex, times the Russian
/// roulette continuation probability when the integrator uses one (SmallVCM
/// does the same). **At a regularized vertex pass p_hat (paper eq. 13:
/// p_hat = (rho_hat/rho) p), or the pdf of the regularized lobe (supp. §4),
/// here -- the same choice for every technique** (SPEC §6). The MIS code
/// treats these numbers as the pdfs of the vertex and does nothing else with
/// the regularization except the virtual merges, which use `tau`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VertexPdfs {
    /// Pdf of sampling the "forward" direction: for a scattering event, the
    /// sampled direction given the incoming one; at a connection or merge, the
    /// direction towards the other sub-path given the own incoming direction
    /// (SmallVCM's `bsdfDirPdfW`).
    pub fwd: f64,
    /// Pdf of the reverse event: sampling the incoming direction given the
    /// forward one (SmallVCM's `bsdfRevPdfW`).
    pub rev: f64,
    /// The regularization bound tau of the vertex (SPEC §5: the largest
    /// solid-angle density of the regularized lobe; 1/tau is the solid angle
    /// of the blur cone). `f64::INFINITY` (see [`NOT_REGULARIZED`]) when the
    /// vertex is not regularized: it then takes part in no virtual merge.
    pub tau: f64,
}

/// The `tau` of a vertex that is not regularized: no blur cone, no virtual
/// merge.
pub const NOT_REGULARIZED: f64 = f64::INFINITY;

impl VertexPdfs {
    /// Pdfs of a vertex that is not regularized.
    pub fn new(fwd: f64, rev: f64) -> Self {
        Self {
            fwd,
            rev,
            tau: NOT_REGULARIZED,
        }
    }

    /// Pdfs of a regularized vertex with bound `tau`; `fwd` and `rev` should
    /// be p_hat (see the type's documentation).
    pub fn regularized(fwd: f64, rev: f64, tau: f64) -> Self {
        Self { fwd, rev, tau }
    }
}

/// A scattering event at a surface vertex: the sub-path samples its next
/// direction there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Scatter {
    /// `pdfs.fwd`: pdf of the sampled direction; `pdfs.rev`: pdf of the
    /// incoming direction given the sampled one; `pdfs.tau`: the vertex's
    /// regularization bound. For a specular (delta) event pass the discrete
    /// probability of the chosen component for both (the delta cancels).
    pub pdfs: VertexPdfs,
    /// |cos| between the shading normal and the sampled direction.
    pub cos_out: f64,
    /// The sampled component is a delta distribution (mirror, smooth
    /// refraction, or any lobe below the smoothness threshold that is *not*
    /// regularized). Such a vertex cannot be connected, merged at, or be a
    /// virtual-merge vertex (tech. rep. §5.2).
    pub specular: bool,
}

/// The MIS quantities of a sub-path vertex (tech. rep. eq. 31-36), with the
/// virtual-merge extension.
///
/// Let the sub-path be y_0 (its origin: emitter or camera), y_1, ..., y_i
/// (this vertex), and let p-> and p<- be the area pdfs of a vertex when
/// sampled by this sub-path and by the opposite one. All quantities are
/// already raised to the heuristic's power beta, like SmallVCM's `Mis()`:
///
/// - `d_vcm` = c_VC (1 + a->(y_{i-1})) / p->(y_i): the connection on the edge
///   (y_{i-1}, y_i) relative to the techniques that sample y_i with this
///   sub-path, including the virtual merge sampled at y_{i-1} towards y_i,
///   whose acceptance a->(y_{i-1}) is known when y_i is sampled. At the first
///   vertex the edge's connection is next-event estimation (light sub-path) or
///   light tracing (camera sub-path), with their own pdfs (eq. 31, 48).
/// - `d_virtual` = c_VC / p->(y_i): the coefficient of the acceptance
///   a<-(y_i) of the virtual merge sampled at y_i towards y_{i-1}. It depends
///   on y_i's next direction, so it is only known at the next scattering event,
///   connection or merge (like the reverse pdf in `d_vc`).
/// - `d_vc`: everything further back (eq. 32/35). Times r^beta, r being the
///   solid-angle pdf at y_i of sampling y_{i-1} given y_i's next direction, it
///   is p<-(y_{i-1})^beta (eta + V_{i-1}) / p->(y_i)^beta, V_{i-1} the bracket
///   of y_{i-1} (see [`SubpathState::scatter`]); r is only known later, like
///   the acceptance in `d_virtual`.
///
/// c_VC is 1 when connections are on and 0 otherwise, eta = eta_VCM^beta when
/// merging is on and 0 otherwise, so one recursion serves BPT, merging only and
/// VCM.
///
/// SmallVCM's third quantity, dVM, is not needed: whenever both connections and
/// merging are on it equals dVC / eta_VCM, and the technique switches are
/// applied through c_VC and eta here. Its slot is taken by `d_virtual`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubpathState {
    d_vcm: f64,
    d_vc: f64,
    d_virtual: f64,
    segments: u32,
}

/// A sub-path that has sampled a direction and not yet found its next vertex:
/// the state between a scattering event (or the sub-path's start) and the
/// next intersection (SmallVCM's partial update, completed after tracing).
///
/// A camera ray that leaves the scene is used as it is, to weight an
/// environment hit ([`MisConfig::environment_hit_weight`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SubpathRay {
    state: SubpathState,
    /// The ray leaves an infinite emitter: no 1/d^2 on arrival.
    infinite: bool,
}

impl SubpathRay {
    /// The light sub-path's first ray (tech. rep. eq. 31-33, with delta and
    /// infinite emitters per eq. 48-50 and §5.1):
    ///
    /// - d_vcm = c_VC p_direct / p_emission (next-event estimation of the same
    ///   point against emission sampling),
    /// - d_virtual = c_VC p_direct / p_emission (the virtual merge at the first
    ///   vertex towards the emitter is one of next-event estimation),
    /// - d_vc = \[hittable\] cos_light / p_emission (the emitter hit, s = 0),
    ///
    /// all to the power beta. `cos_light` is 1 for every kind but `Area`.
    pub fn from_light(config: &MisConfig, emission: &Emission) -> Self {
        let emission_pdf = config.mis(emission.emission_pdf_w);
        let direct = div(config.mis(emission.direct_pdf_a), emission_pdf);
        let d_vcm = mul(config.connect, direct);
        let cos_light = if emission.kind.has_surface() {
            config.mis(abs(emission.cos_light))
        } else {
            1.0
        };
        let d_vc = if emission.kind.is_hittable() {
            div(cos_light, emission_pdf)
        } else {
            0.0
        };
        Self {
            state: SubpathState {
                d_vcm,
                d_vc,
                d_virtual: d_vcm,
                segments: 0,
            },
            infinite: emission.kind.is_infinite(),
        }
    }

    /// The camera sub-path's first ray, `camera_pdf_w` being the solid-angle
    /// pdf of its direction (tech. rep. eq. 31-33):
    ///
    /// - d_vcm = c_VC N / p_camera (light tracing, t = 1, takes N samples),
    /// - d_virtual = c_VC N / p_camera (the virtual merge at the first vertex
    ///   towards the camera is one of light tracing),
    /// - d_vc = 0 (no technique samples the camera vertex by chance),
    ///
    /// all to the power beta. The camera is a pinhole or thin lens: its vertex
    /// is sampled alike by every technique with t >= 1, so its pdf cancels.
    pub fn from_camera(config: &MisConfig, camera_pdf_w: f64) -> Self {
        let d_vcm = mul(
            config.connect,
            div(config.mis_light_paths, config.mis(camera_pdf_w)),
        );
        Self {
            state: SubpathState {
                d_vcm,
                d_vc: 0.0,
                d_virtual: d_vcm,
                segments: 0,
            },
            infinite: false,
        }
    }

    /// The ray has hit its next vertex at `distance`, with |cos| `cos_in`
    /// between the shading normal there and the ray: convert the solid-angle
    /// pdf of the sampled direction into an area pdf (tech. rep. eq. 34-36,
    /// the part SmallVCM applies after tracing).
    ///
    /// d_vcm and d_virtual gain d^2 / |cos_in| (the pdf they divide by becomes
    /// p_w |cos_in| / d^2); d_vc gains only 1 / |cos_in|, its d^2 cancels
    /// against the reverse pdf's conversion (SmallVCM issue #7). Rays from an
    /// infinite emitter carry no d^2 (§5.1).
    #[must_use]
    pub fn arrive(self, config: &MisConfig, distance: f64, cos_in: f64) -> SubpathState {
        let cos_in = config.mis(abs(cos_in));
        let d2 = if self.infinite {
            1.0
        } else {
            let d = abs(distance);
            config.mis(mul(d, d))
        };
        let s = self.state;
        SubpathState {
            d_vcm: div(mul(s.d_vcm, d2), cos_in),
            d_vc: div(s.d_vc, cos_in),
            d_virtual: div(mul(s.d_virtual, d2), cos_in),
            segments: s.segments.saturating_add(1),
        }
    }

    /// The number of segments of the sub-path before this ray (0 for the ray
    /// leaving the emitter or camera).
    pub fn segments(&self) -> u32 {
        self.state.segments
    }

    /// The quantities before arrival, as a vertex at infinity sees them.
    pub(crate) fn pending_state(&self) -> SubpathState {
        self.state
    }
}

impl SubpathState {
    /// The sub-path samples its next direction at this vertex (tech. rep.
    /// eq. 34-36 for a non-specular event, eq. 53-55 for a specular one),
    /// extended by virtual merges. With p = `pdfs.fwd`, r = `pdfs.rev`,
    /// c = `cos_out`, a-> = acceptance(p, tau), a<- = acceptance(r, tau), all
    /// to the power beta:
    ///
    /// Non-specular:
    /// - V = d_vcm + d_virtual a<- + d_vc r (this vertex's techniques relative
    ///   to the ones that sample it with the opposite sub-path),
    /// - d_vc' = c (eta + V) / p,
    /// - d_vcm' = c_VC (1 + a->) / p,
    /// - d_virtual' = c_VC / p.
    ///
    /// Specular (the vertex can neither be connected nor merged at, nor be a
    /// virtual-merge vertex): d_vcm' = d_virtual' = 0 and d_vc' = c d_vc r / p.
    ///
    /// The result still lacks the conversion to the next vertex's area measure:
    /// finish it with [`SubpathRay::arrive`].
    #[must_use]
    pub fn scatter(&self, config: &MisConfig, event: &Scatter) -> SubpathRay {
        let fwd = config.mis(event.pdfs.fwd);
        let rev = config.mis(event.pdfs.rev);
        let cos_out = config.mis(abs(event.cos_out));
        let state = if event.specular {
            SubpathState {
                d_vcm: 0.0,
                d_vc: div(mul(mul(cos_out, self.d_vc), rev), fwd),
                d_virtual: 0.0,
                segments: self.segments,
            }
        } else {
            let back = self.behind(config, event.pdfs.rev, event.pdfs.tau);
            let accept_fwd = config.mis(config.acceptance(event.pdfs.fwd, event.pdfs.tau));
            SubpathState {
                d_vcm: div(mul(config.connect, add(1.0, accept_fwd)), fwd),
                d_vc: div(mul(cos_out, add(config.mis_eta, back)), fwd),
                d_virtual: div(config.connect, fwd),
                segments: self.segments,
            }
        };
        SubpathRay {
            state,
            infinite: false,
        }
    }

    /// The techniques that sample this vertex with the opposite sub-path
    /// (and, for merges at it, with both), relative to the ones that sample it
    /// with this sub-path only -- once the reverse pdf `rev` of this vertex
    /// (sampling the previous vertex given the direction towards the other
    /// sub-path) is known:
    ///
    /// V = d_vcm + d_virtual a<-^beta + d_vc rev^beta, a<- = acceptance(rev, tau).
    ///
    /// This is the bracket of tech. rep. eq. 38-41 without the merge term.
    #[inline]
    pub(crate) fn behind(&self, config: &MisConfig, rev: f64, tau: f64) -> f64 {
        let accept_rev = config.mis(config.acceptance(rev, tau));
        add(
            add(self.d_vcm, mul(self.d_virtual, accept_rev)),
            mul(self.d_vc, config.mis(rev)),
        )
    }

    /// The same state at a vertex where the opposite sub-path may end but
    /// not scatter (regularization's `Unsampleable` mode: this sub-path may
    /// widen the vertex's lobe, the opposite one samples it sharp, so a
    /// technique that scatters there estimates another integrand and is
    /// left out). Drops the techniques whose opposite sub-path scatters
    /// here: everything further back (d_vc) and the virtual merge sampled
    /// here (d_virtual). The connection on the edge that ends here (d_vcm)
    /// stays. Apply it before the vertex's techniques and its scattering.
    #[must_use]
    pub fn without_opposite_scattering(self) -> Self {
        Self {
            d_vc: 0.0,
            d_virtual: 0.0,
            ..self
        }
    }

    /// dVCM (tech. rep. eq. 31/34), extended by the virtual merge sampled at
    /// the previous vertex (see the type's documentation).
    pub fn d_vcm(&self) -> f64 {
        self.d_vcm
    }

    /// dVC (tech. rep. eq. 32/35).
    pub fn d_vc(&self) -> f64 {
        self.d_vc
    }

    /// The coefficient of the acceptance of the virtual merge sampled at this
    /// vertex towards the previous one (see the type's documentation).
    pub fn d_virtual(&self) -> f64 {
        self.d_virtual
    }

    /// The number of segments from the sub-path's origin to this vertex (1 for
    /// the first vertex).
    pub fn segments(&self) -> u32 {
        self.segments
    }
}
