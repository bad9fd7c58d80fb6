//! Reciprocal scaling of a widened lobe that gains energy (`crate::compensation::energy`,
//! "Gains").
//!
//! Where widening alpha to alpha-hat raises the white albedo,
//! E_alpha-hat(mu) above E_alpha(mu) (V-cavity; Beckmann and Blinn-Phong;
//! GGX near grazing), no non-negative lobe added to the widened one can
//! take the gain away. The widened lobe f-hat is scaled instead,
//! symmetrically:
//!
//! f'(wi, wo) = s(mu_i) s(mu_o) f-hat(wi, wo) + f_c(wi, wo),
//!
//! with s > 0 chosen so that the scaled lobe reflects E_s(mu) = min(E_alpha,
//! E_alpha-hat)(mu) at every mu, and f_c Kulla & Conty's compensation lobe
//! (2017) on the deficit dE = E_alpha - E_s = max(0, E_alpha - E_alpha-hat),
//! as without gains (`crate::compensation::energy`). f' is symmetric (reciprocal) and
//! non-negative, and reflects E_s + dE = E_alpha. With
//! K(mu_i, mu_o) = int_0^2pi f-hat(wi, wo) mu_o dphi_o the azimuth-integrated
//! kernel of the white (F = 1) widened lobe, s solves
//!
//! s(mu_i) int_0^1 K(mu_i, mu_o) s(mu_o) dmu_o = E_s(mu_i):
//!
//! a symmetric matrix balancing, the scaling D K D with prescribed row sums
//! of Sinkhorn & Knopp ("Concerning nonnegative matrices and doubly
//! stochastic matrices", Pacific J. Math. 21, 1967) in its symmetric form
//! (one diagonal scaling on both sides, as in Knight, "The Sinkhorn-Knopp
//! algorithm: convergence and applications", SIAM J. Matrix Anal. Appl. 30,
//! 2008, whose damped fixed point s <- sqrt(s E_s / (K s)) `balance` runs).
//! Where the lobe gains nothing s = 1; as alpha-hat -> alpha the gain
//! vanishes and s -> 1 (consistency).
//!
//! **What is tabulated.** Write m(mu) = E_s/E_alpha-hat = min(1, E_alpha /
//! E_alpha-hat) (`kept_share`) and s-bar(mu_i) = int K(mu_i, mu_o) s(mu_o)
//! dmu_o / E_alpha-hat(mu_i), the mean of s over where mu_i reflects to.
//! The balancing is s s-bar = m, so
//!
//! s(mu) = m(mu) / s-bar(mu).
//!
//! m has a kink where the albedos cross, at a mu and an (alpha, alpha-hat)
//! of their own, which no table interpolates well (tabulating s itself left
//! up to 2.7e-3 of albedo at mu >= 0.1); s-bar is a mean over the lobe, smooth
//! across it. So m is computed from the albedo tables at the lobe's own
//! alpha, alpha-hat and mu, exactly as dE is (E_s + dE = E_alpha then
//! holds at every mu), and only s-bar is tabulated (`MeanScaleTable`).
//!
//! **Discretisation.** Per NDF and shadowing model and per alpha-hat node
//! of the albedo tables, the kernel `K[i][b]` is the white lobe's reflection
//! from mu node i deposited into hat functions of sqrt(mu_o) on
//! `SUBDIVISIONS` bins per table cell (fine enough for the kink of m), by
//! the tables' own quadrature (`SplitQuadrature::albedo_with`): its rows sum
//! to the tabulated E_alpha-hat. Per pair of (alpha, alpha-hat) nodes
//! whose white albedos cross (a gain above `MIN_GAIN` at some mu node),
//! `balance` solves s s-bar = m for s-bar at the mu nodes (linear in
//! sqrt(mu) between them, m at the bins from the tables); every other pair
//! keeps s-bar = 1. It converges in at most 23 iterations for every pair.
//! s-bar is interpolated linearly in sqrt(alpha), sqrt(alpha-hat) and
//! sqrt(mu) (bicubic in the alphas, as the albedo tables, moved the
//! furnace errors by 2e-5 at three times the cost); below the diagonal
//! alpha = alpha-hat, which a lobe reads when both share a cell, the table
//! holds the odd continuation 2 - s-bar(alpha-hat, alpha) (see
//! `MeanScaleTable::compute_with_statistics`). A lobe uses the table only
//! when its own pair gains (`energy::Compensation::scaled`); every other
//! lobe is unchanged bit for bit.
//!
//! **Accuracy** (`tests/microfacet/energy_compensation.rs`, quadrature truth with s
//! at every quadrature direction, originals 0 to 0.3, alpha-hat to 1, every
//! NDF and shadowing model): the compensated albedo is within 4.2e-4 of the
//! original's for mu >= 0.04 and 9.2e-4 at mu 0.02, gains included (up to
//! 5.5e-2 off without the scaling). s lies in [0.937, 1.005] over the
//! pairs that gain (slightly above 1 where such a pair loses energy, next
//! to where it gains).
//!
//! **Sampling.** f-hat is sampled as before; s only reweights it, so a
//! sample's value (and weight) gains the factor s(mu_i) s(mu_o) while pdf,
//! reverse pdf and p-hat are unchanged.
//!
//! **Cost.** A table per NDF and shadowing model, built serially at first
//! use of a lobe that gains (after the albedo table it reads; about as
//! long again, 0.15-1.0 s in release), 400 KB. Per evaluation of a scaled
//! lobe, s at mu_i and mu_o: the albedo lookups dE needs anyway and a
//! lookup of s-bar (8 table entries). Measured by callgrind (instructions per call,
//! a gold GGX/Smith conductor regularized from 0.01 to 0.09, which gains):
//! `eval` 2320 against 1896 before the scaling, `sample` 4921 against 5288
//! (`Compensation::probability` now looks each albedo up once, for every
//! compensated lobe); lobes that do not gain: `eval` +3 % (compensated)
//! and +0.2 % (plain).

