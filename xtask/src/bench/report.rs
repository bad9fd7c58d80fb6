//! `end-to-end.md`: the JSON document of a run as a markdown table with the
//! machine's facts, and, given a previous run's JSON, the ratio new/old of
//! seconds per iteration per row.

use std::collections::BTreeMap;
use std::fmt::Write as _;

use serde_json::Value;

/// A row's key: (scene, integrator).
type Key = (String, String);

/// The markdown report of `doc`, compared with `baseline` = (its path,
/// its JSON) when given.
pub fn markdown(doc: &Value, baseline: Option<(&str, &Value)>) -> String {
    let runs = doc["runs"].as_array().map_or(&[][..], Vec::as_slice);
    let mut md = String::from("# End-to-end benchmark\n\n");
    facts(&mut md, doc);
    let old = baseline.map(|(path, base)| {
        baseline_facts(&mut md, doc, path, base);
        times(base)
    });
    table(&mut md, runs, old.as_ref());
    problems(&mut md, runs);
    if let Some(old) = &old {
        unpaired_rows(&mut md, &times(doc), old);
    }
    md
}

/// The run's facts: date, commit, profile, machine, settings.
fn facts(md: &mut String, doc: &Value) {
    let _ = writeln!(md, "- date: {}, {}", text(doc, "date"), commit(doc));
    let _ = writeln!(
        md,
        "- profile: **{}** (compare only runs of the same profile)",
        text(doc, "profile")
    );
    let machine = &doc["machine"];
    let _ = writeln!(
        md,
        "- machine: {} logical cores, {} rayon threads, {}; load average {} before, {} after",
        machine["cores"],
        machine["rayon_threads"],
        machine["cpu_model"].as_str().unwrap_or("unknown CPU"),
        text(&machine["load_average"], 0),
        text(&machine["load_average"], 1)
    );
    let _ = writeln!(
        md,
        "- {}, {} timed iterations after {} warm-up; max depth and regularization \
         from each scene's manifest; all runs took {:.1} s",
        resolution(doc),
        doc["iterations"],
        doc["warmup_iterations"],
        doc["total_seconds"].as_f64().unwrap_or(f64::NAN)
    );
    let repeat = doc["repeat"].as_u64().unwrap_or(1);
    if repeat > 1 {
        let _ = writeln!(
            md,
            "- {repeat} rounds (every row once per round): each row is its median round, \
             s/iteration with the range of the rounds"
        );
    }
}

/// The baseline's facts, and a warning where it differs from this run in
/// what makes times comparable.
fn baseline_facts(md: &mut String, doc: &Value, path: &str, base: &Value) {
    let machine = &doc["machine"];
    let _ = writeln!(
        md,
        "- baseline: {path} ({}, {}, profile {}, {}, {} iterations, {} cores)",
        text(base, "date"),
        commit(base),
        text(base, "profile"),
        resolution(base),
        base["iterations"],
        base["machine"]["cores"]
    );
    let differs: Vec<&str> = ["profile", "resolution", "iterations"]
        .into_iter()
        .filter(|k| base[*k] != doc[*k])
        .chain((base["machine"]["cores"] != machine["cores"]).then_some("cores"))
        .collect();
    if !differs.is_empty() {
        let _ = writeln!(
            md,
            "- **warning**: the baseline differs in {}; its ratios compare unlike runs",
            differs.join(", ")
        );
    }
}

/// The table: a row per run, with the ratio to the baseline's time.
fn table(md: &mut String, runs: &[Value], old: Option<&BTreeMap<Key, f64>>) {
    md.push_str(
        "\n| scene | integrator | s/iteration | samples/s | rays/s | rays/sample | peak MiB | build s |",
    );
    md.push_str(if old.is_some() {
        " new/old s/it |\n|---|---|---:|---:|---:|---:|---:|---:|---:|\n"
    } else {
        "\n|---|---|---:|---:|---:|---:|---:|---:|\n"
    });
    for run in runs {
        let _ = write!(
            md,
            "| {} | {} |",
            text(run, "scene"),
            text(run, "integrator")
        );
        if run["status"] == "ok" {
            let n = |k: &str| run[k].as_f64().unwrap_or(f64::NAN);
            let _ = write!(
                md,
                " {}{} | {} | {} | {:.2} | {:.1} | {} |",
                sig3(n("seconds_per_iteration")),
                range(&run["rounds_seconds_per_iteration"]),
                si(n("samples_per_second")),
                si(n("rays_per_second")),
                n("rays_per_sample"),
                n("peak_rss_mib"),
                sig3(n("build_seconds"))
            );
        } else {
            md.push_str(" failed | - | - | - | - | - |");
        }
        if let Some(old) = &old {
            let ratio = run["seconds_per_iteration"]
                .as_f64()
                .zip(old.get(&key(run)))
                .map_or_else(|| "-".to_string(), |(new, old)| format!("{:.2}", new / old));
            let _ = write!(md, " {ratio} |");
        }
        md.push('\n');
    }
    md.push_str(
        "\ns/iteration: wall-clock seconds per timed iteration (one sample per pixel, \
         rendering and film accumulation); rays: closest-hit and shadow rays; peak MiB: \
         VmHWM of the run's own process; build s: scene load and `Renderer::new` (BVH, lights).\n",
    );
}

