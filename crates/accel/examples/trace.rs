//! Builds a BVH over a triangulated sphere and a floor, traces one camera
//! ray per character cell and prints the picture, shaded by which primitive
//! each ray hits first and whether the point is lit (an any-hit shadow ray).
//!
//! Run with `cargo run -p rlt-accel --example trace`.

use accel::glam::Vec3;
use accel::{Bvh, offset_ray_origin};
use std::f32::consts::PI;

/// A UV sphere as triangles.
fn sphere(centre: Vec3, radius: f32, rings: usize, segments: usize) -> Vec<[Vec3; 3]> {
    let point = |ring: usize, segment: usize| {
        let theta = PI * ring as f32 / rings as f32;
        let phi = 2.0 * PI * segment as f32 / segments as f32;
        centre
            + radius
                * Vec3::new(
                    theta.sin() * phi.cos(),
                    theta.cos(),
                    theta.sin() * phi.sin(),
                )
    };
    let mut triangles = Vec::new();
    for r in 0..rings {
        for s in 0..segments {
            let [a, b, c, d] = [
                point(r, s),
                point(r + 1, s),
                point(r + 1, s + 1),
                point(r, s + 1),
            ];
            triangles.extend([[a, b, c], [a, c, d]]);
        }
    }
    triangles
}

fn main() {
    let mut triangles = sphere(Vec3::new(0.0, 1.0, 0.0), 1.0, 24, 48);
    let floor_id = triangles.len() as u32;
    let floor =
        [(-4.0, -4.0), (4.0, -4.0), (4.0, 4.0), (-4.0, 4.0)].map(|(x, z)| Vec3::new(x, 0.0, z));
    triangles.extend([
        [floor[0], floor[2], floor[1]],
        [floor[0], floor[3], floor[2]],
    ]);
    let bvh = Bvh::build(&triangles);
    println!("{} triangles", bvh.triangle_count());

    let eye = Vec3::new(0.0, 1.5, -5.0);
    let light = Vec3::new(3.0, 5.0, -2.0);
    let (columns, rows) = (72, 28);
    for row in 0..rows {
        let line: String = (0..columns)
            .map(|column| {
                let x = (column as f32 + 0.5) / columns as f32 * 2.0 - 1.0;
                let y = 1.0 - (row as f32 + 0.5) / rows as f32 * 2.0;
                let direction = Vec3::new(x, 0.5 * y - 0.15, 1.0).normalize();
                let Some(hit) = bvh.intersect(eye, direction, f32::INFINITY) else {
                    return ' ';
                };
                let [v0, v1, v2] = triangles[hit.primitive as usize];
                let mut normal = (v1 - v0).cross(v2 - v0).normalize();
                if normal.dot(direction) > 0.0 {
                    normal = -normal; // offset towards the side the ray came from
                }
                let point = eye + hit.t * direction;
                let origin = offset_ray_origin(point, normal);
                let lit = !bvh.occluded(origin, light - origin, 1.0);
                match (hit.primitive >= floor_id, lit) {
                    (false, true) => '@',
                    (false, false) => '+',
                    (true, true) => '.',
                    (true, false) => ':',
                }
            })
            .collect();
        println!("{line}");
    }
}