use std::sync::OnceLock;

use crate::compensation::energy::{
    MODELS, TABLE_ALPHA, TABLE_ALPHA_MAX, TABLE_MU, albedo_table, alpha_node, cell, model_index,
    mu_node,
};
use crate::compensation::quadrature::{SplitQuadrature, lerp};
use crate::ndf::NdfKind;
use crate::shadowing::Shadowing;

/// A gain of the white albedo below this (at every mu node) is left alone:
/// the tables' nodes are within 5e-5 of a finer quadrature and the
/// interpolation adds to that (white Beckmann and Blinn-Phong lobes
/// tabulate up to 1 + 1.3e-4 at alpha 0.02, more than they can reflect),
/// so a smaller gain is not known to be one; leaving it costs the furnace
/// at most this much.
pub(crate) const MIN_GAIN: f32 = 1e-4;

/// Below this widened albedo E_alpha-hat(mu) the ratio m = min(1, E_alpha /
/// E_alpha-hat) is taken as 1: at grazing (the table's mu = 0 column) every
/// lobe reflects almost nothing, and the ratio of two rounding-sized
/// numbers means nothing.
const MIN_ALBEDO: f32 = 1e-6;

/// Kernel rows (mu nodes) that reflect less than this keep s-bar = 1:
/// the balancing would divide by a rounding-sized sum (`MIN_ALBEDO`).
const MIN_ROW_SUM: f64 = 1e-6;

/// The balancing stops when every node's scaled albedo is within this of
/// its target: far below the f32 the table stores and the 1e-3 furnace
/// tolerance.
const BALANCE_TOLERANCE: f64 = 1e-9;

/// Iterations of the damped fixed point at most; it converges linearly,
/// in at most a few hundred iterations for every tabulated pair
/// (`tests::balancing_converges_for_every_pair`).
pub(crate) const MAX_ITERATIONS: usize = 10_000;

/// (radial, azimuthal) Gauss-Legendre nodes per piece of the kernels'
/// quadrature: the albedo tables' (`energy::QUADRATURE`), so the kernels'
/// rows sum to the tabulated albedos.
const QUADRATURE: (usize, usize) = (16, 16);

/// Bins of the kernel per table cell in sqrt(mu_o): s has a kink inside a
/// cell where the target min(E_alpha, E_alpha-hat) switches, which the
/// kernel must resolve finer than the table's cells.
const SUBDIVISIONS: usize = 8;

/// Bins of the kernel in sqrt(mu_o), the table's nodes among them.
const BINS: usize = (TABLE_MU - 1) * SUBDIVISIONS + 1;

/// m(mu) = min(1, E_alpha / E_alpha-hat): the share of the widened lobe's
/// albedo the scaled lobe keeps (1 where nothing is gained).
pub(crate) fn kept_share(e: f32, e_hat: f32) -> f32 {
    if e_hat > MIN_ALBEDO {
        (e / e_hat).min(1.0)
    } else {
        1.0
    }
}

