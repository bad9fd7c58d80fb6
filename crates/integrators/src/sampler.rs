//! Deterministic random numbers: every value is a pure function of
//! (seed, iteration, stream, request), with the stream a pixel index for
//! camera subpaths (or a light-subpath index), so images do not depend on
//! the thread count or the order in which work is scheduled.
//!
//! Values come from padded Owen-scrambled Sobol points (Burley 2020,
//! "Practical Hash-based Owen Scrambling", §4 and §7; pbrt-v4's
//! `PaddedSobolSampler`; the `sobol_burley` crate's parts): the iteration is
//! the point index, and every request of up to four numbers (a light sample,
//! a BSDF sample, ...) takes the first four Sobol dimensions at an index
//! shuffled by its own hash, each dimension Owen-scrambled by its own seed.
//! So every 2-D request is a (0, 2)-sequence over iterations (4x4 strata at
//! 16 iterations, as a multi-jittered pattern has), and requests are
//! decorrelated from each other by the shuffles, as a padded sampler's are.
//! (Taking consecutive dimensions of one 256-dimension Sobol sequence
//! instead, as this module did before, pairs dimensions such as 3 and 4
//! whose 2-D projection is not a (0, 2)-net: the light samples of the first
//! bounce were stratified worse than a jittered pattern.)
//!
//! Subpaths use a fixed request layout per vertex (so that a change at one
//! vertex does not shift the others): [`Sampler::camera_vertex`] and
//! [`Sampler::light_vertex`] are the only places that know it.

use std::sync::LazyLock;

use glam::Vec2;
use sobol_burley::parts;

/// Sobol points per scramble seed (the table's index limit): iteration
/// numbers beyond it start a new, independently scrambled sequence.
const POINTS_PER_SEED: u64 = 1 << 16;

/// Sampler streams of light subpaths start here (camera subpaths use the
/// pixel index), so the two never share random numbers.
pub const LIGHT_STREAM: u64 = 1 << 48;

/// Requests of a camera subpath before its vertices: the position in the
/// pixel.
const PIXEL_REQUESTS: u32 = 1;

/// Requests per camera subpath vertex: the light sample (point, choice),
/// the step (BSDF direction, lobe, roulette).
const CAMERA_VERTEX_REQUESTS: u32 = 2;

/// Requests of a light subpath's start: position and light choice, then
/// the direction.
const EMISSION_REQUESTS: u32 = 2;

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
#[derive(Clone, Copy, Debug)]
pub struct Sampler {
    /// The point index within its epoch, bit-reversed (as every request
    /// takes it).
    index_rev: u32,
    seed: u64,
}

impl Sampler {
    /// The stream `stream` of iteration `iteration` under the user's `seed`.
    /// Iterations are the renderer's N, 1-based: iteration 1 is Sobol point
    /// 0, so that the iterations of a render, 1..=2^k, are one aligned block
    /// of points, the blocks the (0, 2)-sequence stratifies. (Iteration 0,
    /// used by the progress preview, is a point of its own.)
    pub fn new(seed: u64, iteration: u64, stream: u64) -> Self {
        let point = iteration.wrapping_sub(1);
        let epoch = point / POINTS_PER_SEED;
        let index = (point % POINTS_PER_SEED) as u32;
        let seed = mix(mix(mix(seed) ^ stream) ^ epoch.wrapping_mul(0x9e37_79b9_7f4a_7c15));
        Self {
            index_rev: index.reverse_bits(),
            seed,
        }
    }

    /// The position in the pixel of a camera subpath.
    pub fn pixel_position(&self) -> Vec2 {
        let [x, y, ..] = self.request(0);
        Vec2::new(x, y)
    }

    /// The numbers of camera subpath vertex `depth` (1: the first hit).
    pub fn camera_vertex(&self, depth: u32) -> CameraVertexSamples {
        let first = PIXEL_REQUESTS + (depth - 1) * CAMERA_VERTEX_REQUESTS;
        let [u, v, u_light, _] = self.request(first);
        CameraVertexSamples {
            u_light,
            uv_light: Vec2::new(u, v),
            step: self.step(first + 1),
        }
    }

    /// The light choice, position and direction of a light subpath's start.
    pub fn emission(&self) -> (f32, Vec2, Vec2) {
        let [u, v, u_select, _] = self.request(0);
        let [s, t, ..] = self.request(1);
        (u_select, Vec2::new(u, v), Vec2::new(s, t))
    }

    /// The numbers of light subpath vertex `length` (1: the first hit).
    pub fn light_vertex(&self, length: u32) -> StepSamples {
        self.step(EMISSION_REQUESTS + length - 1)
    }

    /// A step's numbers: the direction from the request's (0, 2)-stratified
    /// pair, the lobe and roulette from its other two dimensions.
    fn step(&self, request: u32) -> StepSamples {
        let [u, v, u_lobe, u_roulette] = self.request(request);
        StepSamples {
            u_lobe,
            uv_bsdf: Vec2::new(u, v),
            u_roulette,
        }
    }

