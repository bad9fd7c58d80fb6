//! `cargo xtask mitsuba`: our path tracer against Mitsuba 3's `scalar_rgb`
//! path tracer on the same scene, at the same samples per pixel, by wall
//! time and by error against one reference.
//!
//! What it does, in order:
//! 1. loads the scene with `scene::load` and exports it to a Mitsuba 3 scene
//!    (`<out>/mitsuba-scene/scene.xml`, one binary PLY per material, written
//!    from our world-space triangles; see [`export`] for the mapping);
//! 2. finds Mitsuba (`<out>/venv`, else the system `python3`), or installs it
//!    into `<out>/venv` with `python3 -m venv` and `pip install mitsuba`;
//! 3. renders a reference with our renderer at `--reference-spp` (cached in
//!    `<out>/cache/`, keyed by the settings and the scene's files: delete
//!    that folder after changing the renderer);
//! 4. renders with both renderers at `--spp` (with all cores, and with one
//!    core unless `--no-single-thread`) and at `--check-spp` (all cores),
//!    timing the render call only;
//! 5. compares every image with the reference (RMSE, relMSE, efficiency
//!    1/(time MSE), time-to-equal-error ratio against Mitsuba) and checks
//!    that the two renderers estimate the same image (image means, and
//!    noise-normalised block means), then writes `<out>/report.md` and
//!    `<out>/report.json`.
//!
//! Timings are only meaningful in a release build: when this binary is a
//! debug build (as `cargo xtask` builds it), it runs itself again through
//! `cargo run --release -p xtask -- mitsuba ...` and passes the arguments on.
//!
//! No light transport happens here: our images come from the `integrators`
//! library, Mitsuba's from `xtask/scripts/mitsuba_pt.py`.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::fs;
use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Command, ExitStatus, Stdio};
use std::time::{Duration, Instant};

use glam::{UVec2, Vec3};
use image_io::{read_exr, write_exr};
use integrators::{Regularization, RenderConfig, Renderer};
use scene::{Light, LoadOptions, Scene, Surface};
use serde_json::{Value, json};

pub const USAGE: &str =
    "  mitsuba [options] compare our path tracer with Mitsuba 3 (scalar_rgb `path`)
                    on one scene: export, render both, error against a
                    reference of ours; writes <out>/report.md and report.json.
                    Runs itself in release (timings need it).
      --scene PATH          scene (default scenes/cornell-box/scene.toml)
      --spp N               samples per pixel of the timed renders (default 64)
      --resolution WxH      image size (default 512x512)
      --max-depth D         longest path in segments, both renderers (default 16)
      --reference-spp M     spp of our reference (default 1024; >= 16x --spp
                            keeps its own error small). Cached in <out>/cache
                            by settings: delete it after renderer changes
      --check-spp K         spp of a second pair of renders (all cores, one
                            repeat) for the convergence rate and the floor fit
                            (default spp/4; 0 skips them)
      --repeat R            time each all-core --spp render R times and report
                            the fastest (default 2; the machine may be shared)
      --no-single-thread    skip the one-thread renders
      --out DIR             output folder (default target/mitsuba)
                            (relative paths are from the workspace root)";

/// Sampler seeds: every image uses its own random numbers, so that no test
/// image shares samples with the reference.
const SEED_TEST: u64 = 1;
const SEED_CHECK: u64 = 2;
const SEED_REFERENCE: u64 = 0x5EED_0000_0000_0001;

/// Constant in the denominator of the relative MSE (per channel).
const REL_MSE_EPSILON: f64 = 1e-2;

/// Above this relative difference of the image means the two renderers do
/// not render the same scene (the export is suspect, not the comparison).
const MEAN_TOLERANCE: f64 = 0.03;

/// Blocks per image side of the block-mean agreement test.
const BLOCKS: u32 = 16;

/// Largest |z| of an image mean (per channel) before the report calls it a
/// disagreement beyond noise.
const Z_ALARM: f64 = 5.0;

/// Largest root mean square of the block z-scores (1 for pure noise) before
/// the report calls it a disagreement. Single blocks are not judged: with
/// few samples per block the z-score is skewed (rare bright paths).
const BLOCK_RMS_ALARM: f64 = 1.5;

/// Set on the release child so that a release profile with debug
/// assertions cannot loop.
const CHILD_ENV: &str = "RLT_XTASK_MITSUBA_CHILD";

#[derive(Clone, Debug)]
struct Options {
    scene: PathBuf,
    spp: u32,
    width: u32,
    height: u32,
    max_depth: u32,
    reference_spp: u32,
    check_spp: u32,
    repeat: u32,
    single_thread: bool,
    out: PathBuf,
}

impl Options {
    fn parse(root: &Path, args: &[String]) -> Result<Self, String> {
        let mut o = Self {
            scene: root.join("scenes/cornell-box/scene.toml"),
            spp: 64,
            width: 512,
            height: 512,
            max_depth: 16,
            reference_spp: 1024,
            check_spp: u32::MAX,
            repeat: 2,
            single_thread: true,
            out: root.join("target/mitsuba"),
        };
        let mut it = args.iter();
        while let Some(flag) = it.next() {
            if flag == "--no-single-thread" {
                o.single_thread = false;
                continue;
            }
            let value = it
                .next()
                .ok_or_else(|| format!("{flag} needs a value\n\n{USAGE}"))?;
            let number = |what: &str| -> Result<u32, String> {
                value
                    .parse::<u32>()
                    .map_err(|_| format!("{what}: expected a whole number, got `{value}`"))
            };
            match flag.as_str() {
                "--scene" => o.scene = root.join(value),
                "--spp" => o.spp = number("--spp")?,
                "--max-depth" => o.max_depth = number("--max-depth")?,
                "--reference-spp" => o.reference_spp = number("--reference-spp")?,
                "--check-spp" => o.check_spp = number("--check-spp")?,
                "--repeat" => o.repeat = number("--repeat")?.max(1),
                "--out" => o.out = root.join(value),
                "--resolution" => {
                    let parsed = value
                        .split_once(['x', 'X'])
                        .and_then(|(w, h)| Some((w.parse().ok()?, h.parse().ok()?)));
                    (o.width, o.height) = parsed.ok_or_else(|| {
                        format!("--resolution: expected WxH (e.g. 512x512), got `{value}`")
                    })?;
                }
                other => return Err(format!("unknown option `{other}`\n\nusage:\n{USAGE}")),
            }
        }
        if o.spp == 0 || o.reference_spp == 0 || o.width == 0 || o.height == 0 {
            return Err("--spp, --reference-spp and the resolution must be positive".into());
        }
        if o.check_spp == u32::MAX {
            o.check_spp = o.spp / 4;
        }
        if o.check_spp == o.spp {
            o.check_spp = 0;
        }
        if o.reference_spp < 16 * o.spp {
            println!(
                "warning: --reference-spp {} is below 16x --spp {}: the reference's own error is not negligible (the report removes an estimate of it)",
                o.reference_spp, o.spp
            );
        }
        if o.max_depth == 0 {
            return Err("--max-depth must be at least 1 (1: emitters seen directly)".into());
        }
        Ok(o)
    }

    fn pixels(&self) -> usize {
        self.width as usize * self.height as usize
    }
}

