//! Mitsuba 3 scene files (`.xml`), read as Mitsuba 3.9.1 reads them (the
//! facts, many measured, are in `shared/notes/mitsuba-format.md`; its
//! sections are cited as "note §n").
//!
//! - [`xml`]: the document (substitution, defaults, includes, the upgrade
//!   of Mitsuba 0.6 files, typed properties); [`transform`] its transforms;
//! - [`props`]: typed reads of one plugin; [`tables`] the named IORs and
//!   conductors; [`geometry`] the built-in shapes and `to_world`;
//! - [`ply`], [`serialized`]: the mesh formats (OBJ goes through
//!   [`crate::obj`]);
//! - this file: plugins to the [`Scene`](crate::Scene) model.
//!
//! # Mapping (what differs from Mitsuba is said here and warned about)
//!
//! - `diffuse` -> Lambertian (a `bitmap` reflectance -> a textured one);
//!   `conductor`/`roughconductor` -> a conductor with complex Fresnel (RGB
//!   `eta`/`k` or a named `material`; `none`, the default, a perfect
//!   mirror) times `specular_reflectance`; `dielectric`/`roughdielectric` -> a dielectric of index
//!   int_ior / ext_ior, `specular_transmittance` its tint; `thindielectric`
//!   -> a thin sheet (`microfacet::ThinDielectric`); `plastic` /
//!   `roughplastic` -> the coated lobe (a Schlick coat of F0 ((n-1)/(n+1))^2
//!   over a Lambertian base that loses what the coat reflects; Mitsuba's
//!   coat has exact Fresnel and its base keeps the light the coat reflects
//!   back inside, so our diffuse part is somewhat darker); `twosided` -> its
//!   (front) lobe. `distribution` beckmann (the default) or ggx, `alpha`
//!   (anisotropic `alpha_u` != `alpha_v` is refused). Our lobes shade both
//!   sides; Mitsuba's `diffuse`, conductors and plastics are black from
//!   behind, which only matters where a scene shows a back face.
//! - `area` emitters are one-sided on the shading normal's side (as
//!   Mitsuba's); a uniform `<spectrum>` on an emitter is Mitsuba's pinkish
//!   RGB ([`props::EMISSIVE_WHITE`]). `point`, `spot` (glTF's smooth falloff
//!   between `beam_width` and `cutoff_angle`, Mitsuba's is linear in the
//!   angle: a warning), `directional`, `constant`, `envmap` (rotations about
//!   +y only).
//! - `perspective` sensor: `fov` along `fov_axis`, `to_world` (mirroring
//!   too), `near_clip`; film `width`/`height` -> resolution (box filter always: a warning
//!   names another `rfilter`), sampler `sample_count` -> iterations,
//!   integrator `max_depth` -> max depth, `path` -> our path tracer.

pub mod geometry;
mod numbers;
pub mod ply;
pub mod props;
pub mod serialized;
pub mod tables;
pub mod transform;
pub mod xml;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use glam::{DMat3, DMat4, DVec3, UVec2, Vec2, Vec3};
use microfacet::{Coated, Fresnel, MicrofacetModel, NdfKind, Shadowing};

use crate::camera::{CameraSpec, FovAxis};
use crate::error::{SceneError, quoted};
use crate::light::Light;
use crate::material::{Material, Surface, TexturedPbr};
use crate::paths::ReferencePolicy;
use crate::scene::{RenderSettings, SceneBuilder};
use crate::sphere::Sphere;
use crate::texture::{Texture, Wrap};
use props::{Color, Plugin};
use xml::{Child, Object};

/// A triangle mesh as a Mitsuba mesh file (`.serialized`, `.ply`) stores it,
/// in the file's own (object) space, before the shape's `to_world`.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct MeshData {
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Vertex normals, one per position, or empty when the file has none.
    pub normals: Vec<Vec3>,
    /// Texture coordinates, one per position, or empty when the file has none.
    pub uvs: Vec<Vec2>,
    /// Triangles as indices into `positions`.
    pub triangles: Vec<[u32; 3]>,
}

/// Mitsuba's film size when the file gives none (`hdrfilm`'s defaults).
pub const DEFAULT_FILM: UVec2 = UVec2::new(768, 576);

/// Mitsuba's `perspective` default `near_clip`: camera rays start 0.01 in
/// front of the camera.
const NEAR_CLIP: f64 = 1e-2;

/// Mitsuba's defaults for `alpha` of rough lobes.
const DEFAULT_ALPHA: f64 = 0.1;

/// What a Mitsuba file gives the scene loader.
pub(crate) struct Loaded {
    pub builder: SceneBuilder,
    pub camera: Option<CameraSpec>,
    pub resolution: Option<UVec2>,
    pub render: RenderSettings,
}

