//! Sweeps through the `mis` crate: heuristics on extreme pdfs, and random
//! sub-paths with pdfs 1e-30..1e30, cosines down to 1e-9 and distances
//! 1e-6..1e6 through every public weight function; the explicit reference
//! on random paths.

use std::time::Instant;

use mis::reference::{self, PathVertex};
use mis::{
    ConnectionEnd, Emission, EmitterHit, EmitterKind, Heuristic, LightSample, MisConfig,
    NOT_REGULARIZED, Sampled, Scatter, SubpathRay, SubpathState, Techniques, VertexPdfs,
    acceptance_area, acceptance_probability, balance_heuristic, power_heuristic,
};

use super::tally::{Row, Tally};
use super::{Budget, Rng, log_space};

/// Every row of this module.
pub fn rows(budget: Budget) -> Vec<Row> {
    let mut rows = vec![heuristic_row(budget)];
    rows.extend(subpath_rows(budget));
    rows.push(reference_row(budget));
    rows
}

/// The heuristic weight in log space (exact where the library's guards are
/// exact): (n p)^beta / sum_j (n_j p_j)^beta; 0 when n p = 0.
fn weight_reference(beta: f64, this: (f64, f64), others: &[(f64, f64)]) -> f64 {
    let ln = |(n, p): (f64, f64)| n.ln() + p.ln();
    if this.0 * this.1 == 0.0 {
        return 0.0;
    }
    let own = ln(this);
    let rest: f64 = others
        .iter()
        .filter(|(n, p)| n * p > 0.0)
        .map(|&o| (beta * (ln(o) - own)).exp())
        .sum();
    1.0 / (1.0 + rest)
}

