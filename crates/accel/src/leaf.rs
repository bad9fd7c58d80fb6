//! Triangle blocks: the triangles of one leaf stored lane by lane
//! (structure of arrays, Embree's `Triangle4`), and a SIMD kernel that runs
//! the watertight test of `triangle.rs` on all of them at once
//! ([`Layout::Bvh8`](crate::Layout::Bvh8)'s leaves, [`Layout::Flat`](crate::Layout::Flat)'s
//! blocks).
//!
//! **The same results as the scalar test, bit for bit.** Each lane
//! performs the float operations of [`RayTransform::intersect`] in the
//! same order: the three edge functions, their sum, a true division
//! (no approximate reciprocal), the barycentrics and `t`, with the same
//! comparisons (NaN included) and no fused multiply-add. One difference:
//! the ray transform leaves out the products by the matrix's exact zeros
//! (of its nine entries, four are zero by construction; glam's
//! `Mat3A * Vec3A` multiplies and adds them too). A zero term changes a
//! sum of finite values only when the sum is zero, and then only its
//! sign; a transformed coordinate of either zero sign gives the same
//! answer: it enters the edge functions through products, so it can flip
//! the sign only of an edge function that is zero, which both tests
//! recompute in f64 from the vertices (here: the scalar test does, see
//! below); and it enters `t` only as a term `b * 0`, whose sign matters
//! only for `t = 0`, a miss either way. So each lane's `t`, `b1`, `b2`
//! and verdict equal the scalar test's on every instruction set (the
//! tests here compare them on random and edge-case triangles at every
//! instruction set the CPU has).
//!
//! Lanes with an edge function of exactly zero, which the scalar test
//! recomputes in f64, are flagged and left to it ([`Lane::Scalar`]). The
//! caller walks the lanes in leaf order and is handed a lane's hit when its
//! `t` is at most the closest hit so far ([`LaneHits::lane`]), as the scalar
//! test would hand it over, and decides (ties go to the lower primitive id):
//! so queries return the same hits, ties included, and filters (alpha) are
//! called for the same hits in the same order.
//!
//! Any width: each lane's operations are the same whatever the number of
//! lanes. [`Layout::Bvh8`](crate::Layout::Bvh8)'s leaves are blocks of up
//! to four triangles (`bvh::BVH8_LEAF`), [`Layout::Flat`](crate::Layout::Flat)'s
//! blocks (`flat.rs`) of up to sixteen.

use std::ops::ControlFlow;

use fearless_simd::{Simd, SimdBase, SimdFloat, SimdMask};
use glam::Vec3A;

use crate::triangle::RayTransform;

/// Triangles per block of a [`Layout::Bvh8`](crate::Layout::Bvh8) leaf.
pub(crate) const BLOCK: usize = 4;

/// A lane vector of `W` floats on the instruction set `S` (`f32x4`,
/// `f32x8`, `f32x16`: with fewer hardware lanes, one operation is
/// several instructions with the same per-lane results).
pub(crate) trait Lanes<S: Simd, const W: usize>:
    SimdFloat<S, Element = f32> + SimdBase<S, Array = [f32; W]>
{
}

impl<S: Simd, const W: usize, V: SimdFloat<S, Element = f32> + SimdBase<S, Array = [f32; W]>>
    Lanes<S, W> for V
{
}

/// Up to `W` triangles, coordinate by coordinate; unused lanes are zero
/// (a degenerate triangle, and masked out anyway).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(16))]
pub(crate) struct TriangleBlock<const W: usize = BLOCK> {
    /// `v[k][axis][lane]`: vertex `k` of each lane's triangle.
    v: [[[f32; W]; 3]; 3],
    /// The primitive slot of lane 0; lane `j` holds slot `first + j`.
    pub first: u32,
    /// Number of lanes in use (1 to `W`).
    pub count: u32,
    /// Bit `j`: lane `j`'s slot holds no triangle (a sphere); the kernel
    /// leaves it to the caller ([`Lane::Scalar`]).
    other: u32,
}

