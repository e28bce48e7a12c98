//! Timing a render changes no pixel; the kernel times are positive where the device has
//! timestamp queries (the times `raycast tradeoff` and `bench` report).

/// Whether `gpu` can time its kernels (timestamp queries).
fn has_timestamps(gpu: &raycast::gpu::Gpu) -> bool {
    gpu.device
        .features()
        .contains(wgpu::Features::TIMESTAMP_QUERY)
}

#[test]
fn kernel_timing_changes_no_pixel_and_reports_positive_times() {
    use raycast::Algorithm::Robust;
    use raycast::render::{self, AnyImages};
    let gpu = super::common::gpu();
    let timestamps = has_timestamps(gpu);
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

/// A render reads back only the outputs it asks for, each in its own size (in f32: an id 4
/// bytes, a distance alone 4, a normal 16 with its distance), and its images are those of the
/// render of every output.
#[test]
fn a_render_reads_back_only_the_outputs_asked_for() {
    use raycast::Algorithm::Robust;
    use raycast::images::Outputs;
    use raycast::render;
    let gpu = super::common::gpu();
    let mut scene = super::common::course_scene("bunny");
    scene.camera.resolution = [160, 90];
    let pixels = 160 * 90;
    // The kernel a render of this size runs (fewer rays a lane: quicker to compile).
    let variant = gpu.scene_variant(&scene, raycast::math::Float::F32, Robust);
    let variant = variant.for_rays(pixels);
    let every = Outputs {
        color: false,
        ..Outputs::ALL
    };
    let (all, stages) =
        render::on_gpu::<f32>(gpu, &scene, variant.with_outputs(every), false, None).unwrap();
    assert_eq!(stages.readback_bytes, pixels * 20);
    let only = |id, distance, normal| Outputs {
        id,
        distance,
        normal,
        color: false,
    };
    // A kernel each (compiled once in CI): depth16's id and distance, the distance alone, and
    // the normal (with the distance beside it in the surface).
    for (outputs, bytes) in [
        (only(true, true, false), 8),
        (only(false, true, false), 4),
        (only(false, false, true), 16),
    ] {
        let asked = variant.with_outputs(outputs);
        let (images, stages) = render::on_gpu::<f32>(gpu, &scene, asked, false, None).unwrap();
        assert_eq!(stages.readback_bytes, pixels * bytes, "{outputs:?}");
        assert!(
            stages.wait_s + stages.convert_s <= stages.trace_s,
            "{stages:?}"
        );
        let miss = raycast::Images::<f32>::new_miss(160, 90, images.focal_length);
        fn expect<'a, T>(asked: bool, all: &'a T, miss: &'a T) -> &'a T {
            if asked { all } else { miss }
        }
        assert_eq!(
            images.id,
            *expect(outputs.id, &all.id, &miss.id),
            "{outputs:?}"
        );
        let distance = expect(outputs.distance, &all.distance, &miss.distance);
        assert!(images.distance == *distance, "{outputs:?}");
        let normal = expect(outputs.normal, &all.normal, &miss.normal);
        assert!(images.normal == *normal, "{outputs:?}");
    }
}

/// A timed `Accel` casts the same hits and adds each GPU query's kernel seconds; an untimed one
/// and the CPU's report none.
#[test]
fn timed_queries_change_no_hit_and_add_their_kernel_times() {
    let gpu = super::common::gpu();
    let timestamps = has_timestamps(gpu);
    let scene = super::common::course_scene("bunny");
    let geometry = raycast::Geometry::from_scene(&scene);
    let rays: Vec<raycast::Ray> = (0..300)
        .map(|k| raycast::Ray {
            origin: scene.camera.eye,
            direction: (scene.camera.look.normalize()
                + raycast::DVec3::new((k % 20) as f64 * 0.01, (k / 20) as f64 * 0.01, 0.0))
            .normalize(),
        })
        .collect();
    for precision in [raycast::Precision::F32, raycast::Precision::Adaptive] {
        let plain = gpu.commit(&geometry, precision).unwrap();
        let timed = gpu.commit(&geometry, precision).unwrap().timed();
        assert_eq!(timed.kernel_seconds(), None, "no query yet");
        let hits = timed.intersect(&rays[..]).unwrap();
        assert_eq!(hits, plain.intersect(&rays[..]).unwrap(), "{precision:?}");
        assert_eq!(plain.kernel_seconds(), None);
        let first = timed.kernel_seconds();
        assert_eq!(first.is_some(), timestamps, "{precision:?}");
        timed.occluded(&rays[..], 0.0, 1e9).unwrap();
        if let (Some(first), Some(both)) = (first, timed.kernel_seconds()) {
            assert!(first > 0.0 && both > first && both < 60.0, "{first} {both}");
        }
    }
    let cpu = raycast::Cpu
        .commit(&geometry, raycast::Precision::F64)
        .unwrap()
        .timed();
    cpu.intersect(&rays[..]).unwrap();
    assert_eq!(cpu.kernel_seconds(), None);
}
