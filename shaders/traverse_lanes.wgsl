// Packet traversal of several rays a lane (LANES, Variant::lane_rays): a packet of 8 LANE_RAYS
// rays, which tests each node's boxes once against the interval of its rays
// (traverse_bvh_lanes). CPU mirror of the intervals (tests): src/cpu/traverse.rs.
#import types
#import bindings
#import hit
#import traverse
#import traverse_packet

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
        let leaf0 = is_leaf(n.reference0);
        let leaf1 = is_leaf(n.reference1);
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