impl<const W: usize> TriangleBlock<W> {
    /// The block of `triangles` (at most `W`), the first being in
    /// primitive slot `first`; lanes `j` with `other(j)` hold something
    /// else than a triangle.
    pub(crate) fn new(first: u32, triangles: &[[Vec3A; 3]], other: impl Fn(usize) -> bool) -> Self {
        assert!(W <= 32, "lane bits fit a u32");
        assert!(
            (1..=W).contains(&triangles.len()),
            "1 to {W} triangles a block"
        );
        let mut v = [[[0.0; W]; 3]; 3];
        let mut others = 0;
        for (lane, tri) in triangles.iter().enumerate() {
            if other(lane) {
                others |= 1 << lane;
            }
            for (k, vertex) in tri.iter().enumerate() {
                for axis in 0..3 {
                    v[k][axis][lane] = vertex[axis];
                }
            }
        }
        Self {
            v,
            first,
            count: triangles.len() as u32,
            other: others,
        }
    }
}

/// A ray's [`RayTransform`] splatted over the lanes: the origin and the
/// matrix entries that are not exact zeros.
pub(crate) struct BlockRay<V> {
    /// The permutation `[kx, ky, kz]` of the coordinate axes.
    axes: [usize; 3],
    /// The origin's coordinates `kx`, `ky`, `kz`.
    origin: [V; 3],
    /// The scale: the matrix entries `(0, kx)` and `(1, ky)`.
    scale: V,
    /// Column `kz` of the matrix (the shear).
    shear: [V; 3],
}

impl<V> BlockRay<V> {
    // No closures here or in the kernel: a closure (`[0, 1, 2].map(..)`)
    // is compiled out of line, without the instruction set's target
    // features, and its SIMD operations become calls (measured 2-4 times
    // slower).
    #[inline(always)]
    pub(crate) fn new<S: Simd>(simd: S, ray: &RayTransform) -> Self
    where
        V: SimdFloat<S, Element = f32>,
    {
        let [kx, ky, kz] = ray.axes();
        let o = ray.origin();
        let m = ray.shear();
        let column = m.col(kz);
        Self {
            axes: [kx, ky, kz],
            origin: [
                V::simd_from(simd, o[kx]),
                V::simd_from(simd, o[ky]),
                V::simd_from(simd, o[kz]),
            ],
            scale: V::simd_from(simd, m.col(kx).x),
            shear: [
                V::simd_from(simd, column.x),
                V::simd_from(simd, column.y),
                V::simd_from(simd, column.z),
            ],
        }
    }

    /// `shear * (v - origin)` for vertex `k` of every lane, without the
    /// products by the matrix's zero entries (see the module
    /// documentation): `x = s * p[kx] + c.x * p[kz]`, `y = s * p[ky] +
    /// c.y * p[kz]`, `z = c.z * p[kz]` with `s` the scale and `c` column
    /// `kz`, the paper's `A[kx] - Sx * A[kz]` times the scale.
    #[inline(always)]
    fn transform<S: Simd, const W: usize>(
        &self,
        simd: S,
        block: &TriangleBlock<W>,
        k: usize,
    ) -> [V; 3]
    where
        V: Lanes<S, W>,
    {
        let v = &block.v[k];
        let [kx, ky, kz] = self.axes;
        let p = [
            V::simd_from(simd, v[kx]),
            V::simd_from(simd, v[ky]),
            V::simd_from(simd, v[kz]),
        ];
        sheared(p, &self.origin, self.scale, &self.shear)
    }
}

/// `shear * (p - origin)` lane by lane for a corner `p` and a ray's
/// `origin` in permuted coordinates (`kx`, `ky`, `kz`), without the
/// products by the matrix's zero entries (module documentation): `x = s
/// (p - o)[kx] + c.x (p - o)[kz]`, `y` alike, `z = c.z (p - o)[kz]`, with
/// `s` the scale and `c` the shear column `kz`. Shared by the blocks here
/// (one ray, a triangle a lane) and the packets of `packet.rs` (one
/// triangle, a ray a lane), which must give the same bits.
#[inline(always)]
pub(crate) fn sheared<S: Simd, V: SimdFloat<S, Element = f32>>(
    p: [V; 3],
    origin: &[V; 3],
    scale: V,
    shear: &[V; 3],
) -> [V; 3] {
    let px = p[0] - origin[0];
    let py = p[1] - origin[1];
    let pz = p[2] - origin[2];
    [
        scale * px + shear[0] * pz,
        scale * py + shear[1] * pz,
        shear[2] * pz,
    ]
}

/// The edge functions of the transformed corners `a`, `b`, `c` (Woop et
/// al. 2013: U, V, W), lane by lane.
#[inline(always)]
pub(crate) fn edge_functions<S: Simd, V: SimdFloat<S, Element = f32>>(
    [a, b, c]: [[V; 3]; 3],
) -> [V; 3] {
    [
        c[0] * b[1] - c[1] * b[0],
        a[0] * c[1] - a[1] * c[0],
        b[0] * a[1] - b[1] * a[0],
    ]
}

