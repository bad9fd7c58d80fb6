//! The measurements behind the default `BuildOptions`: every obvhs layout and
//! build preset, build time and single-threaded rays per second, on the
//! ~1M-triangle scene and the Cornell box; plus obvhs' own traversal and
//! ray/triangle test (not watertight, not conservative) as a baseline for the
//! cost of this crate's robust node and triangle tests.
//!
//! Run one scene or variant with a filter, e.g.
//! `cargo bench -p rlt-accel --bench bvh_variants -- cluster_1m/wide-medium`.

mod common;

use std::hint::black_box;
use std::sync::OnceLock;
use std::time::Duration;

use accel::{BuildOptions, BuildQuality, Bvh, Layout};
use criterion::{Throughput, criterion_group, criterion_main};
use glam::Vec3A;
use obvhs::{
    BvhBuildParams,
    cwbvh::builder::build_cwbvh_from_tris,
    ray::{Ray, RayHit},
    triangle::Triangle,
};

const RAYS: usize = 256 * 256;

fn trace(bvh: &Bvh, rays: &[common::Ray], occlusion: bool) -> f32 {
    let mut acc = 0.0;
    for &(o, d, t_max) in rays {
        if occlusion {
            acc += f32::from(u8::from(bvh.occluded(o, d, t_max)));
        } else if let Some(h) = bvh.intersect(o, d, t_max) {
            acc += h.t;
        }
    }
    acc
}

fn name(options: BuildOptions) -> String {
    format!("{:?}-{:?}", options.layout, options.quality).to_lowercase()
}

fn bench(c: &mut criterion::Criterion) {
    for (scene, tris) in [
        ("cluster_1m", common::sphere_cluster()),
        ("cornell", common::cornell_box()),
    ] {
        let ray_sets = common::ray_sets(scene, RAYS);
        let mut group = c.benchmark_group(format!("variants/{scene}"));
        for layout in Layout::ALL {
            for quality in BuildQuality::ALL {
                let options = BuildOptions { layout, quality };
                let id = name(options);
                group.throughput(Throughput::Elements(tris.len() as u64));
                group.bench_function(format!("{id}/build"), |b| {
                    b.iter(|| Bvh::build_with(black_box(&tris), options))
                });
                // Built on first use, so that a filtered run builds only what
                // it measures.
                let bvh = OnceLock::new();
                group.throughput(Throughput::Elements(RAYS as u64));
                for (set, rays, occlusion) in &ray_sets {
                    group.bench_function(format!("{id}/{set}"), |b| {
                        let bvh = bvh.get_or_init(|| Bvh::build_with(&tris, options));
                        b.iter(|| trace(bvh, black_box(rays), *occlusion))
                    });
                }
            }
        }

        // obvhs alone: its CWBVH (medium preset), its SIMD node test and its
        // Möller–Trumbore triangle test, triangles reordered by slot.
        let obvhs_tris: Vec<Triangle> = tris
            .iter()
            .map(|t| Triangle {
                v0: t[0].into(),
                v1: t[1].into(),
                v2: t[2].into(),
            })
            .collect();
        let params = BvhBuildParams::medium_build();
        group.throughput(Throughput::Elements(tris.len() as u64));
        group.bench_function("obvhs-wide-medium/build", |b| {
            b.iter(|| {
                build_cwbvh_from_tris(black_box(&obvhs_tris), params, &mut Duration::default())
            })
        });
        let baseline = OnceLock::new();
        group.throughput(Throughput::Elements(RAYS as u64));
        for (set, rays, occlusion) in &ray_sets {
            group.bench_function(format!("obvhs-wide-medium/{set}"), |b| {
                let (cwbvh, slot_tris) = baseline.get_or_init(|| {
                    let cwbvh =
                        build_cwbvh_from_tris(&obvhs_tris, params, &mut Duration::default());
                    let slot_tris: Vec<Triangle> = cwbvh
                        .primitive_indices
                        .iter()
                        .map(|&i| obvhs_tris[i as usize])
                        .collect();
                    (cwbvh, slot_tris)
                });
                b.iter(|| {
                    let mut acc = 0.0;
                    for &(o, d, t_max) in black_box(rays) {
                        let ray = Ray::new(Vec3A::from(o), Vec3A::from(d), 0.0, t_max);
                        if *occlusion {
                            let miss =
                                cwbvh.ray_traverse_miss(ray, |r, id| slot_tris[id].intersect(r));
                            acc += f32::from(u8::from(!miss));
                        } else {
                            let mut hit = RayHit::none();
                            if cwbvh.ray_traverse(ray, &mut hit, |r, id| slot_tris[id].intersect(r))
                            {
                                acc += hit.t;
                            }
                        }
                    }
                    acc
                })
            });
        }
        group.finish();
    }
}

criterion_group! {
    name = benches;
    config = common::criterion();
    targets = bench
}
criterion_main!(benches);
