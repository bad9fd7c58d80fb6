//! BVH over triangles and spheres: `binned.rs` (by default) or obvhs'
//! PLOC builds the binary tree, `convert.rs` makes it 8-wide, obvhs'
//! node types hold it and `traverse.rs` walks it; this module owns the
//! primitives, the ray/triangle test (the ray/sphere test is
//! `sphere.rs`'s) and the mapping back to caller ids.

use std::ops::ControlFlow;

use glam::{Vec3, Vec3A};
use obvhs::{
    BvhBuildParams,
    aabb::Aabb,
    bvh2::{Bvh2, leaf_collapser::collapse, node::Bvh2Node, reinsertion::ReinsertionOptimizer},
    cwbvh::CwBvh,
    ploc::{PlocBuilder, PlocSearchDistance},
    splits::split_aabbs_preset,
    triangle::Triangle,
};

use fearless_simd::Level;

use crate::binned::{self, PrimRef};
use crate::bvh8::{Bvh8, Isa, MAX_BVH8_SLOTS, traverse8};
use crate::convert::bvh2_to_wide;
use crate::flat::{self, Flat};
use crate::leaf::Lane;
use crate::sphere::Sphere;
use crate::traverse::{NodeRay, traverse_binary, traverse_wide};
use crate::triangle::{RayTransform, is_degenerate};

/// Triangles with a vertex coordinate beyond this magnitude are ignored (never
/// hit): the builder's surface-area costs would overflow f32.
pub const MAX_COORDINATE: f32 = 1e15;

/// Deepest CWBVH this crate traverses: obvhs' CWBVH traversal stack holds 32
/// entries and silently overwrites the last one when full, so deeper trees
/// (only seen with adversarial inputs) are traversed as a BVH2 instead.
pub(crate) const MAX_WIDE_DEPTH: usize = 24;

/// Most triangles in a leaf of [`Layout::Bvh8`]: a block of its leaf
/// kernel (`leaf.rs`). The wide tree's conversion puts up to this many
/// primitives in a leaf where its surface-area cost says so.
const BVH8_LEAF: u32 = crate::leaf::BLOCK as u32;

/// A ray hit: distance, caller primitive id and barycentrics.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Ray parameter of the hit, in units of the direction's length:
    /// the hit point is `origin + t * direction`.
    pub t: f32,
    /// The hit primitive: a triangle's index in the slice given to
    /// [`Bvh::build`], or, from [`Bvh::triangle_count`] on, the triangle
    /// count plus a sphere's index in the slice given to
    /// [`Bvh::build_with_spheres`] ([`Bvh::sphere_of`]).
    pub primitive: u32,
    /// Barycentric weight of the triangle's vertex 1 (0 for a sphere).
    pub b1: f32,
    /// Barycentric weight of the triangle's vertex 2 (vertex 0 weighs
    /// `1 - b1 - b2`; 0 for a sphere).
    pub b2: f32,
}

/// Tree layout built by obvhs.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum Layout {
    /// 8-wide compressed BVH (Ylitie et al. 2017, 80 bytes per node), built by
    /// converting the binary tree; SIMD node tests.
    #[default]
    Wide,
    /// An 8-wide tree with float child boxes in structure-of-arrays form
    /// (Embree's BVH8 node, 256 bytes), all eight children tested in one
    /// SIMD operation on the best instruction set of the CPU ([`Isa`]),
    /// nearest child first, and leaves of up to 4 triangles stored lane
    /// by lane and tested at once (Embree's `Triangle4`), with the same
    /// results as the scalar test. The same conversion as [`Layout::Wide`]'s
    /// with leaves of 4 allowed. As fast as [`Layout::Wide`] on the
    /// measured scenes, faster for some ray sets and slower for others;
    /// 3.2 times its node memory plus a 160-byte block per leaf
    /// (docs/benchmarks.md, "The BVH8 layout").
    Bvh8,
    /// Binary BVH (the builder's tree, reinsertion, leaf collapse). Faster
    /// to build.
    Binary,
    /// No tree, for scenes of at most 64 primitives (others get
    /// [`Layout::Wide`]): every primitive tested, triangles 16 at a time
    /// in one SIMD operation on the CPU's best instruction set ([`Isa`]),
    /// with the same results as the scalar test. [`Layout::Wide`] becomes
    /// this one for such scenes without spheres on CPUs with AVX-512, where
    /// it was measured faster (docs/benchmarks.md, "Small scenes without a
    /// tree").
    Flat,
}

impl Layout {
    /// Every layout.
    pub const ALL: [Self; 4] = [Self::Wide, Self::Bvh8, Self::Binary, Self::Flat];
}

/// The builder: this crate's binned SAH builder (the default), or an
/// obvhs build preset (`BvhBuildParams::*_build`), from fastest build to
/// best tree.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[non_exhaustive]
pub enum BuildQuality {
    /// Top-down binned SAH (`binned.rs`), one primitive per leaf; the
    /// `Medium` preset's wide-leaf size (and, for [`Layout::Binary`], its
    /// collapse and reinsertion). Against `Medium` on a 1M-triangle
    /// height field: 9% fewer instructions per path-traced iteration,
    /// the same on the bundled Cornell boxes, about 1.2x its build time,
    /// and about half its build memory. (obvhs' reinsertion after it
    /// changed nothing measurable and took a third of the build time.)
    #[default]
    Binned,
    /// PLOC search distance 1, no reinsertion, one primitive per leaf.
    Fastest,
    /// Search distance 1, 1% reinsertion.
    VeryFast,
    /// Search distance 6, 2% reinsertion.
    Fast,
    /// Search distance 14, 5% reinsertion ("about Embree build time").
    Medium,
    /// Search distance 24, 20% reinsertion, pre-splits of large triangles.
    Slow,
    /// Search distance 14, full reinsertion, pre-splits of large triangles.
    VerySlow,
}

impl BuildQuality {
    /// Every builder: the binned SAH builder, then obvhs' presets, fastest
    /// build first.
    pub const ALL: [Self; 7] = [
        Self::Binned,
        Self::Fastest,
        Self::VeryFast,
        Self::Fast,
        Self::Medium,
        Self::Slow,
        Self::VerySlow,
    ];

