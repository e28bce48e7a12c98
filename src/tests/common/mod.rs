//! Shared test helpers: two GPU devices per test binary, each test on one (the library's, src/tests/, and the command line's, cli/tests/suite/), course data paths, picture diffs.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::sync::{Mutex, OnceLock};

use raycast::Images;
use raycast::Scene;
use raycast::{Algorithm, Gpu, Mode};

/// The device this test runs its GPU work on (lavapipe in CI). Without an adapter the tests fail
/// loudly: they are never skipped.
pub(crate) fn gpu() -> &'static Gpu {
    // Two devices, each test's thread given the one fewer running tests hold: lavapipe
    // compiles a kernel on its device's queue thread, so tests side by side compile theirs in
    // parallel only on different devices. A thread gives its device back when it ends (libtest
    // runs each test on a thread of its own).
    static GPUS: OnceLock<[Gpu; 2]> = OnceLock::new();
    static HOLDERS: Mutex<[usize; 2]> = Mutex::new([0; 2]);
    struct Lease(usize);
    impl Drop for Lease {
        fn drop(&mut self) {
            HOLDERS.lock().unwrap_or_else(|e| e.into_inner())[self.0] -= 1;
        }
    }
    thread_local! {
        static MINE: Lease = {
            let mut holders = HOLDERS.lock().unwrap_or_else(|e| e.into_inner());
            let index = usize::from(holders[1] < holders[0]);
            holders[index] += 1;
            Lease(index)
        };
    }
    let gpus = GPUS.get_or_init(|| {
        if std::env::var_os("NODEVICE_SELECT").is_none() {
            // SAFETY: tests that touch the environment only do it here, under the OnceLock,
            // before the Vulkan loader starts; Mesa reads it once at instance creation.
            unsafe { std::env::set_var("NODEVICE_SELECT", "1") };
        }
        let new = || {
            Gpu::new().unwrap_or_else(|e| {
                panic!("GPU tests need a Vulkan adapter (lavapipe is enough): {e}")
            })
        };
        [new(), new()]
    });
    &gpus[MINE.with(|m| m.0)]
}

/// The names of the entries of `dir`, sorted.
pub(crate) fn file_names(dir: &Path) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .unwrap_or_else(|e| panic!("{}: {e}", dir.display()))
        .map(|e| e.unwrap().file_name().into_string().unwrap())
        .collect();
    names.sort();
    names
}

/// The repository's root: the library's folder, above the command line's (cli/) and the
/// datasets' (datasets/).
pub(crate) fn repo_root() -> &'static Path {
    let manifest = Path::new(env!("CARGO_MANIFEST_DIR"));
    match env!("CARGO_PKG_NAME") {
        "raycast-cli" | "raycast-datasets" => manifest
            .parent()
            .expect("cli/ and datasets/ are in the repository"),
        _ => manifest,
    }
}

pub(crate) fn repo_path(relative: &str) -> PathBuf {
    repo_root().join(relative)
}

/// The `raycast` command, run in the repository's root (the command line's tests only).
#[allow(dead_code)]
pub(crate) fn raycast() -> std::process::Command {
    let Some(exe) = option_env!("CARGO_BIN_EXE_raycast") else {
        panic!("only the command line's tests (cli/tests) run the command");
    };
    let mut command = std::process::Command::new(exe);
    command.current_dir(repo_root());
    command
}

// The self-test's seeded scenes and rays, shared with these tests.
#[allow(dead_code)]
#[path = "../../../cli/src/study/selftest/scenes.rs"]
mod selftest_scenes;
#[allow(unused_imports)]
pub(crate) use selftest_scenes::COURSE_SCENES;

