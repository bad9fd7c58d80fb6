//! The run cache: every finished config's curve (the times, errors and
//! noise at its checkpoints), its dropped samples, setup time and final
//! image, in `<cache>/runs/<key>.json` and `<key>.exr`, stored as soon as
//! the config is done. A study run again with the same settings (after a
//! kill, or to redo its report) reuses them instead of rendering; the
//! curves' times are those of the run that rendered them.
//!
//! The key hashes everything a curve depends on: the scene's files (as the
//! reference cache's key does), the config's resolved render settings
//! (seed, depth, schedule, ...), the iterations and resolution, the keys of
//! the references it is measured against, the renderer's version (as
//! [`cache::renderer_version`] computes it) and the source of the metrics
//! (RMSE, noise and the checkpoints are computed here, not by the renderer).
//!
//! Floats are stored as text in Rust's shortest round-trip form, so that a
//! reused curve has exactly the values of the rendered one (serde_json's
//! default number parser may miss by an ulp).

use std::fs;
use std::path::{Path, PathBuf};

use serde_json::{Value, json};

use super::cache::{self, Fnv64};
use super::metrics::{Errors, Noise};
use super::{Config, Origin, Point, Run};

/// The layout of an entry and of the key's inputs: changing either
/// changes this, which orphans every older entry.
const FORMAT: &str = "rlt study run v1";

/// The metrics' source, hashed into the key: a changed definition of an
/// error, of the noise or of the checkpoints changes every curve.
const METRICS_SOURCE: &str = include_str!("metrics.rs");

/// What a config's run depends on besides the scene and the renderer.
#[derive(Clone, Debug, PartialEq)]
pub struct RunSpec {
    /// The config (its name holds the swept values).
    pub config: Config,
    /// Every resolved render setting, as one line (`RenderConfig`'s Debug).
    pub settings: String,
    /// Iterations.
    pub iterations: u64,
    /// Resolution.
    pub width: u32,
    /// Resolution.
    pub height: u32,
    /// Keys of the references the errors are measured against, in order.
    pub references: Vec<String>,
}

impl RunSpec {
    /// The inputs as one canonical line (hashed into the key).
    pub fn canonical(&self) -> String {
        format!(
            "config={};settings={};iterations={};resolution={}x{};references={}",
            self.config,
            self.settings,
            self.iterations,
            self.width,
            self.height,
            self.references.join(",")
        )
    }

    /// The cache key: 16 hex digits.
    pub fn key(&self, scene_hash: u64, renderer_version: &str) -> String {
        let mut h = Fnv64::default();
        h.field(FORMAT.as_bytes());
        h.field(&scene_hash.to_le_bytes());
        h.field(self.canonical().as_bytes());
        h.field(renderer_version.as_bytes());
        h.field(METRICS_SOURCE.as_bytes());
        format!("{:016x}", h.finish())
    }
}

/// The folder of the run cache inside the study cache.
pub fn folder(cache_dir: &Path) -> PathBuf {
    cache_dir.join("runs")
}

/// An entry's files: the sidecar and the final image.
fn paths(cache_dir: &Path, key: &str) -> (PathBuf, PathBuf) {
    let dir = folder(cache_dir);
    (
        dir.join(format!("{key}.json")),
        dir.join(format!("{key}.exr")),
    )
}

/// The cached run of `key`, if its sidecar and image are there, whole and
/// of `spec`'s shape (every checkpoint up to the last iteration, one error
/// per reference, the resolution).
pub fn load(cache_dir: &Path, key: &str, spec: &RunSpec) -> Option<Run> {
    let (json, exr) = paths(cache_dir, key);
    let meta: Value = serde_json::from_str(&fs::read_to_string(json).ok()?).ok()?;
    if meta["format"].as_str() != Some(FORMAT) || meta["key"].as_str() != Some(key) {
        return None;
    }
    let points = points_from_json(&meta["points"], spec.references.len())?;
    if points.last()?.iteration != spec.iterations {
        return None;
    }
    let image = image_io::read_exr(&exr).ok()?;
    if (image.width, image.height) != (spec.width, spec.height) {
        return None;
    }
    Some(Run {
        config: spec.config,
        key: key.to_owned(),
        origin: Origin::Cached,
        setup_seconds: number(&meta["setup_seconds"])?,
        points,
        invalid_samples: meta["invalid_samples"].as_u64()?,
        image: image.pixels,
    })
}

