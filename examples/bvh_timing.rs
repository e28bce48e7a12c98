//! Times the stages of a BVH render: `cargo run --release --example bvh_timing SCENE`.
use std::time::Instant;

fn main() {
    let path = std::env::args().nth(1).expect("usage: bvh_timing SCENE");
    let t = Instant::now();
    let scene = raycast::Scene::load(path.as_ref()).unwrap();
    println!("load {:.3} s", t.elapsed().as_secs_f64());
    let t = Instant::now();
    let bvh = raycast::bvh::Bvh::build(&scene, raycast::Algorithm::Robust);
    println!(
        "build {:.3} s, {} nodes, depth {}",
        t.elapsed().as_secs_f64(),
        bvh.nodes.len(),
        bvh.depth()
    );
    let gpu = raycast::gpu::Gpu::new().unwrap();
    for _ in 0..3 {
        let t = Instant::now();
        let (_, kernel) =
            raycast::gpu::render_timed::<f32>(&gpu, &scene, raycast::Algorithm::Robust).unwrap();
        let [w, h] = scene.camera.resolution;
        let k = kernel.unwrap_or(f64::NAN);
        println!(
            "render {:.3} s, kernel {:.3} s, {:.1} Mrays/s",
            t.elapsed().as_secs_f64(),
            k,
            (w * h) as f64 / k * 1e-6
        );
    }
}
