//! Colour helpers shared by the light sources and the environment map's
//! importance sampling, which both weigh RGB by one number.

use glam::Vec3;

/// Luminance weights (Rec. 709) to turn RGB power into one number.
pub(crate) fn luminance(c: Vec3) -> f32 {
    c.dot(Vec3::new(0.2126, 0.7152, 0.0722))
}
