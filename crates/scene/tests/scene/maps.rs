//! Emission, normal and alpha maps and KHR_texture_transform, as the glTF
//! and OBJ/MTL loaders read them: each file is written here (a unit quad in
//! the z = 0 plane, PNG textures made with the `image` crate).

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{Vec2, Vec3};
use scene::material::{Alpha, NormalMapKind};
use scene::{LoadOptions, Scene, SceneError, load};
use serde_json::{Value, json};

/// A fresh scratch folder.
fn scratch_dir() -> PathBuf {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("scene-maps-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    dir
}

/// A `width` x 1 RGBA PNG whose texel x is `texel(x)`.
fn png(width: u32, texel: impl Fn(u32) -> [u8; 4]) -> Vec<u8> {
    let pixels: Vec<u8> = (0..width).flat_map(texel).collect();
    let mut out = std::io::Cursor::new(Vec::new());
    image::write_buffer_with_format(
        &mut out,
        &pixels,
        width,
        1,
        image::ExtendedColorType::Rgba8,
        image::ImageFormat::Png,
    )
    .expect("png");
    out.into_inner()
}

/// Writes `files` into a scratch folder and loads the first one.
fn load_files(files: &[(&str, Vec<u8>)]) -> Result<Scene, SceneError> {
    let dir = scratch_dir();
    for (name, bytes) in files {
        std::fs::write(dir.join(name), bytes).expect("write");
    }
    let result = load(&dir.join(files[0].0), &LoadOptions::default());
    let _ = std::fs::remove_dir_all(&dir);
    result
}

/// The quad's buffer: 4 positions, 4 normals, 4 uvs, 4 tangents, 6 u16 indices.
fn quad_bin() -> Vec<u8> {
    let mut b = Vec::new();
    let mut floats = |v: &[f32]| v.iter().for_each(|c| b.extend_from_slice(&c.to_le_bytes()));
    floats(&[0., 0., 0., 1., 0., 0., 1., 1., 0., 0., 1., 0.]);
    floats(&[0., 0., 1., 0., 0., 1., 0., 0., 1., 0., 0., 1.]);
    floats(&[0., 1., 1., 1., 1., 0., 0., 0.]);
    floats(&[
        1., 0., 0., -1., 1., 0., 0., -1., 1., 0., 0., -1., 1., 0., 0., -1.,
    ]);
    for i in [0u16, 1, 2, 0, 2, 3] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b
}

/// A unit quad (two triangles) with `material`, textures 0 (`a.png`) and 1
/// (`b.png`), a point light, and TANGENT when `tangents`.
fn quad_gltf(material: Value, tangents: bool) -> Value {
    let mut attributes = json!({"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2});
    if tangents {
        attributes["TANGENT"] = json!(3);
    }
    json!({
        "asset": {"version": "2.0"},
        "extensionsUsed": ["KHR_texture_transform", "KHR_materials_emissive_strength", "KHR_lights_punctual"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"extensions": {"KHR_lights_punctual": {"light": 0}}, "translation": [0, 0, 2]}],
        "extensions": {"KHR_lights_punctual": {"lights": [{"type": "point", "intensity": 1}]}},
        "meshes": [{"primitives": [{"attributes": attributes, "indices": 4, "material": 0}]}],
        "materials": [material],
        "textures": [{"source": 0, "sampler": 0}, {"source": 1, "sampler": 0}],
        "samplers": [{"wrapS": 33071, "wrapT": 33071}],
        "images": [{"uri": "a.png"}, {"uri": "b.png"}],
        "buffers": [{"byteLength": 204, "uri": "quad.bin"}],
        "bufferViews": [
            {"buffer": 0, "byteOffset": 0, "byteLength": 48},
            {"buffer": 0, "byteOffset": 48, "byteLength": 48},
            {"buffer": 0, "byteOffset": 96, "byteLength": 32},
            {"buffer": 0, "byteOffset": 128, "byteLength": 64},
            {"buffer": 0, "byteOffset": 192, "byteLength": 12}
        ],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "type": "VEC3", "min": [0, 0, 0], "max": [1, 1, 0]},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5126, "count": 4, "type": "VEC4"},
            {"bufferView": 4, "componentType": 5123, "count": 6, "type": "SCALAR"}
        ]
    })
}

/// Texture a: left half black, right half white, alpha 0 on the left and
/// 255 on the right (8 texels). Texture b: a normal map tilted to +x.
fn load_quad(material: Value, tangents: bool) -> Result<Scene, SceneError> {
    let a = png(8, |x| {
        if x < 4 {
            [0, 0, 0, 0]
        } else {
            [255, 255, 255, 255]
        }
    });
    let b = png(2, |_| [255, 128, 128, 255]);
    load_files(&[
        (
            "quad.gltf",
            quad_gltf(material, tangents).to_string().into_bytes(),
        ),
        ("quad.bin", quad_bin()),
        ("a.png", a),
        ("b.png", b),
    ])
}

