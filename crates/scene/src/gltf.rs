//! glTF 2.0 loading (`.gltf` with external or embedded buffers, and `.glb`)
//! with the `gltf` crate. Material mapping: see the `material` module docs.
//!
//! Photometric light units are read as radiometric ones: a point or spot
//! light of I candela becomes I W/sr, a directional light of E lux E W/m^2.

use std::collections::HashMap;
use std::path::Path;

use glam::{Mat3, Mat4, Vec2, Vec3};
use gltf::khr_lights_punctual::Kind;
use microfacet::{MicrofacetModel, NdfKind, Shadowing};

use crate::camera::CameraSpec;
use crate::error::SceneError;
use crate::light::Light;
use crate::material::{Material, Surface, TexturedPbr, metal_rough_surface};
use crate::scene::SceneBuilder;
use crate::texture::{Texture, Wrap};

/// What a glTF file contributes: geometry, materials, lights and its camera.
pub struct GltfScene {
    /// Geometry, materials, textures and punctual lights.
    pub builder: SceneBuilder,
    /// The chosen camera, if the file has one.
    pub camera: Option<CameraSpec>,
}

/// Loads `path`; `camera_name` chooses a camera by name (default: the first
/// camera met walking the scene's nodes).
pub fn load(
    path: &Path,
    camera_name: Option<&str>,
    _policy: &crate::paths::ReferencePolicy,
) -> Result<GltfScene, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| map_error(path, e))?;
    // gltf-json 1.4.1's validation indexes the POSITION accessor without a
    // bounds check (a panic on malformed files): check it first, then validate.
    check_position_accessors(path, gltf.document.as_json())?;
    let document =
        gltf::Document::from_json(gltf.document.into_json()).map_err(|e| map_error(path, e))?;
    let directory = path.parent().unwrap_or(Path::new("."));
    check_external_files(path, directory, &document)?;
    let buffers = gltf::import_buffers(&document, Some(directory), gltf.blob)
        .map_err(|e| map_error(path, e))?;
    let uses_textures = document.materials().any(|m| {
        m.pbr_metallic_roughness().base_color_texture().is_some()
            || m.pbr_metallic_roughness()
                .metallic_roughness_texture()
                .is_some()
    });
    let images = if uses_textures {
        gltf::import_images(&document, Some(directory), &buffers).map_err(|e| map_error(path, e))?
    } else {
        Vec::new()
    };

    let mut builder = SceneBuilder::default();
    let mut loader = Loader {
        path,
        buffers: &buffers,
        images: &images,
        builder: &mut builder,
        materials: HashMap::new(),
        textures: HashMap::new(),
        cameras: Vec::new(),
    };
    let scene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| SceneError::malformed(path, "the file has no scene"))?;
    for node in scene.nodes() {
        loader.visit(&node, Mat4::IDENTITY, 0)?;
    }
    let cameras = std::mem::take(&mut loader.cameras);
    let camera = choose_camera(path, cameras, camera_name)?;
    Ok(GltfScene { builder, camera })
}

/// Nodes deeper than this are refused: glTF forbids cycles, but a malformed
/// file could still send the traversal into one.
const MAX_NODE_DEPTH: usize = 256;

struct Loader<'a> {
    path: &'a Path,
    buffers: &'a [gltf::buffer::Data],
    images: &'a [gltf::image::Data],
    builder: &'a mut SceneBuilder,
    /// glTF material index (None = default material) -> scene material.
    materials: HashMap<Option<usize>, u32>,
    /// (glTF texture index, sRGB) -> scene texture.
    textures: HashMap<(usize, bool), usize>,
    /// Cameras met: (name, node index, camera, world transform).
    cameras: Vec<(Option<String>, usize, Result<CameraSpec, String>)>,
}

