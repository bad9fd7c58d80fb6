//! Stiff and degenerate inputs: every public function returns finite,
//! non-negative values (weights in [0, 1]) or a typed error, never NaN.

use crate::paths::{Ranges, TestPath, random_emitter};
use mis::*;
use stats::Pcg32;

fn sane(x: f64) -> bool {
    x.is_finite() && x >= 0.0
}

fn weight(x: f64) -> bool {
    sane(x) && x <= 1.0
}

fn state_is_sane(s: &SubpathState) -> bool {
    sane(s.d_vcm()) && sane(s.d_vc()) && sane(s.d_virtual())
}

const TAU_EDGE: f64 = 1.0 / (2.0 * std::f64::consts::PI) + 1e-12;

#[test]
fn stiff_random_paths_stay_finite() {
    let stiff = Ranges {
        pdf: (1e-30, 1e30),
        dist: (1e-20, 1e20),
        cos: (1e-12, 1.0),
        tau: (TAU_EDGE, 1e15),
        specular_probability: 0.2,
        regularized_probability: 0.6,
    };
    let heuristics = [
        Heuristic::BALANCE,
        Heuristic::POWER,
        Heuristic::power(3.0).unwrap(),
    ];
    let radii = [1e-150, 1e-300, 1e-5, 1e150, 1e300];
    let techniques = [
        Techniques::BPT,
        Techniques::MERGING,
        Techniques::VCM.with_virtual_merges(true),
        Techniques::BPT.with_virtual_merges(true),
    ];
    let mut rng = Pcg32::new(31, 1);
    let mut evaluated = 0;
    for n in 0..3000 {
        let config = MisConfig::new(
            techniques[n % techniques.len()],
            [1, 1_000_000, u64::MAX][n % 3],
            radii[n % radii.len()],
            heuristics[n % heuristics.len()],
        )
        .unwrap();
        let emitter = random_emitter(&mut rng);
        let mut path = TestPath::random(&mut rng, 1 + n % 9, emitter, &stiff);
        // Pin some bounds at the edges of the schedule's domain.
        for i in 1..path.k {
            if path.tau[i].is_finite() && rng.uniform_f64() < 0.5 {
                path.tau[i] = if rng.uniform_f64() < 0.5 {
                    TAU_EDGE
                } else {
                    1e15
                };
            }
        }
        for s in path.light_states(&config) {
            assert!(state_is_sane(&s), "{s:?}");
        }
        let (camera, _) = path.camera_states(&config);
        for s in camera.iter().flatten() {
            assert!(state_is_sane(s), "{s:?}");
        }
        for (t, w) in path.recursive_weights(&config) {
            assert!(weight(w), "{t:?}: {w} for {config:?} {path:?}");
            evaluated += 1;
        }
        // The reference works in log space and stays exact.
        let reference = mis::reference::weights(&config, &path.reference_path(&config)).unwrap();
        let total: f64 = reference.iter().map(|t| t.weight).sum();
        assert!(reference.iter().all(|t| weight(t.weight)));
        assert!(total == 0.0 || (total - 1.0).abs() < 1e-9, "{total}");
    }
    assert!(evaluated > 10_000);
}

#[test]
fn degenerate_inputs_never_give_nan() {
    let bad = [
        0.0,
        -1.0,
        f64::NAN,
        f64::INFINITY,
        f64::NEG_INFINITY,
        1e-320,
        1e-300,
        1e300,
        f64::MAX,
    ];
    let configs = [
        MisConfig::vcm(1, 1e-300, Heuristic::POWER).unwrap(),
        MisConfig::new(
            Techniques::VCM.with_virtual_merges(true),
            u64::MAX,
            1e300,
            Heuristic::BALANCE,
        )
        .unwrap(),
        MisConfig::new(Techniques::MERGING, 7, 1.0, Heuristic::power(0.5).unwrap()).unwrap(),
    ];
    for config in &configs {
        for &x in &bad {
            for &y in &[0.5, x] {
                let pdfs = VertexPdfs::regularized(x, y, x);
                let end = ConnectionEnd { pdfs, cos: x };
                for kind in [
                    EmitterKind::Area,
                    EmitterKind::Point,
                    EmitterKind::Directional,
                    EmitterKind::Environment,
                ] {
                    let emission = Emission {
                        kind,
                        direct_pdf_a: x,
                        emission_pdf_w: y,
                        cos_light: x,
                    };
                    let light_ray = SubpathRay::from_light(config, &emission);
                    let light = light_ray.arrive(config, x, y);
                    let camera_ray = SubpathRay::from_camera(config, x);
                    let camera = camera_ray.arrive(config, y, x);
                    let scatter = Scatter {
                        pdfs,
                        cos_out: y,
                        specular: false,
                    };
                    let specular = Scatter {
                        specular: true,
                        ..scatter
                    };
                    let next = camera.scatter(config, &scatter);
                    let after = next.arrive(config, x, x);
                    let after_specular = light.scatter(config, &specular).arrive(config, y, x);
                    for s in [light, camera, after, after_specular] {
                        assert!(state_is_sane(&s), "{s:?}");
                    }
                    let hit = EmitterHit {
                        direct_pdf_a: x,
                        emission_pdf_w: y,
                    };
                    let sample = LightSample {
                        kind,
                        direct_pdf_w: x,
                        emission_pdf_w: y,
                        cos_light: x,
                    };
                    let weights = [
                        config.emitter_hit_weight(&after, &hit),
                        config.environment_hit_weight(&next, &hit),
                        config.next_event_weight(&after, &end, &sample),
                        config.connection_weight(&light, &end, &after, &end, x),
                        config.light_tracing_weight(&after_specular, &end, x, y),
                        config.merge_weight(&light, &after, &pdfs),
                        acceptance_probability(x, y),
                        acceptance_probability(y, x),
                        config.acceptance(x, y),
                    ];
                    for w in weights {
                        assert!(weight(w), "{w} from x = {x}, y = {y}, {config:?}");
                    }
                    assert!(sane(acceptance_area(x, y, x)));
                    assert!(sane(acceptance_area(y, x, y)));
                }
            }
        }
    }
}

#[test]
fn heuristics_with_stiff_pdfs() {
    let mut rng = Pcg32::new(2, 2);
    for _ in 0..2000 {
        let n = 1 + (rng.uniform_f64() * 6.0) as usize;
        let set: Vec<Sampled> = (0..n)
            .map(|_| Sampled::new(rng.log_uniform(1e-3, 1e6), rng.log_uniform(1e-30, 1e30)))
            .collect();
        for h in [
            Heuristic::BALANCE,
            Heuristic::POWER,
            Heuristic::power(7.0).unwrap(),
        ] {
            let mut total = 0.0;
            for i in 0..n {
                let others: Vec<Sampled> = set
                    .iter()
                    .enumerate()
                    .filter(|&(j, _)| j != i)
                    .map(|(_, &s)| s)
                    .collect();
                let w = h.weight_among(set[i], &others);
                assert!(weight(w));
                total += w;
            }
            // Saturation (1e300) can only lose weights below 1e-300 relative.
            assert!((total - 1.0).abs() < 1e-9, "{total} for {set:?}");
        }
    }
}
