//! Batch queries (`Bvh::intersect_batch`, `Bvh::occluded_batch`) give
//! the single-ray queries' answers bit for bit, ties, skipped triangles,
//! spheres and edge functions of exactly zero included, at every
//! instruction set the CPU has: in packets (scenes of at most 64
//! primitives) and one ray after the other (larger scenes).

use accel::{BatchRay, Bvh, Hit, Isa, NO_SURFACE, Sphere, offset_ray_origin};
use glam::Vec3;
use stats::Pcg32;

use crate::common::*;

fn bits(h: Hit) -> [u32; 4] {
    [h.t.to_bits(), h.primitive, h.b1.to_bits(), h.b2.to_bits()]
}

/// Rays of every kind the renderer traces: from outside and inside the
/// scene's box, aimed at triangles, at their vertices (edge functions of
/// zero, ties between the triangles that share them) and at spheres, from
/// offset surface points skipping their triangle, with infinite, short and
/// exact ends.
fn rays(rng: &mut Pcg32, tris: &[[Vec3; 3]], spheres: &[Sphere], count: usize) -> Vec<BatchRay> {
    let (lo, hi) = Bvh::build_with_spheres(tris, spheres, Default::default()).bounds();
    let pad = (hi - lo) * 0.25;
    (0..count)
        .map(|i| {
            let pick = |rng: &mut Pcg32| (rng.next_u32() as usize) % tris.len();
            let mut origin = random_in_box(rng, lo - pad, hi + pad);
            let mut skip = [NO_SURFACE; 2];
            let direction = match i % 6 {
                0 => {
                    let tri = &tris[pick(rng)];
                    random_point_on(rng, tri) - origin
                }
                1 => tris[pick(rng)][(rng.next_u32() % 3) as usize] - origin,
                // Axis-aligned towards a vertex: exact zero edge functions.
                2 => {
                    let v = tris[pick(rng)][(rng.next_u32() % 3) as usize];
                    let axis = (rng.next_u32() % 3) as usize;
                    origin = v;
                    origin[axis] += 1.5;
                    v - origin
                }
                // Through a sphere, or grazing it: within 1e-3 of its
                // silhouette, inside and out.
                3 if !spheres.is_empty() => {
                    let s = &spheres[(rng.next_u32() as usize) % spheres.len()];
                    origin = random_in_box(rng, lo, hi);
                    let to_center = s.center - origin;
                    let towards = to_center.normalize();
                    let side = towards.cross(random_unit(rng)).normalize();
                    // The line passes reach x radius from the centre.
                    let reach = if i % 12 == 3 {
                        rng.uniform_f32() * 0.9
                    } else {
                        1.0 + (rng.uniform_f32() - 0.5) * 2e-3
                    };
                    let sin = (s.radius * reach / to_center.length()).min(1.0);
                    // Long enough for t_max 0.5 to reach past the sphere.
                    (towards * (1.0 - sin * sin).sqrt() + side * sin) * 4.0 * to_center.length()
                }
                4 => {
                    // A bounce off a triangle, skipping it; half of them
                    // towards a point of another, skipping that one too.
                    let (from, to) = (pick(rng), pick(rng));
                    let p = random_point_on(rng, &tris[from]);
                    let target = random_point_on(rng, &tris[to]);
                    let n = geometric_normal(&tris[from]);
                    let d = target - p;
                    origin = offset_ray_origin(p, if d.dot(n) > 0.0 { n } else { -n });
                    skip = [
                        from as u32,
                        if i % 12 == 4 { to as u32 } else { from as u32 },
                    ];
                    target - origin
                }
                _ => random_unit(rng),
            };
            let t_max = [f32::INFINITY, 0.5, 1.0, 0.999_999_9][i % 4];
            BatchRay {
                origin,
                direction,
                t_max,
                skip,
            }
        })
        .collect()
}

