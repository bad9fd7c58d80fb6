//! The scene as a Mitsuba 3 scene: `scene.xml` and one binary PLY per
//! material, written from our world-space triangles.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

use glam::Vec3;
use microfacet::{Coated, Fresnel, MicrofacetModel, NdfKind, Shadowing};
use scene::{Light, Material, Scene, Surface};

use super::Options;

/// The exported Mitsuba scene.
pub(super) struct Exported {
    pub(super) xml: PathBuf,
    pub(super) summary: String,
}

/// Writes `scene` as a Mitsuba 3 scene into `dir`.
///
/// Mapping (checked against Mitsuba 3's `path`, `diffuse`, `twosided`,
/// `area` and `perspective` plugins):
/// - triangles: one binary PLY per material, world space, three vertices per
///   triangle in our order, so Mitsuba's face normal cross(p1-p0, p2-p0) is
///   our winding normal. Face normals (`face_normals=true`) unless the scene
///   has shading normals that differ from them; then they are written per
///   vertex.
/// - `Surface::Diffuse { reflectance }`: `twosided(diffuse(rgb reflectance))`.
///   Our lobes are two-sided, Mitsuba's `diffuse` is black from the back;
///   `twosided` makes it reflect on both sides as ours does.
/// - Materials (see [`bsdf_xml`]): the coated lobe as our `rlt_coated` plugin, conductors
///   as `principled` (Schlick) or `roughconductor` (complex index), dielectrics as
///   `roughdielectric`/`dielectric`; GGX with Smith shadowing only.
/// - emission: an `area` emitter with the same RGB radiance. Both emit on the
///   side of the (winding) normal only.
/// - camera: `perspective`, `lookat` origin/target/up, the vertical field of
///   view with `fov_axis="y"`, `box` reconstruction filter, `independent`
///   sampler with `--spp`.
/// - integrator: `path` with `max_depth` = ours (both count segments: 1 shows
///   emitters only) and `rr_depth` = 3 (both roll the dice after sampling the
///   direction at the third vertex). Differences left: Mitsuba's roulette
///   survival is capped at 0.95 (ours at 1) and its light choice is uniform
///   over emitting shapes; both are unbiased, so only the noise differs.
/// - analytic spheres: Mitsuba's `sphere` shape (centre, radius; with
///   `flip_normals` for an `inside` sphere), so both render the same
///   geometry; bsdf and emitter as for meshes. Mitsuba's sphere uv differ
///   from ours (textured materials are refused anyway).
/// - environment: see [`environment_xml`].
pub(super) fn export(scene: &Scene, options: &Options, dir: &Path) -> Result<Exported, String> {
    check_lights(scene)?;
    let mesh_dir = dir.join("meshes");
    fs::create_dir_all(&mesh_dir)
        .map_err(|e| format!("cannot create {}: {e}", mesh_dir.display()))?;
    let by_material = triangles_by_material(scene);
    let mut shapes = String::new();
    let (mut emitters, mut smooth_meshes) = (0, 0);
    for (&m, triangles) in &by_material {
        let mesh = write_mesh(scene, m, triangles, dir)?;
        shapes.push_str(&shape_xml(&mesh));
        emitters += usize::from(mesh.material.is_emissive());
        smooth_meshes += usize::from(mesh.smooth);
    }
    for sphere in &scene.spheres {
        shapes.push_str(&sphere_xml(scene, sphere)?);
        emitters += usize::from(scene.materials[sphere.material as usize].is_emissive());
    }
    shapes.push_str(&environment_xml(scene, dir)?);
    let xml_path = dir.join("scene.xml");
    crate::write_file(&xml_path, scene_xml(scene, options, &shapes))?;
    Ok(Exported {
        xml: xml_path,
        summary: format!(
            "{} meshes, {} spheres, {emitters} emitting, {}",
            by_material.len(),
            scene.spheres.len(),
            if smooth_meshes == 0 {
                "face normals".to_string()
            } else {
                format!("{smooth_meshes} with shading normals")
            }
        ),
    })
}

