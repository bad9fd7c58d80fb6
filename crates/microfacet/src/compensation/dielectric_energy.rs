//! Energy compensation of regularized dielectric lobes (ARCHITECTURE.md,
//! "Energy-preserving regularization"): the conductor construction of
//! `crate::compensation::energy` (Kulla & Conty, "Revisiting Physically Based Shading at
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
//! **Tables** E(mu, alpha, eta) per NDF x shadowing and per medium of the
//! query (`RARE`: the index ratio seen is >= 1; `DENSE`: < 1), on
//! `TABLE_CRITICAL` x `TABLE_ALPHA` x `table_mu_nodes` nodes (64 in mu with
//! Smith shadowing, 104 with V-cavity's: `MuGrid`). The index
//! ratio enters through the cosine of the critical angle,
//! c = sqrt(1 - 1/max(eta, 1/eta)^2) on [0, c(`ETA_MAX`)]: from the dense
//! side total internal reflection sets in at mu = c, which is a node of
//! every dense row (`MuGrid`), and from the rare side a grazing query
//! refracts to the cosine c, so the albedo is smooth in c where it was not in
//! eta near 1 (`critical_cosine`). Rows of neighbouring c are interpolated at
//! the same position relative to their kink; bicubic (Catmull-Rom) in
//! sqrt(alpha) (`crate::compensation::energy::alpha_weights`) and c, and cubic in the
//! node index inside each segment of the `MuGrid` (the dense side's kink
//! ends one), with dE_avg the exact moment of the interpolated dE
//! (`MuGrid::positive_part_moment`). An interface outside [1/`ETA_MAX`,
//! `ETA_MAX`] is compensated as if its eta were clamped to it: its energy is
//! then restored only approximately (the table's error grows with the
//! distance), never with a NaN. Computed by quadrature over
//! microfacet normals (`Quadrature` from the rare side,
//! `crate::compensation::quadrature::SplitQuadrature`, split at the total-internal-reflection
//! curve, from the dense side), serially, one critical-cosine node at its
//! first use: an interface reads four of the 61 (release build, one core,
//! eta 1.5: 1.5-2.6 s for Beckmann/Smith, 2.7-3.3 s for GGX/Smith, about
//! 1.5x the former 21 x 44-node grid's, measured side by side; 6.6-8.1 s
//! for GGX/V-cavity with its 104 nodes in mu at eta 1.05-2.4 on an idle
//! host, 1.2x what its former 88 took, `TABLE_MU_VCAVITY`; 17-18 s at eta
//! 1.001-1.005, whose slices take a finer rule,
//! `QUADRATURE_DENSE_VCAVITY_FINE`).
//!
//! Accuracy (against fine quadrature, originals alpha 0 to 0.3 widened to
//! 0.15 to 1; a sweep of mu in steps of 0.01, of which
//! `tests/microfacet/dielectric_compensation.rs` checks twelve cosines at
//! eta 1.05-2.2 and eight at 1.001 and 1.0017): the compensated albedo
//! E(alpha-hat) + dE is within 1e-3 of E(alpha) from both sides of the
//! interfaces that regularization widens (|eta - 1| >= 1e-3,
//! `crate::dielectric::INDEX_MATCH_EPSILON`):
//! - GGX/Smith for mu >= 0.01 up to eta 3: 7.8e-4 from the rare side (eta
//!   3, normal incidence; 5.8e-4 up to 2.4), 6.3e-4 from the dense side
//!   (1/2.4; 4.6e-4 for 1/1.05 to 1/2.2, 5.2e-4 for 1/1.001 to 1/1.02);
//!   1.8e-3 at mu 0.01 before the first alpha cell was made linear in
//!   alpha^2 (`crate::compensation::energy::alpha_weights`);
//! - V-cavity for mu >= 0.04 up to eta 2.4, its dense rows split at the
//!   onsets of transmission and of full visibility (`MuGrid`,
//!   `crate::compensation::vcavity_onsets`; 1.75e-3 in one segment below the kink):
//!   Beckmann 4.0e-4 from the rare side and 8.3e-4 from the dense side
//!   (eta 1/1.012; 7.2e-4 at 1/2, where off-plane normals round off the
//!   onset of transmission), Blinn-Phong 7.9e-4 (1/2.4) and GGX 7.6e-4
//!   (1/2.4) from the dense side; near index matching (eta 1/1.001 to
//!   1/1.012) GGX 5.5e-4, where the slices' rule made 1.29e-3 before it was
//!   refined there (`QUADRATURE_DENSE_VCAVITY_FINE`).
//!
//! The same sweep gave GGX/Smith 6.9e-4 and 8.0e-4 for eta 1.05-2.2 but
//! 1.84e-3 at 1/1.0017, and Beckmann/V-cavity 9.1e-4 (Blinn-Phong 9.7e-4)
//! but 4.1e-3 at 1/1.0017, when the rows were read at a fraction of the
//! cell linear in x or t instead of the node index (`Segment::cell`), the
//! critical-cosine nodes were uniform (41, `TABLE_CRITICAL`) and
//! V-cavity's had Smith's 31 cells above the kink (`VCAVITY_UPPER_CELLS`).
//!
//! **Sampling.** The compensation is chosen with probability
//! P_c = dE_s / (E-hat_s + dE_s), then transmission with probability t_s,
//! cosine-distributed on the chosen side; pdf, reverse pdf and p-hat are the
//! mixture (as in `crate::compensation::energy`).
//!
//! **Quadrature.** From the rare side a product rule over D(h)<h,n> normals,
//! 32 x 32 (64 x 64 with V-cavity shadowing, `quadrature_rare`), with
//! u = v^2 (3 - 2v) removing the 1/<h,n> endpoint singularity
//! of refraction through near-horizontal facets; from the dense side a rule
//! split where the integrand has kinks (per ring of normals at the azimuths
//! where <wi,h> reaches the total-internal-reflection cosine, where the
//! reflected direction reaches the horizon and where <wi,h> = 0, and in
//! theta_h where rings become tangent to those curves), 16 x 16
//! Gauss-Legendre nodes per piece: a 64 x 64 product rule cut by the
//! total-internal-reflection curve was off by 1.7e-3, the split rule is
//! within 1.3e-4 of 48 x 48 per piece. Smith G1 comes from a 4097-node
//! table per alpha.
//!
//! **Gains.** Where widening raises a side's energy albedo (up to +0.055:
//! Beckmann, Blinn-Phong, V-cavity; GGX/Smith near grazing) the widened
//! lobe is scaled by s(wi) s(wo) (`crate::compensation::dielectric_gain`), which keeps
//! the generalized reciprocity above.
//!
//! **Limits.** The reflection/transmission split is a model choice (the
//! smooth interface's), not the rough interface's own multiple scattering.

use std::sync::OnceLock;

use glam::{Vec2, Vec3};

use crate::compensation::energy::{
    MODELS, TABLE_ALPHA, alpha_node, alpha_weights, catmull_rom_cubic, catmull_rom_weights, cell,
    cubic_at, model_index, spline_moment_weights, spline_positive_moment,
};
use crate::compensation::gain::{Kernel, MIN_GAIN};
use crate::compensation::quadrature::{GRAZING_MU, SmithG1Table, SplitQuadrature};
use crate::frame::refract_f64;
use crate::fresnel;
use crate::gauss::{gauss_legendre, gauss_legendre_8};
use crate::ndf::{Ndf, NdfKind};

use crate::shadowing::Shadowing;

