//! Helpers shared by the fuzz targets: a private scratch folder per process
//! (the loaders take paths, so every input is written to a file first) and
//! the call into `scene::load`.
//!
//! Targets write only inside `std::env::temp_dir()/rlt-fuzz-<pid>/`.

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// Byte that splits an `obj_mtl` input into the OBJ text (before) and the
/// MTL text (after the first occurrence).
pub const OBJ_MTL_SEPARATOR: u8 = 0;

/// Name of the MTL file the `obj_mtl` target writes; seeds name it in
/// their `mtllib` line.
pub const MTL_NAME: &str = "fuzz.mtl";

/// Buffers the `gltf_json` target writes once next to the `.gltf` file, so
/// that seeds with external buffers (the Khronos samples) resolve them.
const GLTF_BUFFERS: &[(&str, &[u8])] = &[
    (
        "Box0.bin",
        include_bytes!("../../crates/scene/tests/data/Box/glTF/Box0.bin"),
    ),
    (
        "simpleSquare.bin",
        include_bytes!("../../crates/scene/tests/data/Cameras/glTF/simpleSquare.bin"),
    ),
    (
        "MetalRoughSpheresNoTextures.bin",
        include_bytes!(
            "../../crates/scene/tests/data/MetalRoughSpheresNoTextures/glTF/MetalRoughSpheresNoTextures.bin"
        ),
    ),
];

/// This process's scratch folder (created on first use, with the fixed
/// glTF buffers in it).
pub fn scratch_dir() -> &'static Path {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("rlt-fuzz-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("cannot create the fuzz scratch folder");
        for (name, bytes) in GLTF_BUFFERS {
            std::fs::write(dir.join(name), bytes).expect("cannot write a fixed glTF buffer");
        }
        dir
    })
}

/// Writes `bytes` to `name` in the scratch folder and returns its path.
pub fn write_input(name: &str, bytes: &[u8]) -> PathBuf {
    let path = scratch_dir().join(name);
    std::fs::write(&path, bytes).expect("cannot write a fuzz input file");
    path
}

/// Loads `path` with default options (reference policy on: files outside the
/// scratch folder are refused). Errors are fine; a panic is a finding.
pub fn load(path: &Path) -> Result<scene::Scene, scene::SceneError> {
    scene::load(path, &scene::LoadOptions::default())
}

/// Splits an `obj_mtl` input at the first [`OBJ_MTL_SEPARATOR`]: (OBJ, MTL).
pub fn split_obj_mtl(data: &[u8]) -> (&[u8], &[u8]) {
    match data.iter().position(|&b| b == OBJ_MTL_SEPARATOR) {
        Some(i) => (&data[..i], &data[i + 1..]),
        None => (data, &[]),
    }
}

/// Mesh files the `mitsuba_xml` target writes once beside its `scene.xml`
/// (the bundled `mitsuba-features` scene's), so that seeds naming them
/// reach the PLY and `.serialized` readers through the XML loader.
const MITSUBA_MESHES: &[(&str, &[u8])] = &[
    (
        "meshes/torus.serialized",
        include_bytes!("../../scenes/mitsuba-features/meshes/torus.serialized"),
    ),
    (
        "meshes/icosphere.ply",
        include_bytes!("../../scenes/mitsuba-features/meshes/icosphere.ply"),
    ),
    (
        "models/Mesh000.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 1\nf 1//1 2//1 3//1\n",
    ),
];

/// Writes a Mitsuba scene file with its fixed meshes and returns its path.
pub fn write_mitsuba(xml: &[u8]) -> PathBuf {
    static MESHES: OnceLock<()> = OnceLock::new();
    MESHES.get_or_init(|| {
        for (name, bytes) in MITSUBA_MESHES {
            let path = scratch_dir().join(name);
            std::fs::create_dir_all(path.parent().expect("a folder"))
                .expect("cannot create a mesh folder");
            std::fs::write(path, bytes).expect("cannot write a fixed mesh");
        }
    });
    write_input("scene.xml", xml)
}

/// Panics if `mesh` breaks a promise of the mesh readers (`ply`,
/// `serialized` targets): finite positions, indices in range, attributes
/// one per vertex or none.
pub fn check_mesh(mesh: &scene::mitsuba::MeshData) {
    let n = mesh.positions.len();
    assert!(mesh.positions.iter().all(|p| p.is_finite()));
    assert!(mesh.normals.is_empty() || mesh.normals.len() == n);
    assert!(mesh.uvs.is_empty() || mesh.uvs.len() == n);
    assert!(mesh.triangles.iter().flatten().all(|&i| (i as usize) < n));
}