/// s-bar(alpha, alpha-hat, mu) of one NDF and shadowing model on the albedo
/// tables' nodes (`TABLE_ALPHA` x `TABLE_ALPHA` x `TABLE_MU`; module docs).
#[derive(Clone, Debug)]
pub struct MeanScaleTable {
    /// `mean[(a * TABLE_ALPHA + k) * TABLE_MU + j]`: alpha node a,
    /// alpha-hat node k, mu node j.
    mean: Vec<f32>,
}

impl MeanScaleTable {
    /// Computes the table: one kernel per alpha-hat node that has a pair
    /// which gains, one balancing per such pair (module docs).
    pub(crate) fn compute(kind: NdfKind, shadowing: Shadowing) -> Self {
        Self::compute_with_statistics(kind, shadowing).0
    }

    /// `compute`, with the balancings' statistics.
    pub(crate) fn compute_with_statistics(
        kind: NdfKind,
        shadowing: Shadowing,
    ) -> (Self, BalanceStatistics) {
        let albedo = albedo_table(kind, shadowing);
        let mut mean = vec![1.0; TABLE_ALPHA * TABLE_ALPHA * TABLE_MU];
        let mut statistics = BalanceStatistics::default();
        for k in 0..TABLE_ALPHA {
            let gaining: Vec<usize> = (0..k)
                .filter(|&a| {
                    (0..TABLE_MU).any(|j| albedo.node(k, j) - albedo.node(a, j) > MIN_GAIN)
                })
                .collect();
            if gaining.is_empty() {
                continue;
            }
            let kernel = Kernel::compute(kind, shadowing, alpha_node(k));
            let e_hat: Vec<f32> = (0..BINS)
                .map(|b| albedo.node_albedo(k, bin_mu(b)) as f32)
                .collect();
            for a in gaining {
                // m at the kernel's bins, as `Compensation::scale` finds it.
                let kept: Vec<f64> = (0..BINS)
                    .map(|b| {
                        let e = albedo.node_albedo(a, bin_mu(b)) as f32;
                        f64::from(kept_share(e, e_hat[b]))
                    })
                    .collect();
                let node_means = statistics.balance(&kernel, &kept, None, BALANCE_TOLERANCE);
                let row = (a * TABLE_ALPHA + k) * TABLE_MU;
                for (mean, node) in mean[row..row + TABLE_MU].iter_mut().zip(node_means) {
                    *mean = node as f32;
                }
            }
        }
        // Below the diagonal (alpha > alpha-hat), which a lobe reads where
        // alpha and alpha-hat share a cell: the odd continuation s-bar(k +
        // 1, k) = 2 - s-bar(k, k + 1). s-bar - 1 grows linearly with
        // alpha-hat - alpha from the diagonal, and only on its side (the
        // gain is a positive part), so the pair's own value there would put
        // a kink into the interpolation (up to 1.2e-3 of albedo at alpha
        // 0.06 -> 0.07 with the pairs' own values); the continuation is
        // smooth to first order.
        for k in 0..TABLE_ALPHA - 1 {
            for j in 0..TABLE_MU {
                let upper = mean[(k * TABLE_ALPHA + k + 1) * TABLE_MU + j];
                mean[((k + 1) * TABLE_ALPHA + k) * TABLE_MU + j] = 2.0 - upper;
            }
        }
        (Self { mean }, statistics)
    }

    /// s-bar(mu) for a lobe of width `alpha` widened to `alpha_hat`: linear
    /// in sqrt(alpha), sqrt(alpha-hat) and sqrt(mu) (module docs).
    pub fn mean_scale(&self, alpha: f32, alpha_hat: f32, mu: f32) -> f32 {
        let (j, t) = cell(mu, TABLE_MU, 1.0);
        let (a, ta) = cell(alpha, TABLE_ALPHA, TABLE_ALPHA_MAX);
        let (k, tk) = cell(alpha_hat, TABLE_ALPHA, TABLE_ALPHA_MAX);
        let at = |a: usize, k: usize| {
            let row = (a * TABLE_ALPHA + k) * TABLE_MU + j;
            lerp(self.mean[row], self.mean[row + 1], t)
        };
        lerp(
            lerp(at(a, k), at(a, k + 1), tk),
            lerp(at(a + 1, k), at(a + 1, k + 1), tk),
            ta,
        )
    }
}

