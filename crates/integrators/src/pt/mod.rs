//! Path tracing with next-event estimation and BSDF sampling combined by
//! multiple importance sampling (SPEC §7; Veach 1997 ch. 9), Russian
//! roulette, and regularization per SPEC §5-§6: each vertex is regularized
//! when created and MIS compares p-hat (paper eq 13).

use glam::Vec3;
use microfacet::TransportMode;
use mis::power_heuristic;
use rayon::prelude::*;
use regularization::{PathRegularization, Subpath};

use crate::config::Strategies;
use crate::context::SceneContext;
use crate::geometry::SurfacePoint;
use crate::integrator::{Integrator, Stop};
use crate::lights::{LightChoice, LightSample};
use crate::nee;
use crate::sampler::Sampler;
use crate::vertex::PathVertex;
use crate::walk::Walk;

mod lanes;
mod wavefront;

/// Pixels per image side, and paths per pixel, of the preview that
/// estimates the mean pixel value (4096 paths whatever the resolution:
/// 8-12 ms on `cornell-box`, in `cargo xtask bench`'s build time).
const PREVIEW_GRID: u32 = 32;
const PREVIEW_PATHS: u64 = 4;

/// Power-heuristic weight of a technique with density `pdf` against
/// `other`, in f64 (the pdfs of near-specular lobes overflow when squared in f32).
fn mis_weight(pdf: f32, other: f32) -> f32 {
    power_heuristic(f64::from(pdf), f64::from(other)) as f32
}

/// The path tracer: one camera path per pixel and iteration.
#[derive(Clone, Copy, Debug)]
pub struct PathTracer {
    /// Lights are reached by next-event estimation.
    use_nee: bool,
    /// Lights are reached by BSDF-sampled rays.
    use_bsdf: bool,
    /// The paths of a run of pixels advance together ([`wavefront`]).
    wavefront: bool,
}

/// How a path left its previous vertex: what an emitter it hits needs for
/// its MIS weight against next-event estimation from there.
#[derive(Clone, Copy, Debug)]
struct Bounce {
    /// The previous vertex's lobe was a delta (or there was none: the camera).
    specular: bool,
    /// The MIS density of the sampled direction (p-hat where regularized).
    mis_pdf: f32,
    /// The previous vertex's position.
    from: Vec3,
}

impl Integrator for PathTracer {
    fn render_iteration(&self, ctx: &SceneContext, n: u64, estimates: &mut [Vec3], stop: Stop<'_>) {
        let width = ctx.resolution().0 as usize;
        let tau_n = ctx.tau_at(n);
        estimates.par_chunks_mut(width).enumerate().for_each_init(
            wavefront::Queues::default,
            |queues, (y, row)| {
                if stop.requested() {
                    return;
                }
                let y = y as u32;
                if self.wavefront {
                    for (k, run) in row.chunks_mut(wavefront::WAVEFRONT).enumerate() {
                        let x0 = (k * wavefront::WAVEFRONT) as u32;
                        self.trace_wavefront(ctx, (n, tau_n), (x0, y), run, queues);
                    }
                } else {
                    for (x, out) in row.iter_mut().enumerate() {
                        let (sampler, walk) = ctx.camera_path(n, x as u32, y);
                        *out = self.trace_path(ctx, walk, &sampler, tau_n);
                    }
                }
                ctx.flush_ray_count();
            },
        );
    }
}

impl PathTracer {
    /// The path tracer with the given techniques for reaching lights, as a
    /// wavefront or one path at a time (the same image either way).
    pub fn new(strategies: Strategies, wavefront: bool) -> Self {
        let (use_nee, use_bsdf) = match strategies {
            Strategies::Mis => (true, true),
            Strategies::NeeOnly => (true, false),
            Strategies::BsdfOnly => (false, true),
        };
        Self {
            use_nee,
            use_bsdf,
            wavefront,
        }
    }

    /// The mean over a grid of pixels of path-traced estimates (largest RGB
    /// component), from random streams of iteration 0, which renders never
    /// use, unregularized. Its rays are not counted. Returns 0 when the mean
    /// is not a positive finite number.
    ///
    /// Unregularized because the mean only scales a roulette threshold
    /// (any positive scale keeps the estimate unbiased), while a regularized
    /// preview of a glass scene built the dielectric energy tables (3.5-5 s)
    /// before the first iteration, even for renders that then regularize
    /// nothing (VCM in `unsampleable` mode).
    pub fn preview_pixel_mean(&self, ctx: &SceneContext) -> f32 {
        let res = ctx.scene.camera.resolution;
        let mut sum = 0.0f64;
        ctx.uncounted(|| {
            for i in 0..PREVIEW_GRID * PREVIEW_GRID {
                let (gx, gy) = (i % PREVIEW_GRID, i / PREVIEW_GRID);
                let x = ((2 * gx + 1) * res.x) / (2 * PREVIEW_GRID);
                let y = ((2 * gy + 1) * res.y) / (2 * PREVIEW_GRID);
                for k in 0..PREVIEW_PATHS {
                    let pixel = u64::from(y) * u64::from(res.x) + u64::from(x);
                    let sampler = Sampler::new(ctx.config.seed, 0, pixel * PREVIEW_PATHS + k);
                    let (o, d) = ctx.camera.ray(x, y, sampler.pixel_position());
                    let l = self.trace_path(ctx, Walk::new(o, d), &sampler, f64::INFINITY);
                    sum += f64::from(l.max_element());
                }
            }
        });
        let mean = (sum / f64::from(PREVIEW_GRID * PREVIEW_GRID) / PREVIEW_PATHS as f64) as f32;
        if mean.is_finite() && mean > 0.0 {
            mean
        } else {
            0.0
        }
    }

