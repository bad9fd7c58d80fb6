//! Energy compensation of regularized dielectric lobes (ARCHITECTURE.md,
//! "Energy-preserving regularization"): the conductor construction of
//! `crate::energy` (Kulla & Conty, "Revisiting Physically Based Shading at
//! Imageworks", SIGGRAPH 2017 course, §"Energy compensation"), extended to
//! an interface that reflects and transmits, as Kulla & Conty do for their
//! dielectrics: albedo tables per eta and per side, and a reflection /
//! transmission split of the compensated energy that keeps reciprocity.
//!
//! **Energy.** E_s(mu, alpha, eta) is the directional albedo of the white
//! (untinted) rough dielectric queried from side s (s = + above, where the
//! interface is seen with eta; s = - below, seen with 1/eta): reflection plus
//! transmission with their Fresnel factors, transmission in **Importance
//! mode** (SPEC §3). That is the energy-conserving quantity (flux out over
//! flux in; a smooth interface has E = 1 on both sides): Radiance mode's
//! transmitted value carries (eta_i/eta_t)^2, which is radiance compression,
//! not energy. The regularized lobe loses
//! dE_s(mu) = max(0, E_s(mu, alpha) - E_s(mu, alpha-hat)),
//! dE_avg,s = 2 int_0^1 dE_s(mu) mu dmu.
//!
//! **Compensation lobe** (Importance mode; directions on sides s -> s'):
//! - reflection on side s: f_R = (1 - t_s) dE_s(mu_i) dE_s(mu_o) / (pi dE_avg,s),
//! - transmission s -> s': f_T = T_s dE_s(mu_i) dE_s'(mu_o) / (pi M),
//!   M = max(dE_avg,+, dE_avg,-), so that
//!   int f_T |mu_o| dwo = t_s dE_s(mu_i), t_s = T_s min(1, dE_avg,s' / dE_avg,s);
//!   in Radiance mode times (eta_i/eta_t)^2 like the lobe's own refraction.
//!
//! int (f_R + f_T) |mu_o| dwo = dE_s(mu_i): the compensated lobe's energy
//! albedo is the original's wherever widening loses energy (up to table
//! error). f_R is symmetric. T_s is the hemispherical (cosine-weighted)
//! transmittance of the smooth interface seen from side s, T_s = 1 - F_avg,s;
//! it obeys n_s^2 T_s = n_s'^2 T_s' (the Stokes relation integrated over the
//! hemisphere), so f_T(wi, wo) n_i^2 = f_T(wo, wi) n_o^2, the generalized
//! reciprocity of a refracting BSDF (Veach 1997, eq. 5.14): the Importance
//! value of one direction is the Radiance value of the other, as for the
//! microfacet transmission. The split is thus Kulla & Conty's Fresnel
//! average, as for coloured conductors, made reciprocal by the min(): the
//! side with the larger deficit transmits less than T_s and reflects the rest
//! (Kulla & Conty balance the two sides through E_avg of both as well).
//! As alpha-hat -> alpha both deficits vanish (consistency).
//!
//! **Tables** E(mu, alpha, eta) per NDF x shadowing, on `TABLE_MU` x
//! `TABLE_ALPHA` nodes as the conductor tables and `TABLE_ETA` nodes of the
//! index ratio seen from the query side, uniform in ln(eta) on
//! [1/`ETA_MAX`, `ETA_MAX`] (both sides of every interface with eta in that
//! range; uniform in ln(eta) since the table is symmetric in the sense that
//! eta and 1/eta are the two sides of one interface). An interface outside the
//! range is compensated as if its eta were clamped to it: its energy is then
//! restored only approximately (the table's error grows with the distance),
//! never with a NaN. Computed serially at first use by the quadrature of
//! `crate::energy` over D(h)<h,n>-sampled normals, one set of normals per
//! alpha row shared by every mu and eta.

use std::f32::consts::FRAC_1_PI;
use std::sync::OnceLock;

use glam::{Vec2, Vec3};

use crate::energy::{
    GRAZING_MU, MIN_DEFICIT_AVERAGE, MODELS, TABLE_ALPHA, TABLE_ALPHA_MAX, TABLE_MU, alpha_node,
    cell, gauss_legendre, lerp, model_index, mu_node, positive_part_moment,
};
use crate::frame::refract_f64;
use crate::fresnel;
use crate::model::MicrofacetModel;
use crate::ndf::NdfKind;
use crate::sample::TransportMode;
use crate::shadowing::Shadowing;

