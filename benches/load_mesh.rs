//! Mesh loading speed: loads each file N times with `raycast::load_mesh` and prints the
//! triangle count, file size and the best and median wall times (the best is the least disturbed
//! by other load on the machine; the file is in the page cache after the first run).
//!
//!     cargo run --release -p raycast-benches --bin load_mesh -- MESH... [--runs N]

use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut runs = 5;
    if let Some(i) = args.iter().position(|a| a == "--runs") {
        runs = args.get(i + 1).ok_or("--runs N")?.parse()?;
        args.drain(i..i + 2);
    }
    println!("| file | triangles | MB | best s | median s | Mtri/s (best) |");
    println!("|---|---|---|---|---|---|");
    for path in &args {
        let bytes = std::fs::metadata(path)?.len();
        let mut seconds = Vec::new();
        let mut triangles = 0;
        for _ in 0..runs.max(1) {
            let start = Instant::now();
            triangles = raycast::load_mesh(path.as_ref())?.len();
            seconds.push(start.elapsed().as_secs_f64());
        }
        seconds.sort_by(f64::total_cmp);
        let best = seconds[0];
        println!(
            "| {path} | {triangles} | {:.1} | {best:.3} | {:.3} | {:.1} |",
            bytes as f64 / 1e6,
            seconds[seconds.len() / 2],
            triangles as f64 / best / 1e6,
        );
    }
    Ok(())
}
