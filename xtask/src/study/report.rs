//! The study's outputs: curves (CSV, JSON), charts, the contact sheet and
//! report.md with the equal-time comparisons.

use std::fmt::Write as _;
use std::path::Path;

use serde_json::{Value, json};

use super::bias::{self, Bias};
use super::charts::{self, ChartData};
use super::metrics::{self, Errors};
use super::sheet::{self, Crop, SheetInfo};
use super::{Config, Origin, Run, Study};

/// Writes every output into `out`; returns the names of the files written.
pub fn write(out: &Path, study: &Study) -> Result<Vec<String>, String> {
    let mut written = Vec::new();
    write_file(out, "curves.csv", &csv(study), &mut written)?;
    let charts = charts::write(out, &ChartData::of(study))?;
    let (w, h) = study.resolution;
    let reference = &study.references[0];
    let finals: Vec<Vec<f64>> = study
        .runs
        .iter()
        .map(|r| metrics::luminance_image(&r.image))
        .collect();
    let crop = sheet::choose_crop(w, h, &reference.luminance, &finals);
    // The other references first, then every config.
    let tiles: Vec<(String, Vec<glam::Vec3>)> = study.references[1..]
        .iter()
        .map(|r| (format!("{} {}", r.role, r.config), r.image.clone()))
        .chain(
            study
                .runs
                .iter()
                .map(|r| (r.config.to_string(), r.image.clone())),
        )
        .collect();
    let sheet_info = sheet::write(
        &out.join("contact-sheet.png"),
        (w, h),
        (&reference_label(reference), &reference.image),
        &tiles,
        crop,
    )?;
    let bias = match study.bias_pair() {
        Some((regularized, unbiased)) => {
            let b = Bias::of(regularized, unbiased);
            bias::write_image(&out.join("bias.png"), (w, h), regularized, unbiased, &b)?;
            written.push("bias.png".into());
            Some(b)
        }
        None => None,
    };
    let comparisons = Comparisons::of(study);
    write_file(
        out,
        "curves.json",
        &(serde_json::to_string_pretty(&json_of(study, &comparisons, bias.as_ref(), crop))
            .map_err(|e| e.to_string())?
            + "\n"),
        &mut written,
    )?;
    written.extend(charts.iter().cloned());
    written.push("contact-sheet.png".into());
    let md = markdown(
        study,
        &comparisons,
        bias.as_ref(),
        &charts,
        crop,
        &sheet_info,
    );
    write_file(out, "report.md", &md, &mut written)?;
    Ok(written)
}

/// The short label of a reference's tiles: role and config.
fn reference_label(r: &super::Reference) -> String {
    format!("{} {}", r.role, r.config)
}

impl Study {
    /// (regularized, unbiased) references when the study has both.
    fn bias_pair(&self) -> Option<(&super::Reference, &super::Reference)> {
        let find = |role: &str| self.references.iter().find(|r| r.role == role);
        Some((find("regularized")?, find("unbiased")?))
    }
}

/// Writes `<out>/<name>` and adds `name` to `written`.
fn write_file(out: &Path, name: &str, text: &str, written: &mut Vec<String>) -> Result<(), String> {
    crate::write_file(&out.join(name), text)?;
    written.push(name.to_string());
    Ok(())
}

/// A regularized config against its unregularized algorithm at equal time.
struct Pair {
    reference: usize,
    unregularized: String,
    regularized: String,
    time: f64,
    rmse: (f64, f64),
    rel_mse: (f64, f64),
    /// At equal CPU time: (CPU seconds, RMSE off, RMSE reg).
    cpu: Option<(f64, f64, f64)>,
}

/// The goal, per regularized config: the time it takes to reach
/// the final RMSE of its algorithm without regularization, over that
/// config's time.
struct Goal {
    reference: usize,
    regularized: String,
    unregularized: String,
    /// The unregularized config's iterations, final RMSE and render time.
    iterations: u64,
    level: f64,
    time_off: f64,
    /// Seconds the regularized config takes to reach `level` (None: not
    /// within its run).
    time_reg: Option<f64>,
    /// The same two times in CPU seconds (None without CPU times).
    cpu: Option<(f64, Option<f64>)>,
    /// The regularized config's RMSE at its last checkpoint over the one
    /// before, per doubling of iterations (None with fewer than two).
    last_doubling: Option<f64>,
    /// The regularized config's final RMSE.
    final_rmse: f64,
}

/// RMSE per doubling of iterations when noise alone falls: 1/sqrt(2).
const NOISE_DOUBLING: f64 = std::f64::consts::FRAC_1_SQRT_2;
/// Above this RMSE ratio per doubling the error has stopped falling like
/// noise (which gives 0.707): bias dominates it.
const BIAS_LIMITED_DOUBLING: f64 = 0.9;
/// Ratios within [1/1.25, 1.25] count as "no change" in the verdict.
const NO_CHANGE: f64 = 1.25;
/// A config that ends within 1 % of the level without reaching it is "no
/// gain" too (runs identical to the unregularized one end a rounding away).
const SAME_FINAL_RMSE: f64 = 1.01;

/// The goal of issue 21: a regularized config reaches the unregularized
/// one's final RMSE in at most this fraction of its time.
const GOAL_TIME_FRACTION: f64 = 0.25;

impl Goal {
    /// time_reg / time_off.
    fn ratio(&self) -> Option<f64> {
        self.time_reg.map(|t| t / self.time_off)
    }

