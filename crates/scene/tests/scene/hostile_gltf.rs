//! Hostile glTF input: one test per class of corruption that used to panic
//! inside the `gltf` crate, render silently wrong geometry, pass without a
//! word or give a misleading message; and a property test over random edits
//! of a valid file (never a panic; every scene that loads is finite).
//!
//! Every file is generated here from a minimal valid triangle: JSON with a
//! separate `model.bin` (positions, normals, texture coordinates, indices).

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::Vec3;
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use scene::{LoadOptions, Scene, SceneError, Surface, load};
use serde_json::{Value, json};

/// A fresh directory under the system's temporary folder (with a `scene`
/// folder inside it, so that `..` can point at a sibling file).
fn scratch_dir() -> PathBuf {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("scene-hostile-gltf-{}-{n}", std::process::id()));
    std::fs::create_dir_all(dir.join("scene")).expect("temporary directory");
    dir
}

/// Loads `path`; a panic fails the test with its message.
fn load_guarded(path: &Path) -> Result<Scene, SceneError> {
    match std::panic::catch_unwind(|| load(path, &LoadOptions::default())) {
        Ok(result) => result,
        Err(_) => panic!("{}: the loader panicked", path.display()),
    }
}

/// Writes `files` into `scene/` of a fresh directory, loads the first.
fn load_files(files: &[(&str, &[u8])]) -> Result<Scene, SceneError> {
    let dir = scratch_dir();
    for (name, content) in files {
        std::fs::write(dir.join("scene").join(name), content).expect("write test file");
    }
    let result = load_guarded(&dir.join("scene").join(files[0].0));
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// Loads `gltf` as `model.gltf` next to `bin` as `model.bin`.
fn load_gltf(gltf: &Value, bin: &[u8]) -> Result<Scene, SceneError> {
    load_files(&[
        ("model.gltf", gltf.to_string().as_bytes()),
        ("model.bin", bin),
    ])
}

const POSITIONS: [[f32; 3]; 3] = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// The binary buffer of [`triangle`]: positions at 0, normals at 36, texture
/// coordinates at 72, u16 indices at 96 (+2 bytes padding) = 104 bytes.
fn triangle_bin(positions: [[f32; 3]; 3], normals: [[f32; 3]; 3], indices: [u16; 3]) -> Vec<u8> {
    let mut bytes = Vec::new();
    for v in positions.iter().chain(&normals) {
        for c in v {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for uv in [[0.0f32, 0.0], [1.0, 0.0], [0.0, 1.0]] {
        for c in uv {
            bytes.extend_from_slice(&c.to_le_bytes());
        }
    }
    for i in indices {
        bytes.extend_from_slice(&i.to_le_bytes());
    }
    bytes.extend_from_slice(&[0, 0]);
    bytes
}

fn valid_bin() -> Vec<u8> {
    triangle_bin(POSITIONS, [[0.0, 0.0, 1.0]; 3], [0, 1, 2])
}

/// A valid one-triangle glTF: accessor 0 POSITION, 1 NORMAL, 2 TEXCOORD_0,
/// 3 indices, each in its own bufferView (0..3) of buffer 0 (`model.bin`).
fn triangle() -> Value {
    json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0]}],
        "nodes": [{"mesh": 0}],
        "meshes": [{"primitives": [{
            "attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2},
            "indices": 3,
            "material": 0
        }]}],
        "materials": [{"name": "m"}],
        "buffers": [{"byteLength": 104, "uri": "model.bin"}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 36},
            {"buffer": 0, "byteOffset": 36, "byteLength": 36},
            {"buffer": 0, "byteOffset": 72, "byteLength": 24},
            {"buffer": 0, "byteOffset": 96, "byteLength": 6}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 3, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 3, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 3, "type": "SCALAR"}
        ]
    })
}

/// `triangle()` with `edit` applied.
fn edited(edit: impl FnOnce(&mut Value)) -> Value {
    let mut g = triangle();
    edit(&mut g);
    g
}

