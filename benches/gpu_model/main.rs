//! A GPU cost model of the kernel's traversals (docs/gpu.md#a-cost-model): each subgroup's
//! rays replayed through the CPU mirror, in lockstep, through an L1 and L2 model, and a time
//! predicted from the device's parameters.
//!
//!     gpu_model SCENE [--size WxH] [--rays N] [--f64] [--device h200|rtx4090 (h200)]
//!               [--traversal packets|per-ray|if-if|wide|both|all] [--instanced] [--json]
//!
//! `--instanced`: a scene's instances walked in their meshes' coordinates, each mesh held once
//! (#64), per ray only.
//!     gpu_model --calibrate --bench DIR   # the H200 report's workloads against its figures

mod cache;
mod calibration;
mod device;
mod timing;

use std::path::Path;
use std::process::ExitCode;

use rayon::prelude::*;

use raycast::model::{Trace, Traversal, Workload};

use device::Device;
use timing::{Machine, Totals, predict};

/// What one traversal of one workload comes to.
#[derive(Clone, Debug)]
pub struct Figures {
    pub traversal: Traversal,
    pub rays: u64,
    pub steps_per_ray: f64,
    pub simd_efficiency: f64,
    pub l2_bytes_per_ray: f64,
    pub dram_bytes_per_ray: f64,
    pub predicted_ms: f64,
    pub bound: &'static str,
    /// Of the steps a subgroup ran (per ray, as `steps_per_ray`) and the L2 bytes, the nodes'.
    pub node_steps_per_ray: f64,
    pub node_l2_bytes_per_ray: f64,
    /// The geometry's bytes a triangle on the device with this traversal's tree.
    pub bytes_per_triangle: Option<f64>,
}

/// A workload as the command line names it.
#[derive(Clone, Debug)]
pub struct Job {
    pub scene: String,
    pub size: Option<[u32; 2]>,
    pub rays: Option<usize>,
    pub f64: bool,
    /// Through the tree naming the scene's instances (per ray only).
    pub instanced: bool,
}

/// Subgroups traced at once (in parallel) before they run through the caches in order.
const CHUNK: usize = 4096;

pub fn model(job: &Job, device: &Device, traversal: Traversal) -> Result<Figures, String> {
    if job.instanced && !matches!(traversal, Traversal::PerRay | Traversal::IfIf) {
        return Err(format!(
            "--instanced: the tree naming instances is walked ray by ray, not by {traversal:?}"
        ));
    }
    let workload = workload(job)?;
    if traversal == Traversal::Wide && !workload.has_wide_tree() {
        return Err(format!(
            "{}: no wide tree (spheres keep the binary tree)",
            job.scene
        ));
    }
    let mut machine = Machine::new(device, job.f64, traversal == Traversal::Packets);
    let mut totals = Totals::default();
    let subgroups = workload.subgroups();
    let mut traces = vec![Trace::default(); CHUNK];
    for from in (0..subgroups).step_by(CHUNK) {
        let to = (from + CHUNK).min(subgroups);
        traces[..to - from]
            .par_iter_mut()
            .enumerate()
            .for_each(|(k, t)| {
                workload.trace(traversal, from + k, t);
            });
        for (k, t) in traces[..to - from].iter().enumerate() {
            machine.run(from + k, t, |a| workload.element_bytes(a), &mut totals);
        }
    }
    let (predicted_ms, bound) = predict(device, &totals);
    let rays = totals.rays.max(1) as f64;
    Ok(Figures {
        traversal,
        rays: totals.rays,
        steps_per_ray: totals.lane_steps as f64 / rays,
        simd_efficiency: totals.wanted as f64 / (totals.steps.max(1) * 32) as f64,
        l2_bytes_per_ray: (totals.l2_sectors * cache::SECTOR) as f64 / rays,
        dram_bytes_per_ray: (totals.dram_sectors * cache::SECTOR) as f64 / rays,
        predicted_ms,
        bound,
        node_steps_per_ray: totals.node_lane_steps as f64 / rays,
        node_l2_bytes_per_ray: (totals.node_l2_sectors * cache::SECTOR) as f64 / rays,
        bytes_per_triangle: workload.bytes_per_triangle(traversal),
    })
}

fn workload(job: &Job) -> Result<Workload, String> {
    let mut scene = raycast::Scene::load(Path::new(&job.scene)).map_err(|e| e.to_string())?;
    if let Some(size) = job.size {
        scene.camera.resolution = size;
    }
    let rays = job
        .rays
        .map(|n| raycast_cli::study::bench::incoherent_rays(&scene, n));
    let made = match job.instanced {
        true => Workload::instanced(&scene, rays, job.f64),
        false => Workload::new(&scene, rays, job.f64),
    };
    made.ok_or_else(|| format!("{}: the scene is searched without a BVH", job.scene))
}

