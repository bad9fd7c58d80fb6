//! Absorbing media inside closed dielectric meshes (Khronos
//! KHR_materials_volume; `scene::Medium`): Beer-Lambert transmittance on
//! every path segment that runs inside one.
//!
//! Which segments are inside: a dielectric's inside is behind its
//! geometric normal (its `eta` is the inside's index over the outside's),
//! so a segment is inside a material's medium where it leaves a surface of
//! that material towards the back of the geometric normal, or arrives at
//! one from there. Either end decides (the segment's medium is its start's,
//! else its end's), so a segment gets the same transmittance whichever way
//! a technique traces it: a camera subpath, a light subpath, a connection
//! or a shadow ray.
//!
//! Assumptions: media are closed and not nested (a segment inside one
//! medium that ends on a surface of another material, e.g. an object
//! inside the glass, is attenuated by the medium it started in, or ended
//! in); the camera and every light are outside all media (an emissive
//! material's medium is ignored, so that a light subpath, which starts on
//! the emitter, and a camera subpath that reaches it agree).
//!
//! Transmittance multiplies contributions and throughputs, never pdfs: no
//! distance is sampled, so every MIS quantity stays as it is.

use glam::Vec3;
use scene::{Material, Medium, Scene};

use crate::geometry::SurfacePoint;

/// The medium that fills the inside of `material`'s meshes, as transport
/// sees it: none for an emitter (see the module docs).
pub fn of(material: &Material) -> Option<Medium> {
    material.medium.filter(|_| !material.is_emissive())
}

/// The medium behind a surface with geometric normal `ng` filled with
/// `medium`, if direction `w` (away from the surface) goes into it.
pub fn towards(medium: Option<Medium>, ng: Vec3, w: Vec3) -> Option<Medium> {
    medium.filter(|_| ng.dot(w) < 0.0)
}

/// The medium a segment leaving `point` in direction `w` runs through, as
/// far as `point` knows.
pub fn at(scene: &Scene, point: &SurfacePoint, w: Vec3) -> Option<Medium> {
    towards(of(&scene.materials[point.material as usize]), point.ng, w)
}

/// `value` times the Beer-Lambert transmittance of `distance` through
/// `medium` (unchanged without one).
#[inline]
pub fn attenuated(value: Vec3, medium: Option<Medium>, distance: f32) -> Vec3 {
    match medium {
        Some(m) => value * m.transmittance(distance),
        None => value,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use scene::Surface;

    #[test]
    fn a_segment_is_inside_behind_the_geometric_normal_and_never_in_an_emitter() {
        let glass = Medium::absorbing(Vec3::new(1.0, 2.0, 3.0));
        let ng = Vec3::Z;
        assert_eq!(towards(glass, ng, Vec3::new(0.3, 0.0, -0.9)), glass);
        assert_eq!(towards(glass, ng, Vec3::new(0.3, 0.0, 0.9)), None);
        assert_eq!(towards(None, ng, -Vec3::Z), None);
        let surface = Surface::Diffuse {
            reflectance: Vec3::ZERO,
        };
        let mut material = Material {
            medium: glass,
            ..Material::new("glass".into(), surface, Vec3::ZERO)
        };
        assert_eq!(of(&material), glass);
        material.emission = Vec3::ONE;
        assert_eq!(of(&material), None);
        let t = attenuated(Vec3::splat(2.0), glass, 0.5);
        assert!(
            (t - 2.0 * Vec3::new(-0.5f32, -1.0, -1.5).exp())
                .abs()
                .max_element()
                < 1e-6
        );
        assert_eq!(attenuated(Vec3::splat(2.0), None, 0.5), Vec3::splat(2.0));
    }
}
