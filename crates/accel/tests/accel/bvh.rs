//! The BVH against an f64 brute-force reference, robustness of the origin
//! offset, and degenerate inputs.

use crate::common;

use accel::{BuildOptions, BuildQuality, Bvh, Layout, offset_ray_origin, offset_ray_origin_scaled};
use common::*;
use glam::Vec3;
use stats::Pcg32;

/// Every layout, with the fastest and the default preset, plus a pre-split one.
fn option_sets() -> Vec<BuildOptions> {
    let mut v = Vec::new();
    for layout in Layout::ALL {
        for quality in [
            BuildQuality::Binned,
            BuildQuality::Fastest,
            BuildQuality::Medium,
            BuildQuality::Slow,
        ] {
            v.push(BuildOptions { layout, quality });
        }
    }
    v
}

/// Checks every ray on every BVH (built from `tris` with different options)
/// against brute force, closest hit and occlusion, and fails with the first
/// few mismatches.
fn assert_rays(
    name: &str,
    bvhs: &[Bvh],
    tris: &[[Vec3; 3]],
    rays: impl IntoIterator<Item = (Vec3, Vec3, f32)>,
) {
    let mut errors = Vec::new();
    let mut count = 0;
    for ray @ (o, d, t_max) in rays {
        count += 1;
        let reference = reference_closest(tris, o, d, f32::INFINITY);
        for bvh in bvhs {
            if let Err(e) = check_ray(bvh, tris, ray, reference) {
                errors.push(format!("{:?}: {e}", bvh.layout()));
            }
            // Occlusion agrees with brute force, at t_max and around the hit.
            let mut t_maxes = vec![t_max];
            if let Some(h) = bvh.intersect(o, d, t_max) {
                t_maxes.extend([h.t * 0.999, h.t * 1.001]);
            }
            for tm in t_maxes {
                if let Some(want) = reference_occluded(reference, tm)
                    && bvh.occluded(o, d, tm) != want
                {
                    errors.push(format!("occluded({o:?}, {d:?}, {tm}) != {want}"));
                }
            }
        }
    }
    assert!(
        errors.is_empty(),
        "{name}: {} of {count} rays wrong, first: {:#?}",
        errors.len(),
        &errors[..errors.len().min(5)]
    );
}

/// One BVH per option set.
fn build_all(tris: &[[Vec3; 3]]) -> Vec<Bvh> {
    option_sets()
        .into_iter()
        .map(|o| Bvh::build_with(tris, o))
        .collect()
}

fn random_rays(rng: &mut Pcg32, n: usize, lo: Vec3, hi: Vec3) -> Vec<(Vec3, Vec3, f32)> {
    (0..n)
        .map(|i| {
            let o = random_in_box(rng, lo, hi);
            // Mix unit and non-unit directions, infinite and finite t_max.
            let d = random_unit(rng) * if i % 3 == 0 { 0.37 } else { 1.0 };
            let t_max = if i % 4 == 0 {
                0.5 + 2.0 * rng.uniform_f32()
            } else {
                f32::INFINITY
            };
            (o, d, t_max)
        })
        .collect()
}

#[test]
fn random_soups_match_brute_force() {
    let mut rng = Pcg32::new(1, 0);
    for (count, size) in [(1, 0.5), (7, 0.5), (300, 0.3), (3000, 0.15)] {
        let tris = random_soup(&mut rng, count, size);
        let rays = random_rays(&mut rng, 400, Vec3::splat(-1.5), Vec3::splat(1.5));
        let bvhs = build_all(&tris);
        for bvh in &bvhs {
            assert_eq!(bvh.triangle_count(), count);
        }
        assert_rays(&format!("soup {count}"), &bvhs, &tris, rays);
    }
}

