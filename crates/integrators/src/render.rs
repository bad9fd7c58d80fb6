//! The renderer: a scene prepared for ray queries and light sampling, and
//! one iteration of the configured algorithm over the image.

use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

use accel::{Bvh, Hit};
use glam::Vec3;
use rayon::prelude::*;
use regularization::tau::{alpha_cap, alpha_tau};
use regularization::{Lobe, Mode};
use scene::{Scene, SceneFeatures};

use crate::camera::CameraRays;
use crate::config::{Algorithm, RenderConfig};
use crate::film::Film;
use crate::geometry::SurfacePoint;
use crate::lights::Lights;
use crate::merge_radius::{MergeRadius, pixel_footprint};
use crate::sampler::Sampler;

/// A scene ready to render with one configuration.
pub struct Renderer {
    pub(crate) scene: Scene,
    pub(crate) bvh: Bvh,
    pub(crate) lights: Lights,
    /// Unit geometric normal of each triangle ([`Scene::geometric_normal`]):
    /// every surface point needs one, and computing it (in f64, see
    /// `scene::triangle_cross`) cost 5 % of a path-traced iteration.
    geometric_normals: Vec<Vec3>,
    pub(crate) config: RenderConfig,
    pub(crate) camera: CameraRays,
    features: SceneFeatures,
    /// Samples that were NaN or infinite and were dropped (set to zero).
    invalid_samples: AtomicU64,
    /// Rays traced by finished iterations (closest-hit and shadow rays).
    rays: AtomicU64,
    /// The merge radius of every iteration (PPM, VCM).
    pub(crate) merge_radius: MergeRadius,
    /// The mean pixel value (largest RGB component) of a small path-traced
    /// preview: the scale of the shadow-ray roulette threshold (0 when the
    /// algorithm does not use the roulette).
    pub(crate) pixel_scale: f32,
}

/// Pixels per image side, and paths per pixel, of the path-traced preview
/// that estimates the mean pixel value (4096 paths whatever the resolution:
/// 8-12 ms on `cornell-box`, in `cargo xtask bench`'s build time).
const PREVIEW_GRID: u32 = 32;
const PREVIEW_PATHS: u64 = 4;

thread_local! {
    /// Rays traced by this thread since its count was last added to a
    /// renderer's total: a plain per-thread counter costs nothing next to a
    /// traversal, where one shared atomic would bounce between cores.
    static THREAD_RAYS: Cell<u64> = const { Cell::new(0) };
}

impl Renderer {
    /// Prepares `scene` (builds the BVH on the current rayon pool).
    pub fn new(scene: Scene, config: RenderConfig) -> Self {
        let bvh = Bvh::build(&scene.triangles);
        let lights = Lights::new(&scene);
        let features = SceneFeatures::of(&scene);
        let camera = CameraRays::new(scene.camera);
        let merge_radius = MergeRadius::new(
            config.radius_factor,
            lights.scene_radius(),
            pixel_footprint(&bvh, &camera),
            config.radius_alpha,
        );
        let geometric_normals = (0..scene.triangles.len())
            .map(|i| scene.geometric_normal(i))
            .collect();
        let mut renderer = Self {
            camera,
            scene,
            bvh,
            lights,
            geometric_normals,
            config,
            features,
            invalid_samples: AtomicU64::new(0),
            rays: AtomicU64::new(0),
            merge_radius,
            pixel_scale: 0.0,
        };
        if renderer.techniques().connections
            && config.algorithm != Algorithm::Pt
            && config.shadow_roulette > 0.0
        {
            renderer.pixel_scale = renderer.preview_pixel_mean();
        }
        renderer
    }

