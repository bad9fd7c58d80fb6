//! `cargo xtask stability [--quick]`: numerical stability sweeps.
//!
//! Every sweep evaluates library functions over extreme inputs (alpha
//! 1e-8..10, cosines 1e-9..1 on both sides, eta 1 + 1e-7..10 and inverses,
//! tau_0 1/(2 pi) + 1e-12..1e12, N 1..1e15, pdfs 1e-30..1e30, scene scales
//! 1e-4..1e5, degenerate geometry) and counts NaN, Inf, negative values,
//! panics and violations of the sweep's own properties; where an f64
//! reference exists it keeps the largest relative error. The table goes to
//! `target/stability/report.md` (and `report.json`); any non-zero count is an
//! error.
//!
//! Rows, by module: [`microfacet_sweeps`] (NDFs, Lambda/G1, erfc, Fresnel,
//! the lobes), [`regularization_sweeps`] (schedule, alpha-hat, strict,
//! p-hat), [`mis_sweeps`] (heuristics, random sub-paths, the reference), and
//! [`scene_sweeps`] (scaled and degenerate scenes through the renderer).
//! [`tally`] holds the counting helpers, [`reference`] the f64 references.

use std::fmt::Write as _;
use std::fs;
use std::path::Path;
use std::time::Instant;

use glam::Vec3;
use microfacet::NdfKind;
use serde_json::json;

mod microfacet_sweeps;
mod mis_sweeps;
mod reference;
mod regularization_sweeps;
mod scene_sweeps;
mod tally;

use tally::{QuietPanics, Row};

pub const USAGE: &str = "  stability [--quick]
                    numerical stability sweeps (alpha, cosines, eta, tau_0, N,
                    MIS pdfs, scene scale, degenerate geometry): counts of NaN,
                    Inf, negative values, panics and violations, largest error
                    against f64 references; writes target/stability/report.md
                    and report.json; fails if any count is non-zero
                    (--quick: fewer points, for CI)";

/// How many points the sweeps take.
#[derive(Clone, Copy, Debug)]
pub struct Budget {
    /// The CI form: fewer points per axis.
    pub quick: bool,
}

impl Budget {
    /// `quick` points in the quick form, `full` otherwise.
    pub fn n(self, quick: usize, full: usize) -> usize {
        if self.quick { quick } else { full }
    }
}

/// The three NDFs.
pub const KINDS: [NdfKind; 3] = [NdfKind::Ggx, NdfKind::Beckmann, NdfKind::BlinnPhong];

/// `n` >= 2 values from `lo` to `hi` (both included), evenly spaced in log.
pub fn log_space(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    let n = n.max(2);
    let (a, b) = (lo.ln(), hi.ln());
    (0..n)
        .map(|i| {
            if i == 0 {
                lo
            } else if i == n - 1 {
                hi
            } else {
                (a + (b - a) * i as f64 / (n - 1) as f64).exp()
            }
        })
        .collect()
}

/// alpha from 1e-8 to 10 (`n` log-spaced values) and the library's edges:
/// ALPHA_MIN 1e-7, SMOOTH_ALPHA 1e-4 and its neighbours, the Blinn-Phong
/// Lambda switch 0.01, Beckmann's peak shift 1/sqrt 2, and 1. Sorted.
pub fn alphas(n: usize) -> Vec<f32> {
    let smooth = microfacet::SMOOTH_ALPHA;
    let mut out: Vec<f32> = log_space(1e-8, 10.0, n)
        .into_iter()
        .map(|a| a as f32)
        .chain([
            1e-7,
            smooth.next_down(),
            smooth,
            smooth.next_up(),
            0.01,
            std::f32::consts::FRAC_1_SQRT_2,
            1.0,
        ])
        .collect();
    out.sort_by(f32::total_cmp);
    out.dedup();
    out
}

/// Cosines +-(1e-9..1, `n` log-spaced values) and 0.
pub fn signed_cosines(n: usize) -> Vec<f64> {
    let positive = log_space(1e-9, 1.0, n);
    let mut out = positive.clone();
    out.extend(positive.iter().map(|c| -c));
    out.push(0.0);
    out
}

