//! `cargo xtask smallvcm --src DIR`: seconds per iteration of our integrators
//! against SmallVCM's (Georgiev et al. 2012, the VCM paper's reference code)
//! on its scenes 1 and 2, side by side in one run.
//!
//! Procedure (SmallVCM's code is read and run, never committed here):
//! 1. fetch its source into a scratch folder outside this repository, e.g.
//!    `git clone https://github.com/SmallVCM/SmallVCM /tmp/SmallVCM`;
//! 2. `cargo xtask smallvcm --src /tmp/SmallVCM` builds it with
//!    `g++ -O3 -std=c++11 -fopenmp` (its own Makefile's flags) plus, on
//!    x86_64, `-march=x86-64-v2` into `<out>/smallvcm-<baseline>`, builds our
//!    `render-cli` in release, then renders each scene with
//!    each algorithm at 1 and 1 + K iterations with both programs, interleaved,
//!    `--repeat` times; both use every core (OpenMP, rayon).
//! 3. Seconds per iteration = (t(1 + K) - t(1)) / K, t being the wall-clock
//!    time of the whole process, so start-up, scene building and writing the
//!    image cancel; the median over the repeats is reported with the ratio
//!    ours / SmallVCM's in `<out>/report.md` and `report.json`. Not the time
//!    SmallVCM prints: it measures with `clock()`, the CPU time of all its
//!    threads. SmallVCM runs whole iterations in parallel (one per thread),
//!    so K must be a multiple of the core count for its K extra iterations to
//!    keep every thread busy: K is rounded up to one.
//! 4. With `--cpu-time` both run on one thread, pinned to the same core
//!    (`taskset -c`, util-linux), and t is the CPU time (user + system) of
//!    the process: on a machine shared with other work, wall-clock time
//!    measures the load as much as the code, while CPU time barely moves
//!    with it. It also leaves out how each program spreads an iteration over
//!    the cores. The pinning is what makes SmallVCM use one thread: it sets
//!    its thread count to `omp_get_num_procs()` itself, over
//!    `OMP_NUM_THREADS` (which it ignores), and that count follows the
//!    process's CPU affinity. Before the eleventh session it ran two threads
//!    here, each iteration on one of them, while the other iteration
//!    shared the memory bus and the L3 cache, which inflated its CPU time.
//!
//! Same instruction set on both sides: our x86_64 builds target x86-64-v2
//! (`.cargo/config.toml`: SSE4.2 and POPCNT, no AVX or FMA), so SmallVCM is
//! compiled with `-march=x86-64-v2` too ([`MARCH`]); its Makefile's bare
//! `-O3` would target the 2003 baseline (SSE2) and give it a handicap.
//! v2 has no FMA, so neither side can contract `a * b + c` into one rounding.
//!
//! Our scenes are `scenes/smallvcm-1` and `scenes/smallvcm-2`, transcribed
//! from SmallVCM's `scene.hxx`; their manifests say where our models differ
//! (its Phong floor, and its analytic spheres, which ours tessellate).
//! Same resolution (512x512), path length (10 segments), merge radius
//! (0.003 x scene radius, alpha 0.75) and no regularization.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

use serde_json::json;

