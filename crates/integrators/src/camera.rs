//! Primary rays of the pinhole camera.

use glam::{Vec2, Vec3};
use scene::Camera;

/// Generates camera rays through pixels.
#[derive(Clone, Copy, Debug)]
pub struct CameraRays {
    camera: Camera,
    /// Half extents of the image plane at distance 1.
    half: Vec2,
}

impl CameraRays {
    /// Rays of `camera`.
    pub fn new(camera: Camera) -> Self {
        let tan = (0.5 * camera.vertical_fov).tan();
        Self {
            camera,
            half: Vec2::new(tan * camera.aspect(), tan),
        }
    }

    /// Origin and unit direction of the ray through pixel (`x`, `y`) (row 0
    /// at the top) at sub-pixel position `u` in [0, 1)^2 (box filter).
    pub fn ray(&self, x: u32, y: u32, u: Vec2) -> (Vec3, Vec3) {
        let res = self.camera.resolution.as_vec2();
        let ndc = Vec2::new(
            2.0 * (x as f32 + u.x) / res.x - 1.0,
            1.0 - 2.0 * (y as f32 + u.y) / res.y,
        );
        let c = &self.camera;
        let d = c.forward + c.right * (ndc.x * self.half.x) + c.up * (ndc.y * self.half.y);
        (c.position, d.normalize())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::UVec2;

    #[test]
    fn corners_span_the_field_of_view() {
        let cam = Camera::look_at(Vec3::ZERO, -Vec3::Z, Vec3::Y, 90.0, UVec2::new(4, 2)).unwrap();
        let rays = CameraRays::new(cam);
        let (o, centre) = rays.ray(2, 1, Vec2::ZERO);
        assert_eq!(o, Vec3::ZERO);
        assert!((centre - -Vec3::Z).length() < 1e-6);
        // Top-left corner: x = -aspect tan(45), y = +tan(45).
        let (_, d) = rays.ray(0, 0, Vec2::ZERO);
        assert!((d - Vec3::new(-2.0, 1.0, -1.0).normalize()).length() < 1e-6);
    }
}
