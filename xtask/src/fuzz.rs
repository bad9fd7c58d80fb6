//! `cargo xtask fuzz --target NAME --minutes M` (and `--list`): runs one
//! cargo-fuzz target of `fuzz/` for M minutes, with its seed corpus.
//!
//! The fuzz project (`fuzz/`, not a member of the workspace) holds eight
//! libFuzzer targets: the glTF, GLB, OBJ+MTL, manifest and Mitsuba XML
//! loaders through `scene::load`, the PLY and `.serialized` mesh readers
//! directly, and the renderer on small manifests. cargo-fuzz needs
//! nightly features; on the stable toolchain they are unlocked with
//! `RUSTC_BOOTSTRAP=1`, and the build uses `--sanitizer none` (AddressSanitizer
//! does not help with safe Rust, and needs nightly's runtime) with debug
//! assertions on (`-a`), so that integer overflow panics as in the test
//! profile. Install cargo-fuzz with `cargo install cargo-fuzz`.
//!
//! Corpora: libFuzzer writes new inputs to the first folder only,
//! `fuzz/work/corpus/NAME` (ignored by git); the committed seeds
//! (`fuzz/corpus/NAME`, small files) and seeds copied at run time from
//! `scenes/`, `crates/scene/tests/data/` and `../shared/scenes-external/`
//! (`fuzz/work/seeds/NAME`, the large ones) are read only. libFuzzer runs in
//! fork mode and keeps going after a crash; crashes, timeouts and
//! out-of-memory inputs go to `fuzz/artifacts/NAME/`. The log is kept in
//! `fuzz/work/logs/NAME.log`; the summary prints executions, exec/s and the
//! artifacts that are new.
//!
//! Minimise a crash with `RUSTC_BOOTSTRAP=1 cargo fuzz tmin --fuzz-dir fuzz
//! --sanitizer none -a NAME fuzz/artifacts/NAME/crash-...`.

use std::collections::BTreeSet;
use std::fs;
use std::io::{BufRead, BufReader, Write as _};
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Instant;

pub const USAGE: &str = "  fuzz --target NAME --minutes M | --list
                    coverage-guided fuzzing (cargo-fuzz, libFuzzer) of one
                    target of fuzz/ for M minutes with its seed corpus;
                    crashes go to fuzz/artifacts/NAME/ (needs `cargo install
                    cargo-fuzz`; runs on stable with RUSTC_BOOTSTRAP=1)";

/// The targets: name, extension of their inputs, what they exercise.
pub const TARGETS: &[(&str, &str, &str)] = &[
    ("gltf_json", "gltf", ".gltf text through scene::load"),
    ("glb", "glb", ".glb bytes through scene::load"),
    (
        "obj_mtl",
        "objmtl",
        "OBJ, NUL byte, MTL (written as fuzz.mtl) through scene::load",
    ),
    (
        "scene_toml",
        "toml",
        "scene.toml manifests through scene::load",
    ),
    (
        "render",
        "toml",
        "scene.toml at 8x6, one iteration of pt, bpt, ppm, bpm, vcm",
    ),
    (
        "mitsuba_xml",
        "xml",
        "Mitsuba 3 scene files (with fixed meshes beside them) through scene::load",
    ),
    ("ply", "ply", "PLY bytes through scene::mitsuba::ply::read"),
    (
        "serialized",
        "serialized",
        "shape_index byte, then .serialized bytes, through scene::mitsuba::serialized::read",
    ),
];

/// Parsed command line.
struct Options {
    target: String,
    minutes: f64,
}