    /// The same ratio in CPU time.
    fn cpu_ratio(&self) -> Option<f64> {
        let (off, reg) = self.cpu?;
        Some(reg? / off)
    }

    /// Why the goal is met or not, from the curves alone: a regularized
    /// config whose RMSE no longer falls like noise (ratio per doubling of
    /// iterations above `BIAS_LIMITED_DOUBLING`, noise gives 0.707) is held
    /// up by the blur's bias; one that takes about the unregularized time
    /// changes little (its algorithm already samples the paths it blurs).
    fn verdict(&self) -> String {
        let bias_limited = self
            .last_doubling
            .filter(|&d| d > BIAS_LIMITED_DOUBLING)
            .map(|d| {
                format!(
                    "bias-limited: its RMSE fell {:.0} % over its last doubling of iterations (noise alone: {:.0} %)",
                    100.0 * (1.0 - d),
                    100.0 * (1.0 - NOISE_DOUBLING)
                )
            });
        match self.ratio() {
            Some(r) if r <= GOAL_TIME_FRACTION => "met".into(),
            Some(r) if (1.0 / NO_CHANGE..=NO_CHANGE).contains(&r) => {
                "no gain: about the unregularized time".into()
            }
            None if self.final_rmse <= SAME_FINAL_RMSE * self.level => {
                "no gain: ends at about the unregularized RMSE".into()
            }
            Some(r) if r < 1.0 => bias_limited.map_or("faster, short of the goal".into(), |b| {
                format!("faster, then {b}")
            }),
            _ => bias_limited.unwrap_or_else(|| {
                "slower: the blur costs more than it saves at this iteration count".into()
            }),
        }
    }
}

/// A config's time to reach an error level.
struct Level {
    reference: usize,
    /// The config whose final RMSE the level is.
    set_by: String,
    rmse: f64,
    /// Per run (study order): seconds to reach the level.
    times: Vec<Option<f64>>,
}

struct Comparisons {
    pairs: Vec<Pair>,
    goals: Vec<Goal>,
    levels: Vec<Level>,
}

impl Comparisons {
    fn of(study: &Study) -> Self {
        let mut pairs = Vec::new();
        let mut goals = Vec::new();
        let mut levels = Vec::new();
        // Every regularized run (swept or not) with its algorithm's
        // unregularized run.
        let pairings: Vec<(&Run, &Run)> = study
            .runs
            .iter()
            .filter(|r| r.config.regularized)
            .filter_map(|reg| {
                let off = Config::plain(reg.config.algorithm, false);
                Some((study.runs.iter().find(|r| r.config == off)?, reg))
            })
            .collect();
        for reference in 0..study.references.len() {
            let rmse = |r: &Run| r.curve(|p| p.errors[reference].rmse);
            let rel = |r: &Run| r.curve(|p| p.errors[reference].rel_mse);
            for &(unreg, reg) in &pairings {
                if let Some(goal) = Goal::of(reference, unreg, reg) {
                    goals.push(goal);
                }
                let Some((time, e_unreg, e_reg)) = metrics::at_equal_time(&rmse(unreg), &rmse(reg))
                else {
                    continue;
                };
                let Some((_, r_unreg, r_reg)) = metrics::at_equal_time(&rel(unreg), &rel(reg))
                else {
                    continue;
                };
                let cpu = |r: &Run| r.cpu_curve(|p| p.errors[reference].rmse);
                let cpu = match (cpu(unreg), cpu(reg)) {
                    (Some(a), Some(b)) => metrics::at_equal_time(&a, &b),
                    _ => None,
                };
                pairs.push(Pair {
                    reference,
                    unregularized: unreg.config.to_string(),
                    regularized: reg.config.to_string(),
                    time,
                    rmse: (e_unreg, e_reg),
                    rel_mse: (r_unreg, r_reg),
                    cpu,
                });
            }
            let mut finals: Vec<(String, f64)> = study
                .runs
                .iter()
                .filter_map(|r| {
                    let e = r.points.last()?.errors[reference].rmse;
                    Some((r.config.to_string(), e))
                })
                .collect();
            finals.sort_by(|a, b| b.1.total_cmp(&a.1));
            for (set_by, level) in finals {
                levels.push(Level {
                    reference,
                    set_by,
                    rmse: level,
                    times: study
                        .runs
                        .iter()
                        .map(|r| metrics::time_to_reach(&rmse(r), level))
                        .collect(),
                });
            }
        }
        Self {
            pairs,
            goals,
            levels,
        }
    }
}

impl Goal {
    /// `reg` against the final RMSE of `unreg`, against reference `reference`.
    fn of(reference: usize, unreg: &Run, reg: &Run) -> Option<Self> {
        let last = unreg.points.last()?;
        let level = last.errors[reference].rmse;
        let rmse = |p: &super::Point| p.errors[reference].rmse;
        let cpu = match (last.cpu_seconds, reg.cpu_curve(rmse)) {
            (Some(off), Some(curve)) => Some((off, metrics::time_to_reach(&curve, level))),
            _ => None,
        };
        Some(Self {
            reference,
            regularized: reg.config.to_string(),
            unregularized: unreg.config.to_string(),
            iterations: last.iteration,
            level,
            time_off: last.seconds,
            time_reg: metrics::time_to_reach(&reg.curve(rmse), level),
            cpu,
            final_rmse: reg.points.last().map_or(f64::INFINITY, rmse),
            last_doubling: match reg.points.as_slice() {
                [.., a, b] if b.iteration > a.iteration && rmse(a) > 0.0 => Some(
                    (rmse(b) / rmse(a))
                        .powf(1.0 / (b.iteration as f64 / a.iteration as f64).log2()),
                ),
                _ => None,
            },
        })
    }
}