    /// A value in [0, 1) for a decision with no place in the per-vertex
    /// request layout (one per vertex pair, for instance), named by `key`:
    /// a hash of the stream, the iteration and the key, independent of the
    /// Sobol requests.
    pub fn keyed_1d(&self, key: u64) -> f32 {
        /// Sets the hash input apart from the requests' scramble seeds.
        const KEYED: u64 = 0x5851_f42d_4c95_7f2d;
        unit_f32(mix(self.seed
            ^ mix(
                mix(key ^ KEYED) ^ u64::from(self.index_rev.reverse_bits())
            )))
    }

    /// Request `request`: Sobol dimensions 0-3 at this stream's point index
    /// shuffled by the request's own hash (a nested uniform scramble of the
    /// index, Burley 2020 §4), each dimension Owen-scrambled with its own
    /// seed (§3), as `sobol_burley::sample_4d(index, 0, seed)` does with the
    /// request's seed.
    fn request(&self, request: u32) -> [f32; 4] {
        /// `sample_4d`'s constants: a multiplier that decorrelates
        /// structured seeds, its salt of the index shuffle, and one
        /// scramble salt per dimension.
        const SEED_MULTIPLIER: u32 = 0x9c8f_2d3b;
        const SHUFFLE_SALT: u32 = 0x79c6_8e4a;
        const DIMENSION_SALTS: [u32; 4] = [0x912f_69ba, 0x174f_18ab, 0x691e_72ca, 0xb40c_c1b8];
        let seed = mix(self.seed ^ u64::from(request)) as u32;
        let shuffled_rev_index =
            parts::owen_scramble_rev(self.index_rev, parts::hash(seed ^ SHUFFLE_SALT));
        let sobol = sobol_set0_rev(shuffled_rev_index);
        let seed = seed.wrapping_mul(SEED_MULTIPLIER);
        let scramble = parts::Int4::from([seed; 4]) ^ DIMENSION_SALTS.into();
        parts::owen_scramble_int4_rev(sobol, parts::hash_int4(scramble))
            .reverse_bits()
            .to_f32_norm()
    }
}

/// Sobol dimensions 0-3 of the points whose bit-reversed index has `v` in
/// nibble `p` (bits 31-28 for p = 0, ..., 19-16 for p = 3) and zeros elsewhere.
static NIBBLE_POINTS: LazyLock<[[[u32; 4]; 16]; 4]> = LazyLock::new(|| {
    std::array::from_fn(|p| {
        std::array::from_fn(|v| parts::sobol_int4_rev((v as u32) << (28 - 4 * p), 0).into())
    })
});

