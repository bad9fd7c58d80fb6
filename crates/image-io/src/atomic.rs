//! Crash-safe replacement of a file: the file under its name is always
//! either the old one or the complete new one, whatever kills the writer
//! (SIGKILL, power loss, a full disk).
//!
//! The new content goes to a temporary file in the same folder (a rename
//! is atomic only within one file system), which is flushed to the disk
//! (`fsync`) before it is renamed over the old one; the folder is then
//! flushed too, so that the rename itself survives a power loss (POSIX
//! does not promise that a rename is durable before its folder is synced).

use std::fs;
use std::io;
use std::path::{Path, PathBuf};

/// The suffix of the temporary file that [`write_atomically`] writes
/// before renaming it (`image.exr` -> `image.exr.partial`).
pub const TEMPORARY_SUFFIX: &str = ".partial";

/// The temporary file of `path`: the same name with [`TEMPORARY_SUFFIX`],
/// in the same folder. One name per target, not per process: a writer
/// killed half-way leaves one stale file, which the next write of the
/// target replaces. Two processes must not write one target at once
/// (checkpoints are locked, see [`crate::lock`]).
pub fn temporary_path(path: &Path) -> PathBuf {
    let mut name = path.as_os_str().to_owned();
    name.push(TEMPORARY_SUFFIX);
    PathBuf::from(name)
}

/// Replaces `path` with what `write` writes into the file it is given
/// (the temporary file, see [`temporary_path`]), then syncs that file,
/// renames it to `path` and syncs the folder.
///
/// Any failure leaves `path` as it was and removes the temporary file
/// (best effort); `io_error` turns the errors of syncing and renaming into
/// the caller's error type. Errors of `write` are returned as they are.
pub fn write_atomically<E>(
    path: &Path,
    write: impl FnOnce(&Path) -> Result<(), E>,
    io_error: impl FnOnce(io::Error) -> E,
) -> Result<(), E> {
    let temporary = temporary_path(path);
    let result = write(&temporary).and_then(|()| {
        sync_file(&temporary)
            .and_then(|()| fs::rename(&temporary, path))
            .map_err(io_error)
    });
    if result.is_err() {
        // The error that matters is the one returned.
        let _ = fs::remove_file(&temporary);
        return result;
    }
    // The new file is complete and in place; a folder that cannot be synced
    // (some network file systems refuse) only weakens durability after a
    // power loss, which is no reason to fail the write.
    let _ = sync_folder(path);
    Ok(())
}

/// Flushes a written file's data and metadata to the disk.
fn sync_file(path: &Path) -> io::Result<()> {
    fs::File::open(path)?.sync_all()
}

/// Flushes the folder holding `path` (its entries: a rename) to the disk.
#[cfg(unix)]
pub fn sync_folder(path: &Path) -> io::Result<()> {
    let folder = path
        .parent()
        .filter(|p| !p.as_os_str().is_empty())
        .unwrap_or(Path::new("."));
    fs::File::open(folder)?.sync_all()
}

/// Flushes the folder holding `path`: not possible through `std` on this
/// platform, where a rename is made durable by the file system itself.
#[cfg(not(unix))]
pub fn sync_folder(_path: &Path) -> io::Result<()> {
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn temp_dir(name: &str) -> PathBuf {
        let dir = std::env::temp_dir().join(format!("rlt-atomic-{name}-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        dir
    }

    #[test]
    fn a_write_replaces_the_file_and_leaves_no_temporary() {
        let dir = temp_dir("replace");
        let path = dir.join("a.bin");
        fs::write(&path, b"old").unwrap();
        write_atomically(&path, |tmp| fs::write(tmp, b"new"), |e| e).unwrap();
        assert_eq!(fs::read(&path).unwrap(), b"new");
        assert!(!temporary_path(&path).exists());
        fs::remove_dir_all(dir).unwrap();
    }

    #[test]
    fn a_failed_write_keeps_the_old_file() {
        let dir = temp_dir("fail");
        let path = dir.join("a.bin");
        fs::write(&path, b"old").unwrap();
        let err = write_atomically(
            &path,
            |tmp| {
                fs::write(tmp, b"half")?;
                Err(io::Error::other("disk full"))
            },
            |e| e,
        )
        .unwrap_err();
        assert_eq!(err.to_string(), "disk full");
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert!(!temporary_path(&path).exists());
        fs::remove_dir_all(dir).unwrap();
    }

    /// `/dev/full` fails every write with ENOSPC: a temporary file that is a
    /// link to it is a disk that is full, without mounting one.
    #[cfg(target_os = "linux")]
    #[test]
    fn a_full_disk_keeps_the_old_file() {
        let dir = temp_dir("full");
        let path = dir.join("a.bin");
        fs::write(&path, b"old").unwrap();
        std::os::unix::fs::symlink("/dev/full", temporary_path(&path)).unwrap();
        let err = write_atomically(&path, |tmp| fs::write(tmp, b"new"), |e| e).unwrap_err();
        assert_eq!(err.kind(), io::ErrorKind::StorageFull, "{err}");
        assert_eq!(fs::read(&path).unwrap(), b"old");
        assert!(fs::symlink_metadata(temporary_path(&path)).is_err());
        fs::remove_dir_all(dir).unwrap();
    }
}
