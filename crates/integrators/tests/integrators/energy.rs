//! Energy-preserving regularization at the integrator level (issue 21,
//! point 1): on two white furnaces (a white metal sphere and a rough glass
//! sphere under a constant sky) and on every bundled scene, the image mean
//! of a regularized render equals the unregularized one within noise when
//! energy is preserved, at the blur of iterations N = 1, 16 and 256; on
//! the furnaces it is significantly darker when it is not (`Energy::Lost`,
//! the old behaviour: the negative control of the first test).
//!
//! The blur is strong (tau_0 = 1: alpha_tau = 0.28 at N = 1), so that the
//! energy a widened lobe loses is far above the noise. The furnaces use
//! `uniform` mode, so the sphere the camera sees is widened too; their
//! standard errors are 0.2-0.5 %. The bundled scenes use the `selective`
//! rule (SPEC §5; it widens more than the default `unsampleable`), for a
//! reason measured here: `uniform` blurs what the camera sees directly, and
//! where that is a glass sphere acting as a lens (caustic-through-glass,
//! caustic-glass) the blur spreads the camera's view from the bright image
//! it focuses to the darker surroundings. The image mean then changes for
//! a reason other than energy (0.48 and 0.83 of the unregularized mean at
//! N = 1 with compensation, 0.99 and 1.01 with the selective rule). Their
//! standard errors are 1-13 % (stiff's 1 mm, 1e7-radiance light seen in a
//! near mirror is the noisiest), so they catch gross errors only.
//!
//! Each scene is rendered by an estimator that samples all of its paths
//! without regularization (the study's unbiased reference, SPEC §7): VCM
//! where a specular (delta) material makes caustics that only merging
//! reaches, BPT elsewhere. Both renders use the same estimator. One kind
//! of path no unregularized technique samples: a point light seen in a
//! specular surface (a glint, L S+ E: a camera ray cannot hit the point,
//! and a light subpath cannot connect through a delta lobe).
//! Regularization renders those glints, so it adds their energy (measured
//! with `uniform`: 2.1x the image mean on caustic-glass, 15x on stiff). In
//! scenes with a point light and a specular material the test therefore
//! swaps each point light for a small sphere light of the same intensity
//! (`bulbs`), whose glints camera subpaths reach.

use crate::common;

use glam::DVec3;
use integrators::{Algorithm, Energy, Mode, Regularization, RenderConfig, Strategies};
use regularization::Schedule;

/// A strong blur: alpha_tau = 1/sqrt(4 pi tau_0) = 0.28 at N = 1.
const TAU_0: f64 = 1.0;
/// The iterations whose blur (tau_N of the `TAU_0` schedule, held fixed)
/// the first test compares at: alpha_tau = 0.28, 0.19, 0.12.
const BLUR_OF_ITERATION: [u64; 3] = [1, 16, 256];
/// Iterations of each render.
const ITERATIONS: u64 = 16;
/// The furnaces and every bundled scene.
const SCENES: [&str; 13] = [
    "furnace",
    "glass-furnace",
    "caustic-glass",
    "caustic-through-glass",
    "cornell-box",
    "cornell-mcguire",
    "diffuse-only",
    "env-sphere",
    "glossy-caustic",
    "glossy-cornell-glass",
    "smallvcm-1",
    "smallvcm-2",
    "stiff",
];
/// Radius of the sphere lights that stand in for point lights (`bulbs`):
/// small against the scenes (2-6 units across), large enough that camera
/// subpaths hit them through specular chains.
const BULB_RADIUS: f32 = 0.1;
/// The scenes of the negative control.
const FURNACES: [&str; 2] = ["furnace", "glass-furnace"];
const SIZE: (u32, u32) = (64, 48);

