//! Normal and bump maps: the shading normal of a surface point perturbed by
//! its material's [`NormalMap`], in the tangent frame of the triangle.
//!
//! The tangent frame is the file's (glTF `TANGENT`, w the sign of the
//! bitangent) where the triangle has one, otherwise derived per triangle from
//! its uv derivatives (the triangle's dp/du, dp/dv, as pbrt-v3 §3.6.2 derives
//! them for triangle meshes): one constant tangent per triangle, not
//! MikkTSpace's smoothed per-vertex tangents, so normal maps baked against
//! MikkTSpace tangents shade slightly faceted on meshes that lack TANGENT.
//! The glTF convention (spec 3.7.2.1 and 3.9.3) puts the bitangent towards
//! the image's top, i.e. decreasing v (v = 0 is the top row): B = -dp/dv up
//! to orthogonalisation, which fixes the sign w = sign((N x T) . B).
//!
//! The perturbed normal replaces the interpolated one in the shading frame;
//! the geometric normal is untouched, so `PathVertex`'s leak test and the
//! adjoint shading-normal correction of light subpaths (Veach 1997, §5.3)
//! use the same perturbed frame on camera and light subpaths.

use glam::{Vec2, Vec3, Vec4};
use scene::Scene;
use scene::material::{NormalMap, NormalMapKind};

use crate::geometry::{Frame, SurfacePoint};

/// Smallest cosine between a perturbed shading normal and the geometric
/// normal (on the side of the interpolated one). A normal map can tilt the
/// normal past the surface's plane; such a normal is bent back to this
/// cosine, the smallest change that keeps it in the geometric hemisphere
/// (pbrt-v4's `SurfaceInteraction::SetShadingGeometry` only flips the
/// geometric normal to the shading normal's side, which would turn the
/// surface inside out there). 0.01: about 89.4 degrees.
pub const MIN_SHADING_COS: f32 = 0.01;

/// Smallest |det| of a triangle's uv edge matrix for its uv derivatives:
/// below it the uvs are degenerate (all equal, or collinear) and an
/// arbitrary tangent perpendicular to the normal is used.
const MIN_UV_DET: f32 = 1e-12;

/// `point` with its shading normal perturbed by `map` at `point.uv`.
pub fn apply(
    scene: &Scene,
    map: &NormalMap,
    point: &SurfacePoint,
    b1: f32,
    b2: f32,
) -> SurfacePoint {
    let i = point.primitive as usize;
    perturb(
        scene,
        map,
        point,
        |n| tangent_frame(scene, i, n, b1, b2),
        || uv_derivatives(scene, i),
    )
}

/// [`apply`] on an analytic sphere: the tangent frame is the sphere's
/// parametrisation's, dp/du and dp/dv at outward direction `n_outward`
/// (`scene::Sphere::uv_derivatives`), with the bitangent sign of the glTF
/// convention as for triangles without file tangents.
pub fn apply_on_sphere(
    scene: &Scene,
    map: &NormalMap,
    point: &SurfacePoint,
    sphere: &scene::Sphere,
    n_outward: Vec3,
) -> SurfacePoint {
    let (dpdu, dpdv) = sphere.uv_derivatives(n_outward);
    perturb(
        scene,
        map,
        point,
        |n| (dpdu, bitangent_sign(n, dpdu, dpdv)),
        || (dpdu, dpdv),
    )
}

/// The perturbation itself, given the point's tangent and bitangent sign
/// (`tangent(n)`) and its uv derivatives (`derivatives()`), each computed
/// only for the map kind that needs it.
fn perturb(
    scene: &Scene,
    map: &NormalMap,
    point: &SurfacePoint,
    tangent: impl FnOnce(Vec3) -> (Vec3, f32),
    derivatives: impl FnOnce() -> (Vec3, Vec3),
) -> SurfacePoint {
    let Some(texture) = scene.textures.get(map.texture) else {
        return *point;
    };
    let n = point.frame.n;
    let perturbed = match map.kind {
        NormalMapKind::Tangent { scale } => {
            let (tangent, sign) = tangent(n);
            let texel = texture.sample(point.uv).truncate();
            tangent_space_normal(texel, scale, n, tangent, sign)
        }
        NormalMapKind::Height { scale } => {
            let (dpdu, dpdv) = derivatives();
            let (w, h) = (texture.width as f32, texture.height as f32);
            let height = |uv: Vec2| scale * texture.sample(uv).x;
            let h0 = height(point.uv);
            let dhdu = (height(point.uv + Vec2::new(1.0 / w, 0.0)) - h0) * w;
            let dhdv = (height(point.uv + Vec2::new(0.0, 1.0 / h)) - h0) * h;
            bumped_normal(n, dpdu, dpdv, dhdu, dhdv)
        }
    };
    let Some(perturbed) = perturbed else {
        return *point;
    };
    SurfacePoint {
        frame: Frame::from_normal(above(perturbed, point.ng)),
        ..*point
    }
}