/// Balance, power and general power heuristics on a grid of pdfs
/// 0, 1e-30..1e30 (and invalid inputs: NaN, -1, inf); acceptance
/// probability and area on extreme inputs.
fn heuristic_row(budget: Budget) -> Row {
    let start = Instant::now();
    let mut t = Tally::default();
    let mut pdfs = log_space(1e-30, 1e30, budget.n(31, 121));
    pdfs.push(0.0);
    let invalid = [f64::NAN, -1.0, f64::INFINITY];
    let all: Vec<f64> = pdfs.iter().copied().chain(invalid).collect();
    let heuristics = [
        Heuristic::BALANCE,
        Heuristic::POWER,
        Heuristic::power(0.5).expect("valid exponent"),
        Heuristic::power(3.0).expect("valid exponent"),
    ];
    let counts = [1.0, 1e6];
    for &a in &all {
        for &b in &all {
            let valid = a.is_finite() && a >= 0.0 && b.is_finite() && b >= 0.0;
            for (name, w, beta) in [
                (
                    "balance_heuristic",
                    balance_heuristic as fn(f64, f64) -> f64,
                    1.0,
                ),
                ("power_heuristic", power_heuristic, 2.0),
            ] {
                let call = || format!("{name}({a:?}, {b:?})");
                t.guard(call, |t| {
                    t.evaluation();
                    let got = w(a, b);
                    if t.value(got, call) {
                        t.require(got <= 1.0, || format!("{} = {got:e} > 1", call()));
                    }
                    if valid {
                        t.compare(got, weight_reference(beta, (1.0, a), &[(1.0, b)]), call);
                    }
                });
            }
            for h in heuristics {
                for &c in &all {
                    for &n in &counts {
                        let this = Sampled::new(n, a);
                        let others = [Sampled::one(b), Sampled::new(n, c)];
                        let call = || format!("{h:?}.weight_among({this:?}, &{others:?})");
                        t.guard(call, |t| {
                            t.evaluation();
                            let got = h.weight_among(this, &others);
                            if t.value(got, call) {
                                t.require(got <= 1.0, || format!("{} = {got:e} > 1", call()));
                            }
                            if valid && c.is_finite() && c >= 0.0 {
                                let r = weight_reference(h.beta(), (n, a), &[(1.0, b), (n, c)]);
                                t.compare(got, r, call);
                            }
                        });
                    }
                }
            }
            // Acceptance of a virtual merge: pdf a, tau b; area with distance a, cos b.
            let call = || format!("acceptance_probability({a:?}, {b:?})");
            t.guard(call, |t| {
                t.evaluations(2);
                let p = acceptance_probability(a, b);
                if t.value(p, call) {
                    t.require(p <= 1.0, || format!("{} = {p:e} > 1", call()));
                }
                let area = acceptance_area(b, a, a.min(1.0));
                t.value(area, || {
                    format!("acceptance_area({b:?}, {a:?}, {:?})", a.min(1.0))
                });
            });
        }
    }
    Row {
        name: "mis: heuristics, acceptance".into(),
        covers: format!(
            "balance_heuristic, power_heuristic, Heuristic::weight_among (beta 1, 2, 0.5, 3; counts 1, 1e6; 3 techniques), \
             acceptance_probability, acceptance_area; pdfs 0 and 1e-30..1e30 ({} values), plus NaN, -1, inf",
            pdfs.len() - 1
        ),
        other: "weight or acceptance > 1",
        reference: Some("f64 log-space heuristic weight (valid inputs)"),
        tally: t,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// The random draws of the sub-path sweep.
struct Draw<'a> {
    rng: &'a mut Rng,
}

impl Draw<'_> {
    /// A pdf: 0 (5 %) or log-uniform in 1e-30..1e30.
    fn pdf(&mut self) -> f64 {
        if self.rng.chance(0.05) {
            0.0
        } else {
            self.rng.log_uniform(1e-30, 1e30)
        }
    }
    /// A |cos|: 0 (5 %) or log-uniform in 1e-9..1.
    fn cos(&mut self) -> f64 {
        if self.rng.chance(0.05) {
            0.0
        } else {
            self.rng.log_uniform(1e-9, 1.0)
        }
    }
    fn distance(&mut self) -> f64 {
        self.rng.log_uniform(1e-6, 1e6)
    }
    /// tau: not regularized (50 %) or 1/(2 pi) (1 + 1e-12)..1e20.
    fn tau(&mut self) -> f64 {
        if self.rng.chance(0.5) {
            NOT_REGULARIZED
        } else {
            self.rng.log_uniform(0.159_154_943_091_9, 1e20)
        }
    }
    fn pdfs(&mut self) -> VertexPdfs {
        VertexPdfs::regularized(self.pdf(), self.pdf(), self.tau())
    }
    fn kind(&mut self) -> EmitterKind {
        [
            EmitterKind::Area,
            EmitterKind::Point,
            EmitterKind::Directional,
            EmitterKind::Environment,
        ][self.rng.below(4)]
    }
    fn config(&mut self) -> Result<MisConfig, String> {
        let techniques = [Techniques::BPT, Techniques::MERGING, Techniques::VCM][self.rng.below(3)];
        let techniques =
            techniques.with_virtual_merges(techniques.connections && self.rng.chance(0.5));
        let heuristic = [Heuristic::BALANCE, Heuristic::POWER][self.rng.below(2)];
        let light_paths = self.rng.log_uniform(1.0, 1e7) as u64;
        let radius = if techniques.merging {
            self.rng.log_uniform(1e-6, 1e6)
        } else {
            0.0
        };
        MisConfig::new(techniques, light_paths, radius, heuristic).map_err(|e| {
            format!("MisConfig::new({techniques:?}, {light_paths}, {radius:?}, {heuristic:?}) -> Err({e})")
        })
    }
}

/// One step of a random sub-path, kept to describe a problem.
#[derive(Debug)]
#[expect(
    dead_code,
    reason = "the fields are read through Debug, in problem descriptions"
)]
enum Step {
    FromLight(Emission),
    FromCamera(f64),
    Arrive { distance: f64, cos_in: f64 },
    Scatter(Scatter),
}

fn check_state(t: &mut Tally, state: &SubpathState, describe: &dyn Fn() -> String) {
    for (name, x) in [
        ("d_vcm", state.d_vcm()),
        ("d_vc", state.d_vc()),
        ("d_virtual", state.d_virtual()),
    ] {
        t.value(x, || format!("{name} after {}", describe()));
    }
}

fn check_weight(t: &mut Tally, w: f64, describe: impl Fn() -> String) {
    t.evaluation();
    if t.value(w, &describe) {
        t.require(w <= 1.0, || format!("{} = {w:e} > 1", describe()));
    }
}

