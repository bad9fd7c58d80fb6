//! The in-memory scene every integrator sees, and the builder loaders fill.

use std::path::Path;

use glam::{DVec3, Vec2, Vec3, Vec4};

use crate::camera::Camera;
use crate::environment::EnvironmentMap;
use crate::error::SceneError;
use crate::light::Light;
use crate::material::Material;
use crate::sphere::Sphere;
use crate::texture::Texture;

/// Render settings a manifest's `[render]` table may suggest, as written
/// (their types checked, not their ranges): `render-cli` checks a value,
/// with the same checks as its flag, when no flag overrides it.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct RenderSettings {
    /// Integrator name (`pt`, `bpt`, `ppm`, `bpm`, `vcm`).
    pub integrator: Option<String>,
    /// Number of iterations.
    pub iterations: Option<u32>,
    /// Maximum path length.
    pub max_depth: Option<u32>,
    /// Regularization mode (`off`, `uniform`, `selective`).
    pub regularize: Option<String>,
    /// Initial regularization bound tau_0.
    pub tau0: Option<f64>,
    /// Whether tau grows with the iteration count (false: tau stays tau_0).
    pub progressive: Option<bool>,
    /// Random seed.
    pub seed: Option<u64>,
    /// First merge radius of PPM, BPM and VCM, as a fraction of the scene's bounding-sphere radius.
    pub radius: Option<f32>,
    /// Shadow-ray Russian roulette threshold, as a fraction of the mean pixel value (0: off).
    pub shadow_roulette: Option<f32>,
    /// Virtual merges in BPT and VCM with regularization.
    pub virtual_merges: Option<bool>,
    /// Whether regularized lobes keep their original's energy (default true).
    pub regularize_energy: Option<bool>,
}

/// What a load skipped or noticed (nothing is dropped silently).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LoadReport {
    /// Zero-area triangles that were skipped.
    pub degenerate_triangles: usize,
    /// Edges shared by more than two triangles (kept: ray tracing does not need manifolds).
    pub non_manifold_edges: usize,
    /// Human-readable warnings, each naming the file and element.
    pub warnings: Vec<String>,
    /// Features the file uses that the renderer ignores (e.g. an unsupported
    /// glTF extension and its materials), also among `warnings`; `--explain` lists them.
    pub ignored: Vec<String>,
}

/// A scene of triangles and analytic spheres in world space.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Triangle vertices, counter-clockwise seen from the front.
    pub triangles: Vec<[Vec3; 3]>,
    /// Shading normals per triangle vertex (unit; the geometric normal where the file has none).
    pub normals: Vec<[Vec3; 3]>,
    /// Texture coordinates per triangle vertex (zero where the file has none).
    pub uvs: Vec<[Vec2; 3]>,
    /// Tangents per triangle vertex from the file (glTF TANGENT: xyz, w the
    /// bitangent's sign), for normal maps. Empty when no file gives any;
    /// zero for triangles without (their tangent is derived from the uvs).
    pub tangents: Vec<[Vec4; 3]>,
    /// Material index per triangle.
    pub triangle_materials: Vec<u32>,
    /// Analytic spheres (beside the triangles: ray queries number them
    /// after the triangles).
    pub spheres: Vec<Sphere>,
    /// Materials.
    pub materials: Vec<Material>,
    /// Textures referenced by materials.
    pub textures: Vec<Texture>,
    /// Lights, including one `Light::Area` per emissive triangle and one
    /// `Light::Sphere` per emissive sphere.
    pub lights: Vec<Light>,
    /// Environment maps referenced by `Light::EnvironmentMap`.
    pub environment_maps: Vec<EnvironmentMap>,
    /// The camera.
    pub camera: Camera,
    /// Suggested render settings.
    pub render: RenderSettings,
    /// What the load skipped or noticed.
    pub report: LoadReport,
}

impl Scene {
    /// Axis-aligned bounds of all triangles and spheres ((0, 0) for an
    /// empty scene).
    pub fn bounds(&self) -> (Vec3, Vec3) {
        bounds_with_spheres(&self.triangles, &self.spheres)
    }

