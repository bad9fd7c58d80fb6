//! An 8-wide BVH with uncompressed child boxes in structure-of-arrays form
//! (Embree's BVH8 `AABBNode`: Wald, Woop, Benthin, Johnson and Ernst,
//! "Embree: A Kernel Framework for Efficient CPU Ray Tracing", ACM TOG
//! 33(4), 2014), whose node test checks a ray against all eight child boxes
//! in one `f32x8` operation per step, on the best instruction set the CPU
//! has (chosen at run time with `fearless_simd`; SSE4.2 at least).
//!
//! The tree is made by the compressed BVH's conversion (`convert.rs`), with
//! leaves of up to 4 primitives instead of 3, each child's quantized box
//! decoded to floats rounded outwards, so a child box here contains the
//! quantized one, which contains the child's primitives. What changes is
//! the work per node: no 8-bit plane decoding (48 integer-to-float
//! conversions a node, see ../shared/notes/simd-and-wavefront.md §3), one
//! 8-lane slab test instead of two 4-lane ones, and children visited
//! nearest first by their entry distance (the compressed traversal's
//! octant order only approximates it), popped entries beyond the closest
//! hit so far culled. Nodes are 256 bytes (80 compressed).
//!
//! A leaf is a [`TriangleBlock`] (`leaf.rs`): its triangles lane by lane,
//! all tested in one 4-lane watertight test that gives each lane the
//! scalar test's bits; the leaf's slots are then handed to the caller in
//! leaf order with their lane's result, so that closest-hit ties, any-hit
//! exits and filter calls are those of the scalar loop over the leaf.
//!
//! **The same bits on every instruction set.** The leaf test is
//! correctly rounded IEEE arithmetic on a fixed width of 4 lanes (see
//! `leaf.rs`). The node test uses only
//! subtraction, multiplication, addition, `abs`, `min`, `max` and a
//! comparison over finite values, each correctly rounded or exact in every
//! SSE, AVX2 and AVX-512 encoding, on a fixed logical width of 8 lanes, and
//! no fused multiply-add (nothing here asks for one and rustc never contracts
//! `a * b + c`). `min`/`max` may pick either zero of `+0`/`-0` depending on
//! the encoding; both compare equal, so the hit mask and the visiting order
//! are the same. Which children are visited, in which order, and hence
//! which hit is reported, are thus the same at every [`Isa`]
//! (`tests/accel/isa.rs` compares every query's bits across them).

use std::ops::ControlFlow;

use fearless_simd::{Level, Simd, SimdFrom, dispatch, f32x4, f32x8};
use glam::Vec3A;
use obvhs::cwbvh::CwBvh;

use crate::leaf::{self, BlockRay, Lane, TriangleBlock};
use crate::traverse::{NodeRay, WIDEN};
use crate::triangle::RayTransform;

/// Children per node: the logical SIMD width of every node test.
const LANES: usize = 8;

/// A child reference with this bit set is a leaf: its other bits are the
/// index of its [`TriangleBlock`].
const LEAF: u32 = 1 << 31;

/// Traversal stack entries kept in a fixed array (256 bytes to zero per
/// ray); deeper stacks, which only trees of more than four levels can
/// need, go on in a vector allocated on first use.
const INLINE_STACK: usize = 32;

/// The instruction set of the node and leaf tests (see the module documentation: the
/// results are the same at every one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Isa {
    /// The best this CPU has (detected once per process).
    #[default]
    Best,
    /// SSE4.2 on x86-64 (the build's baseline, x86-64-v2), the platform's
    /// baseline SIMD elsewhere: 8 lanes as two 4-lane halves.
    Baseline,
    /// AVX2 (x86-64-v3): 8 lanes in one register.
    Avx2,
    /// AVX-512 (Ice Lake class).
    Avx512,
}

impl Isa {
    /// Every choice.
    pub const ALL: [Self; 4] = [Self::Best, Self::Baseline, Self::Avx2, Self::Avx512];

