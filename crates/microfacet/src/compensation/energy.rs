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
//! (0.05-1.1 s per table), interpolated by Catmull-Rom cubics in both
//! (`catmull_rom_cubic`, `alpha_weights`: linear in alpha^2 below the first
//! alpha node). dE(mu) is then a cubic in s per cell, and dE_avg its exact
//! moment (`positive_part_integral`), so the furnace identity holds for the
//! interpolated dE (4e-8 by a midpoint rule). The table against quadrature: within 1.7e-4 for mu >= 0.1, 8.1e-4
//! for mu >= 0.04; a cell is finer than a narrow lobe's bend only above
//! that (2.7e-3 at alpha 0.002, mu 0.012). Compensated against the
//! original's albedo, without noise (`tests/microfacet/energy_compensation.rs`,
//! originals 0 to 0.3, alpha-hat to 1): within 4.2e-4 for mu >= 0.04,
//! where widening gains energy too (below: "Gains").
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
//! **Gains.** Where the wider lobe reflects more than the original
//! (V-cavity, Beckmann and Blinn-Phong; GGX/Smith below mu = 0.1: up to
//! +0.061 of white albedo) a non-negative lobe cannot remove the gain.
//! There the widened lobe is scaled reciprocally instead
//! (`crate::compensation::gain`): f' = s(mu_i) s(mu_o) f-hat + f_c, s the symmetric
//! Sinkhorn-Knopp balancing of the azimuth-integrated kernel of f-hat that
//! makes it reflect min(E_alpha, E_alpha-hat)(mu), with f_c on dE as
//! above, so that f' reflects E_alpha at every mu. Only a lobe whose pair
//! (alpha, alpha-hat) gains at some table node (`Compensation::scaled`) is
//! scaled; every other one is unchanged bit for bit. Such a lobe may carry
//! the scaling alone: `Compensation` then has no f_c (dE_avg = 0,
//! `Compensation::has_lobe`). Compensated and scaled, the albedo is within
//! 4.2e-4 of the original's for mu >= 0.04 (`crate::compensation::gain`, "Accuracy").
//!
//! **Cost** per regularized vertex: 2 x 64 cubic table lookups (4 rows each)
//! and a Fresnel average (8 Fresnel evaluations for complex-index
//! conductors); 4 cubic lookups per evaluation and 2 per sampling
//! probability, and two lookups of the scaling's table for a scaled lobe
//! (`crate::compensation::gain`, "Cost").

use std::sync::OnceLock;

use crate::compensation::quadrature::{GRAZING_MU, SplitQuadrature};
use crate::gauss::gauss_legendre_4;
use crate::ndf::NdfKind;
use crate::shadowing::Shadowing;

