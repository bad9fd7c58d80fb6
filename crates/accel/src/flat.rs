//! A scene small enough to need no tree: every primitive slot in
//! [`TriangleBlock`]s (`leaf.rs`), all tested by the SIMD leaf kernel, one
//! block after the other.
//!
//! For a few dozen triangles (a Cornell box: 32-36), a tree's node tests
//! and its leaf bookkeeping cost more than testing every triangle: the
//! blocks' tests do not depend on each other, so consecutive blocks
//! overlap in the processor, where a traversal waits on each node's result
//! before it loads the next (`../shared/notes/simd-and-wavefront.md` §3
//! measured a brute-force test of a 36-triangle box as fast as obvhs'
//! traversal on SSE, 1.6x with AVX2).
//!
//! The hits are the tree's: the caller's closest-hit test breaks ties by
//! primitive id, so the order of the slots does not matter, and a block's
//! lanes equal the scalar test's bits (`leaf.rs`).

use std::ops::ControlFlow;

use fearless_simd::{Level, dispatch, f32x16};
use glam::Vec3A;

use crate::Layout;
use crate::bvh8::Isa;
use crate::leaf::{self, BlockRay, Lane, TriangleBlock};
use crate::triangle::RayTransform;

/// Slots per block: one AVX-512 register, two AVX2 ones, four SSE ones.
const WIDTH: usize = 16;

/// Most primitive slots a scene may have to be scanned without a tree:
/// four blocks.
const MAX_SLOTS: usize = 4 * WIDTH;

/// Whether a scene of `slots` primitives built with `layout` is scanned
/// without a tree: on request ([`Layout::Flat`]), or by default
/// ([`Layout::Wide`]) where it was measured faster, for triangles alone on
/// a CPU with AVX-512 (one register a block; with AVX2 it ran at the
/// tree's speed, with SSE4.2 slower, and spheres, which the tree's boxes
/// cull, then take their f64 test on every ray).
pub(crate) fn scans(layout: Layout, slots: usize, spheres: bool) -> bool {
    slots <= MAX_SLOTS
        && match layout {
            Layout::Flat => true,
            Layout::Wide => !spheres && Isa::Avx512.level().is_some(),
            Layout::Bvh8 | Layout::Binary => false,
        }
}

/// Every slot's primitive, [`WIDTH`] slots a block, in slot order.
pub(crate) struct Flat {
    blocks: Vec<TriangleBlock<WIDTH>>,
}

impl Flat {
    /// The blocks of `triangles` (slot `s` holding `triangles[s]`, or
    /// something else, a sphere, when `other(s)`).
    pub(crate) fn new(triangles: &[[Vec3A; 3]], other: impl Fn(usize) -> bool) -> Self {
        let blocks = triangles
            .chunks(WIDTH)
            .enumerate()
            .map(|(b, chunk)| {
                let first = b * WIDTH;
                TriangleBlock::new(first as u32, chunk, |j| other(first + j))
            })
            .collect();
        Self { blocks }
    }
}

/// Visits every slot whose lane hits or needs the scalar test, block by
/// block, with `prim(slot, &mut t_max, lane)` as `bvh8::traverse8` does.
#[inline(always)]
pub(crate) fn scan(
    isa: Level,
    flat: &Flat,
    triangle: &RayTransform,
    t_max: f32,
    prim: impl FnMut(usize, &mut f32, Lane) -> ControlFlow<()>,
) {
    dispatch!(isa, simd => {
        let ray = BlockRay::<f32x16<_>>::new(simd, triangle);
        let (mut t_max, mut prim) = (t_max, prim);
        for block in &flat.blocks {
            if leaf::visit(simd, block, &ray, &mut t_max, &mut prim).is_break() {
                break;
            }
        }
    });
}
