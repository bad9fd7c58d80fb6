//! Command-line arguments, and their resolution into the settings of one render.
//!
//! Precedence, highest first: a flag, the scene manifest's `[render]` table,
//! the built-in default. Flags are checked by clap as they are parsed (a bad
//! value is a usage error, exit code 2, naming the flag); manifest values are
//! checked here, when they are used, and an error names the manifest and the
//! field. A manifest value that a flag overrides is not looked at.

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Duration;

use clap::Parser;
use glam::{UVec2, Vec3};
use integrators::{
    Algorithm, DEFAULT_MAX_DEPTH, DEFAULT_TAU_0, Mode, Regularization, RenderConfig, Schedule,
    Strategies,
};
use scene::{Camera, LoadOptions, RenderSettings};

/// Iterations when neither a flag nor the manifest gives a count or a time.
pub const DEFAULT_ITERATIONS: u64 = 64;
/// Regularization mode when neither a flag nor the manifest gives one.
pub const DEFAULT_MODE: Mode = Mode::Selective;
/// Seed when neither a flag nor the manifest gives one.
pub const DEFAULT_SEED: u64 = 0;
/// Largest image side accepted by `--resolution`.
pub const MAX_RESOLUTION: u32 = 16384;
/// The OpenEXR file written without `--output`.
pub const DEFAULT_OUTPUT: &str = "render.exr";

const AFTER_LONG_HELP: &str = "\
Settings are taken from the flags, else from the scene manifest's [render] table, else from the \
defaults above; --explain shows where each one came from.

Progress goes to stderr (a bar on a terminal); the last line is always a summary such as
  rendered 64 iterations of 256x256 in 3.21 s (19.9 it/s, 1.30 Msamples/s) -> render.exr, render.png

Once rendering has started, Ctrl-C (or SIGTERM) stops after the current iteration and writes the \
mean of the iterations done so far; a second Ctrl-C quits at once without writing.

Exit status: 0 rendered; 1 error (one line on stderr: 'error: ...'); 2 invalid command line; \
130 interrupted (the image of the completed iterations was written, or nothing if none completed).

Examples:
  render-cli scenes/cornell-box/scene.toml
  render-cli scenes/glossy-caustic/scene.toml --time 60 --regularize uniform -o caustic.exr
  render-cli model.glb --camera Overview --resolution 1280x720 --exposure 1";

/// Renders a scene to a linear OpenEXR image and an sRGB PNG preview.
#[derive(Debug, Parser)]
#[command(
    name = "render-cli",
    version,
    about = "Renders a scene to a linear OpenEXR image and an sRGB PNG preview.",
    long_about = "Renders a scene to a linear OpenEXR image and an sRGB PNG preview, with \
                  microfacet model regularization (Jendersie & Grosch 2019) for caustics that \
                  plain path tracing cannot find.",
    after_long_help = AFTER_LONG_HELP,
    max_term_width = 100
)]
pub struct Cli {
    /// The scene: a scene.toml manifest, a glTF 2.0 file (.gltf, .glb) or a Wavefront .obj file.
    #[arg(value_name = "SCENE")]
    pub scene: PathBuf,

