//! The recursion against the explicit reference, and the sum-to-1 invariant,
//! on random paths of 2..10 vertices.

use crate::paths::{Ranges, TestPath, random_emitter, reference_by_executed};
use mis::reference::Technique;
use mis::*;
use stats::Pcg32;

/// Relative tolerance of recursion against reference, and of the sum to 1.
const TOLERANCE: f64 = 1e-6;

/// What one batch of random paths exercised.
#[derive(Default, Debug)]
struct Coverage {
    paths: usize,
    techniques: usize,
    /// Paths no technique can produce (all vertices that could end a
    /// sub-path are specular and the emitter cannot be hit).
    unproducible: usize,
    /// Executed connections whose weight includes a virtual merge of
    /// measurable weight (> 1e-3).
    virtual_merges: usize,
    merges: usize,
    specular_vertices: usize,
    max_error: f64,
}

fn check_path(config: &MisConfig, path: &TestPath, cov: &mut Coverage) {
    assert!(
        path.max_ratio_exponent(config) < 280.0,
        "test ranges too wide for an exact comparison: {}",
        path.max_ratio_exponent(config)
    );
    let reference_path = path.reference_path(config);
    let expected = reference_by_executed(config, &reference_path);
    let got = path.recursive_weights(config);
    assert_eq!(
        expected.keys().collect::<Vec<_>>(),
        got.keys().collect::<Vec<_>>(),
        "technique sets differ for {path:?}"
    );
    let ref_sum: f64 = expected.values().sum();
    let sum: f64 = got.values().sum();
    cov.paths += 1;
    cov.techniques += got.len();
    cov.specular_vertices += path.specular.iter().filter(|&&s| s).count();
    if ref_sum == 0.0 {
        cov.unproducible += 1;
        assert!(got.values().all(|&w| w == 0.0), "{got:?}");
        return;
    }
    assert!((ref_sum - 1.0).abs() < 1e-12, "reference sums to {ref_sum}");
    assert!(
        (sum - 1.0).abs() < TOLERANCE,
        "recursive weights sum to {sum} for {config:?} {path:?}: {got:?}"
    );
    for (technique, &w) in &got {
        let e = expected[technique];
        let err = (w - e).abs() / e.max(1e-300);
        cov.max_error = cov.max_error.max(err.min(1.0));
        assert!(
            (w - e).abs() <= TOLERANCE * e + 1e-300,
            "{technique:?}: recursion {w:e}, reference {e:e}, config {config:?}, path {path:?}"
        );
        assert!((0.0..=1.0).contains(&w));
        if matches!(technique, Technique::Merge { .. }) && w > 1e-3 {
            cov.merges += 1;
        }
    }
    // Virtual merges with a visible share of their connection's weight.
    for tw in mis::reference::weights(config, &reference_path).unwrap() {
        if matches!(tw.technique, Technique::VirtualMerge { .. }) && tw.weight > 1e-3 {
            cov.virtual_merges += 1;
        }
    }
}

fn random_config(rng: &mut Pcg32, techniques: Techniques, heuristic: Heuristic) -> MisConfig {
    let light_paths = rng.log_uniform(1.0, 1e6) as u64;
    let radius = rng.log_uniform(1e-4, 10.0);
    MisConfig::new(techniques, light_paths.max(1), radius, heuristic).unwrap()
}

fn run_batch(
    seed: u64,
    techniques: Techniques,
    heuristic: Heuristic,
    ranges: &Ranges,
    paths: usize,
) -> Coverage {
    let mut rng = Pcg32::new(seed, 7);
    let mut cov = Coverage::default();
    for n in 0..paths {
        let config = random_config(&mut rng, techniques, heuristic);
        let k = 1 + n % 9; // 2..10 vertices
        let emitter = random_emitter(&mut rng);
        let path = TestPath::random(&mut rng, k, emitter, ranges);
        check_path(&config, &path, &mut cov);
    }
    cov
}

const ALL_TECHNIQUE_SETS: [Techniques; 5] = [
    Techniques::BPT,
    Techniques::MERGING,
    Techniques::VCM,
    Techniques::BPT.with_virtual_merges(true),
    Techniques::VCM.with_virtual_merges(true),
];

