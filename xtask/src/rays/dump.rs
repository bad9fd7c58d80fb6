//! `cargo xtask rays dump`: a scene's triangles in world space and three
//! ray sets made the way the path tracer makes its rays, for timing ray
//! queries alone (`rays bench`) and against another ray tracer on exactly
//! the same input.
//!
//! The scene goes through the renderer's own loader and
//! `integrators::context::SceneContext`, so the mesh is what the renderer
//! traces and the rays use its camera, surface points, ray-origin offsets
//! and light sampling:
//! - camera: one ray per pixel through its centre, from the camera (or its
//!   near plane);
//! - diffuse: at each camera ray's hit, a cosine-distributed direction
//!   about the geometric normal on the camera's side, from the offset
//!   origin the renderer would start it at;
//! - shadow: at each such hit, a light sample (the renderer's light
//!   selection and sampling) on the camera's side of the surface, as the
//!   path tracer's next-event estimation traces it: from the offset origin
//!   to the light point offset off the light's surface, `t_max` = 1 (to
//!   infinity for lights at infinity).

use std::fs;
use std::path::{Path, PathBuf};

use glam::{UVec2, Vec2, Vec3};
use integrators::RenderConfig;
use integrators::context::SceneContext;
use integrators::geometry::Frame;
use integrators::lights::cosine_hemisphere;
use scene::{LoadOptions, Scene};
use serde_json::json;

use super::files::{self, INDICES_FILE, MANIFEST_FILE, Ray, SETS, VERTICES_FILE};
use crate::stability::Rng;

/// Largest f32 below 1: uniforms for the samplers stay in [0, 1).
const ONE_MINUS_EPSILON: f32 = 1.0 - f32::EPSILON / 2.0;

/// Where the geometry comes from.
#[derive(Clone, Debug, PartialEq)]
pub(super) enum Source {
    /// A scene file or folder the renderer loads.
    Scene(PathBuf),
    /// The generated height field of `cargo xtask bench --scaling` with
    /// about this many triangles (written under the dump folder first).
    HeightField(u64),
}

/// What `rays dump` writes.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct DumpOptions {
    pub source: Source,
    /// Image size overriding the scene's (one camera ray per pixel).
    pub resolution: Option<UVec2>,
    /// Seed of the diffuse directions and light samples.
    pub seed: u64,
    /// Output folder.
    pub out: PathBuf,
}

/// The three ray sets of a scene, in [`SETS`] order.
pub(super) struct RaySets {
    pub camera: Vec<Ray>,
    pub diffuse: Vec<Ray>,
    pub shadow: Vec<Ray>,
}

/// Runs `rays dump`: loads the scene, makes the rays, writes the files and
/// says what it wrote.
pub(super) fn run(options: &DumpOptions) -> Result<(), String> {
    fs::create_dir_all(&options.out)
        .map_err(|e| format!("cannot create {}: {e}", options.out.display()))?;
    let path = match &options.source {
        Source::Scene(path) => path.clone(),
        Source::HeightField(n) => crate::bench::height_field_obj_scene(&options.out, *n)?,
    };
    let scene = load(&path, options.resolution)?;
    let ctx = SceneContext::new(scene, RenderConfig::default());
    let sets = ray_sets(&ctx, options.seed);
    let scene = &ctx.scene;
    files::write_mesh(&options.out, &scene.positions, &scene.triangles)?;
    let by_name = [&sets.camera, &sets.diffuse, &sets.shadow];
    for ((name, _), rays) in SETS.iter().zip(by_name) {
        files::write_rays(&options.out, name, rays)?;
    }
    let res = scene.camera.resolution;
    let manifest = json!({
        "written_by": "cargo xtask rays dump",
        "scene": path.display().to_string(),
        "resolution": [res.x, res.y],
        "seed": options.seed,
        "vertices": scene.positions.len(),
        "triangles": scene.triangles.len(),
        "vertex_file": VERTICES_FILE,
        "index_file": INDICES_FILE,
        "sets": SETS.iter().zip(by_name).map(|((name, query), rays)| json!({
            "name": name,
            "file": files::ray_file(name),
            "query": query.name(),
            "rays": rays.len(),
        })).collect::<Vec<_>>(),
    });
    let text = serde_json::to_string_pretty(&manifest).map_err(|e| e.to_string())?;
    crate::write_file(&options.out.join(MANIFEST_FILE), text)?;
    println!(
        "{}: {} triangles, {}x{}; rays: {} camera, {} diffuse, {} shadow; written to {}",
        path.display(),
        scene.triangles.len(),
        res.x,
        res.y,
        sets.camera.len(),
        sets.diffuse.len(),
        sets.shadow.len(),
        options.out.display()
    );
    Ok(())
}

