//! End-to-end tests of the `render-cli` binary on the bundled scenes, at tiny
//! settings (16x12 pixels, 2 iterations); checkpoints under faults in
//! [`checkpoint`].

mod checkpoint;
mod libm;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use image_io::read_exr;

const TINY: [&str; 4] = ["--resolution", "16x12", "--iterations", "2"];

fn bundled(scene: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(format!("../../scenes/{scene}/scene.toml"))
}

fn render_cli(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_render-cli"))
        .args(args)
        .output()
        .expect("the binary runs")
}

/// [`render_cli`] with one more environment variable.
fn render_cli_with_env(args: &[&str], (key, value): (&str, &str)) -> Output {
    Command::new(env!("CARGO_BIN_EXE_render-cli"))
        .args(args)
        .env(key, value)
        .output()
        .expect("the binary runs")
}

fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

/// Runs the binary with `args`, asserting that it succeeds; its stdout.
fn stdout_of(args: &[&str]) -> String {
    let output = render_cli(args);
    assert!(output.status.success(), "{}", stderr(&output));
    String::from_utf8(output.stdout).unwrap()
}

/// Asserts that `stdout` contains every one of `lines`.
fn assert_mentions(stdout: &str, lines: &[&str]) {
    for line in lines {
        assert!(stdout.contains(line), "'{line}' missing from:\n{stdout}");
    }
}

fn files_in(dir: &Path) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .collect();
    files.sort();
    files
}

/// Asserts a failed run: non-zero exit, one `error:` line that mentions every
/// string in `names`, and no image written into `dir`.
fn assert_fails_cleanly(output: &Output, names: &[&str], dir: &Path) {
    let err = stderr(output);
    assert!(!output.status.success(), "succeeded; stderr: {err}");
    let lines: Vec<&str> = err.lines().collect();
    assert_eq!(lines.len(), 1, "expected one line, got: {err}");
    assert!(lines[0].starts_with("error: "), "{err}");
    for name in names {
        assert!(lines[0].contains(name), "'{name}' missing from: {err}");
    }
    let written: Vec<PathBuf> = files_in(dir)
        .into_iter()
        .filter(|f| f.extension().is_some_and(|e| e != "toml"))
        .collect();
    assert!(written.is_empty(), "left behind: {written:?}");
}

#[test]
fn renders_the_cornell_box_to_exr_and_png() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("box.exr");
    let scene = bundled("cornell-box");
    let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
    args.extend(TINY);
    let output = render_cli(&args);
    let err = stderr(&output);
    assert!(output.status.success(), "{err}");
    assert!(
        err.lines()
            .last()
            .is_some_and(|l| l.starts_with("rendered 2 iterations of 16x12 in ")),
        "{err}"
    );
    assert!(dir.path().join("box.png").is_file());
    let image = read_exr(&exr).unwrap();
    assert_eq!((image.width, image.height), (16, 12));
    assert!(
        image
            .pixels
            .iter()
            .all(|p| p.is_finite() && p.min_element() >= 0.0)
    );
    let mean = image.pixels.iter().map(|p| p.element_sum()).sum::<f32>();
    assert!(mean > 0.0, "black image");
}

/// The energy tables that the first iteration will read are built before
/// it, with a line on stderr (glossy-caustic: PT, selective, a GGX
/// conductor); not without compensation, and not where the rule may widen
/// nothing (caustic-glass's VCM under `unsampleable`). Where the rule widens
/// lobes only on paths found while rendering (`unsampleable` BPT on
/// caustic-glass's SDS caustic), the tables built at first use are reported
/// after the render.
#[test]
fn energy_tables_are_announced_when_the_render_reads_them() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("out.exr");
    let cases = [
        ("glossy-caustic", &[][..], Some("tables ready in")),
        ("glossy-caustic", &["--regularize-energy", "off"][..], None),
        ("caustic-glass", &[][..], None),
        (
            "caustic-glass",
            &["--integrator", "bpt"][..],
            Some("built at first use, during the render"),
        ),
    ];
    for (scene, extra, announced) in cases {
        let scene = bundled(scene);
        let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
        args.extend(TINY);
        args.extend(extra);
        let output = render_cli(&args);
        let err = stderr(&output);
        assert!(output.status.success(), "{args:?}: {err}");
        let lines: Vec<&str> = err
            .lines()
            .filter(|l| l.starts_with("energy compensation: "))
            .collect();
        match announced {
            Some(phrase) => assert!(
                lines.len() == 1 && lines[0].contains(phrase),
                "{args:?}: {err}"
            ),
            None => assert!(lines.is_empty(), "{args:?}: {err}"),
        }
    }
}

