//! `cargo xtask study`: convergence studies, error against wall-clock time
//! (SPEC §8; supp. §7 and Figure 2).
//!
//! Two references (an unbiased one, BPT or VCM as the scene needs, and the
//! regularized VCM of supp. §7, both at many iterations, cached on disk),
//! then every config (and every `--sweep` value of the regularized ones)
//! for a number of iterations, measured at log-spaced checkpoints; curves,
//! a report with equal-time comparisons, the bias of regularization, charts
//! and a contact sheet of close-ups. All light transport is the `integrators`
//! library's: this module only calls `Renderer::render_iteration` and reads
//! the film.
//!
//! - `cli`: flags, budgets, configs
//! - `progress`: progress bars and lines
//! - `metrics`: RMSE, relMSE and noise on luminance, checkpoints, log-log interpolation
//! - `cache`: the reference cache and its key, atomic writes
//! - `runs`: the run cache, every finished config's curve and image
//! - `checkpoint`: the state of a render in progress, to resume it
//! - `report`: curves.csv, curves.json, report.md (equal-time tables)
//! - `bias`: the regularized reference minus the unbiased one, as numbers
//!   and a false-colour image
//! - `charts`: which charts a study has, from its run or its curves.json
//!   (`--replot`)
//! - `plot`: charts as SVG and PNG, one panel per algorithm
//! - `raster`: an RGB canvas with a bitmap font (contact sheet, bias image)
//! - `sheet`: the contact sheet

mod bias;
pub(crate) mod cache;
mod charts;
mod checkpoint;
mod cli;
pub(crate) mod metrics;
mod plot;
mod progress;
mod raster;
mod report;
mod runs;
mod sheet;

use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use glam::Vec3;
use integrators::{DEFAULT_MAX_DEPTH, DEFAULT_TAU_0, Film, Renderer};
use scene::LoadOptions;
use serde_json::json;

use cache::ReferenceSpec;
use checkpoint::{Checkpoints, Resumed};
pub use cli::Config;
use cli::{HELP, Options, Parsed, Unbiased};
/// Flag-value parsers shared with `cargo xtask bench`.
pub(crate) use cli::{parse_resolution, positive};
use metrics::{Errors, Noise};
use progress::Progress;
use runs::RunSpec;

/// The task's line in `cargo xtask help`.
pub const USAGE: &str = "  study --scene PATH [options]
                    convergence study: every config's error against a cached
                    reference over wall-clock time, written to
                    target/study/<scene>/ (report.md, curves, charts, contact
                    sheet); `cargo xtask study --help` lists the options";

/// Seed offsets of the references (see `--seed`).
const REFERENCE_SEED_OFFSET: u64 = 1_000_003;
const UNBIASED_SEED_OFFSET: u64 = 2_000_006;

/// A reference image with how it was made.
pub struct Reference {
    /// "unbiased" or "regularized".
    pub role: &'static str,
    /// Its config.
    pub config: Config,
    /// Its settings (iterations, seed, ...).
    pub spec: ReferenceSpec,
    /// Cache key.
    pub key: String,
    /// The cached EXR file.
    pub cache_file: PathBuf,
    /// Whether it came from the cache in this run.
    pub cached: bool,
    /// Wall-clock seconds of rendering (when it was rendered).
    pub render_seconds: f64,
    /// CPU seconds of rendering, all threads (when it was rendered, and
    /// where the system reports it).
    pub cpu_seconds: Option<f64>,
    /// Noise of the reference itself (luminance).
    pub noise: Option<Noise>,
    /// NaN/Inf samples the renderer dropped.
    pub invalid_samples: u64,
    /// Mean image, linear RGB.
    pub image: Vec<Vec3>,
    /// Its luminance.
    pub luminance: Vec<f64>,
}

/// One checkpoint of a config.
#[derive(Clone)]
pub struct Point {
    /// Iterations done.
    pub iteration: u64,
    /// Cumulative wall-clock seconds of rendering.
    pub seconds: f64,
    /// Cumulative CPU seconds of rendering, all threads (None where the
    /// system does not report them).
    pub cpu_seconds: Option<f64>,
    /// Noise of the mean image so far (None at 1 iteration).
    pub noise: Option<Noise>,
    /// Error against each reference, in the order of `Study::references`.
    pub errors: Vec<Errors>,
}

/// Where a config's run in a study came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// Rendered in this study from the first iteration.
    Rendered,
    /// Rendered in this study from a checkpoint after this iteration.
    Resumed(u64),
    /// From the run cache (rendered by an earlier study).
    Cached,
}

/// One config's run.
pub struct Run {
    /// The config.
    pub config: Config,
    /// Its key in the run cache.
    pub key: String,
    /// Whether it was rendered, resumed or reused.
    pub origin: Origin,
    /// Seconds to prepare the renderer (BVH, lights), not in the curves.
    pub setup_seconds: f64,
    /// Checkpoints, in order.
    pub points: Vec<Point>,
    /// NaN/Inf samples the renderer dropped.
    pub invalid_samples: u64,
    /// Final mean image.
    pub image: Vec<Vec3>,
}

impl Run {
    /// (wall-clock seconds, value) at each checkpoint.
    pub fn curve(&self, value: impl Fn(&Point) -> f64) -> Vec<(f64, f64)> {
        self.points.iter().map(|p| (p.seconds, value(p))).collect()
    }

    /// (CPU seconds, value) at each checkpoint; None without CPU times.
    pub fn cpu_curve(&self, value: impl Fn(&Point) -> f64) -> Option<Vec<(f64, f64)>> {
        self.points
            .iter()
            .map(|p| Some((p.cpu_seconds?, value(p))))
            .collect()
    }
}

