//! The traversal of the compressed 8-wide BVH (src/prepare/wide.rs, #62), ray by ray: the
//! reference a WGSL traversal of it is to mirror, and what the GPU cost model replays
//! (`--traversal wide`). A node's eight boxes are decoded and tested in the order the ray's
//! octant gives its slots; the children it enters, leaves and nodes alike, go onto one stack
//! with their entry distances, the nearest on top, each skipped when popped if a hit nearer
//! than its entry has been found. The same nodes' primitives as the binary tree's, boxes only
//! larger, so the same nearest hit.

use super::hit::Hit;
use super::traverse::{Trail, box_entry, cull_t, intersect_primitive, ray_inverse};
use crate::kernel::types::{Ray, no_hit, shear_of};
use crate::math::Real;
use crate::prepare::Primitives;
use crate::prepare::bvh::{LEAF_OBJECT_SHIFT, MIXED_OBJECTS};
use crate::prepare::wide::{WIDTH, WideBvh};

/// The count word a leaf's primitives are tested with: triangles, each one's object looked up
/// (a wide node has no room for its leaves' objects).
const TRIANGLE_LEAF: u32 = MIXED_OBJECTS << LEAF_OBJECT_SHIFT;

/// The ray's octant: bit `a` set where its direction's component `a` is negative. It visits
/// slot `k ^ octant` `k`-th.
fn octant<T: Real>(ray: &Ray<T>) -> usize {
    let d = ray.direction.to_array();
    (0..3).filter(|&a| d[a] < T::ZERO).map(|a| 1 << a).sum()
}

/// [`traverse_wide_traced`] without a trail.
#[cfg(test)]
pub(crate) fn traverse_wide<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
    wide: &WideBvh,
    best: &mut Hit<T>,
) {
    traverse_wide_traced::<T, ROBUST>(ray, min_t, prims, wide, best, &mut ());
}

/// The nearest hit through `wide`, telling `trail` each node visited and each leaf tested (its
/// first primitive in the wide tree's order and its length as a count word).
pub(crate) fn traverse_wide_traced<T: Real, const ROBUST: bool>(
    ray: &Ray<T>,
    min_t: T,
    prims: &Primitives<T>,
    wide: &WideBvh,
    best: &mut Hit<T>,
    trail: &mut impl Trail,
) {
    let ri = ray_inverse(ray);
    let shear = shear_of(ray.direction);
    let octant = octant(ray);
    // Waiting children, nearest last: a node, or a leaf (its first primitive and count).
    let mut stack: Vec<(Waiting, T)> = Vec::with_capacity(wide.depth * WIDTH + 1);
    let mut next = Some(0u32);
    while let Some(node) = next {
        trail.node(node, 1);
        let n = &wide.nodes[node as usize];
        let mut hits: Vec<(Waiting, T)> = Vec::with_capacity(WIDTH);
        for k in 0..WIDTH {
            let s = k ^ octant;
            if !n.used(s) {
                continue;
            }
            let (lo, hi) = n.child_box(s);
            let t = box_entry(lo, hi, ray, &ri, min_t, cull_t(best));
            if t == no_hit() {
                continue;
            }
            let child = match n.is_node(s) {
                true => Waiting::Node(n.child_node(s)),
                false => Waiting::Leaf(n.leaf(s)),
            };
            hits.push((child, t));
        }
        // Farthest first onto the stack, so that the nearest is popped first.
        hits.sort_by(|a, b| b.1.partial_cmp(&a.1).expect("entries are numbers"));
        stack.extend(hits);
        next = None;
        let mut tested = 0;
        while let Some((child, t)) = stack.pop() {
            if t > cull_t(best) {
                continue;
            }
            match child {
                Waiting::Node(c) => {
                    next = Some(c);
                    break;
                }
                Waiting::Leaf((first, count)) => {
                    trail.leaf(tested, first, count, 1);
                    tested += 1;
                    for k in first..first + count {
                        let binary = wide.primitives[k as usize];
                        intersect_primitive::<T, ROBUST>(
                            ray,
                            &shear,
                            min_t,
                            prims,
                            binary,
                            TRIANGLE_LEAF,
                            best,
                        );
                    }
                }
            }
        }
    }
}

/// A child waiting on the traversal's stack.
#[derive(Clone, Copy)]
enum Waiting {
    Node(u32),
    Leaf((u32, u32)),
}
