//! Directional albedos of microfacet lobes by quadrature, for the energy
//! tables of `crate::compensation::energy` (conductors) and `crate::compensation::dielectric_energy`
//! (dielectrics): Gauss-Legendre rules and a rule over microfacet normals
//! split where the integrand is not smooth (`SplitQuadrature`).

use glam::{DVec3, Vec3};

use crate::frame::refract_f64;
use crate::fresnel;
use crate::gauss::gauss_legendre;
use crate::ndf::{Ndf, NdfKind};
use crate::shadowing::Shadowing;

/// The mu = 0 column is evaluated at this cosine: exactly grazing
/// directions have no reflection to integrate (every lobe returns 0 there).
pub(crate) const GRAZING_MU: f64 = 1e-3;

/// Linear interpolation from `a` (t = 0) to `b` (t = 1), shared by every
/// table of the compensation.
pub(crate) fn lerp(a: f32, b: f32, t: f32) -> f32 {
    a + (b - a) * t
}

/// Smith's G1 at |<w,n>| = i/(`SMITH_G1_NODES` - 1), linear between (empty
/// for V-cavity shadowing): G1 of an isotropic NDF depends on the
/// direction's cosine only, and the exact Blinn-Phong Lambda (an incomplete
/// beta function) made a table cost 7 s.
pub(crate) struct SmithG1Table(Vec<f32>);

/// Nodes of `SmithG1Table`, uniform in the cosine: the linear interpolation
/// error is below 1e-6 away from grazing; near grazing G1 falls to 0 within
/// a cosine of about alpha, where the integrand carries little (the table's
/// error budget is 1e-3).
const SMITH_G1_NODES: usize = 4097;

impl SmithG1Table {
    /// The table of `ndf`'s Smith G1 (empty for V-cavity shadowing).
    pub(crate) fn new(ndf: &Ndf, shadowing: Shadowing) -> Self {
        Self(match shadowing {
            Shadowing::Smith => (0..SMITH_G1_NODES)
                .map(|i| {
                    let mu = i as f32 / (SMITH_G1_NODES - 1) as f32;
                    ndf.g1(Vec3::new((1.0 - mu * mu).max(0.0).sqrt(), 0.0, mu))
                })
                .collect(),
            Shadowing::VCavity => Vec::new(),
        })
    }

    /// Smith's G1 at cosine `mu` in [0, 1].
    pub(crate) fn at(&self, mu: f32) -> f32 {
        let x = mu.clamp(0.0, 1.0) * (SMITH_G1_NODES - 1) as f32;
        let i = (x as usize).min(SMITH_G1_NODES - 2);
        lerp(self.0[i], self.0[i + 1], x - i as f32)
    }
}

/// A Gauss-Legendre rule on [0, 1] after the substitution x = v^2 (3 - 2v)
/// (dx = 6 v (1 - v) dv), which flattens both endpoints: an integrand that
/// starts like sqrt(x - a) at an endpoint (the smooth interface's
/// transmittance at its critical angle, the extent of a ring's region
/// beyond a tangency) or with an integrable 1/sqrt singularity becomes smooth
/// in v, and the rule converges fast again.
fn flattened_rule(nodes: usize) -> Vec<(f64, f64)> {
    gauss_legendre(nodes)
        .into_iter()
        .map(|(v, w)| (v * v * (3.0 - 2.0 * v), w * 6.0 * v * (1.0 - v)))
        .collect()
}