/// eta = 1 + (1e-7..9, `n` log-spaced values) and glass's 1.5, and their
/// inverses, as f32 (values that round to the same f32 appear once).
pub fn etas(n: usize) -> Vec<f32> {
    let mut out: Vec<f32> = Vec::new();
    for eta in log_space(1e-7, 9.0, n)
        .into_iter()
        .map(|x| (1.0 + x) as f32)
        .chain([1.5])
        .flat_map(|eta| [eta, 1.0 / eta])
    {
        if !out.contains(&eta) {
            out.push(eta);
        }
    }
    out
}

/// The unit direction with cosine `cos` to the normal (+z) at azimuth
/// `phi`, built in f64 and rounded to f32.
pub fn direction(cos: f64, phi: f64) -> Vec3 {
    let sin = (1.0 - cos * cos).max(0.0).sqrt();
    glam::DVec3::new(sin * phi.cos(), sin * phi.sin(), cos).as_vec3()
}

/// `w` as Rust source (`Vec3::new(..)`, exact f32 values), for reproductions.
pub fn v(w: Vec3) -> String {
    format!("Vec3::new({:?}, {:?}, {:?})", w.x, w.y, w.z)
}

/// A small deterministic generator (SplitMix64) for the random MIS paths.
pub struct Rng {
    state: u64,
}

impl Rng {
    /// A generator with `seed`.
    pub fn new(seed: u64) -> Self {
        Self { state: seed }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        self.state = self.state.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.state;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        z ^ (z >> 31)
    }

    /// Uniform in [0, 1).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Log-uniform in [lo, hi).
    pub fn log_uniform(&mut self, lo: f64, hi: f64) -> f64 {
        (lo.ln() + (hi.ln() - lo.ln()) * self.uniform()).exp()
    }

    /// True with probability `p`.
    pub fn chance(&mut self, p: f64) -> bool {
        self.uniform() < p
    }

    /// Uniform in 0..n.
    pub fn below(&mut self, n: usize) -> usize {
        ((self.uniform() * n as f64) as usize).min(n - 1)
    }
}

pub fn run(root: &Path, args: &[String]) -> Result<(), String> {
    let quick = crate::quick_flag(args, "cargo xtask stability [--quick]")?;
    let budget = Budget { quick };
    let out = root.join("target").join("stability");
    let tmp = out.join("tmp");
    if tmp.exists() {
        fs::remove_dir_all(&tmp).map_err(|e| format!("cannot clear {}: {e}", tmp.display()))?;
    }
    fs::create_dir_all(&tmp).map_err(|e| format!("cannot create {}: {e}", tmp.display()))?;
    let start = Instant::now();
    let mut rows = Vec::new();
    {
        let _quiet = QuietPanics::install();
        let groups: [(&str, &dyn Fn() -> Vec<Row>); 4] = [
            ("microfacet", &|| microfacet_sweeps::rows(budget)),
            ("regularization", &|| regularization_sweeps::rows(budget)),
            ("mis", &|| mis_sweeps::rows(budget)),
            ("scene", &|| scene_sweeps::rows(budget, root, &tmp)),
        ];
        for (name, sweep) in groups {
            let t = Instant::now();
            let group = sweep();
            let problems: u64 = group.iter().map(|r| r.tally.problems()).sum();
            eprintln!(
                "stability: {name:<15} {:>3} rows {:>7.1} s  {problems} problems",
                group.len(),
                t.elapsed().as_secs_f64()
            );
            rows.extend(group);
        }
    }
    let seconds = start.elapsed().as_secs_f64();
    let problems: u64 = rows.iter().map(|r| r.tally.problems()).sum();
    // The temporary scenes stay for reproducing a problem.
    if problems == 0 {
        let _ = fs::remove_dir_all(&tmp);
    }
    let markdown = report(&rows, quick, seconds);
    let json = json!({
        "form": if quick { "quick" } else { "full" },
        "seconds": seconds,
        "cores": crate::cores(),
        "problems": rows.iter().map(|r| r.tally.problems()).sum::<u64>(),
        "rows": rows.iter().map(|r| {
            let mut v = r.tally.json();
            v["name"] = json!(r.name);
            v["covers"] = json!(r.covers);
            v["other_counts"] = json!(r.other);
            v["reference"] = json!(r.reference);
            v["seconds"] = json!(r.seconds);
            v
        }).collect::<Vec<_>>(),
    });
    crate::write_report(&out, "report", &markdown, &json)?;
    println!("{}", table(&rows));
    println!(
        "wrote target/stability/report.md and report.json ({:.1} s)",
        seconds
    );
    if problems > 0 {
        return Err(format!(
            "stability: {problems} problems, see target/stability/report.md"
        ));
    }
    Ok(())
}

