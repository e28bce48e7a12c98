//! Timing a render changes no pixel; the kernel times are positive where the device has
//! timestamp queries (the times `raycast tradeoff` and `bench` report).

#[test]
fn kernel_timing_changes_no_pixel_and_reports_positive_times() {
    use raycast::Algorithm::Robust;
    use raycast::render::{self, AnyImages};
    let gpu = super::common::gpu();
    let timestamps = gpu
        .device
        .features()
        .contains(wgpu::Features::TIMESTAMP_QUERY);
    let mut scene = super::common::course_scene("bunny");
    scene.camera.resolution = [48, 27];
    let plain = super::kernels::gpu_scene::<f32>(gpu, &scene, Robust).unwrap();
    let variant = gpu.scene_variant(&scene, raycast::math::Float::F32, Robust);
    let (timed, stages) = render::on_gpu::<f32>(gpu, &scene, variant, true, None).unwrap();
    let kernel_s = stages.kernel_s;
    assert_eq!(plain, timed);
    assert_eq!(kernel_s.is_some(), timestamps);
    if let Some(k) = kernel_s {
        assert!(k > 0.0 && k < 60.0, "{k}");
    }
    // Adaptive: the same images, its two passes timed together.
    let a = raycast::render::adaptive::render_adaptive(gpu, &scene).unwrap();
    let t = raycast::render::adaptive::render_adaptive_timed(gpu, &scene).unwrap();
    assert_eq!(a.images, t.images);
    assert_eq!(a.kernel_s, None);
    assert!(t.recast > 0, "the bunny has uncertain pixels");
    if timestamps && t.recast_on_gpu {
        assert!(t.kernel_s.unwrap() > 0.0);
    }
    // The re-cast forced onto the GPU (the bunny's few pixels go to the CPU): the same images,
    // both passes timed.
    let g = raycast::render::adaptive::render_adaptive_with(gpu, &scene, true, 0).unwrap();
    assert!(g.recast_on_gpu);
    assert_eq!(g.images, t.images);
    assert_eq!(g.kernel_s.is_some(), timestamps);
    if let Some(k) = g.kernel_s {
        assert!(k > 0.0 && k < 60.0, "{k}");
    }
    // render::render_timed: kernel time for the GPU, none for the CPU.
    let mode = |s: &str| s.parse::<raycast::render::Mode>().unwrap();
    let (images, k) = render::render_timed(&scene, mode("gpu:adaptive"), Some(gpu)).unwrap();
    assert_eq!(images, AnyImages::F32(a.images));
    assert_eq!(k.is_some(), timestamps && t.recast_on_gpu);
    let (_, k) = render::render_timed(&scene, mode("cpu:f64"), Some(gpu)).unwrap();
    assert_eq!(k, None);
}