/// The fastest run for a level: (index, seconds).
fn fastest(times: &[Option<f64>]) -> Option<(usize, f64)> {
    times
        .iter()
        .enumerate()
        .filter_map(|(i, t)| t.map(|t| (i, t)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
}

fn csv(study: &Study) -> String {
    let mut s = String::from(
        "config,reference,iteration,seconds,cpu_seconds,rmse,rel_mse,noise_std_error,noise_variance\n",
    );
    let opt = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:e}"));
    for run in &study.runs {
        for p in &run.points {
            for (r, e) in study.references.iter().zip(&p.errors) {
                let _ = writeln!(
                    s,
                    "{},{} {},{},{:e},{},{:e},{:e},{},{}",
                    run.config,
                    r.role,
                    r.config,
                    p.iteration,
                    p.seconds,
                    opt(p.cpu_seconds),
                    e.rmse,
                    e.rel_mse,
                    opt(p.noise.map(|n| n.std_error)),
                    opt(p.noise.map(|n| n.variance)),
                );
            }
        }
    }
    s
}

fn json_of(study: &Study, comparisons: &Comparisons, bias: Option<&Bias>, crop: Crop) -> Value {
    let reference_name = |i: usize| {
        let r = &study.references[i];
        format!("{} {}", r.role, r.config)
    };
    let rows: Vec<Value> = study
        .runs
        .iter()
        .flat_map(|run| {
            run.points.iter().flat_map(move |p| {
                p.errors.iter().enumerate().map(move |(i, e)| {
                    json!({
                        "config": run.config.to_string(),
                        "reference": reference_name(i),
                        "iteration": p.iteration,
                        "seconds": p.seconds,
                        "cpu_seconds": p.cpu_seconds,
                        "rmse": e.rmse,
                        "rel_mse": e.rel_mse,
                        "noise_std_error": p.noise.map(|n| n.std_error),
                        "noise_variance": p.noise.map(|n| n.variance),
                    })
                })
            })
        })
        .collect();
    json!({
        "scene": study.scene_file.display().to_string(),
        "scene_hash": format!("{:016x}", study.scene_hash),
        "resolution": [study.resolution.0, study.resolution.1],
        "iterations": study.iterations,
        "budget": study.budget,
        "seed": study.seed,
        "max_depth": study.max_depth,
        "tau0": study.tau0,
        "sweep": study.sweep,
        "unbiased_reference_choice": study.unbiased_reason,
        "renderer_version": study.renderer_version,
        "cores": study.cores,
        "load_average": [study.load.0, study.load.1],
        "total_seconds": study.total_seconds,
        "command": study.command,
        "metrics": "luminance Y = 0.2126 R + 0.7152 G + 0.0722 B; rmse = sqrt(mean((Y - Y_ref)^2)); \
                    rel_mse = mean((Y - Y_ref)^2 / (Y_ref^2 + 0.01)); noise_std_error = mean(s/sqrt(N)), \
                    noise_variance = mean(s^2/N), s^2 the sample variance of the N per-iteration Y estimates",
        "references": study.references.iter().map(|r| json!({
            "role": r.role,
            "config": r.config.to_string(),
            "iterations": r.spec.iterations,
            "seed": r.spec.seed,
            "key": r.key,
            "cache_file": r.cache_file.display().to_string(),
            "from_cache": r.cached,
            "render_seconds": r.render_seconds,
            "cpu_seconds": r.cpu_seconds,
            "noise_std_error": r.noise.map(|n| n.std_error),
            "noise_variance": r.noise.map(|n| n.variance),
            "invalid_samples": r.invalid_samples,
        })).collect::<Vec<_>>(),
        "configs": study.runs.iter().map(|r| json!({
            "config": r.config.to_string(),
            "key": r.key,
            "origin": origin(r.origin),
            "setup_seconds": r.setup_seconds,
            "render_seconds": r.points.last().map(|p| p.seconds),
            "cpu_seconds": r.points.last().and_then(|p| p.cpu_seconds),
            "invalid_samples": r.invalid_samples,
        })).collect::<Vec<_>>(),
        "rows": rows,
        "equal_time": comparisons.pairs.iter().map(|p| json!({
            "reference": reference_name(p.reference),
            "unregularized": p.unregularized,
            "regularized": p.regularized,
            "seconds": p.time,
            "rmse_unregularized": p.rmse.0,
            "rmse_regularized": p.rmse.1,
            "rmse_ratio_regularized_over_unregularized": p.rmse.1 / p.rmse.0,
            "rel_mse_unregularized": p.rel_mse.0,
            "rel_mse_regularized": p.rel_mse.1,
            "rel_mse_ratio_regularized_over_unregularized": p.rel_mse.1 / p.rel_mse.0,
            "equal_cpu_time": p.cpu.map(|(t, a, b)| json!({
                "cpu_seconds": t,
                "rmse_unregularized": a,
                "rmse_regularized": b,
                "rmse_ratio_regularized_over_unregularized": b / a,
            })),
        })).collect::<Vec<_>>(),
        "bias_of_regularization": bias.map(|b| json!({
            "definition": "d = Y(regularized reference) - Y(unbiased reference) per pixel",
            "rmse": b.rmse,
            "relative_rmse": b.relative_rmse,
            "mean": b.mean,
            "relative_mean": b.relative_mean,
            "noise_rmse": b.noise_rmse,
            "noise_mean": b.noise_mean,
            "image_full_scale": b.scale,
        })),
        "time_to_unregularized_rmse": comparisons.goals.iter().map(|g| json!({
            "reference": reference_name(g.reference),
            "regularized": g.regularized,
            "unregularized": g.unregularized,
            "unregularized_iterations": g.iterations,
            "rmse_level": g.level,
            "seconds_unregularized": g.time_off,
            "seconds_regularized": g.time_reg,
            "ratio": g.ratio(),
            "goal_met": g.ratio().is_some_and(|r| r <= GOAL_TIME_FRACTION),
            "cpu_ratio": g.cpu_ratio(),
            "rmse_ratio_per_doubling_at_end": g.last_doubling,
            "verdict": g.verdict(),
        })).collect::<Vec<_>>(),
        "time_to_rmse": comparisons.levels.iter().map(|l| json!({
            "reference": reference_name(l.reference),
            "rmse": l.rmse,
            "set_by": l.set_by,
            "seconds": study.runs.iter().zip(&l.times)
                .map(|(r, t)| (r.config.to_string(), json!(t)))
                .collect::<serde_json::Map<_, _>>(),
        })).collect::<Vec<_>>(),
        "contact_sheet_crop": { "x": crop.x, "y": crop.y, "width": crop.width, "height": crop.height },
    })
}

fn sci(v: f64) -> String {
    if v.is_finite() {
        format!("{v:.3e}")
    } else {
        "n/a".into()
    }
}

fn secs(v: f64) -> String {
    if !v.is_finite() {
        "n/a".into()
    } else if v < 10.0 {
        format!("{v:.3}")
    } else {
        format!("{v:.1}")
    }
}

fn markdown(
    study: &Study,
    comparisons: &Comparisons,
    bias: Option<&Bias>,
    charts: &[String],
    crop: Crop,
    sheet: &SheetInfo,
) -> String {
    let mut s = String::new();
    md_settings(&mut s, study);
    md_goal(&mut s, study, comparisons);
    md_bias(&mut s, study, bias);
    md_metrics(&mut s);
    md_references(&mut s, study);
    md_final_iteration(&mut s, study);
    md_origins(&mut s, study);
    md_equal_time(&mut s, study, comparisons);
    md_time_to_reach(&mut s, study, comparisons);
    md_checkpoints(&mut s, study);
    md_charts(&mut s, charts);
    md_contact_sheet(&mut s, study, crop, sheet);
    s
}

/// The title, the command and the settings table.
fn md_settings(s: &mut String, study: &Study) {
    let (w, h) = study.resolution;
    let _ = writeln!(s, "# Convergence study: {}\n", study.scene_name);
    let _ = writeln!(s, "Command: `{}`\n", study.command);
    let _ = writeln!(s, "| setting | value |\n|---|---|");
    let rows = [
        ("scene", study.scene_file.display().to_string()),
        ("scene files hash", format!("{:016x}", study.scene_hash)),
        ("resolution", format!("{w}x{h}")),
        ("budget preset", study.budget.to_string()),
        ("iterations per config", study.iterations.to_string()),
        (
            "configs",
            study
                .runs
                .iter()
                .map(|r| r.config.to_string())
                .collect::<Vec<_>>()
                .join(", "),
        ),
        ("seed (configs)", study.seed.to_string()),
        ("max depth", study.max_depth.to_string()),
        (
            "regularization of -reg configs",
            format!(
                "selective, progressive tau_N from tau_0 = {} (r_N = r_0 N^-1/6) unless swept",
                study.tau0
            ),
        ),
        ("sweep", study.sweep.clone()),
        (
            "unbiased reference",
            match (&study.unbiased_reason, study.references.first()) {
                (Some(why), Some(r)) => format!("{} ({why})", r.config),
                _ => "none (--unbiased-reference none)".into(),
            },
        ),
        ("renderer", study.renderer_version.clone()),
        (
            "machine",
            format!(
                "{} logical cores; load average (1, 5, 15 min) {} at start, {} at end",
                study.cores, study.load.0, study.load.1
            ),
        ),
        (
            "study wall time",
            format!(
                "{:.1} s (references, configs and metrics; before writing these outputs)",
                study.total_seconds
            ),
        ),
    ];
    for (k, v) in rows {
        let _ = writeln!(s, "| {k} | {v} |");
    }
}

/// The goal first: per regularized config, the time to reach the
/// unregularized config's final RMSE, against the first (unbiased) reference.
fn md_goal(s: &mut String, study: &Study, comparisons: &Comparisons) {
    let _ = writeln!(
        s,
        "\n## Time to reach the unregularized RMSE\n\n\
         Against the {} reference. For every regularized config: the final RMSE of the same \
         algorithm without regularization (at its last iteration) and its render time, the \
         time the regularized config takes to reach that RMSE for good (log-log interpolation \
         after its last checkpoint above it; its first checkpoint's time, an upper bound, when \
         it is below at every checkpoint; \
         `not reached` within its {} iterations), and their ratio; the goal \
         (issue 21) is a ratio of at most {GOAL_TIME_FRACTION}. Wall-clock times, with the \
         ratio in CPU time beside them (less disturbed by other processes). The verdict reads \
         the curves: a regularized config whose RMSE falls by less than {:.0} % per doubling of \
         iterations at its end (noise alone: {:.0} %) is held up by the blur's bias; one within \
         a factor {NO_CHANGE} of the unregularized time changes little.\n",
        reference_name(study, 0),
        study.iterations,
        100.0 * (1.0 - BIAS_LIMITED_DOUBLING),
        100.0 * (1.0 - NOISE_DOUBLING),
    );
    let goals: Vec<&Goal> = comparisons
        .goals
        .iter()
        .filter(|g| g.reference == 0)
        .collect();
    if goals.is_empty() {
        let _ = writeln!(
            s,
            "(No regularized config with its algorithm's unregularized config among the configs.)"
        );
        return;
    }
    let _ = writeln!(
        s,
        "| regularized | unregularized | its iterations | its RMSE | its time (s) | time of regularized (s) | **ratio** | goal <= {GOAL_TIME_FRACTION} | ratio in CPU time | verdict |\n\
         |---|---|---|---|---|---|---|---|---|---|"
    );
    for g in goals {
        let ratio = g.ratio();
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | **{}** | {} | {} | {} |",
            g.regularized,
            g.unregularized,
            g.iterations,
            sci(g.level),
            secs(g.time_off),
            g.time_reg.map_or("not reached".into(), secs),
            ratio.map_or("-".into(), |r| format!("{r:.3}")),
            match ratio {
                Some(r) if r <= GOAL_TIME_FRACTION => "met",
                _ => "not met",
            },
            g.cpu_ratio().map_or("-".into(), |r| format!("{r:.3}")),
            g.verdict(),
        );
    }
}