pub fn run(root: &Path, args: &[String]) -> Result<(), String> {
    let options = Options::parse(root, args)?;
    if cfg!(debug_assertions) && std::env::var_os(CHILD_ENV).is_none() {
        return rerun_in_release(root, args);
    }
    let started = Instant::now();
    let load_before = load_average();
    fs::create_dir_all(&options.out)
        .map_err(|e| format!("cannot create {}: {e}", options.out.display()))?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    if cfg!(debug_assertions) {
        println!("warning: this is a debug build; timings are not release numbers");
    }

    // 1. The scene, ours and exported.
    let t = Instant::now();
    let scene = scene::load(
        &options.scene,
        &LoadOptions {
            camera_name: None,
            resolution: Some(UVec2::new(options.width, options.height)),
        },
    )
    .map_err(|e| format!("cannot load the scene: {e}"))?;
    let scene_load_s = t.elapsed().as_secs_f64();
    let scene_dir = options.out.join("mitsuba-scene");
    let exported = export(&scene, &options, &scene_dir)?;
    println!(
        "scene: {} ({} triangles, loaded in {scene_load_s:.3} s); Mitsuba export: {} ({})",
        options.scene.display(),
        scene.triangles.len(),
        exported.xml.display(),
        exported.summary
    );

    // 2. Mitsuba.
    let mitsuba = ensure_mitsuba(&options.out)?;
    println!("mitsuba: {} ({})", mitsuba.version, mitsuba.how);

    // 3. The reference.
    let reference = reference(&scene, &options)?;

    // 4. The renders.
    let mut runs: Vec<Run> = Vec::new();
    let mut thread_counts = vec![cores];
    if options.single_thread && cores > 1 {
        thread_counts.push(1);
    }
    let mut jobs: Vec<(u32, u64)> = vec![(options.spp, SEED_TEST)];
    if options.check_spp > 0 {
        jobs.push((options.check_spp, SEED_CHECK));
    }
    for &(spp, seed) in &jobs {
        let threads_here: &[usize] = if spp == options.spp {
            &thread_counts
        } else {
            &thread_counts[..1]
        };
        for &threads in threads_here {
            // Repeats only where the table's ratio is read: all cores, --spp.
            // Alternating, so that other work on the machine hits both alike.
            let repeat = if spp == options.spp && threads == cores {
                options.repeat
            } else {
                1
            };
            let job = Job { spp, seed, threads };
            let (mut ours, mut theirs) = (None, None);
            for _ in 0..repeat {
                merge(&mut ours, render_ours(&scene, &options, job)?);
                merge(
                    &mut theirs,
                    render_mitsuba(root, &mitsuba, &exported, &options, job)?,
                );
            }
            runs.extend(ours);
            runs.extend(theirs);
        }
    }

    // 5. Errors, agreement, report.
    let context = (&options, cores, &mitsuba, scene_load_s, load_before);
    Report::new(context, &reference, &runs).write(&options.out, started.elapsed().as_secs_f64())
}

/// Runs this task again from a release build of xtask.
fn rerun_in_release(root: &Path, args: &[String]) -> Result<(), String> {
    let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
    let mut cargo_args = vec![
        "run",
        "--release",
        "--quiet",
        "-p",
        "xtask",
        "--",
        "mitsuba",
    ];
    cargo_args.extend(args.iter().map(String::as_str));
    println!(
        "timings need a release build: running `cargo {}`",
        cargo_args.join(" ")
    );
    let status = Command::new(&cargo)
        .args(&cargo_args)
        .env(CHILD_ENV, "1")
        .current_dir(root)
        .status()
        .map_err(|e| format!("could not run {cargo}: {e}"))?;
    if status.success() {
        Ok(())
    } else {
        // The child printed its own one-line error.
        Err(format!("the release run failed ({status})"))
    }
}

// ---------------------------------------------------------------------------
// Export

/// The exported Mitsuba scene.
struct Exported {
    xml: PathBuf,
    summary: String,
}

/// Writes `scene` as a Mitsuba 3 scene into `dir`.
///
/// Mapping (checked against Mitsuba 3's `path`, `diffuse`, `twosided`,
/// `area` and `perspective` plugins):
/// - triangles: one binary PLY per material, world space, three vertices per
///   triangle in our order, so Mitsuba's face normal cross(p1-p0, p2-p0) is
///   our winding normal. Face normals (`face_normals=true`) unless the scene
///   has shading normals that differ from them; then they are written per
///   vertex.
/// - `Surface::Diffuse { reflectance }`: `twosided(diffuse(rgb reflectance))`.
///   Our lobes are two-sided, Mitsuba's `diffuse` is black from the back;
///   `twosided` makes it reflect on both sides as ours does.
/// - emission: an `area` emitter with the same RGB radiance. Both emit on the
///   side of the (winding) normal only.
/// - camera: `perspective`, `lookat` origin/target/up, the vertical field of
///   view with `fov_axis="y"`, `box` reconstruction filter, `independent`
///   sampler with `--spp`.
/// - integrator: `path` with `max_depth` = ours (both count segments: 1 shows
///   emitters only) and `rr_depth` = 3 (both roll the dice after sampling the
///   direction at the third vertex). Differences left: Mitsuba's roulette
///   survival is capped at 0.95 (ours at 1) and its light choice is uniform
///   over emitting shapes; both are unbiased, so only the noise differs.
fn export(scene: &Scene, options: &Options, dir: &Path) -> Result<Exported, String> {
    if let Some(light) = scene
        .lights
        .iter()
        .find(|l| !matches!(l, Light::Area { .. }))
    {
        return Err(format!(
            "the Mitsuba export handles emissive triangles only; the scene has {light:?}"
        ));
    }
    let mesh_dir = dir.join("meshes");
    fs::create_dir_all(&mesh_dir)
        .map_err(|e| format!("cannot create {}: {e}", mesh_dir.display()))?;
    let mut by_material: BTreeMap<u32, Vec<usize>> = BTreeMap::new();
    for (i, &m) in scene.triangle_materials.iter().enumerate() {
        by_material.entry(m).or_default().push(i);
    }
    let mut shapes = String::new();
    let (mut emitters, mut smooth_meshes) = (0, 0);
    for (&m, triangles) in &by_material {
        let material = &scene.materials[m as usize];
        let Surface::Diffuse { reflectance } = material.surface else {
            return Err(format!(
                "the Mitsuba export handles diffuse materials only; `{}` is {:?}",
                material.name, material.surface
            ));
        };
        let file = format!("meshes/{m:03}-{}.ply", sanitize(&material.name));
        let smooth = triangles.iter().any(|&t| {
            let n = scene.geometric_normal(t);
            scene.normals[t].iter().any(|s| s.dot(n) < 1.0 - 1e-5)
        });
        smooth_meshes += usize::from(smooth);
        let ply = ply(scene, triangles, smooth);
        let path = dir.join(&file);
        fs::write(&path, &ply).map_err(|e| format!("cannot write {}: {e}", path.display()))?;
        let _ = writeln!(
            shapes,
            r#"    <shape type="ply" id="{id}">
        <string name="filename" value="{file}"/>
        <boolean name="face_normals" value="{face}"/>
        <bsdf type="twosided">
            <bsdf type="diffuse">
                <rgb name="reflectance" value="{r}"/>
            </bsdf>
        </bsdf>"#,
            id = sanitize(&material.name),
            face = !smooth,
            r = rgb(reflectance),
        );
        if material.is_emissive() {
            emitters += 1;
            let _ = writeln!(
                shapes,
                r#"        <emitter type="area">
            <rgb name="radiance" value="{}"/>
        </emitter>"#,
                rgb(material.emission)
            );
        }
        shapes.push_str("    </shape>\n");
    }
    let c = &scene.camera;
    let target = c.position + c.forward;
    let xml = format!(
        r#"<?xml version="1.0" encoding="utf-8"?>
<!-- Written by `cargo xtask mitsuba` from {source}; mapping in xtask/src/mitsuba.rs. -->
<scene version="3.0.0">
    <integrator type="path">
        <integer name="max_depth" value="{max_depth}"/>
        <integer name="rr_depth" value="3"/>
    </integrator>
    <sensor type="perspective">
        <string name="fov_axis" value="y"/>
        <float name="fov" value="{fov:?}"/>
        <float name="near_clip" value="0.001"/>
        <float name="far_clip" value="100000"/>
        <transform name="to_world">
            <lookat origin="{origin}" target="{target}" up="{up}"/>
        </transform>
        <sampler type="independent">
            <integer name="sample_count" value="{spp}"/>
        </sampler>
        <film type="hdrfilm">
            <integer name="width" value="{width}"/>
            <integer name="height" value="{height}"/>
            <string name="pixel_format" value="rgb"/>
            <string name="component_format" value="float32"/>
            <rfilter type="box"/>
        </film>
    </sensor>
{shapes}</scene>
"#,
        source = options.scene.display(),
        max_depth = options.max_depth,
        fov = f64::from(c.vertical_fov).to_degrees(),
        origin = rgb(c.position),
        target = rgb(target),
        up = rgb(c.up),
        spp = options.spp,
        width = c.resolution.x,
        height = c.resolution.y,
    );
    let xml_path = dir.join("scene.xml");
    fs::write(&xml_path, &xml).map_err(|e| format!("cannot write {}: {e}", xml_path.display()))?;
    Ok(Exported {
        xml: xml_path,
        summary: format!(
            "{} meshes, {emitters} emitting, {}",
            by_material.len(),
            if smooth_meshes == 0 {
                "face normals".to_string()
            } else {
                format!("{smooth_meshes} with shading normals")
            }
        ),
    })
}

