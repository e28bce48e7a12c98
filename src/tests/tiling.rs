//! Images and meshes larger than the device's limits are split: image rows into tiles (one
//! dispatch and one readback each), triangles and BVH nodes into several storage bindings. A
//! small image forced into many tiles, and a small mesh forced into several chunks, render
//! exactly as in one piece.

use super::common;

use raycast::Algorithm::{Robust, Textbook};
use raycast::gpu::shader::{MAX_CHUNKS, Variant};
use raycast::math::Float;

#[test]
fn a_small_image_in_many_tiles_equals_one_tile() {
    let gpu = common::gpu();
    let mut bunny = common::course_scene("bunny");
    bunny.camera.resolution = [64, 37];
    for scene in [bunny, common::random_scene(3, [50, 41])] {
        for algorithm in [Robust, Textbook] {
            let variant = gpu.scene_variant(&scene, Float::F32, algorithm);
            let whole = super::kernels::gpu_variant::<f32>(gpu, &scene, variant).unwrap();
            for rows in [1, 3, 8] {
                let tiled = super::kernels::gpu_tiles::<f32>(gpu, &scene, variant, rows).unwrap();
                assert_eq!(tiled, whole, "{algorithm}, tiles of {rows} rows");
            }
            let variant = gpu.scene_variant(&scene, Float::F64, algorithm);
            let whole = super::kernels::gpu_variant::<f64>(gpu, &scene, variant).unwrap();
            let tiled = super::kernels::gpu_tiles::<f64>(gpu, &scene, variant, 5).unwrap();
            assert_eq!(tiled, whole, "{algorithm} f64");
        }
    }
}

#[test]
fn a_mesh_in_several_bindings_equals_one_binding() {
    let gpu = common::gpu();
    let mut bunny = common::course_scene("bunny");
    bunny.camera.resolution = [96, 54];
    // 1000 triangles and ~600 nodes: 256 a chunk gives four triangle chunks, 512 two.
    for (bits, chunks) in [(8, MAX_CHUNKS), (9, 2)] {
        for bvh in [true, false] {
            for algorithm in [Robust, Textbook] {
                let one = Variant {
                    bvh,
                    ..gpu.scene_variant(&bunny, Float::F32, algorithm)
                };
                assert_eq!(one.chunks, 1);
                let split = Variant {
                    chunks,
                    chunk_bits: bits,
                    ..one
                };
                let a = super::kernels::gpu_variant::<f32>(gpu, &bunny, one).unwrap();
                let b = super::kernels::gpu_variant::<f32>(gpu, &bunny, split).unwrap();
                assert_eq!(a, b, "{chunks} chunks of 2^{bits}, bvh {bvh}, {algorithm}");
                assert!(a.id.iter().any(|&id| id >= 0));
            }
        }
    }
}

#[test]
fn a_mesh_needing_more_bindings_than_the_kernel_has_is_refused() {
    let gpu = common::gpu();
    let bunny = common::course_scene("bunny");
    let too_small = Variant {
        chunks: 2,
        chunk_bits: 8,
        ..gpu.scene_variant(&bunny, Float::F32, Robust)
    };
    let err = super::kernels::gpu_variant::<f32>(gpu, &bunny, too_small).unwrap_err();
    assert!(err.to_string().contains("storage bindings"), "{err}");
}
