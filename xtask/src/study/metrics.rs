//! Error and noise of an image (SPEC §8), the checkpoint schedule, and
//! log-log interpolation of error curves (equal-time comparisons).
//!
//! Every metric is computed on luminance, Y = 0.2126 R + 0.7152 G + 0.0722 B
//! (Rec. 709 primaries, the renderer's linear RGB), never per channel: the
//! error against a reference and the noise of the per-iteration estimates
//! use the same scalar, so they can be compared with each other.

use glam::Vec3;

/// Luminance of a linear Rec. 709 RGB value, in f64.
pub fn luminance(c: Vec3) -> f64 {
    0.2126 * f64::from(c.x) + 0.7152 * f64::from(c.y) + 0.0722 * f64::from(c.z)
}

/// Luminance of every pixel.
pub fn luminance_image(pixels: &[Vec3]) -> Vec<f64> {
    pixels.iter().map(|&p| luminance(p)).collect()
}

/// The epsilon of relMSE's denominator (SPEC §8): keeps black reference
/// pixels from dominating.
pub const REL_MSE_EPSILON: f64 = 1e-2;

/// Error of an image against a reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Errors {
    /// sqrt(mean((x - ref)^2)).
    pub rmse: f64,
    /// mean((x - ref)^2 / (ref^2 + 1e-2)).
    pub rel_mse: f64,
}

/// Mean squared error and relMSE (SPEC §8) over a set of scalar values,
/// before the square root: what [`errors`] reports on luminance, and what
/// `cargo xtask mitsuba` reports per channel.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MeanSquared {
    /// mean(e), e the squared error of a value.
    pub mse: f64,
    /// mean(e / (ref^2 + 1e-2)).
    pub rel_mse: f64,
}

/// The means of SPEC §8 over `(e, ref)` pairs, e a squared error (or its
/// expectation, such as a variance) of a value whose reference is `ref`;
/// zero for no pairs. Summed in the order given.
pub fn mean_squared(terms: impl IntoIterator<Item = (f64, f64)>) -> MeanSquared {
    let (mut se, mut rel, mut n) = (0.0, 0.0, 0usize);
    for (e, r) in terms {
        se += e;
        rel += e / (r * r + REL_MSE_EPSILON);
        n += 1;
    }
    let n = n.max(1) as f64;
    MeanSquared {
        mse: se / n,
        rel_mse: rel / n,
    }
}

/// Squared differences of paired values, with the reference value: the
/// terms of [`mean_squared`] for an image against a reference.
pub fn squared_differences<'a>(
    values: impl IntoIterator<Item = f64> + 'a,
    reference: impl IntoIterator<Item = f64> + 'a,
) -> impl Iterator<Item = (f64, f64)> + 'a {
    values
        .into_iter()
        .zip(reference)
        .map(|(x, r)| ((x - r) * (x - r), r))
}

/// RMSE and relMSE of `image` against `reference` (luminance, same size).
pub fn errors(image: &[f64], reference: &[f64]) -> Errors {
    assert_eq!(image.len(), reference.len(), "images of one size");
    let m = mean_squared(squared_differences(
        image.iter().copied(),
        reference.iter().copied(),
    ));
    Errors {
        rmse: m.mse.sqrt(),
        rel_mse: m.rel_mse,
    }
}

/// Noise of a mean over N iterations, averaged over the pixels.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Noise {
    /// mean over pixels of s/sqrt(N), the standard error of the pixel mean.
    pub std_error: f64,
    /// mean over pixels of s^2/N, the variance of the pixel mean (the
    /// supplemental's Fig. 2 plots it as "sigma/N").
    pub variance: f64,
}

/// Noise from per-pixel sample variances s^2 of `iterations` per-iteration
/// estimates; `None` below two iterations, where s^2 is undefined.
pub fn noise(sample_variance: &[f64], iterations: u64) -> Option<Noise> {
    if iterations < 2 || sample_variance.is_empty() {
        return None;
    }
    let n = iterations as f64;
    let pixels = sample_variance.len() as f64;
    let (mut se, mut var) = (0.0, 0.0);
    for &s2 in sample_variance {
        let v = s2.max(0.0) / n;
        se += v.sqrt();
        var += v;
    }
    Some(Noise {
        std_error: se / pixels,
        variance: var / pixels,
    })
}

