//! Fresnel reflectance (SPEC §3): exact unpolarised dielectric, complex-IOR
//! conductor, and Schlick's approximation from F0.

use glam::{Vec3, Vec3A};

use crate::frame::cos2_theta_t;

/// Unpolarised Fresnel reflectance of a dielectric interface (Born & Wolf;
/// pbrt-v4 `FrDielectric`).
///
/// `cos_theta_i` is the cosine between the incident direction and the normal
/// on its side; a negative value means the direction is on the far side, and
/// the interface is then seen with 1/eta. `eta` = eta_t / eta_i. Returns 1 on
/// total internal reflection, 0 for eta = 1 (except at exactly grazing
/// incidence, where it is 1), and a value in [0, 1] otherwise. Computed in
/// f64 (see [`dielectric_f64`]).
pub fn dielectric(cos_theta_i: f32, eta: f32) -> f32 {
    dielectric_f64(f64::from(cos_theta_i), f64::from(eta)).0 as f32
}

/// The transmittance 1 - F of [`dielectric`], computed directly: near the
/// critical angle F -> 1, and 1 - F formed from an f32 F would keep only
/// its absolute error 6e-8 (all of it at 1 - F < 6e-8).
pub fn dielectric_transmittance(cos_theta_i: f32, eta: f32) -> f32 {
    dielectric_f64(f64::from(cos_theta_i), f64::from(eta)).1 as f32
}

/// (F, 1 - F) of a dielectric interface in f64, with the conventions of
/// [`dielectric`] (a negative cosine sees the interface with 1/eta, inverted
/// here in f64).
///
/// cos^2(theta_t) comes from `frame::cos2_theta_t` (f64, exact for f32
/// inputs up to one rounding), the quantity that loses all precision near
/// the critical angle in f32. The transmittance uses 1 - r^2 = 4ab/(a + b)^2
/// for r = (a - b)/(a + b) (Born & Wolf, sec. 1.5.3: the transmissivities
/// (eta cos_t / cos_i) t^2 of the two polarisations), so it has no
/// cancellation as F -> 1: T = 2 eta cos_i cos_t (1/(eta cos_i + cos_t)^2 +
/// 1/(cos_i + eta cos_t)^2).
pub fn dielectric_f64(cos_theta_i: f64, eta: f64) -> (f64, f64) {
    let (cos_i, eta) = if cos_theta_i < 0.0 {
        (-cos_theta_i, 1.0 / eta)
    } else {
        (cos_theta_i, eta)
    };
    let cos_i = cos_i.min(1.0);
    let cos2_t = cos2_theta_t(cos_i, eta);
    if !(cos2_t > 0.0) {
        return (1.0, 0.0);
    }
    let cos_t = cos2_t.sqrt();
    let (parallel, perpendicular) = (eta * cos_i + cos_t, cos_i + eta * cos_t);
    let r_parallel = (eta * cos_i - cos_t) / parallel;
    let r_perpendicular = (cos_i - eta * cos_t) / perpendicular;
    let r = 0.5 * (r_parallel * r_parallel + r_perpendicular * r_perpendicular);
    let t = 2.0
        * eta
        * cos_i
        * cos_t
        * ((parallel * parallel).recip() + (perpendicular * perpendicular).recip());
    if !(r.is_finite() && t.is_finite()) {
        // eta so large or small that a square overflows: seen as opaque.
        return (1.0, 0.0);
    }
    (r.clamp(0.0, 1.0), t.clamp(0.0, 1.0))
}

/// Fresnel reflectance of a conductor with complex index eta + i k, per RGB
/// channel (pbrt-v4 `FrComplex`; the same equations as `dielectric` with a
/// complex eta, where total internal reflection cannot occur), the three
/// channels at once in `Vec3A` lanes (SSE on x86-64): each lane makes the
/// operations of the one-channel formula, so the result is the same.
/// `cos_theta_i` is clamped to [0, 1].
pub fn conductor(cos_theta_i: f32, eta: Vec3, k: Vec3) -> Vec3 {
    let c = Vec3A::splat(cos_theta_i.clamp(0.0, 1.0));
    let eta = Complex3::new(eta.into(), k.into());
    let sin2_i = Vec3A::ONE - c * c;
    let sin2_t = Complex3::real(sin2_i).div(eta.mul(eta));
    let cos_t = Complex3::real(Vec3A::ONE).sub(sin2_t).sqrt();
    let ci = Complex3::real(c);
    let r_parallel = eta.mul(ci).sub(cos_t).div(eta.mul(ci).add(cos_t));
    let r_perpendicular = ci.sub(eta.mul(cos_t)).div(ci.add(eta.mul(cos_t)));
    let f = 0.5 * (r_parallel.norm2() + r_perpendicular.norm2());
    Vec3A::select(
        f.is_finite_mask(),
        f.clamp(Vec3A::ZERO, Vec3A::ONE),
        Vec3A::ONE,
    )
    .into()
}

