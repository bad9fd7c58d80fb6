//! The integrators' integration tests, in one binary: estimators against each other and
//! against closed forms on small scenes.
//! One binary per crate (ARCHITECTURE.md, "Tests are statistical").

mod absorption;
mod bidir;
mod common;
mod energy;
mod environment;
mod furnace;
mod hostile;
mod maps;
mod mitsuba_camera;
mod pt;
mod real_materials;
mod spheres;
mod thin_dielectric;
mod wavefront;
