//! The path tracer's work at Lambertian vertices in 16 SIMD lanes: a
//! batch of [`LANES`] vertices in structure-of-arrays form, computed as
//! 16-lane vectors (`fearless_simd`, on the instruction set `accel` chose
//! at run time): next-event estimation towards points on emissive
//! triangles and point lights ([`NeeLanes`]: direction, density,
//! radiance, f |cos|, BSDF density) and
//! the BSDF sample ([`StepLanes`]: direction, weight, density). One
//! vertex's chain of square roots and divisions, alone, was what limited
//! the scalar loop (docs/benchmarks.md, "Where the time goes"); here
//! sixteen share each instruction.
//!
//! **The scalar code's results, bit for bit.** Each lane makes the float
//! operations of the scalar functions, in the same order (glam's `dot` is
//! `(x x') + (y y') + (z z')`, its `try_normalize` a multiplication by
//! `1 / sqrt`), with the same comparisons: for [`NeeLanes`],
//! [`Lights::sample_chosen`](crate::lights::Lights::sample_chosen) (an
//! area light's branch with `area_pdf_w`, a point light's), [`PathVertex::eval`] and
//! [`PathVertex::mis_pdf`] of a Lambertian lobe in radiance mode; for
//! [`StepLanes`], `Lambertian::sample` (its azimuth's sine and cosine
//! by `microfacet::frame::sin_cos_turns`, whose polynomials make them
//! in lanes too) and [`PathVertex::sample`]. Only IEEE operations, no fused
//! multiply-add: every instruction set gives the same bits (tested here),
//! and the path tracer's wavefront-against-scalar byte-identity test
//! covers every bundled scene, Lambertian surfaces and triangle lights
//! included. Keep the two in step.

use std::f32::consts::{FRAC_1_PI, FRAC_PI_2};

use fearless_simd::{Level, Select, Simd, SimdBase, SimdFloat, SimdMask, dispatch, f32x16};
use glam::{Vec2, Vec3};

use crate::lights::PointTarget;
use crate::vertex::PathVertex;

/// Vertices per batch: two AVX-512 registers of f32, four AVX2 or eight
/// SSE ones (the build's baseline).
pub(super) const LANES: usize = 16;

/// The light point `target` chosen for scattering vertex `vertex` (its
/// index in the wavefront's scattering queue), whose Lambertian lobe has
/// `reflectance`.
#[derive(Clone, Copy, Debug)]
pub(super) struct TargetSample {
    pub vertex: usize,
    pub reflectance: Vec3,
    pub target: PointTarget,
}

/// One light sample's values, where it is valid.
#[derive(Clone, Copy, Debug)]
pub(super) struct LaneSample {
    /// Unit direction from the vertex to the light point.
    pub wi: Vec3,
    /// Density in solid angle, selection included (a point light's
    /// selection probability).
    pub pdf: f32,
    /// Incident radiance (a point light's intensity over the squared
    /// distance).
    pub li: Vec3,
    /// f |cos| at the vertex towards `wi`.
    pub f: Vec3,
    /// The vertex's BSDF density for `wi` (MIS).
    pub bsdf_pdf: f32,
}

/// A batch's inputs and outputs, coordinate by coordinate (`x[axis][lane]`).
/// Unused lanes hold zeros: a zero distance, which makes them invalid.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct NeeLanes {
    /// The receivers.
    vertices: VertexLanes,
    /// The light points, their normals, emission, densities
    /// ([`PointTarget`]), and 1 for point lights, 0 for triangles.
    light_p: [[f32; LANES]; 3],
    light_n: [[f32; LANES]; 3],
    emitted: [[f32; LANES]; 3],
    target_pdf: [f32; LANES],
    delta: [f32; LANES],
    // Results.
    wi: [[f32; LANES]; 3],
    pdf: [f32; LANES],
    li: [[f32; LANES]; 3],
    f: [[f32; LANES]; 3],
    bsdf_pdf: [f32; LANES],
    /// Bit `j`: lane `j`'s sample is valid.
    valid: u32,
}