/// Schlick's approximation F0 + (1 - F0)(1 - cos)^5 (Schlick 1994), used for
/// metals described by a base colour (glTF). `cos_theta_i` is clamped to [0, 1].
pub fn schlick(cos_theta_i: f32, f0: Vec3) -> Vec3 {
    let m = 1.0 - cos_theta_i.clamp(0.0, 1.0);
    let m5 = (m * m) * (m * m) * m;
    f0 + (Vec3::ONE - f0) * m5
}

/// How a conductor's reflectance is computed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Fresnel {
    /// Complex index of refraction eta + i k per RGB channel.
    Conductor {
        /// Real part of the index.
        eta: Vec3,
        /// Extinction coefficient.
        k: Vec3,
        /// Multiplies the reflectance per channel, in [0, 1]: 1 for a physical
        /// conductor (Mitsuba's `specular_reflectance`, a non-physical tint
        /// some scenes use to darken a metal, e.g. Veach's MIS plates).
        tint: Vec3,
    },
    /// Schlick's approximation with normal-incidence reflectance `f0`.
    Schlick {
        /// Reflectance at normal incidence.
        f0: Vec3,
    },
}

impl Fresnel {
    /// A physical conductor with complex index of refraction eta + i k per
    /// RGB channel (relative to the outside medium; e.g. gold
    /// (0.143, 0.374, 1.442) + i (3.983, 2.385, 1.603)), untinted.
    pub const fn conductor(eta: Vec3, k: Vec3) -> Self {
        Fresnel::Conductor {
            eta,
            k,
            tint: Vec3::ONE,
        }
    }

    /// Reflectance for a microfacet at cosine `cos_theta_i` to the direction.
    pub fn eval(&self, cos_theta_i: f32) -> Vec3 {
        match *self {
            Fresnel::Conductor { eta, k, tint } => tint * conductor(cos_theta_i, eta, k),
            Fresnel::Schlick { f0 } => schlick(cos_theta_i, f0),
        }
    }

    /// The cosine-weighted hemispherical average F_avg = 2 int_0^1 F(mu) mu dmu
    /// (Kulla & Conty 2017, the colour of their energy compensation): in
    /// closed form f0 + (1 - f0)/21 for Schlick (int (1 - mu)^5 2 mu dmu =
    /// 1/21), by 8-point Gauss-Legendre for the conductor equations (smooth
    /// in mu; the rule is exact for polynomials of degree 15).
    pub fn average(&self) -> Vec3 {
        match *self {
            Fresnel::Schlick { f0 } => schlick_average(f0),
            Fresnel::Conductor { .. } => crate::gauss::gauss_legendre_8()
                .iter()
                .map(|&(mu, w)| self.eval(mu as f32) * (2.0 * mu * w) as f32)
                .sum(),
        }
    }
}

/// 2 int_0^1 schlick(mu, f0) mu dmu = f0 + (1 - f0)/21 (see `Fresnel::average`).
pub fn schlick_average(f0: Vec3) -> Vec3 {
    f0 + (Vec3::ONE - f0) / 21.0
}

/// Three complex numbers, one per RGB channel, as lanes.
#[derive(Clone, Copy)]
struct Complex3 {
    re: Vec3A,
    im: Vec3A,
}