/// A relative error for the table: 3 significant digits, "-" without one.
fn format_error(e: Option<f64>) -> String {
    match e {
        None => "-".into(),
        Some(0.0) => "0".into(),
        Some(e) => format!("{e:.2e}"),
    }
}

/// The markdown table, one line per row.
pub fn table(rows: &[Row]) -> String {
    let mut s = String::from(
        "| sweep | evaluations | NaN | Inf | negative | panics | other | max rel. error | s |\n\
         |---|---:|---:|---:|---:|---:|---:|---:|---:|\n",
    );
    for r in rows {
        let t = &r.tally;
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} | {} | {} | {} | {:.1} |",
            r.name,
            t.evaluations,
            t.nan,
            t.inf,
            t.negative,
            t.panics,
            t.other,
            format_error(t.max_rel_error()),
            r.seconds
        );
    }
    s
}

/// The whole report: the table, what each row covers, and the problems.
fn report(rows: &[Row], quick: bool, seconds: f64) -> String {
    let problems: u64 = rows.iter().map(|r| r.tally.problems()).sum();
    let mut s = String::new();
    let _ = writeln!(s, "# Numerical stability sweeps\n");
    let _ = writeln!(
        s,
        "`cargo xtask stability{}`: {} form, {:.1} s on {} cores, **{problems} problems**.\n",
        if quick { " --quick" } else { "" },
        if quick { "quick" } else { "full" },
        seconds,
        crate::cores()
    );
    let _ = writeln!(
        s,
        "Columns: `evaluations` = function calls (renders: pixel samples); `NaN`, `Inf`, `negative` = values \
         returned (renders: pixels of the mean image); `panics` = panics caught; `other` = violations of the row's \
         own properties (listed below). Every count must be 0. `max rel. error` = largest |x - ref| / |ref| over \
         comparisons with |ref| > 1e-30 against the row's reference (informational; where it was reached is listed \
         below); `s` = wall-clock seconds (rows of one sweep share its time). The notes under each row are \
         informational counts (statuses, typed errors, samples that returned None), not problems.\n"
    );
    s.push_str(&table(rows));
    let _ = writeln!(s, "\n## What each row covers\n");
    for r in rows {
        let t = &r.tally;
        let _ = writeln!(s, "- **{}**: {}.", r.name, r.covers);
        let _ = writeln!(s, "  - other: {}.", r.other);
        match (&r.reference, &t.errors.max_rel, &t.errors.max_abs) {
            (Some(reference), Some((rel, rel_at)), Some((abs, abs_at))) => {
                let _ = writeln!(
                    s,
                    "  - error against {reference}: {} comparisons; largest relative {rel:.3e} at `{rel_at}`; \
                     largest absolute {abs:.3e} at `{abs_at}`.",
                    t.errors.compared
                );
                for (case, e) in &t.errors_by_case {
                    if let (Some((rel, at)), Some((abs, _))) = (&e.max_rel, &e.max_abs) {
                        let _ = writeln!(
                            s,
                            "    - {case}: {} comparisons, largest relative {rel:.2e} (at `{at}`), absolute {abs:.2e}.",
                            e.compared
                        );
                    }
                }
            }
            (Some(reference), _, _) => {
                let _ = writeln!(s, "  - error against {reference}: no comparison made.");
            }
            (None, _, _) => {}
        }
        if !t.notes.is_empty() {
            let notes: Vec<String> = t.notes.iter().map(|(k, n)| format!("{k}: {n}")).collect();
            let _ = writeln!(s, "  - notes: {}.", notes.join("; "));
        }
    }
    let _ = writeln!(s, "\n## Problems\n");
    if problems == 0 {
        let _ = writeln!(s, "None.");
    } else {
        let _ = writeln!(
            s,
            "The temporary scenes the examples name are kept in `target/stability/tmp/` until the next run.\n"
        );
    }
    for r in rows.iter().filter(|r| r.tally.problems() > 0) {
        let t = &r.tally;
        let _ = writeln!(
            s,
            "### {}\n\n{} NaN, {} Inf, {} negative, {} panics, {} other; the first {}:\n",
            r.name,
            t.nan,
            t.inf,
            t.negative,
            t.panics,
            t.other,
            t.examples.len()
        );
        for e in &t.examples {
            let _ = writeln!(s, "- `{e}`");
        }
        s.push('\n');
    }
    s
}

