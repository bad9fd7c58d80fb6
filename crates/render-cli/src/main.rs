//! `render-cli`: arguments -> scene -> integrator -> OpenEXR + PNG preview.
//!
//! A thin driver in the manner of pbrt-v4's and Mitsuba's command lines: it
//! parses flags ([`cli`], with the value checks of [`values`]), loads the
//! scene, resolves the render settings (flag, else manifest, else default:
//! [`settings`]), optionally explains them ([`explain`]), runs the
//! progressive loop ([`render`]) in a rayon pool of the requested size,
//! saving and resuming a checkpoint if asked ([`checkpoint`]), and writes the
//! mean image ([`outputs`]). It contains no light transport. Every
//! error is one line on stderr (`error: ...`) naming the file and key, or the
//! flag, and no partial image is left behind.

mod checkpoint;
mod cli;
mod error;
mod explain;
mod merge;
mod outputs;
mod render;
mod scene_options;
mod settings;
mod shard;
mod values;

use std::io::Write;
use std::process::ExitCode;

use clap::Parser;
use image_io::film_file::FilmHeader;
use image_io::{ImageError, write_exr, write_png};
use integrators::Renderer;
use scene::SceneError;

use crate::checkpoint::{Checkpoint, CheckpointError};
use crate::cli::Cli;
use crate::error::ArgError;
use crate::outputs::Outputs;
use crate::render::{INTERRUPTED_EXIT_CODE, Outcome};
use crate::settings::{Budget, Settings};

/// Why a render failed; `Display` is the one line printed after `error: `.
#[derive(Debug, thiserror::Error)]
enum Error {
    #[error(transparent)]
    Args(#[from] ArgError),
    #[error(transparent)]
    Scene(#[from] SceneError),
    #[error("--threads: cannot start the worker threads: {0}")]
    ThreadPool(#[from] rayon::ThreadPoolBuildError),
    /// The image error names the file.
    #[error("cannot write {0}")]
    Write(ImageError),
    #[error("interrupted before the first iteration completed; nothing written")]
    InterruptedEarly,
    #[error(
        "interrupted after {0} of the range's iterations: a partial film holds its whole range, so nothing was written"
    )]
    InterruptedPartial(u64),
    #[error(transparent)]
    Checkpoint(#[from] CheckpointError),
    /// A failure after which the checkpoint holds the render's iterations.
    #[error(
        "{error}; checkpoint {} holds iterations {first}..={last}: run the same command again to finish",
        checkpoint.display()
    )]
    Kept {
        error: Box<Error>,
        checkpoint: std::path::PathBuf,
        first: u64,
        last: u64,
    },
    #[error(transparent)]
    Film(#[from] image_io::film_file::FilmFileError),
    /// The film would not fit in the available memory.
    #[error("{0}")]
    Memory(String),
}

impl Error {
    /// Whether the render ended by an interrupt (exit code 130).
    fn is_interrupt(&self) -> bool {
        match self {
            Self::InterruptedEarly | Self::InterruptedPartial(_) => true,
            Self::Kept { error, .. } => error.is_interrupt(),
            _ => false,
        }
    }
}

fn main() -> ExitCode {
    let args: Vec<std::ffi::OsString> = std::env::args_os().collect();
    if args.get(1).is_some_and(|a| a == "merge") {
        return merge::main(&args[1..]);
    }
    let cli = match Cli::try_parse_from(&args) {
        Ok(cli) => cli,
        // --help and --version: printed to stdout, success.
        Err(e) if !e.use_stderr() => {
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) => {
            eprintln!("{}", cli::one_line(&e));
            return ExitCode::from(2);
        }
    };
    match run(&cli) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("error: {e}");
            if e.is_interrupt() {
                ExitCode::from(INTERRUPTED_EXIT_CODE)
            } else {
                ExitCode::FAILURE
            }
        }
    }
}

