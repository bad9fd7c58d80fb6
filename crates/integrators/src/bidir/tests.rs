//! The MIS weights of the techniques of the bidirectional core partition
//! unity on the paths the integrator builds (SPEC §6: in `off` and `uniform`
//! modes, with and without virtual merges; in `unsampleable` mode for BPT,
//! whose techniques that would disagree on a vertex are left out; in
//! `selective` mode the two subpaths regularize a vertex differently, so
//! the techniques estimate different integrands and no partition is
//! expected).
//!
//! Camera subpaths are traced as `Iteration::trace_camera_path` traces them
//! and completed the two ways the integrator completes them: by hitting an
//! area emitter, and by next-event estimation at a non-specular vertex. Each
//! complete path x_0 (light) ... camera is then taken apart into every
//! (light subpath, camera subpath) split: both subpaths' recursions run
//! along the path's vertices as the integrator runs them (same vertices,
//! regularization rules and `mis` calls), and each technique's weight is
//! computed with the integrator's calls and arguments: emitter hit,
//! next-event estimation, connections, light tracing and merges (a
//! connection's weight includes its virtual merges).
//!
//! Both subpaths take their directions from the vertex positions: the
//! traced rays start at offset origins (`accel::offset_ray_origin`), whose
//! 1e-5 shifts change the pdf of a sharp regularized lobe by ~1e-4 between
//! two subpaths, which would hide small partition errors.

use glam::{UVec2, Vec2, Vec3};
use microfacet::TransportMode;
use mis::{EmitterKind, Scatter, SubpathRay, VertexPdfs};
use regularization::{Mode, PathRegularization, Subpath};