/// Loads the Mitsuba scene `path` with the caller's `-D name=value`
/// `parameters`.
pub(crate) fn load(
    path: &Path,
    parameters: &[(String, String)],
    policy: &ReferencePolicy,
) -> Result<Loaded, SceneError> {
    let document = xml::parse(path, parameters, policy)?;
    if !document.unused_parameters.is_empty() {
        return Err(SceneError::invalid(
            path,
            "-D",
            format!(
                "parameter(s) {} not used by the file",
                document.unused_parameters.join(", ")
            ),
        ));
    }
    let mut ids = HashMap::new();
    collect_ids(&document.root, &mut ids)?;
    let mut loader = Loader {
        main: path,
        search_path: &document.search_path,
        policy,
        ids: &ids,
        builder: SceneBuilder::default(),
        materials: HashMap::new(),
        textures: HashMap::new(),
        camera: None,
        resolution: None,
        render: RenderSettings::default(),
    };
    loader.root(&document.root)?;
    Ok(Loaded {
        builder: loader.builder,
        camera: loader.camera,
        resolution: loader.resolution,
        render: loader.render,
    })
}

/// Every `id` in the tree (global across includes; a duplicate is an error).
fn collect_ids<'a>(
    object: &'a Object,
    ids: &mut HashMap<String, &'a Object>,
) -> Result<(), SceneError> {
    if let Some(id) = &object.id
        && let Some(first) = ids.insert(id.clone(), object)
    {
        return Err(SceneError::invalid(
            object.at.file.as_path(),
            xml::element_name(&object.at, &object.tag, &object.plugin),
            format!(
                "id {} is already used on line {} of {}",
                quoted(id),
                first.at.line,
                first.at.file.display()
            ),
        ));
    }
    for child in &object.children {
        if let Child::Object(o) = child {
            collect_ids(o, ids)?;
        }
    }
    Ok(())
}

struct Loader<'a> {
    main: &'a Path,
    search_path: &'a [PathBuf],
    policy: &'a ReferencePolicy,
    ids: &'a HashMap<String, &'a Object>,
    builder: SceneBuilder,
    /// Materials made so far, by the BSDF object's address and the emission.
    materials: HashMap<(usize, [u32; 3]), u32>,
    /// Textures loaded so far, by file and colour space.
    textures: HashMap<(PathBuf, bool), usize>,
    camera: Option<CameraSpec>,
    resolution: Option<UVec2>,
    render: RenderSettings,
}

impl<'a> Loader<'a> {
    fn warn(&mut self, message: String) {
        self.builder.report.ignored.push(message.clone());
        self.builder.report.warnings.push(message);
    }

    /// A warning naming `object`'s file, line and element.
    fn warn_at(&mut self, object: &Object, message: impl std::fmt::Display) {
        self.warn(format!(
            "{}: {}: {message}",
            object.at.file.display(),
            xml::element_name(&object.at, &object.tag, &object.plugin)
        ));
    }

    /// Warns about what `plugin` did not read.
    fn finish(&mut self, plugin: &Plugin) {
        if let Some(w) = plugin.unused() {
            self.warn(w);
        }
    }

    fn root(&mut self, root: &'a Object) -> Result<(), SceneError> {
        let plugin = Plugin::new(root, self.ids);
        if root.tag != "scene" {
            return Err(plugin.error("the root must be <scene> to be rendered"));
        }
        let mut sensors = 0;
        for child in &root.children {
            // Objects written at the top with an id are used by reference;
            // a top-level <ref> instantiates one.
            let object = plugin.resolve(child)?;
            match object.tag.as_str() {
                "shape" => self.shape(object)?,
                // Used by reference from a shape.
                "emitter" if object.plugin == "area" && object.id.is_some() => {}
                "emitter" => self.emitter(object)?,
                "sensor" => {
                    sensors += 1;
                    if sensors == 1 {
                        self.sensor(object)?;
                    } else {
                        self.warn_at(object, "a second sensor: the first one is used");
                    }
                }
                "integrator" => self.integrator(object)?,
                // Used by reference.
                "bsdf" | "texture" if object.id.is_some() => {}
                "medium" => {
                    return Err(unsupported(object, "participating media are not supported"));
                }
                other => self.warn_at(object, format!("<{other}> ignored (not supported here)")),
            }
        }
        if !root.properties.is_empty() {
            self.finish(&plugin);
        }
        Ok(())
    }

    // ---- shapes --------------------------------------------------------