/// Largest index ratio of the tables (and 1/`ETA_MAX` the smallest): glass
/// 1.5, diamond 2.42, rutile 2.9 are inside.
pub const ETA_MAX: f32 = 3.0;
/// Table nodes per side in the interface's critical cosine c (`critical_cosine`)
/// on [0, c(`ETA_MAX`)], spaced from 0.0079 at c = 0 to 0.0236 at the end
/// (`critical_node`); node 0 is the index-matched eta = 1. From the dense
/// side wide lobes have a feature at mu = eta (where the circle of total
/// internal reflection around wi reaches the horizon of the normals), which
/// moves across the rows' `MuGrid` as c changes: with 21 uniform nodes
/// interpolation in c missed it by up to 1.6e-3 (GGX/Smith, eta 1/1.5,
/// alpha 1, mu 0.66; 6.0e-4 at a node), with 41 (0.0236 apart) by 5.5e-4.
/// Near index matching narrow lobes change on the scale of c itself, and
/// the rows below the kink (in x = mu/c) with it: 41 uniform nodes missed
/// by up to 1.55e-3 (GGX/Smith, eta 1/1.0017, alpha 0.03 widened to 1, mu
/// 0.05), these 61 by 2.4e-4. An interface reads 4 of them, so their number
/// costs no build time.
pub const TABLE_CRITICAL: usize = 61;
/// Table nodes in mu per row with Smith shadowing (`MuGrid`). More than the
/// conductor tables' `TABLE_MU`: from the dense side narrow lobes fall over
/// a cosine of the order of alpha just below the kink at mu = c; with 44
/// nodes (22 below the kink, uniform in sqrt(mu/c)) the compensated albedo
/// missed it by up to 1.3e-3 (GGX/Smith, eta 1/2.2, 0.03 -> 0.15, mu 0.86),
/// with 64 by 7.1e-4.
pub(crate) const TABLE_MU_DIELECTRIC: usize = 64;
/// mu cells of a Smith dense-side row below its critical cosine
/// (`Lower::Whole`); the other `UPPER_CELLS` lie above it.
const DENSE_LOWER_CELLS: usize = 32;
/// mu cells of a Smith dense-side row above its critical cosine (`UPPER`).
const UPPER_CELLS: usize = TABLE_MU_DIELECTRIC - 1 - DENSE_LOWER_CELLS;
/// mu cells of a V-cavity dense-side row below its critical cosine, in its
/// three segments (`Lower::Split`): up to the onset of transmission, up to
/// that of full visibility, up to the critical cosine. Against 32 cells in
/// one segment, the sweep of the compensated albedo (mu 0.04 to 1 in steps
/// of 0.01, originals 0-0.3 widened to 0.15-1, eta 1/1.05-1/2.4) fell from
/// 1.75e-3 to 9.1e-4 for Beckmann (from 1.0e-3 to 9.0e-4 for GGX; 9.7e-4
/// for Blinn-Phong). With
/// 32 cells split (8 + 16 + 8, four spacings tried) the error of a single
/// row at a table node stayed at 0.9-1.4e-3, next to x1 (whose kink the
/// cubics round off over 0.02 on both sides) and to the critical cosine.
const VCAVITY_LOWER_CELLS: [usize; 3] = [16, 24, 16];
/// mu cells of a V-cavity dense-side row above its critical cosine
/// (`VCAVITY_UPPER`). Its albedo has features there that Smith's has not:
/// where the facets that refract wi stop being fully visible, at cosines of
/// the order of alpha, which near index matching lie just above the kink.
/// With Smith's 31 cells the compensated albedo missed them by up to
/// 1.66e-3 (Beckmann, eta 1/1.001, 0.03 -> 0.6, mu 0.08) and 6.2e-4 at eta
/// 1/1.05 (GGX, mu 0.96); with 47 by 7.3e-4 and 1.5e-4.
const VCAVITY_UPPER_CELLS: usize = 47;
/// Table nodes in mu per row with V-cavity shadowing: every row of a table
/// has the same length, so its rare side has them too (uniform in sqrt(mu)).
/// A V-cavity interface's tables take 1.4x (albedo) and 1.6-1.7x (gain
/// slices, `crate::compensation::dielectric_gain`) the time they took with 64 (eta 1.5,
/// one core: 4.4 -> 6.4 s and 3.2 -> 5.1 s for GGX, 3.2 -> 4.7 s and 4.1 ->
/// 6.9 s for Beckmann) with 88 nodes, and with these 104 1.2x and 1.5x that
/// (6.4 -> 7.4 s and 5.1 -> 7.5 s for GGX, 4.7 -> 5.5 s and 7.0 -> 10.3 s
/// for Beckmann; side by side on an idle host).
pub(crate) const TABLE_MU_VCAVITY: usize = VCAVITY_LOWER_CELLS[0]
    + VCAVITY_LOWER_CELLS[1]
    + VCAVITY_LOWER_CELLS[2]
    + VCAVITY_UPPER_CELLS
    + 1;
/// The longest row (for arrays on the stack).
const MAX_MU_NODES: usize = TABLE_MU_VCAVITY;

/// Table nodes in mu per row of `shadowing`'s tables.
pub(crate) fn table_mu_nodes(shadowing: Shadowing) -> usize {
    match shadowing {
        Shadowing::Smith => TABLE_MU_DIELECTRIC,
        Shadowing::VCavity => TABLE_MU_VCAVITY,
    }
}
/// (radial Gauss-Legendre, half-azimuth midpoint) nodes of the quadrature
/// for queries from the rare side (eta >= 1). With Smith shadowing the
/// integrand is smooth there and 32 x 32 nodes agree with 256 x 256 to
/// 1e-4. V-cavity's min() has kinks the product rule does not follow, which
/// matter near grazing: at mu >= 0.04 (Beckmann, eta 1.05-2.2, alpha
/// 0.03-1) 32 x 32 nodes were 4.7e-3 off 192 x 192, 64 x 64 are 2.1e-4 off,
/// at no measurable cost beside the dense side's rule (GGX/V-cavity, the
/// four slices of eta 1.5: 9.5-9.7 s against 9.1-10.3 s with 32 x 32, side
/// by side, release, one core).
fn quadrature_rare(shadowing: Shadowing) -> (usize, usize) {
    match shadowing {
        Shadowing::Smith => (32, 32),
        Shadowing::VCavity => (64, 64),
    }
}
/// (radial, azimuthal) Gauss-Legendre nodes per piece of the split rule
/// (`SplitQuadrature`) from the dense side (eta < 1), where F reaches 1
/// with an infinite slope along the curve of total internal reflection: a
/// product rule cut by that curve was off by up to 1.7e-3 at 64 x 64 nodes
/// (GGX/Smith, alpha 0.9, normal incidence) against 256 x 256; split, 20 x
/// 20 nodes per piece (2 to 8 pieces, 800 to 3200 evaluations) are within
/// 1e-3 of it except near normal incidence at alpha about 0.45 (1.5e-3,
/// eta 1/2.2): the kinks left unsplit (module docs of `SplitQuadrature`).
const QUADRATURE_DENSE: (usize, usize) = (16, 16);
/// The split rule of V-cavity slices near index matching (critical cosine
/// below `VCAVITY_FINE_CRITICAL`), where V-cavity's unsplit kinks sit just
/// above the critical cosine, at cosines of the order of alpha: there 16 x
/// 16 nodes per piece were 6e-4 off 64 x 64 (GGX, eta 1/1.0013, mu 0.12,
/// alpha 0.2 and 0.75, with opposite signs) and the compensated albedo
/// missed by 1.29e-3; with 24 x 24 by 4.5e-4.
const QUADRATURE_DENSE_VCAVITY_FINE: (usize, usize) = (24, 24);
/// Critical cosine below which V-cavity slices take
/// `QUADRATURE_DENSE_VCAVITY_FINE` (eta within 1.011 of 1).
const VCAVITY_FINE_CRITICAL: f32 = 0.15;

/// The split rule's nodes per piece for the slice at critical cosine `c`.
fn quadrature_dense(shadowing: Shadowing, c: f32) -> (usize, usize) {
    match shadowing {
        Shadowing::VCavity if c < VCAVITY_FINE_CRITICAL => QUADRATURE_DENSE_VCAVITY_FINE,
        _ => QUADRATURE_DENSE,
    }
}
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
pub(crate) fn seen(eta: f32, side: usize) -> f32 {
    if side == ABOVE { eta } else { 1.0 / eta }
}

/// Medium of the query direction: the table of queries from the rarer
/// medium (index ratio seen >= 1) and that of the denser one.
pub(crate) const RARE: usize = 0;
/// See [`RARE`].
pub(crate) const DENSE: usize = 1;