pub fn json_line(job: &Job, device: &Device, f: &Figures) -> String {
    let traversal = match f.traversal {
        Traversal::Packets => "packets",
        Traversal::PerRay => "per-ray",
        Traversal::IfIf => "if-if",
        Traversal::Wide => "wide",
    };
    let workload = match (job.rays, job.size) {
        (Some(n), _) => format!(r#""rays_list": {n}"#),
        (None, Some([w, h])) => format!(r#""size": "{w}x{h}""#),
        (None, None) => r#""size": "scene""#.to_owned(),
    };
    format!(
        r#"{{"scene": "{}", {workload}, "precision": "{}", "device": "{}", "traversal": "{traversal}", "instanced": {}, "rays": {}, "steps_per_ray": {:.1}, "simd_efficiency": {:.3}, "l2_bytes_per_ray": {:.1}, "dram_bytes_per_ray": {:.1}, "predicted_ms": {:.3}, "bound": "{}", "node_steps_per_ray": {:.1}, "node_l2_bytes_per_ray": {:.1}, "bytes_per_triangle": {}}}"#,
        job.scene.replace('\\', "\\\\").replace('"', "\\\""),
        if job.f64 { "f64" } else { "f32" },
        device.name,
        job.instanced,
        f.rays,
        f.steps_per_ray,
        f.simd_efficiency,
        f.l2_bytes_per_ray,
        f.dram_bytes_per_ray,
        f.predicted_ms,
        f.bound,
        f.node_steps_per_ray,
        f.node_l2_bytes_per_ray,
        f.bytes_per_triangle
            .map_or("null".to_owned(), |b| format!("{b:.1}")),
    )
}

struct Args {
    job: Option<Job>,
    device: Device,
    traversals: Vec<Traversal>,
    json: bool,
    calibrate: Option<String>,
}

fn parse(args: &[String]) -> Result<Args, String> {
    let mut scene = None;
    let (mut size, mut rays, mut f64, mut json) = (None, None, false, false);
    let mut instanced = false;
    let mut device = None;
    let mut traversals = vec![Traversal::Packets, Traversal::PerRay];
    let mut calibrate = None;
    let mut it = args.iter();
    while let Some(a) = it.next() {
        let mut value = |name: &str| it.next().cloned().ok_or(format!("{name} needs a value"));
        match a.as_str() {
            "--size" => {
                let v = value("--size")?;
                let parsed = v
                    .split_once('x')
                    .and_then(|(w, h)| Some([w.parse().ok()?, h.parse().ok()?]));
                size = Some(
                    parsed
                        .filter(|[w, h]: &[u32; 2]| *w > 0 && *h > 0)
                        .ok_or(format!("--size: {v} is not WxH"))?,
                );
            }
            "--rays" => {
                let v = value("--rays")?;
                rays = Some(
                    v.parse()
                        .ok()
                        .filter(|&n: &usize| n > 0)
                        .ok_or(format!("--rays: {v} is not a positive count"))?,
                );
            }
            "--device" => {
                let v = value("--device")?;
                device = Some(
                    device::by_name(&v).ok_or(format!("--device: {v} is not h200 or rtx4090"))?,
                );
            }
            "--traversal" => {
                let v = value("--traversal")?;
                traversals = match v.as_str() {
                    "packets" => vec![Traversal::Packets],
                    "per-ray" => vec![Traversal::PerRay],
                    "if-if" => vec![Traversal::IfIf],
                    "wide" => vec![Traversal::Wide],
                    "both" => vec![Traversal::Packets, Traversal::PerRay],
                    "all" => vec![
                        Traversal::Packets,
                        Traversal::PerRay,
                        Traversal::IfIf,
                        Traversal::Wide,
                    ],
                    _ => {
                        return Err(format!(
                            "--traversal: {v} is not packets, per-ray, if-if, wide, both or all"
                        ));
                    }
                };
            }
            "--f64" => f64 = true,
            "--instanced" => instanced = true,
            "--json" => json = true,
            "--calibrate" => calibrate = Some(calibrate.unwrap_or_default()),
            "--bench" => calibrate = Some(value("--bench")?),
            s if s.starts_with("--") => return Err(format!("{s}: unknown option")),
            s if scene.is_none() => scene = Some(s.to_owned()),
            s => return Err(format!("{s}: one scene only")),
        }
    }
    if calibrate.is_none() && scene.is_none() {
        return Err("a scene file, or --calibrate, is needed".into());
    }
    if calibrate.as_deref() == Some("") {
        return Err(
            "--calibrate needs --bench DIR: the workloads of `raycast workload` in \
             DIR/torus, DIR/torus5m (--triangles 5000000) and DIR/spheres"
                .into(),
        );
    }
    Ok(Args {
        job: scene.map(|scene| Job {
            scene,
            size,
            rays,
            f64,
            instanced,
        }),
        device: device.unwrap_or(device::H200),
        traversals,
        json,
        calibrate,
    })
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let args = match parse(&args) {
        Ok(a) => a,
        Err(e) => {
            eprintln!("gpu_model: {e}");
            return ExitCode::from(2);
        }
    };
    if let Some(bench) = &args.calibrate {
        return calibration::run(Path::new(bench));
    }
    let job = args.job.expect("parse asks for a scene");
    for &t in &args.traversals {
        match model(&job, &args.device, t) {
            Ok(f) if args.json => println!("{}", json_line(&job, &args.device, &f)),
            Ok(f) => println!(
                "{:?}: {:.1} steps/ray, SIMD {:.0}%, L2 {:.0} B/ray, DRAM {:.0} B/ray, {:.3} ms ({})",
                t,
                f.steps_per_ray,
                f.simd_efficiency * 100.0,
                f.l2_bytes_per_ray,
                f.dram_bytes_per_ray,
                f.predicted_ms,
                f.bound
            ),
            // `all` goes on past a scene without a wide tree.
            Err(e) if t == Traversal::Wide && args.traversals.len() > 1 => {
                eprintln!("gpu_model: {e}")
            }
            Err(e) => {
                eprintln!("gpu_model: {e}");
                return ExitCode::from(2);
            }
        }
    }
    ExitCode::SUCCESS
}