/// The scene at `path`, refused when the renderer's queries on it would
/// differ from plain triangle queries: analytic spheres (not in the mesh
/// files) or alpha-tested materials (which the renderer's queries pass
/// through).
pub(super) fn load(path: &Path, resolution: Option<UVec2>) -> Result<Scene, String> {
    let options = LoadOptions {
        resolution,
        ..Default::default()
    };
    let scene =
        scene::load(path, &options).map_err(|e| format!("cannot load {}: {e}", path.display()))?;
    if !scene.spheres.is_empty() {
        return Err(format!(
            "{}: has {} analytic spheres; a ray dump holds triangles only",
            path.display(),
            scene.spheres.len()
        ));
    }
    let cut_out = |&m: &u32| !scene.materials[m as usize].maps.alpha.is_opaque();
    if scene.triangle_materials.iter().any(cut_out) {
        return Err(format!(
            "{}: has alpha-tested materials, which the renderer's ray queries pass through; \
             a ray dump holds opaque triangles only",
            path.display()
        ));
    }
    Ok(scene)
}

/// The ray sets of the scene of `ctx` (see the module documentation),
/// random numbers from `seed`. Pixels in row-major order; a pixel whose
/// camera ray misses has no diffuse and no shadow ray.
pub(super) fn ray_sets(ctx: &SceneContext, seed: u64) -> RaySets {
    let mut rng = Rng::new(seed);
    let mut uniform = || (rng.uniform() as f32).min(ONE_MINUS_EPSILON);
    let res = ctx.scene.camera.resolution;
    let mut sets = RaySets {
        camera: Vec::with_capacity((res.x * res.y) as usize),
        diffuse: Vec::new(),
        shadow: Vec::new(),
    };
    for y in 0..res.y {
        for x in 0..res.x {
            let camera = camera_ray(ctx, x, y);
            sets.camera.push(camera);
            let Some(hit) = ctx
                .bvh
                .intersect(camera.origin, camera.direction, camera.t_max)
            else {
                continue;
            };
            let point = ctx.surface_point(&hit, camera.origin, camera.direction);
            // The geometric normal on the camera's side: where a reflected
            // ray leaves and where a light must be to light the point.
            let n = point.ng_towards(-camera.direction);
            let w =
                Frame::from_normal(n).to_world(cosine_hemisphere(Vec2::new(uniform(), uniform())));
            sets.diffuse.push(Ray {
                origin: point.spawn_origin(w),
                direction: w,
                t_max: f32::INFINITY,
            });
            let u_select = uniform();
            let u_light = Vec2::new(uniform(), uniform());
            let Some(ls) = ctx.lights.sample(&ctx.scene, point.p, u_select, u_light) else {
                continue;
            };
            if ls.wi.dot(n) <= 0.0 {
                continue;
            }
            let origin = point.spawn_origin(ls.wi);
            // As `integrators::nee::visible` traces it.
            sets.shadow.push(match ls.point {
                Some(lp) => {
                    let end = if lp.n == Vec3::ZERO {
                        lp.p
                    } else {
                        let towards = if lp.n.dot(-ls.wi) > 0.0 { lp.n } else { -lp.n };
                        lp.error.offset(lp.p, towards)
                    };
                    Ray {
                        origin,
                        direction: end - origin,
                        t_max: 1.0,
                    }
                }
                None => Ray {
                    origin,
                    direction: ls.wi,
                    t_max: f32::INFINITY,
                },
            });
        }
    }
    sets
}

/// The camera ray through the centre of pixel (`x`, `y`), from the near
/// plane if the camera has one (the renderer's camera rays see only what
/// lies beyond it).
fn camera_ray(ctx: &SceneContext, x: u32, y: u32) -> Ray {
    let (origin, direction) = ctx.camera.ray(x, y, Vec2::splat(0.5));
    Ray {
        origin: origin + direction * ctx.camera.near_t(direction),
        direction,
        t_max: f32::INFINITY,
    }
}
