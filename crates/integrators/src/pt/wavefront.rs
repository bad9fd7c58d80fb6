//! The path tracer as a wavefront (Laine, Karras and Aila 2013,
//! "Megakernels Considered Harmful"; pbrt-v4's `WavefrontPathIntegrator`):
//! the camera paths of a run of pixels advance together, one bounce at a
//! time, through stages that each do one kind of work for all of them:
//!
//! 1. **extend**: the closest hit of every path's ray, as one batch of ray
//!    queries;
//! 2. **shade**: emission found and escaped rays (environment), the path
//!    vertex, and a light sample whose shadow ray joins the shadow queue
//!    (at Lambertian vertices towards triangle and point lights, 16 vertices
//!    at a time in SIMD lanes: [`lanes`](super::lanes));
//! 3. **shadow**: the shadow queue's occlusion queries as one batch, the
//!    unoccluded contributions added;
//! 4. **continue**: a BSDF sample (Lambertian ones in lanes) and Russian
//!    roulette per surviving path; the paths that end leave the wavefront
//!    (compaction).
//!
//! The queues are per worker and sized for its caches (one run of at most
//! [`WAVEFRONT`] pixels), not global with a barrier per stage: pbrt-v4's
//! global queues made its CPU wavefront 5-10x slower than its scalar
//! integrators (../shared/notes/simd-and-wavefront.md §4).
//!
//! **The scalar path tracer's estimate, bit for bit.** Each path draws the
//! same sampler requests, makes the same floating-point operations in the
//! same order and adds its terms to its pixel in the same order (emission,
//! then the light sample, bounce after bounce) as
//! [`PathTracer::trace_path`]; only the interleaving of different paths
//! changes. So every image is byte-identical to the scalar one (tested on
//! every bundled kind of scene), which is a stronger agreement than equal
//! expected values, and the scalar loop stays the readable reference.

use accel::{BatchRay, Hit};
use fearless_simd::Level;
use glam::Vec3;
use microfacet::TransportMode;
use regularization::{PathRegularization, Subpath};

use super::lanes::{LANES, NeeLanes, StepLanes, TargetSample};
use super::{Bounce, PathTracer};
use crate::context::SceneContext;
use crate::geometry::SurfacePoint;
use crate::lights::LightSample;
use crate::nee::{self, ShadowRay};
use crate::sampler::{CameraVertexSamples, Sampler};
use crate::vertex::PathVertex;
use crate::walk::Walk;

/// Paths per wavefront, at most: the pixels of a row are traced in runs of
/// this many. Its state (about 0.5 KiB a path with its vertex, 256 KiB in
/// all) then stays in a core's L2 cache, and after a few bounces enough
/// paths are left for full packets of rays (`accel::Bvh::intersect_batch`):
/// 512 measured 0.968 of 256's CPU time on both SmallVCM scenes.
pub const WAVEFRONT: usize = 512;

/// A camera path in flight.
#[derive(Clone, Copy, Debug)]
struct Path {
    /// Its pixel within the run.
    pixel: usize,
    sampler: Sampler,
    walk: Walk,
    regularization: PathRegularization,
    bounce: Bounce,
}

/// A path that scattered at a vertex and may go on from it.
#[derive(Clone, Copy, Debug)]
struct Scattering {
    /// Its index in the wavefront.
    path: usize,
    vertex: PathVertex,
    /// The vertex's numbers: its light sample's, then its step's.
    u: CameraVertexSamples,
}

/// A light sample waiting for its shadow ray.
#[derive(Clone, Copy, Debug)]
struct ShadowQuery {
    pixel: usize,
    ray: ShadowRay,
    /// What the pixel gains when the ray is unoccluded.
    contribution: Vec3,
}

/// The queues of one worker, reused from run to run.
#[derive(Debug, Default)]
pub struct Queues {
    paths: Vec<Path>,
    /// The rays of the extend or the shadow stage, as one batch query.
    rays: Vec<BatchRay>,
    hits: Vec<Option<Hit>>,
    occluded: Vec<bool>,
    /// The points the paths that go on reached, with their index.
    surfaces: Vec<(usize, SurfacePoint)>,
    scattering: Vec<Scattering>,
    /// Light samples of the scattering queue's entries (by index).
    light_samples: Vec<(usize, LightSample)>,
    /// Light points (on emissive triangles, or point lights) of Lambertian
    /// entries, whose samples are computed in lanes ([`lanes`](super::lanes)).
    target_samples: Vec<TargetSample>,
    shadow: Vec<ShadowQuery>,
}

