//! ns per call of `regularize`, which widens a lobe and builds its energy
//! compensation, against `RegularizationMemo::regularize` answering from
//! its memo (what `PathVertex::new` does for the few lobes a render widens
//! again and again).

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::Vec3;
use microfacet::{Bsdf, Conductor, Dielectric, Fresnel, MicrofacetModel, NdfKind, Shadowing};
use regularization::{Energy, RegularizationMemo, regularize};

/// tau_0 = 30, the default: alpha_tau = 0.052 for reflection.
const TAU: f64 = 30.0;

fn lobes() -> [(&'static str, Bsdf); 3] {
    let model = |alpha| MicrofacetModel::new(NdfKind::Ggx, alpha, Shadowing::Smith);
    [
        (
            "conductor-ggx-0.01",
            Bsdf::Conductor(Conductor {
                model: model(0.01),
                fresnel: Fresnel::Schlick {
                    f0: Vec3::splat(0.9),
                },
            }),
        ),
        (
            "dielectric-ggx-smooth-1.5",
            Bsdf::Dielectric(Dielectric::new(model(0.0), 1.5)),
        ),
        (
            "dielectric-ggx-0.02-1.5",
            Bsdf::Dielectric(Dielectric::new(model(0.02), 1.5)),
        ),
    ]
}

fn bench_regularize(c: &mut Criterion) {
    for (name, bsdf) in lobes() {
        // Builds the tables the lobe reads, outside the measurement.
        let widened = regularize(&bsdf, TAU, Energy::Preserved);
        assert_ne!(widened.0, bsdf, "{name}: not widened at tau {TAU}");
        let mut group = c.benchmark_group(format!("regularize/{name}"));
        group.bench_function("widen", |b| {
            b.iter(|| regularize(black_box(&bsdf), black_box(TAU), Energy::Preserved))
        });
        let mut memo = RegularizationMemo::new();
        group.bench_function("memo", |b| {
            b.iter(|| memo.regularize(black_box(&bsdf), black_box(TAU), Energy::Preserved))
        });
        group.finish();
    }
}

criterion_group!(benches, bench_regularize);
criterion_main!(benches);
