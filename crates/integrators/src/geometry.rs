//! Surface points: the shading frame and the data of a ray hit; the
//! scene's bounding sphere.

use accel::Hit;
use glam::{Vec2, Vec3};
use scene::Scene;

/// The sphere around the scene's bounding box: where lights at infinity
/// emit from, and the scale of the merge radius.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BoundingSphere {
    /// Centre of the bounding box.
    pub centre: Vec3,
    /// Half the box's diagonal, at least [`MIN_SCENE_RADIUS`].
    pub radius: f32,
}

/// Smallest bounding radius: keeps a scene of one point (or none) from a
/// zero radius, which would divide by zero in the emission density of
/// lights at infinity.
pub const MIN_SCENE_RADIUS: f32 = 1e-3;

impl BoundingSphere {
    /// The bounding sphere of `scene`'s triangles and spheres.
    pub fn of(scene: &Scene) -> Self {
        let (lo, hi) = scene.bounds();
        Self {
            centre: 0.5 * (lo + hi),
            radius: (0.5 * (hi - lo).length()).max(MIN_SCENE_RADIUS),
        }
    }
}

/// An orthonormal frame around a normal; BSDFs work in it with the normal as +z.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Frame {
    /// First tangent.
    pub s: Vec3,
    /// Second tangent.
    pub t: Vec3,
    /// The normal.
    pub n: Vec3,
}

impl Frame {
    /// A frame around unit `n` (Duff et al. 2017, "Building an orthonormal
    /// basis, revisited"), exact for every unit `n` including n.z = -1.
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        Self {
            s: Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x),
            t: Vec3::new(b, sign + n.y * n.y * a, -n.y),
            n,
        }
    }

    /// World direction in frame coordinates.
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }

    /// Frame direction in world coordinates.
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }

    /// The same frame seen from the other side (normal negated, right-handed).
    pub fn flipped(&self) -> Self {
        Self {
            s: self.t,
            t: self.s,
            n: -self.n,
        }
    }
}

/// What a ray hit: position, normals, texture coordinates and material.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SurfacePoint {
    /// Position, interpolated from the triangle's vertices (more accurate
    /// than origin + t direction far from the origin), or on a sphere
    /// recomputed in f64 and reprojected onto it.
    pub p: Vec3,
    /// Unit geometric normal from the triangle's winding: the emitting side of
    /// an area light.
    pub n_winding: Vec3,
    /// Unit geometric normal, on the side of the shading normal.
    pub ng: Vec3,
    /// Shading frame around the interpolated normal.
    pub frame: Frame,
    /// Texture coordinates.
    pub uv: Vec2,
    /// Primitive id ([`accel::Hit::primitive`]): a triangle index, or the
    /// triangle count plus a sphere index.
    pub primitive: u32,
    /// Material index.
    pub material: u32,
    /// The error of `p`, which a ray leaving it must clear.
    pub error: PointError,
}

/// How far a computed surface point may lie from its surface: what a
/// ray-origin offset must clear.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum PointError {
    /// Interpolated from triangle vertices whose largest coordinate
    /// magnitude is this ([`vertex_scale`]; infinity for a point light):
    /// the Wächter-Binder offset (`accel::offset_ray_origin_scaled`).
    Vertices(f32),
    /// At most this per coordinate (a reprojected sphere point,
    /// `accel::Sphere::hit_point`): pbrt-v4's offset
    /// (`accel::offset_ray_origin_bounded`).
    Bounded(Vec3),
}

impl PointError {
    /// `p` moved off its surface along `n` (on the side the new ray
    /// leaves to) by enough to clear this error.
    #[inline]
    pub fn offset(self, p: Vec3, n: Vec3) -> Vec3 {
        match self {
            Self::Vertices(scale) => accel::offset_ray_origin_scaled(p, n, scale),
            Self::Bounded(error) => accel::offset_ray_origin_bounded(p, n, error),
        }
    }
}

