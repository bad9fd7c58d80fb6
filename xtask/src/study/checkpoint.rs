//! Checkpoints of renders in progress, so that a study killed in the middle
//! of a config (or of a reference) continues it where it stopped instead of
//! starting it again.
//!
//! A render's checkpoint is the folder `<cache>/partial/<key>/` (the key of
//! its run or reference entry): the film of the RGB estimates and the film
//! of their luminance after iteration N (`rgb-N.rltfilm`,
//! `luminance-N.rltfilm`, `image_io::film_file`, whole or absent), and
//! `state.json`, written after them, naming N with the cumulative render
//! times, the dropped samples and the curve's points so far. Every file is
//! written atomically, so a kill at any moment leaves the previous
//! checkpoint or the new one. An iteration is a pure function of its index,
//! so the films after N plus iterations N+1.. give the same bytes as an
//! uninterrupted render; the resumed curve's times go on from the
//! checkpoint's. The folder goes when the render's entry is stored.

use std::fs;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use image_io::film_file::{self, FilmHeader, PartialFilm};
use image_io::lock::FileLock;
use integrators::Film;
use serde_json::{Value, json};

use super::runs::{number, points_from_json, points_json, text};
use super::{Point, Rendered, cache};

/// The layout of `state.json`.
const FORMAT: &str = "rlt study checkpoint v1";

/// A render's state read back from its checkpoint.
pub struct Resumed {
    /// The films and cumulative times after the checkpoint's iteration.
    pub state: Rendered,
    /// NaN/Inf samples dropped up to it.
    pub invalid_samples: u64,
    /// The curve's points up to it.
    pub points: Vec<Point>,
}

/// Where and how often one render keeps its checkpoint.
pub struct Checkpoints {
    folder: PathBuf,
    key: String,
    /// What the films' headers say (scene, settings, seed): a film of
    /// another render is refused.
    header: FilmHeader,
    interval: Duration,
    last_save: Instant,
    /// Held while this process renders: a second study rendering the same
    /// entry at the same time is refused.
    _lock: Option<FileLock>,
}

impl Checkpoints {
    /// [`Checkpoints::new`], locked for this process (`<folder>/checkpoint.lock`,
    /// `image_io::lock`: released when the process ends, however); an error
    /// naming the holder's pid when another process renders `key` now.
    pub fn locked(
        cache_dir: &Path,
        key: &str,
        interval: Duration,
        header: FilmHeader,
    ) -> Result<Self, String> {
        let mut checkpoints = Self::new(cache_dir, key, interval, header);
        fs::create_dir_all(&checkpoints.folder)
            .map_err(|e| format!("cannot create {}: {e}", checkpoints.folder.display()))?;
        let lock = FileLock::acquire(&checkpoints.folder.join("checkpoint"))
            .map_err(|e| format!("study checkpoint: {e}"))?;
        checkpoints._lock = Some(lock);
        Ok(checkpoints)
    }

    /// The checkpoint of the render whose entry is `key`, saved at most
    /// every `interval`; `header` names the scene, settings and resolution
    /// (its range is set at each save).
    pub fn new(cache_dir: &Path, key: &str, interval: Duration, header: FilmHeader) -> Self {
        Self {
            folder: folder(cache_dir, key),
            key: key.to_owned(),
            header,
            interval,
            last_save: Instant::now(),
            _lock: None,
        }
    }

    /// The folder of the checkpoint.
    pub fn folder(&self) -> &Path {
        &self.folder
    }

    /// The saved state, if there is a checkpoint (None: none); an error
    /// when one is there but damaged or of another render.
    pub fn load(&self, references: usize) -> Result<Option<Resumed>, String> {
        let state_file = self.folder.join("state.json");
        let text = match fs::read_to_string(&state_file) {
            Ok(text) => text,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(e) => return Err(format!("{}: {e}", state_file.display())),
        };
        let bad = |what: &str| format!("{}: {what}", state_file.display());
        let meta: Value = serde_json::from_str(&text).map_err(|e| bad(&e.to_string()))?;
        if meta["format"].as_str() != Some(FORMAT) || meta["key"].as_str() != Some(&self.key) {
            return Err(bad("not a checkpoint of this render"));
        }
        let iteration = meta["iteration"]
            .as_u64()
            .ok_or_else(|| bad("no iteration"))?;
        let rgb = self.read_film(&film_name("rgb", iteration), iteration)?;
        let luminance = self.read_film(&film_name("luminance", iteration), iteration)?;
        let points =
            points_from_json(&meta["points"], references).ok_or_else(|| bad("bad points"))?;
        if points.last().is_some_and(|p| p.iteration > iteration) {
            return Err(bad("a point after the checkpoint's iteration"));
        }
        let cpu_seconds = match &meta["cpu_seconds"] {
            Value::Null => None,
            t => Some(number(t).ok_or_else(|| bad("bad cpu_seconds"))?),
        };
        Ok(Some(Resumed {
            state: Rendered {
                iteration,
                seconds: number(&meta["seconds"]).ok_or_else(|| bad("bad seconds"))?,
                cpu_seconds,
                film: rgb,
                luminance,
            },
            invalid_samples: meta["invalid_samples"]
                .as_u64()
                .ok_or_else(|| bad("no invalid_samples"))?,
            points,
        }))
    }

