//! Reciprocal scaling of a widened dielectric interface that gains energy:
//! `crate::compensation::gain`'s construction on the two sides of an interface.
//!
//! Where widening alpha to alpha-hat raises the white energy albedo of a
//! side, E_s(mu, alpha-hat) above E_s(mu, alpha) (`crate::compensation::dielectric_energy`;
//! up to +0.058 near grazing, Beckmann and Blinn-Phong, and V-cavity
//! shadowing), no non-negative compensation lobe can take the gain away.
//! The widened lobe f-hat (reflection and transmission) is scaled instead:
//!
//! f'(wi, wo) = s_a(mu_i) s_b(mu_o) f-hat(wi, wo) + f_c(wi, wo),
//!
//! a and b the sides of wi and wo, with s_s > 0 chosen so that the scaled
//! interface's energy albedo (Importance mode, `crate::compensation::dielectric_energy`)
//! is E'_s(mu) = min(E_s(mu, alpha), E_s(mu, alpha-hat)) from each side,
//! and f_c the compensation lobe on the deficit
//! dE_s = max(0, E_s(alpha) - E_s(alpha-hat)), unchanged. Then f' carries
//! E_s(alpha) from both sides. With K_ab(mu_i, mu_o) = |mu_o| int f-hat dphi_o
//! the azimuth-integrated kernel from side a to side b, s solves
//!
//! s_a(mu_i) sum_b int_0^1 K_ab(mu_i, mu_o) s_b(mu_o) dmu_o = E'_a(mu_i).
//!
//! **Reciprocity.** The factor s_a(mu_i) s_b(mu_o) is the same with wi and
//! wo exchanged, so f' keeps the generalized reciprocity of the widened
//! refraction, f(wi, wo) n_i^2 = f(wo, wi) n_o^2 in one transport mode
//! (Veach 1997, eq. 5.14), and Radiance mode's value stays the adjoint of
//! Importance mode's. That reciprocity makes n_a^2 mu_i K_ab(mu_i, mu_o)
//! symmetric under (a, mu_i) <-> (b, mu_o), so the equation above is a
//! symmetric balancing (one diagonal scaling on both sides, with targets
//! n_a^2 mu_i E'_a) as for a conductor, and `crate::compensation::gain::balance` (Knight
//! 2008's damped fixed point, in which the weights n^2 mu cancel) solves it
//! on the two sides at once.
//!
//! **What is tabulated**, as in `crate::compensation::gain`: s = m / s-bar with m =
//! min(1, E_alpha / E_alpha-hat) from the albedo tables at the lobe's own
//! alpha, alpha-hat, eta and mu, and s-bar, the kernel's mean of s, per side.
//! Per critical-cosine node c_i of the albedo tables (the interface's two
//! sides are the table's `RARE` and `DENSE` media at the same c), per pair
//! of alpha nodes that gains (above `MIN_GAIN` at a node of either side),
//! s-bar at the `MuGrid` nodes of both sides; every other pair keeps
//! s-bar = 1, and below the diagonal the table holds the odd continuation
//! 2 - s-bar (`crate::compensation::gain`'s reasons). s-bar is interpolated linearly in c,
//! sqrt(alpha), sqrt(alpha-hat) and the `MuGrid` coordinate of the query's c
//! (kink to kink on the dense side, as the albedo table).
//!
//! **Cost.** A slice per critical-cosine node, computed at first use of an
//! interface that gains between its c nodes (after the albedo table's
//! slice at the same node, which it reads): a kernel per alpha-hat node
//! with a gaining pair, by the albedo table's own quadrature (at most as
//! long as that slice's build), and a balancing per pair. Only the rows of
//! gaining pairs are stored.

use std::sync::OnceLock;

use crate::compensation::dielectric_energy::{
    DENSE, MuGrid, RARE, TABLE_CRITICAL, critical_cell, critical_cosine,
    dielectric_albedo_quadrature_with, dielectric_albedo_table, dielectric_kernel, seen,
    table_mu_nodes,
};
use crate::compensation::energy::{
    MODELS, TABLE_ALPHA, TABLE_ALPHA_MAX, alpha_node, cell, model_index,
};
use crate::compensation::gain::{BalanceStatistics, MIN_GAIN, kept_share};
use crate::compensation::quadrature::lerp;
use crate::ndf::NdfKind;
use crate::shadowing::Shadowing;