#[test]
fn emissive_texture_strength_and_transform() {
    let material = json!({
        "emissiveFactor": [0.5, 1.0, 1.0],
        "emissiveTexture": {"index": 0, "extensions": {"KHR_texture_transform": {"offset": [0.5, 0.0]}}},
        "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 4.0}}
    });
    let scene = load_quad(material, false).unwrap();
    let m = &scene.materials[0];
    assert_eq!(m.emission, Vec3::new(2.0, 4.0, 4.0));
    let t = m.maps.emission.expect("emissive texture");
    assert!(scene.textures[t].transform.is_some());
    // The offset moves the white half to u < 0.5 (clamped edges: u + 0.5 > 1 reads white).
    let at = |u: f32| m.emission_at(Vec2::new(u, 0.5), &scene.textures);
    assert_eq!(at(0.1), Vec3::new(2.0, 4.0, 4.0));
    assert_eq!(at(0.3), Vec3::new(2.0, 4.0, 4.0));
    // Both triangles are area lights (chosen by the factor).
    assert_eq!(
        scene
            .lights
            .iter()
            .filter(|l| matches!(l, scene::Light::Area { .. }))
            .count(),
        2
    );

    // Without the transform, the left half is black.
    let material = json!({"emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0}});
    let scene = load_quad(material, false).unwrap();
    let m = &scene.materials[0];
    assert_eq!(
        m.emission_at(Vec2::new(0.1, 0.5), &scene.textures),
        Vec3::ZERO
    );
    assert_eq!(
        m.emission_at(Vec2::new(0.9, 0.5), &scene.textures),
        Vec3::ONE
    );
}

#[test]
fn normal_texture_and_tangents() {
    let material = json!({"normalTexture": {"index": 1, "scale": 0.5}});
    let scene = load_quad(material.clone(), true).unwrap();
    let map = scene.materials[0].maps.normal.expect("normal map");
    assert_eq!(map.kind, NormalMapKind::Tangent { scale: 0.5 });
    let texel = scene.textures[map.texture].sample(Vec2::splat(0.5));
    // Linear (not sRGB-decoded): 128/255.
    assert!((texel.y - 128.0 / 255.0).abs() < 1e-6, "{texel}");
    assert_eq!(scene.triangles.len(), 2);
    assert!(
        (0..2)
            .flat_map(|i| scene.corner_tangents(i))
            .all(|t| t.truncate() == Vec3::X && t.w == -1.0)
    );
    // Without TANGENT, none are stored (derived from the uvs when rendering).
    let scene = load_quad(material, false).unwrap();
    assert!(scene.tangents.is_empty());
    // TANGENT without a normal map is not read.
    let scene = load_quad(json!({}), true).unwrap();
    assert!(scene.tangents.is_empty() && scene.materials[0].maps.normal.is_none());
}

#[test]
fn alpha_modes() {
    let with = |mode: Value| {
        let mut m = json!({"pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "baseColorFactor": [1, 1, 1, 0.8]}});
        if let Value::Object(extra) = mode {
            m.as_object_mut().unwrap().extend(extra);
        }
        let scene = load_quad(m, false).unwrap();
        (scene.materials[0].maps.alpha, scene)
    };
    // OPAQUE (default) ignores alpha.
    let (alpha, _) = with(json!({}));
    assert_eq!(alpha, Alpha::Opaque);
    // MASK: alpha = 0.8 x texture alpha against the cutoff.
    let (alpha, scene) = with(json!({"alphaMode": "MASK", "alphaCutoff": 0.7}));
    assert!(
        matches!(alpha, Alpha::Mask { cutoff, factor, texture: Some(_) } if cutoff == 0.7 && factor == 0.8)
    );
    assert_eq!(alpha.coverage(Vec2::new(0.1, 0.5), &scene.textures), 0.0);
    assert_eq!(alpha.coverage(Vec2::new(0.9, 0.5), &scene.textures), 1.0);
    let (alpha, scene) = with(json!({"alphaMode": "MASK", "alphaCutoff": 0.9}));
    assert_eq!(alpha.coverage(Vec2::new(0.9, 0.5), &scene.textures), 0.0);
    // Default cutoff 0.5.
    let (alpha, _) = with(json!({"alphaMode": "MASK"}));
    assert!(matches!(alpha, Alpha::Mask { cutoff, .. } if cutoff == 0.5));
    // BLEND: coverage is alpha.
    let (alpha, scene) = with(json!({"alphaMode": "BLEND"}));
    assert!((alpha.coverage(Vec2::new(0.9, 0.5), &scene.textures) - 0.8).abs() < 1e-6);
    assert_eq!(alpha.coverage(Vec2::new(0.1, 0.5), &scene.textures), 0.0);
    // An untextured blend of alpha 1 costs nothing: opaque.
    let scene = load_quad(json!({"alphaMode": "BLEND"}), false).unwrap();
    assert_eq!(scene.materials[0].maps.alpha, Alpha::Opaque);
}

#[test]
fn texture_transform_and_tex_coord() {
    // rotation pi about the origin, then offset (1, 1): u -> 1 - u.
    let material = json!({"emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0,
        "extensions": {"KHR_texture_transform": {"offset": [1, 1], "rotation": std::f32::consts::PI}}}});
    let scene = load_quad(material, false).unwrap();
    let m = &scene.materials[0];
    let e = |u: f32| m.emission_at(Vec2::new(u, 0.5), &scene.textures).x;
    assert!(
        (e(0.1) - 1.0).abs() < 1e-5 && e(0.9) < 1e-5,
        "{} {}",
        e(0.1),
        e(0.9)
    );

    // A texCoord other than 0 is read with TEXCOORD_0, with a warning.
    let material =
        json!({"emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0, "texCoord": 1}});
    let scene = load_quad(material, false).unwrap();
    assert!(
        scene
            .report
            .warnings
            .iter()
            .any(|w| w.contains("TEXCOORD_1") && w.contains("emissiveTexture")),
        "{:?}",
        scene.report.warnings
    );

    // A malformed transform is refused in one line naming the key (by
    // the gltf crate's reader for textureInfo, by ours for normalTexture).
    let material = json!({"emissiveFactor": [1, 1, 1], "emissiveTexture": {"index": 0,
        "extensions": {"KHR_texture_transform": {"scale": [1]}}}});
    let message = load_quad(material, false).expect_err("refused").to_string();
    assert!(
        message.contains("quad.gltf") && !message.contains('\n'),
        "{message}"
    );
    let material = json!({"normalTexture": {"index": 1,
        "extensions": {"KHR_texture_transform": {"scale": [1]}}}});
    let message = load_quad(material, false).expect_err("refused").to_string();
    assert!(
        message.contains("normalTexture") && message.contains("scale") && !message.contains('\n'),
        "{message}"
    );
    // The normal texture's transform is applied.
    let material = json!({"normalTexture": {"index": 1,
        "extensions": {"KHR_texture_transform": {"offset": [0.25, 0]}}}});
    let scene = load_quad(material, false).unwrap();
    let t = scene.materials[0].maps.normal.unwrap().texture;
    assert_eq!(
        scene.textures[t].transform.map(|t| t.offset),
        Some(Vec2::new(0.25, 0.0))
    );
}

#[test]
fn mtl_norm_and_bump() {
    let obj = "mtllib a.mtl\nv 0 0 0\nv 1 0 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 1 1\nusemtl m\nf 1/1 2/2 3/3\n";
    let h = png(2, |x| [x as u8 * 200, 0, 0, 255]);
    let load_mtl = |mtl: &str| {
        load_files(&[
            ("a.obj", obj.as_bytes().to_vec()),
            ("a.mtl", mtl.as_bytes().to_vec()),
            ("h.png", h.clone()),
        ])
    };
    let scene = load_mtl("newmtl m\nKd 0.5 0.5 0.5\nbump -bm 0.25 h.png\n").unwrap();
    let map = scene.materials[0].maps.normal.expect("bump");
    assert_eq!(map.kind, NormalMapKind::Height { scale: 0.25 });
    // Height maps are linear.
    assert!(
        (scene.textures[map.texture].sample(Vec2::new(0.75, 0.5)).x - 200.0 / 255.0).abs() < 1e-6
    );
    let scene = load_mtl("newmtl m\nKd 0.5 0.5 0.5\nnorm h.png\nbump h.png\n").unwrap();
    assert_eq!(
        scene.materials[0].maps.normal.map(|m| m.kind),
        Some(NormalMapKind::Tangent { scale: 1.0 })
    );
    let scene = load_mtl("newmtl m\nKd 0.5 0.5 0.5\nmap_Bump -clamp on h.png\n").unwrap();
    assert!(scene.materials[0].maps.normal.is_some());
    assert!(
        scene.report.warnings.iter().any(|w| w.contains("-clamp")),
        "{:?}",
        scene.report.warnings
    );
    let message = load_mtl("newmtl m\nKd 0.5 0.5 0.5\nbump -bm x h.png\n")
        .expect_err("refused")
        .to_string();
    assert!(
        message.contains("-bm") && message.contains("a.mtl"),
        "{message}"
    );
}
