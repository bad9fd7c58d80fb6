//! `cargo xtask bench`: end-to-end throughput of every integrator on every
//! bundled scene, written as JSON and a markdown table with the machine's
//! facts, for comparing commits side by side. `--micro` runs the criterion
//! micro-benchmarks instead.
//!
//! Every (scene, integrator) run is a child process (`xtask bench-run ...`,
//! see `run`), so that its peak memory is its own and a panic costs one row,
//! not the whole bench. Outside `--quick` the children are a release build:
//! dev-profile numbers say little about the renderer's speed.
//!
//! - this file: flags, the release build, spawning the runs, machine facts
//! - `run`: the child, which measures one run and prints one JSON line
//! - `report`: the markdown table and the comparison with a baseline
//! - `micro`: the criterion micro-benchmarks (`--micro`)

mod micro;
mod report;
mod run;
mod scaling;

use std::fs;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

use integrators::Algorithm;
use serde_json::{Value, json};

pub(crate) use run::child as run_child;
pub(crate) use scaling::height_field_obj_scene;

/// The task's lines in `cargo xtask help` (and `cargo xtask bench --help`).
pub const USAGE: &str =
    "  bench [options]   end-to-end benchmark: every integrator (pt, bpt, ppm, bpm, vcm)
                    on every bundled scene (scenes/*/scene.toml), each run in
                    its own process: seconds per iteration, samples/s, rays/s,
                    rays per sample, peak memory and build time. Writes
                    end-to-end.json and end-to-end.md (with the core count,
                    CPU, commit and profile) and prints the table. Without
                    --quick it first runs `cargo build --release -p xtask`
                    and measures that build. Max depth and regularization
                    are each scene manifest's (render-cli's defaults
                    otherwise); the integrator is the run's.
      --scenes LIST         comma-separated bundled scenes (default: all)
      --integrators LIST    comma-separated pt, bpt, ppm, bpm, vcm (default: all)
      --resolution WxH      image size of every scene (default 256x192)
      --iterations N        timed iterations, after 1 untimed warm-up
                            (default 8)
      --repeat N            rounds: every (scene, integrator) runs once per
                            round, rounds one after the other, and each row
                            reports its median round (and the range): on a
                            shared machine, load that comes and goes then
                            skews all rows alike (default 1)
      --quick               64x48 and 2 iterations (explicit flags win),
                            measured with the current (dev-profile) build:
                            for CI
      --baseline FILE       a previous run's end-to-end.json: the table gets
                            a column new/old seconds per iteration, and rows
                            missing on either side are listed
      --out DIR             output folder (default target/bench)
  bench --scaling [--quick] [--integrators I] [--iterations N] [--out DIR]
                    scaling: a generated height field of 1k, 10k, 100k and
                    1M triangles at 256x256, then the 100k one at 256^2 to
                    2048^2 pixels (the first of --integrators, default pt):
                    load and BVH build time, seconds per iteration, peak
                    memory and marginal bytes per triangle, one process per
                    point, into scaling.md and scaling.json
  bench --micro [--quick]
                    criterion micro-benchmarks (crates/*/benches) into
                    target/bench/micro.md and micro.json (--quick: 0.3 s
                    warm-up and 1 s measurement per benchmark)";

/// Image size and timed iterations of a full run and of `--quick`.
const DEFAULT_RESOLUTION: (u32, u32) = (256, 192);
const DEFAULT_ITERATIONS: u64 = 8;
const QUICK_RESOLUTION: (u32, u32) = (64, 48);
const QUICK_ITERATIONS: u64 = 2;

/// The parsed command line of the end-to-end benchmark.
#[derive(Clone, Debug, PartialEq)]
struct Options {
    /// Scene names (folders under `scenes/`), in sorted order.
    scenes: Vec<String>,
    /// Integrators, in `Algorithm::ALL` order.
    integrators: Vec<Algorithm>,
    resolution: (u32, u32),
    iterations: u64,
    /// Rounds over all (scene, integrator) pairs; each row reports its median.
    repeat: u64,
    /// Small image, few iterations, the current build.
    quick: bool,
    baseline: Option<PathBuf>,
    /// Output folder; None: `target/bench` under the workspace root.
    out: Option<PathBuf>,
}