/// The iterations at which a run of `total` iterations is measured: the
/// powers of two up to `total`, and `total` itself.
pub fn checkpoints(total: u64) -> Vec<u64> {
    let mut out = Vec::new();
    let mut n = 1u64;
    while n <= total {
        out.push(n);
        match n.checked_mul(2) {
            Some(next) => n = next,
            None => break,
        }
    }
    if out.last() != Some(&total) && total > 0 {
        out.push(total);
    }
    out
}

/// ln, with non-positive values mapped to a very small number so that a
/// curve touching zero still interpolates (towards zero) instead of NaN.
fn ln(x: f64) -> f64 {
    x.max(1e-300).ln()
}

/// The value of a curve (time, error), sorted by time, at `time`,
/// interpolated linearly in log-log space between the neighbouring points;
/// `None` outside the measured time range.
pub fn value_at(curve: &[(f64, f64)], time: f64) -> Option<f64> {
    let (first, last) = (curve.first()?, curve.last()?);
    // A relative tolerance: the equal time is often exactly a measured end point.
    let slack = 1e-9 * time.abs().max(1e-12);
    if time < first.0 - slack || time > last.0 + slack {
        return None;
    }
    for pair in curve.windows(2) {
        let ((t0, e0), (t1, e1)) = (pair[0], pair[1]);
        if time > t1 + slack {
            continue;
        }
        if time <= t0 {
            return Some(e0);
        }
        if t1 <= t0 {
            return Some(e1);
        }
        let f = ((ln(time) - ln(t0)) / (ln(t1) - ln(t0))).clamp(0.0, 1.0);
        return Some((ln(e0) + f * (ln(e1) - ln(e0))).exp());
    }
    Some(last.1)
}

/// The time from which a curve (time, error), sorted by time, stays at or
/// below `level`, interpolated in log-log space between its last point
/// above the level and the next; `None` if it ends above. A dip below the
/// level that rises again (a firefly, or stratification that helps only
/// some iteration counts) does not count. A curve at or below `level` at
/// every point returns its first time (the crossing was earlier, but was
/// not measured).
pub fn time_to_reach(curve: &[(f64, f64)], level: f64) -> Option<f64> {
    let Some(last_above) = curve.iter().rposition(|&(_, e)| e > level) else {
        return Some(curve.first()?.0);
    };
    let (&(t0, e0), &(t1, e1)) = (&curve[last_above], curve.get(last_above + 1)?);
    // e0 > level >= e1: the crossing lies inside this segment.
    let f = ((ln(level) - ln(e0)) / (ln(e1) - ln(e0))).clamp(0.0, 1.0);
    Some((ln(t0) + f * (ln(t1) - ln(t0))).exp())
}