fn parse(args: &[String]) -> Result<Option<Options>, String> {
    let mut target = None;
    let mut minutes = None;
    let mut it = args.iter();
    while let Some(arg) = it.next() {
        match arg.as_str() {
            "--list" => return Ok(None),
            "--target" => target = it.next().cloned(),
            "--minutes" => {
                let value = it.next().ok_or("--minutes needs a value")?;
                minutes = Some(
                    value
                        .parse::<f64>()
                        .ok()
                        .filter(|m| m.is_finite() && *m > 0.0)
                        .ok_or_else(|| format!("--minutes: not a positive number: {value}"))?,
                );
            }
            other => return Err(format!("unexpected argument `{other}`; usage:\n{USAGE}")),
        }
    }
    let target = target.ok_or_else(|| format!("--target NAME is required; usage:\n{USAGE}"))?;
    if !TARGETS.iter().any(|(name, ..)| *name == target) {
        return Err(format!(
            "unknown target `{target}`; targets: {}",
            TARGETS
                .iter()
                .map(|(n, ..)| *n)
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    Ok(Some(Options {
        target,
        minutes: minutes.unwrap_or(10.0),
    }))
}

/// Entry point of `cargo xtask fuzz`.
pub fn run(root: &Path, args: &[String]) -> Result<(), String> {
    let Some(options) = parse(args)? else {
        for (name, _, what) in TARGETS {
            println!("{name:<12} {what}");
        }
        return Ok(());
    };
    let name = options.target.as_str();
    let fuzz_dir = root.join("fuzz");
    let work = fuzz_dir.join("work");
    let corpus = work.join("corpus").join(name);
    let seeds = work.join("seeds").join(name);
    let artifacts = fuzz_dir.join("artifacts").join(name);
    let logs = work.join("logs");
    for dir in [&corpus, &seeds, &artifacts, &logs] {
        fs::create_dir_all(dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    }
    let copied = copy_runtime_seeds(root, name, &seeds)?;
    println!(
        "fuzz {name}: {:.1} min; seeds: fuzz/corpus/{name} + {copied} copied to {}",
        options.minutes,
        seeds.display()
    );

    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let probe = Command::new(&cargo)
        .args(["fuzz", "--version"])
        .output()
        .map_err(|e| format!("could not run {cargo}: {e}"))?;
    if !probe.status.success() {
        return Err("cargo-fuzz is not installed: run `cargo install cargo-fuzz`".into());
    }

    // Every fork-mode job is a new process with its own scratch folder
    // (`rlt-fuzz-<pid>` in the temporary directory, holding the fixed glTF
    // buffers): point TMPDIR at a folder of ours and remove it afterwards.
    let tmp = work.join("tmp").join(name);
    let _ = fs::remove_dir_all(&tmp);
    fs::create_dir_all(&tmp).map_err(|e| format!("cannot create {}: {e}", tmp.display()))?;

    let before = artifact_names(&artifacts);
    let seconds = (options.minutes * 60.0).round().max(1.0) as u64;
    // The renderer needs more time per input than the loaders, and smaller
    // manifests; loaders get room for the larger glTF samples.
    let (timeout, max_len) = if name == "render" {
        ("-timeout=60", "-max_len=8192")
    } else {
        ("-timeout=20", "-max_len=262144")
    };
    let max_time = format!("-max_total_time={seconds}");
    let target_dir = fuzz_dir.join("target");
    let path_arg = |p: &Path| p.to_string_lossy().into_owned();
    let mut command = Command::new(&cargo);
    command
        .args(["fuzz", "run", "--sanitizer", "none", "-a", "--fuzz-dir"])
        .arg(path_arg(&fuzz_dir))
        .arg("--target-dir")
        .arg(path_arg(&target_dir))
        .arg(name)
        .arg(path_arg(&corpus))
        .arg(path_arg(&fuzz_dir.join("corpus").join(name)))
        .arg(path_arg(&seeds))
        .args([
            "--",
            &max_time,
            timeout,
            max_len,
            "-rss_limit_mb=2048",
            "-fork=1",
            "-ignore_crashes=1",
            "-ignore_timeouts=1",
            "-ignore_ooms=1",
            "-print_final_stats=1",
        ])
        .env("RUSTC_BOOTSTRAP", "1")
        .env("TMPDIR", &tmp)
        .env_remove("CARGO_TARGET_DIR")
        .current_dir(root)
        .stdout(Stdio::inherit())
        .stderr(Stdio::piped());
    let start = Instant::now();
    let mut child = command
        .spawn()
        .map_err(|e| format!("could not run cargo fuzz: {e}"))?;
    let log_path = logs.join(format!("{name}.log"));
    let mut log = fs::File::create(&log_path)
        .map_err(|e| format!("cannot write {}: {e}", log_path.display()))?;
    let mut stats = Stats::default();
    if let Some(stderr) = child.stderr.take() {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = writeln!(log, "{line}");
            stats.read(&line);
            // The fork-mode status lines and errors; per-input noise stays in the log.
            if line.starts_with('#')
                || line.starts_with("INFO: fuzzed")
                || line.contains("error")
                || line.contains("Compiling")
                || line.contains("Finished")
                || line.contains("CRASH")
                || line.contains("panicked")
            {
                eprintln!("{line}");
            }
        }
    }
    let status = child
        .wait()
        .map_err(|e| format!("cargo fuzz did not finish: {e}"))?;
    let elapsed = start.elapsed().as_secs_f64();
    let _ = fs::remove_dir_all(&tmp);

    let after = artifact_names(&artifacts);
    let new: Vec<&String> = after.difference(&before).collect();
    let count = |prefix: &str| new.iter().filter(|n| n.starts_with(prefix)).count();
    println!();
    println!("target:      {name}");
    println!("time:        {elapsed:.0} s (fuzzing {seconds} s)");
    match stats.executions {
        Some(n) => println!(
            "executions:  {n} ({:.0} exec/s)",
            n as f64 / seconds.max(1) as f64
        ),
        None => println!("executions:  ? (see {})", log_path.display()),
    }
    if let Some(cov) = &stats.coverage {
        println!("coverage:    {cov}");
    }
    println!(
        "crashes:     {} new (timeouts {}, out of memory {}) in {}",
        count("crash-"),
        count("timeout-"),
        count("oom-"),
        artifacts.display()
    );
    for n in &new {
        println!("  {n}");
    }
    println!("log:         {}", log_path.display());
    if !status.success() && stats.executions.is_none() {
        return Err(format!(
            "cargo fuzz failed ({status}); see {}",
            log_path.display()
        ));
    }
    Ok(())
}

/// What the libFuzzer log tells.
#[derive(Default)]
struct Stats {
    executions: Option<u64>,
    coverage: Option<String>,
}

impl Stats {
    /// Reads one line: `#N: cov: ...` (fork mode), `#N\tNEW cov: ...`
    /// (single process) or `stat::number_of_executed_units: N`.
    fn read(&mut self, line: &str) {
        if let Some(rest) = line.strip_prefix('#') {
            let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
            if let Ok(n) = digits.parse::<u64>() {
                self.executions = Some(self.executions.map_or(n, |e| e.max(n)));
                if let Some(i) = rest.find("cov: ") {
                    let cov: String = rest[i..]
                        .split_whitespace()
                        .take(4)
                        .collect::<Vec<_>>()
                        .join(" ");
                    self.coverage = Some(cov);
                }
            }
        } else if let Some(n) = line
            .strip_prefix("stat::number_of_executed_units:")
            .and_then(|s| s.trim().parse::<u64>().ok())
        {
            self.executions = Some(self.executions.map_or(n, |e| e.max(n)));
        }
    }
}

/// File names in `dir` (empty if it does not exist).
fn artifact_names(dir: &Path) -> BTreeSet<String> {
    fs::read_dir(dir)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .map(|e| e.file_name().to_string_lossy().into_owned())
                .collect()
        })
        .unwrap_or_default()
}

/// Copies the seeds of `target` that are not committed (too large, or
/// outside the repository) into `seeds`; returns how many.
fn copy_runtime_seeds(root: &Path, target: &str, seeds: &Path) -> Result<usize, String> {
    let data = root.join("crates/scene/tests/data");
    let external = root.join("../shared/scenes-external");
    let mut count = 0;
    let mut put = |name: &str, bytes: Vec<u8>| -> Result<(), String> {
        crate::write_file(&seeds.join(name), bytes)?;
        count += 1;
        Ok(())
    };
    match target {
        "gltf_json" => {
            for base in [&data, &external] {
                for file in gltf_files(base, "gltf") {
                    if let Ok(bytes) = fs::read(&file) {
                        put(&seed_name(base, &file), bytes)?;
                    }
                }
            }
        }
        "glb" => {
            for base in [&data, &external] {
                for file in gltf_files(base, "glb") {
                    if let Ok(bytes) = fs::read(&file) {
                        put(&seed_name(base, &file), bytes)?;
                    }
                }
            }
        }
        "obj_mtl" => {
            let mut objs = vec![root.join("scenes/cornell-box/cornell-box.obj")];
            for base in [&data, &external] {
                objs.extend(gltf_files(base, "obj"));
            }
            for obj in objs {
                if let Some(bytes) = obj_mtl_seed(&obj) {
                    let name = obj
                        .file_stem()
                        .map_or("obj".into(), |s| s.to_string_lossy());
                    put(&format!("{name}.objmtl"), bytes)?;
                }
            }
        }
        "scene_toml" | "render" => {
            if let Ok(entries) = fs::read_dir(root.join("scenes")) {
                for entry in entries.filter_map(Result::ok) {
                    let manifest = entry.path().join("scene.toml");
                    if let Ok(bytes) = fs::read(&manifest) {
                        put(
                            &format!("{}.toml", entry.file_name().to_string_lossy()),
                            bytes,
                        )?;
                    }
                }
            }
        }
        _ => {}
    }
    Ok(count)
}

/// Files ending in `.ext` under `base` (two levels of sample folders deep).
fn gltf_files(base: &Path, ext: &str) -> Vec<PathBuf> {
    let mut out = Vec::new();
    let mut stack = vec![(base.to_path_buf(), 0)];
    while let Some((dir, depth)) = stack.pop() {
        let Ok(entries) = fs::read_dir(&dir) else {
            continue;
        };
        for entry in entries.filter_map(Result::ok) {
            let path = entry.path();
            if path.is_dir() && depth < 3 {
                stack.push((path, depth + 1));
            } else if path.extension().and_then(|e| e.to_str()) == Some(ext) {
                out.push(path);
            }
        }
    }
    out.sort();
    out
}

/// A seed name from a path under `base`: its components joined by `-`.
fn seed_name(base: &Path, file: &Path) -> String {
    let relative = file.strip_prefix(base).unwrap_or(file);
    let parts: Vec<String> = relative
        .components()
        .map(|c| c.as_os_str().to_string_lossy().into_owned())
        .collect();
    parts.join("-")
}

/// An `obj_mtl` input: the OBJ with its `mtllib` line renamed to `fuzz.mtl`,
/// a NUL byte, and the MTL file it named (empty if none).
fn obj_mtl_seed(obj: &Path) -> Option<Vec<u8>> {
    let text = fs::read(obj).ok()?;
    let mut out = Vec::with_capacity(text.len());
    let mut mtl = Vec::new();
    for line in text.split_inclusive(|&b| b == b'\n') {
        let trimmed = line.trim_ascii();
        if let Some(name) = trimmed.strip_prefix(b"mtllib") {
            let name = String::from_utf8_lossy(name.trim_ascii()).into_owned();
            if let Some(dir) = obj.parent() {
                mtl = fs::read(dir.join(&name)).unwrap_or_default();
            }
            out.extend_from_slice(b"mtllib fuzz.mtl\n");
        } else {
            out.extend_from_slice(line);
        }
    }
    out.push(0);
    out.extend_from_slice(&mtl);
    Some(out)
}
