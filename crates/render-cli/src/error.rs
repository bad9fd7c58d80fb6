//! Errors in settings that are well-formed flags or manifest values but
//! cannot be used; each is one line naming the file and key, or the flag.

use std::path::PathBuf;

/// A setting that is invalid, naming where it came from.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ArgError {
    /// A value of the manifest's `[render]` table.
    #[error(
        "{}: [render] {key}: {message} (set in the manifest; the {flag} flag overrides it)",
        manifest.display()
    )]
    Manifest {
        /// The manifest.
        manifest: PathBuf,
        /// The key in the `[render]` table.
        key: &'static str,
        /// The flag that would override it.
        flag: &'static str,
        /// What is wrong.
        message: String,
    },
    /// Flags that are well-formed but unusable (a missing folder, a degenerate camera).
    #[error("{flag}: {message}")]
    Flag {
        /// The flag or flags.
        flag: &'static str,
        /// What is wrong.
        message: String,
    },
}