    fn params(self) -> BvhBuildParams {
        match self {
            Self::Fastest => BvhBuildParams::fastest_build(),
            Self::VeryFast => BvhBuildParams::very_fast_build(),
            Self::Fast => BvhBuildParams::fast_build(),
            Self::Medium | Self::Binned => BvhBuildParams::medium_build(),
            Self::Slow => BvhBuildParams::slow_build(),
            Self::VerySlow => BvhBuildParams::very_slow_build(),
        }
    }
}

/// "No triangle" for [`Bvh::intersect_leaving`] and
/// [`Bvh::occluded_between`] (rays from a camera or a point light).
pub const NO_SURFACE: u32 = u32::MAX;

/// How [`Bvh::build_with`] builds the tree. The default is the measured best
/// trade-off for a renderer that builds once and traces many rays (see the
/// crate documentation).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct BuildOptions {
    /// Tree layout.
    pub layout: Layout,
    /// Build preset.
    pub quality: BuildQuality,
}

enum Tree {
    Empty,
    Wide(CwBvh),
    Bvh8(Bvh8),
    /// No tree: every slot scanned (`flat.rs`).
    Flat(Flat),
    /// With its number of levels.
    Binary(Bvh2, usize),
}

/// A bounding volume hierarchy over a triangle list and a sphere list
/// ([`Bvh::build_with_spheres`]), answering closest-hit
/// ([`Bvh::intersect`]) and any-hit ([`Bvh::occluded`]) ray queries.
///
/// Triangles are two-sided. Triangles with zero area (coincident or exactly
/// collinear vertices, tested in f64), with a non-finite coordinate, or with a
/// coordinate beyond [`MAX_COORDINATE`] are kept out of the tree and never hit;
/// they still count in [`Bvh::triangle_count`] and keep their ids. An empty
/// (or all-degenerate) list gives a BVH that never hits.
///
/// Spheres with a non-finite centre or a radius that is not finite and
/// positive are likewise never hit, but keep their ids.
///
/// Queries do not allocate and take `&self`: share one `Bvh` between threads.
pub struct Bvh {
    tree: Tree,
    /// Triangles in obvhs' primitive slot order (zero at sphere slots).
    pub(crate) triangles: Vec<[Vec3A; 3]>,
    /// Caller id of each slot.
    pub(crate) ids: Vec<u32>,
    pub(crate) triangle_count: usize,
    /// The spheres, by sphere index (caller id minus `triangle_count`).
    pub(crate) spheres: Vec<Sphere>,
    bounds: (Vec3, Vec3),
    /// floor(log2) of the largest coordinate magnitude of the scene.
    scene_exponent: i32,
    /// The instruction set of [`Layout::Bvh8`]'s node and leaf tests.
    pub(crate) isa: Level,
    /// Whether batch queries run in packets (`packet.rs`).
    pub(crate) packets: bool,
    /// Test [`Layout::Bvh8`]'s leaves one triangle at a time with the
    /// scalar test (the reference of the leaf kernel's tests).
    #[cfg(test)]
    scalar_leaves: bool,
}

impl Default for Bvh {
    /// An empty BVH.
    fn default() -> Self {
        Self::build(&[])
    }
}

impl std::fmt::Debug for Bvh {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Bvh")
            .field("layout", &self.layout())
            .field("triangle_count", &self.triangle_count)
            .field("bounds", &self.bounds)
            .finish_non_exhaustive()
    }
}

/// Per-ray state of both queries, in the triangle test's `t` units (see
/// [`Bvh::prepare`]).
pub(crate) struct PreparedRay {
    pub(crate) transform: RayTransform,
    node: NodeRay,
    pub(crate) t_max: f32,
    /// Triangle-test `t` to the caller's `t`: multiply by both (exact).
    pub(crate) to_caller: (f32, f32),
}

impl Bvh {
    /// Peak memory of [`Bvh::build`] per triangle beyond the scene's own,
    /// in bytes, for checking that a scene fits before it is built.
    /// Measured (default options): building a 999,698-triangle OBJ height
    /// field (`cargo xtask bench --scaling`) took the process from 37.8 to
    /// 131.7 MB resident, 94 bytes per triangle: the builder's 28-byte
    /// references and its tree's two 32-byte nodes and 4-byte index per
    /// primitive (`binned.rs`). The conversion to the wide tree needs less
    /// (the tree, 14 bytes of decisions, the wide nodes), and so does what
    /// stays (48 bytes of triangle corners, a 4-byte id, the wide nodes).
    /// obvhs' PLOC presets need more: by the same count about 150 (two
    /// node buffers and the tree, 32 bytes a node with its
    /// `small_bvh2_node` feature, 48 before; Morton codes), measured 212
    /// with 48-byte nodes.
    pub const BUILD_BYTES_PER_TRIANGLE: u64 = 100;

    /// Builds a BVH over `triangles` with the default [`BuildOptions`], in
    /// parallel on the current rayon pool.
    ///
    /// # Panics
    /// If there are more than `u32::MAX` triangles (ids are `u32`).
    #[must_use]
    pub fn build(triangles: &[[Vec3; 3]]) -> Self {
        Self::build_with(triangles, BuildOptions::default())
    }

    /// Builds a BVH over `triangles` with explicit options.
    ///
    /// # Panics
    /// If there are more than `u32::MAX` triangles (ids are `u32`).
    #[must_use]
    pub fn build_with(triangles: &[[Vec3; 3]], options: BuildOptions) -> Self {
        Self::build_with_spheres(triangles, &[], options)
    }

    /// Builds a BVH over `triangles` and `spheres` in one tree. Hits report
    /// triangle `i` as primitive `i` and sphere `j` as primitive
    /// `triangles.len() + j`. Without spheres the tree, and every query's
    /// result, is exactly [`Bvh::build_with`]'s; with spheres the presets'
    /// pre-splits of large triangles are skipped (they split triangles
    /// only, and only `Slow` and `VerySlow` use them).
    ///
    /// # Panics
    /// If there are more than `u32::MAX` primitives (ids are `u32`).
    #[must_use]
    pub fn build_with_spheres(
        triangles: &[[Vec3; 3]],
        spheres: &[Sphere],
        options: BuildOptions,
    ) -> Self {
        Self::build_from(triangles.len(), |i| triangles[i], spheres, options)
    }

