//! Load errors: every one names the file and, where it can, the element.

use std::path::{Path, PathBuf};

use thiserror::Error;

/// Longest quoted value in a message, in characters (a path fits): an OBJ token of 20 MB
/// must not make a 20 MB error line.
pub const MAX_QUOTED: usize = 80;

/// `value` in double quotes for a message, cut to [`MAX_QUOTED`] characters
/// (saying how long it was) and with control characters escaped.
pub fn quoted(value: &str) -> String {
    let count = value.chars().count();
    let shown: String = value
        .chars()
        .take(MAX_QUOTED)
        .flat_map(char::escape_default)
        .collect();
    if count > MAX_QUOTED {
        format!("\"{shown}...\" ({count} characters)")
    } else {
        format!("\"{shown}\"")
    }
}

/// `load` with a panic of a third-party `reader` (e.g. "the glTF reader")
/// turned into a one-line [`SceneError`] naming `path`: loaders validate
/// before they call into other crates, and this catches what still escapes.
pub(crate) fn guarded<T>(
    path: &Path,
    reader: &str,
    load: impl FnOnce() -> Result<T, SceneError>,
) -> Result<T, SceneError> {
    std::panic::catch_unwind(std::panic::AssertUnwindSafe(load)).unwrap_or_else(|payload| {
        let why = payload
            .downcast_ref::<&str>()
            .map(|s| (*s).to_string())
            .or_else(|| payload.downcast_ref::<String>().cloned())
            .unwrap_or_default();
        let why = why.lines().next().unwrap_or_default().to_string();
        Err(SceneError::malformed(
            path,
            format!(
                "{reader} failed on this file (internal error {})",
                quoted(&why)
            ),
        ))
    })
}

/// Why a scene could not be loaded. `Display` is one line that names the file
/// and the element (node, mesh, material, line, field) at fault.
#[derive(Debug, Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The operating system's reason.
        source: std::io::Error,
    },
    /// The file is not valid in its format (syntax, truncation, references).
    #[error("{}: {message}", path.display())]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What is wrong, naming the element or line.
        message: String,
    },
    /// The file is valid but a value is out of range (NaN, negative roughness, ior <= 0, ...).
    #[error("{}: {element}: {message}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// The element at fault, e.g. `material "glass"` or `node 3`.
        element: String,
        /// What is wrong with it.
        message: String,
    },
    /// The file uses something this renderer does not support.
    #[error("{}: unsupported: {message}", path.display())]
    Unsupported {
        /// The file.
        path: PathBuf,
        /// What is unsupported and what to do instead.
        message: String,
    },
}

impl SceneError {
    pub(crate) fn malformed(path: &Path, message: impl Into<String>) -> Self {
        Self::Malformed {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn invalid(
        path: &Path,
        element: impl Into<String>,
        message: impl Into<String>,
    ) -> Self {
        Self::Invalid {
            path: path.to_path_buf(),
            element: element.into(),
            message: message.into(),
        }
    }

    pub(crate) fn unsupported(path: &Path, message: impl Into<String>) -> Self {
        Self::Unsupported {
            path: path.to_path_buf(),
            message: message.into(),
        }
    }

    pub(crate) fn io(path: &Path, source: std::io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_panic_becomes_an_error_naming_the_file() {
        let path = Path::new("model.gltf");
        let result: Result<(), SceneError> = guarded(path, "the glTF reader", || {
            panic!("index out of bounds\nmore")
        });
        let message = result.unwrap_err().to_string();
        assert_eq!(
            message,
            "model.gltf: the glTF reader failed on this file (internal error \"index out of bounds\")"
        );
        assert!(guarded(path, "the glTF reader", || Ok(3)).is_ok_and(|v| v == 3));
    }

    #[test]
    fn quoted_values_are_short_and_escaped() {
        assert_eq!(quoted("a.mtl"), "\"a.mtl\"");
        assert_eq!(quoted("a\nb"), "\"a\\nb\"");
        let long = "x".repeat(20_000_000);
        let q = quoted(&long);
        assert!(
            q.len() <= MAX_QUOTED + 30 && q.ends_with("(20000000 characters)"),
            "{q}"
        );
    }
}
