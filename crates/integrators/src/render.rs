//! The renderer: a scene prepared for ray queries and light sampling, and
//! one iteration of the configured algorithm over the image.

use std::cell::Cell;
use std::fmt::Write as _;
use std::sync::atomic::{AtomicU64, Ordering};

use accel::{Bvh, Hit};
use glam::{Vec2, Vec3};
use rayon::prelude::*;
use regularization::tau::{alpha_cap, alpha_tau};
use regularization::{Lobe, Mode};
use scene::{Scene, SceneFeatures};

use crate::camera::CameraRays;
use crate::config::{Algorithm, RenderConfig, Strategies, mode_name};
use crate::film::Film;
use crate::geometry::SurfacePoint;
use crate::lights::Lights;
use crate::sampler::Sampler;

/// The width of one pixel's footprint at the median distance of the
/// surfaces seen through a grid of pixel centres: a pixel subtends
/// 1 / image_plane_distance radians (the image plane is in pixel units).
fn pixel_footprint(bvh: &Bvh, camera: &CameraRays) -> f32 {
    let res = camera.camera().resolution;
    let mut distances: Vec<f32> = (0..FOOTPRINT_GRID * FOOTPRINT_GRID)
        .filter_map(|i| {
            let (gx, gy) = (i % FOOTPRINT_GRID, i / FOOTPRINT_GRID);
            let x = ((2 * gx + 1) * res.x) / (2 * FOOTPRINT_GRID);
            let y = ((2 * gy + 1) * res.y) / (2 * FOOTPRINT_GRID);
            let (o, d) = camera.ray(x, y, Vec2::splat(0.5));
            bvh.intersect(o, d, f32::INFINITY).map(|hit| hit.t)
        })
        .collect();
    if distances.is_empty() {
        return f32::INFINITY;
    }
    let mid = distances.len() / 2;
    let (_, median, _) = distances.select_nth_unstable_by(mid, f32::total_cmp);
    *median / camera.image_plane_distance()
}

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
    /// Width of a pixel's footprint at the median distance of the surfaces
    /// the camera sees (infinity when it sees none): the scale of what the
    /// image resolves, which bounds the merge radius.
    pub(crate) pixel_footprint: f32,
    /// The mean pixel value (largest RGB component) of a small path-traced
    /// preview: the scale of the shadow-ray roulette threshold (0 when the
    /// algorithm does not use the roulette).
    pub(crate) pixel_scale: f32,
}

/// Camera rays per image side that estimate the distance of visible surfaces.
const FOOTPRINT_GRID: u32 = 16;

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
        let pixel_footprint = pixel_footprint(&bvh, &camera);
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
            pixel_footprint,
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

    /// A human-readable account of what will run and why (for `--explain`).
    pub fn explain(&self) -> String {
        let c = &self.config;
        let f = &self.features;
        let mut s = String::new();
        let _ = writeln!(
            s,
            "integrator:       {} (max depth {}, seed {})",
            c.algorithm, c.max_depth, c.seed
        );
        let strategies = match (c.algorithm, c.strategies) {
            (Algorithm::Pt, Strategies::Mis) => {
                "next-event estimation + BSDF sampling, power-heuristic MIS".to_owned()
            }
            (Algorithm::Pt, Strategies::NeeOnly) => "next-event estimation only".to_owned(),
            (Algorithm::Pt, Strategies::BsdfOnly) => "BSDF sampling only".to_owned(),
            _ => {
                let t = self.techniques();
                let mut list = Vec::new();
                if t.connections {
                    list.push(
                        "emitter hits, next-event estimation, vertex connections, light tracing",
                    );
                }
                if t.merging {
                    list.push("vertex merging");
                }
                if t.virtual_merges && self.regularization_matters(c.regularization.tau_at(1)) {
                    list.push("virtual merges (supp. §6)");
                }
                format!(
                    "one light subpath per pixel; {}; balance-heuristic VCM MIS",
                    list.join(", ")
                )
            }
        };
        let _ = writeln!(
            s,
            "strategies:       {strategies}; Russian roulette from depth {}",
            crate::pt::ROULETTE_DEPTH
        );
        if self.pixel_scale > 0.0 {
            let _ = writeln!(
                s,
                "shadow roulette:  next-event, connection and light-tracing contributions below {:.4e} ({} x the preview's mean pixel value {:.4e}) keep their shadow ray with probability contribution / threshold (Veach 1997, §10.4.1)",
                c.shadow_roulette * self.pixel_scale,
                c.shadow_roulette,
                self.pixel_scale
            );
        }
        if self.techniques().merging && c.algorithm != Algorithm::Pt {
            let r1 = self.merge_radius(1);
            let rule = if r1 < c.radius_factor * self.lights.scene_radius() {
                format!(
                    "capped at {} pixel footprints; {} x scene radius would be {:.4e}",
                    crate::bidir::MAX_MERGE_RADIUS_PIXELS,
                    c.radius_factor,
                    c.radius_factor * self.lights.scene_radius()
                )
            } else {
                format!("{} x scene radius", c.radius_factor)
            };
            let _ = writeln!(
                s,
                "merge radius:     r_1 = {r1:.4e} ({rule}; {:.2} pixel footprints), r_N = r_1 N^(({} - 1)/2)",
                r1 / self.pixel_footprint,
                c.radius_alpha
            );
        } else if c.algorithm == Algorithm::Vcm {
            let _ = writeln!(
                s,
                "merging:          left out: no near-specular or refractive surface, so connections sample every path well (VCM runs as BPT)"
            );
        }
        let r = &c.regularization;
        let _ = write!(s, "regularization:   {}", mode_name(r.mode));
        if r.mode != Mode::Off {
            let _ = write!(
                s,
                ", tau_0 = {} ({}), alpha_tau at N = 1: {:.4}",
                r.schedule.tau_0(),
                if r.progressive {
                    "progressive: tau_N = tau(r_0 N^(-1/6))"
                } else {
                    "fixed"
                },
                alpha_tau(Lobe::Reflection, r.tau_at(1))
            );
            if !self.regularization_matters(r.tau_at(1)) {
                let _ = write!(
                    s,
                    "\n                  inactive: no surface is sharper than alpha_tau (smallest alpha {}), so the render equals the unregularized one",
                    f.smallest_alpha.map_or("none".into(), |a| a.to_string())
                );
            }
        }
        let _ = writeln!(s);
        let _ = writeln!(
            s,
            "left out:         {}{}{}",
            if f.transmission {
                ""
            } else {
                "refraction code (no dielectric); "
            },
            if f.textured {
                ""
            } else {
                "texture lookups (no textures); "
            },
            if f.environment {
                ""
            } else {
                "environment lookups (no environment light)"
            },
        );
        if self.lights.is_empty() {
            let _ = writeln!(
                s,
                "warning:          the scene has no light; the image will be black"
            );
        }
        s
    }
}
