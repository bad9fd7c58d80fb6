//! Sweeps through the `regularization` crate: the progressive schedule,
//! alpha-hat (plain and strict) with its `Bound` status, and p-hat.

use std::f64::consts::PI;
use std::time::Instant;

use glam::Vec3;
use microfacet::{
    Bsdf, Conductor, Dielectric, Fresnel, Lambertian, MicrofacetModel, Ndf, NdfKind, Shadowing,
};
use rayon::prelude::*;
use regularization::tau::{Lobe, alpha_hat_strict, strict_peak};
use regularization::{
    Bound, Energy, Schedule, alpha_hat, cone_of_tau, p_hat, regularize, tau_of_cone,
};

use super::reference;
use super::tally::{Row, Tally};
use super::{Budget, KINDS, alphas, direction, etas, log_space, signed_cosines, v};

/// Relative slack of the bound check (SPEC §5: 1e-5).
const BOUND_SLACK: f64 = 1e-5;

/// Every row of this module.
pub fn rows(budget: Budget) -> Vec<Row> {
    vec![
        schedule_row(budget),
        alpha_hat_row(budget),
        strict_row(budget),
        p_hat_row(budget),
    ]
}

/// tau_0 from just above 1/(2 pi) to 1e12, log-spaced in tau_0 - 1/(2 pi).
fn tau0s(n: usize) -> Vec<f64> {
    let floor = 1.0 / (2.0 * PI);
    let mut out: Vec<f64> = log_space(1e-12, 1e12, n)
        .into_iter()
        .map(|x| floor + x)
        .collect();
    out.push(7.5); // the default
    out
}

/// Iteration numbers 1..1e15, log-spaced, with 1, 2, 3 and the ends.
fn iterations(n: usize) -> Vec<u64> {
    let mut out: Vec<u64> = log_space(1.0, 1e15, n)
        .into_iter()
        .map(|x| x.round() as u64)
        .chain([1, 2, 3, 1024, 10_000, 1_000_000_000_000_000])
        .collect();
    out.sort_unstable();
    out.dedup();
    out
}

