//! The BVH8 layout's node tests and SIMD leaf tests (several triangles of
//! a leaf at once) and the flat layout's tests (16 triangles at once) give
//! the same query results, bit for bit, on every
//! instruction set the CPU has (`accel::Isa`): the rule that makes a
//! render's bytes independent of the machine it ran on.

use accel::{BuildOptions, Bvh, Hit, Isa, Layout};
use glam::Vec3;
use stats::Pcg32;

use crate::common::*;

/// One query's answer as bits: closest hit (t, primitive, barycentrics) and
/// occlusion, unfiltered and with a filter that rejects every third
/// primitive (the leaf kernel's hits passed to it one by one).
type Answer = (Option<[u32; 4]>, bool, Option<[u32; 4]>, bool);

fn answer(bvh: &Bvh, (o, d, t_max): (Vec3, Vec3, f32)) -> Answer {
    let bits = |h: Hit| [h.t.to_bits(), h.primitive, h.b1.to_bits(), h.b2.to_bits()];
    let keep = |p: u32, _, _| !p.is_multiple_of(3);
    (
        bvh.intersect(o, d, t_max).map(bits),
        bvh.occluded(o, d, t_max),
        bvh.intersect_where(o, d, t_max, keep).map(bits),
        bvh.occluded_where(o, d, t_max, keep),
    )
}

/// Rays from inside and outside the scene's box, some grazing, some short.
fn rays(rng: &mut Pcg32, tris: &[[Vec3; 3]], count: usize) -> Vec<(Vec3, Vec3, f32)> {
    let (lo, hi) = Bvh::build(tris).bounds();
    let pad = (hi - lo) * 0.25;
    (0..count)
        .map(|i| {
            let o = random_in_box(rng, lo - pad, hi + pad);
            let d = if i % 3 == 0 {
                // Aimed at a triangle: many hits, edges and vertices included.
                let tri = &tris[(rng.next_u32() as usize) % tris.len()];
                random_point_on(rng, tri) - o
            } else {
                random_unit(rng)
            };
            let t_max = [f32::INFINITY, 0.5, 1.0][i % 3];
            (o, d, t_max)
        })
        .collect()
}

#[test]
fn same_results_on_every_instruction_set() {
    let mut rng = Pcg32::new(45, 0);
    let scenes = [
        (
            "cube sphere",
            cube_sphere(12, 1.0).triangles(),
            Layout::Bvh8,
        ),
        ("height field", height_field(40).triangles(), Layout::Bvh8),
        ("soup", random_soup(&mut rng, 3000, 0.05), Layout::Bvh8),
        ("progression", geometric_progression(), Layout::Bvh8),
        (
            "small height field",
            height_field(4).triangles(),
            Layout::Flat,
        ),
        ("small soup", random_soup(&mut rng, 61, 0.3), Layout::Flat),
    ];
    let mut compared = 0;
    for (name, tris, layout) in scenes {
        let options = BuildOptions {
            layout,
            ..Default::default()
        };
        let mut bvh = Bvh::build_with(&tris, options);
        assert_eq!(bvh.layout(), layout, "{name}");
        let rays = rays(&mut rng, &tris, 4000);
        assert!(bvh.set_isa(Isa::Baseline), "every CPU has the baseline");
        let baseline: Vec<_> = rays.iter().map(|&r| answer(&bvh, r)).collect();
        let hits = baseline.iter().filter(|a| a.0.is_some()).count();
        assert!(hits > rays.len() / 10, "{name}: only {hits} hits");
        for isa in Isa::ALL {
            if !bvh.set_isa(isa) {
                eprintln!("{name}: this CPU lacks {isa:?}; not compared");
                continue;
            }
            for (i, &r) in rays.iter().enumerate() {
                assert_eq!(
                    answer(&bvh, r),
                    baseline[i],
                    "{name}, {isa:?}, ray {i}: {r:?}"
                );
            }
            compared += 1;
        }
    }
    assert!(compared >= 12, "at least Best and Baseline on every scene");
}