impl NeeLanes {
    /// Lane `j` takes the vertex `vertex` and the light point `sample`.
    #[inline(always)]
    pub fn set(&mut self, j: usize, vertex: &PathVertex, sample: &TargetSample) {
        self.vertices.set(j, vertex, sample.reflectance);
        let target = &sample.target;
        set3(&mut self.light_p, j, target.point.p);
        set3(&mut self.light_n, j, target.point.n);
        set3(&mut self.emitted, j, target.emitted);
        self.target_pdf[j] = target.pdf;
        self.delta[j] = if target.delta { 1.0 } else { 0.0 };
    }

    /// Lane `j` unused: a zero distance, for which the sample is `None`.
    pub fn clear(&mut self, j: usize) {
        set3(&mut self.vertices.p, j, Vec3::ZERO);
        set3(&mut self.light_p, j, Vec3::ZERO);
    }

    /// Every lane's light sample (see the module documentation): what
    /// `Lights::sample_chosen` and `nee::light_value` compute, `None` in
    /// lane `j` ([`NeeLanes::sample`]) where either returns `None`; on the
    /// instruction set `level`, with the same results on every one.
    pub fn run(&mut self, level: Level) {
        dispatch!(level, simd => self.run_on(simd));
    }

    #[inline(always)]
    fn run_on<S: Simd>(&mut self, simd: S) {
        // No closures here: one is compiled out of line, without the
        // instruction set's target features (accel's `leaf.rs` measured
        // its SIMD operations as calls, 2-4 times slower).
        type V<S> = f32x16<S>;
        let vertices = &self.vertices;
        let p = load3(simd, &vertices.p);
        let light_p = load3(simd, &self.light_p);
        let light_n = load3(simd, &self.light_n);
        let zero = V::splat(simd, 0.0);
        let one = V::splat(simd, 1.0);
        let inv_pi = V::splat(simd, FRAC_1_PI);
        let delta = V::from_slice(simd, &self.delta).simd_gt(zero);
        let target_pdf = V::from_slice(simd, &self.target_pdf);
        let emitted = load3(simd, &self.emitted);
        // sample_chosen: the direction (try_normalize) and, on a triangle,
        // the facing test.
        let d = [light_p[0] - p[0], light_p[1] - p[1], light_p[2] - p[2]];
        let dist2 = dot(d, d);
        let rcp = one / dist2.sqrt();
        let wi = [d[0] * rcp, d[1] * rcp, d[2] * rcp];
        let facing = dot(light_n, [-wi[0], -wi[1], -wi[2]]);
        // A triangle's area_pdf_w; a point light's selection probability.
        let cos = (dot(light_n, d) / dist2.sqrt()).abs();
        let pdf = target_pdf * dist2 / cos;
        let pdf = delta.select(target_pdf, pdf.is_finite().select(pdf, zero));
        let li = [
            delta.select(emitted[0] / dist2, emitted[0]),
            delta.select(emitted[1] / dist2, emitted[1]),
            delta.select(emitted[2] / dist2, emitted[2]),
        ];
        // PathVertex::eval and mis_pdf of a Lambertian lobe.
        let consistent = (dot(load3(simd, &vertices.ng), wi)
            * V::from_slice(simd, &vertices.ng_wi))
        .simd_gt(zero);
        let wo_z = dot(wi, load3(simd, &vertices.n));
        let same_hemisphere = (V::from_slice(simd, &vertices.wi_z) * wo_z).simd_gt(zero);
        let cos_o = wo_z.abs();
        let r = load3(simd, &vertices.reflectance);
        let f = [
            same_hemisphere.select(r[0] * inv_pi, zero) * cos_o,
            same_hemisphere.select(r[1] * inv_pi, zero) * cos_o,
            same_hemisphere.select(r[2] * inv_pi, zero) * cos_o,
        ];
        let bsdf_pdf = same_hemisphere.select(cos_o * inv_pi, zero);
        let valid = rcp.is_finite()
            & rcp.simd_gt(zero)
            & (delta | !facing.simd_le(zero))
            & pdf.simd_gt(zero)
            & (li[0].simd_gt(zero) | li[1].simd_gt(zero) | li[2].simd_gt(zero))
            & consistent
            & (f[0].simd_gt(zero) | f[1].simd_gt(zero) | f[2].simd_gt(zero));
        for axis in 0..3 {
            wi[axis].store_slice(&mut self.wi[axis]);
            li[axis].store_slice(&mut self.li[axis]);
            f[axis].store_slice(&mut self.f[axis]);
        }
        pdf.store_slice(&mut self.pdf);
        bsdf_pdf.store_slice(&mut self.bsdf_pdf);
        self.valid = valid.to_bitmask() as u32;
    }

