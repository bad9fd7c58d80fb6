//! The input rule, applied once to every finished [`Scene`] whatever file
//! format it came from (ARCHITECTURE.md, "Input rules"):
//!
//! - A value that cannot render correctly is refused, naming the field:
//!   NaN or infinity anywhere (positions, normals, uvs, material parameters,
//!   light positions, directions and intensities, the camera); a negative
//!   colour, intensity or roughness; an index of refraction <= 0; a light
//!   whose value exceeds [`MAX_LIGHT_VALUE`] or whose power (4 pi I for a
//!   point or spot light, pi L A for an emissive triangle) does.
//! - At most one environment light (constant or map): rays that escape see
//!   one background.
//! - A scene without geometry, or without any light (an environment counts),
//!   is refused unless the caller allows it (`--allow-empty`); then it is a
//!   warning.
//! - What a renderer can reasonably go on with is a warning in
//!   `report.warnings` (a diffuse albedo above 1 is clamped by the loaders).
//!
//! Loaders check what they can earlier, with line numbers; this is the net
//! under all of them.

use std::path::Path;

use glam::Vec3;
use microfacet::{Fresnel, MicrofacetModel};

use crate::checks::{finite, unit};
use crate::error::SceneError;
use crate::light::Light;
use crate::material::Surface;
use crate::scene::Scene;

/// Largest light value (intensity, irradiance, radiance, emission, and a
/// light's power) accepted: f32::MAX / 1e6, about 3.4e32. The integrators
/// multiply a light's value by factors that can each reach about 1e2 .. 1e3
/// in ordinary scenes (4 pi for the power of a point light, a BSDF value of
/// a glossy lobe, 1 / r^2 at a few centimetres, a pdf's inverse) and sum
/// samples into the film; six orders of magnitude of headroom keep those
/// products finite, where a light of 3e38 overflowed to infinity on its first
/// multiplication and vanished from the image (its power was NaN). No
/// physical scene comes near: the sun's radiance is about 2e7 W/(m^2 sr).
pub const MAX_LIGHT_VALUE: f32 = f32::MAX / 1e6;

/// Whether an empty scene (no geometry, or no light) is allowed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Allow {
    /// `--allow-empty`: a scene with no geometry or no light is a warning,
    /// not an error.
    pub empty: bool,
}

/// Checks `scene`, loaded from `path`, against the input rule; warnings go to
/// `scene.report.warnings`.
pub fn validate(scene: &mut Scene, path: &Path, allow: Allow) -> Result<(), SceneError> {
    let invalid = |element: String, message: String| SceneError::invalid(path, element, message);
    for (i, t) in scene.triangles.iter().enumerate() {
        if t.iter().any(|&v| v as usize >= scene.positions.len()) {
            return Err(invalid(
                format!("triangle {i}"),
                "vertex index out of range".into(),
            ));
        }
    }
    for (i, p) in scene.positions.iter().enumerate() {
        if !p.is_finite() {
            return Err(invalid(
                format!("vertex {i}"),
                "position is NaN or infinite".into(),
            ));
        }
    }
    for (name, len) in [
        ("normals", scene.normals.len()),
        ("uvs", scene.uvs.len()),
        ("tangents", scene.tangents.len()),
    ] {
        if len != 0 && len != scene.positions.len() {
            return Err(invalid(
                "vertices".into(),
                format!("{len} {name} for {} vertices", scene.positions.len()),
            ));
        }
    }
    for (i, n) in scene.normals.iter().enumerate() {
        if !n.is_finite() {
            return Err(invalid(
                format!("vertex {i}"),
                "normal is NaN or infinite".into(),
            ));
        }
    }
    for (i, uv) in scene.uvs.iter().enumerate() {
        if !uv.is_finite() {
            return Err(invalid(
                format!("vertex {i}"),
                "texture coordinate is NaN or infinite".into(),
            ));
        }
    }
    for (i, sphere) in scene.spheres.iter().enumerate() {
        sphere
            .check()
            .map_err(|e| invalid(format!("sphere {i}"), e))?;
        if scene.materials.get(sphere.material as usize).is_none() {
            return Err(invalid(
                format!("sphere {i}"),
                format!("material {} does not exist", sphere.material),
            ));
        }
    }
    for m in &scene.materials {
        let element = || format!("material {}", crate::error::quoted(&m.name));
        check_material(&m.surface, m.emission).map_err(|e| invalid(element(), e))?;
        if let Some(medium) = m.medium {
            colour("absorption", medium.sigma_a).map_err(|e| invalid(element(), e))?;
        }
        if let Surface::Diffuse { reflectance } = m.surface
            && reflectance.max_element() > 1.0
        {
            scene.report.warnings.push(format!(
                "{}: {}: diffuse reflectance {reflectance} above 1 does not conserve energy",
                path.display(),
                element()
            ));
        }
    }
    for (i, light) in scene.lights.iter().enumerate() {
        let element = || format!("light {} ({})", i + 1, light_kind(light));
        check_light(scene, light).map_err(|e| invalid(element(), e))?;
    }
    if scene.lights.iter().filter(|l| l.is_environment()).count() > 1 {
        return Err(invalid(
            "lights".into(),
            "more than one environment light (constant or map): give at most one".into(),
        ));
    }
    let c = &scene.camera;
    if !(c.position.is_finite()
        && c.forward.is_finite()
        && c.up.is_finite()
        && c.right.is_finite()
        && c.vertical_fov.is_finite())
    {
        return Err(invalid(
            "camera".into(),
            "position, direction or field of view is NaN or infinite".into(),
        ));
    }
    let empty = if scene.triangles.is_empty() && scene.spheres.is_empty() {
        Some("the scene has no geometry")
    } else if scene.lights.is_empty() {
        Some("the scene has no light and no environment: it renders black")
    } else {
        None
    };
    if let Some(message) = empty {
        if !allow.empty {
            return Err(SceneError::invalid(
                path,
                "scene",
                format!("{message} (pass --allow-empty to render it anyway)"),
            ));
        }
        scene
            .report
            .warnings
            .push(format!("{}: {message}", path.display()));
    }
    Ok(())
}