/// Asserts `result` is an error of `kind`, one line, naming the file and every needle.
fn assert_error(
    result: Result<Scene, SceneError>,
    kind: fn(&SceneError) -> bool,
    needles: &[&str],
) -> String {
    let error = match result {
        Ok(_) => panic!("loaded without error, expected one mentioning {needles:?}"),
        Err(e) => e,
    };
    let message = error.to_string();
    assert!(kind(&error), "wrong kind: {error:?}");
    assert!(!message.contains('\n'), "not one line: {message}");
    assert!(
        message.contains("model.gltf") || message.contains("model.glb"),
        "does not name the file: {message}"
    );
    for needle in needles {
        assert!(
            message.contains(needle),
            "\"{message}\" does not mention \"{needle}\""
        );
    }
    let after_path = message
        .rsplit_once("model.gl")
        .map_or(&*message, |(_, m)| m);
    assert!(after_path.len() <= 220, "too long: {message}");
    message
}

fn malformed(e: &SceneError) -> bool {
    matches!(e, SceneError::Malformed { .. })
}
fn invalid(e: &SceneError) -> bool {
    matches!(e, SceneError::Invalid { .. })
}
fn unsupported(e: &SceneError) -> bool {
    matches!(e, SceneError::Unsupported { .. })
}

#[test]
fn the_base_triangle_loads() {
    let s = load_gltf(&triangle(), &valid_bin()).unwrap();
    assert_eq!(s.triangles.len(), 1);
}

// --- Panics inside the gltf crate -------------------------------------------

#[test]
fn byte_stride_smaller_than_the_element_is_refused() {
    let g = edited(|g| g["bufferViews"][0]["byteStride"] = json!(4));
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &[
            "accessor 0 (mesh 0 primitive 0 POSITION)",
            "byteStride 4",
            "element size 12",
        ],
    );
    // Not a multiple of 4 (the spec's rule), though large enough.
    let g = edited(|g| g["bufferViews"][0]["byteStride"] = json!(13));
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &["bufferView 0", "byteStride 13"],
    );
}

#[test]
fn float_indices_are_refused() {
    let g = edited(|g| g["accessors"][3]["componentType"] = json!(5126));
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &[
            "accessor 3 (mesh 0 primitive 0 indices)",
            "component type FLOAT",
        ],
    );
}

#[test]
fn u32_texture_coordinates_are_refused() {
    let g = edited(|g| g["accessors"][2]["componentType"] = json!(5125));
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &[
            "accessor 2 (mesh 0 primitive 0 TEXCOORD_0)",
            "component type UNSIGNED_INT",
        ],
    );
    // Unnormalized UNSIGNED_SHORT is not a texture coordinate either.
    let g = edited(|g| g["accessors"][2]["componentType"] = json!(5123));
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &["accessor 2", "UNSIGNED_SHORT"],
    );
}

// --- Silently wrong images --------------------------------------------------

#[test]
fn index_count_past_the_buffer_is_refused() {
    let g = edited(|g| g["accessors"][3]["count"] = json!(6));
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &[
            "accessor 3 (mesh 0 primitive 0 indices)",
            "count 6",
            "bufferView 3 has 6",
        ],
    );
}

#[test]
fn vec3_indices_are_refused() {
    let g = edited(|g| {
        g["accessors"][3]["type"] = json!("VEC3");
        g["accessors"][3]["count"] = json!(1);
    });
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &["accessor 3", "type VEC3, expected SCALAR"],
    );
}

// --- Accepted without a word ------------------------------------------------

#[test]
fn nan_normals_and_positions_are_refused() {
    let bin = triangle_bin(
        POSITIONS,
        [[0.0, 0.0, 1.0], [f32::NAN, 0.0, 1.0], [0.0, 0.0, 1.0]],
        [0, 1, 2],
    );
    assert_error(
        load_gltf(&triangle(), &bin),
        invalid,
        &["accessor 1 (mesh 0 primitive 0 NORMAL)", "vertex 1", "NaN"],
    );
    let mut positions = POSITIONS;
    positions[2][1] = f32::INFINITY;
    let bin = triangle_bin(positions, [[0.0, 0.0, 1.0]; 3], [0, 1, 2]);
    assert_error(
        load_gltf(&triangle(), &bin),
        invalid,
        &[
            "accessor 0 (mesh 0 primitive 0 POSITION)",
            "vertex 2",
            "inf",
        ],
    );
}