    /// Light-transport algorithm (--help lists them). [default: the manifest's, else pt]
    #[arg(long, value_name = "NAME", value_parser = parse_algorithm,
          long_help = algorithm_help(), help_heading = "Rendering")]
    pub integrator: Option<Algorithm>,

    /// Number of iterations (one sample per pixel each); the image is their mean.
    /// [default: the manifest's, else 64]
    #[arg(long, value_name = "N", value_parser = parse_iterations, allow_negative_numbers = true,
          conflicts_with = "time", help_heading = "Rendering")]
    pub iterations: Option<u64>,

    /// Render for this wall-clock time instead of a number of iterations, in seconds
    /// (fractions allowed). The last iteration may run past it; at least one always completes.
    #[arg(long, value_name = "SECONDS", value_parser = parse_time, allow_negative_numbers = true, help_heading = "Rendering")]
    pub time: Option<Duration>,

    /// Longest path, in segments (1: only light sources seen directly).
    /// [default: the manifest's, else 12]
    #[arg(long, value_name = "D", value_parser = parse_max_depth, allow_negative_numbers = true, help_heading = "Rendering")]
    pub max_depth: Option<u32>,

    /// Seed of every random stream: the same seed gives the same image for any thread count.
    /// [default: the manifest's, else 0]
    #[arg(
        long,
        value_name = "S",
        allow_negative_numbers = true,
        help_heading = "Rendering"
    )]
    pub seed: Option<u64>,

    /// Worker threads. [default: all cores, or RAYON_NUM_THREADS if set]
    #[arg(long, value_name = "K", value_parser = parse_threads, allow_negative_numbers = true, help_heading = "Rendering")]
    pub threads: Option<usize>,

    /// Print the scene's features, what the integrator will do with them and why, and every
    /// resolved setting with its origin (flag, manifest or default) on stdout; then render as
    /// usual.
    #[arg(long, help_heading = "Rendering")]
    pub explain: bool,

    /// Which vertices are regularized: off (none); uniform (every vertex gets tau_N);
    /// selective (tau_N scaled by the roughness of the path so far: what is seen directly or
    /// in mirrors stays sharp, a caustic seen on a diffuse surface is blurred).
    /// [default: the manifest's, else selective]
    #[arg(long, value_name = "MODE", value_parser = parse_regularize,
          help_heading = "Regularization")]
    pub regularize: Option<Mode>,

    /// Initial regularization bound tau_0, in 1/sr; must exceed 1/(2 pi) = 0.159. Smaller values
    /// blur more (tau_0 = 7.5 raises roughness to alpha = 0.103 at the first iteration).
    /// tau bounds the outgoing solid-angle density of a lobe (D/4 for reflection);
    /// implementations that bound D itself use 4x this value.
    /// [default: the manifest's, else 7.5]
    #[arg(long = "tau0", value_name = "TAU", value_parser = parse_tau0, allow_negative_numbers = true,
          help_heading = "Regularization")]
    pub tau0: Option<f64>,

    /// Keep tau at tau_0 in every iteration: a fixed blur, biased and not consistent. By default
    /// tau grows with the iteration count N (tau_N, cone radius ~ N^(-1/6)), so the blur vanishes
    /// as the render converges.
    #[arg(long, help_heading = "Regularization")]
    pub no_progressive: bool,

    /// Virtual merges (supp. §6) for bpt and vcm with regularization: a connection through a
    /// regularized vertex also counts as a merge inside the vertex's blur cone, which keeps
    /// the MIS weights of blurred connections low where merging does better.
    /// [default: on for vcm with regularization, off otherwise]
    #[arg(long, value_name = "on|off", value_parser = parse_on_off, help_heading = "Regularization")]
    pub virtual_merges: Option<bool>,

    /// First merge radius of ppm and vcm, as a fraction of the radius of the scene's bounding
    /// sphere; it shrinks as r_N = r_1 N^((alpha - 1)/2) with alpha = 0.75. [default: 0.003]
    #[arg(long, value_name = "FRACTION", value_parser = parse_radius, help_heading = "Rendering")]
    pub radius: Option<f32>,

    /// Russian roulette on the shadow rays of bpt and vcm's next-event estimation, vertex
    /// connections and light tracing (Veach 1997, §10.4.1): a contribution c below this
    /// fraction t of the mean pixel value (from a small path-traced preview) keeps its shadow
    /// ray with probability c / t and is scaled by t / c, so the image stays unbiased; 0 traces
    /// every shadow ray.
    /// [default: 0.1]
    #[arg(long, value_name = "FRACTION", value_parser = parse_shadow_roulette, allow_negative_numbers = true,
          help_heading = "Rendering")]
    pub shadow_roulette: Option<f32>,

    /// Image size in pixels, WIDTHxHEIGHT (e.g. 640x480), each in 1..=16384.
    /// [default: the manifest's, else 512 wide at the camera's aspect ratio]
    #[arg(long, value_name = "WxH", value_parser = parse_resolution, help_heading = "Camera")]
    pub resolution: Option<UVec2>,

    /// Use the glTF camera of this name. [default: the file's first camera]
    #[arg(
        long,
        value_name = "NAME",
        conflicts_with = "camera_from",
        help_heading = "Camera"
    )]
    pub camera: Option<String>,

    /// Replace the scene's camera: its position, in scene units. Needs --camera-at and --fov.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true,
          requires_all = ["camera_at", "fov"], help_heading = "Camera")]
    pub camera_from: Option<Vec3>,

    /// The point the replacement camera looks at, in scene units.
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true,
          requires = "camera_from", help_heading = "Camera")]
    pub camera_at: Option<Vec3>,

    /// The replacement camera's approximate up direction. [default: 0,1,0]
    #[arg(long, value_name = "X,Y,Z", value_parser = parse_vec3, allow_hyphen_values = true,
          requires = "camera_from", help_heading = "Camera")]
    pub camera_up: Option<Vec3>,

    /// The replacement camera's vertical field of view, in degrees, in (0, 180).
    #[arg(long, value_name = "DEG", value_parser = parse_fov, allow_negative_numbers = true, requires = "camera_from",
          help_heading = "Camera")]
    pub fov: Option<f32>,

    /// The linear (32-bit float RGB) OpenEXR file to write; must end in .exr, and its folder
    /// must exist. [default: render.exr]
    #[arg(short, long, value_name = "PATH", value_parser = parse_exr_path, help_heading = "Output")]
    pub output: Option<PathBuf>,

    /// Where to write the 8-bit sRGB PNG preview; must end in .png.
    /// [default: next to the EXR, same name with .png]
    #[arg(long, value_name = "PATH", value_parser = parse_png_path, conflicts_with = "no_png",
          help_heading = "Output")]
    pub png: Option<PathBuf>,

    /// Write no PNG preview.
    #[arg(long, help_heading = "Output")]
    pub no_png: bool,

    /// Exposure of the PNG preview, in stops: pixels are scaled by 2^STOPS before clamping to
    /// [0, 1] and the sRGB curve. The EXR is never scaled. [default: 0]
    #[arg(long, value_name = "STOPS", value_parser = parse_exposure, allow_hyphen_values = true,
          help_heading = "Output")]
    pub exposure: Option<f32>,
}