impl PathTracer {
    /// The estimates of iteration `n` (whose bound is `tau_n`) for the
    /// pixels `x0..x0 + out.len()` of row `y` (at most [`WAVEFRONT`] of
    /// them), as a wavefront.
    pub(super) fn trace_wavefront(
        &self,
        ctx: &SceneContext,
        (n, tau_n): (u64, f64),
        (x0, y): (u32, u32),
        out: &mut [Vec3],
        queues: &mut Queues,
    ) {
        let start = PathRegularization::new(ctx.effective_mode(tau_n), Subpath::Camera, tau_n)
            .with_energy(ctx.config.regularization.energy);
        out.fill(Vec3::ZERO);
        queues.paths.clear();
        queues.paths.extend((0..out.len()).map(|pixel| {
            let (sampler, walk) = ctx.camera_path(n, x0 + pixel as u32, y);
            Path {
                pixel,
                sampler,
                walk,
                regularization: start,
                bounce: Bounce {
                    specular: true,
                    mis_pdf: 0.0,
                    from: walk.origin,
                },
            }
        }));
        for depth in 1..=ctx.config.max_depth {
            if queues.paths.is_empty() {
                break;
            }
            extend(ctx, depth, queues);
            self.shade(ctx, depth, queues, out);
            shadow(ctx, queues, out);
            continue_paths(queues, depth, ctx.bvh.simd_level());
        }
    }

    /// Stage 2: emission and escape, then the vertex and its light sample
    /// for the paths that go on, in passes over the wavefront (the surface
    /// points, the vertices, the light choices, the light samples in lanes,
    /// the other light samples' values and shadow rays): consecutive paths'
    /// chains of work overlap, and each pass is a place for a batch kernel.
    fn shade(&self, ctx: &SceneContext, depth: u32, queues: &mut Queues, out: &mut [Vec3]) {
        queues.surfaces.clear();
        for (index, (path, hit)) in queues.paths.iter_mut().zip(&queues.hits).enumerate() {
            let walk = &mut path.walk;
            let Some(hit) = hit else {
                if let Some(le) = self.escaped(ctx, walk, &path.bounce) {
                    out[path.pixel] += le;
                }
                continue;
            };
            let point = ctx.surface_point(hit, walk.origin, walk.direction);
            walk.arrive(&ctx.scene, &point, hit.t);
            if let Some(le) = self.emission(ctx, walk, &path.bounce, &point) {
                out[path.pixel] += le;
            }
            if depth < ctx.config.max_depth {
                queues.surfaces.push((index, point));
            }
        }
        queues.scattering.clear();
        for &(index, point) in &queues.surfaces {
            let path = &mut queues.paths[index];
            let u = path.sampler.camera_vertex(depth);
            // Built in the queue's slot, not copied there (half a KiB); the
            // path takes the vertex's regularization state when it goes on
            // (`continue_paths`), not here, where reading it back would
            // wait on the stores that wrote it.
            queues.scattering.push(Scattering {
                path: index,
                vertex: PathVertex::new(
                    &ctx.scene,
                    point,
                    -path.walk.direction,
                    path.walk.throughput,
                    path.regularization,
                ),
                u,
            });
        }
        queues.shadow.clear();
        if !self.use_nee {
            return;
        }
        queues.light_samples.clear();
        queues.target_samples.clear();
        for (k, s) in queues.scattering.iter().enumerate() {
            if s.vertex.is_specular() {
                continue;
            }
            let Some(choice) = ctx.lights.choose(&ctx.scene, s.u.u_light, s.u.uv_light) else {
                continue;
            };
            if let Some(lambertian) = s.vertex.lambertian()
                && let Some(target) = ctx.lights.point_target(&choice)
            {
                queues.target_samples.push(TargetSample {
                    vertex: k,
                    reflectance: lambertian.reflectance,
                    target,
                });
            } else if let Some(ls) = ctx
                .lights
                .sample_chosen(&ctx.scene, &choice, s.vertex.point.p)
            {
                queues.light_samples.push((k, ls));
            }
        }
        self.shade_in_lanes(ctx, queues);
        for (k, ls) in &queues.light_samples {
            let s = &queues.scattering[*k];
            if let Some(f) = nee::light_value(&s.vertex, ls) {
                let path = &queues.paths[s.path];
                queues.shadow.push(ShadowQuery {
                    pixel: path.pixel,
                    ray: nee::shadow_ray(&s.vertex, ls),
                    contribution: path.walk.throughput * self.light_contribution(&s.vertex, ls, f),
                });
            }
        }
    }