/// The cosine of the interface's critical angle, c = sqrt(1 - 1/eta_r^2)
/// with eta_r = max(eta, 1/eta) (Snell: sin theta_c = 1/eta_r), clamped to
/// [0, c(`ETA_MAX`)]; with the medium of a query seeing `eta` (`RARE` or `DENSE`).
///
/// Why the tables are tabulated in c rather than in eta: from the dense side
/// total internal reflection sets in at mu = c, where the albedo has a kink
/// whose position moves with eta; from the rare side a grazing query
/// refracts to the cosine c (cos^2 theta_t = c^2 + mu^2/eta^2), so near
/// eta = 1 the albedo moves with c, not with eta - 1 (which is c^2/2 there).
/// Tables uniform in 1 - eta^{+-2} missed both: up to 6.6e-2 at eta 1/1.05
/// and 4.8e-3 at eta 1.05 (mu 0.1) against a 256 x 256 quadrature.
pub(crate) fn critical_cosine(eta: f32) -> (usize, f32) {
    let (medium, ratio) = if eta < 1.0 {
        (DENSE, eta)
    } else {
        (RARE, eta.recip())
    };
    // NaN (eta <= 0 or NaN, which no valid lobe has) lands on c = 0.
    let c = (1.0 - ratio * ratio).max(0.0).sqrt();
    (medium, if c.is_nan() { 0.0 } else { c.min(CRITICAL_MAX) })
}

/// c of `ETA_MAX`, sqrt(1 - 1/3^2) = sqrt(8)/3: the last node of both
/// sides' tables (checked against `ETA_MAX` by a unit test).
const CRITICAL_MAX: f32 = 0.942_809_04;

/// c of table node i: c = c_max v (s + (1 - s) v), v = i / (`TABLE_CRITICAL` - 1),
/// s = `CRITICAL_START_SLOPE`.
pub(crate) fn critical_node(i: usize) -> f32 {
    let v = i as f64 / (TABLE_CRITICAL - 1) as f64;
    let s = CRITICAL_START_SLOPE;
    (f64::from(CRITICAL_MAX) * v * (s + (1.0 - s) * v)) as f32
}

/// dc/dv of the critical-cosine nodes at c = 0 over c_max (`critical_node`;
/// 2 - s at the end): the nodes are three times as dense near index
/// matching as at c_max.
const CRITICAL_START_SLOPE: f64 = 0.5;

/// (cell index, fraction) of the critical cosine `c` on the nodes, the
/// fraction in v (`critical_node`, inverted in the form that does not
/// cancel at small c).
pub(crate) fn critical_cell(c: f32) -> (usize, f32) {
    let r = (c / CRITICAL_MAX).clamp(0.0, 1.0);
    let slope = CRITICAL_START_SLOPE as f32;
    let v = 2.0 * r / (slope + (slope * slope + 4.0 * (1.0 - slope) * r).sqrt());
    let position = v * (TABLE_CRITICAL - 1) as f32;
    let i = (position as usize).min(TABLE_CRITICAL - 2);
    (i, position - i as f32)
}

/// The nodes in mu of one table row (`table_mu_nodes` of its shadowing).
///
/// - `Rare`: uniform in sqrt(mu), as the conductor tables (`crate::compensation::energy`):
///   the albedo changes fastest near grazing.
/// - `Dense { critical: c, lower }`: segments that meet at the kink mu = c
///   (total internal reflection of the smooth interface), a node at every
///   eta: below it cells in x = mu/c (`Lower`), above it `UPPER_CELLS`
///   (V-cavity: `VCAVITY_UPPER_CELLS`) cells in the refracted cosine
///   t = sqrt((mu^2 - c^2)/(1 - c^2)) = cos theta_t, in which the smooth
///   interface's transmittance starts linearly (1 - F ~ cos theta_t, while
///   it has an infinite slope in mu). Rows of neighbouring c are
///   interpolated at equal (x, t), kink to kink. The nodes cluster at the
///   ends of the segments (`Segment`): grazing incidence; just below the
///   kink, where narrow lobes fall over a cosine of the order of alpha; just
///   above it, where the albedo of nearly index-matched interfaces climbs
///   steeply over a cosine of the order of alpha; and normal incidence,
///   where their wide lobes' feature at mu = eta lies. The cubics are read
///   at the fraction of a cell in the node index (`Segment::cell`).
///   Against nodes uniform in sqrt(mu/c) and in t, a sweep of the
///   compensated albedo (mu in steps of 0.01, originals 0-0.3 widened to
///   0.15-1 in ten steps) fell, for GGX/Smith, from 1.8e-3 to 7.2e-4 at eta
///   1/1.0056 and from 4.3e-3 to 1.8e-3 at 1/1.0017, while it stayed within
///   8.0e-4 elsewhere (7.6e-4 before); for Beckmann/V-cavity at eta
///   1/1.05-1/2.4 from 4.6e-3 to 1.75e-3, and to 9.1e-4 with its rows split
///   at its onsets (`Lower::Split`). Read at the index fraction (and with
///   critical-cosine nodes denser near 0, `TABLE_CRITICAL`), 3.3e-4 at
///   1/1.0017 and at most 6.3e-4 elsewhere for GGX/Smith, 8.3e-4 for
///   Beckmann/V-cavity (with `VCAVITY_UPPER_CELLS`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum MuGrid {
    Rare { shadowing: Shadowing },
    Dense { critical: f32, lower: Lower },
}

/// The cells of a dense-side row below its kink, in x = mu / c.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Lower {
    /// Smith: one segment of `DENSE_LOWER_CELLS` cells (`LOWER`).
    Whole,
    /// V-cavity: three segments of `VCAVITY_LOWER_CELLS` cells, split at
    /// the onsets [x0, x1] of transmission and of full visibility, where
    /// the albedo has kinks (`crate::compensation::vcavity_onsets`; at c, `onsets_at`).
    /// The first segment's cells grow from grazing (`Spacing::Start`), the
    /// others cluster at both ends (`Spacing::BothEnds`), at the onsets and
    /// at the critical cosine.
    Split([f64; 2]),
}

impl Lower {
    /// Its cells.
    fn cells(self) -> usize {
        match self {
            Self::Whole => DENSE_LOWER_CELLS,
            Self::Split(_) => VCAVITY_LOWER_CELLS.iter().sum(),
        }
    }

    /// Its segments.
    fn segments(self) -> usize {
        match self {
            Self::Whole => 1,
            Self::Split(_) => VCAVITY_LOWER_CELLS.len(),
        }
    }

    /// The shadowing whose rows it divides.
    fn shadowing(self) -> Shadowing {
        match self {
            Self::Whole => Shadowing::Smith,
            Self::Split(_) => Shadowing::VCavity,
        }
    }

    /// (first node, x of the first node, x-length) of segment s.
    fn segment_bounds(self, s: usize) -> (usize, f64, f64) {
        match self {
            Self::Whole => (0, 0.0, 1.0),
            Self::Split([x0, x1]) => {
                let [a, b, _] = VCAVITY_LOWER_CELLS;
                [(0, 0.0, x0), (a, x0, x1 - x0), (a + b, x1, 1.0 - x1)][s]
            }
        }
    }

    /// The segment of cell j (< `cells`).
    fn segment_of(self, j: usize) -> usize {
        match self {
            Self::Whole => 0,
            Self::Split(_) => {
                let [a, b, _] = VCAVITY_LOWER_CELLS;
                usize::from(j >= a) + usize::from(j >= a + b)
            }
        }
    }

