//! Wavefront OBJ/MTL loading with `tobj` (mapping: see `material` module docs).

use std::collections::HashMap;
use std::path::Path;

use glam::{Vec2, Vec3};
use microfacet::{Fresnel, MicrofacetModel, NdfKind, Shadowing};

use crate::error::SceneError;
use crate::material::{Material, Surface, TexturedPbr};
use crate::scene::SceneBuilder;
use crate::texture::Texture;

/// Materials with a dissolve `d` below this are transparent (glass-like).
const OPAQUE_DISSOLVE: f32 = 0.999;

/// Material of faces without `usemtl`.
fn default_material() -> Material {
    Material {
        name: "default".into(),
        surface: Surface::Diffuse {
            reflectance: Vec3::splat(0.8),
        },
        emission: Vec3::ZERO,
    }
}

/// Loads an OBJ file and the MTL files it references.
pub fn load(
    path: &Path,
    _policy: &crate::paths::ReferencePolicy,
) -> Result<SceneBuilder, SceneError> {
    let text = std::fs::read(path).map_err(|e| SceneError::io(path, e))?;
    check_lines(path, &text)?;
    let options = tobj::LoadOptions {
        single_index: true,
        triangulate: true,
        ignore_points: true,
        ignore_lines: true,
    };
    let (models, materials) =
        tobj::load_obj(path, &options).map_err(|e| SceneError::malformed(path, describe(&e)))?;
    let mtl_materials = match materials {
        Ok(m) => m,
        Err(e) => {
            return Err(SceneError::malformed(
                path,
                format!(
                    "its material library (mtllib) failed to load: {}",
                    describe(&e)
                ),
            ));
        }
    };
    let mut builder = SceneBuilder::default();
    let directory = path.parent().unwrap_or(Path::new("."));
    let mut texture_cache: HashMap<String, usize> = HashMap::new();
    let mut material_ids = Vec::with_capacity(mtl_materials.len());
    for m in &mtl_materials {
        let material = map_material(path, directory, m, &mut builder, &mut texture_cache)?;
        material_ids.push(builder.add_material(material));
    }
    let mut default_id = None;
    for model in &models {
        let mesh = &model.mesh;
        let material = match mesh.material_id {
            Some(id) => *material_ids.get(id).ok_or_else(|| {
                SceneError::malformed(
                    path,
                    format!(
                        "object \"{}\" uses material {id}, which the MTL does not define",
                        model.name
                    ),
                )
            })?,
            None => *default_id.get_or_insert_with(|| builder.add_material(default_material())),
        };
        let vertex = |i: u32| -> Option<Vec3> {
            let i = i as usize * 3;
            mesh.positions
                .get(i..i + 3)
                .map(|p| Vec3::new(p[0], p[1], p[2]))
        };
        let normal = |i: u32| -> Option<Vec3> {
            let i = i as usize * 3;
            mesh.normals
                .get(i..i + 3)
                .map(|p| Vec3::new(p[0], p[1], p[2]))
        };
        let uv = |i: u32| -> Option<Vec2> {
            let i = i as usize * 2;
            // OBJ's v runs upwards; textures store the top row first.
            mesh.texcoords
                .get(i..i + 2)
                .map(|t| Vec2::new(t[0], 1.0 - t[1]))
        };
        for (f, face) in mesh.indices.chunks_exact(3).enumerate() {
            let element = || format!("object \"{}\", triangle {f}", model.name);
            let get = |g: &dyn Fn(u32) -> Option<Vec3>| -> Option<[Vec3; 3]> {
                Some([g(face[0])?, g(face[1])?, g(face[2])?])
            };
            let positions = get(&vertex).ok_or_else(|| {
                SceneError::malformed(path, format!("{}: vertex index out of range", element()))
            })?;
            let normals = if mesh.normals.is_empty() {
                None
            } else {
                get(&normal)
            };
            let uvs = if mesh.texcoords.is_empty() {
                None
            } else {
                (|| Some([uv(face[0])?, uv(face[1])?, uv(face[2])?]))()
            };
            builder.add_triangle(path, &element, positions, normals, uvs, material)?;
        }
    }
    Ok(builder)
}

/// Finds the first `v`, `vn` or `vt` line with a number that does not parse or is
/// not finite, and the first face with fewer than three vertices, so that the
/// error names the line (tobj's errors do not; it drops short faces silently).
fn check_lines(path: &Path, text: &[u8]) -> Result<(), SceneError> {
    let text = String::from_utf8_lossy(text);
    for (n, line) in text.lines().enumerate() {
        let mut words = line.split_whitespace();
        match words.next() {
            Some("v" | "vn" | "vt") => {}
            Some("f") if words.clone().count() < 3 => {
                return Err(SceneError::invalid(
                    path,
                    format!("line {}", n + 1),
                    "a face needs at least three vertices",
                ));
            }
            _ => continue,
        }
        for word in words {
            match word.parse::<f32>() {
                Ok(x) if x.is_finite() => {}
                _ => {
                    return Err(SceneError::invalid(
                        path,
                        format!("line {}", n + 1),
                        format!("\"{word}\" is not a finite number"),
                    ));
                }
            }
        }
    }
    Ok(())
}

