//! `cargo xtask bench --micro`: criterion micro-benchmarks collected into one table.

use std::fmt::Write as _;
use std::fs;
use std::path::{Path, PathBuf};

use serde_json::{Value, json};

/// Crates with criterion benchmarks, in layer order.
const BENCHED_CRATES: &[&str] = &["microfacet", "regularization"];

/// One benchmark result: criterion's mean with its 95 % confidence interval.
struct Row {
    id: String,
    mean_ns: f64,
    lower_ns: f64,
    upper_ns: f64,
}

pub fn run(root: &Path, args: &[String]) -> Result<(), String> {
    let quick = crate::quick_flag(args, "cargo xtask bench --micro [--quick]")?;
    let criterion_dir = root.join("target").join("criterion");
    // Stale results of renamed benchmarks would otherwise end up in the table.
    if criterion_dir.exists() {
        fs::remove_dir_all(&criterion_dir)
            .map_err(|e| format!("cannot clear {}: {e}", criterion_dir.display()))?;
    }
    for krate in BENCHED_CRATES {
        // Criterion targets only: the library's libtest harness rejects
        // criterion's flags (`--warm-up-time`), which failed `--quick`.
        let mut cargo_args = vec!["bench", "-p", krate, "--bench", "*", "--"];
        if quick {
            cargo_args.extend(["--warm-up-time", "0.3", "--measurement-time", "1"]);
        }
        crate::cargo(root, &cargo_args)?;
    }
    let mut rows = collect(&criterion_dir)?;
    rows.sort_by(|a, b| a.id.cmp(&b.id));
    write_reports(&root.join("target").join("bench"), &rows)
}

/// Reads every `*/new/benchmark.json` + `estimates.json` pair under `dir`.
fn collect(dir: &Path) -> Result<Vec<Row>, String> {
    let mut rows = Vec::new();
    for estimates in find_files(dir, "estimates.json") {
        let Some(new_dir) = estimates.parent().filter(|p| p.ends_with("new")) else {
            continue;
        };
        let benchmark = read_json(&new_dir.join("benchmark.json"))?;
        let estimates = read_json(&estimates)?;
        let id = benchmark["full_id"].as_str().unwrap_or("?").to_string();
        let mean = &estimates["mean"];
        let number = |v: &Value| {
            v.as_f64()
                .ok_or_else(|| format!("{id}: malformed estimates.json"))
        };
        rows.push(Row {
            mean_ns: number(&mean["point_estimate"])?,
            lower_ns: number(&mean["confidence_interval"]["lower_bound"])?,
            upper_ns: number(&mean["confidence_interval"]["upper_bound"])?,
            id,
        });
    }
    if rows.is_empty() {
        return Err(format!("no criterion results under {}", dir.display()));
    }
    Ok(rows)
}

fn find_files(dir: &Path, name: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        let Ok(entries) = fs::read_dir(&d) else {
            continue;
        };
        for entry in entries.flatten() {
            let path = entry.path();
            if path.is_dir() {
                stack.push(path);
            } else if path.file_name().is_some_and(|n| n == name) {
                out.push(path);
            }
        }
    }
    out
}

fn read_json(path: &Path) -> Result<Value, String> {
    let text =
        fs::read_to_string(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))
}

fn write_reports(out_dir: &Path, rows: &[Row]) -> Result<(), String> {
    fs::create_dir_all(out_dir).map_err(|e| format!("cannot create {}: {e}", out_dir.display()))?;
    let cores = crate::cores();
    let mut md = format!(
        "# Micro-benchmarks\n\nMachine: {cores} logical cores. Criterion mean per call, 95 % interval.\n\n"
    );
    md.push_str("| benchmark | mean (ns) | interval (ns) |\n|---|---:|---:|\n");
    for r in rows {
        let _ = writeln!(
            md,
            "| {} | {:.1} | {:.1} - {:.1} |",
            r.id, r.mean_ns, r.lower_ns, r.upper_ns
        );
    }
    let json = json!({
        "cores": cores,
        "results": rows.iter().map(|r| json!({
            "id": r.id, "mean_ns": r.mean_ns, "lower_ns": r.lower_ns, "upper_ns": r.upper_ns,
        })).collect::<Vec<_>>(),
    });
    crate::publish_report(out_dir, "micro", &md, &json)?;
    Ok(())
}
