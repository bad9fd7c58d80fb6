//! The features of real glTF scenes together (issue 18's agreement scene):
//! a coated (glTF metallic-roughness) sphere, an absorbing rough glass
//! sphere, a normal-mapped floor and an HDR environment map as the only
//! light. PT, BPT and VCM must estimate the same image: block means within
//! the films' measured variance (`common::assert_films_agree`).

use crate::common;

use std::path::PathBuf;

use glam::Vec3;
use integrators::{Algorithm, Film, Mode, RenderConfig, Strategies};
use scene::material::{NormalMap, NormalMapKind};
use scene::texture::Texture;

const SCENE: &str = r#"
resolution = [16, 12]
[camera]
from = [0, 1.1, 3.6]
at = [0, 0.45, 0]
fov = 40
[[material]]
name = "floor"
type = "diffuse"
reflectance = [0.6, 0.6, 0.6]
[[material]]
name = "plastic"
type = "coated"
reflectance = [0.8, 0.3, 0.2]
alpha = 0.15
ior = 1.5
[[material]]
name = "glass"
type = "dielectric"
alpha = 0.3
ior = 1.5
absorption = [0.4, 1.2, 2.5]
[[shape]]
type = "quad"
material = "floor"
origin = [-3, 0, 3]
u = [6, 0, 0]
v = [0, 0, -6]
[[shape]]
type = "sphere"
material = "plastic"
center = [-0.6, 0.45, 0]
radius = 0.45
[[shape]]
type = "sphere"
material = "glass"
center = [0.6, 0.45, 0]
radius = 0.45
[[light]]
type = "environment"
file = "sky.hdr"
scale = 0.3
"#;

/// The scene above with the bundled sky map, and a floor whose tangent-space
/// normal map tilts the normal by up to 45 degrees in ridges along u.
fn scene() -> scene::Scene {
    let mut s = common::load_manifest("real-materials", SCENE, &[&sky()], (16, 12));

    let mut ridges = Texture::from_u8(1, 1, 1, &[0], false).unwrap();
    ridges.width = 64;
    ridges.texels = (0..64)
        .map(|i| {
            let slope = (i as f32 * std::f32::consts::TAU / 16.0).sin();
            ((Vec3::new(slope, 0.0, 1.0).normalize() + Vec3::ONE) * 0.5).extend(1.0)
        })
        .collect();
    s.textures.push(ridges);
    let floor = s.materials.iter().position(|m| m.name == "floor").unwrap();
    s.materials[floor].maps.normal = Some(NormalMap {
        texture: s.textures.len() - 1,
        kind: NormalMapKind::Tangent { scale: 1.0 },
    });
    s
}

/// The bundled sky map, which the manifests above name.
fn sky() -> PathBuf {
    common::bundled("env-sphere").with_file_name("sky.hdr")
}

fn render(algorithm: Algorithm, seed: u64) -> Film {
    let config = RenderConfig {
        algorithm,
        seed,
        ..common::config(Strategies::Mis, Mode::Off, 12)
    };
    common::render(scene(), config, 1024)
}

/// PT, BPT and VCM agree on the scene (independent seeds; 4 x 4 blocks and
/// the image mean, Sidak-corrected at 0.01 over blocks and channels).
#[test]
fn pt_bpt_vcm_agree_on_coated_absorbing_normal_mapped_env_lit_scene() {
    let pt = render(Algorithm::Pt, 1);
    for (algorithm, seed) in [(Algorithm::Bpt, 2), (Algorithm::Vcm, 3)] {
        let what = format!("real materials: pt vs {algorithm}");
        let p = common::assert_films_agree(&pt, &render(algorithm, seed), 4, &what);
        eprintln!("{what}: smallest p {p:.3}");
    }
}

/// A white coated sphere (white base, metallic 0) under a white constant
/// environment of radiance 1. A convex object sees only the environment, so
/// every pixel is the lobe's albedo: exactly 1 for a smooth coat (the coat
/// reflects F(mu), the base T(mu) = 1 - F(mu): `microfacet::coated`), at
/// most 1 for a rough one (single scattering loses what the microfacets
/// shadow). Renders with `alpha`, 8x8, 256 iterations of PT.
fn white_furnace(alpha: f32) -> Film {
    let manifest = format!(
        r#"
resolution = [8, 8]
[camera]
from = [0, 0, 3]
at = [0, 0, 0]
fov = 25
[[material]]
name = "white"
type = "coated"
reflectance = [1, 1, 1]
alpha = {alpha}
ior = 1.5
[[shape]]
type = "sphere"
material = "white"
center = [0, 0, 0]
radius = 1
[[light]]
type = "environment"
intensity = [1, 1, 1]
"#
    );
    let dir =
        std::env::temp_dir().join(format!("rlt-white-furnace-{alpha}-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(&path, manifest).unwrap();
    let scene = common::load(&path, 8, 8);
    std::fs::remove_dir_all(&dir).unwrap();
    common::render(scene, common::config(Strategies::Mis, Mode::Off, 16), 256)
}

/// The white furnace of a coated sphere: 1 for a smooth coat (every 2x2
/// block within its measured noise), and for a rough coat (alpha 0.3) no
/// block above 1 by more than 4 standard deviations, and the image mean
/// within 5 % below it.
#[test]
fn white_coated_sphere_in_a_white_furnace_reflects_at_most_everything() {
    let smooth = white_furnace(0.0);
    let p = common::assert_film_equals(&smooth, 1.0, 2, "smooth white coat");
    eprintln!("smooth white coat: smallest p {p:.3}");
    let rough = white_furnace(0.3);
    for (i, (m, v)) in common::block_means(&rough, 2).iter().enumerate() {
        for c in 0..3 {
            assert!(
                m[c] <= 1.0 + 4.0 * v[c].sqrt(),
                "rough white coat, block {i} channel {c}: {} (sd {:.2e}) reflects more than arrives",
                m[c],
                v[c].sqrt()
            );
        }
    }
    let mean = common::block_means(&rough, 1)[0].0;
    eprintln!("rough white coat: image mean {mean}");
    assert!(mean.min_element() > 0.95, "{mean}");
}
