// Packet traversal (PACKETS): the rays of a subgroup walk the BVH together, one ray a lane,
// each node and primitive fetched once for all of them (traverse_bvh_packet), and what the
// traversal of several rays a lane (traverse_lanes.wgsl) builds on: the shared fetches, the
// packet's votes and its stack in registers. Each ray's answer is the per-ray traversal's, so
// its CPU mirror is that one's (src/cpu/traverse.rs).
#import types
#import bindings
#import hit
#import traverse

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
        let leaf0 = is_leaf(n.reference0);
        let leaf1 = is_leaf(n.reference1);
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
