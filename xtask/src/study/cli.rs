//! The command line of `cargo xtask study`: flags, budgets and configs.

use std::fmt;
use std::path::{Path, PathBuf};
use std::time::Duration;

use glam::UVec2;
use integrators::{Algorithm, DEFAULT_TAU_0, Energy, Mode, Regularization, RenderConfig};
use regularization::{DEFAULT_SCHEDULE_EXPONENT, Schedule};

/// `cargo xtask study --help`.
pub(super) const HELP: &str = "usage: cargo xtask study --scene PATH [options]
       cargo xtask study --replot DIR

Renders two references (cached in target/study/cache/): an unbiased one
(unregularized BPT, or VCM where the scene has specular surfaces, see
--unbiased-reference) and the regularized VCM of supp. §7; then every config
for --iterations iterations, measured at iterations 1, 2, 4, 8, ... and the
last: wall-clock render time, RMSE, relMSE and noise (SPEC §8), all on
luminance, against both references. The report leads with the unbiased
reference, shows the bias of regularization (regularized minus unbiased
reference) as bias.png and numbers beside both references' noise, and for
every regularized config the time it takes to reach the final RMSE of the
same algorithm without regularization (the goal: at most 1/4 of that
config's time), with a verdict read from the curves (met, no gain, or
bias-limited where the RMSE stopped falling like noise). Writes curves.csv, curves.json, report.md, charts (SVG and
PNG), bias.png and contact-sheet.png to the output folder.

options:
  --scene PATH          scene folder with a scene.toml (else a scene.xml), or a
                        scene file (.toml, .gltf, .glb, .obj, or a Mitsuba
                        scene .xml); required. The reference cache key
                        hashes every file under a scene.toml's or .xml's
                        folder (models outside it are not seen), or the
                        files next to a model file.
  --configs LIST        comma-separated configs, each an algorithm (pt, bpt,
                        ppm, bpm, vcm) with regularization off, or with `-reg`:
                        selective regularization, progressive tau from tau_0,
                        or with `-uns`: the same with the `unsampleable` rule
                        (blur only subpaths that no unregularized connection
                        or merge of the algorithm samples)
                        [default: pt,pt-reg,bpt,bpt-reg,ppm,vcm,vcm-reg]
  --iterations N        iterations of every config [quick: 16, full: 1024]
  --reference-iterations N
                        iterations of the reference(s) [quick: 64, full: 10000]
  --resolution WxH      image size [quick: 64x64, full: the scene's]
  --budget quick|full   defaults of the three above [default: full]; flags
                        given explicitly win. quick runs in CI.
  --unbiased-reference auto|none|CONFIG
                        the unregularized reference [default: auto: vcm when
                        the scene has a specular (delta) surface, whose SDS
                        paths only merging reaches from a point light; else
                        bpt, which is unbiased]; none skips it (only the
                        regularized reference, as supp. §7)
  --sweep PARAM=V1,V2,...
                        render every -reg config once per value: tau0 (e.g.
                        tau0=2,7.5,30,120) or schedule-exponent (lambda in
                        r_N = r_0 N^-lambda, the paper's 1/6; consistent only
                        strictly between 0 and 1/2, other values are refused;
                        fractions such as 1/6 are accepted).
                        Give both flags for their product. Swept configs are
                        named like bpt-reg@tau0=30@exp=0.25; the references
                        keep --tau0 and 1/6
  --seed S              seed of the configs [default: 1]; the reference uses
                        S + 1000003, the unbiased reference S + 2000006, so no
                        config shares random numbers with a reference
  --tau0 X              tau_0 of the -reg configs and the regularized
                        reference [default: the scene's, else 30]
  --out DIR             output folder [default: target/study/<scene name>]
  --cache DIR           the cache of references, finished configs and
                        checkpoints [default: target/study/cache]; delete it
                        to start every study over
  --rerender-reference  render the reference(s) even when cached (and update
                        the cache), from the first iteration. The cache key
                        holds the renderer's sources (git ids of crates/ and
                        Cargo.lock at HEAD, and any uncommitted change to
                        them), not the commit: commits of documents, scenes
                        elsewhere or xtask keep it
  --fresh               render everything, references and configs, from the
                        first iteration, ignoring cached runs and checkpoints
                        (and update the cache)
  --checkpoint-interval SECONDS
                        save the state of the render in progress (films,
                        times, curve so far) at most this often, so that a
                        study killed and run again with the same command
                        resumes it [default: 60; 0: after every iteration]
  --farm slurm          render uncached references on a Slurm cluster as
                        `cargo xtask farm slurm` does (shards, a merge), and
                        wait for them; their noise is not measured (a partial
                        film keeps RGB sums, not luminance)
  --farm-shards K       shards of each farm reference [default: 4]
  --farm-partition P, --farm-time T, --farm-mem M, --farm-cpus-per-task C
                        Slurm resources of the farm jobs (see `cargo xtask
                        farm help`)
  -h, --help            print this text
  --replot DIR          (alone) redraw the charts of the study whose
                        curves.json is in DIR, into DIR; renders nothing

Every finished config is kept in the cache (its curve, times and final
image) as soon as it is done, and every reference too: running the same
command again renders only what is missing, printing `reusing cached run
of CONFIG` for the others, and gives the same curves and report.

Timings are wall-clock seconds of rendering only (scene setup and metrics
excluded), cumulative over iterations, on all cores; the report records the
core count and load average, since other processes skew them, and also the
CPU seconds of all threads (from /proc), which they skew much less.";

/// Default configs, in report order.
const DEFAULT_CONFIGS: &str = "pt,pt-reg,bpt,bpt-reg,ppm,vcm,vcm-reg";

/// A rendering configuration of the study: an algorithm, regularized or not,
/// and for a swept config the schedule values that differ from the study's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    /// The algorithm.
    pub algorithm: Algorithm,
    /// Selective, progressive regularization (else off).
    pub regularized: bool,
    /// With `regularized`: the `unsampleable` rule instead of `selective`
    /// (config suffix `-uns`).
    pub unsampleable: bool,
    /// tau_0 set by `--sweep tau0=...` (None: the study's tau_0).
    pub tau0: Option<f64>,
    /// lambda of r_N = r_0 N^-lambda set by `--sweep schedule-exponent=...`
    /// (None: the paper's 1/6).
    pub exponent: Option<f64>,
}

