//! Many views of many scenes, to files: a dataset (`raycast render SCENE... --views FILE` or
//! `--orbit N`).
//!
//! The job is every (scene, view) pair: the scenes in the order given, each with every view in
//! the views file's order (or the orbit's). A view's files go to `OUT/<scene stem>/<view name>/`,
//! written into a hidden folder beside it and renamed into place, so a view's folder is there
//! whole or not at all. Its record (`job.json`, [`record`]) says what it was rendered with: a
//! run started again skips the views whose folder holds their files and the same record, and
//! renders the others again ([`RenderViews::force`] renders every one again). A scene is loaded
//! once, what depends on its objects alone made once (a [`Viewer`]: the shape of its BVH, their
//! extent), the render's shade hook and kernel file read once and its kernels compiled once (the
//! device's pipeline cache); a view redoes only what its camera changes: the primitives measured
//! from its eye, the BVH's boxes, the render and the files. The views go through a pipeline
//! ([`ViewRenderer::render_all`]): while the device runs one view's kernel, the host finishes the
//! view before and prepares the next, and a thread writes files. Each view is the same render as
//! the single render of that scene with that camera ([`RenderFiles::run`]), so it writes the same
//! bytes.
//!
//! A shard ([`Shard`]) renders a contiguous share of the pairs, of about equal estimated cost,
//! so that a scene's views mostly stay in one shard and its preparation is done once.
//! `OUT/manifest.jsonl` lists every pair of the job with its status, `done` where its folder
//! is complete, `stale` where it holds another job's files, else `pending`: each run rewrites
//! it whole once its own views are done, under a lock, so the last shard to finish writes the
//! manifest of the whole job.

use std::collections::HashMap;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{Receiver, SyncSender};
use std::time::{Duration, Instant};

use glam::DVec3;
use serde_json::Value;

use raycast::{AnyImages, Begun, Error, Gpu, Result, Viewer};
use raycast::{Coverage, Images};
use raycast::{Lens, Orbit, Projection, Scene, ViewCamera};

use crate::files::{Files, RenderFiles, Whole};
use crate::record::{self, Found};

/// The job's manifest, in the output folder.
const MANIFEST: &str = "manifest.jsonl";

/// The cameras of every scene in a [`RenderViews`] job.
#[derive(Clone, Debug, PartialEq)]
pub enum Views {
    /// A views file: a JSON list of cameras in any form a scene file's camera takes, each with a
    /// `name`, the folder its files go in (docs/datasets.md).
    File(PathBuf),
    /// A views file's text, given in memory (named `<views>` in errors).
    Json(String),
    /// A poses file: JSON lines, a view a line, each moving the scene's instances and maybe
    /// giving a camera (docs/datasets.md#poses).
    Poses(PathBuf),
    /// Views around each scene's bounded objects, named `orbit-000`, `orbit-001`, ...: a
    /// turntable about the scene camera's up direction, from where it stands, on the objects'
    /// side of every plane ([`Orbit`], docs/datasets.md#orbits).
    Orbit(Orbit),
}

impl Views {
    /// Why a camera setting of the render is refused: a views file's cameras are whole, an
    /// orbit takes its settings in [`Orbit::camera`].
    fn camera_refusal(&self) -> String {
        match self {
            Views::Orbit(_) => "sets the orbit's start: give it in Orbit::camera instead".into(),
            _ => "sets one camera, and every view of `views` has its own".into(),
        }
    }

    /// The name of a views file in errors.
    fn file(&self) -> &Path {
        match self {
            Views::File(path) | Views::Poses(path) => path,
            _ => Path::new("<views>"),
        }
    }

    /// The views' names, and a views file's cameras (checked but for what a scene decides).
    fn parse(&self) -> Result<(Vec<String>, Vec<ViewCamera>)> {
        let text = match self {
            Views::File(path) | Views::Poses(path) => {
                std::fs::read_to_string(path).map_err(|e| Error::Io {
                    path: path.to_path_buf(),
                    message: e.to_string(),
                })?
            }
            Views::Json(text) => text.clone(),
            Views::Orbit(orbit) => return Ok((orbit.names()?, Vec::new())),
        };
        let cameras = match self {
            Views::Poses(_) => raycast::parse_poses(&text, self.file())?,
            _ => raycast::parse_views(&text, self.file())?,
        };
        let names: Vec<String> = cameras.iter().map(|c| c.name.clone()).collect();
        check_names(&names, self.file())?;
        Ok((names, cameras))
    }

    /// Every view's name and camera for `scene` (its own camera the orbit's start), as a
    /// [`RenderViews`] job renders them (without a `size`).
    pub fn cameras(&self, scene: &Scene) -> Result<Vec<(String, raycast::Camera)>> {
        let (names, cameras) = self.parse()?;
        let cameras = self.cameras_of(&cameras, scene)?;
        Ok(names.into_iter().zip(cameras).collect())
    }

    /// Every view's camera for `scene`, whose own camera (at the job's size) is the orbit's
    /// start; `cameras` are a views file's.
    fn cameras_of(&self, cameras: &[ViewCamera], scene: &Scene) -> Result<Vec<raycast::Camera>> {
        match self {
            Views::Orbit(orbit) => orbit.cameras(scene),
            _ => (cameras.iter())
                .map(|c| c.camera(self.file(), scene))
                .collect(),
        }
    }
}

