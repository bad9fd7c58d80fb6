//! The integrators' integration tests, in one binary: estimators against each other and
//! against closed forms on small scenes.
//! One binary per crate: one link instead of one per file, tables and
//! fixtures built once and shared, and the long tests run beside the short
//! ones rather than after them.

mod absorption;
mod bidir;
mod common;
mod energy;
mod environment;
mod furnace;
mod hostile;
mod maps;
mod pt;
mod real_materials;
mod spheres;