pub const USAGE: &str = "  smallvcm --src DIR [options]
                    seconds per iteration of our pt, bpt, bpm, ppm and vcm
                    against SmallVCM's on its scenes 1 and 2 (scenes/smallvcm-*),
                    start-up subtracted; DIR is a SmallVCM checkout outside this
                    repository (git clone https://github.com/SmallVCM/SmallVCM)
      --iterations K        the timed renders run 1 and 1 + K iterations (default 8;
                            rounded up to a multiple of the core count)
      --repeat R            interleaved rounds, median reported (default 3)
      --algorithms LIST     comma-separated (default pt,bpt,bpm,ppm,vcm)
      --scenes LIST         SmallVCM scene numbers, 1 and/or 2 (default 1,2)
      --cpu-time            one thread each, both pinned to the last core (taskset),
                            timed by CPU time instead of wall clock
                            (steadier on a busy machine; Linux: reads /proc)
      --out DIR             output folder (default target/smallvcm)";

struct Options {
    src: PathBuf,
    iterations: u32,
    repeat: usize,
    algorithms: Vec<String>,
    scenes: Vec<u32>,
    out: PathBuf,
    /// One thread each, timed by CPU time (`--cpu-time`).
    cpu_time: bool,
}

/// Runs the comparison; see the module docs.
pub fn run(root: &Path, args: &[String]) -> Result<(), String> {
    let mut options = parse(root, args)?;
    if !options.cpu_time {
        options.iterations = options.iterations.next_multiple_of(crate::cores() as u32);
    }
    let commit = crate::git(root, &["rev-parse", "--short", "HEAD"])
        .map(|o| String::from_utf8_lossy(&o).trim().to_string())
        .unwrap_or_else(|| "?".into());
    std::fs::create_dir_all(&options.out)
        .map_err(|e| format!("cannot create {}: {e}", options.out.display()))?;
    let theirs = build_smallvcm(&options.src, &options.out)?;
    crate::cargo(root, &["build", "--release", "-p", "render-cli"])?;
    let ours = crate::release_binary(root, "render-cli");
    let mut rows = Vec::new();
    for &scene in &options.scenes {
        for algorithm in &options.algorithms {
            let manifest = root.join(format!("scenes/smallvcm-{scene}/scene.toml"));
            let (mut ours_s, mut theirs_s) = (Vec::new(), Vec::new());
            for round in 0..options.repeat {
                println!(
                    "smallvcm: scene {scene}, {algorithm}, round {}/{}",
                    round + 1,
                    options.repeat
                );
                ours_s.push(per_iteration(options.iterations, |n| {
                    time_ours(&ours, &manifest, algorithm, n, &options)
                })?);
                theirs_s.push(per_iteration(options.iterations, |n| {
                    time_smallvcm(&theirs, scene, algorithm, n, &options)
                })?);
            }
            rows.push(Row {
                scene,
                algorithm: algorithm.clone(),
                ours: median(&mut ours_s),
                theirs: median(&mut theirs_s),
            });
        }
    }
    report(&commit, &options, &rows)
}

fn parse(root: &Path, args: &[String]) -> Result<Options, String> {
    let mut options = Options {
        src: PathBuf::new(),
        iterations: 8,
        repeat: 3,
        algorithms: ["pt", "bpt", "bpm", "ppm", "vcm"]
            .map(String::from)
            .to_vec(),
        scenes: vec![1, 2],
        out: root.join("target/smallvcm"),
        cpu_time: false,
    };
    let mut it = args.iter();
    while let Some(flag) = it.next() {
        let mut value = || {
            it.next()
                .cloned()
                .ok_or_else(|| format!("{flag} needs a value\n{USAGE}"))
        };
        let number = |v: String| {
            v.parse::<u32>()
                .ok()
                .filter(|&n| n > 0)
                .ok_or_else(|| format!("{flag} takes a positive integer, not {v:?}"))
        };
        match flag.as_str() {
            "--src" => options.src = PathBuf::from(value()?),
            "--iterations" => options.iterations = number(value()?)?,
            "--repeat" => options.repeat = number(value()?)? as usize,
            "--algorithms" => options.algorithms = value()?.split(',').map(String::from).collect(),
            "--scenes" => {
                options.scenes = value()?
                    .split(',')
                    .map(|s| match s {
                        "1" => Ok(1),
                        "2" => Ok(2),
                        _ => Err(format!(
                            "--scenes: {s:?} is not 1 or 2 (the transcribed scenes)"
                        )),
                    })
                    .collect::<Result<_, _>>()?;
            }
            "--out" => options.out = root.join(value()?),
            "--cpu-time" => options.cpu_time = true,
            _ => return Err(format!("unknown flag {flag}\n{USAGE}")),
        }
    }
    if options.src.as_os_str().is_empty() {
        return Err(format!("--src is required\n{USAGE}"));
    }
    if let Some(a) = options
        .algorithms
        .iter()
        .find(|a| !["pt", "bpt", "bpm", "ppm", "vcm"].contains(&a.as_str()))
    {
        return Err(format!(
            "--algorithms: {a:?} is not one of pt, bpt, bpm, ppm, vcm"
        ));
    }
    Ok(options)
}

/// The `-march` SmallVCM is built with: the instruction-set baseline of our
/// own x86_64 builds (`.cargo/config.toml`), so that the comparison measures
/// code, not instruction sets; elsewhere the compiler's default.
const MARCH: Option<&str> = if cfg!(target_arch = "x86_64") {
    Some("x86-64-v2")
} else {
    None
};

/// g++'s flags for SmallVCM: its Makefile's, plus [`MARCH`].
fn gxx_flags() -> Vec<String> {
    let mut flags = vec!["-O3".to_string(), "-std=c++11".into(), "-fopenmp".into()];
    flags.extend(MARCH.map(|m| format!("-march={m}")));
    flags
}

/// Builds SmallVCM from `src` into `out/smallvcm-<march>` unless it is
/// already there (the name carries [`MARCH`], so a binary built with other
/// flags is not reused).
fn build_smallvcm(src: &Path, out: &Path) -> Result<PathBuf, String> {
    let main = src.join("src/smallvcm.cxx");
    if !main.is_file() {
        return Err(format!(
            "{} not found: --src must be a SmallVCM checkout (git clone https://github.com/SmallVCM/SmallVCM DIR)",
            main.display()
        ));
    }
    let flags = gxx_flags();
    let binary = out.join(format!("smallvcm-{}", MARCH.unwrap_or("default")));
    if !binary.is_file() {
        println!(
            "smallvcm: building {} with g++ {}",
            main.display(),
            flags.join(" ")
        );
        let status = Command::new("g++")
            .args(&flags)
            .arg("-o")
            .arg(&binary)
            .arg(&main)
            .status()
            .map_err(|e| format!("cannot run g++: {e}"))?;
        if !status.success() {
            return Err(format!("g++ failed ({status}) building {}", main.display()));
        }
    }
    Ok(binary)
}

/// (t(1 + k) - t(1)) / k for a timing function of the iteration count.
fn per_iteration(k: u32, mut time: impl FnMut(u32) -> Result<f64, String>) -> Result<f64, String> {
    let one = time(1)?;
    let more = time(1 + k)?;
    Ok((more - one) / f64::from(k))
}

fn time_ours(
    binary: &Path,
    manifest: &Path,
    algorithm: &str,
    n: u32,
    options: &Options,
) -> Result<f64, String> {
    let mut command = program(binary, options);
    command
        .arg(manifest)
        .args(["--integrator", algorithm, "--iterations", &n.to_string()])
        .args(["--regularize", "off", "--no-png", "-o"])
        .arg(options.out.join("ours.exr"));
    if options.cpu_time {
        command.args(["--threads", "1"]);
        return cpu_time(&mut command);
    }
    wall_time(&mut command)
}

fn time_smallvcm(
    binary: &Path,
    scene: u32,
    algorithm: &str,
    n: u32,
    options: &Options,
) -> Result<f64, String> {
    let scene = scene.to_string();
    let n = n.to_string();
    let mut command = program(binary, options);
    command
        .args(["-s", &scene, "-a", algorithm, "-i", &n, "-o"])
        .arg(options.out.join("smallvcm.hdr"))
        .current_dir(&options.out);
    if options.cpu_time {
        command.env("OMP_NUM_THREADS", "1");
        return cpu_time(&mut command);
    }
    wall_time(&mut command)
}

/// The command that runs `binary`: with `--cpu-time` under `taskset`, on
/// the core [`pinned_core`] names.
fn program(binary: &Path, options: &Options) -> Command {
    if !options.cpu_time {
        return Command::new(binary);
    }
    let mut command = Command::new("taskset");
    command.args(["-c", &pinned_core().to_string()]).arg(binary);
    command
}

/// The core `--cpu-time` runs both programs on: the last one, so that on a
/// machine where other work starts on core 0 the two share the same
/// conditions.
fn pinned_core() -> usize {
    crate::cores().saturating_sub(1)
}

/// Wall-clock seconds of running `command` to its end; an error names the
/// program and says what it printed when it fails.
fn wall_time(command: &mut Command) -> Result<f64, String> {
    let start = Instant::now();
    run_to_end(command)?;
    Ok(start.elapsed().as_secs_f64())
}

/// CPU seconds (user + system) of running `command` to its end: the growth
/// of this process's waited-for children's CPU time.
fn cpu_time(command: &mut Command) -> Result<f64, String> {
    let before = children_cpu_seconds()?;
    run_to_end(command)?;
    Ok(children_cpu_seconds()? - before)
}

/// User plus system CPU seconds of every child this process has waited for:
/// fields 16 and 17 (`cutime`, `cstime`) of /proc/self/stat, in clock ticks
/// of `getconf CLK_TCK` (proc(5)). Linux only.
fn children_cpu_seconds() -> Result<f64, String> {
    let stat = std::fs::read_to_string("/proc/self/stat")
        .map_err(|e| format!("--cpu-time reads /proc/self/stat (Linux only): {e}"))?;
    ticks_to_seconds(children_ticks(&stat)?)
}

/// cutime + cstime from a /proc/<pid>/stat line. Fields are counted after
/// the command name's closing parenthesis (the name may hold spaces):
/// field 3 (state) is the first there, so fields 16 and 17 are the 14th and
/// 15th.
fn children_ticks(stat: &str) -> Result<u64, String> {
    let rest = stat
        .rsplit_once(')')
        .map(|(_, rest)| rest)
        .ok_or("/proc/self/stat has no command name")?;
    let field = |k: usize| {
        rest.split_whitespace()
            .nth(k - 3)
            .and_then(|v| v.parse::<u64>().ok())
            .ok_or(format!("/proc/self/stat: field {k} is missing"))
    };
    Ok(field(16)? + field(17)?)
}

/// Clock ticks to seconds with the kernel's tick rate (`getconf CLK_TCK`,
/// read once).
fn ticks_to_seconds(ticks: u64) -> Result<f64, String> {
    static CLK_TCK: std::sync::OnceLock<Result<f64, String>> = std::sync::OnceLock::new();
    let rate = CLK_TCK.get_or_init(|| {
        let output = Command::new("getconf")
            .arg("CLK_TCK")
            .output()
            .map_err(|e| format!("--cpu-time runs getconf CLK_TCK: {e}"))?;
        String::from_utf8_lossy(&output.stdout)
            .trim()
            .parse::<f64>()
            .ok()
            .filter(|&r| r > 0.0)
            .ok_or_else(|| "getconf CLK_TCK printed no tick rate".to_string())
    });
    Ok(ticks as f64 / rate.clone()?)
}

/// Runs `command` to its end; an error names the program and says what it
/// printed when it fails.
fn run_to_end(command: &mut Command) -> Result<(), String> {
    let output = command
        .output()
        .map_err(|e| format!("cannot run {:?}: {e}", command.get_program()))?;
    if !output.status.success() {
        return Err(format!(
            "{:?} failed ({}): {}{}",
            command.get_program(),
            output.status,
            String::from_utf8_lossy(&output.stdout),
            String::from_utf8_lossy(&output.stderr)
        ));
    }
    Ok(())
}

fn median(values: &mut [f64]) -> f64 {
    values.sort_by(f64::total_cmp);
    values[values.len() / 2]
}

struct Row {
    scene: u32,
    algorithm: String,
    ours: f64,
    theirs: f64,
}

/// `report.md` and `report.json`; `commit` is the one measured (read at the start).
fn report(commit: &str, options: &Options, rows: &[Row]) -> Result<(), String> {
    let mut md = format!(
        "# Ours against SmallVCM, seconds per iteration\n\n\
         commit {commit}, {} cores, load average {} at the end; 512x512, (t(1 + {k}) - t(1)) / {k} \
         with t the {clock} of the process, median of {} interleaved rounds; SmallVCM built with \
         `g++ {}`. Ratio < 1: ours is faster.\n\n\
         | scene | algorithm | ours (s/it) | SmallVCM (s/it) | ours / SmallVCM |\n|---|---|---:|---:|---:|\n",
        crate::cores(),
        crate::load_average(),
        options.repeat,
        gxx_flags().join(" "),
        k = options.iterations,
        clock = if options.cpu_time {
            "CPU time (user + system), one thread each,"
        } else {
            "wall-clock time"
        },
    );
    for r in rows {
        md += &format!(
            "| {} | {} | {:.4} | {:.4} | {:.2} |\n",
            r.scene,
            r.algorithm,
            r.ours,
            r.theirs,
            r.ours / r.theirs
        );
    }
    let json = json!({
        "commit": commit,
        "cores": crate::cores(),
        "iterations": options.iterations,
        "repeat": options.repeat,
        "clock": if options.cpu_time { "cpu, one thread" } else { "wall" },
        "rows": rows.iter().map(|r| json!({
            "scene": r.scene, "algorithm": r.algorithm,
            "ours_s_per_iteration": r.ours, "smallvcm_s_per_iteration": r.theirs,
        })).collect::<Vec<_>>(),
    });
    let (md_path, _) = crate::write_report(&options.out, "report", &md, &json)?;
    println!("{md}\nwritten to {}", md_path.display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_failing_program_is_an_error_naming_it() {
        let e = wall_time(Command::new("false").arg("x")).unwrap_err();
        assert!(e.contains("false"), "{e}");
        assert!(wall_time(&mut Command::new("true")).unwrap() >= 0.0);
    }

    /// The children's CPU time is read from the right fields, also when the
    /// command name holds spaces and parentheses, and grows with a child
    /// that computes.
    #[test]
    fn cpu_time_counts_the_childs_cpu_seconds() {
        let stat = "12 (a (b) c) S 1 2 3 4 5 6 7 8 9 10 11 12 13 14 15 16";
        // Field 16 is "13" and 17 is "14" (field 3 is "S").
        assert_eq!(children_ticks(stat).unwrap(), 27);
        let busy = cpu_time(
            Command::new("sh").args(["-c", "i=0; while [ $i -lt 300000 ]; do i=$((i+1)); done"]),
        )
        .unwrap();
        assert!(busy > 0.05, "{busy}");
        assert!(cpu_time(&mut Command::new("true")).unwrap() < busy);
    }

    #[test]
    fn per_iteration_subtracts_the_one_iteration_render() {
        let t = per_iteration(4, |n| Ok(0.5 + 0.25 * f64::from(n))).unwrap();
        assert!((t - 0.25).abs() < 1e-12);
    }
}