    /// The nodes of segment s in its own coordinate, 0 to 1.
    fn unit_nodes(self, s: usize) -> &'static [f64] {
        match (self, s) {
            (Self::Whole, _) => &LOWER.x,
            (Self::Split(_), 0) => &GRAZING_SEGMENT.x,
            (Self::Split(_), 1) => &ONSETS_SEGMENT.x,
            (Self::Split(_), _) => &VISIBLE_SEGMENT.x,
        }
    }

    /// (x, dx/dtau) at fraction tau of cell j (`Segment::unit`), x in its
    /// segment's own coordinate.
    fn unit_at(self, j: usize, tau: f64) -> (f64, f64) {
        let s = self.segment_of(j);
        let k = j - self.segment_bounds(s).0;
        match (self, s) {
            (Self::Whole, _) => LOWER.unit(k, tau),
            (Self::Split(_), 0) => GRAZING_SEGMENT.unit(k, tau),
            (Self::Split(_), 1) => ONSETS_SEGMENT.unit(k, tau),
            (Self::Split(_), _) => VISIBLE_SEGMENT.unit(k, tau),
        }
    }

    /// x of node j (<= `cells`).
    fn x(self, j: usize) -> f64 {
        let s = self.segment_of(j.min(self.cells() - 1));
        let (first, start, length) = self.segment_bounds(s);
        start + length * self.unit_nodes(s)[j - first]
    }

    /// (cell, fraction linear in x) of x in [0, 1].
    fn cell(self, x: f64) -> (usize, f32) {
        match self {
            Self::Whole => LOWER.cell(x),
            Self::Split([x0, x1]) => {
                let s = usize::from(x >= x0) + usize::from(x >= x1);
                let (first, start, length) = self.segment_bounds(s);
                let unit = (x - start) / length;
                let (k, fraction) = match s {
                    0 => GRAZING_SEGMENT.cell(unit),
                    1 => ONSETS_SEGMENT.cell(unit),
                    _ => VISIBLE_SEGMENT.cell(unit),
                };
                (first + k, fraction)
            }
        }
    }

    /// The nodes `first..=last` of the segment of cell j.
    fn segment(self, j: usize) -> (usize, usize) {
        let s = self.segment_of(j);
        let first = self.segment_bounds(s).0;
        (first, first + self.unit_nodes(s).len() - 1)
    }

    /// The cells above the kink of the rows it divides, in t (`UPPER`,
    /// `VCAVITY_UPPER`).
    fn upper_cells(self) -> usize {
        match self {
            Self::Whole => UPPER_CELLS,
            Self::Split(_) => VCAVITY_UPPER_CELLS,
        }
    }

    /// t of node k above the kink.
    fn upper_x(self, k: usize) -> f64 {
        match self {
            Self::Whole => UPPER.x[k],
            Self::Split(_) => VCAVITY_UPPER.x[k],
        }
    }

    /// (cell, fraction) of t above the kink (`Segment::cell`).
    fn upper_cell(self, t: f64) -> (usize, f32) {
        match self {
            Self::Whole => UPPER.cell(t),
            Self::Split(_) => VCAVITY_UPPER.cell(t),
        }
    }

    /// (t, dt/dtau) at fraction tau of cell k above the kink (`Segment::unit`).
    fn upper_unit(self, k: usize, tau: f64) -> (f64, f64) {
        match self {
            Self::Whole => UPPER.unit(k, tau),
            Self::Split(_) => VCAVITY_UPPER.unit(k, tau),
        }
    }
}

impl MuGrid {
    /// The grid of `shadowing`'s rows queried from `medium` of an interface
    /// with critical cosine `critical`.
    pub(crate) fn of(shadowing: Shadowing, medium: usize, critical: f32) -> Self {
        if medium == RARE {
            return Self::Rare { shadowing };
        }
        let lower = match shadowing {
            Shadowing::Smith => Lower::Whole,
            Shadowing::VCavity => Lower::Split(onsets_at(critical)),
        };
        Self::Dense { critical, lower }
    }

    /// Its nodes.
    pub(crate) fn len(self) -> usize {
        match self {
            Self::Rare { shadowing } => table_mu_nodes(shadowing),
            Self::Dense { lower, .. } => lower.cells() + lower.upper_cells() + 1,
        }
    }

    /// mu of node j (at least `GRAZING_MU`, as the conductor tables).
    fn node(self, j: usize) -> f64 {
        match self {
            Self::Rare { .. } => (j as f64 / (self.len() - 1) as f64).powi(2).max(GRAZING_MU),
            Self::Dense { critical, lower } => {
                let c = f64::from(critical);
                let mu = if j <= lower.cells() {
                    c * lower.x(j)
                } else {
                    let t = lower.upper_x(j - lower.cells());
                    (c * c + (1.0 - c * c) * t * t).sqrt()
                };
                mu.clamp(GRAZING_MU, 1.0)
            }
        }
    }

    /// (cell index, fraction in the cell) of `mu`.
    pub(crate) fn cell(self, mu: f32) -> (usize, f32) {
        match self {
            Self::Rare { .. } => cell(mu, self.len(), 1.0),
            Self::Dense { critical: c, lower } => {
                let (mu, c) = (f64::from(mu.clamp(0.0, 1.0)), f64::from(c));
                if mu < c {
                    lower.cell(mu / c)
                } else {
                    // In f64: mu^2 - c^2 cancels just above the kink.
                    let t = ((mu * mu - c * c) / (1.0 - c * c)).max(0.0).sqrt();
                    let (k, fraction) = lower.upper_cell(t);
                    (lower.cells() + k, fraction)
                }
            }
        }
    }

    /// d(mu^2)/d tau in cell j at fraction tau (`cell`): the measure 2 mu
    /// dmu of the cosine-weighted average, a polynomial in tau of degree 3
    /// from the rare side and at most 7 from the dense side (whose
    /// `Spacing`s are polynomials of degree up to 4 in the node index).
    fn measure(self, j: usize, tau: f64) -> f64 {
        match self {
            Self::Rare { .. } => {
                // mu = s^2, s = (j + tau) h: mu^2 = s^4.
                let h = 1.0 / (self.len() - 1) as f64;
                let s = (j as f64 + tau) * h;
                4.0 * s.powi(3) * h
            }
            Self::Dense { critical, lower } => {
                // mu^2 = c^2 x^2 below the kink (x = p + L v in a segment
                // from p of length L), c^2 + (1 - c^2) t^2 above it.
                let c2 = f64::from(critical).powi(2);
                if j < lower.cells() {
                    let (_, p, length) = lower.segment_bounds(lower.segment_of(j));
                    let (v, dv) = lower.unit_at(j, tau);
                    2.0 * c2 * (p + length * v) * length * dv
                } else {
                    let (t, dt) = lower.upper_unit(j - lower.cells(), tau);
                    2.0 * (1.0 - c2) * t * dt
                }
            }
        }
    }

    /// (node, weight) of the row's cubic at `mu` (`cell`; within the
    /// segment, `catmull_rom_weights`, the same spline as
    /// `catmull_rom_cubic`).
    fn weights(self, mu: f32) -> [(usize, f32); 4] {
        let (j, t) = self.cell(mu);
        let (first, last) = self.segment(j);
        catmull_rom_weights(j - first, t, last - first + 1).map(|(n, w)| (first + n, w))
    }

    /// The nodes `first..=last` of the segment of cell j, inside which the
    /// table is one cubic spline (`catmull_rom_cubic`): the whole row from
    /// the rare side; from the dense side those below the kink at c
    /// (`Lower::segment`) and those above it.
    pub(crate) fn segment(self, j: usize) -> (usize, usize) {
        match self {
            Self::Dense { lower, .. } if j < lower.cells() => lower.segment(j),
            Self::Dense { lower, .. } => (lower.cells(), self.len() - 1),
            Self::Rare { .. } => (0, self.len() - 1),
        }
    }

    /// 2 int_0^1 max(0, y) mu dmu for y the cubic spline of each segment
    /// through the node values `nodes` (as `DielectricAlbedoTable::albedo`
    /// interpolates), exact (`crate::compensation::energy::spline_positive_moment`: the
    /// integrands, a cubic times `measure`, have degree at most 10, which
    /// 8-point Gauss-Legendre integrates exactly). So dE_avg is the moment
    /// of the very dE that `DielectricCompensation::deficit` interpolates,
    /// and the furnace identity holds for the interpolated dE.
    fn positive_part_moment(self, nodes: &[f32]) -> f64 {
        let weights = self.moment_weights();
        spline_positive_moment(
            nodes,
            &weights[..self.len()],
            |j| self.segment(j),
            |j, t| self.measure(j, t),
            gauss_legendre_8(),
        )
    }

    /// The moment weights of the grid's nodes (`spline_moment_weights`),
    /// from fixed parts (`MomentParts`): below the kink a segment from
    /// x = p of length L has the measure c^2 (p L 2 dv + L^2 2 v dv) in its
    /// own coordinate v (x = p + L v), above it the measure is (1 - c^2)
    /// that of c = 0.
    fn moment_weights(self) -> [f64; MAX_MU_NODES] {
        let mut weights = [0.0; MAX_MU_NODES];
        match self {
            Self::Rare { shadowing } => {
                let parts = MomentParts::of(shadowing);
                weights[..parts.rare.len()].copy_from_slice(&parts.rare);
            }
            Self::Dense { critical, lower } => {
                let parts = MomentParts::of(lower.shadowing());
                let c2 = f64::from(critical).powi(2);
                // (p L, L^2) of each segment, hoisted out of the node loop.
                let scales: [(f64, f64); VCAVITY_LOWER_CELLS.len()] = std::array::from_fn(|s| {
                    let (_, p, length) = lower.segment_bounds(s.min(lower.segments() - 1));
                    (p * length, length * length)
                });
                for (i, weight) in weights.iter_mut().enumerate().take(self.len()) {
                    let below: f64 = scales[..lower.segments()]
                        .iter()
                        .enumerate()
                        .map(|(s, (offset, span))| {
                            offset * parts.offset[s][i] + span * parts.span[s][i]
                        })
                        .sum();
                    *weight = c2 * below + (1.0 - c2) * parts.upper[i];
                }
            }
        }
        weights
    }
}