/// Everything the report needs.
pub struct Study {
    /// Scene file, as given.
    pub scene_file: PathBuf,
    /// Scene name (output folder name).
    pub scene_name: String,
    /// Hash of the scene's files.
    pub scene_hash: u64,
    /// Image size.
    pub resolution: (u32, u32),
    /// Iterations of every config.
    pub iterations: u64,
    /// Budget preset.
    pub budget: &'static str,
    /// Seed of the configs.
    pub seed: u64,
    /// Longest path.
    pub max_depth: u32,
    /// tau_0 of regularized configs.
    pub tau0: f64,
    /// Renderer version string (the cache key's input) and commit.
    pub renderer_version: String,
    /// The references: the unbiased one first (unless skipped), then the
    /// regularized one.
    pub references: Vec<Reference>,
    /// Why the unbiased reference is the config it is (None: skipped).
    pub unbiased_reason: Option<String>,
    /// The `--sweep` values, one line ("none" without a sweep).
    pub sweep: String,
    /// The configs' runs, in the order given.
    pub runs: Vec<Run>,
    /// Logical cores.
    pub cores: usize,
    /// /proc/loadavg at the start and the end.
    pub load: (String, String),
    /// Wall-clock seconds of the whole study so far.
    pub total_seconds: f64,
    /// The command line.
    pub command: String,
}

/// Runs `cargo xtask study ARGS`.
pub fn run(root: &Path, args: &[String]) -> Result<(), String> {
    if let [flag, dir] = args
        && flag == "--replot"
    {
        return charts::replot(Path::new(dir));
    }
    let options = match Options::parse(root, args)? {
        Parsed::Help => {
            println!("{HELP}");
            return Ok(());
        }
        Parsed::Run(options) => *options,
    };
    let started = Instant::now();
    let load_before = crate::load_average();
    fs::create_dir_all(options.out.join("images"))
        .map_err(|e| format!("--out: cannot create {}: {e}", options.out.display()))?;
    let (scene, settings) = load_scene(&options)?;
    let scene_hash =
        cache::scene_hash_of(&options.scene_file).map_err(|e| format!("--scene: {e}"))?;
    let renderer_version = cache::renderer_version(root);
    let unbiased = unbiased_reference(options.unbiased, &scene);
    announce(&options, &settings, unbiased.as_ref());
    let specs = reference_specs(&options, &settings, unbiased.as_ref().map(|(c, _)| *c));
    let context = Context {
        scene: &scene,
        scene_file: &options.scene_file,
        scene_hash,
        renderer_version: &renderer_version,
        cache_dir: &options.cache,
        root,
        farm: options.farm.as_ref(),
        checkpoint_interval: options.checkpoint_interval,
        fresh: options.fresh || options.rerender,
    };
    let reference_keys: Vec<String> = specs
        .iter()
        .map(|(_, _, spec)| spec.key(scene_hash, &renderer_version))
        .collect();
    let jobs = run_jobs(
        &options,
        &settings,
        &reference_keys,
        (scene_hash, &renderer_version),
    )?;
    let cached = look_up_cache(&specs, &context, &options, &settings);
    let cached_runs: Vec<Option<Run>> = jobs
        .iter()
        .map(|job| {
            (!options.fresh)
                .then(|| runs::load(&options.cache, &job.key, &job.spec))
                .flatten()
        })
        .collect();
    // Iterations count towards the progress only when rendered.
    let to_render: u64 = cached
        .iter()
        .filter(|c| c.is_none())
        .map(|_| options.reference_iterations)
        .sum::<u64>()
        + cached_runs
            .iter()
            .filter(|r| r.is_none())
            .map(|_| options.iterations)
            .sum::<u64>();
    let mut progress = Progress::new(to_render);
    let mut references = Vec::new();
    for (spec, cached) in specs.into_iter().zip(cached) {
        let reference = obtain_reference(spec, cached, &context, &mut progress)?;
        crate::write_exr(
            &options.out.join("images").join(reference.image_name()),
            settings.width,
            settings.height,
            &reference.image,
        )?;
        references.push(reference);
    }
    let mut runs = Vec::new();
    for (job, cached) in jobs.iter().zip(cached_runs) {
        let run = match cached {
            Some(run) => {
                progress.println(&format!(
                    "reusing cached run of {} (key {})",
                    job.spec.config, job.key
                ));
                // A run killed after storing its entry, before removing
                // its checkpoint, left one behind.
                checkpoint::remove(context.cache_dir, &job.key);
                run
            }
            None => {
                let run = run_config(
                    job,
                    &options,
                    &settings,
                    &references,
                    &context,
                    &mut progress,
                )?;
                store_run(job, &run, &context)?;
                run
            }
        };
        crate::write_exr(
            &options
                .out
                .join("images")
                .join(format!("{}.exr", run.config)),
            settings.width,
            settings.height,
            &run.image,
        )?;
        runs.push(run);
    }
    progress.finish();
    let study = Study {
        scene_file: options.scene_file.clone(),
        scene_name: options.scene_name.clone(),
        scene_hash,
        resolution: (settings.width, settings.height),
        iterations: options.iterations,
        budget: options.budget.name(),
        seed: options.seed,
        max_depth: settings.max_depth,
        tau0: settings.tau0,
        renderer_version: cache::with_commit(root, &renderer_version),
        references,
        unbiased_reason: unbiased.map(|(_, why)| why),
        sweep: options.sweep.describe(),
        runs,
        cores: crate::cores(),
        load: (load_before, crate::load_average()),
        total_seconds: started.elapsed().as_secs_f64(),
        command: std::iter::once("cargo xtask study".to_string())
            .chain(args.iter().cloned())
            .collect::<Vec<_>>()
            .join(" "),
    };
    let written = report::write(&options.out, &study)?;
    println!(
        "wrote {} ({}) in {:.1} s",
        options.out.display(),
        written.join(", "),
        started.elapsed().as_secs_f64()
    );
    Ok(())
}

/// A config to run: its resolved settings, run-cache inputs and key.
struct RunJob {
    render_config: integrators::RenderConfig,
    spec: RunSpec,
    key: String,
}