    /// The mean over a grid of pixels of path-traced estimates (largest RGB
    /// component), from random streams of iteration 0, which renders never
    /// use. Its rays are not counted in [`Renderer::rays_traced`]. Returns 0
    /// when the mean is not a positive finite number.
    fn preview_pixel_mean(&self) -> f32 {
        let res = self.scene.camera.resolution;
        let rays_before = THREAD_RAYS.get();
        let tau_1 = self.tau_at(1);
        let mut sum = 0.0f64;
        for i in 0..PREVIEW_GRID * PREVIEW_GRID {
            let (gx, gy) = (i % PREVIEW_GRID, i / PREVIEW_GRID);
            let x = ((2 * gx + 1) * res.x) / (2 * PREVIEW_GRID);
            let y = ((2 * gy + 1) * res.y) / (2 * PREVIEW_GRID);
            for k in 0..PREVIEW_PATHS {
                let stream = (u64::from(y) * u64::from(res.x) + u64::from(x)) * PREVIEW_PATHS + k;
                let mut sampler = Sampler::new(self.config.seed, 0, stream);
                let (o, d) = self.camera.ray(x, y, sampler.next_2d());
                sum += f64::from(self.trace_path(o, d, &mut sampler, tau_1).max_element());
            }
        }
        THREAD_RAYS.set(rays_before);
        let mean = (sum / f64::from(PREVIEW_GRID * PREVIEW_GRID) / PREVIEW_PATHS as f64) as f32;
        if mean.is_finite() && mean > 0.0 {
            mean
        } else {
            0.0
        }
    }

    /// Closest hit along `origin + t direction`, t in (0, t_max): every
    /// integrator's ray query, counted for [`Renderer::rays_traced`].
    pub(crate) fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<Hit> {
        THREAD_RAYS.set(THREAD_RAYS.get() + 1);
        self.bvh.intersect(origin, direction, t_max)
    }

    /// The surface point of a hit.
    pub(crate) fn surface_point(&self, hit: &Hit) -> SurfacePoint {
        let n_winding = self.geometric_normals[hit.triangle as usize];
        SurfacePoint::new(&self.scene, n_winding, hit)
    }

    /// Whether anything lies along `origin + t direction`, t in (0, t_max)
    /// (shadow rays), counted like [`Renderer::intersect`].
    pub(crate) fn occluded(&self, origin: Vec3, direction: Vec3, t_max: f32) -> bool {
        THREAD_RAYS.set(THREAD_RAYS.get() + 1);
        self.bvh.occluded(origin, direction, t_max)
    }

    /// Adds this thread's ray count to the total; called at the end of every
    /// parallel task, so that the total is exact after each iteration.
    pub(crate) fn flush_ray_count(&self) {
        let n = THREAD_RAYS.replace(0);
        if n > 0 {
            self.rays.fetch_add(n, Ordering::Relaxed);
        }
    }

    /// Rays traced so far (camera, light, continuation and shadow rays), for
    /// throughput figures (`cargo xtask bench`).
    pub fn rays_traced(&self) -> u64 {
        self.rays.load(Ordering::Relaxed)
    }

    /// The mean pixel value of a small path-traced preview, the scale of
    /// the shadow-ray roulette threshold; 0 when the roulette is off.
    pub fn shadow_roulette_scale(&self) -> f32 {
        self.pixel_scale
    }

    /// The merge-radius rule, fixed when the renderer is made.
    pub fn merge_radius_rule(&self) -> &MergeRadius {
        &self.merge_radius
    }

    /// The scene.
    pub fn scene(&self) -> &Scene {
        &self.scene
    }

    /// The configuration.
    pub fn config(&self) -> &RenderConfig {
        &self.config
    }

    /// What the scene contains.
    pub fn features(&self) -> &SceneFeatures {
        &self.features
    }

    /// Image size (width, height).
    pub fn resolution(&self) -> (u32, u32) {
        let r = self.scene.camera.resolution;
        (r.x, r.y)
    }

    /// An empty film of the image size.
    pub fn new_film(&self) -> Film {
        let (w, h) = self.resolution();
        Film::new(w, h)
    }

