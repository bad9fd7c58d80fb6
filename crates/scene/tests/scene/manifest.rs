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
fn a_folder_loads_its_manifest() {
    let manifest = bundled("caustic-glass");
    let folder = manifest.parent().unwrap();
    let options = LoadOptions::default();
    let (a, b) = (
        load(folder, &options).unwrap(),
        load(&manifest, &options).unwrap(),
    );
    assert_eq!(
        (a.triangles.len(), a.spheres.len(), a.materials.len()),
        (b.triangles.len(), b.spheres.len(), b.materials.len())
    );
    let empty = std::env::temp_dir().join("rlt-scene-folder-without-manifest");
    std::fs::create_dir_all(&empty).unwrap();
    let error = load(&empty, &options).unwrap_err().to_string();
    assert!(error.contains("scene.toml"), "{error}");
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
            // The model is the bundled one, outside the test's folder.
            allow_outside_paths: true,
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
        &LoadOptions {
            allow_outside_paths: true,
            ..Default::default()
        },
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
    // (The file has no geometry: an error unless allowed.)
    std::fs::write(&path, gltf.replace("[0,1,2]", "[0,1]")).unwrap();
    let err = load(&path, &LoadOptions::default()).unwrap_err();
    assert!(err.to_string().contains("no geometry"), "{err}");
    let allow_empty = LoadOptions {
        allow_empty: true,
        ..Default::default()
    };
    let s = load(&path, &allow_empty).unwrap();
    assert!(s.lights.iter().any(|l| matches!(l, Light::Spot { position, intensity, cos_inner, .. }
        if *position == Vec3::new(0.0, 2.0, 0.0) && *intensity == Vec3::new(8.0, 4.0, 2.0) && (cos_inner - 0.2f32.cos()).abs() < 1e-6)));
    assert!(s.lights.iter().any(|l| matches!(l, Light::Directional { direction, .. } if (*direction - Vec3::NEG_Z).length() < 1e-6)));
}

/// A manifest with one triangle (so that it loads) and `render` as its `[render]` table.
fn with_render_table(name: &str, render: &str) -> Result<scene::Scene, SceneError> {
    let text = format!(
        "[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[shape]]\ntype = \"quad\"\nmaterial = \"m\"\norigin = [0, 0, 0]\nu = [1, 0, 0]\nv = [0, 1, 0]\n[render]\n{render}"
    );
    // No light: allowed, since only the [render] table matters here.
    let options = LoadOptions {
        allow_empty: true,
        ..Default::default()
    };
    load(&write_manifest(name, &text), &options)
}

#[test]
fn render_table_keys_are_read() {
    let s = with_render_table(
        "render-keys",
        "integrator = \"vcm\"\niterations = 8\nmax_depth = 5\nregularize = \"uniform\"\ntau0 = 30\nprogressive = false\nseed = 7\nradius = 0.01\nshadow_roulette = 0\nvirtual_merges = false\n",
    )
    .unwrap();
    let r = &s.render;
    assert_eq!(
        (r.integrator.as_deref(), r.iterations, r.max_depth),
        (Some("vcm"), Some(8), Some(5))
    );
    assert_eq!(
        (r.regularize.as_deref(), r.tau0, r.seed),
        (Some("uniform"), Some(30.0), Some(7))
    );
    assert_eq!(
        (r.radius, r.shadow_roulette, r.virtual_merges, r.progressive),
        (Some(0.01), Some(0.0), Some(false), Some(false))
    );
    // Keys left out stay unset: the command line's defaults apply.
    let s = with_render_table("render-empty", "").unwrap();
    assert_eq!(s.render, scene::RenderSettings::default());
}

#[test]
fn render_table_values_of_the_wrong_type_name_the_file_line_and_key() {
    for (render, key, line) in [
        ("virtual_merges = \"on\"\n", "virtual_merges", "line 11"),
        ("virtual_merges = 1\n", "virtual_merges", "line 11"),
        ("radius = \"small\"\n", "radius", "line 11"),
        (
            "seed = 0\nshadow_roulette = [0.1]\n",
            "shadow_roulette",
            "line 12",
        ),
    ] {
        let err = with_render_table("render-types", render).unwrap_err();
        let text = err.to_string();
        assert!(matches!(err, SceneError::Malformed { .. }), "{text}");
        assert!(
            text.contains("scene.toml: ") && text.contains(&format!("{line}: {key}: ")),
            "{render}: {text}"
        );
        assert!(!text.contains('\n'), "{text}");
    }
    // The keys are spelt with underscores, like max_depth.
    let err = with_render_table("render-dash", "shadow-roulette = 0.1\n").unwrap_err();
    assert!(
        err.to_string().contains("unknown field `shadow-roulette`"),
        "{err}"
    );
}

