//! Photon hash grid: parallel build over 1M points and range-query throughput.
//!
//! Points ("photons") lie on the surfaces of 64 spheres in a 30^3 box, the
//! way photons lie on surfaces; queries are other surface points, with the
//! build radius chosen so that a query finds about 50 photons.

mod common;

use std::hint::black_box;

use accel::HashGrid;
use criterion::{Throughput, criterion_group, criterion_main};
use glam::Vec3;
use rayon::prelude::*;
use stats::Pcg32;

const PHOTONS: usize = 1_000_000;
const QUERIES: usize = 100_000;

fn surface_points(n: usize, seed: u64) -> Vec<Vec3> {
    let mut spheres = Pcg32::new(77, 0);
    let spheres: Vec<(Vec3, f32)> = (0..64)
        .map(|_| {
            let c = Vec3::new(
                spheres.uniform_f32() * 24.0 - 12.0,
                spheres.uniform_f32() * 24.0 - 12.0,
                spheres.uniform_f32() * 24.0 - 12.0,
            );
            (c, 1.5 + 2.5 * spheres.uniform_f32())
        })
        .collect();
    let mut rng = Pcg32::new(seed, 3);
    (0..n)
        .map(|_| {
            let (c, r) = spheres[(rng.next_u32() % 64) as usize];
            let u = rng.uniform_vec2();
            let z = 1.0 - 2.0 * u.x;
            let s = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * u.y;
            c + Vec3::new(s * phi.cos(), s * phi.sin(), z) * r
        })
        .collect()
}

fn query_all(grid: &HashGrid, queries: &[Vec3], radius: f32) -> usize {
    let mut found = 0;
    for &q in queries {
        grid.for_each_within(q, radius, |i| found += i & 1);
    }
    found
}

fn bench(c: &mut criterion::Criterion) {
    let photons = surface_points(PHOTONS, 1);
    let queries = surface_points(QUERIES, 2);
    // Mean sphere area is 4 pi E[r^2] = 4 pi * 7.58; density = n / (64 * that).
    let density = PHOTONS as f32 / (64.0 * 4.0 * std::f32::consts::PI * 7.58);
    let radius = (50.0 / (std::f32::consts::PI * density)).sqrt();

    let mut grid = HashGrid::new();
    grid.build(&photons, radius);
    let mut total = 0;
    for &q in &queries {
        grid.for_each_within(q, radius, |_| total += 1);
    }
    println!(
        "grid: {PHOTONS} photons, radius {radius:.4}, {:.1} photons per query",
        total as f64 / QUERIES as f64
    );

    let mut group = c.benchmark_group("grid");
    group.throughput(Throughput::Elements(PHOTONS as u64));
    group.bench_function("build_1m/mt", |b| {
        b.iter(|| grid.build(black_box(&photons), radius))
    });
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .expect("thread pool");
    group.bench_function("build_1m/st", |b| {
        b.iter(|| pool.install(|| grid.build(black_box(&photons), radius)))
    });
    grid.build(&photons, radius);
    group.throughput(Throughput::Elements(QUERIES as u64));
    group.bench_function("query/st", |b| {
        b.iter(|| query_all(&grid, black_box(&queries), radius))
    });
    group.bench_function("query/mt", |b| {
        b.iter(|| {
            black_box(&queries)
                .par_chunks(1024)
                .map(|c| query_all(&grid, c, radius))
                .sum::<usize>()
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = common::criterion();
    targets = bench
}
criterion_main!(benches);
