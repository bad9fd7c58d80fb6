//! Conservative traversal of obvhs trees.
//!
//! obvhs' own node tests are not conservative: a ray whose hit lies on a
//! triangle edge that is also a face of the node's box can be culled by one
//! ulp of slab rounding (light leaks through the corners of a room), its CWBVH
//! test ignores everything closer than `t = 1e-4`, and its `Ray::new` clamps
//! small direction components. The node tests here widen every slab by a bound
//! on its rounding error plus the watertight triangle test's own slack, so a
//! hit that the triangle test reports is never culled.
//!
//! CWBVH nodes are traversed with obvhs' `traverse!` macro (its ordered stack
//! traversal) and our node test; BVH2 nodes with a small stack loop here.

use std::cell::RefCell;
use std::ops::ControlFlow;

use glam::{UVec2, Vec3A, Vec4, uvec2};
use obvhs::{
    bvh2::Bvh2,
    cwbvh::{
        CwBvh,
        node::{CwBvhNode, extract_byte64},
    },
    faststack::FastStack,
};

/// Relative widening of slabs: 32 ulps. Covers the rounding of the slab
/// distances (a few ulps of the terms they are computed from) and the slack
/// of the watertight test, whose transformed vertices carry a few ulps of
/// their distance from the origin.
pub(crate) const WIDEN: f32 = 32.0 * f32::EPSILON;

/// A ray prepared for node tests, in the triangle test's `t` units.
#[derive(Clone, Copy, Debug)]
pub(crate) struct NodeRay {
    pub origin: Vec3A,
    /// Direction (only its signs matter to the traversal order).
    pub direction: Vec3A,
    /// Reciprocal direction, finite: zero components map to a large positive
    /// value (obvhs' octant choice also treats zero as positive).
    pub inv_direction: Vec3A,
}

#[inline(always)]
fn max(a: f32, b: f32) -> f32 {
    if a > b { a } else { b }
}

#[inline(always)]
fn min(a: f32, b: f32) -> f32 {
    if a < b { a } else { b }
}

/// Bit `j` set when child `j` of a CWBVH node may hold a hit with
/// `0 <= t <= t_max`.
#[inline(always)]
fn wide_child_mask(node: &CwBvhNode, ray: &NodeRay, t_max: f32) -> u32 {
    // Child planes are p + q * e (q in 0..=255); the slab distance is
    // q * (e * inv) + (p - o) * inv. e is a power of two, so e * inv is exact;
    // the rest rounds relative to the two terms, not to their (possibly
    // cancelling) sum: widen by a bound on both.
    let scale = node.compute_extent() * ray.inv_direction;
    let offset = (Vec3A::from(node.p) - ray.origin) * ray.inv_direction;
    let margin = (scale.abs() * 255.0 + offset.abs()) * WIDEN;
    let neg = ray.direction.cmplt(Vec3A::ZERO);
    let (x0, x1) = if neg.test(0) {
        (&node.child_max_x, &node.child_min_x)
    } else {
        (&node.child_min_x, &node.child_max_x)
    };
    let (y0, y1) = if neg.test(1) {
        (&node.child_max_y, &node.child_min_y)
    } else {
        (&node.child_min_y, &node.child_max_y)
    };
    let (z0, z1) = if neg.test(2) {
        (&node.child_max_z, &node.child_min_z)
    } else {
        (&node.child_min_z, &node.child_max_z)
    };
    let lo = offset - margin;
    let hi = offset + margin;
    // Four children at a time (glam's Vec4 is an SSE register on x86).
    let quad = |q: &[u8; 8], i: usize| {
        Vec4::new(
            f32::from(q[i]),
            f32::from(q[i + 1]),
            f32::from(q[i + 2]),
            f32::from(q[i + 3]),
        )
    };
    let mut mask = 0u32;
    for i in [0, 4] {
        let tx0 = quad(x0, i) * scale.x + lo.x;
        let ty0 = quad(y0, i) * scale.y + lo.y;
        let tz0 = quad(z0, i) * scale.z + lo.z;
        let tx1 = quad(x1, i) * scale.x + hi.x;
        let ty1 = quad(y1, i) * scale.y + hi.y;
        let tz1 = quad(z1, i) * scale.z + hi.z;
        let t0 = tx0.max(ty0).max(tz0.max(Vec4::ZERO));
        let t1 = tx1.min(ty1).min(tz1.min(Vec4::splat(t_max)));
        mask |= t0.cmple(t1).bitmask() << i;
    }
    mask
}

