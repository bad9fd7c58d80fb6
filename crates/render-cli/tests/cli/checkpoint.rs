//! Checkpoints under faults: renders and merges killed (SIGKILL) at seeded
//! random moments and run again, full disks, read-only folders, two renders
//! given one checkpoint, checkpoints of other renders or damaged ones, time
//! budgets, and a soak of many iterations with millisecond checkpoints.
//!
//! The renders are BPT on cornell-box at 8x8 pixels: camera paths and
//! light-tracing splats, no energy tables to build, about 100 ms each.

use std::ffi::OsString;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::{Duration, Instant};

use image_io::film_file::{self, FilmHeader, PartialFilm};

use crate::{bundled, stderr};

/// Iterations of the renders killed at random moments (about 70 ms).
const KILL_ITERATIONS: u64 = 160;
/// Kill trials; each kills two runs and completes a third.
const KILL_TRIALS: u64 = 20;
/// Seed of the kill moments.
const KILL_SEED: u64 = 0x5eed_c0de;
/// Merges killed at random moments.
const MERGE_TRIALS: u64 = 10;

/// A render-cli command line under construction.
#[derive(Clone)]
struct Args(Vec<OsString>);

impl Args {
    /// The render of these tests with `extra` flags.
    fn render(extra: &[&str]) -> Self {
        let mut args = Self(vec![bundled("cornell-box").into()]);
        args.push(&["--integrator", "bpt", "--resolution", "8x8"]);
        args.push(extra);
        args
    }

    fn push(&mut self, extra: &[&str]) -> &mut Self {
        self.0.extend(extra.iter().map(OsString::from));
        self
    }

    fn path(&mut self, flag: &str, path: &Path) -> &mut Self {
        self.0.push(flag.into());
        self.0.push(path.into());
        self
    }

    fn command(&self) -> Command {
        let mut command = Command::new(env!("CARGO_BIN_EXE_render-cli"));
        command.args(&self.0).stdout(Stdio::null());
        command
    }

    fn run(&self) -> Output {
        self.command().output().expect("the binary runs")
    }

    fn spawn(&self) -> Child {
        self.command()
            .stderr(Stdio::piped())
            .spawn()
            .expect("the binary starts")
    }
}

/// SplitMix64: the seeded kill moments.
struct Rng(u64);