/// The single-ray answers: the closest hit leaving `skip[0]` (the
/// renderer's bounces skip one triangle twice), and occlusion skipping
/// both.
fn single(bvh: &Bvh, ray: &BatchRay) -> (Option<[u32; 4]>, bool) {
    let hit = bvh.intersect_leaving(ray.origin, ray.direction, ray.t_max, ray.skip[0]);
    let occluded = bvh.occluded_between(ray.origin, ray.direction, ray.t_max, ray.skip);
    (hit.map(bits), occluded)
}

/// A named scene: triangles and spheres.
type Scene = (&'static str, Vec<[Vec3; 3]>, Vec<Sphere>);

#[test]
fn batches_answer_as_single_rays_on_every_instruction_set() {
    let mut rng = Pcg32::new(61, 0);
    let ball = |center: Vec3, radius: f32| Sphere { center, radius };
    let scenes: Vec<Scene> = vec![
        ("box", unit_box().triangles(), vec![]),
        (
            "box and spheres",
            unit_box().triangles(),
            vec![
                ball(Vec3::new(0.3, -0.4, 0.1), 0.5),
                ball(Vec3::new(-0.5, 0.5, 1.0), 0.4),
            ],
        ),
        ("small height field", height_field(4).triangles(), vec![]),
        // Every triangle twice, the copies' corners rotated: every hit a
        // tie between two ids, in either slot order.
        (
            "doubled box",
            unit_box()
                .triangles()
                .iter()
                .flat_map(|&[a, b, c]| [[a, b, c], [b, c, a]])
                .collect(),
            vec![],
        ),
        (
            "soup",
            random_soup(&mut rng, 58, 0.3),
            vec![ball(Vec3::ZERO, 0.2)],
        ),
        (
            "tiny soup",
            random_soup(&mut rng, 40, 0.3)
                .iter()
                .map(|t| t.map(|v| v * 1e-13))
                .collect(),
            vec![],
        ),
        // Beyond 64 primitives: one ray after the other.
        (
            "height field",
            height_field(12).triangles(),
            vec![ball(Vec3::Y, 0.3)],
        ),
    ];
    let mut compared = 0;
    for (name, tris, spheres) in &scenes {
        let mut bvh = Bvh::build_with_spheres(tris, spheres, Default::default());
        // Spheres' rays only where the scene has some; the batch crosses a
        // chunk of 256.
        let rays = rays(&mut rng, tris, spheres, 700);
        let expected: Vec<_> = rays.iter().map(|r| single(&bvh, r)).collect();
        let hits = expected.iter().filter(|e| e.0.is_some()).count();
        let occluded = expected.iter().filter(|e| e.1).count();
        assert!(hits > rays.len() / 5, "{name}: {hits} hits");
        assert!(occluded > rays.len() / 5, "{name}: {occluded} occluded");
        for isa in Isa::ALL {
            if !bvh.set_isa(isa) {
                continue;
            }
            for batch in [&rays[..1], &rays[1..18], &rays[18..]] {
                let first = batch.as_ptr() as usize - rays.as_ptr() as usize;
                let first = first / size_of::<BatchRay>();
                let mut batch_hits = vec![None; batch.len()];
                let mut batch_occluded = vec![false; batch.len()];
                let leaving: Vec<BatchRay> = batch
                    .iter()
                    .map(|r| BatchRay {
                        skip: [r.skip[0]; 2],
                        ..*r
                    })
                    .collect();
                bvh.intersect_batch(&leaving, &mut batch_hits);
                bvh.occluded_batch(batch, &mut batch_occluded);
                for (j, ray) in batch.iter().enumerate() {
                    let got = (batch_hits[j].map(bits), batch_occluded[j]);
                    assert_eq!(
                        got,
                        expected[first + j],
                        "{name}, {isa:?}, ray {}: {ray:?}",
                        first + j
                    );
                }
            }
            compared += 1;
        }
    }
    assert!(compared >= 12, "at least Best and Baseline on every scene");
}
