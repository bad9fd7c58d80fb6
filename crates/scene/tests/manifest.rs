//! The bundled scenes and the manifest's features: overrides by name, shapes,
//! lights, cameras; glTF punctual lights and orthographic cameras.

use std::path::{Path, PathBuf};

use glam::{UVec2, Vec3};
use microfacet::{NdfKind, Shadowing};
use scene::{Light, LoadOptions, SceneError, SceneFeatures, Surface, load};

fn bundled(name: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes")
        .join(name)
        .join("scene.toml")
}

fn features(name: &str) -> (scene::Scene, SceneFeatures) {
    let s = load(&bundled(name), &LoadOptions::default()).unwrap_or_else(|e| panic!("{name}: {e}"));
    let f = SceneFeatures::of(&s);
    (s, f)
}

#[test]
fn bundled_scenes_have_what_their_readmes_say() {
    let (cornell, f) = features("cornell-box");
    assert_eq!(
        (cornell.triangles.len(), f.area_lights, f.smallest_alpha),
        (32, 2, None)
    );
    assert_eq!(cornell.camera.resolution, UVec2::new(256, 256));
    assert_eq!(cornell.render.iterations, Some(64));

    let (glass, f) = features("caustic-glass");
    assert_eq!(
        (f.delta_lights, f.area_lights, f.specular_materials),
        (1, 0, 2)
    );
    assert!(f.transmission && !f.regularization_matters(0.0));

    let (_, f) = features("glossy-caustic");
    assert_eq!(f.smallest_alpha, Some(0.02));
    assert!(f.regularization_matters(0.1) && !f.regularization_matters(0.01));

    let (_, f) = features("diffuse-only");
    assert_eq!(f.smallest_alpha, None);
    assert!(f.environment && !f.transmission);

    let (stiff, f) = features("stiff");
    assert!(f.transmission && f.delta_lights == 1 && f.area_lights == 2);
    let kinds: Vec<_> = stiff
        .materials
        .iter()
        .filter_map(|m| m.surface.microfacet())
        .map(|m| (m.ndf.kind(), m.alpha()))
        .collect();
    assert!(kinds.contains(&(NdfKind::Beckmann, 3.0)) && kinds.contains(&(NdfKind::Ggx, 1e-6)));
    let (min, max) = stiff.bounds();
    assert!((max - min).max_element() >= 1e5);
    assert!(glass.lights.iter().all(|l| l.is_delta()));
}

fn write_manifest(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "scene-manifest-tests-{}-{name}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

#[test]
fn overrides_change_a_model_material_by_name() {
    let obj =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/cornell-box/cornell-box.obj");
    let text = format!(
        "[[model]]\nfile = {:?}\n\n[[material]]\nname = \"floor\"\ntype = \"conductor\"\nroughness = 0.3\nndf = \"beckmann\"\nshadowing = \"v-cavity\"\nreflectance = [0.9, 0.8, 0.7]\n\n[[material]]\nname = \"light\"\nemission = [1, 2, 3]\n\n[[light]]\ntype = \"spot\"\nposition = [0, 1.9, 0]\ndirection = [0, -1, 0]\nintensity = [4, 4, 4]\ninner = 10\nouter = 20\n",
        obj.display().to_string()
    );
    let s = load(
        &write_manifest("override", &text),
        &LoadOptions {
            resolution: Some(UVec2::new(32, 16)),
            ..Default::default()
        },
    )
    .unwrap();
    let floor = s.materials.iter().find(|m| m.name == "floor").unwrap();
    assert!(matches!(floor.surface, Surface::Conductor { model, .. }
        if model.ndf.kind() == NdfKind::Beckmann && model.shadowing == Shadowing::VCavity && (model.alpha() - 0.09).abs() < 1e-6));
    // An override without `type` keeps the surface and changes what it names.
    let light = s.materials.iter().find(|m| m.name == "light").unwrap();
    assert_eq!(light.emission, Vec3::new(1.0, 2.0, 3.0));
    assert!(matches!(light.surface, Surface::Diffuse { .. }));
    assert!(s.lights.iter().any(|l| matches!(l, Light::Spot { cos_outer, .. } if (cos_outer - 20f32.to_radians().cos()).abs() < 1e-6)));
    assert_eq!(s.camera.resolution, UVec2::new(32, 16));
    // Roughness on a diffuse material needs a type: a clear error.
    let bad = format!(
        "[[model]]\nfile = {:?}\n[[material]]\nname = \"leftWall\"\nalpha = 0.1\n",
        obj.display().to_string()
    );
    let err = load(
        &write_manifest("diffuse-roughness", &bad),
        &LoadOptions::default(),
    )
    .unwrap_err();
    assert!(
        err.to_string().contains("material \"leftWall\"") && err.to_string().contains("type"),
        "{err}"
    );
}

#[test]
fn gltf_punctual_lights_and_orthographic_camera() {
    let gltf = r#"{"asset":{"version":"2.0"},"extensionsUsed":["KHR_lights_punctual"],
"extensions":{"KHR_lights_punctual":{"lights":[{"type":"spot","color":[1,0.5,0.25],"intensity":8,"spot":{"innerConeAngle":0.2,"outerConeAngle":0.4}},{"type":"directional","intensity":3}]}},
"scene":0,"scenes":[{"nodes":[0,1,2]}],
"nodes":[{"translation":[0,2,0],"extensions":{"KHR_lights_punctual":{"light":0}}},{"extensions":{"KHR_lights_punctual":{"light":1}}},{"camera":0,"translation":[0,0,5]}],
"cameras":[{"type":"orthographic","orthographic":{"xmag":1,"ymag":1,"znear":0.1,"zfar":10}}]}"#;
    let dir = std::env::temp_dir().join(format!("scene-gltf-lights-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("lights.gltf");
    std::fs::write(&path, gltf).unwrap();
    // The only camera is orthographic: refused, naming it and what to do.
    let err = load(&path, &LoadOptions::default()).unwrap_err();
    assert!(
        matches!(err, SceneError::Unsupported { .. }) && err.to_string().contains("orthographic"),
        "{err}"
    );
    // Without the camera the lights load, placed by their nodes.
    std::fs::write(&path, gltf.replace("[0,1,2]", "[0,1]")).unwrap();
    let s = load(&path, &LoadOptions::default()).unwrap();
    assert!(s.lights.iter().any(|l| matches!(l, Light::Spot { position, intensity, cos_inner, .. }
        if *position == Vec3::new(0.0, 2.0, 0.0) && *intensity == Vec3::new(8.0, 4.0, 2.0) && (cos_inner - 0.2f32.cos()).abs() < 1e-6)));
    assert!(s.lights.iter().any(|l| matches!(l, Light::Directional { direction, .. } if (*direction - Vec3::NEG_Z).length() < 1e-6)));
}
