//! The temporary files being written, so that an interrupted process can remove them: output
//! is all or nothing even when the command line is stopped by a signal
//! ([`remove_partial_files`]). A writer of its own (the library's band-by-band files) names its
//! temporary files with [`temp_path`], creates them with [`create`], and places them with
//! [`place_all`] or removes them with [`discard`].
//!
//! A temporary file is registered and created under the registry's lock (`create`), so an
//! interruption either removes it or comes before it exists, and forgotten once renamed or
//! removed. The renames that put a set of files in place run under the lock too
//! (`place_all`), so an interruption waits for the whole set to be placed, never leaving part
//! of it.

use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError, TryLockError};
use std::time::{Duration, Instant};

use crate::{FileError, Result};

static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

fn registry() -> MutexGuard<'static, Vec<PathBuf>> {
    PENDING.lock().unwrap_or_else(PoisonError::into_inner)
}

fn forget<'a>(held: &mut Vec<PathBuf>, paths: impl IntoIterator<Item = &'a Path>) {
    for path in paths {
        if let Some(k) = held.iter().position(|p| p == path) {
            held.swap_remove(k);
        }
    }
}

/// The temporary name beside `path` its contents are written under: `.NAME.tmp-PID`.
pub fn temp_path(path: &Path) -> Result<PathBuf> {
    let name = path
        .file_name()
        .ok_or_else(|| FileError::new(path, "not a file name"))?
        .to_string_lossy();
    Ok(path.with_file_name(format!(".{name}.tmp-{}", std::process::id())))
}

/// Creates the temporary file `path`, registered for removal on an interruption.
pub fn create(path: &Path) -> std::io::Result<File> {
    let mut held = registry();
    held.push(path.to_owned());
    let created = File::create(path);
    if created.is_err() {
        held.pop();
    }
    created
}

/// Removes the temporary files `paths` (those that exist) and forgets them.
pub fn discard<'a>(paths: impl IntoIterator<Item = &'a Path>) {
    let mut held = registry();
    for path in paths {
        let _ = std::fs::remove_file(path);
        forget(&mut held, [path]);
    }
}

/// Renames each temporary file to its final path, `(temporary, final)`, and forgets them; if one
/// rename fails, removes the files already in place and the remaining temporary ones: none or
/// all. An interruption waits until this is done.
pub fn place_all(pairs: &[(PathBuf, PathBuf)]) -> Result<()> {
    let mut held = registry();
    let mut placed = Ok(());
    for (k, (tmp, path)) in pairs.iter().enumerate() {
        if let Err(e) = std::fs::rename(tmp, path) {
            for (_, done) in &pairs[..k] {
                let _ = std::fs::remove_file(done);
            }
            for (rest, _) in &pairs[k..] {
                let _ = std::fs::remove_file(rest);
            }
            placed = Err(FileError::new(path, format!("cannot write: {e}")));
            break;
        }
    }
    forget(&mut held, pairs.iter().map(|(tmp, _)| tmp.as_path()));
    placed
}

/// Creates the temporary folder `path` (removing what a killed run left there), registered for
/// removal with everything in it on an interruption.
pub(crate) fn create_dir(path: &Path) -> Result<()> {
    let mut held = registry();
    let _ = std::fs::remove_dir_all(path);
    held.push(path.to_owned());
    std::fs::create_dir(path).map_err(|e| {
        held.pop();
        FileError::new(path, format!("cannot create folder: {e}"))
    })
}

/// Removes the temporary folder `path` and what it holds, and forgets it.
pub(crate) fn discard_dir(path: &Path) {
    let mut held = registry();
    let _ = std::fs::remove_dir_all(path);
    forget(&mut held, [path]);
}

/// Renames the temporary folder `temporary` to `path`, replacing a folder there (moved aside
/// first, removed after), and forgets it. An interruption waits until this is done, so `path`
/// is the old folder or the new one, never part of either.
pub(crate) fn place_dir(temporary: &Path, path: &Path) -> Result<()> {
    let mut held = registry();
    let old = path.with_file_name(format!(
        ".{}.old-{}",
        path.file_name().unwrap_or_default().to_string_lossy(),
        std::process::id()
    ));
    let replaced = path.exists();
    let placed = (|| {
        if replaced {
            std::fs::rename(path, &old)?;
        }
        std::fs::rename(temporary, path)
    })();
    let _ = std::fs::remove_dir_all(if placed.is_ok() { &old } else { temporary });
    forget(&mut held, [temporary]);
    placed.map_err(|e| FileError::new(path, format!("cannot write: {e}")))
}

/// Removes folder `path`, again while it is there: another thread may still be writing a view's
/// files into it (not under the registry's lock, which only its placing takes), and a file
/// created during a removal leaves the folder not empty. That thread writes at most the rest of
/// one view's files before it waits on the lock, so a few tries empty it.
fn remove_dir_while_written(path: &Path) {
    for _ in 0..1000 {
        if std::fs::remove_dir_all(path).is_ok() || !path.exists() {
            return;
        }
    }
}

/// Whether a file in `dir` is registered.
#[cfg(test)]
pub(crate) fn holds_any_in(dir: &Path) -> bool {
    registry().iter().any(|p| p.parent() == Some(dir))
}

/// How long [`remove_partial_files`] waits for the registry: far longer than any registry operation (a
/// set of renames) takes; held longer, it is held by the thread that calls `remove_partial_files`.
const ABANDON_WAIT: Duration = Duration::from_secs(10);

/// The registry, waited for at most `wait`; `None` where it stays held: by the calling thread
/// itself, where an allocation failed inside a registry operation.
fn registry_within(wait: Duration) -> Option<MutexGuard<'static, Vec<PathBuf>>> {
    let start = Instant::now();
    loop {
        match PENDING.try_lock() {
            Ok(held) => return Some(held),
            Err(TryLockError::Poisoned(held)) => return Some(held.into_inner()),
            Err(TryLockError::WouldBlock) if start.elapsed() < wait => {
                std::thread::sleep(Duration::from_millis(1));
            }
            Err(TryLockError::WouldBlock) => return None,
        }
    }
}

/// Removes every registered temporary file, then runs `exit` still holding the registry, so
/// that no file is created or renamed after the removal: output stays all or nothing for a
/// process leaving at once (`exit` ends it), on a signal or when the system refuses memory
/// (the command line's `abandon`). Where the registry stays held (10 s: by the calling thread
/// itself, where an allocation failed inside a registry operation) it runs `exit` without
/// removing the files.
pub fn remove_partial_files<T>(exit: impl FnOnce() -> T) -> T {
    let held = registry_within(ABANDON_WAIT);
    for path in held.iter().flat_map(|h| h.iter()) {
        if path.is_dir() {
            remove_dir_while_written(path);
        } else {
            let _ = std::fs::remove_file(path);
        }
    }
    exit()
}
