//! ns per call of `eval` and `sample` for each lobe.
//!
//! Inputs are pre-generated so that the loop measures the lobe, not the RNG;
//! each iteration processes one (wi, wo) pair or one sample.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Vec2, Vec3};
use microfacet::{
    Bsdf, Conductor, Dielectric, Fresnel, Lambertian, MicrofacetModel, NdfKind, Shadowing,
    TransportMode,
};
use stats::Pcg32;

const INPUTS: usize = 1024;

fn lobes() -> Vec<(String, Bsdf)> {
    let gold = Fresnel::Conductor {
        eta: Vec3::new(0.18, 0.42, 1.37),
        k: Vec3::new(3.42, 2.35, 1.77),
        tint: Vec3::ONE,
    };
    let mut out = vec![(
        "lambertian".to_string(),
        Bsdf::Lambertian(Lambertian {
            reflectance: Vec3::splat(0.5),
        }),
    )];
    for (kind, shadowing) in [
        (NdfKind::Ggx, Shadowing::Smith),
        (NdfKind::Beckmann, Shadowing::Smith),
        (NdfKind::BlinnPhong, Shadowing::Smith),
        (NdfKind::Ggx, Shadowing::VCavity),
    ] {
        let model = MicrofacetModel::new(kind, 0.3, shadowing);
        let tag = format!("{kind:?}-{shadowing:?}").to_lowercase();
        out.push((
            format!("conductor/{tag}"),
            Bsdf::Conductor(Conductor {
                model,
                fresnel: gold,
            }),
        ));
        out.push((
            format!("dielectric/{tag}"),
            Bsdf::Dielectric(Dielectric::new(model, 1.5)),
        ));
    }
    let smooth = MicrofacetModel::new(NdfKind::Ggx, 0.0, Shadowing::Smith);
    out.push((
        "dielectric/smooth".to_string(),
        Bsdf::Dielectric(Dielectric::new(smooth, 1.5)),
    ));
    out
}

fn random_direction(rng: &mut Pcg32) -> Vec3 {
    let z = 2.0 * rng.uniform_f32() - 1.0;
    let phi = std::f32::consts::TAU * rng.uniform_f32();
    let r = (1.0 - z * z).max(0.0).sqrt();
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

fn bench_lobes(c: &mut Criterion) {
    let mut rng = Pcg32::new(1, 1);
    let pairs: Vec<(Vec3, Vec3)> = (0..INPUTS)
        .map(|_| (random_direction(&mut rng), random_direction(&mut rng)))
        .collect();
    let uniforms: Vec<(f32, Vec2)> = (0..INPUTS)
        .map(|_| (rng.uniform_f32(), rng.uniform_vec2()))
        .collect();
    for (name, bsdf) in lobes() {
        let mut group = c.benchmark_group(name);
        group.bench_function("eval", |b| {
            let mut i = 0;
            b.iter(|| {
                let (wi, wo) = pairs[i % INPUTS];
                i += 1;
                black_box(bsdf.eval(black_box(wi), black_box(wo), TransportMode::Radiance))
            })
        });
        group.bench_function("sample", |b| {
            let mut i = 0;
            b.iter(|| {
                let (wi, _) = pairs[i % INPUTS];
                let (uc, u) = uniforms[i % INPUTS];
                i += 1;
                black_box(bsdf.sample(black_box(wi), uc, u, TransportMode::Radiance))
            })
        });
        group.finish();
    }
}

criterion_group!(benches, bench_lobes);
criterion_main!(benches);