#[test]
fn a_missing_scene_is_one_line_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("no-such-scene.toml");
    let exr = dir.path().join("out.exr");
    let output = render_cli(&[scene.to_str().unwrap(), "-o", exr.to_str().unwrap()]);
    assert_fails_cleanly(&output, &["no-such-scene.toml"], dir.path());
}

#[test]
fn a_malformed_manifest_is_one_line_naming_it() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("broken.toml");
    std::fs::write(&scene, "[camera\nfrom = [0, 1").unwrap();
    let exr = dir.path().join("out.exr");
    let output = render_cli(&[scene.to_str().unwrap(), "-o", exr.to_str().unwrap()]);
    assert_fails_cleanly(&output, &["broken.toml"], dir.path());
}

#[test]
fn a_bad_manifest_value_says_it_came_from_the_manifest() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("scene.toml");
    // Canonical: a message quotes at most 80 characters of a path, so
    // `crates/render-cli/../../` in a deep checkout would cut the file name.
    let box_obj = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("../../scenes/cornell-box")
        .canonicalize()
        .unwrap();
    let manifest = std::fs::read_to_string(box_obj.join("scene.toml"))
        .unwrap()
        .replace("regularize = \"selective\"", "regularize = \"strict\"")
        .replace(
            "file = \"cornell-box.obj\"",
            &format!(
                "file = {:?}",
                box_obj.join("cornell-box.obj").to_str().unwrap()
            ),
        );
    assert!(manifest.contains("strict"));
    std::fs::write(&scene, manifest).unwrap();
    let exr = dir.path().join("out.exr");
    let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
    args.extend(TINY);
    // The model is the bundled one, outside the temporary folder: refused
    // unless allowed.
    let outside = render_cli(&args);
    assert_fails_cleanly(
        &outside,
        &[
            "scene.toml",
            "[[model]] 0 file",
            "cornell-box.obj",
            "outside",
            "--allow-outside-paths",
        ],
        dir.path(),
    );
    args.push("--allow-outside-paths");
    let output = render_cli(&args);
    assert_fails_cleanly(
        &output,
        &["scene.toml", "regularize", "strict", "manifest"],
        dir.path(),
    );
    // A flag overrides the bad value without looking at it.
    args.extend(["--regularize", "off"]);
    let output = render_cli(&args);
    assert!(output.status.success(), "{}", stderr(&output));
}

#[test]
fn bad_flag_values_name_the_flag() {
    let dir = tempfile::tempdir().unwrap();
    let scene = bundled("cornell-box");
    let exr = dir.path().join("out.exr");
    let cases: [(&[&str], &[&str]); 11] = [
        (&["--regularize", "strict"], &["--regularize", "strict"]),
        (&["--integrator", "xyz"], &["--integrator", "xyz"]),
        (&["--resolution", "0x5"], &["--resolution", "0x5"]),
        (&["--tau0", "0.1"], &["--tau0", "0.1"]),
        (&["--iterations", "0"], &["--iterations"]),
        (&["--time", "-1"], &["--time"]),
        (&["--camera-from", "1,2"], &["--camera-from"]),
        (&["--radius", "-1"], &["--radius", "got -1"]),
        (
            &["--shadow-roulette", "NaN"],
            &["--shadow-roulette", "got NaN"],
        ),
        (
            &["--virtual-merges", "yes"],
            &["--virtual-merges", "on or off"],
        ),
        (
            &["--iterations", "2", "--time", "1"],
            &["--iterations", "--time"],
        ),
    ];
    for (flags, names) in cases {
        let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
        args.extend(flags);
        let output = render_cli(&args);
        assert_eq!(
            output.status.code(),
            Some(2),
            "{flags:?}: {}",
            stderr(&output)
        );
        assert_fails_cleanly(&output, names, dir.path());
    }
}

#[test]
fn a_missing_output_folder_fails_before_rendering() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("missing/out.exr");
    let scene = bundled("cornell-box");
    let output = render_cli(&[scene.to_str().unwrap(), "-o", exr.to_str().unwrap()]);
    assert_fails_cleanly(&output, &["--output", "missing"], dir.path());
}

