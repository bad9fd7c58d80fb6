//! `cargo xtask study` killed (SIGKILL) at seeded random moments and run
//! again with the same command gives the curves and images of an
//! uninterrupted run; run again once finished, it renders nothing.

use std::fs;
use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use serde_json::Value;

/// The program under test, built by Cargo for this test.
const XTASK: &str = env!("CARGO_BIN_EXE_xtask");

/// Kill trials, each from an empty cache: with [`KILLS_PER_TRIAL`], up to
/// 21 kills, each chain then run to its end and compared.
const TRIALS: u64 = 7;

/// Kills per trial, at most, before the run that is let finish (a run that
/// ends before its kill ends the trial's chain).
const KILLS_PER_TRIAL: u64 = 3;

/// A kill comes this long at most after the start of a render (one of the
/// study's renders takes about as long on an idle machine, with a
/// checkpoint after every iteration), so that it lands in the render, in
/// storing it, or in setting up the next one.
const MAX_KILL_DELAY: Duration = Duration::from_millis(120);

/// A small study: two references and three configs (a tau0 sweep), 24x16,
/// a checkpoint after every iteration.
fn args(out: &Path, cache: &Path) -> Vec<String> {
    [
        "study",
        "--scene",
        "scenes/glossy-caustic",
        "--resolution",
        "24x16",
        "--iterations",
        "24",
        "--reference-iterations",
        "8",
        "--configs",
        "bpt,bpt-uns",
        "--sweep",
        "tau0=7.5,30",
        "--unbiased-reference",
        "bpt",
        "--seed",
        "31337",
        "--checkpoint-interval",
        "0",
    ]
    .iter()
    .map(|s| s.to_string())
    .chain([
        "--out".to_string(),
        out.display().to_string(),
        "--cache".to_string(),
        cache.display().to_string(),
    ])
    .collect()
}

fn temp_dir(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("xtask-study-kill-{name}-{}", std::process::id()));
    let _ = fs::remove_dir_all(&dir);
    fs::create_dir_all(&dir).unwrap();
    dir
}

/// Runs the study to the end; returns its standard output.
fn run_to_end(out: &Path, cache: &Path) -> String {
    let output = Command::new(XTASK)
        .args(args(out, cache))
        .stdin(Stdio::null())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        output.status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    stdout
}

/// Whether a line of the study's output says a render starts
/// (`bpt-uns@tau0=30: 24 iterations`, or `..., from 9` when resumed).
fn starts_a_render(line: &str) -> bool {
    let Some((_, rest)) = line.rsplit_once(": ") else {
        return false;
    };
    let rest = rest.split(", from ").next().unwrap_or_default();
    rest.strip_suffix(" iterations")
        .is_some_and(|n| n.parse::<u64>().is_ok())
}

/// Starts the study and kills it with SIGKILL `delay` after the start of
/// its render number `render` (counted from 0 in this run's output);
/// returns whether it was killed (false: it finished first) and how many
/// renders it resumed from a checkpoint before.
fn run_and_kill(out: &Path, cache: &Path, render: usize, delay: Duration) -> (bool, usize) {
    let mut child = Command::new(XTASK)
        .args(args(out, cache))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let stdout = BufReader::new(child.stdout.take().unwrap());
    let (mut renders, mut resumed) = (0, 0);
    for line in stdout.lines() {
        let line = line.unwrap();
        resumed += usize::from(line.starts_with("resuming "));
        if starts_a_render(&line) {
            if renders == render {
                std::thread::sleep(delay);
                break;
            }
            renders += 1;
        }
    }
    let killed = child.try_wait().unwrap().is_none();
    // `Child::kill` sends SIGKILL on Unix: no destructor, no flush runs.
    let _ = child.kill();
    child.wait().unwrap();
    (killed, resumed)
}

/// What a study's outputs must reproduce exactly: every curve point's
/// errors and noise (not its times), every config's and reference's key
/// and dropped samples, the references' noise, and every image's bytes.
fn deterministic(out: &Path) -> Vec<String> {
    let json: Value =
        serde_json::from_str(&fs::read_to_string(out.join("curves.json")).unwrap()).unwrap();
    let mut lines = Vec::new();
    for row in json["rows"].as_array().unwrap() {
        let mut row = row.clone();
        let fields = row.as_object_mut().unwrap();
        fields.remove("seconds");
        fields.remove("cpu_seconds");
        lines.push(row.to_string());
    }
    for c in json["configs"].as_array().unwrap() {
        lines.push(format!(
            "{} {} {}",
            c["config"], c["key"], c["invalid_samples"]
        ));
    }
    for r in json["references"].as_array().unwrap() {
        lines.push(format!(
            "{} {} {} {} {}",
            r["config"], r["key"], r["noise_std_error"], r["noise_variance"], r["invalid_samples"]
        ));
    }
    let mut images: Vec<PathBuf> = fs::read_dir(out.join("images"))
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    images.sort();
    for image in images {
        let bytes = fs::read(&image).unwrap();
        let mut hash = 0xcbf2_9ce4_8422_2325u64;
        for b in bytes {
            hash = (hash ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3);
        }
        lines.push(format!(
            "{} {hash:016x}",
            image.file_name().unwrap().display()
        ));
    }
    lines
}