/// `scene` rendered through the API on `gpu` in `precision` with `algorithm`, each lane casting
/// its most rays (as the kernel variants the tests below the API build).
pub(crate) fn api_render(
    gpu: &Gpu,
    scene: &Scene,
    precision: raycast::Precision,
    algorithm: Algorithm,
) -> raycast::AnyImages {
    let options = raycast::RenderOptions {
        precision: Some(precision),
        algorithm,
        ..kernel_options()
    };
    gpu.render(scene, &options)
        .unwrap_or_else(|e| panic!("{precision:?} {algorithm:?}: {e}"))
}

/// `scene` rendered in `mode` (the GPU's on [`gpu`]) with `options`' other settings, through
/// the API.
pub(crate) fn render_in(
    scene: &Scene,
    mode: Mode,
    options: raycast::RenderOptions,
) -> raycast::Result<raycast::AnyImages> {
    let options = raycast::RenderOptions {
        precision: Some(mode.precision),
        algorithm: mode.algorithm,
        ..options
    };
    match mode.device {
        raycast::Device::Gpu => gpu().render(scene, &options),
        raycast::Device::Cpu => raycast::Cpu.render(scene, &options),
    }
}

/// Options as a kernel variant made by hand has them: each lane casting its most rays.
pub(crate) fn kernel_options() -> raycast::RenderOptions {
    raycast::RenderOptions {
        tuning: raycast::Tuning {
            most_lane_rays: true,
            ..raycast::Tuning::default()
        },
        ..raycast::RenderOptions::default()
    }
}

/// The precisions a GPU kernel renders in, as image types.
pub(crate) trait Kernel: Copy + Into<f64> + std::fmt::Debug + PartialEq + 'static {
    const PRECISION: raycast::Precision;
    fn of(images: raycast::AnyImages) -> Option<Images<Self>>;
}

impl Kernel for f32 {
    const PRECISION: raycast::Precision = raycast::Precision::F32;
    fn of(images: raycast::AnyImages) -> Option<Images<f32>> {
        match images {
            raycast::AnyImages::F32(i) => Some(i),
            raycast::AnyImages::F64(_) => None,
        }
    }
}

impl Kernel for f64 {
    const PRECISION: raycast::Precision = raycast::Precision::F64;
    fn of(images: raycast::AnyImages) -> Option<Images<f64>> {
        match images {
            raycast::AnyImages::F64(i) => Some(i),
            raycast::AnyImages::F32(_) => None,
        }
    }
}

/// `scene` rendered on `gpu` by the kernel a render picks for it in precision `R`.
pub(crate) fn gpu_scene<R: Kernel>(
    gpu: &Gpu,
    scene: &Scene,
    algorithm: Algorithm,
) -> raycast::Result<Images<R>> {
    gpu_outputs(gpu, scene, algorithm, raycast::Outputs::default(), None)
}

/// `scene` rendered by the CPU reference in precision `R` with `algorithm`, through the API.
pub(crate) fn cpu_render<R: Kernel>(scene: &Scene, algorithm: Algorithm) -> Images<R> {
    let options = raycast::RenderOptions {
        precision: Some(R::PRECISION),
        algorithm,
        ..raycast::RenderOptions::default()
    };
    let images = raycast::Cpu.render(scene, &options).unwrap();
    R::of(images).expect("images in the precision asked for")
}

/// [`gpu_scene`] computing only `outputs`, with the shade hook `shade` for the colour.
pub(crate) fn gpu_outputs<R: Kernel>(
    gpu: &Gpu,
    scene: &Scene,
    algorithm: Algorithm,
    outputs: raycast::Outputs,
    shade: Option<&raycast::ShadeHook>,
) -> raycast::Result<Images<R>> {
    let options = raycast::RenderOptions {
        precision: Some(R::PRECISION),
        algorithm,
        outputs,
        shade: shade.cloned(),
        ..kernel_options()
    };
    Ok(R::of(gpu.render(scene, &options)?).expect("images in the precision asked for"))
}