#[test]
fn recursion_equals_reference_and_weights_sum_to_one() {
    let mut total = Coverage::default();
    for (t, techniques) in ALL_TECHNIQUE_SETS.iter().enumerate() {
        for (h, heuristic) in [Heuristic::BALANCE, Heuristic::POWER].iter().enumerate() {
            let seed = 1000 + 10 * t as u64 + h as u64;
            let cov = run_batch(seed, *techniques, *heuristic, &Ranges::WIDE, 900);
            assert!(cov.max_error <= TOLERANCE);
            if techniques.virtual_merges {
                assert!(cov.virtual_merges > 100, "{techniques:?}: {cov:?}");
            }
            if techniques.merging {
                assert!(cov.merges > 100, "{techniques:?}: {cov:?}");
            }
            total.paths += cov.paths;
            total.techniques += cov.techniques;
            total.unproducible += cov.unproducible;
            total.specular_vertices += cov.specular_vertices;
            total.max_error = total.max_error.max(cov.max_error);
            total.virtual_merges += cov.virtual_merges;
            total.merges += cov.merges;
        }
    }
    eprintln!("coverage: {total:?}");
    assert_eq!(total.paths, 5 * 2 * 900);
    assert!(total.specular_vertices > 1000);
    // Most paths can be produced by several techniques.
    assert!(total.techniques > 3 * total.paths, "{total:?}");
    assert!(total.unproducible < total.paths / 10, "{total:?}");
}

#[test]
fn other_exponents_and_narrow_or_wide_ranges() {
    // beta = 3 with narrower pdfs; beta = 0.5 and 1 with pdfs over 16 decades.
    let narrow = Ranges {
        pdf: (1e-2, 1e2),
        ..Ranges::WIDE
    };
    let wide = Ranges {
        pdf: (1e-8, 1e8),
        dist: (1e-2, 1e2),
        cos: (1e-3, 1.0),
        ..Ranges::WIDE
    };
    let cases = [
        (Heuristic::power(3.0).unwrap(), narrow),
        (Heuristic::power(0.5).unwrap(), wide),
        (Heuristic::BALANCE, wide),
    ];
    for (c, (heuristic, ranges)) in cases.iter().enumerate() {
        let techniques = Techniques::VCM.with_virtual_merges(true);
        let cov = run_batch(77 + c as u64, techniques, *heuristic, ranges, 600);
        assert!(cov.virtual_merges > 50, "{cov:?}");
    }
}

#[test]
fn all_vertices_regularized_uniform_mode() {
    // SPEC `uniform` mode: every non-specular vertex has the same tau.
    let mut rng = Pcg32::new(5, 11);
    let mut cov = Coverage::default();
    for n in 0..600 {
        let config = random_config(
            &mut rng,
            Techniques::VCM.with_virtual_merges(true),
            Heuristic::POWER,
        );
        let k = 1 + n % 9;
        let emitter = random_emitter(&mut rng);
        let mut path = TestPath::random(&mut rng, k, emitter, &Ranges::WIDE);
        let tau = rng.log_uniform(0.2, 1e3);
        for i in 1..k {
            path.tau[i] = if path.specular[i] {
                NOT_REGULARIZED
            } else {
                tau
            };
        }
        check_path(&config, &path, &mut cov);
    }
    assert!(cov.virtual_merges > 200, "{cov:?}");
}

#[test]
fn infinite_tau_is_the_same_as_virtual_merges_off() {
    let mut rng = Pcg32::new(9, 3);
    for n in 0..300 {
        let radius = rng.log_uniform(1e-3, 1.0);
        let on = MisConfig::new(
            Techniques::VCM.with_virtual_merges(true),
            1000,
            radius,
            Heuristic::POWER,
        )
        .unwrap();
        let off = MisConfig::new(Techniques::VCM, 1000, radius, Heuristic::POWER).unwrap();
        let emitter = random_emitter(&mut rng);
        let mut path = TestPath::random(&mut rng, 1 + n % 9, emitter, &Ranges::WIDE);
        let with_tau = path.recursive_weights(&on);
        let plain = path.recursive_weights(&off);
        path.tau.iter_mut().for_each(|t| *t = NOT_REGULARIZED);
        assert_eq!(path.recursive_weights(&on), plain);
        // With finite tau somewhere, virtual merges add techniques that are
        // executed as connections: hits and merges can only lose weight, the
        // connections together can only gain.
        let connections = |w: &std::collections::BTreeMap<Technique, f64>| -> f64 {
            w.iter()
                .filter(|(t, _)| matches!(t, Technique::Connection { .. }))
                .map(|(_, w)| w)
                .sum()
        };
        assert!(connections(&with_tau) >= connections(&plain) - 1e-12);
        for (technique, &w) in &with_tau {
            if !matches!(technique, Technique::Connection { .. }) {
                assert!(w <= plain[technique] * (1.0 + 1e-12) + 1e-300);
            }
        }
    }
}
