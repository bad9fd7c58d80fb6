//! Environment maps in manifests and from `LoadOptions::environment`: the
//! bundled sky is the generator's, bad files and bad values are one-line
//! errors naming the file, and a scene has at most one environment.

use std::path::{Path, PathBuf};

use glam::Vec3;
use scene::{EnvironmentMap, EnvironmentOption, Light, LoadOptions};

/// Width and height of the bundled sky (`scenes/env-sphere/sky.hdr`).
const SKY_SIZE: (u32, u32) = (128, 64);

/// The bundled sky's radiance at texel centre (u, v) of the map (module
/// docs of `scene::environment`: v = 0 is up, u = 0 looks along -z): a
/// blue-to-white gradient above the horizon, a dim brown ground below it,
/// and a sun of angular radius 4 degrees, 35 degrees above the horizon at
/// u = 0.3 (towards +x, a little to +z).
fn sky_radiance(u: f32, v: f32) -> Vec3 {
    use std::f32::consts::PI;
    let elevation = (0.5 - v) * PI;
    let map = EnvironmentMap::constant(Vec3::ONE).unwrap();
    let d = map.direction((v * PI).cos(), u * 2.0 * PI);
    let sun = map.direction(35f32.to_radians().sin(), 0.3 * 2.0 * PI);
    if d.dot(sun) > 4f32.to_radians().cos() {
        return Vec3::new(900.0, 820.0, 700.0);
    }
    if elevation < 0.0 {
        return Vec3::new(0.22, 0.18, 0.14);
    }
    let t = (elevation / (0.5 * PI)).sqrt();
    Vec3::new(1.1, 1.15, 1.2).lerp(Vec3::new(0.25, 0.45, 1.0), t)
}

fn sky_texels() -> Vec<Vec3> {
    let (w, h) = SKY_SIZE;
    (0..h)
        .flat_map(|row| {
            (0..w).map(move |col| {
                sky_radiance((col as f32 + 0.5) / w as f32, (row as f32 + 0.5) / h as f32)
            })
        })
        .collect()
}

fn bundled_sky() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/env-sphere/sky.hdr")
}

/// The sky as Radiance RGBE bytes.
fn encode_hdr(texels: &[Vec3], (w, h): (u32, u32)) -> Vec<u8> {
    let pixels: Vec<image::Rgb<f32>> = texels.iter().map(|t| image::Rgb(t.to_array())).collect();
    let mut bytes = Vec::new();
    image::codecs::hdr::HdrEncoder::new(&mut bytes)
        .encode(&pixels, w as usize, h as usize)
        .unwrap();
    bytes
}

/// `scenes/env-sphere/sky.hdr` is what `sky_radiance` generates (run with
/// `RLT_WRITE_SKY=1` to rewrite it after changing the generator), and it
/// reads back within RGBE's precision (8-bit mantissa: 1/128 relative).
#[test]
fn bundled_sky_is_the_generated_one() {
    let bytes = encode_hdr(&sky_texels(), SKY_SIZE);
    if std::env::var_os("RLT_WRITE_SKY").is_some() {
        std::fs::write(bundled_sky(), &bytes).unwrap();
    }
    assert!(
        std::fs::read(bundled_sky()).unwrap() == bytes,
        "scenes/env-sphere/sky.hdr differs from the generator (RLT_WRITE_SKY=1 rewrites it)"
    );
    let map = EnvironmentMap::load(&bundled_sky(), 1.0, 0.0).unwrap();
    assert_eq!((map.width, map.height), SKY_SIZE);
    for (read, made) in map.texels.iter().zip(sky_texels()) {
        assert!(
            (*read - made).abs().max_element() <= made.max_element() / 128.0,
            "{read} vs {made}"
        );
    }
}

/// A temporary folder with `files` (name, bytes) and a `scene.toml` of a
/// floor quad and `lights`.
fn scene_with(name: &str, lights: &str, files: &[(&str, Vec<u8>)]) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("rlt-env-{name}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (file, bytes) in files {
        std::fs::write(dir.join(file), bytes).unwrap();
    }
    let manifest = format!(
        r#"
[camera]
from = [0, 1, 3]
at = [0, 0, 0]
fov = 40
[[material]]
name = "white"
type = "diffuse"
[[shape]]
type = "quad"
material = "white"
origin = [-1, 0, 1]
u = [2, 0, 0]
v = [0, 0, -2]
{lights}
"#
    );
    std::fs::write(dir.join("scene.toml"), manifest).unwrap();
    dir.join("scene.toml")
}

fn load(path: &Path) -> Result<scene::Scene, String> {
    scene::load(path, &LoadOptions::default()).map_err(|e| e.to_string())
}

fn small_hdr() -> Vec<u8> {
    encode_hdr(
        &[Vec3::new(1.0, 2.0, 3.0), Vec3::new(0.5, 0.5, 0.5)],
        (2, 1),
    )
}

