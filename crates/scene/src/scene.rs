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
///
/// Triangles index shared vertices (a mesh as the file indexes it: OBJ's
/// `v/vt/vn` triples, glTF's vertices), so a vertex's position, normal and
/// uv are stored once, not once per corner. Every vertex belongs to a
/// triangle.
#[derive(Clone, Debug)]
pub struct Scene {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Shading normal per vertex (unit), or zero where the triangles
    /// meeting there use their geometric normal (the file gives none, or
    /// one of zero length). Empty when every vertex is such a one
    /// ([`Scene::shading_normals`]).
    pub normals: Vec<Vec3>,
    /// Texture coordinates per vertex. Empty when every one is zero (the
    /// file has none) ([`Scene::triangle_uvs`]).
    pub uvs: Vec<Vec2>,
    /// Tangents per vertex from the file (glTF TANGENT: xyz, w the
    /// bitangent's sign), for normal maps. Empty when no file gives any;
    /// zero for vertices without (their tangent is derived from the uvs).
    pub tangents: Vec<Vec4>,
    /// The vertices of each triangle, counter-clockwise seen from the front.
    pub triangles: Vec<[u32; 3]>,
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
        bounds_with_spheres(&self.positions, &self.spheres)
    }

    /// The corners of triangle `i`.
    #[inline]
    pub fn triangle(&self, i: usize) -> [Vec3; 3] {
        self.triangles[i].map(|v| self.positions[v as usize])
    }

    /// Area of triangle `i`.
    pub fn triangle_area(&self, i: usize) -> f32 {
        (0.5 * triangle_cross(&self.triangle(i)).length()) as f32
    }

    /// Geometric normal of triangle `i` (unit, from the winding; zero for a
    /// degenerate triangle).
    pub fn geometric_normal(&self, i: usize) -> Vec3 {
        triangle_normal(&self.triangle(i)).unwrap_or(Vec3::ZERO)
    }

    /// The shading normals at the corners of triangle `i`, whose geometric
    /// normal is `geometric` ([`Scene::geometric_normal`]; callers keep it).
    #[inline]
    pub fn shading_normals(&self, i: usize, geometric: Vec3) -> [Vec3; 3] {
        if self.normals.is_empty() {
            return [geometric; 3];
        }
        self.triangles[i].map(|v| {
            let n = self.normals[v as usize];
            if n == Vec3::ZERO { geometric } else { n }
        })
    }

    /// The texture coordinates at the corners of triangle `i`.
    #[inline]
    pub fn triangle_uvs(&self, i: usize) -> [Vec2; 3] {
        if self.uvs.is_empty() {
            return [Vec2::ZERO; 3];
        }
        self.triangles[i].map(|v| self.uvs[v as usize])
    }

    /// The file's tangents at the corners of triangle `i` (zero where it
    /// gives none).
    pub fn corner_tangents(&self, i: usize) -> [Vec4; 3] {
        if self.tangents.is_empty() {
            return [Vec4::ZERO; 3];
        }
        self.triangles[i].map(|v| self.tangents[v as usize])
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

/// [`bounds_of`] the vertices, grown by the spheres' boxes.
pub(crate) fn bounds_with_spheres(positions: &[Vec3], spheres: &[Sphere]) -> (Vec3, Vec3) {
    let (mut min, mut max) = bounds_of(positions);
    if positions.is_empty() && !spheres.is_empty() {
        (min, max) = (Vec3::INFINITY, Vec3::NEG_INFINITY);
    }
    for s in spheres {
        min = min.min(s.center - Vec3::splat(s.radius));
        max = max.max(s.center + Vec3::splat(s.radius));
    }
    (min, max)
}

pub(crate) fn bounds_of(positions: &[Vec3]) -> (Vec3, Vec3) {
    let mut min = Vec3::splat(f32::INFINITY);
    let mut max = Vec3::splat(f32::NEG_INFINITY);
    for v in positions {
        min = min.min(*v);
        max = max.max(*v);
    }
    if positions.is_empty() {
        (Vec3::ZERO, Vec3::ZERO)
    } else {
        (min, max)
    }
}

/// No scene vertex yet for a file's vertex ([`SceneBuilder::begin_shared_vertices`]).
const UNSHARED: u32 = u32::MAX;

/// Whether two vectors are the same bit for bit (`==` equates 0 and -0).
fn same<const N: usize>(a: [f32; N], b: [f32; N]) -> bool {
    a.map(f32::to_bits) == b.map(f32::to_bits)
}

/// Geometry and materials as loaders produce them, before lights and camera.
/// Vertex arrays are parallel (`tangents` only from the first vertex with
/// one on; zero = none, for normals and tangents).
#[derive(Clone, Debug, Default)]
pub struct SceneBuilder {
    pub(crate) positions: Vec<Vec3>,
    pub(crate) normals: Vec<Vec3>,
    pub(crate) uvs: Vec<Vec2>,
    pub(crate) tangents: Vec<Vec4>,
    pub(crate) triangles: Vec<[u32; 3]>,
    pub(crate) triangle_materials: Vec<u32>,
    pub(crate) spheres: Vec<Sphere>,
    pub(crate) materials: Vec<Material>,
    pub(crate) textures: Vec<Texture>,
    pub(crate) lights: Vec<Light>,
    pub(crate) environment_maps: Vec<EnvironmentMap>,
    pub(crate) report: LoadReport,
    /// The scene vertex of each of the file's vertices in the current mesh
    /// ([`UNSHARED`] before its first use).
    shared: Vec<u32>,
}

/// One corner of a triangle as a loader gives it.
#[derive(Clone, Copy)]
struct Corner {
    position: Vec3,
    /// Unit, or zero for the geometric normal.
    normal: Vec3,
    uv: Vec2,
    tangent: Vec4,
}

impl SceneBuilder {
    /// Reserves room for `triangles` more triangles and `vertices` more
    /// vertices (loaders that know their counts: a large mesh's arrays
    /// then never move, see `obj::load`). Exact on empty arrays, amortized
    /// (`Vec::reserve`) when called again, as per glTF primitive.
    pub(crate) fn reserve(&mut self, triangles: usize, vertices: usize) {
        self.triangles.reserve(triangles);
        self.triangle_materials.reserve(triangles);
        self.positions.reserve(vertices);
        self.normals.reserve(vertices);
        self.uvs.reserve(vertices);
    }

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

    /// Adds one triangle with vertices of its own. Non-finite positions,
    /// normals or uvs are an error naming `element`; zero-area triangles are
    /// skipped and counted; missing or zero shading normals fall back to the
    /// geometric normal.
    pub(crate) fn add_triangle(
        &mut self,
        path: &Path,
        element: &dyn Fn() -> String,
        positions: [Vec3; 3],
        normals: Option<[Vec3; 3]>,
        uvs: Option<[Vec2; 3]>,
        material: u32,
    ) -> Result<(), SceneError> {
        self.add_corners(path, element, None, positions, normals, uvs, None, material)
    }

    /// Starts a mesh whose file indexes `count` vertices: the triangles of
    /// [`SceneBuilder::add_indexed_triangle`] until the next call share
    /// them.
    pub(crate) fn begin_shared_vertices(&mut self, count: usize) {
        self.shared.clear();
        self.shared.resize(count, UNSHARED);
    }

    /// [`SceneBuilder::add_triangle`] for the triangle of the current mesh
    /// (see [`SceneBuilder::begin_shared_vertices`]) whose corners are the
    /// file's vertices `keys`: a corner equal to the one first added for its
    /// key (bit for bit) reuses that vertex. `tangents`: the file's, for
    /// normal maps.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn add_indexed_triangle(
        &mut self,
        path: &Path,
        element: &dyn Fn() -> String,
        keys: [u32; 3],
        positions: [Vec3; 3],
        normals: Option<[Vec3; 3]>,
        uvs: Option<[Vec2; 3]>,
        tangents: Option<[Vec4; 3]>,
        material: u32,
    ) -> Result<(), SceneError> {
        self.add_corners(
            path,
            element,
            Some(keys),
            positions,
            normals,
            uvs,
            tangents,
            material,
        )
    }

    #[allow(clippy::too_many_arguments)]
    fn add_corners(
        &mut self,
        path: &Path,
        element: &dyn Fn() -> String,
        keys: Option<[u32; 3]>,
        positions: [Vec3; 3],
        normals: Option<[Vec3; 3]>,
        uvs: Option<[Vec2; 3]>,
        tangents: Option<[Vec4; 3]>,
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
        if triangle_normal(&positions).is_none() {
            self.report.degenerate_triangles += 1;
            return Ok(());
        }
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
        let mut triangle = [0; 3];
        for k in 0..3 {
            let corner = Corner {
                position: positions[k],
                // Zero stands for the triangle's geometric normal
                // (`Scene::shading_normals`).
                normal: normals
                    .map_or(Vec3::ZERO, |ns| ns[k].try_normalize().unwrap_or(Vec3::ZERO)),
                uv: uvs.map_or(Vec2::ZERO, |t| t[k]),
                tangent: tangents.map_or(Vec4::ZERO, |t| t[k]),
            };
            // The file's vertex, if the current mesh indexes it.
            let slot = keys
                .map(|keys| keys[k] as usize)
                .filter(|&slot| slot < self.shared.len());
            let reused = slot
                .map(|slot| self.shared[slot])
                .filter(|&v| v != UNSHARED && self.vertex_is(v, &corner));
            triangle[k] = match reused {
                Some(v) => v,
                None => {
                    let v = self.push_vertex(&corner);
                    if let Some(slot) = slot.filter(|&slot| self.shared[slot] == UNSHARED) {
                        self.shared[slot] = v;
                    }
                    v
                }
            };
        }
        self.triangles.push(triangle);
        self.triangle_materials.push(material);
        Ok(())
    }

    /// Whether vertex `v` holds `corner`.
    fn vertex_is(&self, v: u32, corner: &Corner) -> bool {
        let v = v as usize;
        let tangent = self.tangents.get(v).copied().unwrap_or(Vec4::ZERO);
        same(self.positions[v].to_array(), corner.position.to_array())
            && same(self.normals[v].to_array(), corner.normal.to_array())
            && same(self.uvs[v].to_array(), corner.uv.to_array())
            && same(tangent.to_array(), corner.tangent.to_array())
    }

    /// Appends `corner` as a new vertex and returns its index.
    fn push_vertex(&mut self, corner: &Corner) -> u32 {
        let v = self.positions.len();
        assert!(
            u32::try_from(v).is_ok_and(|v| v < UNSHARED),
            "a scene holds fewer than u32::MAX vertices"
        );
        self.positions.push(corner.position);
        self.normals.push(corner.normal);
        self.uvs.push(corner.uv);
        if corner.tangent != Vec4::ZERO || !self.tangents.is_empty() {
            self.tangents.resize(v, Vec4::ZERO);
            self.tangents.push(corner.tangent);
        }
        v as u32
    }

    /// Adds an analytic sphere. A non-finite centre or axis, or a radius
    /// that is not finite and positive, is an error naming `element`.
    pub(crate) fn add_sphere(
        &mut self,
        path: &Path,
        element: &str,
        sphere: Sphere,
    ) -> Result<(), SceneError> {
        sphere
            .check()
            .map_err(|e| SceneError::invalid(path, element.to_owned(), e))?;
        self.spheres.push(sphere);
        Ok(())
    }

    /// Appends everything of `other`, re-indexing its vertices, materials
    /// and textures.
    pub(crate) fn append(&mut self, mut other: SceneBuilder) {
        let material_offset = self.materials.len() as u32;
        let texture_offset = self.textures.len();
        let triangle_offset = self.triangles.len() as u32;
        let map_offset = self.environment_maps.len() as u32;
        if self.positions.is_empty() && self.triangles.is_empty() {
            // The first model: its arrays move (a large mesh is not copied;
            // a copy also left the original's space resident under it: 35
            // bytes per triangle of a million-triangle glTF's peak).
            self.positions = std::mem::take(&mut other.positions);
            self.normals = std::mem::take(&mut other.normals);
            self.uvs = std::mem::take(&mut other.uvs);
            self.tangents = std::mem::take(&mut other.tangents);
            self.triangles = std::mem::take(&mut other.triangles);
        } else {
            let vertex_offset = self.positions.len() as u32;
            if !(self.tangents.is_empty() && other.tangents.is_empty()) {
                self.tangents.resize(self.positions.len(), Vec4::ZERO);
                other.tangents.resize(other.positions.len(), Vec4::ZERO);
                self.tangents.append(&mut other.tangents);
            }
            self.positions.append(&mut other.positions);
            self.normals.append(&mut other.normals);
            self.uvs.append(&mut other.uvs);
            self.triangles.extend(
                other
                    .triangles
                    .drain(..)
                    .map(|t| t.map(|v| v + vertex_offset)),
            );
        }
        if self.triangle_materials.is_empty() {
            self.triangle_materials = std::mem::take(&mut other.triangle_materials);
            for m in &mut self.triangle_materials {
                *m += material_offset;
            }
        } else {
            self.triangle_materials
                .extend(other.triangle_materials.iter().map(|m| m + material_offset));
        }
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
        // Attributes no vertex has are not stored (a mesh without normals
        // or uvs is positions and indices only).
        if self.normals.iter().all(|&n| n == Vec3::ZERO) {
            self.normals = Vec::new();
        }
        if self.uvs.iter().all(|uv| same(uv.to_array(), [0.0; 2])) {
            self.uvs = Vec::new();
        }
        if !self.tangents.is_empty() {
            self.tangents.resize(self.positions.len(), Vec4::ZERO);
        }
        // After the unused attributes are freed: the edge map is the peak
        // of a large mesh's load.
        self.report.non_manifold_edges = count_non_manifold_edges(&self.positions, &self.triangles);
        // An empty scene is refused or warned about by `validate`.
        let (min, max) = bounds_with_spheres(&self.positions, &self.spheres);
        let camera = camera.unwrap_or_else(|| Camera::framing(min, max, resolution));
        Scene {
            positions: self.positions,
            normals: self.normals,
            uvs: self.uvs,
            tangents: self.tangents,
            triangles: self.triangles,
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
fn count_non_manifold_edges(positions: &[Vec3], triangles: &[[u32; 3]]) -> usize {
    use std::collections::HashMap;
    let key = |v: Vec3| v.to_array().map(f32::to_bits);
    let mut uses: HashMap<([u32; 3], [u32; 3]), u32> =
        HashMap::with_capacity(triangles.len() * 3 / 2);
    for t in triangles {
        let t = t.map(|v| positions[v as usize]);
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

    /// Corners with the same key and the same data share a vertex; a
    /// corner whose data differ gets its own; a zero normal stands for the
    /// geometric one; attributes no vertex has are not stored.
    #[test]
    fn indexed_triangles_share_vertices() {
        let path = Path::new("t.obj");
        let element = || String::from("t");
        let p = [Vec3::ZERO, Vec3::X, Vec3::Y, Vec3::ONE];
        let mut b = SceneBuilder::default();
        b.begin_shared_vertices(4);
        for keys in [[0u32, 1, 2], [1, 3, 2]] {
            let positions = keys.map(|k| p[k as usize]);
            b.add_indexed_triangle(path, &element, keys, positions, None, None, None, 0)
                .unwrap();
        }
        // Same key, different normal: a vertex of its own.
        let normals = Some([Vec3::Z, Vec3::ZERO, Vec3::Z]);
        b.add_indexed_triangle(
            path,
            &element,
            [0, 1, 2],
            [p[0], p[1], p[2]],
            normals,
            None,
            None,
            0,
        )
        .unwrap();
        b.materials.push(crate::obj::default_material());
        let scene = b.finish(None, glam::UVec2::new(4, 4), RenderSettings::default());
        assert_eq!(scene.triangles[..2], [[0, 1, 2], [1, 3, 2]]);
        assert_eq!(scene.positions.len(), 6);
        assert_eq!(scene.triangles[2], [4, 1, 5]);
        let g = scene.geometric_normal(2);
        assert_eq!(scene.shading_normals(2, g), [Vec3::Z, g, Vec3::Z]);
        assert!(scene.uvs.is_empty() && scene.tangents.is_empty());
        assert_eq!(scene.triangle_uvs(1), [Vec2::ZERO; 3]);
    }
}
