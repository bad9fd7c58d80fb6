//! Path tracing with next-event estimation and BSDF sampling combined by
//! multiple importance sampling (SPEC §7; Veach 1997 ch. 9), Russian
//! roulette, and regularization per SPEC §5-§6: each vertex is regularized
//! when created and MIS compares p-hat (paper eq 13).

use glam::Vec3;
use microfacet::TransportMode;
use mis::power_heuristic;
use regularization::{PathRegularization, Subpath};

use crate::config::Strategies;
use crate::render::Renderer;
use crate::sampler::Sampler;
use crate::vertex::PathVertex;

/// Depth (in vertices) from which Russian roulette may end paths.
pub const ROULETTE_DEPTH: u32 = 3;

/// Sampler dimensions used per vertex: light choice (1), light point (2),
/// BSDF lobe choice (1), BSDF direction (2), roulette (1).
pub(crate) const DIMENSIONS_PER_VERTEX: u32 = 7;

/// Russian roulette on a camera subpath's throughput: survives with
/// probability min(1, max component), reweighted; an unbiased termination
/// that MIS weights need not know about (they stay a partition of unity).
pub(crate) fn survives_roulette(throughput: &mut Vec3, u: f32) -> bool {
    let survive = throughput.max_element().min(1.0);
    if u >= survive {
        return false;
    }
    *throughput /= survive;
    true
}

/// Power-heuristic weight of a technique with density `pdf` against
/// `other`, in f64 (the pdfs of near-specular lobes overflow when squared in f32).
fn mis_weight(pdf: f32, other: f32) -> f32 {
    power_heuristic(f64::from(pdf), f64::from(other)) as f32
}

impl Renderer {
    /// One path-traced radiance estimate for the camera ray (`origin`, `direction`).
    pub(crate) fn trace_path(
        &self,
        mut origin: Vec3,
        mut direction: Vec3,
        sampler: &mut Sampler,
        tau_n: f64,
    ) -> Vec3 {
        let scene = &self.scene;
        let strategies = self.config.strategies;
        let (use_nee, use_bsdf) = match strategies {
            Strategies::Mis => (true, true),
            Strategies::NeeOnly => (true, false),
            Strategies::BsdfOnly => (false, true),
        };
        let mut radiance = Vec3::ZERO;
        let mut throughput = Vec3::ONE;
        let mut regularization =
            PathRegularization::new(self.effective_mode(tau_n), Subpath::Camera, tau_n);
        // State of the previous bounce for MIS on emitter hits.
        let mut specular_bounce = true;
        let mut prev_mis_pdf = 0.0f32;
        let mut prev_point = origin;

        for depth in 1..=self.config.max_depth {
            let Some(hit) = self.intersect(origin, direction, f32::INFINITY) else {
                if let Some(le) = self.lights.environment() {
                    let weight = if specular_bounce || !use_nee {
                        1.0
                    } else if !use_bsdf {
                        0.0
                    } else {
                        mis_weight(prev_mis_pdf, self.lights.environment_pdf())
                    };
                    radiance += throughput * le * weight;
                }
                break;
            };
            let point = self.surface_point(&hit);
            let wi = -direction;

            // Emission found by the previous bounce.
            let emission = scene.materials[point.material as usize].emission;
            if emission.max_element() > 0.0 && point.n_winding.dot(wi) > 0.0 {
                let weight = if specular_bounce || !use_nee {
                    1.0
                } else if !use_bsdf {
                    0.0
                } else {
                    let light_pdf =
                        self.lights
                            .area_pdf(point.triangle, prev_point, point.p, point.n_winding);
                    mis_weight(prev_mis_pdf, light_pdf)
                };
                radiance += throughput * emission * weight;
            }
            if depth == self.config.max_depth {
                break;
            }

            let vertex =
                PathVertex::new(scene, point, wi, throughput, prev_mis_pdf, regularization);
            regularization = vertex.regularization;
            sampler.set_dimension(2 + (depth - 1) * DIMENSIONS_PER_VERTEX);
            let (u_light, uv_light) = (sampler.next_1d(), sampler.next_2d());
            let (u_lobe, uv_bsdf) = (sampler.next_1d(), sampler.next_2d());
            let u_roulette = sampler.next_1d();

            if use_nee && !vertex.is_specular() {
                radiance += throughput * self.next_event(&vertex, u_light, uv_light, use_bsdf);
            }

            let Some(s) = vertex.sample(u_lobe, uv_bsdf, TransportMode::Radiance) else {
                break;
            };
            throughput *= s.weight;
            specular_bounce = s.is_specular;
            prev_mis_pdf = s.mis_pdf;
            prev_point = point.p;
            origin = point.spawn_origin(s.wo);
            direction = s.wo;

            if depth >= ROULETTE_DEPTH && !survives_roulette(&mut throughput, u_roulette) {
                break;
            }
        }
        radiance
    }

    /// Next-event estimation at `vertex`: a light sample, its visibility and
    /// its MIS weight against BSDF sampling (1 without BSDF sampling or for
    /// delta lights).
    fn next_event(
        &self,
        vertex: &PathVertex,
        u_light: f32,
        uv: glam::Vec2,
        use_bsdf: bool,
    ) -> Vec3 {
        let Some((ls, f)) = self.visible_light_sample(vertex, u_light, uv) else {
            return Vec3::ZERO;
        };
        let weight = if ls.is_delta || !use_bsdf {
            1.0
        } else {
            mis_weight(ls.pdf, vertex.mis_pdf(ls.wi))
        };
        f * ls.li * (weight / ls.pdf)
    }
}
