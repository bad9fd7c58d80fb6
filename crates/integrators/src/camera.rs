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

    /// The camera.
    pub fn camera(&self) -> &Camera {
        &self.camera
    }

    /// Distance of the image plane in pixel units (pixels have area 1 on
    /// it), the measure in which camera pdfs are expressed (SmallVCM).
    pub fn image_plane_distance(&self) -> f32 {
        0.5 * self.camera.resolution.y as f32 / self.half.y
    }

    /// Solid-angle density of the camera ray in unit direction `d` (pixel
    /// units): image_plane_distance^2 / cos^3; 0 behind the camera.
    pub fn pdf_w(&self, d: Vec3) -> f32 {
        let cos = d.dot(self.camera.forward);
        if cos <= 0.0 {
            return 0.0;
        }
        let dist = self.image_plane_distance() / cos;
        dist * dist / cos
    }

    /// The ray parameter at which unit direction `d` from the camera
    /// crosses the near plane (`Camera::near_clip`): camera rays see only
    /// what lies beyond it (Mitsuba's `perspective`); 0 without a near plane.
    pub fn near_t(&self, d: Vec3) -> f32 {
        let near = self.camera.near_clip;
        if near > 0.0 {
            near / d.dot(self.camera.forward)
        } else {
            0.0
        }
    }

    /// The pixel (x, y) that sees world point `p`, if any (none before the
    /// near plane).
    pub fn project(&self, p: Vec3) -> Option<(u32, u32)> {
        let c = &self.camera;
        let v = p - c.position;
        let z = v.dot(c.forward);
        if !(z > 0.0 && z >= c.near_clip) {
            return None;
        }
        let ndc = Vec2::new(
            v.dot(c.right) / (z * self.half.x),
            v.dot(c.up) / (z * self.half.y),
        );
        let res = c.resolution.as_vec2();
        let x = (ndc.x + 1.0) * 0.5 * res.x;
        let y = (1.0 - ndc.y) * 0.5 * res.y;
        ((0.0..res.x).contains(&x) && (0.0..res.y).contains(&y)).then_some((x as u32, y as u32))
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

    /// Projection inverts ray generation, and the camera pdf integrates to
    /// the pixel count over the image (pixels have unit area).
    #[test]
    fn projection_and_pdf_match_ray_generation() {
        let cam =
            Camera::look_at(Vec3::ONE, Vec3::ZERO, Vec3::Y, 50.0, UVec2::new(40, 30)).unwrap();
        let rays = CameraRays::new(cam);
        for (x, y) in [(0, 0), (39, 29), (17, 3)] {
            let (o, d) = rays.ray(x, y, Vec2::splat(0.5));
            assert_eq!(rays.project(o + 3.0 * d), Some((x, y)));
        }
        assert_eq!(rays.project(Vec3::ONE + cam.forward * -1.0), None);
        // Sum over pixels of 1/pdf(direction) * (solid angle of a pixel) ~ 1 per pixel:
        // at the centre, one pixel spans 1/dist^2 sr and pdf = dist^2.
        let (_, centre) = rays.ray(20, 15, Vec2::ZERO);
        let dist = rays.image_plane_distance();
        assert!((rays.pdf_w(centre) - dist * dist).abs() < 1e-3 * dist * dist);
    }
}
