//! Deterministic random numbers: every value is a pure function of
//! (seed, iteration, stream, dimension), with the stream a pixel index for
//! camera subpaths (or a light-subpath index), so images do not depend on
//! the thread count or the order in which work is scheduled.
//!
//! Values come from Owen-scrambled Sobol points (Burley 2020, the
//! `sobol_burley` crate): the iteration is the point index, each stream has
//! its own scramble seed. Beyond the 256 dimensions of the table (paths
//! longer than about 35 bounces) and for iterations past 2^16 the values come
//! from a hash of all four inputs, or from a reseeded sequence, so that no
//! input repeats a value.
//!
//! Subpaths use a fixed dimension layout per vertex (so that a change at
//! one vertex does not shift the others): [`Sampler::camera_vertex`] and
//! [`Sampler::light_vertex`] are the only places that know it.

use glam::Vec2;
use sobol_burley::parts;

/// Sobol points per scramble seed (the table's index limit): iteration
/// numbers beyond it start a new, independently scrambled sequence.
const POINTS_PER_SEED: u64 = 1 << 16;

/// `sobol_burley::sample_4d`'s salt of the stream seed for the point shuffle.
const SHUFFLE_SALT: u32 = 0x79c6_8e4a;

/// Sampler streams of light subpaths start here (camera subpaths use the
/// pixel index), so the two never share random numbers.
pub const LIGHT_STREAM: u64 = 1 << 48;

/// Dimensions of a camera subpath's start: the position in the pixel.
const PIXEL_DIMENSIONS: u32 = 2;

/// Dimensions per camera subpath vertex: light choice (1), light point
/// (2), BSDF lobe choice (1), BSDF direction (2), roulette (1).
const CAMERA_VERTEX_DIMENSIONS: u32 = 7;

/// Dimensions of a light subpath's start: light choice (1), position (2),
/// direction (2).
const EMISSION_DIMENSIONS: u32 = 5;

/// Dimensions per light subpath vertex: BSDF lobe (1), direction (2),
/// roulette (1). Packed back to back, so that a vertex mostly needs one new
/// 4-dimension Sobol set (with a camera vertex's stride of 7, two).
const LIGHT_VERTEX_DIMENSIONS: u32 = 4;

/// The random numbers of one step of a walk: BSDF sampling and Russian
/// roulette (all a light subpath vertex draws).
#[derive(Clone, Copy, Debug)]
pub struct StepSamples {
    /// BSDF lobe choice.
    pub u_lobe: f32,
    /// BSDF direction.
    pub uv_bsdf: Vec2,
    /// Russian roulette.
    pub u_roulette: f32,
}

/// The random numbers of one camera subpath vertex: next-event estimation,
/// then the step.
#[derive(Clone, Copy, Debug)]
pub struct CameraVertexSamples {
    /// Light choice.
    pub u_light: f32,
    /// Point on the light.
    pub uv_light: Vec2,
    /// BSDF sampling and roulette.
    pub step: StepSamples,
}

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
/// Sobol values are computed four dimensions at a time (SIMD) and cached: a
/// path vertex uses seven consecutive dimensions.
#[derive(Clone, Copy, Debug)]
pub struct Sampler {
    index: u32,
    seed: u64,
    /// The point index after the stream's Owen shuffle (bit-reversed), the
    /// first step of `sobol_burley::sample_4d`, which depends only on the
    /// stream: computed once here instead of once per 4 dimensions.
    shuffled_rev_index: u32,
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
        let index = (iteration % POINTS_PER_SEED) as u32;
        let seed = mix(mix(mix(seed) ^ stream) ^ epoch.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        Self {
            index,
            seed,
            shuffled_rev_index: parts::owen_scramble_rev(
                index.reverse_bits(),
                parts::hash(seed as u32 ^ SHUFFLE_SALT),
            ),
            dimension: 0,
            cached_set: u32::MAX,
            cache: [0.0; 4],
        }
    }

    /// Skips to dimension `dimension`.
    pub fn set_dimension(&mut self, dimension: u32) {
        self.dimension = dimension;
    }

    /// The position in the pixel of a camera subpath (its first dimensions).
    pub fn pixel_position(&mut self) -> Vec2 {
        self.set_dimension(0);
        self.next_2d()
    }

    /// The numbers of camera subpath vertex `depth` (1: the first hit).
    pub fn camera_vertex(&mut self, depth: u32) -> CameraVertexSamples {
        self.set_dimension(PIXEL_DIMENSIONS + (depth - 1) * CAMERA_VERTEX_DIMENSIONS);
        let (u_light, uv_light) = (self.next_1d(), self.next_2d());
        CameraVertexSamples {
            u_light,
            uv_light,
            step: self.step(),
        }
    }

