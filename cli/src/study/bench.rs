//! `raycast bench`: where the time of a frame goes, and how fast primary rays are cast, for
//! each run configuration (mode x acceleration) of one scene.
//!
//! Per configuration ([`measure`]): one warm-up frame (which compiles the GPU kernel), then
//! [`Options::runs`] timed frames, each with its stages timed apart and the median over the
//! runs reported ([`Row`]):
//! - GPU modes report the render's [`raycast::Stages`]: primitives rounded and laid out and the
//!   BVH built (`build_s`), the scene's buffers uploaded (`upload_s`), every tile dispatched
//!   and read back (`trace_s`, wall clock) and the kernel's GPU time from timestamp queries
//!   (`trace_gpu_s`); of the trace, the inputs written (`write_s`), the wait for the device
//!   (`wait_s`), the outputs converted (`convert_s`), the GPU's copies (`copy_s`) and the bytes
//!   read back (`readback_bytes`).
//! - CPU modes report the BVH build and the layout (`build_s`) apart from the render on them
//!   (`trace_s`); nothing is uploaded.
//!
//! With views ([`Options::views`]: `--orbit`, `--views`) a run renders the scene from every
//! view's camera, as a dataset does: through one [`Viewer`] per configuration, which builds the
//! BVH's shape once (in the warm-up run); each stage is summed over the views.
//!
//! With a shade hook (`--shader`, `--lit`) every frame also colours `color.png`; a hook that
//! casts rays reports them too, as secondary rays a second (`secondary_mrays_per_s`, over the
//! same time as the primary rays).
//!
//! Adaptive precision runs two passes whose stages do not add up to one frame, and is not
//! measured here (`raycast tradeoff` times it as a whole).

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde::Serialize;

use super::{Stream, Table, format_seconds, median, plural};
use raycast::MISS;
use raycast::Viewer;
use raycast::{Algorithm, Cpu, Error, Gpu, RenderOptions, Result, Search, ShadeHook, Tuning};
use raycast::{Camera, Object, Scene};
use raycast::{Device, Mode, Precision};
use raycast_datasets::Views;

/// `--runs` unless given.
pub const DEFAULT_RUNS: usize = 5;

/// `--mode` unless given: the default render.
pub const DEFAULT_MODE: Mode = Mode {
    device: Device::Gpu,
    precision: Precision::F32,
    algorithm: Algorithm::Robust,
};

/// The most rays `--rays` casts: their list and hits fit a few GiB.
pub const MAX_RAYS: usize = 1 << 26;

/// How a GPU kernel's rays walk the BVH (`--traversal`): the device's choice, a subgroup's rays
/// together sharing each node's fetch, or each ray alone ([`raycast::Tuning::packets`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Traversal {
    Auto,
    Packets,
    PerRay,
}

impl Traversal {
    /// `auto`, `packets` or `per-ray`, as `--traversal` spells it.
    pub fn name(self) -> &'static str {
        match self {
            Traversal::Auto => "auto",
            Traversal::Packets => "packets",
            Traversal::PerRay => "per-ray",
        }
    }

    /// [`raycast::Tuning::packets`] for this traversal.
    fn packets(self) -> Option<bool> {
        match self {
            Traversal::Auto => None,
            Traversal::Packets => Some(true),
            Traversal::PerRay => Some(false),
        }
    }
}

impl std::str::FromStr for Traversal {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Traversal, String> {
        [Traversal::Auto, Traversal::Packets, Traversal::PerRay]
            .into_iter()
            .find(|t| t.name() == s)
            .ok_or_else(|| format!("`{s}`: expected auto, packets or per-ray"))
    }
}

/// One configuration a row measures.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Config {
    pub mode: Mode,
    pub accel: Search,
    pub traversal: Traversal,
}

impl std::fmt::Display for Config {
    /// The mode and acceleration, and the traversal where one is asked for.
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {}", self.mode, accel_name(self.accel))?;
        match self.traversal {
            Traversal::Auto => Ok(()),
            t => write!(f, " {}", t.name()),
        }
    }
}

/// What to measure.
#[derive(Clone, Debug, PartialEq)]
pub struct Options {
    /// Timed runs per configuration, after one warm-up run (at least 1).
    pub runs: usize,
    pub modes: Vec<Mode>,
    pub accels: Vec<Search>,
    /// GPU modes' traversals (`auto` alone on the CPU, which has one).
    pub traversals: Vec<Traversal>,
    /// A shade hook every frame runs (GPU modes; on the CPU only the ray tracer's mirror).
    pub shade: Option<ShadeHook>,
    /// Cast this many incoherent rays ([`incoherent_rays`]) instead of the camera's.
    pub rays: Option<usize>,
    /// Render each run from every one of these views instead of the scene's camera
    /// (`--orbit`, `--views`: the cameras `raycast render` renders them from).
    pub views: Option<Views>,
}

impl Default for Options {
    /// [`DEFAULT_RUNS`] runs of [`DEFAULT_MODE`] with [`Search::Auto`].
    fn default() -> Options {
        Options {
            runs: DEFAULT_RUNS,
            modes: vec![DEFAULT_MODE],
            accels: vec![Search::Auto],
            traversals: vec![Traversal::Auto],
            shade: None,
            rays: None,
            views: None,
        }
    }
}

impl Options {
    /// Every (mode, accel, traversal), mode by mode, then accel by accel, in the order given.
    pub fn configurations(&self) -> Vec<Config> {
        let mut c = Vec::new();
        for &mode in &self.modes {
            for &accel in &self.accels {
                for &traversal in &self.traversals {
                    c.push(Config {
                        mode,
                        accel,
                        traversal,
                    });
                }
            }
        }
        c
    }

