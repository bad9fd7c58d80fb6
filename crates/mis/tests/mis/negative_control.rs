//! Negative controls on the counter-example of spec-review O2: the path
//! camera - x1 (regularized) - x2 - light, written here from the light:
//! x_0 (area light), x_1, x_2 (regularized, tau = 50), x_3 (camera).
//!
//! The virtual merge is the one on the connection (x_1, x_2), sampled at x_2
//! towards x_1 with pdf p = `to_light[2]`, p_acc = p / tau.

use crate::paths::{TestPath, reference_by_executed};
use mis::reference::Technique;
use mis::*;
use std::collections::BTreeMap;

const TAU: f64 = 50.0;
/// p(x_2 -> x_1): p_acc = 0.5 / 50 = 0.01.
const P_TO_LIGHT: f64 = 0.5;
/// p(x_2 -> camera): tiny, so that the virtual merge at x_2 towards the camera
/// (on the light-tracing edge) has acceptance 2e-8.
const P_TO_CAMERA: f64 = 1e-6;

fn o2_path() -> TestPath {
    TestPath {
        k: 3,
        emitter: EmitterKind::Area,
        direct: 0.7,
        emit_pos: 0.5,
        emit_dir: 0.3,
        camera_pdf_w: 2.0,
        dist: vec![1.0, 1.5, 2.0],
        cos_minus: vec![1.0, 0.6, 0.8, 1.0],
        cos_plus: vec![0.9, 0.7, 0.5, 1.0],
        to_camera: vec![1.0, 0.4, P_TO_CAMERA, 1.0],
        to_light: vec![1.0, 0.6, P_TO_LIGHT, 1.0],
        specular: vec![false; 4],
        tau: vec![NOT_REGULARIZED, NOT_REGULARIZED, TAU, NOT_REGULARIZED],
    }
}

fn config(virtual_merges: bool) -> MisConfig {
    let t = Techniques::BPT.with_virtual_merges(virtual_merges);
    MisConfig::new(t, 1, 0.0, Heuristic::BALANCE).unwrap()
}

const HIT: Technique = Technique::EmitterHit;
const NEE: Technique = Technique::Connection { light_vertex: 0 };
const CONNECTION: Technique = Technique::Connection { light_vertex: 1 };
const LIGHT_TRACING: Technique = Technique::Connection { light_vertex: 2 };

fn sum(w: &BTreeMap<Technique, f64>) -> f64 {
    w.values().sum()
}

#[test]
fn virtual_merge_model_sums_to_one_on_o2() {
    let path = o2_path();
    let c = config(true);
    let got = path.recursive_weights(&c);
    let expected = reference_by_executed(&c, &path.reference_path(&c));
    assert_eq!(got.len(), 4);
    assert!((sum(&got) - 1.0).abs() < 1e-12, "{got:?}");
    for (t, w) in &got {
        assert!((w - expected[t]).abs() < 1e-12 * expected[t], "{t:?}");
    }
}

/// The shortcut where the supplemental places it: the camera sub-path stores
/// max(p, tau) = p / p_acc in place of the pdf it sampled at x_2, and nothing
/// else changes (connections and light tracing evaluate x_2's BSDF afresh).
/// The hit and next-event techniques then see the path pdfs with 1/p_acc,
/// the connection and light tracing without: the weights no longer sum to 1.
#[test]
fn shortcut_as_stored_pdf_breaks_sum_to_one() {
    let original = o2_path();
    let mut stored = original.clone();
    stored.to_light[2] = P_TO_LIGHT.max(TAU);
    let c = config(false);
    let fresh = original.recursive_weights(&c);
    let with_stored = stored.recursive_weights(&c);
    let broken = [
        with_stored[&HIT],
        with_stored[&NEE],
        fresh[&CONNECTION],
        fresh[&LIGHT_TRACING],
    ];
    let total: f64 = broken.iter().sum();
    assert!(
        (total - 1.0).abs() > 0.1,
        "the shortcut was expected to break the partition of unity, sum = {total}"
    );
    // The model, on the same path, sums to 1.
    assert!((sum(&original.recursive_weights(&config(true))) - 1.0).abs() < 1e-12);
}

/// The shortcut used consistently by every technique (both pdfs of x_2
/// replaced everywhere) is still a partition of unity, but not the virtual
/// merge's: it divides by p_acc only the path pdfs that contain x_2's pdf
/// towards x_1 (hit, next-event estimation), so light tracing -- which
/// contains no pdf of x_2 -- gains a factor 1/p_acc against them. Under the
/// model, the techniques the virtual merge does not belong to keep their
/// ratios (up to the light-tracing edge's own virtual merge, 1 + 2e-8).
#[test]
fn consistent_shortcut_is_a_different_partition() {
    let original = o2_path();
    let mut shortcut = original.clone();
    shortcut.to_light[2] = P_TO_LIGHT.max(TAU);
    shortcut.to_camera[2] = P_TO_CAMERA.max(TAU);
    let plain = original.recursive_weights(&config(false));
    let model = original.recursive_weights(&config(true));
    let cut = shortcut.recursive_weights(&config(false));
    assert!((sum(&cut) - 1.0).abs() < 1e-12);

    let ratio = |w: &BTreeMap<Technique, f64>| w[&HIT] / w[&LIGHT_TRACING];
    let p_acc = P_TO_LIGHT / TAU;
    let p_acc_lt = P_TO_CAMERA / TAU;
    let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
    // Model: unchanged except for light tracing's own virtual merge.
    assert!(close(ratio(&model), ratio(&plain) / (1.0 + p_acc_lt)));
    // Shortcut: hit against light tracing gains exactly 1/p_acc = 100.
    assert!(close(ratio(&cut), ratio(&plain) / p_acc));
    // And the connection the virtual merge belongs to gets a different weight.
    assert!((cut[&CONNECTION] - model[&CONNECTION]).abs() > 0.05 * model[&CONNECTION]);
}

/// A virtual merge that only its own connection knows about (the other
/// techniques' sub-path quantities lack it -- e.g. an implementation that
/// multiplies the connection's own weight by (1 + p_acc) but forgets the
/// d_vcm / d_virtual terms) breaks the sum to 1.
#[test]
fn virtual_merge_known_only_to_its_connection_breaks_sum_to_one() {
    let path = o2_path();
    let with = path.recursive_weights(&config(true));
    let mut broken = path.recursive_weights(&config(false));
    broken.insert(CONNECTION, with[&CONNECTION]);
    // 1000 times the tolerance the sum-to-1 tests use.
    assert!(
        sum(&broken) - 1.0 > 1e-3,
        "sum = {}, the check was expected to catch this",
        sum(&broken)
    );
}
