//! Batch queries in packets of rays: in a scene of at most [`MAX_SLOTS`]
//! primitives (a Cornell box, SmallVCM's scenes), up to [`WIDTH`] rays, one
//! per SIMD lane, are tested together against each triangle in turn.
//!
//! **Why.** In such a scene a single ray's query is mostly its own
//! overhead: set-up, the loop over candidate lanes, the tie rule, each
//! taken one ray at a time (`Layout::Flat` tests 16 triangles at once and
//! still spends about 300 cycles a ray). A packet shares one triangle's
//! loads and branches among its rays, and its lanes' tests, masks and the
//! closest-hit update are branch-free vector operations. The watertight
//! test needs each ray's axis permutation, so a batch is grouped by
//! permutation (six of them) first: the rays of a packet share it, and a
//! triangle's permuted corners are broadcast as they are in `leaf.rs`.
//!
//! **The single-ray queries' results, bit for bit.** Each lane makes the
//! float operations of `leaf.rs`'s kernel (which equal the scalar test's,
//! see there), edge functions of exactly zero go to the scalar test, and
//! spheres, culled in f32 lanes with a margin that never drops a ray the
//! f64 test hits ([`CULL_MARGIN`]), take the f64 test per ray. The
//! closest-hit rule is [`Bvh::intersect`]'s (the nearest `t`, ties to the
//! lowest primitive id, so the order of the tests does not matter), the
//! hit is refined as there, and a ray's `skip` triangles are not tested,
//! as in [`Bvh::intersect_leaving`] and [`Bvh::occluded_between`]. Only
//! IEEE operations without fused multiply-add: the same results on every
//! instruction set (tested against the single-ray queries at each).

use fearless_simd::{Select, Simd, SimdBase, SimdMask, dispatch, f32x16, mask32x16, u32x16};
use glam::{Vec3, Vec3A};

use crate::bvh::{Bvh, Hit, PreparedRay};
use crate::leaf;
use crate::sphere::CULL_MARGIN;

/// Rays per packet: one AVX-512 register a coordinate (two AVX2, four SSE).
const WIDTH: usize = 16;

/// Fewest rays for which a packet is tested: a packet costs the same at
/// any fill, and below about half of its lanes (measured on the 36
/// triangles of cornell-mcguire: its bounces ran at 1.1 times the single
/// queries' rate in full packets) single queries are cheaper.
const MIN_FILL: usize = 8;

/// Most primitive slots of a scene whose batches run in packets: beyond,
/// testing every primitive costs more than a tree's traversal saves.
const MAX_SLOTS: usize = 64;

/// Each lane's index.
const LANE_INDEX: [u32; WIDTH] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 11, 12, 13, 14, 15];

/// No primitive: a lane's best slot before it hits.
const NONE: u32 = u32::MAX;

/// Whether a scene of `slots` primitive slots runs its batches in packets.
pub(crate) fn fits(slots: usize) -> bool {
    slots <= MAX_SLOTS
}

/// One ray of a batch query: `origin + t * direction` for `0 < t < t_max`,
/// not testing the triangles `skip` (caller ids, [`crate::NO_SURFACE`] for
/// none), as [`Bvh::intersect_leaving`] and [`Bvh::occluded_between`] take
/// them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BatchRay {
    /// Origin.
    pub origin: Vec3,
    /// Direction (any length; `t` is in its units).
    pub direction: Vec3,
    /// End of the ray (exclusive); may be infinite.
    pub t_max: f32,
    /// Triangles the ray starts and ends on.
    pub skip: [u32; 2],
}

impl Bvh {
    /// The closest hit of each ray of `rays` into `hits` (the same length):
    /// for each, what [`Bvh::intersect_leaving`] returns, skipping both
    /// `skip` triangles. Scenes of at most 64 primitives test the rays in
    /// packets (`packet.rs`); others answer one ray after the other.
    ///
    /// # Panics
    /// If `hits` and `rays` differ in length.
    pub fn intersect_batch(&self, rays: &[BatchRay], hits: &mut [Option<Hit>]) {
        assert_eq!(rays.len(), hits.len(), "one hit per ray");
        self.in_packets(
            rays,
            hits,
            |packet, hits| {
                let best = dispatch!(self.isa, simd => closest(simd, self, packet));
                self.finish_closest(rays, packet, best, hits);
            },
            |ray| self.intersect_skipping(ray.origin, ray.direction, ray.t_max, ray.skip),
        );
    }