#[test]
fn closed_meshes_match_brute_force_and_never_leak() {
    let mut rng = Pcg32::new(2, 0);
    for mesh in [unit_box(), cube_sphere(12, 1.0), cube_sphere(3, 1.0)] {
        let tris = mesh.triangles();
        let bvhs = build_all(&tris);
        // From inside, every ray hits (watertight), and matches brute force.
        let inside: Vec<_> = (0..400)
            .map(|_| {
                (
                    random_in_box(&mut rng, Vec3::splat(-0.5), Vec3::splat(0.5)),
                    random_unit(&mut rng),
                    f32::INFINITY,
                )
            })
            .collect();
        for bvh in &bvhs {
            for &(o, d, _) in &inside {
                assert!(bvh.intersect(o, d, f32::INFINITY).is_some(), "leak {o} {d}");
                assert!(bvh.occluded(o, d, f32::INFINITY));
            }
        }
        assert_rays("closed inside", &bvhs, &tris, inside);
        let outside = random_rays(&mut rng, 400, Vec3::splat(-3.0), Vec3::splat(3.0));
        assert_rays("closed outside", &bvhs, &tris, outside);
    }
}

/// Rays through points of shared edges and vertices: from inside closed meshes
/// (must hit: no cracks), and from either side at angles that cross every
/// face around the point transversally (so the reference answer is not
/// decided by rounding), including grazing ones.
#[test]
fn rays_through_edges_and_vertices() {
    let mut rng = Pcg32::new(3, 0);
    for (mesh, closed) in [
        (unit_box(), true),
        (cube_sphere(8, 1.0), true),
        (height_field(16), false),
    ] {
        let tris = mesh.triangles();
        let normals: Vec<Vec3> = tris.iter().map(geometric_normal).collect();
        let edges = mesh.interior_edges();
        let mut around: Vec<Vec<usize>> = vec![Vec::new(); mesh.vertices.len()];
        for (t, idx) in mesh.indices.iter().enumerate() {
            for &v in idx {
                around[v as usize].push(t);
            }
        }
        let boundary = mesh.boundary_vertices();
        let bvhs = build_all(&tris);
        let mut rays = Vec::new();
        let mut must_hit = Vec::new();
        for k in 0..600 {
            let (ta, tb, i, j) = edges[k % edges.len()];
            let (a, b) = (mesh.vertices[i as usize], mesh.vertices[j as usize]);
            // A point on the edge, or one of its vertices (not on the border
            // of an open mesh, where hit or miss is decided by rounding).
            let (target, faces) = match k % 5 {
                0 if !boundary[i as usize] => (a, around[i as usize].clone()),
                1 if !boundary[j as usize] => (b, around[j as usize].clone()),
                _ => (a + (b - a) * rng.uniform_f32(), vec![ta, tb]),
            };
            if closed {
                let o = random_in_box(&mut rng, Vec3::splat(-0.3), Vec3::splat(0.3));
                rays.push((o, target - o, f32::INFINITY));
                must_hit.push((o, target - o));
            }
            // From the front of every face around the point (outside for closed
            // meshes), then from the back of all (inside; below the field).
            for side in [1.0f32, -1.0] {
                let crosses =
                    |d: Vec3, cos: f32| faces.iter().all(|&f| d.dot(normals[f] * side) < -cos);
                if let Some(d) = (0..100)
                    .map(|_| random_unit(&mut rng))
                    .find(|&d| crosses(d, 0.2))
                {
                    let dist = 0.5 + 2.0 * rng.uniform_f32();
                    rays.push((target - d * dist, d, f32::INFINITY));
                }
                // Grazing: 0.05 from the plane of the first face.
                let na = normals[faces[0]] * side;
                if let Some(d) = (0..100)
                    .map(|_| direction_at_angle(&mut rng, -na, 0.05))
                    .find(|&d| crosses(d, 0.049))
                {
                    rays.push((target - d * 1.5, d, f32::INFINITY));
                }
            }
        }
        for bvh in &bvhs {
            for &(o, d) in &must_hit {
                assert!(
                    bvh.intersect(o, d, f32::INFINITY).is_some(),
                    "crack at {o} {d}"
                );
            }
        }
        assert_rays(
            &format!("edges closed={closed} n={}", tris.len()),
            &bvhs,
            &tris,
            rays,
        );
    }
}

