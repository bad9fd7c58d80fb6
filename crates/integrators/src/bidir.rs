//! The bidirectional core: vertex connection and merging (Georgiev et al.
//! 2012; the structure of SmallVCM and of the "Implementing VCM" technical
//! report). BPT is this core with merging off, PPM with connections off, VCM
//! with both (SPEC §7): one copy of the subpath code, techniques switched by
//! the `mis` crate's [`Techniques`].
//!
//! One iteration traces one light subpath per pixel (stored, and connected to
//! the camera: light tracing), then one camera subpath per pixel, which at
//! every non-specular vertex does next-event estimation, connects to the
//! vertices of the light subpath with its own index, and merges with the
//! light vertices within the merge radius. Every contribution is weighted
//! with the recursive MIS quantities of `mis`, with p-hat at regularized
//! vertices and, optionally, virtual merges (SPEC §6).

use accel::HashGrid;
use glam::{UVec2, Vec2, Vec3};
use microfacet::TransportMode;
use mis::{
    EmitterHit, Heuristic, MisConfig, Scatter, SubpathRay, SubpathState, Techniques, VertexPdfs,
};
use rayon::prelude::*;
use regularization::{Mode, PathRegularization, Subpath};

use crate::config::Algorithm;
use crate::film::Splats;
use crate::geometry::SurfacePoint;
use crate::pt::DIMENSIONS_PER_VERTEX;
use crate::render::Renderer;
use crate::sampler::Sampler;
use crate::vertex::PathVertex;

/// Light subpaths traced together by one task: a fixed partition, so that
/// splats are added in the same order whatever the thread count.
const LIGHT_BLOCK: usize = 256;

/// Sampler streams of light subpaths start here (camera subpaths use the
/// pixel index), so the two never share random numbers.
const LIGHT_STREAM: u64 = 1 << 48;

/// Sampler dimensions of a light subpath's start (light choice, position, direction).
const EMISSION_DIMENSIONS: u32 = 5;

/// Sampler dimensions per light subpath vertex: BSDF lobe (1), direction
/// (2), roulette (1). Packed back to back, so that a vertex mostly needs
/// one new 4-dimension Sobol set (with a camera vertex's stride of 7, two).
const LIGHT_DIMENSIONS_PER_VERTEX: u32 = 4;

/// What a light subpath leaves at a non-specular vertex: enough to rebuild
/// its [`PathVertex`] with the regularization a technique needs, and its MIS
/// state. Kept small: with merging there are pixels x path length of them.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LightVertex {
    point: SurfacePoint,
    /// Unit direction towards the previous vertex (towards the light).
    wi: Vec3,
    /// Light subpath throughput up to (excluding) this vertex.
    throughput: Vec3,
    state: SubpathState,
    /// Segments from the light to this vertex.
    length: u32,
    /// The largest component of `throughput` times the vertex's
    /// [`PathVertex::importance_bound`]: throughput times f |cos| towards
    /// `wo` is at most `bound` |wo.n_g|.
    bound: f32,
}

impl LightVertex {
    /// An upper bound of the largest component of `throughput` times the
    /// vertex's f |cos| towards unit `wo` (infinity when the lobe has no
    /// cheap bound). Proportional to |wo|: a direction of any length gives
    /// the bound times its length.
    fn bound_towards(&self, wo: Vec3) -> f32 {
        let (cos_in, cos_out) = (self.wi.dot(self.point.ng), wo.dot(self.point.ng));
        // A lobe with a finite bound only reflects: nothing leaves through
        // the other side of the geometric surface (`PathVertex::eval`).
        if self.bound.is_finite() && cos_in * cos_out <= 0.0 {
            0.0
        } else {
            self.bound * cos_out.abs()
        }
    }
}

/// The settings of one iteration.
struct Iteration {
    n: u64,
    mis: MisConfig,
    mode: Mode,
    tau_n: f64,
    radius: f32,
    /// 1 / (pi r^2 light_paths): the merge kernel's normalisation.
    merge_normalisation: f32,
    /// Contributions of next-event estimation, connections and light
    /// tracing below this go through [`shadow_roulette`].
    roulette_threshold: f32,
}

impl Iteration {
    /// The shadow-ray roulette of a contribution whose MIS weight `weight`
    /// computes: the weighted contribution whose visibility is to be
    /// tested, or `None` when the ray is skipped or the weight is zero. The
    /// weight (at most 1) is computed only when the unweighted contribution
    /// does not already fail the roulette.
    fn roulette(&self, unweighted: Vec3, u: f32, weight: impl FnOnce() -> f32) -> Option<Vec3> {
        if roulette_skips(unweighted.max_element(), self.roulette_threshold, u) {
            return None;
        }
        let weight = weight();
        if weight <= 0.0 {
            return None;
        }
        shadow_roulette(unweighted * weight, self.roulette_threshold, u)
    }
}

/// One iteration's light subpaths, as the blocks of [`LIGHT_BLOCK`] paths
/// traced them: not copied into one array, a copy that held the light
/// vertices twice (PPM on `cornell-box` at 512x512: 93 MB of them per
/// iteration; peak memory 220 MB with the copy, 150 MB without).
struct LightPaths {
    /// The light vertices of each block, in light-path order.
    blocks: Vec<Vec<LightVertex>>,
    /// Where light path i's vertices end in its block; they start where
    /// path i - 1's end, or at 0 for a block's first path.
    ends: Vec<usize>,
}

impl LightPaths {
    fn path(&self, i: usize) -> &[LightVertex] {
        let start = if i.is_multiple_of(LIGHT_BLOCK) {
            0
        } else {
            self.ends[i - 1]
        };
        &self.blocks[i / LIGHT_BLOCK][start..self.ends[i]]
    }

    /// Every light vertex, in light-path order.
    fn vertices(&self) -> impl Iterator<Item = &LightVertex> {
        self.blocks.iter().flatten()
    }
}

