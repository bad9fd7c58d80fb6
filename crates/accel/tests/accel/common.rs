//! Meshes, random directions and an f64 brute-force reference for the tests.

use std::collections::HashMap;

use glam::{DVec3, Vec3};
use stats::Pcg32;

/// An indexed triangle mesh.
#[derive(Clone, Debug, Default)]
pub struct Mesh {
    pub vertices: Vec<Vec3>,
    pub indices: Vec<[u32; 3]>,
}

impl Mesh {
    pub fn triangles(&self) -> Vec<[Vec3; 3]> {
        self.indices
            .iter()
            .map(|t| t.map(|i| self.vertices[i as usize]))
            .collect()
    }

    /// Applies `p * scale + offset` to every vertex.
    pub fn transformed(&self, scale: f32, offset: Vec3) -> Self {
        Self {
            vertices: self.vertices.iter().map(|&v| v * scale + offset).collect(),
            indices: self.indices.clone(),
        }
    }

    /// Whether each vertex lies on an edge used by a single triangle.
    pub fn boundary_vertices(&self) -> Vec<bool> {
        let mut count: HashMap<(u32, u32), u32> = HashMap::new();
        for idx in &self.indices {
            for k in 0..3 {
                let (a, b) = (idx[k], idx[(k + 1) % 3]);
                *count.entry((a.min(b), a.max(b))).or_default() += 1;
            }
        }
        let mut boundary = vec![false; self.vertices.len()];
        for ((a, b), n) in count {
            if n == 1 {
                boundary[a as usize] = true;
                boundary[b as usize] = true;
            }
        }
        boundary
    }

    /// For every edge shared by exactly two triangles: (triangle a, triangle b,
    /// vertex i, vertex j).
    pub fn interior_edges(&self) -> Vec<(usize, usize, u32, u32)> {
        let mut map: HashMap<(u32, u32), Vec<usize>> = HashMap::new();
        for (t, idx) in self.indices.iter().enumerate() {
            for k in 0..3 {
                let (a, b) = (idx[k], idx[(k + 1) % 3]);
                map.entry((a.min(b), a.max(b))).or_default().push(t);
            }
        }
        let mut edges: Vec<_> = map
            .into_iter()
            .filter(|(_, ts)| ts.len() == 2)
            .map(|((a, b), ts)| (ts[0], ts[1], a, b))
            .collect();
        edges.sort_unstable();
        edges
    }
}

/// A closed cube-sphere: the surface of a cube with `n` x `n` quads per face,
/// projected on the sphere. Vertices are shared (computed once per lattice
/// point), so the mesh is watertight.
pub fn cube_sphere(n: u32, radius: f32) -> Mesh {
    let mut mesh = Mesh::default();
    let mut lookup: HashMap<[u32; 3], u32> = HashMap::new();
    let mut vertex = |mesh: &mut Mesh, l: [u32; 3]| -> u32 {
        *lookup.entry(l).or_insert_with(|| {
            let p = Vec3::new(l[0] as f32, l[1] as f32, l[2] as f32) * (2.0 / n as f32) - 1.0;
            mesh.vertices.push(p.normalize() * radius);
            (mesh.vertices.len() - 1) as u32
        })
    };
    // Each face: fixed axis `a` at 0 or n, the other two axes span the grid.
    for a in 0..3 {
        for side in [0, n] {
            let (u, v) = ((a + 1) % 3, (a + 2) % 3);
            for i in 0..n {
                for j in 0..n {
                    let mut corner = |di: u32, dj: u32| {
                        let mut l = [0u32; 3];
                        l[a] = side;
                        l[u] = i + di;
                        l[v] = j + dj;
                        vertex(&mut mesh, l)
                    };
                    let mut q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                    // Outward winding on both sides.
                    if side == 0 {
                        q.reverse();
                    }
                    // The four corners are not coplanar: split along the
                    // diagonal that folds outwards, so the mesh stays convex.
                    let p = q.map(|i| mesh.vertices[i as usize].as_dvec3());
                    let n = (p[1] - p[0]).cross(p[2] - p[0]);
                    if n.dot(p[3] - p[0]) <= 0.0 {
                        mesh.indices.push([q[0], q[1], q[2]]);
                        mesh.indices.push([q[0], q[2], q[3]]);
                    } else {
                        mesh.indices.push([q[1], q[2], q[3]]);
                        mesh.indices.push([q[1], q[3], q[0]]);
                    }
                }
            }
        }
    }
    mesh
}