    fn shape(&mut self, object: &'a Object) -> Result<(), SceneError> {
        let p = Plugin::new(object, self.ids);
        if let Some(medium) = p.children("medium")?.first() {
            return Err(unsupported(medium, "participating media are not supported"));
        }
        let to_world = p.transform("to_world")?;
        let flip = p.boolean_or("flip_normals", false)?;
        let material = self.shape_material(&p)?;
        let mesh = match p.plugin() {
            "sphere" => return self.sphere(&p, to_world, flip, material),
            "rectangle" => geometry::rectangle(),
            "cube" => geometry::cube(),
            "disk" => geometry::disk(),
            "obj" => {
                let file = self.file(&p, "filename")?;
                // Mitsuba's default flips v (obj.cpp); our OBJ reader always does.
                if !p.boolean_or("flip_tex_coords", true)? {
                    self.warn_at(
                        object,
                        "flip_tex_coords=false ignored: OBJ texture v is flipped",
                    );
                }
                obj_mesh(&file, self.policy)?
            }
            "ply" => {
                let file = self.file(&p, "filename")?;
                let bytes = read_mesh_file(&file)?;
                let mut mesh = ply::read(&bytes).map_err(|e| SceneError::malformed(&file, e))?;
                if p.boolean_or("flip_tex_coords", false)? {
                    mesh.uvs.iter_mut().for_each(|uv| uv.y = 1.0 - uv.y);
                }
                mesh
            }
            "serialized" => {
                let file = self.file(&p, "filename")?;
                let index = p.integer("shape_index")?.unwrap_or(0);
                let index = u32::try_from(index)
                    .map_err(|_| p.error(format!("shape_index must be >= 0, got {index}")))?;
                let bytes = read_mesh_file(&file)?;
                serialized::read(&bytes, index).map_err(|e| SceneError::malformed(&file, e))?
            }
            other => {
                return Err(unsupported(
                    object,
                    format!(
                        "shape type {} is not supported (obj, ply, serialized, rectangle, cube, disk, sphere are)",
                        quoted(other)
                    ),
                ));
            }
        };
        let face_normals = p.boolean_or("face_normals", false)?;
        let mesh = geometry::to_world(mesh, to_world, flip, face_normals);
        self.add_mesh(&p, &mesh, material)?;
        self.finish(&p);
        Ok(())
    }

    /// An analytic sphere: `to_world * translate(center) * scale(radius)`
    /// (note §2.1); the transform must scale uniformly.
    fn sphere(
        &mut self,
        p: &Plugin<'a>,
        to_world: DMat4,
        flip: bool,
        material: u32,
    ) -> Result<(), SceneError> {
        let center = p.vector("center")?.unwrap_or(DVec3::ZERO);
        let radius = p.float_or("radius", 1.0)?;
        let m =
            to_world * DMat4::from_translation(center) * DMat4::from_scale(DVec3::splat(radius));
        let linear = DMat3::from_mat4(m);
        let scales = [linear.x_axis, linear.y_axis, linear.z_axis].map(DVec3::length);
        let orthogonal = linear.x_axis.dot(linear.y_axis).abs()
            + linear.y_axis.dot(linear.z_axis).abs()
            + linear.x_axis.dot(linear.z_axis).abs();
        if (scales[0] - scales[1]).abs() > 1e-6 * scales[0]
            || (scales[0] - scales[2]).abs() > 1e-6 * scales[0]
            || orthogonal > 1e-6 * scales[0] * scales[0]
        {
            return Err(p.error(
                "a sphere's to_world must scale uniformly (an ellipsoid is not supported)",
            ));
        }
        let sphere = Sphere {
            center: m.transform_point3(DVec3::ZERO).as_vec3(),
            radius: scales[0] as f32,
            axis: linear.z_axis.try_normalize().unwrap_or(DVec3::Z).as_vec3(),
            material,
            inside: flip,
        };
        let element = p.element();
        self.builder
            .add_sphere(p.object.at.file.as_path(), &element, sphere)?;
        self.finish(p);
        Ok(())
    }

    /// Adds a world-space mesh with one material.
    fn add_mesh(&mut self, p: &Plugin, mesh: &MeshData, material: u32) -> Result<(), SceneError> {
        let file = p.object.at.file.clone();
        let element = p.element();
        let name = || element.clone();
        self.builder
            .reserve(mesh.triangles.len(), mesh.positions.len());
        self.builder.begin_shared_vertices(mesh.positions.len());
        let count = mesh.positions.len();
        for t in &mesh.triangles {
            if t.iter().any(|&i| i as usize >= count) {
                return Err(p.error(format!("triangle {t:?} indexes past {count} vertices")));
            }
            let at = |v: &[Vec3]| (!v.is_empty()).then(|| t.map(|i| v[i as usize]));
            let uvs = (!mesh.uvs.is_empty()).then(|| t.map(|i| mesh.uvs[i as usize]));
            self.builder.add_indexed_triangle(
                file.as_path(),
                &name,
                *t,
                t.map(|i| mesh.positions[i as usize]),
                at(&mesh.normals),
                uvs,
                None,
                material,
            )?;
        }
        Ok(())
    }