#[test]
fn help_mentions_every_flag() {
    let output = render_cli(&["--help"]);
    assert!(output.status.success());
    let help = String::from_utf8(output.stdout).unwrap();
    for flag in [
        "--integrator",
        "--iterations",
        "--time",
        "--regularize",
        "--tau0",
        "--no-progressive",
        "--max-depth",
        "--threads",
        "--seed",
        "--resolution",
        "--camera-from",
        "--camera-at",
        "--camera-up",
        "--fov",
        "--camera ",
        "--output",
        "--png",
        "--no-png",
        "--exposure",
        "--explain",
        "--radius",
        "--shadow-roulette",
        "--virtual-merges",
        "--allow-empty",
        "--env ",
        "--env-scale",
        "--env-rotation",
        "-D <NAME=VALUE>",
        "D/4 for reflection",
        "shadow_roulette",
    ] {
        assert!(help.contains(flag), "--help does not mention {flag}");
    }
}

#[test]
fn explain_prints_the_settings_and_renders() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("out.exr");
    let scene = bundled("cornell-box");
    let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
    args.extend(TINY);
    args.extend(["--explain", "--no-png", "--threads", "1"]);
    let stdout = stdout_of(&args);
    assert_mentions(
        &stdout,
        &[
            "regularize:       selective (scene file)",
            "iterations:       2 (flag)",
            "tau0:             30 (default)",
            "threads:          1",
            "ray queries:      32 triangles, 0 spheres; ",
            "; SIMD kernels on ",
        ],
    );
    assert!(exr.is_file() && !dir.path().join("out.png").exists());
}

/// The caustic-glass manifest (analytic shapes only, no model file) with
/// `extra` at the start of its `[render]` table, written to `dir`.
fn caustic_glass_with_render_keys(dir: &Path, extra: &str) -> PathBuf {
    let manifest = std::fs::read_to_string(bundled("caustic-glass"))
        .unwrap()
        .replace("[render]\n", &format!("[render]\n{extra}"));
    assert!(manifest.contains(extra) && !manifest.contains("[[model]]"));
    let scene = dir.join("scene.toml");
    std::fs::write(&scene, manifest).unwrap();
    scene
}

#[test]
fn manifest_render_keys_take_effect_and_flags_override_them() {
    let dir = tempfile::tempdir().unwrap();
    let keys = "radius = 0.02\nshadow_roulette = 0.25\nvirtual_merges = false\n";
    let scene = caustic_glass_with_render_keys(dir.path(), keys);
    let exr = dir.path().join("out.exr");
    let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
    args.extend(TINY);
    args.extend(["--explain", "--no-png", "--integrator", "vcm"]);
    let stdout = stdout_of(&args);
    assert_mentions(
        &stdout,
        &[
            "radius:           0.02 (scene file)",
            "shadow roulette:  0.25 (scene file)",
            "virtual merges:   off (scene file)",
            "(0.02 x scene radius;",
        ],
    );
    args.extend(["--radius", "0.01", "--shadow-roulette", "0"]);
    args.extend(["--virtual-merges", "on"]);
    let stdout = stdout_of(&args);
    assert_mentions(
        &stdout,
        &[
            "radius:           0.01 (flag)",
            "shadow roulette:  0 (flag)",
            "virtual merges:   on (flag)",
            "(0.01 x scene radius;",
        ],
    );
}

#[test]
fn a_bad_manifest_radius_is_one_line_naming_the_file_and_key() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("out.exr");
    for (keys, names) in [
        (
            "radius = nan\n",
            &["scene.toml", "[render] radius", "--radius"][..],
        ),
        (
            "radius = -1\n",
            &["scene.toml", "[render] radius", "got -1"][..],
        ),
        (
            "shadow_roulette = -0.5\n",
            &["scene.toml", "[render] shadow_roulette"][..],
        ),
        (
            "virtual_merges = \"on\"\n",
            &["scene.toml", "virtual_merges", "boolean"][..],
        ),
    ] {
        let scene = caustic_glass_with_render_keys(dir.path(), keys);
        let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
        args.extend(TINY);
        let output = render_cli(&args);
        assert_eq!(output.status.code(), Some(1), "{keys}: {}", stderr(&output));
        assert_fails_cleanly(&output, names, dir.path());
    }
}

