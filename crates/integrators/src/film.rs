//! The film: per-pixel accumulation of per-iteration estimates.
//!
//! Every iteration produces one estimate per pixel (one camera sample, plus
//! light-tracing splats in the bidirectional methods). The film keeps, in
//! f64, the running sum and the sum of squares of these estimates, so that
//! the mean image and its noise (SPEC §8: s^2 = (sum x^2 - (sum x)^2/N)/(N-1))
//! come out of the same buffers without storing iterations.

use glam::{DVec3, Vec3};

/// Accumulated per-iteration estimates of an image.
#[derive(Clone, Debug)]
pub struct Film {
    width: u32,
    height: u32,
    iterations: u64,
    sum: Vec<DVec3>,
    sum_sq: Vec<DVec3>,
}

impl Film {
    /// An empty film of `width` x `height` pixels.
    pub fn new(width: u32, height: u32) -> Self {
        let n = width as usize * height as usize;
        Self {
            width,
            height,
            iterations: 0,
            sum: vec![DVec3::ZERO; n],
            sum_sq: vec![DVec3::ZERO; n],
        }
    }

    /// Image width in pixels.
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Number of iterations accumulated.
    pub fn iterations(&self) -> u64 {
        self.iterations
    }

    /// Adds one iteration's estimates, row-major, one per pixel.
    ///
    /// # Panics
    /// If `estimates` does not have one entry per pixel (a programming error).
    pub fn add_iteration(&mut self, estimates: &[Vec3]) {
        assert_eq!(estimates.len(), self.sum.len(), "one estimate per pixel");
        for ((s, q), x) in self.sum.iter_mut().zip(&mut self.sum_sq).zip(estimates) {
            let x = x.as_dvec3();
            *s += x;
            *q += x * x;
        }
        self.iterations += 1;
    }

    /// Adds every iteration of `other` (same size): films rendered over
    /// disjoint iteration ranges sum to the film of the union.
    ///
    /// # Panics
    /// If the sizes differ.
    pub fn merge(&mut self, other: &Film) {
        assert_eq!((self.width, self.height), (other.width, other.height));
        for (a, b) in self.sum.iter_mut().zip(&other.sum) {
            *a += *b;
        }
        for (a, b) in self.sum_sq.iter_mut().zip(&other.sum_sq) {
            *a += *b;
        }
        self.iterations += other.iterations;
    }

    /// The per-pixel sums and sums of squares of the estimates, row-major:
    /// the film's whole state besides its size and iteration count (saved
    /// by partial renders).
    pub fn sums(&self) -> (&[DVec3], &[DVec3]) {
        (&self.sum, &self.sum_sq)
    }

    /// A film with the given state (see [`Film::sums`]); `None` unless both
    /// buffers have one entry per pixel.
    pub fn from_sums(
        width: u32,
        height: u32,
        iterations: u64,
        sum: Vec<DVec3>,
        sum_sq: Vec<DVec3>,
    ) -> Option<Self> {
        let n = width as usize * height as usize;
        (sum.len() == n && sum_sq.len() == n).then_some(Self {
            width,
            height,
            iterations,
            sum,
            sum_sq,
        })
    }

    /// The mean of the iterations, row-major (black before the first iteration).
    pub fn mean(&self) -> Vec<Vec3> {
        let inv = if self.iterations == 0 {
            0.0
        } else {
            1.0 / self.iterations as f64
        };
        self.sum.iter().map(|s| (*s * inv).as_vec3()).collect()
    }

    /// Mean of pixel (x, y) in f64.
    pub fn pixel_mean(&self, x: u32, y: u32) -> DVec3 {
        let i = y as usize * self.width as usize + x as usize;
        self.sum[i] / self.iterations.max(1) as f64
    }

