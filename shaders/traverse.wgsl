// Nearest-hit search over the spheres and triangles through the BVH built on the host
// (src/prepare/bvh.rs). CPU mirror: src/cpu/traverse.rs.
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

// Tests the `count` primitives of a leaf from `first` (`shear`: shear_of(ray.direction)).
fn intersect_leaf(ray: Ray, shear: Shear, min_t: real, first: u32, count: u32, best: ptr<function, Hit>) {
    let n = leaf_len(count);
    let leaf = leaf_object(count);
    if ((count & SPHERE_LEAF) != 0u) {
#if SPHERES
        for (var k = first; k < first + n; k++) {
            keep_ordered(intersect_sphere(ray, sphere_at(k), min_t), KIND_SPHERE, k, 0u, leaf, best);
        }
#endif
    } else {
#if TRIANGLES
        let base = params.sphere_count + params.plane_count;
        for (var k = first; k < first + n; k++) {
            keep_ordered(intersect_triangle(ray, shear, triangle_at(k), min_t), KIND_TRIANGLE, k, base, leaf, best);
        }
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

#if PACKETS
// This invocation's index in its subgroup (set by `main`).
var<private> lane: u32;
#if HOOK_RAYS
#if !EIGHT_LANES
// The invocations of this invocation's subgroup (set by `main`).
var<private> subgroup_lanes: u32;
#endif

// Whether every invocation of the subgroup is here: a hook's ray is then cast in a packet,
// where some lane with no ray of its own to cast would leave its node words unfetched.
fn subgroup_whole() -> bool {
    let here = subgroupBallot(true);
#if EIGHT_LANES
    return here.x == 0xFFu;
#else
    return countOneBits(here.x) + countOneBits(here.y) + countOneBits(here.z) + countOneBits(here.w) == subgroup_lanes;
#endif
}
#endif

// visit() for a node the whole subgroup visits (same `node` in every lane): lanes 0 to 7 each
// load two of its sixteen words (node_element: one vec2<u32>), and broadcasts hand every lane
// all of them. On llvmpipe (Mesa 25.0) a storage load whose offset is not a constant runs as a
// branchy loop of scalar loads over the lanes, even where the offset is the same in every
// lane, so this is 2 words per lane instead of 16, in one such loop. Needs subgroups of at
// least 8 invocations.
fn visit_shared(node: u32, ray: Ray, ri: RayInverse, min_t: real, t_max: real) -> Visit {
    let w = fetch_shared(node);
    return visit_parts(w.q0, w.q1, w.q2, w.q3, ray, ri, min_t, t_max);
}

// Node `node`, which the whole subgroup visits: lane l loads its words 2l and 2l + 1, and
// broadcasts from constant lanes hand every lane all sixteen (see visit_shared).
fn fetch_shared(node: u32) -> NodeWords {
    let pair = node_element(node, lane & 7u);
    let q0 = vec4<u32>(subgroupBroadcast(pair, 0u), subgroupBroadcast(pair, 1u));
    let q1 = vec4<u32>(subgroupBroadcast(pair, 2u), subgroupBroadcast(pair, 3u));
    let q2 = vec4<u32>(subgroupBroadcast(pair, 4u), subgroupBroadcast(pair, 5u));
    let q3 = vec4<u32>(subgroupBroadcast(pair, 6u), subgroupBroadcast(pair, 7u));
    return NodeWords(q0, q1, q2, q3);
}

// Whether any ray of the packet (the subgroup) has `b`, and how many. With EIGHT_LANES
// (subgroups of exactly 8 invocations, all running here: llvmpipe) by three butterfly steps of
// shuffles by a constant xor, which llvmpipe compiles to a few permutes; it compiles
// subgroupAny and subgroupAdd (Mesa 25.0) to a loop over the lanes with a branch per lane
// (docs/performance.md#why-packets-share-fetches-by-hand).
#if EIGHT_LANES
fn packet_any(b: bool) -> bool {
    return packet_count(b) != 0u;
}

fn packet_count(b: bool) -> u32 {
    return packet_sum(select(0u, 1u, b));
}

// The sum of `u` over the packet's lanes.
fn packet_sum(u: u32) -> u32 {
    let pairs = u + subgroupShuffleXor(u, 1u);
    let quads = pairs + subgroupShuffleXor(pairs, 2u);
    return quads + subgroupShuffleXor(quads, 4u);
}
#else
fn packet_any(b: bool) -> bool {
    return subgroupAny(b);
}

fn packet_count(b: bool) -> u32 {
    return packet_sum(select(0u, 1u, b));
}

fn packet_sum(u: u32) -> u32 {
    return subgroupAdd(u);
}
#endif

// The packet's stack of waiting nodes, which every lane pushes and pops together (the same
// values), held in registers, `low` and `high`: entry i in lane i % 8 of register i / 8, up
// to 40 entries (MAX_DEPTH in src/prepare/bvh.rs); in subgroups wider than 8 lanes each run
// of 8 holds a copy. llvmpipe compiles a push to a per-lane array, indexed by a count it
// cannot tell is uniform, to a scatter over the lanes and a pop to a gather, which registers
// spare (docs/performance.md#why-packets-share-fetches-by-hand).

// Puts `node` at entry `sp` (the same in every lane).
fn packet_push(low: ptr<function, vec4<u32>>, high: ptr<function, u32>, sp: u32, node: u32) {
    if ((lane & 7u) == (sp & 7u)) {
        let r = sp >> 3u;
        if (r < 4u) {
            (*low)[r] = node;
        } else {
            *high = node;
        }
    }
}

// Entry `sp` in every lane: the lane of each run of 8 holding it alone contributes to an OR
// over the run.
fn packet_entry(low: vec4<u32>, high: u32, sp: u32) -> u32 {
    let r = sp >> 3u;
    let held = select(high, low[min(r, 3u)], r < 4u);
    let mine = select(0u, held, (lane & 7u) == (sp & 7u));
    let pairs = mine | subgroupShuffleXor(mine, 1u);
    let quads = pairs | subgroupShuffleXor(pairs, 2u);
    return quads | subgroupShuffleXor(quads, 4u);
}

// Where a packet goes after a visit, given whether any of its rays wants each child (`go0`,
// `go1`): to the child wanted, or where both are, to the one more of its rays reach first
// (`votes0`, `votes1`: how many of a lane's rays do) with the other pushed (packet_step).
fn packet_next(go0: bool, go1: bool, votes0: u32, votes1: u32, reference0: u32, reference1: u32, low: ptr<function, vec4<u32>>, high: ptr<function, u32>, sp: ptr<function, u32>, node: ptr<function, u32>) -> bool {
    var first0 = true;
    if (go0 && go1) {
        first0 = packet_sum(votes0) >= packet_sum(votes1);
    }
    return packet_step(go0, go1, first0, reference0, reference1, low, high, sp, node);
}

// Where a packet goes after a visit, given whether it wants each child (`go0`, `go1`, the
// same in every lane): to the child wanted, or where both are, to child 0 if `first0`, else
// child 1, with the other pushed (`low`, `high`, `sp`: packet_push); where neither is, to the
// next waiting node. Sets `node`; false when no node is left. The pop is a loop left at once:
// llvmpipe compiled this form to faster code than an `else if (sp > 0u)` beside a `break`.
fn packet_step(go0: bool, go1: bool, first0: bool, reference0: u32, reference1: u32, low: ptr<function, vec4<u32>>, high: ptr<function, u32>, sp: ptr<function, u32>, node: ptr<function, u32>) -> bool {
    if (go0 && go1) {
        packet_push(low, high, *sp, select(reference0, reference1, first0));
        *sp += 1u;
        *node = select(reference1, reference0, first0);
    } else if (go0) {
        *node = reference0;
    } else if (go1) {
        *node = reference1;
    } else {
        var popped = false;
        while (*sp > 0u) {
            *sp -= 1u;
            *node = packet_entry(*low, *high, *sp);
            popped = true;
            break;
        }
        return popped;
    }
    return true;
}

#if !F64
#if SPHERES
// Sphere k, which the whole subgroup tests: lanes 0 to 3 load a component of its vec4 each and
// broadcasts from constant lanes hand them to every lane (as shared_triangle), where a
// shuffle by a lane index would be a loop over the lanes.
fn shared_sphere(k: u32) -> Sphere {
    let x = spheres[k][lane & 3u];
    let center = vec3<real>(subgroupBroadcast(x, 0u), subgroupBroadcast(x, 1u), subgroupBroadcast(x, 2u));
    return Sphere(center, subgroupBroadcast(x, 3u));
}
#endif
#if TRIANGLES
// Triangle k, which the whole subgroup tests: lane l loads its pair l (lanes 5 to 7 the
// fifth again), and broadcasts from constant lanes hand every lane all five: one loop of
// loads over the lanes on llvmpipe, where a shuffle by the loop's index would be a loop of
// its own and a ninth real a second loop of loads
// (docs/performance.md#why-packets-share-fetches-by-hand).
fn shared_triangle(k: u32) -> Triangle {
    let x = triangle_pair(k, min(lane & 7u, 4u));
    return triangle_of_pairs(subgroupBroadcast(x, 0u), subgroupBroadcast(x, 1u), subgroupBroadcast(x, 2u), subgroupBroadcast(x, 3u), subgroupBroadcast(x, 4u));
}
#endif
#endif

// The primitives of the leaf children a packet tests after a visit (those of `take0`,
// `take1` that some ray of it enters), leaf 0's then leaf 1's, as one run that a single loop
// walks (run_primitive): the kernel then holds one site of each primitive test rather than
// one per child, which would double the two-ray kernels' code, slow to compile, for no faster
// trace. A loop over the two children around each leaf's loop, whose trip count is at most 2,
// may be unrolled, and traces slower (docs/experiments.md#eight-rays-a-lane).
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

// Whether a lane loads primitive k of a leaf the whole subgroup enters, for its rays that want
// it (`wanted`): in f32 every lane does, spreading the subgroup's shared load (lane_sphere,
// lane_triangle: shared_sphere, shared_triangle); in f64 each lane loads what it tests: f64
// broadcasts (which Vulkan allows only with shaderSubgroupExtendedTypes) make llvmpipe's f64
// kernel slower (docs/experiments.md#tried-and-not-kept).
fn loads_primitive(wanted: bool) -> bool {
#if F64
    return wanted;
#else
    return true;
#endif
}

#if SPHERES
// Sphere k for a lane's rays: in f32 the subgroup's shared load, in f64 the lane's own.
fn lane_sphere(k: u32) -> Sphere {
#if F64
    return sphere_at(k);
#else
    return shared_sphere(k);
#endif
}
#endif
#if TRIANGLES
// lane_sphere() for triangle k.
fn lane_triangle(k: u32) -> Triangle {
#if F64
    return triangle_at(k);
#else
    return shared_triangle(k);
#endif
}
#endif

// intersect_leaf() for primitive k of a leaf (with `count`, leaf_len) the whole subgroup
// enters, tested by the lanes where `wanted`.
fn intersect_shared(ray: Ray, shear: Shear, min_t: real, k: u32, count: u32, wanted: bool, best: ptr<function, Hit>) {
    if (!loads_primitive(wanted)) {
        return;
    }
    let leaf = leaf_object(count);
    if ((count & SPHERE_LEAF) != 0u) {
#if SPHERES
        test_sphere(ray, lane_sphere(k), min_t, k, leaf, wanted, best);
#endif
    } else {
#if TRIANGLES
        test_triangle(ray, shear, lane_triangle(k), min_t, k, leaf, wanted, best);
#endif
    }
}

#if SPHERES
// Sphere k of a leaf of object `leaf`, tested by a ray that wants it.
fn test_sphere(ray: Ray, sphere: Sphere, min_t: real, k: u32, leaf: u32, wanted: bool, best: ptr<function, Hit>) {
    if (wanted) {
        keep_ordered(intersect_sphere(ray, sphere, min_t), KIND_SPHERE, k, 0u, leaf, best);
    }
}
#endif
#if TRIANGLES
// test_sphere() for triangle k.
fn test_triangle(ray: Ray, shear: Shear, tri: Triangle, min_t: real, k: u32, leaf: u32, wanted: bool, best: ptr<function, Hit>) {
    if (wanted) {
        keep_ordered(intersect_triangle(ray, shear, tri, min_t), KIND_TRIANGLE, k, params.sphere_count + params.plane_count, leaf, best);
    }
}
#endif

// Packet traversal: the rays of a subgroup walk the tree together, visiting a node when any of
// them needs it, so every node is fetched once for all of them (visit_shared). Each ray keeps
// its own nearest hit and culls with it, so the answer is the per-ray traversal's. Must be
// reached by every invocation of the subgroup together (see main in entry.wgsl). A waiting
// node is visited when popped, without checking first whether some ray still needs it: its
// boxes are tested against every ray's nearest hit anyway, and keeping each ray's entry
// distance on the stack to check cost more than the visits it saved.
fn traverse_bvh_packet(ray: Ray, min_t: real, best: ptr<function, Hit>) {
    let ri = ray_inverse(ray);
    let shear = shear_of(ray.direction);
    var stack_low = vec4<u32>(0u);
    var stack_high = 0u;
    var sp = 0u;
    var node = 0u;
    loop {
        let n = visit_shared(node, ray, ri, min_t, cull_t(*best));
        let t0 = n.t0;
        let t1 = n.t1;
        let leaf0 = (n.reference0 & LEAF_BIT) != 0u;
        let leaf1 = (n.reference1 & LEAF_BIT) != 0u;
        // Only the rays that reach a leaf test it (as per ray), but the subgroup enters it
        // together so its primitives are fetched once.
        let run = leaf_run(n, leaf0 && packet_any(t0 != NO_HIT), leaf1 && packet_any(t1 != NO_HIT));
        for (var i = 0u; i < run.length; i++) {
            let second = in_leaf1(run, i);
            intersect_shared(ray, shear, min_t, run_primitive(run, i), select(n.count0, n.count1, second), select(t0, t1, second) != NO_HIT, best);
        }
        let want0 = t0 != NO_HIT && !leaf0 && t0 <= cull_t(*best);
        let want1 = t1 != NO_HIT && !leaf1 && t1 <= cull_t(*best);
        // The child more rays reach first goes first.
        let prefer0 = want0 && (!want1 || t0 <= t1);
        let prefer1 = want1 && (!want0 || t1 < t0);
        if (!packet_next(packet_any(want0), packet_any(want1), select(0u, 1u, prefer0), select(0u, 1u, prefer1), n.reference0, n.reference1, &stack_low, &stack_high, &sp, &node)) {
            break;
        }
    }
}
#if LANES

// What the traversal needs of one of a lane's rays.
struct Traced {
    ray: Ray,
    inverse: RayInverse,
    shear: Shear,
}

fn traced(ray: Ray) -> Traced {
    return Traced(ray, ray_inverse(ray), shear_of(ray.direction));
}

// A lane's LANE_RAYS rays and their nearest hits, a field each. The code for them is written
// once per ray by the host (`#each_ray` blocks, `$r` the ray's number): llvmpipe keeps arrays
// indexed in loops over the rays in memory, which makes more rays a lane slower, not faster
// (docs/experiments.md#eight-rays-a-lane).
struct LaneRays {
#each_ray
    r$r: Ray,
#end_each
}

struct LaneHits {
#each_ray
    h$r: Hit,
#end_each
}

// Hit r and ray r of a lane's (r the same in every lane), for code that runs in a loop over the
// rays: fields chosen by branches, where an array indexed by r would be kept in memory.
fn lane_hit(hits: LaneHits, r: u32) -> Hit {
    var hit = hits.h0;
#each_ray
    if (r == $ru) {
        hit = hits.h$r;
    }
#end_each
    return hit;
}

fn lane_ray(rays: LaneRays, r: u32) -> Ray {
    var ray = rays.r0;
#each_ray
    if (r == $ru) {
        ray = rays.r$r;
    }
#end_each
    return ray;
}

// After work on each of a lane's rays in turn: with CERTAINTY, which keeps the ray worked on's
// record in private state and casts two rays a lane, the other ray's record is swapped in;
// otherwise nothing.
fn swap_rays() {
#if CERTAINTY
    swap_certainty();
#endif
}

// The packet's rays as intervals, componentwise: every ray's origin lies in [origin_lo,
// origin_hi] and the inverse of its direction (RayInverse) in [inverse_lo, inverse_hi], as
// f32 bounds (rounded outward from f64: packet_min and packet_max take f32). `unbounded` where
// some ray has a zero direction component (box_entry_axis_parallel's rays) or coordinates
// beyond INTERVAL_LIMIT, whose products might overflow: such a packet tests boxes per ray
// (is_loose), never by interval_entry.
struct PacketInterval {
    origin_lo: vec3<f32>,
    origin_hi: vec3<f32>,
    inverse_lo: vec3<f32>,
    inverse_hi: vec3<f32>,
    unbounded: bool,
}

const INTERVAL_LIMIT: real = 1e30;
const F32_MAX: f32 = 3.40282347e+38;

// A lane's part of PacketInterval: the bounds over its rays so far, joined ray by ray.
fn ray_interval(ray: Ray, ri: RayInverse) -> PacketInterval {
    let wild = ri.axis_parallel || any(abs(ri.inv) > vec3<real>(INTERVAL_LIMIT)) || any(abs(ray.origin) > vec3<real>(INTERVAL_LIMIT));
    return PacketInterval(f32_below(ray.origin), f32_above(ray.origin), f32_below(ri.inv), f32_above(ri.inv), wild);
}

fn join_intervals(a: PacketInterval, b: PacketInterval) -> PacketInterval {
    return PacketInterval(min(a.origin_lo, b.origin_lo), max(a.origin_hi, b.origin_hi), min(a.inverse_lo, b.inverse_lo), max(a.inverse_hi, b.inverse_hi), a.unbounded || b.unbounded);
}

// The lanes' intervals joined over the packet.
fn packet_interval(lane_interval: PacketInterval) -> PacketInterval {
    let i = lane_interval;
    return PacketInterval(packet_min(i.origin_lo), packet_max(i.origin_hi), packet_min(i.inverse_lo), packet_max(i.inverse_hi), packet_any(i.unbounded));
}

// The smallest and the largest of `v` over the packet's lanes (three butterfly steps, as
// packet_sum).
fn packet_min(v: vec3<f32>) -> vec3<f32> {
    let pairs = min(v, subgroupShuffleXor(v, 1u));
    let quads = min(pairs, subgroupShuffleXor(pairs, 2u));
    return min(quads, subgroupShuffleXor(quads, 4u));
}

fn packet_max(v: vec3<f32>) -> vec3<f32> {
    let pairs = max(v, subgroupShuffleXor(v, 1u));
    let quads = max(pairs, subgroupShuffleXor(pairs, 2u));
    return max(quads, subgroupShuffleXor(quads, 4u));
}

// f32 bounds of a `real` below and above it: itself in f32 kernels; in f64 its nearest f32
// moved outward by 2^-22 of itself (at least two of its ulps) and 1e-37, where it is beyond.
#if F64
fn f32_below(x: vec3<real>) -> vec3<f32> {
    let y = vec3<f32>(x);
    return select(y, y - abs(y) * 2.384185791015625e-7 - vec3<f32>(1e-37), vec3<real>(y) > x);
}

fn f32_above(x: vec3<real>) -> vec3<f32> {
    let y = vec3<f32>(x);
    return select(y, y + abs(y) * 2.384185791015625e-7 + vec3<f32>(1e-37), vec3<real>(y) < x);
}
#else
fn f32_below(x: vec3<real>) -> vec3<f32> {
    return x;
}

fn f32_above(x: vec3<real>) -> vec3<f32> {
    return x;
}
#endif

// The farthest any ray of the packet searches (the largest of its rays' cull_t: `lane_cull`
// is the largest of a lane's).
fn packet_cull(lane_cull: real) -> real {
    return real(packet_max(f32_above(vec3<real>(lane_cull))).x);
}

// The smaller and the larger of a and b componentwise, as `smaller` and `larger`.
fn smaller3(a: vec3<real>, b: vec3<real>) -> vec3<real> {
    return select(b, a, a < b);
}

fn larger3(a: vec3<real>, b: vec3<real>) -> vec3<real> {
    return select(b, a, a > b);
}

// box_entry() for the whole packet: where its rays enter the box at the earliest, or NO_HIT
// when box_entry() is NO_HIT for every ray whose t_max is at most `t_max` (packet_cull).
// Exact, not approximately so: each slab distance a ray computes, (plane - origin) * inverse
// rounded twice, is monotonic in the origin and in the inverse, so it lies between the
// smallest and the largest of the same expression at the intervals' corners; box_entry's
// entry and exit, the larger and smaller of such distances (and scaled by a positive constant),
// are then bounded by the corners' too. One such test per child and visit instead of each
// ray's own (docs/performance.md#packet-intervals). The camera's rays all start at the
// kernel's origin (RAYS_FROM_ORIGIN), so two of each plane's four products are the same.
fn interval_entry(lo: vec3<f32>, hi: vec3<f32>, packet: PacketInterval, min_t: real, t_max: real) -> real {
    let o_lo = vec3<real>(packet.origin_lo);
    let o_hi = vec3<real>(packet.origin_hi);
    let i_lo = vec3<real>(packet.inverse_lo);
    let i_hi = vec3<real>(packet.inverse_hi);
    let a_lo = vec3<real>(lo) - o_hi;
    let a_hi = vec3<real>(lo) - o_lo;
    let b_lo = vec3<real>(hi) - o_hi;
    let b_hi = vec3<real>(hi) - o_lo;
    let a = array(a_lo * i_lo, a_lo * i_hi, a_hi * i_lo, a_hi * i_hi);
    let b = array(b_lo * i_lo, b_lo * i_hi, b_hi * i_lo, b_hi * i_hi);
    let near = smaller3(smaller3(smaller3(a[0], a[1]), smaller3(a[2], a[3])), smaller3(smaller3(b[0], b[1]), smaller3(b[2], b[3])));
    let far = larger3(larger3(larger3(a[0], a[1]), larger3(a[2], a[3])), larger3(larger3(b[0], b[1]), larger3(b[2], b[3])));
    let t_in = larger(larger(near.x, near.y), larger(near.z, min_t)) * BOX_ENTRY_SHRINK;
    let t_out = smaller(smaller(far.x, far.y), smaller(far.z, t_max));
    return select(NO_HIT, t_in, t_in <= t_out);
}

// Whether a packet's interval culls too little to test boxes by: where its rays' direction
// components straddle zero on an axis, their inverses span from large negative to large
// positive values and that axis's slab bounds nothing, so a packet through the middle of a view
// along an axis (or of rays jittered about it) would visit every box its other axes allow. Such
// a packet tests each box per ray instead (docs/performance.md#packet-intervals).
fn is_loose(packet: PacketInterval) -> bool {
    return packet.unbounded || any((packet.inverse_lo < vec3<f32>(0.0)) & (packet.inverse_hi > vec3<f32>(0.0)));
}

// The earlier of two box entries, either of which may be NO_HIT.
fn earliest(a: real, b: real) -> real {
    return select(select(smaller(a, b), b, a == NO_HIT), a, b == NO_HIT);
}

// The earliest of the lanes' entries into the two boxes of a visit (each NO_HIT where no ray
// enters), rounded down to f32 for the packet's butterflies: an entry a little early only orders
// and culls less.
fn packet_earliest(lane_t0: real, lane_t1: real) -> vec2<real> {
    let none = vec2<real>(real(F32_MAX));
    let lanes = select(vec2<real>(lane_t0, lane_t1), none, vec2<real>(lane_t0, lane_t1) == vec2<real>(NO_HIT));
    let packet = vec2<real>(packet_min(f32_below(vec3<real>(lanes, real(F32_MAX)))).xy);
    return select(packet, vec2<real>(NO_HIT), packet >= none);
}

// Whether every ray of a packet tests the primitives of a leaf (`count`) the packet enters,
// rather than those whose own box test enters it: robust spheres, whose test costs about what
// a box test does and whose error is far below the boxes' growth, so it finds no hit its box
// would have skipped, and a box test first would cost what it saves. Not the textbook
// formulas, which do find such hits (docs/performance.md#bvh), nor the certainty pass, which
// records every test; nor triangles, whose test costs more (docs/performance.md#packet-intervals).
fn tests_every_ray(count: u32) -> bool {
#if ROBUST
#if !CERTAINTY
    return (count & SPHERE_LEAF) != 0u;
#endif
#endif
    return false;
}

// Whether a ray tests the primitives of the leaf child (box `lo`, `hi`, `count`) of a visit
// that its packet enters.
fn enters_leaf(lo: vec4<u32>, hi: vec4<u32>, count: u32, traced: Traced, min_t: real, t_max: real) -> bool {
    return tests_every_ray(count) || box_entry(bitcast<vec3<f32>>(lo.xyz), bitcast<vec3<f32>>(hi.xyz), traced.ray, traced.inverse, min_t, t_max) != NO_HIT;
}

// Packet traversal of LANE_RAYS rays a lane (Variant::lane_rays): a packet of 8 LANE_RAYS
// rays, so each node and primitive is fetched once for that many. A visit tests the node's
// boxes once for the whole packet, against its rays' interval (interval_entry), and goes to
// the child the packet enters first; only a leaf the packet enters is tested per ray, each
// ray testing its primitives where it enters the leaf's box (enters_leaf). Each ray keeps its
// own nearest hit, so the answer is the per-ray traversal's. One box test per child for the
// whole packet, rather than each ray's and votes for the order, is what makes a visit cheap
// enough to share among many rays (docs/performance.md#packet-intervals).
fn traverse_bvh_lanes(rays: LaneRays, min_t: real, hits: ptr<function, LaneHits>) {
    var lane_interval = PacketInterval(vec3<f32>(F32_MAX), vec3<f32>(-F32_MAX), vec3<f32>(F32_MAX), vec3<f32>(-F32_MAX), false);
    var lane_cull: real = 0.0;
#each_ray
    let traced$r = traced(rays.r$r);
    var best$r = (*hits).h$r;
    lane_interval = join_intervals(lane_interval, ray_interval(traced$r.ray, traced$r.inverse));
    lane_cull = larger(lane_cull, cull_t(best$r));
    swap_rays();
#end_each
    var packet = packet_interval(lane_interval);
#if LIST_ORIGIN
    // The rays' one origin as one value rather than the butterflies' bounds of equal values:
    // the compiler then finds each plane's four products in interval_entry to be two
    // (docs/performance.md#ray-lists).
    let origin = listed_origin();
    packet.origin_lo = f32_below(origin);
    packet.origin_hi = f32_above(origin);
#endif
    let loose = is_loose(packet);
    var cull = packet_cull(lane_cull);
    var stack_low = vec4<u32>(0u);
    var stack_high = 0u;
    var sp = 0u;
    var node = 0u;
    loop {
        let w = fetch_shared(node);
        var t0: real;
        var t1: real;
        if (loose) {
            // Each ray's own box tests, and the earliest entry of any ray into each box.
            var lane_t0 = NO_HIT;
            var lane_t1 = NO_HIT;
#each_ray
            let visit$r = visit_parts(w.q0, w.q1, w.q2, w.q3, traced$r.ray, traced$r.inverse, min_t, cull_t(best$r));
            swap_rays();
            lane_t0 = earliest(lane_t0, visit$r.t0);
            lane_t1 = earliest(lane_t1, visit$r.t1);
#end_each
            let entries = packet_earliest(lane_t0, lane_t1);
            t0 = entries.x;
            t1 = entries.y;
        } else {
            t0 = interval_entry(bitcast<vec3<f32>>(w.q0.xyz), bitcast<vec3<f32>>(w.q1.xyz), packet, min_t, cull);
            t1 = interval_entry(bitcast<vec3<f32>>(w.q2.xyz), bitcast<vec3<f32>>(w.q3.xyz), packet, min_t, cull);
        }
        let n = Visit(t0, t1, w.q0.w, w.q1.w, w.q2.w, w.q3.w);
        let leaf0 = (n.reference0 & LEAF_BIT) != 0u;
        let leaf1 = (n.reference1 & LEAF_BIT) != 0u;
        let run = leaf_run(n, leaf0 && t0 != NO_HIT, leaf1 && t1 != NO_HIT);
        if (run.length != 0u) {
#each_ray
            let leaf_cull$r = cull_t(best$r);
            let enters$r_0 = run.length0 != 0u && enters_leaf(w.q0, w.q1, n.count0, traced$r, min_t, leaf_cull$r);
            let enters$r_1 = run.length != run.length0 && enters_leaf(w.q2, w.q3, n.count1, traced$r, min_t, leaf_cull$r);
            swap_rays();
#end_each
            for (var i = 0u; i < run.length; i++) {
                let second = in_leaf1(run, i);
                let k = run_primitive(run, i);
                let count = select(n.count0, n.count1, second);
                let leaf = leaf_object(count);
                // Whether any of the lane's rays wants primitive k.
                var wanted = false;
#each_ray
                let wanted$r = select(enters$r_0, enters$r_1, second);
                wanted = wanted || wanted$r;
#end_each
                if (!loads_primitive(wanted)) {
                    continue;
                }
                if ((count & SPHERE_LEAF) != 0u) {
#if SPHERES
                    let sphere = lane_sphere(k);
#each_ray
                    test_sphere(traced$r.ray, sphere, min_t, k, leaf, wanted$r, &best$r);
                    swap_rays();
#end_each
#endif
                } else {
#if TRIANGLES
                    let tri = lane_triangle(k);
#each_ray
                    test_triangle(traced$r.ray, traced$r.shear, tri, min_t, k, leaf, wanted$r, &best$r);
                    swap_rays();
#end_each
#endif
                }
            }
            lane_cull = 0.0;
#each_ray
            lane_cull = larger(lane_cull, cull_t(best$r));
            swap_rays();
#end_each
            cull = packet_cull(lane_cull);
        }
        let go0 = t0 != NO_HIT && !leaf0 && t0 <= cull;
        let go1 = t1 != NO_HIT && !leaf1 && t1 <= cull;
        if (!packet_step(go0, go1, t0 <= t1, n.reference0, n.reference1, &stack_low, &stack_high, &sp, &node)) {
            break;
        }
    }
#each_ray
    (*hits).h$r = best$r;
#end_each
}
#endif
#endif
#if RAY_BY_RAY
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
#endif
