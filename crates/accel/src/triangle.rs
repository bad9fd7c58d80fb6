//! Watertight ray/triangle intersection (Woop, Benthin and Wald, "Watertight
//! Ray/Triangle Intersection", JCGT 2(1), 2013), as in pbrt-v3/v4.
//!
//! The ray is translated to the origin, its axes permuted so that the largest
//! direction component becomes z, and sheared so that the direction becomes
//! (0, 0, 1). The 2D edge functions of the transformed vertices are then exact
//! functions of the transformed vertices, which are computed identically for a
//! vertex shared by two triangles: a ray through a shared edge or vertex hits
//! at least one of the triangles that share it (no cracks), and edges count as
//! inside (inclusive test). Edge functions that evaluate to exactly zero in f32
//! are recomputed in f64, as the paper recommends.

use glam::{DVec3, Mat3A, Vec3, Vec3A};

/// Per-ray constants of the watertight test.
#[derive(Clone, Copy, Debug)]
pub(crate) struct RayTransform {
    origin: Vec3A,
    /// Permute, shear and scale in one matrix. Each output component is a
    /// single rounded product added to one exact term (the other term is an
    /// exact zero), so it equals the paper's `A[kx] - Sx * A[kz]` bit for bit,
    /// times the power of two `scale`.
    shear: Mat3A,
    /// The permutation `[kx, ky, kz]`: `shear`'s columns `kx` and `ky` are
    /// `scale` times the unit vectors x and y, column `kz` the shear.
    axes: [u8; 3],
}

impl RayTransform {
    /// Constants for a ray with a finite origin and a finite, non-zero
    /// direction.
    ///
    /// `scale` (a power of two) multiplies the transformed coordinates, so
    /// that edge functions (quadratic in the coordinates) stay within f32
    /// range: pass about one over the largest coordinate magnitude of the
    /// scene and the origin. The distances that
    /// [`RayTransform::intersect`] takes and returns are then `scale` times
    /// the ray parameter of `direction`.
    #[inline]
    pub(crate) fn new(origin: Vec3, direction: Vec3, scale: f32) -> Self {
        let d = direction.abs();
        let kz = if d.x > d.y {
            if d.x > d.z { 0 } else { 2 }
        } else if d.y > d.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        if direction[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let rz = 1.0 / direction[kz];
        let sx = direction[kx] * rz;
        let sy = direction[ky] * rz;
        // Column j of the matrix multiplies coordinate j: selected by value
        // rather than stored at indices (a store-and-reload through the stack).
        let column = |j: usize| {
            if j == kx {
                Vec3A::new(scale, 0.0, 0.0)
            } else if j == ky {
                Vec3A::new(0.0, scale, 0.0)
            } else {
                Vec3A::new(-sx, -sy, rz) * scale
            }
        };
        Self {
            origin: origin.into(),
            shear: Mat3A::from_cols(column(0), column(1), column(2)),
            axes: [kx as u8, ky as u8, kz as u8],
        }
    }

    /// The ray origin.
    #[inline(always)]
    pub(crate) fn origin(&self) -> Vec3A {
        self.origin
    }

    /// The permute-shear-scale matrix (see the field).
    #[inline(always)]
    pub(crate) fn shear(&self) -> Mat3A {
        self.shear
    }

    /// The permutation `[kx, ky, kz]` of the coordinate axes (see the
    /// `axes` field).
    #[inline(always)]
    pub(crate) fn axes(&self) -> [usize; 3] {
        self.axes.map(usize::from)
    }

    /// Intersects the triangle `v`. Returns `(t, b1, b2)` (barycentric weights
    /// of `v[1]` and `v[2]`) when the ray hits it with `0 < t <= t_max` (inclusive, so that a
    /// closest-hit query can break ties at equal `t`), both
    /// in the scaled units of [`RayTransform::new`].
    /// Both faces count. Degenerate triangles (zero area) never hit.
    #[inline(always)]
    pub(crate) fn intersect(&self, v: &[Vec3A; 3], t_max: f32) -> Option<(f32, f32, f32)> {
        // `leaf.rs` repeats these operations lane by lane: keep them in step.
        let a = self.shear * (v[0] - self.origin);
        let b = self.shear * (v[1] - self.origin);
        let c = self.shear * (v[2] - self.origin);

        let mut e0 = c.x * b.y - c.y * b.x;
        let mut e1 = a.x * c.y - a.y * c.x;
        let mut e2 = b.x * a.y - b.y * a.x;
        if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
            e0 = edge_f64(c, b);
            e1 = edge_f64(a, c);
            e2 = edge_f64(b, a);
        }
        if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
            return None;
        }
        let det = e0 + e1 + e2;
        if det == 0.0 {
            return None;
        }
        // Barycentrics first, then t as their blend of the vertices' z (the
        // shear already divided z by d[kz]): every intermediate stays linear
        // or quadratic in the coordinates, where `e * z / det` would be cubic
        // and leave f32 range for large or small scenes.
        let inv_det = 1.0 / det;
        let b0 = e0 * inv_det;
        let b1 = e1 * inv_det;
        let b2 = e2 * inv_det;
        let t = b0 * a.z + b1 * b.z + b2 * c.z;
        if t > 0.0 && t <= t_max {
            Some((t, b1, b2))
        } else {
            None
        }
    }
}

