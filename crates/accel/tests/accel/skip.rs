//! Queries that skip the triangles a ray starts or ends on
//! (`Bvh::intersect_leaving`, `Bvh::occluded_between`) give the plain
//! queries' answers, bit for bit, for rays from offset surface points: a
//! ray offset off a plane and leaving it cannot meet it. Spheres are never
//! skipped (a ray leaving a sphere from inside meets it again).

use accel::{BuildOptions, Bvh, Hit, Layout, NO_SURFACE, Sphere, offset_ray_origin};
use glam::Vec3;
use stats::Pcg32;

use crate::common::*;

fn bits(h: Hit) -> [u32; 4] {
    [h.t.to_bits(), h.primitive, h.b1.to_bits(), h.b2.to_bits()]
}

/// A point on triangle `id` of `tris`, offset to the side of `towards`.
fn leaving(rng: &mut Pcg32, tris: &[[Vec3; 3]], id: usize, towards: Vec3) -> Vec3 {
    let p = random_point_on(rng, &tris[id]);
    let n = geometric_normal(&tris[id]);
    offset_ray_origin(p, if towards.dot(n) > 0.0 { n } else { -n })
}

#[test]
fn skipping_the_ends_changes_no_answer() {
    let mut rng = Pcg32::new(12, 0);
    let meshes = [
        height_field(16).triangles(),
        cube_sphere(6, 1.0).triangles(),
        unit_box().triangles(),
        random_soup(&mut Pcg32::new(13, 0), 300, 0.3),
    ];
    let (mut rays, mut skipped_hits) = (0, 0);
    for tris in &meshes {
        for layout in [Layout::Wide, Layout::Bvh8, Layout::Binary] {
            let bvh = Bvh::build_with(
                tris,
                BuildOptions {
                    layout,
                    ..BuildOptions::default()
                },
            );
            for _ in 0..600 {
                let from = rng.next_u32() as usize % tris.len();
                // A bounce: any direction, some grazing.
                let n = geometric_normal(&tris[from]);
                let cos = if rng.next_u32().is_multiple_of(4) {
                    0.01
                } else {
                    rng.uniform_f32() * 2.0 - 1.0
                };
                let d = direction_at_angle(&mut rng, n, cos);
                let o = leaving(&mut rng, tris, from, d);
                let plain = bvh.intersect(o, d, f32::INFINITY);
                let skipping = bvh.intersect_leaving(o, d, f32::INFINITY, from as u32);
                assert_eq!(plain.map(bits), skipping.map(bits), "{layout:?} {o} {d}");
                // Skipping is not a no-op: skip what the ray hits instead,
                // and the answer changes.
                if let Some(h) = plain {
                    let other = bvh.intersect_leaving(o, d, f32::INFINITY, h.primitive);
                    assert_ne!(other.map(|o| o.primitive), Some(h.primitive));
                    skipped_hits += 1;
                }
                // A segment to a point of another triangle, each end offset
                // towards the other.
                let to = rng.next_u32() as usize % tris.len();
                let q = random_point_on(&mut rng, &tris[to]);
                let o = leaving(&mut rng, tris, from, q - o);
                let m = geometric_normal(&tris[to]);
                let end = offset_ray_origin(q, if (o - q).dot(m) > 0.0 { m } else { -m });
                let surfaces = [from as u32, to as u32];
                assert_eq!(
                    bvh.occluded(o, end - o, 1.0),
                    bvh.occluded_between(o, end - o, 1.0, surfaces),
                    "{layout:?} {o} {end}"
                );
                rays += 1;
            }
        }
    }
    assert_eq!(rays, 4 * 3 * 600);
    assert!(skipped_hits > rays / 4, "{skipped_hits} of {rays}");
}

/// A ray leaving a sphere (from just inside, as a refracted ray does) meets
/// the same sphere again, whether or not its id is passed as the surface.
#[test]
fn spheres_are_not_skipped() {
    let s = Sphere {
        center: Vec3::new(0.0, 1.0, 0.0),
        radius: 0.5,
    };
    let tris = unit_box().transformed(4.0, Vec3::splat(-2.0)).triangles();
    let bvh = Bvh::build_with_spheres(&tris, &[s], BuildOptions::default());
    let sphere_id = tris.len() as u32;
    let inside = s.center + Vec3::X * (s.radius * 0.999);
    let d = Vec3::new(-1.0, 0.2, 0.1).normalize();
    let hit = bvh
        .intersect_leaving(inside, d, f32::INFINITY, sphere_id)
        .expect("the sphere's far side");
    assert_eq!(hit.primitive, sphere_id);
    assert_eq!(
        Some(bits(hit)),
        bvh.intersect(inside, d, f32::INFINITY).map(bits)
    );
    assert!(bvh.occluded_between(inside, d, 10.0, [sphere_id, NO_SURFACE]));
}