/// `Schedule::tau_at`: finite, positive, non-decreasing in N, exactly tau_0
/// at N = 1; closed form against the stepwise route through the cone.
fn schedule_row(budget: Budget) -> Row {
    let start = Instant::now();
    let mut t = Tally::default();
    let taus = tau0s(budget.n(40, 400));
    let ns = iterations(budget.n(60, 600));
    for &tau_0 in &taus {
        t.guard(
            || format!("Schedule::new({tau_0:?})"),
            |t| {
                t.evaluation();
                let schedule = match Schedule::new(tau_0) {
                    Ok(s) => s,
                    Err(e) => {
                        t.require(false, || format!("Schedule::new({tau_0:?}) -> Err({e})"));
                        return;
                    }
                };
                let r_0 = cone_of_tau(tau_0);
                let mut previous = 0.0;
                for &n in &ns {
                    t.evaluation();
                    let what = || format!("Schedule::new({tau_0:?}).tau_at({n})");
                    let tau = schedule.tau_at(n);
                    if !t.value(tau, what) {
                        continue;
                    }
                    t.require(tau > 0.0, || format!("{} = 0", what()));
                    t.require(tau >= previous, || {
                        format!("{} = {tau:e} < {previous:e} at the previous N", what())
                    });
                    if n == 1 {
                        t.require(tau == tau_0, || format!("{} = {tau:e} != tau_0", what()));
                    }
                    previous = tau;
                    if let Ok(r_0) = r_0 {
                        let r_n = r_0 * (n as f64).powf(-1.0 / 6.0);
                        if let Ok(stepwise) = tau_of_cone(r_n) {
                            t.compare(tau, stepwise, what);
                        }
                    }
                }
            },
        );
    }
    // Invalid tau_0 must be a typed error, not a panic or a schedule.
    for bad in [
        1.0 / (2.0 * PI),
        0.0,
        -1.0,
        f64::NAN,
        f64::INFINITY,
        f64::MIN_POSITIVE,
    ] {
        t.guard(
            || format!("Schedule::new({bad:?})"),
            |t| {
                t.evaluation();
                let r = Schedule::new(bad);
                t.require(r.is_err(), || {
                    format!("Schedule::new({bad:?}) = {r:?}, expected an error")
                });
                t.note("typed error for invalid tau_0");
            },
        );
    }
    Row {
        name: "regularization: Schedule::tau_at".into(),
        covers: format!(
            "tau_0 = 1/(2 pi) + (1e-12..1e12) ({} values) and 7.5; N = 1..1e15 ({} values); invalid tau_0 (1/(2 pi), 0, -1, NaN, inf, tiny)",
            taus.len(),
            ns.len()
        ),
        other: "tau_N <= 0, decreasing in N, tau_1 != tau_0, or an invalid tau_0 accepted",
        reference: Some("stepwise route: tau_of_cone(cone_of_tau(tau_0) N^(-1/6)) (f64)"),
        tally: t,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// The lobes of the alpha-hat sweep: reflection, and transmission and the
/// dielectric pair from 1 into every eta.
fn lobes(etas: &[f32]) -> Vec<Lobe> {
    let mut out = vec![Lobe::Reflection];
    for &eta in etas {
        out.push(Lobe::Transmission {
            eta_i: 1.0,
            eta_t: eta,
        });
        out.push(Lobe::Transmission {
            eta_i: eta,
            eta_t: 1.0,
        });
        out.push(Lobe::Dielectric {
            eta_i: 1.0,
            eta_t: eta,
        });
    }
    out
}

/// The peak outgoing density of a lobe at alpha in f64 (SPEC §4-§5):
/// D_max times 1/4 (reflection), eta_t^2/(eta_i - eta_t)^2 (transmission),
/// the larger of both (dielectric).
fn peak_density(kind: NdfKind, alpha: f64, lobe: Lobe) -> f64 {
    let jacobian = |eta_i: f32, eta_t: f32| {
        let (i, t) = (f64::from(eta_i), f64::from(eta_t));
        t * t / ((i - t) * (i - t))
    };
    let factor = match lobe {
        Lobe::Reflection => 0.25,
        Lobe::Transmission { eta_i, eta_t } => jacobian(eta_i, eta_t),
        Lobe::Dielectric { eta_i, eta_t } => jacobian(eta_i, eta_t).max(0.25),
    };
    reference::d_max(kind, alpha) * factor
}

/// alpha_tau in f64: 1/sqrt(4 pi tau), eta_t/(|eta_i - eta_t| sqrt(pi tau)),
/// the larger of both for a dielectric.
fn alpha_tau(lobe: Lobe, tau: f64) -> f64 {
    let transmission = |eta_i: f32, eta_t: f32| {
        f64::from(eta_t) / ((f64::from(eta_i) - f64::from(eta_t)).abs() * (PI * tau).sqrt())
    };
    let reflection = 1.0 / (4.0 * PI * tau).sqrt();
    match lobe {
        Lobe::Reflection => reflection,
        Lobe::Transmission { eta_i, eta_t } => transmission(eta_i, eta_t),
        Lobe::Dielectric { eta_i, eta_t } => transmission(eta_i, eta_t).max(reflection),
    }
}

/// The bounds tau of the alpha-hat sweeps: the schedule's domain and beyond
/// (selective mode divides tau_N by rho^2 >= 1e-8), and +infinity.
fn bounds(n: usize) -> Vec<f64> {
    let mut taus = tau0s(n);
    taus.extend([1e16, 1e20, f64::INFINITY]);
    taus
}

/// `alpha_hat` for every NDF and lobe: finite, >= alpha, unchanged when
/// alpha already meets the bound, and the bound holds where it says `Met`.
fn alpha_hat_row(budget: Budget) -> Row {
    let start = Instant::now();
    let alphas = alphas(budget.n(16, 80));
    let taus = bounds(budget.n(24, 120));
    let mut eta_list = etas(budget.n(4, 10));
    eta_list.extend([1.0005, 1.0 / 1.0005, 1.0]);
    let lobes = lobes(&eta_list);
    let t = KINDS
        .par_iter()
        .map(|&kind| {
            let mut t = Tally::default();
            for &lobe in &lobes {
                for &alpha in &alphas {
                    for &tau in &taus {
                        alpha_hat_case(&mut t, kind, alpha, lobe, tau);
                    }
                }
            }
            t
        })
        .reduce(Tally::default, |mut a, b| {
            a.merge(b);
            a
        });
    Row {
        name: "regularization: alpha_hat".into(),
        covers: format!(
            "GGX, Beckmann, Blinn-Phong x reflection, transmission 1 -> eta and eta -> 1, dielectric 1 -> eta \
             (eta 1, 1 +- 5e-4, 1 + (1e-7..9), 1.5 and inverses: {} values) x alpha {} values 1e-8..10 x \
             tau = 1/(2 pi) + (1e-12..1e12), 7.5, 1e16, 1e20, inf ({} values)",
            eta_list.len(),
            alphas.len(),
            taus.len()
        ),
        other: "alpha-hat < alpha (after the NDF's clamp), changed although alpha meets the bound, \
                or the bound k D_max(alpha-hat) <= tau (1e-5 rel.) broken where the status is Met",
        reference: Some(
            "f64 alpha_tau of SPEC §5, where alpha-hat = alpha_tau (status Met, alpha below it)",
        ),
        tally: t,
        seconds: start.elapsed().as_secs_f64(),
    }
}

fn alpha_hat_case(t: &mut Tally, kind: NdfKind, alpha: f32, lobe: Lobe, tau: f64) {
    let call = || format!("alpha_hat(NdfKind::{kind:?}, {alpha:?}, Lobe::{lobe:?}, {tau:?})");
    t.guard(call, |t| {
        t.evaluation();
        let hat = alpha_hat(kind, alpha, lobe, tau);
        t.note(format!("Bound::{:?}", hat.bound));
        let a = hat.alpha;
        if !t.value(f64::from(a), call) {
            return;
        }
        let clamped = Ndf::new(kind, alpha).alpha();
        t.require(a >= clamped, || {
            format!("{} = {a:?} < alpha {clamped:?}", call())
        });
        let wanted = alpha_tau(lobe, tau);
        let index_matched = match lobe {
            Lobe::Transmission { eta_i, eta_t } => (eta_i - eta_t).abs() < 1e-3,
            _ => false,
        };
        if f64::from(clamped) >= wanted && !index_matched {
            t.require(a == clamped, || {
                format!(
                    "{} = {a:?}: alpha {clamped:?} >= alpha_tau {wanted:e} must stay",
                    call()
                )
            });
        }
        if hat.bound == Bound::Met {
            let peak = peak_density(kind, f64::from(a), lobe);
            t.require(peak <= tau * (1.0 + BOUND_SLACK), || {
                format!("{} = {a:?} says Met, but k D_max = {peak:e} > tau", call())
            });
            if f64::from(clamped) < wanted && a > clamped {
                t.compare(f64::from(a), wanted, call);
            }
        }
    });
}

/// `alpha_hat_strict` (supp. §2): typed error for V-cavity; Met means the
/// strict peak is within tau.
fn strict_row(budget: Budget) -> Row {
    let start = Instant::now();
    let mut t = Tally::default();
    let alphas = alphas(budget.n(16, 80));
    let taus = bounds(budget.n(24, 120));
    for kind in KINDS {
        for shadowing in [Shadowing::Smith, Shadowing::VCavity] {
            for &alpha in &alphas {
                let model = MicrofacetModel::new(kind, alpha, shadowing);
                for &tau in &taus {
                    let call = || {
                        format!(
                            "alpha_hat_strict(&MicrofacetModel::new(NdfKind::{kind:?}, {alpha:?}, Shadowing::{shadowing:?}), {tau:?})"
                        )
                    };
                    t.guard(call, |t| {
                        t.evaluation();
                        match alpha_hat_strict(&model, tau) {
                            Err(_) => {
                                t.require(shadowing == Shadowing::VCavity, || {
                                    format!("{} is an error for Smith", call())
                                });
                                t.note("StrictError::VCavity");
                            }
                            Ok(hat) => {
                                t.note(format!("Bound::{:?}", hat.bound));
                                t.require(shadowing == Shadowing::Smith, || {
                                    format!("{} accepted V-cavity", call())
                                });
                                if !t.value(f64::from(hat.alpha), call) {
                                    return;
                                }
                                t.require(hat.alpha >= model.alpha(), || {
                                    format!("{} = {:?} < alpha", call(), hat.alpha)
                                });
                                if hat.bound == Bound::Met {
                                    let peak = strict_peak(kind, hat.alpha);
                                    t.require(peak <= tau * (1.0 + BOUND_SLACK), || {
                                        format!("{} says Met, strict peak {peak:e} > tau", call())
                                    });
                                }
                            }
                        }
                    });
                }
            }
        }
    }
    Row {
        name: "regularization: alpha_hat_strict".into(),
        covers: format!(
            "GGX, Beckmann, Blinn-Phong x Smith, V-cavity x alpha {} values 1e-8..10 x tau as for alpha_hat",
            alphas.len()
        ),
        other: "error for Smith / accepted V-cavity, alpha-hat < alpha, or the strict peak above tau where Met",
        reference: None,
        tally: t,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// `regularize` + `p_hat` over BSDFs, alphas, taus and direction pairs.
fn p_hat_row(budget: Budget) -> Row {
    let start = Instant::now();
    let alphas = alphas(budget.n(5, 12));
    let taus = bounds(budget.n(5, 12));
    let cos = signed_cosines(budget.n(6, 12));
    let dirs: Vec<Vec3> = cos.iter().map(|&c| direction(c, 0.3)).collect();
    let mut bsdfs = vec![(
        Bsdf::Lambertian(Lambertian {
            reflectance: Vec3::splat(0.5),
        }),
        "Bsdf::Lambertian(Lambertian { reflectance: Vec3::splat(0.5) })".to_string(),
    )];
    for kind in KINDS {
        for shadowing in [Shadowing::Smith, Shadowing::VCavity] {
            for &alpha in &alphas {
                let model = MicrofacetModel::new(kind, alpha, shadowing);
                let m = format!(
                    "MicrofacetModel::new(NdfKind::{kind:?}, {alpha:?}, Shadowing::{shadowing:?})"
                );
                bsdfs.push((
                    Bsdf::Conductor(Conductor {
                        model,
                        fresnel: Fresnel::Schlick {
                            f0: Vec3::splat(0.9),
                        },
                    }),
                    format!(
                        "Bsdf::Conductor(Conductor {{ model: {m}, fresnel: Fresnel::Schlick {{ f0: Vec3::splat(0.9) }} }})"
                    ),
                ));
                for eta in [1.5f32, 1.0 / 1.5, 1.0001] {
                    bsdfs.push((
                        Bsdf::Dielectric(Dielectric::new(model, eta)),
                        format!("Bsdf::Dielectric(Dielectric::new({m}, {eta:?}))"),
                    ));
                }
            }
        }
    }
    let t = bsdfs
        .par_iter()
        .map(|(bsdf, repro)| {
            let mut t = Tally::default();
            for &tau in &taus {
                for &wi in &dirs {
                    let regularized = t.guard(
                        || format!("regularize(&{repro}, {tau:?})"),
                        |t| {
                            t.evaluation();
                            regularize(bsdf, tau, Energy::Preserved)
                        },
                    );
                    let Some((regularized, Some(hat))) = regularized else {
                        continue;
                    };
                    for &wo in &dirs {
                        let call =
                            || format!("p_hat(&{repro}, {:?}, {}, {})", hat.alpha, v(wi), v(wo));
                        t.guard(call, |t| {
                            t.evaluation();
                            let p = p_hat(bsdf, &regularized, wi, wo);
                            t.value(f64::from(p), call);
                        });
                    }
                }
            }
            t
        })
        .reduce(Tally::default, |mut a, b| {
            a.merge(b);
            a
        });
    Row {
        name: "regularization: regularize, p_hat".into(),
        covers: format!(
            "{} BSDFs: Lambertian; conductor, dielectric (eta 1.5, 1/1.5, 1.0001) x 3 NDFs x 2 shadowing models x \
             alpha {} values 1e-8..10; tau {} values 1/(2 pi)+1e-12..1e20 and inf; wi, wo: cos = +-({} values 1e-9..1) and 0",
            bsdfs.len(),
            alphas.len(),
            taus.len(),
            cos.len() / 2
        ),
        other: "-",
        reference: None,
        tally: t,
        seconds: start.elapsed().as_secs_f64(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn independent_bound_agrees_with_the_library_on_a_plain_case() {
        let lobe = Lobe::Transmission {
            eta_i: 1.0,
            eta_t: 1.5,
        };
        let hat = alpha_hat(NdfKind::Ggx, 0.01, lobe, 100.0);
        assert_eq!(hat.bound, Bound::Met);
        assert!((f64::from(hat.alpha) / alpha_tau(lobe, 100.0) - 1.0).abs() < 1e-6);
        let peak = peak_density(NdfKind::Ggx, f64::from(hat.alpha), lobe);
        assert!(peak <= 100.0 * (1.0 + BOUND_SLACK) && peak > 99.99);
    }

    #[test]
    fn sweep_grids_cover_their_ends() {
        let taus = tau0s(10);
        assert!(taus[0] > 1.0 / (2.0 * PI) && taus[0] - 1.0 / (2.0 * PI) < 2e-12);
        assert!(taus.iter().any(|&t| t > 1e12 - 1.0));
        let ns = iterations(10);
        assert_eq!(ns[0], 1);
        assert_eq!(*ns.last().unwrap(), 1_000_000_000_000_000);
        assert!(ns.windows(2).all(|w| w[0] < w[1]));
    }
}