/// Where a setting's value came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// A command-line flag.
    Flag,
    /// The scene manifest's `[render]` table.
    Manifest,
    /// The built-in default.
    Default,
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Flag => "flag",
            Self::Manifest => "manifest",
            Self::Default => "default",
        })
    }
}

/// A setting's value and where it came from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Resolved<T> {
    /// The value.
    pub value: T,
    /// Its origin.
    pub origin: Origin,
}

/// When the progressive render stops.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Budget {
    /// After this many iterations (at least 1).
    Iterations(u64),
    /// At the end of the first iteration that ends after this much wall-clock time.
    Time(Duration),
}

impl fmt::Display for Budget {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Iterations(n) => write!(f, "{n} iterations"),
            Self::Time(t) => write!(f, "{} s", t.as_secs_f64()),
        }
    }
}

/// The resolved settings of one render, each with its origin (for `--explain`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settings {
    /// What the integrator is given.
    pub config: RenderConfig,
    /// When to stop.
    pub budget: Resolved<Budget>,
    /// Origin of `config.algorithm`.
    pub algorithm: Origin,
    /// Origin of `config.regularization.mode`.
    pub mode: Origin,
    /// Origin of tau_0.
    pub tau0: Origin,
    /// Origin of `config.max_depth`.
    pub max_depth: Origin,
    /// Origin of `config.seed`.
    pub seed: Origin,
}

/// The files a render writes.
#[derive(Clone, Debug, PartialEq)]
pub struct Outputs {
    /// The linear OpenEXR image.
    pub exr: PathBuf,
    /// The sRGB PNG preview, unless `--no-png`.
    pub png: Option<PathBuf>,
    /// Exposure of the preview, in stops.
    pub exposure: f32,
}

/// A camera given on the command line, replacing the scene's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct CameraOverride {
    from: Vec3,
    at: Vec3,
    up: Vec3,
    fov_degrees: f32,
}

impl CameraOverride {
    /// The camera at the scene's resolution.
    pub fn camera(&self, resolution: UVec2) -> Result<Camera, ArgError> {
        Camera::look_at(self.from, self.at, self.up, self.fov_degrees, resolution).map_err(
            |message| ArgError::Flag {
                flag: "--camera-from/--camera-at/--camera-up",
                message,
            },
        )
    }
}

/// A setting that is invalid, naming where it came from.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ArgError {
    /// A value of the manifest's `[render]` table.
    #[error(
        "{}: [render] {field}: {message} (set in the manifest; the {flag} flag overrides it)",
        manifest.display()
    )]
    Manifest {
        /// The manifest.
        manifest: PathBuf,
        /// The field.
        field: &'static str,
        /// The flag that would override it.
        flag: &'static str,
        /// What is wrong.
        message: String,
    },
    /// Flags that are well-formed but unusable (a missing folder, a degenerate camera).
    #[error("{flag}: {message}")]
    Flag {
        /// The flag or flags.
        flag: &'static str,
        /// What is wrong.
        message: String,
    },
}

