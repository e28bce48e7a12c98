//! One `Gpu` shared by 8 threads, each rendering a different scene (and mode), gives exactly the
//! images of the same renders one after another.

use super::common;

use common::{COURSE_SCENES, course_scene};
use raycast::Mode;
use raycast::gpu::Gpu;
use raycast::render::{self, AnyImages};

/// The eight renders: the six course scenes and two more modes of the bunny, at a small size.
fn renders() -> Vec<(raycast::Scene, Mode)> {
    let mut list: Vec<(raycast::Scene, Mode)> = COURSE_SCENES
        .iter()
        .map(|name| (course_scene(name), "gpu:f32:robust".parse().unwrap()))
        .collect();
    list.push((course_scene("bunny"), "gpu:f64:robust".parse().unwrap()));
    list.push((
        course_scene("bunny"),
        "gpu:adaptive:robust".parse().unwrap(),
    ));
    for (scene, _) in &mut list {
        scene.camera.resolution = [160, 90];
    }
    list
}

/// The images' bits: ids, and distances and normals as raw bits (NaN-safe).
fn bits(images: &AnyImages) -> (Vec<i32>, Vec<u64>) {
    let id = images.id().to_vec();
    let reals = match images {
        AnyImages::F32(i) => i
            .distance
            .iter()
            .chain(i.normal.iter().flatten())
            .map(|x| x.to_bits() as u64)
            .collect(),
        AnyImages::F64(i) => i
            .distance
            .iter()
            .chain(i.normal.iter().flatten())
            .map(|x| x.to_bits())
            .collect(),
    };
    (id, reals)
}

#[test]
fn eight_threads_sharing_one_gpu_render_what_serial_renders_do() {
    let list = renders();
    assert_eq!(list.len(), 8);
    let serial_gpu = Gpu::new().unwrap();
    let serial: Vec<_> = list
        .iter()
        .map(|(scene, mode)| bits(&render::render(scene, *mode, Some(&serial_gpu), None).unwrap()))
        .collect();
    // A fresh device, so that the first round's threads compile their pipelines side by side
    // (the bunny's three modes and the six scenes' kernels); the second finds them compiled.
    let gpu = Gpu::new().unwrap();
    for _ in 0..2 {
        let parallel: Vec<_> = std::thread::scope(|s| {
            let handles: Vec<_> = list
                .iter()
                .map(|(scene, mode)| {
                    let gpu = &gpu;
                    s.spawn(move || bits(&render::render(scene, *mode, Some(gpu), None).unwrap()))
                })
                .collect();
            handles.into_iter().map(|h| h.join().unwrap()).collect()
        });
        for (k, (a, b)) in serial.iter().zip(&parallel).enumerate() {
            assert!(a == b, "render {k} differs when run beside the others");
        }
    }
}
