//! Ideal diffuse reflection, f = R/pi, two-sided.

use std::f32::consts::FRAC_1_PI;

use glam::{Vec2, Vec3};

use crate::frame::{same_hemisphere, sin_cos_turns};
use crate::sample::BsdfSample;

/// Lambertian reflector with albedo `reflectance` (each channel in [0, 1]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Lambertian {
    /// Directional-hemispherical reflectance.
    pub reflectance: Vec3,
}

impl Lambertian {
    /// A Lambertian reflector of directional-hemispherical reflectance
    /// `reflectance` (the albedo, each channel in [0, 1], dimensionless):
    /// f = R/pi.
    pub fn new(reflectance: Vec3) -> Self {
        Self { reflectance }
    }

    /// R/pi when wi and wo are on the same side, else 0.
    pub fn eval(&self, wi: Vec3, wo: Vec3) -> Vec3 {
        if same_hemisphere(wi, wo) {
            self.reflectance * FRAC_1_PI
        } else {
            Vec3::ZERO
        }
    }

    /// Cosine-weighted density |<wo,n>|/pi on the side of wi.
    pub fn pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        if same_hemisphere(wi, wo) {
            wo.z.abs() * FRAC_1_PI
        } else {
            0.0
        }
    }

    /// Cosine-weighted hemisphere sampling (Malley's method: uniform disk,
    /// projected up) on the side of wi. `None` for wi in the tangent plane
    /// or a sample exactly on the horizon.
    pub fn sample(&self, wi: Vec3, u: Vec2) -> Option<BsdfSample> {
        if wi.z == 0.0 {
            return None;
        }
        let r = u.x.sqrt();
        let (sin_phi, cos_phi) = sin_cos_turns(u.y);
        let z = (1.0 - u.x).max(0.0).sqrt();
        if z == 0.0 {
            return None;
        }
        let wo = Vec3::new(r * cos_phi, r * sin_phi, z.copysign(wi.z));
        Some(BsdfSample {
            wo,
            f: self.reflectance * FRAC_1_PI,
            pdf: z * FRAC_1_PI,
            pdf_reverse: wi.z.abs() * FRAC_1_PI,
            eta: 1.0,
            is_specular: false,
            compensated: None,
        })
    }
}