/// The job of every config, keyed against the references' keys, the
/// scene's hash and the renderer's version.
fn run_jobs(
    options: &Options,
    settings: &Settings,
    reference_keys: &[String],
    (scene_hash, renderer_version): (u64, &str),
) -> Result<Vec<RunJob>, String> {
    options
        .configs
        .iter()
        .map(|&config| {
            let render_config =
                config.render_config(options.seed, settings.max_depth, settings.tau0)?;
            let spec = RunSpec {
                config,
                settings: format!("{render_config:?}"),
                iterations: options.iterations,
                width: settings.width,
                height: settings.height,
                references: reference_keys.to_vec(),
            };
            let key = spec.key(scene_hash, renderer_version);
            Ok(RunJob {
                render_config,
                spec,
                key,
            })
        })
        .collect()
}

/// Stores a rendered config in the run cache (with what made it, for
/// people reading the cache) and removes its checkpoint.
fn store_run(job: &RunJob, run: &Run, context: &Context<'_>) -> Result<(), String> {
    let about = json!({
        "scene": context.scene_file.display().to_string(),
        "scene_hash": format!("{:016x}", context.scene_hash),
        "renderer_version": context.renderer_version,
        "cores": crate::cores(),
    });
    let about = about.as_object().cloned().unwrap_or_default();
    runs::store(context.cache_dir, &job.spec, run, &about)?;
    checkpoint::remove(context.cache_dir, &job.key);
    Ok(())
}

/// What the scene and the flags fix for every render of a study.
struct Settings {
    width: u32,
    height: u32,
    max_depth: u32,
    tau0: f64,
}

/// The scene at `--resolution`, its warnings printed, and the settings
/// from its manifest and the flags.
fn load_scene(options: &Options) -> Result<(scene::Scene, Settings), String> {
    let scene = scene::load(
        &options.scene_file,
        &LoadOptions {
            resolution: options.resolution,
            ..Default::default()
        },
    )
    .map_err(|e| format!("--scene: {e}"))?;
    for warning in &scene.report.warnings {
        eprintln!("warning: {warning}");
    }
    let resolution = scene.camera.resolution;
    let settings = Settings {
        width: resolution.x,
        height: resolution.y,
        max_depth: scene.render.max_depth.unwrap_or(DEFAULT_MAX_DEPTH),
        tau0: options.tau0.or(scene.render.tau0).unwrap_or(DEFAULT_TAU_0),
    };
    // A bad tau_0 from the manifest is reported before any rendering.
    Config::REFERENCE.render_config(0, settings.max_depth, settings.tau0)?;
    Ok((scene, settings))
}

/// The unbiased reference's config and why, from `--unbiased-reference`
/// (None: skipped).
fn unbiased_reference(choice: Unbiased, scene: &scene::Scene) -> Option<(Config, String)> {
    match choice {
        Unbiased::Skip => None,
        Unbiased::Given(c) => Some((c, "given by --unbiased-reference".into())),
        Unbiased::Auto => Some(choose_unbiased(&scene::SceneFeatures::of(scene))),
    }
}

/// The unbiased reference a scene needs: VCM when it has a specular
/// (delta) surface, since a specular-diffuse-specular path lit by a point
/// light has no technique in BPT (every connection needs a non-delta vertex
/// on both ends, and a camera subpath cannot hit a point light) and only
/// merging reaches it (consistent, its bias vanishes as the merge radius
/// shrinks); otherwise BPT, which is unbiased and samples every path.
fn choose_unbiased(features: &scene::SceneFeatures) -> (Config, String) {
    if features.specular_materials > 0 {
        (
            Config::plain(integrators::Algorithm::Vcm, false),
            format!(
                "auto: the scene has {} specular (delta) material(s), whose caustics (SDS \
                 paths) only merging reaches",
                features.specular_materials
            ),
        )
    } else {
        (
            Config::plain(integrators::Algorithm::Bpt, false),
            "auto: no specular (delta) material, so BPT samples every path and is unbiased".into(),
        )
    }
}

/// The one line that says what the study will do.
fn announce(options: &Options, settings: &Settings, unbiased: Option<&(Config, String)>) {
    println!(
        "study: {} at {}x{}, configs {} x {} iterations, references {}{} x {} \
         iterations ({} budget), {} cores",
        options.scene_file.display(),
        settings.width,
        settings.height,
        options
            .configs
            .iter()
            .map(Config::to_string)
            .collect::<Vec<_>>()
            .join(","),
        options.iterations,
        unbiased.map_or(String::new(), |(c, why)| format!("{c} ({why}) and ")),
        Config::REFERENCE,
        options.reference_iterations,
        options.budget.name(),
        crate::cores(),
    );
}

/// (role, config, settings) of every reference: the unbiased one (when
/// there is one), then the regularized one.
fn reference_specs(
    options: &Options,
    settings: &Settings,
    unbiased: Option<Config>,
) -> Vec<(&'static str, Config, ReferenceSpec)> {
    let mut jobs = Vec::new();
    if let Some(c) = unbiased {
        jobs.push(("unbiased", c, UNBIASED_SEED_OFFSET));
    }
    jobs.push(("regularized", Config::REFERENCE, REFERENCE_SEED_OFFSET));
    jobs.into_iter()
        .map(|(role, config, offset)| {
            let spec = ReferenceSpec {
                config: config.to_string(),
                iterations: options.reference_iterations,
                seed: options.seed.wrapping_add(offset),
                width: settings.width,
                height: settings.height,
                max_depth: settings.max_depth,
                tau0: settings.tau0,
            };
            (role, config, spec)
        })
        .collect()
}

