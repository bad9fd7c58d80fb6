//! Importance sampling of an equirectangular environment map
//! ([`scene::EnvironmentMap`]): a piecewise-constant 2-D distribution over
//! the texels, a marginal over rows and a conditional over the texels of
//! each row (pbrt-v4 §12.5.2 `ImageInfiniteLight`, Mitsuba 3 `envmap`).
//!
//! **Weights and density.** Texel (row, col) covers the solid angle
//! `Omega = (2 pi / width) (cos theta_row - cos theta_row+1)` (theta_row =
//! pi row / height), and is chosen with probability
//! `p = Y(L) Omega / sum(Y(L) Omega)` (Y the Rec. 709 luminance). Inside
//! the texel the direction is uniform in solid angle (cos theta and phi
//! uniform), so the density is `p / Omega`, constant over the texel. This
//! integrates the sin theta Jacobian over each row exactly, where pbrt-v4
//! and Mitsuba weight by sin theta at the row's centre and sample uniformly
//! in (u, v), whose density `p_uv / (2 pi^2 sin theta)` varies inside a
//! texel: here the density is exactly proportional to the map's luminance
//! (a constant map samples uniformly, density 1 / (4 pi)), and a texel
//! with radiance has a positive probability.
//!
//! Radiance and density both look the direction up with
//! [`scene::EnvironmentMap::texel_index`], so they cannot disagree.

use std::f32::consts::PI;

use glam::{Vec2, Vec3};
use scene::EnvironmentMap;

use crate::colour::luminance;

/// One less than 1 in f64: a remapped uniform stays inside its cell (the
/// cell's far edge belongs to the next cell).
const ONE_MINUS_EPSILON: f64 = 1.0 - f64::EPSILON;

/// A sampled direction towards the environment.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EnvironmentSample {
    /// Unit direction towards the map (away from the receiver).
    pub direction: Vec3,
    /// Its density in solid angle.
    pub pdf: f32,
    /// The radiance arriving from it.
    pub radiance: Vec3,
}

/// The sampling distribution of one map.
#[derive(Clone, Debug)]
pub struct EnvironmentDistribution {
    width: u32,
    /// Cumulative row probabilities (height + 1 entries, 0 to 1).
    row_cdf: Vec<f64>,
    /// Per row, the cumulative probabilities of its texels given the row
    /// (width + 1 entries each, 0 to 1; all zero for a dark row).
    col_cdf: Vec<f64>,
    /// cos theta at the top edge of each row, and at the bottom of the last
    /// (height + 1 entries, 1 to -1).
    cos_edge: Vec<f32>,
    /// Solid-angle density of each texel, p / Omega.
    texel_pdf: Vec<f32>,
    /// The integral of the luminance over the sphere, sum(Y(L) Omega).
    luminance_integral: f64,
}

impl EnvironmentDistribution {
    /// The distribution of `map` (with its scale): `None` for a dark map,
    /// which emits nothing and is never sampled.
    pub fn new(map: &EnvironmentMap) -> Option<Self> {
        let (w, h) = (map.width as usize, map.height as usize);
        let cos_edge: Vec<f32> = (0..=h)
            .map(|r| (std::f64::consts::PI * r as f64 / h as f64).cos() as f32)
            .collect();
        let omega = |row: usize| {
            2.0 * std::f64::consts::PI / w as f64
                * (f64::from(cos_edge[row]) - f64::from(cos_edge[row + 1]))
        };
        let mut col_cdf = vec![0.0f64; h * (w + 1)];
        let mut row_weight = vec![0.0f64; h];
        for row in 0..h {
            let cdf = &mut col_cdf[row * (w + 1)..(row + 1) * (w + 1)];
            let mut acc = 0.0f64;
            for col in 0..w {
                acc += f64::from(luminance(map.texel(row * w + col)));
                cdf[col + 1] = acc;
            }
            if acc > 0.0 {
                cdf.iter_mut().for_each(|c| *c /= acc);
                cdf[w] = 1.0;
            }
            row_weight[row] = acc * omega(row);
        }
        let total: f64 = row_weight.iter().sum();
        if !(total > 0.0 && total.is_finite()) {
            return None;
        }
        let mut row_cdf = vec![0.0f64; h + 1];
        for row in 0..h {
            row_cdf[row + 1] = row_cdf[row] + row_weight[row] / total;
        }
        row_cdf[h] = 1.0;
        let texel_pdf = (0..h * w)
            .map(|i| {
                let (row, col) = (i / w, i % w);
                let cdf = &col_cdf[row * (w + 1)..];
                let p = (row_cdf[row + 1] - row_cdf[row]) * (cdf[col + 1] - cdf[col]);
                (p / omega(row)) as f32
            })
            .collect();
        Some(Self {
            width: map.width,
            row_cdf,
            col_cdf,
            cos_edge,
            texel_pdf,
            luminance_integral: total,
        })
    }

