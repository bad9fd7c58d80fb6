//! glTF 2.0 loading (`.gltf` with external or embedded buffers, and `.glb`)
//! with the `gltf` crate. Material mapping: see the `material` module docs.
//!
//! Photometric light units are read as radiometric ones: a point or spot
//! light of I candela becomes I W/sr, a directional light of E lux E W/m^2.
//!
//! Hostile files: the `gltf` crate's readers trust the file, so every
//! accessor a triangle primitive reads is checked first (`validate`:
//! component type and shape per semantic, count, offsets, strides, bounds,
//! sparse indices), then index values, finite positions and normals, and the
//! numeric factors of materials and lights. Buffer and image files go through
//! the [`ReferencePolicy`](crate::paths::ReferencePolicy); a panic that still
//! escapes the crate becomes a [`SceneError`].
//!
//! Extensions (`extensions`): a file that requires one this loader does not
//! implement is refused, naming it; one that is only used is a warning naming
//! it and the materials that carry it (`LoadReport::ignored`, shown by `--explain`).

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{Mat3, Mat4, Vec2, Vec3, Vec4};
use gltf::khr_lights_punctual::Kind;
use microfacet::{NdfKind, Shadowing};

use crate::camera::{CameraSpec, FovAxis};
use crate::error::{SceneError, guarded, quoted};
use crate::light::Light;
use crate::material::{
    Alpha, Maps, Material, Medium, MetalRough, NormalMap, NormalMapKind, Surface, TexturedPbr,
    is_transmissive, metal_rough_surface, transmissive_surface,
};
use crate::scene::SceneBuilder;
use crate::texture::{Texture, UvTransform, Wrap};

mod extensions;
mod validate;

use validate::Semantic;

/// What a glTF file contributes: geometry, materials, lights and its camera.
pub struct GltfScene {
    /// Geometry, materials, textures and punctual lights.
    pub builder: SceneBuilder,
    /// The chosen camera, if the file has one.
    pub camera: Option<CameraSpec>,
}

/// Loads `path`; `camera_name` chooses a camera by name (default: the first
/// camera met walking the scene's nodes). Buffer and image files are
/// resolved through `policy`.
///
/// A panic inside the `gltf` crate (which trusts the file in places this
/// loader's checks may not cover) becomes a [`SceneError`] naming the file.
/// The default panic hook still prints its message to stderr: silencing it
/// would mean swapping the process-wide hook, which races with other threads.
pub fn load(
    path: &Path,
    camera_name: Option<&str>,
    policy: &crate::paths::ReferencePolicy,
) -> Result<GltfScene, SceneError> {
    guarded(path, "the glTF reader", || {
        load_unguarded(path, camera_name, policy)
    })
}

