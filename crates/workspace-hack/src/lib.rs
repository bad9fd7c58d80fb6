//! Nothing to call: a dependency of the workspace's binaries (`xtask`,
//! `render-cli`) that turns on, in every build, the dependency features that
//! the test build turns on, so that Cargo's per-selection feature
//! resolution gives one set and the libraries are compiled once (the
//! "workspace-hack" pattern of rustc and cargo-hakari; Cargo.toml lists
//! which features and why). The library crates do not depend on it.
