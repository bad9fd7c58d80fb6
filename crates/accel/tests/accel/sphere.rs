//! Analytic spheres in the BVH: hits against an f64 reference across
//! scales and distances, grazing rays, hits from inside, and rays leaving
//! the surface (offset with the hit point's error bound) that must not hit
//! the sphere they leave.

use crate::common;

use accel::{BuildOptions, BuildQuality, Bvh, Layout, Sphere, offset_ray_origin_bounded};
use common::*;
use glam::Vec3;
use stats::Pcg32;

fn layouts() -> [BuildOptions; 4] {
    Layout::ALL.map(|layout| BuildOptions {
        layout,
        quality: BuildQuality::Medium,
    })
}

/// Closest root t > 0 of the line against the sphere, by bisection-free
/// f64 algebra on the exact inputs (the textbook quadratic: this is a
/// reference, slow and straightforward).
fn reference_t(s: &Sphere, o: Vec3, d: Vec3) -> Option<f64> {
    let (o, d, c) = (o.as_dvec3(), d.as_dvec3(), s.center.as_dvec3());
    let r = f64::from(s.radius);
    let f = o - c;
    let a = d.dot(d);
    let b = 2.0 * f.dot(d);
    let cc = f.dot(f) - r * r;
    let disc = b * b - 4.0 * a * cc;
    if disc < 0.0 {
        return None;
    }
    let (t0, t1) = (
        (-b - disc.sqrt()) / (2.0 * a),
        (-b + disc.sqrt()) / (2.0 * a),
    );
    [t0, t1].into_iter().find(|&t| t > 0.0)
}

/// Rays from random far points towards random points near each sphere, for
/// radii 1e-3 to 1e4 and centres up to 1e4 radii from the origin: the BVH
/// reports the sphere when the reference hits it well inside (not within
/// 1e-4 of the silhouette, where rounding decides), misses it when the
/// reference misses well outside, and its t agrees to 1e-5 relative.
#[test]
fn hits_agree_with_the_reference_across_scales() {
    let mut rng = Pcg32::new(17, 2);
    for radius in [1e-3f32, 1.0, 1e4] {
        for far in [0.0f32, 1e2, 1e4] {
            let center = Vec3::new(0.3, -0.8, 0.52).normalize() * far * radius;
            let s = Sphere { center, radius };
            // A triangle beside it so the tree holds both kinds.
            let tri = [
                center + Vec3::new(3.0, 0.0, 0.0) * radius,
                center + Vec3::new(4.0, 0.0, 0.0) * radius,
                center + Vec3::new(3.0, 1.0, 0.0) * radius,
            ];
            for options in layouts() {
                let bvh = Bvh::build_with_spheres(&[tri], &[s], options);
                assert_eq!(bvh.sphere_of(1), Some(0));
                assert_eq!(bvh.sphere_of(0), None);
                let (mut hits, mut checked) = (0, 0);
                for _ in 0..2000 {
                    let o = center + random_unit(&mut rng) * radius * 50.0;
                    let target = center + random_unit(&mut rng) * radius * 1.2;
                    let d = target - o;
                    let want = reference_t(&s, o, d);
                    let miss_distance = {
                        let f = (o - center).as_dvec3();
                        let dd = d.as_dvec3();
                        let perp = f - dd * (f.dot(dd) / dd.dot(dd));
                        perp.length() / f64::from(radius) - 1.0
                    };
                    let triangle_t = reference_closest(&[tri], o, d, f32::INFINITY).map(|r| r.1);
                    if miss_distance.abs() < 1e-4
                        || triangle_t.is_some_and(|tt| want.is_none_or(|t| tt < t))
                    {
                        continue;
                    }
                    checked += 1;
                    let got = bvh.intersect(o, d, f32::INFINITY);
                    assert!(got.is_none_or(|h| h.primitive == 1));
                    match (want, got) {
                        (Some(t), Some(h)) => {
                            hits += 1;
                            assert!(
                                (f64::from(h.t) / t - 1.0).abs() < 1e-5,
                                "r {radius} far {far}: t {} vs {t}",
                                h.t
                            );
                            assert!(bvh.occluded(o, d, h.t * 1.001));
                            assert!(!bvh.occluded(o, d, h.t * 0.999));
                        }
                        (None, None) => {}
                        (w, g) => panic!("r {radius} far {far} {o} {d}: want {w:?}, got {g:?}"),
                    }
                }
                assert!(hits > 100 && checked > 1900, "{hits} {checked}");
            }
        }
    }
}

/// Rays tangent to the sphere to within 1e-6 of its radius, just inside
/// and just outside: inside ones hit (twice: near root first), outside ones
/// miss, with no NaN.
#[test]
fn grazing_rays() {
    let s = Sphere {
        center: Vec3::new(2.0, 1.0, -3.0),
        radius: 0.75,
    };
    let bvh = Bvh::build_with_spheres(&[], &[s], BuildOptions::default());
    for side in [1.0f32 - 1e-5, 1.0 + 1e-5] {
        let o = s.center + Vec3::new(-10.0, s.radius * side, 0.0);
        let hit = bvh.intersect(o, Vec3::X, f32::INFINITY);
        assert_eq!(hit.is_some(), side < 1.0, "{side}");
        if let Some(h) = hit {
            assert!((h.t - 10.0).abs() < 0.01 && h.t.is_finite());
        }
    }
}