impl Cli {
    /// Options for `scene::load`. `--camera` on an OBJ file is an error
    /// rather than silently ignored: OBJ files have no cameras.
    pub fn load_options(&self) -> Result<LoadOptions, ArgError> {
        let is_obj = (self.scene.extension()).is_some_and(|e| e.eq_ignore_ascii_case("obj"));
        if self.camera.is_some() && is_obj {
            return Err(ArgError::Flag {
                flag: "--camera",
                message: format!(
                    "{} is an OBJ file, which has no cameras (use --camera-from, --camera-at \
                     and --fov)",
                    self.scene.display()
                ),
            });
        }
        Ok(LoadOptions {
            camera_name: self.camera.clone(),
            resolution: self.resolution,
        })
    }

    /// The files to write; an error if a folder to write into does not exist.
    pub fn outputs(&self) -> Result<Outputs, ArgError> {
        let exr = self
            .output
            .clone()
            .unwrap_or_else(|| PathBuf::from(DEFAULT_OUTPUT));
        check_writable("--output", &exr)?;
        let png = if self.no_png {
            None
        } else if let Some(png) = &self.png {
            check_writable("--png", png)?;
            Some(png.clone())
        } else {
            Some(exr.with_extension("png"))
        };
        Ok(Outputs {
            exr,
            png,
            exposure: self.exposure.unwrap_or(0.0),
        })
    }

    /// The camera given by `--camera-from/--camera-at/--camera-up/--fov`, if
    /// any, checked now (at a placeholder resolution) so that a degenerate one
    /// fails before the scene is loaded.
    pub fn camera_override(&self) -> Result<Option<CameraOverride>, ArgError> {
        let (Some(from), Some(at), Some(fov_degrees)) =
            (self.camera_from, self.camera_at, self.fov)
        else {
            return Ok(None);
        };
        let camera = CameraOverride {
            from,
            at,
            up: self.camera_up.unwrap_or(Vec3::Y),
            fov_degrees,
        };
        camera.camera(UVec2::ONE)?;
        Ok(Some(camera))
    }

    /// The render settings: each flag, else the manifest's value (checked
    /// here; errors name `manifest`), else the default.
    pub fn resolve(
        &self,
        manifest: &RenderSettings,
        manifest_path: &Path,
    ) -> Result<Settings, ArgError> {
        let from_manifest = |field, flag| {
            move |message: String| ArgError::Manifest {
                manifest: manifest_path.to_path_buf(),
                field,
                flag,
                message,
            }
        };
        let algorithm = pick(
            self.integrator,
            manifest.integrator.as_deref(),
            Algorithm::default(),
            |s| parse_algorithm(s).map_err(from_manifest("integrator", "--integrator")),
        )?;
        let budget = match (self.iterations, self.time) {
            (Some(n), _) => flag(Budget::Iterations(n)),
            (None, Some(t)) => flag(Budget::Time(t)),
            (None, None) => pick(
                None,
                manifest.iterations,
                Budget::Iterations(DEFAULT_ITERATIONS),
                |n| {
                    at_least_one(u64::from(n))
                        .map(Budget::Iterations)
                        .map_err(from_manifest("iterations", "--iterations"))
                },
            )?,
        };
        let mode = pick(
            self.regularize,
            manifest.regularize.as_deref(),
            DEFAULT_MODE,
            |s| parse_regularize(s).map_err(from_manifest("regularize", "--regularize")),
        )?;
        let tau0 = pick(self.tau0, manifest.tau0, DEFAULT_TAU_0, |t| {
            check_tau0(t).map_err(from_manifest("tau0", "--tau0"))
        })?;
        let max_depth = pick(self.max_depth, manifest.max_depth, DEFAULT_MAX_DEPTH, |d| {
            at_least_one(u64::from(d))
                .map(|_| d)
                .map_err(from_manifest("max_depth", "--max-depth"))
        })?;
        let seed = pick(self.seed, manifest.seed, DEFAULT_SEED, Ok)?;
        let regularization = Regularization::new(mode.value, tau0.value, !self.no_progressive)
            .map_err(|e| match tau0.origin {
                Origin::Manifest => from_manifest("tau0", "--tau0")(e.to_string()),
                _ => ArgError::Flag {
                    flag: "--tau0",
                    message: e.to_string(),
                },
            })?;
        Ok(Settings {
            config: RenderConfig {
                algorithm: algorithm.value,
                strategies: Strategies::Mis,
                max_depth: max_depth.value,
                seed: seed.value,
                regularization,
                virtual_merges: self.virtual_merges,
                radius_factor: self.radius.unwrap_or(integrators::DEFAULT_RADIUS_FACTOR),
                shadow_roulette: self
                    .shadow_roulette
                    .unwrap_or(integrators::DEFAULT_SHADOW_ROULETTE),
                ..RenderConfig::default()
            },
            budget,
            algorithm: algorithm.origin,
            mode: mode.origin,
            tau0: tau0.origin,
            max_depth: max_depth.origin,
            seed: seed.origin,
        })
    }
}

