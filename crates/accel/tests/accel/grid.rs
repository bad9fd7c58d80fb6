//! The photon hash grid against brute force, and its independence of the
//! number of threads.

use accel::HashGrid;
use glam::Vec3;
use stats::Pcg32;

/// The documented inclusion test: f64 from the f32 inputs.
fn within(p: Vec3, q: Vec3, r: f32) -> bool {
    let d = p.as_dvec3() - q.as_dvec3();
    d.x * d.x + d.y * d.y + d.z * d.z <= f64::from(r) * f64::from(r)
}

fn brute_force(points: &[Vec3], q: Vec3, r: f32) -> Vec<usize> {
    if !(r >= 0.0) || !q.is_finite() {
        return Vec::new();
    }
    (0..points.len())
        .filter(|&i| within(points[i], q, r))
        .collect()
}

fn query(grid: &HashGrid, q: Vec3, r: f32) -> Vec<usize> {
    let mut found = Vec::new();
    grid.for_each_within(q, r, |i| found.push(i));
    found
}

fn sorted(mut v: Vec<usize>) -> Vec<usize> {
    v.sort_unstable();
    v
}

fn uniform(rng: &mut Pcg32, lo: f32, hi: f32) -> f32 {
    lo + (hi - lo) * rng.uniform_f32()
}

/// Points on a dyadic lattice (exact sums), with duplicates, clusters and a
/// few far outliers; the first one repeated.
fn test_points(rng: &mut Pcg32, n: usize) -> Vec<Vec3> {
    let mut points: Vec<Vec3> = (0..n)
        .map(|i| match i % 10 {
            // Coordinates on a 2^-10 lattice: p + (2, 3, 6) * 2^-10 * k is exact.
            0..=5 => Vec3::new(
                (rng.next_u32() % 1024) as f32 / 1024.0,
                (rng.next_u32() % 1024) as f32 / 1024.0,
                (rng.next_u32() % 1024) as f32 / 1024.0,
            ),
            6 | 7 => Vec3::new(
                uniform(rng, -0.5, 1.5),
                uniform(rng, 0.0, 1.0),
                uniform(rng, 0.0, 0.01),
            ),
            8 => {
                Vec3::splat(0.25) + Vec3::new(uniform(rng, 0.0, 1e-3), uniform(rng, 0.0, 1e-3), 0.0)
            }
            _ => Vec3::new(
                uniform(rng, -1e3, 1e3),
                uniform(rng, -1e3, 1e3),
                -uniform(rng, 0.0, 1e3),
            ),
        })
        .collect();
    let first = points[0];
    points.extend([first; 5]);
    points
}

fn test_queries(rng: &mut Pcg32, points: &[Vec3], build_radius: f32) -> Vec<(Vec3, f32)> {
    let mut queries = Vec::new();
    // A 2^-10-lattice radius (7 * 2^-10) for exact boundary cases.
    let lattice_r = 7.0 / 1024.0;
    for k in 0..1500 {
        let p = points[(rng.next_u32() as usize) % points.len()];
        let r = match k % 6 {
            0 => build_radius,
            1 => build_radius * uniform(rng, 0.0, 1.0),
            2 => build_radius * uniform(rng, 1.0, 4.0),
            3 => lattice_r,
            4 => 0.0,
            _ => build_radius * 0.5,
        };
        let q = match k % 5 {
            // Exactly at distance 7 * 2^-10 from a lattice point: |(2, 3, 6)| = 7.
            0 => p + Vec3::new(2.0, -3.0, 6.0) / 1024.0,
            1 => p + Vec3::new(lattice_r, 0.0, 0.0),
            2 => p,
            3 => Vec3::new(
                uniform(rng, -0.2, 1.2),
                uniform(rng, -0.2, 1.2),
                uniform(rng, -0.2, 1.2),
            ),
            _ => {
                p + Vec3::new(
                    uniform(rng, -1.0, 1.0),
                    uniform(rng, -1.0, 1.0),
                    uniform(rng, -1.0, 1.0),
                ) * build_radius
            }
        };
        queries.push((q, r));
    }
    queries
}

#[test]
fn queries_match_brute_force() {
    let mut rng = Pcg32::new(21, 0);
    let mut grid = HashGrid::new();
    let mut exact_boundary_hits = 0;
    for (n, build_radius) in [
        (1, 0.01),
        (10, 0.5),
        (3000, 0.01),
        (8000, 0.004),
        (8000, 0.05),
    ] {
        let points = test_points(&mut rng, n);
        grid.build(&points, build_radius);
        assert_eq!(grid.len(), points.len());
        assert_eq!(grid.cell_size(), 2.0 * build_radius);
        for (q, r) in test_queries(&mut rng, &points, build_radius) {
            let found = query(&grid, q, r);
            let want = brute_force(&points, q, r);
            assert_eq!(
                sorted(found.clone()),
                want,
                "n {n} build r {build_radius} q {q} r {r}"
            );
            // Each index once.
            assert_eq!(found.len(), want.len());
            exact_boundary_hits += want
                .iter()
                .filter(|&&i| (points[i] - q).length_squared() == r * r && r > 0.0)
                .count();
        }
    }
    // The exact-distance cases were exercised.
    assert!(exact_boundary_hits > 100, "{exact_boundary_hits}");
}