/// The bias of regularization: the regularized reference minus the
/// unbiased one, beside what the references' noise alone would give.
fn md_bias(s: &mut String, study: &Study, bias: Option<&Bias>) {
    let _ = writeln!(s, "\n## Bias of regularization\n");
    let (Some(b), Some((regularized, unbiased))) = (bias, study.bias_pair()) else {
        let _ = writeln!(s, "(No unbiased reference: `--unbiased-reference none`.)");
        return;
    };
    let _ = writeln!(
        s,
        "d = Y(regularized reference, {} x {}) - Y(unbiased reference, {} x {}) per pixel, \
         luminance:\n\n\
         | quantity | value | relative to the unbiased image mean | from the references' noise alone | ratio |\n\
         |---|---|---|---|---|",
        regularized.config, regularized.spec.iterations, unbiased.config, unbiased.spec.iterations,
    );
    let ratio =
        |v: f64, noise: Option<f64>| noise.map_or("n/a".into(), |n| format!("{:.2}", v / n));
    let _ = writeln!(
        s,
        "| RMSE of d | {} | {:.3} % | {} | {} |",
        sci(b.rmse),
        100.0 * b.relative_rmse,
        b.noise_rmse.map_or("n/a".into(), sci),
        ratio(b.rmse, b.noise_rmse),
    );
    let _ = writeln!(
        s,
        "| mean of d | {} | {:+.3} % | {} (standard deviation) | {} |",
        sci(b.mean),
        100.0 * b.relative_mean,
        b.noise_mean.map_or("n/a".into(), sci),
        ratio(b.mean, b.noise_mean),
    );
    let _ = writeln!(
        s,
        "\nNoise alone gives an RMSE of d near sqrt(mean(v_r + v_u)) and a mean of d within a \
         few times sqrt(mean(v_r + v_u) / pixels), v the references' per-pixel s^2/N; a ratio \
         far above 1 is bias. s^2/N overstates the error of stratified iterations, so these \
         ratios understate the bias. A negative mean beyond its noise means regularization loses energy.\n\n\
         ![bias of regularization](bias.png)\n\n\
         `bias.png`: d per pixel, red where the regularized reference is brighter, blue where \
         darker, white where they agree; full colour at |d| = {} (the 99th percentile of |d|); \
         green marks on the colour bar at +- the per-pixel noise of d (sqrt(mean(v_r + v_u))).",
        sci(b.scale)
    );
}

