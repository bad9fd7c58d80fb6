//! Checkpoints (`--checkpoint FILE`): the film of a render in progress,
//! saved every `--checkpoint-every` seconds as a partial film
//! (`image_io::film_file`), so that a killed render resumes where its last
//! checkpoint left it.
//!
//! Resuming is exact: every iteration is a pure function of (scene,
//! settings, seed, global iteration index), the film is the running f64 sum
//! of the iterations' estimates in their order, and the checkpoint stores
//! those sums bit for bit; a resumed render adds the remaining iterations
//! to them in the same order as an uninterrupted one, so its image is the
//! same bytes.
//!
//! The file is written atomically (`image_io::atomic`) and locked for the
//! whole run (`image_io::lock`): a second render given the same file is
//! refused, and a checkpoint is never half-written, whatever ends the
//! process.

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

use image_io::film_file::{self, FilmFileError, FilmHeader, PartialFilm};
use image_io::lock::{FileLock, LockError};
use integrators::Film;

use crate::settings::Budget;

/// The default `--checkpoint-every`: a killed render loses at most five
/// minutes, and a large film (48 bytes per pixel: 100 MB at 1920x1080) is
/// written a dozen times an hour.
pub const DEFAULT_INTERVAL: Duration = Duration::from_secs(300);

/// A checkpoint file of this run, locked until dropped.
#[derive(Debug)]
pub struct Checkpoint {
    /// The checkpoint file.
    path: PathBuf,
    /// Time between saves.
    interval: Duration,
    /// Held for the whole run.
    _lock: FileLock,
    /// The film found in the file when it was opened (taken by `resume`).
    found: Option<PartialFilm>,
    /// The header of this render (its range's first iteration).
    header: Option<FilmHeader>,
    /// When the film was last saved (or the run started).
    last_save: Instant,
    /// Iterations in the file.
    saved: u64,
}

/// A checkpoint that cannot be used or written; each is one line naming the file.
#[derive(Debug, thiserror::Error)]
pub enum CheckpointError {
    /// Another process holds the lock, or it cannot be taken.
    #[error("checkpoint {0}")]
    Lock(#[from] LockError),
    /// The file is damaged, not a partial film, or unreadable.
    #[error("checkpoint {0}; remove it to start the render over")]
    Read(FilmFileError),
    /// The file belongs to another render.
    #[error(
        "checkpoint {} was made with {}{}, this render asks {}; use another --checkpoint file, or remove it to start over",
        path.display(), difference.kind.noun(), difference.ours, difference.theirs
    )]
    Foreign {
        /// The checkpoint file.
        path: PathBuf,
        /// How its render differs (checkpoint first).
        difference: film_file::Difference,
    },
    /// The file holds iterations that this render does not render.
    #[error("checkpoint {} holds iterations {}..={}, {what}", path.display(), first, last)]
    Range {
        /// The checkpoint file.
        path: PathBuf,
        /// Its first iteration.
        first: u64,
        /// Its last iteration.
        last: u64,
        /// How that does not fit this render.
        what: String,
    },
    /// A save failed (full disk, removed folder); the previous checkpoint is intact.
    #[error("cannot write checkpoint {0}; the previous checkpoint is kept")]
    Write(FilmFileError),
}

/// What a checkpoint gives the render that resumes it.
#[derive(Debug)]
pub struct Resumed {
    /// The film of the iterations done.
    pub film: Film,
    /// Wall-clock time they took (0 where the file does not say).
    pub rendered: Duration,
}

impl Checkpoint {
    /// Locks `path` and reads the checkpoint there, if there is one: done
    /// before the scene is loaded, so a locked or damaged file is refused
    /// at once.
    pub fn open(path: &Path, interval: Duration) -> Result<Self, CheckpointError> {
        let lock = FileLock::acquire(path)?;
        let found = if path.exists() {
            Some(film_file::read(path).map_err(CheckpointError::Read)?)
        } else {
            None
        };
        Ok(Self {
            path: path.to_owned(),
            interval,
            _lock: lock,
            saved: found.as_ref().map_or(0, |f| f.iterations),
            found,
            header: None,
            last_save: Instant::now(),
        })
    }

    /// The checkpoint file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Sets this render's `header` (any range; its first iteration counts)
    /// and returns the film of the checkpoint found by `open`, if any,
    /// after checking that it is of this render (scene content, size,
    /// settings), starts at this render's first iteration and holds no
    /// more iterations than `budget`.
    pub fn resume(
        &mut self,
        header: FilmHeader,
        budget: Budget,
    ) -> Result<Option<Resumed>, CheckpointError> {
        let found = self.found.take();
        let first = header.first;
        self.header = Some(header);
        let Some(found) = found else {
            return Ok(None);
        };
        let ours = self.header.as_ref().expect("set above");
        let h = &found.header;
        if let Some(difference) = film_file::difference(h, ours) {
            return Err(CheckpointError::Foreign {
                path: self.path.clone(),
                difference,
            });
        }
        let range = |what: String| CheckpointError::Range {
            path: self.path.clone(),
            first: h.first,
            last: h.last,
            what,
        };
        if h.first != first {
            return Err(range(format!("this render starts at iteration {first}")));
        }
        if let Budget::Iterations(total) = budget
            && found.iterations > total
        {
            return Err(range(format!(
                "more than this render's {}..={}",
                first,
                first + total - 1
            )));
        }
        let rendered = Duration::from_millis(h.render_millis.unwrap_or(0));
        let film = crate::shard::film(found).ok_or_else(|| {
            CheckpointError::Read(FilmFileError::Invalid {
                path: self.path.clone(),
                message: "its pixel data does not match its size".to_owned(),
            })
        })?;
        Ok(Some(Resumed { film, rendered }))
    }

    /// Whether the interval since the last save has passed.
    pub fn is_due(&self) -> bool {
        self.last_save.elapsed() >= self.interval
    }

    /// Saves `film` (iterations from this render's first on, `rendered`
    /// wall-clock time in all) unless the file already holds it or it is
    /// empty.
    pub fn save(&mut self, film: &Film, rendered: Duration) -> Result<(), CheckpointError> {
        let n = film.iterations();
        if n == 0 || n == self.saved {
            self.last_save = Instant::now();
            return Ok(());
        }
        let mut header = self.header.clone().expect("resume() sets the header");
        header.last = header.first + n - 1;
        header.render_millis = Some(u64::try_from(rendered.as_millis()).unwrap_or(u64::MAX));
        let (sum, sum_sq) = film.sums();
        film_file::write_sums(&self.path, &header, n, sum, sum_sq)
            .map_err(CheckpointError::Write)?;
        self.saved = n;
        self.last_save = Instant::now();
        Ok(())
    }

    /// Iterations in the file.
    pub fn saved(&self) -> u64 {
        self.saved
    }

    /// Removes the file (the render's image is written), then the lock.
    /// A file that cannot be removed is a warning: the image is there, and
    /// the next run of the command would only resume a finished render.
    pub fn remove(self) {
        let temporary = image_io::atomic::temporary_path(&self.path);
        let _ = std::fs::remove_file(temporary);
        if let Err(e) = std::fs::remove_file(&self.path)
            && e.kind() != std::io::ErrorKind::NotFound
        {
            eprintln!(
                "warning: cannot remove checkpoint {}: {e}",
                self.path.display()
            );
        }
    }
}