/// Largest index ratio of the tables (and 1/`ETA_MAX` the smallest): glass
/// 1.5, diamond 2.42, rutile 2.9 are inside.
pub const ETA_MAX: f32 = 3.0;
/// Table nodes in eta, uniform in the variable of `eta_coordinate` on
/// [1/`ETA_MAX`, `ETA_MAX`]; odd, so that the index-matched eta = 1 is a node.
pub const TABLE_ETA: usize = 25;
/// (radial Gauss-Legendre, half-azimuth midpoint) nodes of the quadrature
/// for queries from the rare side (eta >= 1): the integrand is smooth there
/// and 32 x 32 nodes agree with 256 x 256 to 1e-4.
const QUADRATURE_RARE: (usize, usize) = (32, 32);
/// The same from the dense side (eta < 1): where total internal reflection
/// sets in, F reaches 1 with an infinite slope along a curve that no product
/// rule follows, and 32 x 32 nodes were off by up to 3e-3; 64 x 64 by 7e-4.
const QUADRATURE_DENSE: (usize, usize) = (64, 64);
/// Gauss-Legendre nodes of the smooth interface's hemispherical
/// transmittance (`transmittance_above`), whose integrand (1 - F) mu is
/// smooth on the rarer side.
const TRANSMITTANCE_NODES: usize = 16;

/// Side of the interface a direction is on: `ABOVE` (+z, the interface is
/// seen with eta) or `BELOW` (seen with 1/eta); array index of per-side data.
pub const ABOVE: usize = 0;
/// See [`ABOVE`].
pub const BELOW: usize = 1;

/// The side of direction `w` (its z sign; `ABOVE` for w.z >= 0).
pub fn side(w: Vec3) -> usize {
    if w.z < 0.0 { BELOW } else { ABOVE }
}

/// The index ratio seen from `side` of an interface with ratio `eta`.
fn seen(eta: f32, side: usize) -> f32 {
    if side == ABOVE { eta } else { 1.0 / eta }
}

/// Energy albedo E(mu, alpha, eta) of a white rough dielectric (module
/// docs), on a `TABLE_ETA` x `TABLE_ALPHA` x `TABLE_MU` grid.
#[derive(Clone, Debug)]
pub struct DielectricAlbedoTable {
    /// `e[(i * TABLE_ALPHA + k) * TABLE_MU + j]` = E(mu_j, alpha_k, eta_i).
    e: Vec<f32>,
}

impl DielectricAlbedoTable {
    /// Computes the table by quadrature (see [`dielectric_albedo_quadrature`]).
    pub fn compute(kind: NdfKind, shadowing: Shadowing) -> Self {
        let mut e = vec![0.0; TABLE_ETA * TABLE_ALPHA * TABLE_MU];
        for k in 0..TABLE_ALPHA {
            let alpha = alpha_node(k);
            // alpha = 0: the smooth interface, R + T = 1 exactly.
            let rules = (alpha > 0.0).then(|| {
                [QUADRATURE_DENSE, QUADRATURE_RARE].map(|(radial, azimuth)| {
                    Quadrature::new(kind, shadowing, alpha, radial, azimuth)
                })
            });
            for j in 0..TABLE_MU {
                for i in 0..TABLE_ETA {
                    let eta = eta_node(i);
                    e[(i * TABLE_ALPHA + k) * TABLE_MU + j] = rules.as_ref().map_or(1.0, |q| {
                        q[usize::from(eta >= 1.0)].albedo(mu_node(j), f64::from(eta))
                    }) as f32;
                }
            }
        }
        Self { e }
    }

    /// E(mu, alpha, eta), trilinear (linear in sqrt(mu), sqrt(alpha) and
    /// ln(eta)); alpha and eta clamped to the table.
    pub fn albedo(&self, mu: f32, alpha: f32, eta: f32) -> f32 {
        let (j, t) = cell(mu, TABLE_MU, 1.0);
        let row = self.row(alpha, eta);
        lerp(row(j), row(j + 1), t)
    }