/// How the metrics and times are defined.
fn md_metrics(s: &mut String) {
    let _ = writeln!(
        s,
        "\n## Metrics\n\n\
         All metrics are on **luminance** Y = 0.2126 R + 0.7152 G + 0.0722 B of the linear \
         image, none per channel (SPEC §8):\n\n\
         - RMSE = sqrt(mean over pixels of (Y - Y_ref)^2);\n\
         - relMSE = mean of (Y - Y_ref)^2 / (Y_ref^2 + 0.01);\n\
         - noise: per pixel, s^2 = the sample variance of the N per-iteration estimates of Y; \
         reported as the pixel mean of the standard error s/sqrt(N) and of s^2/N (what the \
         supplemental's Fig. 2 plots as \"sigma/N\"). Undefined at N = 1. s^2/N is the \
         variance of the mean of N *independent* estimates; the renderer's iterations are \
         Owen-scrambled Sobol samples, stratified across iterations, so where stratification \
         works (e.g. a pixel on the edge of a light seen directly) the actual error of the \
         mean is far below s^2/N. Compare configs by RMSE; read the noise columns as the \
         per-iteration spread.\n\n\
         Time is the wall-clock time of rendering only (`render_iteration` and the film \
         update, all cores), cumulative over iterations; scene setup (BVH, lights) and the \
         metrics are excluded. The machine is shared: see the load average above. \
         Checkpoints are at N = 1, 2, 4, ... and the last iteration."
    );
}

