//! What the command line says about loading the scene and its camera:
//! `--camera` (a glTF camera by name), `--resolution`, a replacement
//! camera (`--camera-from`, `--camera-at`, `--camera-up`, `--fov`), and a
//! replacement environment (`--env`, `--env-scale`, `--env-rotation`).

use glam::{UVec2, Vec3};
use scene::{Camera, LoadOptions};

use crate::cli::Cli;
use crate::error::ArgError;

/// A camera given on the command line, replacing the scene's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraOverride {
    from: Vec3,
    at: Vec3,
    up: Vec3,
    fov_degrees: f32,
}

impl CameraOverride {
    /// The camera at the scene's resolution.
    pub fn camera(&self, resolution: UVec2) -> Result<Camera, ArgError> {
        Camera::look_at(self.from, self.at, self.up, self.fov_degrees, resolution).map_err(
            |message| ArgError::Flag {
                flag: "--camera-from/--camera-at/--camera-up",
                message,
            },
        )
    }
}

impl Cli {
    /// Options for `scene::load`. `--camera` on an OBJ file is an error
    /// rather than silently ignored: OBJ files have no cameras.
    pub fn load_options(&self) -> Result<LoadOptions, ArgError> {
        let is_obj = (self.scene.extension()).is_some_and(|e| e.eq_ignore_ascii_case("obj"));
        if self.camera.is_some() && is_obj {
            return Err(ArgError::Flag {
                flag: "--camera",
                message: format!(
                    "{} is an OBJ file, which has no cameras (use --camera-from, --camera-at \
                     and --fov)",
                    self.scene.display()
                ),
            });
        }
        Ok(LoadOptions {
            camera_name: self.camera.clone(),
            resolution: self.resolution,
            allow_outside_paths: self.allow_outside_paths,
            allow_empty: self.allow_empty,
            environment: self.env.as_ref().map(|file| scene::EnvironmentOption {
                file: file.clone(),
                scale: self.env_scale.unwrap_or(1.0),
                rotation_degrees: self.env_rotation.unwrap_or(0.0),
            }),
            parameters: self.define.clone(),
        })
    }

    /// The camera given by `--camera-from/--camera-at/--camera-up/--fov`, if
    /// any, checked now (at a placeholder resolution) so that a degenerate one
    /// fails before the scene is loaded.
    pub fn camera_override(&self) -> Result<Option<CameraOverride>, ArgError> {
        let (Some(from), Some(at), Some(fov_degrees)) =
            (self.camera_from, self.camera_at, self.fov)
        else {
            return Ok(None);
        };
        let camera = CameraOverride {
            from,
            at,
            up: self.camera_up.unwrap_or(Vec3::Y),
            fov_degrees,
        };
        camera.camera(UVec2::ONE)?;
        Ok(Some(camera))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_replacement_camera_is_checked_before_loading() {
        let ok = Cli::parse_test(&[
            "--camera-from",
            "-1,0,1",
            "--camera-at",
            "0,0,0",
            "--fov",
            "40",
        ])
        .unwrap();
        assert!(ok.camera_override().unwrap().is_some());
        let degenerate = Cli::parse_test(&[
            "--camera-from",
            "0,0,0",
            "--camera-at",
            "0,0,0",
            "--fov",
            "40",
        ]);
        let e = degenerate.unwrap().camera_override().unwrap_err();
        assert!(e.to_string().contains("--camera-from"), "{e}");
    }
}