    /// One path-traced radiance estimate of the camera walk `walk`.
    fn trace_path(
        &self,
        ctx: &SceneContext,
        mut walk: Walk,
        sampler: &Sampler,
        tau_n: f64,
    ) -> Vec3 {
        let mut radiance = Vec3::ZERO;
        let mut regularization =
            PathRegularization::new(ctx.effective_mode(tau_n), Subpath::Camera, tau_n)
                .with_energy(ctx.config.regularization.energy);
        let mut bounce = Bounce {
            specular: true,
            mis_pdf: 0.0,
            from: walk.origin,
        };

        for depth in 1..=ctx.config.max_depth {
            // The vertex's random numbers, and the light and light point of
            // its next-event estimation, depend on nothing the ray finds:
            // drawn before it, their arithmetic (chains of multiplications,
            // dependent loads, a square root) overlaps the ray query instead
            // of waiting behind its mispredicted branches (PT 0.98-0.99 of
            // the CPU time, and the light 0.98 more on cornell-mcguire).
            let u = sampler.camera_vertex(depth);
            let light = self
                .use_nee
                .then(|| ctx.lights.choose(&ctx.scene, u.u_light, u.uv_light))
                .flatten();
            let hit = if depth == 1 {
                ctx.intersect_camera_ray(walk.origin, walk.direction)
            } else {
                walk.next_hit(ctx)
            };
            let Some(hit) = hit else {
                if let Some(le) = self.escaped(ctx, &walk, &bounce) {
                    radiance += le;
                }
                break;
            };
            let point = ctx.surface_point(&hit, walk.origin, walk.direction);
            walk.arrive(&ctx.scene, &point, hit.t);
            let wi = -walk.direction;
            if let Some(le) = self.emission(ctx, &walk, &bounce, &point) {
                radiance += le;
            }
            if depth == ctx.config.max_depth {
                break;
            }

            let vertex = PathVertex::new(&ctx.scene, point, wi, walk.throughput, regularization);
            regularization = vertex.regularization;
            if !vertex.is_specular()
                && let Some(light) = &light
                && let Some(contribution) = self.next_event(ctx, &vertex, light)
            {
                radiance += walk.throughput * contribution;
            }
            let Some(s) = walk.step(&vertex, depth, u.step, TransportMode::Radiance, 1.0) else {
                break;
            };
            bounce = Bounce {
                specular: s.is_specular,
                mis_pdf: s.mis_pdf,
                from: point.p,
            };
        }
        radiance
    }

    /// What the environment gives a walk that left the scene after
    /// `bounce`: its radiance times the throughput and the MIS weight.
    #[inline]
    fn escaped(&self, ctx: &SceneContext, walk: &Walk, bounce: &Bounce) -> Option<Vec3> {
        let le = ctx.lights.environment(&ctx.scene, walk.direction)?;
        let weight = self.emitter_hit_weight(bounce, || {
            ctx.lights.environment_pdf(&ctx.scene, walk.direction)
        });
        Some(walk.escaped_throughput() * le * weight)
    }

    /// The emission a walk arriving at `point` after `bounce` finds there,
    /// times the throughput and the MIS weight, if the surface emits
    /// towards it.
    #[inline]
    fn emission(
        &self,
        ctx: &SceneContext,
        walk: &Walk,
        bounce: &Bounce,
        point: &SurfacePoint,
    ) -> Option<Vec3> {
        let emission = ctx.emitted(point, -walk.direction)?;
        let weight = self.emitter_hit_weight(bounce, || {
            ctx.lights
                .area_pdf_w(point.primitive, bounce.from, point.p, point.n_winding)
        });
        Some(walk.throughput * emission * weight)
    }

    /// The MIS weight of emission found after `bounce` against next-event
    /// estimation, whose density for the emitter point is `light_pdf`
    /// (solid angle at the previous vertex): 1 after a delta bounce (NEE
    /// cannot follow it) or without NEE, 0 without BSDF sampling.
    fn emitter_hit_weight(&self, bounce: &Bounce, light_pdf: impl FnOnce() -> f32) -> f32 {
        if bounce.specular || !self.use_nee {
            1.0
        } else if !self.use_bsdf {
            0.0
        } else {
            mis_weight(bounce.mis_pdf, light_pdf())
        }
    }

    /// Next-event estimation at `vertex` towards the light and point
    /// `light`: the light sample, its visibility and its weighted
    /// contribution, if any.
    fn next_event(
        &self,
        ctx: &SceneContext,
        vertex: &PathVertex,
        light: &LightChoice,
    ) -> Option<Vec3> {
        let (ls, f) = nee::light_sample(ctx, vertex, light)?;
        nee::visible(ctx, vertex, &ls).then(|| self.light_contribution(vertex, &ls, f))
    }

    /// The contribution of the unoccluded light sample `ls` at `vertex`,
    /// whose f |cos| towards it is `f`: weighted against BSDF sampling by
    /// MIS (weight 1 without BSDF sampling or for delta lights).
    fn light_contribution(&self, vertex: &PathVertex, ls: &LightSample, f: Vec3) -> Vec3 {
        let weight = if ls.is_delta || !self.use_bsdf {
            1.0
        } else {
            mis_weight(ls.pdf, vertex.mis_pdf(ls.wi))
        };
        weighted(f, ls.li, ls.pdf, weight)
    }
}

/// A light sample's contribution: f |cos| times the radiance `li` over
/// the density `pdf`, times the MIS `weight`.
#[inline(always)]
fn weighted(f: Vec3, li: Vec3, pdf: f32, weight: f32) -> Vec3 {
    f * li * (weight / pdf)
}
