//! BVH build time and rays per second with the default build options, on a
//! generated ~1M-triangle scene (64 bumpy spheres) and the Cornell box.
//!
//! Throughput is reported in rays ("elements") per second: single-threaded
//! (`st`) and on the whole rayon pool (`mt`). Coherent: primary rays from a
//! 512 x 512 pinhole grid; incoherent: random origins in the scene box with
//! uniform directions; occlusion: random segments in the scene box.

mod common;

use std::hint::black_box;

use accel::Bvh;
use criterion::{Throughput, criterion_group, criterion_main};
use rayon::prelude::*;

const RAYS: usize = 512 * 512;

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

fn trace_parallel(bvh: &Bvh, rays: &[common::Ray], occlusion: bool) -> f32 {
    rays.par_chunks(1024)
        .map(|c| trace(bvh, c, occlusion))
        .sum()
}

fn bench(c: &mut criterion::Criterion) {
    for (scene, tris) in [
        ("cluster_1m", common::sphere_cluster()),
        ("cornell", common::cornell_box()),
    ] {
        let mut group = c.benchmark_group(format!("bvh/{scene}"));
        group.throughput(Throughput::Elements(tris.len() as u64));
        group.bench_function("build", |b| b.iter(|| Bvh::build(black_box(&tris))));
        let bvh = Bvh::build(&tris);
        group.throughput(Throughput::Elements(RAYS as u64));
        for (name, rays, occlusion) in common::ray_sets(scene, RAYS) {
            group.bench_function(format!("{name}/st"), |b| {
                b.iter(|| trace(&bvh, black_box(&rays), occlusion))
            });
            group.bench_function(format!("{name}/mt"), |b| {
                b.iter(|| trace_parallel(&bvh, black_box(&rays), occlusion))
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