/// The names of the camera settings `view` gives.
fn given(view: &raycast::CameraOverrides) -> Vec<&'static str> {
    let given = [
        ("eye", view.eye.is_some()),
        ("look_at", view.look_at.is_some()),
        ("up", view.up.is_some()),
        ("fov", view.fov.is_some()),
    ];
    given.iter().filter(|(_, g)| *g).map(|(n, _)| *n).collect()
}

/// A share of a job: shard `index` of `count` (0-based), `I/N` on the command line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Shard {
    /// Which share, `0..count`.
    pub index: u32,
    /// How many shares the job is split into.
    pub count: u32,
}

impl std::str::FromStr for Shard {
    type Err = String;
    fn from_str(s: &str) -> std::result::Result<Shard, String> {
        let err = || format!("expected I/N with 0 <= I < N, such as 0/4, got `{s}`");
        let (i, n) = s.split_once('/').ok_or_else(err)?;
        let index: u32 = i.trim().parse().map_err(|_| err())?;
        let count: u32 = n.trim().parse().map_err(|_| err())?;
        (index < count)
            .then_some(Shard { index, count })
            .ok_or_else(err)
    }
}

/// Many views of many scenes rendered to files, as `raycast render SCENE... --views FILE -o OUT`
/// does it (module docs).
#[derive(Clone, Debug)]
pub struct RenderViews {
    /// The scene or mesh files; none: the built-in default scene.
    pub scenes: Vec<PathBuf>,
    /// The cameras.
    pub views: Views,
    /// Render views whose folder is complete again.
    pub force: bool,
    /// How every view is rendered and written: its `out_dir` is the job's `OUT`; its `size`
    /// sets every view's resolution. Its `scene`, `view` and `emit_shader` are not used and
    /// must be unset (an orbit takes camera settings in [`Orbit::camera`]).
    pub render: RenderFiles,
}

/// What a run of a [`RenderViews`] job did, for the user.
#[derive(Clone, Debug)]
pub struct ViewsSummary {
    /// Views rendered, views skipped as complete, and views of this shard.
    pub counts: [usize; 3],
    /// Of the views rendered, those rendered again as stale: their folder held the files of
    /// another job (other options, a changed scene) or of a version without records.
    pub stale: usize,
    /// Views of the whole job.
    pub job: usize,
    /// The shard run, if one was.
    pub shard: Option<Shard>,
    /// Wall time of the run, rendering and writing.
    pub elapsed: Duration,
    /// The manifest written.
    pub manifest: PathBuf,
}

/// The pairs of a job, checked: its scenes, their folder names and the views' names.
#[derive(Clone, Debug)]
struct Pairs {
    scenes: Vec<Option<PathBuf>>,
    stems: Vec<String>,
    names: Vec<String>,
    /// The views file's cameras (for [`Views::File`], [`Views::Json`] and [`Views::Poses`]).
    cameras: Vec<ViewCamera>,
    /// Each pair's estimated cost, in job order.
    costs: Vec<f64>,
    /// Whether some view moves instances (a pose): each scene then has two viewers
    /// ([`Loaded::viewers`]).
    posed: bool,
}

impl Pairs {
    fn len(&self) -> usize {
        self.scenes.len() * self.names.len()
    }

    /// The scene and view of pair `p`.
    fn pair(&self, p: usize) -> (usize, usize) {
        (p / self.names.len(), p % self.names.len())
    }

    /// The instances view `v` moves (a pose's), none for other views.
    fn transforms(&self, v: usize) -> &[(usize, glam::DAffine3)] {
        self.cameras.get(v).map_or(&[], |c| &c.transforms)
    }

    fn folder(&self, out: &Path, p: usize) -> PathBuf {
        let (s, v) = self.pair(p);
        out.join(&self.stems[s]).join(&self.names[v])
    }

    /// The pairs of `shard`: a contiguous run of the job whose estimated costs add up to about
    /// a `count`th of the whole (a pair belongs to the share its cost's midpoint falls in).
    fn share(&self, shard: Option<Shard>) -> Vec<usize> {
        let Some(Shard { index, count }) = shard else {
            return (0..self.len()).collect();
        };
        let total: f64 = self.costs.iter().sum();
        let mut before = 0.0;
        let mut pairs = Vec::new();
        for (p, cost) in self.costs.iter().enumerate() {
            let middle = before + cost / 2.0;
            before += cost;
            let owner = ((middle / total * f64::from(count)) as u32).min(count - 1);
            if owner == index {
                pairs.push(p);
            }
        }
        pairs
    }
}