    /// [`Bvh::build_with_spheres`] over an indexed mesh: triangle `i` has
    /// the corners `positions[triangles[i][k]]`. The tree and every query's
    /// result are those of the same triangles given corner by corner.
    ///
    /// # Panics
    /// If a vertex index is out of range, or there are more than
    /// `u32::MAX` primitives.
    #[must_use]
    pub fn build_indexed(
        positions: &[Vec3],
        triangles: &[[u32; 3]],
        spheres: &[Sphere],
        options: BuildOptions,
    ) -> Self {
        Self::build_from(
            triangles.len(),
            |i| triangles[i].map(|v| positions[v as usize]),
            spheres,
            options,
        )
    }

    /// The build over `count` triangles, triangle `i` being `corners(i)`.
    fn build_from(
        count: usize,
        corners: impl Fn(usize) -> [Vec3; 3],
        spheres: &[Sphere],
        options: BuildOptions,
    ) -> Self {
        assert!(
            u32::try_from(count + spheres.len()).is_ok(),
            "accel::Bvh supports at most u32::MAX primitives"
        );
        let mut min = Vec3::INFINITY;
        let mut max = Vec3::NEG_INFINITY;
        // Triangles first, then spheres, each with its caller id: the
        // builders' input, and all the build keeps per primitive besides
        // the tree (28 bytes).
        let mut prims = Vec::with_capacity(count);
        for id in 0..count {
            let tri = &corners(id);
            if !tri
                .iter()
                .all(|v| v.is_finite() && v.abs().max_element() <= MAX_COORDINATE)
            {
                continue;
            }
            let lo = tri[0].min(tri[1]).min(tri[2]);
            let hi = tri[0].max(tri[1]).max(tri[2]);
            min = min.min(lo);
            max = max.max(hi);
            if !is_degenerate(tri) {
                prims.push(PrimRef {
                    min: lo,
                    id: id as u32,
                    max: hi,
                });
            }
        }
        let valid_triangles = prims.len();
        for (j, s) in spheres.iter().enumerate() {
            if s.is_valid() && s.center.abs().max_element() + s.radius <= MAX_COORDINATE {
                let (lo, hi) = s.bounds();
                min = min.min(lo);
                max = max.max(hi);
                prims.push(PrimRef {
                    min: lo,
                    id: (count + j) as u32,
                    max: hi,
                });
            }
        }
        let bounds = if min.x <= max.x {
            (min, max)
        } else {
            (Vec3::ZERO, Vec3::ZERO)
        };
        let mut bvh = Self {
            tree: Tree::Empty,
            triangles: Vec::new(),
            ids: Vec::new(),
            triangle_count: count,
            spheres: spheres.to_vec(),
            bounds,
            scene_exponent: 0,
            isa: Level::new(),
            packets: false,
            #[cfg(test)]
            scalar_leaves: false,
        };
        if prims.is_empty() {
            return bvh;
        }
        let has_spheres = prims.len() > valid_triangles;
        // Each builder's leaves give the primitives' caller ids.
        let bvh2 = match options.quality {
            BuildQuality::Binned => binned::build(&mut prims),
            _ => {
                let mut bvh2 = if !has_spheres && options.quality.params().pre_split {
                    let tris: Vec<Triangle> = prims
                        .iter()
                        .map(|p| {
                            let [v0, v1, v2] = corners(p.id as usize);
                            Triangle {
                                v0: v0.into(),
                                v1: v1.into(),
                                v2: v2.into(),
                            }
                        })
                        .collect();
                    build_bvh2_split(&tris, options)
                } else {
                    let boxes = prims.iter().map(|p| Aabb::new(p.min.into(), p.max.into()));
                    build_bvh2(boxes, prims.len(), options)
                };
                for index in &mut bvh2.primitive_indices {
                    *index = prims[*index as usize].id;
                }
                bvh2
            }
        };
        // The references are no longer needed (28 bytes per primitive).
        drop(prims);
        // The traversals report slots; the slot -> id map moves here.
        let leaf_sizes;
        (bvh.tree, bvh.ids, leaf_sizes) = finish_tree(bvh2, options);
        bvh.triangles = bvh
            .ids
            .iter()
            .map(|&id| {
                if (id as usize) < count {
                    corners(id as usize).map(Vec3A::from)
                } else {
                    [Vec3A::ZERO; 3]
                }
            })
            .collect();
        // (With too many slots for Bvh8 references the tree stays `Wide`,
        // its leaves of at most 3: see `finish_tree`.)
        if options.layout == Layout::Bvh8
            && bvh.triangles.len() < MAX_BVH8_SLOTS
            && let Tree::Wide(wide) = &bvh.tree
        {
            let other = |slot: usize| bvh.ids[slot] as usize >= count;
            let float = Bvh8::from_cwbvh(wide, &leaf_sizes, &bvh.triangles, other);
            bvh.tree = Tree::Bvh8(float);
        }
        if flat::scans(options.layout, bvh.triangles.len(), has_spheres) {
            let other = |slot: usize| bvh.ids[slot] as usize >= count;
            bvh.tree = Tree::Flat(Flat::new(&bvh.triangles, other));
        }
        let scene_scale = bounds.0.abs().max(bounds.1.abs()).max_element();
        bvh.scene_exponent = exponent(scene_scale).clamp(-100, 100);
        bvh.packets = crate::packet::fits(bvh.triangles.len());
        bvh
    }

    /// Number of triangles given to the build, including those that can
    /// never be hit: the first sphere's primitive id.
    #[must_use]
    pub fn triangle_count(&self) -> usize {
        self.triangle_count
    }

    /// The spheres given to the build, by sphere index.
    #[must_use]
    pub fn spheres(&self) -> &[Sphere] {
        &self.spheres
    }

    /// The sphere index of primitive id `primitive`, `None` for a triangle.
    #[inline]
    #[must_use]
    pub fn sphere_of(&self, primitive: u32) -> Option<usize> {
        (primitive as usize)
            .checked_sub(self.triangle_count)
            .filter(|&j| j < self.spheres.len())
    }

    /// Axis-aligned bounds `(min, max)` of all triangles with finite
    /// coordinates within [`MAX_COORDINATE`] (degenerate ones included)
    /// and of all valid spheres; `(0, 0)` when there are none.
    #[must_use]
    pub fn bounds(&self) -> (Vec3, Vec3) {
        self.bounds
    }

    /// The instruction set the SIMD kernels run on ([`Bvh::set_isa`]):
    /// callers with kernels of their own use it too, so that a forced
    /// choice applies to the whole render.
    pub fn simd_level(&self) -> fearless_simd::Level {
        self.isa
    }