/// The cache entry of every reference (None: not cached, or
/// `--rerender-reference` or `--fresh`).
fn look_up_cache(
    specs: &[(&'static str, Config, ReferenceSpec)],
    context: &Context<'_>,
    options: &Options,
    settings: &Settings,
) -> Vec<Option<(Vec<Vec3>, serde_json::Value)>> {
    specs
        .iter()
        .map(|(_, _, spec)| {
            let key = spec.key(context.scene_hash, context.renderer_version);
            (!options.rerender && !options.fresh)
                .then(|| cache::load(context.cache_dir, &key, settings.width, settings.height))
                .flatten()
        })
        .collect()
}

/// A reference from its cache entry (`cached`), else rendered and stored.
fn obtain_reference(
    (role, config, spec): (&'static str, Config, ReferenceSpec),
    cached: Option<(Vec<Vec3>, serde_json::Value)>,
    context: &Context<'_>,
    progress: &mut Progress,
) -> Result<Reference, String> {
    let key = spec.key(context.scene_hash, context.renderer_version);
    let cache_file = cache::paths(context.cache_dir, &key).0;
    match cached {
        Some((image, meta)) => {
            progress.println(&format!(
                "{role}: {config} x {} iterations from the cache ({})",
                spec.iterations,
                cache_file.display()
            ));
            checkpoint::remove(context.cache_dir, &key);
            Ok(Reference::from_cache(
                role, config, spec, key, cache_file, image, &meta,
            ))
        }
        None => {
            let job = ReferenceJob {
                role,
                config,
                spec,
                key,
                cache_file,
            };
            render_reference(job, context, progress)
        }
    }
}

/// Renders one config, measuring it at every checkpoint against every
/// reference and resuming it from its checkpoint if it has one, and
/// prints its final line.
fn run_config(
    job: &RunJob,
    options: &Options,
    settings: &Settings,
    references: &[Reference],
    context: &Context<'_>,
    progress: &mut Progress,
) -> Result<Run, String> {
    let config = job.spec.config;
    let t = Instant::now();
    let renderer = Renderer::new(context.scene.clone(), job.render_config);
    renderer.prepare_energy_tables();
    let setup_seconds = t.elapsed().as_secs_f64();
    let checkpoints = context.checkpoints(
        &job.key,
        job.render_config.seed,
        &job.spec.settings,
        (settings.width, settings.height),
    )?;
    let label = config.to_string();
    let resumed = resume(
        &checkpoints,
        references.len(),
        options.fresh,
        &label,
        progress,
    );
    let origin = match &resumed {
        Some(r) => Origin::Resumed(r.state.iteration),
        None => Origin::Rendered,
    };
    let mut tracker = Tracker::new(
        metrics::checkpoints(options.iterations),
        references,
        checkpoints,
        resumed,
    );
    let rendered = render(
        &renderer,
        options.iterations,
        &mut tracker,
        progress,
        &label,
    );
    let run = Run {
        config,
        key: job.key.clone(),
        origin,
        setup_seconds,
        invalid_samples: tracker.invalid_samples(&renderer),
        points: tracker.points,
        image: rendered.film.mean(),
    };
    if let Some(last) = run.points.last() {
        progress.println(&format!(
            "{config:>8}: {} iterations in {:.2} s, RMSE {:.3e}, relMSE {:.3e}{}",
            last.iteration,
            last.seconds,
            last.errors[0].rmse,
            last.errors[0].rel_mse,
            if run.invalid_samples > 0 {
                format!(", {} NaN/Inf samples dropped", run.invalid_samples)
            } else {
                String::new()
            }
        ));
    }
    Ok(run)
}

/// The state a render resumes from: its checkpoint's, unless `fresh` or
/// there is none. A damaged checkpoint is reported and the render starts
/// over.
fn resume(
    checkpoints: &Checkpoints,
    references: usize,
    fresh: bool,
    label: &str,
    progress: &Progress,
) -> Option<Resumed> {
    if fresh {
        return None;
    }
    match checkpoints.load(references) {
        Ok(Some(resumed)) => {
            progress.println(&format!(
                "resuming {label} from its checkpoint after iteration {} ({})",
                resumed.state.iteration,
                checkpoints.folder().display()
            ));
            Some(resumed)
        }
        Ok(None) => None,
        Err(e) => {
            progress.println(&format!(
                "warning: ignoring the checkpoint of {label}, starting it over: {e}"
            ));
            None
        }
    }
}

impl Point {
    /// The measurements of a render at a checkpoint.
    fn of(state: &Rendered, references: &[Reference]) -> Self {
        let mean = metrics::luminance_image(&state.film.mean());
        Self {
            iteration: state.iteration,
            seconds: state.seconds,
            cpu_seconds: state.cpu_seconds,
            noise: metrics::noise(&state.luminance_variance(), state.iteration),
            errors: references
                .iter()
                .map(|r| metrics::errors(&mean, &r.luminance))
                .collect(),
        }
    }
}

/// What identifies a reference render.
struct ReferenceJob {
    role: &'static str,
    config: Config,
    spec: ReferenceSpec,
    key: String,
    cache_file: PathBuf,
}

/// What every render of a study needs besides its job.
struct Context<'a> {
    scene: &'a scene::Scene,
    scene_file: &'a Path,
    scene_hash: u64,
    renderer_version: &'a str,
    cache_dir: &'a Path,
    root: &'a Path,
    /// `--farm slurm`: shards per reference and the jobs' resources.
    farm: Option<&'a (u64, crate::farm::Resources)>,
    /// `--checkpoint-interval`.
    checkpoint_interval: Duration,
    /// Whether references start over rather than resume from a checkpoint
    /// (`--fresh`, `--rerender-reference`).
    fresh: bool,
}

impl Context<'_> {
    /// The checkpoint of the render whose cache entry is `key`, of the
    /// render settings `settings` (their seed `seed`) at `resolution`.
    fn checkpoints(
        &self,
        key: &str,
        seed: u64,
        settings: &str,
        (width, height): (u32, u32),
    ) -> Result<Checkpoints, String> {
        let header = image_io::film_file::FilmHeader {
            scene: self.scene_file.display().to_string(),
            scene_hash: self.scene_hash,
            settings: format!("{key} {settings}"),
            seed,
            first: 1,
            last: 1,
            width,
            height,
            render_millis: None,
        };
        Checkpoints::locked(self.cache_dir, key, self.checkpoint_interval, header)
    }
}

impl Reference {
    /// The file name of its copy in `<out>/images/`.
    fn image_name(&self) -> String {
        format!("reference-{}-{}.exr", self.role, self.config)
    }

    /// A reference read from the cache, with the sidecar's timings and noise.
    fn from_cache(
        role: &'static str,
        config: Config,
        spec: ReferenceSpec,
        key: String,
        cache_file: PathBuf,
        image: Vec<Vec3>,
        meta: &serde_json::Value,
    ) -> Self {
        let noise = match (
            meta["noise_std_error"].as_f64(),
            meta["noise_variance"].as_f64(),
        ) {
            (Some(std_error), Some(variance)) => Some(Noise {
                std_error,
                variance,
            }),
            _ => None,
        };
        Self {
            role,
            config,
            key,
            cache_file,
            cached: true,
            render_seconds: meta["render_seconds"].as_f64().unwrap_or(f64::NAN),
            cpu_seconds: meta["cpu_seconds"].as_f64(),
            noise,
            invalid_samples: meta["invalid_samples"].as_u64().unwrap_or(0),
            luminance: metrics::luminance_image(&image),
            image,
            spec,
        }
    }
}

/// Renders a reference and stores it in the cache with its sidecar.
fn render_reference(
    job: ReferenceJob,
    context: &Context<'_>,
    progress: &mut Progress,
) -> Result<Reference, String> {
    let ReferenceJob {
        role,
        config,
        spec,
        key,
        cache_file,
    } = job;
    let render_config = config.render_config(spec.seed, spec.max_depth, spec.tau0)?;
    let (rendered, noise, setup_seconds, invalid_samples) = match context.farm {
        Some((shards, resources)) => {
            let flags = farm_flags(&render_config, &spec, config.regularized);
            let job = crate::farm::FilmJob {
                scene: context.scene_file,
                iterations: spec.iterations,
                shards: *shards,
                render_flags: flags,
                resources: resources.clone(),
                folder: context
                    .root
                    .join("target/farm")
                    .join(format!("study-{key}")),
                settings: format!("{render_config:?}"),
            };
            progress.println(&format!(
                "{role}: {config} on the farm ({})",
                job.folder.display()
            ));
            let (film, seconds) = crate::farm::render_film(context.root, &job)?;
            let rendered = Rendered {
                iteration: spec.iterations,
                seconds,
                cpu_seconds: None,
                luminance: Film::new(film.width(), film.height()),
                film,
            };
            // A partial film keeps RGB sums, not the luminance's.
            (rendered, None, 0.0, 0)
        }
        None => {
            let t = Instant::now();
            let renderer = Renderer::new(context.scene.clone(), render_config);
            renderer.prepare_energy_tables();
            let setup_seconds = t.elapsed().as_secs_f64();
            let label = format!("{role} {config}");
            let checkpoints = context.checkpoints(
                &key,
                spec.seed,
                &format!("{render_config:?}"),
                (spec.width, spec.height),
            )?;
            let resumed = resume(&checkpoints, 0, context.fresh, &label, progress);
            let mut tracker = Tracker::new(Vec::new(), &[], checkpoints, resumed);
            let rendered = render(&renderer, spec.iterations, &mut tracker, progress, &label);
            let noise = metrics::noise(&rendered.luminance_variance(), spec.iterations);
            (
                rendered,
                noise,
                setup_seconds,
                tracker.invalid_samples(&renderer),
            )
        }
    };
    let image = rendered.film.mean();
    let meta = json!({
        "key": key,
        "role": role,
        "scene": context.scene_file.display().to_string(),
        "scene_hash": format!("{:016x}", context.scene_hash),
        "settings": spec.canonical(),
        "config": config.to_string(),
        "iterations": spec.iterations,
        "seed": spec.seed,
        "resolution": [spec.width, spec.height],
        "max_depth": spec.max_depth,
        "tau0": spec.tau0,
        "renderer_version": context.renderer_version,
        "render_seconds": rendered.seconds,
        "cpu_seconds": rendered.cpu_seconds,
        "setup_seconds": setup_seconds,
        "cores": crate::cores(),
        "noise_std_error": noise.map(|n| n.std_error),
        "noise_variance": noise.map(|n| n.variance),
        "invalid_samples": invalid_samples,
    });
    cache::store(
        context.cache_dir,
        &key,
        (spec.width, spec.height),
        &image,
        &meta,
    )?;
    checkpoint::remove(context.cache_dir, &key);
    progress.println(&format!(
        "{role}: {config} x {} iterations rendered in {:.1} s, cached as {}",
        spec.iterations,
        rendered.seconds,
        cache_file.display()
    ));
    Ok(Reference {
        role,
        config,
        key,
        cache_file,
        cached: false,
        render_seconds: rendered.seconds,
        cpu_seconds: rendered.cpu_seconds,
        noise,
        invalid_samples,
        luminance: metrics::luminance_image(&image),
        image,
        spec,
    })
}

/// The render-cli flags that give `render_config` (the farm renders
/// references with render-cli; `farm::render_film` checks that the shards'
/// settings are `render_config`'s).
fn farm_flags(
    render_config: &integrators::RenderConfig,
    spec: &ReferenceSpec,
    regularized: bool,
) -> Vec<String> {
    let c = render_config;
    let mode = if regularized {
        c.regularization.mode.name()
    } else {
        "off"
    };
    [
        "--integrator",
        c.algorithm.name(),
        "--regularize",
        mode,
        "--tau0",
        &c.regularization.schedule.tau_0().to_string(),
        "--max-depth",
        &c.max_depth.to_string(),
        "--seed",
        &c.seed.to_string(),
        "--resolution",
        &format!("{}x{}", spec.width, spec.height),
        "--radius",
        &c.radius_factor.to_string(),
        "--shadow-roulette",
        &c.shadow_roulette.to_string(),
    ]
    .map(str::to_owned)
    .to_vec()
}

/// CPU time of this process so far, in seconds: the sum over its threads
/// of their time on a CPU (`/proc/self/task/*/schedstat`, nanoseconds).
/// Unlike wall-clock time it hardly changes when other processes compete
/// for the cores. Threads that have exited are not counted, which is fine
/// for differences over an iteration (rayon's workers live on). None where
/// /proc does not tell.
pub(crate) fn cpu_seconds() -> Option<f64> {
    let mut ns = 0u64;
    for task in fs::read_dir("/proc/self/task").ok()? {
        // A thread may exit between the listing and the read, and an
        // exiting thread's file may read empty: skip it rather than lose
        // the whole sum.
        let Ok(task) = task else { continue };
        let Ok(text) = fs::read_to_string(task.path().join("schedstat")) else {
            continue;
        };
        let Some(Ok(n)) = text.split_whitespace().next().map(str::parse::<u64>) else {
            continue;
        };
        ns += n;
    }
    Some(ns as f64 * 1e-9)
}

/// The state of a render after an iteration.
struct Rendered {
    iteration: u64,
    /// Cumulative rendering seconds, wall clock.
    seconds: f64,
    /// Cumulative rendering seconds, CPU time of all threads.
    cpu_seconds: Option<f64>,
    /// The film of RGB estimates.
    film: Film,
    /// A film of the luminance of the same estimates (in every channel),
    /// for the noise on luminance: the RGB film's per-channel variances do
    /// not give the luminance's, which needs their covariances.
    luminance: Film,
}

impl Rendered {
    /// Before the first iteration.
    fn start(renderer: &Renderer) -> Self {
        Self {
            iteration: 0,
            seconds: 0.0,
            cpu_seconds: Some(0.0),
            film: renderer.new_film(),
            luminance: renderer.new_film(),
        }
    }

    /// Per-pixel sample variance s^2 of the luminance estimates.
    fn luminance_variance(&self) -> Vec<f64> {
        self.luminance.variance().iter().map(|v| v.x).collect()
    }
}

/// What a render records besides its films: the curve's points at the
/// marks (iterations 1, 2, 4, ...; none for a reference) and a checkpoint
/// every interval.
struct Tracker<'a> {
    /// The state the render starts from (taken when it starts).
    start: Option<Rendered>,
    marks: Vec<u64>,
    references: &'a [Reference],
    points: Vec<Point>,
    /// None once a save failed: the render goes on without checkpoints.
    checkpoints: Option<Checkpoints>,
    /// NaN/Inf samples dropped before the checkpoint resumed from (the
    /// renderer counts only its own).
    invalid_before: u64,
}

