//! Directions in the shading frame, where the normal is n = (0, 0, 1).
//!
//! All directions are unit vectors pointing away from the surface (SPEC §0).

use glam::Vec3;

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
#[inline]
pub fn refract(w: Vec3, m: Vec3, eta: f32) -> Option<Vec3> {
    if !(eta > 0.0 && eta.is_finite()) {
        return None;
    }
    let cos_i = w.dot(m);
    let sin2_i = (1.0 - cos_i * cos_i).max(0.0);
    let sin2_t = sin2_i / (eta * eta);
    if sin2_t >= 1.0 {
        return None;
    }
    let cos_t = (1.0 - sin2_t).sqrt();
    let t = -w / eta + (cos_i / eta - cos_t) * m;
    // Renormalise: round-off in m and w would otherwise accumulate along a path.
    t.try_normalize()
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