fn light_kind(light: &Light) -> &'static str {
    match light {
        Light::Point { .. } => "point",
        Light::Spot { .. } => "spot",
        Light::Directional { .. } => "directional",
        Light::Environment { .. } => "environment",
        Light::EnvironmentMap { .. } => "environment map",
        Light::Area { .. } => "emissive triangle",
        Light::Sphere { .. } => "emissive sphere",
    }
}

/// `value` is finite, non-negative and at most [`MAX_LIGHT_VALUE`].
fn light_value(name: &str, value: Vec3) -> Result<(), String> {
    if !(value.is_finite() && value.min_element() >= 0.0) {
        return Err(format!(
            "{name} must be finite and non-negative, got {value}"
        ));
    }
    if value.max_element() > MAX_LIGHT_VALUE {
        return Err(format!(
            "{name} [{:e}, {:e}, {:e}] exceeds {MAX_LIGHT_VALUE:e}: its power would overflow f32 arithmetic",
            value.x, value.y, value.z
        ));
    }
    Ok(())
}

/// `power` (computed in f64) is at most [`MAX_LIGHT_VALUE`].
fn light_power(power: f64) -> Result<(), String> {
    if power.is_finite() && power <= f64::from(MAX_LIGHT_VALUE) {
        Ok(())
    } else {
        Err(format!(
            "its power {power:e} exceeds {MAX_LIGHT_VALUE:e} and would overflow f32 arithmetic"
        ))
    }
}

fn check_light(scene: &Scene, light: &Light) -> Result<(), String> {
    let four_pi = 4.0 * std::f64::consts::PI;
    match *light {
        Light::Point {
            position,
            intensity,
        } => {
            finite("position", position)?;
            light_value("intensity", intensity)?;
            light_power(four_pi * f64::from(intensity.max_element()))
        }
        Light::Spot {
            position,
            direction,
            intensity,
            cos_inner,
            cos_outer,
        } => {
            finite("position", position)?;
            unit("direction", direction)?;
            if !(cos_inner.is_finite() && cos_outer.is_finite()) {
                return Err("cone angles must be finite".into());
            }
            light_value("intensity", intensity)?;
            light_power(four_pi * f64::from(intensity.max_element()))
        }
        Light::Directional {
            direction,
            irradiance,
        } => {
            unit("direction", direction)?;
            light_value("irradiance", irradiance)
        }
        Light::Environment { radiance } => light_value("radiance", radiance),
        Light::EnvironmentMap { map } => {
            let Some(map) = scene.environment_maps.get(map as usize) else {
                return Err(format!("environment map {map} does not exist"));
            };
            // Texels are finite and non-negative by construction
            // (`EnvironmentMap::new`); the scale can still push them over.
            let largest = map.max_value();
            light_value("largest texel times scale", Vec3::splat(largest))
        }
        Light::Area { triangle } => {
            let i = triangle as usize;
            let (Some(t), Some(&m)) = (
                scene.triangles.get(i).map(|_| scene.triangle(i)),
                scene.triangle_materials.get(i),
            ) else {
                return Err(format!("triangle {i} does not exist"));
            };
            let Some(material) = scene.materials.get(m as usize) else {
                return Err(format!("material {m} does not exist"));
            };
            light_value("emission", material.emission)?;
            let area = 0.5 * crate::scene::triangle_cross(&t).length();
            light_power(std::f64::consts::PI * f64::from(material.emission.max_element()) * area)
        }
        Light::Sphere { sphere } => {
            let i = sphere as usize;
            let Some(s) = scene.spheres.get(i) else {
                return Err(format!("sphere {i} does not exist"));
            };
            let Some(material) = scene.materials.get(s.material as usize) else {
                return Err(format!("material {} does not exist", s.material));
            };
            light_value("emission", material.emission)?;
            light_power(
                std::f64::consts::PI * f64::from(material.emission.max_element()) * s.area(),
            )
        }
    }
}