impl RenderViews {
    /// Checks everything that can be checked before rendering (the options, the scenes' folder
    /// names, every view's name and camera fields, the memory of the views whose size is
    /// known) and lists the job's pairs.
    fn job(&self) -> Result<Pairs> {
        let refuse = |option: &str, message: &str| {
            Err(Error::Argument {
                option: option.into(),
                message: message.into(),
            })
        };
        let r = &self.render;
        if r.scene.is_some() {
            return refuse(
                "scene",
                "every view renders the job's scenes: leave it unset",
            );
        }
        if let Some(option) = given(&r.view).first() {
            return refuse(option, &self.views.camera_refusal());
        }
        if r.emit_shader.is_some() {
            return refuse("emit_shader", "writes one kernel; render one view for it");
        }
        let files = r.check_options()?;
        let scenes: Vec<Option<PathBuf>> = match self.scenes.is_empty() {
            true => vec![None],
            false => self.scenes.iter().cloned().map(Some).collect(),
        };
        crate::files::check_split(r.split, scenes.iter().map(Option::as_deref))?;
        let stems = scene_stems(&scenes)?;
        let (names, cameras) = self.views.parse()?;
        let weights: Vec<f64> = scenes.iter().map(|s| scene_weight(s.as_deref())).collect();
        // A view's size where it is known before its scene is loaded.
        let size = |v: usize| r.size.or_else(|| cameras.get(v).and_then(|c| c.resolution));
        let mut sizes: Vec<[u32; 2]> = (0..names.len()).filter_map(size).collect();
        sizes.sort_unstable();
        sizes.dedup();
        sizes
            .into_iter()
            .try_for_each(|s| r.check_memory(s, &files))?;
        let pixels: Vec<f64> = (0..names.len())
            .map(|v| {
                let [nx, ny] = size(v).unwrap_or(raycast::DEFAULT_RESOLUTION);
                f64::from(nx) * f64::from(ny)
            })
            .collect();
        let costs = weights
            .iter()
            .flat_map(|w| pixels.iter().map(move |p| w * p))
            .collect();
        Ok(Pairs {
            posed: cameras.iter().any(|c| !c.transforms.is_empty()),
            scenes,
            stems,
            names,
            cameras,
            costs,
        })
    }

    /// Checks the job ([`RenderViews::run`] does this first) and returns how many views it has.
    pub fn check(&self) -> Result<usize> {
        self.job().map(|job| job.len())
    }

    /// A renderer of this job's views one by one, which keeps the scene of the last view it
    /// rendered prepared: what a worker of a distributed run holds.
    pub fn renderer(&self) -> Result<ViewRenderer> {
        Ok(ViewRenderer {
            job: self.job()?,
            names: self.file_names(),
            record: record::job_part(&self.render)?,
            spec: self.clone(),
            loaded: None,
            files: None,
        })
    }

    /// Renders every view of `shard` (or of the job) whose folder is not complete, or holds
    /// another job's files (every one with [`RenderViews::force`]), then rewrites the manifest. `on_view(done, total)` is
    /// called as each view of the share is rendered or skipped.
    pub fn run(
        &self,
        gpu: Option<&Gpu>,
        shard: Option<Shard>,
        on_view: &mut dyn FnMut(usize, usize),
    ) -> Result<ViewsSummary> {
        let clock = Instant::now();
        let mut renderer = self.renderer()?;
        let share = renderer.job.share(shard);
        raycast_files::check_writable(&self.render.out_dir)?;
        let [rendered, stale] = renderer.render_all(gpu, &share, on_view)?;
        let manifest = self.manifest_of(&renderer.job, &renderer.names, &renderer.record)?;
        Ok(ViewsSummary {
            counts: [rendered, share.len() - rendered, share.len()],
            stale,
            job: renderer.job.len(),
            shard,
            elapsed: clock.elapsed(),
            manifest,
        })
    }

    /// Rewrites `OUT/manifest.jsonl` from what the output folder holds: a line for every pair
    /// of the job, in job order, `done` with its files where its folder is complete with a
    /// record of this job's options, `stale` where it holds another's, else `pending`. Under an
    /// exclusive lock on `OUT/.manifest.lock` (removed as it is released), so that of shards
    /// finishing together the last writes last and sees every view.
    pub fn write_manifest(&self) -> Result<PathBuf> {
        raycast_files::check_writable(&self.render.out_dir)?;
        let job_part = record::job_part(&self.render)?;
        self.manifest_of(&self.job()?, &self.file_names(), &job_part)
    }

    /// [`RenderViews::write_manifest`] of `job`, this job checked, whose complete views hold
    /// the files `names` and records whose shared part is `job_part`. The scenes and the views'
    /// cameras are not compared: that needs the scenes loaded, which the run whose share a view
    /// is in does.
    fn manifest_of(&self, job: &Pairs, names: &[String], job_part: &Value) -> Result<PathBuf> {
        let out = &self.render.out_dir;
        let _lock = Lock::new(&out.join(".manifest.lock"))?;
        let mut text = String::new();
        for p in 0..job.len() {
            let (s, v) = job.pair(p);
            let found = record::found(&job.folder(out, p), names, job_part, true);
            let done = found == Found::Complete;
            let line = serde_json::json!({
                "scene": job.scenes[s].as_ref().map_or("<default scene>".into(), |p| p.display().to_string()),
                "view": job.names[v],
                "dir": format!("{}/{}", job.stems[s], job.names[v]),
                "files": if done { names } else { &[] },
                "status": match found {
                    Found::Complete => "done",
                    Found::Stale => "stale",
                    Found::Missing => "pending",
                },
            });
            text.push_str(&line.to_string());
            text.push('\n');
        }
        let path = out.join(MANIFEST);
        raycast_files::write_file(&path, text.as_bytes())?;
        Ok(path)
    }

