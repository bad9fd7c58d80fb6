//! The MIS weight of each technique, from the sub-path quantities (tech. rep.
//! eq. 37-47), with virtual merges.
//!
//! Every function returns a value in [0, 1]. The weight of a connection
//! (next-event estimation, vertex connection, light tracing) is the weight of
//! everything the executed connection stands for: the plain connection plus
//! the virtual merges on its edge (see the crate documentation, "Virtual
//! merges").

use crate::MisConfig;
use crate::numeric::{abs, add, div, mul, share};
use crate::subpath::{EmitterKind, SubpathRay, SubpathState, VertexPdfs};

/// One end of a connection: the vertex's pdfs for this connection and its
/// cosine towards the other end.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ConnectionEnd {
    /// `fwd`: pdf of the direction towards the other end, given the vertex's
    /// incoming direction; `rev`: pdf of the incoming direction given the
    /// direction towards the other end; `tau`: the regularization bound.
    /// Solid angle; p_hat at regularized vertices.
    pub pdfs: VertexPdfs,
    /// |cos| between the vertex's shading normal and the connecting direction.
    pub cos: f64,
}

impl ConnectionEnd {
    /// The same end where its own sub-path may end but not scatter
    /// (regularization's `Unsampleable` mode: the other sub-path's rule may
    /// widen the lobe that this sub-path samples sharp): the pdf of its own
    /// scattering towards the other end, `fwd`, counts 0, which leaves out
    /// the techniques that would need it (those that move the connection
    /// towards the other sub-path's origin, and the virtual merge sampled
    /// here).
    #[must_use]
    pub fn without_scattering(self) -> Self {
        Self {
            pdfs: VertexPdfs {
                fwd: 0.0,
                ..self.pdfs
            },
            ..self
        }
    }
}

/// A next-event estimation sample: an emitter point (or direction) chosen
/// for a camera vertex.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LightSample {
    /// The emitter's kind.
    pub kind: EmitterKind,
    /// The solid-angle pdf, at the camera vertex, of the direction towards the
    /// chosen point, including the light-selection probability (SmallVCM's
    /// `directPdfW`). For a point light: the selection probability times d^2.
    pub direct_pdf_w: f64,
    /// The pdf with which the emitter would emit the connecting ray (position
    /// times direction, including the selection probability; see
    /// [`Emission::emission_pdf_w`](crate::Emission::emission_pdf_w)).
    pub emission_pdf_w: f64,
    /// |cos| at the emitter surface towards the camera vertex (used for
    /// `Area` only).
    pub cos_light: f64,
}

/// An emitter found by a camera sub-path ray (technique s = 0).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EmitterHit {
    /// The pdf with which next-event estimation chooses the hit point,
    /// including the selection probability: area measure for an `Area`
    /// emitter, solid angle for an `Environment` (SmallVCM's `directPdfA`).
    pub direct_pdf_a: f64,
    /// The pdf with which the emitter would emit the ray back along the hit
    /// ray (position times direction, including the selection probability).
    pub emission_pdf_w: f64,
}

impl MisConfig {
    /// Weight of a camera sub-path that hits an area emitter (s = 0), the
    /// camera state having arrived at the emitter point (tech. rep. eq. 42-43,
    /// 37):
    ///
    /// w = 1 / (1 + p_direct^beta d_vcm + p_emission^beta d_vc).
    ///
    /// 1 for an emitter seen directly from the camera (the only technique for
    /// that path: light tracing from the emitter itself, s = 1, t = 1, is not
    /// a technique here, as in SmallVCM).
    pub fn emitter_hit_weight(&self, camera: &SubpathState, hit: &EmitterHit) -> f64 {
        if camera.segments() <= 1 {
            return 1.0;
        }
        self.hit_weight(camera, hit)
    }

    /// Weight of a camera sub-path ray that leaves the scene and picks up an
    /// environment emitter (s = 0), using the ray before any arrival (tech.
    /// rep. §5.1: infinite emitters are integrated in solid angle; SmallVCM's
    /// `GetLightRadiance` called before the update):
    ///
    /// w = 1 / (1 + p_direct^beta d_vcm + p_emission^beta d_vc).
    ///
    /// 1 for the camera's own ray.
    pub fn environment_hit_weight(&self, camera: &SubpathRay, hit: &EmitterHit) -> f64 {
        if camera.segments() == 0 {
            return 1.0;
        }
        // The ray's quantities are those of a vertex at infinity.
        self.hit_weight(&camera.pending_state(), hit)
    }

    fn hit_weight(&self, camera: &SubpathState, hit: &EmitterHit) -> f64 {
        let rest = add(
            mul(self.mis(hit.direct_pdf_a), camera.d_vcm()),
            mul(self.mis(hit.emission_pdf_w), camera.d_vc()),
        );
        share(1.0, rest)
    }

