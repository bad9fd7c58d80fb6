//! Environment maps: the sampling distribution against its density
//! (chi-square), a constant map against the constant environment light, a
//! one-texel map against the distant light it approximates, and PT, BPT and
//! VCM on the bundled env-lit scene.

use crate::common;

use glam::{Vec2, Vec3};
use integrators::environment::EnvironmentDistribution;
use integrators::{Algorithm, Film, Mode, RenderConfig, Strategies};
use scene::{EnvironmentMap, Light};
use stats::chi2::{SphericalChi2, sidak};
use stats::quadrature::Depth;
use stats::rng::Pcg32;

/// The chi-square harness bins around its +z; the map's pole is +y. This
/// maps a harness direction to the world so that the harness's (theta, phi)
/// are the map's: harness (x, y, z) = (-z, x, y) of the world.
fn to_world(h: Vec3) -> Vec3 {
    Vec3::new(h.y, h.z, -h.x)
}

fn to_harness(d: Vec3) -> Vec3 {
    Vec3::new(-d.z, d.x, d.y)
}

/// Chi-square of `map`'s direction sampling against its density, on a
/// harness grid of `theta_res` x `phi_res` cells, each coprime with the
/// map's side so that no cell edge but the poles and phi = 0 falls on a
/// texel edge: the quadrature evaluates the density on cell edges, where a
/// texel edge would be ambiguous, and refines the jumps inside cells
/// adaptively. Cells finer than texels test the distribution inside a
/// texel (the sin theta Jacobian) too.
fn chi2_of(
    map: &EnvironmentMap,
    (theta_res, phi_res): (usize, usize),
    seed: u64,
) -> stats::chi2::Chi2Outcome {
    let distribution = EnvironmentDistribution::new(map).unwrap();
    let test = SphericalChi2 {
        theta_res,
        phi_res,
        sample_count: 200_000,
        integration_eps: 1e-9,
        integration_depth: Depth { min: 2, max: 12 },
    };
    let mut rng = Pcg32::new(seed, 0);
    test.run(
        &mut rng,
        |rng| {
            let u = Vec2::new(rng.uniform_f32(), rng.uniform_f32());
            let s = distribution.sample(map, u)?;
            Some(to_harness(s.direction))
        },
        |h| f64::from(distribution.pdf(map, to_world(h.normalize()))),
    )
}

/// A map of `width` x `height` texels with radiance `f(col, row)`.
fn map_of(width: u32, height: u32, mut f: impl FnMut(u32, u32) -> Vec3) -> EnvironmentMap {
    let texels = (0..height)
        .flat_map(|row| (0..width).map(move |col| (col, row)))
        .map(|(col, row)| f(col, row))
        .collect();
    EnvironmentMap::new(width, height, texels, 1.0, 0.0).unwrap()
}

/// Direction sampling matches its density: a random map with dark texels,
/// and a map whose brightest row touches the pole, where the sin theta
/// Jacobian varies most within a texel. Measured negative controls: theta
/// uniform instead of cos theta inside a texel gives chi^2 = 9836 at 335
/// degrees of freedom; a density with pbrt's sin theta at the row centre
/// instead of the texel's exact solid angle, 2663 at 336 (p = 0 both).
#[test]
fn environment_sampling_matches_its_density() {
    let mut rng = Pcg32::new(7, 1);
    let random = map_of(12, 6, |_, _| {
        let x = rng.uniform_f32();
        if x < 0.2 {
            Vec3::ZERO
        } else {
            Vec3::new(x, rng.uniform_f32(), 4.0 * x * x)
        }
    });
    let polar = map_of(8, 10, |col, row| {
        if row == 0 {
            Vec3::splat(40.0 + col as f32)
        } else if row == 9 {
            Vec3::new(0.0, 0.0, 20.0)
        } else {
            Vec3::splat(0.5)
        }
    });
    let significance = sidak(0.01, 2);
    for (name, map, grid, seed) in [
        ("random", random, (13, 29), 1),
        ("polar rows", polar, (23, 17), 2),
    ] {
        let outcome = chi2_of(&map, grid, seed);
        eprintln!("{name}: {outcome:?}");
        assert!(outcome.passes(significance), "{name}: {outcome:?}");
    }
}

/// A manifest at 16x12: a diffuse and a glossy sphere on a diffuse floor,
/// with the background in view, and `light`.
fn spheres_scene(light: &str) -> String {
    format!(
        r#"
resolution = [16, 12]
[camera]
from = [0, 1.0, 3.2]
at = [0, 0.45, 0]
fov = 45
[[material]]
name = "floor"
type = "diffuse"
reflectance = [0.6, 0.6, 0.6]
[[material]]
name = "matte"
type = "diffuse"
reflectance = [0.8, 0.3, 0.2]
[[material]]
name = "glossy"
type = "conductor"
reflectance = [0.9, 0.8, 0.5]
alpha = 0.15
[[shape]]
type = "quad"
material = "floor"
origin = [-2, 0, 2]
u = [4, 0, 0]
v = [0, 0, -4]
[[shape]]
type = "sphere"
material = "matte"
center = [-0.55, 0.45, 0]
radius = 0.45
rings = 12
tessellate = true
[[shape]]
type = "sphere"
material = "glossy"
center = [0.55, 0.45, 0]
radius = 0.45
rings = 12
tessellate = true
{light}
"#
    )
}

/// Loads `manifest` at 16x12.
fn load_manifest(what: &str, manifest: &str) -> scene::Scene {
    common::load_manifest(&format!("env-{what}"), manifest, &[], (16, 12))
}

