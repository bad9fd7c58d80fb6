//! Camera subpaths of the bidirectional core with all their techniques:
//! emitter hits, next-event estimation, vertex connections and merges.

use std::ops::Range;

use accel::{BatchRay, Hit};
use glam::Vec3;
use microfacet::TransportMode;
use mis::{SubpathRay, SubpathState};
use regularization::Subpath;

use super::light_path::LightVertex;
use super::{Iteration, PhotonMap, WeightedPhoton};
use crate::lights::LightChoice;
use crate::medium;
use crate::nee;
use crate::sampler::Sampler;
use crate::vertex::PathVertex;
use crate::walk::Walk;

/// A camera subpath leaving the camera: its random numbers, its walk, and
/// what its camera ray hits.
#[derive(Clone, Copy, Debug)]
pub(super) struct CameraStart {
    pub sampler: Sampler,
    pub walk: Walk,
    pub hit: Option<Hit>,
}

/// The camera subpaths of a block of pixels and the buffers of their camera
/// rays, kept from block to block ([`Iteration::start_camera_paths`]).
#[derive(Default)]
pub(super) struct CameraRays {
    starts: Vec<CameraStart>,
    rays: Vec<BatchRay>,
    hits: Vec<Option<Hit>>,
}

impl Iteration<'_> {
    /// The camera subpaths of pixels `pixels` (row-major indices), their
    /// camera rays traced as one batch query: neighbouring pixels' rays
    /// are coherent, and small scenes test them in packets
    /// (`accel::Bvh::intersect_batch`; the hits of single queries).
    pub(super) fn start_camera_paths<'b>(
        &self,
        pixels: Range<usize>,
        batch: &'b mut CameraRays,
    ) -> &'b [CameraStart] {
        let ctx = self.ctx;
        let CameraRays { starts, rays, hits } = batch;
        starts.clear();
        starts.extend(pixels.map(|index| {
            let (sampler, walk) = ctx.camera_path_of(self.n, index);
            CameraStart {
                sampler,
                walk,
                hit: None,
            }
        }));
        rays.clear();
        rays.extend(starts.iter().map(|start| start.walk.next_ray()));
        hits.clear();
        hits.resize(rays.len(), None);
        ctx.intersect_camera_batch(rays, hits);
        for (start, &hit) in starts.iter_mut().zip(hits.iter()) {
            start.hit = hit;
        }
        starts
    }

    /// The camera subpath `start` with all its techniques: connections to
    /// `light_path` (the light subpath with the same index), and merges
    /// with the photon map when merging. Returns the pixel estimate without
    /// light-tracing splats.
    pub(super) fn trace_camera_path(
        &self,
        start: &CameraStart,
        light_path: &[LightVertex],
        photon_map: Option<&PhotonMap<WeightedPhoton>>,
    ) -> Vec3 {
        let ctx = self.ctx;
        let max_depth = ctx.config.max_depth;
        let CameraStart {
            sampler,
            mut walk,
            hit: camera_hit,
        } = *start;
        let mut ray =
            SubpathRay::from_camera(&self.mis, f64::from(ctx.camera.pdf_w(walk.direction)));
        let mut regularization = self.path_regularization(Subpath::Camera);
        let mut radiance = Vec3::ZERO;
        for length in 1..=max_depth {
            // Drawn before the ray, as in the path tracer (see there), with
            // the light and light point of next-event estimation.
            let u = sampler.camera_vertex(length);
            let light = self
                .mis
                .techniques()
                .connections
                .then(|| ctx.lights.choose(&ctx.scene, u.u_light, u.uv_light))
                .flatten();
            let hit = if length == 1 {
                camera_hit
            } else {
                walk.next_hit(ctx)
            };
            let Some(hit) = hit else {
                if let Some(le) = ctx.lights.environment(&ctx.scene, walk.direction) {
                    let hit = ctx
                        .lights
                        .environment_pdfs(&ctx.scene, walk.direction)
                        .hit();
                    let w = self.mis.environment_hit_weight(&ray, &hit);
                    radiance += walk.escaped_throughput() * le * w as f32;
                }
                break;
            };
            let point = ctx.surface_point(&hit, walk.origin, walk.direction);
            walk.arrive(&ctx.scene, &point, hit.t);
            let wi = -walk.direction;
            let vertex = PathVertex::new(&ctx.scene, point, wi, walk.throughput, regularization);
            regularization = vertex.regularization;
            let state = ray.arrive(&self.mis, f64::from(hit.t), f64::from(vertex.cos(wi)));
            if let Some(emission) = ctx.emitted(&point, wi) {
                let pdfs = ctx
                    .lights
                    .area_pdfs(point.primitive, point.n_winding.dot(wi));
                let w = self.mis.emitter_hit_weight(&state, &pdfs.hit());
                radiance += walk.throughput * emission * w as f32;
            }
            // The techniques whose light subpath would scatter here are left
            // out from here on (`Mode::Unsampleable`; an emitter hit has none).
            let state = if vertex.camera_only {
                state.without_opposite_scattering()
            } else {
                state
            };
            if length >= max_depth {
                break;
            }
            if !vertex.is_specular() {
                if self.mis.techniques().connections {
                    // The emitter point of next-event estimation is light vertex 0.
                    let u_nee = sampler.keyed_1d(u64::from(length) << 32);
                    if let Some(light) = &light {
                        radiance += self.next_event(&vertex, &state, light, u_nee);
                    }
                    for light in light_path {
                        if light.length + length < max_depth {
                            let key = u64::from(length) << 32 | u64::from(light.length);
                            let u = || sampler.keyed_1d(key);
                            radiance += self.connect(&vertex, &state, light, u);
                        }
                    }
                }
                if let Some(photon_map) = photon_map {
                    radiance += walk.throughput * self.merge(&vertex, &state, length, photon_map);
                }
            }

            let Some(s) = walk.step(&vertex, length, u.step, TransportMode::Radiance, 1.0) else {
                break;
            };
            ray = state.scatter(&self.mis, &vertex.scatter_event(&s));
        }
        radiance
    }

    /// Next-event estimation (s = 1) at a camera vertex towards the light
    /// and point `light`, weighted against
    /// every other technique: the contribution to the pixel (camera
    /// throughput included). Its shadow ray goes through the same roulette
    /// as those of connections: its MIS weight shares the path with them.
    fn next_event(
        &self,
        vertex: &PathVertex,
        state: &SubpathState,
        light: &LightChoice,
        u_roulette: f32,
    ) -> Vec3 {
        let Some((ls, f)) = nee::light_sample(self.ctx, vertex, light) else {
            return Vec3::ZERO;
        };
        let unweighted = vertex.throughput * f * ls.li / ls.pdf;
        let contribution = self.roulette.weighted(unweighted, u_roulette, || {
            self.mis
                .next_event_weight(state, &vertex.connection_end(ls.wi), &ls.mis_sample())
                as f32
        });
        match contribution {
            Some(contribution) if nee::visible(self.ctx, vertex, &ls) => contribution,
            _ => Vec3::ZERO,
        }
    }

    /// A vertex connection between a camera vertex and a light vertex: the
    /// contribution to the pixel (camera throughput included). The light
    /// vertex is regularized as the camera subpath would regularize its next
    /// vertex (see `connect_to_camera`). `u_roulette` draws the roulette's
    /// random number, a hash: a third of the pairs are rejected on geometry
    /// alone and need none.
    fn connect(
        &self,
        camera: &PathVertex,
        camera_state: &SubpathState,
        light: &LightVertex,
        u_roulette: impl FnOnce() -> f32,
    ) -> Vec3 {
        let d = light.point.p - camera.point.p;
        // What is zero whichever the distance, first: a light vertex behind
        // the camera vertex's surface, or seen from behind its own.
        let light_bound = light.bound_towards(-d);
        if !camera.is_consistent_towards(d) || light_bound <= 0.0 {
            return Vec3::ZERO;
        }
        let distance2 = d.length_squared();
        let distance = distance2.sqrt();
        if !(distance > 0.0) {
            return Vec3::ZERO;
        }
        let dir = d / distance;
        // The camera side next: it needs no vertex to be rebuilt.
        let f_camera = camera.eval(dir, TransportMode::Radiance);
        if f_camera.max_element() <= 0.0 {
            return Vec3::ZERO;
        }
        // With a bound of the light side, the roulette often decides before
        // the light vertex is rebuilt (the same decisions as from the
        // contribution itself).
        let u_roulette = u_roulette();
        let bound =
            (camera.throughput * f_camera).max_element() * (light_bound / distance) / distance2;
        if self.roulette.skips(bound, u_roulette) {
            return Vec3::ZERO;
        }
        let light_vertex = light.vertex(&self.ctx.scene, camera.regularization);
        if light_vertex.is_specular()
            || !light_vertex
                .regularization
                .admits_light_interior(light.earlier_bounded())
        {
            return Vec3::ZERO;
        }
        let f = f_camera * light_vertex.eval(-dir, TransportMode::Importance);
        if f.max_element() <= 0.0 {
            return Vec3::ZERO;
        }
        // The segment's transmittance (either end knows its medium): at
        // most 1, so `bound` above still bounds the contribution.
        let inside = camera
            .medium_towards(dir)
            .or_else(|| light_vertex.medium_towards(-dir));
        let unweighted = medium::attenuated(
            camera.throughput * f * light.throughput / distance2,
            inside,
            distance,
        );
        let Some(contribution) = self.roulette.weighted(unweighted, u_roulette, || {
            self.mis.connection_weight(
                &light.state,
                &light_vertex.light_end(-dir),
                camera_state,
                &camera.connection_end(dir),
                f64::from(distance),
            ) as f32
        }) else {
            return Vec3::ZERO;
        };
        let origin = camera.point.spawn_origin(dir);
        let end = light.point.spawn_origin(-dir);
        let surfaces = [camera.point.primitive, light.point.primitive];
        if self
            .ctx
            .occluded_between(origin, end - origin, 1.0, surfaces)
        {
            return Vec3::ZERO;
        }
        contribution
    }

    /// Vertex merging at a camera vertex `length` segments from the
    /// camera, each merge weighted against every other technique.
    fn merge(
        &self,
        camera: &PathVertex,
        camera_state: &SubpathState,
        length: u32,
        photon_map: &PhotonMap<WeightedPhoton>,
    ) -> Vec3 {
        photon_map.gather(camera, length, self.ctx.config.max_depth, |record| {
            let photon = &record.photon;
            if !camera
                .regularization
                .admits_light_interior(photon.earlier_bounded())
            {
                return 0.0;
            }
            self.mis.merge_weight(
                &record.state,
                camera_state,
                &camera.connection_pdfs(photon.wi),
            ) as f32
        })
    }
}