impl Rng {
    fn next(&mut self) -> u64 {
        self.0 = self.0.wrapping_add(0x9e37_79b9_7f4a_7c15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
        z ^ (z >> 31)
    }

    /// A uniform moment in [0, `max`).
    fn moment(&mut self, max: Duration) -> Duration {
        max.mul_f64((self.next() >> 11) as f64 / (1u64 << 53) as f64)
    }
}

/// Asserts a run that failed with one `error:` line (exit 1) containing
/// every string of `names` (after the `resuming from` line of a resumed
/// render, if any); the line.
fn one_error_line(output: &Output, names: &[&str]) -> String {
    let err = stderr(output);
    assert_eq!(output.status.code(), Some(1), "{err}");
    let lines: Vec<&str> = err
        .lines()
        .filter(|l| !l.starts_with("resuming from "))
        .collect();
    assert_eq!(lines.len(), 1, "expected one line: {err}");
    assert!(lines[0].starts_with("error: "), "{err}");
    for name in names {
        assert!(lines[0].contains(name), "'{name}' missing from: {err}");
    }
    lines[0].to_owned()
}

fn assert_success(output: &Output) -> String {
    let err = stderr(output);
    assert!(output.status.success(), "{err}");
    err
}

fn bytes(path: &Path) -> Vec<u8> {
    fs::read(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// The file that a checkpoint or image is written through before its rename.
fn temporary(path: &Path) -> PathBuf {
    image_io::atomic::temporary_path(path)
}

/// A temporary folder in memory (/dev/shm) where there is one: for tests
/// of many checkpoints that are about killed processes or memory, not about
/// the disk, whose syncs (about 4 ms a checkpoint here) would make them slow.
fn memory_temp_dir() -> tempfile::TempDir {
    let shm = Path::new("/dev/shm");
    if shm.is_dir()
        && let Ok(dir) = tempfile::tempdir_in(shm)
    {
        return dir;
    }
    tempfile::tempdir().unwrap()
}

/// Runs `args` to the end, or kills it after `limit` and fails.
fn run_within(args: &Args, limit: Duration) -> Output {
    let mut child = args.spawn();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > limit {
            let _ = child.kill();
            panic!("still running after {} s", limit.as_secs());
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().unwrap()
}

/// Kills `child` (SIGKILL) after `delay`, or lets it finish first; its stderr.
fn kill_after(mut child: Child, delay: Duration) -> String {
    std::thread::sleep(delay);
    // It may have exited already: nothing to kill.
    let _ = child.kill();
    stderr(&child.wait_with_output().unwrap())
}

/// SIGKILL at seeded random moments, twice per trial (the second run
/// resumes the first's checkpoint, if it wrote one), then a run to the end:
/// the image (EXR and PNG), or the partial film of a shard, is the
/// uninterrupted render's, byte for byte, and the checkpoint, its
/// temporary file and its lock file are gone.
#[test]
fn renders_killed_at_random_moments_resume_to_the_same_bytes() {
    let dir = memory_temp_dir();
    let path = |name: &str| dir.path().join(name);
    let iterations = KILL_ITERATIONS.to_string();
    let range = format!("3..{KILL_ITERATIONS}");
    let image = |exr: &Path| {
        let mut args = Args::render(&["--iterations", &iterations]);
        args.path("-o", exr);
        args
    };
    let shard = |film: &Path| {
        let mut args = Args::render(&["--iteration-range", &range]);
        args.path("--partial", film);
        args
    };
    assert_success(&image(&path("ref.exr")).run());
    assert_success(&shard(&path("ref.rltfilm")).run());
    // Kills fall in [0, 1.2 x the time of a checkpointed render).
    let start = Instant::now();
    let mut timed = image(&path("timed.exr"));
    timed
        .path("--checkpoint", &path("timed.rltfilm"))
        .push(&["--checkpoint-every", "0.001"]);
    assert_success(&timed.run());
    let span = start.elapsed().mul_f64(1.2);

    let mut rng = Rng(KILL_SEED);
    let (mut resumed, mut finished_resumed) = (0, 0);
    for trial in 0..KILL_TRIALS {
        let is_shard = trial % 2 == 1;
        let (out, reference) = if is_shard {
            (path(&format!("t{trial}.rltfilm")), path("ref.rltfilm"))
        } else {
            (path(&format!("t{trial}.exr")), path("ref.exr"))
        };
        let checkpoint = path(&format!("c{trial}.rltfilm"));
        let mut args = if is_shard { shard(&out) } else { image(&out) };
        args.path("--checkpoint", &checkpoint)
            .push(&["--checkpoint-every", "0.001"]);
        for _ in 0..2 {
            let err = kill_after(args.spawn(), rng.moment(span));
            resumed += usize::from(err.contains("resuming from"));
        }
        let err = assert_success(&args.run());
        finished_resumed += usize::from(err.contains("resuming from"));
        assert!(bytes(&out) == bytes(&reference), "trial {trial}: {err}");
        if !is_shard {
            let png = out.with_extension("png");
            assert!(bytes(&png) == bytes(&path("ref.png")), "trial {trial}");
        }
        for gone in [checkpoint.clone(), temporary(&checkpoint)] {
            assert!(!gone.exists(), "trial {trial}: {} is left", gone.display());
        }
        assert!(!image_io::lock::lock_path(&checkpoint).exists());
    }
    println!(
        "{KILL_TRIALS} trials: {resumed} killed runs and {finished_resumed} final runs resumed a checkpoint"
    );
    // Most kills fall inside the render, after its first checkpoint.
    assert!(
        finished_resumed >= KILL_TRIALS as usize / 4,
        "too few resumptions: {resumed} and {finished_resumed}"
    );
}

/// A partial film of a made-up render (`width` x `height`, iterations
/// `first..=last`) whose sums vary from pixel to pixel.
fn synthetic_film(first: u64, last: u64, width: u32, height: u32) -> PartialFilm {
    let pixels = (width * height) as usize;
    let value = |p: usize, k: u64| {
        let h = (p as u64 ^ k.wrapping_mul(0x9e37_79b9)).wrapping_mul(0x2545_f491_4f6c_dd1d);
        glam::DVec3::new((h % 1000) as f64 * 1e-3, (h >> 20) as f64 % 7.0, k as f64)
    };
    PartialFilm {
        header: FilmHeader {
            scene: "synthetic".to_owned(),
            scene_hash: 1,
            settings: "RenderConfig { seed: 0 }".to_owned(),
            seed: 0,
            first,
            last,
            width,
            height,
            render_millis: None,
        },
        iterations: last - first + 1,
        sum: (0..pixels).map(|p| value(p, first)).collect(),
        sum_sq: (0..pixels).map(|p| value(p, last)).collect(),
    }
}

/// `render-cli merge` killed (SIGKILL) at seeded random moments leaves
/// either no image or the whole one, never a part; run again, it writes
/// the same bytes.
#[test]
fn merges_killed_at_random_moments_leave_whole_files_and_rerun_to_the_same_bytes() {
    let dir = tempfile::tempdir().unwrap();
    let path = |name: &str| dir.path().join(name);
    let mut merge = Args(vec!["merge".into()]);
    for (k, (first, last)) in [(1, 4), (5, 9), (10, 20)].into_iter().enumerate() {
        let film = path(&format!("s{k}.rltfilm"));
        film_file::write(&film, &synthetic_film(first, last, 256, 192)).unwrap();
        merge.0.push(film.into());
    }
    let (exr, png) = (path("out.exr"), path("out.png"));
    merge.path("-o", &exr);
    let start = Instant::now();
    assert_success(&merge.run());
    let span = start.elapsed().mul_f64(1.2);
    let (reference, reference_png) = (bytes(&exr), bytes(&png));
    let mut rng = Rng(KILL_SEED ^ 1);
    let mut cut = 0;
    for trial in 0..MERGE_TRIALS {
        for file in [&exr, &png] {
            let _ = fs::remove_file(file);
        }
        kill_after(merge.spawn(), rng.moment(span));
        // Whole or absent.
        let (exr_whole, png_whole) = (exr.exists(), png.exists());
        if exr_whole {
            assert!(bytes(&exr) == reference, "trial {trial}: a partial EXR");
        }
        if png_whole {
            assert!(bytes(&png) == reference_png, "trial {trial}: a partial PNG");
        }
        cut += usize::from(!png_whole);
        assert_success(&merge.run());
        assert!(bytes(&exr) == reference && bytes(&png) == reference_png);
        assert!(!temporary(&exr).exists() && !temporary(&png).exists());
    }
    println!("{MERGE_TRIALS} merges killed, {cut} before the PNG was written");
    assert!(cut > 0, "no merge was killed while it ran");
}

/// The checkpoint render of the disk tests (`extra` flags), into `exr`.
fn checkpointed(exr: &Path, checkpoint: &Path, extra: &[&str]) -> Args {
    let mut args = Args::render(extra);
    args.path("-o", exr).path("--checkpoint", checkpoint);
    args
}

/// The uninterrupted render of `iterations`, into `exr` (for comparisons).
fn reference(exr: &Path, iterations: u64) -> Vec<u8> {
    let mut args = Args::render(&["--iterations", &iterations.to_string(), "--no-png"]);
    args.path("-o", exr);
    assert_success(&args.run());
    bytes(exr)
}

/// A full disk (`/dev/full`, where every write fails with ENOSPC, as the
/// temporary file): writing a checkpoint fails in one line and leaves the
/// previous one as it was; writing the image fails in one line that says
/// the checkpoint holds the render, which the next run turns into the
/// uninterrupted render's bytes.
#[cfg(target_os = "linux")]
#[test]
fn a_full_disk_keeps_the_previous_checkpoint_and_fails_in_one_line() {
    use std::os::unix::fs::symlink;

    let dir = tempfile::tempdir().unwrap();
    let (exr, checkpoint) = (dir.path().join("out.exr"), dir.path().join("c.rltfilm"));
    let args = |iterations: &str| {
        checkpointed(
            &exr,
            &checkpoint,
            &[
                "--iterations",
                iterations,
                "--no-png",
                "--checkpoint-every",
                "0",
            ],
        )
    };
    let mut first = args("5");
    first.push(&["--keep-checkpoint"]);
    assert_success(&first.run());
    let before = bytes(&checkpoint);
    fs::remove_file(&exr).unwrap();

    symlink("/dev/full", temporary(&checkpoint)).unwrap();
    let line = one_error_line(
        &args("10").run(),
        &[
            "cannot write checkpoint",
            "c.rltfilm",
            "No space left on device",
            "previous checkpoint is kept",
        ],
    );
    assert!(bytes(&checkpoint) == before, "{line}");
    assert!(!exr.exists() && fs::symlink_metadata(temporary(&checkpoint)).is_err());

    symlink("/dev/full", temporary(&exr)).unwrap();
    one_error_line(
        &args("10").run(),
        &[
            "cannot write",
            "out.exr",
            "No space left on device",
            "c.rltfilm holds iterations 1..=10",
        ],
    );
    assert!(!exr.exists());
    let err = assert_success(&args("10").run());
    assert!(err.contains("iterations 1..=10 of 10 done"), "{err}");
    assert!(bytes(&exr) == reference(&dir.path().join("ref.exr"), 10));
}

/// A tmpfs mounted for a test, unmounted on drop; `None` (with the reason)
/// where mounting is not allowed (not root, no `mount`, a container).
struct Tmpfs(PathBuf);

impl Tmpfs {
    fn mount(at: &Path, options: &str) -> Result<Self, String> {
        fs::create_dir_all(at).unwrap();
        let output = Command::new("mount")
            .args(["-t", "tmpfs", "-o", options, "rlt-test"])
            .arg(at)
            .output()
            .map_err(|e| format!("cannot run mount: {e}"))?;
        if !output.status.success() {
            return Err(format!(
                "mount -t tmpfs failed: {}",
                String::from_utf8_lossy(&output.stderr).trim()
            ));
        }
        Ok(Self(at.to_owned()))
    }
}

impl Drop for Tmpfs {
    fn drop(&mut self) {
        let _ = Command::new("umount").arg(&self.0).status();
    }
}

/// A real full file system (a 64 KiB tmpfs, filled): the same as with
/// `/dev/full`, for the checkpoint and for the image. Skipped, saying why,
/// where a tmpfs cannot be mounted.
#[cfg(target_os = "linux")]
#[test]
fn a_full_file_system_keeps_the_previous_checkpoint() {
    use std::io::Write as _;

    let dir = tempfile::tempdir().unwrap();
    let small = dir.path().join("small");
    let _mounted = match Tmpfs::mount(&small, "size=64k") {
        Ok(m) => m,
        Err(reason) => {
            println!("skipped: {reason}");
            return;
        }
    };
    let (exr, checkpoint) = (dir.path().join("out.exr"), small.join("c.rltfilm"));
    let args = |exr: &Path, iterations: &str| {
        checkpointed(
            exr,
            &checkpoint,
            &[
                "--iterations",
                iterations,
                "--no-png",
                "--checkpoint-every",
                "0",
            ],
        )
    };
    // Checkpoints only at the end.
    let rarely = |exr: &Path, iterations: &str| {
        checkpointed(exr, &checkpoint, &["--iterations", iterations, "--no-png"])
    };
    let mut first = args(&exr, "3");
    first.push(&["--keep-checkpoint"]);
    assert_success(&first.run());
    let before = bytes(&checkpoint);
    // Fill what is left.
    let filler = small.join("filler");
    let mut file = fs::File::create(&filler).unwrap();
    while file.write_all(&[0u8; 1024]).is_ok() {}
    drop(file);

    one_error_line(
        &args(&exr, "6").run(),
        &["cannot write checkpoint", "No space left on device"],
    );
    assert!(bytes(&checkpoint) == before);
    assert!(!temporary(&checkpoint).exists());

    // The image on the full file system, the checkpoint too: the previous
    // checkpoint still holds iterations 1..=3.
    let full_exr = small.join("out.exr");
    one_error_line(
        &rarely(&full_exr, "6").run(),
        &[
            "cannot write",
            "out.exr",
            "No space left on device",
            "holds iterations 1..=3",
        ],
    );
    assert!(bytes(&checkpoint) == before && !full_exr.exists());
    fs::remove_file(&filler).unwrap();
    let err = assert_success(&args(&exr, "6").run());
    assert!(err.contains("iterations 1..=3 of 6 done"), "{err}");
    assert!(bytes(&exr) == reference(&dir.path().join("ref.exr"), 6));
}

/// A read-only folder: a checkpoint there is refused before rendering; an
/// image there fails after rendering, in one line that says the checkpoint
/// (elsewhere) holds the render, and the same command, once the folder is
/// writable, writes the uninterrupted render's bytes without rendering
/// again. Root ignores permissions: it gets a read-only tmpfs instead, or
/// the test is skipped, saying why.
#[cfg(unix)]
#[test]
fn a_read_only_folder_fails_in_one_line_and_loses_no_work() {
    use std::os::unix::fs::PermissionsExt as _;

    let dir = tempfile::tempdir().unwrap();
    let read_only = dir.path().join("ro");
    fs::create_dir(&read_only).unwrap();
    fs::set_permissions(&read_only, fs::Permissions::from_mode(0o555)).unwrap();
    let mut mounted = None;
    if fs::write(read_only.join("probe"), b"").is_ok() {
        // Running as root: permissions are not checked.
        match Tmpfs::mount(&read_only, "ro,size=64k") {
            Ok(m) => mounted = Some(m),
            Err(reason) => {
                println!("skipped: root ignores permissions and {reason}");
                return;
            }
        }
    }
    let (exr, checkpoint) = (read_only.join("out.exr"), dir.path().join("c.rltfilm"));
    let flags = ["--iterations", "4", "--no-png"];
    one_error_line(
        &checkpointed(
            &dir.path().join("x.exr"),
            &read_only.join("c.rltfilm"),
            &flags,
        )
        .run(),
        &["checkpoint", "cannot lock", "ro/c.rltfilm.lock"],
    );
    let args = checkpointed(&exr, &checkpoint, &flags);
    one_error_line(
        &args.run(),
        &[
            "cannot write",
            "ro/out.exr",
            "c.rltfilm holds iterations 1..=4",
            "run the same command",
        ],
    );
    drop(mounted);
    fs::set_permissions(&read_only, fs::Permissions::from_mode(0o755)).unwrap();
    let err = assert_success(&args.run());
    assert!(err.contains("iterations 1..=4 of 4 done"), "{err}");
    assert!(err.contains("rendered 0 iterations"), "{err}");
    assert!(bytes(&exr) == reference(&dir.path().join("ref.exr"), 4));
    assert!(!checkpoint.exists());
}

/// Two renders given one checkpoint: the second is refused in one line
/// naming the first's process id; once the first is killed (SIGKILL), the
/// OS has released its lock and the next render resumes the checkpoint.
#[test]
fn a_second_render_of_one_checkpoint_is_refused_until_the_first_dies() {
    use std::io::{BufRead as _, BufReader};

    let dir = tempfile::tempdir().unwrap();
    let checkpoint = dir.path().join("c.rltfilm");
    let args = checkpointed(
        &dir.path().join("out.exr"),
        &checkpoint,
        &["--iterations", "100000000", "--checkpoint-every", "0.01"],
    );
    let mut first = args.spawn();
    let start = Instant::now();
    while !checkpoint.exists() {
        assert!(start.elapsed() < Duration::from_secs(60), "no checkpoint");
        std::thread::sleep(Duration::from_millis(5));
    }
    one_error_line(
        &run_within(&args, Duration::from_secs(60)),
        &[
            "c.rltfilm is in use by another render",
            &format!("(pid {};", first.id()),
        ],
    );
    first.kill().unwrap();
    first.wait().unwrap();
    let mut third = args.spawn();
    let line = BufReader::new(third.stderr.take().unwrap())
        .lines()
        .next()
        .unwrap()
        .unwrap();
    third.kill().unwrap();
    third.wait().unwrap();
    assert!(line.starts_with("resuming from"), "{line}");
}

/// A checkpoint of another render (size, setting, range) or a damaged one
/// is refused in one line naming the difference or the damage, and left
/// as it was; nothing is rendered or written.
#[test]
fn checkpoints_of_other_renders_and_damaged_ones_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let (exr, checkpoint) = (dir.path().join("out.exr"), dir.path().join("c.rltfilm"));
    let mut first = checkpointed(&exr, &checkpoint, &["--iterations", "4", "--no-png"]);
    first.push(&["--keep-checkpoint"]);
    assert_success(&first.run());
    fs::remove_file(&exr).unwrap();
    let kept = bytes(&checkpoint);
    let refused = |checkpoint: &Path, extra: &[&str], names: &[&str]| {
        let mut args = Args(vec![bundled("cornell-box").into()]);
        args.push(&["--integrator", "bpt", "--no-png"])
            .push(extra)
            .path("-o", &exr)
            .path("--checkpoint", checkpoint);
        let before = bytes(checkpoint);
        one_error_line(&args.run(), names);
        assert!(bytes(checkpoint) == before && !exr.exists());
    };
    let size = ["--resolution", "8x8"];
    refused(
        &checkpoint,
        &["--resolution", "4x4", "--iterations", "4"],
        &["c.rltfilm was made with resolution 8x8, this render asks 4x4"],
    );
    refused(
        &checkpoint,
        &[&size[..], &["--iterations", "4", "--seed", "7"]].concat(),
        &["was made with seed: 0, this render asks seed: 7"],
    );
    refused(
        &checkpoint,
        &[&size[..], &["--iterations", "4", "--max-depth", "3"]].concat(),
        &["this render asks max_depth: 3"],
    );
    refused(
        &checkpoint,
        &[&size[..], &["--iterations", "3"]].concat(),
        &["holds iterations 1..=4, more than this render's 1..=3"],
    );
    let partial = dir.path().join("p.rltfilm");
    let mut shard = Args(vec![bundled("cornell-box").into()]);
    shard
        .push(&["--integrator", "bpt", "--iteration-range", "2..9"])
        .push(&size)
        .path("--partial", &partial)
        .path("--checkpoint", &checkpoint);
    one_error_line(
        &shard.run(),
        &["holds iterations 1..=4, this render starts at iteration 2"],
    );
    assert!(!partial.exists() && bytes(&checkpoint) == kept);

    let damaged = |name: &str, edit: &dyn Fn(&mut Vec<u8>), what: &str| {
        let path = dir.path().join(name);
        let mut data = kept.clone();
        edit(&mut data);
        fs::write(&path, data).unwrap();
        refused(
            &path,
            &[&size[..], &["--iterations", "4"]].concat(),
            &[name, what, "remove it to start the render over"],
        );
    };
    damaged("cut.rltfilm", &|d| d.truncate(d.len() - 7), "truncated");
    damaged(
        "flipped.rltfilm",
        &|d| {
            let i = d.len() - 100;
            d[i] ^= 4
        },
        "checksum mismatch",
    );
    damaged("text.rltfilm", &|d| *d = b"not a film".to_vec(), "magic");
}

/// With `--time`, the checkpoint records the time rendered and the budget
/// counts it: run again with the same budget, the render is done and its
/// image is that of `--iterations N` for the N iterations rendered.
#[test]
fn a_time_budget_counts_the_checkpoints_time() {
    let dir = tempfile::tempdir().unwrap();
    let (exr, checkpoint) = (dir.path().join("out.exr"), dir.path().join("c.rltfilm"));
    let args = checkpointed(
        &exr,
        &checkpoint,
        &["--time", "0.2", "--no-png", "--keep-checkpoint"],
    );
    assert_success(&args.run());
    let header = film_file::read_header(&checkpoint).unwrap();
    assert!(header.render_millis.unwrap() >= 200, "{header:?}");
    let err = assert_success(&args.run());
    let n = header.last;
    assert!(err.contains(&format!("iterations 1..={n} in ")), "{err}");
    assert!(err.contains(" of 0.2 s done"), "{err}");
    assert!(err.contains("rendered 0 iterations"), "{err}");
    assert!(bytes(&exr) == reference(&dir.path().join("ref.exr"), n));
}

/// VmHWM (peak resident set) of a running process, in KiB.
#[cfg(target_os = "linux")]
fn peak_rss_kib(pid: u32) -> Option<u64> {
    let status = fs::read_to_string(format!("/proc/{pid}/status")).ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))?
        .trim()
        .trim_end_matches("kB")
        .trim()
        .parse()
        .ok()
}

/// Iterations of the soak: 10^5 at 4x4 pixels with a checkpoint every
/// millisecond take 6-9 s on tmpfs (two cores, under load), 25 s on this
/// machine's disk.
const SOAK_ITERATIONS: u64 = 100_000;
/// How much the peak resident set may grow from iteration 10 to the end:
/// allocator noise; a leak of 11 bytes per iteration, or of 200 per
/// checkpoint, is more.
const SOAK_RSS_SLACK_KIB: u64 = 1024;

/// Many iterations at 4x4 pixels with a checkpoint every millisecond (on
/// tmpfs where there is one: the test is of memory, not of the disk): the
/// peak resident set after the last iteration is that after the tenth, and
/// the film's sums are finite.
#[cfg(target_os = "linux")]
#[test]
fn a_long_render_with_millisecond_checkpoints_keeps_its_memory_and_finite_sums() {
    let dir = memory_temp_dir();
    let checkpoint = dir.path().join("c.rltfilm");
    let mut args = Args(vec![bundled("cornell-box").into()]);
    args.push(&[
        "--resolution",
        "4x4",
        "--iterations",
        &SOAK_ITERATIONS.to_string(),
    ])
    .push(&[
        "--no-png",
        "--checkpoint-every",
        "0.001",
        "--keep-checkpoint",
    ])
    .path("-o", &dir.path().join("out.exr"))
    .path("--checkpoint", &checkpoint);
    let start = Instant::now();
    let mut child = args.spawn();
    let (mut early, mut last) = (None, None);
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        let rss = peak_rss_kib(child.id());
        let done = film_file::read_header(&checkpoint).map_or(0, |h| h.last);
        if early.is_none() && done >= 10 {
            early = rss;
        }
        last = rss.or(last);
        std::thread::sleep(Duration::from_millis(10));
    };
    let output = child.wait_with_output().unwrap();
    assert!(status.success(), "{}", stderr(&output));
    let (early, last) = (early.expect("a reading at iteration 10"), last.unwrap());
    println!(
        "{SOAK_ITERATIONS} iterations in {:.1} s: peak RSS {early} KiB at iteration 10, {last} KiB at the end",
        start.elapsed().as_secs_f64()
    );
    assert!(
        last <= early + SOAK_RSS_SLACK_KIB,
        "{early} KiB -> {last} KiB"
    );
    let film = film_file::read(&checkpoint).unwrap();
    assert_eq!(film.iterations, SOAK_ITERATIONS);
    assert!(film.sum.iter().chain(&film.sum_sq).all(|v| v.is_finite()));
    assert!(
        film.sum.iter().any(|v| v.element_sum() > 0.0),
        "a black film"
    );
}
