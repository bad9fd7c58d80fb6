//! `scene.toml`: which model files to load, camera, resolution, extra lights
//! and shapes, material overrides by name, and default render settings.
//!
//! ```toml
//! description = "one line"      # optional
//! resolution = [512, 512]
//! [camera]                      # look-from, look-at, up, vertical fov in degrees
//! from = [0, 1, 3.5]
//! at = [0, 1, 0]
//! up = [0, 1, 0]                # optional, default +y
//! fov = 40
//! # name = "render_camera"      # or: use this glTF camera instead
//! [render]                      # defaults; the command line's flags override them
//! integrator = "pt"             # pt | bpt | ppm | bpm | vcm
//! iterations = 64
//! max_depth = 16
//! regularize = "unsampleable"   # off | uniform | selective | unsampleable (the default)
//! tau0 = 30                     # > 1/(2 pi), per steradian; default 30
//! progressive = true            # false: tau stays tau0 (a fixed blur)
//! regularize_energy = true      # false: regularized lobes lose energy (darker)
//! seed = 0
//! radius = 0.003                # first merge radius (ppm, bpm, vcm), fraction of the scene radius, > 0
//! shadow_roulette = 0.1         # shadow-ray roulette (bpt, vcm), fraction of the mean pixel, >= 0
//! virtual_merges = true         # bpt, vcm with regularization (default: on for vcm only)
//! [[model]]
//! file = "cornell.obj"          # relative to this file; .obj, .gltf, .glb
//! [[material]]                  # overrides a model's material of that name,
//! name = "floor"                # or defines one for shapes
//! type = "conductor"            # diffuse | conductor | dielectric | coated (optional for overrides)
//! alpha = 0.02                  # or roughness = r (alpha = r^2)
//! ndf = "ggx"                   # ggx | beckmann | blinn-phong
//! shadowing = "smith"           # smith | v-cavity
//! reflectance = [0.9, 0.9, 0.9] # diffuse albedo, conductor F0 (Schlick), or coated base colour
//! # eta = [..], k = [..]        # conductor complex index instead of F0
//! # ior = 1.5                   # dielectric; coated: the coat's index (glTF's
//! #                             # metallic-roughness lobe with metallic 0, specular 1)
//! # tint = [1, 1, 1]            # dielectric: colour of the refracted part (glTF base colour)
//! # absorption = [0, 0, 0]      # dielectric: sigma_a per unit length of a closed mesh's inside
//! # emission = [10, 10, 10]
//! [[shape]]
//! type = "sphere"               # sphere | quad
//! material = "glass"
//! center = [0, 0.5, 0]
//! radius = 0.5
//! # axis = [0, 1, 0]            # pole of the uv parametrisation (and of a cap)
//! # inside = false              # normals face the centre
//! # tessellate = false          # true: triangles (rings x 2 rings quads) instead of
//! #                             # the analytic sphere; a cap below 180 is always tessellated
//! # cap = 180 (degrees), rings = 48 (tessellated spheres only)
//! # quad: origin = [..], u = [..], v = [..] (faces u x v)
//! [[light]]
//! type = "point"                # point | spot | directional | environment
//! position = [0, 1.9, 0]
//! intensity = [5, 5, 5]         # W/sr (point, spot); irradiance (directional); radiance (environment)
//! # direction = [..], inner = 20, outer = 30 (degrees, spot)
//! [[light]]                     # an environment map instead of a constant environment:
//! type = "environment"          # at most one environment per scene
//! file = "sky.exr"              # equirectangular, .exr or .hdr, relative to this file; no `intensity`
//! scale = 1.0                   # optional radiance multiplier, >= 0
//! rotation = 0                  # optional, degrees about +y (up); orientation in `environment`
//! ```

use std::collections::HashMap;
use std::path::Path;

use glam::{UVec2, Vec3};
use microfacet::{Fresnel, MicrofacetModel, NdfKind, Shadowing};
use serde::Deserialize;

