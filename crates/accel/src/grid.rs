//! Hashed uniform grid for fixed-radius point queries (photon merging in PPM
//! and VCM), built in parallel once per iteration.

use glam::Vec3;
use rayon::prelude::*;

/// Largest hash table (buckets): bucket ids share a `u64` sort key with the
/// point index.
const MAX_BUCKETS: usize = 1 << 31;

/// Work items per rayon task during the build.
const MIN_PARALLEL_LEN: usize = 4096;

/// Up to this many cells, a query removes duplicate buckets itself (the usual
/// 2 x 2 x 2 case); beyond it, each candidate's cell is checked instead.
const SMALL_QUERY_CELLS: usize = 8;

/// Cells in a block of 2 x 2 x 2, whose buckets are adjacent.
const BLOCK_CELLS: usize = 8;

/// Slots a small query gathers before reporting them.
const FOUND_GROUP: usize = 16;

/// A hashed uniform grid over a set of points, answering "which stored points
/// lie within `radius` of `q`" ([`HashGrid::for_each_within`]).
///
/// # Layout
/// Cells are cubes of side `2 * radius` (the build radius), so a query of that
/// radius touches at most 2 x 2 x 2 cells. Cells are hashed, in blocks of
/// 2 x 2 x 2 whose eight buckets are adjacent, into a table of
/// `n.next_power_of_two()` buckets (n = number of points, at least 8), and the points are
/// sorted by bucket: memory is about 32 bytes per point plus 4 to 8 bytes of
/// bucket offsets, independent of the scene's extent. Hash collisions only add
/// candidates, which the distance test rejects. The sorted points are the
/// grid's slots `0..len()`: a caller that keeps its per-point data in slot
/// order ([`HashGrid::point_index`]) and queries by slot
/// ([`HashGrid::for_each_slot_within`]) reads a bucket's data from adjacent
/// memory.
///
/// # Determinism
/// The build runs on the current rayon pool, but its result (and so the SET and
/// the ORDER of the indices a query reports) depends only on the points and the
/// build radius, not on the number of threads: points are sorted by the unique
/// key (bucket, index), and a query visits cells in a fixed order and the
/// points of a bucket by increasing index.
///
/// # Reuse
/// [`HashGrid::build`] reuses the grid's buffers: rebuilding with at most as
/// many points as any earlier build does not allocate.
#[derive(Clone, Debug, Default)]
pub struct HashGrid {
    radius: f32,
    cell_size: f64,
    inv_cell_size: f64,
    /// Number of buckets minus one (buckets are a power of two).
    bucket_mask: u64,
    /// Sort keys `bucket << 32 | index`, sorted: the low half is the index.
    keys: Vec<u64>,
    /// Point positions in key order.
    positions: Vec<Vec3>,
    /// `starts[b]..starts[b + 1]` is bucket `b`'s range in `keys`/`positions`.
    starts: Vec<u32>,
    /// The build's keys in index order (kept for its buffer).
    unsorted: Vec<u64>,
}

impl HashGrid {
    /// An empty grid (finds nothing until built).
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// A grid built over `points` for queries of about `radius`.
    #[must_use]
    pub fn with_points(points: &[Vec3], radius: f32) -> Self {
        let mut grid = Self::new();
        grid.build(points, radius);
        grid
    }

    /// Rebuilds the grid over `points` for queries of about `radius` (cell
    /// side `2 * radius`), in parallel on the current rayon pool, reusing the
    /// grid's buffers. Queries stay exact for any radius; this one only sets
    /// the cell size. A radius that is not positive and finite builds with
    /// cell side 1. Points with non-finite coordinates are stored but never
    /// found.
    ///
    /// # Panics
    /// If there are more than `u32::MAX` points.
    pub fn build(&mut self, points: &[Vec3], radius: f32) {
        self.build_with(points.len(), radius, |i| points[i]);
    }

