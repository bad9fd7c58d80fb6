//! Progressive photon mapping (Hachisuka et al. 2008; SmallVCM's `ppm`;
//! SPEC §7): the light pass and photon map of the bidirectional core, and
//! camera paths that follow delta lobes and stop at their first
//! non-specular vertex, where they merge with the photons. Every path is
//! found by exactly one technique (emitter hits after delta bounces only,
//! one merge otherwise), so there is no MIS. Regularization applies as
//! everywhere: a near-specular vertex that alpha-hat blurs is non-specular
//! and merges.

use glam::{UVec2, Vec3};
use microfacet::TransportMode;
use rayon::prelude::*;
use regularization::{PathRegularization, Subpath};

use super::{Bidirectional, Iteration, LIGHT_BLOCK, PhotonMap};
use crate::context::SceneContext;
use crate::integrator::Integrator;
use crate::roulette;
use crate::vertex::PathVertex;

/// The progressive photon mapper.
#[derive(Clone, Copy, Debug)]
pub struct ProgressivePhotonMapper {
    /// The merging-only core whose light pass it uses.
    core: Bidirectional,
}

impl ProgressivePhotonMapper {
    /// The photon mapper for `ctx` (its algorithm must be [`crate::Algorithm::Ppm`]).
    pub fn new(ctx: &SceneContext) -> Self {
        Self {
            core: Bidirectional::new(ctx),
        }
    }
}

impl Integrator for ProgressivePhotonMapper {
    fn render_iteration(&self, ctx: &SceneContext, n: u64, estimates: &mut [Vec3]) {
        let it = self.core.iteration(ctx, n);
        // Without connections the light pass records no splats.
        let (paths, _) = it.trace_light_paths(estimates.len());
        let photon_map = PhotonMap::new(&paths, it.radius, estimates.len());
        estimates
            .par_chunks_mut(LIGHT_BLOCK)
            .enumerate()
            .for_each(|(block, chunk)| {
                for (k, out) in chunk.iter_mut().enumerate() {
                    *out = it.trace_gather_path(block * LIGHT_BLOCK + k, &photon_map);
                }
                ctx.flush_ray_count();
            });
    }
}

impl Iteration<'_> {
    /// The camera path of pixel `index` (row-major): emission seen directly
    /// or through delta lobes, and the density estimate at the first
    /// non-specular vertex.
    fn trace_gather_path(&self, index: usize, photon_map: &PhotonMap<'_>) -> Vec3 {
        let ctx = self.ctx;
        let max_depth = ctx.config.max_depth;
        let width = ctx.scene.camera.resolution.x as usize;
        let pixel = UVec2::new((index % width) as u32, (index / width) as u32);
        let (mut sampler, mut origin, mut direction) = ctx.camera_path(self.n, pixel.x, pixel.y);
        let mut regularization = PathRegularization::new(self.mode, Subpath::Camera, self.tau_n);
        let mut throughput = Vec3::ONE;
        let mut radiance = Vec3::ZERO;
        for length in 1..=max_depth {
            let Some(hit) = ctx.intersect(origin, direction, f32::INFINITY) else {
                if let Some(le) = ctx.lights.environment() {
                    radiance += throughput * le;
                }
                break;
            };
            let point = ctx.surface_point(&hit);
            let wi = -direction;
            if let Some(emission) = ctx.emitted(&point, wi) {
                radiance += throughput * emission;
            }
            if length >= max_depth {
                break;
            }
            let vertex = PathVertex::new(&ctx.scene, point, wi, throughput, regularization);
            regularization = vertex.regularization;
            if !vertex.is_specular() {
                radiance += throughput * photon_map.gather(&vertex, length, max_depth, |_| 1.0);
                break;
            }
            let u = sampler.camera_vertex(length);
            let Some(s) = vertex.sample(u.u_lobe, u.uv_bsdf, TransportMode::Radiance) else {
                break;
            };
            throughput *= s.weight;
            origin = point.spawn_origin(s.wo);
            direction = s.wo;
            if !roulette::survives(length, &mut throughput, 1.0, u.u_roulette) {
                break;
            }
        }
        radiance
    }
}
