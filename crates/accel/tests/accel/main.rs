//! The accel crate's integration tests, in one binary: the BVH, the binned builder and
//! analytic spheres against f64 brute force, and the photon grid.
//! One binary per crate (ARCHITECTURE.md, "Tests are statistical").

mod batch;
mod binned;
mod bvh;
mod common;
mod grid;
mod isa;
mod layouts;
mod skip;
mod sphere;
