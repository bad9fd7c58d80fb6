//! Comparing images with the reference, per pixel and channel: errors,
//! agreement beyond noise, and the fit of Mitsuba's error floor.

use glam::Vec3;

use crate::study::metrics::{MeanSquared, mean_squared, squared_differences};

use super::reference::Reference;
use super::render::Run;

/// Blocks per image side of the block-mean agreement test.
pub(super) const BLOCKS: u32 = 16;

/// Errors of an image against the reference: the study's MSE and relMSE
/// (SPEC §8), taken here over pixels *and channels* rather than on
/// luminance, because the reference's own error ([`reference_floor`]) is
/// known per channel only (the film keeps per-channel variances; the
/// luminance's variance would need their covariances).
pub(super) type Errors = MeanSquared;

/// Every channel of every pixel, in order (R, G, B of pixel 0, ...).
fn channels(image: &[Vec3]) -> impl Iterator<Item = f64> + '_ {
    image.iter().flat_map(|p| p.to_array()).map(f64::from)
}

/// MSE and relMSE of `image` against `reference`, over pixels and channels.
pub(super) fn errors(image: &[Vec3], reference: &[Vec3]) -> Errors {
    mean_squared(squared_differences(channels(image), channels(reference)))
}

/// The errors of each of `run`'s images (its image, then its further
/// `--seeds`' in order) and their mean: one seed's MSE is an estimate of
/// the renderer's expected MSE, which N seeds estimate N times better.
pub(super) fn run_errors(run: &Run, reference: &[Vec3]) -> (Errors, Vec<Errors>) {
    let each: Vec<Errors> = std::iter::once(&run.image)
        .chain(&run.seed_images)
        .map(|image| errors(image, reference))
        .collect();
    let n = each.len() as f64;
    let mean = Errors {
        mse: each.iter().map(|e| e.mse).sum::<f64>() / n,
        rel_mse: each.iter().map(|e| e.rel_mse).sum::<f64>() / n,
    };
    (mean, each)
}

/// The reference's own expected contribution to both error measures: its
/// variance of the mean in place of a squared error.
pub(super) fn reference_floor(reference: &Reference) -> Errors {
    mean_squared(channels(&reference.variance_of_mean).zip(channels(&reference.mean)))
}

fn channel_means(image: &[Vec3]) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    for p in image {
        for (c, s) in sum.iter_mut().enumerate() {
            *s += f64::from(p[c]);
        }
    }
    sum.map(|s| s / image.len().max(1) as f64)
}

/// Agreement of an image with the reference beyond noise: per channel,
/// sum(d) / sqrt(sum(d^2)) with d = image - reference is a z-score (unit
/// variance when both are unbiased estimates of one image with independent
/// pixels), over the whole image and over BLOCKS x BLOCKS blocks.
#[derive(Clone, Debug)]
pub(super) struct Agreement {
    /// (mean(image) - mean(reference)) / mean(reference), per channel.
    pub(super) mean_rel_diff: [f64; 3],
    /// Whole-image z-score per channel.
    pub(super) z_image: [f64; 3],
    /// Largest |z| over blocks and channels, and where (block x, y, channel).
    pub(super) z_block_max: (f64, u32, u32, usize),
    /// Root mean square of the block z-scores (about 1 when unbiased).
    pub(super) z_block_rms: f64,
}

/// Pixel differences up to this fraction of the reference pixel are float
/// rounding, not estimation error: noiseless pixels (a background seen
/// directly) differ between two programs by a few ulps (2e-6 relative on
/// env-sphere's sky, from the order of the scale factor's multiplication),
/// and a block of such pixels with one sign has z = sqrt(n), "beyond noise".
const ROUNDING: f64 = 1e-5;

pub(super) fn agreement(image: &[Vec3], reference: &[Vec3], width: u32, height: u32) -> Agreement {
    let (mi, mr) = (channel_means(image), channel_means(reference));
    let nb = (BLOCKS * BLOCKS) as usize;
    let mut block_sum = vec![[0.0f64; 3]; nb];
    let mut block_sq = vec![[0.0f64; 3]; nb];
    for y in 0..height {
        for x in 0..width {
            let i = (y * width + x) as usize;
            let b = ((y * BLOCKS / height) * BLOCKS + x * BLOCKS / width) as usize;
            for c in 0..3 {
                let r = f64::from(reference[i][c]);
                let mut d = f64::from(image[i][c]) - r;
                if d.abs() <= ROUNDING * r.abs() {
                    d = 0.0;
                }
                block_sum[b][c] += d;
                block_sq[b][c] += d * d;
            }
        }
    }
    let z = |s: f64, q: f64| if q > 0.0 { s / q.sqrt() } else { 0.0 };
    let mut z_image = [0.0; 3];
    for (c, zc) in z_image.iter_mut().enumerate() {
        let s: f64 = block_sum.iter().map(|b| b[c]).sum();
        let q: f64 = block_sq.iter().map(|b| b[c]).sum();
        *zc = z(s, q);
    }
    let (mut max, mut sum_sq, mut count) = ((0.0f64, 0, 0, 0), 0.0, 0);
    for (b, (s, q)) in block_sum.iter().zip(&block_sq).enumerate() {
        for c in 0..3 {
            let zb = z(s[c], q[c]);
            sum_sq += zb * zb;
            count += 1;
            if zb.abs() > max.0.abs() {
                max = (zb, b as u32 % BLOCKS, b as u32 / BLOCKS, c);
            }
        }
    }
    Agreement {
        mean_rel_diff: [0, 1, 2].map(|c| (mi[c] - mr[c]) / mr[c]),
        z_image,
        z_block_max: max,
        z_block_rms: (sum_sq / f64::from(count.max(1))).sqrt(),
    }
}