impl Loader<'_> {
    fn visit(&mut self, node: &gltf::Node, parent: Mat4, depth: usize) -> Result<(), SceneError> {
        if depth > MAX_NODE_DEPTH {
            return Err(SceneError::malformed(
                self.path,
                format!(
                    "node {}: hierarchy deeper than {MAX_NODE_DEPTH} (a cycle?)",
                    node.index()
                ),
            ));
        }
        let local = Mat4::from_cols_array_2d(&node.transform().matrix());
        let world = parent * local;
        if !world.is_finite() {
            return Err(SceneError::invalid(
                self.path,
                format!("node {}", node.index()),
                "transform is not finite",
            ));
        }
        if let Some(mesh) = node.mesh() {
            self.add_mesh(&mesh, world)?;
        }
        if let Some(camera) = node.camera() {
            let spec = camera_spec(&camera, world);
            self.cameras
                .push((camera.name().map(str::to_string), node.index(), spec));
        }
        if let Some(light) = node.light() {
            self.add_light(&light, world);
        }
        for child in node.children() {
            self.visit(&child, world, depth + 1)?;
        }
        Ok(())
    }

    fn add_mesh(&mut self, mesh: &gltf::Mesh, world: Mat4) -> Result<(), SceneError> {
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        let flips = Mat3::from_mat4(world).determinant() < 0.0;
        for primitive in mesh.primitives() {
            let element = format!(
                "mesh {} (\"{}\"), primitive {}",
                mesh.index(),
                mesh.name().unwrap_or(""),
                primitive.index()
            );
            if primitive.mode() != gltf::mesh::Mode::Triangles {
                self.builder.report.warnings.push(format!(
                    "{}: {element}: mode {:?} skipped (only triangles are rendered)",
                    self.path.display(),
                    primitive.mode()
                ));
                continue;
            }
            let material = self.material(&primitive.material())?;
            let reader = primitive.reader(|b| self.buffers.get(b.index()).map(|d| &d.0[..]));
            let positions: Vec<Vec3> = reader
                .read_positions()
                .ok_or_else(|| {
                    SceneError::malformed(self.path, format!("{element}: no POSITION attribute"))
                })?
                .map(|p| world.transform_point3(Vec3::from_array(p)))
                .collect();
            let normals: Option<Vec<Vec3>> = reader
                .read_normals()
                .map(|it| it.map(|n| normal_matrix * Vec3::from_array(n)).collect());
            let uvs: Option<Vec<Vec2>> = reader
                .read_tex_coords(0)
                .map(|t| t.into_f32().map(Vec2::from_array).collect());
            let indices: Vec<u32> = match reader.read_indices() {
                Some(i) => i.into_u32().collect(),
                None => (0..positions.len() as u32).collect(),
            };
            if !indices.len().is_multiple_of(3) {
                return Err(SceneError::malformed(
                    self.path,
                    format!(
                        "{element}: {} indices is not a multiple of 3",
                        indices.len()
                    ),
                ));
            }
            for attribute in [normals.as_ref().map(Vec::len), uvs.as_ref().map(Vec::len)]
                .into_iter()
                .flatten()
            {
                if attribute != positions.len() {
                    return Err(SceneError::malformed(
                        self.path,
                        format!(
                            "{element}: attribute count {attribute} differs from {} positions",
                            positions.len()
                        ),
                    ));
                }
            }
            for (t, tri) in indices.chunks_exact(3).enumerate() {
                let mut ids = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
                if flips {
                    ids.swap(1, 2);
                }
                if let Some(&bad) = ids.iter().find(|&&i| i >= positions.len()) {
                    return Err(SceneError::malformed(
                        self.path,
                        format!(
                            "{element}: triangle {t} uses vertex {bad}, but there are {}",
                            positions.len()
                        ),
                    ));
                }
                let element = || format!("{element}, triangle {t}");
                let p = ids.map(|i| positions[i]);
                let n = normals.as_ref().map(|ns| ids.map(|i| ns[i]));
                let uv = uvs.as_ref().map(|us| ids.map(|i| us[i]));
                self.builder
                    .add_triangle(self.path, &element, p, n, uv, material)?;
            }
        }
        Ok(())
    }

    fn material(&mut self, m: &gltf::Material) -> Result<u32, SceneError> {
        if let Some(&id) = self.materials.get(&m.index()) {
            return Ok(id);
        }
        let element = match m.index() {
            Some(i) => format!("material {i} (\"{}\")", m.name().unwrap_or("")),
            None => "default material".to_string(),
        };
        let invalid = |message: String| SceneError::invalid(self.path, element.clone(), message);
        let pbr = m.pbr_metallic_roughness();
        let base = pbr.base_color_factor();
        let (metallic, roughness) = (pbr.metallic_factor(), pbr.roughness_factor());
        for (name, v) in [("metallicFactor", metallic), ("roughnessFactor", roughness)] {
            if !(0.0..=1.0).contains(&v) {
                return Err(invalid(format!("{name} must be in [0, 1], got {v}")));
            }
        }
        let base = Vec3::new(base[0], base[1], base[2]);
        if !base.is_finite() || base.min_element() < 0.0 {
            return Err(invalid(format!(
                "baseColorFactor must be finite and non-negative, got {base}"
            )));
        }
        let (ndf, shadowing) = microfacet_choice(m).map_err(invalid)?;
        let transmission = m.transmission().map_or(0.0, |t| t.transmission_factor());
        let surface = if transmission > 0.0 {
            let ior = m.ior().unwrap_or(1.5);
            if !(ior > 0.0 && ior.is_finite()) {
                return Err(invalid(format!("KHR_materials_ior must be > 0, got {ior}")));
            }
            Surface::Dielectric {
                model: MicrofacetModel::new(ndf, roughness * roughness, shadowing),
                ior,
            }
        } else {
            let base_texture = pbr
                .base_color_texture()
                .map(|t| self.texture(&t.texture(), true, &element))
                .transpose()?;
            let mr_texture = pbr
                .metallic_roughness_texture()
                .map(|t| self.texture(&t.texture(), false, &element))
                .transpose()?;
            if base_texture.is_some() || mr_texture.is_some() {
                Surface::Textured(TexturedPbr {
                    base_color: base,
                    base_color_texture: base_texture,
                    metallic,
                    roughness,
                    metallic_roughness_texture: mr_texture,
                    ndf,
                    shadowing,
                })
            } else {
                metal_rough_surface(base, metallic, roughness, ndf, shadowing)
            }
        };
        let emission = Vec3::from_array(m.emissive_factor()) * m.emissive_strength().unwrap_or(1.0);
        if !emission.is_finite() || emission.min_element() < 0.0 {
            return Err(invalid(format!(
                "emission must be finite and non-negative, got {emission}"
            )));
        }
        let name = m.name().map_or_else(|| element.clone(), str::to_string);
        let id = self.builder.add_material(Material {
            name,
            surface,
            emission,
        });
        self.materials.insert(m.index(), id);
        Ok(id)
    }

    fn texture(
        &mut self,
        texture: &gltf::Texture,
        srgb: bool,
        element: &str,
    ) -> Result<usize, SceneError> {
        if let Some(&id) = self.textures.get(&(texture.index(), srgb)) {
            return Ok(id);
        }
        let image_index = texture.source().index();
        let image = self.images.get(image_index).ok_or_else(|| {
            SceneError::malformed(
                self.path,
                format!(
                    "{element}: texture {} has no decoded image",
                    texture.index()
                ),
            )
        })?;
        use gltf::image::Format::*;
        let channels = match image.format {
            R8 => 1,
            R8G8 => 2,
            R8G8B8 => 3,
            R8G8B8A8 => 4,
            other => {
                return Err(SceneError::unsupported(
                    self.path,
                    format!(
                        "{element}: image {image_index} has pixel format {other:?}; 8-bit images only"
                    ),
                ));
            }
        };
        let mut t = Texture::from_u8(image.width, image.height, channels, &image.pixels, srgb)
            .ok_or_else(|| {
                SceneError::malformed(
                    self.path,
                    format!("{element}: image {image_index} is truncated"),
                )
            })?;
        let sampler = texture.sampler();
        t.wrap_u = wrap(sampler.wrap_s());
        t.wrap_v = wrap(sampler.wrap_t());
        let id = self.builder.add_texture(t);
        self.textures.insert((texture.index(), srgb), id);
        Ok(id)
    }

    fn add_light(&mut self, light: &gltf::khr_lights_punctual::Light, world: Mat4) {
        let color = Vec3::from_array(light.color()) * light.intensity();
        let position = world.transform_point3(Vec3::ZERO);
        let direction = world
            .transform_vector3(Vec3::NEG_Z)
            .normalize_or(Vec3::NEG_Z);
        let l = match light.kind() {
            Kind::Point => Light::Point {
                position,
                intensity: color,
            },
            Kind::Directional => Light::Directional {
                direction,
                irradiance: color,
            },
            Kind::Spot {
                inner_cone_angle,
                outer_cone_angle,
            } => Light::Spot {
                position,
                direction,
                intensity: color,
                cos_inner: inner_cone_angle.cos(),
                cos_outer: outer_cone_angle.cos(),
            },
        };
        self.builder.lights.push(l);
    }
}

