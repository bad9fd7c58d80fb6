//! The photon map of one iteration: what merges read of every light vertex,
//! in the storage order of a hashed grid over their positions, and the
//! range query that sums a density estimate (SmallVCM's `HashGrid` and
//! `RangeQuery`; SPEC §7).

use std::sync::Mutex;

use accel::HashGrid;
use glam::Vec3;
use microfacet::TransportMode;
use mis::SubpathState;
use rayon::prelude::*;

use super::light_path::{BoundedHistory, LightVertex};
use crate::vertex::PathVertex;

/// Photons a query keeps before summing their contributions.
const PHOTON_GROUP: usize = 32;

/// What a merge reads of a light vertex: 64 bytes of its 176, so that the
/// photons a query finds in one grid bucket share cache lines. (Read
/// through references to the light vertices, in light-path order, each
/// photon found was a cache miss: 24 % of VCM's time on `smallvcm-2`.)
#[derive(Clone, Copy, Debug)]
pub(super) struct Photon {
    pub state: SubpathState,
    /// Unit direction towards the previous vertex (towards the light).
    pub wi: Vec3,
    /// Light subpath throughput up to (excluding) this vertex.
    pub throughput: Vec3,
    /// Segments from the light to this vertex.
    pub length: u32,
    earlier_bounded: BoundedHistory,
}

impl Photon {
    /// [`LightVertex::earlier_bounded`].
    pub fn earlier_bounded(&self) -> impl Iterator<Item = bool> {
        self.earlier_bounded.iter(self.length - 1)
    }
}

impl From<&LightVertex> for Photon {
    fn from(light: &LightVertex) -> Self {
        Self {
            state: light.state,
            wi: light.wi,
            throughput: light.throughput,
            length: light.length,
            earlier_bounded: light.earlier_bounded,
        }
    }
}

/// Every light vertex of an iteration as a [`Photon`], in the slot order of
/// a grid over their positions. Holds no reference to the light paths.
#[derive(Debug, Default)]
pub(super) struct PhotonMap {
    grid: HashGrid,
    /// `photons[slot]` is the light vertex `grid.point_index(slot)`.
    photons: Vec<Photon>,
    radius: f32,
    /// 1 / (pi r^2 light_paths): the merge kernel's normalisation.
    normalisation: f32,
}

impl PhotonMap {
    /// Rebuilds the map over `count` light vertices, vertex i at
    /// `position(i)` with photon `photon(i)`, for merges of radius `radius`
    /// by `light_paths` light subpaths, in the buffers of the last build.
    /// Built on the current rayon pool; the result does not depend on its
    /// size.
    pub fn rebuild(
        &mut self,
        count: usize,
        radius: f32,
        light_paths: usize,
        position: impl Fn(usize) -> Vec3 + Sync,
        photon: impl Fn(usize) -> Photon + Sync,
    ) {
        self.grid.build_with(count, radius, position);
        let grid = &self.grid;
        (0..grid.len())
            .into_par_iter()
            .map(|slot| photon(grid.point_index(slot)))
            .collect_into_vec(&mut self.photons);
        self.radius = radius;
        self.normalisation = 1.0 / (std::f32::consts::PI * radius * radius * light_paths as f32);
    }

    /// The density estimate at camera vertex `camera`, `length` segments
    /// from the camera: the sum over the photons within the radius whose
    /// paths stay within `max_depth` segments of f (camera BSDF towards the
    /// photon's incoming direction) x photon throughput x `weight(photon)`,
    /// times the kernel's normalisation (SmallVCM's range query).
    pub fn gather(
        &self,
        camera: &PathVertex,
        length: u32,
        max_depth: u32,
        weight: impl Fn(&Photon) -> f32,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        let mut add = |slots: &[u32]| {
            for &slot in slots {
                let photon = &self.photons[slot as usize];
                let f = camera.f(photon.wi, TransportMode::Radiance);
                if f.max_element() <= 0.0 {
                    continue;
                }
                sum += f * photon.throughput * weight(photon);
            }
        };
        // The photons found are first only filtered by path length, a few
        // instructions each, so that the reads of their records (each
        // bucket's first a likely cache miss) overlap; then the BSDF and
        // weight of those kept are summed, in the same order.
        let mut kept = [0u32; PHOTON_GROUP];
        let mut k = 0;
        self.grid
            .for_each_slot_within(camera.point.p, self.radius, |slot| {
                kept[k] = slot as u32;
                k += usize::from(self.photons[slot].length + length <= max_depth);
                if k == PHOTON_GROUP {
                    add(&kept);
                    k = 0;
                }
            });
        add(&kept[..k]);
        sum * self.normalisation
    }
}

/// A photon map kept from one iteration to the next, so that each rebuild
/// reuses the last one's buffers: fresh ones, about 90 bytes a photon, were
/// mapped and zeroed by the kernel every iteration (page faults were 2-4 %
/// of PPM's and BPM's time on the SmallVCM scenes).
#[derive(Debug, Default)]
pub(super) struct PhotonMapBuffers(Mutex<PhotonMap>);

impl PhotonMapBuffers {
    /// Runs `f` on the kept map, or on a new one while another iteration
    /// holds it (or after a panic poisoned it): never waits.
    pub fn with<R>(&self, f: impl FnOnce(&mut PhotonMap) -> R) -> R {
        match self.0.try_lock() {
            Ok(mut map) => f(&mut map),
            Err(_) => f(&mut PhotonMap::default()),
        }
    }
}

/// A copy starts without buffers: they are a cache, not state.
impl Clone for PhotonMapBuffers {
    fn clone(&self) -> Self {
        Self::default()
    }
}
