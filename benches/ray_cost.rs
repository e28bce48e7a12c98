//! Casting a list of rays through a committed `raycast::Accel`, as the Python package does: the
//! peer camera's rays (benches/peers.sh: 1920x1080 unit directions from (0, -3, 2.5) at the
//! origin, vertical fov 40) at a mesh, in each mode given. Prints the median seconds of --runs
//! casts and Mrays/s; compare with `raycast bench` on the same scene (target/bench/torus.json).
//!
//!     cargo run --release -p raycast-benches --bin ray_cost -- target/bench/torus.obj [--runs 5] [MODE...]
//!
//! How the rays are given: `--flat` as a plain list rather than an image's rows (packets of 8
//! consecutive rays instead of 4x2 tiles), `--jitter S` with each direction component moved by
//! up to S (less coherent), `--random` from random points near the torus in random directions
//! (incoherent: traced one by one).

use raycast::{Ray, RayList};
use std::time::Instant;

const WIDTH: usize = 1920;
const HEIGHT: usize = 1080;

fn peer_rays() -> Vec<Ray> {
    let eye = [0.0, -3.0, 2.5];
    let norm = |v: [f64; 3]| {
        let l = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
        v.map(|x| x / l)
    };
    let cross = |a: [f64; 3], b: [f64; 3]| {
        [
            a[1] * b[2] - a[2] * b[1],
            a[2] * b[0] - a[0] * b[2],
            a[0] * b[1] - a[1] * b[0],
        ]
    };
    let forward = norm(eye.map(|x: f64| -x));
    let right = norm(cross(forward, [0.0, 0.0, 1.0]));
    let up = cross(right, forward);
    let th = (40f64.to_radians() / 2.0).tan();
    let aspect = WIDTH as f64 / HEIGHT as f64;
    let mut rays = Vec::with_capacity(WIDTH * HEIGHT);
    for i in 0..HEIGHT {
        let y = (1.0 - 2.0 * (i as f64 + 0.5) / HEIGHT as f64) * th;
        for j in 0..WIDTH {
            let x = (2.0 * (j as f64 + 0.5) / WIDTH as f64 - 1.0) * th * aspect;
            let d = [0, 1, 2].map(|k| forward[k] + x * right[k] + y * up[k]);
            rays.push(Ray {
                origin: eye.into(),
                direction: norm(d).into(),
            });
        }
    }
    rays
}

/// Uniform numbers in [-1, 1) from a small LCG.
fn uniform(seed: u64) -> impl FnMut() -> f64 {
    let mut state = seed;
    move || {
        state = state
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        (state >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
    }
}

/// Removes `--name` (and its value, which `value` says it has) from `args`.
fn take(args: &mut Vec<String>, name: &str, value: bool) -> Option<String> {
    let i = args.iter().position(|a| a == name)?;
    let taken = if value {
        args.get(i + 1).cloned()
    } else {
        Some(String::new())
    };
    args.drain(i..(i + 1 + value as usize).min(args.len()));
    taken
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let runs: usize = take(&mut args, "--runs", true).map_or(Ok(5), |r| r.parse())?;
    let flat = take(&mut args, "--flat", false).is_some();
    let random = take(&mut args, "--random", false).is_some();
    let jitter: Option<f64> = take(&mut args, "--jitter", true)
        .map(|s| s.parse())
        .transpose()?;
    let mesh = args
        .first()
        .ok_or("usage: ray_cost MESH [MODE...]")?
        .clone();
    let modes: Vec<String> = match args.len() {
        1 => vec!["gpu:f32".into()],
        _ => args[1..].to_vec(),
    };
    let triangles = raycast::load_mesh(mesh.as_ref())?;
    let vertices: Vec<raycast::DVec3> = triangles.iter().flatten().copied().collect();
    let indices: Vec<[u32; 3]> = (0..triangles.len() as u32)
        .map(|k| [3 * k, 3 * k + 1, 3 * k + 2])
        .collect();
    let mut geometry = raycast::Geometry::new();
    geometry.add_mesh(&vertices, &indices)?;
    let gpu = raycast::Gpu::new()?;
    let mut rays = peer_rays();
    if random {
        let mut next = uniform(12345);
        for ray in rays.iter_mut() {
            ray.origin = [next() * 1.5, next() * 1.5, next() * 0.5].into();
            ray.direction = [next(), next(), next()].into();
        }
    }
    if let Some(s) = jitter {
        let mut next = uniform(777);
        for ray in rays.iter_mut() {
            ray.direction = ray.direction.map(|d| d + s * next());
        }
    }
    let list = match flat {
        true => RayList::from(&rays),
        false => RayList::image(&rays, WIDTH),
    };
    for mode in modes {
        let parsed: raycast::Mode = mode.parse()?;
        geometry.algorithm = parsed.algorithm;
        let accel = match parsed.device {
            raycast::Device::Gpu => gpu.commit(&geometry, parsed.precision)?,
            raycast::Device::Cpu => raycast::Cpu.commit(&geometry, parsed.precision)?,
        };
        accel.intersect(list)?;
        let mut seconds: Vec<f64> = (0..runs.max(1))
            .map(|_| {
                let start = Instant::now();
                accel.intersect(list).map(|_| start.elapsed().as_secs_f64())
            })
            .collect::<raycast::Result<_>>()?;
        seconds.sort_by(f64::total_cmp);
        let median = seconds[seconds.len() / 2];
        println!(
            "{mode}: {} rays, median {median:.4} s, {:.2} Mrays/s",
            rays.len(),
            rays.len() as f64 / median / 1e6
        );
    }
    Ok(())
}