    /// Lane `j`'s light sample after [`NeeLanes::run`], if valid.
    #[inline(always)]
    pub fn sample(&self, j: usize) -> Option<LaneSample> {
        let v = |c: &[[f32; LANES]; 3]| Vec3::new(c[0][j], c[1][j], c[2][j]);
        (self.valid & (1 << j) != 0).then(|| LaneSample {
            wi: v(&self.wi),
            pdf: self.pdf[j],
            li: v(&self.li),
            f: v(&self.f),
            bsdf_pdf: self.bsdf_pdf[j],
        })
    }
}

/// One BSDF sample's values, where it is valid.
#[derive(Clone, Copy, Debug)]
pub(super) struct LaneStep {
    /// Unit world direction.
    pub wo: Vec3,
    /// f |cos| / pdf.
    pub weight: Vec3,
    /// Its density in solid angle (and the MIS density: a Lambertian lobe
    /// is never regularized).
    pub pdf: f32,
}

/// BSDF samples of a batch of Lambertian vertices in radiance mode
/// ([`Lambertian::sample`](microfacet::Lambertian::sample) and
/// [`PathVertex::sample`]: the same operations, as [`NeeLanes`] makes
/// them), coordinate by coordinate. Unused lanes have `wi.z` 0, for which
/// the sample is `None`.
#[derive(Clone, Copy, Debug, Default)]
pub(super) struct StepLanes {
    /// The vertices, and their frames' tangents.
    vertices: VertexLanes,
    s: [[f32; LANES]; 3],
    t: [[f32; LANES]; 3],
    /// The two sample numbers: the radius's and the azimuth's (in turns).
    u: [f32; LANES],
    u_phi: [f32; LANES],
    // Results.
    wo: [[f32; LANES]; 3],
    weight: [[f32; LANES]; 3],
    pdf: [f32; LANES],
    /// Bit `j`: lane `j`'s sample is valid.
    valid: u32,
}

impl StepLanes {
    /// Lane `j` takes the vertex `vertex`, whose Lambertian lobe has
    /// `reflectance`, and the sample numbers `u`.
    #[inline(always)]
    pub fn set(&mut self, j: usize, vertex: &PathVertex, reflectance: Vec3, u: Vec2) {
        self.vertices.set(j, vertex, reflectance);
        set3(&mut self.s, j, vertex.frame.s);
        set3(&mut self.t, j, vertex.frame.t);
        (self.u[j], self.u_phi[j]) = (u.x, u.y);
    }

    /// Lane `j` unused: `wi.z` 0, for which the sample is `None`.
    pub fn clear(&mut self, j: usize) {
        self.vertices.wi_z[j] = 0.0;
    }

    /// Every lane's sample, on the instruction set `level` (the same
    /// results on every one).
    pub fn run(&mut self, level: Level) {
        dispatch!(level, simd => self.run_on(simd));
    }

