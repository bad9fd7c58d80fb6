//! Top-down binned SAH build of a binary BVH with one primitive per leaf,
//! the input of the CWBVH conversion (`convert.rs`), in little memory.
//!
//! Each node chooses the split plane that minimises the surface area
//! heuristic over [`BINS`] bins of primitive centroids on each axis (Wald
//! 2007, "On fast Construction of SAH-based Bounding Volume Hierarchies",
//! §3: binning, then a sweep over the bin boundaries), and partitions its
//! primitive references in place (Hoare's scheme). Leaves hold one
//! primitive each; the conversion groups them into wide leaves of up to 3 (4
//! for `Layout::Bvh8`).
//!
//! Memory: the 28-byte references ([`PrimRef`]) and the tree's `2n - 1`
//! nodes (32 bytes each with obvhs' `small_bvh2_node`) are the only
//! per-primitive storage, 92 bytes per primitive. obvhs' PLOC builder
//! holds about 212 (two 48-byte node buffers, the tree, Morton codes).
//! A subtree of `n` primitives has exactly `2n - 1` nodes, so every
//! subtree's place in the node array is known before it is built and the
//! two halves of a node are built in parallel into disjoint slices.

use glam::{Vec3, Vec3A};
use obvhs::{
    aabb::Aabb,
    bvh2::{Bvh2, node::Bvh2Node},
};

/// Bins per axis. 32 is the usual trade-off (Wald 2007 uses 16 and
/// reports no gain in tree quality beyond 32).
const BINS: usize = 32;

/// Nodes of at most this many primitives take the exact SAH split
/// (sorted centroids, every boundary) instead of the binned one: better
/// splits, and cheaper than clearing and sweeping `3 * BINS` bins for a
/// handful of primitives.
const EXACT_MAX: usize = 16;

/// Subtrees with at least this many primitives build their two halves
/// in parallel (below it rayon's task overhead dominates).
const PARALLEL_MIN: usize = 4096;

/// Below this depth every split is the SAH's; from it on, every split is
/// the object median (down to [`EXACT_MAX`] primitives), so that the
/// tree, and the recursion, stays shallower than `MEDIAN_DEPTH + log2(n) +
/// EXACT_MAX` levels on any input (SAH
/// trees of real scenes of a million triangles are about 40 deep; a
/// geometric progression of boxes makes the SAH peel one box per level).
const MEDIAN_DEPTH: usize = 64;

/// A primitive's box and its id (what the tree's leaves report),
/// partitioned in place during the build.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PrimRef {
    /// Box minimum.
    pub min: Vec3,
    /// The id the leaf of this primitive reports.
    pub id: u32,
    /// Box maximum.
    pub max: Vec3,
}

impl PrimRef {
    /// Twice the box centre (the binning's coordinate; halving is not
    /// needed to compare or to bin).
    #[inline]
    fn centroid2(&self) -> Vec3A {
        Vec3A::from(self.min) + Vec3A::from(self.max)
    }

    fn aabb(&self) -> Aabb {
        Aabb::new(self.min.into(), self.max.into())
    }
}

/// A box grown point by point (`Aabb::empty` and `extend` over two points).
#[derive(Clone, Copy, Debug)]
struct Bounds {
    min: Vec3A,
    max: Vec3A,
}

impl Bounds {
    const EMPTY: Self = Self {
        min: Vec3A::INFINITY,
        max: Vec3A::NEG_INFINITY,
    };

    #[inline]
    fn grow(&mut self, min: Vec3A, max: Vec3A) {
        self.min = self.min.min(min);
        self.max = self.max.max(max);
    }

    #[inline]
    fn union(self, other: Self) -> Self {
        Self {
            min: self.min.min(other.min),
            max: self.max.max(other.max),
        }
    }