/// E(mu, alpha, eta) by quadrature over microfacet normals in the
/// coordinates of the NDF's D(h)<h,n> sampler (u1 -> theta_h, phi = 2 pi u2),
/// split where the integrand is not smooth, so that each piece is smooth
/// and a Gauss-Legendre rule (`flattened_rule`) converges fast:
///
/// - in azimuth, on each ring theta_h, at the phi where <wi,h> equals the
///   cosine of total internal reflection (1 - F has an infinite slope
///   there), where the reflected direction reaches the horizon (2 <wi,h>
///   cos theta_h = mu, where G1 of it has a kink) and where <wi,h> = 0 (the
///   back-facing cut, beyond which the integrand is 0); <wi,h> = sin
///   theta_i sin theta_h cos phi + cos theta_i cos theta_h, so every such
///   phi is explicit;
///   With V-cavity shadowing also where its min() of the reflection
///   switches (`vcavity_kinks`);
/// - in theta_h, where a ring becomes tangent to those curves
///   (theta_h = |theta_c' -+ theta_i| for total internal reflection,
///   theta_c' the angle of its circle around wi; pi/4 -+ theta_i/2 for the
///   reflected horizon; pi/2 - theta_i for the back-facing circle; found
///   numerically for V-cavity's, `vcavity_tangent_rings`), where the rings'
///   integrals have a square-root onset; and for GGX geometrically towards
///   the horizon (`TAIL_BREAKS`).
///
/// A product rule over the whole square (the previous tables') cut the
/// total-internal-reflection curve and converged slowly: 64 x 64 nodes were
/// off by up to 1.7e-3 from the dense side (GGX/Smith, alpha 0.9, normal
/// incidence) against 256 x 256; without the reflected horizon's breaks, 20
/// x 20 split nodes by 1.4e-3. For a white conductor 16 x 16 nodes per
/// piece are within 5e-5 of 64 x 64 for every NDF and shadowing model.
/// The remaining kinks (V-cavity's min() of a refraction, the refracted
/// direction's horizon) are not split.
pub(crate) struct SplitQuadrature {
    ndf: Ndf,
    shadowing: Shadowing,
    radial: Vec<(f64, f64)>,
    azimuth: Vec<(f64, f64)>,
    smith_g1: SmithG1Table,
}

impl SplitQuadrature {
    /// The rule for the NDF `kind` at `alpha` with `shadowing` with `nodes` = (radial,
    /// azimuthal) Gauss-Legendre nodes per piece.
    pub(crate) fn new(
        kind: NdfKind,
        shadowing: Shadowing,
        alpha: f32,
        nodes: (usize, usize),
    ) -> Self {
        let ndf = Ndf::new(kind, alpha);
        let smith_g1 = SmithG1Table::new(&ndf, shadowing);
        Self {
            ndf,
            shadowing,
            radial: flattened_rule(nodes.0),
            azimuth: flattened_rule(nodes.1),
            smith_g1,
        }
    }