    /// Whether each ray of `rays` is occluded, into `occluded` (the same
    /// length): for each, what [`Bvh::occluded_between`] returns for its
    /// `skip` triangles. In packets as [`Bvh::intersect_batch`].
    ///
    /// # Panics
    /// If `occluded` and `rays` differ in length.
    pub fn occluded_batch(&self, rays: &[BatchRay], occluded: &mut [bool]) {
        assert_eq!(rays.len(), occluded.len(), "one answer per ray");
        self.in_packets(
            rays,
            occluded,
            |packet, occluded| {
                let open = dispatch!(self.isa, simd => any(simd, self, packet));
                self.finish_any(rays, packet, open, occluded);
            },
            |ray| self.occluded_between(ray.origin, ray.direction, ray.t_max, ray.skip),
        );
    }

    /// The answers `out` to the queries `rays`: where the scene has
    /// packets, `packet` writes those of each packet of rays of one
    /// permutation class, as each fills up, then of the partly filled
    /// ones; `single` answers the other rays one by one (all of them in
    /// scenes without packets, those of packets left with fewer than
    /// [`MIN_FILL`] rays otherwise). Rays that cannot hit anything are
    /// answered by `T::default()`.
    fn in_packets<T: Default>(
        &self,
        rays: &[BatchRay],
        out: &mut [T],
        mut packet: impl FnMut(&Packet, &mut [T]),
        single: impl Fn(&BatchRay) -> T,
    ) {
        if !self.packets {
            for (ray, out) in rays.iter().zip(out) {
                *out = single(ray);
            }
            return;
        }
        out.fill_with(T::default);
        let mut packets: [Packet; CLASSES] = std::array::from_fn(|_| Packet::default());
        for (i, ray) in rays.iter().enumerate() {
            let Some(r) = self.prepare(ray.origin, ray.direction, ray.t_max) else {
                continue;
            };
            let open = &mut packets[class(&r)];
            open.push(i, ray, &r);
            if open.count == WIDTH {
                packet(open, out);
                open.count = 0;
            }
        }
        for open in &packets {
            if open.count >= MIN_FILL {
                packet(open, out);
            } else {
                for &i in &open.members[..open.count] {
                    out[i] = single(&rays[i]);
                }
            }
        }
    }

    /// The closest hits of `packet` after its triangle lanes' `best`: the
    /// triangles left to the scalar test and the spheres, ray by ray, then
    /// each ray's hit refined as [`Bvh::intersect`] refines it.
    fn finish_closest(
        &self,
        rays: &[BatchRay],
        packet: &Packet,
        mut best: Best,
        hits: &mut [Option<Hit>],
    ) {
        let scalar = best.scalar;
        for &(slot, lanes) in scalar.entries() {
            let triangle = &self.triangles[slot as usize];
            for j in bits(lanes) {
                let r = self.prepared(&rays[packet.members[j]]);
                if let Some((t, b1, b2)) = r.transform.intersect(triangle, best.t[j]) {
                    best.offer(j, slot, self.ids[slot as usize], (t, b1, b2));
                }
            }
        }
        for slot in self.sphere_slots() {
            for j in bits(sphere_candidates(self, packet, slot)) {
                let ray = &rays[packet.members[j]];
                let to_caller = packet.to_caller(j);
                if let Some(t) =
                    self.sphere_test(slot, to_caller, ray.origin, ray.direction, best.t[j])
                {
                    best.offer(j, slot as u32, self.ids[slot], (t, 0.0, 0.0));
                }
            }
        }
        for j in 0..packet.count {
            let slot = best.slot[j];
            if slot == NONE {
                continue;
            }
            let i = packet.members[j];
            let ray = &rays[i];
            let (to_unit, to_caller) = packet.to_caller(j);
            let t = best.t[j] * to_unit * to_caller;
            let slot = slot as usize;
            hits[i] = if self.ids[slot] as usize >= self.triangle_count {
                self.refine_sphere(slot, ray.origin, ray.direction, ray.t_max, t)
            } else {
                let (b1, b2) = (best.b1[j], best.b2[j]);
                self.refine(slot, ray.origin, ray.direction, ray.t_max, (t, b1, b2))
            };
        }
    }