    /// The files each view's folder holds: those the encoding writes for images of this job
    /// (with coverage when supersampled, with a hook's colours when shaded) and camera.json.
    fn file_names(&self) -> Vec<String> {
        let r = &self.render;
        // One pixel, a miss: the files' names do not depend on what it holds.
        let mut images = Images::<f32> {
            width: 1,
            height: 1,
            id: vec![raycast::MISS],
            distance: vec![f32::INFINITY],
            normal: vec![[0.0; 3]],
            ..Images::default()
        };
        if r.spp.is_some_and(|s| s > 1) {
            images.coverage = Some(Coverage {
                spp: 4,
                hits: vec![0],
                alpha: vec![0.0],
                color_sum: vec![[0; 3]],
            });
        }
        if r.shader.is_some() || r.lit {
            images.color = Some(vec![[0; 4]]);
        }
        // Any camera: the names do not depend on it.
        let camera = raycast::Camera {
            projection: Projection::Perspective,
            eye: DVec3::ZERO,
            look: DVec3::NEG_Z,
            up: DVec3::Y,
            focal_length: 1.0,
            lens: Lens::Size {
                width: 1.0,
                height: 1.0,
            },
            resolution: [1, 1],
            depth_white: 1.0,
        };
        let files = AnyImages::F32(images).encode(&r.encoding, &camera);
        files.iter().map(|f| f.name.to_owned()).collect()
    }
}

/// Renders the views of a job one at a time (from [`RenderViews::renderer`]), keeping the
/// last one's scene loaded, with what its views share whatever their camera (the shape of its
/// BVH, the extent of its objects).
pub struct ViewRenderer {
    spec: RenderViews,
    job: Pairs,
    /// The files a complete view's folder holds.
    names: Vec<String>,
    /// The part of the views' records the job shares ([`record::job_part`]).
    record: Value,
    loaded: Option<Loaded>,
    /// The render's shade hook and kernel file, read and checked, the same for every view:
    /// read at the first view rendered.
    files: Option<Files>,
}

/// A scene as its views share it.
struct Loaded {
    index: usize,
    /// The scene, with what its views' preparations share: the BVH's shape, the objects'
    /// extent. Two where views move instances (poses): a view started moves those of one
    /// while the view before, on the device, is finished with the other, at its own pose.
    viewers: Vec<Viewer>,
    /// The viewer the next view started takes (they take turns).
    turn: usize,
    /// Its views' cameras, in the job's order ([`Views::cameras`]).
    cameras: Vec<raycast::Camera>,
    /// The digest of its files, in its views' records ([`record::scene_digest`]).
    digest: String,
    /// The temporary folders killed runs left in its folder, by view name: removed before
    /// that view renders (only the run rendering a view writes its temporary folders).
    stale: HashMap<String, Vec<PathBuf>>,
}

/// The thread that runs the views' kernels, one at a time, while this one prepares the next
/// view and finishes the last ([`ViewRenderer::render_all`]).
struct Device {
    jobs: SyncSender<Box<Begun>>,
    results: Receiver<Result<Begun>>,
}

/// A view whose kernel the device runs, and its place among the views rendered.
struct InFlight {
    view: ViewFiles,
    position: usize,
}

/// Why the views stopped before the last.
enum Stop {
    Failed(Error),
    /// The writer stopped at an error, which it returns.
    Writer,
    /// The device's thread panicked.
    DeviceLost,
}

impl From<Error> for Stop {
    fn from(e: Error) -> Stop {
        Stop::Failed(e)
    }
}

impl ViewRenderer {
    /// Renders the views `pairs` in order; returns how many it rendered (the rest were
    /// complete), and how many of those were stale.
    ///
    /// Three threads share the work. This one prepares each view on the host (its camera's
    /// primitives and BVH) and hands it to the device's thread, which runs its kernel and
    /// reads it back while this one finishes the view before (adaptive precision's re-cast)
    /// and prepares the next; a writer thread writes each view's files. So one prepared view at
    /// most waits for the device, and one rendered view for the writer. Each view is finished,
    /// written and reported (`on_view`) in order; at an error, the views before it are
    /// finished and written, and none after it.
    fn render_all(
        &mut self,
        gpu: Option<&Gpu>,
        pairs: &[usize],
        on_view: &mut dyn FnMut(usize, usize),
    ) -> Result<[usize; 2]> {
        let (writes, to_write) = std::sync::mpsc::sync_channel::<Box<ViewWrite>>(1);
        let (jobs, device_jobs) = std::sync::mpsc::sync_channel::<Box<Begun>>(1);
        let (device_results, results) = std::sync::mpsc::channel();
        std::thread::scope(|scope| {
            let writer = scope.spawn(move || -> Result<()> {
                for write in to_write {
                    write.finish()?;
                }
                Ok(())
            });
            let device_thread = gpu.map(|gpu| {
                scope.spawn(move || {
                    for work in device_jobs {
                        if device_results.send(work.run(gpu)).is_err() {
                            break;
                        }
                    }
                })
            });
            let device = Device { jobs, results };
            let outcome = self.pipeline(gpu, pairs, on_view, &writes, device);
            drop(writes);
            let written = writer.join().expect("the writer does not panic");
            match outcome {
                Ok(counts) => written.map(|()| counts),
                Err(Stop::Failed(e)) => Err(e),
                Err(Stop::Writer) => Err(written.expect_err("the writer stopped at an error")),
                Err(Stop::DeviceLost) => {
                    let thread = device_thread.expect("a device thread where one ran");
                    let panic = thread.join().expect_err("the device thread stopped early");
                    std::panic::resume_unwind(panic)
                }
            }
        })
    }