/// A ray starting inside (the centre, or a point just inside the surface)
/// hits the far side; `t_max` short of it gives nothing.
#[test]
fn hits_from_inside() {
    let s = Sphere {
        center: Vec3::new(0.0, 5.0, 0.0),
        radius: 2.0,
    };
    let bvh = Bvh::build_with_spheres(&[], &[s], BuildOptions::default());
    let h = bvh
        .intersect(s.center, Vec3::new(0.0, 0.0, 0.5), f32::INFINITY)
        .unwrap();
    assert_eq!((h.t, h.primitive), (4.0, 0));
    assert!(bvh.intersect(s.center, Vec3::Z, 1.9).is_none());
    assert!(bvh.occluded(s.center, Vec3::Z, 2.1));
}

/// Rays leaving a sphere point (hit point reprojected, origin offset with
/// its error bound, [`offset_ray_origin_bounded`]) outward never hit the
/// sphere again; inward (refraction into glass) they hit its far side, never
/// the near one at t ~ 0. For radii 1e-3 to 1e4, near and far from the
/// world origin, at grazing and random angles, and a second bounce from
/// every hit.
#[test]
fn no_self_intersection() {
    let mut rng = Pcg32::new(5, 9);
    for radius in [1e-3f32, 1.0, 1e4] {
        for far in [0.0f32, 1e3] {
            let center = Vec3::new(-0.6, 0.2, 0.77) * far * radius;
            let s = Sphere { center, radius };
            let bvh = Bvh::build_with_spheres(&[], &[s], BuildOptions::default());
            let (mut self_hits, mut inward_misses) = (0, 0);
            for k in 0..3000 {
                // A camera ray to a random point of the sphere.
                let o = center + random_unit(&mut rng) * radius * 10.0;
                let target = center + random_unit(&mut rng) * radius * 0.9;
                let Some(h) = bvh.intersect(o, target - o, f32::INFINITY) else {
                    continue;
                };
                let (p, n, error) = s.hit_point(o, target - o, h.t);
                let cos = match k % 3 {
                    0 => [1e-4, -1e-4, 1e-2, -1e-2][k / 3 % 4],
                    _ => rng.uniform_f32() * 2.0 - 1.0,
                };
                let d = direction_at_angle(&mut rng, n, cos);
                let side = if d.dot(n) > 0.0 { n } else { -n };
                let o2 = offset_ray_origin_bounded(p, side, error);
                let hit = bvh.intersect(o2, d, f32::INFINITY);
                if d.dot(n) > 0.0 {
                    self_hits += usize::from(hit.is_some());
                    self_hits += usize::from(bvh.occluded(o2, d, f32::INFINITY));
                } else {
                    // The origin is strictly inside (f64), so every hit is
                    // the far side.
                    let inside = (o2.as_dvec3() - center.as_dvec3()).length() < f64::from(radius);
                    match hit {
                        Some(h2) if inside => {
                            let (q, m, e) = s.hit_point(o2, d, h2.t);
                            // Leave again, outward through the far side.
                            let cos3 = rng.uniform_f32();
                            let d3 = direction_at_angle(&mut rng, m, cos3);
                            let o3 = offset_ray_origin_bounded(q, m, e);
                            self_hits += usize::from(bvh.occluded(o3, d3, f32::INFINITY));
                        }
                        Some(_) => self_hits += 1,
                        None => inward_misses += 1,
                    }
                }
            }
            assert_eq!(self_hits, 0, "r {radius} far {far}");
            assert_eq!(inward_misses, 0, "r {radius} far {far}");
        }
    }
}

/// Spheres and triangles in one tree: the closest of both kinds wins, and
/// the build without spheres is the plain triangle BVH (same hits).
#[test]
fn mixed_with_triangles() {
    let mut rng = Pcg32::new(3, 3);
    let tris = cube_sphere(6, 1.0).triangles();
    let spheres: Vec<Sphere> = (0..40)
        .map(|_| Sphere {
            center: random_in_box(&mut rng, Vec3::splat(-3.0), Vec3::splat(3.0)),
            radius: 0.05 + 0.3 * rng.uniform_f32(),
        })
        .chain([Sphere {
            center: Vec3::ZERO,
            radius: f32::NAN,
        }])
        .collect();
    let plain = Bvh::build(&tris);
    for options in layouts() {
        let bvh = Bvh::build_with_spheres(&tris, &spheres, options);
        assert!(Bvh::build_with_spheres(&tris, &[], options).bounds() == plain.bounds());
        for _ in 0..3000 {
            let o = random_in_box(&mut rng, Vec3::splat(-5.0), Vec3::splat(5.0));
            let d = random_unit(&mut rng);
            let tri = reference_closest(&tris, o, d, f32::INFINITY).map(|r| r.1);
            let sph = spheres
                .iter()
                .enumerate()
                .filter_map(|(j, s)| reference_t(s, o, d).map(|t| (j, t)))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            let got = bvh.intersect(o, d, f32::INFINITY);
            let want_sphere = match (tri, sph) {
                (Some(tt), Some((_, ts))) => (ts < tt).then_some(sph.unwrap().0),
                (None, Some((j, _))) => Some(j),
                _ => None,
            };
            let got_sphere = got.and_then(|h| bvh.sphere_of(h.primitive));
            assert_eq!(got_sphere, want_sphere, "{o} {d}");
            assert_eq!(got.is_some(), tri.is_some() || sph.is_some());
        }
        assert_ne!(spheres.last().map(|s| s.radius.is_nan()), Some(false));
    }
}
