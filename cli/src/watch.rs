//! Noticing that files changed, by polling their modification times and lengths: what
//! `render --watch` and `serve` render again on.

use std::path::PathBuf;
use std::time::SystemTime;

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
