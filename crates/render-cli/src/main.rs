//! `render-cli`: arguments -> scene -> integrator -> OpenEXR + PNG preview.
//!
//! A thin driver in the manner of pbrt-v4's and Mitsuba's command lines: it
//! parses flags ([`cli`], with the value checks of [`values`]), loads the
//! scene, resolves the render settings (flag, else manifest, else default:
//! [`settings`]), optionally explains them ([`explain`]), runs the
//! progressive loop ([`render`]) in a rayon pool of the requested size, and
//! writes the mean image ([`outputs`]). It contains no light transport. Every
//! error is one line on stderr (`error: ...`) naming the file and key, or the
//! flag, and no partial image is left behind.

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
use image_io::{ImageError, write_exr, write_png};
use integrators::Renderer;
use scene::SceneError;

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
    Film(#[from] image_io::film_file::FilmFileError),
    /// The film would not fit in the available memory.
    #[error("{0}")]
    Memory(String),
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
            match e {
                Error::InterruptedEarly | Error::InterruptedPartial(_) => {
                    ExitCode::from(INTERRUPTED_EXIT_CODE)
                }
                _ => ExitCode::FAILURE,
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
        if cli.explain {
            print_explanation(cli, &renderer, &settings, &outputs);
        }
        let first = settings.first_iteration;
        let prepared = prepare_energy_tables(&renderer, first);
        let mut film = renderer.new_film();
        let outcome = render::progressive(&renderer, &mut film, settings.budget.value, first);
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
        let last = first + outcome.iterations.max(1) - 1;
        let header = outputs
            .partial
            .as_ref()
            .map(|_| shard::header(&cli.scene, renderer.scene(), &settings.config, first, last));
        Ok::<_, Error>((film, outcome, header))
    })?;
    if outcome.iterations == 0 {
        return Err(Error::InterruptedEarly);
    }

    render::begin_writing();
    let resolution = (film.width(), film.height());
    if let (Some(path), Some(header)) = (&outputs.partial, header) {
        if outcome.interrupted {
            return Err(Error::InterruptedPartial(outcome.iterations));
        }
        let range = header.range();
        image_io::film_file::write(path, &shard::partial(header, &film))?;
        eprintln!(
            "{} (iterations {range})",
            summary(&outcome, settings.budget.value, resolution, &outputs)
        );
        return Ok(ExitCode::SUCCESS);
    }
    let (width, height) = resolution;
    let pixels = film.mean();
    write_exr(&outputs.exr, width, height, &pixels).map_err(Error::Write)?;
    if let Some(png) = &outputs.png {
        write_png(png, width, height, &pixels, outputs.exposure).map_err(Error::Write)?;
    }
    eprintln!(
        "{}",
        summary(&outcome, settings.budget.value, (width, height), &outputs)
    );
    Ok(if outcome.interrupted {
        ExitCode::from(INTERRUPTED_EXIT_CODE)
    } else {
        ExitCode::SUCCESS
    })
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
    text += &format!("output:           {}\n", file_list(outputs));
    let mut stdout = std::io::stdout().lock();
    let _ = stdout
        .write_all(text.as_bytes())
        .and_then(|()| stdout.flush());
}

/// The last line on stderr, e.g. `rendered 64 iterations of 256x256 in 3.21 s
/// (19.9 it/s, 1.30 Msamples/s) -> render.exr, render.png`.
fn summary(outcome: &Outcome, budget: Budget, (w, h): (u32, u32), outputs: &Outputs) -> String {
    let n = outcome.iterations;
    let seconds = outcome.elapsed.as_secs_f64().max(1e-9);
    let rates = format!(
        "{:.1} it/s, {:.2} Msamples/s",
        n as f64 / seconds,
        n as f64 * f64::from(w) * f64::from(h) / seconds * 1e-6
    );
    let files = file_list(outputs);
    if !outcome.interrupted {
        return format!(
            "rendered {n} iterations of {w}x{h} in {seconds:.2} s ({rates}) -> {files}"
        );
    }
    let planned = match budget {
        Budget::Iterations(total) => format!("{n} of {total} iterations"),
        Budget::Time(t) => format!("{n} iterations ({seconds:.2} of {} s)", t.as_secs_f64()),
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