#[cfg(test)]
mod tests {
    use super::tally::Tally;
    use super::*;

    #[test]
    fn grids_include_their_ends_and_edges() {
        let l = log_space(1e-9, 1.0, 10);
        assert_eq!((l[0], l[9]), (1e-9, 1.0));
        assert!(l.windows(2).all(|w| w[0] < w[1]));
        let a = alphas(5);
        assert!(a.contains(&1e-8) && a.contains(&10.0) && a.contains(&microfacet::SMOOTH_ALPHA));
        assert!(a.windows(2).all(|w| w[0] < w[1]));
        let c = signed_cosines(4);
        assert_eq!(c.len(), 9);
        assert!(c.contains(&-1e-9) && c.contains(&0.0));
        let e = etas(3);
        assert_eq!(e.len(), 8);
        assert!(e.contains(&1.5) && e.contains(&(1.0 / 1.5)));
        // 1 + 1e-7 and 1 + 1.4e-7 are one f32.
        let dense = etas(60);
        assert!(
            dense
                .iter()
                .enumerate()
                .all(|(i, x)| !dense[..i].contains(x))
        );
        assert!(e.contains(&(1.0 + 1e-7)) && e.contains(&10.0) && e.contains(&0.1));
        for cos in [1e-9, 0.5, 1.0, -0.3] {
            let w = direction(cos, 1.0);
            assert!((w.length() - 1.0).abs() < 1e-6 && (f64::from(w.z) - cos).abs() < 1e-7);
        }
    }

    #[test]
    fn rng_is_deterministic_and_in_range() {
        let (mut a, mut b) = (Rng::new(3), Rng::new(3));
        for _ in 0..1000 {
            let x = a.log_uniform(1e-30, 1e30);
            assert_eq!(x, b.log_uniform(1e-30, 1e30));
            assert!((1e-30..1e30).contains(&x));
            assert!(a.below(7) < 7);
            b.below(7);
        }
    }

    #[test]
    fn report_lists_rows_and_problems() {
        let mut t = Tally::default();
        t.evaluations(10);
        t.value(f64::NAN, || "f(1)".into());
        t.compare(1.01, 1.0, || "g(2)".into());
        let rows = vec![Row {
            name: "demo".into(),
            covers: "x in 0..1".into(),
            other: "-",
            reference: Some("f64"),
            tally: t,
            seconds: 0.5,
        }];
        let table = table(&rows);
        assert!(
            table.contains("| demo | 10 | 1 | 0 | 0 | 0 | 0 | 1.00e-2 | 0.5 |"),
            "{table}"
        );
        let md = report(&rows, true, 1.0);
        assert!(
            md.contains("**1 problems**") && md.contains("`NaN: f(1)`"),
            "{md}"
        );
        assert!(
            md.contains("relative 1.000e-2 at `g(2) = 1.01e0, reference 1e0`"),
            "{md}"
        );
    }
}