/// Whether every vertex lies behind the plane of every triangle or within
/// `tolerance` (relative to the triangle's size) in front of it (f64, on the
/// f32 vertices): the mesh bounds a convex solid up to rounding.
pub fn is_convex(mesh: &Mesh, tolerance: f64) -> bool {
    mesh.indices.iter().all(|t| {
        let [a, b, c] = t.map(|i| mesh.vertices[i as usize].as_dvec3());
        let n = (b - a).cross(c - a);
        let size = (b - a).length();
        let n = n / n.length();
        mesh.vertices
            .iter()
            .all(|v| n.dot(v.as_dvec3() - a) <= tolerance * size)
    })
}

/// The box [-1, 1]^3 as 12 triangles (closed).
pub fn unit_box() -> Mesh {
    let vertices = (0..8)
        .map(|i| {
            Vec3::new(
                if i & 1 == 0 { -1.0 } else { 1.0 },
                if i & 2 == 0 { -1.0 } else { 1.0 },
                if i & 4 == 0 { -1.0 } else { 1.0 },
            )
        })
        .collect();
    let quads = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let indices = quads
        .iter()
        .flat_map(|q| [[q[0], q[1], q[2]], [q[0], q[2], q[3]]])
        .collect();
    Mesh { vertices, indices }
}

/// A displaced height field over [-1, 1]^2 (y up) with `n` x `n` quads.
pub fn height_field(n: u32) -> Mesh {
    let mut mesh = Mesh::default();
    for j in 0..=n {
        for i in 0..=n {
            let x = -1.0 + 2.0 * i as f32 / n as f32;
            let z = -1.0 + 2.0 * j as f32 / n as f32;
            let y = 0.25 * (3.0 * x).sin() * (2.0 * z).cos() + 0.1 * (11.0 * x + 7.0 * z).sin();
            mesh.vertices.push(Vec3::new(x, y, z));
        }
    }
    let at = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            mesh.indices.push([at(i, j), at(i, j + 1), at(i + 1, j)]);
            mesh.indices
                .push([at(i + 1, j), at(i, j + 1), at(i + 1, j + 1)]);
        }
    }
    mesh
}

/// Triangles at x = 1.09^i, i < `PROGRESSION`, each 0.3 x wide (a
/// geometric progression of boxes: every split peels one off, so trees
/// grow deep).
pub fn geometric_progression() -> Vec<[Vec3; 3]> {
    (0..PROGRESSION)
        .map(|i| {
            let x = 1.09f32.powi(i);
            let s = x * 0.3;
            [
                Vec3::new(x, 0.0, -s),
                Vec3::new(x, s, s),
                Vec3::new(x, -s, s),
            ]
        })
        .collect()
}

/// Triangles of [`geometric_progression`].
pub const PROGRESSION: i32 = 400;

/// A ray origin beside a random triangle of [`geometric_progression`],
/// on its +x side (rays towards -x cross it and the smaller ones).
pub fn progression_origin(rng: &mut Pcg32) -> Vec3 {
    let x = 1.09f32.powi((rng.next_u32() % PROGRESSION as u32) as i32);
    Vec3::new(
        x * (0.5 + rng.uniform_f32()),
        x * 0.3 * (rng.uniform_f32() - 0.5),
        x * 0.3 * (rng.uniform_f32() - 0.5),
    )
}