/// What the balancings of one table took (`MeanScaleTable::compute_with_statistics`).
#[derive(Clone, Copy, Debug)]
pub(crate) struct BalanceStatistics {
    /// Pairs of nodes balanced (those that gain).
    pub(crate) pairs: usize,
    /// The most iterations one took (`MAX_ITERATIONS`: did not converge).
    pub(crate) max_iterations: usize,
    /// (smallest, largest) s at a node.
    pub(crate) scale_range: (f64, f64),
}

impl Default for BalanceStatistics {
    fn default() -> Self {
        Self {
            pairs: 0,
            max_iterations: 0,
            scale_range: (f64::INFINITY, 0.0),
        }
    }
}

impl BalanceStatistics {
    /// `balance(kernel, kept, start, tolerance)`, recorded.
    pub(crate) fn balance(
        &mut self,
        kernel: &Kernel,
        kept: &[f64],
        start: Option<&[f64]>,
        tolerance: f64,
    ) -> Vec<f64> {
        let (means, iterations) = balance(kernel, kept, start, tolerance);
        self.pairs += 1;
        self.max_iterations = self.max_iterations.max(iterations);
        for (i, mean) in means.iter().enumerate() {
            let scale = kept[kernel.node_bin(i)] / mean;
            self.scale_range = (self.scale_range.0.min(scale), self.scale_range.1.max(scale));
        }
        means
    }
}

/// The shared table of `kind` with `shadowing`, computed at first use
/// (serially; after the albedo table it reads).
pub(crate) fn mean_scale_table(kind: NdfKind, shadowing: Shadowing) -> &'static MeanScaleTable {
    MEAN_SCALE_TABLES[model_index(kind, shadowing)]
        .get_or_init(|| MeanScaleTable::compute(kind, shadowing))
}

/// True once `mean_scale_table(kind, shadowing)` has been computed (never computes it).
pub(crate) fn mean_scale_table_is_built(kind: NdfKind, shadowing: Shadowing) -> bool {
    MEAN_SCALE_TABLES[model_index(kind, shadowing)]
        .get()
        .is_some()
}

static MEAN_SCALE_TABLES: [OnceLock<MeanScaleTable>; MODELS] = [const { OnceLock::new() }; MODELS];

/// mu of kernel bin b (uniform in sqrt(mu), every `SUBDIVISIONS`-th a
/// table node).
fn bin_mu(b: usize) -> f32 {
    (b as f32 / (BINS - 1) as f32).powi(2)
}

/// int f'(wi, wo) mu_o dwo of the scaled white lobe s(mu_i) s(mu_o) f(wi,
/// wo) (f of width `alpha_hat`, F = 1) at mu_i = `mu`, by the tables'
/// quadrature with `nodes` (radial, azimuthal) nodes per piece and `scale`
/// evaluated at every quadrature direction: the noise-free truth of the
/// scaled lobe's albedo, for tests (`scale` = 1 gives
/// `energy::albedo_quadrature`).
pub fn scaled_albedo_quadrature(
    kind: NdfKind,
    shadowing: Shadowing,
    alpha_hat: f32,
    mu: f64,
    nodes: (usize, usize),
    scale: impl Fn(f32) -> f32,
) -> f64 {
    if alpha_hat <= 0.0 {
        return f64::from(scale(mu as f32)).powi(2);
    }
    let mut sum = 0.0;
    SplitQuadrature::new(kind, shadowing, alpha_hat, nodes).albedo_with(mu, None, |mu_o, share| {
        sum += share * f64::from(scale(mu_o as f32));
    });
    f64::from(scale(mu as f32)) * sum
}

/// The azimuth-integrated kernel of a white widened lobe (module docs):
/// `k[i][b]` = int f(wi_i, wo) |mu_o| hat_b(wo) dwo for wi_i at row (node) i
/// and the hat functions of the bins. Rows and bins come in `blocks` of
/// `nodes` table nodes each (one for a conductor; a dielectric's two sides,
/// `crate::compensation::dielectric_gain`), a block's bins `subdivisions` per cell of its
/// nodes' coordinate, every `subdivisions`-th on a node.
pub(crate) struct Kernel {
    blocks: usize,
    nodes: usize,
    subdivisions: usize,
    /// Row-major, `rows()` x `bins()`.
    k: Vec<f64>,
    row_sums: Vec<f64>,
    /// The bins from a row's first to its last non-zero entry (a narrow
    /// lobe reaches few).
    row_spans: Vec<std::ops::Range<usize>>,
}

