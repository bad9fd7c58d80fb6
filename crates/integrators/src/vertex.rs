//! The path vertex every integrator builds: where a subpath touched a
//! surface, the (regularized) BSDF there and the quantities MIS needs.
//!
//! One path-vertex representation for every integrator, and the one BSDF
//! entry point, which applies regularization: a vertex fixes its alpha-hat
//! when it is created (SPEC §5); every later evaluation, sample and pdf at
//! it uses that value.

use std::cell::RefCell;

use glam::{Vec2, Vec3};
use microfacet::{Bsdf, Lambertian, TransportMode};
use regularization::{AlphaHat, PathRegularization, RegularizationMemo, p_hat, p_hat_of_sample};
use scene::Scene;

use crate::geometry::{Frame, SurfacePoint};

thread_local! {
    /// Each worker thread's last widened lobes (`regularization::memo`):
    /// building a widened lobe's energy compensation took about a third of a
    /// uniform-BPT iteration on the glass scenes, for the same few lobes
    /// again and again.
    static WIDENED: RefCell<RegularizationMemo> = const { RefCell::new(RegularizationMemo::new()) };
}

/// A scattering vertex of a camera or light subpath.
#[derive(Clone, Copy, Debug)]
pub struct PathVertex {
    /// The surface point.
    pub point: SurfacePoint,
    /// Shading frame used for the BSDF: the surface's, flipped to the side of
    /// `wi` for two-sided lobes (conductors, coated and diffuse surfaces;
    /// only a dielectric's frame keeps its orientation, which says where its
    /// inside is).
    pub frame: Frame,
    /// Unit direction towards the previous vertex of the subpath.
    pub wi: Vec3,
    /// `wi` in `frame`'s coordinates, fixed with both by
    /// [`PathVertex::new`]: every evaluation at the vertex needs it,
    /// connections many times.
    wi_local: Vec3,
    /// The BSDF actually used: the material's ([`PathVertex::bsdf_original`])
    /// with alpha-hat.
    pub bsdf: Bsdf,
    /// The BSDF as the material defines it (textures resolved), kept only
    /// where regularization changed it (`alpha_hat` is `Some`); otherwise
    /// it is `bsdf`. Most vertices are not regularized, and writing the
    /// lobe twice was a tenth of the wavefront path tracer's own time: the
    /// copy's wide loads waited on the narrow stores that had just built
    /// the lobe.
    original: Option<Bsdf>,
    /// The regularized roughness, when regularization raised alpha here.
    pub alpha_hat: Option<AlphaHat>,
    /// Product of f |cos| / pdf along the subpath up to (excluding) this vertex.
    pub throughput: Vec3,
    /// Regularization state for the next vertex of the subpath.
    pub regularization: PathRegularization,
    /// Only camera subpaths may scatter here
    /// ([`PathRegularization::is_camera_only`], `Mode::Unsampleable`).
    pub camera_only: bool,
    /// The bound tau this vertex was regularized with, when regularization
    /// raised its roughness; infinity otherwise (the `mis` crate's
    /// "not a virtual-merge vertex").
    pub tau: f64,
    /// The medium behind the surface ([`crate::medium`]).
    medium: Option<scene::Medium>,
}

/// A direction sampled at a vertex.
#[derive(Clone, Copy, Debug)]
pub struct VertexSample {
    /// Unit world direction.
    pub wo: Vec3,
    /// f |cos| / pdf.
    pub weight: Vec3,
    /// Sampling density (solid angle).
    pub pdf: f32,
    /// The density MIS compares (p-hat at a regularized vertex, SPEC §6).
    pub mis_pdf: f32,
    /// The MIS density of the reverse direction (sampling `wi` from `wo`),
    /// which bidirectional methods store at the vertex.
    pub mis_pdf_rev: f32,
    /// True for a delta lobe.
    pub is_specular: bool,
}