    /// Whether the interval since the last save (or the start) has passed.
    pub fn due(&self) -> bool {
        self.last_save.elapsed() >= self.interval
    }

    /// Saves `state` with the dropped samples and points so far: both films,
    /// then `state.json`, then removes the films of older checkpoints.
    pub fn save(
        &mut self,
        state: &Rendered,
        invalid_samples: u64,
        points: &[Point],
    ) -> Result<(), String> {
        fs::create_dir_all(&self.folder)
            .map_err(|e| format!("cannot create {}: {e}", self.folder.display()))?;
        let n = state.iteration;
        for (kind, film) in [("rgb", &state.film), ("luminance", &state.luminance)] {
            self.write_film(&film_name(kind, n), film)?;
        }
        let meta = json!({
            "format": FORMAT,
            "key": self.key,
            "iteration": n,
            "seconds": text(state.seconds),
            "cpu_seconds": state.cpu_seconds.map(text),
            "invalid_samples": invalid_samples,
            "points": points_json(points),
        });
        let bytes = serde_json::to_string_pretty(&meta).map_err(|e| e.to_string())? + "\n";
        cache::write_atomic_bytes(&self.folder.join("state.json"), bytes.as_bytes())?;
        // Older films (and the temporaries of a killed save) are not needed
        // any more; a failure to remove one costs only disk space.
        let keep = [film_name("rgb", n), film_name("luminance", n)];
        if let Ok(entries) = fs::read_dir(&self.folder) {
            for entry in entries.flatten() {
                let name = entry.file_name().to_string_lossy().into_owned();
                if name != "state.json" && !keep.contains(&name) {
                    let _ = fs::remove_file(entry.path());
                }
            }
        }
        self.last_save = Instant::now();
        Ok(())
    }

    fn write_film(&self, name: &str, film: &Film) -> Result<(), String> {
        let (sum, sum_sq) = film.sums();
        let partial = PartialFilm {
            header: FilmHeader {
                first: 1,
                last: film.iterations(),
                ..self.header.clone()
            },
            iterations: film.iterations(),
            sum: sum.to_vec(),
            sum_sq: sum_sq.to_vec(),
        };
        film_file::write(&self.folder.join(name), &partial).map_err(|e| e.to_string())
    }

    fn read_film(&self, name: &str, iterations: u64) -> Result<Film, String> {
        let path = self.folder.join(name);
        let partial = film_file::read(&path).map_err(|e| e.to_string())?;
        let expected = FilmHeader {
            first: 1,
            last: iterations,
            ..self.header.clone()
        };
        if partial.header != expected {
            return Err(format!(
                "{}: not this render's film after iteration {iterations} (it holds \
                 iterations 1..{} at {}x{}, settings {})",
                path.display(),
                partial.header.last,
                partial.header.width,
                partial.header.height,
                partial.header.settings
            ));
        }
        let h = &partial.header;
        Film::from_sums(h.width, h.height, iterations, partial.sum, partial.sum_sq)
            .ok_or_else(|| format!("{}: wrong number of pixels", path.display()))
    }
}

/// The checkpoint folder of the render whose cache entry is `key`.
fn folder(cache_dir: &Path, key: &str) -> PathBuf {
    cache_dir.join("partial").join(key)
}

/// Removes the checkpoint of the render whose cache entry is `key` (its
/// render is done and stored), if there is one.
pub fn remove(cache_dir: &Path, key: &str) {
    let folder = folder(cache_dir, key);
    // Best effort: a stale checkpoint is only disk space, and its key is
    // that of an entry now stored, which is used first.
    let _ = fs::remove_dir_all(&folder);
    // The `partial` folder too, once no other checkpoint is in it.
    if let Some(parent) = folder.parent() {
        let _ = fs::remove_dir(parent);
    }
}