/// The largest coordinate magnitude of a triangle's vertices: the error of
/// a point interpolated from them scales with it (`accel::offset_ray_origin_scaled`).
pub fn vertex_scale(triangle: &[Vec3; 3]) -> f32 {
    triangle
        .iter()
        .map(|v| v.abs().max_element())
        .fold(0.0, f32::max)
}

impl SurfacePoint {
    /// The surface point of `hit` in `scene`, whose triangle has the
    /// geometric normal `n_winding` ([`Scene::geometric_normal`]) and the
    /// vertex scale `scale` ([`vertex_scale`]).
    pub fn new(scene: &Scene, n_winding: Vec3, scale: f32, hit: &Hit) -> Self {
        let i = hit.primitive as usize;
        let b = Vec3::new(1.0 - hit.b1 - hit.b2, hit.b1, hit.b2);
        let interpolate = |v: [Vec3; 3]| v[0] * b.x + v[1] * b.y + v[2] * b.z;
        // Without vertex normals the shading normal is the geometric one,
        // as it is: interpolating three copies and renormalizing only added
        // rounding, and a square root and a division to every hit's chain.
        let ns = if scene.normals.is_empty() {
            n_winding
        } else {
            interpolate(scene.shading_normals(i, n_winding))
                .try_normalize()
                .unwrap_or(n_winding)
        };
        let ng = if ns.dot(n_winding) < 0.0 {
            -n_winding
        } else {
            n_winding
        };
        let uv = scene.triangle_uvs(i);
        Self {
            p: interpolate(scene.triangle(i)),
            n_winding,
            ng,
            frame: Frame::from_normal(ns),
            uv: uv[0] * b.x + uv[1] * b.y + uv[2] * b.z,
            primitive: hit.primitive,
            material: scene.triangle_materials[i],
            error: PointError::Vertices(scale),
        }
    }

    /// The point of analytic sphere `sphere` (primitive id `primitive`) in
    /// outward unit direction `n` from its centre, at `p` with error bound
    /// `error` (`accel::Sphere::hit_point`): geometric and shading normal
    /// are the exact normal (facing the centre for an `inside` sphere), uv
    /// the sphere's parametrisation when `reads_uv` (an arc tangent and an
    /// arc cosine), else zero.
    pub fn on_sphere(
        sphere: &scene::Sphere,
        primitive: u32,
        p: Vec3,
        n: Vec3,
        error: Vec3,
        reads_uv: bool,
    ) -> Self {
        let n_winding = if sphere.inside { -n } else { n };
        Self {
            p,
            n_winding,
            ng: n_winding,
            frame: Frame::from_normal(n_winding),
            uv: if reads_uv { sphere.uv(n) } else { Vec2::ZERO },
            primitive,
            material: sphere.material,
            error: PointError::Bounded(error),
        }
    }

    /// The geometric normal on the side of `w` (for ray-origin offsetting).
    pub fn ng_towards(&self, w: Vec3) -> Vec3 {
        if self.ng.dot(w) < 0.0 {
            -self.ng
        } else {
            self.ng
        }
    }

    /// Origin of a ray leaving in direction `w` (Wächter and Binder offset,
    /// scaled for geometry far below unit size near the origin).
    pub fn spawn_origin(&self, w: Vec3) -> Vec3 {
        self.error.offset(self.p, self.ng_towards(w))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frames_are_orthonormal_and_round_trip() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.81).normalize(),
            Vec3::new(1e-8, 0.0, -1.0).normalize(),
        ] {
            for f in [Frame::from_normal(n), Frame::from_normal(n).flipped()] {
                assert!((f.s.cross(f.t) - f.n).length() < 1e-5, "{n}");
                assert!(f.s.dot(f.t).abs() < 1e-6 && f.s.dot(f.n).abs() < 1e-6);
                let v = Vec3::new(0.2, -0.7, 0.4);
                assert!((f.to_world(f.to_local(v)) - v).length() < 1e-6);
                assert!((f.to_local(f.n) - Vec3::Z).length() < 1e-6);
            }
        }
    }
}