/// `triangle()` with accessor 0 sparse: one index (u8 at byte 104 of the
/// buffer, bufferView 4) and its value (VEC3 at byte 108, bufferView 5).
fn sparse_triangle(index: u8, value: [f32; 3]) -> (Value, Vec<u8>) {
    let mut bin = valid_bin();
    bin.extend_from_slice(&[index, 0, 0, 0]);
    for c in value {
        bin.extend_from_slice(&c.to_le_bytes());
    }
    let g = edited(|g| {
        g["buffers"][0]["byteLength"] = json!(bin.len());
        let views = g["bufferViews"].as_array_mut().unwrap();
        views.push(json!({"buffer": 0, "byteOffset": 104, "byteLength": 1}));
        views.push(json!({"buffer": 0, "byteOffset": 108, "byteLength": 12}));
        g["accessors"][0]["sparse"] = json!({
            "count": 1,
            "indices": {"bufferView": 4, "componentType": 5121},
            "values": {"bufferView": 5}
        });
    });
    (g, bin)
}

#[test]
fn sparse_index_past_the_vertex_count_is_refused() {
    let (g, bin) = sparse_triangle(1, [2.0, 0.0, 0.0]);
    let s = load_gltf(&g, &bin).unwrap();
    assert!(s.triangle(0).contains(&glam::Vec3::new(2.0, 0.0, 0.0)));
    let (g, bin) = sparse_triangle(7, [2.0, 0.0, 0.0]);
    assert_error(
        load_gltf(&g, &bin),
        malformed,
        &[
            "accessor 0 (mesh 0 primitive 0 POSITION)",
            "sparse index 0 is 7",
            "count 3",
        ],
    );
    // Sparse values that are NaN are caught like any other position.
    let (g, bin) = sparse_triangle(1, [f32::NAN, 0.0, 0.0]);
    assert_error(load_gltf(&g, &bin), invalid, &["accessor 0", "vertex 1"]);
}

#[test]
fn index_values_past_the_vertex_count_are_refused() {
    let bin = triangle_bin(POSITIONS, [[0.0, 0.0, 1.0]; 3], [0, 1, 5]);
    assert_error(
        load_gltf(&triangle(), &bin),
        malformed,
        &[
            "accessor 3 (mesh 0 primitive 0 indices)",
            "index 2",
            "vertex 5",
            "accessor 0",
        ],
    );
}

#[test]
fn mismatched_component_types_and_shapes_are_refused() {
    for (accessor, field, value, needles) in [
        (
            0,
            "componentType",
            json!(5123),
            [
                "accessor 0 (mesh 0 primitive 0 POSITION)",
                "component type UNSIGNED_SHORT, expected FLOAT",
            ],
        ),
        (
            0,
            "type",
            json!("VEC2"),
            [
                "accessor 0 (mesh 0 primitive 0 POSITION)",
                "type VEC2, expected VEC3",
            ],
        ),
        (
            1,
            "componentType",
            json!(5121),
            [
                "accessor 1 (mesh 0 primitive 0 NORMAL)",
                "component type UNSIGNED_BYTE, expected FLOAT",
            ],
        ),
        (
            2,
            "type",
            json!("VEC3"),
            [
                "accessor 2 (mesh 0 primitive 0 TEXCOORD_0)",
                "type VEC3, expected VEC2",
            ],
        ),
    ] {
        let g = edited(|g| g["accessors"][accessor][field] = value);
        let result = load_gltf(&g, &valid_bin());
        // POSITION's min/max are checked by the gltf crate's own validation
        // against the shape; either error names the accessor.
        let error = result.expect_err("loaded a mismatched accessor");
        let message = error.to_string();
        assert!(
            needles.iter().all(|n| message.contains(n))
                || (accessor == 0 && field == "type" && message.contains("accessors[0]")),
            "{message}"
        );
    }
}