    /// Like [`HashGrid::build`], for points held elsewhere (for example in a
    /// photon struct): `position(i)` for `i` in `0..count` is the position of
    /// point `i`, and `i` is what queries report.
    ///
    /// # Panics
    /// If `count > u32::MAX`.
    pub fn build_with(
        &mut self,
        count: usize,
        radius: f32,
        position: impl Fn(usize) -> Vec3 + Sync,
    ) {
        assert!(
            u32::try_from(count).is_ok(),
            "accel::HashGrid supports at most u32::MAX points"
        );
        self.radius = radius;
        self.cell_size = if radius > 0.0 && radius.is_finite() {
            2.0 * f64::from(radius)
        } else {
            1.0
        };
        self.inv_cell_size = 1.0 / self.cell_size;
        let buckets = count.next_power_of_two().clamp(BLOCK_CELLS, MAX_BUCKETS);
        self.bucket_mask = buckets as u64 - 1;

        // Keys (bucket << 32 | index) in index order, in parallel, then
        // counting-sorted by bucket: a bucket's points keep their index
        // order, so the grid is the one that sorting the (unique) keys would
        // give, on any number of threads. (A comparison sort took 2.7 % of a
        // PPM iteration on `smallvcm-2`; the count also gives `starts`.)
        let mut unsorted = std::mem::take(&mut self.unsorted);
        unsorted.clear();
        unsorted.resize(count, 0);
        let grid = &*self;
        unsorted
            .par_iter_mut()
            .with_min_len(MIN_PARALLEL_LEN)
            .enumerate()
            .for_each(|(i, key)| {
                let bucket = grid.bucket(grid.cell_of(position(i)));
                *key = (bucket << 32) | i as u64;
            });
        self.sort_into_buckets(&unsorted, buckets);
        self.unsorted = unsorted;

        self.positions.clear();
        self.positions.resize(count, Vec3::ZERO);
        self.positions
            .par_iter_mut()
            .with_min_len(MIN_PARALLEL_LEN)
            .zip(self.keys.par_iter())
            .for_each(|(p, key)| *p = position(*key as u32 as usize));
    }

    /// `keys` = `unsorted` sorted by bucket (then index: the order of
    /// `unsorted`), and `starts[b]` = the first position of bucket `b`
    /// (`starts[buckets]` = the count): a counting sort, whose count is the
    /// bucket table.
    fn sort_into_buckets(&mut self, unsorted: &[u64], buckets: usize) {
        let bucket = |key: u64| (key >> 32) as usize;
        self.starts.clear();
        self.starts.resize(buckets + 1, 0);
        for &key in unsorted {
            self.starts[bucket(key)] += 1;
        }
        // Running sums: starts[b] is now the end of bucket b.
        let mut end = 0;
        for start in &mut self.starts {
            end += *start;
            *start = end;
        }
        // Placed from the last key down, each bucket fills from its end
        // backwards, which leaves starts[b] at its first position.
        self.keys.clear();
        self.keys.resize(unsorted.len(), 0);
        for &key in unsorted.iter().rev() {
            let start = &mut self.starts[bucket(key)];
            *start -= 1;
            self.keys[*start as usize] = key;
        }
    }

    /// Number of stored points.
    #[must_use]
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether the grid holds no points.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// The radius of the last build.
    #[must_use]
    pub fn radius(&self) -> f32 {
        self.radius
    }

    /// Side of a grid cell (`2 * radius` for a valid build radius).
    #[must_use]
    pub fn cell_size(&self) -> f32 {
        self.cell_size as f32
    }

    /// Calls `f(index)` once for every stored point `p` within `radius` of
    /// `point`, boundary included: `|p - point|^2 <= radius^2`, evaluated in
    /// f64 from the f32 inputs (the differences and squares are exact there,
    /// so a point exactly at distance `radius` is found).
    ///
    /// Any radius is answered exactly; radii up to the build radius are the
    /// fast case (at most 8 cells). When a query would touch more cells than
    /// the table has buckets, it scans all points instead. Finds nothing for
    /// a negative or NaN radius or a non-finite `point`. Does not allocate.
    pub fn for_each_within(&self, point: Vec3, radius: f32, mut f: impl FnMut(usize)) {
        self.for_each_slot_within(point, radius, |slot| f(self.point_index(slot)));
    }

    /// Index (as given to the build) of the point stored in `slot`, a
    /// position `0..len()` in the grid's storage order, which keeps the
    /// points of a bucket together.
    ///
    /// # Panics
    /// If `slot >= len()`.
    #[inline]
    #[must_use]
    pub fn point_index(&self, slot: usize) -> usize {
        self.keys[slot] as u32 as usize
    }

