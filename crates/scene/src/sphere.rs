//! Analytic spheres: what a manifest's `shape = "sphere"` becomes unless it
//! asks for triangles (`tessellate = true`, or a partial sphere).

use std::f32::consts::PI;

use glam::{Vec2, Vec3};

use crate::checks::{finite, unit};

/// A full sphere in world space with one material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius (> 0).
    pub radius: f32,
    /// Unit pole axis of the texture parametrisation ([`Sphere::uv`]).
    pub axis: Vec3,
    /// Material index.
    pub material: u32,
    /// Normals face the centre (a concave mirror, or an emitter lighting
    /// its inside); the medium of a dielectric is then outside.
    pub inside: bool,
}

impl Sphere {
    /// An analytic sphere's geometry: finite centre and axis, a finite
    /// radius > 0, a unit axis; the message names what is not.
    pub(crate) fn check(&self) -> Result<(), String> {
        finite("center", self.center)?;
        if !(self.radius.is_finite() && self.radius > 0.0) {
            return Err(format!(
                "radius must be finite and > 0, got {}",
                self.radius
            ));
        }
        unit("axis", self.axis)
    }

    /// Surface area 4 pi r^2 (in f64: it overflows f32 only beyond r ~ 5e18).
    pub fn area(&self) -> f64 {
        4.0 * std::f64::consts::PI * f64::from(self.radius) * f64::from(self.radius)
    }

    /// The tangents (t, b) that, with the axis, frame the parametrisation:
    /// the same as `shapes::sphere` uses, so textures sit where they sit on
    /// the tessellated sphere.
    fn tangents(&self) -> (Vec3, Vec3) {
        let t = self.axis.any_orthonormal_vector();
        (t, self.axis.cross(t))
    }

    /// Texture coordinates of the point in outward unit direction `n` from
    /// the centre: u = phi / 2 pi around the axis (from the tangent
    /// towards the bitangent), v = theta / pi from the axis (pbrt-v4's
    /// sphere parametrisation, §6.2, with the pole on `axis`).
    pub fn uv(&self, n: Vec3) -> Vec2 {
        let (t, b) = self.tangents();
        let theta = n.dot(self.axis).clamp(-1.0, 1.0).acos();
        let mut phi = n.dot(b).atan2(n.dot(t));
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        Vec2::new(phi / (2.0 * PI), theta / PI)
    }

    /// dp/du and dp/dv of [`Sphere::uv`]'s parametrisation at the point in
    /// outward unit direction `n` (pbrt-v4 §6.2.3: dp/du = 2 pi r sin(theta)
    /// times the unit phi direction, dp/dv = pi r times the unit theta
    /// direction), for normal and bump maps. dp/du is zero at the poles.
    pub fn uv_derivatives(&self, n: Vec3) -> (Vec3, Vec3) {
        let (t, b) = self.tangents();
        let (x, y, z) = (n.dot(t), n.dot(b), n.dot(self.axis));
        let sin_theta = (x * x + y * y).sqrt();
        let r = self.radius;
        let dpdu = 2.0 * PI * r * (-y * t + x * b);
        let radial = if sin_theta > 0.0 {
            (x * t + y * b) / sin_theta
        } else {
            t
        };
        let dpdv = PI * r * (z * radial - sin_theta * self.axis);
        (dpdu, dpdv)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// uv and its derivatives agree with finite differences of the point.
    #[test]
    fn parametrisation_and_derivatives() {
        let s = Sphere {
            center: Vec3::new(1.0, 2.0, 3.0),
            radius: 2.0,
            axis: Vec3::new(0.0, 0.6, 0.8),
            material: 0,
            inside: false,
        };
        let (t, b) = s.tangents();
        let point = |uv: Vec2| {
            let (phi, theta) = (2.0 * PI * uv.x, PI * uv.y);
            s.axis * theta.cos() + (t * phi.cos() + b * phi.sin()) * theta.sin()
        };
        for uv in [
            Vec2::new(0.1, 0.3),
            Vec2::new(0.7, 0.8),
            Vec2::new(0.45, 0.5),
        ] {
            let n = point(uv);
            assert!((s.uv(n) - uv).length() < 1e-5, "{uv}");
            let (dpdu, dpdv) = s.uv_derivatives(n);
            let h = 1e-3;
            let du = (point(uv + Vec2::new(h, 0.0)) - point(uv - Vec2::new(h, 0.0))) * s.radius
                / (2.0 * h);
            let dv = (point(uv + Vec2::new(0.0, h)) - point(uv - Vec2::new(0.0, h))) * s.radius
                / (2.0 * h);
            assert!((dpdu - du).length() < 1e-2 * du.length(), "{dpdu} {du}");
            assert!((dpdv - dv).length() < 1e-2 * dv.length(), "{dpdv} {dv}");
        }
        assert!((s.area() - 16.0 * std::f64::consts::PI).abs() < 1e-9);
    }
}
