//! Bad input gets a typed error naming the file and the element, never a
//! panic: a table of broken files, and random bytes and random
//! mutations of valid files fed to every loader (proptest).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use proptest::prelude::*;
use scene::{LoadOptions, SceneError, load};

/// A fresh directory under the system's temporary folder.
fn scratch_dir() -> PathBuf {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("scene-tests-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    dir
}

/// Writes `files` (name, content) to a fresh directory and loads the first.
fn load_files(files: &[(&str, &[u8])]) -> Result<scene::Scene, SceneError> {
    let dir = scratch_dir();
    for (name, content) in files {
        std::fs::write(dir.join(name), content).expect("write test file");
    }
    let result = load(&dir.join(files[0].0), &LoadOptions::default());
    let _ = std::fs::remove_dir_all(&dir);
    result
}

const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

/// A one-triangle glTF with an embedded buffer: 3 float3 positions, 3 u16 indices.
fn gltf_triangle(extra_material: &str, positions: [[f32; 3]; 3], indices: [u16; 3]) -> String {
    let mut bytes = Vec::new();
    for p in positions {
        for c in p {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in indices {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    bytes.extend_from_slice(&[0, 0]);
    let data = base64(&bytes);
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],"nodes":[{{"mesh":0}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0}}]}}],
"materials":[{{"name":"m"{extra_material}}}],
"buffers":[{{"byteLength":{len},"uri":"data:application/octet-stream;base64,{data}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}]}}"#,
        len = bytes.len()
    )
}

fn base64(bytes: &[u8]) -> String {
    const ALPHABET: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::new();
    for chunk in bytes.chunks(3) {
        let b = [
            chunk[0],
            *chunk.get(1).unwrap_or(&0),
            *chunk.get(2).unwrap_or(&0),
        ];
        let n = (u32::from(b[0]) << 16) | (u32::from(b[1]) << 8) | u32::from(b[2]);
        for i in 0..4 {
            if i <= chunk.len() {
                out.push(ALPHABET[((n >> (18 - 6 * i)) & 63) as usize] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

const UNIT: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

#[test]
fn valid_fixtures_load() {
    assert_eq!(
        load_files(&[("t.obj", TRIANGLE_OBJ.as_bytes())])
            .unwrap()
            .triangles
            .len(),
        1
    );
    let g = gltf_triangle("", UNIT, [0, 1, 2]);
    assert_eq!(
        load_files(&[("t.gltf", g.as_bytes())])
            .unwrap()
            .triangles
            .len(),
        1
    );
}

/// (description, files, expected error kind, text the message must contain).
type Case = (
    &'static str,
    Vec<(&'static str, Vec<u8>)>,
    fn(&SceneError) -> bool,
    &'static str,
);

fn cases() -> Vec<Case> {
    let s = |t: &str| t.as_bytes().to_vec();
    let malformed: fn(&SceneError) -> bool = |e| matches!(e, SceneError::Malformed { .. });
    let invalid: fn(&SceneError) -> bool = |e| matches!(e, SceneError::Invalid { .. });
    let unsupported: fn(&SceneError) -> bool = |e| matches!(e, SceneError::Unsupported { .. });
    vec![
        ("OBJ face index out of range", vec![("a.obj", s("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"))], invalid, "line 4"),
        ("OBJ NaN position", vec![("a.obj", s("v 0 0 0\nv nan 0 0\nv 0 1 0\nf 1 2 3\n"))], invalid, "line 2"),
        ("OBJ garbage number", vec![("a.obj", s("v 0 0 0\nv 1 0 0\nv 0 1x 0\nf 1 2 3\n"))], invalid, "line 3"),
        ("OBJ truncated face", vec![("a.obj", s("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2"))], invalid, "line 4"),
        ("OBJ missing MTL", vec![("a.obj", s("mtllib missing.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n"))], invalid, "mtllib"),
        ("MTL negative Kd", vec![("a.obj", s("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl x\nf 1 2 3\n")), ("a.mtl", s("newmtl x\nKd -1 0 0\n"))], invalid, "material \"x\""),
        ("MTL glass with Ni 0", vec![("a.obj", s("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl g\nf 1 2 3\n")), ("a.mtl", s("newmtl g\nillum 7\nNi 0\n"))], invalid, "Ni"),
        ("MTL missing texture", vec![("a.obj", s("mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl t\nf 1 2 3\n")), ("a.mtl", s("newmtl t\nKd 1 1 1\nmap_Kd nowhere.png\n"))], invalid, "nowhere.png"),
        ("glTF truncated JSON", vec![("a.gltf", s("{\"asset\":{\"version\":\"2.0\"},\"scenes\":[{\"nodes\":[0]"))], malformed, "a.gltf"),
        ("glTF missing .bin", vec![("a.gltf", s(r#"{"asset":{"version":"2.0"},"buffers":[{"byteLength":12,"uri":"gone.bin"}]}"#))], malformed, "gone.bin"),
        ("glTF accessor out of range", vec![("a.gltf", s(r#"{"asset":{"version":"2.0"},"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],"meshes":[{"primitives":[{"attributes":{"POSITION":7}}]}]}"#))], malformed, "POSITION"),
        ("glTF vertex index out of range", vec![("a.gltf", gltf_triangle("", UNIT, [0, 1, 5]).into_bytes())], malformed, "vertex 5"),
        ("glTF NaN position", vec![("a.gltf", gltf_triangle("", [[0.0, 0.0, 0.0], [f32::NAN, 0.0, 0.0], [0.0, 1.0, 0.0]], [0, 1, 2]).into_bytes())], invalid, "triangle 0"),
        ("glTF negative roughness", vec![("a.gltf", gltf_triangle(r#","pbrMetallicRoughness":{"roughnessFactor":-0.5}"#, UNIT, [0, 1, 2]).into_bytes())], invalid, "roughnessFactor"),
        ("glTF ior 0", vec![("a.gltf", gltf_triangle(r#","extensions":{"KHR_materials_transmission":{"transmissionFactor":1},"KHR_materials_ior":{"ior":0}}"#, UNIT, [0, 1, 2]).into_bytes())], invalid, "ior"),
        ("glTF unknown NDF in extras", vec![("a.gltf", gltf_triangle(r#","extras":{"ndf":"phong"}"#, UNIT, [0, 1, 2]).into_bytes())], invalid, "ndf"),
        ("glTF unknown required extension", vec![("a.gltf", s(r#"{"asset":{"version":"2.0"},"extensionsUsed":["EXT_magic"],"extensionsRequired":["EXT_magic"]}"#))], unsupported, "EXT_magic"),
        ("manifest unknown field", vec![("s.toml", s("resolution = [4, 4]\n\n[camera]\nfrom = [0, 0, 1]\nat = [0, 0, 0]\nfov = 40\nzoom = 2\n"))], malformed, "line 7"),
        ("manifest missing model", vec![("s.toml", s("[[model]]\nfile = \"nothing.obj\"\n"))], invalid, "nothing.obj"),
        ("manifest negative alpha", vec![("s.toml", s("[[material]]\nname = \"m\"\ntype = \"conductor\"\nalpha = -0.1\n"))], invalid, "material \"m\""),
        ("manifest undefined shape material", vec![("s.toml", s("[[shape]]\ntype = \"sphere\"\nmaterial = \"nope\"\ncenter = [0, 0, 0]\nradius = 1\n"))], invalid, "shape 1"),
        ("manifest sphere NaN center", vec![("s.toml", s("[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[shape]]\ntype = \"sphere\"\nmaterial = \"m\"\ncenter = [nan, 0, 0]\nradius = 1\n"))], invalid, "center"),
        ("manifest sphere negative radius", vec![("s.toml", s("[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[shape]]\ntype = \"sphere\"\nmaterial = \"m\"\ncenter = [0, 0, 0]\nradius = -1\n"))], invalid, "radius"),
        ("manifest sphere infinite radius", vec![("s.toml", s("[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[shape]]\ntype = \"sphere\"\nmaterial = \"m\"\ncenter = [0, 0, 0]\nradius = inf\n"))], invalid, "radius"),
        ("manifest zero resolution", vec![("s.toml", s("resolution = [0, 10]\n"))], invalid, "resolution"),
        ("manifest camera without fov", vec![("s.toml", s("[camera]\nfrom = [0, 0, 1]\nat = [0, 0, 0]\n"))], invalid, "fov"),
        ("manifest degenerate camera", vec![("s.toml", s("[camera]\nfrom = [0, 0, 0]\nat = [0, 0, 0]\nfov = 40\n"))], invalid, "camera"),
        ("manifest bad light", vec![("s.toml", s("[[light]]\ntype = \"laser\"\nintensity = [1, 1, 1]\n"))], invalid, "light 1"),
        ("unknown extension", vec![("scene.fbx", s("whatever"))], unsupported, ".fbx"),
        ("missing file", vec![("present.txt", s(""))], unsupported, "present.txt"),
    ]
}

#[test]
fn broken_files_give_typed_errors_that_name_the_problem() {
    for (description, files, kind, needle) in cases() {
        let borrowed: Vec<(&str, &[u8])> = files.iter().map(|(n, c)| (*n, c.as_slice())).collect();
        let error = match load_files(&borrowed) {
            Ok(_) => panic!("{description}: loaded without error"),
            Err(e) => e,
        };
        let message = error.to_string();
        assert!(kind(&error), "{description}: wrong kind: {error:?}");
        assert!(
            message.contains(needle),
            "{description}: \"{message}\" does not mention \"{needle}\""
        );
        assert!(
            !message.contains('\n'),
            "{description}: not one line: {message}"
        );
    }
}

#[test]
fn degenerate_but_legal_input_is_accepted_and_reported() {
    // A zero-area emissive triangle next to a valid one: skipped and counted.
    let obj = "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nusemtl e\nf 1 2 3\nf 1 2 4\n";
    let s = load_files(&[
        ("a.obj", obj.as_bytes()),
        ("a.mtl", b"newmtl e\nKd 0 0 0\nKe 1 1 1\n"),
    ])
    .unwrap();
    assert_eq!((s.triangles.len(), s.report.degenerate_triangles), (1, 1));
    assert_eq!(s.lights.len(), 1);
    // An empty scene is an error, unless allowed: then it loads with a warning.
    let e = load_files(&[("e.toml", b"")]).unwrap_err().to_string();
    assert!(e.contains("e.toml") && e.contains("no geometry"), "{e}");
    let dir = scratch_dir();
    std::fs::write(dir.join("e.toml"), b"").unwrap();
    let allow = LoadOptions {
        allow_empty: true,
        ..Default::default()
    };
    let empty = load(&dir.join("e.toml"), &allow).unwrap();
    let _ = std::fs::remove_dir_all(&dir);
    assert!(empty.triangles.is_empty() && !empty.report.warnings.is_empty());
}

fn fixtures() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("f.obj", TRIANGLE_OBJ.as_bytes().to_vec()),
        ("f.gltf", gltf_triangle(r#","extras":{"ndf":"beckmann"}"#, UNIT, [0, 1, 2]).into_bytes()),
        ("f.toml", b"resolution = [4, 4]\n[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[shape]]\ntype = \"sphere\"\nmaterial = \"m\"\ncenter = [0, 0, 0]\nradius = 1\nrings = 4\n[[light]]\ntype = \"environment\"\nintensity = [1, 1, 1]\n".to_vec()),
        ("f.glb", std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/data/Box/glTF-Binary/Box.glb")).unwrap_or_default()),
        ("f.xml", std::fs::read(Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/veach-mis/scene.xml")).unwrap_or_default()),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 200, failure_persistence: None, ..ProptestConfig::default() })]

    /// Random bytes under every file extension: an error or a scene, no panic.
    #[test]
    fn random_bytes_never_panic(bytes in proptest::collection::vec(any::<u8>(), 0..512), which in 0usize..5) {
        let name = ["r.obj", "r.gltf", "r.toml", "r.glb", "r.xml"][which];
        let _ = load_files(&[(name, &bytes)]);
    }

    /// Random mutations (overwrites, truncation) of valid files: no panic.
    #[test]
    fn mutated_files_never_panic(which in 0usize..5, edits in proptest::collection::vec((any::<u16>(), any::<u8>()), 1..8), cut in any::<u16>()) {
        let (name, mut bytes) = fixtures().swap_remove(which);
        if bytes.is_empty() {
            return Ok(());
        }
        for (at, value) in edits {
            let i = at as usize % bytes.len();
            bytes[i] = value;
        }
        if cut % 3 == 0 {
            bytes.truncate(cut as usize % bytes.len());
        }
        let _ = load_files(&[(name, &bytes)]);
    }
}
