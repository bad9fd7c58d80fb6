#![doc = include_str!("../README.md")]
//!
//! # Layout
//!
//! - [`Heuristic`]: balance and power heuristics (Veach 1997, ch. 9).
//! - [`SubpathState`] / [`SubpathRay`]: the recursive sub-path quantities of
//!   vertex connection and merging (Georgiev, Křivánek, Davidovič, Slusallek
//!   2012, "Light Transport Simulation with Vertex Connection and Merging", and
//!   Georgiev 2012, "Implementing Vertex Connection and Merging", cited as
//!   "tech. rep. eq. N"), extended by virtual merges (supp. §6).
//! - [`MisConfig`]: the technique set ([`Techniques`]: BPT, merging only, VCM,
//!   each with or without virtual merges), N, the merge radius and the
//!   heuristic, and the weight of every technique: emitter hits
//!   ([`MisConfig::emitter_hit_weight`], [`MisConfig::environment_hit_weight`]),
//!   next-event estimation ([`MisConfig::next_event_weight`]), light tracing
//!   ([`MisConfig::light_tracing_weight`]), vertex connections
//!   ([`MisConfig::connection_weight`]) and merges
//!   ([`MisConfig::merge_weight`]).
//! - [`mod@reference`]: the same weights computed explicitly from a whole path's
//!   per-vertex pdfs, without recursion (the tests' oracle).
//!
//! # Conventions (SmallVCM's)
//!
//! - Callers pass solid-angle pdfs at the vertices and |cos| and distances;
//!   the recursion converts to area measure with |cos|/d^2 itself.
//! - Every pdf includes what the sampler really does: light selection
//!   probabilities, Russian roulette continuation probabilities (for both the
//!   forward and the reverse pdf of a vertex), the discrete probability of the
//!   chosen lobe.
//! - A light sub-path starts at an emitter ([`SubpathRay::from_light`]), a
//!   camera sub-path at a pinhole or thin-lens camera
//!   ([`SubpathRay::from_camera`]). After tracing a ray, [`SubpathRay::arrive`]
//!   gives the state of the vertex found; [`SubpathState::scatter`] samples on.
//!   Light vertices store their [`SubpathState`] for connections and merges.
//! - Specular (delta) vertices follow the tech. rep.'s specular rule (§5.2):
//!   pass the discrete probability of the chosen component as both pdfs and
//!   set [`Scatter::specular`]; such vertices are never connection, merge or
//!   virtual-merge vertices.
//! - The camera vertex is never hit (t = 0 is not a technique), and an emitter
//!   is never connected directly to the camera (s = 1, t = 1 is not a
//!   technique): an emitter seen from the camera has weight 1, as in SmallVCM.
//!
//! # Regularized vertices (paper eq. 13, SPEC §6)
//!
//! A technique that evaluates the regularized BSDF rho_hat at a vertex uses,
//! for MIS, p_hat = (rho_hat / rho) p, p being the pdf with the original
//! roughness. **For this crate that only means: pass p_hat (or the pdf of the
//! regularized lobe, supp. §4) as the vertex's pdfs in [`VertexPdfs`], and
//! pass the same choice for the vertex to every technique.** The recursion
//! itself treats these numbers like any other pdfs. With one pdf pair per
//! vertex (SPEC's `off` and `uniform` modes) the weights of all techniques
//! that can produce a path sum to 1; in `selective` mode the two sub-paths may
//! see one vertex with different roughness, and they do not.
//!
//! # Virtual merges (supp. §6, SPEC §6): the model implemented
//!
//! **Virtual-merge vertices.** A vertex x_a can be a virtual-merge vertex iff
//! it is a non-specular surface vertex with a finite regularization bound
//! tau_a ([`VertexPdfs::tau`]; [`NOT_REGULARIZED`] = infinity otherwise).
//! Emitter and camera vertices never are; specular vertices never are (an
//! unregularized delta lobe cannot be connected; a regularized one is glossy,
//! not specular). Whether to give a vertex whose roughness regularization did
//! not change a finite tau is the caller's choice: its acceptance is small
//! (its lobe is wider than the cone), and the model degrades gracefully.
//!
//! **The technique.** For every edge (x_a, x_b) that a connection can join
//! (next-event estimation, a vertex connection, light tracing), and every
//! virtual-merge vertex x_a at an end of it, there is one virtual merge
//! VM(x_a -> x_b): the sub-path that ends at x_a samples a direction from
//! x_a's BSDF, as the next step of its random walk would, and the sample is
//! accepted when the direction falls inside the cone of solid angle 1/tau_a
//! around x_a -> x_b. An edge with two regularized ends has two virtual merges.
//!
//! **Its path pdf.** P_VM = P_conn p_acc, where P_conn is the path pdf of the
//! connection on the same edge and p_acc = min(1, p_w(x_a -> x_b) / tau_a)
//! (supp. eq. 14, clamped: [`acceptance_probability`]), p_w the solid-angle
//! pdf (p_hat) of x_a's BSDF. Written as a merge at x_b, P_VM = P_conn
//! p_A(x_b) A with p_A(x_b) = p_w |cos theta_b| / d^2 the area pdf with which
//! x_a's sub-path samples x_b and A = d^2 / (tau_a |cos theta_b|) the
//! acceptance area ([`acceptance_area`]): the form of a VCM merge, P_conn
//! p_A(x_b) eta_VCM, with eta_VCM = N pi r^2 replaced by A. It takes as many
//! samples as the connection it belongs to (1, or N for light tracing).
//!
//! **An additional technique, executed as the connection.** The virtual merge
//! is a different sampling technique from the plain connection (it samples the
//! edge's direction at x_a instead of joining two fixed vertices), so both
//! are in the technique set: the plain connection's path pdf is P_conn, the
//! actual density of the connection estimator, and stays. The integrator does
//! not run the virtual merge separately: averaged over the acceptance test,
//! its estimator f / P_VM * \[accepted\] has expectation f / P_conn, which is
//! the connection estimator. So the connection is executed once and weighted
//! with w_conn + w_VM(x_a) + w_VM(x_b), which is what the connection-type
//! weight functions return. (The alternative reading, the connection *being*
//! the virtual merge, would weight it by P_conn p_acc; at a vertex whose lobe is
//! wider than the cone, p_acc -> 0 would then switch connections off there.)
//!
//! **The recursion.** Like a merge, a virtual merge adds one term per edge to
//! the sums of the dVCM recursion, which carries it in two places
//! ([`SubpathState`]): the acceptance of the virtual merge sampled at the
//! previous vertex towards this one is known when this vertex is sampled and
//! multiplies the edge's connection term in `d_vcm` by (1 + p_acc^beta); the
//! acceptance of the one sampled at this vertex towards the previous one
//! depends on this vertex's next direction, so it is kept as a coefficient,
//! `d_virtual`, and applied with the vertex's reverse pdf, like the reverse pdf
//! in `d_vc`.
//!
//! **Why not the supplemental's shortcut.** Supp. §6 proposes to store
//! p / p_acc (= tau, or max(p, tau) with the clamp) in place of the vertex's
//! pdf, arguing that the stored pdf enters the path pdf of every technique but
//! the virtual merge, so that this divides all of them by p_acc. It divides
//! exactly the path pdfs that contain the stored pdf, and no others: on the
//! path camera - x1 (regularized) - x2 - light, with the virtual merge on the
//! connection x1 - x2 sampled at x1, the emitter hit and next-event estimation
//! at x2 contain x1's pdf towards x2 and gain the factor 1/p_acc, but light
//! tracing from x1 contains no pdf of x1 and does not, so against them it
//! loses a factor p_acc that no virtual merge accounts for (spec-review O2).
//! Used consistently by every technique, the shortcut is still a partition of
//! unity -- only a different one, in which no technique has the virtual
//! merge's path pdf; used where the supplemental places it (the sampled pdf
//! stored at the vertex, while connections and light tracing evaluate the BSDF
//! afresh) the weights no longer sum to 1. The tests show both
//! (`tests/mis/negative_control.rs`).
//!
//! # Numerics
//!
//! All quantities are f64 and raised to the heuristic's power factor by factor.
//! Ratios of path pdfs are stiff (pdfs from 1e-30 to 1e30 over ten vertices
//! give 1e600), so every product, quotient and sum saturates at 1e300 and
//! denominators are floored at 1e-300 (named constants, with the reasons, in
//! the private `numeric` module): no function returns NaN or infinity, and
//! every weight is in [0, 1]. Inputs are sanitized: NaN and negative pdfs
//! count as 0, infinite ones as 1e300, cosines by absolute value, a NaN or
//! non-positive tau as "not regularized". Within the range the guards are
//! exact, so the recursion agrees with [`mod@reference`] to rounding.
//!
//! # Example: the weight of next-event estimation in BPT
//!
//! ```
//! use mis::*;
//!
//! let config = MisConfig::bpt(640 * 480, Heuristic::POWER).unwrap();
//! // The camera ray hits its first vertex 2.0 away, at |cos| 0.8.
//! let camera = SubpathRay::from_camera(&config, 1.3).arrive(&config, 2.0, 0.8);
//! // Next-event estimation towards an area light.
//! let end = ConnectionEnd {
//!     pdfs: VertexPdfs::new(0.4, 0.3), // BSDF pdfs towards the light / back to the camera
//!     cos: 0.7,
//! };
//! let light = LightSample {
//!     kind: EmitterKind::Area,
//!     direct_pdf_w: 2.5,
//!     emission_pdf_w: 0.1,
//!     cos_light: 0.9,
//! };
//! let w = config.next_event_weight(&camera, &end, &light);
//! assert!(w > 0.0 && w <= 1.0);
//! ```

mod config;
mod error;
mod heuristic;
mod numeric;
pub mod reference;
mod subpath;
mod virtual_merge;
mod weights;

pub use config::{MisConfig, Techniques};
pub use error::MisError;
pub use heuristic::{Heuristic, Sampled, balance_heuristic, power_heuristic};
pub use subpath::{
    Emission, EmitterKind, NOT_REGULARIZED, Scatter, SubpathRay, SubpathState, VertexPdfs,
};
pub use virtual_merge::{acceptance_area, acceptance_probability};
pub use weights::{ConnectionEnd, EmitterHit, LightSample};