/// Table nodes in mu = cos theta, uniform in sqrt(mu) on [0, 1]: the albedo
/// changes fastest near grazing (mu of the order of alpha), where uniform
/// nodes in mu missed it by 9e-3, and 40 nodes linear in sqrt(mu) by
/// 3.4e-3 (at mu 0.03, alpha 0.02; 64 nodes: 1.1e-3; cubic: 8.1e-4 at mu
/// 0.043).
pub(crate) const TABLE_MU: usize = 64;
/// Table nodes in alpha, uniform in sqrt(alpha) on [0, `TABLE_ALPHA_MAX`]
/// (small widths change the albedo near grazing fastest, as above);
/// interpolated by a cubic, which took the largest error at mu >= 0.1 from
/// 2.1e-3 (linear) to 2.4e-4.
pub(crate) const TABLE_ALPHA: usize = 40;
/// Largest tabulated alpha: regularization never raises alpha beyond 1
/// (SPEC §5's alpha_max), and a lobe already wider is left unchanged.
pub(crate) const TABLE_ALPHA_MAX: f32 = 1.0;
/// (radial, azimuthal) Gauss-Legendre nodes per piece of the tables'
/// quadrature (`SplitQuadrature`): within 5e-5 of 64 x 64 for every NDF
/// and shadowing model (`tests/microfacet/energy_compensation.rs`, `REFERENCE`).
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
    pub(crate) fn compute(kind: NdfKind, shadowing: Shadowing) -> Self {
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

    /// E(mu, alpha), bicubic in the table (Catmull-Rom in sqrt(mu) and
    /// sqrt(alpha); alpha clamped to the table).
    pub fn albedo(&self, mu: f32, alpha: f32) -> f32 {
        let (j, t) = cell(mu, TABLE_MU, 1.0);
        let row = self.row(alpha);
        let cubic = catmull_rom_cubic(|i| f64::from(row(i)), j, (0, TABLE_MU - 1));
        cubic_at(cubic, f64::from(t)) as f32
    }

    /// E at alpha node k and mu node j, as computed.
    pub(crate) fn node(&self, k: usize, j: usize) -> f32 {
        self.e[k * TABLE_MU + j]
    }

    /// E(mu) at alpha node k: the row's Catmull-Rom cubic in sqrt(mu), as
    /// `albedo` interpolates it.
    pub(crate) fn node_albedo(&self, k: usize, mu: f32) -> f64 {
        let (j, t) = cell(mu, TABLE_MU, 1.0);
        let cubic = catmull_rom_cubic(|i| f64::from(self.node(k, i)), j, (0, TABLE_MU - 1));
        cubic_at(cubic, f64::from(t))
    }

    /// mu -> E(mu_j, alpha) at node j, a Catmull-Rom cubic in sqrt(alpha)
    /// through the four nearest rows (`alpha_weights`).
    fn row(&self, alpha: f32) -> impl Fn(usize) -> f32 + '_ {
        let weights = alpha_weights(alpha);
        move |j| {
            weights
                .iter()
                .map(|&(r, w)| w * self.e[r * TABLE_MU + j])
                .sum()
        }
    }

    /// The node values of dE(mu) = max(0, E(mu, alpha) - E(mu, alpha_hat))
    /// before clamping, at every mu node: whole rows of the table weighted
    /// and summed (contiguous, so the compiler vectorizes it), as `row`
    /// weights them node by node.
    pub(crate) fn deficit_nodes(&self, alpha: f32, alpha_hat: f32) -> [f32; TABLE_MU] {
        let mut nodes = [0.0; TABLE_MU];
        for (alpha, sign) in [(alpha, 1.0), (alpha_hat, -1.0)] {
            for (r, w) in alpha_weights(alpha) {
                let row = &self.e[r * TABLE_MU..(r + 1) * TABLE_MU];
                for (node, e) in nodes.iter_mut().zip(row) {
                    *node += sign * w * e;
                }
            }
        }
        nodes
    }
}

/// The shared table of `kind` with `shadowing`, computed at first use.
///
/// First use: builds the energy tables it reads, once per process
/// (`crate::compensation::tables`: seconds in a release build, 10-20x
/// longer unoptimised); [`crate::prepare_tables`] builds them ahead.
pub fn albedo_table(kind: NdfKind, shadowing: Shadowing) -> &'static AlbedoTable {
    ALBEDO_TABLES[model_index(kind, shadowing)]
        .get_or_init(|| AlbedoTable::compute(kind, shadowing))
}

/// True once `albedo_table(kind, shadowing)` has been computed (never computes it).
pub(crate) fn albedo_table_is_built(kind: NdfKind, shadowing: Shadowing) -> bool {
    ALBEDO_TABLES[model_index(kind, shadowing)].get().is_some()
}

static ALBEDO_TABLES: [OnceLock<AlbedoTable>; MODELS] = [const { OnceLock::new() }; MODELS];

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
/// sqrt(x / max) over [0, max]: the tables' cells are uniform in sqrt(x).
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

