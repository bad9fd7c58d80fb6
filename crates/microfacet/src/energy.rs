//! Energy compensation of regularized lobes (ARCHITECTURE.md, "Energy-preserving
//! regularization"), after Kulla & Conty, "Revisiting Physically Based
//! Shading at Imageworks" (SIGGRAPH 2017 course), §"Energy compensation".
//!
//! A single-scattering Smith or V-cavity lobe loses energy as alpha grows
//! (a white GGX conductor keeps 0.988 at alpha 0.1, 0.688 at 0.5, normal
//! incidence). Regularization raises alpha to alpha-hat and so darkens the
//! image. Kulla & Conty add a lobe 1 - E(mu); here the same construction is
//! applied to the *difference* between the original and the regularized lobe:
//!
//! dE(mu) = max(0, E_alpha(mu) - E_alpha-hat(mu)),
//! f_c(wi, wo) = dE(mu_i) dE(mu_o) / (pi dE_avg), dE_avg = 2 int_0^1 dE(mu) mu dmu,
//!
//! with E_a(mu) the directional albedo of the lobe at width a and Fresnel 1.
//! f_c is symmetric (reciprocal), and int f_c(wi, wo) mu_o dwo
//! = dE(mu_i) 2 pi int dE(mu) mu dmu / (pi dE_avg) = dE(mu_i) exactly, so the
//! regularized lobe plus f_c reflects what the original did, E_alpha(mu_i)
//! (white furnace), up to table error. As alpha-hat -> alpha, dE -> 0 and the
//! term vanishes: the regularization stays consistent.
//!
//! E_a(mu) is tabulated per NDF and shadowing model (`AlbedoTable`), computed
//! serially at first use by quadrature over microfacet normals
//! (`SplitQuadrature`, split where the integrand bends: within 5e-5 of 64 x
//! 64 nodes). 64 nodes uniform in s = sqrt(mu) by 40 uniform in sqrt(alpha)
//! (0.05-1.1 s per table). Rows are a Catmull-Rom cubic in sqrt(alpha),
//! linear in s between nodes: dE(mu) is piecewise linear in s, and dE_avg
//! is integrated in closed form on that same function, so the furnace
//! identity holds exactly for the interpolated dE (5e-8 by a midpoint rule).
//! Compensated against the original's albedo, without noise
//! (`tests/energy_compensation.rs`, originals 0 to 0.3, alpha-hat to 1):
//! within 7.7e-4 for mu >= 0.04; a table cell is finer than a narrow lobe's
//! bend only above that (2.5e-3 at alpha 0.002, mu 0.012).
//!
//! **Colour.** f_c is scaled by the lobe's Fresnel average
//! F_avg = 2 int F mu dmu (Kulla & Conty's choice; `Fresnel::average`,
//! `Coated::specular_fresnel_average`), so for F = 1 the lobe reflects
//! exactly what the original did. A coated lobe compensates its coat
//! (specular) lobe inside the specular branch of its coin.
//!
//! **Sampling.** The compensation lobe is chosen with probability
//! P_c = dE(mu_i) / (E_alpha-hat(mu_i) + dE(mu_i)) and sampled by cosine;
//! `pdf` is the mixture, and so is p-hat at a regularized vertex
//! ((1 - P_c) p-hat_lobe + P_c mu_o/pi): the paper's eq. 13 ratio is
//! undefined for a lobe the original lacks, and SPEC §6 only needs every
//! technique to use the same pdf.
//!
//! **Cost** per regularized vertex: 2 x 64 cubic table lookups (4 rows each)
//! and a Fresnel average (8 Fresnel evaluations for complex-index
//! conductors); 4 cubic lookups per evaluation.
//!
//! **Limits.** Where the wider lobe reflects more than the original
//! (V-cavity, and Beckmann/Blinn-Phong near grazing: up to +0.049) a
//! non-negative lobe cannot remove the gain, and nothing is added.

use std::f32::consts::FRAC_1_PI;
use std::sync::OnceLock;

use glam::Vec3;

use crate::model::MicrofacetModel;
use crate::ndf::NdfKind;
use crate::quadrature::SplitQuadrature;
use crate::shadowing::Shadowing;