/// The file of a film after iteration `n`.
fn film_name(kind: &str, n: u64) -> String {
    format!("{kind}-{n}.{}", film_file::EXTENSION)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::metrics::{Errors, Noise};
    use glam::Vec3;

    fn header() -> FilmHeader {
        FilmHeader {
            scene: "scene.toml".into(),
            scene_hash: 7,
            settings: "key k; RenderConfig { seed: 1 }".into(),
            seed: 1,
            first: 1,
            last: 1,
            width: 3,
            height: 2,
            render_millis: None,
        }
    }

    fn temp_dir(name: &str) -> PathBuf {
        let dir =
            std::env::temp_dir().join(format!("xtask-checkpoint-{name}-{}", std::process::id()));
        let _ = fs::remove_dir_all(&dir);
        dir
    }

    fn state(iterations: u64) -> Rendered {
        let mut film = Film::new(3, 2);
        let mut luminance = Film::new(3, 2);
        for n in 0..iterations {
            let e: Vec<Vec3> = (0..6).map(|i| Vec3::splat((i * n) as f32 / 7.0)).collect();
            film.add_iteration(&e);
            luminance.add_iteration(&e[..].iter().map(|v| *v * 0.5).collect::<Vec<_>>());
        }
        Rendered {
            iteration: iterations,
            seconds: 1.0 / 3.0,
            cpu_seconds: Some(2.0 / 3.0),
            film,
            luminance,
        }
    }

    fn error(loaded: Result<Option<Resumed>, String>) -> String {
        match loaded {
            Err(e) => e,
            Ok(r) => panic!("loaded: {}", r.is_some()),
        }
    }

    /// A checkpoint reads back bit for bit; only the newest films remain;
    /// a checkpoint of another render, or a damaged one, is an error, and
    /// none at all is `None`.
    #[test]
    fn checkpoints_round_trip_and_refuse_other_renders() {
        let dir = temp_dir("round-trip");
        let mut c = Checkpoints::new(&dir, "k", Duration::ZERO, header());
        assert!(c.load(1).unwrap().is_none());
        assert!(c.due());
        let point = Point {
            iteration: 2,
            seconds: 0.1,
            cpu_seconds: None,
            noise: Some(Noise {
                std_error: 0.5,
                variance: 0.25,
            }),
            errors: vec![Errors {
                rmse: 0.3,
                rel_mse: 0.09,
            }],
        };
        c.save(&state(2), 0, std::slice::from_ref(&point)).unwrap();
        c.save(&state(3), 5, std::slice::from_ref(&point)).unwrap();
        let mut names: Vec<String> = fs::read_dir(c.folder())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        names.sort();
        assert_eq!(
            names,
            ["luminance-3.rltfilm", "rgb-3.rltfilm", "state.json"]
        );
        let back = c.load(1).unwrap().unwrap();
        let saved = state(3);
        assert_eq!(back.state.iteration, 3);
        assert_eq!(back.invalid_samples, 5);
        assert_eq!(back.state.seconds, saved.seconds);
        assert_eq!(back.state.cpu_seconds, saved.cpu_seconds);
        assert_eq!(back.state.film.sums(), saved.film.sums());
        assert_eq!(back.state.luminance.sums(), saved.luminance.sums());
        assert_eq!(back.state.film.iterations(), 3);
        assert_eq!(back.points.len(), 1);
        // Another render's checkpoint (other settings in the films, or
        // another key) is refused, as is a checkpoint with a lost film.
        let other = Checkpoints::new(
            &dir,
            "k",
            Duration::ZERO,
            FilmHeader {
                settings: "other".into(),
                ..header()
            },
        );
        assert!(error(other.load(1)).contains("not this render's film"));
        fs::rename(
            c.folder().join("state.json"),
            dir.join("partial").join("state.json"),
        )
        .unwrap();
        fs::create_dir_all(dir.join("partial/j")).unwrap();
        fs::rename(
            dir.join("partial").join("state.json"),
            dir.join("partial/j/state.json"),
        )
        .unwrap();
        let j = Checkpoints::new(&dir, "j", Duration::ZERO, header());
        assert!(error(j.load(1)).contains("not a checkpoint of this"));
        c.save(&state(3), 5, &[point]).unwrap();
        fs::remove_file(c.folder().join("rgb-3.rltfilm")).unwrap();
        assert!(c.load(1).is_err());
        remove(&dir, "k");
        assert!(!c.folder().exists());
        assert!(c.load(1).unwrap().is_none());
        let slow = Checkpoints::new(&dir, "s", Duration::from_secs(3600), header());
        assert!(!slow.due());
        fs::remove_dir_all(dir).unwrap();
    }

    /// While one study renders an entry, another rendering it is refused
    /// (a lock: two writers would replace each other's films); once the
    /// first is done, it may.
    #[test]
    fn a_render_in_progress_is_locked() {
        let dir = temp_dir("lock");
        let locked = |key| Checkpoints::locked(&dir, key, Duration::ZERO, header());
        let first = locked("k").unwrap();
        let refused = locked("k").err().unwrap();
        assert!(refused.contains("in use by another render"), "{refused}");
        assert!(
            refused.contains(&format!("pid {}", std::process::id())),
            "{refused}"
        );
        let other_key = locked("j").unwrap();
        drop(first);
        assert!(locked("k").is_ok());
        drop(other_key);
        fs::remove_dir_all(dir).unwrap();
    }
}