    /// At least one run and one configuration; no adaptive precision (module docs).
    pub fn check(&self) -> Result<()> {
        if self.runs == 0 {
            return Err(Error::Argument {
                option: "--runs".into(),
                message: "at least one timed run is needed".into(),
            });
        }
        if self.modes.is_empty() || self.accels.is_empty() || self.traversals.is_empty() {
            return Err(Error::Argument {
                option: "--mode/--accel/--traversal".into(),
                message: "nothing to measure".into(),
            });
        }
        let chosen = self.traversals != [Traversal::Auto];
        if let Some(m) = (self.modes.iter()).find(|m| chosen && m.device == Device::Cpu) {
            return Err(Error::Argument {
                option: "--traversal".into(),
                message: format!("{m}: the CPU reference has one traversal; leave out --traversal"),
            });
        }
        if let Some(m) = self
            .modes
            .iter()
            .find(|m| m.precision == Precision::Adaptive)
        {
            return Err(Error::Argument {
                option: "--mode".into(),
                message: format!(
                    "{m}: adaptive precision runs two passes whose stages are not one frame's; \
                     bench f32 or f64 (raycast tradeoff times adaptive as a whole)"
                ),
            });
        }
        for &mode in &self.modes {
            for &traversal in &self.traversals {
                let config = Config {
                    mode,
                    accel: Search::Auto,
                    traversal,
                };
                crate::render::check(mode, self.render_options(config))?;
            }
        }
        match self.rays {
            Some(n) if n == 0 || n > MAX_RAYS => Err(Error::Argument {
                option: "--rays".into(),
                message: format!("{n} rays: from 1 to {MAX_RAYS}"),
            }),
            Some(_) if self.shade.is_some() => Err(Error::Argument {
                option: "--rays".into(),
                message: "a ray list has no shade hook; leave out --shader and --lit".into(),
            }),
            Some(_) if self.accels != [Search::Auto] => Err(Error::Argument {
                option: "--rays".into(),
                message: "a ray list chooses its own acceleration; leave out --accel".into(),
            }),
            Some(_) if chosen => Err(Error::Argument {
                option: "--rays".into(),
                message: "a ray list chooses its own traversal; leave out --traversal".into(),
            }),
            Some(_) if self.views.is_some() => Err(Error::Argument {
                option: "--rays".into(),
                message: "a ray list has no camera; leave out --orbit and --views".into(),
            }),
            _ => Ok(()),
        }
    }

    /// What every frame of `config` renders with: every output, with the hook, timed, each
    /// lane casting its most rays as a kernel traced many times should.
    fn render_options(&self, config: Config) -> RenderOptions {
        RenderOptions {
            shade: self.shade.clone(),
            timed: true,
            tuning: Tuning {
                search: config.accel,
                packets: config.traversal.packets(),
                most_lane_rays: true,
                ..Tuning::default()
            },
            ..RenderOptions::default()
        }
    }

    /// Whether some configuration runs on the GPU.
    pub fn needs_gpu(&self) -> bool {
        self.modes.iter().any(|m| m.device == Device::Gpu)
    }
}

/// A scene as loaded for benchmarking: where it came from, how long loading took, and the
/// cameras a run renders it from.
#[derive(Clone, Debug)]
pub struct Loaded {
    pub path: PathBuf,
    pub scene: Scene,
    /// Wall seconds of [`Scene::load`] (parsing, mesh files, validation).
    pub load_s: f64,
    /// The views' cameras, all of one size, where views were asked for ([`Options::views`]).
    pub views: Option<Vec<Camera>>,
}

impl Loaded {
    /// The cameras a run renders from: the views', or the scene's own.
    pub fn cameras(&self) -> &[Camera] {
        self.views
            .as_deref()
            .unwrap_or(std::slice::from_ref(&self.scene.camera))
    }

    /// The size of every frame (the views share one).
    pub fn size(&self) -> [u32; 2] {
        self.cameras()[0].resolution
    }

    /// Primary rays of a run: one per pixel of every camera.
    pub fn rays(&self) -> u64 {
        self.cameras().iter().map(crate::pixels).sum()
    }
}

/// Loads `path` (timed), with `size` overriding its resolution, and finds the cameras of
/// `views`, as `raycast render` does (the scene's camera at `size` the orbit's start, every
/// view at `size`). Views of different sizes are refused: a row has one size.
pub fn load(path: &Path, size: Option<[u32; 2]>, views: Option<&Views>) -> Result<Loaded> {
    let start = Instant::now();
    let scene = raycast::load_viewed(Some(path), size, &Default::default(), Default::default())?;
    let load_s = start.elapsed().as_secs_f64();
    let views = views
        .map(|views| view_cameras(views, &scene, size))
        .transpose()?;
    Ok(Loaded {
        path: path.to_owned(),
        scene,
        load_s,
        views,
    })
}

/// The cameras of `views` for `scene`, each at `size` where given; refused unless all of one
/// size.
fn view_cameras(views: &Views, scene: &Scene, size: Option<[u32; 2]>) -> Result<Vec<Camera>> {
    let mut cameras: Vec<Camera> = (views.cameras(scene)?.into_iter())
        .map(|(_, camera)| camera)
        .collect();
    for camera in &mut cameras {
        camera.resolution = size.unwrap_or(camera.resolution);
    }
    let sizes = |c: &Camera| format!("{}x{}", c.resolution[0], c.resolution[1]);
    if let Some(other) = cameras
        .iter()
        .find(|c| c.resolution != cameras[0].resolution)
    {
        return Err(Error::Argument {
            option: "--views".into(),
            message: format!(
                "the views are of different sizes ({} and {}); a bench row has one: give --size",
                sizes(&cameras[0]),
                sizes(other)
            ),
        });
    }
    Ok(cameras)
}