/// `parts::sobol_int4_rev(n_rev, 0)`: a Sobol point is the XOR of its
/// index bits' direction vectors, so four lookups, one per nibble of the
/// 16 index bits the table has, give it without the bit loop (whose
/// data-dependent trip count mispredicted).
fn sobol_set0_rev(n_rev: u32) -> parts::Int4 {
    let table = &*NIBBLE_POINTS;
    let nibble = |p: usize| table[p][(n_rev >> (28 - 4 * p)) as usize & 0xf];
    let (a, b, c, d) = (nibble(0), nibble(1), nibble(2), nibble(3));
    std::array::from_fn::<u32, 4, _>(|k| a[k] ^ b[k] ^ c[k] ^ d[k]).into()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every number a camera subpath of 40 vertices draws.
    fn camera_numbers(seed: u64, iteration: u64, stream: u64) -> Vec<f32> {
        let s = Sampler::new(seed, iteration, stream);
        let mut out = s.pixel_position().to_array().to_vec();
        for depth in 1..=40 {
            let u = s.camera_vertex(depth);
            out.extend([u.u_light, u.uv_light.x, u.uv_light.y, u.step.u_lobe]);
            out.extend([u.step.uv_bsdf.x, u.step.uv_bsdf.y, u.step.u_roulette]);
        }
        out
    }

    #[test]
    fn nibble_tables_give_the_sobol_points() {
        let mut n = 0x9e37_79b9u32;
        for i in 0..10_000u32 {
            n = parts::hash(n ^ i);
            let expected: [u32; 4] = parts::sobol_int4_rev(n, 0).into();
            let got: [u32; 4] = sobol_set0_rev(n).into();
            assert_eq!(got, expected, "index bits {n:#x}");
        }
    }

    #[test]
    fn streams_are_pure_functions_of_their_inputs() {
        let a = camera_numbers(7, 3, 11);
        assert_eq!(a, camera_numbers(7, 3, 11));
        assert_ne!(a, camera_numbers(8, 3, 11));
        assert_ne!(a, camera_numbers(7, 4, 11));
        assert_ne!(a, camera_numbers(7, 3, 12));
        assert_ne!(a, camera_numbers(7, 3 + POINTS_PER_SEED, 11));
        assert!(a.iter().all(|&u| (0.0..1.0).contains(&u)));
    }

    /// Every 2-D pair a walk uses is a (0, 2)-sequence over iterations: in
    /// each aligned block of 16 iterations (1..=16, 17..=32, ...), one point in every cell of each
    /// elementary grid of 16 cells (16x1, 8x2, 4x4, 2x8, 1x16), as a
    /// multi-jittered pattern is stratified; and the 1-D numbers one per
    /// sixteenth. (Consecutive dimensions 3 and 4 of one Sobol sequence, the
    /// old layout's first light sample, leave 4x4 cells empty.)
    #[test]
    fn every_pair_is_stratified_in_every_block_of_iterations() {
        type Pick = fn(&Sampler) -> Vec2;
        let pairs: [(&str, Pick); 6] = [
            ("pixel", |s| s.pixel_position()),
            ("light sample at depth 1", |s| s.camera_vertex(1).uv_light),
            ("bsdf at depth 1", |s| s.camera_vertex(1).step.uv_bsdf),
            ("light sample at depth 9", |s| s.camera_vertex(9).uv_light),
            ("emission direction", |s| s.emission().2),
            ("light vertex 3", |s| s.light_vertex(3).uv_bsdf),
        ];
        for (what, pick) in pairs {
            for (stream, block) in [(5, 0), (77, 1), (1 << 48, 37)] {
                let points: Vec<Vec2> = (16 * block + 1..=16 * block + 16)
                    .map(|it| pick(&Sampler::new(3, it, stream)))
                    .collect();
                for log_x in 0..=4 {
                    let (nx, ny) = (1 << log_x, 1 << (4 - log_x));
                    let mut cells = [0u32; 16];
                    for p in &points {
                        let (x, y) = ((p.x * nx as f32) as usize, (p.y * ny as f32) as usize);
                        cells[x * ny + y] += 1;
                    }
                    assert!(
                        cells.iter().all(|&c| c == 1),
                        "{what}, stream {stream}, block {block}: {nx}x{ny} cells {cells:?}"
                    );
                }
            }
        }
        let lobes: Vec<usize> = (1..=16)
            .map(|it| (Sampler::new(3, it, 9).camera_vertex(2).step.u_lobe * 16.0) as usize)
            .collect();
        let mut sorted = lobes.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (0..16).collect::<Vec<_>>(), "{lobes:?}");
    }

    #[test]
    fn keyed_values_are_uniform_and_apart_from_requests() {
        let n = 4096;
        let xs: Vec<f64> = (0..n)
            .map(|it| f64::from(Sampler::new(42, it, 5).keyed_1d(0x0003_0002)))
            .collect();
        let mean = xs.iter().sum::<f64>() / n as f64;
        let se = (1.0 / 12.0 / n as f64).sqrt();
        assert!((mean - 0.5).abs() < 5.0 * se, "mean {mean}");
        let s = Sampler::new(42, 7, 5);
        let key = s.keyed_1d(3);
        assert!(!camera_numbers(42, 7, 5).contains(&key));
        assert_ne!(key, Sampler::new(42, 7, 5).keyed_1d(4));
        assert_ne!(key, Sampler::new(42, 7, 6).keyed_1d(3));
    }

    /// Over iterations, every number of a long camera subpath is uniform:
    /// the mean of n values is 1/2 within 5 standard errors (sd of U(0,1)
    /// is 1/sqrt(12)), the variance 1/12; and numbers of different requests
    /// are uncorrelated (|r| within 5 / sqrt(n)).
    #[test]
    fn numbers_are_uniform_and_uncorrelated_over_iterations() {
        let n = 4096;
        let draws: Vec<Vec<f32>> = (0..n).map(|it| camera_numbers(42, it, 5)).collect();
        let column = |k: usize| draws.iter().map(|d| f64::from(d[k])).collect::<Vec<_>>();
        let moments = |xs: &[f64]| {
            let mean = xs.iter().sum::<f64>() / n as f64;
            let var = xs.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
            (mean, var)
        };
        let se = (1.0 / 12.0 / n as f64).sqrt();
        for k in (0..draws[0].len()).step_by(5) {
            let (mean, var) = moments(&column(k));
            assert!((mean - 0.5).abs() < 5.0 * se, "number {k}: mean {mean}");
            assert!((var - 1.0 / 12.0).abs() < 0.01, "number {k}: var {var}");
        }
        // Pixel x against the first light sample's u, and the first BSDF u
        // against the second vertex's light u: different requests.
        for (a, b) in [(0, 3), (6, 10)] {
            let (xa, xb) = (column(a), column(b));
            let cov = xa
                .iter()
                .zip(&xb)
                .map(|(x, y)| (x - 0.5) * (y - 0.5))
                .sum::<f64>()
                / n as f64;
            let r = cov * 12.0;
            assert!(r.abs() < 5.0 / (n as f64).sqrt(), "numbers {a}, {b}: r {r}");
        }
    }
}