/// Everything after argument parsing; returns the exit code of a render that
/// wrote its image (0, or 130 if it was interrupted).
fn run(cli: &Cli) -> Result<ExitCode, Error> {
    // Checks that need no scene come first, so that a typo fails in milliseconds.
    let outputs = cli.outputs()?;
    let camera = cli.camera_override()?;
    // Locked and read before the scene is loaded: a checkpoint in use or
    // damaged is refused at once.
    let mut checkpoint = match &cli.checkpoint {
        Some(path) => Some(Checkpoint::open(
            path,
            cli.checkpoint_every.unwrap_or(checkpoint::DEFAULT_INTERVAL),
        )?),
        None => None,
    };

    let mut scene = load_quietly(&cli.scene, &cli.load_options()?)?;
    for warning in &scene.report.warnings {
        eprintln!("warning: {warning}");
    }
    let settings = Settings::resolve(cli, &scene.render, &cli.scene)?;
    if let Some(camera) = camera {
        scene.camera = camera.camera(scene.camera.resolution)?;
    }

    // A film allocation that fails aborts the process: check before taking it.
    let resolution = scene.camera.resolution;
    let source = if cli.resolution.is_some() {
        "--resolution".to_owned()
    } else if (cli.scene.extension()).is_some_and(|e| e.eq_ignore_ascii_case("toml")) {
        format!("{}: resolution", cli.scene.display())
    } else {
        "the default resolution".to_owned()
    };
    let size = (resolution.x, resolution.y);
    let film = ("film", settings::film_bytes(resolution.x, resolution.y));
    // A sphere costs a BVH slot like a triangle.
    let primitives = (scene.triangles.len() + scene.spheres.len()) as u64;
    let bvh = primitives * integrators::BVH_BUILD_BYTES_PER_TRIANGLE;
    settings::check_memory(
        &[film, ("BVH", bvh)],
        size,
        &source,
        settings::available_memory(),
    )
    .map_err(Error::Memory)?;

    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(cli.threads.unwrap_or(0))
        .build()?;
    render::install_interrupt_handler();
    // The BVH build and every iteration run in the pool, so --threads bounds both.
    let (film, outcome, header) = pool.install(|| {
        let renderer = Renderer::new(scene, settings.config);
        // The photon map is measured with a few pilot light subpaths once the
        // BVH exists (it is taken anew every iteration).
        let photons = renderer.photon_map_bytes();
        if photons > 0 {
            let needs = [film, ("photon map", photons)];
            settings::check_memory(&needs, size, &source, settings::available_memory())
                .map_err(Error::Memory)?;
        }
        let first = settings.first_iteration;
        let header = shard::header(&cli.scene, renderer.scene(), &settings.config, first, first);
        let resumed = match &mut checkpoint {
            Some(c) => c.resume(header.clone(), settings.budget.value)?,
            None => None,
        };
        if let (Some(c), Some(r)) = (&checkpoint, &resumed) {
            eprintln!("{}", resuming_line(c, r, first, settings.budget.value));
        }
        if cli.explain {
            print_explanation(cli, &renderer, &settings, &outputs);
        }
        let (mut film, rendered_before) = match resumed {
            Some(r) => (r.film, r.rendered),
            None => (renderer.new_film(), std::time::Duration::ZERO),
        };
        let prepared = prepare_energy_tables(&renderer, first + film.iterations());
        let outcome = render::progressive(
            &renderer,
            &mut film,
            settings.budget.value,
            first,
            rendered_before,
            checkpoint.as_mut(),
        )?;
        let built_in_render = renderer.energy_tables_built() - prepared;
        if built_in_render > 0 {
            eprintln!(
                "energy compensation: {built_in_render} tables were built at first use, during \
                 the render, whose time and rate include them (`unsampleable` widens a lobe \
                 only on paths that no technique samples, found while rendering)"
            );
        }
        let invalid = renderer.invalid_samples();
        if invalid > 0 {
            eprintln!("warning: {invalid} samples were NaN or infinite and were replaced by 0");
        }
        let last = first + film.iterations().max(1) - 1;
        let header = FilmHeader { last, ..header };
        Ok::<_, Error>((film, outcome, header))
    })?;
    if film.iterations() == 0 {
        return Err(Error::InterruptedEarly);
    }

    render::begin_writing();
    let written = write_outputs(&outputs, settings.budget.value, &film, &outcome, &header);
    match checkpoint {
        Some(c) => finish_checkpoint(c, written, cli.keep_checkpoint, &film, &outcome, &header),
        None => written,
    }
}