    /// The integral of the map's luminance over the sphere (its power per
    /// unit area of a surface it lights from every side, times pi).
    pub fn luminance_integral(&self) -> f64 {
        self.luminance_integral
    }

    /// A direction towards `map` from two uniforms: row by `u.y`, texel by
    /// `u.x`, then the remapped uniforms place it uniformly in solid angle
    /// inside the texel. `None` when it carries nothing (a rounded
    /// direction on the edge of a dark texel).
    pub fn sample(&self, map: &EnvironmentMap, u: Vec2) -> Option<EnvironmentSample> {
        let w = self.width as usize;
        let (row, v) = sample_cdf(&self.row_cdf, f64::from(u.y));
        let (col, s) = sample_cdf(
            &self.col_cdf[row * (w + 1)..(row + 1) * (w + 1)],
            f64::from(u.x),
        );
        let (top, bottom) = (self.cos_edge[row], self.cos_edge[row + 1]);
        let cos_theta = top - v as f32 * (top - bottom);
        let phi = 2.0 * PI * ((col as f64 + s) / w as f64) as f32;
        let direction = map.direction(cos_theta, phi);
        // Density and radiance of the direction as looked up, not of the
        // cell it was drawn in: they differ only by round-off on an edge.
        let index = map.texel_index(direction);
        let pdf = self.texel_pdf[index];
        let radiance = map.texel(index);
        (pdf > 0.0 && radiance.max_element() > 0.0).then_some(EnvironmentSample {
            direction,
            pdf,
            radiance,
        })
    }

    /// Density in solid angle with which [`EnvironmentDistribution::sample`]
    /// draws unit direction `d`.
    #[inline]
    pub fn pdf(&self, map: &EnvironmentMap, d: Vec3) -> f32 {
        self.texel_pdf[map.texel_index(d)]
    }
}

/// The cell of `cdf` (n + 1 non-decreasing entries from 0 to 1) that `u`
/// falls in, never an empty one, and `u` remapped to [0, 1) inside it.
fn sample_cdf(cdf: &[f64], u: f64) -> (usize, f64) {
    let n = cdf.len() - 1;
    let u = u.clamp(0.0, ONE_MINUS_EPSILON);
    // The first edge above u closes the cell; an empty cell [c, c] is never
    // chosen because c <= u excludes it.
    let i = cdf.partition_point(|&c| c <= u).clamp(1, n) - 1;
    let width = cdf[i + 1] - cdf[i];
    let remapped = if width > 0.0 {
        ((u - cdf[i]) / width).clamp(0.0, ONE_MINUS_EPSILON)
    } else {
        0.5
    };
    (i, remapped)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cdf_cells_skip_empty_ones_and_remap() {
        let cdf = [0.0, 0.25, 0.25, 1.0];
        assert_eq!(sample_cdf(&cdf, 0.0), (0, 0.0));
        assert_eq!(sample_cdf(&cdf, 0.125), (0, 0.5));
        assert_eq!(sample_cdf(&cdf, 0.25), (2, 0.0));
        let (i, r) = sample_cdf(&cdf, 1.0);
        assert_eq!(i, 2);
        assert!(r < 1.0);
    }

    /// A constant map's density is 1 / (4 pi) everywhere, its luminance
    /// integral 4 pi Y(L).
    #[test]
    fn constant_map_is_uniform() {
        let map = EnvironmentMap::new(8, 5, vec![Vec3::splat(2.0); 40], 0.5, 30.0).unwrap();
        let dist = EnvironmentDistribution::new(&map).unwrap();
        for &p in &dist.texel_pdf {
            assert!((p * 4.0 * PI - 1.0).abs() < 1e-5, "{p}");
        }
        assert!((dist.luminance_integral() - 4.0 * std::f64::consts::PI).abs() < 1e-5);
        let dark = EnvironmentMap::new(2, 1, vec![Vec3::ZERO; 2], 1.0, 0.0).unwrap();
        assert!(EnvironmentDistribution::new(&dark).is_none());
    }
}
