//! A thin dielectric sheet (a window pane): two parallel smooth interfaces
//! so close that light leaves where it entered. Mitsuba 3's `thindielectric`
//! (mitsuba3 v3.9.1, `src/bsdfs/thindielectric.cpp`): the reflections inside
//! the sheet sum to R' = R + T^2 R (1 + R^2 + R^4 + ...) = 2R / (1 + R), R
//! the Fresnel reflectance of one interface, and the rest, T' = 1 - R',
//! passes straight through, undeflected. Both are delta lobes; light enters
//! and leaves the same medium, so there is no (eta_i/eta_t)^2 factor in
//! either transport mode. A sheet has no roughness: regularization leaves it
//! as it is (and counts it as never bounded, like every delta lobe).

use glam::Vec3;

use crate::fresnel;
use crate::sample::BsdfSample;

/// A thin sheet of index ratio `eta` to its surroundings; `tint` scales
/// what passes through (Mitsuba's `specular_transmittance`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ThinDielectric {
    /// Index of the sheet over the index around it, > 0.
    pub eta: f32,
    /// Multiplies the transmitted part, each channel in [0, 1].
    pub tint: Vec3,
}

impl ThinDielectric {
    /// A clear (untinted) sheet of relative index `eta` (the sheet's index
    /// over the surrounding medium's, dimensionless, > 0).
    pub fn new(eta: f32) -> Self {
        Self {
            eta,
            tint: Vec3::ONE,
        }
    }

    /// R' = 2R / (1 + R): the reflectance of the sheet at `cos_theta` from
    /// its normal, either side.
    pub fn reflectance(&self, cos_theta: f32) -> f32 {
        let r = fresnel::dielectric(cos_theta.abs(), self.eta);
        2.0 * r / (1.0 + r)
    }

    /// Reflects with probability R', else passes straight through (wo =
    /// -wi): each a delta lobe whose weight f |cos| / pdf is 1 (the tint
    /// for transmission). `None` for wi in the tangent plane.
    pub fn sample(&self, wi: Vec3, uc: f32) -> Option<BsdfSample> {
        if wi.z == 0.0 {
            return None;
        }
        let r = self.reflectance(wi.z);
        let cos = wi.z.abs();
        let (wo, p, weight) = if uc < r {
            (Vec3::new(-wi.x, -wi.y, wi.z), r, Vec3::ONE)
        } else {
            (-wi, 1.0 - r, self.tint)
        };
        Some(BsdfSample {
            wo,
            f: weight * (p / cos),
            pdf: p,
            pdf_reverse: p,
            eta: 1.0,
            is_specular: true,
            compensated: None,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Energy: every sample of a clear sheet carries weight 1, reflections
    /// come with probability 2R/(1+R) (4 % at normal incidence for eta 1.5
    /// gives 7.7 %), and transmission goes straight through.
    #[test]
    fn reflects_two_r_over_one_plus_r_and_passes_the_rest() {
        let sheet = ThinDielectric::new(1.5);
        let r = 0.04f32;
        assert!((sheet.reflectance(1.0) - 2.0 * r / (1.0 + r)).abs() < 1e-6);
        assert_eq!(sheet.reflectance(-1.0), sheet.reflectance(1.0));
        let wi = Vec3::new(0.6, 0.0, 0.8);
        let mut reflected = 0;
        const N: u32 = 10_000;
        for i in 0..N {
            let s = sheet.sample(wi, (i as f32 + 0.5) / N as f32).unwrap();
            let weight = s.f * s.wo.z.abs() / s.pdf;
            assert!((weight - Vec3::ONE).abs().max_element() < 1e-5, "{weight}");
            if s.wo.z > 0.0 {
                reflected += 1;
                assert_eq!(s.wo, Vec3::new(-0.6, 0.0, 0.8));
            } else {
                assert_eq!(s.wo, -wi);
            }
        }
        let expected = sheet.reflectance(0.8) * N as f32;
        assert!(
            (reflected as f32 - expected).abs() <= 1.0,
            "{reflected} {expected}"
        );
        // From below, the same.
        let s = sheet.sample(Vec3::new(0.0, 0.0, -1.0), 0.99).unwrap();
        assert_eq!(s.wo, Vec3::Z);
        assert!(ThinDielectric::new(1.5).sample(Vec3::X, 0.5).is_none());
    }
}