impl Config {
    /// The regularized VCM of the reference.
    pub(super) const REFERENCE: Self = Self::plain(Algorithm::Vcm, true);

    /// `algorithm`, regularized or not, with the study's schedule.
    pub(super) const fn plain(algorithm: Algorithm, regularized: bool) -> Self {
        Self {
            algorithm,
            regularized,
            unsampleable: false,
            tau0: None,
            exponent: None,
        }
    }

    pub(super) fn parse(s: &str) -> Result<Self, String> {
        let s = s.trim().to_ascii_lowercase();
        let (name, regularized, unsampleable) = if let Some(base) = s.strip_suffix("-reg") {
            (base, true, false)
        } else if let Some(base) = s.strip_suffix("-uns") {
            (base, true, true)
        } else {
            (s.as_str(), false, false)
        };
        let algorithm = name.parse::<Algorithm>().map_err(|_| {
            format!(
                "unknown config '{s}' (expected pt, bpt, ppm, bpm or vcm, each optionally with -reg or -uns)"
            )
        })?;
        Ok(Self {
            unsampleable,
            ..Self::plain(algorithm, regularized)
        })
    }

    /// A config from its name as [`fmt::Display`] writes it, swept values
    /// included (`bpt-reg@tau0=30@exp=0.25`).
    pub(super) fn parse_name(s: &str) -> Result<Self, String> {
        let mut parts = s.split('@');
        let mut config = Self::parse(parts.next().unwrap_or_default())?;
        for part in parts {
            let value = |v: &str| {
                v.parse::<f64>()
                    .map_err(|_| format!("config '{s}': bad value '{part}'"))
            };
            match part.split_once('=') {
                Some(("tau0", v)) => config.tau0 = Some(value(v)?),
                Some(("exp", v)) => config.exponent = Some(value(v)?),
                _ => return Err(format!("config '{s}': unknown part '{part}'")),
            }
        }
        Ok(config)
    }

    /// The renderer's configuration; `tau0` is the study's, which a swept
    /// tau_0 replaces.
    pub(super) fn render_config(
        self,
        seed: u64,
        max_depth: u32,
        tau0: f64,
    ) -> Result<RenderConfig, String> {
        let regularization = if self.regularized {
            let flag = if self.tau0.is_some() || self.exponent.is_some() {
                "--sweep"
            } else {
                "--tau0"
            };
            let schedule = Schedule::with_exponent(
                self.tau0.unwrap_or(tau0),
                self.exponent.unwrap_or(DEFAULT_SCHEDULE_EXPONENT),
            )
            .map_err(|e| format!("{flag}: {e}"))?;
            Regularization {
                mode: if self.unsampleable {
                    Mode::Unsampleable
                } else {
                    Mode::Selective
                },
                schedule,
                progressive: true,
                energy: Energy::Preserved,
            }
        } else {
            Regularization::off()
        };
        Ok(RenderConfig {
            algorithm: self.algorithm,
            seed,
            max_depth,
            regularization,
            ..RenderConfig::default()
        })
    }
}

impl fmt::Display for Config {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let suffix = match (self.regularized, self.unsampleable) {
            (false, _) => "",
            (true, false) => "-reg",
            (true, true) => "-uns",
        };
        let mut name = format!("{}{suffix}", self.algorithm.name());
        if let Some(t) = self.tau0 {
            name.push_str(&format!("@tau0={}", short_number(t)));
        }
        if let Some(k) = self.exponent {
            name.push_str(&format!("@exp={}", short_number(k)));
        }
        // `pad`, so that width and alignment flags apply.
        f.pad(&name)
    }
}

