//! Ray-origin offsetting (`offset_ray_origin`): every secondary ray of every
//! integrator starts with one call, and a bidirectional connection makes two.
//! Points are spread over 1e-3..1e3 in magnitude (both the integer-ULP and the
//! near-origin branch), normals are unit vectors, as `SurfacePoint` passes them.

use std::hint::black_box;

use accel::offset_ray_origin;
use criterion::{Throughput, criterion_group, criterion_main};
use glam::Vec3;
use stats::Pcg32;

const POINTS: usize = 4096;

fn bench(c: &mut criterion::Criterion) {
    let mut rng = Pcg32::new(5, 1);
    let mut coordinate = || {
        let magnitude = 10f32.powf(6.0 * rng.uniform_f32() - 3.0);
        if rng.next_u32() & 1 == 0 {
            magnitude
        } else {
            -magnitude
        }
    };
    let points: Vec<Vec3> = (0..POINTS)
        .map(|_| Vec3::new(coordinate(), coordinate(), coordinate()))
        .collect();
    let mut rng = Pcg32::new(6, 1);
    let normals: Vec<Vec3> = (0..POINTS)
        .map(|_| {
            let u = rng.uniform_vec2();
            let z = 1.0 - 2.0 * u.x;
            let s = (1.0 - z * z).max(0.0).sqrt();
            let phi = std::f32::consts::TAU * u.y;
            Vec3::new(s * phi.cos(), s * phi.sin(), z)
        })
        .collect();
    let mut group = c.benchmark_group("offset_ray_origin");
    group.throughput(Throughput::Elements(POINTS as u64));
    group.bench_function("mixed magnitudes, unit normals", |b| {
        b.iter(|| {
            let mut sum = Vec3::ZERO;
            for (&p, &n) in points.iter().zip(&normals) {
                sum += offset_ray_origin(black_box(p), black_box(n));
            }
            sum
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = criterion::Criterion::default().sample_size(30);
    targets = bench
}
criterion_main!(benches);