    /// The loop of [`ViewRenderer::render_all`] on this thread: each view started, its kernel
    /// handed to `device` once the view before has left it, and that view finished and handed
    /// to the writer (`writes`) while the device runs the kernel.
    fn pipeline(
        &mut self,
        gpu: Option<&Gpu>,
        pairs: &[usize],
        on_view: &mut dyn FnMut(usize, usize),
        writes: &SyncSender<Box<ViewWrite>>,
        device: Device,
    ) -> std::result::Result<[usize; 2], Stop> {
        let [mut rendered, mut stale] = [0, 0];
        let mut in_flight: Option<InFlight> = None;
        let mut done = |position: usize| on_view(position + 1, pairs.len());
        for (position, &p) in pairs.iter().enumerate() {
            // A view of another scene: the one in flight is finished with its own first.
            if in_flight
                .as_ref()
                .is_some_and(|f| f.view.scene != self.job.pair(p).0)
            {
                self.land(gpu, in_flight.take(), &device, writes, &mut done)?;
            }
            let (started, found) = match self.start(gpu, p) {
                Ok(started) => started,
                Err(e) => {
                    self.land(gpu, in_flight.take(), &device, writes, &mut done)?;
                    return Err(e.into());
                }
            };
            rendered += usize::from(!matches!(started, Started::Complete));
            stale += usize::from(found == Found::Stale);
            match started {
                Started::Device(work, view) => {
                    // The device is free once the view before is back.
                    let before = in_flight.take().map(|f| (device.results.recv(), f));
                    let before_ran = before.as_ref().is_none_or(|(r, _)| matches!(r, Ok(Ok(_))));
                    if before_ran && device.jobs.send(work).is_ok() {
                        in_flight = Some(InFlight { view, position });
                    }
                    if let Some((ran, f)) = before {
                        self.finish(gpu, ran, f, writes, &mut done)?;
                    }
                    if in_flight.is_none() {
                        return Err(Stop::DeviceLost);
                    }
                }
                other => {
                    self.land(gpu, in_flight.take(), &device, writes, &mut done)?;
                    match other {
                        Started::Complete | Started::Device(..) => {}
                        Started::Rendered(write) => send(writes, write)?,
                        Started::Bands(view) => self.write_bands(gpu, view)?,
                    }
                    done(position);
                }
            }
        }
        self.land(gpu, in_flight, &device, writes, &mut done)?;
        Ok([rendered, stale])
    }

    /// Finishes the view `in_flight`, if any, once the device has run its kernel.
    fn land(
        &mut self,
        gpu: Option<&Gpu>,
        in_flight: Option<InFlight>,
        device: &Device,
        writes: &SyncSender<Box<ViewWrite>>,
        done: &mut dyn FnMut(usize),
    ) -> std::result::Result<(), Stop> {
        match in_flight {
            Some(f) => self.finish(gpu, device.results.recv(), f, writes, done),
            None => Ok(()),
        }
    }

    /// Finishes the view `f` from what the device returned for it (`ran`, an error where its
    /// thread is gone) and hands it to the writer.
    fn finish(
        &mut self,
        gpu: Option<&Gpu>,
        ran: std::result::Result<Result<Begun>, std::sync::mpsc::RecvError>,
        f: InFlight,
        writes: &SyncSender<Box<ViewWrite>>,
        done: &mut dyn FnMut(usize),
    ) -> std::result::Result<(), Stop> {
        let ran = ran.map_err(|_| Stop::DeviceLost)??;
        let gpu = gpu.expect("a view ran on the device");
        let loaded =
            (self.loaded.as_mut()).expect("a view's scene stays loaded until it is finished");
        let camera = f.view.camera.clone();
        let viewer = &mut loaded.viewers[f.view.viewer];
        let images = viewer.render(camera, |scene| ran.finish(gpu, scene))?;
        let write = ViewWrite {
            images,
            encoding: self.spec.render.encoding.clone(),
            view: f.view,
        };
        send(writes, Box::new(write))?;
        done(f.position);
        Ok(())
    }

    /// Renders the views `pairs` of the job (indices of its pairs, below the count
    /// [`RenderViews::check`] returns) in order, each into its folder unless its folder is
    /// complete and the job does not force, writing each view's files while the next renders;
    /// returns how many it rendered.
    pub fn render(&mut self, gpu: Option<&Gpu>, pairs: &[usize]) -> Result<usize> {
        self.render_all(gpu, pairs, &mut |_, _| {})
            .map(|[rendered, _]| rendered)
    }

