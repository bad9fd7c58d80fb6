//! Mitsuba's built-in shapes as meshes in object space, and what a shape's
//! `to_world`, `flip_normals` and `face_normals` do to a mesh (mitsuba3
//! v3.9.1 `src/shapes/*.cpp`, `src/render/mesh.cpp`; note §2.1, measured).

use glam::{DMat3, DMat4, DVec3, Vec2, Vec3};

use super::MeshData;

/// Segments of a tessellated `disk`: Mitsuba's disk is analytic; a regular
/// polygon of n sides covers n sin(2 pi / n) / (2 pi) of its area, 1 - 1.6e-4
/// here, so an emitting disk loses no more power than that.
pub const DISK_SEGMENTS: u32 = 256;

/// `rectangle`: [-1, 1]^2 at z = 0 facing +z, uv = ((x + 1)/2, (y + 1)/2),
/// Mitsuba's vertex order and faces.
pub fn rectangle() -> MeshData {
    let corners = [(-1.0, -1.0), (1.0, -1.0), (-1.0, 1.0), (1.0, 1.0)];
    MeshData {
        positions: corners.map(|(x, y)| Vec3::new(x, y, 0.0)).to_vec(),
        normals: vec![Vec3::Z; 4],
        uvs: corners
            .map(|(x, y)| Vec2::new(0.5 * (x + 1.0), 0.5 * (y + 1.0)))
            .to_vec(),
        triangles: vec![[1, 2, 0], [1, 3, 2]],
    }
}

/// `cube`: [-1, 1]^3, four vertices per face with its outward normal, each
/// face mapped to uv [0, 1]^2.
pub fn cube() -> MeshData {
    let mut mesh = MeshData::default();
    for axis in 0..3 {
        for sign in [-1.0f32, 1.0] {
            let n = Vec3::from_array(std::array::from_fn(|i| if i == axis { sign } else { 0.0 }));
            // (u, v, n) right-handed, so the face winds counter-clockwise around n.
            let u = Vec3::from_array(std::array::from_fn(|i| {
                if i == (axis + 1) % 3 { 1.0 } else { 0.0 }
            })) * sign;
            let v = n.cross(u);
            let base = mesh.positions.len() as u32;
            for (s, t) in [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)] {
                mesh.positions.push(n + s * u + t * v);
                mesh.normals.push(n);
                mesh.uvs.push(Vec2::new(0.5 * (s + 1.0), 0.5 * (t + 1.0)));
            }
            mesh.triangles
                .extend([[base, base + 1, base + 2], [base, base + 2, base + 3]]);
        }
    }
    mesh
}

/// `disk`: the unit disk at z = 0 facing +z, as [`DISK_SEGMENTS`]
/// triangles around its centre; uv = (r, phi / 2 pi) as Mitsuba's.
pub fn disk() -> MeshData {
    let n = DISK_SEGMENTS;
    let mut mesh = MeshData {
        positions: vec![Vec3::ZERO],
        normals: vec![Vec3::Z],
        uvs: vec![Vec2::ZERO],
        triangles: Vec::with_capacity(n as usize),
    };
    for i in 0..n {
        let phi = std::f32::consts::TAU * i as f32 / n as f32;
        mesh.positions.push(Vec3::new(phi.cos(), phi.sin(), 0.0));
        mesh.normals.push(Vec3::Z);
        mesh.uvs.push(Vec2::new(1.0, i as f32 / n as f32));
        mesh.triangles.push([0, 1 + i, 1 + (i + 1) % n]);
    }
    mesh
}

/// The mesh in world space: positions through `to_world`, normals through
/// its inverse transpose and normalized; `face_normals` drops the file's
/// normals; a mesh without normals gets Mitsuba's smooth vertex normals
/// (below); `flip_normals` negates normals and winding. Mitsuba's
/// one-sided emission and shading follow the shading normal, while ours
/// follow the winding: where `to_world` mirrors (negative determinant) and
/// the normals come from the file, the winding is reversed so that both
/// agree again.
pub fn to_world(mut mesh: MeshData, m: DMat4, flip_normals: bool, face_normals: bool) -> MeshData {
    let normal_matrix = DMat3::from_mat4(m).inverse().transpose();
    let mirrors = DMat3::from_mat4(m).determinant() < 0.0;
    for p in &mut mesh.positions {
        *p = m.transform_point3(p.as_dvec3()).as_vec3();
    }
    if face_normals {
        mesh.normals.clear();
    }
    let from_file = !mesh.normals.is_empty();
    for n in &mut mesh.normals {
        *n = (normal_matrix * n.as_dvec3())
            .try_normalize()
            .unwrap_or(DVec3::ZERO)
            .as_vec3();
    }
    if !from_file && !face_normals {
        mesh.normals = smooth_normals(&mesh.positions, &mesh.triangles);
    }
    if flip_normals != (mirrors && from_file) {
        for t in &mut mesh.triangles {
            t.swap(1, 2);
        }
    }
    if flip_normals {
        for n in &mut mesh.normals {
            *n = -*n;
        }
    }
    mesh
}