impl Renderer {
    /// The MIS techniques of the configured algorithm. VCM leaves merging
    /// out when no used surface is near-specular (alpha < 0.1) or
    /// refractive: merging helps only with paths that connections cannot
    /// sample well (specular-diffuse-specular chains), so there it would
    /// build a photon map for nothing; the result is BPT, unbiased.
    pub fn techniques(&self) -> Techniques {
        let techniques = match self.config.algorithm {
            Algorithm::Bpt | Algorithm::Pt => Techniques::BPT,
            Algorithm::Ppm => Techniques::MERGING,
            Algorithm::Vcm if self.merging_can_help() => Techniques::VCM,
            Algorithm::Vcm => Techniques::BPT,
        };
        techniques.with_virtual_merges(self.config.uses_virtual_merges())
    }

    /// Whether the scene has a surface that makes merging worth it (see
    /// [`Renderer::techniques`]).
    pub fn merging_can_help(&self) -> bool {
        self.features().near_specular_materials > 0 || self.features().transmission
    }

    /// Merge radius of iteration `n` (SPEC §7; see [`crate::merge_radius::MergeRadius`]).
    pub fn merge_radius(&self, n: u64) -> f32 {
        self.merge_radius.at(n)
    }

    fn iteration(&self, n: u64) -> Iteration {
        let (w, h) = self.resolution();
        let light_paths = u64::from(w) * u64::from(h);
        let techniques = self.techniques();
        let radius = if techniques.merging {
            self.merge_radius(n)
        } else {
            0.0
        };
        let mis = MisConfig::new(
            techniques,
            light_paths,
            f64::from(radius),
            Heuristic::BALANCE,
        )
        .expect("pixel count and radius are positive");
        let tau_n = self.tau_at(n);
        Iteration {
            n,
            mis,
            mode: self.effective_mode(tau_n),
            tau_n,
            radius,
            merge_normalisation: 1.0
                / (std::f32::consts::PI * radius * radius * light_paths as f32),
            roulette_threshold: self.config.shadow_roulette * self.pixel_scale,
        }
    }

    /// One iteration of BPT, PPM or VCM into `estimates` (see
    /// [`Renderer::render_iteration`]).
    pub(crate) fn render_bidirectional(&self, n: u64, estimates: &mut [Vec3]) {
        let it = self.iteration(n);
        if it.mis.techniques().merging {
            self.render_with_photon_map(&it, estimates);
        } else {
            self.render_paired(&it, estimates);
        }
    }

    /// Without merging, light subpath i is used only by camera subpath i
    /// (and the camera): each block of pixels traces both in turn, so light
    /// vertices need no storage beyond one path per thread.
    fn render_paired(&self, it: &Iteration, estimates: &mut [Vec3]) {
        let splats: Vec<Splats> = estimates
            .par_chunks_mut(LIGHT_BLOCK)
            .enumerate()
            .map(|(block, chunk)| {
                let mut vertices = Vec::new();
                let mut splats = Splats::default();
                for (k, out) in chunk.iter_mut().enumerate() {
                    let index = block * LIGHT_BLOCK + k;
                    vertices.clear();
                    self.trace_light_path(it, index as u64, &mut vertices, &mut splats);
                    *out = self.trace_camera_path(it, index, &vertices, None);
                }
                self.flush_ray_count();
                splats
            })
            .collect();
        for s in &splats {
            s.add_to(estimates);
        }
    }

    /// With merging, every camera subpath may merge with any light vertex:
    /// all light subpaths are traced first and their vertices indexed by a
    /// hash grid (the photon map, freed at the end of the iteration).
    fn render_with_photon_map(&self, it: &Iteration, estimates: &mut [Vec3]) {
        let light_paths = estimates.len();
        // Light pass, in fixed blocks.
        let blocks: Vec<(Vec<LightVertex>, Vec<usize>, Splats)> = (0..light_paths)
            .into_par_iter()
            .step_by(LIGHT_BLOCK)
            .map(|first| {
                let mut vertices = Vec::new();
                let mut ends = Vec::with_capacity(LIGHT_BLOCK);
                let mut splats = Splats::default();
                for i in first..(first + LIGHT_BLOCK).min(light_paths) {
                    self.trace_light_path(it, i as u64, &mut vertices, &mut splats);
                    ends.push(vertices.len());
                }
                self.flush_ray_count();
                // Kept to the end of the iteration: without the growth slack.
                vertices.shrink_to_fit();
                (vertices, ends, splats)
            })
            .collect();
        let mut paths = LightPaths {
            blocks: Vec::with_capacity(blocks.len()),
            ends: Vec::with_capacity(light_paths),
        };
        let mut all_splats = Vec::with_capacity(blocks.len());
        for (vertices, ends, splats) in blocks {
            paths.blocks.push(vertices);
            paths.ends.extend(ends);
            all_splats.push(splats);
        }
        let photons: Vec<&LightVertex> = paths.vertices().collect();
        let mut grid = HashGrid::new();
        grid.build_with(photons.len(), it.radius, |i| photons[i].point.p);

        // Camera pass.
        let photon_map = Some((&grid, photons.as_slice()));
        estimates
            .par_chunks_mut(LIGHT_BLOCK)
            .enumerate()
            .for_each(|(block, chunk)| {
                for (k, out) in chunk.iter_mut().enumerate() {
                    let index = block * LIGHT_BLOCK + k;
                    *out = self.trace_camera_path(it, index, paths.path(index), photon_map);
                }
                self.flush_ray_count();
            });
        for splats in &all_splats {
            splats.add_to(estimates);
        }
    }

