//! The files the self-test renders and compares with, built into the binary so that it runs
//! from the binary alone: the course's six scenes and their 18 reference renders, the lit
//! course bunny, and the extreme scenes whose invariants it checks.

use std::path::Path;

use raycast::{Error, Result};
use raycast::{Scene, parse_mesh};

/// A file of the repository, by its path there.
struct Embedded {
    path: &'static str,
    bytes: &'static [u8],
}

macro_rules! embed {
    ($($path:literal),* $(,)?) => {
        &[$(Embedded { path: $path, bytes: include_bytes!(concat!(env!("CARGO_MANIFEST_DIR"), "/../", $path)) }),*]
    };
}

const FILES: &[Embedded] = embed![
    "scenes/course/bunny.json",
    "scenes/course/bunny.stl",
    "scenes/course/inside-a-sphere.json",
    "scenes/course/sphere-and-plane.json",
    "scenes/course/sphere-packing.json",
    "scenes/course/triangle.json",
    "scenes/course/two-spheres-and-plane.json",
    "tests/data/course/bunny.depth.png",
    "tests/data/course/bunny.id.png",
    "tests/data/course/bunny.normal.png",
    "tests/data/course/inside-a-sphere.depth.png",
    "tests/data/course/inside-a-sphere.id.png",
    "tests/data/course/inside-a-sphere.normal.png",
    "tests/data/course/sphere-and-plane.depth.png",
    "tests/data/course/sphere-and-plane.id.png",
    "tests/data/course/sphere-and-plane.normal.png",
    "tests/data/course/sphere-packing.depth.png",
    "tests/data/course/sphere-packing.id.png",
    "tests/data/course/sphere-packing.normal.png",
    "tests/data/course/triangle.depth.png",
    "tests/data/course/triangle.id.png",
    "tests/data/course/triangle.normal.png",
    "tests/data/course/two-spheres-and-plane.depth.png",
    "tests/data/course/two-spheres-and-plane.id.png",
    "tests/data/course/two-spheres-and-plane.normal.png",
    "scenes/ray-tracing/bunny.json",
    "scenes/ray-tracing/bunny.stl",
    "scenes/extremes/dyadic-base.json",
    "scenes/extremes/dyadic-base.cube.obj",
    "scenes/extremes/scaled-2e-20.json",
    "scenes/extremes/scaled-2e-20.cube.obj",
    "scenes/extremes/scaled-2e20.json",
    "scenes/extremes/scaled-2e20.cube.obj",
    "scenes/extremes/scaled-2e40.json",
    "scenes/extremes/scaled-2e40.cube.obj",
    "scenes/extremes/scaled-2e56.json",
    "scenes/extremes/scaled-2e56.cube.ply",
    "scenes/extremes/translated-1e3.json",
    "scenes/extremes/translated-1e3.cube.obj",
    "scenes/extremes/translated-1e6.json",
    "scenes/extremes/translated-1e6.cube.obj",
    "scenes/extremes/translated-1e6-ascii-ply.json",
    "scenes/extremes/translated-1e6-ascii-ply.cube.ply",
    "scenes/extremes/translated-1e6-binary-ply.json",
    "scenes/extremes/translated-1e6-binary-ply.cube.ply",
];

/// The extreme scenes checked against `dyadic-base`: scaled by 2^k, and translated.
pub const SCALED: [&str; 4] = ["scaled-2e-20", "scaled-2e20", "scaled-2e40", "scaled-2e56"];
pub const TRANSLATED: [&str; 4] = [
    "translated-1e3",
    "translated-1e6",
    "translated-1e6-ascii-ply",
    "translated-1e6-binary-ply",
];

/// The built-in file of the repository path `path`.
pub fn file(path: &str) -> Result<&'static [u8]> {
    FILES
        .iter()
        .find(|f| f.path == path)
        .map(|f| f.bytes)
        .ok_or_else(|| Error::Io {
            path: path.into(),
            message: "not built into the self-test".into(),
        })
}

/// The built-in scene file `path`, its meshes built in beside it.
pub fn scene(path: &str) -> Result<Scene> {
    let text = String::from_utf8_lossy(file(path)?);
    let folder = Path::new(path).parent().unwrap_or(Path::new(""));
    Scene::from_json(&text, Path::new(path), &mut |name, split| {
        let mesh_path = folder.join(name);
        let mesh_name = mesh_path.to_string_lossy().replace('\\', "/");
        parse_mesh(file(&mesh_name)?, &mesh_path, split)
    })
}

/// A course scene by name.
pub fn course_scene(name: &str) -> Result<Scene> {
    scene(&format!("scenes/course/{name}.json"))
}

/// A course reference render (`kind`: id, depth or normal) as raw 8-bit channels: grey for
/// depth, RGB otherwise.
pub fn course_render(name: &str, kind: &str) -> Result<Vec<u8>> {
    let path = format!("tests/data/course/{name}.{kind}.png");
    let decoded = image::load_from_memory(file(&path)?).map_err(|e| Error::Io {
        path: path.clone().into(),
        message: e.to_string(),
    })?;
    Ok(match kind {
        "depth" => decoded.into_luma8().into_raw(),
        _ => decoded.into_rgb8().into_raw(),
    })
}

/// An extreme scene by name.
pub fn extreme(name: &str) -> Result<Scene> {
    scene(&format!("scenes/extremes/{name}.json"))
}

/// The power of two an extreme scene is scaled by, from its file's `comment.scale`.
pub fn scale_of(name: &str) -> Result<f64> {
    let path = format!("scenes/extremes/{name}.json");
    let json: serde_json::Value = serde_json::from_slice(file(&path)?).map_err(|e| Error::Io {
        path: path.clone().into(),
        message: e.to_string(),
    })?;
    json["comment"]["scale"].as_f64().ok_or_else(|| Error::Io {
        path: path.into(),
        message: "no comment.scale".into(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::selftest::scenes::COURSE_SCENES;

    #[test]
    fn every_built_in_scene_and_render_loads() {
        for name in COURSE_SCENES {
            let scene = course_scene(name).unwrap();
            let [w, h] = scene.camera.resolution;
            for kind in ["id", "depth", "normal"] {
                let channels = if kind == "depth" { 1 } else { 3 };
                let render = course_render(name, kind).unwrap();
                assert_eq!(render.len(), (w * h) as usize * channels, "{name} {kind}");
            }
        }
        for name in SCALED {
            assert_eq!(scale_of(name).unwrap().log2().fract(), 0.0, "{name}");
        }
        for name in SCALED.iter().chain(&TRANSLATED).chain(&["dyadic-base"]) {
            assert!(!extreme(name).unwrap().objects.is_empty(), "{name}");
        }
        assert!(
            !scene("scenes/ray-tracing/bunny.json")
                .unwrap()
                .lighting
                .is_empty()
        );
    }
}