/// The glTF bitangent sign of a frame derived from uv derivatives: its
/// bitangent points to decreasing v.
fn bitangent_sign(n: Vec3, dpdu: Vec3, dpdv: Vec3) -> f32 {
    if n.cross(dpdu).dot(-dpdv) < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// The tangent at barycentrics (b1, b2) of triangle `i` and the sign of its
/// bitangent: the file's when it has one, else from the uv derivatives.
fn tangent_frame(scene: &Scene, i: usize, n: Vec3, b1: f32, b2: f32) -> (Vec3, f32) {
    let t = scene.corner_tangents(i);
    if t[0] != Vec4::ZERO {
        let xyz = t[0].truncate() * (1.0 - b1 - b2) + t[1].truncate() * b1 + t[2].truncate() * b2;
        return (xyz, if t[0].w < 0.0 { -1.0 } else { 1.0 });
    }
    let (dpdu, dpdv) = uv_derivatives(scene, i);
    (dpdu, bitangent_sign(n, dpdu, dpdv))
}

/// dp/du and dp/dv of triangle `i` (pbrt-v3 §3.6.2: solve the 2x2 system
/// of its edges against their uv differences); zero for degenerate uvs.
pub fn uv_derivatives(scene: &Scene, i: usize) -> (Vec3, Vec3) {
    let [p0, p1, p2] = scene.triangle(i);
    let [t0, t1, t2] = scene.triangle_uvs(i);
    let (e1, e2) = (p1 - p0, p2 - p0);
    let (d1, d2) = (t1 - t0, t2 - t0);
    let det = d1.x * d2.y - d1.y * d2.x;
    if !(det.abs() > MIN_UV_DET) {
        return (Vec3::ZERO, Vec3::ZERO);
    }
    let inv = 1.0 / det;
    ((d2.y * e1 - d1.y * e2) * inv, (d1.x * e2 - d2.x * e1) * inv)
}

/// The world normal of a tangent-space normal-map `texel` (glTF 2.0 spec
/// 3.9.3: n = normalize((2 rgb - 1) * (scale, scale, 1)) in the frame
/// (T, B, N), T the tangent made orthogonal to N (Gram-Schmidt),
/// B = sign N x T). `None` when the tangent is parallel to N or zero.
pub fn tangent_space_normal(
    texel: Vec3,
    scale: f32,
    n: Vec3,
    tangent: Vec3,
    sign: f32,
) -> Option<Vec3> {
    let t = (tangent - n * n.dot(tangent))
        .try_normalize()
        .unwrap_or_else(|| Frame::from_normal(n).s);
    let b = n.cross(t) * sign;
    let local = (2.0 * texel - Vec3::ONE) * Vec3::new(scale, scale, 1.0);
    (t * local.x + b * local.y + n * local.z).try_normalize()
}

/// The normal of the surface displaced by a height h along `n` (Blinn 1978,
/// as pbrt-v3 §9.3 writes it, without the h dn/du terms: a triangle's
/// interpolated normal varies little across it):
/// dp'/du = dp/du + dh/du n, dp'/dv likewise, n' = dp'/du x dp'/dv, on the
/// side of `n`. `None` for degenerate uv derivatives.
pub fn bumped_normal(n: Vec3, dpdu: Vec3, dpdv: Vec3, dhdu: f32, dhdv: f32) -> Option<Vec3> {
    let cross = (dpdu + dhdu * n).cross(dpdv + dhdv * n).try_normalize()?;
    let unbumped = dpdu.cross(dpdv);
    let sign = if unbumped.dot(n) < 0.0 { -1.0 } else { 1.0 };
    Some(cross * sign)
}

/// `ns` bent towards `ng` until their cosine is at least [`MIN_SHADING_COS`].
pub fn above(ns: Vec3, ng: Vec3) -> Vec3 {
    let c = ns.dot(ng);
    if c >= MIN_SHADING_COS {
        return ns;
    }
    (ns + (MIN_SHADING_COS - c) * ng)
        .try_normalize()
        .unwrap_or(ng)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The flat texel (0.5, 0.5, 1) gives the unperturbed normal; a tilted
    /// one tilts towards the tangent (x) and the bitangent (y) as the
    /// glTF convention says.
    #[test]
    fn tangent_space_decoding() {
        let (n, t) = (Vec3::Z, Vec3::X);
        let flat = tangent_space_normal(Vec3::new(0.5, 0.5, 1.0), 1.0, n, t, 1.0).unwrap();
        assert!((flat - n).length() < 1e-6);
        let x = tangent_space_normal(Vec3::new(1.0, 0.5, 0.5), 1.0, n, t, 1.0).unwrap();
        assert!((x - Vec3::X).length() < 1e-6);
        // B = N x T = +y; a negative sign mirrors it.
        let y = tangent_space_normal(Vec3::new(0.5, 1.0, 0.5), 1.0, n, t, 1.0).unwrap();
        assert!((y - Vec3::Y).length() < 1e-6);
        let y = tangent_space_normal(Vec3::new(0.5, 1.0, 0.5), 1.0, n, t, -1.0).unwrap();
        assert!((y + Vec3::Y).length() < 1e-6);
        // scale 0 flattens any map.
        let s = tangent_space_normal(Vec3::new(1.0, 0.2, 0.7), 0.0, n, t, 1.0).unwrap();
        assert!((s - n).length() < 1e-6);
    }

    #[test]
    fn bump_slope_tilts_against_the_gradient() {
        // Height rising along +x with slope 1: the normal leans to -x by 45 degrees.
        let n = bumped_normal(Vec3::Z, Vec3::X, Vec3::Y, 1.0, 0.0).unwrap();
        assert!((n - Vec3::new(-1.0, 0.0, 1.0).normalize()).length() < 1e-6);
        // Mirrored uvs (dp/dv = -y) keep the normal on the side of n.
        let n = bumped_normal(Vec3::Z, Vec3::X, -Vec3::Y, 0.0, 0.0).unwrap();
        assert!((n - Vec3::Z).length() < 1e-6);
    }

    #[test]
    fn normals_below_the_surface_are_bent_back() {
        let ng = Vec3::Z;
        let below = Vec3::new(1.0, 0.0, -0.3).normalize();
        let bent = above(below, ng);
        assert!(bent.dot(ng) >= MIN_SHADING_COS * 0.99 && bent.x > 0.9);
        let fine = Vec3::new(0.6, 0.0, 0.8);
        assert_eq!(above(fine, ng), fine);
    }
}
