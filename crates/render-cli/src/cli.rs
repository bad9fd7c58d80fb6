//! The command line's schema: every flag, its value parser and its help text.
//! What the flags mean for a render is resolved in `settings`.

use std::path::PathBuf;
use std::time::Duration;

use clap::Parser;
use glam::{UVec2, Vec3};
use integrators::{Algorithm, Mode};

use crate::values::{
    parse_algorithm, parse_checkpoint_interval, parse_define, parse_env_rotation, parse_env_scale,
    parse_exposure, parse_exr_path, parse_fov, parse_iteration_range, parse_iterations,
    parse_max_depth, parse_on_off, parse_partial_path, parse_png_path, parse_radius,
    parse_regularize, parse_resolution, parse_shadow_roulette, parse_tau0, parse_threads,
    parse_time, parse_vec3,
};

const AFTER_LONG_HELP: &str = "\
Settings are taken from the flags, else from the scene manifest's [render] table (a Mitsuba \
file's integrator max_depth, sampler sample_count and film size), else from the defaults above; --explain shows where each one came from. The table's keys are the flags' names \
with underscores: integrator, iterations, max_depth, regularize, tau0, seed, radius, \
shadow_roulette, and progressive, regularize_energy and virtual_merges (true or false).

Progress goes to stderr (a bar on a terminal); the last line is always a summary such as
  rendered 64 iterations of 256x256 in 3.21 s (19.9 it/s, 1.30 Msamples/s) -> render.exr, render.png

Once rendering has started, Ctrl-C (or SIGTERM) stops within about a second, dropping the \
iteration in progress, and writes the mean of the iterations completed so far; a second Ctrl-C \
quits at once without writing.

Shards: --iteration-range A..B --partial shard.rltfilm renders iterations A..B of a longer render (with their global indices) into a partial film; `render-cli merge a.rltfilm b.rltfilm ... -o image.exr` sums partial films of one render into its image (`render-cli merge --help`).

Checkpoints: --checkpoint render.rltfilm saves the film every 300 s (--checkpoint-every); after a \
crash or a kill, the same command resumes from it ('resuming from render.rltfilm: iterations \
1..=N of M done') and writes the image an uninterrupted render gives, byte for byte. With --time, \
the checkpoint also records the time rendered, and the budget counts it: the image is then that \
of --iterations N for the N iterations rendered in all.

Exit status: 0 rendered; 1 error (one line on stderr: 'error: ...'); 2 invalid command line; \
130 interrupted (the image of the completed iterations was written, or nothing if none completed; \
with --checkpoint, the checkpoint holds them).

