//! Furnace test: inside a closed sphere of albedo a and uniform
//! emission Le, radiance is Le (1 + a + a^2 + ...) = Le / (1 - a) everywhere.
//! Every PT variant must converge to it, within a tolerance derived from
//! the measured variance.

use crate::common;

use std::fs;
use std::sync::atomic::{AtomicUsize, Ordering};

use integrators::{Mode, Strategies};

/// Renders the inside of a diffuse emitting sphere (albedo `a`, emission `le`).
fn furnace(a: f32, le: f32, strategies: Strategies) -> integrators::Film {
    // One folder per call: tests run in parallel in one process.
    static CALLS: AtomicUsize = AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, Ordering::Relaxed);
    let dir = std::env::temp_dir().join(format!("rlt-furnace-{}-{call}", std::process::id()));
    fs::create_dir_all(&dir).unwrap();
    let path = dir.join("scene.toml");
    fs::write(
        &path,
        format!(
            r#"
resolution = [8, 8]
[camera]
from = [0, 0, 0.3]
at = [0, 0.2, -1]
fov = 100
[[material]]
name = "wall"
type = "diffuse"
reflectance = [{a}, {a}, {a}]
emission = [{le}, {le}, {le}]
[[shape]]
type = "sphere"
material = "wall"
center = [0, 0, 0]
radius = 1
inside = true
rings = 96
tessellate = true
"#
        ),
    )
    .unwrap();
    let scene = common::load(&path, 8, 8);
    fs::remove_dir_all(&dir).unwrap();
    // Depth 80: the truncated tail a^80 Le/(1-a) is below 1e-20 of the result.
    common::render(scene, common::config(strategies, Mode::Off, 80), 256)
}

#[test]
fn closed_sphere_converges_to_le_over_one_minus_albedo() {
    let (a, le) = (0.6, 0.5);
    let expected = f64::from(le) / (1.0 - f64::from(a));
    for strategies in [Strategies::Mis, Strategies::NeeOnly, Strategies::BsdfOnly] {
        let film = furnace(a, le, strategies);
        let p = common::assert_film_equals(&film, expected, 2, &format!("{strategies:?}"));
        let mean = common::block_means(&film, 1)[0].0;
        eprintln!("{strategies:?}: mean {mean} expected {expected}, smallest p {p:.3}");
    }
}

/// The test fails when the estimator is wrong: a furnace of albedo 0.6 is
/// not at the value of albedo 0.62 (3 % of energy per bounce).
#[test]
fn furnace_detects_a_wrong_albedo() {
    let film = furnace(0.6, 0.5, Strategies::Mis);
    let wrong = 0.5 / (1.0 - 0.62);
    let result = std::panic::catch_unwind(|| common::assert_film_equals(&film, wrong, 2, "wrong"));
    assert!(result.is_err(), "a 3 % albedo error went unnoticed");
}