    /// The light subpath with index `index`: its non-specular vertices are
    /// appended to `vertices`, its light-tracing contributions to `splats`.
    fn trace_light_path(
        &self,
        it: &Iteration,
        index: u64,
        vertices: &mut Vec<LightVertex>,
        splats: &mut Splats,
    ) {
        let scene = &self.scene;
        let techniques = it.mis.techniques();
        let mut sampler = Sampler::new(self.config.seed, it.n, LIGHT_STREAM + index);
        let (u_select, u_position, u_direction) =
            (sampler.next_1d(), sampler.next_2d(), sampler.next_2d());
        let Some(emission) = self
            .lights
            .sample_emission(scene, u_select, u_position, u_direction)
        else {
            return;
        };
        let mut ray = SubpathRay::from_light(&it.mis, &emission.mis.emission());
        let regularization = PathRegularization::new(it.mode, Subpath::Light, it.tau_n);
        let (mut origin, mut direction) = (emission.origin, emission.direction);
        let mut throughput = emission.throughput;
        let emitted = throughput.max_element();
        for length in 1..=self.config.max_depth {
            let Some(hit) = self.intersect(origin, direction, f32::INFINITY) else {
                break;
            };
            let point = self.surface_point(&hit);
            let vertex = PathVertex::new(scene, point, -direction, throughput, 0.0, regularization);
            let state = ray.arrive(&it.mis, f64::from(hit.t), f64::from(vertex.cos(direction)));
            if !vertex.is_specular() {
                vertices.push(LightVertex {
                    point,
                    wi: -direction,
                    throughput,
                    state,
                    length,
                    bound: throughput.max_element() * vertex.importance_bound(),
                });
            }
            if techniques.connections && length < self.config.max_depth {
                let u = sampler.keyed_1d(u64::from(length));
                self.connect_to_camera(it, &vertex, &state, u, splats);
            }
            // Every further vertex makes paths of at least length + 2 segments.
            if length + 2 > self.config.max_depth {
                break;
            }
            sampler.set_dimension(EMISSION_DIMENSIONS + (length - 1) * LIGHT_DIMENSIONS_PER_VERTEX);
            let (u_lobe, u_bsdf) = (sampler.next_1d(), sampler.next_2d());
            let u_roulette = sampler.next_1d();
            let Some(s) = vertex.sample(u_lobe, u_bsdf, TransportMode::Importance) else {
                break;
            };
            ray = state.scatter(&it.mis, &scatter_event(&vertex, &s));
            throughput *= s.weight;
            origin = point.spawn_origin(s.wo);
            direction = s.wo;
            // Russian roulette relative to the emitted throughput (light
            // subpaths carry flux, whose scale is the light's).
            if length >= crate::pt::ROULETTE_DEPTH {
                let survive = (throughput.max_element() / emitted).min(1.0);
                if !(u_roulette < survive) {
                    break;
                }
                throughput /= survive;
            }
        }
    }

    /// Light tracing (t = 1): connects a light vertex to the camera and
    /// records the contribution for the pixel it projects to.
    ///
    /// Seen from the camera, the vertex is the first of a camera subpath, so
    /// it is regularized by the camera-side rule (SPEC §5: nothing before
    /// it, rho = 0): in selective mode what the camera sees directly stays
    /// sharp in light tracing too, and a mirror that the light subpath blurred
    /// does not show a blurred highlight that no camera technique would
    /// produce (the techniques would then estimate different integrands).
    fn connect_to_camera(
        &self,
        it: &Iteration,
        light_vertex: &PathVertex,
        state: &SubpathState,
        u_roulette: f32,
        splats: &mut Splats,
    ) {
        let camera = self.camera.camera();
        let Some((x, y)) = self.camera.project(light_vertex.point.p) else {
            return;
        };
        // Without regularization, or for a lobe without roughness, both
        // rules leave the vertex as it is.
        let rebuilt;
        let vertex = if it.mode == Mode::Off || light_vertex.is_regularization_invariant() {
            light_vertex
        } else {
            let seen_from_camera = PathRegularization::new(it.mode, Subpath::Camera, it.tau_n);
            rebuilt = PathVertex::new(
                &self.scene,
                light_vertex.point,
                light_vertex.wi,
                light_vertex.throughput,
                0.0,
                seen_from_camera,
            );
            &rebuilt
        };
        if vertex.is_specular() {
            return;
        }
        let to_camera = camera.position - vertex.point.p;
        let distance = to_camera.length();
        let dir = to_camera / distance;
        let f = vertex.eval(dir, TransportMode::Importance);
        if f.max_element() <= 0.0 {
            return;
        }
        let camera_pdf_w = self.camera.pdf_w(-dir);
        // The pixel integral is over the image plane in pixel units: the
        // surface-to-image factor is camera_pdf_w / d^2 (SmallVCM's
        // ConnectToCamera); each of the N light paths is one sample.
        let light_paths = (camera.resolution.x * camera.resolution.y) as f32;
        let unweighted =
            vertex.throughput * f * (camera_pdf_w / (distance * distance * light_paths));
        let Some(contribution) = it.roulette(unweighted, u_roulette, || {
            it.mis.light_tracing_weight(
                state,
                &vertex.connection_end(dir),
                f64::from(camera_pdf_w),
                f64::from(distance),
            ) as f32
        }) else {
            return;
        };
        let origin = vertex.point.spawn_origin(dir);
        if self.occluded(origin, camera.position - origin, 1.0) {
            return;
        }
        let pixel = y * camera.resolution.x + x;
        splats.push(pixel, contribution);
    }