    /// Area of triangle `i`.
    pub fn triangle_area(&self, i: usize) -> f32 {
        (0.5 * triangle_cross(&self.triangles[i]).length()) as f32
    }

    /// Geometric normal of triangle `i` (unit, from the winding; zero for a
    /// degenerate triangle).
    pub fn geometric_normal(&self, i: usize) -> Vec3 {
        triangle_normal(&self.triangles[i]).unwrap_or(Vec3::ZERO)
    }
}

/// (v1 - v0) x (v2 - v0) in f64: in f32 its squared length overflows for
/// triangles wider than about 4e9, which then looked degenerate.
pub fn triangle_cross(t: &[Vec3; 3]) -> DVec3 {
    let [a, b, c] = t.map(Vec3::as_dvec3);
    (b - a).cross(c - a)
}

/// The unit normal of a triangle from its winding, `None` for zero area.
pub fn triangle_normal(t: &[Vec3; 3]) -> Option<Vec3> {
    triangle_cross(t).try_normalize().map(DVec3::as_vec3)
}

impl Scene {
    /// Lights the scene with `map`, replacing any environment it had
    /// (constant or map): `--env` on the command line.
    pub fn set_environment(&mut self, map: EnvironmentMap) {
        self.lights.retain(|l| !l.is_environment());
        self.environment_maps.clear();
        self.environment_maps.push(map);
        self.lights.push(Light::EnvironmentMap { map: 0 });
    }
}