#[cfg(unix)]
#[test]
fn interrupt_writes_the_iterations_done_so_far() {
    use std::io::{BufRead, BufReader};
    use std::process::Stdio;
    use std::time::Duration;

    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("out.exr");
    let checkpoint = dir.path().join("c.rltfilm");
    let scene = bundled("cornell-box");
    let mut child = Command::new(env!("CARGO_BIN_EXE_render-cli"))
        .args([scene.to_str().unwrap(), "-o", exr.to_str().unwrap()])
        .args(["--checkpoint", checkpoint.to_str().unwrap()])
        .args([
            "--resolution",
            "16x12",
            "--iterations",
            "100000000",
            "--explain",
        ])
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // --explain prints after the Ctrl-C handler is installed, just before the
    // first iteration, and ends with the "output:" line; then let the render
    // run for a while. stdout is drained to the end, so the child never
    // writes into a closed pipe.
    let stdout = BufReader::new(child.stdout.take().unwrap());
    let (started, explained) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        for line in stdout.lines().map_while(Result::ok) {
            if line.starts_with("output:") {
                let _ = started.send(());
            }
        }
    });
    explained
        .recv_timeout(Duration::from_secs(60))
        .expect("--explain output before the render");
    std::thread::sleep(Duration::from_secs(1));
    let pid = child.id().to_string();
    let kill = Command::new("kill").args(["-INT", &pid]).status().unwrap();
    assert!(kill.success());
    let output = child.wait_with_output().unwrap();
    reader.join().unwrap();
    let err = stderr(&output);
    assert_eq!(output.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted after"), "{err}");
    assert!(err.contains("of 100000000 iterations"), "{err}");
    // The checkpoint is kept, holding every iteration done, and says so.
    assert!(err.contains("c.rltfilm holds iterations 1..="), "{err}");
    assert!(
        err.contains("run the same command again to finish"),
        "{err}"
    );
    assert!(checkpoint.is_file());
    let image = read_exr(&exr).unwrap();
    assert!(image.pixels.iter().all(|p| p.is_finite()));
    assert!(dir.path().join("out.png").is_file());
    let leftovers: Vec<_> = files_in(dir.path())
        .into_iter()
        .filter(|f| f.to_string_lossy().ends_with(".partial"))
        .collect();
    assert!(leftovers.is_empty(), "{leftovers:?}");
}

/// Iteration shards written with `--partial` and merged in any order give
/// the EXR of the single-process render, byte for byte (VCM: light-tracing
/// splats and merges included); a merge merges again; gaps, overlaps,
/// other settings and damaged files are refused naming the file.
/// `--scalar-loop` gives the same image bytes as the default (wavefront)
/// path loop, and shards of either merge with each other (it is left out of
/// the settings a partial film records); `--wavefront`, the default, is
/// still accepted.
#[test]
fn scalar_loop_renders_and_shards_are_the_default_loops() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let scene = bundled("glossy-caustic");
    let common = [scene.to_str().unwrap(), "--resolution", "24x18"];
    let run = |extra: &[&str]| {
        let mut args = common.to_vec();
        args.extend(extra);
        let output = render_cli(&args);
        assert!(output.status.success(), "{args:?}: {}", stderr(&output));
    };
    run(&["--iterations", "4", "-o", &path("wavefront.exr")]);
    run(&[
        "--iterations",
        "4",
        "--scalar-loop",
        "-o",
        &path("scalar.exr"),
    ]);
    run(&["--iterations", "4", "--wavefront", "-o", &path("again.exr")]);
    let (a, b) = (path("a.rltfilm"), path("b.rltfilm"));
    run(&[
        "--iteration-range",
        "1..2",
        "--scalar-loop",
        "--partial",
        &a,
    ]);
    run(&["--iteration-range", "3..4", "--partial", &b]);
    let merged = render_cli(&["merge", &a, &b, "-o", &path("merged.exr"), "--no-png"]);
    assert!(merged.status.success(), "{}", stderr(&merged));
    let bytes = |name: &str| std::fs::read(dir.path().join(name)).unwrap();
    assert_eq!(bytes("wavefront.exr"), bytes("scalar.exr"));
    assert_eq!(bytes("again.exr"), bytes("wavefront.exr"));
    // --explain says which loop runs.
    for (flag, says) in [
        ("--wavefront", "a wavefront"),
        ("--scalar-loop", "one path after"),
    ] {
        let args = [&common[..], &["--iterations", "1", "--explain", flag]].concat();
        let output = render_cli(&[&args[..], &["-o", &path("explain.exr")]].concat());
        let text = String::from_utf8_lossy(&output.stdout);
        assert!(
            text.contains(&format!("path loop:        {says}")),
            "{flag}: {text}"
        );
    }
    assert_eq!(bytes("merged.exr"), bytes("scalar.exr"));
}