/// Rays starting on surfaces, offset with `offset_ray_origin`, leaving in
/// random directions (some grazing), against brute force.
#[test]
fn rays_from_offset_surface_points_match_brute_force() {
    let mut rng = Pcg32::new(4, 0);
    let meshes = [
        height_field(24).triangles(),
        cube_sphere(10, 1.0).triangles(),
        random_soup(&mut Pcg32::new(5, 0), 1000, 0.3),
    ];
    for tris in meshes {
        let bvhs = build_all(&tris);
        let mut rays = Vec::new();
        for _ in 0..800 {
            let id = (rng.next_u32() as usize) % tris.len();
            let tri = tris[id];
            let p = random_point_on(&mut rng, &tri);
            let n = geometric_normal(&tri);
            let cos = match rng.next_u32() % 4 {
                0 => 0.01,
                _ => rng.uniform_f32() * 2.0 - 1.0,
            };
            let d = direction_at_angle(&mut rng, n, cos);
            let n_side = if d.dot(n) > 0.0 { n } else { -n };
            let o = offset_ray_origin(p, n_side);
            rays.push((o, d, f32::INFINITY));
            for bvh in &bvhs {
                assert_ne!(
                    bvh.intersect(o, d, f32::INFINITY).map(|h| h.primitive),
                    Some(id as u32),
                    "self-intersection"
                );
            }
        }
        assert_rays("offset origins", &bvhs, &tris, rays);
    }
}

/// Rays leaving a surface point (computed from barycentrics, offset along the
/// normal on the side they leave to) never hit the triangle they left, for
/// meshes from 1e-4 to 1e5 in size, at the origin and 1e4 sizes away.
#[test]
fn no_self_intersection_across_scales() {
    let mut rng = Pcg32::new(6, 0);
    let sphere = cube_sphere(10, 1.0);
    let field = height_field(12);
    for scale in [1e-4f32, 1e-2, 1.0, 1e2, 1e5] {
        for far in [0.0f32, 1e4] {
            let offset = Vec3::new(1.0, -0.7, 0.3) * far * scale;
            for (is_sphere, mesh) in [(true, &sphere), (false, &field)] {
                let mesh = mesh.transformed(scale, offset);
                // Rounding the translated vertices may break exact convexity.
                let convex = is_sphere && is_convex(&mesh, 1e-6);
                assert!(convex || !is_sphere || far > 0.0);
                let tris = mesh.triangles();
                let bvh = Bvh::build(&tris);
                let mut self_hits = 0;
                let mut convex_escapes_hit = 0;
                for k in 0..1500 {
                    let id = k % tris.len();
                    let tri = tris[id];
                    let n = (tri[1] - tri[0]).cross(tri[2] - tri[0]);
                    let p = random_point_on(&mut rng, &tri);
                    let nu = n.normalize();
                    let cos = match k % 3 {
                        0 => [1e-3, -1e-3, 1e-2, -1e-2][k / 3 % 4],
                        _ => rng.uniform_f32() * 2.0 - 1.0,
                    };
                    let d = direction_at_angle(&mut rng, nu, cos);
                    let n_side = if d.dot(n) > 0.0 { n } else { -n };
                    let o = offset_ray_origin(p, n_side);
                    let hit = bvh.intersect(o, d, f32::INFINITY);
                    if hit.is_some_and(|h| h.primitive as usize == id) {
                        self_hits += 1;
                    }
                    // Leaving a convex closed mesh outwards: nothing to hit.
                    if convex
                        && d.dot(n) > 0.0
                        && (hit.is_some() || bvh.occluded(o, d, f32::INFINITY))
                    {
                        convex_escapes_hit += 1;
                    }
                    // Occlusion over the first 1e-3 (relative to size) of travel
                    // along the leaving ray never reports the source either:
                    // only the source could be that close on a convex mesh.
                    if convex && d.dot(n) > 0.0 {
                        assert!(!bvh.occluded(o, d, 1e-3 * scale));
                    }
                    // A second bounce from the hit point, computed from the
                    // hit's barycentrics as a renderer does.
                    if let Some(h) = hit {
                        let t2 = tris[h.primitive as usize];
                        let q = t2[0] * (1.0 - h.b1 - h.b2) + t2[1] * h.b1 + t2[2] * h.b2;
                        let n2 = (t2[1] - t2[0]).cross(t2[2] - t2[0]);
                        let cos2 = rng.uniform_f32() * 2.0 - 1.0;
                        let d2 = direction_at_angle(&mut rng, n2.normalize(), cos2);
                        let n2_side = if d2.dot(n2) > 0.0 { n2 } else { -n2 };
                        let o2 = offset_ray_origin(q, n2_side);
                        if bvh
                            .intersect(o2, d2, f32::INFINITY)
                            .is_some_and(|h2| h2.primitive == h.primitive)
                        {
                            self_hits += 1;
                        }
                    }
                }
                assert_eq!(
                    self_hits, 0,
                    "self hits: scale {scale} far {far} sphere {is_sphere}"
                );
                assert_eq!(
                    convex_escapes_hit, 0,
                    "escapes hit: scale {scale} far {far}"
                );
            }
        }
    }
}