/// obvhs' hit mask layout for the children in `mask` (see
/// `CwBvhNode::intersect_ray`).
#[inline(always)]
fn wide_hit_mask(node: &CwBvhNode, mask: u32, oct_inv4: u32) -> u32 {
    let (child_bits8, bit_index8) = node.get_child_and_index_bits(oct_inv4);
    let mut hit_mask = 0;
    let mut m = mask;
    while m != 0 {
        let j = m.trailing_zeros() as usize;
        m &= m - 1;
        hit_mask |= extract_byte64(child_bits8, j) << extract_byte64(bit_index8, j);
    }
    hit_mask
}

/// Entries of the CWBVH traversal stack, for the trees of up to
/// `bvh::MAX_WIDE_DEPTH` (24) levels that are traversed wide: a traversal
/// holds at most one group per level below the root (23), and a stack of
/// `N` entries keeps `N - 1` (its top entry is the slot that a push onto a
/// full stack overwrites, see [`WideStack`]).
const WIDE_STACK: usize = 24;

/// The traversal stack of [`traverse_wide`]: obvhs' `StackStack` with fewer
/// entries (obvhs' has 32, whose 256-byte zeroing was a `memset` call per
/// ray, 1.3 % of a path-traced iteration on `smallvcm-2`). Like obvhs', a
/// push onto a full stack overwrites its top entry; no tree traversed here
/// fills it.
struct WideStack {
    data: [UVec2; WIDE_STACK],
    len: usize,
}

impl FastStack<UVec2> for WideStack {
    #[inline(always)]
    fn push(&mut self, v: UVec2) {
        self.data[self.len] = v;
        self.len = (self.len + 1).min(WIDE_STACK - 1);
    }
    #[inline(always)]
    fn pop_fast(&mut self) -> UVec2 {
        self.len = self.len.saturating_sub(1);
        self.data[self.len]
    }
    #[inline(always)]
    fn pop(&mut self) -> Option<UVec2> {
        (self.len > 0).then(|| self.pop_fast())
    }
    #[inline(always)]
    fn len(&self) -> usize {
        self.len
    }
    #[inline(always)]
    fn is_empty(&self) -> bool {
        self.len == 0
    }
    #[inline(always)]
    fn clear(&mut self) {
        self.len = 0;
    }
}

/// The state obvhs' `traverse!` macro works on (the fields of its
/// `Traversal`, with [`WideStack`] as the stack), as `CwBvh::new_traversal`
/// sets it up.
struct WideState {
    stack: WideStack,
    current_group: UVec2,
    primitive_group: UVec2,
    /// Octant of the ray, inverted, in each byte (obvhs' `ray_get_octant_inv4`).
    oct_inv4: u32,
    primitive_id: u32,
    hitmask: u32,
}

impl WideState {
    #[inline(always)]
    fn new(direction: Vec3A) -> Self {
        let bits = |c: f32, b: u32| if c < 0.0 { 0 } else { b };
        Self {
            stack: WideStack {
                data: [UVec2::ZERO; WIDE_STACK],
                len: 0,
            },
            current_group: uvec2(0, 0x8000_0000),
            primitive_group: UVec2::ZERO,
            oct_inv4: bits(direction.x, 0x0404_0404)
                | bits(direction.y, 0x0202_0202)
                | bits(direction.z, 0x0101_0101),
            primitive_id: 0,
            hitmask: 0,
        }
    }
}

/// Visits the primitive slots of a CWBVH in front-to-back order of its nodes.
/// `prim(slot, &mut t_max)` may shorten `t_max` (closest hit) or break.
#[inline(always)]
pub(crate) fn traverse_wide(
    bvh: &CwBvh,
    ray: &NodeRay,
    mut t_max: f32,
    mut prim: impl FnMut(usize, &mut f32) -> ControlFlow<()>,
) {
    if bvh.nodes.is_empty() {
        return;
    }
    let mut state = WideState::new(ray.direction);
    let mut node;
    'done: {
        obvhs::traverse!(
            bvh,
            node,
            state,
            wide_hit_mask(node, wide_child_mask(node, ray, t_max), state.oct_inv4),
            {
                if prim(state.primitive_id as usize, &mut t_max).is_break() {
                    break 'done;
                }
            }
        );
    }
}