/// The reference's own contribution to every measured error (the test
/// images are independent of it, so it adds to their MSE), and the test of
/// a bias between the renderers.
#[derive(Clone, Copy, Debug)]
pub(super) struct ReferenceError {
    /// From the reference film: mean squared standard error of its pixels.
    /// A loose upper bound: our sampler is Owen-scrambled Sobol, whose mean
    /// converges faster than the per-iteration variance over N says.
    pub(super) from_variance: Errors,
    /// What is removed: our all-core MSE at --spp times spp / reference spp.
    /// The reference is our estimator at more spp, so its error is at most
    /// this as long as ours falls at least as fast as 1/spp (plain Monte
    /// Carlo; QMC falls faster). Capped by `from_variance`.
    pub(super) used: Errors,
    /// Mitsuba's floor with its standard error: independent samples give
    /// E[MSE] = a/N + c exactly, and c = (N2 MSE2 - N1 MSE1)/(N2 - N1),
    /// estimated pixel by pixel, is the reference's error plus the squared
    /// bias between the renderers.
    pub(super) mitsuba_floor: Option<(f64, f64)>,
}

/// The fitted floor c of [`ReferenceError::mitsuba_floor`] and its standard error.
pub(super) fn floor_fit(a: &Run, b: &Run, reference: &[Vec3]) -> (f64, f64) {
    let (n1, n2) = (f64::from(a.spp), f64::from(b.spp));
    let (mut sum, mut sum_sq, mut n) = (0.0, 0.0, 0.0);
    for ((x1, x2), r) in a.image.iter().zip(&b.image).zip(reference) {
        for c in 0..3 {
            let d1 = f64::from(x1[c]) - f64::from(r[c]);
            let d2 = f64::from(x2[c]) - f64::from(r[c]);
            let v = (n2 * d2 * d2 - n1 * d1 * d1) / (n2 - n1);
            sum += v;
            sum_sq += v * v;
            n += 1.0;
        }
    }
    let mean = sum / n;
    let variance = (sum_sq / n - mean * mean).max(0.0);
    (mean, (variance / n).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_and_agreement_of_identical_and_shifted_images() {
        let reference = vec![Vec3::new(1.0, 0.5, 0.0); 64];
        let same = errors(&reference, &reference);
        assert_eq!((same.mse, same.rel_mse), (0.0, 0.0));
        let brighter: Vec<Vec3> = reference.iter().map(|p| *p + Vec3::splat(0.1)).collect();
        let e = errors(&brighter, &reference);
        assert!((e.mse - 0.01).abs() < 1e-6);
        let a = agreement(&brighter, &reference, 8, 8);
        assert!((a.mean_rel_diff[0] - 0.1).abs() < 1e-6);
        // A constant offset is maximally "beyond noise": z = sqrt(n).
        assert!((a.z_image[0] - 8.0).abs() < 1e-4);
        // Rounding-sized differences are not.
        let rounded: Vec<Vec3> = reference.iter().map(|p| *p * (1.0 + 2e-6)).collect();
        assert_eq!(agreement(&rounded, &reference, 8, 8).z_image, [0.0; 3]);
    }

    #[test]
    fn a_runs_error_is_the_mean_over_its_seeds() {
        let reference = vec![Vec3::ONE; 16];
        let shifted = |d: f32| reference.iter().map(|p| *p + Vec3::splat(d)).collect();
        let run = Run {
            renderer: "ours (pt)".into(),
            threads: 1,
            spp: 4,
            setup_s: 0.0,
            render_s: 1.0,
            render_times: vec![1.0],
            image: shifted(0.1),
            seed_images: vec![shifted(0.2), shifted(-0.3)],
            path: std::path::PathBuf::new(),
            note: String::new(),
        };
        let (mean, each) = run_errors(&run, &reference);
        let mse: Vec<f64> = each.iter().map(|e| e.mse).collect();
        for (got, want) in mse.iter().zip([0.01, 0.04, 0.09]) {
            assert!((got - want).abs() < 1e-7, "{mse:?}");
        }
        assert!((mean.mse - 0.14 / 3.0).abs() < 1e-7, "{mean:?}");
        assert!((mean.rel_mse - 0.14 / 3.0 / 1.01).abs() < 1e-7, "{mean:?}");
    }

    #[test]
    fn reference_floor_is_the_mean_variance_over_channels() {
        let reference = Reference {
            spp: 4,
            mean: vec![Vec3::new(1.0, 0.0, 0.0), Vec3::new(0.0, 0.0, 2.0)],
            variance_of_mean: vec![Vec3::new(0.5, 0.0, 0.0), Vec3::new(0.0, 0.25, 0.0)],
            path: std::path::PathBuf::new(),
            render_s: 0.0,
            cached: true,
        };
        let f = reference_floor(&reference);
        assert!((f.mse - 0.75 / 6.0).abs() < 1e-12);
        // relMSE: 0.5 / (1 + 0.01) + 0.25 / (0 + 0.01), over six channels.
        assert!((f.rel_mse - (0.5 / 1.01 + 25.0) / 6.0).abs() < 1e-12);
    }
}