/// Failed runs and runs that dropped NaN/Inf samples.
fn problems(md: &mut String, runs: &[Value]) {
    let failures: Vec<String> = runs
        .iter()
        .filter(|r| r["status"] != "ok")
        .map(|r| {
            format!(
                "- {} {}: {}",
                text(r, "scene"),
                text(r, "integrator"),
                text(r, "error")
            )
        })
        .collect();
    if !failures.is_empty() {
        let _ = write!(md, "\nFailed runs:\n\n{}\n", failures.join("\n"));
    }
    let invalid: Vec<String> = runs
        .iter()
        .filter(|r| r["invalid_samples"].as_u64().is_some_and(|n| n > 0))
        .map(|r| {
            format!(
                "{} {} ({})",
                text(r, "scene"),
                text(r, "integrator"),
                r["invalid_samples"]
            )
        })
        .collect();
    if !invalid.is_empty() {
        let _ = writeln!(md, "\nNaN/Inf samples dropped: {}.", invalid.join(", "));
    }
}

/// Rows that have no ratio because one side lacks them.
fn unpaired_rows(md: &mut String, new: &BTreeMap<Key, f64>, old: &BTreeMap<Key, f64>) {
    let missing = |a: &BTreeMap<Key, f64>, b: &BTreeMap<Key, f64>| {
        let keys: Vec<String> = a
            .keys()
            .filter(|k| !b.contains_key(*k))
            .map(|(s, i)| format!("{s} {i}"))
            .collect();
        if keys.is_empty() {
            "none".to_string()
        } else {
            keys.join(", ")
        }
    };
    let _ = write!(
        md,
        "\nRows without a ratio (failed or not run on that side): only in this run: {}; \
         only in the baseline: {}.\n",
        missing(new, old),
        missing(old, new)
    );
}

/// Seconds per iteration of the successful runs of a document, by row.
fn times(doc: &Value) -> BTreeMap<Key, f64> {
    doc["runs"]
        .as_array()
        .into_iter()
        .flatten()
        .filter(|r| r["status"] == "ok")
        .filter_map(|r| Some((key(r), r["seconds_per_iteration"].as_f64()?)))
        .collect()
}

fn key(run: &Value) -> Key {
    (text(run, "scene").into(), text(run, "integrator").into())
}

/// A string field, "?" when absent.
pub(super) fn text<I: serde_json::value::Index>(v: &Value, field: I) -> &str {
    v[field].as_str().unwrap_or("?")
}

/// "commit abcdef012345 (uncommitted changes)" from a document's `git`.
fn commit(doc: &Value) -> String {
    let git = &doc["git"];
    match git["commit"].as_str() {
        Some(c) => format!(
            "commit {}{}",
            c.get(..12).unwrap_or(c),
            if git["dirty"] == true {
                " (uncommitted changes)"
            } else {
                ""
            }
        ),
        None => "no git commit".into(),
    }
}

/// "256x192" from a document's `resolution`.
fn resolution(doc: &Value) -> String {
    format!("{}x{}", doc["resolution"][0], doc["resolution"][1])
}

/// Three significant digits without an exponent ("0.0123", "1.23", "123",
/// "1234"); "-" when not finite.
/// " (min-max)" of a row's rounds, or nothing for a single round.
fn range(rounds: &Value) -> String {
    let seconds: Vec<f64> = rounds
        .as_array()
        .into_iter()
        .flatten()
        .filter_map(Value::as_f64)
        .collect();
    if seconds.len() < 2 {
        return String::new();
    }
    let (min, max) = seconds
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), &s| {
            (lo.min(s), hi.max(s))
        });
    format!(" ({}-{})", sig3(min), sig3(max))
}

pub(super) fn sig3(x: f64) -> String {
    if !x.is_finite() {
        return "-".into();
    }
    let decimals = if x == 0.0 {
        2
    } else {
        (2 - x.abs().log10().floor() as i32).max(0) as usize
    };
    format!("{x:.decimals$}")
}