/// Conservative entry distance of a BVH2 box, or `None` if the ray misses it
/// within `0 <= t <= t_max`.
#[inline(always)]
fn box_entry(min_corner: Vec3A, max_corner: Vec3A, ray: &NodeRay, t_max: f32) -> Option<f32> {
    // Exact planes: each slab distance rounds relative to itself.
    let a = (min_corner - ray.origin) * ray.inv_direction;
    let b = (max_corner - ray.origin) * ray.inv_direction;
    let margin = (a.abs() + b.abs()) * WIDEN;
    let lo = a.min(b) - margin;
    let hi = a.max(b) + margin;
    let t0 = max(max(lo.x, lo.y), max(lo.z, 0.0));
    let t1 = min(min(hi.x, hi.y), min(hi.z, t_max));
    (t0 <= t1).then_some(t0)
}

thread_local! {
    /// Stack for BVH2 trees deeper than the fixed stack (adversarial input).
    static DEEP_STACK: RefCell<Vec<u32>> = const { RefCell::new(Vec::new()) };
}

/// Fixed traversal stack of the BVH2 traversal: enough for any tree of up to
/// this many levels.
const BINARY_STACK: usize = 64;

/// Visits the primitive slots of a BVH2 leaf by leaf, nearer child first.
/// `depth` is the tree's number of levels. `prim` as in [`traverse_wide`].
#[inline(always)]
pub(crate) fn traverse_binary(
    bvh: &Bvh2,
    depth: usize,
    ray: &NodeRay,
    t_max: f32,
    prim: impl FnMut(usize, &mut f32) -> ControlFlow<()>,
) {
    if depth <= BINARY_STACK {
        let mut stack = [0u32; BINARY_STACK];
        traverse_binary_with(bvh, &mut stack, ray, t_max, prim);
    } else {
        traverse_binary_deep(bvh, depth, ray, t_max, prim);
    }
}

#[cold]
#[inline(never)]
fn traverse_binary_deep(
    bvh: &Bvh2,
    depth: usize,
    ray: &NodeRay,
    t_max: f32,
    mut prim: impl FnMut(usize, &mut f32) -> ControlFlow<()>,
) {
    DEEP_STACK.with(|cell| {
        if let Ok(mut stack) = cell.try_borrow_mut() {
            if stack.len() < depth {
                stack.resize(depth, 0);
            }
            traverse_binary_with(bvh, &mut stack, ray, t_max, &mut prim);
        } else {
            // Only if a query re-enters from inside a query on this thread.
            let mut stack = vec![0; depth];
            traverse_binary_with(bvh, &mut stack, ray, t_max, &mut prim);
        }
    });
}

/// `stack` must hold at least depth - 1 entries (one per level below the
/// root at most).
#[inline(always)]
fn traverse_binary_with(
    bvh: &Bvh2,
    stack: &mut [u32],
    ray: &NodeRay,
    mut t_max: f32,
    mut prim: impl FnMut(usize, &mut f32) -> ControlFlow<()>,
) {
    let Some(root) = bvh.nodes.first() else {
        return;
    };
    if box_entry(root.aabb().min, root.aabb().max, ray, t_max).is_none() {
        return;
    }
    let mut leaf = |first: u32, count: u32, t_max: &mut f32| -> ControlFlow<()> {
        for slot in first..first + count {
            prim(slot as usize, t_max)?;
        }
        ControlFlow::Continue(())
    };
    if root.is_leaf() {
        let _ = leaf(root.first_index, root.prim_count, &mut t_max);
        return;
    }
    let mut len = 0usize;
    let mut current = root.first_index;
    loop {
        let left = &bvh.nodes[current as usize];
        let right = &bvh.nodes[current as usize + 1];
        let mut near = (
            left,
            box_entry(left.aabb().min, left.aabb().max, ray, t_max),
        );
        let mut far = (
            right,
            box_entry(right.aabb().min, right.aabb().max, ray, t_max),
        );
        if let (Some(a), Some(b)) = (near.1, far.1) {
            if b < a {
                std::mem::swap(&mut near, &mut far);
            }
        } else if near.1.is_none() {
            std::mem::swap(&mut near, &mut far);
        }
        let mut next = None;
        for (node, entry) in [near, far] {
            if entry.is_none() {
                continue;
            }
            if node.is_leaf() {
                if leaf(node.first_index, node.prim_count, &mut t_max).is_break() {
                    return;
                }
            } else if next.is_none() {
                next = Some(node.first_index);
            } else {
                stack[len] = node.first_index;
                len += 1;
            }
        }
        current = match next {
            Some(n) => n,
            None if len > 0 => {
                len -= 1;
                stack[len]
            }
            None => return,
        };
    }
}