#[test]
fn degenerate_and_invalid_triangles_are_never_hit() {
    let mut rng = Pcg32::new(7, 0);
    let mut tris = height_field(20).triangles();
    let n = tris.len();
    for k in (0..n).step_by(7) {
        let [a, b, _] = tris[k];
        tris[k] = match k % 4 {
            0 => [a, b, a],
            1 => [a, a, a],
            // Exactly collinear along an axis.
            2 => [
                a,
                Vec3::new(a.x + 0.5, a.y, a.z),
                Vec3::new(a.x - 0.25, a.y, a.z),
            ],
            _ => [a, b, b],
        };
    }
    tris[3] = [Vec3::NAN, Vec3::ZERO, Vec3::X];
    tris[5] = [Vec3::INFINITY, Vec3::ZERO, Vec3::X];
    tris[9] = [Vec3::splat(1e20), Vec3::ZERO, Vec3::X];
    let reference: Vec<_> = tris
        .iter()
        .map(|t| {
            if t.iter()
                .all(|v| v.is_finite() && v.abs().max_element() <= accel::MAX_COORDINATE)
            {
                *t
            } else {
                [Vec3::ZERO; 3]
            }
        })
        .collect();
    let bvhs = build_all(&tris);
    for bvh in &bvhs {
        assert_eq!(bvh.triangle_count(), n);
        let (lo, hi) = bvh.bounds();
        assert!(lo.is_finite() && hi.is_finite());
    }
    let rays = random_rays(
        &mut rng,
        600,
        Vec3::new(-1.5, -1.0, -1.5),
        Vec3::new(1.5, 1.5, 1.5),
    );
    assert_rays("degenerate", &bvhs, &reference, rays);
}

#[test]
fn empty_and_all_degenerate_inputs_never_hit() {
    let all_degenerate = vec![
        [Vec3::ONE; 3],
        [Vec3::ZERO, Vec3::X, Vec3::X * 2.0],
        [Vec3::NAN; 3],
    ];
    for tris in [Vec::new(), all_degenerate] {
        for options in option_sets() {
            let bvh = Bvh::build_with(&tris, options);
            assert_eq!(bvh.triangle_count(), tris.len());
            assert!(
                bvh.intersect(Vec3::new(0.5, 1.0, 0.0), Vec3::NEG_Y, f32::INFINITY)
                    .is_none()
            );
            assert!(!bvh.occluded(Vec3::new(0.5, 1.0, 0.0), Vec3::NEG_Y, f32::INFINITY));
        }
    }
    assert_eq!(Bvh::build(&[]).bounds(), (Vec3::ZERO, Vec3::ZERO));
    assert!(Bvh::default().intersect(Vec3::ZERO, Vec3::X, 1.0).is_none());
    assert_eq!(
        Bvh::build(&[[Vec3::ONE; 3], [Vec3::NAN; 3]]).bounds(),
        (Vec3::ONE, Vec3::ONE)
    );
}