impl<'a> Tracker<'a> {
    fn new(
        marks: Vec<u64>,
        references: &'a [Reference],
        checkpoints: Checkpoints,
        resumed: Option<Resumed>,
    ) -> Self {
        let (start, invalid_before, points) = match resumed {
            Some(r) => (Some(r.state), r.invalid_samples, r.points),
            None => (None, 0, Vec::new()),
        };
        Self {
            start,
            marks,
            references,
            points,
            checkpoints: Some(checkpoints),
            invalid_before,
        }
    }

    /// NaN/Inf samples dropped over the whole render.
    fn invalid_samples(&self, renderer: &Renderer) -> u64 {
        self.invalid_before + renderer.invalid_samples()
    }

    /// After iteration `state.iteration`: a point at a mark; a checkpoint
    /// when one is due, except after the last iteration (the render's
    /// cache entry follows at once).
    fn record(&mut self, state: &Rendered, renderer: &Renderer, last: bool, progress: &Progress) {
        if self.marks.contains(&state.iteration) {
            self.points.push(Point::of(state, self.references));
        }
        if last {
            return;
        }
        let invalid = self.invalid_samples(renderer);
        if let Some(c) = self.checkpoints.as_mut().filter(|c| c.due())
            && let Err(e) = c.save(state, invalid, &self.points)
        {
            progress.println(&format!(
                "warning: no more checkpoints of this render (it goes on): {e}"
            ));
            self.checkpoints = None;
        }
    }
}