#[test]
fn shards_merge_into_the_single_process_render() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name).to_str().unwrap().to_owned();
    let scene = bundled("caustic-glass");
    let scene = scene.to_str().unwrap();
    let common = [scene, "--integrator", "vcm", "--resolution", "24x18"];
    let run = |extra: &[&str]| {
        let mut args = common.to_vec();
        args.extend(extra);
        let output = render_cli(&args);
        assert!(output.status.success(), "{args:?}: {}", stderr(&output));
    };
    run(&["--iterations", "7", "-o", &path("whole.exr"), "--no-png"]);
    for (range, file) in [("1..2", "a"), ("3..3", "b"), ("4..7", "c")] {
        run(&[
            "--iteration-range",
            range,
            "--partial",
            &path(&format!("{file}.rltfilm")),
        ]);
    }
    let merge = |films: &[&str], out: &str| {
        let mut args = vec!["merge"];
        args.extend(films);
        args.extend(["-o", out, "--no-png"]);
        render_cli(&args)
    };
    let (a, b, c) = (path("a.rltfilm"), path("b.rltfilm"), path("c.rltfilm"));
    let merged = merge(&[&c, &a, &b], &path("merged.exr"));
    assert!(merged.status.success(), "{}", stderr(&merged));
    assert!(
        stderr(&merged).contains("iterations 1..7"),
        "{}",
        stderr(&merged)
    );
    let bytes = |name: &str| std::fs::read(dir.path().join(name)).unwrap();
    assert_eq!(bytes("merged.exr"), bytes("whole.exr"));
    // Hierarchically: (a + b) + c.
    assert!(merge(&[&a, &b], &path("ab.rltfilm")).status.success());
    assert!(
        merge(&[&path("ab.rltfilm"), &c], &path("again.exr"))
            .status
            .success()
    );
    assert_eq!(bytes("again.exr"), bytes("whole.exr"));

    let refused = |films: &[&str], names: &[&str]| {
        let output = merge(films, &path("refused.exr"));
        let err = stderr(&output);
        assert!(
            !output.status.success() && err.starts_with("error: "),
            "{err}"
        );
        for name in names {
            assert!(err.contains(name), "'{name}' missing from: {err}");
        }
        assert!(!dir.path().join("refused.exr").exists());
    };
    refused(
        &[&a, &c],
        &["iterations 3..3 are missing", "a.rltfilm", "c.rltfilm"],
    );
    refused(&[&a, &path("ab.rltfilm")], &["overlap"]);
    run(&[
        "--iteration-range",
        "3..3",
        "--seed",
        "9",
        "--partial",
        &path("seed.rltfilm"),
    ]);
    refused(&[&a, &path("seed.rltfilm")], &["different settings"]);
    let damaged = path("damaged.rltfilm");
    let mut data = bytes("b.rltfilm");
    data.truncate(data.len() - 10);
    std::fs::write(&damaged, data).unwrap();
    refused(&[&a, &damaged, &c], &["damaged.rltfilm", "truncated"]);
}

/// Writes `files` under `dir/in/` and renders the first at tiny settings
/// (plus `extra`) into `dir/out.exr`.
fn render_files(dir: &Path, files: &[(&str, &[u8])], extra: &[&str]) -> Output {
    let input = dir.join("in");
    for (name, content) in files {
        let path = input.join(name);
        std::fs::create_dir_all(path.parent().unwrap()).unwrap();
        std::fs::write(path, content).unwrap();
    }
    let scene = input.join(files[0].0);
    let exr = dir.join("out.exr");
    let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
    args.extend(["--iterations", "1"]);
    args.extend(extra);
    render_cli(&args)
}

/// Hostile input (ARCHITECTURE.md, "Input rules"): exit 1, one short line
/// naming the file and element, no image written.
fn assert_refused(files: &[(&str, &[u8])], extra: &[&str], names: &[&str]) {
    let dir = tempfile::tempdir().unwrap();
    let output = render_files(dir.path(), files, extra);
    assert_eq!(output.status.code(), Some(1), "{}", stderr(&output));
    assert_fails_cleanly(&output, names, dir.path());
    let line = stderr(&output);
    let limit = 200 + 2 * dir.path().display().to_string().len() + 80;
    assert!(line.len() <= limit, "too long ({}): {line}", line.len());
}

const QUAD_MATERIAL: &str = "[[material]]\nname = \"m\"\ntype = \"diffuse\"\n[[shape]]\ntype = \"quad\"\nmaterial = \"m\"\norigin = [-1, -1, 0]\nu = [2, 0, 0]\nv = [0, 2, 0]\n";
const TRIANGLE_OBJ: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

