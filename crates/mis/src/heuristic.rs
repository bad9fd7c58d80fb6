//! Balance and power heuristics (Veach 1997, ch. 9; Veach & Guibas 1995).

use crate::MisError;
use crate::numeric::{RATIO_MAX, mul, nonneg, share};

/// One sampling technique as a heuristic sees it: how many samples it takes
/// (`count`, n_i) and its pdf for the sample at hand (`pdf`, p_i(x)).
///
/// Pdfs of all techniques passed together must be in the same measure.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Sampled {
    /// Number of samples the technique takes (n_i >= 0).
    pub count: f64,
    /// The technique's pdf of the sample (p_i(x) >= 0).
    pub pdf: f64,
}

impl Sampled {
    /// A technique taking `count` samples, with pdf `pdf`.
    pub fn new(count: f64, pdf: f64) -> Self {
        Self { count, pdf }
    }

    /// A technique taking one sample, with pdf `pdf`.
    pub fn one(pdf: f64) -> Self {
        Self { count: 1.0, pdf }
    }
}

/// The power heuristic with exponent beta (Veach 1997, eq. 9.14):
///
/// w_i(x) = (n_i p_i(x))^beta / sum_j (n_j p_j(x))^beta.
///
/// beta = 1 is the balance heuristic (eq. 9.13), beta = 2 Veach's
/// recommended power heuristic. The same exponent is applied, factor by
/// factor, to every ratio the VCM recursion carries (SmallVCM's `Mis()`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Heuristic {
    beta: f64,
}

impl Heuristic {
    /// The balance heuristic (beta = 1).
    pub const BALANCE: Self = Self { beta: 1.0 };

    /// Veach's power heuristic with beta = 2.
    pub const POWER: Self = Self { beta: 2.0 };

    /// The power heuristic with exponent `beta`.
    ///
    /// # Errors
    /// [`MisError::InvalidExponent`] unless `beta` is finite and positive.
    pub fn power(beta: f64) -> Result<Self, MisError> {
        if beta.is_finite() && beta > 0.0 {
            Ok(Self { beta })
        } else {
            Err(MisError::InvalidExponent(beta))
        }
    }

    /// The exponent beta.
    pub fn beta(self) -> f64 {
        self.beta
    }

    /// x^beta for a non-negative quantity (a pdf, a ratio of pdfs, a count).
    ///
    /// NaN and negative inputs count as 0; the result saturates at 1e300
    /// (see the crate documentation, "Numerics"), so it is always finite.
    #[inline]
    pub fn apply(self, x: f64) -> f64 {
        let x = nonneg(x);
        if self.beta == 1.0 {
            x
        } else if self.beta == 2.0 {
            mul(x, x)
        } else if x == 0.0 {
            0.0
        } else {
            x.powf(self.beta).min(RATIO_MAX)
        }
    }

    /// The weight of technique f against one other technique g (Veach 1997,
    /// eq. 9.13/9.14 with two techniques):
    /// (n_f p_f)^beta / ((n_f p_f)^beta + (n_g p_g)^beta).
    ///
    /// Returns a value in [0, 1]; 0 when n_f p_f = 0.
    pub fn weight(self, f: Sampled, g: Sampled) -> f64 {
        self.weight_among(f, &[g])
    }

    /// The weight of technique `this` among `this` and `others`:
    /// (n p)^beta / ((n p)^beta + sum_j (n_j p_j)^beta).
    ///
    /// Returns a value in [0, 1]; 0 when `this` cannot produce the sample
    /// (n p = 0). Allocation-free.
    pub fn weight_among(self, this: Sampled, others: &[Sampled]) -> f64 {
        // Normalise by the largest n p before taking powers, so that neither
        // the powers nor their sum can overflow: every term is then in [0, 1].
        let product = |t: &Sampled| mul(nonneg(t.count), nonneg(t.pdf));
        let own = product(&this);
        let largest = others.iter().map(product).fold(own, f64::max);
        if own == 0.0 {
            return 0.0;
        }
        let rest = others
            .iter()
            .fold(0.0, |acc, t| acc + self.apply(product(t) / largest));
        share(self.apply(own / largest), rest)
    }
}