/// A scene's spheres, planes and triangles (a soup's triangles counted one by one).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Counts {
    pub spheres: usize,
    pub planes: usize,
    pub triangles: usize,
}

impl Counts {
    pub fn of(scene: &Scene) -> Counts {
        let mut c = Counts::default();
        for object in &scene.objects {
            match object {
                Object::Sphere { .. } => c.spheres += 1,
                Object::Plane { .. } => c.planes += 1,
                Object::Triangle { .. } => c.triangles += 1,
                Object::Soup { triangles, .. } => c.triangles += triangles.len(),
            }
        }
        c
    }
}

/// One configuration's measurement: `raycast bench --json` prints it as one JSON line, keys in
/// this order. Times are in seconds, medians over the timed runs unless said otherwise.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Row {
    /// The scene file, as given.
    pub scene: String,
    /// `DEVICE:PRECISION:ALGORITHM`.
    pub mode: String,
    /// The acceleration asked for: `auto`, `bvh` or `brute-force`.
    pub accel: String,
    /// The traversal asked for: `auto`, `packets` or `per-ray` ([`Traversal`]).
    pub traversal: &'static str,
    /// Whether the render went through a BVH (what `auto` chose).
    pub bvh: bool,
    /// Image size `[width, height]` (of every view).
    pub size: [u32; 2],
    /// Frames a run renders: 1 from the scene's camera, one a view with `--orbit` or
    /// `--views`; `None` for a ray list.
    pub views: Option<usize>,
    /// Primary rays per run: one per pixel of every view.
    pub rays: u64,
    /// The shade hook, if any (its file).
    pub hook: Option<String>,
    /// Rays the hook cast per frame (the last run's), where it casts any.
    pub secondary_rays: Option<u64>,
    pub triangles: usize,
    pub spheres: usize,
    pub planes: usize,
    /// Timed runs (after one warm-up).
    pub runs: usize,
    /// [`Scene::load`] once, before every configuration (the same value on every row).
    pub load_s: f64,
    /// BVH build (when used) and primitive layout ([`raycast::Stages::build_s`]).
    pub build_s: f64,
    /// The warm-up frame's kernel compilation ([`raycast::Stages::compile_s`]); `None` on the
    /// CPU.
    pub compile_s: Option<f64>,
    /// The scene's buffers created and filled on the device; `None` on the CPU.
    pub upload_s: Option<f64>,
    /// Wall time of casting the frame: every tile dispatched and read back on the GPU, the
    /// render from built primitives on the CPU.
    pub trace_s: f64,
    /// The kernel's GPU time, summed over tiles (timestamp queries); `None` on the CPU or
    /// without `TIMESTAMP_QUERY`.
    pub trace_gpu_s: Option<f64>,
    /// Of `trace_s`: the inputs written for the device ([`raycast::Stages::write_s`]); `None`
    /// on the CPU and for ray lists (the API gives no stages of a ray list's cast).
    pub write_s: Option<f64>,
    /// Of `trace_s`: the host waiting for the device ([`raycast::Stages::wait_s`]); `None` as
    /// `write_s`.
    pub wait_s: Option<f64>,
    /// Of `trace_s`: the outputs converted into the layout they are delivered in
    /// ([`raycast::Stages::convert_s`]); `None` as `write_s`.
    pub convert_s: Option<f64>,
    /// The GPU's time copying the outputs to memory the host maps
    /// ([`raycast::Stages::copy_s`]); `None` as `write_s`, and where the render has no such
    /// time.
    pub copy_s: Option<f64>,
    /// Bytes of output read back from the device per run ([`raycast::Stages::readback_bytes`]);
    /// `None` as `write_s`.
    pub readback_bytes: Option<u64>,
    /// `trace_s / trace_gpu_s`: the whole trace against its kernel; `None` without a GPU time.
    pub whole_over_kernel: Option<f64>,
    /// Million rays per second: `rays / trace_gpu_s` where there is a GPU time, else
    /// `rays / trace_s` (`mrays_from` says which).
    pub mrays_per_s: f64,
    /// Million rays per second of wall time: `rays / trace_s`.
    pub mrays_per_s_wall: f64,
    /// Million secondary rays per second: `secondary_rays` over the time `mrays_per_s` divides
    /// by (the frame's, which casts both).
    pub secondary_mrays_per_s: Option<f64>,
    /// `"gpu_timestamps"` or `"wall"`: what `mrays_per_s` divides by.
    pub mrays_from: &'static str,
    /// Fraction of rays that hit something (the last run's frame).
    pub hit_fraction: f64,
    /// Peak resident set of the process in MiB (`VmHWM` of /proc/self/status, reset before the
    /// configuration where the kernel allows; on lavapipe this includes the "device" buffers);
    /// `None` where there is no /proc.
    pub peak_rss_mb: Option<f64>,
    /// The geometry's bytes per triangle as the render held it
    /// ([`raycast::Stages::bytes_per_triangle`]); `None` without triangles.
    pub bytes_per_triangle: Option<f64>,
    /// BVH nodes (64 bytes each), when a BVH is used.
    pub bvh_nodes: Option<usize>,
    /// Whether the GPU kernel's rays walked the BVH in packets (what `--traversal auto`
    /// chose, [`raycast::Stages::packets`]); `None` on the CPU, without a BVH and for ray lists.
    pub packets: Option<bool>,
    /// The GPU adapter's name; `None` on the CPU.
    pub adapter: Option<String>,
    /// The adapter's driver information (Mesa's version on lavapipe); `None` on the CPU.
    pub driver: Option<String>,
    /// The host CPU's model name (what lavapipe and the CPU reference run on), if known.
    pub cpu: Option<String>,
}