/// A binary little-endian PLY of `triangles` (three vertices each).
fn ply(scene: &Scene, triangles: &[usize], normals: bool) -> Vec<u8> {
    let mut header = format!(
        "ply\nformat binary_little_endian 1.0\nelement vertex {}\nproperty float x\nproperty float y\nproperty float z\n",
        3 * triangles.len()
    );
    if normals {
        header.push_str("property float nx\nproperty float ny\nproperty float nz\n");
    }
    let _ = write!(
        header,
        "element face {}\nproperty list uchar int vertex_indices\nend_header\n",
        triangles.len()
    );
    let mut bytes = header.into_bytes();
    for &t in triangles {
        for k in 0..3 {
            let mut values = scene.triangles[t][k].to_array().to_vec();
            if normals {
                values.extend(scene.normals[t][k].to_array());
            }
            for v in values {
                bytes.extend(v.to_le_bytes());
            }
        }
    }
    for i in 0..triangles.len() as i32 {
        bytes.push(3);
        for k in 0..3 {
            bytes.extend((3 * i + k).to_le_bytes());
        }
    }
    bytes
}

fn rgb(v: Vec3) -> String {
    format!("{:?}, {:?}, {:?}", v.x, v.y, v.z)
}

fn sanitize(name: &str) -> String {
    let s: String = name
        .chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect();
    if s.is_empty() { "material".into() } else { s }
}

// ---------------------------------------------------------------------------
// Mitsuba installation and renders

struct Mitsuba {
    python: PathBuf,
    version: String,
    how: String,
}

/// Mitsuba from `<out>/venv`, else the system `python3`, else installed
/// into `<out>/venv`.
fn ensure_mitsuba(out: &Path) -> Result<Mitsuba, String> {
    let venv = out.join("venv");
    let venv_python = venv.join("bin").join("python");
    if let Some(version) = mitsuba_version(&venv_python) {
        return Ok(Mitsuba {
            python: venv_python,
            version,
            how: format!("already installed in {}", venv.display()),
        });
    }
    if let Some(version) = mitsuba_version(Path::new("python3")) {
        return Ok(Mitsuba {
            python: PathBuf::from("python3"),
            version,
            how: "from the system python3".into(),
        });
    }
    println!(
        "mitsuba: not found; installing it into {} (python3 -m venv, pip install mitsuba)",
        venv.display()
    );
    let fail = |what: &str| format!("mitsuba could not be installed: {what}");
    run_quiet(Command::new("python3").arg("-m").arg("venv").arg(&venv))
        .map_err(|e| fail(&format!("python3 -m venv: {e}")))?;
    run_quiet(Command::new(&venv_python).args([
        "-m",
        "pip",
        "install",
        "--quiet",
        "--disable-pip-version-check",
        "mitsuba",
    ]))
    .map_err(|e| fail(&format!("pip install mitsuba: {e}")))?;
    let version = mitsuba_version(&venv_python)
        .ok_or_else(|| fail("pip succeeded but `import mitsuba` still fails"))?;
    Ok(Mitsuba {
        python: venv_python,
        version,
        how: format!("installed now into {} with pip", venv.display()),
    })
}

/// `mitsuba.__version__` if `python` can import Mitsuba and its scalar_rgb variant.
fn mitsuba_version(python: &Path) -> Option<String> {
    let output = Command::new(python)
        .args([
            "-c",
            "import mitsuba as mi; mi.set_variant('scalar_rgb'); print(mi.__version__)",
        ])
        .output()
        .ok()?;
    let version = String::from_utf8_lossy(&output.stdout).trim().to_string();
    (output.status.success() && !version.is_empty()).then_some(version)
}

/// Runs `command`, capturing its output; an error is its last stderr line.
fn run_quiet(command: &mut Command) -> Result<String, String> {
    let output = command.output().map_err(|e| e.to_string())?;
    finished(output.status, &output.stdout, &output.stderr)
}

fn finished(status: ExitStatus, stdout: &[u8], stderr: &[u8]) -> Result<String, String> {
    if status.success() {
        return Ok(String::from_utf8_lossy(stdout).into_owned());
    }
    let stderr = String::from_utf8_lossy(stderr);
    Err(stderr
        .lines()
        .rev()
        .find(|l| !l.trim().is_empty())
        .map_or_else(|| format!("{status}, no message"), |l| l.trim().to_string()))
}

