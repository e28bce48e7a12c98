// What the BVH traversals share: the node and leaf words of the BVH built on the host
// (src/prepare/bvh.rs), the box tests, a node's visit, a leaf's primitives tested ray by ray
// and the nearest hit kept in the scene's order. The traversals, which nearest.wgsl imports
// per variant: traverse_ray.wgsl (ray by ray), traverse_packet.wgsl (a subgroup's rays
// together, one a lane) and traverse_lanes.wgsl (several a lane). CPU mirror:
// src/cpu/traverse.rs.
#import types
#import bindings
#import hit
#if SPHERES
#import sphere
#endif
#if TRIANGLES
#import triangle
#endif
#if CERTAINTY
#import certainty
#endif

// BVH_STACK, the traversal stack's entries, comes with the precision module: at least the
// tree's depth, one entry per level at most is waiting (Bvh::stack_entries in src/prepare/bvh.rs).
const LEAF_BIT: u32 = 0x80000000u;
#if INSTANCES
// Set, without LEAF_BIT, in a child's reference naming an instance (its index below):
// traverse_ray.wgsl moves the ray into the instance's mesh there.
const INSTANCE_BIT: u32 = 0x40000000u;
const NO_INSTANCE: u32 = 0xFFFFFFFFu;
// The instance whose mesh held the triangle of the nearest hit when it was found, or
// NO_INSTANCE; the hit is that instance's where its object is the hit's (placed_normal in
// nearest.wgsl). CPU mirror: Hit::instance in src/cpu/hit.rs.
var<private> hit_instance: u32;
#endif
// A leaf's count word (leaf_word in src/prepare/bvh.rs): SPHERE_LEAF, and either MANY_LEAF
// and its count, or its count in the low LEAF_COUNT bits and above them the object all its
// primitives belong to (MIXED_OBJECTS: several).
const SPHERE_LEAF: u32 = 0x80000000u;
const MANY_LEAF: u32 = 0x40000000u;
const LEAF_COUNT: u32 = 0xFu;
const LEAF_OBJECT_SHIFT: u32 = 4u;
const MIXED_OBJECTS: u32 = 0x3FFFFFFu;

fn leaf_len(count: u32) -> u32 {
    return select(count & LEAF_COUNT, count & (MANY_LEAF - 1u), (count & MANY_LEAF) != 0u);
}

fn leaf_object(count: u32) -> u32 {
    return select((count >> LEAF_OBJECT_SHIFT) & MIXED_OBJECTS, MIXED_OBJECTS, (count & MANY_LEAF) != 0u);
}
// Relative widening of every slab interval: far above the rounding of the box test, so a box
// is skipped only when the ray certainly misses it (boxes were grown on the host as well).
const BOX_SLACK: real = 1.52587890625e-5;  // 2^-16

// What the traversal needs of the ray: whether a direction component is zero (its slab is all
// or nothing: box_entry_axis_parallel) and the inverse of the nonzero ones. One flag, not the
// three components' (box_entry_axis_parallel finds those again): three masks held through the
// whole traversal, where registers are short, cost time to no use.
struct RayInverse {
    axis_parallel: bool,
    inv: vec3<real>,
}

fn ray_inverse(ray: Ray) -> RayInverse {
    let zero = ray.direction == vec3<real>(0.0);
    return RayInverse(any(zero), 1.0 / select(ray.direction, vec3<real>(1.0), zero));
}

// The smaller and the larger of a and b, written as selects: llvmpipe compiles `min` and `max`
// to three instructions each (the IEEE rule for a NaN operand), these to one. No operand here
// is a NaN: the box test divides by nonzero direction components only, and a product of a
// finite difference and a finite nonzero inverse is never one.
fn smaller(a: real, b: real) -> real {
    return select(b, a, a < b);
}

fn larger(a: real, b: real) -> real {
    return select(b, a, a > b);
}

// A box's entry distance is scaled by this before it is compared, so that a box is skipped only
// when the ray certainly misses it: each slab distance is within 3 roundings of exact, far
// below 2^-15 of it, and the boxes were grown on the host as well.
const BOX_ENTRY_SHRINK: real = 0.999969482421875;  // 1 - 2 BOX_SLACK = 1 - 2^-15