/// Per-run stage times, and what the frame's geometry held.
#[derive(Clone, Copy, Debug, Default)]
struct Run {
    build_s: f64,
    compile_s: f64,
    upload_s: Option<f64>,
    trace_s: f64,
    kernel_s: Option<f64>,
    /// The parts of the trace, and the bytes read back (GPU).
    readback: Option<Readback>,
    hits: usize,
    hook_rays: Option<u64>,
    bvh_nodes: Option<usize>,
    packets: Option<bool>,
    bytes_per_triangle: Option<f64>,
}

/// A GPU trace's parts ([`raycast::Stages`]).
#[derive(Clone, Copy, Debug, Default)]
struct Readback {
    write_s: f64,
    wait_s: f64,
    convert_s: f64,
    copy_s: Option<f64>,
    bytes: u64,
}

impl Run {
    /// The frames of one run together: times, hits and rays summed (a time where every frame
    /// has one), the geometry the last frame's.
    fn total(frames: &[Run]) -> Run {
        let sum = |f: fn(&Run) -> f64| frames.iter().map(f).sum::<f64>();
        let last = frames.last().copied().unwrap_or_default();
        let readback = (frames.iter().map(|r| r.readback))
            .collect::<Option<Vec<Readback>>>()
            .map(|parts| Readback {
                write_s: parts.iter().map(|p| p.write_s).sum(),
                wait_s: parts.iter().map(|p| p.wait_s).sum(),
                convert_s: parts.iter().map(|p| p.convert_s).sum(),
                copy_s: parts.iter().map(|p| p.copy_s).sum(),
                bytes: parts.iter().map(|p| p.bytes).sum(),
            });
        Run {
            build_s: sum(|r| r.build_s),
            compile_s: sum(|r| r.compile_s),
            upload_s: frames.iter().map(|r| r.upload_s).sum(),
            trace_s: sum(|r| r.trace_s),
            kernel_s: frames.iter().map(|r| r.kernel_s).sum(),
            readback,
            hits: frames.iter().map(|r| r.hits).sum(),
            hook_rays: frames.iter().map(|r| r.hook_rays).sum(),
            ..last
        }
    }
}

/// One frame of `config` (never adaptive) with `options`' hook, its stages timed apart
/// ([`raycast::Stages`]).
fn run_once(scene: &Scene, config: Config, gpu: Option<&Gpu>, options: &Options) -> Result<Run> {
    let mode = config.mode;
    let images = crate::render::render(scene, mode, gpu, options.render_options(config))?;
    let stages = images
        .stages()
        .expect("f32 and f64 renders report their stages");
    let on_gpu = mode.device == Device::Gpu;
    Ok(Run {
        build_s: stages.build_s,
        compile_s: stages.compile_s,
        upload_s: on_gpu.then_some(stages.upload_s),
        trace_s: stages.trace_s,
        kernel_s: stages.kernel_s,
        readback: on_gpu.then_some(Readback {
            write_s: stages.write_s,
            wait_s: stages.wait_s,
            convert_s: stages.convert_s,
            copy_s: stages.copy_s,
            bytes: stages.readback_bytes,
        }),
        hits: images.id().iter().filter(|&&id| id != MISS).count(),
        hook_rays: stages.hook_rays,
        bvh_nodes: stages.bvh_nodes,
        packets: stages.packets,
        bytes_per_triangle: stages.bytes_per_triangle,
    })
}

/// One run of `loaded` in `config`: a frame from the scene's camera, or with `viewer` one from
/// each view's camera (the frames' stages summed). `tick` is called after every frame.
fn run_frames(
    loaded: &Loaded,
    viewer: Option<&mut Viewer>,
    config: Config,
    gpu: Option<&Gpu>,
    options: &Options,
    tick: &mut dyn FnMut(),
) -> Result<Run> {
    let frame = |scene: &Scene| run_once(scene, config, gpu, options);
    let Some(viewer) = viewer else {
        let run = frame(&loaded.scene)?;
        tick();
        return Ok(run);
    };
    let mut frames = Vec::with_capacity(loaded.cameras().len());
    for camera in loaded.cameras() {
        frames.push(viewer.render(camera.clone(), frame)?);
        tick();
    }
    Ok(Run::total(&frames))
}