    /// Starts view `pair` unless it is complete: renders it on the host, or prepares it for
    /// the device, or leaves a render in bands to [`ViewRenderer::write_bands`]. Also returns
    /// what its folder held (not looked at when forced: [`Found::Missing`]).
    fn start(&mut self, gpu: Option<&Gpu>, pair: usize) -> Result<(Started, Found)> {
        if pair >= self.job.len() {
            return Err(Error::Argument {
                option: "pair".into(),
                message: format!("{pair} is beyond the job's {} views", self.job.len()),
            });
        }
        let out = &self.spec.render.out_dir;
        let folder = self.job.folder(out, pair);
        let (s, v) = self.job.pair(pair);
        let ViewRenderer {
            spec,
            job,
            loaded,
            names,
            record,
            files,
        } = self;
        let loaded = load(loaded, job, spec, s)?;
        let mut camera = loaded.cameras[v].clone();
        if let Some(size) = spec.render.size {
            camera.resolution = size;
        }
        let transforms = job.transforms(v);
        let record = record::view_record(record, &loaded.digest, &camera, transforms);
        let found = match spec.force {
            true => Found::Missing,
            false => record::found(&folder, names, &record, false),
        };
        if found == Found::Complete {
            return Ok((Started::Complete, found));
        }
        for stale in loaded.stale.remove(&job.names[v]).unwrap_or_default() {
            let _ = std::fs::remove_dir_all(stale);
        }
        let view = ViewFiles {
            scene: s,
            viewer: loaded.turn,
            record: record::encode(&record),
            folder,
            camera,
        };
        loaded.turn = (loaded.turn + 1) % loaded.viewers.len();
        let render = view.render_files(spec, job, &view.folder);
        let camera = view.camera.clone();
        let viewer = &mut loaded.viewers[view.viewer];
        viewer.pose(transforms)?;
        let begun = viewer.render(camera, |scene| render.begin_images(gpu, scene, files))?;
        let started = match begun {
            None => Started::Bands(view),
            Some(Whole::Device(work)) => Started::Device(Box::new(work), view),
            Some(Whole::Done(images)) => Started::Rendered(Box::new(ViewWrite {
                images,
                encoding: render.encoding,
                view,
            })),
        };
        Ok((started, found))
    }

    /// Renders and writes view `view` in bands (its files written as they come), into its
    /// temporary folder and then in place.
    fn write_bands(&mut self, gpu: Option<&Gpu>, view: ViewFiles) -> Result<()> {
        let loaded = (self.loaded.as_mut()).expect("a view's scene is loaded");
        raycast_files::write_folder(&view.folder, |temporary| {
            let files = view.render_files(&self.spec, &self.job, temporary);
            let camera = view.camera.clone();
            let viewer = &mut loaded.viewers[view.viewer];
            viewer.render(camera, |scene| files.run_loaded(gpu, None, scene))?;
            write_record(temporary, &view.record)
        })
    }
}

/// Hands `write` to the writer; [`Stop::Writer`] where it stopped at an error.
fn send(
    writes: &SyncSender<Box<ViewWrite>>,
    write: Box<ViewWrite>,
) -> std::result::Result<(), Stop> {
    writes.send(write).map_err(|_| Stop::Writer)
}

/// A view started by [`ViewRenderer::start`].
enum Started {
    /// Its folder was complete: nothing rendered.
    Complete,
    /// Rendered on the host, its files still to write.
    Rendered(Box<ViewWrite>),
    /// Prepared for the device, whose kernel is still to run; then finished on the host.
    Device(Box<Begun>, ViewFiles),
    /// To render in bands, its files written as they come ([`ViewRenderer::write_bands`]).
    Bands(ViewFiles),
}

/// A view being rendered: its scene (by index in the job) and camera, its record, and the
/// folder its files go in (written whole: [`raycast_files::write_folder`]).
struct ViewFiles {
    scene: usize,
    /// Which of its scene's viewers renders it ([`Loaded::viewers`]).
    viewer: usize,
    camera: raycast::Camera,
    record: Vec<u8>,
    folder: PathBuf,
}

impl ViewFiles {
    /// The render of this view as `spec` renders every view, into `out`.
    fn render_files(&self, spec: &RenderViews, job: &Pairs, out: &Path) -> RenderFiles {
        RenderFiles {
            out_dir: out.to_owned(),
            scene: job.scenes[self.scene].clone(),
            ..spec.render.clone()
        }
    }
}

/// Writes a view's record (`record`, encoded) into its temporary folder.
fn write_record(temporary: &Path, record: &[u8]) -> Result<()> {
    let path = temporary.join(record::RECORD);
    std::fs::write(&path, record).map_err(|e| Error::Io {
        path: path.to_path_buf(),
        message: format!("cannot write: {e}"),
    })
}

/// A view's images, and where they go with its record.
struct ViewWrite {
    images: AnyImages,
    encoding: raycast::Encoding,
    view: ViewFiles,
}

impl ViewWrite {
    /// Writes the files and the record, then puts the folder in place; on an error leaves no
    /// folder behind. The files are those [`AnyImages::encode`] makes, written straight into
    /// the temporary folder, which is what appears whole or not at all.
    fn finish(self) -> Result<()> {
        let view = &self.view;
        let files = self.images.encode(&self.encoding, &view.camera);
        raycast_files::write_folder(&view.folder, |temporary| {
            for f in &files {
                let path = temporary.join(f.name);
                std::fs::write(&path, &f.bytes).map_err(|e| Error::Io {
                    path: path.to_path_buf(),
                    message: format!("cannot write: {e}"),
                })?;
            }
            write_record(temporary, &view.record)
        })
    }
}

/// The scene of `job`'s scene `s`, loaded into `loaded` unless it is the one there.
fn load<'a>(
    loaded: &'a mut Option<Loaded>,
    job: &Pairs,
    spec: &RenderViews,
    s: usize,
) -> Result<&'a mut Loaded> {
    if loaded.as_ref().is_none_or(|l| l.index != s) {
        *loaded = None;
        let path = job.scenes[s].as_deref();
        let view = raycast::CameraOverrides::default();
        let scene = raycast::load_viewed(path, spec.render.size, &view, spec.render.split)?;
        for warning in &scene.warnings {
            eprintln!("warning: {warning}");
        }
        *loaded = Some(Loaded {
            digest: record::scene_digest(path, &scene)?,
            stale: stale_folders(&spec.render.out_dir.join(&job.stems[s])),
            index: s,
            cameras: spec.views.cameras_of(&job.cameras, &scene)?,
            viewers: match job.posed {
                true => vec![Viewer::from(scene.clone()), Viewer::from(scene)],
                false => vec![Viewer::from(scene)],
            },
            turn: 0,
        });
    }
    Ok(loaded.as_mut().expect("loaded above"))
}

