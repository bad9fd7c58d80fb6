//! Deterministic random numbers: every value is a pure function of
//! (seed, iteration, stream, dimension), with the stream a pixel index for
//! camera subpaths (or a light-subpath index), so images do not depend on
//! the thread count or the order in which work is scheduled (DESIGN.md,
//! "Determinism").
//!
//! Values come from Owen-scrambled Sobol points (Burley 2020, the
//! `sobol_burley` crate): the iteration is the point index, each stream has
//! its own scramble seed. Beyond the 256 dimensions of the table (paths
//! longer than about 35 bounces) and for iterations past 2^16 the values come
//! from a hash of all four inputs, or from a reseeded sequence, so that no
//! input repeats a value.

use glam::Vec2;

/// Sobol points per scramble seed (the table's index limit): iteration
/// numbers beyond it start a new, independently scrambled sequence.
const POINTS_PER_SEED: u64 = 1 << 16;

/// splitmix64's finaliser (Steele et al. 2014): a bijective 64-bit mix.
fn mix(mut z: u64) -> u64 {
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// A 53-bit-free conversion: the top 24 bits of `bits` as a float in [0, 1).
fn unit_f32(bits: u64) -> f32 {
    (bits >> 40) as f32 * (1.0 / (1u64 << 24) as f32)
}

/// The random stream of one pixel (or light subpath) in one iteration.
///
/// Sobol values are computed four dimensions at a time (`sample_4d`, SIMD)
/// and cached: a path vertex uses seven consecutive dimensions.
#[derive(Clone, Copy, Debug)]
pub struct Sampler {
    index: u32,
    seed: u64,
    dimension: u32,
    /// The 4-dimension set held in `cache` (`u32::MAX`: none).
    cached_set: u32,
    cache: [f32; 4],
}

impl Sampler {
    /// The stream `stream` of iteration `iteration` (1-based or 0-based, as
    /// long as the caller is consistent) under the user's `seed`.
    pub fn new(seed: u64, iteration: u64, stream: u64) -> Self {
        let epoch = iteration / POINTS_PER_SEED;
        Self {
            index: (iteration % POINTS_PER_SEED) as u32,
            seed: mix(mix(mix(seed) ^ stream) ^ epoch.wrapping_mul(0x9e37_79b9_7f4a_7c15)),
            dimension: 0,
            cached_set: u32::MAX,
            cache: [0.0; 4],
        }
    }

    /// Skips to dimension `dimension`: subpaths use a fixed dimension layout
    /// per vertex so that a change at one vertex does not shift the others.
    pub fn set_dimension(&mut self, dimension: u32) {
        self.dimension = dimension;
    }

    /// The next value in [0, 1).
    pub fn next_1d(&mut self) -> f32 {
        let d = self.dimension;
        self.dimension += 1;
        if d < sobol_burley::NUM_DIMENSIONS {
            let set = d / 4;
            if set != self.cached_set {
                self.cache = sobol_burley::sample_4d(self.index, set, self.seed as u32);
                self.cached_set = set;
            }
            self.cache[(d % 4) as usize]
        } else {
            unit_f32(mix(
                self.seed ^ mix(u64::from(d) << 32 | u64::from(self.index))
            ))
        }
    }

    /// The next two values.
    pub fn next_2d(&mut self) -> Vec2 {
        let x = self.next_1d();
        Vec2::new(x, self.next_1d())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn streams_are_pure_functions_of_their_inputs() {
        let draw = |seed, it, stream| {
            let mut s = Sampler::new(seed, it, stream);
            (0..300).map(|_| s.next_1d()).collect::<Vec<_>>()
        };
        let a = draw(7, 3, 11);
        assert_eq!(a, draw(7, 3, 11));
        assert_ne!(a, draw(8, 3, 11));
        assert_ne!(a, draw(7, 4, 11));
        assert_ne!(a, draw(7, 3, 12));
        assert_ne!(draw(7, 3, 11)[..], draw(7, 3 + POINTS_PER_SEED, 11)[..]);
        assert!(a.iter().all(|&u| (0.0..1.0).contains(&u)));
    }

    /// Over iterations, every dimension (in the table and past it) is
    /// uniform: the mean of n values is 1/2 within 5 standard errors
    /// (sd of U(0,1) is 1/sqrt(12)), and the variance is 1/12.
    #[test]
    fn four_dimensional_sets_equal_single_dimensions() {
        let mut s = Sampler::new(3, 17, 99);
        let seed = s.seed as u32;
        for d in 0..40 {
            assert_eq!(
                s.next_1d(),
                sobol_burley::sample(17, d, seed),
                "dimension {d}"
            );
        }
    }

    #[test]
    fn dimensions_are_uniform_over_iterations() {
        let n = 4096;
        for dim in [0, 1, 2, 57, 255, 256, 300] {
            let xs: Vec<f64> = (0..n)
                .map(|it| {
                    let mut s = Sampler::new(42, it, 5);
                    s.set_dimension(dim);
                    f64::from(s.next_1d())
                })
                .collect();
            let mean = xs.iter().sum::<f64>() / n as f64;
            let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
            let se = (1.0 / 12.0 / n as f64).sqrt();
            assert!((mean - 0.5).abs() < 5.0 * se, "dim {dim}: mean {mean}");
            assert!((var - 1.0 / 12.0).abs() < 0.01, "dim {dim}: var {var}");
        }
    }
}