fn load_unguarded(
    path: &Path,
    camera_name: Option<&str>,
    policy: &crate::paths::ReferencePolicy,
) -> Result<GltfScene, SceneError> {
    let bytes = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    check_glb_lengths(path, &bytes)?;
    let gltf = gltf::Gltf::from_slice_without_validation(&bytes).map_err(|e| map_error(path, e))?;
    drop(bytes);
    // gltf-json 1.4.1's validation indexes the POSITION accessor without a
    // bounds check (a panic on malformed files): check it first, then validate.
    check_position_accessors(path, gltf.document.as_json())?;
    check_cameras(path, gltf.document.as_json())?;
    extensions::check_required(path, gltf.document.as_json())?;
    let ignored = extensions::ignored(gltf.document.as_json());
    let document =
        gltf::Document::from_json(gltf.document.into_json()).map_err(|e| map_error(path, e))?;
    let buffers = load_buffers(path, &document, gltf.blob, policy)?;
    validate::check_views(path, &document, &buffers)?;
    let uses_textures = document.materials().any(|m| {
        m.pbr_metallic_roughness().base_color_texture().is_some()
            || m.pbr_metallic_roughness()
                .metallic_roughness_texture()
                .is_some()
            || m.transmission()
                .is_some_and(|t| t.transmission_texture().is_some())
            || m.emissive_texture().is_some()
            || m.normal_texture().is_some()
    });
    let images = if uses_textures {
        load_images(path, &document, &buffers, policy)?
    } else {
        Vec::new()
    };

    let mut builder = SceneBuilder::default();
    for line in ignored {
        builder
            .report
            .warnings
            .push(format!("{}: {line}", path.display()));
        builder.report.ignored.push(line);
    }
    let mut loader = Loader {
        path,
        buffers: &buffers,
        images: &images,
        builder: &mut builder,
        materials: HashMap::new(),
        textures: HashMap::new(),
        cameras: Vec::new(),
        visited: vec![false; document.nodes().len()],
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

/// A binary glTF whose header or chunks declare more bytes than the file has
/// is truncated (the `gltf` crate only says "could not completely read the object").
fn check_glb_lengths(path: &Path, bytes: &[u8]) -> Result<(), SceneError> {
    if !bytes.starts_with(b"glTF") {
        return Ok(());
    }
    let truncated = |what: String| SceneError::malformed(path, format!("truncated .glb: {what}"));
    let len = bytes.len() as u64;
    let word = |at: u64| -> Option<u64> {
        let at = usize::try_from(at).ok()?;
        let b = bytes.get(at..at.checked_add(4)?)?;
        Some(u64::from(u32::from_le_bytes([b[0], b[1], b[2], b[3]])))
    };
    let Some(declared) = word(8) else {
        return Err(truncated(format!(
            "{len} bytes, shorter than the 12-byte header"
        )));
    };
    if declared > len {
        return Err(truncated(format!(
            "the header declares {declared} bytes, the file has {len}"
        )));
    }
    if declared < 12 {
        return Err(SceneError::malformed(
            path,
            format!("the .glb header declares {declared} bytes, less than its own 12"),
        ));
    }
    let mut offset = 12;
    while offset < declared {
        let Some(chunk) = word(offset) else {
            return Err(truncated(format!(
                "the chunk header at byte {offset} is cut (the file has {len} bytes)"
            )));
        };
        if offset + 8 + chunk > len {
            return Err(truncated(format!(
                "the chunk at byte {offset} declares {chunk} bytes, {} remain",
                len.saturating_sub(offset + 8)
            )));
        }
        offset += 8 + chunk;
    }
    Ok(())
}

/// The file a buffer's or image's relative `uri` names, through the
/// reference policy (percent-decoded as the `gltf` crate would, whose own
/// decoding panics on invalid UTF-8). Other schemes than `data:` are refused.
fn referenced_file(
    path: &Path,
    element: &str,
    uri: &str,
    policy: &crate::paths::ReferencePolicy,
) -> Result<PathBuf, SceneError> {
    if uri.contains(':') {
        return Err(SceneError::unsupported(
            path,
            format!(
                "{element}: URI {}: only relative paths and data: URIs are read",
                quoted(uri)
            ),
        ));
    }
    let decoded = percent_decode(uri).ok_or_else(|| {
        SceneError::malformed(
            path,
            format!(
                "{element}: URI {} is not valid percent-encoded UTF-8",
                quoted(uri)
            ),
        )
    })?;
    let folder = path.parent().unwrap_or(Path::new("."));
    if std::fs::symlink_metadata(folder.join(&decoded)).is_err() {
        return Err(SceneError::malformed(
            path,
            format!(
                "{element}: file {} not found next to the glTF file",
                quoted(&decoded)
            ),
        ));
    }
    policy.resolve(path, element, &decoded)
}

/// `%XX` escapes decoded (others kept as written); `None` if the result is not UTF-8.
fn percent_decode(uri: &str) -> Option<String> {
    let bytes = uri.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        let hex = |b: u8| (b as char).to_digit(16);
        if bytes[i] == b'%'
            && let (Some(h), Some(l)) = (
                bytes.get(i + 1).and_then(|&b| hex(b)),
                bytes.get(i + 2).and_then(|&b| hex(b)),
            )
        {
            out.push((h * 16 + l) as u8);
            i += 3;
        } else {
            out.push(bytes[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// Every buffer: the GLB binary chunk, a data: URI, or a file through the policy.
fn load_buffers(
    path: &Path,
    document: &gltf::Document,
    mut blob: Option<Vec<u8>>,
    policy: &crate::paths::ReferencePolicy,
) -> Result<Vec<gltf::buffer::Data>, SceneError> {
    let mut buffers = Vec::new();
    for buffer in document.buffers() {
        let element = format!("buffer {}", buffer.index());
        let data = match buffer.source() {
            gltf::buffer::Source::Uri(uri) if !uri.starts_with("data:") => {
                let file = referenced_file(path, &element, uri, policy)?;
                let bytes = std::fs::read(&file).map_err(|e| {
                    SceneError::malformed(
                        path,
                        format!("{element}: cannot read {}: {e}", quoted(uri)),
                    )
                })?;
                gltf::buffer::Data(bytes)
            }
            source => gltf::buffer::Data::from_source_and_blob(source, None, &mut blob)
                .map_err(|e| SceneError::malformed(path, format!("{element}: {e}")))?,
        };
        if data.0.len() < buffer.length() {
            return Err(SceneError::malformed(
                path,
                format!(
                    "{element}: byteLength {} but only {} bytes of data",
                    buffer.length(),
                    data.0.len()
                ),
            ));
        }
        let mut data = data;
        while !data.0.len().is_multiple_of(4) {
            data.0.push(0);
        }
        buffers.push(data);
    }
    Ok(buffers)
}

/// Every image decoded; a failure names the image (index and URI or bufferView).
fn load_images(
    path: &Path,
    document: &gltf::Document,
    buffers: &[gltf::buffer::Data],
    policy: &crate::paths::ReferencePolicy,
) -> Result<Vec<gltf::image::Data>, SceneError> {
    let directory = path.parent().unwrap_or(Path::new("."));
    document
        .images()
        .map(|image| {
            let label = match image.source() {
                gltf::image::Source::Uri { uri, .. } if uri.starts_with("data:") => {
                    format!("image {} (data: URI)", image.index())
                }
                gltf::image::Source::Uri { uri, .. } => {
                    format!("image {} ({})", image.index(), quoted(uri))
                }
                gltf::image::Source::View { view, .. } => {
                    format!("image {} (bufferView {})", image.index(), view.index())
                }
            };
            if let gltf::image::Source::Uri { uri, .. } = image.source()
                && !uri.starts_with("data:")
            {
                referenced_file(path, &format!("image {}", image.index()), uri, policy)?;
            }
            gltf::image::Data::from_source(image.source(), Some(directory), buffers).map_err(|e| {
                let why = e.to_string();
                SceneError::malformed(path, format!("{label}: cannot decode: {}", quoted(&why)))
            })
        })
        .collect()
}

/// The accessors a triangle primitive reads: (index, label for messages).
struct PrimitiveAccessors {
    position: (usize, String),
    normal: Option<(usize, String)>,
    tex_coord: Option<(usize, String)>,
    tangent: Option<(usize, String)>,
    indices: Option<(usize, String)>,
}

/// A triangle primitive as read from its accessors.
struct PrimitiveData {
    /// Positions, in object space.
    positions: Vec<Vec3>,
    /// Normals, in object space.
    normals: Option<Vec<Vec3>>,
    /// Texture coordinates (set 0).
    uvs: Option<Vec<Vec2>>,
    /// Tangents, in world space; read only under a normal map.
    tangents: Option<Vec<Vec4>>,
    /// Three vertex indices per triangle.
    indices: Vec<u32>,
}
/// `(NaN, 0, 1) ` for a message.
fn fmt_vec(v: Vec3) -> String {
    format!("({}, {}, {}) ", v.x, v.y, v.z)
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
    /// (glTF texture index, sRGB, uv transform's bits) -> scene texture.
    textures: HashMap<(usize, bool, Option<[u32; 5]>), usize>,
    /// Cameras met: (name, node index, camera, world transform).
    cameras: Vec<(Option<String>, usize, Result<CameraSpec, String>)>,
    /// Nodes met so far: a node reached twice (two parents, or a root that
    /// is also a child) is refused, or a chain of nodes each listing the next
    /// twice would make 2^depth visits.
    visited: Vec<bool>,
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
        match self.visited.get_mut(node.index()) {
            Some(seen) if !*seen => *seen = true,
            _ => {
                return Err(SceneError::malformed(
                    self.path,
                    format!(
                        "node {}: reached twice in the scene's hierarchy (a node has one parent at most)",
                        node.index()
                    ),
                ));
            }
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
            self.add_light(&light, world)?;
        }
        for child in node.children() {
            self.visit(&child, world, depth + 1)?;
        }
        Ok(())
    }

    /// Adds the triangle primitives of `mesh`, placed by `world`; a
    /// primitive of another mode is skipped with a warning.
    fn add_mesh(&mut self, mesh: &gltf::Mesh, world: Mat4) -> Result<(), SceneError> {
        for primitive in mesh.primitives() {
            let element = format!(
                "mesh {} ({}), primitive {}",
                mesh.index(),
                quoted(mesh.name().unwrap_or("")),
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
            self.add_primitive(mesh.index(), &primitive, &element, world)?;
        }
        Ok(())
    }

    /// Adds one triangle primitive of mesh `mesh`: its material, its
    /// accessors checked and read, its indices and values checked, then its
    /// triangles in world space. `element` names it in messages.
    fn add_primitive(
        &mut self,
        mesh: usize,
        primitive: &gltf::Primitive,
        element: &str,
        world: Mat4,
    ) -> Result<(), SceneError> {
        let material = self.material(&primitive.material())?;
        let accessors = self.check_primitive(mesh, primitive, element)?;
        self.reserve(primitive);
        let data = self.read_primitive(primitive, &accessors, material, world)?;
        self.check_indices(element, &accessors, &data)?;
        let (positions, normals) = self.world_vertices(&accessors, &data, world)?;
        let flips = Mat3::from_mat4(world).determinant() < 0.0;
        self.add_triangles(
            element,
            &data,
            &positions,
            normals.as_deref(),
            flips,
            material,
        )
    }

    /// Reads the attributes and indices of a checked primitive (without
    /// an index accessor, its vertices in order). Tangents are read only
    /// when `material` has a normal map, the only use of them.
    fn read_primitive(
        &mut self,
        primitive: &gltf::Primitive,
        accessors: &PrimitiveAccessors,
        material: u32,
        world: Mat4,
    ) -> Result<PrimitiveData, SceneError> {
        let (path, buffers) = (self.path, self.buffers);
        let reader = primitive.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
        let unreadable = |(index, label): &(usize, String)| {
            SceneError::malformed(path, format!("{label}: accessor {index} could not be read"))
        };
        let positions: Vec<Vec3> = reader
            .read_positions()
            .ok_or_else(|| unreadable(&accessors.position))?
            .map(Vec3::from_array)
            .collect();
        let normals: Option<Vec<Vec3>> = match &accessors.normal {
            Some(a) => Some(
                reader
                    .read_normals()
                    .ok_or_else(|| unreadable(a))?
                    .map(Vec3::from_array)
                    .collect(),
            ),
            None => None,
        };
        let uvs: Option<Vec<Vec2>> = match &accessors.tex_coord {
            Some(a) => Some(
                reader
                    .read_tex_coords(0)
                    .ok_or_else(|| unreadable(a))?
                    .into_f32()
                    .map(Vec2::from_array)
                    .collect(),
            ),
            None => None,
        };
        // Tangents matter only under a normal map.
        let tangents: Option<Vec<Vec4>> = match &accessors.tangent {
            Some(a)
                if self.builder.materials[material as usize]
                    .maps
                    .normal
                    .is_some() =>
            {
                let read: Vec<Vec4> = reader
                    .read_tangents()
                    .ok_or_else(|| unreadable(a))?
                    .map(Vec4::from_array)
                    .collect();
                Some(self.tangents_to_world(&read, &a.1, world))
            }
            _ => None,
        };
        let indices: Vec<u32> = match &accessors.indices {
            Some(a) => reader
                .read_indices()
                .ok_or_else(|| unreadable(a))?
                .into_u32()
                .collect(),
            None => (0..positions.len() as u32).collect(),
        };
        Ok(PrimitiveData {
            positions,
            normals,
            uvs,
            tangents,
            indices,
        })
    }

    /// The tangents of accessor `label` in world space ([`world_tangents`]),
    /// with a warning counting those replaced by ones the renderer derives.
    fn tangents_to_world(&mut self, read: &[Vec4], label: &str, world: Mat4) -> Vec<Vec4> {
        let (tangents, replaced) = world_tangents(read, world);
        if replaced > 0 {
            self.builder.report.warnings.push(format!(
                "{}: {}: {replaced} zero or non-finite tangents replaced by ones derived from the texture coordinates",
                self.path.display(),
                label
            ));
        }
        tangents
    }

    /// Refuses indices that do not make whole triangles or that name a
    /// vertex past the positions, and an attribute whose count differs from
    /// the positions': triangles are then read without bounds failures.
    fn check_indices(
        &self,
        element: &str,
        accessors: &PrimitiveAccessors,
        data: &PrimitiveData,
    ) -> Result<(), SceneError> {
        let indices = &data.indices;
        if !indices.len().is_multiple_of(3) {
            return Err(SceneError::malformed(
                self.path,
                format!(
                    "{element}: {} indices is not a multiple of 3",
                    indices.len()
                ),
            ));
        }
        let vertex_count = data.positions.len();
        for attribute in [
            data.normals.as_ref().map(Vec::len),
            data.uvs.as_ref().map(Vec::len),
            data.tangents.as_ref().map(Vec::len),
        ]
        .into_iter()
        .flatten()
        {
            if attribute != vertex_count {
                return Err(SceneError::malformed(
                    self.path,
                    format!(
                        "{element}: attribute count {attribute} differs from {vertex_count} positions"
                    ),
                ));
            }
        }
        if let Some(k) = indices.iter().position(|&i| i as usize >= vertex_count) {
            let label = accessors.indices.as_ref().map_or(element, |(_, l)| l);
            return Err(SceneError::malformed(
                self.path,
                format!(
                    "{label}: index {k} (triangle {}) uses vertex {}, but {} has {vertex_count}",
                    k / 3,
                    indices[k],
                    accessors.position.1
                ),
            ));
        }
        Ok(())
    }

    /// The primitive's positions and normals in world space. A non-finite
    /// position (as read or once placed) or normal (as read) is refused.
    fn world_vertices(
        &self,
        accessors: &PrimitiveAccessors,
        data: &PrimitiveData,
        world: Mat4,
    ) -> Result<(Vec<Vec3>, Option<Vec<Vec3>>), SceneError> {
        let normal_matrix = Mat3::from_mat4(world).inverse().transpose();
        let positions: Vec<Vec3> = data
            .positions
            .iter()
            .map(|&p| world.transform_point3(p))
            .collect();
        let normals: Option<Vec<Vec3>> = data
            .normals
            .as_ref()
            .map(|ns| ns.iter().map(|&n| normal_matrix * n).collect());
        let indices = &data.indices;
        self.check_finite(&accessors.position.1, &data.positions, &positions, indices)?;
        if let (Some((_, label)), Some(raw)) = (&accessors.normal, &data.normals) {
            // World-space normals are not checked: a singular transform
            // (a scale of 0 hides a node) makes them NaN, and the scene
            // builder replaces those with the geometric normal.
            self.check_finite(label, raw, raw, indices)?;
        }
        Ok((positions, normals))
    }

    /// Adds the primitive's triangles, sharing its vertices, with their
    /// winding reversed where the transform mirrors (`flips`) so that they
    /// keep facing the way the file has them.
    fn add_triangles(
        &mut self,
        element: &str,
        data: &PrimitiveData,
        positions: &[Vec3],
        normals: Option<&[Vec3]>,
        flips: bool,
        material: u32,
    ) -> Result<(), SceneError> {
        self.builder.begin_shared_vertices(positions.len());
        for (t, tri) in data.indices.chunks_exact(3).enumerate() {
            let mut ids = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
            if flips {
                ids.swap(1, 2);
            }
            let element = || format!("{element}, triangle {t}");
            let p = ids.map(|i| positions[i]);
            let n = normals.map(|ns| ids.map(|i| ns[i]));
            let uv = data.uvs.as_ref().map(|us| ids.map(|i| us[i]));
            let t = data.tangents.as_ref().map(|ts| ids.map(|i| ts[i]));
            self.builder.add_indexed_triangle(
                self.path,
                &element,
                ids.map(|i| i as u32),
                p,
                n,
                uv,
                t,
                material,
            )?;
        }
        Ok(())
    }

    /// Grows the scene's arrays for `primitive` (its accessors checked
    /// against their buffers, so the counts are real) before its attributes
    /// are read into temporary arrays: freed later, those leave no hole under
    /// the scene's arrays, which glibc would keep resident through the BVH
    /// build (a million-triangle .glb peaked at 167 bytes per triangle
    /// without this, 150 with the arrays grown after the reads).
    fn reserve(&mut self, primitive: &gltf::Primitive) {
        let vertices = primitive
            .get(&gltf::mesh::Semantic::Positions)
            .map_or(0, |a| a.count());
        let triangles = primitive.indices().map_or(vertices, |a| a.count()) / 3;
        self.builder.reserve(triangles, vertices);
    }

    /// Checks every accessor `primitive` reads (see [`validate`]) and returns
    /// them with their labels.
    fn check_primitive(
        &self,
        mesh: usize,
        primitive: &gltf::Primitive,
        element: &str,
    ) -> Result<PrimitiveAccessors, SceneError> {
        use gltf::mesh::Semantic as S;
        let check = |accessor: Option<gltf::Accessor>, semantic: Semantic| {
            accessor
                .map(|a| {
                    let label =
                        validate::accessor_label(a.index(), mesh, primitive.index(), semantic);
                    validate::check_accessor(self.path, &label, &a, semantic, self.buffers)
                        .map(|()| (a.index(), label, a.count()))
                })
                .transpose()
        };
        let position =
            check(primitive.get(&S::Positions), Semantic::Position)?.ok_or_else(|| {
                SceneError::malformed(self.path, format!("{element}: no POSITION attribute"))
            })?;
        let normal = check(primitive.get(&S::Normals), Semantic::Normal)?;
        let tex_coord = check(primitive.get(&S::TexCoords(0)), Semantic::TexCoord)?;
        let tangent = check(primitive.get(&S::Tangents), Semantic::Tangent)?;
        let indices = check(primitive.indices(), Semantic::Indices)?;
        for (index, label, count) in [&normal, &tex_coord, &tangent].into_iter().flatten() {
            if *count != position.2 {
                return Err(SceneError::malformed(
                    self.path,
                    format!(
                        "{label}: count {count} differs from POSITION accessor {}'s {}",
                        position.0, position.2
                    ),
                ));
            }
            let _ = index;
        }
        let strip = |a: Option<(usize, String, usize)>| a.map(|(i, l, _)| (i, l));
        Ok(PrimitiveAccessors {
            position: (position.0, position.1),
            normal: strip(normal),
            tex_coord: strip(tex_coord),
            tangent: strip(tangent),
            indices: strip(indices),
        })
    }

    /// Refuses a NaN or infinite vertex attribute (as read, or once
    /// transformed to world space), naming the accessor, the vertex and the
    /// first triangle that uses it.
    fn check_finite(
        &self,
        label: &str,
        raw: &[Vec3],
        world: &[Vec3],
        indices: &[u32],
    ) -> Result<(), SceneError> {
        let Some(bad) = raw
            .iter()
            .zip(world)
            .position(|(r, w)| !r.is_finite() || !w.is_finite())
        else {
            return Ok(());
        };
        let used = indices.iter().position(|&i| i as usize == bad).map_or_else(
            || "unused".to_string(),
            |k| format!("used by triangle {}", k / 3),
        );
        let what = if raw[bad].is_finite() {
            "becomes infinite in world space"
        } else {
            "is not finite"
        };
        Err(SceneError::invalid(
            self.path,
            label,
            format!("vertex {bad} {}{what} ({used})", fmt_vec(raw[bad])),
        ))
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
        if !(0.0..=1.0).contains(&transmission) {
            return Err(invalid(format!(
                "KHR_materials_transmission transmissionFactor must be in [0, 1], got {transmission}"
            )));
        }
        // KHR_materials_ior allows 0 as a special value; it is refused only
        // where the IOR is used, by a transmissive material.
        let ior = m.ior().unwrap_or(1.5);
        if !(ior.is_finite() && (ior > 0.0 || (ior == 0.0 && transmission == 0.0))) {
            return Err(invalid(format!(
                "KHR_materials_ior ior must be finite and > 0, got {ior}"
            )));
        }
        let strength = m.emissive_strength().unwrap_or(1.0);
        if !(strength >= 0.0 && strength.is_finite()) {
            return Err(invalid(format!(
                "KHR_materials_emissive_strength must be finite and >= 0, got {strength}"
            )));
        }
        let base_texture = pbr
            .base_color_texture()
            .map(|t| self.texture_info(&t, true, &element, "baseColorTexture"))
            .transpose()?;
        let mr_texture = pbr
            .metallic_roughness_texture()
            .map(|t| self.texture_info(&t, false, &element, "metallicRoughnessTexture"))
            .transpose()?;
        let transmission_texture = m
            .transmission()
            .and_then(|t| t.transmission_texture())
            .filter(|_| transmission > 0.0)
            .map(|t| self.texture_info(&t, false, &element, "transmissionTexture"))
            .transpose()?;
        let (specular, specular_color) = specular_extension(m).map_err(invalid)?;
        let surface =
            if base_texture.is_some() || mr_texture.is_some() || transmission_texture.is_some() {
                Surface::Textured(TexturedPbr {
                    base_color: base,
                    base_color_texture: base_texture,
                    metallic,
                    roughness,
                    metallic_roughness_texture: mr_texture,
                    transmission,
                    transmission_texture,
                    ior,
                    specular,
                    specular_color,
                    specular_color_texture: None,
                    shininess_texture: None,
                    ndf,
                    shadowing,
                })
            } else if is_transmissive(metallic, transmission) {
                transmissive_surface(base, roughness, ior, ndf, shadowing)
            } else {
                let factors = MetalRough {
                    specular,
                    specular_color,
                    ior,
                    ..MetalRough::new(base, metallic, roughness)
                };
                metal_rough_surface(factors, ndf, shadowing)
            };
        let medium = volume_medium(m, surface.may_transmit()).map_err(invalid)?;
        let factor = Vec3::from_array(m.emissive_factor());
        if !factor.is_finite() || factor.min_element() < 0.0 {
            return Err(invalid(format!(
                "emissiveFactor must be finite and non-negative, got {factor}"
            )));
        }
        let emission = factor * strength;
        if !emission.is_finite() {
            return Err(invalid(format!(
                "emission (emissiveFactor x emissiveStrength) overflows, got {emission}"
            )));
        }
        let maps = self.maps(m, &element)?;
        let name = m.name().map_or_else(|| element.clone(), str::to_string);
        let id = self.builder.add_material(Material {
            name,
            surface,
            emission,
            medium,
            maps,
        });
        self.materials.insert(m.index(), id);
        Ok(id)
    }

    /// The emissive, normal and alpha maps of `m` (material module docs).
    fn maps(&mut self, m: &gltf::Material, element: &str) -> Result<Maps, SceneError> {
        let path = self.path;
        let invalid = |message: String| SceneError::invalid(path, element, message);
        let emission = m
            .emissive_texture()
            .map(|t| self.texture_info(&t, true, element, "emissiveTexture"))
            .transpose()?;
        let normal = match m.normal_texture() {
            Some(n) => {
                let scale = n.scale();
                if !scale.is_finite() {
                    return Err(invalid(format!(
                        "normalTexture.scale must be finite, got {scale}"
                    )));
                }
                // gltf 1.4.1 has no typed transform on normalTexture.
                let raw = n
                    .extension_value("KHR_texture_transform")
                    .map(|v| {
                        RawTransform::from_json(v).map_err(|e| {
                            invalid(format!(
                                "normalTexture.extensions.KHR_texture_transform: {e}"
                            ))
                        })
                    })
                    .transpose()?;
                let transform = self.uv_transform(raw, n.tex_coord(), element, "normalTexture")?;
                let texture = self.texture(&n.texture(), false, transform, element)?;
                Some(NormalMap {
                    texture,
                    kind: NormalMapKind::Tangent { scale },
                })
            }
            None => None,
        };
        let pbr = m.pbr_metallic_roughness();
        let factor = pbr.base_color_factor()[3];
        if !(0.0..=1.0).contains(&factor) {
            return Err(invalid(format!(
                "baseColorFactor's alpha must be in [0, 1], got {factor}"
            )));
        }
        let cutoff = m.alpha_cutoff().unwrap_or(0.5);
        if !(cutoff.is_finite() && cutoff >= 0.0) {
            return Err(invalid(format!(
                "alphaCutoff must be finite and >= 0, got {cutoff}"
            )));
        }
        let mode = m.alpha_mode();
        let texture = match (mode, pbr.base_color_texture()) {
            (gltf::material::AlphaMode::Opaque, _) | (_, None) => None,
            (_, Some(t)) => Some(self.texture_info(&t, true, element, "baseColorTexture")?),
        };
        // Without a texture a mask that keeps everything, or a blend of
        // alpha 1, is opaque: no test at render time.
        let alpha = match mode {
            gltf::material::AlphaMode::Mask if texture.is_some() || factor < cutoff => {
                Alpha::Mask {
                    factor,
                    texture,
                    cutoff,
                }
            }
            gltf::material::AlphaMode::Blend if texture.is_some() || factor < 1.0 => {
                Alpha::Blend { factor, texture }
            }
            _ => Alpha::Opaque,
        };
        Ok(Maps {
            emission,
            normal,
            alpha,
        })
    }

    /// A `textureInfo`'s texture, read through its `KHR_texture_transform`.
    fn texture_info(
        &mut self,
        info: &gltf::texture::Info,
        srgb: bool,
        element: &str,
        slot: &str,
    ) -> Result<usize, SceneError> {
        let transform = info.texture_transform().map(|t| RawTransform {
            offset: t.offset(),
            rotation: t.rotation(),
            scale: t.scale(),
            tex_coord: t.tex_coord(),
        });
        let transform = self.uv_transform(transform, info.tex_coord(), element, slot)?;
        self.texture(&info.texture(), srgb, transform, element)
    }

    /// The uv transform of texture slot `slot` (identity when absent), its
    /// numbers checked. Only TEXCOORD_0 is loaded: a slot reading another
    /// set (`tex_coord`, or the extension's `texCoord` override) is read
    /// with TEXCOORD_0 and warned about.
    fn uv_transform(
        &mut self,
        raw: Option<RawTransform>,
        tex_coord: u32,
        element: &str,
        slot: &str,
    ) -> Result<Option<UvTransform>, SceneError> {
        let tex_coord = raw.and_then(|r| r.tex_coord).unwrap_or(tex_coord);
        if tex_coord != 0 {
            self.builder.report.warnings.push(format!(
                "{}: {element}: {slot} uses TEXCOORD_{tex_coord}; only TEXCOORD_0 is loaded and used instead",
                self.path.display()
            ));
        }
        let Some(raw) = raw else {
            return Ok(None);
        };
        let numbers = [
            raw.offset[0],
            raw.offset[1],
            raw.rotation,
            raw.scale[0],
            raw.scale[1],
        ];
        if !numbers.iter().all(|x| x.is_finite()) {
            return Err(SceneError::invalid(
                self.path,
                element,
                format!(
                    "{slot}.extensions.KHR_texture_transform: offset, rotation and scale must be finite, got {:?}, {}, {:?}",
                    raw.offset, raw.rotation, raw.scale
                ),
            ));
        }
        Ok(Some(UvTransform {
            offset: Vec2::from_array(raw.offset),
            rotation: raw.rotation,
            scale: Vec2::from_array(raw.scale),
        }))
    }

    fn texture(
        &mut self,
        texture: &gltf::Texture,
        srgb: bool,
        transform: Option<UvTransform>,
        element: &str,
    ) -> Result<usize, SceneError> {
        let key = (
            texture.index(),
            srgb,
            transform.map(|t| {
                [t.offset.x, t.offset.y, t.rotation, t.scale.x, t.scale.y].map(f32::to_bits)
            }),
        );
        if let Some(&id) = self.textures.get(&key) {
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
        t.transform = transform;
        let id = self.builder.add_texture(t);
        self.textures.insert(key, id);
        Ok(id)
    }

    fn add_light(
        &mut self,
        light: &gltf::khr_lights_punctual::Light,
        world: Mat4,
    ) -> Result<(), SceneError> {
        let invalid = |message: String| {
            SceneError::invalid(
                self.path,
                format!(
                    "light {} ({})",
                    light.index(),
                    quoted(light.name().unwrap_or(""))
                ),
                message,
            )
        };
        let (color, intensity) = (Vec3::from_array(light.color()), light.intensity());
        if !color.is_finite() || color.min_element() < 0.0 {
            return Err(invalid(format!(
                "color must be finite and non-negative, got {}",
                fmt_vec(color).trim_end()
            )));
        }
        if !(intensity >= 0.0 && intensity.is_finite()) {
            return Err(invalid(format!(
                "intensity must be finite and >= 0, got {intensity}"
            )));
        }
        if let Kind::Spot {
            inner_cone_angle,
            outer_cone_angle,
        } = light.kind()
            && !(0.0 <= inner_cone_angle
                && inner_cone_angle <= outer_cone_angle
                && outer_cone_angle <= std::f32::consts::FRAC_PI_2 + 1e-6)
        {
            return Err(invalid(format!(
                "spot cone angles must satisfy 0 <= inner <= outer <= pi/2, got inner {inner_cone_angle}, outer {outer_cone_angle}"
            )));
        }
        let color = color * intensity;
        if !color.is_finite() {
            return Err(invalid(format!(
                "color x intensity overflows, got {}",
                fmt_vec(color).trim_end()
            )));
        }
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
        Ok(())
    }
}

/// A `KHR_texture_transform` object as written (defaults filled in).
#[derive(Clone, Copy)]
struct RawTransform {
    offset: [f32; 2],
    rotation: f32,
    scale: [f32; 2],
    tex_coord: Option<u32>,
}

impl RawTransform {
    /// Parses the extension's JSON object (where the `gltf` crate has no
    /// typed accessor).
    fn from_json(v: &serde_json::Value) -> Result<Self, String> {
        let pair = |key: &str, default: [f32; 2]| -> Result<[f32; 2], String> {
            match v.get(key) {
                None => Ok(default),
                Some(x) => x
                    .as_array()
                    .filter(|a| a.len() == 2)
                    .and_then(|a| Some([a[0].as_f64()? as f32, a[1].as_f64()? as f32]))
                    .ok_or_else(|| format!("{key} must be two numbers")),
            }
        };
        let rotation = match v.get("rotation") {
            None => 0.0,
            Some(x) => x.as_f64().ok_or("rotation must be a number")? as f32,
        };
        let tex_coord = match v.get("texCoord") {
            None => None,
            Some(x) => Some(
                x.as_u64()
                    .and_then(|t| u32::try_from(t).ok())
                    .ok_or("texCoord must be a non-negative integer")?,
            ),
        };
        Ok(Self {
            offset: pair("offset", [0.0, 0.0])?,
            rotation,
            scale: pair("scale", [1.0, 1.0])?,
            tex_coord,
        })
    }
}

/// Object-space tangents to world space: xyz by the node's linear part
/// (tangents are surface directions, unlike normals), the handedness w
/// flipped by a mirroring transform. A non-finite or zero tangent becomes
/// zero (derived from the uvs at render time); returns how many did.
fn world_tangents(tangents: &[Vec4], world: Mat4) -> (Vec<Vec4>, usize) {
    let linear = Mat3::from_mat4(world);
    let sign = linear.determinant().signum();
    let mut replaced = 0;
    let out = tangents
        .iter()
        .map(|t| match (linear * t.truncate()).try_normalize() {
            Some(xyz) if t.is_finite() => xyz.extend(if t.w < 0.0 { -sign } else { sign }),
            _ => {
                replaced += 1;
                Vec4::ZERO
            }
        })
        .collect();
    (out, replaced)
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

/// A camera's `type` names the projection object it has (the `gltf` crate
/// checks only that one of the two exists, then unwraps the one named).
fn check_cameras(path: &Path, root: &gltf::json::Root) -> Result<(), SceneError> {
    use gltf::json::camera::Type;
    use gltf::json::validation::Checked;
    for (i, camera) in root.cameras.iter().enumerate() {
        let missing = match camera.type_ {
            Checked::Valid(Type::Perspective) => camera.perspective.is_none(),
            Checked::Valid(Type::Orthographic) => camera.orthographic.is_none(),
            Checked::Invalid => false,
        };
        if missing {
            return Err(SceneError::malformed(
                path,
                format!("camera {i}: its type has no matching projection object"),
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
/// The absorbing medium of a material with `KHR_materials_volume` and
/// thicknessFactor > 0 (a closed volume; the thickness itself only says
/// so), from attenuationColor and attenuationDistance (see
/// [`Medium::from_attenuation`]), if its surface is `transmissive`
/// somewhere; `None` for thin walls, clear volumes and opaque materials.
/// The values are checked either way.
fn volume_medium(m: &gltf::Material, transmissive: bool) -> Result<Option<Medium>, String> {
    let Some(volume) = m.volume() else {
        return Ok(None);
    };
    let thickness = volume.thickness_factor();
    if !(thickness.is_finite() && thickness >= 0.0) {
        return Err(format!(
            "KHR_materials_volume thicknessFactor must be finite and >= 0, got {thickness}"
        ));
    }
    let color = Vec3::from_array(volume.attenuation_color());
    if !(color.is_finite() && color.min_element() >= 0.0 && color.max_element() <= 1.0) {
        return Err(format!(
            "KHR_materials_volume attenuationColor must be in [0, 1], got {color}"
        ));
    }
    let distance = volume.attenuation_distance();
    if !(distance > 0.0) {
        return Err(format!(
            "KHR_materials_volume attenuationDistance must be > 0, got {distance}"
        ));
    }
    Ok(if transmissive && thickness > 0.0 {
        Medium::from_attenuation(color, distance)
    } else {
        None
    })
}

/// `KHR_materials_specular`'s (specularFactor, specularColorFactor), glTF's
/// (1, 1) without it; the factor must be in [0, 1] and the colour finite and
/// non-negative (the extension's ranges). Its textures are not used.
fn specular_extension(m: &gltf::Material) -> Result<(f32, Vec3), String> {
    let Some(ext) = m.specular() else {
        return Ok((1.0, Vec3::ONE));
    };
    let (factor, colour) = (
        ext.specular_factor(),
        Vec3::from_array(ext.specular_color_factor()),
    );
    if !(0.0..=1.0).contains(&factor) {
        return Err(format!(
            "KHR_materials_specular specularFactor must be in [0, 1], got {factor}"
        ));
    }
    if !(colour.is_finite() && colour.min_element() >= 0.0) {
        return Err(format!(
            "KHR_materials_specular specularColorFactor must be finite and non-negative, got {colour}"
        ));
    }
    Ok((factor, colour))
}

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
                fov_degrees: p.yfov().to_degrees(),
                fov_axis: FovAxis::Y,
                aspect: p.aspect_ratio(),
                mirrored: false,
                near_clip: 0.0,
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
                .take(3)
                .map(|(p, e)| format!("{p}: {e}"))
                .collect();
            let more = if errors.len() > 3 {
                format!(" (and {} more)", errors.len() - 3)
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
        gltf::Error::Deserialize(e) => {
            SceneError::malformed(path, format!("invalid glTF JSON: {e}"))
        }
        other => SceneError::malformed(path, other.to_string()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn percent_decoding_matches_the_gltf_crate() {
        assert_eq!(percent_decode("a%20b.bin").as_deref(), Some("a b.bin"));
        assert_eq!(percent_decode("%2E%2E/x").as_deref(), Some("../x"));
        assert_eq!(percent_decode("100%").as_deref(), Some("100%"));
        assert_eq!(percent_decode("%FF"), None);
    }
}