/// A swept value in a config's name: at most 4 significant digits, so that
/// `1/6` reads 0.1667 (names are file names too: no `/`).
fn short_number(v: f64) -> String {
    let digits = 3 - v.abs().log10().floor().clamp(-12.0, 3.0) as i32;
    let scale = 10f64.powi(digits);
    format!("{}", (v * scale).round() / scale)
}

/// A number of `--sweep`: decimal, or a fraction p/q (`1/6`).
fn parse_number(text: &str) -> Option<f64> {
    match text.split_once('/') {
        Some((p, q)) => Some(p.trim().parse::<f64>().ok()? / q.trim().parse::<f64>().ok()?),
        None => text.trim().parse::<f64>().ok(),
    }
}

/// Preset iteration counts and resolution.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(super) enum Budget {
    Quick,
    Full,
}

impl Budget {
    pub(super) fn name(self) -> &'static str {
        match self {
            Self::Quick => "quick",
            Self::Full => "full",
        }
    }
}

/// Which unbiased reference to render (`--unbiased-reference`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) enum Unbiased {
    /// Chosen from the scene's features (`choose_unbiased`).
    Auto,
    /// None: the regularized reference only.
    Skip,
    /// This unregularized config.
    Given(Config),
}

/// The values of `--sweep` (empty: no sweep).
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct Sweep {
    /// tau_0 values.
    pub(super) tau0: Vec<f64>,
    /// Schedule exponents lambda.
    pub(super) exponent: Vec<f64>,
}

impl Sweep {
    pub(super) fn is_empty(&self) -> bool {
        self.tau0.is_empty() && self.exponent.is_empty()
    }

    /// `configs` with every regularized config replaced by one config per
    /// combination of the swept values, in the order given.
    pub(super) fn apply(&self, configs: &[Config]) -> Vec<Config> {
        let or_none = |values: &[f64]| -> Vec<Option<f64>> {
            if values.is_empty() {
                vec![None]
            } else {
                values.iter().copied().map(Some).collect()
            }
        };
        let mut out = Vec::new();
        for &c in configs {
            if !c.regularized || self.is_empty() {
                out.push(c);
                continue;
            }
            for tau0 in or_none(&self.tau0) {
                for exponent in or_none(&self.exponent) {
                    out.push(Config {
                        tau0,
                        exponent,
                        ..c
                    });
                }
            }
        }
        out
    }

    /// One line for the report, e.g. `tau0 = 2, 7.5; schedule exponent = 0.25`.
    pub(super) fn describe(&self) -> String {
        let list = |v: &[f64]| v.iter().map(f64::to_string).collect::<Vec<_>>().join(", ");
        let mut parts = Vec::new();
        if !self.tau0.is_empty() {
            parts.push(format!("tau0 = {}", list(&self.tau0)));
        }
        if !self.exponent.is_empty() {
            parts.push(format!("schedule exponent = {}", list(&self.exponent)));
        }
        if parts.is_empty() {
            "none".into()
        } else {
            parts.join("; ")
        }
    }
}

/// The parsed command line.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Options {
    /// The file `scene::load` reads.
    pub(super) scene_file: PathBuf,
    /// Folder name of the scene (or file stem).
    pub(super) scene_name: String,
    pub(super) configs: Vec<Config>,
    pub(super) iterations: u64,
    pub(super) reference_iterations: u64,
    pub(super) resolution: Option<UVec2>,
    pub(super) budget: Budget,
    pub(super) unbiased: Unbiased,
    /// `--sweep` values (already applied to `configs`).
    pub(super) sweep: Sweep,
    pub(super) seed: u64,
    pub(super) tau0: Option<f64>,
    pub(super) out: PathBuf,
    /// `--cache`: references, finished configs and checkpoints.
    pub(super) cache: PathBuf,
    pub(super) rerender: bool,
    /// `--fresh`: neither cached runs and references nor checkpoints.
    pub(super) fresh: bool,
    /// `--checkpoint-interval`.
    pub(super) checkpoint_interval: Duration,
    /// `--farm slurm`: shards per reference and the jobs' resources.
    pub(super) farm: Option<(u64, crate::farm::Resources)>,
}

/// What the command line asks for.
pub(super) enum Parsed {
    Help,
    Run(Box<Options>),
}

/// A flag's value as a positive integer.
pub(crate) fn positive(flag: &str, value: &str) -> Result<u64, String> {
    match value.trim().parse::<u64>() {
        Ok(n) if n > 0 => Ok(n),
        _ => Err(format!(
            "{flag}: expected a positive integer, got '{value}'"
        )),
    }
}

/// `WxH` with both at least 1 and at most 16384.
pub(crate) fn parse_resolution(value: &str) -> Result<UVec2, String> {
    let err = || format!("--resolution: expected WxH (e.g. 128x96), got '{value}'");
    let (w, h) = value.split_once(['x', 'X']).ok_or_else(err)?;
    let parse = |s: &str| {
        s.trim()
            .parse::<u32>()
            .ok()
            .filter(|n| (1..=16_384).contains(n))
    };
    Ok(UVec2::new(
        parse(w).ok_or_else(err)?,
        parse(h).ok_or_else(err)?,
    ))
}

