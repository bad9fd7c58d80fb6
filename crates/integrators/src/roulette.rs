//! Russian roulette, the unbiased way to spend fewer rays: on subpaths
//! (ending them) and on shadow rays (skipping them). Both keep every
//! expectation, and MIS weights need not know about either.

use glam::Vec3;

/// Depth (in vertices) from which Russian roulette may end subpaths.
pub const ROULETTE_DEPTH: u32 = 3;

/// Russian roulette on a subpath's throughput at a vertex of depth `depth`:
/// from [`ROULETTE_DEPTH`] on, the subpath survives with probability
/// min(1, max component / `scale`) and is reweighted. `scale` is 1 on
/// camera subpaths (throughput is a fraction of the pixel) and the emitted
/// throughput on light subpaths (which carry flux, whose scale is the
/// light's). Returns false when the subpath ends.
pub fn survives(depth: u32, throughput: &mut Vec3, scale: f32, u: f32) -> bool {
    if depth < ROULETTE_DEPTH {
        return true;
    }
    let survive = (throughput.max_element() / scale).min(1.0);
    if !(u < survive) {
        return false;
    }
    *throughput /= survive;
    true
}

/// Russian roulette on shadow rays (Veach 1997, §10.4.1, "efficiency-
/// optimized Russian roulette"): a contribution whose largest component c is
/// below the threshold keeps its shadow ray with probability c / threshold
/// and is divided by it, so its expectation is unchanged. Many connections
/// carry a small share of a pixel (their MIS weights split the path among
/// the techniques); skipping most of their rays costs little variance. MIS
/// weights are unaffected: visibility is in no technique's density.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ShadowRoulette {
    /// Contributions below this go through the roulette; 0 keeps every ray.
    pub threshold: f32,
}

impl ShadowRoulette {
    /// The roulette of a contribution whose MIS weight `weight` computes:
    /// the weighted contribution whose visibility is to be tested, or `None`
    /// when the ray is skipped or the weight is zero. The weight (at most 1)
    /// is computed only when the unweighted contribution does not already
    /// fail the roulette.
    #[inline]
    pub fn weighted(&self, unweighted: Vec3, u: f32, weight: impl FnOnce() -> f32) -> Option<Vec3> {
        if self.skips(unweighted.max_element(), u) {
            return None;
        }
        let weight = weight();
        if weight <= 0.0 {
            return None;
        }
        self.apply(unweighted * weight, u)
    }

    /// The contribution to test for visibility, or `None` when the ray is
    /// skipped. A non-finite contribution is kept (and later counted as an
    /// invalid sample).
    pub fn apply(&self, contribution: Vec3, u: f32) -> Option<Vec3> {
        let c = contribution.max_element();
        if !(c < self.threshold) {
            return Some(contribution);
        }
        let q = c / self.threshold;
        (u < q).then(|| contribution / q)
    }

    /// True when [`ShadowRoulette::apply`] is sure to skip every
    /// contribution whose largest component is at most `bound`, with the
    /// same `u`: the MIS weight (at most 1) of a connection need not be
    /// computed when its unweighted contribution already fails the
    /// roulette, nor its BSDFs evaluated when a bound of them does. The same
    /// decisions, reached sooner. A NaN bound decides nothing.
    #[inline]
    pub fn skips(&self, bound: f32, u: f32) -> bool {
        bound < self.threshold && u >= bound / self.threshold
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The roulette keeps a contribution's expectation: averaged over a
    /// stratified grid of u it returns the contribution (to the grid's
    /// resolution); above the threshold, or without one, it is the identity.
    #[test]
    fn shadow_roulette_is_unbiased() {
        let n: u32 = 1 << 16;
        let roulette = ShadowRoulette { threshold: 0.1 };
        let c = Vec3::new(0.03, 0.01, 0.0);
        let u = |i: u32| (i as f32 + 0.5) / n as f32;
        let mean = (0..n)
            .filter_map(|i| roulette.apply(c, u(i)))
            .map(Vec3::as_dvec3)
            .sum::<glam::DVec3>()
            / f64::from(n);
        // One grid cell more or less kept changes the mean by threshold / n.
        let tolerance = 0.1 / f64::from(n);
        assert!(
            (mean - c.as_dvec3()).abs().max_element() < tolerance,
            "{mean} vs {c}"
        );
        let kept = (0..n)
            .filter(|&i| roulette.apply(c, u(i)).is_some())
            .count();
        assert_eq!(kept, (0.3 * f64::from(n)).round() as usize);
        // The early test skips only what the roulette would skip.
        let mut early = 0;
        for i in 0..n {
            for w in [1.0, 0.5, 0.1] {
                if roulette.skips(c.max_element(), u(i)) {
                    early += 1;
                    assert_eq!(roulette.apply(c * w, u(i)), None, "u {}, weight {w}", u(i));
                }
            }
        }
        assert_eq!(early, 3 * (n - kept as u32));
        for u in [0.0, 0.5, 0.999] {
            assert_eq!(ShadowRoulette { threshold: 0.02 }.apply(c, u), Some(c));
            assert_eq!(ShadowRoulette { threshold: 0.0 }.apply(c, u), Some(c));
            assert!(roulette.apply(Vec3::NAN, u).is_some_and(|v| v.is_nan()));
        }
    }

    /// Subpath roulette: below [`ROULETTE_DEPTH`] every subpath survives
    /// unchanged; beyond it the expected throughput is kept.
    #[test]
    fn subpath_roulette_keeps_the_expected_throughput() {
        let t = Vec3::new(0.2, 0.4, 0.1);
        let mut early = t;
        assert!(survives(ROULETTE_DEPTH - 1, &mut early, 1.0, 0.99));
        assert_eq!(early, t);
        for scale in [1.0, 2.0] {
            let n = 1 << 12;
            let sum: Vec3 = (0..n)
                .filter_map(|i| {
                    let mut x = t;
                    let u = (i as f32 + 0.5) / n as f32;
                    survives(ROULETTE_DEPTH, &mut x, scale, u).then_some(x)
                })
                .sum();
            let mean = sum / n as f32;
            assert!((mean - t).abs().max_element() < 1e-3, "{mean} vs {t}");
        }
    }
}