/// After the outputs were `written` (or not): removes the checkpoint of a
/// finished render, whose image is there. Otherwise (interrupted, the image
/// could not be written, or `keep`) saves every iteration in it, and an
/// error says that it holds them.
fn finish_checkpoint(
    mut checkpoint: Checkpoint,
    written: Result<ExitCode, Error>,
    keep: bool,
    film: &integrators::Film,
    outcome: &Outcome,
    header: &FilmHeader,
) -> Result<ExitCode, Error> {
    if written.is_ok() && !outcome.interrupted && !keep {
        checkpoint.remove();
        return written;
    }
    let saved = checkpoint.save(film, outcome.rendered);
    if saved.is_ok() && written.is_ok() && outcome.interrupted {
        eprintln!(
            "checkpoint {} holds iterations {}..={}: run the same command again to finish",
            checkpoint.path().display(),
            header.first,
            header.first + checkpoint.saved() - 1
        );
    }
    match written {
        // The image is there; a checkpoint that was to be kept but failed is the error.
        Ok(code) => saved.map(|()| code).map_err(Error::from),
        // What could not be written is the error; the checkpoint, this
        // one or the previous one, holds the render.
        Err(error) if checkpoint.saved() > 0 => Err(Error::Kept {
            error: Box::new(error),
            checkpoint: checkpoint.path().to_owned(),
            first: header.first,
            last: header.first + checkpoint.saved() - 1,
        }),
        Err(error) => Err(error),
    }
}

/// Writes the image and its preview, or the partial film of `header`'s
/// range; the exit code.
fn write_outputs(
    outputs: &Outputs,
    budget: Budget,
    film: &integrators::Film,
    outcome: &Outcome,
    header: &FilmHeader,
) -> Result<ExitCode, Error> {
    let resolution = (film.width(), film.height());
    if let Some(path) = &outputs.partial {
        if outcome.interrupted {
            return Err(Error::InterruptedPartial(
                outcome.resumed + outcome.iterations,
            ));
        }
        let (sum, sum_sq) = film.sums();
        image_io::film_file::write_sums(path, header, film.iterations(), sum, sum_sq)?;
        eprintln!(
            "{} (iterations {})",
            summary(outcome, budget, resolution, outputs),
            header.range()
        );
        return Ok(ExitCode::SUCCESS);
    }
    let (width, height) = resolution;
    let pixels = film.mean();
    write_exr(&outputs.exr, width, height, &pixels).map_err(Error::Write)?;
    if let Some(png) = &outputs.png {
        write_png(png, width, height, &pixels, outputs.exposure).map_err(Error::Write)?;
    }
    eprintln!("{}", summary(outcome, budget, resolution, outputs));
    Ok(if outcome.interrupted {
        ExitCode::from(INTERRUPTED_EXIT_CODE)
    } else {
        ExitCode::SUCCESS
    })
}

/// The line of a resumed render, e.g. `resuming from c.rltfilm: iterations
/// 1..=40 of 64 done` (of a range `65..=128 of 65..=192`; with a time
/// budget, `in 12.3 of 60 s`).
fn resuming_line(
    checkpoint: &Checkpoint,
    resumed: &checkpoint::Resumed,
    first: u64,
    budget: Budget,
) -> String {
    let done = resumed.film.iterations();
    let range = format!("{first}..={}", first + done - 1);
    let of = match budget {
        Budget::Iterations(total) if first == 1 => format!("of {total} "),
        Budget::Iterations(total) => format!("of {first}..={} ", first + total - 1),
        Budget::Time(limit) => format!(
            "in {:.1} of {} s ",
            resumed.rendered.as_secs_f64(),
            limit.as_secs_f64()
        ),
    };
    format!(
        "resuming from {}: iterations {range} {of}done",
        checkpoint.path().display()
    )
}