Examples:
  render-cli scenes/cornell-box/scene.toml
  render-cli scenes/glossy-caustic/scene.toml --time 60 --regularize uniform -o caustic.exr
  render-cli model.glb --camera Overview --resolution 1280x720 --exposure 1
  render-cli model.glb --env scenes/env-sphere/sky.hdr --env-rotation 90
  render-cli scenes/veach-bidir -D spp=64";

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
    /// The scene: a scene.toml manifest (or a folder holding one, as scenes/caustic-glass), a
    /// glTF 2.0 file (.gltf, .glb), a Wavefront .obj file, or a Mitsuba 3 scene file (.xml, or
    /// a folder holding a scene.xml, as scenes/veach-bidir; Mitsuba 0.6 files too).
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

    /// Path tracing (pt) only: trace one path after the other (the readable reference loop)
    /// instead of the default wavefront, which advances the paths of each run of 512 pixels of a
    /// row together, one bounce at a time, traces their rays in batches (packets of 16 rays in
    /// small scenes) and shades their Lambertian vertices 16 at a time in SIMD lanes. The image
    /// is the same, byte for byte; the wavefront takes 0.76-0.83 of the loop's CPU time on the
    /// SmallVCM, Cornell and Veach scenes (docs/benchmarks.md).
    #[arg(long, help_heading = "Rendering")]
    pub scalar_loop: bool,

    /// The default (the wavefront path loop); accepted so that commands written when it was
    /// an option still run.
    #[arg(long, hide = true, conflicts_with = "scalar_loop")]
    pub wavefront: bool,

    /// Print the scene's features, what the integrator will do with them and why, and every
    /// resolved setting with its origin (flag, manifest or default) on stdout; then render as
    /// usual.
    #[arg(long, help_heading = "Rendering")]
    pub explain: bool,

    /// Which vertices are regularized: off (none); uniform (every vertex gets tau_N);
    /// selective (tau_N scaled by the roughness of the path so far: what is seen directly or
    /// in mirrors stays sharp, a caustic seen on a diffuse surface is blurred); unsampleable
    /// (selective on camera subpaths until an unregularized connection or merge of the
    /// integrator could sample every path through them, light subpaths stay sharp: BPT, BPM,
    /// PPM and VCM; PT treats it as selective).
    /// [default: the manifest's, else unsampleable]
    #[arg(long, value_name = "MODE", value_parser = parse_regularize,
          help_heading = "Regularization")]
    pub regularize: Option<Mode>,

    /// Initial regularization bound tau_0, in 1/sr; must exceed 1/(2 pi) = 0.159. Smaller values
    /// blur more (tau_0 = 30 raises roughness to alpha = 0.052 at the first iteration, 7.5 to 0.103).
    /// tau bounds the outgoing solid-angle density of a lobe (D/4 for reflection);
    /// implementations that bound D itself use 4x this value.
    /// [default: the manifest's, else 30]
    #[arg(long = "tau0", value_name = "TAU", value_parser = parse_tau0, allow_negative_numbers = true,
          help_heading = "Regularization")]
    pub tau0: Option<f64>,

    /// Keep tau at tau_0 in every iteration: a fixed blur, biased and not consistent. By default
    /// tau grows with the iteration count N (tau_N, cone radius ~ N^(-1/6)), so the blur vanishes
    /// as the render converges. [default: the manifest's `progressive`, else progressive]
    #[arg(long, help_heading = "Regularization")]
    pub no_progressive: bool,

    /// Let tau grow with the iteration count (the default), even where the manifest says
    /// `progressive = false`.
    #[arg(
        long,
        conflicts_with = "no_progressive",
        help_heading = "Regularization"
    )]
    pub progressive: bool,

    /// Energy-preserving regularization: a widened lobe keeps the original's directional
    /// albedo through a compensation lobe (Kulla & Conty 2017) on conductors, coated
    /// surfaces and dielectrics; off widens the lobe alone, which loses energy (images 2-6 %
    /// darker). On needs tables of the scene's lobes, built once per run (seconds for a
    /// dielectric): before the first iteration when it will read them (uniform, selective,
    /// and pt), otherwise at first use.
    /// [default: the manifest's `regularize_energy`, else on]
    #[arg(long, value_name = "on|off", value_parser = parse_on_off, help_heading = "Regularization")]
    pub regularize_energy: Option<bool>,

    /// Virtual merges (supp. §6) for bpt and vcm with regularization: a connection through a
    /// regularized vertex also counts as a merge inside the vertex's blur cone, which keeps
    /// the MIS weights of blurred connections low where merging does better.
    /// [default: the manifest's, else on for vcm with regularization, off otherwise]
    #[arg(long, value_name = "on|off", value_parser = parse_on_off, help_heading = "Regularization")]
    pub virtual_merges: Option<bool>,

    /// First merge radius of ppm, bpm and vcm, as a fraction of the radius of the scene's bounding
    /// sphere; it shrinks as r_N = r_1 N^((alpha - 1)/2) with alpha = 0.75.
    /// [default: the manifest's, else 0.003]
    #[arg(long, value_name = "FRACTION", value_parser = parse_radius, allow_negative_numbers = true,
          help_heading = "Rendering")]
    pub radius: Option<f32>,

    /// Russian roulette on the shadow rays of bpt and vcm's next-event estimation, vertex
    /// connections and light tracing (Veach 1997, §10.4.1): a contribution c below this
    /// fraction t of the mean pixel value (from a small path-traced preview) keeps its shadow
    /// ray with probability c / t and is scaled by t / c, so the image stays unbiased; 0 traces
    /// every shadow ray.
    /// [default: the manifest's, else 0.1]
    #[arg(long, value_name = "FRACTION", value_parser = parse_shadow_roulette, allow_negative_numbers = true,
          help_heading = "Rendering")]
    pub shadow_roulette: Option<f32>,

    /// Image size in pixels, WIDTHxHEIGHT (e.g. 640x480), each in 1..=16384.
    /// [default: the manifest's, else 512 wide at the camera's aspect ratio]
    #[arg(long, value_name = "WxH", value_parser = parse_resolution, help_heading = "Camera")]
    pub resolution: Option<UVec2>,

    /// Let the scene's file references (models, material libraries, textures, glTF buffers and
    /// images) point outside the scene file's folder. By default such a reference (`..`, an
    /// absolute path, a symlink out) is refused, so that a scene from elsewhere cannot make
    /// the renderer read other files.
    #[arg(long, help_heading = "Scene")]
    pub allow_outside_paths: bool,

    /// Set a parameter of a Mitsuba scene file, as Mitsuba's own -D: every `$NAME` in the
    /// file's attributes becomes VALUE, and it wins over the file's <default name="NAME">.
    /// Repeat for several (-D spp=64 -D res=512). A parameter the file never uses is an error.
    #[arg(short = 'D', value_name = "NAME=VALUE", value_parser = parse_define, help_heading = "Scene")]
    pub define: Vec<(String, String)>,

    /// Render a scene that has no geometry, or no light and no environment (its image is
    /// black or empty). By default such a scene is an error, since it is almost always a
    /// mistake: an empty or truncated file, a wrong path, a model without its lights.
    #[arg(long, help_heading = "Scene")]
    pub allow_empty: bool,

    /// Light the scene with this environment map instead of its own environment: an
    /// equirectangular (latitude-longitude) OpenEXR (.exr) or Radiance (.hdr) image, +y up, the
    /// image's top row straight up and its left edge looking along -z (Mitsuba 3's envmap
    /// convention). Works with any scene file; a model without lights then gets no default
    /// white environment. Importance-sampled by every integrator.
    #[arg(long, value_name = "FILE", help_heading = "Scene")]
    pub env: Option<PathBuf>,

    /// Multiplier of the --env map's radiance, >= 0. [default: 1]
    #[arg(long, value_name = "S", value_parser = parse_env_scale, allow_negative_numbers = true,
          requires = "env", help_heading = "Scene")]
    pub env_scale: Option<f32>,

    /// Rotation of the --env map about the up axis (+y), in degrees, right-handed.
    /// [default: 0]
    #[arg(long, value_name = "DEG", value_parser = parse_env_rotation, allow_negative_numbers = true,
          requires = "env", help_heading = "Scene")]
    pub env_rotation: Option<f32>,

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

    /// Render only iterations A..B of a longer render (1-based and inclusive, as the progress
    /// bar counts them: 1..64 is all of a 64-iteration render). Iterations keep their global
    /// index, so tau_N, the merge radius and the random numbers are those of the whole render,
    /// and the merged shards equal it.
    #[arg(long, value_name = "A..B", value_parser = parse_iteration_range,
          conflicts_with_all = ["iterations", "time"], help_heading = "Shards")]
    pub iteration_range: Option<(u64, u64)>,

    /// Write the film's state (per-pixel sums and squares, iteration range, scene hash and
    /// settings) to this .rltfilm file instead of an image, for `render-cli merge`. Written
    /// (atomically) only when every iteration of the range completed.
    #[arg(long, value_name = "PATH", value_parser = parse_partial_path,
          conflicts_with_all = ["output", "png", "no_png", "exposure"], help_heading = "Shards")]
    pub partial: Option<PathBuf>,

    /// Save the film of the render in progress to this .rltfilm file every --checkpoint-every
    /// seconds (atomically: a killed render leaves the previous checkpoint whole), and resume
    /// from it if it exists: running the same command again after a crash, a kill or Ctrl-C
    /// renders only the iterations it lacks and writes the same image, byte for byte, as an
    /// uninterrupted render. A checkpoint of another scene, size or setting, or a damaged one,
    /// is refused; so is one that another running render holds. It is removed once the
    /// image (or --partial film) is written, kept if the render was interrupted or the image
    /// could not be written.
    #[arg(long, value_name = "FILE", value_parser = parse_partial_path, help_heading = "Checkpoints")]
    pub checkpoint: Option<PathBuf>,

    /// Seconds between checkpoints (fractions allowed; 0 saves after every iteration). Checked
    /// between iterations, so an iteration longer than this saves after each one.
    /// [default: 300]
    #[arg(long, value_name = "SECONDS", value_parser = parse_checkpoint_interval,
          requires = "checkpoint", help_heading = "Checkpoints")]
    pub checkpoint_every: Option<Duration>,

    /// Keep the checkpoint once the image is written: it then holds every iteration, and a
    /// later run with more --iterations (or a longer --time) continues from it.
    #[arg(long, requires = "checkpoint", help_heading = "Checkpoints")]
    pub keep_checkpoint: bool,
}

