//! `cargo xtask farm selftest`: the farm on a real Slurm, a single-node
//! cluster on this machine (`scripts/slurm-local`). Skipped, with the
//! reason on one line, where no cluster can be started (not root, no
//! packages).
//!
//! 1. Four shards of a VCM render (light-tracing splats and merges: every
//!    kind of contribution) and their merge give the single-process EXR.
//! 2. Kill test: of four running shards, one is killed (SIGKILL) and one
//!    terminated (SIGTERM, which render-cli turns into "stop after this
//!    iteration"), each after its first checkpoint; neither leaves a partial
//!    film, both leave a checkpoint, the merge is cancelled by Slurm, `farm
//!    resume` renders only those two, each resuming from its checkpoint, and
//!    the image equals the uninterrupted one.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::{Duration, Instant};

use super::plan::{Plan, Resources, shard_ranges};
use super::{slurm, submit_and_record};

/// The bundled scene, integrator and size of the selftest renders.
const SCENE: &str = "scenes/caustic-glass/scene.toml";
const FLAGS: [&str; 4] = ["--integrator", "vcm", "--resolution", "96x72"];

/// Iterations and shards of the kill test: long enough that a shard is
/// still running when it is killed (about 4 s per shard on one core).
const KILL_ITERATIONS: u64 = 1600;
const SHARDS: u64 = 4;
/// Seconds between the shards' checkpoints: several within a shard's run.
const CHECKPOINT_EVERY: f64 = 0.2;

/// Longest wait for a job of the selftest.
const JOB_LIMIT: Duration = Duration::from_secs(600);

pub fn run(root: &Path) -> Result<(), String> {
    let script = root.join("scripts/slurm-local");
    // No cluster here (not root, no packages, daemons that cannot start):
    // a skip, with the reason, not a failure.
    for step in ["check", "install", "start"] {
        if let Err(reason) = script_output(&script, step) {
            let last = reason.trim().lines().last().unwrap_or("no reason given");
            println!("farm selftest: skipped: `scripts/slurm-local {step}` failed: {last}");
            return Ok(());
        }
    }
    let conf = script_output(&script, "env")?;
    let conf = conf
        .trim()
        .strip_prefix("export SLURM_CONF=")
        .ok_or_else(|| format!("unexpected `slurm-local env` output: {conf}"))?;
    slurm::use_config(conf);
    // The test profile (the dev profile's settings; its math and integrator
    // crates are optimised, see Cargo.toml): the selftest checks merging and
    // resuming, not speed, and after `cargo test` the binary is built.
    crate::cargo(
        root,
        &["build", "--quiet", "--profile", "test", "-p", "render-cli"],
    )?;

    let base = root.join("target/farm/selftest");
    let _ = std::fs::remove_dir_all(&base);
    let result = shards_equal_the_single_render(root, &base)
        .and_then(|()| killed_shards_are_resumed(root, &base));
    match &result {
        Ok(()) => println!("farm selftest: passed ({})", base.display()),
        Err(e) => println!("farm selftest: FAILED: {e}"),
    }
    result
}

/// Runs `scripts/slurm-local COMMAND`; its output, or an error with it.
fn script_output(script: &Path, command: &str) -> Result<String, String> {
    let output = Command::new(script)
        .arg(command)
        .output()
        .map_err(|e| format!("cannot run {}: {e}", script.display()))?;
    let text = String::from_utf8_lossy(&output.stdout).into_owned()
        + &String::from_utf8_lossy(&output.stderr);
    if output.status.success() {
        Ok(text)
    } else {
        Err(text)
    }
}

/// The plan of a selftest render into `folder`.
fn plan(root: &Path, folder: PathBuf, iterations: u64) -> Result<Plan, String> {
    Ok(Plan {
        scene: root.join(SCENE),
        iterations,
        ranges: shard_ranges(iterations, SHARDS)?,
        render_flags: FLAGS.iter().map(|f| f.to_string()).collect(),
        render_cli: crate::binary(root, "debug", "render-cli"),
        folder,
        resources: Resources {
            cpus_per_task: 1,
            ..Resources::default()
        },
        checkpoint_every: Some(CHECKPOINT_EVERY),
    })
}

/// The single-process render of `plan` into `plan.folder/single.exr`.
fn single_render(plan: &Plan) -> Result<PathBuf, String> {
    let out = plan.folder.join("single.exr");
    let status = Command::new(&plan.render_cli)
        .arg(&plan.scene)
        .args(&plan.render_flags)
        .args([
            "--iterations",
            &plan.iterations.to_string(),
            "--no-png",
            "-o",
        ])
        .arg(&out)
        .status()
        .map_err(|e| e.to_string())?;
    status
        .success()
        .then_some(out)
        .ok_or_else(|| "the single-process render failed".to_owned())
}

/// The merged image equals the single-process one: byte for byte, or else
/// within f32 rounding of the mean (which the film's summation order allows).
fn compare_images(plan: &Plan) -> Result<(), String> {
    let single = single_render(plan)?;
    let (a, b) = (read(&plan.image_file())?, read(&single)?);
    if std::fs::read(plan.image_file()).ok() == std::fs::read(&single).ok() {
        println!("  merged image is byte-identical to the single-process render");
        return Ok(());
    }
    let worst = a
        .iter()
        .zip(&b)
        .map(|(x, y)| ((*x - *y).abs() / y.abs().max(glam::Vec3::splat(1e-30))).max_element())
        .fold(0.0f32, f32::max);
    println!(
        "  merged image differs from the single-process render by at most {worst:.3e} (relative)"
    );
    // Two roundings of the mean to f32.
    (worst <= 2.0 * f32::EPSILON)
        .then_some(())
        .ok_or_else(|| format!("merged image differs by {worst:.3e}, more than f32 rounding"))
}

