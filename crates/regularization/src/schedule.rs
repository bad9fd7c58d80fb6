//! The progressive schedule of tau (supp. §5, paper eq. 14-15; SPEC §5), the
//! "sampler quality" heuristic: tau is the inverse solid angle of a cone whose
//! radius shrinks like N^(-1/6), so the blur vanishes as iterations go on.
//! The exponent 1/6 is the paper's; [`Schedule::with_exponent`] takes another
//! one inside the consistency bound, for studies that sweep it.
//!
//! Everything is f64 and uses the cancellation-free form
//! 1 - cos(atan x) = x^2 / (sqrt(1 + x^2) (1 + sqrt(1 + x^2))).

use std::f64::consts::PI;

use thiserror::Error;

/// Invalid input to the schedule.
#[derive(Clone, Copy, Debug, PartialEq, Error)]
#[non_exhaustive]
pub enum ScheduleError {
    /// tau_0 must exceed 1/(2 pi), the inverse solid angle of a hemisphere.
    #[error(
        "tau_0 = {0} is invalid: it must be a finite number above 1/(2 pi) = 0.159155 (the density of a uniform hemisphere)"
    )]
    InvalidTau(f64),
    /// The schedule exponent must lie in the consistency bound
    /// (0, [`MAX_SCHEDULE_EXPONENT`]).
    #[error(
        "schedule exponent = {0} is invalid: it must lie strictly between 0 and 1/2 (r_N = r_0 N^-exponent: at 0 the blur never vanishes, at 1/2 or above its variance does not; Kaplanyan and Dachsbacher 2013, §5.1)"
    )]
    InvalidExponent(f64),
    /// A cone radius or distance must be positive and finite.
    #[error("cone {name} = {value} is invalid: it must be a positive, finite number")]
    InvalidCone {
        /// Which parameter (`r_0`, `d` or `r`).
        name: &'static str,
        /// The value given.
        value: f64,
    },
}

/// The paper's schedule exponent: r_N = r_0 N^(-1/6) (supp. eq. 12).
pub const DEFAULT_SCHEDULE_EXPONENT: f64 = 1.0 / 6.0;

/// The consistency bound of the schedule exponent lambda in r_N = r_0
/// N^(-lambda): a kernel of bandwidth r_N over d regularized dimensions is
/// consistent iff r_N -> 0 (bias vanishes, lambda > 0) and N r_N^d -> infinity
/// (variance vanishes, lambda < 1/d) (Kaplanyan and Dachsbacher 2013, §5.1,
/// eq. 6). One regularized vertex blurs one direction, d = 2: lambda < 1/2.
/// (A path with k regularized vertices needs lambda < 1/(2k); 1/6 meets it
/// for k <= 2.)
pub const MAX_SCHEDULE_EXPONENT: f64 = 0.5;

/// 1 - cos(atan x) from x^2, without cancellation for small x; 1 when x^2
/// overflows (a cone wider than f64 resolves is the whole hemisphere).
fn one_minus_cos_atan(x2: f64) -> f64 {
    if x2 == f64::INFINITY {
        return 1.0;
    }
    let s = (1.0 + x2).sqrt();
    x2 / (s * (1.0 + s))
}

/// Density of a uniform cone of radius `r` at unit distance (half-angle atan r):
/// tau(r) = 1 / (2 pi (1 - cos(atan r))) (supp. §5, paper eq. 15).
/// `r` must be positive and finite (tau -> infinity as r -> 0).
pub fn tau_of_cone(r: f64) -> Result<f64, ScheduleError> {
    if !(r > 0.0 && r.is_finite()) {
        return Err(ScheduleError::InvalidCone {
            name: "r",
            value: r,
        });
    }
    Ok(1.0 / (2.0 * PI * one_minus_cos_atan(r * r)))
}

/// Inverse of [`tau_of_cone`]: r = sqrt(4 pi tau - 1) / (2 pi tau - 1) (supp. §5).
/// Valid for tau > 1/(2 pi), checked on the computed 2 pi tau - 1 (SPEC §5).
/// tau = +infinity gives r = 0.
pub fn cone_of_tau(tau: f64) -> Result<f64, ScheduleError> {
    if tau == f64::INFINITY {
        return Ok(0.0);
    }
    let excess = 2.0 * PI * tau - 1.0;
    if !(excess > 0.0 && excess.is_finite()) {
        return Err(ScheduleError::InvalidTau(tau));
    }
    // sqrt(4 pi tau - 1) / excess, written so that huge tau cannot overflow.
    Ok((2.0 * PI * tau + excess).sqrt() / excess)
}

/// The progressive tau_N of supp. eq. 12-13: r_N = r_0 N^(-1/6), tau_N = tau(r_N)
/// (the exponent 1/6 unless [`Schedule::with_exponent`] sets another).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Schedule {
    tau_0: f64,
    /// r_0^2 (the cone radius at unit distance, squared).
    r0_squared: f64,
    /// lambda in r_N = r_0 N^(-lambda).
    exponent: f64,
}

