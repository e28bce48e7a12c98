//! Where a BVH starts to pay: random spheres, and random triangles, n = 2 .. 256, rendered at
//! 640x360 by the brute-force and the BVH kernels (GPU, f32, robust), interleaved, median of
//! five GPU times each. `cargo run --release --example bvh_crossover`.
use std::path::Path;

use raycast::Algorithm::Robust;
use raycast::gpu::shader::Variant;
use raycast::math::{Precision, vec3};
use raycast::scene::Scene;

/// A deterministic generator (SplitMix64).
struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 = self.0.wrapping_add(0x9E37_79B9_7F4A_7C15);
        let mut z = self.0;
        z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
        z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
        ((z ^ (z >> 31)) >> 11) as f64 / (1u64 << 53) as f64
    }
    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.next()
    }
}

const CAMERA: &str = r#""camera": {"eye": [0, 0, 6], "look": [0, 0, -1], "up": [0, 1, 0],
    "focal_length": 1.5, "width": 1.6, "height": 0.9, "resolution": [640, 360]}"#;

fn spheres(n: usize, rng: &mut Rng) -> Scene {
    let objects: Vec<String> = (0..n)
        .map(|_| {
            let c = [
                rng.range(-2.0, 2.0),
                rng.range(-1.2, 1.2),
                rng.range(-2.0, 2.0),
            ];
            let r = rng.range(0.1, 0.5);
            format!(r#"{{"type": "sphere", "center": {c:?}, "radius": {r}}}"#)
        })
        .collect();
    let json = format!(r#"{{{CAMERA}, "objects": [{}]}}"#, objects.join(","));
    Scene::from_json(&json, Path::new("spheres.json"), &mut |_| unreachable!()).unwrap()
}

fn triangles(n: usize, rng: &mut Rng) -> Scene {
    let mesh: Vec<_> = (0..n)
        .map(|_| {
            let c = [
                rng.range(-2.0, 2.0),
                rng.range(-1.2, 1.2),
                rng.range(-2.0, 2.0),
            ];
            let mut corner = || {
                vec3(
                    c[0] + rng.range(-0.5, 0.5),
                    c[1] + rng.range(-0.5, 0.5),
                    c[2] + rng.range(-0.5, 0.5),
                )
            };
            [corner(), corner(), corner()]
        })
        .collect();
    let json = format!(r#"{{{CAMERA}, "objects": [{{"type": "soup", "obj": "m.obj"}}]}}"#);
    Scene::from_json(&json, Path::new("tris.json"), &mut |_| Ok(mesh.clone())).unwrap()
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let gpu = raycast::gpu::Gpu::new().unwrap();
    println!("| primitives | n | brute force ms | BVH ms | BVH / brute force |");
    println!("|---|---|---|---|---|");
    let mut rng = Rng(1);
    for kind in ["spheres", "triangles"] {
        for n in [2, 4, 8, 16, 32, 64, 128, 256] {
            let scene = if kind == "spheres" {
                spheres(n, &mut rng)
            } else {
                triangles(n, &mut rng)
            };
            let base = gpu.scene_variant(&scene, Precision::F32, Robust);
            let (mut brute, mut bvh) = (Vec::new(), Vec::new());
            for run in 0..6 {
                for (with_bvh, times) in [(false, &mut brute), (true, &mut bvh)] {
                    let v = Variant {
                        bvh: with_bvh,
                        ..base
                    };
                    let (_, s) = raycast::gpu::render_stages::<f32>(&gpu, &scene, v).unwrap();
                    if run > 0 {
                        times.push(1e3 * s.kernel_s.unwrap_or(s.trace_s));
                    }
                }
            }
            let (b, t) = (median(brute), median(bvh));
            println!("| {kind} | {n} | {b:.2} | {t:.2} | {:.2} |", t / b);
        }
    }
}