    /// mu node j -> E(mu_j, alpha, eta), bilinear in alpha and eta.
    fn row(&self, alpha: f32, eta: f32) -> impl Fn(usize) -> f32 + '_ {
        let (k, s) = cell(alpha, TABLE_ALPHA, TABLE_ALPHA_MAX);
        let (i, r) = eta_cell(eta);
        let at = move |i: usize, k: usize, j: usize| self.e[(i * TABLE_ALPHA + k) * TABLE_MU + j];
        move |j| {
            let lower = lerp(at(i, k, j), at(i, k + 1, j), s);
            let upper = lerp(at(i + 1, k, j), at(i + 1, k + 1, j), s);
            lerp(lower, upper, r)
        }
    }

    /// E(mu_j, alpha, eta) - E(mu_j, alpha_hat, eta) at every mu node.
    fn deficit_nodes(&self, alpha: f32, alpha_hat: f32, eta: f32) -> [f32; TABLE_MU] {
        let (original, regularized) = (self.row(alpha, eta), self.row(alpha_hat, eta));
        std::array::from_fn(|j| original(j) - regularized(j))
    }
}

/// The shared dielectric table of `kind` with `shadowing`, computed at first use.
pub fn dielectric_albedo_table(
    kind: NdfKind,
    shadowing: Shadowing,
) -> &'static DielectricAlbedoTable {
    static TABLES: [OnceLock<DielectricAlbedoTable>; MODELS] = [const { OnceLock::new() }; MODELS];
    TABLES[model_index(kind, shadowing)]
        .get_or_init(|| DielectricAlbedoTable::compute(kind, shadowing))
}

/// The table's coordinate of an index ratio, in [-1, 1]:
/// x = -(1 - eta^2) / r on the dense side (eta < 1) and x = (1 - 1/eta^2) / r
/// on the rare side, r = 1 - 1/ETA_MAX^2. Seen from the dense side the albedo is
/// nearly linear in eta^2 (total internal reflection sets in at sin theta =
/// eta; measured: slopes within 15 % over eta^2 in [0.4, 1]) and curves
/// strongly in ln(eta), where uniform nodes missed it by 8e-3; on the rare
/// side 1/eta^2 does the same. Monotone and continuous through eta = 1.
fn eta_coordinate(eta: f32) -> f32 {
    let range = 1.0 - ETA_MAX.powi(-2);
    if eta < 1.0 {
        -(1.0 - eta * eta) / range
    } else {
        (1.0 - (eta * eta).recip()) / range
    }
}

/// eta of table node i (inverse of `eta_coordinate` at x = 2i/(n-1) - 1).
fn eta_node(i: usize) -> f32 {
    let x = 2.0 * i as f32 / (TABLE_ETA - 1) as f32 - 1.0;
    let range = 1.0 - ETA_MAX.powi(-2);
    if x < 0.0 {
        (1.0 + x * range).sqrt()
    } else {
        (1.0 - x * range).sqrt().recip()
    }
}

/// (cell index, fraction) of `eta` on the eta nodes, clamped to
/// [1/ETA_MAX, ETA_MAX] (module docs: outside, the clamped eta's table).
fn eta_cell(eta: f32) -> (usize, f32) {
    let x = eta_coordinate(eta).clamp(-1.0, 1.0);
    // NaN (eta <= 0 or NaN, which no valid lobe has) lands on the first node.
    let s = if x.is_nan() {
        0.0
    } else {
        0.5 * (x + 1.0) * (TABLE_ETA - 1) as f32
    };
    let i = (s as usize).min(TABLE_ETA - 2);
    (i, s - i as f32)
}

/// Microfacet normals h_m drawn from D(h)<h,n> on a product rule (Gauss-
/// Legendre in the radial uniform, midpoint over the half azimuth) with their
/// weights: one set per alpha, shared by every mu and eta of the table.
struct Quadrature {
    model: MicrofacetModel,
    normals: Vec<(Vec3, f64)>,
    /// Smith's G1 at |<w,n>| = i/(`SMITH_G1_NODES` - 1), linear between:
    /// G1 of an isotropic NDF depends on the direction's cosine only, and
    /// the exact Blinn-Phong Lambda (an incomplete beta function) made a
    /// table cost 7 s.
    smith_g1: Vec<f32>,
}

/// Nodes of `Quadrature::smith_g1`, uniform in the cosine: the linear
/// interpolation error is below 1e-6 away from grazing; near grazing G1
/// falls to 0 within a cosine of about alpha, where the integrand carries
/// little (the table's error budget is 1e-3).
const SMITH_G1_NODES: usize = 4097;