/// Stores a finished run: the image first, then the sidecar, each
/// atomically, so that a sidecar always has its image.
pub fn store(
    cache_dir: &Path,
    spec: &RunSpec,
    run: &Run,
    about: &serde_json::Map<String, Value>,
) -> Result<(), String> {
    let dir = folder(cache_dir);
    fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
    let (json, exr) = paths(cache_dir, &run.key);
    cache::write_atomic(&exr, |tmp| {
        crate::write_exr(tmp, spec.width, spec.height, &run.image)
    })?;
    let mut meta = json!({
        "format": FORMAT,
        "key": run.key,
        "config": run.config.to_string(),
        "inputs": spec.canonical(),
        "setup_seconds": text(run.setup_seconds),
        "invalid_samples": run.invalid_samples,
        "points": points_json(&run.points),
    });
    if let Some(m) = meta.as_object_mut() {
        m.extend(about.clone());
    }
    let text = serde_json::to_string_pretty(&meta).map_err(|e| e.to_string())? + "\n";
    cache::write_atomic_bytes(&json, text.as_bytes())
}

/// Checkpoints as JSON (checkpoint files use it too).
pub fn points_json(points: &[Point]) -> Value {
    points
        .iter()
        .map(|p| {
            json!({
                "iteration": p.iteration,
                "seconds": text(p.seconds),
                "cpu_seconds": p.cpu_seconds.map(text),
                "noise_std_error": p.noise.map(|n| text(n.std_error)),
                "noise_variance": p.noise.map(|n| text(n.variance)),
                "errors": p.errors.iter().map(|e| json!({
                    "rmse": text(e.rmse),
                    "rel_mse": text(e.rel_mse),
                })).collect::<Vec<_>>(),
            })
        })
        .collect()
}

/// [`points_json`] read back; None unless every point has an error per
/// reference and the iterations increase.
pub fn points_from_json(value: &Value, references: usize) -> Option<Vec<Point>> {
    let points = value
        .as_array()?
        .iter()
        .map(|p| {
            let errors = p["errors"]
                .as_array()?
                .iter()
                .map(|e| {
                    Some(Errors {
                        rmse: number(&e["rmse"])?,
                        rel_mse: number(&e["rel_mse"])?,
                    })
                })
                .collect::<Option<Vec<_>>>()?;
            let noise = match (&p["noise_std_error"], &p["noise_variance"]) {
                (Value::Null, Value::Null) => None,
                (s, v) => Some(Noise {
                    std_error: number(s)?,
                    variance: number(v)?,
                }),
            };
            let cpu_seconds = match &p["cpu_seconds"] {
                Value::Null => None,
                t => Some(number(t)?),
            };
            (errors.len() == references).then_some(Point {
                iteration: p["iteration"].as_u64()?,
                seconds: number(&p["seconds"])?,
                cpu_seconds,
                noise,
                errors,
            })
        })
        .collect::<Option<Vec<_>>>()?;
    points
        .windows(2)
        .all(|w| w[0].iteration < w[1].iteration)
        .then_some(points)
}

/// A float as text that parses back to the same bits.
pub fn text(v: f64) -> String {
    format!("{v:?}")
}

