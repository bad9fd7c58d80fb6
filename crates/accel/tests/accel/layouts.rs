//! The layouts against each other: every ray's answer is the same bits
//! whatever the layout, ties at equal distance included (rays through
//! shared vertices, where several triangles meet at exactly the same `t`,
//! go to the lowest primitive id).

use accel::{BuildOptions, Bvh, Hit, Layout};
use glam::Vec3;
use stats::Pcg32;

use crate::common::*;

/// Eight rays from one place: the bundles of [`rays`].
const BUNDLE: usize = 8;

/// A ray: origin, direction, t_max.
#[derive(Clone, Copy, Debug)]
struct Ray {
    origin: Vec3,
    direction: Vec3,
    t_max: f32,
}

type Answer = (Option<[u32; 4]>, bool);

fn bits(h: Hit) -> [u32; 4] {
    [h.t.to_bits(), h.primitive, h.b1.to_bits(), h.b2.to_bits()]
}

/// Each ray's answer from single-ray queries.
fn single(bvh: &Bvh, rays: &[Ray]) -> Vec<Answer> {
    rays.iter()
        .map(|r| {
            (
                bvh.intersect(r.origin, r.direction, r.t_max).map(bits),
                bvh.occluded(r.origin, r.direction, r.t_max),
            )
        })
        .collect()
}

/// Bundles of eight coherent rays: from one origin towards a small patch
/// (camera-like), or straight down onto vertices of `vertices`; then
/// incoherent ones, some degenerate.
fn rays(rng: &mut Pcg32, tris: &[[Vec3; 3]], vertices: &[Vec3], count: usize) -> Vec<Ray> {
    let (lo, hi) = Bvh::build(tris).bounds();
    let pad = (hi - lo) * 0.25;
    let mut rays = Vec::with_capacity(count);
    while rays.len() < count / 2 {
        let origin = random_in_box(rng, lo - pad, hi + pad);
        let aim = rng.next_u32() as usize % tris.len();
        let centre = random_point_on(rng, &tris[aim]);
        let spread = (hi - lo).max_element() * 0.02;
        let onto_vertices = !vertices.is_empty() && rays.len() % (3 * BUNDLE) == 0;
        for k in 0..BUNDLE {
            if onto_vertices {
                // Straight down onto a vertex: its sheared coordinates are
                // exactly zero, so every triangle around it is hit at one t.
                let v = vertices[rng.next_u32() as usize % vertices.len()];
                rays.push(Ray {
                    origin: v + Vec3::Y * 4.0,
                    direction: -Vec3::Y,
                    t_max: f32::INFINITY,
                });
                continue;
            }
            let target = centre + (random_unit(rng) * spread);
            let t_max = [f32::INFINITY, 1.0, 0.5][k % 3];
            rays.push(Ray {
                origin,
                direction: target - origin,
                t_max,
            });
        }
    }
    while rays.len() < count {
        let origin = random_in_box(rng, lo - pad, hi + pad);
        let direction = match rays.len() % 17 {
            0 => Vec3::ZERO,
            1 => Vec3::new(f32::NAN, 0.0, 1.0),
            _ => random_unit(rng),
        };
        rays.push(Ray {
            origin,
            direction,
            t_max: f32::INFINITY,
        });
    }
    rays
}

/// A scene: name, triangles, vertices to aim rays straight down onto.
type Scene = (&'static str, Vec<[Vec3; 3]>, Vec<Vec3>);

/// Each scene's rays answered by `reference` and by each layout of
/// `others`: the same bits; returns how many rays through shared vertices
/// hit (where several triangles meet at exactly the same `t`).
fn compare_layouts(
    rng: &mut Pcg32,
    scenes: Vec<Scene>,
    reference: Layout,
    others: &[Layout],
) -> usize {
    let mut ties = 0;
    for (name, tris, vertices) in scenes {
        let rays = rays(rng, &tris, &vertices, 4000);
        let build = |layout| {
            let bvh = Bvh::build_with(
                &tris,
                BuildOptions {
                    layout,
                    ..Default::default()
                },
            );
            assert_eq!(bvh.layout(), layout, "{name}");
            bvh
        };
        let expected = single(&build(reference), &rays);
        let hits = expected.iter().filter(|a| a.0.is_some()).count();
        assert!(hits > rays.len() / 20, "{name}: only {hits} hits");
        ties += rays
            .iter()
            .zip(&expected)
            .filter(|(r, a)| a.0.is_some() && r.direction == -Vec3::Y)
            .count();
        for &layout in others {
            let answers = single(&build(layout), &rays);
            for (i, a) in answers.iter().enumerate() {
                assert_eq!(
                    *a, expected[i],
                    "{name}, {layout:?}, ray {i}: {:?}",
                    rays[i]
                );
            }
        }
    }
    ties
}

#[test]
fn every_layout_gives_the_same_hits_ties_included() {
    let mut rng = Pcg32::new(46, 0);
    let field = height_field(24);
    let scenes = vec![
        ("height field", field.triangles(), field.vertices.clone()),
        ("cube sphere", cube_sphere(8, 1.0).triangles(), vec![]),
        ("soup", random_soup(&mut rng, 2000, 0.05), vec![]),
    ];
    let others = [Layout::Bvh8, Layout::Binary];
    let ties = compare_layouts(&mut rng, scenes, Layout::Wide, &others);
    assert!(ties > 100, "only {ties} rays through shared vertices hit");
}

/// Scenes of at most 64 triangles, where [`Layout::Flat`] scans every
/// triangle without a tree (and [`Layout::Wide`] may, by the CPU): the
/// same bits as the binary tree's traversal, ties at shared vertices
/// included.
#[test]
fn the_flat_scan_gives_the_trees_hits() {
    let mut rng = Pcg32::new(47, 0);
    let field = height_field(4);
    let scenes = vec![
        ("height field", field.triangles(), field.vertices.clone()),
        ("box", unit_box().triangles(), unit_box().vertices.clone()),
        ("soup", random_soup(&mut rng, 64, 0.3), vec![]),
    ];
    assert!(scenes.iter().all(|(_, tris, _)| tris.len() <= 64));
    let ties = compare_layouts(&mut rng, scenes, Layout::Binary, &[Layout::Flat]);
    assert!(ties > 100, "only {ties} rays through shared vertices hit");
    // Beyond 64 triangles the layout is the compressed tree.
    let big = random_soup(&mut rng, 65, 0.3);
    let options = BuildOptions {
        layout: Layout::Flat,
        ..Default::default()
    };
    assert_eq!(Bvh::build_with(&big, options).layout(), Layout::Wide);
}