impl Quadrature {
    fn new(kind: NdfKind, shadowing: Shadowing, alpha: f32, radial: usize, azimuth: usize) -> Self {
        let model = MicrofacetModel::new(kind, alpha, shadowing);
        let rule = gauss_legendre(radial);
        let mut normals = Vec::with_capacity(radial * azimuth);
        for &(v, w) in &rule {
            // u1 = v^2 (3 - 2v): the integrand has integrable singularities
            // (1/<h,n> -> infinity, e.g. (1 - u1)^(-1/2) for GGX at u1 -> 1,
            // u1^(-alpha^2/2) for Blinn-Phong at u1 -> 0) where refracted
            // directions stay valid for normals near the horizon; the
            // substitution's du1 = 6 v (1 - v) dv removes them, and the
            // Gauss-Legendre rule converges again (without it: 5e-3 off at
            // 32 nodes, O(1/n)).
            let (u1, w1) = (v * v * (3.0 - 2.0 * v), w * 6.0 * v * (1.0 - v));
            for m in 0..azimuth {
                // Half azimuth [0, 1/2) of the sampler's u.y (doubled by the
                // symmetry about the plane of incidence).
                let u2 = (m as f64 + 0.5) / (2 * azimuth) as f64;
                let h = model.ndf.sample_d_cos(Vec2::new(u1 as f32, u2 as f32));
                if h.z > 0.0 {
                    normals.push((h, w1 / azimuth as f64));
                }
            }
        }
        let smith_g1 = match shadowing {
            Shadowing::Smith => (0..SMITH_G1_NODES)
                .map(|i| {
                    let mu = i as f32 / (SMITH_G1_NODES - 1) as f32;
                    model
                        .ndf
                        .g1(Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu))
                })
                .collect(),
            Shadowing::VCavity => Vec::new(),
        };
        Self {
            model,
            normals,
            smith_g1,
        }
    }

    /// Smith's G1 at cosine `mu` in [0, 1], from `smith_g1`.
    fn smith_g1(&self, mu: f32) -> f32 {
        let x = mu.clamp(0.0, 1.0) * (SMITH_G1_NODES - 1) as f32;
        let i = (x as usize).min(SMITH_G1_NODES - 2);
        lerp(self.smith_g1[i], self.smith_g1[i + 1], x - i as f32)
    }

    /// E(mu, alpha, eta) = int D(h) <wi,h>/<wi,n> [F G(wi, wo_r) + (1 - F)
    /// G(wi, wo_t)] dh: with wo_r = reflect(wi, h), dwo = 4 <wo,h> dh, the
    /// reflection f cos_o dwo = F D G <wi,h>/<wi,n> dh (SPEC §3); with wo_t
    /// refracted, dwo = (<wi,h> + eta <wo,h>)^2/(eta^2 |<wo,h>|) dh, the
    /// Importance-mode transmission f |cos_o| dwo = (1 - F) D G <wi,h>/<wi,n>
    /// dh. Divided by the sampling density D(h)<h,n>:
    /// <wi,h>/(<wi,n><h,n>) [F G_r + (1 - F) G_t], total internal
    /// reflection giving F = 1.
    fn albedo(&self, mu: f64, eta: f64) -> f64 {
        let mu = mu.max(GRAZING_MU);
        let wi = Vec3::new((1.0 - mu * mu).max(0.0).sqrt() as f32, 0.0, mu as f32);
        let model = &self.model;
        // Smith's G1(wi) does not depend on h (given <wi,h> > 0).
        let g1_wi = match model.shadowing {
            Shadowing::Smith => model.ndf.g1(wi),
            Shadowing::VCavity => 0.0,
        };
        // Both directions below are valid for their side (checked), so
        // Smith's G1(wo) is the tabulated G1 of |<wo,n>|.
        let g = |wo: Vec3, h: Vec3| match model.shadowing {
            Shadowing::Smith => g1_wi * self.smith_g1(wo.z.abs()),
            Shadowing::VCavity => model.g(wi, wo, h),
        };
        let mut sum = 0.0;
        for &(h, weight) in &self.normals {
            let wi_h = wi.dot(h);
            if !(wi_h > 0.0) {
                continue;
            }
            let (f, t) = fresnel::dielectric_f64(f64::from(wi_h), eta);
            let mut value = 0.0;
            let wo = 2.0 * wi_h * h - wi;
            if wo.z > 0.0 {
                value += f * f64::from(g(wo, h));
            }
            if t > 0.0
                && let Some(wo) = refract_f64(wi, h, eta)
                && wo.z < 0.0
            {
                value += t * f64::from(g(wo, h));
            }
            sum += weight * value * f64::from(wi_h) / (mu * f64::from(h.z));
        }
        sum
    }
}

