//! BVH2 -> 8-wide compressed BVH conversion with one byte per decision.
//!
//! The tree is exactly obvhs 0.4.0's `bvh2_to_cwbvh` (same nodes, same
//! primitive order, bit for bit: `tests::matches_obvhs`), after Ylitie et
//! al. 2017, "Efficient Incoherent Ray Traversal on GPUs Through Compressed
//! Wide BVHs", §3.1 (the cost dynamic program over a BVH2 whose leaves hold
//! one primitive) and §3.2 (child order by ray octant, greedy assignment).
//! The code follows obvhs' `cwbvh/bvh2_to_cwbvh.rs` (D. Griffin, MIT or
//! Apache-2.0, itself after J. van Bergen's GPU-Raytracer `BVH8Converter`);
//! only the bookkeeping differs. obvhs keeps 7 decisions of 8 bytes (a cost
//! and three bytes) for every BVH2 node, 112 bytes per primitive, and
//! reserves a wide node per primitive: the peak of a large scene's build.
//! Here a decision is one byte (its kind and both distribution counts), the
//! costs live only on the recursion's stack (a node's costs are read by its
//! parent alone), and the node list grows as needed: 14 bytes per primitive.
//!
//! Licence: adapted from obvhs 0.4.0 (<https://github.com/DGriffin91/obvhs>),
//! MIT OR Apache-2.0 like this crate; its copyright and licence notices
//! apply to the adapted parts (README, "Credits").

use glam::Vec3A;
use obvhs::{
    bvh2::Bvh2,
    cwbvh::{BRANCHING, CwBvh, node::CwBvhNode},
};

/// Octants of the child-ordering cost table (obvhs' `DIRECTIONS`).
const DIRECTIONS: usize = 8;
/// A child box is quantized to 8 bits per axis, in units of 2^e >= extent / 255
/// (obvhs' `DENOM`, Ylitie et al. §3.3).
const DENOM: f32 = 1.0 / 255.0;
/// SAH cost of a primitive relative to a node (obvhs' `PRIM_COST`).
const PRIM_COST: f32 = 0.3;
/// Smallest extent a node box is quantized with (obvhs' guard against a
/// zero extent, whose log2 is -infinity).
const MIN_EXTENT: f32 = 1e-20;
/// Decisions per BVH2 node: the node's subtree spread over 1 to 7 wide
/// slots (the paper's i = 1..7, here 0..6).
const SLOTS: usize = 7;
/// An empty child slot in the gathering of children.
const NO_CHILD: u32 = u32::MAX;

/// What a BVH2 node becomes for a number of slots.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Kind {
    Leaf,
    Internal,
    Distribute,
}

/// A decision packed into one byte: kind (2 bits) and the slots given to
/// the left and right child (3 bits each, 7 = none, obvhs' `INVALID`).
#[derive(Clone, Copy, Default)]
struct Decision(u8);

/// "No distribution" for a count (obvhs uses `u8::MAX`; 3 bits hold 7).
const NONE: u8 = 7;

impl Decision {
    fn new(kind: Kind, left: u8, right: u8) -> Self {
        let kind = match kind {
            Kind::Leaf => 0,
            Kind::Internal => 1,
            Kind::Distribute => 2,
        };
        Self(kind | (left.min(NONE) << 2) | (right.min(NONE) << 5))
    }

    fn kind(self) -> Kind {
        match self.0 & 3 {
            0 => Kind::Leaf,
            1 => Kind::Internal,
            _ => Kind::Distribute,
        }
    }

    fn left(self) -> usize {
        usize::from((self.0 >> 2) & 7)
    }

    fn right(self) -> usize {
        usize::from(self.0 >> 5)
    }
}

/// The wide tree of `bvh2`, whose leaves hold one primitive each, with at
/// most `max_prims_per_leaf` (1..=3) primitives per wide leaf and children
/// ordered by ray octant: obvhs' `bvh2_to_cwbvh(bvh2, max_prims_per_leaf,
/// true, false)`.
///
/// # Panics
/// If a BVH2 leaf holds more than one primitive.
#[cfg(test)]
pub(crate) fn bvh2_to_cwbvh(bvh2: &Bvh2, max_prims_per_leaf: u32) -> CwBvh {
    assert!(max_prims_per_leaf <= 3, "a CWBVH leaf holds at most 3");
    bvh2_to_wide(bvh2, max_prims_per_leaf).0
}