/// The scene file and the scene's name for `--scene PATH`: relative paths are
/// tried from the current folder, then from the workspace root.
fn resolve_scene(root: &Path, given: &str) -> Result<(PathBuf, String), String> {
    let candidates = [PathBuf::from(given), root.join(given)];
    let path = candidates
        .iter()
        .find(|p| p.exists())
        .ok_or_else(|| format!("--scene: {given}: no such file or folder"))?;
    let file = if path.is_dir() {
        // A manifest wins, as in `scene::load` and `cargo xtask mitsuba`.
        let file = scene::scene_file(path);
        if !file.is_file() {
            return Err(format!(
                "--scene: {given}: the folder has no scene.toml or scene.xml"
            ));
        }
        file
    } else {
        path.clone()
    };
    let name = scene_name(&file);
    Ok((file, name))
}

/// The name of the scene in `file` (the output folder's and the charts'):
/// its folder's for a `scene.toml` or `scene.xml`, else the file's stem.
pub(super) fn scene_name(file: &Path) -> String {
    if file
        .file_name()
        .is_some_and(|n| n == "scene.toml" || n == "scene.xml")
    {
        let dir = file
            .parent()
            .filter(|d| !d.as_os_str().is_empty())
            .unwrap_or(Path::new("."));
        dir.canonicalize()
            .unwrap_or_else(|_| dir.to_path_buf())
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
    } else {
        file.file_stem().map(|n| n.to_string_lossy().into_owned())
    }
    .unwrap_or_else(|| "scene".into())
}

impl Options {
    /// The options of `args`, or a request for the help text.
    pub(super) fn parse(root: &Path, args: &[String]) -> Result<Parsed, String> {
        let mut flags = Flags::default();
        let mut i = 0;
        while i < args.len() {
            let arg = args[i].as_str();
            let (flag, value) = flag_and_value(args, &mut i)?;
            match flag {
                "-h" | "--help" => return Ok(Parsed::Help),
                "--rerender-reference" => flags.rerender = true,
                "--fresh" => flags.fresh = true,
                "--cache" => flags.cache = Some(PathBuf::from(value)),
                "--checkpoint-interval" => {
                    flags.checkpoint_interval = parse_interval(flag, &value)?;
                }
                "--scene" => flags.scene = Some(value),
                "--configs" => flags.configs = Some(parse_configs(&value)?),
                "--iterations" => flags.iterations = Some(positive(flag, &value)?),
                "--reference-iterations" => {
                    flags.reference_iterations = Some(positive(flag, &value)?);
                }
                "--resolution" => flags.resolution = Some(parse_resolution(&value)?),
                "--budget" => flags.budget = parse_budget(&value)?,
                "--unbiased-reference" => flags.unbiased = parse_unbiased(&value)?,
                "--sweep" => parse_sweep(&value, &mut flags.sweep)?,
                "--seed" => flags.seed = parse_seed(&value)?,
                "--tau0" => flags.tau0 = Some(parse_tau0(&value)?),
                "--out" => flags.out = Some(PathBuf::from(value)),
                "--farm" if value == "slurm" => flags.farm = true,
                "--farm" => return Err(format!("--farm: expected slurm, got '{value}'")),
                "--farm-shards" => flags.farm_shards = positive(flag, &value)?,
                "--farm-partition" => flags.farm_resources.partition = Some(value),
                "--farm-time" => flags.farm_resources.time = Some(value),
                "--farm-mem" => flags.farm_resources.mem = Some(value),
                "--farm-cpus-per-task" => {
                    flags.farm_resources.cpus_per_task = u32::try_from(positive(flag, &value)?)
                        .map_err(|_| format!("{flag}: too large"))?;
                }
                _ => {
                    return Err(format!(
                        "unknown option '{arg}' (see `cargo xtask study --help`)"
                    ));
                }
            }
            i += 1;
        }
        flags.into_options(root).map(|o| Parsed::Run(Box::new(o)))
    }
}

/// The flags as given, before defaults.
struct Flags {
    scene: Option<String>,
    configs: Option<Vec<Config>>,
    iterations: Option<u64>,
    reference_iterations: Option<u64>,
    resolution: Option<UVec2>,
    budget: Budget,
    unbiased: Unbiased,
    sweep: Sweep,
    seed: u64,
    tau0: Option<f64>,
    out: Option<PathBuf>,
    cache: Option<PathBuf>,
    rerender: bool,
    fresh: bool,
    checkpoint_interval: Duration,
    farm: bool,
    farm_shards: u64,
    farm_resources: crate::farm::Resources,
}

impl Default for Flags {
    fn default() -> Self {
        Self {
            scene: None,
            configs: None,
            iterations: None,
            reference_iterations: None,
            resolution: None,
            budget: Budget::Full,
            unbiased: Unbiased::Auto,
            sweep: Sweep::default(),
            seed: 1,
            tau0: None,
            out: None,
            cache: None,
            rerender: false,
            fresh: false,
            checkpoint_interval: DEFAULT_CHECKPOINT_INTERVAL,
            farm: false,
            farm_shards: DEFAULT_FARM_SHARDS,
            farm_resources: crate::farm::Resources {
                cpus_per_task: 1,
                ..Default::default()
            },
        }
    }
}

