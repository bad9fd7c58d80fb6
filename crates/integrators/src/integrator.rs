//! The one interface of every light-transport algorithm. The renderer
//! dispatches to the configured one with a `match` over an enum
//! ([`crate::render`]), not through a trait object.

use std::sync::atomic::{AtomicBool, Ordering};

use glam::Vec3;

use crate::context::SceneContext;

/// A request to abandon an iteration, checked before every block of work
/// (an image row, a block of subpaths): at 4K an iteration can take a
/// minute, and an interrupt must act within about a second.
#[derive(Clone, Copy, Debug)]
pub struct Stop<'a>(Option<&'a AtomicBool>);

impl<'a> Stop<'a> {
    /// No request can come.
    pub const NEVER: Stop<'static> = Stop(None);

    /// Stop when `flag` is set.
    pub fn when(flag: &'a AtomicBool) -> Self {
        Self(Some(flag))
    }

    /// Whether the iteration is to be abandoned.
    #[inline]
    pub fn requested(self) -> bool {
        self.0.is_some_and(|flag| flag.load(Ordering::Relaxed))
    }
}

/// A light-transport algorithm over a prepared scene.
pub trait Integrator {
    /// Renders iteration `n` (1-based; it drives tau_N and the merge radius
    /// and selects the random streams) into `estimates`: one estimate per
    /// pixel, row-major, light-tracing splats included. Parallel on the
    /// current rayon pool; the result does not depend on the number of
    /// threads. Estimates may be NaN or infinite; the caller counts them.
    /// When `stop` is requested, remaining blocks are skipped and the
    /// estimates are incomplete (the caller discards them).
    fn render_iteration(&self, ctx: &SceneContext, n: u64, estimates: &mut [Vec3], stop: Stop<'_>);
}