#[test]
fn a_manifest_resolution_above_the_flags_limit_is_refused() {
    let toml = format!("resolution = [65536, 65536]\n{QUAD_MATERIAL}");
    assert_refused(
        &[("scene.toml", toml.as_bytes())],
        &[],
        &["scene.toml", "resolution", "16384"],
    );
}

#[test]
fn a_film_larger_than_the_available_memory_is_refused_before_allocating() {
    // 16384 x 16384 needs 16384^2 x 120 bytes = 30 GiB by the estimate.
    let needed = 16384u64 * 16384 * 120;
    let available = std::fs::read_to_string("/proc/meminfo")
        .ok()
        .and_then(|t| {
            let line = t
                .lines()
                .find(|l| l.starts_with("MemAvailable:"))?
                .to_owned();
            line.split_whitespace().nth(1)?.parse::<u64>().ok()
        })
        .map(|kib| kib * 1024);
    if available.is_none_or(|a| a >= needed) {
        eprintln!("skipped: {available:?} bytes available, the film fits");
        return;
    }
    let toml = format!(
        "resolution = [16384, 16384]\n{QUAD_MATERIAL}[[light]]\ntype = \"environment\"\nintensity = [1, 1, 1]\n"
    );
    assert_refused(
        &[("scene.toml", toml.as_bytes())],
        &[],
        &["scene.toml: resolution", "16384x16384", "memory"],
    );
    assert_refused(
        &[("scene.toml", toml.as_bytes())],
        &["--resolution", "16384x16384"],
        &["--resolution", "16384x16384", "memory"],
    );
}

#[test]
fn a_point_light_whose_power_overflows_is_refused() {
    let toml = format!(
        "{QUAD_MATERIAL}[[light]]\ntype = \"point\"\nposition = [0, 0, 1]\nintensity = [3e38, 3e38, 3e38]\n"
    );
    assert_refused(
        &[("scene.toml", toml.as_bytes())],
        &[],
        &["scene.toml", "light 1 (point)", "intensity"],
    );
}

#[test]
fn a_camera_name_with_an_obj_model_is_refused() {
    let toml = "[[model]]\nfile = \"a.obj\"\n[camera]\nname = \"nosuch\"\n";
    assert_refused(
        &[
            ("scene.toml", toml.as_bytes()),
            ("a.obj", TRIANGLE_OBJ.as_bytes()),
        ],
        &[],
        &["scene.toml", "[camera] name", "nosuch"],
    );
}

#[test]
fn mtl_nan_values_are_refused_naming_file_material_and_line() {
    let obj = format!("mtllib a.mtl\nusemtl m\n{TRIANGLE_OBJ}");
    for (mtl, key) in [("newmtl m\nNs nan\n", "Ns"), ("newmtl m\nd nan\n", "d")] {
        assert_refused(
            &[("a.obj", obj.as_bytes()), ("a.mtl", mtl.as_bytes())],
            &[],
            &["a.mtl", "material \"m\", line 2", key],
        );
    }
}

#[test]
fn empty_files_are_errors_unless_allow_empty() {
    for name in ["empty.obj", "scene.toml"] {
        assert_refused(&[(name, b"")], &[], &[name, "no geometry", "--allow-empty"]);
    }
    let dir = tempfile::tempdir().unwrap();
    let output = render_files(
        dir.path(),
        &[("empty.obj", b"")],
        &["--allow-empty", "--resolution", "4x4"],
    );
    assert!(output.status.success(), "{}", stderr(&output));
    assert!(stderr(&output).contains("warning: "));
    assert!(dir.path().join("out.exr").is_file());
}

#[test]
fn a_huge_obj_token_is_quoted_in_one_short_line() {
    let obj = format!("v 0 0 {}\n{TRIANGLE_OBJ}", "7".repeat(20_000_000));
    assert_refused(
        &[("big.obj", obj.as_bytes())],
        &[],
        &["big.obj", "line 1", "(20000000 characters)"],
    );
}

#[test]
fn a_referenced_folder_is_called_a_folder() {
    let obj = format!("mtllib lib\n{TRIANGLE_OBJ}");
    assert_refused(
        &[("a.obj", obj.as_bytes()), ("lib/x.mtl", b"")],
        &[],
        &["a.obj", "mtllib", "is a folder"],
    );
}

#[test]
fn an_out_of_range_face_index_names_its_line() {
    let obj = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n";
    assert_refused(
        &[("a.obj", obj.as_bytes())],
        &[],
        &["a.obj", "line 4", "vertex index 4"],
    );
}

