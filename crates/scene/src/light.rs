//! Light sources. Emissive triangles and spheres are lights too
//! (`Light::Area`, `Light::Sphere`), with the radiance of their material.

use glam::Vec3;

/// A light source.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Light {
    /// Isotropic point light; `intensity` in W/sr per channel.
    Point {
        /// Position.
        position: Vec3,
        /// Radiant intensity.
        intensity: Vec3,
    },
    /// Spot light: a point light restricted to a cone around `direction`, with
    /// a smooth falloff between the inner and outer cone (glTF semantics).
    Spot {
        /// Position.
        position: Vec3,
        /// Unit direction the spot points to.
        direction: Vec3,
        /// Radiant intensity on the axis.
        intensity: Vec3,
        /// cos of the inner cone angle (full intensity inside).
        cos_inner: f32,
        /// cos of the outer cone angle (zero outside).
        cos_outer: f32,
    },
    /// Distant light; `irradiance` in W/m^2 on a surface facing it.
    Directional {
        /// Unit direction the light travels in.
        direction: Vec3,
        /// Irradiance.
        irradiance: Vec3,
    },
    /// Constant environment (background) radiance from every direction.
    Environment {
        /// Radiance.
        radiance: Vec3,
    },
    /// Environment radiance from an equirectangular map
    /// ([`crate::environment::EnvironmentMap`]).
    EnvironmentMap {
        /// Index into `Scene::environment_maps`.
        map: u32,
    },
    /// An emissive triangle (index into the scene's triangles).
    Area {
        /// Triangle index.
        triangle: u32,
    },
    /// An emissive analytic sphere (index into the scene's spheres),
    /// emitting on the side its normals face.
    Sphere {
        /// Sphere index.
        sphere: u32,
    },
}

impl Light {
    /// True for lights that a BSDF-sampled ray cannot hit (point, spot, directional).
    pub fn is_delta(&self) -> bool {
        matches!(
            self,
            Light::Point { .. } | Light::Spot { .. } | Light::Directional { .. }
        )
    }

    /// True for the lights at infinity that escaping rays see (a constant
    /// environment or a map).
    pub fn is_environment(&self) -> bool {
        matches!(
            self,
            Light::Environment { .. } | Light::EnvironmentMap { .. }
        )
    }
}