/// Three significant digits with an SI prefix: "1.23 M", "456 k", "12.0".
fn si(x: f64) -> String {
    let (scale, prefix) = [(1e9, " G"), (1e6, " M"), (1e3, " k")]
        .into_iter()
        .find(|(s, _)| x.abs() >= *s)
        .unwrap_or((1.0, ""));
    let digits = sig3(x / scale);
    if digits == "-" {
        digits
    } else {
        format!("{digits}{prefix}")
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn ok(scene: &str, integrator: &str, seconds_per_iteration: f64) -> Value {
        json!({
            "scene": scene, "integrator": integrator, "status": "ok",
            "seconds_per_iteration": seconds_per_iteration,
            "samples_per_second": 24_576.0, "rays_per_second": 123_456_789.0,
            "rays_per_sample": 5.025, "peak_rss_mib": 12.34, "build_seconds": 0.00123,
        })
    }

    fn doc(profile: &str, runs: Vec<Value>) -> Value {
        json!({
            "date": "2025-01-02 03:04:05 UTC",
            "git": {"commit": "0123456789abcdef0123", "dirty": true},
            "profile": profile,
            "machine": {"cores": 2, "rayon_threads": 2, "cpu_model": "Test CPU",
                        "load_average": ["1.00 0.50 0.25", "2.00 1.00 0.50"]},
            "resolution": [64, 48], "iterations": 2, "warmup_iterations": 1,
            "total_seconds": 3.21, "runs": runs,
        })
    }

    #[test]
    fn table_has_the_facts_and_one_row_per_run() {
        let failed = json!({"scene": "stiff", "integrator": "vcm", "status": "failed",
                            "error": "boom"});
        let mut run = ok("cornell-box", "pt", 0.5);
        run["invalid_samples"] = json!(3);
        let md = markdown(&doc("dev", vec![run, failed]), None);
        for needle in [
            "commit 0123456789ab (uncommitted changes)",
            "profile: **dev**",
            "2 logical cores, 2 rayon threads, Test CPU; load average 1.00 0.50 0.25 before",
            "64x48, 2 timed iterations after 1 warm-up",
            "| cornell-box | pt | 0.500 | 24.6 k | 123 M | 5.03 | 12.3 | 0.00123 |\n",
            "| stiff | vcm | failed | - | - | - | - | - |\n",
            "- stiff vcm: boom",
            "NaN/Inf samples dropped: cornell-box pt (3).",
        ] {
            assert!(md.contains(needle), "{needle}\n{md}");
        }
        assert!(!md.contains("new/old") && !md.contains("baseline"), "{md}");
        assert!(!md.contains("rounds"), "{md}");

        let mut median = ok("cornell-box", "bpt", 0.652);
        median["rounds_seconds_per_iteration"] = json!([0.7, 0.652, 0.631]);
        let mut repeated = doc("release", vec![median]);
        repeated["repeat"] = json!(3);
        let md = markdown(&repeated, None);
        assert!(md.contains("- 3 rounds (every row once per round)"), "{md}");
        assert!(
            md.contains("| cornell-box | bpt | 0.652 (0.631-0.700) |"),
            "{md}"
        );
    }

    #[test]
    fn baseline_adds_ratios_and_lists_missing_rows() {
        let new = doc(
            "dev",
            vec![ok("cornell-box", "pt", 0.4), ok("cornell-box", "bpt", 1.0)],
        );
        let old = doc(
            "release",
            vec![ok("cornell-box", "pt", 0.5), ok("stiff", "vcm", 2.0)],
        );
        let md = markdown(&new, Some(("old.json", &old)));
        for needle in [
            "- baseline: old.json (2025-01-02 03:04:05 UTC, commit 0123456789ab",
            "**warning**: the baseline differs in profile;",
            "| s/iteration | samples/s | rays/s | rays/sample | peak MiB | build s | new/old s/it |",
            "| cornell-box | pt | 0.400 | 24.6 k | 123 M | 5.03 | 12.3 | 0.00123 | 0.80 |\n",
            "| cornell-box | bpt | 1.00 | 24.6 k | 123 M | 5.03 | 12.3 | 0.00123 | - |\n",
            "only in this run: cornell-box bpt; only in the baseline: stiff vcm.",
        ] {
            assert!(md.contains(needle), "{needle}\n{md}");
        }
        let same = markdown(&new, Some(("new.json", &new)));
        assert!(!same.contains("warning"), "{same}");
        assert!(same.contains("only in this run: none; only in the baseline: none."));
    }

    #[test]
    fn numbers_keep_three_significant_digits() {
        assert_eq!(sig3(0.012345), "0.0123");
        assert_eq!(sig3(1.2345), "1.23");
        assert_eq!(sig3(123.45), "123");
        assert_eq!(sig3(12345.0), "12345");
        assert_eq!(sig3(f64::NAN), "-");
        assert_eq!(si(1_234_567.0), "1.23 M");
        assert_eq!(si(456_000.0), "456 k");
        assert_eq!(si(12.0), "12.0");
        assert_eq!(si(2.5e9), "2.50 G");
    }
}