/// The parts of the moment weights of one shadowing's grids that do not
/// depend on c or the onsets (`MuGrid::moment_weights`): of the rare side;
/// of each segment below the kink, for the measures 2 dv (`offset`) and
/// 2 v dv (`span`) in its own coordinate; and above the kink at c = 0.
struct MomentParts {
    rare: Vec<f64>,
    offset: Vec<Vec<f64>>,
    span: Vec<Vec<f64>>,
    upper: Vec<f64>,
}

impl MomentParts {
    fn of(shadowing: Shadowing) -> &'static Self {
        static PARTS: [OnceLock<MomentParts>; 2] = [const { OnceLock::new() }; 2];
        let (slot, lower) = match shadowing {
            Shadowing::Smith => (0, Lower::Whole),
            // Any onsets: the parts are in the segments' own coordinates.
            Shadowing::VCavity => (1, Lower::Split([0.5, 0.75])),
        };
        PARTS[slot].get_or_init(|| {
            let rare = MuGrid::Rare { shadowing };
            let dense = MuGrid::Dense {
                critical: 0.0,
                lower,
            };
            let n = rare.len();
            let of = |grid: MuGrid, measure: &dyn Fn(usize, f64) -> f64| {
                spline_moment_weights(n, |j| grid.segment(j), measure, gauss_legendre_8())
            };
            // A measure in the segment's own coordinate on segment s, 0 elsewhere.
            let on_segment = |s: usize, measure: fn(f64, f64) -> f64| {
                of(dense, &move |j, t| {
                    if j < lower.cells() && lower.segment_of(j) == s {
                        let (v, dv) = lower.unit_at(j, t);
                        measure(v, dv)
                    } else {
                        0.0
                    }
                })
            };
            Self {
                rare: of(rare, &|j, t| rare.measure(j, t)),
                offset: (0..lower.segments())
                    .map(|s| on_segment(s, |_, dv| 2.0 * dv))
                    .collect(),
                span: (0..lower.segments())
                    .map(|s| on_segment(s, |v, dv| 2.0 * v * dv))
                    .collect(),
                // c = 0: only the cells above the kink have a measure.
                upper: of(dense, &|j, t| dense.measure(j, t)),
            }
        })
    }
}

/// The onsets of V-cavity transmission (`crate::compensation::vcavity_onsets::onsets`)
/// for critical cosine `c`: the Catmull-Rom interpolation in c of those of
/// the critical-cosine nodes (`critical_weights`, as the rows'), so that a
/// node's row splits at its own onsets and neighbouring rows are read at
/// the same position relative to theirs.
fn onsets_at(c: f32) -> [f64; 2] {
    static NODES: OnceLock<[[f64; 2]; TABLE_CRITICAL]> = OnceLock::new();
    let nodes = NODES.get_or_init(|| {
        std::array::from_fn(|i| {
            crate::compensation::vcavity_onsets::onsets(f64::from(critical_node(i)))
        })
    });
    critical_weights(c)
        .iter()
        .fold([0.0; 2], |[x0, x1], &(i, w)| {
            let w = f64::from(w);
            [x0 + w * nodes[i][0], x1 + w * nodes[i][1]]
        })
}

/// The nodes of a dense-side `MuGrid` segment of N - 1 cells, from 0 to 1
/// in its own coordinate (x = mu/c below the kink or the refracted cosine t
/// above it, or a part of x between onsets), and for the search of `cell`
/// the cell that holds the start of each of `SEGMENT_BINS` equal bins.
struct Segment<const N: usize> {
    x: [f64; N],
    spacing: Spacing,
    bin_cell: [u8; SEGMENT_BINS],
}

/// How the nodes of a `Segment` are spaced, in u = k / (N - 1).
#[derive(Clone, Copy)]
enum Spacing {
    /// x = u^2 (3 + 2u - 3u^2) / 2: increasing on [0, 1] and clustered at
    /// both ends, as u^2 at x = 0 and as (1 - u)^2 at x = 1.
    BothEnds,
    /// x = u (1 + u) / 2: cells that grow threefold from x = 0, with x''' =
    /// 0. The cubics are splines in the node index, so a map with a large
    /// x''' bends them: 16 cells spaced `BothEnds` (x''' up to 30) missed a
    /// smooth albedo below the onset of V-cavity transmission by 2.8e-3,
    /// spaced thus by 4e-4 at most (eta 1/1.5 and 1/2, alpha 0.03-1).
    Start,
}

impl Spacing {
    /// x at u.
    const fn at(self, u: f64) -> f64 {
        match self {
            Spacing::BothEnds => 0.5 * u * u * (3.0 + u * (2.0 - 3.0 * u)),
            Spacing::Start => 0.5 * u * (1.0 + u),
        }
    }

    /// dx/du at u.
    fn slope(self, u: f64) -> f64 {
        match self {
            Spacing::BothEnds => 3.0 * u * (1.0 - u) * (1.0 + 2.0 * u),
            Spacing::Start => 0.5 + u,
        }
    }

    /// The u in the cell [lo, hi] (x from x_lo to x_hi) where x(u) = `x`:
    /// exact for `Start`; for `BothEnds` `NEWTON_STEPS` of Newton's method
    /// from the chord, or in the end cells (where x' vanishes at u = 0 and
    /// 1) from the leading terms x ~ 3u^2/2 and 1 - x ~ 9(1 - u)^2/2.
    fn inverse(self, x: f64, (lo, hi): (f64, f64), (x_lo, x_hi): (f64, f64)) -> f64 {
        match self {
            // u^2 + u - 2x = 0, in the form that does not cancel at x ~ 0.
            Spacing::Start => 4.0 * x / (1.0 + (1.0 + 8.0 * x).sqrt()),
            Spacing::BothEnds => {
                let mut u = if lo == 0.0 {
                    (x / 1.5).sqrt()
                } else if hi == 1.0 {
                    1.0 - ((1.0 - x) / 4.5).max(0.0).sqrt()
                } else {
                    lo + (hi - lo) * (x - x_lo) / (x_hi - x_lo)
                };
                for _ in 0..NEWTON_STEPS {
                    let slope = self.slope(u);
                    if slope > 0.0 {
                        u -= (self.at(u) - x) / slope;
                    }
                }
                u.clamp(lo, hi)
            }
        }
    }
}

/// Newton steps of `Spacing::inverse`, which a lookup pays on every query
/// from the dense side: from the chord of a cell next to an end cell (the
/// worst start, 1/12 of a cell off) the error falls to 2e-3 and 3e-6 of a
/// cell, which moves an interpolated albedo by less than 1e-6.
const NEWTON_STEPS: usize = 2;

/// Bins of `Segment::cell`'s search: narrower than nearly every cell, so
/// that a bin holds at most three nodes (`VCAVITY_UPPER`'s first; two
/// elsewhere).
const SEGMENT_BINS: usize = 256;

impl<const N: usize> Segment<N> {
    /// The segment of N nodes spaced `spacing`.
    const fn new(spacing: Spacing) -> Self {
        assert!(
            N >= 3 && N - 1 <= u8::MAX as usize,
            "cells must fit bin_cell"
        );
        let mut x = [0.0; N];
        let mut k = 0;
        while k < N {
            let u = k as f64 / (N - 1) as f64;
            x[k] = spacing.at(u);
            k += 1;
        }
        let mut bin_cell = [0; SEGMENT_BINS];
        let (mut b, mut cell) = (0, 0);
        while b < SEGMENT_BINS {
            while cell + 2 < N && x[cell + 1] <= b as f64 / SEGMENT_BINS as f64 {
                cell += 1;
            }
            bin_cell[b] = cell as u8;
            b += 1;
        }
        Self {
            x,
            spacing,
            bin_cell,
        }
    }

