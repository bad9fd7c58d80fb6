//! Load errors: every one names the file and, where it can, the element.

use std::path::{Path, PathBuf};

use thiserror::Error;

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
