//! Where a BVH starts to pay: random spheres, and random triangles, n = 2 .. 256, rendered at
//! 640x360 by the brute-force and the BVH kernels (GPU, f32, robust), interleaved, median of
//! five GPU times each (`raycast_cli::study::specializations::crossover`, also a section of
//! `raycast specializations`). `cargo run --release -p raycast-benches --bin bvh_crossover`.

fn main() {
    let gpu = raycast::Gpu::new().unwrap();
    let rows = raycast_cli::study::specializations::crossover(&gpu, 5, |_, _| {}).unwrap();
    print!(
        "{}",
        raycast_cli::study::specializations::crossover_table(&rows)
    );
    for kind in ["spheres", "triangles"] {
        let from = raycast_cli::study::specializations::measured_crossover(&rows, kind);
        println!("BVH faster from n = {from:?} {kind}");
    }
}
