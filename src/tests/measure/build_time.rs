//! Times the preparation of a scene (BVH build, its collapse into the 8-wide tree of #62, then
//! the whole `Prepared::new`), `--runs` times each, and prints the medians: `RAYCAST_MEASURE="SCENE [RUNS]" cargo test --release -p raycast --lib build_time -- --ignored --nocapture`.
use std::time::Instant;

use super::median;

use raycast::prepare::Prepared;
use raycast::prepare::bvh::{Bvh, Search};
use raycast::prepare::wide::WideBvh;

#[test]
#[ignore = "a measurement: RAYCAST_MEASURE=\"ARGS\" cargo test --release -p raycast --lib build_time -- --ignored --nocapture"]
fn build_time() {
    let mut args = super::args().into_iter();
    let path = args.next().expect("RAYCAST_MEASURE=\"SCENE [RUNS]\"");
    let runs: usize = args
        .next()
        .map_or(11, |r| r.parse().expect("RUNS: a number"));
    let scene = raycast::Scene::load(path.as_ref()).unwrap();
    let (mut build, mut collapse, mut prepare) = (Vec::new(), Vec::new(), Vec::new());
    for _ in 0..runs {
        let t = Instant::now();
        let bvh = Bvh::build(&scene, raycast::Algorithm::Robust);
        build.push(t.elapsed().as_secs_f64());
        let t = Instant::now();
        let wide = WideBvh::collapse(&bvh);
        collapse.push(t.elapsed().as_secs_f64());
        drop((bvh, wide));
        let t = Instant::now();
        let p = Prepared::<f32>::new(&scene, raycast::Algorithm::Robust, Search::Auto);
        prepare.push(t.elapsed().as_secs_f64());
        drop(p);
    }
    let bvh = Bvh::build(&scene, raycast::Algorithm::Robust);
    let bytes: &[u8] = bytemuck::cast_slice(&bvh.nodes);
    let order: &[u8] = bytemuck::cast_slice(&bvh.triangle_order);
    let hash = bytes
        .iter()
        .chain(order)
        .fold(0xcbf2_9ce4_8422_2325u64, |h, b| {
            (h ^ *b as u64).wrapping_mul(0x100_0000_01b3)
        });
    let wide = WideBvh::collapse(&bvh);
    let triangles = bvh.triangle_order.len().max(1) as f64;
    println!(
        "build {:.4} s, collapse {:.4} s, prepare {:.4} s; {} nodes, hash {hash:016x}; \
         tree bytes a triangle: binary {:.2}, wide {}",
        median(&build),
        median(&collapse),
        median(&prepare),
        bvh.nodes.len(),
        bvh.bytes() as f64 / triangles,
        wide.map_or("none (spheres)".into(), |w| format!(
            "{:.2} ({} nodes, {} levels)",
            w.bytes() as f64 / triangles,
            w.nodes.len(),
            w.depth
        )),
    );
}