/// Shards per reference with `--farm slurm`.
const DEFAULT_FARM_SHARDS: u64 = 4;

/// How often a render in progress saves its checkpoint: at most a minute
/// of work is lost to a kill, and a save (two films of 48 bytes a pixel,
/// 4.7 MB at 256x192, synced to disk; about 80 ms there on a loaded 2-core
/// machine) costs about 0.1 % of the study's time, outside the curves'
/// times.
const DEFAULT_CHECKPOINT_INTERVAL: Duration = Duration::from_secs(60);

/// Longest `--checkpoint-interval`, a day: a longer one is most likely a
/// unit mistake, and would as well be no checkpoint.
const MAX_CHECKPOINT_INTERVAL_SECONDS: f64 = 86_400.0;

impl Flags {
    /// The options: the scene resolved, the budget's defaults filled in.
    fn into_options(self, root: &Path) -> Result<Options, String> {
        let scene = self
            .scene
            .ok_or("--scene: required (e.g. --scene scenes/caustic-glass)")?;
        let (scene_file, scene_name) = resolve_scene(root, &scene)?;
        let (default_iterations, default_reference, default_resolution) = match self.budget {
            Budget::Quick => (16, 64, Some(UVec2::new(64, 64))),
            Budget::Full => (1024, 10_000, None),
        };
        let configs = match self.configs {
            Some(c) => c,
            None => DEFAULT_CONFIGS
                .split(',')
                .map(Config::parse)
                .collect::<Result<_, _>>()?,
        };
        if !self.sweep.is_empty() && !configs.iter().any(|c| c.regularized) {
            return Err(
                "--sweep: no regularized config to sweep (add a -reg config to --configs)".into(),
            );
        }
        let configs = self.sweep.apply(&configs);
        let out = self
            .out
            .unwrap_or_else(|| root.join("target").join("study").join(&scene_name));
        let cache = self
            .cache
            .unwrap_or_else(|| root.join("target").join("study").join("cache"));
        Ok(Options {
            scene_file,
            scene_name,
            configs,
            iterations: self.iterations.unwrap_or(default_iterations),
            reference_iterations: self.reference_iterations.unwrap_or(default_reference),
            resolution: self.resolution.or(default_resolution),
            budget: self.budget,
            unbiased: self.unbiased,
            sweep: self.sweep,
            seed: self.seed,
            tau0: self.tau0,
            out,
            cache,
            rerender: self.rerender,
            fresh: self.fresh,
            checkpoint_interval: self.checkpoint_interval,
            farm: self.farm.then_some((self.farm_shards, self.farm_resources)),
        })
    }
}

/// The flag at `args[*i]` and its value (`--flag=value`, or the next
/// argument, which `*i` then points to; empty for flags without one).
fn flag_and_value<'a>(args: &'a [String], i: &mut usize) -> Result<(&'a str, String), String> {
    let arg = args[*i].as_str();
    let (flag, inline) = match arg.split_once('=') {
        Some((f, v)) if f.starts_with("--") => (f, Some(v.to_string())),
        _ => (arg, None),
    };
    let takes_value = !matches!(flag, "-h" | "--help" | "--rerender-reference" | "--fresh");
    let value = if takes_value {
        match inline {
            Some(v) => v,
            None => {
                *i += 1;
                args.get(*i)
                    .cloned()
                    .ok_or_else(|| format!("{flag}: missing value"))?
            }
        }
    } else if inline.is_some() {
        return Err(format!("{flag}: takes no value"));
    } else {
        String::new()
    };
    Ok((flag, value))
}

/// `--configs a,b,...`: known names, none twice, at least one.
fn parse_configs(value: &str) -> Result<Vec<Config>, String> {
    let mut list: Vec<Config> = Vec::new();
    for name in value.split(',').filter(|s| !s.trim().is_empty()) {
        let c = Config::parse(name).map_err(|e| format!("--configs: {e}"))?;
        if list.contains(&c) {
            return Err(format!("--configs: '{c}' is listed twice"));
        }
        list.push(c);
    }
    if list.is_empty() {
        return Err("--configs: the list is empty".into());
    }
    Ok(list)
}

/// `--budget quick|full`.
fn parse_budget(value: &str) -> Result<Budget, String> {
    match value.to_ascii_lowercase().as_str() {
        "quick" => Ok(Budget::Quick),
        "full" => Ok(Budget::Full),
        _ => Err(format!("--budget: expected quick or full, got '{value}'")),
    }
}

/// `--unbiased-reference auto|none|C`, C an unregularized config.
fn parse_unbiased(value: &str) -> Result<Unbiased, String> {
    match value.trim().to_ascii_lowercase().as_str() {
        "auto" => return Ok(Unbiased::Auto),
        "none" => return Ok(Unbiased::Skip),
        _ => {}
    }
    let c = Config::parse(value).map_err(|e| format!("--unbiased-reference: {e}"))?;
    if c.regularized {
        return Err(format!(
            "--unbiased-reference: '{c}' is regularized (biased); give an \
             unregularized config: pt, bpt, ppm, bpm or vcm"
        ));
    }
    Ok(Unbiased::Given(c))
}

