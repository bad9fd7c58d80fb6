//! The scene model every integrator sees, and every file format that fills it.
//!
//! [`load`] reads a `scene.toml` manifest, a glTF 2.0 file (`.gltf`, `.glb`),
//! a Wavefront OBJ file or a Mitsuba 3 scene (`.xml`) and returns one in-memory [`Scene`]: world-space
//! triangles with shading normals and texture coordinates, materials as
//! `microfacet` lobes (mapping in [`material`]), lights, a pinhole camera.
//! Bad input is a [`SceneError`] naming the file and element, never a panic.
//! [`SceneFeatures`] summarises what a scene contains.

pub mod camera;
mod checks;
pub mod environment;
pub mod error;
pub mod features;
pub mod gltf;
pub mod light;
pub mod manifest;
pub mod material;
pub mod mitsuba;
pub mod obj;
pub mod paths;
pub mod scene;
pub mod shapes;
pub mod sphere;
pub mod texture;
pub mod validate;

use std::path::Path;

use glam::{UVec2, Vec3};

use crate::error::quoted;
use microfacet::{NdfKind, Shadowing};

pub use camera::{Camera, CameraSpec, FovAxis};
pub use environment::EnvironmentMap;
pub use error::SceneError;
pub use features::SceneFeatures;
pub use light::Light;
pub use material::{Material, Medium, Surface};
pub use scene::{LoadReport, RenderSettings, Scene, triangle_cross, triangle_normal};
pub use sphere::Sphere;
pub use texture::Texture;

/// Resolution when neither the manifest nor the caller gives one: 512 pixels
/// wide, and high as the file's camera aspect says (square without one).
pub const DEFAULT_WIDTH: u32 = 512;

/// Radiance of the environment added to model files that bring no light at all
/// (glTF sample models expect image-based lighting).
pub const DEFAULT_ENVIRONMENT: f32 = 1.0;

/// Options of [`load`].
#[derive(Clone, Debug, Default)]
pub struct LoadOptions {
    /// Use the glTF camera of this name instead of the first one.
    pub camera_name: Option<String>,
    /// Image resolution, overriding the manifest's.
    pub resolution: Option<UVec2>,
    /// Let file references leave the scene file's folder
    /// (`--allow-outside-paths`; see [`paths`]).
    pub allow_outside_paths: bool,
    /// Accept a scene with no geometry, or with no light and no environment
    /// (`--allow-empty`): a warning instead of an error (see [`validate`]).
    pub allow_empty: bool,
    /// Light the scene with this map instead of its own environment
    /// (`--env`): a model without lights then gets no default environment.
    pub environment: Option<EnvironmentOption>,
    /// Parameters of a Mitsuba scene file, `name` -> `value` (`-D`, as
    /// Mitsuba's own `-D`: they win over the file's `<default>`s).
    pub parameters: Vec<(String, String)>,
}

/// An environment map given apart from the scene file (`--env FILE`).
#[derive(Clone, Debug)]
pub struct EnvironmentOption {
    /// The `.exr` or `.hdr` file (a command-line path: not subject to the
    /// scene's [`paths::ReferencePolicy`]).
    pub file: std::path::PathBuf,
    /// Radiance multiplier.
    pub scale: f32,
    /// Rotation about +y in degrees.
    pub rotation_degrees: f32,
}

/// The manifest that a folder given as the scene stands for (the bundled
/// scenes' layout, `scenes/<name>/scene.toml`).
pub const FOLDER_MANIFEST: &str = "scene.toml";

/// The Mitsuba scene a folder stands for when it has no [`FOLDER_MANIFEST`]
/// (`scenes/veach-bidir/scene.xml`).
pub const FOLDER_MITSUBA: &str = "scene.xml";

/// The scene file a path given by the user stands for: itself, or a
/// folder's [`FOLDER_MANIFEST`], else its [`FOLDER_MITSUBA`].
pub fn scene_file(path: &Path) -> std::path::PathBuf {
    if !path.is_dir() {
        return path.to_path_buf();
    }
    let manifest = path.join(FOLDER_MANIFEST);
    let mitsuba = path.join(FOLDER_MITSUBA);
    if !manifest.exists() && mitsuba.exists() {
        mitsuba
    } else {
        manifest
    }
}

