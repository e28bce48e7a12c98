//! The packet traversal as GPUs with subgroups wider than 8 run it. llvmpipe's subgroups are 8
//! invocations, so every other test runs the `EIGHT_LANES` kernels (butterfly votes, several
//! rays a lane); NVIDIA's are 32, AMD's 32 or 64, Intel's up to 32, and their kernels vote by
//! `subgroupAny` and `subgroupAdd` and keep a copy of the packet's stack in each run of 8
//! lanes. With `LP_NATIVE_VECTOR_WIDTH=512` lavapipe's subgroups are 16 invocations, so this
//! test runs itself again in a child process with it set (Mesa reads it when it starts) and
//! checks there that those kernels give the CPU reference's answers: camera renders bit for bit
//! in f32, ids in f64 and adaptive precision, ray lists from one origin and from many, and a
//! hook that casts rays against its CPU mirror (in two tests, so two children). Its
//! device is opened as on a discrete GPU, without host-mapped buffers: rays, images and hits go
//! through staging buffers.

use super::common;

use std::process::Command;
use std::sync::OnceLock;

use common::Target;
use raycast::Algorithm::{self, Robust, Textbook};
use raycast::cpu;
use raycast::gpu::shader::Variant;
use raycast::math::Float;
use raycast::prepare::bvh::Search;
use raycast::rays::{Hits, RayList, one_origin};
use raycast::scene::Scene;

use common::assert_same_bits;

/// Set in the child process, which does the checking.
const WIDTH_VAR: &str = "LP_NATIVE_VECTOR_WIDTH";

/// Runs `check` in a child process of this test binary with 16-lane subgroups: here, the
/// child runs the test `test` (this module's) again, with the variable set, and must pass;
/// there, `check` runs on the 16-lane device.
fn with_sixteen_lanes(test: &str, check: impl FnOnce()) {
    if std::env::var_os(WIDTH_VAR).is_none() {
        // The test's full name in the test binary: its module path less the crate's name.
        let module = module_path!().split_once("::").map_or("", |(_, rest)| rest);
        let exe = std::env::current_exe().expect("the test binary's path");
        let output = Command::new(exe)
            .args(["--exact", &format!("{module}::{test}"), "--nocapture"])
            .args(["--test-threads", "1"])
            .env(WIDTH_VAR, "512")
            .env("NODEVICE_SELECT", "1")
            .output()
            .expect("the test binary runs again");
        let stdout = String::from_utf8_lossy(&output.stdout);
        assert!(output.status.success(), "with 16-lane subgroups: {stdout}");
        // The child ran this very test, not none.
        assert!(stdout.contains("test result: ok. 1 passed"), "{stdout}");
        return;
    }
    let gpu = discrete_like();
    let info = gpu.info().adapter;
    assert_eq!(
        (info.subgroup_min_size, info.subgroup_max_size),
        (16, 16),
        "{WIDTH_VAR}=512 gives lavapipe subgroups of 16"
    );
    let packets = gpu.variant(Float::F32, Robust);
    assert!(packets.packets && !packets.eight_lanes && packets.lane_rays() == 1);
    assert!(!gpu.host_memory(), "staging buffers, as on a discrete GPU");
    check();
}

// Two tests, two children, so that the two halves of the checking run side by side.

#[test]
fn sixteen_lane_subgroups_render_and_light_as_the_cpu_robust_and_adaptive() {
    let test = "sixteen_lane_subgroups_render_and_light_as_the_cpu_robust_and_adaptive";
    with_sixteen_lanes(test, || {
        every_camera_render_agrees(Robust);
        adaptive_renders_agree();
        lit_renders_agree();
    });
}

#[test]
fn sixteen_lane_subgroups_render_textbook_and_cast_as_the_cpu() {
    let test = "sixteen_lane_subgroups_render_textbook_and_cast_as_the_cpu";
    with_sixteen_lanes(test, || {
        every_camera_render_agrees(Textbook);
        for seed in common::LIST_SEEDS {
            ray_lists_agree(seed);
        }
    });
}