/// [`run_quiet`] with a watchdog: the child is killed after `timeout`.
fn run_with_timeout(command: &mut Command, timeout: Duration) -> Result<String, String> {
    let mut child = command
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| e.to_string())?;
    let drain = |pipe: Option<Box<dyn Read + Send>>| {
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            if let Some(mut p) = pipe {
                let _ = p.read_to_end(&mut bytes);
            }
            bytes
        })
    };
    let out = drain(
        child
            .stdout
            .take()
            .map(|p| Box::new(p) as Box<dyn Read + Send>),
    );
    let err = drain(
        child
            .stderr
            .take()
            .map(|p| Box::new(p) as Box<dyn Read + Send>),
    );
    let started = Instant::now();
    let status = loop {
        match child.try_wait().map_err(|e| e.to_string())? {
            Some(status) => break status,
            None if started.elapsed() > timeout => {
                let _ = child.kill();
                let _ = child.wait();
                return Err(format!(
                    "no result after {} s: killed (a hang? see xtask/scripts/mitsuba_pt.py)",
                    timeout.as_secs()
                ));
            }
            None => std::thread::sleep(Duration::from_millis(50)),
        }
    };
    let stdout = out.join().unwrap_or_default();
    let stderr = err.join().unwrap_or_default();
    finished(status, &stdout, &stderr)
}

/// What to render: spp, seed, threads.
#[derive(Clone, Copy, Debug)]
struct Job {
    spp: u32,
    seed: u64,
    threads: usize,
}

/// Adds `run`'s time to `acc` (a repeat of the same render), or starts it.
fn merge(acc: &mut Option<Run>, run: Run) {
    match acc {
        None => *acc = Some(run),
        Some(a) => {
            a.render_times.extend(run.render_times);
            a.render_s = fastest(&a.render_times);
        }
    }
}

/// One timed render and its image.
struct Run {
    renderer: &'static str,
    threads: usize,
    spp: u32,
    /// Acceleration-structure build (ours) or scene load (Mitsuba), seconds.
    setup_s: f64,
    /// The fastest of `render_times`.
    render_s: f64,
    /// Every repeat's render time (the image is the same each time).
    render_times: Vec<f64>,
    image: Vec<Vec3>,
    path: PathBuf,
    note: String,
}

const OURS: &str = "ours (pt)";
const MITSUBA: &str = "mitsuba 3 (path, scalar_rgb)";

fn config(options: &Options, seed: u64) -> RenderConfig {
    RenderConfig {
        max_depth: options.max_depth,
        seed,
        regularization: Regularization::off(),
        ..Default::default()
    }
}

/// Renders `spp` iterations of one sample per pixel with our path tracer on
/// `threads` threads; returns the film's mean and variance of the mean.
/// Returns the film, the BVH build time, the render time and the number of
/// dropped NaN/inf samples.
fn render_film(
    scene: &Scene,
    options: &Options,
    job: Job,
) -> Result<(integrators::Film, f64, Vec<f64>, u64), String> {
    let threads = job.threads;
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .map_err(|e| format!("cannot start {threads} render threads: {e}"))?;
    Ok(pool.install(|| {
        let t = Instant::now();
        let renderer = Renderer::new(scene.clone(), config(options, job.seed));
        let setup_s = t.elapsed().as_secs_f64();
        let mut film = renderer.new_film();
        let t = Instant::now();
        renderer.render(&mut film, 1, u64::from(job.spp));
        let times = vec![t.elapsed().as_secs_f64()];
        (film, setup_s, times, renderer.invalid_samples())
    }))
}

fn fastest(times: &[f64]) -> f64 {
    times.iter().copied().fold(f64::INFINITY, f64::min)
}

fn seconds(times: &[f64]) -> String {
    let list: Vec<String> = times.iter().map(|t| format!("{t:.3}")).collect();
    list.join(", ")
}

fn render_ours(scene: &Scene, options: &Options, job: Job) -> Result<Run, String> {
    let Job { spp, threads, .. } = job;
    let (film, setup_s, render_times, invalid) = render_film(scene, options, job)?;
    let render_s = fastest(&render_times);
    let image = film.mean();
    let path = options.out.join(format!("ours-{spp}spp-{threads}t.exr"));
    write_exr(&path, options.width, options.height, &image).map_err(|e| e.to_string())?;
    println!(
        "ours:    {spp:>5} spp, {threads} thread(s): render {} s (BVH {setup_s:.4} s) -> {}",
        seconds(&render_times),
        path.display()
    );
    Ok(Run {
        renderer: OURS,
        threads,
        spp,
        setup_s,
        render_s,
        render_times,
        image,
        path,
        note: if invalid > 0 {
            format!("{invalid} NaN/inf samples dropped")
        } else {
            String::new()
        },
    })
}

fn render_mitsuba(
    root: &Path,
    mitsuba: &Mitsuba,
    exported: &Exported,
    options: &Options,
    job: Job,
) -> Result<Run, String> {
    let Job { spp, seed, threads } = job;
    let script = root.join("xtask/scripts/mitsuba_pt.py");
    let path = options.out.join(format!("mitsuba-{spp}spp-{threads}t.exr"));
    // Generous: 300 s plus 10 us per sample (Mitsuba does ~1e6 samples/s per core here).
    let samples = options.pixels() as f64 * f64::from(spp);
    let timeout = Duration::from_secs_f64(300.0 + 1e-5 * samples);
    let stdout = run_with_timeout(
        Command::new(&mitsuba.python)
            .arg(&script)
            .arg("--scene")
            .arg(&exported.xml)
            .arg("--out")
            .arg(&path)
            .args(["--spp", &spp.to_string()])
            .args(["--seed", &seed.to_string()])
            .args(["--threads", &threads.to_string()]),
        timeout,
    )
    .map_err(|e| format!("mitsuba render failed: {e}"))?;
    let info: Value = stdout
        .lines()
        .rev()
        .find(|l| l.starts_with('{'))
        .and_then(|l| serde_json::from_str(l).ok())
        .ok_or_else(|| "mitsuba render printed no JSON result".to_string())?;
    let img = read_exr(&path).map_err(|e| format!("mitsuba image: {e}"))?;
    if img.pixels.len() != options.pixels() {
        return Err(format!(
            "mitsuba image is {}x{}, expected {}x{}",
            img.width, img.height, options.width, options.height
        ));
    }
    if info["threads"].as_u64() != Some(threads as u64) {
        return Err(format!(
            "mitsuba ran with {} threads, asked for {threads}",
            info["threads"]
        ));
    }
    println!(
        "mitsuba: {spp:>5} spp, {threads} thread(s): render {} s (load {:.3} s) -> {}",
        seconds(&times_of(&info)),
        info["load_s"].as_f64().unwrap_or(f64::NAN),
        path.display()
    );
    let render_times = times_of(&info);
    Ok(Run {
        renderer: MITSUBA,
        threads,
        spp,
        setup_s: info["load_s"].as_f64().unwrap_or(f64::NAN),
        render_s: fastest(&render_times),
        render_times,
        image: img.pixels,
        path,
        note: String::new(),
    })
}

fn times_of(info: &Value) -> Vec<f64> {
    info["render_s"]
        .as_array()
        .map(|a| a.iter().filter_map(Value::as_f64).collect())
        .unwrap_or_default()
}

// ---------------------------------------------------------------------------
// Reference

struct Reference {
    spp: u32,
    mean: Vec<Vec3>,
    /// Per pixel and channel: sample variance of the iterations over their
    /// number, the squared standard error of the mean (an upper bound of the
    /// reference's own squared error: our sampler is Owen-scrambled Sobol).
    variance_of_mean: Vec<Vec3>,
    path: PathBuf,
    render_s: f64,
    cached: bool,
}