#[test]
fn out_of_range_material_factors_are_refused() {
    for (extensions, needle) in [
        (
            json!({"KHR_materials_transmission": {"transmissionFactor": 1e39}}),
            "transmissionFactor",
        ),
        (
            json!({"KHR_materials_transmission": {"transmissionFactor": -0.5}}),
            "transmissionFactor",
        ),
        (json!({"KHR_materials_ior": {"ior": -1}}), "ior"),
        (json!({"KHR_materials_ior": {"ior": 1e39}}), "ior"),
        (
            json!({"KHR_materials_emissive_strength": {"emissiveStrength": 1e39}}),
            "emissive_strength",
        ),
        (
            json!({"KHR_materials_specular": {"specularFactor": 1.5}}),
            "specularFactor",
        ),
        (
            json!({"KHR_materials_specular": {"specularColorFactor": [1, -1, 1]}}),
            "specularColorFactor",
        ),
    ] {
        let g = edited(|g| g["materials"][0]["extensions"] = extensions);
        assert_error(
            load_gltf(&g, &valid_bin()),
            invalid,
            &["material 0 (\"m\")", needle],
        );
    }
    // ior 0 is the extension's special value: refused only when transmissive.
    let g = edited(|g| g["materials"][0]["extensions"] = json!({"KHR_materials_ior": {"ior": 0}}));
    assert!(load_gltf(&g, &valid_bin()).is_ok());
    let g = edited(|g| {
        g["materials"][0]["extensions"] = json!({
            "KHR_materials_ior": {"ior": 0},
            "KHR_materials_transmission": {"transmissionFactor": 0.5}
        })
    });
    assert_error(load_gltf(&g, &valid_bin()), invalid, &["material 0", "ior"]);
    let g = edited(|g| g["materials"][0]["emissiveFactor"] = json!([1e39, 0, 0]));
    assert_error(
        load_gltf(&g, &valid_bin()),
        invalid,
        &["material 0", "emissiveFactor"],
    );
}

/// KHR_materials_specular and KHR_materials_ior reach the coated lobe of a
/// non-transmissive material; metallic is a mix weight, not a threshold.
#[test]
fn specular_and_ior_extensions_set_the_coat() {
    let g = edited(|g| {
        g["materials"][0]["pbrMetallicRoughness"] = json!({"metallicFactor": 0.25});
        g["materials"][0]["extensions"] = json!({
            "KHR_materials_specular": {"specularFactor": 0.5, "specularColorFactor": [1, 0.5, 0.25]},
            "KHR_materials_ior": {"ior": 1.8}
        });
    });
    let scene = load_gltf(&g, &valid_bin()).unwrap();
    let Surface::Coated(c) = scene.materials[0].surface else {
        panic!("{:?}", scene.materials[0].surface)
    };
    assert_eq!(
        (c.metallic, c.specular, c.specular_color, c.ior),
        (0.25, 0.5, Vec3::new(1.0, 0.5, 0.25), 1.8)
    );
    // Specular 0 and metallic 0: nothing but the base, a Lambertian surface.
    let g = edited(|g| {
        g["materials"][0]["pbrMetallicRoughness"] = json!({"metallicFactor": 0});
        g["materials"][0]["extensions"] = json!({"KHR_materials_specular": {"specularFactor": 0}});
    });
    let scene = load_gltf(&g, &valid_bin()).unwrap();
    assert!(matches!(
        scene.materials[0].surface,
        Surface::Diffuse { .. }
    ));
}

#[test]
fn out_of_range_volume_values_are_refused() {
    for (volume, needle) in [
        (json!({"thicknessFactor": -1}), "thicknessFactor"),
        (
            json!({"thicknessFactor": 1, "attenuationDistance": 0}),
            "attenuationDistance",
        ),
        (
            json!({"thicknessFactor": 1, "attenuationDistance": -2}),
            "attenuationDistance",
        ),
        (
            json!({"thicknessFactor": 1, "attenuationColor": [2, 0, 0]}),
            "attenuationColor",
        ),
        (
            json!({"thicknessFactor": 1, "attenuationColor": [-1, 0, 0]}),
            "attenuationColor",
        ),
    ] {
        let g = edited(|g| {
            g["materials"][0]["extensions"] = json!({
                "KHR_materials_transmission": {"transmissionFactor": 1},
                "KHR_materials_volume": volume
            })
        });
        assert_error(
            load_gltf(&g, &valid_bin()),
            invalid,
            &["material 0 (\"m\")", "KHR_materials_volume", needle],
        );
    }
}

/// The material of the base triangle with `extensions` and base colour `base`.
fn material_with(base: [f32; 3], extensions: Value) -> scene::Material {
    let g = edited(|g| {
        g["materials"][0]["extensions"] = extensions;
        g["materials"][0]["pbrMetallicRoughness"] = json!({"baseColorFactor": [base[0], base[1], base[2], 1.0], "roughnessFactor": 0.5, "metallicFactor": 0});
    });
    load_gltf(&g, &valid_bin()).unwrap().materials[0].clone()
}