/// A shading normal whose cosine with the face normal is below this
/// differs from it (beyond the rounding of normals stored as f32), so the
/// mesh is written with per-vertex normals.
const FLAT_COSINE: f32 = 1.0 - 1e-5;

/// An error unless every light is an emissive triangle (Mitsuba's `area`)
/// or the environment (`constant`, `envmap`).
fn check_lights(scene: &Scene) -> Result<(), String> {
    match scene
        .lights
        .iter()
        .find(|l| !matches!(l, Light::Area { .. } | Light::Sphere { .. }) && !l.is_environment())
    {
        Some(light) => Err(format!(
            "the Mitsuba export handles emissive triangles and spheres and environments only; the scene has {light:?}"
        )),
        None => Ok(()),
    }
}

/// Triangle indices per material index, in material order.
fn triangles_by_material(scene: &Scene) -> BTreeMap<u32, Vec<usize>> {
    let mut by_material: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (i, &m) in scene.triangle_materials.iter().enumerate() {
        by_material.entry(m).or_default().push(i);
    }
    by_material
}

/// One material's triangles, written as a PLY file.
struct Mesh<'a> {
    material: &'a Material,
    /// The `<bsdf>` element, indented for its place in the `<shape>`.
    bsdf: String,
    /// The PLY's path relative to the scene folder.
    file: String,
    /// Whether the PLY has per-vertex (shading) normals.
    smooth: bool,
}

/// Writes the triangles of material `m` to `<dir>/meshes/`.
fn write_mesh<'a>(
    scene: &'a Scene,
    m: u32,
    triangles: &[usize],
    dir: &Path,
) -> Result<Mesh<'a>, String> {
    let material = &scene.materials[m as usize];
    let bsdf = bsdf_xml(material)?;
    let file = format!("meshes/{m:03}-{}.ply", sanitize(&material.name));
    let smooth = triangles.iter().any(|&t| {
        let n = scene.geometric_normal(t);
        scene
            .shading_normals(t, n)
            .iter()
            .any(|s| s.dot(n) < FLAT_COSINE)
    });
    let path = dir.join(&file);
    crate::write_file(&path, ply(scene, triangles, smooth))?;
    Ok(Mesh {
        material,
        bsdf,
        file,
        smooth,
    })
}

/// The `<shape>` of a mesh: its PLY file, its `<bsdf>`, and an `area`
/// emitter when the material emits.
fn shape_xml(mesh: &Mesh) -> String {
    let mut shape = String::new();
    let _ = writeln!(
        shape,
        r#"    <shape type="ply" id="{id}">
        <string name="filename" value="{file}"/>
        <boolean name="face_normals" value="{face}"/>
{bsdf}"#,
        id = sanitize(&mesh.material.name),
        file = mesh.file,
        face = !mesh.smooth,
        bsdf = mesh.bsdf,
    );
    if mesh.material.is_emissive() {
        let _ = writeln!(
            shape,
            r#"        <emitter type="area">
            <rgb name="radiance" value="{}"/>
        </emitter>"#,
            rgb(mesh.material.emission)
        );
    }
    shape.push_str("    </shape>\n");
    shape
}

/// The `<shape type="sphere">` of an analytic sphere, with its material's
/// `<bsdf>` and an `area` emitter when it emits.
fn sphere_xml(scene: &Scene, sphere: &scene::Sphere) -> Result<String, String> {
    let material = &scene.materials[sphere.material as usize];
    let c = sphere.center;
    let mut shape = format!(
        r#"    <shape type="sphere">
        <point name="center" x="{}" y="{}" z="{}"/>
        <float name="radius" value="{}"/>
        <boolean name="flip_normals" value="{}"/>
{}"#,
        c.x,
        c.y,
        c.z,
        sphere.radius,
        sphere.inside,
        bsdf_xml(material)?
    );
    if material.is_emissive() {
        let _ = writeln!(
            shape,
            r#"        <emitter type="area">
            <rgb name="radiance" value="{}"/>
        </emitter>"#,
            rgb(material.emission)
        );
    }
    shape.push_str("    </shape>\n");
    Ok(shape)
}

