//! Loaders on real files written by third parties (`tests/data/`, copied
//! unmodified from the team's shared folder; licences and sources in
//! `tests/data/SOURCES.md` and each folder's licence file).

use std::path::{Path, PathBuf};

use glam::{UVec2, Vec3};
use microfacet::{Fresnel, NdfKind};
use scene::{Light, LoadOptions, Scene, SceneError, SceneFeatures, Surface, load};

fn data(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/data")
        .join(relative)
}

fn load_default(relative: &str) -> Scene {
    load(&data(relative), &LoadOptions::default()).unwrap_or_else(|e| panic!("{relative}: {e}"))
}

fn material<'a>(scene: &'a Scene, name: &str) -> &'a scene::Material {
    scene
        .materials
        .iter()
        .find(|m| m.name == name)
        .unwrap_or_else(|| panic!("no material {name}"))
}

fn area_lights(scene: &Scene) -> usize {
    scene
        .lights
        .iter()
        .filter(|l| matches!(l, Light::Area { .. }))
        .count()
}

#[test]
fn cornell_box_original() {
    // Moved to the bundled scenes (it is `scenes/cornell-mcguire` too).
    let s = load_default("../../../../scenes/cornell-mcguire/CornellBox-Original.obj");
    assert_eq!(s.triangles.len(), 36);
    assert_eq!(s.materials.len(), 8);
    // The ceiling light is one quad: two emissive triangles, facing down.
    assert_eq!(area_lights(&s), 2);
    let light = material(&s, "light");
    assert_eq!(light.emission, Vec3::new(17.0, 12.0, 4.0));
    for l in &s.lights {
        if let Light::Area { triangle } = l {
            assert!(s.geometric_normal(*triangle as usize).y < -0.99);
        }
    }
    assert!(
        matches!(material(&s, "leftWall").surface, Surface::Diffuse { reflectance } if (reflectance - Vec3::new(0.63, 0.065, 0.05)).length() < 1e-6)
    );
    // No camera in the file: an automatic one frames the box from +z.
    let (min, max) = s.bounds();
    assert!(s.camera.position.z > max.z && s.camera.forward.z < -0.99);
    assert!((min.x + 1.01).abs() < 0.02 && (max.y - 1.99).abs() < 0.02);
    // Upstream quirk (SOURCES.md): bottom faces reuse other faces' vertices.
    assert_eq!(s.report.non_manifold_edges, 8);
}

#[test]
fn cornell_box_sphere_maps_mirror_glass_and_ignores_tf() {
    let s = load_default("cornell-box-sphere/CornellBox-Sphere.obj");
    assert_eq!(s.triangles.len(), 2188);
    assert!(matches!(material(&s, "leftSphere").surface,
        Surface::Conductor { model, fresnel: Fresnel::Schlick { f0 } } if model.is_smooth() && (f0 - Vec3::splat(0.95)).length() < 1e-6));
    assert!(
        matches!(material(&s, "rightSphere").surface, Surface::Dielectric { model, ior, .. } if model.is_smooth() && ior == 2.5)
    );
    // `Tf 1 1 1` on the opaque light must not make it transparent.
    let light = material(&s, "light");
    assert!(matches!(light.surface, Surface::Diffuse { .. }));
    assert_eq!(light.emission, Vec3::splat(10.0));
    let f = SceneFeatures::of(&s);
    assert!(f.transmission && f.specular_materials == 2 && f.area_lights == 2);
}

#[test]
fn box_loads_identically_from_gltf_glb_and_embedded() {
    let a = load_default("Box/glTF/Box.gltf");
    let b = load_default("Box/glTF-Binary/Box.glb");
    let c = load_default("Box/glTF-Embedded/Box.gltf");
    assert_eq!(a.triangles.len(), 12);
    let corners = |s: &scene::Scene| {
        (0..s.triangles.len())
            .map(|i| s.triangle(i))
            .collect::<Vec<_>>()
    };
    assert_eq!(corners(&a), corners(&b));
    assert_eq!(corners(&a), corners(&c));
    // A non-metal: the coated lobe (glTF's default coat, ior 1.5) over the base.
    assert!(
        matches!(a.materials[0].surface, Surface::Coated(c) if c.base_color == Vec3::new(0.8, 0.0, 0.0)
            && c.metallic == 0.0 && c.specular == 1.0 && c.ior == 1.5)
    );
    // The root node's matrix turns Z-up into Y-up: the unit cube stays a unit cube.
    let (min, max) = a.bounds();
    assert!((max - min - Vec3::ONE).length() < 1e-5, "{min} {max}");
    // No lights in the file: a constant environment is added, and said so.
    assert!(
        a.lights
            .iter()
            .any(|l| matches!(l, Light::Environment { .. }))
    );
    assert_eq!(a.report.warnings.len(), 1);
}