    /// The `fearless_simd` level of this choice, `None` when the CPU lacks it.
    pub(crate) fn level(self) -> Option<Level> {
        let best = Level::new();
        match self {
            Self::Best => Some(best),
            #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
            Self::Baseline => best.as_sse4_2().map(Level::Sse4_2),
            #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
            Self::Avx2 => best.as_avx2().map(Level::Avx2),
            #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
            Self::Avx512 => best.as_avx512().map(Level::Avx512),
            #[cfg(not(any(target_arch = "x86", target_arch = "x86_64")))]
            Self::Baseline => Some(best),
            #[cfg(not(any(target_arch = "x86", target_arch = "x86_64")))]
            Self::Avx2 | Self::Avx512 => None,
        }
    }
}

/// One node: per axis the lower and upper planes of the eight child boxes,
/// and the eight child references (an inner node's index, or a [`LEAF`]).
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub(crate) struct Node8 {
    lower: [[f32; LANES]; 3],
    upper: [[f32; LANES]; 3],
    child: [u32; LANES],
    /// Bit `j` set when child `j` exists.
    valid: u32,
}

/// The tree: node 0 is the root.
pub(crate) struct Bvh8 {
    nodes: Vec<Node8>,
    /// The leaves' triangles, a block per leaf.
    blocks: Vec<TriangleBlock>,
}

/// Most primitive slots of a tree: leaf references and node indices stay
/// below [`LEAF`] (a tree has fewer nodes and leaves than slots).
pub(crate) const MAX_BVH8_SLOTS: usize = LEAF as usize;

impl Bvh8 {
    /// The float form of a wide tree whose node `i` has leaves of
    /// `leaf_sizes[i][j]` primitives (child `j`), primitive slot `s`
    /// holding `triangles[s]`, or something else (a sphere) when
    /// `other(s)`.
    ///
    /// # Panics
    /// With [`MAX_BVH8_SLOTS`] slots or more.
    pub(crate) fn from_cwbvh(
        wide: &CwBvh,
        leaf_sizes: &[[u8; LANES]],
        triangles: &[[Vec3A; 3]],
        other: impl Fn(usize) -> bool,
    ) -> Self {
        assert!(triangles.len() < MAX_BVH8_SLOTS, "too many slots for Bvh8");
        let mut blocks = Vec::new();
        let mut leaf = |first: u32, count: u8| {
            let slots = first as usize..first as usize + usize::from(count);
            let base = slots.start;
            blocks.push(TriangleBlock::new(first, &triangles[slots], |j| {
                other(base + j)
            }));
            LEAF | (blocks.len() - 1) as u32
        };
        let nodes = wide
            .nodes
            .iter()
            .zip(leaf_sizes)
            .map(|(n, sizes)| decode(n, sizes, &mut leaf))
            .collect();
        Self { nodes, blocks }
    }
}

/// A compressed node's children as float boxes rounded outwards: plane
/// `p + q * 2^e` (Ylitie et al. 2017, §3.3), exact in f64. `leaf(first,
/// count)` gives the reference of a leaf child of `sizes[j]` primitives.
fn decode(
    node: &obvhs::cwbvh::node::CwBvhNode,
    sizes: &[u8; LANES],
    leaf: &mut impl FnMut(u32, u8) -> u32,
) -> Node8 {
    let mut out = Node8 {
        lower: [[0.0; LANES]; 3],
        upper: [[0.0; LANES]; 3],
        child: [0; LANES],
        valid: 0,
    };
    let extent = node.compute_extent();
    let quantized = [
        (&node.child_min_x, &node.child_max_x),
        (&node.child_min_y, &node.child_max_y),
        (&node.child_min_z, &node.child_max_z),
    ];
    for j in 0..LANES {
        if node.is_child_empty(j) {
            continue;
        }
        out.valid |= 1 << j;
        for (axis, (lo, hi)) in quantized.iter().enumerate() {
            let plane = |q: u8| f64::from(node.p[axis]) + f64::from(q) * f64::from(extent[axis]);
            out.lower[axis][j] = round_down(plane(lo[j]));
            out.upper[axis][j] = round_up(plane(hi[j]));
        }
        out.child[j] = if node.is_leaf(j) {
            leaf(node.child_primitives(j).0, sizes[j])
        } else {
            node.child_node_index(j)
        };
    }
    out
}

