// The certainty test of adaptive precision's first pass (CERTAINTY): whether a pixel's hit/miss
// and nearest object are those of exact arithmetic. CPU counterpart: src/cpu/margin.rs, which
// derives the same bounds in f64 (it judges margins, it does not mirror this pass).
#import types
#import hit

// Each robust intersect_* function records here whether the decision it just made (hit or
// miss) is certain, where it hits or would hit, and the condition factor of that t.
var<private> decision_certain: bool;
var<private> decision_t: real;
var<private> decision_t_condition: real;

// Safety factor over the first-order error bounds.
const MARGIN_K: real = 2.0;

// The first-order bounds below assume that no operation overflowed or underflowed. Overflow
// leaves an infinity or a NaN in what is tested, so every test requires finite operands (a
// NaN fails every comparison). Underflow (or a driver flushing subnormals to zero) loses at
// most the smallest normal f32, 2^-126, per operation; the few dozen operations behind one
// tested quantity lose less than UNDERFLOW_SLACK = 2^-120, added to every bound.
const UNDERFLOW_SLACK: real = 7.52316384526264e-37;

// 2^-120: a direction component at least this large has an inverse well within range.
const SMALLEST_INVERTIBLE: real = 7.52316384526264e-37;

// Finite and within the f32 range: neither an overflow nor a NaN (which fails both tests).
fn is_finite_real(x: real) -> bool {
    return abs(x) <= T_FAR;
}

// Records the decision an intersect_* function made. A t or condition factor that overflowed
// or is NaN says nothing of where the exact hit lies: the decision is then uncertain, and kept
// at t = 0, nearer than any hit, so that it makes the pixel uncertain whatever else it meets.
fn decide(certain: bool, t: real, t_condition: real) {
    let known = is_finite_real(t) && is_finite_real(t_condition);
    decision_certain = certain && known;
    decision_t = select(0.0, t, known);
    decision_t_condition = select(1.0, t_condition, known);
}

// |q| exceeds MARGIN_K times its first-order error bound EPS * scale (plus the underflow
// slack): its sign is certain.
fn is_certain(q: real, scale: real) -> bool {
    return is_finite_real(scale) && abs(q) >= MARGIN_K * (EPS * scale + UNDERFLOW_SLACK);
}

// Bound on the error of a computed t with condition factor `c`, relative to |t|.
fn t_error(c: real) -> real {
    return EPS * (16.0 + 8.0 * MARGIN_K * c);
}

// The largest coordinate of a ray's origin (kernel coordinates): a corner or centre stored in
// f32 is off by up to EPS times its own size, which is at most its size relative to the origin
// plus this (0 for a camera's rays, which start at the kernel's origin). The bounds of
// triangle.wgsl and sphere.wgsl, relative to the origin, add it. In an instance's mesh the
// origin is also off by what moving it there rounded (placed_origin).
fn origin_size(ray: Ray) -> real {
#if INSTANCES
    return max_component(ray.origin) + placed_origin;
#else
    return max_component(ray.origin);
#endif
}
#if INSTANCES

// A ray moved into an instance's mesh (instance_ray) carries the rounding of that move, which
// exact arithmetic on the placed mesh does not: each component of its origin is off by up to
// EPS placed_origin, and its shear (the direction's two smaller components over its largest)
// by up to EPS placed_skew, which shifts a sheared corner by EPS placed_skew |z| (triangle.wgsl's
// edge_scales). Both 0 in the world's coordinates.
var<private> placed_origin: real;
var<private> placed_skew: real;

// The most a placed ray's shear may be off, relative: 2^-17, 4x below the slack of the box test
// (BOX_ENTRY_SHRINK), so that the mesh's boxes still cull only what the exact ray misses.
const PLACED_SKEW_LIMIT: real = 7.62939453125e-6;

// The rounding `placed` (`world` moved into `instance`'s mesh) carries: each of its components
// is a dot product of a stored row, itself rounded once, with the world ray's, so off by up to
// 2 EPS (four roundings of EPS / 2) times the sum of its terms' magnitudes. The shear's error
// is at most twice the largest direction component's over the largest. Where that exceeds
// PLACED_SKEW_LIMIT, nothing in the instance is certain: an uncertain miss of its object at 0,
// nearer than any hit, leaves the pixel uncertain unless its nearest hit is this instance's.
fn place_certainty(world: Ray, placed: Ray, instance: Instance, best: Hit) {
    let d = abs(world.direction);
    let o = abs(world.origin);
    let r0 = abs(instance.r0);
    let r1 = abs(instance.r1);
    let r2 = abs(instance.r2);
    let spread = vec3<real>(dot(r0.xyz, d), dot(r1.xyz, d), dot(r2.xyz, d));
    let reach = vec3<real>(dot(r0.xyz, o) + r0.w, dot(r1.xyz, o) + r1.w, dot(r2.xyz, o) + r2.w);
    placed_skew = 4.0 * max_component(spread) / max_component(placed.direction);
    placed_origin = 2.0 * max_component(reach);
    if (!(placed_skew * EPS <= PLACED_SKEW_LIMIT) || !is_finite_real(placed_origin)) {
        decide(false, 0.0, 1.0);
        record(NO_HIT, instance.object, false, best);
    }
}

// Back in the world's coordinates.
fn unplace_certainty() {
    placed_origin = 0.0;
    placed_skew = 0.0;
}
#endif

// The conservative start test decides as exact arithmetic would.
fn start_certain(t: real, min_t: real, t_condition: real) -> bool {
    return is_finite_real(t) && is_finite_real(t_condition)
        && abs(t - min_t) >= t_error(t_condition) * abs(t) + UNDERFLOW_SLACK;
}

