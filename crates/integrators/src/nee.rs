//! Next-event estimation: a light sample for a camera subpath vertex, the
//! vertex's BSDF towards it, and the shadow ray. How the contribution is
//! weighted (power heuristic in PT, the VCM recursion in the bidirectional
//! core) is the integrator's.

use glam::{Vec2, Vec3};
use microfacet::TransportMode;

use crate::context::SceneContext;
use crate::lights::LightSample;
use crate::vertex::PathVertex;

/// A light sample for `vertex` with the vertex's f |cos| towards it, times
/// the transmittance of the shadow segment where it starts into an
/// absorbing medium ([`crate::medium`]; lights are outside every medium),
/// if both are non-zero. The shadow ray is the caller's ([`visible`]): the
/// bidirectional core decides its roulette first.
#[inline]
pub fn light_sample(
    ctx: &SceneContext,
    vertex: &PathVertex,
    u_light: f32,
    uv: Vec2,
) -> Option<(LightSample, Vec3)> {
    let ls = ctx.lights.sample(&ctx.scene, vertex.point.p, u_light, uv)?;
    let mut f = vertex.eval(ls.wi, TransportMode::Radiance);
    if let Some(m) = vertex.medium_towards(ls.wi) {
        let distance = ls
            .point
            .map_or(f32::INFINITY, |lp| (lp.p - vertex.point.p).length());
        f *= m.transmittance(distance);
    }
    (f.max_element() > 0.0).then_some((ls, f))
}

/// Whether the shadow ray from `vertex` to the light sample is unoccluded.
pub fn visible(ctx: &SceneContext, vertex: &PathVertex, ls: &LightSample) -> bool {
    let origin = vertex.point.spawn_origin(ls.wi);
    match ls.point {
        Some(lp) => {
            let end = if lp.n == Vec3::ZERO {
                lp.p
            } else {
                let n = if lp.n.dot(-ls.wi) > 0.0 { lp.n } else { -lp.n };
                lp.error.offset(lp.p, n)
            };
            !ctx.occluded(origin, end - origin, 1.0)
        }
        None => !ctx.occluded(origin, ls.wi, f32::INFINITY),
    }
}