    #[inline(always)]
    fn run_on<S: Simd>(&mut self, simd: S) {
        type V<S> = f32x16<S>;
        let zero = V::splat(simd, 0.0);
        let one = V::splat(simd, 1.0);
        let inv_pi = V::splat(simd, FRAC_1_PI);
        let vertices = &self.vertices;
        let wi_z = V::from_slice(simd, &vertices.wi_z);
        let u = V::from_slice(simd, &self.u);
        // Lambertian::sample.
        let r = u.sqrt();
        let (sin_phi, cos_phi) = sin_cos_turns(simd, V::from_slice(simd, &self.u_phi));
        let z = (one - u).max_precise(zero).sqrt();
        let wo_local = [r * cos_phi, r * sin_phi, z.copysign(wi_z)];
        let reflectance = load3(simd, &vertices.reflectance);
        let pdf = z * inv_pi;
        // PathVertex::sample: Frame::to_world, the consistency test, the weight.
        let (s, t, n) = (
            load3(simd, &self.s),
            load3(simd, &self.t),
            load3(simd, &vertices.n),
        );
        let [x, y, z_local] = wo_local;
        let wo = [
            s[0] * x + t[0] * y + n[0] * z_local,
            s[1] * x + t[1] * y + n[1] * z_local,
            s[2] * x + t[2] * y + n[2] * z_local,
        ];
        let consistent = (dot(load3(simd, &vertices.ng), wo)
            * V::from_slice(simd, &vertices.ng_wi))
        .simd_gt(zero);
        let q = z_local.abs() / pdf;
        let weight = [
            reflectance[0] * inv_pi * q,
            reflectance[1] * inv_pi * q,
            reflectance[2] * inv_pi * q,
        ];
        let valid = !wi_z.simd_eq(zero)
            & !z.simd_eq(zero)
            & consistent
            & pdf.simd_gt(zero)
            & weight[0].is_finite()
            & weight[1].is_finite()
            & weight[2].is_finite()
            & (weight[0].simd_gt(zero) | weight[1].simd_gt(zero) | weight[2].simd_gt(zero));
        for axis in 0..3 {
            wo[axis].store_slice(&mut self.wo[axis]);
            weight[axis].store_slice(&mut self.weight[axis]);
        }
        pdf.store_slice(&mut self.pdf);
        self.valid = valid.to_bitmask() as u32;
    }

    /// Lane `j`'s sample after [`StepLanes::run`], if valid.
    #[inline(always)]
    pub fn sample(&self, j: usize) -> Option<LaneStep> {
        let v = |c: &[[f32; LANES]; 3]| Vec3::new(c[0][j], c[1][j], c[2][j]);
        (self.valid & (1 << j) != 0).then(|| LaneStep {
            wo: v(&self.wo),
            weight: v(&self.weight),
            pdf: self.pdf[j],
        })
    }
}

/// The Lambertian vertices of a batch, coordinate by coordinate: what both
/// kernels read of them.
#[derive(Clone, Copy, Debug, Default)]
struct VertexLanes {
    /// Positions, geometric normals, shading normals, reflectances.
    p: [[f32; LANES]; 3],
    ng: [[f32; LANES]; 3],
    n: [[f32; LANES]; 3],
    reflectance: [[f32; LANES]; 3],
    /// `ng . wi` and `wi.z` in the frame, of each vertex's `wi`.
    ng_wi: [f32; LANES],
    wi_z: [f32; LANES],
}

impl VertexLanes {
    /// Lane `j` takes `vertex`, whose Lambertian lobe has `reflectance`.
    #[inline(always)]
    fn set(&mut self, j: usize, vertex: &PathVertex, reflectance: Vec3) {
        set3(&mut self.p, j, vertex.point.p);
        set3(&mut self.ng, j, vertex.point.ng);
        set3(&mut self.n, j, vertex.frame.n);
        set3(&mut self.reflectance, j, reflectance);
        self.ng_wi[j] = vertex.point.ng.dot(vertex.wi);
        self.wi_z[j] = vertex.wi_local().z;
    }
}

/// Lane `j` of a batch's coordinates takes `v`.
#[inline(always)]
fn set3(c: &mut [[f32; LANES]; 3], j: usize, v: Vec3) {
    (c[0][j], c[1][j], c[2][j]) = (v.x, v.y, v.z);
}

/// The three coordinates of a batch.
#[inline(always)]
fn load3<S: Simd>(simd: S, c: &[[f32; LANES]; 3]) -> [f32x16<S>; 3] {
    [
        f32x16::from_slice(simd, &c[0]),
        f32x16::from_slice(simd, &c[1]),
        f32x16::from_slice(simd, &c[2]),
    ]
}