    /// The name of the instruction set of [`Bvh::simd_level`]: "AVX-512",
    /// "AVX2", "SSE4.2" or "Neon", else "the platform's baseline" (for
    /// reports such as `render-cli --explain`).
    #[must_use]
    pub fn simd_name(&self) -> &'static str {
        #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
        {
            // Each level also answers for those below it: the widest first.
            if self.isa.as_avx512().is_some() {
                return "AVX-512";
            }
            if self.isa.as_avx2().is_some() {
                return "AVX2";
            }
            if self.isa.as_sse4_2().is_some() {
                return "SSE4.2";
            }
        }
        #[cfg(target_arch = "aarch64")]
        if self.isa.as_neon().is_some() {
            return "Neon";
        }
        "the platform's baseline"
    }

    /// Chooses the instruction set of the SIMD kernels: [`Layout::Bvh8`]'s node and
    /// leaf tests, [`Layout::Flat`]'s scan, and callers' kernels that follow
    /// [`Bvh::simd_level`]. Every choice gives the same results bit for bit;
    /// this is for measuring and for testing that they do. Returns `false`,
    /// changing nothing, when the CPU lacks `isa`.
    pub fn set_isa(&mut self, isa: Isa) -> bool {
        isa.level().map(|level| self.isa = level).is_some()
    }

    /// The layout actually built: [`Layout::Binary`] when the BVH is empty or
    /// when a wide tree came out too deep for obvhs' fixed traversal stack.
    #[must_use]
    pub fn layout(&self) -> Layout {
        match self.tree {
            Tree::Wide(_) => Layout::Wide,
            Tree::Flat(_) => Layout::Flat,
            Tree::Bvh8(_) => Layout::Bvh8,
            Tree::Binary(..) | Tree::Empty => Layout::Binary,
        }
    }

    /// Closest hit along `origin + t * direction` with `0 < t < t_max`.
    ///
    /// `direction` need not be normalized (`t` is in units of its length);
    /// `t_max` may be `f32::INFINITY`. Returns `None` when nothing is hit, and
    /// for a zero or non-finite direction, a non-finite origin, or a `t_max`
    /// that is not positive (or NaN). No epsilon is applied: start secondary
    /// rays at [`offset_ray_origin`](crate::offset_ray_origin).
    ///
    /// When several primitives are hit at the same `t` (a ray through a
    /// shared edge or vertex), the one with the lowest id is returned,
    /// whatever the layout.
    #[must_use]
    pub fn intersect(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<Hit> {
        self.intersect_leaving(origin, direction, t_max, NO_SURFACE)
    }

    /// [`Bvh::intersect`] of a ray leaving the surface of triangle `surface`
    /// (a caller id; [`NO_SURFACE`] for none) from an origin offset off it
    /// to the side `direction` points to ([`offset_ray_origin`]): that
    /// triangle is not tested. A ray starting off a plane and moving away
    /// from it cannot meet it, so the result is the same, and the test is
    /// saved whenever the traversal reaches the triangle's leaf (often: its
    /// box holds the origin, unless it is flat and the ray leaves it). A
    /// sphere id is tested as usual: a ray leaving a sphere can meet it
    /// again.
    ///
    /// [`offset_ray_origin`]: crate::offset_ray_origin
    #[must_use]
    pub fn intersect_leaving(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        surface: u32,
    ) -> Option<Hit> {
        self.intersect_skipping(origin, direction, t_max, [surface; 2])
    }

    /// [`Bvh::intersect_leaving`] not testing the triangles `skip`.
    #[inline(always)]
    pub(crate) fn intersect_skipping(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        skip: [u32; 2],
    ) -> Option<Hit> {
        if self.spheres.is_empty() {
            self.closest::<false>(origin, direction, t_max, skip, |_, _, _| true)
        } else {
            self.closest::<true>(origin, direction, t_max, skip, |_, _, _| true)
        }
    }

    /// [`Bvh::intersect`] among the hits that `accept(primitive, b1, b2)`
    /// (caller id and barycentrics) keeps: a rejected hit is passed through
    /// as if the primitive were not there (alpha cut-outs, stochastic
    /// transparency). `accept` may be called for any primitive the ray hits
    /// before the closest accepted one, in any order; it should depend only
    /// on its arguments (and the ray).
    #[must_use]
    #[inline]
    pub fn intersect_where(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        mut accept: impl FnMut(u32, f32, f32) -> bool,
    ) -> Option<Hit> {
        let accept = |slot: usize, b1, b2| accept(self.ids[slot], b1, b2);
        let skip = [NO_SURFACE; 2];
        if self.spheres.is_empty() {
            self.closest::<false>(origin, direction, t_max, skip, accept)
        } else {
            self.closest::<true>(origin, direction, t_max, skip, accept)
        }
    }

    /// The closest-hit traversal; `accept(slot, b1, b2)` may reject a hit.
    /// `SPHERES`: whether any slot may hold a sphere (without, the test is
    /// the triangle test alone, as before spheres existed). The triangles
    /// `skip` names are not tested ([`Bvh::intersect_leaving`]).
    #[inline(always)]
    fn closest<const SPHERES: bool>(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        skip: [u32; 2],
        mut accept: impl FnMut(usize, f32, f32) -> bool,
    ) -> Option<Hit> {
        let r = self.prepare(origin, direction, t_max)?;
        let mut best: Option<(usize, f32, f32)> = None;
        let mut t_int = r.t_max;
        // Hits at the closest distance so far are tested too (the triangle
        // and sphere tests take t_max inclusively) and win when their
        // primitive id is lower: the result does not depend on the order in
        // which leaves are visited, so every layout returns the same hit.
        let wins = |slot: usize, t: f32, t_max: f32, best: Option<(usize, f32, f32)>| {
            t < t_max || best.is_some_and(|(b, ..)| self.ids[slot] < self.ids[b])
        };
        let test = |slot: usize, t_max: &mut f32, lane: Lane| {
            let id = self.ids[slot];
            if SPHERES && id as usize >= self.triangle_count {
                if let Some(t) = self.sphere_test(slot, r.to_caller, origin, direction, *t_max)
                    && wins(slot, t, *t_max, best)
                    && accept(slot, 0.0, 0.0)
                {
                    *t_max = t;
                    t_int = t;
                    best = Some((slot, 0.0, 0.0));
                }
            } else if !skip.contains(&id)
                && let Some((t, b1, b2)) =
                    lane.or_scalar(|| r.transform.intersect(&self.triangles[slot], *t_max))
                && wins(slot, t, *t_max, best)
                && accept(slot, b1, b2)
            {
                *t_max = t;
                t_int = t;
                best = Some((slot, b1, b2));
            }
            ControlFlow::Continue(())
        };
        self.traverse(&r, test);
        let (slot, b1, b2) = best?;
        let t = t_int * r.to_caller.0 * r.to_caller.1;
        if SPHERES && self.ids[slot] as usize >= self.triangle_count {
            return self.refine_sphere(slot, origin, direction, t_max, t);
        }
        self.refine(slot, origin, direction, t_max, (t, b1, b2))
    }

    /// The sphere test of the sphere in `slot` for the caller's ray, in
    /// the triangle test's `t` units (see [`Bvh::prepare`]): on the
    /// direction scaled by 2^-k (exact), whose `t` is the triangle test's
    /// times 2^m (`to_caller` of the prepared ray: 2^m, 2^-k).
    #[inline]
    pub(crate) fn sphere_test(
        &self,
        slot: usize,
        to_caller: (f32, f32),
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
    ) -> Option<f32> {
        let sphere = &self.spheres[self.ids[slot] as usize - self.triangle_count];
        let unit = direction * to_caller.1;
        let to_unit = f64::from(to_caller.0);
        // Inclusive of t_max, as the triangle test (`Bvh::closest`'s ties).
        let t = sphere.intersect(origin, unit, f64::from(t_max.next_up()) * to_unit)? / to_unit;
        let t = t as f32;
        (t > 0.0 && t <= t_max).then_some(t)
    }

    /// The sphere hit in `slot` recomputed with the caller's ray (the test
    /// is exact up to the f64 rounding; only the power-of-two scalings
    /// differ), kept inside `(0, t_max)` as [`Bvh::refine`] does.
    #[cold]
    pub(crate) fn refine_sphere(
        &self,
        slot: usize,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        fallback: f32,
    ) -> Option<Hit> {
        let sphere = &self.spheres[self.ids[slot] as usize - self.triangle_count];
        let t = sphere
            .intersect(origin, direction, f64::from(t_max))
            .map_or(fallback, |t| t as f32);
        let t = if t > 0.0 && t < t_max {
            t
        } else if fallback > 0.0 && fallback < t_max {
            fallback
        } else {
            return None;
        };
        Some(Hit {
            t,
            primitive: self.ids[slot],
            b1: 0.0,
            b2: 0.0,
        })
    }

    /// The hit on the triangle in `slot` recomputed in f64 (Möller–Trumbore
    /// on the f32 inputs). The watertight f32 test decides which triangle is
    /// hit; its distance and barycentrics carry an absolute error
    /// proportional to the vertices' distance from the origin, which is large
    /// relative to short hits and to the barycentrics of grazing hits. The
    /// result is kept inside the triangle (`b1, b2 >= 0`, `b1 + b2 <= 1`) and
    /// inside `(0, t_max)`, where the f32 test put it. `None` only for a hit
    /// beyond f32 range.
    #[inline(always)]
    pub(crate) fn refine(
        &self,
        slot: usize,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        fallback: (f32, f32, f32),
    ) -> Option<Hit> {
        let [v0, v1, v2] = self.triangles[slot].map(|v| v.as_dvec3());
        let d = direction.as_dvec3();
        let e1 = v1 - v0;
        let e2 = v2 - v0;
        let p = d.cross(e2);
        let s = origin.as_dvec3() - v0;
        let q = s.cross(e1);
        let inv_det = 1.0 / e1.dot(p);
        let t = (e2.dot(q) * inv_det) as f32;
        let (mut b1, mut b2) = ((s.dot(p) * inv_det) as f32, (d.dot(q) * inv_det) as f32);
        if !(b1.is_finite() && b2.is_finite()) {
            (b1, b2) = (fallback.1, fallback.2);
        }
        let b1 = b1.clamp(0.0, 1.0);
        let b2 = b2.clamp(0.0, 1.0 - b1);
        // At the ends of the range, where rounding decides, keep the f32
        // test's verdict: the hit stays, just inside the range.
        let t = if t > 0.0 && t < t_max {
            t
        } else if fallback.0 > 0.0 && fallback.0 < t_max {
            fallback.0
        } else if t.is_nan() || t <= 0.0 {
            f32::from_bits(1)
        } else {
            f32::from_bits(t_max.to_bits() - 1)
        };
        t.is_finite().then_some(Hit {
            t,
            primitive: self.ids[slot],
            b1,
            b2,
        })
    }

    /// Whether any primitive is hit along `origin + t * direction` with
    /// `0 < t < t_max` (any-hit query with early exit, for shadow and
    /// connection rays).
    ///
    /// Same conventions as [`Bvh::intersect`]; degenerate rays are never
    /// occluded.
    #[must_use]
    pub fn occluded(&self, origin: Vec3, direction: Vec3, t_max: f32) -> bool {
        self.occluded_between(origin, direction, t_max, [NO_SURFACE; 2])
    }

    /// [`Bvh::occluded`] of a segment between two surface points, each end
    /// offset off its surface towards the other ([`offset_ray_origin`]):
    /// the triangles `surfaces` (caller ids; [`NO_SURFACE`] for none) they
    /// lie on are not tested, as in [`Bvh::intersect_leaving`]: the segment
    /// meets neither, and its traversal often reaches both leaves (their
    /// boxes hold its ends).
    ///
    /// [`offset_ray_origin`]: crate::offset_ray_origin
    #[must_use]
    pub fn occluded_between(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        surfaces: [u32; 2],
    ) -> bool {
        if self.spheres.is_empty() {
            self.any::<false>(origin, direction, t_max, surfaces, |_, _, _| true)
        } else {
            self.any::<true>(origin, direction, t_max, surfaces, |_, _, _| true)
        }
    }

    /// [`Bvh::occluded`] by the hits that `accept(primitive, b1, b2)` keeps
    /// (see [`Bvh::intersect_where`]).
    #[must_use]
    #[inline]
    pub fn occluded_where(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        mut accept: impl FnMut(u32, f32, f32) -> bool,
    ) -> bool {
        let accept = |slot: usize, b1, b2| accept(self.ids[slot], b1, b2);
        let skip = [NO_SURFACE; 2];
        if self.spheres.is_empty() {
            self.any::<false>(origin, direction, t_max, skip, accept)
        } else {
            self.any::<true>(origin, direction, t_max, skip, accept)
        }
    }

    /// The any-hit traversal (see [`Bvh::closest`]).
    #[inline(always)]
    fn any<const SPHERES: bool>(
        &self,
        origin: Vec3,
        direction: Vec3,
        t_max: f32,
        skip: [u32; 2],
        mut accept: impl FnMut(usize, f32, f32) -> bool,
    ) -> bool {
        let Some(r) = self.prepare(origin, direction, t_max) else {
            return false;
        };
        let mut occluded = false;
        let test = |slot: usize, t_max: &mut f32, lane: Lane| {
            // The tests take t_max inclusively; an occluder must be before it.
            let id = self.ids[slot];
            let hit = if SPHERES && id as usize >= self.triangle_count {
                self.sphere_test(slot, r.to_caller, origin, direction, *t_max)
                    .is_some_and(|t| t < *t_max)
                    && accept(slot, 0.0, 0.0)
            } else {
                !skip.contains(&id)
                    && lane
                        .or_scalar(|| r.transform.intersect(&self.triangles[slot], *t_max))
                        .is_some_and(|(t, b1, b2)| t < *t_max && accept(slot, b1, b2))
            };
            if hit {
                occluded = true;
                ControlFlow::Break(())
            } else {
                ControlFlow::Continue(())
            }
        };
        self.traverse(&r, test);
        occluded
    }

    /// Runs the traversal of the tree with `prim(slot, &mut t_max, lane)`:
    /// [`Layout::Bvh8`] tests a leaf's triangles at once and passes each
    /// slot's result (see `bvh8::traverse8`), the other layouts pass
    /// [`Lane::Scalar`].
    #[inline(always)]
    fn traverse(
        &self,
        r: &PreparedRay,
        mut prim: impl FnMut(usize, &mut f32, Lane) -> ControlFlow<()>,
    ) {
        let scalar = |slot, t_max: &mut f32| prim(slot, t_max, Lane::Scalar);
        match &self.tree {
            Tree::Empty => {}
            Tree::Wide(bvh) => traverse_wide(bvh, &r.node, r.t_max, scalar),
            #[cfg(test)]
            Tree::Bvh8(bvh) if self.scalar_leaves => {
                traverse8::<false>(self.isa, bvh, &r.node, &r.transform, r.t_max, prim);
            }
            Tree::Bvh8(bvh) => {
                traverse8::<true>(self.isa, bvh, &r.node, &r.transform, r.t_max, prim);
            }
            Tree::Flat(flat) => flat::scan(self.isa, flat, &r.transform, r.t_max, prim),
            Tree::Binary(bvh, depth) => traverse_binary(bvh, *depth, &r.node, r.t_max, scalar),
        }
    }

    /// Validates a query and sets up the triangle test and the node tests.
    ///
    /// With `k` = floor(log2) of the direction's largest component and `m` one
    /// more than floor(log2) of the largest coordinate of the scene and the
    /// origin, both run on direction `d * 2^-k` with coordinates scaled by
    /// `2^-m`: exact power-of-two scalings (the caller's `t` is `2^(m - k)`
    /// times theirs) that keep the triangle test's quadratic terms in f32
    /// range for any scene size and direction length.
    ///
    /// Reciprocal directions are clamped to `2^80` times the reciprocal of
    /// the largest direction component: beyond any slab distance in range,
    /// small enough that no node test multiplies zero by infinity or
    /// overflows.
    ///
    /// Always inlined: called out of line, its result went back through
    /// the stack and the query's first loads of it waited on those stores
    /// (1.2 % of PT's time on one load, perf).
    #[inline(always)]
    pub(crate) fn prepare(&self, origin: Vec3, direction: Vec3, t_max: f32) -> Option<PreparedRay> {
        // The checks and reciprocals below take the three components at
        // once (Vec3A is an SSE register): per component they were about
        // 40 instructions of every ray's set-up.
        let (o, d) = (Vec3A::from(origin), Vec3A::from(direction));
        if matches!(self.tree, Tree::Empty)
            || !(o.is_finite() && d.is_finite())
            || d.cmpeq(Vec3A::ZERO).all()
            || !(t_max > 0.0)
        {
            return None;
        }
        let k = exponent(d.abs().max_element()).clamp(-126, 126);
        let unit = direction * pow2(-k);
        // (An origin beyond 2^126 is clamped and may miss.)
        let m = (self.scene_exponent.max(exponent(o.abs().max_element())) + 1).clamp(-126, 126);
        let node_direction = Vec3A::from(unit) * pow2(m);
        let max_inv = Vec3A::splat(pow2((80 - m).clamp(-126, 126)));
        // Zero components map to +max_inv; 1/c of the others is clamped
        // (never NaN here, so SSE's min and max agree with f32's).
        let inv_direction = Vec3A::select(
            node_direction.cmpeq(Vec3A::ZERO),
            max_inv,
            node_direction.recip().max(-max_inv).min(max_inv),
        );
        Some(PreparedRay {
            transform: RayTransform::new(origin, unit, pow2(-m)),
            node: NodeRay {
                origin: o,
                direction: node_direction,
                inv_direction,
            },
            t_max: t_max * pow2(k) * pow2(-m),
            to_caller: (pow2(m), pow2(-k)),
        })
    }
}