    /// (cell, fraction) of x in [0, 1], the fraction in the node index u
    /// (x = x(u)), in which the rows' cubics are splines
    /// (`catmull_rom_weights`). A fraction linear in x read them at the
    /// wrong u, by up to 1/(4(2k + 1)) of a cell in cell k from an end where
    /// the nodes cluster as u^2: near index matching, where the albedo
    /// climbs by 0.065 per cell just above the kink (GGX/Smith, eta
    /// 1/1.0013, alpha 0.15, mu 0.075), that missed it by 1.7e-3.
    fn cell(&self, x: f64) -> (usize, f32) {
        let x = x.clamp(0.0, 1.0);
        let bin = ((x * SEGMENT_BINS as f64) as usize).min(SEGMENT_BINS - 1);
        let mut k = usize::from(self.bin_cell[bin]);
        while k + 2 < N && self.x[k + 1] <= x {
            k += 1;
        }
        let u = self
            .spacing
            .inverse(x, Self::bounds(k), (self.x[k], self.x[k + 1]));
        (k, (u * (N - 1) as f64 - k as f64).clamp(0.0, 1.0) as f32)
    }

    /// u at the ends of cell k, as quotients: the last cell ends at exactly 1.
    fn bounds(k: usize) -> (f64, f64) {
        let cells = (N - 1) as f64;
        (k as f64 / cells, (k + 1) as f64 / cells)
    }

    /// (x, dx/dtau) at fraction tau of cell k (`cell`).
    fn unit(&self, k: usize, tau: f64) -> (f64, f64) {
        let h = 1.0 / (N - 1) as f64;
        let u = (k as f64 + tau) * h;
        (self.spacing.at(u), self.spacing.slope(u) * h)
    }
}

/// The segment below a Smith dense-side row's kink (`Lower::Whole`).
const LOWER: Segment<{ DENSE_LOWER_CELLS + 1 }> = Segment::new(Spacing::BothEnds);
/// The segment above a Smith dense-side row's kink.
const UPPER: Segment<{ UPPER_CELLS + 1 }> = Segment::new(Spacing::BothEnds);
/// The segment above a V-cavity dense-side row's kink.
const VCAVITY_UPPER: Segment<{ VCAVITY_UPPER_CELLS + 1 }> = Segment::new(Spacing::BothEnds);
/// The segments of a V-cavity dense-side row below its kink (`Lower::Split`):
/// from grazing to the onset of transmission, to that of full visibility,
/// to the critical cosine.
const GRAZING_SEGMENT: Segment<{ VCAVITY_LOWER_CELLS[0] + 1 }> = Segment::new(Spacing::Start);
/// See [`GRAZING_SEGMENT`].
const ONSETS_SEGMENT: Segment<{ VCAVITY_LOWER_CELLS[1] + 1 }> = Segment::new(Spacing::BothEnds);
/// See [`GRAZING_SEGMENT`].
const VISIBLE_SEGMENT: Segment<{ VCAVITY_LOWER_CELLS[2] + 1 }> = Segment::new(Spacing::BothEnds);

/// Energy albedo E(mu, alpha, eta) of a white rough dielectric (module
/// docs): per medium of the query (`RARE`, `DENSE`), `TABLE_CRITICAL`
/// x `TABLE_ALPHA` x `table_mu_nodes` nodes in (c, alpha, `MuGrid` of c),
/// each critical-cosine node's slice computed at first use: an interface
/// reads the four nodes around its own c (`nodes_read`), so a scene of one
/// glass computes 4 of the 61.
#[derive(Debug)]
pub struct DielectricAlbedoTable {
    kind: NdfKind,
    shadowing: Shadowing,
    slices: [OnceLock<CriticalSlice>; TABLE_CRITICAL],
}

/// The table at one critical-cosine node c_i: `e[medium][k * nodes + j]`
/// = E(mu_j, alpha_k, eta(c_i)), mu_j the node j of the `MuGrid` of c_i.
#[derive(Debug)]
struct CriticalSlice {
    e: [Vec<f32>; 2],
    /// Nodes per row (`table_mu_nodes`).
    nodes: usize,
}

impl CriticalSlice {
    /// The slice of node `i` by quadrature (see [`dielectric_albedo_quadrature`]).
    fn compute(kind: NdfKind, shadowing: Shadowing, i: usize) -> Self {
        let c = critical_node(i);
        let nodes = table_mu_nodes(shadowing);
        let size = TABLE_ALPHA * nodes;
        let mut e = [vec![0.0; size], vec![0.0; size]];
        for k in 0..TABLE_ALPHA {
            let alpha = alpha_node(k);
            // alpha = 0: the smooth interface, R + T = 1 exactly.
            let rules = (alpha > 0.0).then(|| {
                let (radial, azimuth) = quadrature_rare(shadowing);
                (
                    Quadrature::new(kind, shadowing, alpha, radial, azimuth),
                    SplitQuadrature::new(kind, shadowing, alpha, quadrature_dense(shadowing, c)),
                )
            });
            for (medium, row) in e.iter_mut().enumerate() {
                let grid = MuGrid::of(shadowing, medium, c);
                let eta = f64::from(eta_of(medium, c));
                let row = &mut row[k * nodes..(k + 1) * nodes];
                for (j, node) in row.iter_mut().enumerate() {
                    let mu = grid.node(j);
                    *node = rules.as_ref().map_or(1.0, |(rare, dense)| {
                        if medium == RARE {
                            rare.albedo(mu, eta)
                        } else {
                            dense.albedo(mu, Some(eta))
                        }
                    }) as f32;
                }
            }
        }
        Self { e, nodes }
    }

    /// The row of E over the `MuGrid` nodes at alpha node k.
    fn row(&self, medium: usize, k: usize) -> &[f32] {
        &self.e[medium][k * self.nodes..(k + 1) * self.nodes]
    }
}

impl DielectricAlbedoTable {
    /// The table of `kind` with `shadowing`, no slice computed yet.
    pub fn new(kind: NdfKind, shadowing: Shadowing) -> Self {
        Self {
            kind,
            shadowing,
            slices: [const { OnceLock::new() }; TABLE_CRITICAL],
        }
    }

    /// The slice of critical-cosine node `i`, computed at first use.
    fn slice(&self, i: usize) -> &CriticalSlice {
        self.slices[i].get_or_init(|| CriticalSlice::compute(self.kind, self.shadowing, i))
    }

    /// Computes the slice of critical-cosine node `i` now, if not yet (for
    /// callers that compute the slices in parallel, as `nodes_read` lists
    /// them, before any timed work).
    pub(crate) fn prepare_node(&self, i: usize) {
        self.slice(i);
    }

    /// True once the slice of critical-cosine node `i` has been computed
    /// (never computes it).
    pub(crate) fn node_is_built(&self, i: usize) -> bool {
        self.slices[i].get().is_some()
    }

    /// The critical-cosine nodes that queries at index ratio `eta` read,
    /// from either side of the interface (the Catmull-Rom support in c).
    pub(crate) fn nodes_read(eta: f32) -> impl Iterator<Item = usize> {
        critical_weights(critical_cosine(eta).1)
            .into_iter()
            .map(|(i, _)| i)
    }

    /// The slices that interpolation at critical cosine `c` reads, with
    /// their Catmull-Rom weights.
    fn slices_at(&self, c: f32) -> [(&CriticalSlice, f32); 4] {
        critical_weights(c).map(|(i, wc)| (self.slice(i), wc))
    }

    /// E(mu, alpha, eta): cubic in the `MuGrid` coordinate of the query's
    /// c (within its segment), bicubic (Catmull-Rom) in sqrt(alpha)
    /// (`alpha_weights`) and c (`critical_weights`); alpha and eta clamped
    /// to the table.
    pub fn albedo(&self, mu: f32, alpha: f32, eta: f32) -> f32 {
        let [e] = self.albedos(mu, [alpha], eta);
        e
    }

    /// `albedo` at each of `alphas`, sharing the weights in c and mu and
    /// the slices: the tricubic as a sum of weighted table entries.
    pub(crate) fn albedos<const N: usize>(&self, mu: f32, alphas: [f32; N], eta: f32) -> [f32; N] {
        let (medium, c) = critical_cosine(eta);
        let in_mu = MuGrid::of(self.shadowing, medium, c).weights(mu);
        let in_alpha = alphas.map(alpha_weights);
        let mut e = [0.0; N];
        for (slice, wc) in self.slices_at(c) {
            for (e, in_alpha) in e.iter_mut().zip(&in_alpha) {
                for &(k, wa) in in_alpha {
                    let row = slice.row(medium, k);
                    let along: f32 = in_mu.iter().map(|&(j, wm)| wm * row[j]).sum();
                    *e += wc * wa * along;
                }
            }
        }
        e
    }

