//! Noticing that files changed, by polling their modification times and lengths: what
//! `render --watch` and `serve` render again on.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::SystemTime;

/// Set once `render --watch` starts: an interrupt is then its way out, not a failure.
static WATCHING: AtomicBool = AtomicBool::new(false);

/// Marks this process as watching, for [`watching`].
pub fn start() {
    WATCHING.store(true, Ordering::SeqCst);
}

/// Whether `render --watch` runs in this process (read by the interrupt handler).
pub fn watching() -> bool {
    WATCHING.load(Ordering::SeqCst)
}

/// A file's modification time and length, `None` while it cannot be read.
pub type Stamp = Option<(SystemTime, u64)>;

/// The stamps of `files`, in their order.
pub fn stamps(files: &[PathBuf]) -> Vec<Stamp> {
    files
        .iter()
        .map(|f| {
            let m = std::fs::metadata(f).ok()?;
            Some((m.modified().ok()?, m.len()))
        })
        .collect()
}
