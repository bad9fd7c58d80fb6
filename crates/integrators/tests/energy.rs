//! Energy-preserving regularization at the integrator level: on two white
//! furnaces (a white metal sphere and a rough glass sphere under a constant
//! sky) and the bundled scenes whose regularized lobes are conductors
//! (glossy-caustic, env-sphere, smallvcm-1), the image mean of a regularized
//! render equals the unregularized one within noise when energy is
//! preserved; on the furnaces it is significantly darker when it is not
//! (`Energy::Lost`, the old behaviour: the negative control of the first
//! test). The bundled glass scenes are left out: there regularization also
//! opens paths (a point light's caustic seen through glass or a mirror) that
//! the unregularized render cannot sample, so their means differ for a
//! reason other than energy.
//!
//! The blur is made strong (tau_0 = 1: alpha_tau = 0.28 at N = 1) and
//! uniform, so that the energy a widened lobe loses is far above the noise
//! of a tiny image; regularization itself redistributes light but keeps
//! the image mean apart from what leaves the frame, which a whole-image
//! mean of these closed or framed scenes barely sees.

mod common;

use glam::DVec3;
use integrators::{Algorithm, Energy, Mode, Regularization, RenderConfig, Strategies};

/// A strong blur: alpha_tau = 1/sqrt(4 pi tau_0) = 0.28 at N = 1.
const TAU_0: f64 = 1.0;
/// The furnaces and the bundled scenes whose regularized lobes are
/// conductors (see the module docs).
const SCENES: [&str; 5] = [
    "furnace",
    "glass-furnace",
    "glossy-caustic",
    "env-sphere",
    "smallvcm-1",
];
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

/// A scene by name: a bundled one, `furnace` (`WHITE_METAL`) or
/// `glass-furnace` (`GLASS`).
fn load(scene: &str) -> scene::Scene {
    match scene {
        "furnace" => common::load_manifest("energy-furnace", &furnace(WHITE_METAL), &[], SIZE),
        "glass-furnace" => {
            common::load_manifest("energy-glass-furnace", &furnace(GLASS), &[], SIZE)
        }
        _ => common::load(&common::bundled(scene), SIZE.0, SIZE.1),
    }
}

/// Path length limit: 8, and 64 in the glass furnace. Widened to alpha 1,
/// its interface scatters light inside the sphere in all directions, and
/// total internal reflection returns most of it (a uniform field inside
/// escapes with the smooth interface's T_- = 0.40 per hit): paths cut at 8
/// vertices lost 3-4 % of the image there (measured 0.960 and 0.968 of the
/// unregularized image with compensation), a truncation, not an energy loss
/// of the lobe.
fn max_depth(scene: &str) -> u32 {
    if scene == "glass-furnace" { 64 } else { 8 }
}

/// (mean, variance of the mean) of the image's channel sum.
fn image_mean(scene: &str, mode: Mode, energy: Energy, iterations: u64) -> (f64, f64) {
    let config = RenderConfig {
        algorithm: Algorithm::Bpt,
        strategies: Strategies::Mis,
        max_depth: max_depth(scene),
        seed: 3,
        regularization: Regularization {
            energy,
            ..Regularization::new(mode, TAU_0, true).unwrap()
        },
        ..RenderConfig::default()
    };
    let film = common::render(load(scene), config, iterations);
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

/// z of regularized against unregularized, and their ratio.
fn compare(scene: &str, energy: Energy, iterations: u64) -> (f64, f64) {
    let (off, off_var) = image_mean(scene, Mode::Off, Energy::Preserved, iterations);
    let (on, on_var) = image_mean(scene, Mode::Uniform, energy, iterations);
    let z = (on - off) / (off_var + on_var).sqrt();
    println!(
        "{scene} N={iterations} {energy:?}: regularized/unregularized {:.4}, z {z:.2}",
        on / off
    );
    (z, on / off)
}

/// Two-sided significance 0.01 with a Sidak correction over the scenes and
/// iteration counts of a test.
fn threshold(tests: usize) -> f64 {
    stats::chi2::sidak(0.01, tests)
}

#[test]
fn preserved_energy_keeps_the_image_mean() {
    let tests = SCENES.len() * 2;
    let outcomes: Vec<_> = SCENES
        .iter()
        .flat_map(|scene| [2, 16].map(|n| (scene, n, compare(scene, Energy::Preserved, n))))
        .collect();
    for (scene, iterations, (z, ratio)) in outcomes {
        {
            let p = common::p_value(z);
            assert!(
                p > threshold(tests),
                "{scene} N={iterations}: regularized/unregularized {ratio:.4}, z {z:.2}, p {p:.2e}"
            );
        }
    }
}

/// The negative control: without compensation the same comparison fails
/// (the darkening of issue 21) on both furnaces at N = 2 and 16; the bundled
/// scenes' darkening (measured 0.4-1.7 % at 64x48, N = 16) is within the
/// noise of a test-sized render and is only printed.
#[test]
fn lost_energy_darkens_the_image() {
    for scene in SCENES.into_iter().filter(|s| !FURNACES.contains(s)) {
        let _ = compare(scene, Energy::Lost, 16);
    }
    for scene in FURNACES {
        for iterations in [2, 16] {
            let (z, ratio) = compare(scene, Energy::Lost, iterations);
            let p = common::p_value(z);
            assert!(
                z < 0.0 && p < threshold(2 * FURNACES.len()),
                "{scene} N={iterations}: regularized/unregularized {ratio:.4}, z {z:.2}, p {p:.2e}: not darker"
            );
        }
    }
}