/// Table nodes in mu = cos theta, uniform in sqrt(mu) on [0, 1]: the albedo
/// changes fastest near grazing (mu of the order of alpha), where uniform
/// nodes in mu missed it by 9e-3, and 40 nodes in sqrt(mu) by 3.4e-3 (at mu
/// 0.03, alpha 0.02; 64 nodes: 1.1e-3).
pub const TABLE_MU: usize = 64;
/// Table nodes in alpha, uniform in sqrt(alpha) on [0, `TABLE_ALPHA_MAX`]
/// (small widths change the albedo near grazing fastest, as above);
/// interpolated by a cubic, which took the largest error at mu >= 0.1 from
/// 2.1e-3 (linear) to 2.4e-4.
pub const TABLE_ALPHA: usize = 40;
/// Largest tabulated alpha: regularization never raises alpha beyond 1
/// (SPEC §5's alpha_max), and a lobe already wider is left unchanged.
pub const TABLE_ALPHA_MAX: f32 = 1.0;
/// The mu = 0 column is evaluated at this cosine: exactly grazing
/// directions have no reflection to integrate (every lobe returns 0 there).
pub(crate) const GRAZING_MU: f64 = 1e-3;
/// (radial, azimuthal) Gauss-Legendre nodes per piece of the tables'
/// quadrature (`SplitQuadrature`): within 5e-5 of 64 x 64 for every NDF
/// and shadowing model (`tests/energy_compensation.rs`, `REFERENCE`).
const QUADRATURE: (usize, usize) = (16, 16);
/// Below this dE_avg the compensation carries nothing a renderer could see
/// (1e-6 of the energy) and is left out, so dE(mu)/dE_avg never divides by
/// a rounding-sized number.
pub(crate) const MIN_DEFICIT_AVERAGE: f32 = 1e-6;

/// Directional albedo E(mu, alpha) of a white (F = 1) Torrance-Sparrow lobe
/// of one NDF and shadowing model, on a `TABLE_ALPHA` x `TABLE_MU` grid.
#[derive(Clone, Debug)]
pub struct AlbedoTable {
    /// Row-major by alpha: `e[k * TABLE_MU + j]` = E(mu_j, alpha_k).
    e: Vec<f32>,
}

impl AlbedoTable {
    /// Computes the table by quadrature (see `albedo_quadrature`).
    pub fn compute(kind: NdfKind, shadowing: Shadowing) -> Self {
        let mut e = Vec::with_capacity(TABLE_ALPHA * TABLE_MU);
        for k in 0..TABLE_ALPHA {
            let alpha = alpha_node(k);
            // alpha = 0: the mirror, E = 1.
            let rule =
                (alpha > 0.0).then(|| SplitQuadrature::new(kind, shadowing, alpha, QUADRATURE));
            for j in 0..TABLE_MU {
                e.push(
                    rule.as_ref()
                        .map_or(1.0, |rule| rule.albedo(mu_node(j), None))
                        as f32,
                );
            }
        }
        Self { e }
    }

    /// E(mu, alpha), bilinear in the table (alpha clamped to the table).
    pub fn albedo(&self, mu: f32, alpha: f32) -> f32 {
        let (j, t) = cell(mu, TABLE_MU, 1.0);
        let row = self.row(alpha);
        lerp(row(j), row(j + 1), t)
    }

    /// mu -> E(mu_j, alpha) at node j, a Catmull-Rom cubic in sqrt(alpha)
    /// through the four nearest rows (`catmull_rom_weights`).
    fn row(&self, alpha: f32) -> impl Fn(usize) -> f32 + '_ {
        let (k, s) = cell(alpha, TABLE_ALPHA, TABLE_ALPHA_MAX);
        let weights = catmull_rom_weights(k, s, TABLE_ALPHA);
        move |j| {
            weights
                .iter()
                .map(|&(r, w)| w * self.e[r * TABLE_MU + j])
                .sum()
        }
    }

    /// The node values of dE(mu) = max(0, E(mu, alpha) - E(mu, alpha_hat))
    /// before clamping, at every mu node.
    fn deficit_nodes(&self, alpha: f32, alpha_hat: f32) -> [f32; TABLE_MU] {
        let (original, regularized) = (self.row(alpha), self.row(alpha_hat));
        std::array::from_fn(|j| original(j) - regularized(j))
    }
}

/// The shared table of `kind` with `shadowing`, computed at first use.
pub fn albedo_table(kind: NdfKind, shadowing: Shadowing) -> &'static AlbedoTable {
    static TABLES: [OnceLock<AlbedoTable>; MODELS] = [const { OnceLock::new() }; MODELS];
    TABLES[model_index(kind, shadowing)].get_or_init(|| AlbedoTable::compute(kind, shadowing))
}

/// NDF x shadowing combinations, one table each.
pub(crate) const MODELS: usize = 6;