    /// A file named by property `name`: looked up against the main file's
    /// folder, then the `<path>` folders (note §1.5: not the including file's).
    fn file(&mut self, p: &Plugin, name: &str) -> Result<PathBuf, SceneError> {
        let reference = p
            .string(name)?
            .ok_or_else(|| p.error(format!("needs a {} property", quoted(name))))?;
        let element = format!("{}: {name}", p.element());
        for dir in self.search_path {
            let referrer = dir.join("_");
            if dir.join(reference).is_file() {
                return self.policy.resolve(&referrer, &element, reference);
            }
        }
        self.policy.resolve(self.main, &element, reference)
    }

    /// The material of a shape: its BSDF (or Mitsuba's defaults: diffuse
    /// 0.5, or black for an emitter) with its area emitter's radiance.
    fn shape_material(&mut self, p: &Plugin<'a>) -> Result<u32, SceneError> {
        let bsdf = p.child("bsdf")?;
        let mut emission = Vec3::ZERO;
        for emitter in p.children("emitter")? {
            if emitter.plugin != "area" {
                return Err(SceneError::unsupported(
                    emitter.at.file.as_path(),
                    format!(
                        "{}: only area emitters can be attached to a shape",
                        xml::element_name(&emitter.at, &emitter.tag, &emitter.plugin)
                    ),
                ));
            }
            let e = Plugin::new(emitter, self.ids);
            emission += e.rgb("radiance", true, false)?.unwrap_or(Vec3::ONE);
            self.finish(&e);
        }
        let key = (
            bsdf.map_or(0, |b| b as *const Object as usize),
            emission.to_array().map(f32::to_bits),
        );
        if let Some(&m) = self.materials.get(&key) {
            return Ok(m);
        }
        let (name, surface) = match bsdf {
            Some(b) => (
                b.id.clone()
                    .unwrap_or_else(|| format!("{} line {}", b.plugin, b.at.line)),
                self.bsdf(b, 0)?,
            ),
            None => (
                "default".into(),
                Surface::Diffuse {
                    reflectance: Vec3::splat(if emission == Vec3::ZERO { 0.5 } else { 0.0 }),
                },
            ),
        };
        let index = self
            .builder
            .add_material(Material::new(name, surface, emission));
        self.materials.insert(key, index);
        Ok(index)
    }

    // ---- BSDFs ----------------------------------------------------------

    fn bsdf(&mut self, object: &'a Object, depth: usize) -> Result<Surface, SceneError> {
        let p = Plugin::new(object, self.ids);
        if depth > props::MAX_REFERENCE_DEPTH {
            return Err(p.error("BSDFs nest or refer to each other too deeply (a cycle?)"));
        }
        let surface = match p.plugin() {
            "twosided" => {
                let children = p.children("bsdf")?;
                match children.as_slice() {
                    [one] => self.bsdf(one, depth + 1)?,
                    [front, back] => {
                        let s = self.bsdf(front, depth + 1)?;
                        if self.bsdf(back, depth + 1)? != s {
                            self.warn_at(
                                object,
                                "a different back BSDF ignored: both sides use the front one",
                            );
                        }
                        s
                    }
                    _ => return Err(p.error("twosided takes one or two BSDFs")),
                }
            }
            "diffuse" => match p.color("reflectance", false, true)? {
                None => Surface::Diffuse {
                    reflectance: Vec3::splat(0.5),
                },
                Some(Color::Rgb(reflectance)) => Surface::Diffuse { reflectance },
                Some(Color::Texture(t)) => {
                    let texture = self.texture(t)?;
                    Surface::Textured(TexturedPbr::lambertian(Vec3::ONE, Some(texture)))
                }
            },
            "conductor" | "roughconductor" => {
                let model = self.model(&p)?;
                let fresnel = self.conductor_fresnel(&p)?;
                Surface::Conductor { model, fresnel }
            }
            "dielectric" | "roughdielectric" => {
                let model = self.model(&p)?;
                let ior = p.ior("int_ior", "bk7")? / p.ior("ext_ior", "air")?;
                self.ignore_unit_color(&p, "specular_reflectance")?;
                let tint = p
                    .rgb("specular_transmittance", false, true)?
                    .unwrap_or(Vec3::ONE);
                Surface::Dielectric { model, ior, tint }
            }
            "thindielectric" => {
                let ior = p.ior("int_ior", "bk7")? / p.ior("ext_ior", "air")?;
                self.ignore_unit_color(&p, "specular_reflectance")?;
                let tint = p
                    .rgb("specular_transmittance", false, true)?
                    .unwrap_or(Vec3::ONE);
                Surface::ThinDielectric { ior, tint }
            }
            "plastic" | "roughplastic" => {
                let model = self.model(&p)?;
                let ior = p.ior("int_ior", "polypropylene")? / p.ior("ext_ior", "air")?;
                self.ignore_unit_color(&p, "specular_reflectance")?;
                if p.boolean_or("nonlinear", false)? {
                    self.warn_at(object, "nonlinear=true ignored");
                }
                let base_color = p
                    .rgb("diffuse_reflectance", false, true)?
                    .unwrap_or(Vec3::splat(0.5));
                Surface::Coated(Coated {
                    model,
                    base_color,
                    metallic: 0.0,
                    specular: 1.0,
                    specular_color: Vec3::ONE,
                    ior,
                })
            }
            other => {
                return Err(unsupported(
                    object,
                    format!(
                        "BSDF type {} is not supported (diffuse, conductor, roughconductor, dielectric, roughdielectric, thindielectric, plastic, roughplastic, twosided are)",
                        quoted(other)
                    ),
                ));
            }
        };
        self.finish(&p);
        Ok(surface)
    }

