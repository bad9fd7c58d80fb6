//! Regularizing a lobe that is not this workspace's `Bsdf`.
//!
//! `MyMetal` stands for another renderer's GGX conductor: its own Schlick
//! Fresnel, NDF, Smith shadowing and visible-normal density, written here from
//! the formulas (Walter et al. 2007, Heitz 2018). Regularization only needs to
//! be told its NDF, shadowing and alpha (`MicrofacetLobe`); the renderer then
//! evaluates its own lobe at alpha-hat, adds the compensation that keeps the
//! lobe's albedo, and weights paths with p-hat.
//!
//! Run with `cargo run -p rlt-regularization --example foreign_lobe`.

use regularization::microfacet::glam::Vec3;
use regularization::microfacet::{NdfKind, Shadowing, TransportMode};
use regularization::{Energy, MicrofacetLobe, RegularizedLobe, Schedule};
use std::f32::consts::PI;

/// Another renderer's rough metal.
#[derive(Clone, Copy)]
struct MyMetal {
    alpha: f32,
    f0: Vec3,
}

impl MicrofacetLobe for MyMetal {
    fn ndf(&self) -> NdfKind {
        NdfKind::Ggx
    }
    fn shadowing(&self) -> Shadowing {
        Shadowing::Smith
    }
    fn alpha(&self) -> f32 {
        self.alpha
    }
}

impl MyMetal {
    fn d(&self, h: Vec3, alpha: f32) -> f32 {
        let a2 = alpha * alpha;
        let t = h.z * h.z * (a2 - 1.0) + 1.0;
        a2 / (PI * t * t)
    }

    fn g1(&self, w: Vec3, alpha: f32) -> f32 {
        let tan2 = (1.0 - w.z * w.z).max(0.0) / (w.z * w.z);
        2.0 / (1.0 + (1.0 + alpha * alpha * tan2).sqrt())
    }

    fn fresnel(&self, cos: f32) -> Vec3 {
        self.f0 + (Vec3::ONE - self.f0) * (1.0 - cos).powi(5)
    }

    /// Its cosine-weighted Fresnel average, f0 + (1 - f0)/21.
    fn fresnel_average(&self) -> Vec3 {
        self.f0 + (Vec3::ONE - self.f0) / 21.0
    }

    /// f(wi, wo) at roughness `alpha` (same hemisphere only).
    fn eval(&self, wi: Vec3, wo: Vec3, alpha: f32) -> Vec3 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return Vec3::ZERO;
        }
        let h = (wi + wo).normalize();
        let g = self.g1(wi, alpha) * self.g1(wo, alpha);
        self.fresnel(wi.dot(h)) * self.d(h, alpha) * g / (4.0 * wi.z * wo.z)
    }

    /// The visible-normal density of `wo` given `wi`: G1(wi) D(h) / (4 cos_i).
    fn pdf(&self, wi: Vec3, wo: Vec3, alpha: f32) -> f32 {
        if wi.z <= 0.0 || wo.z <= 0.0 {
            return 0.0;
        }
        let h = (wi + wo).normalize();
        self.g1(wi, alpha) * self.d(h, alpha) / (4.0 * wi.z)
    }
}

/// The lobe's regularized value: its own value at alpha-hat, scaled, plus the
/// compensation lobe tinted with its Fresnel average.
fn regularized_eval(metal: &MyMetal, r: &RegularizedLobe, wi: Vec3, wo: Vec3) -> Vec3 {
    let (scale, compensation) = r.compensation_terms(wi, wo, TransportMode::Radiance);
    scale * metal.eval(wi, wo, r.alpha()) + compensation * metal.fresnel_average()
}

/// Directional albedo int f(wo) cos_o dwo of `f` (the lobe for a fixed wi)
/// by a midpoint rule in (cos, phi).
fn albedo(f: impl Fn(Vec3) -> Vec3) -> Vec3 {
    let (n_mu, n_phi) = (1200, 600);
    let mut sum = Vec3::ZERO;
    for i in 0..n_mu {
        let mu = (i as f32 + 0.5) / n_mu as f32;
        let sin = (1.0 - mu * mu).sqrt();
        for j in 0..n_phi {
            let phi = 2.0 * PI * (j as f32 + 0.5) / n_phi as f32;
            sum += f(Vec3::new(sin * phi.cos(), sin * phi.sin(), mu)) * mu;
        }
    }
    sum * (2.0 * PI / (n_mu * n_phi) as f32)
}

fn main() {
    let metal = MyMetal {
        alpha: 0.02,
        f0: Vec3::new(0.95, 0.64, 0.54),
    };
    let schedule = Schedule::new(10.0).expect("tau_0 above 1/(2 pi)");
    println!(
        "alpha = {} under the paper's schedule from tau_0 = 10 per sr:",
        metal.alpha
    );
    for n in [1, 10, 100, 1_000, 10_000] {
        let r = RegularizedLobe::new(&metal, schedule.tau_at(n), Energy::Preserved);
        println!(
            "  iteration {n:>6}: tau {:>8.1}, alpha-hat {:.4}",
            schedule.tau_at(n),
            r.alpha()
        );
    }

    let wi = Vec3::new(0.5, 0.0, 0.866);
    let tau = schedule.tau_at(1);
    let widened = RegularizedLobe::new(&metal, tau, Energy::Preserved);
    let original = albedo(|wo| metal.eval(wi, wo, metal.alpha));
    let lost = albedo(|wo| metal.eval(wi, wo, widened.alpha()));
    let kept = albedo(|wo| regularized_eval(&metal, &widened, wi, wo));
    println!("albedo at 30 degrees (red channel):");
    println!(
        "  original lobe, alpha {:.3}:       {:.4}",
        metal.alpha, original.x
    );
    println!(
        "  widened alone, alpha-hat {:.3}:   {:.4}",
        widened.alpha(),
        lost.x
    );
    println!("  widened with compensation:       {:.4}", kept.x);

    let wo = Vec3::new(-0.6, 0.1, 0.79).normalize();
    let p_lobe = metal.pdf(wi, wo, widened.alpha());
    println!(
        "a sampled direction: pdf {:.4} at alpha-hat, p-hat {:.4} for MIS",
        widened.pdf(wi, wo, p_lobe),
        widened.p_hat(wi, wo, p_lobe)
    );
}