fn algorithm_help() -> String {
    let names: Vec<&str> = Algorithm::ALL.iter().map(|(_, name)| *name).collect();
    format!(
        "Light-transport algorithm, one of: {}. pt: path tracing with next-event estimation \
         and multiple importance sampling; bpt: bidirectional path tracing; ppm: progressive \
         photon mapping (camera paths merge at their first non-specular vertex, no MIS); bpm: \
         bidirectional photon mapping (merging at every camera vertex, MIS); vcm: vertex \
         connection and merging (BPT + merging). \
         [default: the manifest's, else {}]",
        names.join(", "),
        Algorithm::default()
    )
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
impl Cli {
    /// `render-cli scene.toml ARGS`, parsed.
    pub fn parse_test(args: &[&str]) -> Result<Self, clap::Error> {
        Self::try_parse_from(["render-cli", "scene.toml"].iter().chain(args))
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    use super::*;

    fn cli(args: &[&str]) -> Result<Cli, clap::Error> {
        Cli::parse_test(args)
    }

    #[test]
    fn help_shows_the_defaults_of_the_integrators_crate() {
        let help = Cli::command().render_long_help().to_string();
        // As one line: where clap wraps depends on the terminal.
        let help = help.split_whitespace().collect::<Vec<_>>().join(" ");
        for default in [
            format!("else {}]", integrators::DEFAULT_RADIUS_FACTOR),
            format!("else {}]", integrators::DEFAULT_SHADOW_ROULETTE),
            format!("else {}]", integrators::DEFAULT_TAU_0),
            format!("else {}]", integrators::DEFAULT_MAX_DEPTH),
        ] {
            assert!(help.contains(&default), "--help lacks '{default}'");
        }
    }

    #[test]
    fn flag_combinations_are_checked() {
        assert!(cli(&["--iterations", "4", "--time", "1"]).is_err());
        assert!(cli(&["--camera-from", "0,0,1"]).is_err());
        assert!(cli(&["--fov", "40"]).is_err());
        assert!(cli(&["--png", "a.png", "--no-png"]).is_err());
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
}