/// Bins of the kernel per `MuGrid` cell (`crate::compensation::gain::SUBDIVISIONS`' reason:
/// m has a kink inside a cell where the albedos cross).
const SUBDIVISIONS: usize = 8;

/// The balancing stops when every node's scaled albedo is within this of
/// its target: 1e-3 of the furnace tolerance and a fiftieth of the tables'
/// own quadrature error (5e-5). Not `crate::compensation::gain`'s 1e-9: near the
/// index-matched interface almost everything is transmitted, the kernel is
/// nearly bipartite (side to side), and its one slow mode (the ratio of the
/// two sides' scales, which a bipartite balancing leaves free) settles by
/// a factor of about 0.75 per thousand iterations while moving the albedo
/// by less than 1e-6 (Beckmann/V-cavity at eta 1.001: residual 5.6e-7
/// after 1000 iterations, 3.5e-8 after 10 000).
const BALANCE_TOLERANCE: f64 = 1e-6;

/// s-bar of both sides at the `MuGrid` nodes: `[RARE nodes, DENSE nodes]`.
type Row = Vec<f32>;

/// `index` value of a pair that keeps s-bar = 1.
const UNSCALED: u32 = u32::MAX;

/// s-bar at one critical-cosine node, for every pair of alpha nodes
/// (module docs).
#[derive(Clone, Debug)]
pub(crate) struct MeanScaleSlice {
    /// `index[a * TABLE_ALPHA + k]`: the row of alpha node a widened to
    /// node k in `rows`, or `UNSCALED`.
    index: Vec<u32>,
    rows: Vec<Row>,
    /// Nodes per side in a row (`table_mu_nodes`).
    nodes: usize,
}

impl MeanScaleSlice {
    /// The slice of critical-cosine node `i`, with its balancings' statistics.
    pub(crate) fn compute(
        kind: NdfKind,
        shadowing: Shadowing,
        i: usize,
    ) -> (Self, BalanceStatistics) {
        let albedo = dielectric_albedo_table(kind, shadowing);
        let nodes = table_mu_nodes(shadowing);
        let mut slice = Self {
            index: vec![UNSCALED; TABLE_ALPHA * TABLE_ALPHA],
            rows: Vec::new(),
            nodes,
        };
        let mut statistics = BalanceStatistics::default();
        let gains = |a: usize, k: usize| {
            [RARE, DENSE].into_iter().any(|medium| {
                (0..nodes)
                    .any(|j| albedo.node(medium, i, k, j) - albedo.node(medium, i, a, j) > MIN_GAIN)
            })
        };
        for k in 1..TABLE_ALPHA {
            let gaining: Vec<usize> = (0..k).filter(|&a| gains(a, k)).collect();
            if gaining.is_empty() {
                continue;
            }
            let kernel = dielectric_kernel(kind, shadowing, i, alpha_node(k), SUBDIVISIONS);
            // (medium, MuGrid cell, fraction) of every bin.
            let per_block = (nodes - 1) * SUBDIVISIONS + 1;
            let bins: Vec<(usize, (usize, f64))> = (0..kernel.bins())
                .map(|b| {
                    let (medium, x) = (b / per_block, b % per_block);
                    let (j, r) = (x / SUBDIVISIONS, x % SUBDIVISIONS);
                    let t = r as f64 / SUBDIVISIONS as f64;
                    let at = if j == nodes - 1 { (j - 1, 1.0) } else { (j, t) };
                    (medium, at)
                })
                .collect();
            let e_hat: Vec<f32> = bins
                .iter()
                .map(|&(medium, at)| albedo.node_albedo(medium, i, k, at) as f32)
                .collect();
            // From the widest original down, each balancing starting from
            // its neighbour's solution (s-bar moves little between them).
            let mut previous: Option<Vec<f64>> = None;
            for a in gaining.into_iter().rev() {
                // m at the kernel's bins, as `DielectricCompensation::scale` finds it.
                let kept: Vec<f64> = bins
                    .iter()
                    .zip(&e_hat)
                    .map(|(&(medium, at), &e_hat)| {
                        let e = albedo.node_albedo(medium, i, a, at) as f32;
                        f64::from(kept_share(e, e_hat))
                    })
                    .collect();
                let means =
                    statistics.balance(&kernel, &kept, previous.as_deref(), BALANCE_TOLERANCE);
                slice.push(a, k, means.iter().map(|&mean| mean as f32).collect());
                previous = Some(means);
            }
        }
        // The odd continuation below the diagonal (`crate::compensation::gain`).
        for k in 0..TABLE_ALPHA - 1 {
            if let Some(upper) = slice.row(k, k + 1) {
                let lower = upper.iter().map(|mean| 2.0 - mean).collect();
                slice.push(k + 1, k, lower);
            }
        }
        (slice, statistics)
    }

