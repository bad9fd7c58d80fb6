//! Chi-square goodness of fit of a direction sampler against its pdf.
//!
//! The procedure follows pbrt-v4's `bsdfs_test.cpp` (itself after Mitsuba's
//! `chi2.py`): samples are binned on a (theta, phi) grid over the whole
//! sphere, the pdf is integrated over every cell, cells whose expected count
//! is small are pooled, and the statistic is compared against the chi-square
//! distribution. Samples the sampler rejects (it returned `None`) form one more
//! cell whose expected count is the pdf mass missing from the sphere, so a
//! sampler that fails too often, or a pdf that claims too much mass, is caught.

use std::f64::consts::PI;

use glam::Vec3;

use crate::quadrature::{Depth, adaptive_simpson_2d};
use crate::rng::Pcg32;
use crate::special::chi2_survival;

/// Cells with a smaller expected count are pooled (the usual rule of thumb
/// for the chi-square approximation to hold; pbrt uses the same 5).
pub const MIN_EXPECTED_COUNT: f64 = 5.0;

/// Fraction of all samples allowed in cells where the pdf integrates to
/// exactly zero before the test fails outright (pbrt-v4 uses the same 1e-5):
/// it tolerates directions that land on a cell edge by round-off.
const MAX_UNEXPECTED_FRACTION: f64 = 1e-5;

/// Configuration of a spherical chi-square test.
#[derive(Clone, Copy, Debug)]
pub struct SphericalChi2 {
    /// Number of theta bins over [0, pi].
    pub theta_res: usize,
    /// Number of phi bins over [0, 2 pi).
    pub phi_res: usize,
    /// Number of samples drawn.
    pub sample_count: usize,
    /// Absolute error allowed when integrating the pdf over one cell.
    ///
    /// An error delta in a cell's probability moves its expected count by
    /// `delta * sample_count`, and the statistic by about that over the
    /// expected count. The default, 1e-7 at 200,000 samples, is 0.02 counts:
    /// about 0.004 per cell of `MIN_EXPECTED_COUNT`, against the
    /// statistic's own spread of sqrt(2 dof). Tighter costs time for nothing:
    /// at 1e-9 microfacet's chi-square tests took 2.1x as long, and their
    /// 300 statistics moved by at most 1.0.
    pub integration_eps: f64,
    /// Refinement limits of the adaptive quadrature (per dimension and cell).
    /// The minimum must resolve the narrowest lobe tested: 2^min intervals per
    /// cell side.
    pub integration_depth: Depth,
}

impl Default for SphericalChi2 {
    fn default() -> Self {
        Self {
            theta_res: 20,
            phi_res: 40,
            sample_count: 200_000,
            integration_eps: 1e-7,
            integration_depth: Depth { min: 3, max: 10 },
        }
    }
}

/// Result of one chi-square test.
#[derive(Clone, Debug)]
pub struct Chi2Outcome {
    /// The chi-square statistic.
    pub statistic: f64,
    /// Degrees of freedom (number of cells after pooling, minus one).
    pub dof: usize,
    /// Probability of a statistic at least this large if the sampler matches the pdf.
    pub p_value: f64,
    /// Number of samples the sampler rejected.
    pub rejected: usize,
    /// Why the test failed regardless of the p-value, if it did.
    pub problem: Option<String>,
}

impl Chi2Outcome {
    /// True when the sampler is consistent with the pdf at `significance`.
    pub fn passes(&self, significance: f64) -> bool {
        self.problem.is_none() && self.p_value.is_finite() && self.p_value >= significance
    }
}

/// Sidak correction: the per-test significance that keeps the probability of
/// any false rejection among `tests` independent tests at `family_significance`.
pub fn sidak(family_significance: f64, tests: usize) -> f64 {
    1.0 - (1.0 - family_significance).powf(1.0 / tests as f64)
}

/// Unit direction with polar angle `theta` and azimuth `phi`.
pub fn spherical_direction(theta: f64, phi: f64) -> Vec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    Vec3::new((st * cp) as f32, (st * sp) as f32, ct as f32)
}

