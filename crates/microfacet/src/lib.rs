#![doc = include_str!("../README.md")]
//!
//! # Conventions (SPEC §0)
//! - Shading frame with normal n = (0, 0, 1); every direction is a unit vector
//!   pointing away from the surface.
//! - `wi` is the direction a BSDF is queried from (towards the previous vertex
//!   of the subpath being built), `wo` the other one. eta_i is the index of
//!   refraction on the side of `wi`, eta_t on the other side.
//! - `alpha` is the microfacet width itself (glTF's roughness r gives alpha = r^2).
//! - [`TransportMode::Radiance`] for camera subpaths, [`TransportMode::Importance`]
//!   for light subpaths: refraction differs between them by (eta_i/eta_t)^2.
//!
//! # Layout
//! - [`ndf`]: D(h), its maximum and bounds, Smith Lambda and G1, D(h)<h,n> sampling.
//! - [`shadowing`]: Smith and V-cavity masking-shadowing.
//! - [`vndf`]: visible-normal samplers (GGX, Beckmann, V-cavity).
//! - [`model`]: an NDF with its shadowing model and sampler.
//! - [`compensation`]: albedo tables and the compensation lobe that keeps a
//!   regularized lobe's energy (Kulla & Conty 2017), for conductors and
//!   coats and for dielectrics (tables per eta and side, a reciprocal
//!   reflection/transmission split); above the lobes' math, which never
//!   reads it.
//! - [`fresnel`], [`bounds`], [`frame`], [`special`]: building blocks.
//! - [`sample`]: what lobes return (a sampled direction) and the transport
//!   mode; [`lambertian`], [`conductor`], [`dielectric`], [`coated`] (glTF
//!   metallic-roughness): the lobes;
//!   [`bsdf`]: the enum that dispatches to them.
//!
//! Equation numbers refer to `SPEC.md` (§) and the paper's supplemental
//! document ("supp. eq."), as the doc comment of each function says.

/// The glam this crate's API is written in (0.34): types such as `Vec3` in its
/// signatures are `microfacet::glam` types. Depend on the same glam version, or
/// use `microfacet::glam` directly, to avoid "multiple different versions of crate
/// `glam`" errors.
pub use glam;

pub mod bounds;
pub mod bsdf;
pub mod coated;
pub mod compensation;
pub mod conductor;
pub mod dielectric;
pub mod frame;
pub mod fresnel;
mod gauss;
pub mod lambertian;
pub mod model;
pub mod ndf;
pub mod sample;
pub mod shadowing;
pub mod special;
pub mod thin_dielectric;
pub mod vndf;

pub use bsdf::Bsdf;
pub use coated::Coated;
pub use compensation::prepare_tables;
pub use conductor::Conductor;
pub use dielectric::Dielectric;
pub use fresnel::Fresnel;
pub use lambertian::Lambertian;
pub use model::{HalfVectorSample, MicrofacetModel, SMOOTH_ALPHA};
pub use ndf::{Ndf, NdfKind};
pub use sample::{BsdfSample, TransportMode};
pub use shadowing::Shadowing;
pub use thin_dielectric::ThinDielectric;