#[test]
fn transmission_is_tinted_glass_and_volume_absorbs() {
    use glam::Vec3;
    let base = [0.9, 0.5, 0.2];
    let clear = material_with(
        base,
        json!({"KHR_materials_transmission": {"transmissionFactor": 1}}),
    );
    assert!(
        matches!(clear.surface, scene::Surface::Dielectric { tint, ior, .. }
        if tint == Vec3::from_array(base) && ior == 1.5)
    );
    assert_eq!(clear.medium, None, "no KHR_materials_volume: clear");
    // sigma_a = -ln(attenuationColor) / attenuationDistance (KHR_materials_volume).
    let volume = json!({
        "KHR_materials_transmission": {"transmissionFactor": 1},
        "KHR_materials_volume": {
            "thicknessFactor": 0.1, "attenuationColor": [0.5, 1.0, 0.25], "attenuationDistance": 2.0
        }
    });
    let absorbing = material_with(base, volume.clone());
    let sigma_a = absorbing.medium.expect("a closed volume absorbs").sigma_a;
    let expected = Vec3::new(0.5f32.ln() / -2.0, 0.0, 0.25f32.ln() / -2.0);
    assert!((sigma_a - expected).abs().max_element() < 1e-6, "{sigma_a}");
    // thicknessFactor 0 is a thin wall: no volume.
    let mut thin = volume.clone();
    thin["KHR_materials_volume"]["thicknessFactor"] = json!(0);
    assert_eq!(material_with(base, thin).medium, None);
    // Transmission below one half: the base (the coated lobe) wins, nothing to fill.
    let mut weak = volume;
    weak["KHR_materials_transmission"]["transmissionFactor"] = json!(0.3);
    let weak = material_with(base, weak);
    assert!(matches!(weak.surface, scene::Surface::Coated(_)));
    assert_eq!(weak.medium, None);
}

#[test]
fn out_of_range_light_values_are_refused() {
    let g = edited(|g| {
        g["extensionsUsed"] = json!(["KHR_lights_punctual"]);
        g["extensions"] = json!({"KHR_lights_punctual": {"lights": [
            {"type": "point", "intensity": 1e39}
        ]}});
        g["nodes"] = json!([{"mesh": 0}, {"extensions": {"KHR_lights_punctual": {"light": 0}}}]);
        g["scenes"] = json!([{"nodes": [0, 1]}]);
    });
    assert_error(
        load_gltf(&g, &valid_bin()),
        invalid,
        &["light 0", "intensity"],
    );
}

#[test]
fn a_camera_without_its_projection_is_refused() {
    // The gltf crate checks that one projection exists, then unwraps the
    // one `type` names: this used to panic.
    let g = edited(|g| {
        g["cameras"] = json!([{"type": "perspective", "orthographic": {"xmag": 1, "ymag": 1, "zfar": 10, "znear": 0.1}}]);
        g["nodes"] = json!([{"mesh": 0}, {"camera": 0}]);
        g["scenes"] = json!([{"nodes": [0, 1]}]);
    });
    assert_error(load_gltf(&g, &valid_bin()), malformed, &["camera 0"]);
}

#[test]
fn huge_sparse_only_accessors_are_refused() {
    let (g, bin) = sparse_triangle(1, [2.0, 0.0, 0.0]);
    let g = {
        let mut g = g;
        g["accessors"][0]
            .as_object_mut()
            .unwrap()
            .remove("bufferView");
        g["accessors"][0]["count"] = json!(4_000_000_000u64);
        g
    };
    assert_error(
        load_gltf(&g, &bin),
        malformed,
        &[
            "accessor 0 (mesh 0 primitive 0 POSITION)",
            "count 4000000000 without a bufferView",
        ],
    );
}

#[test]
fn a_node_scaled_to_zero_still_loads() {
    // Its normal matrix is NaN; that is not the file's fault.
    let g = edited(|g| {
        g["nodes"] = json!([{"mesh": 0, "scale": [0, 0, 0]}, {"mesh": 0}]);
        g["scenes"] = json!([{"nodes": [0, 1]}]);
    });
    let s = load_gltf(&g, &valid_bin()).unwrap();
    assert_eq!((s.triangles.len(), s.report.degenerate_triangles), (1, 1));
}