/// The `<bsdf>` of a material, or why it has none in Mitsuba 3.
///
/// - Diffuse: `twosided(diffuse)`.
/// - Coated: `twosided(rlt_coated)`, our lobe's formula as a Mitsuba plugin
///   (`xtask/scripts/rlt_coated.py`, registered by `mitsuba_pt.py`) with
///   base colour, metallic, specular factor and colour, ior and alpha, so
///   both renderers evaluate the same BSDF. No Mitsuba BSDF has this
///   formula: on the Cornell box with a rough (alpha 0.1) coated tall box at
///   256 spp, `principled` came out 1.0-1.4 % brighter over the whole image
///   (its base is Burley's diffuse, brighter at grazing angles and never
///   dimmed by the coat; its coat uses the exact dielectric Fresnel, ours
///   Schlick's as glTF does: equal at normal incidence, 27 % lower at 50-60
///   degrees, 5 % higher beyond 80), the plugin 0.04-0.06 % (within noise);
///   `roughplastic` models light refracted into the plastic and back (its
///   base is R / (eta^2 (1 - R F_dr,int)), 0.6 times ours for R = 0.5 at
///   eta 1.5) and has no metal. Smooth coats (a delta part) are refused.
/// - Conductor with Schlick F0: `twosided(principled)` with `metallic` 1:
///   principled's metal is the same Schlick Fresnel and GGX lobe.
/// - Conductor with a complex index: `twosided(roughconductor)` (or
///   `conductor` when smooth) with `eta`, `k`.
/// - Dielectric: `roughdielectric` (or `dielectric`) with `int_ior` = ior,
///   `ext_ior` 1, one-sided as ours (the index inside is behind the normal).
///
/// Non-GGX NDFs, V-cavity shadowing and textured surfaces are refused.
fn bsdf_xml(material: &Material) -> Result<String, String> {
    let refuse = |what: &str| {
        Err(format!(
            "the Mitsuba export cannot write `{}`: {what}",
            material.name
        ))
    };
    let ggx = |model: &MicrofacetModel| {
        if model.ndf.kind() == NdfKind::Ggx && model.shadowing == Shadowing::Smith {
            Ok(f64::from(model.alpha()))
        } else {
            Err(format!(
                "the Mitsuba export writes GGX with Smith shadowing only; `{}` has {:?}/{:?}",
                material.name,
                model.ndf.kind(),
                model.shadowing
            ))
        }
    };
    let twosided = |inner: String| {
        format!(
            "        <bsdf type=\"twosided\">\n{}        </bsdf>",
            inner
                .lines()
                .map(|l| format!("    {l}\n"))
                .collect::<String>()
        )
    };
    Ok(match material.surface {
        Surface::Diffuse { reflectance } => twosided(format!(
            "        <bsdf type=\"diffuse\">\n            <rgb name=\"reflectance\" value=\"{}\"/>\n        </bsdf>\n",
            rgb(reflectance)
        )),
        Surface::Coated(c) => {
            if c.model.is_smooth() {
                return refuse("smooth coats (a mirror part) are not exported");
            }
            twosided(rlt_coated(&c, ggx(&c.model)?))
        }
        Surface::Conductor {
            model,
            fresnel: Fresnel::Schlick { f0 },
        } => twosided(principled(f0, 1.0, ggx(&model)?, 1.5)),
        Surface::Conductor {
            model,
            fresnel: Fresnel::Conductor { eta, k, tint },
        } => {
            let alpha = ggx(&model)?;
            let (kind, rough) = if model.is_smooth() {
                ("conductor", String::new())
            } else {
                ("roughconductor", rough_params(alpha))
            };
            twosided(format!(
                "        <bsdf type=\"{kind}\">\n{rough}            <rgb name=\"eta\" value=\"{}\"/>\n            <rgb name=\"k\" value=\"{}\"/>\n            <rgb name=\"specular_reflectance\" value=\"{}\"/>\n        </bsdf>\n",
                rgb(eta),
                rgb(k),
                rgb(tint)
            ))
        }
        Surface::Dielectric { model, ior, tint } => {
            if material.medium.is_some() {
                return refuse("absorbing media (KHR_materials_volume) are not exported");
            }
            let alpha = ggx(&model)?;
            let (kind, rough) = if model.is_smooth() {
                ("dielectric", String::new())
            } else {
                ("roughdielectric", rough_params(alpha))
            };
            format!(
                "        <bsdf type=\"{kind}\">\n{rough}            <float name=\"int_ior\" value=\"{ior:?}\"/>\n            <float name=\"ext_ior\" value=\"1.0\"/>\n            <rgb name=\"specular_transmittance\" value=\"{}\"/>\n        </bsdf>",
                rgb(tint)
            )
        }
        Surface::ThinDielectric { ior, tint } => format!(
            "        <bsdf type=\"thindielectric\">\n            <float name=\"int_ior\" value=\"{ior:?}\"/>\n            <float name=\"ext_ior\" value=\"1.0\"/>\n            <rgb name=\"specular_transmittance\" value=\"{}\"/>\n        </bsdf>",
            rgb(tint)
        ),
        Surface::Textured(_) => return refuse("textured surfaces are not exported"),
    })
}