    /// The camera subpath of pixel `index` (row-major) with all its
    /// techniques: connections to `light_path` (the light subpath with the
    /// same index), and merges with `photons` (a grid over light vertices)
    /// when merging. Returns the pixel estimate without light-tracing splats.
    fn trace_camera_path(
        &self,
        it: &Iteration,
        index: usize,
        light_path: &[LightVertex],
        photons: Option<(&HashGrid, &[&LightVertex])>,
    ) -> Vec3 {
        let scene = &self.scene;
        let techniques = it.mis.techniques();
        let width = self.scene.camera.resolution.x as usize;
        let pixel = UVec2::new((index % width) as u32, (index / width) as u32);
        let mut sampler = Sampler::new(self.config.seed, it.n, index as u64);
        let (mut origin, mut direction) = self.camera.ray(pixel.x, pixel.y, sampler.next_2d());
        let mut ray = SubpathRay::from_camera(&it.mis, f64::from(self.camera.pdf_w(direction)));
        let mut regularization = PathRegularization::new(it.mode, Subpath::Camera, it.tau_n);
        let mut throughput = Vec3::ONE;
        let mut radiance = Vec3::ZERO;
        for length in 1..=self.config.max_depth {
            let Some(hit) = self.intersect(origin, direction, f32::INFINITY) else {
                if let Some(le) = self.lights.environment() {
                    let pdfs = self.lights.environment_pdfs();
                    let w = it.mis.environment_hit_weight(
                        &ray,
                        &EmitterHit {
                            direct_pdf_a: f64::from(pdfs.direct_pdf),
                            emission_pdf_w: f64::from(pdfs.emission_pdf_w),
                        },
                    );
                    radiance += throughput * le * w as f32;
                }
                break;
            };
            let point = self.surface_point(&hit);
            let vertex = PathVertex::new(scene, point, -direction, throughput, 0.0, regularization);
            regularization = vertex.regularization;
            let state = ray.arrive(&it.mis, f64::from(hit.t), f64::from(vertex.cos(direction)));

            let emission = scene.materials[point.material as usize].emission;
            let cos_light = point.n_winding.dot(-direction);
            if emission.max_element() > 0.0 && cos_light > 0.0 {
                let pdfs = self.lights.area_pdfs(point.triangle, cos_light);
                let w = it.mis.emitter_hit_weight(
                    &state,
                    &EmitterHit {
                        direct_pdf_a: f64::from(pdfs.direct_pdf),
                        emission_pdf_w: f64::from(pdfs.emission_pdf_w),
                    },
                );
                radiance += throughput * emission * w as f32;
            }
            if length >= self.config.max_depth {
                break;
            }
            sampler.set_dimension(2 + (length - 1) * DIMENSIONS_PER_VERTEX);
            let (u_light, uv_light) = (sampler.next_1d(), sampler.next_2d());
            let (u_lobe, u_bsdf) = (sampler.next_1d(), sampler.next_2d());
            let u_roulette = sampler.next_1d();

            if !vertex.is_specular() {
                if techniques.connections {
                    // The emitter point of next-event estimation is light vertex 0.
                    let u = sampler.keyed_1d(u64::from(length) << 32);
                    radiance += self.next_event_vcm(it, &vertex, &state, u_light, uv_light, u);
                    for light in light_path {
                        if light.length + length < self.config.max_depth {
                            let key = u64::from(length) << 32 | u64::from(light.length);
                            let u = || sampler.keyed_1d(key);
                            radiance += self.connect(it, &vertex, &state, light, u);
                        }
                    }
                }
                if let Some((grid, vertices)) = photons {
                    radiance +=
                        throughput * self.merge(it, &vertex, &state, length, vertices, grid);
                }
            }

            let Some(s) = vertex.sample(u_lobe, u_bsdf, TransportMode::Radiance) else {
                break;
            };
            ray = state.scatter(&it.mis, &scatter_event(&vertex, &s));
            throughput *= s.weight;
            origin = point.spawn_origin(s.wo);
            direction = s.wo;
            if length >= crate::pt::ROULETTE_DEPTH
                && !crate::pt::survives_roulette(&mut throughput, u_roulette)
            {
                break;
            }
        }
        radiance
    }

    /// Next-event estimation (s = 1) at a camera vertex, weighted against
    /// every other technique: the contribution to the pixel (camera
    /// throughput included). Its shadow ray goes through the same roulette
    /// as those of connections: its MIS weight shares the path with them.
    fn next_event_vcm(
        &self,
        it: &Iteration,
        vertex: &PathVertex,
        state: &SubpathState,
        u_light: f32,
        uv: Vec2,
        u_roulette: f32,
    ) -> Vec3 {
        let Some((ls, f)) = self.light_sample(vertex, u_light, uv) else {
            return Vec3::ZERO;
        };
        let unweighted = vertex.throughput * f * ls.li / ls.pdf;
        let contribution = it.roulette(unweighted, u_roulette, || {
            it.mis
                .next_event_weight(state, &vertex.connection_end(ls.wi), &ls.mis_sample())
                as f32
        });
        match contribution {
            Some(contribution) if self.light_visible(vertex, &ls) => contribution,
            _ => Vec3::ZERO,
        }
    }

    /// A vertex connection between a camera vertex and a light vertex: the
    /// contribution to the pixel (camera throughput included). The light
    /// vertex is regularized as the camera subpath would regularize its next
    /// vertex (see [`Renderer::connect_to_camera`]). `u_roulette` draws the
    /// roulette's random number, a hash: a third of the pairs are rejected
    /// on geometry alone and need none.
    fn connect(
        &self,
        it: &Iteration,
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
        if roulette_skips(bound, it.roulette_threshold, u_roulette) {
            return Vec3::ZERO;
        }
        let light_vertex = PathVertex::new(
            &self.scene,
            light.point,
            light.wi,
            light.throughput,
            0.0,
            camera.regularization,
        );
        if light_vertex.is_specular() {
            return Vec3::ZERO;
        }
        let f = f_camera * light_vertex.eval(-dir, TransportMode::Importance);
        if f.max_element() <= 0.0 {
            return Vec3::ZERO;
        }
        let unweighted = camera.throughput * f * light.throughput / distance2;
        let Some(contribution) = it.roulette(unweighted, u_roulette, || {
            it.mis.connection_weight(
                &light.state,
                &light_vertex.connection_end(-dir),
                camera_state,
                &camera.connection_end(dir),
                f64::from(distance),
            ) as f32
        }) else {
            return Vec3::ZERO;
        };
        let origin = camera.point.spawn_origin(dir);
        let end = light.point.spawn_origin(-dir);
        if self.occluded(origin, end - origin, 1.0) {
            return Vec3::ZERO;
        }
        contribution
    }

