//! Shared test helpers: one GPU device per test binary, course data paths, picture diffs.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use raycast::gpu::Gpu;

/// The device every GPU test runs on (lavapipe in CI). Without an adapter the tests fail
/// loudly: they are never skipped.
pub fn gpu() -> &'static Gpu {
    static GPU: OnceLock<Gpu> = OnceLock::new();
    GPU.get_or_init(|| {
        if std::env::var_os("NODEVICE_SELECT").is_none() {
            // SAFETY: tests that touch the environment only do it here, under the OnceLock,
            // before the Vulkan loader starts; Mesa reads it once at instance creation.
            unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
        }
        Gpu::new()
            .unwrap_or_else(|e| panic!("GPU tests need a Vulkan adapter (lavapipe is enough): {e}"))
    })
}

pub fn repo_path(relative: &str) -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join(relative)
}

/// The six course scenes, by name.
pub const COURSE_SCENES: [&str; 6] = [
    "bunny",
    "inside-a-sphere",
    "sphere-and-plane",
    "sphere-packing",
    "triangle",
    "two-spheres-and-plane",
];

pub fn course_scene(name: &str) -> raycast::Scene {
    raycast::Scene::load(&repo_path(&format!("scenes/course/{name}.json"))).unwrap()
}

/// A course reference render as raw 8-bit channels (RGB or grey, as stored).
pub fn course_render(name: &str, kind: &str) -> Vec<u8> {
    let path = repo_path(&format!("tests/data/course/{name}.{kind}.png"));
    let img = image::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    match kind {
        "depth" => img.into_luma8().into_raw(),
        _ => img.into_rgb8().into_raw(),
    }
}

/// How two 8-bit pictures of `channels` channels differ, per pixel.
#[derive(Debug, Default)]
pub struct PixelDiff {
    pub pixels: usize,
    /// Pixels with any channel different.
    pub differing: usize,
    /// Largest channel difference.
    pub max_level: u8,
}

pub fn diff(a: &[u8], b: &[u8], channels: usize, mask: Option<&[bool]>) -> PixelDiff {
    assert_eq!(a.len(), b.len());
    let mut d = PixelDiff::default();
    for (k, (pa, pb)) in a.chunks(channels).zip(b.chunks(channels)).enumerate() {
        if mask.is_some_and(|m| !m[k]) {
            continue;
        }
        d.pixels += 1;
        let level = pa
            .iter()
            .zip(pb)
            .map(|(x, y)| x.abs_diff(*y))
            .max()
            .unwrap();
        if level > 0 {
            d.differing += 1;
        }
        d.max_level = d.max_level.max(level);
    }
    d
}

/// Saves actual and expected pictures side by side under tests/failures/ (ignored by git)
/// and returns the folder, so a failing comparison can be looked at.
pub fn save_failure(
    name: &str,
    actual: &[u8],
    expected: &[u8],
    w: u32,
    h: u32,
    channels: usize,
) -> PathBuf {
    let dir = repo_path("tests/failures");
    std::fs::create_dir_all(&dir).unwrap();
    let color = if channels == 1 {
        image::ExtendedColorType::L8
    } else {
        image::ExtendedColorType::Rgb8
    };
    let diff: Vec<u8> = actual
        .iter()
        .zip(expected)
        .map(|(a, e)| if a == e { 0 } else { 255 })
        .collect();
    for (suffix, data) in [
        ("actual", actual),
        ("expected", expected),
        ("diff", &diff[..]),
    ] {
        image::save_buffer(dir.join(format!("{name}.{suffix}.png")), data, w, h, color).unwrap();
    }
    dir
}
