#![doc = include_str!("../README.md")]
//!
//! # Contents
//!
//! The API is narrow so that the BVH library can be swapped by editing this
//! crate only:
//!
//! - [`Bvh`]: a triangle BVH (this crate's binned SAH builder, or [obvhs]'
//!   PLOC with reinsertion, converted to an 8-wide BVH in obvhs' compressed
//!   node format, or with float child boxes tested eight at a time and the
//!   triangles of a leaf four at a time on the CPU's best SIMD instruction
//!   set ([`Layout::Bvh8`], [`Isa`]), or for a scene of at most 64
//!   primitives no tree, its triangles tested sixteen at a time
//!   ([`Layout::Flat`])), with
//!   closest-hit ([`Bvh::intersect`]) and
//!   any-hit ([`Bvh::occluded`]) queries that return caller triangle ids and
//!   barycentrics. The ray/triangle test is this crate's own watertight test
//!   (Woop et al. 2013); obvhs only traverses nodes.
//! - [`offset_ray_origin`]: self-intersection avoidance for secondary rays
//!   (Wächter and Binder, Ray Tracing Gems ch. 6), instead of a scene-scale
//!   epsilon.
//! - [`HashGrid`]: a hashed uniform grid for photon range search
//!   ([`HashGrid::for_each_within`]), rebuilt in parallel every iteration
//!   without reallocating.
//!
//! No obvhs type appears in the API.
//!
//! # Robustness
//! - Empty triangle lists, degenerate (zero-area) triangles and non-finite
//!   inputs never panic; such triangles are simply never hit.
//! - Queries are exact with respect to obvhs' known numerical shortcuts: its
//!   CWBVH node test ignores everything closer than `t = 1e-4` and its
//!   `Ray::new` clamps small direction components; the traversal ray is
//!   therefore built here (exact power-of-two direction scaling and our own
//!   reciprocal), see [`Bvh::intersect`].
//!
//! # Choice of layout and preset
//! The default layout (wide CWBVH) was picked from the `cargo bench -p
//! accel` numbers (`benches/bvh.rs`); [`Layout::Bvh8`], the same
//! conversion with float nodes, leaves of up to four triangles and
//! run-time dispatched SIMD node and leaf tests, traces as fast, faster
//! on some ray sets and slower on others (docs/benchmarks.md), with 3.2
//! times the node memory and a 160-byte block per leaf. On a CPU with
//! AVX-512, the default scans a scene of at most 64 triangles (and no
//! spheres) without a tree ([`Layout::Flat`]), measured faster there. The default builder,
//! [`BuildQuality::Binned`], replaced obvhs' `medium` preset for its
//! memory, with trees that trace as fast or faster (its documentation
//! has the measurements).
//!
//! [obvhs]: https://crates.io/crates/obvhs

/// The glam this crate's API is written in (0.34): types such as `Vec3` in its
/// signatures are `accel::glam` types. Depend on the same glam version, or
/// use `accel::glam` directly, to avoid "multiple different versions of crate
/// `glam`" errors.
pub use glam;

mod binned;
mod bvh;
mod bvh8;
mod convert;
mod flat;
mod grid;
mod leaf;
mod offset;
mod packet;
mod sphere;
mod traverse;
mod triangle;

pub use bvh::{BuildOptions, BuildQuality, Bvh, Hit, Layout, MAX_COORDINATE, NO_SURFACE};
pub use bvh8::Isa;
pub use grid::HashGrid;
pub use offset::{offset_ray_origin, offset_ray_origin_bounded, offset_ray_origin_scaled};
pub use packet::BatchRay;
pub use sphere::{HIT_POINT_RELATIVE_ERROR, Sphere};