/// A `principled` element: GGX of width `alpha` (Mitsuba's roughness is
/// sqrt(alpha)), no sheen, clearcoat, tint or transmission.
fn principled(base: Vec3, metallic: f32, alpha: f64, eta: f64) -> String {
    format!(
        "        <bsdf type=\"principled\">\n            <rgb name=\"base_color\" value=\"{}\"/>\n            <float name=\"metallic\" value=\"{metallic:?}\"/>\n            <float name=\"roughness\" value=\"{:?}\"/>\n            <float name=\"eta\" value=\"{eta:?}\"/>\n        </bsdf>\n",
        rgb(base),
        alpha.sqrt()
    )
}

/// `distribution` and `alpha` of Mitsuba's rough conductor and dielectric.
fn rough_params(alpha: f64) -> String {
    format!(
        "            <string name=\"distribution\" value=\"ggx\"/>\n            <float name=\"alpha\" value=\"{alpha:?}\"/>\n"
    )
}

/// A `rlt_coated` element (`xtask/scripts/rlt_coated.py`): our coated lobe.
fn rlt_coated(c: &Coated, alpha: f64) -> String {
    format!(
        "        <bsdf type=\"rlt_coated\">\n            <rgb name=\"base_color\" value=\"{}\"/>\n            <float name=\"metallic\" value=\"{:?}\"/>\n            <float name=\"specular\" value=\"{:?}\"/>\n            <rgb name=\"specular_color\" value=\"{}\"/>\n            <float name=\"ior\" value=\"{:?}\"/>\n            <float name=\"alpha\" value=\"{alpha:?}\"/>\n        </bsdf>\n",
        rgb(c.base_color),
        c.metallic,
        c.specular,
        rgb(c.specular_color),
        c.ior,
    )
}