impl Settings {
    /// One line per setting with its origin, for `--explain`.
    pub fn describe(&self) -> String {
        let c = &self.config;
        let r = &c.regularization;
        let rows = [
            ("integrator", c.algorithm.to_string(), self.algorithm),
            (
                match self.budget.value {
                    Budget::Iterations(_) => "iterations",
                    Budget::Time(_) => "time",
                },
                match self.budget.value {
                    Budget::Iterations(n) => n.to_string(),
                    Budget::Time(t) => format!("{} s", t.as_secs_f64()),
                },
                self.budget.origin,
            ),
            ("regularize", r.mode.to_string(), self.mode),
            ("tau0", r.schedule.tau_0().to_string(), self.tau0),
            (
                "progressive",
                if r.progressive { "yes" } else { "no" }.to_owned(),
                if r.progressive {
                    Origin::Default
                } else {
                    Origin::Flag
                },
            ),
            ("max depth", c.max_depth.to_string(), self.max_depth),
            ("seed", c.seed.to_string(), self.seed),
        ];
        let heading = "settings:         value (origin: flag, manifest or default)\n".to_owned();
        heading
            + &rows
                .iter()
                .map(|(name, value, origin)| {
                    format!("{:<18}{value} ({origin})\n", format!("{name}:"))
                })
                .collect::<String>()
    }
}

/// `Resolved` from a flag.
fn flag<T>(value: T) -> Resolved<T> {
    Resolved {
        value,
        origin: Origin::Flag,
    }
}

/// The flag's value if given, else the manifest's (converted and checked by
/// `check`), else `default`.
fn pick<T, M>(
    flag_value: Option<T>,
    manifest: Option<M>,
    default: T,
    check: impl FnOnce(M) -> Result<T, ArgError>,
) -> Result<Resolved<T>, ArgError> {
    Ok(match (flag_value, manifest) {
        (Some(value), _) => flag(value),
        (None, Some(m)) => Resolved {
            value: check(m)?,
            origin: Origin::Manifest,
        },
        (None, None) => Resolved {
            value: default,
            origin: Origin::Default,
        },
    })
}

/// Checks that `path` can be created: its folder exists and it is not a folder.
fn check_writable(flag: &'static str, path: &Path) -> Result<(), ArgError> {
    let folder = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    let message = if !folder.is_dir() {
        format!("folder {} does not exist", folder.display())
    } else if path.is_dir() {
        format!("{} is a folder", path.display())
    } else {
        return Ok(());
    };
    Err(ArgError::Flag { flag, message })
}

// Value parsers: each returns a message that clap shows as
// "invalid value 'V' for '--flag <NAME>': <message>".

fn algorithm_help() -> String {
    let names: Vec<&str> = Algorithm::ALL.iter().map(|(_, name)| *name).collect();
    format!(
        "Light-transport algorithm, one of: {}. pt: path tracing with next-event estimation \
         and multiple importance sampling; bpt: bidirectional path tracing; ppm: progressive \
         photon mapping (merging only); vcm: vertex connection and merging (BPT + merging). \
         [default: the manifest's, else {}]",
        names.join(", "),
        Algorithm::default()
    )
}

fn parse_on_off(s: &str) -> Result<bool, String> {
    match s.to_ascii_lowercase().as_str() {
        "on" => Ok(true),
        "off" => Ok(false),
        _ => Err("expected on or off".into()),
    }
}

fn parse_radius(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(r) if r > 0.0 && r.is_finite() => Ok(r),
        _ => Err("expected a positive number (a fraction of the scene radius, e.g. 0.003)".into()),
    }
}

fn parse_shadow_roulette(s: &str) -> Result<f32, String> {
    match s.parse::<f32>() {
        Ok(t) if t >= 0.0 && t.is_finite() => Ok(t),
        _ => Err(
            "expected a number >= 0 (a fraction of the mean pixel value, e.g. 0.1; 0: off)".into(),
        ),
    }
}

