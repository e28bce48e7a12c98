// Closest-point query (CLOSEST, ray lists whose origins are the query points): for each point
// the nearest point on any primitive, planes by brute force and the rest through the BVH where
// there is one, the nearer box first, boxes farther than the best so far skipped. A candidate's
// Hit holds its squared distance in `t`, so that is_closer's order decides (ties by object id,
// then the scene's order), whatever order the boxes are visited in. CPU mirror:
// src/cpu/closest.rs.
#import types
#import bindings
#import hit
#import nearest
#if BVH
#import traverse
#endif

// The point of a primitive nearest a query point, and its barycentric (u, v) on a triangle
// (the point is (1 - u - v) a + u b + v c; 0 on spheres and planes).
struct Closest {
    point: vec3<real>,
    uv: vec2<real>,
}

// a / b for b > 0, else 0: a degenerate triangle's ratios, which would be 0 / 0.
fn ratio(a: real, b: real) -> real {
    if (b > 0.0) {
        return a / b;
    }
    return 0.0;
}

// The point of `tri` nearest `p`, by the Voronoi region of the triangle `p` projects into
// (corner, edge or face; Ericson, Real-Time Collision Detection, 5.1.5). A triangle with no
// area answers from its corners and edges, or corner a.
fn closest_on_triangle(p: vec3<real>, tri: Triangle) -> Closest {
    let ab = tri.b - tri.a;
    let ac = tri.c - tri.a;
    let ap = p - tri.a;
    let d1 = dot(ab, ap);
    let d2 = dot(ac, ap);
    if (d1 <= 0.0 && d2 <= 0.0) {
        return Closest(tri.a, vec2<real>(0.0, 0.0));
    }
    let bp = p - tri.b;
    let d3 = dot(ab, bp);
    let d4 = dot(ac, bp);
    if (d3 >= 0.0 && d4 <= d3) {
        return Closest(tri.b, vec2<real>(1.0, 0.0));
    }
    let vc = d1 * d4 - d3 * d2;
    if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) {
        let v = ratio(d1, d1 - d3);
        return Closest(tri.a + ab * v, vec2<real>(v, 0.0));
    }
    let cp = p - tri.c;
    let d5 = dot(ab, cp);
    let d6 = dot(ac, cp);
    if (d6 >= 0.0 && d5 <= d6) {
        return Closest(tri.c, vec2<real>(0.0, 1.0));
    }
    let vb = d5 * d2 - d1 * d6;
    if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) {
        let w = ratio(d2, d2 - d6);
        return Closest(tri.a + ac * w, vec2<real>(0.0, w));
    }
    let va = d3 * d6 - d5 * d4;
    let e4 = d4 - d3;
    let e5 = d5 - d6;
    if (va <= 0.0 && e4 >= 0.0 && e5 >= 0.0) {
        let w = ratio(e4, e4 + e5);
        return Closest(tri.b + (tri.c - tri.b) * w, vec2<real>(1.0 - w, w));
    }
    let sum = va + vb + vc;
    let v = ratio(vb, sum);
    let w = ratio(vc, sum);
    return Closest(tri.a + ab * v + ac * w, vec2<real>(v, w));
}

// The squared distance from `p` to its closest point on `tri`.
fn triangle_distance2(p: vec3<real>, tri: Triangle) -> real {
    let e = p - closest_on_triangle(p, tri).point;
    return dot(e, e);
}

#if SPHERES
// The point of sphere `s` nearest `p` (from its centre, any point: +x).
fn closest_on_sphere(p: vec3<real>, s: Sphere) -> Closest {
    let d = p - s.center;
    let r = length(d);
    var direction = vec3<real>(1.0, 0.0, 0.0);
    if (r > 0.0) {
        direction = d / r;
    }
    return Closest(s.center + direction * s.radius, vec2<real>(0.0));
}

// The squared distance from `p` to sphere `s`, from the distance to its centre (closer to the
// truth than the distance to the rounded closest point).
fn sphere_distance2(p: vec3<real>, s: Sphere) -> real {
    let h = length(p - s.center) - s.radius;
    return h * h;
}
#endif

#if PLANES
// The signed height of `p` above plane `pl`.
fn plane_height(p: vec3<real>, pl: Plane) -> real {
    return dot(p - pl.point, pl.normal);
}
#endif

