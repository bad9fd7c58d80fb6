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
    Algorithm, DEFAULT_MAX_DEPTH, DEFAULT_TAU_0, Mode, Regularization, RenderConfig, Strategies,
};
use scene::RenderSettings;

use crate::cli::Cli;
use crate::error::ArgError;
use crate::values::{at_least_one, check_tau0, parse_algorithm, parse_regularize};

/// Iterations when neither a flag nor the manifest gives a count or a time.
pub const DEFAULT_ITERATIONS: u64 = 64;
/// Regularization mode when neither a flag nor the manifest gives one.
pub const DEFAULT_MODE: Mode = Mode::Selective;
/// Seed when neither a flag nor the manifest gives one.
pub const DEFAULT_SEED: u64 = 0;

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

impl Cli {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn cli(args: &[&str]) -> Result<Cli, clap::Error> {
        Cli::parse_test(args)
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
            ..Default::default()
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
}