/// The references: settings, times, noise, and how far apart they are.
fn md_references(s: &mut String, study: &Study) {
    let _ = writeln!(s, "\n## References\n");
    let _ = writeln!(
        s,
        "| role | config | iterations | seed | render time | CPU time | from cache | noise s/sqrt(N) | noise s^2/N | NaN/Inf dropped | cache file |\n\
         |---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in &study.references {
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} s | {} s | {} | {} | {} | {} | `{}` |",
            r.role,
            r.config,
            r.spec.iterations,
            r.spec.seed,
            secs(r.render_seconds),
            secs(r.cpu_seconds.unwrap_or(f64::NAN)),
            if r.cached {
                "yes: from the cache"
            } else {
                "no: rendered in this run"
            },
            sci(r.noise.map_or(f64::NAN, |n| n.std_error)),
            sci(r.noise.map_or(f64::NAN, |n| n.variance)),
            r.invalid_samples,
            r.cache_file.display()
        );
    }
    let _ = writeln!(
        s,
        "\nA reference's own noise bounds how small an error it can resolve: an RMSE near \
         sqrt(its s^2/N) is at the reference's noise floor. The configs never share random \
         numbers with a reference (different seeds)."
    );
    if let Some((_, unbiased)) = study.bias_pair()
        && matches!(
            unbiased.config.algorithm,
            integrators::Algorithm::Vcm | integrators::Algorithm::Ppm | integrators::Algorithm::Bpm
        )
    {
        let _ = writeln!(
            s,
            "\nNote: the unregularized reference merges photons, which is consistent but \
             biased at a finite iteration count (the merge radius)."
        );
    }
}

/// Every config's last checkpoint: times, errors against each reference, noise.
fn md_final_iteration(s: &mut String, study: &Study) {
    let _ = writeln!(s, "\n## Final iteration\n");
    let mut header = String::from(
        "| config | iterations | render time (s) | CPU time (s) | s/iteration | setup (s) |",
    );
    let mut rule = String::from("|---|---|---|---|---|---|");
    for i in 0..study.references.len() {
        let tag = reference_tag(study, i);
        let _ = write!(header, " RMSE{tag} | relMSE{tag} |");
        rule.push_str("---|---|");
    }
    header.push_str(" s/sqrt(N) | s^2/N | NaN/Inf dropped |");
    rule.push_str("---|---|---|");
    let _ = writeln!(s, "{header}\n{rule}");
    for run in &study.runs {
        let Some(p) = run.points.last() else { continue };
        let _ = write!(
            s,
            "| {} | {} | {} | {} | {} | {} |",
            run.config,
            p.iteration,
            secs(p.seconds),
            secs(p.cpu_seconds.unwrap_or(f64::NAN)),
            sci(p.seconds / p.iteration as f64),
            secs(run.setup_seconds)
        );
        for e in &p.errors {
            let _ = write!(s, " {} | {} |", sci(e.rmse), sci(e.rel_mse));
        }
        let _ = writeln!(
            s,
            " {} | {} | {} |",
            sci(p.noise.map_or(f64::NAN, |n| n.std_error)),
            sci(p.noise.map_or(f64::NAN, |n| n.variance)),
            run.invalid_samples
        );
    }
}

/// Where a run came from, in words.
fn origin(o: Origin) -> String {
    match o {
        Origin::Rendered => "rendered in this run".into(),
        Origin::Resumed(n) => format!("resumed from its checkpoint after iteration {n}"),
        Origin::Cached => "from the run cache".into(),
    }
}

/// Which configs came from the run cache or resumed from a checkpoint
/// (nothing when every one was rendered in this run).
fn md_origins(s: &mut String, study: &Study) {
    let list = |keep: fn(Origin) -> bool| {
        study
            .runs
            .iter()
            .filter(|r| keep(r.origin))
            .map(|r| match r.origin {
                Origin::Resumed(n) => format!("{} (after iteration {n})", r.config),
                _ => r.config.to_string(),
            })
            .collect::<Vec<_>>()
    };
    let cached = list(|o| o == Origin::Cached);
    let resumed = list(|o| matches!(o, Origin::Resumed(_)));
    if !cached.is_empty() {
        let _ = writeln!(
            s,
            "\nFrom the run cache (rendered by an earlier run of this study, with its times): {}.",
            cached.join(", ")
        );
    }
    if !resumed.is_empty() {
        let _ = writeln!(
            s,
            "\nResumed from a checkpoint of an interrupted run (times go on from it): {}.",
            resumed.join(", ")
        );
    }
}