/// Random light and camera sub-paths through `SubpathRay` / `SubpathState`,
/// and every weight function at every vertex pair.
fn subpath_rows(budget: Budget) -> [Row; 2] {
    let start = Instant::now();
    let mut states = Tally::default();
    let mut weights = Tally::default();
    let paths = budget.n(3_000, 60_000);
    let mut rng = Rng::new(0x005E_ED0F_0015);
    for index in 0..paths {
        let mut d = Draw { rng: &mut rng };
        let config = match d.config() {
            Ok(c) => c,
            Err(e) => {
                states.require(false, || e);
                continue;
            }
        };
        let context = |steps: &[Step]| format!("path {index}, {config:?}, steps {steps:?}");
        let mut path = SubpathCheck {
            config: &config,
            states: &mut states,
            weights: &mut weights,
            context: &context,
        };
        let (light, light_steps) = path.light_subpath(&mut d);
        path.light_tracing(&mut d, &light, &light_steps);
        path.camera_subpath(&mut d, &light, &light_steps);
    }
    subpath_report(paths, states, weights, start.elapsed().as_secs_f64())
}

/// A light sub-path vertex: its state, and the pdfs and |cos| of a
/// connection to it.
type LightVertex = (SubpathState, VertexPdfs, f64);

/// One random configuration of the sub-path sweep and where it counts.
struct SubpathCheck<'a> {
    config: &'a MisConfig,
    /// Counts of `SubpathRay::arrive` and `SubpathState::scatter`.
    states: &'a mut Tally,
    /// Counts of the weight functions.
    weights: &'a mut Tally,
    /// Describes the path so far from its steps.
    context: &'a dyn Fn(&[Step]) -> String,
}