/// Measures `loaded` in `config`: one warm-up run, then `runs` timed ones (module docs). `tick`
/// is called after every frame.
pub fn measure(
    loaded: &Loaded,
    config: Config,
    runs: usize,
    gpu: Option<&Gpu>,
    options: &Options,
    tick: &mut dyn FnMut(),
) -> Result<Row> {
    let Config {
        mode,
        accel,
        traversal,
    } = config;
    let scene = &loaded.scene;
    reset_peak_rss();
    // Views share one viewer, as a dataset's views of a scene share its BVH's shape.
    let mut viewer = loaded.views.as_ref().map(|_| Viewer::from(scene.clone()));
    let warm_up = run_frames(loaded, viewer.as_mut(), config, gpu, options, tick)?;
    let mut timed = Vec::with_capacity(runs);
    for _ in 0..runs.max(1) {
        timed.push(run_frames(
            loaded,
            viewer.as_mut(),
            config,
            gpu,
            options,
            tick,
        )?);
    }
    let peak_rss_mb = crate::peak_rss_mib();
    let column = |f: &dyn Fn(&Run) -> f64| median(&timed.iter().map(f).collect::<Vec<_>>());
    // The median of a stage every run has, else `None`.
    let optional = |f: &dyn Fn(&Run) -> Option<f64>| {
        (timed.iter().map(f))
            .collect::<Option<Vec<f64>>>()
            .map(|times| median(&times))
    };
    let build_s = column(&|r| r.build_s);
    let trace_s = column(&|r| r.trace_s);
    let upload_s = optional(&|r| r.upload_s);
    let trace_gpu_s = optional(&|r| r.kernel_s);
    let part = |f: fn(&Readback) -> f64| optional(&|r| r.readback.as_ref().map(f));

    let rays = loaded.rays();
    let mrays = |s: f64| rays as f64 / s * 1e-6;
    let (frame_s, mrays_from) = match trace_gpu_s {
        Some(s) if s > 0.0 => (s, "gpu_timestamps"),
        _ => (trace_s, "wall"),
    };
    let mrays_per_s = mrays(frame_s);
    let counts = Counts::of(scene);
    let on_gpu = gpu
        .filter(|_| mode.device == Device::Gpu)
        .map(|g| g.info().adapter);
    let last = timed.last().expect("at least one run");
    let secondary_rays = last.hook_rays;
    Ok(Row {
        scene: loaded.path.display().to_string(),
        mode: mode.to_string(),
        accel: accel_name(accel).to_owned(),
        traversal: traversal.name(),
        bvh: last.bvh_nodes.is_some(),
        size: loaded.size(),
        views: Some(loaded.cameras().len()),
        rays,
        hook: (options.shade.as_ref()).map(|h| h.file.display().to_string()),
        secondary_rays,
        triangles: counts.triangles,
        spheres: counts.spheres,
        planes: counts.planes,
        runs: timed.len(),
        load_s: loaded.load_s,
        build_s,
        compile_s: warm_up.upload_s.map(|_| warm_up.compile_s),
        upload_s,
        trace_s,
        trace_gpu_s,
        write_s: part(|p| p.write_s),
        wait_s: part(|p| p.wait_s),
        convert_s: part(|p| p.convert_s),
        copy_s: optional(&|r| r.readback.and_then(|p| p.copy_s)),
        readback_bytes: last.readback.map(|p| p.bytes),
        whole_over_kernel: trace_gpu_s.filter(|&k| k > 0.0).map(|k| trace_s / k),
        mrays_per_s,
        mrays_per_s_wall: mrays(trace_s),
        secondary_mrays_per_s: secondary_rays.map(|n| n as f64 / frame_s * 1e-6),
        mrays_from,
        hit_fraction: last.hits as f64 / rays.max(1) as f64,
        peak_rss_mb,
        bytes_per_triangle: last.bytes_per_triangle,
        bvh_nodes: last.bvh_nodes,
        packets: last.packets,
        adapter: on_gpu.as_ref().map(|i| i.name.clone()),
        driver: on_gpu.map(|i| i.driver_info),
        cpu: cpu_model(),
    })
}

/// `n` incoherent rays about `scene`'s geometry: origins uniform in a cube about the centre of
/// its bounds, 4/3 of their largest extent across (the peers' torus: [-2, 2]^3), directions
/// uniform on the sphere (seed 1).
pub fn incoherent_rays(scene: &Scene, n: usize) -> Vec<raycast::Ray> {
    let (lo, hi) = raycast::bounds(&scene.objects).unwrap_or_default();
    let centre = (lo + hi) / 2.0;
    let half = (hi - lo).max_element() / 2.0 * 4.0 / 3.0;
    let mut rays = super::selftest::scenes::incoherent_rays(n, half.max(1e-30), 1);
    for ray in &mut rays {
        ray.origin = std::array::from_fn(|a| ray.origin[a] + centre[a]).into();
    }
    rays
}