/// Renders iterations up to `iterations`, from the tracker's start state
/// (else from the first iteration), letting it record after each. Only
/// `render_iteration` and the RGB film's `add_iteration` are timed.
fn render(
    renderer: &Renderer,
    iterations: u64,
    tracker: &mut Tracker<'_>,
    progress: &mut Progress,
    label: &str,
) -> Rendered {
    let mut state = tracker
        .start
        .take()
        .unwrap_or_else(|| Rendered::start(renderer));
    let pixels = state.film.width() as usize * state.film.height() as usize;
    let mut estimates = vec![Vec3::ZERO; pixels];
    let mut luminance = vec![Vec3::ZERO; pixels];
    let bar = progress.start(label, iterations, state.iteration);
    let seconds_before = state.seconds;
    let mut elapsed = Duration::ZERO;
    for n in state.iteration + 1..=iterations {
        let cpu_before = cpu_seconds();
        let t = Instant::now();
        renderer.render_iteration(n, &mut estimates);
        state.film.add_iteration(&estimates);
        elapsed += t.elapsed();
        state.cpu_seconds = match (state.cpu_seconds, cpu_before, cpu_seconds()) {
            (Some(sum), Some(before), Some(after)) => Some(sum + (after - before).max(0.0)),
            _ => None,
        };
        for (l, e) in luminance.iter_mut().zip(&estimates) {
            *l = Vec3::splat(metrics::luminance(*e) as f32);
        }
        state.luminance.add_iteration(&luminance);
        state.iteration = n;
        state.seconds = seconds_before + elapsed.as_secs_f64();
        tracker.record(&state, renderer, n == iterations, progress);
        progress.advance(&bar, label, n, iterations, state.seconds);
    }
    bar.finish_and_clear();
    state
}

#[cfg(test)]
mod tests {
    use super::*;

    fn root() -> PathBuf {
        crate::workspace_root()
    }

    /// The automatic unbiased reference: VCM where a specular surface makes
    /// SDS paths (caustic-glass: a point light through smooth glass), BPT
    /// elsewhere (glossy-caustic: alpha 0.02, no delta lobe).
    #[test]
    fn unbiased_reference_follows_the_scene() {
        for (name, expected) in [
            ("caustic-glass", "vcm"),
            ("caustic-through-glass", "vcm"),
            ("glossy-cornell-glass", "vcm"),
            ("glossy-caustic", "bpt"),
            ("cornell-box", "bpt"),
        ] {
            let scene = scene::load(
                &root().join("scenes").join(name).join("scene.toml"),
                &LoadOptions::default(),
            )
            .unwrap();
            let (config, why) = unbiased_reference(Unbiased::Auto, &scene).unwrap();
            assert_eq!(config.to_string(), expected, "{name}: {why}");
            assert!(why.starts_with("auto"), "{why}");
        }
        let scene = scene::load(
            &root().join("scenes/cornell-box/scene.toml"),
            &LoadOptions::default(),
        )
        .unwrap();
        assert!(unbiased_reference(Unbiased::Skip, &scene).is_none());
    }