fn check_position_accessors(path: &Path, root: &gltf::json::Root) -> Result<(), SceneError> {
    use gltf::json::validation::Checked;
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, primitive) in mesh.primitives.iter().enumerate() {
            let position = primitive
                .attributes
                .get(&Checked::Valid(gltf::json::mesh::Semantic::Positions));
            if let Some(index) = position
                .map(|i| i.value())
                .filter(|&i| i >= root.accessors.len())
            {
                return Err(SceneError::malformed(
                    path,
                    format!(
                        "meshes[{m}].primitives[{p}].attributes.POSITION: accessor {index} does not exist ({} accessors)",
                        root.accessors.len()
                    ),
                ));
            }
        }
    }
    Ok(())
}

/// Names a missing external buffer or image file (the `gltf` crate's own
/// error only says "No such file or directory").
fn check_external_files(
    path: &Path,
    directory: &Path,
    document: &gltf::Document,
) -> Result<(), SceneError> {
    let external = |uri: &str| !uri.starts_with("data:") && !directory.join(uri).is_file();
    for buffer in document.buffers() {
        if let gltf::buffer::Source::Uri(uri) = buffer.source()
            && external(uri)
        {
            return Err(SceneError::malformed(
                path,
                format!(
                    "buffer {}: file \"{uri}\" not found next to the glTF file",
                    buffer.index()
                ),
            ));
        }
    }
    for image in document.images() {
        if let gltf::image::Source::Uri { uri, .. } = image.source()
            && external(uri)
        {
            return Err(SceneError::malformed(
                path,
                format!(
                    "image {}: file \"{uri}\" not found next to the glTF file",
                    image.index()
                ),
            ));
        }
    }
    Ok(())
}