/// Most primitives in a leaf of [`bvh2_to_wide`]'s tree.
pub(crate) const MAX_WIDE_LEAF: u32 = 4;

/// [`bvh2_to_cwbvh`] (which the tests compare with obvhs') with up to
/// [`MAX_WIDE_LEAF`] primitives per leaf, and each node's leaf sizes
/// (`[node][child]`, 0 for other children). A leaf of 4 is beyond the
/// compressed node's unary count, which says 3: such a tree is for
/// `Bvh8::from_cwbvh` only, which reads the sizes.
///
/// # Panics
/// If a BVH2 leaf holds more than one primitive.
pub(crate) fn bvh2_to_wide(bvh2: &Bvh2, max_prims_per_leaf: u32) -> (CwBvh, Vec<[u8; BRANCHING]>) {
    if bvh2.nodes.is_empty() {
        return (CwBvh::default(), Vec::new());
    }
    let mut converter = Converter {
        bvh2,
        decisions: vec![[Decision::default(); SLOTS]; bvh2.nodes.len()],
        nodes: vec![CwBvhNode::default()],
        leaf_sizes: vec![[0; BRANCHING]],
        primitive_indices: Vec::with_capacity(bvh2.primitive_indices.len()),
    };
    converter.cost(0, max_prims_per_leaf.clamp(1, MAX_WIDE_LEAF));
    converter.convert(0, 0);
    let mut nodes = converter.nodes;
    nodes.shrink_to_fit();
    let wide = CwBvh {
        nodes,
        primitive_indices: converter.primitive_indices,
        total_aabb: *bvh2.nodes[0].aabb(),
        exact_node_aabbs: None,
        uses_spatial_splits: bvh2.uses_spatial_splits,
    };
    (wide, converter.leaf_sizes)
}

struct Converter<'a> {
    bvh2: &'a Bvh2,
    /// Per BVH2 node, its decision for 1..=7 slots (all `Leaf` at a leaf).
    decisions: Vec<[Decision; SLOTS]>,
    nodes: Vec<CwBvhNode>,
    /// Per wide node, the primitive count of each leaf child.
    leaf_sizes: Vec<[u8; BRANCHING]>,
    primitive_indices: Vec<u32>,
}