/// (row, weight) of the albedo tables' interpolation in alpha: the
/// Catmull-Rom spline in sqrt(alpha) (`cell`, `catmull_rom_weights`),
/// except between the smooth lobe (node 0, alpha = 0) and node 1, where E
/// is linear in alpha^2. Shadowing takes energy as alpha^2 as alpha -> 0
/// (Smith's Lambda, the NDF's tail), which near grazing is all of E's
/// change up to node 1: there the spline, through nodes that fall as
/// sqrt(alpha)^4 and an extrapolated node beyond alpha = 0, overshot 1 by
/// up to 4.8e-3 (GGX/Smith, mu 0.005) and was off the quadrature by 5e-3;
/// linear in alpha^2 it is within 1e-4 and never above the nodes.
pub(crate) fn alpha_weights(alpha: f32) -> [(usize, f32); 4] {
    let (k, s) = cell(alpha, TABLE_ALPHA, TABLE_ALPHA_MAX);
    if k > 0 {
        return catmull_rom_weights(k, s, TABLE_ALPHA);
    }
    // (alpha / alpha_1)^2 with alpha_1 the first node: s^4.
    let w = (s * s) * (s * s);
    [(0, 1.0 - w), (1, w), (0, 0.0), (0, 0.0)]
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

/// 2 int_0^1 max(0, y) mu dmu for y the Catmull-Rom cubic in s = sqrt(mu)
/// through the values `nodes` at s = 0, 1/(n-1), ..., 1 (as `albedo`
/// interpolates): with mu = s^2 the measure 2 mu dmu is 4 s^3 ds, a cubic
/// in each cell's fraction (`spline_positive_moment`).
pub(crate) fn positive_part_moment(nodes: &[f32; TABLE_MU]) -> f64 {
    static WEIGHTS: OnceLock<Vec<f64>> = OnceLock::new();
    let segment = |_| (0, TABLE_MU - 1);
    let h = 1.0 / (TABLE_MU - 1) as f64;
    let measure = |j: usize, t: f64| 4.0 * ((j as f64 + t) * h).powi(3) * h;
    let rule = gauss_legendre_4();
    let weights = WEIGHTS.get_or_init(|| spline_moment_weights(TABLE_MU, segment, measure, rule));
    spline_positive_moment(nodes, weights, segment, measure, rule)
}

/// int max(0, y) over a grid of cells of the spline y through `nodes`
/// (`catmull_rom_cubic`, cells grouped into `segment`s), cell j weighted by
/// the polynomial `measure(j, t)` of its fraction t, integrated by the
/// Gauss-Legendre `rule` (exact when the cubic times the measure has at
/// most its degree, `positive_part_integral`). The
/// integral of y itself is linear in the nodes (`weights`, from
/// `spline_moment_weights`); only cells where y may dip below 0 (a Bernstein
/// coefficient of the cubic below 0, which bounds it) are integrated exactly
/// (`positive_part_integral`) to add back what falls below 0. So dE_avg is
/// the exact moment of the very dE the tables interpolate (the furnace
/// identity), at the cost of a dot product where dE stays positive.
pub(crate) fn spline_positive_moment(
    nodes: &[f32],
    weights: &[f64],
    segment: impl Fn(usize) -> (usize, usize),
    measure: impl Fn(usize, f64) -> f64,
    rule: &[(f64, f64)],
) -> f64 {
    let y = |i: usize| f64::from(nodes[i]);
    let whole: f64 = (0..nodes.len()).map(|i| y(i) * weights[i]).sum();
    let below: f64 = (0..nodes.len() - 1)
        .map(|j| {
            let points = catmull_rom_points(y, j, segment(j));
            if bernstein_nonnegative(points) {
                0.0
            } else {
                let cubic = catmull_rom_cubic(y, j, segment(j));
                positive_part_integral(cubic.map(|c| -c), |t| measure(j, t), rule)
            }
        })
        .sum();
    whole + below
}

/// The moment int y measure of each node's spline basis function (its
/// value 1, every other node 0), summed over the cells, by the
/// Gauss-Legendre `rule`: the linear part of `spline_positive_moment`.
pub(crate) fn spline_moment_weights(
    n: usize,
    segment: impl Fn(usize) -> (usize, usize),
    measure: impl Fn(usize, f64) -> f64,
    rule: &[(f64, f64)],
) -> Vec<f64> {
    (0..n)
        .map(|i| {
            (0..n - 1)
                .map(|j| {
                    let basis = catmull_rom_cubic(|k| f64::from(u8::from(k == i)), j, segment(j));
                    rule.iter()
                        .map(|&(t, w)| w * cubic_at(basis, t) * measure(j, t))
                        .sum::<f64>()
                })
                .sum()
        })
        .collect()
}

/// True when the Catmull-Rom cubic through the four `points` is >= 0 on its
/// cell for certain: its Bernstein coefficients (p1, p1 + (p2 - p0)/6,
/// p2 - (p3 - p1)/6, p2: the control points of the same curve) are all >=
/// 0, and the curve lies in their convex hull.
fn bernstein_nonnegative([p0, p1, p2, p3]: [f64; 4]) -> bool {
    p1 >= 0.0 && p2 >= 0.0 && 6.0 * p1 + p2 - p0 >= 0.0 && 6.0 * p2 + p1 - p3 >= 0.0
}

/// The Catmull-Rom cubic of cell `j` (nodes j and j + 1) through the node
/// values `y` of a segment of nodes `first..=last`, as coefficients of the
/// cell's fraction t (y = c0 + c1 t + c2 t^2 + c3 t^3): the spline of
/// `catmull_rom_weights`, with the same quadratic extrapolation beyond the
/// segment's ends (a segment ends where the tabulated function has a kink).
pub(crate) fn catmull_rom_cubic(
    y: impl Fn(usize) -> f64,
    j: usize,
    segment: (usize, usize),
) -> [f64; 4] {
    let [p0, p1, p2, p3] = catmull_rom_points(y, j, segment);
    [
        p1,
        0.5 * (p2 - p0),
        p0 - 2.5 * p1 + 2.0 * p2 - 0.5 * p3,
        0.5 * (p3 - p0) + 1.5 * (p1 - p2),
    ]
}

/// The four values y_(j-1) ..= y_(j+2) of cell j's spline, the outer ones
/// extrapolated quadratically beyond the segment `first..=last`.
fn catmull_rom_points(
    y: impl Fn(usize) -> f64,
    j: usize,
    (first, last): (usize, usize),
) -> [f64; 4] {
    let (p1, p2) = (y(j), y(j + 1));
    let p0 = if j == first {
        3.0 * p1 - 3.0 * p2 + y(j + 2)
    } else {
        y(j - 1)
    };
    let p3 = if j + 1 == last {
        3.0 * p2 - 3.0 * p1 + y(j - 1)
    } else {
        y(j + 2)
    };
    [p0, p1, p2, p3]
}

/// c0 + c1 t + c2 t^2 + c3 t^3.
pub(crate) fn cubic_at(c: [f64; 4], t: f64) -> f64 {
    ((c[3] * t + c[2]) * t + c[1]) * t + c[0]
}

/// int_0^1 max(0, y(t)) m(t) dt for the cubic y (`cubic_at`) and a
/// polynomial m: [0, 1] is cut where y' = 0 (explicit) and where y = 0
/// (bisection inside each monotone piece), and every piece where y > 0 is
/// integrated by the Gauss-Legendre `rule`, exact for y m up to its degree
/// (4 points: degree 7, the conductor tables' cubic measure; 8 points:
/// degree 15, the dielectric's of degree 7, `crate::compensation::dielectric_energy`).
/// So dE_avg is the moment of the very dE the tables interpolate, and the
/// furnace identity holds for it.
pub(crate) fn positive_part_integral(
    y: [f64; 4],
    m: impl Fn(f64) -> f64,
    rule: &[(f64, f64)],
) -> f64 {
    // Turning points: y' = c1 + 2 c2 t + 3 c3 t^2 = 0 inside (0, 1).
    let (a, b, c) = (3.0 * y[3], 2.0 * y[2], y[1]);
    let mut turns = [f64::NAN; 2];
    if a != 0.0 {
        let discriminant = b * b - 4.0 * a * c;
        if discriminant > 0.0 {
            let root = discriminant.sqrt();
            let (t0, t1) = ((-b - root) / (2.0 * a), (-b + root) / (2.0 * a));
            turns = [t0.min(t1), t0.max(t1)];
        }
    } else if b != 0.0 {
        turns[0] = -c / b;
    }
    // Monotone pieces [0, turns.., 1], each cut once more where y = 0:
    // at most 7 points, in order.
    let mut ends = [0.0; 4];
    let mut count = 1;
    for t in turns.into_iter().filter(|t| *t > 0.0 && *t < 1.0) {
        ends[count] = t;
        count += 1;
    }
    ends[count] = 1.0;
    let mut points = [0.0; 7];
    let mut n = 0;
    for piece in ends[..=count].windows(2) {
        points[n] = piece[0];
        n += 1;
        let (mut lo, mut hi) = (piece[0], piece[1]);
        let below = cubic_at(y, lo) <= 0.0;
        if below != (cubic_at(y, hi) <= 0.0) {
            for _ in 0..ROOT_BISECTIONS {
                let mid = 0.5 * (lo + hi);
                if (cubic_at(y, mid) <= 0.0) == below {
                    lo = mid;
                } else {
                    hi = mid;
                }
            }
            points[n] = 0.5 * (lo + hi);
            n += 1;
        }
    }
    points[n] = 1.0;
    points[..=n]
        .windows(2)
        .filter(|piece| cubic_at(y, 0.5 * (piece[0] + piece[1])) > 0.0)
        .map(|piece| {
            let (lo, width) = (piece[0], piece[1] - piece[0]);
            rule.iter()
                .map(|&(x, w)| {
                    let t = lo + width * x;
                    w * width * cubic_at(y, t) * m(t)
                })
                .sum::<f64>()
        })
        .sum()
}

/// Bisection steps for a zero of the interpolated dE in a cell: 2^-50 of
/// the cell, far below what the f32 table resolves.
const ROOT_BISECTIONS: usize = 50;

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

    #[test]
    fn positive_part_integral_matches_a_fine_midpoint_rule() {
        // Three sign changes in [0, 1]: (t - 0.1)(t - 0.5)(t - 0.8), and a
        // cubic measure.
        let (a, b, c) = (0.1, 0.5, 0.8);
        let y = [-a * b * c, a * b + a * c + b * c, -(a + b + c), 1.0];
        let m = |t: f64| 1.0 + t * t * t;
        let n = 1_000_000;
        let fine: f64 = (0..n)
            .map(|k| {
                let t = (k as f64 + 0.5) / n as f64;
                cubic_at(y, t).max(0.0) * m(t) / n as f64
            })
            .sum();
        let exact = positive_part_integral(y, m, gauss_legendre_4());
        assert!((exact - fine).abs() < 1e-10, "{exact} vs {fine}");
    }

    /// Between the smooth lobe (alpha = 0, E = 1) and the first node the
    /// table follows the albedo near grazing, where it falls as alpha^2
    /// (`alpha_weights`): measured 1.0e-4 at most; the Catmull-Rom spline
    /// there was off by 5.0e-3.
    #[test]
    fn albedo_between_the_smooth_lobe_and_the_first_node_follows_quadrature() {
        let (kind, shadowing) = (NdfKind::Ggx, Shadowing::Smith);
        let table = albedo_table(kind, shadowing);
        let mut worst: f64 = 0.0;
        for alpha in [1e-5f32, 1e-4, 3e-4, 5e-4] {
            for mu in [0.005f32, 0.01, 0.02, 0.04] {
                let e = f64::from(table.albedo(mu, alpha));
                let truth = albedo_quadrature(kind, shadowing, alpha, f64::from(mu), (32, 32));
                worst = worst.max((e - truth).abs());
            }
        }
        println!("largest |table - quadrature| below the first alpha node: {worst:.1e}");
        assert!(worst <= 2e-4, "{worst}");
    }

    #[test]
    fn catmull_rom_cubics_reproduce_quadratics_up_to_the_segment_ends() {
        let q = |x: f64| 0.3 - 1.7 * x + 0.9 * x * x;
        for j in 0..9 {
            let cubic = catmull_rom_cubic(|i| q(i as f64), j, (0, 9));
            for t in [0.0, 0.3, 0.8, 1.0] {
                let error = (cubic_at(cubic, t) - q(j as f64 + t)).abs();
                assert!(error < 1e-12, "cell {j} t {t}: {error}");
            }
        }
    }
}