/// The temporary folders of views in a scene's `folder` (`.NAME.tmp-PID`, `.NAME.old-PID`),
/// by view name.
fn stale_folders(folder: &Path) -> HashMap<String, Vec<PathBuf>> {
    let mut stale: HashMap<String, Vec<PathBuf>> = HashMap::new();
    for entry in std::fs::read_dir(folder).into_iter().flatten().flatten() {
        let name = entry.file_name().to_string_lossy().into_owned();
        let view = name
            .strip_prefix('.')
            .and_then(|n| n.rsplit_once(".tmp-").or_else(|| n.rsplit_once(".old-")));
        if let Some((view, _)) = view {
            stale.entry(view.to_owned()).or_default().push(entry.path());
        }
    }
    stale
}

/// The folder each scene's views go in: its file's stem (`default` for the built-in scene),
/// refused where two scenes would share one.
fn scene_stems(scenes: &[Option<PathBuf>]) -> Result<Vec<String>> {
    let mut stems: Vec<String> = Vec::new();
    for (k, scene) in scenes.iter().enumerate() {
        let stem = match scene {
            None => "default".to_owned(),
            Some(path) => path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .filter(|s| {
                    !s.is_empty() && !s.starts_with('.') && !s.eq_ignore_ascii_case(MANIFEST)
                })
                .ok_or_else(|| Error::Argument {
                    option: "scenes".into(),
                    message: format!("{}: no file name to name its folder by", path.display()),
                })?,
        };
        if let Some(j) = stems.iter().position(|s| s.eq_ignore_ascii_case(&stem)) {
            let name = |i: usize| {
                scenes[i]
                    .as_ref()
                    .map_or("<default>".into(), |p| p.display().to_string())
            };
            return Err(Error::Argument {
                option: "scenes".into(),
                message: format!(
                    "{} and {} would share the folder `{stem}`; give scenes of distinct file names",
                    name(j),
                    name(k)
                ),
            });
        }
        stems.push(stem);
    }
    Ok(stems)
}

/// Refuses a view name that is not one plain folder name inside the output folder (empty, `.`
/// or `..`, starting with `.`, with a path separator, a control character or a character
/// Windows forbids), and names that repeat, case aside (folders on macOS and Windows).
fn check_names(names: &[String], file: &Path) -> Result<()> {
    let fail = |k: usize, message: String| Error::SceneValue {
        file: file.to_owned(),
        field: format!("[{k}].name"),
        message,
    };
    for (k, name) in names.iter().enumerate() {
        let bad = name.is_empty()
            || name.starts_with('.')
            || name.len() > 200
            || name
                .chars()
                .any(|c| c.is_control() || "/\\<>:\"|?*".contains(c));
        if bad {
            return Err(fail(
                k,
                format!(
                    "`{name}` is not a folder name inside the output folder: 1 to 200 bytes, not starting with `.`, without / \\ < > : \" | ? * or control characters"
                ),
            ));
        }
        if let Some(j) = names[..k]
            .iter()
            .position(|n| n.to_lowercase() == name.to_lowercase())
        {
            return Err(fail(
                k,
                format!(
                    "`{name}` repeats the name of view {j}, `{}` (names are folders, case aside)",
                    names[j]
                ),
            ));
        }
    }
    Ok(())
}

/// A scene's estimated cost per pixel: the logarithm of its size on disk (the scene file and
/// the meshes it names), as a BVH's depth grows with its primitives.
fn scene_weight(path: Option<&Path>) -> f64 {
    let size = |p: &Path| std::fs::metadata(p).map_or(0, |m| m.len());
    let bytes = match path {
        // The built-in scene's mesh.
        None => raycast::DEFAULT_SCENE_FILES[1].len() as u64,
        Some(path) if raycast::is_mesh_file(path) => size(path),
        Some(path) => {
            let base = path.parent().unwrap_or(Path::new(""));
            let meshes = std::fs::read_to_string(path)
                .ok()
                .and_then(|t| serde_json::from_str::<serde_json::Value>(&t).ok())
                .and_then(|v| v.get("objects").and_then(|o| o.as_array()).cloned())
                .unwrap_or_default();
            let mesh_bytes: u64 = meshes
                .iter()
                .filter_map(|o| {
                    ["stl", "obj", "ply"]
                        .iter()
                        .find_map(|k| o.get(k)?.as_str())
                })
                .map(|m| size(&base.join(m)))
                .sum();
            size(path) + mesh_bytes
        }
    };
    (2.0 + bytes as f64 / 50.0).log2()
}

/// An exclusive lock on the file `path`, created if missing, held until the value is dropped,
/// which removes the file: a dataset's folder keeps no lock file once its runs end.
///
/// Removing a lock file others may wait on is safe by one rule: the file is removed only by
/// its lock's holder, before it lets go, and a process that got the lock then checks that
/// `path` is still the file it locked. A waiter woken on a removed file locked nothing that
/// counts, and tries again on the file now at `path` (or a new one).
#[derive(Debug)]
struct Lock {
    path: PathBuf,
    /// Released when closed, after `drop` has removed the file.
    _file: std::fs::File,
}

