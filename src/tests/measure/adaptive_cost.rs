//! Cost and re-cast fraction of adaptive precision against robust f32 and f64, side by side:
//! median wall time of N warm GPU renders per mode, modes interleaved run by run.
//!
//!     RAYCAST_MEASURE="SCENE... [--runs N]" cargo test --release -p raycast --lib adaptive_cost -- --ignored --nocapture

use std::time::Instant;

use raycast::Algorithm::Robust;
use raycast::Gpu;
use raycast::math::Float;
use raycast::render::on_gpu;

#[test]
#[ignore = "a measurement: RAYCAST_MEASURE=\"ARGS\" cargo test --release -p raycast --lib adaptive_cost -- --ignored --nocapture"]
fn adaptive_cost() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = super::args().into_iter().collect();
    let mut runs = 5;
    if let Some(i) = args.iter().position(|a| a == "--runs") {
        runs = args[i + 1].parse()?;
        args.drain(i..i + 2);
    }
    let gpu = Gpu::new()?;
    println!(
        "adapter: {} ({})",
        gpu.info().adapter.name,
        gpu.info().adapter.driver_info
    );
    println!(
        "| scene | robust f32 s | robust f64 s | certainty pass s | adaptive s | adaptive / f32 | re-cast |"
    );
    println!("|---|---|---|---|---|---|---|");
    for path in &args {
        let scene = raycast::Scene::load(path.as_ref())?;
        let mut t = [vec![], vec![], vec![], vec![]];
        let mut fraction = 0.0;
        for run in 0..=runs {
            let mut time = |k: usize, f: &mut dyn FnMut() -> Result<(), raycast::Error>| {
                let start = Instant::now();
                f()?;
                if run > 0 {
                    t[k].push(start.elapsed().as_secs_f64());
                }
                Ok::<(), raycast::Error>(())
            };
            time(0, &mut || {
                let variant = gpu.scene_variant(&scene, Float::F32, Robust);
                on_gpu::<f32>(&gpu, &scene, variant, false, None).map(|_| ())
            })?;
            time(1, &mut || {
                let variant = gpu.scene_variant(&scene, Float::F64, Robust);
                on_gpu::<f64>(&gpu, &scene, variant, false, None).map(|_| ())
            })?;
            time(2, &mut || {
                raycast::render::adaptive::certainty_pass(&gpu, &scene, false).map(|_| ())
            })?;
            time(3, &mut || {
                fraction =
                    raycast::render::adaptive::render_adaptive(&gpu, &scene)?.recast_fraction();
                Ok(())
            })?;
        }
        let m: Vec<f64> = t.iter().map(|v| super::median(v)).collect();
        println!(
            "| {path} | {:.4} | {:.4} | {:.4} | {:.4} | {:.2}x | {:.3}% |",
            m[0],
            m[1],
            m[2],
            m[3],
            m[3] / m[0],
            100.0 * fraction
        );
    }
    Ok(())
}