    /// [`HashGrid::for_each_within`], reporting each point by its slot
    /// ([`HashGrid::point_index`]) instead of its index, in the same order.
    /// Data that a caller keeps per point in slot order is read in the
    /// order the query visits it: the points of one bucket from adjacent
    /// memory, where data in index order would cost a cache miss per point.
    pub fn for_each_slot_within(&self, point: Vec3, radius: f32, mut f: impl FnMut(usize)) {
        if self.is_empty() || !(radius >= 0.0) || !point.is_finite() {
            return;
        }
        let q = point.as_dvec3();
        let r = f64::from(radius);
        let r2 = r * r;
        let within = |p: Vec3| {
            let d = p.as_dvec3() - q;
            d.x * d.x + d.y * d.y + d.z * d.z <= r2
        };
        // Cell range covering [q - r, q + r], widened by one cell where the
        // bound lies within rounding distance of a cell boundary.
        let range = |c: f64| -> (i64, i64) {
            let lo = (c - r) * self.inv_cell_size;
            let hi = (c + r) * self.inv_cell_size;
            let pad_lo = 1e-6 + lo.abs() * 1e-15;
            let pad_hi = 1e-6 + hi.abs() * 1e-15;
            (floor_to_i64(lo - pad_lo), floor_to_i64(hi + pad_hi))
        };
        let (x0, x1) = range(q.x);
        let (y0, y1) = range(q.y);
        let (z0, z1) = range(q.z);
        let span = |a: i64, b: i64| (b as i128 - a as i128 + 1) as u128;
        let cells = span(x0, x1)
            .saturating_mul(span(y0, y1))
            .saturating_mul(span(z0, z1));

        if cells > self.starts.len() as u128 {
            // Larger than the table: one pass over all points is cheaper.
            for (slot, p) in self.positions.iter().enumerate() {
                if within(*p) {
                    f(slot);
                }
            }
            return;
        }

        if cells <= SMALL_QUERY_CELLS as u128 {
            // Two cells of one query may share a bucket: visit each bucket once.
            let mut buckets = [0u64; SMALL_QUERY_CELLS];
            let mut n = 0;
            for z in z0..=z1 {
                for y in y0..=y1 {
                    for x in x0..=x1 {
                        let b = self.bucket([x, y, z]);
                        if !buckets[..n].contains(&b) {
                            buckets[n] = b;
                            n += 1;
                        }
                    }
                }
            }
            // Every bucket's range first: the table reads (each likely a
            // cache miss) are then in flight together, not one per bucket
            // after the previous bucket's points.
            let mut ranges = [(0, 0); SMALL_QUERY_CELLS];
            for (range, &b) in ranges.iter_mut().zip(&buckets[..n]) {
                *range = self.bucket_range(b);
            }
            // Slots within the radius are gathered without a branch on the
            // test (about one in four passes: it mispredicts, and each
            // misprediction stopped the next bucket's reads) and reported in
            // groups.
            let mut found = [0u32; FOUND_GROUP];
            let mut k = 0;
            for &(start, end) in &ranges[..n] {
                for slot in start..end {
                    found[k] = slot as u32;
                    k += usize::from(within(self.positions[slot]));
                    if k == FOUND_GROUP {
                        found.iter().for_each(|&s| f(s as usize));
                        k = 0;
                    }
                }
            }
            found[..k].iter().for_each(|&s| f(s as usize));
            return;
        }

        // Many cells: report a candidate only from its own cell, so a bucket
        // shared by several cells of the query reports each point once.
        for z in z0..=z1 {
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let cell = [x, y, z];
                    let (start, end) = self.bucket_range(self.bucket(cell));
                    for slot in start..end {
                        let p = self.positions[slot];
                        if within(p) && self.cell_of(p) == cell {
                            f(slot);
                        }
                    }
                }
            }
        }
    }

    #[inline]
    fn bucket_range(&self, bucket: u64) -> (usize, usize) {
        let b = bucket as usize;
        (self.starts[b] as usize, self.starts[b + 1] as usize)
    }

    /// Integer cell of a position (saturating for far or non-finite points).
    #[inline]
    fn cell_of(&self, p: Vec3) -> [i64; 3] {
        let c = |x: f32| floor_to_i64(f64::from(x) * self.inv_cell_size);
        [c(p.x), c(p.y), c(p.z)]
    }

    /// Bucket of a cell: cells are grouped in blocks of 2 x 2 x 2, a block
    /// goes to [`BLOCK_CELLS`] adjacent buckets (one per cell), picked by a
    /// multiplicative hash of the block's coordinates (high bits after a
    /// 64-bit mix). A query's 2 x 2 x 2 cells then lie in 3.4 blocks on
    /// average instead of 8 unrelated buckets: fewer cache lines of bucket
    /// starts and of points to read.
    #[inline]
    fn bucket(&self, cell: [i64; 3]) -> u64 {
        let [x, y, z] = cell;
        let mut h = ((x >> 1) as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15)
            ^ ((y >> 1) as u64).wrapping_mul(0xC2B2_AE3D_27D4_EB4F)
            ^ ((z >> 1) as u64).wrapping_mul(0x1656_67B1_9E37_79F9);
        h ^= h >> 31;
        h = h.wrapping_mul(0xBF58_476D_1CE4_E5B9);
        h ^= h >> 29;
        let within_block = (x & 1) | (y & 1) << 1 | (z & 1) << 2;
        ((h >> 32) * BLOCK_CELLS as u64 + within_block as u64) & self.bucket_mask
    }
}

