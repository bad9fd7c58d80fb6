#![doc = include_str!("../README.md")]
//!
//! # Layout (SPEC §5-§6)
//!
//! - [`tau`]: what tau bounds, in one place, and alpha-hat for reflection,
//!   transmission and the strict variant.
//! - [`schedule`]: the progressive tau_N (supp. §5) and the cone <-> tau maps.
//! - [`selective`]: off / uniform / selective / unsampleable modes and the
//!   per-vertex tau_k carried along a subpath.
//! - [`pdf`]: the MIS pdf correction p-hat (paper eq. 13, supp. §4).
//! - [`foreign`]: the same for another renderer's lobes ([`MicrofacetLobe`]).
//! - [`memo`]: the last widened lobes, for callers that widen the same few
//!   lobes again and again (a compensated lobe costs microseconds to build).

/// The glam this crate's API is written in (0.34): types such as `Vec3` in its
/// signatures are `regularization::glam` types. Depend on the same glam version, or
/// use `regularization::glam` directly, to avoid "multiple different versions of crate
/// `glam`" errors.
pub use glam;

/// The microfacet crate whose `Bsdf` this crate regularizes, so that a
/// dependent needs no second, possibly different, version of it.
pub use microfacet;

pub mod foreign;
pub mod memo;
pub mod pdf;
pub mod schedule;
pub mod selective;
pub mod tau;

pub use foreign::{MicrofacetLobe, RegularizedLobe};
pub use memo::RegularizationMemo;
pub use pdf::{p_hat, p_hat_of_sample};
pub use schedule::{
    DEFAULT_SCHEDULE_EXPONENT, MAX_SCHEDULE_EXPONENT, Schedule, ScheduleError, cone_of_tau,
    tau_of_cone,
};
pub use selective::{Mode, PathRegularization, Subpath, Techniques, UnknownMode};
pub use tau::{
    AlphaHat, Bound, Energy, Lobe, StrictError, alpha_hat, alpha_hat_strict, is_bounded, regularize,
};
