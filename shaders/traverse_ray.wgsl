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
// With INSTANCES, a reference naming an instance moves the ray into its mesh's coordinates
// (instance_ray; t is the same) to walk its mesh's tree, and the ray is the world's again once a
// node waiting from before is popped.
fn traverse_bvh(world: Ray, min_t: real, best: ptr<function, Hit>) {
    var ray = world;
    var ri = ray_inverse(ray);
    var shear = shear_of(ray.direction);
    var stack_node: array<u32, BVH_STACK>;
    var stack_t: array<real, BVH_STACK>;
    var sp = 0u;
    var node = 0u;
#if INSTANCES
    hit_instance = NO_INSTANCE;
    var inside = NO_INSTANCE;
    var inside_object = 0u;
    var inside_sp = 0u;
#endif
    loop {
        var n: Visit;
        var run: LeafRun;
        loop {
#if INSTANCES
            if (inside != NO_INSTANCE && sp < inside_sp) {
                ray = world;
                ri = ray_inverse(ray);
                shear = shear_of(ray.direction);
                inside = NO_INSTANCE;
#if CERTAINTY
                unplace_certainty();
#endif
            }
            if ((node & INSTANCE_BIT) != 0u) {
                inside = node & ~INSTANCE_BIT;
                let instance = instance_at(inside);
                ray = instance_ray(world, instance);
                ri = ray_inverse(ray);
                shear = shear_of(ray.direction);
                inside_object = instance.object;
                inside_sp = sp;
                node = instance.root;
#if CERTAINTY
                place_certainty(world, ray, instance, *best);
#endif
            }
#endif
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
            let count = select(n.count0, n.count1, in_leaf1(run, i));
#if INSTANCES
            intersect_primitive(ray, shear, min_t, run_primitive(run, i), in_instance(count, inside, inside_object), best);
#else
            intersect_primitive(ray, shear, min_t, run_primitive(run, i), count, best);
#endif
        }
#if INSTANCES
        // Each instance is one object: a nearest hit of its object is in its mesh.
        if (inside != NO_INSTANCE && (*best).object == i32(inside_object)) {
            hit_instance = inside;
        }
#endif
        if (!next_node(n, *best, &stack_node, &stack_t, &sp, &node)) {
            break;
        }
    }
#if INSTANCES
#if CERTAINTY
    // The planes, tested after, are in the world's coordinates.
    unplace_certainty();
#endif
#endif
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
#if INSTANCES

// A leaf's count word as the traversal takes it: in an instance (`inside`), its primitives
// the instance's `object` (a mesh's leaves name object 0, whichever instance places them).
fn in_instance(count: u32, inside: u32, object: u32) -> u32 {
    let placed = (count & LEAF_COUNT) | (min(object, MIXED_OBJECTS) << LEAF_OBJECT_SHIFT);
    return select(count, placed, inside != NO_INSTANCE);
}
#endif