#[test]
fn invalid_rays_return_no_hit() {
    let tris = cube_sphere(4, 1.0).triangles();
    let bvh = Bvh::build(&tris);
    let o = Vec3::new(0.1, 0.2, 0.0);
    assert!(bvh.intersect(o, Vec3::X, f32::INFINITY).is_some());
    for (o, d, t) in [
        (o, Vec3::ZERO, f32::INFINITY),
        (o, Vec3::NAN, f32::INFINITY),
        (o, Vec3::new(f32::INFINITY, 0.0, 0.0), f32::INFINITY),
        (Vec3::NAN, Vec3::X, f32::INFINITY),
        (o, Vec3::X, 0.0),
        (o, Vec3::X, -1.0),
        (o, Vec3::X, f32::NAN),
    ] {
        assert!(bvh.intersect(o, d, t).is_none());
        assert!(!bvh.occluded(o, d, t));
    }
}

/// Axis-parallel rays, tiny and huge direction lengths, tiny and huge scenes:
/// the cases obvhs' own ray setup (direction clamp, node-test epsilon) gets wrong.
#[test]
fn axis_parallel_rays_and_extreme_scales() {
    let mut rng = Pcg32::new(8, 0);
    for scale in [1e-6f32, 1e-4, 1.0, 1e5, 1e12] {
        let tris = cube_sphere(6, 1.0)
            .transformed(scale, Vec3::ZERO)
            .triangles();
        let bvhs: Vec<Bvh> = Layout::ALL
            .into_iter()
            .map(|layout| {
                Bvh::build_with(
                    &tris,
                    BuildOptions {
                        layout,
                        ..Default::default()
                    },
                )
            })
            .collect();
        {
            let mut rays = Vec::new();
            for _ in 0..200 {
                let o = random_in_box(
                    &mut rng,
                    Vec3::splat(-0.5 * scale),
                    Vec3::splat(0.5 * scale),
                );
                let axis = [Vec3::X, Vec3::Y, Vec3::Z, -Vec3::X, -Vec3::Y, -Vec3::Z]
                    [(rng.next_u32() % 6) as usize];
                let len = [1e-20f32, 1e-3, 1.0, 1e20][(rng.next_u32() % 4) as usize];
                rays.push((o, axis * len, f32::INFINITY));
                // Nearly axis-parallel: one component below obvhs' 1.2e-7 clamp.
                let d = (axis + Vec3::new(3e-8, -5e-9, 1e-10)).normalize() * len;
                rays.push((o, d, f32::INFINITY));
                // Outside, aimed at the surface along an axis.
                let o2 = Vec3::new(o.x, o.y, -2.0 * scale);
                rays.push((o2, Vec3::Z * len, f32::INFINITY));
            }
            assert_rays(&format!("scale {scale}"), &bvhs, &tris, rays);
        }
    }
}

#[test]
fn single_triangles_and_tiny_counts() {
    let mut rng = Pcg32::new(9, 0);
    // Axis-aligned (flat bounds), single triangle, duplicates.
    let quad = vec![
        [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)],
        [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y],
    ];
    let one = vec![quad[0]];
    let dupes = vec![quad[0]; 300];
    for tris in [quad, one, dupes] {
        let bvhs = build_all(&tris);
        {
            let rays: Vec<_> = (0..300)
                .map(|_| {
                    let target = random_in_box(
                        &mut rng,
                        Vec3::new(-0.2, -0.2, 0.0),
                        Vec3::new(1.2, 1.2, 0.0),
                    );
                    let o = target + random_unit(&mut rng) * 2.0;
                    (o, target - o, f32::INFINITY)
                })
                .collect();
            assert_rays("tiny", &bvhs, &tris, rays);
        }
    }
}

/// Adversarial geometry (exponentially spaced triangles) gives deep trees;
/// the queries must stay exact (a too-deep CWBVH falls back to a BVH2).
#[test]
fn deep_trees_stay_exact() {
    let mut rng = Pcg32::new(10, 0);
    let tris = geometric_progression();
    let bvhs = build_all(&tris);
    for (bvh, options) in bvhs.iter().zip(option_sets()) {
        // Too deep for obvhs' CWBVH traversal stack: built as a BVH2. (The
        // binned builder caps its depth with median splits and stays wide.)
        if options.quality != BuildQuality::Binned {
            assert_eq!(bvh.layout(), Layout::Binary);
        }
    }
    {
        let rays: Vec<_> = (0..600)
            .map(|_| {
                let o = progression_origin(&mut rng);
                (
                    o,
                    Vec3::new(-1.0, 0.01 * (rng.uniform_f32() - 0.5), 0.0),
                    f32::INFINITY,
                )
            })
            .collect();
        assert_rays("deep", &bvhs, &tris, rays);
    }
}