#[test]
fn mtllib_and_textures_outside_the_scene_folder_are_refused() {
    let obj = format!("mtllib ../../../../etc/passwd\n{TRIANGLE_OBJ}");
    assert_refused(
        &[("a.obj", obj.as_bytes())],
        &[],
        &["a.obj", "mtllib", "outside", "--allow-outside-paths"],
    );
    let obj = format!("mtllib a.mtl\nusemtl m\n{TRIANGLE_OBJ}");
    let mtl = "newmtl m\nKd 1 1 1\nmap_Kd ../../../../etc/passwd\n";
    assert_refused(
        &[("a.obj", obj.as_bytes()), ("a.mtl", mtl.as_bytes())],
        &[],
        &["a.mtl", "map_Kd", "outside"],
    );
}

/// A one-triangle glTF (positions, u16 indices in `model.bin`), edited by
/// `edit` (a JSON text replacement), written with its buffer into a
/// `scene` folder of `dir`; the path of the .gltf.
fn hostile_gltf(dir: &Path, edit: (&str, &str)) -> PathBuf {
    let scene = dir.join("scene");
    std::fs::create_dir_all(&scene).unwrap();
    let mut bin = Vec::new();
    for c in [0.0f32, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0] {
        bin.extend_from_slice(&c.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0] {
        bin.extend_from_slice(&i.to_le_bytes());
    }
    std::fs::write(scene.join("model.bin"), &bin).unwrap();
    let gltf = r#"{"asset":{"version":"2.0"},"scene":0,"scenes":[{"nodes":[0]}],"nodes":[{"mesh":0}],
"meshes":[{"primitives":[{"attributes":{"POSITION":0},"indices":1}]}],
"buffers":[{"uri":"model.bin","byteLength":44}],
"bufferViews":[{"buffer":0,"byteOffset":0,"byteLength":36},{"buffer":0,"byteOffset":36,"byteLength":8}],
"accessors":[{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]},
{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}]}"#;
    assert!(gltf.contains(edit.0), "{}", edit.0);
    let path = scene.join("model.gltf");
    std::fs::write(&path, gltf.replacen(edit.0, edit.1, 1)).unwrap();
    path
}

