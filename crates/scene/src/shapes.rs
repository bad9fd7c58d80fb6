//! Analytic shapes a manifest can place (tessellated on load), so bundled
//! scenes stay small and hand-written.

use glam::{Vec2, Vec3};

/// A triangle with per-vertex normals and texture coordinates.
pub type ShapeTriangle = ([Vec3; 3], [Vec3; 3], [Vec2; 3]);

/// The parallelogram origin + s u + t v, (s, t) in [0, 1]^2, facing u x v.
pub fn quad(origin: Vec3, u: Vec3, v: Vec3) -> Vec<ShapeTriangle> {
    let n = u
        .as_dvec3()
        .cross(v.as_dvec3())
        .normalize_or_zero()
        .as_vec3();
    let (p00, p10, p11, p01) = (origin, origin + u, origin + u + v, origin + v);
    let (t00, t10, t11, t01) = (
        Vec2::new(0.0, 1.0),
        Vec2::new(1.0, 1.0),
        Vec2::new(1.0, 0.0),
        Vec2::ZERO,
    );
    vec![
        ([p00, p10, p11], [n; 3], [t00, t10, t11]),
        ([p00, p11, p01], [n; 3], [t00, t11, t01]),
    ]
}

/// A sphere (or a cap of it: the part within `cap_degrees` of `axis`),
/// tessellated in `rings` x 2 `rings` quads with smooth normals. With
/// `inside`, the normals and winding face the centre (a concave mirror).
pub fn sphere(
    center: Vec3,
    radius: f32,
    axis: Vec3,
    cap_degrees: f32,
    rings: u32,
    inside: bool,
) -> Vec<ShapeTriangle> {
    let axis = axis.try_normalize().unwrap_or(Vec3::Y);
    let tangent = axis.any_orthonormal_vector();
    let bitangent = axis.cross(tangent);
    let theta_max = cap_degrees.clamp(0.0, 180.0).to_radians();
    let (rings, segments) = (rings.max(2), 2 * rings.max(2));
    let point = |i: u32, j: u32| {
        let theta = theta_max * i as f32 / rings as f32;
        let phi = std::f32::consts::TAU * j as f32 / segments as f32;
        let n = axis * theta.cos() + (tangent * phi.cos() + bitangent * phi.sin()) * theta.sin();
        (
            center + radius * n,
            if inside { -n } else { n },
            Vec2::new(j as f32 / segments as f32, i as f32 / rings as f32),
        )
    };
    let mut out = Vec::with_capacity((rings * segments * 2) as usize);
    for i in 0..rings {
        for j in 0..segments {
            let (a, b, c, d) = (
                point(i, j),
                point(i + 1, j),
                point(i + 1, j + 1),
                point(i, j + 1),
            );
            for tri in [[a, b, c], [a, c, d]] {
                let mut t = (
                    [tri[0].0, tri[1].0, tri[2].0],
                    [tri[0].1, tri[1].1, tri[2].1],
                    [tri[0].2, tri[1].2, tri[2].2],
                );
                if (t.0[1] - t.0[0]).cross(t.0[2] - t.0[0]).length_squared() == 0.0 {
                    continue; // the fan around a pole
                }
                // Counter-clockwise around the outward normal, or the inward one.
                let facing = (t.0[1] - t.0[0])
                    .cross(t.0[2] - t.0[0])
                    .dot(t.1[0] + t.1[1] + t.1[2]);
                if facing < 0.0 {
                    t.0.swap(1, 2);
                    t.1.swap(1, 2);
                    t.2.swap(1, 2);
                }
                out.push(t);
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sphere_area_and_orientation() {
        let tris = sphere(Vec3::ONE, 2.0, Vec3::Y, 180.0, 48, false);
        let area: f32 = tris
            .iter()
            .map(|(p, _, _)| 0.5 * (p[1] - p[0]).cross(p[2] - p[0]).length())
            .sum();
        // Tessellation slightly underestimates 4 pi r^2.
        assert!(
            (area / (16.0 * std::f32::consts::PI) - 1.0).abs() < 5e-3,
            "{area}"
        );
        for (p, n, _) in &tris {
            let g = (p[1] - p[0]).cross(p[2] - p[0]);
            assert!(
                g.length() == 0.0 || g.dot(p[0] - Vec3::ONE) > 0.0,
                "outward winding"
            );
            assert!(n.iter().all(|n| (n.length() - 1.0).abs() < 1e-5));
        }
        let inside = sphere(Vec3::ZERO, 1.0, Vec3::Y, 60.0, 16, true);
        for (p, _, _) in &inside {
            let g = (p[1] - p[0]).cross(p[2] - p[0]);
            assert!(g.length() == 0.0 || g.dot(p[0]) < 0.0, "inward winding");
        }
    }
}