/// A sphere of the material whose manifest fields are `material` filling
/// the frame under a constant white environment: a lossless lobe in a
/// furnace, whose unregularized image is 1 everywhere up to the lobe's own
/// small loss, with little noise.
fn furnace(material: &str) -> String {
    format!(
        r#"
resolution = [32, 32]
[camera]
from = [0, 0, 3]
at = [0, 0, 0]
fov = 30
[[material]]
name = "sphere"
{material}
[[shape]]
type = "sphere"
material = "sphere"
center = [0, 0, 0]
radius = 1
[[light]]
type = "environment"
intensity = [1, 1, 1]
"#
    )
}

/// A white (F = 1) GGX conductor of alpha 0.01: widened without
/// compensation it is visibly darker.
const WHITE_METAL: &str = r#"type = "conductor"
alpha = 0.01
ndf = "ggx"
shadowing = "smith"
reflectance = [1, 1, 1]"#;

/// Clear glass (IOR 1.5, GGX alpha 0.01). The blur of `TAU_0` widens it to
/// alpha 1 (the transmission bound's clamp, SPEC §5), which without
/// compensation loses a large part of the energy at every crossing.
const GLASS: &str = r#"type = "dielectric"
alpha = 0.01
ndf = "ggx"
shadowing = "smith"
ior = 1.5"#;

/// A scene by name: a bundled one (with `bulbs`), `furnace` (`WHITE_METAL`)
/// or `glass-furnace` (`GLASS`).
fn load(scene: &str) -> scene::Scene {
    match scene {
        "furnace" => common::load_manifest("energy-furnace", &furnace(WHITE_METAL), &[], SIZE),
        "glass-furnace" => {
            common::load_manifest("energy-glass-furnace", &furnace(GLASS), &[], SIZE)
        }
        _ => bulbs(common::load(&common::bundled(scene), SIZE.0, SIZE.1)),
    }
}

/// `scene` with each point light replaced by a black sphere of radius
/// `BULB_RADIUS` and radiance I / (pi r^2), whose intensity is I in every
/// direction, if the scene has a specular material (module docs).
fn bulbs(mut scene: scene::Scene) -> scene::Scene {
    if scene::SceneFeatures::of(&scene).specular_materials == 0 {
        return scene;
    }
    let area = std::f32::consts::PI * BULB_RADIUS * BULB_RADIUS;
    let points: Vec<_> = scene
        .lights
        .iter()
        .filter_map(|light| match *light {
            scene::Light::Point {
                position,
                intensity,
            } => Some((position, intensity)),
            _ => None,
        })
        .collect();
    scene
        .lights
        .retain(|l| !matches!(l, scene::Light::Point { .. }));
    for (position, intensity) in points {
        scene.materials.push(scene::Material {
            name: "bulb".into(),
            surface: scene::Surface::Diffuse {
                reflectance: glam::Vec3::ZERO,
            },
            emission: intensity / area,
            medium: None,
            maps: Default::default(),
        });
        scene.spheres.push(scene::Sphere {
            center: position,
            radius: BULB_RADIUS,
            axis: glam::Vec3::Y,
            material: scene.materials.len() as u32 - 1,
            inside: false,
        });
        let sphere = scene.spheres.len() as u32 - 1;
        scene.lights.push(scene::Light::Sphere { sphere });
    }
    scene
}

/// Path length limit: 8, and 64 in scenes with glass. Widened to alpha 1,
/// a glass interface scatters light inside its object in all directions,
/// and total internal reflection returns most of it (a uniform field inside
/// escapes with the smooth interface's T_- = 0.40 per hit): in the glass
/// furnace, paths cut at 8 vertices lost 3-4 % of the image (measured 0.960
/// and 0.968 of the unregularized image with compensation), a truncation,
/// not an energy loss of the lobe.
fn max_depth(scene: &scene::Scene) -> u32 {
    let glass = |m: &scene::Material| matches!(m.surface, scene::Surface::Dielectric { .. });
    if scene.materials.iter().any(glass) {
        64
    } else {
        8
    }
}

/// The estimator that samples every path of `scene` unregularized: VCM
/// when it has a specular material (SDS caustics), else BPT.
fn algorithm(scene: &scene::Scene) -> Algorithm {
    if scene::SceneFeatures::of(scene).specular_materials > 0 {
        Algorithm::Vcm
    } else {
        Algorithm::Bpt
    }
}

