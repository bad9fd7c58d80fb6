//! The directional albedo of microfacet lobes, estimated by sampling them.
//!
//! For each lobe and roughness, the mean of the sample weights f |cos| / pdf
//! estimates int f(wi, wo) |cos_o| dwo, the fraction of light from `wi` that
//! is scattered (for glass its energy albedo, reflection plus transmission:
//! `TransportMode::Importance`, as radiance is scaled by 1/eta^2 through
//! refraction). A white conductor and clear glass lose energy as they get
//! rougher (single scattering: light that meets a second microfacet is
//! lost), which is what energy compensation (`Bsdf::regularized`) restores
//! when regularization widens a lobe.
//!
//! Run with `cargo run -p rlt-microfacet --example albedo`.

use microfacet::glam::{Vec2, Vec3};
use microfacet::{
    Bsdf, Conductor, Dielectric, Fresnel, MicrofacetModel, NdfKind, Shadowing, TransportMode,
};

/// Stratified uniforms for `n` samples: (uc, u) from a (0, 2)-like lattice.
fn uniforms(i: usize, n: usize) -> (f32, Vec2) {
    let golden = 0.618_034_f32;
    let u = Vec2::new((i as f32 + 0.5) / n as f32, (i as f32 * golden).fract());
    ((i as f32 * 0.754_877_7).fract(), u)
}

/// Mean of f |cos_o| / pdf over `n` samples from `wi` (delta lobes included:
/// a sample's `f / pdf` is its weight either way).
fn albedo(bsdf: &Bsdf, wi: Vec3, mode: TransportMode, n: usize) -> f32 {
    let sum: f32 = (0..n)
        .filter_map(|i| {
            let (uc, u) = uniforms(i, n);
            let s = bsdf.sample(wi, uc, u, mode)?;
            Some(s.f.x * s.wo.z.abs() / s.pdf)
        })
        .sum();
    sum / n as f32
}

fn main() {
    let wi = Vec3::new(0.5, 0.0, 0.866); // 30 degrees from the normal
    let white = Fresnel::Schlick { f0: Vec3::ONE };
    println!("directional albedo at 30 degrees, GGX with Smith shadowing, 65536 samples");
    println!(
        "{:>6}  {:>16}  {:>16}",
        "alpha", "white conductor", "glass, eta 1.5"
    );
    for alpha in [0.0, 0.1, 0.3, 0.6, 1.0] {
        let model = MicrofacetModel::new(NdfKind::Ggx, alpha, Shadowing::Smith);
        let conductor = Bsdf::Conductor(Conductor {
            model,
            fresnel: white,
        });
        let glass = Bsdf::Dielectric(Dielectric::new(model, 1.5));
        let n = 1 << 16;
        println!(
            "{alpha:>6.2}  {:>16.4}  {:>16.4}",
            albedo(&conductor, wi, TransportMode::Radiance, n),
            albedo(&glass, wi, TransportMode::Importance, n)
        );
    }
}