/// E(mu, alpha, eta) of one configuration by the table's quadrature rule
/// with `nodes` = (radial, half-azimuth) nodes (the table's are
/// `QUADRATURE_RARE` and `QUADRATURE_DENSE`); 1 for alpha = 0, the smooth
/// interface. For tests of the rule's convergence.
pub fn dielectric_albedo_quadrature(
    kind: NdfKind,
    shadowing: Shadowing,
    alpha: f32,
    mu: f64,
    eta: f64,
    nodes: (usize, usize),
) -> f64 {
    if alpha <= 0.0 {
        return 1.0;
    }
    Quadrature::new(kind, shadowing, alpha, nodes.0, nodes.1).albedo(mu, eta)
}

/// The hemispherical transmittance T_+ = 2 int_0^1 (1 - F(mu)) mu dmu of the
/// smooth interface seen from above (index ratio `eta`). Integrated on the
/// rarer side, where 1 - F is smooth (no total internal reflection), by
/// Gauss-Legendre; the denser side's follows from n_+^2 T_+ = n_-^2 T_-
/// (module docs), T_+ = eta^2 T_-.
pub fn transmittance_above(eta: f32) -> f32 {
    static NODES: OnceLock<Vec<(f64, f64)>> = OnceLock::new();
    let nodes = NODES.get_or_init(|| gauss_legendre(TRANSMITTANCE_NODES));
    let eta = f64::from(eta);
    let rare = eta.max(1.0 / eta);
    let t_rare: f64 = nodes
        .iter()
        .map(|&(mu, w)| 2.0 * w * mu * fresnel::dielectric_f64(mu, rare).1)
        .sum();
    (if eta >= 1.0 {
        t_rare
    } else {
        eta * eta * t_rare
    }) as f32
}

/// The compensation lobe of a regularized dielectric (module docs): what it
/// needs beyond the lobe (its model at alpha-hat and its eta).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DielectricCompensation {
    /// The original (unregularized) alpha.
    pub alpha: f32,
    /// dE_avg of each side ([`ABOVE`], [`BELOW`]); 0 for a side whose
    /// deficit is below `MIN_DEFICIT_AVERAGE` (then its dE is taken as 0).
    pub deficit_average: [f32; 2],
    /// T_s, the smooth interface's hemispherical transmittance seen from
    /// each side.
    pub transmittance: [f32; 2],
}

impl DielectricCompensation {
    /// The compensation of `model` (at alpha-hat) for an interface of width
    /// `alpha` and index ratio `eta`, or `None` when it would carry nothing
    /// (alpha-hat <= alpha, a smooth model, an invalid eta, or both deficits
    /// below `MIN_DEFICIT_AVERAGE`).
    pub fn new(model: &MicrofacetModel, alpha: f32, eta: f32) -> Option<Self> {
        let alpha_hat = model.alpha();
        if !(alpha_hat > alpha) || model.is_smooth() || !(eta > 0.0 && eta.is_finite()) {
            return None;
        }
        let table = dielectric_albedo_table(model.ndf.kind(), model.shadowing);
        let deficit_average = [ABOVE, BELOW].map(|s| {
            let nodes = table.deficit_nodes(alpha, alpha_hat, seen(eta, s));
            let average = positive_part_moment(&nodes) as f32;
            if average > MIN_DEFICIT_AVERAGE {
                average
            } else {
                0.0
            }
        });
        if deficit_average == [0.0, 0.0] {
            return None;
        }
        let above = transmittance_above(eta);
        Some(Self {
            alpha,
            deficit_average,
            transmittance: [above, above / (eta * eta)],
        })
    }

    /// dE_s(mu) of the regularized `model` (alpha-hat) on `side`.
    pub fn deficit(&self, model: &MicrofacetModel, eta: f32, side: usize, mu: f32) -> f32 {
        if self.deficit_average[side] == 0.0 {
            return 0.0;
        }
        let table = dielectric_albedo_table(model.ndf.kind(), model.shadowing);
        let eta = seen(eta, side);
        (table.albedo(mu, self.alpha, eta) - table.albedo(mu, model.alpha(), eta)).max(0.0)
    }

    /// E_s(mu) at alpha-hat (white, Importance mode) on `side`.
    pub fn regularized_albedo(
        &self,
        model: &MicrofacetModel,
        eta: f32,
        side: usize,
        mu: f32,
    ) -> f32 {
        dielectric_albedo_table(model.ndf.kind(), model.shadowing).albedo(
            mu,
            model.alpha(),
            seen(eta, side),
        )
    }

