//! Mitsuba 3 scene files: the format's rules (substitution, defaults,
//! includes, references, the 0.6 upgrade, transforms), the plugins mapped
//! to the scene model, Mitsuba's conventions, and hostile input.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

use glam::{UVec2, Vec3};
use scene::material::Surface;
use scene::{Light, LoadOptions, Scene, SceneError, load};

fn scratch_dir() -> PathBuf {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("mitsuba-tests-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    dir
}

/// Writes `files` to a fresh folder and loads the first with `parameters`.
fn load_with(files: &[(&str, &[u8])], parameters: &[(&str, &str)]) -> Result<Scene, SceneError> {
    let dir = scratch_dir();
    for (name, content) in files {
        let path = dir.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, content).expect("write test file");
    }
    let options = LoadOptions {
        parameters: parameters
            .iter()
            .map(|(k, v)| (k.to_string(), v.to_string()))
            .collect(),
        ..Default::default()
    };
    let result = load(&dir.join(files[0].0), &options);
    let _ = std::fs::remove_dir_all(&dir);
    result
}

fn load_xml(xml: &str) -> Result<Scene, SceneError> {
    load_with(&[("scene.xml", xml.as_bytes())], &[])
}

/// A scene of `body` with a camera and a light, so that it validates.
fn scene(body: &str) -> String {
    format!(
        r#"<scene version="3.0.0">
    <sensor type="perspective">
        <float name="fov" value="60"/>
        <transform name="to_world"><lookat origin="0,0,0" target="0,0,1" up="0,1,0"/></transform>
        <film type="hdrfilm"><integer name="width" value="32"/><integer name="height" value="24"/>
            <rfilter type="box"/></film>
    </sensor>
    <emitter type="constant"/>
    {body}
</scene>"#
    )
}

/// A shape far behind the camera, so that a scene validates.
const CUBE: &str =
    r#"<shape type="cube"><transform name="to_world"><translate z="-10"/></transform></shape>"#;

/// `bytes` as a zlib stream (the `.serialized` format's compression).
fn zlib(bytes: &[u8]) -> Vec<u8> {
    use std::io::Write;
    let mut e = flate2::write::ZlibEncoder::new(Vec::new(), flate2::Compression::default());
    e.write_all(bytes).unwrap();
    e.finish().unwrap()
}

fn error(xml: &str) -> String {
    load_xml(xml).expect_err("must fail").to_string()
}