/// The slot of `kind` with `shadowing` among the `MODELS` tables.
pub(crate) fn model_index(kind: NdfKind, shadowing: Shadowing) -> usize {
    let ndf = match kind {
        NdfKind::Ggx => 0,
        NdfKind::Beckmann => 1,
        NdfKind::BlinnPhong => 2,
    };
    ndf + match shadowing {
        Shadowing::Smith => 0,
        Shadowing::VCavity => 3,
    }
}

/// mu of table column j, s_j^2 with s_j uniform (the first one evaluated
/// at `GRAZING_MU`).
pub(crate) fn mu_node(j: usize) -> f64 {
    (j as f64 / (TABLE_MU - 1) as f64).powi(2).max(GRAZING_MU)
}

/// alpha of table row k, s_k^2 with s_k uniform.
pub(crate) fn alpha_node(k: usize) -> f32 {
    (k as f32 / (TABLE_ALPHA - 1) as f32).powi(2) * TABLE_ALPHA_MAX
}

/// (cell index, fraction in the cell) of `x` on `n` nodes uniform in
/// sqrt(x / max) over [0, max]: the table is linear in sqrt(x) per cell.
pub(crate) fn cell(x: f32, n: usize, max: f32) -> (usize, f32) {
    let s = (x / max).clamp(0.0, 1.0).sqrt() * (n - 1) as f32;
    let i = (s as usize).min(n - 2);
    (i, s - i as f32)
}

/// (node, weight) of the cubic Catmull-Rom spline (Catmull & Rom 1974)
/// at fraction `t` of cell `k` of `n` nodes: the four nodes k - 1 ..= k + 2.
/// It passes through the nodes and is exact for quadratics; beyond either
/// end of the table the missing node is the quadratic extrapolation of the
/// three inside (y_-1 = 3 y_0 - 3 y_1 + y_2), folded into their weights,
/// so the last cells keep that order.
pub(crate) fn catmull_rom_weights(k: usize, t: f32, n: usize) -> [(usize, f32); 4] {
    let (t2, t3) = (t * t, t * t * t);
    let w = [
        0.5 * (-t3 + 2.0 * t2 - t),
        0.5 * (3.0 * t3 - 5.0 * t2 + 2.0),
        0.5 * (-3.0 * t3 + 4.0 * t2 + t),
        0.5 * (t3 - t2),
    ];
    if k == 0 {
        [
            (0, w[1] + 3.0 * w[0]),
            (1, w[2] - 3.0 * w[0]),
            (2, w[3] + w[0]),
            (0, 0.0),
        ]
    } else if k + 2 == n {
        [
            (k - 1, w[0] + w[3]),
            (k, w[1] - 3.0 * w[3]),
            (k + 1, w[2] + 3.0 * w[3]),
            (k, 0.0),
        ]
    } else {
        [(k - 1, w[0]), (k, w[1]), (k + 1, w[2]), (k + 2, w[3])]
    }
}

pub(crate) fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// E(mu, alpha) = int f(wi, wo) <wo,n> dwo of a white (F = 1) lobe by the
/// tables' quadrature rule with `nodes` (radial, azimuthal) Gauss-Legendre
/// nodes per piece (the tables use `QUADRATURE`); 1 for alpha = 0, the
/// mirror. Over microfacet normals drawn from D(h)<h,n>: with wo =
/// reflect(wi, h) and dwo = 4 <wo,h> dh (SPEC §3), f <wo,n> dwo = D G
/// <wi,h>/<wi,n> dh, so E = int G(wi, wo) <wi,h>/(<wi,n><h,n>) D(h)<h,n> dh,
/// split where wo reaches the horizon and where <wi,h> = 0
/// (`SplitQuadrature`). For tests, with finer rules.
pub fn albedo_quadrature(
    kind: NdfKind,
    shadowing: Shadowing,
    alpha: f32,
    mu: f64,
    nodes: (usize, usize),
) -> f64 {
    if alpha <= 0.0 {
        return 1.0;
    }
    SplitQuadrature::new(kind, shadowing, alpha, nodes).albedo(mu, None)
}

/// The compensation lobe of a regularized model: what it needs beyond the
/// model itself (the original alpha, dE_avg, the colour).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Compensation {
    /// The original (unregularized) alpha.
    pub alpha: f32,
    /// dE_avg = 2 int_0^1 dE(mu) mu dmu.
    pub deficit_average: f32,
    /// The colour of the compensated energy: the lobe's Fresnel average
    /// F_avg = 2 int F(mu) mu dmu (Kulla & Conty's choice for their
    /// multiple-scattering colour; direction-independent, so f_c stays
    /// reciprocal); white until the lobe sets it.
    pub tint: Vec3,
}