/// Measures `n` incoherent rays cast at `loaded` in `mode` ([`raycast::Accel::intersect`]): one
/// warm-up cast (after the commit, which builds and uploads; it compiles), then `runs` timed
/// ones: wall time, and on a GPU with timestamp queries the kernel's ([`raycast::Accel::timed`]).
fn measure_rays(
    loaded: &Loaded,
    mode: Mode,
    n: usize,
    runs: usize,
    gpu: Option<&Gpu>,
    tick: &mut dyn FnMut(),
) -> Result<Row> {
    let rays = incoherent_rays(&loaded.scene, n);
    reset_peak_rss();
    let mut geometry = raycast::Geometry::from_scene(&loaded.scene);
    geometry.algorithm = mode.algorithm;
    let accel = match (mode.device, gpu) {
        (Device::Gpu, Some(gpu)) => gpu.commit(&geometry, mode.precision)?.timed(),
        (Device::Gpu, None) => return Err(Error::Device("a gpu: cast needs a GPU".into())),
        (Device::Cpu, _) => Cpu.commit(&geometry, mode.precision)?,
    };
    let warm_up = accel.intersect(&rays[..])?;
    tick();
    let mut times = Vec::with_capacity(runs);
    let mut kernel_times = Vec::with_capacity(runs);
    for _ in 0..runs.max(1) {
        let before = accel.kernel_seconds();
        let (cast, time) = crate::render::timed(|| accel.intersect(&rays[..]));
        cast?;
        times.push(time.as_secs_f64());
        if let (Some(b), Some(a)) = (before, accel.kernel_seconds()) {
            kernel_times.push(a - b);
        }
        tick();
    }
    let trace_s = median(&times);
    let trace_gpu_s = (kernel_times.len() == times.len()).then(|| median(&kernel_times));
    let (kernel_or_wall_s, mrays_from) = match trace_gpu_s {
        Some(k) if k > 0.0 => (k, "gpu_timestamps"),
        _ => (trace_s, "wall"),
    };
    let counts = Counts::of(&loaded.scene);
    let hits = warm_up.id().iter().filter(|&&id| id != MISS).count();
    let info = gpu.map(|g| g.info().adapter);
    Ok(Row {
        scene: loaded.path.display().to_string(),
        mode: mode.to_string(),
        accel: accel_name(Search::Auto).to_owned(),
        traversal: Traversal::Auto.name(),
        bvh: Search::Auto.uses_bvh(&loaded.scene),
        size: [n.min(u32::MAX as usize) as u32, 1],
        views: None,
        rays: n as u64,
        hook: None,
        secondary_rays: None,
        triangles: counts.triangles,
        spheres: counts.spheres,
        planes: counts.planes,
        runs: times.len(),
        load_s: loaded.load_s,
        build_s: 0.0,
        compile_s: None,
        upload_s: None,
        trace_s,
        trace_gpu_s,
        write_s: None,
        wait_s: None,
        convert_s: None,
        copy_s: None,
        readback_bytes: None,
        whole_over_kernel: None,
        mrays_per_s: n as f64 / kernel_or_wall_s * 1e-6,
        mrays_per_s_wall: n as f64 / trace_s * 1e-6,
        secondary_mrays_per_s: None,
        mrays_from,
        hit_fraction: hits as f64 / n as f64,
        peak_rss_mb: crate::peak_rss_mib(),
        bytes_per_triangle: None,
        bvh_nodes: None,
        packets: None,
        adapter: info.as_ref().map(|i| i.name.clone()),
        driver: info.map(|i| i.driver_info),
        cpu: cpu_model(),
    })
}

/// Measures every configuration of `options` in turn, calling `on_row` as each is done. With
/// `progress`, a progress bar over the frames is drawn on stderr when it is a terminal (and
/// hidden while `on_row` runs).
pub fn run(
    loaded: &Loaded,
    options: &Options,
    gpu: Option<&Gpu>,
    progress: bool,
    mut on_row: impl FnMut(&Row),
) -> Result<Vec<Row>> {
    options.check()?;
    check_size(loaded, options)?;
    if options.needs_gpu() && gpu.is_none() {
        return Err(Error::Device("a GPU mode needs a device".into()));
    }
    let configurations = options.configurations();
    let frames = configurations.len() * (1 + options.runs) * loaded.cameras().len();
    let bar = crate::progress::bar(
        progress,
        frames as u64,
        "bench {bar:24} {pos}/{len} frames: {wide_msg}",
    );
    let mut rows = Vec::with_capacity(configurations.len());
    for config in configurations {
        bar.set_message(config.to_string());
        let mut tick = || bar.inc(1);
        let row = match options.rays {
            Some(n) => measure_rays(loaded, config.mode, n, options.runs, gpu, &mut tick)?,
            None => measure(loaded, config, options.runs, gpu, options, &mut tick)?,
        };
        bar.suspend(|| on_row(&row));
        rows.push(row);
    }
    bar.finish_and_clear();
    Ok(rows)
}

/// A frame is rendered whole (bench times whole frames, not bands): at most
/// [`raycast_datasets::STREAM_PIXELS`] pixels.
fn check_size(loaded: &Loaded, options: &Options) -> Result<()> {
    let [w, h] = loaded.size();
    if options.rays.is_none() && u64::from(w) * u64::from(h) > raycast_datasets::STREAM_PIXELS {
        return Err(Error::Argument {
            option: "--size".into(),
            message: format!(
                "{w}x{h}: bench renders each frame whole, of at most {} pixels; give a smaller --size",
                raycast_datasets::STREAM_PIXELS
            ),
        });
    }
    Ok(())
}

/// `auto`, `bvh` or `brute-force`, as `--accel` spells it.
pub fn accel_name(accel: Search) -> &'static str {
    match accel {
        Search::Auto => "auto",
        Search::Bvh => "bvh",
        Search::BruteForce => "brute-force",
    }
}

/// Resets `VmHWM` to the current resident set (Linux: `5` written to /proc/self/clear_refs),
/// so each configuration's peak is its own; where that fails the peak is the process's.
fn reset_peak_rss() {
    let _ = std::fs::write("/proc/self/clear_refs", "5");
}

/// The CPU's model name from /proc/cpuinfo.
fn cpu_model() -> Option<String> {
    let info = std::fs::read_to_string("/proc/cpuinfo").ok()?;
    info.lines()
        .find(|l| l.starts_with("model name"))
        .and_then(|l| l.split_once(':'))
        .map(|(_, name)| name.trim().to_owned())
}