    /// Vertex merging at a camera vertex: density estimation over the light
    /// vertices within the merge radius (SmallVCM's range query), with the
    /// camera vertex's BSDF towards each photon's incoming direction.
    fn merge(
        &self,
        it: &Iteration,
        camera: &PathVertex,
        camera_state: &SubpathState,
        length: u32,
        photons: &[&LightVertex],
        grid: &HashGrid,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        grid.for_each_within(camera.point.p, it.radius, |i| {
            let light = photons[i];
            if light.length + length > self.config.max_depth {
                return;
            }
            let f = camera.f(light.wi, TransportMode::Radiance);
            if f.max_element() <= 0.0 {
                return;
            }
            let weight = it.mis.merge_weight(
                &light.state,
                camera_state,
                &camera.connection_pdfs(light.wi),
            ) as f32;
            sum += f * light.throughput * weight;
        });
        sum * it.merge_normalisation
    }

    /// A light sample for a camera vertex with the vertex's f |cos| towards
    /// it, if both are non-zero (the start of next-event estimation; the
    /// shadow ray is the caller's: the bidirectional core decides its
    /// roulette first, see `next_event_vcm`).
    fn light_sample(
        &self,
        vertex: &PathVertex,
        u_light: f32,
        uv: Vec2,
    ) -> Option<(crate::lights::LightSample, Vec3)> {
        let ls = self
            .lights
            .sample(&self.scene, vertex.point.p, u_light, uv)?;
        let f = vertex.eval(ls.wi, TransportMode::Radiance);
        (f.max_element() > 0.0).then_some((ls, f))
    }

    /// [`Renderer::light_sample`] when its shadow ray is unoccluded (PT's
    /// next-event estimation).
    pub(crate) fn visible_light_sample(
        &self,
        vertex: &PathVertex,
        u_light: f32,
        uv: Vec2,
    ) -> Option<(crate::lights::LightSample, Vec3)> {
        self.light_sample(vertex, u_light, uv)
            .filter(|(ls, _)| self.light_visible(vertex, ls))
    }

    /// Whether the shadow ray of a light sample is unoccluded.
    fn light_visible(&self, vertex: &PathVertex, ls: &crate::lights::LightSample) -> bool {
        let origin = vertex.point.spawn_origin(ls.wi);
        match ls.point {
            Some(lp) => {
                let end = if lp.n == Vec3::ZERO {
                    lp.p
                } else {
                    let n = if lp.n.dot(-ls.wi) > 0.0 { lp.n } else { -lp.n };
                    accel::offset_ray_origin(lp.p, n)
                };
                !self.occluded(origin, end - origin, 1.0)
            }
            None => !self.occluded(origin, ls.wi, f32::INFINITY),
        }
    }
}

/// Russian roulette on a shadow ray (Veach 1997, §10.4.1, "efficiency-
/// optimized Russian roulette"): a contribution whose largest component c is
/// below `threshold` keeps its shadow ray with probability c / threshold and
/// is divided by it, so its expectation is unchanged. Many connections carry
/// a small share of a pixel (their MIS weights split the path among the
/// techniques); skipping most of their rays costs little variance. MIS
/// weights are unaffected: visibility is in no technique's density.
///
/// Returns the contribution to test for visibility, or `None` when the ray
/// is skipped. A non-finite contribution is kept (and later counted as an
/// invalid sample).
fn shadow_roulette(contribution: Vec3, threshold: f32, u: f32) -> Option<Vec3> {
    let c = contribution.max_element();
    if !(c < threshold) {
        return Some(contribution);
    }
    let q = c / threshold;
    (u < q).then(|| contribution / q)
}

/// True when [`shadow_roulette`] is sure to skip every contribution whose
/// largest component is at most `bound`, with the same `u`: the MIS weight
/// (at most 1) of a connection need not be computed when its unweighted
/// contribution already fails the roulette, nor its BSDFs evaluated when a
/// bound of them does. The same decisions, reached sooner. A NaN bound
/// decides nothing.
fn roulette_skips(bound: f32, threshold: f32, u: f32) -> bool {
    bound < threshold && u >= bound / threshold
}

