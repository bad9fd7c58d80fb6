//! Advisory file locks: one process at a time may write a checkpoint.
//!
//! The lock is an OS lock (`flock` on Unix, `LockFileEx` on Windows,
//! through `std::fs::File::try_lock`) on a small lock file next to the
//! locked file, holding the owner's process id for the message of a
//! refused lock. The OS releases it when its process ends in any way,
//! SIGKILL included, so a killed render never leaves a lock that blocks its
//! resumption; a lock file left behind is harmless.
//!
//! The locked file itself cannot carry the lock: it is replaced by a
//! rename at every write ([`crate::atomic`]), and a lock belongs to the
//! replaced inode.

use std::fs::{self, File, OpenOptions, TryLockError};
use std::io::{self, Read as _, Write as _};
use std::path::{Path, PathBuf};

/// The suffix of the lock file of a locked path (`c.rltfilm` -> `c.rltfilm.lock`).
pub const LOCK_SUFFIX: &str = ".lock";

/// How often [`FileLock::acquire`] retries when the lock file it locked was
/// removed by its previous owner in between (a race that needs two owners
/// to finish within microseconds of each other; more means a file system
/// that does not keep inode numbers, where retrying is pointless).
const RETRIES: usize = 16;

/// An exclusive lock on a path, held until dropped.
#[derive(Debug)]
pub struct FileLock {
    /// The open, locked lock file.
    file: File,
    /// Its path.
    path: PathBuf,
}

/// A lock could not be taken.
#[derive(Debug, thiserror::Error)]
pub enum LockError {
    /// Another process holds it.
    #[error("{} is in use by another render ({}; lock file {})",
        path.display(),
        pid.map_or("its process id is unknown".to_owned(), |p| format!("pid {p}")),
        lock_file.display())]
    InUse {
        /// The locked path.
        path: PathBuf,
        /// Its lock file.
        lock_file: PathBuf,
        /// The owner's process id, if its lock file says.
        pid: Option<u32>,
    },
    /// The lock file could not be created, opened or locked.
    #[error("cannot lock {}: {}: {source}", path.display(), lock_file.display())]
    Io {
        /// The path to lock.
        path: PathBuf,
        /// Its lock file.
        lock_file: PathBuf,
        /// The cause.
        source: io::Error,
    },
}

/// The lock file of `path`.
pub fn lock_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(LOCK_SUFFIX);
    PathBuf::from(name)
}

impl FileLock {
    /// Takes the lock of `path` without waiting, or says who holds it.
    pub fn acquire(path: &Path) -> Result<Self, LockError> {
        let lock_file = lock_path(path);
        let io = |source| LockError::Io {
            path: path.to_owned(),
            lock_file: lock_file.clone(),
            source,
        };
        for _ in 0..RETRIES {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(&lock_file)
                .map_err(io)?;
            match file.try_lock() {
                Ok(()) => {}
                Err(TryLockError::WouldBlock) => {
                    return Err(LockError::InUse {
                        path: path.to_owned(),
                        lock_file: lock_file.clone(),
                        pid: owner(&mut file),
                    });
                }
                Err(TryLockError::Error(source)) => return Err(io(source)),
            }
            // Its previous owner removes the lock file while holding the
            // lock (on drop): a lock on a removed file locks nothing.
            if !is_at(&file, &lock_file) {
                continue;
            }
            // For the message of a refused lock only: a full disk (which
            // the lock itself does not need) leaves it empty.
            let _ = file
                .set_len(0)
                .and_then(|()| writeln!(file, "{}", std::process::id()));
            return Ok(Self {
                file,
                path: lock_file,
            });
        }
        Err(io(io::Error::other(
            "the lock file keeps being replaced while it is locked",
        )))
    }
}

impl Drop for FileLock {
    /// Removes the lock file, then releases the lock (closing the file).
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.path);
        let _ = self.file.unlock();
    }
}

/// The process id written in a lock file, if any.
fn owner(file: &mut File) -> Option<u32> {
    let mut text = String::new();
    file.read_to_string(&mut text).ok()?;
    text.trim().parse().ok()
}

/// Whether the open `file` is still the one named `path` (not removed or
/// replaced since it was opened).
#[cfg(unix)]
fn is_at(file: &File, path: &Path) -> bool {
    use std::os::unix::fs::MetadataExt as _;
    match (file.metadata(), fs::metadata(path)) {
        (Ok(a), Ok(b)) => (a.dev(), a.ino()) == (b.dev(), b.ino()),
        _ => false,
    }
}

/// Whether the open `file` is still the one named `path`: assumed where
/// inode numbers are not available (an open file cannot be removed there).
#[cfg(not(unix))]
fn is_at(_file: &File, path: &Path) -> bool {
    path.exists()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_second_lock_is_refused_naming_the_owner_until_the_first_is_dropped() {
        let dir = std::env::temp_dir().join(format!("rlt-lock-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let path = dir.join("c.rltfilm");
        let first = FileLock::acquire(&path).unwrap();
        // A second open file description conflicts with the first even
        // within one process (flock semantics).
        let err = FileLock::acquire(&path).unwrap_err();
        let pid = std::process::id();
        assert!(
            matches!(err, LockError::InUse { pid: Some(p), .. } if p == pid),
            "{err}"
        );
        assert!(
            err.to_string()
                .contains(&format!("c.rltfilm is in use by another render (pid {pid}")),
            "{err}"
        );
        drop(first);
        assert!(!lock_path(&path).exists());
        let again = FileLock::acquire(&path).unwrap();
        drop(again);
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_lock_in_a_missing_folder_names_the_lock_file() {
        let err = FileLock::acquire(Path::new("/nonexistent-rlt/c.rltfilm")).unwrap_err();
        assert!(
            matches!(err, LockError::Io { .. }) && err.to_string().contains("c.rltfilm.lock"),
            "{err}"
        );
    }
}