/// The whole `scene.xml`: integrator, camera and film, then `shapes`.
fn scene_xml(scene: &Scene, options: &Options, shapes: &str) -> String {
    let c = &scene.camera;
    let target = c.position + c.forward;
    format!(
        r#"<?xml version="1.0" encoding="utf-8"?>
<!-- Written by `cargo xtask mitsuba` from {source}; mapping in xtask/src/mitsuba/export.rs. -->
<scene version="3.0.0">
    <default name="sampler" value="independent"/>
    <integrator type="path">
        <integer name="max_depth" value="{max_depth}"/>
        <integer name="rr_depth" value="3"/>
    </integrator>
    <sensor type="perspective">
        <string name="fov_axis" value="y"/>
        <float name="fov" value="{fov:?}"/>
        <float name="near_clip" value="0.001"/>
        <float name="far_clip" value="100000"/>
        <transform name="to_world">
            <lookat origin="{origin}" target="{target}" up="{up}"/>
        </transform>
        <sampler type="$sampler">
            <integer name="sample_count" value="{spp}"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="{width}"/>
            <integer name="height" value="{height}"/>
            <string name="pixel_format" value="rgb"/>
            <string name="component_format" value="float32"/>
            <rfilter type="box"/>
        </film>
    </sensor>
{shapes}</scene>
"#,
        source = options.scene.display(),
        max_depth = options.max_depth,
        fov = f64::from(c.vertical_fov).to_degrees(),
        origin = rgb(c.position),
        target = rgb(target),
        up = rgb(c.up),
        spp = options.spp,
        width = c.resolution.x,
        height = c.resolution.y,
    )
}

/// A binary little-endian PLY of `triangles` (three vertices each).
fn ply(scene: &Scene, triangles: &[usize], normals: bool) -> Vec<u8> {
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        3 * triangles.len()
    );
    if normals {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    let _ = write!(
        header,
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        triangles.len()
    );
    let mut bytes = header.into_bytes();
    for &t in triangles {
        for k in 0..3 {
            let mut values = scene.triangle(t)[k].to_array().to_vec();
            if normals {
                values.extend(scene.shading_normals(t, scene.geometric_normal(t))[k].to_array());
            }
            for v in values {
                bytes.extend(v.to_le_bytes());
            }
        }
    }
    for i in 0..triangles.len() as i32 {
        bytes.push(3);
        for k in 0..3 {
            bytes.extend((3 * i + k).to_le_bytes());
        }
    }
    bytes
}

/// The scene's environment as a Mitsuba emitter, or nothing.
///
/// - `Light::Environment { radiance }`: `constant` with the same RGB
///   radiance.
/// - `Light::EnvironmentMap`: `envmap` of `envmap.exr` next to `scene.xml`:
///   our texels, each repeated [`ENVMAP_UPSAMPLING`] x [`ENVMAP_UPSAMPLING`]
///   times, the same `scale`, and `to_world` = a rotation about +y by our
///   `rotation` in degrees.
///   Orientation: our map convention is Mitsuba 3's (`scene::environment`
///   module docs: +y up, the image's top row up, u = 0 looking along -z,
///   u = 1/4 along +x; Mitsuba's `envmap.cpp` maps a local direction to
///   (atan2(x, -z) / 2 pi, acos(y) / pi)), and both rotate right-handed
///   about +y (`R_y(angle)` takes the map's frame to the world), so no
///   other transform is needed. What differs: Mitsuba interpolates texels
///   bilinearly, with texel row r at v = r / (height - 1) and column c at
///   u = (c + 1/2) / width, where we look up the nearest texel with row r
///   covering v in [r, r + 1) / height. On `env-sphere` (a 128x64 sky with
///   a sun) a copy of the file made Mitsuba's image 1.1-1.3 % brighter than
///   ours at 256 spp; the upsampled texels make its bilinear function the
///   same as our nearest-texel one except within 1/16 texel of texel edges,
///   and the image means agree to 0.08-0.09 % (within noise).
fn environment_xml(scene: &Scene, dir: &Path) -> Result<String, String> {
    let Some(light) = scene.lights.iter().find(|l| l.is_environment()) else {
        return Ok(String::new());
    };
    match *light {
        Light::Environment { radiance } => Ok(format!(
            "    <emitter type=\"constant\">\n        <rgb name=\"radiance\" value=\"{}\"/>\n    </emitter>\n",
            rgb(radiance)
        )),
        Light::EnvironmentMap { map } => {
            let map = &scene.environment_maps[map as usize];
            let file = "envmap.exr";
            let (width, height, texels) = upsampled(map, ENVMAP_UPSAMPLING);
            crate::write_exr(&dir.join(file), width, height, &texels)?;
            Ok(format!(
                r#"    <emitter type="envmap">
        <string name="filename" value="{file}"/>
        <float name="scale" value="{scale:?}"/>
        <transform name="to_world">
            <rotate y="1" angle="{angle:?}"/>
        </transform>
    </emitter>
"#,
                scale = map.scale,
                angle = map.rotation_degrees,
            ))
        }
        _ => Ok(String::new()),
    }
}