    /// The microfacet model of a lobe: smooth for the plugins without
    /// "rough", else `distribution` and `alpha` (Mitsuba's defaults:
    /// beckmann, 0.1), Smith shadowing.
    fn model(&mut self, p: &Plugin) -> Result<MicrofacetModel, SceneError> {
        if !p.plugin().starts_with("rough") {
            return Ok(MicrofacetModel::new(NdfKind::Ggx, 0.0, Shadowing::Smith));
        }
        let kind = match p.string("distribution")?.unwrap_or("beckmann") {
            "beckmann" => NdfKind::Beckmann,
            "ggx" => NdfKind::Ggx,
            other => {
                return Err(p.error(format!(
                    "distribution {} is not beckmann or ggx",
                    quoted(other)
                )));
            }
        };
        let alpha = match (p.float("alpha_u")?, p.float("alpha_v")?) {
            (Some(u), Some(v)) if u == v => u,
            (None, None) => p
                .rgb("alpha", false, false)?
                .map_or(DEFAULT_ALPHA, |a| f64::from(a.x)),
            _ => return Err(p.error("anisotropic roughness (alpha_u != alpha_v) is not supported")),
        };
        if !(alpha >= 0.0) {
            return Err(p.error(format!("alpha must be >= 0, got {alpha}")));
        }
        p.boolean_or("sample_visible", true)?;
        Ok(MicrofacetModel::new(kind, alpha as f32, Shadowing::Smith))
    }

    /// A conductor's complex index: `material` from Mitsuba's table, or
    /// `eta` and `k` (both at once is an error, as in Mitsuba), and
    /// `specular_reflectance`, which scales its reflectance.
    fn conductor_fresnel(&mut self, p: &Plugin) -> Result<Fresnel, SceneError> {
        let tint = p
            .rgb("specular_reflectance", false, true)?
            .unwrap_or(Vec3::ONE);
        let material = p.string("material")?;
        let (eta, k) = (p.rgb("eta", false, false)?, p.rgb("k", false, false)?);
        let (eta, k) = match (material, eta, k) {
            (Some(_), Some(_), _) | (Some(_), _, Some(_)) => {
                return Err(p.error("give either material or eta and k, not both"));
            }
            (None, Some(eta), Some(k)) => (eta, k),
            (None, Some(_), None) | (None, None, Some(_)) => {
                return Err(p.error("eta and k go together"));
            }
            (material, None, None) => {
                let name = material.unwrap_or("none");
                let (eta, k) = tables::conductor(name).ok_or_else(|| {
                    p.error(format!("unknown conductor material {}", quoted(name)))
                })?;
                (Vec3::from(eta), Vec3::from(k))
            }
        };
        if eta.min_element() == 0.0 && k.min_element() == 0.0 && eta.max_element() > 0.0 {
            return Err(p.error("eta = k = 0 in a channel: Mitsuba's Fresnel is NaN there"));
        }
        Ok(Fresnel::Conductor { eta, k, tint })
    }

    /// Reads a colour that we support only at its default, 1 (a warning
    /// otherwise).
    fn ignore_unit_color(&mut self, p: &Plugin, name: &str) -> Result<(), SceneError> {
        match p.color(name, false, false)? {
            None => {}
            Some(Color::Rgb(c)) if c == Vec3::ONE => {}
            Some(_) => self.warn_at(p.object, format!("{name} other than 1 ignored")),
        }
        Ok(())
    }

