//! Light transport: the film, deterministic samplers, camera rays, light
//! sampling, the shared path vertex, and the integrators.
//!
//! This integrator is path tracing (`pt`) with next-event
//! estimation, BSDF sampling and MIS, regularized per SPEC §5-§6. A
//! [`Renderer`] holds a scene prepared for rendering with one
//! [`RenderConfig`]; [`Renderer::render_iteration`] renders one iteration
//! (one sample per pixel) into per-pixel estimates, which a [`Film`]
//! accumulates with their noise.
//!
//! Everything here is deterministic: the value of a pixel is a pure function
//! of (seed, iteration, pixel), whatever the thread count.

mod bidir;
pub mod camera;
pub mod config;
pub mod film;
pub mod geometry;
pub mod lights;
pub mod merge_radius;
mod pt;
pub mod render;
pub mod sampler;
pub mod vertex;

pub use config::{
    Algorithm, ConfigError, DEFAULT_MAX_DEPTH, DEFAULT_RADIUS_ALPHA, DEFAULT_RADIUS_FACTOR,
    DEFAULT_SHADOW_ROULETTE, DEFAULT_TAU_0, Regularization, RenderConfig, Strategies,
};
pub use film::Film;
pub use pt::ROULETTE_DEPTH;
pub use regularization::{Mode, Schedule};
pub use render::Renderer;
