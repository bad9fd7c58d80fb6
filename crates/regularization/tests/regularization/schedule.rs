//! The progressive schedule (supp. §5 and §7, SPEC §5).

use std::f64::consts::PI;

use regularization::{Schedule, ScheduleError, cone_of_tau, tau_of_cone};

/// 1/(2 pi): the smallest valid tau_0 (a uniform hemisphere).
const TAU_MIN: f64 = 1.0 / (2.0 * PI);

/// supp. eq. 13 written out as one closed form, with the cancellation-free
/// 1 - cos(atan x) = x^2 / (sqrt(1 + x^2)(1 + sqrt(1 + x^2))).
fn supp_eq_13(tau_0: f64, n: f64) -> f64 {
    let x = (4.0 * PI * tau_0 - 1.0).sqrt() / (2.0 * PI * tau_0 - 1.0) * n.powf(-1.0 / 6.0);
    let s = (1.0 + x * x).sqrt();
    1.0 / (2.0 * PI * (x * x / (s * (1.0 + s))))
}

/// The same, evaluated naively: 1 - cos(atan x) cancels for small x.
fn supp_eq_13_naive(tau_0: f64, n: f64) -> f64 {
    let x = (4.0 * PI * tau_0 - 1.0).sqrt() / (2.0 * PI * tau_0 - 1.0) * n.powf(-1.0 / 6.0);
    1.0 / (2.0 * PI * (1.0 - x.atan().cos()))
}

fn tau_0_values() -> Vec<f64> {
    let mut out = vec![TAU_MIN + 1e-9, TAU_MIN + 1e-6, 0.2, 1.0, 7.5, 30.0];
    out.extend((0..=12).map(|e| 10f64.powi(e)));
    out
}

fn iterations() -> Vec<u64> {
    let mut out: Vec<u64> = (0..=12).map(|e| 10u64.pow(e)).collect();
    out.extend([2, 3, 1024, 10_000, 999_999_937]);
    out
}

#[test]
fn first_iteration_is_tau_0_and_tau_never_decreases() {
    for tau_0 in tau_0_values() {
        let s = Schedule::new(tau_0).unwrap();
        assert_eq!(s.tau_at(1), tau_0);
        let mut previous = tau_0;
        for e in 0..=180 {
            let n = 10f64.powf(f64::from(e) / 15.0).round() as u64;
            let tau = s.tau_at(n);
            assert!(
                tau.is_finite() && tau >= previous,
                "tau_0 {tau_0}: tau({n}) = {tau} < {previous}"
            );
            previous = tau;
        }
    }
}

#[test]
fn closed_form_and_step_by_step_route_agree() {
    let mut worst: f64 = 0.0;
    for tau_0 in tau_0_values() {
        let schedule = Schedule::new(tau_0).unwrap();
        let r_0 = cone_of_tau(tau_0).unwrap();
        for n in iterations() {
            let closed = supp_eq_13(tau_0, n as f64);
            // tau_0 -> r_0 -> r_N -> tau_N through the public functions.
            let stepwise = tau_of_cone(r_0 * (n as f64).powf(-1.0 / 6.0)).unwrap();
            let scheduled = schedule.tau_at(n);
            for other in [stepwise, scheduled] {
                let rel = (other / closed - 1.0).abs();
                worst = worst.max(rel);
                assert!(
                    rel < 1e-12,
                    "tau_0 {tau_0} N {n}: closed {closed}, other {other}, rel {rel:e}"
                );
            }
        }
    }
    eprintln!("largest relative difference: {worst:e}");
}

/// Negative control: the naive 1 - cos(atan x) loses the agreement for large
/// tau_0 or N, so the test above does check the cancellation-free form.
#[test]
fn naive_form_would_fail_the_agreement() {
    let (tau_0, n) = (1e12, 1e12);
    let rel = (supp_eq_13_naive(tau_0, n) / supp_eq_13(tau_0, n) - 1.0).abs();
    assert!(
        rel > 1e-6 || !rel.is_finite(),
        "naive form agrees to {rel:e}"
    );
}

#[test]
fn tau_roughly_doubles_between_1024_and_10000_iterations() {
    // supp. §7: "tau becomes roughly twice as large"; SPEC §5: about 2.14 for tau_0 >> 1.
    let s = Schedule::new(30.0).unwrap();
    let ratio = s.tau_at(10_000) / s.tau_at(1024);
    assert!((1.9..2.2).contains(&ratio), "{ratio}");
    // The N^(1/3) asymptote, and the weaker growth SPEC quotes for tau_0 = 0.2.
    let big = Schedule::new(1e6).unwrap();
    let expected = (10_000f64 / 1024.0).cbrt();
    assert!((big.tau_at(10_000) / big.tau_at(1024) / expected - 1.0).abs() < 1e-3);
    let small = Schedule::new(0.2).unwrap();
    assert!((small.tau_at(10_000) / small.tau_at(1024) - 1.47).abs() < 0.01);
}

#[test]
fn invalid_input_is_a_typed_error() {
    for tau_0 in [
        TAU_MIN,
        TAU_MIN * (1.0 - 1e-12),
        0.0,
        -1.0,
        f64::NAN,
        f64::INFINITY,
    ] {
        assert!(
            matches!(Schedule::new(tau_0), Err(ScheduleError::InvalidTau(_))),
            "{tau_0}"
        );
    }
    for (r, d) in [
        (-1.0, 1.0),
        (1.0, 0.0),
        (f64::NAN, 1.0),
        (0.0, 1.0),
        (1.0, f64::INFINITY),
    ] {
        assert!(
            matches!(
                Schedule::from_cone(r, d),
                Err(ScheduleError::InvalidCone { .. })
            ),
            "{r} {d}"
        );
    }
    // The cone of paper §3.4 maps to the same schedule as its tau_0.
    let from_cone = Schedule::from_cone(0.5, 10.0).unwrap();
    let from_tau = Schedule::new(tau_of_cone(0.05).unwrap()).unwrap();
    assert!((from_cone.tau_at(77) / from_tau.tau_at(77) - 1.0).abs() < 1e-14);
    assert!((from_cone.r_0() - 0.05).abs() < 1e-12);
    let message = Schedule::new(0.1).unwrap_err().to_string();
    assert!(
        message.contains("tau_0 = 0.1") && message.contains("1/(2 pi)"),
        "{message}"
    );
}
