//! Absorbing and tinted glass (KHR_materials_volume, KHR_materials_transmission):
//! Beer-Lambert transmittance on the segments inside a closed dielectric
//! mesh, the same in PT and in the bidirectional core.
//!
//! 1. Analytic: an index-matched (ior 1) glass slab of thickness d between
//!    the camera and an emitter of radiance L. Every camera ray crosses the
//!    slab without refraction or reflection (Fresnel is 0 at eta = 1), so
//!    each pixel is exactly L tint^2 exp(-sigma_a d) (the tint once per
//!    crossing of the surface, twice in all) for every integrator, to the
//!    spread of the path length over the narrow field of view.
//! 2. Agreement: PT, BPT and VCM on a rough absorbing glass sphere on a
//!    floor under an area light (block means within the measured variance),
//!    where light subpaths, camera subpaths and connections all run inside
//!    the sphere.

use crate::common;

use std::path::{Path, PathBuf};

use glam::{UVec2, Vec3};
use integrators::{Algorithm, Film, Mode, RenderConfig, Strategies};

/// Writes `text` as `scene.toml` in a folder of its own (named `name`).
fn manifest(name: &str, text: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!(
        "integrators-absorption-{}-{name}",
        std::process::id()
    ));
    std::fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.toml");
    std::fs::write(&path, text).unwrap();
    path
}

fn render(path: &Path, size: UVec2, algorithm: Algorithm, seed: u64, iterations: u64) -> Film {
    let scene = common::load(path, size.x, size.y);
    let config = RenderConfig {
        algorithm,
        seed,
        ..common::config(Strategies::Mis, Mode::Off, 12)
    };
    common::render(scene, config, iterations)
}

/// Emitted radiance of the slab scene's emitter.
const RADIANCE: f32 = 2.0;

/// Thickness of the slab (z from -0.5 to 0.5).
const THICKNESS: f32 = 1.0;

/// Relative tolerance of the slab images: a ray at angle theta to the axis
/// crosses THICKNESS / cos(theta); over the 1-degree field, 1 - cos is at
/// most 8e-5, times sigma_a d <= 2.6 below, 2e-4. Rounding is far below.
const SLAB_TOLERANCE: f64 = 5e-4;

/// The slab scene: a closed box of glass (`glass` keys) 4 x 4 x THICKNESS
/// centred on the axis, an emitter behind it facing the camera, and nothing
/// else (the emitter reflects nothing, so no other path carries light).
fn slab_scene(glass: &str) -> String {
    let faces = [
        // origin, u, v: u x v points out of the box.
        ([-2, -2, 1], [4, 0, 0], [0, 4, 0]),
        ([-2, -2, -1], [0, 4, 0], [4, 0, 0]),
        ([2, -2, -1], [0, 4, 0], [0, 0, 2]),
        ([-2, -2, -1], [0, 0, 2], [0, 4, 0]),
        ([-2, 2, -1], [0, 0, 2], [4, 0, 0]),
        ([-2, -2, -1], [4, 0, 0], [0, 0, 2]),
    ];
    let mut text = format!(
        "[camera]\nfrom = [0, 0, 6]\nat = [0, 0, 0]\nfov = 1\n\n\
         [[material]]\nname = \"glass\"\ntype = \"dielectric\"\nior = 1.0\n{glass}\n\n\
         [[material]]\nname = \"lamp\"\ntype = \"diffuse\"\nreflectance = [0, 0, 0]\n\
         emission = [{RADIANCE}, {RADIANCE}, {RADIANCE}]\n\n\
         [[shape]]\ntype = \"quad\"\nmaterial = \"lamp\"\norigin = [-3, -3, -3]\nu = [6, 0, 0]\nv = [0, 6, 0]\n"
    );
    for (origin, u, v) in faces {
        // The box spans z in [-THICKNESS/2, THICKNESS/2]: halve the z of the table.
        let z = |a: [i32; 3]| [a[0] as f32, a[1] as f32, a[2] as f32 * THICKNESS / 2.0];
        text += &format!(
            "\n[[shape]]\ntype = \"quad\"\nmaterial = \"glass\"\norigin = {:?}\nu = {:?}\nv = {:?}\n",
            z(origin),
            z(u),
            z(v)
        );
    }
    text
}