/// The lines printed above the table: the adapter and its driver (or the CPU), the scene and
/// what was measured.
pub fn header(loaded: &Loaded, options: &Options, gpu: Option<&Gpu>) -> Vec<String> {
    let mut lines = Vec::new();
    if let Some(g) = gpu {
        let info = g.info().adapter;
        lines.push(format!(
            "adapter: {}, driver: {}",
            info.name, info.driver_info
        ));
    }
    let threads = rayon::current_num_threads();
    lines.push(format!(
        "cpu: {}, {threads} threads",
        cpu_model().unwrap_or_else(|| "unknown".into())
    ));
    let c = Counts::of(&loaded.scene);
    let [nx, ny] = loaded.size();
    lines.push(format!(
        "scene: {} ({} triangles, {} spheres, {} planes), loaded in {} s",
        loaded.path.display(),
        c.triangles,
        c.spheres,
        c.planes,
        format_seconds(loaded.load_s)
    ));
    let views = match &loaded.views {
        Some(cameras) => format!("{} of ", plural(cameras.len(), "view")),
        None => String::new(),
    };
    lines.push(format!(
        "{views}{nx}x{ny} = {} rays a run, median of {} after 1 warm-up; Mrays/s from GPU \
         timestamps where there are some, else wall",
        loaded.rays(),
        plural(options.runs, "run")
    ));
    if let Some(hook) = &options.shade {
        lines.push(format!(
            "shade hook: {}{}",
            hook.file.display(),
            match hook.traces {
                true => ", which casts rays: secondary Mrays/s over the same frame time",
                false => "",
            }
        ));
    }
    lines
}

/// Column headings of [`to_table`].
pub const COLUMNS: [&str; 14] = [
    "mode",
    "accel",
    "build s",
    "upload s",
    "trace s",
    "trace GPU s",
    "whole/kernel",
    "Mrays/s",
    "Mrays/s wall",
    "secondary rays",
    "secondary Mrays/s",
    "hit %",
    "peak RSS MiB",
    "B/triangle",
];

/// The rows as an aligned markdown table, ending in a line break.
pub fn to_table(rows: &[Row]) -> String {
    let seconds = |s: Option<f64>| s.map_or("-".to_owned(), format_seconds);
    let mut table = Table::text_then_numbers(&COLUMNS, 2);
    for r in rows {
        let accel = if r.accel == "auto" {
            format!("auto ({})", if r.bvh { "bvh" } else { "brute-force" })
        } else {
            r.accel.clone()
        };
        let accel = match r.traversal {
            "auto" => accel,
            traversal => format!("{accel} {traversal}"),
        };
        table.row([
            r.mode.clone(),
            accel,
            format_seconds(r.build_s),
            seconds(r.upload_s),
            format_seconds(r.trace_s),
            seconds(r.trace_gpu_s),
            (r.whole_over_kernel).map_or("-".into(), |x| format!("{x:.2}")),
            format!("{:.2}", r.mrays_per_s),
            format!("{:.2}", r.mrays_per_s_wall),
            r.secondary_rays.map_or("-".into(), |n| n.to_string()),
            (r.secondary_mrays_per_s).map_or("-".into(), |m| format!("{m:.2}")),
            format!("{:.1}", 100.0 * r.hit_fraction),
            r.peak_rss_mb.map_or("-".into(), |m| format!("{m:.0}")),
            r.bytes_per_triangle
                .map_or("-".into(), |b| format!("{b:.1}")),
        ]);
    }
    table.aligned()
}

/// A line per row with the parts of its trace (GPU camera rows): the inputs written, the wait
/// for the device, the conversion, the GPU's copies and the bytes read back.
pub fn stage_lines(rows: &[Row]) -> Vec<String> {
    let seconds = |s: Option<f64>| s.map_or("-".to_owned(), format_seconds);
    (rows.iter())
        .filter_map(|r| {
            let bytes = r.readback_bytes?;
            let copy = (r.copy_s).map_or("not measured".into(), |s| {
                format!("{} s", format_seconds(s))
            });
            Some(format!(
                "{} {}{}: trace {} s, of it write {} s, wait {} s, convert {} s; GPU copy {copy}; \
                 {} MB read back",
                r.mode,
                r.accel,
                match r.traversal {
                    "auto" => String::new(),
                    traversal => format!(" {traversal}"),
                },
                format_seconds(r.trace_s),
                seconds(r.write_s),
                seconds(r.wait_s),
                seconds(r.convert_s),
                // Three significant digits, as the seconds.
                format_seconds(bytes as f64 * 1e-6)
            ))
        })
        .collect()
}

