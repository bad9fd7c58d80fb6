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
    let (sin_phi, cos_phi) = sin_cos_turns(u.y);
    let z = (1.0 - u.x).max(0.0).sqrt();
    (z > 0.0).then(|| Vec3::new(r * cos_phi, r * sin_phi, z))
}

/// The odd polynomial of sin x on |x| <= pi/4:
/// sin x = x + x^3 ((S0 x^2 + S1) x^2 + S2), the minimax coefficients of
/// Cephes' `sinf` (S. L. Moshier, "Methods and Programs for Mathematical
/// Functions", 1989).
pub const SIN_POLYNOMIAL: [f32; 3] = [-1.951_529_6e-4, 8.332_161e-3, -1.666_665_5e-1];

/// The even polynomial of cos x on |x| <= pi/4:
/// cos x = 1 - x^2/2 + x^4 ((C0 x^2 + C1) x^2 + C2) (Cephes' `cosf`).
pub const COS_POLYNOMIAL: [f32; 3] = [2.443_315_7e-5, -1.388_731_6e-3, 4.166_664_6e-2];

/// (sin 2 pi u, cos 2 pi u): the sine and cosine of an azimuth drawn in
/// turns, as samplers draw it (u in [0, 1]), within 1.2e-7 of the exact
/// values (tested).
///
/// The reduction is exact, not only accurate: n = round(4u) is the
/// quadrant and g = 4u - n in [-1/2, 1/2] is an exact difference
/// (Sterbenz), so x = g pi/2 carries one rounding, and a fixed polynomial
/// takes it from there. Only IEEE operations in a fixed order, without
/// fused multiply-adds: the same bits on every instruction set, which the
/// path tracer's SIMD lanes (`StepLanes` of `rlt-integrators`) reproduce
/// 16 at a time, where libm's `sinf`/`cosf` took a call per lane.
#[inline]
pub fn sin_cos_turns(u: f32) -> (f32, f32) {
    let t = 4.0 * u;
    let n = t.round_ties_even();
    let x = (t - n) * std::f32::consts::FRAC_PI_2;
    let x2 = x * x;
    let [s0, s1, s2] = SIN_POLYNOMIAL;
    let [c0, c1, c2] = COS_POLYNOMIAL;
    let sin = x + x * x2 * ((s0 * x2 + s1) * x2 + s2);
    let cos = (1.0 - 0.5 * x2) + x2 * x2 * ((c0 * x2 + c1) * x2 + c2);
    // sin and cos of n pi/2 + x.
    match n as i32 & 3 {
        0 => (sin, cos),
        1 => (cos, -sin),
        2 => (-sin, -cos),
        _ => (-cos, sin),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every 61st f32 in [0, 1] (about 17 million) and the quadrant
    /// boundaries, against f64's sin and cos of the same angle.
    #[test]
    fn sin_cos_turns_matches_f64() {
        let check = |u: f32| {
            let (s, c) = sin_cos_turns(u);
            let phi = std::f64::consts::TAU * f64::from(u);
            let error = (f64::from(s) - phi.sin())
                .abs()
                .max((f64::from(c) - phi.cos()).abs());
            assert!(error <= 1.2e-7, "u {u}: sin {s} cos {c}, error {error:e}");
        };
        let mut bits = 0;
        while bits <= 1.0f32.to_bits() {
            check(f32::from_bits(bits));
            bits += 61;
        }
        for q in [0.0, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0f32] {
            for u in [q.next_down(), q, q.next_up()] {
                if (0.0..=1.0).contains(&u) {
                    check(u);
                }
            }
        }
        assert_eq!(sin_cos_turns(0.0), (0.0, 1.0));
        assert_eq!(sin_cos_turns(0.25), (1.0, 0.0));
    }

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