/// An orthographic camera at z = 5 looking down -z, image plane `w x h` scene units, `nx x ny`.
pub(crate) fn ortho_json(w: f64, h: f64, nx: u32, ny: u32, objects: &str) -> String {
    format!(
        r#"{{"camera": {{"type": "orthographic", "eye": [0, 0, 5], "look": [0, 0, -1],
            "up": [0, 1, 0], "focal_length": 1, "width": {w}, "height": {h},
            "resolution": [{nx}, {ny}]}}, "objects": [{objects}]}}"#
    )
}

/// A sphere of radius 1.3 at the origin, as a scene object.
pub(crate) const SPHERE: &str = r#"{"type": "sphere", "center": [0, 0, 0], "radius": 1.3}"#;

pub(crate) fn course_scene(name: &str) -> raycast::Scene {
    raycast::Scene::load(&repo_path(&format!("scenes/course/{name}.json"))).unwrap()
}

/// A course reference render as raw 8-bit channels (RGB or grey, as stored).
pub(crate) fn course_render(name: &str, kind: &str) -> Vec<u8> {
    let path = repo_path(&format!("tests/data/course/{name}.{kind}.png"));
    let img = image::open(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    match kind {
        "depth" => img.into_luma8().into_raw(),
        _ => img.into_rgb8().into_raw(),
    }
}

/// How two 8-bit pictures of `channels` channels differ, per pixel.
#[derive(Debug, Default)]
pub(crate) struct PixelDiff {
    pub pixels: usize,
    /// Pixels with any channel different.
    pub differing: usize,
    /// Largest channel difference.
    pub max_level: u8,
}

pub(crate) fn diff(a: &[u8], b: &[u8], channels: usize, mask: Option<&[bool]>) -> PixelDiff {
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
pub(crate) fn save_failure(
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

#[allow(unused_imports)]
pub(crate) use selftest_scenes::{
    Rng, incoherent_rays, moved_along, pinhole_rays, random_scene, sphere_mesh,
};

/// Seeds of [`list_scene`] whose two scenes take the same kernels: one with a plane behind
/// everything, one whose rays miss (with a plane behind the camera), and trees that take the
/// same traversal stack. lavapipe compiles each kernel at its first dispatch, one at a time.
pub(crate) const LIST_SEEDS: [u64; 2] = [2, 5];

/// `random_scene(seed, [4, 4])` for ray lists, with a plane behind its camera where it has none
/// (its rays still miss there; the kernels are those of a scene with planes), and whether it
/// had one (a background).
pub(crate) fn list_scene(seed: u64) -> (raycast::Scene, bool) {
    use raycast::Object;
    let mut scene = random_scene(seed, [4, 4]);
    let background = (scene.objects.iter()).any(|o| matches!(o, Object::Plane { .. }));
    if !background {
        scene.objects.push(Object::Plane {
            point: scene.camera.eye + glam::DVec3::Z,
            normal: glam::DVec3::Z,
        });
    }
    (scene, background)
}

/// The scene files (`*.json`) of the repository folder `dir`, sorted by name.
pub(crate) fn scene_files(dir: &str) -> Vec<PathBuf> {
    let mut paths: Vec<PathBuf> = std::fs::read_dir(repo_path(dir))
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.extension().is_some_and(|e| e == "json"))
        .collect();
    paths.sort();
    paths
}

/// Every scene of `scenes/extremes/`, sorted by file name: (path, scene).
pub(crate) fn extreme_scenes() -> Vec<(PathBuf, raycast::Scene)> {
    scene_files("scenes/extremes")
        .into_iter()
        .map(|p| {
            let scene = raycast::Scene::load(&p).unwrap();
            (p, scene)
        })
        .collect()
}

/// The file stem of `path`, as a scene name.
pub(crate) fn scene_name(path: &Path) -> String {
    path.file_stem().unwrap().to_string_lossy().into_owned()
}

/// Waits until `ready` holds while `child` runs (polling every 5 ms, at most a minute); fails
/// if the child ends first.
pub(crate) fn wait_until(child: &mut std::process::Child, what: &str, ready: impl Fn() -> bool) {
    let start = std::time::Instant::now();
    while !ready() {
        assert!(
            child.try_wait().unwrap().is_none(),
            "the render ended before {what}"
        );
        assert!(
            start.elapsed() < std::time::Duration::from_secs(60),
            "no {what} in a minute"
        );
        std::thread::sleep(std::time::Duration::from_millis(5));
    }
}

/// Asserts that `dir` holds no file (or does not exist): a failed render wrote nothing.
pub(crate) fn assert_no_files(dir: &Path) {
    if dir.exists() {
        assert_eq!(file_names(dir), Vec::<String>::new(), "{}", dir.display());
    }
}

/// `raycast render` of the course bunny, arguments to follow.
pub(crate) fn render_bunny() -> std::process::Command {
    let mut command = raycast();
    command
        .arg("render")
        .arg(repo_path("scenes/course/bunny.json"));
    command
}

/// How many temporary files (`.NAME.tmp-PID`) `dir` holds (0 if it does not exist).
pub(crate) fn temporary_files(dir: &Path) -> usize {
    match dir.exists() {
        true => file_names(dir)
            .iter()
            .filter(|n| n.contains(".tmp-"))
            .count(),
        false => 0,
    }
}

/// The shared adapter opened again without optional features: no `SHADER_F64`.
pub(crate) fn gpu_without_f64() -> Gpu {
    let shared = gpu();
    let (device, queue) =
        pollster::block_on(shared.adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("no f64"),
            required_features: wgpu::Features::empty(),
            required_limits: shared.adapter.limits(),
            ..Default::default()
        }))
        .unwrap();
    Gpu::from_parts(shared.adapter.clone(), device, queue)
}