/// Builds the energy-compensation tables that the first iteration will read
/// (`Renderer::reads_energy_tables`) now, in parallel and outside the render
/// loop, so that a `--time` budget measures rendering alone; says so on
/// stderr, since it takes seconds. Returns how many of the scene's tables
/// are built before the render (`Renderer::energy_tables_built`): the
/// others are left to first use, inside an iteration, which the caller
/// reports after the render.
fn prepare_energy_tables(renderer: &Renderer, first: u64) -> usize {
    if !renderer.reads_energy_tables(first) {
        return renderer.energy_tables_built();
    }
    let start = std::time::Instant::now();
    let tables = renderer.prepare_energy_tables();
    eprintln!(
        "energy compensation: {tables} tables ready in {:.1} s (once per run; \
         `--regularize-energy off` renders without them)",
        start.elapsed().as_secs_f64()
    );
    tables
}

/// `scene::load` without the panic hook's message: the loaders turn a panic
/// of a third-party reader into a one-line error, which is all the user
/// should see (no other thread runs yet, so swapping the process-wide hook
/// affects nothing else).
fn load_quietly(
    path: &std::path::Path,
    options: &scene::LoadOptions,
) -> Result<scene::Scene, SceneError> {
    let hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let loaded = scene::load(path, options);
    std::panic::set_hook(hook);
    loaded
}

/// `--explain`: the scene, what the integrator does with it, the settings.
/// Written in one piece, and a closed stdout (`| head`) is not an error.
fn print_explanation(cli: &Cli, renderer: &Renderer, settings: &Settings, outputs: &Outputs) {
    let (width, height) = renderer.resolution();
    let mut text = format!("scene:            {}\n", cli.scene.display());
    text += &format!("{}\n", renderer.features());
    for line in &renderer.scene().report.ignored {
        text += &format!("ignored:          {line}\n");
    }
    text += &format!("{}\n", explain::integrator(renderer).trim_end());
    if let Some(line) = explain::environment(renderer, cli.env.is_some()) {
        text += &format!("{line}\n");
    }
    text += &explain::settings(settings);
    text += &format!("resolution:       {width}x{height}\n");
    text += &format!("threads:          {}\n", rayon::current_num_threads());
    if outputs.png.is_some() {
        text += &format!("png exposure:     {} stops\n", outputs.exposure);
    }
    if let Some(path) = &cli.checkpoint {
        let every = cli.checkpoint_every.unwrap_or(checkpoint::DEFAULT_INTERVAL);
        text += &format!(
            "checkpoint:       {} (every {} s)\n",
            path.display(),
            every.as_secs_f64()
        );
    }
    text += &format!("output:           {}\n", file_list(outputs));
    let mut stdout = std::io::stdout().lock();
    let _ = stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush());
}

/// The last line on stderr, e.g. `rendered 64 iterations of 256x256 in 3.21 s
/// (19.9 it/s, 1.30 Msamples/s) -> render.exr, render.png`; counts and rates
/// are this run's, and a resumed render says how many it continued.
fn summary(outcome: &Outcome, budget: Budget, (w, h): (u32, u32), outputs: &Outputs) -> String {
    let n = outcome.iterations;
    let seconds = outcome.elapsed.as_secs_f64().max(1e-9);
    let rates = format!(
        "{:.1} it/s, {:.2} Msamples/s",
        n as f64 / seconds,
        n as f64 * f64::from(w) * f64::from(h) / seconds * 1e-6
    );
    let resumed = match outcome.resumed {
        0 => String::new(),
        r => format!(" after the checkpoint's {r} ({} in all)", r + n),
    };
    let files = file_list(outputs);
    if !outcome.interrupted {
        return format!(
            "rendered {n} iterations{resumed} of {w}x{h} in {seconds:.2} s ({rates}) -> {files}"
        );
    }
    let done = outcome.resumed + n;
    let planned = match budget {
        Budget::Iterations(total) => format!("{done} of {total} iterations"),
        Budget::Time(t) => format!(
            "{done} iterations ({:.2} of {} s)",
            outcome.rendered.as_secs_f64(),
            t.as_secs_f64()
        ),
    };
    format!("interrupted after {planned} of {w}x{h} in {seconds:.2} s ({rates}); wrote {files}")
}

fn file_list(outputs: &Outputs) -> String {
    if let Some(partial) = &outputs.partial {
        return partial.display().to_string();
    }
    let mut files = outputs.exr.display().to_string();
    if let Some(png) = &outputs.png {
        files.push_str(", ");
        files.push_str(&png.display().to_string());
    }
    files
}
