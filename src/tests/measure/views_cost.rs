//! Where the time of a dataset's views goes (docs/datasets.md#how-fast): the views of an orbit
//! rendered as `raycast render --orbit` renders them but without the files (the scene loaded,
//! its BVH's shape and kernels made once; per view the camera-relative primitives, the BVH
//! fitted, the upload, the trace, the read-back), against the kernel's own GPU time on the same
//! views (timestamp queries), and the files of a view encoded and written on their own. In
//! rounds, the two renders interleaved.
//!
//!     RAYCAST_MEASURE="SCENE [--views N] [--precision f32|adaptive] [--rounds R]" \
//!         cargo test --release -p raycast --lib views_cost -- --ignored --nocapture

use std::time::Instant;

use raycast::Algorithm::Robust;
use raycast::math::Float;
use raycast::output::{Encoding, Format};
use raycast::render::on_gpu;
use raycast::{Gpu, Mode, RenderOptions};

use crate::prepare::shared::{Shared, sharing};

#[test]
#[ignore = "a measurement: RAYCAST_MEASURE=\"ARGS\" cargo test --release -p raycast --lib views_cost -- --ignored --nocapture"]
fn views_cost() -> Result<(), Box<dyn std::error::Error>> {
    let args = super::args();
    let value = |flag: &str, default: &str| {
        let at = args.iter().position(|a| a == flag);
        at.map_or(default.to_owned(), |i| args[i + 1].clone())
    };
    let path = args.first().ok_or("RAYCAST_MEASURE names a scene")?;
    let n: u32 = value("--views", "100").parse()?;
    let rounds: usize = value("--rounds", "3").parse()?;
    let mode: Mode = format!("gpu:{}", value("--precision", "f32")).parse()?;
    let gpu = Gpu::new()?;
    let mut scene = raycast::Scene::load(path.as_ref())?;
    let cameras = raycast::Orbit {
        views: n,
        ..raycast::Orbit::default()
    }
    .cameras(&scene)?;
    let dir = tempfile::tempdir()?;
    let encoding = Encoding::new(&[Format::Png], None)?;
    // A view's render as `raycast render --orbit` makes it.
    let options = RenderOptions {
        precision: Some(mode.precision),
        algorithm: mode.algorithm,
        outputs: encoding.outputs,
        ..RenderOptions::default()
    };
    println!(
        "adapter: {}; {path}, {n} views, {mode}",
        gpu.info().adapter.name
    );
    println!(
        "| round | views, no files: s | kernel (GPU time): s | kernel / views | files of a view: ms |"
    );
    println!("|---|---|---|---|---|");
    let mut shared = Shared::default();
    for round in 0..=rounds {
        let (mut render_s, mut kernel_s, mut files_s) = (0.0, 0.0, 0.0);
        for camera in &cameras {
            scene.camera = camera.clone();
            let start = Instant::now();
            let images = sharing(&scene, &mut shared, || gpu.render(&scene, &options))?;
            render_s += start.elapsed().as_secs_f64();
            let variant = gpu.scene_variant(&scene, Float::F32, Robust);
            let (_, stages) = on_gpu::<f32>(&gpu, &scene, variant, true, None)?;
            kernel_s += stages.kernel_s.ok_or("the adapter has timestamp queries")?;
            let start = Instant::now();
            raycast_files::write_files(dir.path(), &images.encode(&encoding, &scene.camera))?;
            files_s += start.elapsed().as_secs_f64();
        }
        // Round 0 compiles the kernels.
        if round > 0 {
            println!(
                "| {round} | {render_s:.3} | {kernel_s:.3} | {:.2} | {:.2} |",
                kernel_s / render_s,
                1e3 * files_s / f64::from(n)
            );
        }
    }
    Ok(())
}
