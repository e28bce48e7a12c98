//! A dataset's views are rendered in a pipeline (src/views.rs: the next view prepared, and
//! the last finished and written, while the device runs a view's kernel): each view writes the
//! bytes its single render writes, whichever device and precision, across a change of scene;
//! and an error stops the job with the views before it written whole and none after it.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use raycast::{CameraOverrides, Orbit, Split};
use raycast::{Encoding, Format};
use raycast::{Gpu, Mode};

use crate::common;
use crate::{RenderFiles, RenderViews, Views};

const SIZE: [u32; 2] = [64, 36];

fn scene_path(name: &str) -> PathBuf {
    common::repo_path("scenes").join(name)
}

/// A render of `scenes` to `out` in `mode` (the robust algorithms; the default precision where
/// `mode` gives none) at 64x36 pixels, as png and npy.
fn render_files(mode: &str, out: &Path) -> RenderFiles {
    let parsed: Mode = mode.parse().unwrap();
    RenderFiles {
        scene: None,
        size: Some(SIZE),
        device: parsed.device,
        // The precision is the second field: without it, the render's default.
        precision: mode.contains(':').then_some(parsed.precision),
        algorithm: parsed.algorithm,
        spp: None,
        band_rows: None,
        shader: None,
        lit: false,
        kernel: None,
        out_dir: out.to_owned(),
        encoding: Encoding::new(&[Format::Png, Format::Npy], None).unwrap(),
        emit_shader: None,
        view: CameraOverrides::default(),
        split: Split::default(),
    }
}

/// An orbit of `views` views of each of `scenes`.
fn job(scenes: &[PathBuf], views: u32, mode: &str, out: &Path) -> RenderViews {
    RenderViews {
        scenes: scenes.to_vec(),
        views: Views::Orbit(Orbit {
            views,
            ..Orbit::default()
        }),
        force: false,
        render: render_files(mode, out),
    }
}

/// Every file under `dir` by its path relative to `dir`, with its bytes.
fn tree(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    fn walk(root: &Path, dir: &Path, files: &mut BTreeMap<PathBuf, Vec<u8>>) {
        for entry in std::fs::read_dir(dir).unwrap() {
            let path = entry.unwrap().path();
            if path.is_dir() {
                walk(root, &path, files);
            } else {
                let bytes = std::fs::read(&path).unwrap();
                files.insert(path.strip_prefix(root).unwrap().to_owned(), bytes);
            }
        }
    }
    let mut files = BTreeMap::new();
    walk(dir, dir, &mut files);
    files
}

/// Each view of an orbit of a mesh and of a packing of spheres, rendered as one job (the mesh's
/// last view still on the device when the second scene is loaded), holds the bytes of the
/// single render of the scene with that view's camera: on the GPU in the default (adaptive)
/// precision, where some views cast pixels again in f64 after their kernel, and in f32, and on
/// the CPU.
#[test]
fn every_view_of_a_job_is_its_single_render_on_each_device() {
    let gpu: &Gpu = common::gpu();
    let scenes = [
        scene_path("bunny.stl"),
        scene_path("course/sphere-packing.json"),
    ];
    for mode in ["gpu", "gpu:f32", "cpu"] {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("out");
        let job = job(&scenes, 6, mode, &out);
        let summary = job.run(Some(gpu), None, &mut |_, _| {}).unwrap();
        assert_eq!(summary.counts, [12, 0, 12], "{mode}");
        let mut recast = 0.0;
        for path in &scenes {
            let split = Split::default();
            let start = raycast::load_viewed(Some(path), Some(SIZE), &Default::default(), split);
            let mut scene = start.unwrap();
            let stem = path.file_stem().unwrap();
            for (name, mut camera) in job.views.cameras(&scene).unwrap() {
                camera.resolution = SIZE;
                scene.camera = camera;
                let single = dir.path().join("single").join(&name);
                let files = RenderFiles {
                    scene: Some(path.clone()),
                    ..render_files(mode, &single)
                };
                let summary = files.run_loaded(Some(gpu), None, &scene).unwrap();
                recast += summary.recast.map_or(0.0, |(fraction, _)| fraction);
                let mut view = tree(&out.join(stem).join(&name));
                assert!(view.remove(Path::new("job.json")).is_some(), "a record");
                let single = tree(&single);
                assert_eq!(
                    view.keys().collect::<Vec<_>>(),
                    single.keys().collect::<Vec<_>>()
                );
                for (file, bytes) in &view {
                    let at = format!("{mode} {}/{name}/{}", path.display(), file.display());
                    assert!(
                        bytes == &single[file],
                        "{at} differs from the single render"
                    );
                }
            }
        }
        assert_eq!(recast > 0.0, mode == "gpu", "{mode}: pixels re-cast in f64");
    }
}

/// An error at a view (here a pair beyond the job, given between others) stops the job with
/// its message once the views before it, the last of them on the device when the error came,
/// are written whole: none after it is rendered, and no temporary folder is left.
#[test]
fn an_error_stops_the_views_after_those_before_it_are_written() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let job = job(&[scene_path("bunny.stl")], 4, "gpu", &out);
    let mut renderer = job.renderer().unwrap();
    let error = renderer.render(Some(common::gpu()), &[0, 1, 99, 2]);
    let message = error.unwrap_err().to_string();
    assert!(
        message.contains("99 is beyond the job's 4 views"),
        "{message}"
    );
    assert_eq!(
        common::file_names(&out.join("bunny")),
        ["orbit-000", "orbit-001"]
    );
    for view in ["orbit-000", "orbit-001"] {
        let files = common::file_names(&out.join("bunny").join(view));
        assert!(files.contains(&"job.json".to_owned()), "{view}: {files:?}");
        assert!(files.contains(&"id.npy".to_owned()), "{view}: {files:?}");
    }
    // Started again, the job renders the two views left and skips the two written.
    assert_eq!(
        renderer.render(Some(common::gpu()), &[0, 1, 2, 3]).unwrap(),
        2
    );
}
