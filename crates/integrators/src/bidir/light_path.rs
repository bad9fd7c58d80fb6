//! Light subpaths: traced from an emitter, stored as light vertices for
//! connections and merges, and connected to the camera (light tracing).

use glam::Vec3;
use microfacet::TransportMode;
use mis::{SubpathRay, SubpathState};
use regularization::{Mode, PathRegularization, Subpath};
use scene::Scene;

use super::Iteration;
use crate::film::Splats;
use crate::geometry::SurfacePoint;
use crate::medium;
use crate::sampler::{LIGHT_STREAM, Sampler};
use crate::vertex::PathVertex;
use crate::walk::Walk;

/// What a light subpath leaves at a non-specular vertex: enough to rebuild
/// its [`PathVertex`] with the regularization a technique needs, and its MIS
/// state. Kept small: with merging there are pixels x path length of them.
#[derive(Clone, Copy, Debug)]
pub(super) struct LightVertex {
    pub point: SurfacePoint,
    /// Unit direction towards the previous vertex (towards the light).
    pub wi: Vec3,
    /// Light subpath throughput up to (excluding) this vertex.
    pub throughput: Vec3,
    pub state: SubpathState,
    /// Segments from the light to this vertex.
    pub length: u32,
    /// The largest component of `throughput` times the vertex's
    /// [`PathVertex::importance_bound`]: throughput times f |cos| towards
    /// `wo` is at most `bound` |wo.n_g|.
    pub bound: f32,
    /// Whether the subpath's earlier vertices are bounded at tau_N, the
    /// previous one in bit 0 (`Mode::Unsampleable`; see
    /// [`LightVertex::earlier_bounded`]).
    pub earlier_bounded: BoundedHistory,
}

impl LightVertex {
    /// The light vertex that `vertex`, reached with `state` after `length`
    /// segments, leaves; `earlier_bounded` as in [`BoundedHistory`].
    pub fn new(
        vertex: &PathVertex,
        state: SubpathState,
        length: u32,
        earlier_bounded: BoundedHistory,
    ) -> Self {
        Self {
            point: vertex.point,
            wi: vertex.wi,
            throughput: vertex.throughput,
            state,
            length,
            bound: vertex.throughput.max_element() * vertex.importance_bound(),
            earlier_bounded,
        }
    }

    /// Whether the light subpath's vertices before this one are bounded, from
    /// the previous one back to the first: what
    /// [`PathRegularization::admits_light_interior`] walks (`Mode::Unsampleable`).
    pub fn earlier_bounded(&self) -> impl Iterator<Item = bool> {
        self.earlier_bounded.iter(self.length - 1)
    }

    /// The vertex rebuilt with `regularization`, the rule of the subpath
    /// that a technique makes it part of (SPEC §5).
    pub fn vertex(&self, scene: &Scene, regularization: PathRegularization) -> PathVertex {
        PathVertex::new(scene, self.point, self.wi, self.throughput, regularization)
    }