/// Equal-time comparison of two curves: at the smaller of their final
/// times, (that time, a's error, b's error). `None` when the time lies
/// before the first point of either curve.
pub fn at_equal_time(a: &[(f64, f64)], b: &[(f64, f64)]) -> Option<(f64, f64, f64)> {
    let time = a.last()?.0.min(b.last()?.0);
    Some((time, value_at(a, time)?, value_at(b, time)?))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs().max(1.0)
    }

    #[test]
    fn luminance_weights_sum_to_one() {
        assert!(close(luminance(Vec3::ONE), 1.0));
        assert!(close(luminance(Vec3::new(1.0, 0.0, 0.0)), 0.2126));
        assert!(close(luminance(Vec3::new(0.0, 2.0, 0.0)), 1.4304));
    }

    #[test]
    fn errors_match_hand_computed_values() {
        // Differences 1, -2, 0, 1: squared 1, 4, 0, 1 -> MSE 1.5.
        let reference = [1.0, 2.0, 0.0, 0.5];
        let image = [2.0, 0.0, 0.0, 1.5];
        let e = errors(&image, &reference);
        assert!(close(e.rmse, 1.5f64.sqrt()));
        // relMSE = (1/1.01 + 4/4.01 + 0/0.01 + 1/0.26) / 4.
        let expected = (1.0 / 1.01 + 4.0 / 4.01 + 0.0 + 1.0 / 0.26) / 4.0;
        assert!(close(e.rel_mse, expected), "{} vs {expected}", e.rel_mse);
        let same = errors(&reference, &reference);
        assert_eq!((same.rmse, same.rel_mse), (0.0, 0.0));
    }

    #[test]
    fn noise_is_the_pixel_mean_of_standard_errors_and_variances() {
        // s^2 = 4 and 16 over N = 4 iterations: s^2/N = 1 and 4, s/sqrt(N) = 1 and 2.
        let n = noise(&[4.0, 16.0], 4).unwrap();
        assert!(close(n.std_error, 1.5));
        assert!(close(n.variance, 2.5));
        assert_eq!(noise(&[4.0], 1), None);
        // The film's s^2 of estimates 1, 2, 4, 7 is 7 (integrators::film tests).
        let mut film = integrators::Film::new(1, 1);
        for x in [1.0f32, 2.0, 4.0, 7.0] {
            film.add_iteration(&[Vec3::splat(x)]);
        }
        let s2: Vec<f64> = film.variance().iter().map(|v| v.x).collect();
        let n = noise(&s2, film.iterations()).unwrap();
        assert!(close(n.variance, 7.0 / 4.0));
        assert!(close(n.std_error, (7.0f64 / 4.0).sqrt()));
    }

    #[test]
    fn checkpoints_are_powers_of_two_and_the_end() {
        assert_eq!(checkpoints(1), vec![1]);
        assert_eq!(checkpoints(2), vec![1, 2]);
        assert_eq!(checkpoints(16), vec![1, 2, 4, 8, 16]);
        assert_eq!(checkpoints(20), vec![1, 2, 4, 8, 16, 20]);
        assert_eq!(checkpoints(1024).len(), 11);
        assert_eq!(checkpoints(0), Vec::<u64>::new());
        assert_eq!(checkpoints(u64::MAX).last(), Some(&u64::MAX));
    }

    #[test]
    fn interpolation_is_exact_on_power_laws() {
        // e = 2 t^-1/2 is a line in log-log space: interpolation is exact.
        let curve: Vec<(f64, f64)> = [1.0, 4.0, 16.0]
            .iter()
            .map(|&t: &f64| (t, 2.0 / t.sqrt()))
            .collect();
        assert!(close(value_at(&curve, 2.0).unwrap(), 2.0 / 2f64.sqrt()));
        assert!(close(value_at(&curve, 9.0).unwrap(), 2.0 / 3.0));
        assert!(close(value_at(&curve, 16.0).unwrap(), 0.5));
        assert_eq!(value_at(&curve, 0.5), None);
        assert_eq!(value_at(&curve, 17.0), None);
        // Reaching e = 1 takes t = 4 exactly; 0.8 takes t = 6.25.
        assert!(close(time_to_reach(&curve, 1.0).unwrap(), 4.0));
        assert!(close(time_to_reach(&curve, 0.8).unwrap(), 6.25));
        assert_eq!(time_to_reach(&curve, 0.1), None);
        assert_eq!(time_to_reach(&curve, 5.0), Some(1.0));
    }

    #[test]
    fn equal_time_uses_the_shorter_run() {
        // a: e = t^-1/2 measured to t = 16; b: e = 3 t^-1 measured to t = 4.
        let a = [(1.0, 1.0), (16.0, 0.25)];
        let b = [(1.0, 3.0), (4.0, 0.75)];
        let (t, ea, eb) = at_equal_time(&a, &b).unwrap();
        assert_eq!(t, 4.0);
        assert!(close(ea, 0.5));
        assert!(close(eb, 0.75));
        // A run whose first point comes after the other's end has no equal time.
        let late = [(10.0, 1.0), (20.0, 0.5)];
        assert_eq!(at_equal_time(&b, &late), None);
    }

    /// On a non-monotone curve the level counts as reached where the curve
    /// crosses it for good: the dip to 1.0 at t = 2 rises again to 3.0.
    #[test]
    fn a_dip_that_rises_again_does_not_count() {
        let curve = [(1.0, 4.0), (2.0, 1.0), (4.0, 3.0), (8.0, 0.5)];
        // Between (4, 3) and (8, 0.5): f = ln(2/3) / ln(1/6), t = 4 * 2^f.
        let f = (2.0f64 / 3.0).ln() / (1.0f64 / 6.0).ln();
        assert!(close(
            time_to_reach(&curve, 2.0).unwrap(),
            4.0 * 2f64.powf(f)
        ));
        assert!(close(time_to_reach(&curve, 0.5).unwrap(), 8.0));
        assert_eq!(time_to_reach(&[(1.0, 1.0), (2.0, 3.0)], 2.0), None);
    }
}
