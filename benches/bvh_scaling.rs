//! The BVH's scaling curve: tori of 10k to 5M triangles covering the same part of the screen,
//! rendered at 1920x1080 through the BVH (GPU, f32, robust), one warm-up then the median of
//! three runs. `cargo run --release -p raycast-benches --bin bvh_scaling [MAX_TRIANGLES [MIN_TRIANGLES]]`.
use std::path::Path;

use raycast::{Gpu, Precision, RenderOptions, Search, Tuning};
use raycast::{MeshPart, Scene, Triangle};

/// A torus around the z axis (radii 1 and 0.4) of 2 * nu * nv triangles.
fn torus(nu: usize, nv: usize) -> Vec<Triangle> {
    let p = |i: usize, j: usize| {
        let u = std::f64::consts::TAU * (i % nu) as f64 / nu as f64;
        let v = std::f64::consts::TAU * (j % nv) as f64 / nv as f64;
        let r = 1.0 + 0.4 * v.cos();
        [r * u.cos(), r * u.sin(), 0.4 * v.sin()].into()
    };
    let mut t = Vec::with_capacity(2 * nu * nv);
    for i in 0..nu {
        for j in 0..nv {
            t.push([p(i, j), p(i + 1, j), p(i + 1, j + 1)]);
            t.push([p(i, j), p(i + 1, j + 1), p(i, j + 1)]);
        }
    }
    t
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() {
    let max: usize = std::env::args()
        .nth(1)
        .map_or(6_000_000, |s| s.parse().expect("MAX_TRIANGLES"));
    let min: usize = std::env::args()
        .nth(2)
        .map_or(0, |s| s.parse().expect("MIN_TRIANGLES"));
    let gpu = Gpu::new().unwrap();
    println!("adapter:      {}", gpu.info().adapter.name);
    // Through the BVH, each lane casting its most rays, as the scaling was first measured.
    let options = RenderOptions {
        precision: Some(Precision::F32),
        tuning: Tuning {
            search: Search::Bvh,
            most_lane_rays: true,
            ..Tuning::default()
        },
        timed: true,
        ..RenderOptions::default()
    };
    println!("| triangles | build s | kernel s | Mrays/s | bytes/triangle | vs smallest |");
    println!("|---|---|---|---|---|---|");
    let mut first = None;
    for n in [10_000usize, 40_000, 160_000, 640_000, 2_560_000, 5_120_000] {
        if n > max {
            break;
        }
        if n < min {
            continue;
        }
        // nu = 2.5 nv keeps the cells square-ish.
        let nv = ((n as f64 / 5.0).sqrt()).round() as usize;
        let nu = n / (2 * nv);
        let json = r#"{"camera": {"eye": [0, -3, 2.5], "look": [0, 3, -2.5], "up": [0, 0, 1],
            "focal_length": 1, "height": 0.7279404685324047, "width": 1.2941163885020528,
            "resolution": [1920, 1080]}, "objects": [{"type": "soup", "obj": "torus.obj"}]}"#;
        let mesh = torus(nu, nv);
        let triangles = mesh.len();
        let scene = Scene::from_json(json, Path::new("torus.json"), &mut |_, _| {
            Ok(vec![MeshPart {
                name: String::new(),
                triangles: mesh.clone(),
            }])
        })
        .unwrap();
        drop(mesh);
        let mut builds = Vec::new();
        let mut kernels = Vec::new();
        let mut bytes = 0.0;
        for run in 0..4 {
            let images = gpu.render(&scene, &options).unwrap();
            let s = images.stages().unwrap();
            if run > 0 {
                builds.push(s.build_s);
                kernels.push(s.kernel_s.unwrap_or(s.trace_s));
            }
            bytes = s.bytes_per_triangle.unwrap();
        }
        let kernel = median(kernels);
        let base = *first.get_or_insert(kernel);
        println!(
            "| {triangles} | {:.3} | {kernel:.3} | {:.1} | {bytes:.1} | {:.2}x |",
            median(builds),
            1920.0 * 1080.0 / kernel * 1e-6,
            kernel / base
        );
    }
}
