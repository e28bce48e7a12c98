//! Traversal statistics of the BVH on a scene's primary rays (CPU, f32, robust): box tests and
//! primitive tests per ray. `RAYCAST_MEASURE="SCENE" cargo test --release -p raycast --lib bvh_stats -- --ignored --nocapture`.
use std::sync::Arc;

use raycast::Algorithm::Robust;
use raycast::cpu::traverse::{box_entry, ray_inverse};
use raycast::cpu::triangle::intersect_triangle;
use raycast::kernel::frame::camera_ray;
use raycast::kernel::types::{no_hit, shear_of};
use raycast::prepare::bvh::{Bvh, LEAF_BIT, leaf_len};
use raycast::prepare::{Primitives, kernel_frame};

#[test]
#[ignore = "a measurement: RAYCAST_MEASURE=\"ARGS\" cargo test --release -p raycast --lib bvh_stats -- --ignored --nocapture"]
fn bvh_stats() {
    let path = super::args()
        .into_iter()
        .next()
        .expect("RAYCAST_MEASURE=\"SCENE\"");
    let scene = raycast::Scene::load(path.as_ref()).unwrap();
    let bvh = Arc::new(Bvh::build(&scene, Robust));
    let prims = Primitives::<f32>::with_bvh(&scene, Robust, bvh.clone());
    let frame = kernel_frame(&scene, Robust).cast::<f32>();
    let (mut boxes, mut tests, mut rays, mut hits) = (0u64, 0u64, 0u64, 0u64);
    let leaves: Vec<u32> = bvh
        .nodes
        .iter()
        .flat_map(|n| [(n.reference0, n.count0), (n.reference1, n.count1)])
        .filter(|(r, _)| r & LEAF_BIT != 0)
        .map(|(_, c)| leaf_len(c))
        .collect();
    println!(
        "{} nodes, {} leaves, {:.2} triangles a leaf, depth {}",
        bvh.nodes.len(),
        leaves.len(),
        leaves.iter().sum::<u32>() as f64 / leaves.len() as f64,
        bvh.depth()
    );
    for i in (0..frame.ny).step_by(4) {
        for j in (0..frame.nx).step_by(4) {
            let ray = camera_ray(&frame, i, j);
            let ri = ray_inverse(&ray);
            let shear = shear_of(ray.direction);
            let mut best = f32::MAX;
            let mut stack = vec![(0u32, 0f32)];
            rays += 1;
            while let Some((node, t_entry)) = stack.pop() {
                if t_entry > best {
                    continue;
                }
                let n = &bvh.nodes[node as usize];
                let mut next = Vec::new();
                for (lo, hi, r, c) in [
                    (n.lo0, n.hi0, n.reference0, n.count0),
                    (n.lo1, n.hi1, n.reference1, n.count1),
                ] {
                    boxes += 1;
                    let t = box_entry(lo, hi, &ray, &ri, frame.min_t, best);
                    if t == no_hit::<f32>() {
                        continue;
                    }
                    if r & LEAF_BIT != 0 {
                        let first = r & !LEAF_BIT;
                        for k in first..first + leaf_len(c) {
                            tests += 1;
                            let th = intersect_triangle::<f32, true>(
                                &ray,
                                &shear,
                                &prims.triangles[k as usize],
                                frame.min_t,
                            );
                            if th != no_hit::<f32>() && th < best {
                                best = th;
                            }
                        }
                    } else {
                        next.push((r, t));
                    }
                }
                next.sort_by(|a, b| b.1.total_cmp(&a.1));
                stack.extend(next);
            }
            hits += u64::from(best < f32::MAX);
        }
    }
    println!(
        "{rays} rays ({:.1}% hit): {:.1} box tests, {:.1} triangle tests a ray",
        100.0 * hits as f64 / rays as f64,
        boxes as f64 / rays as f64,
        tests as f64 / rays as f64
    );
}
