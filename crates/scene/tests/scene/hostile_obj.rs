//! Hostile OBJ/MTL and scene.toml input: each failure class gets a small
//! generated file and must give one short line naming the file and element
//! (ARCHITECTURE.md, "Input rules"); random token edits of a valid scene
//! never panic, and every scene that loads is finite.

use std::path::PathBuf;
use std::sync::atomic::{AtomicUsize, Ordering};

use proptest::prelude::*;
use proptest::test_runner::{Config, RngSeed};
use scene::{Light, LoadOptions, Scene, SceneError, Surface, load};

/// A fresh directory under the system's temporary folder.
fn scratch_dir() -> PathBuf {
    static COUNTER: AtomicUsize = AtomicUsize::new(0);
    let n = COUNTER.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("scene-hostile-obj-{}-{n}", std::process::id()));
    std::fs::create_dir_all(&dir).expect("temporary directory");
    dir
}

/// Writes `files` (path under a fresh folder `scene/`, content) and loads the
/// first; returns the result and the folder (removed by the caller).
fn load_in(files: &[(&str, &[u8])], options: &LoadOptions) -> (Result<Scene, SceneError>, PathBuf) {
    let dir = scratch_dir();
    for (name, content) in files {
        let path = dir.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, content).expect("write test file");
    }
    (load(&dir.join(files[0].0), options), dir)
}

/// The error of loading `files`, checked to be one short line naming the
/// file and every string of `names`.
fn refused(files: &[(&str, &[u8])], names: &[&str]) -> String {
    let (result, dir) = load_in(files, &LoadOptions::default());
    let _ = std::fs::remove_dir_all(&dir);
    let message = match result {
        Ok(_) => panic!("{}: loaded without error", files[0].0),
        Err(e) => e.to_string(),
    };
    assert!(!message.contains('\n'), "not one line: {message}");
    // ~200 characters of message plus the path(s) it names.
    let path_len = dir.display().to_string().len() + 40;
    assert!(
        message.len() <= 200 + 2 * path_len,
        "too long ({}): {}",
        message.len(),
        &message[..300.min(message.len())]
    );
    for name in names {
        assert!(message.contains(name), "'{name}' missing from: {message}");
    }
    message
}

const TRIANGLE: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