/// `raycast bench`: loads the scene (timed, and validated before the GPU is opened), measures
/// every configuration of `options` with a progress bar, and prints the [`header`] and the
/// table, or with `json` one JSON object per configuration and nothing else, on stdout.
pub fn command(
    scene: &Path,
    size: Option<[u32; 2]>,
    options: Options,
    json: bool,
    mut say: impl FnMut(Stream, &str),
) -> Result<()> {
    options.check()?;
    let loaded = load(scene, size, options.views.as_ref())?;
    check_size(&loaded, &options)?;
    let gpu = crate::render::gpu_for(options.modes.iter().map(|m| m.device))?;
    if !json {
        for line in header(&loaded, &options, gpu.as_ref()) {
            say(Stream::Stdout, &line);
        }
    }
    let rows = run(&loaded, &options, gpu.as_ref(), true, |row| {
        if json {
            say(
                Stream::Stdout,
                &serde_json::to_string(row).expect("a row serialises"),
            );
        }
    })?;
    if !json {
        say(Stream::Stdout, to_table(&rows).trim_end());
        for line in stage_lines(&rows) {
            say(Stream::Stdout, &line);
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn configurations_are_mode_major() {
        let options = Options {
            runs: 1,
            modes: vec!["gpu:f32".parse().unwrap(), "cpu:f32".parse().unwrap()],
            accels: vec![Search::Bvh, Search::BruteForce],
            ..Options::default()
        };
        let c: Vec<String> = options
            .configurations()
            .iter()
            .map(Config::to_string)
            .collect();
        assert_eq!(
            c,
            [
                "gpu:f32:robust bvh",
                "gpu:f32:robust brute-force",
                "cpu:f32:robust bvh",
                "cpu:f32:robust brute-force"
            ]
        );
    }

    #[test]
    fn traversals_follow_their_acceleration_and_only_gpu_camera_casts_choose_one() {
        let traversals = vec![Traversal::Packets, Traversal::PerRay];
        let options = Options {
            runs: 1,
            traversals: traversals.clone(),
            ..Options::default()
        };
        let c: Vec<String> = (options.configurations().iter())
            .map(Config::to_string)
            .collect();
        assert_eq!(
            c,
            ["gpu:f32:robust auto packets", "gpu:f32:robust auto per-ray"]
        );
        let cpu = Options {
            modes: vec!["cpu:f32".parse().unwrap()],
            ..options.clone()
        };
        let e = cpu.check().unwrap_err().to_string();
        assert!(e.starts_with("--traversal") && e.contains("cpu:f32"), "{e}");
        let listed = Options {
            rays: Some(10),
            ..options
        };
        let e = listed.check().unwrap_err().to_string();
        assert!(e.starts_with("--rays") && e.contains("traversal"), "{e}");
        let names: Vec<Traversal> = ["auto", "packets", "per-ray"]
            .iter()
            .map(|n| n.parse().unwrap())
            .collect();
        assert_eq!(names, [vec![Traversal::Auto], traversals].concat());
        assert!("wide".parse::<Traversal>().unwrap_err().contains("`wide`"));
    }

    #[test]
    fn checks_reject_zero_runs_and_adaptive() {
        let zero = Options {
            runs: 0,
            ..Options::default()
        };
        assert!(zero.check().unwrap_err().to_string().starts_with("--runs"));
        let adaptive = Options {
            modes: vec!["gpu:adaptive".parse().unwrap()],
            ..Options::default()
        };
        assert!(adaptive.check().is_err());
        assert!(Options::default().check().is_ok());
        for rays in [0, MAX_RAYS + 1] {
            let list = Options {
                rays: Some(rays),
                ..Options::default()
            };
            assert!(list.check().unwrap_err().to_string().starts_with("--rays"));
        }
        let orbit = Views::Orbit(raycast::Orbit {
            views: 2,
            ..raycast::Orbit::default()
        });
        let list_of_views = Options {
            rays: Some(10),
            views: Some(orbit),
            ..Options::default()
        };
        let refused = list_of_views.check().unwrap_err().to_string();
        assert!(
            refused.starts_with("--rays: a ray list has no camera"),
            "{refused}"
        );
        // The CPU runs the ray tracer's mirror and no other hook.
        let source = "fn shade(hit: ShadeHit) -> vec4<f32> { return vec4<f32>(1.0); }\n";
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("other.wgsl"), source).unwrap();
        let other = raycast::ShadeHook::load(&dir.path().join("other.wgsl")).unwrap();
        let cpu = |shade: ShadeHook| Options {
            modes: vec!["cpu:f32".parse().unwrap()],
            shade: Some(shade),
            ..Options::default()
        };
        assert!(
            cpu(other)
                .check()
                .unwrap_err()
                .spelled(&crate::flag)
                .to_string()
                .starts_with("--shader")
        );
        assert!(cpu(raycast::ShadeHook::raytrace().unwrap()).check().is_ok());
    }

    /// A run's frames add up: times and counts summed, a time only where every frame has it.
    #[test]
    fn a_runs_frames_add_up() {
        let frame = |k: u32, kernel_s: Option<f64>| Run {
            build_s: f64::from(k),
            upload_s: Some(0.5),
            trace_s: 2.0 * f64::from(k),
            kernel_s,
            readback: Some(Readback {
                write_s: 0.25,
                wait_s: 1.0,
                convert_s: 0.5,
                copy_s: kernel_s,
                bytes: 100 * u64::from(k),
            }),
            hits: k as usize,
            bvh_nodes: Some(k as usize),
            ..Run::default()
        };
        let run = Run::total(&[frame(1, Some(1.0)), frame(2, Some(3.0))]);
        assert_eq!(
            (run.build_s, run.trace_s, run.upload_s),
            (3.0, 6.0, Some(1.0))
        );
        assert_eq!(
            (run.kernel_s, run.hits, run.bvh_nodes),
            (Some(4.0), 3, Some(2))
        );
        let readback = run.readback.unwrap();
        let parts = (readback.write_s, readback.wait_s, readback.convert_s);
        assert_eq!(parts, (0.5, 2.0, 1.0));
        assert_eq!((readback.copy_s, readback.bytes), (Some(4.0), 300));
        let untimed = Run::total(&[frame(1, Some(1.0)), frame(2, None)]);
        assert_eq!(untimed.kernel_s, None);
        assert_eq!(untimed.readback.unwrap().copy_s, None);
        let cpu = Run {
            readback: None,
            ..frame(3, None)
        };
        assert!(Run::total(&[frame(1, None), cpu]).readback.is_none());
    }

    #[test]
    fn peak_rss_reads_proc() {
        if Path::new("/proc/self/status").exists() {
            assert!(crate::peak_rss_mib().is_some_and(|m| m > 0.0));
        }
    }
}