#[test]
fn a_node_with_two_parents_is_refused() {
    // Each node lists the next twice: 2^40 paths to the mesh if walked as a tree.
    let g = edited(|g| {
        let mut nodes: Vec<Value> = (1..=40).map(|i| json!({"children": [i, i]})).collect();
        nodes.push(json!({"mesh": 0}));
        g["nodes"] = Value::Array(nodes);
    });
    let start = std::time::Instant::now();
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &["node 40", "reached twice"],
    );
    assert!(start.elapsed().as_secs() < 5);
}

// --- Misleading messages ----------------------------------------------------

#[test]
fn huge_counts_and_bad_offsets_say_so() {
    let g = edited(|g| g["accessors"][0]["count"] = json!(4_000_000_000u64));
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &[
            "accessor 0 (mesh 0 primitive 0 POSITION)",
            "count 4000000000",
        ],
    );
    let g = edited(|g| g["accessors"][0]["byteOffset"] = json!(1000));
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &["accessor 0", "byteOffset 1000"],
    );
    let g = edited(|g| g["accessors"][0]["byteOffset"] = json!(2));
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &["accessor 0", "byteOffset 2 is not a multiple"],
    );
    let g = edited(|g| g["bufferViews"][1]["byteOffset"] = json!(100));
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &["bufferView 1", "exceeds buffer 0"],
    );
    // byteLength larger than the file.
    let g = edited(|g| g["buffers"][0]["byteLength"] = json!(1u64 << 40));
    assert_error(
        load_gltf(&g, &valid_bin()),
        malformed,
        &["buffer 0", "byteLength 1099511627776"],
    );
}

#[test]
fn a_folder_as_buffer_says_folder() {
    let dir = scratch_dir();
    std::fs::create_dir_all(dir.join("scene/sub")).unwrap();
    let g = edited(|g| g["buffers"][0]["uri"] = json!("sub"));
    let path = dir.join("scene/model.gltf");
    std::fs::write(&path, g.to_string()).unwrap();
    let result = load_guarded(&path);
    let _ = std::fs::remove_dir_all(&dir);
    assert_error(result, invalid, &["buffer 0", "\"sub\"", "folder"]);
}

/// A PNG-named file that is not a PNG, used as a base color texture.
fn textured(uri: &str) -> Value {
    edited(|g| {
        g["materials"][0]["pbrMetallicRoughness"] = json!({"baseColorTexture": {"index": 0}});
        g["textures"] = json!([{"source": 0}]);
        g["images"] = json!([{"uri": uri}]);
    })
}

#[test]
fn image_decode_errors_name_the_image() {
    let g = textured("bad.png");
    let result = load_files(&[
        ("model.gltf", g.to_string().as_bytes()),
        ("model.bin", &valid_bin()),
        ("bad.png", b"not a png at all"),
    ]);
    assert_error(result, malformed, &["image 0", "\"bad.png\"", "decode"]);
}

/// `gltf` and `bin` as a binary glTF (JSON chunk + BIN chunk).
fn glb(gltf: &Value, bin: &[u8]) -> Vec<u8> {
    let mut gltf = gltf.clone();
    gltf["buffers"][0] = json!({"byteLength": bin.len()});
    glb_bytes(gltf.to_string().into_bytes(), bin)
}

/// A GLB of a JSON text (maybe no longer valid) and a binary chunk.
fn glb_bytes(mut json: Vec<u8>, bin: &[u8]) -> Vec<u8> {
    while !json.len().is_multiple_of(4) {
        json.push(b' ');
    }
    let total = 12 + 8 + json.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(json.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&json);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(bin);
    out
}

#[test]
fn truncated_glb_says_truncated() {
    let whole = glb(&triangle(), &valid_bin());
    assert_eq!(
        load_files(&[("model.glb", &whole)])
            .unwrap()
            .triangles
            .len(),
        1
    );
    for cut in [whole.len() - 1, whole.len() - 60, 40, 13, 8] {
        assert_error(
            load_files(&[("model.glb", &whole[..cut])]),
            malformed,
            &["truncated"],
        );
    }
}

// --- References outside the scene folder ------------------------------------