/// (mean, variance of the mean) of the image's channel sum, rendered with
/// `mode` at the fixed bound `tau` over `iterations` iterations.
fn image_mean(scene: &str, mode: Mode, energy: Energy, tau: f64, iterations: u64) -> (f64, f64) {
    let scene = load(scene);
    let config = RenderConfig {
        algorithm: algorithm(&scene),
        strategies: Strategies::Mis,
        max_depth: max_depth(&scene),
        seed: 3,
        regularization: Regularization {
            energy,
            ..Regularization::new(mode, tau, false).unwrap()
        },
        ..RenderConfig::default()
    };
    let film = common::render(scene, config, iterations);
    let (mean, variance) = common::block_means(&film, 1)[0];
    (
        mean.element_sum(),
        variance.element_sum() + sum_covariance_bound(variance),
    )
}

/// The channels of one image are correlated (one path carries all three);
/// the variance of their sum is at most (sum of standard deviations)^2, of
/// which the plain sum of variances is a part: this adds the rest.
fn sum_covariance_bound(variance: DVec3) -> f64 {
    let sd = variance.map(f64::sqrt);
    sd.element_sum().powi(2) - variance.element_sum()
}

/// `uniform` in the furnaces, the `selective` rule in the bundled
/// scenes (module docs).
fn mode(scene: &str) -> Mode {
    if FURNACES.contains(&scene) {
        Mode::Uniform
    } else {
        Mode::Selective
    }
}

/// z of regularized against unregularized at the blur of iteration `n`,
/// and their ratio.
fn compare(scene: &str, energy: Energy, n: u64) -> (f64, f64) {
    let tau = Schedule::new(TAU_0).unwrap().tau_at(n);
    let (off, off_var) = image_mean(scene, Mode::Off, Energy::Preserved, tau, ITERATIONS);
    let (on, on_var) = image_mean(scene, mode(scene), energy, tau, ITERATIONS);
    let z = (on - off) / (off_var + on_var).sqrt();
    println!(
        "{scene} blur of N={n} (tau {tau:.2}) {energy:?}: regularized/unregularized {:.4} \
         (standard error {:.4}), z {z:.2}",
        on / off,
        (off_var + on_var).sqrt() / off
    );
    (z, on / off)
}

/// Two-sided significance 0.01 with a Sidak correction over the scenes and
/// blurs of a test.
fn threshold(tests: usize) -> f64 {
    stats::chi2::sidak(0.01, tests)
}

#[test]
fn preserved_energy_keeps_the_image_mean() {
    let tests = SCENES.len() * BLUR_OF_ITERATION.len();
    let outcomes: Vec<_> = SCENES
        .iter()
        .flat_map(|scene| {
            BLUR_OF_ITERATION.map(|n| (scene, n, compare(scene, Energy::Preserved, n)))
        })
        .collect();
    for (scene, n, (z, ratio)) in outcomes {
        let p = common::p_value(z);
        assert!(
            p > threshold(tests),
            "{scene} blur of N={n}: regularized/unregularized {ratio:.4}, z {z:.2}, p {p:.2e}"
        );
    }
}

/// The negative control: without compensation the same comparison fails
/// (the darkening of issue 21) on both furnaces at every blur; on the
/// bundled scenes the darkening is within the noise of a test-sized render
/// and is only printed.
#[test]
fn lost_energy_darkens_the_image() {
    for scene in SCENES.into_iter().filter(|s| !FURNACES.contains(s)) {
        let _ = compare(scene, Energy::Lost, 1);
    }
    for scene in FURNACES {
        for n in BLUR_OF_ITERATION {
            let (z, ratio) = compare(scene, Energy::Lost, n);
            let p = common::p_value(z);
            assert!(
                z < 0.0 && p < threshold(FURNACES.len() * BLUR_OF_ITERATION.len()),
                "{scene} blur of N={n}: regularized/unregularized {ratio:.4}, z {z:.2}, p {p:.2e}: not darker"
            );
        }
    }
}
