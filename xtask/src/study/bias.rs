//! The bias of regularization as the study measures it: the regularized
//! reference minus the unbiased one, on luminance, as numbers beside the
//! noise both references carry, and as a false-colour image.
//!
//! The difference of two references is bias plus the noise of both. With
//! per-pixel variances v_r and v_u of the two means (s^2/N, SPEC §8) and
//! independent pixels, noise alone gives E[RMSE(d)^2] = mean(v_r + v_u) and
//! a standard deviation of the image-mean difference of
//! sqrt(mean(v_r + v_u) / P) over P pixels; the report divides by these, so
//! a ratio near 1 is noise and one far above it is bias. s^2/N overstates
//! the error of Sobol-stratified iterations (see the report's metrics), so
//! the ratios are conservative: they understate how far bias exceeds noise.

use std::path::Path;

use super::Reference;
use super::raster::{Canvas, for_each_text_pixel, text_size};

/// The difference of the regularized and the unbiased reference.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Bias {
    /// sqrt(mean(d^2)), d = Y_regularized - Y_unbiased per pixel.
    pub rmse: f64,
    /// `rmse` over the unbiased reference's mean luminance.
    pub relative_rmse: f64,
    /// mean(d).
    pub mean: f64,
    /// `mean` over the unbiased reference's mean luminance.
    pub relative_mean: f64,
    /// sqrt(mean(v_r + v_u)): the RMSE noise alone would give (None
    /// without both references' noise, e.g. farm references).
    pub noise_rmse: Option<f64>,
    /// sqrt(mean(v_r + v_u) / P): the standard deviation of `mean` from
    /// noise alone.
    pub noise_mean: Option<f64>,
    /// The 99th percentile of |d|: the false-colour image's full scale.
    pub scale: f64,
}

/// Smallest full scale of the false-colour image, so that identical
/// references (d = 0 everywhere) still map to grey instead of 0/0.
const MIN_SCALE: f64 = 1e-12;

/// The colour of the noise marks on the legend's colour bar (not in the
/// diverging map, whose colours run from blue through white to red).
const NOISE_MARK: [u8; 3] = [0, 200, 0];

/// Pixels of the false-colour image's legend strip below the image.
const LEGEND_HEIGHT: u32 = 24;

impl Bias {
    /// `regularized` minus `unbiased` (luminance images of one size).
    pub fn of(regularized: &Reference, unbiased: &Reference) -> Self {
        let d = difference(regularized, unbiased);
        let pixels = d.len().max(1) as f64;
        let mean_unbiased = unbiased.luminance.iter().sum::<f64>() / pixels;
        let rmse = (d.iter().map(|x| x * x).sum::<f64>() / pixels).sqrt();
        let mean = d.iter().sum::<f64>() / pixels;
        let variance = match (regularized.noise, unbiased.noise) {
            (Some(a), Some(b)) => Some(a.variance + b.variance),
            _ => None,
        };
        let mut magnitudes: Vec<f64> = d.iter().map(|x| x.abs()).collect();
        magnitudes.sort_by(f64::total_cmp);
        let p99 = magnitudes
            .get(((magnitudes.len() as f64 * 0.99) as usize).min(magnitudes.len().max(1) - 1))
            .copied()
            .unwrap_or(0.0);
        Self {
            rmse,
            relative_rmse: rmse / mean_unbiased,
            mean,
            relative_mean: mean / mean_unbiased,
            noise_rmse: variance.map(f64::sqrt),
            noise_mean: variance.map(|v| (v / pixels).sqrt()),
            scale: p99.max(MIN_SCALE),
        }
    }
}

/// Per-pixel Y_regularized - Y_unbiased.
fn difference(regularized: &Reference, unbiased: &Reference) -> Vec<f64> {
    regularized
        .luminance
        .iter()
        .zip(&unbiased.luminance)
        .map(|(r, u)| r - u)
        .collect()
}

/// The diverging colour of t in [-1, 1] (sRGB bytes): blue below zero
/// (regularization darker), white at zero, red above (brighter).
fn diverging(t: f64) -> [u8; 3] {
    let t = t.clamp(-1.0, 1.0);
    let fade = (255.0 * (1.0 - t.abs())).round() as u8;
    if t >= 0.0 {
        [255, fade, fade]
    } else {
        [fade, fade, 255]
    }
}