/// `x.floor() as i64` (saturating; NaN gives 0) without the call to the
/// floor routine that the baseline x86-64 target makes (it has no SSE4.1
/// rounding instruction): 1.5 % of a BPM iteration, six calls per query.
/// Truncation rounds toward zero, so one is taken off where that rounded up.
#[inline]
fn floor_to_i64(x: f64) -> i64 {
    let t = x as i64;
    if t as f64 > x { t.saturating_sub(1) } else { t }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn points(n: usize) -> Vec<Vec3> {
        (0..n)
            .map(|i| {
                let f = i as f32;
                Vec3::new((f * 0.37).fract(), (f * 0.61).fract(), (f * 0.113).fract())
            })
            .collect()
    }

    #[test]
    fn floor_to_i64_is_floor() {
        let mut values = vec![
            0.0,
            -0.0,
            0.5,
            -0.5,
            -1.0,
            1.0 - f64::EPSILON,
            -1.0 - f64::EPSILON,
            2f64.powi(52) + 0.5,
            -(2f64.powi(52) + 0.5),
            2f64.powi(63),
            -(2f64.powi(63)),
            -(2f64.powi(63)) - 4096.0,
            1e300,
            -1e300,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NAN,
            f64::MIN_POSITIVE,
            -f64::MIN_POSITIVE,
        ];
        let mut z = 0x9e37_79b9_7f4a_7c15u64;
        for _ in 0..100_000 {
            z = z.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            values.push(((z >> 11) as f64 / (1u64 << 53) as f64 - 0.5) * 1e4);
        }
        for x in values {
            assert_eq!(floor_to_i64(x), x.floor() as i64, "{x}");
        }
    }

    #[test]
    fn rebuild_reuses_buffers() {
        let mut grid = HashGrid::new();
        grid.build(&points(5000), 0.05);
        let ptrs = (
            grid.keys.as_ptr(),
            grid.unsorted.as_ptr(),
            grid.positions.as_ptr(),
            grid.starts.as_ptr(),
        );
        for n in [5000, 4000, 17, 0, 4999] {
            grid.build(&points(n), 0.01 * (n % 7 + 1) as f32);
            assert_eq!(grid.len(), n);
            assert_eq!(
                ptrs,
                (
                    grid.keys.as_ptr(),
                    grid.unsorted.as_ptr(),
                    grid.positions.as_ptr(),
                    grid.starts.as_ptr()
                )
            );
        }
    }

    #[test]
    fn bucket_offsets_are_consistent() {
        let grid = HashGrid::with_points(&points(3000), 0.02);
        // Sorted by (bucket, index): the order of the sorted unique keys.
        assert!(grid.keys.windows(2).all(|k| k[0] < k[1]));
        assert_eq!(grid.starts.len(), 4096 + 1);
        assert_eq!(grid.starts[0], 0);
        assert_eq!(*grid.starts.last().unwrap() as usize, 3000);
        for b in 0..4096u64 {
            let (s, e) = grid.bucket_range(b);
            assert!(s <= e);
            for j in s..e {
                assert_eq!(grid.keys[j] >> 32, b);
                assert_eq!(grid.bucket(grid.cell_of(grid.positions[j])), b);
            }
        }
    }
}