/// Regularized against unregularized at equal render time.
fn md_equal_time(s: &mut String, study: &Study, comparisons: &Comparisons) {
    let _ = writeln!(s, "\n## Equal-time comparison\n");
    let _ = writeln!(
        s,
        "Regularized against unregularized, each algorithm at the smaller of the two final \
         render times, the errors interpolated linearly in log-log space between \
         checkpoints. A ratio below 1 means regularization has the smaller error at equal \
         time. The last two columns repeat the RMSE ratio at equal CPU time (all threads' time \
         on a core, from /proc), which other processes on the machine disturb much less than \
         wall-clock time.\n"
    );
    if comparisons.pairs.is_empty() {
        let _ = writeln!(
            s,
            "(No pair of an algorithm with and without `-reg` among the configs.)"
        );
    } else {
        let _ = writeln!(
            s,
            "| reference | pair | time (s) | RMSE off | RMSE reg | **RMSE ratio reg/off** | relMSE off | relMSE reg | relMSE ratio reg/off | CPU time (s) | RMSE ratio at equal CPU time |\n\
             |---|---|---|---|---|---|---|---|---|---|---|"
        );
        for p in &comparisons.pairs {
            let _ = writeln!(
                s,
                "| {} | {} vs {} | {} | {} | {} | **{:.3}** | {} | {} | {:.3} | {} | {} |",
                reference_name(study, p.reference),
                p.regularized,
                p.unregularized,
                secs(p.time),
                sci(p.rmse.0),
                sci(p.rmse.1),
                p.rmse.1 / p.rmse.0,
                sci(p.rel_mse.0),
                sci(p.rel_mse.1),
                p.rel_mse.1 / p.rel_mse.0,
                p.cpu.map_or("n/a".into(), |c| secs(c.0)),
                p.cpu.map_or("n/a".into(), |c| format!("{:.3}", c.2 / c.1)),
            );
        }
    }
}

/// When each config's RMSE first reaches each level.
fn md_time_to_reach(s: &mut String, study: &Study, comparisons: &Comparisons) {
    let _ = writeln!(s, "\n## Time to reach an error level\n");
    let _ = writeln!(
        s,
        "Levels: the final RMSE of each config. Each cell is the render time (s) at which a \
         config's RMSE falls to the level for good (log-log interpolation after its last \
         checkpoint above the level, so a dip that rises again does not count; a config \
         below it at every checkpoint shows its first checkpoint's time), and \
         in brackets how many times longer that is than the fastest config's; `-` when the \
         level is not reached within the run.\n"
    );
    for reference in 0..study.references.len() {
        let _ = writeln!(s, "Against the {}:\n", reference_name(study, reference));
        let mut header = String::from("| RMSE level | set by |");
        let mut rule = String::from("|---|---|");
        for run in &study.runs {
            let _ = write!(header, " {} |", run.config);
            rule.push_str("---|");
        }
        let _ = writeln!(s, "{header} first |\n{rule}---|");
        for level in comparisons
            .levels
            .iter()
            .filter(|l| l.reference == reference)
        {
            let best = fastest(&level.times);
            let _ = write!(s, "| {} | {} |", sci(level.rmse), level.set_by);
            for t in &level.times {
                match (t, best) {
                    (Some(t), Some((_, b))) => {
                        let _ = write!(s, " {} (x{:.2}) |", secs(*t), t / b);
                    }
                    _ => s.push_str(" - |"),
                }
            }
            let first = best.map_or("-".to_string(), |(i, _)| study.runs[i].config.to_string());
            let _ = writeln!(s, " {first} |");
        }
        s.push('\n');
    }
}

/// Every checkpoint of every config.
fn md_checkpoints(s: &mut String, study: &Study) {
    let _ = writeln!(s, "## Checkpoints\n");
    let mut header = String::from("| config | N | time (s) | CPU (s) |");
    let mut rule = String::from("|---|---|---|---|");
    for i in 0..study.references.len() {
        let tag = reference_tag(study, i);
        let _ = write!(header, " RMSE{tag} | relMSE{tag} |");
        rule.push_str("---|---|");
    }
    let _ = writeln!(s, "{header} s/sqrt(N) | s^2/N |\n{rule}---|---|");
    for run in &study.runs {
        for p in &run.points {
            let _ = write!(
                s,
                "| {} | {} | {} | {} |",
                run.config,
                p.iteration,
                secs(p.seconds),
                secs(p.cpu_seconds.unwrap_or(f64::NAN))
            );
            for Errors { rmse, rel_mse } in &p.errors {
                let _ = write!(s, " {} | {} |", sci(*rmse), sci(*rel_mse));
            }
            let _ = writeln!(
                s,
                " {} | {} |",
                sci(p.noise.map_or(f64::NAN, |n| n.std_error)),
                sci(p.noise.map_or(f64::NAN, |n| n.variance))
            );
        }
    }
}

/// The charts, SVG inline and links to the PNG versions.
fn md_charts(s: &mut String, charts: &[String]) {
    let _ = writeln!(s, "\n## Charts\n");
    for chart in charts.iter().filter(|c| c.ends_with(".svg")) {
        let _ = writeln!(s, "![{chart}]({chart})\n");
    }
    let png: Vec<&String> = charts.iter().filter(|c| c.ends_with(".png")).collect();
    if !png.is_empty() {
        let _ = writeln!(
            s,
            "PNG versions (same charts, 8x8 bitmap font): {}\n",
            png.iter()
                .map(|c| format!("[{c}]({c})"))
                .collect::<Vec<_>>()
                .join(", ")
        );
    }
}

