//! Energy-preserving regularization at the integrator level: on a white
//! furnace (a white metal sphere under a constant sky) and the bundled
//! scenes whose regularized lobes are conductors (glossy-caustic,
//! env-sphere, smallvcm-1), the image mean of a regularized render equals
//! the unregularized one within noise when energy is preserved; on the
//! furnace it is significantly darker when it is not (`Energy::Lost`, the
//! old behaviour: the negative control of the first test).
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
/// Scenes whose regularized lobes are conductors (dielectrics are not
/// compensated: see ARCHITECTURE.md).
const SCENES: [&str; 4] = ["furnace", "glossy-caustic", "env-sphere", "smallvcm-1"];
const SIZE: (u32, u32) = (64, 48);

/// A white (F = 1) GGX sphere of alpha 0.01 filling the frame under a
/// constant white environment: the unregularized image is 1 everywhere up
/// to the lobe's own small loss, and a widened lobe without compensation
/// is visibly darker, with little noise.
const FURNACE: &str = r#"
resolution = [32, 32]
[camera]
from = [0, 0, 3]
at = [0, 0, 0]
fov = 30
[[material]]
name = "white-metal"
type = "conductor"
alpha = 0.01
ndf = "ggx"
shadowing = "smith"
reflectance = [1, 1, 1]
[[shape]]
type = "sphere"
material = "white-metal"
center = [0, 0, 0]
radius = 1
[[light]]
type = "environment"
intensity = [1, 1, 1]
"#;

/// A scene by name: a bundled one, or `furnace` (`FURNACE`).
fn load(scene: &str) -> scene::Scene {
    if scene == "furnace" {
        common::load_manifest("energy-furnace", FURNACE, &[], SIZE)
    } else {
        common::load(&common::bundled(scene), SIZE.0, SIZE.1)
    }
}

/// (mean, variance of the mean) of the image's channel sum.
fn image_mean(scene: &str, mode: Mode, energy: Energy, iterations: u64) -> (f64, f64) {
    let config = RenderConfig {
        algorithm: Algorithm::Bpt,
        strategies: Strategies::Mis,
        max_depth: 8,
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
/// (the darkening of issue 21) on the furnace at N = 2 and 16; the bundled
/// scenes' darkening (measured 0.4-1.7 % at 64x48, N = 16) is within the
/// noise of a test-sized render and is only printed.
#[test]
fn lost_energy_darkens_the_image() {
    for scene in SCENES {
        let _ = compare(scene, Energy::Lost, 16);
    }
    for iterations in [2, 16] {
        let (z, ratio) = compare("furnace", Energy::Lost, iterations);
        let p = common::p_value(z);
        assert!(
            z < 0.0 && p < threshold(2),
            "furnace N={iterations}: regularized/unregularized {ratio:.4}, z {z:.2}, p {p:.2e}: not darker"
        );
    }
}
