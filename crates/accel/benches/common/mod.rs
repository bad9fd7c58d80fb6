//! Benchmark scenes and ray sets, generated in code.

#![allow(dead_code)]

use std::collections::HashMap;
use std::time::Duration;

use criterion::Criterion;
use glam::Vec3;
use stats::Pcg32;

/// A ray: origin, direction, t_max.
pub type Ray = (Vec3, Vec3, f32);

/// Criterion settings for slow, coarse measurements (seconds per iteration).
pub fn criterion() -> Criterion {
    Criterion::default()
        .sample_size(10)
        .warm_up_time(Duration::from_millis(500))
        .measurement_time(Duration::from_secs(3))
}

/// One displaced cube-sphere: `n` x `n` quads per cube face, radius `r`.
fn bumpy_sphere(n: u32, center: Vec3, radius: f32, phase: f32, out: &mut Vec<[Vec3; 3]>) {
    let mut vertices = Vec::new();
    let mut lookup: HashMap<[u32; 3], usize> = HashMap::new();
    let mut vertex = |l: [u32; 3]| -> usize {
        *lookup.entry(l).or_insert_with(|| {
            let p = (Vec3::new(l[0] as f32, l[1] as f32, l[2] as f32) * (2.0 / n as f32) - 1.0)
                .normalize();
            let bump = 1.0
                + 0.06 * (7.0 * p.x + phase).sin() * (5.0 * p.y).sin() * (6.0 * p.z - phase).cos();
            vertices.push(center + p * radius * bump);
            vertices.len() - 1
        })
    };
    let mut quads = Vec::new();
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
                        vertex(l)
                    };
                    let mut q = [corner(0, 0), corner(1, 0), corner(1, 1), corner(0, 1)];
                    if side == 0 {
                        q.reverse();
                    }
                    quads.push(q);
                }
            }
        }
    }
    for q in quads {
        let [a, b, c, d] = q.map(|i| vertices[i]);
        out.push([a, b, c]);
        out.push([a, c, d]);
    }
}

/// About one million triangles: 64 overlapping bumpy spheres of 15,552
/// triangles each (995,328 in all) scattered in a 30^3 box.
pub fn sphere_cluster() -> Vec<[Vec3; 3]> {
    let mut rng = Pcg32::new(2024, 7);
    let mut tris = Vec::with_capacity(64 * 6 * 36 * 36 * 2);
    for k in 0..64 {
        let center = Vec3::new(
            rng.uniform_f32() * 24.0 - 12.0,
            rng.uniform_f32() * 24.0 - 12.0,
            rng.uniform_f32() * 24.0 - 12.0,
        );
        let radius = 1.5 + 2.5 * rng.uniform_f32();
        bumpy_sphere(36, center, radius, k as f32, &mut tris);
    }
    tris
}

/// The classic Cornell box (cornell.edu measured data), 32 triangles, in mm.
pub fn cornell_box() -> Vec<[Vec3; 3]> {
    const QUADS: [[[f32; 3]; 4]; 16] = [
        // Floor, light, ceiling, back, right (green), left (red) walls.
        [
            [552.8, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 559.2],
            [549.6, 0.0, 559.2],
        ],
        [
            [343.0, 548.8, 227.0],
            [343.0, 548.8, 332.0],
            [213.0, 548.8, 332.0],
            [213.0, 548.8, 227.0],
        ],
        [
            [556.0, 548.8, 0.0],
            [556.0, 548.8, 559.2],
            [0.0, 548.8, 559.2],
            [0.0, 548.8, 0.0],
        ],
        [
            [549.6, 0.0, 559.2],
            [0.0, 0.0, 559.2],
            [0.0, 548.8, 559.2],
            [556.0, 548.8, 559.2],
        ],
        [
            [0.0, 0.0, 559.2],
            [0.0, 0.0, 0.0],
            [0.0, 548.8, 0.0],
            [0.0, 548.8, 559.2],
        ],
        [
            [552.8, 0.0, 0.0],
            [549.6, 0.0, 559.2],
            [556.0, 548.8, 559.2],
            [556.0, 548.8, 0.0],
        ],
        // Short block.
        [
            [130.0, 165.0, 65.0],
            [82.0, 165.0, 225.0],
            [240.0, 165.0, 272.0],
            [290.0, 165.0, 114.0],
        ],
        [
            [290.0, 0.0, 114.0],
            [290.0, 165.0, 114.0],
            [240.0, 165.0, 272.0],
            [240.0, 0.0, 272.0],
        ],
        [
            [130.0, 0.0, 65.0],
            [130.0, 165.0, 65.0],
            [290.0, 165.0, 114.0],
            [290.0, 0.0, 114.0],
        ],
        [
            [82.0, 0.0, 225.0],
            [82.0, 165.0, 225.0],
            [130.0, 165.0, 65.0],
            [130.0, 0.0, 65.0],
        ],
        [
            [240.0, 0.0, 272.0],
            [240.0, 165.0, 272.0],
            [82.0, 165.0, 225.0],
            [82.0, 0.0, 225.0],
        ],
        // Tall block.
        [
            [423.0, 330.0, 247.0],
            [265.0, 330.0, 296.0],
            [314.0, 330.0, 456.0],
            [472.0, 330.0, 406.0],
        ],
        [
            [423.0, 0.0, 247.0],
            [423.0, 330.0, 247.0],
            [472.0, 330.0, 406.0],
            [472.0, 0.0, 406.0],
        ],
        [
            [472.0, 0.0, 406.0],
            [472.0, 330.0, 406.0],
            [314.0, 330.0, 456.0],
            [314.0, 0.0, 456.0],
        ],
        [
            [314.0, 0.0, 456.0],
            [314.0, 330.0, 456.0],
            [265.0, 330.0, 296.0],
            [265.0, 0.0, 296.0],
        ],
        [
            [265.0, 0.0, 296.0],
            [265.0, 330.0, 296.0],
            [423.0, 330.0, 247.0],
            [423.0, 0.0, 247.0],
        ],
    ];
    QUADS
        .iter()
        .flat_map(|q| {
            let [a, b, c, d] = q.map(Vec3::from);
            [[a, b, c], [a, c, d]]
        })
        .collect()
}