    /// A `bitmap` texture (sRGB-decoded unless `raw`), uv (0, 0) at the
    /// image's top left, as Mitsuba's (note §2.3).
    fn texture(&mut self, object: &'a Object) -> Result<usize, SceneError> {
        let p = Plugin::new(object, self.ids);
        if p.plugin() != "bitmap" {
            return Err(unsupported(
                object,
                format!(
                    "texture type {} is not supported (bitmap is)",
                    quoted(p.plugin())
                ),
            ));
        }
        let file = self.file(&p, "filename")?;
        let srgb = !p.boolean_or("raw", false)?;
        let wrap = match p.string("wrap_mode")?.unwrap_or("repeat") {
            "repeat" => Wrap::Repeat,
            "mirror" => Wrap::Mirror,
            "clamp" => Wrap::Clamp,
            other => {
                return Err(p.error(format!(
                    "wrap_mode {} is not repeat, mirror or clamp",
                    quoted(other)
                )));
            }
        };
        if p.string("filter_type")? == Some("nearest") {
            self.warn_at(object, "filter_type=nearest ignored: lookups are bilinear");
        }
        if p.transform("to_uv")? != DMat4::IDENTITY {
            return Err(p.error("to_uv is not supported"));
        }
        self.finish(&p);
        let key = (file.clone(), srgb);
        if let Some(&t) = self.textures.get(&key) {
            return Ok(t);
        }
        let image = image::open(&file)
            .map_err(|e| SceneError::invalid(&file, p.element(), e.to_string()))?
            .to_rgba8();
        let mut texture = Texture::from_u8(image.width(), image.height(), 4, image.as_raw(), srgb)
            .ok_or_else(|| SceneError::invalid(&file, p.element(), "the image is empty"))?;
        texture.wrap_u = wrap;
        texture.wrap_v = wrap;
        let index = self.builder.add_texture(texture);
        self.textures.insert(key, index);
        Ok(index)
    }

    // ---- emitters -------------------------------------------------------

    fn emitter(&mut self, object: &'a Object) -> Result<(), SceneError> {
        let p = Plugin::new(object, self.ids);
        let rgb = |name: &str, default: Vec3| {
            Ok::<_, SceneError>(p.rgb(name, true, false)?.unwrap_or(default))
        };
        let to_world = p.transform("to_world")?;
        let light = match p.plugin() {
            "point" => {
                let position = match p.vector("position")? {
                    Some(v) => v,
                    None => to_world.transform_point3(DVec3::ZERO),
                };
                Light::Point {
                    position: position.as_vec3(),
                    intensity: rgb("intensity", Vec3::ONE)?,
                }
            }
            "spot" => {
                let cutoff = p.float_or("cutoff_angle", 20.0)?;
                let beam = p.float_or("beam_width", 0.75 * cutoff)?;
                if !(cutoff > 0.0 && cutoff <= 180.0 && beam >= 0.0 && beam <= cutoff) {
                    return Err(p.error(format!(
                        "needs 0 <= beam_width <= cutoff_angle in (0, 180], got {beam} and {cutoff}"
                    )));
                }
                self.warn_at(object, "the spot's falloff between beam_width and cutoff_angle is glTF's smooth curve, Mitsuba's is linear in the angle");
                Light::Spot {
                    position: to_world.transform_point3(DVec3::ZERO).as_vec3(),
                    direction: unit(to_world.transform_vector3(DVec3::Z))
                        .ok_or_else(|| p.error("to_world collapses the spot's axis"))?,
                    intensity: rgb("intensity", Vec3::ONE)?,
                    cos_inner: beam.to_radians().cos() as f32,
                    cos_outer: cutoff.to_radians().cos() as f32,
                }
            }
            "directional" => {
                let direction = match p.vector("direction")? {
                    Some(d) => d,
                    None => to_world.transform_vector3(DVec3::Z),
                };
                Light::Directional {
                    direction: unit(direction).ok_or_else(|| p.error("the direction is zero"))?,
                    irradiance: rgb("irradiance", Vec3::ONE)?,
                }
            }
            "constant" => Light::Environment {
                radiance: rgb("radiance", Vec3::ONE)?,
            },
            "envmap" => {
                let file = self.file(&p, "filename")?;
                let scale = p.float_or("scale", 1.0)? as f32;
                let rotation = y_rotation_degrees(to_world).ok_or_else(|| {
                    p.error("an envmap's to_world must be a rotation about +y here")
                })?;
                let map = crate::environment::EnvironmentMap::load(&file, scale, rotation)?;
                self.builder.environment_maps.push(map);
                Light::EnvironmentMap {
                    map: (self.builder.environment_maps.len() - 1) as u32,
                }
            }
            "area" => return Err(p.error("an area emitter must be nested in a shape")),
            other => {
                return Err(unsupported(
                    object,
                    format!(
                        "emitter type {} is not supported (area, point, spot, directional, constant, envmap are)",
                        quoted(other)
                    ),
                ));
            }
        };
        self.builder.lights.push(light);
        self.finish(&p);
        Ok(())
    }