/// [`bounds_of`] the triangles, grown by the spheres' boxes.
pub(crate) fn bounds_with_spheres(triangles: &[[Vec3; 3]], spheres: &[Sphere]) -> (Vec3, Vec3) {
    let (mut min, mut max) = bounds_of(triangles);
    if triangles.is_empty() && !spheres.is_empty() {
        (min, max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    }
    for s in spheres {
        min = min.min(s.center - Vec3::splat(s.radius));
        max = max.max(s.center + Vec3::splat(s.radius));
    }
    (min, max)
}

pub(crate) fn bounds_of(triangles: &[[Vec3; 3]]) -> (Vec3, Vec3) {
    let mut min = Vec3::splat(f32::INFINITY);
    let mut max = Vec3::splat(f32::NEG_INFINITY);
    for v in triangles.iter().flatten() {
        min = min.min(*v);
        max = max.max(*v);
    }
    if triangles.is_empty() {
        (Vec3::ZERO, Vec3::ZERO)
    } else {
        (min, max)
    }
}

/// Geometry and materials as loaders produce them, before lights and camera.
#[derive(Clone, Debug, Default)]
pub struct SceneBuilder {
    pub(crate) triangles: Vec<[Vec3; 3]>,
    pub(crate) normals: Vec<[Vec3; 3]>,
    pub(crate) uvs: Vec<[Vec2; 3]>,
    pub(crate) tangents: Vec<[Vec4; 3]>,
    pub(crate) triangle_materials: Vec<u32>,
    pub(crate) spheres: Vec<Sphere>,
    pub(crate) materials: Vec<Material>,
    pub(crate) textures: Vec<Texture>,
    pub(crate) lights: Vec<Light>,
    pub(crate) environment_maps: Vec<EnvironmentMap>,
    pub(crate) report: LoadReport,
}

impl SceneBuilder {
    /// Adds a material and returns its index.
    pub(crate) fn add_material(&mut self, material: Material) -> u32 {
        self.materials.push(material);
        (self.materials.len() - 1) as u32
    }

    /// Adds a texture and returns its index.
    pub(crate) fn add_texture(&mut self, texture: Texture) -> usize {
        self.textures.push(texture);
        self.textures.len() - 1
    }

    /// Adds one triangle. Non-finite positions, normals or uvs are an error
    /// naming `element`; zero-area triangles are skipped and counted; missing
    /// or zero shading normals fall back to the geometric normal.
    pub(crate) fn add_triangle(
        &mut self,
        path: &Path,
        element: &dyn Fn() -> String,
        positions: [Vec3; 3],
        normals: Option<[Vec3; 3]>,
        uvs: Option<[Vec2; 3]>,
        material: u32,
    ) -> Result<(), SceneError> {
        if !positions.iter().all(|p| p.is_finite()) {
            return Err(SceneError::invalid(
                path,
                element(),
                "vertex position is NaN or infinite",
            ));
        }
        // A degenerate triangle is skipped whatever its shading data (a node
        // scaled to zero makes both degenerate positions and NaN normals).
        let Some(geometric) = triangle_normal(&positions) else {
            self.report.degenerate_triangles += 1;
            return Ok(());
        };
        if normals.is_some_and(|ns| !ns.iter().all(|n| n.is_finite())) {
            return Err(SceneError::invalid(
                path,
                element(),
                "vertex normal is NaN or infinite",
            ));
        }
        if uvs.is_some_and(|t| !t.iter().all(|uv| uv.is_finite())) {
            return Err(SceneError::invalid(
                path,
                element(),
                "texture coordinate is NaN or infinite",
            ));
        }
        let normals = normals.map_or([geometric; 3], |ns| {
            ns.map(|n| n.try_normalize().unwrap_or(geometric))
        });
        let uvs = uvs.unwrap_or([Vec2::ZERO; 3]);
        self.triangles.push(positions);
        self.normals.push(normals);
        self.uvs.push(uvs);
        self.triangle_materials.push(material);
        Ok(())
    }

    /// Adds an analytic sphere. A non-finite centre or axis, or a radius
    /// that is not finite and positive, is an error naming `element`.
    pub(crate) fn add_sphere(
        &mut self,
        path: &Path,
        element: &str,
        sphere: Sphere,
    ) -> Result<(), SceneError> {
        crate::validate::check_sphere(&sphere)
            .map_err(|e| SceneError::invalid(path, element.to_owned(), e))?;
        self.spheres.push(sphere);
        Ok(())
    }

    /// Sets the file's tangents of the triangle just added, if
    /// [`SceneBuilder::add_triangle`] kept it (it had `before` triangles).
    pub(crate) fn set_last_tangents(&mut self, before: usize, tangents: [Vec4; 3]) {
        if self.triangles.len() > before {
            self.tangents.resize(before, [Vec4::ZERO; 3]);
            self.tangents.push(tangents);
        }
    }

    /// Appends everything of `other`, re-indexing its materials and textures.
    pub(crate) fn append(&mut self, mut other: SceneBuilder) {
        let material_offset = self.materials.len() as u32;
        let texture_offset = self.textures.len();
        let triangle_offset = self.triangles.len() as u32;
        let map_offset = self.environment_maps.len() as u32;
        if !(self.tangents.is_empty() && other.tangents.is_empty()) {
            self.tangents.resize(self.triangles.len(), [Vec4::ZERO; 3]);
            other
                .tangents
                .resize(other.triangles.len(), [Vec4::ZERO; 3]);
            self.tangents.extend(other.tangents);
        }
        self.triangles.extend(other.triangles);
        self.normals.extend(other.normals);
        self.uvs.extend(other.uvs);
        self.triangle_materials
            .extend(other.triangle_materials.iter().map(|m| m + material_offset));
        let sphere_offset = self.spheres.len() as u32;
        self.spheres.extend(other.spheres.iter().map(|s| Sphere {
            material: s.material + material_offset,
            ..*s
        }));
        self.materials
            .extend(other.materials.into_iter().map(|mut m| {
                if let crate::material::Surface::Textured(ref mut pbr) = m.surface {
                    pbr.base_color_texture = pbr.base_color_texture.map(|t| t + texture_offset);
                    pbr.metallic_roughness_texture =
                        pbr.metallic_roughness_texture.map(|t| t + texture_offset);
                    pbr.specular_color_texture =
                        pbr.specular_color_texture.map(|t| t + texture_offset);
                    pbr.shininess_texture = pbr
                        .shininess_texture
                        .map(|(ns, t)| (ns, t + texture_offset));
                }
                m.maps = m.maps.with_texture_offset(texture_offset);
                m
            }));
        self.textures.extend(other.textures);
        self.lights
            .extend(other.lights.into_iter().map(|l| match l {
                Light::Area { triangle } => Light::Area {
                    triangle: triangle + triangle_offset,
                },
                Light::Sphere { sphere } => Light::Sphere {
                    sphere: sphere + sphere_offset,
                },
                Light::EnvironmentMap { map } => Light::EnvironmentMap {
                    map: map + map_offset,
                },
                other => other,
            }));
        self.environment_maps.extend(other.environment_maps);
        self.report.degenerate_triangles += other.report.degenerate_triangles;
        self.report.non_manifold_edges += other.report.non_manifold_edges;
        self.report.warnings.extend(other.report.warnings);
    }

    /// The finished scene: area lights for emissive triangles, non-manifold
    /// edges counted, and `camera` (or one framing the geometry).
    pub(crate) fn finish(
        mut self,
        camera: Option<Camera>,
        resolution: glam::UVec2,
        render: RenderSettings,
    ) -> Scene {
        self.lights
            .retain(|l| !matches!(l, Light::Area { .. } | Light::Sphere { .. }));
        for (i, &m) in self.triangle_materials.iter().enumerate() {
            if self.materials[m as usize].is_emissive() {
                self.lights.push(Light::Area { triangle: i as u32 });
            }
        }
        for (i, s) in self.spheres.iter().enumerate() {
            if self.materials[s.material as usize].is_emissive() {
                self.lights.push(Light::Sphere { sphere: i as u32 });
            }
        }
        self.report.non_manifold_edges = count_non_manifold_edges(&self.triangles);
        if !self.tangents.is_empty() {
            self.tangents.resize(self.triangles.len(), [Vec4::ZERO; 3]);
        }
        // An empty scene is refused or warned about by `validate`.
        let (min, max) = bounds_with_spheres(&self.triangles, &self.spheres);
        let camera = camera.unwrap_or_else(|| Camera::framing(min, max, resolution));
        Scene {
            triangles: self.triangles,
            normals: self.normals,
            uvs: self.uvs,
            tangents: self.tangents,
            triangle_materials: self.triangle_materials,
            spheres: self.spheres,
            materials: self.materials,
            textures: self.textures,
            lights: self.lights,
            environment_maps: self.environment_maps,
            camera,
            render,
            report: self.report,
        }
    }
}

/// Edges (by exact vertex positions) used by more than two triangles.
fn count_non_manifold_edges(triangles: &[[Vec3; 3]]) -> usize {
    use std::collections::HashMap;
    let key = |v: Vec3| v.to_array().map(f32::to_bits);
    let mut uses: HashMap<([u32; 3], [u32; 3]), u32> =
        HashMap::with_capacity(triangles.len() * 3 / 2);
    for t in triangles {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            let (ka, kb) = (key(a), key(b));
            *uses
                .entry(if ka < kb { (ka, kb) } else { (kb, ka) })
                .or_default() += 1;
        }
    }
    uses.values().filter(|&&n| n > 2).count()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Found by `cargo xtask stability`: a quad 5e9 wide was dropped as
    /// degenerate because |cross|^2 overflowed f32.
    #[test]
    fn huge_triangles_are_not_degenerate() {
        let t = [
            Vec3::ZERO,
            Vec3::new(5e9, 0.0, 0.0),
            Vec3::new(0.0, 0.0, -5e9),
        ];
        assert_eq!(triangle_normal(&t), Some(Vec3::Y));
        assert!((triangle_cross(&t).length() * 0.5 - 1.25e19).abs() < 1e6);
        assert_eq!(triangle_normal(&[Vec3::ONE; 3]), None);
    }
}
