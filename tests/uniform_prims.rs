//! Spheres, planes and triangles in uniform buffers (`Variant::uniform_prims`) render bit for
//! bit like the same kernel reading storage buffers, by brute force and through the BVH, in
//! f32 and f64. (That the kernel declares them `var<uniform>` is checked on the naga module in
//! `src/gpu/shader.rs`.)

mod common;

use raycast::Algorithm::Robust;
use raycast::gpu::shader::Variant;
use raycast::math::Precision;

/// Renders `scene` with its own kernel and with the primitives in uniform buffers, and checks
/// the two agree exactly.
fn same_as_storage(name: &str, scene: &raycast::Scene) {
    let gpu = common::gpu();
    let storage = gpu.scene_variant(scene, Precision::F32, Robust);
    assert!(gpu.uniform_fits(scene, Precision::F32), "{name}");
    assert!(!storage.uniform_prims, "uniform memory is off by default");
    let uniform = Variant {
        uniform_prims: true,
        ..storage
    };
    let a = common::gpu_variant::<f32>(gpu, scene, storage).unwrap();
    let b = common::gpu_variant::<f32>(gpu, scene, uniform).unwrap();
    assert!(a.id.iter().any(|&id| id >= 0), "{name}: something is hit");
    assert_eq!(a, b, "f32 {name}");
    if gpu.uniform_fits(scene, Precision::F64) {
        let storage = gpu.scene_variant(scene, Precision::F64, Robust);
        let uniform = Variant {
            uniform_prims: true,
            ..storage
        };
        let a = common::gpu_variant::<f64>(gpu, scene, storage).unwrap();
        let b = common::gpu_variant::<f64>(gpu, scene, uniform).unwrap();
        assert_eq!(a, b, "f64 {name}");
    }
}

#[test]
fn course_scenes_render_the_same_from_uniform_buffers() {
    for name in [
        "inside-a-sphere",
        "sphere-and-plane",
        "sphere-packing",
        "two-spheres-and-plane",
        "triangle",
    ] {
        let mut scene = common::course_scene(name);
        scene.camera.resolution = [160, 90];
        same_as_storage(name, &scene);
    }
}

/// Spheres, a plane, loose triangles and a small closed mesh, through the BVH and by brute
/// force, f32 and f64; and the bunny, whose 1000 triangles fit in f32 only.
#[test]
fn small_meshes_render_the_same_from_uniform_buffers() {
    let gpu = common::gpu();
    let scene = common::random_scene(8, [96, 54]);
    let [spheres, planes, triangles] = scene.primitive_counts();
    assert!(spheres > 0 && planes > 0 && triangles > 100);
    for bvh in [false, true] {
        let storage = Variant {
            bvh,
            ..gpu.scene_variant(&scene, Precision::F32, Robust)
        };
        let uniform = Variant {
            uniform_prims: true,
            ..storage
        };
        let a = common::gpu_variant::<f32>(gpu, &scene, storage).unwrap();
        let b = common::gpu_variant::<f32>(gpu, &scene, uniform).unwrap();
        assert_eq!(a, b, "f32, bvh {bvh}");
        let storage = Variant {
            bvh,
            ..gpu.scene_variant(&scene, Precision::F64, Robust)
        };
        let uniform = Variant {
            uniform_prims: true,
            ..storage
        };
        let a = common::gpu_variant::<f64>(gpu, &scene, storage).unwrap();
        let b = common::gpu_variant::<f64>(gpu, &scene, uniform).unwrap();
        assert_eq!(a, b, "f64, bvh {bvh}");
    }
    let mut bunny = common::course_scene("bunny");
    bunny.camera.resolution = [96, 54];
    assert!(
        !gpu.uniform_fits(&bunny, Precision::F64),
        "1000 triangles of 72 bytes"
    );
    same_as_storage("bunny", &bunny);
}

/// A kernel forced to uniform buffers for primitives that do not fit is refused.
#[test]
fn primitives_beyond_a_uniform_binding_are_refused() {
    let gpu = common::gpu();
    let mut scene = common::course_scene("bunny");
    scene.camera.resolution = [16, 9];
    let variant = Variant {
        uniform_prims: true,
        ..gpu.scene_variant(&scene, Precision::F64, Robust)
    };
    let err = common::gpu_variant::<f64>(gpu, &scene, variant).unwrap_err();
    assert!(err.to_string().contains("uniform"), "{err}");
}