    /// The light choice, position and direction of a light subpath's start.
    pub fn emission(&mut self) -> (f32, Vec2, Vec2) {
        self.set_dimension(0);
        (self.next_1d(), self.next_2d(), self.next_2d())
    }

    /// The numbers of light subpath vertex `length` (1: the first hit).
    pub fn light_vertex(&mut self, length: u32) -> StepSamples {
        self.set_dimension(EMISSION_DIMENSIONS + (length - 1) * LIGHT_VERTEX_DIMENSIONS);
        self.step()
    }

    /// A step's numbers from the current dimension on.
    fn step(&mut self) -> StepSamples {
        let (u_lobe, uv_bsdf) = (self.next_1d(), self.next_2d());
        StepSamples {
            u_lobe,
            uv_bsdf,
            u_roulette: self.next_1d(),
        }
    }

    /// The next value in [0, 1).
    pub fn next_1d(&mut self) -> f32 {
        let d = self.dimension;
        self.dimension += 1;
        if d < sobol_burley::NUM_DIMENSIONS {
            let set = d / 4;
            if set != self.cached_set {
                self.cache = self.sobol_4d(set);
                self.cached_set = set;
            }
            self.cache[(d % 4) as usize]
        } else {
            unit_f32(mix(
                self.seed ^ mix(u64::from(d) << 32 | u64::from(self.index))
            ))
        }
    }

    /// A value in [0, 1) for a decision with no place in the per-vertex
    /// dimension layout (one per vertex pair, for instance), named by `key`:
    /// a hash of the stream, the iteration and the key, independent of the
    /// Sobol dimensions and of [`Sampler::next_1d`]'s position.
    pub fn keyed_1d(&self, key: u64) -> f32 {
        /// Sets the hash input apart from the dimension fallback of `next_1d`.
        const KEYED: u64 = 0x5851_f42d_4c95_7f2d;
        unit_f32(mix(
            self.seed ^ mix(mix(key ^ KEYED) ^ u64::from(self.index))
        ))
    }

    /// Dimensions 4 set .. 4 set + 3: `sobol_burley::sample_4d(index, set,
    /// seed)` (Burley 2020: Sobol, then per-dimension Owen scrambling), from
    /// the crate's public parts with the stream's shuffle done once.
    fn sobol_4d(&self, set: u32) -> [f32; 4] {
        /// `sample_4d`'s constants: a multiplier that decorrelates
        /// structured seeds, and one scramble salt per dimension of a set.
        const SEED_MULTIPLIER: u32 = 0x9c8f_2d3b;
        const DIMENSION_SALTS: [u32; 4] = [0x912f_69ba, 0x174f_18ab, 0x691e_72ca, 0xb40c_c1b8];
        let sobol = parts::sobol_int4_rev(self.shuffled_rev_index, set);
        let seed = (self.seed as u32).wrapping_mul(SEED_MULTIPLIER);
        let scramble = parts::Int4::from([seed ^ set; 4]) ^ DIMENSION_SALTS.into();
        parts::owen_scramble_int4_rev(sobol, parts::hash_int4(scramble))
            .reverse_bits()
            .to_f32_norm()
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
        for (it, stream, set) in [(0, 0, 0), (1, 5, 3), (65_535, 1 << 48, 63)] {
            let s = Sampler::new(11, it, stream);
            let expected = sobol_burley::sample_4d(s.index, set, s.seed as u32);
            assert_eq!(s.sobol_4d(set), expected, "iteration {it}, set {set}");
        }
    }

    #[test]
    fn keyed_values_are_uniform_and_apart_from_dimensions() {
        let n = 4096;
        let xs: Vec<f64> = (0..n)
            .map(|it| f64::from(Sampler::new(42, it, 5).keyed_1d(0x0003_0002)))
            .collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let se = (1.0 / 12.0 / n as f64).sqrt();
        assert!((mean - 0.5).abs() < 5.0 * se, "mean {mean}");
        let mut s = Sampler::new(42, 7, 5);
        let key = s.keyed_1d(300);
        s.set_dimension(300);
        assert_ne!(key, s.next_1d());
        assert_ne!(key, Sampler::new(42, 7, 5).keyed_1d(301));
        assert_ne!(key, Sampler::new(42, 7, 6).keyed_1d(300));
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