use crate::camera::{CameraSpec, FovAxis};
use crate::environment::EnvironmentMap;
use crate::error::{SceneError, quoted};
use crate::light::Light;
use crate::material::{Material, Medium, Surface};
use crate::paths::ReferencePolicy;
use crate::scene::{RenderSettings, SceneBuilder};
use crate::shapes;
use crate::sphere::Sphere;

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct Manifest {
    description: Option<String>,
    resolution: Option<[u32; 2]>,
    camera: Option<CameraSection>,
    render: Option<RenderSection>,
    #[serde(default, rename = "model")]
    models: Vec<ModelSection>,
    #[serde(default, rename = "material")]
    materials: Vec<MaterialSection>,
    #[serde(default, rename = "shape")]
    shapes: Vec<ShapeSection>,
    #[serde(default, rename = "light")]
    lights: Vec<LightSection>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraSection {
    from: Option<[f32; 3]>,
    at: Option<[f32; 3]>,
    up: Option<[f32; 3]>,
    fov: Option<f32>,
    name: Option<String>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct RenderSection {
    integrator: Option<String>,
    iterations: Option<u32>,
    max_depth: Option<u32>,
    regularize: Option<String>,
    tau0: Option<f64>,
    progressive: Option<bool>,
    seed: Option<u64>,
    radius: Option<f32>,
    shadow_roulette: Option<f32>,
    virtual_merges: Option<bool>,
    regularize_energy: Option<bool>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ModelSection {
    file: String,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MaterialSection {
    name: String,
    #[serde(rename = "type")]
    kind: Option<String>,
    alpha: Option<f32>,
    roughness: Option<f32>,
    ndf: Option<String>,
    shadowing: Option<String>,
    reflectance: Option<[f32; 3]>,
    eta: Option<[f32; 3]>,
    k: Option<[f32; 3]>,
    ior: Option<f32>,
    tint: Option<[f32; 3]>,
    absorption: Option<[f32; 3]>,
    emission: Option<[f32; 3]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ShapeSection {
    #[serde(rename = "type")]
    kind: String,
    material: String,
    center: Option<[f32; 3]>,
    radius: Option<f32>,
    axis: Option<[f32; 3]>,
    cap: Option<f32>,
    inside: Option<bool>,
    rings: Option<u32>,
    tessellate: Option<bool>,
    origin: Option<[f32; 3]>,
    u: Option<[f32; 3]>,
    v: Option<[f32; 3]>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LightSection {
    #[serde(rename = "type")]
    kind: String,
    position: Option<[f32; 3]>,
    direction: Option<[f32; 3]>,
    intensity: Option<[f32; 3]>,
    inner: Option<f32>,
    outer: Option<f32>,
    file: Option<String>,
    scale: Option<f32>,
    rotation: Option<f32>,
}

/// A parsed manifest, ready to be turned into a scene.
pub struct LoadedManifest {
    /// Geometry, materials and lights of the models, shapes and lights.
    pub builder: SceneBuilder,
    /// The camera, from the manifest or the glTF camera it names.
    pub camera: Option<CameraSpec>,
    /// Resolution, if given.
    pub resolution: Option<UVec2>,
    /// Suggested render settings.
    pub render: RenderSettings,
    /// The description line, if any.
    pub description: Option<String>,
}

/// Loads `path` and everything it references.
pub fn load(
    path: &Path,
    camera_name: Option<&str>,
    policy: &ReferencePolicy,
) -> Result<LoadedManifest, SceneError> {
    let text = std::fs::read_to_string(path).map_err(|e| SceneError::io(path, e))?;
    let manifest: Manifest =
        toml::from_str(&text).map_err(|e| SceneError::malformed(path, toml_message(&text, &e)))?;
    let mut builder = SceneBuilder::default();
    let mut camera = None;
    let camera_name = camera_name.or(manifest.camera.as_ref().and_then(|c| c.name.as_deref()));
    for (i, model) in manifest.models.iter().enumerate() {
        let file = policy.resolve(path, &format!("[[model]] {i} file"), &model.file)?;
        let (part, model_camera) = crate::load_model(&file, camera_name, policy)?;
        camera = camera.or(model_camera);
        builder.append(part);
    }
    if let Some(name) = camera_name
        && camera.is_none()
    {
        // glTF models refuse a name they lack; OBJ models have no cameras at all.
        let key = if manifest.camera.as_ref().and_then(|c| c.name.as_deref()) == Some(name) {
            "[camera] name"
        } else {
            "--camera"
        };
        return Err(SceneError::invalid(
            path,
            key,
            format!(
                "no model of this manifest has a camera named {} (OBJ files have no cameras; \
                 give `from`, `at` and `fov` instead)",
                crate::error::quoted(name)
            ),
        ));
    }
    apply_materials(path, &manifest.materials, &mut builder)?;
    add_shapes(path, &manifest.shapes, &mut builder)?;
    for (i, light) in manifest.lights.iter().enumerate() {
        let light = match environment_map(path, i, light, policy)? {
            Some(map) => {
                builder.environment_maps.push(map);
                Light::EnvironmentMap {
                    map: (builder.environment_maps.len() - 1) as u32,
                }
            }
            None => parse_light(path, i, light)?,
        };
        builder.lights.push(light);
    }
    if let Some(c) = &manifest.camera
        && c.name.is_none()
    {
        let element = "[camera]";
        let missing = |field: &str| {
            SceneError::invalid(
                path,
                element,
                format!("`{field}` is required (or give `name` of a glTF camera)"),
            )
        };
        camera = Some(CameraSpec {
            from: Vec3::from_array(c.from.ok_or_else(|| missing("from"))?),
            at: Vec3::from_array(c.at.ok_or_else(|| missing("at"))?),
            up: Vec3::from_array(c.up.unwrap_or([0.0, 1.0, 0.0])),
            fov_degrees: c.fov.ok_or_else(|| missing("fov"))?,
            fov_axis: FovAxis::Y,
            aspect: None,
            mirrored: false,
            near_clip: 0.0,
        });
    }
    let resolution = match manifest.resolution {
        Some([w, h]) if w > 0 && h > 0 && w <= MAX_RESOLUTION && h <= MAX_RESOLUTION => {
            Some(UVec2::new(w, h))
        }
        Some([w, h]) => {
            return Err(SceneError::invalid(
                path,
                "resolution",
                format!("must be between 1 and {MAX_RESOLUTION} pixels per side, got {w}x{h}"),
            ));
        }
        None => None,
    };
    let render = manifest
        .render
        .map_or_else(RenderSettings::default, |r| RenderSettings {
            integrator: r.integrator,
            iterations: r.iterations,
            max_depth: r.max_depth,
            regularize: r.regularize,
            tau0: r.tau0,
            progressive: r.progressive,
            seed: r.seed,
            radius: r.radius,
            shadow_roulette: r.shadow_roulette,
            virtual_merges: r.virtual_merges,
            regularize_energy: r.regularize_energy,
        });
    Ok(LoadedManifest {
        builder,
        camera,
        resolution,
        render,
        description: manifest.description,
    })
}

/// Largest image side a manifest may ask for: the same as `--resolution`'s
/// (a 64k x 64k film took 100 GB and aborted the process); render-cli
/// further checks that the film fits in the available memory.
pub const MAX_RESOLUTION: u32 = 16_384;

/// toml's message with the line of the error and, for a bad value, its key
/// (toml names the expected type but not the key).
fn toml_message(text: &str, e: &toml::de::Error) -> String {
    // toml quotes the offending value, which may be megabytes long.
    let message = e.message().to_string();
    let message = if message.chars().count() > 200 {
        let shown: String = message.chars().take(160).collect();
        format!("{shown}... ({} characters)", message.chars().count())
    } else {
        message
    };
    let Some(span) = e.span() else {
        return message;
    };
    let before = &text[..span.start.min(text.len())];
    let line = before.matches('\n').count() + 1;
    let line_start = before.rfind('\n').map_or(0, |i| i + 1);
    match before[line_start..].split_once('=') {
        Some((key, _)) if !key.trim().is_empty() => {
            format!("line {line}: {}: {message}", key.trim())
        }
        _ => format!("line {line}: {message}"),
    }
}

/// A shape's or light's `type` for its element name, " (point)", when it is
/// a short word; nothing otherwise (the message quotes it).
fn kind_name(kind: &str) -> String {
    let word = |c: char| c.is_ascii_alphanumeric() || c == '_' || c == '-';
    if !kind.is_empty() && kind.len() <= 20 && kind.chars().all(word) {
        format!(" ({kind})")
    } else {
        String::new()
    }
}

fn vec3(a: Option<[f32; 3]>) -> Option<Vec3> {
    a.map(Vec3::from_array)
}

fn apply_materials(
    path: &Path,
    sections: &[MaterialSection],
    builder: &mut SceneBuilder,
) -> Result<(), SceneError> {
    let existing: HashMap<String, usize> = builder
        .materials
        .iter()
        .enumerate()
        .map(|(i, m)| (m.name.clone(), i))
        .collect();
    for section in sections {
        let element = format!("material {}", quoted(&section.name));
        let invalid = |message: String| SceneError::invalid(path, element.clone(), message);
        let alpha = checked_values(section).map_err(invalid)?;
        let ndf = section
            .ndf
            .as_deref()
            .map(crate::parse_ndf)
            .transpose()
            .map_err(|e| invalid(format!("ndf: {e}")))?;
        let shadowing = section
            .shadowing
            .as_deref()
            .map(crate::parse_shadowing)
            .transpose()
            .map_err(|e| invalid(format!("shadowing: {e}")))?;
        let target = existing.get(&section.name).copied();
        let base = target.map(|i| builder.materials[i].clone());
        let surface = match (&section.kind, &base) {
            (Some(kind), _) => {
                let model = MicrofacetModel::new(
                    ndf.unwrap_or(NdfKind::Ggx),
                    alpha.unwrap_or(0.0),
                    shadowing.unwrap_or(Shadowing::Smith),
                );
                new_surface(kind, section, model).map_err(invalid)?
            }
            (None, Some(base)) => {
                override_surface(base.surface, section, alpha, ndf, shadowing).map_err(invalid)?
            }
            (None, None) => {
                return Err(invalid(
                    "no model material has this name; give `type` to define a new one".into(),
                ));
            }
        };
        let emission = vec3(section.emission)
            .or(base.as_ref().map(|b| b.emission))
            .unwrap_or(Vec3::ZERO);
        let medium = match vec3(section.absorption) {
            Some(_) if !surface.may_transmit() => {
                return Err(invalid(
                    "`absorption` needs a dielectric (light enters no other material)".into(),
                ));
            }
            Some(sigma_a) => Medium::absorbing(sigma_a),
            None => base.as_ref().and_then(|b| b.medium),
        };
        // An overridden model material keeps its normal and alpha maps (they
        // belong to the geometry), and its emissive texture unless the
        // manifest gives the emission.
        let mut maps = base.as_ref().map_or_else(Default::default, |b| b.maps);
        if section.emission.is_some() {
            maps.emission = None;
        }
        let material = Material {
            name: section.name.clone(),
            surface,
            emission,
            medium,
            maps,
        };
        match target {
            Some(i) => builder.materials[i] = material,
            None => {
                builder.add_material(material);
            }
        }
    }
    Ok(())
}

/// The section's alpha (given as `alpha` or as `roughness`, alpha = r^2),
/// after checking that its numbers are in range.
fn checked_values(section: &MaterialSection) -> Result<Option<f32>, String> {
    let alpha = match (section.alpha, section.roughness) {
        (Some(_), Some(_)) => return Err("give `alpha` or `roughness`, not both".into()),
        (Some(a), None) => Some(a),
        (None, Some(r)) => Some(r * r),
        (None, None) => None,
    };
    if let Some(a) = alpha.filter(|a| !(a.is_finite() && *a >= 0.0)) {
        return Err(format!("alpha must be >= 0, got {a}"));
    }
    if let Some(ior) = section.ior.filter(|i| !(i.is_finite() && *i > 0.0)) {
        return Err(format!("ior must be > 0, got {ior}"));
    }
    for (name, value) in [
        ("reflectance", section.reflectance),
        ("emission", section.emission),
        ("eta", section.eta),
        ("k", section.k),
        ("tint", section.tint),
        ("absorption", section.absorption),
    ] {
        if let Some(v) = vec3(value).filter(|v| !(v.is_finite() && v.min_element() >= 0.0)) {
            return Err(format!("{name} must be finite and non-negative, got {v}"));
        }
    }
    // A lossless interface cannot transmit more than it receives.
    if let Some(t) = vec3(section.tint).filter(|t| t.max_element() > 1.0) {
        return Err(format!("tint must be in [0, 1], got {t}"));
    }
    Ok(alpha)
}

/// The surface of a section that gives its `type`.
fn new_surface(
    kind: &str,
    section: &MaterialSection,
    model: MicrofacetModel,
) -> Result<Surface, String> {
    let reflectance = vec3(section.reflectance);
    Ok(match kind {
        "diffuse" => Surface::Diffuse {
            reflectance: reflectance.unwrap_or(Vec3::splat(0.8)).min(Vec3::ONE),
        },
        "conductor" => Surface::Conductor {
            model,
            fresnel: conductor_fresnel(section, reflectance),
        },
        "dielectric" => Surface::Dielectric {
            model,
            ior: section.ior.unwrap_or(1.5),
            tint: vec3(section.tint).unwrap_or(Vec3::ONE),
        },
        "coated" => Surface::Coated(microfacet::Coated {
            model,
            base_color: reflectance.unwrap_or(Vec3::splat(0.8)).min(Vec3::ONE),
            metallic: 0.0,
            specular: 1.0,
            specular_color: Vec3::ONE,
            ior: section.ior.unwrap_or(1.5),
        }),
        other => {
            return Err(format!(
                "unknown type {} (expected diffuse, conductor, dielectric or coated)",
                quoted(other)
            ));
        }
    })
}

fn conductor_fresnel(section: &MaterialSection, reflectance: Option<Vec3>) -> Fresnel {
    match (vec3(section.eta), vec3(section.k)) {
        (Some(eta), Some(k)) => Fresnel::Conductor {
            eta,
            k,
            tint: Vec3::ONE,
        },
        _ => Fresnel::Schlick {
            f0: reflectance.unwrap_or(Vec3::ONE).min(Vec3::ONE),
        },
    }
}

/// Changes only the parameters the section gives.
fn override_surface(
    surface: Surface,
    section: &MaterialSection,
    alpha: Option<f32>,
    ndf: Option<NdfKind>,
    shadowing: Option<Shadowing>,
) -> Result<Surface, String> {
    let remodel = |m: MicrofacetModel| {
        MicrofacetModel::new(
            ndf.unwrap_or(m.ndf.kind()),
            alpha.unwrap_or(m.alpha()),
            shadowing.unwrap_or(m.shadowing),
        )
    };
    let wants_microfacet = alpha.is_some() || ndf.is_some() || shadowing.is_some();
    Ok(match surface {
        Surface::Diffuse { reflectance } if !wants_microfacet => Surface::Diffuse {
            reflectance: vec3(section.reflectance)
                .unwrap_or(reflectance)
                .min(Vec3::ONE),
        },
        Surface::Diffuse { .. } => {
            return Err("is diffuse: set `type` to give it a microfacet roughness".into());
        }
        Surface::Conductor { model, fresnel } => Surface::Conductor {
            model: remodel(model),
            fresnel: if section.reflectance.is_some() || section.eta.is_some() {
                conductor_fresnel(section, vec3(section.reflectance))
            } else {
                fresnel
            },
        },
        Surface::Dielectric { model, ior, tint } => Surface::Dielectric {
            model: remodel(model),
            ior: section.ior.unwrap_or(ior),
            tint: vec3(section.tint).unwrap_or(tint),
        },
        Surface::Coated(c) => Surface::Coated(microfacet::Coated {
            model: remodel(c.model),
            base_color: vec3(section.reflectance).map_or(c.base_color, |r| r.min(Vec3::ONE)),
            ior: section.ior.unwrap_or(c.ior),
            ..c
        }),
        Surface::Textured(mut pbr) => {
            pbr.ndf = ndf.unwrap_or(pbr.ndf);
            pbr.shadowing = shadowing.unwrap_or(pbr.shadowing);
            if let Some(a) = alpha {
                pbr.roughness = a.sqrt();
            }
            Surface::Textured(pbr)
        }
        Surface::ThinDielectric { ior, tint } if !wants_microfacet => Surface::ThinDielectric {
            ior: section.ior.unwrap_or(ior),
            tint: vec3(section.tint).unwrap_or(tint),
        },
        Surface::ThinDielectric { .. } => {
            return Err("is a thin dielectric sheet, which has no roughness".into());
        }
    })
}

fn add_shapes(
    path: &Path,
    sections: &[ShapeSection],
    builder: &mut SceneBuilder,
) -> Result<(), SceneError> {
    for (i, s) in sections.iter().enumerate() {
        let element = format!("shape {}{}", i + 1, kind_name(&s.kind));
        let invalid = |message: String| SceneError::invalid(path, element.clone(), message);
        let material = builder
            .materials
            .iter()
            .position(|m| m.name == s.material)
            .ok_or_else(|| invalid(format!("material {} is not defined", quoted(&s.material))))?
            as u32;
        let need = |v: Option<[f32; 3]>, name: &str| {
            vec3(v).ok_or_else(|| invalid(format!("`{name}` is required")))
        };
        let triangles = match s.kind.as_str() {
            "sphere" => {
                let radius = s
                    .radius
                    .ok_or_else(|| invalid("`radius` is required".into()))?;
                if !(radius > 0.0 && radius.is_finite()) {
                    return Err(invalid(format!("radius must be > 0, got {radius}")));
                }
                let axis = vec3(s.axis).unwrap_or(Vec3::Y);
                let cap = s.cap.unwrap_or(180.0);
                if !s.tessellate.unwrap_or(false) && cap >= 180.0 {
                    if s.rings.is_some() {
                        builder.report.warnings.push(format!(
                            "{}: {element}: `rings` only applies with `tessellate = true`",
                            path.display()
                        ));
                    }
                    let sphere = Sphere {
                        center: need(s.center, "center")?,
                        radius,
                        axis: axis.try_normalize().unwrap_or(Vec3::Y),
                        material,
                        inside: s.inside.unwrap_or(false),
                    };
                    builder.add_sphere(path, &element, sphere)?;
                    continue;
                }
                let rings = s.rings.unwrap_or(48).clamp(2, 1024);
                shapes::sphere(
                    need(s.center, "center")?,
                    radius,
                    axis,
                    cap,
                    rings,
                    s.inside.unwrap_or(false),
                )
            }
            "quad" => shapes::quad(need(s.origin, "origin")?, need(s.u, "u")?, need(s.v, "v")?),
            other => {
                return Err(invalid(format!(
                    "unknown shape type {} (expected sphere or quad)",
                    quoted(other)
                )));
            }
        };
        for (t, (p, n, uv)) in triangles.into_iter().enumerate() {
            builder.add_triangle(
                path,
                &|| format!("{element}, triangle {t}"),
                p,
                Some(n),
                Some(uv),
                material,
            )?;
        }
    }
    Ok(())
}

fn light_element(index: usize, l: &LightSection) -> String {
    format!("light {}{}", index + 1, kind_name(&l.kind))
}

/// The environment map of a light section with `file`, or `None` for a
/// section without one (every other light). Map keys on other lights, and
/// `intensity` with `file`, are errors.
fn environment_map(
    path: &Path,
    index: usize,
    l: &LightSection,
    policy: &ReferencePolicy,
) -> Result<Option<EnvironmentMap>, SceneError> {
    let element = light_element(index, l);
    let invalid = |message: &str| SceneError::invalid(path, element.clone(), message);
    let Some(file) = &l.file else {
        return if l.scale.is_some() || l.rotation.is_some() {
            Err(invalid(
                "`scale` and `rotation` belong to an environment map (give `file`)",
            ))
        } else {
            Ok(None)
        };
    };
    if l.kind != "environment" {
        return Err(invalid("only an environment light takes a `file`"));
    }
    if l.intensity.is_some() {
        return Err(invalid(
            "give `intensity` (a constant environment) or `file` (a map), not both; `scale` multiplies a map",
        ));
    }
    let resolved = policy.resolve(path, &format!("{element} file"), file)?;
    let map = EnvironmentMap::load(&resolved, l.scale.unwrap_or(1.0), l.rotation.unwrap_or(0.0))?;
    Ok(Some(map))
}

fn parse_light(path: &Path, index: usize, l: &LightSection) -> Result<Light, SceneError> {
    let element = light_element(index, l);
    let invalid = |message: String| SceneError::invalid(path, element.clone(), message);
    let intensity = Vec3::from_array(
        l.intensity
            .ok_or_else(|| invalid("`intensity` is required".into()))?,
    );
    if !(intensity.is_finite() && intensity.min_element() >= 0.0) {
        return Err(invalid(format!(
            "intensity must be finite and non-negative, got {intensity}"
        )));
    }
    let need = |v: Option<[f32; 3]>, name: &str| {
        vec3(v)
            .filter(|v| v.is_finite())
            .ok_or_else(|| invalid(format!("`{name}` is required and must be finite")))
    };
    let direction = |v| {
        need(v, "direction")?
            .try_normalize()
            .ok_or_else(|| invalid("direction must not be zero".into()))
    };
    Ok(match l.kind.as_str() {
        "point" => Light::Point {
            position: need(l.position, "position")?,
            intensity,
        },
        "spot" => {
            let (inner, outer) = (l.inner.unwrap_or(0.0), l.outer.unwrap_or(45.0));
            if !(0.0..=90.0).contains(&outer) || !(0.0..=outer).contains(&inner) {
                return Err(invalid(format!(
                    "need 0 <= inner <= outer <= 90 degrees, got {inner} and {outer}"
                )));
            }
            Light::Spot {
                position: need(l.position, "position")?,
                direction: direction(l.direction)?,
                intensity,
                cos_inner: inner.to_radians().cos(),
                cos_outer: outer.to_radians().cos(),
            }
        }
        "directional" => Light::Directional {
            direction: direction(l.direction)?,
            irradiance: intensity,
        },
        "environment" => Light::Environment {
            radiance: intensity,
        },
        other => {
            return Err(invalid(format!(
                "unknown light type {} (expected point, spot, directional or environment)",
                quoted(other)
            )));
        }
    })
}
