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

/// What every merge reads of a light vertex: 32 bytes of its 176, two to a
/// cache line, so that the photons a query finds in one grid bucket share
/// cache lines. (Read through references to the light vertices, in
/// light-path order, each photon found was a cache miss: 24 % of VCM's
/// time on `smallvcm-2`.)
#[derive(Clone, Copy, Debug)]
pub(super) struct Photon {
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
            wi: light.wi,
            throughput: light.throughput,
            length: light.length,
            earlier_bounded: light.earlier_bounded,
        }
    }
}

/// A photon with its light subpath's MIS state, for merges weighted against
/// other techniques (BPM, VCM): 64 bytes. PPM, which weighs nothing, stores
/// bare [`Photon`]s.
#[derive(Clone, Copy, Debug)]
pub(super) struct WeightedPhoton {
    pub photon: Photon,
    pub state: SubpathState,
}

impl From<&LightVertex> for WeightedPhoton {
    fn from(light: &LightVertex) -> Self {
        Self {
            photon: Photon::from(light),
            state: light.state,
        }
    }
}

/// A record a photon map stores: a light vertex's [`Photon`] and whatever
/// else its merges read.
pub(super) trait PhotonRecord: Copy + Send + Sync + for<'a> From<&'a LightVertex> {
    /// What every merge reads (its length filters the query's photons).
    fn photon(&self) -> &Photon;
}

impl PhotonRecord for Photon {
    fn photon(&self) -> &Photon {
        self
    }
}

impl PhotonRecord for WeightedPhoton {
    fn photon(&self) -> &Photon {
        &self.photon
    }
}

/// Every light vertex of an iteration as a record `R`, in the slot order of
/// a grid over their positions. Holds no reference to the light paths.
#[derive(Debug)]
pub(super) struct PhotonMap<R> {
    grid: HashGrid,
    /// `records[slot]` is the light vertex `grid.point_index(slot)`.
    records: Vec<R>,
    radius: f32,
    /// 1 / (pi r^2 light_paths): the merge kernel's normalisation.
    normalisation: f32,
}

/// An empty map (no buffers yet).
impl<R> Default for PhotonMap<R> {
    fn default() -> Self {
        Self {
            grid: HashGrid::new(),
            records: Vec::new(),
            radius: 0.0,
            normalisation: 0.0,
        }
    }
}

impl<R: PhotonRecord> PhotonMap<R> {
    /// Rebuilds the map over `count` light vertices, vertex i at
    /// `position(i)` with record `record(i)`, for merges of radius `radius`
    /// by `light_paths` light subpaths, in the buffers of the last build.
    /// Built on the current rayon pool; the result does not depend on its
    /// size.
    pub fn rebuild(
        &mut self,
        count: usize,
        radius: f32,
        light_paths: usize,
        position: impl Fn(usize) -> Vec3 + Sync,
        record: impl Fn(usize) -> R + Sync,
    ) {
        self.grid.build_with(count, radius, position);
        let grid = &self.grid;
        (0..grid.len())
            .into_par_iter()
            .map(|slot| record(grid.point_index(slot)))
            .collect_into_vec(&mut self.records);
        self.radius = radius;
        self.normalisation = 1.0 / (std::f32::consts::PI * radius * radius * light_paths as f32);
    }

    /// The density estimate at camera vertex `camera`, `length` segments
    /// from the camera: the sum over the photons within the radius whose
    /// paths stay within `max_depth` segments of f (camera BSDF towards the
    /// photon's incoming direction) x photon throughput x `weight(record)`,
    /// times the kernel's normalisation (SmallVCM's range query).
    pub fn gather(
        &self,
        camera: &PathVertex,
        length: u32,
        max_depth: u32,
        weight: impl Fn(&R) -> f32,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        let mut add = |slots: &[u32]| {
            for &slot in slots {
                let record = &self.records[slot as usize];
                let photon = record.photon();
                let f = camera.f(photon.wi, TransportMode::Radiance);
                if f.max_element() <= 0.0 {
                    continue;
                }
                sum += f * photon.throughput * weight(record);
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
                k += usize::from(self.records[slot].photon().length + length <= max_depth);
                if k == PHOTON_GROUP {
                    add(&kept);
                    k = 0;
                }
            });
        add(&kept[..k]);
        sum * self.normalisation
    }
}

/// What merging needs from one iteration to the next: each iteration
/// reuses the last one's buffers. Fresh ones, about 90 bytes a photon
/// for the map and 45-80 for the light pass's photon blocks, were mapped
/// and zeroed by the kernel every iteration (page faults were 2-4 % of
/// PPM's and BPM's time on the SmallVCM scenes).
#[derive(Debug)]
pub(super) struct PhotonMapBuffers<R>(Mutex<Kept<R>>);

/// The buffers [`PhotonMapBuffers`] keeps.
#[derive(Debug)]
pub(super) struct Kept<R> {
    /// The photon map.
    pub map: PhotonMap<R>,
    /// The light pass's photon blocks (`LightPaths`), to be refilled.
    pub blocks: Vec<Vec<(Vec3, R)>>,
}

impl<R> Default for PhotonMapBuffers<R> {
    fn default() -> Self {
        Self(Mutex::new(Kept::default()))
    }
}

impl<R> Default for Kept<R> {
    fn default() -> Self {
        Self {
            map: PhotonMap::default(),
            blocks: Vec::new(),
        }
    }
}

impl<R> PhotonMapBuffers<R> {
    /// Runs `f` on the kept buffers, or on new ones while another iteration
    /// holds them (or after a panic poisoned them): never waits.
    pub fn with<T>(&self, f: impl FnOnce(&mut Kept<R>) -> T) -> T {
        match self.0.try_lock() {
            Ok(mut kept) => f(&mut kept),
            Err(_) => f(&mut Kept::default()),
        }
    }
}

/// A copy starts without buffers: they are a cache, not state.
impl<R> Clone for PhotonMapBuffers<R> {
    fn clone(&self) -> Self {
        Self::default()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The records' sizes are what their cache-line layout is designed
    /// for: two bare photons, or one weighted photon, to a 64-byte line.
    #[test]
    fn records_fit_cache_lines() {
        assert_eq!(std::mem::size_of::<Photon>(), 32);
        assert_eq!(std::mem::size_of::<WeightedPhoton>(), 64);
    }
}
