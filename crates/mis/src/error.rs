//! The crate's error type.

use std::fmt;

/// Invalid parameters of a heuristic, a configuration or a reference path.
///
/// Only constructors and the explicit [`reference`](crate::reference) return
/// errors; the per-vertex functions never fail (they sanitize their inputs,
/// see the crate documentation, "Numerics").
#[derive(Clone, Copy, Debug, PartialEq)]
#[non_exhaustive]
pub enum MisError {
    /// The heuristic exponent beta must be finite and positive.
    InvalidExponent(f64),
    /// The number of light sub-paths per iteration must be at least 1.
    NoLightPaths,
    /// The merge radius must be finite and non-negative, and positive when
    /// merging is enabled.
    InvalidRadius(f64),
    /// Virtual merges are executed as connections (see the crate
    /// documentation), so they need connections to be enabled.
    VirtualMergesNeedConnections,
    /// A reference path needs at least two vertices (emitter and camera).
    PathTooShort,
    /// A reference path has a pdf, acceptance probability or count that is
    /// negative or NaN; `vertex` is its index (0 = emitter).
    InvalidPathValue {
        /// Index of the offending vertex (0 is the emitter).
        vertex: usize,
    },
}

impl fmt::Display for MisError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::InvalidExponent(beta) => {
                write!(
                    f,
                    "MIS heuristic exponent must be finite and > 0, got {beta}"
                )
            }
            Self::NoLightPaths => write!(f, "the number of light sub-paths must be at least 1"),
            Self::InvalidRadius(r) => write!(
                f,
                "merge radius must be finite and >= 0 (> 0 when merging), got {r}"
            ),
            Self::VirtualMergesNeedConnections => write!(
                f,
                "virtual merges are executed as connections and need connections enabled"
            ),
            Self::PathTooShort => write!(f, "a path needs at least an emitter and a camera vertex"),
            Self::InvalidPathValue { vertex } => {
                write!(
                    f,
                    "negative or NaN pdf or acceptance at path vertex {vertex}"
                )
            }
        }
    }
}

impl std::error::Error for MisError {}
