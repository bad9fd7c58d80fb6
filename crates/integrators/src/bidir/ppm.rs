//! Progressive photon mapping (Hachisuka et al. 2008; SmallVCM's `ppm`;
//! SPEC §7): the light pass and photon map of the bidirectional core, and
//! camera paths that follow delta lobes and stop at their first
//! non-specular vertex, where they merge with the photons. Every path is
//! found by exactly one technique (emitter hits after delta bounces only,
//! one merge otherwise), so there is no MIS. Regularization applies as
//! everywhere: a near-specular vertex that alpha-hat blurs is non-specular
//! and merges.

use glam::Vec3;
use microfacet::TransportMode;
use regularization::Subpath;

use super::{Bidirectional, CameraStart, Iteration, Photon, PhotonMap, PhotonMapBuffers};
use crate::context::SceneContext;
use crate::integrator::{Integrator, Stop};
use crate::vertex::PathVertex;

/// The progressive photon mapper.
#[derive(Clone, Debug)]
pub struct ProgressivePhotonMapper {
    /// The merging-only core whose light pass it uses.
    core: Bidirectional,
    /// Its photon map's buffers: bare photons, as no merge is weighted.
    photon_map: PhotonMapBuffers<Photon>,
}

impl ProgressivePhotonMapper {
    /// See [`Bidirectional::photon_map_bytes`].
    pub fn photon_map_bytes(&self, ctx: &SceneContext) -> u64 {
        self.core.photon_map_bytes_of::<Photon>(ctx)
    }

    /// The photon mapper for `ctx` (its algorithm must be [`crate::Algorithm::Ppm`]).
    pub fn new(ctx: &SceneContext) -> Self {
        Self {
            core: Bidirectional::new(ctx),
            photon_map: PhotonMapBuffers::default(),
        }
    }
}

impl Integrator for ProgressivePhotonMapper {
    fn render_iteration(&self, ctx: &SceneContext, n: u64, estimates: &mut [Vec3], stop: Stop<'_>) {
        let it = self.core.iteration(ctx, n, stop);
        self.photon_map.with(|kept| {
            // Without connections the light pass records no splats.
            let blocks = std::mem::take(&mut kept.blocks);
            let (paths, _) = it.trace_light_paths::<Photon>(estimates.len(), blocks);
            if stop.requested() {
                return;
            }
            paths.build_photon_map(&mut kept.map, it.radius, estimates.len());
            // Without connections nothing else reads the light vertices.
            kept.blocks = paths.into_photon_blocks();
            let photon_map = &kept.map;
            it.camera_pass(estimates, |_, start| {
                it.trace_gather_path(start, photon_map)
            });
        });
    }
}

impl Iteration<'_> {
    /// The camera path `start`: emission seen directly or through delta
    /// lobes, and the density estimate at the first non-specular vertex.
    fn trace_gather_path(&self, start: &CameraStart, photon_map: &PhotonMap<Photon>) -> Vec3 {
        let ctx = self.ctx;
        let max_depth = ctx.config.max_depth;
        let CameraStart {
            sampler,
            mut walk,
            hit: camera_hit,
        } = *start;
        let mut regularization = self.path_regularization(Subpath::Camera);
        let mut radiance = Vec3::ZERO;
        for length in 1..=max_depth {
            let hit = if length == 1 {
                camera_hit
            } else {
                walk.next_hit(ctx)
            };
            let Some(hit) = hit else {
                if let Some(le) = ctx.lights.environment(&ctx.scene, walk.direction) {
                    radiance += walk.escaped_throughput() * le;
                }
                break;
            };
            let point = ctx.surface_point(&hit, walk.origin, walk.direction);
            walk.arrive(&ctx.scene, &point, hit.t);
            let wi = -walk.direction;
            if let Some(emission) = ctx.emitted(&point, wi) {
                radiance += walk.throughput * emission;
            }
            if length >= max_depth {
                break;
            }
            let vertex = PathVertex::new(&ctx.scene, point, wi, walk.throughput, regularization);
            regularization = vertex.regularization;
            if !vertex.is_specular() {
                let gathered = photon_map.gather(&vertex, length, max_depth, |_| 1.0);
                radiance += walk.throughput * gathered;
                break;
            }
            let u = sampler.camera_vertex(length).step;
            if walk
                .step(&vertex, length, u, TransportMode::Radiance, 1.0)
                .is_none()
            {
                break;
            }
        }
        radiance
    }
}
