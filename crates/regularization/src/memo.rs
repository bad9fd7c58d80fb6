//! A memo of recently widened lobes, for callers that regularize the same
//! few lobes again and again.
//!
//! [`regularize`] is a pure function of (lobe, tau, energy), and through
//! alpha-hat of (lobe, alpha-hat, energy). Widening a lobe with
//! `Energy::Preserved` builds its compensation (`microfacet::energy`,
//! `microfacet::dielectric_energy`: the deficit's average over both sides'
//! table rows), microseconds per call. A renderer widens few distinct
//! lobes: one alpha-hat per material in uniform mode (tau_N is fixed within
//! an iteration), one per material and rho in selective modes (SPEC §5;
//! rho takes the scene's few alphas). The memo keeps the last
//! [`MEMO_ENTRIES`] widened lobes and returns what `regularize` would,
//! bit for bit.

use microfacet::{Bsdf, SMOOTH_ALPHA};

use crate::selective::Energy;
use crate::tau::{AlphaHat, bsdf_alpha_hat, regularize};

/// Widened lobes a memo keeps: a scene's glossy and specular materials
/// times the few alpha-hat of one iteration, for one worker thread.
pub const MEMO_ENTRIES: usize = 8;

/// The last `MEMO_ENTRIES` lobes widened with their energy compensation by
/// [`RegularizationMemo::regularize`], replaced in turn. Pure data: a
/// multithreaded caller keeps one per thread.
#[derive(Clone, Debug)]
pub struct RegularizationMemo {
    entries: [Option<Entry>; MEMO_ENTRIES],
    next: usize,
}

/// One widened lobe: the key (original lobe, alpha-hat) and the result.
#[derive(Clone, Copy, Debug)]
struct Entry {
    original: Bsdf,
    alpha_hat: f32,
    widened: Bsdf,
}

impl Default for RegularizationMemo {
    fn default() -> Self {
        Self::new()
    }
}

impl RegularizationMemo {
    /// An empty memo (`const`: a `thread_local!` of it needs no lazy
    /// initialisation).
    pub const fn new() -> Self {
        Self {
            entries: [None; MEMO_ENTRIES],
            next: 0,
        }
    }

    /// [`regularize`]`(bsdf, tau, energy)`, from the memo when the same lobe
    /// was widened to the same alpha-hat with its energy compensation
    /// (alpha-hat compared bit for bit; a lobe holding a NaN never matches
    /// and is widened anew). `Energy::Lost` widens in nanoseconds and is
    /// not kept.
    pub fn regularize(
        &mut self,
        bsdf: &Bsdf,
        tau: f64,
        energy: Energy,
    ) -> (Bsdf, Option<AlphaHat>) {
        if energy == Energy::Lost {
            return regularize(bsdf, tau, energy);
        }
        let Some(hat) = bsdf_alpha_hat(bsdf, tau) else {
            return (*bsdf, None);
        };
        if bsdf.alpha() == Some(hat.alpha) {
            return (*bsdf, Some(hat));
        }
        // A lobe that stays a delta gets no compensation
        // (`Bsdf::regularized`): nothing to build, nothing to keep.
        if hat.alpha < SMOOTH_ALPHA {
            return (bsdf.with_alpha(hat.alpha), Some(hat));
        }
        let same = |e: &&Entry| e.alpha_hat.to_bits() == hat.alpha.to_bits() && e.original == *bsdf;
        if let Some(entry) = self.entries.iter().flatten().find(same) {
            return (entry.widened, Some(hat));
        }
        let widened = bsdf.regularized(hat.alpha);
        self.entries[self.next] = Some(Entry {
            original: *bsdf,
            alpha_hat: hat.alpha,
            widened,
        });
        self.next = (self.next + 1) % MEMO_ENTRIES;
        (widened, Some(hat))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::Vec3;
    use microfacet::{Conductor, Dielectric, Fresnel, MicrofacetModel, NdfKind, Shadowing};

    fn lobes() -> Vec<Bsdf> {
        let model = |alpha| MicrofacetModel::new(NdfKind::Ggx, alpha, Shadowing::Smith);
        let mut lobes = Vec::new();
        for alpha in [0.0, 0.02, 0.05, 0.3] {
            lobes.push(Bsdf::Conductor(Conductor {
                model: model(alpha),
                fresnel: Fresnel::Schlick { f0: Vec3::ONE },
            }));
            lobes.push(Bsdf::Dielectric(Dielectric::new(model(alpha), 1.5)));
            lobes.push(Bsdf::Dielectric(Dielectric::new(model(alpha), 1.0 / 1.33)));
        }
        lobes
    }

    /// More lobes and bounds than the memo holds, each asked for twice in a
    /// row (the second from the memo) and between keys that differ in one
    /// part only (energy, tau, alpha, eta): every result equals
    /// `regularize`'s. tau = 1e9 widens the smooth lobes to alpha-hat
    /// between `ALPHA_MIN` and `SMOOTH_ALPHA`: still deltas.
    #[test]
    fn memo_returns_what_regularize_returns() {
        let mut memo = RegularizationMemo::new();
        for (i, bsdf) in lobes().iter().enumerate() {
            for tau in [7.5, 30.0, 120.0, 1e9] {
                for energy in [Energy::Preserved, Energy::Lost] {
                    for _ in 0..2 {
                        let got = memo.regularize(bsdf, tau, energy);
                        assert_eq!(got, regularize(bsdf, tau, energy), "lobe {i}, tau {tau}");
                    }
                }
            }
        }
    }

    /// The same lobe widened over and over is built once.
    #[test]
    fn repeated_lobes_come_from_the_memo() {
        let bsdf = lobes()[1];
        let mut memo = RegularizationMemo::new();
        let first = memo.regularize(&bsdf, 7.5, Energy::Preserved);
        for _ in 0..3 {
            assert_eq!(memo.regularize(&bsdf, 7.5, Energy::Preserved), first);
        }
        assert_eq!(memo.entries.iter().flatten().count(), 1);
    }

    /// A smooth lobe widened to a width that is still a delta is widened
    /// (alpha-hat above its alpha) but not kept: it has no compensation.
    #[test]
    fn lobes_that_stay_deltas_are_not_kept() {
        let mut memo = RegularizationMemo::new();
        for bsdf in lobes().iter().filter(|b| b.is_specular()) {
            let (widened, hat) = memo.regularize(bsdf, 1e9, Energy::Preserved);
            let hat = hat.unwrap();
            assert!(widened.is_specular() && hat.alpha > bsdf.alpha().unwrap());
            assert_eq!(widened.alpha(), Some(hat.alpha));
        }
        assert_eq!(memo.entries.iter().flatten().count(), 0);
    }
}