impl Lock {
    fn new(path: &Path) -> Result<Lock> {
        loop {
            let file = std::fs::OpenOptions::new()
                .create(true)
                .truncate(false)
                .write(true)
                .open(path)
                .map_err(|e| Error::Io {
                    path: path.to_path_buf(),
                    message: format!("cannot create the lock file: {e}"),
                })?;
            #[cfg(unix)]
            {
                use std::os::fd::AsRawFd;
                use std::os::unix::fs::MetadataExt;
                // SAFETY: flock on a file descriptor this function owns; released when it is
                // closed.
                if unsafe { libc::flock(file.as_raw_fd(), libc::LOCK_EX) } != 0 {
                    let e = std::io::Error::last_os_error();
                    return Err(Error::Io {
                        path: path.to_path_buf(),
                        message: format!("cannot lock: {e}"),
                    });
                }
                let identity = |m: std::fs::Metadata| (m.dev(), m.ino());
                let locked = file.metadata().map(identity).ok();
                if locked.is_none() || locked != std::fs::metadata(path).ok().map(identity) {
                    continue;
                }
            }
            return Ok(Lock {
                path: path.to_owned(),
                _file: file,
            });
        }
    }
}

impl Drop for Lock {
    fn drop(&mut self) {
        // Still held here: the file is closed, and the lock released, after this.
        let _ = std::fs::remove_file(&self.path);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Threads that each take the lock many times, read a count, pause and write it plus one:
    /// with every lock exclusive no increment is lost, though each release removes the file
    /// the others wait on; and no lock file is left.
    #[cfg(unix)]
    #[test]
    fn the_manifest_lock_excludes_and_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let (lock, count) = (dir.path().join(".lock"), dir.path().join("count"));
        std::fs::write(&count, "0").unwrap();
        let (threads, rounds) = (4, 50);
        std::thread::scope(|scope| {
            for _ in 0..threads {
                scope.spawn(|| {
                    for _ in 0..rounds {
                        let _held = Lock::new(&lock).unwrap();
                        let n: u32 = std::fs::read_to_string(&count).unwrap().parse().unwrap();
                        std::thread::sleep(Duration::from_micros(200));
                        std::fs::write(&count, (n + 1).to_string()).unwrap();
                    }
                });
            }
        });
        let n: u32 = std::fs::read_to_string(&count).unwrap().parse().unwrap();
        assert_eq!(n, threads * rounds);
        assert!(!lock.exists());
    }

    #[test]
    fn shards_parse_as_i_of_n() {
        assert_eq!("2/3".parse(), Ok(Shard { index: 2, count: 3 }));
        for bad in ["3/3", "0/0", "1", "a/2", "-1/2", "1/2/3", ""] {
            assert!(bad.parse::<Shard>().unwrap_err().contains("I/N"), "{bad}");
        }
    }

    /// Shards split the job into contiguous runs of about equal cost that together hold every
    /// pair once.
    #[test]
    fn shards_cover_the_job_once_in_runs_of_about_equal_cost() {
        let job = |costs: Vec<f64>| Pairs {
            scenes: vec![None; costs.len()],
            stems: Vec::new(),
            names: vec!["v".into()],
            cameras: Vec::new(),
            posed: false,
            costs,
        };
        let uneven: Vec<f64> = (0..97).map(|k| 1.0 + (k % 7) as f64 * 3.0).collect();
        for costs in [vec![1.0; 10], uneven, vec![5.0, 1.0]] {
            let total: f64 = costs.iter().sum();
            let largest = costs.iter().cloned().fold(0.0, f64::max);
            let job = job(costs.clone());
            for count in 1..=5 {
                let mut all = Vec::new();
                for index in 0..count {
                    let share = job.share(Some(Shard { index, count }));
                    assert!(share.windows(2).all(|w| w[1] == w[0] + 1), "contiguous");
                    let cost: f64 = share.iter().map(|&p| costs[p]).sum();
                    assert!(
                        (cost - total / count as f64).abs() <= largest,
                        "{cost} of {total}"
                    );
                    all.extend(share);
                }
                assert_eq!(all, (0..costs.len()).collect::<Vec<_>>());
            }
        }
    }

    #[test]
    fn view_names_are_single_folder_names_without_repeats() {
        let file = Path::new("views.json");
        let names = |list: &[&str]| list.iter().map(|s| s.to_string()).collect::<Vec<_>>();
        assert!(check_names(&names(&["front", "side 2", "é"]), file).is_ok());
        for (list, field, part) in [
            (&["a/b"][..], "[0].name", "not a folder name"),
            (&["..", "x"], "[0].name", "not a folder name"),
            (&["x", ".hidden"], "[1].name", "not a folder name"),
            (&["x", ""], "[1].name", "not a folder name"),
            (&["a\\b"], "[0].name", "not a folder name"),
            (
                &["Front", "back", "front"],
                "[2].name",
                "repeats the name of view 0",
            ),
        ] {
            let e = check_names(&names(list), file).unwrap_err().to_string();
            assert!(e.contains(field) && e.contains(part), "{list:?}: {e}");
        }
    }
}