/// [`microfacet::frame::sin_cos_turns`], lane by lane: (sin 2 pi u,
/// cos 2 pi u) by the same exact reduction, polynomials and quadrant.
#[inline(always)]
fn sin_cos_turns<S: Simd>(simd: S, u: f32x16<S>) -> (f32x16<S>, f32x16<S>) {
    let [s0, s1, s2] = microfacet::frame::SIN_POLYNOMIAL;
    let [c0, c1, c2] = microfacet::frame::COS_POLYNOMIAL;
    let splat = |c: f32| f32x16::splat(simd, c);
    let t = splat(4.0) * u;
    let n = t.round_ties_even();
    let x = (t - n) * splat(FRAC_PI_2);
    let x2 = x * x;
    let sin = x + x * x2 * ((splat(s0) * x2 + splat(s1)) * x2 + splat(s2));
    let cos =
        (splat(1.0) - splat(0.5) * x2) + x2 * x2 * ((splat(c0) * x2 + splat(c1)) * x2 + splat(c2));
    // sin and cos of n pi/2 + x, n in 0..=4.
    let (n1, n2, n3) = (
        n.simd_eq(splat(1.0)),
        n.simd_eq(splat(2.0)),
        n.simd_eq(splat(3.0)),
    );
    let swap = n1 | n3;
    let (sin, cos) = (swap.select(cos, sin), swap.select(sin, cos));
    ((n2 | n3).select(-sin, sin), (n1 | n2).select(-cos, cos))
}