    /// The radial uniform u1 whose ring has polar angle `theta`: bisection
    /// on the sampler's polar angle (`Ndf::d_cos_polar`), which grows with
    /// u1 for GGX and Beckmann and falls for Blinn-Phong (cos^2 = u1^(alpha^2)).
    fn radial_uniform(&self, theta: f64) -> f64 {
        let cos2 = theta.cos().powi(2);
        let cos2_of = |u1: f64| self.ndf.d_cos_polar(u1).0;
        let rising = cos2_of(1.0) > cos2_of(0.0);
        let (mut lo, mut hi) = (0.0f64, 1.0f64);
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            if (cos2_of(mid) > cos2) != rising {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    }

    /// E(mu, alpha, eta) of the white dielectric of index ratio `eta`
    /// (`dielectric_energy::Quadrature::albedo` gives the integrand), or
    /// with `eta` = `None` E(mu, alpha) of the white conductor (F = 1, no
    /// transmission).
    pub(crate) fn albedo(&self, mu: f64, eta: Option<f64>) -> f64 {
        self.albedo_with(mu, eta, |_, _| {})
    }

    /// `albedo`, and each node's share of each scattered direction passed
    /// to `visit(cos_o, share)`, with cos_o the cosine of the reflected
    /// (> 0) or refracted (< 0) direction: the shares sum to the albedo, and
    /// binned by cos_o they give the azimuth-integrated kernels of
    /// `crate::compensation::gain` and `crate::compensation::dielectric_gain`. The returned albedo is
    /// `albedo`'s, bit for bit.
    pub(crate) fn albedo_with(
        &self,
        mu: f64,
        eta: Option<f64>,
        mut visit: impl FnMut(f64, f64),
    ) -> f64 {
        let mu = mu.clamp(GRAZING_MU, 1.0);
        let sin_i = (1.0 - mu * mu).max(0.0).sqrt();
        let wi = DVec3::new(sin_i, 0.0, mu);
        let theta_i = mu.acos();
        // <wi,h> below which the smooth interface reflects totally (from the
        // dense side), and the angle of that circle around wi.
        let tir = eta
            .filter(|&eta| eta < 1.0)
            .map(|eta| (1.0 - eta * eta).sqrt());
        let (half_pi, quarter_pi) = (std::f64::consts::FRAC_PI_2, std::f64::consts::FRAC_PI_4);
        // Back-facing circle, and the rings tangent to the curve where the
        // reflected direction reaches the horizon (2 <wi,h> cos theta_h =
        // mu, i.e. cos(2 theta_h -+ theta_i) = 0).
        let mut breaks = vec![
            0.0,
            1.0,
            self.radial_uniform(half_pi - theta_i),
            self.radial_uniform(quarter_pi + 0.5 * theta_i),
            self.radial_uniform(quarter_pi - 0.5 * theta_i),
        ];
        if self.ndf.kind() == NdfKind::Ggx {
            breaks.extend(TAIL_BREAKS.iter().map(|&k| 1.0 - 10f64.powi(-k)));
        }
        if self.shadowing == Shadowing::VCavity {
            breaks.extend(vcavity_tangent_rings(mu, theta_i).map(|t| self.radial_uniform(t)));
        }
        if let Some(c) = tir {
            let theta_c = c.acos();
            for theta in [(theta_c - theta_i).abs(), theta_c + theta_i] {
                if theta < half_pi {
                    breaks.push(self.radial_uniform(theta));
                }
            }
        }
        breaks.sort_by(f64::total_cmp);
        let g1_wi = match self.shadowing {
            Shadowing::Smith => self.ndf.g1(wi.as_vec3()),
            Shadowing::VCavity => 0.0,
        };
        let mut sum = 0.0;
        for piece in breaks.windows(2) {
            let (a, b) = (piece[0], piece[1]);
            if b - a <= 0.0 {
                continue;
            }
            for &(x, w) in &self.radial {
                let u1 = a + (b - a) * x;
                let (cos2, sin2) = self.ndf.d_cos_polar(u1);
                let (sin_h, cos_h) = (sin2.max(0.0).sqrt(), cos2.max(0.0).sqrt());
                let weight = w * (b - a);
                let ring = (sin_i, mu, sin_h, cos_h);
                sum += weight * self.ring(wi, g1_wi, ring, tir, eta, weight, &mut visit);
            }
        }
        sum
    }

    /// (1/pi) int_0^pi of the integrand over the ring (sin_h, cos_h), split
    /// at the azimuths of the curves in the type's docs (back-facing cut,
    /// reflected horizon, total internal reflection, V-cavity's kinks);
    /// `visit` as in `albedo_with`, `radial` the ring's radial weight.
    #[allow(clippy::too_many_arguments)]
    fn ring(
        &self,
        wi: DVec3,
        g1_wi: f32,
        (sin_i, cos_i, sin_h, cos_h): (f64, f64, f64, f64),
        tir: Option<f64>,
        eta: Option<f64>,
        radial: f64,
        visit: &mut impl FnMut(f64, f64),
    ) -> f64 {
        let pi = std::f64::consts::PI;
        // phi where <wi,h> = k (0 or pi if the ring does not reach k).
        let azimuth_of = |k: f64| {
            let s = sin_i * sin_h;
            if s <= 0.0 {
                if cos_i * cos_h > k { pi } else { 0.0 }
            } else {
                ((k - cos_i * cos_h) / s).clamp(-1.0, 1.0).acos()
            }
        };
        let back = azimuth_of(0.0);
        // The reflected direction's horizon (`albedo`), and total internal
        // reflection.
        let mut breaks = vec![0.0, back, azimuth_of(0.5 * cos_i / cos_h).min(back)];
        if let Some(c) = tir {
            breaks.push(azimuth_of(c).min(back));
        }
        if self.shadowing == Shadowing::VCavity {
            breaks.extend(
                vcavity_kinks(cos_i, cos_h)
                    .into_iter()
                    .flatten()
                    .map(|k| azimuth_of(k).min(back)),
            );
        }
        breaks.sort_by(f64::total_cmp);
        let mut sum = 0.0;
        for piece in breaks.windows(2) {
            let (a, b) = (piece[0], piece[1]);
            if b - a <= 0.0 {
                continue;
            }
            for &(x, w) in &self.azimuth {
                let (sin_phi, cos_phi) = (a + (b - a) * x).sin_cos();
                let h = DVec3::new(sin_h * cos_phi, sin_h * sin_phi, cos_h);
                let weight = w * (b - a);
                let (value, scattered) = self.integrand(wi, g1_wi, h, eta);
                sum += weight * value;
                for (cos_o, share) in scattered.into_iter().flatten() {
                    visit(cos_o, radial * weight * share / pi);
                }
            }
        }
        sum / pi
    }

    /// <wi,h>/(<wi,n><h,n>) [F G_r + (1 - F) G_t] (`Quadrature::albedo`),
    /// in f64. Smith's G needs only the outgoing cosines, which are explicit
    /// (reflection 2 <wi,h> h_z - mu; refraction -mu/eta + (<wi,h>/eta -
    /// cos theta_t) h_z, Snell's law as in `frame::refract_f64`); V-cavity's
    /// needs the directions. With it, (cosine of the outgoing direction,
    /// its part of the integrand) for the reflection and the refraction.
    fn integrand(
        &self,
        wi: DVec3,
        g1_wi: f32,
        h: DVec3,
        eta: Option<f64>,
    ) -> (f64, [Option<(f64, f64)>; 2]) {
        let (wi_h, mu) = (wi.dot(h), wi.z);
        if !(wi_h > 0.0) || !(h.z > 0.0) {
            return (0.0, [None, None]);
        }
        // The white conductor reflects everything and transmits nothing (its
        // eta is never used).
        let (f, t, eta) = match eta {
            Some(eta) => {
                let (f, t) = fresnel::dielectric_f64(wi_h, eta);
                (f, t, eta)
            }
            None => (1.0, 0.0, 1.0),
        };
        let reflected_z = 2.0 * wi_h * h.z - mu;
        // (cos_o, F G or (1 - F) G) of the reflection and the refraction.
        let mut scattered = [None, None];
        match self.shadowing {
            Shadowing::Smith => {
                let g = |cos_o: f64| f64::from(g1_wi * self.smith_g1.at(cos_o.abs() as f32));
                if reflected_z > 0.0 {
                    scattered[0] = Some((reflected_z, f * g(reflected_z)));
                }
                if t > 0.0 {
                    let cos_t = ((eta - 1.0) * (eta + 1.0) + wi_h * wi_h).max(0.0).sqrt() / eta;
                    let refracted_z = -mu / eta + (wi_h / eta - cos_t) * h.z;
                    if refracted_z < 0.0 {
                        scattered[1] = Some((refracted_z, t * g(refracted_z)));
                    }
                }
            }
            Shadowing::VCavity => {
                let (wi32, h32) = (wi.as_vec3(), h.as_vec3());
                if reflected_z > 0.0 {
                    let wo = (2.0 * wi_h * h - wi).as_vec3();
                    scattered[0] = Some((
                        reflected_z,
                        f * f64::from(self.shadowing.masking_shadowing(&self.ndf, wi32, wo, h32)),
                    ));
                }
                if t > 0.0
                    && let Some(wo) = refract_f64(wi32, h32, eta)
                    && wo.z < 0.0
                {
                    let g = f64::from(self.shadowing.masking_shadowing(&self.ndf, wi32, wo, h32));
                    scattered[1] = Some((f64::from(wo.z), t * g));
                }
            }
        }
        let value: f64 = scattered.iter().flatten().map(|(_, v)| v).sum();
        (
            value * wi_h / (mu * h.z),
            scattered.map(|s| s.map(|(cos_o, v)| (cos_o, v * wi_h / (mu * h.z)))),
        )
    }
}

/// The values k of <wi,h> on the ring cos_h where V-cavity's G of the
/// reflection (min(1, G1(wi), G1(wo)), G1(w) = 2 cos_h <w,n>/<w,h>) has a
/// kink, for a query at cosine `mu`: G1(wi) = 1 at k = 2 mu cos_h; G1(wo) =
/// 1 at k (4 cos_h^2 - 1) = 2 mu cos_h (<wo,h> = <wi,h>, wo_z = 2 <wi,h>
/// cos_h - mu); G1(wi) = G1(wo) where wo_z = mu, k = mu / cos_h.
fn vcavity_kinks(mu: f64, cos_h: f64) -> [Option<f64>; 3] {
    let d = 4.0 * cos_h * cos_h - 1.0;
    [
        Some(2.0 * mu * cos_h),
        (d > 0.0).then(|| 2.0 * mu * cos_h / d),
        (cos_h > 0.0).then(|| mu / cos_h),
    ]
}

/// Polar angles of the rings tangent to V-cavity's kink curves
/// (`vcavity_kinks`), where the rings' integrals have a square-root onset
/// and the radial rule must be split: on a ring theta_h, <wi,h> spans
/// [cos(theta_h + theta_i), cos(theta_h - theta_i)], so a curve <wi,h> =
/// k(theta_h) touches the ring where k reaches either end. Found by a scan
/// of `TANGENCY_SCAN` angles and bisection of each sign change (at normal
/// incidence the curves are rings themselves, e.g. G1(wo) = 1 at theta_h =
/// 30 degrees).
fn vcavity_tangent_rings(mu: f64, theta_i: f64) -> impl Iterator<Item = f64> {
    let half_pi = std::f64::consts::FRAC_PI_2;
    let gap = move |kink: usize, sign: f64, theta: f64| {
        vcavity_kinks(mu, theta.cos())[kink]
            .map_or(f64::NAN, |k| k - (theta - sign * theta_i).cos())
    };
    let mut found = Vec::new();
    for kink in 0..3 {
        for sign in [1.0, -1.0] {
            let at = |theta: f64| gap(kink, sign, theta);
            for i in 0..TANGENCY_SCAN {
                let (mut lo, mut hi) = (
                    half_pi * i as f64 / TANGENCY_SCAN as f64,
                    half_pi * (i + 1) as f64 / TANGENCY_SCAN as f64,
                );
                let below = at(lo) < 0.0;
                if !(below != (at(hi) < 0.0) && at(lo).is_finite() && at(hi).is_finite()) {
                    continue;
                }
                for _ in 0..BISECTION_STEPS {
                    let mid = 0.5 * (lo + hi);
                    if (at(mid) < 0.0) == below {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                found.push(0.5 * (lo + hi));
            }
        }
    }
    found.into_iter()
}

/// Polar angles scanned for V-cavity's tangent rings: the kink curves cross
/// each ring end at most a few times, far apart on this grid.
const TANGENCY_SCAN: usize = 128;

/// Bisection steps of `SplitQuadrature::radial_uniform`: 2^-52, the f64
/// resolution of u1 near 1, where GGX's normals near the horizon lie (1 -
/// u1 = alpha^2 / tan^2 theta_h).
const BISECTION_STEPS: usize = 52;

/// Breaks of GGX's radial rule at u1 = 1 - 10^-k, geometric towards the
/// horizon of the normals (1 - u1 = alpha^2 / tan^2 theta_h for small
/// alpha): the integrand's 1/<h,n> and GGX's slowly decaying tail bend it
/// close to, not at, the end of a piece; split geometrically, the pieces
/// are smooth. 16 nodes per piece against 64: a white conductor 5e-4 off at
/// alpha 0.03, mu 0.02 without the breaks, 5e-5 at most with these three
/// (1.5e-6 with six, k = 1..6, which cost a dielectric table 30 % more);
/// from a dielectric's dense side 2.9e-4 without, 1.4e-4 with them.
/// Beckmann's and Blinn-Phong's tails need none (within 1e-5).
const TAIL_BREAKS: [i32; 3] = [2, 4, 6];
