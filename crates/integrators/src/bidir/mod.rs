//! The bidirectional core: vertex connection and merging (Georgiev et al.
//! 2012; the structure of SmallVCM and of the "Implementing VCM" technical
//! report). BPT is this core with merging off, BPM (bidirectional photon
//! mapping) with connections off, VCM with both (SPEC §7): one copy of the
//! subpath code, techniques switched by the `mis` crate's [`Techniques`].
//! Progressive photon mapping ([`ppm`]) shares its light pass and photon map.
//!
//! One iteration traces one light subpath per pixel (stored, and connected to
//! the camera: light tracing, [`light_path`]), then one camera subpath per
//! pixel ([`camera_path`]), which at every non-specular vertex does next-event
//! estimation, connects to the vertices of the light subpath with its own
//! index, and merges with the light vertices within the merge radius. Every
//! contribution is weighted with the recursive MIS quantities of `mis`, with
//! p-hat at regularized vertices and, optionally, virtual merges (SPEC §6).

mod camera_path;
mod light_path;
mod photon_map;
mod ppm;
#[cfg(test)]
mod tests;

use glam::Vec3;
use mis::{Heuristic, MisConfig, Techniques};
use rayon::prelude::*;
use regularization::{Mode, PathRegularization, Subpath};

use crate::config::Algorithm;
use crate::context::SceneContext;
use crate::film::Splats;
use crate::integrator::{Integrator, Stop};
use crate::pt::PathTracer;
use crate::roulette::ShadowRoulette;
use camera_path::{CameraRays, CameraStart};
use light_path::LightVertex;
use photon_map::{Kept, Photon, PhotonMap, PhotonMapBuffers, PhotonRecord, WeightedPhoton};
pub use ppm::ProgressivePhotonMapper;

/// Light subpaths traced together by one task: a fixed partition, so that
/// splats are added in the same order whatever the thread count.
const LIGHT_BLOCK: usize = 256;

/// Light subpaths traced to estimate the photon map's size (a few
/// milliseconds; spread over the image's light-subpath indices).
const PILOT_PATHS: usize = 1024;

/// Bytes per photon besides what its light block keeps (`LightPaths`) and
/// its record in the photon map: the hash grid's sorted and unsorted keys
/// (8 each), position copy (12) and bucket start (at most 8: buckets are the
/// next power of two of the count), and the kept item's reference while the
/// map is built (8).
const GRID_BYTES_PER_PHOTON: usize = 44;

/// BPT, BPM or VCM: the techniques of the configured algorithm on this
/// scene, and the scale of the shadow-ray roulette.
#[derive(Clone, Debug)]
pub struct Bidirectional {
    techniques: Techniques,
    /// The mean pixel value (largest RGB component) of a small path-traced
    /// preview: the scale of the shadow-ray roulette threshold (0 when the
    /// roulette is off).
    pixel_scale: f32,
    /// The photon map's buffers, reused by every iteration. Empty (no
    /// allocation) when no iteration merges: BPT, and PPM, which keeps its
    /// own map of bare photons beside this core.
    photon_map: PhotonMapBuffers<WeightedPhoton>,
}

impl Bidirectional {
    /// The core for `ctx.config.algorithm` (BPT, BPM or VCM). VCM leaves
    /// merging out when no used surface is near-specular (alpha < 0.1) or
    /// refractive: merging helps only with paths that connections cannot
    /// sample well (specular-diffuse-specular chains), so there it would
    /// build a photon map for nothing; the result is BPT, unbiased.
    pub fn new(ctx: &SceneContext) -> Self {
        let merging_can_help =
            ctx.features.near_specular_materials > 0 || ctx.features.transmission;
        let techniques = match ctx.config.algorithm {
            Algorithm::Bpt | Algorithm::Pt => Techniques::BPT,
            Algorithm::Bpm | Algorithm::Ppm => Techniques::MERGING,
            Algorithm::Vcm if merging_can_help => Techniques::VCM,
            Algorithm::Vcm => Techniques::BPT,
        }
        .with_virtual_merges(ctx.config.uses_virtual_merges());
        let pixel_scale = if techniques.connections && ctx.config.shadow_roulette > 0.0 {
            PathTracer::new(ctx.config.strategies, false).preview_pixel_mean(ctx)
        } else {
            0.0
        };
        Self {
            techniques,
            pixel_scale,
            photon_map: PhotonMapBuffers::default(),
        }
    }