    /// E at node (c_i, alpha_k) of `medium`, at fraction t of its `MuGrid`
    /// cell j: the row's cubic, as `albedo` interpolates it.
    pub(crate) fn node_albedo(
        &self,
        medium: usize,
        i: usize,
        k: usize,
        (j, t): (usize, f64),
    ) -> f64 {
        let row = self.slice(i).row(medium, k);
        let grid = MuGrid::of(self.shadowing, medium, critical_node(i));
        cubic_at(
            catmull_rom_cubic(|n| f64::from(row[n]), j, grid.segment(j)),
            t,
        )
    }

    /// The table entry at node (c_i, alpha_k, mu_j) of `medium`.
    pub(crate) fn node(&self, medium: usize, i: usize, k: usize, j: usize) -> f32 {
        self.slice(i).row(medium, k)[j]
    }

    /// 2 int_0^1 max(0, dE(mu)) mu dmu of dE = E(mu, alpha, eta) -
    /// E(mu, alpha_hat, eta), interpolated as `albedo` does, and whether
    /// the widened lobe gains (dE below -`MIN_GAIN` at a node).
    pub(crate) fn deficit_average(&self, alpha: f32, alpha_hat: f32, eta: f32) -> (f64, bool) {
        let (medium, c) = critical_cosine(eta);
        // Whole rows weighted and summed (contiguous: vectorized), as `row`
        // weights them node by node.
        let in_c = self.slices_at(c);
        let grid = MuGrid::of(self.shadowing, medium, c);
        let mut nodes = [0.0; MAX_MU_NODES];
        let nodes = &mut nodes[..grid.len()];
        for (alpha, sign) in [(alpha, 1.0), (alpha_hat, -1.0)] {
            for (k, wa) in alpha_weights(alpha) {
                for (slice, wc) in in_c {
                    let row = slice.row(medium, k);
                    for (node, e) in nodes.iter_mut().zip(row) {
                        *node += sign * wc * wa * e;
                    }
                }
            }
        }
        let gains = nodes.iter().any(|&d| d < -MIN_GAIN);
        (grid.positive_part_moment(nodes), gains)
    }
}

/// The azimuth-integrated kernel (`crate::compensation::gain::Kernel`) of the white
/// interface of width `alpha > 0` with the critical cosine of node `i`, by
/// the tables' quadrature rules (its rows sum to the table's nodes): rows
/// and bins in two blocks, the rare medium's ([`RARE`]) and the dense
/// one's, each on its `MuGrid`; reflection stays in its block, refraction
/// lands in the other (`crate::compensation::dielectric_gain`).
pub(crate) fn dielectric_kernel(
    kind: NdfKind,
    shadowing: Shadowing,
    i: usize,
    alpha: f32,
    subdivisions: usize,
) -> Kernel {
    let c = critical_node(i);
    let (radial, azimuth) = quadrature_rare(shadowing);
    let rare = Quadrature::new(kind, shadowing, alpha, radial, azimuth);
    let dense = SplitQuadrature::new(kind, shadowing, alpha, quadrature_dense(shadowing, c));
    let nodes = table_mu_nodes(shadowing);
    let grids = [RARE, DENSE].map(|medium| MuGrid::of(shadowing, medium, c));
    let mut kernel = Kernel::zeros(2, nodes, subdivisions);
    for medium in [RARE, DENSE] {
        let eta = f64::from(eta_of(medium, c));
        for j in 0..nodes {
            let row = medium * nodes + j;
            let deposit = |cos_o: f64, share: f64| {
                let to = if cos_o > 0.0 { medium } else { 1 - medium };
                let (n, t) = grids[to].cell(cos_o.abs() as f32);
                let x = (n as f64 + f64::from(t)) * subdivisions as f64;
                kernel.deposit(row, to, x, share);
            };
            let mu = grids[medium].node(j);
            if medium == RARE {
                rare.albedo_with(mu, eta, deposit);
            } else {
                dense.albedo_with(mu, Some(eta), deposit);
            }
        }
    }
    kernel.finish()
}

/// The shared dielectric table of `kind` with `shadowing`, computed at first use.
/// Each critical-cosine slice is computed at the first lookup that reads it
/// (`crate::compensation::tables` gives the cost; [`crate::prepare_tables`]
/// builds them ahead).
pub fn dielectric_albedo_table(
    kind: NdfKind,
    shadowing: Shadowing,
) -> &'static DielectricAlbedoTable {
    static TABLES: [OnceLock<DielectricAlbedoTable>; MODELS] = [const { OnceLock::new() }; MODELS];
    TABLES[model_index(kind, shadowing)].get_or_init(|| DielectricAlbedoTable::new(kind, shadowing))
}

/// The Catmull-Rom weights in c of the critical-cosine nodes around `c`.
fn critical_weights(c: f32) -> [(usize, f32); 4] {
    let (i, r) = critical_cell(c);
    catmull_rom_weights(i, r, TABLE_CRITICAL)
}

/// The index ratio seen from `medium` whose critical cosine is `c`.
pub(crate) fn eta_of(medium: usize, c: f32) -> f32 {
    let ratio = (1.0 - c * c).sqrt();
    if medium == RARE { ratio.recip() } else { ratio }
}

/// Microfacet normals h_m drawn from D(h)<h,n> on a product rule (Gauss-
/// Legendre in the radial uniform, midpoint over the half azimuth) with their
/// weights: one set per alpha, shared by every mu and eta of the table. The
/// rule of the rare side, whose integrand has no total internal reflection.
struct Quadrature {
    ndf: Ndf,
    shadowing: Shadowing,
    normals: Vec<(Vec3, f64)>,
    smith_g1: SmithG1Table,
}

impl Quadrature {
    fn new(kind: NdfKind, shadowing: Shadowing, alpha: f32, radial: usize, azimuth: usize) -> Self {
        let ndf = Ndf::new(kind, alpha);
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
                let h = ndf.sample_d_cos(Vec2::new(u1 as f32, u2 as f32));
                if h.z > 0.0 {
                    normals.push((h, w1 / azimuth as f64));
                }
            }
        }
        let smith_g1 = SmithG1Table::new(&ndf, shadowing);
        Self {
            ndf,
            shadowing,
            normals,
            smith_g1,
        }
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
        self.albedo_with(mu, eta, |_, _| {})
    }

    /// `albedo`, and each normal's share of each scattered direction passed
    /// to `visit(cos_o, share)` (as `SplitQuadrature::albedo_with`: cos_o > 0
    /// reflected, < 0 refracted). The returned albedo is `albedo`'s.
    fn albedo_with(&self, mu: f64, eta: f64, mut visit: impl FnMut(f64, f64)) -> f64 {
        let mu = mu.max(GRAZING_MU);
        let wi = Vec3::new((1.0 - mu * mu).max(0.0).sqrt() as f32, 0.0, mu as f32);
        let (ndf, shadowing) = (&self.ndf, self.shadowing);
        // Smith's G1(wi) does not depend on h (given <wi,h> > 0).
        let g1_wi = match shadowing {
            Shadowing::Smith => ndf.g1(wi),
            Shadowing::VCavity => 0.0,
        };
        // Both directions below are valid for their side (checked), so
        // Smith's G1(wo) is the tabulated G1 of |<wo,n>|.
        let g = |wo: Vec3, h: Vec3| match shadowing {
            Shadowing::Smith => g1_wi * self.smith_g1.at(wo.z.abs()),
            Shadowing::VCavity => shadowing.masking_shadowing(ndf, wi, wo, h),
        };
        let mut sum = 0.0;
        for &(h, weight) in &self.normals {
            let wi_h = wi.dot(h);
            if !(wi_h > 0.0) {
                continue;
            }
            let (f, t) = fresnel::dielectric_f64(f64::from(wi_h), eta);
            let jacobian = |value: f64| weight * value * f64::from(wi_h) / (mu * f64::from(h.z));
            let mut value = 0.0;
            let wo = 2.0 * wi_h * h - wi;
            if wo.z > 0.0 {
                let reflected = f * f64::from(g(wo, h));
                visit(f64::from(wo.z), jacobian(reflected));
                value += reflected;
            }
            if t > 0.0
                && let Some(wo) = refract_f64(wi, h, eta)
                && wo.z < 0.0
            {
                let refracted = t * f64::from(g(wo, h));
                visit(f64::from(wo.z), jacobian(refracted));
                value += refracted;
            }
            sum += jacobian(value);
        }
        sum
    }
}