    /// Sample variance s^2 of the per-iteration estimates of each pixel
    /// (SPEC §8), per channel; zero with fewer than two iterations. Rounding
    /// can make the difference slightly negative: it is clamped at 0.
    pub fn variance(&self) -> Vec<DVec3> {
        let n = self.iterations as f64;
        if self.iterations < 2 {
            return vec![DVec3::ZERO; self.sum.len()];
        }
        self.sum
            .iter()
            .zip(&self.sum_sq)
            .map(|(s, q)| ((*q - *s * *s / n) / (n - 1.0)).max(DVec3::ZERO))
            .collect()
    }

    /// Standard error s/sqrt(N) of each pixel's mean, per channel (SPEC §8).
    pub fn standard_error(&self) -> Vec<DVec3> {
        let n = self.iterations.max(1) as f64;
        self.variance()
            .into_iter()
            .map(|v| (v / n).map(f64::sqrt))
            .collect()
    }
}

/// Light-tracing contributions of one block of light subpaths: (pixel, value)
/// pairs recorded by the thread that traced the block.
///
/// Blocks are a fixed partition of the light subpaths, and [`Splats::add_to`]
/// is called in block order, so the sum (and hence the image, bit for bit)
/// does not depend on the number of threads or on scheduling, unlike atomic
/// float additions.
#[derive(Clone, Debug, Default)]
pub struct Splats {
    entries: Vec<(u32, Vec3)>,
}

impl Splats {
    /// Records `value` for pixel index `pixel` (row-major).
    pub fn push(&mut self, pixel: u32, value: Vec3) {
        self.entries.push((pixel, value));
    }

    /// Forgets all entries, keeping the allocation.
    pub fn clear(&mut self) {
        self.entries.clear();
    }

    /// Number of recorded contributions.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// True when nothing was recorded.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Adds every entry, in recording order, to `image` (row-major). Entries
    /// with an out-of-range pixel index are a programming error.
    pub fn add_to(&self, image: &mut [Vec3]) {
        for &(pixel, value) in &self.entries {
            image[pixel as usize] += value;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_and_variance_match_direct_formulas() {
        let mut film = Film::new(2, 1);
        let xs = [1.0f32, 2.0, 4.0, 7.0];
        for &x in &xs {
            film.add_iteration(&[Vec3::splat(x), Vec3::new(x, 0.0, -x)]);
        }
        let mean = film.mean();
        assert_eq!(mean[0], Vec3::splat(3.5));
        assert_eq!(mean[1], Vec3::new(3.5, 0.0, -3.5));
        // s^2 = sum (x - 3.5)^2 / 3 = (6.25 + 2.25 + 0.25 + 12.25) / 3 = 7.
        let var = film.variance();
        assert!((var[0].x - 7.0).abs() < 1e-12);
        assert!((var[1].z - 7.0).abs() < 1e-12 && var[1].y == 0.0);
        let se = film.standard_error();
        assert!((se[0].x - (7.0f64 / 4.0).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn merged_films_equal_one_film_over_all_iterations() {
        let (mut a, mut b, mut all) = (Film::new(1, 1), Film::new(1, 1), Film::new(1, 1));
        for i in 0..6 {
            let x = [Vec3::splat(i as f32 * 0.5)];
            all.add_iteration(&x);
            if i < 2 {
                a.add_iteration(&x)
            } else {
                b.add_iteration(&x)
            }
        }
        a.merge(&b);
        assert_eq!(a.iterations(), 6);
        assert_eq!(a.mean(), all.mean());
        assert_eq!(a.variance(), all.variance());
    }

    #[test]
    fn empty_film_is_black_and_splats_add_in_order() {
        let film = Film::new(3, 2);
        assert!(film.mean().iter().all(|p| *p == Vec3::ZERO));
        assert!(film.variance().iter().all(|p| *p == DVec3::ZERO));
        let mut splats = Splats::default();
        splats.push(1, Vec3::ONE);
        splats.push(1, Vec3::splat(2.0));
        splats.push(4, Vec3::X);
        let mut image = vec![Vec3::ZERO; 6];
        splats.add_to(&mut image);
        assert_eq!(image[1], Vec3::splat(3.0));
        assert_eq!(image[4], Vec3::X);
        assert_eq!(splats.len(), 3);
        splats.clear();
        assert!(splats.is_empty());
    }
}
