//! Compare a GPU render with the CPU reference: render the same scene on both and count the
//! pixels whose object differs, and the largest difference in distance.
//!
//!     cargo run --example compare_cpu [SCENE.json]

use raycast::{AnyImages, Cpu, Gpu, Precision, RenderOptions, Scene};

fn main() -> raycast::Result<()> {
    let file = std::env::args()
        .nth(1)
        .unwrap_or("scenes/course/bunny.json".into());
    let mut scene = Scene::load(file.as_ref())?;
    scene.camera.resolution = [320, 180];

    // The GPU in f32, against the CPU reference in f64.
    let f32_options = RenderOptions {
        precision: Some(Precision::F32),
        ..Default::default()
    };
    let device = Gpu::new()?;
    let fast = device.render(&scene, &f32_options)?;
    let reference = Cpu.render(&scene, &RenderOptions::default())?;

    let (AnyImages::F32(gpu), AnyImages::F64(reference)) = (fast, reference) else {
        unreachable!("an f32 render and an f64 one");
    };
    let differ = (gpu.id.iter().zip(&reference.id))
        .filter(|(a, b)| a != b)
        .count();
    let worst = (gpu.distance.iter().zip(&reference.distance))
        .filter(|(a, b)| a.is_finite() && b.is_finite())
        .map(|(&a, &b)| ((f64::from(a) - b) / b).abs())
        .fold(0.0, f64::max);
    println!(
        "{differ} of {} pixels see another object; distances within {worst:.1e} (relative)",
        gpu.id.len()
    );
    // Adaptive precision (the GPU's default) gives the reference's ids on every pixel.
    let adaptive = device.render(&scene, &RenderOptions::default())?;
    assert_eq!(adaptive.id(), &reference.id[..]);
    Ok(())
}