impl SphericalChi2 {
    /// Draws `sample_count` directions with `sample` and tests them against `pdf`
    /// (a solid-angle density; it may integrate to less than one when the
    /// sampler rejects some samples).
    pub fn run(
        &self,
        rng: &mut Pcg32,
        mut sample: impl FnMut(&mut Pcg32) -> Option<Vec3>,
        pdf: impl Fn(Vec3) -> f64,
    ) -> Chi2Outcome {
        let observed = self.histogram(rng, &mut sample);
        let expected = self.expected(&pdf);
        self.compare(&observed, &expected)
    }

    fn cell_count(&self) -> usize {
        self.theta_res * self.phi_res
    }

    /// Observed counts per cell, plus the rejected samples as the last entry.
    fn histogram(
        &self,
        rng: &mut Pcg32,
        sample: &mut impl FnMut(&mut Pcg32) -> Option<Vec3>,
    ) -> Vec<f64> {
        let mut counts = vec![0.0; self.cell_count() + 1];
        for _ in 0..self.sample_count {
            let index = match sample(rng) {
                Some(w) if w.is_finite() => self.cell_of(w.normalize()),
                Some(_) => {
                    // A non-finite direction is a failure of the sampler: put it
                    // in the rejection cell, where nothing is expected of it.
                    self.cell_count()
                }
                None => self.cell_count(),
            };
            counts[index] += 1.0;
        }
        counts
    }

    fn cell_of(&self, w: Vec3) -> usize {
        let theta = f64::from(w.z).clamp(-1.0, 1.0).acos();
        let mut phi = f64::from(w.y).atan2(f64::from(w.x));
        if phi < 0.0 {
            phi += 2.0 * PI;
        }
        let t = ((theta / PI * self.theta_res as f64) as usize).min(self.theta_res - 1);
        let p = ((phi / (2.0 * PI) * self.phi_res as f64) as usize).min(self.phi_res - 1);
        t * self.phi_res + p
    }

    /// Expected counts per cell from the pdf, plus the missing mass as the last entry.
    fn expected(&self, pdf: &impl Fn(Vec3) -> f64) -> Vec<f64> {
        let dtheta = PI / self.theta_res as f64;
        let dphi = 2.0 * PI / self.phi_res as f64;
        let n = self.sample_count as f64;
        let mut expected = Vec::with_capacity(self.cell_count() + 1);
        for t in 0..self.theta_res {
            for p in 0..self.phi_res {
                let theta = (t as f64 * dtheta, (t + 1) as f64 * dtheta);
                let phi = (p as f64 * dphi, (p + 1) as f64 * dphi);
                let mass = adaptive_simpson_2d(
                    &mut |th, ph| pdf(spherical_direction(th, ph)) * th.sin(),
                    theta,
                    phi,
                    self.integration_eps,
                    self.integration_depth,
                );
                expected.push(mass * n);
            }
        }
        let total: f64 = expected.iter().sum();
        expected.push((n - total).max(0.0));
        expected
    }