fn colour(name: &str, v: Vec3) -> Result<(), String> {
    if v.is_finite() && v.min_element() >= 0.0 {
        Ok(())
    } else {
        Err(format!("{name} must be finite and non-negative, got {v}"))
    }
}

/// A colour in [0, 1] per channel (a reflectance factor).
fn unit_colour(name: &str, v: Vec3) -> Result<(), String> {
    if v.is_finite() && v.min_element() >= 0.0 && v.max_element() <= 1.0 {
        Ok(())
    } else {
        Err(format!("{name} must lie in [0, 1], got {v}"))
    }
}

fn model(m: &MicrofacetModel) -> Result<(), String> {
    let a = m.alpha();
    if a.is_finite() && a >= 0.0 {
        Ok(())
    } else {
        Err(format!("roughness alpha must be finite and >= 0, got {a}"))
    }
}

/// A mix weight: finite and in [0, 1].
fn unit_interval(name: &str, v: f32) -> Result<(), String> {
    if (0.0..=1.0).contains(&v) {
        Ok(())
    } else {
        Err(format!("{name} must be in [0, 1], got {v}"))
    }
}

/// The index of a coat: finite and >= 0 (`KHR_materials_ior`'s 0 means F0 = 1).
fn coat_ior(ior: f32) -> Result<(), String> {
    if ior.is_finite() && ior >= 0.0 {
        Ok(())
    } else {
        Err(format!("ior must be finite and >= 0, got {ior}"))
    }
}

fn check_material(surface: &Surface, emission: Vec3) -> Result<(), String> {
    light_value("emission", emission)?;
    match surface {
        Surface::Diffuse { reflectance } => colour("reflectance", *reflectance),
        Surface::Conductor { model: m, fresnel } => {
            model(m)?;
            match *fresnel {
                Fresnel::Schlick { f0 } => colour("F0", f0),
                Fresnel::Conductor { eta, k, tint } => {
                    colour("eta", eta)?;
                    colour("k", k)?;
                    unit_colour("tint", tint)
                }
            }
        }
        Surface::Dielectric {
            model: m,
            ior,
            tint,
        } => {
            model(m)?;
            colour("tint", *tint)?;
            if ior.is_finite() && *ior > 0.0 {
                Ok(())
            } else {
                Err(format!("ior must be finite and > 0, got {ior}"))
            }
        }
        Surface::ThinDielectric { ior, tint } => {
            unit_colour("tint", *tint)?;
            if ior.is_finite() && *ior > 0.0 {
                Ok(())
            } else {
                Err(format!("ior must be finite and > 0, got {ior}"))
            }
        }
        Surface::Coated(c) => {
            model(&c.model)?;
            colour("base colour", c.base_color)?;
            colour("specular colour", c.specular_color)?;
            unit_interval("metallic", c.metallic)?;
            unit_interval("specular", c.specular)?;
            coat_ior(c.ior)
        }
        Surface::Textured(pbr) => {
            colour("base colour", pbr.base_color)?;
            colour("specular colour", pbr.specular_color)?;
            unit_interval("specular", pbr.specular)?;
            coat_ior(pbr.ior)?;
            for (name, v) in [
                ("metallic", pbr.metallic),
                ("roughness", pbr.roughness),
                ("transmission", pbr.transmission),
            ] {
                if !(v.is_finite() && v >= 0.0) {
                    return Err(format!("{name} must be finite and >= 0, got {v}"));
                }
            }
            if pbr.transmission >= 0.5 && !(pbr.ior.is_finite() && pbr.ior > 0.0) {
                return Err(format!("ior must be finite and > 0, got {}", pbr.ior));
            }
            Ok(())
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn light_values_are_bounded() {
        assert!(light_value("intensity", Vec3::splat(3e38)).is_err());
        assert!(light_value("intensity", Vec3::splat(f32::NAN)).is_err());
        assert!(light_value("intensity", Vec3::splat(-1.0)).is_err());
        assert!(light_value("intensity", Vec3::splat(1e30)).is_ok());
        assert!(light_power(4.0 * std::f64::consts::PI * 1e32).is_err());
        assert!(light_power(f64::NAN).is_err());
    }
}
