//! Next-event estimation: a light sample for a camera subpath vertex, the
//! vertex's BSDF towards it, and the shadow ray. How the contribution is
//! weighted (power heuristic in PT, the VCM recursion in the bidirectional
//! core) is the integrator's.

use glam::Vec3;
use microfacet::TransportMode;

use crate::context::SceneContext;
use crate::lights::{LightChoice, LightPoint, LightSample};
use crate::vertex::PathVertex;

/// The light sample of the light and point `choice` ([`Lights::choose`])
/// for `vertex`, with the vertex's f |cos| towards it, times the
/// transmittance of the shadow segment where it starts into an absorbing
/// medium ([`crate::medium`]; lights are outside every medium), if both are
/// non-zero. The shadow ray is the caller's ([`visible`]): the
/// bidirectional core decides its roulette first.
///
/// [`Lights::choose`]: crate::lights::Lights::choose
#[inline]
pub fn light_sample(
    ctx: &SceneContext,
    vertex: &PathVertex,
    choice: &LightChoice,
) -> Option<(LightSample, Vec3)> {
    let ls = ctx
        .lights
        .sample_chosen(&ctx.scene, choice, vertex.point.p)?;
    light_value(vertex, &ls).map(|f| (ls, f))
}

/// The second half of [`light_sample`]: the vertex's f |cos| towards the
/// light sample `ls`, times the transmittance of the shadow segment, if
/// non-zero.
#[inline]
pub fn light_value(vertex: &PathVertex, ls: &LightSample) -> Option<Vec3> {
    let mut f = vertex.eval(ls.wi, TransportMode::Radiance);
    if let Some(m) = vertex.medium_towards(ls.wi) {
        let distance = ls
            .point
            .map_or(f32::INFINITY, |lp| (lp.p - vertex.point.p).length());
        f *= m.transmittance(distance);
    }
    (f.max_element() > 0.0).then_some(f)
}

/// Whether the shadow ray from `vertex` to the light sample is unoccluded.
pub fn visible(ctx: &SceneContext, vertex: &PathVertex, ls: &LightSample) -> bool {
    let ray = shadow_ray(vertex, ls);
    !ctx.occluded_between(ray.origin, ray.direction, ray.t_max, ray.surfaces)
}

/// A segment to test for occlusion: `origin + t direction`, t in (0, t_max).
#[derive(Clone, Copy, Debug)]
pub struct ShadowRay {
    /// Its start, off the surface it leaves.
    pub origin: Vec3,
    /// Its direction: to the light point's offset position (`t_max` 1), or
    /// the unit direction to a light at infinity (`t_max` infinite).
    pub direction: Vec3,
    /// Where the segment ends, in units of `direction`.
    pub t_max: f32,
    /// The triangles its ends lie on, which need not be tested
    /// ([`SceneContext::occluded_between`]).
    pub surfaces: [u32; 2],
}

impl ShadowRay {
    /// The ray as a query of a batch (what
    /// [`SceneContext::occluded_between`] asks).
    #[inline]
    pub fn batch_ray(&self) -> accel::BatchRay {
        accel::BatchRay {
            origin: self.origin,
            direction: self.direction,
            t_max: self.t_max,
            skip: self.surfaces,
        }
    }
}

/// The shadow ray from `vertex` to the light sample: both ends moved off
/// their surfaces (`accel::offset`), so neither hits its own surface.
#[inline]
pub fn shadow_ray(vertex: &PathVertex, ls: &LightSample) -> ShadowRay {
    shadow_ray_towards(vertex, ls.wi, ls.point)
}

/// [`shadow_ray`] to the light point `point` (`None` for a light at
/// infinity) in direction `wi`.
#[inline]
pub fn shadow_ray_towards(vertex: &PathVertex, wi: Vec3, point: Option<LightPoint>) -> ShadowRay {
    let origin = vertex.point.spawn_origin(wi);
    match point {
        Some(lp) => {
            let end = if lp.n == Vec3::ZERO {
                lp.p
            } else {
                let n = if lp.n.dot(-wi) > 0.0 { lp.n } else { -lp.n };
                lp.error.offset(lp.p, n)
            };
            ShadowRay {
                origin,
                direction: end - origin,
                t_max: 1.0,
                surfaces: [vertex.point.primitive, lp.surface],
            }
        }
        None => ShadowRay {
            origin,
            direction: wi,
            t_max: f32::INFINITY,
            surfaces: [vertex.point.primitive, accel::NO_SURFACE],
        },
    }
}