    /// The occlusion of `packet`'s rays after its triangle lanes' answer
    /// `any`: the triangles left to the scalar test and the spheres, ray
    /// by ray for the rays not yet occluded.
    fn finish_any(&self, rays: &[BatchRay], packet: &Packet, any: Any, occluded: &mut [bool]) {
        let mut open = any.open;
        for &(slot, lanes) in any.scalar.entries() {
            let triangle = &self.triangles[slot as usize];
            for j in bits(lanes & open) {
                let r = self.prepared(&rays[packet.members[j]]);
                if r.transform
                    .intersect(triangle, r.t_max)
                    .is_some_and(|(t, ..)| t < r.t_max)
                {
                    open &= !(1 << j);
                }
            }
        }
        for slot in self.sphere_slots() {
            for j in bits(sphere_candidates(self, packet, slot) & open) {
                let ray = &rays[packet.members[j]];
                let t_max = packet.t_max[j];
                if self
                    .sphere_test(slot, packet.to_caller(j), ray.origin, ray.direction, t_max)
                    .is_some_and(|t| t < t_max)
                {
                    open &= !(1 << j);
                }
            }
        }
        for j in 0..packet.count {
            occluded[packet.members[j]] = open & (1 << j) == 0;
        }
    }

    /// `ray` prepared again (for the rare lanes that need the scalar
    /// triangle test: it was, to be in a packet).
    #[cold]
    fn prepared(&self, ray: &BatchRay) -> PreparedRay {
        self.prepare(ray.origin, ray.direction, ray.t_max)
            .expect("packets hold rays that prepare")
    }

    /// The slots that hold spheres.
    fn sphere_slots(&self) -> impl Iterator<Item = usize> + '_ {
        (0..self.ids.len()).filter(|&slot| self.ids[slot] as usize >= self.triangle_count)
    }
}

/// Permutation classes of rays (see [`class`]).
const CLASSES: usize = 6;

/// The permutation class of a prepared ray: its axis `kz` (the
/// direction's largest component) and whether `kx` and `ky` are swapped
/// (`kz` negative), 0 to 5.
fn class(r: &PreparedRay) -> usize {
    let [kx, _, kz] = r.transform.axes();
    2 * kz + usize::from(kx != (kz + 1) % 3)
}

/// Up to [`WIDTH`] rays of one permutation class, lane by lane (lanes
/// from `count` on are not in use, and are masked out).
#[derive(Default)]
struct Packet {
    /// Batch indices of the lanes' rays.
    members: [usize; WIDTH],
    /// Lanes in use.
    count: usize,
    /// The shared permutation `[kx, ky, kz]`.
    axes: [usize; 3],
    /// The origins' coordinates `kx`, `ky`, `kz`.
    origin: [[f32; WIDTH]; 3],
    /// The triangle test's scale (`RayTransform::shear`'s entry `(0, kx)`).
    scale: [f32; WIDTH],
    /// Column `kz` of the shear.
    shear: [[f32; WIDTH]; 3],
    /// The directions' coordinates `kx`, `ky`, `kz` (sphere culling).
    direction: [[f32; WIDTH]; 3],
    /// The query's end in the triangle test's units.
    t_max: [f32; WIDTH],
    /// The triangles each ray does not test.
    skip: [[u32; WIDTH]; 2],
    /// The prepared rays' scalings to the caller's `t` (`PreparedRay::to_caller`).
    to_caller: [[f32; WIDTH]; 2],
}

impl Packet {
    /// Adds ray `i` of the batch, `ray`, prepared as `r`, in the next lane.
    #[inline(always)]
    fn push(&mut self, i: usize, ray: &BatchRay, r: &PreparedRay) {
        let j = self.count;
        self.axes = r.transform.axes();
        let [kx, ky, kz] = self.axes;
        let o = r.transform.origin();
        let m = r.transform.shear();
        let column = m.col(kz);
        for (k, axis) in [kx, ky, kz].into_iter().enumerate() {
            self.origin[k][j] = o[axis];
            self.shear[k][j] = column[k];
            self.direction[k][j] = ray.direction[axis];
        }
        self.scale[j] = m.col(kx).x;
        self.t_max[j] = r.t_max;
        self.skip[0][j] = ray.skip[0];
        self.skip[1][j] = ray.skip[1];
        self.to_caller[0][j] = r.to_caller.0;
        self.to_caller[1][j] = r.to_caller.1;
        self.members[j] = i;
        self.count += 1;
    }

