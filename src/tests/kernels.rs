//! Renders by a hand-made kernel variant, below the API: for the library's own tests.

use raycast::Algorithm;
use raycast::gpu::Gpu;
use raycast::gpu::shader::Variant;
use raycast::images::Images;
use raycast::kernel::layout::GpuReal;
use raycast::scene::Scene;

/// `scene` rendered on `gpu` by the kernel `variant` (the scene prepared for it).
pub(crate) fn gpu_variant<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
) -> raycast::Result<Images<R>> {
    raycast::render::on_gpu::<R>(gpu, scene, variant, false, None).map(|(images, _)| images)
}

/// `scene` rendered on `gpu` by the kernel a render picks for it in precision `R`.
pub(crate) fn gpu_scene<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    algorithm: Algorithm,
) -> raycast::Result<Images<R>> {
    let variant = gpu.scene_variant(scene, R::PRECISION, algorithm);
    gpu_variant(gpu, scene, variant.for_rays(scene.camera.pixel_count()))
}

/// [`gpu_variant`] in dispatches of at most `max_rows` image rows.
pub(crate) fn gpu_tiles<R: GpuReal>(
    gpu: &Gpu,
    scene: &Scene,
    variant: Variant,
    max_rows: u32,
) -> raycast::Result<Images<R>> {
    let prepared = raycast::gpu::prepare::<R>(scene, &variant)?;
    let job = raycast::gpu::Job::new(variant).rows(max_rows);
    raycast::gpu::run(gpu, &prepared, job).map(|r| r.images)
}