fn parse_algorithm(s: &str) -> Result<Algorithm, String> {
    s.parse()
        .map_err(|e: integrators::ConfigError| e.to_string())
}

fn parse_regularize(s: &str) -> Result<Mode, String> {
    s.parse::<Mode>().map_err(|e| e.to_string())
}

/// tau_0 must exceed 1/(2 pi) (the schedule's own check and message).
fn check_tau0(tau0: f64) -> Result<f64, String> {
    Schedule::new(tau0).map(|_| tau0).map_err(|e| e.to_string())
}

fn at_least_one(n: u64) -> Result<u64, String> {
    if n == 0 {
        return Err("must be at least 1, got 0".into());
    }
    Ok(n)
}

fn parse_tau0(s: &str) -> Result<f64, String> {
    check_tau0(
        s.trim()
            .parse()
            .map_err(|_| format!("'{s}' is not a number"))?,
    )
}

fn parse_iterations(s: &str) -> Result<u64, String> {
    at_least_one(
        s.trim()
            .parse()
            .map_err(|_| format!("'{s}' is not a whole number"))?,
    )
}

fn parse_max_depth(s: &str) -> Result<u32, String> {
    let d: u32 = (s.trim().parse())
        .map_err(|_| format!("'{s}' is not a whole number up to {}", u32::MAX))?;
    at_least_one(u64::from(d)).map(|_| d)
}

fn parse_threads(s: &str) -> Result<usize, String> {
    let k: usize = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a whole number"))?;
    at_least_one(k as u64).map(|_| k)
}

fn parse_time(s: &str) -> Result<Duration, String> {
    let seconds: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !(seconds > 0.0 && seconds.is_finite()) {
        return Err(format!(
            "must be a positive, finite number of seconds, got {s}"
        ));
    }
    Duration::try_from_secs_f64(seconds).map_err(|_| format!("{s} seconds is too long"))
}

fn parse_fov(s: &str) -> Result<f32, String> {
    let fov: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !(fov > 0.0 && fov < 180.0) {
        return Err(format!("must be in (0, 180) degrees, got {s}"));
    }
    Ok(fov)
}

fn parse_exposure(s: &str) -> Result<f32, String> {
    let stops: f32 = s
        .trim()
        .parse()
        .map_err(|_| format!("'{s}' is not a number"))?;
    if !stops.is_finite() {
        return Err(format!("must be a finite number of stops, got {s}"));
    }
    Ok(stops)
}

/// `X,Y,Z`: exactly three finite numbers.
fn parse_vec3(s: &str) -> Result<Vec3, String> {
    let parts: Vec<&str> = s.split(',').map(str::trim).collect();
    let [x, y, z] = parts[..] else {
        return Err(format!(
            "expected 3 comma-separated numbers X,Y,Z, got {}",
            parts.len()
        ));
    };
    let number = |p: &str| match p.parse::<f32>() {
        Ok(v) if v.is_finite() => Ok(v),
        Ok(_) => Err(format!("{p} is not finite")),
        Err(_) => Err(format!("'{p}' is not a number")),
    };
    Ok(Vec3::new(number(x)?, number(y)?, number(z)?))
}

/// `WxH` with each side in 1..=MAX_RESOLUTION.
fn parse_resolution(s: &str) -> Result<UVec2, String> {
    let Some((w, h)) = s.trim().split_once(['x', 'X']) else {
        return Err("expected WIDTHxHEIGHT, e.g. 640x480".into());
    };
    let side = |p: &str| match p.trim().parse::<u32>() {
        Ok(v) if (1..=MAX_RESOLUTION).contains(&v) => Ok(v),
        _ => Err(format!(
            "each side must be a whole number in 1..={MAX_RESOLUTION}, got '{p}'"
        )),
    };
    Ok(UVec2::new(side(w)?, side(h)?))
}

fn parse_path_with_extension(s: &str, extension: &str) -> Result<PathBuf, String> {
    let path = PathBuf::from(s);
    match path.extension().and_then(|e| e.to_str()) {
        Some(e) if e.eq_ignore_ascii_case(extension) => Ok(path),
        _ => Err(format!("the file name must end in .{extension}")),
    }
}

fn parse_exr_path(s: &str) -> Result<PathBuf, String> {
    parse_path_with_extension(s, "exr")
}

fn parse_png_path(s: &str) -> Result<PathBuf, String> {
    parse_path_with_extension(s, "png")
}

