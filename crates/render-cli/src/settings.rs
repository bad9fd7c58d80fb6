//! The settings of one render, each resolved in one place with its origin.
//!
//! Precedence, highest first: a flag, the scene manifest's `[render]` table,
//! the built-in default. Flags were checked by clap as they were parsed;
//! manifest values are checked here, with the same checks (`values`), and an
//! error names the manifest and the key. A manifest value that a flag
//! overrides is not looked at.

use std::fmt;
use std::path::Path;
use std::time::Duration;

use integrators::{
    Algorithm, DEFAULT_MAX_DEPTH, DEFAULT_RADIUS_FACTOR, DEFAULT_SHADOW_ROULETTE, DEFAULT_TAU_0,
    Energy, Mode, Regularization, RenderConfig, Strategies,
};
use scene::RenderSettings;

use crate::cli::Cli;
use crate::error::ArgError;
use crate::values::{
    at_least_one, check_radius, check_shadow_roulette, check_tau0, parse_algorithm,
    parse_regularize,
};

/// Iterations when neither a flag nor the manifest gives a count or a time.
pub const DEFAULT_ITERATIONS: u64 = 64;
/// Regularization mode when neither a flag nor the manifest gives one.
/// `unsampleable`, the tau_0 sweep's choice: against the unbiased reference it was as
/// good as or better than `selective` on every study scene, for BPT and VCM (docs/studies.md,
/// "Regularization against the truth"; SPEC §5's default rule is selective).
pub const DEFAULT_MODE: Mode = Mode::Unsampleable;
/// Seed when neither a flag nor the manifest gives one.
pub const DEFAULT_SEED: u64 = 0;

/// Where a setting's value came from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Origin {
    /// A command-line flag.
    Flag,
    /// The scene file: a manifest's `[render]` table, or a Mitsuba file's
    /// integrator, sampler and film.
    Manifest,
    /// The built-in default.
    Default,
}

impl fmt::Display for Origin {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Flag => "flag",
            Self::Manifest => "scene file",
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
    /// The global index of the first iteration (1 unless `--iteration-range`).
    pub first_iteration: u64,
    /// Origin of `config.algorithm`.
    pub algorithm: Origin,
    /// Origin of `config.regularization.mode`.
    pub mode: Origin,
    /// Origin of tau_0.
    pub tau0: Origin,
    /// Origin of `config.regularization.progressive`.
    pub progressive: Origin,
    /// Origin of `config.regularization.energy`.
    pub energy: Origin,
    /// Origin of `config.max_depth`.
    pub max_depth: Origin,
    /// Origin of `config.seed`.
    pub seed: Origin,
    /// Origin of `config.radius_factor`.
    pub radius: Origin,
    /// Origin of `config.shadow_roulette`.
    pub shadow_roulette: Origin,
    /// Origin of `config.virtual_merges` (`None` by default: the integrator decides).
    pub virtual_merges: Origin,
}

