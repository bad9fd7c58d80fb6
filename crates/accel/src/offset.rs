//! Self-intersection avoidance for secondary rays (Wächter and Binder, "A Fast
//! and Robust Method for Avoiding Self-Intersection", Ray Tracing Gems, ch. 6).

use glam::Vec3;

/// Coordinates with magnitude below this use the float fallback: near zero,
/// ULPs become tiny (down to denormals) while the error of a computed hit
/// point does not (it scales with the magnitude of the triangle's vertices).
/// The chapter's `origin()` (1/32).
const ORIGIN: f32 = 1.0 / 32.0;
/// Fallback offset, in world units per unit of normal, near the origin: the
/// chapter's `float_scale()` (1/65536), for triangles whose vertices reach
/// `ORIGIN` or beyond; scaled down for smaller ones by
/// [`offset_ray_origin_scaled`].
const FLOAT_SCALE: f32 = 1.0 / 65536.0;
/// Offset in ULPs per unit of normal away from the origin: the chapter's
/// `int_scale()` (256).
const INT_SCALE: f32 = 256.0;
/// Smallest geometry scale the fallback follows down (2^-40 = 9e-13): smaller
/// scenes are not supported, and a point exactly at the origin still moves
/// (by at least 2^-51 = 4e-16 per unit of normal).
const MIN_SCALE: f32 = 1.0 / 1_099_511_627_776.0;
/// A normal whose squared length is within this of 1 is used as it is: the
/// offset then differs from the normalized one's by under 0.1 %, far below
/// what matters for an offset of a few hundred ULPs.
const UNIT_TOLERANCE: f32 = 1e-3;

/// Moves a surface point off its surface, along the geometric normal, so that
/// a ray starting there does not hit the surface it starts on again
/// (Ray Tracing Gems, ch. 6).
///
/// Away from the world origin (coordinate magnitude at least 1/32) each
/// coordinate moves by `256 * n_i` units in the last place (an integer step of
/// its bit pattern), so the offset scales with the coordinate's own precision
/// instead of a scene-scale epsilon; coordinates closer to zero than 1/32 move
/// by `n_i / 65536` in world units instead. The offset is a few hundred ULPs of
/// `p`: much larger than the error of a hit point computed from barycentrics,
/// much smaller than any geometry the renderer resolves.
///
/// * `p`: a point on a triangle. Compute it from the hit's barycentrics,
///   `(1 - b1 - b2) * v0 + b1 * v1 + b2 * v2`, rather than as `origin + t *
///   direction` (whose error grows with the distance travelled).
/// * `n_geometric`: the triangle's geometric normal (`(v1 - v0) x (v2 - v0)`,
///   not the shading normal), flipped to the side the new ray leaves to: for a
///   new direction `d`, pass `n` if `n.dot(d) > 0` and `-n` otherwise (so
///   reflection and transmission both work). It need not be normalized.
///
/// Use the returned point as the new ray's origin with no t epsilon
/// (`Bvh::intersect` and `Bvh::occluded` count hits at any `t > 0`). For a
/// shadow or connection ray towards another surface point `q` with normal
/// `m`, offset both ends (`o = offset_ray_origin(p, n_toward_q)`,
/// `q' = offset_ray_origin(q, m_toward_p)`) and test `occluded(o, q' - o, 1.0)`.
///
/// Returns `p` unchanged when `n_geometric` is zero or not finite. Assumes a
/// finite `p` (a non-finite `p` is returned as is).
///
/// Limitation: the fallback near the origin is tuned, as in the chapter, for
/// scenes of roughly unit scale: for geometry much smaller than 1/32 placed
/// around the world origin the offset (1/65536 along the normal) is large
/// compared with the geometry, and a closed box of size 1e-5 or smaller there
/// is jumped over (every ray spawned inside it starts outside and escapes).
/// Use [`offset_ray_origin_scaled`] with the hit triangle's size for such
/// scenes. (The fallback cannot follow |p| instead: a unit-size triangle
/// hit within 1e-3 of the origin has a hit-point error of ~ULP(1), and an
/// offset proportional to |p| then self-intersected, 3 % of rays at
/// |p| = 1e-4.)
///
/// [`Bvh::intersect`]: crate::Bvh::intersect
/// [`Bvh::occluded`]: crate::Bvh::occluded
#[must_use]
pub fn offset_ray_origin(p: Vec3, n_geometric: Vec3) -> Vec3 {
    offset_ray_origin_scaled(p, n_geometric, f32::INFINITY)
}