    /// Every flag that changes a config's render or its errors changes
    /// its run-cache key; the output folder does not.
    #[test]
    fn run_keys_follow_the_flags() {
        let key = |extra: &[&str], references: &[&str]| {
            let args: Vec<String> = ["--scene", "scenes/glossy-caustic", "--configs", "bpt-reg"]
                .iter()
                .chain(extra)
                .map(|s| s.to_string())
                .collect();
            let Ok(Parsed::Run(options)) = Options::parse(&root(), &args) else {
                panic!("{args:?}")
            };
            let (_, settings) = load_scene(&options).unwrap();
            let references: Vec<String> = references.iter().map(|r| r.to_string()).collect();
            run_jobs(&options, &settings, &references, (1, "v")).unwrap()[0]
                .key
                .clone()
        };
        let base = key(&[], &["a", "b"]);
        assert_eq!(base, key(&["--out", "elsewhere"], &["a", "b"]));
        assert_ne!(base, key(&[], &["a"]));
        assert_ne!(base, key(&[], &["a", "c"]));
        for extra in [
            &["--seed", "2"][..],
            &["--tau0", "7.5"],
            &["--sweep", "tau0=2"],
            &["--sweep", "schedule-exponent=0.25"],
            &["--iterations", "3"],
            &["--resolution", "8x4"],
            &["--configs", "bpt-uns"],
        ] {
            assert_ne!(base, key(extra, &["a", "b"]), "{extra:?}");
        }
    }