impl Options {
    /// Parses `args`; `bundled` lists the scenes `--scenes` may name.
    /// `Ok(None)` asks for the help text.
    fn parse(args: &[String], bundled: &[String]) -> Result<Option<Self>, String> {
        let (mut scenes, mut integrators) = (None, None);
        let (mut resolution, mut iterations, mut repeat) = (None, None, None);
        let (mut quick, mut baseline, mut out) = (false, None, None);
        let mut rest = args.iter();
        while let Some(arg) = rest.next() {
            let (flag, inline) = match arg.split_once('=') {
                Some((f, v)) if f.starts_with("--") => (f, Some(v)),
                _ => (arg.as_str(), None),
            };
            if matches!(flag, "-h" | "--help" | "--quick") {
                if inline.is_some() {
                    return Err(format!("{flag}: takes no value"));
                }
                if flag == "--quick" {
                    quick = true;
                    continue;
                }
                return Ok(None);
            }
            let known = [
                "--scenes",
                "--integrators",
                "--resolution",
                "--iterations",
                "--repeat",
                "--baseline",
                "--out",
            ];
            if !known.contains(&flag) {
                return Err(format!(
                    "unknown option '{arg}' (see `cargo xtask bench --help`)"
                ));
            }
            let value = match inline {
                Some(v) => v,
                None => rest
                    .next()
                    .ok_or_else(|| format!("{flag}: missing value"))?,
            };
            match flag {
                "--scenes" => scenes = Some(scene_list(value, bundled)?),
                "--integrators" => integrators = Some(integrator_list(value)?),
                "--resolution" => {
                    let r = crate::study::parse_resolution(value)?;
                    resolution = Some((r.x, r.y));
                }
                "--iterations" => iterations = Some(crate::study::positive(flag, value)?),
                "--repeat" => repeat = Some(crate::study::positive(flag, value)?),
                "--baseline" => baseline = Some(PathBuf::from(value)),
                _ => out = Some(PathBuf::from(value)),
            }
        }
        let (default_resolution, default_iterations) = if quick {
            (QUICK_RESOLUTION, QUICK_ITERATIONS)
        } else {
            (DEFAULT_RESOLUTION, DEFAULT_ITERATIONS)
        };
        Ok(Some(Self {
            scenes: scenes.unwrap_or_else(|| bundled.to_vec()),
            integrators: integrators
                .unwrap_or_else(|| Algorithm::ALL.iter().map(|&(a, _)| a).collect()),
            resolution: resolution.unwrap_or(default_resolution),
            iterations: iterations.unwrap_or(default_iterations),
            repeat: repeat.unwrap_or(1),
            quick,
            baseline,
            out,
        }))
    }
}

/// `--scenes a,b`: bundled scene names, kept in the bundled (sorted) order
/// so that tables of different runs list rows alike.
fn scene_list(value: &str, bundled: &[String]) -> Result<Vec<String>, String> {
    let names: Vec<&str> = value
        .split(',')
        .map(str::trim)
        .filter(|s| !s.is_empty())
        .collect();
    if names.is_empty() {
        return Err("--scenes: the list is empty".into());
    }
    if let Some(bad) = names.iter().find(|n| !bundled.iter().any(|b| b == *n)) {
        return Err(format!(
            "--scenes: unknown scene '{bad}' (bundled: {})",
            bundled.join(", ")
        ));
    }
    Ok(bundled
        .iter()
        .filter(|b| names.contains(&b.as_str()))
        .cloned()
        .collect())
}

/// `--integrators pt,bpt`: in `Algorithm::ALL` order.
fn integrator_list(value: &str) -> Result<Vec<Algorithm>, String> {
    let mut chosen = Vec::new();
    for name in value.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        chosen.push(
            name.parse::<Algorithm>()
                .map_err(|e| format!("--integrators: {e}"))?,
        );
    }
    if chosen.is_empty() {
        return Err("--integrators: the list is empty".into());
    }
    Ok(Algorithm::ALL
        .iter()
        .map(|&(a, _)| a)
        .filter(|a| chosen.contains(a))
        .collect())
}

/// The bundled scenes: folders under `scenes/` with a `scene.toml`, sorted.
fn bundled_scenes(root: &Path) -> Result<Vec<String>, String> {
    let dir = root.join("scenes");
    let entries = fs::read_dir(&dir).map_err(|e| format!("cannot list {}: {e}", dir.display()))?;
    let mut names: Vec<String> = entries
        .flatten()
        .filter(|e| e.path().join("scene.toml").is_file())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    Ok(names)
}