/// [`camera_renders_agree`] for every scene.
fn every_camera_render_agrees(algorithm: Algorithm) {
    for (name, scene) in scenes() {
        camera_renders_agree(&name, &scene, algorithm);
    }
}

/// Adaptive precision's ids are the CPU's f64 ids in every scene.
fn adaptive_renders_agree() {
    for (name, scene) in scenes() {
        let adaptive = raycast::render::adaptive::render_adaptive(discrete_like(), &scene).unwrap();
        let truth = cpu::render_with::<f64>(&scene, Robust, Search::Bvh);
        assert_eq!(adaptive.images.id, truth.id, "{name}: adaptive ids");
    }
}

/// lavapipe opened with the features raycast asks of any GPU, not the host-mapped buffers it
/// asks of a CPU adapter.
fn discrete_like() -> &'static raycast::gpu::Gpu {
    static GPU: OnceLock<raycast::gpu::Gpu> = OnceLock::new();
    GPU.get_or_init(|| {
        let adapter = common::gpu().adapter.clone();
        let descriptor = wgpu::DeviceDescriptor {
            required_features: adapter.features() & raycast::gpu::OPTIONAL_FEATURES,
            required_limits: adapter.limits(),
            ..Default::default()
        };
        let (device, queue) = pollster::block_on(adapter.request_device(&descriptor))
            .expect("the adapter opens a second device");
        raycast::gpu::Gpu::from_parts(adapter, device, queue)
    })
}

/// Random scenes of spheres, triangles and planes, the course bunny, and the extreme scenes.
fn scenes() -> Vec<(String, Scene)> {
    let mut s: Vec<(String, Scene)> = (0..3)
        .map(|seed| {
            let name = format!("random-{seed}");
            (name, common::random_scene(seed, [80, 60]))
        })
        .collect();
    let mut bunny = common::course_scene("bunny");
    bunny.camera.resolution = [160, 90];
    s.push(("bunny".into(), bunny));
    for (path, scene) in common::extreme_scenes() {
        s.push((common::scene_name(&path), scene));
    }
    s
}

/// The GPU's packets and per-ray traversal give the CPU BVH's f32 render bit for bit, and the
/// f64 BVH render the CPU's ids.
fn camera_renders_agree(name: &str, scene: &Scene, algorithm: Algorithm) {
    let gpu = discrete_like();
    // The packets' kernel a render of the scene compiles; the per-ray and f64 ones of every
    // primitive kind, compiled as given, one for every scene (a compile each).
    let packets = Variant {
        bvh: true,
        ..gpu.scene_variant(scene, Float::F32, algorithm)
    };
    let general = |precision, packets| Variant {
        bvh: true,
        packets,
        rays_from_origin: false,
        as_given: true,
        ..gpu.variant(precision, algorithm)
    };
    let cpu32 = cpu::render_with::<f32>(scene, algorithm, Search::Bvh);
    for (variant, way) in [
        (packets, "packets"),
        (general(Float::F32, false), "per ray"),
    ] {
        let gpu32 = super::kernels::gpu_variant::<f32>(gpu, scene, variant);
        let what = format!("{name} {algorithm} f32, {way}");
        assert_same_bits(&gpu32.unwrap(), &cpu32, &what);
    }
    let gpu64 = super::kernels::gpu_variant::<f64>(gpu, scene, general(Float::F64, true)).unwrap();
    let cpu64 = cpu::render_with::<f64>(scene, algorithm, Search::Bvh);
    assert_eq!(gpu64.id, cpu64.id, "{name} {algorithm} f64 ids");
}