/// E(mu, alpha, eta) of one configuration by the tables' quadrature rules
/// with `nodes`: from the rare side (eta >= 1) the product rule
/// (`Quadrature`, (radial, half-azimuth) nodes; the tables use
/// `quadrature_rare`), from the dense side the split rule
/// (`SplitQuadrature`, nodes per piece; the tables use `QUADRATURE_DENSE`);
/// 1 for alpha = 0, the smooth interface. For tests, with finer rules.
pub fn dielectric_albedo_quadrature(
    kind: NdfKind,
    shadowing: Shadowing,
    alpha: f32,
    mu: f64,
    eta: f64,
    nodes: (usize, usize),
) -> f64 {
    dielectric_albedo_quadrature_with(kind, shadowing, alpha, mu, eta, nodes, |_, _| {})
}

/// `dielectric_albedo_quadrature`, and each node's share of each scattered
/// direction passed to `visit(cos_o, share)` (cos_o > 0 reflected, < 0
/// refracted; `SplitQuadrature::albedo_with`); for alpha = 0 none is.
pub(crate) fn dielectric_albedo_quadrature_with(
    kind: NdfKind,
    shadowing: Shadowing,
    alpha: f32,
    mu: f64,
    eta: f64,
    nodes: (usize, usize),
    visit: impl FnMut(f64, f64),
) -> f64 {
    if alpha <= 0.0 {
        return 1.0;
    }
    if eta >= 1.0 {
        Quadrature::new(kind, shadowing, alpha, nodes.0, nodes.1).albedo_with(mu, eta, visit)
    } else {
        SplitQuadrature::new(kind, shadowing, alpha, nodes).albedo_with(mu, Some(eta), visit)
    }
}

/// The hemispherical transmittance T_+ = 2 int_0^1 (1 - F(mu)) mu dmu of the
/// smooth interface seen from above (index ratio `eta`). Integrated on the
/// rarer side, where 1 - F is smooth (no total internal reflection), by
/// Gauss-Legendre; the denser side's follows from n_+^2 T_+ = n_-^2 T_-
/// (module docs), T_+ = eta^2 T_-.
pub(crate) fn transmittance_above(eta: f32) -> f32 {
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn critical_cosines_are_nodes_and_cells_clamp() {
        assert!((CRITICAL_MAX - (1.0 - ETA_MAX.powi(-2)).sqrt()).abs() < 1e-7);
        assert_eq!(critical_cosine(1.0), (RARE, 0.0));
        assert_eq!(critical_cosine(ETA_MAX).1, CRITICAL_MAX);
        assert_eq!(critical_cosine(100.0), (RARE, CRITICAL_MAX));
        assert_eq!(critical_cosine(1e-3), (DENSE, CRITICAL_MAX));
        assert_eq!(critical_cosine(f32::NAN).1, 0.0);
        assert_eq!(critical_cell(CRITICAL_MAX), (TABLE_CRITICAL - 2, 1.0));
        for i in 0..TABLE_CRITICAL {
            let (j, fraction) = critical_cell(critical_node(i));
            assert!(
                (j as f32 + fraction - i as f32).abs() < 1e-4,
                "{i}: {j} {fraction}"
            );
            for medium in [RARE, DENSE] {
                let (m, c) = critical_cosine(eta_of(medium, critical_node(i)));
                assert_eq!(m, if i == 0 { RARE } else { medium });
                assert!((c - critical_node(i)).abs() < 1e-5, "{i}: {c}");
            }
        }
    }

    /// Every grid's nodes are increasing, found again by `cell` (to the
    /// resolution of an f32 cosine: just above the kink one ulp of mu moves
    /// the refracted cosine t by up to 1e-2 of its first cell), the dense
    /// grids have their kink mu = c at the node after their lower cells, and
    /// V-cavity's its onsets at the ends of its first segment.
    #[test]
    fn mu_grids_invert_their_nodes() {
        let grids = [Shadowing::Smith, Shadowing::VCavity].map(|shadowing| {
            [0.0, 0.3, 0.745, CRITICAL_MAX]
                .map(|c| MuGrid::of(shadowing, DENSE, c))
                .into_iter()
                .chain([MuGrid::of(shadowing, RARE, 0.5)])
        });
        for grid in grids.into_iter().flatten() {
            if let MuGrid::Dense { critical, lower } = grid
                && critical > 0.0
            {
                let kink = grid.node(lower.cells());
                assert!((kink - f64::from(critical)).abs() < 1e-6, "{grid:?}");
                if let Lower::Split([x0, x1]) = lower {
                    let [a, b, _] = VCAVITY_LOWER_CELLS;
                    for (j, x) in [(a, x0), (a + b, x1)] {
                        let onset = f64::from(critical) * x;
                        assert!((grid.node(j) - onset).abs() < 1e-12, "{grid:?} {j}");
                    }
                }
            }
            for j in 1..grid.len() {
                let (a, b) = (grid.node(j - 1), grid.node(j));
                assert!(a <= b, "{grid:?} {j}");
                if a > GRAZING_MU {
                    let mu = a as f32;
                    let found = |mu: f32| {
                        let (k, t) = grid.cell(mu);
                        k as f32 + t
                    };
                    let below = found(f32::from_bits(mu.to_bits() - 1));
                    let above = found(f32::from_bits(mu.to_bits() + 1));
                    let node = (j - 1) as f32;
                    assert!(
                        below - 1e-3 < node && node < above + 1e-3,
                        "{grid:?} {j}: {below}..{above}"
                    );
                }
            }
        }
    }

    /// `Segment::cell` finds the cell that holds x, and its fraction in the
    /// node index, at every x: `Spacing::inverse` against bisection.
    #[test]
    fn segments_find_the_cell_of_every_x() {
        fn check<const N: usize>(segment: &Segment<N>) {
            let h = 1.0 / (N - 1) as f64;
            let steps = 100_000;
            for m in 0..=steps {
                let x = m as f64 / steps as f64;
                let (k, t) = segment.cell(x);
                let (x0, x1) = (segment.x[k], segment.x[k + 1]);
                assert!(x0 <= x && (x < x1 || k == N - 2), "{N} {x}: {k}");
                let (mut lo, mut hi) = Segment::<N>::bounds(k);
                for _ in 0..100 {
                    let mid = 0.5 * (lo + hi);
                    if segment.spacing.at(mid) < x {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                let u = segment
                    .spacing
                    .inverse(x, Segment::<N>::bounds(k), (x0, x1));
                // Where x' vanishes (u = 1) bisection stops at x's own resolution.
                let found = (u - lo).abs() < 1e-5 * h || segment.spacing.at(u) == x;
                assert!(found, "{N} {x}: {u} vs {lo}");
                let fraction = f64::from(t);
                assert!(
                    (fraction - (lo / h - k as f64)).abs() < 1e-5,
                    "{N} {x}: {t}"
                );
            }
        }
        check(&LOWER);
        check(&UPPER);
        check(&VCAVITY_UPPER);
        check(&GRAZING_SEGMENT);
        check(&ONSETS_SEGMENT);
        check(&VISIBLE_SEGMENT);
    }

    /// The moment of a dE interpolated by the grid's splines against a fine
    /// midpoint rule in mu over the interpolated function (the V-cavity
    /// dense grid's moment weights from their fixed parts, at its onsets).
    #[test]
    fn positive_part_moment_matches_the_integral() {
        let grids = [Shadowing::Smith, Shadowing::VCavity]
            .map(|shadowing| [RARE, DENSE].map(|medium| MuGrid::of(shadowing, medium, 0.6)));
        for grid in grids.into_iter().flatten() {
            let nodes: Vec<f32> = (0..grid.len())
                .map(|j| (grid.node(j) as f32 * 7.0).sin() - 0.3)
                .collect();
            let n = 400_000;
            let fine: f64 = (0..n)
                .map(|m| {
                    let mu = (m as f64 + 0.5) / n as f64;
                    let (j, t) = grid.cell(mu as f32);
                    let cubic = catmull_rom_cubic(|i| f64::from(nodes[i]), j, grid.segment(j));
                    let y = cubic_at(cubic, f64::from(t));
                    2.0 * y.max(0.0) * mu / n as f64
                })
                .sum();
            let moment = grid.positive_part_moment(&nodes);
            assert!((moment - fine).abs() < 1e-5, "{grid:?}: {moment} vs {fine}");
        }
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