/// Whether the schedule accepts a swept value (the error says why not).
type ValueCheck = fn(f64) -> Result<(), String>;

/// One `--sweep PARAM=V1,V2,...` into `sweep`: a known parameter not swept
/// yet, and a non-empty list of distinct values the schedule accepts
/// (tau0 > 1/(2 pi); an exponent inside the consistency bound (0, 1/2)).
fn parse_sweep(value: &str, sweep: &mut Sweep) -> Result<(), String> {
    let (name, list) = value.split_once('=').ok_or_else(|| {
        format!("--sweep: expected PARAM=V1,V2,... (tau0 or schedule-exponent), got '{value}'")
    })?;
    let name = name.trim().to_ascii_lowercase();
    let (values, check): (&mut Vec<f64>, ValueCheck) = match name.as_str() {
        "tau0" => (&mut sweep.tau0, |t| {
            Schedule::new(t).map(drop).map_err(|e| e.to_string())
        }),
        "schedule-exponent" => (&mut sweep.exponent, |k| {
            Schedule::with_exponent(DEFAULT_TAU_0, k)
                .map(drop)
                .map_err(|e| e.to_string())
        }),
        _ => {
            return Err(format!(
                "--sweep: unknown parameter '{name}' (expected tau0 or schedule-exponent)"
            ));
        }
    };
    if !values.is_empty() {
        return Err(format!("--sweep: {name} is swept twice"));
    }
    for item in list.split(',').filter(|s| !s.trim().is_empty()) {
        let v = parse_number(item)
            .ok_or_else(|| format!("--sweep: {name}: expected a number, got '{item}'"))?;
        check(v).map_err(|e| format!("--sweep: {name}: {e}"))?;
        if values.contains(&v) {
            return Err(format!("--sweep: {name}: {v} is listed twice"));
        }
        values.push(v);
    }
    if values.is_empty() {
        return Err(format!("--sweep: {name}: no values"));
    }
    Ok(())
}

/// `--checkpoint-interval SECONDS`: 0 up to a day, fractions allowed.
fn parse_interval(flag: &str, value: &str) -> Result<Duration, String> {
    match value.trim().parse::<f64>() {
        Ok(s) if (0.0..=MAX_CHECKPOINT_INTERVAL_SECONDS).contains(&s) => {
            Ok(Duration::from_secs_f64(s))
        }
        _ => Err(format!(
            "{flag}: expected seconds from 0 to {MAX_CHECKPOINT_INTERVAL_SECONDS}, got '{value}'"
        )),
    }
}

/// `--seed N`.
fn parse_seed(value: &str) -> Result<u64, String> {
    value
        .trim()
        .parse::<u64>()
        .map_err(|_| format!("--seed: expected a non-negative integer, got '{value}'"))
}