#[test]
fn render_table_numbers_are_passed_on_for_the_command_line_to_check() {
    // Ranges are checked by render-cli, with the flags' checks, when the value
    // is used (a flag that overrides it makes it irrelevant): the loader keeps
    // NaN and negative values as they are written.
    let s = with_render_table("render-nan", "radius = nan\nshadow_roulette = -1\n").unwrap();
    assert!(s.render.radius.is_some_and(f32::is_nan));
    assert_eq!(s.render.shadow_roulette, Some(-1.0));
}

#[test]
fn dielectrics_take_a_tint_and_an_absorption() {
    let scene = |material: &str| {
        format!(
            "[camera]\nfrom = [0, 0, 3]\nat = [0, 0, 0]\nfov = 40\n\n[[material]]\nname = \"glass\"\n{material}\n\n[[shape]]\ntype = \"sphere\"\nmaterial = \"glass\"\ncenter = [0, 0, 0]\nradius = 0.5\n\n[[light]]\ntype = \"point\"\nposition = [0, 2, 0]\nintensity = [1, 1, 1]\n"
        )
    };
    let text = scene("type = \"dielectric\"\ntint = [1, 0.5, 0.25]\nabsorption = [0, 0.5, 2]");
    let s = load(
        &write_manifest("absorbing-glass", &text),
        &LoadOptions::default(),
    )
    .unwrap();
    let glass = &s.materials[0];
    assert!(
        matches!(glass.surface, Surface::Dielectric { tint, .. } if tint == Vec3::new(1.0, 0.5, 0.25))
    );
    assert_eq!(glass.medium.unwrap().sigma_a, Vec3::new(0.0, 0.5, 2.0));
    // Clear glass by default; absorption only where light can enter.
    let s = load(
        &write_manifest("clear-glass", &scene("type = \"dielectric\"")),
        &LoadOptions::default(),
    )
    .unwrap();
    assert!(
        matches!(s.materials[0].surface, Surface::Dielectric { tint, .. } if tint == Vec3::ONE)
    );
    assert_eq!(s.materials[0].medium, None);
    for (material, needle) in [
        ("type = \"diffuse\"\nabsorption = [1, 1, 1]", "absorption"),
        (
            "type = \"dielectric\"\nabsorption = [-1, 1, 1]",
            "absorption",
        ),
        ("type = \"dielectric\"\ntint = [1.5, 1, 1]", "tint"),
    ] {
        let err = load(
            &write_manifest("bad-glass", &scene(material)),
            &LoadOptions::default(),
        )
        .unwrap_err()
        .to_string();
        assert!(
            err.contains("material \"glass\"") && err.contains(needle),
            "{err}"
        );
    }
}

/// `shape = "sphere"` is an analytic sphere (no triangles; an emissive one
/// is a `Light::Sphere`), unless `tessellate = true` or a cap below 180
/// degrees asks for triangles; `rings` without `tessellate` is a warning.
#[test]
fn spheres_are_analytic_unless_tessellated() {
    let base = "[[material]]\nname = \"lamp\"\ntype = \"diffuse\"\nemission = [1, 1, 1]\n\n\
                [[shape]]\ntype = \"sphere\"\nmaterial = \"lamp\"\ncenter = [1, 2, 3]\nradius = 0.5\n";
    let load_text = |name: &str, extra: &str| {
        load(
            &write_manifest(name, &format!("{base}{extra}")),
            &LoadOptions::default(),
        )
        .unwrap()
    };
    let analytic = load_text("analytic-sphere", "");
    assert_eq!((analytic.triangles.len(), analytic.spheres.len()), (0, 1));
    assert_eq!(analytic.lights, vec![Light::Sphere { sphere: 0 }]);
    let s = analytic.spheres[0];
    assert_eq!(
        (s.center, s.radius, s.axis, s.inside),
        (Vec3::new(1.0, 2.0, 3.0), 0.5, Vec3::Y, false)
    );
    let (min, max) = analytic.bounds();
    assert_eq!(
        (min, max),
        (Vec3::new(0.5, 1.5, 2.5), Vec3::new(1.5, 2.5, 3.5))
    );
    assert!(analytic.report.warnings.is_empty());

    let tessellated = load_text("tessellated-sphere", "tessellate = true\nrings = 4\n");
    // 4 rings x 8 segments x 2 triangles, less the degenerate ones at the poles.
    assert!((48..=64).contains(&tessellated.triangles.len()) && tessellated.spheres.is_empty());
    assert!(
        tessellated
            .lights
            .iter()
            .all(|l| matches!(l, Light::Area { .. }))
    );
    let cap = load_text("cap-sphere", "cap = 90\n");
    assert!(!cap.triangles.is_empty() && cap.spheres.is_empty());
    let rings = load_text("rings-sphere", "rings = 16\ninside = true\n");
    assert_eq!(rings.spheres.len(), 1);
    assert!(rings.spheres[0].inside);
    assert!(
        rings.report.warnings.iter().any(|w| w.contains("rings")),
        "{:?}",
        rings.report.warnings
    );
}