    // ---- sensor, film, sampler, integrator -----------------------------

    fn sensor(&mut self, object: &'a Object) -> Result<(), SceneError> {
        let p = Plugin::new(object, self.ids);
        if p.plugin() != "perspective" {
            return Err(unsupported(
                object,
                format!(
                    "sensor type {} is not supported (perspective is)",
                    quoted(p.plugin())
                ),
            ));
        }
        let m = p.transform("to_world")?;
        let linear = DMat3::from_mat4(m);
        let position = m.transform_point3(DVec3::ZERO);
        let forward =
            unit(linear.z_axis).ok_or_else(|| p.error("to_world collapses the view axis"))?;
        let up = unit(linear.y_axis).ok_or_else(|| p.error("to_world collapses the up axis"))?;
        let (fov, axis) = match (p.float("fov")?, p.string("focal_length")?) {
            (Some(fov), _) => (fov, self.fov_axis(&p)?),
            (None, Some(f)) => (
                focal_length_fov(f).map_err(|e| p.error(e))?,
                FovAxis::Diagonal,
            ),
            (None, None) => (
                focal_length_fov("50mm").map_err(|e| p.error(e))?,
                FovAxis::Diagonal,
            ),
        };
        if !(fov > 0.0 && fov < 180.0) {
            return Err(p.error(format!("fov must be in (0, 180) degrees, got {fov}")));
        }
        let near_clip = p.float_or("near_clip", NEAR_CLIP)?;
        p.float("far_clip")?;
        self.camera = Some(CameraSpec {
            from: position.as_vec3(),
            at: (position + forward.as_dvec3()).as_vec3(),
            up,
            fov_degrees: fov as f32,
            fov_axis: axis,
            aspect: None,
            mirrored: linear.determinant() < 0.0,
            near_clip: near_clip as f32,
        });
        if let Some(film) = p.child("film")? {
            self.film(film)?;
        } else {
            self.resolution = Some(DEFAULT_FILM);
        }
        if let Some(sampler) = p.child("sampler")? {
            let s = Plugin::new(sampler, self.ids);
            let count = s.integer("sample_count")?.unwrap_or(4);
            self.render.iterations = Some(
                u32::try_from(count)
                    .ok()
                    .filter(|&c| c > 0)
                    .ok_or_else(|| s.error(format!("sample_count must be >= 1, got {count}")))?,
            );
            s.integer("seed")?;
            self.finish(&s);
        }
        self.finish(&p);
        if let Some(c) = self.camera
            && let Err(e) = c.camera(self.resolution.unwrap_or(DEFAULT_FILM))
        {
            return Err(p.error(e));
        }
        Ok(())
    }

    fn fov_axis(&self, p: &Plugin) -> Result<FovAxis, SceneError> {
        Ok(match p.string("fov_axis")?.unwrap_or("x") {
            "x" => FovAxis::X,
            "y" => FovAxis::Y,
            "diagonal" => FovAxis::Diagonal,
            "smaller" => FovAxis::Smaller,
            "larger" => FovAxis::Larger,
            other => {
                return Err(p.error(format!(
                    "fov_axis {} is not x, y, diagonal, smaller or larger",
                    quoted(other)
                )));
            }
        })
    }

    fn film(&mut self, object: &'a Object) -> Result<(), SceneError> {
        let p = Plugin::new(object, self.ids);
        let size = |name: &str, default: u32| -> Result<u32, SceneError> {
            let v = p.integer(name)?.unwrap_or(i64::from(default));
            u32::try_from(v)
                .ok()
                .filter(|&v| (1..=crate::manifest::MAX_RESOLUTION).contains(&v))
                .ok_or_else(|| {
                    p.error(format!(
                        "{name} must be in 1..={}, got {v}",
                        crate::manifest::MAX_RESOLUTION
                    ))
                })
        };
        self.resolution = Some(UVec2::new(
            size("width", DEFAULT_FILM.x)?,
            size("height", DEFAULT_FILM.y)?,
        ));
        // What an EXR stores does not change the image.
        for name in ["file_format", "pixel_format", "component_format"] {
            p.string(name)?;
        }
        p.boolean_or("banner", false)?;
        p.boolean_or("high_quality_edges", false)?;
        match p.child("rfilter")? {
            Some(f) if f.plugin == "box" => {}
            filter => {
                let what = filter.map_or("gaussian (Mitsuba's default)".to_owned(), |f| {
                    quoted(&f.plugin)
                });
                self.warn_at(
                    object,
                    format!(
                        "reconstruction filter {what} replaced by a box filter (the only one here)"
                    ),
                );
            }
        }
        self.finish(&p);
        Ok(())
    }