impl Settings {
    /// Every render setting: the flag, else the manifest's value (checked
    /// here; errors name `manifest_path` and the key), else the default.
    pub fn resolve(
        cli: &Cli,
        manifest: &RenderSettings,
        manifest_path: &Path,
    ) -> Result<Self, ArgError> {
        let key = |key, flag| manifest_error(manifest_path, key, flag);
        let algorithm = pick(
            cli.integrator,
            manifest.integrator.as_deref(),
            Algorithm::default(),
            |s| parse_algorithm(s).map_err(key("integrator", "--integrator")),
        )?;
        let budget = budget(cli, manifest.iterations, key("iterations", "--iterations"))?;
        let mode = pick(
            cli.regularize,
            manifest.regularize.as_deref(),
            DEFAULT_MODE,
            |s| parse_regularize(s).map_err(key("regularize", "--regularize")),
        )?;
        let tau0 = pick(cli.tau0, manifest.tau0, DEFAULT_TAU_0, |t| {
            check_tau0(t).map_err(key("tau0", "--tau0"))
        })?;
        let flag = match (cli.progressive, cli.no_progressive) {
            (true, _) => Some(true),
            (_, true) => Some(false),
            _ => None,
        };
        let progressive = pick(flag, manifest.progressive, true, Ok)?;
        let energy = pick(cli.regularize_energy, manifest.regularize_energy, true, Ok)?;
        let max_depth = pick(cli.max_depth, manifest.max_depth, DEFAULT_MAX_DEPTH, |d| {
            at_least_one(u64::from(d))
                .map(|_| d)
                .map_err(key("max_depth", "--max-depth"))
        })?;
        let seed = pick(cli.seed, manifest.seed, DEFAULT_SEED, Ok)?;
        let radius = pick(cli.radius, manifest.radius, DEFAULT_RADIUS_FACTOR, |r| {
            check_radius(r).map_err(key("radius", "--radius"))
        })?;
        let shadow_roulette = pick(
            cli.shadow_roulette,
            manifest.shadow_roulette,
            DEFAULT_SHADOW_ROULETTE,
            |t| check_shadow_roulette(t).map_err(key("shadow_roulette", "--shadow-roulette")),
        )?;
        let virtual_merges = pick(
            cli.virtual_merges.map(Some),
            manifest.virtual_merges,
            None,
            |on| Ok(Some(on)),
        )?;
        let regularization = Regularization {
            energy: if energy.value {
                Energy::Preserved
            } else {
                Energy::Lost
            },
            ..Regularization::new(mode.value, tau0.value, progressive.value).map_err(
                |e| match tau0.origin {
                    Origin::Manifest => key("tau0", "--tau0")(e.to_string()),
                    _ => ArgError::Flag {
                        flag: "--tau0",
                        message: e.to_string(),
                    },
                },
            )?
        };
        Ok(Self {
            config: RenderConfig {
                algorithm: algorithm.value,
                strategies: Strategies::Mis,
                max_depth: max_depth.value,
                seed: seed.value,
                regularization,
                virtual_merges: virtual_merges.value,
                radius_factor: radius.value,
                shadow_roulette: shadow_roulette.value,
                wavefront: !cli.scalar_loop,
                ..RenderConfig::default()
            },
            budget,
            first_iteration: cli.iteration_range.map_or(1, |(first, _)| first),
            algorithm: algorithm.origin,
            mode: mode.origin,
            tau0: tau0.origin,
            progressive: progressive.origin,
            energy: energy.origin,
            max_depth: max_depth.origin,
            seed: seed.origin,
            radius: radius.origin,
            shadow_roulette: shadow_roulette.origin,
            virtual_merges: virtual_merges.origin,
        })
    }
}

/// The error of a bad value of the manifest's `key`, which `flag` overrides.
fn manifest_error(
    manifest: &Path,
    key: &'static str,
    flag: &'static str,
) -> impl Fn(String) -> ArgError {
    move |message| ArgError::Manifest {
        manifest: manifest.to_path_buf(),
        key,
        flag,
        message,
    }
}

/// `--iterations` or `--time`, else the manifest's iterations, else the default count.
fn budget(
    cli: &Cli,
    manifest_iterations: Option<u32>,
    error: impl Fn(String) -> ArgError,
) -> Result<Resolved<Budget>, ArgError> {
    let flag_value = match (cli.iterations, cli.time, cli.iteration_range) {
        (Some(n), _, _) => Some(Budget::Iterations(n)),
        (None, Some(t), _) => Some(Budget::Time(t)),
        (None, None, Some((first, last))) => Some(Budget::Iterations(last - first + 1)),
        (None, None, None) => None,
    };
    pick(
        flag_value,
        manifest_iterations,
        Budget::Iterations(DEFAULT_ITERATIONS),
        |n| {
            at_least_one(u64::from(n))
                .map(Budget::Iterations)
                .map_err(error)
        },
    )
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

/// Bytes a render of `width` x `height` pixels needs, estimated: the film's
/// sums and squared sums (two f64 RGB triples, 48 bytes a pixel) plus one
/// f32 RGB estimate a pixel (the iteration's image, or the mean written out:
/// 12 bytes), doubled as a margin for the integrator's per-thread buffers,
/// the PNG and allocator slack. The scene and its BVH are not counted: they
/// are already loaded when this is checked.
pub fn film_bytes(width: u32, height: u32) -> u64 {
    u64::from(width) * u64::from(height) * (48 + 12) * 2
}

/// `MemAvailable` of /proc/meminfo in bytes; `None` where it cannot be read
/// (not Linux, a sandbox): the memory check is then skipped.
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    kib.checked_mul(1024)
}

/// Refuses a render whose estimated needs (`(what, bytes)` pairs: the film,
/// the BVH, the photon map) do not fit in `available` bytes (skipped when
/// `None`), before they are allocated: an allocation that fails aborts the
/// process. `source` says where the resolution came from (flag or manifest
/// key), `(width, height)` is the resolution.
pub fn check_memory(
    needs: &[(&str, u64)],
    (width, height): (u32, u32),
    source: &str,
    available: Option<u64>,
) -> Result<(), String> {
    let needed: u64 = needs.iter().map(|(_, bytes)| bytes).sum();
    let parts: Vec<String> = needs
        .iter()
        .map(|(what, bytes)| format!("{what} {}", gib(*bytes)))
        .collect();
    match available {
        Some(available) if needed > available => Err(format!(
            "{source}: {width}x{height} needs about {} of memory ({}) but only {} is \
             available; lower the resolution",
            gib(needed),
            parts.join(", "),
            gib(available)
        )),
        _ => Ok(()),
    }
}