    fn compare(&self, observed: &[f64], expected: &[f64]) -> Chi2Outcome {
        let rejected = observed[observed.len() - 1] as usize;
        let fail = |problem: String| Chi2Outcome {
            statistic: f64::INFINITY,
            dof: 0,
            p_value: 0.0,
            rejected,
            problem: Some(problem),
        };
        if let Some(bad) = expected.iter().position(|e| !e.is_finite()) {
            return fail(format!(
                "pdf integrates to a non-finite value in cell {bad}"
            ));
        }
        let mut order: Vec<usize> = (0..expected.len()).collect();
        order.sort_by(|&a, &b| expected[a].total_cmp(&expected[b]));

        let (mut pooled_observed, mut pooled_expected) = (0.0, 0.0);
        let (mut statistic, mut cells) = (0.0, 0usize);
        let n = self.sample_count as f64;
        for &i in &order {
            let (o, e) = (observed[i], expected[i]);
            if e == 0.0 {
                if o > n * MAX_UNEXPECTED_FRACTION {
                    return fail(format!(
                        "{o} samples in cell {i}, where the pdf integrates to zero"
                    ));
                }
            } else if e < MIN_EXPECTED_COUNT
                || (pooled_expected > 0.0 && pooled_expected < MIN_EXPECTED_COUNT)
            {
                pooled_observed += o;
                pooled_expected += e;
            } else {
                statistic += (o - e) * (o - e) / e;
                cells += 1;
            }
        }
        if pooled_expected > 0.0 {
            statistic += (pooled_observed - pooled_expected).powi(2) / pooled_expected;
            cells += 1;
        } else if pooled_observed > n * MAX_UNEXPECTED_FRACTION {
            return fail(format!(
                "{pooled_observed} samples where the pdf expects none"
            ));
        }
        if cells < 2 {
            return fail(format!(
                "only {cells} cell(s) after pooling: too few to test"
            ));
        }
        let dof = cells - 1;
        Chi2Outcome {
            statistic,
            dof,
            p_value: chi2_survival(statistic, dof),
            rejected,
            problem: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Cosine-weighted hemisphere sampling (Malley's method) and its pdf.
    fn cosine_sample(rng: &mut Pcg32) -> Option<Vec3> {
        let (u1, u2) = (rng.uniform_f64(), rng.uniform_f64());
        let r = u1.sqrt();
        let phi = 2.0 * PI * u2;
        Some(Vec3::new(
            (r * phi.cos()) as f32,
            (r * phi.sin()) as f32,
            (1.0 - u1).max(0.0).sqrt() as f32,
        ))
    }

    fn cosine_pdf(w: Vec3) -> f64 {
        f64::from(w.z).max(0.0) / PI
    }

    #[test]
    fn accepts_a_correct_sampler() {
        let test = SphericalChi2::default();
        let outcome = test.run(&mut Pcg32::new(1, 1), cosine_sample, cosine_pdf);
        assert!(outcome.passes(0.01), "{outcome:?}");
    }

    #[test]
    fn rejects_a_pdf_off_by_ten_percent() {
        let test = SphericalChi2::default();
        let outcome = test.run(&mut Pcg32::new(1, 1), cosine_sample, |w| {
            1.1 * cosine_pdf(w)
        });
        assert!(!outcome.passes(0.01), "{outcome:?}");
    }

    #[test]
    fn rejects_a_slightly_wrong_shape() {
        // pdf proportional to cos^1.1 instead of cos: same support, 5% shape error.
        let test = SphericalChi2::default();
        let outcome = test.run(&mut Pcg32::new(1, 1), cosine_sample, |w| {
            f64::from(w.z).max(0.0).powf(1.1) * 2.1 / (2.0 * PI)
        });
        assert!(!outcome.passes(0.01), "{outcome:?}");
    }

    #[test]
    fn counts_rejected_samples() {
        // Reject half the samples; the pdf accounts for it by halving.
        let test = SphericalChi2::default();
        let ok = test.run(
            &mut Pcg32::new(2, 1),
            |rng| {
                if rng.uniform_f32() < 0.5 {
                    None
                } else {
                    cosine_sample(rng)
                }
            },
            |w| 0.5 * cosine_pdf(w),
        );
        assert!(ok.passes(0.01), "{ok:?}");
        // A pdf that ignores the rejections must fail.
        let bad = test.run(
            &mut Pcg32::new(2, 1),
            |rng| {
                if rng.uniform_f32() < 0.5 {
                    None
                } else {
                    cosine_sample(rng)
                }
            },
            cosine_pdf,
        );
        assert!(!bad.passes(0.01), "{bad:?}");
    }

    #[test]
    fn sidak_correction() {
        assert!((sidak(0.01, 1) - 0.01).abs() < 1e-15);
        let s = sidak(0.01, 100);
        assert!((1.0 - (1.0 - s).powi(100) - 0.01).abs() < 1e-12);
    }
}