    /// The MIS techniques switched on.
    pub fn techniques(&self) -> Techniques {
        self.techniques
    }

    /// An estimate of the photon map's memory (bytes) in one iteration: the
    /// light vertices that pilot subpaths of iteration 1 store, scaled to
    /// one subpath per pixel; 0 without merging. For refusing a render the
    /// machine cannot hold before it starts.
    pub fn photon_map_bytes(&self, ctx: &SceneContext) -> u64 {
        self.photon_map_bytes_of::<WeightedPhoton>(ctx)
    }

    /// [`Bidirectional::photon_map_bytes`] for a map of records `R`.
    fn photon_map_bytes_of<R>(&self, ctx: &SceneContext) -> u64 {
        if !self.techniques.merging {
            return 0;
        }
        let it = self.iteration(ctx, 1, Stop::NEVER);
        let (w, h) = ctx.resolution();
        let pixels = w as usize * h as usize;
        let pilot = PILOT_PATHS.min(pixels);
        let (mut vertices, mut splats) = (Vec::new(), Splats::default());
        ctx.uncounted(|| {
            for k in 0..pilot {
                let index = (k * (pixels / pilot)) as u64;
                it.trace_light_path(index, &mut vertices, &mut splats);
            }
        });
        let per_path = vertices.len() as f64 / pilot as f64;
        // Kept through the iteration: light vertices for connections, or
        // their photons with positions (`LightPaths`).
        let kept = if self.techniques.connections {
            std::mem::size_of::<LightVertex>()
        } else {
            std::mem::size_of::<(Vec3, R)>()
        };
        let per_vertex = kept + std::mem::size_of::<R>() + GRID_BYTES_PER_PHOTON;
        (per_path * pixels as f64 * per_vertex as f64) as u64
    }

    /// The scale of the shadow-ray roulette threshold (see
    /// [`crate::RenderConfig::shadow_roulette`]); 0 when it is off.
    pub fn pixel_scale(&self) -> f32 {
        self.pixel_scale
    }

    /// The settings of iteration `n`.
    fn iteration<'a>(&self, ctx: &'a SceneContext, n: u64, stop: Stop<'a>) -> Iteration<'a> {
        let (w, h) = ctx.resolution();
        let light_paths = u64::from(w) * u64::from(h);
        let radius = if self.techniques.merging {
            ctx.merge_radius.at(n)
        } else {
            0.0
        };
        let mis = MisConfig::new(
            self.techniques,
            light_paths,
            f64::from(radius),
            Heuristic::BALANCE,
        )
        .expect("pixel count and radius are positive");
        let tau_n = ctx.tau_at(n);
        Iteration {
            ctx,
            stop,
            n,
            mis,
            mode: ctx.effective_mode(tau_n),
            tau_n,
            radius,
            roulette: ShadowRoulette {
                threshold: ctx.config.shadow_roulette * self.pixel_scale,
            },
        }
    }
}

impl Integrator for Bidirectional {
    fn render_iteration(&self, ctx: &SceneContext, n: u64, estimates: &mut [Vec3], stop: Stop<'_>) {
        let it = self.iteration(ctx, n, stop);
        if self.techniques.merging {
            self.photon_map
                .with(|kept| it.render_with_photon_map(estimates, kept));
        } else {
            it.render_paired(estimates);
        }
    }
}

/// One iteration of the core: the scene and the settings that depend on
/// the iteration number. The subpath code is its methods.
struct Iteration<'a> {
    ctx: &'a SceneContext,
    /// Blocks of work start only while no stop is requested.
    stop: Stop<'a>,
    n: u64,
    mis: MisConfig,
    mode: Mode,
    tau_n: f64,
    radius: f32,
    /// Next-event estimation, connections and light tracing skip shadow
    /// rays of small contributions with it.
    roulette: ShadowRoulette,
}