fn gib(bytes: u64) -> String {
    format!("{:.1} GiB", bytes as f64 / f64::from(1u32 << 30))
}

#[cfg(test)]
mod tests {
    #[test]
    fn a_render_larger_than_the_memory_is_refused() {
        assert_eq!(super::film_bytes(10, 10), 12_000);
        let size = (30000, 30000);
        let needs = [("film", super::film_bytes(30000, 30000)), ("BVH", 1 << 30)];
        let e = super::check_memory(&needs, size, "--resolution", Some(8 << 30)).unwrap_err();
        assert!(
            e.starts_with("--resolution: 30000x30000 needs about 101.6 GiB of memory (film 100.6 GiB, BVH 1.0 GiB)"),
            "{e}"
        );
        assert!(super::check_memory(&needs, size, "--resolution", None).is_ok());
        let small = [("film", super::film_bytes(512, 512))];
        assert!(super::check_memory(&small, (512, 512), "--resolution", Some(8 << 30)).is_ok());
    }

    use super::*;
    use crate::values::{parse_radius, parse_shadow_roulette};

    fn resolve(args: &[&str], manifest: &RenderSettings) -> Result<Settings, ArgError> {
        let cli = Cli::parse_test(args).expect("valid flags");
        Settings::resolve(&cli, manifest, Path::new("dir/scene.toml"))
    }

    fn full_manifest() -> RenderSettings {
        RenderSettings {
            integrator: Some("pt".into()),
            iterations: Some(16),
            max_depth: Some(5),
            regularize: Some("uniform".into()),
            tau0: Some(30.0),
            progressive: Some(false),
            seed: Some(7),
            radius: Some(0.01),
            shadow_roulette: Some(0.0),
            virtual_merges: Some(false),
            regularize_energy: Some(false),
        }
    }

    #[test]
    fn the_manifest_overrides_defaults() {
        let s = resolve(&[], &full_manifest()).unwrap();
        let c = &s.config;
        assert_eq!(s.budget, manifest(Budget::Iterations(16)));
        assert_eq!((c.algorithm, c.max_depth, c.seed), (Algorithm::Pt, 5, 7));
        assert_eq!(c.regularization.mode, Mode::Uniform);
        assert_eq!(c.regularization.schedule.tau_0(), 30.0);
        assert!(!c.regularization.progressive);
        assert_eq!((c.radius_factor, c.shadow_roulette), (0.01, 0.0));
        assert_eq!(c.virtual_merges, Some(false));
        assert_eq!(c.regularization.energy, Energy::Lost);
        let origins = [
            s.energy,
            s.algorithm,
            s.mode,
            s.tau0,
            s.max_depth,
            s.seed,
            s.radius,
            s.shadow_roulette,
            s.virtual_merges,
            s.progressive,
        ];
        assert!(origins.iter().all(|o| *o == Origin::Manifest), "{s:?}");
    }

    #[test]
    fn flags_override_the_manifest() {
        let args = [
            "--iterations=3",
            "--max-depth=2",
            "--regularize=off",
            "--tau0=8",
            "--seed=1",
            "--progressive",
            "--radius=0.02",
            "--shadow-roulette=0.5",
            "--virtual-merges=on",
            "--regularize-energy=on",
        ];
        let s = resolve(&args, &full_manifest()).unwrap();
        let c = &s.config;
        assert_eq!(s.budget, flag(Budget::Iterations(3)));
        assert_eq!((c.max_depth, c.seed), (2, 1));
        assert_eq!(c.regularization.mode, Mode::Off);
        assert_eq!(c.regularization.schedule.tau_0(), 8.0);
        assert!(c.regularization.progressive);
        assert_eq!((c.radius_factor, c.shadow_roulette), (0.02, 0.5));
        assert_eq!(c.virtual_merges, Some(true));
        assert_eq!(c.regularization.energy, Energy::Preserved);
        let origins = [
            s.energy,
            s.mode,
            s.tau0,
            s.progressive,
            s.max_depth,
            s.seed,
            s.radius,
            s.shadow_roulette,
            s.virtual_merges,
        ];
        assert!(origins.iter().all(|o| *o == Origin::Flag), "{s:?}");
        assert_eq!(s.algorithm, Origin::Manifest);

        let s = resolve(&["--time", "2"], &full_manifest()).unwrap();
        assert_eq!(s.budget, flag(Budget::Time(Duration::from_secs(2))));
    }