impl Complex3 {
    fn new(re: Vec3A, im: Vec3A) -> Self {
        Self { re, im }
    }
    fn real(re: Vec3A) -> Self {
        Self::new(re, Vec3A::ZERO)
    }
    fn add(self, o: Self) -> Self {
        Self::new(self.re + o.re, self.im + o.im)
    }
    fn sub(self, o: Self) -> Self {
        Self::new(self.re - o.re, self.im - o.im)
    }
    fn mul(self, o: Self) -> Self {
        Self::new(
            self.re * o.re - self.im * o.im,
            self.re * o.im + self.im * o.re,
        )
    }
    fn div(self, o: Self) -> Self {
        let scale = Vec3A::ONE / o.norm2();
        Self::new(
            scale * (self.re * o.re + self.im * o.im),
            scale * (self.im * o.re - self.re * o.im),
        )
    }
    fn norm2(self) -> Vec3A {
        self.re * self.re + self.im * self.im
    }
    /// Principal square root (0 where the norm is 0).
    fn sqrt(self) -> Self {
        let n = self.norm2().sqrt();
        let t1 = (0.5 * (n + self.re.abs())).sqrt();
        let t2 = 0.5 * self.im / t1;
        let non_negative = self.re.cmpge(Vec3A::ZERO);
        let root = Self::new(
            Vec3A::select(non_negative, t1, t2.abs()),
            Vec3A::select(non_negative, t2, t1.copysign(self.im)),
        );
        let zero = n.cmpeq(Vec3A::ZERO);
        Self::new(
            Vec3A::select(zero, Vec3A::ZERO, root.re),
            Vec3A::select(zero, Vec3A::ZERO, root.im),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Found by `cargo xtask stability`: an index-matched interface
    /// reflected grazing rays totally.
    #[test]
    fn index_matched_interface_transmits_at_grazing_angles() {
        assert_eq!(dielectric(1e-4, 1.0), 0.0);
        assert_eq!(dielectric(-1e-6, 1.0), 0.0);
        let f = dielectric(-0.000_509_057_6, 1.000_000_1);
        assert!(f < 0.5, "{f}");
    }

    #[test]
    fn dielectric_known_values() {
        // Normal incidence: ((eta - 1)/(eta + 1))^2 = 0.04 for glass.
        assert!((dielectric(1.0, 1.5) - 0.04).abs() < 1e-6);
        // Brewster's angle: the parallel component vanishes.
        let brewster = 1.5f32.atan();
        let rs = {
            let ci = brewster.cos();
            let ct = (1.0 - (brewster.sin() / 1.5).powi(2)).sqrt();
            ((ci - 1.5 * ct) / (ci + 1.5 * ct)).powi(2)
        };
        assert!((dielectric(brewster.cos(), 1.5) - 0.5 * rs).abs() < 1e-6);
        // Total internal reflection from inside glass beyond the critical angle.
        assert_eq!(dielectric(0.5, 1.0 / 1.5), 1.0);
        assert_eq!(dielectric(-0.5, 1.5), 1.0);
        // Reciprocity: the same interface seen from both sides.
        let ci = 0.8f32;
        let ct = (1.0 - (1.0 - ci * ci) / (1.5 * 1.5)).sqrt();
        assert!((dielectric(ci, 1.5) - dielectric(ct, 1.0 / 1.5)).abs() < 1e-6);
        // Index-matched.
        assert_eq!(dielectric(0.7, 1.0), 0.0);
    }

    #[test]
    fn conductor_reduces_to_dielectric_without_absorption() {
        for c in [0.05, 0.3, 0.7, 1.0] {
            let f = conductor(c, Vec3::splat(1.5), Vec3::ZERO);
            assert!((f.x - dielectric(c, 1.5)).abs() < 1e-5, "{c}");
        }
    }

    #[test]
    fn conductor_known_value() {
        // Gold at 600 nm, eta = 0.2 + 3.0 i: R(0) = ((n-1)^2 + k^2)/((n+1)^2 + k^2).
        let f = conductor(1.0, Vec3::splat(0.2), Vec3::splat(3.0));
        let expected = (0.64 + 9.0) / (1.44 + 9.0);
        assert!((f.x - expected).abs() < 1e-5);
        // Grazing incidence reflects everything.
        assert!((conductor(0.0, Vec3::splat(0.2), Vec3::splat(3.0)).x - 1.0).abs() < 1e-5);
    }

    #[test]
    fn schlick_endpoints() {
        let f0 = Vec3::new(0.9, 0.6, 0.2);
        assert!((schlick(1.0, f0) - f0).length() < 1e-7);
        assert!((schlick(0.0, f0) - Vec3::ONE).length() < 1e-7);
    }
}
