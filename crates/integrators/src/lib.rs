//! Light transport: the film, deterministic samplers, camera rays, light
//! sampling (environment maps included), the shared path vertex, and the integrators: path tracing
//! (`pt`) and one bidirectional core for BPT, PPM and VCM (`bidir`), all
//! regularized per SPEC §5-§6.
//!
//! A [`Renderer`] holds a scene prepared once for rendering
//! ([`context::SceneContext`]) and the integrator of one [`RenderConfig`];
//! [`Renderer::render_iteration`] renders one iteration (one sample per
//! pixel) into per-pixel estimates, which a [`Film`] accumulates with their
//! noise.
//!
//! Everything here is deterministic: the value of a pixel is a pure function
//! of (seed, iteration, pixel), whatever the thread count.

mod bidir;
pub mod camera;
mod colour;
pub mod config;
pub mod context;
pub mod environment;
pub mod film;
pub mod geometry;
mod integrator;
pub mod lights;
pub mod medium;
pub mod merge_radius;
mod nee;
pub mod normal_map;
mod pt;
pub mod render;
pub mod roulette;
pub mod sampler;
pub mod vertex;
pub mod walk;

pub use config::{
    Algorithm, ConfigError, DEFAULT_MAX_DEPTH, DEFAULT_RADIUS_ALPHA, DEFAULT_RADIUS_FACTOR,
    DEFAULT_SHADOW_ROULETTE, DEFAULT_TAU_0, Regularization, RenderConfig, Strategies,
};
pub use film::Film;
pub use regularization::{Energy, Mode, Schedule};
pub use render::Renderer;
pub use roulette::ROULETTE_DEPTH;

/// Peak memory of the BVH build per triangle ([`accel::Bvh::BUILD_BYTES_PER_TRIANGLE`]),
/// for callers that check memory before a scene is prepared.
pub const BVH_BUILD_BYTES_PER_TRIANGLE: u64 = accel::Bvh::BUILD_BYTES_PER_TRIANGLE;
