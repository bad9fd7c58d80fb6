//! Stiff inputs: every public function returns finite values or a
//! typed error for alpha 0 and 1e3, tau at 1/(2 pi) + 1e-12 and 1e15,
//! eta 1 + 1e-9, N = 1 and 1e15.

use std::f64::consts::PI;

use glam::Vec3;
use microfacet::{
    Bsdf, Conductor, Dielectric, Fresnel, Lambertian, MicrofacetModel, NdfKind, Shadowing,
};
use regularization::tau::{alpha_tau, density_factor, peak_density, strict_peak};
use regularization::{
    Lobe, Mode, PathRegularization, Schedule, Subpath, alpha_hat, alpha_hat_strict, cone_of_tau,
    p_hat, tau_of_cone,
};

const ALPHAS: [f32; 5] = [0.0, 1e-7, 0.5, 1.0, 1e3];
const TAUS: [f64; 5] = [1.0 / (2.0 * PI) + 1e-12, 0.2, 7.5, 1e15, f64::INFINITY];
const ETAS: [f32; 4] = [1.0 + 1e-9, 1.0 + 1e-6, 1.5, 1.0 / 1.5];
const KINDS: [NdfKind; 3] = [NdfKind::Ggx, NdfKind::Beckmann, NdfKind::BlinnPhong];

fn lobes() -> Vec<Lobe> {
    let mut out = vec![Lobe::Reflection];
    for eta in ETAS {
        out.push(Lobe::Transmission {
            eta_i: 1.0,
            eta_t: eta,
        });
        out.push(Lobe::Dielectric {
            eta_i: eta,
            eta_t: 1.0,
        });
    }
    out
}

#[test]
fn alpha_hat_is_finite_everywhere() {
    for kind in KINDS {
        for alpha in ALPHAS {
            for tau in TAUS {
                for lobe in lobes() {
                    let hat = alpha_hat(kind, alpha, lobe, tau);
                    assert!(
                        hat.alpha.is_finite() && hat.alpha > 0.0,
                        "{kind:?} {alpha} {tau} {lobe:?}: {hat:?}"
                    );
                    assert!(
                        peak_density(kind, hat.alpha, lobe).is_finite()
                            || (lobe != Lobe::Reflection)
                    );
                    assert!(alpha_tau(lobe, tau).is_finite() || density_factor(lobe).is_infinite());
                }
                for shadowing in [Shadowing::Smith, Shadowing::VCavity] {
                    let model = MicrofacetModel::new(kind, alpha, shadowing);
                    if let Ok(hat) = alpha_hat_strict(&model, tau) {
                        assert!(hat.alpha.is_finite() && strict_peak(kind, hat.alpha).is_finite());
                    }
                }
            }
        }
    }
}

#[test]
fn schedule_is_finite_at_the_extremes() {
    for tau_0 in [1.0 / (2.0 * PI) + 1e-12, 1e15] {
        let s = Schedule::new(tau_0).unwrap();
        for n in [0, 1, 2, 1_000_000_000_000_000] {
            let tau = s.tau_at(n);
            assert!(
                tau.is_finite() && tau >= tau_0,
                "tau_0 {tau_0} N {n}: {tau}"
            );
        }
        assert!(s.r_0().is_finite() && cone_of_tau(tau_0).unwrap().is_finite());
        assert!(tau_of_cone(s.r_0()).unwrap().is_finite());
    }
    assert!(
        tau_of_cone(1e-300).unwrap().is_finite() || tau_of_cone(1e-300).unwrap() == f64::INFINITY
    );
    assert!(tau_of_cone(1e300).unwrap().is_finite());
}

#[test]
fn path_regularization_and_p_hat_are_finite() {
    let dirs = [
        Vec3::Z,
        Vec3::new(1.0, 0.0, 1e-8).normalize(),
        Vec3::new(0.6, 0.0, -0.8),
    ];
    for kind in KINDS {
        for alpha in ALPHAS {
            for eta in ETAS {
                let model = MicrofacetModel::new(kind, alpha, Shadowing::Smith);
                let bsdfs = [
                    Bsdf::Conductor(Conductor {
                        model,
                        fresnel: Fresnel::Schlick { f0: Vec3::ONE },
                    }),
                    Bsdf::Dielectric(Dielectric::new(model, eta)),
                    Bsdf::Lambertian(Lambertian {
                        reflectance: Vec3::ONE,
                    }),
                ];
                for bsdf in bsdfs {
                    for tau in TAUS {
                        for mode in [Mode::Off, Mode::Uniform, Mode::Selective] {
                            let state = PathRegularization::new(mode, Subpath::Camera, tau)
                                .after_vertex(&bsdf);
                            assert!(state.tau() > 0.0);
                            for wi in dirs {
                                let (reg, hat) = state.regularize(&bsdf);
                                let a = hat.map_or(1.0, |h| h.alpha);
                                for wo in dirs {
                                    let p = p_hat(&bsdf, &reg, wi, wo);
                                    assert!(
                                        p.is_finite() && p >= 0.0,
                                        "{bsdf:?} {a} {wi} {wo}: {p}"
                                    );
                                    assert!(reg.pdf(wi, wo).is_finite());
                                }
                            }
                        }
                    }
                }
            }
        }
    }
}