fn config(algorithm: Algorithm, strategies: Strategies, seed: u64) -> RenderConfig {
    RenderConfig {
        algorithm,
        seed,
        ..common::config(strategies, Mode::Off, 12)
    }
}

fn render(scene: &scene::Scene, algorithm: Algorithm, seed: u64, iterations: u64) -> Film {
    common::render(
        scene.clone(),
        config(algorithm, Strategies::Mis, seed),
        iterations,
    )
}

/// The constant environment light and a constant 8x4 map of the same
/// radiance give the same image (block means within their measured
/// variance), with PT and with BPT, whose light subpaths start from the map.
/// (Its power is limited: the centre-sin-theta density above, 2.6 % off
/// per texel here and diluted by MIS, gave p = 0.024 (PT) and 3e-4 (BPT),
/// above the Sidak threshold 2e-4; the chi-square test is the one that
/// catches such a density.)
#[test]
fn constant_map_renders_like_the_constant_environment() {
    let radiance = Vec3::new(0.8, 1.0, 1.2);
    let constant = load_manifest(
        "constant",
        &spheres_scene("[[light]]\ntype = \"environment\"\nintensity = [0.8, 1.0, 1.2]"),
    );
    assert!(matches!(constant.lights[..], [Light::Environment { .. }]));
    let mut mapped = constant.clone();
    mapped.set_environment(map_of(8, 4, |_, _| radiance));
    for (algorithm, seeds) in [(Algorithm::Pt, (1, 2)), (Algorithm::Bpt, (3, 4))] {
        let a = render(&constant, algorithm, seeds.0, 1024);
        let b = render(&mapped, algorithm, seeds.1, 1024);
        let what = format!("{algorithm}: constant environment vs constant map");
        let p = common::assert_films_agree(&a, &b, 4, &what);
        eprintln!("{what}: smallest p {p:.3}");
    }
}

/// A map dark but for one texel lights a diffuse floor like the distant
/// light of the same irradiance: the texel (row r of h, one of w columns)
/// of radiance L gives a surface facing +y the irradiance
/// `L (2 pi / w) (sin^2 theta_1 - sin^2 theta_0) / 2` (the integral of
/// cos theta over the texel's solid angle, theta from +y), which the
/// directional light along the texel's centre delivers with irradiance
/// that over cos theta_c. PT and BPT, against the directional light's
/// image (compared on block means within the measured variance).
#[test]
fn one_bright_texel_is_a_distant_light() {
    let (w, h, row, col) = (64u32, 32u32, 9u32, 20u32);
    let l = Vec3::new(3000.0, 2500.0, 2000.0);
    let map = map_of(
        w,
        h,
        |c, r| if (c, r) == (col, row) { l } else { Vec3::ZERO },
    );
    let pi = std::f32::consts::PI;
    let (theta_0, theta_1) = (pi * row as f32 / h as f32, pi * (row + 1) as f32 / h as f32);
    let e_floor = l * (2.0 * pi / w as f32) * 0.5 * (theta_1.sin().powi(2) - theta_0.sin().powi(2));
    let centre = map.direction(
        (0.5 * (theta_0 + theta_1)).cos(),
        2.0 * pi * (col as f32 + 0.5) / w as f32,
    );
    let manifest = r#"
resolution = [16, 12]
[camera]
from = [0, 3, 2]
at = [0, 0, 0]
fov = 40
[[material]]
name = "floor"
type = "diffuse"
reflectance = [0.7, 0.7, 0.7]
[[shape]]
type = "quad"
material = "floor"
origin = [-4, 0, 4]
u = [8, 0, 0]
v = [0, 0, -8]
[[light]]
type = "environment"
intensity = [0, 0, 0]
"#;
    let mut distant = load_manifest("distant", manifest);
    distant.lights = vec![Light::Directional {
        direction: -centre,
        irradiance: e_floor / centre.y,
    }];
    let mut mapped = distant.clone();
    mapped.lights.clear();
    mapped.set_environment(map);
    let reference = render(&distant, Algorithm::Pt, 1, 16);
    for (algorithm, seed) in [(Algorithm::Pt, 2), (Algorithm::Bpt, 3)] {
        let film = render(&mapped, algorithm, seed, 256);
        let what = format!("{algorithm}: one bright texel vs distant light");
        let p = common::assert_films_agree(&reference, &film, 4, &what);
        eprintln!(
            "{what}: smallest p {p:.3}, means {} vs {}",
            common::block_means(&reference, 1)[0].0,
            common::block_means(&film, 1)[0].0
        );
    }
}

/// PT (MIS and NEE only), BPT and VCM agree on the bundled `env-sphere`
/// (a sky with a sun; VCM merges at its near-specular gold sphere): block
/// means within the measured variance, independent seeds.
#[test]
fn integrators_agree_on_an_environment_lit_scene() {
    let scene = common::load(&common::bundled("env-sphere"), 16, 12);
    assert!(matches!(scene.lights[..], [Light::EnvironmentMap { .. }]));
    let pt = render(&scene, Algorithm::Pt, 1, 1024);
    let nee_only = common::render(
        scene.clone(),
        config(Algorithm::Pt, Strategies::NeeOnly, 2),
        1024,
    );
    let p = common::assert_films_agree(&pt, &nee_only, 4, "env-sphere: pt vs pt nee-only");
    eprintln!("env-sphere: pt vs nee-only: smallest p {p:.3}");
    for (algorithm, seed) in [(Algorithm::Bpt, 3), (Algorithm::Vcm, 4)] {
        let film = render(&scene, algorithm, seed, 1024);
        let what = format!("env-sphere: pt vs {algorithm}");
        let p = common::assert_films_agree(&pt, &film, 4, &what);
        eprintln!("{what}: smallest p {p:.3}");
    }
}