    fn push(&mut self, a: usize, k: usize, row: Row) {
        self.index[a * TABLE_ALPHA + k] = self.rows.len() as u32;
        self.rows.push(row);
    }

    fn row(&self, a: usize, k: usize) -> Option<&Row> {
        match self.index[a * TABLE_ALPHA + k] {
            UNSCALED => None,
            n => Some(&self.rows[n as usize]),
        }
    }

    /// s-bar of `medium` at `MuGrid` cell j, fraction t: linear in sqrt(alpha),
    /// sqrt(alpha-hat) and t.
    fn mean_scale(&self, medium: usize, alpha: f32, alpha_hat: f32, (j, t): (usize, f32)) -> f32 {
        let (a, ta) = cell(alpha, TABLE_ALPHA, TABLE_ALPHA_MAX);
        let (k, tk) = cell(alpha_hat, TABLE_ALPHA, TABLE_ALPHA_MAX);
        let at = |a: usize, k: usize| {
            self.row(a, k).map_or(1.0, |row| {
                let n = medium * self.nodes + j;
                lerp(row[n], row[n + 1], t)
            })
        };
        lerp(
            lerp(at(a, k), at(a, k + 1), tk),
            lerp(at(a + 1, k), at(a + 1, k + 1), tk),
            ta,
        )
    }
}

/// The shared slice of critical-cosine node `i` of `kind` with `shadowing`,
/// computed at first use.
pub(crate) fn mean_scale_slice(
    kind: NdfKind,
    shadowing: Shadowing,
    i: usize,
) -> &'static MeanScaleSlice {
    SLICES[model_index(kind, shadowing)][i]
        .get_or_init(|| MeanScaleSlice::compute(kind, shadowing, i).0)
}

/// True once `mean_scale_slice(kind, shadowing, i)` has been computed (never computes it).
pub(crate) fn mean_scale_slice_is_built(kind: NdfKind, shadowing: Shadowing, i: usize) -> bool {
    SLICES[model_index(kind, shadowing)][i].get().is_some()
}

static SLICES: [[OnceLock<MeanScaleSlice>; TABLE_CRITICAL]; MODELS] =
    [const { [const { OnceLock::new() }; TABLE_CRITICAL] }; MODELS];

/// The slices an interface of index ratio `eta` reads, from either side
/// (those of the critical-cosine cell of its c): for callers that compute
/// them (`mean_scale_slice`) before any timed work.
pub(crate) fn slices_read(eta: f32) -> [usize; 2] {
    let (i, _) = critical_cell(critical_cosine(eta).1);
    [i, i + 1]
}

/// s-bar(mu) of an interface of width `alpha` widened to `alpha_hat`,
/// queried from the side that sees the index ratio `eta`: linear in c
/// between the slices of its cell (module docs).
pub(crate) fn dielectric_mean_scale(
    kind: NdfKind,
    shadowing: Shadowing,
    alpha: f32,
    alpha_hat: f32,
    eta: f32,
    mu: f32,
) -> f32 {
    let (medium, c) = critical_cosine(eta);
    let at = MuGrid::of(shadowing, medium, c).cell(mu);
    let (i, r) = critical_cell(c);
    let mean = |i| mean_scale_slice(kind, shadowing, i).mean_scale(medium, alpha, alpha_hat, at);
    lerp(mean(i), mean(i + 1), r)
}