impl Converter<'_> {
    /// Fills the decisions of `index`'s subtree and returns the node's
    /// costs for 1..=7 slots and its primitive count (obvhs'
    /// `calculate_cost_impl`, the costs returned instead of stored).
    fn cost(&mut self, index: usize, max_prims_per_leaf: u32) -> ([f32; SLOTS], u32) {
        let node = &self.bvh2.nodes[index];
        let half_area = node.aabb().half_area();
        let (first, prim_count) = (node.first_index as usize, node.prim_count);
        if prim_count != 0 {
            assert!(
                prim_count == 1,
                "the CWBVH conversion expects one primitive per BVH2 leaf"
            );
            let cost_leaf = half_area * (prim_count as f32) * PRIM_COST;
            self.decisions[index] = [Decision::new(Kind::Leaf, NONE, NONE); SLOTS];
            return ([cost_leaf; SLOTS], prim_count);
        }
        let (left, left_count) = self.cost(first, max_prims_per_leaf);
        let (right, right_count) = self.cost(first + 1, max_prims_per_leaf);
        let num_primitives = left_count + right_count;
        let mut costs = [0.0; SLOTS];
        let mut decisions = [Decision::default(); SLOTS];
        // One slot (the paper's i = 1): a leaf, or an internal node whose
        // 7 + 1 children are distributed between the two subtrees.
        let cost_leaf = if num_primitives <= max_prims_per_leaf {
            (num_primitives as f32) * half_area * PRIM_COST
        } else {
            f32::INFINITY
        };
        let (mut cost_distribute, mut split) = (f32::INFINITY, (NONE, NONE));
        for k in 0..SLOTS {
            let c = left[k] + right[SLOTS - 1 - k];
            if c < cost_distribute {
                cost_distribute = c;
                split = (k as u8, (SLOTS - 1 - k) as u8);
            }
        }
        let cost_internal = cost_distribute + half_area;
        let kind = if cost_leaf < cost_internal {
            costs[0] = cost_leaf;
            Kind::Leaf
        } else {
            costs[0] = cost_internal;
            Kind::Internal
        };
        decisions[0] = Decision::new(kind, split.0, split.1);
        // i + 1 slots: the best of i slots, or a distribution over both
        // subtrees.
        for i in 1..SLOTS {
            let mut cost_distribute = costs[i - 1];
            let mut split = None;
            for k in 0..i {
                let c = left[k] + right[i - k - 1];
                if c < cost_distribute {
                    cost_distribute = c;
                    split = Some((k as u8, (i - k - 1) as u8));
                }
            }
            if let Some((l, r)) = split {
                costs[i] = cost_distribute;
                decisions[i] = Decision::new(Kind::Distribute, l, r);
            } else {
                costs[i] = costs[i - 1];
                decisions[i] = decisions[i - 1];
            }
        }
        self.decisions[index] = decisions;
        (costs, num_primitives)
    }

    /// Writes wide node `wide` from BVH2 node `index` and recurses into
    /// its internal children (obvhs' `convert_to_cwbvh_impl`).
    fn convert(&mut self, wide: usize, index: usize) {
        let mut node = self.nodes[wide];
        let aabb = *self.bvh2.nodes[index].aabb();
        let node_p = aabb.min;
        node.p = node_p.into();
        let e = ((aabb.max - aabb.min).max(Vec3A::splat(MIN_EXTENT)) * DENOM)
            .log2()
            .ceil()
            .exp2();
        let rcp_e = 1.0 / e;
        // e is a power of two: its biased exponent is the whole encoding.
        node.e = e.to_array().map(|c| (c.to_bits() >> 23) as u8);

        let mut children = [NO_CHILD; BRANCHING];
        let mut child_count = 0;
        self.children(index, &mut children, &mut child_count, 0);
        self.order_children(index, &mut children, child_count);

        node.imask = 0;
        node.primitive_base_idx = self.primitive_indices.len() as u32;
        node.child_base_idx = self.nodes.len() as u32;
        let mut num_internal_nodes = 0;
        let mut num_primitives = 0u32;
        for (i, &child) in children.iter().enumerate() {
            if child == NO_CHILD {
                continue;
            }
            let child_aabb = self.bvh2.nodes[child as usize].aabb();
            let child_min = ((child_aabb.min - node_p) * rcp_e)
                .floor()
                .clamp(Vec3A::ZERO, Vec3A::splat(255.0));
            let child_max = ((child_aabb.max - node_p) * rcp_e)
                .ceil()
                .clamp(Vec3A::ZERO, Vec3A::splat(255.0));
            node.child_min_x[i] = child_min.x as u8;
            node.child_min_y[i] = child_min.y as u8;
            node.child_min_z[i] = child_min.z as u8;
            node.child_max_x[i] = child_max.x as u8;
            node.child_max_y[i] = child_max.y as u8;
            node.child_max_z[i] = child_max.z as u8;
            match self.decisions[child as usize][0].kind() {
                Kind::Leaf => {
                    let count = self.push_primitives(child as usize);
                    // The three highest bits hold the count in unary (a
                    // leaf of 4 says 3: see `bvh2_to_wide`).
                    node.child_meta[i] = num_primitives as u8
                        | match count {
                            1 => 0b0010_0000,
                            2 => 0b0110_0000,
                            3 | 4 => 0b1110_0000,
                            _ => unreachable!("a wide leaf holds 1 to 4 primitives"),
                        };
                    self.leaf_sizes[wide][i] = count as u8;
                    num_primitives += count;
                }
                Kind::Internal => {
                    node.imask |= 1 << i;
                    node.child_meta[i] = (24 + i as u8) | 0b0010_0000;
                    num_internal_nodes += 1;
                }
                Kind::Distribute => unreachable!("a child's first decision never distributes"),
            }
        }
        self.nodes
            .resize(self.nodes.len() + num_internal_nodes, CwBvhNode::default());
        self.leaf_sizes.resize(self.nodes.len(), [0; BRANCHING]);
        self.nodes[wide] = node;
        let mut offset = 0;
        for (i, &child) in children.iter().enumerate() {
            if child != NO_CHILD && node.imask & (1 << i) != 0 {
                self.convert((node.child_base_idx + offset) as usize, child as usize);
                offset += 1;
            }
        }
    }

    /// Appends the primitives of `index`'s subtree, left to right, and
    /// returns their number (obvhs' `count_primitives`).
    fn push_primitives(&mut self, index: usize) -> u32 {
        let node = &self.bvh2.nodes[index];
        if node.is_leaf() {
            self.primitive_indices
                .push(self.bvh2.primitive_indices[node.first_index as usize]);
            return node.prim_count;
        }
        let first = node.first_index as usize;
        self.push_primitives(first) + self.push_primitives(first + 1)
    }

    /// Gathers the BVH2 nodes that become the wide children of `index` for
    /// decision `slot` (obvhs' `get_children`).
    fn children(
        &self,
        index: usize,
        children: &mut [u32; BRANCHING],
        count: &mut usize,
        slot: usize,
    ) {
        let node = &self.bvh2.nodes[index];
        if node.is_leaf() {
            children[*count] = index as u32;
            *count += 1;
            return;
        }
        let decision = self.decisions[index][slot];
        let first = node.first_index as usize;
        for (child, child_slot) in [(first, decision.left()), (first + 1, decision.right())] {
            if self.decisions[child][child_slot].kind() == Kind::Distribute {
                self.children(child, children, count, child_slot);
            } else {
                children[*count] = child as u32;
                *count += 1;
            }
        }
    }

    /// Puts each child in the slot of the ray octant that visits it first
    /// (Ylitie et al. §3.2; greedy, as obvhs' `order_children`).
    // `s` is both the octant's sign bits and the cost table's column.
    #[allow(clippy::needless_range_loop)]
    fn order_children(&self, index: usize, children: &mut [u32; BRANCHING], count: usize) {
        let p = self.bvh2.nodes[index].aabb().center();
        let mut cost = [[f32::MAX; DIRECTIONS]; BRANCHING];
        for s in 0..DIRECTIONS {
            let d = Vec3A::new(
                if s & 0b100 != 0 { -1.0 } else { 1.0 },
                if s & 0b010 != 0 { -1.0 } else { 1.0 },
                if s & 0b001 != 0 { -1.0 } else { 1.0 },
            );
            for (c, &child) in children.iter().enumerate().take(count) {
                let v = self.bvh2.nodes[child as usize].aabb().center() - p;
                cost[c][s] = d.dot(v);
            }
        }
        let mut assignment = [usize::MAX; BRANCHING];
        let mut slot_filled = [false; DIRECTIONS];
        loop {
            let mut min_cost = f32::MAX;
            let (mut min_slot, mut min_index) = (usize::MAX, usize::MAX);
            for c in 0..count {
                if assignment[c] == usize::MAX {
                    for (s, &filled) in slot_filled.iter().enumerate() {
                        if !filled && cost[c][s] < min_cost {
                            min_cost = cost[c][s];
                            min_slot = s;
                            min_index = c;
                        }
                    }
                }
            }
            if min_slot == usize::MAX {
                break;
            }
            slot_filled[min_slot] = true;
            assignment[min_index] = min_slot;
        }
        let original = std::mem::replace(children, [NO_CHILD; BRANCHING]);
        for c in 0..count {
            children[assignment[c]] = original[c];
        }
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use obvhs::{
        BvhBuildParams, bvh2::reinsertion::ReinsertionOptimizer, ploc::PlocBuilder,
        triangle::Triangle,
    };

    /// obvhs' optimised BVH2 of `tris` with `params` (no pre-splits).
    fn bvh2_of(tris: &[Triangle], params: BvhBuildParams) -> Bvh2 {
        let indices = (0..tris.len() as u32).collect();
        let mut bvh2 = PlocBuilder::with_capacity(tris.len()).build(
            params.ploc_search_distance,
            tris,
            indices,
            params.sort_precision,
            params.search_depth_threshold,
        );
        ReinsertionOptimizer::default().run(&mut bvh2, params.reinsertion_batch_ratio, None);
        bvh2
    }

    /// A height field of `g x g` cells over the unit square, two triangles
    /// per cell (also the BVH build's test scene).
    pub(crate) fn height_field(g: usize) -> Vec<Triangle> {
        let h = |i: usize, j: usize| {
            let (x, z) = (i as f32 / g as f32, j as f32 / g as f32);
            Vec3A::new(x, 0.1 * (7.0 * x).sin() * (5.0 * z).cos(), z)
        };
        let mut tris = Vec::new();
        for i in 0..g {
            for j in 0..g {
                let (a, b, c, d) = (h(i, j), h(i + 1, j), h(i + 1, j + 1), h(i, j + 1));
                tris.push(Triangle {
                    v0: a,
                    v1: d,
                    v2: c,
                });
                tris.push(Triangle {
                    v0: a,
                    v1: c,
                    v2: b,
                });
            }
        }
        tris
    }

    /// `height_field(g)` and a few large triangles across it, so that
    /// leaves of 1 to 3 primitives and every distribution occur.
    fn triangles(g: usize) -> Vec<Triangle> {
        let mut tris = height_field(g);
        for k in 0..5 {
            let y = 0.05 * k as f32;
            tris.push(Triangle {
                v0: Vec3A::new(0.0, y, 0.0),
                v1: Vec3A::new(1.0, y + 0.3, 0.2),
                v2: Vec3A::new(0.3, y, 1.0),
            });
        }
        tris
    }

    #[test]
    fn matches_obvhs() {
        for (g, params) in [
            (1, BvhBuildParams::medium_build()),
            (9, BvhBuildParams::fastest_build()),
            (40, BvhBuildParams::medium_build()),
            (40, BvhBuildParams::very_slow_build()),
        ] {
            let tris = triangles(g);
            let bvh2 = bvh2_of(&tris, params);
            for max_prims in 1..=3 {
                let ours = bvh2_to_cwbvh(&bvh2, max_prims);
                let theirs =
                    obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh(&bvh2, max_prims, true, false);
                assert!(ours.nodes.len() > 1 || tris.len() <= 24, "trivial tree");
                assert!(
                    ours.nodes == theirs.nodes,
                    "nodes differ (g {g}, {max_prims} per leaf)"
                );
                assert_eq!(ours.primitive_indices, theirs.primitive_indices);
                assert_eq!(ours.total_aabb, theirs.total_aabb);
            }
        }
    }

    /// The comparison above is not vacuous: obvhs' tree without the
    /// octant order of children differs from ours.
    #[test]
    fn comparison_sees_the_child_order() {
        let bvh2 = bvh2_of(&triangles(40), BvhBuildParams::medium_build());
        let unordered = obvhs::cwbvh::bvh2_to_cwbvh::bvh2_to_cwbvh(&bvh2, 3, false, false);
        let ours = bvh2_to_cwbvh(&bvh2, 3);
        assert_eq!(ours.nodes.len(), unordered.nodes.len());
        assert!(ours.nodes != unordered.nodes);
    }

    /// Leaves of up to four: the sizes add up to each node's primitives,
    /// every primitive once, some leaves of four, and up to three the
    /// sizes are the compressed node's own counts.
    #[test]
    fn leaf_sizes_account_for_every_primitive() {
        let bvh2 = bvh2_of(&triangles(40), BvhBuildParams::medium_build());
        for max_prims in 1..=MAX_WIDE_LEAF {
            let (wide, sizes) = bvh2_to_wide(&bvh2, max_prims);
            assert_eq!(sizes.len(), wide.nodes.len());
            let mut seen = vec![0; wide.primitive_indices.len()];
            let mut largest = 0;
            for (node, sizes) in wide.nodes.iter().zip(&sizes) {
                for (j, &size) in sizes.iter().enumerate() {
                    if node.is_child_empty(j) || !node.is_leaf(j) {
                        assert_eq!(size, 0);
                        continue;
                    }
                    let (first, count) = node.child_primitives(j);
                    if max_prims <= 3 {
                        assert_eq!(u32::from(size), count);
                    }
                    largest = largest.max(u32::from(size));
                    for slot in first..first + u32::from(size) {
                        seen[slot as usize] += 1;
                    }
                }
            }
            assert!(seen.iter().all(|&n| n == 1), "{max_prims} per leaf");
            assert_eq!(largest, max_prims);
        }
    }

    #[test]
    fn decisions_round_trip() {
        for kind in [Kind::Leaf, Kind::Internal, Kind::Distribute] {
            for left in 0..=NONE {
                for right in 0..=NONE {
                    let d = Decision::new(kind, left, right);
                    assert_eq!(
                        (d.kind(), d.left(), d.right()),
                        (kind, left.into(), right.into())
                    );
                }
            }
        }
        assert_eq!(Decision::new(Kind::Leaf, u8::MAX, u8::MAX).left(), 7);
    }
}