/// `count` random triangles of size up to `size` in [-1, 1]^3.
pub fn random_soup(rng: &mut Pcg32, count: usize, size: f32) -> Vec<[Vec3; 3]> {
    (0..count)
        .map(|_| {
            let c = random_in_box(rng, Vec3::splat(-1.0), Vec3::splat(1.0));
            [0, 1, 2].map(|_| c + random_unit(rng) * size * rng.uniform_f32())
        })
        .collect()
}

pub fn random_in_box(rng: &mut Pcg32, lo: Vec3, hi: Vec3) -> Vec3 {
    Vec3::new(
        lo.x + (hi.x - lo.x) * rng.uniform_f32(),
        lo.y + (hi.y - lo.y) * rng.uniform_f32(),
        lo.z + (hi.z - lo.z) * rng.uniform_f32(),
    )
}

/// Uniform direction on the unit sphere.
pub fn random_unit(rng: &mut Pcg32) -> Vec3 {
    let u = rng.uniform_vec2();
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Direction with `dot(d, n) = cos_theta` (n unit), random azimuth.
pub fn direction_at_angle(rng: &mut Pcg32, n: Vec3, cos_theta: f32) -> Vec3 {
    let (t, b) = n.any_orthonormal_pair();
    let phi = std::f32::consts::TAU * rng.uniform_f32();
    let s = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
    (n * cos_theta + (t * phi.cos() + b * phi.sin()) * s).normalize()
}

/// Random point on a triangle, interpolated in f32 from barycentrics as a
/// renderer would.
pub fn random_point_on(rng: &mut Pcg32, tri: &[Vec3; 3]) -> Vec3 {
    let mut u = rng.uniform_vec2();
    if u.x + u.y > 1.0 {
        u = glam::Vec2::ONE - u;
    }
    tri[0] * (1.0 - u.x - u.y) + tri[1] * u.x + tri[2] * u.y
}

pub fn geometric_normal(tri: &[Vec3; 3]) -> Vec3 {
    (tri[1] - tri[0]).cross(tri[2] - tri[0]).normalize()
}

/// Reference hit of one triangle, in f64: the watertight test of Woop et al.
/// (translate, permute, shear; inclusive edge functions) so that a ray through
/// a shared edge or vertex hits one of its triangles here too. Returns
/// (t, b1, b2) for 0 < t < t_max; a zero determinant (ray in the triangle's
/// plane, or zero area) is a miss.
pub fn reference_hit(
    tri: &[Vec3; 3],
    origin: Vec3,
    direction: Vec3,
    t_max: f64,
) -> Option<(f64, f64, f64)> {
    let o = origin.as_dvec3();
    let d = direction.as_dvec3();
    let ad = d.abs();
    let kz = if ad.x > ad.y && ad.x > ad.z {
        0
    } else if ad.y > ad.z {
        1
    } else {
        2
    };
    let (mut kx, mut ky) = ((kz + 1) % 3, (kz + 2) % 3);
    if d[kz] < 0.0 {
        std::mem::swap(&mut kx, &mut ky);
    }
    let (sx, sy, sz) = (d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
    let [a, b, c] = tri.map(|v| {
        let p = v.as_dvec3() - o;
        DVec3::new(p[kx] - sx * p[kz], p[ky] - sy * p[kz], sz * p[kz])
    });
    let e0 = c.x * b.y - c.y * b.x;
    let e1 = a.x * c.y - a.y * c.x;
    let e2 = b.x * a.y - b.y * a.x;
    if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
        return None;
    }
    let det = e0 + e1 + e2;
    if det == 0.0 || !det.is_finite() {
        return None;
    }
    let (b0, b1, b2) = (e0 / det, e1 / det, e2 / det);
    let t = b0 * a.z + b1 * b.z + b2 * c.z;
    (t > 0.0 && t < t_max).then_some((t, b1, b2))
}

/// Brute-force closest hit over all triangles: (triangle, t, b1, b2).
pub fn reference_closest(
    tris: &[[Vec3; 3]],
    origin: Vec3,
    direction: Vec3,
    t_max: f32,
) -> Option<(u32, f64, f64, f64)> {
    let mut best: Option<(u32, f64, f64, f64)> = None;
    let mut best_t = f64::from(t_max);
    for (i, tri) in tris.iter().enumerate() {
        if let Some((t, b1, b2)) = reference_hit(tri, origin, direction, best_t) {
            best_t = t;
            best = Some((i as u32, t, b1, b2));
        }
    }
    best
}

/// Checks one closest-hit query against brute force. `reference` is
/// `reference_closest(tris, origin, direction, f32::INFINITY)`. Returns a
/// description of the mismatch, if any.
pub fn check_ray(
    bvh: &accel::Bvh,
    tris: &[[Vec3; 3]],
    (origin, direction, t_max): (Vec3, Vec3, f32),
    reference: Option<(u32, f64, f64, f64)>,
) -> Result<(), String> {
    let got = bvh.intersect(origin, direction, t_max);
    let want = reference.filter(|r| r.1 < f64::from(t_max));
    let ctx =
        || format!("ray o={origin:?} d={direction:?} t_max={t_max}: got {got:?}, want {want:?}");
    match (got, want) {
        (None, None) => Ok(()),
        (Some(h), Some((id, t, b1, b2))) => {
            let rel = |a: f64, b: f64| (a - b).abs() <= 1e-5 * b.abs().max(1e-30);
            if !rel(f64::from(h.t), t) {
                return Err(format!("t differs: {}", ctx()));
            }
            if h.primitive == id {
                if (f64::from(h.b1) - b1).abs() > 1e-4 || (f64::from(h.b2) - b2).abs() > 1e-4 {
                    return Err(format!("barycentrics differ: {}", ctx()));
                }
            } else {
                // A tie: the reported triangle must itself be hit at (about) t.
                let Some(&tri) = tris.get(h.primitive as usize) else {
                    return Err(format!("bad id: {}", ctx()));
                };
                let own = reference_hit(&tri, origin, direction, f64::INFINITY)
                    .or_else(|| reference_hit_padded(&tri, origin, direction, 1e-5));
                match own {
                    Some((t_own, _, _)) if rel(t_own, t) => {}
                    _ => return Err(format!("different triangle, no tie: {}", ctx())),
                }
            }
            Ok(())
        }
        _ => Err(format!("hit/miss differs: {}", ctx())),
    }
}

/// Reference hit with barycentric bounds widened by `pad` (for ties on edges).
fn reference_hit_padded(
    tri: &[Vec3; 3],
    origin: Vec3,
    direction: Vec3,
    pad: f64,
) -> Option<(f64, f64, f64)> {
    let [v0, v1, v2] = tri.map(|v| v.as_dvec3());
    let o = origin.as_dvec3();
    let d = direction.as_dvec3();
    let (e1, e2) = (v1 - v0, v2 - v0);
    let p = d.cross(e2);
    let det = e1.dot(p);
    if det == 0.0 {
        return None;
    }
    let s = o - v0;
    let b1 = s.dot(p) / det;
    let q = s.cross(e1);
    let b2 = d.dot(q) / det;
    if b1 < -pad || b2 < -pad || b1 + b2 > 1.0 + pad {
        return None;
    }
    Some((e2.dot(q) / det, b1, b2))
}

/// Brute-force occlusion from the unbounded closest hit: any hit with
/// 0 < t < t_max. `None` when the answer is numerically ambiguous (the closest
/// hit within 1e-5 relative of t_max).
pub fn reference_occluded(reference: Option<(u32, f64, f64, f64)>, t_max: f32) -> Option<bool> {
    match reference {
        None => Some(false),
        Some((_, t, _, _)) => {
            let tm = f64::from(t_max);
            if (t - tm).abs() <= 1e-5 * tm {
                None
            } else {
                Some(t < tm)
            }
        }
    }
}