    #[test]
    fn defaults_apply_where_flags_and_manifest_are_silent() {
        let s = resolve(&[], &RenderSettings::default()).unwrap();
        let c = &s.config;
        assert_eq!(s.budget.value, Budget::Iterations(DEFAULT_ITERATIONS));
        assert_eq!((c.max_depth, c.seed), (DEFAULT_MAX_DEPTH, DEFAULT_SEED));
        assert_eq!(c.regularization.mode, DEFAULT_MODE);
        assert_eq!(c.regularization.schedule.tau_0(), DEFAULT_TAU_0);
        assert_eq!(c.radius_factor, DEFAULT_RADIUS_FACTOR);
        assert_eq!(c.shadow_roulette, DEFAULT_SHADOW_ROULETTE);
        assert_eq!(c.virtual_merges, None);
        assert_eq!(c.regularization.energy, Energy::Preserved);
        let origins = [
            s.energy,
            s.budget.origin,
            s.algorithm,
            s.mode,
            s.tau0,
            s.progressive,
            s.max_depth,
            s.seed,
            s.radius,
            s.shadow_roulette,
            s.virtual_merges,
        ];
        assert!(origins.iter().all(|o| *o == Origin::Default), "{s:?}");
        // Exactly what the integrators crate would choose by itself.
        let defaults = RenderConfig::default();
        assert_eq!(
            (c.radius_factor, c.shadow_roulette, c.radius_alpha),
            (
                defaults.radius_factor,
                defaults.shadow_roulette,
                defaults.radius_alpha
            )
        );
    }

    /// The error of a manifest with only `set` applied.
    fn bad(set: impl FnOnce(&mut RenderSettings)) -> String {
        let mut settings = RenderSettings::default();
        set(&mut settings);
        resolve(&[], &settings).unwrap_err().to_string()
    }

    #[test]
    fn bad_manifest_values_name_the_manifest_and_key() {
        let cases = [
            (
                bad(|m| m.regularize = Some("strict".into())),
                "regularize",
                "--regularize",
            ),
            (
                bad(|m| m.integrator = Some("xyz".into())),
                "integrator",
                "--integrator",
            ),
            (bad(|m| m.tau0 = Some(0.1)), "tau0", "--tau0"),
            (
                bad(|m| m.iterations = Some(0)),
                "iterations",
                "--iterations",
            ),
            (bad(|m| m.max_depth = Some(0)), "max_depth", "--max-depth"),
            (bad(|m| m.radius = Some(f32::NAN)), "radius", "--radius"),
            (bad(|m| m.radius = Some(0.0)), "radius", "--radius"),
            (bad(|m| m.radius = Some(-0.5)), "radius", "--radius"),
            (
                bad(|m| m.radius = Some(f32::INFINITY)),
                "radius",
                "--radius",
            ),
            (
                bad(|m| m.shadow_roulette = Some(-0.1)),
                "shadow_roulette",
                "--shadow-roulette",
            ),
            (
                bad(|m| m.shadow_roulette = Some(f32::NAN)),
                "shadow_roulette",
                "--shadow-roulette",
            ),
            (
                bad(|m| m.shadow_roulette = Some(f32::INFINITY)),
                "shadow_roulette",
                "--shadow-roulette",
            ),
        ];
        for (text, key, flag) in cases {
            let prefix = format!("dir/scene.toml: [render] {key}: ");
            let suffix = format!("(set in the manifest; the {flag} flag overrides it)");
            assert!(
                text.starts_with(&prefix) && text.ends_with(&suffix),
                "{text}"
            );
            assert!(!text.contains('\n'), "{text}");
        }
        // The same ranges and wording as the flags.
        let text = bad(|m| m.radius = Some(-0.5));
        assert!(text.contains(&parse_radius("-0.5").unwrap_err()), "{text}");
        let text = bad(|m| m.shadow_roulette = Some(-1.0));
        assert!(
            text.contains(&parse_shadow_roulette("-1").unwrap_err()),
            "{text}"
        );
    }

    #[test]
    fn a_bad_manifest_value_that_a_flag_overrides_is_not_looked_at() {
        let bad = RenderSettings {
            regularize: Some("strict".into()),
            radius: Some(f32::NAN),
            shadow_roulette: Some(-1.0),
            ..Default::default()
        };
        let args = [
            "--regularize",
            "uniform",
            "--radius",
            "0.1",
            "--shadow-roulette",
            "0",
        ];
        let s = resolve(&args, &bad).unwrap();
        assert_eq!(s.config.regularization.mode, Mode::Uniform);
        assert_eq!(
            (s.config.radius_factor, s.config.shadow_roulette),
            (0.1, 0.0)
        );
    }

    /// `Resolved` from the manifest.
    fn manifest<T>(value: T) -> Resolved<T> {
        Resolved {
            value,
            origin: Origin::Manifest,
        }
    }
}
