//! The accel crate's integration tests, in one binary: the BVH, the binned builder and
//! analytic spheres against f64 brute force, and the photon grid.
//! One binary per crate: one link instead of one per file, tables and
//! fixtures built once and shared, and the long tests run beside the short
//! ones rather than after them.

mod binned;
mod bvh;
mod common;
mod grid;
mod sphere;