    /// Lane `j`'s `PreparedRay::to_caller`.
    fn to_caller(&self, j: usize) -> (f32, f32) {
        (self.to_caller[0][j], self.to_caller[1][j])
    }

    /// Bit `j` for each lane in use.
    fn used(&self) -> u32 {
        ((1u64 << self.count) - 1) as u32
    }
}

/// The lane indices of the set bits of `mask`, lowest first.
fn bits(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let j = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            j
        })
    })
}

/// Triangles whose lanes need the scalar test (an edge function of
/// exactly zero), at most one entry per triangle.
#[derive(Clone, Copy)]
struct ScalarLanes {
    /// `(slot, lanes)`: the triangle's slot and its lanes' bits.
    entries: [(u32, u32); MAX_SLOTS],
    count: usize,
}

impl ScalarLanes {
    fn new() -> Self {
        Self {
            entries: [(0, 0); MAX_SLOTS],
            count: 0,
        }
    }

    /// Notes the `lanes` (bits) of the triangle in `slot`, if any.
    #[inline(always)]
    fn note(&mut self, slot: usize, lanes: u32) {
        if lanes != 0 {
            self.entries[self.count] = (slot as u32, lanes);
            self.count += 1;
        }
    }

    /// The noted `(slot, lanes)`.
    fn entries(&self) -> &[(u32, u32)] {
        &self.entries[..self.count]
    }
}

/// The triangles of `bvh`'s slots: `(slot, corners, id)`.
fn triangles(bvh: &Bvh) -> impl Iterator<Item = (usize, &[Vec3A; 3], u32)> {
    let ids = bvh.ids.iter().copied();
    (bvh.triangles.iter().zip(ids).enumerate())
        .filter(|&(_, (_, id))| (id as usize) < bvh.triangle_count)
        .map(|(slot, (v, id))| (slot, v, id))
}

/// Each lane's closest hit so far (the triangle test's units).
struct Best {
    t: [f32; WIDTH],
    b1: [f32; WIDTH],
    b2: [f32; WIDTH],
    /// Its primitive's id (0 before a hit: no id is lower, so a hit at
    /// the query's own end loses, as in [`Bvh::intersect`]).
    id: [u32; WIDTH],
    /// Its slot, [`NONE`] before a hit.
    slot: [u32; WIDTH],
    scalar: ScalarLanes,
}

impl Best {
    /// Lane `j`'s hit `(t, b1, b2)` on primitive `id` in `slot`, at `t` no
    /// farther than its best: taken by [`Bvh::intersect`]'s rule.
    fn offer(&mut self, j: usize, slot: u32, id: u32, (t, b1, b2): (f32, f32, f32)) {
        if t < self.t[j] || id < self.id[j] {
            (self.t[j], self.b1[j], self.b2[j]) = (t, b1, b2);
            (self.id[j], self.slot[j]) = (id, slot);
        }
    }
}

/// Which lanes are still unoccluded (bit `j` for lane `j`), and the
/// triangles left to the scalar test.
struct Any {
    open: u32,
    scalar: ScalarLanes,
}

/// One triangle's test in every lane of a packet, up to the division.
struct Edges<S: Simd> {
    /// Lanes inside the triangle's edges, in use, not skipping it, and
    /// not left to the scalar test.
    candidates: mask32x16<S>,
    /// Bit `j`: lane `j` needs the scalar test (an edge function is zero).
    scalar: u32,
    e: [f32x16<S>; 3],
    /// The transformed corners' z.
    z: [f32x16<S>; 3],
}

/// The packet's rays, splatted per lane.
struct Lanes<S: Simd> {
    axes: [usize; 3],
    origin: [f32x16<S>; 3],
    scale: f32x16<S>,
    shear: [f32x16<S>; 3],
    skip: [u32x16<S>; 2],
    used: mask32x16<S>,
    used_bits: u32,
}