/// `(det, t, b1, b2)` from the edge functions `e` and the corners'
/// transformed `z`, lane by lane: a true division, then the barycentrics'
/// blend of `z` (the scalar test's order).
#[inline(always)]
pub(crate) fn distance<S: Simd, V: SimdFloat<S, Element = f32>>(
    simd: S,
    [e0, e1, e2]: [V; 3],
    z: [V; 3],
) -> (V, V, V, V) {
    let det = e0 + e1 + e2;
    let inv_det = V::simd_from(simd, 1.0) / det;
    let b0 = e0 * inv_det;
    let b1 = e1 * inv_det;
    let b2 = e2 * inv_det;
    (det, b0 * z[0] + b1 * z[1] + b2 * z[2], b1, b2)
}

/// The kernel's verdict on each lane of a block.
#[derive(Clone, Copy, Debug)]
pub(crate) struct LaneHits<const W: usize> {
    /// Bit `j`: lane `j` hits with `0 < t <= t_max` (the `t_max` given to
    /// [`intersect`]).
    hit: u32,
    /// Bit `j`: lane `j` needs the scalar test (an edge function is
    /// exactly zero in f32).
    scalar: u32,
    t: [f32; W],
    b1: [f32; W],
    b2: [f32; W],
}

/// One lane's result for the caller's loop over a leaf.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum Lane {
    /// `(t, b1, b2)`, as the scalar test returns them.
    Hit(f32, f32, f32),
    /// The scalar test would return `None`.
    Miss,
    /// Run the slot's scalar test: the triangle test needs f64 edge
    /// functions, or the slot holds no triangle.
    Scalar,
}

impl Lane {
    /// The triangle test's result: this lane's, or for [`Lane::Scalar`]
    /// the one `scalar` computes.
    #[inline(always)]
    pub(crate) fn or_scalar(
        self,
        scalar: impl FnOnce() -> Option<(f32, f32, f32)>,
    ) -> Option<(f32, f32, f32)> {
        match self {
            Self::Hit(t, b1, b2) => Some((t, b1, b2)),
            Self::Miss => None,
            Self::Scalar => scalar(),
        }
    }
}

impl<const W: usize> LaneHits<W> {
    /// The lanes that hit or need the scalar test (bit `j` for lane `j`):
    /// the others are [`Lane::Miss`] at any `t_max`.
    #[inline(always)]
    pub(crate) fn candidates(&self) -> u32 {
        self.hit | self.scalar
    }

    /// Lane `j` for a ray whose closest hit so far is at `t_max` (at most
    /// the `t_max` the block was tested with): the scalar test's answer.
    #[inline(always)]
    pub(crate) fn lane(&self, j: usize, t_max: f32) -> Lane {
        let bit = 1 << j;
        if self.scalar & bit != 0 {
            Lane::Scalar
        } else if self.hit & bit != 0 && self.t[j] <= t_max {
            Lane::Hit(self.t[j], self.b1[j], self.b2[j])
        } else {
            Lane::Miss
        }
    }
}

/// The watertight test of every lane of `block` (see the module
/// documentation), hits with `0 < t <= t_max` as the scalar test's.
#[inline(always)]
pub(crate) fn intersect<S: Simd, V: Lanes<S, W>, const W: usize>(
    simd: S,
    block: &TriangleBlock<W>,
    ray: &BlockRay<V>,
    t_max: f32,
) -> LaneHits<W> {
    let a = ray.transform(simd, block, 0);
    let b = ray.transform(simd, block, 1);
    let c = ray.transform(simd, block, 2);

    let [e0, e1, e2] = edge_functions([a, b, c]);
    let zero = V::simd_from(simd, 0.0);
    let scalar = e0.simd_eq(zero) | e1.simd_eq(zero) | e2.simd_eq(zero);
    let negative = e0.simd_lt(zero) | e1.simd_lt(zero) | e2.simd_lt(zero);
    let positive = e0.simd_gt(zero) | e1.simd_gt(zero) | e2.simd_gt(zero);
    let inside = !(negative & positive);
    let used = ((1u64 << block.count) - 1) as u32;
    let scalar = (scalar.to_bitmask() as u32 | block.other) & used;
    let candidates = inside.to_bitmask() as u32 & used & !scalar;
    if candidates == 0 {
        // Most leaves a ray reaches it misses: no division, no stores.
        return LaneHits {
            hit: 0,
            scalar,
            t: [0.0; W],
            b1: [0.0; W],
            b2: [0.0; W],
        };
    }
    let (det, t, b1, b2) = distance(simd, [e0, e1, e2], [a[2], b[2], c[2]]);
    let valid = !det.simd_eq(zero) & t.simd_gt(zero) & t.simd_le(V::simd_from(simd, t_max));
    LaneHits {
        hit: valid.to_bitmask() as u32 & candidates,
        scalar,
        t: t.to_array(),
        b1: b1.to_array(),
        b2: b2.to_array(),
    }
}