/// [`offset_ray_origin`] for geometry of any scale near the origin.
///
/// `scale` is the largest coordinate magnitude of the triangle's vertices
/// (`max |v_i|` over its three vertices and their components): the error
/// of a hit point interpolated from them scales with it, not with the hit
/// point, which can be near zero on a large triangle. Coordinates of `p`
/// below 1/32 then move by `n_i * scale / 2048` (the chapter's 1/65536 at
/// scale 1/32; 4000 ULPs of `scale`), capped at the chapter's 1/65536 for
/// scale >= 1/32 and floored at scale 2^-40; coordinates from 1/32 up move by
/// 256 ULPs as in the chapter. A scale of infinity (or NaN) gives
/// [`offset_ray_origin`] exactly.
#[must_use]
pub fn offset_ray_origin_scaled(p: Vec3, n_geometric: Vec3, scale: f32) -> Vec3 {
    // Callers mostly pass unit normals: normalizing only the others makes the
    // function 5x faster (criterion bench `offset`: 36 -> 7 ns per call).
    let n = if (n_geometric.length_squared() - 1.0).abs() <= UNIT_TOLERANCE {
        n_geometric
    } else {
        n_geometric.normalize_or_zero()
    };
    if n == Vec3::ZERO {
        return p;
    }
    let fallback = fallback_offset(scale);
    Vec3::new(
        offset_component(p.x, n.x, fallback),
        offset_component(p.y, n.y, fallback),
        offset_component(p.z, n.z, fallback),
    )
}

/// Moves a point `p` whose coordinates are within `error` of the surface
/// (a per-coordinate bound) off it along the unit normal `n` (flipped to
/// the side the new ray leaves to): pbrt-v4's `OffsetRayOrigin`
/// (Interaction.h; Pharr, Jakob and Humphreys, 4th ed., §6.8.6): by
/// d = |n| . error along n, each coordinate then rounded one float further
/// along n (pbrt-v4 rounds only where the offset is non-zero; here a
/// zero error still moves one float), so the origin lies outside the error box on the side of
/// `n`. For points whose error is known in closed form (a reprojected
/// sphere point, [`crate::Sphere::hit_point`]); triangle points use
/// [`offset_ray_origin`].
///
/// Returns `p` unchanged when `n` is zero or not finite.
#[must_use]
pub fn offset_ray_origin_bounded(p: Vec3, n: Vec3, error: Vec3) -> Vec3 {
    let n = if (n.length_squared() - 1.0).abs() <= UNIT_TOLERANCE {
        n
    } else {
        n.normalize_or_zero()
    };
    if n == Vec3::ZERO {
        return p;
    }
    let d = n.abs().dot(error);
    let offset = d * n;
    let mut o = p + offset;
    for i in 0..3 {
        if n[i] > 0.0 {
            o[i] = o[i].next_up();
        } else if n[i] < 0.0 {
            o[i] = o[i].next_down();
        }
    }
    if o.is_finite() { o } else { p }
}

/// World-space offset per unit of normal for coordinates below `ORIGIN`:
/// `FLOAT_SCALE * scale / ORIGIN` (= scale / 2048) for scale in
/// [`MIN_SCALE`, `ORIGIN`], the chapter's `FLOAT_SCALE` above (and for NaN).
#[inline]
fn fallback_offset(scale: f32) -> f32 {
    if !(scale < ORIGIN) {
        return FLOAT_SCALE;
    }
    FLOAT_SCALE * (scale.max(MIN_SCALE) / ORIGIN)
}

