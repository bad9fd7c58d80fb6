//! A memo of recently widened lobes, for callers that regularize the same
//! few lobes again and again.
//!
//! [`regularize`] is a pure function of (lobe, tau, energy), and through
//! alpha-hat of (lobe, alpha-hat, energy). Widening a lobe with
//! `Energy::Preserved` builds its compensation (`microfacet::compensation::energy`,
//! `microfacet::compensation::dielectric_energy`: the deficit's average over both sides'
//! table rows), microseconds per call. A renderer widens few distinct
//! lobes: one alpha-hat per material in uniform mode (tau_N is fixed within
//! an iteration), one per material and rho in selective modes (SPEC §5;
//! rho takes the scene's few alphas). The memo keeps the last
//! [`MEMO_ENTRIES`] widened lobes and returns what `regularize` would,
//! bit for bit. Keyed by tau too, it also spares alpha-hat itself for the
//! lobe asked again under the same tau (in `unsampleable` mode, every
//! delta lobe at the start of a camera subpath).

use microfacet::Bsdf;

use crate::tau::{AlphaHat, Energy, bsdf_alpha_hat, regularize};

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

/// One widened lobe: the key (original lobe, tau or alpha-hat) and the
/// result.
#[derive(Clone, Copy, Debug)]
struct Entry {
    original: Bsdf,
    tau: f64,
    hat: AlphaHat,
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
    /// was widened under the same tau (then alpha-hat is not computed
    /// again) or to the same alpha-hat (then the compensation is not built
    /// again); tau and alpha-hat compared bit for bit, a lobe holding a NaN
    /// never matches and is widened anew. Lobes that tau leaves as they
    /// are, and `Energy::Lost`, which widens in nanoseconds, are not kept.
    ///
    /// First use: with `Energy::Preserved`, builds the energy tables of the
    /// lobe's model once per process (seconds in a release build, 10-20x
    /// longer unoptimised); `microfacet::prepare_tables` builds them ahead.
    pub fn regularize(
        &mut self,
        bsdf: &Bsdf,
        tau: f64,
        energy: Energy,
    ) -> (Bsdf, Option<AlphaHat>) {
        if energy == Energy::Lost {
            return regularize(bsdf, tau, energy);
        }
        let same_tau = |e: &&Entry| e.tau.to_bits() == tau.to_bits() && e.original == *bsdf;
        if let Some(entry) = self.entries.iter().flatten().find(same_tau) {
            return (entry.widened, Some(entry.hat));
        }
        let Some(hat) = bsdf_alpha_hat(bsdf, tau) else {
            return (*bsdf, None);
        };
        if bsdf.alpha() == Some(hat.alpha) {
            return (*bsdf, Some(hat));
        }
        let same_width =
            |e: &&Entry| e.hat.alpha.to_bits() == hat.alpha.to_bits() && e.original == *bsdf;
        let widened = match self.entries.iter().flatten().find(same_width) {
            Some(entry) => entry.widened,
            None => bsdf.regularized(hat.alpha),
        };
        self.entries[self.next] = Some(Entry {
            original: *bsdf,
            tau,
            hat,
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

    /// Kept: widened lobes, also those that stay deltas (tau = 1e9 widens
    /// the smooth lobes to alpha-hat between `ALPHA_MIN` and `SMOOTH_ALPHA`).
    /// Not kept: lobes that tau leaves as they are (the rough ones there).
    #[test]
    fn only_widened_lobes_are_kept() {
        let mut memo = RegularizationMemo::new();
        let lobes = lobes();
        for bsdf in &lobes {
            let (widened, hat) = memo.regularize(bsdf, 1e9, Energy::Preserved);
            assert_eq!(widened.alpha(), hat.map(|h| h.alpha));
            assert_eq!(widened.is_specular(), bsdf.is_specular());
        }
        let smooth = lobes.iter().filter(|b| b.is_specular()).count();
        assert_eq!(memo.entries.iter().flatten().count(), smooth);
    }

    /// Two bounds that give the same alpha-hat (both beyond the cap) give
    /// the same widened lobe (the second from the first's entry), kept
    /// under each tau.
    #[test]
    fn bounds_with_the_same_alpha_hat_share_the_widened_lobe() {
        let bsdf = lobes()[1];
        let mut memo = RegularizationMemo::new();
        let (a, hat_a) = memo.regularize(&bsdf, 1e-3, Energy::Preserved);
        let (b, hat_b) = memo.regularize(&bsdf, 2e-3, Energy::Preserved);
        assert_eq!(hat_a.unwrap().alpha, hat_b.unwrap().alpha);
        assert_eq!(a, b);
        assert_eq!(memo.entries.iter().flatten().count(), 2);
    }
}