/// Loads a scene from a manifest (`.toml`), glTF (`.gltf`, `.glb`), OBJ
/// (`.obj`) or Mitsuba 3 (`.xml`) file, or a folder's scene file
/// ([`scene_file`]), and checks it against the input rule ([`validate`])
/// whatever its format.
pub fn load(path: &Path, options: &LoadOptions) -> Result<Scene, SceneError> {
    let file = scene_file(path);
    let path = file.as_path();
    let extension = path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase);
    let policy = paths::ReferencePolicy::new(path, options.allow_outside_paths);
    if extension.as_deref() != Some("xml") && !options.parameters.is_empty() {
        return Err(SceneError::unsupported(
            path,
            "parameters (-D) apply to Mitsuba scene files (.xml) only",
        ));
    }
    let (builder, camera, resolution, render) = if extension.as_deref() == Some("toml") {
        let m = manifest::load(path, options.camera_name.as_deref(), &policy)?;
        (m.builder, m.camera, m.resolution, m.render)
    } else if extension.as_deref() == Some("xml") {
        let m = error::guarded(path, "the Mitsuba reader", || {
            mitsuba::load(path, &options.parameters, &policy)
        })?;
        (m.builder, m.camera, m.resolution, m.render)
    } else {
        let (mut builder, camera) = load_model(path, options.camera_name.as_deref(), &policy)?;
        let has_emission = builder.materials.iter().any(Material::is_emissive);
        if builder.lights.is_empty() && !has_emission && options.environment.is_none() {
            builder.lights.push(Light::Environment {
                radiance: Vec3::splat(DEFAULT_ENVIRONMENT),
            });
            builder.report.warnings.push(format!(
                "{}: no lights in the file: added a constant white environment (radiance {DEFAULT_ENVIRONMENT})",
                path.display()
            ));
        }
        (builder, camera, None, RenderSettings::default())
    };
    let resolution = options.resolution.or(resolution).unwrap_or_else(|| {
        let aspect = camera
            .and_then(|c| c.aspect)
            .filter(|a| a.is_finite() && *a > 0.0)
            .unwrap_or(1.0);
        UVec2::new(
            DEFAULT_WIDTH,
            ((DEFAULT_WIDTH as f32 / aspect).round() as u32).max(1),
        )
    });
    let camera = camera
        .map(|spec| {
            spec.camera(resolution)
                .map_err(|e| SceneError::invalid(path, "camera", e))
        })
        .transpose()?;
    let mut scene = builder.finish(camera, resolution, render);
    if let Some(env) = &options.environment {
        scene.set_environment(EnvironmentMap::load(
            &env.file,
            env.scale,
            env.rotation_degrees,
        )?);
    }
    validate::validate(
        &mut scene,
        path,
        validate::Allow {
            empty: options.allow_empty,
        },
    )?;
    Ok(scene)
}

/// One model file (OBJ or glTF) and the camera it carries, if any.
pub(crate) fn load_model(
    path: &Path,
    camera_name: Option<&str>,
    policy: &paths::ReferencePolicy,
) -> Result<(scene::SceneBuilder, Option<CameraSpec>), SceneError> {
    match path
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
        .as_deref()
    {
        Some("obj") => Ok((
            error::guarded(path, "the OBJ reader", || obj::load(path, policy))?,
            None,
        )),
        Some("gltf" | "glb") => {
            let g = gltf::load(path, camera_name, policy)?;
            Ok((g.builder, g.camera))
        }
        Some("xml") => {
            let m = error::guarded(path, "the Mitsuba reader", || {
                mitsuba::load(path, &[], policy)
            })?;
            Ok((m.builder, m.camera))
        }
        _ => Err(SceneError::unsupported(
            path,
            "unknown file type: expected .toml (manifest), .gltf, .glb, .obj or .xml (Mitsuba 3)",
        )),
    }
}

/// Parses an NDF name: `ggx`, `beckmann` or `blinn-phong`.
pub fn parse_ndf(name: &str) -> Result<NdfKind, String> {
    match name {
        "ggx" => Ok(NdfKind::Ggx),
        "beckmann" => Ok(NdfKind::Beckmann),
        "blinn-phong" => Ok(NdfKind::BlinnPhong),
        other => Err(format!(
            "unknown NDF {} (expected ggx, beckmann or blinn-phong)",
            quoted(other)
        )),
    }
}

/// Parses a shadowing model name: `smith` or `v-cavity`.
pub fn parse_shadowing(name: &str) -> Result<Shadowing, String> {
    match name {
        "smith" => Ok(Shadowing::Smith),
        "v-cavity" => Ok(Shadowing::VCavity),
        other => Err(format!(
            "unknown shadowing {} (expected smith or v-cavity)",
            quoted(other)
        )),
    }
}