/// Writes the false-colour image of `regularized` - `unbiased` to `path`:
/// each pixel's difference over `bias.scale` in the diverging map,
/// magnified to at least 256 px wide (nearest neighbour), with a legend
/// strip: the colour bar from -scale to +scale, green marks on it at +-
/// the per-pixel noise of d (sqrt(mean(v_r + v_u))) when that is known,
/// and the full scale.
pub fn write_image(
    path: &Path,
    (width, height): (u32, u32),
    regularized: &Reference,
    unbiased: &Reference,
    bias: &Bias,
) -> Result<(), String> {
    let d = difference(regularized, unbiased);
    let zoom = 256u32.div_ceil(width.max(1)).max(1);
    let (w, h) = (width * zoom, height * zoom);
    let mut canvas = Canvas::new(w.max(256), h + LEGEND_HEIGHT, [0, 0, 0]);
    for y in 0..h {
        for x in 0..w {
            let v = d[(y / zoom * width + x / zoom) as usize];
            canvas.blend(x as i32, y as i32, diverging(v / bias.scale), 1.0);
        }
    }
    // The legend: the map from -scale to +scale, then its label.
    let bar = 64;
    for x in 0..bar {
        let t = 2.0 * f64::from(x) / f64::from(bar - 1) - 1.0;
        for y in h + 4..h + LEGEND_HEIGHT - 4 {
            canvas.blend(x + 4, y as i32, diverging(t), 1.0);
        }
    }
    // Where noise alone would put a typical pixel.
    if let Some(noise) = bias.noise_rmse.filter(|n| *n < bias.scale) {
        for sign in [-1.0, 1.0] {
            let x = ((sign * noise / bias.scale + 1.0) / 2.0 * f64::from(bar - 1)).round() as i32;
            for y in h + 2..h + LEGEND_HEIGHT - 2 {
                canvas.blend(x + 4, y as i32, NOISE_MARK, 1.0);
            }
        }
    }
    let label = match bias.noise_rmse {
        Some(_) => format!("+-{:.2e}, green: noise", bias.scale),
        None => format!("+-{:.2e}", bias.scale),
    };
    let (_, th) = text_size(&label, 1);
    let (ox, oy) = (bar + 12, h as i32 + (LEGEND_HEIGHT as i32 - th) / 2);
    let mut text = Vec::new();
    for_each_text_pixel(&label, 1, |x, y| text.push((x, y)));
    for (x, y) in text {
        canvas.blend(ox + x, oy + y, [255, 255, 255], 1.0);
    }
    canvas.write_png(path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::cache::ReferenceSpec;
    use crate::study::metrics::Noise;
    use crate::study::{Config, Reference};
    use glam::Vec3;

    fn reference(luminance: Vec<f64>, variance: f64) -> Reference {
        Reference {
            role: "test",
            config: Config::REFERENCE,
            spec: ReferenceSpec {
                config: "vcm-reg".into(),
                iterations: 4,
                seed: 1,
                width: luminance.len() as u32,
                height: 1,
                max_depth: 5,
                tau0: 7.5,
            },
            key: String::new(),
            cache_file: Default::default(),
            cached: false,
            render_seconds: 0.0,
            cpu_seconds: None,
            noise: Some(Noise {
                std_error: variance.sqrt(),
                variance,
            }),
            invalid_samples: 0,
            image: luminance.iter().map(|&y| Vec3::splat(y as f32)).collect(),
            luminance,
        }
    }

    /// The numbers follow their definitions on a hand-made pair.
    #[test]
    fn bias_numbers_follow_their_definitions() {
        let unbiased = reference(vec![1.0, 1.0, 2.0, 4.0], 0.01);
        let regularized = reference(vec![1.0, 0.5, 2.0, 3.5], 0.03);
        let b = Bias::of(&regularized, &unbiased);
        // d = 0, -0.5, 0, -0.5; mean(Y_u) = 2.
        assert!((b.mean + 0.25).abs() < 1e-12);
        assert!((b.relative_mean + 0.125).abs() < 1e-12);
        assert!((b.rmse - 0.125f64.sqrt()).abs() < 1e-12);
        assert!((b.relative_rmse - 0.125f64.sqrt() / 2.0).abs() < 1e-12);
        assert!((b.noise_rmse.unwrap() - 0.04f64.sqrt()).abs() < 1e-12);
        assert!((b.noise_mean.unwrap() - 0.01f64.sqrt()).abs() < 1e-12);
        assert_eq!(b.scale, 0.5);
        assert_eq!(diverging(0.0), [255, 255, 255]);
        assert_eq!(diverging(-2.0), [0, 0, 255]);
        assert_eq!(diverging(1.0), [255, 0, 0]);
    }
}