#[test]
fn cameras_first_perspective_and_orthographic_refused() {
    let s = load_default("Cameras/glTF/Cameras.gltf");
    assert_eq!(s.triangles.len(), 2);
    assert!((s.camera.position - Vec3::new(0.5, 0.5, 3.0)).length() < 1e-5);
    assert!((s.camera.vertical_fov - 0.7).abs() < 1e-5);
    assert_eq!(s.camera.resolution, UVec2::new(512, 512));
    // glTF's default material: metallic 1, roughness 1.
    assert!(
        matches!(s.materials[0].surface, Surface::Coated(c) if c.model.alpha() == 1.0 && c.metallic == 1.0)
    );
    let embedded = load_default("Cameras/glTF-Embedded/Cameras.gltf");
    assert_eq!(embedded.positions, s.positions);
    assert_eq!(embedded.triangles, s.triangles);
    // The orthographic camera has no name in the file; asking for a missing
    // name lists what exists, and choosing an orthographic one is refused.
    let err = load(
        &data("Cameras/glTF/Cameras.gltf"),
        &LoadOptions {
            camera_name: Some("nope".into()),
            ..Default::default()
        },
    )
    .unwrap_err();
    assert!(
        matches!(err, SceneError::Malformed { .. })
            && err.to_string().contains("no camera named \"nope\""),
        "{err}"
    );
}

#[test]
fn metal_rough_spheres_map_metallic_and_roughness() {
    let s = load_default("MetalRoughSpheresNoTextures/glTF/MetalRoughSpheresNoTextures.gltf");
    assert_eq!(s.triangles.len(), 1_040_213);
    assert_eq!(s.report.degenerate_triangles, 196);
    let f = SceneFeatures::of(&s);
    // 7 x 7 x 2 spheres: every one the coated lobe, metallic a mix weight
    // in steps of 1/6, alpha = r^2 in steps of r = 1/6.
    let coated: Vec<_> = s
        .materials
        .iter()
        .filter_map(|m| match m.surface {
            Surface::Coated(c) => Some((m, c)),
            _ => None,
        })
        .collect();
    assert!(coated.len() >= 98, "{}", coated.len());
    let sixths = |x: f32| ((x * 6.0).round() - x * 6.0).abs() < 1e-3;
    for (m, c) in &coated {
        assert_eq!(c.model.ndf.kind(), NdfKind::Ggx);
        let r = c.model.alpha().sqrt();
        // alpha clamps to 1e-7 at r = 0.
        assert!(sixths(r) || c.model.alpha() <= 1e-6, "{}", m.name);
        assert!(sixths(c.metallic), "{}: metallic {}", m.name, c.metallic);
    }
    assert!(
        coated
            .iter()
            .any(|(_, c)| c.metallic > 0.0 && c.metallic < 1.0)
    );
    assert!(f.smallest_alpha.unwrap() <= 1e-6 && f.environment && !f.transmission);
}

#[test]
fn transmission_test_uses_its_camera_and_dielectrics() {
    let s = load_default("TransmissionTest/glTF/TransmissionTest.gltf");
    assert_eq!(s.triangles.len(), 128_775);
    let transmissive = s
        .materials
        .iter()
        .filter(|m| m.surface.may_transmit())
        .count();
    assert_eq!(transmissive, 12);
    // The one untextured glass is tinted by its base colour.
    let yellow = material(&s, "YellowTrans");
    assert!(matches!(yellow.surface, Surface::Dielectric { tint, .. }
        if (tint - Vec3::new(0.8468738, 0.8713663, 0.09305903)).abs().max_element() < 1e-6));
    // The rough series takes its roughness per texel from the
    // metallic-roughness texture: smooth and rough tiles across the texture.
    let rough = material(&s, "YellowTransRough");
    let alphas: Vec<f32> = (0..256)
        .filter_map(|i| {
            let uv = glam::Vec2::new((i % 16) as f32 + 0.5, (i / 16) as f32 + 0.5) / 16.0;
            match rough.surface.bsdf(uv, &s.textures) {
                microfacet::Bsdf::Dielectric(d) => Some(d.model.alpha()),
                _ => None,
            }
        })
        .collect();
    assert_eq!(
        alphas.len(),
        256,
        "every texel of the rough series is glass"
    );
    let (lo, hi) = alphas
        .iter()
        .fold((f32::MAX, 0.0f32), |(l, h), &a| (l.min(a), h.max(a)));
    // (Before, every tile had the factor's roughness 1: alpha 1.)
    assert!(
        lo < 0.06 && hi > 0.2 && hi > 4.0 * lo,
        "alphas from {lo} to {hi}"
    );
    // render_camera: yfov 0.602 rad at 4:3.
    assert!((s.camera.vertical_fov - 0.602).abs() < 1e-3);
    assert_eq!(s.camera.resolution, UVec2::new(512, 384));
    let f = SceneFeatures::of(&s);
    assert!(f.transmission && f.textured && f.textures >= 1);
}