/// Our reference image, from the cache or rendered now on all cores.
fn reference(scene: &Scene, options: &Options) -> Result<Reference, String> {
    let mut key = Fnv::new();
    key.write(
        format!(
            "reference v1|{}x{}|depth {}|spp {}|seed {SEED_REFERENCE}",
            options.width, options.height, options.max_depth, options.reference_spp
        )
        .as_bytes(),
    );
    // The settings and the scene's files; not the renderer's sources (they
    // change all the time): after a change to the renderer, delete
    // <out>/cache. A stale reference shows as our own image disagreeing
    // with it in the report's agreement table.
    let mut files = Vec::new();
    if let Some(dir) = options.scene.parent() {
        collect_files(dir, &mut files);
    }
    files.sort();
    for f in &files {
        key.write(f.to_string_lossy().as_bytes());
        key.write(&fs::read(f).unwrap_or_default());
    }
    let stem = format!("reference-{:016x}", key.finish());
    let cache = options.out.join("cache");
    let mean_path = cache.join(format!("{stem}.exr"));
    let var_path = cache.join(format!("{stem}-variance-of-mean.exr"));
    let info_path = cache.join(format!("{stem}.json"));
    if let (Ok(mean), Ok(var), Ok(info)) = (
        read_exr(&mean_path),
        read_exr(&var_path),
        fs::read_to_string(&info_path),
    ) && mean.pixels.len() == options.pixels()
        && var.pixels.len() == options.pixels()
    {
        let render_s = serde_json::from_str::<Value>(&info)
            .ok()
            .and_then(|v| v["render_s"].as_f64())
            .unwrap_or(f64::NAN);
        println!(
            "reference: ours at {} spp, cached ({}; rendered in {render_s:.1} s)",
            options.reference_spp,
            mean_path.display()
        );
        return Ok(Reference {
            spp: options.reference_spp,
            mean: mean.pixels,
            variance_of_mean: var.pixels,
            path: mean_path,
            render_s,
            cached: true,
        });
    }
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    println!(
        "reference: rendering ours at {} spp on {cores} thread(s) ...",
        options.reference_spp
    );
    let job = Job {
        spp: options.reference_spp,
        seed: SEED_REFERENCE,
        threads: cores,
    };
    let (film, _, times, invalid) = render_film(scene, options, job)?;
    let render_s = fastest(&times);
    if invalid > 0 {
        println!("reference: warning: {invalid} NaN/inf samples dropped");
    }
    let mean = film.mean();
    let variance_of_mean: Vec<Vec3> = film
        .standard_error()
        .into_iter()
        .map(|s| (s * s).as_vec3())
        .collect();
    fs::create_dir_all(&cache).map_err(|e| format!("cannot create {}: {e}", cache.display()))?;
    let (w, h) = (options.width, options.height);
    write_exr(&mean_path, w, h, &mean).map_err(|e| e.to_string())?;
    write_exr(&var_path, w, h, &variance_of_mean).map_err(|e| e.to_string())?;
    let info = json!({ "spp": options.reference_spp, "render_s": render_s, "threads": cores });
    fs::write(&info_path, info.to_string())
        .map_err(|e| format!("cannot write {}: {e}", info_path.display()))?;
    println!(
        "reference: rendered in {render_s:.1} s -> {}",
        mean_path.display()
    );
    Ok(Reference {
        spp: options.reference_spp,
        mean,
        variance_of_mean,
        path: mean_path,
        render_s,
        cached: false,
    })
}

fn collect_files(dir: &Path, out: &mut Vec<PathBuf>) {
    let Ok(entries) = fs::read_dir(dir) else {
        return;
    };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            collect_files(&path, out);
        } else {
            out.push(path);
        }
    }
}

/// FNV-1a, 64 bit: a stable hash for cache keys.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Self(0xcbf2_9ce4_8422_2325)
    }
    fn write(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 = (self.0 ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
        // Separates consecutive writes ("ab","c" vs "a","bc").
        self.0 = (self.0 ^ 0xff).wrapping_mul(0x0100_0000_01b3);
    }
    fn finish(&self) -> u64 {
        self.0
    }
}

// ---------------------------------------------------------------------------
// Metrics and the report

/// Errors of an image against the reference, over pixels and channels.
#[derive(Clone, Copy, Debug)]
struct Errors {
    mse: f64,
    rel_mse: f64,
}

fn errors(image: &[Vec3], reference: &[Vec3]) -> Errors {
    let (mut se, mut rel) = (0.0, 0.0);
    for (x, r) in image.iter().zip(reference) {
        for c in 0..3 {
            let (x, r) = (f64::from(x[c]), f64::from(r[c]));
            let d2 = (x - r) * (x - r);
            se += d2;
            rel += d2 / (r * r + REL_MSE_EPSILON);
        }
    }
    let n = 3.0 * image.len() as f64;
    Errors {
        mse: se / n,
        rel_mse: rel / n,
    }
}

/// The reference's own expected contribution to both error measures.
fn reference_floor(reference: &Reference) -> Errors {
    let (mut se, mut rel) = (0.0, 0.0);
    for (v, r) in reference.variance_of_mean.iter().zip(&reference.mean) {
        for c in 0..3 {
            let (v, r) = (f64::from(v[c]), f64::from(r[c]));
            se += v;
            rel += v / (r * r + REL_MSE_EPSILON);
        }
    }
    let n = 3.0 * reference.mean.len() as f64;
    Errors {
        mse: se / n,
        rel_mse: rel / n,
    }
}

fn channel_means(image: &[Vec3]) -> [f64; 3] {
    let mut sum = [0.0f64; 3];
    for p in image {
        for (c, s) in sum.iter_mut().enumerate() {
            *s += f64::from(p[c]);
        }
    }
    sum.map(|s| s / image.len().max(1) as f64)
}

/// Agreement of an image with the reference beyond noise: per channel,
/// sum(d) / sqrt(sum(d^2)) with d = image - reference is a z-score (unit
/// variance when both are unbiased estimates of one image with independent
/// pixels), over the whole image and over BLOCKS x BLOCKS blocks.
#[derive(Clone, Debug)]
struct Agreement {
    /// (mean(image) - mean(reference)) / mean(reference), per channel.
    mean_rel_diff: [f64; 3],
    /// Whole-image z-score per channel.
    z_image: [f64; 3],
    /// Largest |z| over blocks and channels, and where (block x, y, channel).
    z_block_max: (f64, u32, u32, usize),
    /// Root mean square of the block z-scores (about 1 when unbiased).
    z_block_rms: f64,
}