/// Runs `cargo xtask bench ARGS`.
pub fn run(root: &Path, args: &[String]) -> Result<(), String> {
    if args.iter().any(|a| a == "--micro") {
        let rest: Vec<String> = args.iter().filter(|a| *a != "--micro").cloned().collect();
        return micro::run(root, &rest);
    }
    let scaling = args.iter().any(|a| a == "--scaling");
    let args: Vec<String> = args.iter().filter(|a| *a != "--scaling").cloned().collect();
    let bundled = bundled_scenes(root)?;
    let Some(options) = Options::parse(&args, &bundled)? else {
        println!("usage: cargo xtask bench [options]\n\n{USAGE}");
        return Ok(());
    };
    if scaling {
        return scaling::run(root, &options);
    }
    // A bad baseline fails before minutes of measuring, not after.
    let baseline = match &options.baseline {
        Some(path) => Some((path.display().to_string(), read_baseline(path)?)),
        None => None,
    };
    let out_dir = options
        .out
        .clone()
        .unwrap_or_else(|| root.join("target").join("bench"));
    fs::create_dir_all(&out_dir)
        .map_err(|e| format!("--out: cannot create {}: {e}", out_dir.display()))?;

    let (exe, profile) = child_executable(root, options.quick)?;
    let load_before = crate::load_average();
    let started = Instant::now();
    let runs = run_all(root, &exe, &options);
    // Failed runs are in the table; they fail the task after it is written.
    let failed: Vec<String> = runs
        .iter()
        .filter(|r| r["status"] != "ok")
        .map(|r| {
            let field = |k| report::text(r, k);
            format!(
                "{} {} ({})",
                field("scene"),
                field("integrator"),
                field("error")
            )
        })
        .collect();

    let doc = json!({
        "benchmark": "end-to-end",
        "date": utc_now(),
        "git": git_state(root),
        "profile": profile,
        "machine": {
            "cores": crate::cores(),
            "rayon_threads": rayon::current_num_threads(),
            "cpu_model": cpu_model(),
            // Other processes skew wall-clock times: /proc/loadavg before
            // and after the runs.
            "load_average": [load_before, crate::load_average()],
        },
        "resolution": [options.resolution.0, options.resolution.1],
        "iterations": options.iterations,
        "warmup_iterations": 1,
        "repeat": options.repeat,
        "total_seconds": started.elapsed().as_secs_f64(),
        "runs": runs,
    });
    let md = report::markdown(&doc, baseline.as_ref().map(|(p, v)| (p.as_str(), v)));
    crate::publish_report(&out_dir, "end-to-end", &md, &doc)?;

    if failed.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "{} of {} runs failed: {}",
            failed.len(),
            runs.len(),
            failed.join("; ")
        ))
    }
}

/// The profile this executable was built with: `dev` (xtask unoptimised,
/// the renderer's crates at opt-level 3, see the root Cargo.toml; `cargo
/// xtask` builds it as the test profile, which has the same settings) or
/// `release`. Numbers of different profiles do not compare.
const PROFILE: &str = if cfg!(debug_assertions) {
    "dev"
} else {
    "release"
};

/// The executable the runs spawn, with its profile: with `--quick` this
/// one (short for CI); otherwise a release build of xtask, built first, so
/// that numbers of different commits compare.
fn child_executable(root: &Path, quick: bool) -> Result<(PathBuf, &'static str), String> {
    if quick {
        let exe = std::env::current_exe().map_err(|e| format!("cannot find xtask: {e}"))?;
        return Ok((exe, PROFILE));
    }
    crate::cargo(root, &["build", "--release", "-p", "xtask"])?;
    let target = std::env::var_os("CARGO_TARGET_DIR")
        .map_or_else(|| root.join("target"), |dir| root.join(dir));
    let exe = format!("xtask{}", std::env::consts::EXE_SUFFIX);
    Ok((target.join("release").join(exe), "release"))
}