/// Primary rays through the centres of a `width` x `height` pinhole grid
/// (unit directions, infinite t_max), in scanline order.
pub fn pinhole_rays(
    eye: Vec3,
    target: Vec3,
    fov_y_degrees: f32,
    width: u32,
    height: u32,
) -> Vec<Ray> {
    let forward = (target - eye).normalize();
    let right = forward.cross(Vec3::Y).normalize();
    let up = right.cross(forward);
    let half = (fov_y_degrees.to_radians() * 0.5).tan();
    let aspect = width as f32 / height as f32;
    let mut rays = Vec::with_capacity((width * height) as usize);
    for y in 0..height {
        for x in 0..width {
            let u = ((x as f32 + 0.5) / width as f32 * 2.0 - 1.0) * half * aspect;
            let v = (1.0 - (y as f32 + 0.5) / height as f32 * 2.0) * half;
            rays.push((
                eye,
                (forward + right * u + up * v).normalize(),
                f32::INFINITY,
            ));
        }
    }
    rays
}

fn in_box(rng: &mut Pcg32, lo: Vec3, hi: Vec3) -> Vec3 {
    lo + (hi - lo) * Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32())
}

fn unit(rng: &mut Pcg32) -> Vec3 {
    let u = rng.uniform_vec2();
    let z = 1.0 - 2.0 * u.x;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = std::f32::consts::TAU * u.y;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Incoherent rays: origins uniform in the box, directions uniform on the
/// sphere, infinite t_max.
pub fn random_rays(n: usize, lo: Vec3, hi: Vec3, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 1);
    (0..n)
        .map(|_| (in_box(&mut rng, lo, hi), unit(&mut rng), f32::INFINITY))
        .collect()
}

/// Occlusion (shadow-style) segments between two random points of the box:
/// direction `b - a`, t_max just below 1.
pub fn random_segments(n: usize, lo: Vec3, hi: Vec3, seed: u64) -> Vec<Ray> {
    let mut rng = Pcg32::new(seed, 2);
    (0..n)
        .map(|_| {
            let a = in_box(&mut rng, lo, hi);
            let b = in_box(&mut rng, lo, hi);
            (a, b - a, 0.999)
        })
        .collect()
}

/// The ray sets of a scene: (name, rays, is occlusion).
pub fn ray_sets(scene: &str, rays_per_set: usize) -> Vec<(&'static str, Vec<Ray>, bool)> {
    let side = (rays_per_set as f64).sqrt() as u32;
    let (coherent, lo, hi) = match scene {
        "cornell" => (
            pinhole_rays(
                Vec3::new(278.0, 273.0, -800.0),
                Vec3::new(278.0, 273.0, 0.0),
                39.3,
                side,
                side,
            ),
            Vec3::new(1.0, 1.0, 1.0),
            Vec3::new(555.0, 548.0, 559.0),
        ),
        _ => (
            pinhole_rays(Vec3::new(0.0, 4.0, -45.0), Vec3::ZERO, 45.0, side, side),
            Vec3::splat(-15.0),
            Vec3::splat(15.0),
        ),
    };
    vec![
        ("coherent", coherent, false),
        ("incoherent", random_rays(rays_per_set, lo, hi, 11), false),
        ("occlusion", random_segments(rays_per_set, lo, hi, 12), true),
    ]
}