fn agreement(image: &[Vec3], reference: &[Vec3], width: u32, height: u32) -> Agreement {
    let (mi, mr) = (channel_means(image), channel_means(reference));
    let nb = (BLOCKS * BLOCKS) as usize;
    let mut block_sum = vec![[0.0f64; 3]; nb];
    let mut block_sq = vec![[0.0f64; 3]; nb];
    for y in 0..height {
        for x in 0..width {
            let i = (y * width + x) as usize;
            let b = ((y * BLOCKS / height) * BLOCKS + x * BLOCKS / width) as usize;
            for c in 0..3 {
                let d = f64::from(image[i][c]) - f64::from(reference[i][c]);
                block_sum[b][c] += d;
                block_sq[b][c] += d * d;
            }
        }
    }
    let z = |s: f64, q: f64| if q > 0.0 { s / q.sqrt() } else { 0.0 };
    let mut z_image = [0.0; 3];
    for (c, zc) in z_image.iter_mut().enumerate() {
        let s: f64 = block_sum.iter().map(|b| b[c]).sum();
        let q: f64 = block_sq.iter().map(|b| b[c]).sum();
        *zc = z(s, q);
    }
    let (mut max, mut sum_sq, mut count) = ((0.0f64, 0, 0, 0), 0.0, 0);
    for (b, (s, q)) in block_sum.iter().zip(&block_sq).enumerate() {
        for c in 0..3 {
            let zb = z(s[c], q[c]);
            sum_sq += zb * zb;
            count += 1;
            if zb.abs() > max.0.abs() {
                max = (zb, b as u32 % BLOCKS, b as u32 / BLOCKS, c);
            }
        }
    }
    Agreement {
        mean_rel_diff: [0, 1, 2].map(|c| (mi[c] - mr[c]) / mr[c]),
        z_image,
        z_block_max: max,
        z_block_rms: (sum_sq / f64::from(count.max(1))).sqrt(),
    }
}

struct RowMetrics<'a> {
    run: &'a Run,
    raw: Errors,
    /// Errors less the reference's own error (clamped at 0).
    corrected: Errors,
    ratio_raw: Option<f64>,
    ratio_corrected: Option<f64>,
    ratio_rel_raw: Option<f64>,
}

impl RowMetrics<'_> {
    fn samples_per_s(&self, pixels: usize) -> f64 {
        pixels as f64 * f64::from(self.run.spp) / self.run.render_s
    }
    fn efficiency(&self) -> f64 {
        1.0 / (self.run.render_s * self.raw.mse)
    }
}

/// The reference's own contribution to every measured error (the test
/// images are independent of it, so it adds to their MSE), and the test of
/// a bias between the renderers.
#[derive(Clone, Copy, Debug)]
struct ReferenceError {
    /// From the reference film: mean squared standard error of its pixels.
    /// A loose upper bound: our sampler is Owen-scrambled Sobol, whose mean
    /// converges faster than the per-iteration variance over N says.
    from_variance: Errors,
    /// What is removed: our all-core MSE at --spp times spp / reference spp.
    /// The reference is our estimator at more spp, so its error is at most
    /// this as long as ours falls at least as fast as 1/spp (plain Monte
    /// Carlo; QMC falls faster). Capped by `from_variance`.
    used: Errors,
    /// Mitsuba's floor with its standard error: independent samples give
    /// E[MSE] = a/N + c exactly, and c = (N2 MSE2 - N1 MSE1)/(N2 - N1),
    /// estimated pixel by pixel, is the reference's error plus the squared
    /// bias between the renderers.
    mitsuba_floor: Option<(f64, f64)>,
}

/// The fitted floor c of [`ReferenceError::mitsuba_floor`] and its standard error.
fn floor_fit(a: &Run, b: &Run, reference: &[Vec3]) -> (f64, f64) {
    let (n1, n2) = (f64::from(a.spp), f64::from(b.spp));
    let (mut sum, mut sum_sq, mut n) = (0.0, 0.0, 0.0);
    for ((x1, x2), r) in a.image.iter().zip(&b.image).zip(reference) {
        for c in 0..3 {
            let d1 = f64::from(x1[c]) - f64::from(r[c]);
            let d2 = f64::from(x2[c]) - f64::from(r[c]);
            let v = (n2 * d2 * d2 - n1 * d1 * d1) / (n2 - n1);
            sum += v;
            sum_sq += v * v;
            n += 1.0;
        }
    }
    let mean = sum / n;
    let variance = (sum_sq / n - mean * mean).max(0.0);
    (mean, (variance / n).sqrt())
}

