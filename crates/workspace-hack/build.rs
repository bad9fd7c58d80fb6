//! Empty: the build-dependencies in Cargo.toml exist only for their features.
fn main() {}