/// A float written by [`text`].
pub fn number(value: &Value) -> Option<f64> {
    value.as_str()?.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec() -> RunSpec {
        RunSpec {
            config: Config::parse_name("bpt-uns@tau0=30").unwrap(),
            settings: "RenderConfig { seed: 1 }".into(),
            iterations: 64,
            width: 4,
            height: 2,
            references: vec!["00000000000000aa".into(), "00000000000000bb".into()],
        }
    }

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("xtask-runs-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        dir
    }

    fn point(iteration: u64, rmse: f64) -> Point {
        Point {
            iteration,
            seconds: 0.1 * iteration as f64 + 1e-17,
            cpu_seconds: (iteration > 1).then_some(std::f64::consts::PI * iteration as f64),
            noise: (iteration > 1).then_some(Noise {
                std_error: 1.0 / 3.0,
                variance: 1.0 / 9.0,
            }),
            errors: vec![
                Errors {
                    rmse,
                    rel_mse: rmse * rmse / 7.0,
                },
                Errors {
                    rmse: f64::NAN,
                    rel_mse: f64::INFINITY,
                },
            ],
        }
    }

    /// Every input of the key changes it; the same inputs give the same key.
    #[test]
    fn key_follows_every_input() {
        let key = spec().key(1, "v");
        assert_eq!(key, spec().key(1, "v"));
        assert_eq!(key.len(), 16);
        assert_ne!(key, spec().key(2, "v"));
        assert_ne!(key, spec().key(1, "w"));
        let changed = [
            RunSpec {
                config: Config::parse_name("bpt-uns@tau0=7.5").unwrap(),
                ..spec()
            },
            RunSpec {
                settings: "RenderConfig { seed: 2 }".into(),
                ..spec()
            },
            RunSpec {
                iterations: 63,
                ..spec()
            },
            RunSpec {
                width: 2,
                height: 4,
                ..spec()
            },
            RunSpec {
                references: vec!["00000000000000aa".into()],
                ..spec()
            },
            RunSpec {
                references: vec!["00000000000000bb".into(), "00000000000000aa".into()],
                ..spec()
            },
        ];
        for c in changed {
            assert_ne!(c.key(1, "v"), key, "{}", c.canonical());
        }
    }

    /// A stored run reads back the same, bit for bit (NaN and infinite
    /// errors, missing CPU times and noise included); an entry of another
    /// shape, or a damaged one, is a miss.
    #[test]
    fn runs_round_trip_exactly_and_mismatches_miss() {
        let dir = temp_dir("round-trip");
        let s = spec();
        let key = s.key(1, "v");
        let run = Run {
            config: s.config,
            key: key.clone(),
            origin: Origin::Rendered,
            setup_seconds: 0.123_456_789_012_345_67,
            points: vec![point(1, 0.3), point(2, 0.2), point(64, 0.1 + 1e-16)],
            invalid_samples: 3,
            image: (0..8).map(|i| glam::Vec3::splat(i as f32 / 3.0)).collect(),
        };
        let about = serde_json::Map::from_iter([("scene".to_string(), json!("x"))]);
        store(&dir, &s, &run, &about).unwrap();
        let back = load(&dir, &key, &s).unwrap();
        assert_eq!(back.origin, Origin::Cached);
        assert_eq!(back.image, run.image);
        assert_eq!(back.invalid_samples, 3);
        assert_eq!(back.setup_seconds.to_bits(), run.setup_seconds.to_bits());
        let bits = |p: &[Point]| -> Vec<u64> {
            p.iter()
                .flat_map(|p| {
                    [p.seconds, p.cpu_seconds.unwrap_or(-1.0)]
                        .into_iter()
                        .chain(p.noise.map_or([-1.0; 2], |n| [n.std_error, n.variance]))
                        .chain(p.errors.iter().flat_map(|e| [e.rmse, e.rel_mse]))
                        .map(f64::to_bits)
                        .chain([p.iteration])
                })
                .collect()
        };
        assert_eq!(bits(&back.points), bits(&run.points));
        // Another number of references, iterations or resolution: a miss.
        let one_reference = RunSpec {
            references: vec!["00000000000000aa".into()],
            ..spec()
        };
        assert!(load(&dir, &key, &one_reference).is_none());
        assert!(
            load(
                &dir,
                &key,
                &RunSpec {
                    iterations: 65,
                    ..spec()
                }
            )
            .is_none()
        );
        assert!(
            load(
                &dir,
                &key,
                &RunSpec {
                    width: 8,
                    height: 1,
                    ..spec()
                }
            )
            .is_none()
        );
        assert!(load(&dir, "0000000000000000", &s).is_none());
        // A damaged sidecar or a missing image: a miss, not an error.
        let (json, exr) = paths(&dir, &key);
        let text = fs::read_to_string(&json).unwrap();
        fs::write(&json, &text[..text.len() / 2]).unwrap();
        assert!(load(&dir, &key, &s).is_none());
        fs::write(&json, text).unwrap();
        assert!(load(&dir, &key, &s).is_some());
        fs::remove_file(exr).unwrap();
        assert!(load(&dir, &key, &s).is_none());
        // No temporary file is left behind.
        let names: Vec<String> = fs::read_dir(folder(&dir))
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert_eq!(names, [format!("{key}.json")]);
        fs::remove_dir_all(dir).unwrap();
    }
}