fn describe(e: &tobj::LoadError) -> String {
    use tobj::LoadError::*;
    match e {
        OpenFileFailed => "the file (or a material library it names) cannot be opened".into(),
        ReadError => "read error".into(),
        UnrecognizedCharacter => "unrecognized character".into(),
        PositionParseError => "malformed vertex position (v)".into(),
        NormalParseError => "malformed vertex normal (vn)".into(),
        TexcoordParseError => "malformed texture coordinate (vt)".into(),
        FaceParseError => "malformed face (f)".into(),
        MaterialParseError => "malformed material library".into(),
        InvalidObjectName => "invalid object name".into(),
        InvalidPolygon => "face with fewer than three vertices".into(),
        FaceVertexOutOfBounds => "a face refers to a vertex that does not exist".into(),
        FaceTexCoordOutOfBounds => {
            "a face refers to a texture coordinate that does not exist".into()
        }
        FaceNormalOutOfBounds => "a face refers to a normal that does not exist".into(),
        FaceColorOutOfBounds => "a face refers to a vertex colour that does not exist".into(),
        other => format!("{other:?}"),
    }
}

fn param(m: &tobj::Material, key: &str) -> Option<f32> {
    m.unknown_param
        .get(key)
        .and_then(|v| v.split_whitespace().next()?.parse().ok())
}

fn rgb(c: Option<[f32; 3]>) -> Vec3 {
    c.map_or(Vec3::ZERO, Vec3::from_array)
}

/// The mapping of the `material` module docs, with range checks.
fn map_material(
    path: &Path,
    directory: &Path,
    m: &tobj::Material,
    builder: &mut SceneBuilder,
    textures: &mut HashMap<String, usize>,
) -> Result<Material, SceneError> {
    let element = || format!("material \"{}\"", m.name);
    let kd = rgb(m.diffuse);
    let ks = rgb(m.specular);
    let ke = rgb(m.emissive);
    for (name, c) in [("Kd", kd), ("Ks", ks), ("Ke", ke)] {
        if !c.is_finite() || c.min_element() < 0.0 {
            return Err(SceneError::invalid(
                path,
                element(),
                format!("{name} must be finite and non-negative, got {c}"),
            ));
        }
    }
    let roughness = param(m, "Pr");
    let metallic = param(m, "Pm");
    if let Some(r) = roughness.filter(|r| !(r.is_finite() && *r >= 0.0)) {
        return Err(SceneError::invalid(
            path,
            element(),
            format!("roughness Pr must be >= 0, got {r}"),
        ));
    }
    let ior = m.optical_density.unwrap_or(1.5);
    let dissolve = m
        .dissolve
        .or_else(|| param(m, "Tr").map(|tr| 1.0 - tr))
        .unwrap_or(1.0);
    let illum = m.illumination_model.unwrap_or(2);
    let smooth_or_pr = roughness.map_or(0.0, |r| r * r);
    let surface = if illum == 7 || dissolve < OPAQUE_DISSOLVE {
        if !(ior > 0.0 && ior.is_finite()) {
            return Err(SceneError::invalid(
                path,
                element(),
                format!("index of refraction Ni must be > 0, got {ior}"),
            ));
        }
        Surface::Dielectric {
            model: MicrofacetModel::new(NdfKind::Ggx, smooth_or_pr, Shadowing::Smith),
            ior,
        }
    } else if illum == 5 {
        Surface::Conductor {
            model: MicrofacetModel::new(NdfKind::Ggx, smooth_or_pr, Shadowing::Smith),
            fresnel: Fresnel::Schlick {
                f0: ks.min(Vec3::ONE),
            },
        }
    } else if metallic.is_some_and(|pm| pm >= 0.5) {
        let r = roughness.unwrap_or(0.5);
        Surface::Conductor {
            model: MicrofacetModel::new(NdfKind::Ggx, r * r, Shadowing::Smith),
            fresnel: Fresnel::Schlick {
                f0: kd.min(Vec3::ONE),
            },
        }
    } else if ks.max_element() > kd.max_element() && m.shininess.is_some() {
        let ns = m.shininess.unwrap_or(0.0).max(0.0);
        Surface::Conductor {
            // supp. eq. 5: n = 2/alpha^2 - 2.
            model: MicrofacetModel::new(
                NdfKind::BlinnPhong,
                (2.0 / (ns + 2.0)).sqrt(),
                Shadowing::Smith,
            ),
            fresnel: Fresnel::Schlick {
                f0: ks.min(Vec3::ONE),
            },
        }
    } else {
        Surface::Diffuse {
            reflectance: kd.min(Vec3::ONE),
        }
    };
    let surface = match (&m.diffuse_texture, surface) {
        (Some(file), Surface::Diffuse { reflectance }) => {
            let id = load_texture(path, directory, file, builder, textures)?;
            Surface::Textured(TexturedPbr {
                base_color: reflectance,
                base_color_texture: Some(id),
                metallic: 0.0,
                roughness: 1.0,
                metallic_roughness_texture: None,
                ndf: NdfKind::Ggx,
                shadowing: Shadowing::Smith,
            })
        }
        (Some(file), s) => {
            builder.report.warnings.push(format!(
                "{}: {}: map_Kd \"{file}\" ignored on a non-diffuse material",
                path.display(),
                element()
            ));
            s
        }
        (None, s) => s,
    };
    Ok(Material {
        name: m.name.clone(),
        surface,
        emission: ke,
    })
}

fn load_texture(
    path: &Path,
    directory: &Path,
    file: &str,
    builder: &mut SceneBuilder,
    cache: &mut HashMap<String, usize>,
) -> Result<usize, SceneError> {
    if let Some(&id) = cache.get(file) {
        return Ok(id);
    }
    let texture_path = directory.join(file);
    let image = image::open(&texture_path)
        .map_err(|e| {
            SceneError::malformed(path, format!("texture \"{}\": {e}", texture_path.display()))
        })?
        .to_rgba8();
    let texture = Texture::from_u8(image.width(), image.height(), 4, image.as_raw(), true)
        .ok_or_else(|| {
            SceneError::malformed(
                path,
                format!("texture \"{}\" is empty", texture_path.display()),
            )
        })?;
    let id = builder.add_texture(texture);
    cache.insert(file.to_string(), id);
    Ok(id)
}
