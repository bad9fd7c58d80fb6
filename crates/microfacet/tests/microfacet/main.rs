//! The microfacet crate's integration tests, in one binary: sampling against densities,
//! energy and its compensation, reciprocity, and numerical edges.
//! One binary per crate (ARCHITECTURE.md, "Tests are statistical").

mod bounds;
mod chi2;
mod coated;
mod common;
mod dielectric_compensation;
mod edges;
mod energy;
mod energy_compensation;
mod extreme_uniforms;
mod fresnel_critical;
mod index_matched;
mod normalisation;
mod reciprocity;
mod tint;
