//! Side-by-side cost of the kernel variants: median wall time of N warm GPU renders per mode
//! (textbook/robust x f32/f64), modes interleaved run by run so machine load affects all alike.
//!
//!     cargo run --release -p raycast-benches --bin mode_cost -- SCENE... [--size WxH] [--runs N]

use std::time::Instant;

use raycast::Algorithm::{Robust, Textbook};
use raycast::Gpu;
use raycast::{Device, Mode, Precision};
use raycast_cli::render::render;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut take = |flag: &str| {
        let i = args.iter().position(|a| a == flag)?;
        let v = args.get(i + 1).cloned();
        args.drain(i..(i + 2).min(args.len()));
        v
    };
    let runs: usize = take("--runs").map_or(Ok(5), |r| r.parse())?;
    let size = take("--size");
    let gpu = Gpu::new()?;
    println!(
        "adapter: {} ({})",
        gpu.info().adapter.name,
        gpu.info().adapter.driver_info
    );
    println!("| scene | size | mode | median s | vs gpu:f32:textbook |");
    println!("|---|---|---|---|---|");
    for path in &args {
        let mut scene = raycast::Scene::load(path.as_ref())?;
        if let Some(s) = &size {
            let (w, h) = s.split_once('x').ok_or("--size WxH")?;
            scene.camera.resolution = [w.parse()?, h.parse()?];
        }
        let modes: Vec<Mode> = [
            (Precision::F32, Textbook),
            (Precision::F32, Robust),
            (Precision::F64, Textbook),
            (Precision::F64, Robust),
        ]
        .map(|(precision, algorithm)| Mode {
            device: Device::Gpu,
            precision,
            algorithm,
        })
        .to_vec();
        let mut times = vec![Vec::new(); modes.len()];
        for run in 0..=runs {
            for (m, mode) in modes.iter().enumerate() {
                let start = Instant::now();
                render(&scene, *mode, Some(&gpu), Default::default())?;
                if run > 0 {
                    times[m].push(start.elapsed().as_secs_f64());
                }
            }
        }
        let median = |t: &mut Vec<f64>| {
            t.sort_by(f64::total_cmp);
            t[t.len() / 2]
        };
        let medians: Vec<f64> = times.iter_mut().map(median).collect();
        let [nx, ny] = scene.camera.resolution;
        for (mode, t) in modes.iter().zip(&medians) {
            println!(
                "| {path} | {nx}x{ny} | {mode} | {t:.4} | {:.2}x |",
                t / medians[0]
            );
        }
    }
    Ok(())
}