/// Vertex normals as the sum of the faces' unit normals weighted by their
/// corner angles (Thürmer & Wüthrich 1998; Mitsuba's
/// `Mesh::recompute_vertex_normals`), zero where no face has area.
pub fn smooth_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut sums = vec![DVec3::ZERO; positions.len()];
    for t in triangles {
        let p = t.map(|i| positions[i as usize].as_dvec3());
        let Some(n) = (p[1] - p[0]).cross(p[2] - p[0]).try_normalize() else {
            continue;
        };
        for k in 0..3 {
            let a = (p[(k + 1) % 3] - p[k]).try_normalize();
            let b = (p[(k + 2) % 3] - p[k]).try_normalize();
            if let (Some(a), Some(b)) = (a, b) {
                let angle = a.dot(b).clamp(-1.0, 1.0).acos();
                sums[t[k] as usize] += n * angle;
            }
        }
    }
    sums.into_iter()
        .map(|s| s.try_normalize().unwrap_or(DVec3::ZERO).as_vec3())
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn area_and_normal(mesh: &MeshData) -> (f32, Vec3) {
        let mut area = 0.0;
        let mut sum = Vec3::ZERO;
        for t in &mesh.triangles {
            let p = t.map(|i| mesh.positions[i as usize]);
            let c = (p[1] - p[0]).cross(p[2] - p[0]);
            area += 0.5 * c.length();
            sum += c;
        }
        (area, sum.normalize_or_zero())
    }

    #[test]
    fn shapes_face_their_normals() {
        let (area, n) = area_and_normal(&rectangle());
        assert_eq!((area, n), (4.0, Vec3::Z));
        let cube = cube();
        assert_eq!(area_and_normal(&cube).0, 24.0);
        for t in &cube.triangles {
            let p = t.map(|i| cube.positions[i as usize]);
            let g = (p[1] - p[0]).cross(p[2] - p[0]);
            assert!(g.dot(cube.normals[t[0] as usize]) > 0.0, "outward winding");
            assert!(g.dot(p[0]) > 0.0);
        }
        let (area, n) = area_and_normal(&disk());
        assert!((area / std::f32::consts::PI - 1.0).abs() < 2e-4, "{area}");
        assert!((n - Vec3::Z).length() < 1e-6, "{n}");
    }

    /// A mirroring transform keeps the winding consistent with the
    /// transformed normals; flip_normals turns both.
    #[test]
    fn mirrors_and_flips_keep_winding_and_normals_together() {
        for (m, flip, expected) in [
            (
                DMat4::from_scale(DVec3::new(1.0, 1.0, -1.0)),
                false,
                Vec3::NEG_Z,
            ),
            (DMat4::IDENTITY, true, Vec3::NEG_Z),
            (
                DMat4::from_scale(DVec3::new(-1.0, 1.0, 1.0)),
                true,
                Vec3::NEG_Z,
            ),
            (
                DMat4::from_rotation_x(std::f64::consts::FRAC_PI_2),
                false,
                Vec3::NEG_Y,
            ),
        ] {
            let mesh = to_world(rectangle(), m, flip, false);
            let (_, g) = area_and_normal(&mesh);
            assert!((g - expected).length() < 1e-6, "{m:?} {flip}: {g}");
            assert!((mesh.normals[0] - expected).length() < 1e-6);
        }
    }

    #[test]
    fn smooth_normals_of_a_cube_corner_point_along_the_diagonal() {
        let mut mesh = cube();
        mesh.normals.clear();
        // Weld the cube's corners so that faces share vertices.
        let mut welded: Vec<Vec3> = Vec::new();
        for t in &mut mesh.triangles {
            for i in t.iter_mut() {
                let p = mesh.positions[*i as usize];
                *i = welded.iter().position(|&q| q == p).unwrap_or_else(|| {
                    welded.push(p);
                    welded.len() - 1
                }) as u32;
            }
        }
        let normals = smooth_normals(&welded, &mesh.triangles);
        for (p, n) in welded.iter().zip(&normals) {
            assert!((*n - p.normalize()).length() < 1e-5, "{p} {n}");
        }
    }
}
