//! The one interface of every light-transport algorithm. The renderer
//! dispatches to the configured one with a `match` over an enum
//! ([`crate::render`]), not through a trait object.

use glam::Vec3;

use crate::context::SceneContext;

/// A light-transport algorithm over a prepared scene.
pub trait Integrator {
    /// Renders iteration `n` (1-based; it drives tau_N and the merge radius
    /// and selects the random streams) into `estimates`: one estimate per
    /// pixel, row-major, light-tracing splats included. Parallel on the
    /// current rayon pool; the result does not depend on the number of
    /// threads. Estimates may be NaN or infinite; the caller counts them.
    fn render_iteration(&self, ctx: &SceneContext, n: u64, estimates: &mut [Vec3]);
}
