//! Times kernels against each other on one prepared scene, the way docs/experiments.md's
//! kernel steps were measured: `RAYCAST_MEASURE="SCENE [--f64] [--traversal per-ray|packets]
//! [--rounds N] [--no-check] KERNEL..." cargo test --release -p raycast --lib kernel_ab --
//! --ignored --nocapture`, each KERNEL `builtin` (the kernel `render` assembles)
//! or a WGSL file as `render --kernel` takes one (`render --emit-shader` writes the assembled
//! one, to edit). The kernels run in turn, in alternating order, every round (one warm-up
//! round first); it prints each one's median kernel time (timestamp queries) and the median
//! of the rounds' time ratios to the first kernel, which this shared machine's drifts move far
//! less than the times. Every kernel must give the first one's ids, unless `--no-check`.
//!
//! With `--list` the kernels are ray-list kernels (the Python package's `cast_rays`): the
//! camera's rays, in world coordinates and float32 as NumPy callers hold them, cast as an
//! image's list; each round also times the camera's kernel, and it prints the median ratio of
//! the first kernel's time to the camera kernel's. `--emit FILE` writes the assembled kernel
//! (camera or list) to edit, and stops.
//!
//! A `--kernel` file keeps wgpu's runtime checks, the assembled kernel does not
//! (`Variant::is_ours`): compare an edited kernel with the same kernel emitted, not with
//! `builtin`.
use std::path::Path;

use super::median;

use raycast::gpu::shader::{Casts, Variant};
use raycast::gpu::{self, Gpu, Job, kernel};
use raycast::kernel::layout::GpuReal;
use raycast::math::Float;
use raycast::rays::RayList;

struct Options {
    scene: String,
    precision: Float,
    /// Packets (`--traversal packets`) or ray by ray; the device's choice where not given.
    packets: Option<bool>,
    rounds: usize,
    check: bool,
    list: bool,
    emit: Option<String>,
    kernels: Vec<String>,
}

fn options() -> Options {
    let usage = "RAYCAST_MEASURE=\"SCENE [--f64] [--traversal per-ray|packets] [--list] \
                 [--rounds N] [--no-check] [--emit FILE] KERNEL...\"";
    let mut args = super::args().into_iter();
    let mut o = Options {
        scene: args.next().expect(usage),
        precision: Float::F32,
        packets: None,
        rounds: 15,
        check: true,
        list: false,
        emit: None,
        kernels: Vec::new(),
    };
    while let Some(a) = args.next() {
        match a.as_str() {
            "--f64" => o.precision = Float::F64,
            "--no-check" => o.check = false,
            "--traversal" => {
                o.packets = match args.next().as_deref() {
                    Some("packets") => Some(true),
                    Some("per-ray") => Some(false),
                    _ => panic!("{usage}"),
                }
            }
            "--list" => o.list = true,
            "--emit" => o.emit = Some(args.next().expect(usage)),
            "--rounds" => o.rounds = args.next().and_then(|n| n.parse().ok()).expect(usage),
            _ => o.kernels.push(a),
        }
    }
    assert!(!o.kernels.is_empty() || o.emit.is_some(), "{usage}");
    o
}

/// The camera's ray through every pixel, row by row, in world coordinates rounded to f32 (as
/// a NumPy caller holds them): origin, direction.
fn camera_rows(scene: &raycast::Scene) -> Vec<[f32; 6]> {
    let [nx, ny] = scene.camera.resolution;
    let frame = raycast::kernel::frame::Frame::new(&scene.camera, [nx, ny]);
    let pixels = (0..ny).flat_map(|i| (0..nx).map(move |j| (i, j)));
    pixels
        .map(|(i, j)| {
            let ray = raycast::kernel::frame::camera_ray(&frame, i, j);
            let (o, d) = (ray.origin, ray.direction);
            [o.x, o.y, o.z, d.x, d.y, d.z].map(|x| x as f32)
        })
        .collect()
}