/// The course's ray tracer (a hook that casts rays, its kernel per ray, its colours and ray
/// count through staging buffers) against its CPU mirror, in f32 and over several dispatches:
/// the same colours but where `pow` lands a pixel on a level's edge, the same rays.
fn lit_renders_agree() {
    let gpu = discrete_like();
    let hook = raycast::ShadeHook::raytrace().unwrap();
    let path = common::repo_path("scenes/ray-tracing/bunny.json");
    let mut scene = Scene::load(&path).unwrap();
    scene.camera.resolution = [160, 90];
    let variant = gpu
        .scene_variant(&scene, Float::F32, Robust)
        .with_shade(hook.key, hook.traces)
        .with_outputs(raycast::images::Outputs::ALL);
    let lit = super::kernels::gpu_tiles::<f32>(gpu, &scene, variant, 16).unwrap();
    let prepared = raycast::prepare::Prepared::<f32>::new(&scene, Robust, Search::Auto);
    let (colours, rays) = cpu::raytrace::render(&prepared);
    // At least 99.9% of pixels identical in red, green and blue, none more than a level off.
    let lit_colours = lit.color.as_deref().unwrap();
    let levels: Vec<u8> = (lit_colours.iter().zip(&colours))
        .map(|(a, b)| (0..3).map(|c| a[c].abs_diff(b[c])).max().unwrap_or(0))
        .collect();
    let exact = levels.iter().filter(|&&d| d == 0).count();
    let most = levels.iter().copied().max().unwrap_or(0);
    assert!(
        exact as f64 >= 0.999 * colours.len() as f64 && most <= 1,
        "lit bunny: {exact} of {} identical, at most {most} levels off",
        colours.len()
    );
    let gpu_rays = lit.hook_rays.unwrap_or_else(|| panic!("a count"));
    assert!(
        gpu_rays.abs_diff(rays) as f64 <= 1e-4 * rays as f64,
        "{gpu_rays} against {rays}"
    );
}

/// A pinhole camera's rays (one origin: `LIST_ORIGIN`), the same rays each moved a little along
/// itself (many origins), both as an image's rows and as a plain list: in packets on the GPU,
/// the CPU's hits bit for bit in f32, and its f64 ids in f64 and adaptive precision.
fn ray_lists_agree(seed: u64) {
    let gpu = discrete_like();
    let (scene, background) = common::list_scene(seed);
    let eye = scene.camera.eye.to_array();
    let scene = Target::from_scene(scene);
    let w = 90;
    let pinhole = common::pinhole_rays(eye, w, 50, 0.2);
    let along = common::moved_along(&pinhole, 1e-3);
    let f32_mode = "gpu:f32".parse().unwrap();
    let cpu_mode = "cpu:f32".parse().unwrap();
    let exact_mode = "cpu:f64".parse().unwrap();
    for (origins, rays) in [("one origin", &pinhole), ("many origins", &along)] {
        assert_eq!(one_origin(RayList::from(rays)), rays == &pinhole);
        let cpu = common::f32_hits(scene.cast(None, cpu_mode, rays).unwrap());
        let exact = scene.cast(None, exact_mode, rays).unwrap();
        for (way, list) in [("image", RayList::image(rays, w)), ("list", rays.into())] {
            let label = format!("seed {seed}, {origins}, {way}");
            let on_gpu = common::f32_hits(scene.cast(Some(gpu), f32_mode, list).unwrap());
            let hit = on_gpu.id.iter().filter(|&&id| id >= 0).count();
            assert!(hit > 100, "{hit} rays hit ({label})");
            assert!(background || hit < rays.len(), "no ray misses ({label})");
            for k in 0..rays.len() {
                let get = |h: &Hits<f32>| (h.id[k], h.t[k], h.primitive[k], h.uv[k], h.normal[k]);
                assert_eq!(get(&on_gpu), get(&cpu), "ray {k}, {label}");
            }
            for mode in ["gpu:f64", "gpu:adaptive"] {
                let hits = scene.cast(Some(gpu), mode.parse().unwrap(), list).unwrap();
                assert_eq!(hits.id(), exact.id(), "{label}, {mode} ids");
            }
        }
    }
}