/// The optimised binary tree over the primitives whose boxes `boxes`
/// yields (`count` of them), without pre-splits: obvhs' `PlocBuilder::build`
/// and reinsertion (the steps of its `build_*_from_tris` helpers, without
/// their debug-build validation pass), with the leaves written from the
/// boxes as they come (obvhs' `build_ploc` takes a slice of primitives:
/// for triangles a 48-byte copy each, held through the build). The tree is
/// the same: `build_ploc` makes exactly these leaves and this total box
/// (min and max do not depend on the order).
fn build_bvh2(boxes: impl Iterator<Item = Aabb>, count: usize, options: BuildOptions) -> Bvh2 {
    let config = options.quality.params();
    let mut builder = PlocBuilder::with_capacity(count);
    let mut total = Aabb::empty();
    builder.current_nodes.clear();
    builder
        .current_nodes
        .extend(boxes.enumerate().map(|(i, aabb)| {
            total.extend(aabb.min);
            total.extend(aabb.max);
            Bvh2Node::new(aabb, 1, i as u32)
        }));
    assert_eq!(builder.current_nodes.len(), count, "one box per primitive");
    let mut bvh2 = Bvh2::zeroed(count);
    bvh2.reset_for_reuse(count, Some((0..count as u32).collect()));
    let (precision, threshold) = (config.sort_precision, config.search_depth_threshold);
    match config.ploc_search_distance {
        PlocSearchDistance::Minimum => {
            builder.build_ploc_from_leaves::<1, false>(&mut bvh2, total, precision, threshold);
        }
        PlocSearchDistance::VeryLow => {
            builder.build_ploc_from_leaves::<2, false>(&mut bvh2, total, precision, threshold);
        }
        PlocSearchDistance::Low => {
            builder.build_ploc_from_leaves::<6, false>(&mut bvh2, total, precision, threshold);
        }
        PlocSearchDistance::Medium => {
            builder.build_ploc_from_leaves::<14, false>(&mut bvh2, total, precision, threshold);
        }
        PlocSearchDistance::High => {
            builder.build_ploc_from_leaves::<24, false>(&mut bvh2, total, precision, threshold);
        }
        PlocSearchDistance::VeryHigh => {
            builder.build_ploc_from_leaves::<32, false>(&mut bvh2, total, precision, threshold);
        }
    }
    drop(builder);
    ReinsertionOptimizer::default().run(&mut bvh2, config.reinsertion_batch_ratio, None);
    bvh2
}