impl Iteration<'_> {
    /// The regularization state at the start of a subpath of this iteration
    /// (its mode, tau_N, the configured energy compensation, and the
    /// unregularized techniques that `Mode::Unsampleable` relies on).
    fn path_regularization(&self, subpath: Subpath) -> PathRegularization {
        let techniques = self.mis.techniques();
        PathRegularization::new(self.mode, subpath, self.tau_n)
            .with_energy(self.ctx.config.regularization.energy)
            .with_techniques(regularization::Techniques {
                connections: techniques.connections,
                merges: techniques.merging,
            })
    }
}

/// One iteration's light subpaths, as the blocks of [`LIGHT_BLOCK`] paths
/// traced them: not copied into one array, a copy that held the light
/// vertices twice (PPM on `cornell-box` at 512x512: 93 MB of them per
/// iteration; peak memory 220 MB with the copy, 150 MB without). Without
/// connections (BPM, PPM) nothing reads a light vertex but merges: each
/// block keeps only its vertices' photon records `R` (a fifth to a third of
/// their size).
struct LightPaths<R> {
    /// The light vertices of each block, in light-path order (none without
    /// connections).
    blocks: Vec<Vec<LightVertex>>,
    /// Where light path i's vertices end in its block; they start where
    /// path i - 1's end, or at 0 for a block's first path.
    ends: Vec<usize>,
    /// Without connections: the position and photon of each light vertex
    /// of each block, in light-path order.
    photons: Vec<Vec<(Vec3, R)>>,
}

impl<R: PhotonRecord> LightPaths<R> {
    /// The light vertices of path i; none when they were not kept (no
    /// connections).
    fn path(&self, i: usize) -> &[LightVertex] {
        if self.blocks[i / LIGHT_BLOCK].is_empty() {
            return &[];
        }
        let start = if i.is_multiple_of(LIGHT_BLOCK) {
            0
        } else {
            self.ends[i - 1]
        };
        &self.blocks[i / LIGHT_BLOCK][start..self.ends[i]]
    }

    /// Rebuilds `map` over every light vertex, for merges of radius
    /// `radius` by `light_paths` light subpaths.
    fn build_photon_map(&self, map: &mut PhotonMap<R>, radius: f32, light_paths: usize) {
        // Blocks keep either their light vertices or their photons.
        if self.blocks.iter().all(Vec::is_empty) {
            let photons: Vec<&(Vec3, R)> = self.photons.iter().flatten().collect();
            map.rebuild(
                photons.len(),
                radius,
                light_paths,
                |i| photons[i].0,
                |i| photons[i].1,
            )
        } else {
            let vertices: Vec<&LightVertex> = self.blocks.iter().flatten().collect();
            map.rebuild(
                vertices.len(),
                radius,
                light_paths,
                |i| vertices[i].point.p,
                |i| R::from(vertices[i]),
            )
        }
    }

    /// The photon blocks, for the next iteration's light pass to refill.
    fn into_photon_blocks(self) -> Vec<Vec<(Vec3, R)>> {
        self.photons
    }
}

