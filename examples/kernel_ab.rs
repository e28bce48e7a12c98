//! Times kernels against each other on one prepared scene, the way docs/performance.md's
//! kernel steps were measured: `cargo run --release --example kernel_ab SCENE [--f64]
//! [--rounds N] [--no-check] KERNEL...`, each KERNEL `builtin` (the kernel `render` assembles)
//! or a WGSL file as `render --kernel` takes one (`render --emit-shader` writes the assembled
//! one, to edit). The kernels run in turn, in alternating order, every round (one warm-up
//! round first); it prints each one's median kernel time (timestamp queries) and the median
//! of the rounds' time ratios to the first kernel, which this shared machine's drifts move far
//! less than the times. Every kernel must give the first one's ids, unless `--no-check`.
//!
//! A `--kernel` file keeps wgpu's runtime checks, the assembled kernel does not
//! (`Variant::is_ours`): compare an edited kernel with the same kernel emitted, not with
//! `builtin`.
use std::path::Path;

use raycast::gpu::layout::GpuReal;
use raycast::gpu::shader::Variant;
use raycast::gpu::{self, Gpu, Job, kernel};
use raycast::math::Precision;

struct Options {
    scene: String,
    precision: Precision,
    rounds: usize,
    check: bool,
    kernels: Vec<String>,
}

fn options() -> Options {
    let usage = "usage: kernel_ab SCENE [--f64] [--rounds N] [--no-check] KERNEL...";
    let mut args = std::env::args().skip(1);
    let mut o = Options {
        scene: args.next().expect(usage),
        precision: Precision::F32,
        rounds: 15,
        check: true,
        kernels: Vec::new(),
    };
    while let Some(a) = args.next() {
        match a.as_str() {
            "--f64" => o.precision = Precision::F64,
            "--no-check" => o.check = false,
            "--rounds" => o.rounds = args.next().and_then(|n| n.parse().ok()).expect(usage),
            _ => o.kernels.push(a),
        }
    }
    assert!(!o.kernels.is_empty(), "{usage}");
    o
}

fn median(v: &[f64]) -> f64 {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Each kernel's kernel times, one per round after the warm-up.
fn time_kernels<R: GpuReal>(
    gpu: &Gpu,
    scene: &raycast::Scene,
    base: Variant,
    o: &Options,
) -> Vec<Vec<f64>> {
    let prepared = gpu::prepare::<R>(scene, &base).unwrap();
    let resident = gpu::upload(gpu, &prepared, &base).unwrap();
    let variants: Vec<Variant> = (o.kernels.iter())
        .map(|k| match k.as_str() {
            "builtin" => base,
            file => kernel::load(Path::new(file))
                .and_then(|user| user.for_variant(base))
                .unwrap_or_else(|e| panic!("{file}: {e}")),
        })
        .collect();
    let mut times = vec![Vec::new(); variants.len()];
    let mut first_ids = None;
    for round in 0..=o.rounds {
        let mut order: Vec<usize> = (0..variants.len()).collect();
        if round % 2 == 1 {
            order.reverse();
        }
        for k in order {
            let job = Job::new(variants[k]).timed(true).resident(&resident);
            let out = gpu::run(gpu, &prepared, job).unwrap();
            if round > 0 {
                times[k].push(out.stages.kernel_s.expect("timestamp queries"));
            }
            if o.check {
                let ids = first_ids.get_or_insert_with(|| out.images.id.clone());
                assert!(*ids == out.images.id, "{} gives other ids", o.kernels[k]);
            }
        }
    }
    times
}

fn main() {
    let o = options();
    let scene = raycast::Scene::load(Path::new(&o.scene)).unwrap();
    let gpu = Gpu::new().unwrap();
    let base = gpu.scene_variant(&scene, o.precision, raycast::Algorithm::Robust);
    let times = match o.precision {
        Precision::F32 => time_kernels::<f32>(&gpu, &scene, base, &o),
        Precision::F64 => time_kernels::<f64>(&gpu, &scene, base, &o),
    };
    for (name, t) in o.kernels.iter().zip(&times) {
        let ratios: Vec<f64> = t.iter().zip(&times[0]).map(|(a, b)| a / b).collect();
        println!(
            "{name}: median {:.4} s, time / first kernel's {:.4} (median of {} rounds)",
            median(t),
            median(&ratios),
            ratios.len()
        );
    }
}
