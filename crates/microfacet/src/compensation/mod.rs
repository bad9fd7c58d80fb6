//! Energy compensation of regularized lobes: an addition to the BSDF model
//! above it in this crate (ndf, shadowing, vndf, fresnel), which these
//! tables integrate and which never reads them.
//!
//! Regularization widens a lobe from alpha to alpha-hat, and a wider
//! single-scattering lobe reflects less (or, with V-cavity shadowing and at
//! some cosines, more) than the original. The compensation keeps each
//! lobe's white-furnace albedo: Kulla & Conty's lobe for the lost energy
//! ("Revisiting Physically Based Shading at Imageworks", SIGGRAPH 2017
//! course, §"Energy compensation"; ARCHITECTURE.md, "Energy-preserving
//! regularization"), applied to the difference between the original and the
//! widened lobe, and a reciprocal scaling of a lobe that gains.
//!
//! Layers, each reading only those before it:
//! - `quadrature`: directional albedos by quadrature over microfacet normals
//!   (the rules themselves are `crate::gauss`);
//! - `energy`: the conductor albedo tables E(mu, alpha) and their
//!   interpolation; `gain`: the mean-scale tables of a lobe that gains;
//! - `vcavity_onsets`, `dielectric_energy`, `dielectric_gain`: the same for
//!   an interface that reflects and transmits;
//! - `reflection` (`Compensation`, held by a regularized `MicrofacetModel`
//!   for conductors and coats) and `dielectric` (`DielectricCompensation`,
//!   held by a regularized `Dielectric`): what a lobe evaluates, from the
//!   tables;
//! - `tables`: the list of tables a lobe reads, to build them ahead of
//!   their first use ([`prepare_tables`]).

pub mod dielectric;
pub mod dielectric_energy;
pub mod dielectric_gain;
pub mod energy;
pub mod gain;
mod quadrature;
pub mod reflection;
pub mod tables;
mod vcavity_onsets;

pub use dielectric::DielectricCompensation;
pub use reflection::Compensation;
pub use tables::{EnergyTable, prepare_tables};
