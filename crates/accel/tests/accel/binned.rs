//! The binned SAH builder (the default, `BuildQuality::Binned`) against an
//! f64 brute-force reference, in both layouts, on inputs that stress its
//! binning (soups, degenerate distributions, spheres); the `bvh.rs` tests
//! (thread independence, ties, offsets) run it beside the obvhs presets.
//! (That every primitive is in exactly one leaf and every box encloses its
//! subtree is checked on the builder's own tree, in `src/binned.rs`.)

use crate::common;

use accel::{BuildOptions, BuildQuality, Bvh, Layout, Sphere};
use common::*;
use glam::Vec3;
use stats::Pcg32;

/// The binned builder in every layout (the first is the default).
fn options() -> [BuildOptions; 4] {
    Layout::ALL.map(|layout| BuildOptions {
        layout,
        quality: BuildQuality::Binned,
    })
}

/// Every ray against brute force, closest hit and occlusion.
fn assert_rays(name: &str, tris: &[[Vec3; 3]], rays: &[(Vec3, Vec3, f32)]) {
    assert_eq!(options()[0], BuildOptions::default());
    for options in options() {
        let bvh = Bvh::build_with(tris, options);
        assert_eq!(bvh.triangle_count(), tris.len());
        let mut errors = Vec::new();
        for &ray @ (o, d, t_max) in rays {
            let reference = reference_closest(tris, o, d, f32::INFINITY);
            if let Err(e) = check_ray(&bvh, tris, ray, reference) {
                errors.push(e);
            }
            if let Some(want) = reference_occluded(reference, t_max)
                && bvh.occluded(o, d, t_max) != want
            {
                errors.push(format!("occluded({o:?}, {d:?}, {t_max}) != {want}"));
            }
        }
        assert!(
            errors.is_empty(),
            "{name} {options:?}: {} of {} rays wrong, first: {:#?}",
            errors.len(),
            rays.len(),
            &errors[..errors.len().min(5)]
        );
    }
}

fn random_rays(rng: &mut Pcg32, n: usize, lo: Vec3, hi: Vec3) -> Vec<(Vec3, Vec3, f32)> {
    (0..n)
        .map(|i| {
            let o = random_in_box(rng, lo, hi);
            let t_max = if i % 4 == 0 { 0.5 } else { f32::INFINITY };
            (o, random_unit(rng), t_max)
        })
        .collect()
}

#[test]
fn soups_meshes_and_height_fields_match_brute_force() {
    let mut rng = Pcg32::new(21, 0);
    for (count, size) in [(1, 0.5), (2, 0.5), (17, 0.5), (3000, 0.15)] {
        let tris = random_soup(&mut rng, count, size);
        let rays = random_rays(&mut rng, 400, Vec3::splat(-1.5), Vec3::splat(1.5));
        assert_rays(&format!("soup {count}"), &tris, &rays);
    }
    for (name, mesh) in [
        ("box", unit_box()),
        ("sphere", cube_sphere(12, 1.0)),
        ("height field", height_field(40)),
    ] {
        let tris = mesh.triangles();
        let rays = random_rays(&mut rng, 600, Vec3::splat(-2.0), Vec3::splat(2.0));
        assert_rays(name, &tris, &rays);
    }
}

/// Boxes in a geometric progression (each split peels one off) and
/// coincident triangles (no split separates their centroids).
#[test]
fn degenerate_distributions_match_brute_force() {
    let mut rng = Pcg32::new(22, 0);
    let progression = geometric_progression();
    let rays: Vec<_> = (0..400)
        .map(|_| {
            let o = progression_origin(&mut rng);
            (o, Vec3::new(-1.0, 0.0, 0.0), f32::INFINITY)
        })
        .collect();
    assert_rays("progression", &progression, &rays);
    let tri = [Vec3::ZERO, Vec3::X, Vec3::Y];
    let same = vec![tri; 500];
    let rays: Vec<_> = (0..100)
        .map(|_| {
            let p = random_point_on(&mut rng, &tri);
            (p + Vec3::Z, -Vec3::Z, f32::INFINITY)
        })
        .collect();
    assert_rays("coincident", &same, &rays);
}

/// Spheres and triangles in one binned tree: a ray down the axis of a
/// row of spheres above a floor hits the nearest sphere; between them,
/// the floor.
#[test]
fn spheres_and_triangles_share_the_tree() {
    let floor = [
        [
            Vec3::new(-10.0, 0.0, -10.0),
            Vec3::new(10.0, 0.0, 10.0),
            Vec3::new(10.0, 0.0, -10.0),
        ],
        [
            Vec3::new(-10.0, 0.0, -10.0),
            Vec3::new(-10.0, 0.0, 10.0),
            Vec3::new(10.0, 0.0, 10.0),
        ],
    ];
    let spheres: Vec<Sphere> = (0..50)
        .map(|i| Sphere {
            center: Vec3::new(-9.0 + 0.36 * i as f32, 1.0, 0.0),
            radius: 0.1,
        })
        .collect();
    for options in options() {
        let bvh = Bvh::build_with_spheres(&floor, &spheres, options);
        for (j, s) in spheres.iter().enumerate() {
            let hit = bvh
                .intersect(s.center + Vec3::Y * 5.0, -Vec3::Y, f32::INFINITY)
                .expect("a hit");
            assert_eq!(bvh.sphere_of(hit.primitive), Some(j));
            assert!((hit.t - 4.9).abs() < 1e-4, "{}", hit.t);
            let between = s.center + Vec3::new(0.18, 5.0, 0.0);
            let hit = bvh.intersect(between, -Vec3::Y, f32::INFINITY).unwrap();
            assert!(hit.primitive < 2 && (hit.t - 6.0).abs() < 1e-4);
        }
    }
}
