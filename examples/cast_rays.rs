//! Cast rays at a mesh held in memory: build the geometry, commit it to a device once, then
//! query it as often as needed.
//!
//!     cargo run --example cast_rays

use raycast::{Cpu, DVec3, Geometry, Gpu, Precision, Ray};

fn main() -> raycast::Result<()> {
    // A unit cube as 12 triangles, and a sphere beside it.
    let vertices: Vec<DVec3> = (0..8)
        .map(|k| DVec3::from([k & 1, (k >> 1) & 1, (k >> 2) & 1].map(|c| c as f64)))
        .collect();
    let triangles = [
        // The faces z = 0 and z = 1.
        [0, 2, 1],
        [1, 2, 3],
        [4, 5, 6],
        [5, 7, 6],
        // y = 0 and y = 1.
        [0, 1, 4],
        [1, 5, 4],
        [2, 6, 3],
        [3, 6, 7],
        // x = 0 and x = 1.
        [0, 4, 2],
        [2, 4, 6],
        [1, 3, 5],
        [3, 7, 5],
    ];
    let mut geometry = Geometry::new();
    let cube = geometry.add_mesh(&vertices, &triangles)?;
    let sphere = geometry.add_sphere([3.0, 0.5, 0.5], 0.5)?;

    // Rays along x: through both, from between them, and one that misses.
    let along_x = |origin| Ray {
        origin,
        direction: DVec3::X,
    };
    let rays = [
        along_x(DVec3::new(-1.0, 0.3, 0.6)),
        along_x(DVec3::new(2.0, 0.3, 0.6)),
        along_x(DVec3::new(-1.0, 5.0, 0.6)),
    ];

    // Commit builds the BVH and uploads it once; every query reuses it.
    let gpu = Gpu::new()?;
    let accel = gpu.commit(&geometry, Precision::F32)?;
    let hits = accel.intersect(&rays[..])?;
    let t = hits.t_f64();
    for (k, id) in hits.id().iter().enumerate() {
        println!("ray {k}: object {id} at t = {}", t[k]);
    }
    assert_eq!(hits.id(), [cube as i32, sphere as i32, -1]);
    assert_eq!(t[0], 1.0); // the cube's face at x = 0, one unit along

    // How many surfaces each ray crosses (the cube's two faces and the sphere's two sides),
    // and shadow-ray tests: is anything hit with t_near <= t <= t_far?
    assert_eq!(accel.count(&rays[..])?, [4, 2, 0]);
    assert_eq!(accel.occluded(&rays[..], 0.0, 0.6)?, [false, true, false]);

    // The CPU reference answers the same queries, here in f64.
    let exact = Cpu
        .commit(&geometry, Precision::F64)?
        .intersect(&rays[..])?;
    assert_eq!(exact.id(), hits.id());
    Ok(())
}