/// The largest f32 not above `x`.
fn round_down(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) > x { f.next_down() } else { f }
}

/// The smallest f32 not below `x`.
fn round_up(x: f64) -> f32 {
    let f = x as f32;
    if f64::from(f) < x { f.next_up() } else { f }
}

/// A ray's constants for the node test, splatted over the lanes.
struct Ray8<S: Simd> {
    origin: [f32x8<S>; 3],
    inv_direction: [f32x8<S>; 3],
    /// Per axis, whether the direction is negative: its near planes are
    /// then the upper ones.
    negative: [bool; 3],
}

impl<S: Simd> Ray8<S> {
    // (No closures: see `leaf::BlockRay::new`.)
    #[inline(always)]
    fn new(simd: S, ray: &NodeRay) -> Self {
        let (o, inv) = (ray.origin, ray.inv_direction);
        Self {
            origin: [
                simd.splat_f32x8(o.x),
                simd.splat_f32x8(o.y),
                simd.splat_f32x8(o.z),
            ],
            inv_direction: [
                simd.splat_f32x8(inv.x),
                simd.splat_f32x8(inv.y),
                simd.splat_f32x8(inv.z),
            ],
            negative: [inv.x < 0.0, inv.y < 0.0, inv.z < 0.0],
        }
    }
}

/// Which children of `node` the ray may hit with `0 <= t <= t_max` (bit
/// `j` for child `j`), and each child's conservative entry distance: the
/// slab test of `traverse::box_entry`, each slab widened by its rounding
/// bound, for eight boxes at once.
#[inline(always)]
fn child_hits<S: Simd>(simd: S, node: &Node8, ray: &Ray8<S>, t_max: f32) -> (u32, [f32; LANES]) {
    let mut entry = simd.splat_f32x8(0.0);
    let mut exit = simd.splat_f32x8(t_max);
    for axis in 0..3 {
        let (near, far) = if ray.negative[axis] {
            (&node.upper[axis], &node.lower[axis])
        } else {
            (&node.lower[axis], &node.upper[axis])
        };
        let a = (f32x8::simd_from(simd, *near) - ray.origin[axis]) * ray.inv_direction[axis];
        let b = (f32x8::simd_from(simd, *far) - ray.origin[axis]) * ray.inv_direction[axis];
        let margin = (simd.abs_f32x8(a) + simd.abs_f32x8(b)) * WIDEN;
        entry = simd.max_f32x8(entry, a - margin);
        exit = simd.min_f32x8(exit, b + margin);
    }
    let hit = simd.to_bitmask_mask32x8(simd.simd_le_f32x8(entry, exit)) as u32;
    (hit & node.valid, entry.into())
}

/// Visits the primitive slots the ray may hit, leaf by leaf, hit children
/// in order of entry distance; `prim(slot, &mut t_max, lane)` may shorten
/// `t_max` (closest hit) or break (any hit). Any-hit queries gain from the
/// order too: taken as they come, children made shadow rays on
/// `veach-bidir` 26 % slower than the compressed traversal's octant order.
///
/// The triangles of a leaf are tested at once (`leaf.rs`, with the
/// triangle test's ray `triangle`), and `lane` is the test's answer for
/// `slot` given the current `t_max`. Only the slots whose lane hits or
/// needs the scalar test are visited, in leaf order (the others would
/// be [`Lane::Miss`]). With `SOA` false, the kernel is not
/// run and every slot of every leaf reached gets [`Lane::Scalar`] (the
/// reference the tests compare the kernel's traversal with).
#[inline(always)]
pub(crate) fn traverse8<const SOA: bool>(
    isa: Level,
    bvh: &Bvh8,
    ray: &NodeRay,
    triangle: &RayTransform,
    t_max: f32,
    prim: impl FnMut(usize, &mut f32, Lane) -> ControlFlow<()>,
) {
    dispatch!(isa, simd => walk::<_, SOA>(simd, bvh, ray, triangle, t_max, prim));
}

