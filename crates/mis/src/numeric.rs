//! Guarded arithmetic for MIS ratios.
//!
//! Every quantity the recursion carries is a sum of products of pdf ratios.
//! With pdfs between 1e-30 and 1e30, cosines near zero and ten vertices, such a
//! product can leave the range of f64 (1e600 and beyond), and one overflow is
//! enough to turn a weight into NaN (`inf * 0`, `inf / inf`). The helpers below
//! keep every value in `[0, RATIO_MAX]`: products and quotients saturate instead
//! of overflowing, divisions by zero saturate instead of producing `inf`, and
//! NaN or negative inputs count as zero. Inside that range the helpers are
//! exact IEEE operations, so results agree with the unguarded formulas.

/// Largest value any MIS quantity may take.
///
/// A weight computed as `1 / (1 + x)` with `x = RATIO_MAX` is 1e-300: every
/// technique that would need a larger ratio already has a weight that no f64
/// sum can distinguish from zero. The value also leaves room for adding a few
/// saturated terms (4 * 1e300 < f64::MAX = 1.8e308) without overflowing.
pub(crate) const RATIO_MAX: f64 = 1e300;

/// Smallest denominator a division uses.
///
/// Pdfs, cosines and squared distances can legitimately be zero or denormal
/// (a grazing connection, a sample the caller got with pdf 0). Dividing by them
/// would give `inf`; flooring the denominator at 1e-300 makes the quotient
/// saturate at [`RATIO_MAX`] instead, which is the same weight in the end.
pub(crate) const DENOM_MIN: f64 = 1e-300;

/// `x` as a non-negative, finite MIS quantity: NaN and negative values become
/// 0, values above [`RATIO_MAX`] (including +inf) become [`RATIO_MAX`].
#[inline]
pub(crate) fn nonneg(x: f64) -> f64 {
    if x > 0.0 { x.min(RATIO_MAX) } else { 0.0 }
}

/// `|x|` as a non-negative, finite quantity (NaN becomes 0). Used for
/// cosines, which callers may pass signed.
#[inline]
pub(crate) fn abs(x: f64) -> f64 {
    nonneg(x.abs())
}

/// Saturating product of two finite, non-negative values (such as
/// [`nonneg`] returns).
///
/// With finite factors zero times anything is zero (no `0 * inf`), and an
/// overflow to `inf` is clamped to [`RATIO_MAX`]. No branch: the MIS
/// recursions call this at every vertex and connection.
#[inline]
pub(crate) fn mul(a: f64, b: f64) -> f64 {
    debug_assert!(finite_nonneg(a) && finite_nonneg(b), "{a} * {b}");
    (a * b).min(RATIO_MAX)
}

/// Saturating quotient of a finite, non-negative `a` by any `b`: the
/// denominator is floored at [`DENOM_MIN`] (NaN included), so `0 / b = 0`
/// and nothing divides by zero.
#[inline]
pub(crate) fn div(a: f64, b: f64) -> f64 {
    debug_assert!(finite_nonneg(a), "{a} / {b}");
    (a / b.max(DENOM_MIN)).min(RATIO_MAX)
}

/// What [`mul`] and [`div`] require of their operands.
fn finite_nonneg(x: f64) -> bool {
    x.is_finite() && x >= 0.0
}

/// Saturating sum of values in `[0, RATIO_MAX]`.
#[inline]
pub(crate) fn add(a: f64, b: f64) -> f64 {
    (a + b).min(RATIO_MAX)
}

/// `num / (num + rest)` for values in `[0, RATIO_MAX]`, 0 when both are 0.
///
/// This is the form of every MIS weight; it lies in `[0, 1]`.
#[inline]
pub(crate) fn share(num: f64, rest: f64) -> f64 {
    if num == 0.0 {
        0.0
    } else {
        (num / (num + rest)).clamp(0.0, 1.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guards_never_produce_nan_or_inf() {
        let values = [
            0.0,
            -1.0,
            f64::NAN,
            f64::INFINITY,
            f64::NEG_INFINITY,
            1e-320,
            1e-300,
            1.0,
            1e300,
            f64::MAX,
        ];
        for &a in &values {
            for &b in &values {
                let (a, b) = (nonneg(a), nonneg(b));
                for r in [mul(a, b), div(a, b), add(a, b), share(a, b)] {
                    assert!(r.is_finite() && r >= 0.0, "{a} {b} -> {r}");
                }
                assert!(share(a, b) <= 1.0);
            }
        }
    }

    #[test]
    fn guards_are_exact_in_range() {
        assert_eq!(mul(3.0, 0.5), 1.5);
        assert_eq!(div(3.0, 0.5), 6.0);
        assert_eq!(add(3.0, 0.5), 3.5);
        assert_eq!(share(1.0, 3.0), 0.25);
        assert_eq!(abs(-0.25), 0.25);
        assert_eq!(nonneg(-0.25), 0.0);
    }
}