    /// An upper bound of the largest component of `throughput` times the
    /// vertex's f |cos| towards unit `wo` (infinity when the lobe has no
    /// cheap bound). Proportional to |wo|: a direction of any length gives
    /// the bound times its length.
    pub fn bound_towards(&self, wo: Vec3) -> f32 {
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

/// Whether the vertices of a light subpath so far are bounded at tau_N, the
/// last one in bit 0. 32 of them are more than enough: the walk that reads
/// them ends within two vertices ([`PathRegularization::admits_light_interior`]).
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct BoundedHistory(u32);

impl BoundedHistory {
    /// The history after one more vertex.
    fn push(self, bounded: bool) -> Self {
        Self(self.0 << 1 | u32::from(bounded))
    }

    /// The last `count` (at most 32) flags, the last one first.
    pub fn iter(self, count: u32) -> impl Iterator<Item = bool> {
        (0..count.min(u32::BITS)).map(move |k| self.0 >> k & 1 == 1)
    }
}

impl Iteration<'_> {
    /// The light subpath with index `index`: its non-specular vertices are
    /// appended to `vertices`, its light-tracing contributions to `splats`.
    pub(super) fn trace_light_path(
        &self,
        index: u64,
        vertices: &mut Vec<LightVertex>,
        splats: &mut Splats,
    ) {
        let ctx = self.ctx;
        let max_depth = ctx.config.max_depth;
        let sampler = Sampler::new(ctx.config.seed, self.n, LIGHT_STREAM + index);
        let (u_select, u_position, u_direction) = sampler.emission();
        let Some(emission) =
            ctx.lights
                .sample_emission(&ctx.scene, u_select, u_position, u_direction)
        else {
            return;
        };
        let mut ray = SubpathRay::from_light(&self.mis, &emission.mis.emission());
        let regularization = self.path_regularization(Subpath::Light);
        let mut walk = Walk {
            throughput: emission.throughput,
            ..Walk::new(emission.origin, emission.direction)
        };
        let emitted = walk.throughput.max_element();
        let unsampleable = self.mode == Mode::Unsampleable;
        let mut history = BoundedHistory::default();
        for length in 1..=max_depth {
            // Drawn before the ray, as in the path tracer (see there).
            let u = sampler.light_vertex(length);
            let Some(hit) = walk.next_hit(ctx) else {
                break;
            };
            let point = ctx.surface_point(&hit, walk.origin, walk.direction);
            walk.arrive(&ctx.scene, &point, hit.t);
            let wi = -walk.direction;
            let vertex = PathVertex::new(&ctx.scene, point, wi, walk.throughput, regularization);
            let state = ray.arrive(&self.mis, f64::from(hit.t), f64::from(vertex.cos(wi)));
            if !vertex.is_specular() || self.stores_delta_vertices() {
                vertices.push(LightVertex::new(&vertex, state, length, history));
            }
            if self.mis.techniques().connections && length < max_depth {
                let u_roulette = sampler.keyed_1d(u64::from(length));
                let history = history.iter(length - 1);
                self.connect_to_camera(&vertex, &state, history, u_roulette, splats);
            }
            if unsampleable {
                history = history.push(regularization.is_bounded(vertex.bsdf_original()));
            }
            // Every further vertex makes paths of at least length + 2 segments.
            if length + 2 > max_depth {
                break;
            }
            let Some(s) = walk.step(&vertex, length, u, TransportMode::Importance, emitted) else {
                break;
            };
            ray = state.scatter(&self.mis, &vertex.scatter_event(&s));
        }
    }

    /// True when light vertices with a delta lobe are stored too: in
    /// `Unsampleable` mode light subpaths are not regularized, while a
    /// camera subpath's rule may widen the same vertex, and its MIS weights
    /// then count the connection to it, which must therefore be made
    /// (`connect` rebuilds the vertex with the camera's rule and skips it if
    /// it is still delta). Not with merging, whose photon map would gather
    /// them on nearby surfaces; there the camera rule regularizes only
    /// before the first bounded vertex, where alpha-hat is at most
    /// alpha_tau,N times the prefix's largest alpha (< 0.0106 at the default
    /// tau_0) and connections weigh little.
    fn stores_delta_vertices(&self) -> bool {
        self.mode == Mode::Unsampleable && !self.mis.techniques().merging
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
    ///
    /// In `Unsampleable` mode the camera rule must also admit the light
    /// subpath's earlier vertices, `earlier_bounded`
    /// ([`PathRegularization::admits_light_interior`]).
    fn connect_to_camera(
        &self,
        light_vertex: &PathVertex,
        state: &SubpathState,
        earlier_bounded: impl Iterator<Item = bool>,
        u_roulette: f32,
        splats: &mut Splats,
    ) {
        let ctx = self.ctx;
        let camera = ctx.camera.camera();
        let Some((x, y)) = ctx.camera.project(light_vertex.point.p) else {
            return;
        };
        // Without regularization, or for a lobe without roughness, both
        // rules leave the vertex as it is.
        let rebuilt;
        let vertex = if self.mode == Mode::Off || light_vertex.is_regularization_invariant() {
            light_vertex
        } else {
            let seen_from_camera = self.path_regularization(Subpath::Camera);
            rebuilt = light_vertex.regularized_as(&ctx.scene, seen_from_camera);
            &rebuilt
        };
        if vertex.is_specular() || !vertex.regularization.admits_light_interior(earlier_bounded) {
            return;
        }
        let to_camera = camera.position - vertex.point.p;
        let distance = to_camera.length();
        let dir = to_camera / distance;
        let f = vertex.eval(dir, TransportMode::Importance);
        if f.max_element() <= 0.0 {
            return;
        }
        let camera_pdf_w = ctx.camera.pdf_w(-dir);
        // The pixel integral is over the image plane in pixel units: the
        // surface-to-image factor is camera_pdf_w / d^2 (SmallVCM's
        // ConnectToCamera); each of the N light paths is one sample.
        let light_paths = (camera.resolution.x * camera.resolution.y) as f32;
        // The camera is outside every medium: the vertex's end decides.
        let unweighted = medium::attenuated(
            vertex.throughput * f * (camera_pdf_w / (distance * distance * light_paths)),
            vertex.medium_towards(dir),
            distance,
        );
        let Some(contribution) = self.roulette.weighted(unweighted, u_roulette, || {
            self.mis.light_tracing_weight(
                state,
                &vertex.light_end(dir),
                f64::from(camera_pdf_w),
                f64::from(distance),
            ) as f32
        }) else {
            return;
        };
        let origin = vertex.point.spawn_origin(dir);
        // Up to the near plane: what lies before it is not seen
        // (`CameraRays::project` refused points before it).
        let depth = (origin - camera.position).dot(camera.forward);
        let beyond_near = 1.0 - camera.near_clip / depth;
        let surfaces = [vertex.point.primitive, accel::NO_SURFACE];
        if ctx.occluded_between(origin, camera.position - origin, beyond_near, surfaces) {
            return;
        }
        splats.push(y * camera.resolution.x + x, contribution);
    }
}