/// The default adapter's device, opened with the limits `limits` makes of the adapter's.
pub(crate) fn open_device(limits: impl Fn(wgpu::Limits) -> wgpu::Limits) -> Gpu {
    pollster::block_on(async {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor::new_without_display_handle());
        let adapter = instance
            .request_adapter(&wgpu::RequestAdapterOptions::default())
            .await
            .unwrap();
        let descriptor = wgpu::DeviceDescriptor {
            required_limits: limits(adapter.limits()),
            ..Default::default()
        };
        let (device, queue) = adapter.request_device(&descriptor).await.unwrap();
        Gpu::from_parts(adapter, device, queue)
    })
}

/// `a` and `b` hold the same bits: NaNs (robust f32 normals on the `range-*` scenes) included,
/// which `==` would call different.
pub(crate) fn assert_same_bits<T: Copy + Into<f64>>(a: &Images<T>, b: &Images<T>, what: &str) {
    let bits = |i: &Images<T>| {
        let distance: Vec<u64> = i.distance.iter().map(|&d| d.into().to_bits()).collect();
        let normal: Vec<u64> = i
            .normal
            .iter()
            .flatten()
            .map(|&c| c.into().to_bits())
            .collect();
        (i.width, i.height, i.id.clone(), distance, normal)
    };
    assert!(bits(a) == bits(b), "{what}");
}

/// The hits of an f32 (or adaptive) cast.
pub(crate) fn f32_hits(h: raycast::AnyHits) -> raycast::Hits<f32> {
    match h {
        raycast::AnyHits::F32(h) => h,
        raycast::AnyHits::F64(_) => panic!("an f32 cast returned f64 hits"),
    }
}

/// A triangle soup as vertices and indices (each corner its own vertex).
pub(crate) fn indexed(triangles: &[raycast::Triangle]) -> (Vec<[f64; 3]>, Vec<[u32; 3]>) {
    let vertices = triangles.iter().flatten().map(|v| v.to_array()).collect();
    let indices = (0..triangles.len() as u32)
        .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
        .collect();
    (vertices, indices)
}

/// Points written as arrays, as the API's vectors (the same bytes).
pub(crate) fn dvec3s(points: &[[f64; 3]]) -> &[glam::DVec3] {
    bytemuck::cast_slice(points)
}