    /// Weight of next-event estimation (s = 1) from camera vertex `camera`
    /// towards an emitter sample (tech. rep. eq. 44-45, 37), with the virtual
    /// merge sampled at the camera vertex towards the emitter:
    ///
    /// - g = 1 + a^beta, a = acceptance(camera_end.fwd, tau) (plain NEE and
    ///   its virtual merge),
    /// - hit = \[hittable\] (p_bsdf / p_direct)^beta (the camera sub-path hitting
    ///   the emitter, s = 0),
    /// - em = (p_emission |cos_camera| / (p_direct |cos_light|))^beta (the
    ///   techniques that emit from the emitter),
    /// - w = g / (g + hit + em (eta + V)), V = the camera vertex's bracket with
    ///   the reverse pdf `camera_end.rev`.
    ///
    /// 0 when connections are off.
    pub fn next_event_weight(
        &self,
        camera: &SubpathState,
        camera_end: &ConnectionEnd,
        light: &LightSample,
    ) -> f64 {
        if self.connect == 0.0 {
            return 0.0;
        }
        let pdfs = camera_end.pdfs;
        let own = add(1.0, self.mis(self.acceptance(pdfs.fwd, pdfs.tau)));
        let direct = self.mis(light.direct_pdf_w);
        let hit = if light.kind.is_hittable() {
            div(self.mis(pdfs.fwd), direct)
        } else {
            0.0
        };
        let cos_light = if light.kind.has_surface() {
            self.mis(abs(light.cos_light))
        } else {
            1.0
        };
        let emitted = div(
            mul(
                self.mis(light.emission_pdf_w),
                self.mis(abs(camera_end.cos)),
            ),
            mul(direct, cos_light),
        );
        let behind = camera.behind(self, pdfs.rev, pdfs.tau);
        let rest = add(hit, mul(emitted, add(self.mis_eta, behind)));
        share(own, rest)
    }

    /// Weight of a connection between light vertex `light` and camera vertex
    /// `camera` at `distance` (s, t >= 2; tech. rep. eq. 40-41, 37), with the
    /// virtual merges sampled at either end towards the other:
    ///
    /// - g = 1 + a_L^beta + a_C^beta, a_X = acceptance(X.fwd, tau_X),
    /// - p_C = camera_end.fwd |cos_light| / d^2 (the camera sub-path's area pdf
    ///   of the light vertex), p_L = light_end.fwd |cos_camera| / d^2,
    /// - w = g / (g + p_C^beta (eta + V_L) + p_L^beta (eta + V_C)), V_X the
    ///   vertex's bracket with its reverse pdf.
    ///
    /// 0 when connections are off.
    pub fn connection_weight(
        &self,
        light: &SubpathState,
        light_end: &ConnectionEnd,
        camera: &SubpathState,
        camera_end: &ConnectionEnd,
        distance: f64,
    ) -> f64 {
        if self.connect == 0.0 {
            return 0.0;
        }
        let (l, c) = (light_end.pdfs, camera_end.pdfs);
        let own = add(
            add(1.0, self.mis(self.acceptance(l.fwd, l.tau))),
            self.mis(self.acceptance(c.fwd, c.tau)),
        );
        let d = abs(distance);
        let d2 = self.mis(mul(d, d));
        let camera_pdf_a = div(mul(self.mis(c.fwd), self.mis(abs(light_end.cos))), d2);
        let light_pdf_a = div(mul(self.mis(l.fwd), self.mis(abs(camera_end.cos))), d2);
        let light_side = mul(
            camera_pdf_a,
            add(self.mis_eta, light.behind(self, l.rev, l.tau)),
        );
        let camera_side = mul(
            light_pdf_a,
            add(self.mis_eta, camera.behind(self, c.rev, c.tau)),
        );
        share(own, add(light_side, camera_side))
    }

    /// Weight of light tracing (t = 1): light vertex `light` connected to the
    /// camera at `distance`, `camera_pdf_w` being the solid-angle pdf with which
    /// the camera would generate the direction towards the vertex (tech. rep.
    /// eq. 46-47, 37), with the virtual merge sampled at the light vertex
    /// towards the camera:
    ///
    /// - g = 1 + a^beta, a = acceptance(light_end.fwd, tau),
    /// - p_C = camera_pdf_w |cos_light| / d^2,
    /// - w = N^beta g / (N^beta g + p_C^beta (eta + V_L)): the technique splats
    ///   all N light sub-paths, so it takes N samples per camera sample.
    ///
    /// 0 when connections are off.
    pub fn light_tracing_weight(
        &self,
        light: &SubpathState,
        light_end: &ConnectionEnd,
        camera_pdf_w: f64,
        distance: f64,
    ) -> f64 {
        if self.connect == 0.0 {
            return 0.0;
        }
        let l = light_end.pdfs;
        let own = mul(
            self.mis_light_paths,
            add(1.0, self.mis(self.acceptance(l.fwd, l.tau))),
        );
        let d = abs(distance);
        let camera_pdf_a = div(
            mul(self.mis(camera_pdf_w), self.mis(abs(light_end.cos))),
            self.mis(mul(d, d)),
        );
        let light_side = mul(
            camera_pdf_a,
            add(self.mis_eta, light.behind(self, l.rev, l.tau)),
        );
        share(own, light_side)
    }

    /// Weight of merging light vertex `light` into camera vertex `camera`
    /// (tech. rep. eq. 38-39, 37). `camera_end` holds the camera vertex's pdfs
    /// for the merged path, the BSDF of the camera vertex being the one
    /// evaluated (as in SmallVCM): `fwd` towards the light vertex's previous
    /// vertex (the photon's incoming direction), `rev` towards the camera
    /// vertex's previous vertex, `tau` the camera vertex's bound, which is
    /// also the one the virtual merges at this vertex use:
    ///
    /// w = eta^beta / (eta^beta + V_L + V_C), V_L = the light vertex's bracket
    /// with reverse pdf `camera_end.fwd`, V_C = the camera vertex's with
    /// `camera_end.rev`.
    ///
    /// 0 when merging is off.
    pub fn merge_weight(
        &self,
        light: &SubpathState,
        camera: &SubpathState,
        camera_end: &VertexPdfs,
    ) -> f64 {
        let light_side = light.behind(self, camera_end.fwd, camera_end.tau);
        let camera_side = camera.behind(self, camera_end.rev, camera_end.tau);
        share(self.mis_eta, add(light_side, camera_side))
    }
}