impl PathVertex {
    /// The vertex at `point`, reached from direction `wi` (towards the
    /// previous vertex), regularized by `regularization` (the subpath's state
    /// before this vertex).
    ///
    /// Always inlined (as [`PathVertex::sample`]): returned through the
    /// stack, the vertex's fields were reloaded right after the callee
    /// stored them and the loads waited on the stores; inlined, PT takes
    /// 5 % less time on SmallVCM's scenes (docs/benchmarks.md).
    #[inline(always)]
    pub fn new(
        scene: &Scene,
        point: SurfacePoint,
        wi: Vec3,
        throughput: Vec3,
        regularization: PathRegularization,
    ) -> Self {
        let material = &scene.materials[point.material as usize];
        let mut bsdf = material.surface.bsdf(point.uv, &scene.textures);
        let two_sided = !matches!(bsdf, Bsdf::Dielectric(_));
        let frame = if two_sided && point.frame.n.dot(wi) < 0.0 {
            point.frame.flipped()
        } else {
            point.frame
        };
        let (after, camera_only) = regularization.through_vertex(&bsdf);
        // Under tau = infinity (no regularization, a light subpath or a
        // sampleable prefix in `unsampleable` mode: most vertices) the lobe
        // stays as it is. The memo only where a lobe may be widened with its
        // compensation: reaching it costs about 40 instructions. A lobe
        // whose alpha-hat is its own alpha comes back unchanged.
        let tau = regularization.tau();
        let (mut original, mut alpha_hat) = (None, None);
        if tau != f64::INFINITY {
            let (widened, hat) = if regularization.compensates() && bsdf.alpha().is_some() {
                WIDENED.with_borrow_mut(|memo| regularization.regularize_with(&bsdf, memo))
            } else {
                regularization.regularize(&bsdf)
            };
            alpha_hat = hat.filter(|hat| Some(hat.alpha) != bsdf.alpha());
            if alpha_hat.is_some() {
                original = Some(std::mem::replace(&mut bsdf, widened));
            }
        }
        Self {
            point,
            frame,
            wi,
            wi_local: frame.to_local(wi),
            bsdf,
            original,
            alpha_hat,
            throughput,
            regularization: after,
            camera_only,
            tau: if alpha_hat.is_some() {
                tau
            } else {
                f64::INFINITY
            },
            medium: crate::medium::of(material),
        }
    }

    /// The absorbing medium a segment leaving here in direction `w` runs
    /// through, as far as this end knows ([`crate::medium`]).
    pub fn medium_towards(&self, w: Vec3) -> Option<scene::Medium> {
        crate::medium::towards(self.medium, self.point.ng, w)
    }

    /// This vertex regularized by another subpath's rule: where a
    /// technique makes a vertex of one subpath the next vertex of the
    /// other, it is regularized as that subpath would (SPEC §5).
    pub fn regularized_as(&self, scene: &Scene, regularization: PathRegularization) -> Self {
        Self::new(scene, self.point, self.wi, self.throughput, regularization)
    }

    /// The vertex's Lambertian lobe, when it has one and no medium behind
    /// it: its evaluation and density need nothing but the frame and the
    /// reflectance, so batches of such vertices are shaded lane by lane
    /// (the path tracer's wavefront).
    #[inline]
    pub fn lambertian(&self) -> Option<&Lambertian> {
        match &self.bsdf {
            Bsdf::Lambertian(l) if self.medium.is_none() => Some(l),
            _ => None,
        }
    }

    /// The BSDF as the material defines it (textures resolved), before
    /// regularization.
    #[inline]
    pub fn bsdf_original(&self) -> &Bsdf {
        self.original.as_ref().unwrap_or(&self.bsdf)
    }

    /// `wi` in the vertex's frame.
    #[inline]
    pub fn wi_local(&self) -> Vec3 {
        self.wi_local
    }

    /// True when the (regularized) lobe is a delta.
    pub fn is_specular(&self) -> bool {
        self.bsdf.is_specular()
    }