impl<S: Simd> Lanes<S> {
    #[inline(always)]
    fn new(simd: S, p: &Packet) -> Self {
        let lane = u32x16::from_slice(simd, &LANE_INDEX);
        Self {
            axes: p.axes,
            origin: [
                f32x16::from_slice(simd, &p.origin[0]),
                f32x16::from_slice(simd, &p.origin[1]),
                f32x16::from_slice(simd, &p.origin[2]),
            ],
            scale: f32x16::from_slice(simd, &p.scale),
            shear: [
                f32x16::from_slice(simd, &p.shear[0]),
                f32x16::from_slice(simd, &p.shear[1]),
                f32x16::from_slice(simd, &p.shear[2]),
            ],
            skip: [
                u32x16::from_slice(simd, &p.skip[0]),
                u32x16::from_slice(simd, &p.skip[1]),
            ],
            used: lane.simd_lt(u32x16::splat(simd, p.count as u32)),
            used_bits: p.used(),
        }
    }

    /// `shear * (v - origin)` in every lane (`leaf::sheared`).
    #[inline(always)]
    fn transform(&self, simd: S, v: Vec3A) -> [f32x16<S>; 3] {
        let [kx, ky, kz] = self.axes;
        let p = [
            f32x16::splat(simd, v[kx]),
            f32x16::splat(simd, v[ky]),
            f32x16::splat(simd, v[kz]),
        ];
        leaf::sheared(p, &self.origin, self.scale, &self.shear)
    }

    /// The edge functions of triangle `v` (caller id `id`), `leaf.rs`'s
    /// `intersect` up to the division.
    #[inline(always)]
    fn edges(&self, simd: S, v: &[Vec3A; 3], id: u32) -> Edges<S> {
        let a = self.transform(simd, v[0]);
        let b = self.transform(simd, v[1]);
        let c = self.transform(simd, v[2]);
        let [e0, e1, e2] = leaf::edge_functions([a, b, c]);
        let zero = f32x16::splat(simd, 0.0);
        let id = u32x16::splat(simd, id);
        let tested = self.used & !(self.skip[0].simd_eq(id) | self.skip[1].simd_eq(id));
        let zero_edge = e0.simd_eq(zero) | e1.simd_eq(zero) | e2.simd_eq(zero);
        let negative = e0.simd_lt(zero) | e1.simd_lt(zero) | e2.simd_lt(zero);
        let positive = e0.simd_gt(zero) | e1.simd_gt(zero) | e2.simd_gt(zero);
        Edges {
            candidates: tested & !zero_edge & !(negative & positive),
            scalar: (tested & zero_edge).to_bitmask() as u32,
            e: [e0, e1, e2],
            z: [a[2], b[2], c[2]],
        }
    }
}

impl<S: Simd> Edges<S> {
    /// `(det, t, b1, b2)` as `leaf.rs` computes them.
    #[inline(always)]
    fn hit(&self, simd: S) -> (f32x16<S>, f32x16<S>, f32x16<S>, f32x16<S>) {
        leaf::distance(simd, self.e, self.z)
    }
}

/// The closest triangle hit of each lane of `p` (spheres and the scalar
/// test's triangles are left to [`Bvh::finish_closest`]).
#[inline(always)]
fn closest<S: Simd>(simd: S, bvh: &Bvh, p: &Packet) -> Best {
    let lanes = Lanes::new(simd, p);
    let zero = f32x16::splat(simd, 0.0);
    let mut t_best = f32x16::from_slice(simd, &p.t_max);
    let mut b1_best = zero;
    let mut b2_best = zero;
    let mut id_best = u32x16::splat(simd, 0);
    let mut slot_best = u32x16::splat(simd, NONE);
    let mut scalar = ScalarLanes::new();
    for (slot, v, id) in triangles(bvh) {
        let edges = lanes.edges(simd, v, id);
        scalar.note(slot, edges.scalar);
        if edges.candidates.to_bitmask() == 0 {
            continue;
        }
        let (det, t, b1, b2) = edges.hit(simd);
        let id = u32x16::splat(simd, id);
        let wins = t.simd_lt(t_best) | id.simd_lt(id_best);
        let valid =
            edges.candidates & !det.simd_eq(zero) & t.simd_gt(zero) & t.simd_le(t_best) & wins;
        t_best = valid.select(t, t_best);
        b1_best = valid.select(b1, b1_best);
        b2_best = valid.select(b2, b2_best);
        id_best = valid.select(id, id_best);
        slot_best = valid.select(u32x16::splat(simd, slot as u32), slot_best);
    }
    Best {
        t: t_best.into(),
        b1: b1_best.into(),
        b2: b2_best.into(),
        id: id_best.into(),
        slot: slot_best.into(),
        scalar,
    }
}