/// The same build on 1 and 2 threads answers every query identically
/// (including which triangle of a tie is reported).
#[test]
fn build_is_independent_of_thread_count() -> Result<(), rayon::ThreadPoolBuildError> {
    let mut rng = Pcg32::new(11, 0);
    let tris = height_field(60).triangles();
    let rays: Vec<_> = (0..2000)
        .map(|_| {
            let target = random_in_box(
                &mut rng,
                Vec3::new(-1.0, 0.0, -1.0),
                Vec3::new(1.0, 0.0, 1.0),
            );
            // Aim at lattice lines (shared edges) half of the time.
            let target = if rng.next_u32().is_multiple_of(2) {
                (target * 30.0).round() / 30.0
            } else {
                target
            };
            (
                Vec3::new(target.x * 0.5, 2.0, target.z * 0.5),
                Vec3::new(target.x * 0.5, -2.0, target.z * 0.5),
            )
        })
        .collect();
    for options in option_sets() {
        let answers = |threads: usize| -> Result<Vec<_>, rayon::ThreadPoolBuildError> {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()?;
            let bvh = pool.install(|| Bvh::build_with(&tris, options));
            Ok(rays
                .iter()
                .map(|&(o, d)| (bvh.intersect(o, d, f32::INFINITY), bvh.occluded(o, d, 1.0)))
                .collect())
        };
        assert_eq!(answers(1)?, answers(2)?, "{options:?}");
    }
    Ok(())
}