/// How many times each texel of an environment map is repeated along each
/// axis for Mitsuba (see [`environment_xml`]).
const ENVMAP_UPSAMPLING: u32 = 8;

/// `map`'s texels (before its scale), each repeated `k` x `k` times.
fn upsampled(map: &scene::EnvironmentMap, k: u32) -> (u32, u32, Vec<Vec3>) {
    let (width, height) = (map.width * k, map.height * k);
    let texels = (0..height)
        .flat_map(|y| (0..width).map(move |x| (x / k, y / k)))
        .map(|(x, y)| map.texels[(y * map.width + x) as usize])
        .collect();
    (width, height, texels)
}

fn rgb(v: Vec3) -> String {
    format!("{:?}, {:?}, {:?}", v.x, v.y, v.z)
}

fn sanitize(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if s.is_empty() { "material".into() } else { s }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::UVec2;
    use scene::LoadOptions;

    #[test]
    fn materials_map_to_mitsuba_bsdfs() {
        let material = |surface| Material::new("m".into(), surface, Vec3::ZERO);
        let model = MicrofacetModel::new(NdfKind::Ggx, 0.25, Shadowing::Smith);
        let coated = Coated {
            model,
            base_color: Vec3::new(0.5, 0.25, 1.0),
            metallic: 0.5,
            specular: 1.0,
            specular_color: Vec3::ONE,
            ior: 1.5,
        };
        let xml = bsdf_xml(&material(Surface::Coated(coated))).unwrap();
        assert!(xml.starts_with("        <bsdf type=\"twosided\">"), "{xml}");
        for part in [
            "<bsdf type=\"rlt_coated\">",
            "<rgb name=\"base_color\" value=\"0.5, 0.25, 1.0\"/>",
            "<float name=\"metallic\" value=\"0.5\"/>",
            "<float name=\"ior\" value=\"1.5\"/>",
            "<float name=\"alpha\" value=\"0.25\"/>",
        ] {
            assert!(xml.contains(part), "{part} missing from {xml}");
        }
        let glass = bsdf_xml(&material(Surface::Dielectric {
            model,
            ior: 1.33,
            tint: Vec3::ONE,
        }))
        .unwrap();
        assert!(
            glass.contains("roughdielectric")
                && glass.contains("\"1.33\"")
                && !glass.contains("twosided")
        );
        let beckmann = MicrofacetModel::new(NdfKind::Beckmann, 0.25, Shadowing::Smith);
        assert!(
            bsdf_xml(&material(Surface::Coated(Coated {
                model: beckmann,
                ..coated
            })))
            .is_err()
        );
    }

    #[test]
    fn ply_is_well_formed() {
        let scene = scene::load(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/scene.toml"),
            &LoadOptions {
                resolution: Some(UVec2::new(8, 8)),
                ..Default::default()
            },
        )
        .unwrap();
        let bytes = ply(&scene, &[0, 1], false);
        let header_end = bytes
            .windows(11)
            .position(|w| w == b"end_header\n")
            .unwrap()
            + 11;
        // 6 vertices x 3 floats, then 2 faces x (1 + 3 x 4) bytes.
        assert_eq!(bytes.len() - header_end, 6 * 12 + 2 * 13);
    }

    /// The env-sphere map becomes an `envmap` of its texels, upsampled, with
    /// its scale and rotation about +y.
    #[test]
    fn environment_map_exports_as_envmap() {
        let mut scene = scene::load(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/env-sphere/scene.toml"),
            &LoadOptions {
                resolution: Some(UVec2::new(8, 8)),
                ..Default::default()
            },
        )
        .unwrap();
        scene.environment_maps[0].scale = 2.5;
        let dir = std::env::temp_dir().join(format!("xtask-mitsuba-env-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let xml = environment_xml(&scene, &dir).unwrap();
        assert!(xml.contains(r#"<emitter type="envmap">"#), "{xml}");
        assert!(xml.contains(r#"<string name="filename" value="envmap.exr"/>"#));
        assert!(xml.contains(r#"<float name="scale" value="2.5"/>"#));
        assert!(xml.contains(r#"<rotate y="1" angle="0.0"/>"#));
        let map = &scene.environment_maps[0];
        let (w, h, texels) = upsampled(map, 3);
        assert_eq!((w, h), (3 * map.width, 3 * map.height));
        assert_eq!(
            texels[(4 * w + 5) as usize],
            map.texels[(map.width + 1) as usize]
        );
        assert!(dir.join("envmap.exr").is_file());
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn export_writes_one_ply_per_material_and_the_scene_xml() {
        let options = crate::mitsuba::test_options(&["--resolution", "8x8", "--spp", "4"]);
        let scene = scene::load(
            &options.scene,
            &LoadOptions {
                resolution: Some(UVec2::new(8, 8)),
                ..Default::default()
            },
        )
        .unwrap();
        let dir = std::env::temp_dir().join(format!("xtask-mitsuba-export-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        let exported = export(&scene, &options, &dir).unwrap();
        let xml = fs::read_to_string(&exported.xml).unwrap();
        let meshes = triangles_by_material(&scene).len();
        assert_eq!(fs::read_dir(dir.join("meshes")).unwrap().count(), meshes);
        assert_eq!(xml.matches("<shape type=\"ply\"").count(), meshes);
        assert!(xml.contains(r#"<integer name="sample_count" value="4"/>"#));
        assert!(xml.contains(r#"<integer name="width" value="8"/>"#));
        assert!(xml.contains("<emitter type=\"area\">"));
        assert!(exported.summary.starts_with(&format!("{meshes} meshes, ")));
        if std::env::var_os("XTASK_KEEP_EXPORT").is_none() {
            fs::remove_dir_all(dir).unwrap();
        }
    }

    /// An analytic sphere becomes a Mitsuba `sphere` with its centre,
    /// radius, orientation, bsdf and emitter.
    #[test]
    fn spheres_export_as_mitsuba_spheres() {
        let dir =
            std::env::temp_dir().join(format!("xtask-mitsuba-spheres-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("scene.toml");
        fs::write(
            &path,
            "[[material]]\nname = \"ball\"\ntype = \"diffuse\"\n\n\
             [[material]]\nname = \"lamp\"\ntype = \"diffuse\"\nemission = [1, 1, 1]\n\n\
             [[shape]]\ntype = \"sphere\"\nmaterial = \"ball\"\ncenter = [1, -2, 0.5]\nradius = 0.25\n\n\
             [[shape]]\ntype = \"sphere\"\nmaterial = \"lamp\"\ncenter = [0, 0, 0]\nradius = 9\ninside = true\n",
        )
        .unwrap();
        let scene = scene::load(&path, &LoadOptions::default()).unwrap();
        fs::remove_dir_all(&dir).unwrap();
        let xml = sphere_xml(&scene, &scene.spheres[0]).unwrap();
        assert!(
            xml.contains(r#"<point name="center" x="1" y="-2" z="0.5"/>"#),
            "{xml}"
        );
        assert!(xml.contains(r#"<float name="radius" value="0.25"/>"#));
        assert!(xml.contains(r#"<boolean name="flip_normals" value="false"/>"#));
        assert!(xml.contains("diffuse") && !xml.contains("emitter"));
        let xml = sphere_xml(&scene, &scene.spheres[1]).unwrap();
        assert!(xml.contains(r#"<boolean name="flip_normals" value="true"/>"#));
        assert!(xml.contains("<emitter type=\"area\">"));
        assert!(check_lights(&scene).is_ok());
    }
}