/// One coordinate of [`offset_ray_origin_scaled`]. Every case is computed
/// and one is selected, without branches: with a branch per coordinate the
/// three results went through the stack, and the wavefront path tracer's
/// next reads of the origin waited on those narrow stores.
#[inline]
fn offset_component(p: f32, n: f32, fallback: f32) -> f32 {
    // Near the origin: a fixed offset along n.
    let near = p + fallback * n;
    // Truncation toward zero, as the chapter's int conversion; |n| <= 1.
    let of_i = (INT_SCALE * n) as i32;
    // Sign-magnitude bits: adding to the magnitude moves away from zero, so a
    // negative coordinate needs the opposite step to move along +n.
    let step = if p < 0.0 { of_i.wrapping_neg() } else { of_i };
    let moved = f32::from_bits((p.to_bits() as i32).wrapping_add(step) as u32);
    // Never step into infinity or NaN at the top of the float range.
    let far = if moved.is_finite() { moved } else { p };
    let offset = if p.abs() < ORIGIN { near } else { far };
    if p.is_finite() { offset } else { p }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn moves_along_the_normal_in_ulps() {
        let p = Vec3::new(1.0, -2.0, 0.01);
        let o = offset_ray_origin(p, Vec3::new(0.0, 0.0, 3.0));
        assert_eq!(o.x, 1.0);
        assert_eq!(o.y, -2.0);
        assert_eq!(o.z, 0.01 + 1.0 / 65536.0);

        let o = offset_ray_origin(p, Vec3::X);
        assert_eq!(o.x.to_bits(), 1.0f32.to_bits() + 256);
        let o = offset_ray_origin(p, -Vec3::X);
        assert_eq!(o.x.to_bits(), 1.0f32.to_bits() - 256);
        // Negative coordinate moved along +y: magnitude shrinks.
        let o = offset_ray_origin(p, Vec3::Y);
        assert!(o.y > -2.0);
        assert_eq!(o.y.to_bits(), (-2.0f32).to_bits() - 256);
        let o = offset_ray_origin(p, -Vec3::Y);
        assert!(o.y < -2.0);
    }

    #[test]
    fn every_component_moves_to_the_normal_side() {
        for &s in &[1e-6f32, 1e-3, 0.5, 1.0, 1e3, 1e6] {
            for n in [Vec3::new(0.3, -0.5, 0.8), Vec3::new(-0.7, 0.1, -0.2)] {
                let p = Vec3::new(s, -s, 0.5 * s);
                let o = offset_ray_origin(p, n);
                assert!((o - p).dot(n) > 0.0, "{s} {n}");
            }
        }
    }

    /// The scaled fallback: the chapter's 1/65536 from scale 1/32 up (and for
    /// an infinite scale, which is `offset_ray_origin`), scale/2048 below.
    #[test]
    fn fallback_follows_the_geometry_scale() {
        let p = Vec3::new(1e-6, -2e-6, 0.0);
        for scale in [1.0f32 / 32.0, 1.0, f32::INFINITY, f32::NAN] {
            let o = offset_ray_origin_scaled(p, Vec3::Z, scale);
            assert_eq!(o.z, 1.0 / 65536.0);
        }
        assert_eq!(offset_ray_origin(p, Vec3::Z).z, 1.0 / 65536.0);
        let o = offset_ray_origin_scaled(p, Vec3::Z, 1.0 / 64.0);
        assert_eq!(o.z, 1.0 / 131_072.0);
        let o = offset_ray_origin_scaled(p, Vec3::Z, 4e-6);
        assert!((o.z - 4e-6 / 2048.0).abs() < 1e-15, "{o}");
        assert_eq!((o.x, o.y), (p.x, p.y));
        let o = offset_ray_origin_scaled(Vec3::ZERO, -Vec3::Y, 0.0);
        assert_eq!(o.y, -MIN_SCALE / 2048.0);
        // Away from the origin the scale does not matter.
        let q = Vec3::new(1.0, 2.0, 3.0);
        assert_eq!(
            offset_ray_origin_scaled(q, Vec3::X, 1e-6),
            offset_ray_origin(q, Vec3::X)
        );
    }

    #[test]
    fn bounded_offset_leaves_the_error_box() {
        let p = Vec3::new(1.0, -2.0, 1e-3);
        let e = Vec3::new(1e-6, 2e-6, 1e-9);
        let n = Vec3::new(0.6, 0.0, -0.8);
        let o = offset_ray_origin_bounded(p, n, e);
        // Beyond the plane through the box's farthest corner along n.
        assert!((o - p).dot(n) > n.abs().dot(e));
        assert_eq!(offset_ray_origin_bounded(p, Vec3::ZERO, e), p);
        // Zero error still moves by one float.
        let o = offset_ray_origin_bounded(p, Vec3::X, Vec3::ZERO);
        assert_eq!(o.x, 1.0f32.next_up());
    }

    #[test]
    fn degenerate_inputs_return_p() {
        let p = Vec3::new(1.0, 2.0, 3.0);
        assert_eq!(offset_ray_origin(p, Vec3::ZERO), p);
        assert_eq!(offset_ray_origin(p, Vec3::NAN), p);
        let big = Vec3::splat(f32::MAX);
        assert_eq!(offset_ray_origin(big, Vec3::ONE), big);
        let inf = Vec3::new(f32::INFINITY, 0.0, 0.0);
        let o = offset_ray_origin(inf, Vec3::X);
        assert_eq!(o.x, f32::INFINITY);
    }
}