    fn integrator(&mut self, object: &'a Object) -> Result<(), SceneError> {
        let p = Plugin::new(object, self.ids);
        match p.plugin() {
            "path" | "volpath" => self.render.integrator = Some("pt".into()),
            other => self.warn_at(object, format!("integrator {} is not one of ours: the renderer's default or --integrator decides", quoted(other))),
        }
        if let Some(depth) = p.integer("max_depth")? {
            match u32::try_from(depth) {
                Ok(d) if d > 0 => self.render.max_depth = Some(d),
                _ if depth == -1 => self.warn_at(
                    object,
                    "max_depth -1 (unbounded): the renderer's default or --max-depth decides",
                ),
                _ => return Err(p.error(format!("max_depth must be -1 or >= 1, got {depth}"))),
            }
        }
        // Russian roulette changes noise, not the expected image.
        p.integer("rr_depth")?;
        if p.boolean_or("hide_emitters", false)? {
            self.warn_at(
                object,
                "hide_emitters ignored: directly seen emitters are shown",
            );
        }
        if p.plugin() == "path" || p.plugin() == "volpath" {
            self.finish(&p);
        }
        Ok(())
    }
}

/// Largest PLY or `.serialized` file read (they are read whole): the bound
/// of one inflated mesh, [`serialized::MAX_MESH_BYTES`]; a larger file is
/// refused before it is read.
pub const MAX_MESH_FILE_BYTES: u64 = serialized::MAX_MESH_BYTES;

/// The bytes of a mesh file, refused above [`MAX_MESH_FILE_BYTES`].
fn read_mesh_file(path: &Path) -> Result<Vec<u8>, SceneError> {
    let size = std::fs::metadata(path)
        .map_err(|e| SceneError::io(path, e))?
        .len();
    if size > MAX_MESH_FILE_BYTES {
        return Err(SceneError::malformed(
            path,
            format!("{size} bytes: a mesh file larger than {MAX_MESH_FILE_BYTES} bytes is refused"),
        ));
    }
    std::fs::read(path).map_err(|e| SceneError::io(path, e))
}

/// An error saying that `object` uses what is not supported here.
fn unsupported(object: &Object, what: impl std::fmt::Display) -> SceneError {
    SceneError::unsupported(
        object.at.file.as_path(),
        format!(
            "{}: {what}",
            xml::element_name(&object.at, &object.tag, &object.plugin)
        ),
    )
}

/// The unit vector along `v` in f32, if it has a length.
fn unit(v: DVec3) -> Option<Vec3> {
    v.try_normalize().map(DVec3::as_vec3)
}

/// The angle of a `to_world` that rotates about +y only (translation
/// ignored: a map is at infinity), in degrees.
fn y_rotation_degrees(m: DMat4) -> Option<f32> {
    let l = DMat3::from_mat4(m);
    let theta = (-l.x_axis.z).atan2(l.x_axis.x);
    let r = DMat3::from_rotation_y(theta);
    let error = (l.x_axis - r.x_axis).length()
        + (l.y_axis - r.y_axis).length()
        + (l.z_axis - r.z_axis).length();
    (error < 1e-5).then_some(theta.to_degrees() as f32)
}

/// The diagonal field of view of a 35 mm focal length such as "50mm"
/// (Mitsuba's `parse_fov`: 2 atan(sqrt(36^2 + 24^2) / (2 f))).
fn focal_length_fov(value: &str) -> Result<f64, String> {
    let f: f64 = value
        .trim()
        .trim_end_matches("mm")
        .parse()
        .map_err(|_| format!("focal_length {} is not like \"50mm\"", quoted(value)))?;
    if !(f > 0.0 && f.is_finite()) {
        return Err(format!("focal_length must be > 0, got {f}"));
    }
    Ok((2.0 * ((36.0f64 * 36.0 + 24.0 * 24.0).sqrt() / (2.0 * f)).atan()).to_degrees())
}

/// An OBJ file's geometry only (Mitsuba reads `v`, `vt`, `vn`, `f` and
/// ignores materials: the shape's BSDF applies), through our OBJ reader
/// and its input checks.
fn obj_mesh(path: &Path, policy: &ReferencePolicy) -> Result<MeshData, SceneError> {
    let b = crate::error::guarded(path, "the OBJ reader", || crate::obj::load(path, policy))?;
    let has = |n: &Vec3| *n != Vec3::ZERO;
    Ok(MeshData {
        normals: if b.normals.iter().all(has) {
            b.normals.clone()
        } else {
            Vec::new()
        },
        uvs: if b.uvs.iter().any(|uv| *uv != Vec2::ZERO) {
            b.uvs.clone()
        } else {
            Vec::new()
        },
        positions: b.positions,
        triangles: b.triangles,
    })
}