    /// False when `wo` (of any length) leaves through the other side of the
    /// geometric surface than `wi` while the lobe only reflects (not a
    /// dielectric, nor a thin sheet): shading
    /// normals must not let light leak through a surface. `eval` and `f`
    /// are zero towards such a `wo`.
    pub fn is_consistent_towards(&self, wo: Vec3) -> bool {
        matches!(self.bsdf, Bsdf::Dielectric(_) | Bsdf::ThinDielectric(_))
            || self.point.ng.dot(wo) * self.point.ng.dot(self.wi) > 0.0
    }

    /// f(wi, wo) |cos(wo, n_s)| for world direction `wo`; on light subpaths
    /// (`Importance`) with the shading-normal correction. Always inlined:
    /// out of line, its first load of `wo` waited on the caller's store.
    #[inline(always)]
    pub fn eval(&self, wo: Vec3, mode: TransportMode) -> Vec3 {
        if !self.is_consistent_towards(wo) {
            return Vec3::ZERO;
        }
        let (wi_l, wo_l) = (self.wi_local, self.frame.to_local(wo));
        self.bsdf.eval(wi_l, wo_l, mode) * wo_l.z.abs() * self.shading_correction(wo, mode)
    }

    /// A bound c with `eval(wo, Importance).max_element()` at most
    /// c |wo.n_g| for every `wo`: with the shading correction, the cosine a
    /// light subpath carries is the geometric one (Veach 1997, eq. 5.19),
    /// so for a Lambertian lobe c = max(R) / pi |wi.n_s| / |wi.n_g|.
    /// Infinity for microfacet lobes, coated ones included, whose peak has
    /// no cheap bound (it grows without limit as alpha shrinks). Lets the bidirectional core
    /// skip work whose outcome the bound already decides.
    pub fn importance_bound(&self) -> f32 {
        let Bsdf::Lambertian(lambertian) = self.bsdf else {
            return f32::INFINITY;
        };
        lambertian.reflectance.max_element()
            * std::f32::consts::FRAC_1_PI
            * self.wi.dot(self.frame.n).abs()
            / self.wi.dot(self.point.ng).abs()
    }

    /// True when no regularization rule changes this vertex (a Lambertian
    /// lobe has no roughness to raise): it need not be rebuilt for the
    /// rule of another subpath.
    pub fn is_regularization_invariant(&self) -> bool {
        self.bsdf.alpha().is_none()
    }

    /// f(wi, wo) without a cosine (for density estimation at merges).
    pub fn f(&self, wo: Vec3, mode: TransportMode) -> Vec3 {
        if !self.is_consistent_towards(wo) {
            return Vec3::ZERO;
        }
        self.bsdf.eval(self.wi_local, self.frame.to_local(wo), mode)
    }

    /// Veach's (1997, eq. 5.19) adjoint correction for shading normals on
    /// light subpaths: |wi.n_s| |wo.n_g| / (|wi.n_g| |wo.n_s|), so that the
    /// cosine a light subpath carries is the geometric one; 1 for camera
    /// subpaths. `wi` points towards the light side, `wo` onwards.
    fn shading_correction(&self, wo: Vec3, mode: TransportMode) -> f32 {
        if mode == TransportMode::Radiance {
            return 1.0;
        }
        let (ns, ng) = (self.frame.n, self.point.ng);
        let num = self.wi.dot(ns).abs() * wo.dot(ng).abs();
        let den = self.wi.dot(ng).abs() * wo.dot(ns).abs();
        if den > 0.0 { num / den } else { 0.0 }
    }

    /// The density MIS uses for `wo` sampled from this vertex: the sampling
    /// pdf, or p-hat (paper eq 13) where regularization raised alpha.
    pub fn mis_pdf(&self, wo: Vec3) -> f32 {
        self.mis_pdf_local(self.wi_local, self.frame.to_local(wo))
    }

