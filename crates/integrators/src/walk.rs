//! A random walk between vertices: where a subpath's next ray starts, where
//! it goes, and what it carries. Every subpath of every integrator extends
//! itself the same way: a BSDF sample at the vertex, then Russian roulette.

use accel::{BatchRay, Hit, NO_SURFACE};
use glam::Vec3;
use microfacet::TransportMode;
use scene::{Medium, Scene};

use crate::context::SceneContext;
use crate::geometry::SurfacePoint;
use crate::medium;
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
    /// Product of f |cos| / pdf so far (and of roulette reweighting, and of
    /// the transmittance of the segments traced).
    pub throughput: Vec3,
    /// The absorbing medium the next ray starts into, as its origin's
    /// surface knows ([`crate::medium`]); `None` from cameras and lights.
    pub medium: Option<Medium>,
    /// The primitive the next ray leaves ([`accel::NO_SURFACE`] from cameras
    /// and lights), which its query need not test
    /// ([`SceneContext::intersect_leaving`]).
    pub surface: u32,
}

impl Walk {
    /// A walk starting along the ray (`origin`, `direction`) with throughput 1.
    pub fn new(origin: Vec3, direction: Vec3) -> Self {
        Self {
            origin,
            direction,
            throughput: Vec3::ONE,
            medium: None,
            surface: NO_SURFACE,
        }
    }

    /// The closest hit of the next ray.
    #[inline]
    pub fn next_hit(&self, ctx: &SceneContext) -> Option<Hit> {
        ctx.intersect_leaving(self.origin, self.direction, f32::INFINITY, self.surface)
    }

    /// The next ray as a query of a batch (what [`Walk::next_hit`] asks).
    #[inline]
    pub fn next_ray(&self) -> BatchRay {
        BatchRay {
            origin: self.origin,
            direction: self.direction,
            t_max: f32::INFINITY,
            skip: [self.surface; 2],
        }
    }

    /// The ray has hit `point` after `distance`: the throughput takes the
    /// segment's transmittance, its medium being the origin's or else the
    /// one behind `point` that it arrives from ([`crate::medium`]).
    #[inline]
    pub fn arrive(&mut self, scene: &Scene, point: &SurfacePoint, distance: f32) {
        let inside = self
            .medium
            .or_else(|| medium::at(scene, point, -self.direction));
        self.throughput = medium::attenuated(self.throughput, inside, distance);
    }

    /// The throughput of the ray that left the scene: 0 in the channels of
    /// a medium it started in (a closed volume lets no ray escape but
    /// rounding's; those see an infinite distance of it).
    #[inline]
    pub fn escaped_throughput(&self) -> Vec3 {
        medium::attenuated(self.throughput, self.medium, f32::INFINITY)
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
        self.follow(vertex, (s.wo, s.weight), depth, scale, u.u_roulette)
            .then_some(s)
    }

    /// The second half of [`Walk::step`]: the walk leaves `vertex` in the
    /// sampled direction `wo` with the sample's weight (f |cos| / pdf),
    /// then plays Russian roulette. False when the walk ends.
    #[inline(always)]
    pub fn follow(
        &mut self,
        vertex: &PathVertex,
        (wo, weight): (Vec3, Vec3),
        depth: u32,
        scale: f32,
        u_roulette: f32,
    ) -> bool {
        self.throughput *= weight;
        self.origin = vertex.point.spawn_origin(wo);
        self.surface = vertex.point.primitive;
        self.direction = wo;
        self.medium = vertex.medium_towards(wo);
        roulette::survives(depth, &mut self.throughput, scale, u_roulette)
    }
}