#[test]
fn buffer_and_image_uris_outside_the_scene_folder_are_refused() {
    let dir = scratch_dir();
    std::fs::write(dir.join("secret.bin"), valid_bin()).unwrap();
    std::fs::write(dir.join("secret.png"), b"x").unwrap();
    let path = dir.join("scene/model.gltf");
    let cases = [
        (
            edited(|g| g["buffers"][0]["uri"] = json!("../secret.bin")),
            "buffer 0",
        ),
        (
            edited(|g| g["buffers"][0]["uri"] = json!("../../../../../../../../etc/passwd")),
            "buffer 0",
        ),
        (
            edited(|g| g["buffers"][0]["uri"] = json!("%2E%2E/secret.bin")),
            "buffer 0",
        ),
        (textured("../secret.png"), "image 0"),
    ];
    std::fs::write(dir.join("scene/model.bin"), valid_bin()).unwrap();
    for (g, element) in cases {
        std::fs::write(&path, g.to_string()).unwrap();
        let result = load_guarded(&path);
        if g["buffers"][0]["uri"] == "../../../../../../../../etc/passwd"
            && !Path::new("/etc/passwd").exists()
        {
            continue;
        }
        assert_error(
            result,
            invalid,
            &[element, "outside", "--allow-outside-paths"],
        );
    }
    // Other schemes than data: are not read at all.
    for uri in ["file:///etc/passwd", "https://example.com/model.bin"] {
        std::fs::write(
            &path,
            edited(|g| g["buffers"][0]["uri"] = json!(uri)).to_string(),
        )
        .unwrap();
        assert_error(load_guarded(&path), unsupported, &["buffer 0", "data:"]);
    }
    // Percent-encoding that is not UTF-8 (the gltf crate would panic on it).
    std::fs::write(
        &path,
        edited(|g| g["buffers"][0]["uri"] = json!("%FF.bin")).to_string(),
    )
    .unwrap();
    assert_error(load_guarded(&path), malformed, &["buffer 0", "UTF-8"]);
    // With --allow-outside-paths the sibling file is read.
    std::fs::write(
        &path,
        edited(|g| g["buffers"][0]["uri"] = json!("../secret.bin")).to_string(),
    )
    .unwrap();
    let options = LoadOptions {
        allow_outside_paths: true,
        ..LoadOptions::default()
    };
    assert_eq!(load(&path, &options).unwrap().triangles.len(), 1);
    let _ = std::fs::remove_dir_all(&dir);
}

// --- Random edits -----------------------------------------------------------

