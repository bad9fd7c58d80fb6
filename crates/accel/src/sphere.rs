//! Analytic spheres: the ray/sphere test, the hit point on the surface and
//! its error bound.
//!
//! The test is the quadratic of Haines, Günther and Akenine-Möller,
//! "Precision Improvements for Ray/Sphere Intersection" (Ray Tracing Gems,
//! ch. 7): the discriminant from the squared distance of the centre to the
//! ray's line (their eq. 7.5, r^2 - |f - (f.d / d.d) d|^2, instead of
//! b^2 - 4ac, which cancels catastrophically for small spheres far from the
//! origin), and the two roots as c/q and q/a with q = -(b + sign(b)
//! sqrt(disc)) / 2 (their eq. 7.8, the numerically stable pair). It runs
//! in f64 on the f32 inputs: a ray leaving the surface from an offset origin
//! ([`Sphere::hit_point`], [`crate::offset_ray_origin_bounded`]) is outside
//! (or inside) the sphere by a few f32 ulps, which f64 resolves exactly, so a
//! secondary ray never hits the sphere it leaves at t ~ 0.
//!
//! Both roots are candidates: a ray starting inside (refraction into a
//! glass sphere) hits the far side.

use glam::{DVec3, Vec3};

/// A sphere: centre and radius (a finite radius > 0; others never hit).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sphere {
    /// Centre.
    pub center: Vec3,
    /// Radius.
    pub radius: f32,
}

/// Relative error bound of a coordinate of [`Sphere::hit_point`]: the point
/// is computed and reprojected onto the sphere in f64 (error ~1e-16 of
/// |centre| + radius, from the f64 sum) and rounded once to f32 (half an ulp,
/// at most 2^-24 |p_i|): 2^-22, four times the final rounding, covers both
/// with a margin (pbrt-v4's sphere, all in f32, needs gamma(5) = 5 * 2^-24).
pub const HIT_POINT_RELATIVE_ERROR: f32 = 1.0 / 4_194_304.0;

/// Absolute floor of the hit-point error, for coordinates that round to
/// (near) zero: the f64 error of the sum centre + radius direction,
/// 2^-50 (|centre| + radius), is added to it per sphere in
/// [`Sphere::hit_point`].
const HIT_POINT_ABSOLUTE_ERROR: f64 = 1.0 / 1_125_899_906_842_624.0;

/// Relative margin of the f32 culling of spheres in packets
/// (`packet.rs`), 2^-16. The culling rejects a ray when |f x d|^2 > |d|^2
/// reach^2 with reach = r + margin (|f|_1 + r), f = origin - centre (the
/// line passes farther than the radius from the centre), or when f.d >
/// margin |f|_1 |d|_1 and |f|^2 > r^2 (1 + margin) (the origin is outside
/// and moves away). Its sums of products carry at most about 8 ulps
/// (2^-21) of |f| |d| (f is itself rounded once) and its squares a few
/// more, so 2^-16 of the sizes involved covers every rounding with a
/// factor of 8 to spare, and the f64 test's own rounding (2^-50 relative)
/// vanishes beside it: a culled ray is one that [`Sphere::intersect`]
/// misses at every `t_max`. The cost of the margin is culling nothing
/// within 1.5e-5 of the sphere.
pub(crate) const CULL_MARGIN: f32 = 1.0 / 65_536.0;

impl Sphere {
    /// Whether the sphere can be hit: finite centre, finite radius > 0.
    #[must_use]
    pub fn is_valid(&self) -> bool {
        self.center.is_finite() && self.radius.is_finite() && self.radius > 0.0
    }

    /// Axis-aligned bounds `(min, max)`, rounded outward so that every f32
    /// point of the sphere is inside.
    #[must_use]
    pub fn bounds(&self) -> (Vec3, Vec3) {
        let r = self.radius.max(0.0);
        // One ulp of the largest term covers the rounding of c -+ r.
        let slack = (self.center.abs() + Vec3::splat(r)) * f32::EPSILON;
        (
            self.center - Vec3::splat(r) - slack,
            self.center + Vec3::splat(r) + slack,
        )
    }