/// The contact sheet and what its tiles show.
fn md_contact_sheet(s: &mut String, study: &Study, crop: Crop, sheet: &SheetInfo) {
    let _ = writeln!(
        s,
        "## Contact sheet\n\n![contact sheet](contact-sheet.png)\n"
    );
    let _ = writeln!(
        s,
        "Tiles, left to right and top to bottom (five a row): {}. The first is the whole \
         first reference, scaled to the tile, with the crop outlined in red; the others are \
         the crop x = {}..{}, y = {}..{} ({}x{} px, magnified {}x, nearest neighbour) of the \
         references and of every config at its final iteration ({}). The crop is the window \
         of a quarter of the image's width and height where the configs' final images \
         disagree most with the first reference (per pixel min(1, |Y - Y_ref| / (Y_ref + 0.05)), \
         summed over the configs). Exposure: x{:.3} (the reference crop's 99th-percentile \
         luminance maps to 1), then sRGB. Linear images of every tile are in `images/`.",
        sheet.order.join(", "),
        crop.x,
        crop.x + crop.width - 1,
        crop.y,
        crop.y + crop.height - 1,
        crop.width,
        crop.height,
        sheet.zoom,
        study.iterations,
        sheet.exposure
    );
}

fn reference_name(study: &Study, i: usize) -> String {
    let r = &study.references[i];
    format!("{} ({} x {})", r.role, r.config, r.spec.iterations)
}

/// Column suffix for reference `i`: none for the main one.
fn reference_tag(study: &Study, i: usize) -> String {
    if i == 0 {
        String::new()
    } else {
        format!(" vs {}", study.references[i].role)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(config: &str, curve: &[(f64, f64)]) -> Run {
        Run {
            config: Config::parse(config).unwrap(),
            key: String::new(),
            origin: super::super::Origin::Rendered,
            setup_seconds: 0.0,
            points: curve
                .iter()
                .enumerate()
                .map(|(i, &(seconds, rmse))| super::super::Point {
                    iteration: 1 << i,
                    seconds,
                    cpu_seconds: Some(2.0 * seconds),
                    noise: None,
                    errors: vec![Errors { rmse, rel_mse: 0.0 }],
                })
                .collect(),
            invalid_samples: 0,
            image: Vec::new(),
        }
    }

    /// The goal compares the time to reach the unregularized run's final
    /// RMSE with that run's time, in wall-clock and CPU time.
    #[test]
    fn goal_is_the_time_to_reach_the_unregularized_final_rmse() {
        let off = run("bpt", &[(1.0, 0.4), (2.0, 0.2), (4.0, 0.1)]);
        // RMSE 0.1 at sqrt(0.5) s (log-log between 0.5 s / 0.2 and 1 s / 0.05).
        let reg = run("bpt-reg", &[(0.5, 0.2), (1.0, 0.05), (2.0, 0.04)]);
        let g = Goal::of(0, &off, &reg).unwrap();
        assert_eq!((g.iterations, g.level, g.time_off), (4, 0.1, 4.0));
        assert!((g.time_reg.unwrap() - 0.5 * 2f64.powf(0.5)).abs() < 1e-12);
        assert!((g.ratio().unwrap() - 0.5 * 2f64.powf(0.5) / 4.0).abs() < 1e-12);
        assert!((g.cpu_ratio().unwrap() - g.ratio().unwrap()).abs() < 1e-12);
        let slow = run("bpt-reg", &[(1.0, 0.3), (8.0, 0.2)]);
        let g = Goal::of(0, &off, &slow).unwrap();
        assert_eq!((g.time_reg, g.ratio()), (None, None));
    }

    /// The verdict: met; no gain near ratio 1; bias-limited when the RMSE
    /// stops falling like noise at the end; else slower.
    #[test]
    fn verdict_reads_the_curves() {
        let off = run("bpt", &[(1.0, 0.4), (2.0, 0.2), (4.0, 0.1)]);
        let verdict =
            |curve: &[(f64, f64)]| Goal::of(0, &off, &run("bpt-reg", curve)).unwrap().verdict();
        assert_eq!(verdict(&[(0.5, 0.2), (1.0, 0.05), (2.0, 0.035)]), "met");
        assert!(verdict(&[(1.0, 0.4), (2.0, 0.2), (4.0, 0.1)]).starts_with("no gain"));
        // Reaches 0.1 at 2 s, then falls 5 % over its last doubling.
        let v = verdict(&[(1.0, 0.2), (2.0, 0.1), (3.0, 0.095)]);
        assert!(
            v.starts_with("faster, then bias-limited") && v.contains(" 5 %"),
            "{v}"
        );
        assert!(verdict(&[(1.0, 0.3), (4.0, 0.2), (8.0, 0.199)]).starts_with("bias-limited"));
        assert!(verdict(&[(4.0, 0.8), (8.0, 0.4), (16.0, 0.2)]).starts_with("slower"));
        assert!(verdict(&[(2.0, 0.4), (4.0, 0.2), (8.0, 0.1001)]).starts_with("no gain"));
    }

    #[test]
    fn fastest_skips_unreached_levels() {
        assert_eq!(fastest(&[None, Some(2.0), Some(1.5)]), Some((2, 1.5)));
        assert_eq!(fastest(&[None, None]), None);
    }

    #[test]
    fn number_formats() {
        assert_eq!(sci(0.01234), "1.234e-2");
        assert_eq!(sci(f64::NAN), "n/a");
        assert_eq!(secs(1.23456), "1.235");
        assert_eq!(secs(123.456), "123.5");
    }
}
