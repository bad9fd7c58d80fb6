//! A random walk between vertices: where a subpath's next ray starts, where
//! it goes, and what it carries. Every subpath of every integrator extends
//! itself the same way: a BSDF sample at the vertex, then Russian roulette.

use glam::Vec3;
use microfacet::TransportMode;

use crate::roulette;
use crate::sampler::StepSamples;
use crate::vertex::{PathVertex, VertexSample};

/// The state of a subpath between two vertices.
#[derive(Clone, Copy, Debug)]
pub struct Walk {
    /// Origin of the next ray.
    pub origin: Vec3,
    /// Its unit direction.
    pub direction: Vec3,
    /// Product of f |cos| / pdf so far (and of roulette reweighting).
    pub throughput: Vec3,
}

impl Walk {
    /// A walk starting along the ray (`origin`, `direction`) with throughput 1.
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        Self {
            origin,
            direction,
            throughput: Vec3::ONE,
        }
    }

    /// Continues the walk from `vertex`, the `depth`-th of its subpath: a
    /// direction sampled from the vertex's BSDF in `mode`, then Russian
    /// roulette on the throughput relative to `scale` (see
    /// [`roulette::survives`]). The sample, or `None` when the walk ends.
    #[inline]
    pub fn step(
        &mut self,
        vertex: &PathVertex,
        depth: u32,
        u: StepSamples,
        mode: TransportMode,
        scale: f32,
    ) -> Option<VertexSample> {
        let s = vertex.sample(u.u_lobe, u.uv_bsdf, mode)?;
        self.throughput *= s.weight;
        self.origin = vertex.point.spawn_origin(s.wo);
        self.direction = s.wo;
        roulette::survives(depth, &mut self.throughput, scale, u.u_roulette).then_some(s)
    }
}
