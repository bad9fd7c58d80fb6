//! The scene as every integrator sees it: geometry ready for ray queries,
//! the lights, the camera and the render settings, each prepared once when
//! a [`crate::Renderer`] is made, and the ray queries themselves (counted).

use std::cell::Cell;
use std::sync::atomic::{AtomicU64, Ordering};

use accel::{BatchRay, BuildOptions, Bvh, Hit, NO_SURFACE};
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
    /// Its triangles and spheres for ray queries (spheres numbered after
    /// the triangles).
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
    /// Per triangle: its material has an alpha mode other than opaque
    /// (false for every sphere: spheres are opaque, their materials' alpha
    /// is not applied). Empty when no triangle has one: ray queries then
    /// skip the test.
    alpha_tested: Vec<bool>,
    /// Some used material has a normal or bump map.
    normal_mapped: bool,
    /// Rays traced by finished tasks (closest-hit and shadow rays).
    rays: AtomicU64,
}

impl SceneContext {
    /// Prepares `scene` (builds the BVH on the current rayon pool).
    pub fn new(scene: Scene, config: RenderConfig) -> Self {
        let spheres: Vec<accel::Sphere> = scene
            .spheres
            .iter()
            .map(|s| accel::Sphere {
                center: s.center,
                radius: s.radius,
            })
            .collect();
        let bvh = Bvh::build_indexed(
            &scene.positions,
            &scene.triangles,
            &spheres,
            BuildOptions::default(),
        );
        let bounds = BoundingSphere::of(&scene);
        let lights = Lights::new(&scene, bounds);
        // Only the path tracer's MIS knows the receiver of an emitter hit.
        let lights = if config.algorithm == crate::config::Algorithm::Pt {
            lights.with_sphere_cones(&scene)
        } else {
            lights
        };
        let camera = CameraRays::new(scene.camera);
        let merge_radius = MergeRadius::new(
            config.radius_factor,
            bounds.radius,
            pixel_footprint(&bvh, &camera),
            config.radius_alpha,
        );
        let vertex_scales = (0..scene.triangles.len())
            .map(|i| vertex_scale(&scene.triangle(i)))
            .collect();
        let geometric_normals = (0..scene.triangles.len())
            .map(|i| scene.geometric_normal(i))
            .collect();
        let material_of = |&m: &u32| &scene.materials[m as usize];
        let mut alpha_tested: Vec<bool> = scene
            .triangle_materials
            .iter()
            .map(|m| !material_of(m).maps.alpha.is_opaque())
            .collect();
        if alpha_tested.contains(&true) {
            alpha_tested.resize(scene.triangles.len() + scene.spheres.len(), false);
        } else {
            alpha_tested = Vec::new();
        }
        let normal_mapped = scene
            .triangle_materials
            .iter()
            .chain(scene.spheres.iter().map(|s| &s.material))
            .any(|m| material_of(m).maps.normal.is_some());
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
            alpha_tested,
            normal_mapped,
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
        let sampler = Sampler::new(self.config.seed, n, pixel);
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
    /// Surfaces cut out by their alpha are passed through
    /// ([`SceneContext::meets`]).
    #[inline]
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<Hit> {
        self.intersect_leaving(origin, direction, t_max, NO_SURFACE)
    }

    /// [`SceneContext::intersect`] of a ray leaving triangle `surface`
    /// (`accel::Bvh::intersect_leaving`: the same hit, without testing the
    /// triangle it leaves).
    #[inline]
    pub fn intersect_leaving(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        surface: u32,
    ) -> Option<Hit> {
        THREAD_RAYS.set(THREAD_RAYS.get() + 1);
        if self.alpha_tested.is_empty() {
            self.bvh
                .intersect_leaving(origin, direction, t_max, surface)
        } else {
            self.intersect_alpha(origin, direction, t_max)
        }
    }

    /// [`SceneContext::intersect`] of a camera ray (from the camera position):
    /// the closest hit beyond the near plane (`CameraRays::near_t`), with
    /// `t` still measured from `origin`, so that distances to the camera
    /// (MIS, light tracing) stay those of the pinhole.
    pub fn intersect_camera_ray(&self, origin: Vec3, direction: Vec3) -> Option<Hit> {
        let hit = self.intersect(origin, direction, f32::INFINITY);
        self.beyond_near_plane(origin, direction, hit)
    }

    /// The camera ray's hit given its first one, `hit` (from `origin`):
    /// that one if it lies beyond the near plane, else the closest hit
    /// from the near plane on ([`SceneContext::intersect_camera_ray`]).
    #[inline]
    fn beyond_near_plane(&self, origin: Vec3, direction: Vec3, hit: Option<Hit>) -> Option<Hit> {
        let t_near = self.camera.near_t(direction);
        match hit {
            Some(h) if h.t < t_near => self
                .intersect(origin + direction * t_near, direction, f32::INFINITY)
                .map(|h| Hit {
                    t: h.t + t_near,
                    ..h
                }),
            other => other,
        }
    }

    /// The closest hit of every ray of `rays` into `hits`, as one batch
    /// query (`accel::Bvh::intersect_batch`: for a ray skipping one
    /// triangle twice, [`SceneContext::intersect_leaving`]'s hit, in
    /// packets of rays in small scenes), counted like it.
    pub fn intersect_batch(&self, rays: &[BatchRay], hits: &mut [Option<Hit>]) {
        THREAD_RAYS.set(THREAD_RAYS.get() + rays.len() as u64);
        if self.alpha_tested.is_empty() {
            self.bvh.intersect_batch(rays, hits);
        } else {
            for (r, hit) in rays.iter().zip(hits) {
                *hit = self.intersect_alpha(r.origin, r.direction, r.t_max);
            }
        }
    }

    /// [`SceneContext::intersect_camera_ray`] of every ray of `rays` (from
    /// the camera position) into `hits`, as one batch query.
    pub fn intersect_camera_batch(&self, rays: &[BatchRay], hits: &mut [Option<Hit>]) {
        self.intersect_batch(rays, hits);
        for (ray, hit) in rays.iter().zip(hits) {
            *hit = self.beyond_near_plane(ray.origin, ray.direction, *hit);
        }
    }

    /// [`SceneContext::occluded_between`] of every ray of `rays` (between
    /// its `skip` triangles) into `occluded`, as one batch query
    /// (`accel::Bvh::occluded_batch`).
    pub fn occluded_batch(&self, rays: &[BatchRay], occluded: &mut [bool]) {
        THREAD_RAYS.set(THREAD_RAYS.get() + rays.len() as u64);
        if self.alpha_tested.is_empty() {
            self.bvh.occluded_batch(rays, occluded);
        } else {
            for (r, occluded) in rays.iter().zip(occluded) {
                *occluded = self.occluded_alpha(r.origin, r.direction, r.t_max);
            }
        }
    }

    /// [`SceneContext::intersect`] with the alpha test (out of line: scenes
    /// without alpha keep the plain query inlined).
    #[inline(never)]
    fn intersect_alpha(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<Hit> {
        self.bvh
            .intersect_where(origin, direction, t_max, |triangle, b1, b2| {
                self.meets(origin, direction, triangle, b1, b2)
            })
    }

    /// Whether anything lies along `origin + t direction`, t in (0, t_max)
    /// (shadow rays), counted like [`SceneContext::intersect`].
    #[inline]
    pub fn occluded(&self, origin: Vec3, direction: Vec3, t_max: f32) -> bool {
        self.occluded_between(origin, direction, t_max, [NO_SURFACE; 2])
    }

    /// [`SceneContext::occluded`] of a segment between triangles `surfaces`
    /// (`accel::Bvh::occluded_between`: the same answer, without testing
    /// the triangles its ends lie on).
    #[inline]
    pub fn occluded_between(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        surfaces: [u32; 2],
    ) -> bool {
        THREAD_RAYS.set(THREAD_RAYS.get() + 1);
        if self.alpha_tested.is_empty() {
            self.bvh
                .occluded_between(origin, direction, t_max, surfaces)
        } else {
            self.occluded_alpha(origin, direction, t_max)
        }
    }

    /// [`SceneContext::occluded`] with the alpha test (out of line).
    #[inline(never)]
    fn occluded_alpha(&self, origin: Vec3, direction: Vec3, t_max: f32) -> bool {
        self.bvh
            .occluded_where(origin, direction, t_max, |triangle, b1, b2| {
                self.meets(origin, direction, triangle, b1, b2)
            })
    }

    /// Whether the ray `origin + t direction` meets triangle `triangle` at
    /// barycentrics (b1, b2), given its material's alpha (glTF 2.0 spec,
    /// 3.9.4): always for opaque materials; where alpha >= alphaCutoff for
    /// MASK; with probability alpha for BLEND, decided by a hash of the ray
    /// and the triangle (stochastic alpha as pbrt-v4's
    /// `GeometricPrimitive::Intersect` does it with `HashFloat(ray.o, ray.d)`):
    /// every query of the same ray decides the same, so a shadow ray and a
    /// path ray see the surface with the same probability, and light
    /// transport through it is alpha x opaque + (1 - alpha) x absent in
    /// expectation.
    #[inline]
    pub fn meets(&self, origin: Vec3, direction: Vec3, triangle: u32, b1: f32, b2: f32) -> bool {
        let i = triangle as usize;
        if !self.alpha_tested[i] {
            return true;
        }
        let uvs = self.scene.triangle_uvs(i);
        let uv = uvs[0] * (1.0 - b1 - b2) + uvs[1] * b1 + uvs[2] * b2;
        let material = &self.scene.materials[self.scene.triangle_materials[i] as usize];
        let coverage = material.maps.alpha.coverage(uv, &self.scene.textures);
        if coverage >= 1.0 {
            true
        } else if coverage <= 0.0 {
            false
        } else {
            ray_hash(origin, direction, triangle) < coverage
        }
    }

    /// The surface point of a hit of the ray `origin + t direction` (its
    /// shading normal perturbed by the material's normal map, if any). A
    /// sphere's point is recomputed from the ray in f64 and reprojected
    /// onto the sphere (`accel::Sphere::hit_point`).
    #[inline]
    pub fn surface_point(&self, hit: &Hit, origin: Vec3, direction: Vec3) -> SurfacePoint {
        if let Some(j) = self.bvh.sphere_of(hit.primitive) {
            return self.sphere_point(j, hit, origin, direction);
        }
        let i = hit.primitive as usize;
        let point = SurfacePoint::new(
            &self.scene,
            self.geometric_normals[i],
            self.vertex_scales[i],
            hit,
        );
        if self.normal_mapped
            && let Some(map) = &self.scene.materials[point.material as usize].maps.normal
        {
            return crate::normal_map::apply(&self.scene, map, &point, hit.b1, hit.b2);
        }
        point
    }

    /// [`SceneContext::surface_point`] on sphere `j` (out of line: triangle
    /// scenes keep the triangle path inlined).
    #[inline(never)]
    fn sphere_point(&self, j: usize, hit: &Hit, origin: Vec3, direction: Vec3) -> SurfacePoint {
        let sphere = &self.scene.spheres[j];
        let (p, n, error) = self.bvh.spheres()[j].hit_point(origin, direction, hit.t);
        let material = &self.scene.materials[sphere.material as usize];
        let point =
            SurfacePoint::on_sphere(sphere, hit.primitive, p, n, error, material.reads_uv());
        if self.normal_mapped
            && let Some(map) = &material.maps.normal
        {
            return crate::normal_map::apply_on_sphere(&self.scene, map, &point, sphere, n);
        }
        point
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
    /// The emissive texture, if any, is read at the point's uv.
    #[inline]
    pub fn emitted(&self, point: &SurfacePoint, wi: Vec3) -> Option<Vec3> {
        let material = &self.scene.materials[point.material as usize];
        if !(material.is_emissive() && point.n_winding.dot(wi) > 0.0) {
            return None;
        }
        Some(match material.maps.emission {
            None => material.emission,
            Some(_) => material.emission_at(point.uv, &self.scene.textures),
        })
    }
}

/// A uniform number in [0, 1) from the bits of a ray and a triangle id:
/// the random decision of stochastic alpha, a pure function of its
/// arguments (SplitMix64's finaliser, Steele et al. 2014, mixes the words).
fn ray_hash(origin: Vec3, direction: Vec3, triangle: u32) -> f32 {
    let mix = |mut z: u64| {
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    };
    let words = [
        origin.x,
        origin.y,
        origin.z,
        direction.x,
        direction.y,
        direction.z,
    ];
    let mut h = mix(u64::from(triangle) ^ 0x9e37_79b9_7f4a_7c15);
    for w in words {
        h = mix(h ^ u64::from(w.to_bits()));
    }
    // The top 24 bits as a float in [0, 1).
    (h >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}