/// The optimised binary tree of `triangles` with the presets' pre-splits
/// of large triangles (`Slow`, `VerySlow`).
fn build_bvh2_split(triangles: &[Triangle], options: BuildOptions) -> Bvh2 {
    let config = options.quality.params();
    let mut largest_half_area = 0.0f32;
    let mut total_half_area = 0.0f64;
    let mut aabbs: Vec<Aabb> = triangles
        .iter()
        .map(|t| {
            let aabb = t.aabb();
            let half_area = aabb.half_area();
            largest_half_area = largest_half_area.max(half_area);
            total_half_area += f64::from(half_area);
            aabb
        })
        .collect();
    let mut indices: Vec<u32> = (0..triangles.len() as u32).collect();
    let avg_half_area = (total_half_area / triangles.len() as f64) as f32;
    split_aabbs_preset(
        &mut aabbs,
        &mut indices,
        triangles,
        avg_half_area,
        largest_half_area,
    );
    let mut bvh2 = PlocBuilder::with_capacity(aabbs.len()).build(
        config.ploc_search_distance,
        &aabbs,
        indices,
        config.sort_precision,
        config.search_depth_threshold,
    );
    bvh2.uses_spatial_splits = true;
    ReinsertionOptimizer::default().run(&mut bvh2, config.reinsertion_batch_ratio, None);
    bvh2
}