/// Which lanes of `p` no triangle occludes (spheres and the scalar test's
/// triangles are left to [`Bvh::finish_any`]); stops when every lane is.
#[inline(always)]
fn any<S: Simd>(simd: S, bvh: &Bvh, p: &Packet) -> Any {
    let lanes = Lanes::new(simd, p);
    let zero = f32x16::splat(simd, 0.0);
    let t_max = f32x16::from_slice(simd, &p.t_max);
    let mut open = lanes.used;
    let mut scalar = ScalarLanes::new();
    for (slot, v, id) in triangles(bvh) {
        let edges = lanes.edges(simd, v, id);
        scalar.note(slot, edges.scalar);
        let candidates = edges.candidates & open;
        if candidates.to_bitmask() == 0 {
            continue;
        }
        let (det, t, _, _) = edges.hit(simd);
        // The test takes t_max inclusively; an occluder must be before it.
        let occludes = candidates & !det.simd_eq(zero) & t.simd_gt(zero) & t.simd_lt(t_max);
        open &= !occludes;
        if open.to_bitmask() == 0 {
            break;
        }
    }
    Any {
        open: open.to_bitmask() as u32 & lanes.used_bits,
        scalar,
    }
}

/// The lanes of `p` that may hit the sphere in `slot`: in use, and not
/// culled by the f32 test of [`CULL_MARGIN`].
fn sphere_candidates(bvh: &Bvh, p: &Packet, slot: usize) -> u32 {
    let sphere = bvh.spheres[bvh.ids[slot] as usize - bvh.triangle_count];
    let used = p.used();
    used & dispatch!(bvh.isa, simd => may_hit(simd, p, sphere.center, sphere.radius))
}

/// Bit `j`: lane `j`'s ray may hit the sphere (`center`, `r`) by the f32
/// test of [`CULL_MARGIN`]. Conservative on every instruction set: the
/// sphere's own test decides each lane it keeps, so the hits do not depend
/// on it. NaN compares false: such a lane is kept.
#[inline(always)]
fn may_hit<S: Simd>(simd: S, p: &Packet, center: Vec3, r: f32) -> u32 {
    // No closures here: one is compiled out of line, without the
    // instruction set's target features (`leaf.rs`).
    let [kx, ky, kz] = p.axes;
    let fx = f32x16::from_slice(simd, &p.origin[0]) - f32x16::splat(simd, center[kx]);
    let fy = f32x16::from_slice(simd, &p.origin[1]) - f32x16::splat(simd, center[ky]);
    let fz = f32x16::from_slice(simd, &p.origin[2]) - f32x16::splat(simd, center[kz]);
    let dx = f32x16::from_slice(simd, &p.direction[0]);
    let dy = f32x16::from_slice(simd, &p.direction[1]);
    let dz = f32x16::from_slice(simd, &p.direction[2]);
    let cx = fy * dz - fz * dy;
    let cy = fz * dx - fx * dz;
    let cz = fx * dy - fy * dx;
    let margin = f32x16::splat(simd, CULL_MARGIN);
    let r = f32x16::splat(simd, r);
    let f_l1 = fx.abs() + fy.abs() + fz.abs();
    let d_l1 = dx.abs() + dy.abs() + dz.abs();
    let d2 = dx * dx + dy * dy + dz * dz;
    let reach = r + margin * (f_l1 + r);
    let misses_line = (cx * cx + cy * cy + cz * cz).simd_gt(d2 * (reach * reach));
    let moves_away = (fx * dx + fy * dy + fz * dz).simd_gt(margin * f_l1 * d_l1);
    let outside =
        (fx * fx + fy * fy + fz * fz).simd_gt(r * r * (f32x16::splat(simd, 1.0) + margin));
    (!(misses_line | (moves_away & outside))).to_bitmask() as u32
}