use super::light_path::{BoundedHistory, LightVertex};
use super::{Bidirectional, Iteration};
use crate::config::{Algorithm, Regularization, RenderConfig};
use crate::context::SceneContext;
use crate::geometry::SurfacePoint;
use crate::integrator::Stop;
use crate::lights::EmitterPdfs;
use crate::nee;
use crate::vertex::PathVertex;

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
    let r = context("glossy-caustic", Algorithm::Bpt, Mode::Off, false);
    let it = Bidirectional::new(&r).iteration(&r, 1, Stop::NEVER);
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
        let vertex = PathVertex::new(&r.scene, point, wi, throughput, regularization);
        let light = LightVertex::new(&vertex, state, 1, BoundedHistory::default());
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
            primitive: 0,
            material: material(true),
            error: crate::geometry::PointError::Vertices(1.0),
        };
        for wi in sphere_directions(64) {
            let (vertex, light) = light_vertex(point, wi);
            for wo in sphere_directions(256) {
                let value =
                    (vertex.throughput * vertex.eval(wo, TransportMode::Importance)).max_element();
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
fn complete_paths(it: &Iteration, index: usize) -> Vec<CompletePath> {
    let r = it.ctx;
    let (sampler, walk) = r.camera_path_of(it.n, index);
    // The paths' vertices only: no throughput, no roulette.
    let (mut origin, mut direction) = (walk.origin, walk.direction);
    let mut regularization = it.path_regularization(Subpath::Camera);
    let mut camera: Vec<SurfacePoint> = Vec::new();
    let mut paths = Vec::new();
    for length in 1..=r.config.max_depth {
        let Some(hit) = r.intersect(origin, direction, f32::INFINITY) else {
            break;
        };
        let point = r.surface_point(&hit, origin, direction);
        let vertex = PathVertex::new(&r.scene, point, -direction, Vec3::ONE, regularization);
        regularization = vertex.regularization;
        let emission = r.scene.materials[point.material as usize].emission;
        if let Some(&last) = camera.last()
            && emission.max_element() > 0.0
            && point.n_winding.dot(-direction) > 0.0
        {
            let d = last.p - point.p;
            let cos = point.n_winding.dot(d.normalize()).abs();
            let pdfs = r.lights.area_pdfs(point.primitive, cos);
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
        let u = sampler.camera_vertex(length);
        if !vertex.is_specular()
            && let Some(light) = r.lights.choose(&r.scene, u.u_light, u.uv_light)
            && let Some((ls, _)) = nee::light_sample(r, &vertex, &light)
            && nee::visible(r, &vertex, &ls)
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
        let Some(s) = vertex.sample(u.step.u_lobe, u.step.uv_bsdf, TransportMode::Radiance) else {
            break;
        };
        // The recursion below takes a vertex's pdfs towards fixed
        // directions; they must be the ones a sample records.
        if !s.is_specular {
            let (sampled, fixed) = (vertex.scatter_event(&s), scatter_towards(&vertex, s.wo));
            // Re-evaluating at the stored f32 direction moves the pdf by
            // about f32::EPSILON / cos relative (its cosine factors): at
            // grazing directions (cos 1e-4, seen) that exceeds 1e-4.
            let tolerance = 1e-4 + 8.0 * f64::from(f32::EPSILON) / sampled.cos_out.abs();
            let close = |a: f64, b: f64| (a - b).abs() <= tolerance * a.abs().max(b.abs());
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
fn weight_sum(it: &Iteration, path: &CompletePath) -> (f64, bool) {
    let r = it.ctx;
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
        PathVertex::new(&r.scene, path.camera[i - 1], wi, Vec3::ONE, rule)
    };

    // The camera subpath: camera[i - 1] is y_i with its state on arrival.
    let mut ray = SubpathRay::from_camera(&it.mis, f64::from(r.camera.pdf_w(towards(0, 1))));
    let mut rule = it.path_regularization(Subpath::Camera);
    let mut camera = Vec::with_capacity(m);
    for i in 1..=m {
        let y = vertex(i, i - 1, rule);
        rule = y.regularization;
        let mut state = ray.arrive(
            &it.mis,
            distance(i - 1, i),
            f64::from(y.cos(towards(i, i - 1))),
        );
        if y.camera_only {
            state = state.without_opposite_scattering();
        }
        ray = state.scatter(&it.mis, &scatter_towards(&y, towards(i, i + 1)));
        camera.push((y, state));
    }
    let light = &path.light;
    let mut sum = 0.0;
    if light.pdfs.kind.is_hittable() {
        let cos = f64::from(light.pdfs.cos_light);
        let state = ray.arrive(&it.mis, distance(m, m + 1), cos);
        sum += it.mis.emitter_hit_weight(&state, &light.pdfs.hit());
    }

    // The light subpath along the same vertices: light[i - 1] is y_i as
    // the light subpath reaches it, with its state on arrival.
    let mut emission = light.pdfs.emission();
    if light.pdfs.kind == EmitterKind::Point {
        // A point light's next-event pdf carries d^2 (solid angle), its
        // emission's is the bare selection probability.
        emission.direct_pdf_a /= distance(m, m + 1).powi(2);
    }
    let light_rule = it.path_regularization(Subpath::Light);
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
    // `Mode::Unsampleable`: a technique is made only if the camera rule
    // admits its light subpath's vertices before the last, y_j ... y_m
    // (`PathRegularization::admits_light_interior`).
    let bounded: Vec<bool> = light_path
        .iter()
        .map(|(z, _)| light_rule.is_bounded(z.bsdf_original()))
        .collect();
    let interior = |j: usize| bounded[(j - 1).min(m)..].iter().copied();
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
            // (see `Iteration::connect`).
            let (z, light_state) = &light_path[i];
            let end = PathVertex::new(&r.scene, z.point, z.wi, Vec3::ONE, y.regularization);
            if !end.is_specular() && end.regularization.admits_light_interior(interior(i + 2)) {
                let dir = towards(i, i + 1);
                sum += it.mis.connection_weight(
                    light_state,
                    &end.light_end(-dir),
                    camera_state,
                    &y.connection_end(dir),
                    distance(i, i + 1),
                );
            }
        }
        if techniques.merging && y.regularization.admits_light_interior(interior(i + 1)) {
            let (z, light_state) = &light_path[i - 1];
            sum += it
                .mis
                .merge_weight(light_state, camera_state, &y.connection_pdfs(z.wi));
        }
    }
    if techniques.connections {
        // Light tracing from y_1, regularized as seen from the camera
        // (see `Iteration::connect_to_camera`).
        let (z, light_state) = &light_path[0];
        let seen_rule = it.path_regularization(Subpath::Camera);
        let seen = PathVertex::new(&r.scene, z.point, z.wi, Vec3::ONE, seen_rule);
        if !seen.is_specular() && seen.regularization.admits_light_interior(interior(2)) {
            sum += it.mis.light_tracing_weight(
                light_state,
                &seen.light_end(towards(1, 0)),
                f64::from(r.camera.pdf_w(towards(0, 1))),
                distance(0, 1),
            );
        }
    }
    (sum, regularized)
}

/// Where regularization widened a vertex's lobe, its MIS densities are
/// p-hat (paper eq. 13) of the material's own lobe, which the vertex keeps
/// beside the widened one (`PathVertex::bsdf_original`), not the widened
/// lobe's density.
#[test]
fn a_widened_vertex_weighs_with_p_hat_of_the_material_lobe() {
    let r = context("glossy-caustic", Algorithm::Bpt, Mode::Uniform, false);
    let glossy = r
        .scene
        .materials
        .iter()
        .position(|m| m.surface.microfacet().is_some())
        .expect("the scene has a rough conductor") as u32;
    let material_lobe = r.scene.materials[glossy as usize]
        .surface
        .bsdf(Vec2::ZERO, &r.scene.textures);
    let point = SurfacePoint {
        p: Vec3::ZERO,
        n_winding: Vec3::Z,
        ng: Vec3::Z,
        frame: crate::geometry::Frame::from_normal(Vec3::Z),
        uv: Vec2::ZERO,
        primitive: 0,
        material: glossy,
        error: crate::geometry::PointError::Vertices(1.0),
    };
    // tau = 1/sr widens the scene's alpha = 0.02 conductor a great deal.
    let rule = PathRegularization::new(Mode::Uniform, Subpath::Camera, 1.0);
    let wi = Vec3::new(0.3, 0.1, 1.0).normalize();
    let vertex = PathVertex::new(&r.scene, point, wi, Vec3::ONE, rule);
    assert!(vertex.alpha_hat.is_some());
    assert_eq!(*vertex.bsdf_original(), material_lobe);
    assert_ne!(vertex.bsdf, material_lobe);
    let mut unlike_the_widened_pdf = 0;
    for wo in sphere_directions(64).filter(|wo| wo.z > 0.0) {
        let (wi_l, wo_l) = (vertex.frame.to_local(wi), vertex.frame.to_local(wo));
        let p_hat = regularization::p_hat(&material_lobe, &vertex.bsdf, wi_l, wo_l);
        assert_eq!(vertex.mis_pdf(wo).to_bits(), p_hat.to_bits(), "{wo}");
        unlike_the_widened_pdf += usize::from(p_hat != vertex.bsdf.pdf(wi_l, wo_l));
    }
    assert!(unlike_the_widened_pdf > 0);
}

fn context(scene: &str, algorithm: Algorithm, mode: Mode, virtual_merges: bool) -> SceneContext {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(scene)
        .join("scene.toml");
    let options = scene::LoadOptions {
        resolution: Some(UVec2::new(48, 36)),
        ..Default::default()
    };
    let scene = scene::load(&path, &options).expect("bundled scene loads");
    let config = RenderConfig {
        algorithm,
        max_depth: 8,
        // A fixed tau (no schedule): uniform mode then regularizes every
        // vertex of both subpaths with one bound.
        regularization: Regularization::new(mode, crate::DEFAULT_TAU_0, false).expect("valid tau"),
        virtual_merges: Some(virtual_merges),
        ..RenderConfig::default()
    };
    SceneContext::new(scene, config)
}

/// Over the complete paths of every pixel: the largest |sum - 1|, the
/// number of paths, and how many had a regularized vertex.
fn worst_partition(ctx: &SceneContext) -> (f64, usize, usize) {
    let it = Bidirectional::new(ctx).iteration(ctx, 1, Stop::NEVER);
    let (w, h) = ctx.resolution();
    let (mut worst, mut paths, mut regularized) = (0.0f64, 0, 0);
    for index in 0..(w * h) as usize {
        for path in complete_paths(&it, index) {
            let (sum, reg) = weight_sum(&it, &path);
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
        for algorithm in [Algorithm::Bpt, Algorithm::Vcm, Algorithm::Bpm] {
            for (mode, virtual_merges) in [
                (Mode::Off, false),
                (Mode::Uniform, false),
                (Mode::Uniform, true),
                (Mode::Unsampleable, false),
            ] {
                // With merging, unsampleable light subpaths do not store
                // their delta vertices, which the camera rule may widen
                // into connection ends (`stores_delta_vertices`): no
                // partition is expected there.
                if mode == Mode::Unsampleable && algorithm != Algorithm::Bpt {
                    continue;
                }
                let ctx = context(scene, algorithm, mode, virtual_merges);
                let (worst, paths, regularized) = worst_partition(&ctx);
                let what = format!(
                    "{scene} {algorithm} {mode:?} virtual merges {virtual_merges}: \
                     {paths} paths ({regularized} regularized), max |sum - 1| {worst:.3e}"
                );
                eprintln!("{what}");
                assert!(paths > 500, "{what}");
                assert!(worst < PARTITION_TOLERANCE, "{what}");
                // Unsampleable BPT blurs what no technique samples: in these
                // tiny renders only caustic-glass has such paths.
                let blurs = match mode {
                    Mode::Uniform => scene != "cornell-box",
                    Mode::Unsampleable => scene == "caustic-glass",
                    _ => false,
                };
                if blurs {
                    assert!(regularized > 0, "{what}");
                }
            }
        }
    }
}