impl Kernel {
    /// A kernel of zeros with `blocks` blocks of `nodes` nodes.
    pub(crate) fn zeros(blocks: usize, nodes: usize, subdivisions: usize) -> Self {
        let bins = blocks * ((nodes - 1) * subdivisions + 1);
        Self {
            blocks,
            nodes,
            subdivisions,
            k: vec![0.0; blocks * nodes * bins],
            row_sums: Vec::new(),
            row_spans: Vec::new(),
        }
    }

    /// The conductor kernel of the lobe of width `alpha` by the tables'
    /// quadrature (rows and bins on the albedo table's mu nodes); for
    /// alpha = 0 the mirror's, which reflects all of mu_i into mu_i.
    pub(crate) fn compute(kind: NdfKind, shadowing: Shadowing, alpha: f32) -> Self {
        let mut kernel = Self::zeros(1, TABLE_MU, SUBDIVISIONS);
        if alpha <= 0.0 {
            for i in 0..TABLE_MU {
                kernel.deposit(i, 0, (i * SUBDIVISIONS) as f64, 1.0);
            }
        } else {
            let rule = SplitQuadrature::new(kind, shadowing, alpha, QUADRATURE);
            for i in 0..TABLE_MU {
                rule.albedo_with(mu_node(i), None, |mu_o, share| {
                    let (b, t) = cell(mu_o as f32, BINS, 1.0);
                    kernel.deposit(i, 0, b as f64 + f64::from(t), share);
                });
            }
        }
        kernel.finish()
    }

    fn rows(&self) -> usize {
        self.blocks * self.nodes
    }

    fn bins_per_block(&self) -> usize {
        (self.nodes - 1) * self.subdivisions + 1
    }

    pub(crate) fn bins(&self) -> usize {
        self.blocks * self.bins_per_block()
    }

    /// Adds `share` to row `i` at bin coordinate `x` (bin b + fraction) of
    /// `block`, split between the two nearest bins.
    pub(crate) fn deposit(&mut self, i: usize, block: usize, x: f64, share: f64) {
        let (bins, per_block) = (self.bins(), self.bins_per_block());
        let b = (x as usize).min(per_block - 2);
        let t = (x - b as f64).clamp(0.0, 1.0);
        let row = &mut self.k[i * bins + block * per_block..][..per_block];
        row[b] += (1.0 - t) * share;
        row[b + 1] += t * share;
    }

    /// Fixes the row sums once every share is deposited.
    pub(crate) fn finish(mut self) -> Self {
        let bins = self.bins();
        self.row_sums = self.k.chunks(bins).map(|row| row.iter().sum()).collect();
        self.row_spans = self
            .k
            .chunks(bins)
            .map(|row| {
                let first = row.iter().position(|&k| k != 0.0).unwrap_or(0);
                let last = row.iter().rposition(|&k| k != 0.0).map_or(0, |b| b + 1);
                first..last.max(first)
            })
            .collect();
        self
    }

    /// `sum_b k[i][b]`: the lobe's albedo at row i.
    pub(crate) fn row_sum(&self, i: usize) -> f64 {
        self.row_sums[i]
    }

    /// `sum_b k[i][b] s_b`.
    fn apply(&self, i: usize, s: &[f64]) -> f64 {
        let span = self.row_spans[i].clone();
        self.k[i * s.len()..][span.clone()]
            .iter()
            .zip(&s[span])
            .map(|(k, s)| k * s)
            .sum()
    }

    /// (row of the node, fraction towards the next) of bin b.
    fn bin_node(&self, b: usize) -> (usize, usize) {
        let per_block = self.bins_per_block();
        let (block, r) = (b / per_block, b % per_block);
        (
            block * self.nodes + r / self.subdivisions,
            r % self.subdivisions,
        )
    }

    /// The bin on row (node) i.
    pub(crate) fn node_bin(&self, i: usize) -> usize {
        let (block, j) = (i / self.nodes, i % self.nodes);
        block * self.bins_per_block() + j * self.subdivisions
    }
}