/// Tests `block` and hands the slots whose lane hits or needs the scalar
/// test to `prim(slot, &mut t_max, lane)` in leaf order, with each lane's
/// answer at the current `t_max`; stops at the first break.
#[inline(always)]
pub(crate) fn visit<S: Simd, V: Lanes<S, W>, const W: usize>(
    simd: S,
    block: &TriangleBlock<W>,
    ray: &BlockRay<V>,
    t_max: &mut f32,
    prim: &mut impl FnMut(usize, &mut f32, Lane) -> ControlFlow<()>,
) -> ControlFlow<()> {
    let lanes = intersect(simd, block, ray, *t_max);
    let mut candidates = lanes.candidates();
    while candidates != 0 {
        let j = candidates.trailing_zeros() as usize;
        candidates &= candidates - 1;
        let lane = lanes.lane(j, *t_max);
        prim(block.first as usize + j, t_max, lane)?;
    }
    ControlFlow::Continue(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bvh8::Isa;
    use fearless_simd::{dispatch, f32x4, f32x8, f32x16};
    use glam::Vec3;
    use stats::Pcg32;

    /// The kernel on `block` at `level` with `W`-lane vectors.
    macro_rules! lanes {
        ($vector:ident, $level:expr, $block:expr, $ray:expr, $t_max:expr) => {
            dispatch!($level, simd => {
                intersect(simd, $block, &BlockRay::<$vector<_>>::new(simd, $ray), $t_max)
            })
        };
    }

    /// Every lane of `tris` (in blocks of four, eight and sixteen) against
    /// the scalar test, at every instruction set the CPU has; returns how
    /// many lanes hit and how many went to the scalar test (per width).
    fn compare(ray: &RayTransform, tris: &[[Vec3A; 3]], t_max: f32) -> (usize, usize) {
        let mut counts = (0, 0);
        for isa in Isa::ALL {
            let Some(level) = isa.level() else { continue };
            counts = compare_width::<4>(ray, tris, t_max, |b| lanes!(f32x4, level, b, ray, t_max));
            let wider = [
                compare_width::<8>(ray, tris, t_max, |b| lanes!(f32x8, level, b, ray, t_max)),
                compare_width::<16>(ray, tris, t_max, |b| lanes!(f32x16, level, b, ray, t_max)),
            ];
            assert!(wider.iter().all(|&c| c == counts), "{isa:?}");
        }
        counts
    }

    /// [`compare`] at one width, the kernel being `kernel`.
    fn compare_width<const W: usize>(
        ray: &RayTransform,
        tris: &[[Vec3A; 3]],
        t_max: f32,
        kernel: impl Fn(&TriangleBlock<W>) -> LaneHits<W>,
    ) -> (usize, usize) {
        let (mut hits, mut scalar) = (0, 0);
        for (b, chunk) in tris.chunks(W).enumerate() {
            let block = TriangleBlock::<W>::new((b * W) as u32, chunk, |_| false);
            let lanes = kernel(&block);
            for (j, tri) in chunk.iter().enumerate() {
                let expected = ray.intersect(tri, t_max);
                let bits = |h: Option<(f32, f32, f32)>| {
                    h.map(|(t, b1, b2)| [t.to_bits(), b1.to_bits(), b2.to_bits()])
                };
                match lanes.lane(j, t_max) {
                    Lane::Scalar => scalar += 1,
                    Lane::Miss => assert_eq!(expected, None, "{W} lanes {tri:?} {ray:?}"),
                    Lane::Hit(t, b1, b2) => {
                        hits += 1;
                        assert_eq!(
                            bits(Some((t, b1, b2))),
                            bits(expected),
                            "{W} lanes {tri:?} {ray:?}"
                        );
                    }
                }
            }
        }
        (hits, scalar)
    }

    fn tri(a: [f32; 3], b: [f32; 3], c: [f32; 3]) -> [Vec3A; 3] {
        [a.into(), b.into(), c.into()]
    }

    fn random_vec(rng: &mut Pcg32, scale: f32) -> Vec3 {
        Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32()) * (2.0 * scale) - scale
    }

    #[test]
    fn lanes_equal_the_scalar_test_on_random_triangles() {
        let mut rng = Pcg32::new(7, 3);
        let (mut hits, mut total) = (0, 0);
        for round in 0..400 {
            let scale = [1.0, 1e-3, 1e4][round % 3];
            let o = random_vec(&mut rng, scale);
            let tris: Vec<[Vec3A; 3]> = (0..7)
                .map(|_| [0, 1, 2].map(|_| Vec3A::from(random_vec(&mut rng, scale))))
                .collect();
            // Half the rays aimed at a point of the first triangle.
            let d = if round % 2 == 0 {
                let (u, v) = (rng.uniform_f32() * 0.5, rng.uniform_f32() * 0.5);
                let t = &tris[0];
                Vec3::from(t[0] + (t[1] - t[0]) * u + (t[2] - t[0]) * v) - o
            } else {
                random_vec(&mut rng, 1.0)
            };
            let t_max = [f32::INFINITY, 0.7, 2.0][round % 3];
            for s in [1.0, 0.25, 2f32.powi(-14)] {
                let ray = RayTransform::new(o, d, s);
                hits += compare(&ray, &tris, t_max * s).0;
                total += tris.len();
            }
        }
        assert!(hits > total / 10, "{hits} of {total}");
    }

    #[test]
    fn lanes_equal_the_scalar_test_on_edge_cases() {
        // Two triangles sharing the square's diagonal, a degenerate line,
        // a point, a far triangle, a triangle in a plane containing the ray.
        let tris = [
            tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [1.0, 1.0, 0.0]),
            tri([0.0, 0.0, 0.0], [1.0, 1.0, 0.0], [0.0, 1.0, 0.0]),
            tri([0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [3.0, 0.0, 0.0]),
            tri([0.5, 0.5, 0.0], [0.5, 0.5, 0.0], [0.5, 0.5, 0.0]),
            tri([0.0, 0.0, -5.0], [9.0, 0.0, -5.0], [0.0, 9.0, -5.0]),
            tri([0.0, 0.0, 1.0], [1.0, 1.0, 1.0], [0.0, 0.0, -1.0]),
        ];
        let mut scalar = 0;
        let mut hits = 0;
        // Through the shared edge, vertices, edges and the interior, straight
        // down (exact zero edge functions: the f64 path) and slanted.
        for (x, y) in [(0.5, 0.5), (0.0, 0.0), (1.0, 1.0), (0.5, 0.0), (0.3, 0.6)] {
            for d in [
                Vec3::NEG_Z,
                Vec3::new(0.1, -0.2, -1.0),
                Vec3::new(1.0, 1.0, 0.0),
            ] {
                let o = Vec3::new(x, y, 0.0) - d;
                let ray = RayTransform::new(o, d, 1.0);
                for t_max in [f32::INFINITY, 1.0, 1.000_001] {
                    let (h, s) = compare(&ray, &tris, t_max);
                    hits += h;
                    scalar += s;
                }
            }
        }
        assert!(scalar > 0, "the f64 path is exercised");
        assert!(hits > 0, "some lanes hit");
    }

    #[test]
    fn unused_lanes_never_hit() {
        let t = tri([0.0, 0.0, 0.0], [2.0, 0.0, 0.0], [0.0, 2.0, 0.0]);
        let ray = RayTransform::new(Vec3::new(0.0, 0.0, 1.0), Vec3::NEG_Z, 1.0);
        let level = Isa::Best.level().unwrap();
        let t_max = f32::INFINITY;
        let block = TriangleBlock::<4>::new(5, &[t], |_| false);
        let lanes = lanes!(f32x4, level, &block, &ray, t_max);
        assert_eq!(
            (lanes.scalar, lanes.hit),
            (1, 0),
            "the vertex hit needs f64"
        );
        let block = TriangleBlock::<16>::new(5, &[t], |_| false);
        let lanes = lanes!(f32x16, level, &block, &ray, t_max);
        assert_eq!((lanes.scalar, lanes.hit), (1, 0), "16 lanes");
    }
}