/// A clap error as one line: the message, then its list items and tips,
/// without the usage block and the "try --help" hint.
pub fn one_line(error: &clap::Error) -> String {
    let rendered = error.render().to_string();
    let mut line = String::new();
    // After a line ending in ':' come list items, joined with ", ".
    let mut in_list = false;
    for part in rendered
        .lines()
        .take_while(|l| !l.starts_with("Usage:") && !l.starts_with("For more information"))
        .map(str::trim)
        .filter(|l| !l.is_empty())
    {
        in_list &= !part.starts_with("tip:");
        if !line.is_empty() {
            line.push_str(match (in_list, line.ends_with(':')) {
                (_, true) => " ",
                (true, false) => ", ",
                (false, false) => "; ",
            });
        }
        in_list |= part.ends_with(':');
        line.push_str(part);
    }
    line
}

#[cfg(test)]
mod tests {
    use super::*;

    fn cli(args: &[&str]) -> Result<Cli, clap::Error> {
        Cli::try_parse_from(["render-cli", "scene.toml"].iter().chain(args))
    }

    #[test]
    fn vectors_need_three_finite_numbers() {
        assert_eq!(parse_vec3("1, -2.5,3e1"), Ok(Vec3::new(1.0, -2.5, 30.0)));
        assert!(parse_vec3("1,2").unwrap_err().contains("got 2"));
        assert!(parse_vec3("1,2,3,4").unwrap_err().contains("got 4"));
        assert!(parse_vec3("1,x,3").unwrap_err().contains("'x'"));
        assert!(parse_vec3("1,inf,3").unwrap_err().contains("not finite"));
        assert!(parse_vec3("1,NaN,3").unwrap_err().contains("not finite"));
        assert!(parse_vec3("").is_err());
    }