impl Default for Heuristic {
    /// The balance heuristic, which the VCM recursion was derived for.
    fn default() -> Self {
        Self::BALANCE
    }
}

/// The balance heuristic for two techniques, one sample each:
/// p_f / (p_f + p_g) (Veach 1997, eq. 9.13).
pub fn balance_heuristic(pdf_f: f64, pdf_g: f64) -> f64 {
    Heuristic::BALANCE.weight(Sampled::one(pdf_f), Sampled::one(pdf_g))
}

/// The power heuristic with beta = 2 for two techniques, one sample each:
/// p_f^2 / (p_f^2 + p_g^2) (Veach 1997, eq. 9.14).
pub fn power_heuristic(pdf_f: f64, pdf_g: f64) -> f64 {
    Heuristic::POWER.weight(Sampled::one(pdf_f), Sampled::one(pdf_g))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn known_values() {
        let close = |a: f64, b: f64| (a - b).abs() < 1e-15;
        assert!(close(balance_heuristic(1.0, 3.0), 0.25));
        assert!(close(power_heuristic(1.0, 3.0), 0.1));
        assert!(close(power_heuristic(3.0, 1.0), 0.9));
        // Sample counts multiply the pdfs (n = 2, p = 1 against n = 1, p = 2).
        let w = Heuristic::BALANCE.weight(Sampled::new(2.0, 1.0), Sampled::new(1.0, 2.0));
        assert!(close(w, 0.5));
        let cubic = Heuristic::power(3.0).unwrap();
        assert!(close(
            cubic.weight(Sampled::one(2.0), Sampled::one(1.0)),
            8.0 / 9.0
        ));
        // Three techniques, balance: 1/6, 2/6, 3/6.
        let set = [Sampled::one(1.0), Sampled::one(2.0), Sampled::one(3.0)];
        assert!(close(
            Heuristic::BALANCE.weight_among(set[1], &[set[0], set[2]]),
            1.0 / 3.0
        ));
        // Power: 1/14, 4/14, 9/14.
        assert!(close(
            Heuristic::POWER.weight_among(set[2], &[set[0], set[1]]),
            9.0 / 14.0
        ));
        // A technique that cannot produce the sample has weight 0; so does an
        // empty set of pdfs.
        assert_eq!(balance_heuristic(0.0, 1.0), 0.0);
        assert_eq!(balance_heuristic(0.0, 0.0), 0.0);
        assert_eq!(balance_heuristic(1.0, 0.0), 1.0);
        assert_eq!(Heuristic::POWER.weight_among(Sampled::one(2.0), &[]), 1.0);
    }

    #[test]
    fn weights_of_a_set_sum_to_one() {
        let set = [
            Sampled::new(1.0, 0.3),
            Sampled::new(4.0, 2.0),
            Sampled::new(1.0, 1e-9),
            Sampled::new(100.0, 7.0),
            Sampled::new(0.0, 7.0),
        ];
        for h in [
            Heuristic::BALANCE,
            Heuristic::POWER,
            Heuristic::power(0.7).unwrap(),
        ] {
            let total: f64 = (0..set.len())
                .map(|i| {
                    let others: Vec<Sampled> =
                        (0..set.len()).filter(|&j| j != i).map(|j| set[j]).collect();
                    h.weight_among(set[i], &others)
                })
                .sum();
            assert!((total - 1.0).abs() < 1e-14, "{total}");
        }
    }

    #[test]
    fn invalid_exponents_are_errors() {
        for beta in [0.0, -1.0, f64::NAN, f64::INFINITY] {
            assert!(Heuristic::power(beta).is_err());
        }
        assert_eq!(Heuristic::power(1.0).unwrap(), Heuristic::BALANCE);
        assert_eq!(Heuristic::default(), Heuristic::BALANCE);
    }
}