/// Rays spawned inside a closed box of size 1e-4 from points on its inner
/// walls (offset with `offset_ray_origin` towards the inside) never escape:
/// each hits a wall, and so does a second bounce from that hit, and the
/// offset origins lie strictly inside the box. The box sits at the origin,
/// 1e-4 (one box size) from it, and 1e4 box sizes from it, with both
/// `offset_ray_origin` and `offset_ray_origin_scaled`; boxes of size 1e-5 and
/// 1e-6 near the origin need the scaled one (the chapter's fixed 1/65536
/// fallback jumps over them entirely: 4000 of 4000 rays escape).
///
/// Excluded: points that round onto an edge of the box (on the planes of two
/// walls at once; about 1 in 1000 at 1e4 box sizes from the origin, where f32
/// spaces coordinates 1e-3 box sizes apart). The offset moves them off one
/// wall only, so they still lie on the other wall's plane, and a ray leaving
/// through that plane starts at t = 0 on it: no offset along one normal can
/// help, that needs the triangle (see the report of this change).
#[test]
fn rays_never_leak_out_of_a_tiny_closed_box() {
    let mut rng = Pcg32::new(19, 4);
    let mut report = Vec::new();
    for (size, offset, scaled) in [
        (1e-4f32, Vec3::ZERO, false),
        (1e-4, Vec3::new(1.0, -0.7, 0.3) * 1e-4, false),
        (1e-4, Vec3::new(1.0, -0.7, 0.3), false),
        (1e-4, Vec3::ZERO, true),
        (1e-4, Vec3::new(1.0, -0.7, 0.3) * 1e-4, true),
        (1e-4, Vec3::new(1.0, -0.7, 0.3), true),
        (1e-5, Vec3::ZERO, true),
        (1e-6, Vec3::new(1.0, -0.7, 0.3) * 1e-6, true),
    ] {
        let mesh = unit_box().transformed(0.5 * size, offset);
        let tris = mesh.triangles();
        let (lo, hi) = (
            mesh.vertices.iter().fold(Vec3::INFINITY, |a, &v| a.min(v)),
            mesh.vertices
                .iter()
                .fold(Vec3::NEG_INFINITY, |a, &v| a.max(v)),
        );
        let centre = 0.5 * (lo + hi);
        // The offset, with the triangle's vertex magnitude as its scale.
        let spawn = |p: Vec3, n: Vec3, tri: &[Vec3; 3]| {
            if scaled {
                let scale = tri
                    .iter()
                    .map(|v| v.abs().max_element())
                    .fold(0.0, f32::max);
                offset_ray_origin_scaled(p, n, scale)
            } else {
                offset_ray_origin(p, n)
            }
        };
        let inside = |o: Vec3| o.cmpgt(lo).all() && o.cmplt(hi).all();
        // Whether a point on the wall with (axis-aligned) normal n also lies
        // on (or beyond) the plane of another wall: an edge point.
        let on_edge = |p: Vec3, n: Vec3| {
            let other = n.abs().cmplt(Vec3::splat(0.5));
            (other & (p.cmple(lo) | p.cmpge(hi))).any()
        };
        for bvh in build_all(&tris) {
            let (mut outside, mut escaped, mut escaped2, mut on_edges) = (0, 0, 0, 0);
            let rays = 4000;
            for k in 0..rays {
                let tri = tris[k % tris.len()];
                let p = random_point_on(&mut rng, &tri);
                let n = geometric_normal(&tri);
                if on_edge(p, n) {
                    on_edges += 1;
                    continue;
                }
                let n_in = if n.dot(centre - p) > 0.0 { n } else { -n };
                let cos = match k % 4 {
                    0 => [1e-3, 1e-2, 0.1][k / 4 % 3],
                    _ => rng.uniform_f32(),
                };
                let d = direction_at_angle(&mut rng, n_in, cos);
                let o = spawn(p, n_in, &tri);
                if !inside(o) {
                    outside += 1;
                }
                let Some(h) = bvh.intersect(o, d, f32::INFINITY) else {
                    escaped += 1;
                    continue;
                };
                if !bvh.occluded(o, d, f32::INFINITY) {
                    escaped += 1;
                }
                // A second bounce from the hit point, from its barycentrics.
                let t2 = tris[h.primitive as usize];
                let q = t2[0] * (1.0 - h.b1 - h.b2) + t2[1] * h.b1 + t2[2] * h.b2;
                let n2 = geometric_normal(&t2);
                if on_edge(q, n2) {
                    on_edges += 1;
                    continue;
                }
                let n2_in = if n2.dot(centre - q) > 0.0 { n2 } else { -n2 };
                let cos2 = rng.uniform_f32();
                let d2 = direction_at_angle(&mut rng, n2_in, cos2);
                let o2 = spawn(q, n2_in, &t2);
                if !inside(o2) || bvh.intersect(o2, d2, f32::INFINITY).is_none() {
                    escaped2 += 1;
                }
            }
            assert!(on_edges < rays / 100, "{on_edges} edge points");
            if outside + escaped + escaped2 > 0 {
                report.push(format!(
                    "box of size {size} at {offset} (scaled {scaled}, {:?}): {outside} origins outside, {escaped} rays and \
                     {escaped2} second bounces escaped of {rays}",
                    bvh.layout()
                ));
            }
        }
    }
    assert!(report.is_empty(), "{}", report.join("\n"));
}

