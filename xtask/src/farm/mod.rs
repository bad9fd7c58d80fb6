//! `cargo xtask farm`: one render split into iteration shards on a Slurm
//! cluster. Every iteration is a pure function of (scene, settings, seed,
//! global iteration index), so a job array renders the shards
//! (`render-cli --iteration-range A..B --partial`) into a shared folder and
//! a dependent job merges them (`render-cli merge`) into the image the
//! single-process render gives.

mod plan;
mod selftest;
mod slurm;

use std::path::{Path, PathBuf};
use std::time::Duration;

pub use plan::{Plan, Resources, shard_ranges};

use crate::write_file;

/// `cargo xtask help` lines.
pub const USAGE: &str =
    "  farm slurm --scene S --iterations N --shards K [options] [-- RENDER FLAGS]
                    render on a Slurm cluster: a job array of iteration shards
                    and a dependent merge (`cargo xtask farm help`)
  farm resume --folder DIR [--dry-run] [--wait]
                    resubmit the shards a failed or cancelled task left missing
                    (each resumes from its last checkpoint)
  farm selftest     submit shards of a bundled scene to a single-node Slurm on
                    this machine (scripts/slurm-local) and check the merged
                    image against a single-process render";

const HELP: &str =
    "usage: cargo xtask farm slurm --scene S --iterations N --shards K [options] [-- FLAGS]
       cargo xtask farm resume --folder DIR [--dry-run] [--wait]
       cargo xtask farm selftest

slurm: writes two batch scripts into the folder and submits them: shards.sh
as a job array (task k renders iterations of range k into shard-k.rltfilm,
saving a checkpoint, checkpoints/shard-k.rltfilm, every --checkpoint-every
seconds) and merge.sh after it (--dependency=afterok; film.rltfilm, image.exr and
image.png). The folder must be on a file system that every node sees, and so
must the render-cli binary (built here with `cargo build --release`).