/// The tree of `options.layout` from `bvh2` (for [`Layout::Bvh8`] the
/// wide tree to decode, with its leaf sizes), and the caller id of each
/// primitive slot.
fn finish_tree(mut bvh2: Bvh2, options: BuildOptions) -> (Tree, Vec<u32>, Vec<[u8; 8]>) {
    let config = options.quality.params();
    if matches!(options.layout, Layout::Wide | Layout::Bvh8 | Layout::Flat) {
        // The binary tree's bookkeeping of the reinsertion is not needed.
        bvh2.parents = Vec::new();
        bvh2.primitives_to_nodes = Vec::new();
        let leaf =
            if options.layout == Layout::Bvh8 && bvh2.primitive_indices.len() < MAX_BVH8_SLOTS {
                BVH8_LEAF
            } else {
                config.max_prims_per_leaf.clamp(1, 3)
            };
        let (mut wide, sizes) = bvh2_to_wide(&bvh2, leaf);
        let depth = wide_depth(&wide);
        if depth <= MAX_WIDE_DEPTH {
            let ids = std::mem::take(&mut wide.primitive_indices);
            return (Tree::Wide(wide), ids, sizes);
        }
    }
    let mut reinsertion = ReinsertionOptimizer::default();
    collapse(
        &mut bvh2,
        config.max_prims_per_leaf.clamp(1, 255),
        config.collapse_traversal_cost,
    );
    reinsertion.run(
        &mut bvh2,
        config.reinsertion_batch_ratio * config.post_collapse_reinsertion_batch_ratio_multiplier,
        None,
    );
    let depth = binary_depth(&bvh2);
    let ids = std::mem::take(&mut bvh2.primitive_indices);
    (Tree::Binary(bvh2, depth), ids, Vec::new())
}

/// Number of node levels of a CWBVH (0 when empty).
fn wide_depth(bvh: &CwBvh) -> usize {
    let mut max = 0;
    let mut stack = Vec::new();
    if !bvh.nodes.is_empty() {
        stack.push((0u32, 1usize));
    }
    while let Some((index, depth)) = stack.pop() {
        max = max.max(depth);
        let node = &bvh.nodes[index as usize];
        for child in 0..8 {
            if !node.is_child_empty(child) && !node.is_leaf(child) {
                stack.push((node.child_node_index(child), depth + 1));
            }
        }
    }
    max
}

/// Number of node levels of a BVH2 (0 when empty).
fn binary_depth(bvh: &Bvh2) -> usize {
    let mut max = 0;
    let mut stack = Vec::new();
    if !bvh.nodes.is_empty() {
        stack.push((0u32, 1usize));
    }
    while let Some((index, depth)) = stack.pop() {
        max = max.max(depth);
        let node = &bvh.nodes[index as usize];
        if !node.is_leaf() {
            stack.push((node.first_index, depth + 1));
            stack.push((node.first_index + 1, depth + 1));
        }
    }
    max
}

/// floor(log2(|x|)) for a finite non-zero `x` (denormals included).
fn exponent(x: f32) -> i32 {
    let bits = x.abs().to_bits();
    let biased = (bits >> 23) as i32;
    if biased == 0 {
        // Denormal: 2^-149 * mantissa.
        -149 + 31 - (bits.leading_zeros() as i32)
    } else {
        biased - 127
    }
}