    #[test]
    fn resolutions_are_bounded() {
        assert_eq!(parse_resolution("640x480"), Ok(UVec2::new(640, 480)));
        assert_eq!(parse_resolution("16X12"), Ok(UVec2::new(16, 12)));
        assert_eq!(parse_resolution("16384x1"), Ok(UVec2::new(16384, 1)));
        for bad in [
            "0x5", "5x0", "16385x2", "640", "x480", "-1x5", "1.5x2", "axb",
        ] {
            assert!(parse_resolution(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn scalar_values_are_checked() {
        assert!(parse_iterations("0").is_err());
        assert!(parse_time("0").is_err() && parse_time("-1").is_err());
        assert!(parse_time("inf").is_err() && parse_time("NaN").is_err());
        assert_eq!(parse_time("0.25"), Ok(Duration::from_millis(250)));
        assert!(parse_fov("0").is_err() && parse_fov("180").is_err());
        assert!(parse_tau0("0.1").unwrap_err().contains("1/(2 pi)"));
        assert!(parse_tau0("NaN").is_err());
        assert_eq!(parse_tau0("30"), Ok(30.0));
        assert!(parse_threads("0").is_err());
        assert!(parse_exr_path("out.png").is_err() && parse_exr_path("a/b.EXR").is_ok());
    }

    #[test]
    fn flags_override_the_manifest_which_overrides_defaults() {
        let manifest = RenderSettings {
            integrator: Some("pt".into()),
            iterations: Some(16),
            max_depth: Some(5),
            regularize: Some("uniform".into()),
            tau0: Some(30.0),
            seed: Some(7),
        };
        let path = Path::new("scene.toml");

        let s = cli(&[]).unwrap().resolve(&manifest, path).unwrap();
        assert_eq!(s.budget.value, Budget::Iterations(16));
        assert_eq!(s.config.max_depth, 5);
        assert_eq!(s.config.regularization.mode, Mode::Uniform);
        assert_eq!(s.config.regularization.schedule.tau_0(), 30.0);
        assert_eq!(s.config.seed, 7);
        assert!(s.config.regularization.progressive);
        assert_eq!(s.mode, Origin::Manifest);

        let args = [
            "--iterations=3",
            "--max-depth=2",
            "--regularize=off",
            "--tau0=8",
            "--seed=1",
            "--no-progressive",
        ];
        let s = cli(&args).unwrap().resolve(&manifest, path).unwrap();
        assert_eq!(s.budget, flag(Budget::Iterations(3)));
        assert_eq!(s.config.max_depth, 2);
        assert_eq!(s.config.regularization.mode, Mode::Off);
        assert_eq!(s.config.regularization.schedule.tau_0(), 8.0);
        assert_eq!(s.config.seed, 1);
        assert!(!s.config.regularization.progressive);

        let s = cli(&["--time", "2"])
            .unwrap()
            .resolve(&manifest, path)
            .unwrap();
        assert_eq!(s.budget.value, Budget::Time(Duration::from_secs(2)));

        let s = cli(&[])
            .unwrap()
            .resolve(&RenderSettings::default(), path)
            .unwrap();
        assert_eq!(s.budget.value, Budget::Iterations(DEFAULT_ITERATIONS));
        assert_eq!(s.config.max_depth, DEFAULT_MAX_DEPTH);
        assert_eq!(s.config.regularization.mode, DEFAULT_MODE);
        assert_eq!(s.config.regularization.schedule.tau_0(), DEFAULT_TAU_0);
        assert_eq!(s.config.seed, DEFAULT_SEED);
        assert_eq!(s.tau0, Origin::Default);
    }

    #[test]
    fn bad_manifest_values_name_the_manifest_unless_overridden() {
        let path = Path::new("dir/scene.toml");
        let cases = [
            (
                RenderSettings {
                    regularize: Some("strict".into()),
                    ..Default::default()
                },
                "regularize",
            ),
            (
                RenderSettings {
                    integrator: Some("xyz".into()),
                    ..Default::default()
                },
                "integrator",
            ),
            (
                RenderSettings {
                    tau0: Some(0.1),
                    ..Default::default()
                },
                "tau0",
            ),
            (
                RenderSettings {
                    iterations: Some(0),
                    ..Default::default()
                },
                "iterations",
            ),
        ];
        for (manifest, field) in cases {
            let e = cli(&[]).unwrap().resolve(&manifest, path).unwrap_err();
            let text = e.to_string();
            assert!(
                text.starts_with("dir/scene.toml: [render] ") && text.contains(field),
                "{text}"
            );
            assert!(text.contains("manifest") && !text.contains('\n'), "{text}");
        }
        let overridden = RenderSettings {
            regularize: Some("strict".into()),
            ..Default::default()
        };
        let s = cli(&["--regularize", "uniform"])
            .unwrap()
            .resolve(&overridden, path)
            .unwrap();
        assert_eq!(s.config.regularization.mode, Mode::Uniform);
    }

    #[test]
    fn flag_combinations_are_checked() {
        assert!(cli(&["--iterations", "4", "--time", "1"]).is_err());
        assert!(cli(&["--camera-from", "0,0,1"]).is_err());
        assert!(cli(&["--fov", "40"]).is_err());
        assert!(cli(&["--png", "a.png", "--no-png"]).is_err());
        let ok = cli(&[
            "--camera-from",
            "-1,0,1",
            "--camera-at",
            "0,0,0",
            "--fov",
            "40",
        ])
        .unwrap();
        assert!(ok.camera_override().unwrap().is_some());
        let degenerate = cli(&[
            "--camera-from",
            "0,0,0",
            "--camera-at",
            "0,0,0",
            "--fov",
            "40",
        ]);
        let e = degenerate.unwrap().camera_override().unwrap_err();
        assert!(e.to_string().contains("--camera-from"), "{e}");
    }

    #[test]
    fn clap_errors_fit_on_one_line() {
        let e = cli(&["--regularize", "strict"]).unwrap_err();
        let line = one_line(&e);
        assert!(
            line.starts_with("error: ") && line.contains("--regularize"),
            "{line}"
        );
        assert!(line.contains("strict") && !line.contains('\n'), "{line}");
        let e = cli(&["--camera-from", "0,0,1"]).unwrap_err();
        let line = one_line(&e);
        assert!(
            line.contains("--camera-at") && line.contains("--fov"),
            "{line}"
        );
        let e = cli(&["--iteration", "3"]).unwrap_err();
        let line = one_line(&e);
        assert!(
            line.ends_with("found; tip: a similar argument exists: '--iterations'"),
            "{line}"
        );
    }

    #[test]
    fn default_png_sits_next_to_the_exr() {
        let dir = std::env::temp_dir();
        let exr = dir.join("x.exr");
        let o = cli(&["-o", exr.to_str().unwrap()])
            .unwrap()
            .outputs()
            .unwrap();
        assert_eq!(o.png, Some(dir.join("x.png")));
        let o = cli(&["--no-png"]).unwrap().outputs().unwrap();
        assert_eq!((o.exr, o.png), (PathBuf::from(DEFAULT_OUTPUT), None));
        let e = cli(&["-o", "no/such/folder/x.exr"])
            .unwrap()
            .outputs()
            .unwrap_err();
        assert!(e.to_string().contains("no/such/folder"), "{e}");
    }
}