/// The energy albedo of the scaled white interface s_a(mu_i) s_b(mu_o)
/// f-hat(wi, wo) (f-hat of width `alpha_hat`, index ratio `eta`) queried
/// from `side` at mu_i = `mu`, by the tables' quadrature rules with `nodes`
/// (`dielectric_albedo_quadrature`) and `scale(side, mu)` evaluated at every
/// quadrature direction: the noise-free truth of the scaled lobe's albedo,
/// for tests.
#[allow(clippy::too_many_arguments)]
pub fn scaled_dielectric_albedo_quadrature(
    kind: NdfKind,
    shadowing: Shadowing,
    alpha_hat: f32,
    eta: f32,
    side: usize,
    mu: f64,
    nodes: (usize, usize),
    scale: impl Fn(usize, f32) -> f32,
) -> f64 {
    let mut sum = 0.0;
    let seen = f64::from(seen(eta, side));
    dielectric_albedo_quadrature_with(
        kind,
        shadowing,
        alpha_hat,
        mu,
        seen,
        nodes,
        |cos_o, share| {
            let to = if cos_o > 0.0 { side } else { 1 - side };
            sum += share * f64::from(scale(to, cos_o.abs() as f32));
        },
    );
    f64::from(scale(side, mu as f32)) * sum
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every pair of alpha nodes that gains is balanced before the
    /// iteration limit, for the model that gains least (GGX/Smith) and most
    /// (Beckmann/V-cavity), near glass's critical cosine (c node 49: eta
    /// 1.40) and next to the index-matched interface (c node 3: eta
    /// 1.0003); s stays within a few percent of 1 (measured 0.937 to
    /// 1.005). Node 3's nearly bipartite kernel balances slowest (1637
    /// iterations for Beckmann/V-cavity).
    #[test]
    fn balancing_converges_for_every_pair() {
        for (kind, shadowing) in [
            (NdfKind::Ggx, Shadowing::Smith),
            (NdfKind::Beckmann, Shadowing::VCavity),
        ] {
            for i in [3, 49] {
                let (slice, statistics) = MeanScaleSlice::compute(kind, shadowing, i);
                println!("{kind:?}/{shadowing:?} c node {i}: {statistics:?}");
                assert!(statistics.pairs > 0, "{kind:?}/{shadowing:?} {i}: no gain");
                assert!(statistics.max_iterations < crate::compensation::gain::MAX_ITERATIONS);
                let (low, high) = statistics.scale_range;
                assert!(
                    low > 0.9 && high < 1.02,
                    "{kind:?}/{shadowing:?} {i}: {low} {high}"
                );
                // Each gaining pair has a row, and its odd continuation.
                assert!(slice.rows.len() > statistics.pairs);
            }
        }
    }

    /// The kernels' rows sum to the albedo table's nodes (the same
    /// quadrature, summed in another order), from both sides.
    #[test]
    fn kernel_rows_sum_to_the_tabulated_albedo() {
        let (kind, shadowing) = (NdfKind::Beckmann, Shadowing::VCavity);
        let table = dielectric_albedo_table(kind, shadowing);
        for (i, k) in [(3, 9), (14, 25)] {
            let kernel = dielectric_kernel(kind, shadowing, i, alpha_node(k), SUBDIVISIONS);
            for medium in [RARE, DENSE] {
                let nodes = table_mu_nodes(shadowing);
                for j in 0..nodes {
                    let e = f64::from(table.node(medium, i, k, j));
                    let sum = kernel.row_sum(medium * nodes + j);
                    assert!((sum - e).abs() < 1e-6, "{i} {k} {medium} {j}: {sum} vs {e}");
                }
            }
        }
    }
}
