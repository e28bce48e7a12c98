//! Noticing that files changed, by polling their modification times and lengths: what
//! `render --watch` and `serve` render again on.

use std::path::{Path, PathBuf};
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

/// The files a watching render polls: the scene file and the meshes it names (as far as it
/// loads), the shader file and the kernel file.
pub fn watched_files(
    scene: Option<&Path>,
    shader: Option<&Path>,
    kernel: Option<&Path>,
) -> Vec<PathBuf> {
    let mut files: Vec<PathBuf> = Vec::new();
    if let Some(scene) = scene {
        files.push(scene.to_owned());
        if let Ok(loaded) = raycast::Scene::load(scene) {
            let base = scene.parent().unwrap_or(Path::new(""));
            for object in &loaded.objects {
                // The parts of a split mesh file name it each.
                if let raycast::Object::Soup { path, .. } = object
                    && !files.contains(&base.join(path))
                {
                    files.push(base.join(path));
                }
            }
        }
    }
    files.extend(shader.map(Path::to_owned));
    files.extend(kernel.map(Path::to_owned));
    files
}