options:
  --scene S             the scene file (as render-cli takes it); required
  --iterations N        iterations of the whole render; required
  --shards K            shards (array tasks), 1..=N; required
  --folder DIR          shared folder [default: target/farm/<scene name>]
  --partition P         Slurm partition [default: the cluster's]
  --time T              time limit of each job, Slurm syntax (e.g. 01:00:00)
  --mem M               memory of each job, Slurm syntax (e.g. 4G)
  --cpus-per-task C     CPUs (render threads) per task [default: 1]
  --checkpoint-every S  seconds between a shard's checkpoints: a killed or
                        cancelled task loses at most this much work
                        [default: render-cli's, 300]
  --dry-run             print the scripts and the sbatch commands; submit nothing
  --wait                wait for the merge, then print where the image is
  -- FLAGS             further render-cli flags (e.g. --integrator vcm
                        --resolution 640x480); not --iterations, --time,
                        --output, --partial or the checkpoint flags

resume: reads the folder's farm.json, refuses while its array still has
tasks in the queue, resubmits only the shards without a partial film (a
shard's film is written under a temporary name and renamed when its whole
range is done, so a killed task leaves none) and the merge after them. A
resubmitted shard resumes from its checkpoint: a task killed (SIGKILL, a
node failure) loses the iterations since its last checkpoint; one cancelled
or stopped at its time limit (SIGTERM) saves its completed iterations first.";

/// The flags `farm slurm` itself sets for every shard.
const RESERVED_FLAGS: [&str; 9] = [
    "--iterations",
    "--time",
    "--output",
    "-o",
    "--partial",
    "--iteration-range",
    "--checkpoint",
    "--checkpoint-every",
    "--keep-checkpoint",
];

/// How long `--wait` waits for a merge.
const WAIT_LIMIT: Duration = Duration::from_secs(7 * 24 * 3600);

/// `cargo xtask farm ...`.
pub fn run(root: &Path, args: &[String]) -> Result<(), String> {
    match args.first().map(String::as_str) {
        Some("slurm") => slurm_render(root, &args[1..]),
        Some("resume") => resume(&args[1..]),
        Some("selftest") => selftest::run(root),
        Some("help" | "--help" | "-h") | None => {
            println!("{HELP}");
            Ok(())
        }
        Some(other) => Err(format!("farm: unknown command `{other}`\n\n{HELP}")),
    }
}

/// The options of `farm slurm`.
#[derive(Debug, Default)]
struct Options {
    scene: Option<PathBuf>,
    iterations: Option<u64>,
    shards: Option<u64>,
    folder: Option<PathBuf>,
    resources: Resources,
    checkpoint_every: Option<f64>,
    dry_run: bool,
    wait: bool,
    render_flags: Vec<String>,
}

fn parse(args: &[String]) -> Result<Options, String> {
    let mut o = Options {
        resources: Resources {
            cpus_per_task: 1,
            ..Resources::default()
        },
        ..Options::default()
    };
    let mut i = 0;
    while i < args.len() {
        let flag = args[i].as_str();
        let mut value = || {
            i += 1;
            args.get(i)
                .cloned()
                .ok_or_else(|| format!("{flag}: missing value"))
        };
        let number = |v: String| {
            v.parse::<u64>()
                .ok()
                .filter(|&n| n > 0)
                .ok_or_else(|| format!("{flag}: expected a positive whole number, got '{v}'"))
        };
        match flag {
            "--scene" => o.scene = Some(PathBuf::from(value()?)),
            "--iterations" => o.iterations = Some(number(value()?)?),
            "--shards" => o.shards = Some(number(value()?)?),
            "--folder" => o.folder = Some(PathBuf::from(value()?)),
            "--partition" => o.resources.partition = Some(value()?),
            "--time" => o.resources.time = Some(value()?),
            "--mem" => o.resources.mem = Some(value()?),
            "--cpus-per-task" => {
                o.resources.cpus_per_task = u32::try_from(number(value()?)?)
                    .map_err(|_| "--cpus-per-task: too large".to_owned())?;
            }
            "--checkpoint-every" => {
                let v = value()?;
                let seconds = v.parse::<f64>().ok().filter(|s| *s >= 0.0 && s.is_finite());
                o.checkpoint_every = Some(seconds.ok_or_else(|| {
                    format!("--checkpoint-every: expected seconds >= 0, got '{v}'")
                })?);
            }
            "--dry-run" => o.dry_run = true,
            "--wait" => o.wait = true,
            "--" => {
                o.render_flags = args[i + 1..].to_vec();
                break;
            }
            other => return Err(format!("farm slurm: unknown option `{other}`\n\n{HELP}")),
        }
        i += 1;
    }
    if let Some(f) = o.render_flags.iter().find(|f| {
        RESERVED_FLAGS
            .iter()
            .any(|r| f.as_str() == *r || f.starts_with(&format!("{r}=")))
    }) {
        return Err(format!(
            "farm slurm: {f} is set by the farm for every shard"
        ));
    }
    Ok(o)
}

/// `farm slurm`: plan, write, submit.
fn slurm_render(root: &Path, args: &[String]) -> Result<(), String> {
    let o = parse(args)?;
    let required = |what: &str| format!("farm slurm: {what} is required\n\n{HELP}");
    let scene = o.scene.clone().ok_or_else(|| required("--scene"))?;
    let iterations = o.iterations.ok_or_else(|| required("--iterations"))?;
    let shards = o.shards.ok_or_else(|| required("--shards"))?;
    let scene = std::path::absolute(&scene).map_err(|e| format!("{}: {e}", scene.display()))?;
    if !scene.is_file() {
        return Err(format!("--scene: {} is not a file", scene.display()));
    }
    let folder = o
        .folder
        .clone()
        .unwrap_or_else(|| plan::default_folder(root, &scene));
    let folder = std::path::absolute(&folder).map_err(|e| format!("{}: {e}", folder.display()))?;
    let plan = Plan {
        scene,
        iterations,
        ranges: shard_ranges(iterations, shards)?,
        render_flags: o.render_flags.clone(),
        render_cli: crate::release_binary(root, "render-cli"),
        folder,
        resources: o.resources.clone(),
        checkpoint_every: o.checkpoint_every,
    };
    if o.dry_run {
        print_dry_run(&plan, &(0..plan.ranges.len()).collect::<Vec<_>>());
        return Ok(());
    }
    if plan.folder.join("farm.json").exists() {
        return Err(format!(
            "{} already holds a farm render; use `cargo xtask farm resume --folder {}` or another --folder",
            plan.folder.display(),
            plan.folder.display()
        ));
    }
    crate::cargo(root, &["build", "--release", "--quiet", "-p", "render-cli"])?;
    let all: Vec<usize> = (0..plan.ranges.len()).collect();
    submit_and_record(&plan, &all, o.wait)
}

/// Writes the scripts and farm.json, submits `tasks` and the merge, and
/// waits for the merge when asked.
fn submit_and_record(plan: &Plan, tasks: &[usize], wait: bool) -> Result<(), String> {
    write_scripts(plan)?;
    let (array_job, merge_job) = slurm::submit(plan, tasks)?;
    let json = plan.to_json(array_job.as_deref(), Some(&merge_job));
    let text = serde_json::to_string_pretty(&json).map_err(|e| e.to_string())?;
    write_file(&plan.folder.join("farm.json"), text)?;
    println!(
        "submitted {} shard task(s){} and merge job {merge_job}; the image will be {}",
        tasks.len(),
        array_job.map_or_else(String::new, |id| format!(" as array job {id}")),
        plan.image_file().display()
    );
    if wait {
        wait_for_image(plan, &merge_job)?;
    }
    Ok(())
}

/// Waits for merge job `merge_job`; an error (naming the logs) if it ended
/// without the image.
fn wait_for_image(plan: &Plan, merge_job: &str) -> Result<(), String> {
    slurm::wait_for(merge_job, WAIT_LIMIT)?;
    if !plan.image_file().is_file() {
        return Err(format!(
            "the merge job {merge_job} ended without {} (a shard failed or was cancelled? see {}; \
             then `cargo xtask farm resume --folder {}`)",
            plan.image_file().display(),
            plan.folder.join("logs").display(),
            plan.folder.display()
        ));
    }
    println!("merged: {}", plan.image_file().display());
    Ok(())
}

fn write_scripts(plan: &Plan) -> Result<(), String> {
    for folder in [plan.folder.join("logs"), plan.checkpoint_folder()] {
        std::fs::create_dir_all(&folder)
            .map_err(|e| format!("cannot create {}: {e}", folder.display()))?;
    }
    write_file(&plan.shards_script_file(), plan.shards_script())?;
    write_file(&plan.merge_script_file(), plan.merge_script())
}

fn print_dry_run(plan: &Plan, tasks: &[usize]) {
    let list: Vec<String> = tasks.iter().map(usize::to_string).collect();
    println!(
        "# {}\n{}",
        plan.shards_script_file().display(),
        plan.shards_script()
    );
    println!(
        "# {}\n{}",
        plan.merge_script_file().display(),
        plan.merge_script()
    );
    println!(
        "# would run:\nsbatch --parsable --array={} {}\nsbatch --parsable --dependency=afterok:<array job> --kill-on-invalid-dep=yes {}",
        list.join(","),
        plan.shards_script_file().display(),
        plan.merge_script_file().display()
    );
}

/// A film to render on the farm for another task (the study's references).
pub struct FilmJob<'a> {
    /// The scene file.
    pub scene: &'a Path,
    /// Iterations of the whole render.
    pub iterations: u64,
    /// Shards (array tasks).
    pub shards: u64,
    /// The render-cli flags of the render.
    pub render_flags: Vec<String>,
    /// Batch resources.
    pub resources: Resources,
    /// The shared folder (one per film: a second call resumes it).
    pub folder: PathBuf,
    /// The `RenderConfig` (Debug) the shards must have used.
    pub settings: String,
}

/// Renders `job` on the Slurm cluster, or completes an earlier submission
/// of it, waits for the merge, and returns the merged film with the
/// seconds from submission to the merged film.
pub fn render_film(root: &Path, job: &FilmJob<'_>) -> Result<(integrators::Film, f64), String> {
    let start = std::time::Instant::now();
    let plan = Plan {
        scene: std::path::absolute(job.scene).map_err(|e| e.to_string())?,
        iterations: job.iterations,
        ranges: shard_ranges(job.iterations, job.shards)?,
        render_flags: job.render_flags.clone(),
        render_cli: crate::release_binary(root, "render-cli"),
        folder: std::path::absolute(&job.folder).map_err(|e| e.to_string())?,
        resources: job.resources.clone(),
        checkpoint_every: None,
    };
    if !plan.film_file().is_file() {
        crate::cargo(root, &["build", "--release", "--quiet", "-p", "render-cli"])?;
        submit_and_record(&plan, &plan.missing_shards(), true)?;
    }
    let partial = image_io::film_file::read(&plan.film_file()).map_err(|e| e.to_string())?;
    if partial.header.settings != job.settings {
        return Err(format!(
            "{}: rendered with other settings than asked:\n  {}\n  {}",
            plan.film_file().display(),
            partial.header.settings,
            job.settings
        ));
    }
    let h = &partial.header;
    let film = integrators::Film::from_sums(
        h.width,
        h.height,
        partial.iterations,
        partial.sum,
        partial.sum_sq,
    )
    .ok_or_else(|| {
        format!(
            "{}: pixel data does not match its size",
            plan.film_file().display()
        )
    })?;
    Ok((film, start.elapsed().as_secs_f64()))
}

/// `farm resume --folder DIR [--dry-run] [--wait]`.
fn resume(args: &[String]) -> Result<(), String> {
    let (mut folder, mut dry_run, mut wait) = (None, false, false);
    let mut it = args.iter();
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--folder" => folder = it.next().map(PathBuf::from),
            "--dry-run" => dry_run = true,
            "--wait" => wait = true,
            other => return Err(format!("farm resume: unknown option `{other}`\n\n{HELP}")),
        }
    }
    let folder =
        folder.ok_or_else(|| format!("farm resume: --folder DIR is required\n\n{HELP}"))?;
    let path = folder.join("farm.json");
    let text = std::fs::read_to_string(&path)
        .map_err(|e| format!("cannot read {}: {e} (not a farm folder?)", path.display()))?;
    let json = serde_json::from_str(&text).map_err(|e| format!("{}: {e}", path.display()))?;
    let (plan, array_job) = Plan::from_json(&json)?;
    let missing = plan.missing_shards();
    if dry_run {
        print_dry_run(&plan, &missing);
        return Ok(());
    }
    if let Some(id) = &array_job
        && slurm::in_queue(id)?
    {
        return Err(format!(
            "array job {id} still has tasks in the queue; wait for it or `scancel {id}`"
        ));
    }
    if missing.is_empty() && plan.image_file().is_file() {
        println!(
            "nothing to do: every shard is there and {} exists",
            plan.image_file().display()
        );
        return Ok(());
    }
    println!("missing shards: {missing:?}");
    for &k in &missing {
        if let Ok(h) = image_io::film_file::read_header(&plan.checkpoint_file(k)) {
            let (first, last) = plan.ranges[k];
            println!(
                "  shard {k} resumes from its checkpoint: iterations {}..={} of {first}..={last} done",
                h.first, h.last
            );
        }
    }
    submit_and_record(&plan, &missing, wait)
}