#[test]
fn large_radius_and_degenerate_inputs() {
    let mut rng = Pcg32::new(22, 0);
    let mut points = test_points(&mut rng, 2000);
    points.push(Vec3::NAN);
    points.push(Vec3::new(f32::INFINITY, 0.0, 0.0));
    for build_radius in [0.01, 0.0, -1.0, f32::NAN, f32::INFINITY, 1e-30] {
        let grid = HashGrid::with_points(&points, build_radius);
        for (q, r) in [
            (Vec3::splat(0.5), 1e4),      // every finite point: scans
            (Vec3::splat(0.5), 0.3),      // many cells
            (Vec3::splat(0.25), 0.0),     // radius 0: coincident points only
            (Vec3::splat(0.5), -1.0),     // nothing
            (Vec3::splat(0.5), f32::NAN), // nothing
            (Vec3::NAN, 1.0),             // nothing
            (Vec3::splat(1e30), 1.0),     // far away
            (points[0], f32::INFINITY),   // every finite point
        ] {
            assert_eq!(
                sorted(query(&grid, q, r)),
                brute_force(&points, q, r),
                "build r {build_radius} q {q} r {r}"
            );
        }
    }
    let empty = HashGrid::with_points(&[], 0.1);
    assert!(empty.is_empty());
    assert!(query(&empty, Vec3::ZERO, 1.0).is_empty());
    assert!(query(&HashGrid::new(), Vec3::ZERO, 1.0).is_empty());
}

/// The set and the order of the reported indices do not depend on the number
/// of threads the grid was built with.
#[test]
fn results_do_not_depend_on_thread_count() -> Result<(), rayon::ThreadPoolBuildError> {
    let mut rng = Pcg32::new(23, 0);
    let points = test_points(&mut rng, 50_000);
    let queries = test_queries(&mut rng, &points, 0.01);
    let answers = |threads: usize| -> Result<Vec<Vec<usize>>, rayon::ThreadPoolBuildError> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()?;
        let grid = pool.install(|| HashGrid::with_points(&points, 0.01));
        Ok(queries.iter().map(|&(q, r)| query(&grid, q, r)).collect())
    };
    let one = answers(1)?;
    let two = answers(2)?;
    assert_eq!(one, two);
    for (&(q, r), found) in queries.iter().zip(&one).step_by(10) {
        assert_eq!(sorted(found.clone()), brute_force(&points, q, r));
    }
    Ok(())
}

#[test]
fn rebuild_with_fewer_points_forgets_old_ones() {
    let mut rng = Pcg32::new(24, 0);
    let points = test_points(&mut rng, 5000);
    let mut grid = HashGrid::with_points(&points, 0.02);
    grid.build(&points[..100], 0.05);
    assert_eq!(grid.len(), 100);
    for (q, r) in test_queries(&mut rng, &points[..100], 0.05) {
        assert_eq!(
            sorted(query(&grid, q, r)),
            brute_force(&points[..100], q, r)
        );
    }
    // build_with: points held in another struct.
    let photons: Vec<(u8, Vec3)> = points.iter().map(|&p| (0, p)).collect();
    grid.build_with(photons.len(), 0.02, |i| photons[i].1);
    for (q, r) in test_queries(&mut rng, &points, 0.02).into_iter().take(200) {
        assert_eq!(sorted(query(&grid, q, r)), brute_force(&points, q, r));
    }
}

/// Slots: `point_index` is a permutation of the indices, and a query by slot
/// reports the slots of the points that the query by index reports, in the
/// same order; data kept in slot order is found at the reported slot.
#[test]
fn slot_queries_are_index_queries_in_storage_order() {
    let mut rng = Pcg32::new(25, 0);
    let points = test_points(&mut rng, 8000);
    let grid = HashGrid::with_points(&points, 0.01);
    let order: Vec<usize> = (0..grid.len()).map(|s| grid.point_index(s)).collect();
    assert_eq!(sorted(order.clone()), (0..points.len()).collect::<Vec<_>>());
    let in_slot_order: Vec<Vec3> = order.iter().map(|&i| points[i]).collect();
    let mut reported = 0;
    for (q, r) in test_queries(&mut rng, &points, 0.01) {
        let mut slots = Vec::new();
        grid.for_each_slot_within(q, r, |s| slots.push(s));
        let by_slot: Vec<usize> = slots.iter().map(|&s| grid.point_index(s)).collect();
        assert_eq!(
            sorted(by_slot.clone()),
            brute_force(&points, q, r),
            "q {q} r {r}"
        );
        assert_eq!(by_slot, query(&grid, q, r), "q {q} r {r}");
        for &s in &slots {
            assert!(within(in_slot_order[s], q, r), "slot {s}: q {q} r {r}");
        }
        reported += slots.len();
    }
    assert!(reported > 1000, "{reported}");
}