/// `p.x * q.y - p.y * q.x` in f64: exact products of f32 inputs.
#[inline(never)]
fn edge_f64(p: Vec3A, q: Vec3A) -> f32 {
    (f64::from(p.x) * f64::from(q.y) - f64::from(p.y) * f64::from(q.x)) as f32
}

/// Whether a triangle has zero area: the cross product of its edges, computed
/// in f64, is exactly zero (repeated vertices, or exactly collinear ones).
pub(crate) fn is_degenerate(v: &[Vec3; 3]) -> bool {
    let p0 = v[0].as_dvec3();
    let e1: DVec3 = v[1].as_dvec3() - p0;
    let e2: DVec3 = v[2].as_dvec3() - p0;
    e1.cross(e2) == DVec3::ZERO
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [Vec3A; 3] {
        [a.into(), b.into(), c.into()]
    }

    #[test]
    fn barycentrics_on_a_non_unit_triangle() {
        // The case that breaks obvhs' compute_barycentric (it scales by 2 * area).
        let v = tri([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        let ray = RayTransform::new(Vec3::new(0.5, 0.25, 1.0), Vec3::NEG_Z, 1.0);
        let (t, b1, b2) = ray.intersect(&v, f32::INFINITY).unwrap();
        assert_eq!(t, 1.0);
        assert_eq!(b1, 0.25);
        assert_eq!(b2, 0.125);
        // From behind, non-unit direction: t is in units of the direction's length.
        let ray = RayTransform::new(Vec3::new(0.5, 0.25, -2.0), Vec3::new(0.0, 0.0, 4.0), 1.0);
        let (t, b1, b2) = ray.intersect(&v, f32::INFINITY).unwrap();
        assert_eq!((t, b1, b2), (0.5, 0.25, 0.125));
    }

    #[test]
    fn scale_keeps_results_and_range() {
        let v = tri([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        let ray = RayTransform::new(Vec3::new(0.5, 0.25, 1.0), Vec3::NEG_Z, 0.25);
        assert_eq!(ray.intersect(&v, f32::INFINITY), Some((0.25, 0.25, 0.125)));
        // Coordinates around 1e20: unscaled, the edge functions overflow f32.
        let big = v.map(|p| p * 1e20);
        let o = Vec3::new(0.5e20, 0.25e20, 1e20);
        assert!(
            RayTransform::new(o, Vec3::NEG_Z, 1.0)
                .intersect(&big, f32::INFINITY)
                .is_none()
        );
        let s = 2f32.powi(-67);
        let (t, b1, b2) = RayTransform::new(o, Vec3::NEG_Z, s)
            .intersect(&big, f32::INFINITY)
            .unwrap();
        assert!((t / s / 1e20 - 1.0).abs() < 1e-6);
        assert!((b1 - 0.25).abs() < 1e-6 && (b2 - 0.125).abs() < 1e-6);
    }

    #[test]
    fn t_range_is_open_below_and_closed_above() {
        let v = tri([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        let ray = RayTransform::new(Vec3::new(0.5, 0.25, 1.0), Vec3::NEG_Z, 1.0);
        assert!(ray.intersect(&v, 1.0f32.next_down()).is_none());
        assert!(ray.intersect(&v, 1.0).is_some());
        let behind = RayTransform::new(Vec3::new(0.5, 0.25, 1.0), Vec3::Z, 1.0);
        assert!(behind.intersect(&v, f32::INFINITY).is_none());
        let on_plane = RayTransform::new(Vec3::new(0.5, 0.25, 0.0), Vec3::Z, 1.0);
        assert!(on_plane.intersect(&v, f32::INFINITY).is_none());
    }

    #[test]
    fn shared_edge_and_vertex_are_hit() {
        // Two triangles sharing the diagonal of the unit square.
        let t0 = tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]);
        let t1 = tri([0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]);
        let d = Vec3::new(0.1, -0.2, -1.0);
        for (x, y) in [
            (0.3, 0.3),
            (0.1, 0.1),
            (0.7, 0.7),
            (0.5, 0.5),
            (0.999, 0.999),
        ] {
            let ray = RayTransform::new(Vec3::new(x, y, 0.0) - d, d, 1.0);
            let hits = [ray.intersect(&t0, 10.0), ray.intersect(&t1, 10.0)];
            assert!(hits.iter().any(Option::is_some), "{x} {y}");
        }
    }

    #[test]
    fn degenerate_triangles_never_hit() {
        let ray = RayTransform::new(Vec3::new(0.5, 0.0, 1.0), Vec3::NEG_Z, 1.0);
        let line = tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [3.0, 0.0, 0.0]);
        let point = tri([0.5, 0.0, 0.0], [0.5, 0.0, 0.0], [0.5, 0.0, 0.0]);
        assert!(ray.intersect(&line, f32::INFINITY).is_none());
        assert!(ray.intersect(&point, f32::INFINITY).is_none());
        assert!(is_degenerate(&[Vec3::ZERO, Vec3::X, Vec3::X * 3.0]));
        assert!(is_degenerate(&[Vec3::ONE, Vec3::ONE, Vec3::ZERO]));
        assert!(!is_degenerate(&[Vec3::ZERO, Vec3::X, Vec3::Y * 1e-30]));
    }
}