    /// The ray parameter of the closest hit of `origin + t * direction`
    /// with `0 < t < t_max`, in f64 (Ray Tracing Gems ch. 7, see the module
    /// docs). `None` for a miss, a tangent graze that rounds to a negative
    /// discriminant, or degenerate input.
    #[inline]
    #[must_use]
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f64) -> Option<f64> {
        let (t0, t1) = self.roots(origin.as_dvec3(), direction.as_dvec3())?;
        if t0 > 0.0 && t0 < t_max {
            Some(t0)
        } else if t1 > 0.0 && t1 < t_max {
            Some(t1)
        } else {
            None
        }
    }

    /// Both ray parameters where the line `origin + t * direction` meets
    /// the sphere, smaller first.
    #[inline]
    fn roots(&self, origin: DVec3, direction: DVec3) -> Option<(f64, f64)> {
        let r = f64::from(self.radius);
        let f = origin - self.center.as_dvec3();
        let a = direction.length_squared();
        let b_half = f.dot(direction);
        // Eq. 7.5: the discriminant over 4a from the centre's distance to the line.
        let perpendicular = f - (b_half / a) * direction;
        let disc = a * (r * r - perpendicular.length_squared());
        if !(disc >= 0.0) || !(a > 0.0) {
            return None;
        }
        let c = f.length_squared() - r * r;
        // Eq. 7.8: q = -(b + sign(b) sqrt(b^2 - 4ac)) / 2, with b = 2 b_half.
        let q = -(b_half + disc.sqrt().copysign(b_half));
        let (t0, t1) = if q == 0.0 {
            // Origin at the centre-line's closest point and on the sphere
            // (c = 0, b = 0): the single root 0.
            (0.0, 0.0)
        } else {
            (c / q, q / a)
        };
        let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
        (t0.is_finite() && t1.is_finite()).then_some((t0, t1))
    }

    /// The hit of the ray `origin + t * direction` nearest to `t` (a
    /// parameter returned for this sphere by a BVH query), reprojected onto
    /// the sphere (pbrt-v4 `Sphere::Intersect`: pHit *= radius /
    /// Distance(pHit, 0), here in f64), with a per-coordinate bound of its
    /// error for [`crate::offset_ray_origin_bounded`]. Returns the outward
    /// unit normal too, from the f64 point (exact to f32 rounding).
    #[must_use]
    pub fn hit_point(&self, origin: Vec3, direction: Vec3, t: f32) -> (Vec3, Vec3, Vec3) {
        let o = origin.as_dvec3();
        let d = direction.as_dvec3();
        let t = match self.roots(o, d) {
            Some((t0, t1)) => {
                let t = f64::from(t);
                if (t0 - t).abs() <= (t1 - t).abs() {
                    t0
                } else {
                    t1
                }
            }
            None => f64::from(t),
        };
        let c = self.center.as_dvec3();
        let local = o - c + t * d;
        let n = local.try_normalize().unwrap_or(DVec3::Z);
        let p = (c + n * f64::from(self.radius)).as_vec3();
        let floor = HIT_POINT_ABSOLUTE_ERROR
            * (f64::from(self.center.abs().max_element()) + f64::from(self.radius));
        let error = p.abs() * HIT_POINT_RELATIVE_ERROR + Vec3::splat(floor as f32);
        (p, n.as_vec3(), error)
    }

    /// The point of the sphere in unit direction `n` from its centre, its
    /// error bound as in [`Sphere::hit_point`] (sampled light points).
    #[must_use]
    pub fn point_at(&self, n: Vec3) -> (Vec3, Vec3) {
        let p = (self.center.as_dvec3() + n.as_dvec3() * f64::from(self.radius)).as_vec3();
        let floor = HIT_POINT_ABSOLUTE_ERROR
            * (f64::from(self.center.abs().max_element()) + f64::from(self.radius));
        (
            p,
            p.abs() * HIT_POINT_RELATIVE_ERROR + Vec3::splat(floor as f32),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn unit_sphere_from_outside_and_inside() {
        let s = Sphere {
            center: Vec3::ZERO,
            radius: 1.0,
        };
        let t = s.intersect(Vec3::new(0.0, 0.0, -3.0), Vec3::Z, f64::INFINITY);
        assert_eq!(t, Some(2.0));
        // Non-unit direction: t in units of its length.
        let t = s.intersect(Vec3::new(0.0, 0.0, -3.0), Vec3::Z * 4.0, f64::INFINITY);
        assert_eq!(t, Some(0.5));
        // From the centre: the far root.
        assert_eq!(s.intersect(Vec3::ZERO, Vec3::X, f64::INFINITY), Some(1.0));
        // t_max is exclusive; behind the origin is not hit.
        assert_eq!(s.intersect(Vec3::new(0.0, 0.0, -3.0), Vec3::Z, 2.0), None);
        assert_eq!(
            s.intersect(Vec3::new(0.0, 0.0, 3.0), Vec3::Z, f64::INFINITY),
            None
        );
        let (p, n, e) = s.hit_point(Vec3::new(0.3, 0.2, -3.0), Vec3::Z, 2.1);
        assert!((p.length() - 1.0).abs() < 1e-6 && (n - p).length() < 1e-6);
        assert!(e.max_element() < 1e-6);
    }

    #[test]
    fn bounds_contain_the_sphere() {
        let s = Sphere {
            center: Vec3::new(1e4, -3.0, 0.1),
            radius: 0.3,
        };
        let (lo, hi) = s.bounds();
        for n in [Vec3::X, -Vec3::X, Vec3::Y, -Vec3::Y, Vec3::Z, -Vec3::Z] {
            let (p, _) = s.point_at(n);
            assert!(p.cmpge(lo).all() && p.cmple(hi).all(), "{p}");
        }
    }
}
