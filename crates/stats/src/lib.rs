//! Statistical test machinery shared by the renderer's crates.
//!
//! Sampling code is checked the way pbrt-v4 (`bsdfs_test.cpp`) and Mitsuba 3
//! (`chi2.py`) check it: draw many samples, bin them on a (theta, phi) grid,
//! integrate the claimed pdf over every cell, and run a chi-square goodness of
//! fit test with pooled low-count cells and a Sidak-corrected significance.
//!
//! Everything here is deterministic (fixed seeds) and pure computation: no
//! I/O, no threads, no global state.

pub mod chi2;
pub mod quadrature;
pub mod rng;
pub mod special;
pub mod summary;

pub use chi2::{Chi2Outcome, SphericalChi2};
pub use rng::Pcg32;
pub use summary::Summary;
