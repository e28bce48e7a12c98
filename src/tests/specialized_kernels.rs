//! Kernels compiled for only the primitive kinds a scene has render exactly like the general
//! kernel (every kind compiled in), for every combination of kinds, both algorithm sets and
//! both precisions. (That the specialized kernel contains no code for absent kinds is checked
//! on the naga module in `src/gpu/shader/variant.rs`.)

use super::common;

use std::path::Path;

use raycast::Algorithm::{Robust, Textbook};
use raycast::gpu::shader::{Kinds, Variant};
use raycast::math::Float;
use raycast::scene::{MeshPart, Scene};

const OBJECTS: [&str; 4] = [
    r#"{"type": "sphere", "center": [0.3, 0.1, -3], "radius": 0.6}"#,
    r#"{"type": "plane", "point": [0, -0.5, 0], "normal": [0, 1, 0.2]}"#,
    r#"{"type": "triangle", "corners": [[-1, -0.2, -2.5], [0.2, -0.3, -2], [-0.5, 0.8, -3]]}"#,
    r#"{"type": "soup", "obj": "mesh.obj"}"#,
];

fn scene(objects: &[&str]) -> Scene {
    let json = format!(
        r#"{{"camera": {{"eye": [0, 0, 1], "look": [0, 0, -1], "up": [0, 1, 0],
            "focal_length": 1, "width": 1.6, "height": 1.2, "resolution": [48, 36]}},
            "objects": [{}]}}"#,
        objects.join(",")
    );
    Scene::from_json(&json, Path::new("kinds.json"), &mut |_, _| {
        Ok(MeshPart::whole(common::sphere_mesh(
            [-0.6, 0.2, -4.0],
            0.8,
            8,
            6,
        )))
    })
    .unwrap()
}

#[test]
fn specialized_kernels_render_like_the_general_one() {
    let gpu = common::gpu();
    for bits in 0..16u32 {
        let objects: Vec<&str> = (0..4)
            .filter(|k| bits & (1 << k) != 0)
            .map(|k| OBJECTS[k])
            .collect();
        let scene = scene(&objects);
        let kinds = Kinds::of_scene(&scene);
        for algorithm in [Textbook, Robust] {
            let special32 = super::kernels::gpu_scene::<f32>(gpu, &scene, algorithm).unwrap();
            let general = Variant {
                as_given: true,
                ..gpu.variant(Float::F32, algorithm)
            };
            assert_eq!(general.kinds, Kinds::ALL);
            let general32 = super::kernels::gpu_variant::<f32>(gpu, &scene, general).unwrap();
            assert_eq!(special32, general32, "f32 {algorithm} {kinds:?}");
            let special64 = super::kernels::gpu_scene::<f64>(gpu, &scene, algorithm).unwrap();
            let general = Variant {
                as_given: true,
                ..gpu.variant(Float::F64, algorithm)
            };
            let general64 = super::kernels::gpu_variant::<f64>(gpu, &scene, general).unwrap();
            assert_eq!(special64, general64, "f64 {algorithm} {kinds:?}");
        }
        if bits == 0 {
            assert!(!kinds.any());
        }
    }
}

/// Loops over the planes to a constant (`CONSTANT_PLANES`, up to `MAX_CONSTANT_PLANES` planes)
/// and to `params.plane_count` (more) find what the CPU finds: the f32 render bit for bit and
/// the f64 ids, in both algorithm sets, each plane's object id among other objects'.
#[test]
fn plane_loops_of_a_constant_count_and_of_any_count_agree_with_the_cpu() {
    use raycast::gpu::shader::MAX_CONSTANT_PLANES;
    use raycast::prepare::bvh::Search;
    let gpu = common::gpu();
    for n in [MAX_CONSTANT_PLANES, MAX_CONSTANT_PLANES + 1] {
        // Planes tilted every which way behind a sphere, so that each is nearest somewhere.
        let planes: Vec<String> = (0..n)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / n as f64;
                let normal = [a.cos(), a.sin(), 2.5];
                let point = [0.4 * a.cos(), 0.4 * a.sin(), -6.0 - 0.1 * k as f64];
                format!(r#"{{"type": "plane", "point": {point:?}, "normal": {normal:?}}}"#)
            })
            .collect();
        let mut objects: Vec<&str> = vec![OBJECTS[0]];
        objects.extend(planes.iter().map(String::as_str));
        objects.push(OBJECTS[2]);
        let scene = scene(&objects);
        let variant = gpu.scene_variant(&scene, Float::F32, Robust);
        let specialized = raycast::gpu::shader::Variant {
            planes: 0,
            ..variant
        }
        .with_planes(n);
        let constant = n <= MAX_CONSTANT_PLANES;
        assert_eq!(specialized.defines().contains(&"CONSTANT_PLANES"), constant);
        for algorithm in [Textbook, Robust] {
            let what = format!("{n} planes, {algorithm}");
            let gpu32 = super::kernels::gpu_scene::<f32>(gpu, &scene, algorithm).unwrap();
            let cpu32 = raycast::cpu::render_with::<f32>(&scene, algorithm, Search::Auto);
            common::assert_same_bits(&gpu32, &cpu32, &what);
            let ids: std::collections::BTreeSet<i32> = gpu32.id.iter().copied().collect();
            assert!(ids.len() >= n, "{what}: only {ids:?} seen");
            let gpu64 = super::kernels::gpu_scene::<f64>(gpu, &scene, algorithm).unwrap();
            let cpu64 = raycast::cpu::render_with::<f64>(&scene, algorithm, Search::Auto);
            assert_eq!(gpu64.id, cpu64.id, "{what} f64 ids");
        }
    }
}