/// 2^e for -126 <= e <= 127.
fn pow2(e: i32) -> f32 {
    f32::from_bits(((e + 127) as u32) << 23)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The leaves written from boxes give obvhs' own tree (`PlocBuilder::build`
    /// over a slice of triangles, then reinsertion), node for node; a
    /// different search distance gives another (the comparison can fail).
    #[test]
    fn leaves_from_boxes_give_obvhs_tree() {
        let tris = crate::convert::tests::height_field(30);
        let theirs = |quality: BuildQuality| {
            let config = quality.params();
            let mut bvh2 = PlocBuilder::with_capacity(tris.len()).build(
                config.ploc_search_distance,
                &tris,
                (0..tris.len() as u32).collect(),
                config.sort_precision,
                config.search_depth_threshold,
            );
            ReinsertionOptimizer::default().run(&mut bvh2, config.reinsertion_batch_ratio, None);
            bvh2
        };
        for quality in [
            BuildQuality::Fastest,
            BuildQuality::Fast,
            BuildQuality::Medium,
        ] {
            let options = BuildOptions {
                quality,
                ..BuildOptions::default()
            };
            let ours = build_bvh2(tris.iter().map(Triangle::aabb), tris.len(), options);
            let reference = theirs(quality);
            // (Bvh2Node has no PartialEq; Debug prints every f32 exactly.)
            assert_eq!(
                format!("{:?}", ours.nodes),
                format!("{:?}", reference.nodes),
                "{quality:?}"
            );
            assert_eq!(ours.primitive_indices, reference.primitive_indices);
        }
        let fastest = build_bvh2(
            tris.iter().map(Triangle::aabb),
            tris.len(),
            BuildOptions::default(),
        );
        assert_ne!(
            format!("{:?}", fastest.nodes),
            format!("{:?}", theirs(BuildQuality::Fastest).nodes)
        );
    }

    /// Every query on [`Layout::Bvh8`] answers the same bits with the leaf
    /// kernel as with the scalar test slot by slot (the same tree), at
    /// every instruction set, and filtered queries call the filter with
    /// the same arguments in the same order.
    #[test]
    fn leaf_kernel_answers_as_the_scalar_loop() {
        use stats::Pcg32;
        let mut rng = Pcg32::new(11, 5);
        let mut unit = || Vec3::new(rng.uniform_f32(), rng.uniform_f32(), rng.uniform_f32());
        let field: Vec<[Vec3; 3]> = crate::convert::tests::height_field(16)
            .iter()
            .map(|t| [t.v0, t.v1, t.v2].map(Vec3::from))
            .collect();
        let soup: Vec<[Vec3; 3]> = (0..600)
            .map(|_| {
                let c = unit() * 2.0;
                [c, c + unit() * 0.2, c + unit() * 0.2]
            })
            .collect();
        let spheres: Vec<Sphere> = (0..40)
            .map(|_| Sphere {
                center: unit() * 2.0,
                radius: 0.05 + 0.1 * unit().x,
            })
            .collect();
        let options = BuildOptions {
            layout: Layout::Bvh8,
            ..BuildOptions::default()
        };
        let scenes = [
            Bvh::build_with(&field, options),
            Bvh::build_with_spheres(&soup, &spheres, options),
        ];
        // Rays straight down through grid vertices and edges (exact zero
        // edge functions: the f64 path; ties between neighbours), aimed at
        // vertices, and random ones.
        let mut rays = Vec::new();
        for i in 0..600 {
            let target = match i % 3 {
                0 => Vec3::new((i % 17) as f32 / 16.0, 0.0, (i % 13) as f32 / 16.0),
                1 => field[i % field.len()][i % 3],
                _ => unit() * 2.0,
            };
            let d = if i % 2 == 0 {
                Vec3::NEG_Y
            } else {
                unit() - 0.5
            };
            // (Aimed rays reach their target at t = 1.5.)
            let t_max = [f32::INFINITY, 1.5, 2.0][i % 3];
            rays.push((target - d * 1.5, d, t_max));
        }
        let bits = |h: Option<Hit>| h.map(|h| [h.t, h.b1, h.b2].map(f32::to_bits));
        let mut compared = 0;
        for mut bvh in scenes {
            assert_eq!(bvh.layout(), Layout::Bvh8);
            for isa in Isa::ALL {
                if !bvh.set_isa(isa) {
                    continue;
                }
                let answers = |bvh: &Bvh| {
                    let mut calls = Vec::new();
                    let mut out = Vec::new();
                    for &(o, d, t_max) in &rays {
                        let mut keep = |p: u32, b1: f32, b2: f32| {
                            calls.push((p, b1.to_bits(), b2.to_bits()));
                            !p.is_multiple_of(3)
                        };
                        let hit = bvh.intersect(o, d, t_max);
                        out.push((
                            hit.map(|h| h.primitive),
                            bits(hit),
                            bits(bvh.intersect_where(o, d, t_max, &mut keep)),
                            bvh.occluded(o, d, t_max),
                            bvh.occluded_where(o, d, t_max, &mut keep),
                        ));
                    }
                    (out, calls)
                };
                let kernel = answers(&bvh);
                bvh.scalar_leaves = true;
                let scalar = answers(&bvh);
                bvh.scalar_leaves = false;
                let hits = kernel.0.iter().filter(|a| a.0.is_some()).count();
                assert!(hits > rays.len() / 4, "{hits} hits");
                for (i, (k, s)) in kernel.0.iter().zip(&scalar.0).enumerate() {
                    assert_eq!(k, s, "{isa:?}, ray {i}: {:?}", rays[i]);
                }
                assert!(kernel.1 == scalar.1, "{isa:?}: the filter's calls differ");
                compared += 1;
            }
        }
        assert!(compared >= 2);
    }

    /// `simd_name` names the instruction set `set_isa` chose.
    #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
    #[test]
    fn simd_name_follows_the_chosen_instruction_set() {
        let mut bvh = Bvh::build(&[[Vec3::ZERO, Vec3::X, Vec3::Y]]);
        for (isa, name) in [
            (Isa::Baseline, "SSE4.2"),
            (Isa::Avx2, "AVX2"),
            (Isa::Avx512, "AVX-512"),
        ] {
            if bvh.set_isa(isa) {
                assert_eq!(bvh.simd_name(), name);
            }
        }
    }

    #[test]
    fn exponent_and_pow2() {
        assert_eq!(exponent(1.0), 0);
        assert_eq!(exponent(1.5), 0);
        assert_eq!(exponent(-2.0), 1);
        assert_eq!(exponent(0.75), -1);
        assert_eq!(exponent(1e-40), (1e-40f64).log2().floor() as i32);
        assert_eq!(exponent(f32::from_bits(1)), -149);
        assert_eq!(pow2(0), 1.0);
        assert_eq!(pow2(-126), f32::MIN_POSITIVE);
        assert_eq!(pow2(127), 2f32.powi(127));
    }
}