#[test]
fn manifest_environment_maps_load_with_scale_and_rotation() {
    let path = scene_with(
        "ok",
        "[[light]]\ntype = \"environment\"\nfile = \"sky.hdr\"\nscale = 2\nrotation = 90",
        &[("sky.hdr", small_hdr())],
    );
    let scene = load(&path).unwrap();
    assert_eq!(scene.lights, vec![Light::EnvironmentMap { map: 0 }]);
    let map = &scene.environment_maps[0];
    assert_eq!((map.width, map.height, map.scale), (2, 1, 2.0));
    assert_eq!(map.rotation_degrees, 90.0);
    // Rotated by 90 degrees, the map's -z (u = 0, texel 0) looks along -x.
    assert_eq!(map.radiance(-Vec3::X), Vec3::new(2.0, 4.0, 6.0));
    assert_eq!(map.radiance(Vec3::X), Vec3::ONE);
    assert!(scene::SceneFeatures::of(&scene).environment_map);
}

/// A bad-entry case: name, the light's keys, files, expected message part.
type Case = (
    &'static str,
    &'static str,
    Vec<(&'static str, Vec<u8>)>,
    &'static str,
);

#[test]
fn bad_environment_entries_are_one_line_errors() {
    let cases: [Case; 6] = [
        (
            "missing",
            "file = \"nope.exr\"",
            vec![],
            "\"nope.exr\": no such file",
        ),
        (
            "garbage",
            "file = \"sky.exr\"",
            vec![("sky.exr", b"not an exr file".to_vec())],
            "sky.exr: cannot decode the environment map",
        ),
        (
            "extension",
            "file = \"sky.png\"",
            vec![("sky.png", small_hdr())],
            "expected .exr (OpenEXR) or .hdr",
        ),
        (
            "both",
            "file = \"sky.hdr\"\nintensity = [1, 1, 1]",
            vec![("sky.hdr", small_hdr())],
            "not both",
        ),
        (
            "scale",
            "file = \"sky.hdr\"\nscale = -1",
            vec![("sky.hdr", small_hdr())],
            "scale must be finite and >= 0",
        ),
        (
            "two",
            "file = \"sky.hdr\"\n[[light]]\ntype = \"environment\"\nintensity = [1, 1, 1]",
            vec![("sky.hdr", small_hdr())],
            "more than one environment light",
        ),
    ];
    for (name, keys, files, expected) in cases {
        let path = scene_with(
            name,
            &format!("[[light]]\ntype = \"environment\"\n{keys}"),
            &files,
        );
        let e = load(&path).unwrap_err();
        assert!(e.contains(expected), "{name}: {e}");
        assert!(!e.contains('\n'), "{name}: {e}");
    }
    let path = scene_with(
        "point-file",
        "[[light]]\ntype = \"point\"\nposition = [0, 1, 0]\nintensity = [1, 1, 1]\nfile = \"x.hdr\"",
        &[],
    );
    let e = load(&path).unwrap_err();
    assert!(
        e.contains("only an environment light takes a `file`"),
        "{e}"
    );
}

/// A NaN or negative texel is refused, naming the file and the texel.
#[test]
fn non_finite_texels_are_refused() {
    let dir = std::env::temp_dir().join(format!("rlt-env-nan-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for (name, bad) in [("nan.exr", f32::NAN), ("negative.exr", -1.0)] {
        let path = dir.join(name);
        let image = image::Rgb32FImage::from_fn(4, 2, |x, y| {
            image::Rgb(if (x, y) == (3, 1) {
                [1.0, bad, 1.0]
            } else {
                [1.0; 3]
            })
        });
        image
            .save_with_format(&path, image::ImageFormat::OpenExr)
            .unwrap();
        let e = EnvironmentMap::load(&path, 1.0, 0.0)
            .unwrap_err()
            .to_string();
        assert!(e.contains(name) && e.contains("texel (3, 1)"), "{e}");
    }
}

/// `--env` replaces a scene's environment, and a model file without lights
/// then gets no default white environment.
#[test]
fn environment_option_replaces_the_scenes_environment() {
    let path = scene_with(
        "option",
        "[[light]]\ntype = \"environment\"\nintensity = [1, 1, 1]",
        &[("sky.hdr", small_hdr())],
    );
    let options = LoadOptions {
        environment: Some(EnvironmentOption {
            file: path.with_file_name("sky.hdr"),
            scale: 0.5,
            rotation_degrees: 0.0,
        }),
        ..Default::default()
    };
    let scene = scene::load(&path, &options).unwrap();
    assert_eq!(scene.lights, vec![Light::EnvironmentMap { map: 0 }]);
    assert_eq!(scene.environment_maps[0].scale, 0.5);
    let obj = path.with_file_name("quad.obj");
    std::fs::write(&obj, "v 0 0 0\nv 1 0 0\nv 0 0 -1\nf 1 2 3\n").unwrap();
    let scene = scene::load(&obj, &options).unwrap();
    assert_eq!(scene.lights, vec![Light::EnvironmentMap { map: 0 }]);
    assert!(
        !scene
            .report
            .warnings
            .iter()
            .any(|w| w.contains("white environment")),
        "{:?}",
        scene.report.warnings
    );
}
