//! `prepare_tables` covers what `Bsdf::regularized` reads. Alone in its
//! test binary: it watches which tables of the process get built.

use microfacet::compensation::EnergyTable;
use microfacet::compensation::dielectric_energy::TABLE_CRITICAL;
use microfacet::glam::Vec3;
use microfacet::{
    Bsdf, Conductor, Dielectric, Fresnel, Lambertian, MicrofacetModel, NdfKind, Shadowing,
    TransportMode, prepare_tables,
};

/// After `prepare_tables`, every table the lobe lists is built, and
/// regularizing the lobe builds nothing more: the reflection model's
/// and the interface's lists cover what `regularized` reads.
#[test]
fn prepared_lobes_regularize_without_building() {
    let model = MicrofacetModel::new(NdfKind::Beckmann, 0.01, Shadowing::VCavity);
    let conductor = Bsdf::Conductor(Conductor::new(model, Fresnel::Schlick { f0: Vec3::ONE }));
    let glass = Bsdf::Dielectric(Dielectric::new(model, 1.33));
    for bsdf in [conductor, glass] {
        let tables = bsdf.energy_tables();
        assert!(!tables.is_empty());
        prepare_tables(&bsdf);
        assert!(tables.iter().all(|t| t.is_built()), "{tables:?}");
        let every = every_table();
        let built: Vec<_> = every.iter().filter(|t| t.is_built()).collect();
        let _ =
            bsdf.regularized(0.3)
                .eval(Vec3::Z, Vec3::new(0.6, 0.0, 0.8), TransportMode::Radiance);
        let after: Vec<_> = every.iter().filter(|t| t.is_built()).collect();
        assert_eq!(
            built, after,
            "regularizing {bsdf:?} built tables it does not list"
        );
    }
    assert!(
        Bsdf::Lambertian(Lambertian::new(Vec3::ONE))
            .energy_tables()
            .is_empty()
    );
}

/// Every table of this NDF and shadowing, as `is_built` can see them.
fn every_table() -> Vec<EnergyTable> {
    let (kind, shadowing) = (NdfKind::Beckmann, Shadowing::VCavity);
    let slices = 0..TABLE_CRITICAL;
    EnergyTable::of_reflection(kind, shadowing)
        .into_iter()
        .chain(
            slices
                .clone()
                .map(|i| EnergyTable::DielectricAlbedo(kind, shadowing, i)),
        )
        .chain(slices.map(|i| EnergyTable::DielectricMeanScale(kind, shadowing, i)))
        .collect()
}
