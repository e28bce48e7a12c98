//! The temporary files being written, so that an interrupted process can remove them: output
//! is all or nothing even when the command line is stopped by a signal ([`abandon`]).
//!
//! A temporary file is registered before it is created and forgotten once renamed or removed.
//! The renames that put a set of files in place run while holding the registry ([`Pending`]),
//! so an interruption waits for the whole set to be placed, never leaving part of it.

use std::path::{Path, PathBuf};
use std::sync::{Mutex, MutexGuard, PoisonError};

static PENDING: Mutex<Vec<PathBuf>> = Mutex::new(Vec::new());

/// The registry, held.
pub(crate) struct Pending(MutexGuard<'static, Vec<PathBuf>>);

/// Holds the registry (blocking while another thread does).
pub(crate) fn pending() -> Pending {
    Pending(PENDING.lock().unwrap_or_else(PoisonError::into_inner))
}

impl Pending {
    /// Registers `path`, about to be created.
    pub(crate) fn add(&mut self, path: &Path) {
        self.0.push(path.to_owned());
    }

    /// Forgets `paths` (renamed into place, or removed).
    pub(crate) fn forget<'a>(&mut self, paths: impl IntoIterator<Item = &'a Path>) {
        for path in paths {
            if let Some(k) = self.0.iter().position(|p| p == path) {
                self.0.swap_remove(k);
            }
        }
    }
}

#[cfg(test)]
impl Pending {
    /// Whether a file in `dir` is registered.
    pub(crate) fn holds_any_in(&self, dir: &Path) -> bool {
        self.0.iter().any(|p| p.parent() == Some(dir))
    }
}

/// Removes every registered temporary file, prints `message` as the one line on stderr and
/// exits with `code`, still holding the registry so that no file is created or renamed after
/// the removal. For a signal handler on the way out.
pub fn abandon(code: i32, message: &str) -> ! {
    let held = pending();
    for path in held.0.iter() {
        let _ = std::fs::remove_file(path);
    }
    eprintln!("{message}");
    std::process::exit(code)
}