// Two hits are certainly in this order.
fn gap_certain(t1: real, c1: real, t2: real, c2: real) -> bool {
    return is_finite_real(t1) && is_finite_real(t2)
        && abs(t2 - t1) >= t_error(max(c1, c2)) * (abs(t1) + abs(t2)) + UNDERFLOW_SLACK;
}

// A decision kept for the certainty test: where, for which object, how well conditioned.
struct Decision {
    t: real,
    object: i32,          // -1: none
    t_condition: real,
}

// What the certainty test needs of all decisions of a pixel (CPU mirror: margins_of in
// src/cpu/margin.rs): whether some hit is certain, whether every miss is, the nearest hit's
// certainty, the nearest hit of another object, and the two nearest uncertain misses of
// different objects (one of them is of another object than the final nearest hit).
struct Certainty {
    any_certain_hit: bool,
    all_misses_certain: bool,
    best_certain: bool,
    best_condition: real,
    second: Decision,
    miss1: Decision,
    miss2: Decision,
    // The smallest distance beyond which the BVH traversal skipped boxes (cull_bound).
    cull_floor: real,
    // The ray's direction has no component so small (and not zero) that its inverse, used by
    // the box test, overflows.
    ray_invertible: bool,
}

var<private> certainty: Certainty;
#if LANES
// With two rays a lane (certainty kernels cast two: Variant::lane_rays) the record of the ray
// not being worked on: swap_certainty() exchanges the two after work on each (swap_rays).
var<private> certainty_other: Certainty;

fn swap_certainty() {
    let held = certainty;
    certainty = certainty_other;
    certainty_other = held;
}
#endif

// Resets the pixel's certainty state before the nearest-hit search of `ray`.
fn start_certainty(ray: Ray) {
    let none = Decision(T_FAR, -1, 1.0);
    let d = abs(ray.direction);
    let invertible = all((d == vec3<real>(0.0)) | (d >= vec3<real>(SMALLEST_INVERTIBLE)));
    certainty = Certainty(false, true, false, 1.0, none, none, none, T_FAR, invertible);
#if INSTANCES
    unplace_certainty();
#endif
}

// Keeps `d` if it is nearer than `first` or `second`, `first` and `second` being of
// different objects.
fn keep_two(d: Decision, first: ptr<function, Decision>, second: ptr<function, Decision>) {
    if ((*first).object < 0 || d.t < (*first).t) {
        if (d.object != (*first).object) {
            *second = *first;
        }
        *first = d;
    } else if (d.object != (*first).object && ((*second).object < 0 || d.t < (*second).t)) {
        *second = d;
    }
}

// Records the decision the last intersect_* call made, before `best` is updated.
fn record(t: real, object: u32, closer: bool, best: Hit) {
    let d = Decision(decision_t, i32(object), decision_t_condition);
    if (t == NO_HIT) {
        certainty.all_misses_certain = certainty.all_misses_certain && decision_certain;
        if (!decision_certain) {
            var m1 = certainty.miss1;
            var m2 = certainty.miss2;
            keep_two(d, &m1, &m2);
            certainty.miss1 = m1;
            certainty.miss2 = m2;
        }
        return;
    }
    certainty.any_certain_hit = certainty.any_certain_hit || decision_certain;
    var first = Decision(best.t, best.object, certainty.best_condition);
    var second = certainty.second;
    keep_two(d, &first, &second);
    certainty.second = second;
    if (closer) {
        certainty.best_certain = decision_certain;
        certainty.best_condition = decision_t_condition;
    }
}

// Whether the pixel's hit/miss and nearest object are certain.
fn is_pixel_certain(best: Hit) -> bool {
    if (!certainty.ray_invertible) {
        return false;
    }
    if (best.object < 0) {
        return certainty.all_misses_certain;
    }
    if (!certainty.any_certain_hit || !certainty.best_certain) {
        return false;
    }
    // A box skipped by the traversal may hold an object the exact nearest hit belongs to.
    if (t_upper(best.t, certainty.best_condition) > certainty.cull_floor) {
        return false;
    }
    let second = certainty.second;
    if (second.object >= 0 && second.object != best.object
        && !gap_certain(best.t, certainty.best_condition, second.t, second.t_condition)) {
        return false;
    }
    var miss = certainty.miss1;
    if (miss.object == best.object) {
        miss = certainty.miss2;
    }
    if (miss.object >= 0) {
        // An uncertain miss that might turn into a hit before the nearest one.
        if (miss.t <= best.t || !gap_certain(best.t, certainty.best_condition, miss.t, miss.t_condition)) {
            return false;
        }
    }
    return true;
}

// An upper bound of the exact t of a hit computed as `t` with condition factor `c`: t plus its
// error bound as in start_certain.
fn t_upper(t: real, c: real) -> real {
    return t + t_error(c) * abs(t);
}

// How far the BVH traversal must search beyond the nearest hit so far for the certainty test
// to see every object that could be nearer in exact arithmetic: a box whose entry lies beyond
// t_upper of the nearest hit holds nothing the exact search would find first. Records the bound
// as used; a nearest hit found later with a larger bound makes the pixel uncertain
// (is_pixel_certain), since boxes skipped before may then matter.
fn cull_bound(best: Hit) -> real {
    if (best.object < 0) {
        return best.t;
    }
    let bound = t_upper(best.t, certainty.best_condition);
    certainty.cull_floor = min(certainty.cull_floor, bound);
    return bound;
}