impl SubpathCheck<'_> {
    /// A light sub-path of 0..6 random vertices, and its steps.
    fn light_subpath(&mut self, d: &mut Draw) -> (Vec<LightVertex>, Vec<Step>) {
        let (config, context) = (self.config, self.context);
        let mut light_steps = Vec::new();
        let emission = Emission {
            kind: d.kind(),
            direct_pdf_a: d.pdf(),
            emission_pdf_w: d.pdf(),
            cos_light: d.cos(),
        };
        light_steps.push(Step::FromLight(emission));
        let mut light = Vec::new();
        let mut ray = Some(SubpathRay::from_light(config, &emission));
        for _ in 0..d.rng.below(7) {
            let Some(r) = ray else { break };
            let (distance, cos_in) = (d.distance(), d.cos());
            light_steps.push(Step::Arrive { distance, cos_in });
            let state = self.states.guard(
                || context(&light_steps),
                |t| {
                    t.evaluation();
                    let s = r.arrive(config, distance, cos_in);
                    check_state(t, &s, &|| context(&light_steps));
                    s
                },
            );
            let Some(state) = state else { break };
            light.push((state, d.pdfs(), d.cos()));
            let scatter = Scatter {
                pdfs: d.pdfs(),
                cos_out: d.cos(),
                specular: d.rng.chance(0.2),
            };
            light_steps.push(Step::Scatter(scatter));
            ray = self.states.guard(
                || context(&light_steps),
                |t| {
                    t.evaluation();
                    state.scatter(config, &scatter)
                },
            );
        }
        (light, light_steps)
    }

    /// Light tracing from every light vertex.
    fn light_tracing(&mut self, d: &mut Draw, light: &[LightVertex], light_steps: &[Step]) {
        let (config, context) = (self.config, self.context);
        for (i, (state, pdfs, cos)) in light.iter().enumerate() {
            let end = ConnectionEnd {
                pdfs: *pdfs,
                cos: *cos,
            };
            let (camera_pdf_w, distance) = (d.pdf(), d.distance());
            let call = || {
                format!(
                    "light_tracing_weight(light vertex {i}, {end:?}, {camera_pdf_w:?}, {distance:?}) on {}",
                    context(light_steps)
                )
            };
            self.weights.guard(call, |t| {
                check_weight(
                    t,
                    config.light_tracing_weight(state, &end, camera_pdf_w, distance),
                    call,
                );
            });
        }
    }

    /// A camera sub-path of 1..6 random vertices with every technique at
    /// every vertex.
    fn camera_subpath(&mut self, d: &mut Draw, light: &[LightVertex], light_steps: &[Step]) {
        let (config, context) = (self.config, self.context);
        let camera_pdf = d.pdf();
        let mut camera_steps = vec![Step::FromCamera(camera_pdf)];
        let mut ray = Some(SubpathRay::from_camera(config, camera_pdf));
        for _ in 0..1 + d.rng.below(6) {
            let Some(r) = ray else { break };
            let hit = EmitterHit {
                direct_pdf_a: d.pdf(),
                emission_pdf_w: d.pdf(),
            };
            let call = || {
                format!(
                    "environment_hit_weight({hit:?}) on camera {}",
                    context(&camera_steps)
                )
            };
            self.weights.guard(call, |t| {
                check_weight(t, config.environment_hit_weight(&r, &hit), call)
            });
            let (distance, cos_in) = (d.distance(), d.cos());
            camera_steps.push(Step::Arrive { distance, cos_in });
            let describe = || format!("camera {}", context(&camera_steps));
            let Some(state) = self.states.guard(describe, |t| {
                t.evaluation();
                let s = r.arrive(config, distance, cos_in);
                check_state(t, &s, &describe);
                s
            }) else {
                break;
            };
            self.camera_vertex(d, &state, &describe);
            let light_context = || context(light_steps);
            self.connections(d, light, &state, &describe, &light_context);
            let scatter = Scatter {
                pdfs: d.pdfs(),
                cos_out: d.cos(),
                specular: d.rng.chance(0.2),
            };
            camera_steps.push(Step::Scatter(scatter));
            let describe = || format!("camera {}", context(&camera_steps));
            ray = self.states.guard(describe, |t| {
                t.evaluation();
                state.scatter(config, &scatter)
            });
        }
    }

    /// The weights of a camera vertex alone: hitting an emitter there, and
    /// next event estimation from it.
    fn camera_vertex(&mut self, d: &mut Draw, state: &SubpathState, describe: &dyn Fn() -> String) {
        let config = self.config;
        let hit = EmitterHit {
            direct_pdf_a: d.pdf(),
            emission_pdf_w: d.pdf(),
        };
        let call = || format!("emitter_hit_weight({hit:?}) on {}", describe());
        self.weights.guard(call, |t| {
            check_weight(t, config.emitter_hit_weight(state, &hit), call)
        });
        let end = ConnectionEnd {
            pdfs: d.pdfs(),
            cos: d.cos(),
        };
        let sample = LightSample {
            kind: d.kind(),
            direct_pdf_w: d.pdf(),
            emission_pdf_w: d.pdf(),
            cos_light: d.cos(),
        };
        let call = || format!("next_event_weight({end:?}, {sample:?}) on {}", describe());
        self.weights.guard(call, |t| {
            check_weight(t, config.next_event_weight(state, &end, &sample), call);
        });
    }

    /// The weights of a camera vertex with every light vertex: connection
    /// and merge.
    fn connections(
        &mut self,
        d: &mut Draw,
        light: &[LightVertex],
        state: &SubpathState,
        describe: &dyn Fn() -> String,
        light_context: &dyn Fn() -> String,
    ) {
        let config = self.config;
        for (i, (light_state, light_pdfs, light_cos)) in light.iter().enumerate() {
            let light_end = ConnectionEnd {
                pdfs: *light_pdfs,
                cos: *light_cos,
            };
            let (camera_end, distance) = (
                ConnectionEnd {
                    pdfs: d.pdfs(),
                    cos: d.cos(),
                },
                d.distance(),
            );
            let call = || {
                format!(
                    "connection_weight(light vertex {i}, {light_end:?}, {camera_end:?}, {distance:?}) on {}; light {}",
                    describe(),
                    light_context()
                )
            };
            self.weights.guard(call, |t| {
                let w =
                    config.connection_weight(light_state, &light_end, state, &camera_end, distance);
                check_weight(t, w, call);
            });
            let merge = d.pdfs();
            let call = || {
                format!(
                    "merge_weight(light vertex {i}, {merge:?}) on {}; light {}",
                    describe(),
                    light_context()
                )
            };
            self.weights.guard(call, |t| {
                check_weight(t, config.merge_weight(light_state, state, &merge), call);
            });
        }
    }
}