fn read(path: &Path) -> Result<Vec<glam::Vec3>, String> {
    image_io::read_exr(path)
        .map(|image| image.pixels)
        .map_err(|e| e.to_string())
}

fn shards_equal_the_single_render(root: &Path, base: &Path) -> Result<(), String> {
    println!("farm selftest 1: {SHARDS} shards of a 32-iteration VCM render, merged");
    let plan = plan(root, base.join("whole"), 32)?;
    let start = Instant::now();
    let all: Vec<usize> = (0..plan.ranges.len()).collect();
    submit_and_record(&plan, &all, true)?;
    println!(
        "  submitted to merged: {:.1} s",
        start.elapsed().as_secs_f64()
    );
    compare_images(&plan)
}

fn killed_shards_are_resumed(root: &Path, base: &Path) -> Result<(), String> {
    println!(
        "farm selftest 2: two of {SHARDS} running shards killed (SIGKILL, SIGTERM), then resumed"
    );
    let plan = plan(root, base.join("killed"), KILL_ITERATIONS)?;
    let all: Vec<usize> = (0..plan.ranges.len()).collect();
    submit_and_record(&plan, &all, false)?;
    let json = std::fs::read_to_string(plan.folder.join("farm.json")).map_err(|e| e.to_string())?;
    let json: serde_json::Value = serde_json::from_str(&json).map_err(|e| e.to_string())?;
    let array = json["array_job"]
        .as_str()
        .ok_or("no array job recorded")?
        .to_owned();
    let merge = json["merge_job"]
        .as_str()
        .ok_or("no merge job recorded")?
        .to_owned();
    for (task, signal) in [(0, "KILL"), (1, "TERM")] {
        let id = format!("{array}_{task}");
        wait_until_running(&id)?;
        // Into the range, after a checkpoint, well before its end.
        wait_for_file(&plan.checkpoint_file(task))?;
        slurm::cancel(&id, signal)?;
        println!("  task {id} sent SIG{signal}");
    }
    slurm::wait_for(&array, JOB_LIMIT)?;
    slurm::wait_for(&merge, JOB_LIMIT)?;
    let missing = plan.missing_shards();
    if missing != [0, 1] || plan.image_file().exists() {
        return Err(format!(
            "after the kills: missing shards {missing:?} (expected [0, 1]), image present: {}",
            plan.image_file().exists()
        ));
    }
    for k in [0, 1] {
        let h = image_io::film_file::read_header(&plan.checkpoint_file(k))
            .map_err(|e| format!("the killed task left no usable checkpoint: {e}"))?;
        println!(
            "  shard {k} left a checkpoint of iterations {}..={}",
            h.first, h.last
        );
    }
    println!("  no partial film from the killed tasks; the merge was cancelled; resuming");
    super::resume(&[
        "--folder".to_owned(),
        plan.folder.display().to_string(),
        "--wait".to_owned(),
    ])?;
    for k in [0, 1] {
        let file = plan.checkpoint_file(k).display().to_string();
        if !logs_contain(&plan, &format!("resuming from {file}"))? {
            return Err(format!("no shard log says it resumed from {file}"));
        }
        if plan.checkpoint_file(k).exists() {
            return Err(format!("{file} is left after its shard completed"));
        }
    }
    println!("  both resumed from their checkpoints");
    compare_images(&plan)
}

/// Whether a log in the plan's folder holds `text`.
fn logs_contain(plan: &Plan, text: &str) -> Result<bool, String> {
    let logs = plan.folder.join("logs");
    let entries = std::fs::read_dir(&logs).map_err(|e| format!("{}: {e}", logs.display()))?;
    Ok(entries
        .flatten()
        .any(|entry| std::fs::read_to_string(entry.path()).is_ok_and(|log| log.contains(text))))
}

/// Waits until `path` exists.
fn wait_for_file(path: &Path) -> Result<(), String> {
    let start = Instant::now();
    while !path.exists() {
        if start.elapsed() > JOB_LIMIT {
            return Err(format!(
                "{} did not appear within {} s",
                path.display(),
                JOB_LIMIT.as_secs()
            ));
        }
        std::thread::sleep(Duration::from_millis(50));
    }
    Ok(())
}

/// Waits until array task `id` runs.
fn wait_until_running(id: &str) -> Result<(), String> {
    let start = Instant::now();
    loop {
        match slurm::state(id)?.as_deref() {
            Some("RUNNING") => return Ok(()),
            None => {
                return Err(format!(
                    "task {id} left the queue before it could be killed"
                ));
            }
            _ if start.elapsed() > JOB_LIMIT => {
                return Err(format!(
                    "task {id} did not start within {} s",
                    JOB_LIMIT.as_secs()
                ));
            }
            _ => std::thread::sleep(Duration::from_millis(100)),
        }
    }
}