/// The `mis` crate's record of a sampled scattering event.
fn scatter_event(vertex: &PathVertex, s: &crate::vertex::VertexSample) -> Scatter {
    let pdfs = if s.is_specular {
        // The tech. rep.'s specular rule: the lobe's discrete probability
        // as both pdfs.
        VertexPdfs::new(f64::from(s.pdf), f64::from(s.pdf))
    } else {
        VertexPdfs::regularized(f64::from(s.mis_pdf), f64::from(s.mis_pdf_rev), vertex.tau)
    };
    Scatter {
        pdfs,
        cos_out: f64::from(vertex.cos(s.wo)),
        specular: s.is_specular,
    }
}
/// The MIS weights of the techniques of the bidirectional core partition
/// unity on the paths the integrator builds (SPEC §6: in `off` and `uniform`
/// modes, with and without virtual merges; in `selective` mode the two
/// subpaths regularize a vertex differently, so the techniques estimate
/// different integrands and no partition is expected).
///
/// Camera subpaths are traced as [`Renderer::trace_camera_path`] traces them
/// and completed the two ways the integrator completes them: by hitting an
/// area emitter, and by next-event estimation at a non-specular vertex. Each
/// complete path x_0 (light) ... camera is then taken apart into every
/// (light subpath, camera subpath) split: both subpaths' recursions run
/// along the path's vertices as the integrator runs them (same vertices,
/// regularization rules and `mis` calls), and each technique's weight is
/// computed with the integrator's calls and arguments: emitter hit,
/// next-event estimation, connections, light tracing and merges (a
/// connection's weight includes its virtual merges).
///
/// Both subpaths take their directions from the vertex positions: the
/// traced rays start at offset origins (`accel::offset_ray_origin`), whose
/// 1e-5 shifts change the pdf of a sharp regularized lobe by ~1e-4 between
/// two subpaths, which would hide small partition errors.
#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::{Regularization, RenderConfig};
    use crate::lights::EmitterPdfs;
    use mis::EmitterKind;

    /// The roulette keeps a contribution's expectation: averaged over a
    /// stratified grid of u it returns the contribution (to the grid's
    /// resolution); above the threshold, or without one, it is the identity.
    #[test]
    fn shadow_roulette_is_unbiased() {
        let n: u32 = 1 << 16;
        let c = Vec3::new(0.03, 0.01, 0.0);
        let mean = (0..n)
            .filter_map(|i| shadow_roulette(c, 0.1, (i as f32 + 0.5) / n as f32))
            .map(Vec3::as_dvec3)
            .sum::<glam::DVec3>()
            / f64::from(n);
        // One grid cell more or less kept changes the mean by threshold / n.
        let tolerance = 0.1 / f64::from(n);
        assert!(
            (mean - c.as_dvec3()).abs().max_element() < tolerance,
            "{mean} vs {c}"
        );
        let kept = (0..n)
            .filter(|&i| shadow_roulette(c, 0.1, (i as f32 + 0.5) / n as f32).is_some())
            .count();
        assert_eq!(kept, (0.3 * f64::from(n)).round() as usize);
        // The early test skips only what the roulette would skip.
        let mut early = 0;
        for i in 0..n {
            let u = (i as f32 + 0.5) / n as f32;
            for w in [1.0, 0.5, 0.1] {
                if roulette_skips(c.max_element(), 0.1, u) {
                    early += 1;
                    assert_eq!(shadow_roulette(c * w, 0.1, u), None, "u {u}, weight {w}");
                }
            }
        }
        assert_eq!(early, 3 * (n - kept as u32));
        for u in [0.0, 0.5, 0.999] {
            assert_eq!(shadow_roulette(c, 0.02, u), Some(c));
            assert_eq!(shadow_roulette(c, 0.0, u), Some(c));
            assert!(shadow_roulette(Vec3::NAN, 0.1, u).is_some_and(|v| v.is_nan()));
        }
    }

    /// Unit directions spread over the sphere (a Fibonacci lattice).
    fn sphere_directions(n: u32) -> impl Iterator<Item = Vec3> {
        (0..n).map(move |i| {
            let z = 1.0 - (2.0 * i as f32 + 1.0) / n as f32;
            let phi = i as f32 * 2.399_963;
            let r = (1.0 - z * z).sqrt();
            Vec3::new(r * phi.cos(), r * phi.sin(), z)
        })
    }

    /// A light vertex's bound holds towards every direction, with shading
    /// normals away from the geometric one (where the shading correction
    /// exceeds 1), is the value itself where the two normals agree (so it
    /// lets the roulette skip work), and is infinite for microfacet lobes.
    #[test]
    fn light_vertex_bound_holds_towards_every_direction() {
        let r = renderer("glossy-caustic", Algorithm::Bpt, Mode::Off, false);
        let it = r.iteration(1);
        let material = |diffuse: bool| {
            r.scene
                .materials
                .iter()
                .position(|m| matches!(m.surface, scene::Surface::Diffuse { .. }) == diffuse)
                .expect("the scene has diffuse and glossy materials") as u32
        };
        let state = SubpathRay::from_camera(&it.mis, 1.0).arrive(&it.mis, 1.0, 1.0);
        let light_vertex = |point: SurfacePoint, wi: Vec3| {
            let throughput = Vec3::new(0.5, 2.0, 1.0);
            let regularization = PathRegularization::new(Mode::Off, Subpath::Light, 1.0);
            let vertex = PathVertex::new(&r.scene, point, wi, throughput, 0.0, regularization);
            let light = LightVertex {
                point,
                wi,
                throughput,
                state,
                length: 1,
                bound: throughput.max_element() * vertex.importance_bound(),
            };
            (vertex, light)
        };
        let ng = Vec3::Z;
        let mut tight = 0;
        for tilt in [0.0, 0.3, 0.8] {
            let ns = Vec3::new(tilt, 0.2 * tilt, 1.0).normalize();
            let point = SurfacePoint {
                p: Vec3::ZERO,
                n_winding: ng,
                ng,
                frame: crate::geometry::Frame::from_normal(ns),
                uv: Vec2::ZERO,
                triangle: 0,
                material: material(true),
            };
            for wi in sphere_directions(64) {
                let (vertex, light) = light_vertex(point, wi);
                for wo in sphere_directions(256) {
                    let value = (vertex.throughput * vertex.eval(wo, TransportMode::Importance))
                        .max_element();
                    let bound = light.bound_towards(wo);
                    assert!(
                        value <= bound * (1.0 + 1e-5),
                        "{value} > {bound}: {wi} {wo} {ns}"
                    );
                    if tilt == 0.0 {
                        // Equal, zero included (wo on the other side).
                        assert!(value >= bound * (1.0 - 1e-5), "{value} < {bound}");
                        tight += usize::from(value > 0.0);
                    }
                }
            }
            let glossy = SurfacePoint {
                material: material(false),
                ..point
            };
            let (_, light) = light_vertex(glossy, Vec3::Z);
            assert_eq!(light.bound_towards(Vec3::Z), f32::INFINITY);
        }
        assert!(tight > 1000, "{tight}");
    }

    /// The light end x_0 of a complete path, seen from its last camera vertex.
    struct LightEnd {
        p: Vec3,
        /// The emitter's pdfs towards the last camera vertex, in the
        /// conventions of a light sample's (`LightSample::mis`).
        pdfs: EmitterPdfs,
        /// Next-event estimation from the last camera vertex.
        nee: mis::LightSample,
    }

    /// A complete path: camera vertices y_1 ... y_m (first hit first) and
    /// the light x_0.
    struct CompletePath {
        camera: Vec<SurfacePoint>,
        light: LightEnd,
    }

    /// The complete paths that the camera subpath of pixel `index` builds.
    fn complete_paths(r: &Renderer, it: &Iteration, index: usize) -> Vec<CompletePath> {
        let width = r.scene.camera.resolution.x as usize;
        let pixel = UVec2::new((index % width) as u32, (index / width) as u32);
        let mut sampler = Sampler::new(r.config.seed, it.n, index as u64);
        let (mut origin, mut direction) = r.camera.ray(pixel.x, pixel.y, sampler.next_2d());
        let mut regularization = PathRegularization::new(it.mode, Subpath::Camera, it.tau_n);
        let mut camera: Vec<SurfacePoint> = Vec::new();
        let mut paths = Vec::new();
        for length in 1..=r.config.max_depth {
            let Some(hit) = r.intersect(origin, direction, f32::INFINITY) else {
                break;
            };
            let point = r.surface_point(&hit);
            let vertex =
                PathVertex::new(&r.scene, point, -direction, Vec3::ONE, 0.0, regularization);
            regularization = vertex.regularization;
            let emission = r.scene.materials[point.material as usize].emission;
            if let Some(&last) = camera.last()
                && emission.max_element() > 0.0
                && point.n_winding.dot(-direction) > 0.0
            {
                let d = last.p - point.p;
                let cos = point.n_winding.dot(d.normalize()).abs();
                let pdfs = r.lights.area_pdfs(point.triangle, cos);
                let d2 = f64::from(d.length_squared());
                paths.push(CompletePath {
                    camera: camera.clone(),
                    light: LightEnd {
                        p: point.p,
                        pdfs,
                        nee: mis::LightSample {
                            kind: EmitterKind::Area,
                            direct_pdf_w: f64::from(pdfs.direct_pdf) * d2 / f64::from(cos),
                            emission_pdf_w: f64::from(pdfs.emission_pdf_w),
                            cos_light: f64::from(cos),
                        },
                    },
                });
            }
            camera.push(point);
            sampler.set_dimension(2 + (length - 1) * DIMENSIONS_PER_VERTEX);
            let (u_light, uv_light) = (sampler.next_1d(), sampler.next_2d());
            let (u_lobe, u_bsdf) = (sampler.next_1d(), sampler.next_2d());
            if !vertex.is_specular()
                && let Some((ls, _)) = r.visible_light_sample(&vertex, u_light, uv_light)
                && let Some(lp) = ls.point
            {
                paths.push(CompletePath {
                    camera: camera.clone(),
                    light: LightEnd {
                        p: lp.p,
                        pdfs: ls.mis,
                        nee: ls.mis_sample(),
                    },
                });
            }
            let Some(s) = vertex.sample(u_lobe, u_bsdf, TransportMode::Radiance) else {
                break;
            };
            // The recursion below takes a vertex's pdfs towards fixed
            // directions; they must be the ones a sample records.
            if !s.is_specular {
                let (sampled, fixed) = (scatter_event(&vertex, &s), scatter_towards(&vertex, s.wo));
                let close = |a: f64, b: f64| (a - b).abs() <= 1e-4 * a.abs().max(b.abs());
                assert!(
                    close(sampled.pdfs.fwd, fixed.pdfs.fwd),
                    "{sampled:?} {fixed:?}"
                );
                assert!(
                    close(sampled.pdfs.rev, fixed.pdfs.rev),
                    "{sampled:?} {fixed:?}"
                );
                assert_eq!(sampled.pdfs.tau, fixed.pdfs.tau);
            }
            origin = point.spawn_origin(s.wo);
            direction = s.wo;
        }
        paths
    }

    /// The scattering event of a subpath at `vertex` towards the fixed
    /// direction `wo` (the pdfs `scatter_event` records for a sample there;
    /// a delta lobe's discrete probability cancels, so 1 stands for it).
    fn scatter_towards(vertex: &PathVertex, wo: Vec3) -> Scatter {
        let specular = vertex.is_specular();
        Scatter {
            pdfs: if specular {
                VertexPdfs::new(1.0, 1.0)
            } else {
                vertex.connection_pdfs(wo)
            },
            cos_out: f64::from(vertex.cos(wo)),
            specular,
        }
    }

    /// The sum over all techniques of their weights for `path`, and whether
    /// a vertex of it is regularized.
    fn weight_sum(r: &Renderer, it: &Iteration, path: &CompletePath) -> (f64, bool) {
        let techniques = it.mis.techniques();
        let camera_position = r.camera.camera().position;
        let m = path.camera.len();
        // Positions by camera-subpath index: 0 the camera, 1..=m the camera
        // vertices, m + 1 the light.
        let p = |i: usize| match i {
            0 => camera_position,
            i if i <= m => path.camera[i - 1].p,
            _ => path.light.p,
        };
        let towards = |from: usize, to: usize| (p(to) - p(from)).normalize();
        let distance = |a: usize, b: usize| f64::from(p(a).distance(p(b)));
        let vertex = |i: usize, previous: usize, rule: PathRegularization| {
            let wi = towards(i, previous);
            PathVertex::new(&r.scene, path.camera[i - 1], wi, Vec3::ONE, 0.0, rule)
        };

        // The camera subpath: camera[i - 1] is y_i with its state on arrival.
        let mut ray = SubpathRay::from_camera(&it.mis, f64::from(r.camera.pdf_w(towards(0, 1))));
        let mut rule = PathRegularization::new(it.mode, Subpath::Camera, it.tau_n);
        let mut camera = Vec::with_capacity(m);
        for i in 1..=m {
            let y = vertex(i, i - 1, rule);
            rule = y.regularization;
            let state = ray.arrive(
                &it.mis,
                distance(i - 1, i),
                f64::from(y.cos(towards(i, i - 1))),
            );
            ray = state.scatter(&it.mis, &scatter_towards(&y, towards(i, i + 1)));
            camera.push((y, state));
        }
        let light = &path.light;
        let mut sum = 0.0;
        if light.pdfs.kind.is_hittable() {
            let cos = f64::from(light.pdfs.cos_light);
            let state = ray.arrive(&it.mis, distance(m, m + 1), cos);
            let hit = EmitterHit {
                direct_pdf_a: f64::from(light.pdfs.direct_pdf),
                emission_pdf_w: f64::from(light.pdfs.emission_pdf_w),
            };
            sum += it.mis.emitter_hit_weight(&state, &hit);
        }

        // The light subpath along the same vertices: light[i - 1] is y_i as
        // the light subpath reaches it, with its state on arrival.
        let mut emission = light.pdfs.emission();
        if light.pdfs.kind == EmitterKind::Point {
            // A point light's next-event pdf carries d^2 (solid angle), its
            // emission's is the bare selection probability.
            emission.direct_pdf_a /= distance(m, m + 1).powi(2);
        }
        let light_rule = PathRegularization::new(it.mode, Subpath::Light, it.tau_n);
        let mut ray = SubpathRay::from_light(&it.mis, &emission);
        let mut light_path = Vec::with_capacity(m);
        for i in (1..=m).rev() {
            let z = vertex(i, i + 1, light_rule);
            let state = ray.arrive(
                &it.mis,
                distance(i, i + 1),
                f64::from(z.cos(towards(i, i + 1))),
            );
            ray = state.scatter(&it.mis, &scatter_towards(&z, towards(i, i - 1)));
            light_path.push((z, state));
        }
        light_path.reverse();
        let regularized = camera
            .iter()
            .chain(&light_path)
            .any(|(v, _)| v.alpha_hat.is_some());

        for i in 1..=m {
            let (y, camera_state) = &camera[i - 1];
            if y.is_specular() {
                continue;
            }
            if techniques.connections && i == m {
                sum += it.mis.next_event_weight(
                    camera_state,
                    &y.connection_end(towards(i, i + 1)),
                    &light.nee,
                );
            } else if techniques.connections {
                // The light vertex regularized as the camera subpath would
                // (see `Renderer::connect`).
                let (z, light_state) = &light_path[i];
                let end =
                    PathVertex::new(&r.scene, z.point, z.wi, Vec3::ONE, 0.0, y.regularization);
                if !end.is_specular() {
                    let dir = towards(i, i + 1);
                    sum += it.mis.connection_weight(
                        light_state,
                        &end.connection_end(-dir),
                        camera_state,
                        &y.connection_end(dir),
                        distance(i, i + 1),
                    );
                }
            }
            if techniques.merging {
                let (z, light_state) = &light_path[i - 1];
                sum += it
                    .mis
                    .merge_weight(light_state, camera_state, &y.connection_pdfs(z.wi));
            }
        }
        if techniques.connections {
            // Light tracing from y_1, regularized as seen from the camera
            // (see `Renderer::connect_to_camera`).
            let (z, light_state) = &light_path[0];
            let seen_rule = PathRegularization::new(it.mode, Subpath::Camera, it.tau_n);
            let seen = PathVertex::new(&r.scene, z.point, z.wi, Vec3::ONE, 0.0, seen_rule);
            if !seen.is_specular() {
                sum += it.mis.light_tracing_weight(
                    light_state,
                    &seen.connection_end(towards(1, 0)),
                    f64::from(r.camera.pdf_w(towards(0, 1))),
                    distance(0, 1),
                );
            }
        }
        (sum, regularized)
    }

    fn renderer(scene: &str, algorithm: Algorithm, mode: Mode, virtual_merges: bool) -> Renderer {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../scenes")
            .join(scene)
            .join("scene.toml");
        let options = scene::LoadOptions {
            camera_name: None,
            resolution: Some(UVec2::new(48, 36)),
        };
        let scene = scene::load(&path, &options).expect("bundled scene loads");
        let config = RenderConfig {
            algorithm,
            max_depth: 8,
            // A fixed tau (no schedule): uniform mode then regularizes every
            // vertex of both subpaths with one bound.
            regularization: Regularization::new(mode, crate::DEFAULT_TAU_0, false)
                .expect("valid tau"),
            virtual_merges: Some(virtual_merges),
            ..RenderConfig::default()
        };
        Renderer::new(scene, config)
    }

    /// Over the complete paths of every pixel: the largest |sum - 1|, the
    /// number of paths, and how many had a regularized vertex.
    fn worst_partition(r: &Renderer) -> (f64, usize, usize) {
        let it = r.iteration(1);
        let (w, h) = r.resolution();
        let (mut worst, mut paths, mut regularized) = (0.0f64, 0, 0);
        for index in 0..(w * h) as usize {
            for path in complete_paths(r, &it, index) {
                let (sum, reg) = weight_sum(r, &it, &path);
                worst = worst.max((sum - 1.0).abs());
                paths += 1;
                regularized += usize::from(reg);
            }
        }
        (worst, paths, regularized)
    }

    /// Weights of f32 pdfs: sums are 1 to 2.5e-7 at most (measured); a
    /// missing or doubled technique is off by its own weight.
    const PARTITION_TOLERANCE: f64 = 1e-5;

    #[test]
    fn weights_partition_unity_on_integrator_paths() {
        for scene in ["caustic-glass", "glossy-caustic", "cornell-box"] {
            for algorithm in [Algorithm::Bpt, Algorithm::Vcm, Algorithm::Ppm] {
                for (mode, virtual_merges) in [
                    (Mode::Off, false),
                    (Mode::Uniform, false),
                    (Mode::Uniform, true),
                ] {
                    let r = renderer(scene, algorithm, mode, virtual_merges);
                    let (worst, paths, regularized) = worst_partition(&r);
                    let what = format!(
                        "{scene} {algorithm} {mode:?} virtual merges {virtual_merges}: \
                         {paths} paths ({regularized} regularized), max |sum - 1| {worst:.3e}"
                    );
                    eprintln!("{what}");
                    assert!(paths > 500, "{what}");
                    assert!(worst < PARTITION_TOLERANCE, "{what}");
                    if mode == Mode::Uniform && scene != "cornell-box" {
                        assert!(regularized > 0, "{what}");
                    }
                }
            }
        }
    }
}