/// The balancing s(mu) s-bar(mu) = m(mu) at the kernel's rows (nodes), with
/// s = m / s-bar and s-bar(mu_i) = `sum_b K[i][b] s_b` / E_i the kernel's
/// mean of s (module docs), `kept` the ratio m at the kernel's bins. In s it
/// is Knight's damped fixed point s <- sqrt(s target / (K s)) for the
/// targets m E; here for s-bar at the nodes (linear between them within a
/// block), s-bar <- sqrt(s-bar (K s) / E), from s-bar = 1. Rows below
/// `MIN_ROW_SUM` keep s-bar = 1. Starts from `start` (s-bar = 1 if none)
/// and stops when every row's scaled albedo is within `tolerance` of its
/// target. Returns s-bar at the nodes and the iterations taken.
pub(crate) fn balance(
    kernel: &Kernel,
    kept: &[f64],
    start: Option<&[f64]>,
    tolerance: f64,
) -> (Vec<f64>, usize) {
    let rows = kernel.rows();
    let active: Vec<bool> = (0..rows).map(|i| kernel.row_sum(i) > MIN_ROW_SUM).collect();
    let mut mean = start.map_or_else(|| vec![1.0; rows], <[f64]>::to_vec);
    for (mean, _) in mean.iter_mut().zip(&active).filter(|(_, active)| !**active) {
        *mean = 1.0;
    }
    let mut s = vec![0.0; kept.len()];
    for iteration in 0..MAX_ITERATIONS {
        for (b, s) in s.iter_mut().enumerate() {
            let (j, r) = kernel.bin_node(b);
            let at = if r == 0 {
                mean[j]
            } else {
                let t = r as f64 / kernel.subdivisions as f64;
                mean[j] + (mean[j + 1] - mean[j]) * t
            };
            *s = kept[b] / at;
        }
        let ks: Vec<f64> = (0..rows).map(|i| kernel.apply(i, &s)).collect();
        let converged = (0..rows).filter(|&i| active[i]).all(|i| {
            let node = kernel.node_bin(i);
            (s[node] * ks[i] - kept[node] * kernel.row_sum(i)).abs() <= tolerance
        });
        if converged {
            return (mean, iteration);
        }
        for i in (0..rows).filter(|&i| active[i]) {
            mean[i] = (mean[i] * ks[i] / kernel.row_sum(i)).sqrt();
        }
    }
    (mean, MAX_ITERATIONS)
}

#[cfg(test)]
mod tests {
    use super::*;

    const KINDS: [(NdfKind, Shadowing); MODELS] = [
        (NdfKind::Ggx, Shadowing::Smith),
        (NdfKind::Beckmann, Shadowing::Smith),
        (NdfKind::BlinnPhong, Shadowing::Smith),
        (NdfKind::Ggx, Shadowing::VCavity),
        (NdfKind::Beckmann, Shadowing::VCavity),
        (NdfKind::BlinnPhong, Shadowing::VCavity),
    ];

    /// The kernels' rows sum to the albedo tables' entries (the same
    /// quadrature nodes, summed in another order).
    #[test]
    fn kernel_rows_sum_to_the_tabulated_albedo() {
        for (kind, shadowing) in [KINDS[0], KINDS[4]] {
            let table = albedo_table(kind, shadowing);
            for k in [0, 3, 17, 39] {
                let kernel = Kernel::compute(kind, shadowing, alpha_node(k));
                for j in 0..TABLE_MU {
                    let (e, sum) = (f64::from(table.node(k, j)), kernel.row_sum(j));
                    assert!(
                        (sum - e).abs() < 1e-6,
                        "{kind:?}/{shadowing:?} {k} {j}: {sum} vs {e}"
                    );
                }
            }
        }
    }

    /// Every pair of nodes that gains is balanced within `BALANCE_TOLERANCE`
    /// before `MAX_ITERATIONS`.
    #[test]
    fn balancing_converges_for_every_pair() {
        for (kind, shadowing) in KINDS {
            let start = std::time::Instant::now();
            let (_, statistics) = MeanScaleTable::compute_with_statistics(kind, shadowing);
            println!(
                "{kind:?}/{shadowing:?}: {statistics:?} in {:?}",
                start.elapsed()
            );
            assert!(
                statistics.max_iterations < MAX_ITERATIONS,
                "{kind:?}/{shadowing:?}"
            );
        }
    }

    /// With nothing to take away (m = 1) the balancing returns s-bar = 1
    /// at once; with m < 1 everywhere on a mirror (the identity kernel), s
    /// = s-bar = sqrt(m).
    #[test]
    fn balancing_solves_the_trivial_cases() {
        let mirror = Kernel::compute(NdfKind::Ggx, Shadowing::Smith, 0.0);
        let (mean, iterations) = balance(&mirror, &[1.0; BINS], None, BALANCE_TOLERANCE);
        assert_eq!((mean, iterations), (vec![1.0; TABLE_MU], 0));
        let kept = vec![0.81; BINS];
        let (mean, _) = balance(&mirror, &kept, None, BALANCE_TOLERANCE);
        assert!(mean.iter().all(|m| (m - 0.9).abs() < 1e-8), "{mean:?}");
    }
}
