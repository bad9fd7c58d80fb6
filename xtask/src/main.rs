//! `cargo xtask <task>`: project automation that is not part of the renderer.
//!
//! Tasks:
//! - `bench [options]`: end-to-end throughput of every integrator on every
//!   bundled scene (seconds per iteration, samples and rays per second, peak
//!   memory), one child process per run (the hidden `bench-run` task), written
//!   as JSON and a markdown table with the machine's core count to
//!   `target/bench/`, for comparing commits side by side; `--quick` runs in
//!   CI. `bench --micro [--quick]` runs the criterion micro-benchmarks of the
//!   math crates instead.
//! - `study --scene PATH [options]`: convergence studies, every config's
//!   error against a cached reference over wall-clock time, with equal-time
//!   comparisons, charts and a contact sheet (`target/study/<scene>/`).
//! - `stability [--quick]`: numerical stability sweeps of the math crates
//!   and the renderer over extreme inputs (`target/stability/`).
//! - `farm slurm|resume|selftest`: one render as a Slurm job array of
//!   iteration shards and a dependent merge (`target/farm/`).
//! - `mitsuba [options]`: renders one scene with our path tracer and with
//!   Mitsuba 3's (installed on demand into `target/mitsuba/venv`), and
//!   compares speed and error against one reference (`target/mitsuba/`).
//! - `rays dump|bench`: a scene's mesh and camera, diffuse and shadow rays
//!   as files another ray tracer reads, and the time `accel` takes to
//!   trace them alone (docs/benchmarks.md, "Ray throughput against Embree").
//! - `smallvcm --src DIR`: seconds per iteration of our integrators against
//!   SmallVCM's (a checkout outside the repository) on its scenes 1 and 2
//!   (`target/smallvcm/`).
//!
//! Helpers every task uses live here: the workspace root, the core count,
//! the load average, writing reports, `git` and `cargo`.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

mod bench;
mod farm;
mod fuzz;
mod mitsuba;
mod rays;
mod smallvcm;
mod stability;
mod study;

const USAGE_HEADER: &str = "usage: cargo xtask <task>\n\ntasks:";

const USAGE_HELP: &str = "  help              print this text";

fn usage() -> String {
    format!(
        "{USAGE_HEADER}\n{}\n{}\n{}\n{}\n{}\n{}\n{}\n{}\n{USAGE_HELP}",
        bench::USAGE,
        farm::USAGE,
        fuzz::USAGE,
        mitsuba::USAGE,
        rays::USAGE,
        smallvcm::USAGE,
        study::USAGE,
        stability::USAGE
    )
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = match args.first().map(String::as_str) {
        Some("bench") => bench::run(&workspace_root(), &args[1..]),
        // One run of `bench`, spawned by it; not listed in the usage.
        Some("bench-run") => bench::run_child(&args[1..]),
        Some("farm") => farm::run(&workspace_root(), &args[1..]),
        Some("fuzz") => fuzz::run(&workspace_root(), &args[1..]),
        Some("mitsuba") => mitsuba::run(&workspace_root(), &args[1..]),
        Some("rays") => rays::run(&workspace_root(), &args[1..]),
        Some("smallvcm") => smallvcm::run(&workspace_root(), &args[1..]),
        Some("study") => study::run(&workspace_root(), &args[1..]),
        Some("stability") => stability::run(&workspace_root(), &args[1..]),
        Some("help" | "--help" | "-h") | None => {
            println!("{}", usage());
            Ok(())
        }
        Some(other) => Err(format!("unknown task `{other}`\n\n{}", usage())),
    };
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(message) => {
            eprintln!("error: {message}");
            ExitCode::FAILURE
        }
    }
}

/// The workspace root: the parent of this crate's manifest directory.
fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map(Path::to_path_buf)
        .unwrap_or_else(|| PathBuf::from("."))
}

/// Whether `args` is `[--quick]` (true) or empty (false), for tasks whose
/// only flag it is; anything else is an error naming `usage`.
fn quick_flag(args: &[String], usage: &str) -> Result<bool, String> {
    match args {
        [] => Ok(false),
        [flag] if flag == "--quick" => Ok(true),
        _ => Err(format!("unexpected arguments {args:?}; usage: {usage}")),
    }
}