/// Each kernel's kernel times, one per round after the warm-up, and with `--list` last the
/// camera kernel's.
fn time_kernels<R: GpuReal>(
    gpu: &Gpu,
    scene: &raycast::Scene,
    camera: Variant,
    o: &Options,
) -> Vec<Vec<f64>> {
    let prepared = gpu::prepare::<R>(scene, &camera).unwrap();
    let resident = gpu::upload(gpu, &prepared, &camera).unwrap();
    let rows = if o.list {
        camera_rows(scene)
    } else {
        Vec::new()
    };
    let list = RayList::image(&rows[..], scene.camera.resolution[0] as usize);
    // As gpu::run compiles it, so that --emit writes the kernel that runs.
    let casts = if o.list { Casts::Rays } else { Casts::Camera };
    let cast = Variant {
        list_origin: raycast::rays::one_origin(list),
        ..camera
    };
    let base = gpu::dispatch::specialized(cast, casts, &prepared).unwrap();
    if let Some(file) = &o.emit {
        let source = raycast::gpu::shader::kernel_source(&base).unwrap();
        std::fs::write(file, source).unwrap_or_else(|e| panic!("{file}: {e}"));
        return Vec::new(); // --emit: written, nothing to time
    }
    let mut variants: Vec<Variant> = (o.kernels.iter())
        .map(|k| match k.as_str() {
            "builtin" => base,
            file => kernel::UserKernel::load(Path::new(file))
                .and_then(|user| user.for_variant(base))
                .unwrap_or_else(|e| panic!("{file}: {e}")),
        })
        .collect();
    if o.list {
        variants.push(camera);
    }
    let is_list = |k: usize| o.list && k < o.kernels.len();
    let mut times = vec![Vec::new(); variants.len()];
    let mut first_ids = None;
    for round in 0..=o.rounds {
        let mut order: Vec<usize> = (0..variants.len()).collect();
        // Each kernel in each place in turn: this machine's speed drifts within a round too.
        order.rotate_left(round % variants.len());
        if round % 2 == 1 {
            order.reverse();
        }
        for k in order {
            let job = Job::new(variants[k]).timed(true).resident(&resident);
            let job = if is_list(k) { job.rays(list, 0.0) } else { job };
            let out = gpu::run(gpu, &prepared, job).unwrap();
            if round > 0 {
                times[k].push(out.stages.kernel_s.expect("timestamp queries"));
            }
            if o.check && (is_list(k) || !o.list) {
                let ids = out.hits.map_or(out.images.id, |h| h.id);
                let first = first_ids.get_or_insert_with(|| ids.clone());
                assert!(*first == ids, "{} gives other ids", o.kernels[k]);
            }
        }
    }
    times
}

#[test]
#[ignore = "a measurement: RAYCAST_MEASURE=\"ARGS\" cargo test --release -p raycast --lib kernel_ab -- --ignored --nocapture"]
fn kernel_ab() {
    let o = options();
    let scene = raycast::Scene::load(Path::new(&o.scene)).unwrap();
    let gpu = Gpu::new().unwrap();
    let mut base = gpu.scene_variant(&scene, o.precision, raycast::Algorithm::Robust);
    if let Some(packets) = o.packets {
        let general = gpu.variant(o.precision, raycast::Algorithm::Robust);
        assert!(
            !packets || general.packets,
            "this device has no packet traversal"
        );
        base.packets = packets;
    }
    let times = match o.precision {
        Float::F32 => time_kernels::<f32>(&gpu, &scene, base, &o),
        Float::F64 => time_kernels::<f64>(&gpu, &scene, base, &o),
    };
    if o.emit.is_some() {
        return; // the kernel was written, nothing timed
    }
    if o.list {
        let camera = times.last().expect("the camera kernel's times");
        let ratios: Vec<f64> = times[0].iter().zip(camera).map(|(a, b)| a / b).collect();
        println!(
            "camera kernel: median {:.4} s; {} / camera kernel's time {:.4}",
            median(camera),
            o.kernels[0],
            median(&ratios)
        );
    }
    for (name, t) in o.kernels.iter().zip(&times) {
        let ratios: Vec<f64> = t.iter().zip(&times[0]).map(|(a, b)| a / b).collect();
        println!(
            "{name}: median {:.6} s, time / first kernel's {:.4} (median of {} rounds)",
            median(t),
            median(&ratios),
            ratios.len()
        );
    }
}