/// The two rows of [`subpath_rows`].
fn subpath_report(paths: usize, states: Tally, weights: Tally, seconds: f64) -> [Row; 2] {
    let domain = format!(
        "{paths} random configurations (BPT, merging, VCM, +- virtual merges; balance, power; N 1..1e7; radius 1e-6..1e6) \
         with a light sub-path of 0..6 and a camera sub-path of 1..6 vertices; pdfs 0 (5 %) or 1e-30..1e30, \
         |cos| 0 (5 %) or 1e-9..1, distances 1e-6..1e6, tau inf (50 %) or 1/(2 pi)..1e20, 20 % specular scatters"
    );
    [
        Row {
            name: "mis: SubpathRay::arrive, SubpathState::scatter".into(),
            covers: format!("{domain}; d_vcm, d_vc, d_virtual of every vertex"),
            other: "a valid configuration rejected by MisConfig::new",
            reference: None,
            tally: states,
            seconds,
        },
        Row {
            name: "mis: weights (emitter, environment, NEE, connection, light tracing, merge)"
                .into(),
            covers: format!("{domain}; every weight function at every vertex (pair)"),
            other: "weight > 1",
            reference: None,
            tally: weights,
            seconds: 0.0,
        },
    ]
}

/// `mis::reference::weights` on random paths with extreme pdfs: each weight
/// in [0, 1], and they sum to 1 (or are all 0).
fn reference_row(budget: Budget) -> Row {
    let start = Instant::now();
    let mut t = Tally::default();
    let mut rng = Rng::new(0x0DD_BA11);
    let paths = budget.n(3_000, 60_000);
    for index in 0..paths {
        let mut d = Draw { rng: &mut rng };
        let Ok(config) = d.config() else { continue };
        let k = 1 + d.rng.below(10);
        let emitter = d.kind();
        let direct_pdf = d.pdf();
        let vertices: Vec<PathVertex> = (0..=k)
            .map(|_| PathVertex {
                pdf_light: d.pdf(),
                pdf_camera: d.pdf(),
                specular: d.rng.chance(0.2),
                accept_towards_camera: if d.rng.chance(0.5) {
                    0.0
                } else {
                    d.rng.uniform()
                },
                accept_towards_light: if d.rng.chance(0.5) {
                    0.0
                } else {
                    d.rng.uniform()
                },
            })
            .collect();
        let path = reference::Path {
            emitter,
            direct_pdf,
            vertices,
        };
        let call = || format!("reference::weights(&{config:?}, &{path:?}) (path {index})");
        t.guard(call, |t| {
            t.evaluation();
            match reference::weights(&config, &path) {
                Err(e) => {
                    t.require(false, || format!("{} -> Err({e})", call()));
                }
                Ok(list) => {
                    let mut sum = 0.0;
                    for w in &list {
                        if t.value(w.weight, || format!("{:?} of {}", w.technique, call())) {
                            t.require(w.weight <= 1.0, || {
                                format!("{:?} = {:e} > 1 in {}", w.technique, w.weight, call())
                            });
                            sum += w.weight;
                        }
                    }
                    if sum > 0.0 {
                        t.compare(sum, 1.0, || {
                            format!("sum of {} weights of {}", list.len(), call())
                        });
                    } else {
                        t.note("no technique can produce the path (all weights 0)");
                    }
                }
            }
        });
    }
    Row {
        name: "mis: reference::weights".into(),
        covers: format!(
            "{paths} random paths of 2..11 vertices, configurations as above; per-vertex area pdfs 0 (5 %) or 1e-30..1e30, \
             20 % specular, acceptances 0 or uniform"
        ),
        other: "weight > 1, or an error for a valid path",
        reference: Some("1 for the sum of the weights (when not all 0)"),
        tally: t,
        seconds: start.elapsed().as_secs_f64(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_space_reference_matches_the_plain_formula() {
        assert!((weight_reference(1.0, (1.0, 2.0), &[(1.0, 6.0)]) - 0.25).abs() < 1e-15);
        assert!((weight_reference(2.0, (1.0, 1.0), &[(1.0, 3.0)]) - 0.1).abs() < 1e-15);
        // Extreme ratios stay exact instead of overflowing.
        let w = weight_reference(2.0, (1.0, 1e-30), &[(1.0, 1e30)]);
        assert!((w / 1e-120 - 1.0).abs() < 1e-12, "{w:e}");
        assert_eq!(weight_reference(1.0, (1.0, 0.0), &[(1.0, 1.0)]), 0.0);
        assert_eq!(weight_reference(1.0, (1.0, 5.0), &[(1.0, 0.0)]), 1.0);
    }
}