/// The standard output of `git ARGS` run in `root`; None when git is missing,
/// fails or `root` is not a checkout.
fn git(root: &Path, args: &[&str]) -> Option<Vec<u8>> {
    Command::new("git")
        .args(args)
        .current_dir(root)
        .output()
        .ok()
        .filter(|o| o.status.success())
        .map(|o| o.stdout)
}

/// Logical cores (1 where the system does not tell).
fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

/// `<target>/release/<name>` of this workspace.
fn release_binary(root: &Path, name: &str) -> PathBuf {
    binary(root, "release", name)
}

/// `<target>/<profile>/<name>` of this workspace, honouring
/// `CARGO_TARGET_DIR` (a relative one is relative to `root`, where xtask
/// runs cargo); `profile` is the profile's folder ("debug" for dev).
fn binary(root: &Path, profile: &str, name: &str) -> PathBuf {
    std::env::var_os("CARGO_TARGET_DIR")
        .map_or_else(|| root.join("target"), |dir| root.join(dir))
        .join(profile)
        .join(name)
}

/// The first three fields of /proc/loadavg ("?" where unavailable).
fn load_average() -> String {
    std::fs::read_to_string("/proc/loadavg")
        .ok()
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|| "?".into())
}

/// Writes `text` to `path`; the error names the file.
fn write_file(path: &Path, text: impl AsRef<[u8]>) -> Result<(), String> {
    std::fs::write(path, text).map_err(|e| format!("cannot write {}: {e}", path.display()))
}

/// Writes a linear RGB image as an OpenEXR file (`image_io`), with the
/// error as text.
fn write_exr(path: &Path, width: u32, height: u32, pixels: &[glam::Vec3]) -> Result<(), String> {
    image_io::write_exr(path, width, height, pixels).map_err(|e| e.to_string())
}

/// Writes a report as `<dir>/<stem>.md` and `<dir>/<stem>.json` (pretty
/// printed); returns their paths.
fn write_report(
    dir: &Path,
    stem: &str,
    md: &str,
    json: &serde_json::Value,
) -> Result<(PathBuf, PathBuf), String> {
    let md_path = dir.join(format!("{stem}.md"));
    let json_path = dir.join(format!("{stem}.json"));
    write_file(&md_path, md)?;
    let text = serde_json::to_string_pretty(json).map_err(|e| e.to_string())?;
    write_file(&json_path, text)?;
    Ok((md_path, json_path))
}

/// [`write_report`], then prints the Markdown and where both files are.
fn publish_report(
    dir: &Path,
    stem: &str,
    md: &str,
    json: &serde_json::Value,
) -> Result<(), String> {
    let (md_path, json_path) = write_report(dir, stem, md, json)?;
    print!("{md}");
    println!(
        "\nwritten: {} and {}",
        md_path.display(),
        json_path.display()
    );
    Ok(())
}

/// Runs `cargo` with `args` in `root`, inheriting the terminal.
fn cargo(root: &Path, args: &[&str]) -> Result<(), String> {
    cargo_with_env(root, args, &[])
}

/// Runs `cargo xtask TASK ARGS` again from a release build of xtask, with
/// `child_env` set so that the child does not do the same (timings need
/// optimised code; the child prints its own one-line error).
fn rerun_in_release(
    root: &Path,
    task: &str,
    args: &[String],
    child_env: &str,
) -> Result<(), String> {
    let mut cargo_args = vec!["run", "--release", "--quiet", "-p", "xtask", "--", task];
    cargo_args.extend(args.iter().map(String::as_str));
    println!(
        "timings need a release build: running `cargo {}`",
        cargo_args.join(" ")
    );
    cargo_with_env(root, &cargo_args, &[(child_env, "1")])
}

/// [`cargo`] with environment variables `env` set for the child.
fn cargo_with_env(root: &Path, args: &[&str], env: &[(&str, &str)]) -> Result<(), String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let status = Command::new(&cargo)
        .args(args)
        .envs(env.iter().copied())
        .current_dir(root)
        .status()
        .map_err(|e| format!("could not run {cargo}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        Err(format!("`cargo {}` failed ({status})", args.join(" ")))
    }
}