/// glTF files that used to panic inside the gltf crate (exit 101) or read a
/// file outside the scene now fail with one line naming file and element,
/// and write nothing; the unedited file renders.
#[test]
fn hostile_gltf_files_fail_cleanly() {
    let valid = tempfile::tempdir().unwrap();
    let scene = hostile_gltf(valid.path(), ("", ""));
    let exr = valid.path().join("ok.exr");
    let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
    args.extend(TINY);
    let output = render_cli(&args);
    assert!(output.status.success(), "{}", stderr(&output));

    let cases = [
        (
            (r#""byteLength":36}"#, r#""byteLength":36,"byteStride":4}"#),
            &["model.gltf", "accessor 0", "byteStride 4"][..],
        ),
        (
            (r#""componentType":5123"#, r#""componentType":5126"#),
            &["model.gltf", "accessor 1", "FLOAT"][..],
        ),
        (
            (r#""uri":"model.bin""#, r#""uri":"../outside.bin""#),
            &["model.gltf", "buffer 0", "outside", "--allow-outside-paths"][..],
        ),
    ];
    for (edit, names) in cases {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("outside.bin"), [0u8; 44]).unwrap();
        let scene = hostile_gltf(dir.path(), edit);
        let out = dir.path().join("out");
        std::fs::create_dir(&out).unwrap();
        let exr = out.join("out.exr");
        let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
        args.extend(TINY);
        let output = render_cli(&args);
        assert_eq!(
            output.status.code(),
            Some(1),
            "{edit:?}: {}",
            stderr(&output)
        );
        assert_fails_cleanly(&output, names, &out);
    }
}

/// An extension the renderer does not implement is one warning naming it and
/// its material, and `--explain` lists it; a required one is an error naming it.
#[test]
fn unsupported_gltf_extensions_are_named() {
    let primitives = r#""indices":1}]}],"#;
    let with_clearcoat = r#""indices":1,"material":0}]}],
"extensionsUsed":["KHR_materials_clearcoat"],
"materials":[{"name":"paint","extensions":{"KHR_materials_clearcoat":{"clearcoatFactor":1}}}],"#;
    let dir = tempfile::tempdir().unwrap();
    let scene = hostile_gltf(dir.path(), (primitives, with_clearcoat));
    let exr = dir.path().join("out.exr");
    let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
    args.extend(TINY);
    args.extend(["--explain", "--no-png"]);
    let output = render_cli(&args);
    assert!(output.status.success(), "{}", stderr(&output));
    let warning = stderr(&output);
    let warning = warning
        .lines()
        .find(|l| l.contains("KHR_materials_clearcoat"));
    assert!(
        warning.is_some_and(|l| l.starts_with("warning:") && l.contains("\"paint\"")),
        "{warning:?}"
    );
    let explained = String::from_utf8_lossy(&output.stdout);
    assert!(
        explained
            .lines()
            .any(|l| l.starts_with("ignored:") && l.contains("KHR_materials_clearcoat")),
        "{explained}"
    );

    let asset = r#""asset":{"version":"2.0"}"#;
    let required = r#""asset":{"version":"2.0"},"extensionsUsed":["KHR_draco_mesh_compression"],"extensionsRequired":["KHR_draco_mesh_compression"]"#;
    let dir = tempfile::tempdir().unwrap();
    let scene = hostile_gltf(dir.path(), (asset, required));
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    let exr = out.join("out.exr");
    let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
    args.extend(TINY);
    let output = render_cli(&args);
    assert_eq!(output.status.code(), Some(1), "{}", stderr(&output));
    assert_fails_cleanly(&output, &["model.gltf", "KHR_draco_mesh_compression"], &out);
}

/// `--env` lights a scene with a map, replacing its environment, says so
/// in `--explain`; a missing or undecodable map is one line naming it.
#[test]
fn env_lights_any_scene_and_explain_says_so() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("out.exr");
    let sky = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/env-sphere/sky.hdr");
    let scene = bundled("diffuse-only");
    let render = |scale: &str| {
        let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
        args.extend(TINY);
        args.extend(["--no-png", "--explain", "--env", sky.to_str().unwrap()]);
        args.extend(["--env-scale", scale, "--env-rotation", "45"]);
        let stdout = stdout_of(&args);
        let image = read_exr(&exr).unwrap();
        let mean = image.pixels.iter().map(|p| p.element_sum()).sum::<f32>();
        (stdout, mean)
    };
    let (stdout, bright) = render("1");
    assert_mentions(
        &stdout,
        &[
            "environment:      map",
            "sky.hdr (--env: replaces the scene's own environment): 128x64 texels, scale 1, rotated 45",
        ],
    );
    let (_, dark) = render("0.25");
    assert!(bright > 2.0 * dark, "{bright} vs {dark}");
    let missing = dir.path().join("nope.exr");
    let mut args = vec![scene.to_str().unwrap(), "-o", exr.to_str().unwrap()];
    args.extend(["--env", missing.to_str().unwrap()]);
    std::fs::remove_file(&exr).unwrap();
    assert_fails_cleanly(&render_cli(&args), &["nope.exr"], dir.path());
}

/// A Mitsuba scene folder renders with the file's own settings where no
/// flag overrides them (here: the iterations, from `-D spp=2`); an unused
/// parameter is one line naming it, before anything is written.
#[test]
fn renders_a_mitsuba_scene_with_parameters() {
    let dir = tempfile::tempdir().unwrap();
    let exr = dir.path().join("mis.exr");
    let scene = Path::new(env!("CARGO_MANIFEST_DIR")).join("../../scenes/veach-mis");
    let args = [
        scene.to_str().unwrap(),
        "-o",
        exr.to_str().unwrap(),
        "--resolution",
        "32x18",
    ];
    let output = render_cli(&[&args[..], &["-D", "spp=2", "-D", "max_depth=2"]].concat());
    let err = stderr(&output);
    assert!(output.status.success(), "{err}");
    assert!(
        err.lines()
            .last()
            .is_some_and(|l| l.starts_with("rendered 2 iterations of 32x18 in ")),
        "{err}"
    );
    let image = read_exr(&exr).unwrap();
    assert!(
        image.pixels.iter().any(|p| p.element_sum() > 0.0),
        "black image"
    );

    let output = render_cli(&[&args[..], &["-D", "sppp=2"]].concat());
    let _ = std::fs::remove_file(dir.path().join("mis.png"));
    let _ = std::fs::remove_file(&exr);
    assert_fails_cleanly(&output, &["scene.xml", "sppp"], dir.path());
    let output = render_cli(&[&args[..], &["-D", "bad name=1"]].concat());
    assert!(!output.status.success() && stderr(&output).contains("letters, digits and _"));
}