// Where the ray enters the box (shrunk by BOX_ENTRY_SHRINK, at least min_t), or NO_HIT when it
// misses the box, leaves it before min_t, or enters it beyond t_max. Each slab's near and far
// distances are the smaller and larger of its planes' (the same values as choosing the planes
// by the direction's sign, which kept three more masks live through the traversal). Selects
// and one scaling, rather than min/max and a widening of both ends, make the box test less
// than half its instructions on llvmpipe (docs/performance.md#why-packets-share-fetches-by-hand).
fn box_entry(lo: vec3<f32>, hi: vec3<f32>, ray: Ray, ri: RayInverse, min_t: real, t_max: real) -> real {
    let lo_r = vec3<real>(lo);
    let hi_r = vec3<real>(hi);
    let a = (lo_r - ray.origin) * ri.inv;
    let b = (hi_r - ray.origin) * ri.inv;
    if (ri.axis_parallel) {
        let inside = (lo_r <= ray.origin) & (ray.origin <= hi_r);
        return box_entry_axis_parallel(a, b, inside, ray.direction == vec3<real>(0.0), min_t, t_max);
    }
    let t_in = larger(larger(smaller(a.x, b.x), smaller(a.y, b.y)), larger(smaller(a.z, b.z), min_t)) * BOX_ENTRY_SHRINK;
    let t_out = smaller(smaller(larger(a.x, b.x), larger(a.y, b.y)), smaller(larger(a.z, b.z), t_max));
    return select(NO_HIT, t_in, t_in <= t_out);
}

// box_entry() for a ray with a zero direction component (`zero`): that slab holds the whole ray
// (where the origin is `inside` it) or none of it. `a` and `b` are the distances to the box's
// planes, box_entry's. Each slab interval is widened by BOX_SLACK; the entry is 0 if the ray
// starts inside.
fn box_entry_axis_parallel(a: vec3<real>, b: vec3<real>, inside: vec3<bool>, zero: vec3<bool>, min_t: real, t_max: real) -> real {
    let open = select(vec3<real>(T_FAR), vec3<real>(-T_FAR), inside);
    let t0 = select(min(a, b), open, zero);
    let t1 = select(max(a, b), -open, zero);
    var t_in = max(t0.x, max(t0.y, t0.z));
    var t_out = min(t1.x, min(t1.y, t1.z));
    t_in = t_in - BOX_SLACK * abs(t_in);
    t_out = t_out + BOX_SLACK * abs(t_out);
    if (t_in <= t_out && t_out >= min_t && t_in <= t_max) {
        return max(t_in, 0.0);
    }
    return NO_HIT;
}

// is_closer (nearest.wgsl) for a primitive stored at `index` in BVH order: ties within one object
// go to the lower index in the scene's order, as in brute force. `base` is the kind's offset in
// `objects` and `prim_order`.
fn is_closer_ordered(t: real, object: u32, index: u32, base: u32, best: Hit) -> bool {
    if (t == NO_HIT) {
        return false;
    }
    if (best.object < 0 || t < best.t) {
        return true;
    }
    if (t != best.t) {
        return false;
    }
    if (i32(object) != best.object) {
        return i32(object) < best.object;
    }
    return prim_order[base + index] < prim_order[base + best.index];
}

// The object of primitive `index` of a kind (`base`: the kind's offset in `objects`): its
// leaf's, `leaf`, where all the leaf's primitives have one, without a load per candidate (a
// loop over the lanes on llvmpipe).
fn object_of(leaf: u32, index: u32, base: u32) -> u32 {
    if (leaf != MIXED_OBJECTS) {
        return leaf;
    }
    return objects[base + index];
}

// Keeps primitive `index` of a kind (`base`: the kind's offset in `objects` and `prim_order`;
// `leaf`: its leaf's object) as the nearest hit if its `t` is closer. With CERTAINTY every
// decision is recorded, misses too; without, a miss loads nothing.
fn keep_ordered(t: real, kind: u32, index: u32, base: u32, leaf: u32, best: ptr<function, Hit>) {
#if CERTAINTY
    let object = object_of(leaf, index, base);
    let closer = is_closer_ordered(t, object, index, base, *best);
    record(t, object, closer, *best);
    if (closer) {
        *best = Hit(t, i32(object), kind, index);
    }
#else
    if (t != NO_HIT) {
        let object = object_of(leaf, index, base);
        if (is_closer_ordered(t, object, index, base, *best)) {
            *best = Hit(t, i32(object), kind, index);
        }
    }
#endif
}