// The primitive nearest `p`: its Hit, `t` its squared distance (object -1 where there is none).
fn closest_to(p: vec3<real>) -> Hit {
    var best = Hit(T_FAR, -1, 0u, 0u);
#if PLANES
    for (var k = 0u; k < plane_count(); k++) {
        let h = plane_height(p, planes[k]);
        keep(h * h, KIND_PLANE, k, params.sphere_count, &best);
    }
#endif
#if BVH
    closest_in_bvh(p, &best);
#else
#if SPHERES
    for (var k = 0u; k < params.sphere_count; k++) {
        keep(sphere_distance2(p, sphere_at(k)), KIND_SPHERE, k, 0u, &best);
    }
#endif
#if TRIANGLES
    let base = params.sphere_count + params.plane_count;
    for (var k = 0u; k < params.triangle_count; k++) {
        keep(triangle_distance2(p, triangle_at(k)), KIND_TRIANGLE, k, base, &best);
    }
#endif
#endif
    return best;
}

// The closest point of `hit`'s primitive to `p`, computed once for the winner.
fn closest_details(p: vec3<real>, hit: Hit) -> Closest {
    switch (hit.kind) {
#if SPHERES
        case KIND_SPHERE: {
            return closest_on_sphere(p, sphere_at(hit.index));
        }
#endif
#if PLANES
        case KIND_PLANE: {
            let pl = planes[hit.index];
            return Closest(p - pl.normal * plane_height(p, pl), vec2<real>(0.0));
        }
#endif
#if TRIANGLES
        case KIND_TRIANGLE: {
            return closest_on_triangle(p, triangle_at(hit.index));
        }
#endif
        default: {
            return Closest(p, vec2<real>(0.0));
        }
    }
}

#if BVH
// The squared distance from `p` to the box `lo`..`hi` (0 inside it).
fn box_distance2(p: vec3<real>, lo: vec3<f32>, hi: vec3<f32>) -> real {
    let d = max(max(vec3<real>(lo) - p, vec3<real>(0.0)), p - vec3<real>(hi));
    return dot(d, d);
}

// Whether a box at squared distance `d2` may hold a point as close as the best so far: `d2`
// shrunk by 4 BOX_SLACK (2^-14), far above its rounding error, so that no box holding the
// closest point or a tie is skipped.
fn may_hold(d2: real, best: Hit) -> bool {
    return d2 - d2 * (4.0 * BOX_SLACK) <= best.t;
}

// Tests the `count` primitives of a leaf from `first` against `p`.
fn closest_in_leaf(p: vec3<real>, first: u32, count: u32, best: ptr<function, Hit>) {
    let n = leaf_len(count);
    let leaf = leaf_object(count);
    if ((count & SPHERE_LEAF) != 0u) {
#if SPHERES
        for (var k = first; k < first + n; k++) {
            keep_ordered(sphere_distance2(p, sphere_at(k)), KIND_SPHERE, k, 0u, leaf, best);
        }
#endif
    } else {
#if TRIANGLES
        let base = params.sphere_count + params.plane_count;
        for (var k = first; k < first + n; k++) {
            keep_ordered(triangle_distance2(p, triangle_at(k)), KIND_TRIANGLE, k, base, leaf, best);
        }
#endif
    }
}

// Nearest-first traversal: of a node's two children, leaves that may hold a closer point are
// tested at once and the nearer inner node is visited first, the other waiting on the stack
// with its squared distance, skipped when popped if the best has come closer than that.
fn closest_in_bvh(p: vec3<real>, best: ptr<function, Hit>) {
    var stack_node: array<u32, BVH_STACK>;
    var stack_d2: array<real, BVH_STACK>;
    var sp = 0u;
    var node = 0u;
    loop {
        let w = node_words(node);
        let q0 = w.q0;
        let q1 = w.q1;
        let q2 = w.q2;
        let q3 = w.q3;
        let d0 = box_distance2(p, bitcast<vec3<f32>>(q0.xyz), bitcast<vec3<f32>>(q1.xyz));
        let d1 = box_distance2(p, bitcast<vec3<f32>>(q2.xyz), bitcast<vec3<f32>>(q3.xyz));
        let leaf0 = is_leaf(q0.w);
        let leaf1 = is_leaf(q2.w);
        if (leaf0 && may_hold(d0, *best)) {
            closest_in_leaf(p, q0.w & ~LEAF_BIT, q1.w, best);
        }
        if (leaf1 && may_hold(d1, *best)) {
            closest_in_leaf(p, q2.w & ~LEAF_BIT, q3.w, best);
        }
        let go0 = !leaf0 && may_hold(d0, *best);
        let go1 = !leaf1 && may_hold(d1, *best);
        if (go0 && go1) {
            let first0 = d0 <= d1;
            stack_node[sp] = select(q0.w, q2.w, first0);
            stack_d2[sp] = select(d0, d1, first0);
            sp++;
            node = select(q2.w, q0.w, first0);
        } else if (go0) {
            node = q0.w;
        } else if (go1) {
            node = q2.w;
        } else {
            var next = false;
            while (sp > 0u) {
                sp--;
                if (may_hold(stack_d2[sp], *best)) {
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
