//! File references inside a scene (a manifest's model files, an OBJ's
//! material library and textures, a glTF's buffers and images): resolved
//! against the folder of the file that names them, and kept inside the
//! folder of the scene file the user gave, unless the user allows more.
//! A scene downloaded from elsewhere must not make the renderer read
//! `../../../../etc/passwd`.

use std::path::{Path, PathBuf};

use crate::error::{SceneError, quoted};

/// Where the references of one scene may point.
#[derive(Clone, Debug)]
pub struct ReferencePolicy {
    /// The folder of the top-level scene file, canonical (symlinks resolved).
    root: PathBuf,
    /// `--allow-outside-paths`: references may leave `root`.
    allow_outside: bool,
}

impl ReferencePolicy {
    /// The policy of a scene loaded from `scene_file`.
    pub fn new(scene_file: &Path, allow_outside: bool) -> Self {
        let folder = scene_file
            .parent()
            .filter(|p| !p.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        Self {
            root: folder
                .canonicalize()
                .unwrap_or_else(|_| folder.to_path_buf()),
            allow_outside,
        }
    }

    /// The file that `reference` (as written in `referrer`, by `element`,
    /// e.g. `mtllib` or `buffer 0`) names: relative to `referrer`'s folder,
    /// an existing regular file, inside the scene's folder after symlinks
    /// are resolved (or anywhere, when allowed). The error names the
    /// referrer, the element and the reference.
    pub fn resolve(
        &self,
        referrer: &Path,
        element: &str,
        reference: &str,
    ) -> Result<PathBuf, SceneError> {
        let invalid = |message: String| {
            SceneError::invalid(
                referrer,
                element,
                format!("{}: {message}", quoted(reference)),
            )
        };
        let written = Path::new(reference);
        let folder = referrer.parent().unwrap_or(Path::new("."));
        let path = folder.join(written);
        let Ok(canonical) = path.canonicalize() else {
            return Err(invalid("no such file".to_owned()));
        };
        if canonical.is_dir() {
            return Err(invalid("is a folder, not a file".to_owned()));
        }
        if !self.allow_outside && !canonical.starts_with(&self.root) {
            return Err(invalid(format!(
                "is outside the scene's folder {} (pass --allow-outside-paths to read it)",
                self.root.display()
            )));
        }
        Ok(path)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn references_stay_inside_the_scene_folder() {
        let dir = std::env::temp_dir().join(format!("rlt-paths-{}", std::process::id()));
        let scene = dir.join("scene");
        std::fs::create_dir_all(scene.join("models")).unwrap();
        std::fs::write(scene.join("models/a.obj"), "").unwrap();
        std::fs::write(dir.join("secret.txt"), "").unwrap();
        let manifest = scene.join("scene.toml");
        let policy = ReferencePolicy::new(&manifest, false);
        assert!(policy.resolve(&manifest, "model", "models/a.obj").is_ok());
        // `..` that stays inside is fine.
        let obj = scene.join("models/a.obj");
        assert!(policy.resolve(&obj, "mtllib", "../models/a.obj").is_ok());
        let outside = policy
            .resolve(&obj, "mtllib", "../../secret.txt")
            .unwrap_err()
            .to_string();
        assert!(
            outside.contains("mtllib")
                && outside.contains("outside")
                && outside.contains("--allow-outside-paths"),
            "{outside}"
        );
        let absolute = dir.join("secret.txt").display().to_string();
        assert!(
            policy
                .resolve(&obj, "mtllib", &absolute)
                .unwrap_err()
                .to_string()
                .contains("outside")
        );
        assert!(
            policy
                .resolve(&obj, "mtllib", "missing.mtl")
                .unwrap_err()
                .to_string()
                .contains("no such file")
        );
        assert!(
            policy
                .resolve(&manifest, "model", "models")
                .unwrap_err()
                .to_string()
                .contains("folder")
        );
        let allowed = ReferencePolicy::new(&manifest, true);
        assert!(allowed.resolve(&obj, "mtllib", "../../secret.txt").is_ok());
        #[cfg(unix)]
        {
            std::os::unix::fs::symlink(dir.join("secret.txt"), scene.join("link.txt")).unwrap();
            let link = policy
                .resolve(&manifest, "model", "link.txt")
                .unwrap_err()
                .to_string();
            assert!(link.contains("outside"), "{link}");
        }
        std::fs::remove_dir_all(dir).unwrap();
    }
}