/// A geometry of one mesh, the triangle soup `triangles`.
pub(crate) fn soup_geometry(triangles: &[raycast::Triangle]) -> raycast::Geometry {
    let (vertices, indices) = indexed(triangles);
    let mut geometry = raycast::Geometry::new();
    geometry.add_mesh(dvec3s(&vertices), &indices).unwrap();
    geometry
}

/// `geometry` committed in `mode`, whose algorithm set replaces the geometry's: on `gpu`, which
/// a GPU mode's test passes.
pub(crate) fn commit<'g>(
    gpu: Option<&'g Gpu>,
    geometry: &raycast::Geometry,
    mode: Mode,
) -> raycast::Result<raycast::Accel<'g>> {
    let mut geometry = geometry.clone();
    geometry.algorithm = mode.algorithm;
    match mode.device {
        raycast::Device::Gpu => {
            (gpu.expect("a GPU mode's test passes a GPU")).commit(&geometry, mode.precision)
        }
        raycast::Device::Cpu => raycast::Cpu.commit(&geometry, mode.precision),
    }
}

/// A geometry cast at in whichever mode a test names, committed afresh for each call
/// ([`commit`]).
#[derive(Default)]
pub(crate) struct Target {
    pub geometry: raycast::Geometry,
}

impl Target {
    pub(crate) fn new() -> Target {
        Target::default()
    }

    pub(crate) fn from_scene(scene: Scene) -> Target {
        Target {
            geometry: raycast::Geometry::from_scene(&scene),
        }
    }

    fn commit<'g>(&self, gpu: Option<&'g Gpu>, mode: Mode) -> raycast::Result<raycast::Accel<'g>> {
        commit(gpu, &self.geometry, mode)
    }

    pub(crate) fn cast<'a>(
        &self,
        gpu: Option<&Gpu>,
        mode: Mode,
        rays: impl Into<raycast::RayList<'a>>,
    ) -> raycast::Result<raycast::AnyHits> {
        self.commit(gpu, mode)?.intersect(rays)
    }

    pub(crate) fn occluded<'a>(
        &self,
        gpu: Option<&Gpu>,
        mode: Mode,
        rays: impl Into<raycast::RayList<'a>>,
        t_near: f64,
        t_far: f64,
    ) -> raycast::Result<Vec<bool>> {
        self.commit(gpu, mode)?.occluded(rays, t_near, t_far)
    }

    pub(crate) fn count<'a>(
        &self,
        gpu: Option<&Gpu>,
        mode: Mode,
        rays: impl Into<raycast::RayList<'a>>,
    ) -> raycast::Result<Vec<u32>> {
        self.commit(gpu, mode)?.count(rays)
    }
}

impl std::ops::Deref for Target {
    type Target = raycast::Geometry;
    fn deref(&self) -> &raycast::Geometry {
        &self.geometry
    }
}

impl std::ops::DerefMut for Target {
    fn deref_mut(&mut self) -> &mut raycast::Geometry {
        &mut self.geometry
    }
}

/// The unit cube [0, 1]^3: its 8 corners and 12 outward-facing triangles, each face split
/// along a diagonal.
pub(crate) fn unit_cube_mesh() -> (Vec<glam::DVec3>, Vec<[u32; 3]>) {
    let corners = (0..8)
        .map(|k| glam::DVec3::new((k & 1) as f64, ((k >> 1) & 1) as f64, ((k >> 2) & 1) as f64))
        .collect();
    let faces = [
        [0, 2, 3, 1],
        [4, 5, 7, 6],
        [0, 1, 5, 4],
        [2, 6, 7, 3],
        [0, 4, 6, 2],
        [1, 3, 7, 5],
    ];
    let triangles = (faces.iter())
        .flat_map(|[a, b, c, d]| [[*a, *b, *c], [*a, *c, *d]])
        .collect();
    (corners, triangles)
}