impl Schedule {
    /// Schedule starting at `tau_0` (> 1/(2 pi), finite). SPEC §5 default: 7.5.
    pub fn new(tau_0: f64) -> Result<Self, ScheduleError> {
        Self::with_exponent(tau_0, DEFAULT_SCHEDULE_EXPONENT)
    }

    /// Schedule starting at `tau_0` whose cone shrinks as r_N = r_0
    /// N^(-`exponent`), `exponent` in (0, [`MAX_SCHEDULE_EXPONENT`]).
    pub fn with_exponent(tau_0: f64, exponent: f64) -> Result<Self, ScheduleError> {
        if !(exponent > 0.0 && exponent < MAX_SCHEDULE_EXPONENT) {
            return Err(ScheduleError::InvalidExponent(exponent));
        }
        let r_0 = cone_of_tau(tau_0)?;
        if !(tau_0.is_finite() && r_0 > 0.0) {
            return Err(ScheduleError::InvalidTau(tau_0));
        }
        // r_0^2 = (4 pi tau - 1) / (2 pi tau - 1)^2, divided twice to avoid overflow.
        let excess = 2.0 * PI * tau_0 - 1.0;
        let r0_squared = (2.0 * PI * tau_0 + excess) / excess / excess;
        Ok(Self {
            tau_0,
            r0_squared,
            exponent,
        })
    }

    /// Schedule from the cone of paper §3.4: radius `r_0` at distance `d`.
    pub fn from_cone(r_0: f64, d: f64) -> Result<Self, ScheduleError> {
        for (name, value) in [("r_0", r_0), ("d", d)] {
            if !(value > 0.0 && value.is_finite()) {
                return Err(ScheduleError::InvalidCone { name, value });
            }
        }
        Self::new(tau_of_cone(r_0 / d)?)
    }

    /// tau at the first iteration.
    pub fn tau_0(&self) -> f64 {
        self.tau_0
    }

    /// lambda in r_N = r_0 N^(-lambda).
    pub fn exponent(&self) -> f64 {
        self.exponent
    }

    /// Cone radius at unit distance at the first iteration, r_0 / d.
    pub fn r_0(&self) -> f64 {
        self.r0_squared.sqrt()
    }

    /// tau_N (supp. eq. 13) for iteration `n` >= 1 (0 is treated as 1):
    /// non-decreasing in n, exactly tau_0 at n = 1, about tau_0 n^(1/3) for
    /// tau_0 >> 1. +infinity only if the cone underflows f64 (tau_0 > 1e300).
    pub fn tau_at(&self, n: u64) -> f64 {
        if n <= 1 {
            return self.tau_0;
        }
        // r_N^2 = r_0^2 N^(-2 lambda)
        let r2 = self.r0_squared * (n as f64).powf(-2.0 * self.exponent);
        1.0 / (2.0 * PI * one_minus_cos_atan(r2))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cone_and_tau_are_inverse() {
        for tau in [0.2, 1.0, 7.5, 30.0, 1e6] {
            let r = cone_of_tau(tau).unwrap();
            assert!((tau_of_cone(r).unwrap() / tau - 1.0).abs() < 1e-12);
        }
        assert!(cone_of_tau(1.0 / (2.0 * PI)).is_err());
        assert!(cone_of_tau(f64::NAN).is_err());
        assert!(tau_of_cone(-1.0).is_err());
        assert_eq!(cone_of_tau(f64::INFINITY), Ok(0.0));
    }

    #[test]
    fn exponent_sets_the_cone_decay_and_is_bounded() {
        let default = Schedule::new(7.5).unwrap();
        assert_eq!(default.exponent(), DEFAULT_SCHEDULE_EXPONENT);
        assert_eq!(
            Schedule::with_exponent(7.5, 1.0 / 6.0)
                .unwrap()
                .tau_at(1000),
            default.tau_at(1000)
        );
        // r_N = r_0 N^(-lambda): the cone radius at N = 4096 is r_0 / 4096^lambda.
        for lambda in [0.05, 0.25, 0.49] {
            let s = Schedule::with_exponent(30.0, lambda).unwrap();
            let r = cone_of_tau(s.tau_at(4096)).unwrap();
            assert!((r / (s.r_0() * 4096f64.powf(-lambda)) - 1.0).abs() < 1e-9);
        }
        for bad in [0.0, -0.1, 0.5, 0.7, f64::NAN] {
            assert!(matches!(
                Schedule::with_exponent(7.5, bad),
                Err(ScheduleError::InvalidExponent(_))
            ));
        }
    }

    #[test]
    fn default_matches_spec() {
        // SPEC §5: tau_0 = 7.5 gives alpha_tau = 1/sqrt(4 pi 7.5) = 0.103 at N = 1.
        let s = Schedule::new(7.5).unwrap();
        assert_eq!(s.tau_at(1), 7.5);
        assert!(((4.0 * PI * s.tau_at(1)).sqrt().recip() - 0.103).abs() < 1e-3);
    }
}