/// Every (scene, integrator) of `options`, one child process after the
/// other, `options.repeat` rounds, with a progress line each on stderr.
/// One row per pair: its median round (see [`median_round`]).
fn run_all(root: &Path, exe: &Path, options: &Options) -> Vec<Value> {
    let pairs: Vec<(&String, Algorithm)> = options
        .scenes
        .iter()
        .flat_map(|scene| options.integrators.iter().map(move |&a| (scene, a)))
        .collect();
    let total = pairs.len() as u64 * options.repeat;
    let mut rounds: Vec<Vec<Value>> = vec![Vec::new(); pairs.len()];
    let mut n = 0;
    for _ in 0..options.repeat {
        for (&(scene, algorithm), round) in pairs.iter().zip(&mut rounds) {
            n += 1;
            eprint!("[{n}/{total}] {scene} {algorithm} ... ");
            let _ = std::io::stderr().flush();
            let scene_file = root.join("scenes").join(scene).join("scene.toml");
            let mut result = spawn_run(exe, &scene_file, algorithm, options);
            match result["seconds_per_iteration"].as_f64() {
                Some(s) => eprintln!("{} s/it", report::sig3(s)),
                None => eprintln!("FAILED: {}", report::text(&result, "error")),
            }
            result["scene"] = json!(scene);
            result["integrator"] = json!(algorithm.name());
            round.push(result);
        }
    }
    rounds.into_iter().map(median_round).collect()
}

/// The row of one (scene, integrator) from its rounds: the first failed
/// round if any failed; otherwise the round with the median seconds per
/// iteration (the lower one of an even count), with every round's seconds
/// per iteration as `"rounds_seconds_per_iteration"` when there are several.
fn median_round(mut rounds: Vec<Value>) -> Value {
    if let Some(i) = rounds.iter().position(|r| r["status"] != "ok") {
        return rounds.swap_remove(i);
    }
    let seconds = |r: &Value| r["seconds_per_iteration"].as_f64().unwrap_or(f64::NAN);
    let all: Vec<f64> = rounds.iter().map(seconds).collect();
    rounds.sort_by(|a, b| seconds(a).total_cmp(&seconds(b)));
    let mut row = rounds.swap_remove((rounds.len() - 1) / 2);
    if all.len() > 1 {
        row["rounds_seconds_per_iteration"] = json!(all);
    }
    row
}

/// Runs one (scene, integrator) in a child process and returns its JSON
/// object, with `"status": "ok"`, or `"failed"` and the child's last line
/// of stderr as `"error"`.
fn spawn_run(exe: &Path, scene_file: &Path, algorithm: Algorithm, options: &Options) -> Value {
    let (w, h) = options.resolution;
    let output = Command::new(exe)
        .arg("bench-run")
        .arg(scene_file)
        .args([
            algorithm.name().to_string(),
            w.to_string(),
            h.to_string(),
            options.iterations.to_string(),
        ])
        // The panic message, not a backtrace, is the last line of stderr.
        .env("RUST_BACKTRACE", "0")
        .stdin(Stdio::null())
        .output();
    let output = match output {
        Ok(o) => o,
        Err(e) => return failed(format!("cannot run {}: {e}", exe.display())),
    };
    let result = String::from_utf8_lossy(&output.stdout)
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .and_then(|l| serde_json::from_str::<Value>(l).ok())
        .filter(Value::is_object);
    match result {
        Some(mut v) if output.status.success() => {
            v["status"] = json!("ok");
            v
        }
        _ => failed(
            last_line(&String::from_utf8_lossy(&output.stderr))
                .unwrap_or_else(|| format!("exited with {} and no result", output.status)),
        ),
    }
}

/// A failed run's JSON object.
fn failed(error: String) -> Value {
    json!({ "status": "failed", "error": error })
}

/// The last informative line of a child's stderr: skips empty lines and
/// rustc's `note: run with RUST_BACKTRACE=1 ...` after a panic message.
fn last_line(stderr: &str) -> Option<String> {
    stderr
        .lines()
        .map(str::trim)
        .rev()
        .find(|l| !l.is_empty() && !l.starts_with("note: "))
        .map(str::to_string)
}

/// Reads a previous run's `end-to-end.json`.
fn read_baseline(path: &Path) -> Result<Value, String> {
    let text = fs::read_to_string(path)
        .map_err(|e| format!("--baseline: cannot read {}: {e}", path.display()))?;
    let doc: Value =
        serde_json::from_str(&text).map_err(|e| format!("--baseline: {}: {e}", path.display()))?;
    if !doc["runs"].is_array() {
        return Err(format!(
            "--baseline: {}: not an end-to-end.json (no \"runs\" list)",
            path.display()
        ));
    }
    Ok(doc)
}

/// `git rev-parse HEAD` and whether `git status --porcelain` lists changes;
/// nulls outside a git checkout.
fn git_state(root: &Path) -> Value {
    let git = |args: &[&str]| {
        crate::git(root, args).map(|out| String::from_utf8_lossy(&out).trim().to_string())
    };
    json!({
        "commit": git(&["rev-parse", "HEAD"]),
        "dirty": git(&["status", "--porcelain"]).map(|s| !s.is_empty()),
    })
}

