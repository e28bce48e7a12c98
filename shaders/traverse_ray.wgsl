// Per-ray traversal (RAY_BY_RAY): each ray walks the BVH on its own (traverse_bvh), where no
// packets are (no subgroups, listed pixels, counts, closest points) or a hook's ray is cast
// without its whole subgroup. CPU mirror: src/cpu/traverse.rs.
#import types
#import bindings
#import hit
#import traverse

// Ordered traversal: of two children hit, leaves are tested at once and the nearer inner node
// is visited first, the farther one waiting on a short stack with its entry distance, skipped
// when popped if a hit nearer than that entry has been found.
fn traverse_bvh(ray: Ray, min_t: real, best: ptr<function, Hit>) {
    let ri = ray_inverse(ray);
    let shear = shear_of(ray.direction);
    var stack_node: array<u32, BVH_STACK>;
    var stack_t: array<real, BVH_STACK>;
    var sp = 0u;
    var node = 0u;
    loop {
        let n = visit(node, ray, ri, min_t, cull_t(*best));
        let t0 = n.t0;
        let t1 = n.t1;
        let leaf0 = (n.reference0 & LEAF_BIT) != 0u;
        let leaf1 = (n.reference1 & LEAF_BIT) != 0u;
        if (t0 != NO_HIT && leaf0) {
            intersect_leaf(ray, shear, min_t, n.reference0 & ~LEAF_BIT, n.count0, best);
        }
        if (t1 != NO_HIT && leaf1) {
            intersect_leaf(ray, shear, min_t, n.reference1 & ~LEAF_BIT, n.count1, best);
        }
        let go0 = t0 != NO_HIT && !leaf0 && t0 <= cull_t(*best);
        let go1 = t1 != NO_HIT && !leaf1 && t1 <= cull_t(*best);
        if (go0 && go1) {
            let first0 = t0 <= t1;
            stack_node[sp] = select(n.reference0, n.reference1, first0);
            stack_t[sp] = select(t0, t1, first0);
            sp++;
            node = select(n.reference1, n.reference0, first0);
        } else if (go0) {
            node = n.reference0;
        } else if (go1) {
            node = n.reference1;
        } else {
            var next = false;
            while (sp > 0u) {
                sp--;
                if (stack_t[sp] <= cull_t(*best)) {
                    node = stack_node[sp];
                    next = true;
                    break;
                }
            }
            if (!next) {
                break;
            }
        }
    }
}