    /// t_s = T_s min(1, dE_avg,s' / dE_avg,s): the share of side s's
    /// compensated energy that is transmitted.
    pub fn transmitted_share(&self, side: usize) -> f32 {
        let (own, other) = (self.deficit_average[side], self.deficit_average[1 - side]);
        if own == 0.0 {
            return 0.0;
        }
        self.transmittance[side] * (other / own).min(1.0)
    }

    /// The compensation value for `wi`, `wo` (untinted), in `mode`: f_R on
    /// one side, f_T across (module docs), 0 at grazing.
    pub fn value(
        &self,
        model: &MicrofacetModel,
        eta: f32,
        wi: Vec3,
        wo: Vec3,
        mode: TransportMode,
    ) -> f32 {
        if wi.z == 0.0 || wo.z == 0.0 {
            return 0.0;
        }
        let (s_i, s_o) = (side(wi), side(wo));
        let d_i = self.deficit(model, eta, s_i, wi.z.abs());
        if d_i == 0.0 {
            return 0.0;
        }
        let d_o = self.deficit(model, eta, s_o, wo.z.abs());
        if s_i == s_o {
            let reflected = 1.0 - self.transmitted_share(s_i);
            return reflected * d_i * d_o * FRAC_1_PI / self.deficit_average[s_i];
        }
        let largest = self.deficit_average[0].max(self.deficit_average[1]);
        let importance = self.transmittance[s_i] * d_i * d_o * FRAC_1_PI / largest;
        match mode {
            TransportMode::Importance => importance,
            // (eta_i/eta_t)^2 = 1/eta_seen^2, as the lobe's refraction.
            TransportMode::Radiance => importance / seen(eta, s_i).powi(2),
        }
    }

    /// P_c(mu_i) = dE_s / (E_hat,s + dE_s): the probability of sampling the
    /// compensation lobe for a query from `wi`, its share of the energy albedo.
    pub fn probability(&self, model: &MicrofacetModel, eta: f32, wi: Vec3) -> f32 {
        let (s, mu) = (side(wi), wi.z.abs());
        let deficit = self.deficit(model, eta, s, mu);
        let total = deficit + self.regularized_albedo(model, eta, s, mu);
        if deficit > 0.0 && total > 0.0 {
            (deficit / total).clamp(0.0, 1.0)
        } else {
            0.0
        }
    }

    /// Density of the compensation lobe's sampler: cosine on the side that
    /// the coin picks (transmission with probability t_s).
    pub fn sampling_pdf(&self, wi: Vec3, wo: Vec3) -> f32 {
        let s = side(wi);
        let share = if s == side(wo) {
            1.0 - self.transmitted_share(s)
        } else {
            self.transmitted_share(s)
        };
        share * wo.z.abs() * FRAC_1_PI
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eta_nodes_are_symmetric_and_cells_clamp() {
        assert!((eta_node(TABLE_ETA / 2) - 1.0).abs() < 1e-6);
        assert!((eta_node(0) * eta_node(TABLE_ETA - 1) - 1.0).abs() < 1e-5);
        assert_eq!(eta_cell(100.0), (TABLE_ETA - 2, 1.0));
        assert_eq!(eta_cell(1e-3), (0, 0.0));
        assert_eq!(eta_cell(f32::NAN), (0, 0.0));
    }

    /// T_+ against a fine midpoint rule, and the reciprocity identity.
    #[test]
    fn transmittance_matches_fine_quadrature() {
        for eta in [1.05f32, 1.33, 1.5, 2.4, 3.0] {
            let n = 200_000;
            let fine: f64 = (0..n)
                .map(|k| {
                    let mu = (k as f64 + 0.5) / n as f64;
                    2.0 * mu * fresnel::dielectric_f64(mu, f64::from(eta)).1 / n as f64
                })
                .sum();
            let t = f64::from(transmittance_above(eta));
            assert!((t - fine).abs() < 1e-4, "eta {eta}: {t} vs {fine}");
            // Seen from the dense side (total internal reflection included).
            let fine_below: f64 = (0..n)
                .map(|k| {
                    let mu = (k as f64 + 0.5) / n as f64;
                    2.0 * mu * fresnel::dielectric_f64(mu, 1.0 / f64::from(eta)).1 / n as f64
                })
                .sum();
            let below = f64::from(transmittance_above(1.0 / eta));
            assert!(
                (below - fine_below).abs() < 1e-4,
                "1/{eta}: {below} vs {fine_below}"
            );
        }
    }
}
