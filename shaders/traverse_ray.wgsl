// Per-ray traversal (RAY_BY_RAY): each ray walks the BVH on its own (traverse_bvh), where no
// packets are (hardware GPUs, casts of few rays for their primitives, listed pixels, counts,
// closest points) or a hook's ray is cast without its whole subgroup. CPU mirror:
// src/cpu/traverse.rs.
#import types
#import bindings
#import hit
#import traverse

// Ordered traversal: of two children hit, leaves are tested and the nearer inner node is
// visited first, the farther one waiting on a short stack with its entry distance, skipped
// when popped if a hit nearer than that entry has been found. Written as two loops (Aila and
// Laine's while-while): nodes until one has a leaf the ray enters, then that node's leaves, so
// the lanes of a subgroup, which reach leaves at different steps, wait for each other and test
// their leaves together rather than each lane's leaf loop stalling the others at every node.
// The nodes and primitives, and their order, are those of one loop doing both.
fn traverse_bvh(ray: Ray, min_t: real, best: ptr<function, Hit>) {
    let ri = ray_inverse(ray);
    let shear = shear_of(ray.direction);
    var stack_node: array<u32, BVH_STACK>;
    var stack_t: array<real, BVH_STACK>;
    var sp = 0u;
    var node = 0u;
    loop {
        var n: Visit;
        var run: LeafRun;
        loop {
            n = visit(node, ray, ri, min_t, cull_t(*best));
            run = leaf_run(n, n.t0 != NO_HIT && is_leaf(n.reference0), n.t1 != NO_HIT && is_leaf(n.reference1));
            if (run.length != 0u || !next_node(n, *best, &stack_node, &stack_t, &sp, &node)) {
                break;
            }
        }
        if (run.length == 0u) {
            break;
        }
        for (var i = 0u; i < run.length; i++) {
            intersect_primitive(ray, shear, min_t, run_primitive(run, i), select(n.count0, n.count1, in_leaf1(run, i)), best);
        }
        if (!next_node(n, *best, &stack_node, &stack_t, &sp, &node)) {
            break;
        }
    }
}

// Where a ray goes after visiting `n` and testing its leaves: to the inner child it enters
// before `best`, the nearer where both (the other pushed on the stack with its entry
// distance), else to the next waiting node it may still reach. Sets `node`; false when no node
// is left.
fn next_node(n: Visit, best: Hit, stack_node: ptr<function, array<u32, BVH_STACK>>, stack_t: ptr<function, array<real, BVH_STACK>>, sp: ptr<function, u32>, node: ptr<function, u32>) -> bool {
    let go0 = n.t0 != NO_HIT && !is_leaf(n.reference0) && n.t0 <= cull_t(best);
    let go1 = n.t1 != NO_HIT && !is_leaf(n.reference1) && n.t1 <= cull_t(best);
    if (go0 && go1) {
        let first0 = n.t0 <= n.t1;
        (*stack_node)[*sp] = select(n.reference0, n.reference1, first0);
        (*stack_t)[*sp] = select(n.t0, n.t1, first0);
        *sp += 1u;
        *node = select(n.reference1, n.reference0, first0);
        return true;
    }
    if (go0) {
        *node = n.reference0;
        return true;
    }
    if (go1) {
        *node = n.reference1;
        return true;
    }
    while (*sp > 0u) {
        *sp -= 1u;
        if ((*stack_t)[*sp] <= cull_t(best)) {
            *node = (*stack_node)[*sp];
            return true;
        }
    }
    return false;
}