/// Unit-size triangles through the origin, hit within 1e-6..1e-2 of it:
/// neither offset self-intersects (the hit point's error is ~ULP(1) there,
/// whatever |p|; an offset that followed |p| instead of the triangle's
/// scale self-intersected 3 % of these rays at |p| = 1e-4).
#[test]
fn no_self_intersection_near_the_origin_on_large_triangles() {
    let mut rng = Pcg32::new(19, 5);
    let mut self_hits = Vec::new();
    for r in [1e-2f32, 1e-3, 1e-4, 1e-5, 1e-6] {
        let mut hits = 0;
        for _ in 0..100 {
            let normal = Vec3::new(0.3 + rng.uniform_f32(), -0.2, 1.0).normalize();
            let (u, v) = normal.any_orthonormal_pair();
            let a = std::f32::consts::TAU * rng.uniform_f32();
            let tri = [
                (u * a.cos() + v * a.sin()) * 1.3,
                -u * 0.9 + v * 1.1,
                u * 0.1 - v * 1.2,
            ];
            let bvh = Bvh::build(&[tri]);
            let n = geometric_normal(&tri);
            let scale = tri
                .iter()
                .map(|v| v.abs().max_element())
                .fold(0.0, f32::max);
            // Barycentrics (f64) of points within r of the origin in the plane.
            let [v0, v1, v2] = tri.map(|v| v.as_dvec3());
            let (e1, e2) = (v1 - v0, v2 - v0);
            let (d11, d12, d22) = (e1.dot(e1), e1.dot(e2), e2.dot(e2));
            for _ in 0..100 {
                let q = (u * (rng.uniform_f32() - 0.5) + v * (rng.uniform_f32() - 0.5)) * 2.0 * r;
                let w = q.as_dvec3() - v0;
                let (w1, w2) = (w.dot(e1), w.dot(e2));
                let det = d11 * d22 - d12 * d12;
                let b1 = ((d22 * w1 - d12 * w2) / det) as f32;
                let b2 = ((d11 * w2 - d12 * w1) / det) as f32;
                let p = tri[0] * (1.0 - b1 - b2) + tri[1] * b1 + tri[2] * b2;
                let cos = [1e-3f32, 1e-2, 0.1, 0.5][(rng.next_u32() % 4) as usize];
                let cos = if rng.next_u32().is_multiple_of(2) {
                    cos
                } else {
                    -cos
                };
                let d = direction_at_angle(&mut rng, n, cos);
                let n_side = if d.dot(n) > 0.0 { n } else { -n };
                for o in [
                    offset_ray_origin(p, n_side),
                    offset_ray_origin_scaled(p, n_side, scale),
                ] {
                    if bvh.intersect(o, d, f32::INFINITY).is_some() {
                        hits += 1;
                    }
                }
            }
        }
        if hits > 0 {
            self_hits.push(format!("|p| ~ {r}: {hits} self hits of 20000"));
        }
    }
    assert!(self_hits.is_empty(), "{}", self_hits.join("\n"));
}

/// `intersect_where` / `occluded_where` skip rejected hits as if the
/// triangle were absent: accepting only even ids matches a BVH whose odd
/// triangles are degenerate (never hit, same ids), on every layout; a
/// barycentric filter (half of each triangle cut away) never returns a hit
/// in the cut half, and occlusion agrees with the closest accepted hit.
#[test]
fn filtered_queries_skip_rejected_hits() {
    let mut rng = Pcg32::new(11, 0);
    let tris = random_soup(&mut rng, 600, 0.3);
    let even_only: Vec<[Vec3; 3]> = tris
        .iter()
        .enumerate()
        .map(|(i, t)| if i % 2 == 0 { *t } else { [t[0]; 3] })
        .collect();
    let rays = random_rays(&mut rng, 600, Vec3::splat(-1.5), Vec3::splat(1.5));
    let (mut hits, mut cut_hits) = (0, 0);
    for options in option_sets() {
        let bvh = Bvh::build_with(&tris, options);
        let reference = Bvh::build_with(&even_only, options);
        for &(o, d, t_max) in &rays {
            let even = |id: u32, _: f32, _: f32| id.is_multiple_of(2);
            let got = bvh.intersect_where(o, d, t_max, even);
            let want = reference.intersect(o, d, t_max);
            assert_eq!(
                got.map(|h| h.primitive),
                want.map(|h| h.primitive),
                "{o} {d}"
            );
            assert_eq!(bvh.occluded_where(o, d, t_max, even), want.is_some());
            hits += usize::from(want.is_some());

            let half = |_: u32, b1: f32, _: f32| b1 < 0.5;
            let cut = bvh.intersect_where(o, d, t_max, half);
            if let Some(h) = cut {
                // Refined barycentrics differ from the test's by rounding only.
                assert!(h.b1 < 0.5 + 1e-4, "hit in the cut half: b1 = {}", h.b1);
                cut_hits += 1;
            }
            assert_eq!(bvh.occluded_where(o, d, t_max, half), cut.is_some());
            // Accepting everything is the plain query.
            assert_eq!(
                bvh.intersect_where(o, d, t_max, |_, _, _| true),
                bvh.intersect(o, d, t_max)
            );
        }
    }
    assert!(
        hits > 300 && cut_hits > 300,
        "{hits} {cut_hits} hits: the rays must test something"
    );
}
