//! Mirror of shaders/traverse_packet.wgsl `traverse_bvh_packet`, for the GPU cost model (feature
//! `model`) and its tests: a subgroup's rays walk the BVH together, one node at a time for all of
//! them, each ray culling with its own nearest hit, so each ends with the per-ray traversal's
//! answer ([`super::traverse::traverse_bvh`]) by a longer path.

use super::hit::Hit;
use super::traverse::{
    RayInverse, Trail, cull_t, intersect_primitive, is_leaf, ray_inverse, visit,
};
use crate::kernel::types::{Ray, Shear, no_hit, shear_of};
use crate::math::Real;
use crate::prepare::Primitives;
use crate::prepare::bvh::{BvhNode, LEAF_BIT, MAX_DEPTH, leaf_len};

/// The lanes of a packet as a bit mask (at most 64 rays).
type Lanes = u64;

fn count(lanes: Lanes) -> u32 {
    lanes.count_ones()
}

/// Packet traversal of `rays` (a subgroup's, one a lane) with their nearest hits `best`, as
/// the kernel's: a node is visited when any ray wants it (a popped one without checking), a
/// leaf child is entered when any ray's box test hits it and its primitives are tested by the
/// rays that hit it, and of two inner children wanted the one more rays prefer goes first (ties
/// to child 0), the other waiting on the packet's stack. `trail` hears each node with the rays
/// that wanted it and each leaf with the rays that test it.
pub(crate) fn traverse_bvh_packet<T: Real, const ROBUST: bool>(
    rays: &[Ray<T>],
    min_t: T,
    prims: &Primitives<T>,
    nodes: &[BvhNode],
    best: &mut [Hit<T>],
    trail: &mut impl Trail,
) {
    assert!(rays.len() <= 64 && rays.len() == best.len());
    let inverse: Vec<RayInverse<T>> = rays.iter().map(ray_inverse).collect();
    let shear: Vec<Shear<T>> = rays.iter().map(|r| shear_of(r.direction)).collect();
    let all: Lanes = if rays.len() == 64 {
        !0
    } else {
        (1 << rays.len()) - 1
    };
    let mut stack: Vec<(u32, Lanes)> = Vec::with_capacity(MAX_DEPTH);
    let (mut node, mut wanted) = (0u32, all);
    let mut t = vec![(no_hit::<T>(), no_hit::<T>()); rays.len()];
    loop {
        trail.node(node, count(wanted));
        let n = &nodes[node as usize];
        for (l, ray) in rays.iter().enumerate() {
            let v = visit(nodes, node, ray, &inverse[l], min_t, cull_t(&best[l]));
            t[l] = (v.t0, v.t1);
        }
        let leaf0 = is_leaf(n.reference0);
        let leaf1 = is_leaf(n.reference1);
        let hits0 = lanes_where(rays.len(), |l| t[l].0 != no_hit());
        let hits1 = lanes_where(rays.len(), |l| t[l].1 != no_hit());
        let leaves = [
            (leaf0, hits0, n.reference0, n.count0),
            (leaf1, hits1, n.reference1, n.count1),
        ];
        for (child, &(leaf, hits, reference, count_word)) in leaves.iter().enumerate() {
            if !leaf || hits == 0 {
                continue;
            }
            let first = reference & !LEAF_BIT;
            trail.leaf(child, first, count_word, count(hits));
            for k in first..first + leaf_len(count_word) {
                for l in lanes(hits) {
                    let (ray, shear) = (&rays[l], &shear[l]);
                    intersect_primitive::<T, ROBUST>(
                        ray,
                        shear,
                        min_t,
                        prims,
                        k,
                        count_word,
                        &mut best[l],
                    );
                }
            }
        }
        let want0 = lanes_where(rays.len(), |l| {
            !leaf0 && t[l].0 != no_hit() && t[l].0 <= cull_t(&best[l])
        });
        let want1 = lanes_where(rays.len(), |l| {
            !leaf1 && t[l].1 != no_hit() && t[l].1 <= cull_t(&best[l])
        });
        let prefer0 = lanes(want0)
            .filter(|&l| want1 & (1 << l) == 0 || t[l].0 <= t[l].1)
            .count();
        let prefer1 = lanes(want1)
            .filter(|&l| want0 & (1 << l) == 0 || t[l].1 < t[l].0)
            .count();
        let children = [(n.reference0, want0), (n.reference1, want1)];
        (node, wanted) = match (want0 != 0, want1 != 0) {
            (true, true) => {
                let first = if prefer0 >= prefer1 { 0 } else { 1 };
                stack.push(children[1 - first]);
                children[first]
            }
            (true, false) => children[0],
            (false, true) => children[1],
            (false, false) => match stack.pop() {
                Some(next) => next,
                None => break,
            },
        };
    }
}

/// The lanes of `n` where `f` holds.
fn lanes_where(n: usize, f: impl Fn(usize) -> bool) -> Lanes {
    (0..n).filter(|&l| f(l)).fold(0, |m, l| m | 1 << l)
}

/// The lanes in `m`, lowest first.
fn lanes(mut m: Lanes) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (m != 0).then(|| {
            let l = m.trailing_zeros() as usize;
            m &= m - 1;
            l
        })
    })
}