#[test]
fn camera_follows_mitsubas_convention() {
    let s = load_xml(&scene(CUBE)).unwrap();
    let c = s.camera;
    assert_eq!(c.resolution, UVec2::new(32, 24));
    assert_eq!(c.forward, Vec3::Z);
    // Mitsuba shows world +x (the camera's local +x, "left") on the left.
    assert!((c.right - Vec3::NEG_X).length() < 1e-6, "{}", c.right);
    assert!((c.up - Vec3::Y).length() < 1e-6);
    // fov 60 along x: tan(fov_y / 2) = tan(30 deg) / (32 / 24).
    let expected = 2.0 * (30f32.to_radians().tan() * 24.0 / 32.0).atan();
    assert!((c.vertical_fov - expected).abs() < 1e-5);
    // Note §3's measured projection of (1, 0, 5): px = W/2 (1 - X / (Z t)) = 10.457.
    let p = Vec3::new(1.0, 0.0, 5.0) - c.position;
    let half_x = (0.5 * c.vertical_fov).tan() * c.aspect();
    let px = 0.5 * 32.0 * (1.0 + p.dot(c.right) / (p.dot(c.forward) * half_x));
    assert!((px - 10.457).abs() < 1e-2, "{px}");

    // A mirroring to_world flips the image left to right (measured: the
    // sphere moves to the right half).
    let mirrored = scene(CUBE).replace("<lookat", r#"<scale x="-1"/><lookat"#);
    let m = load_xml(&mirrored).unwrap().camera;
    assert!((m.right - Vec3::X).length() < 1e-6, "{}", m.right);
}

#[test]
fn fov_axes_and_resolution_override() {
    let xml = scene(CUBE).replace(
        r#"<float name="fov" value="60"/>"#,
        r#"<float name="fov" value="40"/><string name="fov_axis" value="smaller"/>"#,
    );
    let s = load_xml(&xml).unwrap();
    assert!((s.camera.vertical_fov.to_degrees() - 40.0).abs() < 1e-4);
    let dir = scratch_dir();
    std::fs::write(dir.join("scene.xml"), &xml).unwrap();
    let tall = load(
        &dir,
        &LoadOptions {
            resolution: Some(UVec2::new(12, 16)),
            ..Default::default()
        },
    )
    .unwrap();
    // The smaller axis is now x: the vertical fov is wider than 40.
    let x_fov = 2.0 * ((0.5 * tall.camera.vertical_fov).tan() * 0.75).atan();
    assert!((x_fov.to_degrees() - 40.0).abs() < 1e-3);
}

#[test]
fn parameters_defaults_and_substitution() {
    let xml = r#"<scene version="3.0.0">
        <default name="spp" value="16"/>
        <default name="res" value="20"/>
        <sensor type="perspective">
            <sampler type="independent"><integer name="sample_count" value="$spp"/></sampler>
            <film type="hdrfilm"><integer name="width" value="$res"/><integer name="height" value="$res"/></film>
        </sensor>
        <emitter type="directional"><vector name="direction" value="0, -1, 0"/><rgb name="irradiance" value="$r, 0.5, 0.25"/></emitter>
        <shape type="rectangle"/>
    </scene>"#;
    let files = [("scene.xml", xml.as_bytes())];
    let s = load_with(&files, &[("r", "2"), ("spp", "64")]).unwrap();
    assert_eq!(s.render.iterations, Some(64), "-D wins over <default>");
    assert_eq!(s.camera.resolution, UVec2::new(20, 20));
    assert!(s.lights.contains(&Light::Directional {
        direction: Vec3::NEG_Y,
        irradiance: Vec3::new(2.0, 0.5, 0.25),
    }));
    let e = load_with(&files, &[]).unwrap_err().to_string();
    assert!(
        e.contains("undefined parameter $r") && e.contains("line 8"),
        "{e}"
    );
    let e = load_with(&files, &[("r", "1"), ("unused", "1")])
        .unwrap_err()
        .to_string();
    assert!(e.contains("unused"), "{e}");
}

#[test]
fn transforms_compose_in_mitsubas_order() {
    // translate then scale: the scale applies after, so the centre moves to 2.
    let s = load_xml(&scene(
        r#"<shape type="sphere"><transform name="to_world"><translate x="1"/><scale value="2"/></transform></shape>
           <shape type="sphere"><point name="center" value="0, 0, 3"/><float name="radius" value="0.5"/>
              <transform name="to_world"><rotate y="1" angle="90"/></transform></shape>"#,
    ))
    .unwrap();
    assert_eq!(s.spheres[0].center, Vec3::new(2.0, 0.0, 0.0));
    assert_eq!(s.spheres[0].radius, 2.0);
    // rotate y by 90 maps +z to +x.
    assert!((s.spheres[1].center - Vec3::new(3.0, 0.0, 0.0)).length() < 1e-5);
    assert_eq!(s.spheres[1].radius, 0.5);
    let e = error(&scene(
        r#"<shape type="sphere"><transform name="to_world"><scale x="2"/></transform></shape>"#,
    ));
    assert!(e.contains("uniformly") && e.contains("line 9"), "{e}");
}

#[test]
fn built_in_shapes_emitters_and_materials() {
    let s = load_xml(&scene(
        r#"<bsdf type="roughconductor" id="gold"><string name="material" value="Au"/>
              <string name="distribution" value="ggx"/><float name="alpha" value="0.2"/></bsdf>
           <shape type="rectangle">
              <transform name="to_world"><rotate x="1" angle="90"/><translate y="2"/></transform>
              <emitter type="area"><spectrum name="radiance" value="2"/></emitter>
           </shape>
           <shape type="cube"><ref id="gold"/></shape>
           <shape type="disk"><bsdf type="dielectric"><string name="int_ior" value="acrylic glass"/></bsdf></shape>
           <shape type="cube"><bsdf type="twosided"><bsdf type="diffuse"><rgb name="reflectance" value="0.2, 0.4, 0.6"/></bsdf></bsdf></shape>
           <shape type="sphere"><bsdf type="plastic"/></shape>
           <shape type="rectangle"><bsdf type="thindielectric"><rgb name="specular_transmittance" value="0.9"/></bsdf></shape>"#,
    ))
    .unwrap();
    let emissive: Vec<_> = s.materials.iter().filter(|m| m.is_emissive()).collect();
    assert_eq!(emissive.len(), 1);
    // A uniform spectrum on an emitter is Mitsuba's xyz_to_srgb(1,1,1) tint.
    let e = emissive[0].emission;
    assert!(
        (e - Vec3::new(2.40959, 1.89658, 1.81783)).length() < 1e-4,
        "{e}"
    );
    // Rotated about x by 90 degrees, the rectangle faces -y (winding too).
    let area_lights: Vec<u32> = s
        .lights
        .iter()
        .filter_map(|l| match l {
            Light::Area { triangle } => Some(*triangle),
            _ => None,
        })
        .collect();
    assert_eq!(area_lights.len(), 2);
    for t in area_lights {
        let n = s.geometric_normal(t as usize);
        assert!((n - Vec3::NEG_Y).length() < 1e-6, "{n}");
        assert!(
            s.triangle(t as usize)
                .iter()
                .all(|p| (p.y - 2.0).abs() < 1e-6)
        );
    }
    let surfaces: Vec<Surface> = s.materials.iter().map(|m| m.surface).collect();
    assert!(surfaces.iter().any(|m| matches!(m,
        Surface::Conductor { model, fresnel: microfacet::Fresnel::Conductor { eta, .. } }
            if (model.alpha() - 0.2).abs() < 1e-6 && (eta.x - 0.1430).abs() < 1e-6)));
    assert!(surfaces.iter().any(|m| matches!(m,
        Surface::Dielectric { ior, .. } if (*ior - 1.49 / 1.000277).abs() < 1e-6)));
    assert!(surfaces.iter().any(|m| matches!(m,
        Surface::Diffuse { reflectance } if *reflectance == Vec3::new(0.2, 0.4, 0.6))));
    assert!(surfaces.iter().any(|m| matches!(m,
        Surface::Coated(c) if (c.ior - 1.49 / 1.000277).abs() < 1e-6)));
    assert!(surfaces.iter().any(|m| matches!(m,
        Surface::ThinDielectric { ior, tint }
            if (*ior - 1.5046 / 1.000277).abs() < 1e-6 && *tint == Vec3::splat(0.9))));
    // rectangle 2 + cube 12 + disk 256 + cube 12 + rectangle 2 triangles, one sphere.
    assert_eq!(
        s.triangles.len(),
        2 + 12 + scene::mitsuba::geometry::DISK_SEGMENTS as usize + 12 + 2
    );
    assert_eq!(s.spheres.len(), 1);
}

/// A Mitsuba 0.6 file: camelCase names, `diffuseReflectance`, `toWorld`.
#[test]
fn old_files_are_upgraded() {
    let xml = r#"<?xml version="1.0" encoding="utf-8"?>
<scene version="0.6.0">
    <integrator type="path"><integer name="maxDepth" value="5"/></integrator>
    <sensor type="perspective">
        <float name="fov" value="45"/><string name="fovAxis" value="y"/>
        <transform name="toWorld"><lookat origin="0, 1, -5" target="0, 1, 0" up="0, 1, 0"/></transform>
        <sampler type="independent"><integer name="sampleCount" value="8"/></sampler>
        <film type="hdrfilm"><integer name="width" value="40"/><integer name="height" value="30"/></film>
    </sensor>
    <shape type="rectangle"><bsdf type="diffuse"><rgb name="diffuseReflectance" value="0.3"/></bsdf>
        <emitter type="area"><rgb name="radiance" value="1"/></emitter></shape>
    <shape type="sphere"><bsdf type="dielectric"><float name="intIOR" value="1.33"/></bsdf></shape>
</scene>"#;
    let s = load_xml(xml).unwrap();
    assert_eq!(s.render.max_depth, Some(5));
    assert_eq!(s.render.iterations, Some(8));
    assert_eq!(s.render.integrator.as_deref(), Some("pt"));
    assert!((s.camera.vertical_fov.to_degrees() - 45.0).abs() < 1e-4);
    assert!(s.materials.iter().any(|m| matches!(m.surface,
        Surface::Diffuse { reflectance } if reflectance == Vec3::splat(0.3))));
    assert!(s.materials.iter().any(|m| matches!(m.surface,
        Surface::Dielectric { ior, .. } if (ior - 1.33 / 1.000277).abs() < 1e-6)));
    // Mitsuba's default film is gaussian: the box we use is announced.
    assert!(
        s.report.warnings.iter().any(|w| w.contains("box filter")),
        "{:?}",
        s.report.warnings
    );
}

#[test]
fn includes_refs_and_paths() {
    let main = r#"<scene version="3.0.0">
        <include filename="parts/materials.xml"/>
        <sensor type="perspective"><float name="fov" value="30"/></sensor>
        <emitter type="point"><point name="position" x="0" y="3" z="0"/><rgb name="intensity" value="5"/></emitter>
        <shape type="obj"><string name="filename" value="meshes/tri.obj"/><ref id="red"/></shape>
        <shape type="obj"><string name="filename" value="meshes/tri.obj"/><ref id="glow"/>
            <transform name="to_world"><translate z="-1"/></transform></shape>
    </scene>"#;
    let materials = r#"<scene version="3.0.0">
        <bsdf type="diffuse" id="red"><rgb name="reflectance" value="0.8, 0.1, 0.1"/></bsdf>
        <emitter type="area" id="glow"><rgb name="radiance" value="0.5"/></emitter>
    </scene>"#;
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";
    let s = load_with(
        &[
            ("scene.xml", main.as_bytes()),
            ("parts/materials.xml", materials.as_bytes()),
            ("meshes/tri.obj", obj.as_bytes()),
        ],
        &[],
    )
    .unwrap();
    assert_eq!(s.triangles.len(), 2);
    // An area emitter given by reference lights the second triangle.
    assert_eq!(
        s.materials[s.triangle_materials[1] as usize].emission,
        Vec3::splat(0.5)
    );
    assert_eq!(
        s.materials[s.triangle_materials[0] as usize].surface,
        Surface::Diffuse {
            reflectance: Vec3::new(0.8, 0.1, 0.1)
        }
    );
    // A normal-less mesh gets Mitsuba's computed (here: flat) normals.
    assert!(s.normals.is_empty() || s.normals.iter().all(|n| (*n - Vec3::Z).length() < 1e-6));
    assert_eq!(s.camera.resolution, scene::mitsuba::DEFAULT_FILM);
}

/// One-line errors that name the file, line and element; no panic.
#[test]
fn bad_input_is_named() {
    for (body, expected) in [
        (
            r#"<shape type="cube"><ref id="nope"/></shape>"#,
            "no object has id \"nope\"",
        ),
        (
            r#"<shape type="cube"><bsdf type="diffuse"><rgb name="reflectance" value="1.5"/></bsdf></shape>"#,
            "[0, 1]",
        ),
        (
            r#"<shape type="cube"><bsdf type="dielectric"><string name="int_ior" value="unobtainium"/></bsdf></shape>"#,
            "unknown IOR",
        ),
        (
            r#"<shape type="cube"><bsdf type="conductor"><string name="material" value="Xx"/></bsdf></shape>"#,
            "unknown conductor",
        ),
        (
            r#"<shape type="cube"><bsdf type="roughconductor"><float name="alpha_u" value="0.1"/><float name="alpha_v" value="0.2"/></bsdf></shape>"#,
            "anisotropic",
        ),
        (
            r#"<shape type="shapegroup"/>"#,
            "shape type \"shapegroup\" is not supported",
        ),
        (
            r#"<shape type="cube"><bsdf type="diffuse" id="a"/></shape><shape type="cube"><bsdf type="diffuse" id="a"/></shape>"#,
            "already used",
        ),
        (
            r#"<shape type="cube"><integer name="x" value="3.0"/></shape>"#,
            "not an integer",
        ),
        (
            r#"<shape type="cube"><boolean name="flip_normals" value="1"/></shape>"#,
            "not true or false",
        ),
        (
            r#"<shape type="obj"><string name="filename" value="../../etc/passwd"/></shape>"#,
            "filename",
        ),
        (
            r#"<shape type="cube"><transform name="to_world"><rotate angle="3"/></transform></shape>"#,
            "axis is zero",
        ),
        (r#"<blackbody/>"#, "unknown element"),
        (
            r#"<shape type="cube"><medium type="homogeneous" name="interior"/></shape>"#,
            "media are not supported",
        ),
        (
            r#"<shape type="cube"><bsdf type="blendbsdf"/></shape>"#,
            "\"blendbsdf\" is not supported",
        ),
        (
            r#"<shape type="cube"><float name="radius" value="1"/><float name="face_normals" value="1"/></shape>"#,
            "expected a <boolean>",
        ),
    ] {
        let e = error(&scene(body));
        assert!(e.contains(expected), "{body}: {e}");
        assert!(
            e.contains("scene.xml") && e.contains("line 9"),
            "{body}: {e}"
        );
        assert_eq!(e.lines().count(), 1);
    }
    let e = error(r#"<scene><shape type="cube"/></scene>"#);
    assert!(e.contains("version"), "{e}");
    let e = error("<scene version=\"3.0.0\"><shape type=\"cube\">");
    assert!(e.contains("XML"), "{e}");
}

#[test]
fn hostile_documents_are_refused_without_panic() {
    // Entity expansion (billion laughs): DTDs are refused outright.
    let laughs = r#"<?xml version="1.0"?><!DOCTYPE lolz [<!ENTITY lol "lol"><!ENTITY lol2 "&lol;&lol;&lol;">]>
<scene version="3.0.0"><string name="x" value="&lol2;"/></scene>"#;
    assert!(error(laughs).contains("XML"));
    // Deep nesting stops at the limit.
    let deep = format!(
        r#"<scene version="3.0.0">{}{}</scene>"#,
        r#"<bsdf type="twosided">"#.repeat(5000),
        "</bsdf>".repeat(5000)
    );
    assert!(error(&deep).contains("nest"), "{}", error(&deep));
    // A file including itself stops at Mitsuba's include depth.
    let e = error(r#"<scene version="3.0.0"><include filename="scene.xml"/></scene>"#);
    assert!(e.contains("includes nest deeper"), "{e}");
    // Mesh headers claiming 10^12 vertices are refused before allocating.
    let ply = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n\0\0\0\0";
    let mut serialized = vec![0x1C, 0x04, 4, 0];
    let mut body = vec![0u8; 4];
    body.extend_from_slice(b"m\0");
    body.extend_from_slice(&1_000_000_000_000u64.to_le_bytes());
    body.extend_from_slice(&1u64.to_le_bytes());
    serialized.extend(zlib(&body));
    serialized.extend_from_slice(&0u64.to_le_bytes());
    serialized.extend_from_slice(&1u32.to_le_bytes());
    for (plugin, file, bytes) in [
        ("ply", "m.ply", &ply[..]),
        ("serialized", "m.serialized", &serialized[..]),
    ] {
        let xml = scene(&format!(
            r#"<shape type="{plugin}"><string name="filename" value="{file}"/></shape>"#
        ));
        let e = load_with(&[("scene.xml", xml.as_bytes()), (file, bytes)], &[])
            .unwrap_err()
            .to_string();
        assert!(e.contains(file) && e.contains("1000000000000"), "{e}");
    }
    // A BSDF that refers to itself.
    let e = error(&scene(
        r#"<bsdf type="twosided" id="loop"><ref id="loop"/></bsdf><shape type="cube"><ref id="loop"/></shape>"#,
    ));
    assert!(e.contains("too deeply"), "{e}");
}

/// Unused properties and plugins we do not have are one warning each
/// naming the plugin and line, not errors.
#[test]
fn what_is_ignored_is_said() {
    let s = load_xml(&scene(
        r#"<integrator type="path_guiding_integrator"/>
           <shape type="cube"><bsdf type="diffuse"><float name="roughness" value="0.3"/></bsdf></shape>"#,
    ))
    .unwrap();
    let w = &s.report.warnings;
    assert!(
        w.iter().any(|w| w.contains("path_guiding_integrator")),
        "{w:?}"
    );
    assert!(
        w.iter()
            .any(|w| w.contains("line 10") && w.contains("\"roughness\"")),
        "{w:?}"
    );
}

#[test]
fn folders_holding_a_scene_xml_load() {
    let dir = scratch_dir();
    std::fs::write(dir.join("scene.xml"), scene("<shape type=\"cube\"/>")).unwrap();
    let s = load(Path::new(&dir), &LoadOptions::default()).unwrap();
    assert_eq!(s.triangles.len(), 12);
}

/// A manifest's `[[model]]` takes a Mitsuba file: its shapes, materials and
/// lights join the manifest's (the manifest's camera and settings rule).
#[test]
fn manifests_take_mitsuba_models() {
    let model = scene(
        r#"<shape type="cube"><bsdf type="conductor"><string name="material" value="Au"/></bsdf></shape>"#,
    );
    let manifest = "resolution = [8, 6]\n[camera]\nfrom = [0, 0, 5]\nat = [0, 0, 0]\nfov = 40\n[[model]]\nfile = \"model.xml\"\n";
    let s = load_with(
        &[
            ("scene.toml", manifest.as_bytes()),
            ("model.xml", model.as_bytes()),
        ],
        &[],
    )
    .unwrap();
    assert_eq!(s.triangles.len(), 12);
    assert_eq!(s.camera.resolution, UVec2::new(8, 6));
    assert!(
        s.lights
            .iter()
            .any(|l| matches!(l, Light::Environment { .. }))
    );
    assert!(
        s.materials
            .iter()
            .any(|m| matches!(m.surface, Surface::Conductor { .. }))
    );
}