impl Iteration<'_> {
    /// Without merging, light subpath i is used only by camera subpath i
    /// (and the camera): each block of pixels traces both in turn, so light
    /// vertices need no storage beyond one path per thread.
    fn render_paired(&self, estimates: &mut [Vec3]) {
        let splats: Vec<Splats> = estimates
            .par_chunks_mut(LIGHT_BLOCK)
            .enumerate()
            .map_init(CameraRays::default, |camera_rays, (block, chunk)| {
                let mut vertices = Vec::new();
                let mut splats = Splats::default();
                if self.stop.requested() {
                    return splats;
                }
                let first = block * LIGHT_BLOCK;
                let starts = self.start_camera_paths(first..first + chunk.len(), camera_rays);
                for ((k, out), start) in chunk.iter_mut().enumerate().zip(starts) {
                    vertices.clear();
                    self.trace_light_path((first + k) as u64, &mut vertices, &mut splats);
                    *out = self.trace_camera_path(start, &vertices, None);
                }
                self.ctx.flush_ray_count();
                splats
            })
            .collect();
        for s in &splats {
            s.add_to(estimates);
        }
    }

    /// With merging, every camera subpath may merge with any light vertex:
    /// all light subpaths are traced first and their vertices indexed by a
    /// hash grid (the photon map), in the buffers `kept` holds.
    fn render_with_photon_map(&self, estimates: &mut [Vec3], kept: &mut Kept<WeightedPhoton>) {
        let (paths, splats) =
            self.trace_light_paths(estimates.len(), std::mem::take(&mut kept.blocks));
        if self.stop.requested() {
            return;
        }
        paths.build_photon_map(&mut kept.map, self.radius, estimates.len());
        let photon_map = &kept.map;
        self.camera_pass(estimates, |index, start| {
            self.trace_camera_path(start, paths.path(index), Some(photon_map))
        });
        kept.blocks = paths.into_photon_blocks();
        for s in &splats {
            s.add_to(estimates);
        }
    }

    /// One camera subpath per pixel, `trace(pixel index, its start)`, in
    /// parallel blocks.
    fn camera_pass(
        &self,
        estimates: &mut [Vec3],
        trace: impl Fn(usize, &CameraStart) -> Vec3 + Sync,
    ) {
        estimates
            .par_chunks_mut(LIGHT_BLOCK)
            .enumerate()
            .for_each_init(CameraRays::default, |camera_rays, (block, chunk)| {
                if self.stop.requested() {
                    return;
                }
                let first = block * LIGHT_BLOCK;
                let starts = self.start_camera_paths(first..first + chunk.len(), camera_rays);
                for ((k, out), start) in chunk.iter_mut().enumerate().zip(starts) {
                    *out = trace(first + k, start);
                }
                self.ctx.flush_ray_count();
            });
    }

    /// Every light subpath of the iteration, traced in fixed blocks, with
    /// each block's light-tracing splats; without connections, kept as
    /// photon records `R`.
    fn trace_light_paths<R: PhotonRecord>(
        &self,
        light_paths: usize,
        mut photon_blocks: Vec<Vec<(Vec3, R)>>,
    ) -> (LightPaths<R>, Vec<Splats>) {
        let connections = self.mis.techniques().connections;
        type Block<R> = (Vec<LightVertex>, Vec<usize>, Vec<(Vec3, R)>, Splats);
        photon_blocks.resize_with(light_paths.div_ceil(LIGHT_BLOCK), Vec::new);
        let blocks: Vec<Block<R>> = (0..light_paths)
            .into_par_iter()
            .step_by(LIGHT_BLOCK)
            .zip(photon_blocks)
            // A worker's light vertices are only read into photons (without
            // connections): its buffer is then reused from block to block
            // (growing a new one cost 1.4 % of PPM's time in copies).
            .map_init(Vec::new, |vertices, (first, mut photons)| {
                vertices.clear();
                let mut ends = Vec::with_capacity(LIGHT_BLOCK);
                let mut splats = Splats::default();
                let end = if self.stop.requested() {
                    first
                } else {
                    (first + LIGHT_BLOCK).min(light_paths)
                };
                for i in first..end {
                    self.trace_light_path(i as u64, vertices, &mut splats);
                    ends.push(vertices.len());
                }
                self.ctx.flush_ray_count();
                if connections {
                    // Kept to the end of the iteration: without the growth slack.
                    let mut vertices = std::mem::take(vertices);
                    vertices.shrink_to_fit();
                    (vertices, ends, Vec::new(), splats)
                } else {
                    photons.clear();
                    photons.extend(vertices.iter().map(|v| (v.point.p, R::from(v))));
                    (Vec::new(), ends, photons, splats)
                }
            })
            .collect();
        let mut paths = LightPaths {
            blocks: Vec::with_capacity(blocks.len()),
            ends: Vec::with_capacity(light_paths),
            photons: Vec::with_capacity(blocks.len()),
        };
        let mut all_splats = Vec::with_capacity(blocks.len());
        for (vertices, ends, photons, splats) in blocks {
            paths.blocks.push(vertices);
            paths.ends.extend(ends);
            paths.photons.push(photons);
            all_splats.push(splats);
        }
        (paths, all_splats)
    }
}
