//! Slurm: submitting the shard array and its dependent merge, waiting for
//! them, and resubmitting what a failed or cancelled task left missing.

use std::path::Path;
use std::process::Command;
use std::sync::OnceLock;
use std::time::{Duration, Instant};

use super::plan::Plan;

/// How often `wait` asks the queue.
const POLL: Duration = Duration::from_millis(500);

/// The `SLURM_CONF` of the Slurm clients, when not the environment's.
static CONFIG: OnceLock<String> = OnceLock::new();

/// Makes every Slurm client run with `SLURM_CONF=conf` (a cluster whose
/// config is not in /etc, like `scripts/slurm-local`'s).
pub fn use_config(conf: &str) {
    let _ = CONFIG.set(conf.to_owned());
}

/// Runs a Slurm client command; its standard output, or an error with its
/// standard error.
fn slurm(program: &str, args: &[String]) -> Result<String, String> {
    let mut command = Command::new(program);
    if let Some(conf) = CONFIG.get() {
        command.env("SLURM_CONF", conf);
    }
    let output = command
        .args(args)
        .output()
        .map_err(|e| format!("cannot run {program} ({e}): is Slurm installed and on PATH?"))?;
    if !output.status.success() {
        return Err(format!(
            "{program} {} failed: {}",
            args.join(" "),
            String::from_utf8_lossy(&output.stderr).trim()
        ));
    }
    Ok(String::from_utf8_lossy(&output.stdout).trim().to_owned())
}

/// `sbatch --parsable ARGS SCRIPT`: the job id (the part before a
/// `;cluster` suffix).
fn sbatch(args: &[String], script: &Path) -> Result<String, String> {
    let mut all = vec!["--parsable".to_owned()];
    all.extend_from_slice(args);
    all.push(script.display().to_string());
    let out = slurm("sbatch", &all)?;
    Ok(out.split(';').next().unwrap_or_default().to_owned())
}

/// Submits shard tasks `tasks` (all, or the missing ones) as one job array
/// and the merge after it (cancelled by Slurm if a task fails, so that it
/// never waits forever; `farm resume` resubmits both); with no task, the
/// merge alone. The job ids (array, merge).
pub fn submit(plan: &Plan, tasks: &[usize]) -> Result<(Option<String>, String), String> {
    if tasks.is_empty() {
        return Ok((None, sbatch(&[], &plan.merge_script_file())?));
    }
    let list: Vec<String> = tasks.iter().map(usize::to_string).collect();
    let array_job = sbatch(
        &[format!("--array={}", list.join(","))],
        &plan.shards_script_file(),
    )?;
    let merge_job = sbatch(
        &[
            format!("--dependency=afterok:{array_job}"),
            "--kill-on-invalid-dep=yes".to_owned(),
        ],
        &plan.merge_script_file(),
    )?;
    Ok((Some(array_job), merge_job))
}

/// Whether job `id` (or any task of an array) is still in the queue.
pub fn in_queue(id: &str) -> Result<bool, String> {
    Ok(state(id)?.is_some())
}

/// Waits until job `id` has left the queue, at most `limit`.
pub fn wait_for(id: &str, limit: Duration) -> Result<(), String> {
    let start = Instant::now();
    while in_queue(id)? {
        if start.elapsed() > limit {
            return Err(format!("job {id} still queued after {} s", limit.as_secs()));
        }
        std::thread::sleep(POLL);
    }
    Ok(())
}

/// Cancels job (or array task) `id` with `signal` (e.g. `TERM`, `KILL`).
/// A job that the signal ends while scancel still signals its steps (a
/// shard interrupted before its first iteration exits at once) makes
/// scancel fail; that is no error once the job no longer runs.
pub fn cancel(id: &str, signal: &str) -> Result<(), String> {
    match slurm(
        "scancel",
        &[format!("--signal={signal}"), "--full".into(), id.into()],
    ) {
        Ok(_) => Ok(()),
        Err(e) => match state(id)?.as_deref() {
            Some("RUNNING" | "PENDING") => Err(e),
            _ => Ok(()),
        },
    }
}

/// The state (`PENDING`, `RUNNING`, ...) of job `id` (of an array's first
/// queued task), if it is queued.
pub fn state(id: &str) -> Result<Option<String>, String> {
    let args = ["-h", "-j", id, "-o", "%T"].map(str::to_owned);
    match slurm("squeue", &args) {
        Ok(text) => Ok(text.lines().next().map(str::to_owned)),
        // squeue refuses ids it has forgotten: not in the queue.
        Err(e) if e.contains("Invalid job id") => Ok(None),
        Err(e) => Err(e),
    }
}
