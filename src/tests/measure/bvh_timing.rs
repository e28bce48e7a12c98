//! Times the stages of a render, with the BVH traversed per ray and by subgroup packets, and
//! brute force when `--brute` is given, interleaved so the figures are comparable:
//! `RAYCAST_MEASURE="SCENE [--brute]" cargo test --release -p raycast --lib bvh_timing -- --ignored --nocapture`.
use std::time::Instant;

use raycast::gpu::shader::Variant;
use raycast::math::Float;

#[test]
#[ignore = "a measurement: RAYCAST_MEASURE=\"ARGS\" cargo test --release -p raycast --lib bvh_timing -- --ignored --nocapture"]
fn bvh_timing() {
    let path = (super::args().into_iter().next()).expect("RAYCAST_MEASURE=\"SCENE [--brute]\"");
    let brute = super::args().iter().any(|a| a == "--brute");
    let t = Instant::now();
    let scene = raycast::Scene::load(path.as_ref()).unwrap();
    println!("load {:.3} s", t.elapsed().as_secs_f64());
    let t = Instant::now();
    let bvh = raycast::prepare::bvh::Bvh::build(&scene, raycast::Algorithm::Robust);
    println!(
        "build {:.3} s, {} nodes, depth {}",
        t.elapsed().as_secs_f64(),
        bvh.nodes.len(),
        bvh.depth()
    );
    let gpu = raycast::gpu::Gpu::new().unwrap();
    let base = gpu.scene_variant(&scene, Float::F32, raycast::Algorithm::Robust);
    let mut variants = vec![
        (
            "per-ray",
            Variant {
                bvh: true,
                packets: false,
                ..base
            },
        ),
        (
            "packets",
            Variant {
                bvh: true,
                packets: true,
                ..base
            },
        ),
    ];
    if super::args().iter().any(|a| a == "--probe") {
        variants.push((
            "no-f64",
            Variant {
                bvh: true,
                f64_available: false,
                ..base
            },
        ));
        let textbook = gpu.scene_variant(&scene, Float::F32, raycast::Algorithm::Textbook);
        variants.push((
            "textbook",
            Variant {
                bvh: true,
                ..textbook
            },
        ));
    }
    if brute {
        variants.push(("brute", Variant { bvh: false, ..base }));
    }
    let [w, h] = scene.camera.resolution;
    for round in 0..5 {
        for (name, variant) in &variants {
            let (_, s) =
                raycast::render::on_gpu::<f32>(&gpu, &scene, *variant, true, None).unwrap();
            let k = s.kernel_s.unwrap_or(f64::NAN);
            println!(
                "{round} {name:8} build {:.3} upload {:.3} trace {:.3} kernel {:.3} s: {:.1} Mrays/s",
                s.build_s,
                s.upload_s,
                s.trace_s,
                k,
                (w * h) as f64 / k * 1e-6
            );
        }
    }
}