impl Compensation {
    /// The compensation of `model` (at alpha-hat) for a lobe of width
    /// `alpha`, or `None` when it would carry nothing (alpha-hat <= alpha,
    /// or dE_avg below `MIN_DEFICIT_AVERAGE`).
    pub fn new(model: &MicrofacetModel, alpha: f32) -> Option<Self> {
        let alpha_hat = model.alpha();
        if !(alpha_hat > alpha) || model.is_smooth() {
            return None;
        }
        let table = albedo_table(model.ndf.kind(), model.shadowing);
        let nodes = table.deficit_nodes(alpha, alpha_hat);
        let average = positive_part_moment(&nodes) as f32;
        (average > MIN_DEFICIT_AVERAGE).then_some(Self {
            alpha,
            deficit_average: average,
            tint: Vec3::ONE,
        })
    }

    /// dE(mu) of the regularized `model` (its alpha is alpha-hat).
    pub fn deficit(&self, model: &MicrofacetModel, mu: f32) -> f32 {
        let table = albedo_table(model.ndf.kind(), model.shadowing);
        (table.albedo(mu, self.alpha) - table.albedo(mu, model.alpha())).max(0.0)
    }

    /// E_alpha-hat(mu) (white) of the regularized `model`.
    pub fn regularized_albedo(&self, model: &MicrofacetModel, mu: f32) -> f32 {
        albedo_table(model.ndf.kind(), model.shadowing).albedo(mu, model.alpha())
    }

    /// f_c(wi, wo) = dE(mu_i) dE(mu_o) / (pi dE_avg), untinted.
    pub fn value(&self, model: &MicrofacetModel, mu_i: f32, mu_o: f32) -> f32 {
        self.deficit(model, mu_i) * self.deficit(model, mu_o) * FRAC_1_PI / self.deficit_average
    }

    /// The probability of sampling the compensation lobe for a query at
    /// `mu_i`: its share dE / (E_alpha-hat + dE) of the white albedo.
    pub fn probability(&self, model: &MicrofacetModel, mu_i: f32) -> f32 {
        let deficit = self.deficit(model, mu_i);
        let total = deficit + self.regularized_albedo(model, mu_i);
        if total > 0.0 {
            (deficit / total).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }
}

/// 2 int_0^1 max(0, y) mu dmu for y linear in s = sqrt(mu) between the
/// values `nodes` at s = 0, 1/(n-1), ..., 1: with mu = s^2 the moment is
/// 4 int_0^1 max(0, y(s)) s^3 ds, a polynomial per cell, integrated in
/// closed form with the sign change inside a cell located exactly.
pub(crate) fn positive_part_moment(nodes: &[f32; TABLE_MU]) -> f64 {
    let h = 1.0 / (TABLE_MU - 1) as f64;
    let mut sum = 0.0;
    for j in 0..TABLE_MU - 1 {
        let (a, y0, y1) = (j as f64 * h, f64::from(nodes[j]), f64::from(nodes[j + 1]));
        // Sub-interval [s0, s1] of the cell where y > 0.
        let root = a + h * y0 / (y0 - y1);
        let (s0, s1) = match (y0 > 0.0, y1 > 0.0) {
            (false, false) => continue,
            (true, true) => (a, a + h),
            (true, false) => (a, root),
            (false, true) => (root, a + h),
        };
        // y(s) = p + q s; int (p + q s) s^3 ds = p s^4/4 + q s^5/5.
        let q = (y1 - y0) / h;
        let p = y0 - q * a;
        let antiderivative = |s: f64| p * s.powi(4) / 4.0 + q * s.powi(5) / 5.0;
        sum += antiderivative(s1) - antiderivative(s0);
    }
    4.0 * sum
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn positive_part_moment_matches_the_integral() {
        // y = 1 everywhere: 2 int mu dmu = 1.
        assert!((positive_part_moment(&[1.0; TABLE_MU]) - 1.0).abs() < 1e-12);
        // y = s - 1/2 (node-exact in s = sqrt(mu)):
        // 4 int_{1/2}^1 (s - 1/2) s^3 ds = 4 (31/160 - 15/128) = 0.30625.
        let nodes = std::array::from_fn(|j| j as f32 / (TABLE_MU - 1) as f32 - 0.5);
        let m = positive_part_moment(&nodes);
        assert!((m - 0.30625).abs() < 1e-6, "{m}");
    }
}