    /// Half the surface area; 0 for an empty box.
    #[inline]
    fn half_area(&self) -> f32 {
        let d = (self.max - self.min).max(Vec3A::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }
}

/// A node's primitives as the recursion hands them down: their box and
/// the box of their centroids (doubled, see [`PrimRef::centroid2`]).
#[derive(Clone, Copy, Debug)]
struct Extent {
    bounds: Bounds,
    centroids: Bounds,
}

impl Extent {
    fn of(prims: &[PrimRef]) -> Self {
        let mut e = Self {
            bounds: Bounds::EMPTY,
            centroids: Bounds::EMPTY,
        };
        for p in prims {
            e.bounds.grow(p.min.into(), p.max.into());
            let c = p.centroid2();
            e.centroids.grow(c, c);
        }
        e
    }
}

/// The binary tree over `prims` (reordered in place), leaves of one
/// primitive whose `primitive_indices` entry is the primitive's `id`.
/// Built in parallel on the current rayon pool.
pub(crate) fn build(prims: &mut [PrimRef]) -> Bvh2 {
    let n = prims.len();
    if n == 0 {
        return Bvh2::default();
    }
    let extent = Extent::of(prims);
    let mut nodes = vec![Bvh2Node::default(); 2 * n - 1];
    let (root, descendants) = nodes.split_at_mut(1);
    build_node(prims, 0, &mut root[0], descendants, 1, extent, 0);
    Bvh2 {
        nodes,
        primitive_indices: prims.iter().map(|p| p.id).collect(),
        ..Bvh2::default()
    }
}

/// Builds the subtree of `prims` (their slots start at `first_slot`)
/// into `node` and its `2n - 2` descendants `descendants`, whose first
/// has index `base`: the two children at `base` and `base + 1`, then the
/// left child's descendants, then the right child's.
fn build_node(
    prims: &mut [PrimRef],
    first_slot: u32,
    node: &mut Bvh2Node,
    descendants: &mut [Bvh2Node],
    base: u32,
    extent: Extent,
    depth: usize,
) {
    let n = prims.len();
    debug_assert_eq!(descendants.len(), 2 * n - 2);
    let aabb = Aabb::new(extent.bounds.min, extent.bounds.max);
    if n == 1 {
        *node = Bvh2Node::new(prims[0].aabb(), 1, first_slot);
        return;
    }
    let (mid, left, right) = split(prims, extent, depth);
    *node = Bvh2Node::new(aabb, 0, base);
    let (children, rest) = descendants.split_at_mut(2);
    let (left_node, right_node) = children.split_at_mut(1);
    let (left_desc, right_desc) = rest.split_at_mut(2 * mid - 2);
    let (left_prims, right_prims) = prims.split_at_mut(mid);
    let mut build_left = move || {
        build_node(
            left_prims,
            first_slot,
            &mut left_node[0],
            left_desc,
            base + 2,
            left,
            depth + 1,
        );
    };
    let mut build_right = move || {
        build_node(
            right_prims,
            first_slot + mid as u32,
            &mut right_node[0],
            right_desc,
            base + 2 * mid as u32,
            right,
            depth + 1,
        );
    };
    if n >= PARALLEL_MIN {
        rayon::join(build_left, build_right);
    } else {
        build_left();
        build_right();
    }
}

/// A bin: the box of the primitives whose centroid falls in it, and
/// their number.
#[derive(Clone, Copy)]
struct Bin {
    bounds: Bounds,
    count: u32,
}

/// Splits `prims` (at least two) into two non-empty halves in place and
/// returns the left half's length and both halves' extents.
fn split(prims: &mut [PrimRef], extent: Extent, depth: usize) -> (usize, Extent, Extent) {
    let n = prims.len();
    let c = extent.centroids;
    let size = c.max - c.min;
    // The axis of largest centroid extent (for the fallbacks).
    let widest = if size.x >= size.y && size.x >= size.z {
        0
    } else if size.y >= size.z {
        1
    } else {
        2
    };
    if !(size[widest] > 0.0) {
        // Every centroid is the same point: any split is as good.
        return finish_split(prims, n / 2);
    }
    if n <= EXACT_MAX {
        return exact_split(prims);
    }
    if depth < MEDIAN_DEPTH
        && let Some((axis, plane)) = best_bin_split(prims, c.min, size)
    {
        let scale = BINS as f32 / size[axis];
        let min = c.min[axis];
        let bin = |p: &PrimRef| bin_of(p.centroid2()[axis], min, scale);
        return partition(prims, |p| bin(p) <= plane);
    }
    // No plane separates the centroids (all in one bin), or too deep:
    // the object median along the widest axis.
    let mid = n / 2;
    prims.select_nth_unstable_by(mid, |a, b| {
        a.centroid2()[widest].total_cmp(&b.centroid2()[widest])
    });
    finish_split(prims, mid)
}

/// The SAH-best split of a few primitives (at most [`EXACT_MAX`]): sorted
/// by centroid on each axis, every boundary between two of them tried.
fn exact_split(prims: &mut [PrimRef]) -> (usize, Extent, Extent) {
    let n = prims.len();
    debug_assert!((2..=EXACT_MAX).contains(&n));
    let sort = |prims: &mut [PrimRef], axis: usize| {
        prims.sort_unstable_by(|a, b| a.centroid2()[axis].total_cmp(&b.centroid2()[axis]));
    };
    let mut best = (f32::INFINITY, 0, n / 2);
    for axis in 0..3 {
        sort(prims, axis);
        // right[i]: A N of prims[i..].
        let mut right = [0.0f32; EXACT_MAX];
        let mut bounds = Bounds::EMPTY;
        for i in (1..n).rev() {
            bounds.grow(prims[i].min.into(), prims[i].max.into());
            right[i] = bounds.half_area() * (n - i) as f32;
        }
        let mut bounds = Bounds::EMPTY;
        for i in 1..n {
            bounds.grow(prims[i - 1].min.into(), prims[i - 1].max.into());
            let cost = bounds.half_area() * i as f32 + right[i];
            if cost < best.0 {
                best = (cost, axis, i);
            }
        }
    }
    if best.1 != 2 {
        sort(prims, best.1);
    }
    finish_split(prims, best.2)
}

/// The extents of `prims[..mid]` and `prims[mid..]`.
fn finish_split(prims: &[PrimRef], mid: usize) -> (usize, Extent, Extent) {
    (mid, Extent::of(&prims[..mid]), Extent::of(&prims[mid..]))
}

/// The bin of a (doubled) centroid coordinate `x`: `floor((x - min) *
/// scale)` clamped to the last bin (the maximum lands on `BINS`).
#[inline]
fn bin_of(x: f32, min: f32, scale: f32) -> usize {
    (((x - min) * scale) as usize).min(BINS - 1)
}

/// The SAH-best plane over the bins of every axis with a positive
/// centroid extent: `(axis, last bin of the left side)`, or `None` when
/// every centroid falls in one bin on every axis. The cost of a plane is
/// `A(left) N(left) + A(right) N(right)` (the node's own cost and area
/// are the same for every plane).
fn best_bin_split(prims: &[PrimRef], min: Vec3A, size: Vec3A) -> Option<(usize, usize)> {
    let empty = Bin {
        bounds: Bounds::EMPTY,
        count: 0,
    };
    let mut bins = [[empty; BINS]; 3];
    let scale = Vec3A::splat(BINS as f32) / size;
    for p in prims {
        let c = p.centroid2();
        let (lo, hi) = (Vec3A::from(p.min), Vec3A::from(p.max));
        for axis in 0..3 {
            if size[axis] > 0.0 {
                let b = &mut bins[axis][bin_of(c[axis], min[axis], scale[axis])];
                b.bounds.grow(lo, hi);
                b.count += 1;
            }
        }
    }
    let mut best: Option<(f32, usize, usize)> = None;
    for (axis, bins) in bins.iter().enumerate() {
        if !(size[axis] > 0.0) {
            continue;
        }
        // right_cost[i]: A N of bins i + 1 .. BINS.
        let mut right_cost = [0.0f32; BINS];
        let mut right_count = [0u32; BINS];
        let (mut bounds, mut count) = (Bounds::EMPTY, 0u32);
        for i in (1..BINS).rev() {
            bounds = bounds.union(bins[i].bounds);
            count += bins[i].count;
            right_cost[i - 1] = bounds.half_area() * count as f32;
            right_count[i - 1] = count;
        }
        let (mut bounds, mut count) = (Bounds::EMPTY, 0u32);
        for i in 0..BINS - 1 {
            bounds = bounds.union(bins[i].bounds);
            count += bins[i].count;
            if count == 0 || right_count[i] == 0 {
                continue;
            }
            let cost = bounds.half_area() * count as f32 + right_cost[i];
            if best.is_none_or(|(b, ..)| cost < b) {
                best = Some((cost, axis, i));
            }
        }
    }
    best.map(|(_, axis, plane)| (axis, plane))
}

/// Moves the primitives for which `left` holds to the front (Hoare's
/// scheme: each primitive is tested once) and returns their number and
/// the extents of both sides.
fn partition(prims: &mut [PrimRef], left: impl Fn(&PrimRef) -> bool) -> (usize, Extent, Extent) {
    let empty = Extent {
        bounds: Bounds::EMPTY,
        centroids: Bounds::EMPTY,
    };
    let (mut l, mut r) = (empty, empty);
    let add = |e: &mut Extent, p: &PrimRef| {
        e.bounds.grow(p.min.into(), p.max.into());
        let c = p.centroid2();
        e.centroids.grow(c, c);
    };
    let (mut i, mut j) = (0, prims.len());
    loop {
        while i < j && left(&prims[i]) {
            add(&mut l, &prims[i]);
            i += 1;
        }
        while i < j && !left(&prims[j - 1]) {
            add(&mut r, &prims[j - 1]);
            j -= 1;
        }
        if i == j {
            break;
        }
        prims.swap(i, j - 1);
    }
    (i, l, r)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every primitive is in exactly one leaf, every node's box encloses
    /// its subtree, and children follow the layout `build_node` promises.
    fn check(tree: &Bvh2, prims: &[PrimRef]) {
        let n = prims.len();
        assert_eq!(tree.nodes.len(), 2 * n - 1);
        let mut seen = vec![0u32; n];
        let mut stack = vec![0usize];
        while let Some(i) = stack.pop() {
            let node = &tree.nodes[i];
            let aabb = node.aabb();
            if node.is_leaf() {
                assert_eq!(node.prim_count, 1);
                let slot = node.first_index as usize;
                let id = tree.primitive_indices[slot] as usize;
                seen[id] += 1;
                let p = prims.iter().find(|p| p.id as usize == id).unwrap();
                assert_eq!(Vec3::from(aabb.min), p.min);
                assert_eq!(Vec3::from(aabb.max), p.max);
            } else {
                for child in [node.first_index, node.first_index + 1] {
                    let c = tree.nodes[child as usize].aabb();
                    assert!(c.min.cmpge(aabb.min).all() && c.max.cmple(aabb.max).all());
                    stack.push(child as usize);
                }
            }
        }
        assert!(seen.iter().all(|&k| k == 1), "every primitive exactly once");
    }

    fn refs(boxes: &[(Vec3, Vec3)]) -> Vec<PrimRef> {
        boxes
            .iter()
            .enumerate()
            .map(|(i, &(min, max))| PrimRef {
                min,
                id: i as u32,
                max,
            })
            .collect()
    }

    #[test]
    fn every_primitive_once_inside_its_boxes() {
        // Scattered boxes of mixed sizes (a fixed LCG), coincident ones,
        // and enough of them for the parallel path.
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            (state >> 40) as f32 / (1u64 << 24) as f32
        };
        let mut boxes = Vec::new();
        for _ in 0..20_000 {
            let p = Vec3::new(next(), next(), next()) * 100.0;
            let s = Vec3::new(next(), next(), next()) * next().powi(4) * 30.0;
            boxes.push((p, p + s));
        }
        boxes.extend(std::iter::repeat_n((Vec3::ONE, Vec3::splat(2.0)), 300));
        for count in [1, 2, 3, 7, 100, boxes.len()] {
            let original = refs(&boxes[boxes.len() - count..]);
            let mut prims = original.clone();
            let tree = build(&mut prims);
            check(&tree, &original);
        }
    }

    /// Centroids that no bin separates (a geometric progression), and
    /// all-equal ones: the fallbacks still give a tree of bounded depth.
    #[test]
    fn degenerate_centroids() {
        let boxes: Vec<_> = (0..2000)
            .map(|i| {
                let x = 1.5f32.powi(i % 120);
                (Vec3::splat(x), Vec3::splat(x * 1.01))
            })
            .collect();
        let mut prims = refs(&boxes);
        let tree = build(&mut prims);
        check(&tree, &refs(&boxes));
        let mut depth = 0;
        let mut stack = vec![(0usize, 1usize)];
        while let Some((i, d)) = stack.pop() {
            depth = depth.max(d);
            let node = &tree.nodes[i];
            if !node.is_leaf() {
                let first = node.first_index as usize;
                stack.extend([(first, d + 1), (first + 1, d + 1)]);
            }
        }
        assert!(depth <= MEDIAN_DEPTH + 12, "depth {depth}");
        let same = vec![(Vec3::ZERO, Vec3::ONE); 1000];
        let mut prims = refs(&same);
        check(&build(&mut prims), &refs(&same));
    }
}