    /// The light samples of `queues.target_samples`, [`LANES`] at a time,
    /// and their shadow rays and contributions, as the scalar code gives
    /// them (`Lights::sample_chosen`, `nee::light_value`,
    /// `light_contribution`).
    fn shade_in_lanes(&self, ctx: &SceneContext, queues: &mut Queues) {
        let mut lanes = NeeLanes::default();
        for batch in queues.target_samples.chunks(LANES) {
            for (j, t) in batch.iter().enumerate() {
                lanes.set(j, &queues.scattering[t.vertex].vertex, t);
            }
            (batch.len()..LANES).for_each(|j| lanes.clear(j));
            lanes.run(ctx.bvh.simd_level());
            for (j, t) in batch.iter().enumerate() {
                let Some(ls) = lanes.sample(j) else { continue };
                let s = &queues.scattering[t.vertex];
                let weight = if t.target.delta || !self.use_bsdf {
                    1.0
                } else {
                    super::mis_weight(ls.pdf, ls.bsdf_pdf)
                };
                let path = &queues.paths[s.path];
                queues.shadow.push(ShadowQuery {
                    pixel: path.pixel,
                    ray: nee::shadow_ray_towards(&s.vertex, ls.wi, Some(t.target.point)),
                    contribution: path.walk.throughput
                        * super::weighted(ls.f, ls.li, ls.pdf, weight),
                });
            }
        }
    }
}

/// Stage 1: the closest hit of every path's ray (camera rays from the
/// near plane on).
fn extend(ctx: &SceneContext, depth: u32, queues: &mut Queues) {
    let Queues {
        paths, rays, hits, ..
    } = queues;
    rays.clear();
    rays.extend(paths.iter().map(|path| path.walk.next_ray()));
    hits.clear();
    hits.resize(rays.len(), None);
    if depth == 1 {
        ctx.intersect_camera_batch(rays, hits);
    } else {
        ctx.intersect_batch(rays, hits);
    }
}

/// Stage 3: the shadow queue's rays; the unoccluded ones add their
/// contribution.
fn shadow(ctx: &SceneContext, queues: &mut Queues, out: &mut [Vec3]) {
    let Queues {
        shadow,
        rays,
        occluded,
        ..
    } = queues;
    rays.clear();
    rays.extend(shadow.iter().map(|query| query.ray.batch_ray()));
    occluded.clear();
    occluded.resize(rays.len(), false);
    ctx.occluded_batch(rays, occluded);
    for (query, &occluded) in shadow.iter().zip(occluded.iter()) {
        if !occluded {
            out[query.pixel] += query.contribution;
        }
    }
}

/// Stage 4: a BSDF sample and roulette for every path that scattered (the
/// Lambertian vertices' samples in lanes, [`LANES`] entries at a time, on
/// the instruction set `level`); the survivors form the next wavefront, in
/// their order.
fn continue_paths(queues: &mut Queues, depth: u32, level: Level) {
    let mut survivors = 0;
    let mut lanes = StepLanes::default();
    for batch in queues.scattering.chunks(LANES) {
        let mut lambertian = 0u32;
        for (j, s) in batch.iter().enumerate() {
            if let Some(l) = s.vertex.lambertian() {
                lanes.set(j, &s.vertex, l.reflectance, s.u.step.uv_bsdf);
                lambertian |= 1 << j;
            } else {
                lanes.clear(j);
            }
        }
        (batch.len()..LANES).for_each(|j| lanes.clear(j));
        if lambertian != 0 {
            lanes.run(level);
        }
        for (j, s) in batch.iter().enumerate() {
            let path = &mut queues.paths[s.path];
            let step = &s.u.step;
            let sample = if lambertian & (1 << j) != 0 {
                lanes
                    .sample(j)
                    .filter(|ls| {
                        let sampled = (ls.wo, ls.weight);
                        path.walk
                            .follow(&s.vertex, sampled, depth, 1.0, step.u_roulette)
                    })
                    .map(|ls| (false, ls.pdf))
            } else {
                path.walk
                    .step(&s.vertex, depth, *step, TransportMode::Radiance, 1.0)
                    .map(|sample| (sample.is_specular, sample.mis_pdf))
            };
            let Some((specular, mis_pdf)) = sample else {
                continue;
            };
            path.regularization = s.vertex.regularization;
            path.bounce = Bounce {
                specular,
                mis_pdf,
                from: s.vertex.point.p,
            };
            // Survivors move down over paths already read (s.path >=
            // survivors); until a path ends, each stays where it is.
            if s.path != survivors {
                queues.paths[survivors] = queues.paths[s.path];
            }
            survivors += 1;
        }
    }
    queues.paths.truncate(survivors);
}