fn obj_with_mtl(mtl: &str) -> [(&'static str, Vec<u8>); 2] {
    [
        (
            "a.obj",
            format!("mtllib a.mtl\n{TRIANGLE}")
                .replace("f 1 2 3", "usemtl m\nf 1 2 3")
                .into_bytes(),
        ),
        ("a.mtl", mtl.as_bytes().to_vec()),
    ]
}

fn borrowed<'a>(files: &'a [(&'static str, Vec<u8>)]) -> Vec<(&'static str, &'a [u8])> {
    files.iter().map(|(n, c)| (*n, c.as_slice())).collect()
}

#[test]
fn manifest_resolution_has_the_flags_limit() {
    let toml =
        "resolution = [65536, 65536]\n[[light]]\ntype = \"environment\"\nintensity = [1, 1, 1]\n";
    refused(
        &[("scene.toml", toml.as_bytes())],
        &["scene.toml", "resolution", "16384"],
    );
}

#[test]
fn a_light_whose_power_overflows_is_refused() {
    let toml = "[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[shape]]\ntype = \"quad\"\nmaterial = \"m\"\norigin = [0, 0, 0]\nu = [1, 0, 0]\nv = [0, 1, 0]\n[[light]]\ntype = \"point\"\nposition = [0, 1, 1]\nintensity = [3e38, 3e38, 3e38]\n";
    refused(
        &[("scene.toml", toml.as_bytes())],
        &["scene.toml", "light 1 (point)", "intensity"],
    );
    // The same through an MTL emission (an area light).
    let files = obj_with_mtl("newmtl m\nKe 3e38 3e38 3e38\n");
    refused(&borrowed(&files), &["a.obj", "material \"m\"", "emission"]);
}

#[test]
fn a_camera_name_with_an_obj_model_is_refused() {
    let toml = "[[model]]\nfile = \"a.obj\"\n[camera]\nname = \"nosuch\"\n";
    refused(
        &[
            ("scene.toml", toml.as_bytes()),
            ("a.obj", TRIANGLE.as_bytes()),
        ],
        &["scene.toml", "[camera] name", "nosuch"],
    );
}

#[test]
fn mtl_nan_and_out_of_range_values_name_file_material_and_line() {
    for (mtl, key) in [
        ("newmtl m\nKd 1 1 1\nNs nan\n", "Ns"),
        ("newmtl m\nKd 1 1 1\nd nan\n", "d"),
        ("newmtl m\nKd 1 1 1\nd 1.5\n", "d"),
        ("newmtl m\nKd 1 1 1\nNi inf\n", "Ni"),
        ("newmtl m\nKd 1 1 1\nPr -1\n", "Pr"),
    ] {
        let files = obj_with_mtl(mtl);
        refused(
            &borrowed(&files),
            &["a.mtl", "material \"m\"", "line 3", key],
        );
    }
    // A colour with fewer than three numbers (tobj panics on it).
    let files = obj_with_mtl("newmtl m\nKd 1 1\n");
    refused(
        &borrowed(&files),
        &["a.mtl", "material \"m\", line 2", "Kd"],
    );
    // A glass with Ni 0: the MTL file, the material and its line.
    let files = obj_with_mtl("# glass\nnewmtl m\nillum 7\nNi 0\n");
    refused(
        &borrowed(&files),
        &["a.mtl", "material \"m\" (line 2)", "Ni"],
    );
}

/// Kd + Ks is the coated lobe: base Kd, a coat whose F0 is Ks, the
/// Blinn-Phong alpha of Ns (supp. eq. 5); Ks above Kd stays a coat over
/// the base, not a grey metal (issue 18).
#[test]
fn mtl_kd_and_ks_become_a_coat_over_the_base() {
    for (kd, ks) in [
        ([0.6, 0.6, 0.6], [0.3, 0.3, 0.3]),
        ([0.0, 0.4, 0.4], [0.5, 0.5, 0.5]),
    ] {
        let mtl = format!(
            "newmtl m\nKd {} {} {}\nKs {} {} {}\nNs 98\n",
            kd[0], kd[1], kd[2], ks[0], ks[1], ks[2]
        );
        let files = obj_with_mtl(&mtl);
        let (result, dir) = load_in(&borrowed(&files), &LoadOptions::default());
        let _ = std::fs::remove_dir_all(&dir);
        let scene = result.unwrap();
        let Surface::Coated(c) = scene.materials[0].surface else {
            panic!("{:?}", scene.materials[0].surface)
        };
        assert_eq!(c.base_color, glam::Vec3::from_array(kd));
        assert_eq!(c.metallic, 0.0);
        assert!(
            (c.dielectric_f0() * c.specular - glam::Vec3::from_array(ks))
                .abs()
                .max_element()
                < 1e-6
        );
        assert_eq!(c.model.ndf.kind(), microfacet::NdfKind::BlinnPhong);
        assert!((c.model.alpha() - (2.0f32 / 100.0).sqrt()).abs() < 1e-6);
    }
}

/// A 1x1 PNG of one RGB colour.
fn png(rgb: [u8; 3]) -> Vec<u8> {
    let mut bytes = std::io::Cursor::new(Vec::new());
    image::RgbImage::from_pixel(1, 1, image::Rgb(rgb))
        .write_to(&mut bytes, image::ImageFormat::Png)
        .unwrap();
    bytes.into_inner()
}

/// `map_Ks` multiplies Ks (sRGB) and `map_Ns` multiplies Ns (linear) per
/// texel; on a material without Ks they are ignored with a warning.
#[test]
fn mtl_map_ks_and_map_ns_texture_the_coat() {
    let [obj, mtl] = obj_with_mtl(
        "newmtl m\nKd 0.5 0.5 0.5\nKs 0.4 0.4 0.4\nNs 198\nmap_Ks ks.png\nmap_Ns ns.png\n",
    );
    // sRGB 188 is 0.5 linear; 128 linear is 0.502 (Ns 198 -> 99.4).
    let (ks, ns) = (png([255, 188, 0]), png([128, 128, 128]));
    let files = [obj, mtl, ("ks.png", ks), ("ns.png", ns)];
    let (result, dir) = load_in(&borrowed(&files), &LoadOptions::default());
    let _ = std::fs::remove_dir_all(&dir);
    let scene = result.unwrap();
    let uv = glam::Vec2::splat(0.5);
    let microfacet::Bsdf::Coated(c) = scene.materials[0].surface.bsdf(uv, &scene.textures) else {
        panic!("{:?}", scene.materials[0].surface)
    };
    let f0 = c.dielectric_f0() * c.specular;
    assert!(
        (f0 - glam::Vec3::new(0.4, 0.2, 0.0)).abs().max_element() < 2e-3,
        "{f0}"
    );
    let ns = 198.0 * 128.0 / 255.0;
    let alpha = (2.0f32 / (ns + 2.0)).sqrt();
    assert!(
        (c.model.alpha() - alpha).abs() < 1e-4,
        "{}",
        c.model.alpha()
    );

    let [obj, mtl] = obj_with_mtl("newmtl m\nKd 0.5 0.5 0.5\nmap_Ks ks.png\n");
    let files = [obj, mtl, ("ks.png", png([255, 255, 255]))];
    let (result, dir) = load_in(&borrowed(&files), &LoadOptions::default());
    let _ = std::fs::remove_dir_all(&dir);
    let scene = result.unwrap();
    assert!(matches!(
        scene.materials[0].surface,
        Surface::Diffuse { .. }
    ));
    assert!(
        scene
            .report
            .warnings
            .iter()
            .any(|w| w.contains("map_Ks") && w.contains("ignored")),
        "{:?}",
        scene.report.warnings
    );
}

#[test]
fn empty_files_are_errors_unless_allowed() {
    refused(
        &[("empty.obj", b"")],
        &["empty.obj", "no geometry", "--allow-empty"],
    );
    refused(&[("scene.toml", b"")], &["scene.toml", "no geometry"]);
    let (result, dir) = load_in(
        &[("empty.obj", b"")],
        &LoadOptions {
            allow_empty: true,
            ..Default::default()
        },
    );
    let _ = std::fs::remove_dir_all(dir);
    let scene = result.unwrap();
    assert!(
        scene
            .report
            .warnings
            .iter()
            .any(|w| w.contains("no geometry"))
    );
    // Geometry but no light and no environment.
    let toml = "[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[shape]]\ntype = \"quad\"\nmaterial = \"m\"\norigin = [0, 0, 0]\nu = [1, 0, 0]\nv = [0, 1, 0]\n";
    refused(
        &[("scene.toml", toml.as_bytes())],
        &["scene.toml", "no light"],
    );
}

#[test]
fn a_huge_token_is_quoted_short() {
    let token = "x".repeat(20_000_000);
    let obj = format!("v 0 0 {token}\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let message = refused(
        &[("big.obj", obj.as_bytes())],
        &["big.obj", "line 1", "(20000000 characters)"],
    );
    assert!(message.len() < 400, "{message}");
    let obj = format!("{TRIANGLE}f 1 2 {token}\n");
    refused(
        &[("big.obj", obj.as_bytes())],
        &["big.obj", "line 5", "characters)"],
    );
}

#[test]
fn a_referenced_folder_is_called_a_folder() {
    let (result, dir) = load_in(
        &[
            ("a.obj", format!("mtllib lib\n{TRIANGLE}").as_bytes()),
            ("lib/x.txt", b""),
        ],
        &LoadOptions::default(),
    );
    let _ = std::fs::remove_dir_all(dir);
    let message = result.unwrap_err().to_string();
    assert!(
        message.contains("mtllib") && message.contains("is a folder"),
        "{message}"
    );
    let toml = "[[model]]\nfile = \"models\"\n";
    let (result, dir) = load_in(
        &[("scene.toml", toml.as_bytes()), ("models/x.obj", b"")],
        &LoadOptions::default(),
    );
    let _ = std::fs::remove_dir_all(dir);
    let message = result.unwrap_err().to_string();
    assert!(message.contains("is a folder"), "{message}");
}

#[test]
fn face_indices_out_of_range_name_their_line() {
    for (face, what) in [
        ("f 1 2 9", "vertex index 9"),
        ("f 1 2 0", "vertex index 0"),
        ("f 1 2 -4", "vertex index -4"),
        ("f 1 2 -9223372036854775808", "vertex index"),
        ("f 1/5 2/1 3/1", "texture coordinate index 5"),
        ("f 1//2 2//1 3//1", "normal index 2"),
        ("f 1/1/1/1 2 3", "more than three"),
    ] {
        let obj = format!("v 0 0 0\nv 1 0 0\nv 0 1 0\nvt 0 0\nvn 0 0 1\n# comment\n{face}\n");
        refused(&[("i.obj", obj.as_bytes())], &["i.obj", "line 7", what]);
    }
}

#[test]
fn references_outside_the_scene_folder_are_refused() {
    let obj = format!("mtllib ../../../../etc/passwd\n{TRIANGLE}");
    refused(
        &[("a.obj", obj.as_bytes())],
        &["a.obj", "mtllib", "outside", "--allow-outside-paths"],
    );
    let files = obj_with_mtl("newmtl m\nKd 1 1 1\nmap_Kd ../../../../etc/passwd\n");
    refused(&borrowed(&files), &["a.mtl", "map_Kd", "outside"]);
}

#[test]
fn nan_normals_and_uvs_are_refused() {
    // check_lines refuses them by line in OBJ; the builder refuses them for every format.
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nvn 0 0 nan\nf 1//1 2//1 3//1\n";
    refused(&[("n.obj", obj.as_bytes())], &["n.obj", "line 4", "finite"]);
}

/// Every number of `scene` is finite.
fn assert_finite(scene: &Scene) {
    for v in scene.positions.iter().chain(&scene.normals) {
        assert!(v.is_finite(), "{v:?}");
    }
    assert!(scene.uvs.iter().all(|uv| uv.is_finite()));
    for m in &scene.materials {
        assert!(m.emission.is_finite(), "{m:?}");
        match m.surface {
            Surface::Diffuse { reflectance } => assert!(reflectance.is_finite()),
            Surface::Dielectric { ior, model, .. } => {
                assert!(ior.is_finite() && ior > 0.0 && model.alpha().is_finite())
            }
            Surface::Conductor { model, .. } => assert!(model.alpha().is_finite()),
            Surface::Coated(c) => assert!(
                c.model.alpha().is_finite()
                    && c.base_color.is_finite()
                    && c.specular_color.is_finite()
                    && c.ior.is_finite()
            ),
            Surface::Textured(p) => assert!(p.base_color.is_finite() && p.roughness.is_finite()),
            Surface::ThinDielectric { ior, tint } => assert!(ior > 0.0 && tint.is_finite()),
        }
    }
    for l in &scene.lights {
        let ok = match *l {
            Light::Point {
                position,
                intensity,
            } => position.is_finite() && (intensity * 4.0 * std::f32::consts::PI).is_finite(),
            Light::Spot {
                position,
                direction,
                intensity,
                ..
            } => {
                position.is_finite()
                    && direction.is_finite()
                    && (intensity * 4.0 * std::f32::consts::PI).is_finite()
            }
            Light::Directional {
                direction,
                irradiance,
            } => direction.is_finite() && irradiance.is_finite(),
            Light::Environment { radiance } => radiance.is_finite(),
            Light::EnvironmentMap { map } => scene
                .environment_maps
                .get(map as usize)
                .is_some_and(|m| m.max_value().is_finite()),
            Light::Area { triangle } => (triangle as usize) < scene.triangles.len(),
            Light::Sphere { sphere } => (sphere as usize) < scene.spheres.len(),
        };
        assert!(ok, "{l:?}");
    }
    assert!(scene.camera.position.is_finite() && scene.camera.forward.is_finite());
}

const VALID_OBJ: &str = "mtllib a.mtl\no box\nv 0 0 0\nv 1 0 0\nv 0 1 0\nv 1 1 0\nvt 0 0\nvt 1 0\nvt 0 1\nvn 0 0 1\nusemtl m\nf 1/1/1 2/2/1 3/3/1\nusemtl light\nf 2/2/1 4/1/1 3/3/1\n";
const VALID_MTL: &str = "newmtl m\nKd 0.5 0.5 0.5\nKs 0.1 0.1 0.1\nNs 20\nNi 1.5\nd 1\nillum 2\nnewmtl light\nKd 0 0 0\nKe 4 4 4\n";
const VALID_TOML: &str = "resolution = [8, 8]\n[camera]\nfrom = [0, 0, 3]\nat = [0, 0, 0]\nfov = 40\n[[model]]\nfile = \"a.obj\"\n[[material]]\nname = \"m\"\ntype = \"dielectric\"\nior = 1.5\nalpha = 0.1\n[[light]]\ntype = \"point\"\nposition = [0, 1, 1]\nintensity = [5, 5, 5]\n[[light]]\ntype = \"spot\"\nposition = [0, 1, 1]\ndirection = [0, -1, 0]\nintensity = [5, 5, 5]\ninner = 10\nouter = 20\n";

/// Tokens that break things: non-numbers, NaN, infinities, huge and tiny
/// numbers, zero and negative indices, paths out of the folder, a long word.
const HOSTILE: &[&str] = &[
    "nan",
    "NaN",
    "inf",
    "-inf",
    "1e39",
    "3e38",
    "-1",
    "0",
    "-0",
    "1e-45",
    "9999999999",
    "-9223372036854775808",
    "1/2/3/4",
    "1//",
    "/",
    "../../../../etc/passwd",
    ".",
    "a.mtl",
    "\u{0}",
    "é",
    "[",
    "]",
    "=",
    "\"",
    "xxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxxx",
];

/// Applies token edits to `text`: (which word, what to do) pairs.
fn edit(text: &str, edits: &[(usize, usize, usize)]) -> String {
    let mut lines: Vec<Vec<String>> = text
        .lines()
        .map(|l| l.split(' ').map(str::to_owned).collect())
        .collect();
    for &(line, word, action) in edits {
        let n = lines.len();
        if n == 0 {
            break;
        }
        let line = line % n;
        let words = &mut lines[line];
        let w = word % words.len().max(1);
        match action % 8 {
            0 => {
                lines.remove(line);
            }
            1 => {
                let copy = lines[line].clone();
                lines.insert(line, copy);
            }
            2 if !words.is_empty() => {
                words.remove(w);
            }
            3 => words.push(HOSTILE[action / 8 % HOSTILE.len()].to_owned()),
            _ if !words.is_empty() => words[w] = HOSTILE[action / 8 % HOSTILE.len()].to_owned(),
            _ => {}
        }
    }
    lines.iter().map(|l| l.join(" ") + "\n").collect()
}

fn hostile_config() -> Config {
    Config {
        cases: 300,
        failure_persistence: None,
        rng_seed: RngSeed::Fixed(0x05ee_d0b1),
        ..Config::default()
    }
}

proptest! {
    #![proptest_config(hostile_config())]

    /// Random token edits of a valid scene.toml + OBJ + MTL: never a panic,
    /// every error one line, every scene that loads finite.
    #[test]
    fn token_edits_never_panic_and_loaded_scenes_are_finite(
        which in 0usize..3,
        edits in proptest::collection::vec((any::<usize>(), any::<usize>(), any::<usize>()), 1..5),
    ) {
        let mut texts = [VALID_TOML.to_owned(), VALID_OBJ.to_owned(), VALID_MTL.to_owned()];
        texts[which] = edit(&texts[which], &edits);
        let files = [
            ("scene.toml", texts[0].as_bytes()),
            ("a.obj", texts[1].as_bytes()),
            ("a.mtl", texts[2].as_bytes()),
        ];
        let (result, dir) = load_in(&files, &LoadOptions::default());
        let _ = std::fs::remove_dir_all(dir);
        match result {
            Ok(scene) => assert_finite(&scene),
            Err(e) => {
                let message = e.to_string();
                prop_assert!(!message.contains('\n'), "{}", message);
                prop_assert!(message.len() < 600, "{}", message);
            }
        }
    }
}

#[test]
fn the_valid_fixture_loads() {
    let files = [
        ("scene.toml", VALID_TOML.as_bytes()),
        ("a.obj", VALID_OBJ.as_bytes()),
        ("a.mtl", VALID_MTL.as_bytes()),
    ];
    let (result, dir) = load_in(&files, &LoadOptions::default());
    let _ = std::fs::remove_dir_all(dir);
    let scene = result.unwrap_or_else(|e| panic!("{e}"));
    assert_finite(&scene);
    assert_eq!(scene.triangles.len(), 2);
}

#[test]
fn what_a_renderer_can_go_on_with_is_a_warning() {
    let files = [
        (
            "a.obj",
            format!("mtllib a.mtl\nusemtl nosuch\n{TRIANGLE}").into_bytes(),
        ),
        ("a.mtl", b"newmtl m\nKd 2 1 1\n".to_vec()),
    ];
    let (result, dir) = load_in(&borrowed(&files), &LoadOptions::default());
    let _ = std::fs::remove_dir_all(dir);
    let warnings = result.unwrap().report.warnings.join("\n");
    assert!(warnings.contains("line 2: usemtl \"nosuch\""), "{warnings}");
    assert!(
        warnings.contains("a.mtl: material \"m\" (line 1): Kd"),
        "{warnings}"
    );
}