/// The rows of curves.json, times included.
fn rows(out: &Path) -> Value {
    let json: Value =
        serde_json::from_str(&fs::read_to_string(out.join("curves.json")).unwrap()).unwrap();
    json["rows"].clone()
}

/// Whether every config's wall-clock and CPU times grow along its curve
/// (a resumed curve goes on from its checkpoint's times, not from zero).
fn times_grow(out: &Path) -> bool {
    let mut last = std::collections::HashMap::new();
    rows(out).as_array().unwrap().iter().all(|row| {
        let curve = (row["config"].to_string(), row["reference"].to_string());
        let times = [row["seconds"].as_f64(), row["cpu_seconds"].as_f64()];
        let grows = last.get(&curve).is_none_or(|before: &[Option<f64>; 2]| {
            before.iter().zip(&times).all(|(a, b)| match (a, b) {
                (Some(a), Some(b)) => a <= b,
                _ => true,
            })
        });
        last.insert(curve, times);
        grows
    })
}

/// A random number in [0, 1) from a 64-bit xorshift state.
fn uniform(state: &mut u64) -> f64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    (*state >> 11) as f64 / (1u64 << 53) as f64
}

/// An uninterrupted study; the same command again renders nothing and
/// reproduces its curves, times included; then studies killed at seeded
/// random moments (in a reference's or a config's render, in storing it or
/// in setting up the next) and run again with the same command, killed
/// again and finally let finish, reproduce its curves and images.
#[test]
fn killed_studies_resume_to_the_same_curves_and_finished_ones_render_nothing() {
    let base = temp_dir("base");
    let (out, cache) = (base.join("out"), base.join("cache"));
    let t = Instant::now();
    let first = run_to_end(&out, &cache);
    let whole = t.elapsed();
    assert!(first.contains("rendered in"), "{first}");
    assert_eq!(first.lines().filter(|l| starts_a_render(l)).count(), 5);
    let expected = deterministic(&out);
    let expected_rows = rows(&out);
    assert!(expected.len() > 20, "{expected:?}");

    // Run again: every reference and config from the cache, nothing rendered.
    let again = run_to_end(&out, &cache);
    for config in ["bpt", "bpt-uns@tau0=7.5", "bpt-uns@tau0=30"] {
        assert!(
            again.contains(&format!("reusing cached run of {config} (key ")),
            "{config}: {again}"
        );
    }
    assert_eq!(again.matches("from the cache (").count(), 2, "{again}");
    assert!(
        !again.lines().any(starts_a_render),
        "something was rendered: {again}"
    );
    assert_eq!(deterministic(&out), expected);
    assert_eq!(rows(&out), expected_rows, "reused curves keep their times");

    // Kill, kill again, then let it finish.
    let mut rng = 0x9e37_79b9_7f4a_7c15u64;
    let (mut killed, mut resumed) = (0, 0);
    for trial in 0..TRIALS {
        let dir = temp_dir(&format!("trial-{trial}"));
        let (out, cache) = (dir.join("out"), dir.join("cache"));
        for _ in 0..KILLS_PER_TRIAL {
            let render = (uniform(&mut rng) * 3.0) as usize;
            let delay = MAX_KILL_DELAY.mul_f64(uniform(&mut rng));
            let (was_killed, resumes) = run_and_kill(&out, &cache, render, delay);
            resumed += resumes;
            if !was_killed {
                break;
            }
            killed += 1;
        }
        let last = run_to_end(&out, &cache);
        resumed += last.matches("resuming ").count();
        assert_eq!(deterministic(&out), expected, "trial {trial}: {last}");
        assert!(times_grow(&out), "trial {trial}: {}", rows(&out));
        // Nothing is left of the checkpoints.
        assert!(!cache.join("partial").exists(), "trial {trial}");
        fs::remove_dir_all(dir).unwrap();
    }
    println!(
        "{killed} runs killed, {resumed} renders resumed; an uninterrupted study takes {whole:?}"
    );
    assert!(killed > 0, "no run was killed: the study ran too fast");
    assert!(resumed > 0, "no render was resumed from a checkpoint");
    fs::remove_dir_all(base).unwrap();
}
