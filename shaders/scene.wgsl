// Nearest-hit search: over every primitive (brute force), or the planes by brute force and the
// rest through the BVH (BVH; shaders/bvh.wgsl). CPU mirror: src/cpu/scene.rs.
#import types
#import bindings
#import hit
#if BVH
#import bvh
#endif
#if SPHERES
#import sphere
#endif
#if PLANES
#import plane
#endif
#if TRIANGLES
#import triangle
#endif

#if CERTAINTY
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
}

var<private> certainty: Certainty;

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
    if (best.object < 0) {
        return certainty.all_misses_certain;
    }
    if (!certainty.any_certain_hit || !certainty.best_certain) {
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
#endif

fn nearest_hit(ray: Ray, min_t: real) -> Hit {
    var best = Hit(T_FAR, -1, 0u, 0u);
#if CERTAINTY
    let none = Decision(T_FAR, -1, 1.0);
    certainty = Certainty(false, true, false, 1.0, none, none, none);
#endif
#if SPHERES
#if !BVH
    for (var k = 0u; k < params.sphere_count; k++) {
        let t = intersect_sphere(ray, spheres[k], min_t);
        let object = objects[k];
        let closer = is_closer(t, object, k, best);
#if CERTAINTY
        record(t, object, closer, best);
#endif
        if (closer) {
            best = Hit(t, i32(object), KIND_SPHERE, k);
        }
    }
#endif
#endif
    let plane_base = params.sphere_count;
#if PLANES
    for (var k = 0u; k < params.plane_count; k++) {
        let t = intersect_plane(ray, planes[k], min_t);
        let object = objects[plane_base + k];
        let closer = is_closer(t, object, k, best);
#if CERTAINTY
        record(t, object, closer, best);
#endif
        if (closer) {
            best = Hit(t, i32(object), KIND_PLANE, k);
        }
    }
#endif
    let triangle_base = plane_base + params.plane_count;
#if TRIANGLES
#if !BVH
    for (var k = 0u; k < params.triangle_count; k++) {
        let t = intersect_triangle(ray, triangle_at(k), min_t);
        let object = objects[triangle_base + k];
        let closer = is_closer(t, object, k, best);
#if CERTAINTY
        record(t, object, closer, best);
#endif
        if (closer) {
            best = Hit(t, i32(object), KIND_TRIANGLE, k);
        }
    }
#endif
#endif
#if BVH
    traverse_bvh(ray, min_t, &best);
#endif
    return best;
}

// The normal of the nearest hit, computed once rather than for every candidate.
fn hit_normal(ray: Ray, hit: Hit) -> vec3<real> {
    switch (hit.kind) {
#if SPHERES
        case KIND_SPHERE: {
            return sphere_normal(ray, hit.t, spheres[hit.index]);
        }
#endif
#if PLANES
        case KIND_PLANE: {
            return plane_normal(planes[hit.index]);
        }
#endif
#if TRIANGLES
        case KIND_TRIANGLE: {
            return triangle_normal(triangle_at(hit.index));
        }
#endif
        default: {
            return vec3<real>(0.0);
        }
    }
}