    /// A render killed during iteration 3 (its last checkpoint after
    /// iteration 2) and resumed ends with the same film sums, RGB and
    /// luminance, bit for bit, and the same curve as one never interrupted;
    /// its times go on from the checkpoint's.
    #[test]
    fn a_resumed_render_equals_an_uninterrupted_one() {
        let scene = scene::load(
            &root().join("scenes/glossy-caustic/scene.toml"),
            &LoadOptions {
                resolution: Some(glam::UVec2::new(16, 12)),
                ..Default::default()
            },
        )
        .unwrap();
        let config = Config::parse("bpt-uns").unwrap();
        let renderer = Renderer::new(scene, config.render_config(5, 8, 30.0).unwrap());
        let dir = std::env::temp_dir().join(format!("xtask-study-resume-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        let header = image_io::film_file::FilmHeader {
            scene: "glossy-caustic".into(),
            scene_hash: 1,
            settings: "k bpt-uns".into(),
            seed: 5,
            first: 1,
            last: 1,
            width: 16,
            height: 12,
            render_millis: None,
        };
        let checkpoints = |every| Checkpoints::new(&dir, "k", every, header.clone());
        let hour = Duration::from_secs(3600);
        let marks = metrics::checkpoints(8);
        let mut progress = Progress::new(0);
        let mut whole = Tracker::new(marks.clone(), &[], checkpoints(hour), None);
        let uninterrupted = render(&renderer, 8, &mut whole, &mut progress, "whole");
        assert!(!dir.exists(), "no checkpoint is due within the hour");
        // Iterations 1..=3, a checkpoint after every one but the last.
        let mut killed = Tracker::new(marks.clone(), &[], checkpoints(Duration::ZERO), None);
        render(&renderer, 3, &mut killed, &mut progress, "killed");
        let resumed = checkpoints(hour).load(0).unwrap().unwrap();
        assert_eq!(resumed.state.iteration, 2);
        let checkpoint_seconds = resumed.state.seconds;
        let mut rest = Tracker::new(marks, &[], checkpoints(hour), Some(resumed));
        let finished = render(&renderer, 8, &mut rest, &mut progress, "resumed");
        assert_eq!(finished.film.sums(), uninterrupted.film.sums());
        assert_eq!(finished.luminance.sums(), uninterrupted.luminance.sums());
        assert_eq!(finished.film.iterations(), 8);
        let curve = |points: &[Point]| -> Vec<(u64, Option<(u64, u64)>)> {
            points
                .iter()
                .map(|p| {
                    let noise = p
                        .noise
                        .map(|n| (n.std_error.to_bits(), n.variance.to_bits()));
                    (p.iteration, noise)
                })
                .collect()
        };
        assert_eq!(curve(&rest.points), curve(&whole.points));
        assert_eq!(rest.points.len(), 4, "iterations 1, 2, 4, 8");
        assert!(finished.seconds > checkpoint_seconds);
        assert!(rest.points[2].seconds > checkpoint_seconds);
        fs::remove_dir_all(dir).unwrap();
    }

    /// A whole study on a tiny image with a tau0 sweep: every output file
    /// appears, the references come from the cache the second time, the
    /// curves have one row per config x checkpoint x reference, and the
    /// report leads with the goal table and the bias against the unbiased
    /// reference; without an unbiased reference it says so.
    #[test]
    fn tiny_study_writes_every_output_and_caches_the_reference() {
        let out = std::env::temp_dir().join(format!("xtask-study-run-{}", std::process::id()));
        let _ = fs::remove_dir_all(&out);
        let args: Vec<String> = [
            "--scene",
            "scenes/glossy-caustic",
            "--resolution",
            "16x12",
            "--iterations",
            "3",
            "--reference-iterations",
            "4",
            "--configs",
            "bpt,bpt-reg",
            "--sweep",
            "tau0=2,30",
            "--unbiased-reference",
            "bpt",
            "--seed",
            "424242",
            "--out",
            out.to_str().unwrap(),
            "--cache",
            out.join("cache").to_str().unwrap(),
        ]
        .iter()
        .map(|s| s.to_string())
        .collect();
        let cache = out.join("cache");
        run(&root(), &args).unwrap();
        for file in [
            "curves.csv",
            "curves.json",
            "report.md",
            "rmse-vs-time.svg",
            "rmse-vs-time.png",
            "relmse-vs-time.svg",
            "noise-vs-iterations.svg",
            "rmse-vs-time-regularized.svg",
            "contact-sheet.png",
            "bias.png",
            "images/reference-regularized-vcm-reg.exr",
            "images/reference-unbiased-bpt.exr",
            "images/bpt-reg@tau0=2.exr",
            "images/bpt-reg@tau0=30.exr",
        ] {
            assert!(out.join(file).is_file(), "{file}");
        }
        let csv = fs::read_to_string(out.join("curves.csv")).unwrap();
        // Checkpoints 1, 2, 3; three configs; two references; plus the header.
        assert_eq!(csv.lines().count(), 1 + 3 * 3 * 2, "{csv}");
        let report = fs::read_to_string(out.join("report.md")).unwrap();
        // The goal table, first, against the unbiased reference: one row
        // per swept config, each against bpt's final RMSE.
        let goal = report
            .find("## Time to reach the unregularized RMSE")
            .unwrap();
        assert!(goal < report.find("## Metrics").unwrap(), "{report}");
        assert!(
            report[goal..].starts_with(
                "## Time to reach the unregularized RMSE\n\nAgainst the unbiased (bpt x 4)"
            ),
            "{report}"
        );
        for config in ["bpt-reg@tau0=2", "bpt-reg@tau0=30"] {
            assert!(
                report.contains(&format!("| {config} | bpt | 3 |")),
                "{report}"
            );
        }
        assert!(report.contains("| sweep | tau0 = 2, 30 |"), "{report}");
        assert!(
            report.contains("| unbiased reference | bpt (given by --unbiased-reference) |"),
            "{report}"
        );
        let bias = report.find("## Bias of regularization").unwrap();
        assert!(bias < report.find("## Metrics").unwrap(), "{report}");
        assert!(report.contains("| RMSE of d |"), "{report}");
        assert!(report.contains("| mean of d |"), "{report}");
        assert!(
            report.contains("![bias of regularization](bias.png)"),
            "{report}"
        );
        let json: serde_json::Value =
            serde_json::from_str(&fs::read_to_string(out.join("curves.json")).unwrap()).unwrap();
        // The CPU-time chart needs CPU times above zero: the kernel may
        // account a thread's time only at scheduler ticks, so iterations of
        // a few microseconds can all measure 0 s (seen in 1 of 8 runs).
        let cpu_measured = json["rows"]
            .as_array()
            .unwrap()
            .iter()
            .any(|r| r["cpu_seconds"].as_f64().is_some_and(|t| t > 0.0));
        assert_eq!(
            out.join("rmse-vs-cpu-time.svg").is_file(),
            cpu_measured,
            "the CPU-time chart exactly when CPU times were measured"
        );
        assert_eq!(
            json["time_to_unregularized_rmse"].as_array().unwrap().len(),
            4
        );
        assert!(json["bias_of_regularization"]["rmse"].as_f64().unwrap() > 0.0);
        assert!(report.contains("no: rendered in this run"), "{report}");
        assert!(!report.contains("from the cache"), "{report}");
        // --replot redraws every chart from curves.json alone, the same.
        let charts: Vec<(PathBuf, String)> = fs::read_dir(&out)
            .unwrap()
            .map(|e| e.unwrap().path())
            .filter(|p| p.extension().is_some_and(|x| x == "svg"))
            .map(|p| (p.clone(), fs::read_to_string(&p).unwrap()))
            .collect();
        assert!(charts.len() >= 5, "{charts:?}");
        for (path, _) in &charts {
            fs::remove_file(path).unwrap();
        }
        let replot = ["--replot".to_string(), out.to_str().unwrap().to_string()];
        run(&root(), &replot).unwrap();
        for (path, svg) in &charts {
            assert_eq!(
                &fs::read_to_string(path).unwrap(),
                svg,
                "{}",
                path.display()
            );
        }
        let files = |dir: &Path| {
            fs::read_dir(dir)
                .unwrap()
                .filter(|e| e.as_ref().unwrap().path().is_file())
                .count()
        };
        assert_eq!(files(&cache), 4, "two EXR + JSON pairs");
        assert_eq!(files(&runs::folder(&cache)), 6, "three EXR + JSON pairs");
        assert!(!cache.join("partial").exists(), "no checkpoint is left");
        run(&root(), &args).unwrap();
        let report = fs::read_to_string(out.join("report.md")).unwrap();
        assert!(report.contains("yes: from the cache"), "{report}");
        assert!(!report.contains("rendered in this run"), "{report}");
        assert!(
            report.contains(
                "From the run cache (rendered by an earlier run of this study, with its times): \
                 bpt, bpt-reg@tau0=2, bpt-reg@tau0=30."
            ),
            "{report}"
        );
        // --fresh renders everything again: references and configs.
        let fresh: Vec<String> = args.iter().cloned().chain(["--fresh".into()]).collect();
        run(&root(), &fresh).unwrap();
        let report = fs::read_to_string(out.join("report.md")).unwrap();
        assert!(!report.contains("from the cache"), "{report}");
        assert!(!report.contains("From the run cache"), "{report}");
        let mut without: Vec<String> = args.clone();
        let i = without
            .iter()
            .position(|a| a == "--unbiased-reference")
            .unwrap();
        without[i + 1] = "none".into();
        fs::remove_file(out.join("bias.png")).unwrap();
        run(&root(), &without).unwrap();
        let report = fs::read_to_string(out.join("report.md")).unwrap();
        assert!(report.contains("(No unbiased reference"), "{report}");
        assert!(
            report.contains("Against the regularized (vcm-reg x 4)"),
            "{report}"
        );
        assert!(!out.join("bias.png").exists());
        fs::remove_dir_all(out).unwrap();
    }
}