    /// Number of samples so far that were NaN or infinite and were replaced
    /// by zero (a correct renderer keeps this at 0; tests assert it).
    pub fn invalid_samples(&self) -> u64 {
        self.invalid_samples.load(Ordering::Relaxed)
    }

    /// tau_N at iteration `n` (infinity when regularization is off).
    pub fn tau_at(&self, n: u64) -> f64 {
        self.config.regularization.tau_at(n)
    }

    /// True when regularization with bound `tau` can raise the roughness of
    /// some surface of the scene. Selective mode only ever uses bounds at
    /// least tau_N, so tau_N decides for it too. Transmission can be blurred
    /// up to the cap alpha_max; textured roughness may be below its factor.
    pub fn regularization_matters(&self, tau: f64) -> bool {
        let Some(smallest) = self.features.smallest_alpha else {
            return false;
        };
        if !tau.is_finite() {
            return false;
        }
        let widest = if self.features.transmission || self.features.textured {
            f64::from(alpha_cap(microfacet::NdfKind::Ggx))
        } else {
            alpha_tau(Lobe::Reflection, tau)
        };
        f64::from(smallest) < widest
    }

    /// The regularization mode used at bound `tau_n`: `Off` when nothing
    /// would change, so that such renders are bit-identical to unregularized
    /// ones and cost the same (DESIGN.md, "pay only for what a scene uses").
    pub(crate) fn effective_mode(&self, tau_n: f64) -> Mode {
        if self.regularization_matters(tau_n) {
            self.config.regularization.mode
        } else {
            Mode::Off
        }
    }

    /// Renders iteration `iteration` (1-based; it drives tau_N and selects
    /// the random streams) into `estimates`: one estimate per pixel,
    /// row-major. Parallel over rows on the current rayon pool; the result
    /// does not depend on the number of threads.
    ///
    /// # Panics
    /// If `estimates` does not have one entry per pixel.
    pub fn render_iteration(&self, iteration: u64, estimates: &mut [Vec3]) {
        let (width, height) = self.resolution();
        assert_eq!(estimates.len(), width as usize * height as usize);
        if self.config.algorithm != Algorithm::Pt {
            self.render_bidirectional(iteration, estimates);
            self.count_invalid(estimates);
            return;
        }
        let tau_n = self.tau_at(iteration);
        estimates
            .par_chunks_mut(width as usize)
            .enumerate()
            .for_each(|(y, row)| {
                let mut invalid = 0;
                for (x, out) in row.iter_mut().enumerate() {
                    let pixel = y as u64 * u64::from(width) + x as u64;
                    let mut sampler = Sampler::new(self.config.seed, iteration, pixel);
                    let (o, d) = self.camera.ray(x as u32, y as u32, sampler.next_2d());
                    let l = self.trace_path(o, d, &mut sampler, tau_n);
                    *out = if l.is_finite() {
                        l
                    } else {
                        invalid += 1;
                        Vec3::ZERO
                    };
                }
                if invalid > 0 {
                    self.invalid_samples.fetch_add(invalid, Ordering::Relaxed);
                }
                self.flush_ray_count();
            });
    }

    /// Replaces NaN and infinite estimates by zero and counts them.
    fn count_invalid(&self, estimates: &mut [Vec3]) {
        let mut invalid = 0;
        for e in estimates.iter_mut().filter(|e| !e.is_finite()) {
            *e = Vec3::ZERO;
            invalid += 1;
        }
        if invalid > 0 {
            self.invalid_samples.fetch_add(invalid, Ordering::Relaxed);
        }
    }

    /// Renders iterations `first..first + count` into `film`.
    pub fn render(&self, film: &mut Film, first: u64, count: u64) {
        let mut estimates = vec![Vec3::ZERO; film.width() as usize * film.height() as usize];
        for n in first..first + count {
            self.render_iteration(n, &mut estimates);
            film.add_iteration(&estimates);
        }
    }
}