/// glam's `dot`, lane by lane: `(a.x b.x + a.y b.y) + a.z b.z`.
#[inline(always)]
fn dot<S: Simd>(a: [f32x16<S>; 3], b: [f32x16<S>; 3]) -> f32x16<S> {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[cfg(test)]
mod tests {
    use super::*;
    use stats::Pcg32;

    /// Every instruction set this CPU has (as `accel::Isa` chooses them).
    fn levels() -> Vec<Level> {
        let best = Level::new();
        let mut levels = vec![best];
        #[cfg(any(target_arch = "x86", target_arch = "x86_64"))]
        {
            levels.extend(best.as_sse4_2().map(Level::Sse4_2));
            levels.extend(best.as_avx2().map(Level::Avx2));
            levels.extend(best.as_avx512().map(Level::Avx512));
        }
        levels
    }

    /// A batch of random receivers and light points (a quarter of them
    /// point lights), with the cases that end a sample: a light point at
    /// the receiver, a triangle seen from behind, a direction below the
    /// surface or against its geometric normal, no emission.
    fn random_batch(rng: &mut Pcg32) -> NeeLanes {
        let mut lanes = NeeLanes::default();
        let mut v = |scale: f32| rng.uniform_f32() * 2.0 * scale - scale;
        for j in 0..LANES {
            for axis in 0..3 {
                lanes.vertices.p[axis][j] = v(3.0);
                lanes.vertices.ng[axis][j] = v(1.0);
                lanes.vertices.n[axis][j] = v(1.0);
                lanes.vertices.reflectance[axis][j] = v(1.0).abs();
                lanes.light_p[axis][j] = v(3.0);
                lanes.light_n[axis][j] = v(1.0);
                lanes.emitted[axis][j] = v(4.0).abs();
            }
            lanes.vertices.ng_wi[j] = v(1.0);
            lanes.vertices.wi_z[j] = v(1.0);
            lanes.target_pdf[j] = v(2.0).abs();
            if j % 4 == 3 {
                lanes.delta[j] = 1.0;
                lanes.light_n.iter_mut().for_each(|c| c[j] = 0.0);
            }
        }
        for axis in 0..3 {
            lanes.light_p[axis][0] = lanes.vertices.p[axis][0];
            lanes.emitted[axis][2] = 0.0;
        }
        lanes.target_pdf[1] = 0.0;
        lanes
    }

    /// The kernel's results, as bits.
    fn bits(lanes: &NeeLanes) -> Vec<u32> {
        let mut out = vec![lanes.valid];
        for c in [&lanes.wi, &lanes.li, &lanes.f] {
            out.extend(c.iter().flatten().map(|x| x.to_bits()));
        }
        out.extend(lanes.pdf.iter().chain(&lanes.bsdf_pdf).map(|x| x.to_bits()));
        out
    }

    /// The same bits on every instruction set (the rule of
    /// docs/benchmarks.md: an image must not depend on the CPU's choice),
    /// and both valid and invalid lanes among them.
    #[test]
    fn every_instruction_set_gives_the_same_light_samples() {
        let mut rng = Pcg32::new(11, 5);
        let mut valid = 0;
        for _ in 0..200 {
            let batch = random_batch(&mut rng);
            let mut expected = None;
            for level in levels() {
                let mut lanes = batch;
                lanes.run(level);
                let b = bits(&lanes);
                valid += (expected.is_none()) as u32 * lanes.valid.count_ones();
                assert_eq!(*expected.get_or_insert(b.clone()), b, "{level:?}");
            }
        }
        let total = 200 * LANES as u32;
        assert!(
            valid > total / 20 && valid < total / 2,
            "{valid} of {total} valid"
        );
    }

    /// A batch of random vertices and sample numbers, with the cases that
    /// end a sample: `wi` in the surface, a direction against the
    /// geometric normal, `u` = 1 (a grazing direction).
    fn random_steps(rng: &mut Pcg32) -> StepLanes {
        let mut lanes = StepLanes::default();
        let mut v = |scale: f32| rng.uniform_f32() * 2.0 * scale - scale;
        for j in 0..LANES {
            for axis in 0..3 {
                lanes.s[axis][j] = v(1.0);
                lanes.t[axis][j] = v(1.0);
                lanes.vertices.n[axis][j] = v(1.0);
                lanes.vertices.ng[axis][j] = v(1.0);
                lanes.vertices.reflectance[axis][j] = v(1.0).abs();
            }
            lanes.vertices.ng_wi[j] = v(1.0);
            lanes.vertices.wi_z[j] = v(1.0);
            lanes.u[j] = v(1.0).abs();
            lanes.u_phi[j] = v(1.0).abs();
        }
        lanes.clear(0);
        lanes.u[1] = 1.0;
        lanes
    }

    #[test]
    fn every_instruction_set_gives_the_same_bsdf_samples() {
        let mut rng = Pcg32::new(13, 7);
        let mut valid = 0;
        for _ in 0..200 {
            let batch = random_steps(&mut rng);
            let mut expected = None;
            for level in levels() {
                let mut lanes = batch;
                lanes.run(level);
                let mut b = vec![lanes.valid];
                for c in [&lanes.wo, &lanes.weight] {
                    b.extend(c.iter().flatten().map(|x| x.to_bits()));
                }
                b.extend(lanes.pdf.iter().map(|x| x.to_bits()));
                valid += (expected.is_none()) as u32 * lanes.valid.count_ones();
                assert_eq!(*expected.get_or_insert(b.clone()), b, "{level:?}");
            }
        }
        let total = 200 * LANES as u32;
        assert!(
            valid > total / 10 && valid < total * 3 / 4,
            "{valid} of {total} valid"
        );
    }

    /// The lanes' sine and cosine of an azimuth are the scalar function's
    /// bits (`microfacet::frame::sin_cos_turns`, which `Lambertian::sample`
    /// uses), at every instruction set, across the quadrants' boundaries too.
    #[test]
    fn azimuths_in_lanes_are_the_scalar_ones() {
        let mut rng = Pcg32::new(5, 3);
        let mut us: Vec<f32> = (0..4096).map(|_| rng.uniform_f32()).collect();
        for q in [0.0f32, 0.125, 0.25, 0.375, 0.5, 0.625, 0.75, 0.875, 1.0] {
            us.extend(
                [q.next_down(), q, q.next_up()]
                    .into_iter()
                    .filter(|u| (0.0..=1.0).contains(u)),
            );
        }
        for level in levels() {
            for chunk in us.chunks(LANES) {
                let mut u = [0.5; LANES];
                u[..chunk.len()].copy_from_slice(chunk);
                let (mut sin, mut cos) = ([0.0; LANES], [0.0; LANES]);
                dispatch!(level, simd => {
                    let (s, c) = sin_cos_turns(simd, f32x16::from_slice(simd, &u));
                    s.store_slice(&mut sin);
                    c.store_slice(&mut cos);
                });
                for (j, &u) in chunk.iter().enumerate() {
                    let (s, c) = microfacet::frame::sin_cos_turns(u);
                    assert_eq!(
                        (sin[j].to_bits(), cos[j].to_bits()),
                        (s.to_bits(), c.to_bits()),
                        "u {u} on {level:?}"
                    );
                }
            }
        }
    }
}