/// The first `model name` of /proc/cpuinfo, if any.
fn cpu_model() -> Option<String> {
    let info = fs::read_to_string("/proc/cpuinfo").ok()?;
    info.lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, v)| v.trim().to_string())
}

/// The current time in UTC, `YYYY-MM-DD hh:mm:ss UTC`.
fn utc_now() -> String {
    let secs = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    utc_date(secs)
}

/// `secs` since the Unix epoch as a UTC date (Hinnant's civil_from_days).
fn utc_date(secs: u64) -> String {
    let z = (secs / 86_400) as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z.rem_euclid(146_097);
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let day = doy - (153 * mp + 2) / 5 + 1;
    let month = if mp < 10 { mp + 3 } else { mp - 9 };
    let year = yoe + era * 400 + i64::from(month <= 2);
    let s = secs % 86_400;
    format!(
        "{year:04}-{month:02}-{day:02} {:02}:{:02}:{:02} UTC",
        s / 3600,
        s / 60 % 60,
        s % 60
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn bundled() -> Vec<String> {
        [
            "caustic-glass",
            "cornell-box",
            "diffuse-only",
            "glossy-caustic",
            "stiff",
        ]
        .map(String::from)
        .to_vec()
    }

    fn parse(args: &[&str]) -> Result<Options, String> {
        let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        Options::parse(&args, &bundled())?.ok_or_else(|| "help".into())
    }

    #[test]
    fn defaults_quick_and_flags() {
        let all = parse(&[]).unwrap();
        assert_eq!(all.scenes, bundled());
        assert_eq!(all.integrators.len(), Algorithm::ALL.len());
        assert_eq!(
            (all.resolution, all.iterations, all.repeat),
            ((256, 192), 8, 1)
        );
        assert!(!all.quick && all.baseline.is_none() && all.out.is_none());

        let quick = parse(&["--quick"]).unwrap();
        assert_eq!((quick.resolution, quick.iterations), ((64, 48), 2));

        let some = parse(&[
            "--quick",
            "--scenes",
            "stiff, cornell-box",
            "--integrators=VCM,pt",
            "--resolution",
            "32x24",
            "--iterations=3",
            "--repeat",
            "5",
            "--baseline",
            "old.json",
            "--out",
            "x",
        ])
        .unwrap();
        assert_eq!(some.scenes, ["cornell-box", "stiff"], "bundled order");
        assert_eq!(some.integrators, [Algorithm::Pt, Algorithm::Vcm]);
        assert_eq!(
            (some.resolution, some.iterations, some.repeat),
            ((32, 24), 3, 5)
        );
        assert!(some.quick);
        assert_eq!(some.baseline, Some(PathBuf::from("old.json")));
        assert_eq!(some.out, Some(PathBuf::from("x")));

        assert_eq!(Options::parse(&["-h".into()], &bundled()), Ok(None));
        assert_eq!(Options::parse(&["--help".into()], &bundled()), Ok(None));
    }

    #[test]
    fn bad_flags_are_one_line_naming_the_flag() {
        let cases: &[(&[&str], &str)] = &[
            (&["--frobnicate"], "--frobnicate"),
            (&["cornell-box"], "cornell-box"),
            (&["--scenes"], "--scenes: missing value"),
            (
                &["--scenes", "kitchen"],
                "--scenes: unknown scene 'kitchen'",
            ),
            (&["--scenes", ","], "--scenes: the list is empty"),
            (&["--integrators", "pt,mlt"], "--integrators"),
            (&["--integrators="], "--integrators: the list is empty"),
            (&["--resolution", "256"], "--resolution"),
            (&["--resolution", "0x10"], "--resolution"),
            (&["--iterations", "0"], "--iterations"),
            (&["--iterations", "many"], "--iterations"),
            (&["--repeat", "0"], "--repeat"),
            (&["--quick=yes"], "--quick: takes no value"),
            (&["--out"], "--out: missing value"),
        ];
        for (args, needle) in cases {
            let e = parse(args).unwrap_err();
            assert!(e.contains(needle), "{args:?}: {e}");
            assert!(!e.contains('\n'), "{args:?}: {e}");
        }
    }

    #[test]
    fn usage_documents_every_flag() {
        for flag in [
            "--scenes",
            "--integrators",
            "--resolution",
            "--iterations",
            "--repeat",
            "--quick",
            "--baseline",
            "--out",
            "--micro",
        ] {
            assert!(USAGE.contains(flag), "{flag}");
        }
    }

    /// A row is its median round, with every round listed; a failure wins.
    #[test]
    fn rows_are_median_rounds() {
        let ok = |s: f64, rays: f64| json!({ "status": "ok", "seconds_per_iteration": s, "rays_per_sample": rays });
        let row = median_round(vec![ok(0.9, 1.0), ok(0.5, 2.0), ok(0.7, 3.0)]);
        assert_eq!(row["seconds_per_iteration"], 0.7);
        assert_eq!(
            row["rays_per_sample"], 3.0,
            "the median round's other fields"
        );
        assert_eq!(row["rounds_seconds_per_iteration"], json!([0.9, 0.5, 0.7]));
        let even = median_round(vec![ok(0.9, 1.0), ok(0.5, 2.0), ok(0.7, 3.0), ok(0.6, 4.0)]);
        assert_eq!(even["seconds_per_iteration"], 0.6, "the lower median");
        let single = median_round(vec![ok(0.9, 1.0)]);
        assert_eq!(single, ok(0.9, 1.0), "one round: no list");
        let failed = median_round(vec![ok(0.9, 1.0), failed("boom".into())]);
        assert_eq!(failed["error"], "boom");
    }

    #[test]
    fn child_failures_keep_the_message_not_the_note() {
        let stderr = "thread 'main' panicked at src/x.rs:1:1:\nboom\n\
                      note: run with `RUST_BACKTRACE=1` environment variable to display a backtrace\n";
        assert_eq!(last_line(stderr).as_deref(), Some("boom"));
        assert_eq!(
            last_line("error: no such scene\n").as_deref(),
            Some("error: no such scene")
        );
        assert_eq!(last_line(""), None);
    }

    /// A stand-in child: a shell script with the given body.
    #[cfg(unix)]
    fn fake_child(name: &str, body: &str) -> PathBuf {
        use std::os::unix::fs::PermissionsExt as _;
        let dir = std::env::temp_dir().join(format!("xtask-bench-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join(name);
        fs::write(&path, format!("#!/bin/sh\n{body}\n")).unwrap();
        fs::set_permissions(&path, fs::Permissions::from_mode(0o755)).unwrap();
        path
    }

    /// A child's JSON line is the run; a panic, a non-zero exit or a missing
    /// line is a failed run with the child's last stderr line.
    #[cfg(unix)]
    #[test]
    fn children_succeed_or_fail_with_their_message() {
        let options = parse(&["--quick"]).unwrap();
        let spawn = |name, body| {
            spawn_run(
                &fake_child(name, body),
                Path::new("s.toml"),
                Algorithm::Pt,
                &options,
            )
        };
        let ok = spawn(
            "ok",
            "test \"$*\" = 'bench-run s.toml pt 64 48 2' || exit 3\n\
             echo warning >&2; echo '{\"seconds_per_iteration\": 0.5}'",
        );
        assert_eq!(ok["status"], "ok", "{ok}");
        assert_eq!(ok["seconds_per_iteration"], 0.5);
        let panicked = spawn(
            "panic",
            "echo \"thread 'main' panicked at src/x.rs:1:1:\" >&2; echo boom >&2\n\
             echo 'note: run with `RUST_BACKTRACE=1`' >&2; exit 101",
        );
        assert_eq!(
            (&panicked["status"], &panicked["error"]),
            (&json!("failed"), &json!("boom"))
        );
        let exit = spawn("exit", "echo '{\"seconds_per_iteration\": 0.5}'; exit 1");
        assert_eq!(exit["status"], "failed", "{exit}");
        assert!(
            exit["error"].as_str().unwrap().contains("no result"),
            "{exit}"
        );
        let missing = spawn_run(
            Path::new("/no/such/xtask"),
            Path::new("s"),
            Algorithm::Pt,
            &options,
        );
        assert!(
            missing["error"].as_str().unwrap().starts_with("cannot run"),
            "{missing}"
        );
    }

    #[test]
    fn dates_are_utc() {
        assert_eq!(utc_date(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(utc_date(1_704_067_200 + 3661), "2024-01-01 01:01:01 UTC");
        assert_eq!(utc_date(951_782_400), "2000-02-29 00:00:00 UTC");
    }
}
