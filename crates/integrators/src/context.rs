//! The scene as every integrator sees it: geometry ready for ray queries,
//! the lights, the camera and the render settings, each prepared once when
//! a [`crate::Renderer`] is made, and the ray queries themselves (counted).

use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

use accel::{Bvh, Hit};
use glam::Vec3;
use regularization::tau::{alpha_cap, alpha_tau};
use regularization::{Lobe, Mode};
use scene::{Scene, SceneFeatures};

use crate::camera::CameraRays;
use crate::config::RenderConfig;
use crate::geometry::{BoundingSphere, SurfacePoint, vertex_scale};
use crate::lights::Lights;
use crate::merge_radius::{MergeRadius, pixel_footprint};
use crate::sampler::Sampler;
use crate::walk::Walk;

thread_local! {
    /// Rays traced by this thread since its count was last added to a
    /// context's total: a plain per-thread counter costs nothing next to a
    /// traversal, where one shared atomic would bounce between cores.
    static THREAD_RAYS: Cell<u64> = const { Cell::new(0) };
}

/// A scene prepared for rendering with one configuration: what every
/// integrator reads and none of them changes.
pub struct SceneContext {
    /// The scene.
    pub scene: Scene,
    /// Its triangles for ray queries.
    pub bvh: Bvh,
    /// Light selection and sampling.
    pub lights: Lights,
    /// Camera rays, projection and importance.
    pub camera: CameraRays,
    /// What the scene contains.
    pub features: SceneFeatures,
    /// The render settings.
    pub config: RenderConfig,
    /// The merge radius of every iteration (PPM, VCM).
    pub merge_radius: MergeRadius,
    /// Unit geometric normal of each triangle ([`Scene::geometric_normal`]):
    /// every surface point needs one, and computing it (in f64, see
    /// `scene::triangle_cross`) cost 5 % of a path-traced iteration.
    geometric_normals: Vec<Vec3>,
    /// [`vertex_scale`] of each triangle, for ray-origin offsets: computed
    /// once, like the normals, not at every hit.
    vertex_scales: Vec<f32>,
    /// Rays traced by finished tasks (closest-hit and shadow rays).
    rays: AtomicU64,
}

impl SceneContext {
    /// Prepares `scene` (builds the BVH on the current rayon pool).
    pub fn new(scene: Scene, config: RenderConfig) -> Self {
        let bvh = Bvh::build(&scene.triangles);
        let bounds = BoundingSphere::of(&scene);
        let lights = Lights::new(&scene, bounds);
        let camera = CameraRays::new(scene.camera);
        let merge_radius = MergeRadius::new(
            config.radius_factor,
            bounds.radius,
            pixel_footprint(&bvh, &camera),
            config.radius_alpha,
        );
        let vertex_scales = scene.triangles.iter().map(vertex_scale).collect();
        let geometric_normals = (0..scene.triangles.len())
            .map(|i| scene.geometric_normal(i))
            .collect();
        Self {
            features: SceneFeatures::of(&scene),
            scene,
            bvh,
            lights,
            camera,
            config,
            merge_radius,
            geometric_normals,
            vertex_scales,
            rays: AtomicU64::new(0),
        }
    }

    /// Image size (width, height).
    pub fn resolution(&self) -> (u32, u32) {
        let r = self.scene.camera.resolution;
        (r.x, r.y)
    }

    /// The camera subpath of pixel (`x`, `y`) in iteration `n`: its random
    /// stream and its walk from the camera.
    #[inline]
    pub fn camera_path(&self, n: u64, x: u32, y: u32) -> (Sampler, Walk) {
        let pixel = u64::from(y) * u64::from(self.scene.camera.resolution.x) + u64::from(x);
        let mut sampler = Sampler::new(self.config.seed, n, pixel);
        let (origin, direction) = self.camera.ray(x, y, sampler.pixel_position());
        (sampler, Walk::new(origin, direction))
    }

    /// [`SceneContext::camera_path`] of pixel `index` (row-major).
    #[inline]
    pub fn camera_path_of(&self, n: u64, index: usize) -> (Sampler, Walk) {
        let width = self.scene.camera.resolution.x as usize;
        self.camera_path(n, (index % width) as u32, (index / width) as u32)
    }

    /// Closest hit along `origin + t direction`, t in (0, t_max): every
    /// integrator's ray query, counted for [`SceneContext::rays_traced`].
    #[inline]
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<Hit> {
        THREAD_RAYS.set(THREAD_RAYS.get() + 1);
        self.bvh.intersect(origin, direction, t_max)
    }

    /// Whether anything lies along `origin + t direction`, t in (0, t_max)
    /// (shadow rays), counted like [`SceneContext::intersect`].
    #[inline]
    pub fn occluded(&self, origin: Vec3, direction: Vec3, t_max: f32) -> bool {
        THREAD_RAYS.set(THREAD_RAYS.get() + 1);
        self.bvh.occluded(origin, direction, t_max)
    }

    /// The surface point of a hit.
    #[inline]
    pub fn surface_point(&self, hit: &Hit) -> SurfacePoint {
        let i = hit.triangle as usize;
        SurfacePoint::new(
            &self.scene,
            self.geometric_normals[i],
            self.vertex_scales[i],
            hit,
        )
    }

    /// Adds this thread's ray count to the total; called at the end of every
    /// parallel task, so that the total is exact after each iteration.
    pub fn flush_ray_count(&self) {
        let n = THREAD_RAYS.replace(0);
        if n > 0 {
            self.rays.fetch_add(n, Ordering::Relaxed);
        }
    }

    /// Runs `f` without counting its rays (previews that are not part of
    /// the render).
    pub fn uncounted<T>(&self, f: impl FnOnce() -> T) -> T {
        let before = THREAD_RAYS.get();
        let value = f();
        THREAD_RAYS.set(before);
        value
    }

    /// Rays traced so far (camera, light, continuation and shadow rays).
    pub fn rays_traced(&self) -> u64 {
        self.rays.load(Ordering::Relaxed)
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
    /// ones and cost the same (pay only for what a scene uses).
    pub fn effective_mode(&self, tau_n: f64) -> Mode {
        if self.regularization_matters(tau_n) {
            self.config.regularization.mode
        } else {
            Mode::Off
        }
    }

    /// The light emitted by the surface at `point` towards `wi` (emitters
    /// emit on the side their winding faces), if any.
    #[inline]
    pub fn emitted(&self, point: &SurfacePoint, wi: Vec3) -> Option<Vec3> {
        let emission = self.scene.materials[point.material as usize].emission;
        (emission.max_element() > 0.0 && point.n_winding.dot(wi) > 0.0).then_some(emission)
    }
}
