//! The scene crate's loader tests, in one binary: real third-party files, the
//! manifest, maps, environments, and malformed and hostile input.
//! One binary per crate: one link instead of one per file, tables and
//! fixtures built once and shared, and the long tests run beside the short
//! ones rather than after them.

mod environment;
mod external;
mod hostile_gltf;
mod hostile_obj;
mod malformed;
mod manifest;
mod maps;
