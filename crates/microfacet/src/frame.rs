//! Directions in the shading frame, where the normal is n = (0, 0, 1).
//!
//! All directions are unit vectors pointing away from the surface (SPEC §0).

use glam::{Vec2, Vec3};

/// cos(theta) = <w, n>.
#[inline]
pub fn cos_theta(w: Vec3) -> f32 {
    w.z
}

/// |cos(theta)|.
#[inline]
pub fn abs_cos_theta(w: Vec3) -> f32 {
    w.z.abs()
}

/// sin^2(theta), from the tangential components: no cancellation near the normal.
#[inline]
pub fn sin2_theta(w: Vec3) -> f32 {
    w.x * w.x + w.y * w.y
}

/// True when both directions lie strictly on the same side of the surface.
#[inline]
pub fn same_hemisphere(a: Vec3, b: Vec3) -> bool {
    a.z * b.z > 0.0
}

/// Mirror reflection of `w` about the unit normal `m`: 2 <w,m> m - w.
#[inline]
pub fn reflect(w: Vec3, m: Vec3) -> Vec3 {
    2.0 * w.dot(m) * m - w
}

/// Refraction of `w` through the microfacet `m` (Snell's law), with `eta` =
/// eta_t / eta_i the relative index of the far side and `m` on the side of `w`
/// (<w, m> > 0). `None` on total internal reflection or a degenerate `eta`.
/// See [`refract_f64`]; this is it with an f32 index.
#[inline]
pub fn refract(w: Vec3, m: Vec3, eta: f32) -> Option<Vec3> {
    refract_f64(w, m, f64::from(eta))
}

/// [`refract`] with the index in f64 (a lobe queried from the dense side
/// passes 1/eta without rounding it to f32 first). Computed in f64, with
/// cos^2(theta_t) from [`cos2_theta_t`]: the same quantity, and the same
/// total-internal-reflection decision, as `fresnel::dielectric`.
pub fn refract_f64(w: Vec3, m: Vec3, eta: f64) -> Option<Vec3> {
    if !(eta > 0.0 && eta.is_finite()) {
        return None;
    }
    let (w, m) = (w.as_dvec3(), m.as_dvec3());
    let cos_i = w.dot(m);
    let cos2_t = cos2_theta_t(cos_i, eta);
    if !(cos2_t > 0.0) {
        return None;
    }
    let t = -w / eta + (cos_i / eta - cos2_t.sqrt()) * m;
    // Renormalise: round-off in m and w would otherwise accumulate along a path.
    Some(t.try_normalize()?.as_vec3())
}

/// cos^2(theta_t) = 1 - sin^2(theta_i)/eta^2 (Snell's law), written as
/// ((eta - 1)(eta + 1) + cos_i^2) / eta^2 and evaluated in f64.
///
/// Near the critical angle from the dense side (cos_i^2 -> 1 - eta^2) the
/// result is the difference of two nearly equal numbers: in f32 its absolute
/// error is ~6e-8, so at cos^2(theta_t) = 2.5e-7 it was off by 20 %, and the
/// transmittance 1 - F (proportional to cos(theta_t) there) by 10 %. In f64,
/// with f32 inputs, eta^2 - 1 and cos_i^2 are exact and only the final sum
/// rounds: the result is correct to f64 precision for the given inputs. The
/// form is also exact at eta = 1: the textbook 1 - (1 - cos_i^2)/eta^2
/// rounds 1 - cos_i^2 to 1 at grazing angles and reported total internal
/// reflection for an index-matched interface. Negative means total internal
/// reflection.
#[inline]
pub fn cos2_theta_t(cos_i: f64, eta: f64) -> f64 {
    ((eta - 1.0) * (eta + 1.0) + cos_i * cos_i) / (eta * eta)
}

/// Cosine-weighted direction in the upper hemisphere (Malley's method, as
/// `Lambertian::sample`), density <w,n>/pi; `None` exactly on the horizon.
pub fn cosine_hemisphere(u: Vec2) -> Option<Vec3> {
    let r = u.x.sqrt();
    let phi = 2.0 * std::f32::consts::PI * u.y;
    let z = (1.0 - u.x).max(0.0).sqrt();
    (z > 0.0).then(|| Vec3::new(r * phi.cos(), r * phi.sin(), z))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn refraction_obeys_snell() {
        let m = Vec3::Z;
        let w = Vec3::new(0.6, 0.0, 0.8);
        let t = refract(w, m, 1.5).unwrap();
        assert!((t.length() - 1.0).abs() < 1e-6);
        assert!(t.z < 0.0);
        // sin_t = sin_i / eta
        assert!((t.x.abs() - 0.6 / 1.5).abs() < 1e-6);
        // Going back through the interface recovers the original direction.
        let back = refract(-t, m, 1.0 / 1.5).unwrap();
        assert!((-back - w).length() < 1e-6, "{back}");
        // Total internal reflection from the dense side beyond the critical angle.
        assert!(refract(Vec3::new(0.8, 0.0, 0.6), m, 1.0 / 1.5).is_none());
    }

    #[test]
    fn reflection_is_an_involution() {
        let m = Vec3::new(0.1, -0.2, 0.9).normalize();
        let w = Vec3::new(-0.3, 0.4, 0.5).normalize();
        assert!((reflect(reflect(w, m), m) - w).length() < 1e-6);
    }
}