struct Report<'a> {
    options: &'a Options,
    cores: usize,
    mitsuba_version: String,
    mitsuba_how: String,
    reference: &'a Reference,
    reference_error: ReferenceError,
    rows: Vec<RowMetrics<'a>>,
    /// (renderer, spp, agreement with the reference) for all-core runs.
    agreements: Vec<(&'static str, u32, Agreement)>,
    /// Per renderer: MSE ~ spp^-rate between --spp and --check-spp (1 for
    /// plain Monte Carlo), from reference-corrected MSEs.
    convergence: Vec<(&'static str, f64)>,
    scene_load_s: f64,
    load_average: (String, String),
}

fn load_average() -> String {
    fs::read_to_string("/proc/loadavg")
        .map(|s| s.split_whitespace().take(3).collect::<Vec<_>>().join(" "))
        .unwrap_or_else(|_| "unknown".into())
}

impl<'a> Report<'a> {
    fn new(
        context: (&'a Options, usize, &Mitsuba, f64, String),
        reference: &'a Reference,
        runs: &'a [Run],
    ) -> Self {
        let (options, cores, mitsuba, scene_load_s, load_before) = context;
        let raw: Vec<Errors> = runs
            .iter()
            .map(|run| errors(&run.image, &reference.mean))
            .collect();
        let level = |name: &str, spp: u32| {
            runs.iter()
                .position(|r| r.renderer == name && r.spp == spp && r.threads == cores)
        };
        let (n1, n2) = (f64::from(options.spp), f64::from(options.check_spp));
        let two_levels = |name: &str| {
            if options.check_spp == 0 {
                return None;
            }
            Some((level(name, options.spp)?, level(name, options.check_spp)?))
        };
        let from_variance = reference_floor(reference);
        let extrapolated = level(OURS, options.spp).map_or(from_variance, |i| {
            let f = n1 / f64::from(options.reference_spp);
            Errors {
                mse: (raw[i].mse * f).min(from_variance.mse),
                rel_mse: (raw[i].rel_mse * f).min(from_variance.rel_mse),
            }
        });
        let reference_error = ReferenceError {
            from_variance,
            used: extrapolated,
            mitsuba_floor: two_levels(MITSUBA)
                .map(|(a, b)| floor_fit(&runs[a], &runs[b], &reference.mean)),
        };
        let mut rows: Vec<RowMetrics> = runs
            .iter()
            .zip(&raw)
            .map(|(run, &raw)| RowMetrics {
                run,
                raw,
                corrected: Errors {
                    mse: (raw.mse - reference_error.used.mse).max(0.0),
                    rel_mse: (raw.rel_mse - reference_error.used.rel_mse).max(0.0),
                },
                ratio_raw: None,
                ratio_corrected: None,
                ratio_rel_raw: None,
            })
            .collect();
        // Time to equal error relative to Mitsuba at the same spp and threads.
        let work = |r: &RowMetrics, e: Errors| (r.run.render_s * e.mse, r.run.render_s * e.rel_mse);
        let baselines: Vec<_> = rows
            .iter()
            .filter(|r| r.run.renderer == MITSUBA)
            .map(|r| {
                (
                    r.run.spp,
                    r.run.threads,
                    work(r, r.raw),
                    work(r, r.corrected),
                )
            })
            .collect();
        for r in &mut rows {
            if let Some(&(_, _, (m_raw, m_rel), (m_cor, _))) = baselines
                .iter()
                .find(|b| b.0 == r.run.spp && b.1 == r.run.threads)
            {
                let (raw, rel) = work(r, r.raw);
                let (cor, _) = work(r, r.corrected);
                r.ratio_raw = Some(raw / m_raw);
                r.ratio_rel_raw = Some(rel / m_rel);
                r.ratio_corrected = (m_cor > 0.0).then(|| cor / m_cor);
            }
        }
        let agreements = rows
            .iter()
            .filter(|r| r.run.threads == cores)
            .map(|r| {
                let a = agreement(&r.run.image, &reference.mean, options.width, options.height);
                (r.run.renderer, r.run.spp, a)
            })
            .collect();
        let convergence = [OURS, MITSUBA]
            .into_iter()
            .filter_map(|name| {
                let (a, b) = two_levels(name)?;
                let (ea, eb) = (rows[a].corrected.mse, rows[b].corrected.mse);
                (ea > 0.0 && eb > 0.0).then(|| (name, (ea / eb).ln() / (n2 / n1).ln()))
            })
            .collect();
        Self {
            options,
            cores,
            mitsuba_version: mitsuba.version.clone(),
            mitsuba_how: mitsuba.how.clone(),
            reference,
            reference_error,
            rows,
            agreements,
            convergence,
            scene_load_s,
            load_average: (load_before, load_average()),
        }
    }

    /// Warnings: the two renderers do not estimate the same image.
    fn alarms(&self) -> Vec<String> {
        let mut alarms = Vec::new();
        for (name, spp, a) in &self.agreements {
            if a.mean_rel_diff.iter().any(|d| d.abs() > MEAN_TOLERANCE) {
                alarms.push(format!(
                    "{name} @ {spp} spp: the image mean differs from the reference's by more than {:.0} % \
                     (if Mitsuba's: the export is suspect: emitter side, fov, colours)",
                    100.0 * MEAN_TOLERANCE
                ));
            } else if a.z_image.iter().any(|z| z.abs() > Z_ALARM) || a.z_block_rms > BLOCK_RMS_ALARM
            {
                alarms.push(format!(
                    "{name} @ {spp} spp: differs from the reference beyond noise \
                     (image |z| > {Z_ALARM} or block z rms > {BLOCK_RMS_ALARM})"
                ));
            }
        }
        if let Some((c, se)) = self.reference_error.mitsuba_floor {
            let bound = self.reference_error.from_variance.mse;
            if c - 3.0 * se > bound {
                alarms.push(format!(
                    "Mitsuba's error levels off at MSE {c:.3e} +- {se:.1e}, above the reference's own error bound {bound:.3e}: \
                     a bias between the renderers of RMS about {:.3e} per pixel and channel",
                    (c - self.reference_error.used.mse).max(0.0).sqrt()
                ));
            }
        }
        alarms
    }

    fn markdown(&self, total_s: f64, alarms: &[String]) -> String {
        let o = self.options;
        let pixels = o.pixels();
        let mut md = String::new();
        let _ = writeln!(md, "# Our path tracer vs Mitsuba 3\n");
        let _ = writeln!(
            md,
            "Scene `{}` at {}x{}, max depth {} (segments), Russian roulette from depth 3, box filter, \
             regularization off. Mitsuba {} (`scalar_rgb`, `path`, `independent` sampler; {}). \
             Machine: {} logical cores, load average {} before and {} after (other work on the \
             machine slows both renderers). Times: the render call only, release build, fastest of \
             {} alternating runs (ours, Mitsuba, ours, ...) at all cores and `--spp`, one run otherwise.\n",
            o.scene.display(),
            o.width,
            o.height,
            o.max_depth,
            self.mitsuba_version,
            self.mitsuba_how,
            self.cores,
            self.load_average.0,
            self.load_average.1,
            o.repeat,
        );
        let re = &self.reference_error;
        let _ = writeln!(
            md,
            "Reference: ours at {} spp ({}, {:.1} s, `{}`), seeds independent of the test images. \
             Its own error, which adds to every MSE below: MSE {:.3e}, relMSE {:.3e} (ours at {} spp \
             scaled by {}/{}: the most it can be if our error falls at least as fast as 1/spp; the \
             looser bound from its pixel variances is MSE {:.3e}, relMSE {:.3e}). The last column \
             removes it.\n",
            self.reference.spp,
            if self.reference.cached {
                "cached"
            } else {
                "rendered now"
            },
            self.reference.render_s,
            self.reference.path.display(),
            re.used.mse,
            re.used.rel_mse,
            o.spp,
            o.spp,
            self.reference.spp,
            re.from_variance.mse,
            re.from_variance.rel_mse,
        );
        md.push_str(
            "| renderer | threads | spp | time (s) | samples/s | RMSE | relMSE | efficiency 1/(t MSE) | time to equal MSE vs Mitsuba | same, reference error removed | time to equal relMSE vs Mitsuba | BVH build / scene load (s) |\n\
             |---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n",
        );
        let ratio = |r: Option<f64>| r.map_or("-".to_string(), |r| format!("{r:.3}"));
        for r in &self.rows {
            let _ = writeln!(
                md,
                "| {} | {} | {} | {:.3} | {:.3e} | {:.4e} | {:.4e} | {:.3e} | {} | {} | {} | {:.4} |",
                r.run.renderer,
                r.run.threads,
                r.run.spp,
                r.run.render_s,
                r.samples_per_s(pixels),
                r.raw.mse.sqrt(),
                r.raw.rel_mse,
                r.efficiency(),
                ratio(r.ratio_raw),
                ratio(r.ratio_corrected),
                ratio(r.ratio_rel_raw),
                r.run.setup_s,
            );
        }
        md.push_str(
            "\nTime to equal MSE = (t MSE)_row / (t MSE)_Mitsuba at the same spp and threads: the time \
             ours takes to reach its MSE over the time Mitsuba needs for that MSE (Mitsuba's independent \
             samples give MSE ~ 1/time exactly); below 1, ours is faster. Ours is Owen-scrambled Sobol, \
             whose MSE falls faster than 1/spp (rate below), so the ratio depends on the spp.\n",
        );
        if !self.convergence.is_empty() {
            md.push_str("\nMSE ~ spp^-rate between the two spp levels (reference error removed; 1 = plain Monte Carlo):");
            for (name, rate) in &self.convergence {
                let _ = write!(md, " {name} {rate:.2};");
            }
            md.push('\n');
        }
        let _ = writeln!(md, "\n## Agreement: do both render the same image?\n");
        let _ = writeln!(
            md,
            "d = image - reference per pixel; z = sum d / sqrt(sum d^2) per channel, over the image \
             and over {BLOCKS}x{BLOCKS} blocks, is about N(0, 1) when both are unbiased estimates of \
             one image (skewed at few samples per block). Ours against our reference is the control.\n"
        );
        md.push_str(
            "| image | mean rel. diff R, G, B | image z R, G, B | block z rms | largest block z (x, y, ch) |\n\
             |---|---|---|---:|---|\n",
        );
        for (name, spp, a) in &self.agreements {
            let _ = writeln!(
                md,
                "| {name} @ {spp} spp | {:+.3} %, {:+.3} %, {:+.3} % | {:+.2}, {:+.2}, {:+.2} | {:.2} | {:+.2} ({}, {}, {}) |",
                100.0 * a.mean_rel_diff[0],
                100.0 * a.mean_rel_diff[1],
                100.0 * a.mean_rel_diff[2],
                a.z_image[0],
                a.z_image[1],
                a.z_image[2],
                a.z_block_rms,
                a.z_block_max.0,
                a.z_block_max.1,
                a.z_block_max.2,
                ["R", "G", "B"][a.z_block_max.3],
            );
        }
        if let Some((c, se)) = re.mitsuba_floor {
            let _ = writeln!(
                md,
                "\nBias test: Mitsuba's MSE = a/spp + c over its two spp levels gives c = {c:.3e} +- {se:.1e} \
                 (the reference's error plus the squared bias between the renderers; the reference's error \
                 is at most {:.3e}).",
                re.from_variance.mse
            );
        }
        if alarms.is_empty() {
            md.push_str("\nNo disagreement beyond noise.\n");
        } else {
            md.push_str("\n**Warnings**\n\n");
            for a in alarms {
                let _ = writeln!(md, "- {a}");
            }
        }
        let _ = writeln!(
            md,
            "\nScene load (ours) {:.3} s; whole command {total_s:.1} s.",
            self.scene_load_s
        );
        md
    }

    fn json(&self, total_s: f64, alarms: &[String]) -> Value {
        let o = self.options;
        let pixels = o.pixels();
        let re = &self.reference_error;
        json!({
            "scene": o.scene.display().to_string(),
            "width": o.width,
            "height": o.height,
            "max_depth": o.max_depth,
            "rr_depth": 3,
            "repeat": o.repeat,
            "cores": self.cores,
            "load_average_before": self.load_average.0,
            "load_average_after": self.load_average.1,
            "mitsuba_version": self.mitsuba_version,
            "mitsuba_install": self.mitsuba_how,
            "reference": {
                "spp": self.reference.spp,
                "path": self.reference.path.display().to_string(),
                "cached": self.reference.cached,
                "render_s": self.reference.render_s,
                "error_bound_from_variance_mse": re.from_variance.mse,
                "error_bound_from_variance_rel_mse": re.from_variance.rel_mse,
                "removed_mse": re.used.mse,
                "removed_rel_mse": re.used.rel_mse,
                "mitsuba_floor_mse": re.mitsuba_floor.map(|f| f.0),
                "mitsuba_floor_mse_standard_error": re.mitsuba_floor.map(|f| f.1),
            },
            "rows": self.rows.iter().map(|r| json!({
                "renderer": r.run.renderer,
                "threads": r.run.threads,
                "spp": r.run.spp,
                "render_s": r.run.render_s,
                "render_s_all_repeats": r.run.render_times,
                "setup_s": r.run.setup_s,
                "samples_per_s": r.samples_per_s(pixels),
                "mse": r.raw.mse,
                "rmse": r.raw.mse.sqrt(),
                "rel_mse": r.raw.rel_mse,
                "mse_reference_removed": r.corrected.mse,
                "rel_mse_reference_removed": r.corrected.rel_mse,
                "efficiency": r.efficiency(),
                "time_to_equal_mse_vs_mitsuba": r.ratio_raw,
                "time_to_equal_mse_vs_mitsuba_reference_removed": r.ratio_corrected,
                "time_to_equal_rel_mse_vs_mitsuba": r.ratio_rel_raw,
                "image": r.run.path.display().to_string(),
                "note": r.run.note,
            })).collect::<Vec<_>>(),
            "convergence_rate": self.convergence.iter().map(|(n, r)| json!({"renderer": n, "rate": r})).collect::<Vec<_>>(),
            "agreement": self.agreements.iter().map(|(name, spp, a)| json!({
                "renderer": name,
                "spp": spp,
                "mean_rel_diff": a.mean_rel_diff,
                "z_image": a.z_image,
                "z_block_rms": a.z_block_rms,
                "z_block_max": a.z_block_max.0,
                "z_block_max_at": [a.z_block_max.1, a.z_block_max.2, a.z_block_max.3],
            })).collect::<Vec<_>>(),
            "warnings": alarms,
            "scene_load_s": self.scene_load_s,
            "total_s": total_s,
        })
    }

    fn write(&self, out: &Path, total_s: f64) -> Result<(), String> {
        let alarms = self.alarms();
        let md = self.markdown(total_s, &alarms);
        let md_path = out.join("report.md");
        fs::write(&md_path, &md).map_err(|e| format!("cannot write {}: {e}", md_path.display()))?;
        let json_path = out.join("report.json");
        let text = serde_json::to_string_pretty(&self.json(total_s, &alarms))
            .map_err(|e| e.to_string())?;
        fs::write(&json_path, text)
            .map_err(|e| format!("cannot write {}: {e}", json_path.display()))?;
        println!("\n{md}");
        println!("written: {} and {}", md_path.display(), json_path.display());
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn options_parse_and_reject_bad_values() {
        let root = Path::new("/r");
        let args: Vec<String> = ["--spp", "8", "--resolution", "64x32", "--no-single-thread"]
            .iter()
            .map(|s| s.to_string())
            .collect();
        let o = Options::parse(root, &args).unwrap();
        assert_eq!(
            (o.spp, o.width, o.height, o.single_thread),
            (8, 64, 32, false)
        );
        assert_eq!(o.out, Path::new("/r/target/mitsuba"));
        for bad in [
            &["--spp"][..],
            &["--spp", "x"],
            &["--resolution", "64"],
            &["--max-depth", "0"],
            &["--frobnicate", "1"],
        ] {
            let bad: Vec<String> = bad.iter().map(|s| s.to_string()).collect();
            let e = Options::parse(root, &bad).unwrap_err();
            assert!(!e.is_empty());
        }
    }

    #[test]
    fn errors_and_agreement_of_identical_and_shifted_images() {
        let reference = vec![Vec3::new(1.0, 0.5, 0.0); 64];
        let same = errors(&reference, &reference);
        assert_eq!((same.mse, same.rel_mse), (0.0, 0.0));
        let brighter: Vec<Vec3> = reference.iter().map(|p| *p + Vec3::splat(0.1)).collect();
        let e = errors(&brighter, &reference);
        assert!((e.mse - 0.01).abs() < 1e-6);
        let a = agreement(&brighter, &reference, 8, 8);
        assert!((a.mean_rel_diff[0] - 0.1).abs() < 1e-6);
        // A constant offset is maximally "beyond noise": z = sqrt(n).
        assert!((a.z_image[0] - 8.0).abs() < 1e-4);
    }

    #[test]
    fn ply_is_well_formed() {
        let scene = scene::load(
            &Path::new(env!("CARGO_MANIFEST_DIR")).join("../scenes/cornell-box/scene.toml"),
            &LoadOptions {
                camera_name: None,
                resolution: Some(UVec2::new(8, 8)),
            },
        )
        .unwrap();
        let bytes = ply(&scene, &[0, 1], false);
        let header_end = bytes
            .windows(11)
            .position(|w| w == b"end_header\n")
            .unwrap()
            + 11;
        // 6 vertices x 3 floats, then 2 faces x (1 + 3 x 4) bytes.
        assert_eq!(bytes.len() - header_end, 6 * 12 + 2 * 13);
    }
}
