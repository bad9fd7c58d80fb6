//! The merge radius of photon mapping and VCM (SPEC §7): the rule that fixes
//! r_1 from the scene and the image, and its progressive reduction.

use accel::Bvh;
use glam::Vec2;

use crate::camera::CameraRays;

/// Largest initial merge radius, in pixel footprints at the median distance
/// of visible surfaces. The bounding radius alone is no scale when the scene
/// holds a huge backdrop: on `stiff` (a 1e5 wall around a 10-unit set) it
/// gave r_1 = 213: every camera vertex merged with every photon, 0.65 s per
/// PPM iteration at 64x48 against 0.005 s for PT (now 0.024 s, r_1 = 0.36).
/// On the other bundled scenes r_1 is 0.5-1.1 footprints at their manifest
/// resolutions, so the bound does not change them.
pub const MAX_MERGE_RADIUS_PIXELS: f32 = 8.0;

/// Camera rays per image side that estimate the distance of visible surfaces.
const FOOTPRINT_GRID: u32 = 16;

/// The merge radius of every iteration: r_1 = `factor` x the scene's
/// bounding radius, but at most [`MAX_MERGE_RADIUS_PIXELS`] pixel
/// footprints; r_n = r_1 n^((alpha_r - 1) / 2) (SPEC §7, Knaus and Zwicker 2011).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MergeRadius {
    /// `factor` x the bounding radius: r_1 without the cap.
    pub from_scene: f32,
    /// Width of a pixel's footprint at the median distance of the surfaces
    /// the camera sees (infinity when it sees none): the scale of what the
    /// image resolves.
    pub pixel_footprint: f32,
    /// The radius of the first iteration.
    pub r1: f32,
    /// The reduction exponent alpha_r.
    pub alpha: f32,
}

impl MergeRadius {
    /// The rule for a scene of bounding radius `scene_radius` whose visible
    /// surfaces have pixel footprint `pixel_footprint`.
    pub fn new(factor: f32, scene_radius: f32, pixel_footprint: f32, alpha: f32) -> Self {
        let from_scene = factor * scene_radius;
        Self {
            from_scene,
            pixel_footprint,
            r1: from_scene.min(MAX_MERGE_RADIUS_PIXELS * pixel_footprint),
            alpha,
        }
    }

    /// True when the pixel footprint, not the scene, fixed r_1.
    pub fn is_capped(&self) -> bool {
        self.r1 < self.from_scene
    }

    /// The radius of iteration `n` (1-based).
    pub fn at(&self, n: u64) -> f32 {
        self.r1 * (n.max(1) as f32).powf(0.5 * (self.alpha - 1.0))
    }
}

/// The width of one pixel's footprint at the median distance of the
/// surfaces seen through a grid of pixel centres: a pixel subtends
/// 1 / image_plane_distance radians (the image plane is in pixel units).
pub fn pixel_footprint(bvh: &Bvh, camera: &CameraRays) -> f32 {
    let res = camera.camera().resolution;
    let mut distances: Vec<f32> = (0..FOOTPRINT_GRID * FOOTPRINT_GRID)
        .filter_map(|i| {
            let (gx, gy) = (i % FOOTPRINT_GRID, i / FOOTPRINT_GRID);
            let x = ((2 * gx + 1) * res.x) / (2 * FOOTPRINT_GRID);
            let y = ((2 * gy + 1) * res.y) / (2 * FOOTPRINT_GRID);
            let (o, d) = camera.ray(x, y, Vec2::splat(0.5));
            bvh.intersect(o, d, f32::INFINITY).map(|hit| hit.t)
        })
        .collect();
    if distances.is_empty() {
        return f32::INFINITY;
    }
    let mid = distances.len() / 2;
    let (_, median, _) = distances.select_nth_unstable_by(mid, f32::total_cmp);
    *median / camera.image_plane_distance()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_footprint_caps_r1_and_the_radius_shrinks() {
        let free = MergeRadius::new(0.003, 10.0, 1.0, 0.75);
        assert_eq!(free.r1, 0.003 * 10.0);
        assert!(!free.is_capped());
        let capped = MergeRadius::new(0.003, 1e5, 0.01, 0.75);
        assert_eq!(capped.r1, MAX_MERGE_RADIUS_PIXELS * 0.01);
        assert!(capped.is_capped());
        // r_n = r_1 n^(-1/8) for alpha_r = 0.75.
        assert!((free.at(256) - free.r1 * 0.5).abs() < 1e-8);
        assert_eq!(free.at(0), free.at(1));
    }
}