    /// The MIS density of sampling `wi` from `wo` (the reverse direction).
    pub fn mis_pdf_rev(&self, wo: Vec3) -> f32 {
        self.mis_pdf_local(self.frame.to_local(wo), self.wi_local)
    }

    /// [`PathVertex::mis_pdf`] of sampling `wo_l` from `wi_l` (frame coordinates).
    #[inline]
    fn mis_pdf_local(&self, wi_l: Vec3, wo_l: Vec3) -> f32 {
        match &self.original {
            Some(original) => p_hat(original, &self.bsdf, wi_l, wo_l),
            None => self.bsdf.pdf(wi_l, wo_l),
        }
    }

    /// The vertex's pdfs for a connection or merge in direction `wo`, as the
    /// `mis` crate takes them.
    pub fn connection_pdfs(&self, wo: Vec3) -> mis::VertexPdfs {
        let (wi_l, wo_l) = (self.wi_local, self.frame.to_local(wo));
        mis::VertexPdfs::regularized(
            f64::from(self.mis_pdf_local(wi_l, wo_l)),
            f64::from(self.mis_pdf_local(wo_l, wi_l)),
            self.tau,
        )
    }

    /// The vertex as one end of a connection in direction `wo`, as the `mis`
    /// crate takes it.
    pub fn connection_end(&self, wo: Vec3) -> mis::ConnectionEnd {
        mis::ConnectionEnd {
            pdfs: self.connection_pdfs(wo),
            cos: f64::from(self.cos(wo)),
        }
    }

    /// [`Self::connection_end`] of a light subpath's last vertex, rebuilt
    /// with a camera subpath's rule: where only camera subpaths may scatter
    /// (`camera_only`), the light's own scattering counts 0
    /// (`mis::ConnectionEnd::without_scattering`).
    pub fn light_end(&self, wo: Vec3) -> mis::ConnectionEnd {
        let end = self.connection_end(wo);
        if self.camera_only {
            end.without_scattering()
        } else {
            end
        }
    }

    /// |cos| between the shading normal and `w`.
    pub fn cos(&self, w: Vec3) -> f32 {
        self.frame.n.dot(w).abs()
    }

    /// Samples an outgoing direction from `uc` and `u`.
    #[inline(always)]
    pub fn sample(&self, uc: f32, u: Vec2, mode: TransportMode) -> Option<VertexSample> {
        let wi_l = self.wi_local;
        let s = self.bsdf.sample(wi_l, uc, u, mode)?;
        let wo = self.frame.to_world(s.wo);
        if !self.is_consistent_towards(wo) || !(s.pdf > 0.0) {
            return None;
        }
        let weight = s.f * (s.wo.z.abs() / s.pdf) * self.shading_correction(wo, mode);
        if !weight.is_finite() || weight.max_element() <= 0.0 {
            return None;
        }
        let (mis_pdf, mis_pdf_rev) = match &self.original {
            Some(original) if !s.is_specular => p_hat_of_sample(original, &self.bsdf, wi_l, &s),
            _ => (s.pdf, s.pdf_reverse),
        };
        Some(VertexSample {
            wo,
            weight,
            pdf: s.pdf,
            mis_pdf,
            mis_pdf_rev,
            is_specular: s.is_specular,
        })
    }

    /// The `mis` crate's record of the scattering event `s` sampled here.
    pub fn scatter_event(&self, s: &VertexSample) -> mis::Scatter {
        let pdfs = if s.is_specular {
            // The tech. rep.'s specular rule: the lobe's discrete
            // probability as both pdfs.
            mis::VertexPdfs::new(f64::from(s.pdf), f64::from(s.pdf))
        } else {
            mis::VertexPdfs::regularized(f64::from(s.mis_pdf), f64::from(s.mis_pdf_rev), self.tau)
        };
        mis::Scatter {
            pdfs,
            cos_out: f64::from(self.cos(s.wo)),
            specular: s.is_specular,
        }
    }
}
