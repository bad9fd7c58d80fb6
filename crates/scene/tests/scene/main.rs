//! The scene crate's loader tests, in one binary: real third-party files, the
//! manifest, maps, environments, and malformed and hostile input.
//! One binary per crate (ARCHITECTURE.md, "Tests are statistical").

mod environment;
mod external;
mod hostile_gltf;
mod hostile_obj;
mod malformed;
mod manifest;
mod maps;
mod mitsuba;