/// Asserts that every pixel of `film` is `expected` to [`SLAB_TOLERANCE`].
fn assert_uniform(film: &Film, expected: Vec3, what: &str) {
    for y in 0..film.height() {
        for x in 0..film.width() {
            let got = film.pixel_mean(x, y);
            for c in 0..3 {
                let e = f64::from(expected[c]);
                assert!(
                    (got[c] - e).abs() <= SLAB_TOLERANCE * e,
                    "{what}: pixel ({x}, {y}) channel {c}: {} vs {e}",
                    got[c]
                );
            }
        }
    }
}

#[test]
fn an_absorbing_slab_transmits_exp_of_minus_sigma_a_times_thickness() {
    let sigma_a = Vec3::new(0.1, 0.7, 2.6);
    let tint = Vec3::new(1.0, 0.8, 0.5);
    let size = UVec2::new(8, 6);
    let clear = manifest("clear-slab", &slab_scene(""));
    let absorbing = manifest(
        "absorbing-slab",
        &slab_scene(&format!("absorption = {:?}", sigma_a.to_array())),
    );
    let tinted = manifest(
        "tinted-absorbing-slab",
        &slab_scene(&format!(
            "absorption = {:?}\ntint = {:?}",
            sigma_a.to_array(),
            tint.to_array()
        )),
    );
    let transmittance = (-sigma_a * THICKNESS).exp();
    for (seed, algorithm) in [(1, Algorithm::Pt), (2, Algorithm::Bpt), (3, Algorithm::Vcm)] {
        let image = |path| render(path, size, algorithm, seed, 2);
        assert_uniform(
            &image(&clear),
            Vec3::splat(RADIANCE),
            &format!("{algorithm} clear"),
        );
        assert_uniform(
            &image(&absorbing),
            RADIANCE * transmittance,
            &format!("{algorithm} absorbing"),
        );
        // The tint applies at each of the two crossings of the surface.
        assert_uniform(
            &image(&tinted),
            RADIANCE * transmittance * tint * tint,
            &format!("{algorithm} tinted"),
        );
    }
}

/// A rough (alpha 0.5) absorbing analytic glass sphere (diameter 1) on a diffuse
/// floor under a small area light, seen from the front and above.
fn sphere_scene() -> String {
    "[camera]\nfrom = [0, 1.2, 1.8]\nat = [0, 0.45, 0]\nfov = 40\n\n\
     [[material]]\nname = \"glass\"\ntype = \"dielectric\"\nior = 1.5\nalpha = 0.5\n\
     absorption = [0.2, 1.0, 3.0]\n\n\
     [[material]]\nname = \"floor\"\ntype = \"diffuse\"\nreflectance = [0.8, 0.8, 0.8]\n\n\
     [[material]]\nname = \"lamp\"\ntype = \"diffuse\"\nreflectance = [0, 0, 0]\nemission = [12, 12, 12]\n\n\
     [[shape]]\ntype = \"quad\"\nmaterial = \"floor\"\norigin = [-3, 0, 3]\nu = [6, 0, 0]\nv = [0, 0, -6]\n\n\
     [[shape]]\ntype = \"quad\"\nmaterial = \"lamp\"\norigin = [-0.5, 2, -0.5]\nu = [1, 0, 0]\nv = [0, 0, 1]\n\n\
     [[shape]]\ntype = \"sphere\"\nmaterial = \"glass\"\ncenter = [0, 0.5, 0]\nradius = 0.5\n"
        .to_string()
}

/// Iterations of the agreement test.
const ITERATIONS: u64 = 256;

#[test]
fn pt_bpt_vcm_agree_on_absorbing_glass() {
    let path = manifest("absorbing-sphere", &sphere_scene());
    let size = UVec2::new(24, 24);
    let pt = render(&path, size, Algorithm::Pt, 1, ITERATIONS);
    for (seed, algorithm) in [(2, Algorithm::Bpt), (3, Algorithm::Vcm)] {
        let film = render(&path, size, algorithm, seed, ITERATIONS);
        let p = common::assert_films_agree(&pt, &film, 4, &format!("pt vs {algorithm}"));
        eprintln!("absorbing glass: pt vs {algorithm}: smallest p {p:.3}");
    }
}
