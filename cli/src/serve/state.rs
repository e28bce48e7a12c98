//! What the page shows: the scene and hook last loaded without error (the frames render these),
//! and the status the page reads (`/state`, `/events`): the version, the camera, the error of
//! a failed reload. A thread polls the files and reloads them when one changes.

use std::path::PathBuf;
use std::sync::atomic::AtomicUsize;
use std::sync::{Arc, Condvar, Mutex};
use std::time::Duration;

use raycast::{Camera, Lens};
use raycast::{Gpu, Result, Scene, ShadeHook, Viewer};
use serde::Serialize;

use super::Options;
use super::frame::Cache;
use crate::watch;

/// How often the files are polled.
const POLL: Duration = Duration::from_millis(100);

/// The scene and hook frames render, under one lock: frames render one at a time.
pub(super) struct Current {
    pub viewer: Viewer,
    pub hook: Option<ShadeHook>,
    pub version: u64,
    pub cache: Cache,
}

impl Current {
    fn new(scene: Scene, hook: Option<ShadeHook>, version: u64) -> Current {
        Current {
            viewer: Viewer::from(scene),
            hook,
            version,
            cache: Cache::default(),
        }
    }
}

/// What the page reads: `/state`, and each `/events` message.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(super) struct Status {
    /// Counts the successful loads, from 1.
    pub version: u64,
    pub title: String,
    /// The files whose change reloads, as given (`files` on the page).
    #[serde(rename = "files", serialize_with = "as_given")]
    pub watched: Vec<PathBuf>,
    /// The hook file's name, `lit`, or `None`.
    pub hook: Option<String>,
    /// Whether the CPU reference colours the colour tab (it has no custom hooks).
    pub cpu_color: bool,
    pub camera: PageCamera,
    /// Why the last reload failed, as the command line would print it.
    pub error: Option<String>,
}

/// The scene's own camera as the page moves it: eye, the point looked at, up.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub(super) struct PageCamera {
    pub eye: [f64; 3],
    pub look_at: [f64; 3],
    pub up: [f64; 3],
    /// Vertical field of view in degrees (orthographic cameras: that of their plane seen from
    /// the focal length), for the page's panning speed.
    pub fov: f64,
    pub size: [u32; 2],
}

/// Everything the server's threads share.
pub(super) struct Shared {
    pub options: Options,
    pub gpu: Gpu,
    pub current: Mutex<Current>,
    pub status: Mutex<Status>,
    /// Notified when `status` changes.
    pub changed: Condvar,
    /// Open `/events` streams.
    pub streams: AtomicUsize,
    /// Requests being handled.
    pub requests: AtomicUsize,
}

impl Shared {
    /// The files loaded first: any error here is the command's.
    pub fn load(options: Options, gpu: Gpu) -> Result<Shared> {
        let (scene, hook, watched) = load(&options)?;
        let status = Status {
            version: 1,
            title: options.scene.as_ref().map_or("default scene".into(), |p| {
                p.file_name().unwrap_or_default().to_string_lossy().into()
            }),
            watched,
            hook: match (&options.shader, options.lit) {
                (Some(file), _) => Some(file.display().to_string()),
                (None, true) => Some("lit".into()),
                (None, false) => None,
            },
            cpu_color: options.shader.is_none(),
            camera: page_camera(&scene),
            error: None,
        };
        Ok(Shared {
            current: Mutex::new(Current::new(scene, hook, 1)),
            options,
            gpu,
            status: Mutex::new(status),
            changed: Condvar::new(),
            streams: AtomicUsize::new(0),
            requests: AtomicUsize::new(0),
        })
    }

    pub fn status(&self) -> Status {
        self.status.lock().expect("the status lock").clone()
    }

    /// Reads the files again: the new scene and hook replace the old (once the frame being
    /// rendered is done), or the error is shown.
    fn reload(&self) {
        let loaded = load(&self.options);
        let mut status = self.status.lock().expect("the status lock");
        match loaded {
            Ok((scene, hook, watched)) => {
                status.version += 1;
                status.camera = page_camera(&scene);
                status.watched = watched;
                status.error = None;
                let version = status.version;
                // Not holding the status while a frame renders: the page reads it meanwhile.
                drop(status);
                *self.current.lock().expect("the render lock") = Current::new(scene, hook, version);
            }
            Err(e) => status.error = Some(crate::error_text(e)),
        }
        self.changed.notify_all();
    }

    /// The files whose change reloads.
    fn watched(&self) -> Vec<PathBuf> {
        self.status.lock().expect("the status lock").watched.clone()
    }
}

/// The scene (or mesh) and the hook of `options`, and the files they were read from.
fn load(options: &Options) -> Result<(Scene, Option<ShadeHook>, Vec<PathBuf>)> {
    let scene = raycast::load_viewed(
        options.scene.as_deref(),
        options.size,
        &Default::default(),
        Default::default(),
    )?;
    let hook = raycast_datasets::requested_hook(options.lit, options.shader.as_deref())?;
    Ok((scene, hook, watched(options)))
}

/// The files whose change reloads: the scene file and its meshes, or the mesh file, and the hook.
fn watched(options: &Options) -> Vec<PathBuf> {
    crate::watch::watched_files(options.scene.as_deref(), options.shader.as_deref(), None)
}

/// Paths as given, for the page.
fn as_given<S: serde::Serializer>(paths: &[PathBuf], serializer: S) -> Result<S::Ok, S::Error> {
    serializer.collect_seq(paths.iter().map(|p| p.display().to_string()))
}

/// The page's form of `scene`'s camera: the point looked at is where the view direction
/// passes closest to the centre of the scene's bounds (so orbiting turns about the objects),
/// or one focal length ahead without bounds.
fn page_camera(scene: &Scene) -> PageCamera {
    let c = &scene.camera;
    let ahead = c.look.normalize();
    let along = raycast::bounds(&scene.objects)
        .map(|(lo, hi)| ((lo + hi) / 2.0 - c.eye).dot(ahead))
        .filter(|d| *d > 0.0)
        .unwrap_or(c.focal_length);
    PageCamera {
        eye: c.eye.to_array(),
        look_at: (c.eye + ahead * along).to_array(),
        up: c.up.to_array(),
        fov: fov_degrees(c),
        size: c.resolution,
    }
}

/// The camera's vertical field of view in degrees (an orthographic camera's: that of its image
/// plane seen from the focal length).
fn fov_degrees(camera: &Camera) -> f64 {
    let height = match camera.lens {
        Lens::Fov { degrees } => return degrees,
        Lens::Size { height, .. } => height,
        Lens::Intrinsics { fy, resolution, .. } => camera.focal_length * resolution[1] as f64 / fy,
    };
    2.0 * (height / 2.0).atan2(camera.focal_length).to_degrees()
}

/// Starts the thread that reloads the files when one changes.
pub(super) fn watch(shared: Arc<Shared>) {
    // The first stamps are taken here, before the page's address is printed, not whenever the
    // thread first runs: a file saved once the page is up is always seen as changed.
    let mut files = shared.watched();
    let mut before = watch::stamps(&files);
    std::thread::spawn(move || {
        loop {
            while watch::stamps(&files) == before {
                std::thread::sleep(POLL);
            }
            shared.reload();
            files = shared.watched();
            before = watch::stamps(&files);
        }
    });
}
