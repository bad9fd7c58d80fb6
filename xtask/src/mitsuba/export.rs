//! The scene as a Mitsuba 3 scene: `scene.xml` and one binary PLY per
//! material, written from our world-space triangles.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

use glam::Vec3;
use scene::{Light, Scene, Surface};

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
pub(super) fn export(scene: &Scene, options: &Options, dir: &Path) -> Result<Exported, String> {
    if let Some(light) = scene
        .lights
        .iter()
        .find(|l| !matches!(l, Light::Area { .. }))
    {
        return Err(format!(
            "the Mitsuba export handles emissive triangles only; the scene has {light:?}"
        ));
    }
    let mesh_dir = dir.join("meshes");
    fs::create_dir_all(&mesh_dir)
        .map_err(|e| format!("cannot create {}: {e}", mesh_dir.display()))?;
    let mut by_material: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (i, &m) in scene.triangle_materials.iter().enumerate() {
        by_material.entry(m).or_default().push(i);
    }
    let mut shapes = String::new();
    let (mut emitters, mut smooth_meshes) = (0, 0);
    for (&m, triangles) in &by_material {
        let material = &scene.materials[m as usize];
        let Surface::Diffuse { reflectance } = material.surface else {
            return Err(format!(
                "the Mitsuba export handles diffuse materials only; `{}` is {:?}",
                material.name, material.surface
            ));
        };
        let file = format!("meshes/{m:03}-{}.ply", sanitize(&material.name));
        let smooth = triangles.iter().any(|&t| {
            let n = scene.geometric_normal(t);
            scene.normals[t].iter().any(|s| s.dot(n) < 1.0 - 1e-5)
        });
        smooth_meshes += usize::from(smooth);
        let ply = ply(scene, triangles, smooth);
        let path = dir.join(&file);
        fs::write(&path, &ply).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        let _ = writeln!(
            shapes,
            r#"    <shape type="ply" id="{id}">
        <string name="filename" value="{file}"/>
        <boolean name="face_normals" value="{face}"/>
        <bsdf type="twosided">
            <bsdf type="diffuse">
                <rgb name="reflectance" value="{r}"/>
            </bsdf>
        </bsdf>"#,
            id = sanitize(&material.name),
            face = !smooth,
            r = rgb(reflectance),
        );
        if material.is_emissive() {
            emitters += 1;
            let _ = writeln!(
                shapes,
                r#"        <emitter type="area">
            <rgb name="radiance" value="{}"/>
        </emitter>"#,
                rgb(material.emission)
            );
        }
        shapes.push_str("    </shape>\n");
    }
    let c = &scene.camera;
    let target = c.position + c.forward;
    let xml = format!(
        r#"<?xml version="1.0" encoding="utf-8"?>
<!-- Written by `cargo xtask mitsuba` from {source}; mapping in xtask/src/mitsuba/export.rs. -->
<scene version="3.0.0">
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
        <sampler type="independent">
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
    );
    let xml_path = dir.join("scene.xml");
    fs::write(&xml_path, &xml).map_err(|e| format!("cannot write {}: {e}", xml_path.display()))?;
    Ok(Exported {
        xml: xml_path,
        summary: format!(
            "{} meshes, {emitters} emitting, {}",
            by_material.len(),
            if smooth_meshes == 0 {
                "face normals".to_string()
            } else {
                format!("{smooth_meshes} with shading normals")
            }
        ),
    })
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
            let mut values = scene.triangles[t][k].to_array().to_vec();
            if normals {
                values.extend(scene.normals[t][k].to_array());
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
    fn ply_is_well_formed() {
        let scene = scene::load(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/scene.toml"),
            &LoadOptions {
                camera_name: None,
                resolution: Some(UVec2::new(8, 8)),
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
}