/// A stack of (child reference, entry distance): a fixed array, then a
/// vector for what does not fit.
struct Stack {
    inline: [(u32, f32); INLINE_STACK],
    len: usize,
    spill: Vec<(u32, f32)>,
}

impl Stack {
    #[inline(always)]
    fn new() -> Self {
        Self {
            inline: [(0, 0.0); INLINE_STACK],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline(always)]
    fn push(&mut self, entry: (u32, f32)) {
        if self.len < INLINE_STACK {
            self.inline[self.len] = entry;
            self.len += 1;
        } else {
            self.spill.push(entry);
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<(u32, f32)> {
        if let Some(entry) = self.spill.pop() {
            return Some(entry);
        }
        self.len = self.len.checked_sub(1)?;
        Some(self.inline[self.len])
    }
}

/// The traversal loop over a stack of (child reference, entry distance).
#[inline(always)]
fn walk<S: Simd, const SOA: bool>(
    simd: S,
    bvh: &Bvh8,
    ray: &NodeRay,
    triangle: &RayTransform,
    mut t_max: f32,
    mut prim: impl FnMut(usize, &mut f32, Lane) -> ControlFlow<()>,
) {
    let ray = Ray8::new(simd, ray);
    let block_ray = BlockRay::<f32x4<S>>::new(simd, triangle);
    let mut stack = Stack::new();
    stack.push((0, 0.0));
    while let Some((child, entry)) = stack.pop() {
        if entry > t_max {
            continue;
        }
        if child & LEAF != 0 {
            let block = &bvh.blocks[(child & !LEAF) as usize];
            if !SOA {
                for slot in block.first..block.first + block.count {
                    if prim(slot as usize, &mut t_max, Lane::Scalar).is_break() {
                        return;
                    }
                }
                continue;
            }
            if leaf::visit(simd, block, &block_ray, &mut t_max, &mut prim).is_break() {
                return;
            }
            continue;
        }
        let node = &bvh.nodes[child as usize];
        let (mut hits, entries) = child_hits(simd, node, &ray, t_max);
        let mut children = [(0, 0.0); LANES];
        let mut count = 0;
        while hits != 0 {
            let j = hits.trailing_zeros() as usize;
            hits &= hits - 1;
            children[count] = (node.child[j], entries[j]);
            count += 1;
        }
        let children = &mut children[..count];
        sort_farthest_first(children);
        for &child in children.iter() {
            stack.push(child);
        }
    }
}

/// Insertion sort by decreasing entry distance (at most eight entries), so
/// that the nearest child is popped first.
#[inline(always)]
fn sort_farthest_first(entries: &mut [(u32, f32)]) {
    for i in 1..entries.len() {
        let mut k = i;
        while k > 0 && entries[k - 1].1 < entries[k].1 {
            entries.swap(k - 1, k);
            k -= 1;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn outward_rounding() {
        let x = 0.1f64;
        assert!(f64::from(round_down(x)) <= x && f64::from(round_up(x)) >= x);
        assert_eq!(round_up(x).next_down(), round_down(x));
        assert_eq!(round_down(0.5), 0.5);
        assert_eq!(round_up(0.5), 0.5);
    }

    #[test]
    fn stack_spills_and_pops_in_order() {
        let mut stack = Stack::new();
        let n = INLINE_STACK as u32 * 3;
        for i in 0..n {
            stack.push((i, i as f32));
        }
        assert_eq!(stack.spill.len(), 2 * INLINE_STACK);
        for i in (0..n).rev() {
            assert_eq!(stack.pop(), Some((i, i as f32)));
        }
        assert_eq!(stack.pop(), None);
    }

    #[test]
    fn sort_puts_the_nearest_last() {
        let mut e = [(0, 3.0), (1, 1.0), (2, 2.0), (3, 1.0)];
        sort_farthest_first(&mut e);
        assert_eq!(e.map(|(c, _)| c), [0, 2, 1, 3]);
    }
}