/// One random edit of a glTF's JSON text, its binary buffer, or a GLB.
#[derive(Clone, Debug)]
enum Edit {
    /// XOR the byte at (position mod length) of the JSON text.
    FlipJson(usize, u8),
    /// XOR a byte of the binary buffer.
    FlipBin(usize, u8),
    /// Overwrite the 4-byte-aligned word (index mod words) of the buffer with a float.
    FloatBin(usize, f32),
    /// Replace the n-th number of the JSON text (mod count) with this text.
    Number(usize, &'static str),
    /// Cut the JSON text at (position mod length).
    CutJson(usize),
    /// Cut the binary buffer.
    CutBin(usize),
}

/// Replacements of numbers: invalid JSON, overflows, negatives, huge
/// counts, and legal values in the wrong place (component types, strides).
const NUMBERS: [&str; 20] = [
    "NaN",
    "1e39",
    "-1e39",
    "-1",
    "4000000000",
    "18446744073709551615",
    "0",
    "1",
    "2",
    "3",
    "4",
    "13",
    "252",
    "0.5",
    "65535",
    "5121",
    "5123",
    "5125",
    "5126",
    "1e-45",
];

fn edit_strategy() -> impl Strategy<Value = Edit> {
    let n = || any::<usize>();
    let float = prop_oneof![
        Just(f32::NAN),
        Just(f32::INFINITY),
        Just(-f32::INFINITY),
        Just(1e30f32),
        Just(-1.0f32),
        Just(f32::from_bits(7)),
    ];
    prop_oneof![
        1 => (n(), 1u8..).prop_map(|(i, x)| Edit::FlipJson(i, x)),
        2 => (n(), 1u8..).prop_map(|(i, x)| Edit::FlipBin(i, x)),
        3 => (n(), float).prop_map(|(i, x)| Edit::FloatBin(i, x)),
        8 => (n(), proptest::sample::select(&NUMBERS[..])).prop_map(|(i, x)| Edit::Number(i, x)),
        1 => n().prop_map(Edit::CutJson),
        1 => n().prop_map(Edit::CutBin),
    ]
}

/// Byte ranges of the numbers in a JSON text.
fn number_spans(text: &[u8]) -> Vec<(usize, usize)> {
    let mut spans = Vec::new();
    let mut i = 0;
    while i < text.len() {
        let c = text[i];
        if c.is_ascii_digit() || (c == b'-' && text.get(i + 1).is_some_and(u8::is_ascii_digit)) {
            let start = i;
            i += 1;
            while i < text.len() && (text[i].is_ascii_digit() || b".eE+-".contains(&text[i])) {
                i += 1;
            }
            // Digits inside names ("2.0", "TEXCOORD_0") are edited too: fine.
            spans.push((start, i));
        } else {
            i += 1;
        }
    }
    spans
}

fn apply(edits: &[Edit], json: &mut Vec<u8>, bin: &mut Vec<u8>) {
    for edit in edits {
        match *edit {
            Edit::FlipJson(i, x) if !json.is_empty() => {
                let i = i % json.len();
                json[i] ^= x;
            }
            Edit::FlipBin(i, x) if !bin.is_empty() => {
                let i = i % bin.len();
                bin[i] ^= x;
            }
            Edit::FloatBin(i, x) if bin.len() >= 4 => {
                let i = i % (bin.len() / 4) * 4;
                bin[i..i + 4].copy_from_slice(&x.to_le_bytes());
            }
            Edit::Number(n, text) => {
                let spans = number_spans(json);
                if !spans.is_empty() {
                    let (a, b) = spans[n % spans.len()];
                    json.splice(a..b, text.bytes());
                }
            }
            Edit::CutJson(i) if !json.is_empty() => json.truncate(i % json.len()),
            Edit::CutBin(i) if !bin.is_empty() => bin.truncate(i % bin.len()),
            _ => {}
        }
    }
}

/// A loaded scene holds only finite positions and normals.
fn assert_finite(scene: &Scene) {
    for t in 0..scene.triangles.len() {
        let (p, n) = (
            scene.triangle(t),
            scene.shading_normals(t, scene.geometric_normal(t)),
        );
        assert!(
            p.iter().chain(&n).all(|v| v.is_finite()),
            "triangle {t} is not finite: {p:?} {n:?}"
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig {
        cases: 400,
        failure_persistence: None,
        rng_seed: RngSeed::Fixed(0x5eed_2026),
        ..ProptestConfig::default()
    })]

    /// Random edits of the triangle (with a sparse accessor and a light, so
    /// that those paths are exercised too), as .gltf + .bin and as .glb:
    /// never a panic, and any scene that loads is finite.
    #[test]
    fn random_edits_never_panic_and_load_only_finite_scenes(
        edits in proptest::collection::vec(edit_strategy(), 1..4),
        as_glb in any::<bool>(),
    ) {
        let (mut g, bin) = sparse_triangle(1, [0.5, 0.5, 0.0]);
        g["extensionsUsed"] = json!(["KHR_lights_punctual"]);
        g["extensions"] = json!({"KHR_lights_punctual": {"lights": [
            {"type": "spot", "intensity": 2, "spot": {"innerConeAngle": 0.1, "outerConeAngle": 0.5}}
        ]}});
        g["nodes"] = json!([{"mesh": 0, "children": [1]}, {"extensions": {"KHR_lights_punctual": {"light": 0}}}]);
        if as_glb {
            g["buffers"][0] = json!({"byteLength": bin.len()});
        }
        let mut json_text = g.to_string().into_bytes();
        let mut bin = bin;
        apply(&edits, &mut json_text, &mut bin);
        let result = if as_glb {
            load_files(&[("model.glb", &glb_bytes(json_text, &bin))])
        } else {
            load_files(&[("model.gltf", &json_text), ("model.bin", &bin)])
        };
        match result {
            Ok(scene) => assert_finite(&scene),
            Err(e) => {
                let message = e.to_string();
                prop_assert!(!message.contains('\n'), "not one line: {}", message);
                prop_assert!(!message.contains("internal error"), "a panic was caught: {}", message);
                let (_, after_path) = message.rsplit_once("model.gl").unwrap_or(("", &message));
                prop_assert!(after_path.len() <= 300, "too long: {}", message);
            }
        }
    }
}