/// `--tau0 T`: a number the regularization accepts.
fn parse_tau0(value: &str) -> Result<f64, String> {
    let t = value
        .trim()
        .parse::<f64>()
        .map_err(|_| format!("--tau0: expected a number, got '{value}'"))?;
    Regularization::new(Mode::Selective, t, true).map_err(|e| format!("--tau0: {e}"))?;
    Ok(t)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn root() -> PathBuf {
        crate::workspace_root()
    }

    fn parse(args: &[&str]) -> Result<Options, String> {
        let args: Vec<String> = args.iter().map(|s| s.to_string()).collect();
        match Options::parse(&root(), &args)? {
            Parsed::Run(o) => Ok(*o),
            Parsed::Help => Err("help".into()),
        }
    }

    #[test]
    fn configs_parse_and_print() {
        for name in [
            "pt", "pt-reg", "bpt", "bpt-reg", "ppm", "ppm-reg", "bpm", "bpm-reg", "vcm", "vcm-reg",
            "bpt-uns", "vcm-uns",
        ] {
            assert_eq!(Config::parse(name).unwrap().to_string(), name);
        }
        assert_eq!(Config::parse(" VCM-Reg ").unwrap(), Config::REFERENCE);
        assert!(Config::parse("mlt").unwrap_err().contains("'mlt'"));
        let c = Config::parse("bpt-reg")
            .unwrap()
            .render_config(3, 9, 7.5)
            .unwrap();
        assert_eq!((c.algorithm, c.seed, c.max_depth), (Algorithm::Bpt, 3, 9));
        assert_eq!(c.regularization.mode, Mode::Selective);
        assert!(c.regularization.progressive);
        let off = Config::parse("bpt")
            .unwrap()
            .render_config(3, 9, 7.5)
            .unwrap();
        assert_eq!(off.regularization.mode, Mode::Off);
        let unsampleable = Config::parse("vcm-uns")
            .unwrap()
            .render_config(3, 9, 7.5)
            .unwrap();
        assert_eq!(unsampleable.regularization.mode, Mode::Unsampleable);
    }

    /// A swept config's name (curves.json, `--replot`) parses back to it.
    #[test]
    fn names_with_swept_values_parse_back() {
        let swept = Config {
            tau0: Some(7.5),
            exponent: Some(1.0 / 6.0),
            ..Config::parse("bpt-uns").unwrap()
        };
        let name = swept.to_string();
        assert_eq!(name, "bpt-uns@tau0=7.5@exp=0.1667");
        let back = Config::parse_name(&name).unwrap();
        assert_eq!((back.tau0, back.exponent), (Some(7.5), Some(0.1667)));
        assert_eq!(back.to_string(), name);
        assert_eq!(
            Config::parse_name("vcm").unwrap(),
            Config::parse("vcm").unwrap()
        );
        assert!(
            Config::parse_name("bpt-reg@mu=2")
                .unwrap_err()
                .contains("'mu=2'")
        );
    }

    #[test]
    fn budgets_set_defaults_and_flags_win() {
        let quick = parse(&["--scene", "scenes/caustic-glass", "--budget", "quick"]).unwrap();
        assert_eq!(
            (
                quick.iterations,
                quick.reference_iterations,
                quick.resolution
            ),
            (16, 64, Some(UVec2::new(64, 64)))
        );
        assert_eq!(quick.configs.len(), 7);
        assert_eq!(quick.scene_name, "caustic-glass");
        assert!(quick.scene_file.ends_with("scene.toml"));
        assert!(quick.out.ends_with("target/study/caustic-glass"));
        // A folder without a manifest gives its Mitsuba scene file.
        let xml = parse(&["--scene", "scenes/veach-bidir", "--budget", "quick"]).unwrap();
        assert!(xml.scene_file.ends_with("veach-bidir/scene.xml"));
        assert_eq!(xml.scene_name, "veach-bidir");
        let full = parse(&["--scene=scenes/caustic-glass"]).unwrap();
        assert_eq!((full.iterations, full.reference_iterations), (1024, 10_000));
        assert_eq!(full.resolution, None);
        let mixed = parse(&[
            "--budget",
            "quick",
            "--scene",
            "scenes/glossy-caustic/scene.toml",
            "--iterations",
            "8",
            "--resolution",
            "32x24",
            "--configs",
            "bpt,bpt-reg",
            "--unbiased-reference",
            "bpt",
            "--seed",
            "5",
        ])
        .unwrap();
        assert_eq!(mixed.iterations, 8);
        assert_eq!(mixed.reference_iterations, 64);
        assert_eq!(mixed.resolution, Some(UVec2::new(32, 24)));
        assert_eq!(mixed.configs.len(), 2);
        assert_eq!(mixed.scene_name, "glossy-caustic");
        assert_eq!(
            mixed.unbiased,
            Unbiased::Given(Config::plain(Algorithm::Bpt, false))
        );
        assert_eq!(mixed.seed, 5);
        assert_eq!(quick.unbiased, Unbiased::Auto);
        let none = parse(&["--scene=scenes/stiff", "--unbiased-reference=none"]).unwrap();
        assert_eq!(none.unbiased, Unbiased::Skip);
    }

    /// `--sweep` replaces every regularized config by one per value (the
    /// product of both parameters), leaves the others, names the values,
    /// and gives each config its schedule.
    #[test]
    fn sweep_expands_regularized_configs() {
        let o = parse(&[
            "--scene",
            "scenes/caustic-glass",
            "--configs",
            "pt,bpt-reg,vcm",
            "--sweep",
            "tau0=2,30",
            "--sweep=schedule-exponent=0.1,1/4",
        ])
        .unwrap();
        let names: Vec<String> = o.configs.iter().map(Config::to_string).collect();
        assert_eq!(
            names,
            [
                "pt",
                "bpt-reg@tau0=2@exp=0.1",
                "bpt-reg@tau0=2@exp=0.25",
                "bpt-reg@tau0=30@exp=0.1",
                "bpt-reg@tau0=30@exp=0.25",
                "vcm"
            ]
        );
        assert_eq!(
            o.sweep.describe(),
            "tau0 = 2, 30; schedule exponent = 0.1, 0.25"
        );
        let schedule = o.configs[2]
            .render_config(1, 8, 7.5)
            .unwrap()
            .regularization
            .schedule;
        assert_eq!((schedule.tau_0(), schedule.exponent()), (2.0, 0.25));
        // Unswept: the study's tau_0 and the paper's exponent.
        let plain = Config::parse("bpt-reg")
            .unwrap()
            .render_config(1, 8, 7.5)
            .unwrap()
            .regularization
            .schedule;
        assert_eq!(
            (plain.tau_0(), plain.exponent()),
            (7.5, DEFAULT_SCHEDULE_EXPONENT)
        );
        let sixth = parse(&[
            "--scene",
            "scenes/caustic-glass",
            "--configs",
            "vcm-reg",
            "--sweep",
            "schedule-exponent=1/6,0.0123456",
        ])
        .unwrap();
        assert_eq!(sixth.configs[0].exponent, Some(1.0 / 6.0));
        assert_eq!(sixth.configs[0].to_string(), "vcm-reg@exp=0.1667");
        assert_eq!(sixth.configs[1].to_string(), "vcm-reg@exp=0.01235");
        let default = parse(&["--scene", "scenes/caustic-glass", "--sweep", "tau0=120"]).unwrap();
        assert_eq!(default.configs.len(), 7);
        assert_eq!(
            default
                .configs
                .iter()
                .filter(|c| c.tau0 == Some(120.0))
                .count(),
            3,
            "pt-reg, bpt-reg, vcm-reg"
        );
    }

    #[test]
    fn bad_input_is_one_line_naming_the_flag() {
        let cases: &[(&[&str], &str)] = &[
            (&[], "--scene"),
            (&["--scene", "no/such/scene"], "--scene"),
            (&["--scene", "crates"], "scene.toml"),
            (
                &["--scene", "scenes/stiff", "--iterations", "0"],
                "--iterations",
            ),
            (
                &["--scene", "scenes/stiff", "--iterations"],
                "--iterations: missing",
            ),
            (
                &["--scene", "scenes/stiff", "--resolution", "64"],
                "--resolution",
            ),
            (
                &["--scene", "scenes/stiff", "--resolution", "0x4"],
                "--resolution",
            ),
            (
                &["--scene", "scenes/stiff", "--configs", "pt,xx"],
                "--configs",
            ),
            (&["--scene", "scenes/stiff", "--configs", "pt,pt"], "twice"),
            (&["--scene", "scenes/stiff", "--budget", "huge"], "--budget"),
            (
                &["--scene", "scenes/stiff", "--unbiased-reference", "vcm-reg"],
                "regularized",
            ),
            (&["--scene", "scenes/stiff", "--tau0", "0.1"], "--tau0"),
            (&["--scene", "scenes/stiff", "--seed", "-1"], "--seed"),
            (
                &["--scene", "scenes/stiff", "--unbiased-reference", "mlt"],
                "--unbiased-reference",
            ),
            (&["--scene", "scenes/stiff", "--sweep", "tau0"], "PARAM="),
            (
                &["--scene", "scenes/stiff", "--sweep", "radius=1,2"],
                "unknown parameter",
            ),
            (
                &["--scene", "scenes/stiff", "--sweep", "tau0=2,x"],
                "expected a number",
            ),
            (
                &["--scene", "scenes/stiff", "--sweep", "tau0=2,0.1"],
                "1/(2 pi)",
            ),
            (&["--scene", "scenes/stiff", "--sweep", "tau0=2,2"], "twice"),
            (
                &["--scene", "scenes/stiff", "--sweep", "tau0="],
                "no values",
            ),
            (
                &[
                    "--scene",
                    "scenes/stiff",
                    "--sweep",
                    "tau0=2",
                    "--sweep",
                    "tau0=3",
                ],
                "swept twice",
            ),
            (
                &[
                    "--scene",
                    "scenes/stiff",
                    "--sweep",
                    "schedule-exponent=0.5",
                ],
                "between 0 and 1/2",
            ),
            (
                &["--scene", "scenes/stiff", "--sweep", "schedule-exponent=0"],
                "between 0 and 1/2",
            ),
            (
                &[
                    "--scene",
                    "scenes/stiff",
                    "--sweep",
                    "schedule-exponent=-0.2",
                ],
                "between 0 and 1/2",
            ),
            (
                &[
                    "--scene",
                    "scenes/stiff",
                    "--configs",
                    "pt,bpt",
                    "--sweep",
                    "tau0=2",
                ],
                "no regularized config",
            ),
            (&["--scene", "scenes/stiff", "--frobnicate"], "--frobnicate"),
            (
                &["--scene", "scenes/stiff", "--checkpoint-interval", "-1"],
                "--checkpoint-interval",
            ),
            (
                &["--scene", "scenes/stiff", "--checkpoint-interval", "x"],
                "--checkpoint-interval",
            ),
            (&["--scene", "scenes/stiff", "--fresh=1"], "takes no value"),
        ];
        for (args, needle) in cases {
            let e = parse(args).unwrap_err();
            assert!(e.contains(needle), "{args:?}: {e}");
            assert!(!e.contains('\n'), "{args:?}: {e}");
        }
        assert!(matches!(
            Options::parse(&root(), &["--help".to_string()]),
            Ok(Parsed::Help)
        ));
    }

    #[test]
    fn help_documents_every_flag() {
        for flag in [
            "--scene",
            "--configs",
            "--iterations",
            "--reference-iterations",
            "--resolution",
            "--budget",
            "--unbiased-reference",
            "--sweep",
            "schedule-exponent",
            "--seed",
            "--tau0",
            "--out",
            "--rerender-reference",
            "--fresh",
            "--cache",
            "--checkpoint-interval",
            "--help",
            "--replot",
        ] {
            assert!(HELP.contains(flag), "{flag}");
        }
    }
}