// Tests primitive `k` of a leaf whose count word is `count` (its kind and object; `shear`:
// shear_of(ray.direction)).
fn intersect_primitive(ray: Ray, shear: Shear, min_t: real, k: u32, count: u32, best: ptr<function, Hit>) {
    let leaf = leaf_object(count);
    if ((count & SPHERE_LEAF) != 0u) {
#if SPHERES
        keep_ordered(intersect_sphere(ray, sphere_at(k), min_t), KIND_SPHERE, k, 0u, leaf, best);
#endif
    } else {
#if TRIANGLES
        keep_ordered(intersect_triangle(ray, shear, triangle_at(k), min_t), KIND_TRIANGLE, k, params.sphere_count + params.plane_count, leaf, best);
#endif
    }
}

// The farthest a box may start and still be searched: the nearest hit so far, and with
// CERTAINTY beyond it by that hit's error bound (cull_bound in certainty.wgsl). The CPU
// mirror, which has no certainty pass, uses best.t.
fn cull_t(best: Hit) -> real {
#if CERTAINTY
    return cull_bound(best);
#else
    return best.t;
#endif
}

// A node as the traversal sees it: where the ray enters each child's box (NO_HIT when it
// misses, leaves before min_t or enters beyond t_max) and where the children are.
struct Visit {
    t0: real,
    t1: real,
    reference0: u32,
    count0: u32,
    reference1: u32,
    count1: u32,
}

// Tests the ray against both boxes of a node given as its four vec4<u32> parts.
fn visit_parts(q0: vec4<u32>, q1: vec4<u32>, q2: vec4<u32>, q3: vec4<u32>, ray: Ray, ri: RayInverse, min_t: real, t_max: real) -> Visit {
    let t0 = box_entry(bitcast<vec3<f32>>(q0.xyz), bitcast<vec3<f32>>(q1.xyz), ray, ri, min_t, t_max);
    let t1 = box_entry(bitcast<vec3<f32>>(q2.xyz), bitcast<vec3<f32>>(q3.xyz), ray, ri, min_t, t_max);
    return Visit(t0, t1, q0.w, q1.w, q2.w, q3.w);
}

// Reads node `node` (node_words: a few wide loads) and tests the ray against both boxes.
fn visit(node: u32, ray: Ray, ri: RayInverse, min_t: real, t_max: real) -> Visit {
    let w = node_words(node);
    return visit_parts(w.q0, w.q1, w.q2, w.q3, ray, ri, min_t, t_max);
}

// Whether a child reference is a leaf's (its first primitive, with LEAF_BIT) rather than a node's.
fn is_leaf(reference: u32) -> bool {
    return (reference & LEAF_BIT) != 0u;
}

// The primitives of the leaf children a traversal tests after a visit (those of `take0`,
// `take1`: for a packet, that some ray of it enters), leaf 0's then leaf 1's, as one run that
// a single loop walks (run_primitive): the kernel then holds one site of each primitive test
// rather than one per child, which would double the two-ray kernels' code, slow to compile,
// for no faster trace. A loop over the two children around each leaf's loop, whose trip count
// is at most 2, may be unrolled, and traces slower (docs/experiments.md#eight-rays-a-lane).
struct LeafRun {
    length0: u32, // leaf 0's primitives in the run
    length: u32,
    from0: u32,   // primitive i < length0 of the run is from0 + i,
    from1: u32,   // any later one from1 + i (u32 arithmetic wraps)
}

fn leaf_run(n: Visit, take0: bool, take1: bool) -> LeafRun {
    let length0 = select(0u, leaf_len(n.count0), take0);
    let length1 = select(0u, leaf_len(n.count1), take1);
    return LeafRun(length0, length0 + length1, n.reference0 & ~LEAF_BIT, (n.reference1 & ~LEAF_BIT) - length0);
}

// Whether primitive i of `run` is leaf 1's.
fn in_leaf1(run: LeafRun, i: u32) -> bool {
    return i >= run.length0;
}

fn run_primitive(run: LeafRun, i: u32) -> u32 {
    return select(run.from0, run.from1, in_leaf1(run, i)) + i;
}