fn wrap(mode: gltf::texture::WrappingMode) -> Wrap {
    match mode {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
    }
}

/// The NDF and shadowing a material's `extras` choose (GGX and Smith by default).
fn microfacet_choice(m: &gltf::Material) -> Result<(NdfKind, Shadowing), String> {
    let Some(raw) = m.extras() else {
        return Ok((NdfKind::Ggx, Shadowing::Smith));
    };
    let extras: serde_json::Value =
        serde_json::from_str(raw.get()).map_err(|e| format!("extras: {e}"))?;
    let ndf = match extras.get("ndf").map(|v| v.as_str()) {
        None => NdfKind::Ggx,
        Some(Some(s)) => crate::parse_ndf(s).map_err(|e| format!("extras.ndf: {e}"))?,
        Some(None) => return Err("extras.ndf must be a string".into()),
    };
    let shadowing = match extras.get("shadowing").map(|v| v.as_str()) {
        None => Shadowing::Smith,
        Some(Some(s)) => crate::parse_shadowing(s).map_err(|e| format!("extras.shadowing: {e}"))?,
        Some(None) => return Err("extras.shadowing must be a string".into()),
    };
    Ok((ndf, shadowing))
}

fn camera_spec(camera: &gltf::Camera, world: Mat4) -> Result<CameraSpec, String> {
    match camera.projection() {
        gltf::camera::Projection::Perspective(p) => {
            let from = world.transform_point3(Vec3::ZERO);
            Ok(CameraSpec {
                from,
                at: from + world.transform_vector3(Vec3::NEG_Z),
                up: world.transform_vector3(Vec3::Y),
                vertical_fov_degrees: p.yfov().to_degrees(),
                aspect: p.aspect_ratio(),
            })
        }
        gltf::camera::Projection::Orthographic(_) => {
            Err("orthographic cameras are not supported".into())
        }
    }
}

fn choose_camera(
    path: &Path,
    cameras: Vec<(Option<String>, usize, Result<CameraSpec, String>)>,
    name: Option<&str>,
) -> Result<Option<CameraSpec>, SceneError> {
    let chosen = match name {
        Some(name) => Some(
            cameras
                .iter()
                .find(|(n, _, _)| n.as_deref() == Some(name))
                .ok_or_else(|| {
                    let names: Vec<String> = cameras
                        .iter()
                        .map(|(n, i, _)| {
                            n.clone().unwrap_or_else(|| format!("(unnamed, node {i})"))
                        })
                        .collect();
                    SceneError::malformed(
                        path,
                        format!(
                            "no camera named \"{name}\"; the file has: {}",
                            if names.is_empty() {
                                "none".into()
                            } else {
                                names.join(", ")
                            }
                        ),
                    )
                })?,
        ),
        None => cameras.first(),
    };
    match chosen {
        None => Ok(None),
        Some((n, node, Ok(spec))) => {
            let _ = (n, node);
            Ok(Some(*spec))
        }
        Some((n, node, Err(why))) => Err(SceneError::unsupported(
            path,
            format!(
                "camera \"{}\" (node {node}): {why}; choose a perspective camera by name or give one in a scene.toml",
                n.as_deref().unwrap_or("unnamed")
            ),
        )),
    }
}

fn map_error(path: &Path, e: gltf::Error) -> SceneError {
    match e {
        gltf::Error::Io(io) => SceneError::io(path, io),
        gltf::Error::Validation(errors) => {
            let list: Vec<String> = errors
                .iter()
                .take(5)
                .map(|(p, e)| format!("{p}: {e}"))
                .collect();
            let more = if errors.len() > 5 {
                format!(" (and {} more)", errors.len() - 5)
            } else {
                String::new()
            };
            let text = list.join("; ");
            if text.contains("extensionsRequired") {
                SceneError::unsupported(path, format!("{text}{more}"))
            } else {
                SceneError::malformed(path, format!("invalid glTF: {text}{more}"))
            }
        }
        other => SceneError::malformed(path, other.to_string()),
    }
}
